//! Cameras, lights and the projective math that the passes feed to the GPU. Everything here
//! is plain CPU math so tests can check it without a device.

use glam::{DVec3, Mat4, Vec2, Vec3, Vec4};

/// A camera resolved for one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct View {
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    pub view: Mat4,
    pub proj: Mat4,
    /// Vertical field of view in radians.
    pub fov_y: f32,
    pub aspect: f32,
}

/// A unit vector not parallel to `forward`, preferring `up`.
fn stable_up(forward: Vec3, up: Vec3) -> Vec3 {
    let up = up.normalize_or_zero();
    if up != Vec3::ZERO && forward.cross(up).length_squared() > 1e-8 {
        return up;
    }
    // The requested up is parallel to the view (looking straight up or down): any
    // perpendicular axis gives a valid, if arbitrarily rolled, view.
    if forward.cross(Vec3::Y).length_squared() > 1e-8 {
        Vec3::Y
    } else {
        Vec3::Z
    }
}

impl View {
    pub fn look(
        position: Vec3,
        forward: Vec3,
        up: Vec3,
        fov_y_deg: f32,
        aspect: f32,
        near: f32,
        far: f32,
    ) -> Self {
        let forward = {
            let f = forward.normalize_or_zero();
            if f == Vec3::ZERO { Vec3::NEG_Z } else { f }
        };
        let up = stable_up(forward, up);
        let fov_y = fov_y_deg.clamp(1.0, 179.0).to_radians();
        let aspect = if aspect.is_finite() && aspect > 0.0 {
            aspect
        } else {
            1.0
        };
        let near = if near > 0.0 { near } else { 0.05 };
        let far = if far > near { far } else { near * 1e4 };
        Self {
            position,
            forward,
            view: Mat4::look_to_rh(position, forward, up),
            proj: Mat4::perspective_rh(fov_y, aspect, near, far),
            fov_y,
            aspect,
        }
    }

    pub fn from_camera(c: &pack::Camera, aspect: f32) -> Self {
        let p = Vec3::from(c.position);
        Self::look(
            p,
            Vec3::from(c.target) - p,
            Vec3::from(c.up),
            c.fov_y,
            aspect,
            c.near,
            c.far,
        )
    }

    /// A camera that frames the given bounds from the +Z side, for packs without cameras.
    pub fn framing(min: Vec3, max: Vec3, aspect: f32) -> Self {
        let centre = (min + max) * 0.5;
        let radius = ((max - min).length() * 0.5).max(1e-3);
        let distance = radius / (30f32.to_radians()).tan() * 1.1;
        let eye = centre + Vec3::new(0.0, radius * 0.3, distance);
        Self::look(
            eye,
            centre - eye,
            Vec3::Y,
            60.0,
            aspect,
            distance * 0.01,
            distance + radius * 4.0,
        )
    }

    /// World to clip. Its translation column is about the camera's distance from the origin,
    /// so far from the origin (1e5) its f32 products round to ~0.01 units before the
    /// translation cancels them: the renderer uses [`View::view_proj_relative`] instead.
    pub fn view_proj(&self) -> Mat4 {
        self.proj * self.view
    }

    /// The view's rotation alone: world directions to view space.
    pub fn rotation(&self) -> Mat4 {
        let mut m = self.view;
        m.w_axis = Vec4::W;
        m
    }

    /// Camera-relative position (`p − position`) to clip. No translation, so it loses no
    /// precision wherever the scene is; the shaders subtract the camera position from each
    /// vertex first (an f32 difference, rounded once).
    pub fn view_proj_relative(&self) -> Mat4 {
        self.proj * self.rotation()
    }

    /// `p − position` in f64, rounded once to f32: exact up to that rounding for any `p`.
    pub fn relative(&self, p: Vec3) -> Vec3 {
        (p.as_dvec3() - self.position.as_dvec3()).as_vec3()
    }

