//! The table of contents: everything in a pack that is not bulk data.
//!
//! Encoded with bincode 2 (standard config) through serde. Bulk data (vertices, indices, mip
//! levels) live in sections of their own; the TOC refers to them by section index.

use serde::{Deserialize, Serialize};

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
pub enum Semantic {
    Position,
    Normal,
    TexCoord,
    Tangent,
    MaterialId,
}

/// Vertex attribute formats; names follow wgpu's `VertexFormat`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum AttributeFormat {
    Float32x2,
    Float32x3,
    Float32x4,
    /// Quantized positions (decoded with the layout's `position_offset`/`position_scale`) or UVs.
    Unorm16x2,
    Unorm16x4,
    /// Octahedral-encoded unit vectors.
    Snorm16x2,
    Snorm16x4,
    /// Material ID in the first component; the second is zero.
    Uint16x2,
    /// Quantized positions at 10 bits per axis, packed in a little-endian u32: x in bits 0-9,
    /// y in 10-19, z in 20-29, bits 30-31 zero (wgpu's `Unorm10_10_10_2`).
    Unorm10x3,
    /// Quantized positions at 8 bits per axis; the fourth byte is zero.
    Unorm8x4,
}

impl AttributeFormat {
    pub fn size(self) -> u32 {
        match self {
            Self::Float32x2 => 8,
            Self::Float32x3 => 12,
            Self::Float32x4 => 16,
            Self::Unorm16x2 | Self::Snorm16x2 | Self::Uint16x2 => 4,
            Self::Unorm16x4 | Self::Snorm16x4 => 8,
            Self::Unorm10x3 | Self::Unorm8x4 => 4,
        }
    }

    /// Bits per axis of a quantized position format; `None` for floats and other formats.
    pub fn position_bits(self) -> Option<u32> {
        match self {
            Self::Unorm16x4 => Some(16),
            Self::Unorm10x3 => Some(10),
            Self::Unorm8x4 => Some(8),
            _ => None,
        }
    }
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VertexAttribute {
    pub semantic: Semantic,
    pub format: AttributeFormat,
    pub offset: u32,
}

#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct VertexLayout {
    pub stride: u32,
    pub attributes: Vec<VertexAttribute>,
    /// Dequantization of quantized positions (`Unorm16x4`, `Unorm10x3`, `Unorm8x4`, `q` in
    /// [0, 1]): `p = offset + scale * q`. Identity otherwise.
    pub position_offset: [f32; 3],
    pub position_scale: [f32; 3],
}

impl VertexLayout {
    pub fn attribute(&self, semantic: Semantic) -> Option<&VertexAttribute> {
        self.attributes.iter().find(|a| a.semantic == semantic)
    }

    /// The world-space position of one vertex (`vertex` is its `stride` bytes), dequantized;
    /// `None` when the layout has no position in a position format or the bytes are short.
    pub fn position(&self, vertex: &[u8]) -> Option<[f32; 3]> {
        let a = self.attribute(Semantic::Position)?;
        let o = a.offset as usize;
        let b = vertex.get(o..o + a.format.size() as usize)?;
        let u16_at = |k: usize| u16::from_le_bytes([b[2 * k], b[2 * k + 1]]) as f32;
        let q: [f32; 3] = match a.format {
            AttributeFormat::Float32x3 => {
                return Some(std::array::from_fn(|k| {
                    f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]])
                }));
            }
            AttributeFormat::Unorm16x4 => std::array::from_fn(|k| u16_at(k) / 65535.0),
            AttributeFormat::Unorm10x3 => {
                let w = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                std::array::from_fn(|k| ((w >> (10 * k)) & 0x3ff) as f32 / 1023.0)
            }
            AttributeFormat::Unorm8x4 => std::array::from_fn(|k| b[k] as f32 / 255.0),
            _ => return None,
        };
        Some(std::array::from_fn(|k| {
            self.position_offset[k] + self.position_scale[k] * q[k]
        }))
    }
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

/// The uncompressed vertex the cooker writes by default; [`VertexLayout::standard`] describes it.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct StandardVertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
    /// xyz tangent, w handedness (±1); zero where the material has no normal map.
    pub tangent: [f32; 4],
    /// Material ID in `[0]`, `[1]` is zero.
    pub material: [u16; 2],
}

impl VertexLayout {
    pub fn standard() -> Self {
        let a = |semantic, format, offset| VertexAttribute {
            semantic,
            format,
            offset,
        };
        Self {
            stride: std::mem::size_of::<StandardVertex>() as u32,
            attributes: vec![
                a(Semantic::Position, AttributeFormat::Float32x3, 0),
                a(Semantic::Normal, AttributeFormat::Float32x3, 12),
                a(Semantic::TexCoord, AttributeFormat::Float32x2, 24),
                a(Semantic::Tangent, AttributeFormat::Float32x4, 32),
                a(Semantic::MaterialId, AttributeFormat::Uint16x2, 48),
            ],
            position_offset: [0.0; 3],
            position_scale: [1.0; 3],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn layout(format: AttributeFormat) -> VertexLayout {
        VertexLayout {
            stride: 4 + format.size(),
            attributes: vec![
                VertexAttribute {
                    semantic: Semantic::MaterialId,
                    format: AttributeFormat::Uint16x2,
                    offset: 0,
                },
                VertexAttribute {
                    semantic: Semantic::Position,
                    format,
                    offset: 4,
                },
            ],
            position_offset: [-1.0, 10.0, 0.5],
            position_scale: [2.0, 4.0, 1.0],
        }
    }

    #[test]
    fn quantized_positions_dequantize_over_the_bounds() {
        let max10 = 1023u32 | 1023 << 10 | 1023 << 20;
        let cases: [(AttributeFormat, Vec<u8>, [f32; 3]); 5] = [
            (
                AttributeFormat::Unorm16x4,
                [0u16, 65535, 32768, 0]
                    .iter()
                    .flat_map(|c| c.to_le_bytes())
                    .collect(),
                [-1.0, 14.0, 0.5 + 32768.0 / 65535.0],
            ),
            (
                AttributeFormat::Unorm10x3,
                max10.to_le_bytes().to_vec(),
                [1.0, 14.0, 1.5],
            ),
            (
                AttributeFormat::Unorm10x3,
                (512u32 << 10).to_le_bytes().to_vec(),
                [-1.0, 10.0 + 4.0 * 512.0 / 1023.0, 0.5],
            ),
            (
                AttributeFormat::Unorm8x4,
                vec![255, 0, 51, 0],
                [1.0, 10.0, 0.7],
            ),
            (
                AttributeFormat::Float32x3,
                [3.0f32, -2.0, 1e5]
                    .iter()
                    .flat_map(|c| c.to_le_bytes())
                    .collect(),
                [3.0, -2.0, 1e5],
            ),
        ];
        for (format, bytes, want) in cases {
            let l = layout(format);
            let mut v = vec![0u8; 4];
            v.extend(bytes);
            let got = l.position(&v).unwrap();
            for k in 0..3 {
                assert!(
                    (got[k] - want[k]).abs() < 1e-5,
                    "{format:?}: {got:?} vs {want:?}"
                );
            }
            // Short vertex bytes are refused, not read past.
            assert_eq!(l.position(&v[..v.len() - 1]), None);
        }
        assert_eq!(layout(AttributeFormat::Snorm16x2).position(&[0; 8]), None);
    }
}
