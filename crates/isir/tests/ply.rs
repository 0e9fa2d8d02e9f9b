//! PLY meshes: the same triangles as the OBJ file they were written from, in every
//! encoding; broken files give errors that name the problem, never a panic.

use isir::io::mesh::{load_mesh, load_mesh_with};
use isir::io::ply::parse_ply;
use isir::{scenes, TriangleMesh, Vec3};
use proptest::prelude::*;
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("ply");
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[derive(Clone, Copy)]
enum Encoding {
    Ascii,
    Little,
    Big,
}

/// A PLY file of `mesh`: float positions (and normals when it has them), faces as
/// `list uchar int`, with an unrelated element and property in between to be skipped.
fn write_ply(mesh: &TriangleMesh, encoding: Encoding) -> Vec<u8> {
    let normals = !mesh.normals.is_empty();
    let format = match encoding {
        Encoding::Ascii => "ascii",
        Encoding::Little => "binary_little_endian",
        Encoding::Big => "binary_big_endian",
    };
    let mut out = format!("ply\nformat {format} 1.0\ncomment written by the isir tests\nelement vertex {}\n", mesh.vertices.len());
    out += "property float x\nproperty float y\nproperty float z\nproperty uchar quality\n";
    if normals {
        out += "property float nx\nproperty float ny\nproperty float nz\n";
    }
    out += &format!("element face {}\nproperty list uchar int vertex_indices\n", mesh.triangles.len());
    out += "element camera 1\nproperty float view_px\nend_header\n";
    let mut bytes = out.into_bytes();
    let floats = |fs: &[f32], bytes: &mut Vec<u8>| {
        for &f in fs {
            match encoding {
                Encoding::Ascii => bytes.extend(format!("{f:?} ").as_bytes()),
                Encoding::Little => bytes.extend(f.to_le_bytes()),
                Encoding::Big => bytes.extend(f.to_be_bytes()),
            }
        }
    };
    for (i, v) in mesh.vertices.iter().enumerate() {
        floats(&v.to_array(), &mut bytes);
        match encoding {
            Encoding::Ascii => bytes.extend(b"7 "),
            _ => bytes.push(7),
        }
        if normals {
            floats(&mesh.normals[i].to_array(), &mut bytes);
        }
        if let Encoding::Ascii = encoding {
            bytes.push(b'\n');
        }
    }
    for t in &mesh.triangles {
        match encoding {
            Encoding::Ascii => bytes.extend(format!("3 {} {} {}\n", t[0], t[1], t[2]).as_bytes()),
            Encoding::Little => {
                bytes.push(3);
                t.iter().for_each(|i| bytes.extend((*i as i32).to_le_bytes()));
            }
            Encoding::Big => {
                bytes.push(3);
                t.iter().for_each(|i| bytes.extend((*i as i32).to_be_bytes()));
            }
        }
    }
    floats(&[1.0], &mut bytes);
    bytes
}

#[test]
fn the_bunny_as_ply_in_every_encoding_is_the_obj_bunny() {
    let obj = scenes::load_builtin_model("Bunny").unwrap().mesh;
    for (encoding, name) in [(Encoding::Ascii, "ascii"), (Encoding::Little, "le"), (Encoding::Big, "be")] {
        let path = dir().join(format!("bunny-{name}.ply"));
        std::fs::write(&path, write_ply(&obj, encoding)).unwrap();
        let ply = load_mesh(&path).unwrap();
        assert!(ply.warnings.iter().all(|w| !w.contains("dropped")), "{name}: {:?}", ply.warnings);
        assert_eq!(ply.mesh.triangles, obj.triangles, "{name}");
        assert_eq!(ply.mesh.vertices, obj.vertices, "{name}");
        assert_eq!(ply.mesh.normals, obj.normals, "{name}");
        assert_eq!(ply.mesh.stats().degenerate, obj.stats().degenerate);
    }
    // gzip-compressed, found by its name.
    let gz = dir().join("bunny.ply.gz");
    let mut enc = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
    std::io::Write::write_all(&mut enc, &write_ply(&obj, Encoding::Little)).unwrap();
    std::fs::write(&gz, enc.finish().unwrap()).unwrap();
    assert_eq!(load_mesh(&gz).unwrap().mesh.triangles, obj.triangles);
}

fn ply(text: &str) -> Result<isir::obj::LoadedMesh, String> {
    parse_ply(Path::new("t.ply"), text.as_bytes()).map_err(|e| e.to_string())
}

const HEAD: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n";

