//! Cooking real third-party meshes end to end: OBJ/glTF → cook → pack bytes → reader, and the
//! bad-input catalogue. Data: tests/data/third_party (see SOURCES.md there).

use std::path::{Path, PathBuf};

use cook::{CookError, Manifest, Settings};
use pack::{MaterialClass, Pack};

fn data(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/third_party")
        .join(rel)
}

fn cook_to_pack(manifest: &Manifest) -> (cook::CookOutput, Pack) {
    let out = cook::cook(manifest, &Settings::new(manifest)).expect("cooks");
    let bytes = pack::encode(out.toc.clone(), &out.data).expect("encodes");
    let pack = Pack::from_bytes("memory.pack", &bytes).expect("reads back");
    (out, pack)
}

fn cook_file(rel: &str) -> (cook::CookOutput, Pack) {
    cook_to_pack(&Manifest::open(&data(rel)).unwrap())
}

/// Spot with a colour texture, so that its UVs are needed and kept in the pack (a bare cook
/// of an untextured mesh drops them).
fn textured_spot(dir: &Path) -> Manifest {
    // Spot's faces carry no name a rule could match; give them one.
    let mut obj = b"usemtl spot\n".to_vec();
    obj.extend(std::fs::read(data("classic/spot.obj")).unwrap());
    std::fs::write(dir.join("spot.obj"), obj).unwrap();
    let scene = dir.join("spot.toml");
    let texture = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets-src/textures/wall.png");
    std::fs::write(
        &scene,
        format!(
            "[[mesh]]\nsource = \"spot.obj\"\n\n[[rule]]\nmatch = \"spot\"\nclass = \"other\"\ntexture = {:?}\n",
            texture
        ),
    )
    .unwrap();
    Manifest::open(&scene).unwrap()
}

fn triangles(pack: &Pack) -> u64 {
    pack.toc()
        .meshes
        .iter()
        .map(|m| m.index_count as u64 / 3)
        .sum()
}

/// Every triangle's three vertices carry its draw range's material; windows come last.
fn check_material_ids(pack: &Pack) {
    let toc = pack.toc();
    for m in &toc.meshes {
        let stride = m.layout.stride as usize;
        let bytes = pack.vertex_bytes(m);
        let indices = pack.indices(m);
        let mut seen_window = false;
        for r in &m.ranges {
            let w = toc.materials[r.material as usize].class.is_window();
            assert!(
                !seen_window || w,
                "opaque range after a window range in {:?}",
                m.name
            );
            seen_window |= w;
            for &i in &indices[r.first_index as usize..(r.first_index + r.index_count) as usize] {
                let v = &bytes[i as usize * stride..][..stride];
                assert_eq!(m.layout.material_id(v), Some(r.material));
            }
        }
    }
}

fn class_triangles(pack: &Pack) -> Vec<(String, MaterialClass, u64)> {
    let toc = pack.toc();
    toc.materials
        .iter()
        .zip(toc.triangles_per_material())
        .map(|(m, t)| (m.name.clone(), m.class, t))
        .collect()
}

fn scene(dir: &Path, body: &str) -> Manifest {
    let path = dir.join("scene.toml");
    std::fs::write(&path, body).unwrap();
    Manifest::load(&path).unwrap()
}

#[test]
fn cornell_box_with_rules() {
    let dir = tempfile::tempdir().unwrap();
    let obj = data("cornell_box/cornell_box.obj");
    let m = scene(
        dir.path(),
        &format!(
            r#"
[scene]
name = "cornell"

[[mesh]]
source = {obj:?}

[[rule]]
match = "floor"
on = ["object"]
class = "floor"
material = "floor"

[[rule]]
match = "{{*_wall,ceiling}}"
on = ["object"]
class = "wall"

[[rule]]
match = "light"
class = "window-upper"
material = "skylight"

[[rule]]
match = "*_block"
on = ["object"]
class = "other"
material = "blocks"
diffuse = [0.5, 0.5, 0.5]

[light]
type = "directional"
direction = [0.0, -1.0, 0.0]

[[camera]]
name = "front"
position = [278.0, 273.0, -800.0]
target = [278.0, 273.0, 0.0]

[background]
colour = [0.1, 0.2, 0.3]
"#
        ),
    );
    let (out, pack) = cook_to_pack(&m);
    assert_eq!(triangles(&pack), 36);
    check_material_ids(&pack);
    let mut classes = class_triangles(&pack);
    classes.sort_by(|a, b| a.0.cmp(&b.0));
    assert_eq!(
        classes,
        vec![
            ("blocks".to_string(), MaterialClass::Other, 20),
            ("floor".to_string(), MaterialClass::Floor, 6),
            ("green".to_string(), MaterialClass::Wall, 2),
            ("red".to_string(), MaterialClass::Wall, 2),
            ("skylight".to_string(), MaterialClass::WindowUpper, 2),
            ("white".to_string(), MaterialClass::Wall, 4),
        ]
    );
    let toc = pack.toc();
    let red = toc.materials.iter().find(|m| m.name == "red").unwrap();
    assert_eq!(red.diffuse, [1.0, 0.0, 0.0], "shading comes from the MTL");
    let blocks = toc.materials.iter().find(|m| m.name == "blocks").unwrap();
    assert_eq!(blocks.diffuse, [0.5, 0.5, 0.5], "rules override shading");
    assert!(
        out.report.heuristics.is_empty(),
        "every part matched a rule"
    );
    // The light quad at y = 548.8 is the window: its frame lies in that plane, normal along the light.
    assert_eq!(toc.windows.len(), 1);
    let w = &toc.windows[0];
    assert_eq!(toc.materials[w.material as usize].name, "skylight");
    assert!((w.origin[1] - 548.0).abs() < 1.0, "{w:?}");
    assert!((w.normal[1] + 1.0).abs() < 1e-4, "{w:?}");
    assert_eq!(toc.cameras.len(), 1);
    assert_eq!(toc.background.colour, [0.1, 0.2, 0.3]);
    assert!(matches!(
        toc.light.as_ref().unwrap().kind,
        pack::LightKind::Directional { .. }
    ));

    // The light quad has neither UVs nor a design: it gets planar UVs and a design from its
    // own colour, so only MTL "blue", used by no face, is a finding.
    let v = cook::validate::validate_scene(&m, cook::UpAxis::Y).unwrap();
    let mut codes: Vec<&str> = v.findings.iter().map(|f| f.code).collect();
    codes.sort();
    assert_eq!(codes, vec!["unused-material"], "{:#?}", v.findings);
    assert!(v.findings.iter().any(|f| f.message.contains("\"blue\"")));
    let floor = v.materials.iter().find(|r| r.name == "floor").unwrap();
    assert_eq!(floor.triangles, 6);
    assert!(floor.area > 0.0);
    assert_eq!(
        (floor.bounds_min[1], floor.bounds_max[1]),
        (0.0, 0.0),
        "the floor lies in y = 0"
    );
}

