//! Window designs made in the cook: a design rasterized from the panes' own colours with lead
//! cames, a design image fitted to a window's rectangle, and the window's outline as a mask,
//! so a rectangular photo on a pointed lancet throws a pointed patch of light.
//!
//! Everything is rasterized in texture space. Texel row `r` covers `v` in `[r/H, (r+1)/H)`,
//! which is how the renderer samples a texture at a vertex's coordinate.

use image::{Rgba, RgbaImage};

use crate::manifest::Fit;

/// Largest side of a design made or composed by the cook.
pub const MAX_SIDE: u32 = 1024;
/// Lead came colour (sRGB) and opacity: dark and opaque, so it blocks the light.
const CAME: Rgba<u8> = Rgba([22, 20, 18, 255]);
/// Clear glass around a design that does not fill its window (`fit = "contain"`).
const CLEAR: Rgba<u8> = Rgba([255, 255, 255, 255]);

/// A triangle in texture space and the pane (index into the palette) it belongs to.
pub type UvTriangle = ([[f32; 2]; 3], u16);

/// The colour light takes through one pane: linear RGB, and the fraction that passes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pane {
    pub colour: [f32; 3],
    pub amount: f32,
}

/// Linear RGBA at a triangle's three corners (a model's vertex colours), multiplying its
/// pane's colour and the fraction of light it passes.
pub type Tint = [[f32; 4]; 3];

/// How far outside a triangle's edge, in texels, a texel centre still counts as covered.
/// Texture coordinates computed from positions carry f32 rounding: two identical windows in
/// different places put an edge that should pass through a row of centres a few millionths of
/// a texel to either side of it, and their masks differed by that row, so the two copies were
/// not one design. A centre nearer the edge than this is taken on both, far above the noise
/// (about 1e-4 texels on a 1024-texel side) and far below anything drawn on purpose.
const EDGE_SLACK: f64 = 1e-3;

/// Calls `f(triangle, x, y)` for every texel whose centre a triangle covers (within
/// [`EDGE_SLACK`] of its edges), triangles in order. Scanline: per row, the span between the
/// triangle's edges, so the cost is the covered area, not each triangle's bounding box (a fan
/// of long thin triangles has large boxes and little area).
fn scan(tris: &[UvTriangle], w: u32, h: u32, mut f: impl FnMut(usize, u32, u32, [f64; 2])) {
    for (i, (uv, _)) in tris.iter().enumerate() {
        // The texture repeats: a triangle reaching past [0, 1] covers the texels its other
        // tiles land on too (`map_Kd -o 0.5 0.5` put the glass at 0.5–1.5, and three quarters
        // of a design it showed whole were masked away).
        let tiles = |k: usize| {
            let lo = uv.iter().map(|c| c[k] as f64).fold(f64::INFINITY, f64::min);
            let hi = uv
                .iter()
                .map(|c| c[k] as f64)
                .fold(f64::NEG_INFINITY, f64::max);
            if !(lo.is_finite() && hi.is_finite()) {
                return 0..0;
            }
            // Capped: a triangle over more tiles than this is a degenerate mapping.
            let first = lo.floor().max(-1e6) as i64;
            first..(hi.ceil() as i64).clamp(first + 1, first + MAX_TILES)
        };
        for tv in tiles(1) {
            for tu in tiles(0) {
                let shifted = uv.map(|c| [c[0] as f64 - tu as f64, c[1] as f64 - tv as f64]);
                scan_one(shifted, w, h, |x, y| f(i, x, y, [tu as f64, tv as f64]));
            }
        }
    }
}

/// Tiles of the texture one triangle is looked for in, along each axis.
const MAX_TILES: i64 = 64;

