//! Window geometry: the frame a design is projected from, and the checks `validate` reports.

use pack::LightKind;

/// The triangles of one window material, gathered from every mesh.
#[derive(Clone, Debug, Default)]
pub struct WindowGeometry {
    pub positions: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    pub triangles: Vec<[u32; 3]>,
}

/// What the window's geometry says about itself.
#[derive(Clone, Debug, PartialEq)]
pub struct WindowAnalysis {
    pub frame: pack::Window,
    /// Largest distance of a vertex from the best-fit plane.
    pub max_plane_distance: f32,
    /// Allowed distance: 0.1 % of the window's diagonal (at least 1e-5).
    pub plane_tolerance: f32,
    /// False when every vertex has the same texture coordinate (none in the source).
    pub has_uvs: bool,
    pub uv_min: [f32; 2],
    pub uv_max: [f32; 2],
    /// True when the frame came from a least-squares fit of the UVs, false for the fallback.
    pub from_uvs: bool,
}

pub(crate) fn v3(a: [f32; 3]) -> glam::DVec3 {
    glam::DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

pub(crate) fn f3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// A unit vector in the plane of normal `n` pointing as "up" as the plane allows: +Y
/// projected, or +Z for horizontal glass (skylights), whose image has no natural up.
pub(crate) fn plane_up(n: glam::DVec3) -> glam::DVec3 {
    let reference = if n.y.abs() < 0.99 {
        glam::DVec3::Y
    } else {
        glam::DVec3::Z
    };
    (reference - n * reference.dot(n)).normalize()
}

/// Faces within this angle of a window's plane, facing either way, make up its sheets.
const SHEET_COS: f64 = 0.996_194_698_091_745_5; // cos 5°

/// A glass slab is at most this thick against its narrower side in the plane: a pane a few
/// millimetres thick, not a block of glass.
pub(crate) const SLAB_THICKNESS: f64 = 0.25;

/// How glass lies about its plane, counted per sheet. Real models often give a pane two
/// sheets: double-sided (the same face twice, wound both ways) or with thickness (a thin box,
/// a Blender "solidify"). Each sheet is flat; the distance between them is not a deviation.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(crate) struct Sheets {
    /// Largest distance of a vertex of a sheet's face from that sheet's middle plane.
    pub deviation: f64,
    /// Distance between the middle planes of the front and back sheets (0 for one sheet).
    pub thickness: f64,
    /// Share of the area in the sheets' faces (the rest: a slab's edges, curved facets).
    pub sheet_share: f64,
    /// The narrower side of the glass's bounds in the plane.
    pub narrow: f64,
    /// How far a vertex of a face in neither sheet (a slab's edge, a bay's side) lies outside
    /// the span of the sheets along the normal.
    pub outside: f64,
}

