//! Instances and the scene's top-level BVH: a placed mesh is hit where the same mesh with
//! its vertices moved is; rays leaving an instance do not hit it again; a thousand
//! instances share one mesh and render what the object loop renders.

use isir::geometry::{Geometry, Instance};
use isir::math::sampling::{square_to_uniform_sphere, Sampler};
use isir::scenes::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc, Transform};
use isir::{scenes, Accel, Integrator, Ray, Renderer, TriangleMesh, Vec3};
use std::sync::Arc;

fn bunny() -> TriangleMesh {
    let mut m = scenes::load_builtin_model("Bunny").unwrap().mesh;
    m.build_accel(Accel::BvhSah);
    m
}

#[test]
fn an_instance_is_hit_where_its_moved_vertices_are() {
    let mesh = bunny();
    let t = Transform { translate: Vec3::new(3.0, -2.0, 10.0), rotate: Vec3::new(10.0, 40.0, -20.0), scale: 1.5 };
    let affine = t.to_affine();
    let instance = Instance::new(Arc::new(mesh.clone()), affine).unwrap();
    let mut baked = TriangleMesh::new(mesh.vertices.iter().map(|&v| affine.transform_point3(v)).collect(), vec![], mesh.triangles.clone());
    baked.build_accel(Accel::BvhSah);
    let centre = affine.transform_point3(Vec3::new(-0.25, 0.35, 0.2));
    let mut rng = Sampler::from_seed(5);
    let (mut hits, mut agree) = (0, 0);
    for _ in 0..20_000 {
        let origin = centre + square_to_uniform_sphere(rng.next_2d()) * 8.0;
        let target = centre + square_to_uniform_sphere(rng.next_2d()) * 1.5;
        let ray = Ray::new(origin, target - origin);
        let (a, b) = (instance.intersect(&ray, 0.0, f32::INFINITY), baked.intersect(&ray, 0.0, f32::INFINITY));
        assert_eq!(a.is_some(), b.is_some(), "hit/miss differ for {ray:?}");
        if let (Some(a), Some(b)) = (a, b) {
            hits += 1;
            assert!((a.t - b.t).abs() <= 1e-4 * b.t, "t {} vs {}", a.t, b.t);
            if a.prim == b.prim {
                agree += 1;
                let n = instance.face_normal(a.prim);
                assert!(n.dot(baked.face_normal(b.prim)) > 0.9999, "normals differ");
            }
        }
    }
    assert!(hits > 5_000, "{hits}");
    assert!(agree as f32 > 0.999 * hits as f32, "{agree} of {hits} on the same triangle");
    // A transform that cannot be inverted is refused.
    assert!(Instance::new(Arc::new(mesh), Transform { scale: 0.0, ..Transform::default() }.to_affine()).is_none());
}

#[test]
fn rays_leaving_an_instance_do_not_hit_it_again() {
    let t = Transform { translate: Vec3::new(1e3, 50.0, -2e3), rotate: Vec3::new(0.0, 33.0, 0.0), scale: 40.0 };
    let instance = Instance::new(Arc::new(bunny()), t.to_affine()).unwrap();
    let centre = t.to_affine().transform_point3(Vec3::ZERO);
    let mut rng = Sampler::from_seed(8);
    let (mut spawned, mut self_hits) = (0, 0);
    while spawned < 100_000 {
        let origin = centre + square_to_uniform_sphere(rng.next_2d()) * 400.0;
        let ray = Ray::new(origin, centre + square_to_uniform_sphere(rng.next_2d()) * 40.0 - origin);
        let Some(h) = instance.intersect(&ray, 0.0, f32::INFINITY) else { continue };
        let (p, err) = instance.surface_point(h.prim, h.u, h.v);
        let mut n = instance.face_normal(h.prim);
        if n.dot(ray.direction) > 0.0 {
            n = -n;
        }
        // Towards a light on the side the ray came from.
        let light = p + (n + square_to_uniform_sphere(rng.next_2d()) * 0.5).normalize() * 500.0;
        let Some((shadow, t_max)) = isir::ray::spawn_ray_to(p, err, n, light) else { continue };
        spawned += 1;
        if let Some(s) = instance.intersect(&shadow, 0.0, t_max) {
            if s.prim == h.prim {
                self_hits += 1;
            }
        }
    }
    assert_eq!(self_hits, 0, "of {spawned} shadow rays");
}

fn grid(n: usize, spacing: f32) -> SceneDescription {
    let mut d =
        SceneDescription::new("grid", CameraDesc::new(Vec3::new(0.0, 0.5 * spacing * n as f32, -2.0 * spacing * n as f32), Vec3::ZERO));
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
    d.lights.push(isir::Light::Point { position: Vec3::new(0.0, 40.0, -40.0), color: isir::Color::ONE, power: 4000.0 });
    d
}

#[test]
fn a_thousand_instances_share_one_mesh_and_render_as_the_object_loop_does() {
    let desc = grid(10, 4.0);
    let scene = desc.build(Accel::BvhSah).unwrap();
    assert_eq!(scene.objects.len(), 1000);
    assert!(scene.top_level.is_some(), "1,000 bounded objects get a top-level BVH");
    let Geometry::Instance(first) = &scene.objects[0].geometry else { panic!("an instance") };
    assert_eq!(Arc::strong_count(&first.mesh), 1000, "one mesh, held by every instance");
    let mut looped = scene.clone();
    looped.top_level = None;
    let r = Renderer::new(48, 32).spp(1);
    let cam = desc.camera.build(r.aspect());
    let integrator = Integrator::DirectLighting { light_samples: 1 };
    let (a, _) = r.render(&scene, &cam, &integrator);
    let (b, _) = r.render(&looped, &cam, &integrator);
    assert_eq!(a.pixels, b.pixels, "the top-level BVH finds the same hits as the loop");
    let seen = a.pixels.iter().filter(|c| **c != scene.background).count();
    assert!(seen > 150, "{seen} pixels show a bunny");
}

#[test]
fn placed_meshes_are_every_mesh_where_it_stands() {
    let mut desc = grid(2, 4.0);
    desc.objects.push(ObjectDesc {
        name: "plain".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::Builtin("Bunny"), shading: Default::default() },
        material: None,
    });
    desc.objects.push(ObjectDesc {
        name: "ball".into(),
        shape: ShapeDesc::Sphere(isir::Sphere::new(Vec3::new(0.0, 9.0, 0.0), 1.0)),
        material: None,
    });
    let scene = desc.build(Accel::BvhSah).unwrap();
    let placed: Vec<_> = scene.placed_meshes().collect();
    // The eight instances, then the plain mesh; not the sphere.
    assert_eq!(placed.len(), 9);
    for (i, p) in placed.iter().enumerate() {
        assert_eq!(p.object.name, if i < 8 { format!("bunny{i}") } else { "plain".to_string() });
        assert_eq!(p.to_world.is_some(), i < 8);
        // Its box holds its vertices moved to where they stand; a plain mesh's is its own.
        let eps = 1e-4 * p.bounds.max.abs().max(p.bounds.min.abs()).max_element();
        for &v in &p.mesh.vertices {
            let w = p.to_world.map_or(v, |t| t.transform_point3(v));
            assert!(
                (p.bounds.min - Vec3::splat(eps)).cmple(w).all() && w.cmple(p.bounds.max + Vec3::splat(eps)).all(),
                "{i}: {w} out of {:?}",
                p.bounds
            );
        }
        if p.to_world.is_none() {
            assert_eq!(p.bounds, p.mesh.aabb());
        }
    }
}
