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

use rayon::prelude::*;

use crate::TextureError;
use crate::srgb::{decode8, encoder, linear_to_srgb_lsb};

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

/// How the blur is computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum BlurMethod {
    /// Decimated where it is exact (σ ≥ 3.8), direct otherwise.
    #[default]
    Auto,
    /// Separable FIR with the truncated kernel.
    Direct,
    /// Two half-width Gaussians through a grid of every k-th texel (direct below σ = 3.8).
    Decimated,
}

impl BlurMethod {
    pub fn name(self) -> &'static str {
        match self {
            Self::Auto => "auto",
            Self::Direct => "direct",
            Self::Decimated => "decimated",
        }
    }

    /// The method used at this σ. The decimated grid needs σ ≥ 2·1.9 texels to stay exact
    /// (below that the Gaussian halves are too narrow for their samples), so smaller σ always
    /// runs direct, which is cheap there anyway.
    pub fn resolve(self, sigma: f32) -> Self {
        match self {
            Self::Auto | Self::Decimated if decimation(sigma as f64) >= 2 => Self::Decimated,
            _ => Self::Direct,
        }
    }
}

fn decimation(sigma: f64) -> usize {
    ((sigma / DECIMATION_RATIO).floor() as usize).max(1)
}

pub(crate) fn check_sigma(sigma: f32) -> Result<f64, TextureError> {
    if !(sigma.is_finite() && (0.0..=MAX_SIGMA).contains(&sigma)) {
        return Err(TextureError::InvalidSigma { sigma });
    }
    Ok(sigma as f64)
}

/// Radius of the truncated kernel for σ, in texels.
pub fn kernel_radius(sigma: f64) -> usize {
    if sigma < DELTA_SIGMA {
        0
    } else {
        (KERNEL_RADIUS_SIGMAS * sigma).ceil() as usize
    }
}

/// The normalized truncated kernel, but only its taps at offsets up to `max_offset` (an image
/// `n` texels long never needs more than `n - 1`): returns the taps at offsets
/// `-r..=r`, `r = min(radius, max_offset)`, normalized over the whole radius.
pub fn gaussian_kernel(sigma: f64, max_offset: usize) -> Vec<f64> {
    let radius = kernel_radius(sigma);
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
    let kx = gaussian_kernel(sigma, w.saturating_sub(1));
    let ky = gaussian_kernel(sigma, h.saturating_sub(1));
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
}

/// Where the blur's input rows come from and its output rows go; lets the u8 path decode and
/// encode inside the passes instead of in extra full-image sweeps.
trait Io: Sync {
    type Out: Send + Copy + Default;
    /// Output elements per texel.
    const PER_TEXEL: usize;
    fn fill(&self, y: usize, row: &mut [Px]);
    fn emit(&self, row: &[Px], out: &mut [Self::Out]);
}

struct F32Io<'a> {
    src: &'a [Px],
    w: usize,
}

impl Io for F32Io<'_> {
    type Out = Px;
    const PER_TEXEL: usize = 1;
    fn fill(&self, y: usize, row: &mut [Px]) {
        row.copy_from_slice(&self.src[y * self.w..(y + 1) * self.w]);
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
    fn fill(&self, y: usize, row: &mut [Px]) {
        let lut = decode8();
        let bytes = &self.src[y * self.w * 4..(y + 1) * self.w * 4];
        for (t, b) in row.iter_mut().zip(bytes.chunks_exact(4)) {
            let a = b[3] as f32 * (1.0 / 255.0);
            *t = [
                lut[b[0] as usize] * a,
                lut[b[1] as usize] * a,
                lut[b[2] as usize] * a,
                a,
            ];
        }
    }
    fn emit(&self, row: &[Px], out: &mut [u8]) {
        encoder().encode_rgba(row, out);
    }
}

fn to_f32(k: &[f64]) -> Vec<f32> {
    k.iter().map(|&v| v as f32).collect()
}

