//! The scene BVH with instances, measured: one bunny against a 10×10×10 grid of bunny
//! instances (each turned differently): scene build time, memory, and camera-ray
//! Mrays/s (closest hits through `Scene::intersect`, one ray per pixel, 600×400).
//!
//! ```sh
//! cargo run --release -p isir --example instances
//! ```

use isir::scenes::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc, Transform};
use isir::{Accel, Vec3};
use rayon::prelude::*;
use std::time::Instant;

fn scene(n: usize) -> SceneDescription {
    let spacing = 4.0;
    let dist = if n == 1 { 3.0 } else { 1.6 * spacing * n as f32 };
    let mut d = SceneDescription::new("grid", CameraDesc::new(Vec3::new(0.0, 0.3 * dist, -dist), Vec3::ZERO));
    for i in 0..n * n * n {
        let (x, y, z) = ((i % n) as f32, ((i / n) % n) as f32, (i / (n * n)) as f32);
        let half = 0.5 * spacing * (n as f32 - 1.0);
        d.objects.push(ObjectDesc {
            name: format!("bunny{i}"),
            shape: ShapeDesc::MeshInstance {
                source: MeshSource::Builtin("Bunny"),
                shading: Default::default(),
                transform: Transform {
                    translate: Vec3::new(x, y, z) * spacing - half,
                    rotate: Vec3::new(0.0, 37.0 * i as f32, 0.0),
                    scale: 1.0,
                },
            },
            material: None,
        });
    }
    d
}

fn main() {
    let (w, h) = (600u32, 400u32);
    for n in [1usize, 10] {
        let desc = scene(n);
        let t0 = Instant::now();
        let built = desc.build(Accel::BvhSah).unwrap();
        let build = t0.elapsed().as_secs_f64();
        let cam = desc.camera.build(w as f32 / h as f32);
        let mut best = f64::INFINITY;
        let mut hits = 0;
        for _ in 0..5 {
            let t = Instant::now();
            hits = (0..w * h)
                .into_par_iter()
                .filter(|i| {
                    let ray = cam.generate_ray(((i % w) as f32 + 0.5) / w as f32, ((i / w) as f32 + 0.5) / h as f32);
                    built.intersect(&ray, 0.0, f32::INFINITY).is_some()
                })
                .count();
            best = best.min(t.elapsed().as_secs_f64());
        }
        println!(
            "{:>5} bunnies: build {:.1} ms (mesh load included), {} of {} camera rays hit, {:.2} Mrays/s",
            n * n * n,
            build * 1e3,
            hits,
            w * h,
            f64::from(w * h) / best * 1e-6
        );
    }
}
