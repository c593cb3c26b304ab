#![allow(clippy::needless_range_loop)]
mod common;

use common::{design, rgba_image};
use image::DynamicImage;
use texture::normal::{decode_normals, normal_levels};
use texture::testing::Rng;
use texture::{GreenAxis, NormalEncoding, derive_normal_map, normal_mips};

fn unit_everywhere(levels: &[Vec<[f32; 4]>]) -> Result<(), String> {
    for (i, l) in levels.iter().enumerate() {
        for n in l {
            let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            if len.is_nan() || (len - 1.0).abs() > 1e-3 {
                return Err(format!("level {i}: {n:?} has length {len}"));
            }
        }
    }
    Ok(())
}

#[test]
fn opposite_normals_cancel_to_the_fallback() {
    // Codes b and 255 - b decode to exactly opposite vectors: their average is zero.
    let (a, b) = ([255, 140, 128, 255], [0, 115, 127, 255]);
    let bytes = [a, b, b, a].concat();
    let img = rgba_image(2, 2, bytes);
    let chain = normal_mips(&img, NormalEncoding::Rgb, GreenAxis::OpenGl).unwrap();
    assert_eq!(chain.levels[1], vec![128, 128, 255, 255]);
}

#[test]
fn directx_green_is_flipped_to_opengl() {
    let img = rgba_image(1, 1, vec![128, 200, 200, 255]);
    let gl = decode_normals(&img, NormalEncoding::Rgb, GreenAxis::OpenGl)[0];
    let dx = decode_normals(&img, NormalEncoding::Rgb, GreenAxis::DirectX)[0];
    assert!(
        gl[1] > 0.1 && (gl[1] + dx[1]).abs() < 1e-6 && gl[2] == dx[2],
        "{gl:?} {dx:?}"
    );
    let stored = normal_mips(&img, NormalEncoding::Rgb, GreenAxis::DirectX).unwrap();
    assert!(stored.levels[0][1] < 128, "{:?}", stored.levels[0]);
}

#[test]
fn rg_encoding_reconstructs_z() {
    // x = 0.6, y = 0 → z = 0.8; blue byte is ignored.
    let img = rgba_image(1, 1, vec![204, 128, 0, 255]);
    let n = decode_normals(&img, NormalEncoding::Rg, GreenAxis::OpenGl)[0];
    assert!((n[2] - 0.8).abs() < 0.01, "{n:?}");
    let chain = normal_mips(&img, NormalEncoding::Rg, GreenAxis::OpenGl).unwrap();
    assert!(
        (chain.levels[0][2] as i32 - 230).abs() <= 1,
        "{:?}",
        chain.levels[0]
    );
}

#[test]
fn derived_map_is_deterministic_and_seeded() {
    let img = rgba_image(64, 48, design(64, 48, 3));
    let a = derive_normal_map(&img, 7).unwrap();
    let b = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| derive_normal_map(&img, 7).unwrap());
    assert_eq!(a, b);
    assert_ne!(a, derive_normal_map(&img, 8).unwrap());
}

