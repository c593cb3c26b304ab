//! Stained-glass designs.
//!
//! A design is a function from a point on the window (metres, y up) to a pane label. Leaded
//! glass follows from the labels alone: wherever neighbouring pixels disagree there is a lead
//! came, drawn with an exact Euclidean distance transform so every pane gets an even,
//! anti-aliased border whatever its shape. Each label carries a palette entry; the pane's exact
//! tint is varied by a hash of the label, as hand-made sheets of glass vary.
//!
//! Panes are flat colour apart from a slight darkening at their leads, which keeps the PNGs
//! small (long runs of identical pixels) while still reading as glass.

use glam::Vec2;
use image::RgbImage;
use rayon::prelude::*;

use crate::dmath::{self, smoothstep};
use crate::geom::{ArchShape, Design, Layout};
use crate::rng;

/// Palette entries (sRGB). Index 0 is opaque lead/stone: anything outside the opening.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum Glass {
    Lead = 0,
    Stone,
    Ruby,
    Cobalt,
    Emerald,
    Gold,
    Amethyst,
    Pale,
    Azure,
    Amber,
    Pearl,
    Olive,
}

impl Glass {
    fn rgb(self) -> [f64; 3] {
        match self {
            Glass::Lead => [24.0, 22.0, 20.0],
            Glass::Stone => [44.0, 40.0, 36.0],
            Glass::Ruby => [186.0, 22.0, 36.0],
            Glass::Cobalt => [26.0, 58.0, 176.0],
            Glass::Emerald => [22.0, 140.0, 72.0],
            Glass::Gold => [238.0, 178.0, 36.0],
            Glass::Amethyst => [118.0, 40.0, 142.0],
            Glass::Pale => [212.0, 222.0, 196.0],
            Glass::Azure => [64.0, 148.0, 214.0],
            Glass::Amber => [226.0, 112.0, 26.0],
            Glass::Pearl => [236.0, 232.0, 214.0],
            Glass::Olive => [150.0, 168.0, 92.0],
        }
    }

    fn from_index(i: u64) -> Glass {
        use Glass::*;
        [
            Lead, Stone, Ruby, Cobalt, Emerald, Gold, Amethyst, Pale, Azure, Amber, Pearl, Olive,
        ][i as usize % 12]
    }

    fn opaque(self) -> bool {
        matches!(self, Glass::Lead | Glass::Stone)
    }
}

/// A pane: its glass and an identity that makes it a separate piece (leads go between
/// different labels, so two neighbouring pieces of the same glass still get a lead).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Label(u64);

impl Label {
    fn new(glass: Glass, parts: &[i64]) -> Label {
        Label((rng::hash(0x5eed, parts) & !0xff) | glass as u64)
    }

    fn glass(self) -> Glass {
        Glass::from_index(self.0 & 0xff)
    }
}

const OUTSIDE: Label = Label(Glass::Lead as u64);

/// What a design is drawn on: its size in metres and in pixels.
struct Frame {
    width_m: f32,
    height_m: f32,
    width_px: usize,
    height_px: usize,
}

impl Frame {
    fn new(width_m: f32, height_m: f32, long_side: u32) -> Frame {
        let long = long_side as f32;
        let (width_px, height_px) = if height_m >= width_m {
            (
                ((long * width_m / height_m).round() as usize).max(1),
                long_side as usize,
            )
        } else {
            (
                long_side as usize,
                ((long * height_m / width_m).round() as usize).max(1),
            )
        };
        Frame {
            width_m,
            height_m,
            width_px,
            height_px,
        }
    }

    /// The centre of pixel (i, j) in window metres, y up from the bottom edge.
    fn point(&self, i: usize, j: usize) -> Vec2 {
        Vec2::new(
            (i as f32 + 0.5) * self.width_m / self.width_px as f32,
            self.height_m - (j as f32 + 0.5) * self.height_m / self.height_px as f32,
        )
    }
}

