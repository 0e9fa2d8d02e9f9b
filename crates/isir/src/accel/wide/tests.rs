//! Tests of the wide BVH. Test fixtures build meshes through the course types above
//! the seam (the only imports upward, in tests only).

use super::collapse::*;
use super::*;
use crate::accel::Accel;
use crate::geometry::{MeshAccel, TriangleMesh};
use rand::{Rng, SeedableRng};

/// Random small triangles in a cube, a few of them degenerate.
fn random_mesh(n: usize, seed: u64) -> TriangleMesh {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    let mut vertices = Vec::new();
    for i in 0..n {
        let c = Vec3::new(rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0));
        let mut v = || c + Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let (a, b) = (v(), v());
        // Every 50th triangle has two equal vertices: zero area, left out.
        let c2 = if i % 50 == 0 { b } else { v() };
        vertices.extend([a, b, c2]);
    }
    let triangles = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    TriangleMesh::new(vertices, Vec::new(), triangles)
}

/// The SAH cost of a wide tree as the plan counts it: wide nodes and leaves by the
/// half area of their box.
fn wide_sah_cost(w: &WideBvh, root_area: f32) -> f32 {
    let lane_area = |n: &Node8, lane: usize| {
        crate::math::aabb::Aabb::new(
            Vec3::new(n.lo[0][lane], n.lo[1][lane], n.lo[2][lane]),
            Vec3::new(n.hi[0][lane], n.hi[1][lane], n.hi[2][lane]),
        )
        .half_area()
    };
    let mut cost = if w.root & LEAF == 0 { root_area * WIDE_NODE_COST } else { root_area * leaf_blocks(w.root).len() as f32 };
    for n in &w.nodes {
        for (lane, &code) in n.child.iter().enumerate().filter(|(_, &c)| c != EMPTY) {
            let per_area = if code & LEAF == 0 { WIDE_NODE_COST } else { leaf_blocks(code).len() as f32 };
            cost += lane_area(n, lane) * per_area;
        }
    }
    cost
}

/// The SAH cost of the greedy collapse (each wide node opens its largest interior
/// child until it has eight), the one the plan replaced.
fn greedy_cost(bvh: &Bvh, index: usize) -> f32 {
    let node = &bvh.nodes[index];
    let area = |k: usize| bvh.nodes[k].aabb().half_area();
    if node.is_leaf() {
        return area(index) * node.count.div_ceil(4) as f32;
    }
    let first = node.left_first as usize;
    let mut kids = vec![first, first + 1];
    while kids.len() < 8 {
        let open = kids.iter().enumerate().filter(|(_, &k)| !bvh.nodes[k].is_leaf()).max_by(|a, b| area(*a.1).total_cmp(&area(*b.1)));
        let Some((i, &k)) = open else { break };
        let c = bvh.nodes[k].left_first as usize;
        kids[i] = c;
        kids.push(c + 1);
    }
    area(index) * WIDE_NODE_COST + kids.iter().map(|&k| greedy_cost(bvh, k)).sum::<f32>()
}

#[test]
fn the_collapse_builds_the_planned_tree_and_beats_the_greedy_one() {
    for (n, seed) in [(3, 1), (40, 2), (5_000, 3), (20_000, 4)] {
        let mesh = random_mesh(n, seed);
        let valid: Vec<u32> = (0..n as u32).filter(|i| i % 50 != 0).collect();
        let bvh = Bvh::build_sah(&valid, |i| {
            let [a, b, c] = mesh.triangle_vertices(i);
            crate::math::aabb::Aabb::new(a.min(b).min(c), a.max(b).max(c))
        });
        let plan = Plan::new(&bvh);
        let w = WideBvh::from_bvh(&bvh, &mesh).expect("a small tree");
        let root_area = bvh.nodes[0].aabb().half_area();
        let built = wide_sah_cost(&w, root_area);
        assert!((built - plan.cost).abs() <= 1e-4 * plan.cost, "{n} triangles: built {built}, planned {}", plan.cost);
        assert!((w.sah_cost() * root_area - built).abs() <= 1e-4 * built, "{n} triangles: reported {}", w.sah_cost());
        let greedy = greedy_cost(&bvh, 0);
        assert!(plan.cost <= greedy * (1.0 + 1e-5), "{n} triangles: planned {} > greedy {greedy}", plan.cost);
        if n >= 5_000 {
            assert!(plan.cost < 0.99 * greedy, "{n} triangles: planned {} not below greedy {greedy}", plan.cost);
        }
    }
}

