//! `viewer`: renders a cooked pack (or a `scene.toml` or bare mesh, cooked first) with the
//! stained-glass renderer, in a window (`interactive`: fly camera, views of each pass, egui
//! panel, `--watch`) or `--headless`: PNGs per camera, optionally every intermediate pass, and
//! per-pass GPU times. Both draw through `render::Renderer::render_to`.

mod god_rays;
mod interactive;

use std::collections::VecDeque;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::sync::{Arc, mpsc};
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::Parser;
use render::{
    FrameReport, GodRaySettings, Gpu, PassId, Renderer, Scene, Settings, TargetId, TimingMethod,
    Upload, View,
};

#[derive(Parser, Debug)]
#[command(
    version,
    about = "View a stained-glass pack or scene.toml (headless: PNGs and per-pass timings)",
    after_help = "Exit codes: 0 success, 1 a failed render (no GPU adapter, a device lost), 2 bad \
usage (an option, or a camera the pack does not have), 3 invalid input (a pack or model that \
fails validation; the message names the file), 4 operating-system I/O error (reading the \
input, writing a PNG)."
)]
struct Args {
    /// A cooked `.pack`, or a `scene.toml` or bare .obj/.gltf/.glb/.ply to cook first.
    input: PathBuf,
    /// Cook with IMAGE as the design of the windows NAME matches (a window name, a material,
    /// or a glob); repeatable, as `cooker cook --window`.
    #[arg(long = "window", value_name = "NAME=IMAGE", value_parser = cook::manifest::WindowDesign::parse_override)]
    windows: Vec<(String, PathBuf)>,
    #[command(flatten)]
    model: cook::cli::ModelArgs,
    /// Render to files instead of opening a window (the only mode without a display).
    #[arg(long)]
    headless: bool,
    /// Directory for the images (created if needed).
    #[arg(long, default_value = "viewer-out")]
    out: PathBuf,
    /// Image size, WxH.
    #[arg(long, default_value = "1280x720", value_parser = parse_size)]
    size: (u32, u32),
    /// A camera name from the pack; every camera when absent, or `all` (unless the pack has
    /// a camera named so, which `all` then picks).
    #[arg(long)]
    camera: Option<String>,
    /// Also write each intermediate pass (and the shadow map), and say which windows got a
    /// shadow map and why. The background, lit and god-ray passes hold radiance past 1 and
    /// are written tone-mapped, as the composite shows them at exposure 1.
    #[arg(long)]
    passes: bool,
    /// Say which windows got a shadow map and why (also printed with --passes), and where the
    /// first frame's time went.
    #[arg(short, long)]
    verbose: bool,
    /// Draw the first frame at full size even on a CPU rasterizer, which otherwise draws a
    /// half-size preview first.
    #[arg(long)]
    no_preview: bool,
    /// Load no texture level larger than N texels a side: a larger texture starts at its first
    /// smaller mip level (as for one over the device's own limit, which always applies). For
    /// GPUs with little memory, or to see a pack as such a device would.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    max_texture_size: Option<u32>,
    /// Window light passes through stone, as plain projective texturing does (no shadow maps).
    #[arg(long)]
    no_occlusion: bool,
    /// Cook a scene without the local texture cache `cooker cook` fills and reads
    /// (`$STAINED_GLASS_CACHE`, else `$XDG_CACHE_HOME/stained-glass` or `~/.cache/stained-glass`).
    #[arg(long)]
    no_cache: bool,
    /// Render N frames per camera and print the median time of each pass.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
    bench: Option<u32>,
    /// Largest god-ray error to accept, as a FLIP mean (0 = identical, 1 = worst); picks
    /// samples, ray scale and jitter. `--max-error` is the old spelling.
    ///
    /// The error is the FLIP mean of the final image against a 4096-sample render, as measured
    /// on the default scene and committed in crates/render/src/god_ray_table.json. The
    /// cheapest measured setting within the budget is used and printed with its measured
    /// error; a budget tighter than every measured setting gets the most accurate one and a
    /// warning. Cannot be combined with --samples, --ray-scale, --jitter or --half-res-rays.
    #[arg(
        long = "max-flip",
        alias = "max-error",
        value_name = "FLIP_MEAN",
        value_parser = god_rays::parse_flip_mean,
        conflicts_with_all = ["samples", "ray_scale", "jitter", "half_res_rays"]
    )]
    max_flip: Option<f32>,
    /// God-ray samples per pixel (1..=1024).
    #[arg(
        long,
        default_value_t = GodRaySettings::default().samples,
        value_parser = clap::value_parser!(u32).range(1..=render::MAX_GOD_RAY_SAMPLES as i64)
    )]
    samples: u32,
    /// God-ray target size relative to the frame: 1 full, 0.5 half, 0.25 quarter.
    #[arg(
        long,
        value_name = "SCALE",
        default_value_t = GodRaySettings::default().resolution_scale,
        value_parser = god_rays::parse_scale
    )]
    ray_scale: f32,
    /// Per-pixel jitter of the god-ray samples (trades banding for noise; off by default).
    #[arg(long)]
    jitter: bool,
    /// Shorthand for `--ray-scale 0.5 --jitter`.
    #[arg(long, conflicts_with = "ray_scale")]
    half_res_rays: bool,
    /// Window: re-cook a scene.toml or model and swap the scene in when one of its sources
    /// changes.
    #[arg(long)]
    watch: bool,
    /// Window: present without waiting for vertical sync.
    #[arg(long)]
    no_vsync: bool,
    /// Window: synthetic input for tests (steps separated by `;`, see interactive/script.rs).
    #[arg(long, hide = true)]
    script: Option<String>,
}

