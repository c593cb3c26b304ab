//! Colour mip chains: filtered in linear light with alpha weighting, re-encoded once per level.

use image::DynamicImage;
use rayon::prelude::*;

use crate::TextureError;
use crate::pixels::{Texel, to_linear};
use crate::real::{Real, clamp01};
use crate::resample::{MipFilter, half, next_level, walk_chain};
use crate::srgb::{encoder, unorm8};

/// A texture's levels as stored in a pack: tightly packed RGBA8 rows, level 0 first, each level
/// `max(1, previous / 2)` texels on each axis, down to 1x1 (the rule of `pack::Texture`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MipChain {
    pub width: u32,
    pub height: u32,
    pub levels: Vec<Vec<u8>>,
}

impl MipChain {
    /// Size of a level.
    pub fn level_size(&self, level: usize) -> (u32, u32) {
        level_size(self.width, self.height, level)
    }
}

/// Size of level `level` of a `width x height` texture.
pub fn level_size(width: u32, height: u32, level: usize) -> (u32, u32) {
    let (mut w, mut h) = (width, height);
    for _ in 0..level {
        (w, h) = (half(w), half(h));
    }
    (w, h)
}

/// Number of levels of a full chain down to 1x1.
pub fn level_count(width: u32, height: u32) -> usize {
    (32 - width.max(height).max(1).leading_zeros()) as usize
}

/// How a colour texture is cooked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ColourOptions {
    /// Colour channels are sRGB-encoded (decoded to linear before filtering, re-encoded after).
    /// When false they are filtered and stored as they are.
    pub srgb: bool,
    pub filter: MipFilter,
}

impl Default for ColourOptions {
    fn default() -> Self {
        Self {
            srgb: true,
            filter: MipFilter::Box,
        }
    }
}

/// Colour weight of a fully transparent texel, relative to an opaque one. Premultiplied filtering
/// would weight it 0 and lose its colour; this keeps a fully transparent region's colour (so a
/// constant image stays constant) while moving any partly opaque result by under 1e-5 of the
/// colour difference.
const TRANSPARENT_WEIGHT: f64 = 1.0 / 16_777_216.0;

pub(crate) fn check_size(width: u32, height: u32) -> Result<(), TextureError> {
    if width == 0 || height == 0 {
        return Err(TextureError::Empty { width, height });
    }
    Ok(())
}

/// Straight linear colour and alpha → alpha-weighted form (colour·(a+δ), a+δ).
#[inline]
fn weighted<T: Real>(t: [T; 4]) -> [T; 4] {
    let q = t[3] + T::of(TRANSPARENT_WEIGHT);
    [t[0] * q, t[1] * q, t[2] * q, q]
}

/// Inverse of [`weighted`] after filtering, clamped to [0, 1] (windowed filters overshoot).
#[inline]
fn unweighted<T: Real>(t: [T; 4]) -> [T; 4] {
    let d = T::of(TRANSPARENT_WEIGHT);
    let q = t[3];
    if q > d * T::of(0.5) {
        [
            clamp01(t[0] / q),
            clamp01(t[1] / q),
            clamp01(t[2] / q),
            clamp01(q - d),
        ]
    } else {
        // Negative lobes cancelled all coverage: nothing left to show.
        [T::of(0.0); 4]
    }
}

/// The whole chain in the working precision, straight linear RGBA per level.
pub fn colour_levels<T: Real>(
    level0: Vec<[T; 4]>,
    w: u32,
    h: u32,
    filter: MipFilter,
) -> Vec<Vec<[T; 4]>> {
    let mut levels = Vec::new();
    each_level(level0, 0, w, h, filter, |l| levels.push(l));
    levels
}

/// Level `first`'s texels and every coarser level of a `w x h` texture, in order, each handed
/// to `emit` once the next is filtered from it (see [`walk_chain`]).
fn each_level<T: Real>(
    level: Vec<[T; 4]>,
    first: usize,
    w: u32,
    h: u32,
    filter: MipFilter,
    emit: impl FnMut(Vec<[T; 4]>),
) {
    let (lw, lh) = level_size(w, h, first);
    let next = |level: &[[T; 4]], lw: u32, lh: u32| {
        next_level(level, lw, lh, filter, weighted, unweighted)
    };
    walk_chain(level, lw, lh, next, emit);
}

/// One texel of the colour chain's [`crate::resample::box2`] (alpha-weighted before, unweighted
/// after): the 2x2 block `a b / c d`.
#[inline(always)]
fn box_block<T: Real>(a: [T; 4], b: [T; 4], c: [T; 4], d: [T; 4]) -> [T; 4] {
    unweighted(crate::resample::box_block([a, b, c, d].map(weighted)))
}

