//! The scene manifest (`scene.toml`), parsed exactly as `docs/scene-manifest.md` documents it.
//!
//! Two steps: serde reads the TOML shape (`model.rs`: types, unknown keys, enum names), then a
//! validation pass (`check.rs`) checks what a type cannot say (files that exist, ranges,
//! per-type light fields). Every error names the manifest and the line: toml's spans locate
//! the first kind, [`toml::Spanned`] values the second.

mod check;
mod glob;
mod model;

pub use glob::{NameGlob, NameSet};

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::CookError;

/// A parsed, checked manifest. Paths are resolved against the manifest's directory and exist.
#[derive(Clone, Debug)]
pub struct Manifest {
    /// The manifest file, or the bare mesh file for [`Manifest::from_mesh_file`].
    pub path: PathBuf,
    pub scene: SceneInfo,
    pub textures: Textures,
    pub meshes: Vec<MeshSource>,
    pub rules: Vec<Rule>,
    pub windows: Vec<WindowDesign>,
    pub light: Option<Light>,
    pub cameras: Vec<Camera>,
    pub background: Background,
    /// True for a bare mesh cooked without a manifest: heuristics only.
    pub bare: bool,
    /// The files the manifest names, where: an image or mesh that cannot be used is reported
    /// at its line ([`Manifest::at_its_line`]).
    pub named_files: Vec<NamedFile>,
}

/// A file a manifest names: a mesh source, a design, a texture, a normal map, a panorama.
#[derive(Clone, Debug)]
pub struct NamedFile {
    /// As found (relative to the manifest's directory).
    pub path: PathBuf,
    pub line: Line,
    /// The key, as an error says it (`window design`, `panorama`).
    pub what: &'static str,
    /// As the manifest writes it.
    pub written: String,
}

/// [`NamedFile::what`] of a `[[mesh]] source`, the one kind of file named that is no image.
pub(crate) const MESH_SOURCE: &str = "mesh source";

impl NamedFile {
    pub fn is_image(&self) -> bool {
        self.what != MESH_SOURCE
    }
}

#[derive(Clone, Debug, Default)]
pub struct SceneInfo {
    pub name: Option<String>,
    /// Error budget in 8-bit sRGB LSB for blur and mip method choices. The cook reads it
    /// from [`crate::Settings`], which takes it from here.
    pub max_error: Option<f32>,
    /// How names in the meshes' OBJ and MTL files that are not UTF-8 are read; `None`: as
    /// guessed from them. [`crate::Settings`] takes it from here.
    pub text_encoding: Option<crate::import::text::TextEncoding>,
}

/// How textures are stored in the pack (`[textures] format`, `--texture-format`, or a
/// window's `texture_format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum TextureFormatChoice {
    /// Block-compress each texture with the cheapest encoder setting whose measured error fits
    /// the budget; keep RGBA8 where none does.
    #[default]
    Auto,
    /// Uncompressed RGBA8.
    Rgba8,
    /// Block-compress every texture (BC7 colour, BC5 normal maps), the most accurate setting
    /// with a warning where none fits the budget.
    Bc,
}

impl TextureFormatChoice {
    pub const CHOICES: [(&'static str, TextureFormatChoice); 3] = [
        ("auto", Self::Auto),
        ("rgba8", Self::Rgba8),
        ("bc", Self::Bc),
    ];

    pub fn name(self) -> &'static str {
        Self::CHOICES
            .iter()
            .find(|(_, c)| *c == self)
            .map(|(n, _)| *n)
            .unwrap_or("auto")
    }
}

/// The `[textures]` table. The cook reads its values from [`crate::Settings`], which takes
/// them from here.
#[derive(Clone, Debug)]
pub struct Textures {
    pub mip_filter: texture::MipFilter,
    pub format: TextureFormatChoice,
    /// Budget for block-compressed normal maps: mean angle in degrees (`None`: the default,
    /// `budget::DEFAULT_NORMAL_ERROR_DEG`).
    pub max_normal_error_deg: Option<f32>,
    /// Budget for block-compressed window designs, RMS LSB (`None`: `[scene] max_error`, else
    /// `budget::DEFAULT_DESIGN_ERROR_LSB`).
    pub max_design_error_lsb: Option<f32>,
    /// Lossless compression of every texture's levels in the pack (default zstd).
    pub supercompression: pack::Supercompression,
    /// The largest side a stored texture may have (`None`: as its image).
    pub max_size: Option<u32>,
}

impl Default for Textures {
    fn default() -> Self {
        Self {
            mip_filter: texture::MipFilter::default(),
            format: TextureFormatChoice::default(),
            max_normal_error_deg: None,
            max_design_error_lsb: None,
            supercompression: pack::Supercompression::Zstd,
            max_size: None,
        }
    }
}

/// Where in the manifest a value came from, for errors found after parsing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct Line(pub usize);

#[derive(Clone, Debug)]
pub struct MeshSource {
    pub source: PathBuf,
    pub name: String,
    pub translate: [f32; 3],
    pub rotate_deg: [f32; 3],
    pub scale: [f32; 3],
    pub line: Line,
}

impl MeshSource {
    /// Scale, then rotate (XYZ Euler, degrees), then translate. Quarter turns (every angle a
    /// multiple of 90°) have exact entries, as `--up z`'s turn does: `cooker init` writes that
    /// turn as `rotate_deg = [-90, 0, 0]`, which must move coordinates, not round them (the
    /// sines and cosines of a quaternion's half angles put 1e-7 where 0 belongs).
    pub fn transform(&self) -> glam::Mat4 {
        let scale = glam::Vec3::from(self.scale);
        let translate = glam::Vec3::from(self.translate);
        if let Some(turn) = quarter_turns(self.rotate_deg) {
            let mut m = turn * glam::Mat4::from_scale(scale);
            m.w_axis = translate.extend(1.0);
            return m;
        }
        let r = self.rotate_deg.map(f32::to_radians);
        glam::Mat4::from_scale_rotation_translation(
            scale,
            glam::Quat::from_euler(glam::EulerRot::XYZ, r[0], r[1], r[2]),
            translate,
        )
    }
}