/// Renders one design at `long_side` pixels on its long side.
pub fn render(design: Design, layout: &Layout, long_side: u32, seed: u64) -> RgbImage {
    let seed = rng::hash(seed, &[design as i64]);
    match design {
        Design::Mosaic => {
            let shape = layout.lower;
            let frame = Frame::new(shape.width, shape.height(), long_side);
            paint(&frame, long_side, seed, &|p| mosaic(&shape, p, seed))
        }
        Design::Lancet => {
            let shape = layout.lower;
            let frame = Frame::new(shape.width, shape.height(), long_side);
            paint(&frame, long_side, seed, &|p| lancet(&shape, p, seed))
        }
        Design::Border => {
            let shape = layout.upper;
            let frame = Frame::new(shape.width, shape.height(), long_side);
            paint(&frame, long_side, seed, &|p| border(&shape, p, seed))
        }
        Design::Rose => {
            let r = layout.rose_radius;
            let frame = Frame::new(2.0 * r, 2.0 * r, long_side);
            paint(&frame, long_side, seed, &|p| rose(r, p - Vec2::splat(r)))
        }
    }
}

/// Labels every pixel, finds the leads and colours the panes.
fn paint(
    frame: &Frame,
    long_side: u32,
    seed: u64,
    design: &(dyn Fn(Vec2) -> Label + Sync),
) -> RgbImage {
    let (w, h) = (frame.width_px, frame.height_px);
    let mut labels = vec![OUTSIDE; w * h];
    labels.par_chunks_mut(w).enumerate().for_each(|(j, row)| {
        for (i, l) in row.iter_mut().enumerate() {
            *l = design(frame.point(i, j));
        }
    });
    // Both pixels of every disagreeing pair seed the distance field, so leads are centred on
    // the true boundary.
    let mut seeds = vec![false; w * h];
    for j in 0..h {
        for i in 0..w {
            let k = j * w + i;
            if i + 1 < w && labels[k] != labels[k + 1] {
                seeds[k] = true;
                seeds[k + 1] = true;
            }
            if j + 1 < h && labels[k] != labels[k + w] {
                seeds[k] = true;
                seeds[k + w] = true;
            }
        }
    }
    let dist = distance_transform(&seeds, w, h);
    let scale = long_side as f64 / 1024.0;
    let lead = 1.1 * scale;
    let soft = 7.0 * scale;
    let mut img = RgbImage::new(w as u32, h as u32);
    let buf: &mut [u8] = &mut img;
    buf.par_chunks_mut(w * 3).enumerate().for_each(|(j, row)| {
        for i in 0..w {
            let k = j * w + i;
            let label = labels[k];
            let glass = label.glass();
            let d = dist[k] as f64;
            let lead_rgb = Glass::Lead.rgb();
            let pane = if glass.opaque() {
                glass.rgb()
            } else {
                // Hand-made glass: each sheet a little lighter or darker, a little warmer or
                // cooler; and a touch darker against the lead, where the came shades it.
                let base = glass.rgb();
                let bright = 0.9 + 0.16 * rng::unit(seed, &[label.0 as i64]);
                let tint = [0, 1, 2].map(|c| 10.0 * rng::signed(seed, &[label.0 as i64, c]));
                let edge = 0.84 + 0.16 * smoothstep(lead, lead + soft, d);
                [0, 1, 2].map(|c| ((base[c] + tint[c]) * bright * edge).clamp(0.0, 255.0))
            };
            let cover = 1.0 - smoothstep(lead - 0.6, lead + 0.6, d);
            for c in 0..3 {
                row[i * 3 + c] = dmath::lerp(pane[c], lead_rgb[c], cover).round() as u8;
            }
        }
    });
    img
}

