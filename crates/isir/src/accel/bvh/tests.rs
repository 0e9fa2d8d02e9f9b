//! Tests of the binary BVH.

use super::sah::*;
use super::*;
use glam::Vec3A;
use rand::{Rng, SeedableRng};

fn random_boxes(n: usize, seed: u64) -> Vec<Aabb> {
    let mut rng = rand_pcg::Pcg32::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let c = Vec3::new(rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0), rng.random_range(-10.0..10.0));
            let e = Vec3::new(rng.random_range(0.0..0.5), rng.random_range(0.0..0.5), rng.random_range(0.0..0.5));
            Aabb::new(c - e, c + e)
        })
        .collect()
}

/// Every primitive appears once; every node's box contains its children and primitives.
fn check_invariants(bvh: &Bvh, boxes: &[Aabb], expected_prims: usize) {
    let mut seen = vec![0u32; boxes.len()];
    for &p in &bvh.prim_indices {
        seen[p as usize] += 1;
    }
    assert_eq!(bvh.prim_indices.len(), expected_prims);
    assert!(seen.iter().all(|&s| s <= 1));
    let contains = |outer: &Aabb, inner: &Aabb| outer.min.cmple(inner.min).all() && outer.max.cmpge(inner.max).all();
    let mut leaves_total = 0;
    for n in &bvh.nodes {
        if n.is_leaf() {
            leaves_total += n.count as usize;
            for &p in &bvh.prim_indices[n.left_first as usize..(n.left_first + n.count) as usize] {
                assert!(contains(&n.aabb(), &boxes[p as usize]));
            }
        } else {
            let c = n.left_first as usize;
            assert!(c + 1 < bvh.nodes.len());
            assert!(contains(&n.aabb(), &bvh.nodes[c].aabb()) && contains(&n.aabb(), &bvh.nodes[c + 1].aabb()));
        }
    }
    assert_eq!(leaves_total, expected_prims);
    assert!(bvh.depth() < STACK_SIZE as u32);
}

#[test]
fn builds_are_well_formed() {
    for n in [1, 2, 9, 100, 5000, 20000] {
        let boxes = random_boxes(n, n as u64);
        for q in [BvhQuality::Midpoint, BvhQuality::Sah] {
            let bvh = Bvh::build(&boxes, q);
            check_invariants(&bvh, &boxes, n);
            if q == BvhQuality::Midpoint {
                assert!(
                    bvh.nodes.iter().all(|n| !n.is_leaf() || n.count as usize <= MIDPOINT_MAX_LEAF) || bvh.depth() >= MIDPOINT_MAX_DEPTH
                );
            } else {
                assert!(bvh.nodes.iter().all(|n| !n.is_leaf() || n.count as usize <= SAH_MAX_LEAF));
            }
        }
    }
}

#[test]
fn sah_beats_midpoint() {
    let boxes = random_boxes(20000, 7);
    let mid = Bvh::build(&boxes, BvhQuality::Midpoint).sah_cost();
    let sah = Bvh::build(&boxes, BvhQuality::Sah).sah_cost();
    assert!(sah < mid, "sah {sah} vs midpoint {mid}");
}

#[test]
fn degenerate_inputs() {
    // Empty input, identical boxes, and NaN / empty boxes that must be left out.
    for q in [BvhQuality::Midpoint, BvhQuality::Sah] {
        let empty = Bvh::build(&[], q);
        assert!(empty.nodes.is_empty());
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert_eq!(empty.intersect(&ray, 0.0, f32::INFINITY, |_, _| Some(1.0)), f32::INFINITY);

        let same = vec![Aabb::new(Vec3::ZERO, Vec3::ONE); 1000];
        check_invariants(&Bvh::build(&same, q), &same, 1000);

        let mut mixed = random_boxes(300, 3);
        mixed[5] = Aabb::new(Vec3::splat(f32::NAN), Vec3::splat(f32::NAN));
        mixed[6] = Aabb::EMPTY;
        mixed[7] = Aabb::new(Vec3::ZERO, Vec3::new(f32::INFINITY, 1.0, 1.0));
        let bvh = Bvh::build(&mixed, q);
        check_invariants(&bvh, &mixed, 297);
        assert!(!bvh.prim_indices.contains(&5) && !bvh.prim_indices.contains(&6) && !bvh.prim_indices.contains(&7));
    }
}

