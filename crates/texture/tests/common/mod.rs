//! Deterministic test images.
#![allow(dead_code)]

use texture::testing::Panes;

/// [`texture::testing::design`] with small panes that vary with the seed, so small images still
/// hold many edges.
pub fn design(w: usize, h: usize, seed: u64) -> Vec<u8> {
    let cell = 7 + (seed % 5) as usize;
    let panes = Panes {
        width: cell,
        height: cell + 2,
        lead: 1,
    };
    texture::testing::design(w, h, seed, panes)
}

pub fn rgba_image(w: usize, h: usize, bytes: Vec<u8>) -> image::DynamicImage {
    image::DynamicImage::ImageRgba8(image::RgbaImage::from_raw(w as u32, h as u32, bytes).unwrap())
}

/// Our sRGB8 blur's error against the f64 linear-light reference of the same image.
pub fn blur_error(
    w: usize,
    h: usize,
    sigma: impl Into<texture::Sigma2>,
    method: texture::blur::BlurMethod,
    bytes: &[u8],
) -> texture::ErrorLsb {
    let sigma = sigma.into();
    let ours = texture::blur_srgb8(bytes, w as u32, h as u32, sigma, method).unwrap();
    let linear = texture::blur::srgb8_to_premultiplied_f64(bytes);
    let (sx, sy) = (sigma.x as f64, sigma.y as f64);
    let reference = texture::reference_blur_xy(&linear, w, h, sx, sy);
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
