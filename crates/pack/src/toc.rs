//! The table of contents: everything in a pack that is not bulk data.
//!
//! Encoded with bincode 2 (standard config) through serde. Bulk data (vertices, indices, mip
//! levels) live in sections of their own; the TOC refers to them by section index.

use serde::{Deserialize, Serialize};

pub use crate::vertex::{AttributeFormat, Semantic, StandardVertex, VertexAttribute, VertexLayout};

/// What a material is in the scene; the renderer's passes select on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum MaterialClass {
    Floor,
    Wall,
    WindowUpper,
    WindowLower,
    Background,
    Other,
}

impl MaterialClass {
    pub const ALL: [MaterialClass; 6] = [
        Self::Floor,
        Self::Wall,
        Self::WindowUpper,
        Self::WindowLower,
        Self::Background,
        Self::Other,
    ];

    /// The user-facing name, used by the CLI, the manifest and JSON output.
    pub fn name(self) -> &'static str {
        match self {
            Self::Floor => "floor",
            Self::Wall => "wall",
            Self::WindowUpper => "window-upper",
            Self::WindowLower => "window-lower",
            Self::Background => "background",
            Self::Other => "other",
        }
    }

    pub fn from_name(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.name() == s)
    }

    pub fn is_window(self) -> bool {
        matches!(self, Self::WindowUpper | Self::WindowLower)
    }
}

impl std::fmt::Display for MaterialClass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TextureRole {
    Colour,
    Normal,
    Projector,
}

impl TextureRole {
    pub fn name(self) -> &'static str {
        match self {
            Self::Colour => "colour",
            Self::Normal => "normal",
            Self::Projector => "projector",
        }
    }
}

impl std::fmt::Display for TextureRole {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum ColourSpace {
    /// 8-bit sRGB-encoded colour, linear alpha (sample through an `*Srgb` view).
    Srgb,
    /// Stored values are used as they are (normal maps).
    Linear,
}

impl ColourSpace {
    pub fn name(self) -> &'static str {
        match self {
            Self::Srgb => "srgb",
            Self::Linear => "linear",
        }
    }
}

/// Texel formats a pack may hold: 8-bit RGBA, or GPU block-compressed 4x4 blocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TextureFormat {
    /// Tightly packed RGBA8 rows, sRGB or linear as the colour space says.
    Rgba8,
    /// BC7 (16 bytes a block), RGBA; sRGB or linear as the colour space says.
    Bc7,
    /// BC5 (16 bytes a block): two linear channels, X and Y of a tangent-space normal map
    /// (Z is rebuilt from them).
    Bc5,
    /// BC4 (8 bytes a block): one linear channel.
    Bc4,
}

impl TextureFormat {
    pub const ALL: [TextureFormat; 4] = [Self::Rgba8, Self::Bc7, Self::Bc5, Self::Bc4];

    /// The user-facing name (CLI, JSON).
    pub fn name(self) -> &'static str {
        match self {
            Self::Rgba8 => "rgba8",
            Self::Bc7 => "bc7",
            Self::Bc5 => "bc5",
            Self::Bc4 => "bc4",
        }
    }

    /// Bytes of one 4x4 block; `None` for the uncompressed format.
    pub fn block_bytes(self) -> Option<u64> {
        match self {
            Self::Rgba8 => None,
            Self::Bc7 | Self::Bc5 => Some(16),
            Self::Bc4 => Some(8),
        }
    }

    pub fn is_compressed(self) -> bool {
        self.block_bytes().is_some()
    }

    /// Bytes of a `width x height` level as stored: whole 4x4 blocks for the block formats
    /// (a level smaller than a block still takes one).
    pub fn level_bytes(self, width: u32, height: u32) -> u64 {
        match self.block_bytes() {
            None => width as u64 * height as u64 * 4,
            Some(b) => width.div_ceil(4) as u64 * height.div_ceil(4) as u64 * b,
        }
    }

    /// Whether a texture of this format may be in `space`: the one- and two-channel formats
    /// hold data, never sRGB colour.
    pub fn allows(self, space: ColourSpace) -> bool {
        match self {
            Self::Rgba8 | Self::Bc7 => true,
            Self::Bc5 | Self::Bc4 => space == ColourSpace::Linear,
        }
    }
}

impl std::fmt::Display for TextureFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A lossless compression of a texture's stored levels on top of their format, undone when the
/// pack is read (KTX2 calls this supercompression). Each level is its own zstd frame, so levels
/// stream and decode one by one.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Supercompression {
    /// The section holds the level's bytes as they are (zero-copy from a mapped pack).
    #[default]
    None,
    /// The section holds one zstd frame whose content is the level's bytes.
    Zstd,
}

