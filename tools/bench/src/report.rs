//! The report: Markdown tables and SVG plots in one folder, the raw numbers as JSON, and the
//! error tables the cooker and the renderer embed.

use std::fmt::Write;
use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};

use crate::blur::BlurRow;
use crate::common::{Machine, cell};
use crate::godrays::GodRayReport;
use crate::mesh::MeshRow;
use crate::mips::MipRow;
use crate::svg::{Plot, Point, pareto_front, render};

#[derive(Debug, Serialize, Deserialize)]
pub struct Results {
    pub machine: Machine,
    pub command: String,
    /// Sweeps copied from an earlier report (`bench --only … --keep-others`), each with the
    /// machine line and command of the run that measured them.
    #[serde(default)]
    pub kept: Vec<KeptSweep>,
    pub blur_size: usize,
    pub blur_error_region: usize,
    pub mip_size: usize,
    pub blur: Vec<BlurRow>,
    pub mips: Vec<MipRow>,
    pub meshes: Vec<MeshRow>,
    /// `Err` text when the god-ray sweep could not run (no adapter, say).
    pub god_rays: Result<GodRayReport, String>,
    /// Block compression: settings × roles, and the default scene's pack both ways.
    #[serde(default)]
    pub compression: crate::compress::CompressReport,
    /// `Err` text when the shadow sweep did not run (reports from before it read so).
    #[serde(default = "not_measured")]
    pub shadows: Result<crate::shadows::ShadowReport, String>,
    /// MikkTSpace tangents against the `mikktspace` crate (empty in reports from before it).
    #[serde(default)]
    pub tangents: Vec<crate::tangents::TangentRow>,
    /// The viewer's time to first frame (empty in reports from before it, or when the viewer
    /// was not built).
    #[serde(default)]
    pub first_frame: Vec<crate::first_frame::FirstFrameRow>,
}

fn not_measured() -> Result<crate::shadows::ShadowReport, String> {
    Err("not measured in this run".into())
}

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct KeptSweep {
    pub sweep: String,
    pub machine: String,
    pub command: String,
}

impl Results {
    /// Takes from `earlier` every sweep not in `ran` (`blur`, `mips`, `meshes`, `god-rays`), so
    /// one sweep can be re-measured without re-running the others; the report says which rows
    /// came from which run.
    pub fn keep_from(&mut self, earlier: Results, ran: &[&str]) {
        let note = |sweep: &str| {
            earlier
                .kept
                .iter()
                .find(|k| k.sweep == sweep)
                .cloned()
                .unwrap_or_else(|| KeptSweep {
                    sweep: sweep.to_string(),
                    machine: earlier.machine.markdown(),
                    command: earlier.command.clone(),
                })
        };
        let mut kept = Vec::new();
        if !ran.contains(&"blur") {
            kept.push(note("blur"));
            self.blur = earlier.blur;
            self.blur_size = earlier.blur_size;
            self.blur_error_region = earlier.blur_error_region;
        }
        if !ran.contains(&"mips") {
            kept.push(note("mips"));
            self.mips = earlier.mips;
            self.mip_size = earlier.mip_size;
        }
        if !ran.contains(&"meshes") {
            kept.push(note("meshes"));
            self.meshes = earlier.meshes;
        }
        if !ran.contains(&"god-rays") {
            kept.push(note("god-rays"));
            self.god_rays = earlier.god_rays;
        }
        if !ran.contains(&"shadows") {
            kept.push(note("shadows"));
            self.shadows = earlier.shadows;
        }
        if !ran.contains(&"first-frame") {
            kept.push(note("first-frame"));
            self.first_frame = earlier.first_frame;
        }
        if !ran.contains(&"tangents") {
            kept.push(note("tangents"));
            self.tangents = earlier.tangents;
        }
        if !ran.contains(&"compression") {
            kept.push(note("compression"));
            self.compression = earlier.compression;
        }
        self.kept = kept;
    }
}

fn write(dir: &Path, name: &str, text: &str) -> Result<()> {
    let path = dir.join(name);
    // Write then rename, so a reader never sees half a report.
    let tmp = dir.join(format!(".{name}.tmp"));
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, &path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

fn blur_points(rows: &[BlurRow], sigma: f32) -> Vec<Point> {
    rows.iter()
        .filter(|r| r.sigma == sigma)
        .filter_map(|r| {
            Some(Point {
                series: r.method.clone(),
                label: r.method.trim_start_matches("ours: ").to_string(),
                x: r.time_ms?,
                y: r.max_lsb?,
            })
        })
        .collect()
}

fn god_ray_label(samples: u32, scale: f32, jitter: bool) -> String {
    format!(
        "{samples}s {}{}",
        scale_name(scale),
        if jitter { " j" } else { "" }
    )
}

fn scale_name(scale: f32) -> &'static str {
    if scale >= 1.0 {
        "full"
    } else if scale >= 0.5 {
        "half"
    } else {
        "quarter"
    }
}

