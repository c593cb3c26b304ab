//! God-ray sweep: sample count × resolution scale × jitter on the default scene, frame time from
//! GPU timestamps, error of the final image against a 4096-sample reference of the same view.
//!
//! The renderer caps its sample count at 1024, so the reference is built on the CPU: the
//! renderer's own CPU march (`render::view::god_rays_reference`) at 4096 samples over the GPU's
//! window mask, composited onto the GPU's lit and background targets exactly as the composite
//! shader does (refraction is off for this sweep, so that composite is a few lines). The same
//! CPU composite fed the GPU's own god-ray target must reproduce the GPU's output; the report
//! states how closely it does (`composite_check_lsb`).

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use glam::Vec3;
use render::view::{
    GodRaySettings, LightGeometry, View, god_ray_fade, god_ray_uniforms, god_rays_reference,
};
use render::{Gpu, Renderer, Scene, Settings, TargetId, TimingMethod};
use serde::{Deserialize, Serialize};

use crate::common::median;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GodRayRow {
    pub samples: u32,
    pub resolution_scale: f32,
    pub jitter: bool,
    /// Median GPU time of the god-ray pass (timestamps; the CPU wall clock per pass where the
    /// device has none, see `GodRayReport::timing`).
    pub god_ray_ms: Option<f64>,
    /// Median sum of all passes.
    pub frame_ms: Option<f64>,
    pub flip_mean: f64,
    pub flip_p99: f64,
    /// RMSE of the final image in linear light (display-referred, 0..1).
    pub rmse_linear: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct GodRayReport {
    pub device: String,
    pub timing: String,
    pub width: u32,
    pub height: u32,
    pub camera: String,
    pub god_ray_fade: f32,
    pub reference_samples: u32,
    /// Max difference (LSB) between the GPU's output and the CPU composite of the GPU's own
    /// targets: how far the reference's composite can be trusted.
    pub composite_check_lsb: f64,
    pub rows: Vec<GodRayRow>,
}

pub struct GodRayConfig {
    pub width: u32,
    pub height: u32,
    pub samples: Vec<u32>,
    pub scales: Vec<f32>,
    pub runs: usize,
    pub scene: PathBuf,
}

pub const REFERENCE_SAMPLES: u32 = 4096;

/// The default scene's manifest in the source tree.
pub fn default_scene() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src/scene.toml")
}

fn srgb_encode(c: f32) -> f32 {
    if c <= 0.003_130_8 {
        c * 12.92
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    }
}

