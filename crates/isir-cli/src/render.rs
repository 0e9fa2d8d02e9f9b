//! `isir render`.

use crate::{warn_all, with_threads, AccelArg};
use anyhow::Context;
use clap::{Args, ValueEnum};
use indicatif::{ProgressBar, ProgressStyle};
use isir::scene::{CameraDesc, MeshSource, ObjectDesc, SceneDescription, ShapeDesc};
use isir::{Accel, Display, Integrator, Renderer};
use std::path::PathBuf;
use std::time::Instant;

/// Which integrator.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum IntegratorArg {
    /// Flat colour times the cosine to the viewer.
    RayCast,
    /// Direct lighting with shadow rays.
    Direct,
}

#[derive(Args, Debug)]
pub struct RenderArgs {
    /// A built-in scene name (`isir scenes`) or an OBJ file (.obj, .obj.gz).
    pub scene: Option<String>,
    /// Output image: .png, or .exr for linear floats.
    #[arg(short, long, default_value = "isir.png")]
    pub output: PathBuf,
    /// Image width.
    #[arg(long, default_value_t = 600)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 400)]
    pub height: u32,
    /// Samples per pixel (default: the scene's).
    #[arg(long)]
    pub spp: Option<u32>,
    /// Samples per area light (default: the scene's).
    #[arg(long)]
    pub light_samples: Option<u32>,
    /// Acceleration structure for meshes.
    #[arg(long, value_enum, default_value_t = AccelArg::BvhSah)]
    pub accel: AccelArg,
    /// Integrator (default: the scene's).
    #[arg(long, value_enum)]
    pub integrator: Option<IntegratorArg>,
    /// Worker threads (default: one per core).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Seed of the random numbers.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Use the watertight ray–triangle test (Woop et al.) instead of Möller–Trumbore.
    #[arg(long)]
    pub watertight: bool,
}

impl Default for RenderArgs {
    fn default() -> Self {
        Self {
            scene: None,
            output: "isir.png".into(),
            width: 600,
            height: 400,
            spp: None,
            light_samples: None,
            accel: AccelArg::BvhSah,
            integrator: None,
            threads: None,
            seed: 0,
            watertight: false,
        }
    }
}

/// A scene for a mesh file: the camera in front of its box, a point light at the camera.
fn file_scene(path: &str) -> anyhow::Result<SceneDescription> {
    let loaded = crate::load_mesh(path.as_ref())?;
    let b = loaded.mesh.aabb();
    anyhow::ensure!(!b.is_empty(), "{path}: the mesh has no triangle to look at");
    let c = b.centroid();
    let r = b.diagonal().length().max(1e-6);
    let eye = c + isir::Vec3::new(0.0, 0.25, 1.0).normalize() * r * 1.1;
    let mut d = SceneDescription::new(path, CameraDesc::new(eye, c));
    d.objects.push(ObjectDesc {
        name: path.to_string(),
        shape: ShapeDesc::Mesh { source: MeshSource::File(path.into()), shading: Default::default() },
        material: None,
    });
    d.lights.push(isir::Light::Point { position: eye, color: isir::color::WHITE, power: 1.2 * r * r });
    d.display = Display::Srgb;
    d.spp = 4;
    Ok(d)
}

/// A built-in scene by name, or a scene around an OBJ file.
pub fn scene_description(name: &str) -> anyhow::Result<SceneDescription> {
    match isir::scenes::builtin(name) {
        Ok(d) => Ok(d),
        Err(_) if std::path::Path::new(name).exists() || name.ends_with(".obj") || name.ends_with(".gz") => file_scene(name),
        Err(e) => Err(e.into()),
    }
}

pub fn run(a: RenderArgs) -> anyhow::Result<()> {
    isir::image::check_size(a.width, a.height)?;
    isir::image::check_output_path(&a.output)?;
    let name = a.scene.clone().unwrap_or_else(|| isir::scenes::DEFAULT_SCENE.to_string());
    let desc = scene_description(&name)?;
    let accel: Accel = a.accel.into();
    let t0 = Instant::now();
    let test = if a.watertight { isir::triangle::TriangleTest::Watertight } else { isir::triangle::TriangleTest::MollerTrumbore };
    let scene = with_threads(a.threads, || desc.build_with(accel, test))??;
    let build_s = t0.elapsed().as_secs_f64();
    warn_all(&scene.warnings);

    let mut integrator = match a.integrator {
        Some(IntegratorArg::RayCast) => Integrator::RayCast,
        Some(IntegratorArg::Direct) => match desc.integrator {
            Integrator::DirectLighting { light_samples } => Integrator::DirectLighting { light_samples },
            Integrator::RayCast => Integrator::DirectLighting { light_samples: 1 },
        },
        None => desc.integrator,
    };
    if let Some(n) = a.light_samples {
        anyhow::ensure!(n > 0, "--light-samples must be at least 1");
        integrator = integrator.with_light_samples(n);
    }
    let spp = a.spp.unwrap_or(desc.spp);
    anyhow::ensure!(spp > 0, "--spp must be at least 1");
    let renderer = Renderer::new(a.width, a.height).spp(spp).seed(a.seed);
    let camera = desc.camera.build(renderer.aspect());

    let bar = ProgressBar::new(u64::from(a.width) * u64::from(a.height));
    bar.set_style(
        ProgressStyle::with_template("{spinner} {msg} [{bar:40}] {percent}% {elapsed_precise} (eta {eta})").unwrap().progress_chars("=> "),
    );
    bar.set_message(name.clone());
    let (image, stats) = with_threads(a.threads, || renderer.render_with_progress(&scene, &camera, &integrator, &|n| bar.inc(n)))?;
    bar.finish_and_clear();

    image.save(&a.output, desc.display).with_context(|| "writing the image".to_string())?;
    let threads = a.threads.unwrap_or_else(rayon::current_num_threads);
    println!(
        "isir: {name} {}x{} {spp} spp, {}, {threads} threads: build {:.3} s, render {:.3} s, {:.2} M rays ({:.2} M primary, {:.2} M shadow), {:.2} Mrays/s -> wrote {}",
        a.width,
        a.height,
        accel.name(),
        build_s,
        stats.seconds,
        stats.rays.total() as f64 * 1e-6,
        stats.rays.primary as f64 * 1e-6,
        stats.rays.shadow as f64 * 1e-6,
        stats.mrays_per_second(),
        a.output.display()
    );
    Ok(())
}
