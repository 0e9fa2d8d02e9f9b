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
//! - Files are read through [`crate::input`]: regular files only, at most
//!   [`ReadLimits::max_bytes`] (1 GiB by default, decompressed size for `.gz`; the
//!   `ISIR_MAX_INPUT_BYTES` environment variable changes it, e.g. `4G`), gzip members all
//!   read. A material library that cannot be read is a warning naming it and why.
//! - Errors name the file and, where it can be found, the line; a quoted line or element
//!   is cut to 80 characters.

use crate::color::{Color, WHITE};
use crate::error::{Error, Result};
use crate::geometry::TriangleMesh;
use crate::input::{self, ReadLimits};
use glam::Vec3;
use std::borrow::Cow;
use std::cell::RefCell;
use std::path::Path;

/// A material read from an MTL file.
#[derive(Clone, Debug, PartialEq)]
pub struct FileMaterial {
    /// Its name (`newmtl`).
    pub name: String,
    /// Its diffuse colour `Kd` (white when absent or not finite, negative parts clamped to 0).
    pub diffuse: Color,
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
}

/// The input limits from the environment (see [`ReadLimits::from_env`]), or an error
/// naming `path` and the bad variable.
fn env_limits(path: &Path) -> Result<ReadLimits> {
    ReadLimits::from_env().map_err(|message| Error::Input { path: path.to_path_buf(), message })
}

/// Read a file, decompressing it when its name ends in `.gz`, within the input limits
/// from the environment (see [`crate::input`]).
///
/// # Errors
/// The file is not a regular file, is over the limit, cannot be read or is not valid gzip.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    input::read_file(path, &env_limits(path)?)
}

/// Load an OBJ file (`.obj` or `.obj.gz`); its `mtllib` files are looked up beside it.
/// The input limit comes from `ISIR_MAX_INPUT_BYTES` when it is set (see [`crate::input`]).
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
    if let Some(format) = format_by_name(path) {
        return Err(Error::Input { path: path.to_path_buf(), message: unsupported(format) });
    }
    let bytes = input::read_file(path, limits)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_obj(path, &bytes, |mtl| {
        let p = dir.join(mtl);
        let not_found = |e: &Error| matches!(e, Error::Io { source, .. } if source.kind() == std::io::ErrorKind::NotFound);
        match input::read_file(&p, limits) {
            Err(e) if not_found(&e) => match input::read_file(&p.with_extension("mtl.gz"), limits) {
                Err(e) if not_found(&e) => Err(Error::Input { path: p, message: "not found".into() }),
                r => r,
            },
            r => r,
        }
    })
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
    let mesh_error = |line: Option<usize>, message: String| Error::Mesh { path: path.to_path_buf(), line, message };
    if let Some(message) = format_by_content(bytes) {
        return Err(Error::Input { path: path.to_path_buf(), message });
    }
    let text = decode_text(bytes).map_err(|m| mesh_error(None, m))?;
    let scan = scan_obj(&text).map_err(|(line, m)| mesh_error(Some(line), m))?;
    let text = scan.neutralize(text);

    // tobj calls the loader once per `mtllib` line, in file order: `libraries[k]` is the
    // names the k-th one defined, `None` when it failed.
    let libraries: RefCell<Vec<Option<Vec<String>>>> = RefCell::new(Vec::new());
    let mtl_warnings = RefCell::new(Vec::new());
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let loaded = tobj::load_obj_buf(&mut text.as_bytes(), &options, |mtl| {
        let (library, notes) = load_library(mtl, &mtl_loader);
        libraries.borrow_mut().push(library.as_ref().ok().map(|(materials, _)| materials.iter().map(|m| m.name.clone()).collect()));
        mtl_warnings.borrow_mut().extend(notes);
        library
    });
    let (models, materials) = match loaded {
        Ok(x) => x,
        Err(e) => {
            let (line, message) = locate_error(&text).map_or((None, e.to_string()), |(l, m)| (Some(l), m));
            return Err(mesh_error(line, message));
        }
    };
    let mut warnings = mtl_warnings.into_inner();
    let materials: Vec<FileMaterial> =
        materials.unwrap_or_default().into_iter().map(|m| FileMaterial { diffuse: diffuse(m.diffuse), name: m.name }).collect();
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
    let stats = mesh.stats();
    if stats.triangles == 0 {
        warnings.push("no triangles".into());
    }
    if stats.degenerate > 0 && report_degenerate {
        warnings.push(format!("{} degenerate triangles (zero area or non-finite vertices) are never hit", stats.degenerate));
    }
    Ok(LoadedMesh { mesh, materials, warnings })
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

