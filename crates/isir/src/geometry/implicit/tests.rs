use super::*;
use crate::math::sampling::Sampler;
use glam::Quat;

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() < 1e-5
}

#[test]
fn primitive_distances_by_hand() {
    let s = Sdf::Sphere { radius: 2.0 };
    assert!(close(s.distance(Vec3::new(0.0, 2.0, 0.0)), 0.0));
    assert!(close(s.distance(Vec3::ZERO), -2.0));
    assert!(close(s.distance(Vec3::new(3.0, 4.0, 0.0)), 3.0));

    // Torus R = 2, r = 0.5 in the xz plane.
    let t = Sdf::Torus { major: 2.0, minor: 0.5 };
    assert!(close(t.distance(Vec3::new(2.5, 0.0, 0.0)), 0.0));
    assert!(close(t.distance(Vec3::new(0.0, 0.0, -2.0)), -0.5));
    assert!(close(t.distance(Vec3::ZERO), 1.5));
    assert!(close(t.distance(Vec3::new(2.0, 3.0, 0.0)), 2.5));

    // Box of half sizes (1, 2, 3).
    let b = Sdf::Box { half: Vec3::new(1.0, 2.0, 3.0) };
    assert!(close(b.distance(Vec3::new(1.0, 0.0, 0.0)), 0.0));
    assert!(close(b.distance(Vec3::ZERO), -1.0));
    assert!(close(b.distance(Vec3::new(0.0, 0.0, 5.0)), 2.0));
    assert!(close(b.distance(Vec3::new(4.0, 6.0, 0.0)), 5.0)); // from the edge (1, 2): (3, 4)

    // Rounded box: the corner is rounded off by r.
    let rb = Sdf::RoundedBox { half: Vec3::ONE, radius: 0.25 };
    assert!(close(rb.distance(Vec3::new(1.0, 0.0, 0.0)), 0.0));
    assert!(close(rb.distance(Vec3::new(3.0, 0.0, 0.0)), 2.0));
    let corner = Vec3::splat(0.75) + Vec3::splat(0.25 / 3f32.sqrt());
    assert!(close(rb.distance(corner), 0.0));
    assert!(rb.distance(Vec3::ONE) > 0.1, "the sharp corner is outside the rounded box");
    assert!(close(rb.distance(Vec3::ZERO), -1.0));

    // Capsule from (0,0,0) to (0,2,0), r = 0.5.
    let c = Sdf::Capsule { a: Vec3::ZERO, b: Vec3::new(0.0, 2.0, 0.0), radius: 0.5 };
    assert!(close(c.distance(Vec3::new(0.5, 1.0, 0.0)), 0.0));
    assert!(close(c.distance(Vec3::new(0.0, 1.0, 0.0)), -0.5));
    assert!(close(c.distance(Vec3::new(0.0, 4.0, 0.0)), 1.5));
    assert!(close(c.distance(Vec3::new(0.0, -1.5, 0.0)), 1.0));
    // Both ends equal: a sphere.
    let dot = Sdf::Capsule { a: Vec3::ONE, b: Vec3::ONE, radius: 0.5 };
    assert!(close(dot.distance(Vec3::new(1.0, 3.0, 1.0)), 1.5));

    // Half-space y < 1.
    let p = Sdf::plane(Vec3::Y, 1.0);
    assert!(close(p.distance(Vec3::new(7.0, 1.0, -3.0)), 0.0));
    assert!(close(p.distance(Vec3::new(0.0, 4.0, 0.0)), 3.0));
    assert!(close(p.distance(Vec3::new(0.0, -1.0, 0.0)), -2.0));
}

#[test]
fn transforms_scale_distances_back() {
    let s = Sdf::Sphere { radius: 1.0 }.transformed(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_y(0.7), 2.0);
    // A sphere of radius 2 about (1, 2, 3): exact distances in world units.
    assert!(close(s.distance(Vec3::new(1.0, 2.0, 8.0)), 3.0));
    assert!(close(s.distance(Vec3::new(1.0, 2.0, 3.0)), -2.0));
    // A box rotated 90° about z swaps its x and y sizes.
    let b = Sdf::Box { half: Vec3::new(2.0, 1.0, 1.0) }.transformed(Vec3::ZERO, Quat::from_rotation_z(std::f32::consts::FRAC_PI_2), 1.0);
    assert!(close(b.distance(Vec3::new(0.0, 2.0, 0.0)), 0.0));
    assert!(close(b.distance(Vec3::new(3.0, 0.0, 0.0)), 2.0));
}

