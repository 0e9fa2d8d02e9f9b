//! Rays leaving a surface never hit it again (issue 8, item 1): shadow rays spawned from
//! camera-ray hits towards a light above must not be blocked by the surface they leave,
//! whatever the distance to the camera, the size of the scene or the shape of the
//! triangles. Each case traces 10^6 shadow rays.

use isir::geometry::{Geometry, Plane, Sphere, TriangleMesh};
use isir::sampling::Sampler;
use isir::scene::Object;
use isir::{Accel, Color, Ray, Scene, Vec3};
use rayon::prelude::*;

const RAYS: u32 = 1_000_000;

fn scene_of(geometry: Geometry) -> Scene {
    Scene::new(
        vec![Object { name: "surface".into(), geometry, materials: vec![0] }],
        vec![isir::Material::Color(Color::ONE)],
        Vec::new(),
        Color::ZERO,
    )
}

fn mesh_of(vertices: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Geometry {
    let mut m = TriangleMesh::new(vertices, Vec::new(), triangles);
    m.build_accel(Accel::BvhSah);
    Geometry::Mesh(Box::new(m))
}

/// Of `RAYS` camera rays from `eye` through random points `target(ξ)` of the surface, the
/// number whose shadow ray towards `light` (nothing else in the scene) is blocked though
/// the surface faces the light, and the number of camera rays that hit at all.
fn self_hits(scene: &Scene, eye: Vec3, light: Vec3, target: impl Fn(&mut Sampler) -> Vec3 + Sync) -> (u32, u32) {
    (0..RAYS / 1000)
        .into_par_iter()
        .map(|chunk| {
            let mut rng = Sampler::from_seed(u64::from(chunk) + 1);
            let (mut blocked, mut hits) = (0, 0);
            for _ in 0..1000 {
                let ray = Ray::new(eye, (target(&mut rng) - eye).normalize());
                let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else { continue };
                hits += 1;
                // Where the surface faces away from the light (a sphere's far side), it
                // shadows itself: only the lit side counts, grazing angles included.
                if hit.geometric_normal.dot((light - hit.point).normalize()) < 0.01 {
                    continue;
                }
                let Some((shadow, t_max)) = hit.spawn_ray_to(light) else { continue };
                if scene.occluded(&shadow, 0.0, t_max) {
                    blocked += 1;
                }
            }
            (blocked, hits)
        })
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1 + b.1))
}

fn check(what: &str, scene: &Scene, eye: Vec3, light: Vec3, target: impl Fn(&mut Sampler) -> Vec3 + Sync) {
    let (blocked, hits) = self_hits(scene, eye, light, target);
    assert!(hits > RAYS * 9 / 10, "{what}: only {hits} camera rays hit the surface");
    assert_eq!(blocked, 0, "{what}: {blocked} of {hits} shadow rays hit the surface they leave");
}

fn on_triangle(a: Vec3, b: Vec3, c: Vec3, rng: &mut Sampler) -> Vec3 {
    let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
    if u + v > 1.0 {
        (u, v) = (1.0 - u, 1.0 - v);
    }
    // Keep away from the edges, where a ray may legitimately miss.
    let (u, v) = (0.01 + 0.98 * u, 0.01 + 0.98 * v);
    let w = (1.0 - u - v).max(0.0);
    w * a + u * b + v * c
}

#[test]
fn floor_triangle_seen_from_near_and_far() {
    // A floor at y = 1.57 (the conference room's), seen from 10, 1e3 and 1e5 units away
    // at a grazing-ish angle, lit from above.
    for distance in [10.0f32, 1e3, 1e5] {
        let s = distance * 0.5;
        let (a, b, c) = (Vec3::new(-s, 1.57, -s), Vec3::new(s, 1.57, -0.3 * s), Vec3::new(0.2 * s, 1.57, s));
        let scene = scene_of(mesh_of(vec![a, b, c], vec![[0, 1, 2]]));
        let eye = Vec3::new(-0.7 * distance, 1.57 + 0.4 * distance, -0.6 * distance);
        let light = Vec3::new(0.1 * s, 1.57 + distance, 0.2 * s);
        check(&format!("floor from {distance}"), &scene, eye, light, |rng| on_triangle(a, b, c, rng));
        // The same floor tilted: no axis helps.
        let tilt = |p: Vec3| Vec3::new(p.x, p.y + 0.31 * p.x - 0.17 * p.z, p.z);
        let (a, b, c) = (tilt(a), tilt(b), tilt(c));
        let scene = scene_of(mesh_of(vec![a, b, c], vec![[0, 1, 2]]));
        check(&format!("tilted floor from {distance}"), &scene, eye, light, |rng| on_triangle(a, b, c, rng));
    }
}

