//! Which windows need a shadow map: decided once per light from the pack's geometry, so the
//! pack format carries nothing new.
//!
//! The light through a window fills a volume: the window's rectangle swept along the light
//! (a prism for the sun, a frustum from a lamp). Every opaque triangle is traced back along
//! the light onto the window's rectangle, as the cooker's light-reach test does (clip to the
//! window's side, project through the projector, clip to `[0, 1]²`), but exactly, as polygons
//! instead of bounding boxes. Light through the window is blocked somewhere exactly when
//!
//! - an opaque surface on the light's side of the window covers part of the rectangle (a
//!   buttress, the outer reveal of a deep embrasure), or
//! - two opaque surfaces on the inner side cover a common part of it: along the rays through
//!   that part the nearer one shadows the farther (a pier in front of the floor, the far face
//!   of a pillar behind its near face).
//!
//! Surfaces merely meeting along an edge (floor and wall in a corner, the faces of one
//! surface) cover no common area and block nothing. Surfaces parallel to the light cover no
//! area. The test is exact up to a small tolerance, so a 5 cm mullion is never missed the way
//! a sampled ray trace could miss it.

use glam::{DVec2, DVec3};

use crate::view::{LightGeometry, window_projector};

/// Whether a window's light needs a shadow map, and why.
#[derive(Clone, Debug, PartialEq)]
pub enum WindowShadow {
    /// Some opaque surface can block part of the light: the window gets a shadow map.
    Occluded(Blocker),
    /// Nothing stands between the window and what its light lands on: no shadow map.
    Clear,
    /// No light passes this window (a lamp on its inner side, a sun travelling outwards).
    NoLight,
}

/// What blocks a window's light first found by the analysis (for `--passes` and `-v`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Blocker {
    /// A surface between the light and the window.
    Outside,
    /// One surface on the inner side casts a shadow on another.
    Inside,
}

impl WindowShadow {
    pub fn needs_map(&self) -> bool {
        matches!(self, Self::Occluded(_))
    }

    /// One line for reports: what was decided and why.
    pub fn describe(&self) -> &'static str {
        match self {
            Self::Occluded(Blocker::Outside) => {
                "shadow map: a surface between the light and the window blocks part of its light"
            }
            Self::Occluded(Blocker::Inside) => {
                "shadow map: a surface inside casts a shadow within the window's light"
            }
            Self::Clear => {
                "shadow map skipped: nothing stands between the window and what its light lands on"
            }
            Self::NoLight => "shadow map skipped: no light passes this window",
        }
    }
}

/// A convex polygon on the window's `(u, v)` square with its bounds.
struct Patch {
    points: Vec<DVec2>,
    lo: DVec2,
    hi: DVec2,
}

/// Relative tolerance on the window's square: overlaps thinner than this (a shared edge, a
/// rounding sliver) do not count.
const EPS: f64 = 1e-6;

/// Decides every window of `windows` for `light` over the opaque `triangles` (floors, walls,
/// anything that is neither glass nor backdrop).
pub fn analyse(
    windows: &[pack::Window],
    light: Option<&LightGeometry>,
    triangles: impl Iterator<Item = [glam::Vec3; 3]> + Clone + Send + Sync,
) -> Vec<WindowShadow> {
    use rayon::prelude::*;
    // One window a thread: the default scene's 13 took 8–12 ms one after another, on the
    // way to the first frame.
    windows
        .par_iter()
        .map(|w| match light {
            Some(l) => window_shadow(w, l, triangles.clone()),
            None => WindowShadow::NoLight,
        })
        .collect()
}

