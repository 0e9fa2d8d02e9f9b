//! Small files that name something many times (an image, a material library, an accessor,
//! a mesh) take what they really hold: an image is decoded once for all its materials, a
//! library named again adds nothing, and a glTF file that would expand past the input
//! limit is an error naming the reuse, found before anything is allocated.

use isir::io::input::ReadLimits;
use isir::io::obj::load_obj_with;
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
    let mut mtl: String = (0..8).map(|i| format!("newmtl m{i}\nKd 1 1 1\nmap_Kd t.png\n")).collect();
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
