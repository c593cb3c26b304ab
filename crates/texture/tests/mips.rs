#![allow(clippy::needless_range_loop)]
mod common;

use common::{design, rgba_image};
use image::DynamicImage;
use texture::srgb::{linear_to_srgb_lsb, srgb_to_linear};
use texture::testing::Rng;
use texture::{
    ColourOptions, MipFilter, colour_mips, colour_mips_reference, level_count, level_size,
};

/// Max LSB error of a cooked chain against the f64 reference chain.
fn chain_error(img: &DynamicImage, opts: &ColourOptions) -> Vec<f64> {
    let ours = colour_mips(img, opts).unwrap();
    let reference = colour_mips_reference(img, opts).unwrap();
    assert_eq!(ours.levels.len(), reference.len());
    ours.levels
        .iter()
        .zip(&reference)
        .map(|(o, r)| {
            let mut max = 0.0f64;
            for (o, r) in o.chunks_exact(4).zip(r) {
                for c in 0..4 {
                    let exact = if c == 3 || !opts.srgb {
                        r[c] * 255.0
                    } else {
                        linear_to_srgb_lsb(r[c])
                    };
                    max = max.max((o[c] as f64 - exact).abs());
                }
            }
            max
        })
        .collect()
}

#[test]
fn chain_sizes_follow_the_pack_rule() {
    for (w, h) in [
        (1, 1),
        (1, 9),
        (9, 1),
        (5, 3),
        (64, 64),
        (100, 37),
        (4096, 1),
    ] {
        let img = rgba_image(w, h, vec![7; w * h * 4]);
        let chain = colour_mips(&img, &ColourOptions::default()).unwrap();
        assert_eq!(chain.levels.len(), level_count(w as u32, h as u32));
        let (mut lw, mut lh) = (w as u32, h as u32);
        for (i, l) in chain.levels.iter().enumerate() {
            assert_eq!(level_size(w as u32, h as u32, i), (lw, lh));
            assert_eq!(l.len(), (lw * lh * 4) as usize);
            (lw, lh) = ((lw / 2).max(1), (lh / 2).max(1));
        }
        assert_eq!(chain.levels.last().unwrap().len(), 4);
    }
}

#[test]
fn level_zero_of_an_8_bit_srgb_source_is_its_bytes() {
    let bytes = design(37, 21, 1);
    let chain = colour_mips(
        &rgba_image(37, 21, bytes.clone()),
        &ColourOptions::default(),
    )
    .unwrap();
    assert_eq!(chain.levels[0], bytes);
}

#[test]
fn every_filter_is_within_06_lsb_of_its_f64_reference() {
    for (w, h) in [(64, 64), (45, 31), (7, 100), (1, 33)] {
        let img = rgba_image(w, h, design(w, h, (w * h) as u64));
        for filter in [MipFilter::Box, MipFilter::Kaiser, MipFilter::Lanczos3] {
            for srgb in [true, false] {
                let e = chain_error(&img, &ColourOptions { srgb, filter });
                let max = e.iter().cloned().fold(0.0, f64::max);
                assert!(
                    max <= 0.6,
                    "{w}x{h} {filter:?} srgb={srgb}: per-level {e:?}"
                );
            }
        }
    }
}

