//! Max and RMS error (LSB) of our blur against the f64 reference on a synthetic design:
//! `cargo run --release -p texture --example blur_error -- [side] [sigma...]`.

use texture::blur::{
    BlurMethod, blur_srgb8, error_lsb, reference_blur, srgb8_to_premultiplied_f64,
};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let side: usize = args.first().and_then(|s| s.parse().ok()).unwrap_or(1024);
    let sigmas: Vec<f32> = if args.len() > 1 {
        args[1..]
            .iter()
            .map(|s| s.parse().expect("sigma"))
            .collect()
    } else {
        vec![8.0, 32.0]
    };
    // Same content as the benchmark.
    let src = texture::testing::opaque_design(side, side);
    let input = srgb8_to_premultiplied_f64(&src);
    for sigma in sigmas {
        let reference = reference_blur(&input, side, side, sigma as f64);
        for method in BlurMethod::ALL {
            // The fastest of a few runs: the first one also pays for page faults.
            let mut ms = f64::INFINITY;
            let mut ours = Vec::new();
            for _ in 0..5 {
                let start = std::time::Instant::now();
                ours = blur_srgb8(&src, side as u32, side as u32, sigma, method).unwrap();
                ms = ms.min(start.elapsed().as_secs_f64() * 1e3);
            }
            let e = error_lsb(&ours, &reference);
            println!(
                "{side}x{side} sigma {sigma} {} ({}): {ms:.1} ms, max {:.4} LSB, rms {:.4} LSB",
                method.name(),
                method.resolve_sized(sigma, side as u32, side as u32).name(),
                e.max,
                e.rms
            );
        }
    }
}