/// Lowers the largest texture side loaded to `--max-texture-size` where given; the device's
/// own limit still applies above it.
fn cap_texture_side(gpu: &mut Gpu, max: Option<u32>) {
    if let Some(max) = max {
        gpu.max_texture_side = gpu.max_texture_side.min(max);
    }
}

fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size {s:?} is not WxH"))?;
    let w: u32 = w
        .parse()
        .map_err(|_| format!("width {w:?} is not a number"))?;
    let h: u32 = h
        .parse()
        .map_err(|_| format!("height {h:?} is not a number"))?;
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(format!("size {w}x{h} must be 1..=16384 on each axis"));
    }
    Ok((w, h))
}

enum Message {
    Toc(pack::Toc),
    Section(Upload),
    Done,
    Failed(pack::PackError),
}

/// Reads sections on a thread so uploads and the first frame overlap the file read. Their
/// decoding (zstd, and block-compressed levels where the device does not sample them:
/// `caps` is the device's [`Gpu::texture_caps`]) runs on the thread pool, a
/// few sections at once, and the sections are handed over in file order: on a CPU rasterizer
/// the large levels after the first frame were decoded one by one while the drawing thread
/// waited for them.
fn stream(
    path: PathBuf,
    (source, length): Source,
    caps: render::TextureCaps,
) -> mpsc::Receiver<Message> {
    let (tx, rx) = mpsc::sync_channel(16);
    std::thread::spawn(move || {
        type Job = mpsc::Receiver<Result<Upload, pack::PackError>>;
        let in_flight = 2 * rayon::current_num_threads();
        // Hands the oldest jobs' sections over until at most `keep` are pending; false when
        // the receiver has gone.
        let forward = |pending: &mut VecDeque<Job>, keep: usize| -> Result<bool, pack::PackError> {
            while pending.len() > keep {
                let job = pending.pop_front().expect("more than keep pending");
                let upload = job
                    .recv()
                    .expect("a decoding job answers unless it panicked")?;
                if tx.send(Message::Section(upload)).is_err() {
                    return Ok(false);
                }
            }
            Ok(true)
        };
        let result = (|| -> Result<(), pack::PackError> {
            let mut reader = pack::StreamReader::with_length(&path, source, length)?;
            let mut toc: Option<Arc<pack::Toc>> = None;
            let mut pending: VecDeque<Job> = VecDeque::new();
            loop {
                let raw = match reader.next_raw() {
                    Ok(Some(raw)) => raw,
                    Ok(None) => break,
                    Err(e) => {
                        // Sections before the bad one still arrive, and an error in one of
                        // them is the one to report, as a reader in file order would.
                        forward(&mut pending, 0)?;
                        return Err(e);
                    }
                };
                let Some(toc) = &toc else {
                    let t = reader.toc().cloned().expect("TOC decoded with section 0");
                    toc = Some(Arc::new(t.clone()));
                    if tx.send(Message::Toc(t)).is_err() {
                        return Ok(());
                    }
                    continue;
                };
                if !Upload::needed(toc, raw.role(), caps) {
                    continue;
                }
                let (done, job) = mpsc::sync_channel(1);
                let toc = Arc::clone(toc);
                rayon::spawn(move || {
                    let upload = raw
                        .decode(&toc)
                        .map(|section| Upload::prepare(&toc, section, caps));
                    let _ = done.send(upload);
                });
                pending.push_back(job);
                if !forward(&mut pending, in_flight)? {
                    return Ok(());
                }
            }
            forward(&mut pending, 0)?;
            Ok(())
        })();
        let _ = tx.send(match result {
            Ok(()) => Message::Done,
            Err(e) => Message::Failed(e),
        });
    });
    rx
}

/// `-v`: the cook's notes (blur, mip and encoder choices) are printed too.
static VERBOSE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// How a scene.toml or model is cooked (`--window`, `--up`, `--text-encoding`): set once from
/// the command line, before either mode starts; every cook and re-cook (`--watch`) uses it.
struct CookOptions {
    windows: Vec<cook::manifest::WindowDesign>,
    model: cook::cli::ModelArgs,
    /// Textures from `cooker cook`'s local cache, and into it: a scene cooked before shows in
    /// a fraction of the cook (the default scene: 658 → 87 ms on this project's VM).
    cache: bool,
}