#[test]
fn bare_cornell_box_uses_heuristics_and_says_so() {
    let (out, pack) = cook_file("cornell_box/cornell_box.obj");
    assert_eq!(triangles(&pack), 36);
    check_material_ids(&pack);
    assert!(out.report.warnings.iter().any(|w| {
        w.message
            .contains("cooking a bare mesh without a scene.toml")
    }));
    let floor: u64 = class_triangles(&pack)
        .iter()
        .filter(|c| c.1 == MaterialClass::Floor)
        .map(|c| c.2)
        .sum();
    let wall: u64 = class_triangles(&pack)
        .iter()
        .filter(|c| c.1 == MaterialClass::Wall)
        .map(|c| c.2)
        .sum();
    // Three walls by name; the tall block (60 % of the room's height, mostly vertical) is a
    // wall by geometry too.
    assert_eq!((floor, wall), (6, 6 + 10));
    assert!(
        out.report
            .heuristics
            .iter()
            .any(|h| h.keyword == Some("floor") && h.triangles == 6)
    );
    let v = cook::validate::validate_scene(
        &Manifest::open(&data("cornell_box/cornell_box.obj")).unwrap(),
        cook::UpAxis::Y,
    )
    .unwrap();
    let untagged = v
        .findings
        .iter()
        .find(|f| f.code == "untagged")
        .expect("untagged finding");
    assert!(
        untagged.message.starts_with("36 triangles"),
        "{}",
        untagged.message
    );
    // The cooked pack itself is consistent.
    assert!(cook::validate::validate_pack(&pack).is_clean());
}

#[test]
fn stanford_bunny() {
    let (out, pack) = cook_file("classic/stanford-bunny.obj");
    assert_eq!(triangles(&pack), 69451);
    check_material_ids(&pack);
    let m = &pack.toc().meshes[0];
    // 35947 positions in the file, some unreferenced: dedupe must not add any.
    assert!(
        m.vertex_count <= 35947 && m.vertex_count > 35000,
        "{}",
        m.vertex_count
    );
    let s = &out.report.meshes[0].stats;
    assert!(s.acmr_out <= 0.70, "acmr_out {}", s.acmr_out);
    assert!(s.acmr_out < s.acmr_in);
    assert_eq!(s.normals_generated, 69451 * 3);
    // A sculpture in one material is not cut into a floor and walls: its base and steep
    // flanks pass the size and slope tests, but the flanks lie in no large planes.
    let classes: Vec<_> = pack.toc().materials.iter().map(|m| m.class).collect();
    assert_eq!(classes, [MaterialClass::Other]);
}

#[test]
fn spot_keeps_its_uvs() {
    let dir = tempfile::tempdir().unwrap();
    let (out, pack) = cook_to_pack(&textured_spot(dir.path()));
    assert_eq!(triangles(&pack), 5856);
    check_material_ids(&pack);
    let m = &pack.toc().meshes[0];
    // No normal map: position, normal, UV and material, without the tangent.
    for s in [pack::Semantic::TexCoord, pack::Semantic::Normal] {
        assert!(m.layout.attribute(s).is_some(), "{s:?} kept");
    }
    assert!(m.layout.attribute(pack::Semantic::Tangent).is_none());
    let verts: Vec<([f32; 2], [f32; 3])> = pack
        .vertex_bytes(m)
        .chunks_exact(m.layout.stride as usize)
        .map(|v| {
            let d = m.layout.decode(v);
            (d.uv, d.normal)
        })
        .collect();
    // Spot's UVs slightly exceed [0, 1] in the file (v up to 1.00065); they are kept as they are.
    assert!(
        verts
            .iter()
            .all(|(uv, _)| uv.iter().all(|c| (-0.06..=1.001).contains(c)))
    );
    assert!(verts.iter().any(|(uv, _)| *uv != [0.0, 0.0]));
    assert!(
        verts
            .iter()
            .all(|(_, n)| (glam::Vec3::from(*n).length() - 1.0).abs() < 1e-3)
    );
    assert!(out.report.meshes[0].stats.acmr_out <= 0.75);
}

#[test]
fn gltf_samples() {
    // A box of one material, alone, is a room of one material: its bottom a floor, its sides
    // walls, its top the rest (see `tag::split_mixed_parts`).
    for (file, tris, materials) in [
        ("gltf/Box/Box.gltf", 12, 3),
        ("gltf/Box/Box.glb", 12, 3),
        ("gltf/BoxTextured/BoxTextured.gltf", 12, 3),
        ("gltf/BoxTextured/BoxTextured.glb", 12, 3),
        (
            "gltf/BoxTexturedNonPowerOfTwo/BoxTexturedNonPowerOfTwo.gltf",
            12,
            3,
        ),
        (
            "gltf/TextureCoordinateTest/TextureCoordinateTest.gltf",
            10,
            5,
        ),
        (
            "gltf/TriangleWithoutIndices/TriangleWithoutIndices.gltf",
            1,
            1,
        ),
    ] {
        let (_, pack) = cook_file(file);
        assert_eq!(triangles(&pack), tris, "{file}");
        assert_eq!(pack.toc().materials.len(), materials, "{file}");
        check_material_ids(&pack);
    }
    // The same model as .gltf and .glb cooks to the same geometry.
    let (a, _) = cook_file("gltf/BoxTextured/BoxTextured.gltf");
    let (b, _) = cook_file("gltf/BoxTextured/BoxTextured.glb");
    assert_eq!(a.data.meshes[0].vertices, b.data.meshes[0].vertices);
    assert_eq!(a.data.meshes[0].indices, b.data.meshes[0].indices);
    // Box.gltf places its unit cube through a node matrix; the cooked bounds stay a unit cube.
    let (_, pack) = cook_file("gltf/Box/Box.gltf");
    let m = &pack.toc().meshes[0];
    for k in 0..3 {
        assert!(
            (m.bounds_max[k] - m.bounds_min[k] - 1.0).abs() < 1e-5,
            "{:?}..{:?}",
            m.bounds_min,
            m.bounds_max
        );
    }
}

fn source_error(rel: &str) -> (Option<usize>, String) {
    let m = Manifest::open(&data(rel)).unwrap();
    match cook::cook(&m, &Settings::new(&m)) {
        Err(e @ CookError::Source { .. }) => {
            assert!(!e.is_io());
            let CookError::Source { line, ref path, .. } = e else {
                unreachable!()
            };
            assert!(path.ends_with(Path::new(rel).file_name().unwrap()), "{e}");
            (line, e.to_string())
        }
        Err(e) => panic!("{rel}: wrong error kind: {e}"),
        Ok(_) => panic!("{rel}: cooked, expected an error"),
    }
}

#[test]
fn bad_obj_files_fail_with_file_and_line() {
    for (file, line, text) in [
        ("bad/obj/tinyobjloader/test-nan.obj", 12, "not finite"),
        (
            "bad/obj/tinyobjloader/issue-140-zero-face-idx.obj",
            16,
            "index 0",
        ),
        (
            "bad/obj/tinyobjloader/invalid-relative-vertex-index.obj",
            1,
            "index -4 is out of range",
        ),
        (
            "bad/obj/tinyobjloader/catmark_torus_creases0.obj",
            62,
            "normal index 1 is out of range",
        ),
        (
            "bad/obj/tobj/invalid_index.obj",
            12,
            "vertex index 7 is out of range",
        ),
    ] {
        let (l, msg) = source_error(file);
        assert_eq!(l, Some(line), "{msg}");
        assert!(msg.contains(text), "{msg}");
    }
}

