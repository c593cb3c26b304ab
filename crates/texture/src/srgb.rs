//! sRGB transfer functions: exact decode tables for 8- and 16-bit input and a correctly rounded
//! 8-bit encoder.

use std::sync::OnceLock;

/// The sRGB decode (IEC 61966-2-1), in f64.
pub fn srgb_to_linear(v: f64) -> f64 {
    if v <= 0.04045 {
        v / 12.92
    } else {
        ((v + 0.055) / 1.055).powf(2.4)
    }
}

/// The sRGB encode, unrounded, in f64 on [0, 1] (input clamped).
pub fn linear_to_srgb(l: f64) -> f64 {
    let l = l.clamp(0.0, 1.0);
    if l <= 0.003_130_8 {
        l * 12.92
    } else {
        1.055 * l.powf(1.0 / 2.4) - 0.055
    }
}

/// The unrounded 8-bit sRGB code of a linear value: what the error unit "LSB" is measured on.
pub fn linear_to_srgb_lsb(l: f64) -> f64 {
    linear_to_srgb(l) * 255.0
}

/// The slope of [`linear_to_srgb_lsb`] at `l` in [0, 1]: 12.92 × 255 on the linear toe, then
/// the power curve's, which starts just under it and falls from there, so the slope never
/// rises as `l` grows.
pub(crate) fn linear_to_srgb_lsb_slope(l: f64) -> f64 {
    255.0
        * if l <= 0.003_130_8 {
            12.92
        } else {
            1.055 / 2.4 * l.powf(1.0 / 2.4 - 1.0)
        }
}

/// Linear value of every 8-bit sRGB code.
pub fn decode8() -> &'static [f32; 256] {
    static T: OnceLock<Box<[f32; 256]>> = OnceLock::new();
    T.get_or_init(|| {
        let mut t = Box::new([0.0f32; 256]);
        for (i, v) in t.iter_mut().enumerate() {
            *v = srgb_to_linear(i as f64 / 255.0) as f32;
        }
        t
    })
}

/// Linear value of every 16-bit sRGB code.
pub fn decode16() -> &'static [f32] {
    static T: OnceLock<Vec<f32>> = OnceLock::new();
    T.get_or_init(|| {
        (0..65536u32)
            .map(|i| srgb_to_linear(i as f64 / 65535.0) as f32)
            .collect()
    })
}

const BUCKETS: usize = 4096;

/// Buckets of the f32 encoder are slices of the float's bit pattern: 2^MANTISSA_BITS per
/// power of two from 2^MIN_EXP up to 1. Relative bucket width 2^-7 is below the smallest
/// relative gap between rounding thresholds (0.9%, at the top of the curve), so a bucket holds
/// at most one threshold and one compare finishes the lookup; the table build checks this.
const MANTISSA_BITS: u32 = 7;
const MIN_EXP: i32 = -13;
const FAST_BUCKETS: usize = ((-MIN_EXP) as usize) << MANTISSA_BITS;
/// Bit patterns per bucket: 2^BUCKET_BITS.
const BUCKET_BITS: u32 = 23 - MANTISSA_BITS;
const LO: f32 = 1.0 / 8192.0; // 2^MIN_EXP

/// Correctly rounded linear → 8-bit sRGB encoder (fetch once with [`encoder`], reuse in loops).
pub struct Encoder {
    /// Linear value at which the rounded code steps from k to k + 1 (code k + 0.5 decoded).
    thresholds64: [f64; 255],
    /// The code of each f64 bucket's lower end, so a lookup starts at most a step or two short.
    start: [u8; BUCKETS + 1],
    /// Per bit-pattern bucket: the code at its lower end (bits 17..) and the offset of the one
    /// threshold inside it from the bucket's first bit pattern (bits 0..17; 2^16 when none, which
    /// no offset reaches). One table, so the vector path needs one gather.
    table: Vec<i32>,
    /// The vector path's estimate of the code (below).
    estimate: Estimate,
}

/// An estimate `g` of `255 · encode(l) + 0.5`, the value whose floor is the rounded code,
/// within [`ESTIMATE_SLACK`] of it: `l = m · 2^e` with `m` in [0.75, 1.5), so
/// `g = A_e · m^(5/12) - 13.525` with `A_e = 269.025 · 2^(5e/12)` from a table and `m^(5/12)` a
/// polynomial in `m - 1.125`; `g = 3294.6 · l + 0.5` on the linear segment. Where `g` is
/// farther than the slack from an integer its floor is the code; elsewhere the vector encoder
/// looks the code up exactly.
#[derive(Clone, Copy, Debug)]
struct Estimate {
    /// Coefficients, highest power first.
    poly: [f32; ESTIMATE_DEGREE + 1],
    /// `A_e` for `e = -13..=0` at index `e + 13`.
    scale: [f32; 16],
}

