//! `cooker cook <scene.toml|mesh file> -o <pack> [-v] [--fifo] [--overdraw] [--quantize
//! [--position-bits 16|10|8]]`

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use anyhow::Context;
use cook::{CacheMode, Manifest, Settings};

use crate::exit::{OK, Outcome};
use crate::scene_cache;
use crate::transcript::{Stream, Transcript};

#[derive(clap::Args)]
pub struct Args {
    /// A scene manifest (scene.toml), or a bare .obj/.gltf/.glb/.ply cooked with name heuristics.
    input: PathBuf,
    /// The pack to write (replaced atomically).
    #[arg(short, long)]
    output: PathBuf,
    /// Print per-stage statistics: triangles, ACMR, overfetch, bytes per triangle, time.
    #[arg(short, long)]
    verbose: bool,
    #[command(flatten)]
    settings: SettingsArgs,
    #[command(flatten)]
    cache: crate::cache_cmd::CacheArgs,
}

/// The command line's settings, which override the manifest's.
#[derive(clap::Args)]
pub struct SettingsArgs {
    /// Fast mode: FIFO vertex cache optimization instead of the full optimizer.
    #[arg(long)]
    fifo: bool,
    /// Also reorder opaque ranges to reduce overdraw.
    #[arg(long)]
    overdraw: bool,
    /// Error budget in 8-bit sRGB steps (LSB): per texture, the cheapest blur and mip method
    /// whose measured error stays within it (overrides the manifest's `[scene] max_error`).
    /// `--max-error` is the old spelling.
    #[arg(long = "max-error-lsb", alias = "max-error", value_name = "LSB")]
    max_error: Option<f32>,
    /// How textures are stored: `auto` block-compresses each texture (BC7 colour and
    /// projectors, BC5 normal maps) with the cheapest encoder setting whose measured error
    /// fits the budget (`--max-error-lsb`, RMS; window designs `[textures]
    /// max_design_error_lsb`, normal maps `max_normal_error_deg`) and keeps RGBA8 where none
    /// does; `bc` always compresses; `rgba8` never. Overrides the manifest's `[textures]
    /// format` and every window's `texture_format`.
    #[arg(long, value_name = "auto|rgba8|bc", value_parser = texture_format)]
    texture_format: Option<cook::manifest::TextureFormatChoice>,
    /// Lossless compression of each stored texture level on top of its format (`zstd`, the
    /// default, or `none` for levels a reader can map without decoding). Overrides the
    /// manifest's `[textures] supercompression`.
    #[arg(long, value_name = "zstd|none", value_parser = supercompression)]
    supercompression: Option<pack::Supercompression>,
    /// Store no texture larger than N texels a side: a larger image (colour, normal map, window
    /// design) is cooked from its first mip level that fits, filtered as the mips are. For GPUs
    /// whose limit is below a model's textures (8192 is common) or smaller packs. Overrides the
    /// manifest's `[textures] max_size`.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    max_texture_size: Option<u32>,
    /// Quantize vertices (positions within the mesh's bounds, 16-bit UVs, octahedral
    /// normals); with `-v`, the largest error it made per mesh is reported.
    #[arg(long)]
    quantize: bool,
    /// Bits per axis of quantized positions: 16 (8 bytes), 10 or 8 (4 bytes each).
    #[arg(long, value_name = "BITS", requires = "quantize", default_value = "16",
          value_parser = position_bits)]
    position_bits: cook::mesh::PositionBits,
    /// Use IMAGE as the design of the windows NAME matches: a window name (as `cooker info`
    /// lists them), a material, or a glob over either. Repeatable: where two match a window, the
    /// later one wins. The manifest is not changed, and its `[[window]]` entry for such a
    /// window keeps its normal map, fit and colour space.
    #[arg(long = "window", value_name = "NAME=IMAGE", value_parser = cook::manifest::WindowDesign::parse_override)]
    windows: Vec<(String, PathBuf)>,
    #[command(flatten)]
    model: cook::cli::ModelArgs,
}

