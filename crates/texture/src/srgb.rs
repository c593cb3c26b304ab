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
}

/// The shared encoder tables.
pub fn encoder() -> &'static Encoder {
    static E: OnceLock<Box<Encoder>> = OnceLock::new();
    E.get_or_init(|| {
        let mut e = Box::new(Encoder {
            thresholds64: [0.0; 255],
            start: [0; BUCKETS + 1],
            table: vec![0; FAST_BUCKETS + 1],
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

    #[test]
    fn sixteen_bit_table_agrees_with_eight_bit_one() {
        for i in 0..=255usize {
            assert_eq!(decode16()[i * 257], decode8()[i]);
        }
    }
}