/// zstd level of [`Supercompression::compress`]: levels 9 to 19 take 1.5 to 20 times as long
/// for 1 % more (docs/bench/README.md, "Supercompression").
pub const ZSTD_LEVEL: i32 = 9;

/// log2 of the entries in the match finder's hash and chain tables (level 9 takes 21 and 20
/// for an input above 256 KiB: 12 MB a context, and the texture stage compresses on two
/// threads at once, the largest part of the default scene's cook peak). At 19 the default
/// scene's 157 levels take 4 MB a context and 18 % less time, and grow by 0.07 %
/// (5 282 364 → 5 286 001 bytes; 18: 0.3 %). Smaller inputs get smaller tables anyway.
pub const ZSTD_TABLE_LOG: u32 = 19;

impl Supercompression {
    pub const ALL: [Supercompression; 2] = [Self::None, Self::Zstd];

    /// The user-facing name (CLI, JSON).
    pub fn name(self) -> &'static str {
        match self {
            Self::None => "none",
            Self::Zstd => "zstd",
        }
    }

    /// A level's stored bytes as they go into its section. zstd output depends only on the
    /// input and the parameters, so packs stay byte-identical whatever the thread count.
    pub fn compress(self, level: &[u8]) -> Vec<u8> {
        match self {
            Self::None => level.to_vec(),
            Self::Zstd => {
                use zstd::stream::raw::CParameter;
                let mut c =
                    zstd::bulk::Compressor::new(ZSTD_LEVEL).expect("zstd accepts its own level");
                for p in [
                    CParameter::HashLog(ZSTD_TABLE_LOG),
                    CParameter::ChainLog(ZSTD_TABLE_LOG),
                ] {
                    c.set_parameter(p)
                        .expect("zstd accepts table sizes in its range");
                }
                let mut out = c
                    .compress(level)
                    .expect("zstd compresses any input into a vector of its bound");
                // The vector is allocated at the compression bound, above the level's own
                // size: held until the pack is written, the default scene's 5 MB of levels
                // kept 23 MB of heap, the most of its cook's peak.
                out.shrink_to_fit();
                out
            }
        }
    }

    /// Checks that a section declares a level of `expected` bytes, before any memory is
    /// given to decoding it: a zstd frame states its content size in its header.
    pub fn check_declared(self, section: &[u8], expected: u64) -> Result<(), String> {
        let declared = match self {
            Self::None => section.len() as u64,
            Self::Zstd => match zstd::zstd_safe::get_frame_content_size(section) {
                Ok(Some(n)) => n,
                Ok(None) => return Err("the zstd frame does not declare its size".into()),
                Err(_) => return Err("not a zstd frame".into()),
            },
        };
        if declared != expected {
            return Err(format!(
                "it holds {declared} bytes, but the level is {expected}"
            ));
        }
        Ok(())
    }

    /// A section's bytes back as the level's stored bytes, `out.len()` of them: the whole
    /// section must decode to exactly that many.
    pub fn decompress_into(self, section: &[u8], out: &mut [u8]) -> Result<(), String> {
        self.check_declared(section, out.len() as u64)?;
        match self {
            Self::None => out.copy_from_slice(section),
            Self::Zstd => {
                let n = zstd::bulk::Decompressor::new()
                    .and_then(|mut d| d.decompress_to_buffer(section, out))
                    .map_err(|e| format!("zstd: {e}"))?;
                if n != out.len() {
                    return Err(format!(
                        "the zstd data decodes to {n} bytes, but the level is {}",
                        out.len()
                    ));
                }
            }
        }
        Ok(())
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MipLevel {
    /// Logical size of the level: the texels that hold the image.
    pub width: u32,
    pub height: u32,
    /// Index into the section table of the `TextureMip` section holding this level.
    pub section: u32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Texture {
    /// Unique within the pack.
    pub name: String,
    pub role: TextureRole,
    pub colour_space: ColourSpace,
    pub format: TextureFormat,
    /// How each level's section is compressed on top of `format`.
    pub supercompression: Supercompression,
    /// Logical size of level 0: the image's texels. A block-compressed texture is stored
    /// padded to [`Texture::storage_size`].
    pub width: u32,
    pub height: u32,
    /// Level 0 first (largest). Each level is `max(1, previous / 2)` on each axis.
    pub mips: Vec<MipLevel>,
}

/// A `width x height` level 0 rounded up to whole 4x4 blocks: the stored size of a
/// block-compressed texture ([`Texture::storage_size`]).
pub fn block_padded_size(width: u32, height: u32) -> (u32, u32) {
    (width.div_ceil(4) * 4, height.div_ceil(4) * 4)
}

impl Texture {
    /// Size of level 0 as stored and as a GPU texture: the logical size for RGBA8, rounded up
    /// to whole 4x4 blocks for the block formats (the padding repeats the edge texels, and
    /// smaller levels are the mips of the padded level 0; docs/pack-format.md).
    pub fn storage_size(&self) -> (u32, u32) {
        if self.format.is_compressed() {
            block_padded_size(self.width, self.height)
        } else {
            (self.width, self.height)
        }
    }

    /// Size of a level of the GPU texture (`storage_size` halved `level` times). Its stored
    /// bytes cover it in whole blocks; the logical level (`mips[level]`) is its top-left part.
    pub fn storage_level_size(&self, level: usize) -> (u32, u32) {
        let (w, h) = self.storage_size();
        let s = level.min(31) as u32;
        ((w >> s).max(1), (h >> s).max(1))
    }

    /// The fraction of the stored texture the image covers on each axis: texture coordinates
    /// in [0, 1] over the image are scaled by it to sample the stored texture.
    pub fn uv_scale(&self) -> [f32; 2] {
        let (w, h) = self.storage_size();
        [self.width as f32 / w as f32, self.height as f32 / h as f32]
    }

    /// Bytes of level `level` in `format` (after undoing any supercompression).
    pub fn level_bytes(&self, level: usize) -> u64 {
        let (w, h) = self.storage_level_size(level);
        self.format.level_bytes(w, h)
    }

    /// Bytes of level `level` as uncompressed RGBA8 of its logical size.
    pub fn level_rgba8_bytes(&self, level: usize) -> u64 {
        let m = &self.mips[level];
        m.width as u64 * m.height as u64 * 4
    }
}

/// Phong shading parameters and texture references of one material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Material {
    pub name: String,
    pub class: MaterialClass,
    /// Linear RGB.
    pub diffuse: [f32; 3],
    /// Linear RGB.
    pub specular: [f32; 3],
    pub shininess: f32,
    /// Linear RGB emitted regardless of lighting (e.g. the sky).
    pub emissive: [f32; 3],
    pub diffuse_texture: Option<u32>,
    pub normal_texture: Option<u32>,
    /// Windows only: the blurred design projected onto receiving surfaces.
    pub projector_texture: Option<u32>,
    /// How far the projector texture reaches past the window's frame on each side, as a
    /// fraction of the frame's u and v extent: it spans frame coordinates `-m .. 1 + m`, so
    /// the light's penumbra can spread past the window's edge. Zero without a projector.
    pub projector_margin: [f32; 2],
}

/// The largest projector margin a pack may give, in frames (far beyond any the cooker writes:
/// its margin is at most half the design's longer side).
pub const MAX_PROJECTOR_MARGIN: f32 = 4096.0;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum IndexFormat {
    U16,
    U32,
}

impl IndexFormat {
    pub fn size(self) -> u64 {
        match self {
            Self::U16 => 2,
            Self::U32 => 4,
        }
    }

    /// The indices `bytes` hold in this format (little endian), widened to u32.
    pub fn decode(self, bytes: &[u8]) -> impl Iterator<Item = u32> + '_ {
        bytes.chunks_exact(self.size() as usize).map(|c| match *c {
            [a, b] => u16::from_le_bytes([a, b]) as u32,
            [a, b, c, d] => u32::from_le_bytes([a, b, c, d]),
            _ => unreachable!("chunks of the format's size"),
        })
    }
}

