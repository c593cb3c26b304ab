//! Run time against error for every place the toolchain trades accuracy for speed: blur, mips,
//! meshes, god rays, shadows and block compression, each measured against an exact reference on this machine, written as a
//! Markdown report with SVG plots, and the error tables the cooker's budget reads
//! (`crates/cook/src/error_table.json`) and the renderer's god-ray budget reads
//! (`crates/render/src/god_ray_table.json`).
//!
//! The binary (`bench`) is the entry point; the sweeps are library functions so that the test
//! suite runs a small version of each.

pub mod blur;
pub mod common;
pub mod compress;
pub mod first_frame;
pub mod godrays;
pub mod mesh;
pub mod mips;
pub mod report;
pub mod shadows;
pub mod svg;
pub mod tangents;
