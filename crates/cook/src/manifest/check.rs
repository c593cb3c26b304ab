//! The validation pass: from the TOML shape ([`model`]) to a checked [`Manifest`]. Every error
//! names the manifest and the line of the value at fault.

use std::path::{Path, PathBuf};

use toml::Spanned;

use super::NameGlob;
use super::model;
use super::{
    Background, DEFAULT_CAME_WIDTH, Fit, Light, Line, Manifest, MeshSource, NameKind, NamedFile,
    Rule, SceneInfo, Textures, UvMode, WINDOW_BY_SILL, WindowDesign,
};
use crate::CookError;

/// Reads manifest text into the TOML shape, then checks it.
pub(super) fn parse(path: &Path, text: &str) -> Result<Manifest, CookError> {
    let src = Source {
        path,
        text,
        named: Default::default(),
        breaks: memchr::memchr_iter(b'\n', text.as_bytes()).collect(),
    };
    let raw: model::Manifest = toml::from_str(text).map_err(|e| src.toml_error(&e))?;
    Ok(Manifest {
        path: path.to_path_buf(),
        scene: scene(&src, raw.scene)?,
        textures: match raw.textures {
            None => Textures::default(),
            Some(t) => Textures {
                mip_filter: t.mip_filter.unwrap_or_default(),
                format: t.format.unwrap_or_default(),
                max_normal_error_deg: t
                    .max_normal_error_deg
                    .as_ref()
                    .map(|m| src.positive(m, "max_normal_error_deg"))
                    .transpose()?,
                max_design_error_lsb: t
                    .max_design_error_lsb
                    .as_ref()
                    .map(|m| src.positive(m, "max_design_error_lsb"))
                    .transpose()?,
                supercompression: t
                    .supercompression
                    .unwrap_or(Textures::default().supercompression),
                max_size: t
                    .max_size
                    .as_ref()
                    .map(|m| match u32::try_from(*m.get_ref()) {
                        Ok(v) if v >= 1 => Ok(v),
                        _ => Err(src.err_at(
                            m,
                            format!(
                                "max_size is {} but must be from 1 to {}",
                                m.get_ref(),
                                u32::MAX
                            ),
                        )),
                    })
                    .transpose()?,
            },
        },
        meshes: meshes(&src, &raw.mesh)?,
        rules: rules(&src, &raw.rule)?,
        windows: windows(&src, &raw.window)?,
        light: raw.light.as_ref().map(|l| light(&src, l)).transpose()?,
        cameras: cameras(&src, raw.camera)?,
        background: background(&src, raw.background)?,
        bare: false,
        named_files: src.named.take(),
    })
}

/// Resolves byte offsets in the manifest to 1-based line numbers.
struct Source<'a> {
    path: &'a Path,
    text: &'a str,
    /// Every file the manifest names, in the order checked.
    named: std::cell::RefCell<Vec<NamedFile>>,
    /// Offsets of the text's line breaks: counting them from the start for every entry made
    /// reading the 10,000 rules `cooker init` wrote for a large model take 1.6 s.
    breaks: Vec<usize>,
}

