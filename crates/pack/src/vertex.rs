//! The vertex format: attribute formats, layouts, and the one codec every writer and reader of
//! vertex bytes goes through (the cooker encodes with it; the renderer, the validators and the
//! diff decode with it), so an attribute format means the same thing everywhere.

use serde::{Deserialize, Serialize};

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Semantic {
    Position,
    Normal,
    TexCoord,
    Tangent,
    MaterialId,
    /// A colour that multiplies the material's base colour (a model's vertex colours): sRGB
    /// red, green and blue in `Unorm8x4`, the fourth byte zero. A vertex of a layout without
    /// it is white.
    Colour,
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
    /// An octahedral-encoded unit vector in x and y, a handedness (sign) in z, zero in w.
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

    /// Decodes one value from the first [`size`](Self::size) bytes of `bytes`, as the GPU
    /// would read it: unorm in [0, 1], octahedral vectors unit length (zero stays zero), the
    /// handedness of `Snorm16x4` as ±1, integers as they are; components the format lacks are
    /// zero. `None` when `bytes` is short.
    #[inline(always)]
    pub fn decode(self, bytes: &[u8]) -> Option<[f32; 4]> {
        let b = bytes.get(..self.size() as usize)?;
        let f32_at =
            |k: usize| f32::from_le_bytes([b[4 * k], b[4 * k + 1], b[4 * k + 2], b[4 * k + 3]]);
        let u16_at = |k: usize| u16::from_le_bytes([b[2 * k], b[2 * k + 1]]);
        let snorm_at = |k: usize| snorm16_decode(i16::from_le_bytes([b[2 * k], b[2 * k + 1]]));
        let unorm16_at = |k: usize| u16_at(k) as f32 / 65535.0;
        Some(match self {
            Self::Float32x2 => [f32_at(0), f32_at(1), 0.0, 0.0],
            Self::Float32x3 => [f32_at(0), f32_at(1), f32_at(2), 0.0],
            Self::Float32x4 => [f32_at(0), f32_at(1), f32_at(2), f32_at(3)],
            Self::Unorm16x2 => [unorm16_at(0), unorm16_at(1), 0.0, 0.0],
            Self::Unorm16x4 => std::array::from_fn(unorm16_at),
            Self::Snorm16x2 => {
                let [x, y, z] = oct_decode([snorm_at(0), snorm_at(1)]);
                [x, y, z, 0.0]
            }
            Self::Snorm16x4 => {
                let [x, y, z] = oct_decode([snorm_at(0), snorm_at(1)]);
                [x, y, z, if snorm_at(2) < 0.0 { -1.0 } else { 1.0 }]
            }
            Self::Uint16x2 => [u16_at(0) as f32, u16_at(1) as f32, 0.0, 0.0],
            Self::Unorm10x3 => {
                let w = u32::from_le_bytes([b[0], b[1], b[2], b[3]]);
                let c = |k: u32| ((w >> (10 * k)) & 0x3ff) as f32 / 1023.0;
                [c(0), c(1), c(2), 0.0]
            }
            Self::Unorm8x4 => [b[0], b[1], b[2], 0].map(|c| c as f32 / 255.0),
        })
    }

    /// Encodes one value into the first [`size`](Self::size) bytes of `out`; the inverse of
    /// [`decode`](Self::decode) up to the format's precision. Unorm values are clamped to
    /// [0, 1] and rounded to the nearest step; octahedral formats take the vector in xyz (any
    /// length; zero encodes as +z), `Snorm16x4` its handedness in w; unused components and
    /// padding bits are written as zero.
    #[inline(always)]
    pub fn encode(self, value: [f32; 4], out: &mut [u8]) {
        let out = &mut out[..self.size() as usize];
        let mut put = |k: usize, bytes: &[u8]| out[k..k + bytes.len()].copy_from_slice(bytes);
        match self {
            Self::Float32x2 | Self::Float32x3 | Self::Float32x4 => {
                for (k, c) in value.iter().take(self.size() as usize / 4).enumerate() {
                    put(4 * k, &c.to_le_bytes());
                }
            }
            Self::Unorm16x2 | Self::Unorm16x4 => {
                for (k, &c) in value.iter().take(self.size() as usize / 2).enumerate() {
                    put(2 * k, &(unorm_encode(c, 16) as u16).to_le_bytes());
                }
            }
            Self::Snorm16x2 | Self::Snorm16x4 => {
                let e = oct_encode([value[0], value[1], value[2]]).map(snorm16_encode);
                put(0, &e[0].to_le_bytes());
                put(2, &e[1].to_le_bytes());
                if self == Self::Snorm16x4 {
                    put(4, &snorm16_encode(value[3]).to_le_bytes());
                    put(6, &0i16.to_le_bytes());
                }
            }
            Self::Uint16x2 => {
                put(0, &(value[0] as u16).to_le_bytes());
                put(2, &(value[1] as u16).to_le_bytes());
            }
            Self::Unorm10x3 => {
                let q = |k: usize| unorm_encode(value[k], 10);
                put(0, &(q(0) | q(1) << 10 | q(2) << 20).to_le_bytes());
            }
            Self::Unorm8x4 => {
                let q = |k: usize| unorm_encode(value[k], 8) as u8;
                put(0, &[q(0), q(1), q(2), 0]);
            }
        }
    }
}

