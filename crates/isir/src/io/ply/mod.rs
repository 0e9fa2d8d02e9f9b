//! PLY meshes (Greg Turk's polygon file format): ASCII and binary, either byte order,
//! through `ply-rs-bw`, read into typed vertex and face records (no hash map per
//! element) and checked before they become a [`TriangleMesh`]. The bodies of usual
//! files are read directly (`binary.rs`, `ascii.rs`: the same values, 2 to 5 times
//! faster); any other, or any problem in one, goes through `ply-rs-bw`, which names it.
//!
//! What is read: the `vertex` element's `x y z` (float or double), `nx ny nz` when all
//! three are there, `u v` (or `s t`, `texture_u texture_v`); the `face` element's
//! `vertex_indices` (or `vertex_index`) list, polygons split into fans. Other elements
//! and properties are skipped.
//!
//! Bad input, case by case:
//! - not PLY, a malformed header or body, a body cut short, fewer elements than the header
//!   declares: an error naming the file and the line (ASCII) or what was being read;
//! - an element declared twice, a property declared twice in one element, a face's
//!   `vertex_indices` that is not a list of integers: an error naming the header line
//!   (`ply-rs-bw` would keep the last declaration, or give the faces no indices);
//! - an ASCII line with more values than the header declares (a list's count included),
//!   which `ply-rs-bw` ignores: an error naming the line, whichever reader reads it;
//! - no `vertex` element, or one without `x y z`: an error;
//! - a face index that is negative or past the last vertex: an error naming the face;
//! - faces of one or two vertices: dropped, counted in a warning;
//! - NaN or infinite coordinates in a binary file, zero-area triangles: kept out of the
//!   acceleration structures (never hit) and counted in a warning, as for OBJ files; in an
//!   ASCII file `nan` or `inf` is not a number the PLY grammar knows: an error with the line;
//! - memory: the header's counts only bound the reading; nothing is allocated for what the
//!   file does not actually hold (at most 65,536 records ahead; binary elements without
//!   properties, whose records take no bytes, are not read record by record), and the
//!   file itself is read within the input limit ([`crate::io::input`]).

use crate::error::{Error, Result};
use crate::geometry::TriangleMesh;
use crate::io::obj::LoadedMesh;
use glam::{Vec2, Vec3};
use ply_rs_bw::parser::{Parser, Reader};
use ply_rs_bw::ply::{PropertyAccess, PropertyAccessResult};
use std::path::Path;

mod ascii;
mod binary;
#[cfg(test)]
mod tests;

/// One vertex record: the properties isir reads, and which of them were present.
#[derive(Clone, Copy, Debug, Default)]
struct Vertex {
    p: [f32; 3],
    n: [f32; 3],
    uv: [f32; 2],
    /// Bits 0–2: x, y, z; 3–5: nx, ny, nz; 6–7: u, v.
    present: u8,
}

impl Vertex {
    fn slot(name: &str) -> Option<usize> {
        Some(match name {
            "x" => 0,
            "y" => 1,
            "z" => 2,
            "nx" => 3,
            "ny" => 4,
            "nz" => 5,
            "u" | "s" | "texture_u" | "texture_s" => 6,
            "v" | "t" | "texture_v" | "texture_t" => 7,
            _ => return None,
        })
    }

    /// `value` into slot `i` (see [`Self::slot`]), marked present.
    fn put(&mut self, i: usize, value: f32) {
        match i {
            0..=2 => self.p[i] = value,
            3..=5 => self.n[i - 3] = value,
            _ => self.uv[i - 6] = value,
        }
        self.present |= 1 << i;
    }

