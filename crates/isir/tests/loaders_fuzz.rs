//! Random bytes and random mutations of valid files fed to every mesh loader: an error or
//! a mesh, never a panic (the PLY and glTF suites have their own, with their formats'
//! writers).

use isir::io::mesh::load_mesh;
use isir::io::obj::parse_obj;
use proptest::prelude::*;
use std::path::Path;

const VALID_OBJ: &str = "mtllib m.mtl\n# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
usemtl red\nf 1/1/1 2/2/1 3/3/1 4/4/1\ng second\nf -4 -3 -2\n";
const VALID_MTL: &str = "newmtl red\nKd 1 0 0\nmap_Kd red.png\nnewmtl blue\nKd 0 0 1\n";

fn mutate(mut bytes: Vec<u8>, edits: &[(usize, u8)], cut: usize) -> Vec<u8> {
    for &(at, b) in edits {
        if !bytes.is_empty() {
            let i = at % bytes.len();
            bytes[i] = b;
        }
    }
    bytes.truncate(cut % (bytes.len() + 1));
    bytes
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, ..ProptestConfig::default() })]

    #[test]
    fn obj_and_mtl_bytes_never_panic(
        obj_edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        mtl_edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 0..8),
        cuts in (any::<usize>(), any::<usize>()),
        random in proptest::collection::vec(any::<u8>(), 0..256),
    ) {
        let obj = mutate(VALID_OBJ.as_bytes().to_vec(), &obj_edits, cuts.0);
        let mtl = mutate(VALID_MTL.as_bytes().to_vec(), &mtl_edits, cuts.1);
        let _ = parse_obj(Path::new("m.obj"), &obj, |_| Ok(mtl.clone()));
        let _ = parse_obj(Path::new("r.obj"), &random, |_| Ok(random.clone()));
    }

    #[test]
    fn the_format_dispatch_never_panics(random in proptest::collection::vec(any::<u8>(), 0..256), prefix in 0usize..5) {
        // Files starting like each format, then anything.
        let heads: [&[u8]; 5] = [b"", b"ply\n", b"glTF", b"{\"asset\":", b"v 0 0 0\n"];
        let mut bytes = heads[prefix].to_vec();
        bytes.extend(&random);
        let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("fuzz");
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(format!("f{prefix}.mesh"));
        std::fs::write(&path, &bytes).unwrap();
        let _ = load_mesh(&path);
    }
}
