//! `isir bench`: build, generate the four ray sets of a scene, trace them, and print one
//! table; with `embree-bench` (Embree 3, tools/embree3-bench) and/or `embree4-bench`
//! (Embree 4, tools/embree4-bench) found, run each on the same files in the same run and
//! print, one table per engine, the ratio isir / Embree and the hit agreement.

use crate::trace::{build_timed, trace_timed, Mode, TraceFigures};
use crate::{out, threads_phrase, warn_all, with_threads};
use anyhow::Context;
use clap::Args;
use isir::rays::{self, compare_hits, HitRecord, RayKind};
use isir::scenes::{MeshSource, SceneDescription};
use isir::{Accel, Scene, TriangleMesh};
use std::collections::HashMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(Args, Debug)]
pub struct BenchArgs {
    /// A built-in scene (default tp4-conference), a scene file (.toml) or a mesh file (.obj,
    /// .ply, .gltf, .glb, optionally .gz): its meshes, as placed, traced as one.
    pub target: Option<String>,
    /// The Embree 3 tool (default: `embree3-bench` or `embree-bench` on PATH, then in
    /// ~/.cache/isir/, where tools/embree3-bench/build.sh puts it).
    #[arg(long)]
    pub embree: Option<PathBuf>,
    /// The Embree 4 tool (default: `embree4-bench` on PATH, then ~/.cache/isir/embree4-bench,
    /// where tools/embree4-bench/build.sh puts it).
    #[arg(long)]
    pub embree4: Option<PathBuf>,
    /// Do not run Embree (3 or 4) even when it is found.
    #[arg(long)]
    pub no_embree: bool,
    /// Embree build quality.
    #[arg(long, default_value = "medium", value_parser = ["low", "medium", "high"])]
    pub embree_quality: String,
    /// Width of the ray sets.
    #[arg(long, default_value_t = 1200)]
    pub width: u32,
    /// Height of the ray sets.
    #[arg(long, default_value_t = 800)]
    pub height: u32,
    /// Best of this many builds (at most 3) and traces (at most 1000, as the Embree tools).
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeat: u32,
    /// Threads for both engines (default: one per core; at most 1024).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the diffuse and shadow rays.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Keep the ray files, the mesh as OBJ (unless the target is a plain OBJ file) and
    /// Embree's hit files in this directory, created if need be (default: a temporary one,
    /// removed at the end).
    #[arg(long)]
    pub keep: Option<PathBuf>,
    /// Run the whole comparison this many times (isir, then Embree, per round; at most 99)
    /// and print medians, and the ratio's median with its range: the machine's noise in
    /// one table.
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=99))]
    pub rounds: u32,
    /// When isir's threads trace 16 rays at a time (auto: when the tree is larger than the
    /// CPU's last-level cache; always; never: one ray after the other, as Embree's single
    /// rays go).
    #[arg(long, default_value = "auto")]
    pub interleave: isir::wide::Interleave,
}

/// One round of measurements: isir's build and traces, then each engine's on the same files.
struct Round {
    build_ms: f64,
    /// Closest/occluded traces of the four sets, then the packets.
    ours: Vec<TraceFigures>,
    /// Per engine found: its figures on the three sets, then its stream mode.
    theirs: Vec<Vec<HashMap<String, String>>>,
}

/// An Embree comparison tool that was found.
struct Engine {
    /// Its column in the table and the tag of its hit files: `embree` (Embree 3, the name
    /// the table has always had) or `embree4`.
    label: &'static str,
    bin: PathBuf,
}

/// The median of `v` (NaN when empty).
fn median(mut v: Vec<f64>) -> f64 {
    v.retain(|x| !x.is_nan());
    if v.is_empty() {
        return f64::NAN;
    }
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        (v[n / 2 - 1] + v[n / 2]) / 2.0
    }
}

