//! The texture stage: decodes the images materials and windows refer to and cooks their mip
//! chains into pack textures.

use crate::{CookError, Report, Settings, Warning, manifest::Manifest, tag::Tagging};

/// Cooks every texture the materials use; returns the pack's texture table and mip data, and
/// fills each material's texture references.
pub fn cook_textures(
    manifest: &Manifest,
    tagging: &mut Tagging,
    settings: &Settings,
    report: &mut Report,
) -> Result<(Vec<pack::Texture>, Vec<Vec<Vec<u8>>>), CookError> {
    let referenced = tagging
        .materials
        .iter()
        .map(|m| m.diffuse_texture.is_some() as usize + m.normal_texture.is_some() as usize)
        .sum::<usize>()
        + manifest.windows.len();
    if settings.textures && referenced > 0 {
        report.warnings.push(Warning::new(
            &manifest.path,
            None,
            format!("{referenced} texture references not cooked: texture cooking is not built in yet"),
        ));
    }
    Ok((Vec::new(), Vec::new()))
}