/// Level 1 of an even-sized sRGB RGBA8 image straight from its bytes: the colour chain's
/// [`crate::resample::box2`] of the texels [`to_linear`] would give (so the same bits), without
/// a full-size f32 copy of level 0.
fn box2_srgb8(src: &[u8], w: usize) -> Vec<Texel> {
    let texel = |b: &[u8]| crate::pixels::texel8([b[0], b[1], b[2], b[3]]);
    let w2 = w / 2;
    let mut out = vec![[0.0f32; 4]; w2 * (src.len() / (8 * w))];
    out.par_chunks_mut(w2).enumerate().for_each(|(y, o)| {
        let r0 = &src[2 * y * w * 4..(2 * y + 1) * w * 4];
        let r1 = &src[(2 * y + 1) * w * 4..(2 * y + 2) * w * 4];
        for ((o, t0), t1) in o.iter_mut().zip(r0.chunks_exact(8)).zip(r1.chunks_exact(8)) {
            *o = box_block(
                texel(&t0[..4]),
                texel(&t0[4..]),
                texel(&t1[..4]),
                texel(&t1[4..]),
            );
        }
    });
    out
}

/// An 8-bit sRGB image's bytes and the level 1 of its colour chain made straight from them:
/// the texels [`to_linear`] would give, so the same bits, without a full-size f32 copy of
/// level 0 (a 4097² design's was 269 MB). An even-sized box reduction is one pass
/// ([`box2_srgb8`]); any other size or filter decodes only the rows a band of output rows
/// reaches. `None` for an image not held as 8-bit sRGB, or of one texel.
fn level1_from_bytes<'a>(
    img: &'a DynamicImage,
    opts: &ColourOptions,
) -> Option<(std::borrow::Cow<'a, [u8]>, Vec<Texel>)> {
    let (w, h) = (img.width(), img.height());
    if !opts.srgb || w.max(h) < 2 {
        return None;
    }
    let bytes = crate::pixels::rgba8_bytes(img)?;
    let level1 = if opts.filter == MipFilter::Box && w % 2 == 0 && h % 2 == 0 {
        box2_srgb8(&bytes, w as usize)
    } else {
        let row = w as usize * 4;
        crate::resample::reduce_to_by_rows(
            w,
            h,
            half(w),
            half(h),
            opts.filter,
            32,
            |rows| {
                bytes[rows.start * row..rows.end * row]
                    .par_chunks_exact(4)
                    .map(|b| crate::pixels::texel8([b[0], b[1], b[2], b[3]]))
                    .collect()
            },
            weighted,
            unweighted,
        )
    };
    Some((bytes, level1))
}

/// Encodes straight linear RGBA to RGBA8 (sRGB or plain unorm colour, unorm alpha).
pub fn encode_level(level: &[Texel], srgb: bool) -> Vec<u8> {
    let mut out = vec![0u8; level.len() * 4];
    out.par_chunks_mut(4 * 1024)
        .zip(level.par_chunks(1024))
        .for_each(|(o, l)| {
            let e = encoder();
            if srgb {
                e.encode_rgba(l, o);
                return;
            }
            for (o, t) in o.chunks_exact_mut(4).zip(l) {
                for c in 0..3 {
                    o[c] = if srgb { e.encode(t[c]) } else { unorm8(t[c]) };
                }
                o[3] = unorm8(t[3]);
            }
        });
    out
}

/// Cooks a colour texture: level 0 at the source's resolution, then a full chain to 1x1,
/// filtered in linear light (f32) with alpha-weighted (premultiplied) filtering and re-encoded
/// once per level with correct rounding. An 8-bit sRGB source's level 0 is its own bytes.
pub fn colour_mips(img: &DynamicImage, opts: &ColourOptions) -> Result<MipChain, TextureError> {
    let (w, h) = (img.width(), img.height());
    check_size(w, h)?;
    let mut levels = Vec::new();
    // Each level is encoded as soon as the next is filtered from it, and its f32 copy dropped:
    // the f32 chain of a 4096² image was 341 MiB held whole.
    match level1_from_bytes(img, opts) {
        // Level 0 is the source's bytes: decoding then re-encoding 8-bit sRGB gives back every
        // code (a unit test checks the tables).
        Some((bytes, level1)) => {
            levels.push(bytes.into_owned());
            each_level(level1, 1, w, h, opts.filter, |l| {
                levels.push(encode_level(&l, opts.srgb))
            });
        }
        _ => each_level(to_linear(img, opts.srgb), 0, w, h, opts.filter, |l| {
            levels.push(encode_level(&l, opts.srgb))
        }),
    }
    Ok(MipChain {
        width: w,
        height: h,
        levels,
    })
}

