//! `isir rays` (write a ray set) and `isir trace` (trace a ray file against a mesh).

use crate::out;
use crate::{load_mesh, warn_all, with_threads};
use clap::Args;
use isir::geometry::{MeshAccel, TriangleMesh};
use isir::rays::{self, HitRecord, RayKind, RayRecord};
use isir::wide::{Interleave, SimdLevel, TraversalStats};
use isir::Accel;
use rayon::prelude::*;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Args, Debug)]
pub struct RaysArgs {
    /// A built-in scene name (`isir scenes`), a scene file (.toml) or a mesh file (.obj,
    /// .ply, .gltf, .glb, optionally .gz).
    pub scene: String,
    /// Which ray set (primary, diffuse, shadow, random).
    #[arg(long)]
    pub kind: RayKind,
    /// Output ray file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Image width the rays are shot for.
    #[arg(long, default_value_t = 1200)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 800)]
    pub height: u32,
    /// Seed of the random directions and light points.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

#[derive(Args, Debug)]
pub struct TraceArgs {
    /// Mesh: a mesh file (.obj, .ply, .gltf, .glb, optionally .gz) or a built-in model
    /// (uvsphere, Bunny, conference).
    pub mesh: PathBuf,
    /// Ray file (docs/RAYS.md).
    pub rays: PathBuf,
    /// Write the hits to this hit file.
    #[arg(long)]
    pub hits: Option<PathBuf>,
    /// Any-hit (shadow) queries instead of closest hits.
    #[arg(long)]
    pub occluded: bool,
    /// Acceleration structure.
    /// (none, aabb, bvh-mid, bvh-sah)
    #[arg(long, default_value = "bvh-sah")]
    pub accel: Accel,
    /// Worker threads (default: one per core; at most 1024).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Time the trace this many times and keep the best (at most 1000); the build is the
    /// best of `min(K, 3)`, as the Embree tools do.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u32).range(1..=1000))]
    pub repeat: u32,
    /// Code path of the wide BVH, bvh-sah only (scalar, avx2, avx512; default: the
    /// best this CPU has).
    #[arg(long)]
    pub simd: Option<SimdLevel>,
    /// Use the watertight ray–triangle test (Woop et al.) instead of Möller–Trumbore.
    #[arg(long)]
    pub watertight: bool,
    /// Trace consecutive rays in packets of 16 (for coherent rays such as primary rays;
    /// closest hits only): AVX-512 packets on the avx512 path, AVX2 streams on the avx2
    /// one, one ray at a time on the scalar one. The hits are the single rays', except
    /// that where a ray meets two triangles at exactly one distance an AVX-512 packet may
    /// report the other one.
    #[arg(long)]
    pub packets: bool,
    /// When a thread traces 16 rays at a time, each next node prefetched while it steps
    /// the others (the same hits): auto (when the tree is larger than the CPU's
    /// last-level cache), always, never (one ray after the other; bvh-sah only).
    #[arg(long, default_value = "auto")]
    pub interleave: Interleave,
}

/// How a ray set is traced.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Closest hit, one ray at a time.
    Closest,
    /// Closest hit, packets of 16 consecutive rays.
    Packets,
    /// Any hit.
    Occluded,
}

pub fn rays(a: RaysArgs) -> anyhow::Result<()> {
    isir::image::check_size(a.width, a.height)?;
    crate::args::check_scene_arg(&a.scene)?;
    isir::output::check_writable(&a.output)?;
    crate::args::check_not_an_input("-o", &a.output, &crate::args::scene_inputs(&a.scene)?)?;
    crate::signals::writing([a.output.as_path()]);
    let (desc, scene) = crate::render::build_scene(&a.scene, Accel::BvhSah, isir::triangle::TriangleTest::MollerTrumbore)?;
    // And what its meshes read (material libraries, textures, glTF buffers).
    crate::args::check_not_an_input("-o", &a.output, &crate::args::read_by("scene", &scene.inputs))?;
    warn_all(&scene.warnings);
    let camera = desc.camera.build(a.width as f32 / a.height as f32);
    // Written as generated, a band of rows at a time: memory bounded whatever the size.
    let n = rays::write_ray_set(&a.output, &scene, &camera, a.width, a.height, a.kind, a.seed)?;
    out!("rays: {n}\nwrote: {}", a.output.display());
    Ok(())
}

