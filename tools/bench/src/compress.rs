//! Block-compression sweep: encoder setting × texture role, time against error, and the whole
//! default scene cooked RGBA8 against the default (`auto`) format: pack size, cold cook time and
//! FLIP of every camera's final render against the RGBA8 pack's.
//!
//! Roles: a stained-glass design (our rose), its blurred projector, a normal map (our hammered
//! glass) and stone (Crytek Sponza's bricks from `../shared/testdata` when present, else our
//! wall). Errors are those the cooker budgets with (`texture::bc`): RMS over every channel of
//! every level in 8-bit steps for colour, mean angle in degrees for normal maps; level 0 alone
//! is reported beside them. Times are whole mip chains on one thread.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use texture::bc::{Bc7Profile, Codec};

use crate::common::median;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CompressRow {
    pub role: String,
    pub image: String,
    pub width: u32,
    pub height: u32,
    pub codec: String,
    /// Median over the runs, one thread, the whole chain.
    pub time_ms: f64,
    /// Colour: LSB RMS over the chain; normal maps: mean degrees over the chain.
    pub error: f64,
    pub error_level0: f64,
    /// Colour: largest channel difference (LSB); normal maps: 99th percentile (degrees).
    pub error_max: f64,
}

/// zstd on top of a role's stored chain: what the pack's supercompression costs and saves.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ZstdRow {
    pub role: String,
    /// The chain's format before zstd: `rgba8`, `bc7 very-fast` or `bc5`.
    pub stored: String,
    pub level: i32,
    pub raw_bytes: u64,
    pub bytes: u64,
    /// Median over the runs, one thread, every level of the chain.
    pub compress_ms: f64,
    pub decompress_ms: f64,
}

/// A value per camera, by name.
pub type PerCamera = Vec<(String, f64)>;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ScenePack {
    /// How the textures were stored: `rgba8`, `auto`, and variants.
    pub format: String,
    pub bytes: u64,
    /// The textures' bytes in their formats: what a GPU holds once they are decoded from zstd.
    #[serde(default)]
    pub gpu_texture_bytes: u64,
    /// Cold cook in process (no cache), median over the runs.
    pub cook_ms: f64,
    /// Per camera: FLIP mean of the final render against the RGBA8 pack's (0 for RGBA8).
    pub flip: Vec<(String, f64)>,
}

#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct CompressReport {
    pub rows: Vec<CompressRow>,
    #[serde(default)]
    pub zstd: Vec<ZstdRow>,
    pub scene: Vec<ScenePack>,
    pub render_size: (u32, u32),
    /// Why the scene part did not run, when it did not.
    pub scene_error: Option<String>,
    /// Per camera: FLIP mean of the RGBA8 pack's render against itself with every channel one
    /// 8-bit step brighter, the scale the scene's FLIP numbers are read against.
    #[serde(default)]
    pub flip_one_step: Vec<(String, f64)>,
}

pub struct CompressConfig {
    /// Crop every source to at most this square (centre), to keep quick runs quick.
    pub max_size: u32,
    pub runs: usize,
    pub profiles: Vec<Bc7Profile>,
    /// zstd levels to try on each role's RGBA8 and block-compressed chains.
    pub zstd_levels: Vec<i32>,
    /// The scene to cook both ways, and the render size; `None` skips that part.
    pub scene: Option<PathBuf>,
    pub render_size: (u32, u32),
}

fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src")
}

/// The stone texture: Sponza's bricks from the team's shared test data, else our wall.
fn stone() -> PathBuf {
    let shared = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../../shared/testdata/textures/crytek-sponza/spnza_bricks_a_diff.tga");
    if shared.is_file() {
        shared
    } else {
        assets().join("textures/wall.png")
    }
}

fn crop(img: image::DynamicImage, max: u32) -> image::DynamicImage {
    let (w, h) = (img.width(), img.height());
    let (cw, ch) = (w.min(max), h.min(max));
    img.crop_imm((w - cw) / 2, (h - ch) / 2, cw, ch)
}

fn load(path: &Path, max: u32) -> Result<image::DynamicImage> {
    let img = texture::load_image(path).with_context(|| format!("loading {}", path.display()))?;
    Ok(crop(img, max))
}

/// One role's source chain.
struct Source {
    role: &'static str,
    image: String,
    chain: texture::MipChain,
    measure: texture::bc::Measure,
}

