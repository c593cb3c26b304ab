//! Order-free comparison of two meshes' triangles.
//!
//! Two exports of the same geometry rarely list it in the same order: another tool (gltfpack,
//! a meshopt codec, a different cooker version) reorders vertices, reorders triangles and turns
//! a triangle's corners. Compared index by index such meshes look entirely moved; compared as
//! sets of triangles they are equal. A triangle matches another with the same winding whose
//! corners each lie within the position tolerance; a mirrored (flipped) triangle does not
//! match, since it faces the other way.

use std::collections::HashMap;

use glam::DVec3;

/// One triangle: corner positions and, per corner, a material key comparable across packs and
/// what shades it.
#[derive(Clone, Copy)]
pub struct Triangle {
    pub corners: [[f32; 3]; 3],
    pub materials: [u32; 3],
    pub shading: [Shading; 3],
}

/// A corner's normal, tangent (handedness in w) and texture coordinates; zero where the mesh's
/// layout has none.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Shading {
    pub normal: [f32; 3],
    pub tangent: [f32; 4],
    pub uv: [f32; 2],
}

/// How far two corners' shading may differ before it counts as a change.
#[derive(Clone, Copy, Debug, Default)]
pub struct ShadingTolerance {
    /// Radians a normal or tangent may turn.
    pub angle: f64,
    /// Per-axis texture-coordinate change.
    pub uv: f64,
}

/// The shading changes among matched corners (or vertices in the same order).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShadingChanges {
    /// Corners whose normal turned past the tolerance, and the largest turn (radians).
    pub normals: usize,
    pub max_normal_angle: f64,
    /// Corners whose tangent turned past the tolerance or flipped handedness, and the largest
    /// turn (radians; a flip counts as π).
    pub tangents: usize,
    pub max_tangent_angle: f64,
    /// Corners whose texture coordinates moved past the tolerance, and the largest move.
    pub uvs: usize,
    pub max_uv_delta: f64,
}

/// The angle between two directions, by the chord (accurate for tiny angles, where acos is
/// not). A zero vector is a vertex without that direction (the sky's normals, the tangents of
/// a material without a normal map): the same as another zero vector, and as +Z, which is what
/// an octahedral encoding, having no zero, stores for it (a quantized pack's sky normals were
/// "turned by 180 degrees" against the same cook unquantized).
fn angle(a: [f32; 3], b: [f32; 3]) -> f64 {
    let (a, b) = (
        DVec3::from(a.map(f64::from)).normalize_or_zero(),
        DVec3::from(b.map(f64::from)).normalize_or_zero(),
    );
    if a == DVec3::ZERO || b == DVec3::ZERO {
        let other = a + b;
        return if other == DVec3::ZERO || other.z > 1.0 - 1e-9 {
            0.0
        } else {
            std::f64::consts::PI
        };
    }
    2.0 * ((a - b).length() / 2.0).min(1.0).asin()
}

impl ShadingChanges {
    /// Counts one corner pair.
    pub fn add(&mut self, a: &Shading, b: &Shading, tolerance: ShadingTolerance) {
        let n = angle(a.normal, b.normal);
        if n > tolerance.angle {
            self.normals += 1;
        }
        self.max_normal_angle = self.max_normal_angle.max(n);
        let [tx, ty, tz, tw] = a.tangent;
        let [ux, uy, uz, uw] = b.tangent;
        // A vertex without a tangent has no handedness either.
        let absent = [tx, ty, tz] == [0.0; 3] || [ux, uy, uz] == [0.0; 3];
        let t = if tw != uw && !absent {
            std::f64::consts::PI
        } else {
            angle([tx, ty, tz], [ux, uy, uz])
        };
        if t > tolerance.angle {
            self.tangents += 1;
        }
        self.max_tangent_angle = self.max_tangent_angle.max(t);
        let d = (0..2)
            .map(|k| (a.uv[k] as f64 - b.uv[k] as f64).abs())
            .fold(0.0, f64::max);
        if d > tolerance.uv {
            self.uvs += 1;
        }
        self.max_uv_delta = self.max_uv_delta.max(d);
    }

