//! Polyphase reduction filters for mip levels: each level is `max(1, n / 2)` texels on each axis,
//! and every source texel contributes (for n = 5 → 2 each output covers 2.5 source texels).

use rayon::prelude::*;

use crate::real::Real;

/// Reconstruction filter for mip reduction. Serde names are [`MipFilter::name`]'s.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum MipFilter {
    /// Area average over each output texel's footprint (exact 2x2 for even sizes).
    #[default]
    Box,
    /// Kaiser-windowed sinc (radius 3 output texels, β = 4): sharper than box, little ringing.
    Kaiser,
    /// Lanczos-windowed sinc, radius 3 output texels: sharpest, rings at hard edges.
    Lanczos3,
}

impl MipFilter {
    pub fn name(self) -> &'static str {
        match self {
            Self::Box => "box",
            Self::Kaiser => "kaiser",
            Self::Lanczos3 => "lanczos3",
        }
    }
}

/// The next mip size of one axis.
pub fn half(n: u32) -> u32 {
    (n / 2).max(1)
}

/// Walks a mip chain from `level` (`w x h` texels) down to 1x1: `next` filters a level, given
/// with its size, into the next one, and `emit` gets every level in order as soon as the next
/// exists. At most two levels are held at once: a 4096² chain held whole in f32 was 341 MiB
/// where its encoded levels are 85.
pub(crate) fn walk_chain<T>(
    mut level: Vec<T>,
    w: u32,
    h: u32,
    mut next: impl FnMut(&[T], u32, u32) -> Vec<T>,
    mut emit: impl FnMut(Vec<T>),
) {
    let (mut lw, mut lh) = (w, h);
    while lw > 1 || lh > 1 {
        let coarser = next(&level, lw, lh);
        emit(std::mem::replace(&mut level, coarser));
        (lw, lh) = (half(lw), half(lh));
    }
    emit(level);
}

/// One mip step, `w x h` → `half(w) x half(h)`: every texel through `pre`, filtered, then
/// through `post`. A box on even sizes runs in one pass ([`box2`]), anything else through the
/// separable [`reduce`]; the same bits either way for the values filtering meets (see `box2`).
pub(crate) fn next_level<T: Real>(
    level: &[[T; 4]],
    w: u32,
    h: u32,
    filter: MipFilter,
    pre: impl Fn([T; 4]) -> [T; 4] + Sync,
    post: impl Fn([T; 4]) -> [T; 4] + Sync,
) -> Vec<[T; 4]> {
    if filter == MipFilter::Box && w.is_multiple_of(2) && h.is_multiple_of(2) {
        return box2(level, w as usize, pre, post);
    }
    let mut next = reduce(level, w, h, filter, pre);
    next.par_iter_mut().for_each(|t| *t = post(*t));
    next
}

/// The box reduction of an even-sized level (`w` texels a row) in one pass: each 2x2 block
/// through `pre`, averaged by [`box_block`], then through `post`. The same bits as [`reduce`]
/// with [`MipFilter::Box`] and `pre` followed by `post` on each texel, without its half-size
/// intermediate (a 4096² level's is 128 MiB of f32), for the values filtering meets: no
/// negative zeros, which `reduce`'s sums from zero would turn positive.
pub(crate) fn box2<T: Real>(
    src: &[[T; 4]],
    w: usize,
    pre: impl Fn([T; 4]) -> [T; 4] + Sync,
    post: impl Fn([T; 4]) -> [T; 4] + Sync,
) -> Vec<[T; 4]> {
    let w2 = w / 2;
    let mut out = vec![[T::default(); 4]; w2 * (src.len() / w / 2)];
    out.par_chunks_mut(w2).enumerate().for_each(|(y, o)| {
        let (r0, r1) = (
            &src[2 * y * w..(2 * y + 1) * w],
            &src[(2 * y + 1) * w..(2 * y + 2) * w],
        );
        for (x, o) in o.iter_mut().enumerate() {
            let block = [r0[2 * x], r0[2 * x + 1], r1[2 * x], r1[2 * x + 1]];
            *o = post(box_block(block.map(&pre)));
        }
    });
    out
}

