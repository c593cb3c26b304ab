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
    let (w, h) = (width as usize, height as usize);
    let Some(block_bytes) = format.block_bytes() else {
        let mut out = bytes.to_vec();
        out.resize(w * h * 4, 0);
        return out;
    };
    let block_bytes = block_bytes as usize;
    let (bw, bh) = (w.div_ceil(4), h.div_ceil(4));
    let mut out = vec![0u8; w * h * 4];
    let zero = [0u8; 16];
    for by in 0..bh {
        for bx in 0..bw {
            let at = (by * bw + bx) * block_bytes;
            let block = bytes
                .get(at..at + block_bytes)
                .unwrap_or(&zero[..block_bytes]);
            let texels = decode_block(format, block);
            for y in 0..4 {
                let py = by * 4 + y;
                if py >= h {
                    break;
                }
                for x in 0..4 {
                    let px = bx * 4 + x;
                    if px >= w {
                        break;
                    }
                    let o = (py * w + px) * 4;
                    out[o..o + 4].copy_from_slice(&texels[y * 4 + x]);
                }
            }
        }
    }
    out
}

/// One 4x4 block to RGBA8 texels, row by row.
fn decode_block(format: TextureFormat, block: &[u8]) -> [[u8; 4]; 16] {
    let mut texels = [[0u8; 4]; 16];
    match format {
        TextureFormat::Rgba8 => unreachable!("not a block format"),
        TextureFormat::Bc7 => {
            let mut rgba = [0u8; 64];
            bcdec_rs::bc7(block, &mut rgba, 16);
            for (t, c) in texels.iter_mut().zip(rgba.chunks_exact(4)) {
                t.copy_from_slice(c);
            }
        }
        TextureFormat::Bc5 => {
            let mut rg = [0u8; 32];
            bcdec_rs::bc5(block, &mut rg, 8, false);
            let z = rebuilt_z_table();
            for (t, c) in texels.iter_mut().zip(rg.chunks_exact(2)) {
                *t = [c[0], c[1], z[(c[0] as usize) << 8 | c[1] as usize], 255];
            }
        }
        TextureFormat::Bc4 => {
            let mut r = [0u8; 16];
            bcdec_rs::bc4(block, &mut r, 4, false);
            for (t, &c) in texels.iter_mut().zip(&r) {
                *t = [c, 0, 0, 255];
            }
        }
    }
    texels
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
    crop(&stored, sw, m.width, m.height)
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

    #[test]
    fn crop_keeps_the_top_left() {
        let img: Vec<u8> = (0..4 * 4 * 4).map(|i| i as u8).collect();
        let c = crop(&img, 4, 2, 1);
        assert_eq!(c, img[..8].to_vec());
    }
}
