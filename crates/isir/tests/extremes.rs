//! Scenes at the edges of single precision: any finite scene either renders or is
//! rejected with a message saying why (issue 8, item 1).

use isir::color::GREY;
use isir::scenes::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc};
use isir::{Accel, Integrator, Renderer};

/// A scene of one right triangle of side `scale`, one corner `scale` from the origin (the
/// unit triangle scaled), framed as a mesh file given alone is.
fn triangle_scene(scale: f32, dir: &std::path::Path) -> isir::Result<(SceneDescription, isir::Scene)> {
    let path = dir.join(format!("tri-{scale:e}.obj"));
    let v = |x: f32, y: f32| format!("v {:e} {:e} {:e}\n", scale * x, scale * y, -scale);
    std::fs::write(&path, format!("{}{}{}f 1 2 3\n", v(0.0, 0.0), v(1.0, 0.0), v(0.0, 1.0))).unwrap();
    let mut desc = SceneDescription::new("triangle", CameraDesc::new(isir::Vec3::Z, isir::Vec3::ZERO));
    desc.objects.push(ObjectDesc {
        name: "triangle".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::File(path), shading: Default::default() },
        material: None,
    });
    let mut scene = desc.build(Accel::BvhSah)?;
    let bounds = scene.meshes().next().unwrap().1.aabb();
    let (camera, light) = CameraDesc::framing(&bounds)?;
    desc.camera = camera;
    desc.lights = vec![light.clone()];
    scene.lights = vec![light];
    Ok((desc, scene))
}

#[test]
fn tiny_to_huge_triangles_render_or_are_refused_with_a_reason() {
    let dir = std::env::temp_dir().join(format!("isir-extremes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for scale in [1e-3f32, 1.0, 1e3, 1e7, 1e9, 1e11, 1e12 / 2.5] {
        let (desc, scene) = triangle_scene(scale, &dir).unwrap_or_else(|e| panic!("scale {scale:e}: {e}"));
        let r = Renderer::new(32, 24);
        let img = r.render(&scene, &desc.camera.build(r.aspect()), &Integrator::DirectLighting { light_samples: 1 }).0;
        assert!(img.pixels.iter().all(|c| c.is_finite()), "scale {scale:e}: non-finite pixels");
        let lit = img.pixels.iter().filter(|&&c| c != GREY && c.x > 0.05).count();
        assert!(lit > 32, "scale {scale:e}: only {lit} pixels show the triangle");
    }
    for scale in [1e13f32, 1e20, 3e38] {
        let e = triangle_scene(scale, &dir).err().unwrap_or_else(|| panic!("scale {scale:e} was accepted")).to_string();
        assert!(e.contains("single precision") && e.contains("scale it down"), "scale {scale:e}: {e}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn cameras_that_cannot_form_rays_are_refused() {
    let p = isir::Vec3::new(1.0, 2.0, 3.0);
    let nan = isir::Vec3::new(f32::NAN, 0.0, 0.0);
    for (cam, why) in [
        (CameraDesc::new(p, p), "same point"),
        (CameraDesc::new(nan, p), "finite"),
        (CameraDesc { up: isir::Vec3::X, ..CameraDesc::new(p, p + isir::Vec3::X) }, "along"),
        (CameraDesc { fovy: 180.0, ..CameraDesc::new(p, isir::Vec3::ZERO) }, "fovy"),
        (CameraDesc::new(isir::Vec3::splat(1e30), p), "single precision"),
    ] {
        let e = SceneDescription::new("c", cam).build(Accel::BvhSah).unwrap_err().to_string();
        assert!(e.contains(why), "{cam:?}: {e}");
    }
}

#[test]
fn flat_models_in_any_axis_plane_are_framed_face_on_enough_to_see() {
    // A unit square in the xy, yz and xz planes: none may be seen edge-on (an empty image).
    for (name, a, b) in [("xy", isir::Vec3::X, isir::Vec3::Y), ("yz", isir::Vec3::Y, isir::Vec3::Z), ("xz", isir::Vec3::X, isir::Vec3::Z)] {
        let mesh = isir::TriangleMesh::new(vec![isir::Vec3::ZERO, a, a + b, b], vec![], vec![[0, 1, 2], [0, 2, 3]]);
        let (camera, _) = CameraDesc::framing(&mesh.aabb()).unwrap();
        let cam = camera.build(1.5);
        let (w, h) = (48, 32);
        let seen = (0..w * h)
            .filter(|i| {
                let ray = cam.generate_ray((i % w) as f32 / w as f32, (i / w) as f32 / h as f32);
                mesh.intersect_brute_force(&ray, 0.0, f32::INFINITY).is_some()
            })
            .count();
        assert!(seen > w * h / 20, "the {name} square covers only {seen} of {} pixels", w * h);
    }
}
