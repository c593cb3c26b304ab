//! Gaussian blur of premultiplied linear RGBA with a zero border, and its exact f64 reference.
//!
//! The filter is the sampled Gaussian `exp(-x²/2σ²)` truncated at `KERNEL_RADIUS_SIGMAS·σ` and
//! renormalized to sum to one. Outside the image everything is zero: for a window, outside is
//! opaque wall that lets no light through, so the blurred light fades out at the edges.
//!
//! Two implementations of the same filter:
//! - [`BlurMethod::Direct`]: separable FIR with that kernel in f32, cost O(σ) per texel.
//! - [`BlurMethod::Decimated`]: the Gaussian split in two, `G_σ = G_τ ∗ G_τ` with `τ = σ/√2`.
//!   The first half is evaluated only on a grid of every k-th texel (k ≈ σ/1.9), the second
//!   half interpolates back from that grid with Gaussian weights. By Poisson summation the sum
//!   over the grid equals the continuous convolution up to `2·exp(-2π²(σ/2k)²)` ≈ 4e-8 of the
//!   peak, so this is the same filter to f32 precision, at a cost of about 30 multiply-adds per
//!   texel and axis whatever σ is. No recursion, so no drift at large σ, and every output is a
//!   positive-weighted sum, so dark regions keep their relative precision (which sRGB needs).
//!
//! Both accumulate in f32 with an f32 intermediate between passes, run rows (or columns) in
//! parallel with a fixed operation order per output, and so give the same bits on any number of
//! threads.
//!
//! Two faster approximations with a larger, measured error (docs/bench has the figures; the
//! cooker picks one only when `--max-error` allows it):
//! - [`BlurMethod::DecimatedCoarse`]: the decimated method with the kernel cut at 3σ and a grid
//!   of every k-th texel with k ≈ σ/1.3, about 2.4 times fewer taps. The truncated tail (2.7e-3
//!   of the mass) and the aliasing term (5e-4 of the peak) are the error.
//! - [`BlurMethod::Box3`]: three extended box filters per axis (Gwosdek, Grewenig, Bruhn and
//!   Weickert, "Theoretical foundations of Gaussian convolution by extended box filtering",
//!   2011): a box of radius r with fractional end taps α, chosen so that the three passes have
//!   exactly the variance σ². Running sums, so a handful of additions per texel and pass
//!   whatever σ is. The error is the shape: a piecewise quadratic instead of a Gaussian.
//!   Running sums are kept in f64, so cancellation in long rows costs nothing visible in dark
//!   regions; every pass preserves mass exactly in exact arithmetic, and the zero border is
//!   honoured by running the first two passes over the image plus their reach on each side.

use rayon::prelude::*;

use crate::TextureError;
use crate::fir::{QUAD, Quad, symmetric};
use crate::srgb::{
    decode_premultiplied, decode_premultiplied_columns, encoder, linear_to_srgb_lsb,
};

/// Kernel truncation radius in σ. The mass beyond 5σ is 5.7e-7: under 0.002 LSB even where
/// the sRGB curve is steepest.
pub const KERNEL_RADIUS_SIGMAS: f64 = 5.0;

/// Largest σ accepted, in texels (far beyond any texture; keeps kernel tables bounded).
pub const MAX_SIGMA: f32 = 1e5;

/// Below this σ the Gaussian is a delta to f64 precision at one texel (exp(-1/2σ²) < 1e-300).
const DELTA_SIGMA: f64 = 0.03;

/// Ratio σ / k of the decimated method: keeps the Poisson aliasing term 2·exp(-2π²(σ/2k)²)
/// near 3.5e-8.
const DECIMATION_RATIO: f64 = 1.9;

/// Where [`BlurMethod::Auto`] changes from direct to decimated: the σ where their measured times
/// cross on 1024² and 4096² images (docs/bench has the sweep).
pub const AUTO_DECIMATED_SIGMA: f64 = 6.5;

/// A Gaussian's σ in texels along x and along y. A design stretched onto its window has more
/// texels per unit along one axis than the other, so one blur length on the glass is two
/// numbers of texels. A single `f32` converts to the round blur.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct Sigma2 {
    pub x: f32,
    pub y: f32,
}

impl Sigma2 {
    pub fn new(x: f32, y: f32) -> Self {
        Sigma2 { x, y }
    }

    /// The narrower axis's σ: it decides what the blur leaves of the detail.
    pub fn min(self) -> f32 {
        self.x.min(self.y)
    }

    /// The wider axis's σ: it decides how far the blur reaches.
    pub fn max(self) -> f32 {
        self.x.max(self.y)
    }
}

impl From<f32> for Sigma2 {
    fn from(s: f32) -> Self {
        Sigma2 { x: s, y: s }
    }
}

/// One number for a round blur (as before there were two), `x by y` otherwise.
impl std::fmt::Display for Sigma2 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let precision = f.precision();
        let one = |f: &mut std::fmt::Formatter<'_>, v: f32| match precision {
            Some(p) => write!(f, "{v:.p$}"),
            None => write!(f, "{v}"),
        };
        one(f, self.x)?;
        if self.y != self.x {
            write!(f, " x ")?;
            one(f, self.y)?;
        }
        Ok(())
    }
}

/// [`Sigma2`] checked, in f64.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sig {
    x: f64,
    y: f64,
}

/// The decimated method's accuracy knobs: grid ratio σ / k and kernel truncation in σ.
#[derive(Clone, Copy, Debug)]
struct Decimation {
    ratio: f64,
    radius_sigmas: f64,
    /// Scale the first stage's taps so each residue class mod k sums to 1/k. Every input texel
    /// meets the taps of one class only, and the second stage hands each coarse sample out with
    /// total weight k, so this makes mass exact despite the grid's aliasing (and keeps constants
    /// constant, as the taps still sum to one). The exact grid aliases by 4e-8 and is left alone.
    balance: bool,
}

const EXACT: Decimation = Decimation {
    ratio: DECIMATION_RATIO,
    radius_sigmas: KERNEL_RADIUS_SIGMAS,
    balance: false,
};

/// Aliasing 2·exp(-2π²(1.3/2)²) ≈ 5e-4 of the peak and 2.7e-3 of the mass cut off: a few LSB
/// at most, for about 2.4 times fewer taps than [`EXACT`].
const COARSE: Decimation = Decimation {
    ratio: 1.3,
    radius_sigmas: 3.0,
    balance: true,
};

impl Decimation {
    fn k(self, sigma: f64) -> usize {
        ((sigma / self.ratio).floor() as usize).max(1)
    }
}

/// How the blur is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BlurMethod {
    /// Direct below σ = [`AUTO_DECIMATED_SIGMA`], decimated from there (where the decimated
    /// method's cost, constant in σ, drops below the direct one's, linear in σ).
    #[default]
    Auto,
    /// Separable FIR with the truncated kernel.
    Direct,
    /// Two half-width Gaussians through a grid of every k-th texel (direct below σ = 3.8).
    Decimated,
    /// Approximation: the decimated method on a coarser grid with the kernel cut at 3σ (direct,
    /// which is exact, below σ = 2.6).
    DecimatedCoarse,
    /// Approximation: three extended box filters per axis with the variance of the Gaussian
    /// (direct, which is exact, below σ = 2). Where the box would be wider than the image plus 64 texels (σ beyond the image size),
    /// the exact decimated method runs instead: it is as cheap there and needs no padding.
    Box3,
}

impl BlurMethod {
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Direct => "direct",
            Self::Decimated => "decimated",
            Self::DecimatedCoarse => "decimated-coarse",
            Self::Box3 => "box3",
        }
    }

    /// Every method, `Auto` first.
    pub const ALL: [BlurMethod; 5] = [
        Self::Auto,
        Self::Direct,
        Self::Decimated,
        Self::DecimatedCoarse,
        Self::Box3,
    ];

    /// True for the methods whose error is above the 8-bit rounding floor by design.
    pub fn is_approximation(self) -> bool {
        matches!(self, Self::DecimatedCoarse | Self::Box3)
    }

    /// The method used at this σ. The decimated grid needs σ ≥ 2·1.9 texels to stay exact
    /// (below that the Gaussian halves are too narrow for their samples), so smaller σ always
    /// runs direct, which is cheap there anyway.
    ///
    /// Two σ resolve by the narrower one: every method but the direct one needs its σ on both
    /// axes.
    pub fn resolve(self, sigma: impl Into<Sigma2>) -> Self {
        let sigma = sigma.into();
        let s = sigma.min() as f64;
        let mean = (sigma.x as f64 + sigma.y as f64) / 2.0;
        match self {
            Self::Box3 if s >= BOX_MIN_SIGMA => Self::Box3,
            Self::DecimatedCoarse if COARSE.k(s) >= 2 => Self::DecimatedCoarse,
            // The direct method's cost grows with both σ, the decimated one's with neither.
            Self::Auto if EXACT.k(s) >= 2 && mean >= AUTO_DECIMATED_SIGMA => Self::Decimated,
            Self::Decimated if EXACT.k(s) >= 2 => Self::Decimated,
            _ => Self::Direct,
        }
    }

    /// The method used at this σ on a `w x h` image: [`BlurMethod::resolve`], except that
    /// [`BlurMethod::Box3`] gives way to the exact decimated method once its boxes are wider
    /// than the image (their padding would cost more than the blur).
    pub fn resolve_sized(self, sigma: impl Into<Sigma2>, w: u32, h: u32) -> Self {
        let sigma = sigma.into();
        match self.resolve(sigma) {
            Self::Box3 if ExtBox::new(sigma.max() as f64).reach() > w.max(h) as usize + 64 => {
                Self::Decimated.resolve(sigma)
            }
            m => m,
        }
    }
}