#[test]
fn bad_gltf_files_fail_cleanly() {
    for (file, says) in [
        (
            "bad/gltf/tinygltf/invalid-buffer-index.gltf",
            "invalid glTF: bufferViews[1].buffer: Index out of bounds",
        ),
        (
            "bad/gltf/tinygltf/invalid-buffer-view-index.gltf",
            "invalid glTF: accessors[0].bufferView: Index out of bounds",
        ),
        (
            "bad/gltf/tinygltf/invalid-primitive-indices.gltf",
            "mesh 0 primitive 0 uses accessor 1, but there are 1",
        ),
        (
            "bad/gltf/tinygltf/integer-out-of-bounds.gltf",
            "invalid glTF JSON: invalid type: floating point `1e+300`, expected u64",
        ),
        (
            "bad/gltf/gltf-rs/non_sparse_accessor_without_buffer_view.gltf",
            "invalid glTF: accessors[0].bufferView: Missing data",
        ),
        (
            "bad/gltf/gltf-rs/minimal_accessor_invalid.gltf",
            "attributes[\"POSITION\"].max: Invalid value",
        ),
    ] {
        let (_, msg) = source_error(file);
        assert!(msg.contains(".gltf") && msg.contains(says), "{msg}");
        // gltf's validation message starts with the same words the importer would add.
        assert!(msg.matches("invalid glTF").count() <= 1, "{msg}");
    }
    // JSON errors carry the line.
    let (line, _) = source_error("bad/gltf/tinygltf/integer-out-of-bounds.gltf");
    assert_eq!(line, Some(34));
}

#[test]
fn oddities_cook_with_warnings() {
    // Unknown materials (the file's mtllib is commented out): names still tag, shading falls back.
    let (out, pack) = cook_file("bad/obj/tinyobjloader/missing_material_file.obj");
    assert_eq!(triangles(&pack), 36);
    assert!(
        out.report
            .warnings
            .iter()
            .any(|w| w.message.contains("not defined in any mtllib")),
        "{:?}",
        out.report.warnings
    );
    // Lines and points next to faces: skipped with a warning naming the first line.
    let dir = tempfile::tempdir().unwrap();
    let obj = dir.path().join("mixed.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\np 3\nf 1 2 3\n").unwrap();
    let (out, pack) = cook_to_pack(&Manifest::open(&obj).unwrap());
    assert_eq!(triangles(&pack), 1);
    let w = out
        .report
        .warnings
        .iter()
        .find(|w| w.message.contains("ignored"))
        .expect("warning");
    assert_eq!(w.line, Some(4), "{w}");
    assert!(
        w.message.starts_with("1 line and 1 point elements ignored"),
        "{w}"
    );
    // Faces with fewer than three corners are skipped with a warning.
    let src =
        cook::import::import(&data("bad/obj/tinyobjloader/invalid-face-definition.obj")).unwrap();
    assert_eq!(src.triangle_count(), 0);
    assert!(
        src.warnings
            .iter()
            .any(|w| w.message.contains("fewer than 3")),
        "{:?}",
        src.warnings
    );
    for f in [
        "bad/obj/tinyobjloader/line-prim.obj",
        "bad/obj/tinyobjloader/points-prim.obj",
        "bad/obj/tobj/lines.obj",
    ] {
        let src = cook::import::import(&data(f)).unwrap();
        assert_eq!(src.triangle_count(), 0, "{f}");
        assert!(
            src.warnings.iter().any(|w| w.message.contains("ignored")),
            "{f}: {:?}",
            src.warnings
        );
    }
    // Sparse accessors are applied.
    let (_, pack) = cook_file("bad/gltf/gltf-rs/box_sparse.gltf");
    assert_eq!(triangles(&pack), 12);
    // A GLB with a zero-sized BIN chunk.
    let (_, pack) = cook_file("bad/gltf/tinygltf/zero-sized-bin-chunk-issue-440.glb");
    assert_eq!(triangles(&pack), 1);
}

#[test]
fn ngons_are_triangulated_without_losing_area() {
    // issue-295: quads and n-gons; ear clipping must cover each polygon exactly once.
    let m = Manifest::open(&data(
        "bad/obj/tinyobjloader/issue-295-trianguation-failure.obj",
    ))
    .unwrap();
    let src = cook::import::import(&m.meshes[0].source).unwrap();
    assert!(src.polygons > 0);
    let (_, pack) = cook_to_pack(&m);
    let v = cook::validate::validate_pack(&pack);
    assert!(
        v.findings.iter().all(|f| f.code != "degenerate-triangles"),
        "{:?}",
        v.findings
    );
    let area: f64 = v.materials.iter().map(|r| r.area).sum();
    // Every polygon of the file lies on an axis-aligned unit grid: 6 faces of a 1x1x3 box.
    assert!((area - 14.0).abs() < 1e-3, "area {area}");
}

#[test]
fn cooking_is_deterministic() {
    let m = Manifest::open(&data("classic/spot.obj")).unwrap();
    let a = cook::cook(&m, &Settings::new(&m)).unwrap();
    let b = cook::cook(&m, &Settings::new(&m)).unwrap();
    assert_eq!(
        pack::encode(a.toc, &a.data).unwrap(),
        pack::encode(b.toc, &b.data).unwrap()
    );
}

#[test]
fn fifo_and_quantized_cooks_are_valid() {
    let dir = tempfile::tempdir().unwrap();
    let m = textured_spot(dir.path());
    let mut s = Settings {
        quantize: true,
        ..Settings::new(&m)
    };
    s.mesh.cache = cook::CacheMode::Fifo;
    let out = cook::cook(&m, &s).unwrap();
    let bytes = pack::encode(out.toc.clone(), &out.data).unwrap();
    let pack = Pack::from_bytes("q.pack", &bytes).unwrap();
    check_material_ids(&pack);
    let q = out.report.meshes[0].quantization.unwrap();
    let m0 = &pack.toc().meshes[0];
    let extent = (0..3)
        .map(|k| m0.bounds_max[k] - m0.bounds_min[k])
        .fold(0.0f32, f32::max);
    // Half a step is the rounding bound; f32 decoding adds a few ulps of the coordinates.
    let magnitude = (0..3).fold(0.0f32, |a, k| {
        a.max(m0.bounds_min[k].abs()).max(m0.bounds_max[k].abs())
    });
    let bound = extent / 65535.0 * 0.5 + 4.0 * f32::EPSILON * magnitude;
    assert!(
        q.position > 0.0 && q.position <= bound,
        "position error {} for extent {extent} (bound {bound})",
        q.position
    );
    // Spot's UVs stay floats (below), so they have no quantization error to bound here;
    // `quantized_uvs_stay_within_half_a_step` checks the quantized case.
    assert!(q.normal_deg < 0.01 && q.uv == 0.0, "{q:?}");
    // Spot's UVs leave [0, 1], so they stay 32-bit floats: position 8, normal 4, UV 8,
    // material 4; no normal map, so no tangent.
    assert_eq!(m0.layout.stride, 24);
    assert_eq!(
        m0.layout
            .attribute(pack::Semantic::TexCoord)
            .unwrap()
            .format,
        pack::AttributeFormat::Float32x2
    );
    assert!(out.report.meshes[0].stats.acmr_out < 0.8);
}