fn compression_section(dir: &Path, md: &mut String, r: &Results) -> Result<()> {
    let c = &r.compression;
    if c.rows.is_empty() {
        return Ok(());
    }
    let _ = writeln!(md, "## Block compression (BC7, BC5; `intel_tex_2` 0.5)\n");
    let _ = writeln!(
        md,
        "Each role's whole mip chain compressed level by level from the exact linear-light \
         levels, on one thread. Error as the cooker's budget measures it (`texture::bc`): for \
         colour the RMS over every channel of every texel of every level, in 8-bit steps of the \
         stored sRGB values; for normal maps the mean angle in degrees (Z rebuilt from BC5's X \
         and Y). Level 0 alone beside it, and the largest channel difference (colour) or 99th \
         percentile angle (normal maps). The cooker tries ultra-fast, then very-fast, and keeps \
         the first whose error fits the budget (`crates/cook/src/budget.rs`).\n"
    );
    let _ = writeln!(
        md,
        "| role | image | size | setting | time (ms) | error | level 0 | max / p99 |"
    );
    let _ = writeln!(md, "|---|---|---|---|---:|---:|---:|---:|");
    for row in &c.rows {
        let unit = if row.role == "normal map" {
            "°"
        } else {
            " LSB"
        };
        let _ = writeln!(
            md,
            "| {} | {} | {}x{} | {} | {:.1} | {:.3}{unit} | {:.3}{unit} | {:.2}{unit} |",
            row.role,
            row.image,
            row.width,
            row.height,
            row.codec,
            row.time_ms,
            row.error,
            row.error_level0,
            row.error_max
        );
    }
    md.push('\n');
    let points: Vec<Point> = c
        .rows
        .iter()
        .filter(|row| row.role != "normal map")
        .map(|row| Point {
            series: row.role.clone(),
            label: row.codec.trim_start_matches("bc7 ").to_string(),
            x: row.time_ms,
            y: row.error,
        })
        .collect();
    let mut roles: Vec<&str> = points.iter().map(|p| p.series.as_str()).collect();
    roles.dedup();
    for (i, role) in roles.iter().enumerate() {
        let mine: Vec<Point> = points
            .iter()
            .filter(|p| p.series == *role)
            .cloned()
            .collect();
        let title = format!("BC7, {role}: RMS error over the chain against time");
        let name = format!("compression-{i}.svg");
        write(
            dir,
            &name,
            &crate::svg::render(&Plot {
                title: &title,
                x_label: "time for the whole chain, one thread (ms)",
                y_label: "RMS error (LSB)",
                points: &mine,
            }),
        )?;
        let _ = writeln!(md, "![{title}]({name})\n");
    }
    if !c.zstd.is_empty() {
        let _ = writeln!(
            md,
            "### Supercompression (zstd on top of the stored format)\n\n\
             Each role's chain as stored without block compression (`rgba8`) and with the \
             setting the cooker tries on it, every level its own zstd frame as in the pack, on \
             one thread; decompression is what a reader pays before uploading. The pack uses \
             level {} (`pack::ZSTD_LEVEL`).\n",
            pack::ZSTD_LEVEL
        );
        let _ = writeln!(
            md,
            "| role | stored as | zstd level | bytes before | bytes after | ratio | compress (ms) | decompress (ms) |"
        );
        let _ = writeln!(md, "|---|---|---:|---:|---:|---:|---:|---:|");
        for z in &c.zstd {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {} | {} | {:.2} | {:.1} | {:.1} |",
                z.role,
                z.stored,
                z.level,
                z.raw_bytes,
                z.bytes,
                z.bytes as f64 / z.raw_bytes.max(1) as f64,
                z.compress_ms,
                z.decompress_ms
            );
        }
        md.push('\n');
    }
    if let Some(e) = &c.scene_error {
        let _ = writeln!(md, "The default scene was not cooked both ways: {e}\n");
    }
    if !c.scene.is_empty() {
        let (w, h) = c.render_size;
        let _ = writeln!(
            md,
            "The default scene cooked in process with RGBA8 textures (the reference), the \
             default and its variants, cold (no cache): pack size, the textures' size on the GPU \
             (in their formats, after zstd is undone), cook time, and per camera the FLIP mean of \
             the final render ({w}x{h}, lavapipe) against the RGBA8 pack's.\n"
        );
        let _ = writeln!(
            md,
            "| textures | pack bytes | GPU texture bytes | cold cook (ms) | FLIP mean per camera |"
        );
        let _ = writeln!(md, "|---|---:|---:|---:|---|");
        for s in &c.scene {
            let flips: Vec<String> = s
                .flip
                .iter()
                .map(|(cam, f)| format!("{cam} {f:.4}"))
                .collect();
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.0} | {} |",
                s.format,
                s.bytes,
                s.gpu_texture_bytes,
                s.cook_ms,
                flips.join(", ")
            );
        }
        md.push('\n');
        if !c.flip_one_step.is_empty() {
            let steps: Vec<String> = c
                .flip_one_step
                .iter()
                .map(|(cam, f)| format!("{cam} {f:.4}"))
                .collect();
            let _ = writeln!(
                md,
                "For scale: the RGBA8 renders against themselves with every channel one 8-bit \
                 step brighter measure FLIP mean {}. A mean below that needs most pixels \
                 unchanged to the last bit.\n",
                steps.join(", ")
            );
        }
    }
    Ok(())
}