/// `c` in [0, 1] to the nearest of `2^bits` steps.
fn unorm_encode(c: f32, bits: u32) -> u32 {
    (c.clamp(0.0, 1.0) * ((1u32 << bits) - 1) as f32).round() as u32
}

fn snorm16_encode(c: f32) -> i16 {
    (c.clamp(-1.0, 1.0) * 32767.0).round() as i16
}

fn snorm16_decode(c: i16) -> f32 {
    // -32768 and -32767 both mean -1, as on the GPU.
    (c as f32 / 32767.0).max(-1.0)
}

/// Maps a vector onto the octahedron's unfolded square [-1, 1]²; the zero vector maps to the
/// centre (which decodes as +z).
#[inline(always)]
pub fn oct_encode(n: [f32; 3]) -> [f32; 2] {
    let l1 = n[0].abs() + n[1].abs() + n[2].abs();
    if l1 == 0.0 {
        return [0.0, 0.0];
    }
    let (x, y) = (n[0] / l1, n[1] / l1);
    if n[2] >= 0.0 {
        [x, y]
    } else {
        [(1.0 - y.abs()) * x.signum(), (1.0 - x.abs()) * y.signum()]
    }
}

/// The unit vector of a point of [`oct_encode`]'s square. Normalized as `glam`'s
/// `normalize_or_zero` does (times the reciprocal length), so the renderer's vertices keep the
/// bits they had when it decoded with glam.
#[inline(always)]
pub fn oct_decode(e: [f32; 2]) -> [f32; 3] {
    let z = 1.0 - e[0].abs() - e[1].abs();
    let (x, y) = if z < 0.0 {
        (
            (1.0 - e[1].abs()) * e[0].signum(),
            (1.0 - e[0].abs()) * e[1].signum(),
        )
    } else {
        (e[0], e[1])
    };
    let r = 1.0 / ((x * x) + (y * y) + (z * z)).sqrt();
    if r.is_finite() && r > 0.0 {
        [x * r, y * r, z * r]
    } else {
        [0.0; 3]
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

/// The uncompressed vertex the cooker writes by default; [`VertexLayout::standard`] describes it
/// (all but its colour, which only a layout with [`Semantic::Colour`] stores). It is also what
/// every layout decodes to ([`VertexLayout::decode`]), and what the renderer uploads.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct StandardVertex {
    pub position: [f32; 3],
    pub normal: [f32; 3],
    pub uv: [f32; 2],
    /// xyz tangent, w handedness (±1); zero where the material has no normal map.
    pub tangent: [f32; 4],
    /// Material ID in `[0]`, `[1]` is zero.
    pub material: [u16; 2],
    /// sRGB red, green, blue; the fourth byte zero. [`WHITE`] where the vertex has no colour.
    pub colour: [u8; 4],
}

/// The colour of a vertex that has none: it leaves the material's colour as it is.
pub const WHITE: [u8; 4] = [255, 255, 255, 0];

impl Default for StandardVertex {
    /// Zero but for the colour, which is [`WHITE`].
    fn default() -> Self {
        Self {
            colour: WHITE,
            ..bytemuck::Zeroable::zeroed()
        }
    }
}

impl StandardVertex {
    /// The value of one attribute, as [`AttributeFormat::encode`] takes it.
    pub fn get(&self, semantic: Semantic) -> [f32; 4] {
        let [x, y, z] = match semantic {
            Semantic::Position => self.position,
            Semantic::Normal => self.normal,
            Semantic::TexCoord => [self.uv[0], self.uv[1], 0.0],
            Semantic::Tangent => return self.tangent,
            Semantic::MaterialId => [self.material[0] as f32, 0.0, 0.0],
            Semantic::Colour => {
                let [r, g, b, _] = self.colour.map(|c| c as f32 / 255.0);
                [r, g, b]
            }
        };
        [x, y, z, 0.0]
    }
}

impl VertexLayout {
    pub fn standard() -> Self {
        use AttributeFormat as F;
        Self::packed(
            &[
                (Semantic::Position, F::Float32x3),
                (Semantic::Normal, F::Float32x3),
                (Semantic::TexCoord, F::Float32x2),
                (Semantic::Tangent, F::Float32x4),
                (Semantic::MaterialId, F::Uint16x2),
            ],
            [0.0; 3],
            [1.0; 3],
        )
    }

    /// The attributes back to back in the order given, with the position dequantization.
    pub fn packed(
        attributes: &[(Semantic, AttributeFormat)],
        position_offset: [f32; 3],
        position_scale: [f32; 3],
    ) -> Self {
        let mut stride = 0;
        let attributes = attributes
            .iter()
            .map(|&(semantic, format)| {
                let offset = stride;
                stride += format.size();
                VertexAttribute {
                    semantic,
                    format,
                    offset,
                }
            })
            .collect();
        Self {
            stride,
            attributes,
            position_offset,
            position_scale,
        }
    }

    pub fn attribute(&self, semantic: Semantic) -> Option<&VertexAttribute> {
        self.attributes.iter().find(|a| a.semantic == semantic)
    }

    /// One attribute of one vertex (`vertex` is its `stride` bytes), decoded
    /// ([`AttributeFormat::decode`]) and, for a quantized position, dequantized; `None` when
    /// the layout lacks it, the bytes are short, or a position is in a non-position format.
    pub fn read(&self, vertex: &[u8], semantic: Semantic) -> Option<[f32; 4]> {
        let a = self.attribute(semantic)?;
        self.read_attribute(a, vertex.get(a.offset as usize..)?)
    }

    /// [`read`](Self::read) of one of this layout's attributes from its own bytes (`bytes`
    /// starts at its offset).
    #[inline(always)]
    fn read_attribute(&self, a: &VertexAttribute, bytes: &[u8]) -> Option<[f32; 4]> {
        let v = a.format.decode(bytes)?;
        if a.semantic != Semantic::Position || a.format == AttributeFormat::Float32x3 {
            return Some(v);
        }
        a.format.position_bits()?;
        let p: [f32; 3] =
            std::array::from_fn(|k| self.position_offset[k] + self.position_scale[k] * v[k]);
        Some([p[0], p[1], p[2], 0.0])
    }

    /// The world-space position of one vertex, dequantized (see [`read`](Self::read)).
    pub fn position(&self, vertex: &[u8]) -> Option<[f32; 3]> {
        let [x, y, z, _] = self.read(vertex, Semantic::Position)?;
        Some([x, y, z])
    }

    pub fn material_id(&self, vertex: &[u8]) -> Option<u16> {
        self.read(vertex, Semantic::MaterialId).map(|v| v[0] as u16)
    }

    /// Every attribute of one vertex; those the layout lacks (or cannot read) are zero, but
    /// for the colour, which is [`WHITE`].
    pub fn decode(&self, vertex: &[u8]) -> StandardVertex {
        let read = |s| self.read(vertex, s).unwrap_or([0.0; 4]);
        let [px, py, pz, _] = read(Semantic::Position);
        let [nx, ny, nz, _] = read(Semantic::Normal);
        let [u, v, _, _] = read(Semantic::TexCoord);
        StandardVertex {
            position: [px, py, pz],
            normal: [nx, ny, nz],
            uv: [u, v],
            tangent: read(Semantic::Tangent),
            material: [read(Semantic::MaterialId)[0] as u16, 0],
            colour: self.colour(vertex),
        }
    }

    /// One vertex's colour: sRGB bytes, [`WHITE`] where the layout has none.
    pub fn colour(&self, vertex: &[u8]) -> [u8; 4] {
        match self.read(vertex, Semantic::Colour) {
            // Unorm8x4 decodes a byte to byte / 255, which this rounds back exactly.
            Some([r, g, b, _]) => {
                let byte = |c: f32| (c * 255.0).round() as u8;
                [byte(r), byte(g), byte(b), 0]
            }
            None => WHITE,
        }
    }

    /// `vertices` in this layout (see [`write_vertices`]; its quantization errors are left out).
    pub fn encode_vertices(&self, vertices: &[StandardVertex]) -> Vec<u8> {
        let mut bytes = vec![0; vertices.len() * self.stride as usize];
        write_vertices(self, 0, |i| vertices[i], &mut bytes);
        bytes
    }

    /// One attribute's value of `v` as [`AttributeFormat::encode`] takes it for this layout.
    #[inline(always)]
    fn attribute_value(&self, a: &VertexAttribute, v: &StandardVertex) -> [f32; 4] {
        let mut value = v.get(a.semantic);
        if a.semantic == Semantic::Position && a.format.position_bits().is_some() {
            for ((c, o), s) in value
                .iter_mut()
                .zip(self.position_offset)
                .zip(self.position_scale)
            {
                *c = (*c - o) / s;
            }
        }
        value
    }
}

/// Bits per axis of quantized positions: 16 (`Unorm16x4`, 8 bytes) or 10 and 8 (packed in 4
/// bytes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum PositionBits {
    #[default]
    B16 = 16,
    B10 = 10,
    B8 = 8,
}

