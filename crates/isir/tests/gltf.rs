//! glTF meshes: the same triangles as the OBJ file they were written from (JSON with a
//! data URI, JSON with a .bin beside it, GLB); node transforms and materials applied;
//! broken files name the file and the element, never a panic.

use base64::Engine;
use isir::io::gltf::parse_gltf;
use isir::io::mesh::load_mesh;
use isir::{scenes, TriangleMesh, Vec3};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("gltf");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The binary buffer of `mesh`: positions, then normals (if any), then u32 indices.
fn buffer(mesh: &TriangleMesh) -> Vec<u8> {
    let mut b = Vec::new();
    mesh.vertices.iter().flat_map(|v| v.to_array()).for_each(|f| b.extend(f.to_le_bytes()));
    mesh.normals.iter().flat_map(|v| v.to_array()).for_each(|f| b.extend(f.to_le_bytes()));
    mesh.triangles.iter().flatten().for_each(|i| b.extend(i.to_le_bytes()));
    b
}

/// The glTF JSON for `mesh` in one node with `node_extra` (e.g. a translation), its buffer
/// at `uri` (None: the GLB chunk).
fn json(mesh: &TriangleMesh, uri: Option<&str>, node_extra: &str) -> String {
    let (nv, nt) = (mesh.vertices.len(), mesh.triangles.len());
    let (lo, hi) = mesh.vertices.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(l, h), &v| (l.min(v), h.max(v)));
    let normals = !mesh.normals.is_empty();
    let pos_bytes = nv * 12;
    let nrm_bytes = if normals { nv * 12 } else { 0 };
    let idx_bytes = nt * 12;
    let uri = uri.map(|u| format!(",\"uri\":\"{u}\"")).unwrap_or_default();
    let (normal_attr, normal_view, normal_acc) = if normals {
        (
            ",\"NORMAL\":1",
            format!(",{{\"buffer\":0,\"byteOffset\":{pos_bytes},\"byteLength\":{nrm_bytes}}}"),
            format!(",{{\"bufferView\":1,\"componentType\":5126,\"count\":{nv},\"type\":\"VEC3\"}}"),
        )
    } else {
        ("", String::new(), String::new())
    };
    let idx = if normals { 2 } else { 1 };
    format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scene\":0,\"scenes\":[{{\"nodes\":[0]}}],\
         \"nodes\":[{{\"mesh\":0{node_extra}}}],\
         \"materials\":[{{\"name\":\"gold\",\"pbrMetallicRoughness\":{{\"baseColorFactor\":[1,0.85,0.57,1]}}}}],\
         \"meshes\":[{{\"primitives\":[{{\"attributes\":{{\"POSITION\":0{normal_attr}}},\"indices\":{idx},\"material\":0}}]}}],\
         \"buffers\":[{{\"byteLength\":{}{uri}}}],\
         \"bufferViews\":[{{\"buffer\":0,\"byteOffset\":0,\"byteLength\":{pos_bytes}}}{normal_view},\
         {{\"buffer\":0,\"byteOffset\":{},\"byteLength\":{idx_bytes}}}],\
         \"accessors\":[{{\"bufferView\":0,\"componentType\":5126,\"count\":{nv},\"type\":\"VEC3\",\"min\":[{},{},{}],\"max\":[{},{},{}]}}{normal_acc},\
         {{\"bufferView\":{idx},\"componentType\":5125,\"count\":{},\"type\":\"SCALAR\"}}]}}",
        pos_bytes + nrm_bytes + idx_bytes,
        pos_bytes + nrm_bytes,
        lo.x,
        lo.y,
        lo.z,
        hi.x,
        hi.y,
        hi.z,
        nt * 3
    )
}

fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
    let mut j = json.as_bytes().to_vec();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let mut out = b"glTF".to_vec();
    out.extend(2u32.to_le_bytes());
    out.extend(((12 + 8 + j.len() + 8 + b.len()) as u32).to_le_bytes());
    out.extend((j.len() as u32).to_le_bytes());
    out.extend(b"JSON");
    out.extend(&j);
    out.extend((b.len() as u32).to_le_bytes());
    out.extend(b"BIN\0");
    out.extend(&b);
    out
}

fn data_uri(bin: &[u8]) -> String {
    format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(bin))
}

