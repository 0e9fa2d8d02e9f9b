//! Colour textures: `map_Kd` in MTL and glTF's base-colour texture, decoded from sRGB,
//! looked up at each hit's interpolated UVs; a texture that cannot be read is a warning
//! and a flat colour.

use base64::Engine;
use isir::io::mesh::load_mesh;
use isir::materials::srgb_to_linear;
use isir::scenes::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc};
use isir::{Accel, Color, Ray, Vec3};
use std::path::{Path, PathBuf};

fn dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("textures");
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A 2×1 PNG: red on the left, blue on the right (sRGB 255 and 128).
fn png() -> Vec<u8> {
    let mut img = image::RgbImage::new(2, 1);
    img.put_pixel(0, 0, image::Rgb([255, 0, 0]));
    img.put_pixel(1, 0, image::Rgb([0, 0, 128]));
    let mut out = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png).unwrap();
    out
}

/// The colour seen straight down -z at `(x, 0.5)` on the unit quad of the file.
fn colour_at(path: &Path, x: f32) -> (Color, Vec<String>) {
    let mut d = SceneDescription::new("t", CameraDesc::new(Vec3::new(0.5, 0.5, 3.0), Vec3::new(0.5, 0.5, 0.0)));
    d.objects.push(ObjectDesc {
        name: "quad".into(),
        shape: ShapeDesc::Mesh { source: MeshSource::File(path.into()), shading: Default::default() },
        material: None,
    });
    let scene = d.build(Accel::BvhSah).unwrap();
    let hit = scene.intersect(&Ray::new(Vec3::new(x, 0.5, 1.0), -Vec3::Z), 0.0, f32::INFINITY).expect("the quad is hit");
    (scene.material(&hit).color_at(&hit), scene.warnings)
}

const QUAD_OBJ: &str =
    "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nusemtl tex\nf 1/1 2/2 3/3 4/4\n";

#[test]
fn map_kd_textures_an_obj_and_a_missing_one_is_a_warning() {
    let d = dir();
    std::fs::write(d.join("checker.png"), png()).unwrap();
    std::fs::write(d.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(d.join("quad.mtl"), "newmtl tex\nKd 1 1 1\nmap_Kd -bm 1 checker.png\n").unwrap();
    let loaded = load_mesh(&d.join("quad.obj")).unwrap();
    assert!(loaded.materials[0].texture.is_some(), "{:?}", loaded.warnings);
    // Texel centres: u 0.25 is the red one, u 0.75 the blue one (sRGB-decoded).
    let (red, _) = colour_at(&d.join("quad.obj"), 0.25);
    assert!((red - Color::X).length() < 1e-5, "{red}");
    let (blue, _) = colour_at(&d.join("quad.obj"), 0.75);
    assert!((blue - Color::new(0.0, 0.0, srgb_to_linear(128))).length() < 1e-5, "{blue}");
    // Kd tints the texture.
    std::fs::write(d.join("tinted.obj"), QUAD_OBJ.replace("quad.mtl", "tinted.mtl")).unwrap();
    std::fs::write(d.join("tinted.mtl"), "newmtl tex\nKd 0.5 0.5 0.5\nmap_Kd checker.png\n").unwrap();
    let (half_red, _) = colour_at(&d.join("tinted.obj"), 0.25);
    assert!((half_red - Color::new(0.5, 0.0, 0.0)).length() < 1e-5, "{half_red}");
    // Missing: a warning naming it, and the flat colour.
    std::fs::write(d.join("missing.obj"), QUAD_OBJ.replace("quad.mtl", "missing.mtl")).unwrap();
    std::fs::write(d.join("missing.mtl"), "newmtl tex\nKd 0.2 0.4 0.6\nmap_Kd nowhere.png\n").unwrap();
    let (flat, warnings) = colour_at(&d.join("missing.obj"), 0.25);
    assert_eq!(flat, Color::new(0.2, 0.4, 0.6));
    assert!(warnings.iter().any(|w| w.contains("texture nowhere.png") && w.contains("flat colour")), "{warnings:?}");
    // Not an image: the same.
    std::fs::write(d.join("garbage.png"), b"not a png").unwrap();
    std::fs::write(d.join("missing.mtl"), "newmtl tex\nKd 0.2 0.4 0.6\nmap_Kd garbage.png\n").unwrap();
    let (_, warnings) = colour_at(&d.join("missing.obj"), 0.25);
    assert!(warnings.iter().any(|w| w.contains("texture garbage.png")), "{warnings:?}");
}

#[test]
fn gltf_base_colour_textures_are_read_with_their_uvs() {
    // The quad with TEXCOORD_0 in glTF's convention (v down the image) and the PNG
    // embedded as a data URI.
    let mut bin = Vec::new();
    for f in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend(f.to_le_bytes());
    }
    for f in [0.0f32, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0] {
        bin.extend(f.to_le_bytes());
    }
    for i in [0u32, 1, 2, 0, 2, 3] {
        bin.extend(i.to_le_bytes());
    }
    let b64 = |b: &[u8]| base64::engine::general_purpose::STANDARD.encode(b);
    let json = format!(
        "{{\"asset\":{{\"version\":\"2.0\"}},\"scenes\":[{{\"nodes\":[0]}}],\"nodes\":[{{\"mesh\":0}}],\
         \"meshes\":[{{\"primitives\":[{{\"attributes\":{{\"POSITION\":0,\"TEXCOORD_0\":1}},\"indices\":2,\"material\":0}}]}}],\
         \"materials\":[{{\"pbrMetallicRoughness\":{{\"baseColorTexture\":{{\"index\":0}}}}}}],\
         \"textures\":[{{\"source\":0}}],\"images\":[{{\"uri\":\"data:image/png;base64,{}\"}}],\
         \"buffers\":[{{\"byteLength\":{},\"uri\":\"data:application/octet-stream;base64,{}\"}}],\
         \"bufferViews\":[{{\"buffer\":0,\"byteOffset\":0,\"byteLength\":48}},{{\"buffer\":0,\"byteOffset\":48,\"byteLength\":32}},{{\"buffer\":0,\"byteOffset\":80,\"byteLength\":24}}],\
         \"accessors\":[{{\"bufferView\":0,\"componentType\":5126,\"count\":4,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}},\
         {{\"bufferView\":1,\"componentType\":5126,\"count\":4,\"type\":\"VEC2\"}},{{\"bufferView\":2,\"componentType\":5125,\"count\":6,\"type\":\"SCALAR\"}}]}}",
        b64(&png()),
        bin.len(),
        b64(&bin)
    );
    let path = dir().join("quad.gltf");
    std::fs::write(&path, json).unwrap();
    let (red, warnings) = colour_at(&path, 0.25);
    assert!((red - Color::X).length() < 1e-5, "{red} {warnings:?}");
    let (blue, _) = colour_at(&path, 0.75);
    assert!((blue - Color::new(0.0, 0.0, srgb_to_linear(128))).length() < 1e-5, "{blue}");
}
