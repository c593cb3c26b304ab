//! Mesh sweep: vertex cache optimizer × position quantization, through the cooker's own mesh
//! stage (`cook::mesh::process`, `cook::mesh::encode`) on a generated height field and, when
//! present, the Stanford bunny from the test data.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use anyhow::{Context, Result};
use cook::mesh::{
    Attributes, CacheMode, MaterialNeeds, MeshSettings, PositionBits, Processed, encode, process,
};
use serde::{Deserialize, Serialize};

use crate::common::{median, median_ms};

#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MeshRow {
    pub mesh: String,
    pub triangles: usize,
    pub vertices: usize,
    /// `full`, `fifo`, `none`, or an anchor's name.
    pub cache: String,
    /// Position bits per component: 32 (float), or the cooker's quantization to the bounding
    /// box at 16 (`Unorm16x4`, 8 bytes), 10 (`Unorm10x3`) or 8 (`Unorm8x4`, 4 bytes each).
    pub position_bits: u32,
    /// True for rows computed by a model rather than the cooker's own encoder; every row is
    /// measured now, the field stays so older result files still load.
    #[serde(default)]
    pub modelled: bool,
    pub time_ms: Option<f64>,
    pub acmr: Option<f64>,
    pub overfetch: Option<f64>,
    pub bytes_per_triangle: Option<f64>,
    /// Largest position error, in the mesh's units.
    pub max_position_error: Option<f64>,
    /// The same over the bounding box's largest extent.
    pub relative_position_error: Option<f64>,
    /// Peak resident memory of a whole-process row, in MB (median over its runs).
    #[serde(default)]
    pub peak_rss_mb: Option<f64>,
    pub note: String,
}

pub struct MeshConfig {
    /// Side of the generated height field in quads (2·n² triangles).
    pub grid: usize,
    /// More height fields timed as whole processes only: (side, with normals and UVs).
    pub extra_grids: Vec<(usize, bool)>,
    /// A scene manifest (beside its `corridor.obj`) timed as a whole process.
    pub scene: Option<PathBuf>,
    pub runs: usize,
    pub bunny: Option<PathBuf>,
    pub scratch: PathBuf,
}

/// The Stanford bunny from the project's test data, when it is there.
pub fn bunny_path() -> Option<PathBuf> {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/third_party/classic/stanford-bunny.obj");
    p.is_file().then_some(p)
}

fn stage(p: &Processed, name: &str) -> f64 {
    p.stats
        .stages
        .iter()
        .filter(|(n, _)| *n == name)
        .map(|(_, d)| d.as_secs_f64() * 1e3)
        .sum()
}

fn index_bytes(p: &Processed) -> usize {
    // As the cooker stores them: 16-bit when every index fits.
    let size = if p.vertices.len() <= u16::MAX as usize + 1 {
        2
    } else {
        4
    };
    p.indices.len() * size
}

fn extent(p: &Processed) -> f64 {
    (0..3)
        .map(|k| (p.bounds_max[k] - p.bounds_min[k]) as f64)
        .fold(0.0, f64::max)
}

