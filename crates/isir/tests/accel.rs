//! Every acceleration structure and every traversal path returns the closest hit that
//! brute force returns, and agrees with the any-hit query.

use isir::geometry::{MeshAccel, TriangleMesh};
use isir::sampling::Sampler;
use isir::wide::SimdLevel;
use isir::{Accel, Ray, Vec3};

fn bunny() -> TriangleMesh {
    isir::scenes::load_builtin_model("Bunny").unwrap().mesh
}

/// Rays from around the mesh towards random points of its box: most hit, some graze.
fn random_rays(mesh: &TriangleMesh, n: usize, seed: u64) -> Vec<Ray> {
    let b = mesh.aabb();
    let (c, r) = (b.centroid(), b.diagonal().length());
    let mut rng = Sampler::from_seed(seed);
    let point_in_box = |rng: &mut Sampler| b.min + b.diagonal() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    (0..n)
        .map(|i| {
            let target = point_in_box(&mut rng);
            let origin = if i % 4 == 0 {
                point_in_box(&mut rng) // inside the box: rays start among the triangles
            } else {
                let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::X);
                c + d * r
            };
            Ray::new(origin, target - origin)
        })
        .collect()
}

fn check_mesh(mut mesh: TriangleMesh, rays: &[Ray]) {
    let reference: Vec<_> = rays.iter().map(|r| mesh.intersect_brute_force(r, 0.0, f32::INFINITY)).collect();
    let hits = reference.iter().filter(|h| h.is_some()).count();
    assert!(hits > rays.len() / 4, "the test rays should hit often ({hits} of {})", rays.len());
    for accel in Accel::ALL {
        mesh.build_accel(accel);
        let mut levels = vec![None];
        if let MeshAccel::Wide(_) = mesh.accel() {
            levels = SimdLevel::available().into_iter().map(Some).collect();
        }
        for level in levels {
            let label = format!("{} {:?}", accel.name(), level);
            let mut m = mesh.clone();
            if let (Some(l), MeshAccel::Wide(w)) = (level, m.accel()) {
                let mut w = w.clone();
                w.set_level(l);
                // Trace through the wide BVH directly at this level.
                for (ray, want) in rays.iter().zip(&reference) {
                    let got = w.intersect(ray, 0.0, f32::INFINITY);
                    same_hit(&got, want, &label, ray);
                    assert_eq!(w.occluded(ray, 0.0, f32::INFINITY), want.is_some(), "{label}: any-hit disagrees for {ray:?}");
                    if let Some(h) = want {
                        // Shortened to just before the closest hit: nothing may block it.
                        assert!(!w.occluded(ray, 0.0, h.t * 0.999), "{label}: any-hit before the closest hit for {ray:?}");
                    }
                }
                continue;
            }
            m.build_accel(accel);
            for (ray, want) in rays.iter().zip(&reference) {
                let got = m.intersect(ray, 0.0, f32::INFINITY);
                same_hit(&got, want, &label, ray);
                assert_eq!(m.occluded(ray, 0.0, f32::INFINITY), want.is_some(), "{label}: any-hit disagrees for {ray:?}");
            }
        }
    }
}

/// Same `t` exactly (every path computes Möller–Trumbore the same way) and the same
/// triangle, unless two triangles are hit at exactly the same distance (a shared edge).
fn same_hit(got: &Option<isir::geometry::MeshHit>, want: &Option<isir::geometry::MeshHit>, label: &str, ray: &Ray) {
    match (got, want) {
        (None, None) => {}
        (Some(g), Some(w)) => {
            assert_eq!(g.t, w.t, "{label}: t differs for {ray:?}");
            if g.prim != w.prim {
                return; // a tie at the same t
            }
            assert_eq!((g.u, g.v), (w.u, w.v), "{label}: barycentrics differ for {ray:?}");
        }
        _ => panic!("{label}: {got:?} vs brute force {want:?} for {ray:?}"),
    }
}

#[test]
fn bunny_every_accel_and_path_matches_brute_force() {
    let mesh = bunny();
    let rays = random_rays(&mesh, 1500, 1);
    check_mesh(mesh, &rays);
}

#[test]
fn conference_every_accel_matches_brute_force() {
    // The room is mostly big flat quads and thin chair legs; brute force is slow here so
    // the ray count is small.
    let mesh = isir::scenes::load_builtin_model("conference").unwrap().mesh;
    let rays = random_rays(&mesh, 150, 2);
    check_mesh(mesh, &rays);
}