/// The decision for one window.
pub fn window_shadow(
    w: &pack::Window,
    light: &LightGeometry,
    triangles: impl IntoIterator<Item = [glam::Vec3; 3]>,
) -> WindowShadow {
    let Some(projector) = window_projector(w, light) else {
        return WindowShadow::NoLight;
    };
    let projector = projector.as_dmat4();
    let origin = glam::Vec3::from(w.origin).as_dvec3();
    let normal = glam::Vec3::from(w.normal).as_dvec3().normalize_or_zero();
    let size = (glam::Vec3::from(w.u_axis).length() + glam::Vec3::from(w.v_axis).length()) as f64;
    // Surfaces within this distance of the window's plane are its own wall (or its glass).
    let plane_eps = 1e-4 * size.max(1e-6);
    let to_uv = |p: DVec3| {
        let c = projector * p.extend(1.0);
        DVec2::new(c.x / c.w, c.y / c.w)
    };
    let mut inside: Vec<Patch> = Vec::new();
    for tri in triangles {
        let pts = tri.map(|p| p.as_dvec3());
        let side = pts.map(|p| (p - origin).dot(normal));
        // Inner part: beyond the plane.
        if let Some(p) = clip_side(&pts, &side, plane_eps).and_then(|poly| patch(&poly, &to_uv)) {
            inside.push(p);
        }
        // Outer part: between the light and the plane.
        let neg = side.map(|s| -s);
        if let Some(mut poly) = clip_side(&pts, &neg, plane_eps) {
            if let LightGeometry::Point { position, .. } = *light {
                // Keep the part in front of the lamp: the lamp-side plane through the lamp.
                let l = position.as_dvec3();
                let d: Vec<f64> = poly.iter().map(|p| (*p - l).dot(normal)).collect();
                poly = clip_poly(&poly, &d, plane_eps);
            }
            if poly.len() >= 3 && patch(&poly, &to_uv).is_some() {
                return WindowShadow::Occluded(Blocker::Outside);
            }
        }
    }
    if overlapping(&inside) {
        WindowShadow::Occluded(Blocker::Inside)
    } else {
        WindowShadow::Clear
    }
}

/// How far behind a window's glass (on the light's side, as a fraction of the window's longer
/// side) an uncut wall still counts as the wall the glass sits on. Glazing is often modelled
/// as a pane a few centimetres in front of a wall that was never cut open; taken literally,
/// that wall blocks all the window's light, and the church is dark.
pub const BACKING_DEPTH: f64 = 0.1;
/// `|cos|` of the angle between a wall's and a window's normals above which they are parallel.
const PARALLEL_COS: f64 = 0.999;
/// How far around a backed window's rectangle (a fraction of its sides) its wall reaches.
const BACKING_AROUND: f64 = 0.25;
/// Share of a window's rectangle its uncut wall must cover. A wall with the opening cut out
/// covers only the corners the glass leaves (a pointed lancet's: a tenth, a rose's: a fifth).
const BACKED_COVER: f64 = 0.5;

/// A window's rectangle for the backing test: `(s, t)` on it along its axes, `d` along its
/// inward normal.
#[derive(Clone, Copy, Debug)]
struct Frame {
    window: u32,
    origin: DVec3,
    normal: DVec3,
    /// Rows of the inverse Gram matrix of the axes applied to them: `(p - origin)·dual_s = s`.
    dual_s: DVec3,
    dual_t: DVec3,
    /// The slab `d ∈ [-depth, eps]` the wall must lie in.
    depth: f64,
    eps: f64,
    /// How far behind the glass the wall covering it lies (its farthest corner).
    wall: f64,
}

impl Frame {
    fn new(window: u32, w: &pack::Window) -> Option<Self> {
        let (u, v) = (
            glam::Vec3::from(w.u_axis).as_dvec3(),
            glam::Vec3::from(w.v_axis).as_dvec3(),
        );
        let normal = glam::Vec3::from(w.normal).as_dvec3().normalize_or_zero();
        let (uu, uv, vv) = (u.dot(u), u.dot(v), v.dot(v));
        let det = uu * vv - uv * uv;
        if det.is_nan() || det <= 1e-12 * uu * vv || normal == DVec3::ZERO {
            return None;
        }
        let size = uu.sqrt().max(vv.sqrt());
        Some(Self {
            window,
            origin: glam::Vec3::from(w.origin).as_dvec3(),
            normal,
            dual_s: (u * vv - v * uv) / det,
            dual_t: (v * uu - u * uv) / det,
            depth: BACKING_DEPTH * size,
            eps: 1e-4 * size,
            wall: 0.0,
        })
    }