impl Source<'_> {
    fn line(&self, offset: usize) -> Line {
        let end = offset.min(self.text.len());
        Line(self.breaks.partition_point(|&b| b < end) + 1)
    }

    /// A syntax or type error from toml. One about a value (a wrong type, a name that is no
    /// variant) says which key it is about, since toml's own message does not.
    fn toml_error(&self, e: &toml::de::Error) -> CookError {
        // Rust's type names are no manifest's words: `intensity = "bright"` said "expected
        // f32".
        let mut message = e.message().trim().to_string();
        for (rust, said) in [
            ("expected f32", "expected a number"),
            ("expected f64", "expected a number"),
            ("expected u32", "expected a whole number"),
            ("expected u16", "expected a whole number"),
            ("expected u8", "expected a whole number"),
            ("expected usize", "expected a whole number"),
            ("expected a boolean", "expected true or false"),
        ] {
            if let Some(rest) = message.strip_suffix(rust) {
                message = format!("{rest}{said}");
            }
        }
        let message = match e.span().and_then(|s| self.key_before(s.start)) {
            Some(key) => format!("{key}: {message}"),
            None => message.to_string(),
        };
        // toml says "duplicate key" without the key, or the table a header opens twice.
        let message = match e.span().and_then(|s| self.text.get(s)) {
            Some(what) if message.starts_with("duplicate") && !message.contains('`') => {
                format!("{message} `{}`", what.trim())
            }
            _ => message,
        };
        // `[window]` where `[[window]]` was meant: toml says only that a map is no sequence.
        let header = e.span().and_then(|s| {
            let line = self.text.get(..s.start)?.rsplit('\n').next()?.to_string()
                + self.text.get(s.start..)?.split('\n').next()?;
            let name = line.trim().strip_prefix('[')?.strip_suffix(']')?.trim();
            (!name.starts_with('[')).then(|| name.to_string())
        });
        let message = match header {
            Some(name) if message.contains("expected a sequence") => format!(
                "{message}: [{name}] opens one table, but {name} is a list; write [[{name}]] \
                 for each entry"
            ),
            _ => message,
        };
        let message = match did_you_mean(&message) {
            Some(near) => format!("{message}; did you mean `{near}`?"),
            None => message,
        };
        CookError::Manifest {
            path: self.path.to_path_buf(),
            line: e.span().map(|s| self.line(s.start).0),
            message,
        }
    }

    /// The key of a `key = value` line when `offset` lies in its value.
    fn key_before(&self, offset: usize) -> Option<&str> {
        let line = self.text.get(..offset)?;
        let line = &line[line.rfind('\n').map_or(0, |i| i + 1)..];
        // The last `=` before the value: `key = value`, or a key of an inline table.
        let (before, _) = line.rsplit_once('=')?;
        let key = before
            .trim_end()
            .rsplit(|c: char| c.is_whitespace() || c == '{' || c == ',')
            .next()?;
        let bare = !key.is_empty()
            && key
                .bytes()
                .all(|b| b.is_ascii_alphanumeric() || b"_-.".contains(&b));
        bare.then_some(key)
    }

    fn error(&self, offset: usize, message: impl Into<String>) -> CookError {
        self.at_line(self.line(offset), message)
    }

    fn at_line(&self, line: Line, message: impl Into<String>) -> CookError {
        CookError::Manifest {
            path: self.path.to_path_buf(),
            line: Some(line.0),
            message: message.into(),
        }
    }

    /// An error about the manifest as a whole.
    fn whole(&self, message: impl Into<String>) -> CookError {
        CookError::Manifest {
            path: self.path.to_path_buf(),
            line: None,
            message: message.into(),
        }
    }

    fn err_at<T>(&self, span: &Spanned<T>, message: impl Into<String>) -> CookError {
        self.error(span.span().start, message)
    }

    /// A path relative to the manifest that must name an existing file.
    fn file(&self, value: &Spanned<String>, what: &'static str) -> Result<PathBuf, CookError> {
        let path = self.find_file(value, what)?;
        self.named.borrow_mut().push(NamedFile {
            path: path.clone(),
            line: self.line(value.span().start),
            what,
            written: value.get_ref().clone(),
        });
        Ok(path)
    }

    fn find_file(&self, value: &Spanned<String>, what: &str) -> Result<PathBuf, CookError> {
        let dir = self.path.parent().unwrap_or(Path::new(""));
        // One spelling per file (`./windows/x.png`, `windows//x.png`): a design written two
        // ways was decoded and stored twice.
        let path: PathBuf = dir
            .join(value.get_ref())
            .components()
            .filter(|c| *c != std::path::Component::CurDir)
            .collect();
        match std::fs::metadata(&path) {
            Ok(m) if m.is_file() => Ok(path),
            Ok(_) => Err(self.err_at(value, format!("{what} {:?} is not a file", value.get_ref()))),
            // A manifest written on Windows (`textures\Rose.PNG`) cooks here too, as a
            // model's own texture paths do.
            Err(e) => match crate::import::as_written_on_windows(dir, value.get_ref()) {
                Some(found) => Ok(found),
                None => Err(self.err_at(
                    value,
                    format!(
                        "{what} {:?} cannot be read ({}): {e}{}",
                        value.get_ref(),
                        path.display(),
                        if e.kind() == std::io::ErrorKind::NotFound {
                            file_suggestion(&path, value.get_ref())
                        } else {
                            String::new()
                        }
                    ),
                )),
            },
        }
    }

    fn files(
        &self,
        value: &Option<Spanned<String>>,
        what: &'static str,
    ) -> Result<Option<PathBuf>, CookError> {
        value.as_ref().map(|v| self.file(v, what)).transpose()
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

    fn positive_or(
        &self,
        value: &Option<Spanned<f32>>,
        what: &str,
        default: f32,
    ) -> Result<f32, CookError> {
        Ok(value
            .as_ref()
            .map(|v| self.positive(v, what))
            .transpose()?
            .unwrap_or(default))
    }

    /// One of the names a type gives its values (the pack's classes, colour spaces).
    fn named<T: Copy>(
        &self,
        value: &Spanned<String>,
        what: &str,
        all: &[T],
        name: impl Fn(T) -> &'static str,
    ) -> Result<T, CookError> {
        all.iter()
            .copied()
            .find(|&v| name(v) == value.get_ref())
            .ok_or_else(|| {
                let names: Vec<_> = all.iter().map(|&v| format!("{:?}", name(v))).collect();
                self.err_at(
                    value,
                    format!(
                        "{what} is {:?} but must be one of {}{}",
                        value.get_ref(),
                        names.join(", "),
                        suggestion(value.get_ref(), all.iter().map(|&v| name(v)))
                    ),
                )
            })
    }
}

