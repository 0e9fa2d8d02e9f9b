//! Scenes built in Rust with what a description would refuse: made safe and said in
//! `Scene::warnings`, never a panic in the renderer.

use isir::math::color::WHITE;
use isir::scene::Object;
use isir::{CameraDesc, Geometry, Integrator, Light, Material, Plane, Renderer, Scene, Sphere, Vec3};

fn sphere(name: &str, centre: Vec3, radius: f32, materials: Vec<u32>) -> Object {
    Object { name: name.into(), geometry: Geometry::Sphere(Sphere::new(centre, radius)), materials }
}

fn render(scene: &Scene, integrator: Integrator) -> isir::Image {
    let camera = CameraDesc::new(Vec3::new(0.0, 0.0, -4.0), Vec3::ZERO);
    let r = Renderer::new(16, 12).spp(2);
    r.render(scene, &camera.build(r.aspect()), &integrator).0
}

#[test]
fn objects_without_their_materials_get_the_default_one_and_a_warning() {
    let point = Light::Point { position: Vec3::new(0.0, 3.0, -3.0), color: WHITE, power: 50.0 };
    let objects = vec![
        sphere("none", Vec3::new(-1.5, 0.0, 0.0), 1.0, vec![]),
        sphere("past", Vec3::new(1.5, 0.0, 0.0), 1.0, vec![7]),
        sphere("fine", Vec3::new(0.0, 1.5, 0.0), 0.5, vec![0]),
    ];
    let scene = Scene::new(objects, vec![Material::Lambert(Vec3::splat(0.5))], vec![point], Vec3::ZERO);
    let w = scene.warnings.join("\n");
    assert!(w.contains("object 'none': no material") && w.contains("object 'past': 1 material ids past the 1 materials"), "{w}");
    assert_eq!(scene.materials.len(), 2, "one default added, once");
    assert!(scene.objects.iter().all(|o| !o.materials.is_empty() && o.materials.iter().all(|&m| (m as usize) < scene.materials.len())));
    // Every integrator renders it, the defaulted spheres lit like the course's white.
    for integrator in
        [Integrator::RayCast, Integrator::DirectLighting { light_samples: 1 }, Integrator::Path { light_samples: 1, max_depth: 3 }]
    {
        let image = render(&scene, integrator);
        assert!(image.pixels.iter().all(|p| p.is_finite()) && image.pixels.iter().any(|p| p.max_element() > 0.0), "{integrator:?}");
    }
    // No materials at all.
    let scene = Scene::new(vec![sphere("alone", Vec3::ZERO, 1.0, vec![0])], vec![], vec![], Vec3::ZERO);
    assert_eq!(scene.materials, vec![Material::Color(WHITE)]);
    assert!(render(&scene, Integrator::RayCast).pixels.iter().any(|p| p.max_element() > 0.0));
}

#[test]
fn shapes_lights_and_materials_that_cannot_be_traced_are_named() {
    let objects = vec![
        sphere("inside out", Vec3::ZERO, -1.0, vec![0]),
        Object { name: "flat".into(), geometry: Geometry::Plane(Plane { point: Vec3::ZERO, normal: Vec3::ZERO }), materials: vec![1] },
    ];
    let materials = vec![Material::Transparent { ior: -1.5 }, Material::Lambert(Vec3::new(1.0, -1.0, 0.0))];
    let lights = vec![Light::Quad { corner: Vec3::Y, u: Vec3::ZERO, v: Vec3::X, color: WHITE, power: 10.0 }];
    let scene = Scene::new(objects, materials, lights, Vec3::ZERO);
    let w = scene.warnings.join("\n");
    for expected in [
        "object 'inside out': a sphere of centre [0, 0, 0] and radius -1 is never hit",
        "object 'flat': a plane through [0, 0, 0] whose normal [0, 0, 0] is not of length 1",
        "material 0: ior -1.5 must be finite and above 0",
        "material 1: color [1, -1, 0] must be finite and not negative",
        "light 1: the quad's edges",
    ] {
        assert!(w.contains(expected), "expected '{expected}' in:\n{w}");
    }
    // A valid scene has nothing to say.
    let fine = Scene::new(vec![sphere("s", Vec3::ZERO, 1.0, vec![0])], vec![Material::Mirror], vec![], Vec3::ZERO);
    assert!(fine.warnings.is_empty(), "{:?}", fine.warnings);
}

/// Sizes past the limit are refused before anything is allocated: a render with a clear
/// panic (documented; the `isir` command checks first), a ray set with an error.
#[test]
#[should_panic(expected = "100000x100000: more pixels than the 268435456 a render may have")]
fn a_render_past_the_pixel_limit_panics_before_allocating() {
    let scene = Scene::new(vec![sphere("s", Vec3::ZERO, 1.0, vec![0])], vec![Material::Mirror], vec![], Vec3::ZERO);
    let r = Renderer::new(100_000, 100_000);
    let _ = r.render(&scene, &CameraDesc::new(Vec3::new(0.0, 0.0, -4.0), Vec3::ZERO).build(1.0), &Integrator::RayCast);
}

#[test]
fn a_ray_set_past_the_pixel_limit_is_an_error_and_pixels_outside_an_image_panic() {
    let scene = Scene::new(vec![sphere("s", Vec3::ZERO, 1.0, vec![0])], vec![Material::Mirror], vec![], Vec3::ZERO);
    let camera = CameraDesc::new(Vec3::new(0.0, 0.0, -4.0), Vec3::ZERO).build(1.0);
    let e = isir::io::rays::generate(&scene, &camera, 100_000, 100_000, isir::io::rays::RayKind::Primary, 0).unwrap_err();
    assert!(e.to_string().contains("more than the 268435456"), "{e}");
    // An x past the width named another row's pixel.
    let image = isir::Image::new(4, 4);
    let outside = std::panic::catch_unwind(|| image.get(5, 0)).unwrap_err();
    let message = outside.downcast_ref::<String>().cloned().unwrap_or_default();
    assert!(message.contains("pixel (5, 0) outside the 4x4 image"), "{message}");
}

/// `spp` 0 set through the field (past `Renderer::spp`'s clamp) renders as 1 sample: it
/// rendered no sample, a black image.
#[test]
fn zero_samples_through_the_field_render_as_one() {
    let point = Light::Point { position: Vec3::new(0.0, 3.0, -3.0), color: WHITE, power: 50.0 };
    let scene = Scene::new(vec![sphere("s", Vec3::ZERO, 1.0, vec![0])], vec![Material::Lambert(WHITE)], vec![point], Vec3::ZERO);
    let camera = CameraDesc::new(Vec3::new(0.0, 0.0, -4.0), Vec3::ZERO).build(1.0);
    let integrator = Integrator::DirectLighting { light_samples: 1 };
    let one = Renderer::new(8, 8).spp(1).render(&scene, &camera, &integrator).0;
    let zero = Renderer { spp: 0, ..Renderer::new(8, 8) }.render(&scene, &camera, &integrator).0;
    assert_eq!(zero.pixels, one.pixels);
    assert!(one.pixels.iter().any(|p| p.max_element() > 0.0));
}
