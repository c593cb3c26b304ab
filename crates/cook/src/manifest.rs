//! The scene manifest (`scene.toml`), parsed exactly as `docs/scene-manifest.md` documents it.
//!
//! Every error names the manifest and the line: toml's spans locate syntax errors, unknown keys
//! and wrong types; [`toml::Spanned`] keeps the position of each value that is checked after
//! parsing (paths that must exist, enum-like strings, per-type light fields).

use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use crate::CookError;

/// A parsed, checked manifest. Paths are resolved against the manifest's directory and exist.
#[derive(Clone, Debug)]
pub struct Manifest {
    /// The manifest file, or the bare mesh file for [`Manifest::from_mesh_file`].
    pub path: PathBuf,
    pub scene: SceneInfo,
    pub textures: TextureSettings,
    pub meshes: Vec<MeshSource>,
    pub rules: Vec<Rule>,
    pub windows: Vec<WindowDesign>,
    pub light: Option<Light>,
    pub cameras: Vec<Camera>,
    pub background: Background,
    /// True for a bare mesh cooked without a manifest: heuristics only.
    pub bare: bool,
}

#[derive(Clone, Debug, Default)]
pub struct SceneInfo {
    pub name: Option<String>,
    /// Error budget in 8-bit sRGB LSB for blur and mip method choices.
    pub max_error: Option<f32>,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MipFilter {
    #[default]
    Box,
    Kaiser,
    Lanczos3,
}

/// How textures are stored in the pack (`[textures] format`, `--texture-format`, or a
/// window's `texture_format`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
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

#[derive(Clone, Debug, Default)]
pub struct TextureSettings {
    pub mip_filter: MipFilter,
    pub format: TextureFormatChoice,
    /// Budget for block-compressed normal maps: mean angle in degrees (`None`: the default,
    /// `budget::DEFAULT_NORMAL_ERROR_DEG`).
    pub max_normal_error_deg: Option<f32>,
}

/// Where in the manifest a value came from, for errors found after parsing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
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
    /// Scale, then rotate (XYZ Euler, degrees), then translate.
    pub fn transform(&self) -> glam::Mat4 {
        let r = self.rotate_deg.map(f32::to_radians);
        glam::Mat4::from_scale_rotation_translation(
            glam::Vec3::from(self.scale),
            glam::Quat::from_euler(glam::EulerRot::XYZ, r[0], r[1], r[2]),
            glam::Vec3::from(self.translate),
        )
    }
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

#[derive(Clone, Debug)]
pub struct Rule {
    pub pattern: String,
    pub on: Vec<NameKind>,
    pub class: pack::MaterialClass,
    pub material: Option<String>,
    pub diffuse: Option<[f32; 3]>,
    pub specular: Option<[f32; 3]>,
    pub shininess: Option<f32>,
    pub emissive: Option<[f32; 3]>,
    pub texture: Option<PathBuf>,
    pub normal_map: Option<PathBuf>,
    pub line: Line,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NormalEncoding {
    #[default]
    Rgb,
    /// Two channels; z is reconstructed.
    Rg,
}

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GreenAxis {
    /// +Y up.
    #[default]
    OpenGl,
    /// +Y down.
    DirectX,
}

/// Where a window's texture coordinates come from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum UvMode {
    /// The source's own UVs where the triangles have them, else planar.
    #[default]
    Auto,
    /// Always generated from the window's rectangle.
    Planar,
}

/// How a design image of another aspect ratio fills a window's rectangle (planar UVs only).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Fit {
    /// Fills the glass and crops the excess, as a photo fills a frame.
    #[default]
    Cover,
    /// The whole design, with clear glass around it.
    Contain,
    /// Fills the rectangle exactly, distorting the design.
    Stretch,
}

/// Lead came width as a fraction of a window's shorter side, when the manifest gives none.
pub const DEFAULT_CAME_WIDTH: f32 = 0.015;
/// Resolution of designs rasterized from the mesh, when the manifest gives none.
pub const DEFAULT_TEXELS_PER_METRE: f32 = 128.0;