/// The comparison tool: `explicit` (which must exist), else the first of `names` on PATH,
/// else the first in the cache folder its build.sh installs to (`$XDG_CACHE_HOME/isir` or
/// `~/.cache/isir`).
fn find_tool(explicit: &Option<PathBuf>, option: &str, names: &[&str]) -> anyhow::Result<Option<PathBuf>> {
    if let Some(p) = explicit {
        // Said now, not after minutes of isir's own measurements.
        anyhow::ensure!(p.exists(), "{option} {}: no such file", p.display());
        anyhow::ensure!(p.is_file(), "{option} {}: not a file (the path of the tool's binary)", p.display());
        return Ok(Some(p.clone()));
    }
    if let Ok(path) = std::env::var("PATH") {
        for dir in std::env::split_paths(&path) {
            if let Some(p) = names.iter().map(|n| dir.join(n)).find(|p| p.is_file()) {
                return Ok(Some(p));
            }
        }
    }
    let Some(cache) =
        std::env::var_os("XDG_CACHE_HOME").map(PathBuf::from).or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache")))
    else {
        return Ok(None);
    };
    Ok(names.iter().map(|n| cache.join("isir").join(n)).find(|p| p.is_file()))
}

/// The engines to compare with: Embree 3 (under its tool's new name, or the old
/// `embree-bench`), then Embree 4.
fn find_engines(a: &BenchArgs) -> anyhow::Result<Vec<Engine>> {
    if a.no_embree {
        return Ok(Vec::new());
    }
    let mut engines = Vec::new();
    if let Some(bin) = find_tool(&a.embree, "--embree", &["embree3-bench", "embree-bench"])? {
        engines.push(Engine { label: "embree", bin });
    }
    if let Some(bin) = find_tool(&a.embree4, "--embree4", &["embree4-bench"])? {
        engines.push(Engine { label: "embree4", bin });
    }
    Ok(engines)
}

/// Run an Embree tool (tools/README.md) and read its `key: value` lines.
fn run_embree(
    bin: &Path,
    [mesh, rays, hits]: [&Path; 3],
    occluded: bool,
    mode: &str,
    a: &BenchArgs,
    threads: usize,
) -> anyhow::Result<HashMap<String, String>> {
    let mut cmd = Command::new(bin);
    cmd.arg(mesh).arg(rays).arg("--hits").arg(hits).args([
        "--quality",
        &a.embree_quality,
        "--repeat",
        &a.repeat.to_string(),
        "--threads",
        &threads.to_string(),
        "--mode",
        mode,
    ]);
    if occluded {
        cmd.arg("--occluded");
    }
    // A hit file of an earlier run (a reused `--keep` folder) must not pass for this one's.
    match std::fs::remove_file(hits) {
        Err(e) if e.kind() != std::io::ErrorKind::NotFound => return Err(e).with_context(|| format!("removing {}", hits.display())),
        _ => {}
    }
    let child = cmd
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .with_context(|| format!("running {}", bin.display()))?;
    // Known to the signal handler while it runs, so that stopping isir stops it too.
    crate::signals::state().child = Some(child.id());
    let out = child.wait_with_output();
    crate::signals::state().child = None;
    let out = out.with_context(|| format!("running {}", bin.display()))?;
    // Its first line of error (the problem), not the usage page that may follow.
    let stderr = String::from_utf8_lossy(&out.stderr);
    let reason = stderr.lines().map(str::trim).find(|l| !l.is_empty()).map_or_else(|| format!("{}", out.status), str::to_string);
    anyhow::ensure!(out.status.success(), "{} failed: {reason}", bin.display());
    anyhow::ensure!(hits.is_file(), "{} wrote no hit file: is it an Embree tool of tools/ (tools/README.md)?", bin.display());
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_once(": ").map(|(k, v)| (k.to_string(), v.trim().to_string())))
        .collect())
}

fn num(m: &HashMap<String, String>, k: &str) -> f64 {
    m.get(k).and_then(|v| v.parse().ok()).unwrap_or(f64::NAN)
}

pub fn run(a: BenchArgs) -> anyhow::Result<()> {
    with_threads(a.threads, || run_in_pool(&a))?
}

/// The most rays per set: `isir bench` holds its four sets (32 bytes a ray) and its five
/// traces' hit records (16 bytes) in memory at once, about 210 bytes a ray, 3.5 GB here.
const MAX_BENCH_RAYS: u64 = 4096 * 4096;

/// The ray sets' size: both sides from 1 to 16384, at most [`MAX_BENCH_RAYS`] rays.
fn check_bench_size(width: u32, height: u32) -> anyhow::Result<()> {
    let n = u64::from(width) * u64::from(height);
    anyhow::ensure!(width > 0 && height > 0, "--width {width} --height {height}: both must be at least 1");
    anyhow::ensure!(width <= 16384 && height <= 16384, "--width {width} --height {height}: each at most 16384");
    anyhow::ensure!(
        n <= MAX_BENCH_RAYS,
        "--width {width} --height {height}: {n} rays per set, more than the {MAX_BENCH_RAYS} (4096x4096) isir bench holds in \
         memory (about 210 bytes a ray: {:.1} GB for these)",
        n as f64 * 210e-9
    );
    Ok(())
}

