//! The TOML shape of a manifest, as serde reads it: unknown keys, wrong types and names that
//! are no variant of an enum fail here, with toml's position. Values that need more than
//! their type (files that must exist, ranges, per-type light fields) keep their position in a
//! [`Spanned`] for the checks in `check.rs`.

use serde::Deserialize;
use toml::Spanned;

use super::{Fit, NameKind, UvMode};

/// Three numbers, exactly: serde's arrays read the first three of a longer list and drop the
/// rest, so `inside = [-1, 0, 0, 5]` or a colour of four values cooked without a word.
fn v3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<[f32; 3], D::Error> {
    let v = Vec::<f32>::deserialize(d)?;
    <[f32; 3]>::try_from(v.as_slice())
        .map_err(|_| serde::de::Error::invalid_length(v.len(), &"an array of length 3"))
}

struct V3([f32; 3]);

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        v3(d).map(V3)
    }
}

fn opt_v3<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Option<[f32; 3]>, D::Error> {
    Ok(Option::<V3>::deserialize(d)?.map(|v| v.0))
}

fn opt_spanned_v3<'de, D: serde::Deserializer<'de>>(
    d: D,
) -> Result<Option<Spanned<[f32; 3]>>, D::Error> {
    Ok(Option::<Spanned<V3>>::deserialize(d)?.map(|v| {
        let span = v.span();
        Spanned::new(span, v.into_inner().0)
    }))
}

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
    /// Checked into a u32 by `check`, so an out-of-range value is named as such rather than
    /// as no whole number.
    pub max_size: Option<Spanned<i64>>,
}

#[derive(Deserialize)]
#[serde(untagged, expecting = "a number or [x, y, z]")]
pub(super) enum Scale {
    Uniform(f32),
    Axes(#[serde(deserialize_with = "v3")] [f32; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Mesh {
    pub source: Spanned<String>,
    pub name: Option<String>,
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub translate: Option<Spanned<[f32; 3]>>,
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub rotate_deg: Option<Spanned<[f32; 3]>>,
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
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub diffuse: Option<Spanned<[f32; 3]>>,
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub specular: Option<Spanned<[f32; 3]>>,
    pub shininess: Option<Spanned<f32>>,
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub emissive: Option<Spanned<[f32; 3]>>,
    pub texture: Option<Spanned<String>>,
    pub normal_map: Option<Spanned<String>>,
    pub normal_strength: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Window {
    pub name: Option<Spanned<String>>,
    pub material: Option<Spanned<String>>,
    pub design: Option<Spanned<String>>,
    pub uv: Option<UvMode>,
    pub fit: Option<Fit>,
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub inside: Option<Spanned<[f32; 3]>>,
    pub came_width: Option<Spanned<f32>>,
    pub texels_per_metre: Option<Spanned<f32>>,
    /// A [`pack::ColourSpace`] name; the pack names its colour spaces.
    pub colour_space: Option<Spanned<String>>,
    pub normal_map: Option<Spanned<String>>,
    pub normal_encoding: Option<texture::NormalEncoding>,
    pub green: Option<texture::GreenAxis>,
    pub normal_strength: Option<Spanned<f32>>,
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
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub direction: Option<Spanned<[f32; 3]>>,
    pub angular_size_deg: Option<Spanned<f32>>,
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub position: Option<Spanned<[f32; 3]>>,
    pub radius: Option<Spanned<f32>>,
    pub inner_cone_deg: Option<Spanned<f32>>,
    pub outer_cone_deg: Option<Spanned<f32>>,
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub colour: Option<Spanned<[f32; 3]>>,
    pub intensity: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Camera {
    pub name: String,
    #[serde(deserialize_with = "v3")]
    pub position: [f32; 3],
    #[serde(deserialize_with = "v3")]
    pub target: [f32; 3],
    #[serde(default, deserialize_with = "opt_v3")]
    pub up: Option<[f32; 3]>,
    pub fov_y_deg: Option<Spanned<f32>>,
    pub near: Option<Spanned<f32>>,
    pub far: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct Background {
    #[serde(default, deserialize_with = "opt_spanned_v3")]
    pub colour: Option<Spanned<[f32; 3]>>,
    pub panorama: Option<Spanned<String>>,
}