/// Independent check of the polyphase box: each level texel is the exact area average (in
/// linear light, alpha-weighted) of the level-0 texels under its footprint.
#[test]
fn box_levels_are_exact_area_averages_of_level_zero() {
    let (w, h) = (13usize, 7usize);
    let bytes = design(w, h, 11);
    let chain = colour_mips(&rgba_image(w, h, bytes.clone()), &ColourOptions::default()).unwrap();
    let lin = |i: usize, c: usize| {
        let b = bytes[i * 4 + c] as f64 / 255.0;
        if c == 3 { b } else { srgb_to_linear(b) }
    };
    let overlap = |a0: f64, a1: f64, b0: f64, b1: f64| (a1.min(b1) - a0.max(b0)).max(0.0);
    for level in 1..chain.levels.len() {
        let (lw, lh) = level_size(w as u32, h as u32, level);
        let (sx, sy) = (w as f64 / lw as f64, h as f64 / lh as f64);
        for oy in 0..lh as usize {
            for ox in 0..lw as usize {
                let (mut p, mut a, mut area) = ([0.0f64; 3], 0.0, 0.0);
                for y in 0..h {
                    for x in 0..w {
                        let f = overlap(
                            ox as f64 * sx,
                            (ox + 1) as f64 * sx,
                            x as f64,
                            x as f64 + 1.0,
                        ) * overlap(
                            oy as f64 * sy,
                            (oy + 1) as f64 * sy,
                            y as f64,
                            y as f64 + 1.0,
                        );
                        let i = y * w + x;
                        for c in 0..3 {
                            p[c] += f * lin(i, 3) * lin(i, c);
                        }
                        a += f * lin(i, 3);
                        area += f;
                    }
                }
                let o = &chain.levels[level][(oy * lw as usize + ox) * 4..][..4];
                assert!(
                    (o[3] as f64 - a / area * 255.0).abs() <= 0.51,
                    "level {level} alpha"
                );
                for c in 0..3 {
                    let exact = linear_to_srgb_lsb(p[c] / a);
                    assert!(
                        (o[c] as f64 - exact).abs() <= 0.6,
                        "level {level} ({ox},{oy}) c{c}: {} vs {exact}",
                        o[c]
                    );
                }
            }
        }
    }
}

#[test]
fn linear_light_differs_from_gamma_space_averaging() {
    // Black and white stripes average to linear 0.5, sRGB code 188, not 128.
    let mut bytes = vec![0u8; 2 * 2 * 4];
    for (i, t) in bytes.chunks_exact_mut(4).enumerate() {
        let v = if i % 2 == 0 { 255 } else { 0 };
        t.copy_from_slice(&[v, v, v, 255]);
    }
    let chain = colour_mips(&rgba_image(2, 2, bytes), &ColourOptions::default()).unwrap();
    assert_eq!(chain.levels[1], vec![188, 188, 188, 255]);
}

#[test]
fn transparent_texels_do_not_bleed_their_colour() {
    // An opaque red texel beside three transparent green ones: premultiplied filtering keeps
    // pure red at a quarter coverage.
    let bytes = vec![255, 0, 0, 255, 0, 255, 0, 0, 0, 255, 0, 0, 0, 255, 0, 0];
    let chain = colour_mips(&rgba_image(2, 2, bytes), &ColourOptions::default()).unwrap();
    assert_eq!(chain.levels[1], vec![255, 0, 0, 64]);
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

        /// A constant image (any colour, any alpha, 8 or 16 bit, any size) stays exactly
        /// constant through every level and filter.
        #[test]
        fn constant_images_stay_constant(
            w in 1u32..70, h in 1u32..70,
            px in any::<[u16; 4]>(),
            sixteen in any::<bool>(),
            filter in prop_oneof![Just(MipFilter::Box), Just(MipFilter::Kaiser), Just(MipFilter::Lanczos3)],
        ) {
            let (img, expect): (DynamicImage, [u8; 4]) = if sixteen {
                let i = image::ImageBuffer::from_pixel(w, h, image::Rgba(px));
                let l0 = colour_mips(&DynamicImage::ImageRgba16(i.clone()), &ColourOptions::default()).unwrap();
                let first: [u8; 4] = l0.levels[0][..4].try_into().unwrap();
                (DynamicImage::ImageRgba16(i), first)
            } else {
                let p = px.map(|v| (v >> 8) as u8);
                (DynamicImage::ImageRgba8(image::ImageBuffer::from_pixel(w, h, image::Rgba(p))), p)
            };
            let chain = colour_mips(&img, &ColourOptions { srgb: true, filter }).unwrap();
            for (i, l) in chain.levels.iter().enumerate() {
                for t in l.chunks_exact(4) {
                    prop_assert_eq!(t, &expect[..], "level {}", i);
                }
            }
        }

        /// Random content, random sizes, 16-bit and grey inputs: within 0.6 LSB per level.
        #[test]
        fn random_images_match_reference(
            w in 1usize..40, h in 1usize..40, seed in any::<u64>(), kind in 0u8..4,
        ) {
            let mut rng = Rng(seed | 1);
            let img = match kind {
                0 => rgba_image(w, h, (0..w * h * 4).map(|_| rng.byte()).collect()),
                1 => DynamicImage::ImageRgba16(image::ImageBuffer::from_fn(w as u32, h as u32, |_, _| {
                    image::Rgba([rng.next_u64() as u16, rng.next_u64() as u16, rng.next_u64() as u16, rng.next_u64() as u16])
                })),
                2 => DynamicImage::ImageLuma8(image::ImageBuffer::from_fn(w as u32, h as u32, |_, _| image::Luma([rng.byte()]))),
                _ => DynamicImage::ImageLumaA16(image::ImageBuffer::from_fn(w as u32, h as u32, |_, _| {
                    image::LumaA([rng.next_u64() as u16, rng.next_u64() as u16])
                })),
            };
            let e = chain_error(&img, &ColourOptions::default());
            prop_assert!(e.iter().all(|&v| v <= 0.6), "{:?}", e);
        }
    }
}

