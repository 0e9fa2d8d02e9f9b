//! The course's scenes, built in and reproducible by name, and the models they use
//! (shipped inside the library, so a fresh clone renders them anywhere), and the
//! [`SceneDescription`] they are written in.
//!
//! This folder sits above [`crate::integrators`] (a description names the integrator it
//! is meant for) and [`crate::scene`] (it builds a [`crate::Scene`]), so it is not inside
//! `scene/`: the seam stays free of upward imports.

mod description;

pub use description::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc, MAX_COORDINATE};

use crate::error::{Error, Result};
use crate::geometry::{Plane, Sdf, Shading};
use crate::integrators::Integrator;
use crate::io::obj::{self, LoadedMesh};
use crate::lights::Light;
use crate::materials::Material;
use crate::math::color::{BLUE, CYAN, GREEN, GREY, MAGENTA, RED, WHITE, YELLOW};
use glam::{Quat, Vec3};
use std::path::Path;

/// The models shipped with the library: name, OBJ bytes (gzip when the name of the
/// original ends in `.gz`), MTL bytes.
const MODELS: [(&str, &str, &[u8], &[u8]); 3] = [
    ("uvsphere", "uvsphere.obj", include_bytes!("../../data/uvsphere.obj"), include_bytes!("../../data/uvsphere.mtl")),
    ("Bunny", "Bunny.obj", include_bytes!("../../data/Bunny.obj"), include_bytes!("../../data/Bunny.mtl")),
    (
        "conference",
        "conference.obj.gz",
        include_bytes!("../../data/conference/conference.obj.gz"),
        include_bytes!("../../data/conference/conference.mtl"),
    ),
];

/// Names of the built-in models.
#[must_use]
pub fn builtin_models() -> Vec<&'static str> {
    MODELS.iter().map(|m| m.0).collect()
}

/// The OBJ text of a built-in model (decompressed), as it would be read from its file.
///
/// # Errors
/// No such model.
pub fn builtin_model_obj(name: &str) -> Result<Vec<u8>> {
    let (_, file, bytes, _) = model(name)?;
    unpack(file, bytes)
}

fn model(name: &str) -> Result<&'static (&'static str, &'static str, &'static [u8], &'static [u8])> {
    MODELS.iter().find(|m| m.0 == name).ok_or_else(|| Error::Scene(format!("no built-in model '{name}'")))
}

fn unpack(file: &str, bytes: &[u8]) -> Result<Vec<u8>> {
    if file.ends_with(".gz") {
        crate::io::input::gunzip(Path::new(file), bytes, &crate::io::input::ReadLimits::default())
    } else {
        Ok(bytes.to_vec())
    }
}

/// Load a built-in model with its material library. Its degenerate triangles (53,627 in
/// the conference room) are known facts about a shipped model, not warnings.
///
/// # Errors
/// No such model.
pub fn load_builtin_model(name: &str) -> Result<LoadedMesh> {
    let (_, file, bytes, mtl) = model(name)?;
    let bytes = unpack(file, bytes)?;
    obj::parse_obj_inner(Path::new(file), &bytes, |_| Ok(mtl.to_vec()), false)
}

/// Every built-in scene: `(name, one-line summary)`.
#[must_use]
pub fn list() -> Vec<(&'static str, String)> {
    NAMES.iter().map(|&n| (n, builtin(n).map(|d| d.summary).unwrap_or_default())).collect()
}

const NAMES: [&str; 5] = ["tp4-sphere-flat", "tp4-sphere", "tp4-bunny", "tp4-conference", "tp7-implicit"];

/// The scene rendered when none is named.
pub const DEFAULT_SCENE: &str = "tp4-bunny";

/// The built-in scene called `name`.
///
/// # Errors
/// [`Error::UnknownScene`] when there is none.
pub fn builtin(name: &str) -> Result<SceneDescription> {
    match name {
        "tp4-sphere-flat" => Ok(tp4_room(
            name,
            "uvsphere",
            Shading::Flat,
            Vec3::new(0.0, 2.0, -6.0),
            "TP4 figure 1a: uvsphere.obj with face normals in the room of planes",
        )),
        "tp4-sphere" => Ok(tp4_room(
            name,
            "uvsphere",
            Shading::Smooth,
            Vec3::new(0.0, 2.0, -6.0),
            "TP4 figure 1b: uvsphere.obj with interpolated normals",
        )),
        "tp4-bunny" => Ok(tp4_room(
            name,
            "Bunny",
            Shading::Smooth,
            Vec3::new(0.0, 2.0, -7.0),
            "TP4 figure 1c: Bunny.obj (31,599 triangles), camera moved back by 1",
        )),
        "tp4-conference" => Ok(tp4_conference()),
        "tp7-implicit" => Ok(tp7_implicit()),
        _ => Err(Error::UnknownScene(name.to_string())),
    }
}

