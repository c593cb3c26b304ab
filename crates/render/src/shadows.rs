//! Where the shadow maps look from and what they cover: plain CPU math, so tests can check it
//! without a device.
//!
//! - The sun: one orthographic map, square in light space, fitted to the union of the
//!   windows' light prisms (each window's rectangle swept along the light keeps its light-space
//!   footprint), over the depth range of the opaque geometry.
//! - A lamp: one perspective map per window, a spot frustum from the lamp through the window's
//!   rectangle (with a small margin), from near the lamp to the farthest opaque geometry.
//!
//! Only windows whose light can be blocked ([`crate::occlusion`]) get a map.
//!
//! Depth along the light, ℓ, is what the lit pass compares: for the sun the distance along the
//! travel direction in world units, for a lamp `w`, the distance from the lamp along the
//! window's normal divided by the lamp's distance to the window's plane (1 on the glass).

use glam::{DMat4, DVec2, DVec3, DVec4, Mat4, Vec3};

use crate::occlusion::WindowShadow;
use crate::view::{LightGeometry, window_projector, window_relative_to};

/// Fraction of the window's size added around a lamp's map, so filter taps at the edge of
/// the light still read depths.
const LAMP_MARGIN: f64 = 0.02;
/// Fraction of the sun's footprint added on each side, for the same reason.
const SUN_MARGIN: f64 = 0.02;

/// One layer of the shadow-map array: what the depth pass draws with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapLayer {
    /// Positions minus [`MapLayer::origin`] to clip space.
    pub view_proj: Mat4,
    /// World origin of the layer's local frame (vertices are made relative to it first).
    pub origin: DVec3,
    /// Whether the backed windows' uncut walls are drawn too ([`crate::occlusion::Backings`]):
    /// they stop the direct sun ([`ShadowLayout::direct`]), not the light through the glass.
    pub uncut_walls: bool,
}

/// How one window's light looks its shadow up.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WindowMap {
    pub layer: u32,
    /// Positions minus `origin` to `(u·w, v·w, z·w, w)`: texture coordinates and depth.
    pub lookup: DMat4,
    pub origin: DVec3,
    /// Unit world directions in which the map's texture u and v grow.
    pub x_dir: Vec3,
    pub y_dir: Vec3,
    /// World size of one texel along u and v (for a lamp: on the window's plane, ℓ = 1).
    pub texel: [f32; 2],
    /// Depth range in ℓ.
    pub near: f32,
    pub far: f32,
    /// The lamp's distance to the window's plane (world units per ℓ); 0 for the sun.
    pub lamp_distance: f32,
    /// The sun's travel direction, or the window's inward normal for a lamp (ℓ grows along it).
    pub depth_dir: Vec3,
    /// The sun's angular diameter in radians, or the lamp's diameter.
    pub light_size: f32,
}

impl WindowMap {
    /// The lookup for a camera at `camera`: camera-relative positions to the map (the
    /// difference of the two origins taken in f64, rounded once).
    pub fn lookup_relative(&self, camera: Vec3) -> Mat4 {
        let shift = camera.as_dvec3() - self.origin;
        (self.lookup * DMat4::from_translation(shift)).as_mat4()
    }

