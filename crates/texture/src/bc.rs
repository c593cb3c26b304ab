//! GPU block compression of finished mip levels (BC7 for colour, BC5 for normal maps, BC4
//! for one channel) with Intel's ISPC texture compressor (`intel_tex_2`), and the error of
//! the result against the uncompressed texels.
//!
//! Each level is compressed on its own from the exact (linear-light) level it replaces, never
//! mipped after compression. A level is padded to whole 4x4 blocks by repeating its edge
//! texels, up to the size of the GPU texture's level (`pack::Texture::storage_level_size`).
//! Work is split into horizontal stripes of blocks, compressed in parallel; every block is
//! encoded from its own 16 texels only, so the bytes do not depend on the thread count.

use rayon::prelude::*;

use pack::TextureFormat;

/// BC7 encoder settings, cheapest first: the ISPC compressor's profiles. Each has an opaque
/// variant (alpha ignored) and one with alpha. Both may decode opaque texels with an alpha a
/// few steps below 255: modes 6 and 7 store alpha in endpoints with a p-bit shared with colour.
/// A block whose 16 source texels are opaque but decode otherwise is encoded again with modes
/// 0 and 2, which have no alpha channel (alpha decodes as 255; the compressor's mode 1/3 switch
/// also enables mode 7, which has one), so opaque stays opaque. An opaque level uses the opaque variant, except for ultra-fast, whose opaque variant
/// has only mode 6 and needs that repair in far more blocks than its alpha variant.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Bc7Profile {
    UltraFast,
    VeryFast,
    Fast,
    Basic,
    Slow,
}

impl Bc7Profile {
    pub const ALL: [Bc7Profile; 5] = [
        Self::UltraFast,
        Self::VeryFast,
        Self::Fast,
        Self::Basic,
        Self::Slow,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::UltraFast => "ultra-fast",
            Self::VeryFast => "very-fast",
            Self::Fast => "fast",
            Self::Basic => "basic",
            Self::Slow => "slow",
        }
    }

    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|p| p.name() == s)
    }

    /// The profile restricted to the modes without alpha, for blocks that must decode opaque.
    fn no_alpha_settings(self) -> intel_tex_2::bc7::EncodeSettings {
        let mut s = self.settings(true);
        s.channels = 3;
        s.mode_selection = [true, false, false, false];
        s
    }

    fn settings(self, opaque: bool) -> intel_tex_2::bc7::EncodeSettings {
        use intel_tex_2::bc7;
        match (self, opaque && self != Self::UltraFast) {
            (Self::UltraFast, true) => bc7::opaque_ultra_fast_settings(),
            (Self::VeryFast, true) => bc7::opaque_very_fast_settings(),
            (Self::Fast, true) => bc7::opaque_fast_settings(),
            (Self::Basic, true) => bc7::opaque_basic_settings(),
            (Self::Slow, true) => bc7::opaque_slow_settings(),
            (Self::UltraFast, false) => bc7::alpha_ultra_fast_settings(),
            (Self::VeryFast, false) => bc7::alpha_very_fast_settings(),
            (Self::Fast, false) => bc7::alpha_fast_settings(),
            (Self::Basic, false) => bc7::alpha_basic_settings(),
            (Self::Slow, false) => bc7::alpha_slow_settings(),
        }
    }
}

/// What to compress a level into.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Codec {
    Bc7(Bc7Profile),
    /// X and Y of a normal map from red and green.
    Bc5,
    /// The red channel.
    Bc4,
}

impl Codec {
    pub fn format(self) -> TextureFormat {
        match self {
            Self::Bc7(_) => TextureFormat::Bc7,
            Self::Bc5 => TextureFormat::Bc5,
            Self::Bc4 => TextureFormat::Bc4,
        }
    }

    /// `bc7 ultra-fast`, `bc5`, `bc4`.
    pub fn name(self) -> String {
        match self {
            Self::Bc7(p) => format!("bc7 {}", p.name()),
            Self::Bc5 => "bc5".into(),
            Self::Bc4 => "bc4".into(),
        }
    }
}

