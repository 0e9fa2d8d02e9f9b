//! The `isir` command: bad input gives one line and a non-zero exit, never a panic.

use std::process::Command;

fn isir(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(args)
        .current_dir(std::env::temp_dir())
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into(),
        String::from_utf8_lossy(&out.stderr).into(),
    )
}

fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("isir-cli-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

fn one_line_error(code: i32, err: &str, needle: &str) {
    assert_ne!(code, 0);
    assert!(!err.contains("panicked"), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "expected one line, got:\n{err}");
    assert!(err.contains(needle), "expected '{needle}' in: {err}");
}

#[test]
fn scenes_lists_the_four_tp4_scenes() {
    let (code, out, _) = isir(&["scenes"]);
    assert_eq!(code, 0);
    for n in ["tp4-sphere-flat", "tp4-sphere", "tp4-bunny", "tp4-conference"] {
        assert!(out.lines().any(|l| l.starts_with(n)), "{n} missing from:\n{out}");
    }
}

#[test]
fn render_writes_png_and_exr() {
    let png = tmp("s.png");
    let (code, out, err) = isir(&[
        "render",
        "tp4-sphere",
        "-o",
        png.to_str().unwrap(),
        "--width",
        "30",
        "--height",
        "20",
        "--spp",
        "1",
        "--threads",
        "1",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Mrays/s") && out.contains(png.to_str().unwrap()), "{out}");
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    let exr = tmp("s.exr");
    let (code, _, err) = isir(&[
        "render",
        "tp4-sphere-flat",
        "-o",
        exr.to_str().unwrap(),
        "--width",
        "30",
        "--height",
        "20",
        "--accel",
        "bvh-mid",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(&std::fs::read(&exr).unwrap()[..4], &[0x76, 0x2f, 0x31, 0x01]);
}

#[test]
fn unknown_scene_option_and_values_are_one_line_errors() {
    let (code, _, err) = isir(&["render", "tp5-nothing"]);
    one_line_error(code, &err, "unknown scene 'tp5-nothing'");
    let (code, _, err) = isir(&["render", "--frobnicate"]);
    one_line_error(code, &err, "--frobnicate");
    let (code, _, err) = isir(&["render", "--accel", "kd-tree"]);
    one_line_error(code, &err, "kd-tree");
    let (code, _, err) = isir(&["render", "tp4-sphere", "--spp", "0"]);
    one_line_error(code, &err, "--spp");
    let (code, _, err) = isir(&["render", "tp4-sphere", "--width", "10", "--height", "10", "-o", "x.bmp"]);
    one_line_error(code, &err, "unsupported image format");
}

#[test]
fn missing_and_malformed_meshes_are_one_line_errors() {
    let (code, _, err) = isir(&["render", "/nonexistent/model.obj"]);
    one_line_error(code, &err, "/nonexistent/model.obj");
    let bad = tmp("bad.obj");
    std::fs::write(&bad, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n").unwrap();
    let (code, _, err) = isir(&["render", bad.to_str().unwrap()]);
    one_line_error(code, &err, &format!("{}:5:", bad.display()));
    let gz = tmp("bad.obj.gz");
    std::fs::write(&gz, b"not gzip at all").unwrap();
    let (code, _, err) = isir(&["render", gz.to_str().unwrap()]);
    one_line_error(code, &err, "bad.obj.gz");
}

#[test]
fn renders_an_obj_file_with_warnings_for_degenerate_triangles() {
    let obj = tmp("quad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nf 1 1 2\n").unwrap();
    let out_png = tmp("quad.png");
    let (code, _, err) = isir(&[
        "render",
        obj.to_str().unwrap(),
        "-o",
        out_png.to_str().unwrap(),
        "--width",
        "16",
        "--height",
        "16",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("1 degenerate"), "{err}");
    assert!(out_png.exists());
}