impl SettingsArgs {
    /// One resolved value: the manifest's settings, then this command line's.
    pub fn resolve(&self, manifest: &Manifest) -> anyhow::Result<Settings> {
        let mut settings = Settings::new(manifest);
        if let Some(b) = self.max_error {
            if !(b.is_finite() && b >= 0.0) {
                return Err(crate::exit::UsageError(format!(
                    "--max-error-lsb must be a finite number >= 0, got {b}"
                ))
                .into());
            }
            settings.textures.max_error_lsb = Some(b);
        }
        settings.quantize = self.quantize;
        settings.position_bits = self.position_bits;
        settings.window_overrides = cook::manifest::WindowDesign::overrides(&self.windows)?;
        settings.textures.format = self.texture_format;
        settings.textures.supercompression = self.supercompression;
        if let Some(n) = self.max_texture_size {
            settings.textures.max_size = Some(n);
        }
        settings.mesh.cache = if self.fifo {
            CacheMode::Fifo
        } else {
            CacheMode::Full
        };
        settings.mesh.overdraw = self.overdraw;
        self.model.apply(&mut settings);
        settings.check(manifest)?;
        Ok(settings)
    }
}

fn position_bits(s: &str) -> Result<cook::mesh::PositionBits, String> {
    s.parse::<u32>()
        .ok()
        .and_then(cook::mesh::PositionBits::from_bits)
        .ok_or_else(|| format!("{s:?} is not one of 16, 10, 8"))
}

fn texture_format(s: &str) -> Result<cook::manifest::TextureFormatChoice, String> {
    cook::manifest::TextureFormatChoice::CHOICES
        .iter()
        .find(|(n, _)| *n == s)
        .map(|&(_, c)| c)
        .ok_or_else(|| format!("{s:?} is not one of auto, rgba8, bc"))
}

fn supercompression(s: &str) -> Result<pack::Supercompression, String> {
    pack::Supercompression::ALL
        .into_iter()
        .find(|c| c.name() == s)
        .ok_or_else(|| format!("{s:?} is not one of zstd, none"))
}

/// Refuses an output that is one of the cook's inputs, by whatever path or hard link: the
/// rename would replace the model, manifest or image the pack is cooked from.
pub fn refuse_overwriting_an_input<'a>(
    output: &Path,
    inputs: impl IntoIterator<Item = &'a Path>,
) -> anyhow::Result<()> {
    if let Some(input) = inputs.into_iter().find(|i| same_file(output, i)) {
        return Err(crate::exit::UsageError(format!(
            "-o {} is {}, an input of this command; refusing to replace it",
            output.display(),
            input.display()
        ))
        .into());
    }
    Ok(())
}

/// Refuses an `-o` that names a directory, as bad usage, before any work: `example` is the
/// file name the message suggests in it. Every command that writes a file says this alike.
pub fn refuse_a_directory(output: &Path, example: &str) -> anyhow::Result<()> {
    if output.is_dir() {
        return Err(crate::exit::UsageError(format!(
            "-o {}: is a directory; name the file to write in it, e.g. -o {}",
            output.display(),
            output.join(example).display()
        ))
        .into());
    }
    Ok(())
}