/// A `[[window]]` entry: which windows it describes, and how.
#[derive(Clone, Debug)]
pub struct WindowDesign {
    /// Glob over window names (`cooker info` lists them).
    pub name: Option<String>,
    /// Glob over the materials of a window's triangles (source or pack names).
    pub material: Option<String>,
    /// The design image; `None` rasterizes one from the panes' colours.
    pub design: Option<PathBuf>,
    pub colour_space: pack::ColourSpace,
    pub normal_map: Option<PathBuf>,
    pub normal_encoding: NormalEncoding,
    pub green: GreenAxis,
    pub blur_sigma: Option<f32>,
    /// Overrides `[textures] format` for this window's design, normal map and projector.
    pub texture_format: Option<TextureFormatChoice>,
    pub uv: UvMode,
    pub fit: Fit,
    /// A direction pointing into the building, overriding the guess.
    pub inside: Option<[f32; 3]>,
    /// Lead came width, a fraction of the shorter side (designs from the mesh).
    pub came_width: f32,
    /// Resolution of a design rasterized from the mesh.
    pub texels_per_metre: f32,
    pub line: Line,
}

/// A glob as the manifest writes them; a pattern that does not compile matches only itself.
pub fn glob_matches(pattern: &str, name: &str) -> bool {
    match globset::Glob::new(pattern) {
        Ok(g) => g.compile_matcher().is_match(name),
        Err(_) => pattern == name,
    }
}

impl WindowDesign {
    /// A design entry for `--window NAME=IMAGE`: NAME matches window names and materials.
    pub fn from_override(pattern: &str, design: PathBuf) -> Self {
        Self {
            name: Some(pattern.to_string()),
            material: Some(pattern.to_string()),
            design: Some(design),
            colour_space: pack::ColourSpace::Srgb,
            normal_map: None,
            normal_encoding: NormalEncoding::Rgb,
            green: GreenAxis::OpenGl,
            blur_sigma: None,
            texture_format: None,
            uv: UvMode::Auto,
            fit: Fit::Cover,
            inside: None,
            came_width: DEFAULT_CAME_WIDTH,
            texels_per_metre: DEFAULT_TEXELS_PER_METRE,
            line: Line(0),
        }
    }

    /// Parses a command line's `NAME=IMAGE`.
    pub fn parse_override(s: &str) -> Result<(String, PathBuf), String> {
        match s.split_once('=') {
            Some((name, image)) if !name.is_empty() && !image.is_empty() => {
                Ok((name.to_string(), PathBuf::from(image)))
            }
            _ => Err(format!("{s:?} is not NAME=IMAGE")),
        }
    }

    /// Design entries for `--window NAME=IMAGE` arguments; each image must decode, so a bad
    /// one fails before any cooking, naming the file.
    pub fn overrides(windows: &[(String, PathBuf)]) -> Result<Vec<WindowDesign>, CookError> {
        windows
            .iter()
            .map(|(name, image)| {
                texture::load_image(image)?;
                Ok(Self::from_override(name, image.clone()))
            })
            .collect()
    }

    /// Whether this entry describes the window `name` made of `materials`.
    pub fn matches<'a>(&self, name: &str, mut materials: impl Iterator<Item = &'a str>) -> bool {
        self.name.as_deref().is_some_and(|p| glob_matches(p, name))
            || self
                .material
                .as_deref()
                .is_some_and(|p| materials.any(|m| glob_matches(p, m)))
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
    pub colour: [f32; 3],
    pub panorama: Option<PathBuf>,
}