/// The first level of `img`'s colour chain (as [`colour_mips`] makes it, with `opts`) at most
/// `max_side` texels a side: its level number, and the level as an RGBA8 image with the same
/// bits; `None` when `img` already fits. For a cap on the size of stored textures. A chain cooked from it may differ from the
/// whole chain's smaller levels by a rounding step: the whole chain carries each level to the
/// next in f32, and this one starts again from the level's 8-bit encoding. Only the levels on
/// the way are made, and an 8-bit sRGB image's level 1 comes from its bytes, as in
/// `colour_mips`.
pub fn first_level_within(
    img: &DynamicImage,
    max_side: u32,
    opts: &ColourOptions,
) -> Result<Option<(usize, DynamicImage)>, TextureError> {
    let (w, h) = (img.width(), img.height());
    check_size(w, h)?;
    if w.max(h) <= max_side {
        return Ok(None);
    }
    // The 1x1 level fits any cap of at least 1.
    let target = (1..level_count(w, h))
        .find(|&k| {
            let (lw, lh) = level_size(w, h, k);
            lw.max(lh) <= max_side.max(1)
        })
        .unwrap_or(level_count(w, h) - 1);
    let (mut level, mut at) = match level1_from_bytes(img, opts) {
        Some((_, level1)) => (level1, 1),
        None => (to_linear(img, opts.srgb), 0),
    };
    while at < target {
        let (lw, lh) = level_size(w, h, at);
        level = next_level(&level, lw, lh, opts.filter, weighted, unweighted);
        at += 1;
    }
    let (lw, lh) = level_size(w, h, target);
    let bytes = encode_level(&level, opts.srgb);
    let image = image::RgbaImage::from_raw(lw, lh, bytes).expect("a level's bytes fill its size");
    Ok(Some((target, DynamicImage::ImageRgba8(image))))
}

/// The same chain computed in f64 throughout and not rounded: the reference the f32 chain is
/// measured against. Level `i` holds straight linear RGBA.
pub fn colour_mips_reference(
    img: &DynamicImage,
    opts: &ColourOptions,
) -> Result<Vec<Vec<[f64; 4]>>, TextureError> {
    let (w, h) = (img.width(), img.height());
    check_size(w, h)?;
    let level0 = to_linear(img, opts.srgb)
        .into_iter()
        .map(|t| t.map(|v| v as f64))
        .collect();
    Ok(colour_levels::<f64>(level0, w, h, opts.filter))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The level a cap picks is the whole chain's level of that size, to the bit, whichever
    /// way its first reduction is made (from the bytes, by rows, or from f32 texels).
    #[test]
    fn the_first_level_within_a_cap_is_the_chain_s_level() {
        let panes = crate::testing::Panes {
            width: 7,
            height: 5,
            lead: 1,
        };
        for (w, h, srgb, filter) in [
            (130u32, 96u32, true, MipFilter::Box),
            (129, 96, true, MipFilter::Box),
            (130, 97, true, MipFilter::Box),
            (130, 96, false, MipFilter::Box),
            (130, 96, true, MipFilter::Lanczos3),
        ] {
            let bytes = crate::testing::design(w as usize, h as usize, 4, panes);
            let img = DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w, h, bytes).unwrap());
            let opts = ColourOptions { srgb, filter };
            let chain = colour_mips(&img, &opts).unwrap();
            assert_eq!(first_level_within(&img, w.max(h), &opts).unwrap(), None);
            for cap in [w.max(h) - 1, 65, 64, 33, 1, 0] {
                let (got_level, got) = first_level_within(&img, cap, &opts).unwrap().unwrap();
                let level = (1..chain.levels.len())
                    .find(|&k| {
                        let (lw, lh) = chain.level_size(k);
                        lw.max(lh) <= cap.max(1)
                    })
                    .unwrap();
                let (lw, lh) = chain.level_size(level);
                assert_eq!(got_level, level, "{w}x{h} cap {cap}");
                assert_eq!((got.width(), got.height()), (lw, lh), "{w}x{h} cap {cap}");
                assert_eq!(
                    got.as_bytes(),
                    &chain.levels[level][..],
                    "{w}x{h} {opts:?} cap {cap}"
                );
            }
        }
    }

    /// The chain from an 8-bit source's bytes must be the chain of its f32 decode, whichever
    /// way level 1 is made (whole rows, or bands of rows for an odd width).
    #[test]
    fn a_chain_from_bytes_is_the_chain_of_the_decoded_texels() {
        let panes = crate::testing::Panes {
            width: 7,
            height: 5,
            lead: 1,
        };
        // Odd heights and other filters too: banded from the bytes, a 4097² design's level 0
        // is never held in f32 (269 MB).
        for filter in [MipFilter::Box, MipFilter::Kaiser, MipFilter::Lanczos3] {
            for (w, h) in [
                (37u32, 130u32),
                (129, 200),
                (5, 2),
                (1, 256),
                (64, 66),
                (3, 129),
                (65, 97),
                (130, 1),
                (1, 1),
            ] {
                let bytes = crate::testing::design(w as usize, h as usize, 9, panes);
                let img =
                    DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w, h, bytes).unwrap());
                let opts = ColourOptions { srgb: true, filter };
                let chain = colour_mips(&img, &opts).unwrap();
                let mut expect = Vec::new();
                each_level(to_linear(&img, true), 0, w, h, filter, |l| {
                    expect.push(encode_level(&l, true))
                });
                assert_eq!(chain.levels, expect, "{filter:?} {w}x{h}");
                // The first level within a cap is that level of the chain, as bytes.
                if chain.levels.len() > 2 {
                    let (lw, lh) = level_size(w, h, 2);
                    let (k, level) = first_level_within(&img, lw.max(lh), &opts)
                        .unwrap()
                        .unwrap();
                    assert_eq!(k, 2);
                    assert_eq!(level.as_bytes(), &chain.levels[2][..], "{filter:?} {w}x{h}");
                }
            }
        }
    }
}