/// Writes README.md, the SVG plots and results.json into `dir`.
pub fn write_report(dir: &Path, r: &Results) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut md = String::new();
    let _ = writeln!(md, "# Run time against error\n");
    let _ = writeln!(
        md,
        "Generated by `{}` (tools/bench). {}\n",
        r.command,
        r.machine.markdown()
    );
    let _ = writeln!(
        md,
        "Times are medians of the stated number of runs, wall clock, all cores unless noted. Error \
         unit for images: 1 LSB is one step of the 8-bit sRGB output; error = |our 8-bit value − \
         the unrounded sRGB encoding of an f64 reference computed in linear light|, so 0.50 is the \
         rounding floor. Plots put time on x and error on y, both logarithmic; the dashed line is \
         the Pareto front (no other point is both faster and more accurate), its points ringed \
         and labelled. The raw numbers are in `results.json`.\n"
    );
    for k in &r.kept {
        let _ = writeln!(
            md,
            "The {} sweep is kept from an earlier run: `{}`. {}\n",
            k.sweep, k.command, k.machine
        );
    }
    summary(&mut md, r);
    blur_section(dir, &mut md, r)?;
    mip_section(dir, &mut md, r)?;
    mesh_section(dir, &mut md, r)?;
    tangent_section(&mut md, r);
    god_ray_section(dir, &mut md, r)?;
    shadow_section(&mut md, r);
    first_frame_section(&mut md, r);
    compression_section(dir, &mut md, r)?;
    write(dir, "README.md", &md)?;
    write(dir, "results.json", &serde_json::to_string_pretty(r)?)?;
    Ok(())
}

fn summary(md: &mut String, r: &Results) {
    let _ = writeln!(md, "## Summary\n");
    let mut sigmas: Vec<f32> = r.blur.iter().map(|b| b.sigma).collect();
    sigmas.dedup();
    for s in sigmas {
        let exact = |b: &&BlurRow| !b.note.contains("approximation");
        let best_ours = r
            .blur
            .iter()
            .filter(|b| b.sigma == s && b.ours)
            .filter(exact)
            .min_by(|a, b| {
                a.time_ms
                    .unwrap_or(f64::INFINITY)
                    .total_cmp(&b.time_ms.unwrap_or(f64::INFINITY))
            });
        let lib = r
            .blur
            .iter()
            .find(|b| b.sigma == s && b.method == "libblur exact u8");
        // The cooker's default (`BlurMethod::Auto`) and whether it is on this σ's front.
        let auto = texture::BlurMethod::Auto.resolve(s).name();
        let points = blur_points(&r.blur, s);
        let front = pareto_front(&points);
        let auto_on_front = front.iter().any(|&i| points[i].label == auto);
        if let (Some(o), Some(l)) = (best_ours, lib) {
            let _ = writeln!(
                md,
                "- Blur σ={s} ({n}²): ours ({}) {} ms at max {} LSB; libblur exact u8 {} ms at max {} LSB (its own gamma-space reference){}. The default (auto = {auto}) is {} the Pareto front.",
                o.method.trim_start_matches("ours: "),
                cell(o.time_ms, 1),
                cell(o.max_lsb, 3),
                cell(l.time_ms, 1),
                cell(l.max_lsb, 3),
                match (o.time_ms, l.time_ms) {
                    (Some(a), Some(b)) if a > 0.0 =>
                        format!(": ours takes {:.2}x libblur's time", a / b),
                    _ => String::new(),
                },
                if auto_on_front { "on" } else { "**not** on" },
                n = r.blur_size
            );
        }
        let approx: Vec<String> = r
            .blur
            .iter()
            .filter(|b| b.sigma == s && b.ours && !exact(b))
            .map(|b| {
                format!(
                    "{} {} ms at max {} / RMS {} LSB",
                    b.method.trim_start_matches("ours: "),
                    cell(b.time_ms, 1),
                    cell(b.max_lsb, 2),
                    cell(b.rms_lsb, 2)
                )
            })
            .collect();
        if !approx.is_empty() {
            let _ = writeln!(
                md,
                "  - Approximations (picked only when `--max-error-lsb` allows): {}.",
                approx.join("; ")
            );
        }
    }
    for filter in ["box", "kaiser", "lanczos3"] {
        let lin = r
            .mips
            .iter()
            .find(|m| m.ours && m.filter == filter && m.space == "linear");
        let gam = r
            .mips
            .iter()
            .find(|m| m.ours && m.filter == filter && m.space == "gamma");
        if let (Some(l), Some(g)) = (lin, gam) {
            let _ = writeln!(
                md,
                "- Mips {filter} ({n}² chain): linear light {:.1} ms, worst level {:.3} LSB; gamma space {:.1} ms, worst level {:.1} LSB against the linear-light reference.",
                l.time_ms,
                l.max_lsb(),
                g.time_ms,
                g.max_lsb(),
                n = r.mip_size
            );
            let anchor = r
                .mips
                .iter()
                .find(|m| !m.ours && m.filter == filter && m.space == "linear");
            if let Some(a) = anchor {
                let _ = writeln!(
                    md,
                    "- Mips {filter} in linear light against {} (one thread each, same run): {:.1} against {:.1} ms, {:.2}x its time; worst level {:.3} against {:.3} LSB.",
                    a.method,
                    l.time_ms,
                    a.time_ms,
                    l.time_ms / a.time_ms,
                    l.max_lsb(),
                    a.max_lsb()
                );
            }
        }
    }
    for mesh in dedup(r.meshes.iter().map(|m| m.mesh.clone())) {
        let row = |c: &str| {
            r.meshes
                .iter()
                .find(|m| m.mesh == mesh && m.cache == c && m.position_bits == 16)
        };
        if let (Some(f), Some(q), Some(n)) = (row("full"), row("fifo"), row("none")) {
            let _ = writeln!(
                md,
                "- Mesh {mesh} ({} triangles): full cache optimizer ACMR {} in {} ms, FIFO {} in {} ms, source order {}; 16-bit positions: {} B/triangle, max position error {} ({:.1e} of the extent).",
                f.triangles,
                cell(f.acmr, 3),
                cell(f.time_ms, 1),
                cell(q.acmr, 3),
                cell(q.time_ms, 1),
                cell(n.acmr, 3),
                cell(f.bytes_per_triangle, 1),
                f.max_position_error
                    .map_or(String::new(), |e| format!("{e:.2e}")),
                f.relative_position_error.unwrap_or(f64::NAN)
            );
        }
    }
    for line in end_to_end_lines(r) {
        let _ = writeln!(md, "- {line}");
    }
    if let Ok(g) = &r.god_rays {
        let default = render::view::GodRaySettings::default();
        let d = g.rows.iter().find(|x| {
            x.samples == default.samples
                && x.resolution_scale == default.resolution_scale
                && x.jitter == default.jitter
        });
        let points = god_ray_points(g);
        let front = pareto_front(&points);
        let on_front = d.is_some_and(|d| {
            front
                .iter()
                .any(|&i| points[i].label == god_ray_label(d.samples, d.resolution_scale, d.jitter))
        });
        if let Some(d) = d {
            let _ = writeln!(
                md,
                "- God rays ({}x{}, {}): the default ({}) costs {} ms on the god-ray pass, FLIP mean {:.4} / p99 {:.4}, RMSE {:.5} against {} samples; {} the Pareto front of FLIP mean against pass time.",
                g.width,
                g.height,
                g.device,
                god_ray_label(d.samples, d.resolution_scale, d.jitter),
                cell(d.god_ray_ms, 2),
                d.flip_mean,
                d.flip_p99,
                d.rmse_linear,
                g.reference_samples,
                if on_front { "on" } else { "**not** on" }
            );
        }
    }
    md.push('\n');
}

