//! Uniform blocks shared with the WGSL structs of the same names. Layouts follow WGSL's
//! uniform rules (vec4-aligned members only, so no hidden padding); `tests/shaders.rs` checks
//! every size against naga's layout of the parsed shaders.

use bytemuck::{Pod, Zeroable};
use pack::MaterialClass;

/// The most windows the lit pass projects through; matches `MAX_WINDOWS` in `common.wgsl`.
/// Every lit fragment tests each window's projection, so this bounds that work. The windows
/// are a storage buffer ([`Windows`]), not a uniform block (whose 64 KiB held 192); the
/// device's texture array layers bound them too. Past either, [`crate::Scene::new`] keeps the
/// windows that pass light.
pub const MAX_WINDOWS: usize = 1024;

/// The most god-ray samples per pixel the renderer takes (the least is 1): the settings are
/// clamped to it, and the viewer's flag and slider offer this range.
pub const MAX_GOD_RAY_SAMPLES: u32 = 1024;

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Frame {
    pub view_proj: [[f32; 4]; 4],
    pub view: [[f32; 4]; 4],
    pub camera_pos: [f32; 4],
    pub light_pos: [f32; 4],
    pub light_colour: [f32; 4],
    pub ambient: [f32; 4],
    pub counts: [u32; 4],
    /// Bias (texels), smallest filter σ (texels), layer size (texels), occlusion on (0 or 1).
    pub shadow: [f32; 4],
    /// A spot light's cone as one affine ramp in the direction the light leaves along
    /// ([`Frame::spot_ramp`]); (0, 0, 0, 1) passes every direction whole.
    pub spot: [f32; 4],
    /// Lengths in the scene's units ([`Frame::lengths`]): x how far off a surface the lit
    /// pass's inside test steps, y that test's slack behind a window's plane.
    pub lengths: [f32; 4],
}

impl Frame {
    /// [`Self::lengths`] for a scene whose bounding box has diagonal `diag`: 0.01 and 0.001
    /// units for a scene 10 to 100 units across (a building in metres), shrunk with a smaller
    /// one and grown with a larger one, where f32 positions are coarser than that (1e-4 and
    /// 1e-5 of the diagonal). Fixed at those values, a church 8 mm across (a model in metres
    /// at 1:1000, or in kilometres) stepped every inner wall outside the building, where the
    /// sun lit it whole; a nave 240 000 units long (a cathedral in millimetres) put walls in
    /// a window's plane in and out of the building from texel to texel, in white streaks.
    pub fn lengths(diag: f32) -> [f32; 4] {
        let k = (diag / 10.0).clamp(1e-6, 1.0);
        [
            (0.01 * k).max(1e-4 * diag),
            (1e-3 * k).max(1e-5 * diag),
            0.0,
            0.0,
        ]
    }