    /// A homogeneous world point (w = 1) or direction (w = 0) in clip space, computed
    /// camera-relative.
    pub fn clip(&self, p: Vec4) -> Vec4 {
        let rel = if p.w == 0.0 {
            p
        } else {
            // Dehomogenise in f64 so a w ≠ 1 point is moved by the camera exactly once.
            let w = p.w as f64;
            let world = DVec3::new(p.x as f64, p.y as f64, p.z as f64) / w;
            ((world - self.position.as_dvec3()) * w)
                .as_vec3()
                .extend(p.w)
        };
        self.view_proj_relative() * rel
    }
}

/// The light as the shaders see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightGeometry {
    Point {
        position: Vec3,
        radius: f32,
    },
    /// `towards` is the unit direction from the scene to the light (against the travel).
    Directional {
        towards: Vec3,
    },
}

impl LightGeometry {
    /// A spot light is a point here: its cone only scales the light it sends
    /// (`uniforms::Frame::spot_ramp`).
    pub fn from_light(light: &pack::Light) -> Self {
        match light.kind {
            pack::LightKind::Point { position, radius }
            | pack::LightKind::Spot {
                position, radius, ..
            } => Self::Point {
                position: Vec3::from(position),
                radius,
            },
            pack::LightKind::Directional { direction, .. } => {
                let d = Vec3::from(direction).normalize_or_zero();
                Self::Directional {
                    towards: if d == Vec3::ZERO { Vec3::Y } else { -d },
                }
            }
        }
    }

    /// Homogeneous world position: w = 1 for a point, 0 for a point at infinity.
    pub fn homogeneous(&self) -> Vec4 {
        match *self {
            Self::Point { position, .. } => position.extend(1.0),
            Self::Directional { towards } => towards.extend(0.0),
        }
    }

    /// Unit direction from `eye` towards the light, when defined.
    pub fn direction_from(&self, eye: Vec3) -> Option<Vec3> {
        let d = match *self {
            Self::Point { position, .. } => (position.as_dvec3() - eye.as_dvec3()).as_vec3(),
            Self::Directional { towards } => towards,
        };
        let d = d.normalize_or_zero();
        (d != Vec3::ZERO).then_some(d)
    }
}

impl LightGeometry {
    /// The same light with positions measured from `origin` (computed in f64, rounded once).
    pub fn relative_to(&self, origin: Vec3) -> Self {
        match *self {
            Self::Point { position, radius } => Self::Point {
                position: (position.as_dvec3() - origin.as_dvec3()).as_vec3(),
                radius,
            },
            d @ Self::Directional { .. } => d,
        }
    }
}

/// `w` with its origin measured from `origin` (computed in f64, rounded once): the shaders
/// work in camera-relative coordinates, so window planes and projectors are built there too.
pub fn window_relative_to(w: &pack::Window, origin: Vec3) -> pack::Window {
    let o = (Vec3::from(w.origin).as_dvec3() - origin.as_dvec3()).as_vec3();
    pack::Window {
        origin: o.to_array(),
        ..w.clone()
    }
}

/// The frame a window's projector texture spans: the window's frame grown on each side by its
/// material's projector margin (`pack::Material::projector_margin`, in frame units), so the
/// light's penumbra past the window's edge lands on the texture's margin. Built in f64.
pub fn projector_frame(w: &pack::Window, margin: [f32; 2]) -> pack::Window {
    let (u, v) = (
        Vec3::from(w.u_axis).as_dvec3(),
        Vec3::from(w.v_axis).as_dvec3(),
    );
    let (mu, mv) = (margin[0] as f64, margin[1] as f64);
    let origin = Vec3::from(w.origin).as_dvec3() - u * mu - v * mv;
    pack::Window {
        origin: origin.as_vec3().to_array(),
        u_axis: (u * (1.0 + 2.0 * mu)).as_vec3().to_array(),
        v_axis: (v * (1.0 + 2.0 * mv)).as_vec3().to_array(),
        ..w.clone()
    }
}

/// Every window's [`projector_frame`], in window order.
pub fn projector_frames(toc: &pack::Toc) -> Vec<pack::Window> {
    toc.windows
        .iter()
        .map(|w| {
            let margin = toc
                .materials
                .get(w.material as usize)
                .map_or([0.0; 2], |m| m.projector_margin);
            projector_frame(w, margin)
        })
        .collect()
}