impl Sheets {
    /// Faces on one side (or both, same plane) of `normal` through `centroid`.
    pub(crate) fn of(
        triangles: impl Iterator<Item = [glam::DVec3; 3]>,
        centroid: glam::DVec3,
        normal: glam::DVec3,
    ) -> Sheets {
        let f = plane_up(normal);
        let e = f.cross(normal);
        // [front, back] offsets along the normal, min and max.
        let mut span = [[f64::INFINITY, f64::NEG_INFINITY]; 2];
        let (mut lo, mut hi) = (
            glam::DVec2::splat(f64::INFINITY),
            glam::DVec2::splat(f64::NEG_INFINITY),
        );
        let (mut sheet_area, mut area) = (0.0, 0.0);
        // Offsets of the other faces' vertices, min and max.
        let mut others = [f64::INFINITY, f64::NEG_INFINITY];
        for [a, b, c] in triangles {
            let n = (b - a).cross(c - a);
            let len = n.length();
            area += len;
            for p in [a, b, c] {
                let d = p - centroid;
                let q = glam::DVec2::new(d.dot(e), d.dot(f));
                lo = lo.min(q);
                hi = hi.max(q);
            }
            let cos = if len > 0.0 { n.dot(normal) / len } else { 0.0 };
            let side = if cos >= SHEET_COS {
                0
            } else if cos <= -SHEET_COS {
                1
            } else {
                for p in [a, b, c] {
                    let d = (p - centroid).dot(normal);
                    others = [others[0].min(d), others[1].max(d)];
                }
                continue;
            };
            sheet_area += len;
            for p in [a, b, c] {
                let d = (p - centroid).dot(normal);
                span[side][0] = span[side][0].min(d);
                span[side][1] = span[side][1].max(d);
            }
        }
        let mid = span.map(|[l, h]| (l <= h).then_some(0.5 * (l + h)));
        let deviation = span
            .iter()
            .filter(|[l, h]| l <= h)
            .map(|[l, h]| 0.5 * (h - l))
            .fold(0.0, f64::max);
        // Faces wound the other way at the same place are the same sheet, not a slab.
        let thickness = match mid {
            [Some(a), Some(b)] => (a - b).abs(),
            _ => 0.0,
        };
        let extent = hi - lo;
        let (lo_d, hi_d) = (span[0][0].min(span[1][0]), span[0][1].max(span[1][1]));
        let outside = if others[0] <= others[1] && lo_d <= hi_d {
            (lo_d - others[0]).max(others[1] - hi_d).max(0.0)
        } else {
            0.0
        };
        Sheets {
            outside,
            deviation,
            thickness,
            sheet_share: if area > 0.0 { sheet_area / area } else { 0.0 },
            narrow: if extent.is_finite() {
                extent.min_element()
            } else {
                0.0
            },
        }
    }

    /// Whether the glass is one flat pane of two sheets at most: each sheet within
    /// `tolerance` of flat, most of the area in them, and a slab thin against its width.
    pub(crate) fn flat(&self, tolerance: f64) -> bool {
        self.deviation <= tolerance
            && self.outside <= tolerance
            && self.sheet_share >= 0.5
            && self.thickness <= SLAB_THICKNESS * self.narrow
    }
}

/// Area-weighted plane of some triangles: centroid, unit normal and area, `None` for no
/// area. Faces are turned to agree with `reference` (else with the largest face) before they
/// are summed: double-sided glass (each face twice, wound both ways) and glass with thickness
/// (a thin box) summed to no normal at all, and such a window got no frame and no light.
pub(crate) fn oriented_plane(
    faces: impl Iterator<Item = [glam::DVec3; 3]>,
    reference: Option<glam::DVec3>,
) -> Option<(glam::DVec3, glam::DVec3, f64)> {
    let faces: Vec<(glam::DVec3, glam::DVec3, f64)> = faces
        .map(|[a, b, c]| {
            let n = (b - a).cross(c - a);
            ((a + b + c) / 3.0, n, n.length() * 0.5)
        })
        .collect();
    let reference =
        reference.or_else(|| faces.iter().max_by(|x, y| x.2.total_cmp(&y.2)).map(|f| f.1))?;
    let mut sum = glam::DVec3::ZERO;
    let mut as_wound = glam::DVec3::ZERO;
    let mut centroid = glam::DVec3::ZERO;
    let mut area = 0.0;
    for (c, n, a) in &faces {
        sum += if n.dot(reference) < 0.0 { -*n } else { *n };
        as_wound += *n;
        centroid += *c * *a;
        area += a;
    }
    if area.is_nan() || area <= 0.0 || sum.length() == 0.0 {
        return None;
    }
    // Glass wound one way that turns through more than 90° (a half-cylinder bay) had its far
    // faces turned towards the reference face, an end facet, and the plane came out 67° off
    // the opening's. Where the faces as wound sum to at least half their area, they are one
    // sheet and their sum is the plane's normal; two-sided and thick glass sum to about none.
    let normal = if as_wound.length() >= area {
        let n = as_wound.normalize();
        if n.dot(reference) < 0.0 { -n } else { n }
    } else {
        sum.normalize()
    };
    Some((centroid / area, normal, area))
}