/// TP4 Annex A: six coloured infinite planes, a cyan mesh, a point light.
fn tp4_room(name: &str, model: &'static str, shading: Shading, camera: Vec3, summary: &str) -> SceneDescription {
    let mut d = SceneDescription::new(name, CameraDesc::new(camera, Vec3::new(0.0, 0.0, 79.0)));
    d.summary = summary.to_string();
    for (n, c) in [
        ("RedColor", RED),
        ("GreenColor", GREEN),
        ("BlueColor", BLUE),
        ("GreyColor", GREY),
        ("MagentaColor", MAGENTA),
        ("YellowColor", YELLOW),
        ("CyanColor", CYAN),
    ] {
        d.materials.push((n.to_string(), Material::Color(c)));
    }
    d.objects.push(ObjectDesc {
        name: format!("{model}_defaultobject"),
        shape: ShapeDesc::Mesh { source: MeshSource::Builtin(model), shading },
        material: Some("CyanColor".into()),
    });
    let planes = [
        ("PlaneGround", Vec3::new(0.0, -3.0, 0.0), Vec3::Y, "GreyColor"),
        ("PlaneLeft", Vec3::new(5.0, 0.0, 0.0), -Vec3::X, "RedColor"),
        ("PlaneCeiling", Vec3::new(0.0, 7.0, 0.0), -Vec3::Y, "GreenColor"),
        ("PlaneRight", Vec3::new(-5.0, 0.0, 0.0), Vec3::X, "BlueColor"),
        ("PlaneFront", Vec3::new(0.0, 0.0, 10.0), -Vec3::Z, "MagentaColor"),
        ("PlaneRear", Vec3::new(0.0, 0.0, -10.0), Vec3::Z, "YellowColor"),
    ];
    for (n, p, normal, m) in planes {
        d.objects.push(ObjectDesc { name: n.to_string(), shape: ShapeDesc::Plane(Plane::new(p, normal)), material: Some(m.to_string()) });
    }
    d.lights.push(Light::Point { position: Vec3::new(0.0, 3.0, -5.0), color: WHITE, power: 100.0 });
    d.integrator = Integrator::DirectLighting { light_samples: 1 };
    d.spp = 4;
    d
}

/// TP4 figure 2: the conference room under a quad light.
fn tp4_conference() -> SceneDescription {
    let mut d = SceneDescription::new("tp4-conference", CameraDesc::new(Vec3::new(-250.0, 500.0, 330.0), Vec3::new(0.0, 350.0, 100.0)));
    d.summary = "TP4 figure 2: conference.obj (331,179 triangles) under a quad light, soft shadows".into();
    d.objects.push(ObjectDesc {
        name: "conference".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::Builtin("conference"), shading: Shading::Smooth },
        material: None,
    });
    d.lights.push(Light::Quad {
        corner: Vec3::new(900.0, 600.0, -300.0),
        u: Vec3::new(-800.0, 0.0, 0.0),
        v: Vec3::new(0.0, 0.0, 300.0),
        color: WHITE,
        power: 20.0,
    });
    d.integrator = Integrator::DirectLighting { light_samples: 8 };
    d.spp = 4;
    d
}

