//! Window instances: the windows of a real model are found in its geometry, not read from its
//! material names. A window is a connected, planar patch of window-class triangles: one glass
//! material may hold thirty lancets, and one rose may be made of four coloured glasses.
//!
//! For each instance this module fits the plane, decides which side is inside, fits the
//! minimum-area rectangle with "up" taken from the scene's up axis (+Y), and names it. The
//! pipeline then gives every instance its own pack material (so its own design and projector)
//! and generates planar texture coordinates where the glass has none.

use std::collections::HashMap;

use glam::{DVec2, DVec3};
use pack::{LightKind, MaterialClass};

use crate::import::{Corner, Imported, NONE};
use crate::windows::{Sheets, plane_up, v3};

/// Relative weld tolerance: positions closer than this fraction of the model's diagonal are
/// the same point when deciding which triangles touch.
const WELD: f64 = 1e-5;
/// A patch whose vertices leave its plane by more than this fraction of its size is not flat.
pub const PLANAR_TOLERANCE: f64 = 0.01;
/// Most planes a non-planar patch is split into; more means curved glass, which is reported.
const MAX_SPLIT: usize = 8;

/// One window found in the geometry.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub name: String,
    /// Index of the source (mesh) the triangles belong to.
    pub source: usize,
    /// Triangle indices within the source.
    pub triangles: Vec<u32>,
    /// Tagged pack materials of the triangles with their area, largest first.
    pub materials: Vec<(u16, f64)>,
    pub area: f64,
    pub centroid: DVec3,
    /// Unit normal pointing into the building, and what decided it.
    pub inside: DVec3,
    pub inside_reason: &'static str,
    /// The fitted rectangle: bottom-left corner seen from inside, the full right and up edges.
    pub origin: DVec3,
    pub right: DVec3,
    pub up: DVec3,
    /// Largest distance of a vertex from the fitted plane.
    pub max_deviation: f64,
    /// False for curved glass that could not be split into a few planes.
    pub planar: bool,
    /// True when every corner has a texture coordinate and they are not all the same.
    pub has_uvs: bool,
}

impl Instance {
    pub fn width(&self) -> f64 {
        self.right.length()
    }

    pub fn height(&self) -> f64 {
        self.up.length()
    }

    /// The middle of the fitted rectangle (not the glass's area centroid, `centroid`).
    pub fn centre(&self) -> DVec3 {
        self.origin + (self.right + self.up) * 0.5
    }

    /// The planar texture coordinate of `p`, seen from inside: u from left to right, v from
    /// the top row of the design down, as the pack stores texture coordinates (in OBJ terms,
    /// (0, 0) is the bottom left).
    pub fn planar_uv(&self, p: DVec3) -> [f32; 2] {
        let d = p - self.origin;
        let u = d.dot(self.right) / self.right.length_squared().max(1e-300);
        let v = d.dot(self.up) / self.up.length_squared().max(1e-300);
        [u as f32, (1.0 - v) as f32]
    }
}

struct UnionFind(Vec<u32>);

impl UnionFind {
    fn new(n: usize) -> Self {
        Self((0..n as u32).collect())
    }

    fn find(&mut self, mut a: u32) -> u32 {
        while self.0[a as usize] != a {
            let parent = self.0[self.0[a as usize] as usize];
            self.0[a as usize] = parent;
            a = parent;
        }
        a
    }

    fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        // The smaller root wins, so components do not depend on the order of unions.
        if ra < rb {
            self.0[rb as usize] = ra;
        } else if rb < ra {
            self.0[ra as usize] = rb;
        }
    }
}

/// One id per position of `tris` (others get `u32::MAX`): positions within the weld tolerance
/// (on a grid of that size) share it.
fn weld_ids(src: &Imported, tris: &[u32], tolerance: f64) -> Vec<u32> {
    // Only the glass's positions: the rest of a 100k-triangle model would cost more than
    // everything else the window stage does.
    let mut ids = vec![u32::MAX; src.positions.len()];
    let mut cells: HashMap<[i64; 3], u32> = HashMap::new();
    for &t in tris {
        for p in src.corners.triangle_positions(t as usize) {
            let id = &mut ids[p as usize];
            if *id == u32::MAX {
                let key = src.positions[p as usize].map(|c| (c as f64 / tolerance).round() as i64);
                let next = cells.len() as u32;
                *id = *cells.entry(key).or_insert(next);
            }
        }
    }
    ids
}

/// Triangle `t` of `src`, its corners in f64.
pub(crate) fn triangle(src: &Imported, t: u32) -> [DVec3; 3] {
    (src.corners.triangle_positions(t as usize)).map(|k| v3(src.positions[k as usize]))
}

fn vertices<'a>(src: &'a Imported, tris: &'a [u32]) -> impl Iterator<Item = DVec3> + 'a {
    tris.iter().flat_map(move |&t| triangle(src, t))
}

