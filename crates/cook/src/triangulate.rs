//! Polygon triangulation by ear clipping.
//!
//! A fan (what tobj does) is only right for convex polygons: for a concave one it produces
//! triangles outside the polygon and overlapping each other. Ear clipping works on any simple
//! polygon; for non-simple input (self-intersecting, collinear runs) it still returns `n - 2`
//! triangles covering every vertex, so no input makes it fail or loop.

/// Triangulates the polygon `points` (in order, any winding, roughly planar). Appends `n - 2`
/// triangles of indices into `points` to `out`, each with the polygon's winding.
pub fn triangulate(points: &[[f32; 3]], out: &mut Vec<[u32; 3]>) {
    let n = points.len();
    if n < 3 {
        return;
    }
    if n == 3 {
        out.push([0, 1, 2]);
        return;
    }
    // Newell's normal is robust for concave and slightly non-planar polygons.
    let mut normal = [0.0f64; 3];
    for i in 0..n {
        let a = points[i].map(f64::from);
        let b = points[(i + 1) % n].map(f64::from);
        normal[0] += (a[1] - b[1]) * (a[2] + b[2]);
        normal[1] += (a[2] - b[2]) * (a[0] + b[0]);
        normal[2] += (a[0] - b[0]) * (a[1] + b[1]);
    }
    let axis = (0..3)
        .max_by(|&a, &b| normal[a].abs().total_cmp(&normal[b].abs()))
        .unwrap_or(2);
    if normal[axis] == 0.0 || !normal[axis].is_finite() {
        // Zero area (all points collinear or coincident): any split is as good as another.
        fan(n, out);
        return;
    }
    // Project onto the plane of the two other axes, ordered so the polygon is counter-clockwise.
    let (u, v) = match axis {
        0 => (1, 2),
        1 => (2, 0),
        _ => (0, 1),
    };
    let flip = normal[axis] < 0.0;
    let p2: Vec<[f64; 2]> = points
        .iter()
        .map(|p| {
            let (x, y) = (p[u] as f64, p[v] as f64);
            if flip { [y, x] } else { [x, y] }
        })
        .collect();
    ear_clip(&p2, out);
}

fn fan(n: usize, out: &mut Vec<[u32; 3]>) {
    for i in 1..n - 1 {
        out.push([0, i as u32, i as u32 + 1]);
    }
}

fn cross(o: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
}

fn inside(p: [f64; 2], a: [f64; 2], b: [f64; 2], c: [f64; 2]) -> bool {
    cross(a, b, p) >= 0.0 && cross(b, c, p) >= 0.0 && cross(c, a, p) >= 0.0
}

/// Ear clipping of a counter-clockwise 2D polygon.
///
/// Only vertices that do not turn left can lie inside an ear of a simple polygon (if any
/// vertex does, a reflex one does), and clipping ears only ever turns a reflex vertex
/// convex: so an ear is tested against the polygon's reflex and flat vertices still in the
/// ring, not against every vertex. The ring is a linked list, so a clip does not move the
/// rest of it. Both keep the order in which ears are found, so for a simple polygon the
/// triangles are those of testing every vertex in an array. Where blockers are many (a
/// 50,000-corner star face has 25,000; a circle of as many corners written to 6 decimals has
/// half its corners flat or reflex), a [`Grid`] finds those near an ear: the whole cook of the
/// star takes 0.34 s, not 2.6 s (7.1 s before the list), the circle's 0.62 s, not 2.9 s, of
/// which 0.44 s is now meshopt's vertex cache order around the fan's one corner of 50,000
/// triangles.
fn ear_clip(p: &[[f64; 2]], out: &mut Vec<[u32; 3]>) {
    ear_clip_with(p, GRID_FROM, out)
}

