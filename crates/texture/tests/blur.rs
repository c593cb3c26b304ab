#![allow(clippy::needless_range_loop)]
mod common;

use common::{blur_error as err, design, premul_f32, sum};
use texture::blur::{self, BlurMethod, srgb8_to_premultiplied_f64};
use texture::testing::Rng;
use texture::{Sigma2, blur_linear, blur_srgb8, reference_blur};

#[test]
fn blur_is_within_055_lsb_of_the_f64_reference() {
    let (w, h) = (150, 97);
    let img = design(w, h, 3);
    for sigma in [0.3f32, 0.7, 1.0, 2.5, 3.9, 4.0, 8.0, 13.7, 32.0] {
        for method in [BlurMethod::Direct, BlurMethod::Decimated] {
            let e = err(w, h, sigma, method, &img);
            eprintln!(
                "sigma {sigma} {method:?}: max {:.4} rms {:.4}",
                e.max, e.rms
            );
            assert!(
                e.max <= 0.55,
                "sigma {sigma} {method:?}: max error {} LSB",
                e.max
            );
        }
    }
}

/// A design stretched onto its window is blurred by a different σ along each axis: every exact
/// method stays at the rounding floor against the reference with the two kernels, whichever
/// axis is the wider and whichever method the narrower σ resolves to.
#[test]
fn a_stretched_blur_is_within_055_lsb_of_the_f64_reference() {
    let (w, h) = (150, 97);
    let img = design(w, h, 5);
    for (sx, sy) in [
        (0.7f32, 3.0f32),
        (8.0, 2.5),
        (13.7, 5.0),
        (4.0, 32.0),
        (2.2, 0.0),
    ] {
        let sigma = Sigma2::new(sx, sy);
        for method in [BlurMethod::Direct, BlurMethod::Decimated, BlurMethod::Auto] {
            let e = err(w, h, sigma, method, &img);
            let used = method.resolve(sigma);
            eprintln!("sigma {sigma} {method:?} ({used:?}): max {:.4}", e.max);
            assert!(e.max <= 0.55, "sigma {sigma} {method:?}: max {} LSB", e.max);
        }
    }
}

/// The light of one texel spreads by σx along rows and σy down columns: its second moments
/// about the texel are σ² along each axis (the sampled kernel's, to within the truncation), and
/// the axes are not swapped.
#[test]
fn a_stretched_blur_spreads_a_point_by_each_axis_s_sigma() {
    let (w, h) = (81usize, 121usize);
    let (cx, cy) = (40usize, 60usize);
    let mut src = vec![[0.0f32; 4]; w * h];
    src[cy * w + cx] = [1.0; 4];
    for (sx, sy) in [(1.5f32, 6.0f32), (7.0, 2.0)] {
        for method in [BlurMethod::Direct, BlurMethod::Decimated] {
            let out = blur_linear(&src, w as u32, h as u32, Sigma2::new(sx, sy), method).unwrap();
            let (mut m, mut vx, mut vy) = (0.0f64, 0.0f64, 0.0f64);
            for y in 0..h {
                for x in 0..w {
                    let v = out[y * w + x][0] as f64;
                    m += v;
                    vx += v * (x as f64 - cx as f64).powi(2);
                    vy += v * (y as f64 - cy as f64).powi(2);
                }
            }
            let (vx, vy) = (vx / m, vy / m);
            let near = |v: f64, s: f32| (v.sqrt() - s as f64).abs() < 0.01 * s as f64;
            assert!(
                near(vx, sx) && near(vy, sy),
                "{method:?} σ {sx} x {sy}: {vx} {vy}"
            );
        }
    }
}

#[test]
fn constant_stays_exactly_constant_where_the_kernel_misses_the_border() {
    let (w, h) = (120, 90);
    for sigma in [0.6f32, 2.0, 5.0, 8.0] {
        let bytes: Vec<u8> = [200u8, 30, 90, 255].repeat(w * h);
        let out = blur_srgb8(&bytes, w as u32, h as u32, sigma, BlurMethod::Auto).unwrap();
        let r = blur::kernel_radius(sigma as f64);
        for y in r..h - r {
            for x in r..w - r {
                assert_eq!(
                    &out[(y * w + x) * 4..][..4],
                    &[200, 30, 90, 255],
                    "sigma {sigma} at {x},{y}"
                );
            }
        }
        // The zero border darkens the edge (light stops at the wall).
        assert!(out[3] < 255, "sigma {sigma}: corner alpha {}", out[3]);
    }
}

#[test]
fn mass_is_preserved_away_from_the_border() {
    let (w, h) = (200, 160);
    let mut bytes = vec![0u8; w * h * 4];
    let inner = design(40, 30, 9);
    for y in 0..30 {
        for x in 0..40 {
            let d = ((y + 65) * w + x + 80) * 4;
            bytes[d..d + 4].copy_from_slice(&inner[(y * 40 + x) * 4..][..4]);
        }
    }
    let src = premul_f32(&bytes);
    let before = sum(&src);
    for sigma in [0.3f32, 1.0, 4.0, 6.0, 9.5] {
        for method in [BlurMethod::Direct, BlurMethod::Decimated] {
            let out = blur_linear(&src, w as u32, h as u32, sigma, method).unwrap();
            let after = sum(&out);
            for c in 0..4 {
                let rel = (after[c] - before[c]).abs() / before[c];
                assert!(
                    rel < 1e-6,
                    "sigma {sigma} {method:?} channel {c}: relative mass change {rel}"
                );
            }
        }
    }
}

