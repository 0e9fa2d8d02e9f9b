//! glTF 2.0 meshes, `.gltf` (JSON with its buffers beside it or in `data:` URIs) and
//! `.glb` (binary), through the `gltf` crate: the default scene's node hierarchy with its
//! transforms, indexed or not indexed triangles, normals, the first texture coordinates,
//! and each material's base colour factor and texture. Every node's mesh is placed in world space and
//! the whole scene becomes one [`TriangleMesh`], one material slot per glTF material.
//!
//! Every accessor is checked before it is read (component type, dimensions, offsets and
//! strides inside their buffer view and buffer, with overflow-checked arithmetic), so a
//! malformed file is an error naming the file and the element, never a panic in the
//! reader; buffers are read within the input limit ([`crate::io::input`]). Bad input,
//! case by case:
//! - a version other than 2.x (`asset.version`, the GLB header's): an error ("glTF 1.0 is
//!   not supported (only 2.x)"), also when the file is not valid 2.0 otherwise;
//! - invalid JSON or GLB, a validation failure, a missing or short buffer, an accessor
//!   outside its data, a cycle in the node hierarchy, an index past the last vertex:
//!   an error;
//! - primitives that are not triangles (points, lines, strips, fans) and sparse
//!   accessors: left out, counted in a warning;
//! - a base-colour texture that cannot be read or decoded: a warning, the colour factor
//!   is used (a readable one multiplies the factor, sampled at TEXCOORD_0);
//! - NaN coordinates, zero-area triangles: never hit, counted in a warning;
//! - a file that expands past the input limit ([`ReadLimits::max_bytes`], 1 GiB by
//!   default): an error naming the mesh and primitive where it does, and the reuse that
//!   made it (an accessor read by many primitives, a mesh placed by many nodes). What the
//!   meshes take (vertices, normals, texture coordinates, triangles and their material
//!   slots, and each mesh's copy of the materials) is counted from the accessors' counts
//!   before anything is read, with 32 bytes more for each placed primitive: a 400 KB file
//!   that places a 100,000-triangle mesh 3000 times, or reads one accessor of 300,000
//!   indices in 3000 primitives, asked for gigabytes;
//! - images: each decoded once and shared by the materials that use it, within the input
//!   limit too (see `io/textures.rs`).

use crate::error::{Error, Result};
use crate::geometry::TriangleMesh;
use crate::io::input::ReadLimits;
use crate::io::obj::{FileMaterial, LoadedMesh};
use crate::io::textures::Textures;
use crate::math::color::Color;
use base64::Engine;
use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use std::path::Path;

/// Why a file of `asset.version` `version` is not read: any but 2.x.
fn version_problem(version: &str) -> Option<String> {
    if version.split('.').next() == Some("2") {
        return None;
    }
    let shown: String = version.chars().take(20).collect();
    Some(if version.split('.').all(|p| !p.is_empty() && p.bytes().all(|b| b.is_ascii_digit())) {
        format!("glTF {shown} is not supported (only 2.x)")
    } else {
        format!("asset.version '{shown}' is not a glTF version (only glTF 2.x is supported)")
    })
}

/// For a file the `gltf` crate refuses, the version problem when it is of another glTF
/// version: a GLB header of version 1, or JSON whose `asset.version` is not 2.x.
fn unsupported_version(bytes: &[u8]) -> Option<String> {
    if is_glb(bytes) {
        let v = u32::from_le_bytes(bytes.get(4..8)?.try_into().ok()?);
        return match v {
            1 => Some("glTF 1.0 (binary) is not supported (only 2.x)".into()),
            2 => None,
            v => Some(format!("GLB version {v} is not supported (only 2)")),
        };
    }
    let json: gltf::json::Value = gltf::json::deserialize::from_slice(bytes).ok()?;
    version_problem(json.get("asset")?.get("version")?.as_str()?)
}