impl PositionBits {
    pub fn from_bits(bits: u32) -> Option<Self> {
        match bits {
            16 => Some(Self::B16),
            10 => Some(Self::B10),
            8 => Some(Self::B8),
            _ => None,
        }
    }

    pub fn format(self) -> AttributeFormat {
        match self {
            Self::B16 => AttributeFormat::Unorm16x4,
            Self::B10 => AttributeFormat::Unorm10x3,
            Self::B8 => AttributeFormat::Unorm8x4,
        }
    }
}

/// What [`encode`] stores: position and material ID always, the optional attributes named, and
/// whether to quantize.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Encoding {
    pub normal: bool,
    pub uv: bool,
    pub tangent: bool,
    /// Vertex colours ([`Semantic::Colour`], 8-bit sRGB in either case).
    pub colour: bool,
    /// `None`: every attribute as 32-bit floats.
    pub quantize: Option<PositionBits>,
}

/// Vertices encoded for the pack, and what the encoding cost in accuracy.
#[derive(Clone, Debug, PartialEq)]
pub struct Encoded {
    pub layout: VertexLayout,
    pub bytes: Vec<u8>,
    /// Largest position error in world units (0 for float positions).
    pub max_position_error: f32,
    /// Largest normal error in degrees (0 for float normals).
    pub max_normal_error_deg: f32,
    /// Largest texture-coordinate error (0 when UVs stay 32-bit floats).
    pub max_uv_error: f32,
}

