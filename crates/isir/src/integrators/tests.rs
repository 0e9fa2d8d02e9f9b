//! Whitted and the path tracer against cases whose answer is known.

use super::*;
use crate::geometry::{Geometry, Plane, Sphere};
use crate::lights::Light;
use crate::materials::fresnel_dielectric;
use crate::math::color::{BLACK, BLUE, GREY, RED, WHITE};
use crate::renderer::Renderer;
use crate::scene::Object;
use crate::scenes::CameraDesc;
use glam::Vec3;

/// A scene of objects `(geometry, material)`, lights and a background.
fn scene(objects: Vec<(Geometry, Material)>, lights: Vec<Light>, background: Color) -> Scene {
    let mut materials = Vec::new();
    let objects = objects
        .into_iter()
        .enumerate()
        .map(|(i, (geometry, m))| {
            materials.push(m);
            Object { name: format!("object {i}"), geometry, materials: vec![i as u32] }
        })
        .collect();
    Scene::new(objects, materials, lights, background)
}

fn plane(p: Vec3, n: Vec3) -> Geometry {
    Geometry::Plane(Plane::new(p, n))
}

fn li(integrator: Integrator, scene: &Scene, ray: &Ray) -> (Color, RayCounters) {
    let mut counters = RayCounters::default();
    let c = integrator.li(scene, ray, 0.0, f32::INFINITY, &mut Sampler::from_seed(1), &mut counters);
    (c, counters)
}

const WHITTED: Integrator = Integrator::Whitted { light_samples: 1, max_depth: DEFAULT_MAX_DEPTH };

#[test]
fn a_ray_through_a_glass_slab_leaves_parallel_to_how_it_entered() {
    // Glass between y = -1 and y = 0: the top's outside is up, the bottom's is down.
    let glass = Material::Transparent { ior: 1.5 };
    let s = scene(vec![(plane(Vec3::ZERO, Vec3::Y), glass.clone()), (plane(Vec3::new(0.0, -1.0, 0.0), -Vec3::Y), glass)], vec![], GREY);
    for d in [Vec3::new(1.0, -2.0, 0.5), Vec3::new(-0.3, -1.0, 0.0), Vec3::new(2.0, -1.0, 1.0)] {
        let d = d.normalize();
        let ray = Ray::new(Vec3::new(0.2, 5.0, -0.4), d);
        let top = s.intersect(&ray, 0.0, f32::INFINITY).unwrap();
        assert!(top.front_face, "entering");
        let split_in = specular_split(s.material(&top), &top, -d).unwrap();
        let inside = split_in.refracted.expect("air to glass always refracts");
        assert!((inside - d).length() > 1e-2, "bent towards the normal: {inside} vs {d}");
        let inner = top.spawn_ray(inside);
        let bottom = s.intersect(&inner, 0.0, f32::INFINITY).unwrap();
        assert!(!bottom.front_face && bottom.object == 1, "leaving through the bottom");
        let split_out = specular_split(s.material(&bottom), &bottom, -inside).unwrap();
        let out = split_out.refracted.expect("parallel faces: no total internal reflection");
        assert!((out - d).length() < 1e-5, "leaves parallel: {out} vs {d}");
        // Shifted sideways, not on the entering line.
        let offset = (bottom.point - ray.origin) - (bottom.point - ray.origin).dot(d) * d;
        assert!(offset.length() > 1e-2, "{offset}");
        // Fresnel is the same both ways through the slab.
        assert!((split_in.kr - split_out.kr).abs() < 1e-5, "{} vs {}", split_in.kr, split_out.kr);
    }
}

