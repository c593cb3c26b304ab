//! Projector textures: the design blurred into the soft-edged light pattern a window throws.

use image::DynamicImage;
use rayon::prelude::*;
use std::borrow::Cow;

use crate::TextureError;
use crate::blur::{
    BlurMethod, RowBlur, Sigma2, blur_linear, blur_rgba8_framed_to_linear, check_sigma2,
};
use crate::mips::{MipChain, check_size, level_count, level_size};
use crate::pixels::to_linear;
use crate::real::clamp01;
use crate::resample::{MipFilter, half, next_level, reduce_to, reduce_to_by_rows, walk_chain};
use crate::srgb::{decode8, encoder, linear_to_srgb_lsb, linear_to_srgb_lsb_slope};

/// How a projector texture is cooked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProjectorOptions {
    /// Gaussian σ in texels of the design along x and y (see [`sigma_from_light`]): one length
    /// on the glass is a different number of texels along each axis of a stretched design.
    pub sigma_texels: Sigma2,
    /// When set, the stored texture may start below the design's resolution (dropping leading
    /// levels) as long as sampling it bilinearly stays within this many LSB of the full blur.
    pub max_error_lsb: Option<f32>,
    /// When set, leading levels are dropped until the stored level 0 is at most this many
    /// texels on its longer side: the size a renderer samples projectors at
    /// (`pack::PROJECTOR_MAX_SIZE`), so larger levels would only be bytes never read.
    pub max_size: Option<u32>,
    /// `max_size` bounds the whole stored level, margin included, rather than its design part:
    /// for a cap a device sets (`cooker cook --max-texture-size`), which no texture may pass.
    pub cap_whole_level: bool,
    pub method: BlurMethod,
    /// Grow the stored level 0 with transparent black (the blur's own zero border) to whole
    /// 4x4 blocks before the lower levels are made from it, for block storage
    /// (`crate::bc::block_padded_size`). The chain is then the padded size; the report's size
    /// stays the image's.
    pub block_pad: bool,
    /// Texels of transparent border added on each side of the design before the blur, so the
    /// light can spread past the window's edge as the light's penumbra does
    /// ([`projector_margin`]); the stored texture spans the design and its margin. The size cap
    /// applies to the design's part of a level. `[x, y]`: left and right, top and bottom.
    pub margin: [u32; 2],
    /// The design's colours are linear values, not sRGB-encoded (a manifest's
    /// `colour_space = "linear"`). Its alpha is linear either way.
    pub linear: bool,
}

impl ProjectorOptions {
    pub fn new(sigma_texels: impl Into<Sigma2>) -> Self {
        Self {
            sigma_texels: sigma_texels.into(),
            max_error_lsb: None,
            max_size: None,
            cap_whole_level: false,
            method: BlurMethod::Auto,
            block_pad: false,
            margin: [0, 0],
            linear: false,
        }
    }
}

/// What [`projector`] did, for `-v`.
#[derive(Clone, Debug, PartialEq)]
pub struct ProjectorReport {
    pub sigma_texels: Sigma2,
    /// The method actually used (never `Auto`).
    pub method: BlurMethod,
    pub design_width: u32,
    pub design_height: u32,
    /// Size of the stored level 0.
    pub width: u32,
    pub height: u32,
    /// Leading levels dropped because the blur left nothing they would show.
    pub dropped_levels: u32,
    /// Further halvings of the stored level along x and along y alone, where one axis was
    /// over the size cap and the other was not.
    pub halved: [u32; 2],
    /// Under the size cap, the size of the level that was resampled down to the cap rather
    /// than halved, where that came nearer the blur: a 256²
    /// design with its light margin at σ 2.2 is 274², 12.6 LSB off halved to 137², 5.0
    /// resampled to 256².
    pub resampled_from: Option<(u32, u32)>,
    /// The margin on each side, in design texels ([`ProjectorOptions::margin`]).
    pub margin: [u32; 2],
    /// With a budget: max error (LSB) of the stored texture, sampled bilinearly at the design's
    /// resolution, against the unrounded full-resolution blur.
    pub max_error_lsb: Option<f64>,
}

impl std::fmt::Display for ProjectorReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "sigma {:.2} texels ({}), {}x{}",
            self.sigma_texels,
            self.method.name(),
            self.width,
            self.height
        )?;
        // The margin is in the design's texels: under a size cap, 8 and 25 "texels" round a
        // 10x16 level read as larger than the texture.
        let unit = if [self.width, self.height]
            == [
                self.design_width + 2 * self.margin[0],
                self.design_height + 2 * self.margin[1],
            ] {
            "texels"
        } else {
            "design texels"
        };
        match self.margin {
            [0, 0] => {}
            [x, y] if x == y => write!(f, " with a margin of {x} {unit}")?,
            [x, y] => write!(f, " with margins of {x} and {y} {unit}")?,
        }
        if self.dropped_levels > 0 {
            write!(
                f,
                " (stored below the design's {}x{}: {} level(s) dropped)",
                self.design_width, self.design_height, self.dropped_levels
            )?;
        }
        match self.halved {
            [0, 0] => {}
            [x, 0] => write!(f, " (halved {x} more time(s) across only, to the size cap)")?,
            [0, y] => write!(f, " (halved {y} more time(s) down only, to the size cap)")?,
            [x, y] => write!(f, " (halved {x} more time(s) across and {y} down)")?,
        }
        if let Some((w, h)) = self.resampled_from {
            write!(f, " (resampled from {w}x{h} to the size cap)")?;
        }
        if let Some(e) = self.max_error_lsb {
            write!(f, ", max error {e:.3} LSB against the full-size blur")?;
        }
        Ok(())
    }
}

/// How far a window's blurred light reaches past its design's edge, in σ: the light of an
/// edge has fallen to 0.5·erfc(4/√2) = 3.2e-5 of its level there, under 0.1 LSB of sRGB8 even
/// where the curve is steepest, so it rounds to black.
pub const MARGIN_SIGMAS: f32 = 4.0;

/// Texels of margin for a `w x h` design blurred with σ texels, `[x, y]`: [`MARGIN_SIGMAS`]·σ
/// along each axis, and at most half the design's longer side, so the blurred image is at most
/// four times the design's area (a blur that wide spreads the light into a faint glow; its far
/// tail is cut).
pub fn projector_margin(sigma_texels: impl Into<Sigma2>, w: u32, h: u32) -> [u32; 2] {
    let sigma = sigma_texels.into();
    let one = |s: f32| {
        if s > 0.0 && s.is_finite() {
            ((MARGIN_SIGMAS * s).ceil() as u32).min(w.max(h) / 2)
        } else {
            0
        }
    };
    [one(sigma.x), one(sigma.y)]
}