    /// The share of the rectangle, grown by `grow` (a fraction of its sides) all round, that
    /// `tri` covers seen straight on, when `tri` (with unit normal `n`) is parallel to the
    /// window and lies in the slab behind it; `None` otherwise.
    fn behind(&self, tri: &[DVec3; 3], n: DVec3, grow: f64) -> Option<f64> {
        if n.dot(self.normal).abs() < PARALLEL_COS {
            return None;
        }
        let in_slab = |p: &DVec3| {
            let d = (*p - self.origin).dot(self.normal);
            (-self.depth..=self.eps).contains(&d)
        };
        if !tri.iter().all(in_slab) {
            return None;
        }
        let to_st = |p: DVec3| {
            let r = p - self.origin;
            (DVec2::new(r.dot(self.dual_s), r.dot(self.dual_t)) + grow) / (1.0 + 2.0 * grow)
        };
        patch(tri, &to_st).map(|p| signed_area(&p.points).abs() * (1.0 + 2.0 * grow).powi(2))
    }
}

/// The windows whose glass sits on an uncut wall, and how to tell that wall's triangles.
///
/// Such a window's wall is taken as cut open behind its glass: its triangles are left out of
/// every shadow map and of the analysis above, and the reference tracer lets a ray that
/// crossed the window's glass through them. The cooker's light reach and sun guess already
/// look at the building's inner side only, so the viewer now agrees with them.
#[derive(Clone, Debug, Default)]
pub struct Backings {
    /// Frames of the backed windows only (the first 64: the lit pass projects no more).
    frames: Vec<Frame>,
}