#[test]
fn total_internal_reflection_happens_past_the_critical_angle_and_not_before() {
    // Inside glass (below y = 0, ior 1.5) looking up at the surface: the critical angle is
    // asin(1/1.5) = 41.81°. What is refracted sees the blue sky; what is reflected sees a
    // red floor at y = -10 lit by a light at y = -5.
    let s = scene(
        vec![
            (plane(Vec3::ZERO, Vec3::Y), Material::Transparent { ior: 1.5 }),
            (plane(Vec3::new(0.0, -10.0, 0.0), Vec3::Y), Material::Color(RED)),
        ],
        vec![Light::Point { position: Vec3::new(0.0, -5.0, 0.0), color: WHITE, power: 10.0 }],
        BLUE,
    );
    let critical = (1.0f32 / 1.5).asin().to_degrees();
    for degrees in [0.0, 20.0, 40.0, 41.5, 42.0, 45.0, 70.0] {
        let theta = f32::to_radians(degrees);
        let d = Vec3::new(theta.sin(), theta.cos(), 0.0);
        let (c, counters) = li(WHITTED, &s, &Ray::new(Vec3::new(0.0, -1.0, 0.0), d));
        assert!(c.x > 0.0, "{degrees}°: the reflection of the red floor is always seen: {c}");
        if degrees < critical {
            let kr = fresnel_dielectric(theta.cos(), 1.0 / 1.5);
            assert!((c.z - (1.0 - kr)).abs() < 1e-5, "{degrees}°: (1 - kr) of the sky, kr = {kr}: {c}");
            assert_eq!(counters.secondary, 2, "{degrees}°: reflected and refracted");
        } else {
            assert_eq!(c.z, 0.0, "{degrees}°: total internal reflection, no sky: {c}");
            assert_eq!(counters.secondary, 1, "{degrees}°: reflected only");
        }
    }
}

#[test]
fn a_mirror_facing_a_lit_surface_shows_it() {
    // A mirror at z = 5 facing the origin; behind the origin a surface at z = -5 facing
    // the mirror, lit by a light at z = -2 (3 away: radiance 10/9).
    let colour = Vec3::new(0.8, 0.4, 0.1);
    let s = scene(
        vec![
            (plane(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z), Material::Mirror),
            (plane(Vec3::new(0.0, 0.0, -5.0), Vec3::Z), Material::Color(colour)),
        ],
        vec![Light::Point { position: Vec3::new(0.0, 0.0, -2.0), color: WHITE, power: 10.0 }],
        GREY,
    );
    let ray = Ray::new(Vec3::ZERO, Vec3::Z);
    let (c, counters) = li(WHITTED, &s, &ray);
    assert!((c - colour * 10.0 / 9.0).abs().max_element() < 1e-5, "{c}");
    assert_eq!((counters.primary, counters.secondary), (1, 1));
    // Direct lighting sees the mirror itself: black.
    assert_eq!(li(Integrator::DirectLighting { light_samples: 1 }, &s, &ray).0, BLACK);
}

#[test]
fn max_depth_bounds_the_recursion_between_facing_mirrors() {
    let mirrors = vec![
        (plane(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z), Material::Mirror),
        (plane(Vec3::new(0.0, 0.0, -5.0), Vec3::Z), Material::Mirror),
        (plane(Vec3::new(4.0, 0.0, 0.0), -Vec3::X), Material::Color(WHITE)),
    ];
    let s = scene(mirrors, vec![Light::Point { position: Vec3::new(2.0, 0.0, 0.0), color: WHITE, power: 10.0 }], GREY);
    // Straight between the mirrors: black after max_depth bounces, max_depth rays.
    for max_depth in [1, 5, 9, 200] {
        let w = Integrator::Whitted { light_samples: 1, max_depth };
        let (c, counters) = li(w, &s, &Ray::new(Vec3::ZERO, Vec3::Z));
        assert_eq!(c, BLACK);
        assert_eq!((counters.primary, counters.secondary), (1, u64::from(max_depth)));
    }
    // Drifting by 1 in x per 10 in z, the ray reaches the lit wall at x = 4 after four
    // bounces (at x = 0.5, 1.5, 2.5, 3.5).
    let ray = Ray::new(Vec3::ZERO, Vec3::new(0.1, 0.0, 1.0).normalize());
    for (max_depth, lit) in [(3, false), (4, true), (5, true)] {
        let (c, _) = li(Integrator::Whitted { light_samples: 1, max_depth }, &s, &ray);
        assert_eq!(c.x > 0.0, lit, "max depth {max_depth}: {c}");
    }
}

/// Render `s` with `integrator` from `camera` at `w × h`, `spp`.
fn render(s: &Scene, camera: &CameraDesc, integrator: Integrator, w: u32, h: u32, spp: u32) -> (crate::Image, crate::RenderStats) {
    render_seeded(s, camera, integrator, w, h, spp, 3)
}