/// True when `bytes` are binary glTF.
#[must_use]
pub fn is_glb(bytes: &[u8]) -> bool {
    bytes.starts_with(b"glTF")
}

/// Parse glTF bytes (`.gltf` JSON or `.glb`). `load_uri` returns the bytes of a buffer
/// named by a relative URI (the file beside the glTF file); `path` names the source in
/// messages. What the file may expand to is bounded by the default input limit.
///
/// # Errors
/// See the module documentation.
pub fn parse_gltf(path: &Path, bytes: &[u8], load_uri: impl Fn(&str) -> Result<Vec<u8>>) -> Result<LoadedMesh> {
    parse_gltf_with(path, bytes, load_uri, &ReadLimits::default())
}

/// [`parse_gltf`] with explicit input limits, which bound what the file expands to and
/// its decoded textures.
///
/// # Errors
/// As [`parse_gltf`].
pub fn parse_gltf_with(path: &Path, bytes: &[u8], load_uri: impl Fn(&str) -> Result<Vec<u8>>, limits: &ReadLimits) -> Result<LoadedMesh> {
    let (mut meshes, _) = parse_inner(path, bytes, &load_uri, false, limits)?;
    Ok(meshes.remove(0))
}

/// Where a glTF file's nodes place its meshes: `(mesh, transform)`.
pub type Placements = Vec<(usize, glam::Affine3A)>;

/// The meshes of a glTF file, read once for a scene: when some mesh is placed more than
/// once, each mesh in its own space and the placements (instances, to be built once each);
/// otherwise the one world-space mesh of [`parse_gltf`] and `None`.
///
/// # Errors
/// As [`parse_gltf_with`].
pub fn parse_gltf_instances(
    path: &Path,
    bytes: &[u8],
    load_uri: impl Fn(&str) -> Result<Vec<u8>>,
    limits: &ReadLimits,
) -> Result<(Vec<LoadedMesh>, Option<Placements>)> {
    parse_inner(path, bytes, &load_uri, true, limits)
}