/// Whether `light` comes in through window `w`: it passes the window inwards (not the sun
/// behind it, nor a lamp inside), and a spot's cone reaches the glass.
pub fn window_passes_light(w: &pack::Window, light: &pack::Light) -> bool {
    if window_projector(w, &LightGeometry::from_light(light)).is_none() {
        return false;
    }
    match (light.kind.cone(), light.kind.lamp()) {
        (Some(cone), Some((position, _))) => {
            let f = |a: [f32; 3]| a.map(f64::from);
            cone.reaches(f(position), f(w.origin), f(w.u_axis), f(w.v_axis))
        }
        _ => true,
    }
}

/// The share of `light` that comes in through window `w`, one it passes
/// ([`window_passes_light`]): 1, or for a spot the mean of its cone's fall-off over a 5 x 5
/// grid of the glass. It weighs the window's god rays.
pub fn window_light_share(w: &pack::Window, light: &pack::Light) -> f32 {
    let (Some(cone), Some((position, _))) = (light.kind.cone(), light.kind.lamp()) else {
        return 1.0;
    };
    let at = Vec3::from(position).as_dvec3();
    let (o, u, v) = (
        Vec3::from(w.origin).as_dvec3(),
        Vec3::from(w.u_axis).as_dvec3(),
        Vec3::from(w.v_axis).as_dvec3(),
    );
    let mut sum = 0.0;
    for i in 0..5 {
        for j in 0..5 {
            let q = o + u * (0.1 + 0.2 * i as f64) + v * (0.1 + 0.2 * j as f64);
            sum += cone.towards((q - at).to_array());
        }
    }
    (sum / 25.0) as f32
}

/// The matrix mapping a world position to `(u·w, v·w, 0, w)` on a window's design as seen
/// from the light: a perspective projector from a point light's position, an orthographic one
/// along a directional light. For points on the window `w = 1` and `(u, v)` are the design's
/// texture coordinates (the `Window` frame's parametrisation).
///
/// `None` when the window cannot pass light: a degenerate frame, a point light on the inner
/// side of (or in) the window plane, or a directional light travelling outwards.
pub fn window_projector(w: &pack::Window, light: &LightGeometry) -> Option<Mat4> {
    let o = Vec3::from(w.origin);
    let u_axis = Vec3::from(w.u_axis);
    let v_axis = Vec3::from(w.v_axis);
    let n = Vec3::from(w.normal).normalize_or_zero();
    if n == Vec3::ZERO {
        return None;
    }
    // Dual basis: du·u_axis = 1, du·v_axis = 0, du·n = 0 (and likewise dv), so skewed or
    // non-unit axes still give exact texture coordinates.
    let vn = v_axis.cross(n);
    let nu = n.cross(u_axis);
    let (ku, kv) = (u_axis.dot(vn), v_axis.dot(nu));
    if ku.abs() < 1e-12 || kv.abs() < 1e-12 {
        return None;
    }
    let du = vn / ku;
    let dv = nu / kv;
    let rows: [Vec4; 4] = match *light {
        LightGeometry::Point { position: lp, .. } => {
            let a = (o - lp).dot(n);
            if a.is_nan() || a <= 1e-6 {
                return None;
            }
            // w = n·(P − Lp)/a is 1 on the window plane; w·(X − o) = w·(Lp − o) + (P − Lp)
            // for X the window point on the line from the light through P.
            let row = |d: Vec3| {
                let c = d.dot(lp - o);
                (d + n * (c / a)).extend(-c * n.dot(lp) / a - d.dot(lp))
            };
            [row(du), row(dv), Vec4::ZERO, (n / a).extend(-n.dot(lp) / a)]
        }
        LightGeometry::Directional { towards } => {
            let travel = -towards;
            let k = travel.dot(n);
            if k.is_nan() || k <= 1e-6 {
                return None;
            }
            // X = P − travel·(n·(P − o))/k; u = du·(X − o).
            let row = |d: Vec3| {
                let c = d.dot(travel) / k;
                (d - n * c).extend(c * n.dot(o) - d.dot(o))
            };
            [row(du), row(dv), Vec4::ZERO, Vec4::W]
        }
    };
    let m = Mat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose();
    m.is_finite().then_some(m)
}