/// [`render`] with a seed.
fn render_seeded(
    s: &Scene,
    camera: &CameraDesc,
    integrator: Integrator,
    w: u32,
    h: u32,
    spp: u32,
    seed: u64,
) -> (crate::Image, crate::RenderStats) {
    let r = Renderer::new(w, h).spp(spp).seed(seed);
    r.render(s, &camera.build(r.aspect()), &integrator)
}

/// TP2/TP3's sphere over a plane, in Lambert materials, on black.
fn lambert_scene(light: Light) -> (Scene, CameraDesc) {
    let s = scene(
        vec![
            (Geometry::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0)), Material::Lambert(Vec3::new(0.3, 0.5, 0.8))),
            (plane(Vec3::new(0.0, -2.0, 0.0), Vec3::Y), Material::Lambert(Vec3::new(0.8, 0.6, 0.4))),
        ],
        vec![light],
        BLACK,
    );
    (s, CameraDesc::new(Vec3::new(0.0, 1.0, -3.0), Vec3::new(0.0, -1.0, 3.0)))
}

/// Over the pixels the reference lights: the relative difference of the two images'
/// sums, and the mean of the pixels' relative differences.
fn relative_differences(a: &crate::Image, reference: &crate::Image) -> (f32, f32, usize) {
    let lum = |c: &Color| c.x + c.y + c.z;
    let lit: Vec<(f32, f32)> = a.pixels.iter().zip(&reference.pixels).map(|(a, r)| (lum(a), lum(r))).filter(|&(_, r)| r > 1e-3).collect();
    let (sa, sr) = lit.iter().fold((0.0, 0.0), |(x, y), (a, r)| (x + a, y + r));
    let mean = lit.iter().map(|(a, r)| (a - r).abs() / r).sum::<f32>() / lit.len() as f32;
    ((sa - sr).abs() / sr, mean, lit.len())
}

#[test]
fn path_tracing_to_depth_one_converges_to_direct_lighting() {
    // A point light: both integrators take the same one sample, the BSDF rays escape.
    let (s, cam) = lambert_scene(Light::Point { position: Vec3::new(1.0, 10.0, 1.0), color: WHITE, power: 100.0 });
    let (direct, _) = render(&s, &cam, Integrator::DirectLighting { light_samples: 1 }, 48, 32, 4);
    let (path, stats) = render(&s, &cam, Integrator::Path { light_samples: 1, max_depth: 1 }, 48, 32, 4);
    let (of_sums, mean, lit) = relative_differences(&path, &direct);
    assert!(lit > 1000, "{lit} lit pixels");
    assert!(of_sums < 1e-4 && mean < 1e-4, "point light: {of_sums} {mean}");
    assert!(stats.samples.all_good());
    // TP3's quad light: light samples and BSDF samples weighted by MIS, against direct
    // lighting with as many light samples.
    let quad = Light::Quad {
        corner: Vec3::new(1.0, 10.0, 2.0),
        u: Vec3::new(-2.0, 0.0, 0.0),
        v: Vec3::new(0.0, 0.0, 2.0),
        color: WHITE,
        power: 40.0,
    };
    let (s, cam) = lambert_scene(quad);
    let (direct, _) = render(&s, &cam, Integrator::DirectLighting { light_samples: 8 }, 48, 32, 64);
    let (path, stats) = render(&s, &cam, Integrator::Path { light_samples: 8, max_depth: 1 }, 48, 32, 64);
    let (of_sums, mean, lit) = relative_differences(&path, &direct);
    eprintln!("quad light: relative difference of the sums {of_sums:.5}, mean per pixel {mean:.5} over {lit} pixels");
    assert!(lit > 1000, "{lit} lit pixels");
    assert!(of_sums < 0.01 && mean < 0.01, "quad light: {of_sums} {mean}");
    assert!(stats.samples.all_good() && stats.rays.secondary > 0);
    // A 6×6 quad light 5 above the floor (out of the camera's view): BSDF sampling finds
    // it often and MIS weighs the two strategies evenly. Other random numbers than the
    // reference's, which has 16384 light samples per pixel.
    let big = Light::Quad {
        corner: Vec3::new(3.0, 3.0, -2.0),
        u: Vec3::new(-6.0, 0.0, 0.0),
        v: Vec3::new(0.0, 0.0, 6.0),
        color: WHITE,
        power: 2.0,
    };
    let (s, cam) = lambert_scene(big);
    let (direct, _) = render_seeded(&s, &cam, Integrator::DirectLighting { light_samples: 16 }, 24, 16, 1024, 1);
    let (path, stats) = render_seeded(&s, &cam, Integrator::Path { light_samples: 4, max_depth: 1 }, 24, 16, 4096, 2);
    let (of_sums, mean, lit) = relative_differences(&path, &direct);
    eprintln!("large quad light: relative difference of the sums {of_sums:.5}, mean per pixel {mean:.5} over {lit} pixels");
    assert!(lit > 250, "{lit} lit pixels");
    assert!(of_sums < 0.01, "large quad light: the images' sums differ by {of_sums}");
    assert!(mean < 0.01, "large quad light: pixels differ by {mean} on average");
    assert!(stats.samples.all_good());
}