// ---- the raw TOML shape -------------------------------------------------------------------

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawManifest {
    scene: Option<RawScene>,
    textures: Option<RawTextures>,
    #[serde(default)]
    mesh: Vec<Spanned<RawMesh>>,
    #[serde(default)]
    rule: Vec<Spanned<RawRule>>,
    #[serde(default)]
    window: Vec<Spanned<RawWindow>>,
    light: Option<Spanned<RawLight>>,
    #[serde(default)]
    camera: Vec<RawCamera>,
    background: Option<RawBackground>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawScene {
    name: Option<String>,
    max_error: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawTextures {
    mip_filter: Option<Spanned<String>>,
    format: Option<Spanned<String>>,
    max_normal_error_deg: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum RawScale {
    Uniform(f32),
    Axes([f32; 3]),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawMesh {
    source: Spanned<String>,
    name: Option<String>,
    translate: Option<[f32; 3]>,
    rotate_deg: Option<[f32; 3]>,
    scale: Option<Spanned<RawScale>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawRule {
    #[serde(rename = "match")]
    pattern: Spanned<String>,
    on: Option<Spanned<Vec<NameKind>>>,
    class: Spanned<String>,
    material: Option<String>,
    diffuse: Option<[f32; 3]>,
    specular: Option<[f32; 3]>,
    shininess: Option<f32>,
    emissive: Option<[f32; 3]>,
    texture: Option<Spanned<String>>,
    normal_map: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawWindow {
    name: Option<Spanned<String>>,
    material: Option<Spanned<String>>,
    design: Option<Spanned<String>>,
    uv: Option<Spanned<String>>,
    fit: Option<Spanned<String>>,
    inside: Option<Spanned<[f32; 3]>>,
    came_width: Option<Spanned<f32>>,
    texels_per_metre: Option<Spanned<f32>>,
    colour_space: Option<Spanned<String>>,
    normal_map: Option<Spanned<String>>,
    normal_encoding: Option<Spanned<String>>,
    green: Option<Spanned<String>>,
    blur_sigma: Option<Spanned<f32>>,
    texture_format: Option<Spanned<String>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawLight {
    #[serde(rename = "type")]
    kind: Spanned<String>,
    direction: Option<Spanned<[f32; 3]>>,
    angular_size_deg: Option<Spanned<f32>>,
    position: Option<Spanned<[f32; 3]>>,
    radius: Option<Spanned<f32>>,
    colour: Option<[f32; 3]>,
    intensity: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCamera {
    name: String,
    position: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov_y_deg: Option<Spanned<f32>>,
    near: Option<Spanned<f32>>,
    far: Option<Spanned<f32>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBackground {
    colour: Option<[f32; 3]>,
    panorama: Option<Spanned<String>>,
}

/// Resolves byte offsets in the manifest to 1-based line numbers.
struct Source<'a> {
    path: &'a Path,
    text: &'a str,
}

impl Source<'_> {
    fn line(&self, offset: usize) -> Line {
        let end = offset.min(self.text.len());
        Line(
            self.text.as_bytes()[..end]
                .iter()
                .filter(|&&b| b == b'\n')
                .count()
                + 1,
        )
    }

    fn error(&self, offset: usize, message: impl Into<String>) -> CookError {
        CookError::Manifest {
            path: self.path.to_path_buf(),
            line: Some(self.line(offset).0),
            message: message.into(),
        }
    }

    fn at_line(&self, line: Line, message: impl Into<String>) -> CookError {
        CookError::Manifest {
            path: self.path.to_path_buf(),
            line: Some(line.0),
            message: message.into(),
        }
    }

    fn err_at<T>(&self, span: &Spanned<T>, message: impl Into<String>) -> CookError {
        self.error(span.span().start, message)
    }

    /// A path relative to the manifest that must name an existing file.
    fn file(&self, value: &Spanned<String>, what: &str) -> Result<PathBuf, CookError> {
        let dir = self.path.parent().unwrap_or(Path::new(""));
        let path = dir.join(value.get_ref());
        match std::fs::metadata(&path) {
            Ok(m) if m.is_file() => Ok(path),
            Ok(_) => Err(self.err_at(value, format!("{what} {:?} is not a file", value.get_ref()))),
            Err(e) => Err(self.err_at(
                value,
                format!(
                    "{what} {:?} cannot be read ({}): {e}",
                    value.get_ref(),
                    path.display()
                ),
            )),
        }
    }

    fn positive(&self, value: &Spanned<f32>, what: &str) -> Result<f32, CookError> {
        let v = *value.get_ref();
        if v.is_finite() && v > 0.0 {
            Ok(v)
        } else {
            Err(self.err_at(
                value,
                format!("{what} is {v} but must be a positive number"),
            ))
        }
    }

    fn choice<T: Copy>(
        &self,
        value: &Spanned<String>,
        what: &str,
        options: &[(&str, T)],
    ) -> Result<T, CookError> {
        options
            .iter()
            .find(|(n, _)| *n == value.get_ref())
            .map(|&(_, v)| v)
            .ok_or_else(|| {
                let names: Vec<_> = options.iter().map(|(n, _)| format!("{n:?}")).collect();
                self.err_at(
                    value,
                    format!(
                        "{what} is {:?} but must be one of {}",
                        value.get_ref(),
                        names.join(", ")
                    ),
                )
            })
    }
}

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

impl Manifest {
    /// Reads and checks a `scene.toml`.
    pub fn load(path: &Path) -> Result<Manifest, CookError> {
        let text = std::fs::read_to_string(path).map_err(|source| {
            if source.kind() == std::io::ErrorKind::InvalidData {
                CookError::Manifest {
                    path: path.to_path_buf(),
                    line: None,
                    message: "not UTF-8 text".into(),
                }
            } else {
                CookError::Io {
                    path: path.to_path_buf(),
                    source,
                }
            }
        })?;
        Self::parse(path, &text)
    }

    /// Parses manifest text; `path` resolves relative paths and names the manifest in errors.
    pub fn parse(path: &Path, text: &str) -> Result<Manifest, CookError> {
        let src = Source { path, text };
        let raw: RawManifest = toml::from_str(text).map_err(|e| CookError::Manifest {
            path: path.to_path_buf(),
            line: e.span().map(|s| src.line(s.start).0),
            message: e.message().trim().to_string(),
        })?;

        let scene = match raw.scene {
            Some(s) => SceneInfo {
                name: s.name,
                max_error: s
                    .max_error
                    .map(|m| src.positive(&m, "max_error"))
                    .transpose()?,
            },
            None => SceneInfo::default(),
        };
        let raw_textures = raw.textures.unwrap_or(RawTextures {
            mip_filter: None,
            format: None,
            max_normal_error_deg: None,
        });
        let textures = TextureSettings {
            format: match &raw_textures.format {
                Some(f) => src.choice(f, "format", &TextureFormatChoice::CHOICES)?,
                None => TextureFormatChoice::Auto,
            },
            max_normal_error_deg: raw_textures
                .max_normal_error_deg
                .as_ref()
                .map(|m| src.positive(m, "max_normal_error_deg"))
                .transpose()?,
            mip_filter: match raw_textures.mip_filter {
                Some(f) => src.choice(
                    &f,
                    "mip_filter",
                    &[
                        ("box", MipFilter::Box),
                        ("kaiser", MipFilter::Kaiser),
                        ("lanczos3", MipFilter::Lanczos3),
                    ],
                )?,
                None => MipFilter::Box,
            },
        };

        let mut meshes = Vec::new();
        for m in &raw.mesh {
            let line = src.line(m.span().start);
            let m = m.get_ref();
            let source = src.file(&m.source, "mesh source")?;
            let scale = match &m.scale {
                None => [1.0; 3],
                Some(s) => match s.get_ref() {
                    RawScale::Uniform(k) => [*k; 3],
                    RawScale::Axes(a) => *a,
                },
            };
            if let Some(s) = &m.scale
                && (!finite3(scale) || scale.contains(&0.0))
            {
                return Err(src.err_at(s, format!("scale {scale:?} must be finite and non-zero")));
            }
            let name = m.name.clone().unwrap_or_else(|| {
                source
                    .file_stem()
                    .map(|s| s.to_string_lossy().into_owned())
                    .unwrap_or_default()
            });
            meshes.push(MeshSource {
                source,
                name,
                translate: m.translate.unwrap_or([0.0; 3]),
                rotate_deg: m.rotate_deg.unwrap_or([0.0; 3]),
                scale,
                line,
            });
        }
        if meshes.is_empty() {
            return Err(CookError::Manifest {
                path: path.to_path_buf(),
                line: None,
                message: "no [[mesh]] entries: a scene needs at least one mesh source".into(),
            });
        }

        let mut rules = Vec::new();
        for r in &raw.rule {
            let line = src.line(r.span().start);
            let r = r.get_ref();
            if let Err(e) = globset::GlobBuilder::new(r.pattern.get_ref()).build() {
                return Err(src.err_at(&r.pattern, format!("invalid glob: {e}")));
            }
            let class = pack::MaterialClass::from_name(r.class.get_ref()).ok_or_else(|| {
                let names: Vec<_> = pack::MaterialClass::ALL
                    .iter()
                    .map(|c| format!("{:?}", c.name()))
                    .collect();
                src.err_at(
                    &r.class,
                    format!(
                        "class is {:?} but must be one of {}",
                        r.class.get_ref(),
                        names.join(", ")
                    ),
                )
            })?;
            let on = match &r.on {
                Some(on) if on.get_ref().is_empty() => {
                    return Err(src.err_at(on, "`on` is empty: the rule could never match"));
                }
                Some(on) => on.get_ref().clone(),
                None => NameKind::ALL.to_vec(),
            };
            for (v, what) in [
                (&r.diffuse, "diffuse"),
                (&r.specular, "specular"),
                (&r.emissive, "emissive"),
            ] {
                if let Some(c) = v
                    && !finite3(*c)
                {
                    return Err(src.at_line(line, format!("{what} {c:?} is not finite")));
                }
            }
            rules.push(Rule {
                pattern: r.pattern.get_ref().clone(),
                on,
                class,
                material: r.material.clone(),
                diffuse: r.diffuse,
                specular: r.specular,
                shininess: r.shininess,
                emissive: r.emissive,
                texture: r
                    .texture
                    .as_ref()
                    .map(|t| src.file(t, "texture"))
                    .transpose()?,
                normal_map: r
                    .normal_map
                    .as_ref()
                    .map(|t| src.file(t, "normal_map"))
                    .transpose()?,
                line,
            });
        }

        let mut windows: Vec<WindowDesign> = Vec::new();
        for w in &raw.window {
            let line = src.line(w.span().start);
            let w = w.get_ref();
            let name = w.name.as_ref().map(|n| n.get_ref().clone());
            let material = w.material.as_ref().map(|n| n.get_ref().clone());
            if name.is_none() && material.is_none() {
                return Err(src.at_line(
                    line,
                    "a [[window]] needs `name` (a window name or glob) or `material` (a material \
                     name or glob)",
                ));
            }
            for p in [&w.name, &w.material].into_iter().flatten() {
                if let Err(e) = globset::Glob::new(p.get_ref()) {
                    return Err(src.err_at(p, format!("invalid glob: {e}")));
                }
            }
            if let Some(prev) = windows
                .iter()
                .find(|p| p.material.is_some() && p.material == material && p.name == name)
            {
                return Err(src.at_line(
                    line,
                    format!(
                        "window {} is already described at line {}",
                        prev.describe(),
                        prev.line.0
                    ),
                ));
            }
            let fraction = |v: &Option<Spanned<f32>>, what: &str, default: f32| match v {
                Some(s)
                    if !(s.get_ref().is_finite() && *s.get_ref() >= 0.0 && *s.get_ref() < 0.5) =>
                {
                    Err(src.err_at(s, format!("{what} {} must be in [0, 0.5)", s.get_ref())))
                }
                Some(s) => Ok(*s.get_ref()),
                None => Ok(default),
            };
            windows.push(WindowDesign {
                name,
                material,
                design: w
                    .design
                    .as_ref()
                    .map(|d| src.file(d, "window design"))
                    .transpose()?,
                uv: match &w.uv {
                    Some(c) => src.choice(
                        c,
                        "uv",
                        &[("source", UvMode::Auto), ("planar", UvMode::Planar)],
                    )?,
                    None => UvMode::Auto,
                },
                fit: match &w.fit {
                    Some(c) => src.choice(
                        c,
                        "fit",
                        &[
                            ("cover", Fit::Cover),
                            ("contain", Fit::Contain),
                            ("stretch", Fit::Stretch),
                        ],
                    )?,
                    None => Fit::Cover,
                },
                inside: match &w.inside {
                    Some(v) if !finite3(*v.get_ref()) || *v.get_ref() == [0.0; 3] => {
                        return Err(src.err_at(v, "inside must be a finite, non-zero vector"));
                    }
                    v => v.as_ref().map(|v| *v.get_ref()),
                },
                came_width: fraction(&w.came_width, "came_width", DEFAULT_CAME_WIDTH)?,
                texels_per_metre: w
                    .texels_per_metre
                    .as_ref()
                    .map(|s| src.positive(s, "texels_per_metre"))
                    .transpose()?
                    .unwrap_or(DEFAULT_TEXELS_PER_METRE),
                colour_space: match &w.colour_space {
                    Some(c) => src.choice(
                        c,
                        "colour_space",
                        &[
                            ("srgb", pack::ColourSpace::Srgb),
                            ("linear", pack::ColourSpace::Linear),
                        ],
                    )?,
                    None => pack::ColourSpace::Srgb,
                },
                normal_map: w
                    .normal_map
                    .as_ref()
                    .map(|t| src.file(t, "normal_map"))
                    .transpose()?,
                normal_encoding: match &w.normal_encoding {
                    Some(c) => src.choice(
                        c,
                        "normal_encoding",
                        &[("rgb", NormalEncoding::Rgb), ("rg", NormalEncoding::Rg)],
                    )?,
                    None => NormalEncoding::Rgb,
                },
                green: match &w.green {
                    Some(c) => src.choice(
                        c,
                        "green",
                        &[
                            ("opengl", GreenAxis::OpenGl),
                            ("directx", GreenAxis::DirectX),
                        ],
                    )?,
                    None => GreenAxis::OpenGl,
                },
                blur_sigma: w
                    .blur_sigma
                    .as_ref()
                    .map(|s| src.positive(s, "blur_sigma"))
                    .transpose()?,
                texture_format: w
                    .texture_format
                    .as_ref()
                    .map(|f| src.choice(f, "texture_format", &TextureFormatChoice::CHOICES))
                    .transpose()?,
                line,
            });
        }

        let light = raw
            .light
            .as_ref()
            .map(|l| parse_light(&src, l))
            .transpose()?;

        let mut cameras = Vec::new();
        for c in raw.camera {
            let fov_y = c
                .fov_y_deg
                .as_ref()
                .map(|f| src.positive(f, "fov_y_deg"))
                .transpose()?
                .unwrap_or(60.0);
            if let Some(f) = &c.fov_y_deg
                && fov_y >= 180.0
            {
                return Err(src.err_at(f, format!("fov_y_deg is {fov_y} but must be below 180")));
            }
            let near = c
                .near
                .as_ref()
                .map(|f| src.positive(f, "near"))
                .transpose()?
                .unwrap_or(0.05);
            let far = c
                .far
                .as_ref()
                .map(|f| src.positive(f, "far"))
                .transpose()?
                .unwrap_or(500.0);
            if far <= near {
                let at = c
                    .far
                    .as_ref()
                    .or(c.near.as_ref())
                    .map(|s| s.span().start)
                    .unwrap_or(0);
                return Err(src.error(
                    at,
                    format!("camera {:?}: far {far} must exceed near {near}", c.name),
                ));
            }
            let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
            if !finite3(c.position) || !finite3(c.target) || !finite3(up) || c.position == c.target
            {
                return Err(CookError::Manifest {
                    path: path.to_path_buf(),
                    line: None,
                    message: format!(
                        "camera {:?}: position, target and up must be finite and position must differ from target",
                        c.name
                    ),
                });
            }
            cameras.push(pack::Camera {
                name: c.name,
                position: c.position,
                target: c.target,
                up,
                fov_y,
                near,
                far,
            });
        }

        let background = match raw.background {
            Some(b) => Background {
                colour: b.colour.unwrap_or([0.0; 3]),
                panorama: b
                    .panorama
                    .as_ref()
                    .map(|p| src.file(p, "panorama"))
                    .transpose()?,
            },
            None => Background::default(),
        };

        Ok(Manifest {
            path: path.to_path_buf(),
            scene,
            textures,
            meshes,
            rules,
            windows,
            light,
            cameras,
            background,
            bare: false,
        })
    }

    /// A manifest for a bare OBJ/glTF file: no rules (tagging falls back to name heuristics),
    /// no windows designs, no light or cameras.
    pub fn from_mesh_file(path: &Path) -> Result<Manifest, CookError> {
        std::fs::metadata(path).map_err(|source| CookError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Ok(Manifest {
            path: path.to_path_buf(),
            scene: SceneInfo {
                name: Some(name.clone()),
                max_error: None,
            },
            textures: TextureSettings::default(),
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

fn parse_light(src: &Source<'_>, l: &Spanned<RawLight>) -> Result<Light, CookError> {
    let raw = l.get_ref();
    #[derive(Clone, Copy)]
    enum Kind {
        Point,
        Directional,
    }
    let kind = src.choice(
        &raw.kind,
        "light type",
        &[("point", Kind::Point), ("directional", Kind::Directional)],
    )?;
    let missing = |what: &str, t: &str| src.err_at(l, format!("a {t} light needs `{what}`"));
    let stray = |s: usize, what: &str, t: &str| {
        src.error(s, format!("`{what}` does not apply to a {t} light"))
    };
    let kind = match kind {
        Kind::Directional => {
            if let Some(p) = &raw.position {
                return Err(stray(p.span().start, "position", "directional"));
            }
            if let Some(p) = &raw.radius {
                return Err(stray(p.span().start, "radius", "directional"));
            }
            let d = raw
                .direction
                .as_ref()
                .ok_or_else(|| missing("direction", "directional"))?;
            let v = glam::Vec3::from(*d.get_ref());
            if !v.is_finite() || v.length() < 1e-6 {
                return Err(src.err_at(
                    d,
                    format!(
                        "direction {:?} must be a finite non-zero vector",
                        d.get_ref()
                    ),
                ));
            }
            let size = raw
                .angular_size_deg
                .as_ref()
                .map(|a| src.positive(a, "angular_size_deg"))
                .transpose()?
                .unwrap_or(0.53);
            pack::LightKind::Directional {
                direction: v.normalize().to_array(),
                angular_size: size.to_radians(),
            }
        }
        Kind::Point => {
            if let Some(p) = &raw.direction {
                return Err(stray(p.span().start, "direction", "point"));
            }
            if let Some(p) = &raw.angular_size_deg {
                return Err(stray(p.span().start, "angular_size_deg", "point"));
            }
            let p = raw
                .position
                .as_ref()
                .ok_or_else(|| missing("position", "point"))?;
            if !finite3(*p.get_ref()) {
                return Err(src.err_at(p, "position must be finite"));
            }
            let radius = raw
                .radius
                .as_ref()
                .ok_or_else(|| missing("radius", "point"))?;
            pack::LightKind::Point {
                position: *p.get_ref(),
                radius: src.positive(radius, "radius")?,
            }
        }
    };
    let colour = raw.colour.unwrap_or([1.0; 3]);
    if !finite3(colour) || colour.iter().any(|&c| c < 0.0) {
        return Err(src.err_at(
            l,
            format!("light colour {colour:?} must be finite and non-negative"),
        ));
    }
    let intensity = raw
        .intensity
        .as_ref()
        .map(|i| src.positive(i, "intensity"))
        .transpose()?
        .unwrap_or(1.0);
    Ok(Light {
        kind,
        colour,
        intensity,
    })
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
        assert_eq!(m.textures.mip_filter, MipFilter::Lanczos3);
        assert_eq!(m.meshes[0].scale, [2.0; 3]);
        assert_eq!(m.meshes[0].line, Line(9));
        let t = m.meshes[0].transform();
        let p = t.transform_point3(glam::Vec3::X);
        assert!((p - glam::Vec3::new(0.0, 1.0, -2.0)).length() < 1e-5, "{p}");
        assert_eq!(m.rules[0].class, pack::MaterialClass::Floor);
        assert_eq!(m.rules[0].on, vec![NameKind::Material]);
        assert_eq!(m.windows[0].normal_encoding, NormalEncoding::Rg);
        assert_eq!(m.windows[0].green, GreenAxis::DirectX);
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

    #[test]
    fn errors_name_the_line() {
        let d = dir();
        let mesh = "[[mesh]]\nsource = \"corridor.obj\"\n";
        let cases = [
            (format!("{mesh}bogus = 1\n"), 3, "unknown field"),
            (format!("{mesh}scale = \"x\"\n"), 3, ""),
            (
                format!("{mesh}\n[[rule]]\nmatch = \"a\"\nclass = \"ceiling\"\n"),
                6,
                "ceiling",
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
            (format!("{mesh}[light]\ntype = \"sun\"\n"), 4, "light type"),
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
                "cubic",
            ),
            (format!("{mesh}[scene\n"), 3, ""),
        ];
        for (text, line, word) in cases {
            let (l, msg) = line_of(parse(&d, &text).unwrap_err());
            assert_eq!(l, Some(line), "{text}\n→ {msg}");
            assert!(msg.contains(word), "{text}\n→ {msg}");
        }
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
