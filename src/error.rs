//! Errors that name the file and the problem.

use std::path::{Path, PathBuf};

/// What went wrong with a file the user gave or asked for.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// The file could not be read or written. The OS error is part of the message rather
    /// than its source, so that a report of the whole chain (`{:#}`) says it once.
    #[error("{}: {cause}", path.display())]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    /// The file was read but its contents are not what they must be.
    #[error("{}: {problem}", path.display())]
    Invalid { path: PathBuf, problem: String },
}

impl Error {
    pub fn io(path: &Path, cause: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            cause,
        }
    }

    pub fn invalid(path: &Path, problem: impl Into<String>) -> Self {
        Self::Invalid {
            path: path.to_path_buf(),
            problem: problem.into(),
        }
    }
}

pub type Result<T, E = Error> = std::result::Result<T, E>;