/// Per mesh: the cooker against native gltfpack, whole processes of the same run, float
/// against `-noq` and `--quantize` against gltfpack's default.
fn end_to_end_lines(r: &Results) -> Vec<String> {
    let mut lines = Vec::new();
    for mesh in dedup(r.meshes.iter().map(|m| m.mesh.clone())) {
        let time = |c: &str| {
            r.meshes
                .iter()
                .find(|m| m.mesh == mesh && m.cache == c)
                .and_then(|m| m.time_ms.map(|t| (t, m.triangles)))
        };
        let pairs = [
            (
                "cooker (end to end)",
                "gltfpack native -noq (end to end)",
                "float",
            ),
            (
                "cooker --quantize (end to end)",
                "gltfpack native (end to end)",
                "quantized",
            ),
        ];
        let parts: Vec<String> = pairs
            .iter()
            .filter_map(|(ours, theirs, what)| {
                let ((a, _), (b, _)) = (time(ours)?, time(theirs)?);
                Some(format!("{what} {a:.1} against {b:.1} ms ({:.2}x)", a / b))
            })
            .collect();
        if let (false, Some((_, tris))) = (parts.is_empty(), time("cooker (end to end)")) {
            lines.push(format!(
                "Whole `cooker cook` against native gltfpack, {mesh} ({tris} triangles), interleaved runs: {}.",
                parts.join("; ")
            ));
        }
    }
    lines
}

fn dedup(it: impl Iterator<Item = String>) -> Vec<String> {
    let mut v: Vec<String> = Vec::new();
    for s in it {
        if !v.contains(&s) {
            v.push(s);
        }
    }
    v
}