/// Fits `world = origin + u * u_axis + v * v_axis` to the window's vertices and orients the
/// normal into the building: along the direction a directional light travels, or away from a
/// point light. Returns `None` for a window with no area.
pub fn analyze(
    material: u16,
    g: &WindowGeometry,
    light: Option<&LightKind>,
    inside: Option<glam::DVec3>,
) -> Option<WindowAnalysis> {
    let corners = |t: &[u32; 3]| t.map(|i| v3(g.positions[i as usize]));
    // The inside decides which way the faces are turned; else the largest face.
    let (centroid, plane_n, _) = oriented_plane(g.triangles.iter().map(corners), inside)?;
    let sheets = Sheets::of(g.triangles.iter().map(corners), centroid, plane_n);

    let used: Vec<u32> = {
        let mut u: Vec<u32> = g.triangles.iter().flatten().copied().collect();
        u.sort_unstable();
        u.dedup();
        u
    };
    let mut lo = glam::DVec3::splat(f64::INFINITY);
    let mut hi = glam::DVec3::splat(f64::NEG_INFINITY);
    let mut max_d = 0.0f64;
    let mut uv_min = [f32::INFINITY; 2];
    let mut uv_max = [f32::NEG_INFINITY; 2];
    for &i in &used {
        let p = v3(g.positions[i as usize]);
        lo = lo.min(p);
        hi = hi.max(p);
        max_d = max_d.max((p - centroid).dot(plane_n).abs());
        let uv = g.uvs[i as usize];
        for k in 0..2 {
            uv_min[k] = uv_min[k].min(uv[k]);
            uv_max[k] = uv_max[k].max(uv[k]);
        }
    }
    let has_uvs = uv_min != uv_max;

    // Least squares over (u, v, 1) -> xyz: solve the 3x3 normal equations once per axis.
    let fit = has_uvs.then(|| {
        let mut m = glam::DMat3::ZERO;
        let mut rhs = [glam::DVec3::ZERO; 3];
        for &i in &used {
            let uv = g.uvs[i as usize];
            let x = glam::DVec3::new(uv[0] as f64, uv[1] as f64, 1.0);
            m += glam::DMat3::from_cols(x * x.x, x * x.y, x * x.z);
            let p = v3(g.positions[i as usize]);
            for k in 0..3 {
                rhs[k] += x * p[k];
            }
        }
        if m.determinant().abs() < 1e-12 {
            return None;
        }
        let inv = m.inverse();
        let sol: [glam::DVec3; 3] = rhs.map(|r| inv * r);
        let u_axis = glam::DVec3::new(sol[0].x, sol[1].x, sol[2].x);
        let v_axis = glam::DVec3::new(sol[0].y, sol[1].y, sol[2].y);
        let origin = glam::DVec3::new(sol[0].z, sol[1].z, sol[2].z);
        let n = u_axis.cross(v_axis);
        (n.length() > 0.0 && origin.is_finite()).then_some((origin, u_axis, v_axis))
    });
    let (from_uvs, (origin, u_axis, v_axis)) = match fit.flatten() {
        Some(f) => (true, f),
        None => (false, planar_frame(&used, g, plane_n, centroid)),
    };

    // A window is seen from inside; its normal points into the building, away from the light.
    let mut normal = plane_n;
    // The window stage's decision (light, manifest or receiving geometry) comes first.
    let inward = match (inside, light) {
        (Some(d), _) => Some(d),
        (None, Some(LightKind::Directional { direction, .. })) => Some(v3(*direction)),
        (None, Some(l)) => l.lamp().map(|(position, _)| centroid - v3(position)),
        (None, None) => None,
    };
    if let Some(d) = inward
        && normal.dot(d) < 0.0
    {
        normal = -normal;
    }
    let diag = (hi - lo).length();
    // The cook's own limit for one pane (window instances): validate said a 559-unit window
    // 1.07 off its plane was not planar against 0.56 while the cook kept it whole.
    let plane_tolerance = (diag * crate::instances::PLANAR_TOLERANCE).max(1e-5);
    // A slab's two sheets each lie in a plane; how far apart they are is its thickness.
    let max_d = if sheets.thickness > 0.0 && sheets.flat(plane_tolerance) {
        sheets.deviation
    } else {
        max_d
    };
    Some(WindowAnalysis {
        frame: pack::Window {
            material,
            origin: f3(origin),
            u_axis: f3(u_axis),
            v_axis: f3(v_axis),
            normal: f3(normal),
            source_materials: Vec::new(),
        },
        max_plane_distance: max_d as f32,
        plane_tolerance: plane_tolerance as f32,
        has_uvs,
        uv_min,
        uv_max,
        from_uvs,
    })
}

