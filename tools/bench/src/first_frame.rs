//! Time to the viewer's first frame and to full quality, whole headless processes on the
//! default scene's pack: as it draws by default (a half-size preview first on a CPU
//! rasterizer) against `--no-preview` (the whole frame first), runs interleaved; and the
//! large generated mesh's pack, for the viewer's peak memory on a mesh of a million triangles.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::common::median;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct FirstFrameRow {
    /// `default`, `--no-preview`, the RGBA8 pack without zstd in the default mode, or the
    /// generated grid's pack in the default mode.
    pub mode: String,
    pub runs: usize,
    pub first_frame_ms: f64,
    pub full_quality_ms: f64,
    /// The viewer's own `-v` split of its first frame, from the median run's output.
    pub split: String,
    /// Peak resident memory of the viewer process, MB (median), and the pack's size.
    #[serde(default)]
    pub peak_rss_mb: Option<f64>,
    #[serde(default)]
    pub pack_mb: Option<f64>,
}

pub struct FirstFrameConfig {
    pub scene: PathBuf,
    pub runs: usize,
    pub size: (u32, u32),
    pub scratch: PathBuf,
    /// The generated height field's side, as the meshes sweep's (`grid` x `grid` quads).
    pub grid: usize,
}

/// A binary built beside this one (`cargo build --release -p viewer`), if any.
fn sibling(name: &str) -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let p = exe.with_file_name(format!("{name}{}", std::env::consts::EXE_SUFFIX));
    p.is_file().then_some(p)
}

fn number_after(text: &str, prefix: &str) -> Option<f64> {
    let rest = &text[text.find(prefix)? + prefix.len()..];
    rest.split_whitespace().next()?.parse().ok()
}

/// Empty when the viewer is not built beside the bench.
pub fn sweep(cfg: &FirstFrameConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<FirstFrameRow>> {
    let Some(viewer) = sibling("viewer") else {
        progress("first frame: no viewer built beside the bench, skipped");
        return Ok(Vec::new());
    };
    std::fs::create_dir_all(&cfg.scratch)?;
    let manifest = cook::Manifest::open(&cfg.scene)
        .with_context(|| format!("loading {}", cfg.scene.display()))?;
    // The default pack against the one the texture-compression issue started from (RGBA8, no
    // zstd), so "time to full quality does not grow" is read off one interleaved run.
    let mut rgba8 = cook::Settings::new(&manifest);
    rgba8.textures.format = Some(cook::manifest::TextureFormatChoice::Rgba8);
    rgba8.textures.supercompression = Some(pack::Supercompression::None);
    let mut packs = Vec::new();
    for (file, settings) in [
        ("first-frame.pack", cook::Settings::new(&manifest)),
        ("first-frame-rgba8.pack", rgba8),
    ] {
        let cooked = cook::cook(&manifest, &settings)
            .with_context(|| format!("cooking {}", cfg.scene.display()))?;
        let bytes = pack::encode(cooked.toc, &cooked.data).context("encoding the pack")?;
        let path = cfg.scratch.join(file);
        std::fs::write(&path, &bytes).with_context(|| format!("writing {}", path.display()))?;
        packs.push((path, bytes.len() as f64 / 1e6));
    }
    // A bare mesh cooked as `cooker cook` cooks one: a guessed sun and cameras.
    let grid_obj = cfg
        .scratch
        .join(format!("first-frame-grid-{}.obj", cfg.grid));
    std::fs::write(&grid_obj, cook::testing::height_field_obj(cfg.grid))
        .with_context(|| format!("writing {}", grid_obj.display()))?;
    let grid_manifest = cook::Manifest::open(&grid_obj)
        .with_context(|| format!("loading {}", grid_obj.display()))?;
    let cooked = cook::cook(&grid_manifest, &cook::Settings::new(&grid_manifest))
        .with_context(|| format!("cooking {}", grid_obj.display()))?;
    let _ = std::fs::remove_file(&grid_obj);
    let bytes = pack::encode(cooked.toc, &cooked.data).context("encoding the pack")?;
    let grid_pack = cfg.scratch.join("first-frame-grid.pack");
    std::fs::write(&grid_pack, &bytes)
        .with_context(|| format!("writing {}", grid_pack.display()))?;
    packs.push((grid_pack, bytes.len() as f64 / 1e6));
    let grid_mode = format!(
        "{}-triangle generated grid's pack (default mode)",
        2 * cfg.grid * cfg.grid
    );
    let modes: [(&str, usize, &[&str]); 4] = [
        ("default", 0, &[]),
        ("--no-preview", 0, &["--no-preview"]),
        ("RGBA8 pack, no zstd (default mode)", 1, &[]),
        (&grid_mode, 2, &[]),
    ];
    let mut runs: Vec<Vec<(f64, f64, String)>> = vec![Vec::new(); modes.len()];
    let mut peaks: Vec<Vec<f64>> = vec![Vec::new(); modes.len()];
    for i in 0..cfg.runs.max(1) {
        for (m, (name, pack, extra)) in modes.iter().enumerate() {
            progress(&format!("first frame: {name}, run {}", i + 1));
            let (out, _, peak) = crate::common::output_with_peak_rss(
                Command::new(&viewer)
                    .arg(&packs[*pack].0)
                    .args(["--headless", "--camera", "nave", "-v", "--size"])
                    .arg(format!("{}x{}", cfg.size.0, cfg.size.1))
                    .arg("--out")
                    .arg(cfg.scratch.join("first-frame-images"))
                    .args(*extra),
            )
            .context("running the viewer")?;
            peaks[m].push(peak as f64 / 1e6);
            let text = String::from_utf8_lossy(&out.stdout).into_owned();
            anyhow::ensure!(
                out.status.success(),
                "viewer failed: {}",
                String::from_utf8_lossy(&out.stderr)
            );
            let first = number_after(&text, "first frame after ").context("no first frame time")?;
            let full =
                number_after(&text, "full quality after ").context("no full quality time")?;
            let line = |prefix: &str| {
                text.lines()
                    .find(|l| l.starts_with(prefix))
                    .unwrap_or_default()
                    .trim_start_matches(prefix)
                    .to_string()
            };
            let split = format!(
                "before it: instance, adapter and device {}; then {}; to full quality: {}",
                line("instance, adapter and device: "),
                line("first frame: "),
                line("full quality: ")
            );
            runs[m].push((first, full, split));
        }
    }
    Ok(modes
        .iter()
        .zip(runs.into_iter().zip(&mut peaks))
        .map(|((name, pack, _), (mut r, peak))| {
            let mut firsts: Vec<f64> = r.iter().map(|x| x.0).collect();
            let mut fulls: Vec<f64> = r.iter().map(|x| x.1).collect();
            r.sort_by(|a, b| a.0.total_cmp(&b.0));
            FirstFrameRow {
                mode: name.to_string(),
                runs: r.len(),
                first_frame_ms: median(&mut firsts),
                full_quality_ms: median(&mut fulls),
                split: r[r.len() / 2].2.clone(),
                peak_rss_mb: Some(median(peak)),
                pack_mb: Some(packs[*pack].1),
            }
        })
        .collect())
}

/// The default scene beside the checkout.
pub fn default_scene() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src/scene.toml");
    p.is_file().then_some(p)
}