/// The benchmark's folder: `--keep`'s (created if need be, kept), or a temporary one that
/// goes when this does, on an error or a panic too, and on Ctrl-C or `kill` (SIGINT,
/// SIGTERM, SIGHUP), where the process then stops the Embree tool it runs, if any, and
/// ends with status 130.
struct WorkDir {
    path: PathBuf,
    keep: bool,
}

impl WorkDir {
    fn new(keep: Option<&Path>) -> anyhow::Result<Self> {
        match keep {
            Some(p) => {
                anyhow::ensure!(p.is_dir() || std::fs::symlink_metadata(p).is_err(), "--keep {}: not a directory", p.display());
                std::fs::create_dir_all(p).with_context(|| format!("--keep {}", p.display()))?;
                crate::signals::install();
                Ok(Self { path: p.to_path_buf(), keep: true })
            }
            None => {
                let t = tempfile::Builder::new().prefix("isir-bench-").tempdir().context("creating a temporary folder")?;
                let path = t.keep();
                crate::signals::state().dir = Some(path.clone());
                crate::signals::install();
                Ok(Self { path, keep: false })
            }
        }
    }
}

impl Drop for WorkDir {
    fn drop(&mut self) {
        if !self.keep {
            // Removed with the state locked: a signal meanwhile waits for the removal.
            let mut state = crate::signals::state();
            state.dir = None;
            std::fs::remove_dir_all(&self.path).ok();
        }
    }
}

fn run_in_pool(a: &BenchArgs) -> anyhow::Result<()> {
    check_bench_size(a.width, a.height)?;
    let engines = find_engines(a)?;
    let name = a.target.clone().unwrap_or_else(|| "tp4-conference".to_string());
    let (desc, scene) = crate::render::build_scene(&name, Accel::BvhSah, isir::triangle::TriangleTest::MollerTrumbore)?;
    warn_all(&scene.warnings);
    let (mesh, source) = bench_mesh(&scene, &desc).with_context(|| format!("{name}: the scene has no mesh to benchmark"))?;
    let dir = WorkDir::new(a.keep.as_deref())?;
    let mut report = bench_in(a, &name, &desc, &scene, mesh, source, &dir.path, &engines)?;
    if dir.keep {
        let _ = write!(report, "\nfiles kept in {}", dir.path.display());
    }
    // The table printed once the files are gone (a reader that stops early ends the
    // process at the first line it misses).
    drop(dir);
    out!("{report}");
    Ok(())
}

/// The mesh to trace, in world space, and where its file comes from when it can be given
/// to Embree as it is: the scene's one mesh; or all its meshes as one, those placed by a
/// transform (a scene file's mesh with a `transform`, a glTF node: instances) with their
/// vertices moved to where they stand, each mesh's triangles after the one before's.
fn bench_mesh(scene: &Scene, desc: &SceneDescription) -> Option<(TriangleMesh, Option<MeshSource>)> {
    use isir::scenes::ShapeDesc;
    let meshes: Vec<isir::scene::PlacedMesh> = scene.placed_meshes().collect();
    if let [placed @ isir::scene::PlacedMesh { to_world: None, .. }] = meshes.as_slice() {
        // The file as it is, when the scene's mesh object is this plain mesh.
        let source = desc.objects.iter().find_map(|d| match &d.shape {
            ShapeDesc::Mesh { source, .. } if d.name == placed.object.name => Some(source.clone()),
            _ => None,
        });
        return Some((placed.mesh.clone(), source));
    }
    if meshes.is_empty() {
        return None;
    }
    let (mut vertices, mut triangles) = (Vec::new(), Vec::new());
    for placed in meshes {
        let first = u32::try_from(vertices.len()).ok()?;
        vertices.extend(placed.mesh.vertices.iter().map(|&v| placed.to_world.map_or(v, |t| t.transform_point3(v))));
        triangles.extend(placed.mesh.triangles.iter().map(|t| t.map(|i| i + first)));
    }
    Some((TriangleMesh::new(vertices, Vec::new(), triangles), None))
}