const ESTIMATE_DEGREE: usize = 5;

/// Bound on the estimate's error in codes, with a wide margin over the largest error measured
/// over every float from 2^MIN_EXP to 1 (the exhaustive test checks it).
const ESTIMATE_SLACK: f32 = 2e-3;

impl Estimate {
    /// Interpolates `m^(5/12)` at the Chebyshev nodes of [0.75, 1.5], in f64.
    fn new() -> Self {
        const N: usize = ESTIMATE_DEGREE + 1;
        let (mid, half) = (1.125f64, 0.375f64);
        let nodes: [f64; N] = std::array::from_fn(|j| {
            half * (std::f64::consts::PI * (j as f64 + 0.5) / N as f64).cos()
        });
        // Newton's divided differences, then expanded to powers of (m - mid).
        let mut dd: [f64; N] = std::array::from_fn(|j| (mid + nodes[j]).powf(5.0 / 12.0));
        for level in 1..N {
            for j in (level..N).rev() {
                dd[j] = (dd[j] - dd[j - 1]) / (nodes[j] - nodes[j - level]);
            }
        }
        let mut coef = [0.0f64; N];
        for j in (0..N).rev() {
            // coef = coef · (x - nodes[j]) + dd[j]
            for i in (1..N).rev() {
                coef[i] = coef[i - 1] - nodes[j] * coef[i];
            }
            coef[0] = dd[j] - nodes[j] * coef[0];
        }
        let mut poly = [0.0f32; N];
        for (p, c) in poly.iter_mut().zip(coef.iter().rev()) {
            *p = *c as f32;
        }
        let mut scale = [0.0f32; 16];
        for (i, v) in scale.iter_mut().enumerate().take(14) {
            *v = (269.025 * (5.0 * (i as f64 - 13.0) / 12.0).exp2()) as f32;
        }
        Estimate { poly, scale }
    }
}

/// The shared encoder tables.
pub fn encoder() -> &'static Encoder {
    static E: OnceLock<Box<Encoder>> = OnceLock::new();
    E.get_or_init(|| {
        let mut e = Box::new(Encoder {
            thresholds64: [0.0; 255],
            start: [0; BUCKETS + 1],
            table: vec![0; FAST_BUCKETS + 1],
            estimate: Estimate::new(),
        });
        for k in 0..255 {
            e.thresholds64[k] = srgb_to_linear((k as f64 + 0.5) / 255.0);
        }
        for b in 0..=BUCKETS {
            let l = b as f64 / BUCKETS as f64;
            e.start[b] = e.thresholds64.iter().take_while(|&&t| t <= l).count() as u8;
        }
        let thresholds32: Vec<f32> = e.thresholds64.iter().map(|&t| t as f32).collect();
        assert!(
            thresholds32[0] > (MIN_EXP as f32).exp2(),
            "first threshold below the table"
        );
        let lo_bits = (MIN_EXP as f32).exp2().to_bits();
        for b in 0..=FAST_BUCKETS {
            let lo = f32::from_bits(lo_bits + ((b as u32) << (23 - MANTISSA_BITS)));
            let hi = f32::from_bits(lo_bits + ((b as u32 + 1) << (23 - MANTISSA_BITS)));
            let below = thresholds32.iter().take_while(|&&t| t <= lo).count();
            let inside: Vec<f32> = thresholds32
                .iter()
                .copied()
                .filter(|&t| t > lo && t < hi)
                .collect();
            assert!(
                inside.len() <= 1,
                "bucket {b} holds {} thresholds",
                inside.len()
            );
            let offset = inside
                .first()
                .map_or(1 << BUCKET_BITS, |t| t.to_bits() - lo.to_bits());
            e.table[b] = ((below as i32) << 17) | offset as i32;
        }
        e
    })
}

