//! Coincident and nested triangles (issue 8, item 2): no arrangement may turn closest-hit
//! traversal into a linear scan without a warning. Exact copies are hit as one (the first),
//! so rays stay fast; overlaps that cannot be removed are found and reported.

use isir::geometry::{MeshAccel, TriangleMesh};
use isir::wide::TraversalStats;
use isir::{Accel, Ray, Vec3};

fn mesh(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> TriangleMesh {
    let mut m = TriangleMesh::new(vertices, Vec::new(), triangles);
    m.build_accel(Accel::BvhSah);
    m
}

/// The most triangle tests of one ray, of a grid of rays through the triangle (0,0,0),
/// (1,0,0), (0,1,0) region along -z.
fn worst_tests(m: &TriangleMesh) -> u64 {
    let MeshAccel::Wide(w) = m.accel() else { panic!("not a wide BVH") };
    let mut worst = 0;
    for i in 0..16 {
        for j in 0..16 - i {
            let p = Vec3::new((i as f32 + 0.3) / 16.0, (j as f32 + 0.3) / 16.0, 1.0);
            let mut stats = TraversalStats::default();
            w.intersect_stats::<true>(&Ray::new(p, -Vec3::Z), 0.0, f32::INFINITY, &mut stats);
            worst = worst.max(stats.triangles);
        }
    }
    worst
}

#[test]
fn exact_copies_are_hit_as_one() {
    // 200,000 copies of one triangle, as written by a tool that duplicates faces, with
    // the vertices repeated, rotated and reversed.
    let (a, b, c) = (Vec3::ZERO, Vec3::X, Vec3::Y);
    let orders = [[a, b, c], [b, c, a], [c, b, a]];
    let n = 200_000;
    let vertices: Vec<Vec3> = (0..n).flat_map(|i| orders[i % 3]).collect();
    let triangles: Vec<[u32; 3]> = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    let mut m = mesh(vertices, triangles);
    assert!(worst_tests(&m) > 1000, "copies are no bad case any more");
    assert!(m.remove_overlaps().is_none());
    assert_eq!(m.stats().duplicates, n - 1);
    assert!(worst_tests(&m) <= 8, "{} tests for one ray", worst_tests(&m));
    let hit = m.intersect(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert_eq!(hit.prim, 0, "the first copy is the one hit");
    assert_eq!(m.intersect_brute_force(&Ray::new(Vec3::new(0.2, 0.2, 1.0), -Vec3::Z), 0.0, f32::INFINITY).unwrap().prim, 0);
    assert!(m.overlap_probe().is_none());
}

#[test]
fn nested_and_rotated_coplanar_triangles_are_reported() {
    // 20,000 coplanar triangles about one point, each a scaled or rotated copy of the
    // last: every ray through the centre must test them all, as in any renderer.
    let n = 20_000;
    let centre = Vec3::new(0.3, 0.3, 0.0);
    for rotate in [false, true] {
        let mut vertices = Vec::new();
        for i in 0..n {
            let (s, angle) = if rotate { (1.0, i as f32 * 0.001) } else { (1.0 - i as f32 / n as f32 * 0.9, 0.0) };
            for k in 0..3 {
                let a = angle + k as f32 * std::f32::consts::TAU / 3.0;
                vertices.push(centre + s * 0.3 * Vec3::new(a.cos(), a.sin(), 0.0));
            }
        }
        let triangles: Vec<[u32; 3]> = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let mut m = mesh(vertices, triangles);
        assert!(worst_tests(&m) > 1000, "rotate {rotate}: the arrangement is not a bad case any more");
        let (tests, at) = m.remove_overlaps().expect("the overlap is reported");
        assert_eq!(m.stats().duplicates, 0);
        assert!(tests > 1000 && (at - centre).length() < 0.3, "rotate {rotate}: {tests} tests at {at}");
    }
}

#[test]
fn stacked_copies_and_ordinary_meshes_are_quiet() {
    // Copies moved apart along the normal: the nearest is found first and the others are
    // culled by distance, so no warning is due.
    let n = 20_000;
    let vertices: Vec<Vec3> = (0..n).flat_map(|i| [Vec3::ZERO, Vec3::X, Vec3::Y].map(|v| v + Vec3::Z * (i as f32 * 1e-3))).collect();
    let triangles: Vec<[u32; 3]> = (0..n as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
    let mut m = mesh(vertices, triangles);
    assert!(worst_tests(&m) < 200, "{}", worst_tests(&m));
    assert!(m.remove_overlaps().is_none());
    assert_eq!(m.stats().duplicates, 0);
    for model in ["Bunny", "conference"] {
        let mut m = isir::scenes::load_builtin_model(model).unwrap().mesh;
        m.build_accel(Accel::BvhSah);
        assert!(m.overlap_probe().is_none(), "{model}: {:?}", m.overlap_probe());
    }
}

#[test]
fn a_file_of_copies_loads_with_warnings_and_renders_fast() {
    use isir::scenes::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc};
    let dir = std::env::temp_dir().join(format!("isir-overlap-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("copies.obj");
    let mut obj = String::from("v 0 0 0\nv 1 0 0\nv 0 1 0\n");
    obj.push_str(&"f 1 2 3\n".repeat(300_000));
    std::fs::write(&path, obj).unwrap();
    let mut desc = SceneDescription::new("copies", CameraDesc::new(Vec3::new(0.3, 0.3, 2.0), Vec3::new(0.3, 0.3, 0.0)));
    desc.objects.push(ObjectDesc {
        name: "copies".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::File(path), shading: Default::default() },
        material: None,
    });
    let scene = desc.build(Accel::BvhSah).unwrap();
    assert!(scene.warnings.iter().any(|w| w.contains("299999 duplicate triangles")), "{:?}", scene.warnings);
    assert!(!scene.warnings.iter().any(|w| w.contains("overlap")), "{:?}", scene.warnings);
    // Every ray through the triangle tests it once.
    let (_, m) = scene.meshes().next().unwrap();
    assert_eq!(worst_tests(m), 4, "one block of four lanes");
    std::fs::remove_dir_all(&dir).ok();
}