/// [`ear_clip`], with a [`Grid`] from `grid_from` blockers on.
fn ear_clip_with(p: &[[f64; 2]], grid_from: usize, out: &mut Vec<[u32; 3]>) {
    let n = p.len();
    let blockers: Vec<usize> = (0..n)
        .filter(|&i| cross(p[(i + n - 1) % n], p[i], p[(i + 1) % n]) <= 0.0)
        .collect();
    // Many blockers (a huge face, or a circle whose rounded corners are half of them flat)
    // would make every ear test a pass over all of them: bucket them, so that a test looks
    // only near its triangle.
    let grid = (blockers.len() >= grid_from).then(|| Grid::new(p, &blockers));
    let mut in_ring = vec![true; n];
    let mut next: Vec<usize> = (0..n).map(|i| (i + 1) % n).collect();
    let mut prev: Vec<usize> = (0..n).map(|i| (i + n - 1) % n).collect();
    // Where the search for an ear starts: the first vertex still in the ring.
    let mut head = 0;
    let mut m = n;
    // Ear tests left before the rest is cut as a fan (see [`TEST_BUDGET`]).
    let mut budget = TEST_BUDGET.0 * n + TEST_BUDGET.1;
    while m > 3 {
        if budget == 0 {
            let mut i = next[head];
            while next[i] != head {
                out.push([head as u32, i as u32, next[i] as u32]);
                i = next[i];
            }
            return;
        }
        let mut best: Option<usize> = None;
        let mut ib = head;
        for _ in 0..m {
            let (ia, ic) = (prev[ib], next[ib]);
            let (a, b, c) = (p[ia], p[ib], p[ic]);
            // Reflex or flat: not an ear.
            if cross(a, b, c) > 0.0 {
                budget = budget.saturating_sub(1);
                let blocks = |j: usize| {
                    in_ring[j]
                        && j != ia
                        && j != ib
                        && j != ic
                        && p[j] != a
                        && p[j] != b
                        && p[j] != c
                        && inside(p[j], a, b, c)
                };
                let blocked = match &grid {
                    Some(g) => g.any_in(a, b, c, blocks),
                    None => blockers.iter().any(|&j| blocks(j)),
                };
                if !blocked {
                    best = Some(ib);
                    break;
                }
            }
            ib = next[ib];
        }
        // No ear: the polygon is not simple (or numerically degenerate). Clip the vertex with
        // the largest turn (the last of equals, from the head) so progress is guaranteed and
        // output stays n - 2 triangles.
        let b = best.unwrap_or_else(|| {
            let turn = |i: usize| cross(p[prev[i]], p[i], p[next[i]]);
            let (mut at, mut most) = (head, turn(head));
            let mut i = next[head];
            for _ in 1..m {
                let t = turn(i);
                if t.total_cmp(&most) != std::cmp::Ordering::Less {
                    (at, most) = (i, t);
                }
                i = next[i];
            }
            at
        });
        out.push([prev[b] as u32, b as u32, next[b] as u32]);
        in_ring[b] = false;
        next[prev[b]] = next[b];
        prev[next[b]] = prev[b];
        if b == head {
            head = next[b];
        }
        m -= 1;
    }
    out.push([head as u32, next[head] as u32, next[next[head]] as u32]);
}

/// How many ear tests a face of n corners may take, `.0 * n + .1`, before the rest of its
/// ring is cut as a fan from its first corner. A simple face takes one or two per corner (a
/// 20,000-corner star, rounded circle and comb: 1.0 to 2.0 n); a face that crosses itself
/// finds no ear over and over, and each time tests its whole ring again (5,000 random
/// corners: 390 n, and a cook of 20,000 of them took 8.9 s). Past the budget such a face's
/// triangles could not be right anyway: any n - 2 that use its corners will do.
const TEST_BUDGET: (usize, usize) = (8, 1 << 16);

/// From how many blockers an ear test looks them up in a [`Grid`] rather than going through
/// them all: below it, building the grid costs more than it saves.
const GRID_FROM: usize = 64;

