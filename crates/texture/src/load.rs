//! Decoding source images with limits, so a small file cannot claim a huge allocation.

use std::io::{BufRead, Cursor, Read, Seek};
use std::path::Path;

use image::{DynamicImage, ImageReader, Limits};

use crate::TextureError;
use crate::basis::{KTX2_IDENTIFIER, decode_ktx2, is_ktx2};

/// Largest side accepted, in texels (also the largest texture wgpu guarantees).
pub const MAX_SIDE: u32 = 16384;
/// Upper bound on what a decoder may allocate (a 16384² RGBA16 image fits with room to spare).
pub const MAX_DECODE_BYTES: u64 = 3 << 30;

fn io_error(path: &Path) -> impl Fn(std::io::Error) -> TextureError + '_ {
    |source| TextureError::Io {
        path: path.to_path_buf(),
        source,
    }
}

fn reader(path: &Path) -> Result<ImageReader<std::io::BufReader<std::fs::File>>, TextureError> {
    ImageReader::open(path)
        .map_err(io_error(path))?
        .with_guessed_format()
        .map_err(io_error(path))
}

/// Decodes an image file (PNG, JPEG, TGA, BMP, GIF, TIFF, WebP, PNM, QOI, ICO, HDR: 8 or 16
/// bits, grey, RGB, RGBA or palette; KTX2 with a Basis Universal payload). The header's size
/// is checked against [`MAX_SIDE`] before anything is allocated; truncated or corrupt data is
/// an error naming the file.
pub fn load_image(path: &Path) -> Result<DynamicImage, TextureError> {
    let mut head = Vec::with_capacity(KTX2_IDENTIFIER.len());
    std::fs::File::open(path)
        .and_then(|f| f.take(KTX2_IDENTIFIER.len() as u64).read_to_end(&mut head))
        .map_err(io_error(path))?;
    if is_ktx2(&head) {
        let bytes = std::fs::read(path).map_err(io_error(path))?;
        return decode_ktx2(&bytes, path);
    }
    limited(|| reader(path), path)
}

/// [`load_image`] for an image held in memory (embedded in a glTF, say); `name` is what errors
/// call it.
pub fn load_image_bytes(bytes: &[u8], name: &Path) -> Result<DynamicImage, TextureError> {
    if is_ktx2(bytes) {
        return decode_ktx2(bytes, name);
    }
    limited(
        || {
            ImageReader::new(Cursor::new(bytes))
                .with_guessed_format()
                .map_err(io_error(name))
        },
        name,
    )
}

/// Reads the header for the size, refuses what is too large or empty, then decodes with the
/// allocation limits set.
fn limited<R: BufRead + Seek>(
    open: impl Fn() -> Result<ImageReader<R>, TextureError>,
    path: &Path,
) -> Result<DynamicImage, TextureError> {
    let decode = |error| TextureError::Decode {
        path: path.to_path_buf(),
        error,
    };
    let (width, height) = open()?.into_dimensions().map_err(decode)?;
    if width > MAX_SIDE || height > MAX_SIDE {
        return Err(TextureError::TooLarge {
            path: path.to_path_buf(),
            width,
            height,
            max: MAX_SIDE,
        });
    }
    if width == 0 || height == 0 {
        return Err(TextureError::Empty { width, height });
    }
    let mut r = open()?;
    let mut limits = Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    r.limits(limits);
    r.decode().map_err(decode)
}