/// Figures of a timed build.
#[derive(Clone, Copy, Debug)]
pub struct BuildFigures {
    pub build_ms: f64,
    pub stats: isir::geometry::MeshStats,
    /// The code path of the wide BVH ("n/a" for the other structures).
    pub simd: &'static str,
}

impl BuildFigures {
    pub fn build_mtris_per_s(&self) -> f64 {
        self.stats.triangles as f64 / (self.build_ms * 1e-3).max(1e-12) * 1e-6
    }
}

/// Figures of one traced ray set.
#[derive(Clone, Debug, Default)]
pub struct TraceFigures {
    pub rays: usize,
    pub hits: usize,
    pub trace_ms: f64,
    /// Average (wide) node visits and triangle tests per ray, when the accel counts them.
    pub visits: Option<(f64, f64)>,
    pub hit_records: Vec<HitRecord>,
}

impl TraceFigures {
    pub fn mrays_per_s(&self) -> f64 {
        self.rays as f64 / (self.trace_ms * 1e-3).max(1e-12) * 1e-6
    }
}

/// Build `mesh`'s structure `min(repeat, 3)` times (as embree-bench does) and keep the
/// fastest, then pick the wide BVH's code path.
pub fn build_timed(mesh: &mut TriangleMesh, accel: Accel, repeat: u32, simd: Option<SimdLevel>) -> anyhow::Result<BuildFigures> {
    let mut build_ms = f64::INFINITY;
    for _ in 0..repeat.clamp(1, 3) {
        let t = Instant::now();
        mesh.build_accel(accel);
        build_ms = build_ms.min(t.elapsed().as_secs_f64() * 1e3);
    }
    let fallback = mesh.stats().warning();
    warn_all(fallback.as_slice());
    if let Some(l) = simd {
        anyhow::ensure!(SimdLevel::available().contains(&l), "--simd {}: this CPU cannot run it", l.name());
        if !mesh.set_simd_level(l) {
            match fallback {
                Some(why) => anyhow::bail!("--simd applies to the wide BVH only, and this mesh has none: {why}"),
                None => anyhow::bail!("--simd applies to --accel bvh-sah only"),
            }
        }
    }
    let simd = match mesh.accel() {
        MeshAccel::Wide(w) => w.level().name(),
        _ => "n/a",
    };
    Ok(BuildFigures { build_ms, stats: mesh.stats(), simd })
}

/// Trace `rays` `repeat` times on the current pool and keep the fastest; then count node
/// visits and triangle tests in a separate, untimed pass.
pub fn trace_timed(mesh: &TriangleMesh, rays: &[RayRecord], mode: Mode, repeat: u32) -> TraceFigures {
    let occluded = mode == Mode::Occluded;
    let mut hits = vec![HitRecord::MISS; rays.len()];
    let mut trace_ms = f64::INFINITY;
    for _ in 0..repeat.max(1) {
        let t = Instant::now();
        if mode == Mode::Packets {
            rays::trace_mesh_packets(mesh, rays, &mut hits);
        } else {
            rays::trace_mesh(mesh, rays, occluded, &mut hits);
        }
        trace_ms = trace_ms.min(t.elapsed().as_secs_f64() * 1e3);
    }
    let visits = match mesh.accel() {
        MeshAccel::Wide(w) => {
            let total = rays
                .par_chunks(4096)
                .map(|chunk| {
                    let mut s = TraversalStats::default();
                    for r in chunk {
                        if occluded {
                            let _ = w.occluded_stats::<true>(&r.ray(), r.t_min, r.t_max, &mut s);
                        } else {
                            let _ = w.intersect_stats::<true>(&r.ray(), r.t_min, r.t_max, &mut s);
                        }
                    }
                    s
                })
                .reduce(TraversalStats::default, |a, b| a + b);
            let n = rays.len().max(1) as f64;
            Some((total.nodes as f64 / n, total.triangles as f64 / n))
        }
        _ => None,
    };
    TraceFigures { rays: rays.len(), hits: hits.iter().filter(|h| h.is_hit()).count(), trace_ms, visits, hit_records: hits }
}