/// Whether the light passes the window inwards at all: the sun travels into the building
/// through it (not grazing), or the lamp stands on its outer side and, for a spot, its cone
/// reaches the glass.
pub fn light_enters(frame: &pack::Window, light: &LightKind) -> bool {
    faces_light(frame, light)
        && match (light.cone(), light.lamp()) {
            (Some(cone), Some((position, _))) => cone.reaches(
                position.map(f64::from),
                frame.origin.map(f64::from),
                frame.u_axis.map(f64::from),
                frame.v_axis.map(f64::from),
            ),
            _ => true,
        }
}

/// The first half of [`light_enters`]: the window's inner side faces away from the light.
pub fn faces_light(frame: &pack::Window, light: &LightKind) -> bool {
    let n = v3(frame.normal).normalize_or_zero();
    match (light.sun(), light.lamp()) {
        (Some((direction, _)), _) => v3(direction).normalize_or_zero().dot(n) > 1e-9,
        (None, Some((position, _))) => (v3(position) - v3(frame.origin)).dot(n) < 0.0,
        (None, None) => false,
    }
}

/// Whether light through the window can land on any of `receivers` (triangles of floors,
/// walls and other opaque surfaces): some part of a triangle lies behind the window (on the
/// side its normal points to) and, traced back along the light to the window's plane, falls
/// inside the window's rectangle. Each triangle is clipped to the inner side first, then the
/// bounding box of its traced-back corners is tested against [0, 1]², which can only err
/// towards "reaches". Occlusion is not considered: a wall between the window and the floor
/// does not stop the projector from being cooked.
pub fn light_reaches(
    frame: &pack::Window,
    light: &LightKind,
    receivers: impl IntoIterator<Item = [[f32; 3]; 3]>,
) -> bool {
    let origin = v3(frame.origin);
    let (u, v, n) = (v3(frame.u_axis), v3(frame.v_axis), v3(frame.normal));
    let n = n.normalize_or_zero();
    // Surfaces in the window's own plane (the wall around it) are not behind it.
    let eps = 1e-4 * (u.length() + v.length());
    let gram = glam::DMat2::from_cols(
        glam::DVec2::new(u.dot(u), u.dot(v)),
        glam::DVec2::new(u.dot(v), v.dot(v)),
    );
    // Degenerate against the window's own size: 1e-18 absolute took every window of a nave
    // scaled to 0.2 mm (sides of 2e-5) for a line, its light for none.
    let flat = gram.determinant().abs() <= 1e-12 * u.dot(u) * v.dot(v);
    if n == glam::DVec3::ZERO || flat || !light_enters(frame, light) {
        return false;
    }
    let inv = gram.inverse();
    // Back along the light to the window's plane.
    let trace: Box<dyn Fn(glam::DVec3, f64) -> glam::DVec3> = match *light {
        LightKind::Directional { direction, .. } => {
            let d = v3(direction).normalize_or_zero();
            let dn = d.dot(n);
            Box::new(move |p, s| p - d * (s / dn))
        }
        LightKind::Point { position, .. } | LightKind::Spot { position, .. } => {
            let l = v3(position);
            let sl = (l - origin).dot(n);
            Box::new(move |p, s| l + (p - l) * (sl / (sl - s)))
        }
    };
    let uv = |q: glam::DVec3| {
        let r = q - origin;
        inv * glam::DVec2::new(r.dot(u), r.dot(v))
    };
    for tri in receivers {
        let pts = tri.map(v3);
        let side = pts.map(|p| (p - origin).dot(n) - eps);
        let mut lo = glam::DVec2::splat(f64::INFINITY);
        let mut hi = glam::DVec2::splat(f64::NEG_INFINITY);
        let mut any = false;
        let mut add = |p: glam::DVec3, s: f64| {
            let q = uv(trace(p, s + eps));
            lo = lo.min(q);
            hi = hi.max(q);
            any = true;
        };
        for k in 0..3 {
            let (a, b) = (pts[k], pts[(k + 1) % 3]);
            let (sa, sb) = (side[k], side[(k + 1) % 3]);
            if sa > 0.0 {
                add(a, sa);
            }
            if (sa > 0.0) != (sb > 0.0) && sa != sb {
                let t = sa / (sa - sb);
                add(a + (b - a) * t, 0.0);
            }
        }
        if any
            && lo.is_finite()
            && hi.is_finite()
            && lo.x <= 1.0
            && lo.y <= 1.0
            && hi.x >= 0.0
            && hi.y >= 0.0
        {
            return true;
        }
    }
    false
}

