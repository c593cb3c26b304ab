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
    pub note: String,
}

pub struct MeshConfig {
    /// Side of the generated height field in quads (2·n² triangles).
    pub grid: usize,
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
    // Our whole cook as a user runs it, timed the same way as the gltfpack anchor: process
    // start, OBJ parsing, processing and writing the output.
    let end_to_end = |label: &str, bits: u32, ms: f64, note: &str| MeshRow {
        mesh: name.to_string(),
        triangles: src.triangle_count(),
        vertices: 0,
        cache: label.into(),
        position_bits: bits,
        modelled: false,
        time_ms: Some(ms),
        acmr: None,
        overfetch: None,
        bytes_per_triangle: None,
        max_position_error: None,
        relative_position_error: None,
        note: note.into(),
    };
    if let Some(cooker) = cooker_binary() {
        let out = cfg.scratch.join("cooker-out.pack");
        for (label, flags, bits) in [
            ("cooker (end to end)", &[][..], 32),
            ("cooker --fifo (end to end)", &["--fifo"][..], 32),
            ("cooker --quantize (end to end)", &["--quantize"][..], 16),
        ] {
            let ms = time_process(cfg.runs, || {
                let mut c = Command::new(&cooker);
                c.arg("cook").arg(path).arg("-o").arg(&out);
                c.arg("--no-cache").args(flags);
                c
            })?;
            rows.push(end_to_end(
                label,
                bits,
                ms,
                "includes OBJ parsing, process start and the atomic pack write (fsync)",
            ));
        }
        let _ = std::fs::remove_file(&out);
    }
    // Native gltfpack, when the machine has it: it quantizes by default, so its like-for-like
    // row is `cooker --quantize` of this same run. Only run, never linked or needed to build.
    match native_gltfpack() {
        Some(native) => {
            let out = cfg.scratch.join("gltfpack-native-out.glb");
            for (label, flags, bits, note) in [
                (
                    "gltfpack native (end to end)",
                    &[][..],
                    14,
                    "native build, default settings (quantized): compare with cooker --quantize",
                ),
                (
                    "gltfpack native -noq (end to end)",
                    &["-noq"][..],
                    32,
                    "native build, float attributes: compare with cooker",
                ),
            ] {
                let ms = time_process(cfg.runs, || {
                    let mut c = Command::new(&native);
                    c.arg("-i").arg(path).arg("-o").arg(&out).args(flags);
                    c
                })?;
                rows.push(end_to_end(label, bits, ms, note));
            }
            let _ = std::fs::remove_file(&out);
        }
        None => progress(&format!(
            "mesh {name}: no native gltfpack (GLTFPACK_NATIVE or ../shared/anchors/gltfpack): \
             its rows are skipped"
        )),
    }
    if let Some(gltfpack) = which("gltfpack") {
        let out = cfg.scratch.join("gltfpack-out.glb");
        let ms = time_process(cfg.runs, || {
            let mut c = Command::new(&gltfpack);
            c.arg("-i").arg(path).arg("-o").arg(&out);
            c
        })?;
        let _ = std::fs::remove_file(&out);
        rows.push(end_to_end(
            "gltfpack (end to end)",
            14,
            ms,
            "includes OBJ parsing, process start and writing the .glb; the npm build is \
             WebAssembly under Node.js (about 4.6x slower than native gltfpack)",
        ));
    }
    Ok(rows)
}

/// Median wall time of `runs` runs of a process, which must succeed.
fn time_process(runs: usize, command: impl Fn() -> Command) -> Result<f64> {
    let mut times = Vec::new();
    for _ in 0..runs.max(1) {
        let mut c = command();
        let start = Instant::now();
        let out = c
            .output()
            .with_context(|| format!("running {:?}", c.get_program()))?;
        times.push(start.elapsed().as_secs_f64() * 1e3);
        anyhow::ensure!(
            out.status.success(),
            "{:?} failed: {}",
            c.get_program(),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    Ok(median(&mut times))
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
    Ok(rows)
}