/// Read the file; with `instances` and a mesh placed twice, one [`LoadedMesh`] per glTF
/// mesh in its own space and the placements; otherwise one mesh in world space.
fn parse_inner(
    path: &Path,
    bytes: &[u8],
    load_uri: &dyn Fn(&str) -> Result<Vec<u8>>,
    instances: bool,
    limits: &ReadLimits,
) -> Result<(Vec<LoadedMesh>, Option<Placements>)> {
    let fail = |message: String| Error::Mesh { path: path.to_path_buf(), line: None, message };
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| match unsupported_version(bytes) {
        // glTF 1.0 is laid out otherwise: say so rather than what 2.0 finds wrong in it.
        Some(message) => fail(message),
        None => match e {
            gltf::Error::Deserialize(j) => Error::Mesh { path: path.to_path_buf(), line: Some(j.line()), message: format!("JSON: {j}") },
            e => fail(format!("{e}")),
        },
    })?;
    if let Some(message) = version_problem(&gltf.document.as_json().asset.version) {
        return Err(fail(message));
    }
    let doc = &gltf.document;
    // ---- Buffers ----
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for b in doc.buffers() {
        let data = match b.source() {
            gltf::buffer::Source::Bin => {
                gltf.blob.clone().ok_or_else(|| fail(format!("buffer {} is the GLB binary chunk, which is missing", b.index())))?
            }
            gltf::buffer::Source::Uri(uri) => match uri.strip_prefix("data:") {
                Some(rest) => {
                    let (_, payload) =
                        rest.split_once(";base64,").ok_or_else(|| fail(format!("buffer {}: a data URI that is not base64", b.index())))?;
                    base64::engine::general_purpose::STANDARD
                        .decode(payload)
                        .map_err(|e| fail(format!("buffer {}: bad base64 in its data URI: {e}", b.index())))?
                }
                None => load_uri(&percent_decode(uri)).map_err(|e| fail(format!("buffer {}: {e}", b.index())))?,
            },
        };
        if data.len() < b.length() {
            return Err(fail(format!("buffer {} holds {} bytes where the file declares {}", b.index(), data.len(), b.length())));
        }
        buffers.push(data);
    }
    // ---- The default scene's nodes, in world space ----
    let scene = doc.default_scene().or_else(|| doc.scenes().next());
    let mut placements: Vec<Placed> = Vec::new();
    let mut seen = vec![false; doc.nodes().len()];
    let mut stack: Vec<(gltf::Node, Mat4)> = scene.map(|s| s.nodes().map(|n| (n, Mat4::IDENTITY)).collect()).unwrap_or_default();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(fail(format!("node {} appears twice in the scene's hierarchy (a cycle, or a shared child)", node.index())));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        if !world.is_finite() {
            return Err(fail(format!("node {}: its transform is not finite", node.index())));
        }
        stack.extend(node.children().map(|c| (c, world)));
        if let Some(mesh) = node.mesh() {
            placements.push((mesh, world, Some(node.index())));
        }
    }
    // Which meshes to build, each from which placements.
    let mut uses = vec![0usize; doc.meshes().len()];
    placements.iter().for_each(|(m, _, _)| uses[m.index()] += 1);
    let shared = instances && uses.iter().any(|&u| u > 1);
    let groups: Vec<Vec<Placed>> =
        if shared { doc.meshes().map(|m| vec![(m, Mat4::IDENTITY, None)]).collect() } else { vec![placements.clone()] };
    let instance_list = shared.then(|| placements.iter().map(|(m, w, _)| (m.index(), glam::Affine3A::from_mat4(*w))).collect::<Vec<_>>());
    // Before anything is read or decoded.
    check_expansion(doc, &buffers, &groups, &uses, limits).map_err(fail)?;
    // ---- Materials: one slot each, and a last one for primitives without a material ----
    let mut warnings = Vec::new();
    let mut materials: Vec<FileMaterial> = Vec::new();
    // Each image decoded once, shared by the materials that use it.
    let mut textures = Textures::new(limits);
    for m in doc.materials() {
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _] = pbr.base_color_factor();
        let c = Color::new(r, g, b);
        let diffuse = if c.is_finite() { c.clamp(Vec3::ZERO, Vec3::ONE) } else { Vec3::ONE };
        let name = m.name().map_or_else(|| format!("material{}", m.index().unwrap_or(0)), str::to_string);
        let mut texture = None;
        if let Some(info) = pbr.base_color_texture() {
            let image = info.texture().source();
            let read = || match image.source() {
                gltf::image::Source::View { view, .. } => buffers
                    .get(view.buffer().index())
                    .and_then(|b| b.get(view.offset()..view.offset().checked_add(view.length())?))
                    .map(<[u8]>::to_vec)
                    .ok_or_else(|| format!("its buffer view {} is outside its buffer", view.index())),
                gltf::image::Source::Uri { uri, .. } => match uri.strip_prefix("data:") {
                    Some(rest) => rest
                        .split_once(";base64,")
                        .ok_or_else(|| "a data URI that is not base64".to_string())
                        .and_then(|(_, p)| base64::engine::general_purpose::STANDARD.decode(p).map_err(|e| e.to_string())),
                    None => load_uri(&percent_decode(uri)).map_err(|e| e.to_string()),
                },
            };
            match textures.get(image.index(), read) {
                Ok(t) if info.tex_coord() == 0 => texture = Some(t),
                Ok(_) => warnings.push(format!(
                    "material '{name}': its texture uses TEXCOORD_{}, isir reads only TEXCOORD_0; its colour factor is used",
                    info.tex_coord()
                )),
                Err(why) => {
                    warnings.push(format!("material '{name}': texture of image {}: {why}; its colour factor is used", image.index()))
                }
            }
        }
        materials.push(FileMaterial { name, diffuse, texture_name: None, texture });
    }
    let doc_warnings = warnings;
    let mut results = Vec::new();
    for group in groups {
        let mut warnings = if results.is_empty() { doc_warnings.clone() } else { Vec::new() };
        let mut vertices = Vec::new();
        let mut normals = Vec::new();
        let mut uvs = Vec::new();
        let mut triangles = Vec::new();
        let mut slots = Vec::new();
        let (mut all_normals, mut all_uvs) = (true, true);
        let mut skipped_modes = 0usize;
        let mut sparse = 0usize;
        for (mesh, world, _) in group {
            let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
            for prim in mesh.primitives() {
                if prim.mode() != Mode::Triangles {
                    skipped_modes += 1;
                    continue;
                }
                let what = format!("mesh {} primitive {}", mesh.index(), prim.index());
                let get = |b: gltf::Buffer| buffers.get(b.index()).map(Vec::as_slice);
                let Some(pos) = prim.get(&gltf::Semantic::Positions) else {
                    return Err(fail(format!("{what} has no POSITION")));
                };
                if pos.sparse().is_some() {
                    sparse += 1;
                    continue;
                }
                check_accessor(&pos, &buffers, &[DataType::F32], Dimensions::Vec3).map_err(|m| fail(format!("{what} POSITION: {m}")))?;
                let reader = prim.reader(get);
                let base = vertices.len() as u64;
                let count = pos.count() as u64;
                if base + count > u64::from(u32::MAX) {
                    return Err(fail(format!("{what}: more than 2^32 vertices in all")));
                }
                vertices.extend(reader.read_positions().into_iter().flatten().map(|p| world.transform_point3(Vec3::from(p))));
                match prim.get(&gltf::Semantic::Normals) {
                    Some(n)
                        if n.sparse().is_none()
                            && check_accessor(&n, &buffers, &[DataType::F32], Dimensions::Vec3).is_ok()
                            && n.count() == pos.count() =>
                    {
                        normals.extend(
                            reader.read_normals().into_iter().flatten().map(|n| (normal_matrix * Vec3::from(n)).normalize_or_zero()),
                        );
                    }
                    _ => all_normals = false,
                }
                match prim.get(&gltf::Semantic::TexCoords(0)) {
                    Some(t)
                        if t.sparse().is_none()
                            && check_accessor(&t, &buffers, &[DataType::F32], Dimensions::Vec2).is_ok()
                            && t.count() == pos.count() =>
                    {
                        // glTF's v points down the image; isir's (OBJ's) up.
                        uvs.extend(reader.read_tex_coords(0).into_iter().flat_map(|t| t.into_f32()).map(|[u, v]| Vec2::new(u, 1.0 - v)));
                    }
                    _ => all_uvs = false,
                }
                let first = triangles.len();
                match prim.indices() {
                    Some(ind) => {
                        if ind.sparse().is_some() {
                            sparse += 1;
                            continue;
                        }
                        check_accessor(&ind, &buffers, &[DataType::U8, DataType::U16, DataType::U32], Dimensions::Scalar)
                            .map_err(|m| fail(format!("{what} indices: {m}")))?;
                        let idx: Vec<u32> = reader.read_indices().map(|r| r.into_u32().collect()).unwrap_or_default();
                        if let Some(&bad) = idx.iter().find(|&&i| u64::from(i) >= count) {
                            return Err(fail(format!("{what}: index {bad} past its {count} vertices")));
                        }
                        triangles.extend(idx.chunks_exact(3).map(|t| [t[0] + base as u32, t[1] + base as u32, t[2] + base as u32]));
                    }
                    None => triangles.extend((0..count / 3).map(|t| {
                        let i = base as u32 + 3 * t as u32;
                        [i, i + 1, i + 2]
                    })),
                }
                let slot = prim.material().index().map_or(materials.len(), |i| i.min(materials.len())) as u32;
                slots.extend(std::iter::repeat_n(slot, triangles.len() - first));
            }
        }
        if skipped_modes > 0 {
            warnings.push(format!("{skipped_modes} primitives that are not triangle lists (points, lines, strips, fans) left out"));
        }
        if sparse > 0 {
            warnings.push(format!("{sparse} primitives with sparse accessors left out (not read yet)"));
        }
        let mut mesh = TriangleMesh::new(vertices, if all_normals { normals } else { Vec::new() }, triangles);
        mesh.material_slots = slots;
        if all_uvs && !uvs.is_empty() {
            mesh.uvs = uvs;
        }
        warnings.extend(crate::io::obj::mesh_warnings(&mesh, true));
        let format = if is_glb(bytes) { "glTF 2.0 (binary .glb)" } else { "glTF 2.0" }.into();
        results.push(LoadedMesh { mesh, materials: materials.clone(), warnings, format, files: Vec::new() });
    }
    Ok((results, instance_list))
}

