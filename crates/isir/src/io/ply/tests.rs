//! The direct binary reader (`binary.rs`) against the record reader.

use super::*;
use proptest::prelude::*;

/// The two readers of `bytes`: the same mesh, float bits and all, the same warnings, or
/// the same error.
fn assert_same_readers(bytes: &[u8]) -> Result<LoadedMesh> {
    let (a, b) = (parse_ply_by(Path::new("t.ply"), bytes, true), parse_ply_by(Path::new("t.ply"), bytes, false));
    match (&a, &b) {
        (Ok(a), Ok(b)) => {
            let bits = |v: &[Vec3]| v.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
            assert!(bits(&a.mesh.vertices) == bits(&b.mesh.vertices), "vertices differ");
            assert!(bits(&a.mesh.normals) == bits(&b.mesh.normals), "normals differ");
            let uv = |v: &[Vec2]| v.iter().map(|p| p.to_array().map(f32::to_bits)).collect::<Vec<_>>();
            assert!(uv(&a.mesh.uvs) == uv(&b.mesh.uvs), "uvs differ");
            assert_eq!(a.mesh.triangles, b.mesh.triangles);
            assert_eq!(a.warnings, b.warnings);
            assert_eq!(a.format, b.format);
        }
        (Err(a), Err(b)) => assert_eq!(a.to_string(), b.to_string()),
        _ => panic!("one reader failed: {:?} / {:?}", a.as_ref().err(), b.as_ref().err()),
    }
    a
}

/// A scalar type's PLY name and byte size.
const TYPES: [(&str, usize); 8] =
    [("char", 1), ("uchar", 1), ("short", 2), ("ushort", 2), ("int", 4), ("uint", 4), ("float", 4), ("double", 8)];

/// `value` written as PLY type `t` (an index of `TYPES`), in either byte order.
fn put(out: &mut Vec<u8>, t: usize, value: f64, big: bool) {
    macro_rules! w {
        ($v:expr) => {
            if big {
                out.extend_from_slice(&$v.to_be_bytes())
            } else {
                out.extend_from_slice(&$v.to_le_bytes())
            }
        };
    }
    match t {
        0 => w!(value as i8),
        1 => w!(value as u8),
        2 => w!(value as i16),
        3 => w!(value as u16),
        4 => w!(value as i32),
        5 => w!(value as u32),
        6 => w!(value as f32),
        _ => w!(value),
    }
}

/// A binary PLY file: vertices with the named properties of the given types (values
/// from `values`), faces as lists of `count`/`item` types with other properties around,
/// maybe an element to skip (with a list), maybe a cut body or bytes after it.
#[allow(clippy::too_many_arguments)]
fn binary_ply(
    big: bool,
    vertex_props: &[(&str, usize)],
    values: &[f64],
    vertices: usize,
    faces: &[Vec<i64>],
    (count, item): (usize, usize),
    extra_face_prop: bool,
    skipped: bool,
    cut: Option<usize>,
) -> Vec<u8> {
    let format = if big { "binary_big_endian" } else { "binary_little_endian" };
    let mut h = format!("ply\nformat {format} 1.0\nelement vertex {vertices}\n");
    for (name, t) in vertex_props {
        h += &format!("property {} {name}\n", TYPES[*t].0);
    }
    if skipped {
        h += "element material 2\nproperty uchar red\nproperty list uchar float weights\n";
    }
    h += &format!("element face {}\n", faces.len());
    if extra_face_prop {
        h += "property ushort flags\n";
    }
    h += &format!("property list {} {} vertex_indices\n", TYPES[count].0, TYPES[item].0);
    if extra_face_prop {
        h += "property list uchar float texcoord\n";
    }
    h += "end_header\n";
    let mut out = h.into_bytes();
    let mut k = 0;
    for _ in 0..vertices {
        for (_, t) in vertex_props {
            put(&mut out, *t, values[k % values.len()], big);
            k += 1;
        }
    }
    if skipped {
        for m in 0..2 {
            out.push(m);
            out.push(m);
            for w in 0..m {
                put(&mut out, 6, f64::from(w) * 0.5, big);
            }
        }
    }
    for f in faces {
        if extra_face_prop {
            put(&mut out, 3, 9.0, big);
        }
        put(&mut out, count, f.len() as f64, big);
        for &i in f {
            put(&mut out, item, i as f64, big);
        }
        if extra_face_prop {
            out.push(2);
            put(&mut out, 6, 0.25, big);
            put(&mut out, 6, 0.75, big);
        }
    }
    if let Some(c) = cut {
        out.truncate(out.len().saturating_sub(c));
    }
    out
}

