//! AOVs: what they show is checked against what the scene holds, and `cost` against the
//! TP4 lesson (brute force tests every triangle; a BVH a handful).

use isir::aov::{render_aov, Aov, COLOR_BAR_ROWS};
use isir::{scenes, Accel, Color, Renderer};

fn aov(name: &str, accel: Accel, aov: Aov, w: u32, h: u32) -> (isir::Image, isir::aov::AovStats) {
    let desc = scenes::builtin(name).unwrap();
    let scene = desc.build(accel).unwrap();
    let camera = desc.camera.build(Renderer::new(w, h).aspect());
    render_aov(&scene, &camera, w, h, aov)
}

#[test]
fn cost_shows_the_tp4_lesson() {
    let (w, h) = (30, 20);
    let stats: Vec<_> = Accel::ALL.iter().map(|&a| aov("tp4-bunny", a, Aov::Cost, w, h).1).collect();
    let [none, aabb, mid, sah] = [stats[0], stats[1], stats[2], stats[3]];
    // Brute force: every ray tests the 31,599 triangles and the six planes, and nothing else.
    assert_eq!(none.tests_per_ray, 31_605.0);
    assert_eq!(none.nodes_per_ray, 0.0);
    // The box: one node per ray, all the triangles only for the rays that enter it.
    assert_eq!(aabb.nodes_per_ray, 1.0);
    assert!(aabb.tests_per_ray < none.tests_per_ray && aabb.tests_per_ray > 6.0, "{aabb:?}");
    // The BVHs: a few dozen tests where brute force made 31,605.
    assert!(mid.tests_per_ray < 100.0 && mid.nodes_per_ray > 1.0, "{mid:?}");
    assert!(sah.tests_per_ray < 100.0 && sah.nodes_per_ray >= 1.0, "{sah:?}");
    assert!(sah.nodes_per_ray + sah.tests_per_ray < mid.nodes_per_ray + mid.tests_per_ray, "{sah:?} vs {mid:?}");
}

#[test]
fn cost_images_carry_a_colour_bar_and_are_the_same_on_any_thread_count() {
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| aov("tp4-sphere", Accel::BvhMid, Aov::Cost, 40, 30))
    };
    let (a, sa) = run(1);
    let (b, sb) = run(2);
    assert_eq!(a.pixels, b.pixels);
    assert_eq!(sa, sb);
    assert_eq!(a.height, 30 + COLOR_BAR_ROWS);
    // The bar runs from the heat of 0 at the left to that of the maximum at the right.
    let y = 30 + COLOR_BAR_ROWS - 1;
    assert_eq!(a.get(0, y), isir::aov::heat(0.0));
    assert_eq!(a.get(39, y), isir::aov::heat(1.0));
}

#[test]
fn albedo_normal_and_depth_show_the_first_hit() {
    // TP1: the blue sphere at (0,0,3), r = 1, seen from the origin along +z.
    let (w, h) = (41, 31);
    let centre = (20, 15);
    let (albedo, _) = aov("tp1-sphere", Accel::BvhSah, Aov::Albedo, w, h);
    assert_eq!(albedo.get(centre.0, centre.1), Color::new(0.0, 0.0, 1.0));
    assert_eq!(albedo.get(0, 0), Color::splat(0.5), "the background where nothing is hit");
    let (normal, _) = aov("tp1-sphere", Accel::BvhSah, Aov::Normal, w, h);
    let n = normal.get(centre.0, centre.1) * 2.0 - 1.0;
    assert!((n - Color::new(0.0, 0.0, -1.0)).length() < 0.05, "facing the camera: {n}");
    let (depth, _) = aov("tp1-sphere", Accel::BvhSah, Aov::Depth, w, h);
    let d = depth.get(centre.0, centre.1).x;
    let hits: Vec<f32> = depth.pixels.iter().filter(|c| c.x < 1.0).map(|c| c.x).collect();
    assert!(d > 0.0 && hits.iter().all(|&x| x >= d - 1e-6), "the centre is the nearest point: {d}");
    assert_eq!(depth.get(0, 0), Color::ONE, "white where nothing is hit");
}