#[test]
fn huge_sigma_spreads_mass_as_the_reference_does() {
    let (w, h) = (9, 7);
    let bytes = design(w, h, 5);
    let src = premul_f32(&bytes);
    let reference = reference_blur(&srgb8_to_premultiplied_f64(&bytes), w, h, 1e4);
    let out = blur_linear(&src, w as u32, h as u32, 1e4, BlurMethod::Auto).unwrap();
    let (a, b) = (sum(&out), {
        let mut s = [0.0; 4];
        for t in &reference {
            for c in 0..4 {
                s[c] += t[c];
            }
        }
        s
    });
    for c in 0..4 {
        assert!(a[c].is_finite() && a[c] > 0.0);
        assert!(
            (a[c] - b[c]).abs() / b[c] < 1e-5,
            "channel {c}: {} vs {}",
            a[c],
            b[c]
        );
    }
}

#[test]
fn zero_and_tiny_sigma_are_the_identity() {
    let (w, h) = (13, 11);
    let bytes = design(w, h, 2);
    for sigma in [0.0f32, 1e-6, 1e-3] {
        let out = blur_srgb8(&bytes, w as u32, h as u32, sigma, BlurMethod::Auto).unwrap();
        // Identity on premultiplied colour: opaque texels keep their bytes.
        for (o, i) in out.chunks_exact(4).zip(bytes.chunks_exact(4)) {
            if i[3] == 255 {
                assert_eq!(o, i, "sigma {sigma}");
            }
        }
    }
}

#[test]
fn invalid_sigma_is_an_error_not_a_panic() {
    let bytes = [1u8, 2, 3, 4];
    for sigma in [-1.0f32, f32::NAN, f32::INFINITY, 1e9] {
        let e = blur_srgb8(&bytes, 1, 1, sigma, BlurMethod::Auto).unwrap_err();
        assert!(e.to_string().contains("sigma"), "{e}");
    }
    assert!(blur_srgb8(&[], 0, 0, 1.0, BlurMethod::Auto).is_err());
}

#[test]
fn thread_count_does_not_change_the_result() {
    let (w, h) = (77, 61);
    let bytes = design(w, h, 4);
    let run = |threads: usize, sigma: f32| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| blur_srgb8(&bytes, w as u32, h as u32, sigma, BlurMethod::Auto).unwrap())
    };
    for sigma in [1.5f32, 9.0] {
        assert_eq!(run(1, sigma), run(3, sigma), "sigma {sigma}");
    }
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig { cases: 48, ..ProptestConfig::default() })]

        /// Any size (1x1, 1xN, Nx1 included), any σ class, random bytes with any alpha: finite,
        /// within 0.55 LSB of the reference.
        #[test]
        fn blur_matches_reference(
            w in 1usize..24,
            h in 1usize..24,
            sigma in prop_oneof![Just(0.0f32), Just(1e-6f32), Just(0.3f32), 0.0f32..12.0, Just(1e4f32)],
            seed in any::<u64>(),
            alpha_zero in any::<bool>(),
        ) {
            let mut rng = Rng(seed | 1);
            let mut bytes: Vec<u8> = (0..w * h * 4).map(|_| rng.byte()).collect();
            if alpha_zero {
                for t in bytes.chunks_exact_mut(4) {
                    t[3] = 0;
                }
            }
            let src = premul_f32(&bytes);
            let lin = blur_linear(&src, w as u32, h as u32, sigma, BlurMethod::Auto).unwrap();
            prop_assert!(lin.iter().flatten().all(|v| v.is_finite() && *v >= 0.0));
            if alpha_zero {
                prop_assert!(lin.iter().flatten().all(|&v| v == 0.0));
            }
            let e = err(w, h, sigma, BlurMethod::Auto, &bytes);
            prop_assert!(e.max <= 0.55, "max error {} LSB", e.max);
        }
    }
}

/// The projector's input read from the bytes is the f32 copy it replaced, bit for bit: every
/// alpha, both exact methods and both approximations.
#[test]
fn bytes_blur_like_their_decoded_premultiplied_copy() {
    let (w, h) = (61, 45);
    let mut rng = Rng(7);
    let bytes: Vec<u8> = (0..w * h * 4).map(|_| rng.byte()).collect();
    let img = common::rgba_image(w, h, bytes.clone());
    let mut premul = texture::pixels::to_linear(&img, true);
    for t in &mut premul {
        *t = [t[0] * t[3], t[1] * t[3], t[2] * t[3], t[3]];
    }
    for sigma in [0.5f32, 2.2, 9.0] {
        for method in [
            BlurMethod::Direct,
            BlurMethod::Decimated,
            BlurMethod::DecimatedCoarse,
            BlurMethod::Box3,
        ] {
            let copy = blur_linear(&premul, w as u32, h as u32, sigma, method).unwrap();
            let read =
                blur::blur_rgba8_to_linear(&bytes, w as u32, h as u32, sigma, method).unwrap();
            let bits = |v: &[[f32; 4]]| v.iter().flatten().map(|f| f.to_bits()).collect::<Vec<_>>();
            assert!(bits(&copy) == bits(&read), "sigma {sigma} {method:?}");
        }
    }
}