#[test]
fn a_binary_file_of_the_usual_layout_is_read_directly() {
    let faces = vec![vec![0, 1, 2], vec![0, 2, 3, 1], vec![3, 2]];
    let xyz = [("x", 6), ("y", 6), ("z", 6)];
    for big in [false, true] {
        let bytes = binary_ply(big, &xyz, &[0.0, 1.5, -2.25, 3.0], 4, &faces, (1, 4), false, false, None);
        let mut reader = Reader::new(&bytes[..]);
        let header = Parser::<Skip>::new().read_header(&mut reader).unwrap();
        let body = binary::read(&header, reader.get_ref()).expect("read directly");
        assert_eq!(body.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 1]]);
        assert_eq!(body.short, (1, 2));
        let m = assert_same_readers(&bytes).unwrap();
        assert_eq!(m.mesh.vertices[1], Vec3::new(3.0, 0.0, 1.5));
    }
}

#[test]
fn what_the_direct_reader_declines_is_read_record_by_record() {
    let xyz = [("x", 6), ("y", 6), ("z", 6)];
    let tri = vec![vec![0, 1, 2]];
    let declined = [
        ("an index past the vertices", binary_ply(false, &xyz, &[1.0], 3, &[vec![0, 1, 3]], (1, 4), false, false, None)),
        ("a negative index", binary_ply(false, &xyz, &[1.0], 3, &[vec![0, -1, 2]], (1, 4), false, false, None)),
        ("a body cut short", binary_ply(false, &xyz, &[1.0], 3, &tri, (1, 4), false, false, Some(3))),
        ("no z", binary_ply(false, &xyz[..2], &[1.0], 3, &tri, (1, 4), false, false, None)),
        ("float indices", binary_ply(false, &xyz, &[1.0], 3, &tri, (1, 6), false, false, None)),
    ];
    // Two index lists: the record reader keeps the last.
    let mut two = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar int vertex_index\nproperty list uchar int vertex_indices\nend_header\n"
        .to_vec();
    for k in 0..12u8 {
        two.extend(f32::from(k).to_le_bytes());
    }
    for list in [[0i32, 1, 2], [1, 2, 3]] {
        two.push(3);
        list.iter().for_each(|i| two.extend(i.to_le_bytes()));
    }
    assert_eq!(assert_same_readers(&two).unwrap().mesh.triangles, vec![[1, 2, 3]]);
    let declined = declined.into_iter().chain([("two index lists", two)]);
    for (what, bytes) in declined {
        let mut reader = Reader::new(&bytes[..]);
        let header = Parser::<Skip>::new().read_header(&mut reader).unwrap();
        assert!(binary::read(&header, reader.get_ref()).is_none(), "{what}");
        let _ = assert_same_readers(&bytes);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn the_direct_reader_gives_the_record_readers_answers(
        big in any::<bool>(),
        extra in proptest::collection::vec((prop_oneof![
            3 => "[a-z]{1,3}",
            1 => prop_oneof![Just("nx"), Just("ny"), Just("nz"), Just("s"), Just("t"), Just("texture_u"), Just("x")].prop_map(String::from),
        ], 0usize..8), 0..4),
        types in (0usize..8, 0usize..8, 0usize..8),
        normals in any::<bool>(),
        uvs in any::<bool>(),
        values in proptest::collection::vec(-300.0f64..300.0, 1..20),
        vertices in 0usize..12,
        faces in proptest::collection::vec(proptest::collection::vec((0i64..1000, 0u8..60), 0..6), 0..12),
        list_types in (prop_oneof![Just(0usize), Just(1), Just(3), Just(5)], 0usize..6),
        extra_face_prop in any::<bool>(),
        skipped in any::<bool>(),
        cut in prop_oneof![3 => Just(None), 1 => (0usize..20).prop_map(Some)],
        trailing in proptest::collection::vec(any::<u8>(), 0..3),
    ) {
        let mut props: Vec<(String, usize)> = vec![("x".into(), types.0), ("y".into(), types.1), ("z".into(), types.2)];
        if normals {
            props.extend([("nx".into(), 6), ("ny".into(), 7), ("nz".into(), 6)]);
        }
        if uvs {
            props.extend([("u".into(), 6), ("v".into(), 6)]);
        }
        // Other properties anywhere, some named as isir's ('s' is a texture coordinate).
        for (k, (name, t)) in extra.into_iter().enumerate() {
            let at = (k * 2) % (props.len() + 1);
            props.insert(at, (name, t));
        }
        let named: Vec<(&str, usize)> = props.iter().map(|(n, t)| (n.as_str(), *t)).collect();
        // Indices of the vertices, now and then one out of range.
        let faces: Vec<Vec<i64>> = faces
            .iter()
            .map(|f| f.iter().map(|&(i, bad)| match bad { 0 => -1, 1 => vertices as i64, _ => i % vertices.max(1) as i64 }).collect())
            .collect();
        let mut bytes = binary_ply(big, &named, &values, vertices, &faces, list_types, extra_face_prop, skipped, cut);
        bytes.extend(trailing);
        let _ = assert_same_readers(&bytes);
    }
}

/// A token for a value written in one of the ways the grammar takes, or now and then one
/// it or the property's type rejects.
fn ascii_token(value: f64, style: u8, t: usize) -> String {
    let int = t < 6;
    let v = match t {
        1 | 3 | 5 => value.trunc().abs(),
        0 | 2 | 4 => value.trunc(),
        _ => value,
    };
    match style {
        0 if int => format!("+{v}"),
        0 => format!("{v:e}"),
        1 => format!("{v:.3}"),
        2 if int => format!("0{}", v.abs()),
        2 => format!("{v:E}"),
        3 => ["nan", "1.", ".5", "1e", "--1", "0x1", "1.5"][(value.abs() as usize) % 7].to_string(),
        _ => format!("{v}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    #[test]
    fn the_ascii_reader_gives_the_record_readers_answers(
        types in (0usize..8, 0usize..8, 0usize..8),
        normals in any::<bool>(),
        extra in proptest::collection::vec((prop_oneof![Just("q"), Just("nx"), Just("s"), Just("t")], 0usize..8), 0..3),
        values in proptest::collection::vec((-100.0f64..100.0, prop_oneof![60 => 4u8..5, 6 => 0u8..3, 1 => Just(3u8)]), 1..30),
        vertices in 0usize..10,
        faces in proptest::collection::vec(proptest::collection::vec((0i64..1000, 0u8..60), 0..6), 0..10),
        list_types in (prop_oneof![Just(1usize), Just(3), Just(5)], prop_oneof![Just(1usize), Just(4), Just(5), Just(6)]),
        separators in proptest::collection::vec(prop_oneof![8 => Just(" "), 1 => Just("\t"), 1 => Just("  ")], 4),
        crlf in any::<bool>(),
        extra_tokens in any::<bool>(),
        skipped in any::<bool>(),
        cut_lines in prop_oneof![4 => Just(0usize), 1 => 1usize..3],
        odd_line in prop_oneof![6 => Just(None), 1 => (0usize..20, prop_oneof![Just(""), Just("\r"), Just(" 1 \r 2"), Just("é")]).prop_map(Some)],
    ) {
        let mut props: Vec<(String, usize)> = vec![("x".into(), types.0), ("y".into(), types.1), ("z".into(), types.2)];
        if normals {
            props.extend([("nx".into(), 6), ("ny".into(), 7), ("nz".into(), 6)]);
        }
        for (k, (name, t)) in extra.into_iter().enumerate() {
            props.insert((k * 2) % (props.len() + 1), (name.to_string(), t));
        }
        let mut header = format!("ply\nformat ascii 1.0\nelement vertex {vertices}\n");
        for (name, t) in &props {
            header += &format!("property {} {name}\n", TYPES[*t].0);
        }
        if skipped {
            header += "element material 1\nproperty uchar red\nproperty list uchar float weights\n";
        }
        header += &format!("element face {}\nproperty list {} {} vertex_indices\nend_header\n", faces.len(), TYPES[list_types.0].0, TYPES[list_types.1].0);
        let sep = |k: usize| separators[k % separators.len()];
        let mut lines: Vec<String> = Vec::new();
        let mut k = 0;
        for _ in 0..vertices {
            let mut line = String::new();
            for (p, (_, t)) in props.iter().enumerate() {
                let (value, style) = values[k % values.len()];
                k += 1;
                if p > 0 {
                    line += sep(k);
                }
                line += &ascii_token(value, style, *t);
            }
            if extra_tokens {
                line += " 7";
            }
            lines.push(line);
        }
        if skipped {
            lines.push("4 2 0.5 1e-3".into());
        }
        for f in &faces {
            let idx: Vec<String> = f.iter().map(|&(i, bad)| match bad { 0 => "-1".into(), 1 => vertices.to_string(), _ => (i % vertices.max(1) as i64).to_string() }).collect();
            lines.push(format!("{}{}{}", f.len(), if f.is_empty() { "" } else { sep(f.len()) }, idx.join(sep(0))));
        }
        if let Some((at, odd)) = odd_line {
            let at = at % (lines.len() + 1);
            lines.insert(at, odd.to_string());
        }
        lines.truncate(lines.len().saturating_sub(cut_lines));
        let mut bytes = header.into_bytes();
        bytes.extend(lines.join(if crlf { "\r\n" } else { "\n" }).as_bytes());
        let _ = assert_same_readers(&bytes);
    }
}

#[test]
fn an_ascii_file_of_the_usual_layout_is_read_directly() {
    let src = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
element face 3\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0\n1.5 -2 3e2\n+1 0.25 1E-3\n\t0 1 0 \r\n3 0 1 2\n4 0 2 3 1\n2 3 2\n";
    let mut reader = Reader::new(src.as_bytes());
    let header = Parser::<Skip>::new().read_header(&mut reader).unwrap();
    let body = ascii::read(&header, reader.get_ref()).expect("read directly");
    assert_eq!(body.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 3, 1]]);
    assert_eq!(body.short, (1, 2));
    assert_eq!(body.positions[1], Vec3::new(1.5, -2.0, 300.0));
    let m = assert_same_readers(src.as_bytes()).unwrap();
    assert_eq!(m.mesh.vertices[2], Vec3::new(1.0, 0.25, 1e-3));
    // The grammar's refusals: read record by record, which names the line.
    for odd in ["1.", "nan", ".5", "1\r2"] {
        let bad = src.replace("+1 0.25", &format!("{odd} 0.25"));
        let mut reader = Reader::new(bad.as_bytes());
        let header = Parser::<Skip>::new().read_header(&mut reader).unwrap();
        assert!(ascii::read(&header, reader.get_ref()).is_none(), "{odd}");
        assert!(assert_same_readers(bad.as_bytes()).is_err(), "{odd}");
    }
}

#[test]
fn ascii_doubles_and_faces_past_the_first_chunk_read_as_the_record_reader_reads_them() {
    // A double rounded to f32 through f64 (as the record reader does): not the f32 parse.
    let tie = "1.00000005960464477539062500000001";
    assert_ne!(tie.parse::<f32>().unwrap(), tie.parse::<f64>().unwrap() as f32);
    let faces = ascii::FACE_CHUNK + 100;
    let mut src = format!(
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty double x\nproperty float y\nproperty float z\n\
element face {faces}\nproperty list uchar uint vertex_indices\nend_header\n{tie} 0 0\n0 1 0\n0 0 1\n"
    );
    for f in 0..faces {
        // The first short face is in the second chunk.
        src += if f == ascii::FACE_CHUNK + 7 || f == faces - 1 { "2 0 1\n" } else { "3 0 1 2\n" };
    }
    let mut reader = Reader::new(src.as_bytes());
    let header = Parser::<Skip>::new().read_header(&mut reader).unwrap();
    let body = ascii::read(&header, reader.get_ref()).expect("read directly");
    assert_eq!(body.short, (2, ascii::FACE_CHUNK + 7));
    assert_eq!(body.positions[0].x, 1.0);
    let m = assert_same_readers(src.as_bytes()).unwrap();
    assert!(m.warnings.iter().any(|w| w.contains(&format!("the first: face {}", ascii::FACE_CHUNK + 7))), "{:?}", m.warnings);
}

#[test]
fn binary_elements_without_properties_cost_nothing_whatever_their_count() {
    // Records of no bytes: the crate's reader would make one per declared record (memory
    // for 10^12 vertices or faces, or 10^18 steps over a skipped element).
    let head = "ply\nformat binary_little_endian 1.0\n";
    let three_vertices = |extra: &str| {
        let mut b = format!("{head}{extra}element vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n").into_bytes();
        for k in 0..9u8 {
            b.extend(f32::from(k).to_le_bytes());
        }
        b
    };
    // Vertices without x y z: the error, at once.
    let e = assert_same_readers(format!("{head}element vertex 1000000000000\nend_header\n").as_bytes()).unwrap_err().to_string();
    assert!(e.contains("no x, y and z"), "{e}");
    // Faces without indices: all short.
    let m = assert_same_readers(format!("{head}element vertex 0\nproperty float x\nelement face 1000000000000\nend_header\n").as_bytes())
        .unwrap();
    assert!(m.warnings.iter().any(|w| w.contains("1000000000000 faces with fewer than three vertices")), "{:?}", m.warnings);
    // A skipped element of 10^18 records, then a face index out of range (so the record
    // reader reads the file): its error, at once.
    let mut b = three_vertices("element junk 1000000000000000000\n");
    b.extend([3, 0, 0, 0, 0, 1, 0, 0, 0, 9, 0, 0, 0]);
    let e = assert_same_readers(&b).unwrap_err().to_string();
    assert!(e.contains("refers to vertex 9"), "{e}");
    // The same element before a valid face: read.
    let mut b = three_vertices("element junk 1000000000000000000\n");
    b.extend([3, 0, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0]);
    assert_eq!(assert_same_readers(&b).unwrap().mesh.triangles, vec![[0, 1, 2]]);
}

/// A header of three float vertices (`vertex_extra` after `x y z`) and one face
/// declared as `face_decl`, in `format`.
fn header_with(format: &str, vertex_extra: &str, face_decl: &str) -> String {
    format!(
        "ply\nformat {format} 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n{vertex_extra}\
element face 1\n{face_decl}\nend_header\n"
    )
}

/// The bytes of three float vertices and one `list uchar int` triangle, little endian.
fn binary_triangle() -> Vec<u8> {
    let mut b: Vec<u8> = [0f32, 0., 0., 1., 0., 0., 0., 1., 0.].iter().flat_map(|f| f.to_le_bytes()).collect();
    b.push(3);
    [0i32, 1, 2].iter().for_each(|i| b.extend(i.to_le_bytes()));
    b
}

#[test]
fn an_element_or_property_declared_twice_is_an_error_naming_its_header_line() {
    let vertex = "element vertex 3\nproperty float x\nproperty float y\nproperty float z\n";
    let ascii = format!(
        "ply\nformat ascii 1.0\n{vertex}{vertex}element face 1\nproperty list uchar int vertex_indices\nend_header\n\
0 0 0\n1 0 0\n0 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"
    );
    let e = assert_same_readers(ascii.as_bytes()).unwrap_err().to_string();
    assert_eq!(e, "t.ply:7: header: element 'vertex' declared twice");
    // Binary, and another element.
    let mut bin =
        header_with("binary_little_endian", "", "property list uchar int vertex_indices\nelement face 1\nproperty uchar n").into_bytes();
    bin.extend(binary_triangle());
    let e = assert_same_readers(&bin).unwrap_err().to_string();
    assert_eq!(e, "t.ply:9: header: element 'face' declared twice");
    // A property declared twice in one element; the same name in two elements is fine.
    let e = assert_same_readers(header_with("ascii", "property float x\n", "property list uchar int vertex_indices").as_bytes())
        .unwrap_err()
        .to_string();
    assert_eq!(e, "t.ply:7: header: property 'x' of element 'vertex' declared twice");
    let mut ok = header_with("binary_little_endian", "", "property list uchar int vertex_indices\nproperty uchar x").into_bytes();
    ok.extend(binary_triangle());
    ok.push(7);
    assert_eq!(assert_same_readers(&ok).unwrap().mesh.triangles, vec![[0, 1, 2]]);
    // A format version PLY does not have.
    let v2 = ascii.replacen("format ascii 1.0", "format ascii 2.0", 1).replacen(vertex, "", 1);
    let e = assert_same_readers(v2.as_bytes()).unwrap_err().to_string();
    assert_eq!(e, "t.ply:2: header: format version 2.0: PLY has only version 1.0");
}

#[test]
fn vertex_indices_must_be_a_list_of_integers() {
    for (decl, shown) in [
        ("property list uchar float vertex_indices", "property list uchar float vertex_indices"),
        ("property int vertex_indices", "property int vertex_indices"),
        ("property  list uint8 float64  vertex_index", "property list uint8 float64 vertex_index"),
    ] {
        let name = shown.rsplit(' ').next().unwrap();
        let want = format!("t.ply:8: header: '{name}' must be a list of integers ('property list uchar int {name}'), not '{shown}'");
        let ascii = header_with("ascii", "", decl) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(assert_same_readers(ascii.as_bytes()).unwrap_err().to_string(), want);
        let mut bin = header_with("binary_big_endian", "", decl).into_bytes();
        bin.extend([0u8; 64]);
        assert_eq!(assert_same_readers(&bin).unwrap_err().to_string(), want);
    }
    // Every integer type is an index type; other elements' lists are not read.
    for item in ["char", "uchar", "short", "ushort", "int", "uint", "int8", "uint16", "int32", "uint32"] {
        let ascii = header_with("ascii", "", &format!("property list uchar {item} vertex_indices")) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
        assert_eq!(assert_same_readers(ascii.as_bytes()).unwrap().mesh.triangles, vec![[0, 1, 2]], "{item}");
    }
    let other = header_with("ascii", "property list uchar float vertex_indices\n", "property list uchar int vertex_indices")
        + "0 0 0 0\n1 0 0 1 0.5\n0 1 0 0\n3 0 1 2\n";
    assert_eq!(assert_same_readers(other.as_bytes()).unwrap().mesh.triangles, vec![[0, 1, 2]]);
}

#[test]
fn ascii_lines_with_more_values_than_declared_are_errors_in_both_readers() {
    let head = header_with("ascii", "", "property list uchar int vertex_indices");
    let declined = |src: &str| {
        let mut reader = Reader::new(src.as_bytes());
        let header = Parser::<Skip>::new().read_header(&mut reader).unwrap();
        ascii::read(&header, reader.get_ref()).is_none()
    };
    let cases = [
        ("0 0 0 5\n1 0 0\n0 1 0\n3 0 1 2\n", "t.ply:10: element 'vertex' (3 declared): 4 values where the header declares 3"),
        (
            "0 0 0\n1 0 0\n0 1 0\n2 0 1 2\n",
            "t.ply:13: element 'face' (1 declared): the list 'vertex_indices' says 2 values, the line holds 3",
        ),
        // The first problem in the file, whichever reader finds it.
        ("0 0 0\n1 0 0 1\n0 1 0\n3 0 1 nan\n", "t.ply:11: element 'vertex' (3 declared): 4 values where the header declares 3"),
    ];
    for (body, want) in cases {
        let src = format!("{head}{body}");
        assert!(declined(&src), "{body}");
        assert_eq!(assert_same_readers(src.as_bytes()).unwrap_err().to_string(), want);
    }
    // A problem the record reader names before the line with values too many: its error.
    let src = format!("{head}0 0 0\n1 0 nan\n0 1 0 9\n3 0 1 2\n");
    let e = assert_same_readers(src.as_bytes()).unwrap_err().to_string();
    assert!(e.starts_with("t.ply:11: element 'vertex' (3 declared): Couldn't read element line"), "{e}");
    // In an element isir skips, after a list that is not the last property.
    let face = "property list uchar int vertex_indices\nelement material 1\nproperty list uchar float w\nproperty uchar red";
    let src = header_with("ascii", "", face) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n2 0.5 0.25 7 8\n";
    assert_eq!(
        assert_same_readers(src.as_bytes()).unwrap_err().to_string(),
        "t.ply:17: element 'material' (1 declared): 5 values where the header declares 4"
    );
    // Spaces, tabs and CRLF around the values are not values.
    let src = format!("{head}0 0 0 \n\t1 0 0\t\r\n0  1 0\r\n3 0 1 2  \n");
    assert!(!declined(&src));
    assert_eq!(assert_same_readers(src.as_bytes()).unwrap().mesh.triangles, vec![[0, 1, 2]]);
}