fn blur_section(dir: &Path, md: &mut String, r: &Results) -> Result<()> {
    let _ = writeln!(md, "## Blur ({0}x{0} RGBA8)\n", r.blur_size);
    let region = r.blur_error_region.min(r.blur_size);
    let _ = writeln!(
        md,
        "Ours (crates/texture): Gaussian in linear light, premultiplied alpha, zero border, \
         measured against the f64 reference (`texture::reference_blur`) over the top-left \
         {region}x{region} texels (two borders and a corner; the f64 reference of a whole 4096² \
         image takes minutes per σ, and it is computed exactly over that region). Anchors filter \
         the stored gamma-encoded bytes and clamp at the edges, so they are measured against an \
         f64 blur of those bytes over a {region}x{region} square no kernel reaches the border \
         from (`reference = gamma`). The design is opaque: with translucent texels the anchors \
         disagree on alpha (ImageMagick weights colour by alpha, the others do not), so no single \
         gamma-space reference would be fair to all of them. External tools include process start and PNG decode and \
         encode; an empty cell means the tool is not installed or was not run (see note).\n"
    );
    let _ = writeln!(
        md,
        "| σ | method | reference | time (ms) | runs | max (LSB) | RMS (LSB) | note |"
    );
    let _ = writeln!(md, "|---:|---|---|---:|---:|---:|---:|---|");
    for b in &r.blur {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            b.sigma,
            b.method,
            b.reference,
            cell(b.time_ms, 1),
            b.runs,
            cell(b.max_lsb, 3),
            cell(b.rms_lsb, 3),
            b.note
        );
    }
    md.push('\n');
    let mut sigmas: Vec<f32> = r.blur.iter().map(|b| b.sigma).collect();
    sigmas.dedup();
    for s in sigmas {
        let points = blur_points(&r.blur, s);
        let name = format!("blur-sigma-{s}.svg");
        let title = format!(
            "Gaussian blur {0}x{0}, σ = {s}: max error against time",
            r.blur_size
        );
        write(
            dir,
            &name,
            &render(&Plot {
                title: &title,
                x_label: "time (ms)",
                y_label: "max error (LSB)",
                points: &points,
            }),
        )?;
        let _ = writeln!(md, "![blur σ={s}]({name})\n");
    }
    Ok(())
}

fn mip_section(dir: &Path, md: &mut String, r: &Results) -> Result<()> {
    let _ = writeln!(md, "## Mip chains ({0}x{0} RGBA8 → 1x1)\n", r.mip_size);
    let _ = writeln!(
        md,
        "Every level against the f64 chain of the same filter computed in linear light with \
         alpha weighting (`texture::colour_mips_reference`). `gamma` filters the stored sRGB bytes \
         directly: its error is what linear-light filtering avoids. Time is for the whole chain \
         (level 0 is the source's bytes), every method on one thread; fast_image_resize weights \
         by alpha (`use_alpha(true)`) as ours does.\n"
    );
    let _ = writeln!(
        md,
        "| method | time (ms) | runs | worst level max (LSB) | max per level 1, 2, … (LSB) | note |"
    );
    let _ = writeln!(md, "|---|---:|---:|---:|---|---|");
    for m in &r.mips {
        let per: Vec<String> = m
            .levels
            .iter()
            .map(|l| format!("{:.2}", l.max_lsb))
            .collect();
        let _ = writeln!(
            md,
            "| {} | {:.1} | {} | {:.3} | {} | {} |",
            m.method,
            m.time_ms,
            m.runs,
            m.max_lsb(),
            per.join(", "),
            m.note
        );
    }
    md.push('\n');
    let _ = writeln!(md, "RMS error per level (LSB):\n");
    let _ = writeln!(md, "| method | RMS per level 1, 2, … |");
    let _ = writeln!(md, "|---|---|");
    for m in &r.mips {
        let per: Vec<String> = m
            .levels
            .iter()
            .map(|l| format!("{:.3}", l.rms_lsb))
            .collect();
        let _ = writeln!(md, "| {} | {} |", m.method, per.join(", "));
    }
    md.push('\n');
    let points: Vec<Point> = r
        .mips
        .iter()
        .map(|m| Point {
            series: m.method.clone(),
            label: m.method.trim_start_matches("ours: ").to_string(),
            x: m.time_ms,
            y: m.max_lsb(),
        })
        .collect();
    let title = format!(
        "Mip chain {0}x{0}: worst-level max error against time",
        r.mip_size
    );
    write(
        dir,
        "mips.svg",
        &render(&Plot {
            title: &title,
            x_label: "time (ms)",
            y_label: "max error (LSB)",
            points: &points,
        }),
    )?;
    let _ = writeln!(md, "![mips](mips.svg)\n");
    Ok(())
}

