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
    /// An image given with `--window NAME=IMAGE` that cannot be used: said as the option, since
    /// the scene names no such file.
    #[error("--window {pattern}={}", path.display())]
    WindowImage {
        pattern: String,
        path: PathBuf,
        #[source]
        source: Box<CookError>,
    },
    /// An image a model's material names that cannot be used: said with the material and
    /// the model, as the manifest's files are at their line (it named the image alone).
    #[error("{}: {what} of material {material:?}", model.display())]
    MaterialImage {
        model: PathBuf,
        material: String,
        what: &'static str,
        #[source]
        source: Box<CookError>,
    },
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
            CookError::WindowImage { source, .. } | CookError::MaterialImage { source, .. } => {
                source.is_io()
            }
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
            | CookError::UpAxisOfManifest { path }
            | CookError::WindowImage { path, .. } => Some(path),
            CookError::MaterialImage { source, .. } => source.path(),
            CookError::Texture(t) => t.path(),
            CookError::Pack(_) | CookError::UnknownWindow { .. } => None,
        }
    }
}

/// Exit code of the tools for bad usage: an option that names nothing (`--window` matching no
/// window), or one that does not apply to the input.
pub const EXIT_USAGE: i32 = 2;
/// Exit code of the tools for invalid input: a file that fails to parse or validate.
pub const EXIT_INVALID_INPUT: i32 = 3;
/// Exit code of the tools for an operating-system I/O error.
pub const EXIT_IO: i32 = 4;

/// The exit code the cooker and the viewer give one error of a chain when it is one of the
/// libraries' (a pack's, a cook's) or the operating system's: [`EXIT_IO`] for I/O,
/// [`EXIT_USAGE`] for an option the input gives no meaning (both tools take them), else
/// [`EXIT_INVALID_INPUT`]. `None` for any other error, which is the tool's to map.
pub fn exit_code(cause: &(dyn std::error::Error + 'static)) -> Option<i32> {
    if let Some(p) = cause.downcast_ref::<pack::PackError>() {
        return Some(if p.is_io() {
            EXIT_IO
        } else {
            EXIT_INVALID_INPUT
        });
    }
    if let Some(c) = cause.downcast_ref::<CookError>() {
        return Some(match c {
            CookError::UnknownWindow { .. } | CookError::UpAxisOfManifest { .. } => EXIT_USAGE,
            c if c.is_io() => EXIT_IO,
            _ => EXIT_INVALID_INPUT,
        });
    }
    cause.downcast_ref::<std::io::Error>().map(|_| EXIT_IO)
}