/// The XYZ Euler rotation of `degrees` with exact entries (0 and ±1), where every angle is a
/// whole number of quarter turns; `None` otherwise.
fn quarter_turns(degrees: [f32; 3]) -> Option<glam::Mat4> {
    let exact = |d: f32| -> Option<(f32, f32)> {
        let q = d / 90.0;
        if !(q.is_finite() && q.fract() == 0.0) {
            return None;
        }
        // (sin, cos) of q quarter turns.
        Some(match (q as i64).rem_euclid(4) {
            0 => (0.0, 1.0),
            1 => (1.0, 0.0),
            2 => (0.0, -1.0),
            _ => (-1.0, 0.0),
        })
    };
    let [(sx, cx), (sy, cy), (sz, cz)] =
        [exact(degrees[0])?, exact(degrees[1])?, exact(degrees[2])?];
    let x = glam::Mat3::from_cols_array(&[1.0, 0.0, 0.0, 0.0, cx, sx, 0.0, -sx, cx]);
    let y = glam::Mat3::from_cols_array(&[cy, 0.0, -sy, 0.0, 1.0, 0.0, sy, 0.0, cy]);
    let z = glam::Mat3::from_cols_array(&[cz, sz, 0.0, -sz, cz, 0.0, 0.0, 0.0, 1.0]);
    // No -0.0 entries (+ 0.0 clears the sign), as `UpAxis::to_y_up` has none: a normal's
    // zero component keeps its sign bit from the model, not from the turn's spelling.
    let m = (x * y * z).to_cols_array().map(|e| e + 0.0);
    Some(glam::Mat4::from_mat3(glam::Mat3::from_cols_array(&m)))
}

/// Which source names a rule looks at.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum NameKind {
    Material,
    Group,
    Object,
    Mesh,
    Node,
}

impl NameKind {
    pub const ALL: [NameKind; 5] = [
        Self::Material,
        Self::Group,
        Self::Object,
        Self::Mesh,
        Self::Node,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Material => "material",
            Self::Group => "group",
            Self::Object => "object",
            Self::Mesh => "mesh",
            Self::Node => "node",
        }
    }
}

/// The rule class that makes a window whose upper/lower class follows its sill.
pub const WINDOW_BY_SILL: &str = "window";

#[derive(Clone, Debug)]
pub struct Rule {
    pub pattern: String,
    pub on: Vec<NameKind>,
    pub class: pack::MaterialClass,
    /// `class = "window"`: a window, upper or lower by its sill height (the cook decides,
    /// per window instance), instead of a fixed class.
    pub by_sill: bool,
    pub material: Option<String>,
    pub diffuse: Option<[f32; 3]>,
    pub specular: Option<[f32; 3]>,
    pub shininess: Option<f32>,
    pub emissive: Option<[f32; 3]>,
    pub texture: Option<PathBuf>,
    pub normal_map: Option<PathBuf>,
    /// Replaces the source's strength (`-bm`, glTF's `scale`) of the material's normal map.
    pub normal_strength: Option<f32>,
    pub line: Line,
}

/// Where a window's texture coordinates come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum UvMode {
    /// The source's own UVs where the triangles have them, else planar.
    #[default]
    #[serde(rename = "source")]
    Auto,
    /// Always generated from the window's rectangle.
    Planar,
}

/// How a design image of another aspect ratio fills a window's rectangle (planar UVs only).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Fit {
    /// Fills the glass and crops the excess, as a photo fills a frame.
    #[default]
    Cover,
    /// The whole design, with clear glass around it.
    Contain,
    /// Fills the rectangle exactly, distorting the design.
    Stretch,
}

impl Fit {
    /// As the manifest writes it.
    pub fn name(self) -> &'static str {
        match self {
            Fit::Cover => "cover",
            Fit::Contain => "contain",
            Fit::Stretch => "stretch",
        }
    }
}

/// Lead came width as a fraction of a window's shorter side, when the manifest gives none.
pub const DEFAULT_CAME_WIDTH: f32 = 0.015;
/// Resolution of designs rasterized from the mesh, when the manifest gives none.
pub const DEFAULT_TEXELS_PER_METRE: f32 = 128.0;

/// A `[[window]]` entry: which windows it describes, and how. (Serialized into cache keys
/// when it comes from `--window`.)
#[derive(Clone, Debug, Serialize)]
pub struct WindowDesign {
    /// Glob over window names (`cooker info` lists them).
    pub name: Option<NameGlob>,
    /// Glob over the materials of a window's triangles (source or pack names).
    pub material: Option<NameGlob>,
    /// The design image; `None` rasterizes one from the panes' colours.
    #[serde(serialize_with = "path_bytes")]
    pub design: Option<PathBuf>,
    pub colour_space: pack::ColourSpace,
    #[serde(serialize_with = "path_bytes")]
    pub normal_map: Option<PathBuf>,
    pub normal_encoding: texture::NormalEncoding,
    pub green: texture::GreenAxis,
    /// Scales the window's normal map, given or derived (default 1, or the glass's own).
    pub normal_strength: Option<f32>,
    pub blur_sigma: Option<f32>,
    /// Overrides `[textures] format` for this window's design, normal map and projector.
    pub texture_format: Option<TextureFormatChoice>,
    pub uv: UvMode,
    pub fit: Fit,
    /// A direction pointing into the building, overriding the guess.
    pub inside: Option<[f32; 3]>,
    /// Lead came width, a fraction of the shorter side (designs from the mesh).
    pub came_width: f32,
    /// Resolution of a design rasterized from the mesh, in texels per scene unit as given;
    /// `None`: [`DEFAULT_TEXELS_PER_METRE`] per metre, the model's unit told from its windows'
    /// sizes ([`crate::design::unit_from_windows`]).
    #[serde(serialize_with = "texels_or_default")]
    pub texels_per_metre: Option<f32>,
    pub line: Line,
}

/// `texels_per_metre` as the f32 the cache keys held before it was optional (the default when
/// unset), so keys of cooks that do not set it are unchanged.
fn texels_or_default<S: serde::Serializer>(v: &Option<f32>, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_f32(v.unwrap_or(DEFAULT_TEXELS_PER_METRE))
}

/// A path as its bytes: serde's own form of a path fails on one that is not UTF-8.
fn path_bytes<S: serde::Serializer>(path: &Option<PathBuf>, s: S) -> Result<S::Ok, S::Error> {
    path.as_ref()
        .map(|p| p.as_os_str().as_encoded_bytes())
        .serialize(s)
}

