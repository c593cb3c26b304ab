//! The texture stage: decodes the images materials, windows and the background refer to, once
//! each, and cooks them with the `texture` crate: colour mip chains (sRGB-correct), normal maps
//! (supplied, or derived from a window's design), and each window's blurred projector.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use rayon::prelude::*;

use serde::Serialize;
use texture::{GreenAxis, NormalEncoding};

use crate::import::ImageRef;
use crate::manifest::{Manifest, TextureFormatChoice};
use crate::tag::Tagging;
use crate::{CookError, Report, Settings, TextureSettings, Warning, cache};

/// One texture to cook: the image it reads and every parameter that shapes the result. The
/// serialized job, without the image, is part of the texture's cache key; the image enters
/// the key by its content.
#[derive(Clone, Debug, PartialEq, Serialize)]
enum Job {
    Colour {
        #[serde(skip)]
        image: ImageRef,
        srgb: bool,
        /// A window's design: what the viewer looks at, so it has its own error budget.
        design: bool,
    },
    Normal {
        #[serde(skip)]
        image: ImageRef,
        encoding: NormalEncoding,
        green: GreenAxis,
        /// `SourceMaterial::normal_scale`.
        strength: f32,
    },
    /// Its hammered-glass noise is seeded by the design's content ([`seed`]), which the key
    /// holds already.
    DerivedNormal {
        #[serde(skip)]
        design: ImageRef,
        /// The relief's height scaled (`[[window]] normal_strength`).
        strength: f32,
    },
    Projector {
        #[serde(skip)]
        design: ImageRef,
        sigma: texture::Sigma2,
        /// Texels of margin on each side, `[x, y]` (`texture::projector_margin`).
        margin: [u32; 2],
        /// The design's colours are sRGB-encoded (else linear, `colour_space = "linear"`).
        srgb: bool,
    },
}

impl Job {
    fn role(&self) -> (pack::TextureRole, pack::ColourSpace) {
        match self {
            Job::Colour { srgb, .. } => (
                pack::TextureRole::Colour,
                if *srgb {
                    pack::ColourSpace::Srgb
                } else {
                    pack::ColourSpace::Linear
                },
            ),
            Job::Normal { .. } | Job::DerivedNormal { .. } => {
                (pack::TextureRole::Normal, pack::ColourSpace::Linear)
            }
            Job::Projector { .. } => (pack::TextureRole::Projector, pack::ColourSpace::Srgb),
        }
    }

    /// A unique, readable texture name: the image's file stem and what was made of it.
    fn base_name(&self) -> String {
        let image = match self {
            Job::Colour { image, .. } | Job::Normal { image, .. } => image,
            Job::DerivedNormal { design, .. } | Job::Projector { design, .. } => design,
        };
        let stem = match image {
            ImageRef::File(p) => p
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            ImageRef::Embedded { name, .. } => {
                name.rsplit(['/', '#']).next().unwrap_or(name).to_string()
            }
            ImageRef::Raster { name, .. } => name.clone(),
        };
        let suffix = match self {
            Job::Colour { .. } => "",
            Job::Normal { .. } => ".normal",
            Job::DerivedNormal { .. } => ".derived-normal",
            Job::Projector { .. } => ".projector",
        };
        format!("{stem}{suffix}")
    }
}

pub(crate) fn texture_error(path: &Path, e: texture::TextureError) -> CookError {
    if e.path().is_some() {
        CookError::Texture(e)
    } else {
        CookError::Source {
            path: path.to_path_buf(),
            line: None,
            message: e.to_string(),
        }
    }
}

pub(crate) fn decode(image: &ImageRef) -> Result<image::DynamicImage, CookError> {
    match image {
        ImageRef::File(p) => texture::load_image(p).map_err(|e| texture_error(p, e)),
        ImageRef::Embedded { name, bytes } => {
            let name = Path::new(name);
            texture::load_image_bytes(bytes, name).map_err(|e| texture_error(name, e))
        }
        ImageRef::Raster { image, .. } => Ok(image::DynamicImage::ImageRgba8((**image).clone())),
    }
}

/// An 8-bit image without alpha, or grey, as RGBA8: the same texels to every reader (see
/// `texture::pixels::rgba8_bytes`), and the byte view the projector's blur and a derived
/// normal map's height field read borrows it rather than each making its own copy (4.2 MB
/// each for the 1024² RGB rose, two of them at the default scene's cook peak). Grey with
/// alpha stays as it is: a normal map given as `rg` holds x in its grey and y in its alpha,
/// which RGBA8 would make a grey height map.
fn as_rgba8(img: image::DynamicImage) -> image::DynamicImage {
    match img {
        image::DynamicImage::ImageRgb8(_) | image::DynamicImage::ImageLuma8(_) => {
            image::DynamicImage::ImageRgba8(img.to_rgba8())
        }
        other => other,
    }
}

/// Image files decoded once per cook. A window design is read by the window stage (once per
/// window that shows it) and by its colour, projector and derived-normal jobs; the default
/// scene decoded its four design PNGs 25 times. Other images (embedded, made by the cook)
/// are decoded where they are used, as before.
#[derive(Default)]
pub struct DecodedImages {
    files: Mutex<HashMap<PathBuf, DecodeSlot>>,
    /// Files the user named as colour (designs, a rule's texture, the panorama), whose
    /// embedded ICC profile is applied (`texture::profile`); a model's own textures are read
    /// as sRGB whatever they embed, as glTF requires.
    /// Settled before any of them is decoded: a `--window` design's by the window stage,
    /// which knows the colour space each window reads it in.
    colour_managed: Mutex<std::collections::HashSet<PathBuf>>,
    /// Uses still to come, per file, where the texture stage has said: a file is let go after
    /// its last job, not held to the end of the stage (a 4096² design is 48 MiB decoded).
    uses: Mutex<HashMap<PathBuf, usize>>,
}

/// One file's decoded image, filled by the first caller while later ones wait on the lock.
type DecodeSlot = Arc<Mutex<Option<Arc<image::DynamicImage>>>>;

impl std::fmt::Debug for DecodedImages {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let files = self.files.lock().unwrap_or_else(|e| e.into_inner());
        f.debug_list().entries(files.keys()).finish()
    }
}

impl DecodedImages {
    /// Decodes the `colour_managed` files into sRGB by their embedded profiles.
    pub(crate) fn with_colour_managed(colour_managed: impl IntoIterator<Item = PathBuf>) -> Self {
        Self {
            colour_managed: Mutex::new(colour_managed.into_iter().collect()),
            ..Self::default()
        }
    }

    fn is_colour_managed(&self, image: &ImageRef) -> bool {
        let managed = self
            .colour_managed
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        matches!(image, ImageRef::File(p) if managed.contains(p))
    }

    /// Decodes `path` into sRGB by its embedded profile from now on; called before it is
    /// first decoded.
    pub(crate) fn manage_colour(&self, path: &Path) {
        let mut managed = self
            .colour_managed
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        managed.insert(path.to_path_buf());
    }

