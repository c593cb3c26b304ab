//! What a bare model does not say: a sun whose light, through the windows, lands on the floor,
//! and a few cameras inside the building (for a model without a floor, an object rather than a
//! building, first a view of all of it from outside). `cooker init` writes these into a
//! starter manifest, and a bare `cooker cook model.obj` uses them directly, so a model from
//! another tool shows stained-glass light without hand edits.

use glam::{DVec2, DVec3, Vec3Swizzles};
use pack::MaterialClass;

use crate::Prepared;
use crate::instances::triangle;
use crate::manifest::{Camera, Light};
use crate::windows::f3;

/// The least cosine between the sun's direction and a window's inward normal for the sun to
/// count as coming in through it.
const MIN_ENTRY_COS: f64 = 0.05;

/// The sun's angular diameter.
const SUN_DEG: f32 = 0.53;
/// Cells per side of the floor's footprint grid.
const GRID: usize = 256;

/// The guessed light and cameras, and what decided them.
#[derive(Clone, Debug)]
pub struct Guess {
    pub light: Option<Light>,
    pub cameras: Vec<Camera>,
    /// The background colour, linear RGB: a daylight sky where the model has windows.
    pub sky: Option<[f32; 3]>,
    pub notes: Vec<String>,
    /// The model looks Z-up (its note is among `notes`): `cooker init` says it on the
    /// terminal too, not only in the manifest's comments.
    pub looks_z_up: bool,
}

/// What a window of a bare model shows behind its glass (the background's colour, linear
/// RGB) where no sky geometry covers it: a daylight sky. Black, the manifest's default,
/// drew every window black from inside.
pub const DAYLIGHT_SKY: [f32; 3] = [0.5, 0.6, 0.75];

/// The floor's footprint seen from above, for "does this ray land on the floor".
struct Footprint {
    lo: DVec2,
    cell: DVec2,
    y: f64,
    /// Rasterized only where windows could land light on it: a model without windows uses the
    /// footprint's bounds and height alone.
    covered: Vec<bool>,
}

impl Footprint {
    /// `sum`: the floor's triangles summed up; `tris` yields them again for the raster:
    /// held as 72-byte corners, a 100k-triangle floor was the largest block of a bare mesh's
    /// cook. `raster`: whether [`Footprint::land`] will be asked (the raster was a quarter of
    /// the guess's time on a bare 100k-triangle floor).
    fn new<I: Iterator<Item = [DVec3; 3]>>(
        sum: &FloorSum,
        tris: impl Fn() -> I,
        raster: bool,
    ) -> Option<Self> {
        let FloorSum {
            lo, hi, y, area, ..
        } = *sum;
        if area.is_nan() || area <= 0.0 || hi.x.is_nan() || hi.x <= lo.x || hi.y <= lo.y {
            return None;
        }
        let cell = (hi - lo) / GRID as f64;
        let covered = if raster {
            // The footprint in [0, 1]², rasterized like a window's outline.
            let flat: Vec<crate::design::UvTriangle> = tris()
                .map(|t| {
                    (
                        t.map(|p| ((p.xz() - lo) / (hi - lo)).as_vec2().to_array()),
                        0,
                    )
                })
                .collect();
            crate::design::coverage(&flat, GRID as u32, GRID as u32)
        } else {
            Vec::new()
        };
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
        let covered = self.covered.get(c.y as usize * GRID + c.x as usize);
        debug_assert!(
            covered.is_some(),
            "a footprint without its raster asked to land a ray"
        );
        covered.copied().unwrap_or(false).then_some(hit)
    }
}

/// The floor's horizontal bounds, area and area-weighted height, summed triangle by triangle
/// in the same pass as the model's bounds: a second pass over a 100k-triangle floor took
/// 2.8 ms, a third of the guess.
#[derive(Clone, Copy)]
struct FloorSum {
    lo: DVec2,
    hi: DVec2,
    y: f64,
    area: f64,
    /// Twice the area facing along each axis, either way: a floor of a Z-up model faces z.
    facing: DVec3,
}

impl FloorSum {
    fn new() -> Self {
        Self {
            lo: DVec2::splat(f64::INFINITY),
            hi: DVec2::splat(f64::NEG_INFINITY),
            y: 0.0,
            area: 0.0,
            facing: DVec3::ZERO,
        }
    }

    fn add(&mut self, t: [DVec3; 3]) {
        for p in t {
            self.lo = self.lo.min(p.xz());
            self.hi = self.hi.max(p.xz());
        }
        let n = (t[1] - t[0]).cross(t[2] - t[0]);
        let a = n.length() * 0.5;
        self.y += a * (t[0].y + t[1].y + t[2].y) / 3.0;
        self.area += a;
        self.facing += n.abs();
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
    full: Cells,
}

const OCC: usize = 64;

/// Which of the 64³ cells are marked: a bit each, a 64-bit word per row along x. Each chunk
/// of triangles clears, fills and merges 32 KB where a byte a cell was 256 KB; that was most
/// of a small model's guess.
#[derive(Clone)]
struct Cells(Vec<u64>);

const _: () = assert!(OCC == u64::BITS as usize, "a row of cells is one word");

impl Cells {
    fn new() -> Self {
        Self(vec![0; OCC * OCC])
    }

    fn get(&self, i: usize) -> bool {
        self.0[i / OCC] >> (i % OCC) & 1 == 1
    }

    fn set(&mut self, [x, y, z]: [usize; 3]) {
        self.set_index(cell_index(x, y, z));
    }

    fn set_index(&mut self, i: usize) {
        self.0[i / OCC] |= 1 << (i % OCC);
    }

    /// Every cell marked.
    #[cfg(test)]
    fn all() -> Self {
        Self(vec![u64::MAX; OCC * OCC])
    }

    /// Whether any cell of the box `lo..=hi` is marked: a masked word per row of the box.
    fn any_in(&self, lo: [usize; 3], hi: [usize; 3]) -> bool {
        let row = (u64::MAX >> (OCC - 1 - hi[0])) & (u64::MAX << lo[0]);
        (lo[2]..=hi[2]).any(|z| (lo[1]..=hi[1]).any(|y| self.0[z * OCC + y] & row != 0))
    }
}

impl Occupancy {
    /// The cells that the views from `views` (eye and direction, each at most `max` deep)
    /// can reach are marked exactly; a triangle whose box of cells holds none of those is
    /// skipped. The views read only cells their rays pass before the first full one, a
    /// subset of what they pass in an empty grid, so their depths are those of the whole
    /// grid (a height field of 100k triangles: 8 ms of clipping on one thread, most of it
    /// for cells no view looks at).
    fn new(
        p: &Prepared,
        classes: &[MaterialClass],
        (lo, hi): (DVec3, DVec3),
        views: &[(DVec3, DVec3)],
        max: f64,
    ) -> Self {
        let mut grid = Self::empty(lo, hi);
        let wanted = grid.reach(views, max);
        grid.fill(p, classes, &wanted);
        grid
    }

    /// Every cell the rays of `views` pass through in an empty grid.
    fn reach(&self, views: &[(DVec3, DVec3)], max: f64) -> Cells {
        let mut wanted = Cells::new();
        for &(eye, dir) in views {
            for r in Self::rays(dir) {
                self.march(eye, r, max, |i| {
                    wanted.set_index(i);
                    false
                });
            }
        }
        wanted
    }

    /// The grid starts a fraction of a cell before the bounds, so the round fractions of
    /// them that eyes stand at (the middle, quarters) and walls on the bounds lie inside
    /// cells, not on their faces: a ray along a face walked one column of cells or the next
    /// by a millionth of a unit, and a church exported to OBJ and to glTF (positions 3e-6
    /// apart) got views 4 m apart.
    fn empty(lo: DVec3, hi: DVec3) -> Self {
        const SHIFT: f64 = 0.382;
        let cell = ((hi - lo) / (OCC as f64 - 1.0))
            .max(DVec3::splat((hi - lo).max_element() * 1e-3 + 1e-9));
        Self {
            lo: lo - cell * SHIFT,
            cell,
            full: Cells::new(),
        }
    }

    /// Marks the cells that surfaces (not glass, not the backdrop) pass through, at least
    /// those of `wanted`.
    fn fill(&mut self, p: &Prepared, classes: &[MaterialClass], wanted: &Cells) {
        use rayon::prelude::*;
        let grid = &*self;
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
            .fold(Cells::new, |mut full, (src, mats, range)| {
                for t in range {
                    let c = classes[mats[t] as usize];
                    if c.is_window() || c == MaterialClass::Background {
                        continue;
                    }
                    let q = triangle(src, t as u32).map(|q| (q - grid.lo) / grid.cell);
                    mark_cells(&mut full, wanted, q);
                }
                full
            })
            .reduce_with(|mut a, b| {
                a.0.iter_mut().zip(b.0).for_each(|(a, b)| *a |= b);
                a
            });
        if let Some(full) = marked {
            self.full = full;
        }
    }

    /// The cell holding `q`, if the grid does.
    fn cell(&self, q: DVec3) -> Option<[usize; 3]> {
        let c = (q - self.lo) / self.cell;
        // Truncation is the floor here: negative (and NaN) coordinates were turned away.
        if !c.is_finite() || c.min_element() < 0.0 || c.max_element() >= OCC as f64 {
            return None;
        }
        Some([c.x as usize, c.y as usize, c.z as usize])
    }

    /// The [`cell_index`] of the cell holding `q`, for tests that walk a ray point by point.
    #[cfg(test)]
    fn index(&self, q: DVec3) -> Option<usize> {
        self.cell(q).map(|[x, y, z]| cell_index(x, y, z))
    }

    /// Walks the unit ray from `o` cell by cell (each cell it passes through, in order),
    /// skipping the cell the eye is in, until `stop` holds for a cell (the distance at which
    /// the ray enters it), the ray leaves the grid or passes `max` (then `max`). Depths and the
    /// cells they may read both come from here. Quarter-cell steps took 4 ms of a bare 100k
    /// height field's guess: its cells are flat, and the steps followed the thinnest side.
    fn march(&self, o: DVec3, d: DVec3, max: f64, mut stop: impl FnMut(usize) -> bool) -> f64 {
        let Some(mut at) = self.cell(o) else {
            return max;
        };
        let c = (o - self.lo) / self.cell;
        // Per axis: the distance along the ray to its next cell face, and between faces.
        let mut next = [f64::INFINITY; 3];
        let mut every = [f64::INFINITY; 3];
        for k in 0..3 {
            if d[k] > 0.0 {
                next[k] = (at[k] as f64 + 1.0 - c[k]) * self.cell[k] / d[k];
                every[k] = self.cell[k] / d[k];
            } else if d[k] < 0.0 {
                next[k] = (c[k] - at[k] as f64) * self.cell[k] / -d[k];
                every[k] = self.cell[k] / -d[k];
            }
        }
        loop {
            let k = if next[0] <= next[1] && next[0] <= next[2] {
                0
            } else if next[1] <= next[2] {
                1
            } else {
                2
            };
            let t = next[k];
            // Also ends a ray along no axis (every face infinitely far) or a NaN one.
            if t.is_nan() || t >= max {
                return max;
            }
            if d[k] > 0.0 {
                if at[k] + 1 >= OCC {
                    return max;
                }
                at[k] += 1;
            } else {
                let Some(a) = at[k].checked_sub(1) else {
                    return max;
                };
                at[k] = a;
            }
            next[k] += every[k];
            if stop(cell_index(at[0], at[1], at[2])) {
                return t;
            }
        }
    }