/// The benchmark proper, writing its files in `dir`: the report to print.
#[allow(clippy::too_many_arguments)] // the run's parts, each named
fn bench_in(
    a: &BenchArgs,
    name: &str,
    desc: &SceneDescription,
    scene: &Scene,
    mut mesh: TriangleMesh,
    source: Option<MeshSource>,
    dir: &Path,
    engines: &[Engine],
) -> anyhow::Result<String> {
    // The files this run writes in `dir`: never one the scene reads (`--keep .` beside a
    // scene's own `mesh.obj`, which the moved mesh would have replaced).
    let inputs: Vec<PathBuf> = std::iter::once(PathBuf::from(name))
        .chain(desc.objects.iter().filter_map(|o| match &o.shape {
            isir::scenes::ShapeDesc::Mesh { source: MeshSource::File(p), .. }
            | isir::scenes::ShapeDesc::MeshInstance { source: MeshSource::File(p), .. } => Some(p.clone()),
            _ => None,
        }))
        .filter_map(|p| p.canonicalize().ok())
        .collect();
    let canonical_dir = dir.canonicalize().with_context(|| format!("{}", dir.display()))?;
    let output = |file: String| -> anyhow::Result<PathBuf> {
        anyhow::ensure!(
            !inputs.contains(&canonical_dir.join(&file)),
            "--keep {}: {file} there is one of the scene's own files: keep the bench's files in another folder",
            dir.display()
        );
        let path = dir.join(file);
        // Its temporary file removed if a signal stops the write (the folder `--keep` gives
        // stays).
        crate::signals::writing([path.as_path()]);
        Ok(path)
    };

    // ---- The scene's mesh is the one traced; the four ray sets ----
    let camera = desc.camera.build(a.width as f32 / a.height as f32);
    let mut sets = Vec::new();
    for kind in RayKind::ALL {
        let label = kind.name();
        let set = rays::generate(scene, &camera, a.width, a.height, kind, a.seed)?;
        let path = output(format!("{label}.rays"))?;
        rays::write_rays(&path, &set)?;
        sets.push((label, kind, set, path));
    }

    // ---- The mesh as a plain OBJ file, for Embree ----
    let obj_path = match &source {
        Some(MeshSource::Builtin(model)) => {
            let p = output(format!("{model}.obj"))?;
            std::fs::write(&p, isir::scenes::builtin_model_obj(model)?).with_context(|| format!("writing {}", p.display()))?;
            p
        }
        Some(MeshSource::File(path)) if path.extension().is_some_and(|e| e == "obj") => path.clone(),
        _ => {
            // Compressed, another format (PLY, glTF) or placed by a transform: the loaded
            // mesh, written as OBJ (floats in their shortest exact form, so both engines
            // trace the same triangles).
            let p = output("isir-bench-mesh.obj".to_string())?;
            let mut text = String::with_capacity(mesh.vertices.len() * 40 + mesh.triangles.len() * 24);
            for v in &mesh.vertices {
                text += &format!("v {:?} {:?} {:?}\n", v.x, v.y, v.z);
            }
            for t in &mesh.triangles {
                text += &format!("f {} {} {}\n", t[0] + 1, t[1] + 1, t[2] + 1);
            }
            std::fs::write(&p, text).with_context(|| format!("writing {}", p.display()))?;
            p
        }
    };
    let threads = rayon::current_num_threads();

    let mut rounds: Vec<Round> = Vec::new();
    let mut build = None;
    for _ in 0..a.rounds {
        // ---- isir: one timed build, then every set traced with that tree ----
        let b = build_timed(&mut mesh, Accel::BvhSah, a.repeat, None)?;
        mesh.set_interleave(a.interleave);
        let mut ours: Vec<TraceFigures> = sets
            .iter()
            .map(|(_, kind, set, _)| {
                trace_timed(&mesh, set, if *kind == RayKind::Shadow { Mode::Occluded } else { Mode::Closest }, a.repeat)
            })
            .collect();
        // Coherent primary rays in packets, beside Embree's stream mode.
        ours.push(trace_timed(&mesh, &sets[0].2, Mode::Packets, a.repeat));
        if let Some(last) = rounds.last_mut() {
            // Hits are compared once, from the last round: drop the earlier ones' records.
            last.ours.iter_mut().for_each(|f| f.hit_records = Vec::new());
        }

        // ---- Each engine, on the same files ----
        let mut theirs = Vec::new();
        for e in engines {
            let mut figures = Vec::new();
            for (label, kind, _, path) in &sets {
                let hits = output(format!("{label}.{}.hits", e.label))?;
                figures.push(run_embree(&e.bin, [&obj_path, path, &hits], *kind == RayKind::Shadow, "single", a, threads)?);
            }
            let hits = output(format!("primary.{}-stream.hits", e.label))?;
            figures.push(run_embree(&e.bin, [&obj_path, &sets[0].3, &hits], false, "stream", a, threads)?);
            theirs.push(figures);
        }
        rounds.push(Round { build_ms: b.build_ms, ours, theirs });
        build = Some(b);
    }
    let build = build.expect("at least one round");
    let last = rounds.last().expect("at least one round");

    // ---- Table ----
    let mut report = String::new();
    let _ = writeln!(
        report,
        "isir bench: {name}, {} triangles ({} degenerate){}, {}x{} rays, {}, isir simd {} ({}){}{}",
        build.stats.triangles,
        build.stats.degenerate,
        match scene.placed_meshes().count() {
            0 | 1 => String::new(),
            n => format!(" (the scene's {n} meshes as one)"),
        },
        a.width,
        a.height,
        threads_phrase(threads),
        build.simd,
        match mesh.rays_in_flight() {
            1 => "single rays one at a time".to_string(),
            n => format!("single rays {n} at a time per thread"),
        },
        engine_summary(engines, &a.embree_quality, a.no_embree),
        if a.rounds > 1 { format!(", medians of {} rounds", a.rounds) } else { String::new() }
    );
    // One table per engine (the first, Embree 3's, as it has always been); without any, one
    // table of isir's figures alone.
    let size = (build.stats.triangles, f64::from(build.stats.bytes_per_triangle));
    if engines.is_empty() {
        print_table(&mut report, &rounds, &sets, size, None, dir)?;
    }
    for (i, e) in engines.iter().enumerate() {
        if i > 0 {
            report.push('\n');
        }
        print_table(&mut report, &rounds, &sets, size, Some((i, e)), dir)?;
    }
    let _ = write!(
        report,
        "sah_cost: {:.3}  nodes: {}  bytes_per_triangle: {:.1}",
        build.stats.sah_cost, build.stats.nodes, build.stats.bytes_per_triangle
    );
    for (i, (label, _, set, _)) in sets.iter().enumerate() {
        if let Some((n, t)) = last.ours[i].visits {
            let _ = write!(
                report,
                "\n{label}: {} rays, {} hits, {n:.2} node visits and {t:.2} triangle tests per ray",
                set.len(),
                last.ours[i].hits
            );
        }
    }
    Ok(report)
}

