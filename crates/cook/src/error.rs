//! The cook's one error type.

use std::path::{Path, PathBuf};

/// An error while cooking, naming the file (and line where there is one). Wrapped errors are
/// the `source`, not repeated in the message.
#[derive(Debug, thiserror::Error)]
pub enum CookError {
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error(transparent)]
    Pack(#[from] pack::PackError),
    /// An image could not be read or cooked; the message names the file.
    #[error(transparent)]
    Texture(#[from] texture::TextureError),
    /// The manifest is malformed: syntax, unknown key, wrong type, bad value, missing file.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Manifest {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
    /// `--window NAME=…` names no window of the scene.
    #[error("--window {pattern:?} matches no window; the scene's windows are: {}", if known.is_empty() { "(none)".to_string() } else { known.join(", ") })]
    UnknownWindow { pattern: String, known: Vec<String> },
    /// `--up` with a scene manifest, which turns its meshes itself.
    #[error(
        "--up turns a bare model; {} is a scene manifest: give its [[mesh]] \
         `rotate_deg = [-90.0, 0.0, 0.0]` instead",
        path.display()
    )]
    UpAxisOfManifest { path: PathBuf },
    /// A source file (mesh, material library, image) is malformed.
    #[error("{}{}: {message}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Source {
        path: PathBuf,
        line: Option<usize>,
        message: String,
    },
}

impl CookError {
    /// True when the operating system failed (permission, disk full, missing directory), as
    /// opposed to invalid input.
    pub fn is_io(&self) -> bool {
        match self {
            CookError::Io { .. } => true,
            CookError::Pack(p) => p.is_io(),
            CookError::Texture(t) => t.is_io(),
            CookError::Manifest { .. }
            | CookError::Source { .. }
            | CookError::UnknownWindow { .. }
            | CookError::UpAxisOfManifest { .. } => false,
        }
    }

    /// The file the error is about.
    pub fn path(&self) -> Option<&Path> {
        match self {
            CookError::Io { path, .. }
            | CookError::Manifest { path, .. }
            | CookError::Source { path, .. }
            | CookError::UpAxisOfManifest { path } => Some(path),
            CookError::Texture(t) => t.path(),
            CookError::Pack(_) | CookError::UnknownWindow { .. } => None,
        }
    }
}