/// [`scan`] of one triangle in texture coordinates, clipped to the image.
fn scan_one(uv: [[f64; 2]; 3], w: u32, h: u32, mut f: impl FnMut(u32, u32)) {
    let (wf, hf) = (w as f64, h as f64);
    let p = uv.map(|c| [c[0] * wf, c[1] * hf]);
    let area =
        (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
    if area == 0.0 || !area.is_finite() {
        return;
    }
    let y_min = p.iter().map(|q| q[1]).fold(f64::INFINITY, f64::min);
    let y_max = p.iter().map(|q| q[1]).fold(f64::NEG_INFINITY, f64::max);
    let y0 = (y_min - 0.5 - EDGE_SLACK).ceil().max(0.0) as u32;
    let y1 = ((y_max - 0.5 + EDGE_SLACK).floor() + 1.0).clamp(0.0, hf) as u32;
    for y in y0..y1 {
        let cy = y as f64 + 0.5;
        // Where the row crosses the edges, a row just past a corner taking the corner's
        // end of the edge; a centre on an edge counts as inside.
        let (mut xl, mut xr) = (f64::INFINITY, f64::NEG_INFINITY);
        for k in 0..3 {
            let (a, b) = (p[k], p[(k + 1) % 3]);
            let (lo, hi) = (a[1].min(b[1]), a[1].max(b[1]));
            if cy < lo - EDGE_SLACK || cy > hi + EDGE_SLACK {
                continue;
            }
            if hi - lo <= EDGE_SLACK {
                xl = xl.min(a[0].min(b[0]));
                xr = xr.max(a[0].max(b[0]));
            } else {
                let t = ((cy - a[1]) / (b[1] - a[1])).clamp(0.0, 1.0);
                let x = a[0] + (b[0] - a[0]) * t;
                xl = xl.min(x);
                xr = xr.max(x);
            }
        }
        if xl.partial_cmp(&xr).is_none_or(|o| o.is_gt()) {
            continue;
        }
        let x0 = (xl - 0.5 - EDGE_SLACK).ceil().max(0.0) as u32;
        let x1 = ((xr - 0.5 + EDGE_SLACK).floor() + 1.0).clamp(0.0, wf) as u32;
        for x in x0..x1 {
            f(x, y);
        }
    }
}

/// Pane index + 1 per texel (0 where no triangle covers the texel's centre).
pub fn rasterize(tris: &[UvTriangle], w: u32, h: u32) -> Vec<u16> {
    let mut ids = vec![0u16; (w * h) as usize];
    scan(tris, w, h, |t, x, y, _| {
        ids[(y * w + x) as usize] = tris[t].1 + 1
    });
    ids
}

/// Whether panes of different colours lie on one another in texture space: more than 2% of
/// the covered texels of a 128² raster are covered by two panes (a centre on an edge shared
/// by two panes counts for both, hence not any one texel). A design drawn in such coordinates
/// shows only the pane drawn last.
pub fn panes_overlap(tris: &[UvTriangle]) -> bool {
    const SIDE: u32 = 128;
    let mut ids = vec![0u16; (SIDE * SIDE) as usize];
    let (mut covered, mut both) = (0usize, 0usize);
    scan(tris, SIDE, SIDE, |t, x, y, _| {
        let id = &mut ids[(y * SIDE + x) as usize];
        let pane = tris[t].1 + 1;
        if *id == 0 {
            covered += 1;
            *id = pane;
        } else if *id != pane && *id != u16::MAX {
            both += 1;
            // Counted once, however many panes lie there.
            *id = u16::MAX;
        }
    });
    both * 50 > covered
}

/// `tint` at the centre of texel (`x`, `y`) of triangle `uv` moved back by `tile` (whole
/// repeats of the texture), interpolated across it in texture space (a centre just outside,
/// on an edge, takes the nearest blend).
fn tint_at(
    uv: &[[f32; 2]; 3],
    tile: [f64; 2],
    tint: &Tint,
    x: u32,
    y: u32,
    w: u32,
    h: u32,
) -> [f32; 4] {
    let p = uv.map(|c| {
        [
            (c[0] as f64 - tile[0]) * w as f64,
            (c[1] as f64 - tile[1]) * h as f64,
        ]
    });
    let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    };
    let area = cross(p[0], p[1], p[2]);
    let mut b = [
        cross(p[1], p[2], [cx, cy]) / area,
        cross(p[2], p[0], [cx, cy]) / area,
        cross(p[0], p[1], [cx, cy]) / area,
    ]
    .map(|v| v.max(0.0));
    let sum: f64 = b.iter().sum();
    if sum > 0.0 {
        b = b.map(|v| v / sum);
    } else {
        b = [1.0 / 3.0; 3];
    }
    std::array::from_fn(|c| (0..3).map(|k| b[k] * tint[k][c] as f64).sum::<f64>() as f32)
}

/// A glass's own colour texture times the vertex colours of its triangles, as any other
/// surface shows its texture times its vertex colours (glTF's `COLOR_0` multiplies the base
/// colour texture): each texel a triangle covers (in `tris`' texture space, as [`scan`]
/// counts coverage) takes the colour interpolated there from its corners (`tints`, linear
/// RGBA), in linear light where `srgb`; where triangles overlap, the last one's, as
/// [`rasterize`] takes; texels no triangle covers stay as they are. Textured glass showed
/// the texture alone before, whatever its vertex colours.
pub fn tint_image(image: &mut RgbaImage, tris: &[UvTriangle], tints: &[Tint], srgb: bool) {
    let (w, h) = image.dimensions();
    let decode = texture::srgb::decode8();
    // Last wins: the triangles are scanned in reverse, and a texel is taken once.
    let reversed: Vec<UvTriangle> = tris.iter().rev().copied().collect();
    let mut taken = vec![0u64; (w as usize * h as usize).div_ceil(64)];
    scan(&reversed, w, h, |r, x, y, tile| {
        let i = y as usize * w as usize + x as usize;
        if taken[i / 64] >> (i % 64) & 1 == 1 {
            return;
        }
        taken[i / 64] |= 1 << (i % 64);
        let t = tris.len() - 1 - r;
        let tint = tint_at(&tris[t].0, tile, &tints[t], x, y, w, h);
        let texel = image.get_pixel_mut(x, y);
        for k in 0..3 {
            texel[k] = if srgb {
                texture::srgb::encode8(decode[texel[k] as usize] * tint[k])
            } else {
                texture::srgb::unorm8(texel[k] as f32 / 255.0 * tint[k])
            };
        }
        texel[3] = texture::srgb::unorm8(texel[3] as f32 / 255.0 * tint[3]);
    });
}

/// Distance in texels from each texel to the nearest texel of another pane, of no pane, or
/// beyond the image edge (a 3-4 chamfer transform: within 4 % of the Euclidean distance).
fn boundary_distance(ids: &[u16], w: u32, h: u32) -> Vec<f32> {
    let (w, h) = (w as usize, h as usize);
    let mut d = vec![f32::INFINITY; w * h];
    for y in 0..h {
        for x in 0..w {
            let id = ids[y * w + x];
            let differs = |nx: isize, ny: isize| {
                nx < 0
                    || ny < 0
                    || nx >= w as isize
                    || ny >= h as isize
                    || ids[ny as usize * w + nx as usize] != id
            };
            let (xi, yi) = (x as isize, y as isize);
            if differs(xi - 1, yi)
                || differs(xi + 1, yi)
                || differs(xi, yi - 1)
                || differs(xi, yi + 1)
            {
                d[y * w + x] = 0.0;
            }
        }
    }
    let (a, b) = (1.0f32, 1.4f32);
    for y in 0..h {
        for x in 0..w {
            let mut v = d[y * w + x];
            if x > 0 {
                v = v.min(d[y * w + x - 1] + a);
            }
            if y > 0 {
                v = v.min(d[(y - 1) * w + x] + a);
                if x > 0 {
                    v = v.min(d[(y - 1) * w + x - 1] + b);
                }
                if x + 1 < w {
                    v = v.min(d[(y - 1) * w + x + 1] + b);
                }
            }
            d[y * w + x] = v;
        }
    }
    for y in (0..h).rev() {
        for x in (0..w).rev() {
            let mut v = d[y * w + x];
            if x + 1 < w {
                v = v.min(d[y * w + x + 1] + a);
            }
            if y + 1 < h {
                v = v.min(d[(y + 1) * w + x] + a);
                if x + 1 < w {
                    v = v.min(d[(y + 1) * w + x + 1] + b);
                }
                if x > 0 {
                    v = v.min(d[(y + 1) * w + x - 1] + b);
                }
            }
            d[y * w + x] = v;
        }
    }
    d
}