#[test]
fn operators() {
    let a = Sdf::sphere(Vec3::new(-1.0, 0.0, 0.0), 1.5);
    let b = Sdf::sphere(Vec3::new(1.0, 0.0, 0.0), 1.5);
    let mut rng = Sampler::from_seed(7);
    let (u, i, s) = (a.clone().union(b.clone()), a.clone().intersection(b.clone()), a.clone().subtract(b.clone()));
    let k = 0.5;
    let smooth = a.clone().smooth_union(b.clone(), k);
    let mut blended = 0;
    for _ in 0..10_000 {
        let p = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 8.0 - Vec3::splat(4.0);
        let (da, db) = (a.distance(p), b.distance(p));
        assert_eq!(u.distance(p), da.min(db));
        assert_eq!(i.distance(p), da.max(db));
        assert_eq!(s.distance(p), da.max(-db));
        let sm = smooth.distance(p);
        assert!(sm <= da.min(db) && sm >= da.min(db) - k / 4.0, "smooth union at {p}: {sm} vs {da}, {db}");
        if (da - db).abs() >= k {
            assert_eq!(sm, da.min(db), "far from the blend the smooth union is the union");
        } else {
            blended += 1;
        }
    }
    assert!(blended > 100);
    // In the neck between the spheres the blend fills: the point (0, 1.2, 0) is outside both
    // spheres and the union, inside the smooth union with k = 1.
    let neck = Vec3::new(0.0, 1.2, 0.0);
    assert!(u.distance(neck) > 0.0 && a.smooth_union(b, 1.0).distance(neck) < 0.0);
    assert_eq!(smooth_min(1.0, 3.0, 0.5), 1.0);
    assert!(close(smooth_min(1.0, 1.0, 0.5), 1.0 - 0.125));
}

/// Shapes of every kind, placed and combined, for the box and tracing tests.
fn zoo() -> Vec<(&'static str, Sdf)> {
    let rot = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 0.5).normalize(), 0.8);
    vec![
        ("sphere", Sdf::sphere(Vec3::new(0.5, -0.2, 0.3), 1.1)),
        ("torus", Sdf::Torus { major: 1.0, minor: 0.3 }.transformed(Vec3::new(0.2, 0.1, 0.0), rot, 1.3)),
        ("box", Sdf::Box { half: Vec3::new(0.5, 1.0, 0.25) }.transformed(Vec3::ZERO, rot, 1.0)),
        ("rounded box", Sdf::RoundedBox { half: Vec3::new(1.0, 0.6, 0.8), radius: 0.3 }.transformed(Vec3::X, rot, 0.7)),
        ("capsule", Sdf::Capsule { a: Vec3::new(-1.0, -0.5, 0.0), b: Vec3::new(0.8, 1.0, 0.3), radius: 0.4 }),
        ("plane ∩ sphere", Sdf::sphere(Vec3::ZERO, 1.2).intersection(Sdf::plane(Vec3::Y, 0.3))),
        ("tilted plane ∩ box", Sdf::Box { half: Vec3::ONE }.intersection(Sdf::plane(Vec3::new(1.0, 1.0, 1.0), 0.5))),
        ("union", Sdf::sphere(Vec3::new(-1.0, 0.0, 0.0), 0.7).union(Sdf::Box { half: Vec3::splat(0.5) }.translated(Vec3::X))),
        ("subtraction", Sdf::Box { half: Vec3::ONE }.subtract(Sdf::sphere(Vec3::new(0.0, 0.0, -1.0), 0.9))),
        (
            "smooth union",
            Sdf::sphere(Vec3::new(-0.6, 0.0, 0.0), 0.7).smooth_union(Sdf::sphere(Vec3::new(0.6, 0.3, 0.0), 0.5), 0.8).transformed(
                Vec3::new(0.0, 0.5, 0.0),
                rot,
                1.5,
            ),
        ),
    ]
}

