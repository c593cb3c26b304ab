//! Work a scene does not need is skipped, and said so: materials without triangles and their
//! textures, source materials nothing uses, projectors for windows whose light lands nowhere,
//! and vertex attributes no material of a mesh reads.

mod common;

use std::path::Path;
use std::process::Output;

fn cooker(args: &[&str], dir: &Path) -> Output {
    common::command()
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

fn design(path: &Path) {
    let img = image::RgbaImage::from_fn(16, 32, |x, y| {
        image::Rgba([(x * 15) as u8, (y * 7) as u8, 200, 255])
    });
    img.save(path).unwrap();
}

/// Material "empty" has only degenerate faces, so nothing of it survives mesh processing;
/// "orphan" is defined in the MTL and never used. A floor (y = 0, z in [0, 10]); window "lit" above it in the plane z = 0, and window "dark"
/// far to the side (x in [100, 101]) where the sun's shaft meets no floor. The sun travels
/// along +z and down, so light through "lit" lands on the floor at z in [2, 4].
const OBJ: &str = "\
mtllib scene.mtl
v -5 0 0
v 5 0 0
v 5 0 10
v -5 0 10
v 0 2 0
v 1 2 0
v 1 4 0
v 0 4 0
v 100 2 0
v 101 2 0
v 101 4 0
v 100 4 0
vt 0 1
vt 1 1
vt 1 0
vt 0 0
g floor
usemtl stone
f 1 4 3
f 1 3 2
g windows
usemtl lit
f 5/1 6/2 7/3
f 5/1 7/3 8/4
usemtl dark
f 9/1 10/2 11/3
f 9/1 11/3 12/4
g nothing
usemtl empty
f 1 1 2
f 3 3 3
";

const MTL: &str = "\
newmtl stone
Kd 0.5 0.5 0.5
newmtl lit
Kd 1 1 1
newmtl dark
Kd 1 1 1
newmtl empty
Kd 1 0 0
map_Kd empty.png
newmtl orphan
Kd 0 1 0
map_Kd orphan.png
norm orphan-missing.png
";

const SCENE: &str = r#"
[[mesh]]
source = "scene.obj"

[[rule]]
match = "stone"
class = "floor"

[[rule]]
match = "{lit,dark}"
on = ["material"]
class = "window-upper"

[[rule]]
match = "empty"
class = "wall"

[[window]]
material = "lit"
design = "lit.png"

[[window]]
material = "dark"
design = "dark.png"

[light]
type = "directional"
direction = [0.0, -1.0, 1.0]
angular_size_deg = 0.53
colour = [1.0, 1.0, 1.0]
intensity = 1.0
"#;

#[test]
fn unneeded_materials_textures_and_projectors_are_skipped_and_reported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("scene.obj"), OBJ).unwrap();
    std::fs::write(d.join("scene.mtl"), MTL).unwrap();
    std::fs::write(d.join("scene.toml"), SCENE).unwrap();
    design(&d.join("lit.png"));
    design(&d.join("dark.png"));
    // Not an image: had it been decoded, the cook would fail.
    std::fs::write(d.join("orphan.png"), b"not a png").unwrap();
    std::fs::write(d.join("empty.png"), b"not a png").unwrap();

    let o = cooker(&["cook", "scene.toml", "-o", "out.pack", "--no-cache"], d);
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    // A missing texture of a material nothing draws is not worth a warning.
    assert!(!out.contains("orphan-missing.png"), "{out}");
    assert!(
        out.contains(
            "skipped: material \"empty\" (wall): no triangles, not cooked, nor its textures ("
        ) && out.contains("empty.png"),
        "{out}"
    );
    assert!(
        out.contains("skipped: material \"orphan\" of ")
            && out.contains("defined but no triangle uses it, not cooked, nor its textures (")
            && out.contains("orphan.png"),
        "{out}"
    );
    assert!(
        out.contains("skipped: window \"dark\": its light reaches no floor, wall or other receiving surface, so no projector texture was cooked"),
        "{out}"
    );

    let info = cooker(&["info", "--json", "out.pack"], d);
    assert!(info.status.success(), "{}", text(&info));
    let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
    let materials = v["materials"].as_array().unwrap();
    let names: Vec<&str> = materials
        .iter()
        .map(|m| m["name"].as_str().unwrap())
        .collect();
    assert_eq!(names, ["stone", "lit", "dark"], "{v:#}");
    let projector = |name: &str| {
        materials
            .iter()
            .find(|m| m["name"] == name)
            .unwrap()
            .get("projector_texture")
            .cloned()
            .unwrap_or(serde_json::Value::Null)
    };
    assert!(projector("lit").is_string(), "{v:#}");
    assert!(projector("dark").is_null(), "{v:#}");
    let projectors = v["textures"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|t| t["role"] == "projector")
        .count();
    assert_eq!(projectors, 1, "{v:#}");

    // The pack is clean by its own validation: no unused material or texture left in it.
    let check = cooker(&["validate", "out.pack"], d);
    assert_eq!(check.status.code(), Some(0), "{}", text(&check));
    assert!(!text(&check).contains("unused"), "{}", text(&check));
}