    /// The image, decoded by the first caller; callers wanting the same file meanwhile wait for
    /// that decode rather than repeat it. A file that fails to decode is not remembered, so
    /// every caller reports the error as it would have.
    pub(crate) fn get(&self, image: &ImageRef) -> Result<Arc<image::DynamicImage>, CookError> {
        let ImageRef::File(path) = image else {
            return decode(image).map(Arc::new);
        };
        let slot = {
            let mut files = self.files.lock().unwrap_or_else(|e| e.into_inner());
            Arc::clone(files.entry(path.clone()).or_default())
        };
        let mut slot = slot.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(img) = &*slot {
            return Ok(Arc::clone(img));
        }
        let decoded = if self.is_colour_managed(image) {
            texture::load_image_in_srgb(path)
                .map(|(img, _)| img)
                .map_err(|e| texture_error(path, e))?
        } else {
            decode(image)?
        };
        let img = Arc::new(as_rgba8(decoded));
        *slot = Some(Arc::clone(&img));
        Ok(img)
    }

    /// Counts one use to come of each file in `paths`, and lets go of the decoded files that
    /// are none of them: designs the window stage masked into images of its own were held
    /// to the end of the texture stage, 14 MB of the default scene's peak.
    fn expect_uses<'a>(&self, paths: impl Iterator<Item = &'a Path>) {
        let mut uses = self.uses.lock().unwrap_or_else(|e| e.into_inner());
        for p in paths {
            *uses.entry(p.to_path_buf()).or_default() += 1;
        }
        let mut files = self.files.lock().unwrap_or_else(|e| e.into_inner());
        files.retain(|p, _| uses.contains_key(p));
    }

    /// One counted use of `path` is over; after the last, the decoded image is let go (a
    /// caller still holding it keeps it until done). A later `get` would decode it again.
    fn done_with(&self, path: &Path) {
        let mut uses = self.uses.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(n) = uses.get_mut(path) {
            *n -= 1;
            if *n == 0 {
                uses.remove(path);
                let mut files = self.files.lock().unwrap_or_else(|e| e.into_inner());
                files.remove(path);
            }
        }
    }
}

/// Seed of a derived normal map's hammered-glass noise: the size of the image it is derived
/// from, nothing else, so the noise is where it was after an edit and a change stays where it
/// was made. Seeded by the design's content, one pixel changed in the default scene's mosaic
/// moved 309,261 of its 336,896 normals (up to 102 LSB, 400 texels away), and a regression diff
/// could not say where the edit was; seeded by its file's name, a renamed design changed its
/// glass (98 LSB). Designs of one size share their hammering; their cames differ.
fn seed((w, h): (u32, u32)) -> u64 {
    (u64::from(w) << 32 | u64::from(h)) ^ 0x9E37_79B9_7F4A_7C15
}

impl Job {
    /// The image file the job reads, if it is a file.
    fn file(&self) -> Option<&Path> {
        match self {
            Job::Colour {
                image: ImageRef::File(p),
                ..
            }
            | Job::Normal {
                image: ImageRef::File(p),
                ..
            }
            | Job::DerivedNormal {
                design: ImageRef::File(p),
                ..
            }
            | Job::Projector {
                design: ImageRef::File(p),
                ..
            } => Some(p),
            _ => None,
        }
    }

    /// The texture settings this job's output can depend on, for its key. A projector builds
    /// its own chain and never reads the mip filter, nor does a derived normal map (its design
    /// is reduced by a box); a given normal map reads it only to bring an image over the size
    /// cap down to the cap. With the filter in their keys, changing it re-cooked them for
    /// nothing.
    fn settings_read(&self, s: &TextureSettings) -> TextureSettings {
        let filter_read = match self {
            Job::Colour { .. } => true,
            Job::Normal { .. } => s.max_size.is_some(),
            Job::DerivedNormal { .. } => false,
            Job::Projector { .. } => false,
        };
        let mut s = s.clone();
        if !filter_read {
            s.mip_filter = texture::MipFilter::default();
        }
        s
    }

    /// What the `cooked`/`reused` lines add to the texture's name, which says the other roles.
    fn base_name_suffix(&self) -> String {
        match self {
            Job::Colour { .. } => " (colour)".into(),
            Job::Normal { .. } | Job::DerivedNormal { .. } => String::new(),
            Job::Projector { sigma, .. } => format!(" (sigma {sigma})"),
        }
    }

    /// The cache key: the texture settings, the storage choice, the job's parameters and the
    /// image's content. The chosen format and encoder setting follow from these and the texels.
    fn cache_key(&self, p: &Params) -> Result<cache::Key, CookError> {
        let mut k = cache::texture_key(&self.settings_read(&p.textures));
        k.serialized(
            "storage",
            &(
                p.format,
                p.normal_budget,
                p.design_budget,
                p.supercompression,
            ),
        );
        k.str("encoder", ENCODER);
        k.serialized("job", self);
        let image = match self {
            Job::Colour { image, .. } | Job::Normal { image, .. } => image,
            Job::DerivedNormal { design, .. } | Job::Projector { design, .. } => design,
        };
        key_image(&mut k, image)?;
        if p.images.is_colour_managed(image) {
            // The conversion is the colour library's: another version may round otherwise.
            k.str("colour profile", "applied, moxcms 0.8");
        }
        Ok(k.finish())
    }
}

fn key_image(k: &mut cache::KeyBuilder, image: &ImageRef) -> Result<(), CookError> {
    match image {
        ImageRef::File(p) => {
            k.file("image", p)?;
        }
        ImageRef::Embedded { name, bytes } => {
            k.str("name", name).bytes("image", bytes);
        }
        ImageRef::Raster { name, image } => {
            k.str("name", name)
                .u64("width", image.width() as u64)
                .u64("height", image.height() as u64)
                .bytes("pixels", image.as_raw());
        }
    }
    Ok(())
}

/// The block encoder and its version: part of every texture's cache key, since another
/// encoder (or version) may choose other blocks.
const ENCODER: &str = "intel_tex_2 0.5";

/// How every texture of a cook is made, apart from the job itself.
#[derive(Clone, Debug)]
struct Params<'a> {
    /// Source images, decoded once per cook.
    images: &'a DecodedImages,
    /// Mip filter and the scene's error budget (LSB), for blur, mips and block compression.
    textures: TextureSettings,
    format: TextureFormatChoice,
    /// Mean angle, degrees, for block-compressed normal maps.
    normal_budget: f32,
    /// `[textures] max_design_error_lsb`, for window designs.
    design_budget: Option<f32>,
    supercompression: pack::Supercompression,
}

/// A cooked texture: its logical size, the format its levels are stored in, and the levels.
#[derive(Clone, Debug, PartialEq)]
struct CookedTexture {
    width: u32,
    height: u32,
    format: pack::TextureFormat,
    supercompression: pack::Supercompression,
    /// As stored: in `format`, then compressed as `supercompression` says.
    levels: Vec<Vec<u8>>,
}

impl CookedTexture {
    /// The pack's texture record (without name, role and sections).
    fn describe(
        &self,
        name: String,
        role: pack::TextureRole,
        colour_space: pack::ColourSpace,
    ) -> pack::Texture {
        self.describe_levels(self.levels.len(), name, role, colour_space)
    }