#[test]
fn boxes_hold_the_surface_and_the_inside() {
    for (name, sdf) in zoo() {
        let imp = Implicit::new(sdf.clone()).unwrap();
        let b = sdf.bounds();
        assert!(b.min.is_finite() && b.max.is_finite(), "{name}: {b:?}");
        // A 48³ grid over a region larger than the box.
        let (lo, hi) = (b.min - Vec3::ONE, b.max + Vec3::ONE);
        let n = 48;
        let step = (hi - lo) / (n - 1) as f32;
        let eps = 0.5 * step.max_element();
        let (mut near, mut inside) = (0, 0);
        for i in 0..n * n * n {
            let p = lo + step * Vec3::new((i % n) as f32, ((i / n) % n) as f32, (i / (n * n)) as f32);
            let d = sdf.distance(p);
            if d < eps {
                // Within eps of the surface or inside: within eps of the box.
                let grown = Aabb::new(b.min - Vec3::splat(eps), b.max + Vec3::splat(eps));
                assert!(p.cmpge(grown.min).all() && p.cmple(grown.max).all(), "{name}: {p} (distance {d}) outside {b:?}");
                near += usize::from(d.abs() < eps);
                inside += usize::from(d < 0.0);
                assert!(p.cmpge(imp.bounds().min - eps).all() && p.cmple(imp.bounds().max + eps).all());
            }
        }
        assert!(near > 50 && inside > 50, "{name}: the grid found {near} points near the surface, {inside} inside");
    }
}

#[test]
fn sphere_gradient_is_the_analytic_normal() {
    let c = Vec3::new(0.3, -1.0, 2.0);
    let imp = Implicit::new(Sdf::sphere(c, 1.5)).unwrap();
    let mut rng = Sampler::from_seed(3);
    for _ in 0..1000 {
        let dir = (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5).normalize();
        let p = c + 1.5 * dir;
        let n = imp.normal(p);
        assert!((n.length() - 1.0).abs() < 1e-5);
        assert!(n.dot(dir) > 0.99999, "normal {n} at {p}, analytic {dir}");
    }
    // At the centre the gradient vanishes: a unit normal anyway, not NaN.
    assert!(imp.normal(c).is_finite());
}

#[test]
fn rays_hit_miss_graze_and_start_inside() {
    let imp = Implicit::new(Sdf::sphere(Vec3::new(0.0, 0.0, 3.0), 1.0)).unwrap();
    let t = imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert!((t - 2.0).abs() < 2.0 * MIN_DISTANCE, "{t}");
    // A direction of length 2: t in units of the direction.
    let t = imp.intersect(&Ray::new(Vec3::ZERO, 2.0 * Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert!((t - 1.0).abs() < MIN_DISTANCE, "{t}");
    // Interval before the sphere, and beyond it.
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 0.0, 1.9), None);
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 4.1, f32::INFINITY), None);
    // A miss and grazing rays, tangent to the sphere and just inside or outside: all end.
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Y), 0.0, f32::INFINITY), None);
    for x in [1.0f32, 1.0 - 1e-4, 1.0 + 1e-4, 0.9999999, 1.0000001] {
        let r = Ray::new(Vec3::new(x, 0.0, -10.0), Vec3::Z);
        if let Some(t) = imp.intersect(&r, 0.0, f32::MAX) {
            assert!((r.at(t) - Vec3::new(0.0, 0.0, 3.0)).length() < 1.001, "x = {x}: t = {t}");
        }
    }
    // Starting inside: the ray reaches the surface it leaves by.
    let t = imp.intersect(&Ray::new(Vec3::new(0.0, 0.0, 3.0), Vec3::X), 0.0, f32::INFINITY).unwrap();
    assert!((t - 1.0).abs() < 2.0 * MIN_DISTANCE, "{t}");
    // Huge t_max, huge t_min, NaN rays and intervals.
    assert!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 0.0, f32::MAX).is_some());
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), f32::MAX, f32::INFINITY), None);
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::new(f32::NAN, 0.0, 1.0)), 0.0, f32::INFINITY), None);
    assert_eq!(imp.intersect(&Ray::new(Vec3::splat(f32::NAN), Vec3::Z), 0.0, f32::INFINITY), None);
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::ZERO), 0.0, f32::INFINITY), None);
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), f32::NAN, f32::INFINITY), None);
    assert_eq!(imp.intersect(&Ray::new(Vec3::ZERO, Vec3::Z), 0.0, f32::NAN), None);
    // Far from the origin the threshold grows with the coordinates, so rays still hit.
    let far = Implicit::new(Sdf::sphere(Vec3::new(1e6, 0.0, 1e6), 10.0)).unwrap();
    let t = far.intersect(&Ray::new(Vec3::new(1e6, 0.0, 1e6 - 1000.0), Vec3::Z), 0.0, f32::INFINITY).unwrap();
    assert!((t - 990.0).abs() < 1.0, "{t}");
}