/// The size a `width x height` level 0 is padded to for block storage: whole 4x4 blocks
/// (`pack::Texture::storage_size`). A chain cooked from level 0 padded to this size, rather
/// than each logical level padded on its own, keeps the image in the same share
/// (`pack::Texture::uv_scale`) of every level, so a renderer's one scale fits them all.
pub use pack::block_padded_size;

/// Copies a tightly packed RGBA8 `width x height` image into a `pw x ph` one (each at least as
/// large), repeating the last column and row into the padding.
pub fn pad_edges(rgba: &[u8], width: u32, height: u32, pw: u32, ph: u32) -> Vec<u8> {
    let (w, h, pw, ph) = (width as usize, height as usize, pw as usize, ph as usize);
    debug_assert!(pw >= w && ph >= h && rgba.len() == w * h * 4);
    if (w, h) == (pw, ph) {
        return rgba.to_vec();
    }
    let mut out = Vec::with_capacity(pw * ph * 4);
    for y in 0..ph {
        let row = &rgba[y.min(h - 1) * w * 4..][..w * 4];
        out.extend_from_slice(row);
        let last = &row[(w - 1) * 4..];
        for _ in w..pw {
            out.extend_from_slice(last);
        }
    }
    out
}

/// Block rows per parallel task: enough work per task to hide rayon's overhead, small enough
/// to balance two cores on a 64-texel-high level.
const ROWS_PER_TASK: usize = 4;

/// Compresses one level: `rgba` is its `width x height` texels (logical size), stored as a
/// `storage_width x storage_height` level (at least as large) in whole blocks.
pub fn compress_level(
    codec: Codec,
    rgba: &[u8],
    width: u32,
    height: u32,
    storage_width: u32,
    storage_height: u32,
) -> Vec<u8> {
    let (pw, ph) = block_padded_size(storage_width, storage_height);
    let padded = pad_edges(rgba, width, height, pw, ph);
    let channels = match codec {
        Codec::Bc7(_) => 4,
        Codec::Bc5 => 2,
        Codec::Bc4 => 1,
    };
    let texels: Vec<u8> = if channels == 4 {
        padded
    } else {
        padded
            .chunks_exact(4)
            .flat_map(|t| t[..channels].iter().copied())
            .collect()
    };
    let opaque = channels == 4 && texels.chunks_exact(4).all(|t| t[3] == 255);
    let block_bytes = codec.format().block_bytes().expect("block format") as usize;
    let blocks_x = pw as usize / 4;
    let stripe_in = pw as usize * 4 * channels;
    let stripe_out = blocks_x * block_bytes;
    let mut out = vec![0u8; stripe_out * ph as usize / 4];
    out.par_chunks_mut(stripe_out * ROWS_PER_TASK)
        .zip(texels.par_chunks(stripe_in * ROWS_PER_TASK))
        .for_each(|(dst, src)| {
            let rows = (src.len() / stripe_in) as u32;
            match codec {
                Codec::Bc7(p) => {
                    let s = intel_tex_2::RgbaSurface {
                        data: src,
                        width: pw,
                        height: rows * 4,
                        stride: pw * 4,
                    };
                    intel_tex_2::bc7::compress_blocks_into(&p.settings(opaque), &s, dst);
                    keep_opaque_blocks(p, src, pw as usize, dst);
                }
                Codec::Bc5 => {
                    let s = intel_tex_2::RgSurface {
                        data: src,
                        width: pw,
                        height: rows * 4,
                        stride: pw * 2,
                    };
                    intel_tex_2::bc5::compress_blocks_into(&s, dst);
                }
                Codec::Bc4 => {
                    let s = intel_tex_2::RSurface {
                        data: src,
                        width: pw,
                        height: rows * 4,
                        stride: pw,
                    };
                    intel_tex_2::bc4::compress_blocks_into(&s, dst);
                }
            }
        });
    out
}