/// The 2x2 block `a b / c d` averaged with [`reduce`]'s operations in its order: each row's
/// pair, then the two rows, every term weighted by a half.
#[inline(always)]
pub(crate) fn box_block<T: Real>([a, b, c, d]: [[T; 4]; 4]) -> [T; 4] {
    let half = T::of(0.5);
    let mut t = [T::default(); 4];
    for ch in 0..4 {
        let top = half * a[ch] + half * b[ch];
        let bottom = half * c[ch] + half * d[ch];
        t[ch] = half * top + half * bottom;
    }
    t
}

/// Filter taps of one output texel: the first source index and the weights from there on.
#[derive(Clone, Debug)]
pub struct Taps {
    pub start: usize,
    pub weights: Vec<f64>,
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 {
        1.0
    } else {
        let p = std::f64::consts::PI * x;
        p.sin() / p
    }
}

/// Modified Bessel function of the first kind, order 0 (power series; converges fast for the
/// small arguments a Kaiser window uses).
fn bessel_i0(x: f64) -> f64 {
    let mut sum = 1.0;
    let mut term = 1.0;
    let q = x * x / 4.0;
    for k in 1..64 {
        term *= q / (k * k) as f64;
        sum += term;
        if term < sum * 1e-17 {
            break;
        }
    }
    sum
}

const WINDOW_RADIUS: f64 = 3.0;
const KAISER_BETA: f64 = 4.0;

fn windowed(filter: MipFilter, x: f64) -> f64 {
    let ax = x.abs();
    if ax >= WINDOW_RADIUS {
        return 0.0;
    }
    match filter {
        MipFilter::Lanczos3 => sinc(x) * sinc(x / WINDOW_RADIUS),
        MipFilter::Kaiser => {
            let r = ax / WINDOW_RADIUS;
            sinc(x) * bessel_i0(KAISER_BETA * (1.0 - r * r).sqrt()) / bessel_i0(KAISER_BETA)
        }
        MipFilter::Box => unreachable!("box is computed from exact overlaps"),
    }
}

/// Polyphase taps reducing `n` source texels to `m` (m ≤ n). Box weights are exact overlaps of
/// each output footprint `[i·s, (i+1)·s)` (s = n/m) with the source texels; windowed filters
/// are stretched by s, and taps falling off an edge are folded onto the edge texel (clamp).
/// Every output's weights sum to one.
pub fn taps(n: usize, m: usize, filter: MipFilter) -> Vec<Taps> {
    assert!(m >= 1 && m <= n, "reduction {n} -> {m}");
    let s = n as f64 / m as f64;
    (0..m)
        .map(|i| {
            if m == n {
                return Taps {
                    start: i,
                    weights: vec![1.0],
                };
            }
            let mut t = match filter {
                MipFilter::Box => {
                    let lo = i as f64 * s;
                    let hi = (i + 1) as f64 * s;
                    let start = lo.floor() as usize;
                    let end = (hi.ceil() as usize).min(n);
                    let weights = (start..end)
                        .map(|j| (hi.min(j as f64 + 1.0) - lo.max(j as f64)).max(0.0))
                        .collect();
                    Taps { start, weights }
                }
                _ => {
                    let c = (i as f64 + 0.5) * s;
                    let lo = (c - WINDOW_RADIUS * s).floor() as i64;
                    let hi = (c + WINDOW_RADIUS * s).ceil() as i64;
                    let start = lo.max(0) as usize;
                    let end = (hi.min(n as i64 - 1) + 1) as usize;
                    let mut weights = vec![0.0; end - start];
                    for j in lo..=hi {
                        let k = windowed(filter, (j as f64 + 0.5 - c) / s);
                        weights[j.clamp(start as i64, end as i64 - 1) as usize - start] += k;
                    }
                    Taps { start, weights }
                }
            };
            let sum: f64 = t.weights.iter().sum();
            for w in &mut t.weights {
                *w /= sum;
            }
            t
        })
        .collect()
}

/// Taps converted to the working precision, flattened for speed.
struct FlatTaps<T> {
    start: Vec<usize>,
    offset: Vec<usize>,
    weights: Vec<T>,
}

