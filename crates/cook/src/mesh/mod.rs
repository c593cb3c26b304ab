//! Mesh processing: from a tagged triangle soup to GPU-ready, optimized vertex and index
//! buffers with one draw range per material (window materials last, since they are blended).
//!
//! Order matters: indices are already validated by the importers (meshopt crashes the process
//! on an out-of-range index), -0.0 is normalized before deduplication (meshopt compares raw
//! bits), and vertices shared by two materials are split simply because the material ID is
//! part of the vertex.
//!
//! `process.rs` turns a soup into optimized buffers, `weld.rs` merges equal values by their
//! bits, `tangents.rs` computes MikkTSpace tangents, `encode.rs` writes the pack's vertex layout and index format.

mod encode;
mod process;
pub mod tangents;
mod weld;

use std::time::Duration;

use pack::StandardVertex;

pub use encode::{Attributes, Encoded, PackedMesh, PositionBits, encode, pack_mesh};
pub use process::{Deduplicated, SourceNormals, deduplicate, is_degenerate, optimize, process};

/// Vertex cache optimizer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum CacheMode {
    /// meshopt's full optimizer (Forsyth-like, best ACMR).
    #[default]
    Full,
    /// meshopt's FIFO optimizer (cache of 16): faster, slightly worse ACMR (docs/bench has both
    /// modes side by side).
    Fifo,
}

/// The knobs of mesh processing (part of [`crate::Settings`]).
#[derive(Clone, Debug, serde::Serialize)]
pub struct MeshSettings {
    pub cache: CacheMode,
    /// Reorder opaque ranges to reduce overdraw (threshold 1.05).
    pub overdraw: bool,
    /// Faces meeting at a sharper angle than this keep separate generated normals.
    pub crease_angle_deg: f32,
    /// Measure ACMR and overfetch for the report (three passes over the indices; the output
    /// does not depend on it).
    #[serde(skip)]
    pub analyze: bool,
}

impl Default for MeshSettings {
    fn default() -> Self {
        Self {
            cache: CacheMode::Full,
            overdraw: false,
            crease_angle_deg: 60.0,
            analyze: true,
        }
    }
}

/// What each material needs from mesh processing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialNeeds {
    /// Blended: drawn after every opaque range.
    pub window: bool,
    /// Has a normal map: MikkTSpace tangents are generated.
    pub tangents: bool,
    /// Samples a texture (design, colour or normal map). Without it the texture coordinates
    /// are zeroed before deduplication, so vertices that differ only there merge.
    pub uvs: bool,
    /// Is shaded with its normal (everything but unlit backdrops); zeroed otherwise.
    pub normals: bool,
    /// Shows the model's vertex colours (everything but windows, whose designs hold the
    /// colours of their panes); white otherwise.
    pub colours: bool,
}

impl MaterialNeeds {
    /// An opaque material that keeps every attribute the source has.
    pub const OPAQUE: MaterialNeeds = MaterialNeeds {
        window: false,
        tangents: false,
        uvs: true,
        normals: true,
        colours: true,
    };
}

/// Per-stage numbers, for `cooker cook -v`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshStats {
    pub triangles_in: usize,
    pub degenerate_dropped: usize,
    pub triangles_out: usize,
    pub corners: usize,
    pub vertices_out: usize,
    pub normals_generated: usize,
    pub tangent_triangles: usize,
    /// ACMR with a FIFO cache of 16, before and after cache optimization.
    pub acmr_in: f32,
    pub acmr_out: f32,
    pub overfetch: f32,
    pub stages: Vec<(&'static str, Duration)>,
}

/// A processed mesh's vertices, attribute by attribute. An attribute no vertex has (every
/// value zero) is an empty array: a bare mesh's vertices take 26 bytes each here (position,
/// normal, material) where whole [`StandardVertex`]es took 52, and a large mesh's were gathered
/// into one block that no freed one fitted (the 1M-triangle grid's cook grew by 10 MB of RSS
/// there).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexArrays {
    pub positions: Vec<[f32; 3]>,
    /// One per vertex, or empty when all are zero; as are `uvs` and `tangents`.
    pub normals: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    pub tangents: Vec<[f32; 4]>,
    pub materials: Vec<u16>,
    /// One per vertex, or empty when all are white ([`pack::vertex::WHITE`]).
    pub colours: Vec<[u8; 4]>,
}