/// For serde's "unknown field `desing`, expected one of `name`, `design`, ..." (and the same
/// of variants), the expected name nearest the unknown one, where it is near enough to be a
/// typo: the list alone left the user to spot `design` among a dozen.
fn did_you_mean(message: &str) -> Option<&str> {
    let (_, rest) = message.split_once("unknown ")?;
    let (_, rest) = rest.split_once('`')?;
    let (unknown, rest) = rest.split_once('`')?;
    let (_, expected) = rest.split_once("expected ")?;
    nearest(unknown, expected.split('`').skip(1).step_by(2))
}

/// The one of `names` nearest `unknown`, where it is near enough to be a slip. Letter case
/// aside (`sRGB`, `BC7`): keys and values are lower case. A key with a unit or a word more
/// or less (`max_error_lsb`, `rotate`) is the one it starts or ends.
fn nearest<'n>(unknown: &str, names: impl Iterator<Item = &'n str>) -> Option<&'n str> {
    let unknown = unknown.to_lowercase();
    names
        .filter_map(|name| {
            let d = strsim::damerau_levenshtein(&unknown, name);
            let (short, long) = if name.len() < unknown.len() {
                (name, unknown.as_str())
            } else {
                (unknown.as_str(), name)
            };
            let part = short.len() >= 4 && (long.starts_with(short) || long.ends_with(short));
            (d <= 1 || (d == 2 && name.len() >= 6) || part).then_some((d, name))
        })
        .min_by_key(|&(d, _)| d)
        .map(|(_, name)| name)
}

/// `; did you mean `x`?` where one of `names` is near `unknown`, else nothing.
fn suggestion<'n>(unknown: &str, names: impl Iterator<Item = &'n str>) -> String {
    nearest(unknown, names).map_or_else(String::new, |n| format!("; did you mean `{n}`?"))
}

/// `; did you mean `windows/rose.png`?` where the folder `path` names holds a file whose name
/// is near the missing one's (`rosee.png`), written as `written` writes its folders.
fn file_suggestion(path: &Path, written: &str) -> String {
    let (Some(dir), Some(name)) = (path.parent(), path.file_name().and_then(|n| n.to_str())) else {
        return String::new();
    };
    let Ok(entries) = std::fs::read_dir(if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    }) else {
        return String::new();
    };
    let mut names: Vec<String> = entries
        .filter_map(Result::ok)
        .filter(|e| e.file_type().is_ok_and(|t| t.is_file()))
        .filter_map(|e| e.file_name().into_string().ok())
        .collect();
    names.sort();
    let Some(near) = nearest(name, names.iter().map(String::as_str)) else {
        return String::new();
    };
    let folder = written.rfind(['/', '\\']).map_or("", |i| &written[..=i]);
    format!("; did you mean `{folder}{near}`?")
}