    /// Distance along the unit ray from `o` to the first occupied cell, at most `max`.
    fn depth(&self, o: DVec3, d: DVec3, max: f64) -> f64 {
        self.march(o, d, max, |i| self.full.get(i))
    }

    /// How many rays a view casts: a 3 × 3 fan.
    const RAYS: usize = 9;

    /// The rays spread over a 60° view along `dir`.
    fn rays(dir: DVec3) -> impl Iterator<Item = DVec3> {
        let side = dir.cross(DVec3::Y).normalize_or_zero();
        (0..Self::RAYS).map(move |i| {
            let (x, y) = ((i % 3) as f64 - 1.0, (i / 3) as f64 - 1.0);
            (dir + side * (0.6 * x) + DVec3::Y * (0.45 * y)).normalize()
        })
    }

    /// How far a view from `eye` along `dir` sees: the mean depth of its rays, each at most
    /// `max`.
    fn view_depth(&self, eye: DVec3, dir: DVec3, max: f64) -> f64 {
        Self::rays(dir)
            .map(|r| self.depth(eye, r, max))
            .sum::<f64>()
            / Self::RAYS as f64
    }

    /// As [`Self::view_depth`], each ray also stopped by the first of `near` (triangles about
    /// the eye, the eye at the origin) it meets.
    fn view_depth_near(&self, eye: DVec3, dir: DVec3, max: f64, near: &[[glam::Vec3; 3]]) -> f64 {
        Self::rays(dir)
            .map(|r| {
                let d = r.as_vec3();
                near.iter()
                    .filter_map(|&t| geom::intersect(t, glam::Vec3::ZERO, d))
                    .map(|(t, _)| t as f64)
                    .fold(self.depth(eye, r, max), f64::min)
            })
            .sum::<f64>()
            / Self::RAYS as f64
    }
}

/// Whether `eye` is inside a closed object: the nearest surface along each of three axes is
/// met from behind, as the wound faces of a closed mesh are from within. A building whose
/// walls face in is not one (nor, where its faces point out, is it told from an object: its
/// views are then the overview's alone). One pass over the triangles, three rays each (a BVH
/// would cost more to build than three rays save).
fn inside_an_object(p: &Prepared, classes: &[MaterialClass], eye: DVec3) -> bool {
    use rayon::prelude::*;
    let rays = [DVec3::X, DVec3::Y, DVec3::Z];
    let o = eye.as_vec3();
    // Per ray: the nearest hit's distance and whether its face points along the ray.
    let nearest = p
        .imported
        .par_iter()
        .zip(&p.tri_material)
        .map(|(src, mats)| {
            let mut best = [(f32::INFINITY, false); 3];
            for (t, &m) in mats.iter().enumerate() {
                let c = classes[m as usize];
                if c.is_window() || c == MaterialClass::Background {
                    continue;
                }
                let tri = triangle(src, t as u32).map(|q| q.as_vec3());
                let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                for (b, d) in best.iter_mut().zip(rays) {
                    if let Some((dist, _)) = geom::intersect(tri, o, d.as_vec3())
                        && dist > 0.0
                        && dist < b.0
                    {
                        *b = (dist, n.dot(d.as_vec3()) > 0.0);
                    }
                }
            }
            best
        })
        .reduce(
            || [(f32::INFINITY, false); 3],
            |a, b| std::array::from_fn(|i| if b[i].0 < a[i].0 { b[i] } else { a[i] }),
        );
    nearest.iter().all(|&(d, behind)| d.is_finite() && behind)
}

/// Where each of `views` (name, eye, target) sees its target: the eye as given, or, where
/// the view is blocked near the eye, the first of three points nearer the target (at the same
/// height) from which it is not. The footprint's margin can put an eye inside masonry (walls
/// 1.2 m thick around recessed glass), whose view is the back of the wall: one grey frame
/// where the lit floor should be. Blocked: the mean depth of the view's rays is under a third
/// of the way to the target, where an open view reaches most of it.
fn unblocked<'a>(
    p: &Prepared,
    classes: &[MaterialClass],
    bounds: (DVec3, DVec3),
    views: &[(&'a str, DVec3, DVec3)],
) -> Vec<(&'a str, DVec3, DVec3)> {
    const STEPS: [f64; 4] = [1.0, 0.7, 0.45, 0.25];
    let tries = |&(_, eye, target): &(&str, DVec3, DVec3)| {
        STEPS.map(|f| {
            let mut q = target + (eye - target) * f;
            q.y = eye.y;
            (q, (target - q).normalize_or_zero(), (target - q).length())
        })
    };
    let reach = views.iter().map(|v| tries(v)[0].2).fold(0.0, f64::max);
    let rays: Vec<(DVec3, DVec3)> = views
        .iter()
        .flat_map(|v| tries(v).map(|(q, d, _)| (q, d)))
        .collect();
    let occupancy = Occupancy::new(p, classes, bounds, &rays, reach);
    // The grid skips the cell an eye is in (else the floor or a wall beside it would stop
    // every ray at once), so an eye a few centimetres behind a wall's inner face saw through
    // the wall: a 0.6 m wall, the eye 4 cm into it, one grey frame. Within a cell's diagonal
    // of each eye the rays meet the triangles themselves.
    let near = occupancy.cell.length();
    let eyes: Vec<DVec3> = views
        .iter()
        .flat_map(|v| tries(v).map(|(q, _, _)| q))
        .collect();
    let close = surfaces_near(p, classes, &eyes, near);
    views
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let (name, _, target) = *v;
            let open = tries(v)
                .into_iter()
                .zip(&close[i * STEPS.len()..])
                .find(|&((q, d, len), tris)| {
                    len <= 0.0 || occupancy.view_depth_near(q, d, len, tris) >= len / 3.0
                })
                .map_or(v.1, |((q, _, _), _)| q);
            (name, open, target)
        })
        .collect()
}

/// For each of `eyes`, the surfaces (not glass, not the backdrop) whose bounds come within
/// `reach` of it, moved so the eye is at the origin: in f32, a model far from the origin
/// keeps its precision near the eye.
fn surfaces_near(
    p: &Prepared,
    classes: &[MaterialClass],
    eyes: &[DVec3],
    reach: f64,
) -> Vec<Vec<[glam::Vec3; 3]>> {
    let mut near = vec![Vec::new(); eyes.len()];
    for (src, mats) in p.imported.iter().zip(&p.tri_material) {
        for (t, &m) in mats.iter().enumerate() {
            let c = classes[m as usize];
            if c.is_window() || c == MaterialClass::Background {
                continue;
            }
            let tri = triangle(src, t as u32);
            let lo = tri[0].min(tri[1]).min(tri[2]) - reach;
            let hi = tri[0].max(tri[1]).max(tri[2]) + reach;
            for (e, list) in eyes.iter().zip(&mut near) {
                if e.cmpge(lo).all() && e.cmple(hi).all() {
                    list.push(tri.map(|q| (q - *e).as_vec3()));
                }
            }
        }
    }
    near
}

/// A convex polygon of at most seven corners: a triangle clipped by four axis-aligned planes.
struct Polygon {
    q: [DVec3; 7],
    len: usize,
}

impl Polygon {
    fn new(corners: &[DVec3]) -> Self {
        let mut q = [DVec3::ZERO; 7];
        q[..corners.len()].copy_from_slice(corners);
        Self {
            q,
            len: corners.len(),
        }
    }

    fn points(&self) -> &[DVec3] {
        &self.q[..self.len]
    }

    /// The part on one side of the plane `q[axis] = at`: above it when `above`, else below.
    /// Corners on the plane stay, and new ones are put on it exactly.
    fn clip(&self, axis: usize, at: f64, above: bool) -> Self {
        let mut out = Self::new(&[]);
        let side = |q: DVec3| if above { q[axis] - at } else { at - q[axis] };
        for (i, &a) in self.points().iter().enumerate() {
            let b = self.q[(i + 1) % self.len];
            let (sa, sb) = (side(a), side(b));
            if sa >= 0.0 && out.len < out.q.len() {
                out.q[out.len] = a;
                out.len += 1;
            }
            if (sa >= 0.0) != (sb >= 0.0) && out.len < out.q.len() {
                let mut q = a + (b - a) * (sa / (sa - sb));
                q[axis] = at;
                out.q[out.len] = q;
                out.len += 1;
            }
        }
        out
    }

    /// The part in layer `i` of `axis` (`first..=last` being the layers it spans), or `None`
    /// when that is the whole polygon.
    fn layer(&self, axis: usize, i: usize, first: usize, last: usize) -> Option<Self> {
        match (i > first, i < last) {
            (false, false) => None,
            (true, false) => Some(self.clip(axis, i as f64, true)),
            (false, true) => Some(self.clip(axis, (i + 1) as f64, false)),
            (true, true) => {
                let part = self.clip(axis, i as f64, true);
                Some(if part.len > 0 {
                    part.clip(axis, (i + 1) as f64, false)
                } else {
                    part
                })
            }
        }
    }

    /// The layers of `axis` the polygon spans.
    fn layers(&self, axis: usize) -> (usize, usize) {
        let (lo, hi) = self
            .points()
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), q| {
                (lo.min(q[axis]), hi.max(q[axis]))
            });
        (lo as usize, hi as usize)
    }
}

/// Cell units: `OCC` cells per axis, the model's bounds at 0 and `OCC`.
fn cell_index(x: usize, y: usize, z: usize) -> usize {
    (z * OCC + y) * OCC + x
}

/// The cell at [`cell_index`] `i`.
#[cfg(test)]
fn cell_coords(i: usize) -> [usize; 3] {
    [i % OCC, i / OCC % OCC, i / (OCC * OCC)]
}

/// Marks exactly the cells a triangle (corners in cell units) passes through: it is cut into
/// strips along one axis, each strip into columns along a second, and each column's part,
/// convex, crosses every layer of the third axis between its lowest corner and its highest.
/// The third axis is the one it spans the most layers of, so the cuts are fewest: a height
/// field's triangles, in cells flattened to its bounds, are tall slivers a fraction of a cell
/// across, cut at most twice, and most triangles of a large mesh lie in one column and need no
/// cut. On a bare 100k-triangle height field, cutting every triangle took 8 ms on one thread
/// where points half a cell apart took 12, and those missed 5 % of the cells (corners clipped
/// between points). A triangle whose box of cells holds no `wanted` cell is left out: there,
/// all but 9 % of them.
fn mark_cells(full: &mut Cells, wanted: &Cells, t: [DVec3; 3]) {
    let top = DVec3::splat(OCC as f64 - 1e-6);
    let mut p = [DVec3::ZERO; 3];
    for (q, c) in p.iter_mut().zip(t) {
        if !c.is_finite() {
            return;
        }
        *q = c.max(DVec3::ZERO).min(top);
    }
    // The cell of a corner of the bounds: non-negative, so truncation is the floor.
    let cell = |q: DVec3| q.as_uvec3().to_array().map(|c| c as usize);
    let lo = cell(p[0].min(p[1]).min(p[2]));
    let hi = cell(p[0].max(p[1]).max(p[2]));
    if !wanted.any_in(lo, hi) {
        return;
    }
    let count = |axis: usize| hi[axis] - lo[axis];
    let d = (0..3).max_by_key(|&axis| count(axis)).unwrap_or(0);
    let (u, v) = ((d + 1) % 3, (d + 2) % 3);
    let mut coord = lo;
    if count(u) == 0 && count(v) == 0 {
        // One column, which a triangle (connected) crosses from its lowest cell to its
        // highest: most triangles of a large mesh.
        for k in lo[d]..=hi[d] {
            coord[d] = k;
            full.set(coord);
        }
        return;
    }
    let tri = Polygon::new(&p);
    let (u0, u1) = (lo[u], hi[u]);
    for i in u0..=u1 {
        let cut = tri.layer(u, i, u0, u1);
        let strip = cut.as_ref().unwrap_or(&tri);
        if strip.len == 0 {
            continue;
        }
        coord[u] = i;
        let (v0, v1) = strip.layers(v);
        for j in v0..=v1 {
            let cut = strip.layer(v, j, v0, v1);
            let part = cut.as_ref().unwrap_or(strip);
            if part.len == 0 {
                continue;
            }
            coord[v] = j;
            let (d0, d1) = part.layers(d);
            for k in d0..=d1 {
                coord[d] = k;
                full.set(coord);
            }
        }
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

/// The 5 x 5 points a window's light is traced from: the centres of a grid over its rectangle.
fn window_samples(w: &crate::instances::Instance) -> impl Iterator<Item = DVec3> + '_ {
    (0..5).flat_map(move |i| {
        (0..5).map(move |j| {
            w.origin + w.right * ((i as f64 + 0.5) / 5.0) + w.up * ((j as f64 + 0.5) / 5.0)
        })
    })
}

/// A lamp of the model's file chosen as the light, and what the guess measured of it.
struct ChosenLamp<'a> {
    lamp: &'a crate::import::FileLamp,
    /// How many windows its light comes in through.
    windows: usize,
    /// Its light's mean direction where it lands (or, without a floor, where it enters).
    direction: DVec3,
    /// The mean squared distance its light travels to where it lands (or enters).
    reach_sq: f64,
    /// The mean share of its light a spot's cone lets through where it lands (1 for a point
    /// light): the exposure is divided by it, so a floor lit through the cone's soft edge is
    /// exposed as the sun's would be.
    share: f64,
    /// Its size: a little penumbra, as the sun's half-degree gives at the nearest window.
    radius: f64,
}

