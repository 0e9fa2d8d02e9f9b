//! Wavefront OBJ + MTL loading (through `tobj`), plain or gzip-compressed (`.obj.gz`).
//!
//! - Polygons are fan-triangulated in file order, `(v0, vi, vi+1)`; triangle `k` of the
//!   mesh is the `k`-th triangle so produced (the numbering of the ray/hit files).
//! - One material per file material, a ColorMaterial from `Kd`. Transparency (`d`, `Tr`)
//!   is ignored: the course's files say `Tr 1.0` and mean opaque. A negative `Kd`
//!   component is clamped to 0, and a `Kd` with a NaN or infinite component is replaced
//!   by the default white, each with a warning: a material problem never stops a render
//!   (a broken material library falls back to the default material the same way).
//! - Missing normals: faces use their face normal. Degenerate triangles (zero area,
//!   non-finite vertices) stay in the numbering but are never hit, and are counted in a
//!   warning (not for the built-in models, whose degenerate triangles are known).
//! - Dropped, and counted in one warning per kind with the first line: faces with fewer
//!   than 3 vertices, `l` (polyline) and `p` (point) elements, `usemtl` of a material the
//!   libraries do not define (those faces get the default material), and a last face cut
//!   short by a truncated file.
//! - Text: UTF-8 (with or without a byte-order mark) or ASCII; bytes that are not UTF-8
//!   (a Latin-1 `é` in a comment or a name) are read as Latin-1, as other readers accept
//!   them. UTF-16 files and binary data are refused with a message saying so.
//! - Other mesh formats (PLY, STL, glTF, FBX...) are recognised by name and by content
//!   and refused as not supported, rather than read as an OBJ without triangles.
//! - Files are read through [`crate::io::input`]: regular files only, at most
//!   [`ReadLimits::max_bytes`] (1 GiB by default, decompressed size for `.gz`; the
//!   `ISIR_MAX_INPUT_BYTES` environment variable changes it, e.g. `4G`), gzip members all
//!   read. A material library that cannot be read is a warning naming it and why.
//! - A material library is loaded once however many `mtllib` lines name it (or name a
//!   copy of it): the later lines add no materials. Each `map_Kd` image is decoded once,
//!   shared by its materials, all within the input limit (see `io/textures.rs`).
//! - Errors name the file and, where it can be found, the line; a quoted line or element
//!   is cut to 80 characters.

mod fast;
mod format;
mod scan;
#[cfg(test)]
mod tests;

use crate::error::{Error, Result};
use crate::geometry::TriangleMesh;
use crate::io::input::{self, ReadLimits};
use crate::io::textures::Textures;
use crate::math::color::{Color, WHITE};
use format::*;
use glam::Vec3;
use scan::*;
use std::borrow::Cow;
use std::cell::RefCell;
use std::path::{Path, PathBuf};

/// A material read from an MTL file.
#[derive(Clone, Debug, PartialEq)]
pub struct FileMaterial {
    /// Its name (`newmtl`).
    pub name: String,
    /// Its diffuse colour `Kd` (white when absent or not finite, negative parts clamped to 0).
    pub diffuse: Color,
    /// The colour texture it names (`map_Kd`), as the file writes it.
    pub texture_name: Option<String>,
    /// That texture, decoded, when the loader could read it (see [`load_obj`]).
    pub texture: Option<std::sync::Arc<crate::materials::Texture>>,
}

/// A loaded mesh with its file's materials and what loading had to say.
#[derive(Clone, Debug)]
pub struct LoadedMesh {
    /// The mesh; `material_slots` index `materials`, and `materials.len()` means "none".
    pub mesh: TriangleMesh,
    /// The file's materials.
    pub materials: Vec<FileMaterial>,
    /// Things handled but worth telling, one line each.
    pub warnings: Vec<String>,
    /// The file's format, for people: `Wavefront OBJ`, `PLY (binary little endian)`, ...
    pub format: String,
    /// The other files the load read (material libraries, textures, glTF buffers and
    /// images), for a caller that must not write over an input.
    pub files: Vec<PathBuf>,
}

