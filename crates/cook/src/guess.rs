//! What a bare model does not say: a sun whose light, through the windows, lands on the floor,
//! and a few cameras inside the building. `cooker init` writes these into a starter manifest,
//! and a bare `cooker cook model.obj` uses them directly, so a model from another tool shows
//! stained-glass light without hand edits.

use glam::{DVec2, DVec3, Vec3Swizzles};
use pack::MaterialClass;

use crate::Prepared;
use crate::instances::triangle;
use crate::manifest::{Camera, Light};
use crate::windows::f3;

/// The sun's angular diameter.
const SUN_DEG: f32 = 0.53;
/// Cells per side of the floor's footprint grid.
const GRID: usize = 256;

/// The guessed light and cameras, and what decided them.
#[derive(Clone, Debug)]
pub struct Guess {
    pub light: Option<Light>,
    pub cameras: Vec<Camera>,
    pub notes: Vec<String>,
}

/// The floor's footprint seen from above, for "does this ray land on the floor".
struct Footprint {
    lo: DVec2,
    cell: DVec2,
    y: f64,
    covered: Vec<bool>,
}

impl Footprint {
    /// `tris` yields the floor's triangles, twice (bounds, then the raster): held as 72-byte
    /// corners, a 100k-triangle floor was the largest block of a bare mesh's cook.
    fn new<I: Iterator<Item = [DVec3; 3]>>(tris: impl Fn() -> I) -> Option<Self> {
        let mut lo = DVec2::splat(f64::INFINITY);
        let mut hi = DVec2::splat(f64::NEG_INFINITY);
        let mut y = 0.0;
        let mut area = 0.0;
        for t in tris() {
            for p in t {
                lo = lo.min(p.xz());
                hi = hi.max(p.xz());
            }
            let a = (t[1] - t[0]).cross(t[2] - t[0]).length() * 0.5;
            y += a * (t[0].y + t[1].y + t[2].y) / 3.0;
            area += a;
        }
        if area.is_nan() || area <= 0.0 || hi.x.is_nan() || hi.x <= lo.x || hi.y <= lo.y {
            return None;
        }
        let cell = (hi - lo) / GRID as f64;
        // The footprint in [0, 1]², rasterized like a window's outline.
        let flat: Vec<crate::design::UvTriangle> = tris()
            .map(|t| {
                (
                    t.map(|p| ((p.xz() - lo) / (hi - lo)).as_vec2().to_array()),
                    0,
                )
            })
            .collect();
        let covered = crate::design::coverage(&flat, GRID as u32, GRID as u32);
        Some(Self {
            lo,
            cell,
            y: y / area,
            covered,
        })
    }

    /// Where a ray from `p` along `d` (downwards) meets the floor, if it lands on it.
    fn land(&self, p: DVec3, d: DVec3) -> Option<DVec3> {
        if d.y >= -1e-6 || p.y <= self.y {
            return None;
        }
        let hit = p + d * ((self.y - p.y) / d.y);
        let c = (hit.xz() - self.lo) / self.cell;
        if c.x < 0.0 || c.y < 0.0 || c.x >= GRID as f64 || c.y >= GRID as f64 {
            return None;
        }
        self.covered[c.y as usize * GRID + c.x as usize].then_some(hit)
    }
}

/// Guesses a sun and cameras for the prepared scene (see the module documentation). The sun
/// is the direction, among 5 elevations × 24 azimuths, through which the most window area
/// (sampled on a 5 × 5 grid of each window's rectangle) lands on the floor, ties going to
/// elevations near 45°. Occluders between a window and the floor are not considered.
/// Which cells of a 64³ grid over the model hold a surface (not glass, not the backdrop):
/// enough to tell whether a view runs down an open nave or into a pier, at the cost of one
/// pass over the triangles, where ray casting every triangle for every trial view costs
/// hundreds of milliseconds on a large model.
struct Occupancy {
    lo: DVec3,
    cell: DVec3,
    full: Vec<bool>,
}