    /// As [`CookedTexture::describe`], for `count` levels whatever `levels` holds.
    fn describe_levels(
        &self,
        count: usize,
        name: String,
        role: pack::TextureRole,
        colour_space: pack::ColourSpace,
    ) -> pack::Texture {
        let mips = (0..count)
            .map(|k| {
                let (width, height) = texture::level_size(self.width, self.height, k);
                pack::MipLevel {
                    width,
                    height,
                    section: 0,
                }
            })
            .collect();
        pack::Texture {
            name,
            role,
            colour_space,
            format: self.format,
            supercompression: self.supercompression,
            width: self.width,
            height: self.height,
            mips,
        }
    }
}

/// What a texture job says about itself: what a user should know (a note), where it fell short
/// of the budget (a warning), and the choices the budget made, with their measured errors (a
/// detail, shown with `-v`: three a window drowned the warnings of a cathedral's cook), each
/// `; `-joined.
#[derive(Clone, Debug, Default, PartialEq)]
struct Said {
    note: Option<String>,
    warning: Option<String>,
    detail: Option<String>,
}

impl Said {
    fn note(note: impl Into<String>) -> Self {
        Self {
            note: Some(note.into()),
            ..Self::default()
        }
    }

    fn detail(detail: impl Into<String>) -> Self {
        Self {
            detail: Some(detail.into()),
            ..Self::default()
        }
    }

    /// Both, `self`'s first.
    fn and(self, other: Said) -> Said {
        let join = |a: Option<String>, b: Option<String>| match (a, b) {
            (Some(a), Some(b)) => Some(format!("{a}; {b}")),
            (a, b) => a.or(b),
        };
        Said {
            note: join(self.note, other.note),
            warning: join(self.warning, other.warning),
            detail: join(self.detail, other.detail),
        }
    }
}

fn encode_cooked(c: &CookedTexture, said: &Said) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&c.width.to_le_bytes());
    out.extend_from_slice(&c.height.to_le_bytes());
    let format = pack::TextureFormat::ALL
        .iter()
        .position(|f| *f == c.format)
        .unwrap_or(0) as u32;
    out.extend_from_slice(&format.to_le_bytes());
    let supercompression = pack::Supercompression::ALL
        .iter()
        .position(|s| *s == c.supercompression)
        .unwrap_or(0) as u32;
    out.extend_from_slice(&supercompression.to_le_bytes());
    out.extend_from_slice(&(c.levels.len() as u32).to_le_bytes());
    for l in &c.levels {
        out.extend_from_slice(&(l.len() as u64).to_le_bytes());
        out.extend_from_slice(l);
    }
    for text in [&said.note, &said.warning, &said.detail] {
        let text = text.as_deref().unwrap_or("");
        out.extend_from_slice(&(text.len() as u64).to_le_bytes());
        out.extend_from_slice(text.as_bytes());
    }
    out
}

/// Decodes a cache payload; `None` when it does not hold a well-formed texture (every level
/// the size its format and level size call for, or a zstd frame that says so).
fn decode_cooked(bytes: &[u8]) -> Option<(CookedTexture, Said)> {
    let mut at = 0usize;
    let mut take = |n: usize| -> Option<&[u8]> {
        let s = bytes.get(at..at.checked_add(n)?)?;
        at += n;
        Some(s)
    };
    let u32_ = |b: &[u8]| u32::from_le_bytes(b.try_into().unwrap());
    let width = u32_(take(4)?);
    let height = u32_(take(4)?);
    let format = *pack::TextureFormat::ALL.get(u32_(take(4)?) as usize)?;
    let supercompression = *pack::Supercompression::ALL.get(u32_(take(4)?) as usize)?;
    let n = u32_(take(4)?) as usize;
    if n == 0 || n > 32 || width == 0 || height == 0 {
        return None;
    }
    let mut cooked = CookedTexture {
        width,
        height,
        format,
        supercompression,
        levels: Vec::with_capacity(n),
    };
    let shape = cooked.describe_levels(
        n,
        String::new(),
        pack::TextureRole::Colour,
        pack::ColourSpace::Linear,
    );
    for k in 0..n {
        let len = u64::from_le_bytes(take(8)?.try_into().unwrap());
        let level = take(usize::try_from(len).ok()?)?;
        supercompression
            .check_declared(level, shape.level_bytes(k))
            .ok()?;
        cooked.levels.push(level.to_vec());
    }
    let mut text = || -> Option<Option<String>> {
        let len = u64::from_le_bytes(take(8)?.try_into().unwrap()) as usize;
        let t = String::from_utf8(take(len)?.to_vec()).ok()?;
        Some((!t.is_empty()).then_some(t))
    };
    let said = Said {
        note: text()?,
        warning: text()?,
        detail: text()?,
    };
    if at != bytes.len() {
        return None;
    }
    Some((cooked, said))
}

/// A cooked texture, what its job said (method and encoder choices, budget misses), and where
/// it came from.
type Cooked = (CookedTexture, Said, crate::ArtifactSource);

/// Cooks one texture, or reuses it from the cache.
fn run_cached(job: &Job, p: &Params, cache: Option<&cache::Cache>) -> Result<Cooked, CookError> {
    let Some(cache) = cache else {
        let (c, n) = run_and_compress(job, p)?;
        return Ok((c, n, crate::ArtifactSource::Cooked));
    };
    let key = job.cache_key(p)?;
    let mut source = crate::ArtifactSource::Cooked;
    match cache.get(&key) {
        cache::Lookup::Hit(bytes) => match decode_cooked(&bytes) {
            Some((c, n)) => return Ok((c, n, crate::ArtifactSource::Reused)),
            None => {
                source =
                    crate::ArtifactSource::Recooked(format!("{}: malformed payload", key.hex()))
            }
        },
        cache::Lookup::Corrupt(why) => source = crate::ArtifactSource::Recooked(why),
        cache::Lookup::Miss => {}
    }
    let (c, n) = run_and_compress(job, p)?;
    // A cache that cannot be written only costs time next cook; the cook itself succeeded.
    let _ = cache.put(&key, &encode_cooked(&c, &n));
    Ok((c, n, source))
}

/// Cooks the RGBA8 chain, then stores it as the format choice says. A chain that may be
/// block-compressed is cooked from level 0 padded to whole blocks (`texture::bc`), so the one
/// `uv_scale` a renderer applies fits every level; it is cooked again unpadded when it stays
/// RGBA8.
fn run_and_compress(job: &Job, p: &Params) -> Result<(CookedTexture, Said), CookError> {
    let pad = p.format != TextureFormatChoice::Rgba8;
    let (mut chain, size, said, unpadded) = run(job, &p.textures, pad, p.images)?;
    let padded = (chain.width, chain.height) != size;
    // The padded chain can run a level longer (64x60 against 62x58); the logical size says how
    // many levels the texture has, and the GPU texture has as many of the padded size.
    chain.levels.truncate(texture::level_count(size.0, size.1));
    let (role, colour_space) = job.role();
    let design = matches!(job, Job::Colour { design: true, .. });
    let (mut cooked, stored) = compress(chain, size, (role, design), colour_space, p);
    if padded && cooked.format == pack::TextureFormat::Rgba8 {
        cooked.levels = match unpadded {
            Some(chain) => chain.levels,
            None => run(job, &p.textures, false, p.images)?.0.levels,
        };
    }
    supercompress(&mut cooked, p.supercompression);
    Ok((cooked, big_for_some_gpus(size).and(said).and(stored)))
}

/// The largest side many integrated and mobile GPUs load, and WebGPU's default limit
/// (`wgpu::Limits::default().max_texture_dimension_2d`).
const COMMON_MAX_SIDE: u32 = 8192;

