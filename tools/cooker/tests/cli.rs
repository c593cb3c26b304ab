//! The `cooker cook` and `cooker validate` command lines: exit codes, messages, no partial packs.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::assert_said_once;

/// Runs the cooker; `cook` runs without the cache, so every run cooks and reports its stages.
fn cooker(args: &[&str]) -> Output {
    let mut args = args.to_vec();
    if args.first() == Some(&"cook") {
        args.push("--no-cache");
    }
    common::command().args(&args).output().expect("cooker runs")
}

fn data(rel: &str) -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/third_party")
        .join(rel)
        .to_string_lossy()
        .into_owned()
}

/// A fresh, empty directory for one test.
fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cooker-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn text(b: &[u8]) -> String {
    String::from_utf8_lossy(b).into_owned()
}

#[test]
fn cook_verbose_reports_stages_and_acmr() {
    let dir = scratch("verbose");
    let out = dir.join("bunny.pack");
    let o = cooker(&[
        "cook",
        &data("classic/stanford-bunny.obj"),
        "-o",
        out.to_str().unwrap(),
        "-v",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    let acmr = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("acmr_in="))
        .expect("acmr line");
    let out_value: f32 = acmr
        .split("acmr_out=")
        .nth(1)
        .unwrap()
        .trim()
        .parse()
        .unwrap();
    assert!(out_value <= 0.70, "{acmr}");
    assert!(
        stdout.contains("total: triangles 69451 -> 69451"),
        "{stdout}"
    );
    assert!(
        stdout.contains("overfetch=") && stdout.contains("bytes/triangle="),
        "{stdout}"
    );
    // Every stage, write last, with the peak memory so far: never falling, and at least the
    // bunny's 1.4 MB pack, which the write held whole.
    let peaks: Vec<(String, f64)> = stdout
        .lines()
        .filter_map(|l| l.strip_prefix("stage "))
        .map(|l| {
            let (name, rest) = l.split_at(12);
            let mb = rest.split("peak RSS ").nth(1).expect(l);
            (
                name.trim().to_string(),
                mb.trim_end_matches(" MB").parse().expect(l),
            )
        })
        .collect();
    let names: Vec<&str> = peaks.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names.first(), Some(&"import"), "{stdout}");
    assert_eq!(names.last(), Some(&"write"), "{stdout}");
    assert!(
        names.contains(&"mesh") && names.contains(&"textures"),
        "{stdout}"
    );
    assert!(peaks.windows(2).all(|w| w[0].1 <= w[1].1), "{stdout}");
    assert!(peaks.last().unwrap().1 >= 1.4, "{stdout}");
    // A bare mesh's guessed views are timed, on the line after the mesh stage they ran beside.
    let after_mesh = stdout
        .lines()
        .skip_while(|l| !l.starts_with("stage mesh"))
        .nth(1)
        .unwrap_or_default();
    assert!(
        after_mesh
            .trim_start()
            .starts_with("guessed light and cameras")
            && after_mesh.contains(" ms"),
        "{stdout}"
    );
    assert!(
        text(&o.stderr).contains("cooking a bare mesh without a scene.toml")
            && text(&o.stderr).contains("`cooker init`"),
        "a bare mesh warns"
    );
    // The pack it wrote validates clean.
    let v = cooker(&["validate", out.to_str().unwrap()]);
    assert_eq!(v.status.code(), Some(0), "{}", text(&v.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn validate_json_lists_findings_and_materials() {
    let o = cooker(&["validate", &data("cornell_box/cornell_box.obj"), "--json"]);
    assert_eq!(
        o.status.code(),
        Some(1),
        "findings exit 1: {}",
        text(&o.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let findings = v["findings"].as_array().unwrap();
    assert!(findings.iter().any(|f| f["code"] == "untagged"));
    assert!(
        findings
            .iter()
            .any(|f| f["code"] == "unused-material"
                && f["message"].as_str().unwrap().contains("blue"))
    );
    let materials = v["materials"].as_array().unwrap();
    let floor = materials.iter().find(|m| m["class"] == "floor").unwrap();
    assert_eq!(floor["triangles"], 6);
    // Text output numbers its findings.
    let o = cooker(&["validate", &data("cornell_box/cornell_box.obj")]);
    assert!(
        text(&o.stdout).contains("  1. [untagged]"),
        "{}",
        text(&o.stdout)
    );
}

/// A model of lines only validated clean ("no findings", exit 0) and cooked an empty pack.
#[test]
fn validate_finds_a_model_without_faces() {
    let o = cooker(&["validate", &data("bad/obj/tobj/lines.obj"), "--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert!(
        v["findings"]
            .as_array()
            .unwrap()
            .iter()
            .any(|f| f["code"] == "no-triangles"
                && f["message"]
                    .as_str()
                    .unwrap()
                    .contains("lines.obj: no faces")),
        "{v:#}"
    );
}

/// A gate on third-party models can accept what their exporters leave behind: allowed findings
/// are listed and marked, and only the others exit 1.
#[test]
fn validate_allow_accepts_findings_by_code() {
    let obj = data("cornell_box/cornell_box.obj");
    let o = cooker(&["validate", &obj, "--allow", "unused-material"]);
    assert_eq!(o.status.code(), Some(1), "untagged is left");
    assert!(
        text(&o.stdout).contains("  2. [unused-material] (allowed) material \"blue\""),
        "{}",
        text(&o.stdout)
    );
    let o = cooker(&[
        "validate",
        &obj,
        "--allow",
        "unused-material",
        "--allow",
        "untagged",
        "--json",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let findings = v["findings"].as_array().unwrap();
    assert_eq!(findings.len(), 2, "{v:#}");
    assert!(findings.iter().all(|f| f["allowed"] == true), "{v:#}");
    // A code that does not exist is bad usage, and the message lists those that do.
    let o = cooker(&["validate", &obj, "--allow", "unused-materials"]);
    assert_eq!(o.status.code(), Some(2));
    let err = text(&o.stderr);
    assert!(
        err.contains("invalid value 'unused-materials' for '--allow <CODE>'")
            && err.contains("unused-material"),
        "{err}"
    );
}

#[test]
fn bad_input_exits_3_with_file_and_line_and_keeps_the_old_pack() {
    let dir = scratch("bad");
    let out = dir.join("scene.pack");
    std::fs::write(&out, b"previous pack").unwrap();
    for (file, at, says) in [
        (
            "bad/obj/tinyobjloader/test-nan.obj",
            "test-nan.obj:12:",
            "vertex coordinate \"nan\" is not finite",
        ),
        (
            "bad/obj/tobj/invalid_index.obj",
            "invalid_index.obj:12:",
            "vertex index 7 is out of range: 6 vertices are defined before this line",
        ),
        (
            "bad/gltf/tinygltf/integer-out-of-bounds.gltf",
            "integer-out-of-bounds.gltf:34:",
            "invalid glTF JSON: invalid type: floating point `1e+300`, expected u64",
        ),
        (
            "bad/gltf/tinygltf/invalid-primitive-indices.gltf",
            "invalid-primitive-indices.gltf:",
            "mesh 0 primitive 0 uses accessor 1, but there are 1",
        ),
    ] {
        let o = cooker(&["cook", &data(file), "-o", out.to_str().unwrap()]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "{file}: {err}");
        assert!(err.contains(at) && err.contains(says), "{file}: {err}");
        assert_said_once(&err);
        assert_eq!(std::fs::read(&out).unwrap(), b"previous pack");
    }
    // One whole line for exit 3: the label, file and line, the reason, nothing else.
    let nan = data("bad/obj/tinyobjloader/test-nan.obj");
    let o = cooker(&["cook", &nan, "-o", out.to_str().unwrap()]);
    assert_eq!(
        text(&o.stderr),
        format!("error: {nan}:12: vertex coordinate \"nan\" is not finite\n")
    );
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(leftovers.len(), 1, "temp files left behind: {leftovers:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn manifest_errors_name_the_line() {
    let dir = scratch("manifest");
    let obj = data("cornell_box/cornell_box.obj");
    let cases = [
        (
            format!("[[mesh]]\nsource = {obj:?}\ncolour = 1\n"),
            ":3:",
            "unknown field `colour`",
        ),
        (
            format!("[[mesh]]\nsource = {obj:?}\n\n[[rule]]\nmatch = \"x\"\nclass = \"roof\"\n"),
            ":6:",
            "class is \"roof\" but must be one of",
        ),
        (
            "[[mesh]]\nsource = \"nowhere.obj\"\n".to_string(),
            ":2:",
            "mesh source \"nowhere.obj\" cannot be read",
        ),
        (
            format!("[[mesh]]\nsource = {obj:?}\nscale = \"big\"\n"),
            ":3:",
            "scale: a number or [x, y, z]",
        ),
        (
            format!(
                "[[mesh]]\nsource = {obj:?}\n[light]\ntype = \"point\"\nposition = [0.0, 1.0, 0.0]\n"
            ),
            ":3:",
            "a point light needs `radius`",
        ),
    ];
    for (i, (body, line, word)) in cases.iter().enumerate() {
        let manifest = dir.join(format!("scene{i}.toml"));
        std::fs::write(&manifest, body).unwrap();
        let o = cooker(&[
            "cook",
            manifest.to_str().unwrap(),
            "-o",
            dir.join("x.pack").to_str().unwrap(),
        ]);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(3), "case {i}: {err}");
        assert!(
            err.contains(&format!("scene{i}.toml{line}")),
            "case {i}: {err}"
        );
        assert!(err.contains(word), "case {i}: {err}");
        assert_said_once(&err);
        assert!(!dir.join("x.pack").exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn oddities_cook_with_warnings_and_exit_0() {
    let dir = scratch("odd");
    let obj = dir.join("mixed.obj");
    // A quad (n-gon), a line and a point, and a material library that does not exist.
    std::fs::write(
        &obj,
        "mtllib gone.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nl 1 2\np 3\nf 1 2 3 4\n",
    )
    .unwrap();
    let out = dir.join("mixed.pack");
    let o = cooker(&["cook", obj.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let err = text(&o.stderr);
    assert_eq!(o.status.code(), Some(0), "{err}");
    assert!(
        err.contains("mixed.obj:6: 1 line and 1 point elements ignored"),
        "{err}"
    );
    assert!(
        err.contains("mixed.obj:1: material library \"gone.mtl\" not found"),
        "{err}"
    );
    assert!(
        text(&o.stdout).contains("2 triangles"),
        "{}",
        text(&o.stdout)
    );
    assert!(out.exists());
    let _ = std::fs::remove_dir_all(&dir);
}

/// A model's names are printed with their control characters escaped: `info` ran the escape
/// sequences in a material's and an object's names on the terminal.
#[test]
fn info_prints_names_with_control_characters_escaped() {
    let dir = scratch("escapes");
    let obj = dir.join("e.obj");
    std::fs::write(dir.join("e.mtl"), "newmtl red\x1b[31mglass\nKd 1 0 0\n").unwrap();
    std::fs::write(
        &obj,
        "mtllib e.mtl\no title\x1b]0;owned\x07\nusemtl red\x1b[31mglass\n\
         v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    )
    .unwrap();
    let out = dir.join("e.pack");
    let o = cooker(&["cook", obj.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(!text(&o.stderr).contains('\x1b'), "{}", text(&o.stderr));
    let o = cooker(&["info", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let said = text(&o.stdout);
    assert!(!said.contains('\x1b'), "{said:?}");
    assert!(said.contains("red\\u{1b}[31mglass"), "{said}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn missing_input_is_an_io_error() {
    let o = cooker(&[
        "cook",
        "/nonexistent/dir/scene.obj",
        "-o",
        "/tmp/never.pack",
    ]);
    assert_eq!(o.status.code(), Some(4), "{}", text(&o.stderr));
    // The whole line for exit 4: the path, then the operating system's reason, once.
    assert_eq!(
        text(&o.stderr),
        "error: /nonexistent/dir/scene.obj: No such file or directory (os error 2)\n"
    );
    let o = cooker(&["cook", "scene.obj"]);
    assert_eq!(o.status.code(), Some(2), "missing -o is bad usage");
    let err = text(&o.stderr);
    assert!(
        err.starts_with("error: the following required arguments were not provided:")
            && err.contains("--output <OUTPUT>"),
        "{err}"
    );
}

/// `-o` naming a file the command reads (the model, its MTL, by another path or a hard link,
/// the pack `extract` reads) is refused before anything is written: the rename would have
/// replaced the model with the pack, and `--force` replaces manifests, not models.
#[test]
fn an_output_over_an_input_is_refused() {
    let dir = scratch("over-input");
    for f in ["cornell_box.obj", "cornell_box.mtl"] {
        std::fs::copy(data(&format!("cornell_box/{f}")), dir.join(f)).unwrap();
    }
    let obj = dir.join("cornell_box.obj");
    let mtl = dir.join("cornell_box.mtl");
    let linked = dir.join("linked.obj");
    std::fs::hard_link(&obj, &linked).unwrap();
    let (obj_before, mtl_before) = (std::fs::read(&obj).unwrap(), std::fs::read(&mtl).unwrap());
    let other_path = dir.join(".").join("cornell_box.mtl");
    let s = |p: &Path| p.to_string_lossy().into_owned();
    for (args, input) in [
        (vec!["cook", &s(&obj), "-o", &s(&obj)], "cornell_box.obj"),
        (
            vec!["cook", &s(&obj), "-o", &s(&other_path)],
            "cornell_box.mtl",
        ),
        (vec!["cook", &s(&obj), "-o", &s(&linked)], "cornell_box.obj"),
        (
            vec!["init", &s(&obj), "-o", &s(&mtl), "--force"],
            "cornell_box.mtl",
        ),
    ] {
        let o = cooker(&args);
        let err = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(&format!(
                "{input}, an input of this command; refusing to replace it"
            )),
            "{args:?}: {err}"
        );
    }
    assert_eq!(std::fs::read(&obj).unwrap(), obj_before);
    assert_eq!(std::fs::read(&mtl).unwrap(), mtl_before);
    let pack = dir.join("box.pack");
    assert!(
        cooker(&["cook", &s(&obj), "-o", &s(&pack)])
            .status
            .success()
    );
    let pack_before = std::fs::read(&pack).unwrap();
    let o = cooker(&["extract", &s(&pack), "anything", "-o", &s(&pack)]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert_eq!(std::fs::read(&pack).unwrap(), pack_before);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A pane whose inside is against its normal, with a wall on that side: its inside was
/// written `[-1.0, -0.0, -0.0]`, the negated normal's signed zeros.
#[test]
fn init_writes_an_inside_without_negative_zeros() {
    let dir = scratch("negzero");
    std::fs::write(
        dir.join("g.mtl"),
        "newmtl glass\nd 0.3\nnewmtl stone\nKd 0.5 0.5 0.5\n",
    )
    .unwrap();
    let obj = dir.join("w.obj");
    std::fs::write(
        &obj,
        "mtllib g.mtl\nv 0 0 0\nv 0 2 0\nv 0 2 2\nv 0 0 2\nv -3 -1 -1\nv -3 3 -1\nv -3 3 3\n\
         v -3 -1 3\nusemtl glass\nf 1 2 3\nf 1 3 4\nusemtl stone\nf 5 6 7\nf 5 7 8\n",
    )
    .unwrap();
    let toml = dir.join("w.toml");
    let o = cooker(&["init", obj.to_str().unwrap(), "-o", toml.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let written = std::fs::read_to_string(&toml).unwrap();
    assert!(
        written.lines().any(|l| l == "inside = [-1.0, 0.0, 0.0]"),
        "{written}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A lone pane of glass facing up with nothing under it: the default sun through the largest
/// window was the normalized sum of its inside (straight up) and down, NaN, and the cook failed
/// "writing the pack: … light has invalid parameters", `init` with "a bug in cooker init".
#[test]
fn glass_lit_from_below_gets_a_valid_default_sun() {
    let dir = scratch("up");
    std::fs::write(dir.join("g.mtl"), "newmtl glass\nKd 0.2 0.4 0.8\nd 0.3\n").unwrap();
    let obj = dir.join("up.obj");
    std::fs::write(
        &obj,
        "mtllib g.mtl\nv 0 3 0\nv 0 3 2\nv 2 3 2\nv 2 3 0\nusemtl glass\nf 1 2 3\nf 1 3 4\n",
    )
    .unwrap();
    let pack = dir.join("up.pack");
    let o = cooker(&["cook", obj.to_str().unwrap(), "-o", pack.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    let toml = dir.join("up.toml");
    let o = cooker(&["init", obj.to_str().unwrap(), "-o", toml.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o.stderr));
    assert!(!std::fs::read_to_string(&toml).unwrap().contains("nan"));
}

/// `init` names a manifest given as the model at once (it said "exists; pass --force", and with
/// --force that a manifest is no model), and a directory as `-o` is bad usage.
#[test]
fn init_refuses_a_manifest_as_model_and_a_directory_as_output() {
    let dir = scratch("init");
    let toml = dir.join("scene.toml");
    std::fs::write(&toml, "[[mesh]]\nsource = \"m.obj\"\n").unwrap();
    let o = cooker(&["init", toml.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o.stderr));
    assert!(!text(&o.stderr).contains("--force"), "{}", text(&o.stderr));
    let o = cooker(&[
        "init",
        &data("cornell_box/cornell_box.obj"),
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("is a directory; name the file to write in it"),
        "{}",
        text(&o.stderr)
    );
    // The model as its own manifest: refused as such, not "pass --force" (which it refused).
    let model = data("cornell_box/cornell_box.obj");
    let o = cooker(&["init", &model, "-o", &model]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o.stderr));
    assert!(
        text(&o.stderr).contains("an input of this command"),
        "{}",
        text(&o.stderr)
    );
    assert!(!text(&o.stderr).contains("--force"), "{}", text(&o.stderr));
}

/// Output that cannot be written (`> /dev/full`) is an I/O error, exit 4, said in one line:
/// `println!` panicked with a backtrace (exit 101) after the pack was already in place. An
/// error whose message cannot be written keeps its own exit code.
#[cfg(target_os = "linux")]
#[test]
fn unwritable_output_is_an_io_error_not_a_panic() {
    let dir = scratch("devfull");
    let out = dir.join("box.pack");
    let full = || {
        std::fs::File::options()
            .write(true)
            .open("/dev/full")
            .unwrap()
    };
    let o = common::command()
        .args([
            "cook",
            &data("gltf/Box/Box.gltf"),
            "-o",
            out.to_str().unwrap(),
            "--no-cache",
        ])
        .stdout(full())
        .output()
        .unwrap();
    let stderr = text(&o.stderr);
    assert_eq!(o.status.code(), Some(4), "{stderr}");
    assert!(
        stderr.contains("error: failed printing to stdout"),
        "{stderr}"
    );
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(
        cooker(&["info", out.to_str().unwrap()]).status.code(),
        Some(0)
    );
    let o = common::command()
        .args(["info", out.to_str().unwrap()])
        .stdout(full())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(4), "{}", text(&o.stderr));
    // A bad pack is still exit 3 when its error cannot be printed.
    let bad = dir.join("bad.pack");
    std::fs::write(&bad, b"not a pack").unwrap();
    let o = common::command()
        .args(["info", bad.to_str().unwrap()])
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3));
}