#[test]
fn huge_coordinates_still_give_small_leaves() {
    // Doubled centroids overflow to +inf on x and coincide on y and z: no binned split
    // exists, the build must still split (the wide layout holds at most 32 per leaf).
    let mut boxes: Vec<Aabb> = (0..40).map(|i| Aabb::new(Vec3::new(i as f32, 0.0, 0.0), Vec3::new(i as f32 + 1.0, 1.0, 1.0))).collect();
    boxes.extend((0..40).map(|_| Aabb::new(Vec3::new(3e38, 0.0, 0.0), Vec3::new(3.1e38, 1.0, 1.0))));
    let bvh = Bvh::build(&boxes, BvhQuality::Sah);
    check_invariants(&bvh, &boxes, boxes.len());
    assert!(bvh.nodes.iter().all(|n| !n.is_leaf() || n.count as usize <= SAH_MAX_LEAF));
}

#[test]
fn parallel_build_is_deterministic() {
    let boxes = random_boxes(100_000, 11);
    let a = Bvh::build(&boxes, BvhQuality::Sah);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
    let b = pool.install(|| Bvh::build(&boxes, BvhQuality::Sah));
    assert_eq!(a.nodes, b.nodes);
    assert_eq!(a.prim_indices, b.prim_indices);
    check_invariants(&a, &boxes, boxes.len());
}

#[test]
fn parallel_top_flattens_to_the_sequential_layout() {
    // The `Part` tree of the parallel build, flattened, is node for node the tree the
    // sequential build lays out: children adjacent, indices relocated right.
    let boxes = random_boxes(50_000, 13);
    let indices: Vec<u32> = (0..boxes.len() as u32).collect();
    let (nodes, prims) = build_sah(&indices, |i| boxes[i as usize]);
    let mut refs: Vec<PrimRef> = boxes.iter().enumerate().map(|(i, b)| PrimRef::new(i as u32, b)).collect();
    let bounds = Bounds::of(&refs);
    let mut seq = vec![BvhNode::default()];
    build_sah_into(&mut seq, 0, &mut refs, &bounds, 0, 0);
    assert!(nodes.len() > 1000);
    assert_eq!(nodes, seq);
    assert_eq!(prims, refs.iter().map(|p| p.index).collect::<Vec<_>>());
}

#[test]
fn traversal_finds_the_closest_box_hit() {
    // Primitives are the boxes themselves: the closest entry distance must match brute force.
    let boxes = random_boxes(3000, 5);
    let mut rng = rand_pcg::Pcg32::seed_from_u64(99);
    for q in [BvhQuality::Midpoint, BvhQuality::Sah] {
        let bvh = Bvh::build(&boxes, q);
        for _ in 0..500 {
            let o = Vec3::new(rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0), rng.random_range(-15.0..15.0));
            let d = Vec3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0));
            let ray = Ray::new(o, d);
            let hit = |p: u32, t_max: f32| boxes[p as usize].intersect(&ray, 0.0, t_max).map(|(t0, _)| t0).filter(|&t| t < t_max);
            let brute = (0..boxes.len() as u32).fold(f32::INFINITY, |best, p| hit(p, best).unwrap_or(best));
            assert_eq!(bvh.intersect(&ray, 0.0, f32::INFINITY, hit), brute);
            assert_eq!(bvh.occluded(&ray, 0.0, f32::INFINITY, |p, t| hit(p, t).is_some()), brute.is_finite());
        }
    }
}

