//! `isir render`.

use crate::out;
use crate::{threads_phrase, warn_all, with_threads};
use anyhow::Context;
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use isir::aov::{render_aov, Aov};
use isir::integrators::MAX_DEPTH_LIMIT;
use isir::scenes::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc};
use isir::triangle::TriangleTest;
use isir::{Accel, Display, Integrator, Renderer, Scene};
use std::path::PathBuf;
use std::time::Instant;

/// Which integrator.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum IntegratorArg {
    /// Flat colour times the cosine to the viewer.
    RayCast,
    /// Direct lighting with shadow rays.
    Direct,
    /// Whitted: mirror and glass recursion, direct lighting elsewhere.
    Whitted,
    /// Path tracing with next-event estimation and MIS.
    Path,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// A built-in scene name (`isir scenes`), a scene file (.toml, docs/scene-format.md) or a
    /// mesh file (.obj, .ply, .gltf, .glb, optionally .gz).
    pub scene: Option<String>,
    /// Output image: .png, or .exr for linear floats.
    #[arg(short, long, default_value = "isir.png")]
    pub output: PathBuf,
    /// Image width.
    /// (default: the scene file's, else 600)
    #[arg(long)]
    pub width: Option<u32>,
    /// Image height.
    /// (default: the scene file's, else 400)
    #[arg(long)]
    pub height: Option<u32>,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Samples per area light (default: the scene's).
    #[arg(long)]
    pub light_samples: Option<u32>,
    /// Acceleration structure for meshes.
    /// (none, aabb, bvh-mid, bvh-sah)
    #[arg(long, default_value = "bvh-sah")]
    pub accel: Accel,
    /// Integrator (default: the scene's).
    #[arg(long, value_enum)]
    pub integrator: Option<IntegratorArg>,
    /// Most bounces of the whitted and path integrators (default: the scene's, else 5).
    #[arg(long)]
    pub max_depth: Option<u32>,
    /// Worker threads (default: one per core; at most 1024).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the random numbers.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Use the watertight ray–triangle test (Woop et al.) instead of Möller–Trumbore.
    #[arg(long)]
    pub watertight: bool,
    /// Also write these AOVs beside the image (`isir.cost.png` for `-o isir.png`):
    /// albedo, normal, depth, or cost (a heat map of nodes visited + primitives tested per
    /// pixel, with a colour bar). Repeat or separate with commas.
    #[arg(long, value_delimiter = ',')]
    pub aov: Vec<Aov>,
}

/// True when `name` is a scene file (`.toml`).
pub fn is_scene_file(name: &str) -> bool {
    name.to_ascii_lowercase().ends_with(".toml")
}

/// The image size: the options, else the scene file's `[render]` size, else 600×400.
fn image_size(a: &RenderArgs) -> anyhow::Result<(u32, u32)> {
    let (mut w, mut h) = (600, 400);
    if let Some(name) = a.scene.as_deref().filter(|n| is_scene_file(n)) {
        let f = isir::scenes::load_scene_file(std::path::Path::new(name))?;
        w = f.width.unwrap_or(w);
        h = f.height.unwrap_or(h);
    }
    Ok((a.width.unwrap_or(w), a.height.unwrap_or(h)))
}

/// Where an AOV of the image `output` goes: `out.png` -> `out.cost.png`.
fn aov_path(output: &std::path::Path, aov: Aov) -> PathBuf {
    let stem = output.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = output.extension().map(|e| format!(".{}", e.to_string_lossy())).unwrap_or_default();
    output.with_file_name(format!("{stem}.{}{ext}", aov.name()))
}

/// A scene for a mesh file: sRGB output; camera and light are placed by [`frame`] once the
/// mesh is loaded (the file is read once).
fn file_scene(path: &str) -> SceneDescription {
    let mut d = SceneDescription::new(path, CameraDesc::new(isir::Vec3::Z, isir::Vec3::ZERO));
    d.objects.push(ObjectDesc {
        name: path.to_string(),
        shape: ShapeDesc::Mesh { source: MeshSource::File(path.into()), shading: Default::default() },
        material: None,
    });
    d.display = Display::Srgb;
    d.spp = 4;
    d
}

