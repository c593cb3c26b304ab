//! The headless viewer end to end on a tiny pack: files written per camera and pass, errors
//! naming what is wrong. Needs a GPU adapter (lavapipe in CI) and fails without one.

use std::path::PathBuf;
use std::process::Command;

use pack::{
    Camera, DrawRange, IndexFormat, Light, LightKind, Material, MaterialClass, Mesh, MeshData,
    PackData, StandardVertex, Toc, VertexLayout, Window,
};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("viewer-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A floor and a window quad in front of it, a sun, two cameras.
fn tiny_pack() -> Vec<u8> {
    let (toc, data) = tiny_scene();
    pack::encode(toc, &data).unwrap()
}

/// [`tiny_pack`]'s TOC and data.
fn tiny_scene() -> (Toc, PackData) {
    let material = |name: &str, class| Material {
        name: name.into(),
        class,
        diffuse: [0.7, 0.6, 0.5],
        specular: [0.0; 3],
        shininess: 8.0,
        emissive: [0.0; 3],
        diffuse_texture: None,
        normal_texture: None,
        projector_texture: None,
        projector_margin: [0.0; 2],
    };
    let v = |p: [f32; 3], n: [f32; 3], m: u16| StandardVertex {
        position: p,
        normal: n,
        uv: [0.0; 2],
        tangent: [1.0, 0.0, 0.0, 1.0],
        material: [m, 0],
        colour: pack::vertex::WHITE,
    };
    let vertices = vec![
        v([-5.0, 0.0, 5.0], [0.0, 1.0, 0.0], 0),
        v([5.0, 0.0, 5.0], [0.0, 1.0, 0.0], 0),
        v([5.0, 0.0, -5.0], [0.0, 1.0, 0.0], 0),
        v([-5.0, 0.0, -5.0], [0.0, 1.0, 0.0], 0),
        v([-1.0, 3.0, 0.0], [0.0, 0.0, 1.0], 1),
        v([1.0, 3.0, 0.0], [0.0, 0.0, 1.0], 1),
        v([1.0, 1.0, 0.0], [0.0, 0.0, 1.0], 1),
        v([-1.0, 1.0, 0.0], [0.0, 0.0, 1.0], 1),
    ];
    let indices: Vec<u16> = vec![0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7];
    let camera = |name: &str, z: f32| Camera {
        name: name.into(),
        position: [0.0, 1.7, z],
        target: [0.0, 2.0, 0.0],
        up: [0.0, 1.0, 0.0],
        fov_y: 60.0,
        near: 0.05,
        far: 100.0,
    };
    let toc = Toc {
        meshes: vec![Mesh {
            name: "tiny".into(),
            layout: VertexLayout::standard(),
            vertex_count: vertices.len() as u32,
            index_count: indices.len() as u32,
            index_format: IndexFormat::U16,
            vertex_section: 0,
            index_section: 0,
            bounds_min: [-5.0, 0.0, -5.0],
            bounds_max: [5.0, 3.0, 5.0],
            ranges: vec![
                DrawRange {
                    material: 0,
                    first_index: 0,
                    index_count: 6,
                },
                DrawRange {
                    material: 1,
                    first_index: 6,
                    index_count: 6,
                },
            ],
        }],
        materials: vec![
            material("floor", MaterialClass::Floor),
            material("glass", MaterialClass::WindowLower),
        ],
        windows: vec![Window {
            material: 1,
            origin: [-1.0, 3.0, 0.0],
            u_axis: [2.0, 0.0, 0.0],
            v_axis: [0.0, -2.0, 0.0],
            normal: [0.0, 0.0, 1.0],
            source_materials: Vec::new(),
        }],
        light: Some(Light {
            kind: LightKind::Directional {
                direction: [0.0, -0.5, 1.0],
                angular_size: 0.01,
            },
            colour: [1.0; 3],
            intensity: 2.0,
        }),
        cameras: vec![camera("near view", 6.0), camera("far", 9.0)],
        ..Toc::default()
    };
    let data = PackData {
        meshes: vec![MeshData {
            vertices: bytemuck_bytes(&vertices),
            indices: indices.iter().flat_map(|i| i.to_le_bytes()).collect(),
        }],
        textures: Vec::new(),
    };
    (toc, data)
}

fn bytemuck_bytes(v: &[StandardVertex]) -> Vec<u8> {
    let mut out = Vec::new();
    for x in v {
        for f in x
            .position
            .iter()
            .chain(&x.normal)
            .chain(&x.uv)
            .chain(&x.tangent)
        {
            out.extend_from_slice(&f.to_le_bytes());
        }
        for m in x.material {
            out.extend_from_slice(&m.to_le_bytes());
        }
    }
    out
}

fn test_cache() -> std::path::PathBuf {
    std::env::temp_dir().join(format!("viewer-tests-cache-{}", std::process::id()))
}

fn viewer(args: &[&std::ffi::OsStr]) -> std::process::Output {
    // As on a server or in CI: no session, so no runtime directory. Mesa's device-select layer
    // then made libwayland print "error: XDG_RUNTIME_DIR is invalid" (tested below).
    Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args(args)
        .env_remove("XDG_RUNTIME_DIR")
        .env_remove("NODEVICE_SELECT")
        // Cooks go through the texture cache: a folder of the tests', not the user's.
        .env("STAINED_GLASS_CACHE", test_cache())
        .output()
        .unwrap()
}

/// The headless viewer on `pack`, writing 64x36 images to `out`, with `extra` arguments.
fn headless_64x36(
    pack: &std::path::Path,
    out: &std::path::Path,
    extra: &[&str],
) -> std::process::Output {
    let mut args = vec![
        pack.as_os_str(),
        "--headless".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
        "--size".as_ref(),
        "64x36".as_ref(),
    ];
    args.extend(extra.iter().map(std::ffi::OsStr::new));
    viewer(&args)
}

#[test]
fn writes_every_camera_and_pass() {
    let dir = scratch("ok");
    let pack_path = dir.join("tiny.pack");
    std::fs::write(&pack_path, tiny_pack()).unwrap();
    let out = dir.join("images/nested");
    let o = viewer(&[
        pack_path.as_os_str(),
        "--headless".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
        "--size".as_ref(),
        "64x36".as_ref(),
        "--passes".as_ref(),
        "--bench".as_ref(),
        "2".as_ref(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        o.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for cam in ["near_view", "far"] {
        let img = image::open(out.join(format!("{cam}.png"))).unwrap();
        assert_eq!((img.width(), img.height()), (64, 36));
        for pass in ["pass0-background", "pass1-window-mask", "pass3-lit"] {
            assert!(
                out.join(format!("{cam}-{pass}.png")).is_file(),
                "{cam}-{pass}.png missing"
            );
        }
        // No normal maps: pass 2 is skipped and says so instead of writing a stale image.
        assert!(!out.join(format!("{cam}-pass2-window-normals.png")).exists());
        // The floor runs on beyond the window's plane: the sun's map over it is drawn, and
        // its view shows it (it was black, kept from the half-size preview's frame).
        let map = image::open(out.join(format!("{cam}-shadow-map.png")))
            .unwrap()
            .into_luma8();
        assert!(
            map.pixels().any(|p| p.0[0] > 0),
            "{cam}-shadow-map.png is black"
        );
    }
    assert!(
        stdout.contains("first frame after") && stdout.contains("full quality after"),
        "{stdout}"
    );
    // The device's time, and the first frame's since the process started, are said too.
    assert!(
        stdout.contains("instance, adapter and device: ")
            && stdout.contains(" ms since the viewer started)"),
        "{stdout}"
    );
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!stderr.contains("XDG_RUNTIME_DIR"), "{stderr}");
    assert!(
        stdout.contains("skipped (no window normal maps)"),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!("images are in {}", out.display())),
        "{stdout}"
    );
    // Window-only options headless are said to do nothing (they were taken without a word).
    let w = headless_64x36(
        &pack_path,
        &dir.join("watch"),
        &["--watch", "--no-occlusion", "-v"],
    );
    let (w_out, w_err) = (
        String::from_utf8_lossy(&w.stdout),
        String::from_utf8_lossy(&w.stderr),
    );
    assert!(w.status.success(), "{w_err}");
    assert!(
        w_err.contains("warning: --watch only applies to the interactive window"),
        "{w_err}"
    );
    // No window is said to get a map under --no-occlusion (each was, with its reason).
    assert!(
        w_out.contains("shadow maps: none (--no-occlusion"),
        "{w_out}"
    );
    assert!(!w_out.contains("shadow map: "), "{w_out}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// On lavapipe (a CPU rasterizer) the first frame is a half-size preview, which changes no
/// image written; `--no-preview` draws it at full size.
#[test]
fn first_frame_preview_leaves_the_images_alone() {
    let dir = scratch("first-frame");
    let pack_path = dir.join("tiny.pack");
    std::fs::write(&pack_path, tiny_pack()).unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = dir.join(name);
        let o = headless_64x36(&pack_path, &out, &[&["-v"], extra].concat());
        let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(
            o.status.success(),
            "{stdout}{}",
            String::from_utf8_lossy(&o.stderr)
        );
        (out, stdout)
    };
    let (preview, said) = run("preview", &[]);
    let (full, said_full) = run("full", &["--no-preview"]);
    let cpu = said.contains("Cpu");
    assert_eq!(said.contains("32x18 preview"), cpu, "{said}");
    assert!(!said_full.contains(" preview, "), "{said_full}");
    for text in [&said, &said_full] {
        assert!(
            text.contains("scene and renderer (pipelines)") && text.contains("instance, adapter"),
            "{text}"
        );
    }
    for cam in ["near_view", "far"] {
        let a = std::fs::read(preview.join(format!("{cam}.png"))).unwrap();
        let b = std::fs::read(full.join(format!("{cam}.png"))).unwrap();
        assert!(a == b, "{cam}.png differs with the preview");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--max-texture-size` loads a larger texture from its first level that fits and says so;
/// without it, nothing is said.
#[test]
fn max_texture_size_loads_a_smaller_level_and_says_so() {
    let dir = scratch("max-texture-size");
    let pack_path = dir.join("textured.pack");
    let (mut toc, mut data) = tiny_scene();
    let (t, levels) =
        pack::testing::sample_texture("flagstones", pack::TextureRole::Colour, 64, 64);
    toc.textures.push(t);
    data.textures.push(levels);
    toc.materials[0].diffuse_texture = Some(0);
    std::fs::write(&pack_path, pack::encode(toc, &data).unwrap()).unwrap();
    let run = |extra: &[&str]| headless_64x36(&pack_path, &dir.join("images"), extra);
    let o = run(&["--max-texture-size", "20"]);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{said}");
    assert!(
        said.contains("1 of 1 textures are larger than the 20 texels a side")
            && said.contains("\"flagstones\" at 64x64, from level 2, 16x16"),
        "{said}"
    );
    let o = run(&[]);
    let said = String::from_utf8_lossy(&o.stderr);
    assert!(
        o.status.success() && !said.contains("larger than"),
        "{said}"
    );
    let o = run(&["--max-texture-size", "0"]);
    assert_eq!(
        o.status.code(),
        Some(2),
        "{}",
        String::from_utf8_lossy(&o.stderr)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// `--camera all` draws every camera, but a camera called `all` (a name like any other) is
/// drawn alone by it; it could not be drawn alone before.
#[test]
fn a_camera_called_all_can_be_drawn_alone() {
    let dir = scratch("all");
    let pack_path = dir.join("tiny.pack");
    let run = |toc: &Toc, data: &PackData, camera: &[&str]| {
        std::fs::write(&pack_path, pack::encode(toc.clone(), data).unwrap()).unwrap();
        let out = dir.join("out");
        let _ = std::fs::remove_dir_all(&out);
        let mut args = vec![
            pack_path.as_os_str(),
            "--headless".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
            "--size".as_ref(),
            "32x18".as_ref(),
        ];
        args.extend(camera.iter().map(std::ffi::OsStr::new));
        let o = viewer(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let mut files: Vec<String> = std::fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        files.sort();
        files
    };
    let (mut toc, data) = tiny_scene();
    assert_eq!(
        run(&toc, &data, &["--camera", "all"]),
        ["far.png", "near_view.png"]
    );
    toc.cameras[0].name = "all".into();
    assert_eq!(run(&toc, &data, &["--camera", "all"]), ["all.png"]);
    assert_eq!(run(&toc, &data, &[]), ["all.png", "far.png"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A pack with nothing to stream (no mesh, no texture: a camera and a light) is drawn at the
/// size asked for; it was left at the half-size preview's.
#[test]
fn a_pack_of_nothing_to_stream_is_drawn_at_full_size() {
    let dir = scratch("nothing");
    let pack_path = dir.join("empty.pack");
    let (full, _) = tiny_scene();
    let toc = Toc {
        cameras: full.cameras,
        light: full.light,
        ..Toc::default()
    };
    let data = PackData {
        meshes: Vec::new(),
        textures: Vec::new(),
    };
    std::fs::write(&pack_path, pack::encode(toc, &data).unwrap()).unwrap();
    let out = dir.join("out");
    let o = headless_64x36(&pack_path, &out, &[]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    for cam in ["near_view", "far"] {
        let img = image::open(out.join(format!("{cam}.png"))).unwrap();
        assert_eq!((img.width(), img.height()), (64, 36), "{cam}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn names_the_problem_on_bad_input() {
    let dir = scratch("bad");
    let pack_path = dir.join("tiny.pack");
    std::fs::write(&pack_path, tiny_pack()).unwrap();
    let out = dir.join("out");
    let o = viewer(&[
        pack_path.as_os_str(),
        "--headless".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
        "--camera".as_ref(),
        "nope".as_ref(),
        "--size".as_ref(),
        "32x18".as_ref(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    // Bad usage, as clap's: it exited 1, the code of a failed render.
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("no camera named \"nope\"") && err.contains("near view"),
        "{err}"
    );
    // Said from the pack's cameras, before the GPU was set up and the pack streamed.
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        !said.contains("adapter") && !said.contains("first frame"),
        "{said}"
    );

    // An --out the system will not let us make is said before the render (it came after the
    // whole frame): exit 4, as any I/O refusal, and no adapter set up.
    let o = headless_64x36(
        &pack_path,
        std::path::Path::new("/proc/no-such-frames"),
        &[],
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert!(err.contains("creating /proc/no-such-frames"), "{err}");
    assert!(
        !String::from_utf8_lossy(&o.stdout).contains("adapter"),
        "{err}"
    );
    assert!(
        !out.exists(),
        "a refused input left {} behind",
        out.display()
    );

    let headless = |pack: &std::path::Path| {
        viewer(&[
            pack.as_os_str(),
            "--headless".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ])
    };
    let mut bytes = tiny_pack();
    let last = bytes.len() - 1;
    bytes[last] ^= 0x40;
    std::fs::write(&pack_path, &bytes).unwrap();
    let o = headless(&pack_path);
    // Invalid input exits 3 and a file that cannot be read 4, as the cooker's do.
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("tiny.pack") && err.contains("checksum"),
        "{err}"
    );
    // Named once ("reading tiny.pack: tiny.pack: ..." before).
    assert_eq!(err.matches("tiny.pack").count(), 1, "{err}");
    // A refused input leaves no empty --out directory behind.
    assert!(!out.exists());
    // A pack cut short is said to be at once, against its header's length, as `cooker info`
    // says it (it was found at the first section past the cut, after a first frame).
    let whole = tiny_pack();
    std::fs::write(&pack_path, &whole[..whole.len() * 2 / 3]).unwrap();
    let o = headless(&pack_path);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains(&format!(
            "tiny.pack: at byte offset 24: file length is {} bytes but the header says {}",
            whole.len() * 2 / 3,
            whole.len()
        )),
        "{err}"
    );
    assert!(!String::from_utf8_lossy(&o.stdout).contains("first frame"));
    let missing = dir.join("missing.pack");
    let o = headless(&missing);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert!(err.contains("missing.pack"), "{err}");
    // A missing model too, named once, and before the GPU is set up ("loading missing.obj:
    // missing.obj: ..." after the adapter line).
    let o = headless(&dir.join("missing.obj"));
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert_eq!(err.matches("missing.obj").count(), 1, "{err}");
    assert!(!String::from_utf8_lossy(&o.stdout).contains("adapter"));

    // A file as --out, or above it, is bad usage alike (the second exited 4, an I/O error),
    // said before the GPU is set up.
    std::fs::write(&pack_path, tiny_pack()).unwrap();
    let notes = dir.join("notes.txt");
    std::fs::write(&notes, b"mine").unwrap();
    for out in [notes.clone(), notes.join("frames")] {
        let o = viewer(&[
            pack_path.as_os_str(),
            "--headless".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{err}");
        assert!(
            err.contains("notes.txt") && err.contains("directory"),
            "{err}"
        );
        assert!(!String::from_utf8_lossy(&o.stdout).contains("adapter"));
    }
    assert_eq!(std::fs::read(&notes).unwrap(), b"mine");

    let _ = std::fs::remove_dir_all(&dir);
}

/// A pack whose vertices' material IDs disagree with their draw range (checksums agreeing)
/// is refused as invalid input, naming the pack: it was drawn without a word, though
/// `cooker validate` reported it.
#[test]
fn a_vertex_material_against_its_draw_range_is_refused() {
    let dir = scratch("mismatch");
    let pack_path = dir.join("tiny.pack");
    let (toc, mut data) = tiny_scene();
    // The window's first corner, drawn in range 1 (material 1), says material 0: its ID is
    // the u16 after position, normal, uv and tangent (48 bytes into its 52).
    data.meshes[0].vertices[4 * 52 + 48..4 * 52 + 50].copy_from_slice(&0u16.to_le_bytes());
    std::fs::write(&pack_path, pack::encode(toc, &data).unwrap()).unwrap();
    let o = headless_64x36(&pack_path, &dir.join("out"), &[]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("tiny.pack")
            && err.contains("2 triangles have vertices whose material IDs disagree")
            && err.contains("range material 1, vertices [0, 1, 1]"),
        "{err}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A cooked pack is cooked: the options that change a cook are refused for it (they were
/// dropped without a word), and a pack named without `.pack` is still read as one.
#[test]
fn cook_options_on_a_pack_are_bad_usage() {
    let dir = scratch("cook-options");
    let pack_path = dir.join("tiny.pack");
    std::fs::write(&pack_path, tiny_pack()).unwrap();
    let out = dir.join("out");
    for extra in [["--window", "rose=x.png"], ["--up", "z"]] {
        let mut args = vec![
            pack_path.as_os_str(),
            "--headless".as_ref(),
            "--out".as_ref(),
            out.as_os_str(),
        ];
        args.extend(extra.iter().map(std::ffi::OsStr::new));
        let o = viewer(&args);
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {err}");
        assert!(
            err.contains("tiny.pack is a cooked pack: give them to `cooker cook`"),
            "{err}"
        );
    }
    assert!(!out.exists(), "images written for bad usage");
    let renamed = dir.join("tiny.bin");
    std::fs::write(&renamed, tiny_pack()).unwrap();
    let o = viewer(&[
        renamed.as_os_str(),
        "--headless".as_ref(),
        "--out".as_ref(),
        out.as_os_str(),
        "--size".as_ref(),
        "32x18".as_ref(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let _ = std::fs::remove_dir_all(&dir);
}

/// On a valid pack, so only the size check can make it fail.
#[test]
fn zero_size_is_bad_usage() {
    let dir = scratch("size");
    let pack_path = dir.join("tiny.pack");
    std::fs::write(&pack_path, tiny_pack()).unwrap();
    let o = viewer(&[
        pack_path.as_os_str(),
        "--headless".as_ref(),
        "--out".as_ref(),
        dir.join("out").as_os_str(),
        "--size".as_ref(),
        "0x10".as_ref(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(
        err.contains("size 0x10 must be 1..=16384 on each axis"),
        "{err}"
    );
    assert!(!dir.join("out").exists(), "images written for a bad size");
    let _ = std::fs::remove_dir_all(&dir);
}

/// A named pipe: the viewer opened it to look at its first bytes, then again to read it, and
/// waited forever for a second writer. Now it is refused before anything is opened.
#[cfg(unix)]
#[test]
fn a_pipe_is_refused_at_once() {
    let dir = scratch("fifo");
    let fifo = dir.join("scene.pack");
    assert!(
        Command::new("mkfifo")
            .arg(&fifo)
            .status()
            .unwrap()
            .success()
    );
    let o = viewer(&[
        fifo.as_os_str(),
        "--headless".as_ref(),
        "--out".as_ref(),
        dir.join("out").as_os_str(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{err}");
    assert!(err.contains("is not a regular file"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// OpenGL alone (a machine without a Vulkan driver, or `WGPU_BACKEND=gl`): the viewer found
/// llvmpipe's OpenGL and panicked at the shadow lookup's pipeline (exit 101). Now there is no
/// adapter, said plainly, exit 1, whether the machine has OpenGL or not.
#[test]
fn opengl_alone_is_no_adapter_not_a_panic() {
    let dir = scratch("gl");
    let pack_path = dir.join("tiny.pack");
    std::fs::write(&pack_path, tiny_pack()).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_viewer"))
        .args([
            pack_path.as_os_str(),
            "--headless".as_ref(),
            "--out".as_ref(),
            dir.join("out").as_os_str(),
            "--size".as_ref(),
            "16x9".as_ref(),
        ])
        .env("WGPU_BACKEND", "gl")
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("no GPU adapter found"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Runs the headless viewer on `pack` with the camera "far" at 64x36 and the god-ray pass
/// written; returns (stdout, stderr, final image, god-ray image).
fn render_far(
    pack: &std::path::Path,
    out: &std::path::Path,
    extra: &[&str],
) -> (String, String, image::RgbaImage, image::RgbaImage) {
    let o = headless_64x36(
        pack,
        out,
        &[&["--camera", "far", "--passes"], extra].concat(),
    );
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&o.stderr).into_owned();
    assert!(o.status.success(), "{extra:?}: {stdout}\n{stderr}");
    let frame = image::open(out.join("far.png")).unwrap().into_rgba8();
    let rays = image::open(out.join("far-god-rays.png"))
        .unwrap()
        .into_rgba8();
    (stdout, stderr, frame, rays)
}

#[test]
fn max_flip_chooses_reports_and_uses_a_measured_setting() {
    let dir = scratch("max-flip");
    let pack_path = dir.join("tiny.pack");
    std::fs::write(&pack_path, tiny_pack()).unwrap();

    // A loose budget: the cheapest measured setting, whatever the committed table says.
    let loose = render::budget::choose_god_rays(0.2).expect("the table has god-ray rows");
    assert!(loose.warning.is_none());
    let (stdout, _, frame, rays) =
        render_far(&pack_path, &dir.join("loose"), &["--max-flip", "0.2"]);
    let reported = format!("god rays for --max-flip 0.2: {} samples, ", loose.samples);
    assert!(stdout.contains(&reported), "{stdout}");
    assert!(
        stdout.contains(&format!(
            "measured FLIP mean {:.4}",
            loose.expected_flip_mean
        )),
        "{stdout}"
    );
    assert!(
        stdout.contains(if loose.jitter {
            ", jitter;"
        } else {
            ", no jitter;"
        }),
        "{stdout}"
    );
    // Used: the god-ray target has the chosen size, and the frame is the one the same
    // setting gives through the explicit flags.
    let scaled = |n: u32| ((n as f32 * loose.resolution_scale).round() as u32).max(1);
    assert_eq!(rays.dimensions(), (scaled(64), scaled(36)));
    let samples = loose.samples.to_string();
    let scale = loose.resolution_scale.to_string();
    let mut explicit = vec!["--samples", &samples, "--ray-scale", &scale];
    if loose.jitter {
        explicit.push("--jitter");
    }
    let (stdout, _, same_frame, same_rays) =
        render_far(&pack_path, &dir.join("explicit"), &explicit);
    assert!(
        stdout.contains(&format!("god rays: {} samples", loose.samples)),
        "{stdout}"
    );
    assert!(
        same_frame == frame && same_rays == rays,
        "--max-flip and explicit flags differ"
    );

    // Tighter than any measured setting: the most accurate one, and a warning (asked with the
    // flag's old spelling, which still works).
    let tight = render::budget::choose_god_rays(0.0).unwrap();
    let (stdout, stderr, tight_frame, tight_rays) =
        render_far(&pack_path, &dir.join("tight"), &["--max-error", "0"]);
    assert!(
        stderr.contains("warning:") && stderr.contains("tighter than any measured setting"),
        "{stderr}"
    );
    assert!(
        stdout.contains(&format!(
            "god rays for --max-flip 0: {} samples",
            tight.samples
        )),
        "{stdout}"
    );
    assert_ne!(
        (tight.samples, tight.resolution_scale),
        (loose.samples, loose.resolution_scale)
    );
    assert!(
        tight_frame != frame && tight_rays != rays,
        "the two budgets rendered the same god rays"
    );

    // The budget replaces the explicit quality flags; both together are a usage error.
    let o = viewer(&[
        pack_path.as_os_str(),
        "--headless".as_ref(),
        "--max-flip".as_ref(),
        "0.02".as_ref(),
        "--samples".as_ref(),
        "16".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("cannot be used with"), "{err}");
    let o = viewer(&[
        pack_path.as_os_str(),
        "--headless".as_ref(),
        "--max-error".as_ref(),
        "-1".as_ref(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    let _ = std::fs::remove_dir_all(&dir);
}
