//! Shadow rays traced as packets (`occluded_packet`) get the answers single rays get, and
//! renders that use them are the renders of the scalar path, bit for bit.

use glam::Vec2;
use isir::math::ray::RaySegment;
use isir::math::sampling::Sampler;
use isir::wide::SimdLevel;
use isir::{scenes, Accel, Geometry, Integrator, Renderer, Scene};

fn set_level(scene: &mut Scene, level: SimdLevel) {
    for object in &mut scene.objects {
        if let Geometry::Mesh(mesh) = &mut object.geometry {
            mesh.set_simd_level(level);
        }
    }
}

/// From points on the conference room's surfaces towards its quad light: 1 to 16 rays per
/// packet, every SIMD level, against one `occluded` per ray.
#[test]
fn packets_of_shadow_rays_answer_as_single_rays() {
    let desc = scenes::builtin("tp4-conference").unwrap();
    let mut scene = desc.build(Accel::BvhSah).unwrap();
    let camera = desc.camera.build(1.5);
    let light = scene.lights[0].sampler();
    for level in SimdLevel::available() {
        set_level(&mut scene, level);
        let mut rng = Sampler::from_seed(3);
        let (mut rays_tested, mut blocked, mut packets) = (0, 0, 0);
        while packets < 20_000 {
            let ray = camera.generate_ray(rng.next_f32(), rng.next_f32());
            let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else { continue };
            packets += 1;
            let n = 1 + (packets % 16) as usize;
            let mut shadow = hit.shadow_rays();
            let mut rays = Vec::new();
            for _ in 0..n {
                let ls = light.sample(hit.point, Vec2::new(rng.next_f32(), rng.next_f32()));
                if let Some((r, t_max)) = shadow.to(ls.point) {
                    rays.push(RaySegment { origin: r.origin, t_min: 0.0, direction: r.direction, t_max });
                }
            }
            let mask = scene.occluded_packet(&rays);
            for (i, r) in rays.iter().enumerate() {
                let single = scene.occluded(&r.ray(), 0.0, r.t_max);
                assert_eq!(mask & (1 << i) != 0, single, "{level:?}: packet {packets}, ray {i} of {}", rays.len());
                rays_tested += 1;
                blocked += usize::from(single);
            }
            assert_eq!(mask >> rays.len(), 0);
        }
        // Both answers occur often: the comparison is not vacuous.
        assert!(blocked > rays_tested / 10 && blocked < rays_tested * 9 / 10, "{blocked} of {rays_tested} blocked");
    }
}

/// Rays with a NaN, a zero direction or an empty interval are not occluded, as single rays.
#[test]
fn invalid_rays_in_a_packet_are_answered_as_single_rays() {
    let desc = scenes::builtin("tp4-bunny").unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    let o = glam::Vec3::new(0.0, -2.5, 0.0);
    let up = glam::Vec3::Y;
    let seg = |direction, t_max| RaySegment { origin: o, t_min: 0.0, direction, t_max };
    let rays = [
        seg(up, 100.0),
        seg(glam::Vec3::ZERO, 100.0),
        seg(glam::Vec3::new(f32::NAN, 1.0, 0.0), 100.0),
        seg(up, 0.0),
        seg(up, f32::NAN),
        seg(-up, 100.0),
    ];
    let mask = scene.occluded_packet(&rays);
    for (i, r) in rays.iter().enumerate() {
        assert_eq!(mask & (1 << i) != 0, scene.occluded(&r.ray(), 0.0, r.t_max), "ray {i}");
    }
}

/// Quad-light scenes with 16 light samples (traced as packets where the CPU has AVX-512)
/// render the pixels of the scalar path.
#[test]
fn renders_with_shadow_packets_are_those_of_the_scalar_path() {
    for name in ["tp4-conference", "tp3-quad-soft"] {
        let desc = scenes::builtin(name).unwrap();
        let mut scene = desc.build(Accel::BvhSah).unwrap();
        let renderer = Renderer::new(64, 48).spp(2);
        let camera = desc.camera.build(renderer.aspect());
        let integrator = Integrator::DirectLighting { light_samples: 16 };
        set_level(&mut scene, SimdLevel::Scalar);
        let (reference, _) = renderer.render(&scene, &camera, &integrator);
        for level in SimdLevel::available() {
            set_level(&mut scene, level);
            let (image, stats) = renderer.render(&scene, &camera, &integrator);
            assert!(stats.rays.shadow > 10_000, "{name}: {:?}", stats.rays);
            assert!(image.pixels == reference.pixels, "{name}: {level:?} differs from the scalar path");
        }
    }
}
