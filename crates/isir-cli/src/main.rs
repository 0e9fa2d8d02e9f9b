//! The `isir` command: render the course's scenes, list them, write and trace ray files,
//! and benchmark the acceleration structures against Embree.

mod args;
mod bench;
mod check;
mod info;
mod render;
mod signals;
mod trace;

use clap::{Parser, Subcommand};

/// `println!` for the command's output, which never panics and never stops the work:
/// when standard output is a pipe whose reader has gone (`isir scenes | head -1`), the
/// rest of the output is dropped and the command goes on (its files are still written;
/// status 0); when it cannot be written otherwise (a full disk), the command goes on too
/// and ends with one error line (status 1). `println!` panicked in both cases.
macro_rules! out {
    ($($arg:tt)*) => {
        $crate::write_out(format_args!($($arg)*))
    };
}
pub(crate) use out;

/// Standard output failed: nothing more is written to it.
static STDOUT_FAILED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);
/// Its error when that was not a reader gone, said at the end.
static STDOUT_ERROR: std::sync::Mutex<Option<String>> = std::sync::Mutex::new(None);

/// What [`out!`] does.
pub fn write_out(args: std::fmt::Arguments) {
    use std::io::Write;
    use std::sync::atomic::Ordering;
    if STDOUT_FAILED.load(Ordering::Relaxed) {
        return;
    }
    let mut stdout = std::io::stdout().lock();
    if let Err(e) = stdout.write_fmt(args).and_then(|()| stdout.write_all(b"\n")) {
        STDOUT_FAILED.store(true, Ordering::Relaxed);
        if e.kind() != std::io::ErrorKind::BrokenPipe {
            STDOUT_ERROR.lock().unwrap_or_else(std::sync::PoisonError::into_inner).get_or_insert(e.to_string());
        }
    }
}

/// The error of standard output, other than a reader gone, if it failed.
fn stdout_error() -> Option<String> {
    STDOUT_ERROR.lock().unwrap_or_else(std::sync::PoisonError::into_inner).clone()
}

/// isir: a CPU ray tracer for the ISIR ray-tracing course.
#[derive(Parser, Debug)]
#[command(name = "isir", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a built-in scene (see `isir scenes`), a scene file (.toml) or a mesh file (OBJ, PLY or glTF).
    Render(render::RenderArgs),
    /// List the built-in scenes.
    Scenes,
    /// Read a scene file (.toml), load its meshes and report what it holds, without rendering.
    Check(check::CheckArgs),
    /// Describe a mesh file: format, triangles, vertices, bounds, materials, what was dropped.
    Info(info::InfoArgs),
    /// Write a ray set of a scene to a ray file (docs/RAYS.md).
    Rays(trace::RaysArgs),
    /// Trace a ray file against a mesh and print `key: value` figures.
    Trace(trace::TraceArgs),
    /// Build, trace the four ray sets of a scene and print one table (with Embree
    /// beside it when `embree3-bench` or `embree4-bench` is found).
    Bench(bench::BenchArgs),
}

/// The most worker threads `--threads` accepts: far more than any machine this runs on has
/// cores (more threads than cores only cost time), and few enough to start at once.
pub const MAX_THREADS: usize = 1024;

/// Where the thread count option leads: the global pool, or a pool of `n` threads.
pub fn with_threads<T: Send>(threads: Option<usize>, f: impl FnOnce() -> T + Send) -> anyhow::Result<T> {
    match threads {
        None => Ok(f()),
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) if n > MAX_THREADS => anyhow::bail!("--threads {n}: at most {MAX_THREADS} worker threads"),
        Some(n) => Ok(rayon::ThreadPoolBuilder::new().num_threads(n).build()?.install(f)),
    }
}

/// "1 thread", "2 threads".
pub fn threads_phrase(n: usize) -> String {
    if n == 1 {
        "1 thread".to_string()
    } else {
        format!("{n} threads")
    }
}