/// Load the material library named `mtl` (as the `mtllib` line writes it): its materials
/// and the warnings about values it fixed, or an error and the warning that says why it
/// is not used.
fn load_library(mtl: &Path, loader: &impl Fn(&Path) -> Result<Vec<u8>>) -> (tobj::MTLLoadResult, Vec<String>) {
    let name = excerpt(&mtl.to_string_lossy());
    let failed =
        |why: String| (Err(tobj::LoadError::MaterialParseError), vec![format!("material library {why}; faces use the default material")]);
    let bytes = match loader(mtl) {
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
fn plural(n: usize, thing: &str) -> String {
    if n == 1 {
        format!("1 {thing}")
    } else {
        format!("{n} {thing}s")
    }
}

/// At most 80 characters of `s`, then `…`: messages quote lines, never echo megabytes.
fn excerpt(s: &str) -> String {
    const MAX: usize = 80;
    match s.char_indices().nth(MAX) {
        Some((cut, _)) => format!("{}…", &s[..cut]),
        None => s.to_string(),
    }
}

/// Mesh formats isir does not read, by file name ending (before any `.gz`).
const UNSUPPORTED: [(&str, &str); 15] = [
    ("ply", "PLY"),
    ("stl", "STL"),
    ("gltf", "glTF"),
    ("glb", "glTF (binary .glb)"),
    ("fbx", "FBX"),
    ("dae", "COLLADA"),
    ("3ds", "3DS"),
    ("usd", "USD"),
    ("usda", "USD"),
    ("usdc", "USD"),
    ("usdz", "USD"),
    ("abc", "Alembic"),
    ("off", "OFF"),
    ("x3d", "X3D"),
    ("wrl", "VRML"),
];

fn unsupported(format: &str) -> String {
    format!("{format} meshes are not supported yet (isir reads Wavefront OBJ only: .obj or .obj.gz)")
}

/// `s`, or its first and last 80 characters around a `…` when it is long: a message
/// naming a file keeps its reason, at the end, however long the name.
fn excerpt_ends(s: &str) -> String {
    const END: usize = 80;
    let n = s.chars().count();
    if n <= 2 * END + 1 {
        return s.to_string();
    }
    let tail = s.char_indices().nth(n - END).map_or(s.len(), |(i, _)| i);
    format!("{}…{}", excerpt(s).trim_end_matches('…'), &s[tail..])
}

/// The unsupported mesh format `path`'s name says, if any.
fn format_by_name(path: &Path) -> Option<&'static str> {
    let name = path.file_name()?.to_string_lossy().to_ascii_lowercase();
    let name = name.strip_suffix(".gz").unwrap_or(&name);
    let ext = name.rsplit_once('.')?.1;
    UNSUPPORTED.iter().find(|(e, _)| *e == ext).map(|(_, f)| *f)
}

/// Why `bytes` are not OBJ text, if their first bytes say so: another mesh format, or
/// compressed data the name does not announce.
fn format_by_content(bytes: &[u8]) -> Option<String> {
    let magic: [(&[u8], &str); 6] = [
        (b"ply\n", "PLY"),
        (b"ply\r\n", "PLY"),
        (b"glTF", "glTF (binary .glb)"),
        (b"Kaydara FBX Binary", "FBX"),
        (b"; FBX", "FBX"),
        (b"#VRML", "VRML"),
    ];
    if let Some((_, format)) = magic.iter().find(|(m, _)| bytes.starts_with(m)) {
        return Some(unsupported(format));
    }
    // Binary STL: an 80-byte header, a triangle count, 50 bytes per triangle.
    if let Some(count) = bytes.get(80..84) {
        let count = u64::from(u32::from_le_bytes([count[0], count[1], count[2], count[3]]));
        if 84 + 50 * count == bytes.len() as u64 {
            return Some(unsupported("STL (binary)"));
        }
    }
    let compressed: [(&[u8], &str); 5] = [
        (&[0x1f, 0x8b], "gzip-compressed data: name the file with a .gz ending (model.obj.gz) to have it decompressed"),
        (b"PK\x03\x04", "a ZIP archive: extract the OBJ file from it"),
        (&[0xfd, b'7', b'z', b'X', b'Z', 0], "xz-compressed data: isir decompresses gzip (.gz) only"),
        (&[0x28, 0xb5, 0x2f, 0xfd], "zstd-compressed data: isir decompresses gzip (.gz) only"),
        (b"BZh", "bzip2-compressed data: isir decompresses gzip (.gz) only"),
    ];
    if let Some((_, what)) = compressed.iter().find(|(m, _)| bytes.starts_with(m)) {
        return Some((*what).to_string());
    }
    let text = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes).trim_ascii_start();
    if text.starts_with(b"{") {
        let head = &text[..text.len().min(4096)];
        let gltf = head.windows(7).any(|w| w == b"\"asset\"");
        return Some(if gltf { unsupported("glTF") } else { "JSON data, not an OBJ mesh".into() });
    }
    if text.starts_with(b"solid") && text.get(5).is_none_or(u8::is_ascii_whitespace) {
        return Some(unsupported("STL (ASCII)"));
    }
    None
}

/// The text of an OBJ or MTL file: UTF-8 without its byte-order mark (which would hide the
/// first keyword from tobj), bytes that are not UTF-8 read as Latin-1 (one `é` in a comment
/// must not fail a valid file); UTF-16 and binary data refused with the reason.
fn decode_text(bytes: &[u8]) -> std::result::Result<Cow<'_, str>, String> {
    let head = &bytes[..bytes.len().min(1024) & !1];
    let zeros = |parity: usize| head.iter().skip(parity).step_by(2).filter(|&&b| b == 0).count();
    let (even, odd) = (zeros(0), zeros(1));
    let utf16 = if bytes.starts_with(&[0xff, 0xfe]) || bytes.starts_with(&[0xfe, 0xff]) {
        Some("UTF-16 text (it starts with a UTF-16 byte-order mark)")
    } else if head.len() >= 2 && (odd * 4 >= head.len() && even == 0 || even * 4 >= head.len() && odd == 0) {
        // ASCII in UTF-16 puts a NUL byte beside every character.
        Some("UTF-16 text (NUL bytes between its characters)")
    } else {
        None
    };
    if let Some(what) = utf16 {
        return Err(format!("{what}: isir reads UTF-8 or ASCII; save the file as UTF-8"));
    }
    if let Some(at) = head.iter().position(|&b| b == 0) {
        return Err(format!("binary data (a NUL byte at offset {at}), not a text file"));
    }
    let bytes = bytes.strip_prefix(b"\xef\xbb\xbf").unwrap_or(bytes);
    Ok(match std::str::from_utf8(bytes) {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => {
            let mut s = String::with_capacity(bytes.len() + bytes.len() / 16);
            for chunk in bytes.utf8_chunks() {
                s.push_str(chunk.valid());
                s.extend(chunk.invalid().iter().map(|&b| char::from(b)));
            }
            Cow::Owned(s)
        }
    })
}

/// How many lines of a kind, and the first.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    count: usize,
    first: usize,
}

impl Tally {
    fn add(&mut self, line: usize) {
        if self.count == 0 {
            self.first = line;
        }
        self.count += 1;
    }
}