/// Why a value written finite reads as `inf`: the manifest's numbers are 32-bit floats
/// (`translate = [1e300, 0, 0]` was "[inf, 0.0, 0.0] must be finite", with no reason).
fn beyond_f32(v: &[f32]) -> &'static str {
    if v.iter().any(|x| x.is_infinite()) {
        " (a number beyond ±3.4e38 does not fit the 32-bit floats a manifest holds)"
    } else {
        ""
    }
}

fn finite3(v: [f32; 3]) -> bool {
    v.iter().all(|x| x.is_finite())
}

fn scene(src: &Source<'_>, raw: Option<model::Scene>) -> Result<SceneInfo, CookError> {
    let Some(s) = raw else {
        return Ok(SceneInfo::default());
    };
    Ok(SceneInfo {
        name: s.name,
        max_error: s
            .max_error
            .map(|m| src.positive(&m, "max_error"))
            .transpose()?,
        text_encoding: s
            .text_encoding
            .map(|label| {
                crate::import::text::TextEncoding::from_label(label.get_ref())
                    .map_err(|why| src.err_at(&label, format!("text_encoding: {why}")))
            })
            .transpose()?,
    })
}

fn meshes(src: &Source<'_>, raw: &[Spanned<model::Mesh>]) -> Result<Vec<MeshSource>, CookError> {
    let mut meshes = Vec::new();
    for m in raw {
        let line = src.line(m.span().start);
        let m = m.get_ref();
        let source = src.file(&m.source, super::MESH_SOURCE)?;
        let scale = match &m.scale {
            None => [1.0; 3],
            Some(s) => match s.get_ref() {
                model::Scale::Uniform(k) => [*k; 3],
                model::Scale::Axes(a) => *a,
            },
        };
        if let Some(s) = &m.scale
            && (!finite3(scale) || scale.contains(&0.0))
        {
            return Err(src.err_at(
                s,
                format!(
                    "scale {scale:?} must be finite and non-zero{}",
                    beyond_f32(&scale)
                ),
            ));
        }
        // A NaN here cooked to an empty pack with exit 0, every triangle dropped as degenerate.
        for (v, what) in [(&m.translate, "translate"), (&m.rotate_deg, "rotate_deg")] {
            if let Some(v) = v
                && !finite3(*v.get_ref())
            {
                return Err(src.err_at(
                    v,
                    format!(
                        "{what} {:?} must be finite{}",
                        v.get_ref(),
                        beyond_f32(v.get_ref())
                    ),
                ));
            }
        }
        if m.name.as_ref().is_some_and(|n| n.trim().is_empty()) {
            return Err(src.at_line(
                line,
                "the mesh's name is empty: leave `name` out for the file's stem",
            ));
        }
        let name = m.name.clone().unwrap_or_else(|| {
            source
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default()
        });
        let placed = MeshSource {
            source,
            name,
            translate: m.translate.as_ref().map_or([0.0; 3], |v| *v.get_ref()),
            rotate_deg: m.rotate_deg.as_ref().map_or([0.0; 3], |v| *v.get_ref()),
            scale,
            line,
        };
        // A second entry placing the same file in the same place (a copied entry left as it
        // was) doubled every triangle: coplanar twins that flicker, and twice the work.
        if let Some(twin) = meshes.iter().find(|e: &&MeshSource| {
            e.source == placed.source
                && e.translate == placed.translate
                && e.rotate_deg == placed.rotate_deg
                && e.scale == placed.scale
        }) {
            return Err(src.at_line(
                line,
                format!(
                    "this [[mesh]] places {:?} exactly where the one at line {} does: every \
                     triangle would be doubled; remove one, or move it (translate, rotate_deg, \
                     scale)",
                    m.source.get_ref(),
                    twin.line.0
                ),
            ));
        }
        meshes.push(placed);
    }
    if meshes.is_empty() {
        return Err(src.whole("no [[mesh]] entries: a scene needs at least one mesh source"));
    }
    Ok(meshes)
}