/// `room.obj` in `dir`: a 4 x 4 floor at y = 0 (material `stone`) and a 1 x 2 lancet in the
/// plane z = 0 (`glass_1`), u to the right; the OBJ's v = 0 is at y = 3, which OBJ's
/// convention (v up) makes the bottom of the image.
fn lancet_room(dir: &Path) {
    std::fs::write(
        dir.join("room.obj"),
        "v 0 0 0\nv 4 0 0\nv 4 0 4\nv 0 0 4\nv 1 3 0\nv 2 3 0\nv 2 1 0\nv 1 1 0\n\
         vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         o floor\nusemtl stone\nf 1 4 3 2\no lancet\nusemtl glass_1\nf 5/1 8/4 7/3 6/2\n",
    )
    .unwrap();
}

/// A normal map derived from a design over 1024 texels a side is made from the design's
/// first level within 1024: its invented relief gains nothing from more texels (a 4096²
/// design's derived map was 8.1 MB of an 8.3 MB pack), while the design keeps its own size.
#[test]
fn a_large_design_s_derived_normal_map_is_made_at_1024() {
    let dir = tempfile::tempdir().unwrap();
    lancet_room(dir.path());
    image::RgbaImage::from_fn(2048, 64, |x, y| {
        let lead = x % 128 < 4 || y % 32 < 2;
        image::Rgba(if lead {
            [20, 20, 20, 255]
        } else {
            [200, (x / 8) as u8, 90, 255]
        })
    })
    .save(dir.path().join("design.png"))
    .unwrap();
    let m = scene(
        dir.path(),
        r#"
[[mesh]]
source = "room.obj"

[[rule]]
match = "stone"
class = "floor"

[[rule]]
match = "glass_*"
on = ["material"]
class = "window-upper"

[[window]]
material = "glass_1"
design = "design.png"
texture_format = "rgba8"
"#,
    );
    let (_, pack) = cook_to_pack(&m);
    let toc = pack.toc();
    let glass = toc.materials.iter().find(|m| m.name == "glass_1").unwrap();
    let size = |t: Option<u32>| {
        let t = &toc.textures[t.expect("texture set") as usize];
        (t.width, t.height)
    };
    assert_eq!(size(glass.diffuse_texture), (2048, 64));
    assert_eq!(size(glass.normal_texture), (1024, 32));
}

#[test]
fn window_scene_cooks_design_normal_map_and_projector() {
    let dir = tempfile::tempdir().unwrap();
    lancet_room(dir.path());
    let design = image::RgbaImage::from_fn(16, 32, |x, y| {
        image::Rgba([(x * 16) as u8, (y * 8) as u8, 200, 255])
    });
    design.save(dir.path().join("design.png")).unwrap();
    let m = scene(
        dir.path(),
        r#"
[[mesh]]
source = "room.obj"

[[rule]]
match = "stone"
class = "floor"

[[rule]]
match = "glass_*"
on = ["material"]
class = "window-upper"

[[window]]
material = "glass_1"
design = "design.png"

[light]
type = "directional"
direction = [0.0, -0.5, 1.0]
"#,
    );
    let (out, pack) = cook_to_pack(&m);
    check_material_ids(&pack);
    let toc = pack.toc();
    assert_eq!(triangles(&pack), 4);
    let glass = toc.materials.iter().find(|m| m.name == "glass_1").unwrap();
    let role = |t: Option<u32>| toc.textures[t.expect("texture set") as usize].role;
    assert_eq!(role(glass.diffuse_texture), pack::TextureRole::Colour);
    assert_eq!(role(glass.normal_texture), pack::TextureRole::Normal);
    assert_eq!(role(glass.projector_texture), pack::TextureRole::Projector);
    let colour = &toc.textures[glass.diffuse_texture.unwrap() as usize];
    assert_eq!(
        (colour.width, colour.height, colour.mips.len()),
        (16, 32, 6)
    );
    assert_eq!(colour.colour_space, pack::ColourSpace::Srgb);
    assert_eq!(
        toc.textures[glass.normal_texture.unwrap() as usize].colour_space,
        pack::ColourSpace::Linear
    );
    // Level 0 of the design, block-compressed by default, decodes to within the default
    // colour budget of its bytes.
    let level0 = pack::texels::decode_level(
        colour,
        0,
        pack.mip_bytes(glass.diffuse_texture.unwrap() as usize, 0),
    );
    let sq: f64 = level0
        .iter()
        .zip(design.as_raw())
        .map(|(&a, &b)| (a as f64 - b as f64).powi(2))
        .sum();
    let rms = (sq / level0.len() as f64).sqrt();
    assert!(
        rms <= cook::budget::DEFAULT_COLOUR_ERROR_LSB as f64,
        "{:?}: level 0 is {rms} LSB RMS off",
        colour.format
    );
    // The frame reproduces the UV mapping (the image's top row, v = 0 in the pack, at the
    // OBJ's v = 1: y = 1); the normal points along the light, into the room.
    let w = &toc.windows[0];
    let close = |a: [f32; 3], b: [f32; 3]| a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-4);
    assert!(
        close(w.origin, [1.0, 1.0, 0.0]) && close(w.u_axis, [1.0, 0.0, 0.0]),
        "{w:?}"
    );
    assert!(
        close(w.v_axis, [0.0, 2.0, 0.0]) && close(w.normal, [0.0, 0.0, 1.0]),
        "{w:?}"
    );
    // Windows are drawn last.
    let ranges = &toc.meshes[0].ranges;
    assert_eq!(
        toc.materials[ranges.last().unwrap().material as usize].name,
        "glass_1"
    );
    assert!(out.report.heuristics.is_empty());
    let v = cook::validate::validate_scene(&m, cook::UpAxis::Y).unwrap();
    assert!(v.is_clean(), "{:#?}", v.findings);
    assert!(cook::validate::validate_pack(&pack).is_clean());
}

#[test]
fn window_problems_are_found() {
    let dir = tempfile::tempdir().unwrap();
    // A bent window (one corner 0.5 out of plane) with UVs up to 2, and no [[window]] design.
    std::fs::write(
        dir.path().join("w.obj"),
        "v 0 0 0\nv 1 0 0\nv 1 1 0.5\nv 0 1 0\nvt 0 0\nvt 2 0\nvt 2 1\nvt 0 1\n\
         usemtl window_lower_a\nf 1/1 2/2 3/3 4/4\nf 1/1 2/2 3/3\nf 3/3 1/1 2/2\n",
    )
    .unwrap();
    let m = Manifest::open(&dir.path().join("w.obj")).unwrap();
    let v = cook::validate::validate_scene(&m, cook::UpAxis::Y).unwrap();
    let codes: Vec<&str> = v.findings.iter().map(|f| f.code).collect();
    // Bent by half its size, the window is split along its planes (each a window of its own,
    // with a design from its colour, so no window-no-design). Its UVs beyond 1 are no
    // finding: the cook places such glass's design by planar coordinates, as validate sees it.
    assert!(!codes.contains(&"window-uv-range"), "{:#?}", v.findings);
    for code in ["untagged", "duplicate-triangles"] {
        assert!(
            codes.contains(&code),
            "{code} missing from {:#?}",
            v.findings
        );
    }
    assert!(!codes.contains(&"window-not-planar"), "{:#?}", v.findings);
    let windows: Vec<_> = v.materials.iter().filter(|m| m.class.is_window()).collect();
    assert!(windows.len() >= 2, "{:#?}", v.materials);
    assert!(
        windows
            .iter()
            .all(|m| m.class == MaterialClass::WindowLower)
    );
}