impl Encoder {
    /// Correctly rounded 8-bit sRGB code of a linear value (clamped to [0, 1]; NaN gives 0).
    #[inline]
    pub fn encode(&self, l: f32) -> u8 {
        // Written so NaN takes the second branch.
        let l = if l > LO { l.min(1.0) } else { LO };
        let bits = l.to_bits() - LO.to_bits();
        let entry = self.table[(bits >> BUCKET_BITS) as usize];
        let offset = (bits & ((1 << BUCKET_BITS) - 1)) as i32;
        ((entry >> 17) + i32::from(offset >= (entry & 0x1_FFFF))) as u8
    }
}

impl Encoder {
    /// Encodes RGBA texels (premultiplied or straight, linear) to RGBA8: sRGB colour, unorm
    /// alpha. Same results as [`Encoder::encode`] and [`unorm8`] texel by texel.
    pub fn encode_rgba(&self, src: &[[f32; 4]], out: &mut [u8]) {
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx512f") {
            // SAFETY: the CPU supports AVX-512F, checked just above.
            unsafe { self.encode_rgba_avx512(src, out) };
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if std::is_x86_feature_detected!("avx2") {
            // SAFETY: the CPU supports AVX2, checked just above.
            unsafe { self.encode_rgba_avx2(src, out) };
            return;
        }
        self.encode_rgba_plain(src, out)
    }

    fn encode_rgba_plain(&self, src: &[[f32; 4]], out: &mut [u8]) {
        for (o, t) in out.chunks_exact_mut(4).zip(src) {
            o[0] = self.encode(t[0]);
            o[1] = self.encode(t[1]);
            o[2] = self.encode(t[2]);
            o[3] = unorm8(t[3]);
        }
    }