/// What one cheap pass over an OBJ's lines found, beside what tobj reads.
#[derive(Debug, Default)]
struct ObjScan {
    /// `f` lines with fewer than 3 vertices (tobj drops them).
    short_faces: Tally,
    /// `l` lines (tobj would make polygons of those with 3 points or more: hidden from it).
    polylines: Tally,
    /// `p` lines (tobj ignores them).
    points: Tally,
    /// The last line, when the file ends inside a face: its number, and whether the face
    /// is dropped (fewer than 3 vertices) rather than kept with a possibly cut last vertex.
    truncated: Option<(usize, bool)>,
    /// `usemtl` lines: line number, byte offset, byte range of the name as tobj reads it.
    usemtl: Vec<(usize, usize, std::ops::Range<usize>)>,
    /// Byte offsets of the `mtllib` lines.
    mtllib: Vec<usize>,
    /// Byte offsets of the keywords of lines hidden from tobj: `l` lines and empty `f`
    /// lines (which tobj rejects as an invalid polygon, with no line number).
    hide: Vec<usize>,
}

/// The shape of a face line's elements, found without parsing them.
struct FaceShape {
    words: usize,
    ends_with_slash: bool,
    /// Worth a full check: a negative (relative) index or a number of 10 digits or more,
    /// on which tobj computes `index * 2` or `index * 3` unchecked (a panic, or a wrong
    /// normal read in silence); or non-ASCII text, where Unicode whitespace splits words.
    suspicious: bool,
}

/// The shape of the face elements in `rest` (what follows `f`) up to the end of its line,
/// and the length of that line part.
fn face_shape(rest: &str) -> (FaceShape, usize) {
    // This runs over every face of every mesh, in the same pass that finds the end of the
    // line: digits, the commonest bytes, go first.
    let bytes = rest.as_bytes();
    let (mut words, mut after_space, mut digits, mut suspicious, mut len) = (0, true, 0, false, bytes.len());
    for (i, &b) in bytes.iter().enumerate() {
        if b.is_ascii_digit() {
            digits += 1;
            suspicious |= digits == 10;
            if after_space {
                (words, after_space) = (words + 1, false);
            }
            continue;
        }
        digits = 0;
        // Rust's (and so tobj's) ASCII whitespace: ' ' and 9..=13, vertical tab included.
        if b == b' ' || b.wrapping_sub(9) < 5 {
            if b == b'\n' {
                len = i;
                break;
            }
            after_space = true;
            continue;
        }
        if after_space {
            (words, after_space) = (words + 1, false);
        }
        suspicious |= b == b'-' || b >= 0x80;
    }
    let rest = &rest[..len];
    let shape = if suspicious && !rest.is_ascii() {
        // Unicode whitespace splits words too.
        let all: Vec<&str> = rest.split_whitespace().collect();
        FaceShape { words: all.len(), ends_with_slash: all.last().is_some_and(|w| w.ends_with('/')), suspicious }
    } else {
        FaceShape { words, ends_with_slash: rest.trim_ascii_end().ends_with('/'), suspicious }
    };
    (shape, len)
}

/// The name tobj reads on a `usemtl` line: everything after the first space, trimmed
/// (so `usemtl<TAB>name` and a line indented by spaces do not name what they seem to).
fn tobj_usemtl_name(line: &str) -> &str {
    line.split_once(' ').map_or("", |(_, name)| name).trim()
}

/// One pass over the lines: counts what tobj drops, finds what it must not see, and checks
/// the few face elements tobj would mishandle (see [`FaceShape::suspicious`]).
fn scan_obj(text: &str) -> std::result::Result<ObjScan, (usize, String)> {
    let mut s = ObjScan::default();
    let mut counts = [0usize; 3];
    let (mut start, mut lineno) = (0, 0);
    while start < text.len() {
        lineno += 1;
        // A face line (most of a mesh's bytes) is read once: its shape, and where it ends.
        let face_first = text[start..].starts_with("f ");
        let (face, end) = if face_first {
            let (face, len) = face_shape(&text[start + 1..]);
            (Some(face), start + 1 + len)
        } else {
            (None, text[start..].find('\n').map_or(text.len(), |i| start + i))
        };
        let next = end + 1;
        let ends_file = end == text.len();
        // As `BufRead::lines` gives it to tobj: without "\n" or "\r\n".
        let line = &text[start..end];
        let line = line.strip_suffix('\r').unwrap_or(line);
        let line_start = std::mem::replace(&mut start, next);
        // The other lines that make up nearly all of a mesh, without splitting them into words.
        match line.as_bytes() {
            [b'v', b' ', ..] => {
                counts[0] += 1;
                continue;
            }
            [b'v', b't' | b'n', b' ', ..] => {
                counts[usize::from(line.as_bytes()[1] == b'n') + 1] += 1;
                continue;
            }
            _ => {}
        }
        let (key, body) = if face_first {
            ("f", line)
        } else {
            let body = line.trim_start();
            let Some(key) = body.split_whitespace().next() else { continue };
            (key, body)
        };
        let key_at = line_start + (line.len() - body.len());
        match key {
            "v" => counts[0] += 1,
            "vt" => counts[1] += 1,
            "vn" => counts[2] += 1,
            "f" => {
                let rest = &body[1..];
                let face = face.unwrap_or_else(|| face_shape(rest).0);
                if face.words == 0 {
                    s.hide.push(key_at);
                }
                if ends_file && (face.words < 3 || face.ends_with_slash) {
                    s.truncated = Some((lineno, face.words < 3));
                } else if face.words < 3 {
                    s.short_faces.add(lineno);
                }
                if face.words >= 3 && face.suspicious {
                    if let Some(problem) = rest.split_whitespace().find_map(|w| check_face_element(w, Some(counts))) {
                        return Err((lineno, problem));
                    }
                }
            }
            "l" => {
                s.polylines.add(lineno);
                s.hide.push(key_at);
            }
            "p" => s.points.add(lineno),
            "usemtl" => {
                // An empty name is an error tobj reports (and `locate_error` finds).
                let name = tobj_usemtl_name(line);
                if !name.is_empty() {
                    let at = line_start + (name.as_ptr() as usize - line.as_ptr() as usize);
                    s.usemtl.push((lineno, line_start, at..at + name.len()));
                }
            }
            "mtllib" => s.mtllib.push(line_start),
            _ => {}
        }
    }
    Ok(s)
}