#[test]
fn position_bits_bound_the_error_and_the_size() {
    let m = Manifest::open(&data("classic/stanford-bunny.obj")).unwrap();
    let mut strides = Vec::new();
    for (bits, levels) in [
        (cook::mesh::PositionBits::B16, 65535.0f32),
        (cook::mesh::PositionBits::B10, 1023.0),
        (cook::mesh::PositionBits::B8, 255.0),
    ] {
        let s = Settings {
            quantize: true,
            position_bits: bits,
            ..Settings::new(&m)
        };
        let out = cook::cook(&m, &s).unwrap();
        let bytes = pack::encode(out.toc.clone(), &out.data).unwrap();
        let pack = Pack::from_bytes("q.pack", &bytes).unwrap();
        let m0 = &pack.toc().meshes[0];
        let extent: [f32; 3] = std::array::from_fn(|k| m0.bounds_max[k] - m0.bounds_min[k]);
        let q = out.report.meshes[0].quantization.unwrap();
        // Half a quantization step, plus the f32 rounding of decoding near the coordinates.
        let magnitude = (0..3).fold(0.0f32, |a, k| {
            a.max(m0.bounds_min[k].abs()).max(m0.bounds_max[k].abs())
        });
        let bound = extent.iter().fold(0.0f32, |a, &e| a.max(e)) / levels * 0.5
            + 4.0 * f32::EPSILON * magnitude;
        assert!(q.position <= bound, "{bits:?}: {} > {bound}", q.position);
        // The reported error is what a reader decoding the pack sees.
        let (src, _) = cook_file("classic/stanford-bunny.obj");
        let exact = &src.toc.meshes[0];
        let exact_pos = |i: usize| {
            let stride = exact.layout.stride as usize;
            exact
                .layout
                .position(&src.data.meshes[0].vertices[i * stride..(i + 1) * stride])
                .unwrap()
        };
        let stride = m0.layout.stride as usize;
        let mut worst = 0.0f32;
        for (i, v) in pack.vertex_bytes(m0).chunks_exact(stride).enumerate() {
            let p = m0.layout.position(v).unwrap();
            let e = exact_pos(i);
            for k in 0..3 {
                worst = worst.max((p[k] - e[k]).abs());
            }
        }
        assert!(
            worst <= q.position * 1.001 + 1e-7,
            "{bits:?}: decoded {worst} vs reported {}",
            q.position
        );
        strides.push(m0.layout.stride);
    }
    // The bunny has no texture: position + normal + material; 16-bit positions take 8 bytes,
    // 10- and 8-bit ones 4.
    assert_eq!(strides, [16, 12, 12]);
}

/// UVs inside [0, 1] are stored as unorm16 when quantizing: the reported error is positive,
/// within half a step, and is what a reader decoding the bytes by hand sees.
#[test]
fn quantized_uvs_stay_within_half_a_step() {
    let dir = tempfile::tempdir().unwrap();
    // A 9x9 grid whose UVs (multiples of 1/7 and 1/9) fall between unorm16 steps.
    let mut obj = String::from("usemtl tile\n");
    for j in 0..9 {
        for i in 0..9 {
            obj += &format!(
                "v {i} {} {j}\nvt {} {}\n",
                (i * j) % 3,
                i as f32 / 7.0 % 1.0,
                j as f32 / 9.0
            );
        }
    }
    for j in 0..8 {
        for i in 0..8 {
            let k = j * 9 + i + 1;
            obj += &format!("f {k}/{k} {}/{} {}/{}\n", k + 1, k + 1, k + 10, k + 10);
            obj += &format!("f {k}/{k} {}/{} {}/{}\n", k + 10, k + 10, k + 9, k + 9);
        }
    }
    std::fs::write(dir.path().join("grid.obj"), obj).unwrap();
    let texture = Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets-src/textures/wall.png");
    let scene = dir.path().join("grid.toml");
    std::fs::write(
        &scene,
        format!(
            "[[mesh]]\nsource = \"grid.obj\"\n\n[[rule]]\nmatch = \"tile\"\nclass = \"floor\"\ntexture = {texture:?}\n"
        ),
    )
    .unwrap();
    let m = Manifest::load(&scene).unwrap();
    let uvs = |quantize: bool| {
        let s = Settings {
            quantize,
            ..Settings::new(&m)
        };
        let out = cook::cook(&m, &s).unwrap();
        let q = out.report.meshes[0].quantization;
        let mesh = &out.toc.meshes[0];
        let a = mesh.layout.attribute(pack::Semantic::TexCoord).unwrap();
        let stride = mesh.layout.stride as usize;
        let uv: Vec<[f32; 2]> = out.data.meshes[0]
            .vertices
            .chunks_exact(stride)
            .map(|v| {
                let at = |k: usize| &v[a.offset as usize + k..];
                match a.format {
                    pack::AttributeFormat::Float32x2 => std::array::from_fn(|c| {
                        f32::from_le_bytes(at(4 * c)[..4].try_into().unwrap())
                    }),
                    pack::AttributeFormat::Unorm16x2 => std::array::from_fn(|c| {
                        u16::from_le_bytes(at(2 * c)[..2].try_into().unwrap()) as f32 / 65535.0
                    }),
                    f => panic!("UV format {f:?}"),
                }
            })
            .collect();
        (a.format, q, uv)
    };
    let (float_format, _, exact) = uvs(false);
    let (format, q, quantized) = uvs(true);
    assert_eq!(float_format, pack::AttributeFormat::Float32x2);
    assert_eq!(format, pack::AttributeFormat::Unorm16x2);
    assert_eq!(exact.len(), quantized.len());
    let worst = exact
        .iter()
        .zip(&quantized)
        .flat_map(|(e, q)| [(e[0] - q[0]).abs(), (e[1] - q[1]).abs()])
        .fold(0.0f32, f32::max);
    let half_step = 0.5 / 65535.0;
    let reported = q.unwrap().uv;
    assert!(
        worst > 0.1 * half_step && worst <= half_step * 1.001,
        "decoded UV error {worst}, half a step {half_step}"
    );
    assert!(
        (reported - worst).abs() <= 1e-7,
        "reported {reported}, decoded {worst}"
    );
}