/// σ in window texels of the penumbra a light casts: a light of angular size θ (the sun: about
/// 0.53° = 0.00925 rad; a point light: its radius over its distance) through a window onto a
/// floor `distance` behind it gives a penumbra θ·d wide, taken as 4σ. `texels_per_unit` is the
/// design's resolution on the window (texels per scene unit). Invalid inputs give a non-finite
/// or negative σ, which [`projector`] rejects.
pub fn sigma_from_light(angular_size_rad: f32, distance: f32, texels_per_unit: f32) -> f32 {
    angular_size_rad * distance / 4.0 * texels_per_unit
}

/// Cooks a projector texture: the design (sRGB, straight alpha) blurred with a Gaussian of σ
/// texels in linear light with premultiplied alpha and a zero border (outside the window is
/// opaque wall, which lets no light through).
///
/// Stored as RGBA8: colour is the sRGB encoding of the blurred *premultiplied* colour, i.e. the
/// fraction of light the window lets through (multiply the light by it; no division by alpha),
/// alpha is the blurred coverage, linear. Mips are box-filtered like colour mips.
pub fn projector(
    design: &DynamicImage,
    opts: &ProjectorOptions,
) -> Result<(MipChain, ProjectorReport), TextureError> {
    projector_with_unpadded(design, opts).map(|(chain, _, report)| (chain, report))
}

/// [`projector`], and when `block_pad` grew the stored level to whole blocks, also the chain
/// without the padding (the levels [`projector`] returns without `block_pad`), which costs
/// only its encoding: a cook that tries block compression and keeps RGBA8 needs both, and
/// blurring twice took the default scene's largest projector 140 ms more.
pub fn projector_with_unpadded(
    design: &DynamicImage,
    opts: &ProjectorOptions,
) -> Result<(MipChain, Option<MipChain>, ProjectorReport), TextureError> {
    cook_projector(design, opts, true)
}

/// [`projector_with_unpadded`]; `stream` lets a large design's blur be streamed in bands (the
/// tests turn it off to check that streaming changes no bit).
fn cook_projector(
    design: &DynamicImage,
    opts: &ProjectorOptions,
    stream: bool,
) -> Result<(MipChain, Option<MipChain>, ProjectorReport), TextureError> {
    let (dw, dh) = (design.width(), design.height());
    check_size(dw, dh)?;
    check_sigma2(opts.sigma_texels)?;
    if let Some(b) = opts.max_error_lsb
        && !(b.is_finite() && b >= 0.0)
    {
        return Err(TextureError::InvalidBudget { budget: b });
    }
    let m = opts.margin;
    if let Some(&margin) = m.iter().find(|&&m| m > dw.max(dh)) {
        return Err(TextureError::MarginTooWide {
            margin,
            width: dw,
            height: dh,
        });
    }
    // The blurred image: the design and its margin.
    let (w, h) = (dw + 2 * m[0], dh + 2 * m[1]);
    // The 8-bit passes decode sRGB as they read; a linear design takes the f32 route.
    let bytes = if opts.linear {
        None
    } else {
        crate::pixels::rgba8_bytes(design)
    };
    // A design larger than the cap never has its level 0 stored, so its full-size blur is
    // needed only as the reference the stored levels are measured against: stream it in bands
    // (once for the levels, again for each level measured) rather than hold it whole, 17 MB of
    // f32 for a 1024² design. Any height: an odd one's halving reads a row past each band
    // (it was held whole, 297 MB for a 4097² design).
    let streamed = match &bytes {
        Some(b)
            if stream
                && opts.max_size.is_some_and(|cap| dw.max(dh) > cap)
                && !resamples_level0(opts, w, h) =>
        {
            RowBlur::new(b, dw, dh, m, opts.sigma_texels, opts.method)?.map(Streamed)
        }
        _ => None,
    };
    // Levels `first..` of the blur's chain, in f32 and encoded.
    let (first, levels) = match &streamed {
        Some(s) => (1, premultiplied_levels(s.half(), half(w), half(h))),
        None => {
            let blurred = match &bytes {
                // 8-bit designs (nearly all) are decoded inside the passes: no f32 copy.
                Some(bytes) => {
                    blur_rgba8_framed_to_linear(bytes, dw, dh, m, opts.sigma_texels, opts.method)?
                }
                None => {
                    let mut premul = to_linear(design, !opts.linear);
                    premul
                        .par_iter_mut()
                        .for_each(|t| *t = [t[0] * t[3], t[1] * t[3], t[2] * t[3], t[3]]);
                    if m != [0, 0] {
                        let mut framed = vec![[0.0f32; 4]; (w * h) as usize];
                        for (y, row) in premul.chunks_exact(dw as usize).enumerate() {
                            let at = (y + m[1] as usize) * w as usize + m[0] as usize;
                            framed[at..at + dw as usize].copy_from_slice(row);
                        }
                        premul = framed;
                    }
                    blur_linear(&premul, w, h, opts.sigma_texels, opts.method)?
                }
            };
            (0, premultiplied_levels(blurred, w, h))
        }
    };
    let encoded: Vec<Vec<u8>> = levels.iter().map(|l| encode_premultiplied(l)).collect();
    let n = first + levels.len();
    let error = |k: usize| -> f64 {
        let (lw, lh) = level_size(w, h, k);
        match &streamed {
            Some(s) if k == 0 => s.max_over_bands(|band, y0, y1| {
                let bh = y1 - y0;
                upsampled_error(&encode_premultiplied(band), w, bh, band, w, bh)
            }),
            Some(s) => s.max_over_bands(|band, y0, _| {
                upsampled_error_rows(&encoded[k - first], lw, lh, band, y0, w, h)
            }),
            None => upsampled_error(&encoded[k], lw, lh, &levels[0], w, h),
        }
    };
    let Kept {
        level: keep,
        halved,
        fit,
        max_error,
    } = choose_level(opts, w, h, n, error);
    let report = |(width, height): (u32, u32),
                  max_error_lsb,
                  resampled_from,
                  (dropped_levels, halved): (usize, [u32; 2])| ProjectorReport {
        sigma_texels: opts.sigma_texels,
        method: opts.method.resolve_sized(opts.sigma_texels, w, h),
        design_width: dw,
        design_height: dh,
        width,
        height,
        dropped_levels: dropped_levels as u32,
        halved,
        resampled_from,
        margin: m,
        max_error_lsb,
    };
    if halved != [0, 0] || fit.is_some() {
        let c = reduced_to_cap(
            opts.block_pad,
            (w, h),
            levels,
            first,
            streamed.as_ref(),
            keep,
            halved,
            fit,
        );
        // Halvings along both axes are a level dropped.
        let more = c.halvings;
        let both = more[0].min(more[1]);
        let halved = [halved[0] + more[0] - both, halved[1] + more[1] - both];
        let dropped = (keep + both as usize, halved);
        let report = report(c.size, Some(c.max_error), c.resampled_from, dropped);
        return Ok((c.chain, c.unpadded, report));
    }
    let (sw, sh) = level_size(w, h, keep);
    let report = report((sw, sh), max_error, None, (keep, halved));
    let (pw, ph) = crate::bc::block_padded_size(sw, sh);
    let unpadded = MipChain {
        width: sw,
        height: sh,
        levels: encoded.into_iter().skip(keep - first).collect(),
    };
    if opts.block_pad && (pw, ph) != (sw, sh) {
        // Only the kept level goes on, padded in place, and its chain is encoded as it is
        // walked: the rose's 518² level held beside its padded copy and all the padded levels
        // in f32 was 11 MB more at the default scene's peak.
        let mut levels = levels;
        let kept = levels.swap_remove(keep - first);
        drop(levels);
        let padded = crate::pixels::pad_texels_owned(kept, sw, sh, pw, ph, Some([0.0; 4]));
        Ok((encoded_chain(padded, pw, ph), Some(unpadded), report))
    } else {
        Ok((unpadded, None, report))
    }
}