/// Without usable UVs: the window's bounding rectangle in its plane, v up where possible.
fn planar_frame(
    used: &[u32],
    g: &WindowGeometry,
    n: glam::DVec3,
    centroid: glam::DVec3,
) -> (glam::DVec3, glam::DVec3, glam::DVec3) {
    let v_dir = plane_up(n);
    let u_dir = v_dir.cross(n);
    let (mut s0, mut s1, mut t0, mut t1) = (
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::INFINITY,
        f64::NEG_INFINITY,
    );
    for &i in used {
        let d = v3(g.positions[i as usize]) - centroid;
        let (s, t) = (d.dot(u_dir), d.dot(v_dir));
        s0 = s0.min(s);
        s1 = s1.max(s);
        t0 = t0.min(t);
        t1 = t1.max(t);
    }
    // Image rows run downwards: v = 0 is the top edge.
    let origin = centroid + u_dir * s0 + v_dir * t1;
    (origin, u_dir * (s1 - s0), -v_dir * (t1 - t0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn double_sided_and_thick_glass_gets_a_frame_in_its_plane() {
        // A 1 x 2 pane in x = 0 drawn twice, wound both ways: its normals summed to nothing.
        let two_sided = WindowGeometry {
            positions: vec![[0., 0., 0.], [0., 0., 1.], [0., 2., 1.], [0., 2., 0.]],
            uvs: vec![[0.0; 2]; 4],
            triangles: vec![[0, 1, 2], [0, 2, 3], [0, 2, 1], [0, 3, 2]],
        };
        let a = analyze(0, &two_sided, None, Some(glam::DVec3::X)).expect("a frame");
        assert_eq!(a.frame.normal, [1.0, 0.0, 0.0]);
        assert!(a.max_plane_distance <= a.plane_tolerance);
        // The same pane as a 1 cm slab: front, back and four edges.
        let mut positions = Vec::new();
        for x in [0.0, 0.01] {
            positions.extend([[x, 0., 0.], [x, 0., 1.], [x, 2., 1.], [x, 2., 0.]]);
        }
        let quad = |q: [u32; 4]| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]];
        let mut triangles = Vec::new();
        for q in [
            [0, 3, 2, 1],
            [4, 5, 6, 7],
            [0, 1, 5, 4],
            [3, 7, 6, 2],
            [0, 4, 7, 3],
            [1, 2, 6, 5],
        ] {
            triangles.extend(quad(q));
        }
        let slab = WindowGeometry {
            uvs: vec![[0.0; 2]; positions.len()],
            positions,
            triangles,
        };
        let sun = LightKind::Directional {
            direction: [1.0, -1.0, 0.0],
            angular_size: 0.01,
        };
        let a = analyze(0, &slab, Some(&sun), None).expect("a frame");
        assert_eq!(a.frame.normal, [1.0, 0.0, 0.0]);
        // Each sheet is flat: the 1 cm between them is thickness, not a warped window.
        assert!(a.max_plane_distance <= a.plane_tolerance, "{a:?}");
        assert!(
            (a.frame.origin[0] - 0.005).abs() < 1e-6,
            "{:?}",
            a.frame.origin
        );
    }

    #[test]
    fn frame_reproduces_uv_mapping_and_faces_away_from_light() {
        // A 2 x 3 window in the plane z = 5, u along +x, v down -y.
        let g = WindowGeometry {
            positions: vec![[1., 4., 5.], [3., 4., 5.], [3., 1., 5.], [1., 1., 5.]],
            uvs: vec![[0., 0.], [1., 0.], [1., 1.], [0., 1.]],
            triangles: vec![[0, 2, 1], [0, 3, 2]],
        };
        let light = LightKind::Directional {
            direction: [0.0, -0.5, -1.0],
            angular_size: 0.01,
        };
        let a = analyze(7, &g, Some(&light), None).unwrap();
        assert!(a.from_uvs && a.has_uvs);
        let close = |x: [f32; 3], y: [f32; 3]| x.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-5);
        assert!(close(a.frame.origin, [1., 4., 5.]), "{:?}", a.frame);
        assert!(close(a.frame.u_axis, [2., 0., 0.]));
        assert!(close(a.frame.v_axis, [0., -3., 0.]));
        assert!(close(a.frame.normal, [0., 0., -1.]));
        assert_eq!(a.max_plane_distance, 0.0);
    }

    /// A unit window in the plane z = 0 (normal +z into the building), and a floor patch.
    fn window() -> pack::Window {
        pack::Window {
            material: 0,
            origin: [0.0, 2.0, 0.0],
            u_axis: [1.0, 0.0, 0.0],
            v_axis: [0.0, -1.0, 0.0],
            normal: [0.0, 0.0, 1.0],
            source_materials: Vec::new(),
        }
    }

    fn floor(z0: f32, z1: f32, x0: f32, x1: f32) -> Vec<[[f32; 3]; 3]> {
        vec![
            [[x0, 0.0, z0], [x1, 0.0, z0], [x1, 0.0, z1]],
            [[x0, 0.0, z0], [x1, 0.0, z1], [x0, 0.0, z1]],
        ]
    }

    #[test]
    fn sun_through_window_reaches_the_floor_behind_it_only() {
        let sun = LightKind::Directional {
            direction: [0.0, -1.0, 1.0],
            angular_size: 0.01,
        };
        // The shaft lands at z in [1, 2]; a floor there is lit.
        assert!(light_reaches(&window(), &sun, floor(0.5, 3.0, -1.0, 2.0)));
        // Floor beside the shaft, or outside the building, is not.
        assert!(!light_reaches(&window(), &sun, floor(0.5, 3.0, 5.0, 6.0)));
        assert!(!light_reaches(
            &window(),
            &sun,
            floor(-3.0, -0.5, -1.0, 2.0)
        ));
        // The wall the window sits in lies in its plane and receives nothing.
        let wall = vec![[[-5.0, 0.0, 0.0], [5.0, 0.0, 0.0], [5.0, 5.0, 0.0]]];
        assert!(!light_reaches(&window(), &sun, wall));
        // A floor crossing the window's plane counts with its inner part only.
        assert!(light_reaches(&window(), &sun, floor(-3.0, 1.5, -1.0, 2.0)));
        assert!(!light_reaches(&window(), &sun, floor(-3.0, 0.5, -1.0, 2.0)));
    }

    #[test]
    fn light_that_cannot_pass_the_window_reaches_nothing() {
        let all = floor(-10.0, 10.0, -10.0, 10.0);
        let grazing = LightKind::Directional {
            direction: [1.0, 0.0, 0.0],
            angular_size: 0.01,
        };
        assert!(!light_reaches(&window(), &grazing, all.clone()));
        let inside = LightKind::Point {
            position: [0.5, 1.5, 1.0],
            radius: 0.1,
        };
        assert!(!light_reaches(&window(), &inside, all.clone()));
        let outside = LightKind::Point {
            position: [0.5, 1.5, -1.0],
            radius: 0.1,
        };
        // From (0.5, 1.5, -1), only the window's lower half sends light down: through its
        // lower edge (y = 1) the light reaches the floor at z = 2, through higher points
        // further away.
        assert!(light_reaches(
            &window(),
            &outside,
            floor(0.5, 3.0, -1.0, 2.0)
        ));
        assert!(!light_reaches(
            &window(),
            &outside,
            floor(0.1, 0.4, -1.0, 2.0)
        ));
    }

    /// A spot's light enters a window only where its outer cone meets the glass: the window
    /// spans x 0..1, y 1..2 in z = 0, the spot stands 1 m before it at (0.5, 1.5, -1).
    #[test]
    fn a_spot_light_enters_only_the_windows_its_cone_meets() {
        let spot = |axis: [f32; 3], outer_deg: f32| LightKind::Spot {
            position: [0.5, 1.5, -1.0],
            radius: 0.05,
            direction: axis,
            inner: 0.0,
            outer: outer_deg.to_radians(),
        };
        let all = floor(-10.0, 10.0, -10.0, 10.0);
        // Aimed at the glass, however narrow: the axis passes through it.
        assert!(light_enters(&window(), &spot([0.0, 0.0, 1.0], 1.0)));
        // Aimed sideways along +x: the glass's nearest point, the middle of its edge x = 1,
        // is atan(1 / 0.5) = 63.43° off the axis, so a cone of 64° meets it and 63° does not.
        let w = window();
        let nearest_cos = |axis: glam::DVec3| {
            let cone = pack::SpotCone {
                axis: axis.to_array(),
                cos_inner: 1.0,
                cos_outer: 0.0,
            };
            let f = |a: [f32; 3]| a.map(f64::from);
            cone.nearest_cos([0.5, 1.5, -1.0], f(w.origin), f(w.u_axis), f(w.v_axis))
        };
        let cos = nearest_cos(glam::DVec3::X);
        assert!((cos - 0.5 / 1.25f64.sqrt()).abs() < 1e-9, "{cos}");
        assert!(light_enters(&w, &spot([1.0, 0.0, 0.0], 64.0)));
        assert!(!light_enters(&w, &spot([1.0, 0.0, 0.0], 63.0)));
        assert!(!light_reaches(
            &w,
            &spot([1.0, 0.0, 0.0], 63.0),
            all.clone()
        ));
        // Aimed away: no cone of at most 90° reaches glass it turns its back on.
        assert!(!light_enters(&w, &spot([0.0, 0.0, -1.0], 90.0)));
        // Aimed past a corner: the nearest point is the corner (1, 1, 0), not an edge's middle.
        let past = glam::DVec3::new(1.0, -1.0, 1.0).normalize();
        let corner = (glam::DVec3::new(1.0, 1.0, 0.0) - v3([0.5, 1.5, -1.0])).normalize();
        let cos = nearest_cos(past);
        assert!((cos - past.dot(corner)).abs() < 1e-9, "{cos}");
    }
}