/// A design from the window's own triangles: each pane in its glass colour (times the
/// triangles' `tints`, interpolated, where the model has vertex colours), lead cames of
/// `came` texels along the outline and between panes of different glass, nothing (alpha 0)
/// outside the outline.
pub fn mesh_design(
    panes: &[Pane],
    tris: &[UvTriangle],
    tints: Option<&[Tint]>,
    w: u32,
    h: u32,
    came: f32,
) -> RgbaImage {
    let texel = |p: Pane, tint: [f32; 4]| {
        let c = std::array::from_fn::<f32, 3, _>(|k| p.colour[k] * tint[k]);
        let c = c.map(texture::srgb::encode8);
        Rgba([c[0], c[1], c[2], texture::srgb::unorm8(p.amount * tint[3])])
    };
    // Which triangle covers each texel, where the tints need it.
    let mut ids = vec![0u16; (w * h) as usize];
    let mut tri_of = tints.map(|_| vec![0u32; (w * h) as usize]);
    scan(tris, w, h, |t, x, y, _| {
        let i = (y * w + x) as usize;
        ids[i] = tris[t].1 + 1;
        if let Some(tri_of) = &mut tri_of {
            tri_of[i] = t as u32;
        }
    });
    let dist = boundary_distance(&ids, w, h);
    // The boundary texels are themselves lead; half the width lies on each side of a seam.
    let half = came * 0.5;
    let flat: Vec<Rgba<u8>> = panes.iter().map(|&p| texel(p, [1.0; 4])).collect();
    RgbaImage::from_fn(w, h, |x, y| {
        let i = (y * w + x) as usize;
        match ids[i] {
            0 => Rgba([0, 0, 0, 0]),
            _ if came > 0.0 && dist[i] < half.max(0.5) => CAME,
            id => match (tints, &tri_of) {
                (Some(tints), Some(tri_of)) => {
                    let t = tri_of[i] as usize;
                    // A design drawn from the panes lays them out in [0, 1]: no tile but the first.
                    let tint = tint_at(&tris[t].0, [0.0; 2], &tints[t], x, y, w, h);
                    texel(panes[id as usize - 1], tint)
                }
                _ => flat[id as usize - 1],
            },
        }
    })
}

/// The model's unit in metres as its windows' sizes tell it, with its name: the median of their
/// longer sides, `long_sides` (scene units), is a window's size in metres (up to 30), in
/// centimetres (up to 1000: 3ds Max, or an inch model, whose designs then come out 2.5x
/// coarser), or in millimetres (Revit, ArchiCAD; a window is 1–5 m, 100–500 cm, 1000–5000
/// mm), and under 0.03 in kilometres. Models carry no unit (OBJ) or one that exporters get wrong, and designs rasterized at
/// 128 texels per *unit* of a centimetre model all hit the 1024-texel cap: the Šibenik
/// stand-in written in centimetres cooked 5.6x slower into a 4.9x larger pack. `None` for
/// metres (or no windows).
pub fn unit_from_windows(long_sides: impl IntoIterator<Item = f64>) -> Option<(f64, &'static str)> {
    let mut sides: Vec<f64> = long_sides
        .into_iter()
        .filter(|s| s.is_finite() && *s > 0.0)
        .collect();
    if sides.is_empty() {
        return None;
    }
    sides.sort_by(f64::total_cmp);
    let median = sides[sides.len() / 2];
    if median < 0.03 {
        // A window under 3 cm long is no window in metres: a model in kilometres (or a
        // miniature), whose designs got the 8-texel floor and rendered as blurred smudges.
        Some((1000.0, "kilometres"))
    } else if median <= 30.0 {
        None
    } else if median <= 1000.0 {
        Some((0.01, "centimetres"))
    } else {
        Some((0.001, "millimetres"))
    }
}

#[cfg(test)]
mod unit_tests {
    use super::unit_from_windows;

    #[test]
    fn the_unit_follows_the_median_window() {
        assert_eq!(unit_from_windows([]), None);
        // Metres: lancets of 2.5 m, a rose of 13 m, a small 0.3 m light.
        assert_eq!(unit_from_windows([2.5, 2.5, 13.0, 0.3]), None);
        assert_eq!(unit_from_windows([30.0]), None);
        // One giant window does not make a metre model centimetres.
        assert_eq!(unit_from_windows([2.0, 3.0, 4000.0]), None);
        assert_eq!(
            unit_from_windows([250.0, 250.0, 1300.0]).unwrap().1,
            "centimetres"
        );
        assert_eq!(unit_from_windows([30.5]).unwrap().0, 0.01);
        assert_eq!(
            unit_from_windows([2500.0, 13000.0, 2500.0]).unwrap().1,
            "millimetres"
        );
        assert_eq!(unit_from_windows([f64::NAN, 0.0, -1.0, 2.0]), None);
        assert_eq!(
            unit_from_windows([0.0025, 0.0025, 0.013]).unwrap(),
            (1000.0, "kilometres")
        );
        assert_eq!(unit_from_windows([0.03]), None);
    }
}

