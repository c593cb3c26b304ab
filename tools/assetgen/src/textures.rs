//! Everything that is not stained glass: glass normal maps, the sky panorama and the stone.

use image::RgbImage;
use rayon::prelude::*;

use crate::dmath::{self, lerp, smoothstep};
use crate::geom::Layout;
use crate::rng;

pub const NORMAL_SIZE: u32 = 512;
pub const SKY_WIDTH: u32 = 1024;
pub const SKY_HEIGHT: u32 = 512;
/// Floor texture: 2 m x 2 m of flagstones.
pub const FLOOR_SIZE: (u32, u32) = (512, 512);
/// Wall texture: 2.4 m x 2.1 m of ashlar (4 blocks x 6 courses).
pub const WALL_SIZE: (u32, u32) = (512, 448);

/// Fills an image row by row in parallel; `f(i, j)` gives the pixel.
fn fill(w: u32, h: u32, f: &(dyn Fn(u32, u32) -> [f64; 3] + Sync)) -> RgbImage {
    let mut img = RgbImage::new(w, h);
    let buf: &mut [u8] = &mut img;
    buf.par_chunks_mut(w as usize * 3)
        .enumerate()
        .for_each(|(j, row)| {
            for i in 0..w {
                let c = f(i, j as u32);
                for k in 0..3 {
                    row[i as usize * 3 + k] = c[k].round().clamp(0.0, 255.0) as u8;
                }
            }
        });
    img
}

/// Encodes a tangent-space normal (x right, y up the texture: OpenGL convention) as RGB.
fn encode_normal(n: [f64; 3]) -> [f64; 3] {
    let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
    n.map(|c| (c / len * 0.5 + 0.5) * 255.0)
}

/// Hammered glass: a tileable field of shallow round dimples, one per jittered cell; the
/// surface is the lower envelope of paraboloids, so dimples meet in soft ridges.
pub fn hammered(seed: u64) -> RgbImage {
    let cells = 14i64;
    let size = NORMAL_SIZE as f64;
    let cell = size / cells as f64;
    let site = |cx: i64, cy: i64| {
        let (wx, wy) = (cx.rem_euclid(cells), cy.rem_euclid(cells));
        (
            (cx as f64 + 0.2 + 0.6 * rng::unit(seed, &[wx, wy, 0])) * cell,
            (cy as f64 + 0.2 + 0.6 * rng::unit(seed, &[wx, wy, 1])) * cell,
        )
    };
    // Slope of the dimple wall at one cell from its centre: about 30 degrees.
    let strength = 0.6 / cell;
    fill(NORMAL_SIZE, NORMAL_SIZE, &|i, j| {
        let (x, y) = (i as f64 + 0.5, j as f64 + 0.5);
        let (gx, gy) = ((x / cell).floor() as i64, (y / cell).floor() as i64);
        let mut best = (f64::INFINITY, 0.0, 0.0);
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (sx, sy) = site(gx + dx, gy + dy);
                let d2 = (x - sx) * (x - sx) + (y - sy) * (y - sy);
                if d2 < best.0 {
                    best = (d2, x - sx, y - sy);
                }
            }
        }
        // h = |p - site|^2 / 2 * strength: gradient is strength * (p - site); image rows run
        // down, so the up component flips sign.
        encode_normal([-strength * best.1, strength * best.2, 1.0])
    })
}

/// Reeded glass: parallel vertical convex reeds, each a circular segment whose edges tilt by
/// 35 degrees.
pub fn reeded() -> RgbImage {
    let period = 32.0;
    let max_tilt = dmath::sin(35f64.to_radians());
    fill(NORMAL_SIZE, NORMAL_SIZE, &|i, _| {
        let t = ((i as f64 + 0.5) % period) / period * 2.0 - 1.0;
        let nx = t * max_tilt;
        encode_normal([nx, 0.0, (1.0 - nx * nx).sqrt()])
    })
}

