//! Criterion benchmarks: SAH build and wide-BVH traversal (primary, diffuse, shadow rays)
//! on the bunny and the conference room. `cargo bench -p isir`.
//! For the comparison with Embree use `isir bench` (see the README).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use isir::rays::{generate, RayKind, RayRecord};
use isir::{scenes, Accel, Bvh, BvhQuality};

fn setup(scene: &str, model: &str) -> (isir::TriangleMesh, Vec<(RayKind, Vec<RayRecord>)>) {
    let desc = scenes::builtin(scene).unwrap();
    let built = desc.build(Accel::BvhSah).unwrap();
    let camera = desc.camera.build(1.5);
    let sets = [RayKind::Primary, RayKind::Diffuse, RayKind::Shadow]
        .into_iter()
        .map(|k| (k, generate(&built, &camera, 300, 200, k, 1).unwrap()))
        .collect();
    let mut mesh = scenes::load_builtin_model(model).unwrap().mesh;
    mesh.build_accel(Accel::BvhSah);
    (mesh, sets)
}

fn benches(c: &mut Criterion) {
    for (scene, model) in [("tp4-bunny", "Bunny"), ("tp4-conference", "conference")] {
        let (mesh, sets) = setup(scene, model);
        let boxes = mesh.triangle_boxes();
        let mut g = c.benchmark_group(format!("build/{model}"));
        g.throughput(Throughput::Elements(boxes.len() as u64));
        g.sample_size(10);
        g.bench_function("sah", |b| b.iter(|| Bvh::build(&boxes, BvhQuality::Sah)));
        g.bench_function("midpoint", |b| b.iter(|| Bvh::build(&boxes, BvhQuality::Midpoint)));
        g.finish();

        let mut g = c.benchmark_group(format!("trace/{model}"));
        g.sample_size(10);
        for (kind, rays) in &sets {
            g.throughput(Throughput::Elements(rays.len() as u64));
            g.bench_with_input(BenchmarkId::new(format!("{kind:?}").to_lowercase(), rays.len()), rays, |b, rays| {
                b.iter(|| {
                    let mut n = 0u32;
                    for r in rays {
                        let ray = r.ray();
                        n += if *kind == RayKind::Shadow {
                            u32::from(mesh.occluded(&ray, r.t_min, r.t_max))
                        } else {
                            u32::from(mesh.intersect(&ray, r.t_min, r.t_max).is_some())
                        };
                    }
                    n
                })
            });
        }
        g.finish();
    }
}

criterion_group!(bvh, benches);
criterion_main!(bvh);