#[test]
fn attributes_no_material_uses_are_dropped() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // Untextured, no normal map: UVs and tangents are dead weight.
    std::fs::write(
        d.join("plain.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0.5 0.5\n\
         usemtl wall\nf 1/1 2/2 3/3\nf 1/4 3/3 4/4\n",
    )
    .unwrap();
    for quantize in [false, true] {
        let mut args = vec!["cook", "plain.obj", "-o", "plain.pack", "-v", "--no-cache"];
        if quantize {
            args.push("--quantize");
        }
        let o = cooker(&args, d);
        let out = text(&o);
        assert!(o.status.success(), "{out}");
        assert!(
            out.contains("attributes dropped (no material uses them): uv, tangent"),
            "{out}"
        );
        let info = cooker(&["info", "--json", "plain.pack"], d);
        let v: serde_json::Value = serde_json::from_slice(&info.stdout).unwrap();
        let mesh = &v["meshes"][0];
        // Float: position 12 + normal 12 + material 4. Quantized: 8 + 4 + 4.
        assert_eq!(mesh["stride"], if quantize { 16 } else { 28 }, "{v:#}");
        // Corners that differed only in their unused UV merge: the quad has 4 vertices, not 5.
        assert_eq!(mesh["vertices"], 4, "{v:#}");
    }
}

/// A shared MTL library of forty materials, one of them used: the thirty-nine others are one
/// line naming the first three, with the textures not cooked for them; a line each buried the
/// rest of the output. Three or fewer keep a line each (the test above).
#[test]
fn a_library_of_unused_materials_is_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("scene.obj"),
        "mtllib library.mtl\nv 0 0 0\nv 1 0 0\nv 1 0 1\nusemtl m0\nf 1 3 2\n",
    )
    .unwrap();
    let mut mtl = String::new();
    for i in 0..40 {
        mtl += &format!("newmtl m{i}\nKd 0.5 0.5 0.5\nmap_Kd t{i}.png\n\n");
    }
    std::fs::write(d.join("library.mtl"), mtl).unwrap();
    design(&d.join("t0.png"));
    // Not images: had they been decoded, the cook would fail.
    for i in 1..40 {
        std::fs::write(d.join(format!("t{i}.png")), b"not a png").unwrap();
    }

    let o = cooker(&["cook", "scene.obj", "-o", "out.pack", "--no-cache"], d);
    let out = text(&o);
    assert!(o.status.success(), "{out}");
    assert!(
        out.contains("skipped: 39 materials of ")
            && out.contains(
                "(\"m1\", \"m2\", \"m3\" and 36 more): defined but no triangle uses them, not \
                 cooked, nor their 39 textures (\"t1.png\", \"t2.png\", \"t3.png\" and 36 more)"
            ),
        "{out}"
    );
    assert!(!out.contains("material \"m5\""), "{out}");
}
