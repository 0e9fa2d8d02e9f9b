//! Tests of the OBJ reader.

use super::*;
use proptest::prelude::*;
use std::io::Write;

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

/// A fresh directory for this test's files, removed when the test ends (failing too).
fn tmp_dir(test: &str) -> tempfile::TempDir {
    tempfile::Builder::new().prefix(&format!("isir-obj-{test}-")).tempdir().unwrap()
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
    let obj =
        b"# caf\xe9\nmtllib m.mtl\no caf\xe9\ng gr\xfcn\nusemtl rouge\xe9\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nusemtl rouge\xe8\nf 1 2 3\n";
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
    for (what, bytes) in [("LE", [&[0xff, 0xfe][..], &le].concat()), ("BE", [&[0xfe, 0xff][..], &be].concat()), ("no BOM", le.clone())] {
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
    let src = "v 0 0 0\r\nv 1 0 0\r\n\tv 0 1 0\r\nf\t1 2 3\r\n  f 1 2\r\n  l 1 2 3\r\nf\u{a0}1 2 3\r\nf 3 2\u{a0}1\r\nf 1 2 3 \r\nf 1 2";
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
    let tmp = tmp_dir("mtl");
    let dir = tmp.path();
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
    let tmp = tmp_dir("fifo");
    let dir = tmp.path();
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
    let tmp = tmp_dir("gz");
    let dir = tmp.path();
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
    for (file, format) in [("m.stl", "STL"), ("m.fbx.gz", "FBX")] {
        // Refused by name, before anything is read.
        let e = load_obj(&Path::new("/nonexistent").join(file)).unwrap_err().to_string();
        assert_eq!(
            e,
            format!(
                "/nonexistent/{file}: {format} meshes are not supported yet (isir reads Wavefront OBJ, PLY and glTF: .obj, .ply, \
                 .gltf, .glb, the first two optionally gzip-compressed)"
            )
        );
    }
    // Formats isir reads through `io::mesh`, but not as OBJ.
    for (file, format) in [("m.ply", "PLY"), ("m.PLY.gz", "PLY"), ("m.gltf", "glTF"), ("m.glb", "glTF (binary .glb)")] {
        let e = load_obj(&Path::new("/nonexistent").join(file)).unwrap_err().to_string();
        assert!(e.ends_with(&format!("{format} meshes are not OBJ: read them with isir::io::mesh::load_mesh")), "{e}");
    }
    let mut stl = vec![b' '; 80];
    stl.extend(1u32.to_le_bytes());
    stl.extend([0u8; 50]);
    let gltf = b"{\n  \"asset\": {\"version\": \"2.0\"}, \"meshes\": []\n}\n";
    for (bytes, format) in [
        (&b"ply\nformat ascii 1.0\nelement vertex 3\n"[..], "PLY meshes are not OBJ"),
        (b"glTF\x02\0\0\0\x10\0\0\0", "glTF (binary .glb) meshes are not OBJ"),
        (&stl, "STL (binary) meshes"),
        (b"solid cube\n  facet normal 0 0 1\n", "STL (ASCII) meshes"),
        (gltf, "glTF meshes are not OBJ"),
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

// ---- The parallel reader (`fast.rs`) against tobj ----

/// `a` and `b` the same, float bits and all (NaN too), or the same error.
fn assert_same(a: &Result<LoadedMesh>, b: &Result<LoadedMesh>, what: &str) {
    match (a, b) {
        (Ok(a), Ok(b)) => {
            let bits = |v: &[Vec3]| v.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
            assert!(bits(&a.mesh.vertices) == bits(&b.mesh.vertices), "{what}: vertices differ");
            assert!(bits(&a.mesh.normals) == bits(&b.mesh.normals), "{what}: normals differ");
            let uv_bits = |v: &[glam::Vec2]| v.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
            assert!(uv_bits(&a.mesh.uvs) == uv_bits(&b.mesh.uvs), "{what}: uvs differ");
            assert!(a.mesh.triangles == b.mesh.triangles, "{what}: triangles differ");
            assert!(a.mesh.material_slots == b.mesh.material_slots, "{what}: material slots differ");
            assert_eq!(a.materials, b.materials, "{what}: materials differ");
            assert_eq!(a.warnings, b.warnings, "{what}: warnings differ");
        }
        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string(), "{what}: errors differ"),
        (a, b) => panic!("{what}: one reader failed: {:?} / {:?}", a.as_ref().err(), b.as_ref().err()),
    }
}

const TWO_MATERIALS: &[u8] = b"newmtl a\nKd 1 0 0\nnewmtl b\nKd 0 0 1\n";

fn by(src: &[u8], reader: Reader) -> Result<LoadedMesh> {
    parse_obj_by(Path::new("t.obj"), src, |_| Ok(TWO_MATERIALS.to_vec()), true, reader)
}

#[test]
fn the_parallel_reader_reads_the_built_in_models_as_tobj() {
    for name in crate::scenes::builtin_models() {
        let bytes = crate::scenes::builtin_model_obj(name).unwrap();
        let text = decode_text(&bytes).unwrap();
        let geometry = fast::read_geometry(&text).expect("the built-in models are plain OBJ");
        // Read by the parallel reader to the end (not declined to tobj on the way).
        let (skeleton, runs) = geometry.skeleton(&text);
        assert!(!runs.is_empty(), "{name}: no face run");
        let options = tobj::LoadOptions { triangulate: true, single_index: true, ignore_points: true, ignore_lines: true };
        let (models, _) = tobj::load_obj_buf(&mut skeleton.as_bytes(), &options, |_| tobj::load_mtl_buf(&mut &TWO_MATERIALS[..])).unwrap();
        assert!(geometry.models(models, &runs).is_some(), "{name}: declined");
        let reference = by(&bytes, Reader::Tobj);
        assert!(reference.as_ref().is_ok_and(|m| !m.mesh.triangles.is_empty()), "{name}");
        for chunks in [None, Some(1), Some(7), Some(64)] {
            assert_same(&by(&bytes, Reader::Parallel(chunks)), &reference, &format!("{name}, {chunks:?} chunks"));
        }
    }
}

#[test]
fn the_parallel_reader_declines_what_tobj_reads_its_own_way() {
    let plain = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    assert!(fast::read_geometry(plain).is_some());
    for odd in [
        "v 0 0 0\nv 1 0 0\nv 0 1 0 0\nf 1 2 3\n",                 // a weight of 0
        "v 0 0 0 1 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",             // a colour on one vertex only
        "v 0 0 0 1 x 0\nv 1 0 0 1 0 0\nv 0 1 0 1 0 0\nf 1 2 3\n", // a colour not a number
        "v 0 0 0 1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",               // five numbers
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n",                // relative indices
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 +3\n",                  // a sign
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 0\n",                   // index 0
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3/1/1/1\n",             // four parts
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n",                   // not a number
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2 3\n",                   // a polyline
        "v 0 0 0\nv 1 0 0\nv 0\u{a0}1 0\nf 1 2 3\n",              // Unicode whitespace
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n\u{a0}g x\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 1234567890\n", // ten digits
    ] {
        assert!(fast::read_geometry(odd).is_none(), "{odd:?}");
        assert_same(&by(odd.as_bytes(), Reader::Parallel(None)), &by(odd.as_bytes(), Reader::Tobj), odd);
    }
    // Colours on every vertex (not kept) and weights (divided by): read, as tobj reads them.
    for read in ["v 0 0 0 1 0 0\nv 1 0 0 0 1 0\nv 0 1 0 0 0 1\nf 1 2 3\n", "v 0 0 0\nv 2 0 0 2\nv 0 3 0 -0.5\nf 1 2 3\n"] {
        assert!(fast::read_geometry(read).is_some(), "{read:?}");
        assert_same(&by(read.as_bytes(), Reader::Parallel(None)), &by(read.as_bytes(), Reader::Tobj), read);
    }
    assert_eq!(
        by(b"v 0 0 0\nv 2 0 0 2\nv 0 3 0 -0.5\nf 1 2 3\n", Reader::Parallel(None)).unwrap().mesh.vertices[2],
        Vec3::new(0.0, -6.0, 0.0)
    );
    // Read, but an index out of range: tobj's error, through tobj.
    let out = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
    assert!(fast::read_geometry(out).is_some());
    let (a, b) = (by(out.as_bytes(), Reader::Parallel(None)), by(out.as_bytes(), Reader::Tobj));
    assert!(a.is_err(), "an index out of range is an error");
    assert_same(&a, &b, out);
}

/// One line of a generated OBJ file.
fn obj_line() -> impl Strategy<Value = String> {
    let float = prop_oneof![
        (-50i32..50).prop_map(|i| i.to_string()),
        (-1000i32..1000).prop_map(|i| format!("{}", i as f32 / 7.0)),
        Just("1e-3".to_string()),
        Just("+2.".to_string()),
        Just("-0".to_string()),
        Just(".5".to_string()),
        Just("nan".to_string()),
    ];
    let index = prop_oneof![8 => 1u32..12, 1 => Just(0u32), 1 => 12u32..20];
    // Element shapes: v, v/vt, v//vn, v/vt/vn, and now and then something else.
    let element = (index.clone(), index.clone(), index, 0u8..9).prop_map(|(v, t, n, shape)| match shape {
        0 | 1 => format!("{v}"),
        2 => format!("{v}/{t}"),
        3 | 4 => format!("{v}//{n}"),
        5..=7 => format!("{v}/{t}/{n}"),
        _ => ["-1", "1/", "1//", "01", "/2", "1/2/3/4", "2/x"][v as usize % 7].to_string(),
    });
    let space = prop_oneof![6 => Just(" "), 1 => Just("  "), 1 => Just("\t"), 1 => Just(" \r")];
    prop_oneof![
        4 => (proptest::collection::vec(float.clone(), 3..=4), space.clone()).prop_map(|(f, s)| format!("v {}", f.join(s))),
        1 => (proptest::collection::vec(float.clone(), 5..=7), space.clone()).prop_map(|(f, s)| format!("v {}", f.join(s))),
        2 => proptest::collection::vec(float.clone(), 2..=3).prop_map(|f| format!("vt {}", f.join(" "))),
        2 => proptest::collection::vec(float, 2..=4).prop_map(|f| format!("vn {}", f.join(" "))),
        6 => (proptest::collection::vec(element, 1..=6), space).prop_map(|(e, s)| format!("f {}", e.join(s))),
        1 => prop_oneof![
            Just("o first".to_string()),
            Just("g second".to_string()),
            Just("g".to_string()),
            Just("usemtl a".to_string()),
            Just("usemtl b".to_string()),
            Just("usemtl missing".to_string()),
            Just("mtllib m.mtl".to_string()),
            Just("s 1".to_string()),
            Just("# a comment é".to_string()),
            Just("".to_string()),
            Just("   ".to_string()),
            Just("vp 0.5".to_string()),
            // Faces without elements, which the scan hides from tobj (and the reader
            // then reads the text again).
            Just("f".to_string()),
            Just("f  ".to_string()),
        ],
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 400, ..ProptestConfig::default() })]

    #[test]
    fn the_parallel_reader_gives_tobj_answers(
        lines in proptest::collection::vec(obj_line(), 0..60),
        crlf in any::<bool>(),
        newline_at_end in any::<bool>(),
        chunks in 1usize..9,
    ) {
        let mut src = lines.join(if crlf { "\r\n" } else { "\n" });
        if newline_at_end {
            src.push('\n');
        }
        let reference = by(src.as_bytes(), Reader::Tobj);
        assert_same(&by(src.as_bytes(), Reader::Parallel(Some(chunks))), &reference, &src);
    }

    #[test]
    fn the_parallel_reader_reads_plain_files_itself(
        vertices in proptest::collection::vec((-100i32..100, -100i32..100, -100i32..100), 3..40),
        faces in proptest::collection::vec((proptest::collection::vec(0usize..1000, 3..6), 0u8..3), 1..40),
        chunks in 1usize..9,
    ) {
        // Plain files, groups and materials included: read by the parallel reader, and
        // as tobj reads them.
        let mut src = String::from("mtllib m.mtl\n");
        for (x, y, z) in &vertices {
            src += &format!("v {} {} {}\nvn 0 0 1\nvt 0.{} 0.5\n", *x as f32 / 3.0, y, z, x.unsigned_abs());
        }
        for (k, (f, group)) in faces.iter().enumerate() {
            match group {
                1 if k % 3 == 0 => src += "usemtl a\n",
                2 if k % 5 == 0 => src += &format!("g part{k}\nusemtl b\n"),
                _ => {}
            }
            // One texture index per position mostly, another now and then.
            let n = vertices.len();
            let e: Vec<String> = f.iter().map(|i| { let (v, t) = (i % n + 1, if i % 4 == 0 { i / 4 % n + 1 } else { i % n + 1 }); format!("{v}/{t}/{v}") }).collect();
            src += &format!("f {}\n", e.join(" "));
        }
        prop_assert!(fast::read_geometry_in(&src, chunks).is_some());
        let reference = by(src.as_bytes(), Reader::Tobj);
        prop_assert!(reference.as_ref().is_ok_and(|m| !m.mesh.triangles.is_empty()));
        assert_same(&by(src.as_bytes(), Reader::Parallel(Some(chunks))), &reference, &src);
    }
}

