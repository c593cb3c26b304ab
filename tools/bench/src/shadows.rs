//! Shadow sweep: the lit pass with and without occlusion against the CPU ray-traced reference
//! (`render::reference`, rules in docs/reference-tracer.md), camera by camera on the default
//! scene and the pillar hall (`tests/data/pillar-hall`), and the cost of the shadow pass and
//! of the lit pass with shadows at several map sizes.
//!
//! The GPU image is drawn at 4× the size and averaged 4 × 4 (16 samples per pixel, as the
//! reference takes), both are tone mapped as the composite does (exposure 1, ACES, sRGB), and
//! compared with FLIP. The reference images and the GPU's are written next to the report.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result};
use render::reference::{Reference, ReferenceSettings, tone_mapped};
use render::{Gpu, PassId, Renderer, Scene, Settings, ShadowSettings, TargetId, TimingMethod};
use serde::{Deserialize, Serialize};

use crate::common::median;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShadowCameraRow {
    pub scene: String,
    pub camera: String,
    pub flip_mean: f64,
    pub flip_p99: f64,
    /// The same without occlusion (plain projective texturing).
    pub flip_mean_unoccluded: f64,
    /// Image files, relative to the report.
    pub reference_image: String,
    pub gpu_image: String,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShadowTimingRow {
    pub scene: String,
    pub camera: String,
    pub width: u32,
    pub height: u32,
    /// Side of the sun's map (0: occlusion off).
    pub map_size: u32,
    pub shadow_ms: Option<f64>,
    pub lit_ms: Option<f64>,
    pub frame_ms: Option<f64>,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ShadowReport {
    pub device: String,
    pub timing: String,
    pub width: u32,
    pub height: u32,
    pub pixel_samples: u32,
    pub light_samples: u32,
    /// Per window of the default scene: whether it got a map and why.
    pub default_windows: Vec<String>,
    pub cameras: Vec<ShadowCameraRow>,
    pub timings: Vec<ShadowTimingRow>,
}

pub struct ShadowConfig {
    pub width: u32,
    pub height: u32,
    pub runs: usize,
    /// (size, label) of the frames timed; the first is also the compared size.
    pub timing_sizes: Vec<(u32, u32)>,
    pub map_sizes: Vec<u32>,
    pub scenes: Vec<(String, PathBuf)>,
}

/// The pillar hall's manifest in the source tree.
pub fn pillar_hall() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/pillar-hall/hall.toml")
}

fn cook_pack(manifest: &Path) -> Result<Vec<u8>> {
    let m = cook::Manifest::load(manifest)
        .with_context(|| format!("loading {}", manifest.display()))?;
    let out = cook::cook(&m, &cook::Settings::new(&m))
        .with_context(|| format!("cooking {}", manifest.display()))?;
    pack::encode(out.toc, &out.data).context("encoding the cooked pack")
}

/// The lit pass at 4× the size, averaged 4 × 4.
fn lit_16(
    gpu: &Gpu,
    scene: &Scene,
    camera: &pack::Camera,
    (w, h): (u32, u32),
    settings: Settings,
) -> Result<(Vec<[f32; 4]>, render::View)> {
    let mut r = Renderer::headless(gpu, scene, 4 * w, 4 * h, settings)?;
    let view = r.view_for(camera);
    r.render(gpu, scene, &view, TimingMethod::None)?;
    let (_, _, px) = r.read_target(gpu, TargetId::Lit)?;
    let mut out = vec![[0.0f32; 4]; (w * h) as usize];
    for y in 0..h {
        for x in 0..w {
            let o = &mut out[(y * w + x) as usize];
            for k in 0..16 {
                let p = px[((4 * y + k / 4) * 4 * w + 4 * x + k % 4) as usize];
                for c in 0..4 {
                    o[c] += p[c] / 16.0;
                }
            }
        }
    }
    Ok((out, view))
}

pub fn sweep(
    cfg: &ShadowConfig,
    out_dir: &Path,
    progress: &mut dyn FnMut(&str),
) -> Result<ShadowReport> {
    let gpu = Gpu::headless()?;
    progress(&format!("shadows on {}", gpu.describe()));
    let images = out_dir.join("shadows");
    std::fs::create_dir_all(&images).with_context(|| format!("creating {}", images.display()))?;
    let rs = ReferenceSettings::default();
    let (w, h) = (cfg.width, cfg.height);
    let mut cameras = Vec::new();
    let mut timings = Vec::new();
    let mut default_windows = Vec::new();
    let mut timing_method = String::from("not timed");
    for (name, manifest) in &cfg.scenes {
        let bytes = cook_pack(manifest)?;
        let pack = pack::Pack::from_bytes(manifest, &bytes).context("reading the cooked pack")?;
        let scene = Scene::from_pack(&gpu, &pack)?;
        if default_windows.is_empty() {
            let toc = scene.toc();
            default_windows = toc
                .windows
                .iter()
                .zip(scene.window_shadows())
                .map(|(w, d)| {
                    let m = toc.materials.get(w.material as usize);
                    format!("{}: {}", m.map_or("?", |m| m.name.as_str()), d.describe())
                })
                .collect();
        }
        let reference = Reference::from_pack(&pack);
        for camera in &scene.toc().cameras {
            progress(&format!("shadows: {name} camera {}", camera.name));
            let (on, view) = lit_16(&gpu, &scene, camera, (w, h), Settings::default())?;
            let mut off_settings = Settings::default();
            off_settings.shadows.enabled = false;
            let (off, _) = lit_16(&gpu, &scene, camera, (w, h), off_settings)?;
            let traced = reference.render_lit(&view, w, h, &rs);
            let (r_img, on_img, off_img) = (
                tone_mapped(w, h, &traced),
                tone_mapped(w, h, &on),
                tone_mapped(w, h, &off),
            );
            let (mean, p99) = crate::common::flip(&r_img, &on_img, w, h);
            let (mean_off, _) = crate::common::flip(&r_img, &off_img, w, h);
            let stem = format!("{name}-{}", camera.name).replace(' ', "-");
            let reference_image = format!("shadows/{stem}-reference.png");
            let gpu_image = format!("shadows/{stem}-gpu.png");
            r_img
                .save(out_dir.join(&reference_image))
                .context("writing an image")?;
            on_img
                .save(out_dir.join(&gpu_image))
                .context("writing an image")?;
            cameras.push(ShadowCameraRow {
                scene: name.clone(),
                camera: camera.name.clone(),
                flip_mean: mean,
                flip_p99: p99,
                flip_mean_unoccluded: mean_off,
                reference_image,
                gpu_image,
            });
        }
        // Timings on the first camera: the shadow pass at each map size, and the lit pass with
        // and without occlusion.
        let Some(camera) = scene.toc().cameras.first() else {
            continue;
        };
        for &(tw, th) in &cfg.timing_sizes {
            for &map in std::iter::once(&0).chain(&cfg.map_sizes) {
                progress(&format!("shadows: timing {name} {tw}x{th}, map {map}"));
                let settings = Settings {
                    shadows: ShadowSettings {
                        enabled: map > 0,
                        map_size: map.max(16),
                        ..Default::default()
                    },
                    ..Default::default()
                };
                let mut r = Renderer::headless(&gpu, &scene, tw, th, settings)?;
                let view = r.view_for(camera);
                r.render(&gpu, &scene, &view, TimingMethod::None)?;
                let (mut shadow, mut lit, mut frame) = (Vec::new(), Vec::new(), Vec::new());
                for _ in 0..cfg.runs.max(1) {
                    r.invalidate_shadow_maps();
                    let report = r.render(&gpu, &scene, &view, TimingMethod::GpuTimestamps)?;
                    timing_method = format!("{:?}", report.method);
                    let ms = |p: PassId| {
                        report
                            .passes
                            .iter()
                            .find(|x| x.pass == p)
                            .and_then(|x| x.ms)
                    };
                    shadow.extend(ms(PassId::Shadows));
                    lit.extend(ms(PassId::Lit));
                    frame.push(report.passes.iter().filter_map(|p| p.ms).sum::<f64>());
                }
                timings.push(ShadowTimingRow {
                    scene: name.clone(),
                    camera: camera.name.clone(),
                    width: tw,
                    height: th,
                    map_size: map,
                    shadow_ms: (!shadow.is_empty()).then(|| median(&mut shadow)),
                    lit_ms: (!lit.is_empty()).then(|| median(&mut lit)),
                    frame_ms: (!frame.is_empty()).then(|| median(&mut frame)),
                });
            }
        }
    }
    Ok(ShadowReport {
        device: gpu.describe(),
        timing: timing_method,
        width: w,
        height: h,
        pixel_samples: rs.pixel_samples * rs.pixel_samples,
        light_samples: rs.light_samples,
        default_windows,
        cameras,
        timings,
    })
}