fn check_sigma(sigma: f32) -> Result<f64, TextureError> {
    if !(sigma.is_finite() && (0.0..=MAX_SIGMA).contains(&sigma)) {
        return Err(TextureError::InvalidSigma { sigma });
    }
    Ok(sigma as f64)
}

pub(crate) fn check_sigma2(sigma: Sigma2) -> Result<Sig, TextureError> {
    Ok(Sig {
        x: check_sigma(sigma.x)?,
        y: check_sigma(sigma.y)?,
    })
}

/// Radius of the truncated kernel for σ, in texels.
pub fn kernel_radius(sigma: f64) -> usize {
    radius_at(sigma, KERNEL_RADIUS_SIGMAS)
}

fn radius_at(sigma: f64, radius_sigmas: f64) -> usize {
    if sigma < DELTA_SIGMA {
        0
    } else {
        (radius_sigmas * sigma).ceil() as usize
    }
}

/// The normalized truncated kernel, but only its taps at offsets up to `max_offset` (an image
/// `n` texels long never needs more than `n - 1`): returns the taps at offsets
/// `-r..=r`, `r = min(radius, max_offset)`, normalized over the whole radius.
pub fn gaussian_kernel(sigma: f64, max_offset: usize) -> Vec<f64> {
    kernel_at(sigma, KERNEL_RADIUS_SIGMAS, max_offset)
}

fn kernel_at(sigma: f64, radius_sigmas: f64, max_offset: usize) -> Vec<f64> {
    let radius = radius_at(sigma, radius_sigmas);
    if radius == 0 {
        return vec![1.0];
    }
    let g = |d: usize| (-((d * d) as f64) / (2.0 * sigma * sigma)).exp();
    // Sum smallest first, so the normalization is as exact as f64 allows.
    let mut sum = 0.0;
    for d in (1..=radius).rev() {
        sum += 2.0 * g(d);
    }
    sum += 1.0;
    let r = radius.min(max_offset);
    (0..=2 * r).map(|i| g(i.abs_diff(r)) / sum).collect()
}

/// Exact reference: separable convolution in f64 with the truncated, renormalized kernel and a
/// zero border. Premultiplied linear RGBA in and out, row-major `w x h`.
pub fn reference_blur(src: &[[f64; 4]], w: usize, h: usize, sigma: f64) -> Vec<[f64; 4]> {
    reference_blur_xy(src, w, h, sigma, sigma)
}

/// [`reference_blur`] with σ `sx` along x and `sy` along y.
pub fn reference_blur_xy(src: &[[f64; 4]], w: usize, h: usize, sx: f64, sy: f64) -> Vec<[f64; 4]> {
    let kx = gaussian_kernel(sx, w.saturating_sub(1));
    let ky = gaussian_kernel(sy, h.saturating_sub(1));
    let (rx, ry) = (kx.len() / 2, ky.len() / 2);
    let mut mid = vec![[0.0; 4]; w * h];
    mid.par_chunks_mut(w)
        .zip(src.par_chunks(w))
        .for_each(|(out, row)| {
            for (n, o) in out.iter_mut().enumerate() {
                let lo = n.saturating_sub(rx);
                let hi = (n + rx).min(w - 1);
                for (j, v) in row.iter().enumerate().take(hi + 1).skip(lo) {
                    let k = kx[j + rx - n];
                    for c in 0..4 {
                        o[c] += k * v[c];
                    }
                }
            }
        });
    let mut out = vec![[0.0; 4]; w * h];
    out.par_chunks_mut(w).enumerate().for_each(|(y, orow)| {
        let lo = y.saturating_sub(ry);
        let hi = (y + ry).min(h - 1);
        for sy in lo..=hi {
            let k = ky[sy + ry - y];
            for (o, v) in orow.iter_mut().zip(&mid[sy * w..(sy + 1) * w]) {
                for c in 0..4 {
                    o[c] += k * v[c];
                }
            }
        }
    });
    out
}

type Px = [f32; 4];

/// Output floats kept in registers while the terms stream past (eight 256-bit registers).
const CHUNK: usize = 64;

#[inline(always)]
fn wsum_plain(out: &mut [f32], terms: &[(f32, &[f32])]) {
    let n = out.len();
    let mut i = 0;
    while i + CHUNK <= n {
        let mut acc = [0.0f32; CHUNK];
        for &(w, s) in terms {
            let s = &s[i..i + CHUNK];
            for j in 0..CHUNK {
                acc[j] += w * s[j];
            }
        }
        out[i..i + CHUNK].copy_from_slice(&acc);
        i += CHUNK;
    }
    for (j, o) in out.iter_mut().enumerate().skip(i) {
        let mut acc = 0.0f32;
        for &(w, s) in terms {
            acc += w * s[j];
        }
        *o = acc;
    }
}

/// The same loop compiled for 256-bit vectors. Rust never fuses `w * s + acc` into an FMA, so
/// this gives the same bits as the plain loop: results do not depend on the CPU.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
unsafe fn wsum_avx(out: &mut [f32], terms: &[(f32, &[f32])]) {
    wsum_plain(out, terms)
}

/// `out = Σ w · src` over texels, summed in the order of `terms` (so one output's value never
/// depends on how the work is split). Every pass of the blur is one of these: long, contiguous,
/// independent multiply-adds with the partial sums held in registers.
fn wsum(out: &mut [Px], terms: &[(f32, &[Px])]) {
    let n = out.len();
    let flat: Vec<(f32, &[f32])> = terms
        .iter()
        .map(|&(w, s)| (w, &s.as_flattened()[..n * 4]))
        .collect();
    let out = out.as_flattened_mut();
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx") {
        // SAFETY: the CPU supports AVX, checked just above.
        unsafe { wsum_avx(out, &flat) };
        return;
    }
    wsum_plain(out, &flat)
}

/// A row filter with decimation: `out[m] = Σ_t taps[t] · x[m·k + t - pad]`, with `x` zero
/// outside the row. Computed polyphase: the padded row is split into its k phases
/// `X_s[i] = x[k·i + s - pad]`, so each tap is a contiguous slice in one weighted sum.
struct RowFir {
    k: usize,
    pad: usize,
    taps: Vec<f32>,
}

impl RowFir {
    fn phase_len(&self, out_len: usize) -> usize {
        out_len + (self.taps.len() - 1) / self.k + 1
    }

    fn scratch(&self, out_len: usize) -> Vec<Vec<Px>> {
        vec![vec![[0.0; 4]; self.phase_len(out_len)]; self.k]
    }

    fn apply(&self, row: &[Px], phases: &mut [Vec<Px>], out: &mut [Px]) {
        // A kernel far wider than the row (σ beyond the image's size) meets the row with a
        // few of its taps per output: summing every tap over every output was σ-bound, hours
        // for σ = 9e4 texels on a 1024² design.
        if self.taps.len() > 4 * (row.len() + out.len()) {
            self.apply_per_output(row, out);
        } else {
            self.apply_per_tap(row, phases, out);
        }
    }

    /// Every tap over every output, tap after tap: long contiguous multiply-adds ([`wsum`]),
    /// each phase of the row laid out once.
    fn apply_per_tap(&self, row: &[Px], phases: &mut [Vec<Px>], out: &mut [Px]) {
        let n = out.len();
        for (s, xs) in phases.iter_mut().enumerate() {
            for (i, v) in xs.iter_mut().enumerate() {
                let j = (self.k * i + s) as i64 - self.pad as i64;
                *v = if j >= 0 && (j as usize) < row.len() {
                    row[j as usize]
                } else {
                    [0.0; 4]
                };
            }
        }
        let terms: Vec<(f32, &[Px])> = self
            .taps
            .iter()
            .enumerate()
            .map(|(t, &w)| (w, &phases[t % self.k][t / self.k..t / self.k + n]))
            .collect();
        wsum(out, &terms);
    }