/// A mesh placed in the scene: the mesh, its transform and the node that places it (`None`
/// for a mesh built once in its own space, for instances).
type Placed<'a> = (gltf::Mesh<'a>, Mat4, Option<usize>);

/// What building each placed primitive costs besides its data, in bytes (the least a
/// primitive placed many times over costs, in time as in memory).
const PRIMITIVE_BYTES: u64 = 32;

/// Check, from the accessors' counts before anything is read, that the meshes `groups`
/// build (with a copy of the file's materials each) take at most the input limit;
/// otherwise say which mesh, primitive and node take them past it, and the reuse that
/// made them so large.
fn check_expansion(
    doc: &gltf::Document,
    buffers: &[Vec<u8>],
    groups: &[Vec<Placed>],
    uses: &[usize],
    limits: &ReadLimits,
) -> std::result::Result<(), String> {
    use std::mem::size_of;
    // How many primitives of the file read each accessor (as positions or indices).
    let mut reads = vec![0usize; doc.accessors().len()];
    // Per mesh, per primitive: (vertices, triangles, bytes) as the build reads them.
    let mut costs: Vec<Vec<(u64, u64, u64)>> = Vec::with_capacity(doc.meshes().len());
    for mesh in doc.meshes() {
        let mut prims = Vec::new();
        for prim in mesh.primitives() {
            let pos = prim.get(&gltf::Semantic::Positions);
            for a in pos.iter().chain(prim.indices().as_ref()) {
                reads[a.index()] += 1;
            }
            let pos = pos.filter(|p| {
                prim.mode() == Mode::Triangles
                    && p.sparse().is_none()
                    && check_accessor(p, buffers, &[DataType::F32], Dimensions::Vec3).is_ok()
            });
            let Some(pos) = pos else {
                prims.push((0, 0, 0));
                continue;
            };
            let count = pos.count() as u64;
            let attribute = |semantic: gltf::Semantic, dims: Dimensions| {
                prim.get(&semantic).is_some_and(|a| {
                    a.sparse().is_none() && a.count() == pos.count() && check_accessor(&a, buffers, &[DataType::F32], dims).is_ok()
                })
            };
            let mut per_vertex = size_of::<Vec3>();
            if attribute(gltf::Semantic::Normals, Dimensions::Vec3) {
                per_vertex += size_of::<Vec3>();
            }
            if attribute(gltf::Semantic::TexCoords(0), Dimensions::Vec2) {
                per_vertex += size_of::<Vec2>();
            }
            let triangles = match prim.indices() {
                Some(ind) if ind.sparse().is_none() => ind.count() as u64 / 3,
                Some(_) => 0,
                None => count / 3,
            };
            // Indices, material slot, and whether it can be hit.
            let per_triangle = size_of::<[u32; 3]>() + size_of::<u32>() + size_of::<bool>();
            let bytes = count.saturating_mul(per_vertex as u64).saturating_add(triangles.saturating_mul(per_triangle as u64));
            prims.push((count, triangles, bytes));
        }
        costs.push(prims);
    }
    // Each mesh's copy of the materials (a name given or `material12`).
    let materials_bytes: u64 = doc.materials().map(|m| (size_of::<FileMaterial>() + m.name().map_or(16, str::len)) as u64).sum();
    let (mut bytes, mut vertices, mut triangles) = (0u64, 0u64, 0u64);
    for group in groups {
        bytes = bytes.saturating_add(materials_bytes);
        for (mesh, _, node) in group {
            for (prim, &(v, t, b)) in costs[mesh.index()].iter().enumerate() {
                bytes = bytes.saturating_add(b).saturating_add(PRIMITIVE_BYTES);
                vertices = vertices.saturating_add(v);
                triangles = triangles.saturating_add(t);
                if bytes <= limits.max_bytes {
                    continue;
                }
                let at = node.map_or(String::new(), |n| format!(" (node {n})"));
                let mut why = Vec::new();
                if node.is_some() && uses[mesh.index()] > 1 {
                    why.push(format!("mesh {} is placed by {} nodes, each a copy in world space", mesh.index(), uses[mesh.index()]));
                }
                let p = mesh.primitives().nth(prim);
                let accessors = p.iter().flat_map(|p| p.get(&gltf::Semantic::Positions).into_iter().chain(p.indices()));
                if let Some((r, a)) = accessors.map(|a| (reads[a.index()], a.index())).max().filter(|&(r, _)| r > 1) {
                    why.push(format!("its accessor {a} is read by {r} primitives"));
                }
                if doc.materials().len() > 1 && groups.len() > 1 {
                    why.push(format!("each of the {} meshes has its copy of the {} materials", groups.len(), doc.materials().len()));
                }
                let why = if why.is_empty() { String::new() } else { format!(": {}", why.join(", ")) };
                return Err(format!(
                    "mesh {} primitive {prim}{at} takes the file's meshes past {}, at {triangles} triangles and {vertices} vertices{why}",
                    mesh.index(),
                    limits.described(),
                ));
            }
        }
    }
    Ok(())
}

