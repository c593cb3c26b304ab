//! Cooks scene sources (OBJ, glTF, window images) into a pack.

use std::path::PathBuf;

/// An error while cooking, naming the file (and line or offset where there is one).
#[derive(Debug, thiserror::Error)]
pub enum CookError {
    #[error("{}: {source}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Pack(#[from] pack::PackError),
}

impl CookError {
    /// True when the operating system failed (permission, disk full, missing directory), as
    /// opposed to invalid input.
    pub fn is_io(&self) -> bool {
        match self {
            CookError::Io { .. } => true,
            CookError::Pack(p) => p.is_io(),
        }
    }
}