fn srgb_decode(s: f32) -> f32 {
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// Narkowicz's ACES fit, as in `shaders/composite.wgsl`.
fn aces(x: Vec3) -> Vec3 {
    let (a, b, c, d, e) = (2.51, 0.03, 2.43, 0.59, 0.14);
    ((x * (a * x + b)) / (x * (c * x + d) + e)).clamp(Vec3::ZERO, Vec3::ONE)
}

/// The composite without refraction: lit scene, plus the background through the glass where
/// the window mask covers, plus the god rays; tone mapped. Linear display values.
fn composite(
    lit: &[[f32; 4]],
    background: &[[f32; 4]],
    mask: &[[f32; 4]],
    rays: &[Vec3],
    exposure: f32,
) -> Vec<Vec3> {
    lit.iter()
        .zip(background)
        .zip(mask)
        .zip(rays)
        .map(|(((l, b), m), r)| {
            let mut c = Vec3::new(l[0], l[1], l[2]);
            if m[3] > 0.5 {
                c += Vec3::new(b[0], b[1], b[2]) * Vec3::new(m[0], m[1], m[2]);
            }
            aces((c + *r).max(Vec3::ZERO) * exposure)
        })
        .collect()
}

fn to_rgb8(px: &[Vec3]) -> Vec<u8> {
    px.iter()
        .flat_map(|c| {
            c.to_array()
                .map(|v| (srgb_encode(v) * 255.0 + 0.5).clamp(0.0, 255.0) as u8)
        })
        .collect()
}

fn rgb8_of(img: &image::RgbaImage) -> Vec<u8> {
    img.pixels().flat_map(|p| [p[0], p[1], p[2]]).collect()
}

/// RMSE in linear light of 8-bit sRGB output against unrounded linear values.
fn rmse_linear(test: &[u8], reference: &[Vec3]) -> f64 {
    let mut sq = 0.0f64;
    for (t, r) in test.chunks_exact(3).zip(reference) {
        for c in 0..3 {
            let d = srgb_decode(t[c] as f32 / 255.0) as f64 - r[c] as f64;
            sq += d * d;
        }
    }
    (sq / (reference.len().max(1) * 3) as f64).sqrt()
}

/// Cooks the scene and uploads it.
pub fn load_scene(gpu: &Gpu, manifest: &Path) -> Result<Scene> {
    let m = cook::Manifest::load(manifest)
        .with_context(|| format!("loading {}", manifest.display()))?;
    // RGBA8, as when the committed god-ray table was measured: this sweep is about god rays.
    let mut settings = cook::Settings::new(&m);
    settings.textures.format = Some(cook::manifest::TextureFormatChoice::Rgba8);
    let out =
        cook::cook(&m, &settings).with_context(|| format!("cooking {}", manifest.display()))?;
    let bytes = pack::encode(out.toc, &out.data).context("encoding the cooked pack")?;
    let pack = pack::Pack::from_bytes(manifest, &bytes).context("reading the cooked pack")?;
    Ok(Scene::from_pack(gpu, &pack)?)
}

pub fn sweep(cfg: &GodRayConfig, progress: &mut dyn FnMut(&str)) -> Result<GodRayReport> {
    let gpu = Gpu::headless()?;
    progress(&format!("god rays on {}", gpu.describe()));
    let scene = load_scene(&gpu, &cfg.scene)?;
    let toc = scene.toc().clone();
    let Some(light) = toc.light.as_ref() else {
        bail!(
            "{}: the scene has no light, so no god rays",
            cfg.scene.display()
        );
    };
    let geometry = LightGeometry::from_light(light);
    let (w, h) = (cfg.width, cfg.height);
    let aspect = w as f32 / h as f32;
    // The camera that sees the light most directly: where god rays matter.
    let (camera, fade) = toc
        .cameras
        .iter()
        .map(|c| (c, god_ray_fade(&View::from_camera(c, aspect), &geometry)))
        .max_by(|a, b| a.1.total_cmp(&b.1))
        .context("the scene has no camera")?;
    if fade.is_nan() || fade <= 0.0 {
        bail!("no camera of {} sees the light", cfg.scene.display());
    }
    let view = View::from_camera(camera, aspect);
    let base = Settings {
        // Refraction off: the reference composite below is then exact without the shader's
        // refraction lookup. The god rays are what this sweep changes.
        refraction_strength: 0.0,
        ..Settings::default()
    };

    // The reference: GPU targets at full resolution, CPU march at 4096 samples.
    let max_gpu = GodRaySettings {
        samples: render::MAX_GOD_RAY_SAMPLES,
        jitter: false,
        resolution_scale: 1.0,
        ..base.god_rays
    };
    let mut r = Renderer::headless(
        &gpu,
        &scene,
        w,
        h,
        Settings {
            god_rays: max_gpu,
            ..base
        },
    )?;
    r.render(&gpu, &scene, &view, TimingMethod::None)?;
    let (_, _, lit) = r.read_target(&gpu, TargetId::Lit)?;
    let (_, _, background) = r.read_target(&gpu, TargetId::Background)?;
    let (_, _, mask) = r.read_target(&gpu, TargetId::WindowMask)?;
    let (rw, rh, gpu_rays) = r.read_target(&gpu, TargetId::GodRays)?;
    anyhow::ensure!(
        (rw, rh) == (w, h),
        "god-ray target is {rw}x{rh}, expected {w}x{h}"
    );
    let gpu_out = rgb8_of(&r.read_output(&gpu)?);
    let gpu_rays: Vec<Vec3> = gpu_rays
        .iter()
        .map(|p| Vec3::new(p[0], p[1], p[2]))
        .collect();
    let check = to_rgb8(&composite(
        &lit,
        &background,
        &mask,
        &gpu_rays,
        base.exposure,
    ));
    let composite_check_lsb = check
        .iter()
        .zip(&gpu_out)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap_or(0) as f64;

    let colour = Vec3::from(light.colour) * light.intensity * render::god_ray_falloff(&toc, light);
    let (mut u, _) = god_ray_uniforms(&max_gpu, &view, &geometry, colour, 0);
    u.samples = REFERENCE_SAMPLES;
    let ref_rays = god_rays_reference(&u, &mask, w as usize, h as usize, w as usize, h as usize);
    let reference = composite(&lit, &background, &mask, &ref_rays, base.exposure);
    let reference8 = to_rgb8(&reference);
    progress(&format!(
        "god rays: camera {:?}, fade {fade:.2}, reference at {REFERENCE_SAMPLES} samples; composite check {composite_check_lsb} LSB",
        camera.name
    ));

    let mut rows = Vec::new();
    let mut timing = String::from("none");
    for &scale in &cfg.scales {
        for jitter in [false, true] {
            for &samples in &cfg.samples {
                let settings = Settings {
                    god_rays: GodRaySettings {
                        samples,
                        resolution_scale: scale,
                        jitter,
                        ..base.god_rays
                    },
                    ..base
                };
                let mut r = Renderer::headless(&gpu, &scene, w, h, settings)?;
                // One untimed frame first: pipeline and allocation costs are not the pass's.
                r.render(&gpu, &scene, &view, TimingMethod::None)?;
                let (mut rays_ms, mut frame_ms) = (Vec::new(), Vec::new());
                for _ in 0..cfg.runs.max(1) {
                    let report = r.render(&gpu, &scene, &view, TimingMethod::GpuTimestamps)?;
                    timing = format!("{:?}", report.method);
                    let rays = report
                        .passes
                        .iter()
                        .find(|p| p.pass == render::PassId::GodRays)
                        .and_then(|p| p.ms);
                    if let Some(ms) = rays {
                        rays_ms.push(ms);
                    }
                    frame_ms.push(report.passes.iter().filter_map(|p| p.ms).sum::<f64>());
                }
                let out = rgb8_of(&r.read_output(&gpu)?);
                let (flip_mean, flip_p99) = crate::common::flip(&reference8, &out, w, h);
                let row = GodRayRow {
                    samples,
                    resolution_scale: scale,
                    jitter,
                    god_ray_ms: (!rays_ms.is_empty()).then(|| median(&mut rays_ms)),
                    frame_ms: (timing != "None").then(|| median(&mut frame_ms)),
                    flip_mean,
                    flip_p99,
                    rmse_linear: rmse_linear(&out, &reference),
                };
                progress(&format!(
                    "god rays {samples} samples, scale {scale}, jitter {jitter}: {:?} ms, FLIP mean {flip_mean:.4}",
                    row.god_ray_ms
                ));
                rows.push(row);
            }
        }
    }
    Ok(GodRayReport {
        device: gpu.describe(),
        timing,
        width: w,
        height: h,
        camera: camera.name.clone(),
        god_ray_fade: fade,
        reference_samples: REFERENCE_SAMPLES,
        composite_check_lsb,
        rows,
    })
}