/// Binning into two sets of bins (every other record) gives the bins of one record at a
/// time: boxes, counts, and so the split, whatever the count's parity.
#[test]
fn bins_of_pairs_are_the_bins_of_one_record_at_a_time() {
    for n in [1, 63, 64, 65, 1000, 1001] {
        let boxes = random_boxes(n, n as u64);
        let prims: Vec<PrimRef> = boxes.iter().enumerate().map(|(i, b)| PrimRef::new(i as u32, b)).collect();
        let bounds = Bounds::of(&prims);
        let binner = Binner::new(&bounds, 256); // 32 bins
        let got = bin_prims::<32>(&prims, &binner);
        let mut want = [[EMPTY_BIN; 32]; 3];
        prims.iter().for_each(|p| bin_record(&mut want, &binner, p));
        for axis in 0..3 {
            for k in 0..32 {
                let (g, w) = (&got[axis][k], &want[axis][k]);
                assert_eq!((g.lo, g.hi, g.count), (w.lo, w.hi, w.count), "n {n}, axis {axis}, bin {k}");
            }
        }
        assert_eq!(got[0].iter().map(|b| b.count as usize).sum::<usize>(), n);
        assert_eq!(best_split(&got).map(|s| (s.0, s.1)), best_split(&want).map(|s| (s.0, s.1)));
    }
}

/// The branch-free partition leaves the records in Hoare's order and returns its bounds
/// bit for bit, signed zeros included (boxes touching zero on every axis, half of them
/// written -0.0), whatever the sizes, the share on the left and the runs of one side.
#[test]
fn flag_partition_is_hoare_partition_bit_for_bit() {
    let bits = |b: &Bounds| [b.lo, b.hi, b.clo, b.chi].map(|v| v.to_array().map(f32::to_bits));
    let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
    for n in [0, 1, 2, 3, 63, 64, 65, 127, 128, 129, 255, 256, 257, 1000, 4097, 16384, 16385] {
        for share in [0.0, 0.02, 0.5, 0.98, 1.0] {
            let mut prims: Vec<PrimRef> = random_boxes(n, n as u64)
                .iter()
                .enumerate()
                .map(|(i, b)| {
                    // Boxes in the positive octant, a third of them from a signed zero
                    // (-0.0 and +0.0 compare equal): the least corner of a side is a zero,
                    // its sign that of the zero grown last.
                    let (lo, hi) = (b.min.abs().min(b.max.abs()), b.min.abs().max(b.max.abs()));
                    let mut p = PrimRef::new(i as u32, &Aabb::new(lo, hi));
                    if i % 3 == 0 {
                        p.min = [if rng.random_bool(0.5) { -0.0 } else { 0.0 }; 3];
                    }
                    p
                })
                .collect();
            // Runs of one side as well as coin tosses.
            let runs = rng.random_bool(0.5);
            let sides: Vec<bool> = (0..n).map(|i| if runs { (i / 37) % 2 == 0 } else { rng.random_bool(share) }).collect();
            let left = |p: &PrimRef| sides[p.index as usize];
            let mut a = prims.clone();
            let (ka, la, ra) = partition_hoare(&mut a, left);
            let (kb, lb, rb) = partition_bounds(&mut prims, left);
            assert_eq!(ka, kb, "n {n}, share {share}");
            assert!(a.iter().zip(&prims).all(|(x, y)| x.index == y.index), "n {n}, share {share}: another order");
            assert_eq!((bits(&la), bits(&ra)), (bits(&lb), bits(&rb)), "n {n}, share {share}: other bounds");
        }
    }
}

