//! How to cook: every knob that shapes a pack.

use crate::mesh::MeshSettings;
use crate::{cache, manifest, mesh};

/// How to cook.
#[derive(Clone, Debug)]
pub struct Settings {
    pub mesh: MeshSettings,
    /// Quantize vertices (positions to `position_bits`, octahedral normals, 16-bit UVs).
    pub quantize: bool,
    pub position_bits: mesh::PositionBits,
    /// Cook textures; off for geometry-only checks such as `cooker validate`.
    pub textures: bool,
    /// Reuse cooked textures from this cache, and store new ones in it.
    pub cache: Option<cache::Cache>,
    /// `--window NAME=IMAGE` designs, taking precedence over the manifest's `[[window]]`s.
    pub window_overrides: Vec<manifest::WindowDesign>,
    /// `--texture-format`: stores every texture so, over the manifest's `[textures] format`
    /// and every window's `texture_format`.
    pub texture_format: Option<manifest::TextureFormatChoice>,
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            mesh: MeshSettings::default(),
            quantize: false,
            position_bits: mesh::PositionBits::B16,
            textures: true,
            cache: None,
            window_overrides: Vec::new(),
            texture_format: None,
        }
    }
}
