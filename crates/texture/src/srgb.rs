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

/// Correctly rounded linear → 8-bit sRGB encoder (fetch once with [`encoder`], reuse in loops).
pub struct Encoder {
    /// Linear value at which the rounded code steps from k to k + 1 (code k + 0.5 decoded).
    thresholds32: [f32; 255],
    thresholds64: [f64; 255],
    /// The code of each bucket's lower end, so a lookup starts at most a step or two short.
    start: [u8; BUCKETS + 1],
}

pub fn encoder() -> &'static Encoder {
    static E: OnceLock<Box<Encoder>> = OnceLock::new();
    E.get_or_init(|| {
        let mut e = Box::new(Encoder {
            thresholds32: [0.0; 255],
            thresholds64: [0.0; 255],
            start: [0; BUCKETS + 1],
        });
        for k in 0..255 {
            let t = srgb_to_linear((k as f64 + 0.5) / 255.0);
            e.thresholds64[k] = t;
            e.thresholds32[k] = t as f32;
        }
        for b in 0..=BUCKETS {
            let l = b as f64 / BUCKETS as f64;
            e.start[b] = e.thresholds64.iter().take_while(|&&t| t <= l).count() as u8;
        }
        e
    })
}

impl Encoder {
    /// Correctly rounded 8-bit sRGB code of a linear value (clamped to [0, 1]; NaN gives 0).
    #[inline]
    pub fn encode(&self, l: f32) -> u8 {
        // `!(l > 0)` also catches NaN.
        if !(l > 0.0) {
            return 0;
        }
        if l >= 1.0 {
            return 255;
        }
        let mut k = self.start[(l * BUCKETS as f32) as usize] as usize;
        while k < 255 && l >= self.thresholds32[k] {
            k += 1;
        }
        k as u8
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
    if !(l > 0.0) {
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
    if !(v > 0.0) {
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
    fn sixteen_bit_table_agrees_with_eight_bit_one() {
        for i in 0..=255usize {
            assert_eq!(decode16()[i * 257], decode8()[i]);
        }
    }
}