/// A note for a texture over [`COMMON_MAX_SIDE`]: it cooks, and the viewer loads it from a
/// smaller level on such a GPU, but the user may want the pack to carry no more than it shows.
fn big_for_some_gpus((width, height): (u32, u32)) -> Said {
    if width.max(height) <= COMMON_MAX_SIDE {
        return Said::default();
    }
    Said::note(format!(
        "{width}x{height} is over {COMMON_MAX_SIDE} texels a side, the most many integrated and \
         mobile GPUs load (the viewer loads a smaller level there; `--max-texture-size \
         {COMMON_MAX_SIDE}` stores it so)"
    ))
}

/// Compresses the levels losslessly when that makes them smaller in all (tiny or noisy
/// levels may not be; the texture is then stored as it is).
fn supercompress(cooked: &mut CookedTexture, with: pack::Supercompression) {
    if with == pack::Supercompression::None {
        return;
    }
    let stored: Vec<Vec<u8>> = cooked.levels.par_iter().map(|l| with.compress(l)).collect();
    let size = |levels: &[Vec<u8>]| levels.iter().map(Vec::len).sum::<usize>();
    if size(&stored) < size(&cooked.levels) {
        cooked.levels = stored;
        cooked.supercompression = with;
    }
}

/// Stores a chain uncompressed or block-compressed: `auto` takes the cheapest encoder setting
/// whose measured error (worst level) fits the budget, and RGBA8 when none does; `bc` takes
/// the most accurate one when none does. Returns what was chosen and why, for the report.
fn compress(
    chain: texture::MipChain,
    (width, height): (u32, u32),
    (role, design): (pack::TextureRole, bool),
    colour_space: pack::ColourSpace,
    p: &Params,
) -> (CookedTexture, Said) {
    let rgba8 = |chain: texture::MipChain| CookedTexture {
        width,
        height,
        format: pack::TextureFormat::Rgba8,
        supercompression: pack::Supercompression::None,
        levels: chain.levels,
    };
    if p.format == TextureFormatChoice::Rgba8 {
        return (rgba8(chain), Said::default());
    }
    let normal = role == pack::TextureRole::Normal;
    let measure = match role {
        pack::TextureRole::Normal => texture::bc::Measure::Normal,
        pack::TextureRole::Colour => texture::bc::Measure::Rgba,
        // Renderers read a projector's colour only (the light it lets through).
        pack::TextureRole::Projector => texture::bc::Measure::Rgb,
    };
    let budget = crate::budget::compression_budget(
        (role, design),
        p.textures.max_error_lsb,
        p.design_budget,
        p.normal_budget,
    );
    let unit = if normal { "° mean" } else { " LSB RMS" };
    let candidates = crate::budget::compression_candidates(role);
    // `auto` keeps RGBA8 when no setting fits, so a setting may stop encoding as soon as its
    // error is certain to exceed the budget; `bc` stores the closest one, so each is finished.
    let give_up_above = if p.format == TextureFormatChoice::Auto {
        budget as f64
    } else {
        f64::INFINITY
    };
    let mut best: Option<(texture::bc::Codec, texture::bc::Compressed)> = None;
    // What each setting that did not fit measured, for the note when none does.
    let mut misses: Vec<String> = Vec::new();
    for codec in candidates {
        let shape = CookedTexture {
            width,
            height,
            format: codec.format(),
            supercompression: pack::Supercompression::None,
            levels: Vec::new(),
        }
        .describe_levels(chain.levels.len(), String::new(), role, colour_space);
        let c =
            match texture::bc::compress_chain_within(codec, &chain, &shape, measure, give_up_above)
            {
                Ok(c) => c,
                Err(over) => {
                    misses.push(format!(
                        "{} at least {:.3}{unit} over the chain from its {} smallest level(s)",
                        codec.name(),
                        over.at_least,
                        over.levels
                    ));
                    continue;
                }
            };
        let fits = c.error.mean <= budget as f64;
        if !fits {
            misses.push(format!(
                "{} {:.3}{unit} over the chain, {:.3} on level 0",
                codec.name(),
                c.error.mean,
                c.error.level0
            ));
        }
        let better = best
            .as_ref()
            .is_none_or(|(_, b)| c.error.mean < b.error.mean);
        if fits || better {
            best = Some((codec, c));
        }
        if fits {
            break;
        }
    }
    let fits = best
        .as_ref()
        .is_some_and(|(_, c)| c.error.mean <= budget as f64);
    if !fits && p.format == TextureFormatChoice::Auto {
        if misses.is_empty() {
            return (rgba8(chain), Said::default());
        }
        let note = format!(
            "kept RGBA8: no block encoder setting fits the budget of {budget}{unit} ({})",
            misses.join("; ")
        );
        return (rgba8(chain), Said::detail(note));
    }
    let Some((codec, c)) = best else {
        return (rgba8(chain), Said::default());
    };
    let measured = format!(
        "measured {:.3}{unit} over the chain, {:.3} on level 0, budget {budget}{unit}",
        c.error.mean, c.error.level0
    );
    // Under `bc` with none fitting, the budget chose nothing: a note saying it had read as a
    // contradiction of the warning beside it. The format is named, not a flag: the manifest's
    // `[textures] format` or a window's `texture_format` ask the same.
    let said = if fits {
        Said::detail(format!(
            "{} chosen by the error budget ({measured})",
            codec.name()
        ))
    } else {
        Said {
            warning: Some(format!(
                "no block encoder setting fits the budget of {budget}{unit}; stored as {}, the \
                 most accurate, as texture format \"bc\" asks ({})",
                codec.name(),
                misses.join("; ")
            )),
            ..Said::default()
        }
    };
    let cooked = CookedTexture {
        width,
        height,
        format: codec.format(),
        supercompression: pack::Supercompression::None,
        levels: c.levels,
    };
    (cooked, said)
}

/// A detail of the method the budget chose, or, where none fits it, the warning alone (it
/// names the method used; a note beside it saying the budget chose it read as a contradiction).
fn choice_note(what: &str, c: &crate::budget::Choice) -> Said {
    Said {
        note: None,
        detail: c.warning.is_none().then(|| {
            format!(
                "{what} method {} chosen by the error budget (measured max error {:.3} LSB)",
                c.method, c.expected_error
            )
        }),
        warning: c.warning.as_ref().map(|w| format!("{what}: {w}")),
    }
}

/// A job's RGBA8 chain, the image's size (the chain's own unless padded), what it said, and
/// the chain without padding when the job made that too on the way (a projector does).
type Chain = (
    texture::MipChain,
    (u32, u32),
    Said,
    Option<texture::MipChain>,
);

/// The largest side a normal map derived from a design is made at. Its relief is invented
/// (lead ridges, hammered dimples a 24th of the design across) and its texels within about a
/// degree of flat between them: a 4096² design's derived map was 8.1 MB of a 8.3 MB pack and
/// 9 of a cook's 17 s, for noise no view resolves beside its design.
pub const DERIVED_NORMAL_MAX_SIDE: u32 = 1024;