/// Makes a mode-6 BC7 block decode opaque: both alpha endpoints 127 and both p-bits 1, so every
/// interpolated alpha is 255. The p-bits are shared with colour, which moves a colour endpoint
/// by at most one 8-bit step. Returns false for blocks of other modes.
fn opaque_mode6(block: &mut [u8]) -> bool {
    let mut bits = u128::from_le_bytes(block[..16].try_into().unwrap());
    // Mode 6: bit 6 is the first set bit. Layout after the 7 mode bits: R0 R1 G0 G1 B0 B1 A0
    // A1 (7 bits each, from bit 7), then P0 and P1 at bits 63 and 64.
    if bits & 0x7f != 0x40 {
        return false;
    }
    bits |= 0x7f << 49 | 0x7f << 56 | 1 << 63 | 1 << 64;
    block[..16].copy_from_slice(&bits.to_le_bytes());
    true
}

/// Repairs every BC7 block of a stripe whose source texels are all opaque but whose decode is
/// not (see [`Bc7Profile`]): mode 6 by its endpoint bits, any other mode by encoding the block
/// again without alpha modes. `src` is RGBA rows `width` texels wide.
fn keep_opaque_blocks(profile: Bc7Profile, src: &[u8], width: usize, dst: &mut [u8]) {
    let blocks_x = width / 4;
    let row = width * 4;
    let mut texels = [0u8; 64];
    let mut decoded = [0u8; 64];
    for (i, block) in dst.chunks_exact_mut(16).enumerate() {
        let (bx, by) = (i % blocks_x, i / blocks_x);
        for y in 0..4 {
            let at = (by * 4 + y) * row + bx * 16;
            texels[y * 16..y * 16 + 16].copy_from_slice(&src[at..at + 16]);
        }
        if texels.chunks_exact(4).any(|t| t[3] != 255) {
            continue;
        }
        bcdec_rs::bc7(block, &mut decoded, 16);
        if decoded.chunks_exact(4).all(|t| t[3] == 255) || opaque_mode6(block) {
            continue;
        }
        let s = intel_tex_2::RgbaSurface {
            data: &texels,
            width: 4,
            height: 4,
            stride: 16,
        };
        intel_tex_2::bc7::compress_blocks_into(&profile.no_alpha_settings(), &s, block);
    }
}

/// How far a compressed chain (or level) is from the texels it was made from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BlockError {
    /// Colour: RMS over every channel of every texel, in 8-bit steps (LSB) of the stored
    /// (sRGB-encoded for colour) values. Normal maps: mean angle in degrees.
    pub mean: f64,
    /// Colour: the largest difference of one channel, LSB. Normal maps: the 99th percentile of
    /// the angle, degrees.
    pub max: f64,
    /// Level 0 alone, as `mean`.
    pub level0: f64,
}

/// Per-texel errors of one level, to be combined over a chain.
#[derive(Clone, Debug, Default)]
struct Tally {
    /// Colour: sum of squared channel differences; normals: sum of angles.
    sum: f64,
    /// Channels (colour) or texels (normals) counted.
    count: u64,
    max: u8,
}

/// Colour tally of `decoded` (`width` texels a row) against the same texels of `original`,
/// whose rows are `stride` texels apart (a level's block padding is left out without a
/// cropped copy).
fn colour_tally(
    original: &[u8],
    stride: usize,
    decoded: &[u8],
    width: usize,
    channels: usize,
) -> Tally {
    let mut t = Tally::default();
    if width == 0 {
        return t;
    }
    for (a, b) in original
        .chunks(4 * stride)
        .zip(decoded.chunks_exact(4 * width))
    {
        for (a, b) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
            for c in 0..channels {
                let d = a[c].abs_diff(b[c]);
                t.sum += d as f64 * d as f64;
                t.max = t.max.max(d);
            }
        }
    }
    t.count = (decoded.len() / 4 * channels) as u64;
    t
}

/// What a chain's error is measured in, by what the renderer reads from it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Measure {
    /// RMS over all four channels, 8-bit steps.
    Rgba,
    /// RMS over red, green and blue, 8-bit steps, for a texture whose alpha is never sampled
    /// (a projector's): it is encoded opaque, so BC7's modes without alpha give colour all the
    /// bits.
    Rgb,
    /// Mean angle in degrees between unit normals (Z rebuilt).
    Normal,
}