fn size_of(src: &Imported, tris: &[u32]) -> f64 {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for p in vertices(src, tris) {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    (hi - lo).length()
}

/// Connected components of `tris` over welded positions, each in ascending triangle order,
/// ordered by their first triangle.
fn components(src: &Imported, weld: &[u32], tris: &[u32]) -> Vec<Vec<u32>> {
    let mut local: HashMap<u32, u32> = HashMap::new();
    for &t in tris {
        for k in 0..3 {
            let w = weld[src.corners.p(t as usize * 3 + k) as usize];
            let n = local.len() as u32;
            local.entry(w).or_insert(n);
        }
    }
    let mut uf = UnionFind::new(local.len());
    for &t in tris {
        let ids: Vec<u32> = (0..3)
            .map(|k| local[&weld[src.corners.p(t as usize * 3 + k) as usize]])
            .collect();
        uf.union(ids[0], ids[1]);
        uf.union(ids[0], ids[2]);
    }
    let mut groups: Vec<(u32, Vec<u32>)> = Vec::new();
    let mut slot: HashMap<u32, usize> = HashMap::new();
    for &t in tris {
        let w = weld[src.corners.p(t as usize * 3) as usize];
        let root = uf.find(local[&w]);
        let i = *slot.entry(root).or_insert_with(|| {
            groups.push((t, Vec::new()));
            groups.len() - 1
        });
        groups[i].1.push(t);
    }
    groups.into_iter().map(|g| g.1).collect()
}

/// The plane, size and flatness of some glass.
#[derive(Clone, Copy, Debug)]
struct Shape {
    centroid: DVec3,
    normal: DVec3,
    /// Area of one side: a slab's front and back, or a pane drawn from both sides (each face
    /// twice, wound both ways), count once.
    area: f64,
    /// Diagonal of the bounding box.
    size: f64,
    /// Largest distance of a vertex from the plane; for a flat slab, from its own sheet.
    deviation: f64,
    planar: bool,
    sheets: Sheets,
    lo: DVec3,
    hi: DVec3,
    /// Bounds in the plane, in the basis of [`canonical_basis`] of the normal.
    lo2: DVec2,
    hi2: DVec2,
}

/// Whether the faces of `tris` come in pairs, the same corners wound both ways (a pane drawn
/// from both sides), rather than one pane whose faces happen to face either way: the sorted
/// corners of the faces facing along `normal` and of those facing against it are the same
/// (positions compared on a grid of `weld`).
fn two_sided(src: &Imported, tris: &[u32], normal: DVec3, weld: f64) -> bool {
    type Corners = [[i64; 3]; 3];
    let (mut front, mut back): (Vec<Corners>, Vec<Corners>) = (Vec::new(), Vec::new());
    for &t in tris {
        let [a, b, c] = triangle(src, t);
        let mut key = [a, b, c].map(|p| (p / weld.max(1e-300)).round().as_i64vec3().to_array());
        key.sort_unstable();
        if (b - a).cross(c - a).dot(normal) >= 0.0 {
            front.push(key);
        } else {
            back.push(key);
        }
    }
    front.sort_unstable();
    back.sort_unstable();
    !front.is_empty() && front == back
}

/// An in-plane basis that two nearly parallel planes share whichever way their normals
/// point: the normal is first turned so that its largest component is positive.
fn canonical_basis(n: DVec3) -> (DVec3, DVec3) {
    let a = n.abs();
    let largest = if a.x >= a.y && a.x >= a.z {
        n.x
    } else if a.y >= a.z {
        n.y
    } else {
        n.z
    };
    let n = if largest < 0.0 { -n } else { n };
    let f = plane_up(n);
    (f.cross(n), f)
}

impl Shape {
    fn of(src: &Imported, tris: &[u32]) -> Option<Shape> {
        let (centroid, normal, area) =
            crate::windows::oriented_plane(tris.iter().map(|&t| triangle(src, t)), None)?;
        let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
        let (mut lo2, mut hi2) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        let (e, f) = canonical_basis(normal);
        let mut deviation = 0.0f64;
        for p in vertices(src, tris) {
            lo = lo.min(p);
            hi = hi.max(p);
            let q = DVec2::new(p.dot(e), p.dot(f));
            lo2 = lo2.min(q);
            hi2 = hi2.max(q);
            deviation = deviation.max((p - centroid).dot(normal).abs());
        }
        let size = (hi - lo).length();
        let tolerance = PLANAR_TOLERANCE * size;
        let sheets = Sheets::of(tris.iter().map(|&t| triangle(src, t)), centroid, normal);
        // A flat pane by either measure: flat sheets of a slab, or all vertices near one
        // plane (glass with slightly tilted facets stays a pane, as before sheets counted).
        // Sheets apart by more than the weld tolerance are a slab (float noise is not).
        let (planar, deviation, area) = if sheets.thickness > WELD * size && sheets.flat(tolerance)
        {
            // A slab's front and back are one pane's area.
            (
                true,
                sheets.deviation,
                area * (1.0 - 0.5 * sheets.sheet_share),
            )
        } else if deviation <= tolerance {
            let once = if two_sided(src, tris, normal, WELD * size) {
                0.5
            } else {
                1.0
            };
            (true, deviation, area * once)
        } else {
            (false, deviation, area)
        };
        Some(Shape {
            centroid,
            normal,
            area,
            size,
            deviation,
            planar,
            sheets,
            lo,
            hi,
            lo2,
            hi2,
        })
    }
}

/// Coplanar glass pieces closer than this share of the narrower piece's narrower side are one
/// window: the panes of a leaded window, each its own mesh between lead cames (1–2 cm on
/// 10–40 cm panes), modelled as separate geometry. Lancets a mullion apart (Šibenik's: 0.2 m
/// gaps between 0.4 m lights) stay apart.
const CAME_GAP: f64 = 0.15;

/// Parallel sheets of glass that cover each other in the plane and lie at most this share of
/// the narrower one's narrower side apart are the front and back of one pane: a slab modelled
/// as two loose faces, without the edges that would join them into one piece.
const SLAB_DEPTH: f64 = 0.1;

/// Whether `a` and `b` (parallel within 5°, `off_plane` apart) are one pane's front and back
/// ([`SLAB_DEPTH`]): wound to face opposite ways, each covering nine tenths of the
/// other's bounds in the plane. Apart, each was a window of its own from 6 cm on, and the floor
/// got the window's light twice. Two layers wound alike (a protective glazing outside the
/// stained glass) stay two windows.
fn front_and_back(a: &Shape, b: &Shape, off_plane: f64) -> bool {
    if a.normal.dot(b.normal) >= 0.0 {
        return false;
    }
    let area = |lo: DVec2, hi: DVec2| {
        let d = (hi - lo).max(DVec2::ZERO);
        d.x * d.y
    };
    let overlap = area(a.lo2.max(b.lo2), a.hi2.min(b.hi2));
    let larger = area(a.lo2, a.hi2).max(area(b.lo2, b.hi2));
    off_plane <= SLAB_DEPTH * a.sheets.narrow.min(b.sheets.narrow)
        && larger > 0.0
        && overlap >= 0.9 * larger
}

/// Joins planar pieces that lie in one plane a came's width apart (see [`CAME_GAP`]): groups
/// of indices into `pieces`, ascending, ordered by their first piece.
fn join_leaded(pieces: &[(Vec<u32>, Shape)]) -> Vec<Vec<usize>> {
    let n = pieces.len();
    let mut uf = UnionFind::new(n);
    // Sweep along the axis the pieces spread most on: each piece meets only those starting
    // within its reach there.
    let (mut lo, mut hi) = (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY));
    for (_, s) in pieces {
        lo = lo.min(s.centroid);
        hi = hi.max(s.centroid);
    }
    let axis = (hi - lo).max_position();
    // The widest off-plane slack any pair is allowed, so the sweep stops no pair early.
    let slack = pieces
        .iter()
        .map(|(_, s)| PLANAR_TOLERANCE * s.size + s.sheets.thickness)
        .fold(0.0, f64::max);
    let reach = |s: &Shape| CAME_GAP * s.sheets.narrow + slack;
    let mut order: Vec<usize> = (0..n).filter(|&i| pieces[i].1.planar).collect();
    order.sort_by(|&a, &b| pieces[a].1.lo[axis].total_cmp(&pieces[b].1.lo[axis]));
    let cos = 5f64.to_radians().cos();
    for (k, &i) in order.iter().enumerate() {
        let a = &pieces[i].1;
        for &j in &order[k + 1..] {
            let b = &pieces[j].1;
            if b.lo[axis] > a.hi[axis] + reach(a) {
                break;
            }
            if a.normal.dot(b.normal).abs() < cos {
                continue;
            }
            let off_plane = (b.centroid - a.centroid).dot(a.normal).abs();
            let allowed = PLANAR_TOLERANCE * a.size.max(b.size)
                + 0.5 * (a.sheets.thickness + b.sheets.thickness);
            if off_plane > allowed && !front_and_back(a, b, off_plane) {
                continue;
            }
            // The gap between the bounds in the plane (a shared basis: the normals agree
            // within 5°); 3D boxes gave none on a wall at 45°.
            let gap = (b.lo2 - a.hi2).max(a.lo2 - b.hi2).max(DVec2::ZERO).length();
            if gap <= CAME_GAP * a.sheets.narrow.min(b.sheets.narrow) {
                uf.union(i as u32, j as u32);
            }
        }
    }
    let mut groups: Vec<Vec<usize>> = Vec::new();
    let mut slot: HashMap<u32, usize> = HashMap::new();
    for i in 0..n {
        let root = uf.find(i as u32);
        let g = *slot.entry(root).or_insert_with(|| {
            groups.push(Vec::new());
            groups.len() - 1
        });
        groups[g].push(i);
    }
    groups
}

/// Splits a non-planar patch into the planes it is made of (a bay window), each piece
/// connected; `None` when it would take more than [`MAX_SPLIT`] planes, or two of them turn
/// less than 15° from each other (curved glass).
fn split_planes(src: &Imported, weld: &[u32], tris: &[u32], size: f64) -> Option<Vec<Vec<u32>>> {
    let mut order: Vec<(u32, DVec3, DVec3, f64)> = tris
        .iter()
        .map(|&t| {
            let [a, b, c] = triangle(src, t);
            let n = (b - a).cross(c - a);
            (t, n.normalize_or_zero(), (a + b + c) / 3.0, n.length())
        })
        .collect();
    order.sort_by(|a, b| b.3.total_cmp(&a.3).then(a.0.cmp(&b.0)));
    let cos = 5f64.to_radians().cos();
    let mut planes: Vec<(DVec3, DVec3, Vec<u32>)> = Vec::new();
    for (t, n, c, _) in order {
        let found = planes.iter_mut().find(|(pn, pc, _)| {
            n.dot(*pn).abs() >= cos && (c - *pc).dot(*pn).abs() <= PLANAR_TOLERANCE * size
        });
        match found {
            Some(p) => p.2.push(t),
            None => {
                if planes.len() == MAX_SPLIT {
                    return None;
                }
                planes.push((n, c, vec![t]));
            }
        }
    }
    // Planes facing nearly the same way (under 15° apart, not parallel) are the facets of a
    // curve, not a bay's faces, which meet at 30° and more: a shallow arc of twelve facets was
    // six windows, each with a lead outline on the glass and the floor.
    let (parallel, bent) = (0.5f64.to_radians().cos(), 15f64.to_radians().cos());
    for (i, (a, _, _)) in planes.iter().enumerate() {
        if planes[i + 1..].iter().any(|(b, _, _)| {
            let d = a.dot(*b);
            d < parallel && d > bent
        }) {
            return None;
        }
    }
    let mut pieces = Vec::new();
    for (_, _, mut group) in planes {
        group.sort_unstable();
        pieces.extend(components(src, weld, &group));
    }
    pieces.sort_by_key(|p| p[0]);
    Some(pieces)
}