/// Exact Euclidean distance (pixels) to the nearest seed: Felzenszwalb & Huttenlocher's
/// separable lower-envelope algorithm, columns then rows.
fn distance_transform(seeds: &[bool], w: usize, h: usize) -> Vec<f32> {
    const INF: f64 = 1e20;
    let mut grid: Vec<f64> = seeds.iter().map(|&s| if s { 0.0 } else { INF }).collect();
    let mut f = vec![0.0; w.max(h)];
    let mut out = vec![0.0; w.max(h)];
    for i in 0..w {
        for j in 0..h {
            f[j] = grid[j * w + i];
        }
        envelope(&f[..h], &mut out[..h]);
        for j in 0..h {
            grid[j * w + i] = out[j];
        }
    }
    for j in 0..h {
        f[..w].copy_from_slice(&grid[j * w..(j + 1) * w]);
        envelope(&f[..w], &mut out[..w]);
        grid[j * w..(j + 1) * w].copy_from_slice(&out[..w]);
    }
    grid.iter().map(|&d| d.sqrt() as f32).collect()
}

/// 1D squared distance transform of sampled function `f` (the lower envelope of parabolas).
fn envelope(f: &[f64], d: &mut [f64]) {
    let n = f.len();
    let mut v = vec![0usize; n];
    let mut z = vec![0.0f64; n + 1];
    let mut k = 0usize;
    z[0] = f64::NEG_INFINITY;
    z[1] = f64::INFINITY;
    let cross = |q: usize, p: usize| {
        ((f[q] + (q * q) as f64) - (f[p] + (p * p) as f64)) / (2.0 * q as f64 - 2.0 * p as f64)
    };
    for q in 1..n {
        let mut s = cross(q, v[k]);
        // z[0] is -inf, so this stops at k = 0 at the latest.
        while s <= z[k] {
            k -= 1;
            s = cross(q, v[k]);
        }
        k += 1;
        v[k] = q;
        z[k] = s;
        z[k + 1] = f64::INFINITY;
    }
    k = 0;
    for (q, out) in d.iter_mut().enumerate() {
        while z[k + 1] < q as f64 {
            k += 1;
        }
        let dq = q as f64 - v[k] as f64;
        *out = dq * dq + f[v[k]];
    }
}

// ---- shared motifs ------------------------------------------------------------------------

/// The cell of a jittered-grid Voronoi diagram containing `p`.
fn voronoi_cell(p: Vec2, cell: f32, seed: u64) -> (i64, i64) {
    let g = p / cell;
    let (gx, gy) = (g.x.floor() as i64, g.y.floor() as i64);
    let mut best = (f32::INFINITY, (0, 0));
    for dy in -2..=2 {
        for dx in -2..=2 {
            let (cx, cy) = (gx + dx, gy + dy);
            let jx = 0.15 + 0.7 * rng::unit(seed, &[cx, cy, 0]) as f32;
            let jy = 0.15 + 0.7 * rng::unit(seed, &[cx, cy, 1]) as f32;
            let site = Vec2::new(cx as f32 + jx, cy as f32 + jy);
            let d = (site - g).length_squared();
            if d < best.0 {
                best = (d, (cx, cy));
            }
        }
    }
    best.1
}

/// Position along the border of an arch opening, for cutting border bands into pieces: height
/// on the straight sides, continued by arc length over the arch; the bottom edge counts from
/// the left. Returned with a side tag so the two sides never merge.
fn perimeter(shape: &ArchShape, p: Vec2, band: f32) -> (i64, f32) {
    let ys = shape.spring_local();
    if p.y < band {
        return (0, p.x);
    }
    let right = p.x > shape.width / 2.0;
    if p.y <= ys {
        return (if right { 2 } else { 1 }, p.y);
    }
    let (cx, sign) = if right {
        (shape.width - shape.radius, 1.0)
    } else {
        (shape.radius, -1.0)
    };
    let a = dmath::atan2((p.y - ys) as f64, (sign * (p.x - cx)) as f64) as f32;
    (if right { 2 } else { 1 }, ys + a * shape.radius)
}