/// Rays starting on a triangle (t = 0) that lies on a face of its leaf's box: the ULP
/// widening must keep the box when its far distance is -0.0 (origin x -0.0, going
/// down x out of the box) and its near one +0.0.
#[test]
fn rays_starting_on_an_axis_aligned_triangle_hit_it_at_zero_on_every_level() {
    // A triangle in the plane x = 0 with one at x = 0.5 beside it (one leaf, its box
    // from x = 0 to 0.5), and far ones so the tree has inner nodes.
    let vertices = vec![
        Vec3::new(0.0, -1.0, -1.0),
        Vec3::new(0.0, 1.0, -1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(0.5, 2.0, 2.0),
        Vec3::new(0.5, 3.0, 2.0),
        Vec3::new(0.5, 2.0, 3.0),
    ];
    let mut vertices = vertices;
    let mut rng = rand_pcg::Pcg32::seed_from_u64(5);
    for _ in 0..60 {
        let c = Vec3::new(rng.random_range(5.0..20.0), rng.random_range(-5.0..5.0), rng.random_range(-5.0..5.0));
        vertices.extend([c, c + Vec3::X, c + Vec3::Y]);
    }
    let triangles = (0..vertices.len() as u32 / 3).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    let mut mesh = TriangleMesh::new(vertices, Vec::new(), triangles);
    mesh.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
    assert!(w.root & LEAF == 0, "the test needs box tests");
    let mut checked = 0;
    for ox in [0.0f32, -0.0] {
        for dx in [1.0f32, -1.0, 1e-3, -1e-3] {
            for t_min in [0.0f32, -0.0] {
                let ray = Ray::new(Vec3::new(ox, 0.0, 0.0), Vec3::new(dx, 0.25, 0.5));
                let want = mesh.intersect_brute_force(&ray, t_min, f32::INFINITY);
                assert!(want.is_some_and(|h| h.t == 0.0 && h.prim == 0), "brute force hits triangle 0 at t = 0");
                for level in SimdLevel::available() {
                    let mut w = w.clone();
                    w.set_level(level);
                    let got = w.intersect(&ray, t_min, f32::INFINITY);
                    assert_eq!(got.map(|h| (h.t, h.prim)), Some((0.0, 0)), "{level:?}, origin x {ox:?}, dx {dx:?}, t_min {t_min:?}");
                    assert!(w.occluded(&ray, t_min, f32::INFINITY));
                    checked += 1;
                }
            }
        }
    }
    assert!(checked >= 32);
}

#[test]
fn collapsed_nodes_bound_their_children_in_decreasing_area_order() {
    let mut mesh = random_mesh(20_000, 9);
    mesh.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
    let lane_box = |n: &Node8, lane: usize| {
        crate::math::aabb::Aabb::new(
            Vec3::new(n.lo[0][lane], n.lo[1][lane], n.lo[2][lane]),
            Vec3::new(n.hi[0][lane], n.hi[1][lane], n.hi[2][lane]),
        )
    };
    let contains = |outer: &crate::math::aabb::Aabb, p: Vec3| outer.min.cmple(p).all() && outer.max.cmpge(p).all();
    let mut seen = vec![0u32; 20_000];
    for node in &w.nodes {
        let used = node.child.iter().take_while(|&&c| c != EMPTY).count();
        assert!(used >= 2 && node.child[used..].iter().all(|&c| c == EMPTY), "children first: {:?}", node.child);
        for lane in 1..used {
            assert!(lane_box(node, lane - 1).half_area() >= lane_box(node, lane).half_area(), "lanes by decreasing area");
        }
        for lane in used..8 {
            assert!(lane_box(node, lane).min.x > lane_box(node, lane).max.x, "empty lanes hold an inverted box");
            assert_eq!(node.next[lane], EMPTY, "an empty lane has nothing to prefetch");
        }
        for lane in 0..used {
            let b = lane_box(node, lane);
            let code = node.child[lane];
            if code & LEAF == 0 {
                let kid = &w.nodes[code as usize / std::mem::size_of::<Node8>()];
                assert_eq!(node.next[lane], kid.child[0], "an inner child's next is its lane 0");
                for k in kid.child.iter().enumerate().filter(|(_, &c)| c != EMPTY).map(|(k, _)| k) {
                    let kb = lane_box(kid, k);
                    assert!(contains(&b, kb.min) && contains(&b, kb.max), "a child box outside its parent's lane");
                }
            } else {
                assert_eq!(node.next[lane], code, "a leaf's next is the leaf");
                for block in &w.tris[leaf_blocks(code)] {
                    for (l, &p) in block.prim.iter().enumerate().filter(|(_, &p)| p != EMPTY) {
                        seen[p as usize] += 1;
                        let v0 = Vec3::new(block.v0[0][l], block.v0[1][l], block.v0[2][l]);
                        assert!(mesh.triangle_vertices(p).iter().all(|&v| contains(&b, v)) && contains(&b, v0));
                    }
                }
            }
        }
    }
    for (p, &count) in seen.iter().enumerate() {
        assert_eq!(count, u32::from(p % 50 != 0), "triangle {p}: degenerate ones never, the others once");
    }
}

/// The build's records in the blocks' storage (`Bvh::build_sah_in`, then
/// `WideBvh::from_bvh_in`) give the tree of separate arrays, bit for bit: with the
/// storage the mesh build makes, one too small for the records (grown), one too small for
/// the blocks (replaced), and one holding an earlier tree's blocks.
#[test]
fn records_in_the_blocks_storage_give_the_same_tree() {
    let bits = |w: &WideBvh| {
        let nodes: Vec<u32> = w.nodes.iter().flat_map(|n| n.lo.iter().chain(&n.hi).flatten().map(|x| x.to_bits()).chain(n.child)).collect();
        let tris: Vec<u32> =
            w.tris.iter().flat_map(|t| t.v0.iter().chain(&t.e1).chain(&t.e2).flatten().map(|x| x.to_bits()).chain(t.prim)).collect();
        (w.root, nodes, tris)
    };
    for (n, seed) in [(1, 5), (40, 6), (20_000, 7)] {
        let mesh = random_mesh(n, seed);
        let valid: Vec<u32> = (0..n as u32).filter(|i| i % 50 != 0).collect();
        let box_of = |i: u32| {
            let [a, b, c] = mesh.triangle_vertices(i);
            crate::math::aabb::Aabb::new(a.min(b).min(c), a.max(b).max(c))
        };
        let want = bits(&WideBvh::from_bvh(&Bvh::build_sah(&valid, box_of), &mesh).expect("a small tree"));
        let earlier =
            WideBvh::from_bvh(&Bvh::build_sah(&(0..n as u32).rev().collect::<Vec<_>>(), box_of), &mesh).expect("a small tree").tris;
        for (label, storage) in [
            ("the mesh build's", WideBvh::block_storage(valid.len())),
            ("empty", Vec::new()),
            ("room for the records only", Vec::with_capacity(valid.len() / 5 + 1)),
            ("an earlier tree's", earlier),
        ] {
            let mut storage = storage;
            let bvh = Bvh::build_sah_in(&valid, box_of, &mut storage);
            assert!(storage.is_empty(), "{label}: the storage is left empty");
            let got = bits(&WideBvh::from_bvh_in(&bvh, &mesh, storage, MAX_NODES).expect("a small tree"));
            assert!(got == want, "{n} triangles, {label} storage: another tree");
        }
    }
}

/// A tree needing more wide nodes than its limit is refused whole ([`TooLarge`]), never
/// cut or wrongly numbered; at exactly the limit it is the same tree. The real limit
/// keeps every inner code a byte offset below `LEAF`.
#[test]
fn a_tree_over_the_node_limit_is_refused() {
    assert!(MAX_NODES * std::mem::size_of::<Node8>() <= LEAF as usize && MAX_NODES >= 8_000_000);
    let mesh = random_mesh(20_000, 8);
    let valid: Vec<u32> = (0..20_000).filter(|i| i % 50 != 0).collect();
    let bvh = Bvh::build_sah(&valid, |i| {
        let [a, b, c] = mesh.triangle_vertices(i);
        crate::math::aabb::Aabb::new(a.min(b).min(c), a.max(b).max(c))
    });
    let full = WideBvh::from_bvh(&bvh, &mesh).expect("a small tree");
    let n = full.node_count();
    assert!(n > 100, "{n} nodes");
    let exact = WideBvh::from_bvh_in(&bvh, &mesh, Vec::new(), n).expect("the limit holds the tree");
    assert_eq!((exact.root, exact.node_count(), exact.tris.len()), (full.root, n, full.tris.len()));
    for limit in [0, 1, n / 2, n - 1] {
        assert_eq!(WideBvh::from_bvh_in(&bvh, &mesh, Vec::new(), limit).err(), Some(TooLarge), "limit {limit}");
    }
    assert!(TooLarge.to_string().contains("8388608 nodes"), "{TooLarge}");
}

/// A mesh whose wide tree would be too large is traced by its binary SAH tree: the same
/// hits, the fallback in its figures and a warning; a rebuild (as `remove_overlaps`
/// does) asks for `bvh-sah` again.
#[test]
fn a_mesh_too_large_for_the_wide_tree_falls_back_to_the_binary_tree() {
    let mut wide = random_mesh(5_000, 11);
    wide.build_accel(Accel::BvhSah);
    assert!(matches!(wide.accel(), MeshAccel::Wide(_)) && !wide.stats().binary_fallback && wide.stats().warning().is_none());
    let mut binary = random_mesh(5_000, 11);
    binary.build_accel_within(Accel::BvhSah, 10);
    let MeshAccel::Bvh(bvh) = binary.accel() else { panic!("a binary tree") };
    let stats = binary.stats();
    assert!(stats.binary_fallback && stats.nodes == bvh.nodes.len() && stats.sah_cost == bvh.sah_cost());
    let warning = stats.warning().expect("a warning");
    assert!(warning.contains("5000 triangles") && warning.contains("binary SAH BVH"), "{warning}");
    let mut rng = rand_pcg::Pcg32::seed_from_u64(12);
    let (mut hits, mut blocked) = (0, 0);
    for _ in 0..2_000 {
        let o = Vec3::new(rng.random_range(-12.0..12.0), rng.random_range(-12.0..12.0), rng.random_range(-12.0..12.0));
        let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
        let ray = Ray::new(o, d);
        let t_max = rng.random_range(1.0..30.0);
        let (want, got) = (wide.intersect(&ray, 0.0, t_max), binary.intersect(&ray, 0.0, t_max));
        assert_eq!(got.map(|h| (h.t, h.u, h.v, h.prim)), want.map(|h| (h.t, h.u, h.v, h.prim)), "{ray:?}");
        assert_eq!(binary.occluded(&ray, 0.0, t_max), want.is_some());
        hits += usize::from(want.is_some());
        blocked += usize::from(binary.occluded(&ray, 0.0, t_max));
    }
    assert!(hits > 200 && hits < 1_900 && blocked == hits, "{hits} hits, {blocked} occluded");
    // A rebuild within the real limit gives the wide tree back.
    binary.build_accel(Accel::BvhSah);
    assert!(matches!(binary.accel(), MeshAccel::Wide(_)) && !binary.stats().binary_fallback);
}

/// Rays for the batch tests: from around and inside the cube of [`random_mesh`], with
/// intervals of every kind (negative `t_min`, short `t_max`) and a few invalid rays.
fn batch_rays(n: usize, seed: u64) -> Vec<crate::math::ray::RaySegment> {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    (0..n)
        .map(|i| {
            let mut p = || Vec3::new(rng.random_range(-14.0..14.0), rng.random_range(-14.0..14.0), rng.random_range(-14.0..14.0));
            let (origin, target) = (p(), p());
            let (t_min, t_max) = match i % 5 {
                0 => (-0.5, 0.5),
                1 => (0.0, 0.3),
                _ => (0.0, f32::INFINITY),
            };
            let direction = match i % 97 {
                0 => Vec3::ZERO,
                1 => Vec3::new(f32::NAN, 1.0, 0.0),
                _ => target - origin,
            };
            crate::math::ray::RaySegment { origin, t_min, direction, t_max }
        })
        .collect()
}

/// Interleaved batches give each ray the single ray's answer on the same code path, bit
/// for bit (the same nodes in the same order), for closest and any hits, Möller–Trumbore
/// and watertight, batches shorter and longer than the rays in flight.
#[test]
fn interleaved_batches_answer_as_single_rays_on_every_level() {
    let rays = batch_rays(3000, 7);
    for watertight in [false, true] {
        let mut mesh = random_mesh(4000, 11);
        if watertight {
            mesh.triangle_test = crate::accel::triangle::TriangleTest::Watertight;
        }
        mesh.build_accel(Accel::BvhSah);
        let MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
        let mut w = w.clone();
        w.set_interleave(Interleave::Always);
        assert!(w.interleaves(), "a shallow tree interleaves when asked to");
        let mut hits = 0;
        for level in SimdLevel::available() {
            w.set_level(level);
            for n in [0, 1, IN_FLIGHT - 1, IN_FLIGHT, IN_FLIGHT + 1, rays.len()] {
                let rays = &rays[..n];
                let (mut closest, mut blocked) = (vec![None; n], vec![false; n]);
                w.intersect_batch(rays, &mut closest);
                w.occluded_batch(rays, &mut blocked);
                for (i, r) in rays.iter().enumerate() {
                    let label = format!("{level:?}, watertight {watertight}, batch of {n}, ray {i}: {r:?}");
                    assert_eq!(closest[i], w.intersect(&r.ray(), r.t_min, r.t_max), "{label}");
                    assert_eq!(blocked[i], w.occluded(&r.ray(), r.t_min, r.t_max), "{label}");
                    hits += usize::from(closest[i].is_some());
                }
            }
        }
        assert!(hits > rays.len() / 4, "the rays meet the mesh ({hits} hits)");
    }
}

/// Trees deeper than the slots' stacks, and `Never`, trace one ray after the other (the
/// same answers); `Auto` interleaves only a tree larger than the last-level cache.
#[test]
fn deep_trees_and_trees_in_the_cache_are_traced_one_ray_at_a_time() {
    let mut mesh = random_mesh(2000, 3);
    mesh.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
    let mut w = w.clone();
    assert!(!w.interleaves(), "Auto: {} bytes fit in any last-level cache", w.bytes());
    w.set_interleave(Interleave::Never);
    assert!(!w.interleaves());
    w.set_interleave(Interleave::Always);
    assert!(w.interleaves() && w.depth <= 16);
    // The same tree said to be 17 levels deep: its rays would overflow the slots' stacks,
    // so even `Always` traces them one by one (a tree that deep takes thousands of
    // triangles at scales spanning most of the float range to build).
    w.depth = 17;
    assert!(!w.interleaves(), "17 levels: {} stack entries", w.stack_entries());
    let rays = batch_rays(500, 5);
    let mut out = vec![None; rays.len()];
    w.intersect_batch(&rays, &mut out);
    for (r, o) in rays.iter().zip(&out) {
        assert_eq!(*o, w.intersect(&r.ray(), r.t_min, r.t_max));
    }
    assert!(out.iter().any(Option::is_some));
    // An empty tree: nothing to interleave, every ray misses.
    let mut empty = TriangleMesh::new(Vec::new(), Vec::new(), Vec::new());
    empty.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = empty.accel() else { panic!("bvh-sah builds a wide BVH") };
    let mut w = w.clone();
    w.set_interleave(Interleave::Always);
    assert!(!w.interleaves());
    let mut blocked = vec![true; rays.len()];
    w.occluded_batch(&rays, &mut blocked);
    assert!(blocked.iter().all(|b| !b));
    assert_eq!("never".parse::<Interleave>(), Ok(Interleave::Never));
    assert!("sometimes".parse::<Interleave>().is_err());
}

#[test]
#[should_panic(expected = "one answer per ray")]
fn a_batch_needs_room_for_every_answer() {
    let mut mesh = random_mesh(100, 1);
    mesh.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = mesh.accel() else { panic!("bvh-sah builds a wide BVH") };
    w.intersect_batch(&batch_rays(10, 1), &mut [None; 9]);
}