/// Parameters of the god rays. Decay and weight are per unit of march (the march covers
/// `density` times the distance from a pixel to the light, at most `max_length`), so the
/// sample count changes the accuracy of the integral, not its look.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GodRaySettings {
    pub exposure: f32,
    /// Fraction of the light left after one whole march, in (0, 1].
    pub decay: f32,
    pub density: f32,
    pub weight: f32,
    pub samples: u32,
    /// Longest march, in units of half the screen height.
    pub max_length: f32,
    /// Largest value written, so one hot texel cannot saturate a whole ray.
    pub max_output: f32,
    /// God-ray target size relative to the frame: 1.0 full, 0.5 half, 0.25 quarter.
    pub resolution_scale: f32,
    /// Per-pixel jitter of the sample positions (trades banding for noise at low counts).
    pub jitter: bool,
}

impl Default for GodRaySettings {
    /// 128 samples at half resolution without jitter: on the Pareto front of the measured
    /// table ([`crate::budget`]; the numbers are in `docs/bench/README.md`), which the viewer's
    /// tests check. The rays are smooth, so half resolution costs little accuracy; without
    /// jitter frames do not shimmer (the seed changes per frame and nothing accumulates them).
    fn default() -> Self {
        Self {
            exposure: 0.35,
            decay: 0.25,
            density: 0.9,
            weight: 1.0,
            samples: 128,
            max_length: 3.0,
            max_output: 8.0,
            resolution_scale: 0.5,
            jitter: false,
        }
    }
}