#[test]
fn convex_polygon_of_thin_fan_triangles() {
    // A 1000-gon fanned from its first vertex (as OBJ polygons are): long thin triangles.
    let (n, r) = (1000, 50.0f32);
    let center = Vec3::new(3.0, -2.0, 7.0);
    let basis = (Vec3::new(1.0, 0.2, 0.1).normalize(), Vec3::new(-0.1, 0.3, 1.0).normalize());
    let vertices: Vec<Vec3> = (0..n)
        .map(|i| {
            let a = i as f32 / n as f32 * std::f32::consts::TAU;
            center + r * (a.cos() * basis.0 + a.sin() * basis.1)
        })
        .collect();
    let triangles: Vec<[u32; 3]> = (1..n - 1).map(|i| [0, i, i + 1]).collect();
    let normal = basis.0.cross(basis.1).normalize();
    let scene = scene_of(mesh_of(vertices, triangles));
    let eye = center + 3.0 * r * (normal + 0.5 * basis.0);
    let light = center + 2.0 * r * (normal - 0.3 * basis.1);
    check("1000-gon", &scene, eye, light, |rng| {
        let p = rng.next_2d();
        let (rad, a) = (0.95 * r * p.x.sqrt(), p.y * std::f32::consts::TAU);
        center + rad * (a.cos() * basis.0 + a.sin() * basis.1)
    });
}

#[test]
fn bunny_scaled_by_ten_thousand() {
    let mut mesh = isir::scenes::load_builtin_model("Bunny").unwrap().mesh;
    for v in &mut mesh.vertices {
        *v *= 1e4;
    }
    let m = TriangleMesh::new(mesh.vertices.clone(), Vec::new(), mesh.triangles.clone());
    let b = m.aabb();
    let (c, size) = (b.centroid(), b.diagonal().length());
    let scene = scene_of(mesh_of(mesh.vertices, mesh.triangles));
    let eye = c + Vec3::new(0.3, 0.4, -1.0).normalize() * 2.0 * size;
    let light = c + Vec3::new(0.0, 1.0, -0.6).normalize() * 10.0 * size;
    // Only hits whose geometric normal faces the light: elsewhere the bunny shadows itself.
    let mut rng = Sampler::from_seed(3);
    let (mut blocked, mut tried) = (0, 0);
    while tried < RAYS / 4 {
        let target = b.min + b.diagonal() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let ray = Ray::new(eye, (target - eye).normalize());
        let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else { continue };
        let to_light = (light - hit.point).normalize();
        // Facing the light clearly, and nothing else of the bunny in the way: the light is
        // seen over the bunny's top from its front, so require the hit near the light side.
        if hit.geometric_normal.dot(to_light) < 0.3 || hit.normal.dot(to_light) < 0.3 {
            continue;
        }
        tried += 1;
        let (shadow, t_max) = hit.spawn_ray_to(light).unwrap();
        // A blocker at a distance is the bunny's own relief (at the grazing angles kept
        // here, a neighbouring bump); leaving the surface, a ray hits its own triangle, or
        // another within a few error bounds (about 1e-7 of the size here).
        if let Some(h) = scene.intersect(&shadow, 0.0, t_max) {
            if h.prim == hit.prim || h.t < 1e-6 * size {
                blocked += 1;
            }
        }
    }
    assert_eq!(blocked, 0, "{blocked} of {tried} shadow rays hit the bunny where they leave it");
}

#[test]
fn spheres_near_and_far() {
    for (center, radius, distance) in [
        (Vec3::new(0.0, 0.0, 3.0), 1.0f32, 10.0f32),
        (Vec3::new(250.0, -80.0, 900.0), 40.0, 1e3),
        (Vec3::new(-3e4, 2e4, 5e4), 2e3, 1e5),
        (Vec3::new(1.0, 2.0, 3.0), 1e-3, 0.05),
    ] {
        let scene = scene_of(Geometry::Sphere(Sphere::new(center, radius)));
        let eye = center + Vec3::new(0.2, 0.5, -1.0).normalize() * distance;
        let light = center + Vec3::new(0.0, 1.0, 0.1).normalize() * 3.0 * distance;
        check(&format!("sphere r={radius} from {distance}"), &scene, eye, light, |rng| {
            let p = rng.next_2d();
            let (rad, a) = (0.99 * radius * p.x.sqrt(), p.y * std::f32::consts::TAU);
            // Points of the disc facing the eye, projected on the sphere along the view.
            let w = (center - eye).normalize();
            let u = w.cross(Vec3::Y).normalize();
            let v = u.cross(w);
            center + rad * (a.cos() * u + a.sin() * v)
        });
    }
}

#[test]
fn planes_near_and_far() {
    for distance in [10.0f32, 1e3, 1e5] {
        for normal in [Vec3::Y, Vec3::new(0.3, 1.0, -0.2).normalize()] {
            let p0 = Vec3::new(0.0, -3.0, 0.0);
            let scene = scene_of(Geometry::Plane(Plane::new(p0, normal)));
            let eye = p0 + Vec3::new(-0.5, 0.4, -0.7) * distance;
            let light = p0 + Vec3::new(0.1, 1.0, 0.2) * distance;
            let (u, v) = (normal.any_orthonormal_pair().0, normal.any_orthonormal_pair().1);
            check(&format!("plane {normal} from {distance}"), &scene, eye, light, |rng| {
                let p = rng.next_2d() * 2.0 - isir::Vec2::ONE;
                p0 + distance * 0.5 * (p.x * u + p.y * v)
            });
        }
    }
}