#[test]
fn the_bunny_as_gltf_in_every_packaging_is_the_obj_bunny() {
    let obj = scenes::load_builtin_model("Bunny").unwrap().mesh;
    let bin = buffer(&obj);
    let d = dir();
    std::fs::write(d.join("bunny-embedded.gltf"), json(&obj, Some(&data_uri(&bin)), "")).unwrap();
    std::fs::write(d.join("bunny data.bin"), &bin).unwrap();
    std::fs::write(d.join("bunny-external.gltf"), json(&obj, Some("bunny%20data.bin"), "")).unwrap();
    std::fs::write(d.join("bunny.glb"), glb(&json(&obj, None, ""), &bin)).unwrap();
    for name in ["bunny-embedded.gltf", "bunny-external.gltf", "bunny.glb"] {
        let m = load_mesh(&d.join(name)).unwrap();
        assert_eq!(m.mesh.triangles, obj.triangles, "{name}");
        assert_eq!(m.mesh.vertices, obj.vertices, "{name}");
        assert_eq!(m.mesh.normals.len(), obj.normals.len(), "{name}");
        assert_eq!(m.materials.len(), 1);
        assert_eq!(m.materials[0].name, "gold");
        assert_eq!(m.materials[0].diffuse, Vec3::new(1.0, 0.85, 0.57));
        assert!(m.mesh.material_slots.iter().all(|&s| s == 0));
        // The files it read besides itself: the external buffer only.
        let files = if name == "bunny-external.gltf" { vec![d.join("bunny data.bin")] } else { vec![] };
        assert_eq!(m.files, files, "{name}");
    }
}

#[test]
fn node_transforms_place_the_mesh_in_the_world() {
    let tri = TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![], vec![[0, 1, 2]]);
    let bin = buffer(&tri);
    let m = parse_gltf(
        Path::new("t.gltf"),
        json(&tri, Some(&data_uri(&bin)), ",\"translation\":[1,2,3],\"scale\":[2,2,2]").as_bytes(),
        |_| unreachable!(),
    )
    .unwrap();
    assert_eq!(m.mesh.vertices, vec![Vec3::new(1.0, 2.0, 3.0), Vec3::new(3.0, 2.0, 3.0), Vec3::new(1.0, 4.0, 3.0)]);
}

#[test]
fn broken_files_name_the_file_and_the_element() {
    let tri = TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![], vec![[0, 1, 2]]);
    let bin = buffer(&tri);
    let good = json(&tri, Some(&data_uri(&bin)), "");
    let parse = |text: &str| {
        parse_gltf(Path::new("t.gltf"), text.as_bytes(), |u| Err(isir::Error::Scene(format!("{u} not here")))).map_err(|e| e.to_string())
    };
    assert!(parse(&good).is_ok());
    let cases: Vec<(String, &str)> = vec![
        ("{\"asset\": ".into(), "t.gltf:1: JSON"),
        (
            good.replace("\"count\":3,\"type\":\"SCALAR\"", "\"count\":300,\"type\":\"SCALAR\""),
            "accessor 1: 300 elements from offset 0 overrun its buffer view",
        ),
        (good.replace("\"count\":3,\"type\":\"VEC3\"", "\"count\":3000000000,\"type\":\"VEC3\""), "overrun its buffer view"),
        (
            good.replace("\"componentType\":5126,\"count\":3,\"type\":\"VEC3\"", "\"componentType\":5121,\"count\":3,\"type\":\"VEC3\""),
            "POSITION: accessor 0 is Vec3 U8",
        ),
        (good.replace(&data_uri(&bin), "missing.bin"), "missing.bin not here"),
        (good.replace(&data_uri(&bin), &data_uri(&bin[..20])), "buffer 0 holds 20 bytes where the file declares 48"),
        (good.replace(&data_uri(&bin), "data:application/octet-stream;base64,@@@@"), "bad base64"),
    ];
    for (text, needle) in cases {
        let e = parse(&text).expect_err(needle);
        assert!(e.starts_with("t.gltf") && e.contains(needle), "expected '{needle}' in: {e}");
    }
    // An index past the last vertex.
    let mut bad = bin.clone();
    let n = bad.len();
    bad[n - 4..].copy_from_slice(&7u32.to_le_bytes());
    let e = parse(&good.replace(&data_uri(&bin), &data_uri(&bad))).unwrap_err();
    assert!(e.contains("index 7 past its 3 vertices"), "{e}");
    // A cycle in the node hierarchy.
    let cyclic = good.replace("\"nodes\":[{\"mesh\":0}]", "\"nodes\":[{\"mesh\":0,\"children\":[1]},{\"children\":[0]}]");
    let e = parse(&cyclic).unwrap_err();
    assert!(e.starts_with("t.gltf"), "{e}");
}

