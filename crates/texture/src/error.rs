use std::path::PathBuf;

/// Everything that can go wrong while loading or cooking a texture. Each variant carries the
/// file (where there is one) and the offending value, so a message is actionable on its own.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    // The wrapped error is the `source`, printed by whoever prints the chain (`{:#}`).
    #[error("{}: cannot read", path.display())]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    // Not a `source`: image's errors print their own cause in their message and return it
    // again as their source, so a chain printer would repeat it.
    #[error("{}: cannot decode image: {}", path.display(), decoder_message(error))]
    Decode {
        path: PathBuf,
        error: image::ImageError,
    },
    #[error("{}: cannot decode KTX2/Basis Universal texture: {reason}", path.display())]
    Basis { path: PathBuf, reason: String },
    #[error("{}: cannot decode DDS texture: {reason}", path.display())]
    Dds { path: PathBuf, reason: String },
    #[error(
        "{}: image claims {width}x{height} texels, over the limit of {max}x{max}",
        path.display()
    )]
    TooLarge {
        path: PathBuf,
        width: u32,
        height: u32,
        max: u32,
    },
    #[error("image is {width}x{height}; both sides must be at least 1 texel")]
    Empty { width: u32, height: u32 },
    #[error(
        "{}: the {what} file is cut short (it ends before its end-of-image marker)",
        path.display()
    )]
    Truncated { path: PathBuf, what: &'static str },
    #[error("blur sigma {sigma} texels is invalid: it must be from 0 to {max}", max = crate::MAX_SIGMA)]
    InvalidSigma { sigma: f32 },
    #[error("error budget {budget} LSB is invalid: it must be finite and >= 0")]
    InvalidBudget { budget: f32 },
    #[error(
        "projector margin of {margin} texels is wider than the {width}x{height} design's longer side"
    )]
    MarginTooWide {
        margin: u32,
        width: u32,
        height: u32,
    },
}

impl TextureError {
    /// True when the operating system failed us (exit 4), false for bad input (exit 3).
    pub fn is_io(&self) -> bool {
        match self {
            Self::Io { .. } => true,
            // Decoders report a truncated file as an I/O error; that is bad input, not the OS.
            Self::Decode {
                error: image::ImageError::IoError(e),
                ..
            } => !matches!(
                e.kind(),
                std::io::ErrorKind::UnexpectedEof
                    | std::io::ErrorKind::InvalidData
                    | std::io::ErrorKind::InvalidInput
            ),
            _ => false,
        }
    }

    /// The file the error is about, if it is about a file.
    pub fn path(&self) -> Option<&std::path::Path> {
        match self {
            Self::Io { path, .. }
            | Self::Truncated { path, .. }
            | Self::Decode { path, .. }
            | Self::Basis { path, .. }
            | Self::Dds { path, .. }
            | Self::TooLarge { path, .. } => Some(path),
            _ => None,
        }
    }
}

/// The decoder's message, with what it prints for a programmer made readable: the png crate
/// names a chunk by its `Debug` form, `ChunkType { type: IHDR, critical: true, … }`.
fn decoder_message(e: &image::ImageError) -> String {
    const CHUNK: &str = "ChunkType { type: ";
    let s = e.to_string();
    let mut out = String::with_capacity(s.len());
    let mut rest = s.as_str();
    while let Some(i) = rest.find(CHUNK) {
        out.push_str(&rest[..i]);
        let after = &rest[i + CHUNK.len()..];
        let name = after.find([',', ' ', '}']).unwrap_or(after.len());
        out.push_str(&after[..name]);
        rest = after.find('}').map_or("", |j| &after[j + 1..]);
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_png_chunk_is_named_by_its_type() {
        let png = std::fs::read(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../assets-src/windows/lancet.png"
        ))
        .unwrap();
        let mut bad = png.clone();
        // The IHDR chunk's CRC: 8 bytes of signature, 8 of length and type, 13 of data.
        bad[29] ^= 0xff;
        let error = image::load_from_memory(&bad).unwrap_err();
        let e = TextureError::Decode {
            path: "w.png".into(),
            error,
        };
        let said = e.to_string();
        assert!(said.starts_with("w.png: cannot decode image: "), "{said}");
        assert!(said.ends_with("while decoding IHDR chunk."), "{said}");
        assert!(!said.contains("ChunkType"), "{said}");
    }
}