impl ObjScan {
    /// `text` with the keywords of the lines tobj must not see turned into comments (same
    /// length, so offsets and line numbers hold); copied only when there are some.
    fn neutralize<'a>(&self, text: Cow<'a, str>) -> Cow<'a, str> {
        if self.hide.is_empty() {
            return text;
        }
        let mut bytes = text.into_owned().into_bytes();
        for &at in &self.hide {
            bytes[at] = b'#'; // an ASCII `f` or `l` becomes an ASCII `#`: still UTF-8
        }
        Cow::Owned(String::from_utf8(bytes).expect("one ASCII byte replaced by another"))
    }

    /// The warnings: one line per kind of dropped element. `libraries` are the names each
    /// `mtllib` line defined (`None`: it failed, and was warned about). They do not name
    /// the OBJ file: the scene prefixes its warnings with the object's name.
    fn warnings(&self, text: &str, libraries: &[Option<Vec<String>>]) -> Vec<String> {
        let mut w = Vec::new();
        for (tally, what) in [
            (self.short_faces, "with fewer than 3 vertices dropped"),
            (self.polylines, "ignored: polylines ('l') are not rendered"),
            (self.points, "ignored: points ('p') are not rendered"),
        ] {
            if tally.count > 0 {
                let noun = if what.starts_with("with") { "face" } else { "element" };
                w.push(format!("{} {what} (first at line {})", plural(tally.count, noun), tally.first));
            }
        }
        match self.truncated {
            Some((line, true)) => {
                w.push(format!("the file ends inside a face at line {line} (cut short?): that face is dropped"));
            }
            Some((line, false)) => {
                w.push(format!("the file ends inside a face at line {line} (cut short?): its last vertex may be incomplete"));
            }
            None => {}
        }
        // A library that failed was already warned about, with what its faces get.
        if libraries.iter().all(Option::is_some) {
            let mut known = std::collections::HashSet::new();
            let mut next_library = 0;
            let mut unknown = Tally::default();
            let mut first_name = "";
            for (line, at, name) in &self.usemtl {
                while next_library < self.mtllib.len() && self.mtllib[next_library] < *at {
                    known.extend(libraries.get(next_library).into_iter().flatten().flatten().map(String::as_str));
                    next_library += 1;
                }
                let name = &text[name.clone()];
                if !name.is_empty() && !known.contains(name) {
                    if unknown.count == 0 {
                        first_name = name;
                    }
                    unknown.add(*line);
                }
            }
            if unknown.count > 0 {
                w.push(format!(
                    "{} {} a material no material library defines (first at line {}: '{}'): their faces use the default material",
                    plural(unknown.count, "usemtl line"),
                    if unknown.count == 1 { "names" } else { "name" },
                    unknown.first,
                    excerpt(first_name),
                ));
            }
        }
        w
    }
}

/// What a scan of an MTL file found: the first line tobj would reject (or panic on), and
/// the `Kd` values that would not render.
#[derive(Debug, Default)]
struct MtlScan {
    error: Option<(usize, String)>,
    negative_kd: MaterialTally,
    nonfinite_kd: MaterialTally,
}

/// How many materials have a problem, and the first: its line and name.
#[derive(Debug, Default)]
struct MaterialTally {
    count: usize,
    first: Option<(usize, String)>,
}

impl MaterialTally {
    fn add(&mut self, line: usize, material: &str) {
        self.first.get_or_insert_with(|| (line, excerpt(material)));
        self.count += 1;
    }
}

/// Check an MTL file line by line as tobj reads it (its keywords, case-sensitive).
fn scan_mtl(text: &str) -> MtlScan {
    let mut s = MtlScan::default();
    let mut material = "";
    for (i, line) in text.lines().enumerate() {
        let lineno = i + 1;
        let line = line.trim();
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let quoted = || excerpt(line);
        let problem = match key {
            "newmtl" => {
                material = line[key.len()..].trim();
                material.is_empty().then(|| "newmtl without a material name".to_string())
            }
            "Ka" | "Kd" | "Ks" | "Ke" => {
                let vals: Vec<f32> = words.take(3).map_while(|w| w.parse().ok()).collect();
                if vals.len() < 3 {
                    Some(format!("bad {key} '{}': expected 3 numbers", quoted()))
                } else {
                    if key == "Kd" && vals.iter().any(|v| !v.is_finite()) {
                        s.nonfinite_kd.add(lineno, material);
                    } else if key == "Kd" && vals.iter().any(|&v| v < 0.0) {
                        s.negative_kd.add(lineno, material);
                    }
                    None
                }
            }
            "Ns" | "Ni" | "d" => {
                words.next().and_then(|w| w.parse::<f32>().ok()).is_none().then(|| format!("bad {key} '{}': expected a number", quoted()))
            }
            "illum" => words
                .next()
                .and_then(|w| w.parse::<u8>().ok())
                .is_none()
                .then(|| format!("bad illum '{}': expected an illumination model number (0 to 10)", quoted())),
            "map_Ka" | "map_Kd" | "map_Ks" | "map_Ns" | "map_ns" | "map_NS" | "map_d" | "map_Bump" | "map_bump" | "bump" => {
                line[key.len()..].trim().is_empty().then(|| format!("{key} without a file name"))
            }
            _ => None,
        };
        if let Some(p) = problem {
            s.error = Some((lineno, p));
            break;
        }
    }
    s
}

/// Check one face element `v`, `v/vt`, `v//vn` or `v/vt/vn` as tobj parses it; with the
/// vertex, texture-coordinate and normal counts so far, check its indices are in range too
/// (only for faces tobj keeps: it never looks up the indices of 1- and 2-vertex faces).
fn check_face_element(w: &str, counts: Option<[usize; 3]>) -> Option<String> {
    const KINDS: [&str; 3] = ["vertices", "texture coordinates", "normals"];
    for (k, part) in w.split('/').enumerate() {
        if part.is_empty() && k > 0 {
            continue; // `1//3`, or a trailing `/`: tobj skips empty parts
        }
        if k >= 3 {
            return Some(format!("bad face element '{}': more than 3 parts (v/vt/vn)", excerpt(w)));
        }
        let Ok(idx) = part.parse::<i64>() else { return Some(format!("bad face element '{}'", excerpt(w))) };
        let Some(counts) = counts else { continue };
        let n = counts[k] as u64;
        if k > 0 && (n == 0 || idx == 0) {
            continue; // tobj ignores texture and normal indices when there are none, and index 0
        }
        if idx == 0 || idx.unsigned_abs() > n {
            return Some(format!("face index {idx} out of range (there are {n} {})", KINDS[k]));
        }
    }
    None
}