/// The stored chain of a blur whose kept level is over the size cap along one axis only, or
/// over a cap on the whole level: level `keep` (of `levels`, which start at level `first`;
/// from `streamed`'s bands where that is not held) halved `halved[0]` more times across and
/// `halved[1]` down, then resampled to `fit`, box-filtered as the mips are, and its chain
/// below; with the chain unpadded when `block_pad` grew it, as [`projector_with_unpadded`];
/// the stored level's size; its error against the full-resolution blur, as the cap's always
/// is; the size `fit` resampled from; and the halvings made instead of it, along x and y,
/// where they came nearer the blur.
#[allow(clippy::too_many_arguments)]
fn reduced_to_cap(
    block_pad: bool,
    (w, h): (u32, u32),
    levels: Vec<Vec<[f32; 4]>>,
    first: usize,
    streamed: Option<&Streamed>,
    keep: usize,
    [mut hx, mut hy]: [u32; 2],
    fit: Option<(u32, u32)>,
) -> Capped {
    let (mut lw, mut lh) = level_size(w, h, keep);
    // Borrowed until the first reduction makes a level of its own: a copy of the border's
    // 763x1100 level 0 in f32 was 13 MB of the default scene's peak.
    let mut level: Option<Cow<'_, [[f32; 4]]>> =
        (keep >= first).then(|| Cow::Borrowed(levels[keep - first].as_slice()));
    while hx > 0 || hy > 0 {
        let nw = if hx > 0 { half(lw) } else { lw };
        let nh = if hy > 0 { half(lh) } else { lh };
        level = Some(Cow::Owned(match (&level, streamed) {
            (Some(l), _) => reduce_premultiplied(l, lw, lh, nw, nh),
            // Level 0 is never held whole when streamed: its first halving, band by band.
            (None, Some(s)) => s.reduced(nw, nh),
            (None, None) => unreachable!("levels below `first` are streamed"),
        }));
        hx = hx.saturating_sub(1);
        hy = hy.saturating_sub(1);
        (lw, lh) = (nw, nh);
    }
    let measure = |level: &[[f32; 4]], lw: u32, lh: u32| {
        let encoded = encode_premultiplied(level);
        match streamed {
            Some(s) => s.max_over_bands(|band, y0, _| {
                upsampled_error_rows(&encoded, lw, lh, band, y0, w, h)
            }),
            None => upsampled_error(&encoded, lw, lh, &levels[0], w, h),
        }
    };
    // `cook_projector` holds level 0 whole where a resample starts from it.
    let mut level = level.expect("halved, or held to be resampled");
    let mut halvings = [0, 0];
    let mut from = None;
    let max_error = match fit {
        None => measure(&level, lw, lh),
        Some((tw, th)) => {
            // Resampled to the cap (Lanczos: 5.0 LSB where a box gave 7.2, 256² from 274² at
            // σ 2.2), or the axes over it halved once more, whichever is nearer the blur: the
            // resample keeps more of it, except near 2:1 at a small σ, where the halving's
            // whole 2x2 boxes win (σ 0.5: 99 against 70 LSB).
            let resampled = reduce_premultiplied_with(&level, lw, lh, tw, th, MipFilter::Lanczos3);
            let by_resample = measure(&resampled, tw, th);
            halvings = [(tw < lw) as u32, (th < lh) as u32];
            let (nw, nh) = (
                if tw < lw { half(lw) } else { lw },
                if th < lh { half(lh) } else { lh },
            );
            let halved = reduce_premultiplied(&level, lw, lh, nw, nh);
            let by_halving = measure(&halved, nw, nh);
            if by_resample < by_halving {
                from = Some((lw, lh));
                halvings = [0, 0];
                (level, lw, lh) = (Cow::Owned(resampled), tw, th);
                by_resample
            } else {
                (level, lw, lh) = (Cow::Owned(halved), nw, nh);
                by_halving
            }
        }
    };
    let level = level.into_owned();
    drop(levels);
    let (pw, ph) = crate::bc::block_padded_size(lw, lh);
    let (chain, unpadded) = if block_pad && (pw, ph) != (lw, lh) {
        let padded = crate::pixels::pad_texels(&level, lw, lh, pw, ph, Some([0.0; 4]));
        let unpadded = encoded_chain(level, lw, lh);
        (encoded_chain(padded, pw, ph), Some(unpadded))
    } else {
        (encoded_chain(level, lw, lh), None)
    };
    Capped {
        chain,
        unpadded,
        size: (lw, lh),
        max_error,
        resampled_from: from,
        halvings,
    }
}

/// What [`reduced_to_cap`] stored.
struct Capped {
    chain: MipChain,
    unpadded: Option<MipChain>,
    size: (u32, u32),
    max_error: f64,
    resampled_from: Option<(u32, u32)>,
    halvings: [u32; 2],
}