impl Backings {
    /// Finds the backed windows among `windows` over the opaque `triangles`.
    pub fn find(
        windows: &[pack::Window],
        triangles: impl IntoIterator<Item = [glam::Vec3; 3]>,
    ) -> Self {
        let frames: Vec<Frame> = windows
            .iter()
            .take(64)
            .enumerate()
            .filter_map(|(i, w)| Frame::new(i as u32, w))
            .collect();
        if frames.is_empty() {
            return Self::default();
        }
        let mut cover = vec![0.0f64; frames.len()];
        let mut frames = frames;
        for tri in triangles {
            let Some((pts, n)) = unit_normal(tri) else {
                continue;
            };
            for (f, c) in frames.iter_mut().zip(&mut cover) {
                if let Some(a) = f.behind(&pts, n, 0.0) {
                    *c += a;
                    for p in pts {
                        f.wall = f.wall.max(-(p - f.origin).dot(f.normal));
                    }
                }
            }
        }
        Self {
            frames: frames
                .into_iter()
                .zip(cover)
                .filter(|&(_, c)| c >= BACKED_COVER)
                .map(|(f, _)| f)
                .collect(),
        }
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// Whether window `i` (TOC order) sits on an uncut wall.
    pub fn backed(&self, i: usize) -> bool {
        self.wall(i).is_some()
    }

    /// How far behind window `i`'s glass its uncut wall lies (`None`: not backed). The lit
    /// pass counts the space between the two as inside, so the floor strip there is not lit
    /// as the outside is.
    pub fn wall(&self, i: usize) -> Option<f64> {
        self.frames
            .iter()
            .find(|f| f.window as usize == i)
            .map(|f| f.wall)
    }

    /// The backed windows (bit `i` for window `i`) whose wall `tri` is part of: parallel to
    /// the window, in the slab behind it, and covering part of its rectangle seen straight on,
    /// grown by [`BACKING_AROUND`]: a wall built of tiles has some meeting the rectangle at
    /// its edge only, which slanted light still traces onto the glass.
    pub fn mask(&self, tri: [glam::Vec3; 3]) -> u64 {
        if self.frames.is_empty() {
            return 0;
        }
        let Some((pts, n)) = unit_normal(tri) else {
            return 0;
        };
        self.frames
            .iter()
            .filter(|f| f.behind(&pts, n, BACKING_AROUND).is_some())
            .fold(0, |m, f| m | 1 << f.window)
    }
}

/// Whether any of the opaque `triangles` reaches beyond some window's plane (past the uncut
/// wall a backed window sits on): the lit pass takes such points for the outside, so the sun's
/// direct map ([`crate::shadows::ShadowLayout::direct`]) must say whether the sun reaches them.
/// A wall in the windows' planes alone never needs it.
pub fn beyond_windows(
    windows: &[pack::Window],
    backings: &Backings,
    triangles: impl IntoIterator<Item = [glam::Vec3; 3]>,
) -> bool {
    let planes: Vec<(DVec3, DVec3, f64)> = windows
        .iter()
        .take(64)
        .enumerate()
        .map(|(i, w)| {
            (
                glam::Vec3::from(w.origin).as_dvec3(),
                glam::Vec3::from(w.normal).as_dvec3().normalize_or_zero(),
                // The lit pass's own tolerance (`is_inside` in lit.wgsl).
                1e-3 + backings.wall(i).unwrap_or(0.0),
            )
        })
        .collect();
    triangles.into_iter().any(|t| {
        t.iter().any(|p| {
            let p = p.as_dvec3();
            planes.iter().any(|(o, n, tol)| (p - *o).dot(*n) < -tol)
        })
    })
}

/// A triangle in f64 and its unit normal; `None` when it has no area.
fn unit_normal(tri: [glam::Vec3; 3]) -> Option<([DVec3; 3], DVec3)> {
    let pts = tri.map(|p| p.as_dvec3());
    let n = (pts[1] - pts[0]).cross(pts[2] - pts[0]);
    let len = n.length();
    (len > 0.0 && len.is_finite()).then(|| (pts, n / len))
}

/// The part of a triangle where `side > eps`, as a polygon (`None` when empty).
fn clip_side(pts: &[DVec3; 3], side: &[f64; 3], eps: f64) -> Option<Vec<DVec3>> {
    let poly = clip_poly(pts, side, eps);
    (poly.len() >= 3).then_some(poly)
}

/// Sutherland–Hodgman against one plane: keeps the part with `d > eps`.
fn clip_poly(pts: &[DVec3], d: &[f64], eps: f64) -> Vec<DVec3> {
    let mut out = Vec::with_capacity(pts.len() + 1);
    for k in 0..pts.len() {
        let j = (k + 1) % pts.len();
        let (a, b) = (pts[k], pts[j]);
        let (da, db) = (d[k] - eps, d[j] - eps);
        if da > 0.0 {
            out.push(a);
        }
        if (da > 0.0) != (db > 0.0) {
            let t = da / (da - db);
            out.push(a + (b - a) * t);
        }
    }
    out
}

/// A polygon traced back onto the window, clipped to the window's square; `None` when it
/// covers no area there.
fn patch(poly: &[DVec3], to_uv: &impl Fn(DVec3) -> DVec2) -> Option<Patch> {
    let mut pts: Vec<DVec2> = poly.iter().map(|&p| to_uv(p)).collect();
    if pts.iter().any(|p| !p.is_finite()) {
        return None;
    }
    // Clip to the unit square, one edge at a time.
    for (axis, keep_above, bound) in [
        (0, true, 0.0),
        (0, false, 1.0),
        (1, true, 0.0),
        (1, false, 1.0),
    ] {
        let d: Vec<f64> = pts
            .iter()
            .map(|p| {
                let c = if axis == 0 { p.x } else { p.y };
                if keep_above { c - bound } else { bound - c }
            })
            .collect();
        pts = clip_2d(&pts, &d);
        if pts.len() < 3 {
            return None;
        }
    }
    let area = signed_area(&pts).abs();
    if area <= EPS * EPS {
        return None;
    }
    let lo = pts
        .iter()
        .fold(DVec2::splat(f64::INFINITY), |a, &p| a.min(p));
    let hi = pts
        .iter()
        .fold(DVec2::splat(f64::NEG_INFINITY), |a, &p| a.max(p));
    Some(Patch {
        points: pts,
        lo,
        hi,
    })
}

fn clip_2d(pts: &[DVec2], d: &[f64]) -> Vec<DVec2> {
    let mut out = Vec::with_capacity(pts.len() + 1);
    for k in 0..pts.len() {
        let j = (k + 1) % pts.len();
        let (a, b) = (pts[k], pts[j]);
        let (da, db) = (d[k], d[j]);
        if da >= 0.0 {
            out.push(a);
        }
        if (da >= 0.0) != (db >= 0.0) {
            let t = da / (da - db);
            out.push(a + (b - a) * t);
        }
    }
    out
}

fn signed_area(pts: &[DVec2]) -> f64 {
    let mut a = 0.0;
    for k in 0..pts.len() {
        let (p, q) = (pts[k], pts[(k + 1) % pts.len()]);
        a += p.perp_dot(q);
    }
    a * 0.5
}

/// True when two convex patches share an area wider than [`EPS`] (separating axes).
fn overlap(a: &Patch, b: &Patch) -> bool {
    if a.hi.x <= b.lo.x + EPS
        || b.hi.x <= a.lo.x + EPS
        || a.hi.y <= b.lo.y + EPS
        || b.hi.y <= a.lo.y + EPS
    {
        return false;
    }
    for poly in [&a.points, &b.points] {
        for k in 0..poly.len() {
            let e = poly[(k + 1) % poly.len()] - poly[k];
            let len = e.length();
            if len <= 1e-15 {
                continue;
            }
            let axis = e.perp() / len;
            let range = |pts: &[DVec2]| {
                pts.iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
                        let d = p.dot(axis);
                        (lo.min(d), hi.max(d))
                    })
            };
            let (a0, a1) = range(&a.points);
            let (b0, b1) = range(&b.points);
            if a1.min(b1) - a0.max(b0) <= EPS {
                return false;
            }
        }
    }
    true
}