/// How a colour image's chain is made: the mip filter, and in linear light where the image is
/// sRGB, unless the error budget chose otherwise (its choice is returned to be reported). The
/// window stage reduces a design over the size cap with these too, as this stage would.
pub(crate) fn colour_options(
    srgb: bool,
    settings: &TextureSettings,
) -> (texture::ColourOptions, Option<crate::budget::Choice>) {
    let mut opts = texture::ColourOptions {
        srgb,
        filter: settings.mip_filter,
    };
    // The error budget picks from the committed table of measured errors, never from
    // timings taken now, so the pack stays deterministic.
    let choice = settings.max_error_lsb.map(|b| {
        let c = crate::budget::choose_mip(b, Some(opts.filter.name()));
        opts.filter = c.mip_filter().unwrap_or(opts.filter);
        opts.srgb = srgb && c.linear_light;
        c
    });
    (opts, choice)
}

/// Cooks a job's RGBA8 chain. With `pad`, level 0 is grown to whole 4x4 blocks before the
/// lower levels are made from it.
fn run(
    job: &Job,
    settings: &TextureSettings,
    pad: bool,
    images: &DecodedImages,
) -> Result<Chain, CookError> {
    let max_error = settings.max_error_lsb;
    // The size level 0 is cooked at.
    let storage = |(w, h): (u32, u32)| {
        if pad {
            texture::bc::block_padded_size(w, h)
        } else {
            (w, h)
        }
    };
    // Over the size cap, the image is replaced by its first mip level that fits, filtered as
    // the chain's levels are (`opts`), before padding: as if that level were the image given.
    let fit = |img: Arc<image::DynamicImage>,
               opts: &texture::ColourOptions,
               name: &ImageRef|
     -> Result<(Arc<image::DynamicImage>, Said), CookError> {
        let Some(cap) = settings.max_size else {
            return Ok((img, Said::default()));
        };
        let within = texture::first_level_within(&img, cap, opts)
            .map_err(|e| texture_error(Path::new(&name.name()), e))?;
        Ok(match within {
            None => (img, Said::default()),
            Some((k, level)) => {
                let said = Said::note(format!(
                    "{}x{} is over the size cap of {cap}: cooked from its mip level {k}, {}x{}",
                    img.width(),
                    img.height(),
                    level.width(),
                    level.height()
                ));
                (Arc::new(level), said)
            }
        })
    };
    // Supplied normal maps and heights are reduced as plain values, channel by channel.
    let plain = texture::ColourOptions {
        srgb: false,
        filter: settings.mip_filter,
    };
    let padded = |img: Arc<image::DynamicImage>| {
        let size = (img.width(), img.height());
        let (pw, ph) = storage(size);
        let img = if (pw, ph) != size {
            Arc::new(texture::pixels::pad_image(&img, pw, ph))
        } else {
            img
        };
        (img, size)
    };
    match job {
        Job::Colour {
            image,
            srgb,
            design,
        } => {
            let (opts, choice) = colour_options(*srgb, settings);
            let said = choice.map_or_else(Said::default, |c| choice_note("mips", &c));
            let (img, reduced) = fit(images.get(image)?, &opts, image)?;
            // A design is filtered as stored before it is weighed by its alpha: the colour
            // under its fully transparent texels (lead) must be its panes', not whatever the
            // image editor left there.
            let img = match design.then(|| texture::pixels::bleed_under_transparent(&img)) {
                Some(Some(bled)) => Arc::new(bled),
                _ => img,
            };
            let (img, size) = padded(img);
            let chain = texture::colour_mips(&img, &opts)
                .map_err(|e| texture_error(Path::new(&image.name()), e))?;
            Ok((chain, size, reduced.and(said), None))
        }
        Job::Normal {
            image,
            encoding,
            green,
            strength,
        } => {
            let (img, reduced) = fit(images.get(image)?, &plain, image)?;
            let (img, size) = padded(img);
            let (chain, held) = texture::supplied_normal_mips(&img, *encoding, *green, *strength)
                .map_err(|e| texture_error(Path::new(&image.name()), e))?;
            let said = match held {
                texture::SuppliedNormals::Vectors => Said::default(),
                texture::SuppliedNormals::RgInRgb => Said::note(
                    "its blue is near 0 throughout (no tangent-space normal points into the \
                     surface), so it is read as rg: z rebuilt from x and y; say normal_encoding \
                     = \"rg\" to mean it"
                        .to_string(),
                ),
                texture::SuppliedNormals::Unlike { share } => Said {
                    warning: Some(format!(
                        "{:.0} % of its texels encode no unit vector (or one into the surface): \
                         is it a colour image rather than a tangent-space normal map? Its \
                         normals are cooked as they read, and shade as noise",
                        share * 100.0
                    )),
                    ..Said::default()
                },
                texture::SuppliedNormals::Heights { depth } => Said::note(format!(
                    "grey, so read as a height (bump) map: its range spans {depth:.2} texels of \
                     depth (1/256 of its longer side times the strength {strength})"
                )),
            };
            Ok((chain, size, reduced.and(said), None))
        }
        Job::DerivedNormal { design, strength } => {
            // From the design's first level within [`DERIVED_NORMAL_MAX_SIDE`] (and the size
            // cap), box-filtered in linear light whatever the mip filter.
            let srgb = texture::ColourOptions {
                srgb: true,
                filter: texture::MipFilter::Box,
            };
            let cap = settings
                .max_size
                .map_or(DERIVED_NORMAL_MAX_SIDE, |c| c.min(DERIVED_NORMAL_MAX_SIDE));
            let img = images.get(design)?;
            let img = match texture::first_level_within(&img, cap, &srgb)
                .map_err(|e| texture_error(Path::new(&design.name()), e))?
            {
                Some((_, level)) => Arc::new(level),
                None => img,
            };
            let size = (img.width(), img.height());
            let (pw, ph) = storage(size);
            let chain = texture::derive_normal_map_padded(&img, seed(size), *strength, pw, ph)
                .map_err(|e| texture_error(Path::new(&design.name()), e))?;
            Ok((chain, size, Said::default(), None))
        }
        Job::Projector {
            design,
            sigma,
            margin,
            srgb,
        } => {
            let img = images.get(design)?;
            let mut opts = texture::ProjectorOptions::new(*sigma);
            opts.margin = *margin;
            opts.linear = !*srgb;
            opts.max_error_lsb = max_error;
            // The projector reduces a large design itself, its blur scaled to match.
            opts.max_size = Some(settings.max_size.map_or(pack::PROJECTOR_MAX_SIZE, |cap| {
                cap.min(pack::PROJECTOR_MAX_SIZE)
            }));
            // A cap the user sets holds for every texture, a projector's light margin included
            // (a 256 cap stored a 269 projector); the format's own bounds the design's part.
            opts.cap_whole_level = settings
                .max_size
                .is_some_and(|c| c <= pack::PROJECTOR_MAX_SIZE);
            opts.block_pad = pad;
            let choice = max_error.map_or_else(Said::default, |b| {
                // The blur runs by its narrower σ (`texture::BlurMethod::resolve`).
                let c = crate::budget::choose_blur(b, sigma.min());
                opts.method = c.blur_method().unwrap_or(opts.method);
                choice_note("blur", &c)
            });
            let (chain, unpadded, report) = texture::projector_with_unpadded(&img, &opts)
                .map_err(|e| texture_error(Path::new(&design.name()), e))?;
            let said = Said::detail(report.to_string()).and(choice);
            Ok((chain, (report.width, report.height), said, unpadded))
        }
    }
}

