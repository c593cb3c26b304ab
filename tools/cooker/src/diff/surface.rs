//! How far one set of triangles lies from another's surface.
//!
//! Triangles left unmatched by [`super::triangles::compare`] are often the same surface cut
//! another way: an OBJ quad split along its other diagonal by another tool's triangulator. The
//! question is then whether every point of one lies on the other: measured at each triangle's
//! corners, edge midpoints and centroid, against the nearest point of the other mesh's
//! triangles (all of them: a point on the border of a retriangulated patch lies on a matched
//! neighbour). The samples make it a lower bound of the Hausdorff distance, exact where the
//! pieces are flat, which is what a retriangulated planar polygon is.

use glam::DVec3;

use super::triangles::Triangle;

/// A bounding-volume hierarchy over triangles, for nearest-point queries within a radius.
pub struct Bvh<'a> {
    triangles: &'a [Triangle],
    order: Vec<u32>,
    nodes: Vec<Node>,
}

struct Node {
    lo: DVec3,
    hi: DVec3,
    /// Leaf: `order[start..start + count]`; inner (count 0): children at `start`, `start + 1`.
    start: u32,
    count: u32,
}

const LEAF: usize = 4;

impl<'a> Bvh<'a> {
    pub fn new(triangles: &'a [Triangle]) -> Self {
        let mut bvh = Bvh {
            triangles,
            order: (0..triangles.len() as u32).collect(),
            nodes: Vec::with_capacity(2 * triangles.len() / LEAF + 1),
        };
        let centre: Vec<DVec3> = triangles.iter().map(Triangle::centroid).collect();
        bvh.nodes.push(bvh.bounds(0, triangles.len()));
        // Split nodes breadth-first, each at the median centre along its longest axis.
        let mut next = 0;
        while next < bvh.nodes.len() {
            let (start, count) = (
                bvh.nodes[next].start as usize,
                bvh.nodes[next].count as usize,
            );
            if count > LEAF {
                let axis = (bvh.nodes[next].hi - bvh.nodes[next].lo).max_position();
                let half = count / 2;
                bvh.order[start..start + count].select_nth_unstable_by(half, |&x, &y| {
                    centre[x as usize][axis].total_cmp(&centre[y as usize][axis])
                });
                let first = bvh.nodes.len() as u32;
                bvh.nodes.push(bvh.bounds(start, half));
                bvh.nodes.push(bvh.bounds(start + half, count - half));
                bvh.nodes[next].start = first;
                bvh.nodes[next].count = 0;
            }
            next += 1;
        }
        bvh
    }

    fn bounds(&self, start: usize, count: usize) -> Node {
        let (mut lo, mut hi) = (DVec3::INFINITY, DVec3::NEG_INFINITY);
        for &t in &self.order[start..start + count] {
            for c in self.triangles[t as usize].points() {
                lo = lo.min(c);
                hi = hi.max(c);
            }
        }
        Node {
            lo,
            hi,
            start: start as u32,
            count: count as u32,
        }
    }

    /// The nearest triangle to `p` within `radius` and its distance.
    pub fn nearest(&self, p: DVec3, radius: f64) -> Option<(u32, f64)> {
        self.nearest_where(p, radius, |_| true)
    }

    /// The nearest triangle to `p` within `radius` of those `keep` accepts.
    pub fn nearest_where(
        &self,
        p: DVec3,
        radius: f64,
        keep: impl Fn(&Triangle) -> bool,
    ) -> Option<(u32, f64)> {
        if self.triangles.is_empty() {
            return None;
        }
        let mut best: Option<(u32, f64)> = None;
        let mut limit = radius;
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = &self.nodes[n];
            let outside = (node.lo - p).max(p - node.hi).max(DVec3::ZERO);
            if outside.length() > limit {
                continue;
            }
            if node.count == 0 {
                stack.push(node.start as usize);
                stack.push(node.start as usize + 1);
                continue;
            }
            let (s, c) = (node.start as usize, node.count as usize);
            for &t in &self.order[s..s + c] {
                let triangle = &self.triangles[t as usize];
                if !keep(triangle) {
                    continue;
                }
                let d = (closest_point(p, triangle.points()) - p).length();
                if d <= limit && best.is_none_or(|(_, bd)| d < bd) {
                    best = Some((t, d));
                    limit = d;
                }
            }
        }
        best
    }
}

/// The point of triangle `[a, b, c]` nearest to `p` (by the triangle's Voronoi regions).
fn closest_point(p: DVec3, [a, b, c]: [DVec3; 3]) -> DVec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() < f64::MIN_POSITIVE {
        // Degenerate (zero-area) triangle: the nearest of its three edges.
        return [(a, b), (b, c), (c, a)]
            .into_iter()
            .map(|(s, e)| {
                let d = e - s;
                let t = if d.length_squared() > 0.0 {
                    ((p - s).dot(d) / d.length_squared()).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                s + d * t
            })
            .min_by(|x, y| (*x - p).length().total_cmp(&(*y - p).length()))
            .expect("three edges");
    }
    a + ab * (vb / denom) + ac * (vc / denom)
}