/// Andrew's monotone chain; the hull counter-clockwise without repeated points.
fn convex_hull(mut pts: Vec<DVec2>) -> Vec<DVec2> {
    pts.sort_by(|a, b| a.x.total_cmp(&b.x).then(a.y.total_cmp(&b.y)));
    pts.dedup();
    if pts.len() < 3 {
        return pts;
    }
    let cross = |o: DVec2, a: DVec2, b: DVec2| (a - o).perp_dot(b - o);
    let mut hull: Vec<DVec2> = Vec::with_capacity(pts.len() * 2);
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &DVec2>> = if pass == 0 {
            Box::new(pts.iter())
        } else {
            Box::new(pts.iter().rev())
        };
        for &p in iter {
            while hull.len() >= start + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
}

/// The direction (angle in [0, π/2)) of the minimum-area rectangle around `hull`, preferring
/// the one closest to the axes among those within 1 % of the minimum area; upright for round
/// shapes: a rose window's rectangle is not turned to some polygon edge.
fn rectangle_angle(hull: &[DVec2]) -> f64 {
    let quarter = std::f64::consts::FRAC_PI_2;
    let mut candidates = vec![0.0];
    for i in 0..hull.len() {
        let e = hull[(i + 1) % hull.len()] - hull[i];
        if e.length_squared() > 0.0 {
            candidates.push(e.y.atan2(e.x).rem_euclid(quarter));
        }
    }
    let area = |angle: f64| {
        let (a, b) = (DVec2::from_angle(angle), DVec2::from_angle(angle + quarter));
        let (mut lo, mut hi) = (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY));
        for p in hull {
            let q = DVec2::new(p.dot(a), p.dot(b));
            lo = lo.min(q);
            hi = hi.max(q);
        }
        (hi - lo).x * (hi - lo).y
    };
    let areas: Vec<f64> = candidates.iter().map(|&c| area(c)).collect();
    let best = areas.iter().copied().fold(f64::INFINITY, f64::min);
    // A shape whose bounding rectangle hardly changes with the angle has no direction of its
    // own: a rose of 16 segments is 4 % smaller turned to an edge, an octagon 15 %, while any
    // rectangle's grows at least twofold at 45°. Such a shape stays upright.
    let largest = (0..16)
        .map(|k| area(k as f64 * quarter / 16.0))
        .chain(areas.iter().copied())
        .fold(0.0, f64::max);
    if largest <= best * 1.25 {
        return 0.0;
    }
    let tilt = |c: f64| c.min(quarter - c);
    candidates
        .iter()
        .zip(&areas)
        .filter(|(_, a)| **a <= best * 1.01 + 1e-12)
        .map(|(c, _)| *c)
        .min_by(|a, b| tilt(*a).total_cmp(&tilt(*b)).then(a.total_cmp(b)))
        .unwrap_or(0.0)
}

