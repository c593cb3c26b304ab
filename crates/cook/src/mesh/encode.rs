//! Encoding: a processed mesh into the vertex layout and index format its pack entry
//! records, keeping only the attributes its materials read.

pub use pack::vertex::{Encoded, PositionBits};

use super::{MaterialNeeds, Processed, VertexArrays};
use crate::report::QuantizationError;

/// Which optional vertex attributes a mesh stores; position and material ID always are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Attributes {
    pub normal: bool,
    pub uv: bool,
    pub tangent: bool,
    /// Vertex colours, where some vertex of a material that shows them has one.
    pub colour: bool,
}

impl Attributes {
    pub const ALL: Attributes = Attributes {
        normal: true,
        uv: true,
        tangent: true,
        colour: true,
    };

    /// What the given materials need: an attribute no material of the mesh uses is dropped.
    pub fn for_materials(
        needs: &[MaterialNeeds],
        materials: impl IntoIterator<Item = u16>,
    ) -> Self {
        let mut a = Attributes {
            normal: false,
            uv: false,
            tangent: false,
            colour: false,
        };
        for m in materials {
            let n = needs[m as usize];
            a.normal |= n.normals || n.tangents;
            a.uv |= n.uvs || n.tangents;
            a.tangent |= n.tangents;
            a.colour |= n.colours;
        }
        a
    }

    /// Names of the attributes left out, for the report.
    pub fn dropped(&self) -> Vec<&'static str> {
        [
            (self.normal, "normal"),
            (self.uv, "uv"),
            (self.tangent, "tangent"),
        ]
        .into_iter()
        .filter(|(kept, _)| !kept)
        .map(|(_, name)| name)
        .collect()
    }
}

/// Vertices per piece of the vertex buffer written on one thread.
const PIECE: usize = 16 * 1024;

/// Encodes vertices with the attributes `attrs` keeps, quantized when `quantize` gives the
/// position bits; the layouts are [`pack::vertex::encode`]'s. Written in pieces side by side:
/// quantizing the 819k-triangle grid's vertices one after another took 38 ms.
pub fn encode(
    vertices: &VertexArrays,
    bounds_min: [f32; 3],
    bounds_max: [f32; 3],
    attrs: Attributes,
    quantize: Option<PositionBits>,
) -> Encoded {
    use rayon::prelude::*;
    let encoding = pack::vertex::Encoding {
        normal: attrs.normal,
        uv: attrs.uv,
        tangent: attrs.tangent,
        // Colours are stored only where some vertex has one other than white.
        colour: attrs.colour && !vertices.colours.is_empty(),
        quantize,
    };
    // A mesh without texture coordinates reads them as zeros, which fit unorm.
    let uv_unorm = quantize.is_some()
        && attrs.uv
        && vertices
            .uvs
            .par_iter()
            .all(|&uv| pack::vertex::unorm_uv(uv));
    let layout = pack::vertex::layout(encoding, uv_unorm, bounds_min, bounds_max);
    let stride = layout.stride as usize;
    let mut bytes = vec![0; vertices.len() * stride];
    let error = bytes
        .par_chunks_mut(PIECE * stride)
        .enumerate()
        .map(|(k, out)| pack::vertex::write_vertices(&layout, k * PIECE, |i| vertices.get(i), out))
        .reduce(Default::default, pack::vertex::QuantizationError::max);
    Encoded::new(layout, bytes, error)
}

/// One processed mesh as the pack stores it, with what the report says about it.
pub struct PackedMesh {
    pub mesh: pack::Mesh,
    pub data: pack::MeshData,
    /// Vertex attributes left out because no material of the mesh uses them.
    pub dropped_attributes: Vec<&'static str>,
    /// The quantization error, when quantized.
    pub quantization: Option<QuantizationError>,
}

/// Encodes a processed mesh: the attributes its materials need, quantized when `quantize`
/// gives the position bits, and 16-bit indices when every vertex fits.
pub fn pack_mesh(
    name: &str,
    p: Processed,
    needs: &[MaterialNeeds],
    quantize: Option<PositionBits>,
) -> PackedMesh {
    let attrs = Attributes::for_materials(needs, p.ranges.iter().map(|r| r.material));
    let e = encode(&p.vertices, p.bounds_min, p.bounds_max, attrs, quantize);
    let vertex_count = p.vertices.len();
    // The whole vertices are spent: let them go before the index bytes are written beside the
    // index buffer (on a large mesh these are the cook's last peak).
    let Processed {
        vertices,
        indices,
        ranges,
        bounds_min,
        bounds_max,
        ..
    } = p;
    drop(vertices);
    let index_count = indices.len() as u32;
    let quantization = quantize.map(|_| QuantizationError {
        position: e.max_position_error,
        normal_deg: e.max_normal_error_deg,
        uv: e.max_uv_error,
    });
    let (index_format, indices) = if vertex_count <= u16::MAX as usize + 1 {
        let v: Vec<u16> = indices.iter().map(|&i| i as u16).collect();
        (pack::IndexFormat::U16, bytemuck::cast_slice(&v).to_vec())
    } else {
        (
            pack::IndexFormat::U32,
            bytemuck::cast_slice(&indices).to_vec(),
        )
    };
    PackedMesh {
        mesh: pack::Mesh {
            name: name.to_string(),
            layout: e.layout,
            vertex_count: vertex_count as u32,
            index_count,
            index_format,
            vertex_section: 0,
            index_section: 0,
            bounds_min,
            bounds_max,
            ranges,
        },
        data: pack::MeshData {
            vertices: e.bytes,
            indices,
        },
        dropped_attributes: attrs.dropped(),
        quantization,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::{MeshSettings, process, soup};

    #[test]
    fn quantization_error_is_bounded() {
        let s = soup(
            vec![[0., 0., 0.], [10., 0., 0.], [0., 3., 1.]],
            vec![[0, 1, 2]],
        );
        let p = process(&s, &[0], &[MaterialNeeds::OPAQUE], &MeshSettings::default());
        let q = encode(
            &p.vertices,
            p.bounds_min,
            p.bounds_max,
            Attributes::ALL,
            Some(PositionBits::B16),
        );
        assert_eq!(q.bytes.len(), p.vertices.len() * q.layout.stride as usize);
        assert!(
            q.max_position_error <= 10.0 / 65535.0 * 0.51,
            "{}",
            q.max_position_error
        );
        assert!(q.max_normal_error_deg < 0.01, "{}", q.max_normal_error_deg);
    }
}
