//! The `isir` command: render the course's scenes, list them, write and trace ray files,
//! and benchmark the acceleration structures against Embree.

mod bench;
mod render;
mod trace;

use clap::{Parser, Subcommand};

/// isir: a CPU ray tracer for the ISIR ray-tracing course.
#[derive(Parser, Debug)]
#[command(name = "isir", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a built-in scene (see `isir scenes`) or an OBJ file.
    Render(render::RenderArgs),
    /// List the built-in scenes.
    Scenes,
    /// Write a ray set of a scene to a ray file (docs/RAYS.md).
    Rays(trace::RaysArgs),
    /// Trace a ray file against a mesh and print `key: value` figures.
    Trace(trace::TraceArgs),
    /// Build, trace the three ray sets of a scene and print one table (with Embree
    /// beside it when `embree-bench` is found).
    Bench(bench::BenchArgs),
}

/// Where the thread count option leads: the global pool, or a pool of `n` threads.
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    match threads {
        None => Ok(f()),
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new().num_threads(n).build()?.install(f)),
    }
}

/// A mesh argument: an OBJ file, or the name of a built-in model.
pub fn load_mesh(arg: &std::path::Path) -> anyhow::Result<isir::obj::LoadedMesh> {
    let name = arg.to_string_lossy();
    if !arg.exists() && isir::scenes::builtin_models().contains(&name.as_ref()) {
        return Ok(isir::scenes::load_builtin_model(&name)?);
    }
    Ok(isir::obj::load_obj(arg)?)
}

fn warn_all(warnings: &[String]) {
    for w in warnings {
        eprintln!("isir: warning: {w}");
    }
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        // No command: `isir render` with clap's defaults (one place for them).
        None => run(Cli::try_parse_from(["isir", "render"])?),
        Some(Command::Render(a)) => render::run(a),
        Some(Command::Rays(a)) => trace::rays(a),
        Some(Command::Trace(a)) => trace::trace(a),
        Some(Command::Bench(a)) => bench::run(a),
        Some(Command::Scenes) => {
            for (name, summary) in isir::scenes::list() {
                println!("{name:<16} {summary}");
            }
            Ok(())
        }
    }
}

fn main() {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand)
            {
                e.exit();
            }
            // One line naming the problem, not clap's usage page.
            let msg = e.to_string();
            let first = msg.lines().next().unwrap_or("bad arguments").trim_start_matches("error: ");
            eprintln!("isir: error: {first} (see 'isir --help')");
            std::process::exit(2);
        }
    };
    if let Err(e) = run(cli) {
        eprintln!("isir: error: {e:#}");
        std::process::exit(1);
    }
}