/// The rectangle of `tris` in the plane through `centroid` with normal `inside`.
fn fit_rectangle(
    src: &Imported,
    tris: &[u32],
    centroid: DVec3,
    inside: DVec3,
) -> (DVec3, DVec3, DVec3) {
    let f = plane_up(inside);
    let e = f.cross(inside);
    let pts: Vec<DVec2> = vertices(src, tris)
        .map(|p| DVec2::new((p - centroid).dot(e), (p - centroid).dot(f)))
        .collect();
    let hull = convex_hull(pts);
    let angle = rectangle_angle(&hull);
    let axes = [
        DVec2::from_angle(angle),
        DVec2::from_angle(angle + std::f64::consts::FRAC_PI_2),
    ]
    .map(|a| e * a.x + f * a.y);
    // Of the rectangle's four edge directions, "up" is the one closest to the scene's up.
    let up_dir = [axes[0], -axes[0], axes[1], -axes[1]]
        .into_iter()
        .max_by(|a, b| a.dot(f).total_cmp(&b.dot(f)))
        .unwrap_or(f);
    // Seen from inside, the viewer looks along −inside; right = look × up.
    let right_dir = (-inside).cross(up_dir).normalize();
    let (mut r0, mut r1, mut u0, mut u1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for p in vertices(src, tris) {
        let d = p - centroid;
        r0 = r0.min(d.dot(right_dir));
        r1 = r1.max(d.dot(right_dir));
        u0 = u0.min(d.dot(up_dir));
        u1 = u1.max(d.dot(up_dir));
    }
    (
        centroid + right_dir * r0 + up_dir * u0,
        right_dir * (r1 - r0),
        up_dir * (u1 - u0),
    )
}

fn has_uvs(src: &Imported, tris: &[u32]) -> bool {
    let mut first: Option<[f32; 2]> = None;
    let mut varies = false;
    for &t in tris {
        for k in 0..3 {
            let c = src.corners.get(t as usize * 3 + k);
            if c.t == NONE {
                return false;
            }
            let uv = src.uvs[c.t as usize];
            match first {
                None => first = Some(uv),
                Some(f) => varies |= (f[0] - uv[0]).abs() > 1e-6 || (f[1] - uv[1]).abs() > 1e-6,
            }
        }
    }
    varies
}

/// The surfaces that can receive window light (not glass, not the backdrop), as centroid,
/// area and whether they are floor, over all sources: triangles gathered into cells of 1/64 of
/// the model's size, floors apart, each with its area-weighted centroid. Which side of a
/// window faces more of them does not change, and deciding it costs as many cells as a whole
/// model has, not triangles.
///
/// A triangle longer than a cell is cut into pieces no longer than one first: a ground plane
/// of two triangles around a building put all its area at two centroids, one of them outside
/// the building beside a window, and that window faced outwards.
pub fn receivers(
    sources: &[Imported],
    tri_material: &[Vec<u16>],
    classes: &[MaterialClass],
) -> Vec<Receiver> {
    let (lo, hi) = bounds(sources);
    let cell = ((hi - lo).length() / 64.0).max(1e-9);
    let mut cells: HashMap<(usize, [i64; 3], bool), (DVec3, f64)> = HashMap::new();
    let mut pieces = Vec::new();
    let mut cuts = 0usize;
    for (si, (src, mats)) in sources.iter().zip(tri_material).enumerate() {
        for (t, &m) in mats.iter().enumerate() {
            let class = classes[m as usize];
            if class.is_window() || class == MaterialClass::Background {
                continue;
            }
            let floor = class == MaterialClass::Floor;
            pieces.push(triangle(src, t as u32));
            while let Some([a, b, c]) = pieces.pop() {
                let area = (b - a).cross(c - a).length() * 0.5;
                if !(area > 0.0 && area.is_finite()) {
                    continue;
                }
                // Halving the longest edge: a sliver is cut along its length only.
                let edges = [
                    (b - a).length_squared(),
                    (c - b).length_squared(),
                    (a - c).length_squared(),
                ];
                let longest = edges.into_iter().fold(0.0, f64::max);
                if longest > cell * cell && cuts < MAX_RECEIVER_CUTS {
                    cuts += 1;
                    let [a, b, c] = if edges[0] == longest {
                        [a, b, c]
                    } else if edges[1] == longest {
                        [b, c, a]
                    } else {
                        [c, a, b]
                    };
                    let m = (a + b) * 0.5;
                    pieces.push([a, m, c]);
                    pieces.push([m, b, c]);
                    continue;
                }
                let centre = (a + b + c) / 3.0;
                let key = ((centre - lo) / cell).floor().as_i64vec3().to_array();
                let e = cells.entry((si, key, floor)).or_insert((DVec3::ZERO, 0.0));
                e.0 += centre * area;
                e.1 += area;
            }
        }
    }
    // In cell order: the sums over them must not depend on the map's iteration order.
    let mut out: Vec<_> = cells.into_iter().collect();
    out.sort_by_key(|(k, _)| *k);
    out.into_iter()
        .map(|((source, _, floor), (c, a))| Receiver {
            centre: c / a,
            area: a,
            floor,
            source,
        })
        .collect()
}

/// A cell's worth of receiving surface ([`receivers`]): its area-weighted centre, its area,
/// whether it is floor, and the source (mesh) it belongs to.
#[derive(Clone, Copy, Debug)]
pub struct Receiver {
    pub centre: DVec3,
    pub area: f64,
    pub floor: bool,
    pub source: usize,
}

/// The most cuts [`receivers`] makes over a whole model: past it, a triangle counts whole at
/// its centroid. A real model needs about as many as its surface has cells (a hall on 40 m of
/// open ground, 9500); 3000 random triangles across a model's bounds, a hostile file, would
/// need millions: 2^20 took 190 ms here, this bound 21 ms.
const MAX_RECEIVER_CUTS: usize = 1 << 18;

fn bounds(sources: &[Imported]) -> (DVec3, DVec3) {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for s in sources {
        for p in &s.positions {
            lo = lo.min(v3(*p));
            hi = hi.max(v3(*p));
        }
    }
    (lo, hi)
}

/// Which way is inside: an explicit point or direction; else the side facing most receiving
/// geometry (nearer surfaces count more) where at least three quarters of it lie on one side,
/// first without floors, then with them; else the side the light leaves the window through;
/// else the side facing more geometry.
///
/// The building's geometry comes before the light: with the light first, a window on the
/// shaded side of a nave (the sun in through the other side's windows) faced out, its design
/// read mirrored from inside and its light thrown on the ground outside. Floors are asked
/// second: the ground a building stands on lies on both sides of its walls.
/// Whether a manifest's `inside` lies within about 6° of a window's plane (`normal` its unit
/// normal), too close to say which side it points to.
pub fn lies_in_plane(inside: [f32; 3], normal: DVec3) -> bool {
    let v = v3(inside).normalize_or_zero();
    v.dot(normal).abs() < INSIDE_MIN_COS
}

/// Why a window faces the way the manifest's `inside` says, where the model closes round the
/// window on the other side: the plan warns.
pub const INSIDE_AGAINST_ENCLOSURE: &str =
    "the manifest's `inside`, though the model closes round the window on its other side";

/// The side of a window (`normal` or its opposite) round which the model closes, from the
/// shares of open view in `front` of it (along `normal`) and `back`: a hall is closed, and
/// the sky shows on its outside however narrow the alley (4 % of the view up a 1 m alley
/// between halls 8 m high, a tenth up a 2 m one).
fn closed_round(front: f64, back: f64, normal: DVec3) -> Option<DVec3> {
    let (closed, opened) = (front.min(back), front.max(back));
    let side = if front < back { normal } else { -normal };
    (opened >= 0.03 && closed <= opened / 4.0).then_some(side)
}

/// [`lies_in_plane`]'s bound: cos 84°.
const INSIDE_MIN_COS: f64 = 0.1;

#[allow(clippy::too_many_arguments)]
pub fn decide_inside<'r>(
    normal: DVec3,
    centroid: DVec3,
    size: f64,
    explicit: Option<[f32; 3]>,
    light: Option<&LightKind>,
    source: usize,
    receivers: &dyn Fn() -> &'r [Receiver],
    open: &dyn Fn() -> Option<[f64; 2]>,
) -> (DVec3, &'static str) {
    let orient = |d: DVec3| if normal.dot(d) < 0.0 { -normal } else { normal };
    // A direction (nearly) in the window's plane tells its sides apart by rounding noise: the
    // window is guessed as if none were given (and the plan warns).
    if let Some(v) = explicit.filter(|&v| !lies_in_plane(v, normal)) {
        let side = orient(v3(v));
        // Followed, but said: the lit pass takes what lies beyond a window's inner side for
        // the outdoors, and a whole nave in direct sun turned every floor patch white. Only
        // where the model is closed round the other side; a roofless hall is not evidence.
        let against = open()
            .and_then(|[front, back]| closed_round(front, back, normal))
            .is_some_and(|enclosed| enclosed.dot(side) < 0.0);
        let why = if against {
            INSIDE_AGAINST_ENCLOSURE
        } else {
            "the manifest's `inside`"
        };
        return (side, why);
    }
    // A building is closed around its inside: what the window sees on that side is the model
    // in every direction, on the outside there is sky. This sees past surfaces hidden behind
    // others, which the weights below count as if in view: a church's window 1-5 m from a
    // neighbour looked into the neighbour, whose near wall and whole inside outweighed the
    // church's own hall.
    if let Some([front, back]) = open() {
        // A roofless hall is half open, its outside wholly.
        let half_open = (front - back).abs() >= 0.3;
        let side = if front < back { normal } else { -normal };
        if let Some(side) = closed_round(front, back, normal).or(half_open.then_some(side)) {
            return (
                side,
                "the enclosed side (seen from it the model closes round the window)",
            );
        }
    }
    // Each surface counts by how large it looks from the window (area × |cos| / d², with the
    // cosine taken against the window's normal); surfaces lying about in the window's own
    // plane (its wall, a reveal just behind the glass) say nothing about the sides.
    // [score, total weight], without floors and with them.
    //
    // The window's own mesh is asked first: a scene of several buildings, each its own mesh,
    // had a church's windows face its neighbour ten metres away, whose walls and floor
    // outweighed the church's own. Glass modelled as a mesh of its own (no receivers) asks
    // every mesh.
    let sums_of = |own: bool| {
        let mut sums = [[0.0f64; 2]; 2];
        for r in receivers().iter().filter(|r| !own || r.source == source) {
            let d = r.centre - centroid;
            let side = d.dot(normal);
            if side.abs() >= 0.05 * size {
                let weight = r.area * side.abs() / d.length().powi(3);
                for (k, sum) in sums.iter_mut().enumerate() {
                    if k == 1 || !r.floor {
                        sum[0] += side.signum() * weight;
                        sum[1] += weight;
                    }
                }
            }
        }
        sums
    };
    let own = sums_of(true);
    let sums = if own[1][1] > 0.0 { own } else { sums_of(false) };
    let facing = |score: f64| if score < 0.0 { -normal } else { normal };
    for (k, [score, total]) in sums.into_iter().enumerate() {
        if total > 0.0 && score.abs() >= 0.5 * total {
            let why = if k == 0 {
                "the side facing most receiving geometry other than floors"
            } else {
                "the side facing most receiving geometry"
            };
            return (facing(score), why);
        }
    }
    match light {
        Some(LightKind::Directional { direction, .. })
            if normal.dot(v3(*direction)).abs() > 1e-6 =>
        {
            (
                orient(v3(*direction)),
                "the side the sunlight leaves through",
            )
        }
        Some(LightKind::Point { position, .. } | LightKind::Spot { position, .. })
            if normal.dot(centroid - v3(*position)).abs() > 1e-9 =>
        {
            (
                orient(centroid - v3(*position)),
                "the side away from the light",
            )
        }
        _ => (
            facing(sums[1][0]),
            "the side facing more receiving geometry",
        ),
    }
}

/// Rays traced from each side of a window against the model: which side it closes round.
struct Enclosure {
    /// Every triangle that is not sky (glass included: a hall's other windows close it too).
    corners: Vec<[glam::Vec3; 3]>,
    /// Per triangle: its source and its index there.
    ids: Vec<(u32, u32)>,
    bvh: geom::Bvh,
}

/// Rays per side: enough that a side 15 % open is told from a closed one several times over.
const ENCLOSURE_RAYS: usize = 128;