/// A contiguous run of indices drawn with one material.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct DrawRange {
    pub material: u16,
    pub first_index: u32,
    pub index_count: u32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub name: String,
    pub layout: VertexLayout,
    pub vertex_count: u32,
    pub index_count: u32,
    pub index_format: IndexFormat,
    pub vertex_section: u32,
    pub index_section: u32,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    /// Sorted by material; window materials come after opaque ones.
    pub ranges: Vec<DrawRange>,
}

/// The widest range of depth a cooker gives a camera, far plane over near: f32 depth holds no
/// scene over a wider one. Not checked when a pack is read (packs written before this was
/// held may exceed it, and still draw).
pub const MAX_FAR_OVER_NEAR: f64 = 1e9;

/// The longest side, in texels, at which renderers sample projector textures: cookers store no
/// level whose design part is larger (projectors are blurred, so this keeps their detail; the
/// light's margin around the design comes on top, so a stored level may be a little larger),
/// and renderers resample any projector to at most this size.
pub const PROJECTOR_MAX_SIZE: u32 = 512;

/// The plane a window's design is mapped onto: `world = origin + u * u_axis + v * v_axis` for
/// texture coordinates `(u, v)` in [0, 1]. The renderer builds the projector from it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Window {
    pub material: u16,
    pub origin: [f32; 3],
    pub u_axis: [f32; 3],
    pub v_axis: [f32; 3],
    /// Unit normal pointing into the building (away from the light's side).
    pub normal: [f32; 3],
    /// The materials the window's glass had in the source model, as named there (a rose window
    /// cut from four coloured glasses lists all four); `validate` and `info` report them, since
    /// the pack material is the cook's own per-window name.
    pub source_materials: Vec<String>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum LightKind {
    /// A light at `position` of physical `radius` (also the falloff clamp `1/max(d², r²)`).
    Point { position: [f32; 3], radius: f32 },
    /// The sun: light travels along `direction`; `angular_size` in radians.
    Directional {
        direction: [f32; 3],
        angular_size: f32,
    },
    /// A point light whose light is limited to a cone (glTF `KHR_lights_punctual`'s spot):
    /// full within `inner` of its axis `direction` (the way the light travels), none beyond
    /// `outer` (half-angles in radians, 0 ≤ inner ≤ outer ≤ π/2), glTF's smooth fall-off
    /// between ([`SpotCone::attenuation`]). Added after the other two, so packs without a
    /// spot are encoded as before.
    Spot {
        position: [f32; 3],
        radius: f32,
        direction: [f32; 3],
        inner: f32,
        outer: f32,
    },
}