/// Check that `a` is of one of `types` with `dims`, not normalized, and lies inside its
/// buffer view and buffer (what the `gltf` reader assumes without checking).
fn check_accessor(a: &gltf::Accessor, buffers: &[Vec<u8>], types: &[DataType], dims: Dimensions) -> std::result::Result<(), String> {
    if !types.contains(&a.data_type()) || a.dimensions() != dims {
        return Err(format!("accessor {} is {:?} {:?}, expected {dims:?} of {types:?}", a.index(), a.dimensions(), a.data_type()));
    }
    if a.normalized() {
        return Err(format!("accessor {} is normalized integers, expected floats", a.index()));
    }
    let view = a.view().ok_or_else(|| format!("accessor {} has no buffer view", a.index()))?;
    if a.count() == 0 {
        return Err(format!("accessor {} is empty", a.index()));
    }
    let size = a.size();
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!("buffer view {}: stride {stride} is less than the element size {size}", view.index()));
    }
    let inside_view = (a.count() - 1).checked_mul(stride).and_then(|x| x.checked_add(size)).and_then(|x| x.checked_add(a.offset()));
    if inside_view.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "accessor {}: {} elements from offset {} overrun its buffer view of {} bytes",
            a.index(),
            a.count(),
            a.offset(),
            view.length()
        ));
    }
    let buffer = buffers.get(view.buffer().index()).map_or(0, Vec::len);
    if view.offset().checked_add(view.length()).is_none_or(|end| end > buffer) {
        return Err(format!("buffer view {} overruns its buffer of {buffer} bytes", view.index()));
    }
    Ok(())
}

/// `%20` and the like in a relative URI, decoded (invalid escapes kept as written).
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%' && i + 2 < b.len() {
            if let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}
