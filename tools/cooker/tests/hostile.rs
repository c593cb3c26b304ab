//! The bad-input catalogue: every hostile file gets a specific message naming the file and
//! its reason once, the documented exit code, no panic, and no output (a pack already at the
//! output path stays as it was). Cases are built here in code, plus every fuzz regression in
//! tests/data/bad/ and every malformed third-party file we keep.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::{assert_said_once, cooker};

const OLD_PACK: &[u8] = b"an old pack that must survive a failed cook";

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn cook(input: &Path, out: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("cook")
        .arg(input)
        .arg("-o")
        .arg(out)
        .arg("--no-cache")
        .output()
        .expect("cooker runs")
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

/// Cooks `input`, expecting `code`; the message must name `names` (a file) and say `says`.
fn expect(input: &Path, code: i32, names: &str, says: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.pack");
    std::fs::write(&out, OLD_PACK).unwrap();
    let o = cook(input, &out);
    let msg = text(&o);
    assert_eq!(o.status.code(), Some(code), "{}: {msg}", input.display());
    assert!(!msg.contains("panicked"), "{}: {msg}", input.display());
    assert!(
        msg.contains(names),
        "{}: message does not name {names:?}: {msg}",
        input.display()
    );
    assert!(
        !says.is_empty() && msg.to_lowercase().contains(&says.to_lowercase()),
        "{}: message does not say {says:?}: {msg}",
        input.display()
    );
    assert_said_once(&msg);
    if code != 0 {
        assert_eq!(
            std::fs::read(&out).unwrap(),
            OLD_PACK,
            "{}: old pack changed",
            input.display()
        );
        let entries = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(entries, 1, "{}: temp files left behind", input.display());
    }
    msg
}

const QUAD_OBJ: &str = "mtllib quad.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl glass\nf 1/1/1 2/2/1 3/3/1 4/4/1\n";

/// A scene with one window whose design is `design`.
fn window_scene(dir: &Path, design: &str) -> PathBuf {
    std::fs::write(dir.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(dir.join("quad.mtl"), "newmtl glass\nKd 1 1 1\n").unwrap();
    let manifest = format!(
        "[[mesh]]\nsource = \"quad.obj\"\n\n[[rule]]\nmatch = \"glass\"\nclass = \"window-lower\"\n\n\
         [[window]]\nmaterial = \"glass\"\ndesign = \"{design}\"\n\n\
         [light]\ntype = \"directional\"\ndirection = [0.0, -0.5, -1.0]\nangular_size_deg = 0.53\n"
    );
    let path = dir.join("scene.toml");
    std::fs::write(&path, manifest).unwrap();
    path
}

fn png_bytes(w: u32, h: u32) -> Vec<u8> {
    let img = image::RgbaImage::from_fn(w, h, |x, y| image::Rgba([x as u8, y as u8, 128, 255]));
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A PNG whose header claims `w`×`h` (with a valid CRC) but holds almost no data.
fn png_claiming(w: u32, h: u32) -> Vec<u8> {
    let mut ihdr = b"IHDR".to_vec();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 6, 0, 0, 0]);
    let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
    png.extend_from_slice(&13u32.to_be_bytes());
    png.extend_from_slice(&ihdr);
    png.extend_from_slice(&crc32fast::hash(&ihdr).to_be_bytes());
    // One tiny IDAT (zlib of a single zero byte), so decoders get past the header.
    let mut idat = b"IDAT".to_vec();
    idat.extend_from_slice(&[0x78, 0x9c, 0x63, 0x00, 0x00, 0x00, 0x01, 0x00, 0x01]);
    png.extend_from_slice(&9u32.to_be_bytes());
    png.extend_from_slice(&idat);
    png.extend_from_slice(&crc32fast::hash(&idat).to_be_bytes());
    png.extend_from_slice(&[0, 0, 0, 0, b'I', b'E', b'N', b'D', 0xAE, 0x42, 0x60, 0x82]);
    png
}

#[test]
fn hostile_images() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let good = png_bytes(64, 32);
    std::fs::write(d.join("truncated.png"), &good[..good.len() / 2]).unwrap();
    std::fs::write(d.join("empty.png"), b"").unwrap();
    std::fs::write(d.join("huge.png"), png_claiming(100_000, 100_000)).unwrap();
    std::fs::write(d.join("garbage.png"), b"this is not an image at all").unwrap();
    for (file, says) in [
        (
            "truncated.png",
            "cannot decode image: unexpected end of file",
        ),
        ("empty.png", "cannot decode image: unexpected end of file"),
        ("huge.png", "claims 100000x100000 texels, over the limit"),
        ("garbage.png", "Invalid PNG signature"),
    ] {
        let scene = window_scene(d, file);
        let msg = expect(&scene, 3, file, says);
        // At the [[window]] entry that names it, not only the image's own path.
        assert!(msg.contains("scene.toml:10: window design "), "{msg}");
    }
    let scene = window_scene(d, "missing.png");
    expect(
        &scene,
        3,
        "missing.png",
        "window design \"missing.png\" cannot be read",
    );
}

