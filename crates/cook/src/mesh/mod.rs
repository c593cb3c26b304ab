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
pub use process::{Deduplicated, deduplicate, is_degenerate, optimize, process};

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
}

impl MaterialNeeds {
    /// An opaque material that keeps every attribute the source has.
    pub const OPAQUE: MaterialNeeds = MaterialNeeds {
        window: false,
        tangents: false,
        uvs: true,
        normals: true,
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

/// Processed geometry of one mesh.
#[derive(Clone, Debug, Default)]
pub struct Processed {
    pub vertices: Vec<StandardVertex>,
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