/// Periodic noise in azimuth (integer frequencies, so it tiles): smooth swells plus sharp
/// crests (1 - |sin|), the outline of a mountain range, in [0, 1].
fn ridge_noise(a: f64, seed: u64, tag: i64, freqs: &[(i64, f64)]) -> f64 {
    let mut sum = 0.0;
    let mut norm = 0.0;
    for &(k, w) in freqs {
        let phase = rng::unit(seed, &[tag, k]) * dmath::TAU;
        let swell = 0.5 + 0.5 * dmath::sin(k as f64 * a + phase);
        let crest = 1.0 - dmath::sin(k as f64 * a / 2.0 + 2.0 * phase).abs();
        sum += w * (0.6 * swell + 0.4 * crest * crest);
        norm += w;
    }
    sum / norm
}

/// The panorama on the sky cylinder: u is the azimuth (0 = straight down the corridor, turning
/// towards +x), v runs from the ground (bottom row, also the ground disc's colour) to the top
/// of the cylinder (top row, also the cap's colour).
pub fn sky(layout: &Layout, seed: u64) -> RgbImage {
    let (w, h) = (SKY_WIDTH, SKY_HEIGHT);
    let (y0, y1, r) = (
        layout.ground_y as f64,
        layout.sky_top as f64,
        layout.sky_radius as f64,
    );
    let eye = 1.7;
    let top_elev = dmath::atan2(y1 - eye, r);
    let far_freqs = [
        (2, 1.0),
        (3, 0.8),
        (5, 0.6),
        (7, 0.45),
        (11, 0.3),
        (17, 0.15),
    ];
    let near_freqs = [(2, 1.0), (3, 0.6), (7, 0.3)];
    fill(w, h, &|i, j| {
        let a = dmath::TAU * (i as f64 + 0.5) / w as f64;
        let y = y0 + (y1 - y0) * (h - 1 - j) as f64 / (h - 1) as f64;
        let pix = (y1 - y0) / (h - 1) as f64;
        let elev = dmath::atan2(y - eye, r);
        // Sky: pale at the horizon, deep blue overhead; the top rows are uniform for the cap.
        let t = smoothstep(0.0, top_elev * 0.85, elev);
        let horizon = [206.0, 220.0, 232.0];
        let zenith = [58.0, 108.0, 188.0];
        let mut c = [0, 1, 2].map(|k| lerp(horizon[k], zenith[k], t.sqrt()));
        // Soft clouds in a band above the mountains.
        // The texture stretches 4:1 horizontally on the cylinder, so clouds are drawn tall
        // and narrow here to come out as wide flat banks.
        let band = smoothstep(0.16, 0.22, elev) * (1.0 - smoothstep(0.27, 0.36, elev));
        let blob = dmath::sin(4.0 * a + 1.3) * 0.5
            + dmath::sin(9.0 * a + 0.4 + elev * 6.0) * 0.35
            + dmath::sin(17.0 * a + 2.1 - elev * 10.0) * 0.25;
        let cloud = smoothstep(0.3, 0.8, blob) * band * 0.7;
        c = [0, 1, 2].map(|k| lerp(c[k], [244.0, 244.0, 248.0][k], cloud));
        // Far range, hazy blue with snow on the peaks, lit on the slopes facing the sun.
        let far = ridge_noise(a, seed, 1, &far_freqs);
        let far_top = 3.0 + 90.0 * (far - 0.3).max(0.0);
        let far_cover = ((far_top - y) / pix + 0.5).clamp(0.0, 1.0);
        if far_cover > 0.0 {
            let slope = ridge_noise(a + 0.01, seed, 1, &far_freqs) - far;
            let lit = 0.96 + 0.08 * smoothstep(-0.01, 0.01, slope);
            let snow =
                smoothstep(far_top - 6.0, far_top - 3.0, y) * smoothstep(22.0, 28.0, far_top);
            let rock = [116.0 * lit, 134.0 * lit, 164.0 * lit];
            let m = [0, 1, 2].map(|k| lerp(rock[k], [232.0, 238.0, 246.0][k] * lit, snow));
            c = [0, 1, 2].map(|k| lerp(c[k], m[k], far_cover));
        }
        // Near hills, green, darker at their crest; the meadow below is uniform.
        let near = ridge_noise(a, seed, 2, &near_freqs);
        let near_top = 3.0 + 7.0 * near;
        let near_cover = ((near_top - y) / pix + 0.5).clamp(0.0, 1.0);
        if near_cover > 0.0 {
            let meadow = [92.0, 128.0, 62.0];
            let hill = [62.0, 92.0, 70.0];
            let k = smoothstep(1.0, near_top, y);
            let m = [0, 1, 2].map(|c| lerp(meadow[c], hill[c], k));
            c = [0, 1, 2].map(|k| lerp(c[k], m[k], near_cover));
        }
        c
    })
}

