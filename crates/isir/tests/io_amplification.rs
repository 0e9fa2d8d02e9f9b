//! Small files that name something many times (an image, a material library, an accessor,
//! a mesh) take what they really hold: an image is decoded once for all its materials, a
//! library named again adds nothing, and a glTF file that would expand past the input
//! limit is an error naming the reuse, found before anything is allocated.

use base64::Engine;
use isir::io::gltf::{parse_gltf, parse_gltf_instances, parse_gltf_with};
use isir::io::input::ReadLimits;
use isir::io::obj::{load_obj_with, parse_obj};
use std::path::Path;
use std::sync::Arc;

/// A fresh directory for one test, removed when it ends.
fn tmp() -> tempfile::TempDir {
    tempfile::Builder::new().prefix("isir-amplification-").tempdir().unwrap()
}

/// A `w × h` PNG, all one grey.
fn png(w: u32, h: u32) -> Vec<u8> {
    let mut out = Vec::new();
    image::RgbImage::from_pixel(w, h, image::Rgb([200, 100, 50]))
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

/// An OBJ of one textured triangle per material `m0`..`m{n-1}`, with `mtllib` lines naming
/// `library` as each of `names`.
fn obj(n: usize, names: &[&str]) -> String {
    let mut s: String = names.iter().map(|l| format!("mtllib {l}\n")).collect();
    s += "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\n";
    for i in 0..n {
        s += &format!("usemtl m{i}\nf 1/1 2/2 3/3\n");
    }
    s
}

#[test]
fn an_obj_texture_named_by_many_materials_is_decoded_once() {
    let d = tmp();
    std::fs::write(d.path().join("t.png"), png(3, 2)).unwrap();
    std::fs::write(d.path().join("other.png"), png(3, 2)).unwrap();
    // However the file is written: `t.png`, `./t.png`, `sub/../t.png`.
    std::fs::create_dir(d.path().join("sub")).unwrap();
    let mut mtl: String = (0..8).map(|i| format!("newmtl m{i}\nKd 1 1 1\nmap_Kd {}t.png\n", ["", "./", "sub/../"][i % 3])).collect();
    mtl += "newmtl m8\nKd 1 1 1\nmap_Kd -bm 1 other.png\n";
    std::fs::write(d.path().join("many.mtl"), mtl).unwrap();
    std::fs::write(d.path().join("many.obj"), obj(9, &["many.mtl"])).unwrap();
    let m = load_obj_with(&d.path().join("many.obj"), &ReadLimits::default()).unwrap();
    assert_eq!(m.materials.len(), 9);
    let textures: Vec<_> = m.materials.iter().map(|m| m.texture.clone().expect("decoded")).collect();
    // The eight materials of t.png share one texture; other.png is another.
    assert!(textures[..8].iter().all(|t| Arc::ptr_eq(t, &textures[0])));
    assert!(!Arc::ptr_eq(&textures[8], &textures[0]));
    assert_eq!(Arc::strong_count(&textures[0]), 8 + 8, "the materials' and this test's");
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    // The files the load read besides the OBJ: its library, then each image once.
    assert_eq!(m.files, [d.path().join("many.mtl"), d.path().join("t.png"), d.path().join("other.png")]);
}

#[test]
fn obj_textures_stop_at_the_input_limit_with_a_warning() {
    // Each 20×20 PNG decodes to 4800 bytes of texels: two fit in 12,000 bytes, not three.
    let d = tmp();
    let mut mtl = String::new();
    for i in 0..3 {
        std::fs::write(d.path().join(format!("t{i}.png")), png(20, 20)).unwrap();
        mtl += &format!("newmtl m{i}\nKd 0.5 0.5 0.5\nmap_Kd t{i}.png\n");
    }
    std::fs::write(d.path().join("three.mtl"), mtl).unwrap();
    std::fs::write(d.path().join("three.obj"), obj(3, &["three.mtl"])).unwrap();
    let m = load_obj_with(&d.path().join("three.obj"), &ReadLimits::new(12_000)).unwrap();
    assert!(m.materials[0].texture.is_some() && m.materials[1].texture.is_some());
    assert!(m.materials[2].texture.is_none());
    let w = m.warnings.iter().find(|w| w.starts_with("material 'm2': texture t2.png: 20x20 texels")).expect("a warning for m2");
    assert!(w.contains("past the input limit of 12000 bytes") && w.ends_with("its flat colour is used"), "{w}");
    // With the default limit all three are decoded.
    let m = load_obj_with(&d.path().join("three.obj"), &ReadLimits::default()).unwrap();
    assert!(m.materials.iter().all(|m| m.texture.is_some()), "{:?}", m.warnings);
}

#[test]
fn a_material_library_named_again_adds_nothing() {
    let library = "newmtl m0\nKd 1 0 0\nnewmtl m1\nKd 0 1 0\nnewmtl m2\nKd 0 0 1\n";
    let reads = std::cell::Cell::new(0);
    let loader = |p: &Path| {
        reads.set(reads.get() + 1);
        match p.to_str() {
            Some("a.mtl" | "./a.mtl" | "copy.mtl") => Ok(library.as_bytes().to_vec()),
            _ => Err(isir::Error::Scene(format!("{} not here", p.display()))),
        }
    };
    // 300 lines naming one library, two other spellings of it, and a missing one twice.
    let mut names = vec!["a.mtl"; 300];
    names.extend(["./a.mtl", "copy.mtl", "gone.mtl", "gone.mtl"]);
    let m = parse_obj(Path::new("t.obj"), obj(3, &names).as_bytes(), loader).unwrap();
    assert_eq!(m.materials.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(), ["m0", "m1", "m2"]);
    assert_eq!(m.mesh.material_slots, [0, 1, 2]);
    assert_eq!(m.materials[2].diffuse, isir::Vec3::Z);
    // Read once by name: a.mtl, ./a.mtl, copy.mtl, gone.mtl; one warning for the missing one.
    assert_eq!(reads.get(), 4);
    assert_eq!(m.warnings.iter().filter(|w| w.contains("gone.mtl not here")).count(), 1, "{:?}", m.warnings);

    // Two different libraries, each named once, give their materials in order, as before.
    let two = |p: &Path| match p.to_str() {
        Some("a.mtl") => Ok(library.as_bytes().to_vec()),
        _ => Ok(b"newmtl b0\nKd 1 1 0\n".to_vec()),
    };
    let text = "mtllib a.mtl\nmtllib b.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl b0\nf 1 2 3\nusemtl m1\nf 1 2 3\n";
    let m = parse_obj(Path::new("t.obj"), text.as_bytes(), two).unwrap();
    assert_eq!(m.materials.iter().map(|m| m.name.as_str()).collect::<Vec<_>>(), ["m0", "m1", "m2", "b0"]);
    assert_eq!(m.mesh.material_slots, [3, 1]);
}

/// A GLB: a triangle (3 positions) and one accessor of `indices` u8 indices, read by
/// `prims` primitives of mesh 0, which `nodes` nodes place (one apart from the next).
fn glb(indices: usize, prims: usize, nodes: usize) -> Vec<u8> {
    let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    bin.extend((0..indices).map(|i| (i % 3) as u8));
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let prim = "{\"attributes\":{\"POSITION\":0},\"indices\":1}";
    let prims = vec![prim; prims].join(",");
    let node_list = (0..nodes).map(|i| i.to_string()).collect::<Vec<_>>().join(",");
    let node_defs = (0..nodes).map(|i| format!("{{\"mesh\":0,\"translation\":[{i},0,0]}}")).collect::<Vec<_>>().join(",");
    let json = format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[{node_list}]}}],\"nodes\":[{node_defs}],\
         \"buffers\":[{{\"byteLength\":{}}}],\
         \"bufferViews\":[{{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36}},{{\"buffer\":0,\"byteOffset\":36,\"byteLength\":{indices}}}],\
         \"accessors\":[{{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}},\
         {{\"bufferView\":1,\"componentType\":5121,\"count\":{indices},\"type\":\"SCALAR\"}}],\
         \"meshes\":[{{\"primitives\":[{prims}]}}]}}",
        bin.len()
    );
    let mut j = json.into_bytes();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + j.len() + 8 + bin.len()) as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&j);
    out.extend((bin.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&bin);
    out
}

