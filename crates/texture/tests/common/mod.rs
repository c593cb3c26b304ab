//! Deterministic test images.
#![allow(dead_code)]

pub use texture::testing::Rng;

/// A stained-glass-like RGBA8 test image: flat panes of random colour (some very dark, some
/// saturated), black lead lines, a few translucent panes, and a little noise: hard edges and
/// dark regions, where a blur's errors show most in sRGB.
pub fn design(w: usize, h: usize, seed: u64) -> Vec<u8> {
    let mut rng = Rng(seed | 1);
    let cell = 7 + (seed % 5) as usize;
    let panes: Vec<[u8; 4]> = (0..64)
        .map(|i| match i % 4 {
            0 => [rng.byte() / 16, rng.byte() / 16, rng.byte() / 16, 255],
            1 => [rng.byte(), rng.byte(), rng.byte(), 255],
            2 => [
                rng.byte(),
                rng.byte() / 4,
                rng.byte() / 8,
                128 + rng.byte() / 2,
            ],
            _ => [255, 250, rng.byte(), 255],
        })
        .collect();
    let mut out = vec![0u8; w * h * 4];
    for y in 0..h {
        for x in 0..w {
            let lead = x % cell == 0 || y % (cell + 2) == 0;
            let p = if lead {
                [8, 8, 10, 255]
            } else {
                panes[((x / cell) * 7 + (y / (cell + 2)) * 3) % 64]
            };
            let noise = rng.byte() % 3;
            let o = &mut out[(y * w + x) * 4..][..4];
            for c in 0..3 {
                o[c] = p[c].saturating_add(noise);
            }
            o[3] = p[3];
        }
    }
    out
}

pub fn rgba_image(w: usize, h: usize, bytes: Vec<u8>) -> image::DynamicImage {
    image::DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w as u32, h as u32, bytes).unwrap())
}

/// Our sRGB8 blur's error against the f64 linear-light reference of the same image.
pub fn blur_error(
    w: usize,
    h: usize,
    sigma: f32,
    method: texture::blur::BlurMethod,
    bytes: &[u8],
) -> texture::ErrorLsb {
    let ours = texture::blur_srgb8(bytes, w as u32, h as u32, sigma, method).unwrap();
    let linear = texture::blur::srgb8_to_premultiplied_f64(bytes);
    let reference = texture::reference_blur(&linear, w, h, sigma as f64);
    texture::error_lsb(&ours, &reference)
}

/// sRGB RGBA8 → premultiplied linear f32.
pub fn premul_f32(bytes: &[u8]) -> Vec<[f32; 4]> {
    texture::blur::srgb8_to_premultiplied_f64(bytes)
        .iter()
        .map(|t| t.map(|v| v as f32))
        .collect()
}

/// Per-channel sum in f64, for mass checks.
pub fn sum(v: &[[f32; 4]]) -> [f64; 4] {
    let mut s = [0.0f64; 4];
    for t in v {
        for c in 0..4 {
            s[c] += t[c] as f64;
        }
    }
    s
}