impl VertexArrays {
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Vertex `i` whole.
    pub fn get(&self, i: usize) -> StandardVertex {
        StandardVertex {
            position: self.positions[i],
            normal: self.normals.get(i).copied().unwrap_or_default(),
            uv: self.uvs.get(i).copied().unwrap_or_default(),
            tangent: self.tangents.get(i).copied().unwrap_or_default(),
            material: [self.materials[i], 0],
            colour: self.colours.get(i).copied().unwrap_or(pack::vertex::WHITE),
        }
    }

    pub fn iter(&self) -> impl ExactSizeIterator<Item = StandardVertex> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    /// The vertices `order` names, in that order; each attribute's old array goes as its new
    /// one is made.
    pub fn permuted(self, order: &[u32]) -> Self {
        use rayon::prelude::*;
        fn column<T: Copy + Send + Sync>(v: Vec<T>, order: &[u32]) -> Vec<T> {
            if v.is_empty() {
                v
            } else {
                order.par_iter().map(|&i| v[i as usize]).collect()
            }
        }
        Self {
            positions: column(self.positions, order),
            normals: column(self.normals, order),
            uvs: column(self.uvs, order),
            tangents: column(self.tangents, order),
            materials: column(self.materials, order),
            colours: column(self.colours, order),
        }
    }

    /// Drops each optional attribute whose every value is zero (+0.0: a -0.0 is kept, so that
    /// [`Self::get`] gives back the very bits), and the colours where all are white.
    fn drop_zero_attributes(&mut self) {
        fn zero<const N: usize>(v: &[[f32; N]]) -> bool {
            v.iter().flatten().all(|x| x.to_bits() == 0)
        }
        if zero(&self.normals) {
            self.normals = Vec::new();
        }
        if zero(&self.uvs) {
            self.uvs = Vec::new();
        }
        if zero(&self.tangents) {
            self.tangents = Vec::new();
        }
        if self.colours.iter().all(|&c| c == pack::vertex::WHITE) {
            self.colours = Vec::new();
        }
    }
}

impl FromIterator<StandardVertex> for VertexArrays {
    fn from_iter<I: IntoIterator<Item = StandardVertex>>(iter: I) -> Self {
        let mut out = Self::default();
        for v in iter {
            out.positions.push(v.position);
            out.normals.push(v.normal);
            out.uvs.push(v.uv);
            out.tangents.push(v.tangent);
            out.materials.push(v.material[0]);
            out.colours.push(v.colour);
        }
        out.drop_zero_attributes();
        out
    }
}

/// Processed geometry of one mesh.
#[derive(Clone, Debug, Default)]
pub struct Processed {
    pub vertices: VertexArrays,
    pub indices: Vec<u32>,
    pub ranges: Vec<pack::DrawRange>,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    pub stats: MeshStats,
}

/// A triangle soup without normals, UVs or names, for tests.
#[cfg(test)]
pub(crate) fn soup(positions: Vec<[f32; 3]>, tris: Vec<[u32; 3]>) -> crate::import::Imported {
    let n = tris.len();
    crate::import::Imported {
        positions,
        corners: tris
            .iter()
            .flatten()
            .map(|&p| crate::import::Corner {
                p,
                t: crate::import::NONE,
                n: crate::import::NONE,
            })
            .collect(),
        tri_part: vec![0; n],
        parts: vec![crate::import::Part {
            names: Default::default(),
            material: None,
        }],
        ..Default::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vertex_arrays_give_back_the_very_vertices() {
        let v = [
            StandardVertex {
                position: [1.0, 2.0, 3.0],
                // -0.0 is not zero to the arrays: the normals stay, bits and all.
                normal: [0.0, 0.0, -0.0],
                material: [3, 0],
                ..Default::default()
            },
            StandardVertex {
                position: [-4.0, 5.0, 6.0],
                material: [1, 0],
                ..Default::default()
            },
        ];
        let a: VertexArrays = v.iter().copied().collect();
        assert_eq!(a.len(), 2);
        assert_eq!(a.normals.len(), 2);
        assert!(a.uvs.is_empty() && a.tangents.is_empty());
        for (i, v) in v.iter().enumerate() {
            assert_eq!(bytemuck::bytes_of(&a.get(i)), bytemuck::bytes_of(v));
        }
        let b: VertexArrays = a.iter().collect();
        assert_eq!(a, b);
    }
}