/// What measuring `from` against the surface of `to` found.
#[derive(Debug, Default, PartialEq)]
pub struct Cover {
    /// Triangles of `from` with a sample farther than the tolerance from `to`'s surface, or
    /// facing against it.
    pub off_surface: usize,
    /// The largest sample distance among the triangles that lie on the surface.
    pub max_gap: f64,
    /// Triangles of `from` whose centroid's nearest triangle of `to` has another material there.
    pub material_changes: usize,
    /// Triangles of `from` whose texture coordinates at the centroid differ from those of
    /// `to` at the same point of the surface by more than the tolerance (per axis), and the
    /// largest difference. A vertex slid along its plane in a reordered export keeps the
    /// surface but stretches the texture over it.
    pub uv_changes: usize,
    pub max_uv_delta: f64,
}

/// The texture coordinates of triangle `t` at `q`, a point on it, by barycentric weights;
/// `None` for a triangle with no area.
fn uv_at(t: &Triangle, q: DVec3) -> Option<[f64; 2]> {
    let [a, b, c] = t.points();
    let n = (b - a).cross(c - a);
    let area = n.length_squared();
    if area <= 0.0 {
        return None;
    }
    let wb = (q - a).cross(c - a).dot(n) / area;
    let wc = (b - a).cross(q - a).dot(n) / area;
    let wa = 1.0 - wb - wc;
    let uv = |k: usize| {
        wa * t.shading[0].uv[k] as f64
            + wb * t.shading[1].uv[k] as f64
            + wc * t.shading[2].uv[k] as f64
    };
    Some([uv(0), uv(1)])
}