/// Check a list of numbers as tobj reads it: the first `need` must be numbers (tobj
/// ignores what follows).
fn check_floats(mut words: std::str::SplitWhitespace, need: usize, what: &str, line: &str) -> Option<String> {
    let ok = words.by_ref().take(need).filter(|w| w.parse::<f32>().is_ok()).count() == need;
    (!ok).then(|| format!("bad {what} '{}': expected {need} numbers", excerpt(line.trim())))
}

/// Find the first line tobj would reject, to name it in the error (run only when tobj
/// failed, so it may take its time).
fn locate_error(text: &str) -> Option<(usize, String)> {
    let mut counts = [0usize; 3];
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let problem = match key {
            "v" => {
                counts[0] += 1;
                // x y z, then nothing, a non-zero w, or r g b (tobj's rules).
                let rest: Vec<&str> = words.clone().skip(3).collect();
                check_floats(words, 3, "vertex", line).or_else(|| match rest.len() {
                    0 | 3 => None,
                    1 if rest[0].parse::<f32>().is_ok_and(|w| w != 0.0) => None,
                    _ => Some(format!("bad vertex '{}': expected x y z, x y z w (w not 0) or x y z r g b", excerpt(line.trim()))),
                })
            }
            "vt" => {
                counts[1] += 1;
                check_floats(words, 2, "texture coordinate", line)
            }
            "vn" => {
                counts[2] += 1;
                check_floats(words, 3, "normal", line)
            }
            "f" => {
                let elements: Vec<&str> = words.collect();
                let kept = (elements.len() >= 3).then_some(counts);
                elements.iter().find_map(|w| check_face_element(w, kept))
            }
            "usemtl" if tobj_usemtl_name(line).is_empty() => {
                Some("usemtl without a material name (tobj wants a space, not a tab, after 'usemtl')".to_string())
            }
            _ => None,
        };
        if let Some(p) = problem {
            return Some((i + 1, p));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::path::PathBuf;

    const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

    fn no_mtl(p: &Path) -> Result<Vec<u8>> {
        Err(Error::Input { path: p.to_path_buf(), message: "not found".into() })
    }

    fn parse(src: &str) -> Result<LoadedMesh> {
        parse_obj(Path::new("test.obj"), src.as_bytes(), no_mtl)
    }

    fn parse_bytes(src: &[u8]) -> Result<LoadedMesh> {
        parse_obj(Path::new("t.obj"), src, no_mtl)
    }

    /// Parse `obj` with `mtl` as the bytes of every material library it names.
    fn with_mtl(obj: &str, mtl: &[u8]) -> LoadedMesh {
        parse_obj(Path::new("t.obj"), obj.as_bytes(), |_| Ok(mtl.to_vec())).unwrap()
    }

    /// A fresh directory for this test's files.
    fn tmp_dir(test: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("isir-obj-{}-{test}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn gz(data: &[u8]) -> Vec<u8> {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        e.write_all(data).unwrap();
        e.finish().unwrap()
    }

    fn warned(m: &LoadedMesh, parts: &[&str]) -> bool {
        m.warnings.iter().any(|w| parts.iter().all(|p| w.contains(p)))
    }

    #[test]
    fn texture_coordinates_are_kept_per_vertex() {
        let m = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n").unwrap();
        assert_eq!(m.mesh.uvs, vec![glam::Vec2::ZERO, glam::Vec2::X, glam::Vec2::Y]);
        assert!(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap().mesh.uvs.is_empty());
    }

    #[test]
    fn polygons_are_fans_in_file_order() {
        let m = parse("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nv -1 1 0\nf 1 2 3\nf 1 2 3 4 5\n").unwrap();
        let tris: Vec<[Vec3; 3]> = (0..m.mesh.triangles.len() as u32).map(|i| m.mesh.triangle_vertices(i)).collect();
        let v = |i: usize| [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y, Vec3::new(-1.0, 1.0, 0.0)][i];
        assert_eq!(tris, vec![[v(0), v(1), v(2)], [v(0), v(1), v(2)], [v(0), v(2), v(3)], [v(0), v(3), v(4)]]);
        assert!(m.mesh.normals.is_empty(), "no normals in the file");
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    }

    #[test]
    fn relative_and_zero_padded_indices_still_load() {
        // Both take the careful path of the scan (a '-', 10 digits); both are valid.
        let m = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//-1 -2//1 -1//+0000000001\n").unwrap();
        assert_eq!(m.mesh.triangle_vertices(0), [Vec3::ZERO, Vec3::X, Vec3::Y]);
        assert_eq!(m.mesh.normals, vec![Vec3::Z; 3]);
    }

    #[test]
    fn malformed_files_name_the_line() {
        let e = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:4:") && e.contains("out of range"), "{e}");
        let e = parse("v 0 0 0\nv 1 zero 0\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:2:") && e.contains("vertex"), "{e}");
        let e = parse("v 0 0 0\nf 1 a 1\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:2:"), "{e}");
        let e = parse(&format!("{TRI}usemtl\tred\nf 1 2 3\n")).unwrap_err().to_string();
        assert!(e.starts_with("test.obj:5: usemtl without a material name"), "{e}");
    }

    #[test]
    fn face_elements_with_more_than_three_parts_name_the_line() {
        let e = parse(&format!("{TRI}f 1/1/1/1/1/1/1/1 2 3\n")).unwrap_err().to_string();
        assert!(e.starts_with("test.obj:5: bad face element '1/1/1/1/1/1/1/1': more than 3 parts"), "{e}");
        // The same in a face of two vertices, which tobj parses (and drops).
        let e = parse(&format!("{TRI}f 1/1/1/1 2\n")).unwrap_err().to_string();
        assert!(e.starts_with("test.obj:5:") && e.contains("more than 3 parts"), "{e}");
    }

    #[test]
    fn indices_that_overflow_in_tobj_are_errors_not_panics() {
        // tobj multiplies such indices by 3 unchecked: a panic with overflow checks, and in
        // release either a panic or a wrong normal read in silence.
        let normals = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvn 0 1 0\n";
        for face in ["f 1//-9000000000000000000 2//1 3//1", "f 1//6148914691236517206 2//1 3//1", "f 1//6148914691236517207 2//1 3//1"] {
            let e = parse(&format!("{normals}{face}\n")).unwrap_err().to_string();
            assert!(e.starts_with("test.obj:6: face index") && e.contains("out of range (there are 2 normals)"), "{face}: {e}");
        }
        let e = parse("v 0 0 0\nf 1 -2 99999999999999999999\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:2:"), "{e}");
    }

    #[test]
    fn long_lines_are_quoted_short() {
        let huge = "x".repeat(4 << 20);
        for src in [format!("{TRI}v 1 2 {huge}\n"), format!("{TRI}f 1 2 3{}\n", "9".repeat(4 << 20)), format!("{TRI}f 1 2 {huge}\n")] {
            let e = parse(&src).unwrap_err().to_string();
            assert!(e.starts_with("test.obj:5:") && e.len() < 300 && e.contains('…'), "{} bytes: {}", e.len(), &e[..e.len().min(300)]);
        }
        let m = parse(&format!("mtllib {huge}.mtl\n{TRI}usemtl {huge}\nf 1 2 3\n")).unwrap();
        assert!(m.warnings.iter().all(|w| w.len() < 400), "{:?}", m.warnings.iter().map(String::len).collect::<Vec<_>>());
        assert!(warned(&m, &["material library xxxx", "…"]), "{:?}", m.warnings.iter().map(|w| excerpt(w)).collect::<Vec<_>>());
    }

    #[test]
    fn latin1_bytes_in_comments_and_names_are_read() {
        let obj = b"# caf\xe9\nmtllib m.mtl\no caf\xe9\ng gr\xfcn\nusemtl rouge\xe9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl rouge\xe8\nf 1 2 3\n";
        let m = parse_obj(Path::new("t.obj"), obj, |_| Ok(b"newmtl rouge\xe9\nKd 1 0 0\nnewmtl rouge\xe8\nKd 0 1 0\n".to_vec())).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        // Two names that differ only in their non-UTF-8 byte stay two materials.
        let names: Vec<&str> = m.materials.iter().map(|x| x.name.as_str()).collect();
        assert_eq!(names, ["rouge\u{e9}", "rouge\u{e8}"]);
        assert_eq!(m.mesh.material_slots, [0, 1]);
    }

    #[test]
    fn a_utf8_byte_order_mark_is_skipped() {
        let mut obj = b"\xef\xbb\xbfmtllib m.mtl\nusemtl a\n".to_vec();
        obj.extend_from_slice(TRI.as_bytes());
        let m = parse_obj(Path::new("t.obj"), &obj, |_| Ok(b"\xef\xbb\xbfnewmtl a\nKd 1 0 0\n".to_vec())).unwrap();
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        assert_eq!(m.materials[0].diffuse, Vec3::X);
        let mut obj = b"\xef\xbb\xbf".to_vec();
        obj.extend_from_slice(TRI.as_bytes());
        let m = parse_bytes(&obj).unwrap();
        assert_eq!(m.mesh.triangle_vertices(0), [Vec3::ZERO, Vec3::X, Vec3::Y], "the first vertex is read");
    }

    #[test]
    fn utf16_files_are_refused_saying_so() {
        let le: Vec<u8> = TRI.encode_utf16().flat_map(u16::to_le_bytes).collect();
        let be: Vec<u8> = TRI.encode_utf16().flat_map(u16::to_be_bytes).collect();
        for (what, bytes) in [("LE", [&[0xff, 0xfe][..], &le].concat()), ("BE", [&[0xfe, 0xff][..], &be].concat()), ("no BOM", le.clone())]
        {
            let e = parse_bytes(&bytes).unwrap_err().to_string();
            assert!(e.starts_with("t.obj: UTF-16 text") && e.contains("save the file as UTF-8"), "{what}: {e}");
        }
        let mtl: Vec<u8> = "newmtl a\nKd 1 0 0\n".encode_utf16().flat_map(u16::to_le_bytes).collect();
        let m = with_mtl(&format!("mtllib m.mtl\n{TRI}"), &mtl);
        assert!(warned(&m, &["material library m.mtl: UTF-16 text", "save the file as UTF-8"]), "{:?}", m.warnings);
        let e = parse_bytes(b"v 0 0 0\n\0\0\x01\x02garbage").unwrap_err().to_string();
        assert!(e.starts_with("t.obj: binary data"), "{e}");
    }

    #[test]
    fn degenerate_and_nan_triangles_are_counted_not_fatal() {
        let m = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\nf 1 5 3\n").unwrap();
        assert_eq!(m.mesh.stats().degenerate, 2);
        assert!(m.warnings.iter().any(|w| w.contains("2 degenerate")), "{:?}", m.warnings);
        let quiet = parse_obj_inner(Path::new("t.obj"), b"v 0 0 0\nv 1 0 0\nf 1 2 1\n", no_mtl, false).unwrap();
        assert_eq!(quiet.mesh.stats().degenerate, 1);
        assert!(quiet.warnings.is_empty(), "{:?}", quiet.warnings);
    }

    #[test]
    fn malformed_material_library_is_a_warning_naming_its_line() {
        // tobj itself panics on a colour with fewer than three numbers.
        let m = with_mtl("mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", b"newmtl a\nKa 0 0 0\nKd 0.5\n");
        assert!(warned(&m, &["m.mtl:3:", "Kd"]), "{:?}", m.warnings);
        assert!(m.materials.is_empty());
        assert_eq!(m.mesh.triangles.len(), 1);
    }

    #[test]
    fn every_mtl_line_tobj_rejects_names_the_file_and_line() {
        for (line, expect) in [
            ("Ka 1 x 0", "bad Ka"),
            ("Ks 1 1", "bad Ks"),
            ("Ke", "bad Ke"),
            ("Kd 0.5", "bad Kd"),
            ("Ns shiny", "bad Ns"),
            ("Ni", "bad Ni"),
            ("d half", "bad d"),
            ("illum 300", "bad illum"),
            ("illum two", "bad illum"),
            ("map_Kd", "map_Kd without a file name"),
            ("bump  ", "bump without a file name"),
            ("newmtl", "newmtl without a material name"),
        ] {
            let m = with_mtl(&format!("mtllib m.mtl\nusemtl a\n{TRI}"), format!("# materials\nnewmtl a\n{line}\nKd 1 1 1\n").as_bytes());
            assert!(warned(&m, &["material library m.mtl:3: ", expect, "faces use the default material"]), "{line}: {:?}", m.warnings);
            assert!(m.materials.is_empty() && m.warnings.len() == 1, "{line}: {:?}", m.warnings);
        }
        // What tobj accepts stays accepted: extra numbers, unknown keywords, a malformed `Tr`
        // (transparency is ignored).
        let m = with_mtl(&format!("mtllib m.mtl\nusemtl a\n{TRI}"), b"newmtl a\nKd 1 0 0 7\nTr x\nPr 0.5\nmap_Kd tex.png\n");
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
        assert_eq!(m.materials[0].diffuse, Vec3::X);
    }

    #[test]
    fn negative_kd_is_clamped_and_non_finite_kd_is_white() {
        let obj = format!("mtllib m.mtl\n{TRI}usemtl a\nf 1 2 3\nusemtl b\nf 1 2 3\nusemtl c\nf 1 2 3\nusemtl d\nf 1 2 3\n");
        let m = with_mtl(&obj, b"newmtl a\nKd -1 0.5 0\nnewmtl b\nKd nan 0 0\nnewmtl c\nKd 0 inf 0\nnewmtl d\nKd 0 0 -0.5\n");
        let kd: Vec<Vec3> = m.materials.iter().map(|x| x.diffuse).collect();
        assert_eq!(kd, [Vec3::new(0.0, 0.5, 0.0), WHITE, WHITE, Vec3::ZERO]);
        assert!(warned(&m, &["m.mtl: 2 materials with a negative Kd clamped to 0 (first at line 2, material 'a')"]), "{:?}", m.warnings);
        assert!(
            warned(&m, &["m.mtl: 2 materials with a NaN or infinite Kd use the default white (first at line 4, material 'b')"]),
            "{:?}",
            m.warnings
        );
        assert_eq!(m.warnings.len(), 2, "{:?}", m.warnings);
    }

    #[test]
    fn dropped_elements_are_counted_with_their_first_line() {
        let src = format!("{TRI}f 1 2\nl 1 2\nf 1\nl 1 2 3\np 1\nf\np 2 3\nf 3 2 1\nl 1 2 3 1\n");
        let m = parse(&src).unwrap();
        // `l 1 2 3` is a polyline, not a triangle (tobj would make one of it).
        assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [2, 1, 0]]);
        for w in [
            "3 faces with fewer than 3 vertices dropped (first at line 5)",
            "3 elements ignored: polylines ('l') are not rendered (first at line 6)",
            "2 elements ignored: points ('p') are not rendered (first at line 9)",
        ] {
            assert!(m.warnings.iter().any(|x| x == w), "{w}: {:?}", m.warnings);
        }
        assert_eq!(m.warnings.len(), 3, "{:?}", m.warnings);
    }

    #[test]
    fn crlf_tabs_and_indentation_are_scanned_as_tobj_reads_them() {
        let src =
            "v 0 0 0\r\nv 1 0 0\r\n\tv 0 1 0\r\nf\t1 2 3\r\n  f 1 2\r\n  l 1 2 3\r\nf\u{a0}1 2 3\r\nf 3 2\u{a0}1\r\nf 1 2 3 \r\nf 1 2";
        let m = parse(src).unwrap();
        // A no-break space splits words for tobj too: `f 3 2\u{a0}1` is a triangle.
        assert_eq!(m.mesh.triangles.len(), 4, "{:?}", m.warnings);
        assert!(warned(&m, &["1 face with fewer than 3 vertices dropped (first at line 5)"]), "{:?}", m.warnings);
        assert!(warned(&m, &["(first at line 6)", "'l'"]), "{:?}", m.warnings);
        assert!(warned(&m, &["the file ends inside a face at line 10"]), "{:?}", m.warnings);
        assert_eq!(m.warnings.len(), 3, "{:?}", m.warnings);
    }

    #[test]
    fn a_file_cut_inside_its_last_face_is_reported() {
        for (tail, dropped) in [("f 1 2", true), ("f 1/", true), ("f", true), ("f 1/1 2/2 3/", false)] {
            let src = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n{tail}");
            let m = parse(&src).unwrap();
            let what = if dropped { "that face is dropped" } else { "its last vertex may be incomplete" };
            assert!(warned(&m, &["the file ends inside a face at line 8 (cut short?): ", what]), "{tail}: {:?}", m.warnings);
            assert_eq!(m.mesh.triangles.len(), if dropped { 1 } else { 2 }, "{tail}");
            assert_eq!(m.warnings.len(), 1, "{tail}: {:?}", m.warnings);
        }
        // A whole last face without a final newline is no news.
        assert!(parse(TRI.trim_end()).unwrap().warnings.is_empty());
    }

    #[test]
    fn usemtl_of_an_unknown_material_is_counted() {
        let obj = format!("usemtl a\nmtllib m.mtl\n{TRI}usemtl a\nf 1 2 3\nusemtl b\nf 1 2 3\nusemtl c\nf 1 2 3\n");
        let m = with_mtl(&obj, b"newmtl a\nKd 1 0 0\n");
        // The first `usemtl a` comes before the library that defines `a`: tobj leaves it unknown.
        assert_eq!(m.mesh.material_slots, [1, 0, 1, 1]);
        let w = "3 usemtl lines name a material no material library defines (first at line 1: 'a'): their faces use the default material";
        assert!(m.warnings.iter().any(|x| x == w), "{:?}", m.warnings);
        assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
        // Without a library, that is the one warning.
        let m = parse(&format!("mtllib nowhere.mtl\nusemtl red\n{TRI}")).unwrap();
        assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings);
        assert!(warned(&parse(&format!("usemtl red\n{TRI}")).unwrap(), &["1 usemtl line names a material", "'red'"]));
    }

    #[test]
    fn vertex_and_texture_lines_follow_tobj_rules() {
        let e = parse("v 0 0 0 0\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:1:"), "{e}");
        let e = parse("v 0 0 0\nv 0 0 0 1 2\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:2:"), "{e}");
        let e = parse("v 0 0 0\nvt 0.5\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:2:"), "{e}");
        assert!(parse("v 0 0 0 1\nv 1 0 0 2\nv 0 1 0 1\nf 1 2 3\n").is_ok());
        assert!(parse("v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n").is_ok());
    }

    #[test]
    fn missing_material_library_is_a_warning() {
        let m = parse("mtllib nowhere.mtl\nusemtl red\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        assert!(m.warnings.iter().any(|w| w.contains("nowhere.mtl")), "{:?}", m.warnings);
        assert_eq!(m.mesh.material_slots, vec![0]);
        assert!(m.materials.is_empty());
    }

    #[test]
    fn unreadable_material_libraries_are_warnings_naming_them_and_why() {
        let dir = tmp_dir("mtl");
        std::fs::create_dir(dir.join("folder.mtl")).unwrap();
        let obj = dir.join("m.obj");
        std::fs::write(&obj, format!("mtllib /dev/zero\nmtllib folder.mtl\nmtllib gone.mtl\n{TRI}")).unwrap();
        let t = std::time::Instant::now();
        let m = load_obj(&obj).unwrap();
        assert!(t.elapsed().as_secs() < 2, "/dev/zero is refused, not read");
        assert!(warned(&m, &["material library /dev/zero: not a regular file (a character device)"]), "{:?}", m.warnings);
        assert!(warned(&m, &["folder.mtl: not a regular file (a directory)"]), "{:?}", m.warnings);
        assert!(warned(&m, &["gone.mtl: not found"]), "{:?}", m.warnings);
        assert_eq!(m.mesh.triangles.len(), 1);
    }

    #[test]
    fn a_fifo_as_material_library_does_not_block() {
        let dir = tmp_dir("fifo");
        assert!(std::process::Command::new("mkfifo").arg(dir.join("pipe.mtl")).status().expect("mkfifo runs").success());
        let obj = dir.join("m.obj");
        std::fs::write(&obj, format!("mtllib pipe.mtl\n{TRI}")).unwrap();
        let (tx, rx) = std::sync::mpsc::channel();
        // In a thread: a regression fails this test instead of hanging the suite.
        std::thread::spawn(move || tx.send(load_obj(&obj).map(|m| m.warnings)));
        let warnings = rx.recv_timeout(std::time::Duration::from_secs(5)).expect("load_obj returns").unwrap();
        assert!(warnings.iter().any(|w| w.contains("pipe.mtl: not a regular file (a FIFO)")), "{warnings:?}");
    }

    #[test]
    fn gzip_files_are_bounded_and_read_whole() {
        let dir = tmp_dir("gz");
        // Two gzip members, as parallel gzip tools write: the triangles of both load.
        let two = dir.join("two.obj.gz");
        std::fs::write(&two, [gz(TRI.as_bytes()), gz(b"v 0 0 1\nv 1 0 1\nv 0 1 1\nf 4 5 6\n")].concat()).unwrap();
        let m = load_obj(&two).unwrap();
        assert_eq!(m.mesh.triangles.len(), 2, "{:?}", m.warnings);
        // A bomb: 32 MiB of comment in 32 KiB, with a 1 MiB limit.
        let bomb = dir.join("bomb.obj.gz");
        std::fs::write(&bomb, gz(&vec![b'#'; 32 << 20])).unwrap();
        let e = load_obj_with(&bomb, &ReadLimits::new(1 << 20)).unwrap_err().to_string();
        assert!(e.contains("bomb.obj.gz: decompresses to more than the input limit of 1 MiB"), "{e}");
        let e = load_obj(Path::new("/dev/zero")).unwrap_err().to_string();
        assert_eq!(e, "/dev/zero: not a regular file (a character device)");
    }

    #[test]
    fn other_mesh_formats_are_named_not_read() {
        for (file, format) in [
            ("m.ply", "PLY"),
            ("m.PLY.gz", "PLY"),
            ("m.gltf", "glTF"),
            ("m.glb", "glTF (binary .glb)"),
            ("m.stl", "STL"),
            ("m.fbx.gz", "FBX"),
        ] {
            // Refused by name, before anything is read.
            let e = load_obj(&Path::new("/nonexistent").join(file)).unwrap_err().to_string();
            assert_eq!(
                e,
                format!("/nonexistent/{file}: {format} meshes are not supported yet (isir reads Wavefront OBJ only: .obj or .obj.gz)")
            );
        }
        let mut stl = vec![b' '; 80];
        stl.extend(1u32.to_le_bytes());
        stl.extend([0u8; 50]);
        let gltf = b"{\n  \"asset\": {\"version\": \"2.0\"}, \"meshes\": []\n}\n";
        for (bytes, format) in [
            (&b"ply\nformat ascii 1.0\nelement vertex 3\n"[..], "PLY meshes"),
            (b"glTF\x02\0\0\0\x10\0\0\0", "glTF (binary .glb) meshes"),
            (&stl, "STL (binary) meshes"),
            (b"solid cube\n  facet normal 0 0 1\n", "STL (ASCII) meshes"),
            (gltf, "glTF meshes"),
            (b"Kaydara FBX Binary  \0\x1a\0", "FBX meshes"),
            (&gz(TRI.as_bytes()), "gzip-compressed data: name the file with a .gz ending"),
        ] {
            let e = parse_bytes(bytes).unwrap_err().to_string();
            assert!(e.starts_with(&format!("t.obj: {format}")), "{format}: {e}");
        }
    }

    #[test]
    fn empty_file_is_an_empty_mesh() {
        let m = parse("# nothing\n").unwrap();
        assert_eq!(m.mesh.triangles.len(), 0);
        assert!(m.warnings.iter().any(|w| w.contains("no triangles")));
    }

    #[test]
    fn missing_file_is_an_error_naming_it() {
        let e = load_obj(Path::new("/nonexistent/x.obj")).unwrap_err().to_string();
        assert!(e.contains("/nonexistent/x.obj"), "{e}");
    }
}