#[test]
fn pad_image_repeats_the_edge_in_the_source_format() {
    let grey16 = image::ImageBuffer::<image::Luma<u16>, Vec<u16>>::from_fn(5, 3, |x, y| {
        image::Luma([(x * 1000 + y * 7) as u16])
    });
    let padded = texture::pixels::pad_image(&image::DynamicImage::ImageLuma16(grey16), 8, 4);
    let image::DynamicImage::ImageLuma16(p) = &padded else {
        panic!("format changed: {:?}", padded.color());
    };
    assert_eq!(p.dimensions(), (8, 4));
    for (x, y, v) in p.enumerate_pixels() {
        assert_eq!(v[0], (x.min(4) * 1000 + y.min(2) * 7) as u16, "({x}, {y})");
    }
    // A block-sized image comes back as it is.
    let rgba = image::DynamicImage::ImageRgba8(image::RgbaImage::new(8, 4));
    assert_eq!(texture::pixels::pad_image(&rgba, 8, 4), rgba);
}

/// 8-bit sources other than RGBA8 take the byte path (level 1 straight from the bytes, no f32
/// copy of level 0) and the chain is the one the f32 path gives, level by level, byte for byte.
#[test]
fn grey_and_rgb_sources_give_the_f32_chain() {
    let mut rng = Rng(3);
    for (w, h) in [(64u32, 48u32), (37, 21)] {
        let images = [
            DynamicImage::ImageRgb8(image::ImageBuffer::from_fn(w, h, |_, _| {
                image::Rgb([rng.byte(), rng.byte(), rng.byte()])
            })),
            DynamicImage::ImageLuma8(image::ImageBuffer::from_fn(w, h, |_, _| {
                image::Luma([rng.byte()])
            })),
            DynamicImage::ImageLumaA8(image::ImageBuffer::from_fn(w, h, |_, _| {
                image::LumaA([rng.byte(), rng.byte()])
            })),
        ];
        for img in &images {
            for filter in [MipFilter::Box, MipFilter::Kaiser] {
                let opts = ColourOptions { srgb: true, filter };
                let f32_chain: Vec<Vec<u8>> = texture::mips::colour_levels::<f32>(
                    texture::pixels::to_linear(img, true),
                    w,
                    h,
                    filter,
                )
                .iter()
                .map(|l| texture::mips::encode_level(l, true))
                .collect();
                let chain = colour_mips(img, &opts).unwrap();
                assert!(
                    chain.levels == f32_chain,
                    "{w}x{h} {:?} {filter:?}",
                    img.color()
                );
            }
        }
    }
}