#[test]
fn rays_along_every_shape_end_and_agree_with_the_function() {
    // Random rays through every shape of the zoo: each ends (bounded steps), and a hit is
    // within the threshold of the surface, with a unit normal.
    let mut rng = Sampler::from_seed(11);
    for (name, sdf) in zoo() {
        let imp = Implicit::new(sdf.clone()).unwrap();
        let c = imp.bounds().centroid();
        let mut hits = 0;
        for _ in 0..2000 {
            let o = c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 12.0;
            let target = c + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * 2.0;
            let r = Ray::new(o, (target - o).normalize());
            if let Some(t) = imp.intersect(&r, 0.0, f32::INFINITY) {
                hits += 1;
                let p = r.at(t);
                assert!(sdf.distance(p).abs() <= hit_threshold(p) * 1.01, "{name}: {}", sdf.distance(p));
                assert!((imp.normal(p).length() - 1.0).abs() < 1e-4);
            }
        }
        assert!(hits > 100, "{name}: {hits} hits");
    }
}

#[test]
fn bad_trees_are_refused_with_the_node_named() {
    let cases: Vec<(Sdf, &str)> = vec![
        (Sdf::Sphere { radius: 0.0 }, "sphere"),
        (Sdf::Sphere { radius: f32::NAN }, "sphere"),
        (Sdf::Torus { major: 1.0, minor: -0.1 }, "torus"),
        (Sdf::Box { half: Vec3::new(1.0, f32::INFINITY, 1.0) }, "box"),
        (Sdf::RoundedBox { half: Vec3::ONE, radius: 1.5 }, "rounded box"),
        (Sdf::Capsule { a: Vec3::splat(f32::NAN), b: Vec3::ONE, radius: 1.0 }, "capsule"),
        (Sdf::Box { half: Vec3::ONE }.intersection(Sdf::plane(Vec3::ZERO, 1.0)), "plane"),
        (Sdf::Sphere { radius: 1.0 }.smooth_union(Sdf::Sphere { radius: 1.0 }, 0.0), "smooth union"),
        (Sdf::Sphere { radius: 1.0 }.transformed(Vec3::ZERO, Quat::IDENTITY, -1.0), "transform"),
        (Sdf::Sphere { radius: 1.0 }.translated(Vec3::new(f32::NAN, 0.0, 0.0)), "transform"),
        (Sdf::plane(Vec3::Y, 0.0), "unbounded"),
        (
            Sdf::Box { half: Vec3::ONE }
                .intersection(Sdf::plane(Vec3::Y, 0.0).translated(Vec3::ONE).transformed(Vec3::ZERO, Quat::from_rotation_x(0.3), 1.0))
                .union(Sdf::plane(Vec3::X, 0.0)),
            "unbounded",
        ),
    ];
    for (sdf, needle) in cases {
        let err = Implicit::new(sdf.clone()).unwrap_err();
        assert!(err.contains(needle), "{sdf:?}: {err}");
    }
    // Too deep a tree is refused before it is evaluated.
    let mut deep = Sdf::Sphere { radius: 1.0 };
    for _ in 0..100 {
        deep = deep.translated(Vec3::X);
    }
    assert!(Implicit::new(deep).unwrap_err().contains("deeper"));
    // An intersection of shapes that do not meet: empty box, never hit.
    let empty = Implicit::new(Sdf::sphere(Vec3::ZERO, 1.0).intersection(Sdf::sphere(Vec3::new(5.0, 0.0, 0.0), 1.0))).unwrap();
    assert!(empty.bounds().is_empty());
    assert_eq!(empty.intersect(&Ray::new(Vec3::new(-5.0, 0.0, 0.0), Vec3::X), 0.0, f32::INFINITY), None);
}

#[test]
fn a_ray_skimming_a_long_face_ends_after_the_step_limit() {
    // Parallel to the top face of a box 2,000 long, 2e-4 above it: every step is 2e-4, so
    // the march would need 10^7 steps to cross; it stops at MAX_STEPS and reports no hit.
    let slab = Implicit::new(Sdf::Box { half: Vec3::new(1000.0, 1.0, 1.0) }).unwrap();
    let skim = Ray::new(Vec3::new(-1500.0, 1.0 + 2e-4 + 1000.0 / 1_048_576.0, 0.0), Vec3::X);
    let start = std::time::Instant::now();
    assert_eq!(slab.intersect(&skim, 0.0, f32::INFINITY), None);
    assert!(start.elapsed().as_millis() < 100);
    // The same ray a little lower hits the top face's edge region within the threshold.
    let touching = Ray::new(Vec3::new(-1500.0, 1.0 + 0.5e-4, 0.0), Vec3::X);
    let t = slab.intersect(&touching, 0.0, f32::INFINITY).unwrap();
    assert!((t - 500.0).abs() < 1.0, "{t}");
}