/// A size cap cooks each texture from its image's first mip level that fits: glTF-Sample-
/// Models' 211x211 Cesium logo under a cap of 60 is stored from its level 2, 52x52, with the
/// very bytes of the whole chain's level 2, and its smaller levels within a rounding step of
/// the whole chain's; the cook says so. A window's design, derived normal map and projector
/// keep to the cap too (the projector's design part: its margin lies around it).
#[test]
fn a_size_cap_cooks_each_texture_from_its_first_level_that_fits() {
    let rgba8 = |manifest: &Manifest, cap: Option<u32>| {
        let mut s = Settings::new(manifest);
        s.textures.format = Some(cook::manifest::TextureFormatChoice::Rgba8);
        s.textures.supercompression = Some(pack::Supercompression::None);
        s.textures.max_size = cap;
        cook::cook(manifest, &s).expect("cooks")
    };
    let logo = Manifest::open(&data(
        "gltf/BoxTexturedNonPowerOfTwo/BoxTexturedNonPowerOfTwo.gltf",
    ))
    .unwrap();
    let whole = rgba8(&logo, None);
    let capped = rgba8(&logo, Some(60));
    let (t, w) = (&capped.toc.textures[0], &whole.toc.textures[0]);
    assert_eq!((w.width, w.height, t.width, t.height), (211, 211, 52, 52));
    assert_eq!(t.mips.len(), w.mips.len() - 2);
    let (levels, whole_levels) = (&capped.data.textures[0], &whole.data.textures[0]);
    assert_eq!(levels[0], whole_levels[2]);
    for (k, (a, b)) in levels.iter().zip(&whole_levels[2..]).enumerate() {
        let most = a.iter().zip(b).map(|(x, y)| x.abs_diff(*y)).max();
        assert!(most <= Some(1), "level {k} differs by {most:?}");
    }
    let said: Vec<String> = capped.report.notes.iter().map(|n| n.to_string()).collect();
    assert!(
        said.iter().any(|n| n
            .contains("211x211 is over the size cap of 60: cooked from its mip level 2, 52x52")),
        "{said:?}"
    );
    // Without a cap, or with one it fits, the texture is as it was.
    assert_eq!(rgba8(&logo, Some(211)).data.textures, whole.data.textures);

    let dir = tempfile::tempdir().unwrap();
    lancet_room(dir.path());
    let design = image::RgbaImage::from_fn(64, 128, |x, y| {
        image::Rgba([(x * 4) as u8, (y * 2) as u8, 200, 255])
    });
    design.save(dir.path().join("design.png")).unwrap();
    let m = scene(
        dir.path(),
        "[textures]\nmax_size = 32\n\n[[mesh]]\nsource = \"room.obj\"\n\n[[rule]]\nmatch = \"stone\"\n\
         class = \"floor\"\n\n[[rule]]\nmatch = \"glass_*\"\nclass = \"window-upper\"\n\n\
         [[window]]\nmaterial = \"glass_1\"\ndesign = \"design.png\"\n\n\
         [light]\ntype = \"directional\"\ndirection = [0.0, -0.5, 1.0]\n",
    );
    let (out, _) = cook_to_pack(&m);
    let names: Vec<(&str, u32, u32)> = out
        .toc
        .textures
        .iter()
        .map(|t| (t.name.as_str(), t.width, t.height))
        .collect();
    // 64x128 under 32: level 2. The projector is halved along each axis only while that axis
    // is over the cap, its blur's margin (a texel or two a side here) included, since no
    // texture may pass a cap the user sets: 32 wide with its margin is over, so 17 x 16.
    let (projector_w, projector_h) = (names[2].1, names[2].2);
    assert!(
        names[..2] == [("design", 16, 32), ("design.derived-normal", 16, 32)]
            && names[2].0 == "design.projector"
            && (16..=32).contains(&projector_w)
            && (16..=32).contains(&projector_h),
        "{names:?}"
    );
}

/// A texture over 8192 texels a side cooks with a note that many GPUs load at most 8192 (the
/// viewer takes a smaller level there) and how to store it so; under a cap of 8192 it is
/// stored at 4100 and the note is gone.
#[test]
fn a_texture_over_common_gpu_limits_is_named() {
    let dir = tempfile::tempdir().unwrap();
    image::RgbaImage::from_fn(8200, 2, |x, y| {
        image::Rgba([(x % 256) as u8, (y * 90) as u8, 7, 255])
    })
    .save(dir.path().join("frieze.png"))
    .unwrap();
    std::fs::write(
        dir.path().join("m.mtl"),
        "newmtl frieze\nKd 1 1 1\nmap_Kd frieze.png\n",
    )
    .unwrap();
    std::fs::write(
        dir.path().join("frieze.obj"),
        "mtllib m.mtl\nv 0 0 0\nv 4 0 0\nv 4 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\n\
         usemtl frieze\nf 1/1 2/2 3/3 4/4\n",
    )
    .unwrap();
    let m = Manifest::open(&dir.path().join("frieze.obj")).unwrap();
    for cap in [None, Some(8192)] {
        let mut s = Settings::new(&m);
        s.textures.max_size = cap;
        let out = cook::cook(&m, &s).expect("cooks");
        let said: Vec<String> = out.report.notes.iter().map(|n| n.to_string()).collect();
        let named = said.iter().any(|n| {
            n.contains("8200x2 is over 8192 texels a side")
                && n.contains("`--max-texture-size 8192` stores it so")
        });
        assert_eq!(named, cap.is_none(), "{said:?}");
        let t = &out.toc.textures[0];
        assert_eq!(
            (t.width, t.height),
            if cap.is_none() { (8200, 2) } else { (4100, 1) }
        );
    }
}

/// One glass material in windows at two heights: each window's class comes from its sill, and
/// the tagging note says so per window, as the pack has it (it said the material's class).
#[test]
fn the_tagging_note_gives_each_window_its_own_class() {
    let dir = tempfile::tempdir().unwrap();
    let (mut obj, mtl) = cook::testing::hall_on_open_ground(20.0);
    // A high window on the east wall of the 4-high hall, after the hall's nine quads.
    obj += "usemtl glass\nv 4.99 3 -1\nv 4.99 3 1\nv 4.99 3.8 1\nv 4.99 3.8 -1\nf 37 38 39 40\n";
    std::fs::write(dir.path().join("hall.obj"), obj).unwrap();
    std::fs::write(dir.path().join("hall.mtl"), mtl).unwrap();
    let (out, pack) = cook_to_pack(&Manifest::open(&dir.path().join("hall.obj")).unwrap());
    let glass: Vec<_> = out
        .report
        .heuristics
        .iter()
        .filter(|h| h.names.contains("glass"))
        .collect();
    assert_eq!(glass.len(), 1, "{:?}", out.report.heuristics);
    let classes = class_triangles(&pack);
    let class_of = |name: &str| {
        classes
            .iter()
            .find(|c| c.0 == name)
            .unwrap_or_else(|| panic!("no material {name:?} in {classes:?}"))
            .1
    };
    let noted = &glass[0].materials;
    assert_eq!(noted.len(), 5, "{noted:?}");
    for (name, class) in noted {
        assert_eq!(*class, class_of(name), "{name}");
    }
    let count = |c: MaterialClass| noted.iter().filter(|m| m.1 == c).count();
    assert_eq!(
        (
            count(MaterialClass::WindowLower),
            count(MaterialClass::WindowUpper)
        ),
        (4, 1)
    );
    assert_eq!(glass[0].classes(), "window-lower and window-upper");
    assert!(
        glass[0]
            .tagged()
            .starts_with("window-lower and window-upper as 5 windows ("),
        "{}",
        glass[0].tagged()
    );
}