#[test]
fn derived_map_raises_lead_and_keeps_glass_subtle() {
    // A bright glass pane crossed by one dark vertical lead line at x = 20..23.
    let (w, h) = (48usize, 32usize);
    let mut bytes = Vec::with_capacity(w * h * 4);
    for _y in 0..h {
        for x in 0..w {
            bytes.extend_from_slice(if (20..23).contains(&x) {
                &[15, 15, 18, 255]
            } else {
                &[40, 90, 220, 255]
            });
        }
    }
    let chain = derive_normal_map(&rgba_image(w, h, bytes), 1).unwrap();
    let l0 = &chain.levels[0];
    let x_at = |x: usize, y: usize| l0[(y * w + x) * 4] as i32 - 128;
    // Left flank of the came faces -x (height rises towards +x), right flank +x.
    assert!(x_at(19, 16) < -20, "left flank {}", x_at(19, 16));
    assert!(x_at(23, 16) > 20, "right flank {}", x_at(23, 16));
    // Glass far from the lead is nearly flat.
    for y in 0..h {
        for x in (0..10).chain(35..w) {
            let z = l0[(y * w + x) * 4 + 2];
            assert!(z >= 240, "glass at {x},{y} tilts too much: z byte {z}");
        }
    }
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 40, ..ProptestConfig::default() })]

        /// Random bytes (including zero vectors and 16-bit input) decode, filter and
        /// renormalize to unit vectors at every level; never NaN.
        #[test]
        fn normals_are_unit_at_every_level(
            w in 1u32..40, h in 1u32..40, seed in any::<u64>(), rg in any::<bool>(), sixteen in any::<bool>(),
        ) {
            let mut rng = Rng(seed | 1);
            let img = if sixteen {
                DynamicImage::ImageRgb16(image::ImageBuffer::from_fn(w, h, |_, _| {
                    image::Rgb([rng.next_u64() as u16, rng.next_u64() as u16, (rng.next_u64() as u16) | 1])
                }))
            } else {
                DynamicImage::ImageRgb8(image::ImageBuffer::from_fn(w, h, |_, _| {
                    // Often exactly 128: zero components and all-zero vectors.
                    let mut b = || if rng.byte() < 64 { 128 } else { rng.byte() };
                    image::Rgb([b(), b(), b()])
                }))
            };
            let enc = if rg { NormalEncoding::Rg } else { NormalEncoding::Rgb };
            let levels = normal_levels(decode_normals(&img, enc, GreenAxis::OpenGl), w, h);
            prop_assert!(unit_everywhere(&levels).is_ok(), "{:?}", unit_everywhere(&levels));
            let chain = normal_mips(&img, enc, GreenAxis::DirectX).unwrap();
            prop_assert_eq!(chain.levels.len(), levels.len());
        }

        #[test]
        fn derived_normals_are_unit(w in 1u32..48, h in 1u32..48, seed in any::<u64>()) {
            let mut rng = Rng(seed | 1);
            let img = DynamicImage::ImageRgba8(image::ImageBuffer::from_fn(w, h, |_, _| {
                image::Rgba([rng.byte(), rng.byte(), rng.byte(), rng.byte()])
            }));
            let height = texture::normal::design_height(&img, seed).unwrap();
            prop_assert!(height.iter().all(|v| v.is_finite()));
            let levels = normal_levels(texture::normal::height_to_normals(&height, w, h), w, h);
            prop_assert!(unit_everywhere(&levels).is_ok(), "{:?}", unit_everywhere(&levels));
        }
    }
}

#[test]
fn padded_derived_normal_map_repeats_its_edge_and_keeps_level_zero() {
    let (w, h) = (37, 22);
    let img = common::rgba_image(w, h, common::design(w, h, 6));
    let plain = texture::derive_normal_map(&img, 7).unwrap();
    let padded = texture::derive_normal_map_padded(&img, 7, 1.0, 40, 24).unwrap();
    assert_eq!((padded.width, padded.height), (40, 24));
    assert_eq!(padded.levels.len(), texture::level_count(40, 24));
    let at = |c: &texture::MipChain, x: usize, y: usize| {
        c.levels[0][(y * c.width as usize + x) * 4..][..4].to_vec()
    };
    for y in 0..24 {
        for x in 0..40 {
            let expected = at(&plain, x.min(36), y.min(21));
            assert_eq!(at(&padded, x, y), expected, "({x}, {y})");
        }
    }
}

/// One pixel of a design changed moves the derived normals near it only: the came's profile
/// and the glass's relief are local, and the noise is seeded by the caller (the cook: by the
/// design's size). Seeded by the content, one pixel moved nearly every normal of the map.
#[test]
fn a_one_pixel_edit_changes_the_derived_map_only_near_it() {
    let (w, h) = (256usize, 192usize);
    let before = design(w, h, 3);
    let mut after = before.clone();
    let (px, py) = (100usize, 60usize);
    let at = (py * w + px) * 4;
    after[at] = after[at].wrapping_add(90);
    let a = derive_normal_map(&rgba_image(w, h, before), 7).unwrap();
    let b = derive_normal_map(&rgba_image(w, h, after), 7).unwrap();
    let (mut near, mut far) = (0, 0);
    for y in 0..h {
        for x in 0..w {
            let i = (y * w + x) * 4;
            if a.levels[0][i..i + 4] != b.levels[0][i..i + 4] {
                if x.abs_diff(px).max(y.abs_diff(py)) <= 12 {
                    near += 1;
                } else {
                    far += 1;
                }
            }
        }
    }
    assert!(near > 0, "the edit changed nothing");
    assert_eq!(
        far, 0,
        "{far} normals changed more than 12 texels from the edit ({near} near it)"
    );
}
