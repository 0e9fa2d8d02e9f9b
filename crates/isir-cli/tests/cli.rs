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
    for n in ["tp4-sphere-flat", "tp4-sphere", "tp4-bunny", "tp4-conference", "tp7-implicit"] {
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
fn meshes_too_large_for_single_precision_are_refused_and_large_ones_render() {
    // Scaled by 1e20, products of coordinates overflow f32: refused with the reason.
    let huge = tmp("huge.obj");
    std::fs::write(&huge, "v 0 0 0\nv 1e20 0 0\nv 0 1e20 0\nf 1 2 3\n").unwrap();
    let (code, _, err) = isir(&["render", huge.to_str().unwrap(), "-o", tmp("huge.png").to_str().unwrap()]);
    one_line_error(code, &err, "huge.obj");
    assert!(err.contains("scale it down"), "{err}");
    assert!(!tmp("huge.png").exists(), "nothing is written for a refused scene");
    // Scaled by 1e9 (inside the range): framed and rendered, not a background-only image.
    let big = tmp("big.obj");
    std::fs::write(&big, "v 0 0 0\nv 1e9 0 0\nv 0 1e9 0\nf 1 2 3\n").unwrap();
    let (code, _, err) =
        isir(&["render", big.to_str().unwrap(), "-o", tmp("big.png").to_str().unwrap(), "--width", "32", "--height", "32"]);
    assert_eq!(code, 0, "{err}");
    let img = image::open(tmp("big.png")).unwrap().to_rgb8();
    let background = *img.get_pixel(0, 0);
    let lit = img.pixels().filter(|p| **p != background && p.0.iter().any(|&c| c > 0)).count();
    assert!(lit > 32, "camera rays must reach the triangle: {lit} lit pixels");
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
    // A small mesh's rays one at a time (auto), or sixteen at a time when asked: the same
    // hit file.
    assert!(out.contains("rays_in_flight: 1\n"), "{out}");
    let hits16 = tmp("p16.hits");
    let (code, out_i, err) =
        isir(&["trace", "uvsphere", rays.to_str().unwrap(), "--interleave", "always", "--hits", hits16.to_str().unwrap(), "--repeat", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(out_i.contains("rays_in_flight: 16\n") && out_i.contains(&format!("hits: {n_hits}\n")), "{out_i}");
    assert_eq!(std::fs::read(&hits16).unwrap(), std::fs::read(&hits).unwrap());
    // A truncated ray file and a file that is not one.
    let bytes = std::fs::read(&rays).unwrap();
    let cut = tmp("cut.rays");
    std::fs::write(&cut, &bytes[..bytes.len() - 7]).unwrap();
    let (code, _, err) = isir(&["trace", "uvsphere", cut.to_str().unwrap()]);
    one_line_error(code, &err, "cut.rays");
    let (code, _, err) = isir(&["trace", "uvsphere", hits.to_str().unwrap()]);
    one_line_error(code, &err, "a hit file, not a ray file");
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
    assert!(out.contains("medians of 3 rounds") && out.contains("Embree not run (--no-embree)"), "{out}");
    for row in ["build (Mtris/s)", "build (ms)", "primary closest", "diffuse closest", "shadow occluded", "primary packets/stream"] {
        let line = out.lines().find(|l| l.starts_with(row)).unwrap_or_else(|| panic!("no '{row}' row in:\n{out}"));
        let figure: f64 = line[row.len()..].split_whitespace().find_map(|w| w.parse().ok()).unwrap_or(f64::NAN);
        assert!(figure.is_finite() && figure > 0.0, "'{row}' has no figure: {line}");
    }
    let (code, _, err) = isir(&["bench", "--rounds", "0", "--no-embree"]);
    one_line_error(code, &err, "--rounds");
}

/// Run `isir` and wait at most `secs` seconds: a run that takes longer is killed and fails
/// the test (a check that should come before the work did not).
fn isir_within(secs: u64, args: &[&str]) -> (i32, String, String) {
    use std::io::Read;
    use std::process::Stdio;
    let mut child = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(args)
        .current_dir(env!("CARGO_TARGET_TMPDIR"))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let (mut out, mut err) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let out = std::thread::spawn(move || {
        let mut s = String::new();
        out.read_to_string(&mut s).ok();
        s
    });
    let err = std::thread::spawn(move || {
        let mut s = String::new();
        err.read_to_string(&mut s).ok();
        s
    });
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(secs);
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if std::time::Instant::now() > deadline {
            child.kill().ok();
            child.wait().ok();
            panic!("isir {args:?} still running after {secs} s");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    (status.code().unwrap_or(-1), out.join().unwrap(), err.join().unwrap())
}

/// Files in `dir` whose names start with `.{name}.tmp`: temporary files left behind.
fn temporaries(dir: &std::path::Path, name: &str) -> Vec<String> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with(&format!(".{name}.tmp")))
        .collect()
}

/// A write that fails half-way (a file-size limit of one block: isir ignores SIGXFSZ, so
/// the write returns EFBIG) is an error naming the file, and the file that was there is
/// intact (found by an audit: without the shell's `trap '' XFSZ` the signal killed isir,
/// status 153, no message, the temporary left behind).
#[cfg(unix)]
#[test]
fn a_failed_write_is_an_error_and_keeps_the_old_file() {
    // Empty: a temporary file another run left is not taken for this one's.
    let dir = fresh_dir("efbig");
    let mesh = tmp("efbig-mesh.rays");
    let (code, _, err) =
        isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", mesh.to_str().unwrap(), "--width", "40", "--height", "30"]);
    assert_eq!(code, 0, "{err}");
    let cases: [(&str, Vec<&str>); 5] = [
        // Smaller than the writer's buffer: only the last flush fails.
        ("small.png", vec!["render", "tp4-sphere", "--width", "40", "--height", "30", "-o"]),
        ("big.png", vec!["render", "tp4-sphere", "--width", "200", "--height", "150", "--spp", "4", "-o"]),
        ("big.exr", vec!["render", "tp4-sphere", "--width", "200", "--height", "150", "--spp", "1", "-o"]),
        ("big.rays", vec!["rays", "tp4-sphere", "--kind", "primary", "--width", "200", "--height", "150", "-o"]),
        ("big.hits", vec!["trace", "uvsphere", mesh.to_str().unwrap(), "--repeat", "1", "--hits"]),
    ];
    for (name, args) in cases {
        let target = dir.join(name);
        std::fs::write(&target, b"the good old content").unwrap();
        let script = r#"ulimit -f 1; exec "$@""#;
        let out = Command::new("sh").args(["-c", script, "sh", env!("CARGO_BIN_EXE_isir")]).args(&args).arg(&target).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{name}: {:?} {err}", out.status);
        one_line_error(out.status.code().unwrap_or(-1), &err, target.to_str().unwrap());
        assert!(err.contains("File too large") || err.contains("os error 27"), "{name}: {err}");
        assert!(!String::from_utf8_lossy(&out.stdout).contains("wrote"), "{name}: reported as written");
        assert_eq!(std::fs::read(&target).unwrap(), b"the good old content", "{name}: the old file was lost");
        assert_eq!(temporaries(&dir, name), Vec::<String>::new(), "{name}: temporary files left");
    }
}

/// An output path that cannot be written is reported before any work: a render that would
/// take minutes fails at once, naming the path.
#[test]
fn unwritable_outputs_are_reported_before_any_work() {
    let not_a_dir = tmp("plain-file");
    std::fs::write(&not_a_dir, b"x").unwrap();
    for out in ["/nonexistent-isir-dir/x.png".to_string(), format!("{}/x.exr", not_a_dir.display())] {
        let (code, stdout, err) =
            isir_within(10, &["render", "tp4-conference", "--width", "16384", "--height", "16384", "--spp", "1000", "-o", &out]);
        one_line_error(code, &err, &out);
        assert!(stdout.is_empty(), "{stdout}");
    }
    let (code, _, err) = isir_within(
        10,
        &["rays", "tp4-conference", "--kind", "shadow", "--width", "16384", "--height", "16384", "-o", "/nonexistent-isir-dir/r.rays"],
    );
    one_line_error(code, &err, "/nonexistent-isir-dir/r.rays");
    // The hit file is checked before the mesh and the ray file are read.
    let (code, _, err) = isir_within(10, &["trace", "/nonexistent.obj", "/nonexistent.rays", "--hits", "/nonexistent-isir-dir/h.hits"]);
    one_line_error(code, &err, "/nonexistent-isir-dir/h.hits");
    // A directory is not an image.
    let dir = tmp("a-dir.png");
    std::fs::create_dir_all(&dir).unwrap();
    let (code, _, err) = isir_within(10, &["render", "tp4-conference", "--spp", "1000", "-o", dir.to_str().unwrap()]);
    one_line_error(code, &err, "is a directory");
}

#[test]
fn thread_counts_are_capped_with_a_clear_error() {
    let (code, _, err) = isir_within(10, &["render", "tp4-sphere", "--threads", "1000000", "--width", "8", "--height", "8"]);
    one_line_error(code, &err, "--threads");
    assert!(err.contains("1024"), "{err}");
    let (code, _, err) = isir_within(10, &["trace", "uvsphere", "x.rays", "--threads", "5000"]);
    one_line_error(code, &err, "1024");
    let (code, help, err) = isir(&["render", "--help"]);
    assert_eq!(code, 0, "{err}");
    assert!(help.contains("1024"), "{help}");
}

#[test]
fn os_errors_are_printed_once_with_the_path() {
    let (code, _, err) = isir(&["trace", "uvsphere", "/nonexistent/r.rays"]);
    one_line_error(code, &err, "/nonexistent/r.rays");
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
    let (code, _, err) = isir(&["render", "/nonexistent/model.obj"]);
    one_line_error(code, &err, "/nonexistent/model.obj");
    assert_eq!(err.matches("os error 2").count(), 1, "{err}");
}

#[test]
fn argument_errors_name_the_arguments_and_values() {
    let (code, _, err) = isir(&["trace"]);
    one_line_error(code, &err, "<MESH>");
    assert!(err.contains("<RAYS>"), "{err}");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "-o", "x.rays"]);
    one_line_error(code, &err, "--kind");
    let (code, _, err) = isir(&["render", "--integrator", "foo"]);
    one_line_error(code, &err, "foo");
    assert!(err.contains("ray-cast") && err.contains("direct"), "{err}");
    let (code, _, err) = isir(&["render", "--accel", "foo"]);
    one_line_error(code, &err, "foo");
    assert!(err.contains("bvh-sah") && err.contains("bvh-mid"), "{err}");
    assert!(!err.contains("Usage"), "{err}");
}