/// Projector blur σ in design texels: the manifest's, or the light's penumbra on the floor.
///
/// The penumbra is round on the glass, but a design stretched onto its window (a square
/// image on a lancet three times as tall as wide) has fewer texels per unit along one axis:
/// σ is the penumbra's length in texels along each axis.
fn projector_sigma(
    blur_sigma: Option<f32>,
    frame: Option<&pack::Window>,
    light: Option<&pack::LightKind>,
    floor_y: Option<f32>,
    design_size: Option<(u32, u32)>,
) -> texture::Sigma2 {
    if let Some(s) = blur_sigma {
        return s.into();
    }
    let (Some(frame), Some(light), Some((width, height))) = (frame, light, design_size) else {
        return 0.0.into();
    };
    let u = glam::Vec3::from(frame.u_axis);
    let v = glam::Vec3::from(frame.v_axis);
    let centre = glam::Vec3::from(frame.origin) + 0.5 * (u + v);
    let floor = floor_y.unwrap_or(centre.y - v.length().max(u.length()));
    // The lamp's distance from the window (infinite for the sun).
    let (dir, angular, lamp) = match *light {
        pack::LightKind::Directional {
            direction,
            angular_size,
        } => (glam::Vec3::from(direction), angular_size, f32::INFINITY),
        pack::LightKind::Point { position, radius }
        | pack::LightKind::Spot {
            position, radius, ..
        } => {
            let d = centre - glam::Vec3::from(position);
            let a = d.length().max(1e-6);
            (d, (radius / a).atan() * 2.0, a)
        }
    };
    let dir = dir.normalize_or_zero();
    // Distance from the window along the light to the floor plane; straight down otherwise.
    let drop = (centre.y - floor).max(0.0);
    let floor_distance = if dir.y < -1e-3 { drop / -dir.y } else { drop };
    // The penumbra θ·d is on the floor, but the blur is of the design: a lamp magnifies the
    // design (a + d)/a times on its way to the floor, so in the window's plane the penumbra is
    // that much narrower. The sun does not magnify it.
    let distance = if lamp.is_finite() {
        floor_distance * lamp / (lamp + floor_distance)
    } else {
        floor_distance
    };
    let along = |texels: u32, axis: glam::Vec3| {
        let texels_per_unit = texels as f32 / axis.length().max(1e-6);
        let sigma = texture::sigma_from_light(angular, distance, texels_per_unit);
        if sigma.is_finite() && sigma >= 0.0 {
            // Windows sharing a design at the same height differ in σ only by float noise
            // (2.2256246 against 2.2256413 in the default scene). Rounded to 1/1000 texel,
            // they share one projector texture; the change (< 0.0005 texel) is far below what
            // the penumbra estimate itself can claim.
            (sigma * 1000.0).round() / 1000.0
        } else {
            0.0
        }
    };
    texture::Sigma2::new(along(width, u), along(height, v))
}

/// The pack's texture table, the mip levels of each texture, and the background panorama.
pub type CookedTextures = (Vec<pack::Texture>, Vec<Vec<Vec<u8>>>, Option<u32>);

/// Cooks every texture the materials, windows and background use; fills each material's
/// texture references and returns the pack's texture table and mip data.
#[allow(clippy::too_many_arguments)]
pub fn cook_textures(
    manifest: &Manifest,
    tagging: &mut Tagging,
    windows: &[pack::Window],
    lit_windows: &[bool],
    floor_y: Option<f32>,
    settings: &Settings,
    images: &DecodedImages,
    report: &mut Report,
) -> Result<CookedTextures, CookError> {
    if !settings.cook_textures {
        return Ok((Vec::new(), Vec::new(), None));
    }
    // Each job with the format it is stored in: a window's `texture_format` or the scene's.
    let mut jobs: Vec<(Job, TextureFormatChoice)> = Vec::new();
    let format = manifest.textures.format;
    let mut add = |job: Job, format: TextureFormatChoice| -> u32 {
        let job = (job, format);
        match jobs.iter().position(|j| *j == job) {
            Some(i) => i as u32,
            None => {
                jobs.push(job);
                jobs.len() as u32 - 1
            }
        }
    };
    // Job indices per material: (diffuse, normal, projector).
    // Each material's diffuse, normal and projector texture, and its projector's margin.
    type Refs = (Option<u32>, Option<u32>, Option<u32>, [f32; 2]);
    let mut refs: Vec<Refs> = Vec::new();
    let light = manifest.light.as_ref().map(|l| &l.kind);
    for (mi, plan) in tagging.materials.iter().enumerate() {
        let design = plan
            .window
            .as_deref()
            .filter(|_| plan.material.class.is_window());
        let mut r: Refs = (None, None, None, [0.0; 2]);
        match design {
            Some(w) => {
                let f = w.texture_format.unwrap_or(format);
                r.0 = Some(add(
                    Job::Colour {
                        image: w.design.clone(),
                        srgb: w.colour_space == pack::ColourSpace::Srgb,
                        design: true,
                    },
                    f,
                ));
                // The [[window]]'s own normal map, else the glass's (a rule's `normal_map`,
                // or the source material's), else one derived from the design: a rule's map
                // on window glass was read, checked, and then never used.
                r.1 = Some(add(
                    match (&w.normal, &plan.normal_texture) {
                        (Some((image, encoding, green)), _) => Job::Normal {
                            image: image.clone(),
                            encoding: *encoding,
                            green: *green,
                            strength: w.normal_strength.unwrap_or(1.0),
                        },
                        (None, Some(image)) => Job::Normal {
                            image: image.clone(),
                            encoding: NormalEncoding::Rgb,
                            green: GreenAxis::OpenGl,
                            strength: w.normal_strength.unwrap_or(plan.normal_scale),
                        },
                        (None, None) => Job::DerivedNormal {
                            design: w.design.clone(),
                            strength: w.normal_strength.unwrap_or(1.0),
                        },
                    },
                    f,
                ));
                if lit_windows.get(mi).copied().unwrap_or(false) {
                    let frame = windows.iter().find(|f| f.material as usize == mi);
                    let (dw, dh) = w.design_size;
                    let size = (dw > 0 && dh > 0).then_some((dw, dh));
                    let sigma = projector_sigma(w.blur_sigma, frame, light, floor_y, size);
                    let margin = texture::projector_margin(sigma, dw, dh);
                    r.2 = Some(add(
                        Job::Projector {
                            design: w.design.clone(),
                            sigma,
                            margin,
                            srgb: w.colour_space == pack::ColourSpace::Srgb,
                        },
                        f,
                    ));
                    // The texture spans the design and its margin: in frame units, m / size.
                    if dw > 0 && dh > 0 {
                        r.3 = [margin[0] as f32 / dw as f32, margin[1] as f32 / dh as f32];
                    }
                }
            }
            None => {
                r.0 = plan.diffuse_texture.clone().map(|image| {
                    add(
                        Job::Colour {
                            image,
                            srgb: true,
                            design: false,
                        },
                        format,
                    )
                });
                r.1 = plan.normal_texture.clone().map(|image| {
                    add(
                        Job::Normal {
                            image,
                            encoding: NormalEncoding::Rgb,
                            green: GreenAxis::OpenGl,
                            strength: plan.normal_scale,
                        },
                        format,
                    )
                });
            }
        }
        refs.push(r);
    }
    let panorama = manifest.background.panorama.clone().map(|p| {
        add(
            Job::Colour {
                image: ImageRef::File(p),
                srgb: true,
                design: false,
            },
            format,
        )
    });

    for (job, _) in &jobs {
        if let Some(p) = job.file() {
            report.inputs.push(p.to_path_buf());
        }
    }
    let params = |format: TextureFormatChoice| Params {
        images,
        textures: settings.textures.clone(),
        format: settings.textures.format.unwrap_or(format),
        normal_budget: manifest
            .textures
            .max_normal_error_deg
            .unwrap_or(crate::budget::DEFAULT_NORMAL_ERROR_DEG),
        design_budget: manifest.textures.max_design_error_lsb,
        supercompression: settings
            .textures
            .supercompression
            .unwrap_or(manifest.textures.supercompression),
    };
    images.expect_uses(jobs.iter().filter_map(|(j, _)| j.file()));
    let results: Vec<Result<Cooked, CookError>> = jobs
        .par_iter()
        .map(|(j, f)| {
            let cooked = run_cached(j, &params(*f), settings.cache.as_ref());
            if let Some(p) = j.file() {
                images.done_with(p);
            }
            cooked
        })
        .collect();
    let mut textures = Vec::with_capacity(jobs.len());
    let mut data = Vec::with_capacity(jobs.len());
    let names = unique_names(jobs.iter().map(|(job, _)| job.base_name()).collect());
    // Where a window's textures are said to come from where the manifest does not name their
    // file: its `[[window]]` entry (a design cut to the outline is the cook's own image), or
    // the `--window` image (it was said to be the manifest's, at no line).
    let mut said_at: HashMap<usize, (PathBuf, Option<usize>)> = HashMap::new();
    for (plan, r) in tagging.materials.iter().zip(&refs) {
        if let Some(at) = plan.window.as_deref().and_then(|w| w.said_at.as_ref()) {
            for k in [r.0, r.1, r.2].into_iter().flatten() {
                said_at.entry(k as usize).or_insert_with(|| at.clone());
            }
        }
    }
    for (i, (((job, _), result), name)) in jobs.iter().zip(results).zip(names).enumerate() {
        let (cooked, said, source) = result?;
        // As `cooker info` names it: a file's path said nothing of which of two textures
        // made from one design (`lancet.masked`, `lancet.masked.2`) was cooked.
        report
            .artifacts
            .push((format!("{name}{}", job.base_name_suffix()), source));
        let (role, colour_space) = job.role();
        // Named as `cooker info` lists the texture, so two designs of one file name are told
        // apart in the notes too.
        // At the line naming its file, where a manifest names it (a colour photo given as a
        // normal map is found at its key, not by searching the manifest for the name).
        let what = matches!(job, Job::Normal { .. }).then_some("normal_map");
        let line = job
            .file()
            .and_then(|p| manifest.naming(p, what))
            .map(|n| n.line.0);
        let (path, line) = match (line, said_at.get(&i)) {
            (None, Some((path, line))) => (path.as_path(), *line),
            _ => (manifest.path.as_path(), line),
        };
        let about = |text: String| Warning::new(path, line, format!("{name}: {text}"));
        report.notes.extend(said.note.map(about));
        report.details.extend(said.detail.map(about));
        report.warnings.extend(said.warning.map(about));
        textures.push(cooked.describe(name, role, colour_space));
        data.push(cooked.levels);
    }
    for (plan, r) in tagging.materials.iter_mut().zip(refs) {
        plan.material.diffuse_texture = r.0;
        plan.material.normal_texture = r.1;
        plan.material.projector_texture = r.2;
        plan.material.projector_margin = if r.2.is_some() { r.3 } else { [0.0; 2] };
    }
    Ok((textures, data, panorama))
}