/// TP7: implicit surfaces, sphere traced, in the TP6 room (the Cornell planes without the
/// rear one) under its point light: a torus, a rounded box, a capsule, a sphere cut by a
/// box (intersection), and a smooth union of two spheres minus a box.
fn tp7_implicit() -> SceneDescription {
    let mut d = SceneDescription::new("tp7-implicit", CameraDesc::new(Vec3::new(0.0, 2.0, -6.0), Vec3::new(0.0, 0.0, 79.0)));
    d.summary = "TP7: implicit surfaces by sphere tracing (torus, rounded box, capsule, CSG, smooth union) in the TP6 room".into();
    for (n, c) in [
        ("Red", RED),
        ("Green", GREEN),
        ("Blue", BLUE),
        ("Grey", GREY),
        ("Magenta", MAGENTA),
        ("Yellow", YELLOW),
        ("Cyan", CYAN),
        ("White", WHITE),
    ] {
        d.materials.push((n.to_string(), Material::Lambert(c)));
    }
    let planes = [
        ("PlaneGround", Vec3::new(0.0, -3.0, 0.0), Vec3::Y, "Grey"),
        ("PlaneLeft", Vec3::new(5.0, 0.0, 0.0), -Vec3::X, "Red"),
        ("PlaneCeiling", Vec3::new(0.0, 7.0, 0.0), -Vec3::Y, "Green"),
        ("PlaneRight", Vec3::new(-5.0, 0.0, 0.0), Vec3::X, "Blue"),
        ("PlaneFront", Vec3::new(0.0, 0.0, 10.0), -Vec3::Z, "Magenta"),
    ];
    for (n, p, normal, m) in planes {
        d.objects.push(ObjectDesc { name: n.to_string(), shape: ShapeDesc::Plane(Plane::new(p, normal)), material: Some(m.to_string()) });
    }
    let tilt = |axis: Vec3, degrees: f32| Quat::from_axis_angle(axis.normalize(), degrees.to_radians());
    let blob = Sdf::sphere(Vec3::new(-0.55, 0.0, 0.0), 0.8)
        .smooth_union(Sdf::sphere(Vec3::new(0.6, 0.25, 0.0), 0.65), 0.6)
        .subtract(Sdf::Box { half: Vec3::new(1.5, 0.35, 0.35) }.translated(Vec3::new(0.0, 0.55, -0.7)));
    let shapes = [
        ("Torus", Sdf::Torus { major: 0.9, minor: 0.3 }.transformed(Vec3::new(3.0, -1.8, 4.6), tilt(Vec3::X, -60.0), 1.0), "Yellow"),
        (
            "RoundedBox",
            Sdf::RoundedBox { half: Vec3::splat(0.8), radius: 0.2 }.transformed(Vec3::new(-3.0, -2.2, 5.2), tilt(Vec3::Y, 30.0), 1.0),
            "Cyan",
        ),
        ("Capsule", Sdf::Capsule { a: Vec3::new(-0.9, -2.6, 7.0), b: Vec3::new(0.9, 0.4, 7.5), radius: 0.4 }, "White"),
        ("Blob", blob.translated(Vec3::new(0.7, -2.15, 3.0)), "Red"),
        (
            "CutSphere",
            Sdf::Sphere { radius: 0.75 }.intersection(Sdf::Box { half: Vec3::splat(0.58) }).transformed(
                Vec3::new(-1.45, -2.42, 2.9),
                tilt(Vec3::new(1.0, 1.0, 0.0), 25.0),
                1.0,
            ),
            "Green",
        ),
    ];
    for (n, sdf, m) in shapes {
        d.objects.push(ObjectDesc { name: n.to_string(), shape: ShapeDesc::Implicit(sdf), material: Some(m.to_string()) });
    }
    d.lights.push(Light::Point { position: Vec3::new(0.0, 5.0, 0.0), color: WHITE, power: 100.0 });
    d.integrator = Integrator::DirectLighting { light_samples: 1 };
    d.spp = 4;
    d
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_models_load_without_warnings() {
        for name in builtin_models() {
            let m = load_builtin_model(name).unwrap();
            assert!(m.warnings.is_empty(), "{name}: {:?}", m.warnings);
            assert!(!m.mesh.triangles.is_empty());
        }
        // The conference room has degenerate triangles: known, so not warned about.
        assert!(load_builtin_model("conference").unwrap().mesh.stats().degenerate > 50_000);
    }

    #[test]
    fn the_same_degenerate_triangles_in_a_user_file_are_warned_about() {
        let bytes = builtin_model_obj("conference").unwrap();
        let m = obj::parse_obj(Path::new("mine.obj"), &bytes, |p| Err(Error::Scene(format!("{} not here", p.display())))).unwrap();
        assert!(m.warnings.iter().any(|w| w.contains("degenerate triangles")), "{:?}", m.warnings);
    }
}