/// The input limits from the environment (see [`ReadLimits::from_env`]), or an error
/// naming `path` and the bad variable.
pub(crate) fn env_limits(path: &Path) -> Result<ReadLimits> {
    ReadLimits::from_env().map_err(|message| Error::Input { path: path.to_path_buf(), message })
}

/// Read a file, decompressing it when its name ends in `.gz`, within the input limits
/// from the environment (see [`crate::io::input`]).
///
/// # Errors
/// The file is not a regular file, is over the limit, cannot be read or is not valid gzip.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    input::read_file(path, &env_limits(path)?)
}

/// Load an OBJ file (`.obj` or `.obj.gz`); its `mtllib` files are looked up beside it.
/// The input limit comes from `ISIR_MAX_INPUT_BYTES` when it is set (see [`crate::io::input`]).
///
/// # Errors
/// The file cannot be read, is not an OBJ file, or is malformed.
pub fn load_obj(path: &Path) -> Result<LoadedMesh> {
    load_obj_with(path, &env_limits(path)?)
}

/// [`load_obj`] with explicit input limits (for the OBJ and each of its material libraries).
///
/// # Errors
/// As [`load_obj`].
pub fn load_obj_with(path: &Path, limits: &ReadLimits) -> Result<LoadedMesh> {
    check_name(path)?;
    let bytes = input::read_file(path, limits)?;
    parse_obj_beside(path, &bytes, limits)
}

/// Refuse a file whose name says it is another mesh format (`model.stl`, `scene.glb`...),
/// before anything is read.
///
/// # Errors
/// The format the name says, as not read by isir (or, for PLY, not by the OBJ reader).
pub fn check_name(path: &Path) -> Result<()> {
    match format_by_name(path) {
        Some(format) => Err(Error::Input { path: path.to_path_buf(), message: unsupported(format) }),
        None => Ok(()),
    }
}

/// Parse the OBJ bytes of the file `path`, its `mtllib` files looked up beside it within
/// `limits` (what [`load_obj_with`] does once it has read the file).
///
/// # Errors
/// As [`parse_obj`].
pub fn parse_obj_beside(path: &Path, bytes: &[u8], limits: &ReadLimits) -> Result<LoadedMesh> {
    let mut loaded = parse_obj_only(path, bytes, limits)?;
    // Colour textures (`map_Kd`), beside the file: each file decoded once and shared by
    // the materials that name it, all within the input limit (see `io::textures`); one
    // that cannot be read is a warning and its material keeps its flat colour.
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let mut textures = Textures::new(limits);
    let log = input::ReadLog::default();
    for m in &mut loaded.materials {
        let Some(name) = m.texture_name.clone() else { continue };
        // MTL options (`-bm 1 -s 2 2 file.png`) come first; the file is the last word.
        let file = name.split_whitespace().last().unwrap_or(&name).to_string();
        let p = dir.join(&file);
        // The key is the file itself, however it is written (`big.png`, `./big.png`).
        let key = p.canonicalize().unwrap_or_else(|_| p.clone());
        match textures.get(key, || log.read(&p, limits).map_err(|e| e.to_string())) {
            Ok(t) => m.texture = Some(t),
            Err(why) => loaded.warnings.push(format!("material '{}': texture {file}: {why}; its flat colour is used", m.name)),
        }
    }
    loaded.files.extend(log.into_files());
    Ok(loaded)
}

/// [`parse_obj_beside`] without the textures.
fn parse_obj_only(path: &Path, bytes: &[u8], limits: &ReadLimits) -> Result<LoadedMesh> {
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    let log = input::ReadLog::default();
    let mut loaded = parse_obj(path, bytes, |mtl| {
        let p = dir.join(mtl);
        let not_found = |e: &Error| matches!(e, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound);
        match log.read(&p, limits) {
            Err(e) if not_found(&e) => match log.read(&p.with_extension("mtl.gz"), limits) {
                Err(e) if not_found(&e) => Err(Error::Input { path: p, message: "not found".into() }),
                r => r,
            },
            r => r,
        }
    })?;
    loaded.files = log.into_files();
    Ok(loaded)
}

