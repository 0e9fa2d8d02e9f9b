//! Errors of the library: every user error names the file (and line, where there is one).

use std::path::PathBuf;

/// What can go wrong loading, building or saving.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A file could not be read or written. Its message quotes the OS error, which is
    /// also its `source()`: a printer of error chains shows that text once (as `isir`
    /// does), not after the message again.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// An input file was refused before it was parsed: not a regular file, larger than
    /// the input limit (see [`crate::io::input::ReadLimits`]), or of a format isir does not read.
    #[error("{path}: {message}")]
    Input {
        /// The file.
        path: PathBuf,
        /// Why it was refused.
        message: String,
    },
    /// A mesh file is malformed.
    #[error("{path}{}: {message}", line.map(|l| format!(":{l}")).unwrap_or_default())]
    Mesh {
        /// The file.
        path: PathBuf,
        /// The 1-based line, when known.
        line: Option<usize>,
        /// What is wrong.
        message: String,
    },
    /// A ray or hit file is malformed.
    #[error("{path}: {message}")]
    RayFile {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// No built-in scene has this name.
    #[error("unknown scene '{0}' (run 'isir scenes' for the list)")]
    UnknownScene(String),
    /// A scene description refers to something that does not exist, or is inconsistent.
    #[error("scene: {0}")]
    Scene(String),
    /// An image could not be written.
    #[error("{path}: {message}")]
    Image {
        /// The file.
        path: PathBuf,
        /// Why.
        message: String,
    },
}

/// `Result` with this crate's [`Error`].
pub type Result<T> = std::result::Result<T, Error>;