/// The chain of `level` (`w x h`, premultiplied linear) down to 1x1, each level encoded as it
/// is walked.
fn encoded_chain(level: Vec<[f32; 4]>, w: u32, h: u32) -> MipChain {
    let mut chain = MipChain {
        width: w,
        height: h,
        levels: Vec::new(),
    };
    walk_chain(level, w, h, next_premultiplied, |l| {
        chain.levels.push(encode_premultiplied(&l))
    });
    chain
}

/// Which level the stored chain starts at, how many more times it is halved along x or along y
/// alone, the size it is then resampled to (where a halving would undershoot the cap), and its error:
/// the lowest level whose error stays within the budget, among those σ leaves detail for,
/// then lower still to fit the size cap. The cap halves an axis only while
/// that axis is over it: a lancet's design 32 texels across and 1024 up was halved both ways,
/// and its stripes across were lost (78 LSB). `error(k)` measures level `k` against the
/// full-resolution blur; with halvings along one axis or a resample the error is left to the
/// caller.
fn choose_level(
    opts: &ProjectorOptions,
    w: u32,
    h: u32,
    n: usize,
    mut error: impl FnMut(usize) -> f64,
) -> Kept {
    let mut keep = 0;
    let mut max_error = None;
    if let Some(budget) = opts.max_error_lsb {
        for k in 1..n {
            // A level coarser than σ cannot hold the blurred detail; don't spend a pass on it.
            // The narrower σ: the level must hold the sharper axis's detail too.
            if (1u64 << k) as f32 > opts.sigma_texels.min() {
                break;
            }
            let e = error(k);
            if e > budget as f64 {
                break;
            }
            keep = k;
            max_error = Some(e);
        }
    }
    if let Some(cap) = opts.max_size {
        let first = keep;
        // Halvings of one axis (`size` texels, margin `m`) from `keep` on until its design
        // part, the level less its margin of m / 2^k on each side, is within the cap.
        let halvings = |size: u32, m: u32| {
            let mut k = keep;
            let margin = if opts.cap_whole_level { 0 } else { m };
            let part =
                |k: usize| (size >> k).max(1) as f64 - 2.0 * margin as f64 / (1u64 << k) as f64;
            while (size >> k) > 1 && part(k) > cap as f64 {
                k += 1;
            }
            k
        };
        let (mut hx, mut hy) = (halvings(w, opts.margin[0]), halvings(h, opts.margin[1]));
        let mut fit = None;
        // An axis's level before its last halving is over the cap by less than twice:
        // resampled to the cap it keeps more of the blur than halved. Under a cap on the
        // whole level, block storage pads to whole blocks, which must stay within it too;
        // under the format's cap on the design part, the size whose design part is the cap.
        // Without it, a 300x600 design (616 texels down with its margin) was halved to 308
        // and stored 31 LSB off the blur the renderer samples at 512.
        let target = |size: u32, m: u32, j: usize| -> u32 {
            if opts.cap_whole_level {
                if opts.block_pad && cap >= 4 {
                    cap / 4 * 4
                } else {
                    cap
                }
            } else {
                let s = (size >> j).max(1) as f64;
                let part = s - 2.0 * m as f64 / (1u64 << j) as f64;
                (s * cap as f64 / part).floor() as u32
            }
        };
        let back = |k: usize, size: u32, m: u32| match k.checked_sub(1) {
            Some(j)
                if k > first
                    && (size >> j) > target(size, m, j)
                    && (size >> k).max(1) < target(size, m, j) =>
            {
                (j, target(size, m, j))
            }
            _ => (k, (size >> k).max(1)),
        };
        let ((sx, tx), (sy, ty)) = (back(hx, w, opts.margin[0]), back(hy, h, opts.margin[1]));
        if (sx, sy) != (hx, hy) {
            (hx, hy) = (sx, sy);
            fit = Some((tx, ty));
        }
        keep = hx.min(hy).min(n - 1);
        let extra = [(hx - keep) as u32, (hy - keep) as u32];
        if extra != [0, 0] || fit.is_some() {
            return Kept {
                level: keep,
                halved: extra,
                fit,
                max_error: None,
            };
        }
        if keep > first {
            // Against the full-resolution blur, like the budget's levels: what the cap costs.
            return Kept {
                level: keep,
                halved: extra,
                fit: None,
                max_error: Some(error(keep)),
            };
        }
    }
    if opts.max_error_lsb.is_some() && max_error.is_none() {
        max_error = Some(error(0));
    }
    Kept {
        level: keep,
        halved: [0, 0],
        fit: None,
        max_error,
    }
}

/// What [`choose_level`] chose.
struct Kept {
    level: usize,
    halved: [u32; 2],
    fit: Option<(u32, u32)>,
    max_error: Option<f64>,
}

/// Whether the size cap resamples level 0 itself, not halved along either axis first: such a
/// level must be held whole, not streamed. [`choose_level`] as it goes when no level below
/// 0 is within the budget: a budget that keeps a lower level never starts from level 0.
/// Where the cap halves one axis before the resample (the default scene's border, 763x1100
/// halved down, then resampled across), the halving is streamed and level 0 never held: it
/// was 13 MB of f32.
fn resamples_level0(opts: &ProjectorOptions, w: u32, h: u32) -> bool {
    if opts.max_size.is_none() {
        return false;
    }
    let k = choose_level(opts, w, h, level_count(w, h), |_| f64::INFINITY);
    k.level == 0 && k.halved == [0, 0] && k.fit.is_some()
}

/// The blur of an 8-bit design, a band of rows at a time.
struct Streamed<'a>(RowBlur<'a>);

impl Streamed<'_> {
    /// Rows per band: 2 MiB of f32 at 1024 texels a row; even, so each band halves on its own.
    const BAND: u32 = 128;

    fn bands(&self) -> impl Iterator<Item = (u32, u32)> + use<> {
        let h = self.0.size().1;
        (0..h)
            .step_by(Self::BAND as usize)
            .map(move |y0| (y0, (y0 + Self::BAND).min(h)))
    }

    /// The blur's level 1, [`premultiplied_levels`]' bits, from band after band.
    fn half(&self) -> Vec<[f32; 4]> {
        let (w, h) = self.0.size();
        self.reduced(half(w), half(h))
    }

    /// The blur reduced to `nw x nh` (each its own size or half of it) as
    /// [`reduce_premultiplied`] reduces it, from band after band.
    fn reduced(&self, nw: u32, nh: u32) -> Vec<[f32; 4]> {
        let (w, h) = self.0.size();
        // Output rows per band: a band's source rows, `BAND` of them, as before.
        let band = if nh < h { Self::BAND / 2 } else { Self::BAND } as usize;
        reduce_to_by_rows(
            w,
            h,
            nw,
            nh,
            MipFilter::Box,
            band,
            |r| self.0.rows(r.start as u32..r.end as u32),
            |t| t,
            |t| t.map(clamp01),
        )
    }

    /// The largest of `f(band, y0, y1)` over the bands of rows `y0..y1`.
    fn max_over_bands(&self, f: impl Fn(&[[f32; 4]], u32, u32) -> f64) -> f64 {
        self.bands()
            .map(|(y0, y1)| f(&self.0.rows(y0..y1), y0, y1))
            .fold(0.0, f64::max)
    }
}