#[test]
fn other_primitive_modes_are_counted_and_left_out() {
    let tri = TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![], vec![[0, 1, 2]]);
    let text = json(&tri, Some(&data_uri(&buffer(&tri))), "").replace("\"material\":0}", "\"material\":0,\"mode\":1}");
    let m = parse_gltf(Path::new("t.gltf"), text.as_bytes(), |_| unreachable!()).unwrap();
    assert!(m.mesh.triangles.is_empty());
    assert!(m.warnings.iter().any(|w| w.contains("1 primitives that are not triangle lists")), "{:?}", m.warnings);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn random_and_mutated_files_never_panic(edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..6), cut in any::<usize>(), glb_form in any::<bool>()) {
        let tri = TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![Vec3::Z; 3], vec![[0, 1, 2]]);
        let bin = buffer(&tri);
        let mut bytes = if glb_form { glb(&json(&tri, None, ""), &bin) } else { json(&tri, Some(&data_uri(&bin)), "").into_bytes() };
        for (at, b) in edits {
            let i = at % bytes.len();
            bytes[i] = b;
        }
        bytes.truncate(cut % (bytes.len() + 1));
        let _ = parse_gltf(Path::new("m.gltf"), &bytes, |_| Ok(vec![0; 64]));
    }
}

#[test]
fn nodes_sharing_a_mesh_become_instances_of_one_mesh() {
    use isir::geometry::Geometry;
    use isir::scenes::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc};
    let tri = TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::Y], vec![], vec![[0, 1, 2]]);
    let bin = buffer(&tri);
    let nodes: Vec<String> = (0..20).map(|i| format!("{{\"mesh\":0,\"translation\":[{},0,0]}}", 2 * i)).collect();
    let roots: Vec<String> = (0..20).map(|i| i.to_string()).collect();
    let text = json(&tri, Some(&data_uri(&bin)), "")
        .replace("\"scenes\":[{\"nodes\":[0]}]", &format!("\"scenes\":[{{\"nodes\":[{}]}}]", roots.join(",")))
        .replace("\"nodes\":[{\"mesh\":0}]", &format!("\"nodes\":[{}]", nodes.join(",")));
    let path = dir().join("shared.gltf");
    std::fs::write(&path, text).unwrap();
    // Flattened (isir info, mesh loading): 20 triangles.
    assert_eq!(load_mesh(&path).unwrap().mesh.triangles.len(), 20);
    // In a scene: 20 instances of one mesh, under a top-level BVH.
    let mut d = SceneDescription::new("s", CameraDesc::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO));
    d.objects.push(ObjectDesc {
        name: "tris".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::File(path), shading: Default::default() },
        material: None,
    });
    let scene = d.build(isir::Accel::BvhSah).unwrap();
    assert_eq!(scene.objects.len(), 20);
    let Geometry::Instance(first) = &scene.objects[0].geometry else { panic!("an instance") };
    assert_eq!(std::sync::Arc::strong_count(&first.mesh), 20);
    assert!(scene.top_level.is_some());
    // Each node's triangle is where its translation puts it, with the file's material.
    for i in 0..20 {
        let hit = scene.intersect(&isir::Ray::new(Vec3::new(2.0 * i as f32 + 0.2, 0.2, 1.0), -Vec3::Z), 0.0, f32::INFINITY).expect("hit");
        let o = &scene.objects[hit.object as usize];
        let Geometry::Instance(inst) = &o.geometry else { panic!() };
        assert_eq!(inst.to_world().translation.x, 2.0 * i as f32);
        assert_eq!(scene.material(&hit).flat_color(), Vec3::new(1.0, 0.85, 0.57));
    }
}