fn sources(max: u32) -> Result<Vec<Source>> {
    let srgb = texture::ColourOptions {
        srgb: true,
        filter: texture::MipFilter::Box,
    };
    let design_path = assets().join("windows/rose.png");
    let design = load(&design_path, max)?;
    let normal_path = assets().join("normals/hammered.png");
    let stone_path = stone();
    let name = |p: &Path| {
        p.file_name()
            .unwrap_or_default()
            .to_string_lossy()
            .into_owned()
    };
    // The default scene's rose projector blur, scaled to the cropped size.
    let sigma = 6.57 * design.width() as f32 / 1024.0;
    // As the cooker stores it: no larger than renderers sample it (and encoded opaque, by its
    // measure below).
    let mut opts = texture::ProjectorOptions::new(sigma);
    opts.max_size = Some(pack::PROJECTOR_MAX_SIZE);
    let (projector, _) = texture::projector(&design, &opts).context("blurring the projector")?;
    Ok(vec![
        Source {
            role: "stained-glass design",
            image: name(&design_path),
            chain: texture::colour_mips(&design, &srgb)?,
            measure: texture::bc::Measure::Rgba,
        },
        Source {
            role: "projector",
            image: format!("{} blurred, sigma {sigma:.2}", name(&design_path)),
            chain: projector,
            measure: texture::bc::Measure::Rgb,
        },
        Source {
            role: "normal map",
            image: name(&normal_path),
            chain: texture::normal_mips(
                &load(&normal_path, max)?,
                texture::NormalEncoding::Rgb,
                texture::GreenAxis::OpenGl,
            )?,
            measure: texture::bc::Measure::Normal,
        },
        Source {
            role: "stone",
            image: name(&stone_path),
            chain: texture::colour_mips(&load(&stone_path, max)?, &srgb)?,
            measure: texture::bc::Measure::Rgba,
        },
    ])
}

/// The pack record a chain is compressed as.
fn shape(chain: &texture::MipChain, codec: Codec) -> pack::Texture {
    texture::bc::chain_shape(chain, codec, pack::ColourSpace::Linear)
}

/// zstd at `level` over every level of `chain`, on this thread: bytes, then the medians of the
/// compress and decompress times.
fn zstd_chain(levels: &[Vec<u8>], level: i32, runs: usize) -> Result<(u64, f64, f64)> {
    let (mut enc, mut dec) = (Vec::new(), Vec::new());
    let mut bytes = 0;
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        let frames = levels
            .iter()
            .map(|l| zstd::bulk::compress(l, level))
            .collect::<std::io::Result<Vec<_>>>()?;
        enc.push(start.elapsed().as_secs_f64() * 1e3);
        bytes = frames.iter().map(|f| f.len() as u64).sum();
        let start = Instant::now();
        for (f, l) in frames.iter().zip(levels) {
            let mut out = vec![0u8; l.len()];
            let n = zstd::bulk::decompress_to_buffer(f, &mut out)?;
            anyhow::ensure!(out[..n] == l[..], "zstd round trip differs");
        }
        dec.push(start.elapsed().as_secs_f64() * 1e3);
    }
    Ok((bytes, median(&mut enc), median(&mut dec)))
}

pub fn sweep(cfg: &CompressConfig, progress: &mut dyn FnMut(&str)) -> Result<CompressReport> {
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    let mut rows = Vec::new();
    let mut zstd_rows = Vec::new();
    for s in sources(cfg.max_size)? {
        // The chain as the cooker would store it without block compression, and with the
        // setting the cooker reaches for first on each role.
        let codec = if s.measure == texture::bc::Measure::Normal {
            Codec::Bc5
        } else {
            Codec::Bc7(Bc7Profile::VeryFast)
        };
        let blocks =
            texture::bc::compress_chain(codec, &s.chain, &shape(&s.chain, codec), s.measure);
        for (stored, levels) in [
            ("rgba8".to_string(), &s.chain.levels),
            (codec.name(), &blocks.levels),
        ] {
            let raw_bytes = levels.iter().map(|l| l.len() as u64).sum();
            for &level in &cfg.zstd_levels {
                let (bytes, compress_ms, decompress_ms) =
                    one.install(|| zstd_chain(levels, level, cfg.runs))?;
                progress(&format!(
                    "zstd {} {stored} level {level}: {raw_bytes} -> {bytes} bytes, {compress_ms:.1} / {decompress_ms:.1} ms",
                    s.role
                ));
                zstd_rows.push(ZstdRow {
                    role: s.role.into(),
                    stored: stored.clone(),
                    level,
                    raw_bytes,
                    bytes,
                    compress_ms,
                    decompress_ms,
                });
            }
        }
        let codecs: Vec<Codec> = if s.measure == texture::bc::Measure::Normal {
            vec![Codec::Bc5]
        } else {
            cfg.profiles.iter().map(|&p| Codec::Bc7(p)).collect()
        };
        for codec in codecs {
            let texture = shape(&s.chain, codec);
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..cfg.runs.max(1) {
                let start = Instant::now();
                let c = one
                    .install(|| texture::bc::compress_chain(codec, &s.chain, &texture, s.measure));
                times.push(start.elapsed().as_secs_f64() * 1e3);
                last = Some(c);
            }
            let e = last.expect("at least one run").error;
            let row = CompressRow {
                role: s.role.into(),
                image: s.image.clone(),
                width: s.chain.width,
                height: s.chain.height,
                codec: codec.name(),
                time_ms: median(&mut times),
                error: e.mean,
                error_level0: e.level0,
                error_max: e.max,
            };
            progress(&format!(
                "compress {} {}: {:.1} ms, error {:.3} (level 0 {:.3})",
                row.role, row.codec, row.time_ms, row.error, row.error_level0
            ));
            rows.push(row);
        }
    }
    let mut report = CompressReport {
        rows,
        zstd: zstd_rows,
        scene: Vec::new(),
        render_size: cfg.render_size,
        scene_error: None,
        flip_one_step: Vec::new(),
    };
    if let Some(scene) = &cfg.scene {
        match scene_effect(scene, cfg, progress) {
            Ok((s, step)) => {
                report.scene = s;
                report.flip_one_step = step;
            }
            Err(e) => {
                progress(&format!("compression: scene part not run: {e:#}"));
                report.scene_error = Some(format!("{e:#}"));
            }
        }
    }
    Ok(report)
}