    /// Two texels at a time: the bucket lookup of [`Encoder::encode`] with gathers. Every
    /// step is an exact comparison or integer operation, so the codes are the scalar ones.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn encode_rgba_avx2(&self, src: &[[f32; 4]], out: &mut [u8]) {
        use std::arch::x86_64::*;
        let pairs = src.len().min(out.len() / 4) / 2;
        let lo = _mm256_set1_ps(LO);
        let lo_bits = _mm256_set1_epi32(LO.to_bits() as i32);
        let one = _mm256_set1_ps(1.0);
        let offset_mask = _mm256_set1_epi32((1 << BUCKET_BITS) - 1);
        let threshold_mask = _mm256_set1_epi32(0x1_FFFF);
        let ones = _mm256_set1_epi32(1);
        for i in 0..pairs {
            let flat = src[2 * i..2 * i + 2].as_flattened();
            // SAFETY: `flat` holds exactly 8 floats; unaligned load.
            let v = unsafe { _mm256_loadu_ps(flat.as_ptr()) };
            let above = _mm256_cmp_ps::<_CMP_GT_OQ>(v, lo);
            let l = _mm256_blendv_ps(lo, _mm256_min_ps(v, one), above);
            let bits = _mm256_sub_epi32(_mm256_castps_si256(l), lo_bits);
            let idx = _mm256_srli_epi32::<{ BUCKET_BITS as i32 }>(bits);
            // SAFETY: `l` is clamped to [2^MIN_EXP, 1], so every index is in 0..=FAST_BUCKETS,
            // the table's length minus one.
            let entry = unsafe { _mm256_i32gather_epi32::<4>(self.table.as_ptr(), idx) };
            let offset = _mm256_and_si256(bits, offset_mask);
            let below = _mm256_cmpgt_epi32(_mm256_and_si256(entry, threshold_mask), offset);
            // base + 1, less one where the offset is below the threshold (mask is -1 there).
            let code = _mm256_add_epi32(
                _mm256_add_epi32(_mm256_srli_epi32::<17>(entry), ones),
                below,
            );
            let packed = _mm256_packus_epi16(_mm256_packus_epi32(code, code), code);
            let lo4 = _mm_cvtsi128_si32(_mm256_castsi256_si128(packed)) as u32;
            let hi4 = _mm_cvtsi128_si32(_mm256_extracti128_si256::<1>(packed)) as u32;
            let o = &mut out[8 * i..8 * i + 8];
            o[..4].copy_from_slice(&lo4.to_le_bytes());
            o[4..].copy_from_slice(&hi4.to_le_bytes());
            o[3] = unorm8(flat[3]);
            o[7] = unorm8(flat[7]);
        }
        self.encode_rgba_plain(&src[2 * pairs..], &mut out[8 * pairs..]);
    }

    /// Four texels at a time. The colour lanes take the floor of the [`Estimate`], and only a
    /// vector with a lane too close to a rounding threshold for that to be sure gathers from the
    /// table as [`Encoder::encode_rgba_avx2`] does, for those lanes. The alpha lanes go through
    /// [`unorm8`]'s clamp, multiply and truncation. So the codes are the scalar ones.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f")]
    unsafe fn encode_rgba_avx512(&self, src: &[[f32; 4]], out: &mut [u8]) {
        use std::arch::x86_64::*;
        let quads = src.len().min(out.len() / 4) / 4;
        let colour: __mmask16 = 0x7777;
        let lo = _mm512_set1_ps(LO);
        let lo_bits = _mm512_set1_epi32(LO.to_bits() as i32);
        let zero = _mm512_setzero_ps();
        let one = _mm512_set1_ps(1.0);
        let offset_mask = _mm512_set1_epi32((1 << BUCKET_BITS) - 1);
        let threshold_mask = _mm512_set1_epi32(0x1_FFFF);
        let ones = _mm512_set1_epi32(1);
        let est = &self.estimate;
        let poly = est.poly.map(|c| _mm512_set1_ps(c));
        // SAFETY: `scale` holds 16 floats.
        let scale = unsafe { _mm512_loadu_ps(est.scale.as_ptr()) };
        let mid = _mm512_set1_ps(1.125);
        let knee = _mm512_set1_ps(0.003_130_8);
        let slope = _mm512_set1_ps(12.92 * 255.0);
        let (half, offset) = (_mm512_set1_ps(0.5), _mm512_set1_ps(-13.525));
        let (slack, far) = (
            _mm512_set1_ps(ESTIMATE_SLACK),
            _mm512_set1_ps(1.0 - ESTIMATE_SLACK),
        );
        let exp_bias = _mm512_set1_epi32(13);
        for i in 0..quads {
            // SAFETY: texels 4i..4i + 4 are in `src`; unaligned load of 16 floats.
            let v = unsafe { _mm512_loadu_ps(src.as_ptr().add(4 * i).cast()) };
            let above = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(v, lo);
            let l = _mm512_mask_blend_ps(above, lo, _mm512_min_ps(v, one));
            let m = _mm512_getmant_ps::<_MM_MANT_NORM_P75_1P5, _MM_MANT_SIGN_ZERO>(l);
            // l = m · 2^e exactly, so the exponent is the difference of the bit patterns.
            let e = _mm512_srai_epi32::<23>(_mm512_sub_epi32(
                _mm512_castps_si512(l),
                _mm512_castps_si512(m),
            ));
            let a = _mm512_permutexvar_ps(_mm512_add_epi32(e, exp_bias), scale);
            let x = _mm512_sub_ps(m, mid);
            let mut p = poly[0];
            for &c in &poly[1..] {
                p = _mm512_fmadd_ps(p, x, c);
            }
            let g = _mm512_fmadd_ps(a, p, offset);
            let linear = _mm512_cmp_ps_mask::<_CMP_LE_OQ>(l, knee);
            let g = _mm512_mask_blend_ps(linear, g, _mm512_fmadd_ps(l, slope, half));
            let floor = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(g);
            let frac = _mm512_sub_ps(g, floor);
            let unsure = (_mm512_cmp_ps_mask::<_CMP_LT_OQ>(frac, slack)
                | _mm512_cmp_ps_mask::<_CMP_GT_OQ>(frac, far))
                & colour;
            let mut code = _mm512_cvttps_epi32(floor);
            if unsure != 0 {
                let bits = _mm512_sub_epi32(_mm512_castps_si512(l), lo_bits);
                let idx = _mm512_srli_epi32::<{ BUCKET_BITS }>(bits);
                // SAFETY: `l` is clamped to [2^MIN_EXP, 1], so every index is in
                // 0..=FAST_BUCKETS, the table's length minus one.
                let entry = unsafe {
                    _mm512_mask_i32gather_epi32::<4>(
                        _mm512_setzero_si512(),
                        unsure,
                        idx,
                        self.table.as_ptr(),
                    )
                };
                let offset = _mm512_and_si512(bits, offset_mask);
                let up = _mm512_cmpge_epi32_mask(offset, _mm512_and_si512(entry, threshold_mask));
                let base = _mm512_srli_epi32::<17>(entry);
                let exact = _mm512_mask_add_epi32(base, up, base, ones);
                code = _mm512_mask_blend_epi32(unsure, code, exact);
            }
            // vmaxps returns its second operand when the first is NaN: NaN alpha becomes 0.
            let a = _mm512_min_ps(_mm512_max_ps(v, zero), one);
            let a = _mm512_add_ps(_mm512_mul_ps(a, _mm512_set1_ps(255.0)), half);
            let code = _mm512_mask_blend_epi32(colour, _mm512_cvttps_epi32(a), code);
            // SAFETY: bytes 16i..16i + 16 are in `out`.
            unsafe {
                _mm_storeu_si128(
                    out.as_mut_ptr().add(16 * i).cast(),
                    _mm512_cvtepi32_epi8(code),
                )
            };
        }
        self.encode_rgba_plain(&src[4 * quads..], &mut out[16 * quads..]);
    }
}