/// Measures the triangles `which` of `from` against the surface of all of `to`.
pub fn cover(
    from: &[Triangle],
    which: &[usize],
    to: &Bvh,
    tolerance: f64,
    uv_tolerance: f64,
) -> Cover {
    let mut out = Cover::default();
    for &i in which {
        let t = &from[i];
        let [a, b, c] = t.points();
        let centroid = t.centroid();
        let samples = [a, b, c, (a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0];
        let mut gap = 0.0f64;
        let mut on = true;
        for p in samples {
            match to.nearest(p, tolerance) {
                Some((_, d)) => gap = gap.max(d),
                None => {
                    on = false;
                    break;
                }
            }
        }
        // A triangle lying on the other surface but facing the other way is another face (a
        // flipped one is culled from the side it was seen from). Judged at the centroid, where
        // the nearest triangle is the one under it, not a neighbour across a crease; among
        // coincident faces (a floor and a reversed patch on it) the one facing the same way.
        let n = t.normal();
        let inside = on
            .then(|| to.nearest_where(centroid, tolerance, |u| u.normal().dot(n) >= 0.0))
            .flatten();
        match inside {
            Some((j, d)) => {
                out.max_gap = out.max_gap.max(gap.max(d));
                // The material at the centroid: the corner material the nearest triangle
                // shares most, its first corner's on a tie.
                let material = |m: [u32; 3]| if m[1] == m[2] { m[1] } else { m[0] };
                let other = &to.triangles[j as usize];
                if material(t.materials) != material(other.materials) {
                    out.material_changes += 1;
                }
                let [ta, tb, tc] = t.shading.map(|s| s.uv.map(f64::from));
                let here = [0, 1].map(|k| (ta[k] + tb[k] + tc[k]) / 3.0);
                if let Some(there) = uv_at(other, closest_point(centroid, other.points())) {
                    let d = (here[0] - there[0]).abs().max((here[1] - there[1]).abs());
                    if d > uv_tolerance {
                        out.uv_changes += 1;
                    }
                    out.max_uv_delta = out.max_uv_delta.max(d);
                }
            }
            None => out.off_surface += 1,
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::triangles::tri;
    use super::*;

    #[test]
    fn closest_points_in_every_region() {
        let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let near = |p: [f64; 3], want: [f64; 3]| {
            let got = closest_point(DVec3::from(p), t);
            assert!(got.distance(DVec3::from(want)) < 1e-12, "{p:?}: {got}");
        };
        near([0.2, 0.2, 5.0], [0.2, 0.2, 0.0]);
        near([-1.0, -1.0, 0.0], [0.0, 0.0, 0.0]);
        near([3.0, -0.5, 0.0], [1.0, 0.0, 0.0]);
        near([0.5, -2.0, 1.0], [0.5, 0.0, 0.0]);
        near([-2.0, 0.5, 0.0], [0.0, 0.5, 0.0]);
        near([1.0, 1.0, 0.0], [0.5, 0.5, 0.0]);
        near([-0.5, 3.0, 0.0], [0.0, 1.0, 0.0]);
        let line = [DVec3::ZERO, DVec3::X, DVec3::X * 2.0];
        let got = closest_point(DVec3::new(1.5, 1.0, 0.0), line);
        assert!(got.distance(DVec3::new(1.5, 0.0, 0.0)) < 1e-12, "{got}");
    }

    #[test]
    fn nearest_matches_brute_force() {
        // A bumpy 30 x 30 grid, queried at scattered points.
        let mut ts = Vec::new();
        let h = |x: usize, y: usize| ((x * 7 + y * 13) % 5) as f32 * 0.1;
        for y in 0..30 {
            for x in 0..30 {
                let p =
                    |dx: usize, dy: usize| [(x + dx) as f32, h(x + dx, y + dy), (y + dy) as f32];
                ts.push(tri([p(0, 0), p(1, 0), p(1, 1)], 0));
                ts.push(tri([p(0, 0), p(1, 1), p(0, 1)], 0));
            }
        }
        let bvh = Bvh::new(&ts);
        for k in 0..200 {
            let p = DVec3::new(
                (k * 37 % 310) as f64 / 10.0,
                (k % 9) as f64 / 4.0 - 0.5,
                (k * 53 % 290) as f64 / 10.0,
            );
            let brute = ts
                .iter()
                .map(|t| (closest_point(p, t.points()) - p).length())
                .fold(f64::INFINITY, f64::min);
            let (_, d) = bvh.nearest(p, 10.0).unwrap();
            assert!((d - brute).abs() < 1e-12, "{p}: {d} vs {brute}");
            assert_eq!(bvh.nearest(p, brute * 0.99 - 1e-9), None);
        }
    }

    #[test]
    fn a_quad_split_the_other_way_lies_on_the_surface() {
        let (p, q, r, s) = ([0.0; 3], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [0.0, 1.0, 0.0]);
        let a = [tri([p, q, r], 1), tri([p, r, s], 1)];
        let b = [tri([p, q, s], 1), tri([q, r, s], 1)];
        let bvh = Bvh::new(&b);
        let c = cover(&a, &[0, 1], &bvh, 1e-6, 1e-6);
        assert_eq!((c.off_surface, c.material_changes), (0, 0));
        assert!(c.max_gap < 1e-12, "{c:?}");
        // Bent along its diagonal, the other split is another surface.
        let bent = [
            tri([p, q, [0.0, 1.0, 0.5]], 1),
            tri([q, r, [0.0, 1.0, 0.5]], 1),
        ];
        let c = cover(&a, &[0, 1], &Bvh::new(&bent), 0.1, 1e-6);
        assert_eq!(c.off_surface, 2);
        // Same surface, another material.
        let recoloured = [tri([p, q, s], 2), tri([q, r, s], 2)];
        let c = cover(&a, &[0, 1], &Bvh::new(&recoloured), 1e-6, 1e-6);
        assert_eq!((c.off_surface, c.material_changes), (0, 2));
        // Same surface, facing the other way.
        let flipped = [tri([p, s, q], 1), tri([q, s, r], 1)];
        let c = cover(&a, &[0, 1], &Bvh::new(&flipped), 1e-6, 1e-6);
        assert_eq!(c.off_surface, 2);
    }

    /// Texture coordinates that follow the surface (here u, v = x, y) agree however it is
    /// cut; a vertex slid along the plane with its coordinates kept stretches the texture.
    #[test]
    fn a_vertex_slid_in_its_plane_with_its_uv_kept_is_a_uv_change() {
        let planar = |t: Triangle| {
            let mut t = t;
            for (s, c) in t.shading.iter_mut().zip(t.corners) {
                s.uv = [c[0], c[1]];
            }
            t
        };
        let (p, q, r, s) = ([0.0; 3], [2.0, 0.0, 0.0], [2.0, 1.0, 0.0], [0.0, 1.0, 0.0]);
        let a = [planar(tri([p, q, r], 1)), planar(tri([p, r, s], 1))];
        let b = [planar(tri([p, q, s], 1)), planar(tri([q, r, s], 1))];
        let c = cover(&a, &[0, 1], &Bvh::new(&b), 1e-6, 1e-6);
        assert_eq!(c.uv_changes, 0, "{c:?}");
        assert!(c.max_uv_delta < 1e-9, "{c:?}");
        // r slid to (1.5, 1): on the same plane, its uv still (2, 1).
        let slid = [1.5, 1.0, 0.0];
        let mut moved = [tri([p, q, slid], 1), tri([p, slid, s], 1)];
        for t in &mut moved {
            for (sh, c) in t.shading.iter_mut().zip(t.corners) {
                sh.uv = if c == slid { [2.0, 1.0] } else { [c[0], c[1]] };
            }
        }
        let c = cover(&moved, &[0, 1], &Bvh::new(&a), 1e-6, 1e-3);
        assert_eq!((c.off_surface, c.uv_changes), (0, 2), "{c:?}");
        assert!(c.max_uv_delta > 0.1, "{c:?}");
    }
}