/// Point the camera at the built scene's meshes, from the front and a little above, with a
/// point light at the camera ([`CameraDesc::framing`]).
fn frame(path: &str, desc: &mut SceneDescription, scene: &mut Scene) -> anyhow::Result<()> {
    // Every mesh, those placed by a glTF file's nodes (instances) too.
    let b = scene.placed_meshes().fold(isir::Aabb::EMPTY, |b, p| b.union(&p.bounds));
    let (camera, light) = CameraDesc::framing(&b).with_context(|| path.to_string())?;
    desc.camera = camera;
    desc.lights = vec![light.clone()];
    scene.lights = vec![light];
    Ok(())
}

/// A built-in scene by name, or a scene around a mesh file, built on the current pool.
pub fn build_scene(name: &str, accel: Accel, test: TriangleTest) -> anyhow::Result<(SceneDescription, Scene)> {
    crate::args::check_scene_arg(name)?;
    if is_scene_file(name) {
        let d = isir::scenes::load_scene_file(std::path::Path::new(name))?.description;
        let scene = d.build_with(accel, test)?;
        return Ok((d, scene));
    }
    match isir::scenes::builtin(name) {
        Ok(d) => {
            let scene = d.build_with(accel, test)?;
            Ok((d, scene))
        }
        Err(_)
            if std::path::Path::new(name).exists()
                || name.ends_with(".obj")
                || name.ends_with(".ply")
                || name.ends_with(".gltf")
                || name.ends_with(".glb")
                || name.ends_with(".gz") =>
        {
            let mut d = file_scene(name);
            let mut scene = d.build_with(accel, test)?;
            frame(name, &mut d, &mut scene)?;
            Ok((d, scene))
        }
        Err(isir::Error::UnknownScene(_)) => Err(crate::args::unknown_scene(name)),
        Err(e) => Err(e.into()),
    }
}

pub fn run(a: RenderArgs) -> anyhow::Result<()> {
    // Every check before any work (the output's directory is writable, too).
    let name = a.scene.as_deref().unwrap_or(isir::scenes::DEFAULT_SCENE);
    crate::args::check_scene_arg(name)?;
    let (width, height) = image_size(&a)?;
    isir::image::check_size(width, height)?;
    let outputs = outputs(&a);
    let inputs = crate::args::scene_inputs(name)?;
    for out in &outputs {
        check_image_extension(out)?;
        isir::image::check_output_path(out)?;
        crate::args::check_not_an_input("-o", out, &inputs)?;
    }
    anyhow::ensure!(a.spp != Some(0), "--spp must be at least 1");
    anyhow::ensure!(a.light_samples != Some(0), "--light-samples must be at least 1");
    if let Some(d) = a.max_depth {
        anyhow::ensure!(
            (1..=MAX_DEPTH_LIMIT).contains(&d),
            "--max-depth {d}: must be between 1 and {MAX_DEPTH_LIMIT} (bounces along a path)"
        );
    }
    crate::signals::writing(outputs.iter().map(PathBuf::as_path));
    with_threads(a.threads, || render_in_pool(&a, width, height))?
}

/// The files a render writes: the image and its AOVs.
fn outputs(a: &RenderArgs) -> Vec<PathBuf> {
    std::iter::once(a.output.clone()).chain(a.aov.iter().map(|&aov| aov_path(&a.output, aov))).collect()
}

/// An image path without an extension is said to be one (the library's message, "unsupported
/// image format '.'", quoted an empty extension).
fn check_image_extension(path: &std::path::Path) -> anyhow::Result<()> {
    anyhow::ensure!(
        path.extension().is_some_and(|e| !e.is_empty()),
        "-o {}: the file name has no extension: name the image .png, or .exr for linear floats",
        path.display()
    );
    Ok(())
}

