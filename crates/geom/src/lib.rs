//! Geometry the cook and the renderer share: a bounding-volume hierarchy over triangles that
//! rays are traced through (the renderer's ray-traced reference; the cook's test of which
//! side of a window is enclosed), and the ray-triangle test it uses.
//!
//! The hierarchy holds no triangles: the caller keeps them and hands over a corner lookup,
//! so each keeps its own triangle type (the reference's carries normals, texture coordinates
//! and colours) without a copy.

use glam::{Vec2, Vec3};

/// A bounding-volume hierarchy over triangles: median splits on the widest axis of the
/// centroids, leaves of up to four. Tens of thousands of triangles build in milliseconds.
pub struct Bvh {
    nodes: Vec<Node>,
    order: Vec<u32>,
}

#[derive(Clone, Copy)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: first index into `order`; inner: the second child (the first follows the node).
    start: u32,
    /// Leaf: triangle count; inner: 0.
    count: u32,
}

impl Bvh {
    /// The hierarchy over triangles `0..n`, whose corners `corners(i)` gives.
    pub fn build(n: usize, corners: impl Fn(u32) -> [Vec3; 3]) -> Self {
        let mut order: Vec<u32> = (0..n as u32).collect();
        let mut nodes = Vec::with_capacity(n * 2 / 3 + 1);
        if n > 0 {
            Self::split(&corners, &mut order, 0, n, &mut nodes);
        }
        Self { nodes, order }
    }

    fn split(
        corners: &impl Fn(u32) -> [Vec3; 3],
        order: &mut [u32],
        start: usize,
        end: usize,
        nodes: &mut Vec<Node>,
    ) -> usize {
        let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let (mut clo, mut chi) = (lo, hi);
        for &i in &order[start..end] {
            let p = corners(i);
            for q in p {
                lo = lo.min(q);
                hi = hi.max(q);
            }
            let c = (p[0] + p[1] + p[2]) / 3.0;
            clo = clo.min(c);
            chi = chi.max(c);
        }
        let index = nodes.len();
        nodes.push(Node {
            lo,
            hi,
            start: start as u32,
            count: (end - start) as u32,
        });
        let extent = chi - clo;
        if end - start <= 4 || extent.max_element() <= 0.0 {
            return index;
        }
        let axis = if extent.x >= extent.y && extent.x >= extent.z {
            0
        } else if extent.y >= extent.z {
            1
        } else {
            2
        };
        let mid = (start + end) / 2;
        let key = |i: &u32| {
            let p = corners(*i);
            (p[0] + p[1] + p[2])[axis]
        };
        order[start..end].select_nth_unstable_by(mid - start, |a, b| key(a).total_cmp(&key(b)));
        Self::split(corners, order, start, mid, nodes);
        let second = Self::split(corners, order, mid, end, nodes);
        nodes[index].start = second as u32;
        nodes[index].count = 0;
        index
    }

    /// Calls `f(triangle, t, barycentrics)` for every hit along the ray closer than the
    /// current limit (first `max_t`, in no particular order); `f` returns the new limit (the
    /// hit's distance to keep only closer ones, a negative one to stop). True when stopped.
    pub fn visit(
        &self,
        o: Vec3,
        d: Vec3,
        max_t: f32,
        corners: impl Fn(u32) -> [Vec3; 3],
        f: &mut impl FnMut(u32, f32, Vec2) -> f32,
    ) -> bool {
        if self.nodes.is_empty() {
            return false;
        }
        let mut limit = max_t;
        let inv = d.recip();
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let n = self.nodes[i];
            let t0 = (n.lo - o) * inv;
            let t1 = (n.hi - o) * inv;
            let near = t0.min(t1).max_element();
            let far = t0.max(t1).min_element();
            if near > far.min(limit) || far < 0.0 {
                continue;
            }
            if n.count > 0 {
                for &t in &self.order[n.start as usize..(n.start + n.count) as usize] {
                    if let Some((dist, b)) = intersect(corners(t), o, d)
                        && dist <= limit
                    {
                        limit = f(t, dist, b);
                        if limit < 0.0 {
                            return true;
                        }
                    }
                }
            } else {
                stack.push(n.start as usize);
                stack.push(i + 1);
            }
        }
        false
    }
}

/// Möller–Trumbore, either side: the distance and the barycentrics of corners 1 and 2.
pub fn intersect(p: [Vec3; 3], o: Vec3, d: Vec3) -> Option<(f32, Vec2)> {
    let (e1, e2) = (p[1] - p[0], p[2] - p[0]);
    let q = d.cross(e2);
    let det = e1.dot(q);
    if det.abs() < 1e-20 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - p[0];
    let u = s.dot(q) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let r = s.cross(e1);
    let v = d.dot(r) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let dist = e2.dot(r) * inv;
    (dist > 1e-5).then_some((dist, Vec2::new(u, v)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every hit the hierarchy reports is one a test of every triangle finds, and the nearest
    /// is the same, on a cloud of random triangles and rays.
    #[test]
    fn the_hierarchy_finds_what_testing_every_triangle_finds() {
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut v = || Vec3::new(next(), next(), next());
        let tris: Vec<[Vec3; 3]> = (0..500)
            .map(|_| {
                let c = v() * 10.0;
                [c + v(), c + v(), c + v()]
            })
            .collect();
        let bvh = Bvh::build(tris.len(), |i| tris[i as usize]);
        // Half the rays aimed at a triangle's centroid, so that most of them hit something.
        let rays: Vec<(Vec3, Vec3)> = (0..300)
            .map(|k| {
                let o = v() * 12.0;
                let d = if k % 2 == 0 {
                    let t = tris[k % tris.len()];
                    (t[0] + t[1] + t[2]) / 3.0 - o
                } else {
                    v()
                };
                (o, d.normalize())
            })
            .collect();
        let mut hits = 0;
        for (o, d) in rays {
            let brute = (0..tris.len() as u32)
                .filter_map(|i| intersect(tris[i as usize], o, d).map(|h| (i, h.0)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let mut best: Option<(u32, f32)> = None;
            bvh.visit(o, d, f32::INFINITY, |i| tris[i as usize], &mut |i, t, _| {
                best = Some((i, t));
                t
            });
            assert_eq!(best, brute);
            hits += best.is_some() as usize;
            // Stopping at the first hit reports whether there is one.
            let stopped = bvh.visit(o, d, f32::INFINITY, |i| tris[i as usize], &mut |_, _, _| {
                -1.0
            });
            assert_eq!(stopped, brute.is_some());
        }
        assert!(hits > 150, "{hits} rays hit: the test says little");
    }
}