/// Pale limestone flags, half a metre by one, in staggered rows: light enough that coloured
/// light on them reads clearly.
pub fn floor(seed: u64) -> RgbImage {
    let (w, h) = FLOOR_SIZE;
    let px_per_m = w as f64 / 2.0;
    stones(
        w,
        h,
        px_per_m,
        1.0,
        0.5,
        [206.0, 198.0, 182.0],
        [128.0, 120.0, 108.0],
        seed,
    )
}

/// Warm sandstone ashlar, 0.6 m blocks in 0.35 m courses.
pub fn wall(seed: u64) -> RgbImage {
    let (w, h) = WALL_SIZE;
    let px_per_m = w as f64 / 2.4;
    stones(
        w,
        h,
        px_per_m,
        0.6,
        0.35,
        [184.0, 166.0, 138.0],
        [150.0, 140.0, 122.0],
        seed,
    )
}

/// Running-bond blocks `bw` x `bh` metres with mortar joints, each block a slightly different
/// tone with a faint low-frequency mottle. Tileable: the image holds whole blocks.
#[allow(clippy::too_many_arguments)]
fn stones(
    w: u32,
    h: u32,
    px_per_m: f64,
    bw: f64,
    bh: f64,
    base: [f64; 3],
    mortar: [f64; 3],
    seed: u64,
) -> RgbImage {
    let (wm, hm) = (w as f64 / px_per_m, h as f64 / px_per_m);
    let cols = (wm / bw).round() as i64;
    let joint = 0.012;
    fill(w, h, &|i, j| {
        let x = (i as f64 + 0.5) / px_per_m;
        let y = (j as f64 + 0.5) / px_per_m;
        let row = (y / bh).floor() as i64;
        let shift = if row % 2 == 1 { bw / 2.0 } else { 0.0 };
        let xs = (x + shift).rem_euclid(wm);
        let col = (xs / bw).floor() as i64 % cols;
        let (fx, fy) = (xs - col as f64 * bw, y - row as f64 * bh);
        let edge = fx.min(bw - fx).min(fy).min(bh - fy);
        let tone = 0.9 + 0.14 * rng::unit(seed, &[row, col]);
        let warm = 6.0 * rng::signed(seed, &[row, col, 1]);
        let mottle = 1.0
            + 0.03 * dmath::sin(dmath::TAU * (2.0 * x / wm + 3.0 * y / hm) + 1.7)
            + 0.02 * dmath::sin(dmath::TAU * (5.0 * x / wm - 2.0 * y / hm) + 0.3);
        let stone = [
            base[0] * tone * mottle + warm,
            base[1] * tone * mottle,
            base[2] * tone * mottle - warm,
        ];
        let k = smoothstep(joint * 0.5, joint * 1.5, edge);
        [0, 1, 2].map(|c| lerp(mortar[c], stone[c], k))
    })
}
