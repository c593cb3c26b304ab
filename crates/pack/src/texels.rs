//! Decoding of stored texture levels to RGBA8, for readers without GPU block-compression
//! support and for tools that compare or extract texels.
//!
//! Block formats decode through `bcdec_rs`. A two-channel (BC5) normal map decodes to X and Y
//! in red and green, the rebuilt Z (`sqrt(1 - x² - y²)`, encoded as `z * 0.5 + 0.5`) in blue
//! and an opaque alpha, so it reads like an RGBA8 normal map. One channel (BC4) decodes to red
//! with zero green and blue, as a GPU samples it.

use crate::toc::{Texture, TextureFormat};

/// Decodes `bytes`, a level of `width x height` texels stored in `format` (whole blocks for
/// the block formats), to tightly packed RGBA8 of `width x height`. The caller has checked the
/// length (`TextureFormat::level_bytes`); a short input decodes the missing blocks as zero.
pub fn decode(format: TextureFormat, width: u32, height: u32, bytes: &[u8]) -> Vec<u8> {
    let native = decode_native(format, width, height, bytes);
    match format {
        TextureFormat::Rgba8 | TextureFormat::Bc7 => native,
        TextureFormat::Bc5 => {
            let z = rebuilt_z_table();
            native
                .chunks_exact(2)
                .flat_map(|c| [c[0], c[1], z[(c[0] as usize) << 8 | c[1] as usize], 255])
                .collect()
        }
        TextureFormat::Bc4 => native.iter().flat_map(|&c| [c, 0, 0, 255]).collect(),
    }
}

/// Bytes per texel of a level decoded by [`decode_native`]: the channels the format stores
/// (RGBA for RGBA8 and BC7, RG for BC5, R for BC4).
fn native_channels(format: TextureFormat) -> usize {
    match format {
        TextureFormat::Rgba8 | TextureFormat::Bc7 => 4,
        TextureFormat::Bc5 => 2,
        TextureFormat::Bc4 => 1,
    }
}

/// [`decode`]'s first step: the level in the format's own channels ([`native_channels`]),
/// which `decode` then widens to RGBA8.
fn decode_native(format: TextureFormat, width: u32, height: u32, bytes: &[u8]) -> Vec<u8> {
    let (w, h) = (width as usize, height as usize);
    let c = native_channels(format);
    let Some(block_bytes) = format.block_bytes() else {
        let mut out = bytes.to_vec();
        out.resize(w * h * 4, 0);
        return out;
    };
    let block_bytes = block_bytes as usize;
    let (bw, bh) = (w.div_ceil(4), h.div_ceil(4));
    let pitch = w * c;
    let mut out = vec![0u8; pitch * h];
    let zero = [0u8; 16];
    let mut edge = [0u8; 64];
    for by in 0..bh {
        for bx in 0..bw {
            let at = (by * bw + bx) * block_bytes;
            let block = bytes
                .get(at..at + block_bytes)
                .unwrap_or(&zero[..block_bytes]);
            let (x0, y0) = (bx * 4, by * 4);
            if x0 + 4 <= w && y0 + 4 <= h {
                // Whole blocks decode straight into the image: no copy through a block buffer.
                decode_block(format, block, &mut out[y0 * pitch + x0 * c..], pitch);
            } else {
                decode_block(format, block, &mut edge, 4 * c);
                let cols = (w - x0).min(4) * c;
                for y in 0..(h - y0).min(4) {
                    let o = (y0 + y) * pitch + x0 * c;
                    out[o..o + cols].copy_from_slice(&edge[y * 4 * c..y * 4 * c + cols]);
                }
            }
        }
    }
    out
}

/// One 4x4 block into `dst`, rows `pitch` bytes apart, in [`native_channels`] per texel.
fn decode_block(format: TextureFormat, block: &[u8], dst: &mut [u8], pitch: usize) {
    match format {
        TextureFormat::Rgba8 => unreachable!("not a block format"),
        TextureFormat::Bc7 => bcdec_rs::bc7(block, dst, pitch),
        TextureFormat::Bc5 => bcdec_rs::bc5(block, dst, pitch, false),
        TextureFormat::Bc4 => bcdec_rs::bc4(block, dst, pitch, false),
    }
}

/// [`rebuild_z`] of every (x, y), at `x << 8 | y`: decoding a normal map looks Z up instead of
/// taking a square root per texel, which was most of a BC5 level's decode time.
fn rebuilt_z_table() -> &'static [u8; 1 << 16] {
    static TABLE: std::sync::OnceLock<Box<[u8; 1 << 16]>> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = Box::new([0u8; 1 << 16]);
        for (i, z) in t.iter_mut().enumerate() {
            *z = rebuild_z((i >> 8) as u8, i as u8);
        }
        t
    })
}

/// The Z of a unit tangent-space normal from its stored X and Y (`v * 2 - 1` each), encoded
/// back to 8 bits as `z * 0.5 + 0.5`, the same formula the shaders use.
pub fn rebuild_z(x: u8, y: u8) -> u8 {
    let fx = x as f32 / 255.0 * 2.0 - 1.0;
    let fy = y as f32 / 255.0 * 2.0 - 1.0;
    let z = (1.0 - fx * fx - fy * fy).max(0.0).sqrt();
    ((z * 0.5 + 0.5) * 255.0).round() as u8
}