/// A polygon's blockers bucketed in a uniform grid of about one cell per blocker over their
/// bounding box. It only ever narrows down which blockers an ear test sees, never adds or
/// reorders a verdict, so the triangles are those of the plain pass over every blocker.
struct Grid {
    origin: [f64; 2],
    /// Cells per unit along x and y (zero along an axis where all blockers line up).
    scale: [f64; 2],
    dims: [usize; 2],
    /// The blockers of cell `y * dims[0] + x` are `items[start[cell]..start[cell + 1]]`.
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    fn new(p: &[[f64; 2]], blockers: &[usize]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for &j in blockers {
            for k in 0..2 {
                lo[k] = lo[k].min(p[j][k]);
                hi[k] = hi[k].max(p[j][k]);
            }
        }
        let size = [hi[0] - lo[0], hi[1] - lo[1]];
        let cells = blockers.len() as f64;
        // Square cells where the box has area; a line of cells where it has not.
        let dims = if size[0] > 0.0 && size[1] > 0.0 {
            let nx = (cells * size[0] / size[1]).sqrt().clamp(1.0, cells);
            let ny = (cells / nx).clamp(1.0, cells);
            [nx.ceil() as usize, ny.ceil() as usize]
        } else if size[0] > 0.0 {
            [blockers.len(), 1]
        } else if size[1] > 0.0 {
            [1, blockers.len()]
        } else {
            [1, 1]
        };
        let scale = [0, 1].map(|k| {
            if size[k] > 0.0 && size[k].is_finite() {
                dims[k] as f64 / size[k]
            } else {
                0.0
            }
        });
        let mut grid = Grid {
            origin: lo.map(|x| if x.is_finite() { x } else { 0.0 }),
            scale,
            dims,
            start: vec![0; dims[0] * dims[1] + 1],
            items: vec![0; blockers.len()],
        };
        let cell_of = |g: &Grid, j: usize| g.cell(1, p[j][1]) * g.dims[0] + g.cell(0, p[j][0]);
        for &j in blockers {
            let c = cell_of(&grid, j);
            grid.start[c + 1] += 1;
        }
        for c in 1..grid.start.len() {
            grid.start[c] += grid.start[c - 1];
        }
        let mut fill = grid.start.clone();
        for &j in blockers {
            let c = cell_of(&grid, j);
            grid.items[fill[c] as usize] = j as u32;
            fill[c] += 1;
        }
        grid
    }

    /// The cell along axis `k` of coordinate `x`. Monotone in `x`, so a point inside a box
    /// lies in a cell between those of the box's corners.
    fn cell(&self, k: usize, x: f64) -> usize {
        let c = ((x - self.origin[k]) * self.scale[k]).floor();
        // `as` saturates (NaN to 0), and the clamp keeps the box's far edge in the last cell.
        (c.max(0.0) as usize).min(self.dims[k] - 1)
    }

    /// Whether `test` holds for a blocker in a cell that triangle `a b c` touches: row by row,
    /// the cells between the triangle's least and greatest x within the row's band, one more
    /// each side for rounding. A sliver across the polygon (as ear clipping a convex run
    /// makes, fanning from one corner) so visits a few cells a row, not its whole bounding box.
    fn any_in(
        &self,
        a: [f64; 2],
        b: [f64; 2],
        c: [f64; 2],
        mut test: impl FnMut(usize) -> bool,
    ) -> bool {
        let (ylo, yhi) = (a[1].min(b[1]).min(c[1]), a[1].max(b[1]).max(c[1]));
        let (xlo, xhi) = (a[0].min(b[0]).min(c[0]), a[0].max(b[0]).max(c[0]));
        let (r0, r1) = (self.cell(1, ylo), self.cell(1, yhi));
        for row in r0..=r1 {
            let (mut x0, mut x1) = (xlo, xhi);
            if self.scale[1] > 0.0 && r0 != r1 {
                // The band of this row, widened by half a cell each way against rounding.
                let y0 = self.origin[1] + (row as f64 - 0.5) / self.scale[1];
                let y1 = self.origin[1] + (row as f64 + 1.5) / self.scale[1];
                (x0, x1) = (f64::INFINITY, f64::NEG_INFINITY);
                for (p, q) in [(a, b), (b, c), (c, a)] {
                    if let Some((u, v)) = clip_to_band(p, q, y0, y1) {
                        x0 = x0.min(u.min(v));
                        x1 = x1.max(u.max(v));
                    }
                }
                if x0 > x1 {
                    continue;
                }
            }
            let c0 = self.cell(0, x0).saturating_sub(1);
            let c1 = (self.cell(0, x1) + 1).min(self.dims[0] - 1);
            let base = row * self.dims[0];
            let cells = self.start[base + c0] as usize..self.start[base + c1 + 1] as usize;
            if self.items[cells].iter().any(|&j| test(j as usize)) {
                return true;
            }
        }
        false
    }
}