/// The unit direction a manifest's light `direction` stands for. One already of unit length
/// (within f32 rounding) is kept as written: normalizing it again can move it by an ulp, so
/// the exact direction `cooker init` writes out would not come back as written.
pub fn light_direction(v: glam::Vec3) -> glam::Vec3 {
    if (v.length_squared() - 1.0).abs() <= 4.0 * f32::EPSILON {
        v
    } else {
        v.normalize()
    }
}

impl WindowDesign {
    /// A design entry for `--window NAME=IMAGE`: NAME matches window names and materials.
    pub fn from_override(pattern: &str, design: PathBuf) -> Self {
        Self {
            name: Some(NameGlob::new(pattern)),
            material: Some(NameGlob::new(pattern)),
            design: Some(design),
            colour_space: pack::ColourSpace::Srgb,
            normal_map: None,
            normal_encoding: texture::NormalEncoding::Rgb,
            green: texture::GreenAxis::OpenGl,
            normal_strength: None,
            blur_sigma: None,
            texture_format: None,
            uv: UvMode::Auto,
            fit: Fit::Cover,
            inside: None,
            came_width: DEFAULT_CAME_WIDTH,
            texels_per_metre: None,
            line: Line(0),
        }
    }

    /// Parses a command line's `NAME=IMAGE`.
    pub fn parse_override(s: &str) -> Result<(String, PathBuf), String> {
        match s.split_once('=') {
            Some((name, image)) if !name.is_empty() && !image.is_empty() => {
                // Checked here as the manifest's globs are, rather than matching only itself.
                NameGlob::checked(name).map_err(|e| format!("invalid glob {name:?}: {e}"))?;
                Ok((name.to_string(), PathBuf::from(image)))
            }
            _ => Err(format!("{s:?} is not NAME=IMAGE")),
        }
    }

    /// Design entries for `--window NAME=IMAGE` arguments. Each image's header must be one
    /// the cook reads, so a missing file, a file that is no image or one too large fails
    /// before any cooking, naming the option. Its texels are decoded by the cook that needs
    /// them (one that hits its cache never does; decoding here too held a 4096² design's
    /// 64 MiB on every re-cook); corrupt data past the header is said as the option then
    /// ([`WindowDesign::at_its_option`]).
    pub fn overrides(windows: &[(String, PathBuf)]) -> Result<Vec<WindowDesign>, CookError> {
        windows
            .iter()
            .map(|(name, image)| {
                texture::probe_image(image).map_err(|e| CookError::WindowImage {
                    pattern: name.clone(),
                    path: image.clone(),
                    source: Box::new(e.into()),
                })?;
                Ok(Self::from_override(name, image.clone()))
            })
            .collect()
    }

    /// `e`, when it is about the image of a `--window NAME=IMAGE` override, as that option's
    /// error (the scene names no such file, so its path alone read like one of the scene's).
    pub fn at_its_option(overrides: &[WindowDesign], e: CookError) -> CookError {
        if e.is_io() || matches!(e, CookError::WindowImage { .. }) {
            return e;
        }
        let Some(path) = e.path().map(Path::to_path_buf) else {
            return e;
        };
        match overrides
            .iter()
            .rev()
            .find(|o| o.design.as_deref() == Some(path.as_path()))
        {
            Some(o) => CookError::WindowImage {
                pattern: o.name.as_deref().unwrap_or_default().to_string(),
                path,
                source: Box::new(e),
            },
            None => e,
        }
    }