#[test]
fn what_tobj_reads_depends_on_where_a_model_ends_goes_through_tobj() {
    // tobj checks a model's indices, and decides whether it has texture coordinates and
    // normals, when the model ends (`o`, `g`, a new `usemtl`, the end of the file), with
    // what it had read by then. (Found by review: the parallel reader had used the whole
    // file's lines.)
    for src in [
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\no b\nv 1 1 0\n",
        "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\nusemtl a\nv 1 1 0\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1/1 2/1 3/1\ng b\nvt 0.5 0.5\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nf 1/1 2/2 3/1\ng b\nvt 0.5 0.5\n",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1//1 2//1 3//1\ng b\nvn 0 0 1\n",
    ] {
        let reference = by(src.as_bytes(), Reader::Tobj);
        for chunks in [1, 3] {
            assert_same(&by(src.as_bytes(), Reader::Parallel(Some(chunks))), &reference, src);
        }
    }
    // Within one model, lines after its faces count: read by the parallel reader.
    let later = "f 1/1 2/1 3/1\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0.5 0.5\n";
    assert!(fast::read_geometry(later).is_some());
    assert_same(&by(later.as_bytes(), Reader::Parallel(None)), &by(later.as_bytes(), Reader::Tobj), later);
}

#[test]
fn degenerate_triangles_are_counted_in_words_that_agree() {
    let v = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0];
    // One degenerate triangle (three points on a line), then two.
    let one = TriangleMesh::new(v.clone(), Vec::new(), vec![[0, 1, 2], [0, 1, 3]]);
    assert_eq!(mesh_warnings(&one, true), ["1 degenerate triangle (zero area or non-finite vertices) is never hit"]);
    let two = TriangleMesh::new(v, Vec::new(), vec![[0, 1, 2], [0, 1, 3], [1, 3, 0]]);
    assert_eq!(mesh_warnings(&two, true), ["2 degenerate triangles (zero area or non-finite vertices) are never hit"]);
    assert!(mesh_warnings(&two, false).is_empty());
}
