//! Mip sweep: each filter in linear light (the cooker's way) and in gamma space (filtering the
//! stored bytes), with `fast_image_resize` as the anchor, every level measured against the f64
//! linear-light chain of the same filter.

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use texture::srgb::linear_to_srgb_lsb;
use texture::{ColourOptions, MipFilter, colour_mips, colour_mips_reference};

use crate::common::median_ms;

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LevelError {
    pub level: usize,
    pub width: u32,
    pub height: u32,
    pub max_lsb: f64,
    pub rms_lsb: f64,
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MipRow {
    /// `box`, `kaiser`, `lanczos3` (texture's `MipFilter::name`).
    pub filter: String,
    /// `linear` or `gamma`.
    pub space: String,
    pub method: String,
    pub ours: bool,
    /// The whole chain, level 1 down to 1x1.
    pub time_ms: f64,
    pub runs: usize,
    /// Levels 1 and below (level 0 is the source's own bytes).
    pub levels: Vec<LevelError>,
    pub note: String,
}

impl MipRow {
    pub fn max_lsb(&self) -> f64 {
        self.levels.iter().map(|l| l.max_lsb).fold(0.0, f64::max)
    }
}

pub struct MipConfig {
    pub size: usize,
    pub runs: usize,
}

pub const FILTERS: [MipFilter; 3] = [MipFilter::Box, MipFilter::Kaiser, MipFilter::Lanczos3];

/// Per-level error of RGBA8 levels (sRGB colour, linear straight alpha) against straight
/// linear f64 levels.
fn level_errors(
    levels: &[Vec<u8>],
    reference: &[Vec<[f64; 4]>],
    w: u32,
    h: u32,
) -> Vec<LevelError> {
    levels
        .iter()
        .zip(reference)
        .enumerate()
        .skip(1)
        .map(|(i, (ours, r))| {
            let (lw, lh) = texture::level_size(w, h, i);
            let (mut max, mut sq) = (0.0f64, 0.0f64);
            for (o, r) in ours.chunks_exact(4).zip(r) {
                for c in 0..4 {
                    let exact = if c < 3 {
                        linear_to_srgb_lsb(r[c].clamp(0.0, 1.0))
                    } else {
                        r[3].clamp(0.0, 1.0) * 255.0
                    };
                    let e = (o[c] as f64 - exact).abs();
                    max = max.max(e);
                    sq += e * e;
                }
            }
            LevelError {
                level: i,
                width: lw,
                height: lh,
                max_lsb: max,
                rms_lsb: (sq / ours.len().max(1) as f64).sqrt(),
            }
        })
        .collect()
}

/// `fast_image_resize`'s box filter on the stored bytes (gamma space, alpha-weighted like ours:
/// `use_alpha(true)`, as in the criterion bench), one level from the previous, single-threaded
/// (its default build).
fn fir_chain(src: &[u8], w: u32, h: u32) -> Result<Vec<Vec<u8>>> {
    use fast_image_resize::images::Image;
    use fast_image_resize::{FilterType, PixelType, ResizeAlg, ResizeOptions, Resizer};
    let mut resizer = Resizer::new();
    let opts = ResizeOptions::new()
        .resize_alg(ResizeAlg::Convolution(FilterType::Box))
        .use_alpha(true);
    let mut levels = vec![src.to_vec()];
    let mut cur = Image::from_vec_u8(w, h, src.to_vec(), PixelType::U8x4)?;
    let (mut lw, mut lh) = (w, h);
    while lw > 1 || lh > 1 {
        (lw, lh) = ((lw / 2).max(1), (lh / 2).max(1));
        let mut dst = Image::new(lw, lh, PixelType::U8x4);
        resizer.resize(&cur, &mut dst, &opts)?;
        levels.push(dst.buffer().to_vec());
        cur = dst;
    }
    Ok(levels)
}

/// `fast_image_resize` run gamma-correct: the bytes mapped to linear u16 through its sRGB
/// mapper, each level box-filtered from the previous one in u16 (alpha-weighted), and mapped
/// back to sRGB bytes; one thread.
fn fir_srgb_chain(src: &[u8], w: u32, h: u32) -> Result<Vec<Vec<u8>>> {
    use fast_image_resize::images::{Image, ImageRef};
    use fast_image_resize::{
        FilterType, PixelType, ResizeAlg, ResizeOptions, Resizer, create_srgb_mapper,
    };
    let mapper = create_srgb_mapper();
    let mut resizer = Resizer::new();
    let opts = ResizeOptions::new()
        .resize_alg(ResizeAlg::Convolution(FilterType::Box))
        .use_alpha(true);
    let mut cur = Image::new(w, h, PixelType::U16x4);
    mapper.forward_map(&ImageRef::new(w, h, src, PixelType::U8x4)?, &mut cur)?;
    let mut levels = vec![src.to_vec()];
    let (mut lw, mut lh) = (w, h);
    while lw > 1 || lh > 1 {
        (lw, lh) = ((lw / 2).max(1), (lh / 2).max(1));
        let mut next = Image::new(lw, lh, PixelType::U16x4);
        resizer.resize(&cur, &mut next, &opts)?;
        let mut bytes = Image::new(lw, lh, PixelType::U8x4);
        mapper.backward_map(&next, &mut bytes)?;
        levels.push(bytes.into_vec());
        cur = next;
    }
    Ok(levels)
}

pub fn sweep(cfg: &MipConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<MipRow>> {
    let n = cfg.size as u32;
    let bytes = crate::common::design(cfg.size, cfg.size, 4);
    let img = image::DynamicImage::ImageRgba8(
        image::RgbaImage::from_raw(n, n, bytes.clone()).context("design buffer")?,
    );
    let mut rows = Vec::new();
    // The anchor runs on one thread, so ours does too: the ratio compares the same cores.
    let one = rayon::ThreadPoolBuilder::new().num_threads(1).build()?;
    for filter in FILTERS {
        let reference = colour_mips_reference(&img, &ColourOptions { srgb: true, filter })?;
        for (space, srgb) in [("linear", true), ("gamma", false)] {
            let opts = ColourOptions { srgb, filter };
            let (ms, chain) = one.install(|| median_ms(cfg.runs, || colour_mips(&img, &opts)));
            let chain = chain?;
            let levels = level_errors(&chain.levels, &reference, n, n);
            let row = MipRow {
                filter: filter.name().into(),
                space: space.into(),
                method: format!("ours: {} ({space})", filter.name()),
                ours: true,
                time_ms: ms,
                runs: cfg.runs,
                levels,
                note: "one thread".into(),
            };
            progress(&format!(
                "mips {n}² {}: {ms:.1} ms, max {:.3} LSB",
                row.method,
                row.max_lsb()
            ));
            rows.push(row);
        }
        if filter == MipFilter::Box {
            let (ms, chain) = median_ms(cfg.runs, || fir_chain(&bytes, n, n));
            let levels = level_errors(&chain?, &reference, n, n);
            let row = MipRow {
                filter: filter.name().into(),
                space: "gamma".into(),
                method: "fast_image_resize box (gamma)".into(),
                ours: false,
                time_ms: ms,
                runs: cfg.runs,
                levels,
                note: "one thread".into(),
            };
            progress(&format!(
                "mips {n}² {}: {ms:.1} ms, max {:.3} LSB",
                row.method,
                row.max_lsb()
            ));
            rows.push(row);
            let (ms, chain) = median_ms(cfg.runs, || fir_srgb_chain(&bytes, n, n));
            let levels = level_errors(&chain?, &reference, n, n);
            let row = MipRow {
                filter: filter.name().into(),
                space: "linear".into(),
                method: "fast_image_resize box (linear, sRGB mapper, u16)".into(),
                ours: false,
                time_ms: ms,
                runs: cfg.runs,
                levels,
                note: "one thread; gamma-correct: sRGB to linear u16, filter, back".into(),
            };
            progress(&format!(
                "mips {n}² {}: {ms:.1} ms, max {:.3} LSB",
                row.method,
                row.max_lsb()
            ));
            rows.push(row);
        }
    }
    Ok(rows)
}
