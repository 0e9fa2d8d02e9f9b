//! Renders of the built-in scenes: conventions, determinism, nothing blank.

use isir::color::GREY;
use isir::scene::{MeshSource, ObjectDesc, ShapeDesc};
use isir::{scenes, Accel, Image, Integrator, Renderer, Vec3};

fn render(name: &str, w: u32, h: u32, spp: u32) -> Image {
    let desc = scenes::builtin(name).unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    let r = Renderer::new(w, h).spp(spp);
    r.render(&scene, &desc.camera.build(r.aspect()), &desc.integrator).0
}

#[test]
fn tp4_sphere_has_red_on_the_left_and_blue_on_the_right() {
    let img = render("tp4-sphere", 60, 40, 1);
    let left = img.get(1, 20);
    let right = img.get(58, 20);
    assert!(left.x > 0.2 && left.y < 0.05 && left.z < 0.05, "left is {left}");
    assert!(right.z > 0.2 && right.x < 0.05 && right.y < 0.05, "right is {right}");
    // The ceiling (green) is at the top, the grey ground at the bottom.
    let top = img.get(30, 0);
    assert!(top.y > 0.05 && top.x < 0.05 && top.z < 0.05, "top is {top}");
}

#[test]
fn every_builtin_scene_renders_something() {
    for (name, summary) in scenes::list() {
        assert!(!summary.is_empty());
        let img = render(name, 48, 32, 1);
        let distinct: std::collections::HashSet<[u32; 3]> =
            img.pixels.iter().map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()]).collect();
        assert!(distinct.len() > 20, "{name}: only {} distinct colours", distinct.len());
        assert!(img.pixels.iter().filter(|&&c| c != GREY).count() > img.pixels.len() / 2, "{name} is mostly background");
        assert!(img.pixels.iter().all(|c| c.is_finite()), "{name} has non-finite pixels");
    }
}

#[test]
fn same_image_on_one_and_two_threads() {
    // The conference room: area light sampling and jittered pixels use random numbers, and
    // the BVH is built in parallel; both happen inside each pool.
    let desc = scenes::builtin("tp4-conference").unwrap();
    let r = Renderer::new(64, 48).spp(3).seed(7);
    let cam = desc.camera.build(r.aspect());
    let integrator = Integrator::DirectLighting { light_samples: 3 };
    let run = |threads: usize| {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| {
            let scene = desc.build(Accel::BvhSah).unwrap();
            r.render(&scene, &cam, &integrator)
        })
    };
    let (one, two) = (run(1), run(2));
    let scene = desc.build(Accel::BvhSah).unwrap();
    assert_eq!(one.0.to_rgb8(desc.display), two.0.to_rgb8(desc.display));
    assert_eq!(one.0.pixels, two.0.pixels, "float pixels differ");
    assert_eq!(one.1.rays, two.1.rays);
    // Another seed gives another (noisy) image.
    let other = r.clone().seed(8).render(&scene, &cam, &integrator).0;
    assert_ne!(other.pixels, one.0.pixels);
}

#[test]
fn every_accel_renders_the_same_bunny() {
    let desc = scenes::builtin("tp4-bunny").unwrap();
    let r = Renderer::new(40, 30).spp(1);
    let cam = desc.camera.build(r.aspect());
    let images: Vec<Vec<u8>> = Accel::ALL
        .iter()
        .map(|&a| {
            let scene = desc.build(a).unwrap();
            r.render(&scene, &cam, &desc.integrator).0.to_rgb8(desc.display)
        })
        .collect();
    for (i, img) in images.iter().enumerate() {
        assert_eq!(img, &images[0], "{} differs from none", Accel::ALL[i].name());
    }
}

#[test]
fn bunny_keeps_its_file_material_despite_tr_1() {
    // Bunny.mtl says `Tr 1.000000`, meaning opaque: the bunny must be visible in Kd.
    let loaded = scenes::load_builtin_model("Bunny").unwrap();
    assert_eq!(loaded.materials.len(), 1);
    assert_eq!(loaded.materials[0].diffuse, Vec3::new(0.7, 0.0, 0.7));
    let mut desc = scenes::builtin("tp4-bunny").unwrap();
    desc.objects[0] = ObjectDesc {
        name: "Bunny".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::Builtin("Bunny"), shading: Default::default() },
        material: None,
    };
    let scene = desc.build(Accel::BvhSah).unwrap();
    let ray = isir::Ray::new(Vec3::new(0.0, 2.0, -7.0), (Vec3::new(0.0, 0.0, 0.0) - Vec3::new(0.0, 2.0, -7.0)).normalize());
    let hit = scene.intersect(&ray, 0.0, f32::INFINITY).expect("the bunny is in front of the camera");
    assert_eq!(scene.objects[hit.object as usize].name, "Bunny");
    assert_eq!(scene.material(&hit).flat_color(), Vec3::new(0.7, 0.0, 0.7));
}

#[test]
fn no_shadow_acne_on_lit_surfaces() {
    // Direct light on the bunny, shadow rays from every primary hit: a point whose normal
    // faces the light and that no other surface hides must be lit. Count the pixels of
    // the bunny that face the light but come out black; acne would make many.
    let desc = scenes::builtin("tp4-bunny").unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    let r = Renderer::new(120, 80);
    let cam = desc.camera.build(r.aspect());
    let light = Vec3::new(0.0, 3.0, -5.0);
    let (mut facing, mut dark) = (0, 0);
    for y in 0..80 {
        for x in 0..120 {
            let ray = cam.generate_ray((x as f32 + 0.5) / 120.0, (y as f32 + 0.5) / 80.0);
            let Some(hit) = scene.intersect(&ray, 0.0, f32::INFINITY) else {
                continue;
            };
            if hit.object != 0 || hit.geometric_normal.dot(light - hit.point) <= 0.0 || hit.normal.dot(light - hit.point) <= 0.0 {
                continue;
            }
            facing += 1;
            let c = Integrator::DirectLighting { light_samples: 1 }.li(
                &scene,
                &ray,
                0.0,
                f32::INFINITY,
                &mut isir::sampling::Sampler::from_seed(0),
                &mut Default::default(),
            );
            if c == Vec3::ZERO {
                dark += 1;
            }
        }
    }
    assert!(facing > 300, "{facing}");
    // The bunny shadows itself (ears on the back) a little, acne would be a large fraction.
    assert!(dark * 20 < facing, "{dark} of {facing} lit-facing pixels are black");
}