fn first_frame_section(md: &mut String, r: &Results) {
    if r.first_frame.is_empty() {
        return;
    }
    let _ = writeln!(md, "## Viewer first frame\n");
    let _ = writeln!(
        md,
        "Whole headless viewer processes on the default scene's pack (camera `nave`), runs of \
         every mode interleaved, medians; the clock starts when the pack starts streaming (the \
         device is created before it). By default a CPU rasterizer draws a half-size preview \
         first (`Gpu::first_frame_divisor`); `--no-preview` draws the whole frame first. The \
         split is the viewer's own (`-v`) for the median run. Peak resident memory is the \
         whole process's (lavapipe's render targets and threads included). The third row is the pack \
         the texture-compression issue started from (RGBA8 textures, no zstd), drawn in the \
         default mode in the same rounds: the compressed pack's decoding must not make full \
         quality later than it. The generated grid's row is the meshes sweep's largest mesh, \
         cooked bare (a guessed sun and cameras, no windows), for the viewer's memory on a \
         mesh of a million triangles.\n"
    );
    let _ = writeln!(
        md,
        "| mode | runs | first frame | full quality | peak RSS | split |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|");
    for f in &r.first_frame {
        let memory = match (f.peak_rss_mb, f.pack_mb) {
            (Some(m), Some(p)) => format!("{m:.0} MB ({:.0}x the {p:.1} MB pack)", m / p),
            _ => String::new(),
        };
        let _ = writeln!(
            md,
            "| {} | {} | {:.0} ms | {:.0} ms | {memory} | {} |",
            f.mode, f.runs, f.first_frame_ms, f.full_quality_ms, f.split
        );
    }
    md.push('\n');
}

fn tangent_section(md: &mut String, r: &Results) {
    if r.tangents.is_empty() {
        return;
    }
    let _ = writeln!(md, "## Tangents\n");
    let _ = writeln!(
        md,
        "MikkTSpace tangents of the corners the cooker's mesh stage leaves (generated normals, \
         deduplicated vertices, cache-optimized order): ours (`cook::mesh::tangents`) against the \
         `mikktspace` crate on the same corners, medians. The difference is the largest of any \
         tangent component over every corner.\n"
    );
    let _ = writeln!(
        md,
        "| mesh | triangles | runs | mikktspace crate | ours, all cores | ours, one thread | time ratio (all cores / one thread) | max difference | signs agree |"
    );
    let _ = writeln!(md, "|---|---|---|---|---|---|---|---|---|");
    for t in &r.tangents {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.2} ms | {:.2} ms | {:.2} ms | {:.3} / {:.3} | {:.1e} | {} |",
            t.mesh,
            t.triangles,
            t.runs,
            t.reference_ms,
            t.ours_ms,
            t.ours_one_thread_ms,
            t.ours_ms / t.reference_ms,
            t.ours_one_thread_ms / t.reference_ms,
            t.max_difference,
            if t.signs_agree { "yes" } else { "no" }
        );
    }
    md.push('\n');
}

fn mesh_section(dir: &Path, md: &mut String, r: &Results) -> Result<()> {
    let _ = writeln!(md, "## Meshes\n");
    let _ = writeln!(
        md,
        "The cooker's mesh stage (`cook::mesh::process`: degenerate removal, normals, dedupe, \
         vertex cache, vertex fetch) with each vertex cache mode, then `cook::mesh::encode` \
         for 16-, 10- and 8-bit positions (`cooker cook --quantize --position-bits`), every \
         attribute kept. ACMR with a FIFO cache of 16; overfetch against a 64-byte line; bytes \
         per triangle count the vertex and index buffers as the cooker stores them (16-bit \
         indices when they fit). The *end to end* rows time whole processes the same way: the \
         `cooker` binary (release build) and gltfpack where found: the native build \
         (`$GLTFPACK_NATIVE` or `../shared/anchors/gltfpack`), whose default quantizes (compare \
         it with `cooker --quantize`; its `-noq` row with `cooker`), and the npm WebAssembly \
         build on `PATH`.\n"
    );
    let _ = writeln!(
        md,
        "| mesh | triangles | cache | position bits | time (ms) | peak RSS (MB) | ACMR | overfetch | bytes/triangle | max position error | relative | note |"
    );
    let _ = writeln!(
        md,
        "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---|"
    );
    for m in &r.meshes {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {}{} | {} | {} | {} | {} | {} | {} | {} | {} |",
            m.mesh,
            m.triangles,
            m.cache,
            m.position_bits,
            if m.modelled { " (modelled)" } else { "" },
            cell(m.time_ms, 2),
            cell(m.peak_rss_mb, 1),
            cell(m.acmr, 3),
            cell(m.overfetch, 3),
            cell(m.bytes_per_triangle, 2),
            m.max_position_error
                .map_or(String::new(), |e| format!("{e:.3e}")),
            m.relative_position_error
                .map_or(String::new(), |e| format!("{e:.2e}")),
            m.note
        );
    }
    md.push('\n');
    for (i, mesh) in dedup(r.meshes.iter().map(|m| m.mesh.clone()))
        .iter()
        .enumerate()
    {
        let points: Vec<Point> = r
            .meshes
            .iter()
            .filter(|m| &m.mesh == mesh && m.position_bits == 16)
            .filter_map(|m| {
                Some(Point {
                    series: m.cache.clone(),
                    label: m.cache.clone(),
                    x: m.time_ms?,
                    y: m.acmr?,
                })
            })
            .collect();
        if points.is_empty() {
            continue;
        }
        let name = format!("meshes-{i}.svg");
        let title = format!("{mesh}: ACMR against time (16-bit positions)");
        write(
            dir,
            &name,
            &render(&Plot {
                title: &title,
                x_label: "time (ms)",
                y_label: "ACMR",
                points: &points,
            }),
        )?;
        let _ = writeln!(md, "![{mesh}]({name})\n");
    }
    Ok(())
}

