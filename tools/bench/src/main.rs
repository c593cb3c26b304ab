//! `bench [--quick] [--out docs/bench] [--runs N] [--emit-table PATH] [--emit-god-ray-table PATH]`:
//! measures run time
//! against error for blur, mips, meshes, tangents and god rays on this machine and writes the report.

use std::path::PathBuf;

use anyhow::{Context, Result};
use bench::blur::BlurConfig;
use bench::common::Machine;
use bench::godrays::GodRayConfig;
use bench::mesh::MeshConfig;
use bench::mips::MipConfig;
use bench::report::{Results, error_table, god_ray_table, write_report};
use clap::Parser;

const LAVAPIPE_ICD: &str = "/usr/share/vulkan/icd.d/lvp_icd.x86_64.json";

#[derive(Parser, Debug)]
#[command(about = "Run time against error: blur, mips, meshes and god rays")]
struct Args {
    /// Small sizes and few parameters (CI): 256x256 blur and mips, few σ, a small frame.
    #[arg(long)]
    quick: bool,
    /// Where the report goes.
    #[arg(long, default_value = "docs/bench")]
    out: PathBuf,
    /// Runs per measurement (the median is reported). Default: 3, or 1 with --quick.
    #[arg(long)]
    runs: Option<usize>,
    /// Also write the cooker's error table (blur and mip errors and relative costs) here, e.g.
    /// crates/cook/src/error_table.json.
    #[arg(long)]
    emit_table: Option<PathBuf>,
    /// Also write the renderer's god-ray table (FLIP error and relative cost of each setting)
    /// here, e.g. crates/render/src/god_ray_table.json.
    #[arg(long)]
    emit_god_ray_table: Option<PathBuf>,
    /// Side of the square blur image (default 4096, 256 with --quick).
    #[arg(long)]
    blur_size: Option<usize>,
    /// σ values to sweep, comma-separated (default 0.5,1,2,2.2,4,8,16,32,64, 2.2 being the
    /// default scene's projectors; 1,2,4,8 with --quick).
    #[arg(long, value_delimiter = ',')]
    sigmas: Option<Vec<f32>>,
    /// Blur error is measured over a square region this many texels wide (the top-left corner
    /// for ours, an interior square for the anchors): the f64 reference of the whole 4096²
    /// image would take minutes per σ.
    #[arg(long, default_value_t = 1024)]
    error_region: usize,
    /// Skip the god-ray and shadow sweeps (they need a GPU adapter; lavapipe is enough).
    #[arg(long)]
    no_god_rays: bool,
    /// Run only these sweeps (blur, mips, meshes, tangents, god-rays, shadows, first-frame, compression), comma-separated; the others are
    /// left out of the report.
    #[arg(long, value_delimiter = ',')]
    only: Option<Vec<String>>,
    /// With --only: take the sweeps not run from the results.json already in --out (and say so
    /// in the report), so one sweep can be re-measured and the error table rewritten without
    /// re-running the others.
    #[arg(long, requires = "only")]
    keep_others: bool,
    /// Use whatever Vulkan driver the loader picks instead of forcing lavapipe.
    #[arg(long)]
    native_gpu: bool,
}