/// Box mip chain of premultiplied linear RGBA (already alpha-weighted, so plain filtering).
pub fn premultiplied_levels(level0: Vec<[f32; 4]>, w: u32, h: u32) -> Vec<Vec<[f32; 4]>> {
    let mut levels = Vec::new();
    walk_chain(level0, w, h, next_premultiplied, |l| levels.push(l));
    levels
}

/// A premultiplied level (`w x h`) box-filtered to `nw x nh`, no larger, clamped as
/// [`next_premultiplied`] clamps: the size cap's halving along one axis, or its resample.
fn reduce_premultiplied(level: &[[f32; 4]], w: u32, h: u32, nw: u32, nh: u32) -> Vec<[f32; 4]> {
    reduce_premultiplied_with(level, w, h, nw, nh, MipFilter::Box)
}

/// [`reduce_premultiplied`] through `filter`.
fn reduce_premultiplied_with(
    level: &[[f32; 4]],
    w: u32,
    h: u32,
    nw: u32,
    nh: u32,
    filter: MipFilter,
) -> Vec<[f32; 4]> {
    let mut out = reduce_to(level, w, h, nw, nh, filter, |t| t);
    out.iter_mut().for_each(|t| *t = t.map(clamp01));
    out
}

/// One step of [`premultiplied_levels`].
fn next_premultiplied(level: &[[f32; 4]], w: u32, h: u32) -> Vec<[f32; 4]> {
    next_level(level, w, h, MipFilter::Box, |t| t, |t| t.map(clamp01))
}

/// Premultiplied linear RGBA → RGBA8 (sRGB colour, linear alpha).
pub fn encode_premultiplied(level: &[[f32; 4]]) -> Vec<u8> {
    let mut out = vec![0u8; level.len() * 4];
    out.par_chunks_mut(4 * 1024)
        .zip(level.par_chunks(1024))
        .for_each(|(o, l)| encoder().encode_rgba(l, o));
    out
}

/// Bilinear sample positions of a `from`-texel axis at the texel centres of a `to`-texel axis,
/// as the GPU computes them (clamp to edge).
fn bilinear_axis(from: u32, to: u32) -> Vec<(usize, usize, f32)> {
    (0..to)
        .map(|i| {
            let u = (i as f64 + 0.5) / to as f64 * from as f64 - 0.5;
            let u = u.clamp(0.0, from as f64 - 1.0);
            let i0 = u.floor() as usize;
            let i1 = (i0 + 1).min(from as usize - 1);
            (i0, i1, (u - i0 as f64) as f32)
        })
        .collect()
}

/// Upper bounds of the sRGB encode's slope (in LSB per unit of linear light), per bin of
/// linear values: a colour's exact error costs two `powf`s, and only texels that might beat
/// the largest error found so far need them.
struct EncodeSlopes([f64; EncodeSlopes::BINS]);

impl EncodeSlopes {
    const BINS: usize = 1024;

    fn get() -> &'static EncodeSlopes {
        static SLOPES: std::sync::OnceLock<EncodeSlopes> = std::sync::OnceLock::new();
        SLOPES.get_or_init(|| {
            // The slope never rises on [0, 1], so a bin's value at its lower edge bounds it
            // over the whole bin and above.
            EncodeSlopes(std::array::from_fn(|b| {
                linear_to_srgb_lsb_slope(b as f64 / Self::BINS as f64)
            }))
        })
    }

    /// At least |encode(v) - encode(r)| in LSB, for v and r in [0, 1]: by the mean value
    /// theorem it is the slope somewhere between them times |v - r|, and the slope there is
    /// at most the bound of the lower one's bin. The margin covers the rounding of `powf`.
    fn bound(&self, v: f64, r: f64) -> f64 {
        let low = v.min(r);
        let bin = ((low * Self::BINS as f64) as usize).min(Self::BINS - 1);
        self.0[bin] * (v - r).abs() * (1.0 + 1e-9) + 1e-9
    }
}

/// Max error (LSB) of an RGBA8 level sampled bilinearly in linear light (as through an sRGB
/// view) at every texel of a `w x h` reference, against that reference unrounded.
pub fn upsampled_error(
    bytes: &[u8],
    lw: u32,
    lh: u32,
    reference: &[[f32; 4]],
    w: u32,
    h: u32,
) -> f64 {
    upsampled_error_rows(bytes, lw, lh, reference, 0, w, h)
}