/// Texture names from their base names: the first of each keeps it, later ones take the first
/// `.2`, `.3`, ... that no texture has, so `x/t.png`, `y/t.png` and `t.2.png` become `t`,
/// `t.3` and `t.2` (a pack's names must be unique).
fn unique_names(bases: Vec<String>) -> Vec<String> {
    let mut taken: std::collections::HashSet<String> = bases.iter().cloned().collect();
    let mut first = std::collections::HashSet::new();
    bases
        .into_iter()
        .map(|base| {
            if first.insert(base.clone()) {
                return base;
            }
            let name = (2..)
                .map(|k| format!("{base}.{k}"))
                .find(|n| !taken.contains(n))
                .expect("a free suffix");
            taken.insert(name.clone());
            name
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A design renamed, copied elsewhere or edited keeps its hammered glass: the noise's seed is
    /// the size of what it is derived from.
    #[test]
    fn a_derived_normal_s_seed_is_its_size_alone() {
        assert_eq!(seed((64, 32)), seed((64, 32)));
        assert_ne!(seed((64, 32)), seed((32, 64)));
        assert_ne!(seed((64, 32)), seed((64, 33)));
    }

    /// Changing the mip filter re-cooks what reads it: colour chains, and given normal maps
    /// only where a size cap may bring their image down with it; never a projector nor a
    /// derived normal map (its design is reduced by a box).
    #[test]
    fn only_jobs_that_read_the_mip_filter_have_it_in_their_keys() {
        let image = ImageRef::Raster {
            name: "w".into(),
            image: Arc::new(image::RgbaImage::new(4, 4)),
        };
        let jobs = [
            Job::Colour {
                image: image.clone(),
                srgb: true,
                design: true,
            },
            Job::DerivedNormal {
                design: image.clone(),
                strength: 1.0,
            },
            Job::Projector {
                design: image,
                sigma: 2.0.into(),
                margin: [8, 8],
                srgb: true,
            },
        ];
        let images = DecodedImages::default();
        let params = |filter, max_size| Params {
            images: &images,
            textures: TextureSettings {
                mip_filter: filter,
                max_error_lsb: None,
                format: None,
                supercompression: None,
                max_size,
            },
            format: TextureFormatChoice::default(),
            normal_budget: 1.0,
            design_budget: None,
            supercompression: pack::Supercompression::default(),
        };
        let changed = |max_size| -> Vec<bool> {
            jobs.iter()
                .map(|j| {
                    let a = j
                        .cache_key(&params(texture::MipFilter::Box, max_size))
                        .unwrap();
                    let b = j
                        .cache_key(&params(texture::MipFilter::Kaiser, max_size))
                        .unwrap();
                    a != b
                })
                .collect()
        };
        assert_eq!(changed(None), [true, false, false]);
        assert_eq!(changed(Some(1024)), [true, false, false]);
    }

    /// `x/t.png`, `y/t.png` and `t.2.png` cooked together: the second `t` used to be named
    /// `t.2` too, and the cook failed with an invalid table of contents (exit 3).
    #[test]
    fn texture_names_are_unique_whatever_the_file_names() {
        let names = |b: &[&str]| unique_names(b.iter().map(|s| s.to_string()).collect());
        assert_eq!(names(&["t", "t", "t.2"]), ["t", "t.3", "t.2"]);
        assert_eq!(names(&["t.2", "t", "t", "t"]), ["t.2", "t", "t.3", "t.4"]);
        assert_eq!(names(&["a", "b", "a"]), ["a", "b", "a.2"]);
        let many = names(&["t", "t.2", "t", "t.3", "t", "t.2"]);
        let set: std::collections::HashSet<_> = many.iter().collect();
        assert_eq!(set.len(), many.len(), "{many:?}");
    }

    /// The blur is the light's penumbra on the floor, measured in the design: a lamp a metres
    /// from a window casts a penumbra θ·b on a floor b beyond it, and the design reaches the
    /// floor (a + b)/a times as large, so in the design it is θ·b·a/(a + b). The sun's rays
    /// are parallel: θ·b.
    #[test]
    fn the_projector_blur_is_the_penumbra_in_the_window_s_plane() {
        // A 2 m skylight of 200 texels at y = 8 over a floor at 0.
        let frame = pack::Window {
            material: 0,
            origin: [-1.0, 8.0, -1.0],
            u_axis: [2.0, 0.0, 0.0],
            v_axis: [0.0, 0.0, 2.0],
            normal: [0.0, -1.0, 0.0],
            source_materials: Vec::new(),
        };
        let sigma = |light: pack::LightKind| {
            let s = projector_sigma(
                None,
                Some(&frame),
                Some(&light),
                Some(0.0),
                Some((200, 200)),
            );
            // A square design on a square window: the same texels per unit both ways.
            assert_eq!(s.x, s.y);
            s.x
        };
        let (a, b, r) = (12.0f32, 8.0f32, 0.2f32);
        let theta = 2.0 * (r / a).atan();
        let lamp = sigma(pack::LightKind::Point {
            position: [0.0, 8.0 + a, 0.0],
            radius: r,
        });
        let expected = theta * b * a / (a + b) / 4.0 * 100.0;
        assert!((lamp - expected).abs() < 2e-3, "{lamp} against {expected}");
        let sun = sigma(pack::LightKind::Directional {
            direction: [0.0, -1.0, 0.0],
            angular_size: theta,
        });
        assert!((sun - theta * b / 4.0 * 100.0).abs() < 2e-3, "{sun}");
        // A given σ is kept.
        assert_eq!(
            projector_sigma(Some(3.5), Some(&frame), None, None, Some((200, 200))),
            3.5.into()
        );
    }

    /// A square design stretched onto a window three times as long as wide has a third of the
    /// texels per unit along the long side, so the same penumbra is a third as many texels
    /// there. A design drawn at the window's proportions is round again.
    #[test]
    fn a_stretched_design_is_blurred_by_its_own_texels_along_each_axis() {
        let lancet = pack::Window {
            material: 0,
            origin: [-0.5, 8.0, -3.0],
            u_axis: [1.0, 0.0, 0.0],
            v_axis: [0.0, 0.0, 6.0],
            normal: [0.0, -1.0, 0.0],
            source_materials: Vec::new(),
        };
        let sun = pack::LightKind::Directional {
            direction: [0.0, -1.0, 0.0],
            angular_size: 0.02,
        };
        let sigma = |size| projector_sigma(None, Some(&lancet), Some(&sun), Some(0.0), Some(size));
        let square = sigma((200, 200));
        // 0.02 rad over 8 m is 0.16 m of penumbra, σ 0.04 m: 8 texels across, 1.333 along.
        assert!((square.x - 8.0).abs() < 1e-3, "{square}");
        assert!((square.y - 8.0 / 6.0).abs() < 1e-3, "{square}");
        let proportioned = sigma((200, 1200));
        assert_eq!(proportioned.x, proportioned.y, "{proportioned}");
        assert_eq!(proportioned.x, square.x);
    }

    #[test]
    fn an_image_file_is_decoded_once_per_cook_and_a_bad_one_fails_every_time() {
        let dir = std::env::temp_dir().join(format!("decoded-images-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("design.png");
        image::RgbaImage::from_pixel(5, 3, image::Rgba([10, 20, 30, 255]))
            .save(&good)
            .unwrap();
        let bad = dir.join("broken.png");
        std::fs::write(&bad, b"\x89PNG\r\n\x1a\n not really").unwrap();
        let images = DecodedImages::default();
        let (a, b) = rayon::join(
            || images.get(&ImageRef::File(good.clone())).unwrap(),
            || images.get(&ImageRef::File(good.clone())).unwrap(),
        );
        assert!(Arc::ptr_eq(&a, &b), "one decode, shared");
        assert_eq!((a.width(), a.height()), (5, 3));
        for _ in 0..2 {
            let e = images.get(&ImageRef::File(bad.clone())).unwrap_err();
            assert!(e.to_string().contains("broken.png"), "{e}");
        }
        // Let go where no use is counted; kept through its counted uses, let go after the
        // last one.
        images.expect_uses(std::iter::empty());
        let e = images.get(&ImageRef::File(good.clone())).unwrap();
        assert!(!Arc::ptr_eq(&a, &e), "let go with no use to come");
        let a = e;
        images.expect_uses([good.as_path(), good.as_path()].into_iter());
        images.done_with(&good);
        let c = images.get(&ImageRef::File(good.clone())).unwrap();
        assert!(
            Arc::ptr_eq(&a, &c),
            "still held after the first of two uses"
        );
        images.done_with(&good);
        let d = images.get(&ImageRef::File(good.clone())).unwrap();
        assert!(
            !Arc::ptr_eq(&a, &d),
            "let go after the last use, so decoded afresh"
        );
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A cache payload gives back the texture and both its note and its warning, and a payload
    /// cut short or with a byte too many is refused.
    #[test]
    fn cooked_payload_round_trips_notes_and_warnings() {
        let bc7 = CookedTexture {
            width: 6,
            height: 5,
            format: pack::TextureFormat::Bc7,
            supercompression: pack::Supercompression::None,
            levels: vec![vec![1; 2 * 2 * 16], vec![2; 16], vec![3; 16]],
        };
        let mut zstd = bc7.clone();
        supercompress(&mut zstd, pack::Supercompression::Zstd);
        assert_eq!(zstd.supercompression, pack::Supercompression::Zstd);
        // A frame that declares another level size is refused like a level of the wrong size.
        let mut wrong = zstd.clone();
        wrong.levels[1] = pack::Supercompression::Zstd.compress(&[2; 32]);
        assert_eq!(
            decode_cooked(&encode_cooked(&wrong, &Said::default())),
            None
        );
        for (cooked, said) in [
            Said::default(),
            Said::note("bc7 very-fast chosen"),
            Said {
                warning: Some("tighter than any".into()),
                ..Said::default()
            },
            Said::note("a").and(Said {
                note: Some("b".into()),
                warning: Some("c".into()),
                detail: Some("d".into()),
            }),
            Said::detail("sigma 2.2"),
        ]
        .into_iter()
        .flat_map(|said| [(bc7.clone(), said.clone()), (zstd.clone(), said)])
        {
            let bytes = encode_cooked(&cooked, &said);
            assert_eq!(decode_cooked(&bytes), Some((cooked.clone(), said.clone())));
            assert_eq!(decode_cooked(&bytes[..bytes.len() - 1]), None);
            let mut longer = bytes.clone();
            longer.push(0);
            assert_eq!(decode_cooked(&longer), None);
        }
        assert_eq!(
            Said::note("a").and(Said::note("b")).note.as_deref(),
            Some("a; b")
        );
    }
}
