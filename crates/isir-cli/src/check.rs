//! `isir check FILE.toml`: read a scene file, load its meshes, report what it holds and
//! what loading had to say, without rendering.

use crate::out;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// A scene file (.toml, see docs/scene-format.md).
    pub scene: PathBuf,
}

pub fn run(a: CheckArgs) -> anyhow::Result<()> {
    crate::args::check_scene_file_arg(&a.scene.to_string_lossy())?;
    let file = isir::scenes::load_scene_file(&a.scene)?;
    let d = &file.description;
    let scene = d.build(isir::Accel::BvhSah)?;
    let triangles: usize = scene.placed_meshes().map(|p| p.mesh.triangles.len()).sum();
    out!("{}: ok", a.scene.display());
    out!("image:      {}x{}, {} spp, {}", file.width.unwrap_or(600), file.height.unwrap_or(400), d.spp, d.integrator.name());
    out!("objects:    {} ({triangles} triangles in meshes)", scene.objects.len());
    out!("materials:  {} named", d.materials.len());
    out!("lights:     {}", d.lights.len());
    for w in &scene.warnings {
        out!("warning:    {w}");
    }
    Ok(())
}
