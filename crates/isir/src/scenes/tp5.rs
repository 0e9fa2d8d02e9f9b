//! TP5: materials. One sphere above a red Lambert plane, lit by a point light beside the
//! camera; the sphere's material is the session's subject, each value of its parameter
//! sweep a named scene (`tp5-oren-nayar-s0.2` ...); the name without a value is the
//! sweep's last value.

use super::*;
use crate::math::color::Color;

/// The material of a TP5 sphere.
#[derive(Clone, Copy)]
pub(super) enum Sweep {
    /// Oren–Nayar of this σ.
    OrenNayar(f32),
    /// Phong of this exponent.
    Phong(f32),
    /// Blinn–Phong of this exponent.
    BlinnPhong(f32),
    /// Cook–Torrance gold of this metalness.
    CookTorrance(f32),
}

/// The session's scenes, by name.
pub(super) const SCENES: [(&str, Sweep); 18] = [
    ("tp5-oren-nayar", Sweep::OrenNayar(0.6)),
    ("tp5-oren-nayar-s0.2", Sweep::OrenNayar(0.2)),
    ("tp5-oren-nayar-s0.4", Sweep::OrenNayar(0.4)),
    ("tp5-oren-nayar-s0.6", Sweep::OrenNayar(0.6)),
    ("tp5-phong", Sweep::Phong(64.0)),
    ("tp5-phong-s8", Sweep::Phong(8.0)),
    ("tp5-phong-s16", Sweep::Phong(16.0)),
    ("tp5-phong-s32", Sweep::Phong(32.0)),
    ("tp5-phong-s64", Sweep::Phong(64.0)),
    ("tp5-blinn-phong", Sweep::BlinnPhong(64.0)),
    ("tp5-blinn-phong-s8", Sweep::BlinnPhong(8.0)),
    ("tp5-blinn-phong-s16", Sweep::BlinnPhong(16.0)),
    ("tp5-blinn-phong-s32", Sweep::BlinnPhong(32.0)),
    ("tp5-blinn-phong-s64", Sweep::BlinnPhong(64.0)),
    ("tp5-cook-torrance", Sweep::CookTorrance(1.0)),
    ("tp5-cook-torrance-m0", Sweep::CookTorrance(0.0)),
    ("tp5-cook-torrance-m0.5", Sweep::CookTorrance(0.5)),
    ("tp5-cook-torrance-m1", Sweep::CookTorrance(1.0)),
];

/// The TP5 set: sphere (0,0,3) r 1 of the swept material, plane through (0,-2,0) facing +y
/// with a red Lambert material, `PointLight((0,0,-2), WHITE, 60)`, camera at the origin
/// looking along +z.
pub(super) fn scene(name: &str, sweep: Sweep) -> SceneDescription {
    let gold = Color::new(1.0, 0.85, 0.57);
    let (material, summary) = match sweep {
        Sweep::OrenNayar(sigma) => {
            (Material::Matte { kd: GREY, sigma }, format!("TP5: Oren–Nayar (MatteMaterial) grey sphere, σ = {sigma}"))
        }
        Sweep::Phong(s) => (
            Material::Plastic { kd: GREY, ks: WHITE, shininess: s, blinn: false },
            format!("TP5: Phong (PlasticMaterial) grey sphere, white highlight, s = {s}"),
        ),
        Sweep::BlinnPhong(s) => (
            Material::Plastic { kd: GREY, ks: WHITE, shininess: s, blinn: true },
            format!("TP5: Blinn–Phong grey sphere, white highlight, s = {s}"),
        ),
        Sweep::CookTorrance(metalness) => (
            Material::CookTorrance { kd: gold, f0: gold, roughness: 0.3, metalness },
            format!("TP5: Cook–Torrance gold (1, 0.85, 0.57) sphere, roughness 0.3, metalness {metalness}"),
        ),
    };
    let mut d = SceneDescription::new(name, CameraDesc::new(Vec3::ZERO, Vec3::Z));
    d.summary = summary;
    d.materials.push(("SphereMaterial".into(), material));
    d.materials.push(("RedLambert".into(), Material::Lambert(RED)));
    d.objects.push(ObjectDesc {
        name: "Sphere1".into(),
        shape: ShapeDesc::Sphere(Sphere::new(Vec3::new(0.0, 0.0, 3.0), 1.0)),
        material: Some("SphereMaterial".into()),
    });
    d.objects.push(ObjectDesc {
        name: "Plane1".into(),
        shape: ShapeDesc::Plane(Plane::new(Vec3::new(0.0, -2.0, 0.0), Vec3::Y)),
        material: Some("RedLambert".into()),
    });
    d.lights.push(Light::Point { position: Vec3::new(0.0, 0.0, -2.0), color: WHITE, power: 60.0 });
    d.integrator = Integrator::DirectLighting { light_samples: 1 };
    d.spp = 4;
    d
}