static COOK_OPTIONS: std::sync::OnceLock<CookOptions> = std::sync::OnceLock::new();

/// Per cooked scene, what its last cook read and the folders where it looked for files its
/// sources name but it did not find: what `--watch` polls beside what the manifest names
/// (the textures an MTL names, a glTF's images and buffers).
static COOKED_FROM: std::sync::Mutex<Vec<(PathBuf, Vec<PathBuf>)>> =
    std::sync::Mutex::new(Vec::new());

fn record_cooked_from(manifest: &Path, report: &cook::Report) {
    let mut paths = report.inputs.clone();
    for a in &report.absent {
        // A file appearing changes its folder's modification time: the nearest folder that
        // exists on the way to where it was looked for.
        let wanted = a.dir.join(a.name.replace('\\', "/"));
        let folder = wanted.ancestors().skip(1).find(|d| d.is_dir());
        paths.push(folder.unwrap_or(&a.dir).to_path_buf());
    }
    let mut all = COOKED_FROM.lock().unwrap_or_else(|e| e.into_inner());
    all.retain(|(m, _)| m != manifest);
    all.push((manifest.to_path_buf(), paths));
}

/// What the last cook of `manifest` read, and where it looked in vain (see [`COOKED_FROM`]).
pub fn cooked_from(manifest: &Path) -> Vec<PathBuf> {
    let all = COOKED_FROM.lock().unwrap_or_else(|e| e.into_inner());
    all.iter()
        .find(|(m, _)| m == manifest)
        .map_or_else(Vec::new, |(_, p)| p.clone())
}

/// Whether `path` is a cooked pack: by its extension, or by its first bytes (a pack renamed
/// without `.pack` was taken for a model of no known format).
/// The one camera `--camera` asks for, or `None` for every camera: absent, or `all` where no
/// camera of `names` is called so (one called `all` could not be drawn alone).
fn one_camera<'a>(camera: &'a Option<String>, names: &[&str]) -> Option<&'a str> {
    camera
        .as_deref()
        .filter(|&c| c != "all" || names.contains(&"all"))
}

fn is_pack(path: &Path) -> bool {
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("pack"))
    {
        return true;
    }
    let mut head = [0u8; 8];
    std::fs::File::open(path)
        .and_then(|mut f| f.read_exact(&mut head))
        .is_ok_and(|()| head == pack::format::MAGIC)
}

/// A pack's bytes, and their length where it is known (a file).
type Source = (Box<dyn Read + Send>, Option<u64>);