    /// [`RowFir::apply`] one output at a time over the taps that meet the row, in tap order:
    /// the taps left out meet zeros and add +0, so the bits are [`wsum`]'s.
    fn apply_per_output(&self, row: &[Px], out: &mut [Px]) {
        for (i, o) in out.iter_mut().enumerate() {
            // Output i reads row[t + k·i − pad] for tap t.
            let shift = (self.k * i) as i64 - self.pad as i64;
            let lo = (-shift).clamp(0, self.taps.len() as i64) as usize;
            let hi = (row.len() as i64 - shift).clamp(0, self.taps.len() as i64) as usize;
            let mut acc = [0.0f32; 4];
            for t in lo..hi {
                let (w, x) = (self.taps[t], row[(t as i64 + shift) as usize]);
                for c in 0..4 {
                    acc[c] += w * x[c];
                }
            }
            *o = acc;
        }
    }
}

/// Where the blur's input rows come from and its output rows go; lets the u8 path decode and
/// encode inside the passes instead of in extra full-image sweeps.
trait Io: Sync {
    type Out: Send + Copy + Default;
    /// Output elements per texel.
    const PER_TEXEL: usize;
    /// Image height.
    fn height(&self) -> usize;
    /// Texels `x0..x0 + row.len()` of row `y`.
    fn fill(&self, y: usize, x0: usize, row: &mut [Px]);
    /// Texels `x0..x0 + out.len()` of rows `y0..y0 + 4` in columns: `out[i]` holds column
    /// `x0 + i` of the four rows, top first; rows outside the image are zero.
    fn fill_columns(&self, y0: isize, x0: usize, out: &mut [[f32; QUAD]], row: &mut Vec<Px>) {
        row.resize(out.len(), [0.0; 4]);
        for l in 0..4 {
            let y = y0 + l as isize;
            if (0..self.height() as isize).contains(&y) {
                self.fill(y as usize, x0, row);
            } else {
                row.fill([0.0; 4]);
            }
            for (o, t) in out.iter_mut().zip(row.iter()) {
                o[4 * l..4 * l + 4].copy_from_slice(t);
            }
        }
    }
    fn emit(&self, row: &[Px], out: &mut [Self::Out]);
}

struct F32Io<'a> {
    src: &'a [Px],
    w: usize,
}

impl Io for F32Io<'_> {
    type Out = Px;
    const PER_TEXEL: usize = 1;
    fn height(&self) -> usize {
        self.src.len() / self.w
    }
    fn fill(&self, y: usize, x0: usize, row: &mut [Px]) {
        let at = y * self.w + x0;
        row.copy_from_slice(&self.src[at..at + row.len()]);
    }
    fn emit(&self, row: &[Px], out: &mut [Px]) {
        out.copy_from_slice(row);
    }
}

struct Srgb8Io<'a> {
    src: &'a [u8],
    w: usize,
}

impl Io for Srgb8Io<'_> {
    type Out = u8;
    const PER_TEXEL: usize = 4;
    fn height(&self) -> usize {
        self.src.len() / (4 * self.w)
    }
    fn fill_columns(&self, y0: isize, x0: usize, out: &mut [[f32; QUAD]], row: &mut Vec<Px>) {
        let (w, h) = (self.w, self.height());
        let n = out.len();
        let rows: [Option<&[u8]>; 4] = std::array::from_fn(|l| {
            let y = y0 + l as isize;
            (0..h as isize)
                .contains(&y)
                .then(|| &self.src[(y as usize * w + x0) * 4..][..n * 4])
        });
        decode_premultiplied_columns(rows, out, row);
        // Strips read a short span of each row, too short for the hardware to see the stream:
        // fetch the next four rows' span while these are filtered.
        #[cfg(target_arch = "x86_64")]
        for l in 4..8 {
            let y = y0 + l as isize;
            if (0..h as isize).contains(&y) {
                let span = &self.src[(y as usize * w + x0) * 4..][..n * 4];
                for line in span.chunks(64) {
                    use std::arch::x86_64::{_MM_HINT_T0, _mm_prefetch};
                    // SAFETY: SSE is part of x86-64; a prefetch never faults.
                    unsafe { _mm_prefetch::<_MM_HINT_T0>(line.as_ptr().cast()) };
                }
            }
        }
    }
    fn fill(&self, y: usize, x0: usize, row: &mut [Px]) {
        let at = (y * self.w + x0) * 4;
        decode_premultiplied(&self.src[at..at + row.len() * 4], row);
    }
    fn emit(&self, row: &[Px], out: &mut [u8]) {
        encoder().encode_rgba(row, out);
    }
}

/// sRGB RGBA8 with straight alpha, decoded as [`crate::pixels::to_linear`] decodes it and then
/// premultiplied ([`crate::pixels::texel8`] times its alpha), the same bits as that
/// full-size f32 copy, which this reads without (a 4096² design's copy is 256 MiB). Not
/// [`Srgb8Io`]'s vector decode: it multiplies by 1/255, a different last bit for half the codes.
///
/// The image (`w` texels a row) sits in a frame of `m` transparent texels on each side, which
/// reads as zero: the bits of a framed copy, without the copy.
struct Straight8Io<'a> {
    src: &'a [u8],
    w: usize,
    mx: usize,
    my: usize,
}

impl<'a> Straight8Io<'a> {
    /// The reader of `src` (`w x h`) in a frame of `margin` texels on each side (`[x, y]`), with
    /// σ and the sizes checked (`what` names the caller in an error): the reader, σ, and the
    /// framed size.
    fn framed(
        src: &'a [u8],
        w: u32,
        h: u32,
        margin: [u32; 2],
        sigma: impl Into<Sigma2>,
        what: &'static str,
    ) -> Result<(Self, Sig, usize, usize), TextureError> {
        let (s, dw, _) = checked(sigma.into(), w, h, src.len(), 4, what)?;
        let io = Straight8Io {
            src,
            w: dw,
            mx: margin[0] as usize,
            my: margin[1] as usize,
        };
        let (fw, fh) = (dw + 2 * io.mx, io.height());
        Ok((io, s, fw, fh))
    }
}

impl Io for Straight8Io<'_> {
    type Out = Px;
    const PER_TEXEL: usize = 1;
    fn height(&self) -> usize {
        self.src.len() / (4 * self.w) + 2 * self.my
    }
    fn fill(&self, y: usize, x0: usize, row: &mut [Px]) {
        let (w, mx, my) = (self.w, self.mx, self.my);
        // The image's columns within the row, in frame coordinates.
        let (lo, hi) = (x0.max(mx), (x0 + row.len()).min(mx + w));
        let inside = y >= my && y < self.height() - my && lo < hi;
        if mx > 0 || !inside {
            row.fill([0.0; 4]);
        }
        if !inside {
            return;
        }
        let at = ((y - my) * w + lo - mx) * 4;
        let bytes = &self.src[at..at + (hi - lo) * 4];
        for (t, px) in row[lo - x0..hi - x0].iter_mut().zip(bytes.chunks_exact(4)) {
            let [r, g, b, a] = crate::pixels::texel8([px[0], px[1], px[2], px[3]]);
            *t = [r * a, g * a, b * a, a];
        }
    }
    fn emit(&self, row: &[Px], out: &mut [Px]) {
        out.copy_from_slice(row);
    }
}

fn to_f32(k: &[f64]) -> Vec<f32> {
    k.iter().map(|&v| v as f32).collect()
}

/// Texels per strip of the direct blur: its ring of filtered rows (4 KiB per row) stays in the
/// L2 cache up to σ ≈ 8, and the input columns both neighbours' windows read again are
/// 2·radius per strip.
const DIRECT_STRIP: usize = 256;

/// Output rows the vertical pass computes together (and the unit bands are cut in).
const GROUP: usize = 8;

/// 64-byte aligned quads, so the passes' loads never straddle cache lines.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Line([f32; QUAD]);

fn floats(v: &[Line]) -> &[f32] {
    // SAFETY: `Line` is 16 floats with no padding (size 64 = alignment).
    unsafe { std::slice::from_raw_parts(v.as_ptr().cast(), v.len() * QUAD) }
}

fn floats_mut(v: &mut [Line]) -> &mut [f32] {
    // SAFETY: as in `floats`.
    unsafe { std::slice::from_raw_parts_mut(v.as_mut_ptr().cast(), v.len() * QUAD) }
}