/// How strongly the god rays show for this view: 1 while the light is within the view's
/// half-diagonal cone, falling smoothly to exactly 0 at 90° and beyond (behind the camera).
pub fn god_ray_fade(view: &View, light: &LightGeometry) -> f32 {
    let Some(to_light) = light.direction_from(view.position) else {
        return 0.0;
    };
    let cos = view.forward.dot(to_light);
    if cos.is_nan() || cos <= 0.0 {
        return 0.0;
    }
    let half_h = (view.fov_y * 0.5).tan();
    let half_diag = (half_h * half_h * (1.0 + view.aspect * view.aspect)).sqrt();
    let cos_edge = 1.0 / (1.0 + half_diag * half_diag).sqrt();
    let t = (cos / cos_edge).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The uniform block of the god-ray pass, and the fade it was built with. The light's clip
/// position is kept homogeneous; nothing here divides by its w.
pub fn god_ray_uniforms(
    settings: &GodRaySettings,
    view: &View,
    light: &LightGeometry,
    colour: Vec3,
    seed: u32,
) -> (crate::uniforms::GodRays, f32) {
    let clip = view.clip(light.homogeneous());
    let mut fade = god_ray_fade(view, light);
    if !clip.is_finite() || clip.w <= 0.0 {
        fade = 0.0;
    }
    let light = if fade > 0.0 {
        // Scale the homogeneous vector to unit length: the same point, and far from f32 limits
        // whatever the scene's units.
        let l = Vec4::new(clip.x * view.aspect, clip.y, 0.0, clip.w);
        l / l.length()
    } else {
        Vec4::ZERO
    };
    let decay = if settings.decay > 0.0 {
        settings.decay.min(1.0)
    } else {
        1e-6
    };
    let c = colour * settings.exposure * fade;
    let u = crate::uniforms::GodRays {
        light: light.to_array(),
        colour: c.extend(0.0).to_array(),
        density: settings.density.max(0.0),
        ln_decay: decay.ln(),
        weight: settings.weight.max(0.0),
        max_length: settings.max_length.max(0.0),
        aspect: view.aspect,
        jitter: if settings.jitter { 1.0 } else { 0.0 },
        max_output: settings.max_output.max(0.0),
        samples: settings
            .samples
            .clamp(1, crate::uniforms::MAX_GOD_RAY_SAMPLES),
        seed,
        ..Default::default()
    };
    (u, fade)
}

/// Bilinear sample of an RGBA f32 image with clamp-to-edge addressing and texel centres at
/// half-integers, as the GPU's linear sampler does.
fn sample_bilinear(image: &[[f32; 4]], w: usize, h: usize, uv: Vec2) -> Vec3 {
    let x = uv.x * w as f32 - 0.5;
    let y = uv.y * h as f32 - 0.5;
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |xi: f32, yi: f32| {
        let xi = (xi as i64).clamp(0, w as i64 - 1) as usize;
        let yi = (yi as i64).clamp(0, h as i64 - 1) as usize;
        let p = image[yi * w + xi];
        Vec3::new(p[0], p[1], p[2])
    };
    let top = at(x0, y0).lerp(at(x0 + 1.0, y0), fx);
    let bottom = at(x0, y0 + 1.0).lerp(at(x0 + 1.0, y0 + 1.0), fx);
    top.lerp(bottom, fy)
}

/// CPU reference of the god-ray shader without jitter: the same march over `mask`
/// (`mask_w`×`mask_h`, RGBA linear), evaluated at the pixel centres of an `out_w`×`out_h` image.
pub fn god_rays_reference(
    u: &crate::uniforms::GodRays,
    mask: &[[f32; 4]],
    mask_w: usize,
    mask_h: usize,
    out_w: usize,
    out_h: usize,
) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; out_w * out_h];
    let l = Vec4::from(u.light);
    if l.w.is_nan() || l.w <= 0.0 {
        return out;
    }
    let crate::uniforms::GodRays {
        aspect,
        density,
        ln_decay,
        weight,
        max_length,
        ..
    } = *u;
    let samples = u.samples.max(1);
    let n = samples as f32;
    for y in 0..out_h {
        for x in 0..out_w {
            let uv = Vec2::new(
                (x as f32 + 0.5) / out_w as f32,
                (y as f32 + 0.5) / out_h as f32,
            );
            let p = Vec2::new((uv.x * 2.0 - 1.0) * aspect, 1.0 - uv.y * 2.0);
            let d = Vec2::new(l.x, l.y) - p * l.w;
            let dl = d.length();
            let (dir, march) = if dl > 0.0 {
                let m = if density * dl >= max_length * l.w {
                    max_length
                } else {
                    density * dl / l.w
                };
                (d / dl, m)
            } else {
                (Vec2::ZERO, 0.0)
            };
            let mut sum = Vec3::ZERO;
            for i in 0..samples {
                let t = (i as f32 + 0.5) / n;
                let s = p + dir * (march * t);
                let suv = Vec2::new((s.x / aspect) * 0.5 + 0.5, 0.5 - s.y * 0.5);
                if (0.0..=1.0).contains(&suv.x) && (0.0..=1.0).contains(&suv.y) {
                    sum += sample_bilinear(mask, mask_w, mask_h, suv)
                        * (weight / n * (ln_decay * t).exp());
                }
            }
            let c = Vec3::new(u.colour[0], u.colour[1], u.colour[2]);
            out[y * out_w + x] = (sum * c).clamp(Vec3::ZERO, Vec3::splat(u.max_output));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window() -> pack::Window {
        pack::Window {
            material: 0,
            origin: [-1.0, 1.0, 0.0],
            u_axis: [2.0, 0.0, 0.0],
            v_axis: [0.0, 2.0, 0.0],
            normal: [0.0, 0.0, -1.0],
            source_materials: Vec::new(),
        }
    }

    fn project(m: Mat4, p: Vec3) -> Option<Vec2> {
        let c = m * p.extend(1.0);
        (c.w > 0.0).then(|| Vec2::new(c.x / c.w, c.y / c.w))
    }

    /// A point at frame coordinates `(u, v)` samples the texture of margin `m` at
    /// `(u + m) / (1 + 2m)`, as the pack format says, under either kind of light.
    #[test]
    fn a_projector_frame_maps_the_window_into_its_margin() {
        let margin = [0.25f32, 0.1];
        let grown = projector_frame(&window(), margin);
        let lights = [
            LightGeometry::Point {
                position: Vec3::new(0.5, 3.0, 4.0),
                radius: 0.1,
            },
            LightGeometry::Directional {
                towards: Vec3::new(0.2, 0.3, 1.0).normalize(),
            },
        ];
        for light in lights {
            let m = window_projector(&grown, &light).expect("light outside");
            for (u, v) in [(0.0f32, 0.0f32), (1.0, 1.0), (0.3, 0.8), (-0.25, 1.1)] {
                let on = Vec3::new(-1.0, 1.0, 0.0)
                    + Vec3::new(2.0, 0.0, 0.0) * u
                    + Vec3::new(0.0, 2.0, 0.0) * v;
                let want = Vec2::new(
                    (u + margin[0]) / (1.0 + 2.0 * margin[0]),
                    (v + margin[1]) / (1.0 + 2.0 * margin[1]),
                );
                let got = project(m, on).unwrap();
                assert!(
                    (got - want).length() < 1e-5,
                    "({u}, {v}): {got} against {want}"
                );
            }
        }
        // Without a margin the frame is the window's.
        assert_eq!(projector_frame(&window(), [0.0; 2]), window());
    }

    #[test]
    fn point_projector_follows_the_ray_through_the_window() {
        let lp = Vec3::new(0.5, 3.0, 4.0);
        let light = LightGeometry::Point {
            position: lp,
            radius: 0.1,
        };
        let m = window_projector(&window(), &light).expect("light outside");
        // A point on the window maps to its own design coordinates with w = 1.
        let on = Vec3::new(-1.0, 1.0, 0.0)
            + Vec3::new(2.0, 0.0, 0.0) * 0.25
            + Vec3::new(0.0, 2.0, 0.0) * 0.75;
        let c = m * on.extend(1.0);
        assert!((c.w - 1.0).abs() < 1e-5, "{c}");
        assert!((project(m, on).unwrap() - Vec2::new(0.25, 0.75)).length() < 1e-5);
        // Any point further along the same ray gets the same coordinates.
        let beyond = lp + (on - lp) * 2.7;
        assert!((project(m, beyond).unwrap() - Vec2::new(0.25, 0.75)).length() < 1e-4);
        // Behind the light: w < 0, rejected.
        let behind = lp - (on - lp);
        assert!(project(m, behind).is_none());
    }

    #[test]
    fn directional_projector_is_orthographic_and_one_sided() {
        let travel = Vec3::new(0.3, -0.5, -1.0).normalize();
        let light = LightGeometry::Directional { towards: -travel };
        let m = window_projector(&window(), &light).expect("travels inwards");
        let on = Vec3::new(0.0, 2.0, 0.0);
        let uv = project(m, on).unwrap();
        assert!((uv - Vec2::new(0.5, 0.5)).length() < 1e-5, "{uv}");
        let beyond = on + travel * 5.0;
        assert!((project(m, beyond).unwrap() - uv).length() < 1e-4);
        let outwards = LightGeometry::Directional { towards: travel };
        assert!(window_projector(&window(), &outwards).is_none());
        let inside = LightGeometry::Point {
            position: Vec3::new(0.0, 1.0, -2.0),
            radius: 0.1,
        };
        assert!(window_projector(&window(), &inside).is_none());
    }

    /// The same camera and lamp 1e5 from the origin give the lamp the clip position they give
    /// at the origin; the world view-projection matrix loses ~1e-2 there, the relative path
    /// only the rounding of its inputs.
    #[test]
    fn clip_positions_do_not_depend_on_the_distance_from_the_origin() {
        let eye = Vec3::new(0.5, 1.5, 9.0);
        let lamp = Vec4::new(1.0, 5.0, -3.0, 1.0);
        let near = View::look(
            eye,
            Vec3::new(0.0, 0.3, -1.0),
            Vec3::Y,
            60.0,
            1.6,
            0.05,
            300.0,
        );
        let expected = near.view_proj() * lamp;
        assert!((near.clip(lamp) - expected).length() < 1e-5);
        let offset = Vec3::splat(1e5);
        let far = View::look(
            eye + offset,
            Vec3::new(0.0, 0.3, -1.0),
            Vec3::Y,
            60.0,
            1.6,
            0.05,
            300.0,
        );
        let shifted = (lamp.truncate() + offset).extend(1.0);
        let got = far.clip(shifted);
        assert!(
            (got - expected).length() < 1e-5 * expected.length(),
            "{got} vs {expected}"
        );
        // Directions are unaffected by the camera's position.
        let sun = Vec4::new(0.1, 0.4, -0.9, 0.0);
        assert!((far.clip(sun) - near.view_proj() * sun).length() < 1e-5);
    }

    #[test]
    fn fade_is_exactly_zero_at_and_beyond_perpendicular() {
        let light = LightGeometry::Directional {
            towards: Vec3::new(0.0, 0.0, -1.0),
        };
        let mut previous = 1.0f32;
        for deg in 0..=180 {
            let a = (deg as f32).to_radians();
            let forward = Vec3::new(a.sin(), 0.0, -a.cos());
            let view = View::look(Vec3::ZERO, forward, Vec3::Y, 60.0, 16.0 / 9.0, 0.1, 100.0);
            let f = god_ray_fade(&view, &light);
            assert!(f.is_finite() && (0.0..=1.0).contains(&f));
            assert!(f <= previous + 1e-6, "fade rises at {deg}°");
            assert!(
                (previous - f).abs() < 0.1,
                "fade jumps at {deg}°: {previous} -> {f}"
            );
            if deg >= 90 {
                assert_eq!(f, 0.0, "{deg}°");
                let (u, _) =
                    god_ray_uniforms(&GodRaySettings::default(), &view, &light, Vec3::ONE, 0);
                assert_eq!(u.colour, [0.0; 4]);
            }
            previous = f;
        }
    }
}

#[cfg(test)]
mod march_tests {
    use super::*;

    /// Around the perpendicular view, where the light's w goes to zero, the march stays finite
    /// and changes smoothly: the CPU march over a mask with a bright bar, in 0.05° steps.
    #[test]
    fn march_is_finite_and_continuous_as_w_goes_to_zero() {
        let (w, h) = (32usize, 18usize);
        let mut mask = vec![[0.0f32; 4]; w * h];
        for y in 4..14 {
            for x in 20..24 {
                mask[y * w + x] = [1.0, 0.5, 0.2, 1.0];
            }
        }
        let light = LightGeometry::Directional {
            towards: Vec3::new(1.0, 0.2, 0.0).normalize(),
        };
        let settings = GodRaySettings {
            samples: 32,
            ..Default::default()
        };
        let mut energies = Vec::new();
        let mut deg = 70.0f32;
        while deg <= 95.0 {
            let a = deg.to_radians();
            // Turn away from the light about the vertical axis.
            let forward = Vec3::new(a.cos(), 0.0, -a.sin());
            let view = View::look(
                Vec3::ZERO,
                forward,
                Vec3::Y,
                60.0,
                w as f32 / h as f32,
                0.1,
                100.0,
            );
            let (u, fade) = god_ray_uniforms(&settings, &view, &light, Vec3::ONE, 0);
            assert!(
                u.light
                    .iter()
                    .chain(&u.colour)
                    .chain(&[u.density, u.ln_decay, u.weight, u.max_length])
                    .all(|v| v.is_finite()),
                "{deg}°: {u:?}"
            );
            let out = god_rays_reference(&u, &mask, w, h, w, h);
            let energy: f32 = out.iter().map(|c| c.element_sum()).sum();
            assert!(energy.is_finite(), "{deg}°");
            if deg >= 90.0 {
                assert_eq!(energy, 0.0, "{deg}°, fade {fade}");
            }
            energies.push((deg, energy));
            deg += 0.05;
        }
        let peak = energies.iter().map(|e| e.1).fold(0.0f32, f32::max);
        assert!(peak > 0.0);
        for pair in energies.windows(2) {
            let step = (pair[1].1 - pair[0].1).abs() / peak;
            assert!(
                step <= 0.01,
                "jump of {step} of the peak between {}° and {}°",
                pair[0].0,
                pair[1].0
            );
        }
    }
}
