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

/// Texel formats a pack may hold. Only 8-bit RGBA today; the enum keeps room to grow.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum TextureFormat {
    Rgba8,
}

impl TextureFormat {
    pub fn bytes_per_texel(self) -> u64 {
        match self {
            Self::Rgba8 => 4,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MipLevel {
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
    pub width: u32,
    pub height: u32,
    /// Level 0 first (largest). Each level is `max(1, previous / 2)` on each axis.
    pub mips: Vec<MipLevel>,
}

impl Texture {
    pub fn level_bytes(&self, level: usize) -> u64 {
        let m = &self.mips[level];
        m.width as u64 * m.height as u64 * self.format.bytes_per_texel()
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
}

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