fn direct<I: Io>(io: &I, w: usize, h: usize, sigma: f64, out: &mut [I::Out]) {
    let kx = to_f32(&gaussian_kernel(sigma, w - 1));
    let ky = to_f32(&gaussian_kernel(sigma, h - 1));
    let ry = ky.len() / 2;
    let fir = RowFir {
        k: 1,
        pad: kx.len() / 2,
        taps: kx,
    };
    let mut mid = vec![[0.0f32; 4]; w * h];
    mid.par_chunks_mut(w).enumerate().for_each_init(
        || (vec![[0.0f32; 4]; w], fir.scratch(w)),
        |(row, phases), (y, o)| {
            io.fill(y, row);
            fir.apply(row, phases, o);
        },
    );
    out.par_chunks_mut(w * I::PER_TEXEL)
        .enumerate()
        .for_each_init(
            || vec![[0.0f32; 4]; w],
            |acc, (y, o)| {
                let lo = y.saturating_sub(ry);
                let hi = (y + ry).min(h - 1);
                let terms: Vec<(f32, &[Px])> = (lo..=hi)
                    .map(|sy| (ky[sy + ry - y], &mid[sy * w..(sy + 1) * w]))
                    .collect();
                wsum(acc, &terms);
                io.emit(acc, o);
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
    fn new(n: usize, k: usize, tau: f64) -> Axis {
        let rt = kernel_radius(tau);
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

fn decimated<I: Io>(io: &I, w: usize, h: usize, sigma: f64, out: &mut [I::Out]) {
    let k = decimation(sigma);
    let tau = sigma / std::f64::consts::SQRT_2;
    let g1 = to_f32(&gaussian_kernel(tau, usize::MAX));
    let r1 = g1.len() / 2;
    let ax = Axis::new(w, k, tau);
    let ay = Axis::new(h, k, tau);
    let (mx, my) = (ax.count, ay.count);
    let fir = ax.stage1(&g1);

    // Stage 1 along x at the coarse columns, every fine row.
    let mut a = vec![[0.0f32; 4]; mx * h];
    a.par_chunks_mut(mx).enumerate().for_each_init(
        || (vec![[0.0f32; 4]; w], fir.scratch(mx)),
        |(row, phases), (y, o)| {
            io.fill(y, row);
            fir.apply(row, phases, o);
        },
    );
    // Stage 1 along y at the coarse rows (zero rows outside the image contribute nothing).
    let mut b = vec![[0.0f32; 4]; mx * my];
    b.par_chunks_mut(mx).enumerate().for_each(|(m, o)| {
        let p = (m * k) as i64 - ay.rt as i64;
        let terms: Vec<(f32, &[Px])> = g1
            .iter()
            .enumerate()
            .filter_map(|(t, &g)| {
                let y = usize::try_from(p - r1 as i64 + t as i64)
                    .ok()
                    .filter(|&y| y < h)?;
                Some((g, &a[y * mx..(y + 1) * mx]))
            })
            .collect();
        wsum(o, &terms);
    });
    drop(a);
    // Stage 2: interpolate y back to fine rows, then x to fine columns.
    out.par_chunks_mut(w * I::PER_TEXEL)
        .enumerate()
        .for_each_init(
            || {
                (
                    vec![[0.0f32; 4]; mx],
                    vec![[0.0f32; 4]; w],
                    vec![[0.0f32; 4]; w.div_ceil(k)],
                )
            },
            |(c, row, tmp), (y, o)| {
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

fn run<I: Io>(io: &I, w: usize, h: usize, sigma: f64, method: BlurMethod, out: &mut [I::Out]) {
    match method.resolve(sigma as f32) {
        BlurMethod::Decimated => decimated(io, w, h, sigma, out),
        _ => direct(io, w, h, sigma, out),
    }
}

/// Blurs premultiplied linear RGBA (`w x h`, row-major) with σ in texels.
pub fn blur_linear(
    src: &[[f32; 4]],
    w: u32,
    h: u32,
    sigma: f32,
    method: BlurMethod,
) -> Result<Vec<[f32; 4]>, TextureError> {
    let s = check_sigma(sigma)?;
    crate::mips::check_size(w, h)?;
    let (w, h) = (w as usize, h as usize);
    assert_eq!(
        src.len(),
        w * h,
        "blur_linear: buffer does not match {w}x{h}"
    );
    let mut out = vec![[0.0f32; 4]; w * h];
    run(&F32Io { src, w }, w, h, s, method, &mut out);
    Ok(out)
}

/// Blurs sRGB RGBA8 with straight alpha (`w x h`, row-major) in linear light with premultiplied
/// alpha; returns RGBA8 holding the sRGB encoding of the blurred *premultiplied* colour (the
/// light a window lets through) and linear alpha. The end-to-end operation the benchmarks time.
pub fn blur_srgb8(
    src: &[u8],
    w: u32,
    h: u32,
    sigma: f32,
    method: BlurMethod,
) -> Result<Vec<u8>, TextureError> {
    let s = check_sigma(sigma)?;
    crate::mips::check_size(w, h)?;
    let (w, h) = (w as usize, h as usize);
    assert_eq!(
        src.len(),
        w * h * 4,
        "blur_srgb8: buffer does not match {w}x{h}"
    );
    let mut out = vec![0u8; w * h * 4];
    run(&Srgb8Io { src, w }, w, h, s, method, &mut out);
    Ok(out)
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