#[test]
fn a_closed_diffuse_sphere_around_a_point_light_converges_to_its_analytic_radiance() {
    // An integrating sphere: inside a Lambert sphere of radius R and albedo a, a point
    // light of intensity I at the centre gives every wall point the irradiance
    // E = I/R². A sphere's wall sees every other wall point with the same form factor
    // (dA / 4πR²), so the wall's radiance is uniform, L = (a/π)(E + πL), and with
    // paths of at most D bounces L_D = (E/π)(a + a² + ... + a^D) -> (E/π)·a/(1 - a).
    let (r, a, intensity) = (2.0f32, 0.5f32, 10.0f32);
    let s = scene(
        vec![(Geometry::Sphere(Sphere::new(Vec3::ZERO, r)), Material::Lambert(Vec3::splat(a)))],
        vec![Light::Point { position: Vec3::ZERO, color: WHITE, power: intensity }],
        GREY,
    );
    let e = intensity / (r * r);
    let l_depth = |d: i32| e / std::f32::consts::PI * (1..=d).map(|k| a.powi(k)).sum::<f32>();
    let cam = CameraDesc::new(Vec3::new(0.3, 0.2, -0.5), Vec3::new(0.0, 0.0, 1.0));
    // Depth 1 and 3: no Russian roulette yet, and every estimate is exact.
    for d in [1u32, 3] {
        let (img, stats) = render(&s, &cam, Integrator::Path { light_samples: 1, max_depth: d }, 16, 12, 2);
        let want = l_depth(d as i32);
        assert!(img.pixels.iter().all(|c| (c.x - want).abs() < 1e-4 * want), "depth {d}: {:?} vs {want}", img.pixels[0]);
        assert_eq!(stats.rays.secondary, u64::from(d) * 16 * 12 * 2);
    }
    // Deep paths, ended by Russian roulette: the infinite sum, within 1%.
    let (img, stats) = render(&s, &cam, Integrator::Path { light_samples: 1, max_depth: 200 }, 32, 24, 16);
    let want = e / std::f32::consts::PI * a / (1.0 - a);
    let mean = img.pixels.iter().map(|c| c.x).sum::<f32>() / img.pixels.len() as f32;
    eprintln!("integrating sphere: mean {mean:.5}, analytic {want:.5}, relative difference {:.5}", (mean - want).abs() / want);
    assert!((mean - want).abs() < 0.01 * want, "{mean} vs {want}");
    // Roulette ended the paths long before depth 200.
    let per_path = stats.rays.secondary as f32 / (32.0 * 24.0 * 16.0);
    assert!(per_path < 10.0, "{per_path} BSDF rays per path");
}

#[test]
fn a_diffuse_sphere_under_a_uniform_sky_reflects_its_albedo() {
    // The background is a uniform environment of radiance Le: a convex Lambert surface
    // sees only sky, so it reflects exactly a·Le (the white furnace), and so does every
    // sample (cosine sampling's weight is the albedo, and the next ray always escapes).
    // One sample per pixel, through its centre: each pixel is all sphere or all sky.
    let (a, le) = (0.7f32, Vec3::new(0.5, 1.0, 2.0));
    let s = scene(vec![(Geometry::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 4.0), 1.5)), Material::Lambert(Vec3::splat(a)))], vec![], le);
    let cam = CameraDesc::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0));
    let (img, stats) = render(&s, &cam, Integrator::Path { light_samples: 1, max_depth: 5 }, 32, 24, 1);
    let on_sphere: Vec<Color> = img.pixels.iter().copied().filter(|&c| c != le).collect();
    assert!(on_sphere.len() > 200, "{} pixels on the sphere", on_sphere.len());
    for c in on_sphere {
        assert!(((c - a * le) / (a * le)).abs().max_element() < 1e-5, "{c} vs {}", a * le);
    }
    assert!(stats.rays.secondary > 200);
}