/// Render at the size `run` settled (the options, else the scene file's, else 600×400).
fn render_in_pool(a: &RenderArgs, width: u32, height: u32) -> anyhow::Result<()> {
    let name = a.scene.clone().unwrap_or_else(|| isir::scenes::DEFAULT_SCENE.to_string());
    let accel = a.accel;
    let test = if a.watertight { TriangleTest::Watertight } else { TriangleTest::MollerTrumbore };
    let t0 = Instant::now();
    let (desc, scene) = build_scene(&name, accel, test)?;
    let build_s = t0.elapsed().as_secs_f64();
    // What the meshes read (material libraries, textures, glTF buffers) is known once they
    // are loaded: still before rendering.
    let inputs = crate::args::read_by("scene", &scene.inputs);
    for out in outputs(a) {
        crate::args::check_not_an_input("-o", &out, &inputs)?;
    }
    warn_all(&scene.warnings);

    // The scene's light samples and bounces carry over to the integrator chosen.
    let (light_samples, max_depth) = (desc.integrator.light_samples(), desc.integrator.max_depth());
    let mut integrator = match a.integrator {
        Some(IntegratorArg::RayCast) => Integrator::RayCast,
        Some(IntegratorArg::Direct) => Integrator::DirectLighting { light_samples },
        Some(IntegratorArg::Whitted) => Integrator::Whitted { light_samples, max_depth },
        Some(IntegratorArg::Path) => Integrator::Path { light_samples, max_depth },
        None => desc.integrator,
    };
    if let Some(n) = a.light_samples {
        integrator = integrator.with_light_samples(n);
    }
    if let Some(d) = a.max_depth {
        if !matches!(integrator, Integrator::Whitted { .. } | Integrator::Path { .. }) {
            warn_all(&[format!("--max-depth has no effect on the {} integrator (only on whitted and path)", integrator.name())]);
        }
        integrator = integrator.with_max_depth(d);
    }
    warn_all(&integrator.warnings(&scene));
    let spp = a.spp.unwrap_or(desc.spp);
    let renderer = Renderer::new(width, height).spp(spp).seed(a.seed);
    let camera = desc.camera.build(renderer.aspect());

    let bar = ProgressBar::new(u64::from(width) * u64::from(height));
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {percent}% {elapsed_precise} (eta {eta})").unwrap().progress_chars("=> "),
    );
    bar.set_message(name.clone());
    let (image, stats) = renderer.render_with_progress(&scene, &camera, &integrator, &|n| bar.inc(n));
    bar.finish_and_clear();

    image.save(&a.output, desc.display).with_context(|| "writing the image".to_string())?;
    if image.pixels.iter().all(|&c| c == scene.background) {
        warn_all(&[format!("{name}: nothing is in view: every pixel of the image is the background")]);
    }
    let bad = stats.samples;
    if bad.nan + bad.inf > 0 {
        warn_all(&[format!("{} NaN and {} infinite pixel samples were dropped (each pixel averages its other samples)", bad.nan, bad.inf)]);
    }
    if bad.negative > 0 {
        warn_all(&[format!("{} pixel samples had a negative component", bad.negative)]);
    }
    let samples = if bad.all_good() {
        "all samples finite".to_string()
    } else {
        format!("{} NaN, {} Inf, {} negative samples", bad.nan, bad.inf, bad.negative)
    };
    out!(
        "isir: {name} {}x{} {spp} spp, {}, {}, {}: build {:.3} s, render {:.3} s, {:.2} M rays ({:.2} M primary, {:.2} M shadow, {:.2} M secondary), \
         {:.2} Mrays/s, {samples} -> wrote {}",
        width,
        height,
        integrator.name(),
        accel.name(),
        threads_phrase(rayon::current_num_threads()),
        build_s,
        stats.seconds,
        stats.rays.total() as f64 * 1e-6,
        stats.rays.primary as f64 * 1e-6,
        stats.rays.shadow as f64 * 1e-6,
        stats.rays.secondary as f64 * 1e-6,
        stats.mrays_per_second(),
        a.output.display()
    );
    for &aov in &a.aov {
        let (image, stats) = render_aov(&scene, &camera, width, height, aov);
        let path = aov_path(&a.output, aov);
        image.save(&path, Display::LinearClamp).with_context(|| format!("writing the {} AOV", aov.name()))?;
        let detail = match aov {
            Aov::Cost => format!(
                " ({}: {:.1} nodes visited and {:.1} primitives tested per camera ray; colour bar 0 to {})",
                accel.name(),
                stats.nodes_per_ray,
                stats.tests_per_ray,
                stats.max_cost
            ),
            _ => String::new(),
        };
        out!("isir: {} AOV -> wrote {}{detail}", aov.name(), path.display());
    }
    Ok(())
}