impl<T: Real> FlatTaps<T> {
    fn new(taps: &[Taps]) -> Self {
        let mut f = FlatTaps {
            start: vec![],
            offset: vec![0],
            weights: vec![],
        };
        for t in taps {
            f.start.push(t.start);
            f.weights.extend(t.weights.iter().map(|&w| T::of(w)));
            f.offset.push(f.weights.len());
        }
        f
    }
    #[inline]
    fn get(&self, i: usize) -> (usize, &[T]) {
        (
            self.start[i],
            &self.weights[self.offset[i]..self.offset[i + 1]],
        )
    }
}

/// One mip reduction of a 4-channel image: `w x h` → `half(w) x half(h)`, separable, linear in
/// each channel. `pre` maps every source texel before filtering (e.g. to premultiplied form).
pub fn reduce<T: Real>(
    src: &[[T; 4]],
    w: u32,
    h: u32,
    filter: MipFilter,
    pre: impl Fn([T; 4]) -> [T; 4] + Sync,
) -> Vec<[T; 4]> {
    reduce_to(src, w, h, half(w), half(h), filter, pre)
}

/// [`reduce`] to any `w2 x h2` no larger than the source: an axis kept at its size passes
/// through (one tap of weight one), so a level can be halved along one axis only.
pub fn reduce_to<T: Real>(
    src: &[[T; 4]],
    w: u32,
    h: u32,
    w2: u32,
    h2: u32,
    filter: MipFilter,
    pre: impl Fn([T; 4]) -> [T; 4] + Sync,
) -> Vec<[T; 4]> {
    let (w, h) = (w as usize, h as usize);
    let (w2, h2) = (w2 as usize, h2 as usize);
    let tx = FlatTaps::<T>::new(&taps(w, w2, filter));
    let ty = FlatTaps::<T>::new(&taps(h, h2, filter));
    let mid = horizontal(src, w, w2, &tx, &pre);
    vertical(&mid, w2, &ty, 0..h2, 0)
}

/// [`reduce`]'s horizontal pass over every row of `src` (`w` texels a row) to `w2` texels.
fn horizontal<T: Real>(
    src: &[[T; 4]],
    w: usize,
    w2: usize,
    tx: &FlatTaps<T>,
    pre: &(impl Fn([T; 4]) -> [T; 4] + Sync),
) -> Vec<[T; 4]> {
    let zero = [T::default(); 4];
    let mut mid = vec![zero; w2 * (src.len() / w.max(1))];
    mid.par_chunks_mut(w2)
        .zip(src.par_chunks(w))
        .for_each(|(out, row)| {
            for (i, o) in out.iter_mut().enumerate() {
                let (start, ws) = tx.get(i);
                let mut acc = zero;
                for (k, &wt) in ws.iter().enumerate() {
                    let p = pre(row[start + k]);
                    for c in 0..4 {
                        acc[c] = acc[c] + wt * p[c];
                    }
                }
                *o = acc;
            }
        });
    mid
}

/// [`reduce`]'s vertical pass, for output rows `rows`, from `mid`'s rows (`w2` texels each),
/// the first of which is source row `first`. As whole-row multiply-adds, which stream
/// through memory.
fn vertical<T: Real>(
    mid: &[[T; 4]],
    w2: usize,
    ty: &FlatTaps<T>,
    rows: std::ops::Range<usize>,
    first: usize,
) -> Vec<[T; 4]> {
    let zero = [T::default(); 4];
    let mut out = vec![zero; w2 * rows.len()];
    out.par_chunks_mut(w2).enumerate().for_each(|(i, orow)| {
        let (start, ws) = ty.get(rows.start + i);
        for (k, &wt) in ws.iter().enumerate() {
            let r = &mid[(start + k - first) * w2..(start + k - first + 1) * w2];
            for (o, v) in orow.iter_mut().zip(r) {
                for c in 0..4 {
                    o[c] = o[c] + wt * v[c];
                }
            }
        }
    });
    out
}