impl Enclosure {
    fn new(sources: &[Imported], tri_material: &[Vec<u16>], classes: &[MaterialClass]) -> Self {
        let (mut corners, mut ids) = (Vec::new(), Vec::new());
        for (si, (src, mats)) in sources.iter().zip(tri_material).enumerate() {
            for (t, &m) in mats.iter().enumerate() {
                if classes[m as usize] == MaterialClass::Background {
                    continue;
                }
                corners.push(triangle(src, t as u32).map(|p| p.as_vec3()));
                ids.push((si as u32, t as u32));
            }
        }
        let bvh = geom::Bvh::build(corners.len(), |i| corners[i as usize]);
        Enclosure { corners, ids, bvh }
    }

    /// The share of rays that leave the model without meeting it, from just off the window's
    /// centroid on the side `normal` points to and on the other; cosine-weighted (the window's
    /// view, not the grazing directions along its own wall), on a fixed spiral so that the
    /// answer is the same on every run. The window's own triangles (both faces of a slab) and
    /// what lies near its plane do not stop a ray.
    fn open(
        &self,
        source: usize,
        own: &[u32],
        centroid: DVec3,
        normal: DVec3,
        size: f64,
    ) -> Option<[f64; 2]> {
        if self.corners.is_empty() || size.is_nan() || size <= 0.0 {
            return None;
        }
        let mut own: Vec<u32> = own.to_vec();
        own.sort_unstable();
        let (t, b) = normal.any_orthonormal_pair();
        let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
        // What lies within this of the window's plane is its wall: the reveal of its opening,
        // or an uncut wall just behind glass drawn on it, which closes nothing (the
        // receivers' weights leave it out alike).
        let near = 0.05 * size;
        let mut sides = [0.0; 2];
        for (side, sign) in sides.iter_mut().zip([1.0, -1.0]) {
            let n = normal * sign;
            let origin = (centroid + n * (1e-4 * size)).as_vec3();
            let mut open = 0usize;
            for k in 0..ENCLOSURE_RAYS {
                let r = ((k as f64 + 0.5) / ENCLOSURE_RAYS as f64).sqrt();
                let phi = k as f64 * golden;
                let d = t * (r * phi.cos()) + b * (r * phi.sin()) + n * (1.0 - r * r).sqrt();
                let blocked = self.bvh.visit(
                    origin,
                    d.as_vec3(),
                    f32::INFINITY,
                    |i| self.corners[i as usize],
                    &mut |i, hit, _| {
                        let (s, tri) = self.ids[i as usize];
                        let own = s as usize == source && own.binary_search(&tri).is_ok();
                        if own || (hit as f64) * d.dot(n) < near {
                            f32::INFINITY
                        } else {
                            -1.0
                        }
                    },
                );
                open += usize::from(!blocked);
            }
            *side = open as f64 / ENCLOSURE_RAYS as f64;
        }
        Some(sides)
    }
}

/// The manifest's `inside` override for a window name and its materials.
pub type InsideOverride<'a> = &'a dyn Fn(&str, &[u16]) -> Option<[f32; 3]>;

/// Finds every window instance. `tri_material` gives each triangle's tagged pack material,
/// `classes` each material's class, `names` each material's name; `inside` gives the
/// manifest's override for an instance name and its materials, if any.
pub fn find(
    sources: &[Imported],
    tri_material: &[Vec<u16>],
    classes: &[MaterialClass],
    names: &[String],
    light: Option<&LightKind>,
    inside: InsideOverride<'_>,
) -> Vec<Instance> {
    // Only a window without an override needs them, and there are as many as the model has
    // triangles.
    let all_receivers = std::cell::OnceCell::new();
    let receivers = || {
        all_receivers
            .get_or_init(|| receivers(sources, tri_material, classes))
            .as_slice()
    };
    // The weld tolerance is relative to the whole model, so it means the same for every mesh.
    let (lo, hi) = bounds(sources);
    let tolerance = ((hi - lo).length() * WELD).max(1e-9);

    let all_enclosure = std::cell::OnceCell::new();
    let enclosure = || all_enclosure.get_or_init(|| Enclosure::new(sources, tri_material, classes));
    let mut out: Vec<Instance> = Vec::new();
    for (si, (src, mats)) in sources.iter().zip(tri_material).enumerate() {
        let glass: Vec<u32> = (0..mats.len() as u32)
            .filter(|&t| classes[mats[t as usize] as usize].is_window())
            .collect();
        if glass.is_empty() {
            continue;
        }
        let weld = weld_ids(src, &glass, tolerance);
        let mut pieces = Vec::new();
        for component in components(src, &weld, &glass) {
            let Some(whole) = Shape::of(src, &component) else {
                continue;
            };
            if whole.planar {
                pieces.push((component, whole));
            } else {
                let split = split_planes(src, &weld, &component, whole.size);
                for tris in split.unwrap_or_else(|| vec![component]) {
                    if let Some(shape) = Shape::of(src, &tris) {
                        pieces.push((tris, shape));
                    }
                }
            }
        }
        // A joined group must itself be flat (pairs agree within 5° and a tolerance, but a
        // chain of them may bend): else its pieces stay apart.
        let mut joined: Vec<(Vec<u32>, Shape)> = Vec::new();
        for group in join_leaded(&pieces) {
            if let [i] = group[..] {
                joined.push(pieces[i].clone());
                continue;
            }
            let mut tris: Vec<u32> = group.iter().flat_map(|&i| pieces[i].0.clone()).collect();
            tris.sort_unstable();
            match Shape::of(src, &tris) {
                Some(shape) if shape.planar => joined.push((tris, shape)),
                _ => joined.extend(group.iter().map(|&i| pieces[i].clone())),
            }
        }
        joined.sort_by_key(|(t, _)| t[0]);
        for (tris, shape) in joined {
            let mut by_material: Vec<(u16, f64)> = Vec::new();
            for &t in &tris {
                let [a, b, c] = triangle(src, t);
                let ar = (b - a).cross(c - a).length() * 0.5;
                let m = mats[t as usize];
                match by_material.iter_mut().find(|e| e.0 == m) {
                    Some(e) => e.1 += ar,
                    None => by_material.push((m, ar)),
                }
            }
            // Areas equal but for rounding (two red and two blue panes of one size) are
            // equal: the first material wins, at any scale of the model (at 0.01 the rounding
            // named three of six like windows after the blue glass).
            let step = by_material.iter().map(|e| e.1).sum::<f64>() * 1e-6;
            let rank = |a: f64| if step > 0.0 { (a / step).round() } else { a };
            by_material.sort_by(|a, b| rank(b.1).total_cmp(&rank(a.1)).then(a.0.cmp(&b.0)));
            out.push(Instance {
                name: names[by_material[0].0 as usize].clone(),
                source: si,
                has_uvs: has_uvs(src, &tris),
                triangles: tris,
                materials: by_material,
                area: shape.area,
                centroid: shape.centroid,
                inside: shape.normal,
                inside_reason: "",
                origin: DVec3::ZERO,
                right: DVec3::ZERO,
                up: DVec3::ZERO,
                max_deviation: shape.deviation,
                planar: shape.planar,
            });
        }
    }
    // Names: the dominant material's, numbered where several windows share it.
    let mut count: HashMap<String, usize> = HashMap::new();
    for i in &out {
        *count.entry(i.name.clone()).or_insert(0) += 1;
    }
    let mut seen: HashMap<String, usize> = HashMap::new();
    for i in &mut out {
        if count[&i.name] > 1 {
            let k = seen.entry(i.name.clone()).or_insert(0);
            *k += 1;
            i.name = format!("{}#{k}", i.name);
        }
    }
    for i in &mut out {
        let mats: Vec<u16> = i.materials.iter().map(|m| m.0).collect();
        let size = size_of(&sources[i.source], &i.triangles);
        let open = || enclosure().open(i.source, &i.triangles, i.centroid, i.inside, size);
        let (n, why) = decide_inside(
            i.inside,
            i.centroid,
            size,
            inside(&i.name, &mats),
            light,
            i.source,
            &receivers,
            &open,
        );
        i.inside = n;
        i.inside_reason = why;
        let (o, r, u) = fit_rectangle(&sources[i.source], &i.triangles, i.centroid, n);
        i.origin = o;
        i.right = r;
        i.up = u;
    }
    out
}