/// A square design stretched onto a lancet three times as tall as wide: the light's penumbra is
/// round on the glass, so the projector's blur, measured in scene units on the window, must be
/// as wide up the lancet as across it. σ came from the texels across alone and was applied both
/// ways, which blurred the design three times too wide up the lancet.
#[test]
fn a_stretched_design_s_projector_is_blurred_alike_both_ways_on_the_glass() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    tall_lancet_room(d);
    // A white-and-black checker of four 32-texel quadrants: an edge each way through the middle.
    image::RgbaImage::from_fn(64, 64, |x, y| {
        let v = if (x < 32) == (y < 32) { 255 } else { 0 };
        image::Rgba([v, v, v, 255])
    })
    .save(d.join("design.png"))
    .unwrap();
    let pack = cook_lancet(d, "");
    let toc = pack.toc();
    let glass = toc.materials.iter().find(|m| m.name == "glass").unwrap();
    let (texels, w, h) = projector_level0(&pack);
    let red =
        |x: usize, y: usize| texture::srgb::srgb_to_linear(texels[(y * w + x) * 4] as f64 / 255.0);
    // Where a white-to-black profile crosses `level`, by linear interpolation.
    let crossing = |profile: &[f64], level: f64| {
        let i = profile
            .windows(2)
            .position(|p| p[0] >= level && p[1] < level)
            .expect("the profile crosses");
        i as f64 + (profile[i] - level) / (profile[i] - profile[i + 1])
    };
    // The 25 %–75 % width of a blurred edge is 1.349 σ.
    let sigma = |profile: &[f64]| (crossing(profile, 0.25) - crossing(profile, 0.75)) / 1.349;
    // The texture spans the window and its margin: scene units per texel along each axis.
    let [mu, mv] = glass.projector_margin;
    let (unit_x, unit_y) = (
        1.0 * (1.0 + 2.0 * mu as f64) / w as f64,
        3.0 * (1.0 + 2.0 * mv as f64) / h as f64,
    );
    // Across the top left quadrant's right edge, a quarter of the way down the design (the
    // image's top row is v = 0), and down its lower edge, a quarter of the way across.
    let (x0, x1) = (
        (mu as f64 / (1.0 + 2.0 * mu as f64) * w as f64) as usize,
        ((1.0 + mu as f64) / (1.0 + 2.0 * mu as f64) * w as f64) as usize,
    );
    let (y0, y1) = (
        (mv as f64 / (1.0 + 2.0 * mv as f64) * h as f64) as usize,
        ((1.0 + mv as f64) / (1.0 + 2.0 * mv as f64) * h as f64) as usize,
    );
    let (qx, qy) = (x0 + (x1 - x0) / 4, y0 + (y1 - y0) / 4);
    let (mx, my) = ((x0 + x1) / 2, (y0 + y1) / 2);
    let across: Vec<f64> = (qx..x1).map(|x| red(x, qy)).collect();
    let down: Vec<f64> = (qy..y1).map(|y| red(qx, y)).collect();
    let (sx, sy) = (sigma(&across) * unit_x, sigma(&down) * unit_y);
    // 5° over the 5 m from the lancet's middle to the floor along the light: σ ≈ 0.108 m.
    let expected = 5f64.to_radians() * 3.5 * 2f64.sqrt() / 4.0;
    assert!(
        (sx / sy - 1.0).abs() < 0.2 && (sx / expected - 1.0).abs() < 0.25,
        "σ across {sx:.4} m, up {sy:.4} m, expected {expected:.4} m \
         ({w}x{h} texels, margins {mu} {mv}, edges at {mx} and {my})"
    );
}

/// Floor y = 0; a lancet x in [0, 1], y in [2, 5] in the plane z = 0, facing +z, its material
/// `glass`.
fn tall_lancet_room(d: &Path) {
    std::fs::write(
        d.join("room.obj"),
        "v -6 0 -1\nv 6 0 -1\nv 6 0 12\nv -6 0 12\nv 0 5 0\nv 1 5 0\nv 1 2 0\nv 0 2 0\n\
         vt 0 1\nvt 1 1\nvt 1 0\nvt 0 0\n\
         o floor\nusemtl stone\nf 1 4 3 2\no lancet\nusemtl glass\nf 5/1 8/4 7/3 6/2\n",
    )
    .unwrap();
}

/// [`tall_lancet_room`] with `design.png` on its lancet (`window` adds to its [[window]]),
/// textures stored RGBA8, under a 5° sun: the pack.
fn cook_lancet(d: &Path, window: &str) -> Pack {
    let m = scene(
        d,
        &format!(
            r#"
[[mesh]]
source = "room.obj"

[[rule]]
match = "stone"
class = "floor"

[[rule]]
match = "glass"
class = "window-lower"

[[window]]
material = "glass"
design = "design.png"
{window}

[textures]
format = "rgba8"

[light]
type = "directional"
direction = [0.0, -1.0, 1.0]
angular_size_deg = 5.0
"#
        ),
    );
    cook_to_pack(&m).1
}

/// The `glass` material's projector, level 0 as RGBA8, and its size.
fn projector_level0(pack: &Pack) -> (Vec<u8>, usize, usize) {
    let toc = pack.toc();
    let glass = toc.materials.iter().find(|m| m.name == "glass").unwrap();
    let index = glass.projector_texture.expect("a projector") as usize;
    let texture = &toc.textures[index];
    let texels = pack::texels::decode_level(texture, 0, pack.mip_bytes(index, 0));
    let (w, h) = (
        texture.mips[0].width as usize,
        texture.mips[0].height as usize,
    );
    (texels, w, h)
}

/// A design in linear colour (`colour_space = "linear"`) lets through the light its values
/// say: mid grey 128 is 0.502 of the light, stored in the sRGB projector as 188. It was decoded
/// as sRGB (0.216 of the light, stored as 128), so the floor was far darker than the glass.
#[test]
fn a_linear_design_s_projector_passes_its_linear_light() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    tall_lancet_room(d);
    image::RgbaImage::from_pixel(64, 64, image::Rgba([128, 128, 128, 255]))
        .save(d.join("design.png"))
        .unwrap();
    for (window, expected) in [("", 128u8), ("colour_space = \"linear\"", 188)] {
        let (texels, w, h) = projector_level0(&cook_lancet(d, window));
        let centre = &texels[((h / 2) * w + w / 2) * 4..][..4];
        assert!(
            centre[..3].iter().all(|&c| c.abs_diff(expected) <= 1) && centre[3] == 255,
            "{window:?}: centre {centre:?}, expected {expected}"
        );
    }
}

/// A 16-bit design on glass with its own texture coordinates, which lets no light outside
/// the glass, is the image as it is, under its own name like an 8-bit one: its 8-bit copy was
/// taken for a tinted design and named `.masked`, with nothing masked.
#[test]
fn a_16_bit_design_keeps_its_name() {
    let dir = tempfile::tempdir().unwrap();
    lancet_room(dir.path());
    let design = image::ImageBuffer::from_fn(16, 32, |x, y| {
        image::Rgb([(x * 4000) as u16, (y * 2000) as u16, 50000u16])
    });
    image::DynamicImage::ImageRgb16(design)
        .save(dir.path().join("design.png"))
        .unwrap();
    let m = scene(
        dir.path(),
        "[[mesh]]\nsource = \"room.obj\"\n\n[[rule]]\nmatch = \"stone\"\nclass = \"floor\"\n\n\
         [[rule]]\nmatch = \"glass_*\"\non = [\"material\"]\nclass = \"window-upper\"\n\n\
         [[window]]\nmaterial = \"glass_1\"\ndesign = \"design.png\"\n",
    );
    let (_, pack) = cook_to_pack(&m);
    let names: Vec<&str> = pack
        .toc()
        .textures
        .iter()
        .map(|t| t.name.as_str())
        .collect();
    assert!(names.contains(&"design"), "{names:?}");
    assert!(!names.iter().any(|n| n.contains("masked")), "{names:?}");
}

