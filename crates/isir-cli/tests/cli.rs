//! The `isir` command: bad input gives one line and a non-zero exit, never a panic.

use std::process::Command;

fn isir(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_isir")).args(args).current_dir(env!("CARGO_TARGET_TMPDIR")).output().unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

/// A file in cargo's scratch directory for integration tests (under `target/`).
fn tmp(name: &str) -> std::path::PathBuf {
    let d = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("isir-cli");
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
    let (code, out, err) =
        isir(&["render", "tp4-sphere", "-o", png.to_str().unwrap(), "--width", "30", "--height", "20", "--spp", "1", "--threads", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Mrays/s") && out.contains(png.to_str().unwrap()), "{out}");
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    let exr = tmp("s.exr");
    let (code, _, err) =
        isir(&["render", "tp4-sphere-flat", "-o", exr.to_str().unwrap(), "--width", "30", "--height", "20", "--accel", "bvh-mid"]);
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
    let (code, _, err) = isir(&["render", obj.to_str().unwrap(), "-o", out_png.to_str().unwrap(), "--width", "16", "--height", "16"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("1 degenerate"), "{err}");
    assert!(out_png.exists());
}

#[test]
fn sizes_are_checked_before_any_work() {
    let (code, _, err) = isir(&["render", "tp4-sphere", "--width", "100000", "--height", "100000"]);
    one_line_error(code, &err, "100000x100000");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", "r.bin", "--width", "0"]);
    one_line_error(code, &err, "at least 1");
    let (code, _, err) = isir(&["bench", "--height", "0", "--no-embree"]);
    one_line_error(code, &err, "at least 1");
}

#[test]
fn rays_and_trace_round_trip_and_reject_bad_files() {
    let rays = tmp("p.rays");
    let (code, out, err) =
        isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", rays.to_str().unwrap(), "--width", "20", "--height", "10"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("rays: 200"), "{out}");
    let hits = tmp("p.hits");
    let (code, out, err) = isir(&["trace", "uvsphere", rays.to_str().unwrap(), "--hits", hits.to_str().unwrap(), "--repeat", "1"]);
    assert_eq!(code, 0, "{err}");
    for key in
        ["triangles: 960", "rays: 200", "build_ms:", "mrays_per_s:", "sah_cost:", "nodes:", "bytes_per_triangle:", "avg_node_visits:"]
    {
        assert!(out.contains(key), "missing '{key}' in:\n{out}");
    }
    let n_hits: usize = out.lines().find_map(|l| l.strip_prefix("hits: ")).unwrap().parse().unwrap();
    assert!(n_hits > 0 && n_hits < 200, "{out}");
    assert_eq!(std::fs::metadata(&hits).unwrap().len(), 24 + 16 * 200);
    // The same with packets and with the watertight test: the same number of hits.
    let (_, out_p, _) = isir(&["trace", "uvsphere", rays.to_str().unwrap(), "--packets", "--repeat", "1"]);
    assert!(out_p.contains(&format!("hits: {n_hits}\n")), "{out_p}");
    // A truncated ray file and a file that is not one.
    let bytes = std::fs::read(&rays).unwrap();
    let cut = tmp("cut.rays");
    std::fs::write(&cut, &bytes[..bytes.len() - 7]).unwrap();
    let (code, _, err) = isir(&["trace", "uvsphere", cut.to_str().unwrap()]);
    one_line_error(code, &err, "cut.rays");
    let (code, _, err) = isir(&["trace", "uvsphere", hits.to_str().unwrap()]);
    one_line_error(code, &err, "magic");
    let (code, _, err) = isir(&["trace", "uvsphere", rays.to_str().unwrap(), "--packets", "--occluded"]);
    one_line_error(code, &err, "--packets");
}

#[test]
fn bench_rounds_print_medians_and_reject_zero() {
    let (code, out, err) = isir(&[
        "bench",
        "tp4-sphere",
        "--width",
        "24",
        "--height",
        "16",
        "--repeat",
        "1",
        "--rounds",
        "3",
        "--no-embree",
        "--threads",
        "1",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("medians of 3 rounds") && out.contains("embree-bench not found"), "{out}");
    for row in ["build (Mtris/s)", "build (ms)", "primary closest", "diffuse closest", "shadow occluded", "primary packets/stream"] {
        let line = out.lines().find(|l| l.starts_with(row)).unwrap_or_else(|| panic!("no '{row}' row in:\n{out}"));
        let figure: f64 = line[row.len()..].split_whitespace().find_map(|w| w.parse().ok()).unwrap_or(f64::NAN);
        assert!(figure.is_finite() && figure > 0.0, "'{row}' has no figure: {line}");
    }
    let (code, _, err) = isir(&["bench", "--rounds", "0", "--no-embree"]);
    one_line_error(code, &err, "--rounds");
}
