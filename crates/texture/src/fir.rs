//! The direct blur's inner loops: a symmetric FIR over a sequence of four-texel vectors, and a
//! four-by-four texel transpose, written once over [`Quad`] and compiled for AVX-512, AVX2 + FMA
//! and plain Rust.
//!
//! Every output is `Σ_{d=r..1} k_d · (x_{-d} + x_{+d})` then `+ k_0 · x_0`, each step one fused
//! multiply-add from zero, outermost pair first. Pairing the symmetric taps halves the
//! multiplies; fusing them rounds once per step. Every implementation performs exactly these
//! operations per float (the plain one through `f32::mul_add`), so the bits do not depend on the
//! CPU, the tiling or the thread count.

/// Floats in one [`Quad`]: four RGBA texels.
pub(crate) const QUAD: usize = 16;

/// Four RGBA texels in f32 (a row's four neighbours, or one column's texel in four rows).
pub(crate) trait Quad: Copy {
    fn zero() -> Self;
    fn splat(v: f32) -> Self;
    /// # Safety
    /// `p` points at [`QUAD`] readable floats.
    unsafe fn load(p: *const f32) -> Self;
    /// # Safety
    /// `p` points at [`QUAD`] writable floats.
    unsafe fn store(self, p: *mut f32);
    fn add(self, o: Self) -> Self;
    /// `self · k + acc`, rounded once.
    fn mul_add(self, k: Self, acc: Self) -> Self;
    /// Texel `j` of quad `i` becomes texel `i` of quad `j`.
    fn transpose(q: [Self; 4]) -> [Self; 4];
}

/// Calls `$f::<Q, B, P>` with the const `P` equal to the runtime phase `$p` (below 8).
macro_rules! by_phase {
    ($p:expr, $f:ident::<$q:ident, $b:ident>($($arg:expr),*)) => {
        match $p {
            0 => $f::<$q, $b, 0>($($arg),*),
            1 => $f::<$q, $b, 1>($($arg),*),
            2 => $f::<$q, $b, 2>($($arg),*),
            3 => $f::<$q, $b, 3>($($arg),*),
            4 => $f::<$q, $b, 4>($($arg),*),
            5 => $f::<$q, $b, 5>($($arg),*),
            6 => $f::<$q, $b, 6>($($arg),*),
            _ => $f::<$q, $b, 7>($($arg),*),
        }
    };
}

/// Most outputs one call of [`symmetric`] may compute (the phases of its windows run to 8).
pub(crate) const MAX_BLOCK: usize = 8;

/// `B` outputs of the symmetric filter with half-kernel `k` (`k[0]` the centre, `k[d]` the taps
/// at ±d): output `b` is centred on `at(b)`, and `at(m)` points at the quad `m` steps away
/// (`m` from `-r` to `B - 1 + r`). Two windows of `B` quads slide one step per tap, so each
/// step loads two quads for `B` fused multiply-adds. The windows are circular (quad `m` in slot
/// `m mod B`) and every step is compiled for its phase `d mod B`, so they stay in registers.
///
/// # Safety
/// `at(m)` must be readable for every such `m`.
#[inline(always)]
pub(crate) unsafe fn symmetric<Q: Quad, const B: usize>(
    at: impl Fn(isize) -> *const f32,
    k: &[f32],
) -> [Q; B] {
    const { assert!(B >= 1 && B <= MAX_BLOCK) };
    let r = k.len() - 1;
    let mut acc = [Q::zero(); B];
    let mut left = [Q::zero(); B];
    let mut right = [Q::zero(); B];
    // SAFETY (every call below): the caller guarantees `at(m)` for m in -r..B + r.
    unsafe {
        if r > 0 {
            by_phase!(r % B, fill::<Q, B>(&mut left, &mut right, &at, r));
            for d in (1..=r).rev() {
                by_phase!(
                    d % B,
                    step::<Q, B>(&mut left, &mut right, &mut acc, &at, k[d], d)
                );
            }
        } else {
            for (b, l) in left.iter_mut().enumerate() {
                *l = Q::load(at(b as isize));
            }
        }
    }
    // The left window has slid onto the centres, quad b in slot b.
    let k0 = Q::splat(k[0]);
    for b in 0..B {
        acc[b] = left[b].mul_add(k0, acc[b]);
    }
    acc
}

/// The windows for the outermost pair, `P = r mod B`.
#[inline(always)]
unsafe fn fill<Q: Quad, const B: usize, const P: usize>(
    left: &mut [Q; B],
    right: &mut [Q; B],
    at: &impl Fn(isize) -> *const f32,
    r: usize,
) {
    for b in 0..B {
        // SAFETY: in the caller's range.
        unsafe {
            left[(b + B - P) % B] = Q::load(at(b as isize - r as isize));
            right[(b + P) % B] = Q::load(at((b + r) as isize));
        }
    }
}