/// A design transparent in every texel cooks a black window that throws no light: the cook
/// says so (it was silent). One with any coverage is not said.
#[test]
fn a_transparent_design_is_said() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    tall_lancet_room(d);
    let said = |alpha: u8| {
        image::RgbaImage::from_pixel(8, 8, image::Rgba([200, 200, 200, alpha]))
            .save(d.join("design.png"))
            .unwrap();
        let m = scene(
            d,
            "[[mesh]]\nsource = \"room.obj\"\n\n[[rule]]\nmatch = \"glass\"\n\
             class = \"window-lower\"\n\n[[window]]\nmaterial = \"glass\"\n\
             design = \"design.png\"\n",
        );
        let (out, _) = cook_to_pack(&m);
        out.report
            .warnings
            .iter()
            // At the line naming the design.
            .any(|w| {
                let w = w.to_string();
                w.contains("scene.toml:10: design ") && w.contains("transparent in every texel")
            })
    };
    assert!(said(0));
    assert!(!said(1));
}

/// `validate` holds a window to the cook's flatness limit: glass a little off its plane (0.5%
/// of its size) is one pane to both, and curved glass is said to be curved once, not also
/// "not planar".
#[test]
fn validate_and_cook_agree_on_what_is_flat() {
    let dir = tempfile::tempdir().unwrap();
    // A strip of glass 2 wide and 2 high in `n` facets, bent out of x = x0 by `bend` at its
    // middle.
    let strip = |x0: f64, bend: f64, n: usize, first: usize| {
        let mut s = String::new();
        for i in 0..=n {
            let t = i as f64 / n as f64;
            let x = x0 + bend * (std::f64::consts::PI * t).sin();
            let z = -1.0 + 2.0 * t;
            s += &format!("v {x} 1 {z}\nv {x} 3 {z}\nvt {t} 0\nvt {t} 1\n");
        }
        for i in 0..n {
            let a = first + 2 * i;
            let (b, c, d) = (a + 1, a + 3, a + 2);
            s += &format!("f {a}/{a} {d}/{d} {c}/{c}\nf {a}/{a} {c}/{c} {b}/{b}\n");
        }
        s
    };
    let mut obj = String::from("mtllib w.mtl\nusemtl glass_slight\n");
    // 0.014 off at the middle of a 2.83 diagonal: 0.5%.
    obj += &strip(5.0, 0.014, 8, 1);
    // Bent by 30% in 64 facets: too many planes to split it into.
    obj += "usemtl glass_curved\n";
    obj += &strip(-5.0, 0.6, 64, 19);
    obj += "usemtl floor\nv -5 0 -5\nv 5 0 -5\nv 5 0 5\nv -5 0 5\nf 149 151 150\nf 149 152 151\n";
    std::fs::write(dir.path().join("w.obj"), obj).unwrap();
    std::fs::write(
        dir.path().join("w.mtl"),
        "newmtl floor\nKd 0.5 0.5 0.5\nnewmtl glass_slight\nd 0.3\nnewmtl glass_curved\nd 0.3\n",
    )
    .unwrap();
    let m = Manifest::open(&dir.path().join("w.obj")).unwrap();
    let v = cook::validate::validate_scene(&m, cook::UpAxis::Y).unwrap();
    let of = |code: &str| -> Vec<&str> {
        v.findings
            .iter()
            .filter(|f| f.code == code)
            .map(|f| f.message.as_str())
            .collect()
    };
    assert!(of("window-not-planar").is_empty(), "{:#?}", v.findings);
    let curved = of("window-curved");
    assert_eq!(curved.len(), 1, "{:#?}", v.findings);
    assert!(curved[0].contains("glass_curved"), "{curved:?}");
}

/// A normal map's +y (green, up its image, the OpenGL convention bakers and glTF use) tilts
/// the glass up the window: each window vertex's bitangent, `cross(n, t) · w` as the viewer
/// and the reference renderer build it, runs up the design (against the frame's `v_axis`,
/// which runs down it) and its tangent along `u_axis`. Unflipped from MikkTSpace's (whose v
/// runs up where the pack's runs down), every window's relief was lit and refracted upside
/// down.
#[test]
fn window_bitangents_run_up_the_design() {
    let manifest =
        Manifest::open(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets-src/scene.toml"))
            .unwrap();
    let (_, pack) = cook_to_pack(&manifest);
    let toc = pack.toc();
    let m = &toc.meshes[0];
    assert!(m.layout.attribute(pack::Semantic::Tangent).is_some());
    let verts: Vec<_> = pack
        .vertex_bytes(m)
        .chunks_exact(m.layout.stride as usize)
        .map(|v| m.layout.decode(v))
        .collect();
    assert!(!toc.windows.is_empty());
    for w in &toc.windows {
        let (u, v) = (glam::Vec3::from(w.u_axis), glam::Vec3::from(w.v_axis));
        let mine: Vec<_> = verts
            .iter()
            .filter(|d| d.material[0] == w.material)
            .collect();
        assert!(!mine.is_empty(), "window material {}", w.material);
        for d in mine {
            let n = glam::Vec3::from(d.normal);
            let t = glam::Vec3::from_slice(&d.tangent[..3]);
            let b = n.cross(t) * d.tangent[3];
            assert!(t.dot(u) > 0.0, "tangent {t} against u {u}");
            assert!(b.dot(v) < 0.0, "bitangent {b} against v {v}");
        }
    }
}

/// The colour under a design's fully transparent texels (lead) never reaches the pack: the
/// viewer filters a design as stored before weighing it by alpha, so what an image editor
/// left there (white, often) showed as halos around the panes. Two designs that differ only
/// there cook to the same textures.
#[test]
fn the_colour_under_transparent_lead_does_not_reach_the_pack() {
    let dir = tempfile::tempdir().unwrap();
    let design = |under: u8| {
        let img = image::RgbaImage::from_fn(16, 16, |x, y| {
            if x % 4 == 3 || y % 4 == 3 {
                image::Rgba([under, under, under, 0])
            } else if (x / 4 + y / 4) % 2 == 0 {
                image::Rgba([200, 20, 20, 255])
            } else {
                image::Rgba([20, 160, 40, 255])
            }
        });
        let path = dir.path().join(format!("lead{under}.png"));
        img.save(&path).unwrap();
        path
    };
    let manifest =
        Manifest::open(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../assets-src/scene.toml"))
            .unwrap();
    let cook_with = |path: PathBuf| {
        let mut settings = Settings::new(&manifest);
        settings.window_overrides = vec![cook::manifest::WindowDesign::from_override("*", path)];
        let out = cook::cook(&manifest, &settings).expect("cooks");
        let bytes = pack::encode(out.toc.clone(), &out.data).expect("encodes");
        Pack::from_bytes("memory.pack", &bytes).expect("reads back")
    };
    let (black, white) = (cook_with(design(0)), cook_with(design(255)));
    let colour = |p: &Pack| -> Vec<Vec<u8>> {
        let toc = p.toc();
        (toc.textures.iter().enumerate())
            .filter(|(_, t)| t.role == pack::TextureRole::Colour && t.name.starts_with("lead"))
            .flat_map(|(i, t)| (0..t.mips.len()).map(move |l| (i, l)))
            .map(|(i, l)| p.mip_bytes(i, l).to_vec())
            .collect()
    };
    assert!(!colour(&black).is_empty());
    assert!(
        colour(&black) == colour(&white),
        "the hidden colour reached the design"
    );
}