const OCC: usize = 64;

impl Occupancy {
    fn new(p: &Prepared, classes: &[MaterialClass], lo: DVec3, hi: DVec3) -> Self {
        use rayon::prelude::*;
        let cell =
            ((hi - lo) / OCC as f64).max(DVec3::splat((hi - lo).max_element() * 1e-3 + 1e-9));
        let mut grid = Self {
            lo,
            cell,
            full: vec![false; OCC * OCC * OCC],
        };
        // Chunks of triangles mark grids of their own, or-ed together: the same cells whatever
        // the split.
        const CHUNK: usize = 1 << 14;
        let marked = p
            .imported
            .iter()
            .zip(&p.tri_material)
            .flat_map(|(src, mats)| {
                (0..mats.len())
                    .step_by(CHUNK)
                    .map(move |t0| (src, mats, t0..(t0 + CHUNK).min(mats.len())))
            })
            .collect::<Vec<_>>()
            .into_par_iter()
            .fold(
                || vec![false; OCC * OCC * OCC],
                |mut full, (src, mats, range)| {
                    for t in range {
                        let c = classes[mats[t] as usize];
                        if c.is_window() || c == MaterialClass::Background {
                            continue;
                        }
                        let [a, b, c] = triangle(src, t as u32);
                        // A triangle within one row of cells marks that row from its lowest
                        // cell to its highest (rows are convex, and so are triangles).
                        if let Some(cells) = grid.row_span([a, b, c]) {
                            for k in cells {
                                full[k] = true;
                            }
                            continue;
                        }
                        // Points on the triangle at most half a cell apart on every axis mark
                        // every cell it crosses; they are placed in cell units (no divide per
                        // point), and counted in them: cells are flat where the bounds are (a
                        // height field's), and a count from the smallest cell side sampled
                        // such a mesh's steep triangles at a hundred times the points.
                        let [a, b, c] = [a, b, c].map(|q| (q - grid.lo) / grid.cell);
                        let (ab, ac) = (b - a, c - a);
                        // Rows across ab, points along ac within each row, each edge cut into
                        // steps of at most half a cell on every axis: a height field's
                        // triangles are steep along one edge only, and one count for both
                        // edges sampled them at several times the points.
                        let steps = |e: DVec3| {
                            ((e.abs().max_element() / 0.5).ceil() as usize).clamp(1, 4 * OCC)
                        };
                        let (n, m) = (steps(ab), steps(ac));
                        let last = DVec3::splat(OCC as f64 - 1e-6);
                        let mut mark = |q: DVec3| {
                            let q = q.min(last);
                            if q.is_finite() && q.min_element() >= 0.0 {
                                let q = q.as_uvec3();
                                full[((q.z as usize * OCC) + q.y as usize) * OCC + q.x as usize] =
                                    true;
                            }
                        };
                        for i in 0..=n {
                            let s = i as f64 / n as f64;
                            let row = a + ab * s;
                            // The row reaches bc at ac · (1 - s); its last point is there.
                            let reach = 1.0 - s;
                            let points = (m as f64 * reach).floor() as usize;
                            for j in 0..=points {
                                mark(row + ac * (j as f64 / m as f64));
                            }
                            mark(row + ac * reach);
                        }
                    }
                    full
                },
            )
            .reduce_with(|mut a, b| {
                a.iter_mut().zip(b).for_each(|(a, b)| *a |= b);
                a
            });
        if let Some(full) = marked {
            grid.full = full;
        }
        grid
    }

    /// The cell a point on the model marks: a point on the far faces of the box belongs to the
    /// last cell.
    fn cell_of(&self, q: DVec3) -> Option<usize> {
        self.index(q.min(self.lo + self.cell * (OCC as f64 - 1e-6)))
    }