/// Horizontal pass on columns: `out[j]` is the filter centred on `cols[j + r]`, for `out.len()`
/// (a multiple of [`GROUP`]) columns; `cols` holds `out.len() + 2r` columns.
#[inline(always)]
unsafe fn hpass<Q: Quad, const B: usize>(cols: &[[f32; QUAD]], k: &[f32], out: &mut [Line]) {
    let r = k.len() - 1;
    assert!(cols.len() >= out.len() + 2 * r && out.len().is_multiple_of(B));
    for j in (0..out.len()).step_by(B) {
        let centre = cols[j + r..].as_ptr().cast::<f32>();
        // SAFETY: quads j..j + B - 1 + 2r of `cols` exist, checked above.
        let res = unsafe { symmetric::<Q, B>(|m| centre.wrapping_offset(m * QUAD as isize), k) };
        for (b, v) in res.into_iter().enumerate() {
            // SAFETY: quad j + b of `out` exists.
            unsafe { v.store(out[j + b].0.as_mut_ptr()) };
        }
    }
}

/// The horizontal pass's columns (four rows each) back into the four rows, which start at
/// `rows[l]` in `ring`.
#[inline(always)]
unsafe fn to_rows<Q: Quad>(cols: &[Line], ring: &mut [f32], rows: [usize; 4]) {
    let n = cols.len();
    assert!(n.is_multiple_of(4) && rows.iter().all(|&r| r + n * 4 <= ring.len()));
    for j in (0..n).step_by(4) {
        // SAFETY: quads j..j + 4 of `cols` exist.
        let q = std::array::from_fn(|i| unsafe { Q::load(cols[j + i].0.as_ptr()) });
        for (&row, v) in rows.iter().zip(Q::transpose(q)) {
            // SAFETY: floats row + 4j..row + 4j + 16 are in `ring`, checked above.
            unsafe { v.store(ring.as_mut_ptr().add(row + 4 * j)) };
        }
    }
}

/// Vertical pass: row `b` of `tile` (`GROUP` rows of `stride` floats) is the filter centred on
/// `rows[b + r]`; every row pointer reaches `stride` floats.
#[inline(always)]
unsafe fn vpass<Q: Quad, const B: usize>(
    rows: &[*const f32],
    k: &[f32],
    tile: &mut [f32],
    stride: usize,
) {
    let r = k.len() - 1;
    assert!(rows.len() == 2 * r + GROUP && tile.len() >= GROUP * stride);
    for b0 in (0..GROUP).step_by(B) {
        let window = &rows[b0..];
        for c in (0..stride).step_by(QUAD) {
            // SAFETY: every row pointer reaches `stride` floats (the caller's promise).
            let res = unsafe {
                symmetric::<Q, B>(|m| window[(m + r as isize) as usize].wrapping_add(c), k)
            };
            for (b, v) in res.into_iter().enumerate() {
                // SAFETY: row b0 + b of `tile` holds `stride` floats, checked above.
                unsafe { v.store(tile.as_mut_ptr().add((b0 + b) * stride + c)) };
            }
        }
    }
}

/// The instruction set the direct blur's loops run on. All give the same bits.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Isa {
    Plain,
    #[cfg(target_arch = "x86_64")]
    Avx2,
    #[cfg(target_arch = "x86_64")]
    Avx512,
}

#[cfg(target_arch = "x86_64")]
mod isa_x86 {
    use super::*;
    use crate::fir::x86::{Avx2, Avx512};

    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn hpass_avx512(cols: &[[f32; QUAD]], k: &[f32], out: &mut [Line]) {
        unsafe { hpass::<Avx512, 8>(cols, k, out) }
    }
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn to_rows_avx512(cols: &[Line], ring: &mut [f32], rows: [usize; 4]) {
        unsafe { to_rows::<Avx512>(cols, ring, rows) }
    }
    #[target_feature(enable = "avx512f")]
    pub(super) unsafe fn vpass_avx512(rows: &[*const f32], k: &[f32], t: &mut [f32], s: usize) {
        unsafe { vpass::<Avx512, 8>(rows, k, t, s) }
    }
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn hpass_avx2(cols: &[[f32; QUAD]], k: &[f32], out: &mut [Line]) {
        unsafe { hpass::<Avx2, 2>(cols, k, out) }
    }
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn to_rows_avx2(cols: &[Line], ring: &mut [f32], rows: [usize; 4]) {
        unsafe { to_rows::<Avx2>(cols, ring, rows) }
    }
    #[target_feature(enable = "avx2,fma")]
    pub(super) unsafe fn vpass_avx2(rows: &[*const f32], k: &[f32], t: &mut [f32], s: usize) {
        unsafe { vpass::<Avx2, 2>(rows, k, t, s) }
    }
}

impl Isa {
    fn detect() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx512f") {
                return Isa::Avx512;
            }
            if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
                return Isa::Avx2;
            }
        }
        Isa::Plain
    }

    fn hpass(self, cols: &[[f32; QUAD]], k: &[f32], out: &mut [Line]) {
        // SAFETY: `detect` saw each instruction set on this CPU; the loops check their bounds.
        unsafe {
            match self {
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512 => isa_x86::hpass_avx512(cols, k, out),
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2 => isa_x86::hpass_avx2(cols, k, out),
                Isa::Plain => hpass::<[f32; QUAD], 2>(cols, k, out),
            }
        }
    }

    fn to_rows(self, cols: &[Line], ring: &mut [f32], rows: [usize; 4]) {
        // SAFETY: as in `hpass`.
        unsafe {
            match self {
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512 => isa_x86::to_rows_avx512(cols, ring, rows),
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2 => isa_x86::to_rows_avx2(cols, ring, rows),
                Isa::Plain => to_rows::<[f32; QUAD]>(cols, ring, rows),
            }
        }
    }

    /// # Safety
    /// Every row pointer reaches `stride` readable floats.
    unsafe fn vpass(self, rows: &[*const f32], k: &[f32], tile: &mut [f32], stride: usize) {
        // SAFETY: as in `hpass`; the row pointers are the caller's promise.
        unsafe {
            match self {
                #[cfg(target_arch = "x86_64")]
                Isa::Avx512 => isa_x86::vpass_avx512(rows, k, tile, stride),
                #[cfg(target_arch = "x86_64")]
                Isa::Avx2 => isa_x86::vpass_avx2(rows, k, tile, stride),
                Isa::Plain => vpass::<[f32; QUAD], 2>(rows, k, tile, stride),
            }
        }
    }
}

/// One task of the direct blur: its strip, first row, and output slices (one per row).
type Task<'a, T> = (usize, usize, Vec<&'a mut [T]>);

fn direct<I: Io>(io: &I, w: usize, h: usize, sigma: Sig, out: &mut [I::Out]) {
    direct_with(Isa::detect(), io, w, h, sigma, 0..h, out)
}

/// The centre and one side of a symmetric kernel.
fn half_kernel(k: &[f64]) -> Vec<f32> {
    to_f32(&k[k.len() / 2..])
}