/// The pairs at ±d (`P = d mod B`): left holds `b - d`, right `b + d`; then each window slides
/// one step inwards.
#[inline(always)]
unsafe fn step<Q: Quad, const B: usize, const P: usize>(
    left: &mut [Q; B],
    right: &mut [Q; B],
    acc: &mut [Q; B],
    at: &impl Fn(isize) -> *const f32,
    kd: f32,
    d: usize,
) {
    let kd = Q::splat(kd);
    for b in 0..B {
        acc[b] = left[(b + B - P) % B]
            .add(right[(b + P) % B])
            .mul_add(kd, acc[b]);
    }
    // SAFETY: in the caller's range.
    unsafe {
        left[(B - P) % B] = Q::load(at(B as isize - d as isize));
        right[(P + B - 1) % B] = Q::load(at(d as isize - 1));
    }
}

impl Quad for [f32; QUAD] {
    #[inline(always)]
    fn zero() -> Self {
        [0.0; QUAD]
    }
    #[inline(always)]
    fn splat(v: f32) -> Self {
        [v; QUAD]
    }
    #[inline(always)]
    unsafe fn load(p: *const f32) -> Self {
        // SAFETY: the caller guarantees QUAD readable floats.
        unsafe { p.cast::<[f32; QUAD]>().read_unaligned() }
    }
    #[inline(always)]
    unsafe fn store(self, p: *mut f32) {
        // SAFETY: the caller guarantees QUAD writable floats.
        unsafe { p.cast::<[f32; QUAD]>().write_unaligned(self) }
    }
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        std::array::from_fn(|i| self[i] + o[i])
    }
    #[inline(always)]
    fn mul_add(self, k: Self, acc: Self) -> Self {
        std::array::from_fn(|i| self[i].mul_add(k[i], acc[i]))
    }
    #[inline(always)]
    fn transpose(q: [Self; 4]) -> [Self; 4] {
        std::array::from_fn(|j| std::array::from_fn(|f| q[f / 4][j * 4 + f % 4]))
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x86 {
    use std::arch::x86_64::*;

    use super::Quad;

    /// A quad in two 256-bit registers.
    #[derive(Clone, Copy)]
    pub(crate) struct Avx2([__m256; 2]);

    // SAFETY (every method): only compiled into functions that enable AVX2 and FMA, called
    // after checking the CPU has them.
    impl Quad for Avx2 {
        #[inline(always)]
        fn zero() -> Self {
            unsafe { Avx2([_mm256_setzero_ps(); 2]) }
        }
        #[inline(always)]
        fn splat(v: f32) -> Self {
            unsafe { Avx2([_mm256_set1_ps(v); 2]) }
        }
        #[inline(always)]
        unsafe fn load(p: *const f32) -> Self {
            unsafe { Avx2([_mm256_loadu_ps(p), _mm256_loadu_ps(p.add(8))]) }
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f32) {
            unsafe {
                _mm256_storeu_ps(p, self.0[0]);
                _mm256_storeu_ps(p.add(8), self.0[1]);
            }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            unsafe {
                Avx2([
                    _mm256_add_ps(self.0[0], o.0[0]),
                    _mm256_add_ps(self.0[1], o.0[1]),
                ])
            }
        }
        #[inline(always)]
        fn mul_add(self, k: Self, acc: Self) -> Self {
            unsafe {
                Avx2([
                    _mm256_fmadd_ps(self.0[0], k.0[0], acc.0[0]),
                    _mm256_fmadd_ps(self.0[1], k.0[1], acc.0[1]),
                ])
            }
        }
        #[inline(always)]
        fn transpose(q: [Self; 4]) -> [Self; 4] {
            // Texels are 128-bit halves: quad i is [q_i0 q_i1][q_i2 q_i3].
            unsafe {
                let [a, b, c, d] = q.map(|v| v.0);
                let lo = |x: __m256, y: __m256| _mm256_permute2f128_ps::<0x20>(x, y);
                let hi = |x: __m256, y: __m256| _mm256_permute2f128_ps::<0x31>(x, y);
                [
                    Avx2([lo(a[0], b[0]), lo(c[0], d[0])]),
                    Avx2([hi(a[0], b[0]), hi(c[0], d[0])]),
                    Avx2([lo(a[1], b[1]), lo(c[1], d[1])]),
                    Avx2([hi(a[1], b[1]), hi(c[1], d[1])]),
                ]
            }
        }
    }

    /// A quad in one 512-bit register.
    #[derive(Clone, Copy)]
    pub(crate) struct Avx512(__m512);

    // SAFETY (every method): only compiled into functions that enable AVX-512F, called after
    // checking the CPU has it.
    impl Quad for Avx512 {
        #[inline(always)]
        fn zero() -> Self {
            unsafe { Avx512(_mm512_setzero_ps()) }
        }
        #[inline(always)]
        fn splat(v: f32) -> Self {
            unsafe { Avx512(_mm512_set1_ps(v)) }
        }
        #[inline(always)]
        unsafe fn load(p: *const f32) -> Self {
            unsafe { Avx512(_mm512_loadu_ps(p)) }
        }
        #[inline(always)]
        unsafe fn store(self, p: *mut f32) {
            unsafe { _mm512_storeu_ps(p, self.0) }
        }
        #[inline(always)]
        fn add(self, o: Self) -> Self {
            unsafe { Avx512(_mm512_add_ps(self.0, o.0)) }
        }
        #[inline(always)]
        fn mul_add(self, k: Self, acc: Self) -> Self {
            unsafe { Avx512(_mm512_fmadd_ps(self.0, k.0, acc.0)) }
        }
        #[inline(always)]
        fn transpose(q: [Self; 4]) -> [Self; 4] {
            unsafe {
                let [a, b, c, d] = q.map(|v| v.0);
                let ab_lo = _mm512_shuffle_f32x4::<0x44>(a, b); // a0 a1 b0 b1
                let ab_hi = _mm512_shuffle_f32x4::<0xEE>(a, b); // a2 a3 b2 b3
                let cd_lo = _mm512_shuffle_f32x4::<0x44>(c, d);
                let cd_hi = _mm512_shuffle_f32x4::<0xEE>(c, d);
                [
                    Avx512(_mm512_shuffle_f32x4::<0x88>(ab_lo, cd_lo)), // a0 b0 c0 d0
                    Avx512(_mm512_shuffle_f32x4::<0xDD>(ab_lo, cd_lo)),
                    Avx512(_mm512_shuffle_f32x4::<0x88>(ab_hi, cd_hi)),
                    Avx512(_mm512_shuffle_f32x4::<0xDD>(ab_hi, cd_hi)),
                ]
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quads(n: usize) -> Vec<[f32; QUAD]> {
        (0..n)
            .map(|i| std::array::from_fn(|f| ((i * 31 + f * 7) % 97) as f32 / 97.0))
            .collect()
    }

    #[test]
    fn plain_symmetric_filter_is_the_fused_pair_sum() {
        let x = quads(40);
        let k = [0.4f32, 0.2, 0.07, 0.03];
        let out = unsafe { symmetric::<[f32; QUAD], 5>(|m| x[(10 + m) as usize].as_ptr(), &k) };
        for (b, o) in out.iter().enumerate() {
            for f in 0..QUAD {
                let v = |m: isize| x[(10 + b as isize + m) as usize][f];
                let mut acc = 0.0f32;
                for d in (1..4).rev() {
                    acc = (v(-(d as isize)) + v(d as isize)).mul_add(k[d], acc);
                }
                acc = v(0).mul_add(k[0], acc);
                assert_eq!(o[f].to_bits(), acc.to_bits());
            }
        }
    }

    #[test]
    fn plain_transpose_swaps_quads_and_texels() {
        let q = quads(4);
        let t = <[f32; QUAD] as Quad>::transpose([q[0], q[1], q[2], q[3]]);
        for i in 0..4 {
            for j in 0..4 {
                assert_eq!(t[j][i * 4..i * 4 + 4], q[i][j * 4..j * 4 + 4]);
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_quads_match_plain_ones() {
        #[target_feature(enable = "avx2,fma")]
        unsafe fn avx2(x: &[[f32; QUAD]], k: &[f32]) -> (Vec<[f32; QUAD]>, [[f32; QUAD]; 4]) {
            let out = unsafe { symmetric::<x86::Avx2, 3>(|m| x[(12 + m) as usize].as_ptr(), k) };
            let t =
                x86::Avx2::transpose([0, 1, 2, 3].map(|i| unsafe { Quad::load(x[i].as_ptr()) }));
            unpack(&out, t)
        }
        #[target_feature(enable = "avx512f")]
        unsafe fn avx512(x: &[[f32; QUAD]], k: &[f32]) -> (Vec<[f32; QUAD]>, [[f32; QUAD]; 4]) {
            let out = unsafe { symmetric::<x86::Avx512, 3>(|m| x[(12 + m) as usize].as_ptr(), k) };
            let t =
                x86::Avx512::transpose([0, 1, 2, 3].map(|i| unsafe { Quad::load(x[i].as_ptr()) }));
            unpack(&out, t)
        }
        fn unpack<Q: Quad>(out: &[Q], t: [Q; 4]) -> (Vec<[f32; QUAD]>, [[f32; QUAD]; 4]) {
            let get = |q: &Q| {
                let mut v = [0.0f32; QUAD];
                unsafe { q.store(v.as_mut_ptr()) };
                v
            };
            (out.iter().map(get).collect(), t.each_ref().map(get))
        }
        let x = quads(40);
        let k = [0.31f32, 0.21, 0.09, 0.04, 0.007, 0.0003];
        let plain = unsafe { symmetric::<[f32; QUAD], 3>(|m| x[(12 + m) as usize].as_ptr(), &k) };
        let plain_t = <[f32; QUAD] as Quad>::transpose([x[0], x[1], x[2], x[3]]);
        let bits = |v: &[[f32; QUAD]]| v.iter().flatten().map(|f| f.to_bits()).collect::<Vec<_>>();
        if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
            let (o, t) = unsafe { avx2(&x, &k) };
            assert_eq!(bits(&o), bits(&plain));
            assert_eq!(bits(&t), bits(&plain_t));
        }
        if std::is_x86_feature_detected!("avx512f") {
            let (o, t) = unsafe { avx512(&x, &k) };
            assert_eq!(bits(&o), bits(&plain));
            assert_eq!(bits(&t), bits(&plain_t));
        }
    }
}