#[test]
fn degenerate_meshes_and_rays_never_panic_nor_hit_wrongly() {
    let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(2.0, 0.0, 0.0), Vec3::new(f32::NAN, 0.0, 0.0), Vec3::new(0.0, 0.0, f32::INFINITY)];
    // Zero-area, collinear, NaN and infinite triangles, and one good one last.
    let tris = vec![[0, 0, 1], [0, 1, 3], [0, 4, 2], [0, 1, 5], [0, 1, 2]];
    let bad_rays = [
        Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::ZERO),
        Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::new(f32::NAN, 0.0, 1.0)),
        Ray::new(Vec3::new(f32::NAN, 0.2, -1.0), Vec3::Z),
        Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::new(0.0, 0.0, f32::INFINITY)),
    ];
    let good = Ray::new(Vec3::new(0.2, 0.2, -1.0), Vec3::Z);
    let on_collinear = Ray::new(Vec3::new(1.5, 0.0, -1.0), Vec3::Z);
    for accel in Accel::ALL {
        let mut m = TriangleMesh::new(v.clone(), vec![], tris.clone());
        assert_eq!(m.stats().degenerate, 4);
        m.build_accel(accel);
        for r in &bad_rays {
            assert_eq!(m.intersect(r, 0.0, f32::INFINITY), None, "{}", accel.name());
            assert!(!m.occluded(r, 0.0, f32::INFINITY));
        }
        let h = m.intersect(&good, 0.0, f32::INFINITY).expect("the good triangle");
        assert_eq!((h.prim, h.t), (4, 1.0), "{}", accel.name());
        assert_eq!(m.intersect(&on_collinear, 0.0, f32::INFINITY), None);

        // An empty mesh, made by `new` or `default`, single rays and batches.
        for mut empty in [TriangleMesh::new(vec![], vec![], vec![]), TriangleMesh::default()] {
            assert_eq!(empty.aabb(), isir::math::aabb::Aabb::EMPTY);
            empty.build_accel(accel);
            assert_eq!(empty.intersect(&good, 0.0, f32::INFINITY), None);
            assert!(!empty.occluded(&good, 0.0, f32::INFINITY));
            let segment = isir::math::ray::RaySegment { origin: good.origin, t_min: 0.0, direction: good.direction, t_max: f32::INFINITY };
            let (mut closest, mut blocked) = ([Some(h)], [true]);
            empty.intersect_batch(&[segment], &mut closest);
            empty.occluded_batch(&[segment], &mut blocked);
            assert_eq!((closest, blocked), ([None], [false]), "{}", accel.name());
        }
    }
}

#[test]
fn sah_tree_is_cheaper_than_the_course_midpoint_tree() {
    let mut mesh = bunny();
    mesh.build_accel(Accel::BvhMid);
    let mid = mesh.stats();
    mesh.build_accel(Accel::BvhSah);
    let sah = mesh.stats();
    assert!(sah.sah_cost < mid.sah_cost, "SAH {} vs midpoint {}", sah.sah_cost, mid.sah_cost);
    assert!(sah.nodes > 0 && mid.nodes > 0);
}

#[test]
fn conference_ray_sets_trace_like_brute_force() {
    // The scene's own ray sets (primary, diffuse, shadow), on a sample of pixels: the
    // parallel tracer over the wide BVH agrees with brute force ray for ray.
    use isir::rays::{compare_hits, generate, trace_mesh, HitRecord, RayKind};
    let desc = isir::scenes::builtin("tp4-conference").unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    let cam = desc.camera.build(1.5);
    let mut brute = isir::scenes::load_builtin_model("conference").unwrap().mesh;
    brute.build_accel(Accel::None);
    let (_, fast) = scene.meshes().next().unwrap();
    for kind in [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow] {
        let rays: Vec<_> = generate(&scene, &cam, 24, 16, kind, 3).unwrap();
        assert!(rays.len() > 300, "{kind:?}: {}", rays.len());
        let occluded = kind == RayKind::Shadow;
        let mut a = vec![HitRecord::MISS; rays.len()];
        let mut b = a.clone();
        trace_mesh(fast, &rays, occluded, &mut a);
        trace_mesh(&brute, &rays, occluded, &mut b);
        let agreement = compare_hits(&a, &b, 0.0);
        assert_eq!(agreement.agree, rays.len(), "{kind:?}: {agreement:?}");
        if !occluded {
            assert_eq!(a, b, "{kind:?}: closest hits differ");
            assert!(agreement.both_hit > rays.len() / 2, "{kind:?}: most rays should hit");
        }
    }
}

#[test]
fn watertight_test_matches_brute_force_on_every_path() {
    let mut mesh = bunny();
    mesh.triangle_test = isir::triangle::TriangleTest::Watertight;
    let rays = random_rays(&mesh, 800, 4);
    check_mesh(mesh, &rays);
}

#[test]
fn watertight_rays_through_vertices_and_edges_of_a_closed_mesh_all_hit() {
    // pbrt's test: from inside a closed mesh, rays aimed exactly at vertices and edge
    // midpoints must hit something; with Möller–Trumbore some slip through.
    let mut mesh = isir::scenes::load_builtin_model("uvsphere").unwrap().mesh;
    let centre = Vec3::new(0.013, -0.021, 0.017);
    let mut targets = Vec::new();
    for t in 0..mesh.triangles.len() as u32 {
        let [a, b, c] = mesh.triangle_vertices(t);
        targets.extend([a, (a + b) * 0.5, (b + c) * 0.5, (c + a) * 0.5]);
    }
    // Möller–Trumbore does let some through (351 of 3,840 when measured): the test can fail.
    mesh.build_accel(Accel::None);
    let mt_misses = targets.iter().filter(|&&p| mesh.intersect(&Ray::new(centre, p - centre), 0.0, f32::INFINITY).is_none()).count();
    assert!(mt_misses > 0, "expected Möller–Trumbore to miss some edge rays");
    mesh.triangle_test = isir::triangle::TriangleTest::Watertight;
    for accel in Accel::ALL {
        mesh.build_accel(accel);
        let levels: Vec<Option<SimdLevel>> = match mesh.accel() {
            MeshAccel::Wide(_) => SimdLevel::available().into_iter().map(Some).collect(),
            _ => vec![None],
        };
        for level in levels {
            let mut m = mesh.clone();
            if let Some(l) = level {
                assert!(m.set_simd_level(l));
            }
            let misses = targets.iter().filter(|&&p| m.intersect(&Ray::new(centre, p - centre), 0.0, f32::INFINITY).is_none()).count();
            assert_eq!(misses, 0, "{} {level:?}: {misses} of {} rays slipped through", accel.name(), targets.len());
        }
    }
}