pub fn trace(a: TraceArgs) -> anyhow::Result<()> {
    // Every check of the arguments before loading anything.
    anyhow::ensure!(!(a.packets && a.occluded), "--packets traces closest hits: drop --occluded or --packets");
    if let Some(l) = a.simd {
        anyhow::ensure!(a.accel == Accel::BvhSah, "--simd {} applies to --accel bvh-sah only, not {}", l.name(), a.accel.name());
        anyhow::ensure!(SimdLevel::available().contains(&l), "--simd {}: this CPU cannot run it", l.name());
    }
    anyhow::ensure!(
        a.interleave == Interleave::Auto || a.accel == Accel::BvhSah,
        "--interleave {} applies to --accel bvh-sah only, not {}",
        a.interleave.name(),
        a.accel.name()
    );
    anyhow::ensure!(
        !(a.packets && a.interleave == Interleave::Always),
        "--packets traces packets of 16: drop --interleave always or --packets"
    );
    crate::args::check_mesh_arg(&a.mesh.to_string_lossy())?;
    if let Some(out) = &a.hits {
        isir::output::check_writable(out)?;
        let inputs = [("the mesh".to_string(), a.mesh.clone()), ("the ray file".to_string(), a.rays.clone())];
        crate::args::check_not_an_input("--hits", out, &inputs)?;
        crate::signals::writing([out.as_path()]);
    }
    with_threads(a.threads, || trace_in_pool(&a))?
}

fn trace_in_pool(a: &TraceArgs) -> anyhow::Result<()> {
    let loaded = load_mesh(&a.mesh)?;
    if let Some(out) = &a.hits {
        // What the mesh read besides itself (material libraries, textures, glTF buffers).
        crate::args::check_not_an_input("--hits", out, &crate::args::read_by("mesh", &loaded.files))?;
    }
    // Each warning names the file (the loader's do not).
    warn_all(&loaded.warnings.iter().map(|w| format!("{}: {w}", a.mesh.display())).collect::<Vec<_>>());
    let mut mesh = loaded.mesh;
    if a.watertight {
        mesh.triangle_test = isir::triangle::TriangleTest::Watertight;
    }
    let set = rays::read_rays(&a.rays)?;
    let (accel, simd) = (a.accel, a.simd);
    let mode = if a.occluded {
        Mode::Occluded
    } else if a.packets {
        Mode::Packets
    } else {
        Mode::Closest
    };
    let b = build_timed(&mut mesh, accel, a.repeat, simd)?;
    if a.interleave != Interleave::Auto {
        anyhow::ensure!(mesh.set_interleave(a.interleave), "--interleave applies to --accel bvh-sah only");
    }
    let f = trace_timed(&mesh, &set, mode, a.repeat);
    out!("engine: isir {}", env!("CARGO_PKG_VERSION"));
    out!(
        "threads: {}\nmode: {}\naccel: {}\nsimd: {}\ntriangle_test: {:?}",
        rayon::current_num_threads(),
        match mode {
            Mode::Occluded => "occluded-single",
            Mode::Packets => "packet16",
            Mode::Closest => "single",
        },
        accel.name(),
        b.simd,
        mesh.triangle_test
    );
    if mode != Mode::Packets {
        out!("rays_in_flight: {}", mesh.rays_in_flight());
    }
    out!("triangles: {}\ndegenerate_triangles: {}\nrays: {}\nhits: {}", b.stats.triangles, b.stats.degenerate, f.rays, f.hits);
    out!("build_ms: {:.2}\nbuild_mtris_per_s: {:.2}", b.build_ms, b.build_mtris_per_s());
    out!("trace_ms: {:.2}\nmrays_per_s: {:.2}", f.trace_ms, f.mrays_per_s());
    out!("sah_cost: {:.3}\nnodes: {}\nbytes_per_triangle: {:.1}", b.stats.sah_cost, b.stats.nodes, b.stats.bytes_per_triangle);
    if let Some((n, t)) = f.visits {
        out!("avg_node_visits: {n:.2}\navg_triangle_tests: {t:.2}");
    }
    if let Some(out) = &a.hits {
        rays::write_hits(out, &f.hit_records)?;
    }
    Ok(())
}