/// A spot light's cone (`LightKind::Spot`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotCone {
    /// Unit axis, the way the light travels.
    pub axis: [f64; 3],
    pub cos_inner: f64,
    pub cos_outer: f64,
}

impl SpotCone {
    /// The cone around `axis` (any length; normalized here) of half-angles `inner` and
    /// `outer` in radians; `None` for an axis of zero or infinite length.
    pub fn new(axis: [f32; 3], inner: f32, outer: f32) -> Option<Self> {
        let d = axis.map(f64::from);
        let len = dot3(d, d).sqrt();
        (len > 0.0 && len.is_finite()).then(|| SpotCone {
            axis: d.map(|c| c / len),
            cos_inner: f64::from(inner).cos(),
            cos_outer: f64::from(outer).cos(),
        })
    }

    /// The fraction of the light that leaves along a unit direction whose cosine with the
    /// axis is `cos_angle`: glTF's fall-off, the square of a linear ramp in the cosine from
    /// the outer cone (0) to the inner (1). The ramp's width is kept above 1e-3 as glTF's
    /// reference code does, so equal angles give a hard edge without dividing by zero.
    pub fn attenuation(&self, cos_angle: f64) -> f64 {
        let t = ((cos_angle - self.cos_outer) / (self.cos_inner - self.cos_outer).max(1e-3))
            .clamp(0.0, 1.0);
        t * t
    }

    /// Whether any light of a spot at `at` passes through the parallelogram
    /// `origin + s·u + t·v`, s and t in [0, 1] (a window's glass): its point nearest the
    /// axis ([`SpotCone::nearest_cos`]) lies inside the outer cone.
    pub fn reaches(&self, at: [f64; 3], origin: [f64; 3], u: [f64; 3], v: [f64; 3]) -> bool {
        self.nearest_cos(at, origin, u, v) > self.cos_outer
    }