/// Chooses a layout for `vertices` and encodes them. Unquantized with every attribute but the
/// colour this is exactly [`VertexLayout::standard`] (52 bytes): the standard vertex's bytes
/// less its colour.
///
/// Quantized: positions as unorm within the bounding box, normals and tangents octahedral in
/// 16-bit snorm (tangent handedness in z), UVs as 16-bit unorm when they all lie in [0, 1]
/// (else floats): 28 bytes with every attribute at 16 bits. Attributes keep the order position,
/// normal, tangent, UV, colour, material when quantized, and position, normal, UV, tangent,
/// colour, material as floats, so that the full float layout without colours is the standard
/// one. Colours take 4 bytes (8-bit sRGB) either way.
pub fn encode(
    vertices: &[StandardVertex],
    bounds_min: [f32; 3],
    bounds_max: [f32; 3],
    encoding: Encoding,
) -> Encoded {
    let uv_unorm =
        encoding.quantize.is_some() && encoding.uv && vertices.iter().all(|v| unorm_uv(v.uv));
    let layout = layout(encoding, uv_unorm, bounds_min, bounds_max);
    let mut bytes = vec![0; vertices.len() * layout.stride as usize];
    let error = write_vertices(&layout, 0, |i| vertices[i], &mut bytes);
    Encoded::new(layout, bytes, error)
}

impl Encoded {
    /// Vertices `write_vertices` wrote in `layout`, with what quantizing them cost.
    pub fn new(layout: VertexLayout, bytes: Vec<u8>, error: QuantizationError) -> Self {
        Self {
            layout,
            bytes,
            max_position_error: error.position,
            max_normal_error_deg: error.normal_deg,
            max_uv_error: error.uv,
        }
    }
}

/// Whether a texture coordinate can be stored as 16-bit unorm ([`layout`]'s `uv_unorm`).
pub fn unorm_uv(uv: [f32; 2]) -> bool {
    uv.iter().all(|&c| (0.0..=1.0).contains(&c))
}