/// [`reduce_to`] of a level given by rows, each output texel through `post`: `rows(a..b)`
/// gives source rows `a` to `b` (`w` texels each). Made `band` output rows at a time from
/// the source rows the band's taps reach, so no more of the source is held at once (a 4097²
/// design's whole level 0 in f32 was 269 MB). With half sizes, the same bits as
/// [`next_level`] (for the values filtering meets: see [`box2`]).
#[allow(clippy::too_many_arguments)]
pub(crate) fn reduce_to_by_rows<T: Real>(
    w: u32,
    h: u32,
    w2: u32,
    h2: u32,
    filter: MipFilter,
    band: usize,
    rows: impl Fn(std::ops::Range<usize>) -> Vec<[T; 4]>,
    pre: impl Fn([T; 4]) -> [T; 4] + Sync,
    post: impl Fn([T; 4]) -> [T; 4] + Sync,
) -> Vec<[T; 4]> {
    let (w, h) = (w as usize, h as usize);
    let (w2, h2) = (w2 as usize, h2 as usize);
    let tx = FlatTaps::<T>::new(&taps(w, w2, filter));
    let ty = FlatTaps::<T>::new(&taps(h, h2, filter));
    let mut out = Vec::with_capacity(w2 * h2);
    for y0 in (0..h2).step_by(band.max(1)) {
        let band = y0..(y0 + band.max(1)).min(h2);
        let reach = |y: usize| {
            let (start, ws) = ty.get(y);
            (start, start + ws.len())
        };
        let first = band.clone().map(|y| reach(y).0).min().unwrap_or(0);
        let last = band.clone().map(|y| reach(y).1).max().unwrap_or(0);
        let mid = horizontal(&rows(first..last), w, w2, &tx, &pre);
        let mut next = vertical(&mid, w2, &ty, band, first);
        next.par_iter_mut().for_each(|t| *t = post(*t));
        out.extend(next);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The one-pass box gives the separable path's bits, on values with zeros among them, as
    /// the projector's chain meets them (premultiplied, then clamped).
    #[test]
    fn one_pass_box_is_the_separable_one_on_even_sizes() {
        let mut rng = crate::testing::Rng(5);
        for (w, h) in [(2u32, 2u32), (8, 6), (34, 12)] {
            let src: Vec<[f32; 4]> = (0..w * h)
                .map(|_| {
                    std::array::from_fn(|_| match rng.byte() % 4 {
                        0 => 0.0,
                        _ => rng.byte() as f32 / 200.0,
                    })
                })
                .collect();
            let clamp = |t: [f32; 4]| t.map(|v| v.clamp(0.0, 1.0));
            let mut separable = reduce(&src, w, h, MipFilter::Box, |t| t);
            separable.iter_mut().for_each(|t| *t = clamp(*t));
            let one_pass = box2(&src, w as usize, |t| t, clamp);
            let bits = |v: &[[f32; 4]]| v.iter().flatten().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert!(bits(&separable) == bits(&one_pass), "{w}x{h}");
        }
    }

    #[test]
    fn five_to_two_box_covers_two_and_a_half_texels() {
        let t = taps(5, 2, MipFilter::Box);
        assert_eq!(t[0].start, 0);
        assert_eq!(t[0].weights, vec![0.4, 0.4, 0.2]);
        assert_eq!(t[1].start, 2);
        assert_eq!(t[1].weights, vec![0.2, 0.4, 0.4]);
    }

    #[test]
    fn every_source_texel_contributes_equally_to_a_box_reduction() {
        for n in 2..40usize {
            let m = (n / 2).max(1);
            let mut total = vec![0.0; n];
            for t in taps(n, m, MipFilter::Box) {
                for (k, w) in t.weights.iter().enumerate() {
                    total[t.start + k] += w;
                }
            }
            for v in total {
                assert!((v - m as f64 / n as f64).abs() < 1e-12, "n={n}: {v}");
            }
        }
    }

    #[test]
    fn windowed_taps_sum_to_one_and_stay_in_range() {
        for f in [MipFilter::Kaiser, MipFilter::Lanczos3] {
            for n in 1..30usize {
                let m = (n / 2).max(1);
                for t in taps(n, m, f) {
                    assert!(t.start + t.weights.len() <= n);
                    let s: f64 = t.weights.iter().sum();
                    assert!((s - 1.0).abs() < 1e-12);
                }
            }
        }
    }
}
