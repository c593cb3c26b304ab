//! Cooks scene sources (OBJ, glTF, window images) into a pack.
//!
//! [`cook`] (in `pipeline.rs`) is the whole pipeline, top to bottom: import → tag → windows →
//! mesh → window frames → textures → TOC. Each stage is a plain function over plain data, so
//! `cooker validate` can run the first stages ([`prepare`]) and inspect what they produced.

mod buckets;
pub mod budget;
pub mod cache;
#[cfg(feature = "cli")]
pub mod cli;
pub mod design;
mod error;
pub mod guess;
pub mod import;
pub mod instances;
pub mod manifest;
pub mod mesh;
pub mod path_serde;
mod pipeline;
mod prune;
mod report;
mod settings;
pub mod tag;
#[doc(hidden)]
pub mod testing;
mod textures;
pub mod triangulate;
pub mod validate;
pub mod window_plan;
pub mod windows;

pub use error::{CookError, EXIT_INVALID_INPUT, EXIT_IO, EXIT_USAGE, exit_code};
pub use import::Warning;
pub use manifest::Manifest;
pub use mesh::{CacheMode, MeshSettings, MeshStats};
pub use pipeline::{
    CookOutput, Prepared, cook, import_sources, material_needs, no_faces, prepare, window_geometry,
};
pub use report::{
    ArtifactSource, HeuristicNote, MeshReport, QuantizationError, Report, Stage, group_heuristics,
    group_names, length, padded, peak_rss, shown,
};
pub use settings::{Settings, TextureSettings, UpAxis};