    /// `spot` for a light: xyz the unit axis over the ramp's width in cosine, w the outer
    /// cosine over it negated, so `clamp(dot(spot.xyz, d) + spot.w, 0, 1)` squared is glTF's
    /// fall-off ([`pack::SpotCone::attenuation`]) for a unit direction `d` from the light. No
    /// cone, no ramp: a branch would cost every lit fragment on lavapipe.
    pub fn spot_ramp(kind: Option<&pack::LightKind>) -> [f32; 4] {
        match kind.and_then(pack::LightKind::cone) {
            Some(c) => {
                let scale = 1.0 / (c.cos_inner - c.cos_outer).max(1e-3);
                let a = c.axis.map(|x| (x * scale) as f32);
                [a[0], a[1], a[2], (-c.cos_outer * scale) as f32]
            }
            None => [0.0, 0.0, 0.0, 1.0],
        }
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct WindowProjector {
    pub projector: [[f32; 4]; 4],
    pub origin: [f32; 4],
    pub normal: [f32; 4],
    pub tint: [f32; 4],
    pub params: [u32; 4],
    pub shadow: [[f32; 4]; 4],
    pub shadow_x: [f32; 4],
    pub shadow_y: [f32; 4],
    pub shadow_depth: [f32; 4],
    pub shadow_dir: [f32; 4],
    pub aperture: [[f32; 4]; 4],
    pub aperture_box: [f32; 4],
}

/// One plane of the building's edge (`planes` in `common.wgsl`): a window's, shared by every
/// window in it. A point inside lies on the inner side of all of them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct WindowPlane {
    /// xyz: a point of the plane (camera-relative); w: how far behind it the uncut wall the
    /// glass sits on lies (0 for glass in a cut opening).
    pub origin: [f32; 4],
    /// xyz: unit normal into the building.
    pub normal: [f32; 4],
    /// xyz: the low corner of the buildings whose windows lie in the plane (camera-relative):
    /// the plane bounds their inside, and is not tested elsewhere (another building of the
    /// scene lies outside it). The lowest f32 where unbounded.
    pub lo: [f32; 4],
    /// xyz: the high corner.
    pub hi: [f32; 4],
}

impl WindowPlane {
    /// One plane per distinct (normal, offset, wall) of `windows`' entries, in first-seen
    /// order. Windows along a wall share one: a hall's 450 lancets are two planes, and every
    /// lit fragment tests each. Normals within 1e-6 and offsets within a tenth of the test's
    /// slack (`slack`, [`Frame::lengths`]'s y, 1e-3 units in most scenes) count as one plane:
    /// tested with the first window's, a point 100 units away moves by at most 2e-4.
    ///
    /// `buildings[i]` bounds the building window `i` belongs to (camera-relative), `None` for
    /// unbounded; a plane shared by several takes the union.
    pub fn distinct(
        windows: &[WindowProjector],
        buildings: &[Option<[glam::Vec3; 2]>],
        slack: f32,
    ) -> Vec<WindowPlane> {
        let mut seen = std::collections::HashMap::new();
        let mut out: Vec<WindowPlane> = Vec::new();
        for (i, w) in windows.iter().enumerate() {
            let [lo, hi] = buildings
                .get(i)
                .copied()
                .flatten()
                .unwrap_or([glam::Vec3::splat(f32::MIN), glam::Vec3::splat(f32::MAX)]);
            let n = glam::Vec3::from_slice(&w.normal[..3]);
            let o = glam::Vec3::from_slice(&w.origin[..3]);
            let q = |x: f32, step: f32| (x as f64 / step as f64).round() as i64;
            let key = (
                [q(n.x, 1e-6), q(n.y, 1e-6), q(n.z, 1e-6)],
                q(n.dot(o), slack * 0.1),
                w.origin[3].to_bits(),
            );
            match seen.get(&key) {
                Some(&k) => {
                    let p: &mut WindowPlane = &mut out[k];
                    for a in 0..3 {
                        p.lo[a] = p.lo[a].min(lo[a]);
                        p.hi[a] = p.hi[a].max(hi[a]);
                    }
                }
                None => {
                    seen.insert(key, out.len());
                    out.push(WindowPlane {
                        origin: w.origin,
                        normal: w.normal,
                        lo: lo.extend(0.0).to_array(),
                        hi: hi.extend(0.0).to_array(),
                    });
                }
            }
        }
        out
    }
}

/// The `Windows` storage buffer of `common.wgsl`: the light's direct map, then one entry per
/// window. WGSL's runtime-sized array has the element's size as its stride (336 bytes, a
/// multiple of 16), so the buffer is the entries' bytes back to back.
#[derive(Clone, Debug, Default)]
pub struct Windows {
    /// The light's direct map ([`crate::shadows::ShadowLayout::direct`]) in the shadow fields
    /// (`params.w` = 1 when there is one); the rest unused.
    pub direct: WindowProjector,
    pub items: Vec<WindowProjector>,
}

impl Windows {
    /// `count` windows, all zero.
    pub fn new(count: usize) -> Self {
        Self {
            direct: WindowProjector::zeroed(),
            items: vec![WindowProjector::zeroed(); count],
        }
    }

    /// Bytes of a buffer holding `count` windows (at least one, as WGSL has no empty buffer).
    pub fn buffer_size(count: usize) -> u64 {
        ((1 + count.max(1)) * std::mem::size_of::<WindowProjector>()) as u64
    }