/// The header's words on the engines: Embree 3's as they have always been, then Embree 4's
/// when found.
fn engine_summary(engines: &[Engine], quality: &str, not_run: bool) -> String {
    if not_run {
        return ", Embree not run (--no-embree)".to_string();
    }
    let found = |label: &str| engines.iter().find(|e| e.label == label).map(|e| e.bin.display().to_string());
    let mut s = match found("embree") {
        Some(bin) => format!(", embree-bench {bin} (quality {quality})"),
        None => ", embree-bench not found".to_string(),
    };
    if let Some(bin) = found("embree4") {
        s += &format!(", embree4-bench {bin} (quality {quality})");
    }
    s
}

/// The ray sets as `bench_in` keeps them: label, kind, rays, file.
type RaySet = (&'static str, RayKind, Vec<isir::rays::RayRecord>, PathBuf);

/// One table: isir's figures, and with `engine` (its index in each round's figures) that
/// engine's, the per-round ratios and the hit agreement of the last round.
fn print_table(
    report: &mut String,
    rounds: &[Round],
    sets: &[RaySet],
    (triangles, our_bytes_per_tri): (usize, f64),
    engine: Option<(usize, &Engine)>,
    dir: &Path,
) -> anyhow::Result<()> {
    let label = engine.map_or("embree", |(_, e)| e.label);
    let last = rounds.last().expect("at least one round");
    let _ = writeln!(report, "{:<28} {:>12} {:>12} {:>20} {:>14}", "figure", "isir", label, format!("isir/{label}"), "hits agree");
    // One row from per-round figures: isir's, the engine's (NaN when not run), the ratio of
    // each round (inverted for times), and the hit agreement.
    let cell = |x: f64| if x.is_finite() { format!("{x:.2}") } else { "-".to_string() };
    let mut row = |label: &str, ours: &[f64], theirs: &[f64], ratio_of: Option<fn(f64, f64) -> f64>, agree: &str| {
        let ratios: Vec<f64> = match ratio_of {
            Some(f) => ours.iter().zip(theirs).map(|(&o, &t)| f(o, t)).filter(|r| r.is_finite()).collect(),
            None => Vec::new(),
        };
        let ratio = match ratios.len() {
            0 => String::new(),
            1 => format!("{:.2}", ratios[0]),
            _ => {
                let (lo, hi) = ratios.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &r| (l.min(r), h.max(r)));
                let m = median(ratios);
                // A figure that does not move (the memory) has no range to show.
                if format!("{lo:.2}") == format!("{hi:.2}") {
                    format!("{m:.2}")
                } else {
                    format!("{m:.2} ({lo:.2}-{hi:.2})")
                }
            }
        };
        let _ = writeln!(
            report,
            "{label:<28} {:>12} {:>12} {ratio:>20} {agree:>14}",
            cell(median(ours.to_vec())),
            cell(median(theirs.to_vec()))
        );
    };
    let agreement = |file: &str, ours: &[HitRecord]| -> anyhow::Result<String> {
        let theirs = rays::read_hits(&dir.join(file))?;
        // A tool that answered another number of rays answered other rays.
        anyhow::ensure!(theirs.len() == ours.len(), "{file}: the Embree tool wrote {} hit records for {} rays", theirs.len(), ours.len());
        Ok(format!("{:.4}%", 100.0 * compare_hits(ours, &theirs, 1e-4).fraction()))
    };
    // The engine's figures of each round (NaN without an engine).
    let theirs = |i: usize, key: &str| -> Vec<f64> {
        rounds.iter().map(|r| engine.and_then(|(e, _)| r.theirs[e].get(i)).map_or(f64::NAN, |m| num(m, key))).collect()
    };
    let speed = |o: f64, t: f64| o / t;
    let triangles = triangles as f64;
    let our_build: Vec<f64> = rounds.iter().map(|r| r.build_ms).collect();
    // The engine's build: the fastest of its runs in the round (each run builds).
    let their_build: Vec<f64> =
        (0..rounds.len()).map(|round| (0..=sets.len()).map(|i| theirs(i, "build_ms")[round]).fold(f64::NAN, f64::min)).collect();
    let mtris = |ms: &[f64]| ms.iter().map(|&t| triangles / (t * 1e-3) * 1e-6).collect::<Vec<_>>();
    row("build (Mtris/s)", &mtris(&our_build), &mtris(&their_build), Some(speed), "");
    row("build (ms)", &our_build, &their_build, None, "");
    // Memory of the acceleration structure per triangle (the engine's as its device memory
    // monitor counts it, the mesh's own arrays excluded on both sides); the ratio is theirs
    // over ours, so that above 1 means isir better here too.
    let our_memory = vec![our_bytes_per_tri; rounds.len()];
    let their_memory: Vec<f64> = theirs(0, "memory_bytes").iter().map(|b| b / triangles).collect();
    row("memory (B/tri)", &our_memory, &their_memory, Some(|o, t| t / o), "");
    let our_speed = |i: usize| rounds.iter().map(|r| r.ours[i].mrays_per_s()).collect::<Vec<_>>();
    for (i, (set, kind, _, _)) in sets.iter().enumerate() {
        let q = if *kind == RayKind::Shadow { "occluded" } else { "closest" };
        let agree = if engine.is_some() { agreement(&format!("{set}.{label}.hits"), &last.ours[i].hit_records)? } else { "-".to_string() };
        row(&format!("{set} {q} (Mrays/s)"), &our_speed(i), &theirs(i, "mrays_per_s"), Some(speed), &agree);
    }
    // isir's packets of 16 against Embree's stream of 256 (its best mode on these rays).
    let p = sets.len();
    let agree =
        if engine.is_some() { agreement(&format!("primary.{label}-stream.hits"), &last.ours[p].hit_records)? } else { "-".to_string() };
    row("primary packets/stream", &our_speed(p), &theirs(p, "mrays_per_s"), Some(speed), &agree);
    Ok(())
}
