//! The course's scenes, built in and reproducible by name, and the models they use
//! (shipped inside the library, so a fresh clone renders them anywhere), and the
//! [`SceneDescription`] they are written in.
//!
//! This folder sits above [`crate::integrators`] (a description names the integrator it
//! is meant for) and [`crate::scene`] (it builds a [`crate::Scene`]), so it is not inside
//! `scene/`: the seam stays free of upward imports.

mod description;
mod file;
mod tp1;
mod tp2;
mod tp4;
mod tp5;
mod tp6;
mod tp7;

pub use description::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc, Transform, MAX_COORDINATE};
pub use file::{edit_distance, load_scene_file, parse_scene, to_toml, SceneFile};

use crate::error::{Error, Result};
use crate::geometry::{Plane, Sdf, Shading, Sphere};
use crate::integrators::Integrator;
use crate::io::obj::{self, LoadedMesh};
use crate::lights::Light;
use crate::materials::Material;
use crate::math::color::{BLUE, CYAN, GREEN, GREY, MAGENTA, RED, WHITE, YELLOW};
use glam::{Quat, Vec3};
use std::path::Path;
use tp4::{tp4_conference, tp4_room};

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
    names().into_iter().map(|n| (n, builtin(n).map(|d| d.summary).unwrap_or_default())).collect()
}

/// Every built-in scene's name, session by session.
fn names() -> Vec<&'static str> {
    let (early, late) = NAMES.split_at(NAMES.len() - 1); // TP1–TP4 | TP7
    let mut v = early.to_vec();
    v.extend(tp5::SCENES.iter().map(|s| s.0));
    v.extend(tp6::SCENES.iter().map(|s| s.0));
    v.extend(late);
    v
}

const NAMES: &[&str] = &[
    "tp1-sphere",
    "tp1-sphere-cam1",
    "tp1-sphere-cam2",
    "tp1-sphere-cam3",
    "tp1-sphere-cam4",
    "tp2-plane-point",
    "tp3-quad-soft",
    "tp4-sphere-flat",
    "tp4-sphere",
    "tp4-bunny",
    "tp4-conference",
    "tp7-implicit",
];

/// The scene rendered when none is named.
pub const DEFAULT_SCENE: &str = "tp4-bunny";

/// The built-in scene called `name`.
///
/// # Errors
/// [`Error::UnknownScene`] when there is none.
pub fn builtin(name: &str) -> Result<SceneDescription> {
    match name {
        "tp1-sphere" => Ok(tp1::sphere(name, CameraDesc::new(Vec3::ZERO, Vec3::Z), "TP1: a blue sphere, ray cast, camera at the origin")),
        "tp1-sphere-cam1" => Ok(tp1::sphere(
            name,
            CameraDesc::new(Vec3::new(0.0, 0.0, -2.0), Vec3::new(0.0, 0.0, 79.0)),
            "TP1 camera 1: moved back to (0,0,-2), looking at (0,0,79)",
        )),
        "tp1-sphere-cam2" => Ok(tp1::sphere(
            name,
            CameraDesc::new(Vec3::new(1.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 1.0)),
            "TP1 camera 2: at (1,0,0) looking along +z (the sphere moves right: +x is left)",
        )),
        "tp1-sphere-cam3" => Ok(tp1::sphere(
            name,
            CameraDesc::new(Vec3::new(0.0, 1.0, 0.0), Vec3::new(0.0, 1.0, 1.0)),
            "TP1 camera 3: at (0,1,0) looking along +z (the sphere moves down)",
        )),
        "tp1-sphere-cam4" => Ok(tp1::sphere(
            name,
            CameraDesc::new(Vec3::new(4.0, -1.0, 0.0), Vec3::new(-1.0, -1.0, 2.0)),
            "TP1 camera 4: at (4,-1,0) looking at (-1,-1,2)",
        )),
        "tp2-plane-point" => Ok(tp2::plane_point(name)),
        "tp3-quad-soft" => Ok(tp2::quad_soft(name)),
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
        "tp7-implicit" => Ok(tp7::tp7_implicit()),
        _ => {
            if let Some(&(n, sweep)) = tp5::SCENES.iter().find(|s| s.0 == name) {
                return Ok(tp5::scene(n, sweep));
            }
            if let Some(&(n, spheres, quad)) = tp6::SCENES.iter().find(|s| s.0 == name) {
                return Ok(tp6::scene(n, spheres, quad));
            }
            Err(Error::UnknownScene(name.to_string()))
        }
    }
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