/// Mirror, glass and Lambert spheres in a Lambert room under a quad light.
fn mixed_scene() -> (Scene, CameraDesc) {
    let quad = Light::Quad {
        corner: Vec3::new(1.0, 4.9, -2.0),
        u: Vec3::new(-2.0, 0.0, 0.0),
        v: Vec3::new(0.0, 0.0, 2.0),
        color: WHITE,
        power: 20.0,
    };
    let s = scene(
        vec![
            (Geometry::Sphere(Sphere::new(Vec3::new(-2.0, 0.0, 3.0), 1.2)), Material::Mirror),
            (Geometry::Sphere(Sphere::new(Vec3::new(2.0, 0.0, 3.0), 1.2)), Material::Transparent { ior: 1.3 }),
            (Geometry::Sphere(Sphere::new(Vec3::new(0.0, -1.0, 5.0), 1.0)), Material::Color(Vec3::new(0.9, 0.8, 0.2))),
            (plane(Vec3::new(0.0, -2.0, 0.0), Vec3::Y), Material::Lambert(Vec3::splat(0.7))),
            (plane(Vec3::new(0.0, 5.0, 0.0), -Vec3::Y), Material::Lambert(Vec3::splat(0.7))),
            (plane(Vec3::new(5.0, 0.0, 0.0), -Vec3::X), Material::Lambert(RED)),
            (plane(Vec3::new(0.0, 0.0, 10.0), -Vec3::Z), Material::Lambert(Vec3::splat(0.5))),
        ],
        vec![quad, Light::Point { position: Vec3::new(0.0, 3.0, 0.0), color: WHITE, power: 5.0 }],
        GREY,
    );
    (s, CameraDesc::new(Vec3::new(0.0, 1.0, -5.0), Vec3::new(0.0, 0.0, 3.0)))
}

#[test]
fn whitted_and_path_render_the_same_on_one_and_two_threads() {
    let (s, cam) = mixed_scene();
    for integrator in [Integrator::Whitted { light_samples: 2, max_depth: 5 }, Integrator::Path { light_samples: 2, max_depth: 5 }] {
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| render(&s, &cam, integrator, 40, 30, 3))
        };
        let ((one, s1), (two, s2)) = (run(1), run(2));
        assert_eq!(one.pixels, two.pixels, "{integrator:?}");
        assert_eq!((s1.rays, s1.samples), (s2.rays, s2.samples));
        assert!(s1.rays.secondary > 0 && s1.samples.all_good(), "{s1:?}");
        assert!(one.pixels.iter().all(|c| c.is_finite() && c.min_element() >= 0.0));
    }
}

#[test]
fn the_path_tracer_warns_once_about_color_materials() {
    let (s, _) = mixed_scene();
    let w = Integrator::Path { light_samples: 1, max_depth: 5 }.warnings(&s);
    assert_eq!(w.len(), 1, "{w:?}");
    assert!(w[0].contains("ColorMaterial") && w[0].contains("1 ColorMaterial"), "{w:?}");
    assert!(WHITTED.warnings(&s).is_empty());
    let (lambert, _) = lambert_scene(Light::Point { position: Vec3::Y, color: WHITE, power: 1.0 });
    assert!(Integrator::Path { light_samples: 1, max_depth: 5 }.warnings(&lambert).is_empty());
}

