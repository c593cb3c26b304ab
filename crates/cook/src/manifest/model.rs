//! The TOML shape of a manifest, as serde reads it: unknown keys, wrong types and names that
//! are no variant of an enum fail here, with toml's position. Values that need more than
//! their type (files that must exist, ranges, per-type light fields) keep their position in a
//! [`Spanned`] for the checks in `check.rs`.

use serde::Deserialize;
use toml::Spanned;

use super::{Fit, NameKind, UvMode};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Manifest {
    pub scene: Option<Scene>,
    pub textures: Option<Textures>,
    #[serde(default)]
    pub mesh: Vec<Spanned<Mesh>>,
    #[serde(default)]
    pub rule: Vec<Spanned<Rule>>,
    #[serde(default)]
    pub window: Vec<Spanned<Window>>,
    pub light: Option<Spanned<Light>>,
    #[serde(default)]
    pub camera: Vec<Spanned<Camera>>,
    pub background: Option<Spanned<Background>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Scene {
    pub name: Option<String>,
    pub max_error: Option<Spanned<f32>>,
    pub text_encoding: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Textures {
    pub mip_filter: Option<texture::MipFilter>,
    pub format: Option<super::TextureFormatChoice>,
    pub max_normal_error_deg: Option<Spanned<f32>>,
    pub max_design_error_lsb: Option<Spanned<f32>>,
    pub supercompression: Option<pack::Supercompression>,
    pub max_size: Option<Spanned<u32>>,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a number or [x, y, z]")]
pub(super) enum Scale {
    Uniform(f32),
    Axes([f32; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Mesh {
    pub source: Spanned<String>,
    pub name: Option<String>,
    pub translate: Option<[f32; 3]>,
    pub rotate_deg: Option<[f32; 3]>,
    pub scale: Option<Spanned<Scale>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Rule {
    #[serde(rename = "match")]
    pub pattern: Spanned<String>,
    pub on: Option<Spanned<Vec<NameKind>>>,
    /// A [`pack::MaterialClass`] name; the pack names its classes.
    pub class: Spanned<String>,
    pub material: Option<String>,
    pub diffuse: Option<[f32; 3]>,
    pub specular: Option<[f32; 3]>,
    pub shininess: Option<f32>,
    pub emissive: Option<[f32; 3]>,
    pub texture: Option<Spanned<String>>,
    pub normal_map: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Window {
    pub name: Option<Spanned<String>>,
    pub material: Option<Spanned<String>>,
    pub design: Option<Spanned<String>>,
    pub uv: Option<UvMode>,
    pub fit: Option<Fit>,
    pub inside: Option<Spanned<[f32; 3]>>,
    pub came_width: Option<Spanned<f32>>,
    pub texels_per_metre: Option<Spanned<f32>>,
    /// A [`pack::ColourSpace`] name; the pack names its colour spaces.
    pub colour_space: Option<Spanned<String>>,
    pub normal_map: Option<Spanned<String>>,
    pub normal_encoding: Option<texture::NormalEncoding>,
    pub green: Option<texture::GreenAxis>,
    pub blur_sigma: Option<Spanned<f32>>,
    pub texture_format: Option<super::TextureFormatChoice>,
}

#[derive(Clone, Copy, Deserialize)]
#[serde(rename_all = "lowercase")]
pub(super) enum LightType {
    Point,
    Directional,
    Spot,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Light {
    #[serde(rename = "type")]
    pub kind: LightType,
    pub direction: Option<Spanned<[f32; 3]>>,
    pub angular_size_deg: Option<Spanned<f32>>,
    pub position: Option<Spanned<[f32; 3]>>,
    pub radius: Option<Spanned<f32>>,
    pub inner_cone_deg: Option<Spanned<f32>>,
    pub outer_cone_deg: Option<Spanned<f32>>,
    pub colour: Option<[f32; 3]>,
    pub intensity: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Camera {
    pub name: String,
    pub position: [f32; 3],
    pub target: [f32; 3],
    pub up: Option<[f32; 3]>,
    pub fov_y_deg: Option<Spanned<f32>>,
    pub near: Option<Spanned<f32>>,
    pub far: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Background {
    pub colour: Option<[f32; 3]>,
    pub panorama: Option<Spanned<String>>,
}
