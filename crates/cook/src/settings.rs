//! How to cook: every knob that shapes a pack, resolved once. [`Settings::new`] takes the
//! manifest's values; a command line then overrides fields of the result. The cook reads its
//! knobs from here only, and every cache key is derived from the serialized form
//! (`cache::scene_key`, `cache::texture_key`), so a knob added here reaches the keys without
//! anyone listing it there.

use serde::Serialize;

use crate::manifest::{Manifest, WindowDesign};
use crate::mesh::{MeshSettings, PositionBits};

/// How to cook a scene.
#[derive(Clone, Debug, Serialize)]
pub struct Settings {
    pub mesh: MeshSettings,
    /// Quantize vertices (positions to `position_bits`, octahedral normals, 16-bit UVs).
    pub quantize: bool,
    pub position_bits: PositionBits,
    /// Cook textures; off for geometry-only checks such as `cooker validate`.
    pub cook_textures: bool,
    /// How textures are cooked: everything a texture's cache key takes from the settings.
    pub textures: TextureSettings,
    /// `--window NAME=IMAGE` designs, taking precedence over the manifest's `[[window]]`s.
    pub window_overrides: Vec<WindowDesign>,
    /// A bare model's up axis (`--up`); a scene.toml turns its meshes with `rotate_deg`.
    /// Left out of the keys at its default, so keys made before it existed still hold.
    #[serde(skip_serializing_if = "UpAxis::is_y")]
    pub up: UpAxis,
    /// `--text-encoding`: how names in OBJ and MTL files that are not UTF-8 are read, rather
    /// than in the encoding guessed from them. Left out of the keys when not given.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub text_encoding: Option<crate::import::text::TextEncoding>,
    /// Where cooked textures are reused from and stored: it changes how long a cook takes,
    /// never what it makes, so no key includes it.
    #[serde(skip)]
    pub cache: Option<crate::cache::Cache>,
}

/// The knobs of the texture stage.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TextureSettings {
    /// Mip reduction filter (`[textures] mip_filter`).
    pub mip_filter: texture::MipFilter,
    /// Error budget in 8-bit sRGB steps (`[scene] max_error`, `--max-error-lsb`): per texture,
    /// the cheapest blur and mip method whose measured error stays within it.
    pub max_error_lsb: Option<f32>,
    /// `--texture-format`: stores every texture so, over the manifest's `[textures] format`
    /// and every window's `texture_format`.
    pub format: Option<crate::manifest::TextureFormatChoice>,
    /// `--supercompression`: over the manifest's `[textures] supercompression`.
    pub supercompression: Option<pack::Supercompression>,
    /// The largest side a stored texture may have (`[textures] max_size`,
    /// `--max-texture-size`): a larger image is cooked from its first mip level that fits.
    /// Left out of the cache key when unset, so keys made before it existed still match.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_size: Option<u32>,
}

impl Settings {
    /// Whether these settings fit `manifest`: `up` turns a bare model only.
    pub fn check(&self, manifest: &Manifest) -> Result<(), crate::CookError> {
        if self.up != UpAxis::Y && !manifest.bare {
            return Err(crate::CookError::UpAxisOfManifest {
                path: manifest.path.clone(),
            });
        }
        Ok(())
    }

    /// The manifest's settings, every other knob at its default.
    pub fn new(manifest: &Manifest) -> Self {
        Self {
            mesh: MeshSettings::default(),
            quantize: false,
            position_bits: PositionBits::B16,
            cook_textures: true,
            textures: TextureSettings {
                mip_filter: manifest.textures.mip_filter,
                max_error_lsb: manifest.scene.max_error,
                format: None,
                supercompression: None,
                max_size: manifest.textures.max_size,
            },
            window_overrides: Vec::new(),
            up: UpAxis::Y,
            text_encoding: manifest.scene.text_encoding,
            cache: None,
        }
    }
}

/// Which axis of a bare model points up. The pipeline takes Y, as glTF does; many CAD and
/// architecture tools (SketchUp, Revit, 3ds Max without its flip) write OBJ files Z-up, whose
/// floor would stand on its edge and catch no sun.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub enum UpAxis {
    #[default]
    Y,
    Z,
}

impl UpAxis {
    fn is_y(&self) -> bool {
        *self == Self::Y
    }

    /// The turn that stands a model with this up axis on Y: for Z, (x, y, z) -> (x, z, −y),
    /// a −90° turn about x as `rotate_deg = [-90, 0, 0]` makes it, but with exact entries, so
    /// coordinates are moved, not rounded.
    pub fn to_y_up(self) -> glam::Mat4 {
        match self {
            Self::Y => glam::Mat4::IDENTITY,
            Self::Z => glam::Mat4::from_cols(
                glam::Vec4::X,
                glam::Vec4::NEG_Z,
                glam::Vec4::Y,
                glam::Vec4::W,
            ),
        }
    }

    /// `--up` on a command line: y or z.
    pub fn from_arg(s: &str) -> Result<Self, String> {
        match s {
            "y" | "Y" => Ok(Self::Y),
            "z" | "Z" => Ok(Self::Z),
            _ => Err(format!("{s:?} is not one of y, z")),
        }
    }
}