    /// The problems, one line per attribute that changed, for mesh `name`; `unit` is what was
    /// counted ("vertices" in the same order, "corners" of triangles matched in any).
    pub fn problems(&self, name: &str, unit: &str) -> Vec<String> {
        let mut out = Vec::new();
        // A turn too small for three decimals (a re-quantized normal) read "by up to 0.000".
        let deg = |r: f64| {
            let d = r.to_degrees();
            if d >= 1e-3 || d == 0.0 {
                format!("{d:.3}")
            } else {
                format!("{d:.1e}")
            }
        };
        if self.normals > 0 {
            out.push(format!(
                "mesh {name:?}: {} {unit}' normals turned, by up to {} degrees",
                self.normals,
                deg(self.max_normal_angle)
            ));
        }
        if self.tangents > 0 {
            out.push(format!(
                "mesh {name:?}: {} {unit}' tangents turned or flipped, by up to {} degrees",
                self.tangents,
                deg(self.max_tangent_angle)
            ));
        }
        if self.uvs > 0 {
            out.push(format!(
                "mesh {name:?}: {} {unit}' texture coordinates moved, by up to {:.3e}",
                self.uvs, self.max_uv_delta
            ));
        }
        out
    }
}

impl Triangle {
    /// The corners in double precision, where distances and normals are measured.
    pub fn points(&self) -> [DVec3; 3] {
        self.corners.map(|c| DVec3::from(c.map(f64::from)))
    }

    /// Unnormalized: its direction says which way the triangle faces (zero when degenerate).
    pub fn normal(&self) -> DVec3 {
        let [a, b, c] = self.points();
        (b - a).cross(c - a)
    }

    pub fn centroid(&self) -> DVec3 {
        self.points().iter().sum::<DVec3>() / 3.0
    }
}

/// What matching `a`'s triangles against `b`'s found.
#[derive(Debug, PartialEq)]
pub struct Matching {
    /// Triangles of `a` with no counterpart in `b`, and the reverse, by index.
    pub unmatched: [Vec<usize>; 2],
    /// Largest per-axis corner move among matched triangles.
    pub max_delta: f64,
    /// Matched corners whose material differs.
    pub material_changes: usize,
    /// Matched corners whose shading differs.
    pub shading: ShadingChanges,
}