/// Parse OBJ bytes. `mtl_loader` returns the bytes of a material library named by
/// `mtllib`, or an error (which names the file and why: missing, refused, unreadable);
/// then a warning is given and faces get the default material. `path` only names the
/// source in messages.
///
/// # Errors
/// Not an OBJ file, or malformed: the error names `path` and the offending line.
pub fn parse_obj(path: &Path, bytes: &[u8], mtl_loader: impl Fn(&Path) -> Result<Vec<u8>>) -> Result<LoadedMesh> {
    parse_obj_inner(path, bytes, mtl_loader, true)
}

/// [`parse_obj`], with the degenerate-triangle warning only when `report_degenerate`
/// (the built-in models' degenerate triangles are known facts, not news).
pub(crate) fn parse_obj_inner(
    path: &Path,
    bytes: &[u8],
    mtl_loader: impl Fn(&Path) -> Result<Vec<u8>>,
    report_degenerate: bool,
) -> Result<LoadedMesh> {
    parse_obj_by(path, bytes, mtl_loader, report_degenerate, Reader::Parallel(None))
}

/// Who reads an OBJ's geometry.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Reader {
    /// The parallel reader of `fast.rs` where the file is plain, tobj otherwise; in about
    /// so many chunks (`None`: by the file's size and the threads).
    Parallel(Option<usize>),
    /// tobj alone (the tests' reference).
    #[cfg_attr(not(test), allow(dead_code))]
    Tobj,
}

