//! Signals: a file-size limit is an error, not a silent death, and Ctrl-C or `kill`
//! (SIGINT, SIGTERM, SIGHUP) leaves nothing behind.
//!
//! - SIGXFSZ is ignored from the start, so that a write past a file-size limit (`ulimit -f`)
//!   fails with EFBIG: the library's writer then removes its temporary file, keeps the old
//!   file and the error names the target (by default the signal killed the process with no
//!   message, the temporary left behind).
//! - Once a command is about to write a file or a folder it must clean up, it installs one
//!   handler ([`install`]) that, on SIGINT, SIGTERM or SIGHUP, stops the Embree tool
//!   `isir bench` runs, removes bench's temporary folder and the temporary files of the
//!   outputs being written ([`writing`]), and ends the process with status 130.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, Once, PoisonError};

/// What a signal must undo.
pub struct State {
    /// `isir bench`'s temporary folder while there is one.
    pub dir: Option<PathBuf>,
    /// The Embree tool while it runs.
    pub child: Option<u32>,
    /// The temporary files of the outputs being written: (folder, name prefix) pairs, as
    /// the library names them (`.NAME.tmp-PID-N` beside the target; see `isir::output`).
    temporaries: Vec<(PathBuf, String)>,
}

static STATE: Mutex<State> = Mutex::new(State { dir: None, child: None, temporaries: Vec::new() });

/// The state, locked: the handler waits while it is held.
pub fn state() -> MutexGuard<'static, State> {
    STATE.lock().unwrap_or_else(PoisonError::into_inner)
}

/// Ignore SIGXFSZ (at start-up): a write past the file-size limit fails with EFBIG, an
/// error like any other, instead of killing the process.
pub fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to "ignore" installs no handler code; it runs
    // at start-up, before any other thread.
    unsafe {
        let _ = nix::sys::signal::signal(nix::sys::signal::Signal::SIGXFSZ, nix::sys::signal::SigHandler::SigIgn);
    }
}

/// Install the handler (once per process; later calls do nothing). The state stays locked
/// to the end, so bench's folder removal and the tool's start wait for it.
pub fn install() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let _ = ctrlc::set_handler(|| {
            let state = state();
            #[cfg(unix)]
            if let Some(pid) = state.child.and_then(|p| i32::try_from(p).ok()) {
                let _ = nix::sys::signal::kill(nix::unistd::Pid::from_raw(pid), nix::sys::signal::Signal::SIGTERM);
            }
            if let Some(dir) = &state.dir {
                std::fs::remove_dir_all(dir).ok();
            }
            for (dir, prefix) in &state.temporaries {
                remove_temporaries(dir, prefix);
            }
            std::process::exit(130);
        });
    });
}

/// The outputs `paths` are about to be written: on a signal, their temporary files are
/// removed (the handler is installed if need be).
pub fn writing<'a>(paths: impl IntoIterator<Item = &'a Path>) {
    let mut state = state();
    for path in paths {
        // The library writes beside the path, or beside the file a symbolic link leads to.
        for target in std::iter::once(path.to_path_buf()).chain(path.canonicalize().ok()) {
            let Some(name) = target.file_name() else { continue };
            let dir = match target.parent() {
                Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
                _ => PathBuf::from("."),
            };
            let entry = (dir, format!(".{}.tmp-{}-", name.to_string_lossy(), std::process::id()));
            if !state.temporaries.contains(&entry) {
                state.temporaries.push(entry);
            }
        }
    }
    drop(state);
    install();
}

/// Remove the files in `dir` named `PREFIX` and a number: this process's temporaries of
/// one output.
fn remove_temporaries(dir: &Path, prefix: &str) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let name = e.file_name();
        let ours =
            name.to_str().and_then(|n| n.strip_prefix(prefix)).is_some_and(|n| !n.is_empty() && n.bytes().all(|b| b.is_ascii_digit()));
        if ours {
            std::fs::remove_file(e.path()).ok();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_this_processs_temporaries_of_the_output_are_removed() {
        let d = std::env::temp_dir().join(format!("isir-cli-signals-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let pid = std::process::id();
        let names = [
            format!(".out.png.tmp-{pid}-0"),
            format!(".out.png.tmp-{pid}-17"),
            format!(".out.png.tmp-{}-0", pid + 1),
            format!(".out.png.tmp-{pid}-x"),
            ".out.png".to_string(),
            "out.png".to_string(),
        ];
        for n in &names {
            std::fs::write(d.join(n), b"x").unwrap();
        }
        remove_temporaries(&d, &format!(".out.png.tmp-{pid}-"));
        let mut left: Vec<String> = std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        left.sort();
        let mut expected = names[2..].to_vec();
        expected.sort();
        assert_eq!(left, expected);
        std::fs::remove_dir_all(&d).ok();
    }
}