/// An 8-bit normal's direction: each byte mapped to [-1, 1], scaled to unit length. `signed`
/// holds each byte's mapping (`t / 255 * 2 - 1`, the same value as computing it).
fn unit_normal(t: &[u8], signed: &[f64; 256]) -> [f64; 3] {
    let v = [0, 1, 2].map(|i| signed[t[i] as usize]);
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 1e-9 {
        v.map(|c| c / l)
    } else {
        [0.0, 0.0, 1.0]
    }
}

/// Each texel's angle (degrees) into `angles` (one per texel of `decoded`, `width` texels a
/// row), and their sum; `original`'s rows are `stride` texels apart, as in [`colour_tally`].
///
/// The angles are kept for the 99th percentile only, so in f32: a 1024² normal map's chain
/// held 11 MB of them in f64. The sum is taken in f64 from the unrounded angles, row by row
/// (each row in texel order, in parallel), then over the rows in order: the same bits on any
/// number of threads.
fn normal_tally(
    original: &[u8],
    stride: usize,
    decoded: &[u8],
    width: usize,
    angles: &mut [f32],
) -> Tally {
    let signed: [f64; 256] = std::array::from_fn(|t| t as f64 / 255.0 * 2.0 - 1.0);
    let rows: Vec<f64> = angles
        .par_chunks_mut(width.max(1))
        .zip(original.par_chunks(4 * stride.max(1)))
        .zip(decoded.par_chunks(4 * width.max(1)))
        .map(|((angles, original), decoded)| {
            let mut sum = 0.0;
            for ((angle, a), b) in angles
                .iter_mut()
                .zip(original.chunks_exact(4))
                .zip(decoded.chunks_exact(4))
            {
                let (a, b) = (unit_normal(a, &signed), unit_normal(b, &signed));
                let dot = (a[0] * b[0] + a[1] * b[1] + a[2] * b[2]).clamp(-1.0, 1.0);
                let degrees = dot.acos().to_degrees();
                sum += degrees;
                *angle = degrees as f32;
            }
            sum
        })
        .collect();
    Tally {
        sum: rows.iter().sum(),
        count: angles.len() as u64,
        max: 0,
    }
}

/// A tally's error: its mean angle for normals, the root of its mean square for colour.
fn tally_error(sum: f64, count: u64, normal: bool) -> f64 {
    let m = sum / count.max(1) as f64;
    if normal { m } else { m.sqrt() }
}

/// The chain's error from its levels' tallies; for normals, `angles` holds every texel's
/// angle, in any order (the 99th percentile is taken in place).
fn finish(tallies: &[Tally], normal: bool, angles: &mut [f32]) -> BlockError {
    let level_mean = |t: &Tally| tally_error(t.sum, t.count, normal);
    let total = Tally {
        sum: tallies.iter().map(|t| t.sum).sum(),
        count: tallies.iter().map(|t| t.count).sum(),
        ..Default::default()
    };
    let max = if normal {
        if angles.is_empty() {
            0.0
        } else {
            let k = ((angles.len() - 1) as f64 * 0.99).round() as usize;
            *angles.select_nth_unstable_by(k, f32::total_cmp).1 as f64
        }
    } else {
        tallies.iter().map(|t| t.max).max().unwrap_or(0) as f64
    };
    BlockError {
        mean: level_mean(&total),
        max,
        level0: tallies.first().map(level_mean).unwrap_or(0.0),
    }
}

/// Colour error of `decoded` against `original` (both RGBA8, same size).
pub fn colour_error(original: &[u8], decoded: &[u8]) -> BlockError {
    let n = original.len().min(decoded.len()) / 4;
    finish(
        &[colour_tally(original, n, &decoded[..4 * n], n, 4)],
        false,
        &mut [],
    )
}

/// Angular error of a decoded normal map (Z rebuilt, as `pack::texels` decodes BC5) against
/// the RGBA8 normal map it was made from.
pub fn normal_error(original: &[u8], decoded: &[u8]) -> BlockError {
    let n = original.len().min(decoded.len()) / 4;
    let mut angles = vec![0.0; n];
    let tally = normal_tally(original, n, &decoded[..4 * n], n, &mut angles);
    finish(&[tally], true, &mut angles)
}