/// [`parse_obj_inner`] with the geometry read by `reader`.
fn parse_obj_by(
    path: &Path,
    bytes: &[u8],
    mtl_loader: impl Fn(&Path) -> Result<Vec<u8>>,
    report_degenerate: bool,
    reader: Reader,
) -> Result<LoadedMesh> {
    let mesh_error = |line: Option<usize>, message: String| Error::Mesh { path: path.to_path_buf(), line, message };
    if let Some(message) = format_by_content(bytes) {
        return Err(Error::Input { path: path.to_path_buf(), message });
    }
    let text = decode_text(bytes).map_err(|m| mesh_error(None, m))?;
    // PERF: the scan (one thread, line by line) beside the parallel reader, which reads
    // the same text: the conference room's load ~5 ms shorter. The reader's answer is
    // kept when the scan leaves the text as it is, which it does but for faces without
    // elements (which the reader declines).
    let read = |text: &str| match reader {
        Reader::Parallel(None) => fast::read_geometry(text),
        Reader::Parallel(Some(chunks)) => fast::read_geometry_in(text, chunks),
        Reader::Tobj => None,
    };
    let (scan, geometry) = rayon::join(|| scan_obj(&text), || read(&text));
    let scan = scan.map_err(|(line, m)| mesh_error(Some(line), m))?;
    let text = scan.neutralize(text);
    let geometry = if scan.hides_nothing() { geometry } else { read(&text) };

    // tobj calls the loader once per `mtllib` line, in file order: `libraries[k]` is the
    // names the k-th one defined, `None` when it failed.
    let libraries: RefCell<Vec<Option<Vec<String>>>> = RefCell::new(Vec::new());
    let mtl_warnings = RefCell::new(Vec::new());
    let loaded = RefCell::new(LoadedLibraries::default());
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let loader = |mtl: &Path| {
        let (library, notes) = loaded.borrow_mut().load(mtl, &mtl_loader);
        libraries.borrow_mut().push(library.as_ref().ok().map(|(materials, _)| materials.iter().map(|m| m.name.clone()).collect()));
        mtl_warnings.borrow_mut().extend(notes);
        library
    };
    // The parallel reader's models, with the materials tobj loaded for its skeleton; tobj
    // reads the whole file where that reader declines or the skeleton fails (its
    // libraries' notes then forgotten, as tobj loads them again).
    let fast = geometry.and_then(|geometry| {
        let (skeleton, runs) = geometry.skeleton(&text);
        let (models, materials) = tobj::load_obj_buf(&mut skeleton.as_bytes(), &options, loader).ok()?;
        Some((geometry.models(models, &runs)?, materials))
    });
    let loaded = match fast {
        Some(x) => Ok(x),
        None => {
            libraries.borrow_mut().clear();
            mtl_warnings.borrow_mut().clear();
            *loaded.borrow_mut() = LoadedLibraries::default();
            tobj::load_obj_buf(&mut text.as_bytes(), &options, loader)
        }
    };
    let (models, materials) = match loaded {
        Ok(x) => x,
        Err(e) => {
            let (line, message) = locate_error(&text).map_or((None, e.to_string()), |(l, m)| (Some(l), m));
            return Err(mesh_error(line, message));
        }
    };
    let mut warnings = mtl_warnings.into_inner();
    let materials: Vec<FileMaterial> = materials
        .unwrap_or_default()
        .into_iter()
        .map(|m| FileMaterial { diffuse: diffuse(m.diffuse), name: m.name, texture_name: m.diffuse_texture, texture: None })
        .collect();
    warnings.extend(scan.warnings(&text, &libraries.into_inner()));

    let mut vertices = Vec::new();
    let mut normals = Vec::new();
    let mut triangles = Vec::new();
    let mut slots = Vec::new();
    let mut all_normals = true;
    let mut uvs = Vec::new();
    let mut all_uvs = true;
    for model in &models {
        let m = &model.mesh;
        let base = vertices.len() as u32;
        let count = m.positions.len() / 3;
        vertices.extend(m.positions.chunks_exact(3).map(|p| Vec3::new(p[0], p[1], p[2])));
        if m.normals.len() == m.positions.len() {
            normals.extend(m.normals.chunks_exact(3).map(|n| Vec3::new(n[0], n[1], n[2])));
        } else {
            all_normals = false;
        }
        if m.texcoords.len() == count * 2 {
            uvs.extend(m.texcoords.chunks_exact(2).map(|t| glam::Vec2::new(t[0], t[1])));
        } else {
            all_uvs = false;
        }
        let slot = m.material_id.filter(|&id| id < materials.len()).unwrap_or(materials.len()) as u32;
        for t in m.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(mesh_error(None, "face index out of range".into()));
            }
            triangles.push([base + t[0], base + t[1], base + t[2]]);
            slots.push(slot);
        }
    }
    if !all_normals {
        if !normals.is_empty() {
            warnings.push("some faces have no normals: the whole mesh uses face normals".into());
        }
        normals.clear();
    }
    let mut mesh = TriangleMesh::new(vertices, normals, triangles);
    mesh.material_slots = slots;
    if all_uvs {
        mesh.uvs = uvs; // unused by the course's materials so far, kept for textures
    }
    warnings.extend(mesh_warnings(&mesh, report_degenerate));
    Ok(LoadedMesh { mesh, materials, warnings, format: "Wavefront OBJ".into(), files: Vec::new() })
}

/// What every mesh reader says about the mesh it made: no triangles, and, when
/// `degenerate`, how many triangles are degenerate.
pub(crate) fn mesh_warnings(mesh: &TriangleMesh, degenerate: bool) -> Vec<String> {
    let stats = mesh.stats();
    let mut w = Vec::new();
    if stats.triangles == 0 {
        w.push("no triangles".into());
    }
    if stats.degenerate > 0 && degenerate {
        w.push(match stats.degenerate {
            1 => "1 degenerate triangle (zero area or non-finite vertices) is never hit".to_string(),
            n => format!("{n} degenerate triangles (zero area or non-finite vertices) are never hit"),
        });
    }
    w
}

/// The colour of a material's `Kd`: white when absent or not finite (NaN would blacken
/// every pixel that sees it), negative components clamped to 0 (the scan of its library
/// warned about both).
fn diffuse(kd: Option<[f32; 3]>) -> Color {
    match kd {
        Some(c) if c.iter().all(|x| x.is_finite()) => Color::from(c).max(Vec3::ZERO),
        _ => WHITE,
    }
}