/// The layout [`encode`] chooses: `uv_unorm` says that every vertex's texture coordinates
/// pass [`unorm_uv`] (read only when quantizing).
pub fn layout(
    encoding: Encoding,
    uv_unorm: bool,
    bounds_min: [f32; 3],
    bounds_max: [f32; 3],
) -> VertexLayout {
    use AttributeFormat as F;
    use Semantic as S;
    let Encoding {
        normal,
        uv,
        tangent,
        colour,
        quantize,
    } = encoding;
    let mut attributes = Vec::new();
    match quantize {
        None => {
            attributes.push((S::Position, F::Float32x3));
            if normal {
                attributes.push((S::Normal, F::Float32x3));
            }
            if uv {
                attributes.push((S::TexCoord, F::Float32x2));
            }
            if tangent {
                attributes.push((S::Tangent, F::Float32x4));
            }
            if colour {
                attributes.push((S::Colour, F::Unorm8x4));
            }
            attributes.push((S::MaterialId, F::Uint16x2));
            VertexLayout::packed(&attributes, [0.0; 3], [1.0; 3])
        }
        Some(bits) => {
            attributes.push((S::Position, bits.format()));
            if normal {
                attributes.push((S::Normal, F::Snorm16x2));
            }
            if tangent {
                attributes.push((S::Tangent, F::Snorm16x4));
            }
            if uv {
                attributes.push((
                    S::TexCoord,
                    if uv_unorm { F::Unorm16x2 } else { F::Float32x2 },
                ));
            }
            if colour {
                attributes.push((S::Colour, F::Unorm8x4));
            }
            attributes.push((S::MaterialId, F::Uint16x2));
            // A unorm q reads as q / (2^bits - 1) in [0, 1], so the scale is the box's full
            // extent.
            let scale = std::array::from_fn(|k| {
                let s = bounds_max[k] - bounds_min[k];
                if s > 0.0 { s } else { 1.0 }
            });
            VertexLayout::packed(&attributes, bounds_min, scale)
        }
    }
}

/// The largest errors quantization made over some vertices ([`write_vertices`]); zero for
/// attributes stored as floats.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QuantizationError {
    /// World units.
    pub position: f32,
    pub normal_deg: f32,
    pub uv: f32,
}

impl QuantizationError {
    /// The larger of each; order-free, so errors of pieces written apart combine to the same
    /// bits whatever the order.
    pub fn max(self, o: Self) -> Self {
        Self {
            position: self.position.max(o.position),
            normal_deg: self.normal_deg.max(o.normal_deg),
            uv: self.uv.max(o.uv),
        }
    }
}

/// Writes vertices `first..` in `layout` into `out` (as many as it holds whole strides; its
/// bytes must be zero where no attribute writes; a quantized position is mapped into [0, 1]
/// over the layout's offset and scale first), and measures what quantization cost them,
/// each attribute read back as a renderer reads it. Pieces of one vertex buffer can be
/// written side by side.
pub fn write_vertices(
    layout: &VertexLayout,
    first: usize,
    vertex: impl Fn(usize) -> StandardVertex,
    out: &mut [u8],
) -> QuantizationError {
    use AttributeFormat as F;
    let quantized = layout
        .attribute(Semantic::Position)
        .is_some_and(|a| a.format.position_bits().is_some());
    let mut worst = Worst::default();
    for a in &layout.attributes {
        let mut write = |format| {
            column(
                layout,
                a,
                format,
                quantized,
                (first, &vertex),
                out,
                &mut worst,
            );
        };
        // One attribute over the whole piece, its format matched once: each arm below is a
        // loop of its own, compiled for its format (matched per vertex and attribute, the
        // 100k grid's 50k quantized vertices took 4.8 ms on two threads instead of 2.1).
        match a.format {
            F::Unorm16x4 => write(F::Unorm16x4),
            F::Unorm10x3 => write(F::Unorm10x3),
            F::Unorm8x4 => write(F::Unorm8x4),
            F::Snorm16x2 => write(F::Snorm16x2),
            F::Snorm16x4 => write(F::Snorm16x4),
            F::Unorm16x2 => write(F::Unorm16x2),
            F::Float32x3 => write(F::Float32x3),
            other => write(other),
        }
    }
    worst.finish()
}

/// [`write_vertices`] of one attribute, in `format` (its own, passed as a constant).
#[inline(always)]
fn column(
    layout: &VertexLayout,
    a: &VertexAttribute,
    format: AttributeFormat,
    quantized: bool,
    (first, vertex): (usize, &impl Fn(usize) -> StandardVertex),
    out: &mut [u8],
    worst: &mut Worst,
) {
    let stride = layout.stride as usize;
    let size = format.size() as usize;
    for (i, bytes) in out.chunks_exact_mut(stride).enumerate() {
        let v = vertex(first + i);
        let at = &mut bytes[a.offset as usize..][..size];
        format.encode(layout.attribute_value(a, &v), at);
        if quantized {
            // Read back through the one decoder every reader uses.
            let back = layout.read_attribute(a, at).unwrap_or([0.0; 4]);
            worst.add(a.semantic, format, back, &v);
        }
    }
}