#[test]
fn polygons_become_fans_and_short_faces_are_counted() {
    let m = ply(&format!(
        "{HEAD}property float u\nproperty float v\nelement face 3\nproperty list uchar uint vertex_index\nend_header\n\
         0 0 0 0 0\n1 0 0 1 0\n1 1 0 1 1\n0 1 0 0 1\n4 0 1 2 3\n2 0 1\n1 3\n"
    ))
    .unwrap();
    assert_eq!(m.mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(m.mesh.uvs.len(), 4);
    assert_eq!(m.mesh.uvs[2], isir::Vec2::new(1.0, 1.0));
    assert!(
        m.warnings.iter().any(|w| w.contains("2 faces with fewer than three vertices dropped (the first: face 1)")),
        "{:?}",
        m.warnings
    );
}

#[test]
fn broken_files_name_the_file_and_the_problem() {
    let v4 = "0 0 0\n1 0 0\n1 1 0\n0 1 0\n";
    let face = "element face 1\nproperty list uchar int vertex_indices\nend_header\n";
    let cases: Vec<(String, &str)> = vec![
        ("solid x\n".into(), "t.ply:1: not a PLY file"),
        ("ply\nformat ascii 1.0\nelement vertex two\nend_header\n".into(), "t.ply:3: header"),
        (format!("{HEAD}{face}{v4}3 0 1 9\n"), "face 0 (0-based) refers to vertex 9, but there are 4 vertices (0 to 3)"),
        (format!("{HEAD}{face}{v4}3 0 -1 2\n"), "refers to vertex -1"),
        (format!("{HEAD}{face}0 0 0\n1 0 0\n"), "element 'vertex' (4 declared)"),
        (format!("{HEAD}{face}{v4}3 0 1\n"), "element 'face' (1 declared)"),
        (
            format!("{HEAD}{face}0 0 zero\n1 0 0\n1 1 0\n0 1 0\n3 0 1 2\n"),
            "t.ply:10: element 'vertex' (4 declared): Couldn't read element line. ('0 0 zero')",
        ),
        ("ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n".into(), "no 'vertex' element"),
        ("ply\nformat ascii 1.0\nelement vertex 1\nproperty float a\nend_header\n1\n".into(), "no x, y and z"),
    ];
    for (text, needle) in cases {
        let e = ply(&text).expect_err(needle);
        assert!(e.starts_with("t.ply") && e.contains(needle), "expected '{needle}' in: {e}");
    }
}

#[test]
fn nan_coordinates_and_zero_area_faces_are_counted_not_fatal() {
    // Binary: a NaN is a float like any other.
    let mesh =
        TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0, Vec3::new(f32::NAN, 1.0, 0.0)], vec![], vec![[0, 1, 2], [0, 1, 3]]);
    let m = parse_ply(Path::new("t.ply"), &write_ply(&mesh, Encoding::Little)).unwrap();
    assert_eq!(m.mesh.stats().degenerate, 2);
    assert!(m.warnings.iter().any(|w| w.contains("2 degenerate triangles")), "{:?}", m.warnings);
}

#[test]
fn counts_the_file_cannot_hold_are_errors_without_the_memory() {
    // A binary file declaring 2^31 vertices and faces but holding one triangle: an error
    // once the bytes run out, after allocating for what is there (the test would be killed
    // long before 2^31 × 12 bytes).
    let mut bytes =
        b"ply\nformat binary_little_endian 1.0\nelement vertex 2147483647\nproperty float x\nproperty float y\nproperty float z\n\
element face 2147483647\nproperty list uchar int vertex_indices\nend_header\n"
            .to_vec();
    for f in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend(f.to_le_bytes());
    }
    let e = parse_ply(Path::new("big.ply"), &bytes).unwrap_err().to_string();
    assert!(e.starts_with("big.ply") && e.contains("element 'vertex' (2147483647 declared)"), "{e}");
}

#[test]
fn the_format_is_known_from_the_content_then_the_name() {
    let obj = scenes::load_builtin_model("uvsphere").unwrap().mesh;
    // PLY content under another name is read as PLY.
    let misnamed = dir().join("really-a-ply.obj");
    std::fs::write(&misnamed, write_ply(&obj, Encoding::Ascii)).unwrap();
    assert_eq!(load_mesh(&misnamed).unwrap().mesh.triangles, obj.triangles);
    // OBJ text still goes to the OBJ reader; other formats are named.
    let plain = dir().join("tri.obj");
    std::fs::write(&plain, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    assert_eq!(load_mesh(&plain).unwrap().mesh.triangles, vec![[0, 1, 2]]);
    let e = load_mesh(Path::new("/nonexistent/m.stl")).unwrap_err().to_string();
    assert!(e.contains("STL meshes are not supported yet"), "{e}");
    // The input limit holds for PLY files too.
    let big = dir().join("sphere-le.ply");
    std::fs::write(&big, write_ply(&obj, Encoding::Little)).unwrap();
    let limits = isir::io::input::ReadLimits::new(1 << 10);
    let e = load_mesh_with(&big, &limits).unwrap_err().to_string();
    assert!(e.contains("input limit"), "{e}");
}

fn valid_plys() -> Vec<Vec<u8>> {
    let quad = TriangleMesh::new(vec![Vec3::ZERO, Vec3::X, Vec3::ONE, Vec3::Y], vec![Vec3::Z; 4], vec![[0, 1, 2], [0, 2, 3]]);
    [Encoding::Ascii, Encoding::Little, Encoding::Big].iter().map(|&e| write_ply(&quad, e)).collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        let _ = parse_ply(Path::new("r.ply"), &bytes);
        let mut with_magic = b"ply\n".to_vec();
        with_magic.extend(&bytes);
        let _ = parse_ply(Path::new("r.ply"), &with_magic);
    }

    #[test]
    fn mutated_valid_files_never_panic(which in 0usize..3, edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8), cut in any::<usize>()) {
        let mut bytes = valid_plys()[which].clone();
        for (at, b) in edits {
            let i = at % bytes.len();
            bytes[i] = b;
        }
        let _ = parse_ply(Path::new("m.ply"), &bytes);
        bytes.truncate(cut % (bytes.len() + 1));
        let _ = parse_ply(Path::new("m.ply"), &bytes);
    }
}
