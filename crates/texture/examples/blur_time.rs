//! Times every blur method on an opaque design, f32 linear in and out and sRGB8 in and out:
//! `cargo run --release -p texture --example blur_time -- [side] [sigma...]`.

use texture::blur::{BlurMethod, blur_linear, blur_srgb8};

fn best_ms<T>(runs: usize, mut f: impl FnMut() -> T) -> f64 {
    (0..runs)
        .map(|_| {
            let start = std::time::Instant::now();
            std::hint::black_box(f());
            start.elapsed().as_secs_f64() * 1e3
        })
        .fold(f64::INFINITY, f64::min)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let side: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(2048);
    let sigmas: Vec<f32> = args.iter().skip(1).filter_map(|s| s.parse().ok()).collect();
    let bytes: Vec<u8> = (0..side * side * 4)
        .map(|i| {
            if i % 4 == 3 {
                255
            } else {
                ((i * 37) % 251) as u8
            }
        })
        .collect();
    let lin: Vec<[f32; 4]> = vec![[0.25, 0.5, 0.125, 1.0]; side * side];
    let n = side as u32;
    for sigma in sigmas {
        // BLUR_METHODS=box3,decimated limits the run to those methods.
        let only = std::env::var("BLUR_METHODS").unwrap_or_default();
        for m in BlurMethod::ALL.into_iter().skip(1) {
            if !only.is_empty() && !only.split(',').any(|o| o == m.name()) {
                continue;
            }
            let a = best_ms(5, || blur_linear(&lin, n, n, sigma, m).unwrap());
            let b = best_ms(5, || blur_srgb8(&bytes, n, n, sigma, m).unwrap());
            println!(
                "{side}² σ={sigma} {} ({}): linear f32 {a:.1} ms, srgb8 {b:.1} ms",
                m.name(),
                m.resolve_sized(sigma, n, n).name()
            );
        }
    }
}
