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