fn measure(
    name: &str,
    path: &Path,
    cfg: &MeshConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<MeshRow>> {
    let src =
        cook::import::import(path).with_context(|| format!("importing {}", path.display()))?;
    let tri_material = vec![0u16; src.triangle_count()];
    let needs = [MaterialNeeds::OPAQUE];
    let mut rows = Vec::new();
    // (label, cache mode to run, whether to take the vertex-cache stage out)
    let modes = [
        ("full", CacheMode::Full, false),
        ("fifo", CacheMode::Fifo, false),
        ("none", CacheMode::Fifo, true),
    ];
    for (label, cache, without_cache) in modes {
        let settings = MeshSettings {
            cache,
            ..MeshSettings::default()
        };
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..cfg.runs.max(1) {
            let start = Instant::now();
            let p = process(&src, &tri_material, &needs, &settings);
            let mut ms = start.elapsed().as_secs_f64() * 1e3;
            if without_cache {
                ms -= stage(&p, "vertex cache");
            }
            times.push(ms);
            last = Some(p);
        }
        let p = last.expect("ran at least once");
        let process_ms = median(&mut times);
        let tris = p.indices.len() / 3;
        let (acmr, overfetch, note) = if without_cache {
            (
                p.stats.acmr_in as f64,
                None,
                "source order: ACMR before optimization as the cooker measures it; time without \
                 its vertex-cache stage; overfetch of the unoptimized order is not exposed",
            )
        } else {
            (p.stats.acmr_out as f64, Some(p.stats.overfetch as f64), "")
        };
        let float_stride = std::mem::size_of::<pack::StandardVertex>();
        let per_tri = |stride: usize| {
            (p.vertices.len() * stride + index_bytes(&p)) as f64 / tris.max(1) as f64
        };
        let ext = extent(&p).max(f64::MIN_POSITIVE);
        let base = MeshRow {
            mesh: name.to_string(),
            triangles: tris,
            vertices: p.vertices.len(),
            cache: label.to_string(),
            position_bits: 32,
            modelled: false,
            time_ms: Some(process_ms),
            acmr: Some(acmr),
            overfetch,
            bytes_per_triangle: Some(per_tri(float_stride)),
            max_position_error: Some(0.0),
            relative_position_error: Some(0.0),
            peak_rss_mb: None,
            note: note.to_string(),
        };
        rows.push(base.clone());
        let mut e16 = 0.0;
        for bits in [PositionBits::B16, PositionBits::B10, PositionBits::B8] {
            let (q_ms, q) = median_ms(cfg.runs, || {
                encode(
                    &p.vertices,
                    p.bounds_min,
                    p.bounds_max,
                    Attributes::ALL,
                    Some(bits),
                )
            });
            let e = q.max_position_error as f64;
            if bits == PositionBits::B16 {
                e16 = e;
            }
            rows.push(MeshRow {
                position_bits: bits as u32,
                time_ms: Some(process_ms + q_ms),
                bytes_per_triangle: Some(per_tri(q.layout.stride as usize)),
                max_position_error: Some(e),
                relative_position_error: Some(e / ext),
                ..base.clone()
            });
        }
        progress(&format!(
            "mesh {name} ({tris} tris) {label}: {process_ms:.1} ms, acmr {acmr:.3}, 16-bit error {e16:.2e}"
        ));
    }
    rows.extend(end_to_end(
        name,
        path,
        path,
        src.triangle_count(),
        cfg,
        progress,
    )?);
    Ok(rows)
}

/// One whole-process contender: a label, the program and its arguments, the position bits
/// of what it writes, and a note.
struct Contender {
    label: &'static str,
    program: PathBuf,
    args: Vec<std::ffi::OsString>,
    bits: u32,
    note: &'static str,
}

/// Whole processes side by side, as a user runs them: `cooker cook` (float, and `--quantize`)
/// on `cooker_input`, native gltfpack (`-noq`, and its quantized default) and the npm build
/// when installed on `gltfpack_input`. The runs are interleaved (one of each per round) so a
/// slow spell of the machine hits every contender alike; each row is the median of its runs.
pub fn end_to_end(
    name: &str,
    cooker_input: &Path,
    gltfpack_input: &Path,
    triangles: usize,
    cfg: &MeshConfig,
    progress: &mut dyn FnMut(&str),
) -> Result<Vec<MeshRow>> {
    let os = |s: &str| std::ffi::OsString::from(s);
    let mut contenders = Vec::new();
    if let Some(cooker) = cooker_binary() {
        let out = cfg.scratch.join("cooker-out.pack");
        let base = vec![
            os("cook"),
            cooker_input.as_os_str().to_owned(),
            os("-o"),
            out.as_os_str().to_owned(),
            os("--no-cache"),
        ];
        let note = "includes the source's parsing, process start and the atomic pack write (fsync)";
        for (label, flags, bits) in [
            ("cooker (end to end)", &[][..], 32),
            ("cooker --quantize (end to end)", &["--quantize"][..], 16),
        ] {
            let mut args = base.clone();
            args.extend(flags.iter().map(|f| os(f)));
            contenders.push(Contender {
                label,
                program: cooker.clone(),
                args,
                bits,
                note,
            });
        }
    }
    let glb = cfg.scratch.join("gltfpack-out.glb");
    let gltfpack_args = |flags: &[&str]| {
        let mut a = vec![
            os("-i"),
            gltfpack_input.as_os_str().to_owned(),
            os("-o"),
            glb.as_os_str().to_owned(),
        ];
        a.extend(flags.iter().map(|f| os(f)));
        a
    };
    match native_gltfpack() {
        // Native gltfpack quantizes by default, so its like-for-like row is `cooker
        // --quantize`; `-noq` is the float one. Only run, never linked or needed to build.
        Some(native) => {
            contenders.push(Contender {
                label: "gltfpack native -noq (end to end)",
                program: native.clone(),
                args: gltfpack_args(&["-noq"]),
                bits: 32,
                note: "native build, float attributes: compare with cooker",
            });
            contenders.push(Contender {
                label: "gltfpack native (end to end)",
                program: native,
                args: gltfpack_args(&[]),
                bits: 14,
                note: "native build, default settings (quantized): compare with cooker --quantize",
            });
        }
        None => progress(&format!(
            "mesh {name}: no native gltfpack (GLTFPACK_NATIVE or ../shared/anchors/gltfpack): \
             its rows are skipped"
        )),
    }
    if let Some(npm) = which("gltfpack") {
        contenders.push(Contender {
            label: "gltfpack (end to end)",
            program: npm,
            args: gltfpack_args(&[]),
            bits: 14,
            note: "the npm build: WebAssembly under Node.js",
        });
    }
    let mut times: Vec<Vec<f64>> = vec![Vec::new(); contenders.len()];
    let mut peaks: Vec<Vec<f64>> = vec![Vec::new(); contenders.len()];
    for round in 0..cfg.runs.max(1) {
        // Each round starts with the next contender: whatever the first run after the
        // previous round pays (a fresh file's pages, the VM's memory) is shared out.
        let n = contenders.len();
        for i in (0..n).map(|i| (i + round) % n) {
            let c = &contenders[i];
            let (ms, peak) = time_process(1, || {
                let mut cmd = Command::new(&c.program);
                cmd.args(&c.args);
                cmd
            })?;
            times[i].push(ms);
            peaks[i].push(peak);
        }
    }
    let _ = std::fs::remove_file(cfg.scratch.join("cooker-out.pack"));
    let _ = std::fs::remove_file(&glb);
    Ok(contenders
        .iter()
        .zip(times.iter_mut().zip(&mut peaks))
        .map(|(c, (t, peak))| {
            let ms = median(t);
            let peak = median(peak);
            progress(&format!(
                "mesh {name}: {} {ms:.1} ms, peak RSS {peak:.1} MB",
                c.label
            ));
            MeshRow {
                mesh: name.to_string(),
                triangles,
                vertices: 0,
                cache: c.label.into(),
                position_bits: c.bits,
                modelled: false,
                time_ms: Some(ms),
                acmr: None,
                overfetch: None,
                bytes_per_triangle: None,
                max_position_error: None,
                relative_position_error: None,
                peak_rss_mb: Some(peak),
                note: format!("{}; median of {} interleaved runs", c.note, t.len()),
            }
        })
        .collect())
}

/// Median wall time of `runs` runs of a process, which must succeed. Dirty pages are written
/// back before each run (`sync`): the cooker's fsync commits the file system's journal, which
/// on ext4 also waits for every other file's unwritten data, so without it the cooker would pay
/// for the output the previous contender (gltfpack, which does not fsync) left in memory.
fn time_process(runs: usize, command: impl Fn() -> Command) -> Result<(f64, f64)> {
    let mut times = Vec::new();
    let mut peaks = Vec::new();
    for _ in 0..runs.max(1) {
        let _ = Command::new("sync").status();
        let mut c = command();
        let (out, ms, peak) = crate::common::output_with_peak_rss(&mut c)?;
        times.push(ms);
        peaks.push(peak as f64 / 1e6);
        anyhow::ensure!(
            out.status.success(),
            "{:?} failed: {}",
            c.get_program(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok((median(&mut times), median(&mut peaks)))
}

/// The `cooker` binary built beside this one (`cargo build --release -p cooker`), if any.
fn cooker_binary() -> Option<PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let p = exe.with_file_name(format!("cooker{}", std::env::consts::EXE_SUFFIX));
    p.is_file().then_some(p)
}

/// A native gltfpack: `$GLTFPACK_NATIVE`, else the team's shared anchor build beside the
/// checkout (`../shared/anchors/gltfpack`).
fn native_gltfpack() -> Option<PathBuf> {
    let p = match std::env::var_os("GLTFPACK_NATIVE") {
        Some(p) => PathBuf::from(p),
        None => Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/anchors/gltfpack"),
    };
    p.is_file().then_some(p)
}

fn which(program: &str) -> Option<PathBuf> {
    let paths = std::env::var_os("PATH")?;
    std::env::split_paths(&paths)
        .map(|d| d.join(program))
        .find(|p| p.is_file())
}

pub fn sweep(cfg: &MeshConfig, progress: &mut dyn FnMut(&str)) -> Result<Vec<MeshRow>> {
    std::fs::create_dir_all(&cfg.scratch)?;
    let grid = cfg.scratch.join(format!("grid-{}.obj", cfg.grid));
    std::fs::write(&grid, cook::testing::height_field_obj(cfg.grid))
        .with_context(|| format!("writing {}", grid.display()))?;
    let mut rows = measure(
        &format!("generated {0}x{0} height field", cfg.grid),
        &grid,
        cfg,
        progress,
    )?;
    let _ = std::fs::remove_file(&grid);
    if let Some(b) = &cfg.bunny {
        rows.extend(measure("Stanford bunny", b, cfg, progress)?);
    }
    // Whole processes only: a mesh the size of the dragon the issue timed (100k triangles,
    // no normals or texture coordinates), a large one with both, and the textured default
    // scene (gltfpack gets its OBJ and copies the images; ours cooks every texture).
    for (n, attributes) in cfg.extra_grids.iter().copied() {
        let file = cfg.scratch.join(format!("grid-{n}-{attributes}.obj"));
        let text = if attributes {
            cook::testing::height_field_obj_with_normals_and_uvs(n)
        } else {
            cook::testing::height_field_obj(n)
        };
        std::fs::write(&file, text).with_context(|| format!("writing {}", file.display()))?;
        let name = if attributes {
            format!("generated {n}x{n} height field with normals and UVs")
        } else {
            format!("generated {n}x{n} height field")
        };
        rows.extend(end_to_end(&name, &file, &file, 2 * n * n, cfg, progress)?);
        // The same mesh as a GLB (glTF's one index per vertex, a binary buffer): written by
        // native gltfpack, the one GLB writer at hand, when it is there.
        if attributes && let Some(native) = native_gltfpack() {
            let glb = cfg.scratch.join(format!("grid-{n}.glb"));
            let written = Command::new(native)
                .args([
                    std::ffi::OsStr::new("-noq"),
                    "-i".as_ref(),
                    file.as_os_str(),
                ])
                .args(["-o".as_ref(), glb.as_os_str()])
                .output()
                .is_ok_and(|o| o.status.success());
            if written {
                let name = format!("{name}, as GLB");
                rows.extend(end_to_end(&name, &glb, &glb, 2 * n * n, cfg, progress)?);
            } else {
                progress(&format!(
                    "mesh {name}: gltfpack did not write the GLB; its rows are skipped"
                ));
            }
            let _ = std::fs::remove_file(&glb);
        }
        let _ = std::fs::remove_file(&file);
    }
    if let Some(scene) = &cfg.scene {
        let obj = scene.with_file_name("corridor.obj");
        if obj.is_file() {
            let tris = cook::import::import(&obj).map_or(0, |m| m.triangle_count());
            rows.extend(end_to_end(
                "default scene (textured)",
                scene,
                &obj,
                tris,
                cfg,
                progress,
            )?);
        }
    }
    Ok(rows)
}
