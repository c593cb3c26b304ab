//! `cooker validate` on packs built in code to hold exactly one defect each: the finding's code,
//! a phrase of its message, and exit 1. The unedited sample must be clean, so a finding can
//! only come from the defect.

mod common;

use std::path::Path;
use std::process::{Command, Output};

use pack::testing::{sample, sample_texture};
use pack::{PackData, TextureRole, Toc};

fn validate(pack: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("validate")
        .arg(pack)
        .arg("--json")
        .output()
        .expect("cooker runs")
}

/// Writes the sample pack with `edit` applied and returns validate's exit code and findings
/// as (code, message) pairs.
fn findings(edit: impl FnOnce(&mut Toc, &mut PackData)) -> (Option<i32>, Vec<(String, String)>) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.pack");
    let (mut toc, mut data) = sample();
    edit(&mut toc, &mut data);
    pack::write_pack(&path, toc, &data).unwrap();
    let o = validate(&path);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap_or_else(|e| {
        panic!(
            "validate --json printed no JSON ({e}): {}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        )
    });
    let list = v["findings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            (
                f["code"].as_str().unwrap().to_string(),
                f["message"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    (o.status.code(), list)
}

#[test]
fn the_unedited_sample_is_clean() {
    let (code, list) = findings(|_, _| {});
    assert_eq!((code, list.len()), (Some(0), 0), "{list:#?}");
}

#[test]
fn a_vertex_with_another_material_is_a_material_mismatch() {
    let (code, list) = findings(|_, data| {
        // The sample's first vertex belongs to range 0 (material 0); its material ID is the
        // u16 after position, normal, uv and tangent (48 bytes in).
        let v = &mut data.meshes[0].vertices;
        v[48..50].copy_from_slice(&1u16.to_le_bytes());
    });
    assert_eq!(code, Some(1), "{list:#?}");
    let codes: Vec<&str> = list.iter().map(|(c, _)| c.as_str()).collect();
    assert_eq!(codes, ["material-mismatch"], "{list:#?}");
    assert!(
        list[0].1.contains("1 triangles") && list[0].1.contains("range material 0"),
        "{}",
        list[0].1
    );
}

#[test]
fn a_texture_nothing_references_is_unused() {
    let (code, list) = findings(|toc, data| {
        let (t, levels) = sample_texture("orphan", TextureRole::Colour, 2, 2);
        toc.textures.push(t);
        data.textures.push(levels);
    });
    assert_eq!(code, Some(1), "{list:#?}");
    let codes: Vec<&str> = list.iter().map(|(c, _)| c.as_str()).collect();
    assert_eq!(codes, ["unused-texture"], "{list:#?}");
    assert!(
        list[0].1.contains("\"orphan\"") && list[0].1.contains("referenced by nothing"),
        "{}",
        list[0].1
    );
}

/// A pack with windows and no light cooks every window dark: validate says so (it said
/// nothing, while the cook listed each projector as skipped). The sample has a light and a
/// window, so the one finding comes from the light removed.
#[test]
fn windows_without_a_light_are_a_finding() {
    let (code, list) = findings(|toc, _| toc.light = None);
    assert_eq!(code, Some(1), "{list:#?}");
    let codes: Vec<&str> = list.iter().map(|(c, _)| c.as_str()).collect();
    assert_eq!(codes, ["no-light"], "{list:#?}");
    assert!(list[0].1.contains("throw"), "{}", list[0].1);
}

/// The same of a scene: the default scene without its `[light]` has the finding, as it is
/// clean with it.
#[test]
fn a_scene_without_a_light_is_a_finding() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    common::copy_dir(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src"),
        &scene,
    );
    let toml = std::fs::read_to_string(scene.join("scene.toml")).unwrap();
    let start = toml.find("\n[light]\n").unwrap();
    let end = start + 1 + toml[start + 1..].find("\n\n").unwrap();
    std::fs::write(
        scene.join("dark.toml"),
        format!("{}{}", &toml[..start], &toml[end..]),
    )
    .unwrap();
    let codes = |name: &str| {
        let o = validate(&scene.join(name));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        v["findings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|f| f["code"].as_str().unwrap().to_string())
            .collect::<Vec<_>>()
    };
    assert!(codes("dark.toml").contains(&"no-light".to_string()));
    assert!(!codes("scene.toml").contains(&"no-light".to_string()));
}

/// The whole finding line for exit 1, as `validate` prints it without `--json`.
#[test]
fn text_output_numbers_the_finding_with_its_code() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("s.pack");
    let (mut toc, mut data) = sample();
    let (t, levels) = sample_texture("orphan", TextureRole::Colour, 2, 2);
    toc.textures.push(t);
    data.textures.push(levels);
    pack::write_pack(&path, toc, &data).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("validate")
        .arg(&path)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(
        out.lines().next(),
        Some("  1. [unused-texture] texture \"orphan\" (colour, 2x2) is referenced by nothing"),
        "{out}"
    );
}

/// A model of a format the cooker does not read is said to be one, not "bad magic"; a pack
/// under another name is still validated as a pack.
#[test]
fn a_model_of_another_format_is_named_as_such() {
    let dir = tempfile::tempdir().unwrap();
    let stl = dir.path().join("model.stl");
    std::fs::write(&stl, b"solid model\nendsolid model\n").unwrap();
    let o = validate(&stl);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("model.stl: not a stained-glass pack, and .stl is no format the cooker reads"),
        "{err}"
    );
    assert!(!err.contains("bad magic"), "{err}");
    let (toc, data) = sample();
    let renamed = dir.path().join("scene.bin");
    pack::write_pack(&renamed, toc, &data).unwrap();
    assert_eq!(validate(&renamed).status.code(), Some(0));
}