    /// The largest cosine between the axis and the way from `at` to a point of the
    /// parallelogram `origin + s·u + t·v`: 1 where the axis passes through it, else the best
    /// of its edges. Along a line the way from `at` turns through less than a half turn in
    /// one plane, so the cosine has at most one turning point there, and a ternary search
    /// with the ends finds its largest.
    pub fn nearest_cos(&self, at: [f64; 3], origin: [f64; 3], u: [f64; 3], v: [f64; 3]) -> f64 {
        let axis = self.axis;
        let cos = |q: [f64; 3]| {
            let d = sub3(q, at);
            let len = dot3(d, d).sqrt();
            if len > 0.0 { dot3(axis, d) / len } else { 1.0 }
        };
        let n = cross3(u, v);
        let along = dot3(axis, n);
        if along.abs() > 1e-300 {
            let t = dot3(sub3(origin, at), n) / along;
            let r = sub3(add3(at, scale3(axis, t)), origin);
            // (s, t) of the axis's point in the plane, from the Gram matrix of u and v.
            let (uu, uv, vv) = (dot3(u, u), dot3(u, v), dot3(v, v));
            let det = uu * vv - uv * uv;
            if t > 0.0 && det.abs() > 1e-300 {
                let (ru, rv) = (dot3(r, u), dot3(r, v));
                let s = (vv * ru - uv * rv) / det;
                let w = (uu * rv - uv * ru) / det;
                if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&w) {
                    return 1.0;
                }
            }
        }
        let corners = [
            origin,
            add3(origin, u),
            add3(add3(origin, u), v),
            add3(origin, v),
        ];
        let mut best = f64::NEG_INFINITY;
        for k in 0..4 {
            let (a, b) = (corners[k], corners[(k + 1) % 4]);
            let at_s = |s: f64| cos(add3(a, scale3(sub3(b, a), s)));
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..60 {
                let m1 = lo + (hi - lo) / 3.0;
                let m2 = hi - (hi - lo) / 3.0;
                if at_s(m1) < at_s(m2) {
                    lo = m1;
                } else {
                    hi = m2;
                }
            }
            best = best.max(at_s(0.0)).max(at_s(0.5 * (lo + hi)));
        }
        best
    }

    /// The fraction along `d` (any length; zero gives 0), from the light outwards.
    pub fn towards(&self, d: [f64; 3]) -> f64 {
        let len = dot3(d, d).sqrt();
        // Written as a positive test so NaN gives no light.
        if len > 0.0 {
            self.attenuation(dot3(self.axis, d) / len)
        } else {
            0.0
        }
    }
}

fn dot3(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn sub3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn add3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

fn scale3(a: [f64; 3], k: f64) -> [f64; 3] {
    [a[0] * k, a[1] * k, a[2] * k]
}

fn cross3(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

impl LightKind {
    /// What the light is, in words: "point", "directional" or "spot".
    pub fn name(&self) -> &'static str {
        match self {
            Self::Point { .. } => "point",
            Self::Directional { .. } => "directional",
            Self::Spot { .. } => "spot",
        }
    }

    /// A lamp's position and radius (point and spot lights); `None` for the sun.
    pub fn lamp(&self) -> Option<([f32; 3], f32)> {
        match *self {
            Self::Point { position, radius }
            | Self::Spot {
                position, radius, ..
            } => Some((position, radius)),
            Self::Directional { .. } => None,
        }
    }

    /// The sun's direction of travel and angular size; `None` for lamps.
    pub fn sun(&self) -> Option<([f32; 3], f32)> {
        match *self {
            Self::Directional {
                direction,
                angular_size,
            } => Some((direction, angular_size)),
            _ => None,
        }
    }

    /// A spot light's cone (its axis normalized); `None` for other lights, and for an axis
    /// of zero length (which validation refuses).
    pub fn cone(&self) -> Option<SpotCone> {
        match *self {
            Self::Spot {
                direction,
                inner,
                outer,
                ..
            } => SpotCone::new(direction, inner, outer),
            _ => None,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Light {
    pub kind: LightKind,
    /// Linear RGB.
    pub colour: [f32; 3],
    pub intensity: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Camera {
    pub name: String,
    pub position: [f32; 3],
    pub target: [f32; 3],
    pub up: [f32; 3],
    /// Vertical field of view in degrees.
    pub fov_y: f32,
    pub near: f32,
    pub far: f32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Background {
    /// Linear RGB shown where no background geometry covers the view.
    pub colour: [f32; 3],
    /// An equirectangular panorama, when the scene uses one instead of geometry.
    pub panorama: Option<u32>,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Toc {
    pub meshes: Vec<Mesh>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub windows: Vec<Window>,
    pub light: Option<Light>,
    pub cameras: Vec<Camera>,
    pub background: Background,
}

impl Default for Toc {
    fn default() -> Self {
        Self {
            meshes: Vec::new(),
            materials: Vec::new(),
            textures: Vec::new(),
            windows: Vec::new(),
            light: None,
            cameras: Vec::new(),
            background: Background {
                colour: [0.0; 3],
                panorama: None,
            },
        }
    }
}

impl Toc {
    /// Triangles drawn with each material, in material-table order.
    pub fn triangles_per_material(&self) -> Vec<u64> {
        let mut counts = vec![0u64; self.materials.len()];
        for mesh in &self.meshes {
            for r in &mesh.ranges {
                if let Some(c) = counts.get_mut(r.material as usize) {
                    *c += r.index_count as u64 / 3;
                }
            }
        }
        counts
    }

    pub fn texture_by_name(&self, name: &str) -> Option<(usize, &Texture)> {
        self.textures
            .iter()
            .enumerate()
            .find(|(_, t)| t.name == name)
    }
}