#[test]
fn integrator_and_max_depth_errors_name_the_option() {
    let (code, _, err) = isir(&["render", "tp4-sphere", "--integrator", "bogus"]);
    one_line_error(code, &err, "bogus");
    assert!(err.contains("--integrator") && err.contains("whitted") && err.contains("path") && err.contains("ray-cast"), "{err}");
    for bad in ["0", "100000"] {
        let (code, _, err) = isir(&["render", "tp4-sphere", "--width", "8", "--height", "8", "--max-depth", bad, "-o", "never.png"]);
        one_line_error(code, &err, "--max-depth");
    }
    let (code, _, err) = isir(&["render", "tp4-sphere", "--max-depth", "two"]);
    one_line_error(code, &err, "--max-depth");
    // Given to an integrator without bounces: said, not silently ignored.
    let png = tmp("depth.png");
    let (code, _, err) = isir(&["render", "tp4-sphere", "--width", "8", "--height", "8", "--max-depth", "3", "-o", png.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("isir: warning: --max-depth has no effect on the direct integrator"), "{err}");
}

#[test]
fn the_path_tracer_renders_the_bunny_and_warns_once_about_color_materials() {
    let png = tmp("bunny-path.png");
    let (code, out, err) = isir(&[
        "render",
        "tp4-bunny",
        "--integrator",
        "path",
        "--max-depth",
        "3",
        "--width",
        "32",
        "--height",
        "24",
        "--spp",
        "1",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(err.matches("isir: warning:").count(), 1, "{err}");
    assert!(err.contains("ColorMaterial") && err.contains("Lambert"), "{err}");
    assert!(out.contains(", path,") && out.contains("M secondary") && out.contains("all samples finite"), "{out}");
    assert_eq!(&std::fs::read(&png).unwrap()[1..4], b"PNG");
    // Whitted: no warning, secondary rays only where mirrors and glass are (none here).
    let (code, out, err) = isir(&[
        "render",
        "tp4-bunny",
        "--integrator",
        "whitted",
        "--width",
        "32",
        "--height",
        "24",
        "--spp",
        "1",
        "-o",
        png.to_str().unwrap(),
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("warning"), "{err}");
    assert!(out.contains(", whitted,") && out.contains("0.00 M secondary"), "{out}");
}

#[test]
fn incompatible_flags_are_rejected_before_loading() {
    // The mesh and ray files do not exist: the flags are what must be reported.
    let (code, _, err) = isir(&["trace", "/nonexistent.obj", "/nonexistent.rays", "--packets", "--occluded"]);
    one_line_error(code, &err, "--packets");
    assert!(!err.contains("nonexistent"), "{err}");
    let (code, _, err) = isir(&["trace", "/nonexistent.obj", "/nonexistent.rays", "--simd", "scalar", "--accel", "bvh-mid"]);
    one_line_error(code, &err, "--simd");
    assert!(!err.contains("nonexistent"), "{err}");
    let (code, _, err) = isir(&["trace", "/nonexistent.obj", "/nonexistent.rays", "--repeat", "0"]);
    one_line_error(code, &err, "--repeat");
    let (code, _, err) = isir(&["trace", "/nonexistent.obj", "/nonexistent.rays", "--interleave", "always", "--accel", "bvh-mid"]);
    one_line_error(code, &err, "--interleave");
    assert!(!err.contains("nonexistent"), "{err}");
    let (code, _, err) = isir(&["trace", "/nonexistent.obj", "/nonexistent.rays", "--interleave", "always", "--packets"]);
    one_line_error(code, &err, "--packets");
    let (code, _, err) = isir(&["trace", "/nonexistent.obj", "/nonexistent.rays", "--interleave", "sometimes"]);
    one_line_error(code, &err, "sometimes");
    let (code, _, err) = isir(&["bench", "--repeat", "0", "--no-embree"]);
    one_line_error(code, &err, "--repeat");
}

#[test]
fn one_thread_is_one_thread() {
    let png = tmp("one-thread.png");
    let (code, out, err) = isir(&["render", "tp4-sphere", "-o", png.to_str().unwrap(), "--width", "8", "--height", "8", "--threads", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains(" 1 thread:") && !out.contains("threads"), "{out}");
    let (code, out, err) =
        isir(&["bench", "tp4-sphere", "--width", "8", "--height", "8", "--repeat", "1", "--no-embree", "--threads", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains(" 1 thread,") && !out.contains("1 threads"), "{out}");
    // A small mesh's rays one at a time, unless asked otherwise: the same hits either way.
    assert!(out.contains("(single rays one at a time)"), "{out}");
    let (code, out16, err) = isir(&[
        "bench",
        "tp4-sphere",
        "--width",
        "8",
        "--height",
        "8",
        "--repeat",
        "1",
        "--no-embree",
        "--threads",
        "1",
        "--interleave",
        "always",
    ]);
    assert_eq!(code, 0, "{err}");
    assert!(out16.contains("(single rays 16 at a time per thread)"), "{out16}");
}

#[test]
fn ray_files_whose_size_disagrees_with_the_header_are_rejected() {
    let rays = tmp("size.rays");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", rays.to_str().unwrap(), "--width", "4", "--height", "2"]);
    assert_eq!(code, 0, "{err}");
    let good = std::fs::read(&rays).unwrap();
    assert_eq!(good.len(), 24 + 8 * 32);
    // Trailing bytes after the 8 records.
    let trailing = tmp("trailing.rays");
    std::fs::write(&trailing, [&good[..], &[0u8; 5]].concat()).unwrap();
    let (code, _, err) = isir(&["trace", "uvsphere", trailing.to_str().unwrap(), "--repeat", "1"]);
    one_line_error(code, &err, "trailing.rays");
    assert!(err.contains('8') && err.contains("261"), "{err}");
    // A header claiming 2^40 records: rejected at once, nothing allocated for them.
    let mut huge = good.clone();
    huge[16..24].copy_from_slice(&(1u64 << 40).to_le_bytes());
    let claims = tmp("claims.rays");
    std::fs::write(&claims, huge).unwrap();
    let (code, _, err) = isir_within(10, &["trace", "uvsphere", claims.to_str().unwrap(), "--repeat", "1"]);
    one_line_error(code, &err, "claims.rays");
    assert!(err.contains(&(1u64 << 40).to_string()) && err.contains("256"), "{err}");
}

// ---- `isir bench` with Embree 3 and Embree 4 (tools/), by stand-ins: CI has no Embree ----

/// A stand-in for tools/embree3-bench or tools/embree4-bench: isir's own `trace` on the files
/// `isir bench` passes, so that its hits agree exactly. It accepts exactly the command line
/// the real tools take from bench (anything else exits 2) and logs it to `<script>.log`.
#[cfg(unix)]
fn fake_embree(path: &std::path::Path) {
    use std::os::unix::fs::PermissionsExt;
    let script = format!(
        r#"#!/bin/sh
echo "$@" >> "$0.log"
mesh=$1; rays=$2; shift 2
hits=""; occluded=""; repeat=""; threads=""
while [ $# -gt 0 ]; do
  case $1 in
    --hits) hits=$2; shift 2;;
    --repeat) repeat=$2; shift 2;;
    --threads) threads=$2; shift 2;;
    --occluded) occluded=--occluded; shift;;
    --quality) [ "$2" = medium ] || exit 2; shift 2;;
    --mode) [ "$2" = single ] || [ "$2" = stream ] || exit 2; shift 2;;
    *) echo "unexpected argument $1" >&2; exit 2;;
  esac
done
exec '{}' trace "$mesh" "$rays" --hits "$hits" --repeat "$repeat" --threads "$threads" $occluded 2>/dev/null
"#,
        env!("CARGO_BIN_EXE_isir")
    );
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, script).unwrap();
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755)).unwrap();
    std::fs::remove_file(path.with_extension("log")).ok();
}

