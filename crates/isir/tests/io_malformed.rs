//! Malformed input files, through the loader the `isir` command uses: each a clear error
//! naming the file (and the line where there is one), never a misleading warning or a
//! silent success.

use isir::io::input::ReadLimits;
use isir::io::mesh::load_mesh_with;
use std::io::Write;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("io_malformed");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `bytes` written as `name`, loaded: the error's text, or the triangle count.
fn load(name: &str, bytes: &[u8]) -> Result<usize, String> {
    let path = dir().join(name);
    std::fs::write(&path, bytes).unwrap();
    load_mesh_with(&path, &ReadLimits::default()).map(|m| m.mesh.triangles.len()).map_err(|e| e.to_string())
}

/// `load`'s error, which must end with `message` after the file's name.
fn refused(name: &str, bytes: &[u8], message: &str) {
    let e = load(name, bytes).expect_err(name);
    assert!(e.ends_with(&format!("{name}{message}")), "{name}: {e}");
}

const VERTICES: &str = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
const FACES: &str = "element face 1\nproperty list uchar int vertex_indices\n";
const BODY: &str = "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";

fn ascii_ply(elements: &str, body: &str) -> String {
    format!("ply\nformat ascii 1.0\n{elements}end_header\n{body}")
}

#[test]
fn a_well_formed_ascii_ply_file_is_read() {
    assert_eq!(load("ok.ply", ascii_ply(&format!("{VERTICES}{FACES}"), BODY).as_bytes()), Ok(1));
}

#[test]
fn a_ply_element_declared_twice_names_the_header_line() {
    let src = ascii_ply(&format!("{VERTICES}{VERTICES}{FACES}"), &format!("0 0 0\n1 0 0\n0 1 0\n{BODY}"));
    refused("dupelem.ply", src.as_bytes(), ":7: header: element 'vertex' declared twice");
}

#[test]
fn ply_vertex_indices_that_are_not_a_list_of_integers_are_refused() {
    for (decl, body) in [("property list uchar float vertex_indices", BODY), ("property int vertex_indices", "0 0 0\n1 0 0\n0 1 0\n3\n")] {
        let src = ascii_ply(&format!("{VERTICES}element face 1\n{decl}\n"), body);
        refused(
            "idx.ply",
            src.as_bytes(),
            &format!(":8: header: 'vertex_indices' must be a list of integers ('property list uchar int vertex_indices'), not '{decl}'"),
        );
    }
}

#[test]
fn ascii_ply_lines_with_values_past_the_declared_ones_are_refused() {
    let elements = format!("{VERTICES}{FACES}");
    refused(
        "asc_extra.ply",
        ascii_ply(&elements, "0 0 0 5\n1 0 0\n0 1 0\n3 0 1 2\n").as_bytes(),
        ":10: element 'vertex' (3 declared): 4 values where the header declares 3",
    );
    refused(
        "listlong.ply",
        ascii_ply(&elements, "0 0 0\n1 0 0\n0 1 0\n2 0 1 2\n").as_bytes(),
        ":13: element 'face' (1 declared): the list 'vertex_indices' says 2 values, the line holds 3",
    );
    // With a face index out of range too (the record reader's to name): the extra
    // values come first in the file, and are the error.
    refused(
        "both.ply",
        ascii_ply(
            &format!("{VERTICES}element face 2\nproperty list uchar int vertex_indices\n"),
            "0 0 0\n1 0 0 7\n0 1 0\n3 0 1 9\n3 0 1 2\n",
        )
        .as_bytes(),
        ":11: element 'vertex' (3 declared): 4 values where the header declares 3",
    );
}

fn gz(data: &[u8]) -> Vec<u8> {
    let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(data).unwrap();
    e.finish().unwrap()
}

const TRI_OBJ: &[u8] = b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

#[test]
fn gzip_inside_gzip_is_named() {
    assert_eq!(load("once.obj.gz", &gz(TRI_OBJ)), Ok(1));
    refused("double.obj.gz", &gz(&gz(TRI_OBJ)), ": the file is compressed twice (gzip inside gzip): decompress it once");
}

#[test]
fn bytes_after_the_gzip_data_are_counted() {
    let mut trail = gz(TRI_OBJ);
    let end = trail.len();
    trail.extend(b"garbage\n");
    refused("trail.obj.gz", &trail, &format!(": 8 bytes after the end of the gzip data (at byte {end}) are not gzip"));
    // Several members are one file.
    let mut multi = gz(&TRI_OBJ[..16]);
    multi.extend(gz(&TRI_OBJ[16..]));
    assert_eq!(load("multi.obj.gz", &multi), Ok(1));
}

/// A one-triangle glTF file of `asset.version` `version`.
fn gltf(version: &str) -> String {
    format!(
        r#"{{"asset": {{"version": "{version}"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
"buffers": [{{"byteLength": 44, "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}}],
"bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 36}}, {{"buffer": 0, "byteOffset": 36, "byteLength": 6}}],
"accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
{{"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}}],
"meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}]}}"#
    )
}

#[test]
fn gltf_versions_other_than_2_are_refused() {
    assert_eq!(load("v2.gltf", gltf("2.0").as_bytes()), Ok(1));
    assert_eq!(load("v21.gltf", gltf("2.1").as_bytes()), Ok(1));
    refused("v1.gltf", gltf("1.0").as_bytes(), ": glTF 1.0 is not supported (only 2.x)");
    refused("v3.gltf", gltf("3.0").as_bytes(), ": glTF 3.0 is not supported (only 2.x)");
    refused("vx.gltf", gltf("two").as_bytes(), ": asset.version 'two' is not a glTF version (only glTF 2.x is supported)");
    // A glTF 1.0 file as 1.0 lays it out (objects by name, not arrays): the version, not
    // what 2.0 finds wrong in it.
    let v1 = r#"{"asset": {"version": "1.0"}, "scene": "s", "scenes": {"s": {"nodes": ["n"]}}, "nodes": {"n": {"meshes": ["m"]}}, "meshes": {"m": {"primitives": []}}}"#;
    refused("real1.gltf", v1.as_bytes(), ": glTF 1.0 is not supported (only 2.x)");
    // Binary glTF 1.0 (KHR_binary_glTF): version 1 in the GLB header.
    let mut glb = b"glTF".to_vec();
    glb.extend(1u32.to_le_bytes());
    glb.extend(32u32.to_le_bytes());
    glb.extend(12u32.to_le_bytes());
    glb.extend(0u32.to_le_bytes());
    glb.extend(b"{\"a\": 1}    ");
    refused("v1.glb", &glb, ": glTF 1.0 (binary) is not supported (only 2.x)");
}