#[test]
fn packets_return_the_same_hits_as_single_rays() {
    use isir::rays::{generate, HitRecord, RayKind, RayRecord};
    let desc = isir::scenes::builtin("tp4-conference").unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    let (_, mesh) = scene.meshes().next().unwrap();
    // Coherent camera rays (the packets' case), diffuse rays (mixed signs: the fallback),
    // and odd ones: invalid rays and short intervals inside a packet, a partial last packet.
    let mut rays: Vec<RayRecord> = generate(&scene, &desc.camera.build(1.5), 64, 40, RayKind::Primary, 1).unwrap();
    rays.extend(generate(&scene, &desc.camera.build(1.5), 32, 20, RayKind::Diffuse, 1).unwrap());
    for i in (0..rays.len()).step_by(37) {
        rays[i].t_max = 300.0;
    }
    // Intervals that start behind the origin (the box tests' other widening).
    for i in (3..rays.len()).step_by(41) {
        rays[i].t_min = -50.0;
    }
    rays[5].direction = Vec3::ZERO;
    rays[21].origin.x = f32::NAN;
    // A whole packet with a -0.0 component (its octant must follow the sign bit) and one
    // with +0.0.
    for r in &mut rays[32..48] {
        r.direction.x = -0.0;
    }
    for r in &mut rays[48..64] {
        r.direction.y = 0.0;
    }
    rays.truncate(rays.len() - 5);
    if !SimdLevel::available().contains(&SimdLevel::Avx512) {
        eprintln!("note: no AVX-512 on this CPU: its packets are not tested here (the AVX2 streams and the scalar fallback are)");
    }
    packets_on_every_level_as_single_rays(mesh, &rays, "", |packed: &[HitRecord]| {
        assert!(!packed[5].is_hit() && !packed[21].is_hit());
        assert!(packed.iter().filter(|h| h.is_hit()).count() > rays.len() / 2);
    });
}

/// On every code path this CPU has, `rays` traced as packets (`trace_mesh_packets`) get
/// the hits of single rays (`trace_mesh`), except that AVX-512 packets may report the
/// other of two triangles at exactly one distance (rarely); `check` then looks at the
/// packets' hits of each path.
fn packets_on_every_level_as_single_rays(
    mesh: &TriangleMesh,
    rays: &[isir::rays::RayRecord],
    label: &str,
    check: impl Fn(&[isir::rays::HitRecord]),
) {
    use isir::rays::{trace_mesh, trace_mesh_packets, HitRecord};
    let mut single = vec![HitRecord::MISS; rays.len()];
    let mut packed = single.clone();
    for level in SimdLevel::available() {
        let mut m = mesh.clone();
        assert!(m.set_simd_level(level));
        trace_mesh(&m, rays, false, &mut single);
        trace_mesh_packets(&m, rays, &mut packed);
        let mut ties = 0;
        for (i, (s, p)) in single.iter().zip(&packed).enumerate() {
            if level == SimdLevel::Avx512 && s.prim != p.prim {
                // AVX-512 packets of a ray file report either of two triangles at exactly
                // one distance (the renderer's lanes report the single ray's).
                assert_eq!(s.t.to_bits(), p.t.to_bits(), "{label}{level:?} ray {i}: {s:?} vs {p:?}");
                ties += 1;
                continue;
            }
            assert_eq!(s, p, "{label}{level:?} ray {i}");
        }
        assert!(ties * 1000 < rays.len(), "{label}{level:?}: {ties} ties");
        check(&packed);
    }
}

/// Camera rays from views all around the conference room (one origin per packet: the
/// AVX-512 packets cull the child boxes their frustum misses before testing each ray),
/// among them the one under the table whose rays meet chair legs, traced as packets: the
/// hits of single rays. `tools/bench-views/` holds the same views as scene files.
#[test]
fn camera_packets_from_every_view_return_the_single_rays_hits() {
    use isir::rays::{generate, RayKind};
    use isir::scenes::CameraDesc;
    let desc = isir::scenes::builtin("tp4-conference").unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    let (_, mesh) = scene.meshes().next().unwrap();
    let views = [
        (Vec3::new(600.0, 300.0, -100.0), Vec3::new(-300.0, 150.0, 200.0)),
        (Vec3::new(0.0, 150.0, 0.0), Vec3::new(400.0, 100.0, -200.0)),
        (Vec3::new(-400.0, 550.0, -250.0), Vec3::new(200.0, 0.0, 150.0)),
        // Far outside the room, a narrow field: the origin's large coordinates (the slab
        // tests' rounding).
        (Vec3::new(9000.0, 4000.0, -7000.0), Vec3::new(0.0, 200.0, 0.0)),
    ];
    for (v, (position, look_at)) in views.into_iter().enumerate() {
        let fovy = if v == 3 { 8.0 } else { 60.0 };
        let camera = CameraDesc { fovy, ..CameraDesc::new(position, look_at) }.build(1.5);
        let rays = generate(&scene, &camera, 96, 64, RayKind::Primary, 1).unwrap();
        packets_on_every_level_as_single_rays(mesh, &rays, &format!("view {v}, "), |packed| {
            assert!(packed.iter().filter(|h| h.is_hit()).count() > rays.len() / 4, "view {v}: the view sees the room");
        });
    }
}