/// Whether two paths name one existing file.
pub fn same_file(a: &Path, b: &Path) -> bool {
    let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) else {
        return false;
    };
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        ma.dev() == mb.dev() && ma.ino() == mb.ino()
    }
    #[cfg(not(unix))]
    {
        let _ = (ma, mb);
        matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

fn ms(d: Duration) -> String {
    format!("{:.2} ms", d.as_secs_f64() * 1e3)
}

pub fn run(args: Args) -> Outcome {
    let start = Instant::now();
    // Before the cook, which would otherwise run only to fail at the write with an I/O error.
    refuse_a_directory(&args.output, "scene.pack")?;
    refuse_overwriting_an_input(&args.output, [args.input.as_path()])?;
    let manifest = Manifest::open(&args.input)?;
    let mut settings = args.settings.resolve(&manifest)?;
    // ACMR and overfetch are only printed with -v.
    settings.mesh.analyze = args.verbose;

    // Reuse: the whole pack when no input changed, else each texture whose inputs did not.
    let (cache, remote) = match args.cache.open_for_cook()? {
        Some((c, r)) => (Some(c), r),
        None => (None, None),
    };
    let remote = remote.as_deref();
    let scene_key = match &cache {
        Some(_) => Some(cook::cache::scene_key(
            &args.input,
            &scene_cache::keyed(&args.input, &settings),
        )?),
        None => None,
    };
    if let (Some(cache), Some(key)) = (&cache, &scene_key) {
        match scene_cache::lookup(cache, key, &args.input, &settings, &args.output) {
            scene_cache::Reuse::UpToDate(t) => {
                replay(&t, args.verbose);
                trim(cache, args.verbose);
                crate::cache_cmd::finish_remote(remote, &args.cache)?;
                println!(
                    "{} is up to date: no input changed since it was cooked: {} (reused, {})",
                    args.output.display(),
                    t.summary,
                    ms(start.elapsed())
                );
                return Ok(OK);
            }
            scene_cache::Reuse::Pack(bytes, t, keep) => {
                // A pack from the remote is kept locally while the output is written: two
                // writes of the same bytes, on the two cores.
                let bytes = &bytes[..];
                std::thread::scope(|s| {
                    if let Some(sha) = keep {
                        s.spawn(move || {
                            if let Err(e) = cache.keep_blob(&sha, bytes) {
                                eprintln!("warning: cache not updated: {e}");
                            }
                        });
                    }
                    pack::write_atomic(&args.output, bytes)
                })?;
                replay(&t, args.verbose);
                trim(cache, args.verbose);
                crate::cache_cmd::finish_remote(remote, &args.cache)?;
                println!(
                    "wrote {}: reused the cached pack, no input changed: {} in {}",
                    args.output.display(),
                    t.summary,
                    ms(start.elapsed())
                );
                return Ok(OK);
            }
            scene_cache::Reuse::Cook(why) => {
                if args.verbose {
                    println!("cache: cooking because {why}");
                }
            }
            scene_cache::Reuse::Damaged(why) => eprintln!("warning: cache: {why}"),
        }
    }
    settings.cache = cache.clone();

    let spinner = std::io::stderr().is_terminal().then(|| {
        let pb = indicatif::ProgressBar::new_spinner();
        pb.set_message(format!("cooking {}", args.input.display()));
        pb.enable_steady_tick(Duration::from_millis(100));
        pb
    });
    let result = cook::cook(&manifest, &settings);
    if let Some(pb) = &spinner {
        pb.finish_and_clear();
    }
    let out = result?;
    let report = &out.report;
    refuse_overwriting_an_input(&args.output, report.inputs.iter().map(|p| p.as_path()))?;
    let mut transcript = Transcript::default();
    let verbose = args.verbose;
    for w in &report.warnings {
        transcript.message(Stream::Err, format!("warning: {w}"), verbose);
    }
    for n in &report.notes {
        transcript.message(Stream::Err, format!("note: {n}"), verbose);
    }
    for d in &report.details {
        transcript.message(Stream::Detail, format!("note: {d}"), verbose);
    }
    for group in cook::group_heuristics(&report.heuristics) {
        let h = group[0];
        transcript.message(
            Stream::Err,
            format!(
                "note: {}: {} triangles {} {} tagged {} ({})",
                h.source.display(),
                group.iter().map(|n| n.triangles).sum::<usize>(),
                if group.len() == 1 { "with" } else { "in" },
                cook::group_names(&group),
                h.tagged(),
                h.reason
            ),
            verbose,
        );
    }
    for s in &report.skipped {
        transcript.message(Stream::Out, format!("skipped: {s}"), verbose);
    }
    transcript.print_details_left_out(verbose);

    // A remote that must answer and did not fails the cook before it touches the output.
    crate::cache_cmd::check_remote(remote, &args.cache)?;
    let write_start = Instant::now();
    crate::alloc::release_free();
    // Validated while the file is written and synced; renamed into place only when valid.
    let bytes = pack::write_pack(&args.output, out.toc.clone(), &out.data)
        // The pack error names the path; the context says what was being done with it.
        .context("writing the pack")?;
    let reused = report
        .artifacts
        .iter()
        .filter(|(_, s)| *s == cook::ArtifactSource::Reused)
        .count();
    if cache.is_some() {
        println!(
            "cache: {} textures reused, {} cooked",
            reused,
            report.artifacts.len() - reused
        );
    }
    for (name, source) in &report.artifacts {
        match source {
            cook::ArtifactSource::Recooked(why) => eprintln!("warning: {why}; re-cooked {name}"),
            s if args.verbose => println!(
                "  {:<8} {name}",
                if *s == cook::ArtifactSource::Reused {
                    "reused"
                } else {
                    "cooked"
                }
            ),
            _ => {}
        }
    }
    let write_time = write_start.elapsed();

    let triangles: u64 = out
        .toc
        .meshes
        .iter()
        .map(|m| m.index_count as u64 / 3)
        .sum();
    transcript.stats = stats(&out, write_time, settings.mesh.analyze);
    if args.verbose {
        transcript.print_stats();
    }
    transcript.summary = format!(
        "{} meshes, {triangles} triangles, {} materials, {} textures, {} bytes",
        out.toc.meshes.len(),
        out.toc.materials.len(),
        out.toc.textures.len(),
        bytes.len()
    );
    transcript.textures = report.artifacts.iter().map(|(n, _)| n.clone()).collect();
    if let (Some(cache), Some(key)) = (&cache, &scene_key)
        && let Err(e) = scene_cache::store(
            cache,
            scene_cache::Cooked {
                key,
                manifest: &args.input,
                settings: &settings,
                inputs: &report.inputs,
                absent: &report.absent,
                pack: &bytes,
                transcript: &transcript,
            },
        )
    {
        eprintln!("warning: cache not updated: {e:#}");
    }
    if let Some(cache) = &cache {
        trim(cache, args.verbose);
    }
    crate::cache_cmd::finish_remote(remote, &args.cache)?;
    println!(
        "wrote {}: {} in {}",
        args.output.display(),
        transcript.summary,
        ms(start.elapsed())
    );
    Ok(OK)
}

/// Keeps the local cache under its cap; a failure only costs space, never the cook.
fn trim(cache: &cook::cache::Cache, verbose: bool) {
    match cache.trim() {
        Ok(t) if t.evicted > 0 && verbose => println!(
            "cache: {} entries evicted ({} -> {} bytes, cap {})",
            t.evicted,
            t.before,
            t.after,
            cache.max_size()
        ),
        Ok(_) => {}
        // With its cause: the path alone ("cache not trimmed: rocache") said nothing of why.
        Err(e) => eprintln!("warning: cache not trimmed: {:#}", anyhow::Error::new(e)),
    }
}

/// Says again what the cook of a reused pack said, and that every texture was reused.
fn replay(t: &Transcript, verbose: bool) {
    t.print_messages(verbose);
    println!("cache: {} textures reused, 0 cooked", t.textures.len());
    if verbose {
        for name in &t.textures {
            println!("  {:<8} {name}", "reused");
        }
        println!("cache: the pack and the statistics below are those of the cook it reuses");
        t.print_stats();
    }
}

/// `analyzed`: whether the cook measured ACMR and overfetch (only with -v); a transcript kept
/// in the cache without them said 0.000 when a later `-v` replayed it.
fn stats(out: &cook::CookOutput, write_time: Duration, analyzed: bool) -> Vec<String> {
    const NOT_MEASURED: &str = "not measured (the cook ran without -v)";
    let mut lines = Vec::new();
    let report = &out.report;
    let (mut tri_in, mut tri_out, mut acmr_in, mut acmr_out, mut bytes) =
        (0usize, 0usize, 0f64, 0f64, 0usize);
    for m in &report.meshes {
        let s = &m.stats;
        lines.push(format!("mesh {:?} ({})", m.name, m.source.display()));
        lines.push(format!(
            "  {:<14} {:>9} -> {:>9} triangles  {:>10}  ({} n-gons split)",
            "import",
            s.triangles_in,
            s.triangles_in,
            ms(m.import_time),
            m.polygons
        ));
        let mut tris = s.triangles_in;
        for (name, t) in &s.stages {
            let after = if *name == "filter+group" {
                s.triangles_in - s.degenerate_dropped
            } else {
                tris
            };
            let extra = match *name {
                "filter+group" => format!("  ({} degenerate dropped)", s.degenerate_dropped),
                "normals" => format!(
                    "  ({} of {} corners generated)",
                    s.normals_generated, s.corners
                ),
                "tangents+dedupe" => format!(
                    "  ({} triangles with tangents, {} corners)",
                    s.tangent_triangles, s.corners
                ),
                "dedupe" => format!("  ({} corners)", s.corners),
                _ => String::new(),
            };
            lines.push(format!(
                "  {:<14} {:>9} -> {:>9} triangles  {:>10}{extra}",
                name,
                tris,
                after,
                ms(*t)
            ));
            tris = after;
        }
        let mesh_bytes = m.vertex_bytes + m.index_bytes;
        let overfetch = if analyzed {
            lines.push(format!(
                "  acmr_in={:.3} acmr_out={:.3}",
                s.acmr_in, s.acmr_out
            ));
            format!("overfetch={:.3}", s.overfetch)
        } else {
            lines.push(format!("  acmr {NOT_MEASURED}"));
            "overfetch not measured".to_string()
        };
        lines.push(format!(
            "  {overfetch} vertices={} bytes/triangle={:.2} (vertices {} B, indices {} B)",
            s.vertices_out,
            mesh_bytes as f64 / s.triangles_out.max(1) as f64,
            m.vertex_bytes,
            m.index_bytes
        ));
        if !m.dropped_attributes.is_empty() {
            lines.push(format!(
                "  attributes dropped (no material uses them): {}",
                m.dropped_attributes.join(", ")
            ));
        }
        if let Some(q) = m.quantization {
            lines.push(format!(
                "  quantization error: position {:.3e} (world units), normal {:.4} deg, uv {:.3e}",
                q.position, q.normal_deg, q.uv
            ));
        }
        tri_in += s.triangles_in;
        tri_out += s.triangles_out;
        acmr_in += s.acmr_in as f64 * s.triangles_out as f64;
        acmr_out += s.acmr_out as f64 * s.triangles_out as f64;
        bytes += mesh_bytes;
    }
    // Each stage's time and the process's peak memory once it ended: the first stage showing
    // the final figure is the one that set it.
    let peak = |bytes: Option<u64>| {
        bytes.map_or_else(String::new, |b| {
            format!("  peak RSS {:.1} MB", b as f64 / 1e6)
        })
    };
    let write = ("write", write_time, cook::peak_rss());
    let stages = report.stages.iter().map(|s| (s.name, s.time, s.peak_rss));
    for (name, time, rss) in stages.chain([write]) {
        lines.push(format!("stage {name:<12} {:>10}{}", ms(time), peak(rss)));
        if let ("mesh", Some(t)) = (name, report.guess_time) {
            lines.push(format!(
                "  guessed light and cameras {:>10} (beside the mesh stage's normals and dedupe)",
                ms(t)
            ));
        }
    }
    let n = tri_out.max(1) as f64;
    let acmr = if analyzed {
        format!("acmr_in={:.3} acmr_out={:.3}", acmr_in / n, acmr_out / n)
    } else {
        format!("acmr {NOT_MEASURED}")
    };
    lines.push(format!(
        "total: triangles {tri_in} -> {tri_out} {acmr} bytes/triangle={:.2}",
        bytes as f64 / n
    ));
    lines
}