/// `t` turned (winding kept) so that its smallest corner comes first; ties between repeated
/// corners are broken by the whole triangle, so equal triangles always turn the same way.
fn canonical(t: &Triangle) -> Triangle {
    let turn = |r: usize| Triangle {
        corners: [0, 1, 2].map(|k| t.corners[(k + r) % 3]),
        materials: [0, 1, 2].map(|k| t.materials[(k + r) % 3]),
        shading: [0, 1, 2].map(|k| t.shading[(k + r) % 3]),
    };
    let key = |t: &Triangle| t.corners.map(|c| c.map(unsigned_zero));
    (0..3)
        .map(turn)
        .min_by(|x, y| {
            key(x)
                .iter()
                .flatten()
                .zip(key(y).iter().flatten())
                .map(|(p, q)| p.total_cmp(q))
                .find(|o| o.is_ne())
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .expect("three turns")
}

/// -0.0 and 0.0 are the same position.
fn unsigned_zero(x: f32) -> f32 {
    x + 0.0
}

fn bits(t: &Triangle) -> [u32; 9] {
    let mut k = [0u32; 9];
    for (i, c) in t.corners.iter().flatten().enumerate() {
        k[i] = unsigned_zero(*c).to_bits();
    }
    k
}

/// Largest per-axis difference of two points or vectors.
pub(super) fn corner_delta(p: &[f32; 3], q: &[f32; 3]) -> f64 {
    (0..3)
        .map(|k| (p[k] as f64 - q[k] as f64).abs())
        .fold(0.0, f64::max)
}

/// The smallest largest-corner move over the three turns of `b` that keep its winding, and the
/// turn that gives it.
fn best_turn(a: &Triangle, b: &Triangle) -> (f64, usize) {
    (0..3)
        .map(|r| {
            let d = (0..3)
                .map(|k| corner_delta(&a.corners[k], &b.corners[(k + r) % 3]))
                .fold(0.0, f64::max);
            (d, r)
        })
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .expect("three turns")
}

/// Matches `a`'s triangles to `b`'s, each used once: first exactly (bit-equal corners after
/// turning), then, for what is left and when `tolerance > 0`, the nearest triangle whose corners
/// each lie within `tolerance` per axis.
pub fn compare(
    a: &[Triangle],
    b: &[Triangle],
    tolerance: f64,
    shading_tolerance: ShadingTolerance,
) -> Matching {
    let a: Vec<Triangle> = a.iter().map(canonical).collect();
    let b: Vec<Triangle> = b.iter().map(canonical).collect();
    let mut material_changes = 0;
    let mut shading = ShadingChanges::default();
    let mut count_changes = |x: &Triangle, y: &Triangle, turn: usize| {
        for k in 0..3 {
            shading.add(&x.shading[k], &y.shading[(k + turn) % 3], shading_tolerance);
        }
        (0..3)
            .filter(|&k| x.materials[k] != y.materials[(k + turn) % 3])
            .count()
    };

    let mut exact: HashMap<[u32; 9], Vec<usize>> = HashMap::with_capacity(b.len());
    for (j, t) in b.iter().enumerate().rev() {
        exact.entry(bits(t)).or_default().push(j);
    }
    let mut used_b = vec![false; b.len()];
    let mut unmatched_a = Vec::new();
    for (i, t) in a.iter().enumerate() {
        match exact.get_mut(&bits(t)).and_then(Vec::pop) {
            Some(j) => {
                used_b[j] = true;
                material_changes += count_changes(t, &b[j], 0);
            }
            None => unmatched_a.push(i),
        }
    }

    let mut max_delta = 0.0f64;
    // Cells finer than the coordinates' own precision only spread equal points apart, and
    // their numbers would overflow.
    let magnitude = a
        .iter()
        .chain(&b)
        .flat_map(|t| t.corners.iter().flatten())
        .fold(0.0f64, |m, &x| m.max((x as f64).abs()));
    let finest = magnitude * 2f64.powi(-40);
    // Within growing radii up to the tolerance: most triangles moved by far less (a
    // quantization step) and are matched while the grid's cells are small and hold a few
    // candidates each; a cell the tolerance wide may hold thousands, so each triangle looks
    // at no more than `CANDIDATES` (what is left unmatched is measured against the surface).
    const CANDIDATES: usize = 512;
    for radius in [
        tolerance / 512.0,
        tolerance / 64.0,
        tolerance / 8.0,
        tolerance,
    ] {
        if tolerance <= 0.0 || unmatched_a.is_empty() {
            break;
        }
        let size = radius.max(finest).max(f64::MIN_POSITIVE);
        // Matched corners lie within `radius` per axis, so their centroids do too: a grid of
        // cells at least that size finds every candidate in the 27 cells around a centroid.
        let cell = |p: DVec3| p.to_array().map(|x| (x / size).floor() as i64);
        let mut grid: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
        for (j, t) in b.iter().enumerate() {
            if !used_b[j] {
                grid.entry(cell(t.centroid())).or_default().push(j);
            }
        }
        let left = std::mem::take(&mut unmatched_a);
        for i in left {
            let t = &a[i];
            let (c, n) = (cell(t.centroid()), t.normal());
            let mut best: Option<(f64, usize, usize)> = None;
            let mut seen = 0;
            'cells: for dx in -1..=1i64 {
                for dy in -1..=1i64 {
                    for dz in -1..=1i64 {
                        let key = [
                            c[0].saturating_add(dx),
                            c[1].saturating_add(dy),
                            c[2].saturating_add(dz),
                        ];
                        let Some(js) = grid.get(&key) else {
                            continue;
                        };
                        for &j in js.iter().filter(|&&j| !used_b[j]) {
                            if seen == CANDIDATES {
                                break 'cells;
                            }
                            seen += 1;
                            let (d, turn) = best_turn(t, &b[j]);
                            // A flipped triangle faces the other way: another face, however
                            // close its corners (closer than its edges are long).
                            if d <= radius
                                && best.is_none_or(|(bd, _, _)| d < bd)
                                && b[j].normal().dot(n) >= 0.0
                            {
                                best = Some((d, j, turn));
                            }
                        }
                    }
                }
            }
            match best {
                Some((d, j, turn)) => {
                    used_b[j] = true;
                    max_delta = max_delta.max(d);
                    material_changes += count_changes(t, &b[j], turn);
                }
                None => unmatched_a.push(i),
            }
        }
    }
    let unmatched_b: Vec<usize> = (0..b.len()).filter(|&j| !used_b[j]).collect();
    Matching {
        unmatched: [unmatched_a, unmatched_b],
        max_delta,
        material_changes,
        shading,
    }
}

/// A triangle of one material, for tests.
#[cfg(test)]
pub(super) fn tri(c: [[f32; 3]; 3], m: u32) -> Triangle {
    Triangle {
        corners: c,
        materials: [m; 3],
        shading: Default::default(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_direction_matches_its_octahedral_encoding_only() {
        let z = [0.0; 3];
        assert_eq!(angle(z, z), 0.0);
        assert_eq!(angle(z, [0.0, 0.0, 1.0]), 0.0);
        assert_eq!(angle([0.0, 0.0, 1.0], z), 0.0);
        assert_eq!(angle(z, [0.0, 1.0, 0.0]), std::f64::consts::PI);
        assert!(
            (angle([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]) - std::f64::consts::FRAC_PI_2).abs() < 1e-12
        );
    }

    fn grid(n: usize) -> Vec<Triangle> {
        let mut out = Vec::new();
        for y in 0..n {
            for x in 0..n {
                let p = |dx: usize, dy: usize| [(x + dx) as f32 * 0.5, (y + dy) as f32 * 0.5, 0.0];
                out.push(tri([p(0, 0), p(1, 0), p(1, 1)], (x % 3) as u32));
                out.push(tri([p(0, 0), p(1, 1), p(0, 1)], (y % 2) as u32));
            }
        }
        out
    }

    #[test]
    fn reordered_and_turned_triangles_match_exactly() {
        let a = grid(20);
        let mut b = a.clone();
        b.reverse();
        for (i, t) in b.iter_mut().enumerate() {
            t.corners.rotate_left(i % 3);
            t.materials.rotate_left(i % 3);
        }
        let m = compare(&a, &b, 0.0, ShadingTolerance::default());
        assert_eq!(
            m,
            Matching {
                unmatched: [vec![], vec![]],
                max_delta: 0.0,
                material_changes: 0,
                shading: ShadingChanges::default(),
            }
        );
    }

    #[test]
    fn flipped_moved_missing_and_retagged_triangles_are_found() {
        let a = grid(10);
        let mut b = a.clone();
        b[3].corners.swap(1, 2); // flipped: faces the other way
        b[7].corners[0][2] += 0.01; // moved
        b[11].materials[1] = 99; // one corner retagged
        b.remove(20);
        b.push(tri([[9.0; 3], [10.0, 9.0, 9.0], [9.0, 10.0, 9.0]], 0));

        let strict = compare(&a, &b, 0.0, ShadingTolerance::default());
        assert_eq!(strict.unmatched, [vec![3, 7, 20], vec![3, 7, 199]]);
        assert_eq!(strict.material_changes, 1);

        let loose = compare(&a, &b, 0.02, ShadingTolerance::default());
        assert_eq!(loose.unmatched, [vec![3, 20], vec![3, 199]]);
        assert!((loose.max_delta - 0.01).abs() < 1e-6, "{loose:?}");
        assert_eq!(loose.material_changes, 1);
    }

    /// Under a tolerance longer than the triangles' edges, a flipped triangle's corners are
    /// all within reach of the original's; it still faces the other way.
    #[test]
    fn flipped_triangles_do_not_match_under_a_loose_tolerance() {
        let a = grid(10);
        let b: Vec<Triangle> = a
            .iter()
            .map(|t| Triangle {
                corners: [t.corners[0], t.corners[2], t.corners[1]],
                materials: t.materials,
                shading: t.shading,
            })
            .collect();
        let m = compare(&a, &b, 0.6, ShadingTolerance::default());
        assert_eq!((m.unmatched[0].len(), m.unmatched[1].len()), (200, 200));
    }

    /// Tolerances at the edge of what floats hold finish, and match what they should.
    #[test]
    fn tiny_tolerances_terminate() {
        let a: Vec<Triangle> = grid(5)
            .into_iter()
            .map(|mut t| {
                for c in &mut t.corners {
                    c[0] += 1e4;
                }
                t
            })
            .collect();
        let mut b = a.clone();
        b.reverse();
        b[0].corners[0][1] += 0.01;
        for tolerance in [1e-12, 1e-300, f64::MIN_POSITIVE, 4.9e-324] {
            let m = compare(&a, &b, tolerance, ShadingTolerance::default());
            assert_eq!(
                (m.unmatched[0].len(), m.unmatched[1].len()),
                (1, 1),
                "{tolerance}"
            );
        }
    }

    #[test]
    fn a_tolerance_match_keeps_corner_correspondence_for_materials_and_shading() {
        let shade = |n: [f32; 3], u: f32| Shading {
            normal: n,
            tangent: [1.0, 0.0, 0.0, 1.0],
            uv: [u, 0.5],
        };
        let z = [0.0, 0.0, 1.0];
        let a = vec![Triangle {
            corners: [[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            materials: [1, 2, 3],
            shading: [shade(z, 0.0), shade(z, 1.0), shade(z, 0.5)],
        }];
        // Turned once and nudged: corner k of `a` is corner k+1 of `b`. One normal tilted by
        // 0.01 rad, one texture coordinate moved by 1e-3.
        let tilted = [0.01f32.sin(), 0.0, 0.01f32.cos()];
        let b = vec![Triangle {
            corners: [[1.0, 0.0, 0.001], [0.0, 1.0, 0.0], [0.0, 0.0, 0.001]],
            materials: [2, 3, 1],
            shading: [shade(tilted, 1.0), shade(z, 0.501), shade(z, 0.0)],
        }];
        let tolerance = ShadingTolerance {
            angle: 1e-3,
            uv: 1e-4,
        };
        let m = compare(&a, &b, 0.01, tolerance);
        assert_eq!(m.unmatched, [Vec::<usize>::new(), vec![]]);
        assert_eq!(m.material_changes, 0);
        assert_eq!(
            (m.shading.normals, m.shading.uvs, m.shading.tangents),
            (1, 1, 0)
        );
        assert!(
            (m.shading.max_normal_angle - 0.01).abs() < 1e-6,
            "{:?}",
            m.shading
        );
        assert!(
            (m.shading.max_uv_delta - 1e-3).abs() < 1e-6,
            "{:?}",
            m.shading
        );
        // Within looser tolerances, nothing changed.
        let loose = ShadingTolerance {
            angle: 0.02,
            uv: 0.01,
        };
        let m = compare(&a, &b, 0.01, loose);
        assert_eq!((m.shading.normals, m.shading.uvs), (0, 0));
    }

    #[test]
    fn repeated_triangles_are_matched_once_each() {
        let t = tri([[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], 0);
        let m = compare(&[t, t, t], &[t, t], 0.0, ShadingTolerance::default());
        assert_eq!(m.unmatched, [vec![2], vec![]]);
        let m = compare(&[t], &[t, t], 0.5, ShadingTolerance::default());
        assert_eq!(m.unmatched, [vec![], vec![1]]);
    }
}