#[test]
fn nan_samples_are_counted_and_dropped_not_propagated() {
    // A material whose colour is NaN makes every sample that sees it NaN.
    let s = scene(
        vec![
            (Geometry::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0)), Material::Lambert(Vec3::NAN)),
            (plane(Vec3::new(0.0, -2.0, 0.0), Vec3::Y), Material::Lambert(Vec3::splat(0.5))),
        ],
        vec![Light::Point { position: Vec3::new(0.0, 5.0, 0.0), color: WHITE, power: 50.0 }],
        GREY,
    );
    let cam = CameraDesc::new(Vec3::ZERO, Vec3::new(0.0, 0.0, 1.0));
    for integrator in [Integrator::DirectLighting { light_samples: 1 }, Integrator::Path { light_samples: 1, max_depth: 3 }] {
        let (img, stats) = render(&s, &cam, integrator, 24, 16, 4);
        assert!(img.pixels.iter().all(|c| c.is_finite()), "{integrator:?}: a NaN reached the image");
        assert!(stats.samples.nan > 0, "{integrator:?}: {:?}", stats.samples);
        assert!(stats.samples.nan < 24 * 16 * 4, "the plane's samples are fine");
    }
    // The counting itself.
    let mut counts = crate::renderer::SampleCounts::default();
    let kept: Vec<bool> = [
        Vec3::ONE,
        Vec3::new(f32::NAN, 1.0, 0.0),
        Vec3::new(f32::INFINITY, f32::NAN, 0.0),
        Vec3::new(0.0, f32::NEG_INFINITY, 0.0),
        Vec3::new(-0.5, 1.0, 1.0),
        // Signed zeros are not negative; the largest float is finite.
        Vec3::new(-0.0, 0.0, 1.0),
        Vec3::new(f32::MAX, 0.0, -0.0),
        Vec3::new(0.0, 0.0, f32::INFINITY),
        Vec3::new(0.0, 0.0, f32::NAN),
        Vec3::new(1.0, 1.0, -1e-30),
    ]
    .iter()
    .map(|&c| counts.check(c))
    .collect();
    assert_eq!(kept, [true, false, false, false, true, true, true, false, false, true]);
    assert_eq!((counts.nan, counts.inf, counts.negative), (3, 2, 2));
}

#[test]
fn names_light_samples_and_depths_carry_over() {
    assert_eq!(Integrator::NAMES.map(|n| !n.is_empty()), [true; 4]);
    let p = Integrator::Path { light_samples: 3, max_depth: 5 };
    assert_eq!(p.name(), "path");
    assert_eq!(p.with_max_depth(0).max_depth(), 1);
    assert_eq!(p.with_max_depth(10_000).max_depth(), MAX_DEPTH_LIMIT);
    assert_eq!(p.with_light_samples(7).light_samples(), 7);
    assert_eq!(Integrator::DirectLighting { light_samples: 2 }.with_max_depth(9), Integrator::DirectLighting { light_samples: 2 });
    assert_eq!(WHITTED.name(), "whitted");
}

/// An integrator built with a bounce limit beyond [`MAX_DEPTH_LIMIT`] renders as with the
/// limit: between two facing mirrors, where every bounce goes on, a limit of billions
/// ran Whitted's tree out of memory and the path tracer for hours.
#[test]
fn a_bounce_limit_beyond_the_largest_renders_as_the_largest() {
    let s = scene(
        vec![
            (plane(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z), Material::Mirror),
            (plane(Vec3::new(0.0, 0.0, -5.0), Vec3::Z), Material::Mirror),
            (plane(Vec3::new(0.0, -2.0, 0.0), Vec3::Y), Material::Lambert(GREY)),
        ],
        vec![Light::Point { position: Vec3::new(0.0, 1.0, 0.0), color: WHITE, power: 10.0 }],
        BLACK,
    );
    let camera = CameraDesc::new(Vec3::ZERO, Vec3::new(0.0, -0.3, 1.0));
    for make in [|d| Integrator::Whitted { light_samples: 1, max_depth: d }, |d| Integrator::Path { light_samples: 1, max_depth: d }] {
        let (huge, stats) = render_seeded(&s, &camera, make(u32::MAX), 6, 4, 2, 3);
        let (limit, _) = render_seeded(&s, &camera, make(MAX_DEPTH_LIMIT), 6, 4, 2, 3);
        assert_eq!(huge.pixels, limit.pixels, "{:?}", make(0));
        assert!(stats.rays.secondary > 0 && huge.pixels.iter().any(|p| *p != BLACK), "{:?}: the mirrors reflect", make(0));
    }
}
