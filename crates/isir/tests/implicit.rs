//! Implicit surfaces (TP7) seen through the scene: the sphere-traced sphere has the
//! analytic sphere's silhouette, shadow rays leaving an implicit surface do not hit it
//! again, bad descriptions are refused naming the object, and tp7-implicit casts shadows.

use isir::geometry::{Geometry, Implicit, Sdf, Sphere};
use isir::sampling::Sampler;
use isir::scene::Object;
use isir::scenes::{ObjectDesc, SceneDescription, ShapeDesc, MAX_COORDINATE};
use isir::{scenes, Accel, CameraDesc, Color, Light, Ray, Scene, Vec3};
use rayon::prelude::*;

fn scene_of(geometry: Geometry) -> Scene {
    Scene::new(
        vec![Object { name: "surface".into(), geometry, materials: vec![0] }],
        vec![isir::Material::Color(Color::ONE)],
        Vec::new(),
        Color::ZERO,
    )
}

fn implicit(sdf: Sdf) -> Geometry {
    Geometry::Implicit(Box::new(Implicit::new(sdf).unwrap()))
}

#[test]
fn the_sdf_sphere_has_the_analytic_silhouette() {
    let (c, r) = (Vec3::new(0.3, -0.2, 3.0), 1.0);
    let analytic = scene_of(Geometry::Sphere(Sphere::new(c, r)));
    let traced = scene_of(implicit(Sdf::sphere(c, r)));
    let (w, h) = (128, 96);
    for eye in [Vec3::new(0.0, 0.0, -2.0), Vec3::new(4.0, -1.0, 0.0)] {
        let camera = CameraDesc::new(eye, c).build(w as f32 / h as f32);
        let (mut disagree, mut both) = (0, 0);
        for y in 0..h {
            for x in 0..w {
                let ray = camera.generate_ray((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                let a = analytic.intersect(&ray, 0.0, f32::INFINITY);
                let b = traced.intersect(&ray, 0.0, f32::INFINITY);
                match (a, b) {
                    (Some(a), Some(b)) => {
                        both += 1;
                        // The march stops within 1e-4 of the surface; at grazing angles that
                        // is further along the ray.
                        assert!((a.t - b.t).abs() < 2e-2, "pixel ({x}, {y}): t {} against {}", b.t, a.t);
                        if a.normal.dot(-ray.direction) > 0.2 {
                            assert!((a.t - b.t).abs() < 1e-3, "pixel ({x}, {y}): t {} against {}", b.t, a.t);
                            assert!(a.normal.dot(b.normal) > 0.9999, "pixel ({x}, {y}): normal {} against {}", b.normal, a.normal);
                        }
                    }
                    (None, None) => {}
                    _ => disagree += 1,
                }
            }
        }
        assert!(both > 500, "the sphere covers {both} pixels");
        assert!(disagree <= 4, "{disagree} pixels hit one sphere and not the other (eye {eye})");
    }
}

/// Of `rays` camera rays from `eye` to random points of the box, the shadow rays towards
/// `light` from the hits whose outward normal faces it and are blocked within `near` of where they start
/// (any distance for a convex shape: it cannot shadow itself), and the number of hits.
fn self_hits(scene: &Scene, eye: Vec3, light: Vec3, rays: u32, near: f32) -> (u32, u32) {
    let Geometry::Implicit(imp) = &scene.objects[0].geometry else { unreachable!() };
    let b = imp.bounds();
    (0..rays / 1000)
        .into_par_iter()
        .map(|chunk| {
            let mut rng = Sampler::from_seed(u64::from(chunk) + 1);
            let (mut blocked, mut hits) = (0, 0);
            for _ in 0..1000 {
                let target = b.min + b.diagonal() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                let ray = Ray::new(eye, (target - eye).normalize());
                let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else { continue };
                hits += 1;
                // Only points whose outward normal faces the light: a ray grazing an edge
                // stops within the threshold of a face it does not enter, and the scene
                // turns that normal to face the ray, away from the light.
                if imp.normal(hit.point).dot((light - hit.point).normalize()) < 0.01 {
                    continue;
                }
                let Some((shadow, t_max)) = hit.spawn_ray_to(light) else { continue };
                if let Some(h) = scene.intersect(&shadow, 0.0, t_max) {
                    if h.t < near {
                        blocked += 1;
                    }
                }
            }
            (blocked, hits)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

#[test]
fn shadow_rays_leaving_implicit_surfaces_do_not_hit_them_again() {
    let tilt = glam::Quat::from_axis_angle(Vec3::new(1.0, 0.3, -0.4).normalize(), 0.7);
    let cases: Vec<(&str, Sdf, f32)> = vec![
        ("sphere", Sdf::sphere(Vec3::new(0.0, 0.0, 3.0), 1.0), f32::INFINITY),
        ("rounded box", Sdf::RoundedBox { half: Vec3::ONE, radius: 0.2 }.transformed(Vec3::new(0.0, 0.0, 3.0), tilt, 1.0), f32::INFINITY),
        ("capsule", Sdf::Capsule { a: Vec3::new(-1.0, 0.0, 2.5), b: Vec3::new(1.0, 0.5, 3.5), radius: 0.5 }, f32::INFINITY),
        (
            "box ∩ sphere",
            Sdf::Box { half: Vec3::splat(0.8) }.intersection(Sdf::Sphere { radius: 1.0 }).transformed(Vec3::new(0.0, 0.0, 3.0), tilt, 1.0),
            f32::INFINITY,
        ),
        ("torus", Sdf::Torus { major: 1.0, minor: 0.35 }.transformed(Vec3::new(0.0, 0.0, 3.0), tilt, 1.0), 1e-2),
        // Not convex: it may shadow itself, but not within 1e-2 of where a ray leaves it.
        // (Concave creases, as a box subtracted, legitimately shadow points beside them.)
        (
            "smooth union",
            Sdf::sphere(Vec3::new(-0.5, 0.0, 0.0), 0.8).smooth_union(Sdf::sphere(Vec3::new(0.6, 0.2, 0.0), 0.6), 0.6).transformed(
                Vec3::new(0.0, 0.0, 3.0),
                tilt,
                1.0,
            ),
            1e-2,
        ),
        ("sphere far away, scaled", Sdf::Sphere { radius: 1.0 }.transformed(Vec3::new(1e4, 0.0, 1e4 + 3.0), tilt, 20.0), f32::INFINITY),
    ];
    for (name, sdf, near) in cases {
        let scene = scene_of(implicit(sdf));
        let Geometry::Implicit(imp) = &scene.objects[0].geometry else { unreachable!() };
        let (c, size) = (imp.bounds().centroid(), imp.bounds().diagonal().length() * 0.5);
        let eye = c + Vec3::new(1.0, 2.5, -4.0) * size;
        let light = c + Vec3::new(-0.5, 6.0, 1.0) * size;
        let (blocked, hits) = self_hits(&scene, eye, light, 200_000, near);
        assert!(hits > 30_000, "{name}: only {hits} camera rays hit");
        assert_eq!(blocked, 0, "{name}: {blocked} of {hits} shadow rays hit the surface they leave");
    }
}

fn room_with(shape: ShapeDesc) -> SceneDescription {
    let mut d = SceneDescription::new("test", CameraDesc::new(Vec3::new(0.0, 0.0, -5.0), Vec3::ZERO));
    d.objects.push(ObjectDesc { name: "Thing".into(), shape, material: None });
    d.lights.push(Light::Point { position: Vec3::new(0.0, 5.0, 0.0), color: Color::ONE, power: 10.0 });
    d
}

#[test]
fn bad_implicit_objects_are_refused_naming_them() {
    for (sdf, needle) in [
        (Sdf::Torus { major: f32::NAN, minor: 0.2 }, "torus"),
        (Sdf::Capsule { a: Vec3::ZERO, b: Vec3::ONE, radius: 0.0 }, "capsule"),
        (Sdf::plane(Vec3::Y, 0.0), "unbounded"),
        (Sdf::sphere(Vec3::new(0.0, 0.0, 1e13), 1.0), "beyond"),
        (Sdf::sphere(Vec3::ZERO, MAX_COORDINATE * 2.0), "beyond"),
    ] {
        let err = room_with(ShapeDesc::Implicit(sdf)).build(Accel::BvhSah).unwrap_err().to_string();
        assert!(err.contains("object 'Thing'") && err.contains(needle), "{err}");
    }
    // Empty (an intersection of shapes that do not meet): built, with a warning naming it.
    let empty = Sdf::sphere(Vec3::ZERO, 1.0).intersection(Sdf::sphere(Vec3::new(3.0, 0.0, 0.0), 1.0));
    let scene = room_with(ShapeDesc::Implicit(empty)).build(Accel::BvhSah).unwrap();
    assert!(scene.warnings.iter().any(|w| w.starts_with("Thing:") && w.contains("empty")), "{:?}", scene.warnings);
}

#[test]
fn tp7_implicit_casts_shadows_and_renders_finite_pixels() {
    let desc = scenes::builtin("tp7-implicit").unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    assert!(scene.objects.iter().filter(|o| matches!(o.geometry, Geometry::Implicit(_))).count() >= 4);
    let light = Vec3::new(0.0, 5.0, 0.0);
    let blocked = |p: Vec3| {
        let (ray, t_max) = (Ray::new(p, (light - p).normalize()), (light - p).length());
        scene.occluded(&ray, 0.0, t_max)
    };
    // The ground under each implicit object, away from the light, is in its shadow.
    for o in &scene.objects {
        if let Geometry::Implicit(imp) = &o.geometry {
            // A point well inside the object, from a grid over its box.
            let (b, n) = (imp.bounds(), 16);
            let c = (0..n * n * n)
                .map(|i| b.min + b.diagonal() * Vec3::new((i % n) as f32, ((i / n) % n) as f32, (i / (n * n)) as f32) / (n - 1) as f32)
                .find(|&p| imp.sdf().distance(p) < -0.1)
                .unwrap();
            let ground = light + (c - light) * ((light.y + 3.0 - 1e-3) / (light.y - c.y));
            assert!(blocked(ground), "{}: no shadow at {ground}", o.name);
        }
    }
    assert!(!blocked(Vec3::new(0.0, -2.999, -2.0)), "the open floor is lit");
    let renderer = isir::Renderer::new(48, 32).spp(1);
    let (image, _) = renderer.render(&scene, &desc.camera.build(renderer.aspect()), &desc.integrator);
    assert!(image.pixels.iter().all(|p| p.is_finite() && p.min_element() >= 0.0));
}