/// Separable FIR, horizontal pass first, each output the fused pair sum of [`crate::fir`], so
/// every output has one value whatever the tiling, threads or instruction set.
///
/// Tiled so the intermediate never leaves the cache: the image is cut into strips of
/// [`DIRECT_STRIP`] columns (and, when there are too few strips for the threads, bands of rows).
/// A task walks down its strip four input rows at a time: decodes them into columns, filters
/// along the row (on columns, so every load is a whole aligned vector), turns the result back
/// into rows in a ring, and as soon as [`GROUP`] output rows have all their input rows in the
/// ring, filters down the columns and encodes straight into the output.
///
/// `out` holds output rows `rows` only: a band of the image, the same bits as those rows of
/// the whole (every band already starts its ring `ry` rows above its first row).
fn direct_with<I: Io>(
    isa: Isa,
    io: &I,
    w: usize,
    h: usize,
    sigma: Sig,
    rows: std::ops::Range<usize>,
    out: &mut [I::Out],
) {
    let kx = half_kernel(&gaussian_kernel(sigma.x, w - 1));
    let ky = half_kernel(&gaussian_kernel(sigma.y, h - 1));
    let (rx, ry) = (kx.len() - 1, ky.len() - 1);
    let strip = DIRECT_STRIP.min(w.next_multiple_of(GROUP));
    let strips = w.div_ceil(strip);
    // Bands only when strips alone cannot keep the threads busy; each band re-filters the 2·ry
    // rows above it, so bands stay many times taller than that.
    let threads = rayon::current_num_threads();
    let n_rows = rows.len();
    let max_bands = (n_rows / (8 * (2 * ry + 1)).max(GROUP)).max(1);
    let bands = (2 * threads).div_ceil(strips).clamp(1, max_bands);
    let band_rows = n_rows.div_ceil(bands).next_multiple_of(GROUP);
    let per = I::PER_TEXEL;
    assert!(rows.end <= h && out.len() == n_rows * w * per);

    // Every task's output: one slice per row of its band, the strip's columns.
    let mut tasks: Vec<Task<I::Out>> = (0..bands)
        .flat_map(|b| (0..strips).map(move |s| (s, rows.start + b * band_rows, Vec::new())))
        .filter(|&(_, y0, _)| y0 < rows.end)
        .collect();
    for (y, row) in out.chunks_mut(w * per).enumerate() {
        let band = y / band_rows;
        for (s, part) in row.chunks_mut(strip * per).enumerate() {
            tasks[band * strips + s].2.push(part);
        }
    }

    // Texels per row of the passes: the strip rounded up to whole groups of quads.
    let width = strip.next_multiple_of(GROUP);
    let stride = width * 4;
    let cap = 2 * ry + GROUP + 4;
    let zero = vec![Line([0.0; QUAD]); width / 4];
    struct Scratch {
        cols: Vec<[f32; QUAD]>,
        filtered: Vec<Line>,
        ring: Vec<Line>,
        tile: Vec<Line>,
        row: Vec<Px>,
        inputs: Vec<*const f32>,
    }
    tasks.into_par_iter().for_each_init(
        || Scratch {
            cols: vec![[0.0; QUAD]; width + 2 * rx],
            filtered: vec![Line([0.0; QUAD]); width],
            ring: vec![Line([0.0; QUAD]); cap * width / 4],
            tile: vec![Line([0.0; QUAD]); GROUP * width / 4],
            row: Vec::new(),
            inputs: Vec::with_capacity(2 * ry + GROUP),
        },
        |sc, (s, y0, mut rows)| {
            let zero = floats(&zero).as_ptr();
            let x0 = s * strip;
            let n = strip.min(w - x0);
            // Columns x0 - rx .. inside the image, and where they sit in `cols`.
            let (cx0, cx1) = (x0.saturating_sub(rx), (x0 + n + rx).min(w));
            let at = cx0 + rx - x0;
            sc.cols.fill([0.0; QUAD]);
            let y1 = y0 + rows.len();
            // The first row of the next four to filter into the ring.
            let mut next = y0 as isize - ry as isize;
            for ys in (y0..y1).step_by(GROUP) {
                let last = (ys + GROUP - 1 + ry) as isize;
                while next <= last {
                    if next + 3 >= 0 && next < h as isize {
                        io.fill_columns(next, cx0, &mut sc.cols[at..at + cx1 - cx0], &mut sc.row);
                        isa.hpass(&sc.cols, &kx, &mut sc.filtered);
                        let slot = |l: isize| (next + l).rem_euclid(cap as isize) as usize * stride;
                        let rows = [0, 1, 2, 3].map(slot);
                        isa.to_rows(&sc.filtered, floats_mut(&mut sc.ring), rows);
                    }
                    next += 4;
                }
                let ring = floats(&sc.ring).as_ptr();
                sc.inputs.clear();
                sc.inputs.extend((0..2 * ry + GROUP).map(|m| {
                    let y = ys as isize - ry as isize + m as isize;
                    if (0..h as isize).contains(&y) {
                        ring.wrapping_add(y.rem_euclid(cap as isize) as usize * stride)
                    } else {
                        zero
                    }
                }));
                // SAFETY: every input points at a whole ring row or the zero row, `stride`
                // floats each.
                unsafe { isa.vpass(&sc.inputs, &ky, floats_mut(&mut sc.tile), stride) };
                let tile = floats(&sc.tile);
                for (q, o) in rows[ys - y0..(ys + GROUP).min(y1) - y0]
                    .iter_mut()
                    .enumerate()
                {
                    let t = &tile[q * stride..q * stride + n * 4];
                    io.emit(t.as_chunks::<4>().0, o);
                }
            }
        },
    );
}

/// One axis of the decimated method.
struct Axis {
    n: usize,
    k: usize,
    /// Radius of the second stage, also the offset of coarse sample 0 (at position `-rt`).
    rt: usize,
    /// Coarse samples: positions `m·k - rt` for `m` in `0..count`.
    count: usize,
    /// Per fine-texel phase `r = n mod k`: the first coarse sample past `n / k`, and the
    /// interpolation weights from there on.
    phases: Vec<(usize, Vec<f32>)>,
}

impl Axis {
    fn new(n: usize, k: usize, tau: f64, radius_sigmas: f64) -> Axis {
        let rt = radius_at(tau, radius_sigmas);
        let count = (n - 1 + 2 * rt).div_ceil(k) + 1;
        let phases = (0..k)
            .map(|r| {
                let off = usize::from(r > 0);
                let d0 = (rt + r) as i64 - (k * off) as i64;
                let mut ws: Vec<f64> = Vec::new();
                let mut d = d0;
                while d >= -(rt as i64) {
                    ws.push((-((d * d) as f64) / (2.0 * tau * tau)).exp());
                    d -= k as i64;
                }
                // Normalizing each phase keeps constants exactly constant; the sum is already
                // 1 to ~1e-15 by Poisson summation.
                let s: f64 = ws.iter().rev().sum();
                (off, ws.iter().map(|&v| (v / s) as f32).collect())
            })
            .collect();
        Axis {
            n,
            k,
            rt,
            count,
            phases,
        }
    }

    /// First coarse sample and weights that interpolate fine texel `i`.
    fn interp(&self, i: usize) -> (usize, &[f32]) {
        let (off, ws) = &self.phases[i % self.k];
        (i / self.k + off, ws)
    }

    /// Stage 1 along this axis: the coarse samples as a decimating row filter.
    fn stage1(&self, g1: &[f32]) -> RowFir {
        RowFir {
            k: self.k,
            pad: self.rt + g1.len() / 2,
            taps: g1.to_vec(),
        }
    }

    /// Stage 2 along a row: fine texels from coarse samples `c`, one phase at a time so each
    /// weight applies to a contiguous slice; `tmp` holds one phase's outputs.
    fn interp_row(&self, c: &[Px], tmp: &mut [Px], out: &mut [Px]) {
        for r in 0..self.k.min(self.n) {
            let (m0, ws) = self.interp(r);
            let len = (self.n - r).div_ceil(self.k);
            let tmp = &mut tmp[..len];
            let terms: Vec<(f32, &[Px])> = ws
                .iter()
                .enumerate()
                .map(|(t, &w)| (w, &c[m0 + t..m0 + t + len]))
                .collect();
            wsum(tmp, &terms);
            for (q, v) in tmp.iter().enumerate() {
                out[q * self.k + r] = *v;
            }
        }
    }
}

fn decimated<I: Io>(io: &I, w: usize, h: usize, sigma: Sig, dec: Decimation, out: &mut [I::Out]) {
    let grid = Grid::new(io, w, h, sigma, dec);
    grid.rows(io, 0..h, out);
}

/// The decimated method's coarse grid (its first stage), from which [`Grid::rows`] interpolates
/// any fine rows: `1/k²` of the image, so a caller can hold it and take the blur a band at a
/// time.
struct Grid {
    w: usize,
    ax: Axis,
    ay: Axis,
    b: Vec<Px>,
}