/// sRGB RGBA8 with straight alpha to premultiplied linear RGBA: colour from [`decode8`] times
/// alpha, alpha `a / 255`. `out` gets one texel per four bytes.
pub fn decode_premultiplied(bytes: &[u8], out: &mut [[f32; 4]]) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512vbmi") && std::is_x86_feature_detected!("avx512bw") {
        // SAFETY: the CPU supports AVX-512 VBMI and BW (and so F), checked just above.
        unsafe { decode_premultiplied_vbmi(bytes, out) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512f") {
        // SAFETY: the CPU supports AVX-512F, checked just above.
        unsafe { decode_premultiplied_avx512(bytes, out) };
        return;
    }
    decode_premultiplied_plain(bytes, out)
}

fn decode_premultiplied_plain(bytes: &[u8], out: &mut [[f32; 4]]) {
    let lut = decode8();
    for (t, b) in out.iter_mut().zip(bytes.chunks_exact(4)) {
        let a = b[3] as f32 * (1.0 / 255.0);
        *t = [
            lut[b[0] as usize] * a,
            lut[b[1] as usize] * a,
            lut[b[2] as usize] * a,
            a,
        ];
    }
}

/// [`decode8`] as four planes of bytes, lowest byte first: byte-wide table lookups then give
/// every float of 64 codes in a few instructions, where a gather takes one load per value.
#[repr(align(64))]
struct Planes([[u8; 256]; 4]);

fn decode8_planes() -> &'static Planes {
    static P: OnceLock<Box<Planes>> = OnceLock::new();
    P.get_or_init(|| {
        let mut p = Box::new(Planes([[0; 256]; 4]));
        for (i, v) in decode8().iter().enumerate() {
            for (k, b) in v.to_bits().to_le_bytes().into_iter().enumerate() {
                p.0[k][i] = b;
            }
        }
        p
    })
}

/// Sixteen texels at a time without gathers: the bytes are looked up in the four byte planes
/// of [`decode8`] (two 128-entry lookups each) and interleaved back into floats. Interleaving
/// works within 128-bit lanes, so the texels are first transposed four by four, which makes
/// each result vector four consecutive texels. The products are the plain loop's.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
unsafe fn decode_premultiplied_vbmi(bytes: &[u8], out: &mut [[f32; 4]]) {
    use std::arch::x86_64::*;
    let t = unsafe { plane_tables() };
    let transpose = _mm512_setr_epi32(0, 4, 8, 12, 1, 5, 9, 13, 2, 6, 10, 14, 3, 7, 11, 15);
    let groups = out.len().min(bytes.len() / 4) / 16;
    for g in 0..groups {
        // SAFETY: bytes 64g..64g + 64 are in `bytes`.
        let v = unsafe { _mm512_loadu_si512(bytes.as_ptr().add(64 * g).cast()) };
        // Texel 4k + l moves to dword 4l + k, so result k is texels 4k..4k + 4.
        let p = _mm512_permutexvar_epi32(transpose, v);
        // SAFETY: AVX-512 F, BW and VBMI are enabled here.
        let r = unsafe { decode_lanes(p, &t) };
        for (k, v) in r.into_iter().enumerate() {
            // SAFETY: texels 16g + 4k..16g + 4k + 4 are in `out`.
            unsafe { _mm512_storeu_ps(out.as_mut_ptr().add(16 * g + 4 * k).cast(), v) };
        }
    }
    decode_premultiplied_plain(&bytes[64 * groups..], &mut out[16 * groups..]);
}