fn open_source(path: &Path) -> Result<Source> {
    if !is_pack(path) {
        let start = Instant::now();
        // Its errors name the file already.
        let manifest = cook::Manifest::open(path)?;
        let mut settings = cook::Settings::new(&manifest);
        if let Some(o) = COOK_OPTIONS.get() {
            settings.window_overrides = o.windows.clone();
            o.model.apply(&mut settings);
            if o.cache {
                match cook::cache::Cache::open(cook::cache::Cache::default_dir()) {
                    Ok(c) => settings.cache = Some(c),
                    Err(e) => eprintln!(
                        "warning: cache directory {:#}; cooking without a cache",
                        anyhow::Error::new(e)
                    ),
                }
            }
        }
        let out = cook::cook(&manifest, &settings)
            .with_context(|| format!("cooking {}", path.display()))?;
        // As after `cooker cook`: the least recently used entries past the default cap go.
        if let Some(cache) = &settings.cache
            && let Err(e) = cache.trim()
        {
            eprintln!("warning: cache not trimmed: {:#}", anyhow::Error::new(e));
        }
        record_cooked_from(path, &out.report);
        for w in &out.report.warnings {
            eprintln!("warning: {w}");
        }
        if VERBOSE.load(std::sync::atomic::Ordering::Relaxed) {
            for n in out.report.notes.iter().chain(&out.report.details) {
                eprintln!("note: {n}");
            }
        }
        let bytes = pack::encode(out.toc, &out.data).context("encoding the cooked pack")?;
        println!(
            "cooked {} in {:.0} ms ({} bytes)",
            path.display(),
            start.elapsed().as_secs_f64() * 1e3,
            bytes.len()
        );
        let length = bytes.len() as u64;
        Ok((Box::new(std::io::Cursor::new(bytes)), Some(length)))
    } else {
        let file =
            std::fs::File::open(path).with_context(|| format!("opening {}", path.display()))?;
        // A pipe or a device has no length to hold the header to.
        let length = file
            .metadata()
            .ok()
            .filter(|m| m.is_file())
            .map(|m| m.len());
        Ok((
            Box::new(std::io::BufReader::with_capacity(1 << 20, file)),
            length,
        ))
    }
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Streams the pack into a GPU scene, drawing a first frame as soon as the geometry and the
/// small mips are in and reporting both times.
fn load(gpu: &Gpu, args: &Args, settings: Settings) -> Result<(Scene, Renderer)> {
    // Cooking (for a scene.toml) is reported on its own; the clock starts with the stream.
    let source = open_source(&args.input)?;
    let start = Instant::now();
    let rx = stream(args.input.clone(), source, gpu.texture_caps());
    let mut scene: Option<(Scene, Renderer, View)> = None;
    let mut first_frame = false;
    // Where the first frame's time goes, for `-v`: waiting for the reader, scene and renderer
    // creation (pipelines), uploads, and the frame itself.
    let mut waited = Duration::ZERO;
    let mut uploads = Duration::ZERO;
    let mut created = Duration::ZERO;
    // And from the first frame to full quality: waiting for the reader, uploads, the last frame.
    let mut waited_after = Duration::ZERO;
    let mut uploads_after = Duration::ZERO;
    loop {
        let wait = Instant::now();
        let message = rx.recv().context("pack reader thread ended unexpectedly")?;
        if !first_frame {
            waited += wait.elapsed();
        } else {
            waited_after += wait.elapsed();
        }
        match message {
            Message::Toc(toc) => {
                let create = Instant::now();
                let s = Scene::new(gpu, &toc)?;
                let div = if args.no_preview {
                    1
                } else {
                    gpu.first_frame_divisor()
                };
                let (w, h) = ((args.size.0 / div).max(1), (args.size.1 / div).max(1));
                let r = Renderer::headless(gpu, &s, w, h, settings)?;
                created = create.elapsed();
                let view = first_view(&s, &r);
                scene = Some((s, r, view));
            }
            Message::Section(section) => {
                let (s, r, view) = scene.as_mut().context("section before the TOC")?;
                let upload = Instant::now();
                s.upload_section(gpu, &section)
                    .with_context(|| args.input.display().to_string())?;
                if !first_frame {
                    uploads += upload.elapsed();
                } else {
                    uploads_after += upload.elapsed();
                }
                if !first_frame && s.ready_for_first_frame() {
                    let frame = Instant::now();
                    s.refresh(gpu);
                    r.render(gpu, s, view, TimingMethod::None)?;
                    gpu.wait()?;
                    first_frame = true;
                    let st = s.status();
                    let (w, h) = r.size();
                    let preview = if (w, h) == args.size {
                        String::new()
                    } else {
                        format!("{w}x{h} preview, ")
                    };
                    // From the stream's start, as the bench reads it; and from the process's,
                    // which the device's creation and a cook are part of (it was left unsaid).
                    println!(
                        "first frame after {:.1} ms ({preview}geometry + {}/{} mips, {} bytes \
                         uploaded; {:.1} ms since the viewer started)",
                        ms(start.elapsed()),
                        st.mips_loaded,
                        st.mips_total,
                        st.bytes_uploaded,
                        ms(started().elapsed())
                    );
                    if r.size() != args.size {
                        r.resize(gpu, args.size.0, args.size.1);
                        *view = first_view(s, r);
                    }
                    if args.verbose {
                        println!(
                            "first frame: waiting for the reader {:.1} ms, scene and renderer \
                             (pipelines) {:.1} ms, uploads {:.1} ms, frame {:.1} ms",
                            ms(waited),
                            ms(created),
                            ms(uploads),
                            ms(frame.elapsed())
                        );
                    }
                }
            }
            Message::Done => break,
            // The pack's errors name the file already ("reading X: X: ..." before).
            Message::Failed(e) => return Err(e.into()),
        }
    }
    let (mut s, mut r, mut view) = scene.context("empty pack")?;
    // A pack of no sections (no mesh, no texture) drew no first frame, so the renderer was
    // still the preview's: its frames were written at half the size asked for.
    if r.size() != args.size {
        r.resize(gpu, args.size.0, args.size.1);
        view = first_view(&s, &r);
    }
    let last_frame = Instant::now();
    s.refresh(gpu);
    r.render(gpu, &s, &view, TimingMethod::None)?;
    gpu.wait()?;
    println!(
        "full quality after {:.1} ms ({} bytes uploaded)",
        ms(start.elapsed()),
        s.status().bytes_uploaded
    );
    if args.verbose {
        println!(
            "full quality: after the first frame, waiting for the reader {:.1} ms, uploads {:.1} ms, \
             last frame {:.1} ms",
            ms(waited_after),
            ms(uploads_after),
            ms(last_frame.elapsed())
        );
    }
    Ok((s, r))
}

/// The pack's first camera at the renderer's aspect ratio, or a view framing the scene.
fn first_view(scene: &Scene, renderer: &Renderer) -> View {
    match scene.toc().cameras.first() {
        Some(c) => renderer.view_for(c),
        None => {
            let (lo, hi) = scene.framing_bounds();
            let (w, h) = renderer.size();
            View::framing(lo, hi, w as f32 / h as f32)
        }
    }
}

/// Each camera's image file stem: its name with letters and digits kept (in any script:
/// "Вид" and "Пол" were both "___"), other characters `_`, and `_2`, `_3` … after a stem an
/// earlier camera took (compared without case, as Windows and macOS file systems do).
fn file_names<'a>(cameras: impl IntoIterator<Item = &'a str>) -> Vec<String> {
    let mut taken = std::collections::HashSet::new();
    cameras
        .into_iter()
        .map(|camera| {
            let s: String = camera
                .chars()
                .map(|c| {
                    let kept = if c.is_ascii() {
                        c.is_ascii_alphanumeric() || c == '-' || c == '_'
                    } else {
                        c.is_alphanumeric()
                    };
                    if kept { c } else { '_' }
                })
                .collect();
            let stem = if s.is_empty() {
                "camera".to_string()
            } else {
                s
            };
            let mut name = stem.clone();
            let mut n = 1;
            while !taken.insert(name.to_lowercase()) {
                n += 1;
                name = format!("{stem}_{n}");
            }
            name
        })
        .collect()
}