/// An empty folder for a test's cache (target/tmp outlives test runs: no leftovers).
#[cfg(unix)]
fn fresh_dir(name: &str) -> std::path::PathBuf {
    let d = tmp(name);
    std::fs::remove_dir_all(&d).ok();
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `isir bench` on a small scene with `cache` as the cache folder and a PATH without any
/// Embree tool, so that only the stand-ins given are found.
#[cfg(unix)]
fn bench_with_cache(cache: &std::path::Path, extra: &[&str]) -> (i32, String, String) {
    let args = ["bench", "tp4-sphere", "--width", "24", "--height", "16", "--repeat", "1", "--threads", "1"];
    let out = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(args.iter().chain(extra))
        .current_dir(env!("CARGO_TARGET_TMPDIR"))
        .env("XDG_CACHE_HOME", cache)
        .env("PATH", "/usr/bin:/bin")
        .output()
        .unwrap();
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stdout).into(), String::from_utf8_lossy(&out.stderr).into())
}

/// The tables of a bench output: each from its `figure` header to the next blank line.
#[cfg(unix)]
fn bench_tables(out: &str) -> Vec<Vec<&str>> {
    let lines: Vec<&str> = out.lines().collect();
    let starts = lines.iter().enumerate().filter(|(_, l)| l.starts_with("figure")).map(|(i, _)| i);
    starts.map(|i| lines[i..].iter().take_while(|l| !l.is_empty() && !l.starts_with("sah_cost")).copied().collect()).collect()
}

#[cfg(unix)]
#[test]
fn bench_compares_with_embree_3_and_embree_4_found_in_the_cache() {
    let cache = fresh_dir("bench-cache-both");
    // Embree 3 under the old name `embree-bench` (installs from before tools/ still work).
    let e3 = cache.join("isir").join("embree-bench");
    let e4 = cache.join("isir").join("embree4-bench");
    fake_embree(&e3);
    fake_embree(&e4);
    let (code, out, err) = bench_with_cache(&cache, &[]);
    assert_eq!(code, 0, "{err}");
    let header = out.lines().next().unwrap();
    assert!(header.contains(&format!("embree-bench {} (quality medium)", e3.display())), "{header}");
    assert!(header.contains(&format!("embree4-bench {} (quality medium)", e4.display())), "{header}");
    let tables = bench_tables(&out);
    assert_eq!(tables.len(), 2, "{out}");
    for (table, label) in tables.iter().zip(["embree", "embree4"]) {
        let head: Vec<&str> = table[0].split_whitespace().collect();
        assert_eq!(head, ["figure", "isir", label, &format!("isir/{label}"), "hits", "agree"], "{out}");
        for row in ["build (Mtris/s)", "primary closest", "diffuse closest", "shadow occluded", "random closest", "primary packets/stream"]
        {
            let line = table.iter().find(|l| l.starts_with(row)).unwrap_or_else(|| panic!("no '{row}' row in:\n{out}"));
            // isir, the engine and the ratio are all figures (the engine's parsed from its output).
            let figures: Vec<f64> = line[row.len()..].split_whitespace().filter_map(|w| w.parse().ok()).collect();
            assert!(figures.len() == 3 && figures.iter().all(|f| f.is_finite() && *f > 0.0), "'{row}' in:\n{out}");
            if row != "build (Mtris/s)" {
                assert!(line.ends_with("100.0000%"), "the stand-in is isir itself, its hits must all agree: {line}");
            }
        }
    }
    // The memory row: isir's bytes per triangle; the stand-ins report no Embree memory.
    for table in &tables {
        let line = table.iter().find(|l| l.starts_with("memory (B/tri)")).unwrap_or_else(|| panic!("no memory row in:\n{out}"));
        let words: Vec<&str> = line["memory (B/tri)".len()..].split_whitespace().collect();
        assert!(words[0].parse::<f64>().is_ok_and(|b| b > 10.0 && b < 1000.0) && words[1] == "-", "{line}");
    }
    // Each tool got exactly what the real ones take: four single-ray sets (shadow rays
    // occluded), then the primary rays in stream mode, with the hit files named per engine.
    for (tool, tag) in [(&e3, "embree"), (&e4, "embree4")] {
        let log = std::fs::read_to_string(tool.with_extension("log")).unwrap();
        let calls: Vec<&str> = log.lines().collect();
        assert_eq!(calls.len(), 5, "{log}");
        for (call, (set, tail)) in calls.iter().zip([
            ("primary", format!("primary.{tag}.hits --quality medium --repeat 1 --threads 1 --mode single")),
            ("diffuse", format!("diffuse.{tag}.hits --quality medium --repeat 1 --threads 1 --mode single")),
            ("shadow", format!("shadow.{tag}.hits --quality medium --repeat 1 --threads 1 --mode single --occluded")),
            ("random", format!("random.{tag}.hits --quality medium --repeat 1 --threads 1 --mode single")),
            ("primary", format!("primary.{tag}-stream.hits --quality medium --repeat 1 --threads 1 --mode stream")),
        ]) {
            let words: Vec<&str> = call.split_whitespace().collect();
            assert!(words[0].ends_with("uvsphere.obj") && words[1].ends_with(&format!("{set}.rays")) && words[2] == "--hits", "{call}");
            assert!(call.ends_with(&tail), "expected '... {tail}', got: {call}");
        }
    }
}