/// A compressed mip chain and its error over every texel of every level.
#[derive(Clone, Debug)]
pub struct Compressed {
    pub levels: Vec<Vec<u8>>,
    pub error: BlockError,
}

/// Compresses every level of `chain` (RGBA8, level 0 first) as the levels of `texture`
/// (whose format, logical and storage sizes say how), and measures each against its source
/// over the level's logical size. `chain` is either the logical chain (`texture.mips` sizes;
/// each level padded with its edge texels) or one cooked from level 0 already padded to
/// `texture.storage_size()` ([`block_padded_size`]), whose levels are then the storage levels
/// and keep the image in the same share of every level. `measure` selects the error measure.
/// Levels are compressed one after another, each in parallel stripes.
pub fn compress_chain(
    codec: Codec,
    chain: &crate::MipChain,
    texture: &pack::Texture,
    measure: Measure,
) -> Compressed {
    match compress_chain_within(codec, chain, texture, measure, f64::INFINITY) {
        Ok(c) => c,
        Err(_) => unreachable!("no error exceeds an infinite budget"),
    }
}

/// The TOC entry of `chain` stored with `codec`: a colour texture whose levels are the chain's
/// sizes, for compressing and measuring a chain outside a cook (benchmarks, tests).
pub fn chain_shape(
    chain: &crate::MipChain,
    codec: Codec,
    colour_space: pack::ColourSpace,
) -> pack::Texture {
    pack::Texture {
        name: String::new(),
        role: pack::TextureRole::Colour,
        colour_space,
        format: codec.format(),
        supercompression: pack::Supercompression::None,
        width: chain.width,
        height: chain.height,
        mips: (0..chain.levels.len())
            .map(|k| {
                let (width, height) = chain.level_size(k);
                pack::MipLevel {
                    width,
                    height,
                    section: 0,
                }
            })
            .collect(),
    }
}

/// The chain's error already exceeds the budget: `at_least` is a lower bound of its error over
/// the whole chain (same unit as [`BlockError::mean`]), reached by the `levels` smallest levels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OverBudget {
    pub at_least: f64,
    pub levels: usize,
}

