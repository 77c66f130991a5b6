//! The one error type of host-trainer.

use std::fmt;
use std::path::PathBuf;

/// Everything that can stop training, export or evaluation.
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// A blob could not be written or read by policy-core.
    Blob(policy_core::Error),
    /// The network shape has no compiled policy-core type.
    UnsupportedShape {
        /// The requested shape, e.g. "2 obs, 5x48 hidden, 2 actions".
        shape: String,
        /// The shapes that are compiled in.
        supported: &'static str,
    },
    /// Sizes that do not fit together (network, normaliser, bounds, batch).
    ShapeMismatch {
        /// What was being combined.
        what: &'static str,
        /// The size expected.
        expected: usize,
        /// The size found.
        found: usize,
    },
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Blob(e) => write!(f, "blob: {e}"),
            Error::UnsupportedShape { shape, supported } => {
                write!(f, "unsupported network shape {shape} (compiled shapes: {supported})")
            }
            Error::ShapeMismatch { what, expected, found } => {
                write!(f, "{what}: expected size {expected}, found {found}")
            }
            Error::Io { path, source } => write!(f, "{}: {source}", path.display()),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Blob(e) => Some(e),
            Error::Io { source, .. } => Some(source),
            _ => None,
        }
    }
}

impl From<policy_core::Error> for Error {
    fn from(e: policy_core::Error) -> Self {
        Error::Blob(e)
    }
}