/// Cooks the scene with RGBA8 textures (the reference), the default and its variants, renders
/// every camera of each, and compares; also returns what one 8-bit step on every channel of
/// the RGBA8 renders measures.
fn scene_effect(
    scene: &Path,
    cfg: &CompressConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<(Vec<ScenePack>, PerCamera)> {
    use cook::manifest::TextureFormatChoice;
    use pack::Supercompression;
    let loaded =
        cook::Manifest::load(scene).with_context(|| format!("loading {}", scene.display()))?;
    let gpu = render::Gpu::headless()?;
    let (w, h) = cfg.render_size;
    let mut out = Vec::new();
    let mut reference: Vec<Vec<u8>> = Vec::new();
    let mut one_step = Vec::new();
    // (name, format, supercompression, design budget in LSB)
    let variants: [(&str, TextureFormatChoice, Supercompression, Option<f32>); 5] = [
        (
            "rgba8, no zstd",
            TextureFormatChoice::Rgba8,
            Supercompression::None,
            None,
        ),
        (
            "rgba8",
            TextureFormatChoice::Rgba8,
            Supercompression::Zstd,
            None,
        ),
        (
            "auto (the default)",
            TextureFormatChoice::Auto,
            Supercompression::Zstd,
            None,
        ),
        (
            "auto, no zstd",
            TextureFormatChoice::Auto,
            Supercompression::None,
            None,
        ),
        (
            "auto, designs in BC7 too (max_design_error_lsb = 4)",
            TextureFormatChoice::Auto,
            Supercompression::Zstd,
            Some(4.0),
        ),
    ];
    for (name, format, supercompression, design_lsb) in variants {
        let mut manifest = loaded.clone();
        manifest.textures.max_design_error_lsb = design_lsb;
        let mut settings = cook::Settings::new(&manifest);
        settings.textures.format = Some(format);
        settings.textures.supercompression = Some(supercompression);
        let mut times = Vec::new();
        let mut cooked = None;
        for _ in 0..cfg.runs.max(1) {
            let start = Instant::now();
            let c = cook::cook(&manifest, &settings)?;
            let bytes = pack::encode(c.toc, &c.data)?;
            times.push(start.elapsed().as_secs_f64() * 1e3);
            cooked = Some(bytes);
        }
        let bytes = cooked.expect("at least one run");
        let pack = pack::Pack::from_bytes(scene, &bytes)?;
        let scene_gpu = render::Scene::from_pack(&gpu, &pack)?;
        let mut flip = Vec::new();
        for (i, camera) in pack.toc().cameras.iter().enumerate() {
            let view = render::view::View::from_camera(camera, w as f32 / h as f32);
            let mut r =
                render::Renderer::headless(&gpu, &scene_gpu, w, h, render::Settings::default())?;
            r.render(&gpu, &scene_gpu, &view, render::TimingMethod::None)?;
            let rgb: Vec<u8> = r
                .read_output(&gpu)?
                .pixels()
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect();
            let f = match reference.get(i) {
                Some(base) => crate::common::flip(base, &rgb, w, h).0,
                None => {
                    let brighter: Vec<u8> = rgb.iter().map(|v| v.saturating_add(1)).collect();
                    one_step.push((
                        camera.name.clone(),
                        crate::common::flip(&rgb, &brighter, w, h).0,
                    ));
                    reference.push(rgb);
                    0.0
                }
            };
            flip.push((camera.name.clone(), f));
        }
        let gpu_texture_bytes = pack
            .toc()
            .textures
            .iter()
            .map(|t| (0..t.mips.len()).map(|k| t.level_bytes(k)).sum::<u64>())
            .sum();
        let row = ScenePack {
            format: name.into(),
            bytes: bytes.len() as u64,
            gpu_texture_bytes,
            cook_ms: median(&mut times),
            flip,
        };
        progress(&format!(
            "compression, scene {name}: {} bytes, cook {:.0} ms, FLIP {:?}",
            row.bytes, row.cook_ms, row.flip
        ));
        out.push(row);
    }
    Ok((out, one_step))
}