/// An image that cannot be used is reported at the manifest line that names it, whichever key
/// names it: a panorama, a rule's texture or normal map, a window's normal map (only window
/// designs were, and `validate` passed the others while the cook failed). A mesh source in
/// no format the cook reads is reported at its line too.
#[test]
fn files_named_anywhere_in_a_manifest_are_reported_at_their_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(d.join("quad.mtl"), "newmtl glass\nKd 1 1 1\n").unwrap();
    std::fs::write(d.join("good.png"), png_bytes(16, 16)).unwrap();
    let good = png_bytes(64, 32);
    std::fs::write(d.join("bad.png"), &good[..good.len() / 2]).unwrap();
    std::fs::write(d.join("mesh.png"), &good).unwrap();
    // Each line names good.png but the one under test, which names bad.png.
    let lines = [
        ("[[mesh]]", ""),
        ("source = \"quad.obj\"", ""),
        ("[[rule]]", ""),
        ("match = \"glass\"", ""),
        ("class = \"window-lower\"", ""),
        ("texture = \"good.png\"", "texture"),
        ("normal_map = \"good.png\"", "normal_map"),
        ("[[window]]", ""),
        ("material = \"glass\"", ""),
        ("normal_map = \"good.png\"", "normal_map"),
        ("[background]", ""),
        ("panorama = \"good.png\"", "panorama"),
        ("[light]", ""),
        ("type = \"directional\"", ""),
        ("direction = [0.0, -0.5, -1.0]", ""),
    ];
    let scene = d.join("scene.toml");
    let cooker = |args: &[&std::ffi::OsStr]| {
        Command::new(env!("CARGO_BIN_EXE_cooker"))
            .args(args)
            .output()
            .expect("cooker runs")
    };
    for (at, (_, what)) in lines.iter().enumerate().filter(|(_, l)| !l.1.is_empty()) {
        let text_of = |bad: usize| {
            lines
                .iter()
                .enumerate()
                .map(|(i, (l, _))| {
                    if i == bad {
                        l.replace("good.png", "bad.png")
                    } else if bad == 6 && i == 9 {
                        // The window's own map would stand in for its glass's.
                        "# the glass's normal map serves the window".to_string()
                    } else {
                        l.to_string()
                    }
                })
                .collect::<Vec<_>>()
                .join("\n")
        };
        std::fs::write(&scene, text_of(at)).unwrap();
        let line = format!("scene.toml:{}: {what} \"bad.png\" cannot be used: ", at + 1);
        let msg = expect(&scene, 3, "bad.png", "unexpected end of file");
        assert!(msg.contains(&line), "{msg}");
        let o = cooker(&["validate".as_ref(), scene.as_os_str()]);
        assert_eq!(o.status.code(), Some(3), "{}", text(&o));
        assert!(text(&o).contains(&line), "{}", text(&o));
    }
    // A colour image given as a normal map is warned of at the line that gives it.
    let window_map_only: Vec<String> = lines
        .iter()
        .enumerate()
        .map(|(i, (l, _))| match i {
            6 => "# no normal map of the rule's".to_string(),
            _ => l.to_string(),
        })
        .collect();
    std::fs::write(&scene, window_map_only.join("\n")).unwrap();
    let out = d.join("good.pack");
    let o = cooker(&[
        "cook".as_ref(),
        scene.as_os_str(),
        "-o".as_ref(),
        out.as_os_str(),
        "--no-cache".as_ref(),
    ]);
    let t = text(&o);
    assert_eq!(o.status.code(), Some(0), "{t}");
    assert!(
        t.lines()
            .any(|l| l.contains("scene.toml:10: ") && l.contains("is it a colour image")),
        "{t}"
    );
    std::fs::write(&scene, text_of_mesh(&lines)).unwrap();
    let msg = expect(
        &scene,
        3,
        "mesh.png",
        "mesh source \"mesh.png\" cannot be used",
    );
    assert!(msg.contains("scene.toml:2: "), "{msg}");
    // The mesh named as an image too: the image's error is at the line naming it as one.
    let mesh_as_panorama: Vec<String> = lines
        .iter()
        .map(|(l, _)| l.replace("panorama = \"good.png\"", "panorama = \"quad.obj\""))
        .collect();
    std::fs::write(&scene, mesh_as_panorama.join("\n")).unwrap();
    let msg = expect(
        &scene,
        3,
        "quad.obj",
        "panorama \"quad.obj\" cannot be used",
    );
    assert!(msg.contains("scene.toml:12: "), "{msg}");

    fn text_of_mesh(lines: &[(&str, &str)]) -> String {
        lines
            .iter()
            .map(|(l, _)| l.replace("quad.obj", "mesh.png"))
            .collect::<Vec<_>>()
            .join("\n")
    }
}