/// The largest errors of [`write_vertices`] so far. A normal's error is the angle
/// `atan2(|n' x n|, n' . n)`, taken for the worst pair only: below 90° the angle rises with
/// `|n' x n| / n' . n`, which two pairs compare exactly as products in f64.
struct Worst {
    position: f32,
    uv: f32,
    /// (|cross|, dot) of the widest angle under 90°.
    normal: (f32, f32),
    /// Angles of 90° and more, in degrees.
    normal_wide: f32,
}

impl Default for Worst {
    fn default() -> Self {
        Self {
            position: 0.0,
            uv: 0.0,
            normal: (0.0, 1.0),
            normal_wide: 0.0,
        }
    }
}

impl Worst {
    #[inline(always)]
    fn add(
        &mut self,
        semantic: Semantic,
        format: AttributeFormat,
        back: [f32; 4],
        v: &StandardVertex,
    ) {
        match (semantic, format) {
            (Semantic::Position, _) => {
                for (b, p) in back.iter().zip(v.position) {
                    self.position = self.position.max((b - p).abs());
                }
            }
            (Semantic::Normal, _) if dot(v.normal, v.normal) > 0.0 => {
                let back = [back[0], back[1], back[2]];
                let c = cross(back, v.normal);
                let (sin, cos) = (dot(c, c).sqrt(), dot(back, v.normal));
                if cos > 0.0 {
                    let (s, c) = self.normal;
                    if f64::from(sin) * f64::from(c) > f64::from(s) * f64::from(cos) {
                        self.normal = (sin, cos);
                    }
                } else {
                    self.normal_wide = self.normal_wide.max(angle_deg(sin, cos));
                }
            }
            (Semantic::TexCoord, AttributeFormat::Unorm16x2) => {
                for (b, t) in back.iter().zip(v.uv) {
                    self.uv = self.uv.max((b - t).abs());
                }
            }
            _ => {}
        }
    }

    fn finish(self) -> QuantizationError {
        let (sin, cos) = self.normal;
        QuantizationError {
            position: self.position,
            normal_deg: angle_deg(sin, cos).max(self.normal_wide),
            uv: self.uv,
        }
    }
}