fn rules(src: &Source<'_>, raw: &[Spanned<model::Rule>]) -> Result<Vec<Rule>, CookError> {
    let mut rules = Vec::new();
    for r in raw {
        let line = src.line(r.span().start);
        let r = r.get_ref();
        // An empty glob matches only an empty name: a rule that tags nothing, said only by
        // `validate` (as an unused rule).
        if r.pattern.get_ref().trim().is_empty() {
            return Err(src.err_at(
                &r.pattern,
                "match is empty: give a glob over names (`*` matches every name)",
            ));
        }
        if let Err(e) = globset::GlobBuilder::new(r.pattern.get_ref()).build() {
            return Err(src.err_at(&r.pattern, format!("invalid glob: {e}")));
        }
        let by_sill = r.class.get_ref() == WINDOW_BY_SILL;
        let class = if by_sill {
            Some(pack::MaterialClass::WindowUpper)
        } else {
            pack::MaterialClass::from_name(r.class.get_ref())
        };
        let class = class.ok_or_else(|| {
            let names = || {
                pack::MaterialClass::ALL
                    .iter()
                    .map(|c| c.name())
                    .chain([WINDOW_BY_SILL])
            };
            let quoted: Vec<_> = names().map(|c| format!("{c:?}")).collect();
            src.err_at(
                &r.class,
                format!(
                    "class is {:?} but must be one of {}{}",
                    r.class.get_ref(),
                    quoted.join(", "),
                    suggestion(r.class.get_ref(), names())
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
            // At the key's own line, not the [[rule]]'s.
            if let Some(c) = v
                && (!finite3(*c.get_ref()) || c.get_ref().iter().any(|&x| x < 0.0))
            {
                return Err(src.err_at(
                    c,
                    format!(
                        "{what} {:?} must be finite and not negative{}",
                        c.get_ref(),
                        beyond_f32(c.get_ref())
                    ),
                ));
            }
        }
        if let Some(s) = &r.shininess
            && !(s.get_ref().is_finite() && *s.get_ref() >= 0.0)
        {
            return Err(src.err_at(
                s,
                format!(
                    "shininess {} must be finite and not negative{}",
                    s.get_ref(),
                    beyond_f32(&[*s.get_ref()])
                ),
            ));
        }
        rules.push(Rule {
            pattern: r.pattern.get_ref().clone(),
            on,
            class,
            by_sill,
            material: match &r.material {
                // `material = ""` made a pack material of no name, which `cooker info` shows
                // as a blank row and no [[window]] `material` glob can name.
                Some(m) if m.trim().is_empty() => {
                    return Err(src.at_line(
                        line,
                        "the rule's material name is empty: leave `material` out to keep the \
                         source's names",
                    ));
                }
                m => m.clone(),
            },
            diffuse: r.diffuse.as_ref().map(|v| *v.get_ref()),
            specular: r.specular.as_ref().map(|v| *v.get_ref()),
            shininess: r.shininess.as_ref().map(|v| *v.get_ref()),
            emissive: r.emissive.as_ref().map(|v| *v.get_ref()),
            texture: src.files(&r.texture, "texture")?,
            normal_map: src.files(&r.normal_map, "normal_map")?,
            normal_strength: normal_strength(src, &r.normal_strength)?,
            line,
        });
    }
    Ok(rules)
}

/// The most a normal map may be scaled by: 64 tilts a 1° bump to 48°, far past any relief.
const MAX_NORMAL_STRENGTH: f32 = 64.0;

/// `normal_strength`: x and y of a map's vectors, or a height map's depth, scaled by it; a
/// negative one turns bumps into dents (a height map painted the other way up).
fn normal_strength(src: &Source<'_>, v: &Option<Spanned<f32>>) -> Result<Option<f32>, CookError> {
    match v {
        Some(s) if !(s.get_ref().is_finite() && s.get_ref().abs() <= MAX_NORMAL_STRENGTH) => {
            Err(src.err_at(
                s,
                format!(
                    "normal_strength is {} but must be a number from -{MAX_NORMAL_STRENGTH} to \
                     {MAX_NORMAL_STRENGTH} (1: as the map is; 0: flat; negative: dents for bumps)",
                    s.get_ref()
                ),
            ))
        }
        v => Ok(v.as_ref().map(|s| *s.get_ref())),
    }
}

fn windows(
    src: &Source<'_>,
    raw: &[Spanned<model::Window>],
) -> Result<Vec<WindowDesign>, CookError> {
    let mut windows: Vec<WindowDesign> = Vec::new();
    for w in raw {
        let line = src.line(w.span().start);
        let w = w.get_ref();
        if w.name.is_none() && w.material.is_none() {
            return Err(src.at_line(
                line,
                "a [[window]] needs `name` (a window name or glob) or `material` (a material \
                 name or glob)",
            ));
        }
        let glob = |p: &Option<Spanned<String>>| {
            p.as_ref()
                .map(|p| {
                    NameGlob::checked(p.get_ref())
                        .map_err(|e| src.err_at(p, format!("invalid glob: {e}")))
                })
                .transpose()
        };
        let name = glob(&w.name)?;
        let material = glob(&w.material)?;
        if let Some(prev) = windows
            .iter()
            .find(|p| p.material == material && p.name == name)
        {
            return Err(src.at_line(
                line,
                format!(
                    "{} is already described by the [[window]] at line {}",
                    prev.describe(),
                    prev.line.0
                ),
            ));
        }
        let fraction = |v: &Option<Spanned<f32>>, what: &str, default: f32| match v {
            Some(s) if !(s.get_ref().is_finite() && *s.get_ref() >= 0.0 && *s.get_ref() < 0.5) => {
                Err(src.err_at(s, format!("{what} {} must be in [0, 0.5)", s.get_ref())))
            }
            Some(s) => Ok(*s.get_ref()),
            None => Ok(default),
        };
        windows.push(WindowDesign {
            name,
            material,
            design: src.files(&w.design, "window design")?,
            uv: w.uv.unwrap_or(UvMode::Auto),
            fit: w.fit.unwrap_or(Fit::Cover),
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
                .map(|v| src.positive(v, "texels_per_metre"))
                .transpose()?,
            colour_space: match &w.colour_space {
                Some(c) => src.named(
                    c,
                    "colour_space",
                    &[pack::ColourSpace::Srgb, pack::ColourSpace::Linear],
                    pack::ColourSpace::name,
                )?,
                None => pack::ColourSpace::Srgb,
            },
            normal_map: src.files(&w.normal_map, "normal_map")?,
            normal_encoding: w.normal_encoding.unwrap_or_default(),
            green: w.green.unwrap_or_default(),
            normal_strength: normal_strength(src, &w.normal_strength)?,
            blur_sigma: w
                .blur_sigma
                .as_ref()
                .map(|s| {
                    // 0 is a sharp projector, the design's own edges on the floor.
                    // The blur's own bound, checked here so that `validate` finds it too.
                    let v = *s.get_ref();
                    if v.is_finite() && (0.0..=texture::MAX_SIGMA).contains(&v) {
                        Ok(v)
                    } else {
                        Err(src.err_at(
                            s,
                            format!(
                                "blur_sigma is {v} but must be a number of texels from 0 (no \
                                 blur) to {}",
                                texture::MAX_SIGMA
                            ),
                        ))
                    }
                })
                .transpose()?,
            texture_format: w.texture_format,
            line,
        });
    }
    Ok(windows)
}

fn light(src: &Source<'_>, l: &Spanned<model::Light>) -> Result<Light, CookError> {
    let raw = l.get_ref();
    let missing = |what: &str, t: &str| src.err_at(l, format!("a {t} light needs `{what}`"));
    let stray = |s: usize, what: &str, t: &str| {
        src.error(s, format!("`{what}` does not apply to a {t} light"))
    };
    let t = match raw.kind {
        model::LightType::Directional => "directional",
        model::LightType::Point => "point",
        model::LightType::Spot => "spot",
    };
    // Each field, and the light types it applies to.
    let fields: [(&str, Option<usize>, &[&str]); 6] = [
        (
            "direction",
            raw.direction.as_ref().map(|v| v.span().start),
            &["directional", "spot"],
        ),
        (
            "angular_size_deg",
            raw.angular_size_deg.as_ref().map(|v| v.span().start),
            &["directional"],
        ),
        (
            "position",
            raw.position.as_ref().map(|v| v.span().start),
            &["point", "spot"],
        ),
        (
            "radius",
            raw.radius.as_ref().map(|v| v.span().start),
            &["point", "spot"],
        ),
        (
            "inner_cone_deg",
            raw.inner_cone_deg.as_ref().map(|v| v.span().start),
            &["spot"],
        ),
        (
            "outer_cone_deg",
            raw.outer_cone_deg.as_ref().map(|v| v.span().start),
            &["spot"],
        ),
    ];
    for (what, at, types) in fields {
        if let Some(at) = at
            && !types.contains(&t)
        {
            return Err(stray(at, what, t));
        }
    }
    let direction = || -> Result<[f32; 3], CookError> {
        let d = raw
            .direction
            .as_ref()
            .ok_or_else(|| missing("direction", t))?;
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
        Ok(super::light_direction(v).to_array())
    };
    let lamp = || -> Result<([f32; 3], f32), CookError> {
        let p = raw
            .position
            .as_ref()
            .ok_or_else(|| missing("position", t))?;
        if !finite3(*p.get_ref()) {
            return Err(src.err_at(p, "position must be finite"));
        }
        let radius = raw.radius.as_ref().ok_or_else(|| missing("radius", t))?;
        Ok((*p.get_ref(), src.positive(radius, "radius")?))
    };
    let kind = match raw.kind {
        model::LightType::Directional => {
            let size = src.positive_or(&raw.angular_size_deg, "angular_size_deg", 0.53)?;
            // The penumbra grows as tan(size / 2): 500° blurred a projector by σ = 592 texels
            // without a word, and at 180° the tangent is infinite.
            if let Some(v) = raw.angular_size_deg.as_ref().filter(|_| size > 90.0) {
                return Err(src.err_at(
                    v,
                    format!(
                        "angular_size_deg is {size} but a sun's disc is at most 90° across (the \
                         sun's own is 0.53°)"
                    ),
                ));
            }
            pack::LightKind::Directional {
                direction: direction()?,
                angular_size: size.to_radians(),
            }
        }
        model::LightType::Point => {
            let (position, radius) = lamp()?;
            pack::LightKind::Point { position, radius }
        }
        model::LightType::Spot => {
            let (position, radius) = lamp()?;
            let direction = direction()?;
            // glTF's defaults: a 45° cone, full strength only along the axis.
            let outer = src.positive_or(&raw.outer_cone_deg, "outer_cone_deg", 45.0)?;
            if outer > 90.0 {
                let at = raw
                    .outer_cone_deg
                    .as_ref()
                    .map_or(l.span().start, |v| v.span().start);
                return Err(src.error(
                    at,
                    format!("outer_cone_deg is {outer} but a spot's cone is at most 90°"),
                ));
            }
            let inner = match &raw.inner_cone_deg {
                Some(v) => {
                    let x = *v.get_ref();
                    if !(x >= 0.0 && x <= outer) {
                        return Err(src.err_at(
                            v,
                            format!(
                                "inner_cone_deg is {x} but must lie between 0 and outer_cone_deg ({outer})"
                            ),
                        ));
                    }
                    x
                }
                None => 0.0,
            };
            pack::LightKind::Spot {
                position,
                radius,
                direction,
                inner: inner.to_radians(),
                outer: outer.to_radians(),
            }
        }
    };
    let colour = raw.colour.as_ref().map_or([1.0; 3], |c| *c.get_ref());
    if !finite3(colour) || colour.iter().any(|&c| c < 0.0) {
        let at = raw
            .colour
            .as_ref()
            .map_or(l.span().start, |c| c.span().start);
        return Err(src.error(
            at,
            format!(
                "light colour {colour:?} must be finite and non-negative{}",
                beyond_f32(&colour)
            ),
        ));
    }
    Ok(Light {
        kind,
        colour,
        intensity: src.positive_or(&raw.intensity, "intensity", 1.0)?,
    })
}

fn cameras(
    src: &Source<'_>,
    raw: Vec<Spanned<model::Camera>>,
) -> Result<Vec<pack::Camera>, CookError> {
    let mut cameras: Vec<(pack::Camera, Line)> = Vec::new();
    for c in raw {
        let line = src.line(c.span().start);
        let c = c.into_inner();
        // The viewer picks a camera by name (`--camera`), and writes a frame per name.
        if c.name.trim().is_empty() {
            return Err(src.at_line(
                line,
                "camera name is empty: the viewer picks a camera and names its frame by it",
            ));
        }
        if let Some((_, first)) = cameras.iter().find(|(k, _)| k.name == c.name) {
            return Err(src.at_line(
                line,
                format!(
                    "camera {:?} is already described at line {}: names must differ",
                    c.name, first.0
                ),
            ));
        }
        let fov_y = src.positive_or(&c.fov_y_deg, "fov_y_deg", 60.0)?;
        if let Some(f) = &c.fov_y_deg
            && fov_y >= 180.0
        {
            return Err(src.err_at(f, format!("fov_y_deg is {fov_y} but must be below 180")));
        }
        let near = src.positive_or(&c.near, "near", 0.05)?;
        let far = src.positive_or(&c.far, "far", 500.0)?;
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
        // Depth over a wider range has no precision (pack::MAX_FAR_OVER_NEAR).
        if far as f64 > pack::MAX_FAR_OVER_NEAR * near as f64 {
            let at = c.far.as_ref().or(c.near.as_ref()).map(|s| s.span().start);
            let message = format!(
                "camera {:?}: far {far} is over 1e9 times near {near}; depth has no \
                 precision over such a range",
                c.name
            );
            return Err(match at {
                Some(at) => src.error(at, message),
                None => src.at_line(line, message),
            });
        }
        let up = c.up.unwrap_or([0.0, 1.0, 0.0]);
        if !finite3(c.position) || !finite3(c.target) || !finite3(up) || c.position == c.target {
            return Err(src.at_line(
                line,
                format!(
                    "camera {:?}: position, target and up must be finite and position must \
                     differ from target",
                    c.name
                ),
            ));
        }
        // An `up` given as zero or along the view leaves the roll to chance (the viewer
        // picks an axis); left out, a camera looking straight down or up is rolled to +z.
        if c.up.is_some() {
            let view = glam::Vec3::from(c.target) - glam::Vec3::from(c.position);
            let u = glam::Vec3::from(up);
            if view.normalize().cross(u.normalize_or_zero()).length() < 1e-3 {
                return Err(src.at_line(
                    line,
                    format!(
                        "camera {:?}: up {up:?} is {} the view direction, so it sets no roll; \
                         give an up across the view, or leave it out",
                        c.name,
                        if u == glam::Vec3::ZERO {
                            "zero, not across"
                        } else {
                            "along"
                        }
                    ),
                ));
            }
        }
        cameras.push((
            pack::Camera {
                name: c.name,
                position: c.position,
                target: c.target,
                up,
                fov_y,
                near,
                far,
            },
            line,
        ));
    }
    Ok(cameras.into_iter().map(|(c, _)| c).collect())
}

fn background(
    src: &Source<'_>,
    raw: Option<Spanned<model::Background>>,
) -> Result<Background, CookError> {
    Ok(match raw {
        Some(b) => {
            let b = b.into_inner();
            let colour = b.colour.as_ref().map_or([0.0; 3], |c| *c.get_ref());
            if let Some(c) = &b.colour
                && (!finite3(colour) || colour.iter().any(|&c| c < 0.0))
            {
                return Err(src.err_at(
                    c,
                    format!(
                        "background colour {colour:?} must be finite and not negative{}",
                        beyond_f32(&colour)
                    ),
                ));
            }
            Background {
                colour,
                panorama: src.files(&b.panorama, "panorama")?,
                colour_given: b.colour.is_some(),
            }
        }
        None => Background::default(),
    })
}