impl Grid {
    fn new<I: Io>(io: &I, w: usize, h: usize, sigma: Sig, dec: Decimation) -> Grid {
        // Each axis its own grid step and first-stage kernel, from its own σ.
        let stage1 = |sigma: f64| {
            let k = dec.k(sigma);
            let tau = sigma / std::f64::consts::SQRT_2;
            let mut g1 = kernel_at(tau, dec.radius_sigmas, usize::MAX);
            if dec.balance {
                for residue in 0..k {
                    let class = || g1.iter().skip(residue).step_by(k);
                    let sum: f64 = class().sum();
                    if sum > 0.0 {
                        let scale = 1.0 / (k as f64 * sum);
                        g1.iter_mut()
                            .skip(residue)
                            .step_by(k)
                            .for_each(|g| *g *= scale);
                    }
                }
            }
            (k, tau, to_f32(&g1))
        };
        let (kx, taux, g1x) = stage1(sigma.x);
        let (ky, tauy, g1y) = stage1(sigma.y);
        let r1 = g1y.len() / 2;
        let ax = Axis::new(w, kx, taux, dec.radius_sigmas);
        let ay = Axis::new(h, ky, tauy, dec.radius_sigmas);
        let (mx, my) = (ax.count, ay.count);
        let fir = ax.stage1(&g1x);

        // Stage 1 along x, then along y at the coarse rows, streamed: each task takes a band of
        // coarse rows and computes the fine rows its kernel windows reach, once each, into a ring
        // of 2·r1 + 1 rows (at most the image's height: a window holds no more). A full-height
        // intermediate (mx × h texels, 64 MiB at 4096² and σ = 8) cost more in page faults than
        // the blur itself; bands recompute only the few rows their windows share. Every coarse
        // row sums the same terms in the same order as before, so the result does not depend on
        // the banding or the thread count.
        let mut b = vec![[0.0f32; 4]; mx * my];
        let taps = g1y.len();
        let ring_rows = taps.min(h);
        let bands = (rayon::current_num_threads() * 2).clamp(1, my.max(1));
        let band_rows = my.div_ceil(bands).max(1);
        let first_row = |m: usize| (m * ky) as i64 - ay.rt as i64 - r1 as i64;
        b.par_chunks_mut(mx * band_rows).enumerate().for_each_init(
            || {
                (
                    vec![[0.0f32; 4]; w],
                    fir.scratch(mx),
                    vec![[0.0f32; 4]; mx * ring_rows],
                )
            },
            |(row, phases, ring), (band, out_rows)| {
                let m0 = band * band_rows;
                // The next fine row to compute into the ring.
                let mut next = first_row(m0).max(0) as usize;
                for (i, o) in out_rows.chunks_mut(mx).enumerate() {
                    let lo = first_row(m0 + i);
                    let hi = (lo + taps as i64).min(h as i64);
                    // Rows between windows (a step k wider than the kernel) are never needed.
                    next = next.max(lo.max(0) as usize);
                    while (next as i64) < hi {
                        let slot = next % ring_rows;
                        io.fill(next, 0, row);
                        fir.apply(row, phases, &mut ring[slot * mx..(slot + 1) * mx]);
                        next += 1;
                    }
                    let terms: Vec<(f32, &[Px])> = g1y
                        .iter()
                        .enumerate()
                        .filter_map(|(t, &g)| {
                            let y = usize::try_from(lo + t as i64).ok().filter(|&y| y < h)?;
                            let slot = y % ring_rows;
                            Some((g, &ring[slot * mx..(slot + 1) * mx]))
                        })
                        .collect();
                    wsum(o, &terms);
                }
            },
        );
        Grid { w, ax, ay, b }
    }

    /// Stage 2 for fine rows `rows` into `out` (those rows only): interpolate y back to fine rows,
    /// then x to fine columns. Each row on its own, so a band has the whole image's bits.
    fn rows<I: Io>(&self, io: &I, rows: std::ops::Range<usize>, out: &mut [I::Out]) {
        let Grid { w, ax, ay, b } = self;
        let (w, k, mx) = (*w, ax.k, ax.count);
        assert_eq!(out.len(), rows.len() * w * I::PER_TEXEL);
        out.par_chunks_mut(w * I::PER_TEXEL)
            .zip(rows)
            .for_each_init(
                || {
                    (
                        vec![[0.0f32; 4]; mx],
                        vec![[0.0f32; 4]; w],
                        vec![[0.0f32; 4]; w.div_ceil(k)],
                    )
                },
                |(c, row, tmp), (o, y)| {
                    let (m0, ws) = ay.interp(y);
                    let terms: Vec<(f32, &[Px])> = ws
                        .iter()
                        .enumerate()
                        .map(|(i, &t)| (t, &b[(m0 + i) * mx..(m0 + i + 1) * mx]))
                        .collect();
                    wsum(c, &terms);
                    ax.interp_row(c, tmp, row);
                    io.emit(row, o);
                },
            );
    }
}

/// One extended box: weight 1 on `-r..=r` and `alpha` at ±(r+1), scaled by `norm` to sum to
/// one, with variance exactly `var` (Gwosdek et al. 2011, eq. 11–13).
#[derive(Clone, Copy, Debug)]
struct ExtBox {
    r: usize,
    alpha: f64,
    norm: f64,
}

/// Below this σ the box runs direct (exact): a 3-pass box with fractional ends has tails far
/// heavier than a Gaussian that narrow (13 LSB at σ = 0.7), and direct costs at most 21 taps.
const BOX_MIN_SIGMA: f64 = 2.0;

/// Passes per axis: three already bring the shape within a few LSB of the Gaussian; more passes
/// would cost more than the decimated method.
const BOX_PASSES: usize = 3;

/// Columns per vertical strip: 16 texels of four f64 running sums fit the vector registers.
const STRIP: usize = 16;

impl ExtBox {
    /// The box of one pass for a Gaussian of σ.
    fn new(sigma: f64) -> Self {
        let var = sigma * sigma / BOX_PASSES as f64;
        // The widest integer box whose variance r(r+1)/3 does not exceed `var`.
        let mut r = (((12.0 * var + 1.0).sqrt() - 1.0) / 2.0).floor().max(0.0) as usize;
        // sqrt may round either way at the boundaries; settle r exactly.
        let v = |r: usize| (r * (r + 1)) as f64 / 3.0;
        while r > 0 && v(r) > var {
            r -= 1;
        }
        while v(r + 1) <= var {
            r += 1;
        }
        let rf = r as f64;
        let alpha =
            ((2.0 * rf + 1.0) * (var - v(r)) / (2.0 * ((rf + 1.0).powi(2) - var))).clamp(0.0, 1.0);
        ExtBox {
            r,
            alpha,
            norm: 1.0 / (2.0 * rf + 1.0 + 2.0 * alpha),
        }
    }

    /// Half-width of the box's support, the α taps included, plus one: the running sum also
    /// reads the texel that leaves the window.
    fn reach(&self) -> usize {
        self.r + 1
    }

    /// One pass along a padded line of `S`-texel groups (one texel for a row, a strip of columns
    /// for the vertical passes): `dst[i]` for `i` in `lo..hi`. Needs `lo > r` and
    /// `hi + r < src.len()`, which the padding of [`box3`] guarantees.
    fn pass<const S: usize>(&self, src: &[[Px; S]], dst: &mut [[Px; S]], lo: usize, hi: usize) {
        let r = self.r;
        debug_assert!(lo > r && hi + r < src.len() && hi <= dst.len());
        let mut acc = [[0.0f64; 4]; S];
        for t in &src[lo - r..=lo + r] {
            for s in 0..S {
                for c in 0..4 {
                    acc[s][c] += t[s][c] as f64;
                }
            }
        }
        let (a, n) = (self.alpha, self.norm);
        for i in lo..hi {
            let (before, after) = (&src[i - r - 1], &src[i + r + 1]);
            let (leave, o) = (&src[i - r], &mut dst[i]);
            for s in 0..S {
                for c in 0..4 {
                    let v = (acc[s][c] + a * (before[s][c] as f64 + after[s][c] as f64)) * n;
                    // Running sums cancel to about 1e-16 below zero where light ends.
                    o[s][c] = v.max(0.0) as f32;
                    acc[s][c] += after[s][c] as f64 - leave[s][c] as f64;
                }
            }
        }
    }

    /// The three passes along a line held in `a[2e..2e + n]` (`e` = reach), zero elsewhere;
    /// the result lands in `b[2e..2e + n]`. The first two passes run over `e` texels beyond
    /// each end, where their output is light the zero border has not yet cut off and the third
    /// pass needs; outside that the values are truly zero or never read.
    fn line<const S: usize>(&self, a: &mut [[Px; S]], b: &mut [[Px; S]], n: usize) {
        let e = self.reach();
        self.pass(a, b, e, n + 3 * e);
        self.pass(b, a, e, n + 3 * e);
        self.pass(a, b, 2 * e, n + 2 * e);
    }
}