/// Whether any two patches overlap; a grid over the square keeps it near linear.
fn overlapping(patches: &[Patch]) -> bool {
    const CELLS: usize = 32;
    let mut grid: Vec<Vec<u32>> = vec![Vec::new(); CELLS * CELLS];
    let cell = |v: f64| ((v * CELLS as f64).floor().max(0.0) as usize).min(CELLS - 1);
    for (i, p) in patches.iter().enumerate() {
        let (x0, x1) = (cell(p.lo.x), cell(p.hi.x));
        let (y0, y1) = (cell(p.lo.y), cell(p.hi.y));
        for y in y0..=y1 {
            for x in x0..=x1 {
                let slot = &mut grid[y * CELLS + x];
                if slot.iter().any(|&j| overlap(p, &patches[j as usize])) {
                    return true;
                }
                slot.push(i as u32);
            }
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    /// A 2 x 2 window in the plane z = 0, inside towards +z.
    fn window() -> pack::Window {
        pack::Window {
            material: 0,
            origin: [-1.0, 3.0, 0.0],
            u_axis: [2.0, 0.0, 0.0],
            v_axis: [0.0, -2.0, 0.0],
            normal: [0.0, 0.0, 1.0],
            source_materials: Vec::new(),
        }
    }

    fn quad(o: Vec3, a: Vec3, b: Vec3) -> [[Vec3; 3]; 2] {
        [[o, o + a, o + a + b], [o, o + a + b, o + b]]
    }

    fn sun() -> LightGeometry {
        LightGeometry::Directional {
            towards: -Vec3::new(0.2, -0.6, 1.0).normalize(),
        }
    }

    fn room() -> Vec<[Vec3; 3]> {
        let mut t = Vec::new();
        // Floor inside, a wall around the window in its plane, a back wall far inside.
        t.extend(quad(
            Vec3::new(-10.0, 0.0, 0.0),
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 20.0),
        ));
        t.extend(quad(
            Vec3::new(-10.0, 0.0, 0.0),
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ));
        t.extend(quad(
            Vec3::new(-10.0, 0.0, 20.0),
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(0.0, 8.0, 0.0),
        ));
        t
    }

    #[test]
    fn floor_walls_and_corners_block_nothing() {
        assert_eq!(
            window_shadow(&window(), &sun(), room()),
            WindowShadow::Clear
        );
        let lamp = LightGeometry::Point {
            position: Vec3::new(0.5, 5.0, -4.0),
            radius: 0.1,
        };
        assert_eq!(window_shadow(&window(), &lamp, room()), WindowShadow::Clear);
    }

    #[test]
    fn a_pillar_or_a_thin_mullion_in_the_light_is_found() {
        // The sun's light through the window lands on the floor between z = 1 and 5.
        for width in [0.6, 0.05] {
            let mut t = room();
            let (x, z) = (0.0, 2.5);
            t.extend(quad(
                Vec3::new(x, 0.0, z),
                Vec3::new(width, 0.0, 0.0),
                Vec3::new(0.0, 4.0, 0.0),
            ));
            assert_eq!(
                window_shadow(&window(), &sun(), t.iter().copied()),
                WindowShadow::Occluded(Blocker::Inside),
                "pillar {width} wide"
            );
        }
        // Out of the light (far to the side), it blocks nothing.
        let mut t = room();
        t.extend(quad(
            Vec3::new(-8.0, 0.0, 2.5),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
        ));
        assert_eq!(
            window_shadow(&window(), &sun(), t.iter().copied()),
            WindowShadow::Clear
        );
    }

    #[test]
    fn a_surface_outside_in_front_of_the_window_is_found() {
        let mut t = room();
        // A ledge outside, 0.1 high, across the light's path to the window's lower half.
        t.extend(quad(
            Vec3::new(-2.0, 2.5, -1.0),
            Vec3::new(4.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 0.5),
        ));
        assert_eq!(
            window_shadow(&window(), &sun(), t.iter().copied()),
            WindowShadow::Occluded(Blocker::Outside)
        );
        // Behind a lamp it blocks nothing.
        let lamp = LightGeometry::Point {
            position: Vec3::new(0.0, 2.0, -0.5),
            radius: 0.1,
        };
        assert_eq!(
            window_shadow(&window(), &lamp, t.iter().copied()),
            WindowShadow::Clear
        );
    }

    /// The room with the window's wall at `behind` (on the light's side, z < 0) either whole
    /// or cut open where the window is, and `extra` triangles.
    fn walled_room(behind: f32, cut: bool, extra: &[[Vec3; 3]]) -> Vec<[Vec3; 3]> {
        let mut t = room();
        let z = -behind;
        if cut {
            // Around the opening x in [-1, 1], y in [1, 3].
            t.extend(quad(
                Vec3::new(-10.0, 0.0, z),
                Vec3::new(9.0, 0.0, 0.0),
                Vec3::new(0.0, 8.0, 0.0),
            ));
            t.extend(quad(
                Vec3::new(1.0, 0.0, z),
                Vec3::new(9.0, 0.0, 0.0),
                Vec3::new(0.0, 8.0, 0.0),
            ));
            t.extend(quad(
                Vec3::new(-1.0, 0.0, z),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ));
            t.extend(quad(
                Vec3::new(-1.0, 3.0, z),
                Vec3::new(2.0, 0.0, 0.0),
                Vec3::new(0.0, 5.0, 0.0),
            ));
        } else {
            t.extend(quad(
                Vec3::new(-10.0, 0.0, z),
                Vec3::new(20.0, 0.0, 0.0),
                Vec3::new(0.0, 8.0, 0.0),
            ));
        }
        t.extend_from_slice(extra);
        t
    }

    /// What the viewer analyses: the opaque triangles less the backed windows' walls.
    fn decide(w: &pack::Window, tris: &[[Vec3; 3]]) -> (bool, WindowShadow) {
        let b = Backings::find(std::slice::from_ref(w), tris.iter().copied());
        let casting = tris.iter().copied().filter(|&t| b.mask(t) == 0);
        (b.backed(0), window_shadow(w, &sun(), casting))
    }

    #[test]
    fn glass_on_an_uncut_wall_lets_its_light_through() {
        // Taken literally, the wall 5 cm behind the glass blocks all of it.
        let whole = walled_room(0.05, false, &[]);
        assert_eq!(
            window_shadow(&window(), &sun(), whole.iter().copied()),
            WindowShadow::Occluded(Blocker::Outside)
        );
        assert_eq!(decide(&window(), &whole), (true, WindowShadow::Clear));
        // The wall in the glass's own plane, too.
        assert!(decide(&window(), &walled_room(0.0, false, &[])).0);
        // A pillar inside still casts its shadow.
        let pillar = quad(
            Vec3::new(0.0, 0.0, 2.5),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(0.0, 4.0, 0.0),
        );
        assert_eq!(
            decide(&window(), &walled_room(0.05, false, &pillar)),
            (true, WindowShadow::Occluded(Blocker::Inside))
        );
        // The wall's triangles are told apart from the rest (the low wall in the glass's
        // plane below the window is one with it).
        let b = Backings::find(std::slice::from_ref(&window()), whole.iter().copied());
        let masked = |tris: &[[Vec3; 3]], b: &Backings| {
            tris.iter()
                .filter(|t| b.mask(**t) == 1)
                .map(|t| t[0].z)
                .collect::<Vec<f32>>()
        };
        assert_eq!(masked(&whole, &b), [0.0, 0.0, -0.05, -0.05]);
        // The same wall built of 1 m tiles: those meeting the rectangle grown by a quarter
        // all round, and no others.
        let mut tiles = room();
        for i in -10..10 {
            for j in 0..8 {
                tiles.extend(quad(Vec3::new(i as f32, j as f32, -0.05), Vec3::X, Vec3::Y));
            }
        }
        let b = Backings::find(std::slice::from_ref(&window()), tiles.iter().copied());
        assert!(b.backed(0));
        // Tiles x in [-2, 2), y in [0, 4): 16 tiles, 32 triangles less the two that only
        // touch the grown rectangle (x in (-1.5, 1.5), y in (0.5, 3.5)) at a corner.
        let tiles_masked = masked(&tiles, &b);
        assert_eq!(tiles_masked.iter().filter(|&&z| z < 0.0).count(), 30);
        let casting = tiles.iter().copied().filter(|&t| b.mask(t) == 0);
        assert_eq!(
            window_shadow(&window(), &sun(), casting),
            WindowShadow::Clear
        );
    }

    #[test]
    fn walls_cut_open_far_behind_or_only_partly_covering_still_block() {
        // The opening cut: the wall covers none of the rectangle, so the window is not
        // backed, and the wall 5 cm out shades the glass's edge from the slanted sun.
        assert_eq!(
            decide(&window(), &walled_room(0.05, true, &[])),
            (false, WindowShadow::Occluded(Blocker::Outside))
        );
        assert_eq!(
            decide(&window(), &walled_room(0.0, true, &[])),
            (false, WindowShadow::Clear)
        );
        // An uncut wall farther behind than a tenth of the window's size is a real blocker.
        assert_eq!(
            decide(&window(), &walled_room(0.5, false, &[])),
            (false, WindowShadow::Occluded(Blocker::Outside))
        );
        // Stone tracery 3 cm outside the glass, parallel to it, covering a third of the
        // rectangle in three bars: not an uncut wall, so the bars block light.
        let mut bars = Vec::new();
        for x in [-0.9f32, -0.1, 0.7] {
            bars.extend(quad(
                Vec3::new(x, 1.0, -0.03),
                Vec3::new(0.22, 0.0, 0.0),
                Vec3::new(0.0, 2.0, 0.0),
            ));
        }
        assert_eq!(
            decide(&window(), &walled_room(0.05, true, &bars)),
            (false, WindowShadow::Occluded(Blocker::Outside))
        );
        // A board behind the whole window, within the slab, tilted 4° from the glass: not the
        // wall it sits on (tilted 1°, it is).
        let board = |deg: f32| {
            let rise = 2.2 * deg.to_radians().tan();
            quad(
                Vec3::new(-1.1, 0.9, -0.02),
                Vec3::new(2.2, 0.0, 0.0),
                Vec3::new(0.0, 2.2, -rise),
            )
        };
        assert!(!decide(&window(), &walled_room(0.05, true, &board(4.0))).0);
        assert!(decide(&window(), &walled_room(0.05, true, &board(1.0))).0);
    }

    #[test]
    fn geometry_beyond_a_windows_plane_is_found() {
        let none = Backings::default();
        // The room: a wall in the window's plane, everything else inside.
        assert!(!beyond_windows(&[window()], &none, room()));
        // A floor running on outside.
        let mut t = room();
        t.extend(quad(
            Vec3::new(-10.0, 0.0, -5.0),
            Vec3::new(20.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 5.0),
        ));
        assert!(beyond_windows(&[window()], &none, t.iter().copied()));
        // The uncut wall a backed window sits on is not beyond it.
        let whole = walled_room(0.05, false, &[]);
        let b = Backings::find(std::slice::from_ref(&window()), whole.iter().copied());
        assert!(beyond_windows(&[window()], &none, whole.iter().copied()));
        assert!(!beyond_windows(&[window()], &b, whole.iter().copied()));
    }

    #[test]
    fn no_light_through_the_window() {
        let outwards = LightGeometry::Directional {
            towards: Vec3::new(0.2, 0.6, 1.0).normalize(),
        };
        assert_eq!(
            window_shadow(&window(), &outwards, room()),
            WindowShadow::NoLight
        );
    }
}
