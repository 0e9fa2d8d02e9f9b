//! Write every built-in scene that a scene file can say as `scenes/<name>.toml` (what
//! `tests/scene_files.rs` checks the shipped files against).
//!
//! ```sh
//! cargo run -p isir --example export_scenes -- scenes
//! ```

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::path::PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "scenes".into()));
    std::fs::create_dir_all(&dir)?;
    let mut n = 0;
    for (name, _) in isir::scenes::list() {
        let desc = isir::scenes::builtin(name)?;
        match isir::scenes::to_toml(&desc, (600, 400)) {
            Some(text) => {
                std::fs::write(dir.join(format!("{name}.toml")), text)?;
                n += 1;
            }
            None => eprintln!("{name}: not expressible as a scene file yet (implicit surfaces)"),
        }
    }
    eprintln!("wrote {n} scene files in {}", dir.display());
    Ok(())
}