    /// The buffer's contents.
    pub fn bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(Self::buffer_size(self.items.len()) as usize);
        out.extend_from_slice(bytemuck::bytes_of(&self.direct));
        out.extend_from_slice(bytemuck::cast_slice(&self.items));
        out
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Material {
    pub diffuse: [f32; 4],
    pub specular: [f32; 4],
    pub emissive: [f32; 4],
    pub flags: [u32; 4],
    /// xy: the diffuse texture's `pack::Texture::uv_scale`, zw: the normal map's (1 unless a
    /// block-compressed texture was padded to whole blocks).
    pub uv_scale: [f32; 4],
}

/// The panorama's pass (`sky.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Sky {
    /// Clip space to a camera-relative point on the pixel's ray.
    pub clip_to_ray: [[f32; 4]; 4],
    /// rgb: the panorama's scale, the background colour.
    pub scale: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct GodRays {
    /// `(L.x * aspect, L.y, 0, L.w)`: the light in clip space, aspect-corrected.
    pub light: [f32; 4],
    /// rgb: light colour × intensity × exposure × view fade.
    pub colour: [f32; 4],
    /// March length as a fraction of the distance from a pixel to the light.
    pub density: f32,
    /// ln(decay) per unit of march.
    pub ln_decay: f32,
    /// Weight per unit of march.
    pub weight: f32,
    /// Longest march, in half screen heights.
    pub max_length: f32,
    /// Width / height.
    pub aspect: f32,
    /// 1 to jitter the samples per pixel, 0 for midpoints.
    pub jitter: f32,
    /// Largest value written.
    pub max_output: f32,
    pub pad0: f32,
    /// 1..=[`MAX_GOD_RAY_SAMPLES`].
    pub samples: u32,
    /// Seed of the jitter, changed every frame.
    pub seed: u32,
    pub pad1: [u32; 2],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Composite {
    pub params: [f32; 4],
    pub flags: [u32; 4],
}

/// One shadow-map layer's depth pass (`shadow.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ShadowPass {
    pub view_proj: [[f32; 4]; 4],
    pub origin: [f32; 4],
}

/// The shadow-map view (`shadow_view.wgsl`): layer and layer size.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct ShadowView {
    pub params: [u32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable)]
pub struct Blit {
    /// x, y: the source level (relative to the view's base) whose texels are the size of one
    /// array texel across and down; z: one array texel in texture coordinates.
    pub lod: [f32; 4],
    /// xy: the source's `pack::Texture::uv_scale`.
    pub scale: [f32; 4],
}

/// The class number the shaders compare against (`CLASS_*` in `common.wgsl`).
pub fn class_id(class: MaterialClass) -> u32 {
    match class {
        MaterialClass::Floor => 0,
        MaterialClass::Wall => 1,
        MaterialClass::WindowUpper => 2,
        MaterialClass::WindowLower => 3,
        MaterialClass::Background => 4,
        MaterialClass::Other => 5,
    }
}

/// Rust name, WGSL name and Rust size of every uniform block, for the layout test.
pub const LAYOUTS: &[(&str, &str, usize)] = &[
    ("Frame", "Frame", std::mem::size_of::<Frame>()),
    (
        "WindowProjector",
        "WindowProjector",
        std::mem::size_of::<WindowProjector>(),
    ),
    (
        "WindowPlane",
        "WindowPlane",
        std::mem::size_of::<WindowPlane>(),
    ),
    ("Material", "Material", std::mem::size_of::<Material>()),
    ("GodRays", "GodRays", std::mem::size_of::<GodRays>()),
    ("Sky", "Sky", std::mem::size_of::<Sky>()),
    ("Composite", "Composite", std::mem::size_of::<Composite>()),
    ("Blit", "Blit", std::mem::size_of::<Blit>()),
    (
        "ShadowPass",
        "ShadowPass",
        std::mem::size_of::<ShadowPass>(),
    ),
    (
        "ShadowView",
        "ShadowView",
        std::mem::size_of::<ShadowView>(),
    ),
];

#[cfg(test)]
mod tests {
    use super::*;