/// Signed distance to an n-foil: n circles of radius `r` whose centres sit `off` from `c`.
fn foil(p: Vec2, c: Vec2, n: usize, off: f32, r: f32, turn: f64) -> f32 {
    let mut d = f32::INFINITY;
    for k in 0..n {
        let (s, co) = dmath::sin_cos(turn + dmath::TAU * k as f64 / n as f64);
        let centre = c + Vec2::new(co as f32, s as f32) * off;
        d = d.min((p - centre).length() - r);
    }
    d.min((p - c).length() - off)
}

/// Which of `n` equal angular sectors around `c` holds `p` (0 starts at angle `turn`).
fn sector(p: Vec2, c: Vec2, n: usize, turn: f64) -> i64 {
    let a = dmath::angle((p.y - c.y) as f64, (p.x - c.x) as f64) - turn;
    let a = a.rem_euclid(dmath::TAU);
    ((a / dmath::TAU * n as f64).floor() as i64).min(n as i64 - 1)
}

/// An eight-pointed star (two overlapping squares) of circumradius `r`.
fn star8(p: Vec2, c: Vec2, r: f32) -> bool {
    let d = p - c;
    let a = r * std::f32::consts::FRAC_1_SQRT_2;
    (d.x.abs() < a && d.y.abs() < a) || (d.x.abs() + d.y.abs() < r)
}

fn pick(seed: u64, parts: &[i64], choices: &[Glass]) -> Glass {
    choices[(rng::hash(seed, parts) % choices.len() as u64) as usize]
}

// ---- the designs --------------------------------------------------------------------------

/// A Voronoi mosaic: jewel-coloured shards graded from warm at the bottom to deep blue at the
/// top, a golden stem up the middle, three roundels of finer shards, and a beaded border.
fn mosaic(shape: &ArchShape, p: Vec2, seed: u64) -> Label {
    let sd = shape.sdf(p);
    if sd > 0.0 {
        return OUTSIDE;
    }
    let inset = -sd;
    if inset < 0.075 {
        let (side, t) = perimeter(shape, p, 0.075);
        let piece = (t / 0.2).floor() as i64;
        let glass = if piece % 2 == 0 {
            Glass::Ruby
        } else {
            Glass::Gold
        };
        return Label::new(glass, &[1, side, piece]);
    }
    if inset < 0.115 {
        let (side, t) = perimeter(shape, p, 0.115);
        return Label::new(Glass::Pearl, &[2, side, (t / 0.7).floor() as i64]);
    }
    let h = shape.height();
    let cx = shape.width / 2.0;
    for (k, y) in [0.24f32, 0.5, 0.76].iter().enumerate() {
        let c = Vec2::new(cx, y * (h - 1.0) + 0.2);
        let d = (p - c).length();
        let r = 0.56;
        if d < r {
            if d > r - 0.06 {
                let s = sector(p, c, 16, 0.0);
                return Label::new(
                    if s % 2 == 0 {
                        Glass::Gold
                    } else {
                        Glass::Amber
                    },
                    &[3, k as i64, s],
                );
            }
            let (i, j) = voronoi_cell(p, 0.09, seed ^ 0x77);
            let warm = [
                Glass::Ruby,
                Glass::Amber,
                Glass::Gold,
                Glass::Ruby,
                Glass::Amethyst,
            ];
            let cool = [
                Glass::Cobalt,
                Glass::Azure,
                Glass::Emerald,
                Glass::Cobalt,
                Glass::Pale,
            ];
            let g = pick(seed, &[4, i, j], if k == 1 { &cool } else { &warm });
            return Label::new(g, &[4, k as i64, i, j]);
        }
    }
    let (i, j) = voronoi_cell(p, 0.16, seed);
    let site_y = (j as f32 + 0.5) * 0.16 / h;
    let site_x = (i as f32 + 0.5) * 0.16;
    let stem = (site_x - cx).abs() < 0.14;
    let roll = rng::unit(seed, &[5, i, j]);
    let glass = if stem {
        if roll < 0.7 {
            Glass::Gold
        } else {
            Glass::Amber
        }
    } else if roll < 0.12 {
        Glass::Pale
    } else if site_y < 0.33 {
        pick(
            seed,
            &[6, i, j],
            &[
                Glass::Ruby,
                Glass::Ruby,
                Glass::Amethyst,
                Glass::Amber,
                Glass::Emerald,
            ],
        )
    } else if site_y < 0.66 {
        pick(
            seed,
            &[6, i, j],
            &[
                Glass::Emerald,
                Glass::Azure,
                Glass::Olive,
                Glass::Cobalt,
                Glass::Ruby,
            ],
        )
    } else {
        pick(
            seed,
            &[6, i, j],
            &[
                Glass::Cobalt,
                Glass::Cobalt,
                Glass::Azure,
                Glass::Amethyst,
                Glass::Ruby,
            ],
        )
    };
    Label::new(glass, &[7, i, j])
}