#[test]
fn hostile_meshes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let write = |name: &str, bytes: &[u8]| {
        let p = d.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    // Zero-length and empty-of-geometry files.
    for name in ["empty.obj", "empty.gltf", "empty.glb"] {
        expect(&write(name, b""), 3, name, "the file is empty (0 bytes)");
    }
    // Points and lines only: an empty pack would pass a gate on the exit status.
    let points = write("points.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\np 1 2 3\nl 1 2\n");
    expect(
        &points,
        3,
        "points.obj:4",
        "no faces (1 line and 1 point elements ignored: only faces are cooked): nothing to cook",
    );
    // A glTF of lines only says so too (it said the model held "no geometry, or only
    // vertices").
    let lines = write(
        "lines.gltf",
        br#"{"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}], "meshes": [{"primitives": [{"attributes": {"POSITION": 0},
        "mode": 1}]}], "accessors": [{"bufferView": 0, "componentType": 5126, "count": 2,
        "type": "VEC3", "min": [0, 0, 0], "max": [1, 0, 0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 24}], "buffers": [{"byteLength": 24,
        "uri": "data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAA"}]}"#,
    );
    expect(
        &lines,
        3,
        "lines.gltf",
        "no faces (primitives of mode Lines ignored: only triangles are cooked): nothing to cook",
    );
    // Faces of fewer than three corners: said at the first, not as points or lines.
    let short = write(
        "short.obj",
        b"v 0 0 0
v 1 0 0
v 0 1 0

f 1
f 2 3
",
    );
    expect(
        &short,
        3,
        "short.obj:5",
        "no faces (2 faces with fewer than 3 vertices ignored): nothing to cook",
    );
    // `init` refuses such a model too, and writes no manifest that could only fail to cook.
    let manifest = d.join("short.toml");
    let o = cooker(&[&"init", &short, &"-o", &manifest]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(text(&o).contains("short.obj:5: no faces"), "{}", text(&o));
    assert!(!manifest.exists());
    // Faces of zero area only, as written or as placed (an empty pack, exit 0).
    let flat = write("flat.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
    expect(
        &flat,
        3,
        "flat.obj",
        "every face has zero area (as placed): nothing to cook",
    );
    std::fs::write(d.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(d.join("quad.mtl"), "newmtl glass\nKd 1 1 1\n").unwrap();
    let tiny = write(
        "tiny.toml",
        b"[[mesh]]\nsource = \"quad.obj\"\nscale = 1e-30\n\n[[mesh]]\nsource = \"flat.obj\"\n",
    );
    expect(
        &tiny,
        3,
        "quad.obj",
        "every face of the scene's 2 meshes has zero area",
    );
    let v = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("validate")
        .arg(&flat)
        .output()
        .unwrap();
    let t = text(&v);
    assert_eq!(v.status.code(), Some(1), "{t}");
    assert!(
        t.contains("no-triangles") && t.contains("every face has zero area"),
        "{t}"
    );
    // A texture a material names that cannot be decoded: said with the material and model.
    std::fs::write(d.join("garbled.png"), b"this is not an image at all").unwrap();
    std::fs::write(
        d.join("tex.mtl"),
        "newmtl stone\nKd 1 1 1\nmap_Kd garbled.png\n",
    )
    .unwrap();
    let tex = write(
        "tex.obj",
        b"mtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nusemtl stone\nf 1/1 2/2 3/3\n",
    );
    expect(
        &tex,
        3,
        "tex.obj",
        "tex.obj: diffuse texture of material \"stone\": ",
    );
    // NaN and infinite coordinates, with the line.
    expect(
        &write("nan.obj", b"v 0 0 0\nv 1 0 0\nv nan 1 0\nf 1 2 3\n"),
        3,
        "nan.obj:3",
        "vertex coordinate \"nan\" is not finite",
    );
    expect(
        &write("inf.obj", b"v 0 0 0\nv 1 inf 0\nv 0 1 0\nf 1 2 3\n"),
        3,
        "inf.obj:2",
        "vertex coordinate \"inf\" is not finite",
    );
    // Indices past the end.
    expect(
        &write("index.obj", b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"),
        3,
        "index.obj:4",
        "vertex index 9 is out of range",
    );
    // UTF-16 text is not an OBJ.
    let utf16: Vec<u8> = "\u{feff}v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"
        .encode_utf16()
        .flat_map(|u| u.to_le_bytes())
        .collect();
    expect(
        &write("utf16.obj", &utf16),
        3,
        "utf16.obj",
        "UTF-16 or binary",
    );
    // A missing MTL cooks with a warning.
    expect(
        &write(
            "nomtl.obj",
            b"mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
        ),
        0,
        "gone.mtl",
        "warning",
    );
    // A truncated GLB.
    let glb = std::fs::read(root().join("tests/data/third_party/gltf/Box/Box.glb")).unwrap();
    expect(
        &write("truncated.glb", &glb[..glb.len() / 2]),
        3,
        "truncated.glb",
        "GLB header declares 1664 bytes, but the file has 832",
    );
    // A node hierarchy that contains itself.
    let recursive = br#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"children":[1]},{"children":[0]}]}"#;
    expect(
        &write("recursive.gltf", recursive),
        3,
        "recursive.gltf",
        "node hierarchy is cyclic",
    );
}

/// The exit code and reason of every file in tests/data/bad/ (fuzz regressions). A file added
/// there without a line here fails the test, so none is left out of the replay.
const FUZZ_REGRESSIONS: &[(&str, i32, &str)] = &[
    // The header's length underflows gltf's own reader.
    (
        "glb-length-underflow.glb",
        3,
        "GLB header declares 0 bytes, but the file has 1749",
    ),
    (
        "gltf-image-without-mime-type.glb",
        3,
        "image 0 needs a uri, or a bufferView with a mimeType",
    ),
    // gltf-json's validation indexed the accessor before checking it.
    (
        "gltf-position-accessor-out-of-range.gltf",
        3,
        "mesh 3 primitive 0 uses accessor 13, but there are 13",
    ),
];

#[test]
fn every_fuzz_regression_is_replayed() {
    let dir = root().join("tests/data/bad");
    let mut replayed = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        let Some(&(_, code, says)) = FUZZ_REGRESSIONS.iter().find(|(f, ..)| *f == name) else {
            panic!("{name}: no expected exit code and message in FUZZ_REGRESSIONS");
        };
        expect(&path, code, &name, says);
        replayed += 1;
    }
    assert_eq!(replayed, FUZZ_REGRESSIONS.len(), "a listed file is missing");
}

#[test]
fn hostile_manifests_and_outputs() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("quad.obj"), QUAD_OBJ).unwrap();
    std::fs::write(d.join("quad.mtl"), "newmtl glass\n").unwrap();
    let m = |name: &str, body: &str| {
        let p = d.join(name);
        std::fs::write(&p, body).unwrap();
        p
    };
    expect(
        &m(
            "unknown.toml",
            "[[mesh]]\nsource = \"quad.obj\"\ncolour = 3\n",
        ),
        3,
        "unknown.toml:3",
        "unknown field `colour`",
    );
    expect(
        &m("type.toml", "[[mesh]]\nsource = 42\n"),
        3,
        "type.toml:2",
        "invalid type: integer `42`, expected a string",
    );
    expect(
        &m("missing.toml", "[[mesh]]\nsource = \"nothere.obj\"\n"),
        3,
        "nothere.obj",
        "mesh source \"nothere.obj\" cannot be read",
    );
    expect(
        &m("syntax.toml", "[[mesh]\nsource = \"quad.obj\"\n"),
        3,
        "syntax.toml:1",
        "unclosed array table",
    );
    expect(&m("empty.toml", ""), 3, "empty.toml", "no [[mesh]] entries");

    // Output paths the OS refuses: exit 4, and the whole line: what was done, the path, the
    // operating system's reason, each once.
    let scene = m("ok.toml", "[[mesh]]\nsource = \"quad.obj\"\n");
    for (out, reason) in [
        (
            d.join("no/such/dir/out.pack"),
            "No such file or directory (os error 2)",
        ),
        (d.join("quad.obj/out.pack"), "Not a directory (os error 20)"),
    ] {
        let o = cook(&scene, &out);
        assert_eq!(o.status.code(), Some(4), "{}: {}", out.display(), text(&o));
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(
            stderr.lines().last(),
            Some(format!("error: writing the pack: {}: {reason}", out.display()).as_str()),
            "{stderr}"
        );
    }

    // A directory is bad usage, said before the cook runs (it cooked, then exited 4).
    let o = cook(&scene, d);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(
        stderr.lines().last(),
        Some(
            format!(
                "error: -o {}: is a directory; name the file to write in it, e.g. -o {}",
                d.display(),
                d.join("scene.pack").display()
            )
            .as_str()
        ),
        "{stderr}"
    );
    assert!(!stderr.contains("note:"), "cooked first: {stderr}");
}