fn no_uri(u: &str) -> isir::Result<Vec<u8>> {
    Err(isir::Error::Scene(format!("{u}: no external buffers here")))
}

#[test]
fn an_accessor_read_by_many_primitives_stops_at_the_limit() {
    let path = Path::new("amp.glb");
    // 300 indices read by 40 primitives: 4000 triangles of 17 bytes, about 68 KB.
    let file = glb(300, 40, 1);
    let m = parse_gltf_with(path, &file, no_uri, &ReadLimits::new(100_000)).unwrap();
    assert_eq!(m.mesh.triangles.len(), 4000);
    let e = parse_gltf_with(path, &file, no_uri, &ReadLimits::new(20_000)).unwrap_err().to_string();
    assert!(e.starts_with("amp.glb: mesh 0 primitive 11 (node 0) takes the file's meshes past the input limit of 20000 bytes"), "{e}");
    assert!(e.contains("ISIR_MAX_INPUT_BYTES") && e.ends_with(": its accessor 1 is read by 40 primitives"), "{e}");
    // The audit's file: 300,000 indices read by 3000 primitives, 300 million triangles
    // (4.9 GB) from 300 KB. Refused at once under the default limit, nothing allocated.
    let file = glb(300_000, 3000, 1);
    let t = std::time::Instant::now();
    let e = parse_gltf(path, &file, no_uri).unwrap_err().to_string();
    assert!(e.contains("past the input limit of 1 GiB") && e.ends_with("its accessor 1 is read by 3000 primitives"), "{e}");
    assert!(t.elapsed().as_secs() < 5);
    let e = parse_gltf_instances(path, &file, no_uri, &ReadLimits::default()).unwrap_err().to_string();
    assert!(e.starts_with("amp.glb: mesh 0 primitive 631 (node 0) takes"), "{e}");
}