/// [`decode_premultiplied`] of up to four rows into columns: `out[i]` holds texel `i` of each
/// row in turn (16 floats), a missing row as zeros. `row` is scratch.
pub(crate) fn decode_premultiplied_columns(
    rows: [Option<&[u8]>; 4],
    out: &mut [[f32; 16]],
    row: &mut Vec<[f32; 4]>,
) {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx512vbmi") && std::is_x86_feature_detected!("avx512bw") {
        // SAFETY: the CPU supports AVX-512 VBMI and BW (and so F), checked just above.
        unsafe { decode_columns_vbmi(rows, out) };
        return;
    }
    row.resize(out.len(), [0.0; 4]);
    for (l, bytes) in rows.into_iter().enumerate() {
        match bytes {
            Some(b) => decode_premultiplied(b, row),
            None => row.fill([0.0; 4]),
        }
        for (o, t) in out.iter_mut().zip(row.iter()) {
            o[4 * l..4 * l + 4].copy_from_slice(t);
        }
    }
}

/// Sixteen texels of one row through the byte planes: the four quads of `v`'s dwords
/// `4l + k` (`k` = 0..4) for each 128-bit lane `l`, premultiplied.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn decode_lanes(
    v: std::arch::x86_64::__m512i,
    t: &[[std::arch::x86_64::__m512i; 4]; 4],
) -> [std::arch::x86_64::__m512; 4] {
    use std::arch::x86_64::*;
    // SAFETY (the whole body): called only from functions that enable AVX-512 F, BW and VBMI.
    unsafe {
        let high = _mm512_movepi8_mask(v);
        let plane = |k: usize| {
            let lo = _mm512_permutex2var_epi8(t[k][0], v, t[k][1]);
            let hi = _mm512_permutex2var_epi8(t[k][2], v, t[k][3]);
            _mm512_mask_blend_epi8(high, lo, hi)
        };
        let (p0, p1, p2, p3) = (plane(0), plane(1), plane(2), plane(3));
        let (lo01, hi01) = (_mm512_unpacklo_epi8(p0, p1), _mm512_unpackhi_epi8(p0, p1));
        let (lo23, hi23) = (_mm512_unpacklo_epi8(p2, p3), _mm512_unpackhi_epi8(p2, p3));
        // Result k, lane l: dword 4l + k.
        let r = [
            _mm512_unpacklo_epi16(lo01, lo23),
            _mm512_unpackhi_epi16(lo01, lo23),
            _mm512_unpacklo_epi16(hi01, hi23),
            _mm512_unpackhi_epi16(hi01, hi23),
        ];
        let scale = _mm512_set1_ps(1.0 / 255.0);
        let a = _mm512_mul_ps(_mm512_cvtepi32_ps(_mm512_srli_epi32::<24>(v)), scale);
        let a = [
            _mm512_permute_ps::<0x00>(a),
            _mm512_permute_ps::<0x55>(a),
            _mm512_permute_ps::<0xAA>(a),
            _mm512_permute_ps::<0xFF>(a),
        ];
        let alpha: __mmask16 = 0x8888;
        std::array::from_fn(|k| {
            let c = _mm512_castsi512_ps(r[k]);
            _mm512_mask_blend_ps(alpha, _mm512_mul_ps(c, a[k]), a[k])
        })
    }
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn plane_tables() -> [[std::arch::x86_64::__m512i; 4]; 4] {
    use std::arch::x86_64::*;
    let planes = decode8_planes();
    // SAFETY: each plane is 256 bytes, 64-byte aligned; AVX-512F is enabled by every caller.
    std::array::from_fn(|k| {
        std::array::from_fn(|h| unsafe { _mm512_load_si512(planes.0[k][h * 64..].as_ptr().cast()) })
    })
}

/// Four texels of each of four rows at a time: one row per 128-bit lane, so the byte planes'
/// lookups come out as columns directly.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512bw,avx512vbmi")]
unsafe fn decode_columns_vbmi(rows: [Option<&[u8]>; 4], out: &mut [[f32; 16]]) {
    use std::arch::x86_64::*;
    let t = unsafe { plane_tables() };
    let n = out.len();
    assert!(rows.iter().flatten().all(|r| r.len() >= n * 4));
    let load = |l: usize, g: usize| match rows[l] {
        // SAFETY: bytes 16g..16g + 16 of the row exist, checked above.
        Some(r) => unsafe { _mm_loadu_si128(r.as_ptr().add(16 * g).cast()) },
        None => _mm_setzero_si128(),
    };
    for g in 0..n / 4 {
        let v = _mm512_castsi128_si512(load(0, g));
        let v = _mm512_inserti32x4::<1>(v, load(1, g));
        let v = _mm512_inserti32x4::<2>(v, load(2, g));
        let v = _mm512_inserti32x4::<3>(v, load(3, g));
        // SAFETY: AVX-512 F, BW and VBMI are enabled here.
        let cols = unsafe { decode_lanes(v, &t) };
        for (k, c) in cols.into_iter().enumerate() {
            // SAFETY: quad 4g + k of `out` exists.
            unsafe { _mm512_storeu_ps(out[4 * g + k].as_mut_ptr(), c) };
        }
    }
    // The last texels one at a time.
    let lut = decode8();
    for (i, o) in out.iter_mut().enumerate().skip(n / 4 * 4) {
        for (l, r) in rows.iter().enumerate() {
            let px = match r {
                Some(r) => {
                    let b = &r[4 * i..4 * i + 4];
                    let a = b[3] as f32 * (1.0 / 255.0);
                    [
                        lut[b[0] as usize] * a,
                        lut[b[1] as usize] * a,
                        lut[b[2] as usize] * a,
                        a,
                    ]
                }
                None => [0.0; 4],
            };
            o[4 * l..4 * l + 4].copy_from_slice(&px);
        }
    }
}

/// Four texels at a time, the same products as the plain loop.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
unsafe fn decode_premultiplied_avx512(bytes: &[u8], out: &mut [[f32; 4]]) {
    use std::arch::x86_64::*;
    let lut = decode8();
    let quads = out.len().min(bytes.len() / 4) / 4;
    let alpha: __mmask16 = 0x8888;
    let scale = _mm512_set1_ps(1.0 / 255.0);
    for i in 0..quads {
        // SAFETY: bytes 16i..16i + 16 are in `bytes`.
        let b = unsafe { _mm_loadu_si128(bytes.as_ptr().add(16 * i).cast()) };
        let idx = _mm512_cvtepu8_epi32(b);
        // SAFETY: every index is a byte, and the table has 256 entries; alpha lanes not loaded.
        let colour = unsafe {
            _mm512_mask_i32gather_ps::<4>(_mm512_setzero_ps(), !alpha, idx, lut.as_ptr())
        };
        // Each texel's alpha in all four of its lanes.
        let a = _mm512_permute_ps::<0xFF>(_mm512_mul_ps(_mm512_cvtepi32_ps(idx), scale));
        let v = _mm512_mask_blend_ps(alpha, _mm512_mul_ps(colour, a), a);
        // SAFETY: texels 4i..4i + 4 are in `out`.
        unsafe { _mm512_storeu_ps(out.as_mut_ptr().add(4 * i).cast(), v) };
    }
    decode_premultiplied_plain(&bytes[16 * quads..], &mut out[4 * quads..]);
}

/// Correctly rounded 8-bit sRGB code of a linear value (clamped to [0, 1]; NaN gives 0).
#[inline]
pub fn encode8(l: f32) -> u8 {
    encoder().encode(l)
}

/// [`encode8`] for f64 input (reference paths).
pub fn encode8_f64(l: f64) -> u8 {
    let e = encoder();
    if l.is_nan() || l <= 0.0 {
        return 0;
    }
    if l >= 1.0 {
        return 255;
    }
    let mut k = e.start[(l * BUCKETS as f64) as usize] as usize;
    while k < 255 && l >= e.thresholds64[k] {
        k += 1;
    }
    k as u8
}

/// Rounds a linear value in [0, 1] to an 8-bit code without a transfer function (alpha,
/// linear textures). NaN gives 0.
#[inline]
pub fn unorm8(v: f32) -> u8 {
    if v.is_nan() || v <= 0.0 {
        return 0;
    }
    (v.min(1.0) * 255.0 + 0.5) as u8
}

#[cfg(test)]
mod tests {
    use super::*;
    use rayon::prelude::*;

    #[test]
    fn encode_inverts_decode_and_rounds_like_f64() {
        for i in 0..=255u8 {
            assert_eq!(encode8(decode8()[i as usize]), i);
        }
        let mut worst = 0.0f64;
        for i in 0..=200_000u32 {
            let l = i as f64 / 200_000.0;
            let ours = encode8(l as f32) as f64;
            let exact = linear_to_srgb_lsb(l as f32 as f64);
            worst = worst.max((ours - exact).abs());
            assert_eq!(
                encode8_f64(l),
                linear_to_srgb_lsb(l).round() as u8,
                "at {l}"
            );
        }
        assert!(worst <= 0.5 + 1e-4, "worst rounding error {worst}");
        assert_eq!(encode8(f32::NAN), 0);
        assert_eq!(encode8(-1.0), 0);
        assert_eq!(encode8(7.0), 255);
    }

    #[test]
    fn vector_encoder_matches_scalar_one() {
        let e = encoder();
        let mut vals: Vec<f32> = (0..100_000).map(|i| i as f32 / 99_000.0 - 0.005).collect();
        vals.extend(e.thresholds64.iter().flat_map(|&t| {
            let t = t as f32;
            [
                t,
                f32::from_bits(t.to_bits() - 1),
                f32::from_bits(t.to_bits() + 1),
            ]
        }));
        vals.extend([
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            -0.0,
            1e-30,
            1.0,
            2.0,
        ]);
        let texels: Vec<[f32; 4]> = vals
            .chunks(4)
            .filter(|c| c.len() == 4)
            .map(|c| [c[0], c[1], c[2], c[3]])
            .collect();
        let mut fast = vec![0u8; texels.len() * 4];
        let mut plain = vec![0u8; texels.len() * 4];
        e.encode_rgba(&texels, &mut fast);
        e.encode_rgba_plain(&texels, &mut plain);
        assert_eq!(fast, plain);
    }

    /// Every float from below 2^MIN_EXP to above 1 through the vector encoder against the scalar
    /// one: the estimate's slack must hold everywhere, and this is where it would not.
    #[test]
    fn vector_encoder_matches_scalar_one_on_every_float_in_range() {
        let e = encoder();
        let first = LO.to_bits() - 4096;
        let last = 1.0f32.to_bits() + 4096;
        let chunk = 1 << 20;
        let bad = (first..last)
            .step_by(chunk)
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|start| {
                let end = (start + chunk as u32).min(last);
                let texels: Vec<[f32; 4]> = (start..end)
                    .step_by(3)
                    .map(|b| {
                        [
                            f32::from_bits(b),
                            f32::from_bits(b + 1),
                            f32::from_bits(b + 2),
                            0.5,
                        ]
                    })
                    .collect();
                let mut fast = vec![0u8; texels.len() * 4];
                e.encode_rgba(&texels, &mut fast);
                texels
                    .iter()
                    .zip(fast.chunks_exact(4))
                    .flat_map(|(t, f)| (0..3).map(move |c| (t[c], f[c])))
                    .filter(|&(v, f)| e.encode(v) != f)
                    .count()
            })
            .sum::<usize>();
        assert_eq!(bad, 0, "floats the vector encoder rounds differently");
    }

    #[test]
    fn vector_decoders_match_plain_one() {
        // Every code in every channel, with every alpha.
        let bytes: Vec<u8> = (0..256 * 256)
            .flat_map(|i| {
                let (c, a) = ((i % 256) as u8, (i / 256) as u8);
                [c, c.wrapping_mul(7), c.wrapping_add(101), a]
            })
            .collect();
        // Odd lengths leave tails for the plain loop.
        for n in [bytes.len() / 4, bytes.len() / 4 - 5, 3] {
            let mut plain = vec![[0.0f32; 4]; n];
            let mut fast = vec![[1.0f32; 4]; n];
            decode_premultiplied_plain(&bytes[..4 * n], &mut plain);
            decode_premultiplied(&bytes[..4 * n], &mut fast);
            assert!(
                plain
                    .iter()
                    .flatten()
                    .zip(fast.iter().flatten())
                    .all(|(a, b)| a.to_bits() == b.to_bits())
            );
            #[cfg(target_arch = "x86_64")]
            if std::is_x86_feature_detected!("avx512f") {
                // SAFETY: checked just above.
                unsafe { decode_premultiplied_avx512(&bytes[..4 * n], &mut fast) };
                assert!(
                    plain
                        .iter()
                        .flatten()
                        .zip(fast.iter().flatten())
                        .all(|(a, b)| a.to_bits() == b.to_bits())
                );
            }
        }
    }

    #[test]
    fn sixteen_bit_table_agrees_with_eight_bit_one() {
        for i in 0..=255usize {
            assert_eq!(decode16()[i * 257], decode8()[i]);
        }
    }
}
