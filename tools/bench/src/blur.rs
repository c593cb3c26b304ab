//! Blur sweep: our methods against the f64 linear-light reference (the texture issue's error
//! unit), beside anchors that filter the stored gamma-encoded bytes, measured against an f64
//! blur of those bytes (a reference of their own kind, as the guide's anchor figures are).
//!
//! The anchors clamp at the edges where ours uses a zero border, so their error is measured only
//! where no kernel (theirs or the reference's, 5σ) reaches an edge.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result, bail};
use serde::{Deserialize, Serialize};
use texture::blur::{
    BlurMethod, blur_srgb8_into, error_lsb, kernel_radius, reference_blur,
    srgb8_to_premultiplied_f64,
};

use crate::common::median_ms;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct BlurRow {
    pub sigma: f32,
    /// `ours: direct`, `libblur exact u8`, …
    pub method: String,
    /// Whether the cooker can use it (and so it goes into the error table).
    pub ours: bool,
    /// `linear` (linear light, premultiplied, zero border: the texture issue's definition) or
    /// `gamma` (the stored bytes filtered directly, interior only).
    pub reference: String,
    pub time_ms: Option<f64>,
    pub runs: usize,
    pub max_lsb: Option<f64>,
    pub rms_lsb: Option<f64>,
    pub note: String,
}

impl BlurRow {
    /// An anchor that was not measured at `sigma`, and why.
    fn not_run(sigma: f32, method: &str, why: String) -> Self {
        Self {
            sigma,
            method: method.into(),
            ours: false,
            reference: "gamma".into(),
            time_ms: None,
            runs: 0,
            max_lsb: None,
            rms_lsb: None,
            note: format!("not run: {why}"),
        }
    }
}

pub struct BlurConfig {
    pub size: usize,
    pub sigmas: Vec<f32>,
    pub runs: usize,
    /// Command-line tools (`vips`, `convert`); skipped for larger σ once a call takes longer
    /// than this many seconds.
    pub external_limit_s: f64,
    /// Side of the square region the error is measured over (the whole image when larger).
    pub region: usize,
    pub scratch: PathBuf,
}

/// Our methods worth measuring at σ on an `n x n` image: each only where it really runs as
/// itself (the others fall back to an exact method there and would repeat its row).
fn our_methods(sigma: f32, n: usize) -> Vec<BlurMethod> {
    BlurMethod::ALL
        .into_iter()
        .filter(|&m| m != BlurMethod::Auto && m.resolve_sized(sigma, n as u32, n as u32) == m)
        .collect()
}

/// Error in LSB of 8-bit `ours` against `reference` (values on the 0..255 scale), over texels at
/// least `margin` from every edge. `None` when no texel is that far in.
fn interior_error(
    ours: &[u8],
    reference: &[[f64; 4]],
    w: usize,
    h: usize,
    margin: usize,
) -> Option<(f64, f64)> {
    if 2 * margin >= w || 2 * margin >= h {
        return None;
    }
    let (mut max, mut sq, mut n) = (0.0f64, 0.0f64, 0usize);
    for y in margin..h - margin {
        for x in margin..w - margin {
            let i = y * w + x;
            for c in 0..4 {
                let e = (ours[i * 4 + c] as f64 - reference[i][c]).abs();
                max = max.max(e);
                sq += e * e;
                n += 1;
            }
        }
    }
    Some((max, (sq / n as f64).sqrt()))
}

/// A square region of the image where the error is measured.
#[derive(Clone, Copy, Debug)]
struct Region {
    x0: usize,
    y0: usize,
    size: usize,
}

/// The f64 reference blur of `region` only: the reference over the region plus the kernel
/// radius around it (clipped to the image, where the zero border then applies as it does for
/// the whole image), so the result equals the whole-image reference there at a fraction of its
/// cost (the whole 4096² f64 reference takes minutes at σ = 64).
fn region_reference(src: &[[f64; 4]], n: usize, region: Region, sigma: f64) -> Vec<[f64; 4]> {
    let r = kernel_radius(sigma);
    let (cx0, cy0) = (region.x0.saturating_sub(r), region.y0.saturating_sub(r));
    let cx1 = (region.x0 + region.size + r).min(n);
    let cy1 = (region.y0 + region.size + r).min(n);
    let cw = cx1 - cx0;
    let crop: Vec<[f64; 4]> = (cy0..cy1)
        .flat_map(|y| src[y * n + cx0..y * n + cx1].iter().copied())
        .collect();
    let full = reference_blur(&crop, cw, cy1 - cy0, sigma);
    let (ox, oy) = (region.x0 - cx0, region.y0 - cy0);
    (0..region.size)
        .flat_map(|y| {
            full[(oy + y) * cw + ox..(oy + y) * cw + ox + region.size]
                .iter()
                .copied()
        })
        .collect()
}