#[test]
fn a_mesh_placed_by_many_nodes_is_copied_within_the_limit_or_instanced() {
    let path = Path::new("nodes.glb");
    // 100 triangles placed by 50 nodes: 5000 triangles in world space, about 100 KB.
    let file = glb(300, 1, 50);
    let m = parse_gltf_with(path, &file, no_uri, &ReadLimits::new(200_000)).unwrap();
    assert_eq!(m.mesh.triangles.len(), 5000);
    assert_eq!(m.mesh.vertices.len(), 150);
    let limits = ReadLimits::new(20_000);
    let e = parse_gltf_with(path, &file, no_uri, &limits).unwrap_err().to_string();
    assert!(e.starts_with("nodes.glb: mesh 0 primitive 0 (node "), "{e}");
    assert!(e.contains("past the input limit of 20000 bytes"), "{e}");
    assert!(e.ends_with(": mesh 0 is placed by 50 nodes, each a copy in world space"), "{e}");
    // As instances, the mesh is built once: well within the same limit.
    let (meshes, placements) = parse_gltf_instances(path, &file, no_uri, &limits).unwrap();
    assert_eq!(meshes.len(), 1);
    assert_eq!(meshes[0].mesh.triangles.len(), 100);
    assert_eq!(placements.map(|p| p.len()), Some(50));
}

/// A glTF file of `materials` materials, each with the one image as its base colour
/// texture, on one triangle each.
fn gltf_textured(materials: usize, image: &[u8]) -> String {
    let b64 = |b: &[u8]| base64::engine::general_purpose::STANDARD.encode(b);
    let mut bin: Vec<u8> = [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0].iter().flat_map(|f| f.to_le_bytes()).collect();
    bin.extend([0.0f32, 0.0, 1.0, 0.0, 0.0, 1.0].iter().flat_map(|f| f.to_le_bytes()));
    let prims = (0..materials)
        .map(|i| format!("{{\"attributes\":{{\"POSITION\":0,\"TEXCOORD_0\":1}},\"material\":{i}}}"))
        .collect::<Vec<_>>()
        .join(",");
    let mats = vec!["{\"pbrMetallicRoughness\":{\"baseColorTexture\":{\"index\":0}}}"; materials].join(",");
    format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scenes\":[{{\"nodes\":[0]}}],\"nodes\":[{{\"mesh\":0}}],\
         \"meshes\":[{{\"primitives\":[{prims}]}}],\"materials\":[{mats}],\
         \"textures\":[{{\"source\":0}}],\"images\":[{{\"uri\":\"data:image/png;base64,{}\"}}],\
         \"buffers\":[{{\"byteLength\":{},\"uri\":\"data:application/octet-stream;base64,{}\"}}],\
         \"bufferViews\":[{{\"buffer\":0,\"byteOffset\":0,\"byteLength\":36}},{{\"buffer\":0,\"byteOffset\":36,\"byteLength\":24}}],\
         \"accessors\":[{{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}},\
         {{\"bufferView\":1,\"componentType\":5126,\"count\":3,\"type\":\"VEC2\"}}]}}",
        b64(image),
        bin.len(),
        b64(&bin)
    )
}

#[test]
fn a_gltf_image_used_by_many_materials_is_decoded_once() {
    let m = parse_gltf(Path::new("t.gltf"), gltf_textured(6, &png(4, 4)).as_bytes(), no_uri).unwrap();
    assert_eq!(m.materials.len(), 6);
    let first = m.materials[0].texture.clone().expect("decoded");
    assert!(m.materials.iter().all(|m| m.texture.as_ref().is_some_and(|t| Arc::ptr_eq(t, &first))));
    assert_eq!(Arc::strong_count(&first), 6 + 1);
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    // One 100×100 image (120,000 bytes of texels) over a smaller limit: a warning for each
    // material, the colour factor used, and the mesh read.
    let m = parse_gltf_with(Path::new("t.gltf"), gltf_textured(2, &png(100, 100)).as_bytes(), no_uri, &ReadLimits::new(100_000)).unwrap();
    assert!(m.materials.iter().all(|m| m.texture.is_none()));
    let w: Vec<_> = m.warnings.iter().filter(|w| w.contains("100x100 texels") && w.contains("past the input limit")).collect();
    assert_eq!(w.len(), 2, "{:?}", m.warnings);
    assert_eq!(m.mesh.triangles.len(), 2);
}