/// Packets of one origin whose rays aim at triangles' edges and corners, where the leaves'
/// boxes have their faces, some from far away: every child box a ray enters must survive
/// the packet's frustum test, so the packets find the hits of single rays (the renderer's
/// lanes, ties included; a ray file's packets may report the other triangle of a tie).
#[test]
fn packets_of_one_origin_find_the_hits_at_box_faces() {
    use isir::math::ray::RaySegment;
    let mut mesh = isir::scenes::load_builtin_model("conference").unwrap().mesh;
    mesh.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = mesh.accel() else { panic!("the SAH BVH is the wide BVH") };
    let b = mesh.aabb();
    let mut rng = Sampler::from_seed(29);
    let n = mesh.triangles.len();
    let mut packets = Vec::new();
    for p in 0..600 {
        // Sixteen points on the edges of a run of triangles (near one another in the file),
        // seen from inside the room (often several octants: the AVX2 stream's case, also
        // checked), from 20 to 220 units or from far away (one octant: the frustum's).
        let first = (rng.next_f32() * n as f32) as usize % n;
        let targets: Vec<Vec3> = (0..16)
            .map(|k| {
                let [a, c, d] = mesh.triangle_vertices(((first + k / 3) % n) as u32);
                let s = if k % 4 == 0 { 0.0 } else { rng.next_f32() };
                [a + (c - a) * s, c + (d - c) * s, d + (a - d) * s][k % 3]
            })
            .collect();
        let centre = targets.iter().fold(Vec3::ZERO, |m, t| m + *t) / 16.0;
        let dir = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y);
        let origin = match p % 3 {
            0 => b.min + b.diagonal() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
            1 => centre + dir * (20.0 + 200.0 * rng.next_f32()),
            _ => centre + dir * 2.0e4,
        };
        let rays: Vec<RaySegment> =
            targets.iter().map(|t| RaySegment { origin, t_min: 0.0, direction: *t - origin, t_max: f32::INFINITY }).collect();
        packets.push(rays);
    }
    let (mut hits, mut ties) = (0, 0);
    for level in SimdLevel::available() {
        let mut w = w.clone();
        w.set_level(level);
        for rays in &packets {
            let mut out = [None; 16];
            w.intersect_packet(rays, &mut out);
            // The renderer's lanes: the single rays' hits, ties included.
            let lanes = isir::math::ray::RayLanes::new(rays);
            let mut from_lanes = [None; 16];
            w.intersect_lanes(&lanes, &lanes.t_max, u32::MAX, &mut from_lanes);
            for ((r, got), lane) in rays.iter().zip(out).zip(from_lanes) {
                let want = w.intersect(&r.ray(), r.t_min, r.t_max);
                hits += usize::from(want.is_some());
                assert_eq!(lane, want, "{level:?}, lanes: {r:?}");
                match (got, want) {
                    (Some(g), Some(s)) if g.prim != s.prim && level == SimdLevel::Avx512 => {
                        assert_eq!(g.t.to_bits(), s.t.to_bits(), "{level:?}: {r:?}");
                        ties += 1;
                    }
                    (g, s) => assert_eq!(g, s, "{level:?}: {r:?}"),
                }
            }
        }
    }
    let total = packets.len() * 16 * SimdLevel::available().len();
    assert!(hits * 10 > total * 9, "{hits} of {total} rays hit: the rays reach their triangles");
    assert!(ties * 100 < total, "{ties} ties");
}