fn print_report(
    label: &str,
    method: TimingMethod,
    medians: &[(PassId, Option<f64>, Option<&'static str>)],
) {
    let how = match method {
        TimingMethod::GpuTimestamps => "GPU timestamp queries",
        TimingMethod::CpuWallClock => {
            "CPU wall clock per pass (no timestamp queries on this device)"
        }
        TimingMethod::None => "not timed",
    };
    println!("{label}: median per-pass time ({how})");
    let mut total = 0.0;
    for (pass, ms, skipped) in medians {
        match (ms, skipped) {
            (_, Some(why)) => println!("  {:<18} skipped ({why})", pass.name()),
            (Some(t), None) => {
                total += t;
                println!("  {:<18} {t:8.3} ms", pass.name());
            }
            (None, None) => println!("  {:<18} (no time)", pass.name()),
        }
    }
    println!("  {:<18} {total:8.3} ms", "total");
    if medians
        .iter()
        .any(|(p, ms, _)| *p == PassId::Shadows && ms.is_some())
    {
        println!(
            "  (shadow maps are redrawn only when the light or the geometry changes; the total \
             counts them every frame)"
        );
    }
}

fn bench(
    gpu: &Gpu,
    scene: &Scene,
    r: &mut Renderer,
    view: &View,
    frames: u32,
    label: &str,
) -> Result<()> {
    let mut reports: Vec<FrameReport> = Vec::new();
    // One untimed frame first, so pipeline compilation is not measured.
    r.render(gpu, scene, view, TimingMethod::None)?;
    for _ in 0..frames.max(1) {
        // The maps are view-independent and kept between frames; redraw them each frame here
        // so their cost is measured (the report says they are cached otherwise).
        r.invalidate_shadow_maps();
        reports.push(r.render(gpu, scene, view, TimingMethod::GpuTimestamps)?);
    }
    let method = reports[0].method;
    let medians: Vec<_> = PassId::ALL
        .iter()
        .map(|&id| {
            let mut times: Vec<f64> = reports
                .iter()
                .filter_map(|rep| rep.passes.iter().find(|p| p.pass == id).and_then(|p| p.ms))
                .collect();
            times.sort_by(f64::total_cmp);
            let skipped = reports[0]
                .passes
                .iter()
                .find(|p| p.pass == id)
                .and_then(|p| p.skipped);
            (id, median(&times), skipped)
        })
        .collect();
    print_report(label, method, &medians);
    Ok(())
}

/// The median of sorted `times`: the mean of the middle two where their count is even.
fn median(times: &[f64]) -> Option<f64> {
    let n = times.len();
    match n {
        0 => None,
        _ if n % 2 == 1 => Some(times[n / 2]),
        _ => Some((times[n / 2 - 1] + times[n / 2]) * 0.5),
    }
}

/// One line per window: whether its light gets a shadow map, and why.
fn print_window_shadows(scene: &Scene) {
    let toc = scene.toc();
    let decisions = scene.window_shadows();
    let maps = decisions.iter().filter(|d| d.needs_map()).count();
    println!(
        "shadow maps: {maps} of {} windows' light can be blocked",
        decisions.len()
    );
    let backed = scene.backed_windows();
    for (i, (w, d)) in toc.windows.iter().zip(decisions).enumerate() {
        let name = toc
            .materials
            .get(w.material as usize)
            .map_or("?", |m| m.name.as_str());
        let wall = if backed.get(i).copied().unwrap_or(false) {
            " (its glass sits on a wall not cut open behind it: that wall is taken as open)"
        } else {
            ""
        };
        println!(
            "  window {i} ({}): {}{wall}",
            cook::shown(name),
            d.describe()
        );
    }
}

/// The renderer's settings with the god-ray quality from `--max-flip` or the explicit flags
/// (clap rejects both together); prints which setting it is and what it was measured at.
fn god_ray_settings(args: &Args) -> Result<Settings> {
    let mut settings = Settings::default();
    let g = &mut settings.god_rays;
    if let Some(budget) = args.max_flip {
        let choice = god_rays::apply_budget(budget, g)?;
        if let Some(w) = &choice.warning {
            eprintln!("warning: {w}");
        }
        println!(
            "god rays for --max-flip {budget}: {}; {}",
            god_rays::describe(g),
            god_rays::measured_note(g)
        );
        return Ok(settings);
    }
    g.samples = args.samples;
    g.resolution_scale = if args.half_res_rays {
        0.5
    } else {
        args.ray_scale
    };
    g.jitter = args.jitter || args.half_res_rays;
    println!(
        "god rays: {}; {}",
        god_rays::describe(g),
        god_rays::measured_note(g)
    );
    Ok(settings)
}

/// glibc maps every block from 128 KiB up on its own and unmaps it when freed, so each
/// streamed section's buffers (the file's bytes, zstd's output, decoded texels) were faulted
/// in and zeroed afresh by the kernel, on a CPU rasterizer's cores. Blocks up to 64 MiB now
/// come from heaps that are never trimmed, so freed buffers are reused; two arenas keep the
/// reader and the rasterizer's threads from contending for one. The default scene on
/// lavapipe, 20 interleaved rounds: full quality 973 -> 947 ms, peak RSS 251 -> 258 MB.
fn tune_allocator() {
    // SAFETY: called first thing in main, before any other thread exists; mallopt only
    // changes allocator parameters.
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 64 << 20);
        libc::mallopt(libc::M_TRIM_THRESHOLD, i32::MAX);
        libc::mallopt(libc::M_ARENA_MAX, 2);
    }
}