/// The least short side of a design drawn from a window's panes: a lead came of the default
/// 1.5 % is a texel wide there. Windows of 1.2 x 3 cm got 8 x 8 designs, square, with came
/// lines an eighth of the window wide.
pub const MIN_SHORT_SIDE: u32 = 64;

/// Texture size for a design of a `width` × `height` window at `texels_per_metre`, at most
/// [`MAX_SIDE`] on the long side and at least [`MIN_SHORT_SIDE`] on the short one (where the
/// long side allows; 8 at the least), in the window's proportions.
pub fn design_size(width: f64, height: f64, texels_per_metre: f32) -> (u32, u32) {
    let tpm = texels_per_metre as f64;
    let (mut w, mut h) = (width * tpm, height * tpm);
    if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
        return (MIN_SHORT_SIDE, MIN_SHORT_SIDE);
    }
    let short = w.min(h);
    if short < MIN_SHORT_SIDE as f64 {
        w *= MIN_SHORT_SIDE as f64 / short;
        h *= MIN_SHORT_SIDE as f64 / short;
    }
    let long = w.max(h);
    if long > MAX_SIDE as f64 {
        w *= MAX_SIDE as f64 / long;
        h *= MAX_SIDE as f64 / long;
    }
    (
        (w.round() as u32).clamp(8, MAX_SIDE),
        (h.round() as u32).clamp(8, MAX_SIDE),
    )
}

/// Places `design` in a canvas of the window rectangle's aspect ratio (`aspect` = width /
/// height): `cover` crops the excess, `contain` adds clear glass, `stretch` keeps the design
/// as it is (the texture coordinates stretch it).
pub fn fit_design(design: &RgbaImage, fit: Fit, aspect: f64) -> RgbaImage {
    let (iw, ih) = (design.width() as f64, design.height() as f64);
    if fit == Fit::Stretch || aspect.is_nan() || aspect <= 0.0 || !aspect.is_finite() {
        return design.clone();
    }
    let wider = iw / ih > aspect;
    let (cw, ch) = match (fit, wider) {
        (Fit::Cover, true) | (Fit::Contain, false) => ((ih * aspect).round(), ih),
        _ => (iw, (iw / aspect).round()),
    };
    // `contain` of a design far from the window's shape is mostly clear glass: a 4000 x 3
    // strip on a lancet made a 4000 x 12464 canvas (266 MB, 15 s of cooking, 815 MB in the
    // viewer). The canvas is kept within four times the design's texels (or MAX_SIDE²), the
    // design reduced with it.
    let limit = (4.0 * iw * ih).max((MAX_SIDE as f64).powi(2));
    if cw * ch > limit {
        let s = (limit / (cw * ch)).sqrt();
        let (w, h) = (
            ((iw * s).round() as u32).max(1),
            ((ih * s).round() as u32).max(1),
        );
        let smaller = image::imageops::resize(design, w, h, image::imageops::FilterType::Triangle);
        let (cw, ch) = (
            ((cw * s).round() as u32).max(1),
            ((ch * s).round() as u32).max(1),
        );
        return centred(&smaller, cw, ch);
    }
    let (cw, ch) = (cw.max(1.0) as u32, ch.max(1.0) as u32);
    centred(design, cw, ch)
}

/// `design` centred in a `cw x ch` canvas of clear glass, cropped where it is larger.
fn centred(design: &RgbaImage, cw: u32, ch: u32) -> RgbaImage {
    let (iw, ih) = (design.width() as f64, design.height() as f64);
    // The design's centre goes to the canvas centre; both are sampled on the same texel grid.
    let dx = (iw as i64 - cw as i64) / 2;
    let dy = (ih as i64 - ch as i64) / 2;
    RgbaImage::from_fn(cw, ch, |x, y| {
        let (sx, sy) = (x as i64 + dx, y as i64 + dy);
        if sx < 0 || sy < 0 || sx >= iw as i64 || sy >= ih as i64 {
            CLEAR
        } else {
            *design.get_pixel(sx as u32, sy as u32)
        }
    })
}

/// How far past the texture's square `[0, 1]²` texture coordinates may reach and still place
/// the design as they are: a projector covers that square, and exporters write 1.0001 for 1.
pub const UV_SLACK: f32 = 0.01;

/// The bounds `[u_min, v_min, u_max, v_max]` of triangles' texture coordinates where they
/// reach past the texture's square by more than [`UV_SLACK`] (tiled glass, or coordinates in
/// metres as SketchUp writes them), else `None`.
pub fn beyond_unit_square(tris: &[UvTriangle]) -> Option<[f32; 4]> {
    let mut b = [
        f32::INFINITY,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NEG_INFINITY,
    ];
    for c in tris.iter().flat_map(|(uv, _)| uv) {
        b = [
            b[0].min(c[0]),
            b[1].min(c[1]),
            b[2].max(c[0]),
            b[3].max(c[1]),
        ];
    }
    let finite = b.iter().all(|v| v.is_finite());
    (finite && (b[0].min(b[1]) < -UV_SLACK || b[2].max(b[3]) > 1.0 + UV_SLACK)).then_some(b)
}

