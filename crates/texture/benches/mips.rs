//! Full mip chain of a 4096x4096 RGBA8 colour texture: ours (linear light, alpha-weighted,
//! f32, re-encoded to sRGB per level) beside fast_image_resize (gamma space, alpha-weighted
//! like ours, each level from the previous one). Both on one thread for the ratio; ours also
//! on every core, labelled with the count.
//!
//! `TEXTURE_BENCH_SIZE` overrides the side (default 4096).

use std::hint::black_box;
use std::time::Duration;

use criterion::{Criterion, criterion_group, criterion_main};
use fast_image_resize::images::Image;
use fast_image_resize::{FilterType, PixelType, ResizeAlg, ResizeOptions, Resizer};
use texture::{ColourOptions, MipFilter, colour_mips};

/// The blur benchmark's content, so both benchmarks filter the same kind of image.
fn design(side: u32) -> image::RgbaImage {
    let bytes = texture::testing::opaque_design(side as usize, side as usize);
    image::RgbaImage::from_raw(side, side, bytes).expect("side x side RGBA8")
}

/// fast_image_resize's chain: every level resized from the previous one, straight in the
/// stored (gamma-encoded) bytes. `use_alpha(true)` (its default, and the bench tool's) weights
/// colour by alpha as ours does; without it the anchor does less work (18.5 against 34.9 ms
/// at 4096², GUIDE.md).
fn fir_chain(src: &image::RgbaImage, filter: FilterType) -> usize {
    let mut resizer = Resizer::new();
    let opts = ResizeOptions::new()
        .resize_alg(ResizeAlg::Convolution(filter))
        .use_alpha(true);
    let (mut w, mut h) = src.dimensions();
    let mut level = Image::from_vec_u8(w, h, src.as_raw().clone(), PixelType::U8x4).unwrap();
    let mut bytes = 0;
    while w > 1 || h > 1 {
        (w, h) = ((w / 2).max(1), (h / 2).max(1));
        let mut next = Image::new(w, h, PixelType::U8x4);
        resizer.resize(&level, &mut next, &opts).unwrap();
        bytes += next.buffer().len();
        level = next;
    }
    bytes
}

fn bench(c: &mut Criterion) {
    let side: u32 = std::env::var("TEXTURE_BENCH_SIZE")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(4096);
    let img = image::DynamicImage::ImageRgba8(design(side));
    let rgba = img.to_rgba8();
    let mut g = c.benchmark_group(format!("mip chain {side}x{side}"));
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let all = rayon::current_num_threads();
    for filter in [MipFilter::Box, MipFilter::Lanczos3] {
        let opts = ColourOptions { srgb: true, filter };
        g.bench_function(
            format!(
                "mip chain: {} (ours, linear light, 1 thread)",
                filter.name()
            ),
            |b| b.iter(|| one.install(|| colour_mips(black_box(&img), &opts).unwrap())),
        );
        g.bench_function(
            format!(
                "mip chain: {} (ours, linear light, {all} threads)",
                filter.name()
            ),
            |b| b.iter(|| colour_mips(black_box(&img), &opts).unwrap()),
        );
    }
    // fast_image_resize runs on the calling thread.
    for (name, filter) in [("box", FilterType::Box), ("lanczos3", FilterType::Lanczos3)] {
        g.bench_function(
            format!("mip chain: {name} (fast_image_resize, gamma, 1 thread)"),
            |b| b.iter(|| fir_chain(black_box(&rgba), filter)),
        );
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