/// Writes an image as PNG through a temp file and a rename, so a failed write (a full disk, a
/// killed run) leaves no cut-short PNG where a frame is expected.
fn write_png(img: image::RgbaImage, path: &Path) -> Result<()> {
    let mut png = Vec::new();
    image::DynamicImage::ImageRgba8(img)
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .with_context(|| format!("encoding {}", path.display()))?;
    pack::write_atomic(path, &png).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Exit codes as the cooker's: 3 for invalid input (a pack or model that fails validation,
/// the message naming it), 4 for an operating-system I/O error, 2 for bad usage (clap's); 1
/// for anything else that failed (no GPU adapter, a device lost).
fn main() -> std::process::ExitCode {
    cook::cli::exit_on_failed_output();
    match run() {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            use std::io::Write;
            // The failure's own code, even where stderr cannot take its message.
            let _ = writeln!(std::io::stderr(), "error: {e:#}");
            std::process::ExitCode::from(exit_code(&e))
        }
    }
}

fn exit_code(e: &anyhow::Error) -> u8 {
    e.chain()
        .find_map(|c| {
            if c.is::<Usage>() {
                return Some(2);
            }
            // A pack whose geometry disagrees with its table of contents is invalid input.
            if let Some(render::RenderError::VertexLayout { .. }) = c.downcast_ref() {
                return Some(3);
            }
            // A PNG that cannot be written is an I/O error however the encoder wraps it.
            if let Some(image::ImageError::IoError(_)) = c.downcast_ref::<image::ImageError>() {
                return Some(4);
            }
            cook::exit_code(c)
        })
        .map_or(1, |code| code as u8)
}

/// Makes the `--out` directory. A file where it or a folder above it should be is bad usage
/// (exit 2), as `--out` naming a file is; only the system's refusal (permissions, a full
/// disk) is an I/O error (exit 4). `--out notes.txt/frames` exited 4 and `--out notes.txt` 2.
fn create_out(out: &Path) -> anyhow::Result<()> {
    out_in_the_way(out)?;
    std::fs::create_dir_all(out).with_context(|| format!("creating {}", out.display()))
}

/// A file where the `--out` directory or a folder above it should be: bad usage.
fn out_in_the_way(out: &Path) -> anyhow::Result<()> {
    if let Some(file) = out
        .ancestors()
        .filter(|a| !a.as_os_str().is_empty())
        .find(|a| a.exists() && !a.is_dir())
    {
        return Err(Usage(format!(
            "--out {}: {} is a file, not a directory; the images go in a directory",
            out.display(),
            file.display()
        ))
        .into());
    }
    Ok(())
}