/// Two coincident tilings of the plane z = 0 and small triangles above it, with rays that
/// meet both tilings at exactly the same `t` (see the test below): the mesh (a wide BVH),
/// the rays and the number of tiling triangles.
fn coincident_tilings() -> (TriangleMesh, Vec<isir::rays::RayRecord>, usize) {
    use isir::rays::RayRecord;
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    let add = |vertices: &mut Vec<Vec3>, triangles: &mut Vec<[u32; 3]>, a: Vec3, b: Vec3, c: Vec3| {
        let n = vertices.len() as u32;
        vertices.extend([a, b, c]);
        triangles.push([n, n + 1, n + 2]);
    };
    for shift in [0.0, 2.0] {
        for i in 0..16 {
            for j in 0..16 {
                let (x, y) = (i as f32 * 4.0 + shift, j as f32 * 4.0 + shift);
                add(&mut vertices, &mut triangles, Vec3::new(x, y, 0.0), Vec3::new(x + 4.0, y, 0.0), Vec3::new(x, y + 4.0, 0.0));
                add(
                    &mut vertices,
                    &mut triangles,
                    Vec3::new(x + 4.0, y + 4.0, 0.0),
                    Vec3::new(x, y + 4.0, 0.0),
                    Vec3::new(x + 4.0, y, 0.0),
                );
            }
        }
    }
    let tiles = triangles.len();
    let mut rng = Sampler::from_seed(3);
    for _ in 0..200 {
        let p = Vec3::new(rng.next_f32() * 66.0, rng.next_f32() * 66.0, 0.5 + rng.next_f32() * 6.0);
        add(&mut vertices, &mut triangles, p, p + Vec3::new(0.3, 0.0, 0.1), p + Vec3::new(0.0, 0.3, 0.2));
    }
    let mut mesh = TriangleMesh::new(vertices, Vec::new(), triangles);
    mesh.build_accel(Accel::BvhSah);
    // Packets of sixteen neighbours (4 × 4 origins a quarter apart), each ray leaning its
    // own way by sixteenths: rays of several octants (the streams' case), then of one
    // octant (the AVX-512 packets'), then of one octant and one origin (the packets'
    // frustum's).
    let mut rays = Vec::new();
    for kind in 0..3 {
        for py in 0..24 {
            for px in 0..24 {
                for k in 0..16 {
                    let (dx, dy) = (((k * 5) % 7) as f32 / 16.0, ((k * 3) % 5) as f32 / 16.0);
                    let (spread, direction) = match kind {
                        0 => (0.25, Vec3::new(dx - 0.1875, dy - 0.125, -1.0)),
                        1 => (0.25, Vec3::new(dx + 0.0625, dy + 0.0625, -1.0)),
                        _ => (0.0, Vec3::new(dx + 0.0625, dy + 0.0625, -1.0)),
                    };
                    let origin =
                        Vec3::new(4.0 + px as f32 * 2.5 + (k % 4) as f32 * spread, 4.0 + py as f32 * 2.5 + (k / 4) as f32 * spread, 16.0);
                    rays.push(RayRecord { origin, t_min: 0.0, direction, t_max: f32::INFINITY });
                }
            }
        }
    }
    (mesh, rays, tiles)
}

/// Two triangles at exactly the same distance: a single ray reports the one it visits
/// first, and streams and the renderer's lanes, which visit in another order, must report
/// the same one (they see the tie and trace the ray again alone), on every code path;
/// AVX-512 packets of a ray file report either.
/// The plane z = 0 is tiled twice by right triangles with legs of 4 (the second tiling
/// shifted by 2): rays of dyadic origins and directions meet both tilings at exactly the
/// same `t` (every product exact, the determinant a power of two). Small triangles
/// scattered above the plane give the leaves' boxes different tops, so that rays next
/// to each other order the leaves differently.
#[test]
fn packets_resolve_ties_between_coincident_triangles_as_single_rays() {
    use isir::math::ray::{RayLanes, RaySegment};
    use isir::rays::{trace_mesh, trace_mesh_packets, HitRecord};
    let (mut mesh, rays, tiles) = coincident_tilings();
    let mut single = vec![HitRecord::MISS; rays.len()];
    let mut packed = single.clone();
    for level in SimdLevel::available() {
        assert!(mesh.set_simd_level(level));
        trace_mesh(&mesh, &rays, false, &mut single);
        let ties = single.iter().filter(|h| h.t == 16.0 && (h.prim as usize) < tiles).count();
        let first = single.iter().filter(|h| h.t == 16.0 && (h.prim as usize) < tiles / 2).count();
        // Most rays meet the plane, and single rays report triangles of both tilings.
        assert!(ties > rays.len() / 2 && first > 0 && first < ties, "{level:?}: {first} of {ties} plane hits on the first tiling");
        // The renderer's lanes: AVX-512 packets from eight lanes, on every level.
        let MeshAccel::Wide(w) = mesh.accel() else { panic!("the SAH BVH is the wide BVH") };
        for (p, chunk) in rays.chunks(16).enumerate() {
            let segments: Vec<RaySegment> =
                chunk.iter().map(|r| RaySegment { origin: r.origin, t_min: r.t_min, direction: r.direction, t_max: r.t_max }).collect();
            let lanes = RayLanes::new(&segments);
            let mut out = [None; 16];
            w.intersect_lanes(&lanes, &lanes.t_max, u32::MAX, &mut out);
            for (k, got) in out.iter().enumerate() {
                let s = &single[16 * p + k];
                let got = got.map_or(HitRecord::MISS, HitRecord::from);
                assert_eq!(&got, s, "{level:?}, lanes of packet {p}, lane {k}");
            }
        }
        // Ray files' packets: AVX-512 ones report either triangle of a tie.
        if level == SimdLevel::Avx512 {
            continue;
        }
        trace_mesh_packets(&mesh, &rays, &mut packed);
        for (i, (s, p)) in single.iter().zip(&packed).enumerate() {
            assert_eq!(s, p, "{level:?} ray {i}: {:?}", rays[i]);
        }
    }
}