fn god_ray_points(g: &GodRayReport) -> Vec<Point> {
    g.rows
        .iter()
        .map(|x| Point {
            series: format!(
                "{} resolution{}",
                scale_name(x.resolution_scale),
                if x.jitter { ", jitter" } else { "" }
            ),
            label: god_ray_label(x.samples, x.resolution_scale, x.jitter),
            x: x.god_ray_ms.unwrap_or(f64::NAN),
            y: x.flip_mean,
        })
        .collect()
}

fn god_ray_section(dir: &Path, md: &mut String, r: &Results) -> Result<()> {
    let _ = writeln!(md, "## God rays\n");
    let g = match &r.god_rays {
        Ok(g) => g,
        Err(e) => {
            let _ = writeln!(md, "Not measured: {e}\n");
            return Ok(());
        }
    };
    let _ = writeln!(
        md,
        "Default scene, camera `{}` (god-ray fade {:.2}), {}x{}, on {} ({} timing). Error of \
         the final image against a {}-sample reference of the same view and parameters: the \
         renderer caps its sample count at 1024, so the reference march runs on the CPU \
         (`render::view::god_rays_reference`) over the GPU's window mask and is composited onto \
         the GPU's own lit and background targets (refraction off for this sweep); the same CPU \
         composite of the GPU's own god-ray target differs from the GPU's output by at most {} \
         LSB. FLIP mean and 99th percentile (nv-flip, default pixels per degree), RMSE of the \
         tone-mapped output in linear light. Lavapipe times are for relative comparisons only.\n",
        g.camera,
        g.god_ray_fade,
        g.width,
        g.height,
        g.device,
        g.timing,
        g.reference_samples,
        g.composite_check_lsb
    );
    let _ = writeln!(
        md,
        "| samples | resolution | jitter | god-ray pass (ms) | frame (ms) | FLIP mean | FLIP p99 | RMSE (linear) |"
    );
    let _ = writeln!(md, "|---:|---|---|---:|---:|---:|---:|---:|");
    for x in &g.rows {
        let _ = writeln!(
            md,
            "| {} | {} | {} | {} | {} | {:.4} | {:.4} | {:.5} |",
            x.samples,
            scale_name(x.resolution_scale),
            if x.jitter { "yes" } else { "no" },
            cell(x.god_ray_ms, 2),
            cell(x.frame_ms, 2),
            x.flip_mean,
            x.flip_p99,
            x.rmse_linear
        );
    }
    md.push('\n');
    let points = god_ray_points(g);
    let title = format!(
        "God rays {}x{}: FLIP mean against god-ray pass time",
        g.width, g.height
    );
    write(
        dir,
        "godrays.svg",
        &render(&Plot {
            title: &title,
            x_label: "god-ray pass (ms)",
            y_label: "FLIP mean",
            points: &points,
        }),
    )?;
    let _ = writeln!(md, "![god rays](godrays.svg)\n");
    Ok(())
}

fn shadow_section(md: &mut String, r: &Results) {
    let _ = writeln!(md, "## Shadows\n");
    let s = match &r.shadows {
        Ok(s) => s,
        Err(e) => {
            let _ = writeln!(md, "Not measured: {e}\n");
            return;
        }
    };
    let _ = writeln!(
        md,
        "The lit pass (pass 3) against the CPU ray-traced reference (`render::reference`, rules \
         in docs/reference-tracer.md) at {}x{}, on {}: the reference takes {} rays per pixel, \
         each with {} shadow rays over the light's disc; the GPU image is drawn at 4x the size \
         and averaged 4 x 4 (the same 16 samples per pixel). Both are tone mapped as the \
         composite does (exposure 1, ACES, sRGB) and compared with FLIP (nv-flip, default \
         pixels per degree). \"Without occlusion\" is plain projective texturing, the renderer \
         before shadow maps. Images: `shadows/`.\n",
        s.width, s.height, s.device, s.pixel_samples, s.light_samples
    );
    let _ = writeln!(
        md,
        "| scene | camera | FLIP mean | FLIP p99 | without occlusion | reference | GPU |"
    );
    let _ = writeln!(md, "|---|---|---:|---:|---:|---|---|");
    for c in &s.cameras {
        let _ = writeln!(
            md,
            "| {} | {} | {:.4} | {:.4} | {:.4} | ![]({}) | ![]({}) |",
            c.scene,
            c.camera,
            c.flip_mean,
            c.flip_p99,
            c.flip_mean_unoccluded,
            c.reference_image,
            c.gpu_image
        );
    }
    let _ = writeln!(
        md,
        "\nCost ({} timing; lavapipe times are for relative comparisons only). The maps do not \
         depend on the camera and are redrawn only when the light or the geometry changes; the \
         rows time them every frame. Map 0 is occlusion off.\n",
        s.timing
    );
    let _ = writeln!(
        md,
        "| scene | camera | size | map | shadow pass (ms) | lit pass (ms) | frame (ms) |"
    );
    let _ = writeln!(md, "|---|---|---|---:|---:|---:|---:|");
    for t in &s.timings {
        let _ = writeln!(
            md,
            "| {} | {} | {}x{} | {} | {} | {} | {} |",
            t.scene,
            t.camera,
            t.width,
            t.height,
            t.map_size,
            cell(t.shadow_ms, 2),
            cell(t.lit_ms, 2),
            cell(t.frame_ms, 2)
        );
    }
    let _ = writeln!(md, "\nWindows of the default scene:\n");
    for w in &s.default_windows {
        let _ = writeln!(md, "- {w}");
    }
    md.push('\n');
}