/// A lancet of stacked medallions (circles and quatrefoils) holding eight-pointed stars and
/// crosses, on a ground of pale diamond quarries, in a border of ruby and cobalt blocks.
fn lancet(shape: &ArchShape, p: Vec2, seed: u64) -> Label {
    let sd = shape.sdf(p);
    if sd > 0.0 {
        return OUTSIDE;
    }
    let inset = -sd;
    if inset < 0.11 {
        let (side, t) = perimeter(shape, p, 0.11);
        let piece = (t / 0.26).floor() as i64;
        let glass = if piece % 2 == 0 {
            Glass::Ruby
        } else {
            Glass::Cobalt
        };
        return Label::new(glass, &[1, side, piece]);
    }
    if inset < 0.14 {
        let (side, t) = perimeter(shape, p, 0.14);
        return Label::new(Glass::Pearl, &[2, side, (t / 0.5).floor() as i64]);
    }
    let cx = shape.width / 2.0;
    let rows = [0.95f32, 2.45, 3.95];
    for (k, &y) in rows.iter().enumerate() {
        let c = Vec2::new(cx, y);
        let quatre = k % 2 == 1;
        let d = if quatre {
            foil(p, c, 4, 0.3, 0.33, dmath::PI / 4.0)
        } else {
            (p - c).length() - 0.64
        };
        if d < 0.0 {
            let k = k as i64;
            if d > -0.06 {
                let s = sector(p, c, 12, 0.0);
                return Label::new(Glass::Gold, &[3, k, s]);
            }
            let q = p - c;
            if quatre {
                // A cross of emerald with a ruby heart.
                if q.length() < 0.12 {
                    return Label::new(Glass::Ruby, &[4, k]);
                }
                if q.x.abs() < 0.1 || q.y.abs() < 0.1 {
                    let arm = sector(p, c, 4, dmath::PI / 4.0);
                    return Label::new(Glass::Emerald, &[5, k, arm]);
                }
                let s = sector(p, c, 4, 0.0);
                return Label::new(Glass::Ruby, &[6, k, s]);
            }
            if q.length() < 0.11 {
                return Label::new(Glass::Ruby, &[4, k]);
            }
            if star8(p, c, 0.46) {
                let s = sector(p, c, 8, dmath::PI / 8.0);
                return Label::new(
                    if s % 2 == 0 {
                        Glass::Gold
                    } else {
                        Glass::Amber
                    },
                    &[5, k, s],
                );
            }
            let s = sector(p, c, 8, 0.0);
            return Label::new(Glass::Cobalt, &[6, k, s]);
        }
    }
    // Small roundels between the medallions and in the head of the arch.
    for (k, y) in [1.7f32, 3.2, 4.75].iter().enumerate() {
        let c = Vec2::new(cx, *y);
        let d = (p - c).length();
        if d < 0.15 {
            let g = if k % 2 == 0 {
                Glass::Cobalt
            } else {
                Glass::Ruby
            };
            return Label::new(
                if d < 0.06 { Glass::Gold } else { g },
                &[8, k as i64, (d < 0.06) as i64],
            );
        }
    }
    let head = Vec2::new(cx, shape.spring_local() + 0.45);
    if foil(p, head, 3, 0.14, 0.15, dmath::PI / 2.0) < 0.0 {
        let s = sector(p, head, 3, dmath::PI / 6.0);
        return Label::new(
            if (p - head).length() < 0.09 {
                Glass::Gold
            } else {
                Glass::Emerald
            },
            &[9, s],
        );
    }
    // Diamond quarries, a few of them coloured.
    let u = ((p.x - cx) / 0.21 + p.y / 0.34).floor() as i64;
    let v = ((p.x - cx) / 0.21 - p.y / 0.34).floor() as i64;
    let roll = rng::unit(seed, &[10, u, v]);
    let glass = if roll < 0.1 {
        Glass::Azure
    } else if roll < 0.16 {
        Glass::Olive
    } else {
        Glass::Pale
    };
    Label::new(glass, &[11, u, v])
}