#[cfg(unix)]
#[test]
fn bench_with_embree_3_alone_prints_its_one_table_and_no_embree_runs_none() {
    let cache = fresh_dir("bench-cache-none");
    let e3 = tmp("bench-explicit/embree3-bench");
    fake_embree(&e3);
    let (code, out, err) = bench_with_cache(&cache, &["--embree", e3.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(!out.contains("embree4"), "{out}");
    let tables = bench_tables(&out);
    assert_eq!(tables.len(), 1, "{out}");
    assert_eq!(tables[0][0], format!("{:<28} {:>12} {:>12} {:>20} {:>14}", "figure", "isir", "embree", "isir/embree", "hits agree"));
    assert!(tables[0].iter().filter(|l| l.ends_with("100.0000%")).count() == 5, "{out}");
    // --no-embree: a tool in the cache is not even started.
    let e4 = cache.join("isir").join("embree4-bench");
    fake_embree(&e4);
    let (code, out, err) = bench_with_cache(&cache, &["--no-embree"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("Embree not run (--no-embree)") && !out.contains("embree4"), "{out}");
    assert!(!e4.with_extension("log").exists(), "embree4-bench ran despite --no-embree");
}

#[cfg(unix)]
#[test]
fn bench_names_a_missing_or_failing_embree_tool() {
    let cache = fresh_dir("bench-cache-failing");
    // A missing tool is named before any work, by its option.
    let (code, _, err) = bench_with_cache(&cache, &["--embree4", "/nonexistent/embree4-bench"]);
    one_line_error(code, &err, "--embree4 /nonexistent/embree4-bench: no such file");
    let (code, _, err) = bench_with_cache(&cache, &["--embree", "/nonexistent/embree-bench"]);
    one_line_error(code, &err, "--embree /nonexistent/embree-bench: no such file");
    // A tool that fails: its message, and its name.
    let broken = tmp("bench-broken/embree4-bench");
    fake_embree(&broken);
    std::fs::write(&broken, "#!/bin/sh\necho 'cannot open mesh' >&2\necho 'usage: embree4-bench MESH RAYS' >&2\nexit 1\n").unwrap();
    let (code, _, err) = bench_with_cache(&cache, &["--embree4", broken.to_str().unwrap()]);
    // Its first line (the problem), not the usage page after it.
    one_line_error(code, &err, "cannot open mesh");
    assert!(err.contains(broken.to_str().unwrap()) && !err.contains("usage"), "{err}");
    // A folder given as the tool.
    let (code, _, err) = bench_with_cache(&cache, &["--embree", cache.to_str().unwrap()]);
    one_line_error(code, &err, "not a file");
    // A tool that answers another number of rays than it was given: an error, not an
    // agreement of 0%.
    let short = tmp("bench-short/embree4-bench");
    fake_embree(&short);
    let hits_of_one = r#"printf 'ISIRHITS\001\000\000\000\000\000\000\000\001\000\000\000\000\000\000\000' > "$hits""#;
    let script = std::fs::read_to_string(&short).unwrap();
    let (head, _) = script.rsplit_once("exec ").unwrap();
    std::fs::write(&short, format!("{head}{hits_of_one}\nhead -c 16 /dev/zero >> \"$hits\"\necho build_ms: 1\necho mrays_per_s: 1\n"))
        .unwrap();
    let (code, _, err) = bench_with_cache(&cache, &["--embree4", short.to_str().unwrap()]);
    one_line_error(code, &err, "the Embree tool wrote 1 hit records for");
}

/// `isir bench` with `TMPDIR` set to a fresh folder, stdout piped and closed at once when
/// `close_stdout` (a reader that stops early): its status, stderr, and whether the folder
/// is empty afterwards.
#[cfg(unix)]
fn bench_in_tmpdir(name: &str, extra: &[&str], close_stdout: bool) -> (i32, String, bool) {
    use std::io::Read;
    use std::process::Stdio;
    let tmpdir = fresh_dir(name);
    let cache = fresh_dir(&format!("{name}-cache"));
    let args = ["bench", "tp4-sphere", "--width", "24", "--height", "16", "--repeat", "1", "--threads", "1"];
    let mut child = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(args.iter().chain(extra))
        .current_dir(env!("CARGO_TARGET_TMPDIR"))
        .env("TMPDIR", &tmpdir)
        .env("XDG_CACHE_HOME", &cache)
        .env("PATH", "/usr/bin:/bin")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    if close_stdout {
        drop(stdout);
    } else {
        std::io::copy(&mut { stdout }, &mut std::io::sink()).unwrap();
    }
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    let status = child.wait().unwrap();
    let empty = std::fs::read_dir(&tmpdir).unwrap().next().is_none();
    (status.code().unwrap_or(-1), err, empty)
}

#[cfg(unix)]
#[test]
fn bench_leaves_no_temporary_files_and_a_closed_pipe_is_no_panic() {
    // A reader that has gone: no panic, status 0, the temporary folder removed.
    let (code, err, empty) = bench_in_tmpdir("bench-tmp-pipe", &["--no-embree"], true);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(empty, "the temporary folder was left behind");
    // A failing Embree tool: an error, and the folder removed too.
    let broken = tmp("bench-tmp-broken/embree3-bench");
    fake_embree(&broken);
    std::fs::write(&broken, "#!/bin/sh\necho 'no memory' >&2\nexit 1\n").unwrap();
    let (code, err, empty) = bench_in_tmpdir("bench-tmp-fail", &["--embree", broken.to_str().unwrap()], false);
    one_line_error(code, &err, "no memory");
    assert!(empty, "the temporary folder was left behind after an error");
    // `isir scenes` into a pipe read no further.
    let mut child = Command::new(env!("CARGO_BIN_EXE_isir"))
        .arg("scenes")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    assert_eq!(out.status.code(), Some(0));
    assert!(!String::from_utf8_lossy(&out.stderr).contains("panicked"));
}

#[test]
fn bench_checks_its_options_before_any_work() {
    // Each refused at once, in one line (not after isir's measurements, by the tool).
    let (code, _, err) = isir_within(10, &["bench", "--embree-quality", "best", "--no-embree"]);
    one_line_error(code, &err, "--embree-quality");
    assert!(err.contains("low, medium, high"), "{err}");
    let (code, _, err) = isir_within(10, &["bench", "--repeat", "2000", "--no-embree"]);
    one_line_error(code, &err, "--repeat");
    let (code, _, err) = isir_within(10, &["bench", "--width", "8000", "--height", "8000", "--no-embree"]);
    one_line_error(code, &err, "4096x4096");
    let file = tmp("bench-keep-file");
    std::fs::write(&file, "x").unwrap();
    let (code, _, err) = isir_within(30, &["bench", "tp4-sphere", "--keep", file.to_str().unwrap(), "--no-embree"]);
    one_line_error(code, &err, "not a directory");
}

#[cfg(unix)]
#[test]
fn bench_traces_a_scene_files_placed_mesh_where_it_stands() {
    // A mesh with a transform (an instance in the scene): benchmarked in world space, the
    // same triangles for isir and for the Embree stand-in (which traces the OBJ written).
    let scene = tmp("bench-placed.toml");
    let data = concat!(env!("CARGO_MANIFEST_DIR"), "/../isir/data/uvsphere.obj");
    std::fs::write(
        &scene,
        format!(
            "[camera]\nposition = [0, 0, -6]\nlook_at = [0, 0, 0]\n\n[[objects]]\ntype = \"mesh\"\nfile = \"{data}\"\n\
             transform = {{ translate = [0.5, 0, 0], rotate = [0, 30, 0], scale = 2 }}\n\n[[lights]]\ntype = \"point\"\n\
             position = [0, 3, -5]\ncolor = [1, 1, 1]\npower = 50\n"
        ),
    )
    .unwrap();
    let cache = fresh_dir("bench-cache-placed");
    let e3 = cache.join("isir").join("embree3-bench");
    fake_embree(&e3);
    let keep = fresh_dir("bench-keep-placed");
    let out = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(["bench", scene.to_str().unwrap(), "--width", "24", "--height", "16", "--repeat", "1", "--threads", "1"])
        .args(["--keep", keep.to_str().unwrap()])
        .current_dir(env!("CARGO_TARGET_TMPDIR"))
        .env("XDG_CACHE_HOME", &cache)
        .env("PATH", "/usr/bin:/bin")
        .output()
        .unwrap();
    let (stdout, err) = (String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert_eq!(out.status.code(), Some(0), "{err}");
    let tables = bench_tables(&stdout);
    assert_eq!(tables.len(), 1, "{stdout}");
    assert!(tables[0].iter().filter(|l| l.ends_with("100.0000%")).count() == 5, "{stdout}");
    // The primary rays hit the sphere as placed: radius 2 at 6 units fills about 20% of the
    // frame (the file's unit sphere would fill 5%).
    let primary = stdout.lines().find(|l| l.starts_with("primary:")).unwrap();
    let hits: usize = primary.split(", ").nth(1).unwrap().split(' ').next().unwrap().parse().unwrap();
    assert!(hits > 24 * 16 / 8, "{primary}");
    // The OBJ written holds the moved vertices: none of the file's own (a unit sphere).
    let obj = std::fs::read_to_string(keep.join("isir-bench-mesh.obj")).unwrap();
    let radius = obj
        .lines()
        .filter_map(|l| l.strip_prefix("v "))
        .map(|l| l.split_whitespace().map(|x| x.parse::<f32>().unwrap()).collect::<Vec<_>>())
        .map(|v| ((v[0] - 0.5).powi(2) + v[1].powi(2) + v[2].powi(2)).sqrt())
        .fold(0f32, f32::max);
    assert!((radius - 2.0).abs() < 0.01, "the sphere's radius as written: {radius}");
}

#[test]
fn aovs_are_written_beside_the_image_and_cost_reports_the_lesson() {
    let out = tmp("aov.png");
    let (code, stdout, err) = isir(&[
        "render",
        "tp4-sphere",
        "-o",
        out.to_str().unwrap(),
        "--width",
        "40",
        "--height",
        "30",
        "--aov",
        "cost,normal",
        "--aov",
        "depth",
    ]);
    assert_eq!(code, 0, "{err}");
    for (aov, h) in [("cost", 30 + 16), ("normal", 30), ("depth", 30)] {
        let img = image::open(tmp(&format!("aov.{aov}.png"))).unwrap();
        assert_eq!((img.width(), img.height()), (40, h), "{aov}");
    }
    assert!(stdout.contains("nodes visited") && stdout.contains("primitives tested per camera ray"), "{stdout}");
    let (code, _, err) = isir(&["render", "tp4-sphere", "--aov", "bogus"]);
    one_line_error(code, &err, "albedo");
}

#[test]
fn a_ply_file_renders_and_its_errors_name_the_element() {
    // A binary PLY quad.
    let ply = tmp("quad.ply");
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
element face 1\nproperty list uchar int vertex_indices\nend_header\n"
        .to_vec();
    for f in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0] {
        bytes.extend(f.to_le_bytes());
    }
    bytes.push(4);
    for i in 0..4i32 {
        bytes.extend(i.to_le_bytes());
    }
    std::fs::write(&ply, &bytes).unwrap();
    let png = tmp("quad-ply.png");
    let (code, out, err) = isir(&["render", ply.to_str().unwrap(), "-o", png.to_str().unwrap(), "--width", "32", "--height", "24"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("quad.ply") && png.exists(), "{out}");
    let (code, _, err) = isir(&["render", tmp("missing.ply").to_str().unwrap()]);
    one_line_error(code, &err, "missing.ply");
    // Cut short: an error naming the file and the element.
    std::fs::write(&ply, &bytes[..bytes.len() - 6]).unwrap();
    let (code, _, err) = isir(&["render", ply.to_str().unwrap()]);
    one_line_error(code, &err, "quad.ply: element 'face' (1 declared)");
}

#[test]
fn a_gltf_file_with_its_buffer_beside_it_renders() {
    let bin = tmp("tri.bin");
    let mut b = Vec::new();
    for f in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        b.extend(f.to_le_bytes());
    }
    std::fs::write(&bin, &b).unwrap();
    let gltf = tmp("tri.gltf");
    std::fs::write(
        &gltf,
        "{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],\
         \"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0}}]}],\"buffers\":[{\"byteLength\":36,\"uri\":\"tri.bin\"}],\
         \"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],\
         \"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}]}",
    )
    .unwrap();
    let png = tmp("tri-gltf.png");
    let (code, out, err) = isir(&["render", gltf.to_str().unwrap(), "-o", png.to_str().unwrap(), "--width", "32", "--height", "24"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("tri.gltf") && png.exists(), "{out}");
    std::fs::remove_file(&bin).unwrap();
    let (code, _, err) = isir(&["render", gltf.to_str().unwrap()]);
    one_line_error(code, &err, "tri.gltf: buffer 0:");
    assert!(err.contains("tri.bin"), "{err}");
}

#[test]
fn an_image_of_nothing_comes_with_a_warning() {
    // An image where every pixel is the background says so.
    let obj = tmp("far-apart.obj");
    // Two tiny triangles 1e6 apart: framed to see both, each is under a pixel.
    std::fs::write(&obj, "v 0 0 0\nv 1e-6 0 0\nv 0 1e-6 0\nv 1e6 1e6 1e6\nv 1e6 1e6 1.000001e6\nv 1e6 1.000001e6 1e6\nf 1 2 3\nf 4 5 6\n")
        .unwrap();
    let (code, _, err) =
        isir(&["render", obj.to_str().unwrap(), "-o", tmp("far-apart.png").to_str().unwrap(), "--width", "16", "--height", "12"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains("nothing is in view"), "{err}");
    let (code, _, err) = isir(&["render", "tp1-sphere", "-o", tmp("sphere-seen.png").to_str().unwrap(), "--width", "16", "--height", "12"]);
    assert_eq!(code, 0);
    assert!(!err.contains("nothing is in view"), "{err}");
}

#[test]
fn info_describes_a_mesh_file_and_names_what_was_dropped() {
    let obj = tmp("info.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 2\nl 1 2\n").unwrap();
    let (code, out, err) = isir(&["info", obj.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    for needle in [
        "format:     Wavefront OBJ",
        "triangles:  2 (1 degenerate",
        "vertices:   3",
        "bounds:     [0, 0, 0] to [1, 1, 0]",
        "polylines ('l') are not rendered",
    ] {
        assert!(out.contains(needle), "'{needle}' missing from:\n{out}");
    }
    let (code, out, _) = isir(&["info", "uvsphere"]);
    assert_eq!(code, 0);
    assert!(out.contains("triangles:  960"), "{out}");
    let (code, _, err) = isir(&["info", tmp("none.glb").to_str().unwrap()]);
    one_line_error(code, &err, "none.glb");
}

#[test]
fn scene_files_render_check_and_report_errors_on_one_line() {
    let scene = tmp("two.toml");
    std::fs::write(
        &scene,
        "[render]\nwidth = 40\nheight = 30\n[camera]\nposition = [0, 0, -4]\n[materials]\nred = { type = \"lambert\", color = [1, 0, 0] }\n\
         [[objects]]\ntype = \"sphere\"\nmaterial = \"red\"\n[[lights]]\ntype = \"point\"\nposition = [0, 3, -3]\n",
    )
    .unwrap();
    let png = tmp("two.png");
    let (code, out, err) = isir(&["render", scene.to_str().unwrap(), "-o", png.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("40x30"), "the file's size: {out}");
    let (code, out, err) = isir(&["render", scene.to_str().unwrap(), "-o", png.to_str().unwrap(), "--width", "20"]);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("20x30"), "the option overrides the file: {out}");
    let (code, out, _) = isir(&["check", scene.to_str().unwrap()]);
    assert_eq!(code, 0);
    assert!(out.contains("objects:    1") && out.contains("lights:     1"), "{out}");
    std::fs::write(&scene, "[[objects]]\ntype = \"spere\"\n").unwrap();
    let (code, _, err) = isir(&["check", scene.to_str().unwrap()]);
    one_line_error(code, &err, "two.toml:2:");
    assert!(err.contains("did you mean `sphere`?"), "{err}");
}

#[test]
fn trace_names_its_mesh_in_warnings_and_a_built_in_model_in_other_letters() {
    // One degenerate triangle: the warning names the file, in the singular.
    let obj = tmp("one-degenerate.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n").unwrap();
    let rays = tmp("one-degenerate.rays");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", rays.to_str().unwrap(), "--width", "4", "--height", "2"]);
    assert_eq!(code, 0, "{err}");
    let (code, _, err) = isir(&["trace", obj.to_str().unwrap(), rays.to_str().unwrap(), "--repeat", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(err.contains(&format!("{}: 1 degenerate triangle ", obj.display())) && err.contains("is never hit"), "{err}");
    // `bunny` for `Bunny`: said which is meant.
    let (code, _, err) = isir(&["trace", "bunny", rays.to_str().unwrap()]);
    one_line_error(code, &err, "the built-in model is named 'Bunny'");
}

#[cfg(unix)]
#[test]
fn bench_says_when_an_embree_tool_writes_no_hits() {
    // A program that succeeds without doing anything (`true`) given as the tool.
    let cache = fresh_dir("bench-cache-true");
    let (code, out, err) = bench_with_cache(&cache, &["--embree", "/bin/true"]);
    one_line_error(code, &err, "wrote no hit file");
    assert!(out.is_empty(), "half a table printed: {out}");
}

#[cfg(unix)]
#[test]
fn bench_stopped_by_a_signal_removes_its_temporary_files() {
    let tmpdir = fresh_dir("bench-tmp-signal");
    let mut child = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(["bench", "tp4-conference", "--no-embree", "--rounds", "5"])
        .env("TMPDIR", &tmpdir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Once it has written its first ray set, `kill` (SIGTERM) it.
    let written =
        |d: &std::path::Path| std::fs::read_dir(d).unwrap().flatten().any(|e| e.path().is_dir() && e.path().join("primary.rays").exists());
    let start = std::time::Instant::now();
    while !written(&tmpdir) {
        assert!(start.elapsed().as_secs() < 60, "no ray file written");
        assert!(child.try_wait().unwrap().is_none(), "bench ended before it was stopped");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let killed = Command::new("kill").arg(child.id().to_string()).status().unwrap();
    assert!(killed.success());
    let status = child.wait().unwrap();
    assert_eq!(status.code(), Some(130), "{status:?}");
    assert!(std::fs::read_dir(&tmpdir).unwrap().next().is_none(), "the temporary folder was left behind");
}

/// `isir ARGS` with its stdout a pipe closed at once (`isir ... | true`): the status and
/// stderr.
#[cfg(unix)]
fn isir_into_closed_pipe(args: &[&str]) -> (i32, String) {
    use std::io::Read;
    let mut child = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(args)
        .current_dir(env!("CARGO_TARGET_TMPDIR"))
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut err = String::new();
    child.stderr.take().unwrap().read_to_string(&mut err).unwrap();
    (child.wait().unwrap().code().unwrap_or(-1), err)
}

/// A reader gone does not stop the work: `isir trace` still writes its hits, `isir render`
/// its AOVs, after the lines they print first (found by review: the first version of
/// `out!` ended the process there, status 0 and no files).
#[cfg(unix)]
#[test]
fn output_into_a_closed_pipe_still_writes_every_file() {
    let rays = tmp("pipe.rays");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", rays.to_str().unwrap(), "--width", "8", "--height", "4"]);
    assert_eq!(code, 0, "{err}");
    let hits = tmp("pipe.hits");
    std::fs::remove_file(&hits).ok();
    let (code, err) =
        isir_into_closed_pipe(&["trace", "uvsphere", rays.to_str().unwrap(), "--hits", hits.to_str().unwrap(), "--repeat", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(hits.exists() && !err.contains("panicked"), "{err}");
    let png = tmp("pipe.png");
    let depth = tmp("pipe.depth.png");
    std::fs::remove_file(&depth).ok();
    let (code, err) =
        isir_into_closed_pipe(&["render", "tp4-sphere", "--width", "16", "--height", "12", "--aov", "depth", "-o", png.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    assert!(depth.exists() && !err.contains("panicked"), "{err}");
}

/// `--keep` naming the folder of a scene whose placed mesh is `mesh.obj`: the scene's file
/// is left as it was (found by review: the moved mesh was written over it), and no output
/// of bench may take the name of one of the scene's files.
#[cfg(unix)]
#[test]
fn bench_keep_never_writes_over_the_scenes_own_files() {
    let dir = fresh_dir("keep-own-mesh");
    let original = std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/../isir/data/uvsphere.obj")).unwrap();
    std::fs::write(dir.join("mesh.obj"), &original).unwrap();
    std::fs::copy(concat!(env!("CARGO_MANIFEST_DIR"), "/../isir/data/uvsphere.mtl"), dir.join("uvsphere.mtl")).unwrap();
    let scene = "[camera]\nposition = [0, 0, -6]\nlook_at = [0, 0, 0]\n\n[[objects]]\ntype = \"mesh\"\nfile = \"FILE\"\n\
                 transform = { translate = [0.5, 0, 0], scale = 2 }\n\n[[lights]]\ntype = \"point\"\nposition = [0, 3, -5]\n";
    std::fs::write(dir.join("s.toml"), scene.replace("FILE", "mesh.obj")).unwrap();
    let bench = |dir: &std::path::Path, toml: &str| {
        Command::new(env!("CARGO_BIN_EXE_isir"))
            .args(["bench", toml, "--width", "8", "--height", "4", "--repeat", "1", "--threads", "1", "--no-embree", "--keep", "."])
            .current_dir(dir)
            .output()
            .unwrap()
    };
    let out = bench(&dir, "s.toml");
    assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
    assert!(std::fs::read(dir.join("mesh.obj")).unwrap() == original, "the scene's mesh.obj was overwritten");
    // A scene whose own mesh has the name of bench's output: refused, the file unchanged.
    std::fs::write(dir.join("isir-bench-mesh.obj"), &original).unwrap();
    std::fs::write(dir.join("t.toml"), scene.replace("FILE", "isir-bench-mesh.obj")).unwrap();
    let out = bench(&dir, "t.toml");
    one_line_error(out.status.code().unwrap_or(-1), &String::from_utf8_lossy(&out.stderr), "one of the scene's own files");
    assert!(std::fs::read(dir.join("isir-bench-mesh.obj")).unwrap() == original);
}

/// A reused `--keep` folder: the hit files of an earlier run do not pass for this run's
/// (found by review: a tool that writes nothing, `/bin/true`, got 100% agreement).
#[cfg(unix)]
#[test]
fn bench_keep_reused_does_not_read_an_earlier_runs_hits() {
    let cache = fresh_dir("keep-stale-cache");
    let e3 = cache.join("isir").join("embree3-bench");
    fake_embree(&e3);
    let keep = fresh_dir("keep-stale");
    let (code, _, err) = bench_with_cache(&cache, &["--keep", keep.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    std::fs::remove_file(&e3).unwrap();
    let (code, _, err) = bench_with_cache(&cache, &["--keep", keep.to_str().unwrap(), "--embree", "/bin/true"]);
    one_line_error(code, &err, "wrote no hit file");
}

/// Stopped by `kill`, bench stops the Embree tool it runs too (found by review: the tool
/// ran on, its parent gone).
#[cfg(unix)]
#[test]
fn bench_stopped_by_a_signal_stops_its_embree_tool() {
    let dir = fresh_dir("bench-signal-child");
    // A tool that writes its pid, then waits long.
    let tool = dir.join("embree3-bench");
    let pid_file = dir.join("tool.pid");
    std::fs::write(&tool, format!("#!/bin/sh\necho $$ > '{}'\nexec sleep 60\n", pid_file.display())).unwrap();
    {
        use std::os::unix::fs::PermissionsExt;
        std::fs::set_permissions(&tool, std::fs::Permissions::from_mode(0o755)).unwrap();
    }
    let mut child = Command::new(env!("CARGO_BIN_EXE_isir"))
        .args(["bench", "tp4-sphere", "--width", "8", "--height", "4", "--repeat", "1", "--threads", "1"])
        .args(["--embree", tool.to_str().unwrap()])
        .env("TMPDIR", &dir)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while !pid_file.exists() || std::fs::read_to_string(&pid_file).unwrap().trim().is_empty() {
        assert!(start.elapsed().as_secs() < 60, "the tool did not start");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let tool_pid = std::fs::read_to_string(&pid_file).unwrap().trim().to_string();
    assert!(Command::new("kill").arg(child.id().to_string()).status().unwrap().success());
    assert_eq!(child.wait().unwrap().code(), Some(130));
    // The tool is gone within a few seconds (`kill -0` fails once it is).
    let start = std::time::Instant::now();
    while Command::new("kill").args(["-0", &tool_pid]).stderr(std::process::Stdio::null()).status().unwrap().success() {
        assert!(start.elapsed().as_secs() < 10, "the Embree tool still runs after bench was stopped");
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

/// A glTF file whose one mesh two nodes place (instances) renders framed, both copies in
/// view (found by review: the framing looked at plain meshes only and said there was no
/// triangle to look at).
#[test]
fn a_gltf_of_instances_renders_framed() {
    let gltf = tmp("two-nodes.gltf");
    std::fs::write(
        &gltf,
        r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0,1]}],
        "nodes":[{"mesh":0,"translation":[-1,0,0]},{"mesh":0,"translation":[1,0,0]}],
        "meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
        "buffers":[{"byteLength":44,"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAAAAABAAIAAAA="}],
        "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":6}],
        "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
        {"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#,
    )
    .unwrap();
    // isir bench traces both copies, as one mesh, the same triangles as the Embree stand-in.
    #[cfg(unix)]
    {
        let cache = fresh_dir("bench-cache-two-nodes");
        fake_embree(&cache.join("isir").join("embree3-bench"));
        let out = Command::new(env!("CARGO_BIN_EXE_isir"))
            .args(["bench", gltf.to_str().unwrap(), "--width", "24", "--height", "16", "--repeat", "1", "--threads", "1"])
            .current_dir(env!("CARGO_TARGET_TMPDIR"))
            .env("XDG_CACHE_HOME", &cache)
            .env("PATH", "/usr/bin:/bin")
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert_eq!(out.status.code(), Some(0), "{}", String::from_utf8_lossy(&out.stderr));
        assert!(stdout.contains(", 2 triangles (0 degenerate) (the scene's 2 meshes as one),"), "{stdout}");
        assert!(bench_tables(&stdout)[0].iter().filter(|l| l.ends_with("100.0000%")).count() == 5, "{stdout}");
    }
    let png = tmp("two-nodes.png");
    let (code, _, err) =
        isir(&["render", gltf.to_str().unwrap(), "-o", png.to_str().unwrap(), "--width", "60", "--height", "40", "--spp", "1"]);
    assert_eq!(code, 0, "{err}");
    // Both triangles in the frame: lit pixels in the left and in the right half.
    let img = image::open(&png).unwrap().to_rgb8();
    let background = *img.get_pixel(0, 0);
    let lit = |xs: std::ops::Range<u32>| xs.flat_map(|x| (0..40).map(move |y| (x, y))).any(|(x, y)| *img.get_pixel(x, y) != background);
    assert!(lit(0..30) && lit(30..60), "both copies in view");
}

/// An output that is one of the command's inputs is refused before any work, naming both,
/// and the input is left as it was (found by an audit: `--hits M.obj` replaced the mesh
/// with hits, `-o M.obj` the mesh with rays).
#[test]
fn an_output_that_is_an_input_is_refused_and_the_input_kept() {
    let dir = tmp("same-file");
    std::fs::create_dir_all(&dir).unwrap();
    let mesh = dir.join("m.obj");
    let mesh_text = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    std::fs::write(&mesh, mesh_text).unwrap();
    let rays = dir.join("m.rays");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", rays.to_str().unwrap(), "--width", "4", "--height", "2"]);
    assert_eq!(code, 0, "{err}");
    let rays_bytes = std::fs::read(&rays).unwrap();
    let scene = dir.join("s.toml");
    std::fs::write(&scene, "[camera]\nposition = [0, 0, -4]\n[[objects]]\ntype = \"mesh\"\nfile = \"m.obj\"\n").unwrap();
    let (m, r, s) = (mesh.to_str().unwrap(), rays.to_str().unwrap(), scene.to_str().unwrap());
    // The same file by another path: `./` in it, or a symbolic link to it.
    let dotted = format!("{}/./m.obj", dir.display());
    let mut cases: Vec<(Vec<&str>, String)> = vec![
        (vec!["trace", m, r, "--hits", m], format!("--hits {m}: the same file as the mesh {m}")),
        (vec!["trace", "uvsphere", r, "--hits", r], format!("--hits {r}: the same file as the ray file {r}")),
        (vec!["rays", m, "--kind", "primary", "-o", m], format!("-o {m}: the same file as the mesh {m}")),
        (vec!["rays", m, "--kind", "primary", "-o", &dotted], format!("-o {dotted}: the same file as the mesh {m}")),
        (vec!["rays", s, "--kind", "primary", "-o", s], format!("-o {s}: the same file as the scene file {s}")),
    ];
    let scene_mesh = dir.join("m.obj").display().to_string();
    cases.push((vec!["rays", s, "--kind", "primary", "-o", m], format!("-o {m}: the same file as the scene's mesh {scene_mesh}")));
    #[cfg(unix)]
    let link = dir.join("link.png");
    #[cfg(unix)]
    {
        // An image path that leads to the mesh: `render` would write the image over it.
        std::fs::remove_file(&link).ok();
        std::os::unix::fs::symlink(&mesh, &link).unwrap();
        cases.push((
            vec!["render", m, "-o", link.to_str().unwrap(), "--width", "8", "--height", "8"],
            format!("-o {}: the same file as the mesh {m}", link.display()),
        ));
    }
    for (args, needle) in cases {
        let (code, out, err) = isir_within(10, &args);
        one_line_error(code, &err, &needle);
        assert!(err.contains("would replace an input"), "{err}");
        assert!(out.is_empty(), "{args:?}: {out}");
        assert_eq!(std::fs::read_to_string(&mesh).unwrap(), mesh_text, "{args:?}: the mesh was changed");
        assert_eq!(std::fs::read(&rays).unwrap(), rays_bytes, "{args:?}: the ray file was changed");
        assert!(std::fs::read_to_string(&scene).unwrap().contains("m.obj"), "{args:?}: the scene file was changed");
    }
    // Another file is written as before.
    let hits = dir.join("m.hits");
    let (code, _, err) = isir(&["trace", m, r, "--hits", hits.to_str().unwrap(), "--repeat", "1"]);
    assert_eq!(code, 0, "{err}");
    assert!(hits.exists());
}

/// What a mesh reads besides itself (its material library, its texture) is an input too:
/// an image written over the texture, rays over the library, hits over either, refused.
#[test]
fn a_file_the_mesh_reads_is_an_input_too() {
    let dir = fresh_dir("same-file-side");
    let obj = dir.join("m.obj");
    std::fs::write(&obj, "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl a\nf 1/1 2/2 3/3\n").unwrap();
    let (mtl, tex) = (dir.join("m.mtl"), dir.join("tex.png"));
    std::fs::write(&mtl, "newmtl a\nKd 1 1 1\nmap_Kd tex.png\n").unwrap();
    // The texture: any PNG (isir's own render of a sphere).
    let (code, _, err) = isir(&["render", "tp1-sphere", "--width", "4", "--height", "4", "-o", tex.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let (tex_bytes, mtl_text) = (std::fs::read(&tex).unwrap(), std::fs::read_to_string(&mtl).unwrap());
    let rays = dir.join("r.rays");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", rays.to_str().unwrap(), "--width", "4", "--height", "2"]);
    assert_eq!(code, 0, "{err}");
    let (o, t, l, r) = (obj.to_str().unwrap(), tex.to_str().unwrap(), mtl.to_str().unwrap(), rays.to_str().unwrap());
    for (args, needle) in [
        (vec!["render", o, "-o", t, "--width", "8", "--height", "8"], format!("-o {t}: the same file as a file the scene reads")),
        (vec!["rays", o, "--kind", "primary", "-o", l], format!("-o {l}: the same file as a file the scene reads")),
        (vec!["trace", o, r, "--hits", t], format!("--hits {t}: the same file as a file the mesh reads")),
    ] {
        let (code, out, err) = isir_within(10, &args);
        one_line_error(code, &err, &needle);
        assert!(out.is_empty(), "{args:?}: {out}");
        assert_eq!(std::fs::read(&tex).unwrap(), tex_bytes, "{args:?}: the texture was changed");
        assert_eq!(std::fs::read_to_string(&mtl).unwrap(), mtl_text, "{args:?}: the material library was changed");
    }
}

/// Stopped by Ctrl-C or `kill` while it writes, `isir rays` leaves no temporary file (found
/// by an audit: a SIGTERM left a 33 MB `.big.rays.tmp-PID-1`), and ends with status 130.
#[cfg(unix)]
#[test]
fn a_write_stopped_by_a_signal_leaves_no_temporary_file() {
    let dir = fresh_dir("write-signal");
    let mesh = dir.join("tri.obj");
    std::fs::write(&mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    for signal in ["TERM", "INT", "HUP"] {
        let out = dir.join("big.rays");
        // 8192x4096 random rays, 1 GB: seconds of writing, stopped within milliseconds.
        let mut child = Command::new(env!("CARGO_BIN_EXE_isir"))
            .args(["rays", mesh.to_str().unwrap(), "--kind", "random", "--width", "8192", "--height", "4096", "-o"])
            .arg(&out)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let start = std::time::Instant::now();
        while temporaries(&dir, "big.rays").is_empty() {
            assert!(start.elapsed().as_secs() < 60, "no temporary file written");
            assert!(child.try_wait().unwrap().is_none(), "rays ended before it was stopped");
            std::thread::sleep(std::time::Duration::from_millis(2));
        }
        let killed = Command::new("kill").args([format!("-{signal}"), child.id().to_string()]).status().unwrap();
        assert!(killed.success());
        let status = child.wait().unwrap();
        assert_eq!(status.code(), Some(130), "SIG{signal}: {status:?}");
        assert_eq!(temporaries(&dir, "big.rays"), Vec::<String>::new(), "SIG{signal}: temporary files left");
        assert!(!out.exists(), "SIG{signal}: a stopped write left an output");
    }
}

/// A file given to the wrong command says what it is and which command reads it (found by
/// a new user: `isir info scene.toml` parsed TOML as OBJ, `isir check Bunny.obj` gave a
/// TOML error, `isir check tp4-bunny` "No such file or directory").
#[test]
fn a_file_given_to_the_wrong_command_says_which_reads_it() {
    let scene = tmp("kind.toml");
    std::fs::write(&scene, "[camera]\nposition = [0, 0, -4]\n[[objects]]\ntype = \"sphere\"\n").unwrap();
    let mesh = tmp("kind.obj");
    std::fs::write(&mesh, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let rays = tmp("kind.rays");
    let (code, _, err) = isir(&["rays", "tp4-sphere", "--kind", "primary", "-o", rays.to_str().unwrap(), "--width", "4", "--height", "2"]);
    assert_eq!(code, 0, "{err}");
    let (s, m, r) = (scene.to_str().unwrap(), mesh.to_str().unwrap(), rays.to_str().unwrap());
    let cases: [(Vec<&str>, String); 9] = [
        (vec!["info", s], format!("{s} is a scene file, not a mesh: `isir check` or `isir render` read it")),
        (vec!["trace", s, r, "--repeat", "1"], format!("{s} is a scene file, not a mesh")),
        (vec!["check", m], format!("{m} is a mesh, not a scene file: `isir info` describes it")),
        (vec!["check", "tp4-bunny"], "tp4-bunny is a built-in scene, not a scene file: `isir render tp4-bunny` renders it".to_string()),
        (vec!["check", "Bunny"], "Bunny is a built-in model, not a scene file: `isir info Bunny` describes it".to_string()),
        (vec!["check", "tp4-buny"], "did you mean the built-in scene `tp4-bunny`?".to_string()),
        (vec!["info", "tp4-bunny"], "tp4-bunny is a built-in scene, not a mesh: `isir render tp4-bunny` renders it".to_string()),
        (vec!["render", r, "-o", "kind.png"], format!("{r} is a ray file, not a scene: `isir trace MESH {r}` traces it")),
        (vec!["check", r], format!("{r} is a ray file, not a scene file")),
    ];
    for (args, needle) in cases {
        let (code, out, err) = isir_within(10, &args);
        one_line_error(code, &err, &needle);
        assert!(out.is_empty(), "{args:?}: {out}");
    }
    // Each right command still reads its file.
    assert_eq!(isir(&["check", s]).0, 0);
    assert_eq!(isir(&["info", m]).0, 0);
}

/// A misspelt scene gets the nearest name; a built-in model's name where a scene is
/// expected says which scene shows it (found by a new user: `unknown scene 'tp4-buny'`,
/// nothing more).
#[test]
fn unknown_scenes_get_a_suggestion_and_models_the_scene_that_shows_them() {
    for cmd in [vec!["render"], vec!["rays", "--kind", "primary", "-o", "never.rays"], vec!["bench", "--no-embree"]] {
        let (code, _, err) = isir_within(10, &[cmd.as_slice(), &["tp4-buny"]].concat());
        one_line_error(code, &err, "unknown scene 'tp4-buny' (did you mean `tp4-bunny`?");
    }
    let (code, _, err) = isir_within(10, &["render", "tp4-Conferense"]);
    one_line_error(code, &err, "did you mean `tp4-conference`?");
    // Nothing near: no suggestion.
    let (code, _, err) = isir_within(10, &["render", "tp5-nothing"]);
    one_line_error(code, &err, "unknown scene 'tp5-nothing'");
    assert!(!err.contains("did you mean"), "{err}");
    for (name, needle) in [
        ("Bunny", "'Bunny' is a built-in model, not a scene: the built-in scene `tp4-bunny` shows it (`isir render tp4-bunny`)"),
        ("bunny", "'bunny' is a built-in model, not a scene: the built-in scene `tp4-bunny` shows it"),
        ("uvsphere", "the built-in scenes `tp4-sphere-flat` and `tp4-sphere` show it"),
    ] {
        let (code, _, err) = isir_within(10, &["render", name]);
        one_line_error(code, &err, needle);
        assert!(err.contains("model = \""), "{err}");
    }
}

/// An image name without an extension says so and names the formats (it was "unsupported
/// image format '.'").
#[test]
fn an_image_name_without_an_extension_names_the_formats() {
    let (code, _, err) = isir_within(10, &["render", "tp4-sphere", "--width", "8", "--height", "8", "-o", "noext"]);
    one_line_error(code, &err, "-o noext: the file name has no extension");
    assert!(err.contains(".png") && err.contains(".exr"), "{err}");
}
