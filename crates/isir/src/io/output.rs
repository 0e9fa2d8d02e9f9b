//! Output files written whole or not at all.
//!
//! Every file the library writes (images, ray and hit files) goes to a temporary file
//! beside its target (`.NAME.tmp-PID-N`, same directory, so the same file system);
//! every write, the flush and an `fsync` are checked; then the temporary is renamed over
//! the target. A rename is atomic: a reader, or a second writer of the same path, sees the
//! old file or the new one, never a mix, and a failed or interrupted write leaves the old
//! file as it was. On any error the temporary is removed and the error names the target.

use crate::error::{Error, Result};
use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// The buffered writer [`write_atomically`] hands to its closure: the temporary file.
pub(crate) type TempWriter<'a> = BufWriter<&'a File>;

/// A temporary file, removed when dropped unless renamed. (Not the `tempfile` crate: its
/// errors quote the temporary's name, and ours name the target.)
struct Temporary {
    path: PathBuf,
    file: File,
    renamed: bool,
}

impl Drop for Temporary {
    fn drop(&mut self) {
        if !self.renamed {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

/// Temporaries created by this process: with the process id, a name no other writer uses.
static TEMPORARIES: AtomicU64 = AtomicU64::new(0);

/// The file a write of `path` replaces: `path` itself, or where it leads when it is a
/// symbolic link (the link stays, as when the file was written in place).
///
/// # Errors
/// `path` names an existing directory or other non-regular file (a device, a FIFO: they
/// cannot be replaced by a rename), or an existing file that cannot be opened for writing.
fn target(path: &Path) -> io::Result<PathBuf> {
    let meta = match std::fs::metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(path.to_path_buf()),
        Err(e) => return Err(e),
    };
    if meta.is_dir() {
        return Err(io::Error::new(io::ErrorKind::IsADirectory, "is a directory"));
    }
    if !meta.is_file() {
        return Err(io::Error::other("not a regular file (only regular files are replaced)"));
    }
    // An existing file the user may not write is not replaced either (as `File::create`
    // would have refused); opening without truncating changes nothing.
    std::fs::OpenOptions::new().write(true).open(path)?;
    if std::fs::symlink_metadata(path)?.file_type().is_symlink() {
        return std::fs::canonicalize(path);
    }
    Ok(path.to_path_buf())
}

/// A new, empty temporary file beside `target` (`.NAME.tmp-PID-N`), with the permissions a
/// new file would get, or those of the file it replaces.
fn temporary(target: &Path) -> io::Result<Temporary> {
    let dir = match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let mut options = std::fs::OpenOptions::new();
    options.write(true).create_new(true);
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::mode(&mut options, 0o666); // less the umask, as `File::create`
                                                                  // A name left by a crashed process with the same id is skipped.
    for _ in 0..1000 {
        let n = TEMPORARIES.fetch_add(1, Ordering::Relaxed);
        let path = dir.join(format!(".{name}.tmp-{}-{n}", std::process::id()));
        match options.open(&path) {
            Ok(file) => {
                let tmp = Temporary { path, file, renamed: false };
                if let Ok(meta) = std::fs::metadata(target) {
                    tmp.file.set_permissions(meta.permissions())?;
                }
                return Ok(tmp);
            }
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {}
            Err(e) => return Err(io::Error::new(e.kind(), format!("cannot create a file in directory '{}': {e}", dir.display()))),
        }
    }
    Err(io::Error::other(format!("cannot create a temporary file in directory '{}': all names taken", dir.display())))
}

/// Check that `path` can be written as the library writes its files (see the module), by
/// creating and removing a temporary file beside it: before hours of work, not after.
///
/// # Errors
/// The directory does not exist or cannot be written, or `path` names a directory, a
/// non-regular file or a file that cannot be written; the error names `path`.
pub fn check_writable(path: &Path) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let target = target(path).map_err(io)?;
    drop(temporary(&target).map_err(io)?); // removes it
    Ok(())
}

/// Write `path` whole or not at all: `write` fills a buffered temporary file beside it,
/// which is then flushed, synced and renamed over `path`.
///
/// # Errors
/// Any error of `write`, of the flush, the sync or the rename, as [`Error::Io`] naming
/// `path`; the temporary file is removed and `path` is left as it was.
pub(crate) fn write_atomically(path: &Path, write: impl FnOnce(&mut TempWriter) -> io::Result<()>) -> Result<()> {
    let io = |source| Error::Io { path: path.to_path_buf(), source };
    let target = target(path).map_err(io)?;
    let mut tmp = temporary(&target).map_err(io)?;
    let mut w = BufWriter::new(&tmp.file);
    write(&mut w).map_err(io)?;
    // `into_inner` flushes and reports the flush's error (dropping a BufWriter would not).
    w.into_inner().map_err(|e| io(e.into_error()))?;
    tmp.file.sync_all().map_err(io)?;
    std::fs::rename(&tmp.path, &target).map_err(io)?; // on error the temporary is dropped: removed
    tmp.renamed = true;
    // Make the rename itself durable; the data is already safe, so a directory that
    // cannot be synced (some file systems refuse) is not an error.
    if let Some(dir) = target.parent().filter(|d| !d.as_os_str().is_empty()) {
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

/// An `io::Error` for a failure of an encoder that is not an I/O error.
pub(crate) fn other(e: impl std::fmt::Display) -> io::Error {
    io::Error::other(e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    fn dir(name: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("isir-output-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn leftovers(dir: &Path) -> Vec<String> {
        std::fs::read_dir(dir).unwrap().filter_map(|e| e.ok()?.file_name().into_string().ok()).filter(|n| n.contains(".tmp-")).collect()
    }

    #[test]
    fn a_failed_write_keeps_the_old_file_and_removes_the_temporary() {
        let d = dir("fail");
        let p = d.join("out.bin");
        std::fs::write(&p, b"old").unwrap();
        let e = write_atomically(&p, |w| {
            w.write_all(&[7; 100_000])?; // more than the buffer: the temporary has data
            Err(io::Error::other("disk on fire"))
        })
        .unwrap_err();
        assert_eq!(e.to_string(), format!("{}: disk on fire", p.display()));
        assert_eq!(std::fs::read(&p).unwrap(), b"old");
        assert_eq!(leftovers(&d), Vec::<String>::new());
        // A success replaces it, and leaves nothing else.
        write_atomically(&p, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new");
        assert_eq!(leftovers(&d), Vec::<String>::new());
        std::fs::remove_dir_all(&d).ok();
    }

    #[test]
    fn unwritable_places_are_reported_naming_the_path() {
        let d = dir("unwritable");
        let missing = d.join("no-such-dir").join("x.png");
        let e = check_writable(&missing).unwrap_err().to_string();
        assert!(e.starts_with(&missing.display().to_string()) && e.contains("no-such-dir"), "{e}");
        assert!(write_atomically(&missing, |w| w.write_all(b"x")).is_err());
        let e = check_writable(&d).unwrap_err().to_string();
        assert!(e.contains("directory"), "{e}");
        let file = d.join("file");
        std::fs::write(&file, b"x").unwrap();
        assert!(check_writable(&file.join("x.png")).is_err());
        check_writable(&file).unwrap();
        assert_eq!(std::fs::read(&file).unwrap(), b"x", "checking changes nothing");
        assert_eq!(leftovers(&d), Vec::<String>::new());
        #[cfg(unix)]
        assert!(check_writable(Path::new("/dev/null")).unwrap_err().to_string().contains("not a regular file"));
        std::fs::remove_dir_all(&d).ok();
    }

    #[cfg(unix)]
    #[test]
    fn a_symbolic_link_is_written_through() {
        let d = dir("link");
        let real = d.join("real.bin");
        std::fs::write(&real, b"old").unwrap();
        let link = d.join("link.bin");
        std::os::unix::fs::symlink(&real, &link).unwrap();
        write_atomically(&link, |w| w.write_all(b"new")).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&real).unwrap(), b"new");
        std::fs::remove_dir_all(&d).ok();
    }
}