/// `design` as the glass shows it, drawn on the window's planar coordinates: every texel a
/// triangle of `planar` covers takes the design where the same triangle of `source` (its own
/// texture coordinates, in the same order) puts that point, the texture repeating as a
/// renderer repeats it, filtered bilinearly. Texels no glass covers are transparent.
pub fn bake(
    planar: &[UvTriangle],
    source: &[UvTriangle],
    design: &RgbaImage,
    w: u32,
    h: u32,
) -> RgbaImage {
    let mut out = RgbaImage::new(w, h);
    let (dw, dh) = (design.width() as i64, design.height() as i64);
    if dw == 0 || dh == 0 {
        return out;
    }
    let texel = |x: i64, y: i64| design.get_pixel(x.rem_euclid(dw) as u32, y.rem_euclid(dh) as u32);
    scan(planar, w, h, |t, x, y, tile| {
        let p = planar[t].0.map(|c| {
            [
                (c[0] as f64 - tile[0]) * w as f64,
                (c[1] as f64 - tile[1]) * h as f64,
            ]
        });
        let (cx, cy) = (x as f64 + 0.5, y as f64 + 0.5);
        let det =
            (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (p[1][1] - p[0][1]);
        if det == 0.0 || !det.is_finite() {
            return;
        }
        let b1 =
            ((cx - p[0][0]) * (p[2][1] - p[0][1]) - (p[2][0] - p[0][0]) * (cy - p[0][1])) / det;
        let b2 =
            ((p[1][0] - p[0][0]) * (cy - p[0][1]) - (cx - p[0][0]) * (p[1][1] - p[0][1])) / det;
        let b0 = 1.0 - b1 - b2;
        let uv = source[t].0;
        let at = |k: usize| b0 * uv[0][k] as f64 + b1 * uv[1][k] as f64 + b2 * uv[2][k] as f64;
        // Texel centres sit at half-integers, as the renderer samples them.
        let (sx, sy) = (at(0) * dw as f64 - 0.5, at(1) * dh as f64 - 0.5);
        if !(sx.is_finite() && sy.is_finite()) || sx.abs().max(sy.abs()) > 1e9 {
            return;
        }
        let (x0, y0) = (sx.floor(), sy.floor());
        let (fx, fy) = (sx - x0, sy - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let mut c = [0.0f64; 4];
        for (dx, dy, wgt) in [
            (0, 0, (1.0 - fx) * (1.0 - fy)),
            (1, 0, fx * (1.0 - fy)),
            (0, 1, (1.0 - fx) * fy),
            (1, 1, fx * fy),
        ] {
            let q = texel(x0 + dx, y0 + dy);
            for k in 0..4 {
                c[k] += wgt * q[k] as f64;
            }
        }
        out.put_pixel(x, y, Rgba(c.map(|v| v.round().clamp(0.0, 255.0) as u8)));
    });
    out
}

/// The shorter side below which a design cannot draw a window's outline: [`outline_resolved`]
/// filters such a design up before it is masked.
pub const OUTLINE_SIDE: u32 = 32;

/// `design` filtered up, by a whole factor per axis, until its texels are no longer on the
/// window than a [`OUTLINE_SIDE`]th of the window's shorter side (`extent`: the window's
/// width and height, the design stretched onto them), when they are longer; else `None`.
/// Each side stays within [`MAX_SIDE`]. Filtered as a renderer samples the small image:
/// bilinear in linear light, edges clamped. A 3 x 1000 design was left as it was, and its
/// mask three texels across lost the lancet's point; a 2048 x 8 one on a lancet 4 m high was
/// filtered up to 32 rows, each 12 cm of the window, and the floor's patch had a stepped
/// point; a 2 x 2 design's panes were blended in sRGB bytes, darker between than the
/// renderer's own filtering of them.
pub fn outline_resolved(design: &RgbaImage, extent: (f64, f64)) -> Option<RgbaImage> {
    let (w, h) = design.dimensions();
    if w == 0 || h == 0 {
        return None;
    }
    let (ew, eh) = extent;
    let short = ew.min(eh);
    // Texels each axis needs: OUTLINE_SIDE across the shorter side, about as many per metre
    // along the other (a tenth longer passes: a square photo stretched onto a lancet 6.26
    // times its width, 200 texels up it, is fine as it is). A degenerate extent counts as
    // square.
    let need = |along: f64| -> u32 {
        let ratio = if short > 0.0 && along.is_finite() && short.is_finite() {
            (along / short / 1.1).clamp(1.0, MAX_SIDE as f64 / OUTLINE_SIDE as f64)
        } else {
            1.0
        };
        (OUTLINE_SIDE as f64 * ratio).ceil() as u32
    };
    let factor = |s: u32, need: u32| {
        if s < need {
            need.div_ceil(s).min((MAX_SIDE / s).max(1))
        } else {
            1
        }
    };
    let (fx, fy) = (factor(w, need(ew)), factor(h, need(eh)));
    if fx == 1 && fy == 1 {
        return None;
    }
    let decode = texture::srgb::decode8();
    let linear = image::Rgba32FImage::from_fn(w, h, |x, y| {
        let p = design.get_pixel(x, y).0;
        image::Rgba([
            decode[p[0] as usize],
            decode[p[1] as usize],
            decode[p[2] as usize],
            p[3] as f32 / 255.0,
        ])
    });
    let up = image::imageops::resize(
        &linear,
        w * fx,
        h * fy,
        image::imageops::FilterType::Triangle,
    );
    let encoder = texture::srgb::encoder();
    let texels: Vec<[f32; 4]> = up.pixels().map(|p| p.0).collect();
    let mut bytes = vec![0u8; texels.len() * 4];
    encoder.encode_rgba(&texels, &mut bytes);
    RgbaImage::from_raw(w * fx, h * fy, bytes)
}

/// The window's coverage in texture space at the image's size.
pub fn coverage(tris: &[UvTriangle], w: u32, h: u32) -> Vec<bool> {
    rasterize(tris, w, h).into_iter().map(|i| i != 0).collect()
}

/// Whether `design` lets light through where the window has no glass: a texel outside the
/// outline grown by one texel passes 1/64 of the light or more (alpha times the brightest
/// channel). A design whose light stays within a texel of the outline (its edges antialiased
/// differently) is left as it is. It counted only texels passing a quarter of the light, over
/// 0.5 % of the image: a design whose alpha fades in from the top kept 7020 dim texels of
/// light round a lancet's point, on the floor through stone. A design under 16 texels a side
/// is not grown round: one texel is a third of a 3-texel-wide design, whose corners outside a
/// pointed lancet's arch were all "near" the outline, so it was never cut to it.
pub fn light_outside(design: &RgbaImage, mask: &[bool]) -> bool {
    let (w, h) = (design.width() as i64, design.height() as i64);
    let grow = if w.min(h) >= 16 { 1 } else { 0 };
    let near = |x: i64, y: i64| {
        (-grow..=grow).any(|dy| {
            (-grow..=grow).any(|dx| {
                let (nx, ny) = (x + dx, y + dy);
                nx >= 0 && ny >= 0 && nx < w && ny < h && mask[(ny * w + nx) as usize]
            })
        })
    };
    (0..h).any(|y| {
        (0..w).any(|x| {
            let p = design.get_pixel(x as u32, y as u32);
            let light = p[3] as u32 * p[0].max(p[1]).max(p[2]) as u32;
            light * 64 >= 255 * 255 && !near(x, y)
        })
    })
}

/// Clears the design outside the mask (no glass: no colour, no light).
pub fn apply_mask(design: &mut RgbaImage, mask: &[bool]) {
    for (p, &m) in design.pixels_mut().zip(mask) {
        if !m {
            *p = Rgba([0, 0, 0, 0]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three panes each mapped to the whole square overlap; the same panes side by side, or
    /// one pane drawn as two triangles sharing an edge, do not.
    #[test]
    fn panes_on_one_another_are_told_from_panes_side_by_side() {
        let stacked: Vec<UvTriangle> = (0..3).flat_map(|p| quad(0.0, 0.0, 1.0, 1.0, p)).collect();
        assert!(panes_overlap(&stacked));
        let side_by_side: Vec<UvTriangle> = (0..3)
            .flat_map(|p| quad(p as f32 / 3.0, 0.0, (p + 1) as f32 / 3.0, 1.0, p))
            .collect();
        assert!(!panes_overlap(&side_by_side));
        // Edges on texel centres (1/4 of 128 texels is 32, centres at k + 0.5: not on them;
        // 0.5 / 128 is): two panes meeting on a row of centres still do not overlap.
        let at_centres = [
            quad(0.0, 0.0, 1.0, 0.5 + 0.5 / 128.0, 0),
            quad(0.0, 0.5 + 0.5 / 128.0, 1.0, 1.0, 1),
        ]
        .concat();
        assert!(!panes_overlap(&at_centres));
        // One pane partly over another, a third of it: overlap.
        let partly = [quad(0.0, 0.0, 0.6, 1.0, 0), quad(0.4, 0.0, 1.0, 1.0, 1)].concat();
        assert!(panes_overlap(&partly));
    }

    /// A window's outline whose edges pass through rows and columns of texel centres, moved by
    /// the f32 rounding that coordinates computed from another copy's positions carry, covers
    /// the same texels: two identical windows make one design.
    #[test]
    fn rounding_noise_on_an_edge_through_centres_changes_no_texel() {
        let (w, h) = (64u32, 32u32);
        let (u0, v0, u1, v1) = (8.5 / 64.0, 4.5 / 32.0, 40.5 / 64.0, 20.5 / 32.0);
        let exact = rasterize(&quad(u0, v0, u1, v1, 0), w, h);
        let covered = exact.iter().filter(|&&id| id != 0).count();
        // Centres on the edges count: columns 8..=40, rows 4..=20.
        assert_eq!(covered, 33 * 17);
        for (du, dv) in [(1, 1), (-1, -1), (1, -1), (-1, 1), (3, -2)] {
            let nudge = |x: f32, d: i32| f32::from_bits((x.to_bits() as i32 + d) as u32);
            let noisy = quad(
                nudge(u0, du),
                nudge(v0, dv),
                nudge(u1, -du),
                nudge(v1, -dv),
                0,
            );
            assert_eq!(
                rasterize(&noisy, w, h),
                exact,
                "nudged by ({du}, {dv}) ulps"
            );
        }
        // A thousandth of a texel and more is drawn as it is: an edge a tenth of a texel
        // past a column of centres leaves that column out.
        let inset = quad(u0 + 0.1 / 64.0, v0, u1, v1, 0);
        let fewer = rasterize(&inset, w, h)
            .iter()
            .filter(|&&id| id != 0)
            .count();
        assert_eq!(fewer, 32 * 17);
    }

    /// Two quads over one texture, the second overlapping the first's right half: a texel
    /// takes the colour of the last quad covering it, once, in linear light (sRGB) or as it
    /// is (linear); texels no quad covers are left alone.
    #[test]
    fn a_texture_is_tinted_by_the_last_triangle_over_each_texel() {
        let grey = Rgba([188, 188, 188, 200]);
        let red = [[1.0, 0.0, 0.0, 1.0]; 3];
        let half = [[0.5, 0.5, 0.5, 0.5]; 3];
        let mut tris = quad(0.0, 0.0, 0.5, 1.0, 0).to_vec();
        tris.extend(quad(0.25, 0.0, 0.75, 1.0, 0));
        let tints = [red, red, half, half];
        for srgb in [true, false] {
            let mut img = RgbaImage::from_pixel(8, 4, grey);
            tint_image(&mut img, &tris, &tints, srgb);
            let halved = if srgb {
                // sRGB 188 is linear 0.5029; half of it is sRGB 137.
                Rgba([137, 137, 137, 100])
            } else {
                Rgba([94, 94, 94, 100])
            };
            for (x, y, p) in img.enumerate_pixels() {
                let want = match x {
                    0 | 1 => Rgba([188, 0, 0, 200]),
                    2..=5 => halved,
                    _ => grey,
                };
                assert_eq!(*p, want, "srgb {srgb}, texel ({x}, {y})");
            }
        }
    }

    fn quad(u0: f32, v0: f32, u1: f32, v1: f32, pane: u16) -> [UvTriangle; 2] {
        [
            ([[u0, v0], [u1, v0], [u1, v1]], pane),
            ([[u0, v0], [u1, v1], [u0, v1]], pane),
        ]
    }

    /// The texture repeats: glass at 0.5–1.5 (an MTL `-o 0.5 0.5`) covers every texel, as
    /// glass at 0–1 does; glass at 0.25–0.75 covers its middle only. Tints follow the tile.
    #[test]
    fn coverage_wraps_as_the_texture_repeats() {
        let all = |t: &[UvTriangle]| coverage(t, 8, 8).iter().filter(|&&c| c).count();
        assert_eq!(all(&quad(0.0, 0.0, 1.0, 1.0, 0)), 64);
        assert_eq!(all(&quad(0.5, 0.5, 1.5, 1.5, 0)), 64);
        assert_eq!(all(&quad(-3.5, 2.5, -2.5, 3.5, 0)), 64);
        assert_eq!(all(&quad(0.25, 0.25, 0.75, 0.75, 0)), 16);
        assert_eq!(all(&quad(1.25, 0.25, 1.75, 0.75, 0)), 16);
        let tris = quad(0.5, 0.5, 1.5, 1.5, 0);
        let half = [[0.5f32, 0.5, 0.5, 1.0]; 3];
        let mut image = RgbaImage::from_pixel(8, 8, Rgba([200, 200, 200, 255]));
        tint_image(&mut image, &tris, &[half, half], false);
        assert!(
            image.pixels().all(|p| p.0 == [100, 100, 100, 255]),
            "{image:?}"
        );
    }

    #[test]
    fn panes_get_their_colour_and_lead_between_them() {
        let mut tris = quad(0.0, 0.0, 0.5, 1.0, 0).to_vec();
        tris.extend(quad(0.5, 0.0, 1.0, 1.0, 1));
        let panes = [
            Pane {
                colour: [1.0, 0.0, 0.0],
                amount: 1.0,
            },
            Pane {
                colour: [0.0, 0.0, 1.0],
                amount: 1.0,
            },
        ];
        let img = mesh_design(&panes, &tris, None, 100, 50, 4.0);
        assert_eq!(*img.get_pixel(25, 25), Rgba([255, 0, 0, 255]));
        assert_eq!(*img.get_pixel(75, 25), Rgba([0, 0, 255, 255]));
        // The seam at x = 50 and the outline are lead, 4 texels wide in all.
        for x in 48..52 {
            assert_eq!(*img.get_pixel(x, 25), CAME, "x {x}");
        }
        assert_eq!(*img.get_pixel(46, 25), Rgba([255, 0, 0, 255]));
        assert_eq!(*img.get_pixel(0, 25), CAME);
        assert_eq!(*img.get_pixel(1, 25), CAME);
        assert_eq!(*img.get_pixel(3, 25), Rgba([255, 0, 0, 255]));
    }

    /// A white design 3 texels wide on a window whose top narrows to a point: the top rows'
    /// corners lie outside the outline and pass light, so the design is cut to it.
    #[test]
    fn a_narrow_design_on_a_pointed_window_lets_light_outside() {
        let (w, h) = (3u32, 40u32);
        let white = RgbaImage::from_pixel(w, h, Rgba([255; 4]));
        // Full width below v = 0.25, a triangle up to the apex above.
        let tris: Vec<UvTriangle> = vec![
            ([[0.0, 0.25], [1.0, 0.25], [1.0, 1.0]], 0),
            ([[0.0, 0.25], [1.0, 1.0], [0.0, 1.0]], 0),
            ([[0.0, 0.25], [0.5, 0.0], [1.0, 0.25]], 0),
        ];
        let mask = coverage(&tris, w, h);
        assert!(mask.iter().any(|&m| !m));
        assert!(light_outside(&white, &mask));
        let mut cut = white.clone();
        apply_mask(&mut cut, &mask);
        assert_eq!(cut.get_pixel(0, 0)[3], 0);
        assert_eq!(cut.get_pixel(1, 39)[3], 255);
    }

    #[test]
    fn a_pointed_outline_masks_a_rectangular_design() {
        // A lancet: a rectangle below v = 0.6 and a triangle up to a point at (0.5, 1).
        let mut tris = quad(0.0, 0.0, 1.0, 0.6, 0).to_vec();
        tris.push(([[0.0, 0.6], [1.0, 0.6], [0.5, 1.0]], 0));
        let mask = coverage(&tris, 40, 100);
        let mut photo = RgbaImage::from_pixel(40, 100, Rgba([200, 150, 100, 255]));
        assert!(light_outside(&photo, &mask));
        apply_mask(&mut photo, &mask);
        assert_eq!(photo.get_pixel(20, 95)[3], 255, "the point itself is glass");
        assert_eq!(photo.get_pixel(2, 95)[3], 0, "beside the point is stone");
        assert_eq!(photo.get_pixel(2, 30)[3], 255);
        assert!(!light_outside(&photo, &mask));
    }

    /// A design of faint light (alpha faded to a sixth round a lancet's point, a glow, a
    /// vignette) lets it through stone: cut to the outline too; one dark outside but for its
    /// antialiased edge, a texel wide, is left as it is.
    #[test]
    fn faint_light_outside_the_outline_is_cut_and_an_antialiased_edge_is_not() {
        let mut tris = quad(0.0, 0.0, 1.0, 0.6, 0).to_vec();
        tris.push(([[0.0, 0.6], [1.0, 0.6], [0.5, 1.0]], 0));
        let (w, h) = (60u32, 120u32);
        let mask = coverage(&tris, w, h);
        // A sixth of the light round the point, wherever the image puts it.
        let faded = RgbaImage::from_pixel(w, h, Rgba([230, 200, 120, 40]));
        assert!(light_outside(&faded, &mask));
        // The outline's own texels, and half-covered ones a texel beyond it, light: kept.
        let edged = RgbaImage::from_fn(w, h, |x, y| {
            let near = (-1i64..=1).any(|d| {
                let nx = x as i64 + d;
                nx >= 0 && nx < w as i64 && mask[(y * w) as usize + nx as usize]
            });
            if near {
                Rgba([230, 200, 120, 255])
            } else {
                Rgba([0, 0, 0, 0])
            }
        });
        assert!(!light_outside(&edged, &mask));
    }

    /// A design too small to draw an outline is filtered up until its texels are a 32nd of
    /// the window's shorter side, per axis, within the cap: a thin and long one across alone,
    /// one on a tall lancet (1.2 x 4 m) up its height too.
    #[test]
    fn small_and_thin_designs_are_filtered_up_to_draw_an_outline() {
        let size =
            |w, h, extent| outline_resolved(&RgbaImage::new(w, h), extent).map(|i| i.dimensions());
        let square = (1.0, 1.0);
        assert_eq!(size(20, 100, square), Some((40, 100)));
        assert_eq!(size(3, 1000, square), Some((33, 1000)));
        assert_eq!(size(1000, 8, square), Some((1000, 32)));
        assert_eq!(size(40, 40, square), None);
        // 1.2 x 4.04 m: 32 texels across, 98 up (a tenth longer than a 32nd of the width).
        assert_eq!(size(2048, 8, (1.2, 4.04)), Some((2048, 104)));
        assert_eq!(size(2, 2, (1.2, 4.04)), Some((32, 98)));
        assert_eq!(size(64, 200, (1.2, 4.04)), None);
        // A window ever so long stays within the cap.
        assert_eq!(size(4, 4, (1.0, 1e9)), Some((32, 1024)));
    }

    /// Filtered up in linear light, as the renderer filters the small design: between a red
    /// and a green texel the upscaled design is (188, 188, 0), not the sRGB bytes' (128,
    /// 128, 0).
    #[test]
    fn a_small_design_is_filtered_up_in_linear_light() {
        let d = RgbaImage::from_fn(2, 1, |x, _| {
            Rgba(if x == 0 {
                [255, 0, 0, 255]
            } else {
                [0, 255, 0, 255]
            })
        });
        let up = outline_resolved(&d, (2.0, 1.0)).unwrap();
        let (w, h) = up.dimensions();
        let mid = up.get_pixel(w / 2, h / 2).0;
        let mid2 = up.get_pixel(w / 2 - 1, h / 2).0;
        // The two texels either side of the middle straddle the 50 % mix.
        let g = (mid[0] as u32 + mid2[0] as u32) / 2;
        assert!((180..=196).contains(&g), "{mid:?} {mid2:?}");
        assert_eq!(mid[3], 255);
    }

    #[test]
    fn fit_cover_crops_and_contain_pads() {
        let d = RgbaImage::from_fn(200, 100, |x, _| Rgba([(x / 100) as u8 * 255, 0, 0, 255]));
        let c = fit_design(&d, Fit::Cover, 1.0);
        assert_eq!(c.dimensions(), (100, 100));
        assert_eq!(c.get_pixel(0, 0)[0], 0);
        assert_eq!(c.get_pixel(99, 0)[0], 255);
        let c = fit_design(&d, Fit::Contain, 1.0);
        assert_eq!(c.dimensions(), (200, 200));
        assert_eq!(*c.get_pixel(100, 10), CLEAR);
        assert_eq!(c.get_pixel(150, 100)[0], 255);
        assert_eq!(fit_design(&d, Fit::Stretch, 1.0).dimensions(), (200, 100));
    }

    /// `contain` of a strip on a lancet: the canvas stays within four times the design's
    /// texels or MAX_SIDE², of the window's shape, the strip reduced and centred in it; a
    /// square design on a 1:3 lancet is kept whole at its size.
    #[test]
    fn contain_keeps_a_strip_s_canvas_bounded() {
        let strip = RgbaImage::from_pixel(4000, 3, Rgba([200, 30, 30, 255]));
        let c = fit_design(&strip, Fit::Contain, 0.321);
        let (w, h) = c.dimensions();
        assert!(
            (w * h) as f64 <= (MAX_SIDE as f64).powi(2) * 1.01,
            "{w}x{h}"
        );
        assert!(((w as f64 / h as f64) - 0.321).abs() < 0.01, "{w}x{h}");
        assert_eq!(c.get_pixel(w / 2, h / 2)[0], 200);
        assert_eq!(*c.get_pixel(w / 2, 0), CLEAR);
        let square = RgbaImage::from_pixel(1024, 1024, Rgba([30, 30, 200, 255]));
        assert_eq!(
            fit_design(&square, Fit::Contain, 1.0 / 3.0).dimensions(),
            (1024, 3072)
        );
    }

    #[test]
    fn design_size_follows_the_window_and_is_capped() {
        assert_eq!(design_size(2.0, 6.0, 100.0), (200, 600));
        assert_eq!(design_size(2.0, 6.0, 1000.0), (341, 1024));
        // Small windows keep their proportions, their short side 64 texels.
        assert_eq!(design_size(0.01, 0.01, 100.0), (64, 64));
        assert_eq!(design_size(0.012, 0.03, 128.0), (64, 160));
        assert_eq!(design_size(0.3, 1.0, 128.0), (64, 213));
        // Very thin ones as far as the long side's cap allows, and 8 texels at least.
        assert_eq!(design_size(0.01, 1.0, 128.0), (10, 1024));
        assert_eq!(design_size(0.001, 1.0, 128.0), (8, 1024));
        assert_eq!(design_size(0.0, 1.0, 128.0), (64, 64));
    }
}