/// Whether images can be written under `out`, asked before the render: a probe folder made and
/// removed where `out` is or would be made, so a refused input still leaves nothing behind.
/// `--out /proc/x` failed with exit 4 after the whole render (minutes, at a large size).
fn out_writable(out: &Path) -> anyhow::Result<()> {
    let base = out
        .ancestors()
        .find(|a| a.as_os_str().is_empty() || a.is_dir())
        .filter(|a| !a.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let probe = base.join(format!(".viewer-probe-{}", std::process::id()));
    std::fs::create_dir(&probe).with_context(|| format!("creating {}", out.display()))?;
    let _ = std::fs::remove_dir(&probe);
    Ok(())
}

/// Bad usage that shows only once the pack is read (a camera it does not have): exit 2, as
/// clap's usage errors; it exited 1, the code of a failed render.
#[derive(Debug)]
struct Usage(String);

impl std::fmt::Display for Usage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Usage {}

/// When the process started (near enough: the first thing `run` does).
fn started() -> Instant {
    static STARTED: std::sync::OnceLock<Instant> = std::sync::OnceLock::new();
    *STARTED.get_or_init(Instant::now)
}

fn run() -> Result<()> {
    started();
    // Rust ignores SIGPIPE, so a closed stdout (`viewer p.pack --headless | head`) made the
    // next `println!` panic; like other Unix tools, stop quietly instead.
    // SAFETY: first thing in main, before any other thread exists; SIG_DFL is a valid
    // disposition for SIGPIPE.
    #[cfg(unix)]
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    tune_allocator();
    let args = Args::parse();
    // Before the GPU is set up (a quarter of a second on lavapipe, more on a cold driver), so
    // a mistyped path fails at once.
    let input = std::fs::metadata(&args.input).with_context(|| args.input.display().to_string())?;
    if input.is_dir() {
        // It was read as a model of no known format: 'unsupported mesh format ""'.
        return Err(anyhow::Error::new(std::io::Error::new(
            std::io::ErrorKind::IsADirectory,
            "is a directory, not a pack, scene.toml or model",
        ))
        .context(args.input.display().to_string()));
    }
    // A pipe or a device: opened once to look at its first bytes and again to read it, a FIFO
    // waited forever for a second writer, and `/dev/stdin` was taken for a model.
    if !input.is_file() {
        return Err(anyhow::Error::new(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "is not a regular file (a pipe or a device); give a pack, scene.toml or model file",
        ))
        .context(args.input.display().to_string()));
    }
    // Window-only options: a script that gave --watch headless thought it was watching.
    if args.headless {
        let given: Vec<&str> = [("--watch", args.watch), ("--no-vsync", args.no_vsync)]
            .into_iter()
            .filter_map(|(flag, on)| on.then_some(flag))
            .collect();
        if !given.is_empty() {
            eprintln!(
                "warning: {} only {} to the interactive window; --headless renders once",
                given.join(" and "),
                if given.len() == 1 { "applies" } else { "apply" }
            );
        }
    }
    if args.out.exists() && !args.out.is_dir() {
        return Err(Usage(format!(
            "--out {}: is not a directory; the images go in a directory",
            args.out.display()
        ))
        .into());
    }
    // They change how a scene is cooked; a pack was cooked already, and they were dropped
    // without a word.
    if is_pack(&args.input)
        && (!args.windows.is_empty()
            || args.model.up != cook::UpAxis::Y
            || args.model.text_encoding.is_some())
    {
        use clap::CommandFactory;
        Args::command()
            .error(
                clap::error::ErrorKind::ArgumentConflict,
                format!(
                    "--window, --up and --text-encoding change how a scene.toml or model is \
                     cooked, and {} is a cooked pack: give them to `cooker cook`, or view the \
                     scene.toml or model",
                    args.input.display()
                ),
            )
            .exit();
    }
    // Usage a pack can answer before the GPU is set up and the pack streamed (seconds on
    // lavapipe for a large one): a camera it does not have, an --out that cannot be made.
    // A scene.toml or model says its cameras only once cooked, below.
    if args.headless
        && is_pack(&args.input)
        && let Some(camera) = &args.camera
    {
        let pack = pack::Pack::open(&args.input)?;
        let names: Vec<&str> = pack.toc().cameras.iter().map(|c| c.name.as_str()).collect();
        let known = if names.is_empty() {
            &["default"][..]
        } else {
            &names[..]
        };
        if one_camera(&args.camera, known).is_some() && !known.contains(&camera.as_str()) {
            return Err(Usage(format!(
                "no camera named {:?} in {} (cameras: {})",
                camera,
                args.input.display(),
                known.join(", ")
            ))
            .into());
        }
    }
    // Checked here, before the GPU is set up and the pack streamed; made once the scene is
    // loaded, so that a refused input leaves no empty directory behind.
    if args.headless {
        out_in_the_way(&args.out)?;
        out_writable(&args.out)?;
    }
    let no_display =
        std::env::var_os("DISPLAY").is_none() && std::env::var_os("WAYLAND_DISPLAY").is_none();
    if (args.headless || no_display)
        && std::env::var_os("XDG_RUNTIME_DIR").is_none()
        && std::env::var_os("NODEVICE_SELECT").is_none()
    {
        // Mesa's device-select layer, which the Vulkan loader turns on by itself, connects to
        // a Wayland display to put its GPU first; without XDG_RUNTIME_DIR libwayland printed
        // "error: XDG_RUNTIME_DIR is invalid" twice, which read like a failure. Headless (asked
        // for, or for want of a display), no display's GPU is to be preferred, and this is the
        // layer's own switch.
        // SAFETY: no other thread exists yet (only the arguments were parsed), so nothing
        // reads the environment concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    VERBOSE.store(args.verbose, std::sync::atomic::Ordering::Relaxed);
    // Before either mode: the interactive viewer cooks through `open_source` too (it ignored
    // `--window` when only the headless path set it).
    let _ = COOK_OPTIONS.set(CookOptions {
        windows: cook::manifest::WindowDesign::overrides(&args.windows)?,
        model: args.model.clone(),
        cache: !args.no_cache,
    });
    let mut settings = god_ray_settings(&args)?;
    settings.shadows.enabled = !args.no_occlusion;
    if !args.headless {
        let outcome = interactive::run(interactive::Options {
            input: args.input.clone(),
            out: args.out.clone(),
            size: args.size,
            camera: args.camera.clone(),
            settings,
            watch: args.watch,
            vsync: !args.no_vsync,
            no_preview: args.no_preview,
            max_texture_size: args.max_texture_size,
            script: args.script.clone(),
        })?;
        match outcome {
            interactive::Outcome::Closed => return Ok(()),
            interactive::Outcome::NoDisplay(why) => println!("{why}: rendering headless"),
        }
    }
    let gpu_start = Instant::now();
    let mut gpu = Gpu::headless()?;
    cap_texture_side(&mut gpu, args.max_texture_size);
    println!("adapter: {}", gpu.describe());
    println!(
        "instance, adapter and device: {:.1} ms",
        ms(gpu_start.elapsed())
    );
    let (scene, mut renderer) = load(&gpu, &args, settings)?;

    let toc = scene.toc();
    if toc.meshes.iter().all(|m| m.index_count == 0) {
        eprintln!(
            "warning: {} holds no triangles to draw: the frames show the background alone",
            args.input.display()
        );
    }
    if args.no_occlusion && (args.verbose || args.passes) {
        // Each window's reason for a map read as if maps were drawn.
        println!("shadow maps: none (--no-occlusion: window light passes through everything)");
    } else if args.verbose || args.passes {
        print_window_shadows(&scene);
    }
    let aspect = args.size.0 as f32 / args.size.1 as f32;
    let mut views: Vec<(String, View)> = toc
        .cameras
        .iter()
        .map(|c| (c.name.clone(), renderer.view_for(c)))
        .collect();
    if views.is_empty() {
        let (lo, hi) = scene.framing_bounds();
        views.push(("default".into(), View::framing(lo, hi, aspect)));
    }
    // Named among all the cameras, so that one camera is written to the same file whether it
    // is drawn alone or with the rest (`a_b` was `a_b.png` alone, `a_b_2.png` beside `a b`).
    let stems = file_names(views.iter().map(|(n, _)| n.as_str()));
    let mut views: Vec<((String, View), String)> = views.into_iter().zip(stems).collect();
    let names: Vec<String> = views.iter().map(|((n, _), _)| n.clone()).collect();
    let known: Vec<&str> = names.iter().map(String::as_str).collect();
    if let Some(camera) = one_camera(&args.camera, &known) {
        views.retain(|((n, _), _)| n == camera);
        if views.is_empty() {
            return Err(Usage(format!(
                "no camera named {:?} in {} (cameras: {})",
                camera,
                args.input.display(),
                names.join(", ")
            ))
            .into());
        }
    }
    create_out(&args.out)?;
    for ((name, view), stem) in &views {
        if args.passes {
            // The shadow-map view is drawn with the maps: kept from a frame drawn at another
            // size (the preview), it was black.
            renderer.invalidate_shadow_maps();
        }
        let report = renderer.render(&gpu, &scene, view, TimingMethod::None)?;
        let path = args.out.join(format!("{stem}.png"));
        write_png(renderer.read_output(&gpu)?, &path)?;
        println!("wrote {}", path.display());
        if args.passes {
            for id in TargetId::ALL {
                let pass = id.pass();
                // The maps outlive the frame that drew them: "up to date" still has a view.
                if let Some(why) = report
                    .passes
                    .iter()
                    .find(|p| p.pass == pass)
                    .and_then(|p| p.skipped)
                    .filter(|_| !(id == TargetId::ShadowMap && renderer.has_shadow_maps()))
                {
                    println!("  {} not drawn ({why})", id.file_stem());
                    continue;
                }
                let (w, h, px) = renderer.read_target(&gpu, id)?;
                let path = args.out.join(format!("{stem}-{}.png", id.file_stem()));
                write_png(render::target_image(id, w, h, &px), &path)?;
                println!("wrote {}", path.display());
            }
        }
        if let Some(n) = args.bench {
            bench(
                &gpu,
                &scene,
                &mut renderer,
                view,
                n,
                &format!("camera {name:?} at {}x{}", args.size.0, args.size.1),
            )?;
        }
    }
    println!("images are in {}", args.out.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::file_names;

    #[test]
    fn camera_file_names_keep_letters_and_never_collide() {
        assert_eq!(
            file_names([
                "nave",
                "Вид",
                "Пол",
                "Camera.001",
                "Camera_001",
                "CAMERA_001",
                ""
            ]),
            [
                "nave",
                "Вид",
                "Пол",
                "Camera_001",
                "Camera_001_2",
                "CAMERA_001_3",
                "camera"
            ]
        );
        assert_eq!(
            file_names(["a/b", "a:b", "正面 视图"]),
            ["a_b", "a_b_2", "正面_视图"]
        );
    }
}