    /// Where the light line through each position of this map crosses the window's plane,
    /// for a camera at `camera`: `projector` is the window's projector frame
    /// ([`crate::view::projector_frame`], camera-relative, as the lit pass gets it), `frame`
    /// that frame, `margin` its material's projector margin, `size` the map's side in texels.
    /// `None` where the map cannot be inverted.
    pub fn aperture(
        &self,
        camera: Vec3,
        projector: Mat4,
        frame: &pack::Window,
        margin: [f32; 2],
        size: u32,
    ) -> Option<Aperture> {
        let shift = camera.as_dvec3() - self.origin;
        let lookup = self.lookup * DMat4::from_translation(shift);
        let map = projector.as_dmat4() * lookup.inverse();
        if !map.is_finite() {
            return None;
        }
        let st = |uv: DVec2, z: f64| {
            let c = map * DVec4::new(uv.x, uv.y, z, 1.0);
            (c.w > 0.0).then(|| DVec2::new(c.x, c.y) / c.w)
        };
        // One texel of the map, at the glass's centre, in the projector's coordinates.
        let centre = Vec3::from(frame.origin).as_dvec3()
            + 0.5 * (Vec3::from(frame.u_axis).as_dvec3() + Vec3::from(frame.v_axis).as_dvec3());
        let c = lookup * centre.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let (uv, z) = (DVec2::new(c.x, c.y) / c.w, c.z / c.w);
        let texel = 1.0 / size.max(1) as f64;
        let at = st(uv, z)?;
        let du = st(uv + DVec2::new(texel, 0.0), z)? - at;
        let dv = st(uv + DVec2::new(0.0, texel), z)? - at;
        let reach = du.abs() + dv.abs();
        // The frame spans the glass grown by `margin` (in glass sizes) on each side.
        let inset = |m: f32| m as f64 / (1.0 + 2.0 * m as f64);
        let lo = DVec2::new(inset(margin[0]), inset(margin[1])) + reach;
        let hi = DVec2::ONE - DVec2::new(inset(margin[0]), inset(margin[1])) - reach;
        // Glass under two texels across keeps its centre line (the frame is centred on it), so
        // the nearest point of the glass stays defined.
        let (lo, hi) = (lo.min(DVec2::splat(0.5)), hi.max(DVec2::splat(0.5)));
        Some(Aperture {
            map,
            bounds: [lo.x, lo.y, hi.x, hi.y],
        })
    }

    /// Texture coordinates and depth (`z` in [0, 1]) of a world point, for tests.
    pub fn project(&self, p: DVec3) -> Option<DVec3> {
        let c = self.lookup * (p - self.origin).extend(1.0);
        (c.w > 0.0).then(|| c.truncate() / c.w)
    }

    /// ℓ of a stored depth.
    pub fn linear_depth(&self, z: f32) -> f32 {
        let (n, f) = (self.near, self.far);
        if self.lamp_distance > 0.0 {
            f * n / (f - z * (f - n))
        } else {
            n + z * (f - n)
        }
    }
}

/// A window's glass as its shadow map sees it ([`WindowMap::aperture`]), for the lit pass's
/// `shadow_visibility`.
///
/// The projector and the map both look from the light, so the light line through a map
/// position is one ray whatever the depth, and it crosses the window's plane at one point.
/// Where that point is off the glass, the wall around the window stops the ray, and the
/// projector's texture (nothing outside the glass, blurred by the light's size) already says
/// so; the map's taps there would count the same wall a second time, a second penumbra on top
/// of the projector's own (windows in deep openings drew darker edges than the reference).
/// So the lit pass averages its taps over those whose ray crosses the glass: of the light
/// that passes the window, how much nothing else stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aperture {
    /// Map `(u, v, z, 1)` to the projector's `(s·q, t·q, ·, q)`, any `z`.
    pub map: DMat4,
    /// The glass in `(s, t)`, min then max, less one map texel on each side: a tap mixes the
    /// texels around it, and the wall's reach up to the glass's edge.
    pub bounds: [f64; 4],
}

/// Every layer and, per window (TOC order), its map or `None` (no map: never shadowed).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct ShadowLayout {
    pub layers: Vec<MapLayer>,
    pub windows: Vec<Option<WindowMap>>,
    /// The light's map over all the opaque geometry: whether a point on the outer side of a
    /// window's plane sees the light directly. A window's plane runs on through the building
    /// (the nave beyond a transept's window, the chapels beside an aisle's), so the outer
    /// side of it is not the outside; without this map such floors were lit by the full sun
    /// under their roof. For a lamp, a perspective map through a frame facing it
    /// ([`lamp_frame`]); `None` where none fits (the lamp among the geometry), and its light
    /// stays unblocked there.
    pub direct: Option<WindowMap>,
}

