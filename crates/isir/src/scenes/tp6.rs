//! TP6: Whitted ray tracing. The room of TP4 without its rear wall, every plane an
//! Oren–Nayar matte (σ 0.6), two spheres of radius 1.5 at (±2, 0, 3); first both matte,
//! then the left one a mirror, then the right one glass (ior 1.3), each under the point
//! light or the quad light.

use super::*;
use crate::math::color::Color;

/// What the two spheres are made of.
#[derive(Clone, Copy, PartialEq)]
pub(super) enum Spheres {
    /// Both matte.
    Matte,
    /// The left one a mirror.
    Mirror,
    /// The left one a mirror, the right one glass.
    Glass,
}

/// The session's scenes: name, spheres, quad light (else point light).
pub(super) const SCENES: [(&str, Spheres, bool); 6] = [
    ("tp6-matte", Spheres::Matte, false),
    ("tp6-mirror", Spheres::Mirror, false),
    ("tp6-glass", Spheres::Glass, false),
    ("tp6-matte-quad", Spheres::Matte, true),
    ("tp6-mirror-quad", Spheres::Mirror, true),
    ("tp6-glass-quad", Spheres::Glass, true),
];

/// A TP6 scene: camera (0,2,-6) looking at (0,0,79); `PointLight((0,5,0), WHITE, 100)` or
/// `QuadLight((1,5,-2), (-2,0,0), (0,1,2), WHITE, 40)` with 16 samples; Whitted, 5 bounces.
pub(super) fn scene(name: &str, spheres: Spheres, quad: bool) -> SceneDescription {
    let mut d = SceneDescription::new(name, CameraDesc::new(Vec3::new(0.0, 2.0, -6.0), Vec3::new(0.0, 0.0, 79.0)));
    let what = match spheres {
        Spheres::Matte => "two matte spheres",
        Spheres::Mirror => "a mirror sphere (left) and a matte one",
        Spheres::Glass => "a mirror sphere (left) and a glass one (ior 1.3)",
    };
    let light = if quad { "the quad light, soft shadows" } else { "the point light" };
    d.summary = format!("TP6: {what} in the matte room under {light}, Whitted");
    let matte = |c: Color| Material::Matte { kd: c, sigma: 0.6 };
    for (n, m) in [
        ("RedMatte", matte(RED)),
        ("GreenMatte", matte(GREEN)),
        ("BlueMatte", matte(BLUE)),
        ("GreyMatte", matte(GREY)),
        ("MagentaMatte", matte(MAGENTA)),
        ("Mirror", Material::Mirror),
        ("Glass", Material::Transparent { ior: 1.3 }),
    ] {
        d.materials.push((n.to_string(), m));
    }
    let planes = [
        ("PlaneGround", Vec3::new(0.0, -3.0, 0.0), Vec3::Y, "GreyMatte"),
        ("PlaneLeft", Vec3::new(5.0, 0.0, 0.0), -Vec3::X, "RedMatte"),
        ("PlaneCeiling", Vec3::new(0.0, 7.0, 0.0), -Vec3::Y, "GreenMatte"),
        ("PlaneRight", Vec3::new(-5.0, 0.0, 0.0), Vec3::X, "BlueMatte"),
        ("PlaneFront", Vec3::new(0.0, 0.0, 10.0), -Vec3::Z, "MagentaMatte"),
    ];
    for (n, p, normal, m) in planes {
        d.objects.push(ObjectDesc { name: n.to_string(), shape: ShapeDesc::Plane(Plane::new(p, normal)), material: Some(m.to_string()) });
    }
    let (left, right) = match spheres {
        Spheres::Matte => ("GreyMatte", "GreyMatte"),
        Spheres::Mirror => ("Mirror", "GreyMatte"),
        Spheres::Glass => ("Mirror", "Glass"),
    };
    // +x is on the left of the image (the camera looks along +z).
    for (n, x, m) in [("SphereLeft", 2.0, left), ("SphereRight", -2.0, right)] {
        d.objects.push(ObjectDesc {
            name: n.to_string(),
            shape: ShapeDesc::Sphere(Sphere::new(Vec3::new(x, 0.0, 3.0), 1.5)),
            material: Some(m.to_string()),
        });
    }
    if quad {
        d.lights.push(Light::Quad {
            corner: Vec3::new(1.0, 5.0, -2.0),
            u: Vec3::new(-2.0, 0.0, 0.0),
            v: Vec3::new(0.0, 1.0, 2.0),
            color: WHITE,
            power: 40.0,
        });
    } else {
        d.lights.push(Light::Point { position: Vec3::new(0.0, 5.0, 0.0), color: WHITE, power: 100.0 });
    }
    d.integrator = Integrator::Whitted { light_samples: if quad { 16 } else { 1 }, max_depth: crate::integrators::DEFAULT_MAX_DEPTH };
    d.spp = 4;
    d
}