#[test]
fn third_party_malformed_files_never_panic() {
    let base = root().join("tests/data/third_party/bad");
    let mut files = Vec::new();
    let mut stack = vec![base.clone()];
    while let Some(dir) = stack.pop() {
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(
                p.extension().and_then(|e| e.to_str()),
                Some("obj" | "gltf" | "glb" | "ply")
            ) {
                files.push(p);
            }
        }
    }
    files.sort();
    assert!(
        files.len() >= 10,
        "catalogue has only {} files",
        files.len()
    );
    let dir = tempfile::tempdir().unwrap();
    for f in files {
        let out = dir.path().join("out.pack");
        let _ = std::fs::remove_file(&out);
        let o = cook(&f, &out);
        let msg = text(&o);
        let code = o.status.code();
        assert!(
            matches!(code, Some(0) | Some(3)),
            "{}: exit {code:?}: {msg}",
            f.display()
        );
        assert!(!msg.contains("panicked"), "{}: {msg}", f.display());
        assert_said_once(&msg);
        if code == Some(3) {
            let name = f.file_name().unwrap().to_string_lossy().into_owned();
            assert!(
                msg.contains(&name) || msg.contains(".bin") || msg.contains(".mtl"),
                "{}: error names no file: {msg}",
                f.display()
            );
            assert!(!out.exists(), "{}: failed cook left a pack", f.display());
        } else {
            pack::Pack::open(&out)
                .unwrap_or_else(|e| panic!("{}: cooked pack invalid: {e}", f.display()));
        }
    }
}