/// Bounds of the opaque geometry.
pub fn bounds(triangles: impl IntoIterator<Item = [Vec3; 3]>) -> Option<(DVec3, DVec3)> {
    let mut lo = DVec3::splat(f64::INFINITY);
    let mut hi = DVec3::splat(f64::NEG_INFINITY);
    for t in triangles {
        for p in t {
            lo = lo.min(p.as_dvec3());
            hi = hi.max(p.as_dvec3());
        }
    }
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

fn corners((lo, hi): (DVec3, DVec3)) -> [DVec3; 8] {
    std::array::from_fn(|k| {
        DVec3::new(
            if k & 1 == 0 { lo.x } else { hi.x },
            if k & 2 == 0 { lo.y } else { hi.y },
            if k & 4 == 0 { lo.z } else { hi.z },
        )
    })
}

/// Lays out the maps for `light` over `windows`, given which need one and the bounds of the
/// opaque geometry. `size` is a layer's width in texels.
/// `beyond`: whether opaque geometry reaches beyond a window's plane, so the light's direct map
/// is needed ([`crate::occlusion::beyond_windows`]).
pub fn layout(
    windows: &[pack::Window],
    decisions: &[WindowShadow],
    light: &pack::Light,
    geometry: Option<(DVec3, DVec3)>,
    beyond: bool,
    size: u32,
) -> ShadowLayout {
    let mut out = ShadowLayout {
        layers: Vec::new(),
        windows: vec![None; windows.len()],
        direct: None,
    };
    let Some(bounds) = geometry else {
        return out;
    };
    let geometry = LightGeometry::from_light(light);
    if beyond && !windows.is_empty() {
        out.direct = match (&light.kind, geometry) {
            (
                pack::LightKind::Directional { angular_size, .. },
                LightGeometry::Directional { towards },
            ) => {
                let centre = (bounds.0 + bounds.1) * 0.5;
                let sun = Sun::new(towards, *angular_size);
                Some(sun.map(
                    &mut out.layers,
                    centre,
                    &corners(bounds),
                    bounds,
                    size,
                    true,
                ))
            }
            (
                pack::LightKind::Point { radius, .. } | pack::LightKind::Spot { radius, .. },
                LightGeometry::Point { position, .. },
            ) => lamp_frame(position, bounds).and_then(|frame| {
                let layers = &mut out.layers;
                lamp_map(layers, &frame, position, *radius, bounds, size, true)
            }),
            _ => None,
        };
    }
    let needed: Vec<usize> = (0..windows.len())
        .filter(|&i| decisions.get(i).is_some_and(WindowShadow::needs_map))
        .filter(|&i| window_projector(&windows[i], &geometry).is_some())
        .collect();
    if needed.is_empty() {
        return out;
    }
    match (&light.kind, geometry) {
        (
            pack::LightKind::Directional { angular_size, .. },
            LightGeometry::Directional { towards },
        ) => {
            let rect = |w: &pack::Window| {
                let o = Vec3::from(w.origin).as_dvec3();
                let (u, v) = (
                    Vec3::from(w.u_axis).as_dvec3(),
                    Vec3::from(w.v_axis).as_dvec3(),
                );
                [o, o + u, o + v, o + u + v]
            };
            let points: Vec<DVec3> = needed.iter().flat_map(|&i| rect(&windows[i])).collect();
            let origin = points.iter().sum::<DVec3>() / points.len() as f64;
            let map = Sun::new(towards, *angular_size).map(
                &mut out.layers,
                origin,
                &points,
                bounds,
                size,
                false,
            );
            for &i in &needed {
                out.windows[i] = Some(map);
            }
        }
        (
            pack::LightKind::Point { radius, .. } | pack::LightKind::Spot { radius, .. },
            LightGeometry::Point { position, .. },
        ) => {
            for &i in &needed {
                out.windows[i] = lamp_map(
                    &mut out.layers,
                    &windows[i],
                    position,
                    *radius,
                    bounds,
                    size,
                    false,
                );
            }
        }
        _ => {}
    }
    out
}

/// Bytes the shadow maps may take (32-bit depth, one level): a lamp's 1024² maps are 4 MiB a
/// layer, so 256 windows keep them whole and more share this at a smaller size.
pub const MAPS_BUDGET: u64 = 1 << 30;

/// The layer size for `layers` maps of at most `size` texels a side within [`MAPS_BUDGET`]:
/// halved until they fit (not below 16, the least the settings give).
pub fn fitted_layer_size(size: u32, layers: usize) -> u32 {
    crate::side_within(size, MAPS_BUDGET, |s| {
        layers as u64 * s as u64 * s as u64 * 4
    })
}

/// A lamp's perspective map through window `w`'s rectangle (with a margin), from near the lamp
/// to the farthest of `bounds`; pushed onto `layers`. `None` when the lamp does not face it.
fn lamp_map(
    layers: &mut Vec<MapLayer>,
    w: &pack::Window,
    position: Vec3,
    radius: f32,
    bounds: (DVec3, DVec3),
    size: u32,
    uncut_walls: bool,
) -> Option<WindowMap> {
    let origin = Vec3::from(w.origin).as_dvec3();
    let local = window_relative_to(w, origin.as_vec3());
    let lamp = LightGeometry::Point {
        position: (position.as_dvec3() - origin).as_vec3(),
        radius,
    };
    let p = window_projector(&local, &lamp)?.as_dmat4();
    let n = Vec3::from(w.normal).as_dvec3().normalize();
    let a = (origin - position.as_dvec3()).dot(n);
    let w_of = |q: DVec3| (q - position.as_dvec3()).dot(n) / a;
    let (mut near, mut far) = (f64::INFINITY, f64::NEG_INFINITY);
    for q in corners(bounds) {
        near = near.min(w_of(q));
        far = far.max(w_of(q));
    }
    // Nothing closer to the lamp than this fraction of the way to the window is drawn: depth
    // precision would suffer, and such a blocker would be the lamp's own fitting.
    let near = near.max(0.05);
    let far = far.max(1.0) * 1.01;
    let k = 1.0 / (1.0 + 2.0 * LAMP_MARGIN);
    let m = LAMP_MARGIN * k;
    // (u'·w, v'·w) with u' = (u + margin)·k; depth z·w = f(w − n)/(f − n).
    let (ru, rv, rw) = (p.row(0), p.row(1), p.row(3));
    let row_u = ru * k + rw * m;
    let row_v = rv * k + rw * m;
    let row_z = rw * (far / (far - near)) - DVec4::W * (far * near / (far - near));
    let lookup = DMat4::from_cols(row_u, row_v, row_z, rw).transpose();
    let layer = layers.len() as u32;
    layers.push(MapLayer {
        view_proj: (LOOKUP_TO_CLIP * lookup).as_mat4(),
        origin,
        uncut_walls,
    });
    let (u, v) = (Vec3::from(w.u_axis), Vec3::from(w.v_axis));
    Some(WindowMap {
        layer,
        lookup,
        origin,
        x_dir: u.normalize_or_zero(),
        y_dir: v.normalize_or_zero(),
        texel: [
            (u.length() as f64 / (k * size.max(1) as f64)) as f32,
            (v.length() as f64 / (k * size.max(1) as f64)) as f32,
        ],
        near: near as f32,
        far: far as f32,
        lamp_distance: a as f32,
        depth_dir: n.as_vec3(),
        light_size: 2.0 * radius.max(0.0),
    })
}

/// A rectangle facing the lamp at `position`, as far from it as the nearest corner of `bounds`
/// along the way to their centre, through which the lamp sees all of `bounds`: the frame of
/// its map over all the geometry. `None` when no such frame is sensible: the lamp among the
/// geometry, or the geometry wider than 160° seen from it.
fn lamp_frame(position: Vec3, bounds: (DVec3, DVec3)) -> Option<pack::Window> {
    let lamp = position.as_dvec3();
    let inside = lamp.cmpge(bounds.0).all() && lamp.cmple(bounds.1).all();
    let axis = ((bounds.0 + bounds.1) * 0.5 - lamp).normalize_or_zero();
    if inside || axis == DVec3::ZERO {
        return None;
    }
    let all = corners(bounds);
    let along: Vec<f64> = all.iter().map(|c| (*c - lamp).dot(axis)).collect();
    let a = along.iter().copied().fold(f64::INFINITY, f64::min);
    let farthest = along.iter().copied().fold(0.0, f64::max);
    if a.is_nan() || a <= 1e-6 * farthest {
        return None;
    }
    let (right, up) = across(axis);
    // The corners seen from the lamp, on the frame's plane.
    let seen = all.iter().zip(&along).map(|(c, l)| (*c - lamp) * (a / l));
    let (lo, hi) = spread(seen, right, up);
    // tan 80°: wider, the perspective's far texels would be too coarse to say anything.
    if lo.abs().max(hi.abs()).max_element() > 5.67 * a {
        return None;
    }
    let corner = lamp + axis * a + right * lo.x + up * hi.y;
    Some(pack::Window {
        material: 0,
        origin: corner.as_vec3().to_array(),
        u_axis: (right * (hi.x - lo.x)).as_vec3().to_array(),
        v_axis: (-up * (hi.y - lo.y)).as_vec3().to_array(),
        normal: axis.as_vec3().to_array(),
        source_materials: Vec::new(),
    })
}

/// Clip x = 2u − 1, y = 1 − 2v, z as is, from a lookup's (u, v, z, w).
const LOOKUP_TO_CLIP: DMat4 = DMat4::from_cols(
    DVec4::new(2.0, 0.0, 0.0, 0.0),
    DVec4::new(0.0, -2.0, 0.0, 0.0),
    DVec4::new(0.0, 0.0, 1.0, 0.0),
    DVec4::new(-1.0, 1.0, 0.0, 1.0),
);

/// Two unit axes across `dir` (a unit vector), the second as near to world up as the first
/// allows.
fn across(dir: DVec3) -> (DVec3, DVec3) {
    let hint = if dir.y.abs() < 0.99 {
        DVec3::Y
    } else {
        DVec3::X
    };
    let right = dir.cross(hint).normalize();
    (right, right.cross(dir))
}

/// The smallest and largest `(p·right, p·up)` of `points`.
fn spread(points: impl IntoIterator<Item = DVec3>, right: DVec3, up: DVec3) -> (DVec2, DVec2) {
    points.into_iter().fold(
        (DVec2::splat(f64::INFINITY), DVec2::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| {
            let q = DVec2::new(p.dot(right), p.dot(up));
            (lo.min(q), hi.max(q))
        },
    )
}

/// The sun's frame: its travel direction and two axes across it.
struct Sun {
    travel: DVec3,
    right: DVec3,
    up: DVec3,
    angular_size: f32,
}

impl Sun {
    fn new(towards: Vec3, angular_size: f32) -> Self {
        let travel = (-towards).as_dvec3().normalize();
        let (right, up) = across(travel);
        Self {
            travel,
            right,
            up,
            angular_size,
        }
    }

    /// An orthographic map, square across the light, covering `points` (seen along the
    /// light) over the depth range of `bounds`; pushed onto `layers`.
    fn map(
        &self,
        layers: &mut Vec<MapLayer>,
        origin: DVec3,
        points: &[DVec3],
        bounds: (DVec3, DVec3),
        size: u32,
        uncut_walls: bool,
    ) -> WindowMap {
        let (right, up, t) = (self.right, self.up, self.travel);
        let (lo, hi) = spread(points.iter().map(|p| *p - origin), right, up);
        let extent = (hi - lo).max_element().max(1e-6) * (1.0 + 2.0 * SUN_MARGIN);
        let (cx, cy) = ((lo.x + hi.x) * 0.5, (lo.y + hi.y) * 0.5);
        let (mut near, mut far) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in corners(bounds) {
            let l = (p - origin).dot(t);
            near = near.min(l);
            far = far.max(l);
        }
        let pad = (far - near).max(1e-3) * 0.01;
        let (near, far) = (near - pad, far + pad);
        // Rows of the lookup: u = (x − x0)/E, v = (y1 − y)/E, z = (ℓ − near)/(far − near).
        let (xa, ya) = (cx - extent * 0.5, cy + extent * 0.5);
        let row_u = (right / extent).extend(-xa / extent);
        let row_v = (-up / extent).extend(ya / extent);
        let row_z = (t / (far - near)).extend(-near / (far - near));
        let lookup = DMat4::from_cols(row_u, row_v, row_z, DVec4::W).transpose();
        let layer = layers.len() as u32;
        layers.push(MapLayer {
            view_proj: (LOOKUP_TO_CLIP * lookup).as_mat4(),
            origin,
            uncut_walls,
        });
        let texel = (extent / size.max(1) as f64) as f32;
        WindowMap {
            layer,
            lookup,
            origin,
            x_dir: right.as_vec3(),
            y_dir: (-up).as_vec3(),
            texel: [texel; 2],
            near: near as f32,
            far: far as f32,
            lamp_distance: 0.0,
            depth_dir: t.as_vec3(),
            light_size: self.angular_size.max(0.0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::occlusion::Blocker;

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

    fn light(kind: pack::LightKind) -> pack::Light {
        pack::Light {
            kind,
            colour: [1.0; 3],
            intensity: 1.0,
        }
    }

    /// A sun and a lamp, both lighting [`window`] from outside.
    fn sun_and_lamp() -> [pack::Light; 2] {
        [
            light(pack::LightKind::Directional {
                direction: [0.2, -0.6, 1.0],
                angular_size: 0.01,
            }),
            light(pack::LightKind::Point {
                position: [0.5, 5.0, -4.0],
                radius: 0.1,
            }),
        ]
    }

    /// The direction `l`'s light travels in at `p`.
    fn travel(l: &pack::Light, p: DVec3) -> DVec3 {
        match l.kind {
            pack::LightKind::Directional { direction, .. } => {
                Vec3::from(direction).as_dvec3().normalize()
            }
            pack::LightKind::Point { position, .. } | pack::LightKind::Spot { position, .. } => {
                (p - Vec3::from(position).as_dvec3()).normalize()
            }
        }
    }

    const BOUNDS: (DVec3, DVec3) = (DVec3::new(-10.0, 0.0, -1.0), DVec3::new(10.0, 8.0, 20.0));

    /// Points on the line of light through a window point share texture coordinates, and the
    /// depth grows along the light; the window's corners land inside the map.
    #[test]
    fn maps_follow_the_light_through_the_window() {
        let occluded = [WindowShadow::Occluded(Blocker::Inside)];
        for l in sun_and_lamp() {
            let layout = layout(&[window()], &occluded, &l, Some(BOUNDS), false, 1024);
            assert_eq!(layout.layers.len(), 1);
            let map = layout.windows[0].expect("a map");
            let on = DVec3::new(0.3, 2.2, 0.0);
            let travel = travel(&l, on);
            let a = map.project(on).unwrap();
            let b = map.project(on + travel * 3.0).unwrap();
            assert!((a.truncate() - b.truncate()).length() < 1e-6, "{a} {b}");
            assert!(b.z > a.z && (0.0..=1.0).contains(&a.z) && (0.0..=1.0).contains(&b.z));
            for corner in [[-1.0, 3.0], [1.0, 3.0], [-1.0, 1.0], [1.0, 1.0]] {
                let c = map.project(DVec3::new(corner[0], corner[1], 0.0)).unwrap();
                assert!(
                    (0.0..=1.0).contains(&c.x) && (0.0..=1.0).contains(&c.y),
                    "{c}"
                );
            }
            // The linear depth of a stored depth matches ℓ.
            let ell = |p: DVec3| match l.kind {
                pack::LightKind::Directional { .. } => (p - map.origin).dot(travel),
                pack::LightKind::Point { position, .. }
                | pack::LightKind::Spot { position, .. } => {
                    (p - Vec3::from(position).as_dvec3()).z / map.lamp_distance as f64
                }
            };
            let p = on + travel * 3.0;
            let z = map.project(p).unwrap().z as f32;
            let (l0, l1) = (map.linear_depth(z) as f64, ell(p));
            assert!((l0 - l1).abs() < 1e-4 * l1.abs().max(1.0), "{l0} {l1}");
            // The render matrix agrees with the lookup.
            let layer = layout.layers[0];
            let clip = layer.view_proj.as_dmat4() * (p - layer.origin).extend(1.0);
            let ndc = clip.truncate() / clip.w;
            let uv = map.project(p).unwrap();
            assert!((ndc.x - (2.0 * uv.x - 1.0)).abs() < 1e-5);
            assert!((ndc.y - (1.0 - 2.0 * uv.y)).abs() < 1e-5);
        }
    }

    /// The light line through a map position crosses the window's plane where the aperture
    /// says, whatever its depth: glass points land inside the bounds, the wall past the
    /// glass's edge outside, and the bounds sit about a texel inside the glass.
    #[test]
    fn the_aperture_follows_light_lines_onto_the_glass() {
        let occluded = [WindowShadow::Occluded(Blocker::Inside)];
        let margin = [0.1, 0.25];
        let size = 1024;
        for l in sun_and_lamp() {
            let layout = layout(&[window()], &occluded, &l, Some(BOUNDS), false, size);
            let map = layout.windows[0].expect("a map");
            for camera in [Vec3::ZERO, Vec3::new(3.0, -2.0, 5.0)] {
                let frame =
                    window_relative_to(&crate::view::projector_frame(&window(), margin), camera);
                let g = LightGeometry::from_light(&l).relative_to(camera);
                let projector = window_projector(&frame, &g).expect("a projector");
                let a = map
                    .aperture(camera, projector, &frame, margin, size)
                    .expect("an aperture");
                let st = |p: DVec3| {
                    let c = map.project(p).unwrap();
                    let h = a.map * c.extend(1.0);
                    DVec2::new(h.x, h.y) / h.w
                };
                let inside = |v: DVec2| {
                    v.x >= a.bounds[0]
                        && v.y >= a.bounds[1]
                        && v.x <= a.bounds[2]
                        && v.y <= a.bounds[3]
                };
                // The glass's own coordinates (s, t) in the frame's.
                let framed = |s: f64, t: f64| {
                    let m = margin.map(|m| m as f64);
                    DVec2::new(
                        (s + m[0]) / (1.0 + 2.0 * m[0]),
                        (t + m[1]) / (1.0 + 2.0 * m[1]),
                    )
                };
                let on_glass = |s: f64, t: f64| DVec3::new(-1.0 + 2.0 * s, 3.0 - 2.0 * t, 0.0);
                for (s, t) in [(0.3, 0.6), (0.02, 0.97), (0.5, 0.5)] {
                    let p = on_glass(s, t);
                    for along in [0.0, 2.0, 7.0] {
                        let got = st(p + travel(&l, p) * along);
                        assert!((got - framed(s, t)).length() < 1e-4, "{got} at ({s}, {t})");
                        assert!(
                            inside(got),
                            "({s}, {t}) {along} along: {got} {:?}",
                            a.bounds
                        );
                    }
                }
                for (s, t) in [
                    (1.01, 0.5),
                    (-0.01, 0.5),
                    (0.5, 1.01),
                    (0.5, -0.01),
                    (1.3, 1.2),
                ] {
                    let p = on_glass(s, t);
                    assert!(!inside(st(p + travel(&l, p) * 2.0)), "({s}, {t})");
                }
                // About a texel inside the glass's edge, and no more.
                let edge = framed(0.0, 0.0);
                for k in 0..2 {
                    let gap = a.bounds[k] - edge[k];
                    assert!(gap > 0.0 && gap < 0.01, "{gap}");
                }
                // On a map too coarse for the glass, its centre is what is left.
                let coarse = map
                    .aperture(camera, projector, &frame, margin, 2)
                    .expect("an aperture");
                assert_eq!(coarse.bounds, [0.5; 4]);
            }
        }
    }

    #[test]
    fn many_maps_share_the_budget_at_a_smaller_size() {
        // A lamp's 1024² maps: 256 fit whole, more are halved, and whatever the count the
        // maps keep within the budget (down to 16 texels).
        assert_eq!(fitted_layer_size(1024, 256), 1024);
        assert_eq!(fitted_layer_size(1024, 257), 512);
        assert_eq!(fitted_layer_size(2048, 1), 2048);
        assert_eq!(fitted_layer_size(1024, 1 << 24), 16);
        for layers in [1, 100, 257, 1025, 2048] {
            let s = fitted_layer_size(2048, layers) as u64;
            assert!(layers as u64 * s * s * 4 <= MAPS_BUDGET, "{layers}");
        }
    }

    #[test]
    fn windows_that_need_no_map_get_none() {
        let sun = light(pack::LightKind::Directional {
            direction: [0.2, -0.6, 1.0],
            angular_size: 0.01,
        });
        let layout = layout(
            &[window()],
            &[WindowShadow::Clear],
            &sun,
            Some(BOUNDS),
            false,
            64,
        );
        assert!(layout.layers.is_empty() && layout.windows == vec![None]);
    }

    /// With geometry beyond a window's plane the light gets a map over all of it, drawn with
    /// the uncut walls, besides the windows' own.
    #[test]
    fn the_suns_direct_map_covers_all_the_geometry() {
        let sun = light(pack::LightKind::Directional {
            direction: [0.2, -0.6, 1.0],
            angular_size: 0.01,
        });
        let occluded = [WindowShadow::Occluded(Blocker::Inside)];
        let layout = layout(&[window()], &occluded, &sun, Some(BOUNDS), true, 1024);
        assert_eq!(layout.layers.len(), 2);
        let direct = layout.direct.expect("a direct map");
        let own = layout.windows[0].expect("the window's map");
        assert_ne!(direct.layer, own.layer);
        assert!(layout.layers[direct.layer as usize].uncut_walls);
        assert!(!layout.layers[own.layer as usize].uncut_walls);
        for c in corners(BOUNDS) {
            let p = direct.project(c).unwrap();
            for v in [p.x, p.y, p.z] {
                assert!((0.0..=1.0).contains(&v), "{c} lands at {p}");
            }
        }
        // Without windows needing maps, the direct map alone.
        let alone = layout_clear(&sun);
        assert_eq!((alone.layers.len(), alone.windows[0]), (1, None));
        assert!(alone.direct.is_some());
        // A lamp outside the geometry's bounds: a perspective map that sees all of it; among
        // the geometry, none.
        let lamp = |position| {
            light(pack::LightKind::Point {
                position,
                radius: 0.1,
            })
        };
        let outside = layout_clear(&lamp([0.5, 5.0, -4.0]));
        let direct = outside.direct.expect("a lamp's direct map");
        assert!(direct.lamp_distance > 0.0 && outside.layers[direct.layer as usize].uncut_walls);
        for c in corners(BOUNDS) {
            let p = direct.project(c).unwrap();
            for v in [p.x, p.y, p.z] {
                assert!((0.0..=1.0).contains(&v), "{c} lands at {p}");
            }
        }
        assert!(layout_clear(&lamp([0.5, 5.0, 4.0])).direct.is_none());
    }

    fn layout_clear(l: &pack::Light) -> ShadowLayout {
        layout(
            &[window()],
            &[WindowShadow::Clear],
            l,
            Some(BOUNDS),
            true,
            64,
        )
    }
}