/// atan2 of |cross| and dot stays accurate for tiny angles, where acos(dot) does not.
fn angle_deg(sin: f32, cos: f32) -> f32 {
    sin.atan2(cos).to_degrees()
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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

    fn angle_deg(a: [f32; 3], b: [f32; 3]) -> f32 {
        let c = cross(a, b);
        dot(c, c).sqrt().atan2(dot(a, b)).to_degrees()
    }

    fn round_trip(format: AttributeFormat, value: [f32; 4]) -> [f32; 4] {
        let mut bytes = vec![0xAAu8; format.size() as usize];
        format.encode(value, &mut bytes);
        let back = format.decode(&bytes).unwrap();
        // Re-encoding what was decoded gives the same bytes: decode loses nothing encode kept.
        let mut again = vec![0x55u8; bytes.len()];
        format.encode(back, &mut again);
        assert_eq!(again, bytes, "{format:?} {value:?}");
        assert_eq!(format.decode(&bytes[..bytes.len() - 1]), None);
        back
    }

    fn unit() -> impl Strategy<Value = [f32; 3]> {
        prop::array::uniform3(-1.0f32..=1.0)
            .prop_filter("not near zero", |v| dot(*v, *v) > 1e-4)
            .prop_map(|v| {
                let l = dot(v, v).sqrt();
                v.map(|c| c / l)
            })
    }

    proptest! {
        #[test]
        fn floats_round_trip_exactly(v in prop::array::uniform4(prop::num::f32::NORMAL | prop::num::f32::ZERO)) {
            for (format, n) in [(AttributeFormat::Float32x2, 2), (AttributeFormat::Float32x3, 3), (AttributeFormat::Float32x4, 4)] {
                let back = round_trip(format, v);
                for k in 0..4 {
                    let want = if k < n { v[k].to_bits() } else { 0 };
                    prop_assert_eq!(back[k].to_bits(), want, "{:?}", format);
                }
            }
        }

        #[test]
        fn unorms_round_trip_within_half_a_step(v in prop::array::uniform4(0.0f32..=1.0)) {
            for (format, n, levels) in [
                (AttributeFormat::Unorm16x2, 2, 65535.0f32),
                (AttributeFormat::Unorm16x4, 4, 65535.0),
                (AttributeFormat::Unorm10x3, 3, 1023.0),
                (AttributeFormat::Unorm8x4, 3, 255.0),
            ] {
                let back = round_trip(format, v);
                for k in 0..4 {
                    if k < n {
                        prop_assert!((back[k] - v[k]).abs() <= 0.5 / levels + 1e-7, "{:?} {:?}", format, back);
                    } else {
                        prop_assert_eq!(back[k], 0.0);
                    }
                }
            }
        }

        #[test]
        fn octahedral_normals_round_trip(n in unit()) {
            let back = round_trip(AttributeFormat::Snorm16x2, [n[0], n[1], n[2], 0.0]);
            prop_assert!(angle_deg([back[0], back[1], back[2]], n) < 0.01, "{:?} {:?}", n, back);
            prop_assert_eq!(back[3], 0.0);
        }

        #[test]
        fn tangents_round_trip_with_handedness(t in unit(), left in any::<bool>()) {
            let w = if left { -1.0 } else { 1.0 };
            let back = round_trip(AttributeFormat::Snorm16x4, [t[0], t[1], t[2], w]);
            prop_assert!(angle_deg([back[0], back[1], back[2]], t) < 0.01, "{:?} {:?}", t, back);
            prop_assert_eq!(back[3], w);
        }

        #[test]
        fn material_ids_round_trip(id in any::<u16>()) {
            let back = round_trip(AttributeFormat::Uint16x2, [id as f32, 0.0, 0.0, 0.0]);
            prop_assert_eq!(back, [id as f32, 0.0, 0.0, 0.0]);
        }

        #[test]
        fn quantized_vertices_decode_within_the_reported_error(
            vs in prop::collection::vec((prop::array::uniform3(-50.0f32..50.0), unit(), prop::array::uniform2(0.0f32..=1.0), unit(), 0u16..9, any::<[u8; 3]>()), 1..20),
            bits in prop::sample::select(vec![PositionBits::B16, PositionBits::B10, PositionBits::B8]),
        ) {
            let vertices: Vec<StandardVertex> = vs.iter().map(|&(p, n, uv, t, m, [r, g, b])| StandardVertex {
                position: p, normal: n, uv, tangent: [t[0], t[1], t[2], -1.0], material: [m, 0], colour: [r, g, b, 0],
            }).collect();
            let lo = std::array::from_fn(|k| vertices.iter().map(|v| v.position[k]).fold(f32::INFINITY, f32::min));
            let hi = std::array::from_fn(|k| vertices.iter().map(|v| v.position[k]).fold(f32::NEG_INFINITY, f32::max));
            let e = encode(&vertices, lo, hi, Encoding { normal: true, uv: true, tangent: true, colour: true, quantize: Some(bits) });
            let levels = ((1u32 << bits as u32) - 1) as f32;
            let step = (0..3).map(|k| (hi[k] - lo[k]) / levels).fold(0.0, f32::max);
            prop_assert!(e.max_position_error <= step * 0.5 + 1e-5, "{} > half of {}", e.max_position_error, step);
            prop_assert!(e.max_normal_error_deg < 0.01);
            prop_assert!(e.max_uv_error <= 0.5 / 65535.0 + 1e-7);
            for (v, bytes) in vertices.iter().zip(e.bytes.chunks_exact(e.layout.stride as usize)) {
                let back = e.layout.decode(bytes);
                prop_assert_eq!(back.material, v.material);
                // Colours are stored as they are: 8-bit sRGB in, 8-bit sRGB out.
                prop_assert_eq!(back.colour, v.colour);
                prop_assert_eq!(back.tangent[3], -1.0);
                prop_assert!(angle_deg([back.tangent[0], back.tangent[1], back.tangent[2]], [v.tangent[0], v.tangent[1], v.tangent[2]]) < 0.01);
            }
        }

        /// Pieces written apart make the whole buffer's bytes, and their errors combine to the
        /// largest of each vertex's own, measured the plain way (every vertex decoded whole, an
        /// arc tangent each), bit for bit; normals of any length and direction, zero included.
        #[test]
        fn pieces_give_the_whole_bytes_and_the_per_vertex_errors(
            vs in prop::collection::vec((prop::array::uniform3(-50.0f32..50.0), prop::array::uniform3(-2.0f32..2.0), prop::array::uniform2(0.0f32..=1.0), 0u16..9), 1..60),
            zero in any::<bool>(),
            piece in 1usize..9,
            bits in prop::sample::select(vec![PositionBits::B16, PositionBits::B10, PositionBits::B8]),
        ) {
            let mut vertices: Vec<StandardVertex> = vs.iter().map(|&(p, n, uv, m)| StandardVertex {
                position: p, normal: n, uv, tangent: [0.0; 4], material: [m, 0], colour: crate::vertex::WHITE,
            }).collect();
            if zero {
                vertices[0].normal = [0.0; 3];
            }
            let lo = std::array::from_fn(|k| vertices.iter().map(|v| v.position[k]).fold(f32::INFINITY, f32::min));
            let hi = std::array::from_fn(|k| vertices.iter().map(|v| v.position[k]).fold(f32::NEG_INFINITY, f32::max));
            let whole = encode(&vertices, lo, hi, Encoding { normal: true, uv: true, tangent: false, colour: false, quantize: Some(bits) });
            let stride = whole.layout.stride as usize;
            let mut bytes = vec![0; whole.bytes.len()];
            let error = bytes
                .chunks_mut(piece * stride)
                .enumerate()
                .map(|(k, out)| write_vertices(&whole.layout, k * piece, |i| vertices[i], out))
                .fold(QuantizationError::default(), QuantizationError::max);
            prop_assert_eq!(&bytes, &whole.bytes);
            let mut want = QuantizationError::default();
            for (v, b) in vertices.iter().zip(whole.bytes.chunks_exact(stride)) {
                let back = whole.layout.decode(b);
                for k in 0..3 {
                    want.position = want.position.max((back.position[k] - v.position[k]).abs());
                }
                if dot(v.normal, v.normal) > 0.0 {
                    want.normal_deg = want.normal_deg.max(angle_deg(back.normal, v.normal));
                }
                for k in 0..2 {
                    want.uv = want.uv.max((back.uv[k] - v.uv[k]).abs());
                }
            }
            prop_assert_eq!(error.position.to_bits(), want.position.to_bits());
            prop_assert_eq!(error.normal_deg.to_bits(), want.normal_deg.to_bits(), "{} {}", error.normal_deg, want.normal_deg);
            prop_assert_eq!(error.uv.to_bits(), want.uv.to_bits());
            prop_assert_eq!(whole.max_normal_error_deg.to_bits(), want.normal_deg.to_bits());
        }
    }

    /// Unquantized with every attribute but the colour, the encoder writes the standard
    /// vertex's own bytes less the colour; with colours, the colour goes before the material
    /// ID, and a layout without them decodes white.
    #[test]
    fn the_full_float_encoding_is_the_standard_vertex() {
        let vertices = [
            StandardVertex {
                position: [1.0, -0.0, 3.5],
                normal: [0.0, 0.6, 0.8],
                uv: [2.0, -1.0],
                tangent: [1.0, 0.0, 0.0, -1.0],
                material: [7, 0],
                colour: WHITE,
            },
            StandardVertex::default(),
        ];
        let mut all = Encoding {
            normal: true,
            uv: true,
            tangent: true,
            colour: false,
            quantize: None,
        };
        let e = encode(&vertices, [0.0; 3], [1.0; 3], all);
        assert_eq!(e.layout, VertexLayout::standard());
        assert_eq!(e.layout.stride, 52);
        let whole: &[u8] = bytemuck::cast_slice(&vertices);
        let size = std::mem::size_of::<StandardVertex>();
        for (k, (v, b)) in vertices.iter().zip(e.bytes.chunks_exact(52)).enumerate() {
            assert_eq!(b, &whole[k * size..][..52]);
            assert_eq!(e.layout.decode(b), *v);
        }

        let coloured = vertices.map(|v| StandardVertex {
            colour: [200, 3, 0, 0],
            ..v
        });
        all.colour = true;
        let e = encode(&coloured, [0.0; 3], [1.0; 3], all);
        assert_eq!(e.layout.stride, 56);
        let colour = e.layout.attribute(Semantic::Colour).unwrap();
        assert_eq!(
            (colour.offset, colour.format),
            (48, AttributeFormat::Unorm8x4)
        );
        for (v, b) in coloured.iter().zip(e.bytes.chunks_exact(56)) {
            assert_eq!(&b[48..52], &[200, 3, 0, 0]);
            assert_eq!(e.layout.decode(b), *v);
        }
    }

    /// The zero vector (a tangent where no material has a normal map) encodes as +z.
    #[test]
    fn zero_vectors_decode_as_plus_z() {
        let mut bytes = [0xAA; 8];
        AttributeFormat::Snorm16x4.encode([0.0; 4], &mut bytes);
        assert_eq!(bytes, [0; 8]);
        assert_eq!(
            AttributeFormat::Snorm16x4.decode(&bytes),
            Some([0.0, 0.0, 1.0, 1.0])
        );
    }
}