    /// Whether this entry describes the window `name` made of `materials`.
    pub fn matches<'a>(&self, name: &str, mut materials: impl Iterator<Item = &'a str>) -> bool {
        self.name.as_ref().is_some_and(|p| p.is_match(name))
            || self
                .material
                .as_ref()
                .is_some_and(|p| materials.any(|m| p.is_match(m)))
    }

    /// What the entry names, for messages.
    pub fn describe(&self) -> String {
        match (&self.name, &self.material) {
            (Some(n), Some(m)) if n == m => format!("{n:?}"),
            (Some(n), _) => format!("window {n:?}"),
            (None, Some(m)) => format!("material {m:?}"),
            (None, None) => "nothing".into(),
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub kind: pack::LightKind,
    pub colour: [f32; 3],
    pub intensity: f32,
}

pub type Camera = pack::Camera;

#[derive(Clone, Debug, Default)]
pub struct Background {
    /// Black unless given.
    pub colour: [f32; 3],
    pub panorama: Option<PathBuf>,
    /// Whether the colour was chosen: given in `[background]`, or a bare cook's guessed sky.
    /// A window shows it behind its glass, so the black default drew windows black.
    pub colour_given: bool,
}

impl Manifest {
    /// `e`, when it is about a file this manifest names and gives no line of its own (an
    /// image that does not decode, a mesh source in no format the cook reads), as an error at
    /// the manifest line that names the file: the file's name alone left a user with several
    /// entries naming similar files to search for the one at fault. I/O failures stay what
    /// they are (their exit status differs).
    pub fn at_its_line(&self, e: CookError) -> CookError {
        if e.is_io()
            || matches!(
                e,
                CookError::Manifest { .. }
                    | CookError::Source { line: Some(_), .. }
                    | CookError::WindowImage { .. }
                    | CookError::MaterialImage { .. }
            )
        {
            return e;
        }
        // A file named both as a mesh and as an image (`design = "room.obj"`): an image's
        // error is about the entry naming it as one.
        let image = matches!(e, CookError::Texture(_));
        let Some(n) = e.path().and_then(|p| {
            let mut named = self.named_files.iter().filter(|n| n.path == p);
            named
                .clone()
                .find(|n| n.is_image() == image)
                .or_else(|| named.next())
        }) else {
            return e;
        };
        CookError::Manifest {
            path: self.path.clone(),
            line: Some(n.line.0),
            message: format!("{} {:?} cannot be used: {e}", n.what, n.written),
        }
    }

    /// The first entry that names `path` as `what` (a [`NamedFile::what`]), else the first
    /// that names it at all, for errors and warnings about the file: one image can be a
    /// rule's texture and a window's normal map.
    pub fn naming(&self, path: &Path, what: Option<&str>) -> Option<&NamedFile> {
        let mut named = self.named_files.iter().filter(|n| n.path == path);
        named
            .clone()
            .find(|n| Some(n.what) == what)
            .or_else(|| named.next())
    }

    /// This manifest in a scene moved by `-shift` (a model in survey coordinates, see
    /// `pipeline::import_sources`): its cameras and point light, which it places in the
    /// model's coordinates, moved with it (in f64). Itself, borrowed, where nothing moves.
    pub fn shifted(&self, shift: [f64; 3]) -> std::borrow::Cow<'_, Manifest> {
        if shift == [0.0; 3] {
            return std::borrow::Cow::Borrowed(self);
        }
        let moved = |p: [f32; 3]| -> [f32; 3] {
            std::array::from_fn(|k| (f64::from(p[k]) - shift[k]) as f32)
        };
        let mut m = self.clone();
        for c in &mut m.cameras {
            c.position = moved(c.position);
            c.target = moved(c.target);
        }
        if let Some(
            pack::LightKind::Point { position, .. } | pack::LightKind::Spot { position, .. },
        ) = m.light.as_mut().map(|l| &mut l.kind)
        {
            *position = moved(*position);
        }
        std::borrow::Cow::Owned(m)
    }

    /// Reads and checks a `scene.toml`.
    pub fn load(path: &Path) -> Result<Manifest, CookError> {
        let bytes = std::fs::read(path).map_err(|source| CookError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        // Where the text stops being UTF-8: a manifest saved in a legacy code page goes wrong
        // at its first accented name, which the user must find.
        let text = std::str::from_utf8(&bytes).map_err(|e| {
            let at = e.valid_up_to();
            let line = bytes[..at].iter().filter(|&&b| b == b'\n').count() + 1;
            let start = bytes[..at]
                .iter()
                .rposition(|&b| b == b'\n')
                .map_or(0, |i| i + 1);
            // In characters: the bytes before `at` are UTF-8.
            let column = String::from_utf8_lossy(&bytes[start..at]).chars().count();
            CookError::Manifest {
                path: path.to_path_buf(),
                line: Some(line),
                message: format!(
                    "not UTF-8 text: byte 0x{:02x} at column {} (byte offset {at}); save the \
                     manifest as UTF-8",
                    bytes[at],
                    column + 1
                ),
            }
        })?;
        Self::parse(path, text)
    }

    /// Parses manifest text; `path` resolves relative paths and names the manifest in errors.
    pub fn parse(path: &Path, text: &str) -> Result<Manifest, CookError> {
        check::parse(path, text)
    }

    /// A manifest for a bare OBJ/glTF file: no rules (tagging falls back to name heuristics),
    /// no windows designs, no light or cameras.
    pub fn from_mesh_file(path: &Path) -> Result<Manifest, CookError> {
        std::fs::metadata(path).map_err(|source| CookError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        crate::import::mesh_format(path)?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Ok(Manifest {
            path: path.to_path_buf(),
            scene: SceneInfo {
                name: Some(name.clone()),
                max_error: None,
                text_encoding: None,
            },
            textures: Textures::default(),
            meshes: vec![MeshSource {
                source: path.to_path_buf(),
                name,
                translate: [0.0; 3],
                rotate_deg: [0.0; 3],
                scale: [1.0; 3],
                line: Line(0),
            }],
            rules: Vec::new(),
            windows: Vec::new(),
            light: None,
            cameras: Vec::new(),
            background: Background::default(),
            bare: true,
            named_files: Vec::new(),
        })
    }

    /// A manifest for `path`: `.toml` files are manifests, anything else a bare mesh.
    pub fn open(path: &Path) -> Result<Manifest, CookError> {
        let is_toml = path
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml"));
        if is_toml {
            Self::load(path)
        } else {
            Self::from_mesh_file(path)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A directory with the files the examples refer to.
    fn dir() -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        for f in ["corridor.obj", "lancet.png", "hammered.png"] {
            std::fs::write(d.path().join(f), b"").unwrap();
        }
        d
    }

    fn parse(d: &tempfile::TempDir, text: &str) -> Result<Manifest, CookError> {
        Manifest::parse(&d.path().join("scene.toml"), text)
    }

    fn line_of(e: CookError) -> (Option<usize>, String) {
        match e {
            CookError::Manifest { line, message, .. } => (line, message),
            other => panic!("not a manifest error: {other}"),
        }
    }

    /// Paths written on Windows, with backslashes and in another letter case than the files',
    /// name the files; a path that names no file in any case is still an error at its line.
    #[test]
    fn windows_paths_name_the_files() {
        let d = dir();
        std::fs::create_dir(d.path().join("Designs")).unwrap();
        std::fs::write(d.path().join("Designs/Rose.png"), b"").unwrap();
        let m = parse(
            &d,
            "[[mesh]]\nsource = 'CORRIDOR.OBJ'\n\n[[window]]\nname = 'a'\ndesign = 'designs\\rose.PNG'\n",
        )
        .unwrap();
        assert_eq!(m.meshes[0].source, d.path().join("corridor.obj"));
        assert_eq!(m.windows[0].design, Some(d.path().join("Designs/Rose.png")));
        let (line, message) = line_of(
            parse(
                &d,
                "[[mesh]]\nsource = 'corridor.obj'\n\n[[window]]\nname = 'a'\ndesign = 'designs\\lily.png'\n",
            )
            .unwrap_err(),
        );
        assert_eq!(line, Some(6), "{message}");
        assert!(message.contains("cannot be read"), "{message}");
    }

    /// One file however the manifest spells its path: a design written `./x.png` in one entry
    /// and `x.png` in another was decoded and stored twice. Each named file is listed at the
    /// line that names it.
    #[test]
    fn one_file_is_one_path_however_it_is_spelt() {
        let d = dir();
        std::fs::create_dir(d.path().join("designs")).unwrap();
        std::fs::write(d.path().join("designs/rose.png"), b"").unwrap();
        let m = parse(
            &d,
            "[[mesh]]\nsource = 'corridor.obj'\n\n[[window]]\nname = 'a'\ndesign = \
             'designs/rose.png'\n\n[[window]]\nname = 'b'\ndesign = './designs//./rose.png'\n",
        )
        .unwrap();
        assert_eq!(m.windows[0].design, Some(d.path().join("designs/rose.png")));
        assert_eq!(m.windows[1].design, m.windows[0].design);
        let named: Vec<(usize, &str)> = m.named_files.iter().map(|n| (n.line.0, n.what)).collect();
        assert_eq!(
            named,
            [
                (2, MESH_SOURCE),
                (6, "window design"),
                (10, "window design")
            ]
        );
    }

    /// A manifest that is not UTF-8 is refused at the line and column of its first bad byte.
    #[test]
    fn non_utf8_manifests_name_the_line() {
        let d = dir();
        let path = d.path().join("scene.toml");
        std::fs::write(&path, b"[scene]\nname = \"K\xc3\xb6ln \xe9glise\"\n").unwrap();
        let (line, message) = line_of(Manifest::load(&path).unwrap_err());
        assert_eq!(line, Some(2), "{message}");
        assert!(
            message.contains("byte 0xe9 at column 14 (byte offset 22)"),
            "{message}"
        );
    }

    /// `--window NAME=IMAGE` checks NAME as a glob, as the manifest does its patterns: an
    /// invalid one is a usage error, not a name that then matches no window.
    #[test]
    fn window_overrides_check_their_glob() {
        assert_eq!(
            WindowDesign::parse_override("nave-*=rose.png"),
            Ok(("nave-*".to_string(), PathBuf::from("rose.png")))
        );
        let e = WindowDesign::parse_override("nave-[1=rose.png").unwrap_err();
        assert!(e.contains("invalid glob \"nave-[1\""), "{e}");
        let e = WindowDesign::parse_override("rose.png").unwrap_err();
        assert!(e.contains("is not NAME=IMAGE"), "{e}");
    }

    /// Quarter turns are exact and agree with the quaternion route; `[-90, 0, 0]` is the
    /// turn `--up z` makes, to the bit.
    #[test]
    fn quarter_turns_are_exact() {
        let quaternion = |d: [f32; 3]| {
            let r = d.map(f32::to_radians);
            glam::Mat4::from_quat(glam::Quat::from_euler(
                glam::EulerRot::XYZ,
                r[0],
                r[1],
                r[2],
            ))
        };
        let turns = [
            -450.0, -270.0, -180.0, -90.0, 0.0, 90.0, 180.0, 270.0, 360.0,
        ];
        for a in turns {
            for b in turns {
                for c in turns {
                    let exact = quarter_turns([a, b, c]).unwrap();
                    assert!(
                        exact.abs_diff_eq(quaternion([a, b, c]), 1e-6),
                        "{a} {b} {c}: {exact} against {}",
                        quaternion([a, b, c])
                    );
                    let entries = exact.to_cols_array();
                    assert!(
                        entries
                            .iter()
                            .all(|e| [0.0, 1.0, -1.0].contains(e)
                                && e.to_bits() != (-0.0f32).to_bits()),
                        "{entries:?}"
                    );
                }
            }
        }
        assert_eq!(quarter_turns([0.0, 45.0, 0.0]), None);
        assert_eq!(quarter_turns([f32::NAN, 0.0, 0.0]), None);
        let m = MeshSource {
            source: PathBuf::from("m.obj"),
            name: "m".into(),
            translate: [1.0, 2.0, 3.0],
            rotate_deg: [-90.0, 0.0, 0.0],
            scale: [2.0; 3],
            line: Line(0),
        };
        assert_eq!(
            m.transform(),
            glam::Mat4::from_translation(glam::Vec3::new(1.0, 2.0, 3.0))
                * crate::UpAxis::Z.to_y_up()
                * glam::Mat4::from_scale(glam::Vec3::splat(2.0))
        );
        // Any other angle takes the quaternion route, as before.
        let turned = MeshSource {
            rotate_deg: [0.0, 30.0, 0.0],
            ..m
        };
        let r = 30f32.to_radians();
        assert_eq!(
            turned.transform(),
            glam::Mat4::from_scale_rotation_translation(
                glam::Vec3::splat(2.0),
                glam::Quat::from_euler(glam::EulerRot::XYZ, 0.0, r, 0.0),
                glam::Vec3::new(1.0, 2.0, 3.0),
            )
        );
    }

    #[test]
    fn documented_example_parses() {
        // The example of docs/scene-manifest.md with its file names.
        let d = dir();
        let text = r#"
[scene]
name = "corridor"
max_error = 0.55

[textures]
mip_filter = "lanczos3"
format = "bc"
max_normal_error_deg = 0.5
max_design_error_lsb = 2.5
supercompression = "none"
max_size = 2048

[[mesh]]
source = "corridor.obj"
name = "corridor"
translate = [0.0, 1.0, 0.0]
rotate_deg = [0.0, 90.0, 0.0]
scale = [2.0, 2.0, 2.0]

[[rule]]
match = "Floor*"
on = ["material"]
class = "floor"
material = "floor"
diffuse = [0.6, 0.55, 0.5]
specular = [0.05, 0.05, 0.05]
shininess = 16.0
emissive = [0.0, 0.0, 0.0]

[[window]]
material = "lancet_1"
design = "lancet.png"
colour_space = "srgb"
normal_map = "hammered.png"
normal_encoding = "rg"
green = "directx"
blur_sigma = 6.0
texture_format = "rgba8"

[light]
type = "point"
position = [10.0, 8.0, 0.0]
radius = 0.25
colour = [1.0, 0.95, 0.85]
intensity = 4.0

[[camera]]
name = "nave"
position = [0.0, 1.7, 18.0]
target = [0.0, 2.5, 0.0]

[background]
colour = [0.35, 0.5, 0.8]
"#;
        let m = parse(&d, text).unwrap();
        assert_eq!(m.scene.name.as_deref(), Some("corridor"));
        assert_eq!(m.textures.mip_filter, texture::MipFilter::Lanczos3);
        assert_eq!(m.textures.format, TextureFormatChoice::Bc);
        assert_eq!(m.textures.max_design_error_lsb, Some(2.5));
        assert_eq!(m.textures.supercompression, pack::Supercompression::None);
        assert_eq!(m.textures.max_size, Some(2048));
        // Without the keys: no design budget of its own, zstd.
        let mesh = "[[mesh]]\nsource = \"corridor.obj\"\n";
        let bare = parse(&d, &format!("[textures]\nformat = \"auto\"\n{mesh}")).unwrap();
        assert_eq!(bare.textures.max_design_error_lsb, None);
        assert_eq!(bare.textures.supercompression, pack::Supercompression::Zstd);
        assert_eq!(bare.textures.max_size, None);
        for bad in [
            "supercompression = \"lz4\"",
            "max_design_error_lsb = -1",
            "max_size = 0",
            "max_size = -4",
            "max_size = 100000000000",
        ] {
            let e = parse(&d, &format!("[textures]\n{bad}\n{mesh}")).unwrap_err();
            assert!(e.to_string().contains(":2"), "{bad}: {e}");
            if bad.starts_with("max_size") {
                assert!(e.to_string().contains("must be from 1 to"), "{bad}: {e}");
            }
        }
        // A window's blur: 0 is no blur; below 0 or not a number is an error at its line.
        let window = |sigma: &str| {
            parse(
                &d,
                &format!("{mesh}\n[[window]]\nmaterial = \"g\"\nblur_sigma = {sigma}\n"),
            )
        };
        assert_eq!(window("0").unwrap().windows[0].blur_sigma, Some(0.0));
        for bad in ["-1", "nan", "inf"] {
            let e = window(bad).unwrap_err().to_string();
            assert!(e.contains(":6") && e.contains("blur_sigma"), "{bad}: {e}");
        }
        // A normal map's strength, on a window or a rule: negative is dents, not a number or
        // past 64 is an error at its line.
        let strength = |table: &str, s: &str| {
            let head = match table {
                "window" => "[[window]]\nmaterial = \"g\"",
                _ => "[[rule]]\nmatch = \"g\"\nclass = \"wall\"",
            };
            parse(&d, &format!("{mesh}\n{head}\nnormal_strength = {s}\n"))
        };
        assert_eq!(
            strength("window", "-0.5").unwrap().windows[0].normal_strength,
            Some(-0.5)
        );
        assert_eq!(
            strength("rule", "2").unwrap().rules[0].normal_strength,
            Some(2.0)
        );
        for (table, at) in [("window", ":6"), ("rule", ":7")] {
            for bad in ["65", "-100", "nan", "inf"] {
                let e = strength(table, bad).unwrap_err().to_string();
                assert!(
                    e.contains(at) && e.contains("normal_strength"),
                    "{bad}: {e}"
                );
            }
        }
        assert_eq!(m.textures.max_normal_error_deg, Some(0.5));
        assert_eq!(
            m.windows[0].texture_format,
            Some(TextureFormatChoice::Rgba8)
        );
        assert_eq!(m.meshes[0].scale, [2.0; 3]);
        assert_eq!(m.meshes[0].line, Line(14));
        let t = m.meshes[0].transform();
        let p = t.transform_point3(glam::Vec3::X);
        assert!((p - glam::Vec3::new(0.0, 1.0, -2.0)).length() < 1e-5, "{p}");
        assert_eq!(m.rules[0].class, pack::MaterialClass::Floor);
        assert_eq!(m.rules[0].on, vec![NameKind::Material]);
        assert_eq!(m.windows[0].normal_encoding, texture::NormalEncoding::Rg);
        assert_eq!(m.windows[0].green, texture::GreenAxis::DirectX);
        assert_eq!(
            m.light.as_ref().unwrap().kind,
            pack::LightKind::Point {
                position: [10.0, 8.0, 0.0],
                radius: 0.25
            }
        );
        assert_eq!(m.cameras[0].fov_y, 60.0);
        assert_eq!(m.cameras[0].up, [0.0, 1.0, 0.0]);
    }

    /// A spot keeps its cone, in radians, its axis normalized; glTF's defaults fill in.
    #[test]
    fn a_spot_light_keeps_its_cone() {
        let d = dir();
        let mesh = "[[mesh]]\nsource = \"corridor.obj\"\n";
        let spot = "[light]\ntype = \"spot\"\nposition = [0.0, 5.0, 0.0]\nradius = 0.1\ndirection = [0.0, -2.0, 0.0]\n";
        let m = parse(
            &d,
            &format!("{mesh}{spot}inner_cone_deg = 10.0\nouter_cone_deg = 30.0\n"),
        )
        .unwrap();
        assert_eq!(
            m.light.unwrap().kind,
            pack::LightKind::Spot {
                position: [0.0, 5.0, 0.0],
                radius: 0.1,
                direction: [0.0, -1.0, 0.0],
                inner: 10f32.to_radians(),
                outer: 30f32.to_radians(),
            }
        );
        let m = parse(&d, &format!("{mesh}{spot}")).unwrap();
        match m.light.unwrap().kind {
            pack::LightKind::Spot { inner, outer, .. } => {
                assert_eq!((inner, outer), (0.0, std::f32::consts::FRAC_PI_4));
            }
            other => panic!("{other:?}"),
        }
        // A survey-sized shift moves the spot as it moves a point light.
        let m = parse(&d, &format!("{mesh}{spot}")).unwrap();
        let moved = m.shifted([0.0, 1.0, 0.0]);
        assert_eq!(
            moved.light.as_ref().unwrap().kind.lamp(),
            Some(([0.0, 4.0, 0.0], 0.1))
        );
    }

    #[test]
    fn errors_name_the_line() {
        let d = dir();
        let mesh = "[[mesh]]\nsource = \"corridor.obj\"\n";
        let cases = [
            (format!("{mesh}bogus = 1\n"), 3, "unknown field"),
            (
                format!(
                    "{mesh}[light]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\ncolour = [-1.0, 0.5, 2.0]\n"
                ),
                6,
                "light colour [-1.0, 0.5, 2.0] must be finite and non-negative",
            ),
            (
                format!("{mesh}[[camera]]\nname = \"c\"\nfov = 60.0\n"),
                5,
                "expected one of",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 1.0, 5.0]\n\
                     target = [0.0, 1.0, 0.0]\nnear = 1e-9\nfar = 1e3\n"
                ),
                8,
                "camera \"c\": far 1000 is over 1e9 times near 0.000000001",
            ),
            (
                format!("{mesh}[window]\nname = \"w\"\n"),
                3,
                "[window] opens one table, but window is a list; write [[window]] for each entry",
            ),
            (
                format!("{mesh}[textures]\nformat = \"bc\"\nformat = \"rgba8\"\n"),
                5,
                "duplicate key `format`",
            ),
            (
                format!("{mesh}[[window]]\nname = \"w\"\ndesing = \"lancet.png\"\n"),
                5,
                "; did you mean `design`?",
            ),
            (
                format!("{mesh}[[window]]\nname = \"w\"\nuv = \"planer\"\n"),
                5,
                "expected `source` or `planar`; did you mean `planar`?",
            ),
            // Letter case, and a key with a word more or less.
            (
                format!("{mesh}[[window]]\nname = \"w\"\ncolour_space = \"sRGB\"\n"),
                5,
                "; did you mean `srgb`?",
            ),
            (
                format!("{mesh}[textures]\nformat = \"BC7\"\n"),
                4,
                "; did you mean `bc`?",
            ),
            (
                format!("[scene]\nmax_error_lsb = 0.5\n{mesh}"),
                2,
                "; did you mean `max_error`?",
            ),
            (
                format!("{mesh}rotate = [0.0, 90.0, 0.0]\n"),
                3,
                "; did you mean `rotate_deg`?",
            ),
            (
                format!("[scene]\ntext_encoding = \"cp-1251\"\n{mesh}"),
                2,
                "text_encoding: unknown text encoding \"cp-1251\"",
            ),
            (
                format!("{mesh}scale = \"x\"\n"),
                3,
                "scale: a number or [x, y, z]",
            ),
            (
                format!("{mesh}[[window]]\nname = \"w\"\nuv = \"sideways\"\n"),
                5,
                "uv: unknown variant `sideways`, expected `source` or `planar`",
            ),
            (
                format!("{mesh}[[window]]\nname = \"w\"\ncolour_space = \"rgb\"\n"),
                5,
                "colour_space is \"rgb\" but must be one of \"srgb\", \"linear\"",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\nup = \"y\"\n"
                ),
                7,
                "up: invalid type: string \"y\"",
            ),
            // A fourth number was dropped without a word, as was a fifth of any type.
            (
                format!("{mesh}[[window]]\nname = \"w\"\ninside = [-1.0, 0.0, 0.0, 5.0]\n"),
                5,
                "inside: invalid length 4, expected an array of length 3",
            ),
            (
                format!("{mesh}[background]\ncolour = [0.1, 0.2, 0.3, \"junk\", [1, 2]]\n"),
                4,
                "colour: invalid type: string \"junk\"",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 1.0]\n"
                ),
                5,
                "position: invalid length 4, expected an array of length 3",
            ),
            (
                format!("{mesh}[light]\ntype = \"directional\"\ndirection = [0.0, -1.0]\n"),
                5,
                "direction: invalid length 2, expected an array of length 3",
            ),
            (
                format!("{mesh}scale = [1.0, 2.0, 3.0, 4.0]\n"),
                3,
                "scale: a number or [x, y, z]",
            ),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a\"\nclass = \"ceiling\"\n"),
                6,
                "ceiling",
            ),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a\"\nclass = \"Floor\"\n"),
                6,
                "; did you mean `floor`?",
            ),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a[\"\nclass = \"wall\"\n"),
                5,
                "glob",
            ),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a\"\non = [\"texture\"]\nclass = \"wall\"\n"),
                6,
                "texture",
            ),
            (
                "[[mesh]]\nsource = \"missing.obj\"\n".to_string(),
                2,
                "missing.obj",
            ),
            // A file name one letter off: the file beside it is named.
            (
                "[[mesh]]\nsource = \"./corridoor.obj\"\n".to_string(),
                2,
                "; did you mean `./corridor.obj`?",
            ),
            // The manifest's words for a value's type, not Rust's.
            (
                format!("{mesh}[light]\ntype = \"directional\"\nintensity = \"bright\"\n"),
                5,
                "intensity: invalid type: string \"bright\", expected a number",
            ),
            (
                format!("{mesh}[[window]]\nmaterial = \"w\"\ndesign = \"nope.png\"\n"),
                5,
                "nope.png",
            ),
            (
                format!("{mesh}[light]\ntype = \"directional\"\ndirection = [0.0, 0.0, 0.0]\n"),
                5,
                "non-zero",
            ),
            (
                format!(
                    "{mesh}[light]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nradius = 1.0\n"
                ),
                6,
                "radius",
            ),
            (
                format!("{mesh}[light]\ntype = \"sun\"\n"),
                4,
                "type: unknown variant `sun`, expected one of `point`, `directional`, `spot`",
            ),
            // A spot: every field of a lamp and a direction, its cone within 90°.
            (
                format!(
                    "{mesh}[light]\ntype = \"spot\"\nposition = [0.0, 5.0, 0.0]\nradius = 0.1\n"
                ),
                3,
                "a spot light needs `direction`",
            ),
            (
                format!(
                    "{mesh}[light]\ntype = \"spot\"\nposition = [0.0, 5.0, 0.0]\nradius = 0.1\ndirection = [0.0, -1.0, 0.0]\nouter_cone_deg = 120.0\n"
                ),
                8,
                "at most 90",
            ),
            (
                format!(
                    "{mesh}[light]\ntype = \"spot\"\nposition = [0.0, 5.0, 0.0]\nradius = 0.1\ndirection = [0.0, -1.0, 0.0]\ninner_cone_deg = 30.0\nouter_cone_deg = 20.0\n"
                ),
                8,
                "inner_cone_deg is 30 but must lie between 0 and outer_cone_deg (20)",
            ),
            (
                format!(
                    "{mesh}[light]\ntype = \"spot\"\nposition = [0.0, 5.0, 0.0]\nradius = 0.1\ndirection = [0.0, -1.0, 0.0]\nangular_size_deg = 0.5\n"
                ),
                8,
                "`angular_size_deg` does not apply to a spot light",
            ),
            (
                format!(
                    "{mesh}[light]\ntype = \"point\"\nposition = [0.0, 5.0, 0.0]\nradius = 0.1\nouter_cone_deg = 20.0\n"
                ),
                7,
                "`outer_cone_deg` does not apply to a point light",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\nfov_y_deg = -5.0\n"
                ),
                7,
                "fov_y_deg",
            ),
            (
                format!("{mesh}[textures]\nmip_filter = \"cubic\"\n"),
                4,
                "mip_filter: unknown variant `cubic`, expected one of `box`, `kaiser`, `lanczos3`",
            ),
            (format!("{mesh}[scene\n"), 3, ""),
            // Nonsense that cooked before: to an empty pack (a NaN placement), or to a pack
            // the writer refused without the manifest's line (a NaN shininess).
            (
                format!("{mesh}translate = [nan, 0.0, 0.0]\n"),
                3,
                "translate [NaN, 0.0, 0.0] must be finite",
            ),
            (
                format!("{mesh}rotate_deg = [inf, 0.0, 0.0]\n"),
                3,
                "rotate_deg [inf, 0.0, 0.0] must be finite",
            ),
            (
                format!(
                    "{mesh}\n[[rule]]\nmatch = \"a\"\nclass = \"wall\"\ndiffuse = [-3.0, 0.5, 0.5]\n"
                ),
                7,
                "diffuse [-3.0, 0.5, 0.5] must be finite and not negative",
            ),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a\"\nclass = \"wall\"\nshininess = nan\n"),
                7,
                "shininess NaN must be finite and not negative",
            ),
            // The blur's bound is the manifest's: `validate` passed it and the cook failed.
            (
                format!("{mesh}[[window]]\nname = \"w\"\nblur_sigma = 1e6\n"),
                5,
                "blur_sigma is 1000000 but must be a number of texels from 0 (no blur) to 100000",
            ),
            (
                format!("{mesh}[background]\ncolour = [-1.0, 0.0, 0.0]\n"),
                4,
                "background colour [-1.0, 0.0, 0.0] must be finite and not negative",
            ),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a\"\nclass = \"wall\"\nshininess = nan\n"),
                7,
                "shininess NaN must be finite and not negative",
            ),
            (
                format!("{mesh}[[rule]]\nmatch = \"\"\nclass = \"floor\"\n"),
                4,
                "match is empty",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \" \"\nposition = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\n"
                ),
                3,
                "camera name is empty",
            ),
            (
                format!("{mesh}[[window]]\nname = \"w\"\n[[window]]\nname = \"w\"\n"),
                5,
                "window \"w\" is already described by the [[window]] at line 3",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\n[[camera]]\nname = \"c\"\nposition = [1.0, 0.0, 0.0]\ntarget = [0.0, 0.0, 1.0]\n"
                ),
                7,
                "camera \"c\" is already described at line 3",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 0.0, 1.0]\ntarget = [0.0, 0.0, 1.0]\n"
                ),
                3,
                "position must differ from target",
            ),
            (
                format!("{mesh}[background]\ncolour = [-1.0, 0.5, 1.0]\n"),
                4,
                "background colour [-1.0, 0.5, 1.0] must be finite and not negative",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 2.0, 5.0]\ntarget = [0.0, 5.0, 5.0]\nup = [0.0, -3.0, 0.0]\n"
                ),
                3,
                "camera \"c\": up [0.0, -3.0, 0.0] is along the view direction",
            ),
            (
                format!(
                    "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 2.0, 5.0]\ntarget = [0.0, 2.0, 0.0]\nup = [0.0, 0.0, 0.0]\n"
                ),
                3,
                "is zero, not across the view direction",
            ),
            (
                format!(
                    "{mesh}[light]\ntype = \"directional\"\ndirection = [0.0, -1.0, 0.0]\nangular_size_deg = 500.0\n"
                ),
                6,
                "angular_size_deg is 500 but a sun's disc is at most 90° across",
            ),
            (
                "[[mesh]]\nsource = \"corridor.obj\"\nname = \" \"\n".to_string(),
                1,
                "the mesh's name is empty",
            ),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a\"\nclass = \"wall\"\nmaterial = \"\"\n"),
                4,
                "the rule's material name is empty",
            ),
            (
                format!("{mesh}translate = [1e300, 0.0, 0.0]\n"),
                3,
                "translate [inf, 0.0, 0.0] must be finite (a number beyond ±3.4e38",
            ),
            // The same file placed twice in one place, however its path is spelt.
            (
                format!("{mesh}[[mesh]]\nsource = \"./corridor.obj\"\nscale = 1.0\n"),
                3,
                "places \"./corridor.obj\" exactly where the one at line 1 does",
            ),
        ];
        for (text, line, word) in cases {
            let (l, msg) = line_of(parse(&d, &text).unwrap_err());
            assert_eq!(l, Some(line), "{text}\n→ {msg}");
            assert!(msg.contains(word), "{text}\n→ {msg}");
            assert!(!msg.contains("  "), "{text}\n→ {msg}");
        }
        // Straight down with the default up is a plan view (rolled to +z), not a mistake.
        let down = format!(
            "{mesh}[[camera]]\nname = \"c\"\nposition = [0.0, 5.0, 0.0]\ntarget = [0.0, 0.0, 0.0]\n"
        );
        assert_eq!(parse(&d, &down).unwrap().cameras.len(), 1);
        // Moved, it is a second copy.
        let moved =
            format!("{mesh}[[mesh]]\nsource = \"corridor.obj\"\ntranslate = [4.0, 0.0, 0.0]\n");
        assert_eq!(parse(&d, &moved).unwrap().meshes.len(), 2);
        // Two letters off a three-letter key is no typo (`fov` was "did you mean `far`?").
        let fov = format!("{mesh}[[camera]]\nname = \"c\"\nfov = 60.0\n");
        let (_, msg) = line_of(parse(&d, &fov).unwrap_err());
        assert!(!msg.contains("did you mean"), "{msg}");
        let (l, msg) = line_of(parse(&d, "[scene]\nname = \"x\"\n").unwrap_err());
        assert_eq!(l, None);
        assert!(msg.contains("[[mesh]]"));
    }

    #[test]
    fn manifest_errors_display_path_and_line() {
        let d = dir();
        let e = parse(&d, "[[mesh]]\nsource = \"corridor.obj\"\nextra = 1\n").unwrap_err();
        assert!(!e.is_io());
        let s = e.to_string();
        assert!(s.contains("scene.toml:3: "), "{s}");
    }
}
