//! The interactive window under Xvfb: it opens, renders frames driven by `--script`, writes
//! screenshots, follows a resize and closes with exit status 0. Without a display the same
//! command falls back to headless images.
//!
//! These tests need `xvfb-run` and a Vulkan adapter (lavapipe is forced when installed, since a
//! GPU driver usually cannot present to Xvfb); `scripts/install-test-deps.sh` installs both.
//! They fail, never skip, when either is missing.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// `xvfb-run -a` picks a free display number racily; one window test at a time.
static XVFB: Mutex<()> = Mutex::new(());

fn lavapipe_icd() -> Option<PathBuf> {
    let dir = std::fs::read_dir("/usr/share/vulkan/icd.d").ok()?;
    dir.filter_map(|e| e.ok().map(|e| e.path())).find(|p| {
        p.file_name()
            .and_then(|n| n.to_str())
            .is_some_and(|n| n.starts_with("lvp_icd") && n.ends_with(".json"))
    })
}

fn sample_pack(dir: &Path) -> PathBuf {
    let (toc, data) = pack::testing::sample();
    let path = dir.join("sample.pack");
    pack::write_pack(&path, toc, &data).expect("writing the sample pack");
    path
}

struct Run {
    status: std::process::ExitStatus,
    log: String,
}

/// Runs the viewer with `args`, under `xvfb-run` when `display` is set, with a time limit.
fn viewer(args: &[&std::ffi::OsStr], display: bool, dir: &Path) -> Run {
    let exe = env!("CARGO_BIN_EXE_viewer");
    let mut cmd = if display {
        let found = Command::new("xvfb-run")
            .arg("--help")
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
        assert!(
            found.is_ok(),
            "xvfb-run is missing: run scripts/install-test-deps.sh (Debian package xvfb)"
        );
        let mut c = Command::new("xvfb-run");
        c.args(["-a", "-s", "-screen 0 1280x720x24", exe]);
        c
    } else {
        let mut c = Command::new(exe);
        // As on a server: no display, and no session's runtime folder either.
        c.env_remove("DISPLAY")
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("NODEVICE_SELECT");
        c
    };
    // Cooks go through the texture cache: the test's own folder, not the user's.
    cmd.args(args)
        .env_remove("WAYLAND_DISPLAY")
        .env("STAINED_GLASS_CACHE", dir.join("cache"));
    if let Some(icd) = lavapipe_icd() {
        cmd.env("VK_DRIVER_FILES", icd);
    }
    let log_path = dir.join("viewer.log");
    let log = std::fs::File::create(&log_path).unwrap();
    cmd.stdout(log.try_clone().unwrap()).stderr(log);
    let mut child = cmd.spawn().expect("starting the viewer");
    let start = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if start.elapsed() > Duration::from_secs(300) {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "the viewer did not close within 300 s:\n{}",
                std::fs::read_to_string(&log_path).unwrap_or_default()
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    Run {
        status,
        log: std::fs::read_to_string(&log_path).unwrap_or_default(),
    }
}

/// Distinct colours covering at least `min_pixels` pixels each.
fn colours(img: &image::RgbaImage, min_pixels: usize) -> usize {
    let mut counts = std::collections::HashMap::new();
    for p in img.pixels() {
        *counts.entry(p.0).or_insert(0usize) += 1;
    }
    counts.values().filter(|&&n| n >= min_pixels).count()
}

fn load(path: &Path, log: &str) -> image::RgbaImage {
    let meta = std::fs::metadata(path)
        .unwrap_or_else(|e| panic!("{}: {e}\nviewer output:\n{log}", path.display()));
    assert!(meta.len() > 0, "{} is empty", path.display());
    image::open(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .to_rgba8()
}

#[test]
fn window_renders_frames_takes_screenshots_and_closes_cleanly() {
    let _guard = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let pack = sample_pack(dir.path());
    let shots = dir.path().join("shots");
    let final_png = shots.join("final.png");
    let ids_png = shots.join("ids.png");
    let small_png = shots.join("resized.png");
    // Frames, a camera move with held keys and the mouse, a view switch, a resize: each shot
    // waits for frames drawn after the change.
    let script = format!(
        "wait 3; shot {}; hold w 3; look 5 -3; camera 1; wait 25; view ids; wait 2; shot {}; \
         resize 240 160; wait 10; shot {}; quit",
        final_png.display(),
        ids_png.display(),
        small_png.display()
    );
    let args = [
        pack.as_os_str(),
        "--out".as_ref(),
        shots.as_os_str(),
        "--size".as_ref(),
        "320x180".as_ref(),
        // The window takes its god-ray quality from an error budget too.
        "--max-flip".as_ref(),
        "0.2".as_ref(),
        "--script".as_ref(),
        script.as_ref(),
    ];
    let run = viewer(&args, true, dir.path());
    assert!(
        run.status.success(),
        "viewer exited with {}:\n{}",
        run.status,
        run.log
    );
    assert!(
        run.log.contains("adapter:"),
        "no adapter line in:\n{}",
        run.log
    );
    assert!(
        run.log.contains("god rays for --max-flip 0.2: ") && run.log.contains("measured FLIP mean"),
        "no god-ray choice in:\n{}",
        run.log
    );
    // Full quality is a frame drawn with every mip at the window's size, so it never comes
    // before the first frame (the small pack's last mip arrives before the window opens).
    let first = run.log.find("first frame after");
    let full = run.log.find("full quality after");
    assert!(
        matches!((first, full), (Some(a), Some(b)) if a < b),
        "expected 'first frame' then 'full quality' in:\n{}",
        run.log
    );

    let img = load(&final_png, &run.log);
    assert_eq!(img.dimensions(), (320, 180), "{}", run.log);
    assert!(colours(&img, 20) >= 2, "the final image is uniform");

    // The material-ID view: background plus one false colour per material of the quad.
    let img = load(&ids_png, &run.log);
    assert!(
        colours(&img, 20) >= 3,
        "expected the background and two material colours, found {}",
        colours(&img, 20)
    );

    // The resize recreated the targets: the screenshot has the new size.
    let img = load(&small_png, &run.log);
    assert_eq!(img.dimensions(), (240, 160), "{}", run.log);
}

#[test]
fn without_a_display_the_viewer_renders_headless_and_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let pack = sample_pack(dir.path());
    let out = dir.path().join("out");
    let args = [
        pack.as_os_str(),
        "--out".as_ref(),
        out.as_os_str(),
        "--size".as_ref(),
        "64x36".as_ref(),
    ];
    let run = viewer(&args, false, dir.path());
    assert!(run.status.success(), "{}:\n{}", run.status, run.log);
    assert!(
        run.log.contains("no display found") && run.log.contains("rendering headless"),
        "no fallback notice in:\n{}",
        run.log
    );
    // Mesa's device-select layer, left on, printed libwayland's complaint twice, which read
    // like a failure of a run that succeeded.
    assert!(!run.log.contains("error"), "{}", run.log);
    let pngs: Vec<_> = std::fs::read_dir(&out)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "png"))
        .collect();
    assert!(
        !pngs.is_empty(),
        "no images in {}:\n{}",
        out.display(),
        run.log
    );
}