/// The table `crates/cook/src/budget.rs` embeds: our methods only, costs relative to the first
/// (smallest σ) direct blur and to the linear-light box chain.
#[derive(Debug, Serialize)]
pub struct ErrorTable {
    pub generated_by: String,
    pub machine: String,
    pub image_size: usize,
    pub blur: Vec<BlurEntry>,
    pub mip: Vec<MipEntry>,
}

/// The table `crates/render/src/budget.rs` embeds: every god-ray row, costs relative to 64
/// samples at full resolution.
#[derive(Debug, Serialize)]
pub struct GodRayTable {
    pub generated_by: String,
    pub machine: String,
    pub god_rays: Vec<GodRayEntry>,
}

#[derive(Debug, Serialize)]
pub struct BlurEntry {
    pub method: String,
    pub sigma: f32,
    pub max_error_lsb: f64,
    pub rms_error_lsb: f64,
    pub relative_cost: f64,
}

#[derive(Debug, Serialize)]
pub struct GodRayEntry {
    pub samples: u32,
    pub resolution_scale: f32,
    pub jitter: bool,
    pub flip_mean: f64,
    pub flip_p99: f64,
    pub relative_cost: f64,
}

#[derive(Debug, Serialize)]
pub struct MipEntry {
    pub filter: String,
    pub linear_light: bool,
    pub max_error_lsb: f64,
    pub relative_cost: f64,
}

fn round(v: f64, digits: i32) -> f64 {
    let p = 10f64.powi(digits);
    (v * p).round() / p
}

pub fn error_table(r: &Results) -> Result<ErrorTable> {
    let ours: Vec<&BlurRow> = r.blur.iter().filter(|b| b.ours).collect();
    let unit = ours
        .iter()
        .filter(|b| b.method == "ours: direct")
        .min_by(|a, b| a.sigma.total_cmp(&b.sigma))
        .and_then(|b| b.time_ms)
        .context("no direct blur measured: nothing to measure costs against")?;
    let blur = ours
        .iter()
        .map(|b| {
            Ok(BlurEntry {
                method: b.method.trim_start_matches("ours: ").to_string(),
                sigma: b.sigma,
                max_error_lsb: round(b.max_lsb.context("blur error missing")?, 4),
                rms_error_lsb: round(b.rms_lsb.context("blur error missing")?, 4),
                relative_cost: round(b.time_ms.context("blur time missing")? / unit, 3).max(0.001),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let mip_unit = r
        .mips
        .iter()
        .find(|m| m.ours && m.filter == "box" && m.space == "linear")
        .map(|m| m.time_ms)
        .context("no linear box chain measured")?;
    let mip = r
        .mips
        .iter()
        .filter(|m| m.ours)
        .map(|m| MipEntry {
            filter: m.filter.to_string(),
            linear_light: m.space == "linear",
            max_error_lsb: round(m.max_lsb(), 4),
            relative_cost: round(m.time_ms / mip_unit, 3).max(0.001),
        })
        .collect();
    Ok(ErrorTable {
        generated_by: r.command.clone(),
        machine: r.machine.markdown(),
        image_size: r.blur_size,
        blur,
        mip,
    })
}

/// The god-ray rows, pass time relative to 64 samples at full resolution without jitter (a row
/// every sweep, quick or full, measures, and one that does not move when the default does);
/// empty when the sweep did not run.
pub fn god_ray_table(r: &Results) -> GodRayTable {
    let mut god_rays = Vec::new();
    if let Ok(g) = &r.god_rays {
        let unit = g
            .rows
            .iter()
            .find(|x| x.samples == 64 && x.resolution_scale == 1.0 && !x.jitter)
            .and_then(|x| x.god_ray_ms);
        if let Some(unit) = unit {
            for x in &g.rows {
                if let Some(ms) = x.god_ray_ms {
                    god_rays.push(GodRayEntry {
                        samples: x.samples,
                        resolution_scale: x.resolution_scale,
                        jitter: x.jitter,
                        flip_mean: round(x.flip_mean, 5),
                        flip_p99: round(x.flip_p99, 5),
                        relative_cost: round(ms / unit, 3).max(0.001),
                    });
                }
            }
        }
    }
    GodRayTable {
        generated_by: r.command.clone(),
        machine: r.machine.markdown(),
        god_rays,
    }
}