/// A mesh argument: a mesh file (OBJ, PLY or glTF), or the name of a built-in model.
pub fn load_mesh(arg: &std::path::Path) -> anyhow::Result<isir::obj::LoadedMesh> {
    let name = arg.to_string_lossy();
    args::check_mesh_arg(&name)?;
    if !arg.exists() {
        if isir::scenes::builtin_models().contains(&name.as_ref()) {
            return Ok(isir::scenes::load_builtin_model(&name)?);
        }
        // A built-in model's name in other letters (`bunny`): say which it is.
        if let Some(model) = isir::scenes::builtin_models().iter().find(|m| m.eq_ignore_ascii_case(&name)) {
            anyhow::bail!("{name}: no such file, and the built-in model is named '{model}'");
        }
    }
    Ok(isir::io::mesh::load_mesh(arg)?)
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
        Some(Command::Info(a)) => info::run(a),
        Some(Command::Check(a)) => check::run(a),
        Some(Command::Scenes) => {
            for (name, summary) in isir::scenes::list() {
                out!("{name:<24} {summary}");
            }
            Ok(())
        }
    }
}

/// An error and its causes on one line, each text once: the library's I/O errors quote
/// their OS error (`path: No such file or directory (os error 2)`) and also return it as
/// their `source()`, so a cause the message so far already ends with is not repeated.
fn error_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.ends_with(&text) {
            continue;
        }
        if !line.is_empty() {
            line.push_str(": ");
        }
        line.push_str(&text);
    }
    line
}

/// clap's message on one line, without the usage page: the problem, then what it lists
/// (the missing arguments, the possible values) and its suggestions.
fn clap_error_line(e: &clap::Error) -> String {
    let text = e.to_string();
    let mut line = String::new();
    for l in text.lines().map(str::trim) {
        if l.starts_with("Usage:") || l.starts_with("For more information") {
            break;
        }
        if l.is_empty() || (l.starts_with("tip:") && !l.contains("similar")) {
            continue;
        }
        let l = l.strip_prefix("error: ").unwrap_or(l);
        if line.is_empty() {
            line.push_str(l);
        } else if line.ends_with(':') || l.starts_with('[') {
            line.push(' ');
            line.push_str(l);
        } else if let Some(tip) = l.strip_prefix("tip: ") {
            line.push_str(&format!(" ({tip})"));
        } else {
            line.push_str(", ");
            line.push_str(l);
        }
    }
    if line.is_empty() {
        "bad arguments".to_string()
    } else {
        line
    }
}

fn main() {
    signals::ignore_file_size_signal();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand)
            {
                e.exit();
            }
            // One line naming the problem, not clap's usage page.
            eprintln!("isir: error: {} (see 'isir --help')", clap_error_line(&e));
            std::process::exit(2);
        }
    };
    if let Err(e) = run(cli) {
        eprintln!("isir: error: {}", error_line(&e));
        std::process::exit(1);
    }
    if let Some(e) = stdout_error() {
        eprintln!("isir: error: writing the output: {e}");
        std::process::exit(1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn os_errors_are_printed_once() {
        let io = std::io::Error::from(std::io::ErrorKind::NotFound);
        let text = io.to_string();
        let e: anyhow::Error = isir::Error::Io { path: "/x/y.rays".into(), source: io }.into();
        assert_eq!(error_line(&e), format!("/x/y.rays: {text}"));
        let e = e.context("writing the image");
        assert_eq!(error_line(&e), format!("writing the image: /x/y.rays: {text}"));
        // Causes that are not quoted are kept.
        let e = anyhow::Error::from(std::io::Error::from(std::io::ErrorKind::NotFound)).context("running embree-bench");
        assert_eq!(error_line(&e), format!("running embree-bench: {text}"));
    }

    #[test]
    fn clap_errors_fit_on_one_line_and_name_what_they_list() {
        let err = |args: &[&str]| clap_error_line(&Cli::try_parse_from(args).unwrap_err());
        assert_eq!(err(&["isir", "trace"]), "the following required arguments were not provided: <MESH>, <RAYS>");
        let e = err(&["isir", "render", "--integrator", "raycast"]);
        assert!(
            e.contains("'raycast'") && e.contains("[possible values: ray-cast, direct, whitted, path]") && e.contains("'ray-cast'"),
            "{e}"
        );
        let e = err(&["isir", "render", "--widht", "3"]);
        assert!(e.contains("'--widht'") && e.contains("'--width'") && !e.contains("Usage"), "{e}");
    }
}