/// The region's texels of an RGBA8 image.
fn region_bytes(img: &[u8], n: usize, region: Region) -> Vec<u8> {
    (region.y0..region.y0 + region.size)
        .flat_map(|y| {
            img[(y * n + region.x0) * 4..(y * n + region.x0 + region.size) * 4]
                .iter()
                .copied()
        })
        .collect()
}

/// libblur into `dst` (as long as `src`), which the caller reuses from run to run as ours
/// does, so neither time includes the kernel faulting in and zeroing a fresh 64 MiB result.
fn libblur(
    src: &[u8],
    side: u32,
    sigma: f32,
    mode: libblur::ConvolutionMode,
    dst: &mut [u8],
) -> Result<()> {
    use libblur::{
        BlurImage, BlurImageMut, EdgeMode, EdgeMode2D, FastBlurChannels, GaussianBlurParams,
        ThreadingPolicy,
    };
    let s = BlurImage::borrow(src, side, side, FastBlurChannels::Channels4);
    let mut d = BlurImageMut::borrow(dst, side, side, FastBlurChannels::Channels4);
    // libblur's own kernel-size rule of thumb: about 8σ + 1 taps, odd.
    let ksize = ((sigma * 8.0).round() as u32) | 1;
    libblur::gaussian_blur(
        &s,
        &mut d,
        GaussianBlurParams::new(ksize.max(3), sigma as f64),
        EdgeMode2D::new(EdgeMode::Clamp),
        ThreadingPolicy::Adaptive,
        mode,
    )
    .map_err(|e| anyhow::anyhow!("libblur: {e:?}"))
}

/// libblur's own linear-light route, like for like with ours: sRGB bytes to linear u16, its
/// exact Gaussian on u16, back to sRGB bytes (straight alpha; the sweep's image is opaque).
fn libblur_linear(src: &[u8], side: u32, sigma: f32) -> Result<Vec<u8>> {
    use libblur::{
        BlurImage, BlurImageMut, ConvolutionMode, EdgeMode, EdgeMode2D, FastBlurChannels,
        GaussianBlurParams, ThreadingPolicy, TransferFunction,
    };
    let err = |e: libblur::BlurError| anyhow::anyhow!("libblur: {e:?}");
    let s = BlurImage::borrow(src, side, side, FastBlurChannels::Channels4);
    let linear = s.linearize(TransferFunction::Srgb, true).map_err(err)?;
    let mut blurred = BlurImageMut::<u16>::alloc(side, side, FastBlurChannels::Channels4);
    let ksize = ((sigma * 8.0).round() as u32) | 1;
    libblur::gaussian_blur_u16(
        &linear,
        &mut blurred,
        GaussianBlurParams::new(ksize.max(3), sigma as f64),
        EdgeMode2D::new(EdgeMode::Clamp),
        ThreadingPolicy::Adaptive,
        ConvolutionMode::Exact,
    )
    .map_err(err)?;
    let out = blurred.gamma8(TransferFunction::Srgb, true).map_err(err)?;
    Ok(out.data.borrow().to_vec())
}

/// An external blur command, or `None` when it is not installed.
struct External {
    name: &'static str,
    program: &'static str,
    args: fn(&Path, &Path, f32) -> Vec<String>,
}

const EXTERNALS: [External; 2] = [
    External {
        name: "vips gaussblur (default)",
        program: "vips",
        args: |i, o, s| {
            vec![
                "gaussblur".into(),
                i.display().to_string(),
                o.display().to_string(),
                format!("{s}"),
            ]
        },
    },
    External {
        name: "ImageMagick convert -gaussian-blur",
        program: "convert",
        args: |i, o, s| {
            vec![
                i.display().to_string(),
                "-gaussian-blur".into(),
                format!("0x{s}"),
                "-depth".into(),
                "8".into(),
                format!("PNG32:{}", o.display()),
            ]
        },
    },
];

fn installed(program: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|paths| {
        std::env::split_paths(&paths).any(|d| {
            let p = d.join(program);
            p.is_file()
        })
    })
}

fn run_external(e: &External, input: &Path, output: &Path, sigma: f32) -> Result<()> {
    let status = Command::new(e.program)
        .args((e.args)(input, output, sigma))
        .output()
        .with_context(|| format!("running {}", e.program))?;
    if !status.status.success() {
        bail!(
            "{} failed: {}",
            e.program,
            String::from_utf8_lossy(&status.stderr).trim()
        );
    }
    Ok(())
}