/// The x of the ends of segment `p q` cut to the band `y0 ≤ y ≤ y1`, if it crosses it.
fn clip_to_band(p: [f64; 2], q: [f64; 2], y0: f64, y1: f64) -> Option<(f64, f64)> {
    let dy = q[1] - p[1];
    if dy == 0.0 {
        return (p[1] >= y0 && p[1] <= y1).then_some((p[0], q[0]));
    }
    let (t0, t1) = ((y0 - p[1]) / dy, (y1 - p[1]) / dy);
    let (lo, hi) = (t0.min(t1).max(0.0), t0.max(t1).min(1.0));
    (lo <= hi).then(|| {
        let x = |t: f64| p[0] + (q[0] - p[0]) * t;
        (x(lo), x(hi))
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn area2(p: [[f64; 2]; 3]) -> f64 {
        cross(p[0], p[1], p[2])
    }

    fn polygon_area2(p: &[[f64; 2]]) -> f64 {
        (0..p.len())
            .map(|i| cross([0.0, 0.0], p[i], p[(i + 1) % p.len()]))
            .sum()
    }

    #[test]
    fn concave_quad_is_split_at_the_reflex_vertex() {
        // An arrowhead: vertex 2 is reflex, so the fan diagonal 0-2 would run outside.
        let q = [
            [0.0, 0.0, 0.0],
            [2.0, 1.0, 0.0],
            [0.5, 0.5, 0.0],
            [1.0, 2.0, 0.0],
        ];
        let mut out = Vec::new();
        triangulate(&q, &mut out);
        assert_eq!(out.len(), 2);
        for t in &out {
            assert!(
                t.contains(&2),
                "diagonal must touch the reflex vertex: {out:?}"
            );
            let tri = t.map(|i| [q[i as usize][0] as f64, q[i as usize][1] as f64]);
            assert!(area2(tri) > 0.0, "triangle {t:?} has the wrong winding");
        }
    }

    #[test]
    fn clockwise_polygon_keeps_its_winding() {
        let q = [
            [0.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.5, 0.2, 0.0],
        ];
        let mut out = Vec::new();
        triangulate(&q, &mut out);
        assert_eq!(out.len(), 3);
        for t in &out {
            let tri = t.map(|i| [q[i as usize][0] as f64, q[i as usize][1] as f64]);
            assert!(area2(tri) < 0.0);
        }
    }

    /// Large faces of the shapes that make many blockers: a star (every other corner reflex),
    /// a circle whose corners are rounded to a grid (half of them flat or reflex, and long
    /// slivers fanning from one corner), and a comb (deep notches).
    fn large_faces(n: usize) -> Vec<Vec<[f64; 2]>> {
        let tau = std::f64::consts::TAU;
        let star = (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * tau;
                let r = if i % 2 == 0 { 10.0 } else { 6.0 };
                [r * a.cos(), r * a.sin()]
            })
            .collect();
        let circle = (0..n)
            .map(|i| {
                let a = i as f64 / n as f64 * tau;
                [(a.cos() * 1e4).round() / 1e4, (a.sin() * 1e4).round() / 1e4]
            })
            .collect();
        let teeth = n / 4;
        let mut comb: Vec<[f64; 2]> = (0..teeth)
            .flat_map(|t| {
                let x = t as f64;
                [[x, 0.0], [x, 5.0], [x + 0.5, 5.0], [x + 0.5, 0.5]]
            })
            .collect();
        comb.push([teeth as f64, 0.0]);
        comb.push([teeth as f64, -1.0]);
        comb.push([0.0, -1.0]);
        comb.reverse();
        let area: f64 = polygon_area2(&comb);
        if area < 0.0 {
            comb.reverse();
        }
        vec![star, circle, comb]
    }

    /// A large face that crosses itself everywhere is cut as far as the test budget goes,
    /// then as a fan: still n - 2 triangles of distinct corners, each corner used.
    #[test]
    fn a_large_tangled_face_stops_clipping_at_its_budget() {
        let mut rng = texture::testing::Rng(0x2545_f491_4f6c_dd1d);
        let mut rnd = || (rng.next_u64() % 1_000_000) as f64 / 1e6;
        let n = 20_000;
        let tangle: Vec<[f64; 2]> = (0..n).map(|_| [rnd(), rnd()]).collect();
        let mut out = Vec::new();
        ear_clip(&tangle, &mut out);
        assert_eq!(out.len(), n - 2);
        let mut used = vec![false; n];
        for t in &out {
            assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2], "{t:?}");
            for &i in t {
                used[i as usize] = true;
            }
        }
        assert!(used.iter().all(|&u| u));
    }

    #[test]
    fn large_faces_are_cut_as_without_the_grid_and_cover_their_area() {
        for poly in large_faces(2000) {
            let (mut plain, mut gridded) = (Vec::new(), Vec::new());
            ear_clip_with(&poly, usize::MAX, &mut plain);
            ear_clip(&poly, &mut gridded);
            assert_eq!(plain, gridded);
            assert_eq!(gridded.len(), poly.len() - 2);
            let total = polygon_area2(&poly).abs();
            let sum: f64 = gridded
                .iter()
                .map(|t| area2(t.map(|i| poly[i as usize])).abs())
                .sum();
            assert!((sum - total).abs() <= 1e-6 * total, "{sum} vs {total}");
        }
    }

    /// Star-shaped polygons around the origin are simple, so an exact triangulation covers
    /// exactly their area with positively oriented triangles.
    fn star() -> impl Strategy<Value = Vec<[f64; 2]>> {
        prop::collection::vec((0.1f64..10.0, 0.0f64..1.0), 3..24).prop_map(|v| {
            let n = v.len();
            v.iter()
                .enumerate()
                .map(|(i, &(r, jitter))| {
                    let a = (i as f64 + 0.8 * jitter) / n as f64 * std::f64::consts::TAU;
                    [r * a.cos(), r * a.sin()]
                })
                .collect()
        })
    }

    proptest! {
        #[test]
        fn star_polygons_are_covered_exactly(poly in star(), z in -5.0f32..5.0, swap in any::<bool>()) {
            let pts: Vec<[f32; 3]> = poly
                .iter()
                .map(|p| if swap { [p[0] as f32, z, p[1] as f32] } else { [p[0] as f32, p[1] as f32, z] })
                .collect();
            let mut out = Vec::new();
            triangulate(&pts, &mut out);
            prop_assert_eq!(out.len(), pts.len() - 2);
            let p2: Vec<[f64; 2]> = pts.iter().map(|p| if swap { [p[2] as f64, p[0] as f64] } else { [p[0] as f64, p[1] as f64] }).collect();
            let total = polygon_area2(&p2);
            let mut sum = 0.0;
            for t in &out {
                let tri = t.map(|i| p2[i as usize]);
                let a = area2(tri);
                prop_assert!(a * total.signum() >= -1e-6 * total.abs(), "triangle {:?} flipped", t);
                sum += a.abs();
            }
            prop_assert!((sum - total.abs()).abs() <= 1e-4 * total.abs().max(1e-9), "area {} vs {}", sum, total);
        }

        /// The grid only narrows down which blockers a test sees: with it and without, any
        /// polygon (simple or not, on a lattice so that points coincide and line up) gives the
        /// same triangles.
        #[test]
        fn the_grid_changes_no_triangle(
            pts in prop::collection::vec((0i32..12, 0i32..12), 3..80),
            star in star(),
        ) {
            let lattice: Vec<[f64; 2]> = pts.iter().map(|&(x, y)| [x as f64 * 0.25, y as f64]).collect();
            for poly in [&lattice, &star] {
                let (mut plain, mut gridded) = (Vec::new(), Vec::new());
                ear_clip_with(poly, usize::MAX, &mut plain);
                ear_clip_with(poly, 0, &mut gridded);
                prop_assert_eq!(plain, gridded);
            }
        }

        #[test]
        fn arbitrary_points_never_fail(pts in prop::collection::vec(prop::array::uniform3(-1e3f32..1e3), 0..16)) {
            let mut out = Vec::new();
            triangulate(&pts, &mut out);
            prop_assert_eq!(out.len(), pts.len().saturating_sub(2));
            for t in &out {
                prop_assert!(t.iter().all(|&i| (i as usize) < pts.len()));
                prop_assert!(t[0] != t[1] && t[1] != t[2] && t[0] != t[2]);
            }
        }
    }
}