/// The material libraries an OBJ file's `mtllib` lines loaded so far, by the name the
/// line writes and by content, and whether each loaded. A library named again (on another
/// line, or spelled otherwise: `./a.mtl`, or a copy of it) adds nothing: tobj appends a
/// library's materials on every `mtllib` line, and 300 lines naming one library of
/// 100,000 materials were 30 million materials. So it is read once (by name) or parsed
/// once (by content), and the later lines give no materials, or the same failure without
/// a second warning; its names keep their first materials. Files that name each library
/// once are read as before.
#[derive(Default)]
struct LoadedLibraries {
    by_name: std::collections::HashMap<std::path::PathBuf, bool>,
    by_content: std::collections::HashMap<u64, bool>,
    hasher: std::collections::hash_map::RandomState,
}

impl LoadedLibraries {
    /// [`load_library`] for a library not loaded before; for one loaded already, no
    /// materials, or the same failure as before.
    fn load(&mut self, mtl: &Path, loader: &impl Fn(&Path) -> Result<Vec<u8>>) -> (tobj::MTLLoadResult, Vec<String>) {
        let again =
            |ok: bool| (if ok { Ok((Vec::new(), Default::default())) } else { Err(tobj::LoadError::MaterialParseError) }, Vec::new());
        if let Some(&ok) = self.by_name.get(mtl) {
            return again(ok);
        }
        let bytes = loader(mtl);
        let content = bytes.as_ref().ok().map(|b| std::hash::BuildHasher::hash_one(&self.hasher, b));
        if let Some(&ok) = content.and_then(|c| self.by_content.get(&c)) {
            self.by_name.insert(mtl.to_path_buf(), ok);
            return again(ok);
        }
        let (library, notes) = load_library(mtl, bytes);
        self.by_name.insert(mtl.to_path_buf(), library.is_ok());
        if let Some(c) = content {
            self.by_content.insert(c, library.is_ok());
        }
        (library, notes)
    }
}

/// Load the material library named `mtl` (as the `mtllib` line writes it) from `bytes`
/// (what its loader gave): its materials and the warnings about values it fixed, or an
/// error and the warning that says why it is not used.
fn load_library(mtl: &Path, bytes: Result<Vec<u8>>) -> (tobj::MTLLoadResult, Vec<String>) {
    let name = excerpt(&mtl.to_string_lossy());
    let failed =
        |why: String| (Err(tobj::LoadError::MaterialParseError), vec![format!("material library {why}; faces use the default material")]);
    let bytes = match bytes {
        Ok(b) => b,
        Err(e) => return failed(excerpt_ends(&e.to_string())),
    };
    let text = match decode_text(&bytes) {
        Ok(t) => t,
        Err(m) => return failed(format!("{name}: {m}")),
    };
    let scan = scan_mtl(&text);
    if let Some((line, problem)) = scan.error {
        // Checked before tobj, which panics on some malformed colour lines.
        return failed(format!("{name}:{line}: {problem}"));
    }
    let library = tobj::load_mtl_buf(&mut text.as_bytes());
    if let Err(e) = &library {
        return failed(format!("{name}: {e}"));
    }
    let mut notes = Vec::new();
    if let Some((line, material)) = &scan.negative_kd.first {
        notes.push(format!(
            "material library {name}: {} with a negative Kd clamped to 0 (first at line {line}, material '{material}')",
            plural(scan.negative_kd.count, "material"),
        ));
    }
    if let Some((line, material)) = &scan.nonfinite_kd.first {
        notes.push(format!(
            "material library {name}: {} with a NaN or infinite Kd {} the default white (first at line {line}, material '{material}')",
            plural(scan.nonfinite_kd.count, "material"),
            if scan.nonfinite_kd.count == 1 { "uses" } else { "use" },
        ));
    }
    (library, notes)
}

/// `n thing` or `n things`.
pub(super) fn plural(n: usize, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}

/// At most 80 characters of `s`, then `…`: messages quote lines, never echo megabytes.
pub(super) fn excerpt(s: &str) -> String {
    const MAX: usize = 80;
    match s.char_indices().nth(MAX) {
        Some((cut, _)) => format!("{}…", &s[..cut]),
        None => s.to_string(),
    }
}
