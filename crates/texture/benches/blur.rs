//! Gaussian blur of a 4096x4096 RGBA8 design: ours (linear light, premultiplied, zero border)
//! beside libblur's exact u8 Gaussian and `image::imageops::blur` (both gamma space).
//!
//! `TEXTURE_BENCH_SIZE` overrides the side (default 4096); `TEXTURE_BENCH_SIGMAS` the σ list
//! (default "8,32"); `TEXTURE_BENCH_ANCHORS=0` skips the anchors.

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use texture::blur::{BlurMethod, blur_srgb8, blur_srgb8_into};

fn env_list(name: &str, default: &str) -> Vec<f32> {
    std::env::var(name)
        .unwrap_or_else(|_| default.into())
        .split(',')
        .map(|s| s.trim().parse().expect("sigma list"))
        .collect()
}

fn bench(c: &mut Criterion) {
    let side: usize = std::env::var("TEXTURE_BENCH_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4096);
    let anchors = std::env::var("TEXTURE_BENCH_ANCHORS").map_or(true, |v| v != "0");
    let src = texture::testing::opaque_design(side, side);
    let mut g = c.benchmark_group(format!("gaussian blur {side}x{side}"));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    for sigma in env_list("TEXTURE_BENCH_SIGMAS", "8,32") {
        // Into a reused buffer, as libblur below writes into `dst`: both then pay for the blur,
        // not for faulting in a fresh 64 MiB result.
        let mut out = vec![0u8; src.len()];
        g.bench_function(format!("gaussian blur: sigma {sigma} (ours, auto)"), |b| {
            b.iter(|| {
                blur_srgb8_into(
                    black_box(&src),
                    side as u32,
                    side as u32,
                    sigma,
                    BlurMethod::Auto,
                    &mut out,
                )
                .unwrap()
            })
        });
        if sigma <= 8.0 {
            g.bench_function(
                format!("gaussian blur: sigma {sigma} (ours, direct)"),
                |b| {
                    b.iter(|| {
                        blur_srgb8(
                            black_box(&src),
                            side as u32,
                            side as u32,
                            sigma,
                            BlurMethod::Direct,
                        )
                        .unwrap()
                    })
                },
            );
        }
        if anchors {
            g.bench_function(
                format!("gaussian blur: sigma {sigma} (libblur exact u8)"),
                |b| {
                    let mut dst = vec![0u8; src.len()];
                    b.iter(|| libblur_exact(black_box(&src), &mut dst, side as u32, sigma))
                },
            );
            g.bench_function(
                format!("gaussian blur: sigma {sigma} (image::imageops::blur)"),
                |b| {
                    let img =
                        image::RgbaImage::from_raw(side as u32, side as u32, src.clone()).unwrap();
                    b.iter(|| image::imageops::blur(black_box(&img), sigma))
                },
            );
        }
    }
    g.finish();
}

/// libblur's exact (f32-accumulating) u8 Gaussian with a kernel of about 8σ + 1 taps.
pub fn libblur_exact(src: &[u8], dst: &mut [u8], side: u32, sigma: f32) {
    use libblur::{
        BlurImage, BlurImageMut, ConvolutionMode, EdgeMode, EdgeMode2D, FastBlurChannels,
        GaussianBlurParams, ThreadingPolicy,
    };
    let s = BlurImage::borrow(src, side, side, FastBlurChannels::Channels4);
    let mut d = BlurImageMut::borrow(dst, side, side, FastBlurChannels::Channels4);
    let ksize = ((sigma * 8.0).round() as u32) | 1;
    libblur::gaussian_blur(
        &s,
        &mut d,
        GaussianBlurParams::new(ksize, sigma as f64),
        EdgeMode2D::new(EdgeMode::Clamp),
        ThreadingPolicy::Adaptive,
        ConvolutionMode::Exact,
    )
    .unwrap();
}

criterion_group!(benches, bench);
criterion_main!(benches);
