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

fn v3(a: [f32; 3]) -> glam::DVec3 {
    glam::DVec3::new(a[0] as f64, a[1] as f64, a[2] as f64)
}

fn f3(v: glam::DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

/// Fits `world = origin + u * u_axis + v * v_axis` to the window's vertices and orients the
/// normal into the building: along the direction a directional light travels, or away from a
/// point light. Returns `None` for a window with no area.
pub fn analyze(
    material: u16,
    g: &WindowGeometry,
    light: Option<&LightKind>,
) -> Option<WindowAnalysis> {
    let mut area_normal = glam::DVec3::ZERO;
    let mut centroid = glam::DVec3::ZERO;
    let mut area = 0.0;
    for t in &g.triangles {
        let [a, b, c] = t.map(|i| v3(g.positions[i as usize]));
        let n = (b - a).cross(c - a);
        let w = n.length() * 0.5;
        area_normal += n;
        centroid += (a + b + c) / 3.0 * w;
        area += w;
    }
    if area.is_nan() || area <= 0.0 || area_normal.length() == 0.0 {
        return None;
    }
    centroid /= area;
    let plane_n = area_normal.normalize();

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
    let inward = match light {
        Some(LightKind::Directional { direction, .. }) => Some(v3(*direction)),
        Some(LightKind::Point { position, .. }) => Some(centroid - v3(*position)),
        None => None,
    };
    if let Some(d) = inward
        && normal.dot(d) < 0.0
    {
        normal = -normal;
    }
    let diag = (hi - lo).length();
    Some(WindowAnalysis {
        frame: pack::Window {
            material,
            origin: f3(origin),
            u_axis: f3(u_axis),
            v_axis: f3(v_axis),
            normal: f3(normal),
        },
        max_plane_distance: max_d as f32,
        plane_tolerance: (diag * 1e-3).max(1e-5) as f32,
        has_uvs,
        uv_min,
        uv_max,
        from_uvs,
    })
}

/// Without usable UVs: the window's bounding rectangle in its plane, v up where possible.
fn planar_frame(
    used: &[u32],
    g: &WindowGeometry,
    n: glam::DVec3,
    centroid: glam::DVec3,
) -> (glam::DVec3, glam::DVec3, glam::DVec3) {
    let up = if n.y.abs() < 0.99 {
        glam::DVec3::Y
    } else {
        glam::DVec3::Z
    };
    let v_dir = (up - n * up.dot(n)).normalize();
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
        let a = analyze(7, &g, Some(&light)).unwrap();
        assert!(a.from_uvs && a.has_uvs);
        let close = |x: [f32; 3], y: [f32; 3]| x.iter().zip(&y).all(|(a, b)| (a - b).abs() < 1e-5);
        assert!(close(a.frame.origin, [1., 4., 5.]), "{:?}", a.frame);
        assert!(close(a.frame.u_axis, [2., 0., 0.]));
        assert!(close(a.frame.v_axis, [0., -3., 0.]));
        assert!(close(a.frame.normal, [0., 0., -1.]));
        assert_eq!(a.max_plane_distance, 0.0);
    }
}
