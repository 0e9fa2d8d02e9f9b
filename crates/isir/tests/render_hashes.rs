//! Every built-in scene renders the same pixels, bit for bit, as recorded here.
//!
//! The table guards refactors (moving code must not move a single bit of any image). The
//! renders use the scalar traversal, which every x86-64 CPU runs and which computes the
//! same floats on all of them, so the table does not depend on AVX2/AVX-512. A change
//! that is meant to change images (new sampling, a fixed bug) updates the table in the
//! same commit and says why; the test prints the new hashes to paste.

use isir::wide::SimdLevel;
use isir::{scenes, Accel, Geometry, Renderer};

/// FNV-1a over the bits of every pixel's linear RGB: stable across Rust versions, unlike
/// `DefaultHasher`.
fn fnv1a(words: impl Iterator<Item = u32>) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for w in words {
        for b in w.to_le_bytes() {
            h ^= b as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    h
}

fn render_hash(name: &str, accel: Accel) -> u64 {
    render_hash_with(name, accel, None)
}

/// [`render_hash`] with the scene's integrator, or `integrator` instead.
fn render_hash_with(name: &str, accel: Accel, integrator: Option<isir::Integrator>) -> u64 {
    let mut desc = scenes::builtin(name).unwrap();
    if let Some(i) = integrator {
        desc.integrator = i;
    }
    let mut scene = desc.build(accel).unwrap();
    for object in &mut scene.objects {
        if let Geometry::Mesh(mesh) = &mut object.geometry {
            mesh.set_simd_level(SimdLevel::Scalar);
        }
    }
    let renderer = Renderer::new(64, 48).spp(2);
    let (image, _) = renderer.render(&scene, &desc.camera.build(renderer.aspect()), &desc.integrator);
    fnv1a(image.pixels.iter().flat_map(|c| [c.x.to_bits(), c.y.to_bits(), c.z.to_bits()]))
}

/// (scene, acceleration structure, hash of its 64×48, 2 spp render).
const TABLE: &[(&str, Accel, u64)] = &[
    ("tp1-sphere", Accel::BvhSah, 0xa30859d76b1d13b0),
    ("tp1-sphere-cam1", Accel::BvhSah, 0xa8aee7ad0c37e088),
    ("tp1-sphere-cam2", Accel::BvhSah, 0x39caa0b66c68f394),
    ("tp1-sphere-cam3", Accel::BvhSah, 0x674f71b70bc0038c),
    ("tp1-sphere-cam4", Accel::BvhSah, 0x3550f86eab626425),
    ("tp2-plane-point", Accel::BvhSah, 0x5a54349fbb5398bd),
    ("tp3-quad-soft", Accel::BvhSah, 0x86354c4ace55d77b),
    ("tp4-sphere-flat", Accel::BvhSah, 0x19d2a3cf95412bd8),
    ("tp4-sphere", Accel::BvhSah, 0xd3771cbf8bdb4a29),
    ("tp4-bunny", Accel::BvhSah, 0x81ccbed896a6c2c6),
    ("tp4-bunny", Accel::BvhMid, 0x81ccbed896a6c2c6),
    ("tp4-conference", Accel::BvhSah, 0xc83cbcaa6f1140e6),
    ("tp5-oren-nayar", Accel::BvhSah, 0x0189e7bf41537e72),
    ("tp5-oren-nayar-s0.2", Accel::BvhSah, 0x31179e3be6ce14f2),
    ("tp5-oren-nayar-s0.4", Accel::BvhSah, 0x5a467280ba6b6bb5),
    ("tp5-oren-nayar-s0.6", Accel::BvhSah, 0x0189e7bf41537e72),
    ("tp5-phong", Accel::BvhSah, 0x7ece21e72c141850),
    ("tp5-phong-s8", Accel::BvhSah, 0x10d71eec6a857867),
    ("tp5-phong-s16", Accel::BvhSah, 0x64b2c1bba72f97f4),
    ("tp5-phong-s32", Accel::BvhSah, 0x2711ca674e37fc51),
    ("tp5-phong-s64", Accel::BvhSah, 0x7ece21e72c141850),
    ("tp5-blinn-phong", Accel::BvhSah, 0x55e549285a617b13),
    ("tp5-blinn-phong-s8", Accel::BvhSah, 0xf44c5e28efa070db),
    ("tp5-blinn-phong-s16", Accel::BvhSah, 0xee24492d6ef6c089),
    ("tp5-blinn-phong-s32", Accel::BvhSah, 0x8512aa41e93a726d),
    ("tp5-blinn-phong-s64", Accel::BvhSah, 0x55e549285a617b13),
    ("tp5-cook-torrance", Accel::BvhSah, 0xc6eacbee10f5e487),
    ("tp5-cook-torrance-m0", Accel::BvhSah, 0x45cbb07eccae6a7f),
    ("tp5-cook-torrance-m0.5", Accel::BvhSah, 0x99b3228fca3ad538),
    ("tp5-cook-torrance-m1", Accel::BvhSah, 0xc6eacbee10f5e487),
    ("tp6-matte", Accel::BvhSah, 0x620f52d761b3e915),
    ("tp6-mirror", Accel::BvhSah, 0x032dbfffe0214416),
    ("tp6-glass", Accel::BvhSah, 0xf2d81a80ef5f9348),
    ("tp6-matte-quad", Accel::BvhSah, 0x20a937f85dc30077),
    ("tp6-mirror-quad", Accel::BvhSah, 0x940ede275e461715),
    ("tp6-glass-quad", Accel::BvhSah, 0x62b916ae0fcc62a2),
    ("tp7-implicit", Accel::BvhSah, 0xd5522954441e1fe3),
];

#[test]
fn every_builtin_scene_renders_the_recorded_pixels() {
    let listed: Vec<&str> = scenes::list().into_iter().map(|(n, _)| n).collect();
    for n in &listed {
        assert!(TABLE.iter().any(|(t, _, _)| t == n), "built-in scene {n} has no recorded hash: add it to TABLE");
    }
    let got: Vec<(&str, Accel, u64)> = TABLE.iter().map(|&(n, a, _)| (n, a, render_hash(n, a))).collect();
    let table: String = got.iter().map(|(n, a, h)| format!("    (\"{n}\", Accel::{a:?}, {h:#018x}),\n")).collect();
    for (&(n, a, want), &(_, _, h)) in TABLE.iter().zip(&got) {
        assert_eq!(h, want, "{n} ({}) renders other pixels than recorded; if that is intended, the table is now:\n{table}", a.name());
    }
}

/// The path tracer, whose scenes' integrators are not it, on the scenes where a vertex's
/// quad-light samples (sixteen, four or more go as a batch) are valued in lanes: the
/// TP6 room's Oren–Nayar walls, TP3's colours, and the conference room's colours (its
/// eight samples). Recorded with the code before those lanes (the images the same bits).
const PATH_TABLE: &[(&str, u64)] = &[
    ("tp6-glass-quad", 0x6ccbb1bed95b9f97),
    ("tp6-matte-quad", 0xb2bea47af406c400),
    ("tp3-quad-soft", 0xbb4568fe4c9e4d92),
    ("tp4-conference", 0xe51a84877f3b1913),
];

#[test]
fn the_path_tracer_renders_the_recorded_pixels() {
    let path = |n| isir::Integrator::Path { light_samples: n, max_depth: 5 };
    let got: Vec<(&str, u64)> = PATH_TABLE
        .iter()
        .map(|&(n, _)| (n, render_hash_with(n, Accel::BvhSah, Some(path(if n == "tp4-conference" { 8 } else { 16 })))))
        .collect();
    let table: String = got.iter().map(|(n, h)| format!("    (\"{n}\", {h:#018x}),\n")).collect();
    for (&(n, want), &(_, h)) in PATH_TABLE.iter().zip(&got) {
        assert_eq!(h, want, "{n} (path) renders other pixels than recorded; if that is intended, the table is now:\n{table}");
    }
}