/// Writes planar texture coordinates for the instance's triangles into its source.
pub fn write_planar_uvs(src: &mut Imported, instance: &Instance) {
    for &t in &instance.triangles {
        for k in 0..3 {
            let c = t as usize * 3 + k;
            let p = v3(src.positions[src.corners.p(c) as usize]);
            src.uvs.push(instance.planar_uv(p));
            let t = src.uvs.len() as u32 - 1;
            src.corners.set(
                c,
                Corner {
                    t,
                    ..src.corners.get(c)
                },
            );
        }
    }
}

/// The class of a window no rule placed: lower when its sill is in the lower half of the
/// height between the floor and the top of the walls.
pub fn class_by_sill(sill: f64, floor: f64, wall_top: f64) -> MaterialClass {
    if wall_top > floor && (sill - floor) < 0.5 * (wall_top - floor) {
        MaterialClass::WindowLower
    } else {
        MaterialClass::WindowUpper
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A church's window between its own far wall (+x, 10 m) and a neighbouring building,
    /// another mesh of the scene, whose whole mass lies on the other side: the window's own
    /// mesh decides, so it faces into its church. Without receivers of its own (glass as a
    /// mesh apart), every mesh counts.
    #[test]
    fn the_windows_own_mesh_decides_its_inside() {
        let at = |x: f64, area: f64, source: usize| Receiver {
            centre: DVec3::new(x, 5.0, 0.0),
            area,
            floor: false,
            source,
        };
        let scene = [at(10.0, 100.0, 0), at(-10.0, 150.0, 1), at(-20.0, 400.0, 1)];
        let decide = |source: usize| {
            decide_inside(
                DVec3::X,
                DVec3::ZERO,
                3.0,
                None,
                None,
                source,
                &|| &scene[..],
                &|| None,
            )
        };
        assert_eq!(decide(0).0, DVec3::X);
        // Glass in a mesh of its own: the neighbour's mass on −x outweighs the far wall.
        assert_eq!(decide(2).0, DVec3::NEG_X);
    }
    use crate::import::{Corner, Part};

    /// A quad: corner, right edge, up edge, material.
    type Quad = ([f32; 3], [f32; 3], [f32; 3], u32);

    fn quads(q: &[Quad]) -> Imported {
        let mut s = Imported::default();
        for &(o, r, u, m) in q {
            let base = s.positions.len() as u32;
            let o = glam::Vec3::from(o);
            let (r, u) = (glam::Vec3::from(r), glam::Vec3::from(u));
            for p in [o, o + r, o + r + u, o + u] {
                s.positions.push(p.to_array());
            }
            for t in [[0, 1, 2], [0, 2, 3]] {
                for k in t {
                    s.corners.push(Corner {
                        p: base + k,
                        t: NONE,
                        n: NONE,
                    });
                }
                s.tri_part.push(m);
            }
        }
        let parts = s.tri_part.iter().copied().max().unwrap_or(0) + 1;
        s.parts = (0..parts)
            .map(|_| Part {
                names: Default::default(),
                material: None,
            })
            .collect();
        s
    }

    fn run(src: &Imported, classes: &[MaterialClass], light: Option<&LightKind>) -> Vec<Instance> {
        let mats: Vec<u16> = src.tri_part.iter().map(|&p| p as u16).collect();
        let names: Vec<String> = (0..classes.len()).map(|i| format!("m{i}")).collect();
        find(
            std::slice::from_ref(src),
            &[mats],
            classes,
            &names,
            light,
            &|_, _| None,
        )
    }

    const W: MaterialClass = MaterialClass::WindowUpper;
    const F: MaterialClass = MaterialClass::Floor;

    #[test]
    fn panes_of_four_materials_in_one_plane_are_one_window() {
        // A 2 x 2 grid of 1 m panes in the plane x = 0, sharing edges, four materials.
        let mut q = Vec::new();
        for (i, (y, z)) in [(0., 0.), (0., 1.), (1., 0.), (1., 1.)]
            .into_iter()
            .enumerate()
        {
            q.push(([0., 2. + y, z], [0., 0., 1.], [0., 1., 0.], i as u32));
        }
        let src = quads(&q);
        let sun = LightKind::Directional {
            direction: [1.0, -1.0, 0.0],
            angular_size: 0.01,
        };
        let w = run(&src, &[W, W, W, W], Some(&sun));
        assert_eq!(w.len(), 1, "{w:#?}");
        let w = &w[0];
        assert_eq!(w.materials.len(), 4);
        assert!((w.area - 4.0).abs() < 1e-9);
        assert_eq!(w.inside, DVec3::X);
        assert!((w.width() - 2.0).abs() < 1e-9 && (w.height() - 2.0).abs() < 1e-9);
        // Seen from inside (looking along −x), right is −z and up is +y.
        assert!((w.up.normalize() - DVec3::Y).length() < 1e-9);
        assert!(
            (w.right.normalize() + DVec3::Z).length() < 1e-9,
            "{:?}",
            w.right
        );
        assert!((w.origin - DVec3::new(0.0, 2.0, 2.0)).length() < 1e-9);
        // Bottom left and top right seen from inside; v runs down the design.
        assert_eq!(w.planar_uv(DVec3::new(0.0, 2.0, 2.0)), [0.0, 1.0]);
        assert_eq!(w.planar_uv(DVec3::new(0.0, 4.0, 0.0)), [1.0, 0.0]);
    }

    /// A closed box of stone (material 1), x from `x0` to `x0 + 10`, 8 high and 30 long; with
    /// `window`, its +x wall has a 6 x 4 opening glazed in material 0.
    fn hall(x0: f32, window: bool) -> Vec<Quad> {
        let (w, h, l) = (10.0, 8.0, 30.0);
        let mut q = vec![
            ([x0, 0., 0.], [w, 0., 0.], [0., 0., l], 1),
            ([x0, h, 0.], [w, 0., 0.], [0., 0., l], 1),
            ([x0, 0., 0.], [0., 0., l], [0., h, 0.], 1),
            ([x0, 0., 0.], [w, 0., 0.], [0., h, 0.], 1),
            ([x0, 0., l], [w, 0., 0.], [0., h, 0.], 1),
        ];
        let x1 = x0 + w;
        if window {
            q.extend([
                ([x1, 0., 0.], [0., 0., l], [0., 2., 0.], 1),
                ([x1, 6., 0.], [0., 0., l], [0., 2., 0.], 1),
                ([x1, 2., 0.], [0., 0., 12.], [0., 4., 0.], 1),
                ([x1, 2., 18.], [0., 0., 12.], [0., 4., 0.], 1),
                ([x1, 2., 12.], [0., 0., 6.], [0., 4., 0.], 0),
            ]);
        } else {
            q.push(([x1, 0., 0.], [0., 0., l], [0., h, 0.], 1));
        }
        q
    }

    /// A church's window in its side wall, a neighbouring hall across an alley: the window's
    /// inside is its own hall, though the neighbour's near wall and whole inside (which the
    /// window cannot see) lie on the other side. It faced the alley up to a 5 m gap. Without
    /// a light, so nothing but the geometry decides.
    #[test]
    fn a_window_facing_a_neighbour_across_an_alley_looks_into_its_own_hall() {
        const S: MaterialClass = MaterialClass::Wall;
        for gap in [1.0, 1.5, 2.0, 3.0, 5.0, 10.0] {
            let mut q = hall(-5.0, true);
            q.extend(hall(5.0 + gap, false));
            let w = run(&quads(&q), &[W, S], None);
            assert_eq!(w.len(), 1, "{w:#?}");
            assert_eq!(
                w[0].inside,
                DVec3::NEG_X,
                "gap {gap}: {}",
                w[0].inside_reason
            );
            assert!(
                w[0].inside_reason.starts_with("the enclosed side"),
                "{}",
                w[0].inside_reason
            );
        }
        // Alone, with no roof: still the hall's side (half its view is sky, all of the
        // outside's).
        let roofless: Vec<Quad> = hall(-5.0, true)
            .into_iter()
            .filter(|q| q.0[1] != 8.0)
            .collect();
        let w = run(&quads(&roofless), &[W, S], None);
        assert_eq!(w[0].inside, DVec3::NEG_X, "{}", w[0].inside_reason);
    }

    #[test]
    fn thirty_panes_of_one_material_are_thirty_windows_in_order() {
        let q: Vec<_> = (0..30)
            .map(|i| ([4., 1., -2. * i as f32], [0., 0., 1.], [0., 3., 0.], 0))
            .collect();
        let mut src = quads(&q);
        // A floor inside (x < 4) decides the inside without a light.
        let floor = quads(&[([-4., 0., -60.], [8., 0., 0.], [0., 0., 62.], 1)]);
        let n = src.positions.len() as u32;
        src.positions.extend(&floor.positions);
        for c in floor.corners.iter() {
            src.corners.push(Corner { p: c.p + n, ..c });
        }
        src.tri_part.extend([1, 1]);
        src.parts.push(Part {
            names: Default::default(),
            material: None,
        });
        let w = run(&src, &[W, F], None);
        assert_eq!(w.len(), 30);
        assert_eq!(w[0].name, "m0#1");
        assert_eq!(w[29].name, "m0#30");
        for i in &w {
            assert_eq!(i.inside, -DVec3::X, "{}", i.inside_reason);
            assert!((i.height() - 3.0).abs() < 1e-6 && (i.width() - 1.0).abs() < 1e-6);
        }
    }

    #[test]
    fn a_bay_window_in_two_planes_splits() {
        // Two 1 x 2 panes meeting at a 90° edge.
        let src = quads(&[
            ([0., 0., 0.], [1., 0., 0.], [0., 2., 0.], 0),
            ([1., 0., 0.], [0., 0., 1.], [0., 2., 0.], 0),
        ]);
        let w = run(&src, &[W], None);
        assert_eq!(w.len(), 2, "{w:#?}");
        assert!(w.iter().all(|i| i.planar && i.max_deviation < 1e-9));
        assert_eq!(w[0].name, "m0#1");
    }

    #[test]
    fn curved_glass_is_kept_whole_and_marked_non_planar() {
        // Twelve facets of a half cylinder: too many planes to split.
        let mut q = Vec::new();
        for i in 0..12 {
            let a0 = i as f32 / 12.0 * std::f32::consts::PI;
            let a1 = (i + 1) as f32 / 12.0 * std::f32::consts::PI;
            let p0 = [a0.cos(), 0., a0.sin()];
            let p1 = [a1.cos(), 0., a1.sin()];
            q.push((p0, [p1[0] - p0[0], 0., p1[2] - p0[2]], [0., 2., 0.], 0));
        }
        let w = run(&quads(&q), &[W], None);
        assert_eq!(w.len(), 1);
        assert!(!w[0].planar);
        assert!(w[0].max_deviation > 0.1);
    }

    /// Glass wound one way that turns through 180° lies in the plane of its opening: its far
    /// facets were turned towards an end facet, and the plane came out 67° off it.
    #[test]
    fn a_half_cylinder_bay_lies_in_the_plane_of_its_opening() {
        for n in [12, 16] {
            let mut q = Vec::new();
            for i in 0..n {
                let a0 = i as f32 / n as f32 * std::f32::consts::PI;
                let a1 = (i + 1) as f32 / n as f32 * std::f32::consts::PI;
                let p0 = [a0.cos(), 0., a0.sin()];
                let p1 = [a1.cos(), 0., a1.sin()];
                q.push((p0, [p1[0] - p0[0], 0., p1[2] - p0[2]], [0., 2., 0.], 0));
            }
            let w = run(&quads(&q), &[W], None);
            assert_eq!(w.len(), 1, "{w:#?}");
            assert!(w[0].inside.z.abs() > 0.9999, "{n}: {:?}", w[0].inside);
            assert!((w[0].width() - 2.0).abs() < 1e-3, "{n}: {:?}", w[0]);
            assert!((w[0].height() - 2.0).abs() < 1e-3, "{n}: {:?}", w[0]);
        }
    }

    /// A shallow arc, twelve facets 3.75° apart over a 3 m chord, is one curved window, not
    /// six two-facet "bay" planes with lead outlines between them.
    #[test]
    fn a_shallow_arc_is_one_curved_window_not_a_bay() {
        let (r, half) = (3.9f32, 22.5f32.to_radians());
        let mut q = Vec::new();
        for i in 0..12 {
            let a0 = -half + i as f32 / 12.0 * 2.0 * half;
            let a1 = -half + (i + 1) as f32 / 12.0 * 2.0 * half;
            let p0 = [r * a0.sin(), 0., r * a0.cos()];
            let p1 = [r * a1.sin(), 0., r * a1.cos()];
            q.push((p0, [p1[0] - p0[0], 0., p1[2] - p0[2]], [0., 3., 0.], 0));
        }
        let w = run(&quads(&q), &[W], None);
        assert_eq!(w.len(), 1, "{w:#?}");
        assert!(!w[0].planar);
        assert!(w[0].inside.z.abs() > 0.9999, "{:?}", w[0].inside);
    }

    #[test]
    fn a_rotated_rectangle_is_found_with_its_own_axes() {
        // A 1 x 3 pane tilted by 30° in the plane z = 0.
        let (s, c) = 30f32.to_radians().sin_cos();
        let src = quads(&[([0., 0., 0.], [c, s, 0.], [-3. * s, 3. * c, 0.], 0)]);
        let w = run(&src, &[W], None);
        assert!((w[0].width() - 1.0).abs() < 1e-5, "{:?}", w[0]);
        assert!((w[0].height() - 3.0).abs() < 1e-5);
    }

    #[test]
    fn a_rose_of_sixteen_segments_stays_upright() {
        // Its minimum-area rectangle is turned 11.25° (to an edge), 4 % smaller than upright.
        let r = 1.5f32;
        let mut s = Imported::default();
        for k in 0..16 {
            let (a0, a1) = (
                k as f32 * 22.5f32.to_radians(),
                (k + 1) as f32 * 22.5f32.to_radians(),
            );
            let base = s.positions.len() as u32;
            s.positions.push([0.0, 6.0, 0.0]);
            s.positions.push([r * a0.cos(), 6.0 + r * a0.sin(), 0.0]);
            s.positions.push([r * a1.cos(), 6.0 + r * a1.sin(), 0.0]);
            for c in 0..3 {
                s.corners.push(Corner {
                    p: base + c,
                    t: NONE,
                    n: NONE,
                });
            }
            s.tri_part.push(0);
        }
        s.parts.push(Part {
            names: Default::default(),
            material: None,
        });
        let w = run(&s, &[W], None);
        assert_eq!(w.len(), 1);
        assert!(
            (w[0].up.normalize() - DVec3::Y).length() < 1e-9,
            "{:?}",
            w[0].up
        );
        assert!((w[0].width() - 3.0).abs() < 1e-5 && (w[0].height() - 3.0).abs() < 1e-5);
    }

    /// A closed box with outward faces: corner and the three edges.
    fn slab(o: [f32; 3], a: [f32; 3], b: [f32; 3], c: [f32; 3], m: u32) -> Vec<Quad> {
        let add = |p: [f32; 3], q: [f32; 3]| [p[0] + q[0], p[1] + q[1], p[2] + q[2]];
        vec![
            (o, b, a, m),
            (add(o, c), a, b, m),
            (o, a, c, m),
            (add(o, b), c, a, m),
            (o, c, b, m),
            (add(o, a), b, c, m),
        ]
    }

    #[test]
    fn a_double_sided_pane_and_a_thin_slab_are_each_one_flat_window() {
        // Real exports: the face twice, wound both ways (x = 0), and a 1 cm slab (x = 5).
        let mut q = vec![
            ([0., 1., 0.], [0., 0., 1.], [0., 2., 0.], 0),
            ([0., 1., 0.], [0., 2., 0.], [0., 0., 1.], 0),
        ];
        // A leaded pane's size: its half thickness is more than 1 % of its diagonal.
        q.extend(slab(
            [5., 1., 0.],
            [0.01, 0., 0.],
            [0., 0.35, 0.],
            [0., 0., 0.25],
            0,
        ));
        let w = run(&quads(&q), &[W], None);
        assert_eq!(w.len(), 2, "{w:#?}");
        for (i, size) in w.iter().zip([[1.0, 2.0], [0.25, 0.35]]) {
            assert!(i.planar, "{i:#?}");
            assert!(i.max_deviation < 1e-6, "{}", i.max_deviation);
            assert!(i.inside.x.abs() > 0.999, "{:?}", i.inside);
            assert!((i.width() - size[0]).abs() < 1e-5 && (i.height() - size[1]).abs() < 1e-5);
        }
        // The two-sided pane and the slab's front and back count once (its edges besides).
        assert!((w[0].area - 2.0).abs() < 1e-9, "{}", w[0].area);
        assert!((w[1].area - 0.0995).abs() < 1e-5, "{}", w[1].area);
        // One pane whose two triangles face either way is one side, whole.
        let mut flipped = quads(&[([0., 1., 0.], [0., 0., 1.], [0., 2., 0.], 0)]);
        let c = flipped.corners.get(5);
        let b = flipped.corners.get(4);
        flipped.corners.set(4, c);
        flipped.corners.set(5, b);
        let w = run(&flipped, &[W], None);
        assert!((w[0].area - 2.0).abs() < 1e-9, "{}", w[0].area);
    }

    #[test]
    fn a_pane_s_front_and_back_as_loose_faces_are_one_window() {
        // A 2 x 3 m pane whose two faces, wound opposite ways, are 8 cm apart with nothing
        // joining them: one flat window of one pane's area (it was two from 6 cm on).
        let front = ([0., 1., 0.], [0., 0., 2.], [0., 3., 0.], 0);
        let back = ([0.08, 1., 0.], [0., 3., 0.], [0., 0., 2.], 0);
        let w = run(&quads(&[front, back]), &[W], None);
        assert_eq!(w.len(), 1, "{w:#?}");
        assert!(w[0].planar, "{:#?}", w[0]);
        assert!((w[0].area - 6.0).abs() < 1e-6, "{}", w[0].area);
        // Wound alike (a protective glazing outside the stained glass), or only half
        // covering each other, or 0.3 m apart (over a tenth of its 2 m side): two windows.
        let outer = ([0.08, 1., 0.], [0., 0., 2.], [0., 3., 0.], 0);
        let shifted = ([0.08, 1., 1.], [0., 3., 0.], [0., 0., 2.], 0);
        let far = ([0.3, 1., 0.], [0., 3., 0.], [0., 0., 2.], 0);
        for other in [outer, shifted, far] {
            assert_eq!(
                run(&quads(&[front, other]), &[W], None).len(),
                2,
                "{other:?}"
            );
        }
    }

    #[test]
    fn leaded_panes_a_came_apart_are_one_window_and_the_next_window_is_not() {
        // Two windows of 3 x 6 panes (0.25 x 0.35 m, 2 cm cames between them, three
        // glasses) in the wall x = 0, 1.2 m apart; the panes are 1 cm slabs.
        let mut q = Vec::new();
        for window in 0..2 {
            for i in 0..3 {
                for j in 0..6 {
                    let z = window as f32 * 2.0 + i as f32 * 0.27;
                    let y = 2.0 + j as f32 * 0.37;
                    let m = ((i + j) % 3) as u32;
                    q.extend(slab(
                        [0., y, z],
                        [0.01, 0., 0.],
                        [0., 0.35, 0.],
                        [0., 0., 0.25],
                        m,
                    ));
                }
            }
        }
        let w = run(&quads(&q), &[W, W, W], None);
        assert_eq!(
            w.len(),
            2,
            "{:#?}",
            w.iter().map(|i| &i.name).collect::<Vec<_>>()
        );
        for i in &w {
            assert!(i.planar);
            assert_eq!(i.materials.len(), 3);
            assert_eq!(i.triangles.len(), 18 * 12);
            assert!((i.width() - 0.79).abs() < 1e-4, "{}", i.width());
            assert!((i.height() - 2.2).abs() < 1e-4, "{}", i.height());
        }
        // Wider gaps stay apart: panes 0.2 m apart on 0.4 m (Šibenik's lancets), and a
        // pane in a parallel plane 0.3 m behind.
        let q = vec![
            ([0., 0., 0.], [0., 0., 0.4], [0., 2., 0.], 0),
            ([0., 0., 0.6], [0., 0., 0.4], [0., 2., 0.], 0),
            ([0.3, 0., 1.0], [0., 0., 0.4], [0., 2., 0.], 0),
        ];
        assert_eq!(run(&quads(&q), &[W], None).len(), 3);
    }

    #[test]
    fn on_a_wall_at_45_degrees_panes_a_came_apart_join_and_lancets_do_not() {
        // Walls along (1, 0, ±1)/√2, up +Y.
        for side in [1.0f32, -1.0] {
            let along = |d: f32| [d * 0.5f32.sqrt(), 0.0, side * d * 0.5f32.sqrt()];
            let pane = |start: f32, width: f32| (along(start), along(width), [0., 2., 0.], 0);
            // A skylight far above makes the sweep run along +Y, where the lancets overlap.
            let sky = ([0., 100., 0.], [1., 0., 0.], [0., 0., 1.], 0);
            // Three panes 0.3 m wide, 2 cm apart: one window.
            let leaded = quads(&[pane(0.0, 0.3), pane(0.32, 0.3), pane(0.64, 0.3), sky]);
            assert_eq!(run(&leaded, &[W], None).len(), 2);
            // Lancets 0.4 m wide, 0.2 m apart (half their width): three windows.
            let lancets = quads(&[pane(0.0, 0.4), pane(0.6, 0.4), pane(1.2, 0.4), sky]);
            assert_eq!(
                run(&lancets, &[W], None).len(),
                4,
                "wall along z = {side} x"
            );
        }
    }

    #[test]
    fn a_thick_bay_window_is_not_taken_for_one_flat_slab() {
        // A bay of 1 cm glass: a 3 m centre facet (60 % of the area) between two 1 m facets
        // at 37°. The centre's front and back are flat sheets; the sides leave them by 0.6 m.
        let line = [(-2.3f32, -0.6f32), (-1.5, 0.0), (1.5, 0.0), (2.3, -0.6)];
        let t = 0.01;
        let mut q = Vec::new();
        for k in 0..3 {
            let (a, b) = (line[k], line[k + 1]);
            let o = [a.0, 0.0, a.1];
            let r = [b.0 - a.0, 0.0, b.1 - a.1];
            q.push((o, r, [0., 2., 0.], 0));
            q.push(([a.0, 0.0, a.1 - t], [0., 2., 0.], r, 0));
            q.push(([a.0, 2.0, a.1], [0., 0., -t], r, 0));
            q.push(([a.0, 0.0, a.1], r, [0., 0., -t], 0));
        }
        let w = run(&quads(&q), &[W], None);
        // Split along its planes: the centre facet is a window of its own.
        assert!(
            w.iter()
                .any(|i| (i.width() - 3.0).abs() < 1e-3 && (i.height() - 2.0).abs() < 1e-3),
            "{:?}",
            w.iter()
                .map(|i| (i.width(), i.height()))
                .collect::<Vec<_>>()
        );
    }

    #[test]
    fn sill_height_decides_upper_and_lower() {
        assert_eq!(class_by_sill(1.0, 0.0, 12.5), MaterialClass::WindowLower);
        assert_eq!(class_by_sill(8.2, 0.0, 12.5), MaterialClass::WindowUpper);
    }
}