/// Rays traced 16 at a time per thread ([`isir::wide::Interleave`]) visit the nodes in the
/// single ray's order, so where two triangles meet a ray at one distance they report the
/// single ray's triangle, on every code path (AVX-512 included), closest and any hits.
#[test]
fn interleaved_rays_resolve_ties_between_coincident_triangles_as_single_rays() {
    use isir::rays::{trace_mesh, HitRecord};
    use isir::wide::Interleave;
    let (mut mesh, rays, tiles) = coincident_tilings();
    let mut single = vec![HitRecord::MISS; rays.len()];
    let mut interleaved = single.clone();
    for level in SimdLevel::available() {
        assert!(mesh.set_simd_level(level));
        for occluded in [false, true] {
            assert!(mesh.set_interleave(Interleave::Never));
            assert_eq!(mesh.rays_in_flight(), 1);
            trace_mesh(&mesh, &rays, occluded, &mut single);
            assert!(mesh.set_interleave(Interleave::Always));
            assert_eq!(mesh.rays_in_flight(), isir::wide::IN_FLIGHT);
            trace_mesh(&mesh, &rays, occluded, &mut interleaved);
            if !occluded {
                let first = single.iter().filter(|h| h.t == 16.0 && (h.prim as usize) < tiles / 2).count();
                let ties = single.iter().filter(|h| h.t == 16.0 && (h.prim as usize) < tiles).count();
                assert!(ties > rays.len() / 2 && first > 0 && first < ties, "{level:?}: {first} of {ties} plane hits on the first tiling");
            }
            for (i, (s, p)) in single.iter().zip(&interleaved).enumerate() {
                assert_eq!(s, p, "{level:?}, occluded {occluded}, ray {i}: {:?}", rays[i]);
            }
        }
    }
}

/// A mesh's batches, interleaved or not, answer each ray as `TriangleMesh::intersect` and
/// `occluded` do, rays that miss the mesh's box (answered without a traversal) included.
#[test]
fn mesh_batches_answer_as_single_queries() {
    use isir::math::ray::RaySegment;
    use isir::wide::Interleave;
    let mut mesh = bunny();
    mesh.build_accel(Accel::BvhSah);
    let b = mesh.aabb();
    let mut rays: Vec<RaySegment> = random_rays(&mesh, 1200, 9)
        .iter()
        .enumerate()
        .map(|(i, r)| RaySegment {
            origin: r.origin,
            t_min: 0.0,
            direction: r.direction,
            t_max: if i % 3 == 0 { 0.05 } else { f32::INFINITY },
        })
        .collect();
    // Rays beside the box, parallel to it: they miss it.
    rays.extend((0..100).map(|i| RaySegment {
        origin: b.max + Vec3::new(0.01, 0.01 * i as f32, 0.0),
        t_min: 0.0,
        direction: Vec3::new(0.0, 0.0, -1.0),
        t_max: f32::INFINITY,
    }));
    for level in SimdLevel::available() {
        assert!(mesh.set_simd_level(level));
        for interleave in [Interleave::Never, Interleave::Always] {
            assert!(mesh.set_interleave(interleave));
            let (mut closest, mut blocked) = (vec![None; rays.len()], vec![false; rays.len()]);
            mesh.intersect_batch(&rays, &mut closest);
            mesh.occluded_batch(&rays, &mut blocked);
            let mut hits = 0;
            for (i, r) in rays.iter().enumerate() {
                assert_eq!(closest[i], mesh.intersect(&r.ray(), r.t_min, r.t_max), "{level:?} {interleave:?} ray {i}");
                assert_eq!(blocked[i], mesh.occluded(&r.ray(), r.t_min, r.t_max), "{level:?} {interleave:?} ray {i}");
                hits += usize::from(closest[i].is_some());
            }
            assert!(hits > rays.len() / 4 && closest[rays.len() - 100..].iter().all(Option::is_none), "{hits} hits");
        }
    }
}

#[test]
fn negative_t_min_finds_hits_behind_the_origin_on_every_path() {
    // RAYS.md allows any t_min: the interval [-r, r) around an origin inside the bunny's
    // box reaches triangles on both sides.
    let mut mesh = bunny();
    let r = mesh.aabb().diagonal().length();
    let rays: Vec<Ray> = random_rays(&mesh, 400, 9).into_iter().step_by(4).collect(); // origins inside the box
    let reference: Vec<_> = rays.iter().map(|ray| mesh.intersect_brute_force(ray, -r, r)).collect();
    assert!(reference.iter().filter(|h| h.is_some_and(|h| h.t < 0.0)).count() > 10, "some hits must lie behind the origins");
    mesh.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = mesh.accel() else { unreachable!() };
    for level in SimdLevel::available() {
        let mut w = w.clone();
        w.set_level(level);
        for (ray, want) in rays.iter().zip(&reference) {
            same_hit(&w.intersect(ray, -r, r), want, &format!("{level:?}"), ray);
        }
    }
}