    /// When the corners' cells differ along one axis at most: the cells between them along it.
    fn row_span(&self, t: [DVec3; 3]) -> Option<impl Iterator<Item = usize>> {
        let k = t.map(|q| self.cell_of(q));
        let [a, b, c] = [k[0]?, k[1]?, k[2]?];
        let axes = |i: usize| [i % OCC, i / OCC % OCC, i / (OCC * OCC)];
        let (a, b, c) = (axes(a), axes(b), axes(c));
        let stride = [1, OCC, OCC * OCC];
        let mut varying = (0..3).filter(|&d| a[d] != b[d] || a[d] != c[d]);
        let d = match (varying.next(), varying.next()) {
            (None, _) => 0,
            (Some(d), None) => d,
            _ => return None,
        };
        let (lo, hi) = (a[d].min(b[d]).min(c[d]), a[d].max(b[d]).max(c[d]));
        let base: usize = (0..3).filter(|&e| e != d).map(|e| a[e] * stride[e]).sum();
        Some((lo..=hi).map(move |v| base + v * stride[d]))
    }

    fn index(&self, q: DVec3) -> Option<usize> {
        let c = (q - self.lo) / self.cell;
        // Truncation is the floor here: negative (and NaN) coordinates were turned away.
        if !c.is_finite() || c.min_element() < 0.0 || c.max_element() >= OCC as f64 {
            return None;
        }
        Some((c.z as usize * OCC + c.y as usize) * OCC + c.x as usize)
    }

    /// Distance along the unit ray from `o` to the first occupied cell (a quarter-cell march,
    /// skipping the cell the eye is in), at most `max`.
    fn depth(&self, o: DVec3, d: DVec3, max: f64) -> f64 {
        let step = self.cell.min_element() * 0.25;
        let own = self.index(o);
        let mut t = step;
        while t < max {
            match self.index(o + d * t) {
                None => return max,
                Some(i) if Some(i) != own && self.full[i] => return t,
                _ => {}
            }
            t += step;
        }
        max
    }

    /// How far a view from `eye` along `dir` sees: the mean depth of nine rays spread over
    /// a 60° view, each at most `max`.
    fn view_depth(&self, eye: DVec3, dir: DVec3, max: f64) -> f64 {
        let side = dir.cross(DVec3::Y).normalize_or_zero();
        let mut sum = 0.0;
        for i in 0..9 {
            let (x, y) = ((i % 3) as f64 - 1.0, (i / 3) as f64 - 1.0);
            let r = (dir + side * (0.6 * x) + DVec3::Y * (0.45 * y)).normalize();
            sum += self.depth(eye, r, max);
        }
        sum / 9.0
    }
}

/// Bright enough that the floor under clear glass is near white without clipping: then
/// coloured glass keeps its colour on the floor instead of saturating to white. Measured on
/// the floor's brightest diffuse colour (every receiver's when there is no floor) at the sun's
/// angle of incidence.
fn sun_intensity(tagging: &crate::tag::Tagging, classes: &[MaterialClass], d: DVec3) -> f32 {
    let brightest = |want: &dyn Fn(MaterialClass) -> bool| {
        tagging
            .materials
            .iter()
            .zip(classes)
            .filter(|(_, c)| want(**c))
            .map(|(m, _)| m.material.diffuse.iter().copied().fold(0.0f32, f32::max))
            .fold(0.0f32, f32::max)
    };
    let mut albedo = brightest(&|c| c == MaterialClass::Floor);
    if albedo <= 0.0 {
        albedo = brightest(&|c| !c.is_window() && c != MaterialClass::Background);
    }
    let cos = (-d.y as f32).max(0.2);
    (0.85 / (albedo.max(0.2) * cos)).clamp(0.5, 8.0)
}

