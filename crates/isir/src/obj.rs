//! Wavefront OBJ + MTL loading (through `tobj`), plain or gzip-compressed (`.obj.gz`).
//!
//! - Polygons are fan-triangulated in file order, `(v0, vi, vi+1)`; triangle `k` of the
//!   mesh is the `k`-th triangle so produced (the numbering of the ray/hit files).
//! - One material per file material, a ColorMaterial from `Kd`. Transparency (`d`, `Tr`)
//!   is ignored: the course's files say `Tr 1.0` and mean opaque.
//! - Missing normals: faces use their face normal. Degenerate triangles (zero area,
//!   non-finite vertices) stay in the numbering but are never hit, and are counted in a
//!   warning.
//! - Errors name the file and, where it can be found, the line.

use crate::color::{Color, WHITE};
use crate::error::{Error, Result};
use crate::geometry::TriangleMesh;
use glam::Vec3;
use std::io::{BufReader, Read};
use std::path::Path;

/// A material read from an MTL file.
#[derive(Clone, Debug, PartialEq)]
pub struct FileMaterial {
    /// Its name (`newmtl`).
    pub name: String,
    /// Its diffuse colour `Kd` (white when absent).
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

/// Read a file, decompressing it when its name ends in `.gz`.
///
/// # Errors
/// The file cannot be read or is not valid gzip.
pub fn read_file(path: &Path) -> Result<Vec<u8>> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let raw = std::fs::read(path).map_err(io)?;
    if path.extension().is_some_and(|e| e == "gz") {
        gunzip(&raw).map_err(io)
    } else {
        Ok(raw)
    }
}

/// Decompress gzip bytes.
///
/// # Errors
/// The bytes are not valid gzip.
pub fn gunzip(raw: &[u8]) -> std::io::Result<Vec<u8>> {
    let mut out = Vec::with_capacity(raw.len() * 4);
    flate2::read::GzDecoder::new(raw).read_to_end(&mut out)?;
    Ok(out)
}

/// Load an OBJ file (`.obj` or `.obj.gz`); its `mtllib` files are looked up beside it.
///
/// # Errors
/// The file cannot be read or is malformed.
pub fn load_obj(path: &Path) -> Result<LoadedMesh> {
    let bytes = read_file(path)?;
    let dir = path.parent().map(Path::to_path_buf).unwrap_or_default();
    parse_obj(path, &bytes, |mtl| {
        let p = dir.join(mtl);
        read_file(&p).ok().or_else(|| read_file(&p.with_extension("mtl.gz")).ok())
    })
}

/// Parse OBJ bytes. `mtl_loader` returns the bytes of a material library named by
/// `mtllib`, or `None` when there is none (then a warning is given and faces get the
/// default material). `path` only names the source in messages.
///
/// # Errors
/// Malformed OBJ: the error names `path` and the offending line.
pub fn parse_obj(path: &Path, bytes: &[u8], mtl_loader: impl Fn(&Path) -> Option<Vec<u8>>) -> Result<LoadedMesh> {
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
    let missing_mtl = std::cell::RefCell::new(Vec::new());
    let bad_mtl = std::cell::RefCell::new(Vec::new());
    let loaded = tobj::load_obj_buf(&mut BufReader::new(bytes), &options, |mtl| match mtl_loader(mtl) {
        Some(m) => match locate_mtl_error(&m) {
            // tobj panics on some malformed colour lines: check them first.
            Some((line, problem)) => {
                bad_mtl.borrow_mut().push(format!("{}:{line}: {problem}", mtl.display()));
                Err(tobj::LoadError::MaterialParseError)
            }
            None => tobj::load_mtl_buf(&mut BufReader::new(&m[..])),
        },
        None => {
            missing_mtl.borrow_mut().push(mtl.display().to_string());
            Err(tobj::LoadError::OpenFileFailed)
        }
    });
    let (models, materials) = match loaded {
        Ok(x) => x,
        Err(e) => {
            let (line, message) = locate_error(bytes).map_or((None, e.to_string()), |(l, m)| (Some(l), m));
            return Err(Error::Mesh { path: path.to_path_buf(), line, message });
        }
    };
    let mut warnings = Vec::new();
    let materials: Vec<FileMaterial> = match materials {
        Ok(m) => m.into_iter().map(|m| FileMaterial { diffuse: m.diffuse.map_or(WHITE, Color::from), name: m.name }).collect(),
        Err(e) => {
            let missing = missing_mtl.borrow();
            let bad = bad_mtl.borrow();
            if !bad.is_empty() {
                warnings.push(format!("material library {}; faces use the default material", bad.join(", ")));
            } else if missing.is_empty() {
                warnings.push(format!("material library: {e}; faces use the default material"));
            } else {
                warnings.push(format!("material library {} not found; faces use the default material", missing.join(", ")));
            }
            Vec::new()
        }
    };

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
                return Err(Error::Mesh { path: path.to_path_buf(), line: None, message: "face index out of range".into() });
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
    if stats.degenerate > 0 {
        warnings.push(format!("{} degenerate triangles (zero area or non-finite vertices) are never hit", stats.degenerate));
    }
    Ok(LoadedMesh { mesh, materials, warnings })
}