fn box3<I: Io>(io: &I, w: usize, h: usize, sigma: Sig, out: &mut [I::Out]) {
    let by = ExtBox::new(sigma.y);
    let e = by.reach();
    let mut img = vec![[0.0f32; 4]; w * h];
    img.par_chunks_mut(w)
        .enumerate()
        .for_each(|(y, row)| io.fill(y, 0, row));
    // Vertical passes on strips of STRIP columns, so the running sums walk down contiguous
    // memory; the strips are stored strip-major and gathered back into rows below.
    let strips = w.div_ceil(STRIP);
    let mut cols = vec![[[0.0f32; 4]; STRIP]; strips * h];
    let len = h + 4 * e;
    cols.par_chunks_mut(h).enumerate().for_each_init(
        || {
            (
                vec![[[0.0f32; 4]; STRIP]; len],
                vec![[[0.0f32; 4]; STRIP]; len],
            )
        },
        |(a, b), (strip, o)| {
            let x0 = strip * STRIP;
            let n = STRIP.min(w - x0);
            // Pass two wrote the margins of `a` for the previous strip: clear them.
            a[e..2 * e].fill([[0.0; 4]; STRIP]);
            a[h + 2 * e..h + 3 * e].fill([[0.0; 4]; STRIP]);
            for (y, t) in a[2 * e..2 * e + h].iter_mut().enumerate() {
                t[..n].copy_from_slice(&img[y * w + x0..y * w + x0 + n]);
            }
            by.line(a, b, h);
            o.copy_from_slice(&b[2 * e..2 * e + h]);
        },
    );
    drop(img);
    let bx = ExtBox::new(sigma.x);
    let e = bx.reach();
    let len = w + 4 * e;
    out.par_chunks_mut(w * I::PER_TEXEL)
        .enumerate()
        .for_each_init(
            || (vec![[[0.0f32; 4]; 1]; len], vec![[[0.0f32; 4]; 1]; len]),
            |(a, b), (y, o)| {
                a[e..2 * e].fill([[0.0; 4]]);
                a[w + 2 * e..w + 3 * e].fill([[0.0; 4]]);
                for (x, t) in a[2 * e..2 * e + w].iter_mut().enumerate() {
                    t[0] = cols[(x / STRIP) * h + y][x % STRIP];
                }
                bx.line(a, b, w);
                io.emit(b[2 * e..2 * e + w].as_flattened(), o);
            },
        );
}

fn run<I: Io>(io: &I, w: usize, h: usize, sigma: Sig, method: BlurMethod, out: &mut [I::Out]) {
    let s = Sigma2::new(sigma.x as f32, sigma.y as f32);
    match method.resolve_sized(s, w as u32, h as u32) {
        BlurMethod::Decimated => decimated(io, w, h, sigma, EXACT, out),
        BlurMethod::DecimatedCoarse => decimated(io, w, h, sigma, COARSE, out),
        BlurMethod::Box3 => box3(io, w, h, sigma, out),
        _ => direct(io, w, h, sigma, out),
    }
}

/// σ checked and the size as `usize`, for a `w x h` buffer of `len` elements, `per` a texel
/// (a caller's buffer of another size is a bug, not bad input).
fn checked(
    sigma: Sigma2,
    w: u32,
    h: u32,
    len: usize,
    per: usize,
    what: &str,
) -> Result<(Sig, usize, usize), TextureError> {
    let s = check_sigma2(sigma)?;
    crate::mips::check_size(w, h)?;
    let (w, h) = (w as usize, h as usize);
    assert_eq!(len, w * h * per, "{what}: buffer does not match {w}x{h}");
    Ok((s, w, h))
}

/// Blurs premultiplied linear RGBA (`w x h`, row-major) with σ in texels.
pub fn blur_linear(
    src: &[[f32; 4]],
    w: u32,
    h: u32,
    sigma: impl Into<Sigma2>,
    method: BlurMethod,
) -> Result<Vec<[f32; 4]>, TextureError> {
    let (s, w, h) = checked(sigma.into(), w, h, src.len(), 1, "blur_linear")?;
    let mut out = vec![[0.0f32; 4]; w * h];
    run(&F32Io { src, w }, w, h, s, method, &mut out);
    Ok(out)
}

/// [`blur_linear`] of an sRGB RGBA8 image with straight alpha (`w x h`, row-major) after
/// [`crate::pixels::to_linear`] and premultiplying, the same bits, read from the bytes as the
/// passes go instead of from a full-size f32 copy.
pub fn blur_rgba8_to_linear(
    src: &[u8],
    w: u32,
    h: u32,
    sigma: impl Into<Sigma2>,
    method: BlurMethod,
) -> Result<Vec<[f32; 4]>, TextureError> {
    blur_rgba8_framed_to_linear(src, w, h, [0, 0], sigma, method)
}

/// [`blur_rgba8_to_linear`] of the image in a frame of `margin = [mx, my]` transparent texels
/// on each side: `(w + 2·mx) x (h + 2·my)` texels, the bits of blurring a framed copy.
pub fn blur_rgba8_framed_to_linear(
    src: &[u8],
    w: u32,
    h: u32,
    margin: [u32; 2],
    sigma: impl Into<Sigma2>,
    method: BlurMethod,
) -> Result<Vec<[f32; 4]>, TextureError> {
    let (io, s, w, h) =
        Straight8Io::framed(src, w, h, margin, sigma, "blur_rgba8_framed_to_linear")?;
    let mut out = vec![[0.0f32; 4]; w * h];
    run(&io, w, h, s, method, &mut out);
    Ok(out)
}

/// [`blur_rgba8_to_linear`] a band of rows at a time, the same bits as those rows of the whole
/// blur: a caller that needs the blur only a band at a time holds a band, not the image (a
/// 1024² design's blur is 17 MB of f32). The decimated methods hold their coarse grid, `1/k²`
/// of the image; the direct one holds nothing, each band starting its passes `r` rows early.
pub struct RowBlur<'a> {
    io: Straight8Io<'a>,
    /// The framed image's size.
    w: usize,
    h: usize,
    sigma: Sig,
    grid: Option<Grid>,
}

impl<'a> RowBlur<'a> {
    /// The blur of `src` (`w x h`) in a frame of `margin` transparent texels, as
    /// [`blur_rgba8_framed_to_linear`]; rows count from the frame's top. `None` for
    /// [`BlurMethod::Box3`], whose passes run down whole columns.
    pub fn new(
        src: &'a [u8],
        w: u32,
        h: u32,
        margin: [u32; 2],
        sigma: impl Into<Sigma2>,
        method: BlurMethod,
    ) -> Result<Option<Self>, TextureError> {
        let sigma = sigma.into();
        let (io, s, w, h) = Straight8Io::framed(src, w, h, margin, sigma, "RowBlur")?;
        let grid = match method.resolve_sized(sigma, w as u32, h as u32) {
            BlurMethod::Decimated => Some(Grid::new(&io, w, h, s, EXACT)),
            BlurMethod::DecimatedCoarse => Some(Grid::new(&io, w, h, s, COARSE)),
            BlurMethod::Box3 => return Ok(None),
            _ => None,
        };
        Ok(Some(RowBlur {
            io,
            w,
            h,
            sigma: s,
            grid,
        }))
    }

    /// The framed image's width and height.
    pub fn size(&self) -> (u32, u32) {
        (self.w as u32, self.h as u32)
    }

    /// Rows `rows` of the blur (within the image).
    pub fn rows(&self, rows: std::ops::Range<u32>) -> Vec<[f32; 4]> {
        let rows = rows.start as usize..rows.end as usize;
        assert!(
            rows.start <= rows.end && rows.end <= self.h,
            "RowBlur: rows {rows:?}"
        );
        let io = &self.io;
        let mut out = vec![[0.0f32; 4]; rows.len() * self.w];
        match &self.grid {
            Some(grid) => grid.rows(io, rows, &mut out),
            None => direct_with(
                Isa::detect(),
                io,
                self.w,
                self.h,
                self.sigma,
                rows,
                &mut out,
            ),
        }
        out
    }
}

/// Blurs sRGB RGBA8 with straight alpha (`w x h`, row-major) in linear light with premultiplied
/// alpha; returns RGBA8 holding the sRGB encoding of the blurred *premultiplied* colour (the
/// light a window lets through) and linear alpha. The end-to-end operation the benchmarks time.
pub fn blur_srgb8(
    src: &[u8],
    w: u32,
    h: u32,
    sigma: impl Into<Sigma2>,
    method: BlurMethod,
) -> Result<Vec<u8>, TextureError> {
    let mut out = vec![0u8; src.len()];
    blur_srgb8_into(src, w, h, sigma, method, &mut out)?;
    Ok(out)
}

/// [`blur_srgb8`] into a caller's buffer (`w * h * 4` bytes), so repeated blurs of one size
/// reuse memory instead of faulting in fresh pages for every result.
pub fn blur_srgb8_into(
    src: &[u8],
    w: u32,
    h: u32,
    sigma: impl Into<Sigma2>,
    method: BlurMethod,
    out: &mut [u8],
) -> Result<(), TextureError> {
    let (s, w, h) = checked(sigma.into(), w, h, src.len(), 4, "blur_srgb8")?;
    assert_eq!(
        out.len(),
        src.len(),
        "blur_srgb8: output does not match {w}x{h}"
    );
    run(&Srgb8Io { src, w }, w, h, s, method, out);
    Ok(())
}

/// sRGB RGBA8 with straight alpha → premultiplied linear RGBA in f64 (exact decode).
pub fn srgb8_to_premultiplied_f64(src: &[u8]) -> Vec<[f64; 4]> {
    src.chunks_exact(4)
        .map(|b| {
            let a = b[3] as f64 / 255.0;
            let c = |v: u8| crate::srgb::srgb_to_linear(v as f64 / 255.0) * a;
            [c(b[0]), c(b[1]), c(b[2]), a]
        })
        .collect()
}