/// Clerestory glass: interlaced grisaille circles with coloured bosses around a central
/// quatrefoil, framed by a border of ruby, gold and cobalt blocks each set with a pearl.
fn border(shape: &ArchShape, p: Vec2, seed: u64) -> Label {
    let sd = shape.sdf(p);
    if sd > 0.0 {
        return OUTSIDE;
    }
    let inset = -sd;
    if inset < 0.05 {
        let (side, t) = perimeter(shape, p, 0.05);
        return Label::new(Glass::Pearl, &[1, side, (t / 0.4).floor() as i64]);
    }
    if inset < 0.22 {
        let (side, t) = perimeter(shape, p, 0.22);
        let piece = (t / 0.2).floor() as i64;
        // Each block holds a round jewel at its centre; the two bottom corners are square
        // blocks of their own.
        let corner = p.y < 0.22 && (p.x < 0.22 || p.x > shape.width - 0.22);
        let (side, piece, jewel) = if corner {
            let cx = if p.x < 0.22 {
                0.135
            } else {
                shape.width - 0.135
            };
            (
                3 + (p.x > 0.22) as i64,
                0,
                (p - Vec2::new(cx, 0.135)).length(),
            )
        } else {
            let along = t - (piece as f32 + 0.5) * 0.2;
            let across = inset - 0.135;
            (side, piece, (along * along + across * across).sqrt())
        };
        if jewel < 0.05 {
            return Label::new(Glass::Pearl, &[2, side, piece]);
        }
        let glass = [Glass::Ruby, Glass::Gold, Glass::Cobalt][piece.rem_euclid(3) as usize];
        return Label::new(glass, &[3, side, piece]);
    }
    if inset < 0.25 {
        let (side, t) = perimeter(shape, p, 0.25);
        return Label::new(Glass::Emerald, &[4, side, (t / 0.6).floor() as i64]);
    }
    let cx = shape.width / 2.0;
    let centre = Vec2::new(cx, 1.45);
    let d = foil(p, centre, 4, 0.32, 0.34, 0.0);
    if d < 0.0 {
        if d > -0.06 {
            return Label::new(Glass::Gold, &[5, sector(p, centre, 8, 0.0)]);
        }
        let q = p - centre;
        if q.length() < 0.13 {
            return Label::new(Glass::Ruby, &[6]);
        }
        if star8(p, centre, 0.42) {
            return Label::new(Glass::Gold, &[7, sector(p, centre, 8, dmath::PI / 8.0)]);
        }
        return Label::new(Glass::Cobalt, &[8, sector(p, centre, 4, dmath::PI / 4.0)]);
    }
    let head = Vec2::new(cx, shape.spring_local() + 0.62);
    let dh = (p - head).length();
    if dh < 0.26 {
        if dh > 0.21 {
            return Label::new(Glass::Gold, &[9, sector(p, head, 6, 0.0)]);
        }
        return Label::new(
            if dh < 0.08 { Glass::Ruby } else { Glass::Azure },
            &[10, (dh < 0.08) as i64],
        );
    }
    // Interlaced circles: every grid node and every cell centre carries a circle touching its
    // neighbours, and the lenses where they overlap are separate pieces.
    let g = 0.3f32;
    let q = Vec2::new(p.x - cx, p.y) / g;
    let (i, j) = (q.x.floor() as i64, q.y.floor() as i64);
    let f = q - Vec2::new(i as f32, j as f32);
    let r = 0.5f32;
    let mut mask = 0i64;
    for (bit, c) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0), (0.5, 0.5)]
        .iter()
        .enumerate()
    {
        if (f - Vec2::new(c.0, c.1)).length() < r * if bit == 4 { 0.72 } else { 1.0 } {
            mask |= 1 << bit;
        }
    }
    let boss = (f - Vec2::splat(0.5)).length() < 0.16;
    if boss {
        let glass = if (i + j).rem_euclid(2) == 0 {
            Glass::Ruby
        } else {
            Glass::Cobalt
        };
        return Label::new(glass, &[11, i, j]);
    }
    let roll = rng::unit(seed, &[12, i, j, mask]);
    let glass = match mask.count_ones() {
        0 | 1 => {
            if roll < 0.15 {
                Glass::Olive
            } else {
                Glass::Pale
            }
        }
        _ => Glass::Amber,
    };
    Label::new(glass, &[13, i, j, mask])
}