/// The box test's FMA form rounds `origin · inv` once, an error absolute in the origin's
/// magnitude: short rays far from the world origin, aimed at triangles' edges (where a
/// triangle touches its box), must still find them on every SIMD level and in packets.
/// The first ray is a conference-room shadow ray that leaked light through a wall.
#[test]
fn short_rays_far_from_the_origin_find_triangles_at_their_box_edges() {
    use isir::math::ray::RaySegment;
    let mut mesh = isir::scenes::load_builtin_model("conference").unwrap().mesh;
    mesh.build_accel(Accel::BvhSah);
    let bits = |x: [u32; 3]| Vec3::from_array(x.map(f32::from_bits));
    let mut rays = vec![(
        Ray::new(bits([0x44cea7ed, 0x438eda30, 0xc2708f50]), bits([0xbf6ef1f3, 0x3eb390e4, 0xbd9bff67])),
        f32::from_bits(0x4460044a),
    )];
    let mut rng = Sampler::from_seed(12);
    let n = mesh.triangles.len();
    while rays.len() < 3000 {
        let [a, b, c] = mesh.triangle_vertices(((rng.next_f32() * n as f32) as usize % n) as u32);
        // A point on an edge, a little inside or outside, from 2 to 60 units away.
        let (s, inset) = (rng.next_f32(), (rng.next_f32() - 0.5) * 1e-5);
        let p = a + (b - a) * s + (c - a) * inset;
        let d = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::X);
        let len = 2.0 + 58.0 * rng.next_f32();
        rays.push((Ray::new(p - d * len, d), len * 1.5));
    }
    let reference: Vec<bool> = rays.iter().map(|(r, t)| mesh.occluded_brute_force(r, 0.0, *t)).collect();
    assert!(reference[0], "the conference shadow ray is blocked by a wall");
    let MeshAccel::Wide(w) = mesh.accel() else { panic!("the SAH BVH is the wide BVH") };
    for level in SimdLevel::available() {
        let mut w = w.clone();
        w.set_level(level);
        for ((r, t), want) in rays.iter().zip(&reference) {
            assert_eq!(w.occluded(r, 0.0, *t), *want, "{level:?}: any-hit for {r:?} up to {t}");
            assert_eq!(w.intersect(r, 0.0, *t).is_some(), *want, "{level:?}: closest hit for {r:?} up to {t}");
        }
        let segments: Vec<RaySegment> =
            rays.iter().map(|(r, t)| RaySegment { origin: r.origin, t_min: 0.0, direction: r.direction, t_max: *t }).collect();
        for (chunk, want) in segments.chunks(16).zip(reference.chunks(16)) {
            let mask = w.occluded_packet(chunk);
            for (i, want) in want.iter().enumerate() {
                assert_eq!(mask & (1 << i) != 0, *want, "{level:?}: packet answer for {:?}", chunk[i]);
            }
        }
    }
}

/// The shadow rays of one point towards an area light, the renderer's packets: traced
/// together (AVX-512 packets, AVX2 streams) they must get the answers each gets alone,
/// whole, partial and with odd members (invalid rays, a negative `t_min`, empty intervals).
#[test]
fn shadow_packets_of_one_point_answer_as_single_rays() {
    use isir::math::ray::{RayLanes, RaySegment};
    let mut mesh = isir::scenes::load_builtin_model("conference").unwrap().mesh;
    mesh.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = mesh.accel() else { panic!("the SAH BVH is the wide BVH") };
    let b = mesh.aabb();
    let mut rng = Sampler::from_seed(5);
    let mut point = || b.min + (b.max - b.min) * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let mut packets = Vec::new();
    for p in 0..400 {
        let origin = point();
        let n = 1 + p % 16;
        let mut rays: Vec<RaySegment> = (0..n)
            .map(|_| {
                let target = point();
                RaySegment { origin, t_min: 1e-4, direction: target - origin, t_max: 1.0 - 1e-4 }
            })
            .collect();
        if p % 7 == 0 {
            rays[0].direction = Vec3::ZERO;
        }
        if p % 11 == 0 {
            rays[n - 1].t_min = -0.5;
        }
        if p % 13 == 0 {
            rays[n / 2].t_max = rays[n / 2].t_min;
        }
        packets.push(rays);
    }
    let mut blocked = 0;
    for level in SimdLevel::available() {
        let mut w = w.clone();
        w.set_level(level);
        for (p, rays) in packets.iter().enumerate() {
            let mask = w.occluded_packet(rays);
            // The same rays in lanes, asked about all of them or every lane but some.
            let asked = if p % 3 == 0 { u32::MAX } else { !(0b1001 << (p % 5)) };
            let lanes = w.occluded_lanes(&RayLanes::new(rays), asked);
            for (i, r) in rays.iter().enumerate() {
                let want = w.occluded(&r.ray(), r.t_min, r.t_max);
                blocked += usize::from(want);
                assert_eq!(mask & (1 << i) != 0, want, "{level:?}: packet of {}, ray {i}: {r:?}", rays.len());
                assert_eq!(lanes & (1 << i) != 0, want && asked & (1 << i) != 0, "{level:?}: lanes of {}, ray {i}: {r:?}", rays.len());
            }
            assert_eq!(mask >> rays.len(), 0, "{level:?}: bits beyond the packet");
            assert_eq!(lanes >> rays.len(), 0, "{level:?}: bits beyond the lanes");
        }
    }
    let total = packets.iter().map(Vec::len).sum::<usize>() * SimdLevel::available().len();
    assert!(blocked > total / 10 && blocked < total * 9 / 10, "{blocked} of {total} blocked: a test of both answers");
}