fn main() -> Result<()> {
    let raw: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if raw
        .get(1)
        .is_some_and(|a| a == bench::common::MEASURE_CHILD)
    {
        std::process::exit(bench::common::measure_child(&raw[2..])?);
    }
    let args = Args::parse();
    if !args.native_gpu
        && std::env::var_os("VK_DRIVER_FILES").is_none()
        && std::path::Path::new(LAVAPIPE_ICD).is_file()
    {
        // SAFETY: nothing else runs yet (no threads, no wgpu instance), so no one reads the
        // environment concurrently. Lavapipe renders bit-identically run to run.
        unsafe { std::env::set_var("VK_DRIVER_FILES", LAVAPIPE_ICD) };
    }
    let machine = Machine::detect();
    let runs = args.runs.unwrap_or(if args.quick { 1 } else { 3 });
    let blur_size = args
        .blur_size
        .unwrap_or(if args.quick { 256 } else { 4096 });
    let sigmas = args.sigmas.clone().unwrap_or_else(|| {
        if args.quick {
            vec![1.0, 2.0, 4.0, 8.0]
        } else {
            vec![0.5, 1.0, 2.0, 2.2, 4.0, 8.0, 16.0, 32.0, 64.0]
        }
    });
    let scratch = std::env::temp_dir().join(format!("bench-scratch-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).with_context(|| format!("creating {}", scratch.display()))?;
    let command = std::env::args()
        .map(|a| if a.contains(' ') { format!("{a:?}") } else { a })
        .collect::<Vec<_>>()
        .join(" ")
        .replace(&*std::env::args().next().unwrap_or_default(), "bench");
    let mut progress = |s: &str| eprintln!("{s}");
    eprintln!("{}", machine.markdown());

    let wanted = |name: &str| {
        args.only
            .as_ref()
            .is_none_or(|o| o.iter().any(|x| x == name))
    };
    let blur = if wanted("blur") {
        bench::blur::sweep(
            &BlurConfig {
                size: blur_size,
                sigmas,
                runs,
                external_limit_s: if args.quick { 5.0 } else { 30.0 },
                region: args.error_region,
                scratch: scratch.clone(),
            },
            &mut progress,
        )?
    } else {
        Vec::new()
    };
    let mip_size = blur_size;
    let mips = if wanted("mips") {
        bench::mips::sweep(
            &MipConfig {
                size: mip_size,
                runs,
            },
            &mut progress,
        )?
    } else {
        Vec::new()
    };
    let meshes = if wanted("meshes") {
        bench::mesh::sweep(
            &MeshConfig {
                grid: if args.quick { 100 } else { 707 },
                extra_grids: if args.quick {
                    vec![(40, true)]
                } else {
                    vec![(224, false), (640, true)]
                },
                scene: (!args.quick)
                    .then(|| {
                        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
                            .join("../../assets-src/scene.toml")
                    })
                    .filter(|p| p.is_file()),
                runs,
                bunny: bench::mesh::bunny_path(),
                scratch: scratch.clone(),
            },
            &mut progress,
        )?
    } else {
        Vec::new()
    };
    let tangents = if wanted("tangents") {
        bench::tangents::sweep(
            &bench::tangents::TangentConfig {
                grid: if args.quick { 40 } else { 640 },
                runs: runs.max(if args.quick { 1 } else { 5 }),
                model: bench::tangents::spot_path(),
            },
            &mut progress,
        )?
    } else {
        Vec::new()
    };
    let god_rays = if args.no_god_rays || !wanted("god-rays") {
        Err("skipped".to_string())
    } else {
        let cfg = if args.quick {
            GodRayConfig {
                width: 160,
                height: 90,
                samples: vec![16, 64],
                scales: vec![1.0, 0.5, 0.25],
                runs,
                scene: bench::godrays::default_scene(),
            }
        } else {
            GodRayConfig {
                width: 480,
                height: 270,
                samples: vec![8, 16, 32, 64, 128, 256, 1024],
                scales: vec![1.0, 0.5, 0.25],
                runs,
                scene: bench::godrays::default_scene(),
            }
        };
        bench::godrays::sweep(&cfg, &mut progress).map_err(|e| format!("{e:#}"))
    };
    if let Err(e) = &god_rays {
        eprintln!("god rays not measured: {e}");
    }
    let shadows = if args.no_god_rays || !wanted("shadows") {
        Err("skipped".to_string())
    } else {
        let scenes = vec![
            ("default".to_string(), bench::godrays::default_scene()),
            ("pillar hall".to_string(), bench::shadows::pillar_hall()),
        ];
        let cfg = if args.quick {
            bench::shadows::ShadowConfig {
                width: 80,
                height: 45,
                runs,
                timing_sizes: vec![(160, 90)],
                map_sizes: vec![1024],
                scenes,
            }
        } else {
            bench::shadows::ShadowConfig {
                width: 320,
                height: 180,
                runs,
                timing_sizes: vec![(320, 180), (1920, 1080)],
                map_sizes: vec![1024, 2048, 4096],
                scenes,
            }
        };
        std::fs::create_dir_all(&args.out)
            .with_context(|| format!("creating {}", args.out.display()))?;
        bench::shadows::sweep(&cfg, &args.out, &mut progress).map_err(|e| format!("{e:#}"))
    };
    if let Err(e) = &shadows {
        eprintln!("shadows not measured: {e}");
    }
    // Not in --quick: it runs the viewer binary, which the test suite's bench run may find
    // stale beside it.
    let first_frame = if args.quick || args.no_god_rays || !wanted("first-frame") {
        Vec::new()
    } else if let Some(scene) = bench::first_frame::default_scene() {
        bench::first_frame::sweep(
            &bench::first_frame::FirstFrameConfig {
                scene,
                runs: runs.max(5),
                size: (1280, 720),
                scratch: scratch.clone(),
                grid: 707,
            },
            &mut progress,
        )?
    } else {
        Vec::new()
    };
    let compression = if wanted("compression") {
        use texture::bc::Bc7Profile;
        bench::compress::sweep(
            &bench::compress::CompressConfig {
                max_size: if args.quick { 64 } else { 1024 },
                runs,
                profiles: if args.quick {
                    vec![Bc7Profile::UltraFast, Bc7Profile::VeryFast]
                } else {
                    Bc7Profile::ALL.to_vec()
                },
                zstd_levels: if args.quick {
                    vec![pack::ZSTD_LEVEL]
                } else {
                    vec![1, 3, pack::ZSTD_LEVEL, 19]
                },
                scene: (!args.quick && !args.no_god_rays).then(bench::godrays::default_scene),
                // The viewer's default size: a smaller frame samples only the small mip
                // levels, where block compression errs most.
                render_size: (1280, 720),
            },
            &mut progress,
        )?
    } else {
        Default::default()
    };
    let _ = std::fs::remove_dir_all(&scratch);
    let mut results = Results {
        machine,
        command,
        kept: Vec::new(),
        blur_size,
        blur_error_region: args.error_region,
        mip_size,
        blur,
        mips,
        meshes,
        god_rays,
        shadows,
        compression,
        tangents,
        first_frame,
    };
    if args.keep_others {
        let path = args.out.join("results.json");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("--keep-others: reading {}", path.display()))?;
        let earlier: Results = serde_json::from_str(&text)
            .with_context(|| format!("--keep-others: parsing {}", path.display()))?;
        let ran: Vec<&str> = args.only.iter().flatten().map(String::as_str).collect();
        results.keep_from(earlier, &ran);
    }
    write_report(&args.out, &results)?;
    eprintln!("report written to {}", args.out.join("README.md").display());
    if let Some(path) = &args.emit_table {
        write_json(path, &error_table(&results)?)?;
        eprintln!("error table written to {}", path.display());
    }
    if let Some(path) = &args.emit_god_ray_table {
        write_json(path, &god_ray_table(&results))?;
        eprintln!("god-ray table written to {}", path.display());
    }
    Ok(())
}

/// Writes through a temp file and a rename, so a failed run leaves the committed table whole.
fn write_json(path: &std::path::Path, value: &impl serde::Serialize) -> Result<()> {
    let text = serde_json::to_string_pretty(value)? + "\n";
    let tmp = path.with_extension("json.tmp");
    std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}