/// The rose: a central star, a ring of gold bosses, twelve pointed petals between stone
/// spokes, and an outer ring of twenty-four roundels, framed in stone.
fn rose(radius: f32, p: Vec2) -> Label {
    let rn = p.length() / radius;
    let a = dmath::angle(p.y as f64, p.x as f64);
    let stone = |parts: &[i64]| Label::new(Glass::Stone, parts);
    if rn > 0.985 {
        return OUTSIDE;
    }
    if rn > 0.93 {
        return stone(&[1]);
    }
    // Petals point at 90 degrees + k * 30: sector k spans the petal's axis +- 15 degrees.
    let petal_axis = |k: i64| dmath::PI / 2.0 + k as f64 * dmath::TAU / 12.0;
    let k12 = (((a - dmath::PI / 2.0) / (dmath::TAU / 12.0) + 0.5).floor() as i64).rem_euclid(12);
    let off = a - petal_axis(k12);
    let off = (off + dmath::PI).rem_euclid(dmath::TAU) - dmath::PI;
    // Local frame of the sector: along its axis and across it (both in units of the radius).
    let (so, co) = dmath::sin_cos(off);
    let (along, across) = ((rn as f64 * co) as f32, (rn as f64 * so) as f32);
    if rn > 0.785 {
        // Outer ring: 24 roundels on a ground split into halves.
        let k24 =
            (((a - dmath::PI / 2.0) / (dmath::TAU / 24.0) + 0.5).floor() as i64).rem_euclid(24);
        let axis = dmath::PI / 2.0 + k24 as f64 * dmath::TAU / 24.0;
        let (s, c) = dmath::sin_cos(axis);
        let centre = Vec2::new(c as f32, s as f32) * 0.857;
        let d = (p / radius - centre).length();
        if d < 0.058 {
            let glass = if k24 % 2 == 0 {
                Glass::Ruby
            } else {
                Glass::Cobalt
            };
            return Label::new(
                if d < 0.025 { Glass::Pearl } else { glass },
                &[2, k24, (d < 0.025) as i64],
            );
        }
        let half = (((a - axis) + dmath::PI).rem_euclid(dmath::TAU) - dmath::PI > 0.0) as i64;
        return Label::new(
            if k24 % 2 == 0 {
                Glass::Cobalt
            } else {
                Glass::Gold
            },
            &[3, k24, half],
        );
    }
    if rn > 0.76 {
        return stone(&[4]);
    }
    if rn > 0.37 {
        // Stone spokes of constant width between the petals.
        let spoke_half = 0.02f64;
        let gap = (dmath::TAU / 24.0 - off.abs()) * rn as f64;
        if gap < spoke_half {
            return stone(&[5]);
        }
        // The petal: a pointed lancet along the sector axis, cusped at its head.
        let petal = ArchShape {
            width: 0.15,
            sill: 0.0,
            spring: 0.2,
            radius: 0.15,
        };
        let local = Vec2::new(across + petal.width / 2.0, along - 0.41);
        let sd = petal.sdf(local);
        if sd < 0.0 {
            if sd > -0.018 {
                return Label::new(Glass::Ruby, &[6, k12, (local.y / 0.09).floor() as i64]);
            }
            let boss = Vec2::new(petal.width / 2.0, 0.12);
            if (local - boss).length() < 0.04 {
                return Label::new(Glass::Gold, &[7, k12]);
            }
            let head = Vec2::new(petal.width / 2.0, 0.235);
            if (local - head).length() < 0.03 {
                return Label::new(Glass::Emerald, &[8, k12]);
            }
            return Label::new(Glass::Azure, &[9, k12, (local.y > 0.12) as i64]);
        }
        // Spandrels: ruby below the petal head, with a small gold trefoil in each corner.
        let tref = Vec2::new(0.0, 0.69);
        let pl = Vec2::new(across.abs() - 0.11, along) - tref;
        if pl.length() < 0.035 {
            return Label::new(Glass::Gold, &[10, k12, (across > 0.0) as i64]);
        }
        let upper = along > 0.55;
        let glass = if upper { Glass::Cobalt } else { Glass::Ruby };
        return Label::new(glass, &[11, k12, (across > 0.0) as i64, upper as i64]);
    }
    if rn > 0.33 {
        return stone(&[12]);
    }
    if rn > 0.16 {
        // A ring of twelve gold bosses on ruby, with emerald between.
        let (s, c) = dmath::sin_cos(petal_axis(k12));
        let centre = Vec2::new(c as f32, s as f32) * 0.245;
        let d = (p / radius - centre).length();
        if d < 0.055 {
            return Label::new(Glass::Gold, &[13, k12]);
        }
        let glass = if !(0.19..=0.3).contains(&rn) {
            Glass::Emerald
        } else {
            Glass::Ruby
        };
        return Label::new(
            glass,
            &[
                14,
                k12,
                (across > 0.0) as i64,
                (rn > 0.3) as i64 + 2 * (rn < 0.19) as i64,
            ],
        );
    }
    if rn > 0.145 {
        return stone(&[15]);
    }
    let q = p / radius;
    if q.length() < 0.04 {
        return Label::new(Glass::Ruby, &[16]);
    }
    if star8(q, Vec2::ZERO, 0.13) {
        let s = sector(q, Vec2::ZERO, 8, dmath::PI / 8.0);
        return Label::new(Glass::Gold, &[17, s]);
    }
    Label::new(Glass::Cobalt, &[18, sector(q, Vec2::ZERO, 8, 0.0)])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn distance_transform_is_exact_on_a_small_grid() {
        let (w, h) = (9, 7);
        let mut seeds = vec![false; w * h];
        seeds[2 * w + 3] = true;
        seeds[6 * w + 8] = true;
        let d = distance_transform(&seeds, w, h);
        for j in 0..h {
            for i in 0..w {
                let a = ((i as f32 - 3.0).powi(2) + (j as f32 - 2.0).powi(2)).sqrt();
                let b = ((i as f32 - 8.0).powi(2) + (j as f32 - 6.0).powi(2)).sqrt();
                assert!((d[j * w + i] - a.min(b)).abs() < 1e-5, "({i},{j})");
            }
        }
    }
}