/// Decodes level `level` of `texture` from its stored bytes to RGBA8 of the level's logical
/// size (`texture.mips[level]`), dropping the block padding.
pub fn decode_level(texture: &Texture, level: usize, bytes: &[u8]) -> Vec<u8> {
    let (sw, sh) = texture.storage_level_size(level);
    let stored = decode(texture.format, sw, sh, bytes);
    let m = &texture.mips[level];
    crop_owned(stored, sw, m.width, m.height)
}

/// [`crop`] in place: the rows moved down over the padding, the rest cut off, so no second
/// image is held while it runs.
pub fn crop_owned(mut rgba: Vec<u8>, stride_texels: u32, width: u32, height: u32) -> Vec<u8> {
    let (row, stride) = (width as usize * 4, stride_texels as usize * 4);
    for y in 1..height as usize {
        rgba.copy_within(y * stride..y * stride + row, y * row);
    }
    rgba.truncate(height as usize * row);
    rgba
}

/// The top-left `width x height` texels of an RGBA8 image `stride_texels` wide.
pub fn crop(rgba: &[u8], stride_texels: u32, width: u32, height: u32) -> Vec<u8> {
    if stride_texels == width {
        return rgba[..width as usize * height as usize * 4].to_vec();
    }
    let mut out = Vec::with_capacity(width as usize * height as usize * 4);
    for row in rgba
        .chunks_exact(stride_texels as usize * 4)
        .take(height as usize)
    {
        out.extend_from_slice(&row[..width as usize * 4]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In place or copied, the same texels.
    #[test]
    fn crop_owned_is_crop() {
        let image: Vec<u8> = (0..7 * 5 * 4).map(|i| (i * 37 % 251) as u8).collect();
        for (w, h) in [(7, 5), (5, 5), (1, 3), (6, 1), (3, 0)] {
            assert_eq!(
                crop_owned(image.clone(), 7, w, h),
                crop(&image, 7, w, h),
                "{w}x{h}"
            );
        }
    }

    #[test]
    fn the_z_table_is_rebuild_z_everywhere() {
        let table = rebuilt_z_table();
        for x in 0..=255u8 {
            for y in 0..=255u8 {
                assert_eq!(
                    table[(x as usize) << 8 | y as usize],
                    rebuild_z(x, y),
                    "{x} {y}"
                );
            }
        }
    }

    #[test]
    fn rgba8_is_passed_through() {
        let bytes: Vec<u8> = (0..2 * 3 * 4).map(|i| i as u8).collect();
        assert_eq!(decode(TextureFormat::Rgba8, 2, 3, &bytes), bytes);
    }

    #[test]
    fn bc4_constant_block_and_crop() {
        // Endpoints 200 and 200, every index 0: every texel 200.
        let block = [200u8, 200, 0, 0, 0, 0, 0, 0];
        let out = decode(TextureFormat::Bc4, 3, 2, &block);
        assert_eq!(out.len(), 3 * 2 * 4);
        assert!(
            out.chunks_exact(4).all(|t| t == [200, 0, 0, 255]),
            "{out:?}"
        );
    }

    #[test]
    fn bc5_rebuilds_z_of_a_flat_normal() {
        // X = Y = 128 (about 0): Z = 1, stored 255.
        let block = [128u8, 128, 0, 0, 0, 0, 0, 0, 128, 128, 0, 0, 0, 0, 0, 0];
        let out = decode(TextureFormat::Bc5, 4, 4, &block);
        assert!(
            out.chunks_exact(4).all(|t| t == [128, 128, 255, 255]),
            "{out:?}"
        );
        // A tilted normal keeps unit length.
        let z = rebuild_z(255, 128) as f32 / 255.0 * 2.0 - 1.0;
        assert!(z.abs() < 0.02, "{z}");
    }

    /// Whole blocks decode in place and edge blocks through a buffer: both must give what each
    /// block decodes to on its own, at sizes with partial blocks on both edges.
    #[test]
    fn native_decode_matches_block_by_block() {
        let mut seed = 0x2545_f491_u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as u8
        };
        for format in [TextureFormat::Bc7, TextureFormat::Bc5, TextureFormat::Bc4] {
            let c = native_channels(format);
            let bb = format.block_bytes().unwrap() as usize;
            for (w, h) in [(13usize, 7usize), (8, 8), (1, 1), (4, 9), (6, 4)] {
                let (bw, bh) = (w.div_ceil(4), h.div_ceil(4));
                let bytes: Vec<u8> = (0..bw * bh * bb).map(|_| next()).collect();
                let out = decode_native(format, w as u32, h as u32, &bytes);
                assert_eq!(out.len(), w * h * c);
                let rgba = decode(format, w as u32, h as u32, &bytes);
                for by in 0..bh {
                    for bx in 0..bw {
                        let mut one = [0u8; 64];
                        let block = &bytes[(by * bw + bx) * bb..][..bb];
                        decode_block(format, block, &mut one, 4 * c);
                        for y in 0..4.min(h - by * 4) {
                            for x in 0..4.min(w - bx * 4) {
                                let (px, py) = (bx * 4 + x, by * 4 + y);
                                let want = &one[(y * 4 + x) * c..][..c];
                                assert_eq!(
                                    &out[(py * w + px) * c..][..c],
                                    want,
                                    "{format:?} {w}x{h} ({px}, {py})"
                                );
                                assert_eq!(
                                    &rgba[(py * w + px) * 4..][..c],
                                    want,
                                    "{format:?} {w}x{h} ({px}, {py})"
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn crop_keeps_the_top_left() {
        let img: Vec<u8> = (0..4 * 4 * 4).map(|i| i as u8).collect();
        let c = crop(&img, 4, 2, 1);
        assert_eq!(c, img[..8].to_vec());
    }
}