/// An empty mesh and rays that are all invalid: packets and streams answer "nothing" on
/// every level, as single rays do.
#[test]
fn packets_of_an_empty_mesh_or_of_invalid_rays_hit_nothing() {
    use isir::math::ray::RaySegment;
    let mut empty = TriangleMesh::new(Vec::new(), Vec::new(), Vec::new());
    empty.build_accel(Accel::BvhSah);
    let mut bunny = bunny();
    bunny.build_accel(Accel::BvhSah);
    let ray = |origin: Vec3, direction: Vec3| RaySegment { origin, t_min: 0.0, direction, t_max: f32::INFINITY };
    let (centre, size) = (bunny.aabb().min + bunny.aabb().diagonal() * 0.5, bunny.aabb().diagonal().length());
    let into_bunny: Vec<RaySegment> =
        (0..16).map(|i| ray(centre + Vec3::new(0.0, 0.0, size), Vec3::new(i as f32 * 1e-3, 0.0, -1.0))).collect();
    let invalid: Vec<RaySegment> = (0..16).map(|i| ray(Vec3::ZERO, if i % 2 == 0 { Vec3::ZERO } else { Vec3::NAN })).collect();
    for (mesh, rays, label) in [(&empty, &into_bunny, "empty mesh"), (&bunny, &invalid, "invalid rays")] {
        let MeshAccel::Wide(w) = mesh.accel() else { panic!("the SAH BVH is the wide BVH") };
        for level in SimdLevel::available() {
            let mut w = w.clone();
            w.set_level(level);
            assert_eq!(w.occluded_packet(rays), 0, "{label} {level:?}");
            let mut out = [Some(isir::geometry::MeshHit { t: 1.0, prim: 0, u: 0.0, v: 0.0 }); 16];
            w.intersect_packet(rays, &mut out);
            assert!(out.iter().all(Option::is_none), "{label} {level:?}");
        }
    }
    // The same rays into the bunny do hit it (the test above can fail).
    let MeshAccel::Wide(w) = bunny.accel() else { unreachable!() };
    assert_ne!(w.occluded_packet(&into_bunny), 0);
}

/// The renderer's lanes (`intersect_lanes`, an AVX-512 packet from eight lanes) with bad
/// lanes among good ones: NaN or infinite origins and directions, zero directions, NaN,
/// negative and empty intervals, lanes left out of the mask. Each lane answers as its
/// single ray does, on every level, whether the good rays hit or miss.
#[test]
fn lanes_with_bad_rays_among_good_ones_answer_as_single_rays() {
    use isir::math::ray::{RayLanes, RaySegment};
    let mut bunny = bunny();
    bunny.build_accel(Accel::BvhSah);
    let MeshAccel::Wide(w) = bunny.accel() else { panic!("the SAH BVH is the wide BVH") };
    let (centre, size) = (bunny.aabb().min + bunny.aabb().diagonal() * 0.5, bunny.aabb().diagonal().length());
    let mut rng = Sampler::from_seed(43);
    let (mut hits, mut checked) = (0, 0);
    for round in 0..400 {
        // Far enough to one side that the good rays share an octant (a packet's case).
        let eye = centre + Vec3::new(size, 1.2 * size, 1.5 * size);
        let rays: Vec<RaySegment> = (0..16)
            .map(|k| {
                let target = centre + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * size * 0.5;
                let good = RaySegment { origin: eye, t_min: 0.0, direction: (target - eye).normalize(), t_max: f32::INFINITY };
                // A few bad lanes per packet, of a kind that changes with the round.
                if (k + round) % 5 != 0 {
                    return good;
                }
                match (k + round / 5) % 8 {
                    0 => RaySegment { origin: Vec3::NAN, ..good },
                    1 => RaySegment { direction: Vec3::new(f32::NAN, 0.0, -1.0), ..good },
                    2 => RaySegment { direction: Vec3::ZERO, ..good },
                    3 => RaySegment { t_max: f32::NAN, ..good },
                    4 => RaySegment { t_min: 5.0, t_max: 1.0, ..good },
                    5 => RaySegment { t_min: -size, ..good },
                    6 => RaySegment { origin: Vec3::splat(f32::INFINITY), ..good },
                    _ => RaySegment { t_max: 1e-3, ..good },
                }
            })
            .collect();
        let lanes = RayLanes::new(&rays);
        let mask = if round % 3 == 0 { u32::MAX } else { !(1u32 << (round % 16)) };
        for level in SimdLevel::available() {
            let mut w = w.clone();
            w.set_level(level);
            let mut out = [Some(isir::geometry::MeshHit { t: 1.0, prim: 0, u: 0.0, v: 0.0 }); 16];
            w.intersect_lanes(&lanes, &lanes.t_max, mask, &mut out);
            for (k, r) in rays.iter().enumerate() {
                let want = if mask & (1 << k) != 0 { w.intersect(&r.ray(), r.t_min, r.t_max) } else { None };
                assert_eq!(out[k], want, "round {round}, {level:?}, lane {k}: {r:?}");
                hits += usize::from(want.is_some());
                checked += 1;
            }
        }
    }
    assert!(hits > checked / 3 && hits < checked, "{hits} of {checked} lanes hit: both answers seen");
}