    /// The shader's one affine ramp gives glTF's spot fall-off (`pack::SpotCone`), and no
    /// cone passes every direction whole.
    #[test]
    fn the_spot_ramp_is_the_cone_s_fall_off() {
        let kind = pack::LightKind::Spot {
            position: [0.0, 5.0, 0.0],
            radius: 0.1,
            direction: [0.0, -3.0, 0.0],
            inner: 0.3,
            outer: 0.6,
        };
        let cone = kind.cone().unwrap();
        let ramp = Frame::spot_ramp(Some(&kind));
        let shader = |d: glam::Vec3| {
            let t = (glam::Vec3::from_slice(&ramp[..3]).dot(d) + ramp[3]).clamp(0.0, 1.0);
            t * t
        };
        for deg in 0..=90 {
            let a = (deg as f32).to_radians();
            let d = glam::Vec3::new(a.sin(), -a.cos(), 0.0);
            let exact = cone.towards(d.as_dvec3().to_array());
            assert!(
                (shader(d) as f64 - exact).abs() < 2e-5,
                "{deg}°: {} {exact}",
                shader(d)
            );
            let want = if a < 0.3 {
                1.0
            } else if a > 0.6 {
                0.0
            } else {
                exact
            };
            assert_eq!(exact, want, "{deg}°");
        }
        // Half way in cosine between the cones, a quarter of the light.
        let mid = (cone.cos_inner + cone.cos_outer) * 0.5;
        assert!((cone.attenuation(mid) - 0.25).abs() < 1e-12);
        let sun = pack::LightKind::Directional {
            direction: [0.0, -1.0, 0.0],
            angular_size: 0.01,
        };
        for kind in [None, Some(&sun)] {
            assert_eq!(Frame::spot_ramp(kind), [0.0, 0.0, 0.0, 1.0]);
        }
    }

    fn window(origin: [f32; 3], normal: [f32; 3], wall: f32) -> WindowProjector {
        WindowProjector {
            origin: [origin[0], origin[1], origin[2], wall],
            normal: [normal[0], normal[1], normal[2], 0.0],
            ..Default::default()
        }
    }

    #[test]
    fn windows_along_a_wall_share_a_plane() {
        let n = [0.0, 0.0, 1.0];
        let windows = [
            window([0.0, 2.0, 0.0], n, 0.0),
            // Along the same wall, its normal a rounding step off.
            window([5.0, 4.0, 1e-6], [1e-7, 0.0, 1.0], 0.0),
            // A wall turned by 1e-5 rad: a plane of its own.
            window([4.0, 2.0, 0.0], [1e-5, 0.0, 1.0], 0.0),
            // The opposite wall, facing back in.
            window([0.0, 2.0, 12.0], [0.0, 0.0, -1.0], 0.0),
            // The first wall's plane, but glass on an uncut wall 5 cm behind it.
            window([9.0, 2.0, 0.0], n, 0.05),
            // A wall 1 mm in front of the first: a plane of its own.
            window([3.0, 2.0, 0.001], n, 0.0),
        ];
        let planes = WindowPlane::distinct(&windows, &[], Frame::lengths(100.0)[1]);
        let origins: Vec<[f32; 4]> = planes.iter().map(|p| p.origin).collect();
        assert_eq!(
            origins,
            [
                windows[0].origin,
                windows[2].origin,
                windows[3].origin,
                windows[4].origin,
                windows[5].origin
            ]
        );
        assert!(WindowPlane::distinct(&[], &[], 1e-3).is_empty());
        // In a scene a thousandth that size the step shrinks with the slack: a wall 1 µm in
        // front (the 1 mm above, scaled) is a plane of its own, one 0.03 µm in front is not.
        let tiny = [
            windows[0],
            window([3.0, 2.0, 3e-8], n, 0.0),
            window([3.0, 2.0, 1e-6], n, 0.0),
        ];
        let slack = Frame::lengths(0.01)[1];
        assert_eq!(slack, 1e-6);
        assert_eq!(WindowPlane::distinct(&tiny, &[], slack).len(), 2);
    }
}
