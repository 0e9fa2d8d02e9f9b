//! `isir info MESH`: what a mesh file holds, as isir reads it.

use crate::out;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// A mesh file (.obj, .ply, .gltf, .glb, optionally .gz) or a built-in model name.
    pub mesh: PathBuf,
}

pub fn run(a: InfoArgs) -> anyhow::Result<()> {
    let loaded = crate::load_mesh(&a.mesh)?;
    let m = &loaded.mesh;
    let stats = m.stats();
    let b = m.aabb();
    out!("file:       {}", a.mesh.display());
    out!("format:     {}", loaded.format);
    out!("triangles:  {} ({} degenerate: zero area or non-finite, never hit)", stats.triangles, stats.degenerate);
    out!("vertices:   {}", m.vertices.len());
    out!(
        "normals:    {}",
        if m.normals.is_empty() { "none (face normals)".to_string() } else { format!("{} (per vertex)", m.normals.len()) }
    );
    out!("uvs:        {}", if m.uvs.is_empty() { "none".to_string() } else { format!("{} (per vertex)", m.uvs.len()) });
    if b.is_empty() {
        out!("bounds:     empty");
    } else {
        out!("bounds:     {} to {} (size {})", b.min, b.max, b.max - b.min);
    }
    out!("materials:  {}", loaded.materials.len());
    for (i, mat) in loaded.materials.iter().enumerate() {
        let used = m.material_slots.iter().filter(|&&s| s as usize == i).count();
        out!("  {:<20} colour {} ({used} triangles)", mat.name, mat.diffuse);
    }
    let unassigned = m.material_slots.iter().filter(|&&s| s as usize >= loaded.materials.len()).count();
    if unassigned > 0 {
        out!("  (no material)        {unassigned} triangles");
    }
    if loaded.warnings.is_empty() {
        out!("dropped:    nothing");
    } else {
        for w in &loaded.warnings {
            out!("note:       {w}");
        }
    }
    Ok(())
}