/// Find the first colour line of an MTL file without three numbers (tobj would panic).
fn locate_mtl_error(bytes: &[u8]) -> Option<(usize, String)> {
    let text = String::from_utf8_lossy(bytes);
    for (i, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = words.next() {
            let vals: Vec<&str> = words.take(3).collect();
            if vals.len() < 3 || vals.iter().any(|w| w.parse::<f32>().is_err()) {
                return Some((i + 1, format!("bad {key} '{}': expected 3 numbers", line.trim())));
            }
        }
    }
    None
}

/// Find the first line tobj would reject, to name it in the error.
fn locate_error(bytes: &[u8]) -> Option<(usize, String)> {
    let text = String::from_utf8_lossy(bytes);
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let lineno = i + 1;
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let floats = |words: std::str::SplitWhitespace, need: usize, what: &str| -> Option<String> {
            let vals: Vec<&str> = words.collect();
            if vals.len() < need || vals.iter().any(|w| w.parse::<f32>().is_err()) {
                Some(format!("bad {what} '{}': expected {need} numbers", line.trim()))
            } else {
                None
            }
        };
        let problem = match key {
            "v" => {
                nv += 1;
                // x y z, then nothing, a non-zero w, or r g b (tobj's rules).
                let vals: Vec<&str> = words.clone().collect();
                floats(words, 3, "vertex").or_else(|| match vals.len() {
                    3 | 6 => None,
                    4 if vals[3].parse::<f32>().is_ok_and(|w| w != 0.0) => None,
                    _ => Some(format!("bad vertex '{}': expected x y z, x y z w (w not 0) or x y z r g b", line.trim())),
                })
            }
            "vt" => {
                nvt += 1;
                floats(words, 2, "texture coordinate")
            }
            "vn" => {
                nvn += 1;
                floats(words, 3, "normal")
            }
            "f" => words.find_map(|w| {
                for (k, part) in w.split('/').enumerate() {
                    if part.is_empty() && k > 0 {
                        continue;
                    }
                    let n = [nv, nvt, nvn][k.min(2)];
                    if k > 0 && n == 0 {
                        continue; // tobj ignores texture and normal indices when there are none
                    }
                    match part.parse::<i64>() {
                        Ok(idx) if idx != 0 && (idx > 0 && idx <= n || idx < 0 && -idx <= n) => {}
                        Ok(idx) => {
                            return Some(format!(
                                "face index {idx} out of range (there are {n} {})",
                                ["vertices", "texture coordinates", "normals"][k.min(2)]
                            ))
                        }
                        Err(_) => return Some(format!("bad face element '{w}'")),
                    }
                }
                None
            }),
            _ => None,
        };
        if let Some(p) = problem {
            return Some((lineno, p));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(src: &str) -> Result<LoadedMesh> {
        parse_obj(Path::new("test.obj"), src.as_bytes(), |_| None)
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
    fn malformed_files_name_the_line() {
        let e = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:4:") && e.contains("out of range"), "{e}");
        let e = parse("v 0 0 0\nv 1 zero 0\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:2:") && e.contains("vertex"), "{e}");
        let e = parse("v 0 0 0\nf 1 a 1\n").unwrap_err().to_string();
        assert!(e.starts_with("test.obj:2:"), "{e}");
    }

    #[test]
    fn degenerate_and_nan_triangles_are_counted_not_fatal() {
        let m = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nv nan 0 0\nf 1 2 3\nf 1 2 4\nf 1 5 3\n").unwrap();
        assert_eq!(m.mesh.stats().degenerate, 2);
        assert!(m.warnings.iter().any(|w| w.contains("2 degenerate")), "{:?}", m.warnings);
    }

    #[test]
    fn malformed_material_library_is_a_warning_naming_its_line() {
        // tobj itself panics on a colour with fewer than three numbers.
        let m = parse_obj(Path::new("t.obj"), b"mtllib m.mtl\nusemtl a\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", |_| {
            Some(b"newmtl a\nKa 0 0 0\nKd 0.5\n".to_vec())
        })
        .unwrap();
        assert!(m.warnings.iter().any(|w| w.contains("m.mtl:3:") && w.contains("Kd")), "{:?}", m.warnings);
        assert!(m.materials.is_empty());
        assert_eq!(m.mesh.triangles.len(), 1);
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