/// Runs the sweep. `progress` gets one line per measurement.
pub fn sweep(cfg: &BlurConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<BlurRow>> {
    let n = cfg.size;
    let side = n as u32;
    // Opaque: the anchors filter straight alpha, and ImageMagick weights colour by alpha, so
    // with translucent texels no single gamma-space reference would be fair to all of them.
    // (The texture crate's own tests cover translucent designs.)
    let mut src = crate::common::design(n, n, 8);
    for t in src.chunks_exact_mut(4) {
        t[3] = 255;
    }
    let linear = srgb8_to_premultiplied_f64(&src);
    let bytes_f64: Vec<[f64; 4]> = src
        .chunks_exact(4)
        .map(|b| [b[0] as f64, b[1] as f64, b[2] as f64, b[3] as f64])
        .collect();
    let input_png = cfg.scratch.join(format!("blur-input-{n}.png"));
    let externals: Vec<&External> = EXTERNALS.iter().filter(|e| installed(e.program)).collect();
    if !externals.is_empty() {
        std::fs::create_dir_all(&cfg.scratch)?;
        image::RgbaImage::from_raw(side, side, src.clone())
            .context("design buffer")?
            .save(&input_png)
            .with_context(|| format!("writing {}", input_png.display()))?;
    }
    let mut too_slow: Vec<Option<f64>> = vec![None; EXTERNALS.len()];
    let mut rows = Vec::new();
    for &sigma in &cfg.sigmas {
        // Ours: the top-left corner, so two borders and a corner are in it.
        let corner = Region {
            x0: 0,
            y0: 0,
            size: cfg.region.min(n),
        };
        let reference = region_reference(&linear, n, corner, sigma as f64);
        for method in our_methods(sigma, n) {
            let mut out = vec![0u8; src.len()];
            let (ms, done) = median_ms(cfg.runs, || {
                blur_srgb8_into(&src, side, side, sigma, method, &mut out)
            });
            done?;
            let e = error_lsb(&region_bytes(&out, n, corner), &reference);
            progress(&format!(
                "blur {n}² σ={sigma} ours {}: {ms:.1} ms, max {:.3} LSB",
                method.name(),
                e.max
            ));
            rows.push(BlurRow {
                sigma,
                method: format!("ours: {}", method.name()),
                ours: true,
                reference: "linear".into(),
                time_ms: Some(ms),
                runs: cfg.runs,
                max_lsb: Some(e.max),
                rms_lsb: Some(e.rms),
                note: if method.is_approximation() {
                    "approximation".into()
                } else {
                    String::new()
                },
            });
        }
        drop(reference);

        // Anchors: a region no kernel reaches the border from (theirs clamp, ours is zero).
        let margin = kernel_radius(sigma as f64);
        let inner = Region {
            x0: margin,
            y0: margin,
            size: cfg.region.min(n.saturating_sub(2 * margin)),
        };
        let gamma_ref =
            (inner.size > 0).then(|| region_reference(&bytes_f64, n, inner, sigma as f64));
        // The same route in linear light: measured against our reference, away from the edges
        // (libblur clamps there).
        let linear_ref =
            (inner.size > 0).then(|| region_reference(&linear, n, inner, sigma as f64));
        let (ms, out) = median_ms(cfg.runs, || libblur_linear(&src, side, sigma));
        let out = out?;
        let e = linear_ref
            .as_ref()
            .map(|r| error_lsb(&region_bytes(&out, n, inner), r));
        progress(&format!(
            "blur {n}² σ={sigma} libblur exact u16, linear light: {ms:.1} ms, max {:?} LSB",
            e.map(|e| e.max)
        ));
        rows.push(BlurRow {
            sigma,
            method: "libblur exact u16, linear light".into(),
            ours: false,
            reference: "linear".into(),
            time_ms: Some(ms),
            runs: cfg.runs,
            max_lsb: e.map(|e| e.max),
            rms_lsb: e.map(|e| e.rms),
            note: "sRGB decode to u16, blur, encode (straight alpha; the image is opaque)".into(),
        });
        drop(linear_ref);
        let mut anchor = |name: &str, ms: f64, out: &[u8], note: String| {
            let e = gamma_ref.as_ref().and_then(|g| {
                interior_error(&region_bytes(out, n, inner), g, inner.size, inner.size, 0)
            });
            progress(&format!(
                "blur {n}² σ={sigma} {name}: {ms:.1} ms, max {:?} LSB",
                e.map(|e| e.0)
            ));
            BlurRow {
                sigma,
                method: name.to_string(),
                ours: false,
                reference: "gamma".into(),
                time_ms: Some(ms),
                runs: cfg.runs,
                max_lsb: e.map(|e| e.0),
                rms_lsb: e.map(|e| e.1),
                note,
            }
        };
        for (name, mode) in [
            ("libblur exact u8", libblur::ConvolutionMode::Exact),
            (
                "libblur fixed-point u8",
                libblur::ConvolutionMode::FixedPoint,
            ),
        ] {
            let mut out = vec![0u8; src.len()];
            let (ms, done) = median_ms(cfg.runs, || libblur(&src, side, sigma, mode, &mut out));
            done?;
            rows.push(anchor(name, ms, &out, String::new()));
        }
        let img = image::RgbaImage::from_raw(side, side, src.clone()).context("design buffer")?;
        let (ms, out) = median_ms(cfg.runs, || image::imageops::blur(&img, sigma));
        rows.push(anchor(
            "image::imageops::blur",
            ms,
            out.as_raw(),
            String::new(),
        ));

        for e in &externals {
            let slot = EXTERNALS.iter().position(|x| x.name == e.name).unwrap_or(0);
            if let Some(s) = too_slow[slot] {
                rows.push(BlurRow::not_run(
                    sigma,
                    e.name,
                    format!("a smaller σ already took {s:.0} s"),
                ));
                continue;
            }
            let output = cfg
                .scratch
                .join(format!("blur-{}-{n}-{sigma}.png", e.program));
            let mut times = Vec::new();
            let mut failed = None;
            for _ in 0..cfg.runs.max(1) {
                let start = Instant::now();
                // A tool on PATH that does not work (a stand-in, a broken install) is an anchor
                // missing from the report, not a failed benchmark.
                if let Err(err) = run_external(e, &input_png, &output, sigma) {
                    failed = Some(format!("{err:#}"));
                    break;
                }
                times.push(start.elapsed().as_secs_f64() * 1e3);
                // One run of a slow tool is enough to place it; repeating costs minutes.
                if times[0] > cfg.external_limit_s * 1e3 / 6.0 {
                    break;
                }
            }
            if let Some(why) = failed {
                rows.push(BlurRow::not_run(sigma, e.name, why));
                continue;
            }
            let ms = crate::common::median(&mut times);
            if ms > cfg.external_limit_s * 1e3 {
                too_slow[slot] = Some(ms / 1e3);
            }
            let out = image::open(&output)
                .with_context(|| format!("reading {}", output.display()))?
                .to_rgba8();
            if out.dimensions() != (side, side) {
                bail!("{} wrote a {:?} image", e.program, out.dimensions());
            }
            rows.push(anchor(
                e.name,
                ms,
                out.as_raw(),
                format!(
                    "{} run(s); includes PNG decode and encode and process start",
                    times.len()
                ),
            ));
            let _ = std::fs::remove_file(&output);
        }
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn region_reference_equals_the_whole_image_reference_there() {
        let n = 40;
        let bytes = crate::common::design(n, n, 3);
        let src = srgb8_to_premultiplied_f64(&bytes);
        let sigma = 2.5;
        let full = reference_blur(&src, n, n, sigma);
        for region in [
            Region {
                x0: 0,
                y0: 0,
                size: 12,
            },
            Region {
                x0: 9,
                y0: 14,
                size: 10,
            },
            Region {
                x0: 25,
                y0: 25,
                size: 15,
            },
        ] {
            let part = region_reference(&src, n, region, sigma);
            for y in 0..region.size {
                for x in 0..region.size {
                    let a = part[y * region.size + x];
                    let b = full[(region.y0 + y) * n + region.x0 + x];
                    for c in 0..4 {
                        assert!(
                            (a[c] - b[c]).abs() < 1e-12,
                            "{region:?} {x},{y}: {a:?} {b:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn interior_error_skips_the_margin() {
        let (w, h) = (6, 6);
        let mut ours = vec![10u8; w * h * 4];
        // A wrong texel on the edge must not count.
        ours[0] = 200;
        let reference = vec![[10.25; 4]; w * h];
        let (max, rms) = interior_error(&ours, &reference, w, h, 1).unwrap();
        assert!((max - 0.25).abs() < 1e-12 && (rms - 0.25).abs() < 1e-12);
        assert!(interior_error(&ours, &reference, w, h, 3).is_none());
    }
}