pub fn guess(p: &Prepared) -> Guess {
    let mut notes = Vec::new();
    let classes: Vec<MaterialClass> = p
        .tagging
        .materials
        .iter()
        .map(|m| m.material.class)
        .collect();
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for (src, mats) in p.imported.iter().zip(&p.tri_material) {
        for (t, &m) in mats.iter().enumerate() {
            if classes[m as usize] == MaterialClass::Background {
                continue;
            }
            for q in triangle(src, t as u32) {
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
    }
    if !lo.is_finite() {
        return Guess {
            light: None,
            cameras: Vec::new(),
            notes: vec!["the model has no geometry to light".into()],
        };
    }
    let diag = (hi - lo).length().max(1e-6);
    // The floor's triangles are found by their class at each pass over them, not listed:
    // the list of a large floor's ids (8 bytes a triangle) was held beside mesh processing,
    // at the peak of a large mesh's cook.
    let class_of = classes.as_slice();
    let floor = Footprint::new(|| {
        p.imported
            .iter()
            .zip(&p.tri_material)
            .flat_map(move |(src, mats)| {
                mats.iter()
                    .enumerate()
                    .filter(move |&(_, &m)| class_of[m as usize] == MaterialClass::Floor)
                    .map(move |(t, _)| triangle(src, t as u32))
            })
    });
    let windows = &p.windows.instances;

    // The sun: the most window area landing on the floor.
    let mut best: Option<(f64, DVec3)> = None;
    if let Some(fp) = &floor {
        for el in [25.0f64, 35.0, 45.0, 55.0, 65.0] {
            for az in 0..24 {
                let (e, a) = (el.to_radians(), (az as f64 * 15.0).to_radians());
                let d = DVec3::new(e.cos() * a.sin(), -e.sin(), e.cos() * a.cos());
                let mut score = 0.0;
                for w in windows {
                    if w.inside.dot(d) <= 0.05 {
                        continue;
                    }
                    let mut landed = 0;
                    for i in 0..5 {
                        for j in 0..5 {
                            let q = w.origin
                                + w.right * ((i as f64 + 0.5) / 5.0)
                                + w.up * ((j as f64 + 0.5) / 5.0);
                            landed += fp.land(q, d).is_some() as u32;
                        }
                    }
                    score += w.area * landed as f64 / 25.0 * w.inside.dot(d);
                }
                // Ties (and near ties) go to a sun near 45°, which casts patches of a sensible
                // length.
                let score = score * (1.0 - 0.002 * (el - 45.0).abs());
                if score > 0.0 && best.is_none_or(|b| score > b.0) {
                    best = Some((score, d));
                }
            }
        }
    }
    let light = match best {
        Some((_, d)) => {
            notes.push(format!(
                "sun direction [{:.3}, {:.3}, {:.3}]: the most window light lands on the floor",
                d.x, d.y, d.z
            ));
            Some(d)
        }
        None if windows.is_empty() => {
            notes.push("no windows found: a default sun, which lights nothing through glass".into());
            Some(DVec3::new(-0.4, -0.8, 0.45).normalize())
        }
        None => {
            notes.push(
                "no sun direction lands window light on a floor (no floor found, or the windows face away): a default sun through the largest window".into(),
            );
            let w = windows.iter().max_by(|a, b| a.area.total_cmp(&b.area));
            Some(w.map_or(DVec3::new(-0.4, -0.8, 0.45), |w| (w.inside - DVec3::Y).normalize()))
        }
    }
    .map(|d| Light {
        kind: pack::LightKind::Directional {
            direction: f3(d),
            angular_size: SUN_DEG.to_radians(),
        },
        colour: [1.0, 0.95, 0.85],
        intensity: sun_intensity(&p.tagging, &classes, d),
    });

    // Cameras at eye height above the floor (or the model's bottom), inside its footprint.
    let floor_y = floor.as_ref().map_or(lo.y, |f| f.y);
    // A fraction of the building's height, not metres: models come in any unit (the Cornell
    // box is 550 units tall, and 2 units above its floor is a view along the floor).
    let eye = floor_y + ((hi.y - floor_y) * 0.12).max(diag * 0.002);
    let centre = match &floor {
        Some(f) => {
            let c = f.lo + f.cell * (GRID as f64 / 2.0);
            DVec3::new(c.x, eye, c.y)
        }
        None => DVec3::new((lo.x + hi.x) / 2.0, eye, (lo.z + hi.z) / 2.0),
    };
    let camera = |name: &str, position: DVec3, target: DVec3| Camera {
        name: name.into(),
        position: f3(position),
        target: f3(target),
        up: [0.0, 1.0, 0.0],
        fov_y: 60.0,
        near: (diag * 1e-4).max(0.01) as f32,
        far: (diag * 3.0) as f32,
    };
    let mut cameras = Vec::new();
    // Along the longer horizontal axis, from near one end towards the other, placed where
    // the view runs farthest before it meets geometry: down the middle of a nave, but beside
    // a block or a pier standing in the middle rather than up against it.
    let long_x = hi.x - lo.x >= hi.z - lo.z;
    let (along, across) = if long_x {
        (DVec3::X, DVec3::Z)
    } else {
        (DVec3::Z, DVec3::X)
    };
    let (len, wide) = ((hi - lo).dot(along), (hi - lo).dot(across));
    let mut candidates = Vec::new();
    for height in [0.12, 0.3, 0.5] {
        for from_hi in [false, true] {
            for side in [0.0, -0.25, 0.25] {
                let mut a = lo + along * (len * if from_hi { 0.9 } else { 0.1 });
                a += across * ((centre - lo).dot(across) + side * wide);
                a.y = floor_y + ((hi.y - floor_y) * height).max(diag * 0.002);
                let dir = if from_hi { -along } else { along };
                candidates.push((a, dir));
            }
        }
    }
    let occupancy = Occupancy::new(p, &classes, lo, hi);
    let depths: Vec<f64> = candidates
        .iter()
        .map(|&(a, dir)| occupancy.view_depth(a, dir, len))
        .collect();
    let mut best_view: Option<(f64, DVec3, DVec3)> = None;
    for (&(a, dir), &depth) in candidates.iter().zip(&depths) {
        // Near ties go to the earlier candidate: low, in the middle, from the low end.
        if best_view.is_none_or(|v| depth > v.0 * 1.1) {
            best_view = Some((depth, a, a + dir * len * 0.9));
        }
    }
    if let Some((_, a, b)) = best_view {
        cameras.push(camera("nave", a, b));
    }
    let mut by_area: Vec<&crate::instances::Instance> = windows.iter().collect();
    by_area.sort_by(|x, y| y.area.total_cmp(&x.area));
    if let Some(w) = by_area.first() {
        let target = w.origin + (w.right + w.up) * 0.5;
        // From inside: back from the window along its inside normal, at eye height.
        let back = (w.width().max(w.height()) * 1.5).max(diag * 0.05);
        let mut pos = target + w.inside * back;
        pos.y = eye;
        cameras.push(camera("windows", pos, target));
        if let (Some(fp), Some(l)) = (&floor, &light)
            && let pack::LightKind::Directional { direction, .. } = l.kind
        {
            let d = DVec3::new(
                direction[0] as f64,
                direction[1] as f64,
                direction[2] as f64,
            );
            let lit = by_area
                .iter()
                .find_map(|w| fp.land(w.origin + (w.right + w.up) * 0.5, d));
            if let Some(spot) = lit {
                let away = DVec3::new(d.x, 0.0, d.z).normalize_or_zero();
                let mut pos = spot + away * (hi.y - floor_y).max(diag * 0.05) * 0.8;
                // Kept inside the model's footprint.
                pos.x = pos
                    .x
                    .clamp(lo.x + 0.05 * (hi.x - lo.x), hi.x - 0.05 * (hi.x - lo.x));
                pos.z = pos
                    .z
                    .clamp(lo.z + 0.05 * (hi.z - lo.z), hi.z - 0.05 * (hi.z - lo.z));
                pos.y = eye;
                cameras.push(camera("lit-floor", pos, spot));
            }
        }
    }
    Guess {
        light,
        cameras,
        notes,
    }
}
