//! Mesh files of any format isir reads: Wavefront OBJ ([`crate::io::obj`]), PLY
//! ([`crate::io::ply`]) and glTF ([`crate::io::gltf`]), each optionally gzip-compressed
//! (`.gz`). The format is known from the content first (a PLY file starts with the line
//! `ply`, a GLB file with `glTF`, a glTF file is JSON), then from the name; formats isir
//! does not read (STL, FBX...) are named as such.

use crate::error::Result;
use crate::io::input::{self, ReadLimits};
use crate::io::obj::{self, LoadedMesh};
use crate::io::{gltf, ply};
use std::path::Path;

/// Load a mesh file, within the input limit from the environment (`ISIR_MAX_INPUT_BYTES`,
/// see [`crate::io::input`]).
///
/// # Errors
/// The file cannot be read, is of a format isir does not read, or is malformed: the error
/// names the file and, where there is one, the line.
pub fn load_mesh(path: &Path) -> Result<LoadedMesh> {
    load_mesh_with(path, &obj::env_limits(path)?)
}

/// [`load_mesh`] with explicit input limits.
///
/// # Errors
/// As [`load_mesh`].
pub fn load_mesh_with(path: &Path, limits: &ReadLimits) -> Result<LoadedMesh> {
    let name = path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    if name.ends_with(".ply") {
        return ply::parse_ply(path, &input::read_file(path, limits)?);
    }
    if name.ends_with(".gltf") || name.ends_with(".glb") {
        return load_gltf(path, &input::read_file(path, limits)?, limits);
    }
    if !name.ends_with(".obj") {
        // Another format named by its extension is refused before anything is read.
        obj::check_name(path)?;
    }
    let bytes = input::read_file(path, limits)?;
    if ply::is_ply(&bytes) {
        return ply::parse_ply(path, &bytes);
    }
    if gltf::is_glb(&bytes) || bytes.trim_ascii_start().starts_with(b"{") {
        return load_gltf(path, &bytes, limits);
    }
    obj::parse_obj_beside(path, &bytes, limits)
}

/// A mesh file as the scene builds it: one mesh, or (a glTF file whose nodes place a mesh
/// more than once) each mesh in its own space with where the nodes place them.
#[derive(Clone, Debug)]
pub enum MeshFile {
    /// One mesh in world space.
    One(Box<LoadedMesh>),
    /// Meshes and their placements `(mesh, transform)`: instances.
    Instances(Vec<LoadedMesh>, gltf::Placements),
}

/// Read a mesh file for a scene: [`load_mesh`], except that a glTF file whose nodes share
/// a mesh gives its meshes once each and their placements.
///
/// # Errors
/// As [`load_mesh`].
pub fn load_mesh_file(path: &Path) -> Result<MeshFile> {
    let limits = obj::env_limits(path)?;
    let name = path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    if name.ends_with(".gltf") || name.ends_with(".glb") {
        let bytes = input::read_file(path, &limits)?;
        let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
        // The file is parsed once, whether its nodes share meshes or not.
        let log = input::ReadLog::default();
        let (mut meshes, placements) = gltf::parse_gltf_instances(path, &bytes, |uri| log.read(&dir.join(uri), &limits), &limits)?;
        let files = log.into_files();
        for m in &mut meshes {
            m.files.clone_from(&files);
        }
        return Ok(match placements {
            Some(placements) => MeshFile::Instances(meshes, placements),
            None => MeshFile::One(Box::new(meshes.remove(0))),
        });
    }
    load_mesh_with(path, &limits).map(|m| MeshFile::One(Box::new(m)))
}

/// A glTF file's bytes, its external buffers read beside it within `limits`.
fn load_gltf(path: &Path, bytes: &[u8], limits: &ReadLimits) -> Result<LoadedMesh> {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let log = input::ReadLog::default();
    let mut loaded = gltf::parse_gltf_with(path, bytes, |uri| log.read(&dir.join(uri), limits), limits)?;
    loaded.files = log.into_files();
    Ok(loaded)
}