    fn set(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        let Some(i) = Self::slot(name) else { return PropertyAccessResult::Ignored };
        self.put(i, value);
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Vertex {
    fn new() -> Self {
        Self::default()
    }
    fn set_float(&mut self, name: &str, value: f32) -> PropertyAccessResult {
        self.set(name, value)
    }
    fn set_double(&mut self, name: &str, value: f64) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
    fn set_char(&mut self, name: &str, value: i8) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_uchar(&mut self, name: &str, value: u8) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_short(&mut self, name: &str, value: i16) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_ushort(&mut self, name: &str, value: u16) -> PropertyAccessResult {
        self.set(name, f32::from(value))
    }
    fn set_int(&mut self, name: &str, value: i32) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
    fn set_uint(&mut self, name: &str, value: u32) -> PropertyAccessResult {
        self.set(name, value as f32)
    }
}

/// One face record: its vertex indices, widened so that negative ones can be reported.
#[derive(Clone, Debug, Default)]
struct Face {
    indices: Vec<i64>,
}

impl Face {
    fn set<T: Into<i64>>(&mut self, name: &str, values: Vec<T>) -> PropertyAccessResult {
        if name != "vertex_indices" && name != "vertex_index" {
            return PropertyAccessResult::Ignored;
        }
        self.indices = values.into_iter().map(Into::into).collect();
        PropertyAccessResult::Set
    }
}

impl PropertyAccess for Face {
    fn new() -> Self {
        Self::default()
    }
    fn set_list_char(&mut self, name: &str, v: Vec<i8>) -> PropertyAccessResult {
        self.set(name, v)
    }
    fn set_list_uchar(&mut self, name: &str, v: Vec<u8>) -> PropertyAccessResult {
        self.set(name, v)
    }
    fn set_list_short(&mut self, name: &str, v: Vec<i16>) -> PropertyAccessResult {
        self.set(name, v)
    }
    fn set_list_ushort(&mut self, name: &str, v: Vec<u16>) -> PropertyAccessResult {
        self.set(name, v)
    }
    fn set_list_int(&mut self, name: &str, v: Vec<i32>) -> PropertyAccessResult {
        self.set(name, v)
    }
    fn set_list_uint(&mut self, name: &str, v: Vec<u32>) -> PropertyAccessResult {
        self.set(name, v)
    }
}

/// An element isir does not read: every property ignored.
#[derive(Clone, Copy, Debug, Default)]
struct Skip;

impl PropertyAccess for Skip {
    fn new() -> Self {
        Skip
    }
}

/// A parser message on one line: its first sentence and the line of the file it quotes
/// (at most 80 characters), not the grammar's internals.
fn short(s: &str) -> String {
    let first = s.lines().next().unwrap_or("").trim();
    let quoted = s.split_once("String: '").and_then(|(_, rest)| rest.split_once('\'')).map(|(q, _)| q.trim());
    let cut = |q: &str| match q.char_indices().nth(80) {
        Some((i, _)) => format!("{}…", &q[..i]),
        None => q.to_string(),
    };
    match quoted {
        Some(q) => format!("{first} ('{}')", cut(q)),
        None => cut(first),
    }
}

/// True when `bytes` start as a PLY file does.
#[must_use]
pub fn is_ply(bytes: &[u8]) -> bool {
    bytes.starts_with(b"ply\n") || bytes.starts_with(b"ply\r\n")
}

/// Parse PLY bytes (already decompressed). `path` only names the source in messages.
///
/// # Errors
/// See the module documentation: each case names `path` and, for ASCII files, the line.
pub fn parse_ply(path: &Path, bytes: &[u8]) -> Result<LoadedMesh> {
    parse_ply_by(path, bytes, true)
}

/// [`parse_ply`], the body read directly when `direct` (and it can be: `binary.rs`,
/// `ascii.rs`), otherwise record by record.
fn parse_ply_by(path: &Path, bytes: &[u8], direct: bool) -> Result<LoadedMesh> {
    let fail = |line: Option<usize>, message: String| Error::Mesh { path: path.to_path_buf(), line, message };
    if !is_ply(bytes) {
        return Err(fail(Some(1), "not a PLY file (it does not start with the line 'ply')".into()));
    }
    // The crate writes "Line N: ..."; the line goes to the error's own field, and only
    // where it means something (the header, and the body of an ASCII file).
    let parse_error = |what: &str, e: ply_rs_bw::parser::ParseError, lines: bool| {
        let text = e.to_string();
        let message = match e.line() {
            Some(l) => text.strip_prefix(&format!("Line {l}: ")).unwrap_or(&text).to_string(),
            None => text,
        };
        fail(e.line().filter(|_| lines), format!("{what}: {}", short(&message)))
    };
    let mut reader = Reader::new(bytes);
    let header = Parser::<Skip>::new().read_header(&mut reader).map_err(|e| parse_error("header", e, true))?;
    let header_text = &bytes[..bytes.len() - reader.get_ref().len()];
    check_header(header_text).map_err(|(line, message)| fail(Some(line), format!("header: {message}")))?;
    let direct = direct.then(|| binary::read(&header, reader.get_ref()).or_else(|| ascii::read(&header, reader.get_ref())));
    let body = match direct.flatten() {
        Some(body) => body,
        None => read_records(&header, &mut reader, &fail, &parse_error)?,
    };
    finish(body, &header)
}

/// What `ply-rs-bw` lets through in a header it parses (`text`, from the `ply` line to
/// `end_header`), as the line (1-based) and the problem: an element declared twice, or a
/// property declared twice in one element (the crate keeps the last declaration in the
/// first one's place, and the body is then read with the wrong layout); a face's
/// `vertex_indices` (or `vertex_index`) that is not a list of integers (the crate gives
/// the faces no indices: they would all be dropped as faces of no vertices); a format
/// version other than 1.0.
fn check_header(text: &[u8]) -> std::result::Result<(), (usize, String)> {
    use std::collections::HashSet;
    let mut elements: HashSet<&str> = HashSet::new();
    let mut properties: HashSet<&str> = HashSet::new();
    let mut element = "";
    for (k, line) in text.split(|&b| b == b'\n').enumerate() {
        // The crate has read every line as UTF-8 text.
        let Ok(line) = std::str::from_utf8(line) else { continue };
        let tokens: Vec<&str> = line.split_ascii_whitespace().collect();
        match tokens[..] {
            // PLY has one version, 1.0 (the crate reads any number there).
            ["format", _, version] if version != "1.0" => {
                return Err((k + 1, format!("format version {version}: PLY has only version 1.0")));
            }
            ["element", name, ..] => {
                if !elements.insert(name) {
                    return Err((k + 1, format!("element '{name}' declared twice")));
                }
                properties.clear();
                element = name;
            }
            ["property", .., name] => {
                if !properties.insert(name) {
                    return Err((k + 1, format!("property '{name}' of element '{element}' declared twice")));
                }
                let is_float = |t: &str| matches!(t, "float" | "double" | "float32" | "float64");
                let indices = element == "face" && (name == "vertex_indices" || name == "vertex_index");
                if indices && !matches!(tokens[..], ["property", "list", _, item, _] if !is_float(item)) {
                    return Err((
                        k + 1,
                        format!("'{name}' must be a list of integers ('property list uchar int {name}'), not '{}'", tokens.join(" ")),
                    ));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// What a PLY body holds, as isir reads it.
#[derive(Debug, Default)]
pub(super) struct Body {
    positions: Vec<Vec3>,
    /// Empty unless the vertices have `nx ny nz`.
    normals: Vec<Vec3>,
    /// The vertices' texture coordinates, when they have both.
    uvs: Option<Vec<Vec2>>,
    /// The faces' fans.
    triangles: Vec<[u32; 3]>,
    /// Faces of fewer than three vertices: how many, and the first.
    short: (usize, usize),
}

impl Body {
    /// The vertices' positions, and their normals and texture coordinates where the
    /// records have all of them (every record has the first's properties).
    fn set_vertices(&mut self, records: &[Vertex]) {
        let present = records.first().map_or(0, |v| v.present);
        self.positions = records.iter().map(|v| Vec3::from(v.p)).collect();
        if present & 0b111_000 == 0b111_000 {
            self.normals = records.iter().map(|v| Vec3::from(v.n)).collect();
        }
        if present & 0b1100_0000 == 0b1100_0000 {
            self.uvs = Some(records.iter().map(|v| Vec2::from(v.uv)).collect());
        }
    }

    /// Face `f` (its indices checked): its fan, or counted when it has fewer than three
    /// vertices.
    fn add_face(&mut self, f: usize, face: &[u32]) {
        if face.len() < 3 {
            self.add_short(f, 1);
            return;
        }
        for k in 1..face.len() - 1 {
            self.triangles.push([face[0], face[k], face[k + 1]]);
        }
    }

    /// `count` faces of fewer than three vertices, the first of them face `first`.
    fn add_short(&mut self, first: usize, count: usize) {
        if count > 0 {
            if self.short.0 == 0 {
                self.short.1 = first;
            }
            self.short.0 += count;
        }
    }

    /// The faces of `later`, read after this body's.
    fn append_faces(&mut self, later: Body) {
        self.triangles.extend_from_slice(&later.triangles);
        self.add_short(later.short.1, later.short.0);
    }
}

/// The body read record by record through `ply-rs-bw`, each problem named.
fn read_records(
    header: &ply_rs_bw::ply::Header,
    reader: &mut Reader<&[u8]>,
    fail: &impl Fn(Option<usize>, String) -> Error,
    parse_error: &impl Fn(&str, ply_rs_bw::parser::ParseError, bool) -> Error,
) -> Result<Body> {
    let ascii = header.encoding == ply_rs_bw::ply::Encoding::Ascii;
    let reader_body: &[u8] = reader.get_ref();
    let mut vertices: Option<Vec<Vertex>> = None;
    let mut faces: Vec<Face> = Vec::new();
    // Faces of a binary element without properties (no indices: all short).
    let mut empty_faces = 0;
    // The ASCII body's lines, checked for values past the declared ones (which the crate
    // ignores) as the crate reads them: where the next element starts, and its line.
    let (mut at, mut line) = (0usize, reader.line());
    for def in header.elements.values() {
        let what = format!("element '{}' ({} declared)", def.name, def.count);
        // A binary record without properties takes no bytes, and the crate would make one
        // per declared record (10^12 if the header says so: memory, or time). What they
        // would give: vertices without x y z (an error if there are any), faces without
        // indices, nothing.
        let empty = !ascii && def.properties.is_empty();
        let read = match def.name.as_str() {
            "vertex" if empty => {
                vertices = Some(vec![Vertex::default(); def.count.min(1)]);
                Ok(())
            }
            "face" if empty => {
                empty_faces = def.count;
                Ok(())
            }
            _ if empty => Ok(()),
            "vertex" => Parser::<Vertex>::new().read_payload_for_element(reader, def, header).map(|v| vertices = Some(v)),
            "face" => Parser::<Face>::new().read_payload_for_element(reader, def, header).map(|f| faces = f),
            _ => Parser::<Skip>::new().read_payload_for_element(reader, def, header).map(|_| ()),
        };
        if ascii {
            // Up to the line the crate stopped at: a line before it with values too many
            // is the first problem.
            let until = match &read {
                Ok(()) => usize::MAX,
                Err(e) => e.line().unwrap_or(0),
            };
            if let Some((l, problem)) = ascii::values_past_the_declared(def, reader_body, &mut at, &mut line, until) {
                return Err(fail(Some(l), format!("{what}: {problem}")));
            }
        }
        read.map_err(|e| parse_error(&what, e, ascii))?;
    }
    let Some(vertices) = vertices else {
        return Err(fail(None, "no 'vertex' element".into()));
    };
    if let Some(v) = vertices.first() {
        if v.present & 0b111 != 0b111 {
            return Err(fail(None, "the 'vertex' element has no x, y and z properties".into()));
        }
    }
    let mut body = Body::default();
    body.set_vertices(&vertices);
    let n = body.positions.len();
    body.triangles.reserve(faces.len());
    let mut indices = Vec::new();
    for (f, face) in faces.iter().enumerate() {
        if let Some(&bad) = face.indices.iter().find(|&&i| i < 0 || i as u64 >= n as u64) {
            return Err(fail(
                None,
                format!("face {f} (0-based) refers to vertex {bad}, but there are {n} vertices (0 to {})", n as i64 - 1),
            ));
        }
        indices.clear();
        indices.extend(face.indices.iter().map(|&i| i as u32));
        body.add_face(f, &indices);
    }
    body.add_short(0, empty_faces);
    Ok(body)
}

/// The mesh of a body, with its warnings.
fn finish(body: Body, header: &ply_rs_bw::ply::Header) -> Result<LoadedMesh> {
    let Body { positions, normals, uvs, triangles, short } = body;
    let mut warnings = Vec::new();
    if short.0 > 0 {
        warnings.push(format!("{} faces with fewer than three vertices dropped (the first: face {})", short.0, short.1));
    }
    let mut mesh = TriangleMesh::new(positions, normals, triangles);
    if let Some(uvs) = uvs {
        mesh.uvs = uvs;
    }
    warnings.extend(crate::io::obj::mesh_warnings(&mesh, true));
    let format = match header.encoding {
        ply_rs_bw::ply::Encoding::Ascii => "PLY (ASCII)",
        ply_rs_bw::ply::Encoding::BinaryLittleEndian => "PLY (binary little endian)",
        ply_rs_bw::ply::Encoding::BinaryBigEndian => "PLY (binary big endian)",
    };
    Ok(LoadedMesh { mesh, materials: Vec::new(), warnings, format: format.into(), files: Vec::new() })
}