/// [`upsampled_error`] over rows `y0..` of the reference only, which `reference` holds.
///
/// Bilinear sampling is separable: the reference rows between the same two level rows (all
/// of them but one in every `2^k` for level `k`) share those rows interpolated across, so each
/// level row is decoded and interpolated across once per run of reference rows rather than
/// at every texel. Same arithmetic, in the same order, as sampling texel by texel.
fn upsampled_error_rows(
    bytes: &[u8],
    lw: u32,
    lh: u32,
    reference: &[[f32; 4]],
    y0: u32,
    w: u32,
    h: u32,
) -> f64 {
    let lut = decode8();
    let xs = bilinear_axis(lw, w);
    let ys = bilinear_axis(lh, h);
    let rows = reference.len() / w as usize;
    let ys = &ys[y0 as usize..][..rows];
    // Runs of reference rows that sample the same two level rows.
    let mut runs: Vec<std::ops::Range<usize>> = Vec::new();
    for (i, &(a, b, _)) in ys.iter().enumerate() {
        match runs.last_mut() {
            Some(r) if (ys[r.start].0, ys[r.start].1) == (a, b) => r.end = i + 1,
            _ => runs.push(i..i + 1),
        }
    }
    let across = |y: usize, out: &mut Vec<[f32; 4]>| {
        let row = &bytes[y * lw as usize * 4..][..lw as usize * 4];
        let texel = |x: usize| -> [f32; 4] {
            let b = &row[x * 4..][..4];
            [
                lut[b[0] as usize],
                lut[b[1] as usize],
                lut[b[2] as usize],
                b[3] as f32 / 255.0,
            ]
        };
        out.clear();
        out.extend(xs.iter().map(|&(x0, x1, fx)| {
            let (a, b) = (texel(x0), texel(x1));
            std::array::from_fn(|ch| a[ch] + (b[ch] - a[ch]) * fx)
        }));
    };
    let slopes = EncodeSlopes::get();
    runs.into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(top, bottom), run| {
                let (ly0, ly1, _) = ys[run.start];
                across(ly0, top);
                across(ly1, bottom);
                let mut max = 0.0f64;
                for i in run {
                    let fy = ys[i].2;
                    let row = &reference[i * w as usize..][..w as usize];
                    for ((r, t), b) in row.iter().zip(top.iter()).zip(bottom.iter()) {
                        for ch in 0..4 {
                            let v = (t[ch] + (b[ch] - t[ch]) * fy) as f64;
                            let e = if ch < 3 {
                                let (v, r) = (v.clamp(0.0, 1.0), (r[ch] as f64).clamp(0.0, 1.0));
                                if slopes.bound(v, r) <= max {
                                    continue;
                                }
                                linear_to_srgb_lsb(v) - linear_to_srgb_lsb(r)
                            } else {
                                (v - r[3].clamp(0.0, 1.0) as f64) * 255.0
                            };
                            max = max.max(e.abs());
                        }
                    }
                }
                max
            },
        )
        .reduce(|| 0.0, f64::max)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The margin is said in the design's texels where the stored level is smaller than the
    /// design with its margins (a size cap), and the error against what.
    #[test]
    fn the_report_says_what_its_numbers_are_in() {
        let mut r = ProjectorReport {
            sigma_texels: 2.0.into(),
            method: BlurMethod::Direct,
            design_width: 100,
            design_height: 200,
            width: 116,
            height: 216,
            dropped_levels: 0,
            halved: [0, 0],
            resampled_from: None,
            margin: [8, 8],
            max_error_lsb: Some(0.5),
        };
        assert_eq!(
            r.to_string(),
            "sigma 2.00 texels (direct), 116x216 with a margin of 8 texels, max error 0.500 LSB \
             against the full-size blur"
        );
        (r.width, r.height) = (29, 54);
        assert!(
            r.to_string()
                .contains("29x54 with a margin of 8 design texels"),
            "{r}"
        );
    }

    /// Every texel and channel through the exact encode: what `upsampled_error` must equal.
    fn exhaustive(bytes: &[u8], lw: u32, lh: u32, reference: &[[f32; 4]], w: u32) -> f64 {
        let lut = decode8();
        let xs = bilinear_axis(lw, w);
        let ys = bilinear_axis(lh, reference.len() as u32 / w);
        let texel = |x: usize, y: usize, ch: usize| {
            let b = bytes[(y * lw as usize + x) * 4 + ch];
            if ch < 3 {
                lut[b as usize]
            } else {
                b as f32 / 255.0
            }
        };
        let mut max = 0.0f64;
        for (row, &(y0, y1, fy)) in reference.chunks(w as usize).zip(&ys) {
            for (r, &(x0, x1, fx)) in row.iter().zip(&xs) {
                for ch in 0..4 {
                    let top = texel(x0, y0, ch) + (texel(x1, y0, ch) - texel(x0, y0, ch)) * fx;
                    let bottom = texel(x0, y1, ch) + (texel(x1, y1, ch) - texel(x0, y1, ch)) * fx;
                    let v = (top + (bottom - top) * fy) as f64;
                    let e = if ch < 3 {
                        linear_to_srgb_lsb(v) - linear_to_srgb_lsb(r[ch] as f64)
                    } else {
                        (v - r[3].clamp(0.0, 1.0) as f64) * 255.0
                    };
                    max = max.max(e.abs());
                }
            }
        }
        max
    }

    #[test]
    fn skipping_texels_by_the_slope_bound_changes_no_maximum() {
        let (w, h) = (37u32, 29u32);
        let mut seed = 0x9e37_79b9_u32;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        // Dark values (the steep toe of the encode), mid tones, and values just outside [0, 1].
        for scale in [0.004f32, 0.05, 1.0, 1.02] {
            let reference: Vec<[f32; 4]> = (0..w * h)
                .map(|_| std::array::from_fn(|_| next() * scale - 0.01))
                .collect();
            let (lw, lh) = (half(w), half(h));
            let level: Vec<u8> = (0..lw * lh * 4).map(|_| (next() * 255.0) as u8).collect();
            let rounded: Vec<u8> = reference
                .iter()
                .flat_map(|t| encode_premultiplied(&[t.map(|c| c.clamp(0.0, 1.0))]))
                .collect();
            for (bytes, lw, lh) in [(&level, lw, lh), (&rounded, w, h)] {
                let fast = upsampled_error(bytes, lw, lh, &reference, w, h);
                let exact = exhaustive(bytes, lw, lh, &reference, w);
                assert_eq!(fast.to_bits(), exact.to_bits(), "scale {scale}, {lw}x{lh}");
            }
        }
    }

    #[test]
    fn streaming_a_large_design_changes_no_bit() {
        let panes = crate::testing::Panes {
            width: 9,
            height: 5,
            lead: 2,
        };
        // Direct and decimated blurs, odd widths, and an odd height.
        let cases = [
            (300u32, 260u32, 2.2f32),
            (258, 40, 0.7),
            (96, 388, 4.5),
            (329, 200, 2.2),
            (301, 256, 6.6),
            (260, 130, 9.4),
            (200, 301, 3.0),
        ];
        // And blurs wider one way: a design stretched onto its window.
        let stretched = [
            (300u32, 260u32, Sigma2::new(2.2, 0.8)),
            (301, 256, Sigma2::new(6.6, 12.0)),
        ];
        let cases = cases
            .into_iter()
            .map(|(w, h, s)| (w, h, Sigma2::from(s)))
            .chain(stretched);
        for (w, h, sigma) in cases {
            let design = DynamicImage::ImageRgba8(
                image::RgbaImage::from_raw(
                    w,
                    h,
                    crate::testing::design(w as usize, h as usize, 3, panes),
                )
                .unwrap(),
            );
            for (budget, cap, pad, whole) in [
                (Some(1.0), Some(128), true, false),
                (Some(0.2), Some(256), false, false),
                (None, Some(100), true, false),
                (Some(8.0), Some(32), false, false),
                // A cap on the whole level: resampled from level 1, or from level 0 (held).
                (None, Some(150), true, true),
                (Some(1.0), Some(270), false, true),
            ] {
                let opts = ProjectorOptions {
                    max_error_lsb: budget,
                    max_size: cap,
                    cap_whole_level: whole,
                    block_pad: pad,
                    margin: if pad {
                        projector_margin(sigma, w, h)
                    } else {
                        [0, 0]
                    },
                    ..ProjectorOptions::new(sigma)
                };
                let streamed = cook_projector(&design, &opts, true).unwrap();
                let whole = cook_projector(&design, &opts, false).unwrap();
                assert_eq!(
                    streamed.0.levels, whole.0.levels,
                    "{w}x{h} σ={sigma} {opts:?}"
                );
                assert_eq!(
                    streamed.1.map(|c| c.levels),
                    whole.1.map(|c| c.levels),
                    "{w}x{h} σ={sigma} {opts:?}"
                );
                assert_eq!(streamed.2, whole.2, "{w}x{h} σ={sigma} {opts:?}");
            }
        }
    }

    /// A margin is the design framed in transparent texels: the same texture as cooking the
    /// framed design without one, from 8-bit and 16-bit designs alike (with the cap counting
    /// the design's part only).
    #[test]
    fn a_margin_is_the_design_framed_in_transparent_texels() {
        let panes = crate::testing::Panes {
            width: 6,
            height: 4,
            lead: 1,
        };
        let (w, h, sigma) = (70u32, 44u32, 2.2f32);
        assert_eq!(projector_margin(sigma, w, h), [9, 9]);
        // At most half the longer side; none without a blur; each axis by its own σ.
        let at = |s: f32| projector_margin(s, w, h);
        assert_eq!((at(1e4), at(0.0), at(f32::NAN)), ([35, 35], [0, 0], [0, 0]));
        assert_eq!(projector_margin(Sigma2::new(0.5, 2.2), w, h), [2, 9]);
        let bytes = crate::testing::design(w as usize, h as usize, 4, panes);
        let img8 =
            DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w, h, bytes.clone()).unwrap());
        for sigma in [
            Sigma2::from(sigma),
            Sigma2::new(2.2, 0.9),
            Sigma2::new(1.0, 3.0),
        ] {
            let m = projector_margin(sigma, w, h);
            let framed =
                crate::testing::framed(&bytes, w as usize, h as usize, m.map(|m| m as usize));
            let framed8 = DynamicImage::ImageRgba8(
                image::RgbaImage::from_raw(w + 2 * m[0], h + 2 * m[1], framed).unwrap(),
            );
            for (design, framed) in [
                (img8.clone(), framed8.clone()),
                (
                    DynamicImage::ImageRgba16(img8.to_rgba16()),
                    DynamicImage::ImageRgba16(framed8.to_rgba16()),
                ),
            ] {
                let opts = ProjectorOptions {
                    max_error_lsb: Some(1.0),
                    ..ProjectorOptions::new(sigma)
                };
                let with = projector(&design, &ProjectorOptions { margin: m, ..opts }).unwrap();
                let without = projector(&framed, &opts).unwrap();
                assert_eq!(with.0.levels, without.0.levels);
                assert_eq!((with.1.width, with.1.height), (w + 2 * m[0], h + 2 * m[1]));
                assert_eq!(with.1.margin, m);
                assert_eq!((with.1.design_width, with.1.design_height), (w, h));
            }
        }
        let m = projector_margin(sigma, w, h);
        // The cap counts the design's part: 70 texels wide fit a cap of 70 with any margin.
        let capped = |cap| {
            let opts = ProjectorOptions {
                max_size: Some(cap),
                margin: m,
                ..ProjectorOptions::new(sigma)
            };
            let report = projector(&img8, &opts).unwrap().1;
            let resampled = report.resampled_from.is_some();
            (report.dropped_levels, report.halved, resampled)
        };
        // 69 is over the cap across only, by a texel: resampled to it rather than halved.
        // 35 is over it both ways: halved across, where the half is the cap, and down (44)
        // resampled to it, nearer the blur than a halving to 22.
        assert_eq!(
            (capped(70), capped(69), capped(35)),
            ((0, [0, 0], false), (0, [0, 0], true), (0, [1, 0], true))
        );
        let wide = ProjectorOptions {
            margin: [9, 71],
            ..ProjectorOptions::new(sigma)
        };
        assert!(matches!(
            projector(&img8, &wide),
            Err(TextureError::MarginTooWide { margin: 71, .. })
        ));
    }

    /// A design a little over the format's cap on the design part (300 x 600 under 512) is
    /// resampled to the cap, its margin kept on top, rather than halved to 300 down: the
    /// renderer samples it at 512, and the halving stored it 31 LSB off the blur.
    #[test]
    fn a_design_a_little_over_the_format_s_cap_is_resampled_to_it() {
        let design = DynamicImage::ImageRgba8(image::RgbaImage::from_fn(300, 600, |x, y| {
            let band = (y / 6 + x / 50) % 3;
            image::Rgba([[230, 40, 40, 255], [40, 200, 60, 255], [30, 60, 220, 255]][band as usize])
        }));
        let sigma = Sigma2::from(2.2);
        let opts = ProjectorOptions {
            max_size: Some(512),
            margin: projector_margin(sigma, 300, 600),
            ..ProjectorOptions::new(sigma)
        };
        let m = opts.margin;
        let (chain, report) = projector(&design, &opts).unwrap();
        assert_eq!(
            report.resampled_from,
            Some((300 + 2 * m[0], 600 + 2 * m[1])),
            "{report}"
        );
        // Its design part is the cap, within a texel of rounding.
        let part = chain.height as f64 * 600.0 / (600 + 2 * m[1]) as f64;
        assert!((part - 512.0).abs() < 1.0, "{report}: {part}");
        assert_eq!(chain.width, 300 + 2 * m[0]);
        let halved = {
            let mut h = opts;
            h.max_size = Some(300);
            projector(&design, &h).unwrap().1.max_error_lsb.unwrap()
        };
        let e = report.max_error_lsb.unwrap();
        assert!(e < halved * 0.5, "{report}: halving gave {halved}");
    }

    /// A design over the size cap along one axis only is halved along that axis alone: a
    /// lancet's 32 x 1024 design of stripes two texels wide, blurred σ 0.69 across and 2.75
    /// down, keeps its stripes (they were lost to a halving both ways: 78.7 LSB, now 7.6).
    #[test]
    fn a_design_over_the_cap_one_way_keeps_its_detail_the_other_way() {
        let colours = [
            [255u8, 0, 0, 255],
            [0, 255, 0, 255],
            [0, 0, 255, 255],
            [255; 4],
        ];
        let design = DynamicImage::ImageRgba8(image::RgbaImage::from_fn(32, 1024, |x, _| {
            image::Rgba(colours[(x as usize / 2) % 4])
        }));
        let sigma = Sigma2::new(0.69, 2.75);
        let opts = ProjectorOptions {
            max_error_lsb: Some(1.0),
            max_size: Some(512),
            margin: projector_margin(sigma, 32, 1024),
            ..ProjectorOptions::new(sigma)
        };
        let (chain, report) = projector(&design, &opts).unwrap();
        assert_eq!(
            (report.dropped_levels, report.halved),
            (0, [0, 1]),
            "{report}"
        );
        assert_eq!(
            (chain.width, chain.height),
            (32 + 2 * opts.margin[0], (1024 + 2 * opts.margin[1]) / 2)
        );
        // What is left is the light's fade at the top and bottom, halved (7.6 LSB where sRGB
        // is steep), not the stripes.
        let e = report.max_error_lsb.unwrap();
        assert!(e < 10.0, "{report}");
        assert!(
            report
                .to_string()
                .contains("halved 1 more time(s) down only"),
            "{report}"
        );
    }

    /// A cap on the whole level that the design fits but its light margin does not resamples
    /// the level down to the cap: a 256² design with σ 2.2 is 274² with its margin, and at a
    /// cap of 256 it was halved to 137² (12.6 LSB); resampled it stays 256² (5.0 LSB). Where
    /// halving comes nearer (close to 2:1 at a small σ) it is halved. Block storage keeps the
    /// padded level within the cap.
    #[test]
    fn a_margin_over_a_whole_level_cap_is_resampled_not_halved() {
        let panes = crate::testing::Panes {
            width: 8,
            height: 8,
            lead: 2,
        };
        let (w, h, sigma) = (256u32, 256u32, 2.2f32);
        let bytes = crate::testing::design(w as usize, h as usize, 3, panes);
        let design = DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w, h, bytes).unwrap());
        let m = projector_margin(sigma, w, h);
        let at = |cap: u32, pad: bool| {
            let opts = ProjectorOptions {
                max_size: Some(cap),
                cap_whole_level: true,
                block_pad: pad,
                margin: m,
                ..ProjectorOptions::new(sigma)
            };
            projector(&design, &opts).unwrap()
        };
        let (chain, report) = at(256, false);
        assert_eq!((chain.width, chain.height), (256, 256), "{report}");
        assert_eq!(report.resampled_from, Some((274, 274)), "{report}");
        assert_eq!((report.dropped_levels, report.halved), (0, [0, 0]));
        let fitted = report.max_error_lsb.unwrap();
        assert!(fitted < 6.0, "{report}");
        assert!(
            report
                .to_string()
                .contains("resampled from 274x274 to the size cap"),
            "{report}"
        );
        // What halving gave: the same level halved, measured the same way.
        let halved = {
            let opts = ProjectorOptions {
                margin: m,
                ..ProjectorOptions::new(sigma)
            };
            let (full, _) = projector(&design, &opts).unwrap();
            let reference = premultiplied_levels(
                blur_rgba8_framed_to_linear(
                    design.as_rgba8().unwrap().as_raw(),
                    w,
                    h,
                    m,
                    sigma,
                    BlurMethod::Auto,
                )
                .unwrap(),
                274,
                274,
            )
            .swap_remove(0);
            upsampled_error(&full.levels[1], 137, 137, &reference, 274, 274)
        };
        assert!(fitted * 2.0 < halved, "resampled {fitted}, halved {halved}");
        // A cap that is not whole blocks: the padded level stays within it.
        let (chain, report) = at(255, true);
        assert_eq!((chain.width, chain.height), (252, 252), "{report}");
        // Two levels over: halved once, then resampled; one axis over: that axis alone.
        let (chain, report) = at(130, false);
        assert_eq!((chain.width, chain.height), (130, 130), "{report}");
        assert_eq!(
            (report.dropped_levels, report.resampled_from),
            (1, Some((137, 137)))
        );
        let (chain, report) = at(300, false);
        assert_eq!((chain.width, chain.height), (274, 274), "{report}");
        assert_eq!(report.resampled_from, None);
        // σ 0.5 (260² with its margin) at a cap of 131: resampled 99 LSB off, halved 70.
        let opts = ProjectorOptions {
            max_size: Some(131),
            cap_whole_level: true,
            margin: projector_margin(0.5, w, h),
            ..ProjectorOptions::new(0.5)
        };
        let (chain, report) = projector(&design, &opts).unwrap();
        assert_eq!((chain.width, chain.height), (130, 130), "{report}");
        assert_eq!(
            (report.dropped_levels, report.halved, report.resampled_from),
            (1, [0, 0], None)
        );
    }

    /// An opaque white design's light spreads into the margin and has faded to black at its
    /// outer edge: the margin holds the whole penumbra.
    #[test]
    fn the_light_fades_to_black_across_the_margin() {
        for sigma in [0.8f32, 2.2, 7.5] {
            let (w, h) = (64u32, 40u32);
            let img = DynamicImage::ImageRgba8(image::RgbaImage::from_pixel(
                w,
                h,
                image::Rgba([255, 255, 255, 255]),
            ));
            let [m, _] = projector_margin(sigma, w, h);
            let opts = ProjectorOptions {
                margin: [m, m],
                ..ProjectorOptions::new(sigma)
            };
            let (chain, _) = projector(&img, &opts).unwrap();
            let fw = (w + 2 * m) as usize;
            let row = |y: usize| &chain.levels[0][y * fw * 4..(y + 1) * fw * 4];
            // Along the middle row: black at the outer edge, light just outside the design.
            let mid = row((h / 2 + m) as usize);
            assert_eq!(&mid[..4], &[0, 0, 0, 0], "σ={sigma}");
            let outside = (m as usize - 1) * 4;
            assert!(
                mid[outside] > 0 && mid[outside + 3] > 0,
                "σ={sigma}: {:?}",
                &mid[outside..outside + 4]
            );
            assert!(
                row(0).iter().all(|&b| b == 0),
                "σ={sigma}: light on the outer edge"
            );
        }
    }

    #[test]
    fn the_slope_bound_holds_on_a_fine_grid() {
        let slopes = EncodeSlopes::get();
        for i in 0..=20_000u32 {
            for j in [0u32, 1, 7, 100, 5_000, 20_000] {
                let (v, r) = (i as f64 / 20_000.0, j as f64 / 20_000.0);
                let exact = (linear_to_srgb_lsb(v) - linear_to_srgb_lsb(r)).abs();
                assert!(slopes.bound(v, r) >= exact, "{v} {r}");
            }
        }
    }
}