/// Error statistics in LSB of the 8-bit output: colour against the unrounded sRGB encoding of
/// the reference, alpha against 255·alpha. 0.5 is the rounding floor.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ErrorLsb {
    pub max: f64,
    pub rms: f64,
}

/// Error of RGBA8 output (sRGB-encoded premultiplied colour, linear alpha) against a
/// premultiplied linear f64 reference.
pub fn error_lsb(ours: &[u8], reference: &[[f64; 4]]) -> ErrorLsb {
    assert_eq!(ours.len(), reference.len() * 4);
    let (max, sq) = ours
        .par_chunks(4 * 4096)
        .zip(reference.par_chunks(4096))
        .map(|(o, r)| {
            let mut max = 0.0f64;
            let mut sq = 0.0f64;
            for (o, r) in o.chunks_exact(4).zip(r) {
                for c in 0..4 {
                    let exact = if c < 3 {
                        linear_to_srgb_lsb(r[c])
                    } else {
                        r[3].clamp(0.0, 1.0) * 255.0
                    };
                    let e = (o[c] as f64 - exact).abs();
                    max = max.max(e);
                    sq += e * e;
                }
            }
            (max, sq)
        })
        .reduce(|| (0.0, 0.0), |a, b| (a.0.max(b.0), a.1 + b.1));
    ErrorLsb {
        max,
        rms: (sq / (ours.len().max(1)) as f64).sqrt(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The vector loops must give the plain loops' bits, on shapes that leave partial strips,
    /// partial vector blocks and partial row groups, and on one tall enough to be cut into
    /// bands.
    #[test]
    fn direct_blur_gives_the_same_bits_on_every_instruction_set() {
        let mut isas = vec![Isa::Plain];
        #[cfg(target_arch = "x86_64")]
        {
            if std::is_x86_feature_detected!("avx2") {
                isas.push(Isa::Avx2);
            }
            if std::is_x86_feature_detected!("avx512f") {
                isas.push(Isa::Avx512);
            }
        }
        let cases = [
            (301, 37, 1.3, 1.3),
            (17, 900, 2.2, 2.2),
            (5, 3, 0.7, 0.7),
            (260, 64, 3.5, 3.5),
            (301, 37, 0.8, 3.1),
            (90, 70, 4.4, 1.2),
        ];
        for (w, h, sx, sy) in cases {
            let sigma = Sig { x: sx, y: sy };
            let panes = crate::testing::Panes {
                width: 13,
                height: 9,
                lead: 2,
            };
            let src = crate::testing::design(w, h, 7, panes);
            let io = Srgb8Io { src: &src, w };
            let results: Vec<Vec<u8>> = isas
                .iter()
                .map(|&isa| {
                    let mut out = vec![0u8; w * h * 4];
                    direct_with(isa, &io, w, h, sigma, 0..h, &mut out);
                    out
                })
                .collect();
            for (isa, r) in isas.iter().zip(&results) {
                assert!(r == &results[0], "{isa:?} differs at {w}x{h} σ={sigma:?}");
            }
        }
    }

    /// The per-output loop of a kernel wider than its row gives the tap-major loop's bits.
    #[test]
    fn a_kernel_wider_than_the_row_gives_the_same_bits_output_by_output() {
        let mut seed = 7u32;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            (seed % 1000) as f32 / 999.0
        };
        for (len, k, sigma) in [(37usize, 21usize, 28.0f64), (5, 30, 40.0), (64, 40, 80.0)] {
            let g1 = to_f32(&kernel_at(sigma, KERNEL_RADIUS_SIGMAS, usize::MAX));
            let ax = Axis::new(len, k, sigma, KERNEL_RADIUS_SIGMAS);
            let fir = ax.stage1(&g1);
            let row: Vec<Px> = (0..len).map(|_| [next(), next(), next(), next()]).collect();
            let n = ax.count;
            assert!(
                fir.taps.len() > 4 * (len + n),
                "apply takes the per-output loop for these"
            );
            let mut taps_major = vec![[0.0f32; 4]; n];
            fir.apply_per_tap(&row, &mut fir.scratch(n), &mut taps_major);
            let mut per_output = vec![[0.0f32; 4]; n];
            fir.apply_per_output(&row, &mut per_output);
            assert!(
                taps_major
                    .iter()
                    .zip(&per_output)
                    .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)),
                "len {len}, k {k}, σ {sigma}"
            );
            assert!(per_output.iter().any(|t| t[0] > 0.0));
        }
    }

    #[test]
    fn bands_of_the_blur_are_those_rows_of_the_whole() {
        let panes = crate::testing::Panes {
            width: 11,
            height: 7,
            lead: 2,
        };
        let cases = [
            (301u32, 97u32, 1.3f32, BlurMethod::Direct),
            (64, 300, 2.2, BlurMethod::Direct),
            (9, 40, 5.5, BlurMethod::Direct),
            (520, 33, 0.4, BlurMethod::Direct),
            (333, 120, 6.6, BlurMethod::Decimated),
            (80, 257, 19.0, BlurMethod::Decimated),
            (129, 64, 9.4, BlurMethod::DecimatedCoarse),
        ];
        // And a blur wider one way than the other, by each method that streams.
        let stretched = [
            (301u32, 97u32, Sigma2::new(1.3, 4.0), BlurMethod::Direct),
            (333, 120, Sigma2::new(6.6, 13.0), BlurMethod::Decimated),
            (129, 64, Sigma2::new(9.4, 5.0), BlurMethod::DecimatedCoarse),
        ];
        let cases = cases
            .into_iter()
            .map(|(w, h, s, m)| (w, h, Sigma2::from(s), m))
            .chain(stretched);
        for (w, h, sigma, method) in cases {
            let src = crate::testing::design(w as usize, h as usize, 5, panes);
            let whole = blur_rgba8_to_linear(&src, w, h, sigma, method).unwrap();
            let blur = RowBlur::new(&src, w, h, [0, 0], sigma, method)
                .unwrap()
                .unwrap();
            for band in [1u32, 7, 16, 50, h] {
                let mut y0 = 0;
                while y0 < h {
                    let y1 = (y0 + band).min(h);
                    let rows = blur.rows(y0..y1);
                    let expect = &whole[(y0 * w) as usize..(y1 * w) as usize];
                    assert!(
                        rows.iter()
                            .zip(expect)
                            .all(|(a, b)| a.map(f32::to_bits) == b.map(f32::to_bits)),
                        "{w}x{h} σ={sigma} {method:?}: rows {y0}..{y1} differ"
                    );
                    y0 = y1;
                }
            }
        }
    }

    /// A frame of transparent texels read as zero is the framed copy, by every method.
    #[test]
    fn a_frame_blurs_as_a_framed_copy() {
        let panes = crate::testing::Panes {
            width: 5,
            height: 7,
            lead: 1,
        };
        let (w, h) = (37usize, 23usize);
        let src = crate::testing::design(w, h, 3, panes);
        for (method, sigma, m) in [
            (BlurMethod::Direct, Sigma2::from(2.2), [9, 9]),
            (BlurMethod::Decimated, 7.0.into(), [9, 9]),
            (BlurMethod::DecimatedCoarse, 9.0.into(), [9, 9]),
            (BlurMethod::Box3, 3.0.into(), [9, 9]),
            (BlurMethod::Direct, Sigma2::new(2.2, 0.9), [9, 4]),
            (BlurMethod::Decimated, Sigma2::new(4.0, 9.0), [16, 36]),
            (BlurMethod::Box3, Sigma2::new(5.0, 2.5), [20, 10]),
        ] {
            let framed = crate::testing::framed(&src, w, h, m);
            let m32 = m.map(|m| m as u32);
            let a =
                blur_rgba8_framed_to_linear(&src, w as u32, h as u32, m32, sigma, method).unwrap();
            let (fw, fh) = ((w + 2 * m[0]) as u32, (h + 2 * m[1]) as u32);
            let b = blur_rgba8_to_linear(&framed, fw, fh, sigma, method).unwrap();
            assert!(
                a.iter()
                    .zip(&b)
                    .all(|(x, y)| x.map(f32::to_bits) == y.map(f32::to_bits)),
                "{method:?} {sigma}"
            );
            if let Some(rows) = RowBlur::new(&src, w as u32, h as u32, m32, sigma, method).unwrap()
            {
                assert!(
                    rows.rows(5..fh)
                        .iter()
                        .zip(&b[5 * fw as usize..])
                        .all(|(x, y)| x == y)
                );
            }
        }
    }
}