/// The three-lane sweep finds the split of the axis-by-axis sweep, cost bit for bit:
/// random bins, empty bins, ties (repeated boxes and counts, where the first minimum
/// must win), every bin count the build uses, and boxes whose areas overflow to infinity
/// or give NaN (infinite extent times a flat one), where the per-axis lanes must still
/// agree with the sequential rule (`best_split`'s comment says why they do).
#[test]
fn lane_sweep_finds_the_split_of_the_sequential_sweep() {
    fn check<const NB: usize>(rng: &mut rand_pcg::Pcg32, round: usize) -> bool {
        let mut bins = [[EMPTY_BIN; NB]; 3];
        let template = {
            let lo = Vec3A::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0));
            Bin { lo, hi: lo + Vec3A::splat(1.0), count: 3 }
        };
        for (axis, row) in bins.iter_mut().enumerate() {
            for (k, bin) in row.iter_mut().enumerate() {
                *bin = match (round + axis + k) % 9 {
                    // Empty bins.
                    0 | 1 => EMPTY_BIN,
                    // The same box and count in many bins and axes: ties.
                    2 | 3 if round.is_multiple_of(2) => template,
                    // Huge boxes: areas overflow (round % 5 == 1), or an infinite extent
                    // against a flat one gives NaN (round % 5 == 2).
                    4 if round % 5 == 1 => Bin { lo: Vec3A::splat(-3e38), hi: Vec3A::splat(3e38), count: 2 },
                    4 if round % 5 == 2 => Bin { lo: Vec3A::new(-3e38, 1.0, 0.0), hi: Vec3A::new(3e38, 1.0, 1.0), count: 2 },
                    _ => {
                        let lo = Vec3A::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0));
                        let size = Vec3A::new(rng.random_range(0.0..2.0), rng.random_range(0.0..2.0), rng.random_range(0.0..2.0));
                        Bin { lo, hi: lo + size, count: rng.random_range(1..40) }
                    }
                };
            }
        }
        let (got, want) = (best_split(&bins), best_split_scalar(&bins));
        assert_eq!(got.map(|(a, k, c)| (a, k, c.to_bits())), want.map(|(a, k, c)| (a, k, c.to_bits())), "{NB} bins, round {round}");
        want.is_some_and(|(_, _, c)| !c.is_finite())
    }
    let mut rng = rand_pcg::Pcg32::seed_from_u64(21);
    let mut not_finite = 0;
    for round in 0..3000 {
        not_finite += usize::from(check::<8>(&mut rng, round));
        not_finite += usize::from(check::<16>(&mut rng, round));
        not_finite += usize::from(check::<32>(&mut rng, round));
    }
    assert!(not_finite > 50, "{not_finite} splits of infinite or NaN cost");
    // All bins empty, or all records in one bin: no split.
    assert!(best_split(&[[EMPTY_BIN; 8]; 3]).is_none());
    let mut one = [[EMPTY_BIN; 8]; 3];
    for row in &mut one {
        row[3] = Bin { lo: Vec3A::ZERO, hi: Vec3A::ONE, count: 9 };
    }
    assert!(best_split(&one).is_none());
}

/// A record's two halves, each one aligned load, are its box corners, the fourth lanes
/// cleared whatever the index (index bits read as a float may be denormal or NaN).
#[test]
fn record_halves_are_its_corners() {
    let boxes = random_boxes(200, 17);
    for (i, b) in boxes.iter().enumerate() {
        for index in [i as u32, 0x007f_ffff, 0x7f80_0001, u32::MAX - 1] {
            let p = PrimRef::new(index, b);
            let [lo, hi] = p.halves();
            assert_eq!((lo.to_array(), hi.to_array()), (p.min, p.max));
            assert_eq!((lo, hi), (p.lo(), p.hi()));
            #[cfg(target_arch = "x86_64")]
            {
                // SAFETY: a `Vec3A` is 16 bytes, any of which make a `[u32; 4]`.
                let w = [lo, hi].map(|h| unsafe { std::mem::transmute::<Vec3A, [u32; 4]>(h) }[3]);
                assert_eq!(w, [0, 0], "index {index:#x}");
            }
        }
    }
}
