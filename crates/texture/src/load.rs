//! Decoding source images with limits, so a small file cannot claim a huge allocation.

use std::path::Path;

use image::{DynamicImage, ImageReader, Limits};

use crate::TextureError;

/// Largest side accepted, in texels (also the largest texture wgpu guarantees).
pub const MAX_SIDE: u32 = 16384;
/// Upper bound on what a decoder may allocate (a 16384² RGBA16 image fits with room to spare).
pub const MAX_DECODE_BYTES: u64 = 3 << 30;

fn reader(path: &Path) -> Result<ImageReader<std::io::BufReader<std::fs::File>>, TextureError> {
    let io = |source| TextureError::Io {
        path: path.to_path_buf(),
        source,
    };
    ImageReader::open(path)
        .map_err(io)?
        .with_guessed_format()
        .map_err(io)
}

/// Decodes an image file (PNG, JPEG, TGA, BMP, GIF, TIFF, WebP, PNM, QOI, ICO, HDR): 8 or 16
/// bits, grey, RGB, RGBA or palette. The header's size is checked against [`MAX_SIDE`] before
/// anything is allocated; truncated or corrupt data is a [`TextureError::Decode`] naming the file.
pub fn load_image(path: &Path) -> Result<DynamicImage, TextureError> {
    let decode = |error| TextureError::Decode {
        path: path.to_path_buf(),
        error,
    };
    let (width, height) = reader(path)?.into_dimensions().map_err(decode)?;
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
    let mut r = reader(path)?;
    let mut limits = Limits::default();
    limits.max_image_width = Some(MAX_SIDE);
    limits.max_image_height = Some(MAX_SIDE);
    limits.max_alloc = Some(MAX_DECODE_BYTES);
    r.limits(limits);
    r.decode().map_err(decode)
}