impl ChosenLamp<'_> {
    fn position(&self) -> DVec3 {
        DVec3::from(self.lamp.position.map(f64::from))
    }

    /// A lamp a hundred times the model's size away (`diag`) shines as the sun does: one
    /// way, and within 32-bit numbers (a lamp 1e30 units away needed an intensity past f32's
    /// range for its light to reach the floor, and the scene went black).
    fn as_sun(&self, diag: f64) -> bool {
        self.reach_sq.sqrt() > 100.0 * diag
    }
}

/// The file's lamp whose light, through the windows, lands the most window area on the
/// floor (without a floor, comes in through the most window area), scored as the sun is: a
/// lamp indoors lights no window from outside and is passed over. A spot light weighs each
/// window sample by its cone's fall-off (none outside the outer cone); light that would land
/// past a lamp's `range` counts for nothing, as glTF says it gives none there. Also returns
/// the lamps whose light came in only past their range.
fn best_lamp<'a>(
    lamps: &[&'a crate::import::FileLamp],
    windows: &[crate::instances::Instance],
    floor: Option<&Footprint>,
) -> (Option<ChosenLamp<'a>>, Vec<&'a str>) {
    let mut best: Option<(f64, ChosenLamp<'a>)> = None;
    let mut out_of_range = Vec::new();
    for &lamp in lamps {
        let mut past_range = false;
        let at = DVec3::from(lamp.position.map(f64::from));
        let cone = lamp
            .spot
            .and_then(|s| pack::SpotCone::new(s.axis, s.inner, s.outer));
        let (mut score, mut weight, mut unshared, mut lit) = (0.0, 0.0, 0.0, 0);
        let (mut direction, mut reach_sq, mut nearest) = (DVec3::ZERO, 0.0, f64::INFINITY);
        for w in windows {
            let mut landed = 0.0;
            for q in window_samples(w) {
                let to = q - at;
                let distance = to.length();
                if distance.is_nan() || distance <= 0.0 {
                    continue;
                }
                let d = to / distance;
                let entry = w.inside.dot(d);
                let share = cone.map_or(1.0, |c| c.towards(d.to_array()));
                if entry <= MIN_ENTRY_COS || share <= 0.0 {
                    continue;
                }
                let reach = match floor {
                    Some(fp) => match fp.land(q, d) {
                        Some(hit) => (hit - at).length(),
                        None => continue,
                    },
                    None => distance,
                };
                if lamp.range.is_some_and(|r| reach > f64::from(r)) {
                    past_range = true;
                    continue;
                }
                let s = w.area / 25.0 * entry * share;
                unshared += s / share;
                landed += s;
                direction += d * s;
                reach_sq += reach * reach * s;
                weight += s;
                nearest = nearest.min(distance);
            }
            score += landed;
            lit += usize::from(landed > 0.0);
        }
        if score <= 0.0 && past_range {
            out_of_range.push(lamp.name.as_str());
        }
        if score > 0.0 && best.as_ref().is_none_or(|b| score > b.0) {
            best = Some((
                score,
                ChosenLamp {
                    lamp,
                    windows: lit,
                    direction: (direction / weight).normalize_or(DVec3::NEG_Y),
                    reach_sq: reach_sq / weight,
                    share: weight / unshared,
                    radius: (nearest * (SUN_DEG as f64 * 0.5).to_radians().tan()).max(1e-6),
                },
            ));
        }
    }
    (best.map(|(_, l)| l), out_of_range)
}

/// What a cook's notes and `cooker validate` say of a model that looks Z-up.
pub(crate) const Z_UP_NOTE: &str = "the floor faces along z, not up (y): the model looks Z-up; \
     `--up z` stands it up (in a scene.toml, `rotate_deg = [-90.0, 0.0, 0.0]` on its [[mesh]])";

/// The guessed cameras' vertical field of view.
const FOV_Y_DEG: f64 = 60.0;

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
    let mut floor_sum = FloorSum::new();
    // Floors the geometry found lie flat by construction: only those a name, a material or a
    // rule made floors can show that the model stands on its side (see the Z-up note below).
    let mut by_geometry = vec![true; classes.len()];
    for (decisions, materials) in p.tagging.decisions.iter().zip(&p.tagging.part_material) {
        for (d, &m) in decisions.iter().zip(materials) {
            if !matches!(d, crate::tag::Decision::Geometry { .. })
                && let Some(g) = by_geometry.get_mut(m as usize)
            {
                *g = false;
            }
        }
    }
    // Twice the area of those floors facing along each axis, either way.
    let mut named_floor_facing = DVec3::ZERO;
    // The walls' and windows' bounds: the building, where the floor may be open ground.
    let mut shell_lo = DVec3::splat(f64::INFINITY);
    let mut shell_hi = DVec3::splat(f64::NEG_INFINITY);
    for (src, mats) in p.imported.iter().zip(&p.tri_material) {
        for (t, &m) in mats.iter().enumerate() {
            let class = classes[m as usize];
            if class == MaterialClass::Background {
                continue;
            }
            let tri = triangle(src, t as u32);
            for q in tri {
                lo = lo.min(q);
                hi = hi.max(q);
            }
            if class == MaterialClass::Wall || class.is_window() {
                for q in tri {
                    shell_lo = shell_lo.min(q);
                    shell_hi = shell_hi.max(q);
                }
            }
            if class == MaterialClass::Floor {
                floor_sum.add(tri);
                if !by_geometry[m as usize] {
                    named_floor_facing += (tri[1] - tri[0]).cross(tri[2] - tri[0]).abs();
                }
            }
        }
    }
    // Every corner at one point: only degenerate triangles, which the mesh stage drops.
    if !lo.is_finite() || lo == hi {
        return Guess {
            light: None,
            cameras: Vec::new(),
            sky: None,
            notes: vec!["the model has no geometry to light".into()],
            looks_z_up: false,
        };
    }
    let diag = (hi - lo).length().max(1e-6);
    // The floor's triangles are found by their class at each pass over them, not listed:
    // the list of a large floor's ids (8 bytes a triangle) was held beside mesh processing,
    // at the peak of a large mesh's cook.
    let class_of = classes.as_slice();
    let windows = &p.windows.instances;
    let floor = Footprint::new(
        &floor_sum,
        || {
            p.imported
                .iter()
                .zip(&p.tri_material)
                .flat_map(move |(src, mats)| {
                    mats.iter()
                        .enumerate()
                        .filter(move |&(_, &m)| class_of[m as usize] == MaterialClass::Floor)
                        .map(move |(t, _)| triangle(src, t as u32))
                })
        },
        !windows.is_empty(),
    );

    // Y is up here, as in glTF; many CAD and architecture tools write OBJ files Z-up, whose
    // floor then stands on its edge and catches no sun. The geometry may take the lowest wall,
    // lying flat, for another floor, which faces y: so the floors named so are asked alone too
    // (a glTF's "Floor" beside a wall cut out as one), and where none is, the glass tells, a
    // good share of it lying flat in the lower half of the building (walls and windows; a
    // skylight lies in the upper half), as the windows of a Z-up model's walls do.
    let mid = if shell_lo.y <= shell_hi.y {
        (shell_lo.y + shell_hi.y) * 0.5
    } else {
        (lo.y + hi.y) * 0.5
    };
    let window_area: f64 = windows.iter().map(|w| w.area).sum();
    let low_flat_glass: f64 = windows
        .iter()
        .filter(|w| w.inside.y.abs() > 0.9 && w.centre().y < mid)
        .map(|w| w.area)
        .sum();
    let stands_on_z = |f: DVec3| f.z > 2.0 * f.y;
    // Where no floor was found at all (a Z-up model's floor, unnamed, is tagged wall: it
    // stands on its edge), the windows of the upright walls tell: lancets are tall, so in a
    // Z-up model read Y-up they lie along z, longer than high.
    let lying_lancets = floor_sum.area == 0.0 && {
        let (mut along_z, mut upright) = (0.0, 0.0);
        for w in windows.iter().filter(|w| w.inside.y.abs() < 0.1) {
            let (wide, high) = (w.width(), w.height());
            if w.right.normalize_or_zero().z.abs() > 0.9 && wide > 1.5 * high {
                along_z += w.area;
            } else if high > 1.5 * wide {
                upright += w.area;
            }
        }
        along_z > 0.25 * window_area && along_z > 2.0 * upright
    };
    let looks_z_up = stands_on_z(floor_sum.facing)
        || stands_on_z(named_floor_facing)
        || low_flat_glass > 0.25 * window_area
        || lying_lancets;
    if looks_z_up {
        notes.push(Z_UP_NOTE.into());
    }

    // The light: the file's own sun (an artist's sun through the rose window), else a lamp of
    // the file's that shines in through the windows, else the sun that lands the most window
    // area on the floor.
    let file_sun = p.imported.iter().find_map(|s| s.sun.clone());
    let lamps: Vec<&crate::import::FileLamp> = p.imported.iter().flat_map(|s| &s.lamps).collect();
    let (lamp, out_of_range) = if file_sun.is_none() {
        best_lamp(&lamps, windows, floor.as_ref())
    } else {
        (None, Vec::new())
    };
    // Said after the light the guess takes.
    let mut unused_lamps = None;
    if !lamps.is_empty() {
        let names = |skip: Option<&str>| {
            lamps
                .iter()
                .filter(|l| Some(l.name.as_str()) != skip)
                .map(|l| format!("{:?}", l.name))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let why = match (&file_sun, &lamp) {
            (Some(s), _) => format!("its sun {:?} lights the scene", s.name),
            (None, Some(_)) => "a pack holds one light".to_string(),
            (None, None) if floor.is_some() => {
                "none of them shines in through a window onto the floor".to_string()
            }
            (None, None) => "none of them shines in through a window".to_string(),
        };
        let why = match &out_of_range[..] {
            [] => why,
            [one] => format!("{why} ({one:?} would, but its light lands past its range)"),
            many => format!(
                "{why} ({} would, but their light lands past their ranges)",
                crate::report::few_names(many)
            ),
        };
        let unused = names(lamp.as_ref().map(|l| l.lamp.name.as_str()));
        if !unused.is_empty() {
            unused_lamps = Some(format!("the model's lamps {unused} are not used: {why}"));
        }
    }
    let mut best: Option<(f64, DVec3)> = None;
    if let Some(fp) = floor
        .as_ref()
        .filter(|_| file_sun.is_none() && lamp.is_none())
    {
        for el in [25.0f64, 35.0, 45.0, 55.0, 65.0] {
            for az in 0..24 {
                let (e, a) = (el.to_radians(), (az as f64 * 15.0).to_radians());
                let d = DVec3::new(e.cos() * a.sin(), -e.sin(), e.cos() * a.cos());
                let mut score = 0.0;
                for w in windows {
                    if w.inside.dot(d) <= MIN_ENTRY_COS {
                        continue;
                    }
                    let landed: u32 = window_samples(w)
                        .map(|q| fp.land(q, d).is_some() as u32)
                        .sum();
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
    let sun = match (&file_sun, best) {
        _ if lamp.is_some() => None,
        (Some(s), _) => {
            let d = DVec3::from(s.direction.map(f64::from));
            notes.push(format!(
                "sun direction [{:.3}, {:.3}, {:.3}]: the model's own light {:?}",
                d.x, d.y, d.z, s.name
            ));
            Some(d)
        }
        (None, Some((_, d))) => {
            notes.push(format!(
                "sun direction [{:.3}, {:.3}, {:.3}]: the most window light lands on the floor",
                d.x, d.y, d.z
            ));
            Some(d)
        }
        (None, None) if windows.is_empty() => {
            notes
                .push("no windows found: a default sun, which lights nothing through glass".into());
            Some(DVec3::new(-0.4, -0.8, 0.45).normalize())
        }
        (None, None) => {
            notes.push(
                "no sun direction lands window light on a floor (no floor found, or the windows face away): a default sun through the largest window".into(),
            );
            let order = larger_window_first(windows);
            let w = windows.iter().min_by(|a, b| order(a, b));
            let fallback = DVec3::new(-0.4, -0.8, 0.45).normalize();
            Some(w.map_or(fallback, |w| down_through(w.inside).unwrap_or(fallback)))
        }
    };
    let light = match &lamp {
        Some(l) => {
            let kind = if l.lamp.spot.is_some() {
                "spot"
            } else {
                "point"
            };
            let as_sun = l.as_sun(diag);
            notes.push(format!(
                "light at [{:.3}, {:.3}, {:.3}]: the model's own {kind} light {:?}, which \
                 shines in through {} of {} windows{}",
                l.position().x,
                l.position().y,
                l.position().z,
                l.lamp.name,
                l.windows,
                windows.len(),
                if as_sun {
                    ", so far away that it is taken as a sun along its light".to_string()
                } else if let Some(r) = l.lamp.range {
                    format!(
                        " (its range, {r}, is not a cut-off in the pack: the lamp's light falls \
                         off by the inverse square alone)"
                    )
                } else {
                    String::new()
                }
            ));
            let exposure = sun_intensity(&p.tagging, &classes, l.direction);
            Some(if as_sun {
                Light {
                    kind: pack::LightKind::Directional {
                        direction: f3(l.direction),
                        angular_size: SUN_DEG.to_radians(),
                    },
                    colour: l.lamp.colour,
                    intensity: exposure,
                }
            } else {
                // Exposed as the sun would be, at the distance its light lands from it.
                let (position, radius) = (l.lamp.position, l.radius as f32);
                Light {
                    kind: match l.lamp.spot {
                        Some(s) => pack::LightKind::Spot {
                            position,
                            radius,
                            direction: s.axis,
                            inner: s.inner,
                            outer: s.outer,
                        },
                        None => pack::LightKind::Point { position, radius },
                    },
                    colour: l.lamp.colour,
                    intensity: (exposure as f64 * l.reach_sq / l.share) as f32,
                }
            })
        }
        None => sun.map(|d| Light {
            kind: pack::LightKind::Directional {
                direction: f3(d),
                angular_size: SUN_DEG.to_radians(),
            },
            colour: file_sun.as_ref().map_or([1.0, 0.95, 0.85], |s| s.colour),
            intensity: sun_intensity(&p.tagging, &classes, d),
        }),
    };
    notes.extend(unused_lamps);
    // Where the light travels at a point it passes: one way for the sun, away from a lamp.
    // A spot's light reaches only what its cone does: a view of a window or floor outside it
    // shows none (the views looked at the window the cook skipped for it).
    let cone = lamp
        .as_ref()
        .and_then(|l| l.lamp.spot)
        .and_then(|s| pack::SpotCone::new(s.axis, s.inner, s.outer));
    let travel = |at: DVec3| -> Option<DVec3> {
        match &lamp {
            Some(l) if l.as_sun(diag) => Some(l.direction),
            Some(l) => Some((at - l.position()).normalize_or_zero()).filter(|d| {
                *d != DVec3::ZERO && cone.is_none_or(|c| c.towards(d.to_array()) > 0.0)
            }),
            None => sun,
        }
    };

    // Cameras at eye height above the floor (or the model's bottom), inside its footprint:
    // within the walls and windows where the floor reaches past them (a building on open
    // ground, whose views over the whole ground stood outside it).
    let (inner_lo, inner_hi) = if floor.is_some()
        && !windows.is_empty()
        && shell_hi.x > shell_lo.x
        && shell_hi.z > shell_lo.z
    {
        (
            DVec3::new(lo.x.max(shell_lo.x), lo.y, lo.z.max(shell_lo.z)),
            DVec3::new(hi.x.min(shell_hi.x), hi.y, hi.z.min(shell_hi.z)),
        )
    } else {
        (lo, hi)
    };
    let floor_y = floor.as_ref().map_or(lo.y, |f| f.y);
    // Distances inside scale with the building, not with the ground around it (a hall on a
    // kilometre of ground had its eye at 2.8 m).
    let inner_diag = (inner_hi - inner_lo).length().max(1e-6);
    // A fraction of the building's height, not metres: models come in any unit (the Cornell
    // box is 550 units tall, and 2 units above its floor is a view along the floor).
    let eye = floor_y + ((hi.y - floor_y) * 0.12).max(inner_diag * 0.002);
    let centre = match &floor {
        Some(f) => {
            let c = f.lo + f.cell * (GRID as f64 / 2.0);
            DVec3::new(
                c.x.clamp(inner_lo.x, inner_hi.x),
                eye,
                c.y.clamp(inner_lo.z, inner_hi.z),
            )
        }
        None => DVec3::new((lo.x + hi.x) / 2.0, eye, (lo.z + hi.z) / 2.0),
    };
    // Kept inside the footprint, a twentieth of it from its edges.
    let within = |mut q: DVec3| {
        let margin = (inner_hi - inner_lo) * 0.05;
        q.x = q.x.clamp(inner_lo.x + margin.x, inner_hi.x - margin.x);
        q.z = q.z.clamp(inner_lo.z + margin.z, inner_hi.z - margin.z);
        q
    };
    let camera = |name: &str, position: DVec3, target: DVec3| Camera {
        name: name.into(),
        position: f3(position),
        target: f3(target),
        up: [0.0, 1.0, 0.0],
        fov_y: FOV_Y_DEG as f32,
        // The 0.01 floor keeps the near plane of a small model (a bunny in metres) where it
        // was; a tenth of the model's size caps it, so a model in large units (a statue
        // in kilometres) keeps its near plane in front of the far one.
        // A quarter of the eye's height above a floor caps it too: a nave 0.09 units long
        // (a model in kilometres) put the near plane three times that height away, and the
        // floor in front of the views was cut off.
        near: (diag * 1e-4)
            .max(0.01)
            .min(diag * 0.1)
            .min(if floor.is_some() {
                (eye - floor_y) * 0.25
            } else {
                f64::INFINITY
            }) as f32,
        far: (diag * 3.0) as f32,
    };
    let mut cameras = Vec::new();
    // A model without a floor is an object rather than a building to walk through (a statue,
    // a bunny): first a view of all of it from outside, from above on its sunlit side, at the
    // distance where its bounding sphere fills the height of the view. The view inside its
    // bounds follows, for a building whose floor was not recognised.
    let overview = || {
        let toward_sun =
            travel((lo + hi) * 0.5).map_or(DVec3::ZERO, |d| DVec3::new(-d.x, 0.0, -d.z));
        let dir = (toward_sun.normalize_or(DVec3::Z) + DVec3::Y * 0.6).normalize();
        let middle = (lo + hi) * 0.5;
        let distance = diag * 0.5 / (FOV_Y_DEG.to_radians() * 0.5).sin();
        camera("overview", middle + dir * distance, middle)
    };
    if floor.is_none() {
        cameras.push(overview());
    }
    // Along the longer horizontal axis, from near one end towards the other, placed where
    // the view runs farthest before it meets geometry: down the middle of a nave, but beside
    // a block or a pier standing in the middle rather than up against it. A footprint within
    // a quarter of square tries both axes, x first: the longer one alone turned a square
    // room's view a quarter turn for a vertex moved 1 cm (4 x 4.01 m), and `cooker diff`
    // of a regression test saw the camera move 2 m.
    let span = inner_hi - inner_lo;
    let axes: &[(DVec3, DVec3)] = if span.x.max(span.z) < 1.25 * span.x.min(span.z) {
        &[(DVec3::X, DVec3::Z), (DVec3::Z, DVec3::X)]
    } else if span.x >= span.z {
        &[(DVec3::X, DVec3::Z)]
    } else {
        &[(DVec3::Z, DVec3::X)]
    };
    // Each candidate: eye, direction and how far it looks (its axis's length).
    let mut candidates = Vec::new();
    for &(along, across) in axes {
        let (len, wide) = (span.dot(along), span.dot(across));
        for height in [0.12, 0.3, 0.5] {
            for from_hi in [false, true] {
                for side in [0.0, -0.25, 0.25] {
                    let mut a = inner_lo + along * (len * if from_hi { 0.9 } else { 0.1 });
                    a += across * ((centre - inner_lo).dot(across) + side * wide);
                    a.y = floor_y + ((hi.y - floor_y) * height).max(inner_diag * 0.002);
                    let dir = if from_hi { -along } else { along };
                    candidates.push((a, dir, len));
                }
            }
        }
    }
    let len = span.x.max(span.z);
    // Around each eye, level views every eighth of a turn: one inside a building meets its
    // walls every way, one in the alley between two buildings sees out along it. The alley
    // ran farthest, and two churches a metre apart got a "nave" view between them.
    const RING: usize = 8;
    let ring = |a: DVec3| {
        (0..RING).map(move |k| {
            let t = k as f64 * std::f64::consts::TAU / RING as f64;
            (a, DVec3::new(t.cos(), 0.0, t.sin()))
        })
    };
    let mut views: Vec<(DVec3, DVec3)> = candidates.iter().map(|&(a, d, _)| (a, d)).collect();
    views.extend(candidates.iter().flat_map(|&(a, _, _)| ring(a)));
    let occupancy = Occupancy::new(p, &classes, (lo, hi), &views, len);
    let depths: Vec<f64> = candidates
        .iter()
        .map(|&(a, dir, len)| occupancy.view_depth(a, dir, len))
        .collect();
    // Counted ahead of the eye only, where the picture is: the Cornell box, open at one end,
    // was seen from its back wall looking out of the opening, since an eye by the opening
    // had open sky behind it.
    let open: Vec<usize> = candidates
        .iter()
        .map(|&(a, dir, len)| {
            ring(a)
                .filter(|&(a, d)| d.dot(dir) > 1e-9 && occupancy.depth(a, d, len) >= len)
                .count()
        })
        .collect();
    // Among the eyes that see at least half as far as the best (not one inside a pier), the
    // most enclosed.
    let deepest = depths.iter().copied().fold(0.0, f64::max);
    let fewest_open = (0..candidates.len())
        .filter(|&i| depths[i] >= 0.5 * deepest)
        .map(|i| open[i])
        .min()
        .unwrap_or(0);
    let mut best_view: Option<(f64, DVec3, DVec3)> = None;
    for (i, (&(a, dir, len), &depth)) in candidates.iter().zip(&depths).enumerate() {
        if depth < 0.5 * deepest || open[i] > fewest_open {
            continue;
        }
        // Near ties go to the earlier candidate: low, in the middle, from the low end.
        if best_view.is_none_or(|v| depth > v.0 * 1.1) {
            best_view = Some((depth, a, a + dir * len * 0.9));
        }
    }
    // The model may be an object, and the eye inside it: the bunny's "nave" view was of its
    // inside; a closed box's bottom is a floor (floors are taken facing up or down, as
    // exporters flip them), and Box.glb was seen only from within. Such a model is first
    // seen from outside, floor or not. A flat model (one triangle, a sheet) has no inside:
    // its "nave" eye stood in its plane and saw nothing.
    let flat = (hi - lo).min_element() < 1e-3 * (hi - lo).max_element();
    if let Some((_, a, b)) = best_view {
        if flat || inside_an_object(p, &classes, a) {
            if floor.is_some() {
                cameras.insert(0, overview());
            }
        } else {
            cameras.push(camera("nave", a, b));
        }
    }
    let mut by_area: Vec<&crate::instances::Instance> = windows.iter().collect();
    let order = larger_window_first(windows);
    by_area.sort_by(|x, y| order(x, y));
    // The largest window the sun comes in through, glowing over its light on the floor; the
    // largest of all where the sun enters none.
    let enters = |w: &crate::instances::Instance| {
        travel(w.centre()).is_some_and(|d| w.inside.dot(d) > MIN_ENTRY_COS)
    };
    if let Some(w) = by_area.iter().find(|w| enters(w)).or(by_area.first()) {
        let target = w.centre();
        // From inside: back from the window along its inside normal, at eye height.
        let back = (w.width().max(w.height()) * 1.5).max(inner_diag * 0.05);
        let mut pos = within(target + w.inside * back);
        pos.y = eye;
        let mut views = vec![("windows", pos, target)];
        if let Some(fp) = &floor {
            // As the sun's score: a window the light leaves through lights the ground outside.
            let lit = by_area.iter().filter(|w| enters(w)).find_map(|w| {
                let d = travel(w.centre())?;
                Some((fp.land(w.centre(), d)?, d))
            });
            if let Some((spot, d)) = lit {
                let away = DVec3::new(d.x, 0.0, d.z).normalize_or_zero();
                let mut pos = within(spot + away * (hi.y - floor_y).max(inner_diag * 0.05) * 0.8);
                pos.y = eye;
                views.push(("lit-floor", pos, spot));
            }
        }
        for (name, pos, target) in unblocked(p, &classes, (lo, hi), &views) {
            cameras.push(camera(name, pos, target));
        }
    }
    // A model far from the origin for its size can put a view's eye and target on the same
    // f32 point, which looks nowhere.
    cameras.retain(|c| c.position != c.target);
    // The views the file frames come first (the viewer opens on the first), under their own
    // names; a guessed view of the same name gives way.
    let framed: Vec<Camera> = p.imported.iter().flat_map(|s| s.views.clone()).collect();
    if !framed.is_empty() {
        notes.push(format!(
            "the model's own cameras {} first",
            framed
                .iter()
                .map(|c| format!("{:?}", c.name))
                .collect::<Vec<_>>()
                .join(", ")
        ));
        let mut all: Vec<Camera> = Vec::new();
        for mut c in framed.into_iter().chain(cameras) {
            let base = c.name.clone();
            let mut k = 2;
            while all.iter().any(|o| o.name == c.name) {
                c.name = format!("{base} {k}");
                k += 1;
            }
            all.push(c);
        }
        cameras = all;
    }
    let sky = (!windows.is_empty()).then_some(DAYLIGHT_SKY);
    Guess {
        light,
        cameras,
        sky,
        notes,
        looks_z_up,
    }
}

/// A sun that falls into a window's inside: 45° down along the inside of upright glass,
/// straight down through a skylight. `None` for glass whose inside is straight up (a pane lit
/// from below, which no sun reaches): the sum was the zero vector there, and its NaN sun
/// failed the cook with an invalid light.
fn down_through(inside: DVec3) -> Option<DVec3> {
    (inside - DVec3::Y).try_normalize()
}

/// Windows in order of area, largest first; windows as large as each other (to a millionth of
/// the largest, float noise of their triangles' order) by their centres, lowest x, y, z first.
/// The order the model lists them in decided between equal windows, so a re-export with its
/// nodes in another order looked at another window.
fn larger_window_first(
    windows: &[crate::instances::Instance],
) -> impl Fn(&crate::instances::Instance, &crate::instances::Instance) -> std::cmp::Ordering {
    // Sizes and places in steps (a thousandth of the largest), so windows drawn alike tie
    // and are taken in order of place whatever an export's rounding: by a millionth, a
    // church's five equal windows on one wall were ordered by the noise in their x, and its
    // OBJ and glTF exports looked at windows 18 m apart.
    let largest = windows.iter().map(|w| w.area).fold(0.0f64, f64::max);
    let step = (largest * 1e-3).max(f64::MIN_POSITIVE);
    let at = (largest.sqrt() * 1e-3).max(f64::MIN_POSITIVE);
    move |a, b| {
        let size = |w: &crate::instances::Instance| (w.area / step).round();
        let place = |w: &crate::instances::Instance| (w.centre() / at).round();
        size(b).total_cmp(&size(a)).then_with(|| {
            let (p, q) = (place(a), place(b));
            p.x.total_cmp(&q.x)
                .then(p.y.total_cmp(&q.y))
                .then(p.z.total_cmp(&q.z))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn guessed_cameras(model: &std::path::Path) -> Vec<Camera> {
        let manifest = crate::manifest::Manifest::from_mesh_file(model).unwrap();
        crate::pipeline::cook(&manifest, &crate::Settings::new(&manifest))
            .unwrap()
            .toc
            .cameras
    }

    /// Spot (a cow: no floor, an object) is first seen whole from outside: every corner of its
    /// bounds lies in the cone of half the field of view around the view direction, which
    /// the view's frustum contains at any aspect of 1 or wider.
    #[test]
    fn an_object_without_a_floor_is_first_seen_whole_from_outside() {
        let spot = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/third_party/classic/spot.obj");
        let cameras = guessed_cameras(&spot);
        assert_eq!(cameras[0].name, "overview", "{cameras:?}");
        // The view "inside its bounds" for a building with an unrecognised floor stood inside
        // the cow and saw its inside: a closed object gets none.
        assert!(cameras.iter().all(|c| c.name != "nave"), "{cameras:?}");
        let c = &cameras[0];
        let src = crate::import::import(&spot).unwrap();
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        for p in &src.positions {
            let p = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64);
            (lo, hi) = (lo.min(p), hi.max(p));
        }
        let eye = DVec3::new(
            c.position[0] as f64,
            c.position[1] as f64,
            c.position[2] as f64,
        );
        let target = DVec3::new(c.target[0] as f64, c.target[1] as f64, c.target[2] as f64);
        let inside = |q: DVec3| q.cmpge(lo).all() && q.cmple(hi).all();
        assert!(!inside(eye), "the camera is inside the model's bounds");
        let view = (target - eye).normalize();
        let half = (c.fov_y as f64).to_radians() * 0.5;
        for k in 0..8 {
            let corner = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            let angle = view.angle_between(corner - eye);
            assert!(
                angle <= half + 1e-6,
                "corner {corner} is {angle} rad off the view"
            );
            assert!((corner - eye).length() > c.near as f64);
        }
    }

    /// A hall on open ground is seen from inside, and the `lit-floor` view looks where the sun
    /// comes in, not where it leaves. The largest window is alone on the north wall; three
    /// smaller ones on the south wall add up to more glass, so the sun comes in from the
    /// south. The sun's line through the north window runs out of the hall and lands on the
    /// ground outside, where the view looked before windows facing away from the sun were
    /// passed over; and every view stood on the ground outside before views were kept within
    /// the walls.
    #[test]
    fn a_hall_on_open_ground_is_seen_from_inside_where_the_sun_comes_in() {
        // 40 m of ground, and a kilometre, where the eye once stood at 2.8 m.
        for half in [20.0, 500.0] {
            hall_on_open_ground(half);
        }
    }

    fn hall_on_open_ground(half: f64) {
        let dir = tempfile::tempdir().unwrap();
        let (obj, mtl) = crate::testing::hall_on_open_ground(half);
        let path = dir.path().join("hall.obj");
        std::fs::write(&path, obj).unwrap();
        std::fs::write(dir.path().join("hall.mtl"), mtl).unwrap();
        let manifest = crate::manifest::Manifest::from_mesh_file(&path).unwrap();
        let toc = crate::pipeline::cook(&manifest, &crate::Settings::new(&manifest))
            .unwrap()
            .toc;
        // The ground's two triangles once put its area at their centroids: the one outside
        // beside the west south window turned that window outwards.
        for w in &toc.windows {
            let into_hall = if w.origin[2] > 0.0 { -1.0 } else { 1.0 };
            assert_eq!(
                w.normal[2], into_hall,
                "the window at {:?} faces out",
                w.origin
            );
        }
        assert_eq!(toc.background.colour, DAYLIGHT_SKY);
        let cameras = toc.cameras;
        let lit = cameras
            .iter()
            .find(|c| c.name == "lit-floor")
            .unwrap_or_else(|| panic!("no lit-floor view: {cameras:?}"));
        let [x, y, z] = lit.target;
        assert!(
            x.abs() < 5.0 && z.abs() < 3.0 && y.abs() < 1e-3,
            "the lit-floor view looks at {:?}, outside the hall",
            lit.target
        );
        // The `windows` view shows a south window, lit from behind, not the larger north one.
        let shown = cameras.iter().find(|c| c.name == "windows").unwrap();
        assert!(
            (shown.target[2] + 2.99).abs() < 1e-3,
            "the windows view looks at {:?}",
            shown.target
        );
        assert_eq!(cameras.len(), 3, "{cameras:?}");
        // At eye height: 0.12 of the hall's height.
        assert!(
            (lit.position[1] - 0.48).abs() < 1e-3,
            "{half} m of ground: {cameras:?}"
        );
        for c in &cameras {
            let [x, y, z] = c.position;
            assert!(
                x.abs() < 5.0 && z.abs() < 3.0 && y > 0.0 && y < 4.0,
                "view {} stands at {:?}, outside the hall ({half} m of ground each way)",
                c.name,
                c.position
            );
        }
    }

    /// The hall on open ground as a glTF with `lamps` (name, node, light) of its own: its light
    /// and the guess's words.
    fn hall_with_lamps(
        lamps: &[(&str, serde_json::Value, serde_json::Value)],
    ) -> (Option<pack::Light>, String) {
        let (toc, words) = hall_toc_with_lamps(lamps);
        (toc.light, words)
    }

    /// [`hall_with_lamps`], with the whole table of contents.
    fn hall_toc_with_lamps(
        lamps: &[(&str, serde_json::Value, serde_json::Value)],
    ) -> (pack::Toc, String) {
        let dir = tempfile::tempdir().unwrap();
        let (nodes, lights): (Vec<_>, Vec<_>) = lamps
            .iter()
            .enumerate()
            .map(|(i, (name, node, light))| {
                let mut node = node.clone();
                node["name"] = serde_json::json!(format!("node of {name}"));
                node["extensions"] = serde_json::json!({"KHR_lights_punctual": {"light": i}});
                let mut light = light.clone();
                light["name"] = serde_json::json!(name);
                (node, light)
            })
            .unzip();
        let (gltf, bin) = crate::testing::hall_gltf(20.0, nodes, lights);
        std::fs::write(dir.path().join("hall.bin"), bin).unwrap();
        let path = dir.path().join("hall.gltf");
        std::fs::write(&path, serde_json::to_vec(&gltf).unwrap()).unwrap();
        bare_cook(&path)
    }

    /// A bare cook of `model`: its table of contents and its warnings' words, a line each
    /// (the guess's notes among them).
    fn bare_cook(model: &std::path::Path) -> (pack::Toc, String) {
        let manifest = crate::manifest::Manifest::from_mesh_file(model).unwrap();
        let out = crate::pipeline::cook(&manifest, &crate::Settings::new(&manifest)).unwrap();
        let words = out
            .report
            .warnings
            .iter()
            .map(|w| w.message.clone())
            .collect::<Vec<_>>()
            .join("\n");
        (out.toc, words)
    }

    /// The views a spot light gets look at the window its cone reaches and the floor it
    /// lights through it, not at the first window of the wall it stands outside (which the
    /// cook skips for it). The spot stands outside the south wall, aimed at its third window.
    #[test]
    fn a_spot_lights_the_window_its_views_look_at() {
        use serde_json::json;
        let at = glam::Vec3::new(3.5, 5.0, -10.0);
        let aim = glam::Vec3::new(3.5, 2.25, -2.99);
        let turn = glam::Quat::from_rotation_arc(glam::Vec3::NEG_Z, (aim - at).normalize());
        let (toc, words) = hall_toc_with_lamps(&[(
            "Strahler",
            json!({"translation": at.to_array(), "rotation": turn.to_array()}),
            json!({"type": "spot", "spot": {"outerConeAngle": 0.12}}),
        )]);
        assert!(
            matches!(toc.light.unwrap().kind, pack::LightKind::Spot { .. }),
            "{words}"
        );
        let view = |name: &str| {
            toc.cameras
                .iter()
                .find(|c| c.name == name)
                .unwrap_or_else(|| panic!("no {name} view: {:?}\n{words}", toc.cameras))
        };
        let target = glam::Vec3::from(view("windows").target);
        assert!((target - aim).length() < 1e-3, "{target}\n{words}");
        // Its light lands on the floor inside, beyond the window, within the cone's reach.
        let spot = glam::Vec3::from(view("lit-floor").target);
        assert!(spot.y.abs() < 1e-3 && spot.z > -2.99, "{spot}");
        assert!((spot.x - 3.5).abs() < 0.5, "{spot}");
    }

    /// glTF's `range`: a lamp whose light would land past it gives none there and is not the
    /// light, and the guess says why; one whose light lands within it is, with a note that
    /// the pack has no cut-off. The lantern's light travels 7-9 m to the floor.
    #[test]
    fn a_lamp_out_of_its_range_is_not_the_light() {
        use serde_json::json;
        let lantern = |range: f64| {
            (
                "Laterne",
                json!({"translation": [0.0, 6.0, 8.0]}),
                json!({"type": "point", "intensity": 800.0, "range": range}),
            )
        };
        let (light, words) = hall_with_lamps(&[lantern(2.0)]);
        assert!(
            matches!(light.unwrap().kind, pack::LightKind::Directional { .. }),
            "{words}"
        );
        assert!(
            words.contains(
                "the model's lamps \"Laterne\" are not used: none of them shines in through a \
                 window onto the floor (\"Laterne\" would, but its light lands past its range)"
            ),
            "{words}"
        );
        let (light, words) = hall_with_lamps(&[lantern(30.0)]);
        assert!(
            matches!(light.unwrap().kind, pack::LightKind::Point { .. }),
            "{words}"
        );
        assert!(
            words.contains("(its range, 30, is not a cut-off in the pack"),
            "{words}"
        );
    }

    /// A node naming a light the file does not define, and a light of a type glTF does not
    /// define, are each said, as what they are; lights are read, so requiring the extension
    /// is no warning.
    #[test]
    fn broken_lights_are_named_for_what_is_wrong() {
        use serde_json::json;
        let dir = tempfile::tempdir().unwrap();
        let nodes = vec![
            json!({"name": "Lampe", "extensions": {"KHR_lights_punctual": {"light": 7}}}),
            json!({"name": "Fläche", "extensions": {"KHR_lights_punctual": {"light": 0}}}),
        ];
        let lights = vec![json!({"name": "Fläche", "type": "area"})];
        let (mut gltf, bin) = crate::testing::hall_gltf(20.0, nodes, lights);
        gltf["extensionsRequired"] = json!(["KHR_lights_punctual"]);
        std::fs::write(dir.path().join("hall.bin"), bin).unwrap();
        let path = dir.path().join("hall.gltf");
        std::fs::write(&path, serde_json::to_vec(&gltf).unwrap()).unwrap();
        let imported = crate::import::import_with(&path, None).unwrap();
        let words: Vec<String> = imported
            .warnings
            .iter()
            .map(|w| w.message.clone())
            .collect();
        assert_eq!(
            words,
            [
                "node \"Lampe\" places light 7, but the file defines 1 lights: no light placed \
                 there",
                "light \"Fläche\" has type \"area\", which KHR_lights_punctual does not define \
                 (directional, point, spot): not used",
            ],
        );
    }

    /// A lamp of the file's that shines in through a window onto the floor is the light, as a
    /// lamp outside a church's glass is set up to; lamps indoors, spots turned away and lamps
    /// beside the file's own sun are passed over, and said so. The hall's one north window
    /// faces a lantern 5 m out and 6 m up; its candle stands inside.
    #[test]
    fn a_lamp_shining_in_through_the_windows_is_the_light_and_one_indoors_is_not() {
        use serde_json::json;
        let point = json!({"type": "point", "color": [1.0, 0.8, 0.5], "intensity": 800.0});
        let lantern = (
            "Laterne",
            json!({"translation": [0.0, 6.0, 8.0]}),
            point.clone(),
        );
        let candle = (
            "Kerze",
            json!({"translation": [0.0, 2.0, 0.0]}),
            point.clone(),
        );
        let lantern_at = [0.0, 6.0, 8.0];
        let is_lamp = |light: &Option<pack::Light>| match light.as_ref().map(|l| &l.kind) {
            Some(pack::LightKind::Point { position, radius }) => {
                assert_eq!(*position, lantern_at);
                // The sun's half degree, seen from the nearest point of the window.
                assert!(*radius > 0.02 && *radius < 0.05, "{radius}");
                let l = light.as_ref().unwrap();
                assert_eq!(l.colour, [1.0, 0.8, 0.5]);
                // Exposed as the sun is, at the 7-9 m its light travels to the floor.
                assert!(l.intensity > 40.0 && l.intensity < 400.0, "{}", l.intensity);
                true
            }
            _ => false,
        };

        let (light, words) = hall_with_lamps(std::slice::from_ref(&lantern));
        assert!(is_lamp(&light), "{light:?}\n{words}");
        assert!(
            words.contains(
                "the model's own point light \"Laterne\", which shines in through 1 of 4 windows"
            ),
            "{words}"
        );

        let (light, words) = hall_with_lamps(std::slice::from_ref(&candle));
        assert!(
            matches!(light.unwrap().kind, pack::LightKind::Directional { .. }),
            "{words}"
        );
        assert!(
            words.contains(
                "the model's lamps \"Kerze\" are not used: none of them shines in \
                            through a window onto the floor"
            ),
            "{words}"
        );

        let (light, words) = hall_with_lamps(&[candle.clone(), lantern.clone()]);
        assert!(is_lamp(&light), "{light:?}\n{words}");
        assert!(
            words.contains("lamps \"Kerze\" are not used: a pack holds one light"),
            "{words}"
        );

        // A spot at the lantern: its axis is its node's -z, towards the hall; turned half way
        // round about y it points away, and a narrow cone aimed above the hall misses the glass.
        let spot = |cone: f64| json!({"type": "spot", "spot": {"outerConeAngle": cone}});
        let s = std::f64::consts::FRAC_1_SQRT_2;
        let (light, words) =
            hall_with_lamps(&[("Strahler", json!({"translation": lantern_at}), spot(0.6))]);
        // The pack's light keeps the cone.
        match light.as_ref().unwrap().kind {
            pack::LightKind::Spot {
                direction,
                inner,
                outer,
                ..
            } => {
                let towards = (glam::Vec3::ZERO - glam::Vec3::from(lantern_at)).normalize();
                assert!(
                    glam::Vec3::from(direction).dot(towards) > 0.5,
                    "{direction:?}"
                );
                assert_eq!((inner, outer), (0.0, 0.6));
            }
            ref other => panic!("{other:?}\n{words}"),
        }
        // Its exposure makes up for the share of its light the cone's soft edge takes: the
        // window lies near the edge of a cone with no full-light core (inner 0), where a few
        // percent of the light gets through, so the spot is far brighter than the lantern.
        let lamp_intensity = hall_with_lamps(std::slice::from_ref(&lantern))
            .0
            .unwrap()
            .intensity;
        let spot_intensity = light.as_ref().unwrap().intensity;
        assert!(
            spot_intensity > 10.0 * lamp_intensity && spot_intensity < 1000.0 * lamp_intensity,
            "{spot_intensity} against {lamp_intensity}"
        );
        assert!(words.contains("spot light \"Strahler\""), "{words}");
        for node in [
            json!({"translation": lantern_at, "rotation": [0.0, 1.0, 0.0, 0.0]}),
            // Tilted 45° up about x.
            json!({"translation": lantern_at, "rotation": [0.382_683_43, 0.0, 0.0, 0.923_879_5]}),
        ] {
            let (light, words) = hall_with_lamps(&[("Strahler", node, spot(0.1))]);
            assert!(
                matches!(light.unwrap().kind, pack::LightKind::Directional { .. }),
                "{words}"
            );
            assert!(words.contains("\"Strahler\" are not used"), "{words}");
        }

        // A lamp a million times the hall's size away is a sun along its light.
        let far = (
            "Laterne",
            json!({"translation": [0.0, 6e6, 8e6]}),
            point.clone(),
        );
        let (light, words) = hall_with_lamps(&[far]);
        match light.as_ref().map(|l| &l.kind) {
            Some(pack::LightKind::Directional { direction, .. }) => {
                let d = glam::Vec3::from(*direction);
                assert!(
                    (d - glam::Vec3::new(0.0, -0.6, -0.8)).length() < 1e-5,
                    "{d}"
                );
            }
            other => panic!("{other:?}\n{words}"),
        }
        assert!(
            words.contains("so far away that it is taken as a sun"),
            "{words}"
        );

        // The file's own sun comes first.
        let sun = (
            "Sonne",
            json!({"rotation": [-s, 0.0, 0.0, s]}),
            json!({"type": "directional"}),
        );
        let (light, words) = hall_with_lamps(&[lantern, sun]);
        assert!(
            matches!(light.unwrap().kind, pack::LightKind::Directional { .. }),
            "{words}"
        );
        assert!(
            words.contains("lamps \"Laterne\" are not used: its sun \"Sonne\" lights the scene"),
            "{words}"
        );
    }

    /// Two halls a metre apart along their length, each with windows in its +x wall (the
    /// first's facing the second): the nave view is inside a hall. The alley between them ran farthest, and the
    /// view stood there, outside both.
    #[test]
    fn the_nave_view_is_inside_a_hall_not_in_the_alley_between_two() {
        use std::fmt::Write;
        let dir = tempfile::tempdir().unwrap();
        let mut obj = String::from("mtllib halls.mtl\n");
        let mut n = 0;
        let mut quad = |obj: &mut String, m: &str, o: [f64; 3], a: [f64; 3], b: [f64; 3]| {
            let _ = writeln!(obj, "usemtl {m}");
            for c in [[0., 0.], [1., 0.], [1., 1.], [0., 1.]] {
                let p: Vec<f64> = (0..3).map(|k| o[k] + c[0] * a[k] + c[1] * b[k]).collect();
                let _ = writeln!(obj, "v {} {} {}", p[0], p[1], p[2]);
            }
            let _ = writeln!(obj, "f {} {} {} {}", n + 1, n + 2, n + 3, n + 4);
            n += 4;
        };
        for (x0, windows) in [(-5.0, true), (6.0, true)] {
            let x1 = x0 + 10.0;
            quad(
                &mut obj,
                "floor",
                [x0, 0., 0.],
                [10., 0., 0.],
                [0., 0., 30.],
            );
            quad(&mut obj, "roof", [x0, 8., 0.], [10., 0., 0.], [0., 0., 30.]);
            quad(&mut obj, "wall", [x0, 0., 0.], [0., 0., 30.], [0., 8., 0.]);
            quad(&mut obj, "wall", [x0, 0., 0.], [10., 0., 0.], [0., 8., 0.]);
            quad(&mut obj, "wall", [x0, 0., 30.], [10., 0., 0.], [0., 8., 0.]);
            if windows {
                quad(&mut obj, "wall", [x1, 0., 0.], [0., 0., 30.], [0., 2., 0.]);
                quad(&mut obj, "wall", [x1, 6., 0.], [0., 0., 30.], [0., 2., 0.]);
                for (z, l) in [(0., 4.), (6., 5.), (13., 5.), (20., 5.), (27., 3.)] {
                    quad(&mut obj, "wall", [x1, 2., z], [0., 0., l], [0., 4., 0.]);
                }
                for z in [4., 11., 18., 25.] {
                    quad(&mut obj, "glass", [x1, 2., z], [0., 0., 2.], [0., 4., 0.]);
                }
            } else {
                quad(&mut obj, "wall", [x1, 0., 0.], [0., 0., 30.], [0., 8., 0.]);
            }
        }
        let model = dir.path().join("halls.obj");
        std::fs::write(&model, obj).unwrap();
        std::fs::write(
            dir.path().join("halls.mtl"),
            "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl roof\nKd 0.4 0.4 0.4\nnewmtl wall\nKd 0.8 0.8 0.8\n\
             newmtl glass\nKd 0.2 0.4 0.8\nd 0.3\n",
        )
        .unwrap();
        let cameras = guessed_cameras(&model);
        let nave = cameras
            .iter()
            .find(|c| c.name == "nave")
            .expect("a nave view");
        let x = nave.position[0];
        assert!(
            !(5.0..=6.0).contains(&x),
            "the nave view stands in the alley: {nave:?}"
        );
    }

    /// A model with a floor is a building: its first camera looks down it from inside.
    #[test]
    fn a_model_with_a_floor_is_seen_from_inside() {
        let dir = tempfile::tempdir().unwrap();
        let grid = dir.path().join("grid.obj");
        std::fs::write(&grid, crate::testing::height_field_obj(20)).unwrap();
        let cameras = guessed_cameras(&grid);
        assert_eq!(cameras[0].name, "nave", "{cameras:?}");
        assert!(cameras.iter().all(|c| c.name != "overview"));
    }

    /// A closed box whose bottom reads as a floor (Box.glb) and a lone triangle are objects
    /// seen from outside: the box got only a view from within it, the triangle one standing in
    /// its plane.
    #[test]
    fn a_closed_box_and_a_flat_sheet_are_seen_from_outside() {
        let sample = |rel: &str| {
            std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("../../tests/data/third_party/gltf")
                .join(rel)
        };
        for model in [
            "Box/Box.glb",
            "TriangleWithoutIndices/TriangleWithoutIndices.gltf",
        ] {
            let cameras = guessed_cameras(&sample(model));
            assert_eq!(cameras[0].name, "overview", "{model}: {cameras:?}");
            assert!(
                cameras.iter().all(|c| c.name != "nave"),
                "{model}: {cameras:?}"
            );
        }
    }

    /// A square room's view does not turn when a corner of its floor moves a centimetre (a
    /// regression test's edit): it looked along z at 4 x 4.01 m and along x at 4 x 4.
    #[test]
    fn a_square_room_s_view_stays_put_under_a_small_edit() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("room.mtl"),
            "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl wall\nKd 0.7 0.7 0.7\n\
             newmtl glass\nKd 0.2 0.4 0.8\nd 0.3\n",
        )
        .unwrap();
        let nave = |z: f64| {
            let obj = format!(
                "mtllib room.mtl\nv 0 0 0\nv 4 0 0\nv 4 0 {z}\nv 0 0 4\n\
                 v 0 3 0\nv 0 3 4\nv 0 1 1.5\nv 0 2 1.5\nv 0 2 2.5\nv 0 1 2.5\n\
                 usemtl floor\nf 1 4 3\nf 1 3 2\nusemtl wall\nf 1 4 6\nf 1 6 5\n\
                 usemtl glass\nf 7 10 9\nf 7 9 8\n"
            );
            let model = dir.path().join(format!("room-{z}.obj"));
            std::fs::write(&model, obj).unwrap();
            let cameras = guessed_cameras(&model);
            let c = cameras.iter().find(|c| c.name == "nave").cloned();
            c.unwrap_or_else(|| panic!("no nave view at {z}: {cameras:?}"))
        };
        let square = nave(4.0);
        for z in [3.99, 4.01, 4.2] {
            let edited = nave(z);
            let moved = (DVec3::from(edited.position.map(f64::from))
                - DVec3::from(square.position.map(f64::from)))
            .length();
            let turned = (DVec3::from(edited.target.map(f64::from))
                - DVec3::from(edited.position.map(f64::from)))
            .normalize()
            .dot(
                (DVec3::from(square.target.map(f64::from))
                    - DVec3::from(square.position.map(f64::from)))
                .normalize(),
            );
            assert!(
                moved < 0.3 && turned > 0.99,
                "at {z}: {edited:?} against {square:?}"
            );
        }
    }

    /// The same church with its coordinates rounded another way (an OBJ and a glTF export,
    /// 3e-6 apart) gets the same views: the nave's eye stood 1.2 or 5 m high and the window
    /// views looked at windows 18 m apart, as rays along cell faces and the order of equal
    /// windows followed the noise.
    #[test]
    fn an_export_s_rounding_does_not_move_the_views() {
        let dir = tempfile::tempdir().unwrap();
        let views = |noise| {
            let (obj, mtl) = crate::testing::nave_of_equal_windows(noise);
            std::fs::write(dir.path().join("m.mtl"), mtl).unwrap();
            let model = dir
                .path()
                .join(format!("nave-{}.obj", noise.map_or(0, |n| n.1)));
            std::fs::write(&model, obj).unwrap();
            guessed_cameras(&model)
        };
        let exact = views(None);
        assert!(exact.len() >= 3, "{exact:?}");
        for seed in 1..=4 {
            let rounded = views(Some((3e-6, seed)));
            assert_eq!(rounded.len(), exact.len(), "{rounded:?} against {exact:?}");
            for (r, e) in rounded.iter().zip(&exact) {
                let far = |a: [f32; 3], b: [f32; 3]| {
                    (DVec3::from(a.map(f64::from)) - DVec3::from(b.map(f64::from))).length()
                };
                assert!(
                    r.name == e.name
                        && far(r.position, e.position) < 1e-3
                        && far(r.target, e.target) < 1e-3,
                    "seed {seed}: {r:?} against {e:?}"
                );
            }
        }
    }

    /// The Cornell box is open at z = 0: its first view stands by the opening and looks in at
    /// the blocks and the back wall, not from the back wall out into the void.
    #[test]
    fn a_box_open_at_one_end_is_seen_into_from_the_opening() {
        let model = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/third_party/cornell_box/cornell_box.obj");
        let cameras = guessed_cameras(&model);
        let nave = &cameras[0];
        assert_eq!(nave.name, "nave", "{cameras:?}");
        assert!(
            nave.target[2] > nave.position[2] && nave.position[2] < 559.2 * 0.5,
            "{nave:?}"
        );
    }

    /// Cameras the pack accepts, whatever the model's unit: the Cornell box (550 units across)
    /// at 1e-6 of its size had its views' near planes behind their far ones, and the cook
    /// failed at the pack's validation. A model whose corners are all one point gets no views.
    #[test]
    fn views_are_valid_at_any_scale() {
        let dir = tempfile::tempdir().unwrap();
        let box_dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/third_party/cornell_box");
        let source = std::fs::read_to_string(box_dir.join("cornell_box.obj")).unwrap();
        std::fs::copy(
            box_dir.join("cornell_box.mtl"),
            dir.path().join("cornell_box.mtl"),
        )
        .unwrap();
        for scale in [1e-6, 1e-3, 1.0, 1e4] {
            let model = dir.path().join(format!("box-{scale}.obj"));
            std::fs::write(&model, crate::testing::scaled_obj(&source, scale)).unwrap();
            let cameras = guessed_cameras(&model);
            assert!(!cameras.is_empty(), "scale {scale}");
            for c in &cameras {
                assert!(
                    c.near > 0.0 && c.far > c.near && c.position != c.target,
                    "scale {scale}: {c:?}"
                );
            }
        }
        let point = dir.path().join("point.obj");
        std::fs::write(&point, "v 1 2 3\nv 1 2 3\nv 1 2 3\nf 1 2 3\n").unwrap();
        // The guess runs on it (beside the mesh stage) without a panic; the cook then refuses
        // a model with nothing of non-zero area.
        let manifest = crate::manifest::Manifest::from_mesh_file(&point).unwrap();
        let e = crate::pipeline::cook(&manifest, &crate::Settings::new(&manifest)).unwrap_err();
        assert!(e.to_string().contains("zero area"), "{e}");
    }

    /// A room whose floor faces z is said to look Z-up; the same room y-up is not.
    #[test]
    fn a_z_up_model_is_pointed_out() {
        let dir = tempfile::tempdir().unwrap();
        let notes = |z_up: bool| {
            let v = |x: f64, y: f64, z: f64| {
                if z_up {
                    format!("v {x} {} {y}\n", -z)
                } else {
                    format!("v {x} {y} {z}\n")
                }
            };
            let mut obj = String::new();
            // Floor 10 x 20, and two walls 8 high along its long sides.
            for (x, y, z) in [
                (-5., 0., -10.),
                (5., 0., -10.),
                (5., 0., 10.),
                (-5., 0., 10.),
            ] {
                obj += &v(x, y, z);
            }
            for side in [-5.0, 5.0] {
                for (y, z) in [(0., -10.), (0., 10.), (8., 10.), (8., -10.)] {
                    obj += &v(side, y, z);
                }
            }
            obj += "usemtl floor\nf 1 4 3 2\nusemtl wall\nf 5 6 7 8\nf 9 12 11 10\n";
            let model = dir.path().join(format!("room-{z_up}.obj"));
            std::fs::write(&model, obj).unwrap();
            bare_cook(&model).1
        };
        assert!(notes(true).contains("looks Z-up"), "{}", notes(true));
        assert!(!notes(false).contains("Z-up"), "{}", notes(false));
    }

    /// A Z-up nave whose floor is named for its stone ("Marble"), not as a floor: read Y-up
    /// it stands on its edge and is taken for a wall, so no floor is found; its lancets, tall
    /// in the walls, then lie along z, and tell. The nave read the right way up is not said
    /// to be Z-up.
    #[test]
    fn a_z_up_nave_with_an_unnamed_floor_is_pointed_out_by_its_lancets() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(
            dir.path().join("nave.mtl"),
            "newmtl Marble\nKd 0.5 0.5 0.5\nnewmtl Stone\nKd 0.6 0.6 0.6\n\
             newmtl Glass\nKd 0.2 0.2 0.2\nTf 0.2 0.4 0.9\nillum 4\n",
        )
        .unwrap();
        let notes = |z_up: bool| {
            let mut obj = String::from("mtllib nave.mtl\n");
            let mut n = 0;
            let mut quad = |obj: &mut String, m: &str, pts: [[f64; 3]; 4]| {
                *obj += &format!("usemtl {m}\n");
                for [x, y, z] in pts {
                    *obj += &if z_up {
                        format!("v {x} {} {y}\n", -z)
                    } else {
                        format!("v {x} {y} {z}\n")
                    };
                }
                *obj += &format!("f {} {} {} {}\n", n + 1, n + 2, n + 3, n + 4);
                n += 4;
            };
            quad(
                &mut obj,
                "Marble",
                [
                    [-5., 0., -10.],
                    [-5., 0., 10.],
                    [5., 0., 10.],
                    [5., 0., -10.],
                ],
            );
            for x in [-5.0, 5.0] {
                quad(
                    &mut obj,
                    "Stone",
                    [[x, 0., -10.], [x, 0., 10.], [x, 8., 10.], [x, 8., -10.]],
                );
                for z in [-6.0, -2.0, 2.0, 6.0] {
                    let x = x * 0.99;
                    quad(
                        &mut obj,
                        "Glass",
                        [
                            [x, 2., z - 0.5],
                            [x, 2., z + 0.5],
                            [x, 6., z + 0.5],
                            [x, 6., z - 0.5],
                        ],
                    );
                }
            }
            let model = dir.path().join(format!("nave-{z_up}.obj"));
            std::fs::write(&model, obj).unwrap();
            bare_cook(&model).1
        };
        assert!(notes(true).contains("looks Z-up"), "{}", notes(true));
        assert!(!notes(false).contains("Z-up"), "{}", notes(false));
    }

    /// A Z-up hall whose floor and walls have no telling names: the geometry takes its lowest
    /// wall, lying flat, for the floor, which faces y; the glass of that wall, lying flat at
    /// the bottom of the model, still tells. The hall read the right way up is not said to be.
    #[test]
    fn a_z_up_hall_with_generic_names_is_pointed_out() {
        let dir = tempfile::tempdir().unwrap();
        let (obj, mtl) = crate::testing::hall_on_open_ground(20.0);
        let ground = std::cell::Cell::new("Material.001");
        let generic = |t: &str| {
            t.replace("ground", ground.get())
                .replace("wall", "Material.002")
        };
        let z_up: String = obj
            .lines()
            .map(|l| match l.strip_prefix("v ") {
                Some(rest) => {
                    let c: Vec<f64> = rest.split(' ').map(|x| x.parse().unwrap()).collect();
                    format!("v {} {} {}\n", c[0], -c[2], c[1])
                }
                None => format!("{l}\n"),
            })
            .collect();
        let notes = |obj: &str, name: &str| {
            let model = dir.path().join(format!("{name}.obj"));
            std::fs::write(&model, generic(obj)).unwrap();
            std::fs::write(dir.path().join("hall.mtl"), generic(&mtl)).unwrap();
            bare_cook(&model).1
        };
        let said = notes(&z_up, "z");
        assert!(said.contains("looks Z-up"), "{said}");
        let said = notes(&obj, "y");
        assert!(!said.contains("Z-up"), "{said}");
        // The ground named a floor: it faces z, beside the wall the geometry cuts out as a
        // floor lying flat, which no longer outweighs it.
        ground.set("Floor");
        let said = notes(&z_up, "z-floor");
        assert!(said.contains("looks Z-up"), "{said}");
        let said = notes(&obj, "y-floor");
        assert!(!said.contains("Z-up"), "{said}");
    }

    fn marked(t: [DVec3; 3]) -> Vec<bool> {
        let mut full = Cells::new();
        mark_cells(&mut full, &Cells::all(), t);
        (0..OCC * OCC * OCC).map(|i| full.get(i)).collect()
    }

    fn cell(q: DVec3) -> [usize; 3] {
        let q = q.min(DVec3::splat(OCC as f64 - 1e-6)).as_uvec3();
        [q.x as usize, q.y as usize, q.z as usize]
    }

    #[test]
    fn a_level_triangle_marks_its_own_layer_only() {
        let t = [
            DVec3::new(2.5, 10.5, 3.5),
            DVec3::new(9.5, 10.5, 3.5),
            DVec3::new(2.5, 10.5, 7.5),
        ];
        let full = marked(t);
        let layer = (0..OCC * OCC * OCC)
            .filter(|&i| full[i])
            .map(|i| i / OCC % OCC)
            .collect::<std::collections::BTreeSet<_>>();
        assert_eq!(layer.into_iter().collect::<Vec<_>>(), vec![10]);
        // Columns x 2..=9 by z 3..=7 that the hypotenuse leaves something of: 8, 7, 5, 4 and 2
        // of the rows z = 3..=7.
        assert_eq!(full.iter().filter(|&&f| f).count(), 8 + 7 + 5 + 4 + 2);
    }

    proptest! {
        /// Views see exactly as far when only the triangles near their rays are marked.
        #[test]
        fn views_read_only_the_cells_they_can_reach(
            tris in prop::collection::vec(
                (prop::array::uniform3(0.0f64..10.0), prop::array::uniform3(prop::array::uniform3(-1.5f64..1.5))),
                1..80,
            ),
            eyes in prop::collection::vec((prop::array::uniform3(0.0f64..10.0), 0.0f64..std::f64::consts::TAU), 1..6),
        ) {
            let (lo, hi) = (DVec3::ZERO, DVec3::splat(10.0));
            let views: Vec<(DVec3, DVec3)> = eyes
                .iter()
                .map(|&(e, a)| (DVec3::from(e), DVec3::new(a.cos(), 0.0, a.sin())))
                .collect();
            let mut whole = Occupancy::empty(lo, hi);
            let mut part = Occupancy::empty(lo, hi);
            let wanted = part.reach(&views, 12.0);
            for (centre, offsets) in &tris {
                let t = offsets.map(|o| (DVec3::from(*centre) + DVec3::from(o) - lo) / whole.cell);
                mark_cells(&mut whole.full, &Cells::all(), t);
                mark_cells(&mut part.full, &wanted, t);
            }
            for &(eye, dir) in &views {
                prop_assert_eq!(
                    whole.view_depth(eye, dir, 12.0).to_bits(),
                    part.view_depth(eye, dir, 12.0).to_bits()
                );
            }
        }

        /// The march passes every cell that a dense walk along the ray finds, in the walk's
        /// order, each next to the one before, and says the ray enters a cell where the walk
        /// first finds it (within one step of the walk).
        #[test]
        fn marching_passes_every_cell_the_ray_crosses(
            eye in prop::array::uniform3(0.0f64..1.0),
            dir in prop::array::uniform3(-1.0f64..1.0),
            max in 0.5f64..30.0,
        ) {
            let dir = DVec3::from(dir);
            prop_assume!(dir.length() > 0.1);
            let d = dir.normalize();
            // Cells of three different sizes.
            let (lo, hi) = (DVec3::new(-1.0, 2.0, 0.5), DVec3::new(9.0, 3.0, 7.5));
            let grid = Occupancy::empty(lo, hi);
            let eye = lo + DVec3::from(eye) * (hi - lo);
            let mut passed = Vec::new();
            grid.march(eye, d, max, |i| {
                passed.push(i);
                false
            });
            let at = |i: usize| cell_coords(i).map(|c| c as i64);
            for w in passed.windows(2) {
                let (a, b) = (at(w[0]), at(w[1]));
                let steps: i64 = (0..3).map(|k| (a[k] - b[k]).abs()).sum();
                prop_assert_eq!(steps, 1, "{:?} to {:?}", a, b);
            }
            let step = 1e-3;
            let own = grid.index(eye);
            let mut walk: Vec<(usize, f64)> = Vec::new();
            let mut t = step;
            while t < max - step {
                match grid.index(eye + d * t) {
                    None => break,
                    Some(i) if Some(i) != own && walk.last().map(|w| w.0) != Some(i) => {
                        walk.push((i, t))
                    }
                    _ => {}
                }
                t += step;
            }
            let mut rest = passed.iter();
            for &(cell, _) in &walk {
                prop_assert!(rest.any(|&p| p == cell), "cell {:?} not passed", at(cell));
            }
            if let Some(&(first, t)) = walk.first() {
                let entry = grid.march(eye, d, max, |i| i == first);
                prop_assert!(entry <= t + 1e-9 && entry > t - step - 1e-9, "{entry} against {t}");
            }
        }

        /// Every point of the triangle lies in a marked cell, and every marked cell touches one
        /// that holds a point of it (the cut is exact but for rounding at cell faces).
        #[test]
        fn columns_cover_the_triangle_and_little_else(
            corners in prop::array::uniform3(prop::array::uniform3(0.0f64..24.0)),
            flat in prop::sample::select(vec![None, Some(0usize), Some(1), Some(2)]),
        ) {
            let mut t = corners.map(DVec3::from);
            if let Some(axis) = flat {
                // Thin along one axis, as a height field's triangles are in cell units.
                let base = t[0][axis];
                for q in &mut t {
                    q[axis] = base + (q[axis] - base) * 0.01;
                }
            }
            let full = marked(t);
            // Dense points strictly inside, away from cell faces where rounding may go either way.
            let longest = (0..3).map(|i| (t[(i + 1) % 3] - t[i]).length()).fold(0.0, f64::max);
            let steps = (longest * 4.0).ceil() as usize;
            let mut touched = vec![false; OCC * OCC * OCC];
            for i in 0..=steps {
                for j in 0..=steps - i {
                    let (s, r) = (i as f64 / steps as f64, j as f64 / steps as f64);
                    let q = t[0] + (t[1] - t[0]) * s + (t[2] - t[0]) * r;
                    let [x, y, z] = cell(q);
                    touched[cell_index(x, y, z)] = true;
                    let near_face = (0..3).any(|a| (q[a] - q[a].round()).abs() < 1e-9);
                    prop_assert!(near_face || full[cell_index(x, y, z)], "{q:?} of {t:?}");
                }
            }
            for i in (0..full.len()).filter(|&i| full[i]) {
                let [x, y, z] = cell_coords(i);
                let near = (0..27).any(|k| {
                    let c = [x + k % 3, y + k / 3 % 3, z + k / 9].map(|v| v as isize - 1);
                    c.iter().all(|&v| (0..OCC as isize).contains(&v))
                        && touched[cell_index(c[0] as usize, c[1] as usize, c[2] as usize)]
                });
                prop_assert!(near, "cell {:?} marked far from {t:?}", [x, y, z]);
            }
        }
    }
}