/// A Z-up room of one glass window, as a CAD tool would export it.
fn z_up_room(dir: &Path) -> PathBuf {
    let mut obj = String::from("mtllib room.mtl\n");
    let mut quad = |mtl: &str, corners: [[f32; 3]; 4]| {
        obj += &format!("usemtl {mtl}\n");
        for [x, y, z] in corners {
            // Y-up (x, y, z) written Z-up.
            obj += &format!("v {x} {} {y}\n", -z);
        }
        obj += "f -4 -3 -2 -1\n";
    };
    quad(
        "floor",
        [
            [-5., 0., -10.],
            [-5., 0., 10.],
            [5., 0., 10.],
            [5., 0., -10.],
        ],
    );
    quad(
        "wall",
        [
            [-5., 0., -10.],
            [-5., 0., 10.],
            [-5., 8., 10.],
            [-5., 8., -10.],
        ],
    );
    quad(
        "wall",
        [[5., 0., -10.], [5., 8., -10.], [5., 8., 10.], [5., 0., 10.]],
    );
    quad(
        "glass",
        [
            [-4.99, 2., -2.],
            [-4.99, 2., 2.],
            [-4.99, 6., 2.],
            [-4.99, 6., -2.],
        ],
    );
    std::fs::write(
        dir.join("room.mtl"),
        "newmtl glass\nKd 0.2 0.8 0.2\nTf 0.2 0.8 0.2\nd 0.3\n",
    )
    .unwrap();
    let path = dir.join("room.obj");
    std::fs::write(&path, obj).unwrap();
    path
}

/// The window cooks a model with the command line's `--window` designs and `--up` axis, as the
/// headless path does (it ignored `--window` while only the headless path set them): the
/// screenshot with a red design is redder than with a blue one, and the turned room says
/// nothing about looking Z-up.
#[test]
fn window_cooks_a_model_with_the_command_lines_designs_and_up_axis() {
    let _guard = XVFB.lock().unwrap_or_else(|e| e.into_inner());
    let dir = tempfile::tempdir().unwrap();
    let room = z_up_room(dir.path());
    let mut redness = Vec::new();
    for (name, colour) in [("red", [230u8, 20, 20, 255]), ("blue", [20, 20, 230, 255])] {
        let design = dir.path().join(format!("{name}.png"));
        image::RgbaImage::from_pixel(16, 16, image::Rgba(colour))
            .save(&design)
            .unwrap();
        let shot = dir.path().join(format!("{name}-shot.png"));
        // The guessed `lit-floor` view, where the window's light lands.
        let script = format!("camera 2; wait 5; shot {}; quit", shot.display());
        let window = format!("glass={}", design.display());
        let args = [
            room.as_os_str(),
            "--up".as_ref(),
            "z".as_ref(),
            "--window".as_ref(),
            window.as_ref(),
            "--size".as_ref(),
            "320x180".as_ref(),
            "--script".as_ref(),
            script.as_ref(),
        ];
        let run = viewer(&args, true, dir.path());
        assert!(run.status.success(), "{}:\n{}", run.status, run.log);
        assert!(!run.log.contains("Z-up"), "{}", run.log);
        let img = load(&shot, &run.log);
        let (r, b) = img.pixels().fold((0u64, 0u64), |(r, b), p| {
            (r + p.0[0] as u64, b + p.0[2] as u64)
        });
        redness.push(r as f64 - b as f64);
    }
    assert!(
        redness[0] > redness[1] + 1000.0,
        "red and blue designs gave the same window: {redness:?}"
    );
}