/// [`compress_chain`], giving up as soon as the chain's error is certain to exceed `budget`
/// (compared with [`BlockError::mean`]). Levels go smallest first: their errors add up over the
/// whole chain's texel count, which is known before any is encoded, so the sum so far bounds
/// the result from below, and a setting that fails usually fails on the quarter of the texels
/// below level 0. What it returns when it fits is what [`compress_chain`] returns, bit for bit.
pub fn compress_chain_within(
    codec: Codec,
    chain: &crate::MipChain,
    texture: &pack::Texture,
    measure: Measure,
    budget: f64,
) -> Result<Compressed, OverBudget> {
    let normal = measure == Measure::Normal;
    let per_texel = match measure {
        Measure::Normal => 1,
        Measure::Rgba => 4,
        Measure::Rgb => 3,
    };
    let total: u64 = (0..chain.levels.len())
        .map(|k| {
            let m = &texture.mips[k];
            m.width as u64 * m.height as u64 * per_texel
        })
        .sum();
    let bound = |sum: f64| tally_error(sum, total, normal);
    let mut levels = vec![Vec::new(); chain.levels.len()];
    let mut tallies: Vec<Tally> = (0..chain.levels.len()).map(|_| Tally::default()).collect();
    let mut sum = 0.0;
    // Every texel's angle of a normal map's chain, level after level, for the percentile:
    // one vector for the chain, sized once, where each level's own and a copy of them all
    // were twice its size (358 MB for a 4096² normal map).
    let mut angles: Vec<f32> = Vec::with_capacity(if normal { total as usize } else { 0 });
    for (done, k) in (0..chain.levels.len()).rev().enumerate() {
        let rgba = &chain.levels[k];
        let m = &texture.mips[k];
        let (sw, sh) = texture.storage_level_size(k);
        let opaque;
        let source = if measure == Measure::Rgb {
            let mut level = rgba.clone();
            level.iter_mut().skip(3).step_by(4).for_each(|a| *a = 255);
            opaque = level;
            &opaque
        } else {
            rgba
        };
        let (cw, ch) = chain.level_size(k);
        let blocks = compress_level(codec, source, cw, ch, sw, sh);
        // The level's logical texels: `decoded` holds them alone, `rgba` within its padding.
        let decoded = pack::texels::decode_level(texture, k, &blocks);
        let (stride, width) = (cw as usize, m.width as usize);
        let tally = match measure {
            Measure::Normal => {
                let at = angles.len();
                angles.resize(at + decoded.len() / 4, 0.0);
                normal_tally(rgba, stride, &decoded, width, &mut angles[at..])
            }
            Measure::Rgba => colour_tally(rgba, stride, &decoded, width, 4),
            Measure::Rgb => colour_tally(rgba, stride, &decoded, width, 3),
        };
        sum += tally.sum;
        tallies[k] = tally;
        levels[k] = blocks;
        // The last level gives the exact error, which the caller compares; before it, a margin
        // keeps float summation order from ever turning down what the full sum would accept.
        if k > 0 && bound(sum) > budget * (1.0 + 1e-9) {
            return Err(OverBudget {
                at_least: bound(sum),
                levels: done + 1,
            });
        }
    }
    Ok(Compressed {
        levels,
        error: finish(&tallies, normal, &mut angles),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32) -> Vec<u8> {
        (0..w * h)
            .flat_map(|i| {
                let (x, y) = (i % w, i / w);
                [
                    (x * 255 / w.max(2).saturating_sub(1).max(1)) as u8,
                    (y * 255 / h.max(2).saturating_sub(1).max(1)) as u8,
                    ((x + y) * 2).min(255) as u8,
                    255,
                ]
            })
            .collect()
    }

    #[test]
    fn padding_repeats_edges() {
        let img = vec![1, 2, 3, 4, 5, 6, 7, 8];
        let p = pad_edges(&img, 2, 1, 3, 2);
        assert_eq!(
            p,
            vec![
                1, 2, 3, 4, 5, 6, 7, 8, 5, 6, 7, 8, 1, 2, 3, 4, 5, 6, 7, 8, 5, 6, 7, 8
            ]
        );
    }

    #[test]
    fn sizes_follow_blocks() {
        let img = gradient(9, 5);
        let b = compress_level(Codec::Bc7(Bc7Profile::UltraFast), &img, 9, 5, 12, 8);
        assert_eq!(b.len(), 3 * 2 * 16);
        let b = compress_level(Codec::Bc5, &img, 9, 5, 12, 8);
        assert_eq!(b.len(), 3 * 2 * 16);
        let b = compress_level(Codec::Bc4, &img, 9, 5, 12, 8);
        assert_eq!(b.len(), 3 * 2 * 8);
        // A level smaller than a block is one block.
        let b = compress_level(Codec::Bc7(Bc7Profile::UltraFast), &img[..8], 2, 1, 3, 2);
        assert_eq!(b.len(), 16);
    }

    #[test]
    fn opaque_stays_opaque_and_error_is_small_on_a_smooth_image() {
        let (w, h) = (64, 32);
        let img = gradient(w, h);
        for p in [Bc7Profile::UltraFast, Bc7Profile::VeryFast] {
            let b = compress_level(Codec::Bc7(p), &img, w, h, w, h);
            let d = pack::texels::decode(TextureFormat::Bc7, w, h, &b);
            // Opaque stays opaque (see `Bc7Profile`).
            assert!(d.chunks_exact(4).all(|t| t[3] == 255), "{p:?}: alpha");
            let e = colour_error(&img, &d);
            assert!(e.mean < 3.0 && e.max < 10.0, "{p:?}: {e:?}");
        }
    }

    #[test]
    fn a_mode6_block_made_opaque_keeps_its_colour_within_a_step() {
        let img = gradient(4, 4);
        let s = intel_tex_2::RgbaSurface {
            data: &img,
            width: 4,
            height: 4,
            stride: 16,
        };
        let mut block = [0u8; 16];
        let mut settings = Bc7Profile::UltraFast.settings(true);
        settings.mode_selection = [false, false, false, true];
        intel_tex_2::bc7::compress_blocks_into(&settings, &s, &mut block);
        // Force alpha endpoints below 255, as the kernels sometimes leave them.
        let mut bits = u128::from_le_bytes(block);
        bits &= !(1u128 << 49 | 1 << 56 | 1 << 63 | 1 << 64);
        let mut low = bits.to_le_bytes();
        let mut before = [0u8; 64];
        bcdec_rs::bc7(&low, &mut before, 16);
        assert!(before.chunks_exact(4).any(|t| t[3] < 255));
        assert!(opaque_mode6(&mut low));
        let mut after = [0u8; 64];
        bcdec_rs::bc7(&low, &mut after, 16);
        for (a, b) in before.chunks_exact(4).zip(after.chunks_exact(4)) {
            assert_eq!(b[3], 255);
            for c in 0..3 {
                assert!(a[c].abs_diff(b[c]) <= 1, "{a:?} {b:?}");
            }
        }
        // Another mode is left alone.
        let mut other = [0x01u8; 16];
        assert!(!opaque_mode6(&mut other));
    }

    #[test]
    fn colour_error_counts_every_channel() {
        let a = [10u8, 10, 10, 10];
        let e = colour_error(&a, &[12, 10, 10, 10]);
        assert_eq!(e.max, 2.0);
        assert!((e.mean - 1.0).abs() < 1e-12, "{e:?}");
    }

    #[test]
    fn bc5_normal_error_is_small_on_a_smooth_normal_map() {
        let (w, h) = (32u32, 32u32);
        let img: Vec<u8> = (0..w * h)
            .flat_map(|i| {
                let x = ((i % w) as f64 / w as f64 - 0.5) * 0.6;
                let y = ((i / w) as f64 / h as f64 - 0.5) * 0.6;
                let z = (1.0 - x * x - y * y).sqrt();
                [x, y, z]
                    .map(|c| ((c * 0.5 + 0.5) * 255.0).round() as u8)
                    .into_iter()
                    .chain([255])
            })
            .collect();
        let b = compress_level(Codec::Bc5, &img, w, h, w, h);
        let d = pack::texels::decode(TextureFormat::Bc5, w, h, &b);
        let e = normal_error(&img, &d);
        assert!(e.mean < 0.5 && e.max < 2.0, "{e:?}");
        // A different normal map is far off: the measure can fail.
        let flat: Vec<u8> = img
            .chunks_exact(4)
            .flat_map(|_| [128, 128, 255, 255])
            .collect();
        assert!(normal_error(&img, &flat).mean > 3.0);
    }

    /// The parallel tally is the plain one, bit for bit: each texel's angle by the plain
    /// formula (bytes divided out, not looked up), summed row by row in texel order. Random bytes
    /// over many rows, zero-length normals included, the original within a padding of 3
    /// texels a row (a block-padded level) and without one; the colour tally skips the
    /// padding too.
    #[test]
    fn tallies_are_the_plain_per_texel_sums() {
        let (width, height) = (61usize, 700usize);
        let bytes = |seed: u32, n: usize| -> Vec<u8> {
            (0..n as u32 * 4)
                .map(|i| ((i ^ seed).wrapping_mul(2654435761) >> 11) as u8)
                .collect()
        };
        let unit = |t: &[u8]| {
            let v = [0, 1, 2].map(|i| t[i] as f64 / 255.0 * 2.0 - 1.0);
            let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            if l > 1e-9 {
                v.map(|c| c / l)
            } else {
                [0.0, 0.0, 1.0]
            }
        };
        for stride in [width, width + 3] {
            let (mut a, b) = (bytes(0, stride * height), bytes(0x9e37, width * height));
            a[4..8].copy_from_slice(&[127, 128, 128, 0]);
            // The texels the tallies must see, in order.
            let logical: Vec<&[u8]> = a
                .chunks_exact(4 * stride)
                .flat_map(|row| row[..4 * width].chunks_exact(4))
                .collect();
            let want: Vec<f64> = logical
                .iter()
                .zip(b.chunks_exact(4))
                .map(|(a, b)| {
                    let (a, b) = (unit(a), unit(b));
                    (a[0] * b[0] + a[1] * b[1] + a[2] * b[2])
                        .clamp(-1.0, 1.0)
                        .acos()
                        .to_degrees()
                })
                .collect();
            let mut angles = vec![0.0; width * height];
            let t = normal_tally(&a, stride, &b, width, &mut angles);
            assert_eq!(t.count, (width * height) as u64);
            assert!(
                angles
                    .iter()
                    .zip(&want)
                    .all(|(x, y)| x.to_bits() == (*y as f32).to_bits())
            );
            let by_rows: f64 = want.chunks(width).map(|row| row.iter().sum::<f64>()).sum();
            assert_eq!(t.sum.to_bits(), by_rows.to_bits());
            let c = colour_tally(&a, stride, &b, width, 3);
            let (mut sum, mut max) = (0.0f64, 0u8);
            for (a, b) in logical.iter().zip(b.chunks_exact(4)) {
                for k in 0..3 {
                    let d = a[k].abs_diff(b[k]);
                    sum += d as f64 * d as f64;
                    max = max.max(d);
                }
            }
            assert_eq!(
                (c.sum.to_bits(), c.max, c.count),
                (sum.to_bits(), max, (3 * width * height) as u64)
            );
        }
    }

    #[test]
    fn bytes_do_not_depend_on_the_thread_count() {
        let (w, h) = (100, 70);
        let img: Vec<u8> = (0..w * h * 4)
            .map(|i: u32| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        let run = |threads: usize, codec: Codec| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| compress_level(codec, &img, w, h, 100, 72))
        };
        for codec in [Codec::Bc7(Bc7Profile::VeryFast), Codec::Bc5, Codec::Bc4] {
            let one = run(1, codec);
            assert_eq!(one, run(2, codec), "{codec:?}");
            assert_eq!(one, run(8, codec), "{codec:?}");
        }
    }

    /// A noisy 64x48 chain (7 levels) in `codec`'s shape, for the budgeted encoder.
    fn noisy_chain(codec: Codec) -> (crate::MipChain, pack::Texture) {
        let (w, h) = (64u32, 48u32);
        let noise: Vec<u8> = (0..w * h * 4)
            .map(|i: u32| (i.wrapping_mul(2654435761) >> 13) as u8)
            .collect();
        let img = image::DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w, h, noise).unwrap());
        let chain = crate::colour_mips(&img, &crate::ColourOptions::default()).unwrap();
        let texture = chain_shape(&chain, codec, pack::ColourSpace::Srgb);
        (chain, texture)
    }

    #[test]
    fn a_budget_stops_early_and_only_when_the_chain_must_exceed_it() {
        for (codec, measure) in [
            (Codec::Bc7(Bc7Profile::UltraFast), Measure::Rgba),
            (Codec::Bc7(Bc7Profile::UltraFast), Measure::Rgb),
            (Codec::Bc5, Measure::Normal),
        ] {
            let (chain, texture) = noisy_chain(codec);
            let full = compress_chain(codec, &chain, &texture, measure);
            let e = full.error.mean;
            assert!(e > 0.0, "{codec:?}");
            // At or above the full error: the same levels and error, bit for bit.
            for budget in [e, e * 1.01, f64::INFINITY] {
                let within = compress_chain_within(codec, &chain, &texture, measure, budget)
                    .unwrap_or_else(|o| panic!("{codec:?} {measure:?} gave up at {o:?}"));
                assert_eq!(within.levels, full.levels);
                assert_eq!(within.error, full.error);
            }
            // Far below it: it stops before level 0, with a true lower bound above the budget.
            let budget = e * 0.05;
            let over = compress_chain_within(codec, &chain, &texture, measure, budget)
                .expect_err("a budget a twentieth of the error must be exceeded");
            assert!(
                over.at_least > budget && over.at_least <= e,
                "{over:?}, error {e}"
            );
            assert!(over.levels < chain.levels.len(), "{over:?}");
            // Just below it: never accepted, though it may take every level to know.
            match compress_chain_within(codec, &chain, &texture, measure, e * 0.999) {
                Ok(c) => assert_eq!(c.error, full.error),
                Err(o) => assert!(o.at_least <= e, "{o:?}"),
            }
        }
    }
}
