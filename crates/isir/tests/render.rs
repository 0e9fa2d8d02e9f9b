//! Renders of the built-in scenes: conventions, determinism, nothing blank.

use isir::color::GREY;
use isir::scenes::{MeshSource, ObjectDesc, ShapeDesc};
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
        // TP1's sphere alone covers a few percent of the image; the rooms most of it.
        let tp1 = name.starts_with("tp1-");
        assert!(distinct.len() > if tp1 { 10 } else { 20 }, "{name}: only {} distinct colours", distinct.len());
        let min_covered = if tp1 { img.pixels.len() / 50 } else { img.pixels.len() / 2 };
        assert!(img.pixels.iter().filter(|&&c| c != GREY).count() > min_covered, "{name} is mostly background");
        assert!(img.pixels.iter().all(|c| c.is_finite() && c.min_element() >= 0.0), "{name} has non-finite or negative pixels");
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

#[test]
fn conference_floor_has_no_acne() {
    // TP4 figure 2. Shadow acne on the lit floor shows as pixels darker than their
    // neighbours: with the pixel centre as the only sample, a hit point computed below the
    // floor sends its shadow rays into the floor. Find the lit floor pixels darker than
    // half the median of their 3×3 neighbourhood, then trace shadow rays from each: none
    // may be stopped by the floor itself. (Before the fix, 12.9% of all floor shadow rays
    // were, and 1,866 of about 12,400 lit floor pixels were dark at this size; what stays
    // dark now is the shadow of thin things standing on the floor.)
    let desc = scenes::builtin("tp4-conference").unwrap();
    let scene = desc.build(Accel::BvhSah).unwrap();
    let (w, h) = (240, 160);
    let r = Renderer::new(w, h).spp(1);
    let cam = desc.camera.build(r.aspect());
    let (img, _) = r.render(&scene, &cam, &Integrator::DirectLighting { light_samples: 32 });
    let is_floor = |hit: &isir::Hit| hit.geometric_normal.y > 0.99 && hit.point.y < 2.0;
    let hits: Vec<Option<isir::Hit>> = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .map(|(x, y)| {
            let ray = cam.generate_ray((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            scene.intersect(&ray, 0.0, f32::INFINITY).filter(is_floor)
        })
        .collect();
    let lum = |x: u32, y: u32| img.get(x, y).dot(Vec3::ONE);
    let (mut lit, mut dark, mut by_floor) = (0, 0, 0);
    let mut rng = isir::sampling::Sampler::from_seed(5);
    for y in 1..h - 1 {
        for x in 1..w - 1 {
            let around: Vec<(u32, u32)> = (0..9).map(|k| (x + k % 3 - 1, y + k / 3 - 1)).collect();
            if !around.iter().all(|&(x, y)| hits[(y * w + x) as usize].is_some()) {
                continue;
            }
            let mut l: Vec<f32> = around.iter().map(|&(x, y)| lum(x, y)).collect();
            l.sort_by(f32::total_cmp);
            if l[4] < 0.05 {
                continue; // in shadow
            }
            lit += 1;
            if lum(x, y) >= 0.5 * l[4] {
                continue;
            }
            dark += 1;
            let hit = hits[(y * w + x) as usize].unwrap();
            for _ in 0..64 {
                let ls = scene.lights[0].sample(hit.point, rng.next_2d());
                let (shadow, t_max) = hit.spawn_ray_to(ls.point).unwrap();
                if scene.intersect(&shadow, 0.0, t_max).is_some_and(|b| is_floor(&b) && (b.point.y - hit.point.y).abs() < 1e-2) {
                    by_floor += 1;
                }
            }
        }
    }
    assert!(lit > 10_000, "only {lit} lit floor pixels");
    assert!(dark < lit / 10, "{dark} of {lit} lit floor pixels are darker than half their neighbours");
    assert_eq!(by_floor, 0, "shadow rays of the {dark} dark floor pixels stopped by the floor itself");
}
