//! `cooker info` and `cooker diff` on packs built in code.

mod common;

use std::path::Path;
use std::process::Output;

use common::cooker;

use pack::testing::sample;

/// Writes `obj` as `<name>.obj` in `dir` and cooks it uncached into `<name>.pack`.
fn cook_obj(dir: &Path, name: &str, obj: &str) -> std::path::PathBuf {
    let source = dir.join(format!("{name}.obj"));
    std::fs::write(&source, obj).unwrap();
    let out = dir.join(format!("{name}.pack"));
    let o = cooker(&[&"cook", &source, &"-o", &out, &"--no-cache"]);
    assert!(o.status.success(), "{}", text(&o));
    out
}

/// `cooker diff a b --max-position-delta <delta>` and any further arguments.
fn diff_within(a: &Path, b: &Path, delta: &str, more: &[&str]) -> Output {
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
        vec![&"diff", &a, &b, &"--max-position-delta", &delta];
    args.extend(more.iter().map(|m| m as &dyn AsRef<std::ffi::OsStr>));
    cooker(&args)
}

fn write_sample(path: &Path, edit: impl FnOnce(&mut pack::Toc, &mut pack::PackData)) {
    let (mut toc, mut data) = sample();
    edit(&mut toc, &mut data);
    pack::write_pack(path, toc, &data).unwrap();
}

fn text(o: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    )
}

#[test]
fn info_json_has_the_documented_fields() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("s.pack");
    write_sample(&p, |toc, _| {
        toc.cameras = vec![pack::Camera {
            name: "nave".into(),
            position: [0.0, 1.5, 9.0],
            target: [0.0, 2.0, 0.0],
            up: [0.0, 1.0, 0.0],
            fov_y: 60.0,
            near: 0.0625,
            far: 300.0,
        }];
    });
    let o = cooker(&[&"info", &p, &"--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["format_version"], pack::FORMAT_VERSION);
    // The views whole, the cameras by name.
    assert_eq!(v["cameras"], serde_json::json!(["nave"]));
    assert_eq!(
        v["views"],
        serde_json::json!([{"name": "nave", "position": [0.0, 1.5, 9.0],
            "target": [0.0, 2.0, 0.0], "up": [0.0, 1.0, 0.0], "fov_y_deg": 60.0,
            "near": 0.0625, "far": 300.0}])
    );
    assert_eq!(v["sections"][0]["kind"], "toc");
    assert!(
        v["sections"]
            .as_array()
            .unwrap()
            .iter()
            .all(|s| s["offset"].is_u64() && s["length"].is_u64())
    );
    assert_eq!(v["materials"][0]["name"], "floor");
    assert_eq!(v["materials"][0]["class"], "floor");
    assert_eq!(v["materials"][1]["class"], "window-upper");
    assert_eq!(v["materials"][1]["triangles"], 1);
    assert_eq!(v["textures"][0]["role"], "colour");
    assert_eq!(v["textures"][1]["role"], "normal");
    assert_eq!(
        (
            v["textures"][0]["width"].as_u64(),
            v["textures"][0]["height"].as_u64(),
            v["textures"][0]["mips"].as_u64()
        ),
        (Some(4), Some(2), Some(3))
    );

    let o = cooker(&[&"info", &p]);
    assert_eq!(o.status.code(), Some(0));
    let out = text(&o);
    assert!(
        out.contains("window-upper")
            && out.contains("rose.colour")
            && out.contains("all checksums OK"),
        "{out}"
    );
}

#[test]
fn info_exit_codes_for_bad_input_io_and_usage() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("bad.pack");
    write_sample(&p, |_, _| {});
    let mut bytes = std::fs::read(&p).unwrap();
    let n = bytes.len();
    bytes[n - 1] ^= 0x10;
    std::fs::write(&p, &bytes).unwrap();
    let o = cooker(&[&"info", &p]);
    assert_eq!(o.status.code(), Some(3), "{}", text(&o));
    assert!(
        text(&o).contains("bad.pack: at byte offset") && text(&o).contains("checksum mismatch"),
        "{}",
        text(&o)
    );

    let missing = dir.path().join("missing.pack");
    let o = cooker(&[&"info", &missing]);
    assert_eq!(o.status.code(), Some(4), "{}", text(&o));
    assert_eq!(
        text(&o),
        format!(
            "error: {}: No such file or directory (os error 2)\n",
            missing.display()
        )
    );

    // A directory is said to be one (mapping it failed with "No such device").
    let o = cooker(&[&"info", &dir.path()]);
    assert_eq!(o.status.code(), Some(4), "{}", text(&o));
    assert_eq!(
        text(&o),
        format!(
            "error: {}: is a directory, not a pack file\n",
            dir.path().display()
        )
    );

    let o = cooker(&[&"info"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("the following required arguments were not provided"),
        "{}",
        text(&o)
    );
    let o = cooker(&[&"frobnicate"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("unrecognized subcommand 'frobnicate'"),
        "{}",
        text(&o)
    );
}

/// `diff --json` of two packs whose one mesh holds the same triangles in another vertex order:
/// accepted at `--max-position-delta delta`, compared as sets, none left unmatched. The JSON.
fn same_triangles_in_another_order(a: &Path, b: &Path, delta: &str) -> serde_json::Value {
    let o = diff_within(a, b, delta, &["--json"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["meshes"][0]["same_order"], false);
    assert_eq!(
        v["meshes"][0]["unmatched_triangles"],
        serde_json::json!([0, 0])
    );
    v
}

/// The sample with its vertices decoded, edited and written back in the layout of `encoding`
/// (the sample's own where `None`).
/// The first mesh's vertices, decoded from its own layout.
fn sample_vertices(toc: &pack::Toc, data: &pack::PackData) -> Vec<pack::StandardVertex> {
    let layout = &toc.meshes[0].layout;
    data.meshes[0]
        .vertices
        .chunks_exact(layout.stride as usize)
        .map(|b| layout.decode(b))
        .collect()
}

fn write_in_layout(
    path: &Path,
    encoding: Option<pack::vertex::Encoding>,
    edit: impl FnOnce(&mut Vec<pack::StandardVertex>),
) {
    write_sample(path, |toc, data| {
        let standard = toc.meshes[0].layout.clone();
        let mut verts = sample_vertices(toc, data);
        edit(&mut verts);
        let layout = encoding.map_or(standard, |e| {
            pack::vertex::layout(e, false, [0.0; 3], [1.0; 3])
        });
        data.meshes[0].vertices = layout.encode_vertices(&verts);
        toc.meshes[0].layout = layout;
    });
}

/// [`write_in_layout`] in the sample's own layout.
fn write_edited_vertices(path: &Path, edit: impl FnOnce(&mut Vec<pack::StandardVertex>)) {
    write_in_layout(path, None, edit);
}

/// Textures are named after their files: a renamed design file, or another of the same stem
/// that shifts the names, must not turn a texture into "missing" and "new", or compare it with
/// another image. They are paired by the materials that use them.
#[test]
fn diff_pairs_textures_by_the_materials_that_use_them() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.pack");
    write_sample(&a, |_, _| {});
    let renamed = dir.path().join("renamed.pack");
    write_sample(&renamed, |toc, _| {
        toc.textures[0].name = "rose-v2.colour".into();
    });
    let o = cooker(&[&"diff", &a, &renamed]);
    let said = text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains("texture \"rose.colour\" is named \"rose-v2.colour\" in b"),
        "{said}"
    );
    assert!(
        !said.contains("missing") && !said.contains("new in b"),
        "{said}"
    );
    assert!(!said.contains("max error"), "{said}");
    // The section list pairs them too: the renamed texture's mips are equal, not "only in a"
    // and "only in b"; the TOC, which holds the name, is what differs.
    let o = cooker(&[&"diff", &a, &renamed, &"--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let states: Vec<(&str, &str)> = v["sections"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| (s["section"].as_str().unwrap(), s["state"].as_str().unwrap()))
        .collect();
    assert!(
        states
            .iter()
            .any(|&(k, _)| k.starts_with("mip/rose.colour/")),
        "{states:?}"
    );
    assert!(
        states
            .iter()
            .all(|&(k, state)| (k == "toc") == (state != "equal")),
        "{states:?}"
    );
    // With a tolerance the name is not a problem, as a mesh's is not with one.
    let o = cooker(&[&"diff", &a, &renamed, &"--tolerance-lsb", &"0"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    // The two names swapped: by name, a colour texture was compared with a normal map.
    let swapped = dir.path().join("swapped.pack");
    write_sample(&swapped, |toc, _| {
        let (x, y) = (toc.textures[0].name.clone(), toc.textures[1].name.clone());
        toc.textures[0].name = y;
        toc.textures[1].name = x;
    });
    let o = cooker(&[&"diff", &a, &swapped, &"--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let pairs: Vec<(&str, &str)> = v["textures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            (
                t["name"].as_str().unwrap(),
                t["name_in_b"].as_str().unwrap(),
            )
        })
        .collect();
    assert_eq!(
        pairs,
        [
            ("rose.colour", "rose.normal"),
            ("rose.normal", "rose.colour")
        ],
        "{v:#}"
    );
    let problems = v["problems"].as_array().unwrap();
    assert_eq!(problems.len(), 2, "only the two names: {v:#}");
    // Each texture's mips are keyed by its partner's name: the colour levels of a with the
    // colour levels of b, equal, whatever b calls them.
    let sections = v["sections"].as_array().unwrap();
    assert!(
        sections
            .iter()
            .all(|s| s["section"] == "toc" || s["state"] == "equal"),
        "{sections:#?}"
    );
}

/// A diff's `--json` problems, as text.
fn problems_of(v: &serde_json::Value) -> Vec<&str> {
    v["problems"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap())
        .collect()
}

/// One window of three that share a design switched to a copy of another folder (same file
/// stem, so the names shift): the design shared by the other two is still paired with itself,
/// and the window whose material now names another image is named.
#[test]
fn diff_names_the_material_whose_design_changed() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene");
    common::copy_dir(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src"),
        &scene,
    );
    let scene_toml = scene.join("scene.toml");
    let cook_with = |name: &str, extra: &[String]| {
        let out = dir.path().join(name);
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
            vec![&"cook", &scene_toml, &"-o", &out, &"--no-cache"];
        args.extend(extra.iter().map(|e| e as &dyn AsRef<std::ffi::OsStr>));
        let o = cooker(&args);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
        out
    };
    let cook = |name: &str| cook_with(name, &[]);
    let a = cook("a.pack");

    // Every window that showed the lancet or the mosaic given the rose instead: the rose is
    // still the rose (equal bits, the rose window's own material unchanged), the lancet and
    // mosaic are gone, and each window given another image says so.
    let rose = scene.join("windows/rose.png");
    let roses = cook_with(
        "roses.pack",
        &[
            "--window".into(),
            format!("window_lower_*={}", rose.display()),
        ],
    );
    let o = cooker(&[&"diff", &a, &roses, &"--json"]);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let equal_in = |v: &serde_json::Value, name: &str| {
        v["materials"]
            .as_array()
            .unwrap()
            .iter()
            .find(|m| m["name"] == name)
            .unwrap_or_else(|| panic!("no material {name}: {v:#}"))["textures_equal"]
            .clone()
    };
    assert_eq!(equal_in(&v, "rose"), true, "{v:#}");
    for k in 1..=5 {
        assert_eq!(equal_in(&v, &format!("window_lower_{k}")), false, "{v:#}");
    }
    let problems = problems_of(&v);
    assert!(
        problems.contains(&"texture \"mosaic.masked\" is missing from b"),
        "{problems:#?}"
    );
    // The lancets' windows now show the rose cut to their outline: a texture of its own, made
    // from the rose, which takes the rose's plain name (the rose window's own, its bits
    // equal, is said renamed, nothing more).
    assert!(
        problems.contains(&"texture \"lancet.masked\" is named \"rose.masked\" in b"),
        "{problems:#?}"
    );
    assert!(
        problems
            .iter()
            .filter(|p| p.starts_with("texture \"rose.masked"))
            .all(|p| p.contains(" is named \"rose.masked") && p.ends_with(".2\" in b")),
        "{problems:#?}"
    );
    // Capped by --max-texture-size, a chain starts at the full one's level 1 or 2: its
    // sections are paired by size, so the level stored alike is "equal" (by index every level
    // was "different", identical bytes included).
    let cap = cook_with("cap.pack", &["--max-texture-size".into(), "256".into()]);
    let o = cooker(&[&"diff", &a, &cap, &"--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let floor_equal =
        v["sections"].as_array().unwrap().iter().any(|s| {
            s["section"].as_str().unwrap().starts_with("mip/floor/") && s["state"] == "equal"
        });
    assert!(floor_equal, "{:#}", v["sections"]);
    let mosaic = image::open(scene.join("windows/mosaic.png")).unwrap();
    std::fs::create_dir_all(scene.join("alt")).unwrap();
    mosaic.fliph().save(scene.join("alt/mosaic.png")).unwrap();
    let toml = std::fs::read_to_string(scene.join("scene.toml"))
        .unwrap()
        .replacen(
            "material = \"window_lower_2\"\ndesign = \"windows/mosaic.png\"",
            "material = \"window_lower_2\"\ndesign = \"alt/mosaic.png\"",
            1,
        );
    assert!(toml.contains("alt/mosaic.png"));
    std::fs::write(scene.join("scene.toml"), toml).unwrap();
    let b = cook("b.pack");

    let o = cooker(&[&"diff", &a, &b, &"--json"]);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let problems = problems_of(&v);
    assert!(
        problems.iter().any(|p| p.starts_with(
            "material \"window_lower_2\": its colour texture is \"mosaic.masked\" in a and"
        ) && p.ends_with("in b, another image")),
        "{problems:#?}"
    );
    // The design the other windows keep is compared with itself: no texel differs.
    assert!(
        !problems
            .iter()
            .any(|p| p.starts_with("texture \"mosaic.masked\" mip")),
        "{problems:#?}"
    );
    assert_eq!(equal_in(&v, "window_lower_2"), false);
    assert_eq!(equal_in(&v, "window_lower_4"), true);

    // The design file edited in place, to another size: every name stays, yet the windows
    // that show it differ, and its textures are listed as such (they were left out of
    // `textures`, and the materials said `textures_equal: true`).
    mosaic
        .resize_exact(300, 700, image::imageops::FilterType::Triangle)
        .save(scene.join("windows/mosaic.png"))
        .unwrap();
    let c = cook("c.pack");
    let o = cooker(&[&"diff", &b, &c, &"--json"]);
    assert_eq!(o.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(equal_in(&v, "window_lower_4"), false, "{v:#}");
    assert_eq!(equal_in(&v, "window_lower_2"), true, "{v:#}");
    assert_eq!(equal_in(&v, "rose"), true, "{v:#}");
    let textures = v["textures"].as_array().unwrap();
    // The design and its projector and normal map: 329 x 1024 in b, 300 x 700 in c.
    let resized: Vec<&serde_json::Value> = textures
        .iter()
        .filter(|t| t["state"] == "sizes differ")
        .collect();
    assert!(resized.len() >= 2, "{v:#}");
    assert!(
        resized
            .iter()
            .any(|t| t["size"][0] == serde_json::json!([329, 1024, 11])
                && t["size"][1] == serde_json::json!([300, 700, 10])),
        "{v:#}"
    );
    assert!(
        textures.iter().filter(|t| t["state"] == "compared").count() >= 10,
        "{v:#}"
    );
}

/// The sample's quad with its triangles' corners listed from the second (so it compares as
/// sets), moved by `dz` off its plane.
fn write_rotated_corners(path: &Path, dz: f32) {
    write_sample(path, |toc, data| {
        let layout = toc.meshes[0].layout.clone();
        let mut verts = sample_vertices(toc, data);
        for v in &mut verts {
            v.position[2] += dz;
        }
        data.meshes[0].vertices = layout.encode_vertices(&verts);
        let rotated: [u16; 6] = [1, 2, 0, 4, 5, 3];
        data.meshes[0].indices = rotated.iter().flat_map(|i| i.to_le_bytes()).collect();
        toc.meshes[0].bounds_min[2] += dz;
        toc.meshes[0].bounds_max[2] += dz;
    });
}

/// Compared as sets, the summary said "largest corner move 0.000e0, surface gap …" beside
/// triangles off the other's surface: the move is over matched triangles and the gap over
/// those on the surface, and there were none of either.
#[test]
fn diff_as_sets_says_what_its_largest_move_and_gap_are_of() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.pack");
    write_sample(&a, |_, _| {});
    let diff = |b: &Path| {
        let o = cooker(&[&"diff", &a, &b, &"--max-position-delta", &"0.001"]);
        let json = cooker(&[
            &"diff",
            &a,
            &b,
            &"--max-position-delta",
            &"0.001",
            &"--json",
        ]);
        let v: serde_json::Value = serde_json::from_slice(&json.stdout).unwrap();
        (o.status.code(), text(&o), v["meshes"][0].clone())
    };
    let moved = dir.path().join("moved.pack");
    write_rotated_corners(&moved, 0.5);
    let (code, said, m) = diff(&moved);
    assert_eq!(code, Some(1), "{said}");
    assert!(
        said.contains("2 and 2 of those off the other's surface; none matched\n"),
        "{said}"
    );
    assert!(!said.contains("largest"), "{said}");
    assert_eq!(m["max_position_delta"], serde_json::Value::Null, "{m:#}");
    assert_eq!(m["surface_gap"], serde_json::Value::Null, "{m:#}");

    let same = dir.path().join("same.pack");
    write_rotated_corners(&same, 0.0);
    let (code, said, m) = diff(&same);
    assert_eq!(code, Some(0), "{said}");
    assert!(
        said.contains(
            "0 of a and 0 of b unmatched, 0 and 0 of those off the other's surface; \
                       largest corner move of the 2 matched 0.000e0\n"
        ),
        "{said}"
    );
    assert_eq!(m["max_position_delta"], 0.0, "{m:#}");
}

/// A regression gate that accepts moved geometry must still see turned normals and moved
/// texture coordinates: they change the shading and the texturing, not the positions. They
/// were not compared at all, so `--max-position-delta` passed them with exit 0.
#[test]
fn diff_sees_changed_normals_tangents_and_texture_coordinates() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.pack");
    write_edited_vertices(&a, |_| {});
    let b = dir.path().join("b.pack");
    write_edited_vertices(&b, |v| {
        // Vertex 1's normal tilted by 1 degree, vertex 3's u moved by 0.01.
        let n = glam::Vec3::from(v[1].normal);
        let axis = n.any_orthonormal_vector();
        v[1].normal = (glam::Quat::from_axis_angle(axis, 1f32.to_radians()) * n).to_array();
        v[3].uv[0] += 0.01;
    });
    for extra in [&[][..], &["--max-position-delta", "0.1"][..]] {
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![&"diff", &a, &b];
        args.extend(extra.iter().map(|s| s as &dyn AsRef<std::ffi::OsStr>));
        let o = cooker(&args);
        let said = text(&o);
        assert_eq!(o.status.code(), Some(1), "{extra:?}: {said}");
        assert!(
            said.contains("1 vertices' normals turned, by up to 1.000 degrees")
                && said.contains("1 vertices' texture coordinates moved, by up to 1.000e-2"),
            "{extra:?}: {said}"
        );
    }
    // Looser thresholds accept them.
    let o = cooker(&[
        &"diff",
        &a,
        &b,
        &"--max-normal-delta-deg",
        &"1.5",
        &"--max-uv-delta",
        &"0.02",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // In another vertex order, the triangles are matched first and their corners compared.
    let c = dir.path().join("c.pack");
    write_sample(&c, |toc, data| {
        let layout = &toc.meshes[0].layout;
        let mut verts: Vec<pack::StandardVertex> = data.meshes[0]
            .vertices
            .chunks_exact(layout.stride as usize)
            .map(|b| layout.decode(b))
            .collect();
        let n = verts.len() as u16;
        verts.reverse();
        verts[0].tangent[3] = -verts[0].tangent[3];
        data.meshes[0].vertices = layout.encode_vertices(&verts);
        let indices: Vec<u16> = data.meshes[0]
            .indices
            .chunks_exact(2)
            .map(|b| n - 1 - u16::from_le_bytes([b[0], b[1]]))
            .collect();
        data.meshes[0].indices = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    });
    let o = cooker(&[&"diff", &a, &c, &"--max-position-delta", &"0.1"]);
    let said = text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains("corners' tangents turned or flipped, by up to 180.000 degrees"),
        "{said}"
    );
    // The two triangles' vertices listed the other way round over the same index buffer
    // (0, 1, 2, 3, 4, 5): the same triangles, not vertices that moved.
    let e = dir.path().join("e.pack");
    write_sample(&e, |toc, data| {
        let stride = toc.meshes[0].layout.stride as usize;
        let v = data.meshes[0].vertices.clone();
        let (first, second) = v.split_at(3 * stride);
        data.meshes[0].vertices = [second, first].concat();
    });
    same_triangles_in_another_order(&a, &e, "1e-6");
    // A mesh that lost its texture coordinates is a difference whatever the thresholds.
    let d = dir.path().join("d.pack");
    let bare = pack::vertex::Encoding {
        normal: true,
        uv: false,
        tangent: false,
        colour: false,
        quantize: None,
    };
    write_in_layout(&d, Some(bare), |_| {});
    let o = cooker(&[
        &"diff",
        &a,
        &d,
        &"--max-position-delta",
        &"1",
        &"--max-uv-delta",
        &"9",
    ]);
    let said = text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains("texture coordinates in a, none in b"),
        "{said}"
    );
}

#[test]
fn diff_identical_changed_texel_and_material() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.pack");
    let b = dir.path().join("b.pack");
    let c = dir.path().join("c.pack");
    write_sample(&a, |_, _| {});
    write_sample(&b, |_, data| {
        data.textures[0][0][5] = data.textures[0][0][5].wrapping_add(2)
    });
    // Vertex 2 moves from material 0 ("floor") to 1.
    write_sample(&c, |_, data| data.meshes[0].vertices[52 * 2 + 48] = 1);

    let o = cooker(&[&"diff", &a, &a]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    assert!(text(&o).contains("identical"));

    let o = cooker(&[&"diff", &a, &b, &"--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["within_thresholds"], false);
    assert_eq!(v["textures"][0]["levels"][0]["max_error"], 2);
    assert_eq!(v["textures"][0]["levels"][1]["max_error"], 0);
    // Numbers stay numbers: an equal level's infinite PSNR is null (it was the string "inf").
    let levels = &v["textures"][0]["levels"];
    assert!(levels[0]["psnr"].is_f64(), "{levels}");
    assert_eq!(levels[0]["equal"], false);
    assert!(levels[1]["psnr"].is_null(), "{levels}");
    assert_eq!(levels[1]["equal"], true);
    let changed: Vec<_> = v["sections"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["state"] != "equal")
        .collect();
    assert_eq!(changed.len(), 1, "only the edited mip differs: {changed:?}");
    assert_eq!(changed[0]["section"], "mip/rose.colour/4x2");

    let o = cooker(&[&"diff", &a, &b, &"--tolerance-lsb", &"2"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // The old spelling of --tolerance-lsb still works.
    let o = cooker(&[&"diff", &a, &b, &"--max-error", &"1"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(text(&o).contains("max error 2 LSB"), "{}", text(&o));

    let o = cooker(&[&"diff", &a, &c]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("1 vertices changed material"),
        "{}",
        text(&o)
    );

    // One vertex painted: the colour a layout without one decodes to is white, so only that
    // vertex differs, by its largest channel's change.
    let e = dir.path().join("e.pack");
    let everything = pack::vertex::Encoding {
        normal: true,
        uv: true,
        tangent: true,
        colour: true,
        quantize: None,
    };
    write_in_layout(&e, Some(everything), |verts| {
        verts[4].colour = [255, 240, 250, 0]
    });
    let o = cooker(&[&"diff", &a, &e]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("1 vertices changed colour, by up to 15 sRGB steps"),
        "{}",
        text(&o)
    );

    // The same two triangles, vertices listed in reverse within each and corners turned: equal
    // as geometry, not as bytes. Without --max-position-delta that is a difference.
    let d = dir.path().join("d.pack");
    write_sample(&d, |_, data| {
        let stride = 52;
        let v = data.meshes[0].vertices.clone();
        for (new, old) in [2usize, 1, 0, 5, 4, 3].into_iter().enumerate() {
            data.meshes[0].vertices[new * stride..(new + 1) * stride]
                .copy_from_slice(&v[old * stride..(old + 1) * stride]);
        }
        // Triangle (0,1,2) is now (2,1,0) in slots; (1,0,2) keeps its winding, turned.
        let turned: [u16; 6] = [1, 0, 2, 4, 3, 5];
        data.meshes[0].indices = turned.iter().flat_map(|i| i.to_le_bytes()).collect();
    });
    let o = cooker(&[&"diff", &a, &d]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("the same triangles in another order"),
        "{}",
        text(&o)
    );
    let v = same_triangles_in_another_order(&a, &d, "0");
    assert_eq!(v["meshes"][0]["material_corner_changes"], 0);
    // Reversed winding is another face: it faces the other way.
    let e = dir.path().join("e.pack");
    write_sample(&e, |_, data| {
        let flipped: [u16; 6] = [0, 2, 1, 3, 5, 4];
        data.meshes[0].indices = flipped.iter().flat_map(|i| i.to_le_bytes()).collect();
    });
    let o = cooker(&[&"diff", &a, &e, &"--max-position-delta", &"0.1"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains(
            "2 of a's 2 triangles are off b's surface (farther than 1.000e-1, or facing the \
             other way), 2 of b's 2 off a's"
        ),
        "{}",
        text(&o)
    );

    // One mesh in each pack, named after different source files (church.obj, church.glb):
    // compared with each other. A changed colour is a difference.
    let f = dir.path().join("f.pack");
    write_sample(&f, |toc, _| toc.meshes[0].name = "church".into());
    let o = cooker(&[&"diff", &a, &f]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("mesh \"quad\" is named \"church\" in b"),
        "{}",
        text(&o)
    );
    let o = cooker(&[&"diff", &a, &f, &"--max-position-delta", &"0"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    let g = dir.path().join("g.pack");
    write_sample(&g, |toc, _| toc.materials[0].diffuse[1] = 0.41);
    let o = cooker(&[&"diff", &a, &g, &"--max-position-delta", &"0"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        text(&o).contains("material \"floor\": shading differs: diffuse [0.5, 0.4, 0.3]"),
        "{}",
        text(&o)
    );

    // A changed light is said with both, so a regression run shows what moved.
    let l = dir.path().join("l.pack");
    write_sample(&l, |toc, _| {
        toc.light.as_mut().unwrap().intensity = 2.5;
    });
    let o = cooker(&[&"diff", &a, &l]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let said = text(&o);
    let line = said
        .lines()
        .find(|l| l.contains("the light differs: "))
        .unwrap_or_else(|| panic!("{said}"));
    assert!(
        line.contains("intensity 3 in a") && line.ends_with("intensity 2.5 in b"),
        "{said}"
    );

    let o = cooker(&[&"diff", &a, &b, &"--max-error", &"-1"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(
        text(&o).contains("--tolerance-lsb must be a finite number >= 0, got -1"),
        "{}",
        text(&o)
    );
}

/// A projector's alpha is never sampled, and its block-compressed copy is opaque: diff
/// compares its colour only, so an RGBA8 pack and a BC one compare by their light.
#[test]
fn diff_compares_a_projector_by_its_colour() {
    let dir = tempfile::tempdir().unwrap();
    let as_projector = |toc: &mut pack::Toc| toc.textures[0].role = pack::TextureRole::Projector;
    let a = dir.path().join("a.pack");
    write_sample(&a, |toc, _| as_projector(toc));
    let b = dir.path().join("b.pack");
    write_sample(&b, |toc, data| {
        as_projector(toc);
        data.textures[0][0][3] = data.textures[0][0][3].wrapping_sub(200);
        data.textures[0][0][4] = data.textures[0][0][4].wrapping_add(2);
    });
    let o = cooker(&[&"diff", &a, &b, &"--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["textures"][0]["levels"][0]["max_error"], 2, "{v}");
    let o = cooker(&[&"diff", &a, &b, &"--tolerance-lsb", &"2"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

/// Windows listed in another order (a model exported with its objects in another order) are
/// the same windows: each is paired with the nearest of the other pack's. Compared by index,
/// every frame had moved, whatever the tolerance.
#[test]
fn diff_pairs_windows_listed_in_another_order() {
    let dir = tempfile::tempdir().unwrap();
    let two = |toc: &mut pack::Toc| {
        let mut second = toc.windows[0].clone();
        second.origin = [5.0, 0.0, 0.0];
        second.source_materials = vec!["rose-red".into(), "rose-blue".into()];
        toc.windows.push(second);
    };
    let a = dir.path().join("a.pack");
    write_sample(&a, |toc, _| two(toc));
    let b = dir.path().join("b.pack");
    write_sample(&b, |toc, _| {
        two(toc);
        toc.windows.reverse();
    });
    let o = cooker(&[&"diff", &a, &b, &"--max-position-delta", &"0"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // One of them moved: named with its partner.
    let c = dir.path().join("c.pack");
    write_sample(&c, |toc, _| {
        two(toc);
        toc.windows.reverse();
        toc.windows[0].origin[1] += 0.5;
    });
    let o = cooker(&[&"diff", &a, &c, &"--max-position-delta", &"0.1"]);
    let said = text(&o);
    assert_eq!(o.status.code(), Some(1), "{said}");
    assert!(
        said.contains("the window frames differ: window 1 (\"rose\") and b's window 0")
            && said.contains("moved by 5.000e-1"),
        "{said}"
    );
}

/// Every camera preset that moved is named, in the text and in `--json`: a re-export that
/// moved three views reported the first alone.
#[test]
fn diff_names_every_camera_that_moved() {
    let dir = tempfile::tempdir().unwrap();
    let three = |toc: &mut pack::Toc| {
        let first = toc.cameras[0].clone();
        for name in ["windows", "lit-floor"] {
            let mut c = first.clone();
            c.name = name.into();
            toc.cameras.push(c);
        }
    };
    let a = dir.path().join("a.pack");
    write_sample(&a, |toc, _| three(toc));
    let b = dir.path().join("b.pack");
    write_sample(&b, |toc, _| {
        three(toc);
        toc.cameras[0].position[0] += 2.0;
        toc.cameras[2].target[1] += 0.5;
    });
    let o = cooker(&[&"diff", &a, &b, &"--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let first = v["scene"]["cameras_differing"][0]
        .as_str()
        .unwrap()
        .to_string();
    assert_eq!(
        v["scene"]["cameras_differing"],
        serde_json::json!([first, "lit-floor"]),
        "{v:#}"
    );
    let problems = problems_of(&v);
    let cameras: Vec<&&str> = problems
        .iter()
        .filter(|p| p.starts_with("the camera presets differ"))
        .collect();
    assert!(
        cameras.len() == 1
            && cameras[0].contains(&format!("{first:?}: position or target moved by 2.000e0"))
            && cameras[0].contains("\"lit-floor\": position or target moved by 5.000e-1")
            && !cameras[0].contains("\"windows\""),
        "{problems:#?}"
    );
}

/// A guessed view stands up to the model's diagonal from it, so with `--max-position-delta`
/// a camera may move (1 + 2√3) times the delta: a gltfpack-quantized export failed on its
/// cameras alone.
#[test]
fn diff_lets_cameras_move_as_far_as_the_delta_moves_a_guessed_view() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.pack");
    write_sample(&a, |_, _| {});
    for (moved, differ) in [(0.3, false), (0.5, true)] {
        let b = dir.path().join("b.pack");
        write_sample(&b, |toc, _| toc.cameras[0].position[0] += moved);
        let o = cooker(&[&"diff", &a, &b, &"--json", &"--max-position-delta", &"0.1"]);
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let named = v["scene"]["cameras_differing"].as_array().unwrap().len();
        assert_eq!(named > 0, differ, "{moved}: {v:#}");
    }
}

/// The scene's parameters are fields of `--json` (a script need not parse the problems'
/// text), and the background's problem gives both sides.
#[test]
fn diff_json_says_which_scene_parameters_differ() {
    let dir = tempfile::tempdir().unwrap();
    let a = dir.path().join("a.pack");
    write_sample(&a, |_, _| {});
    let b = dir.path().join("b.pack");
    write_sample(&b, |toc, _| {
        toc.background.colour = [0.5, 0.6, 0.75];
    });
    let o = cooker(&[&"diff", &a, &b, &"--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        v["scene"],
        serde_json::json!({
            "light_equal": true,
            "cameras_equal": true,
            "cameras_differing": [],
            "window_frames_equal": true,
            "background_equal": false,
        }),
        "{v:#}"
    );
    let problems = problems_of(&v);
    assert!(
        problems
            .iter()
            .any(|p| p.starts_with("the background differs: colour [")
                && p.ends_with("in a, colour [0.500, 0.600, 0.750] in b")),
        "{problems:#?}"
    );
}

/// A vertex moved off its plane by 1e-4 on a mesh whose floor is 100 units wide is a change
/// at `--max-position-delta 0`: the allowance for rounding was a millionth of the mesh's
/// diagonal (1.4e-4 here), so such a gate passed changed geometry.
#[test]
fn diff_at_a_position_delta_of_0_sees_a_small_move_on_a_large_mesh() {
    let dir = tempfile::tempdir().unwrap();
    let quads = |z: &str| {
        format!(
            "o floor\nv -50 0 -50\nv 50 0 -50\nv 50 0 50\nv -50 0 50\nf 1 4 3 2\n\
             o box\nv 0 0 0\nv 1 0 0\nv 1 1 {z}\nv 0 1 0\nf 5 6 7 8\n"
        )
    };
    let (a, b) = (
        cook_obj(dir.path(), "a", &quads("0")),
        cook_obj(dir.path(), "b", &quads("0.0001")),
    );
    let o = diff_within(&a, &b, "0", &[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let o = diff_within(&a, &b, "0.001", &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

/// A vertex slid along its own plane leaves the surface where it was but moves the texture
/// with it: with the vertices in the same order it is a move as far as the vertex went, over
/// `--max-position-delta`, where comparing the triangles as sets found every one on the
/// other's surface and passed.
#[test]
fn diff_sees_a_vertex_slid_along_its_plane_past_the_position_delta() {
    let dir = tempfile::tempdir().unwrap();
    // A floor of four quads round a centre vertex, which slides 0.5 along the floor in b. It
    // is textured: without a texture its coordinates are not stored, and a slide along the
    // plane changes nothing that is drawn.
    std::fs::write(
        dir.path().join("floor.mtl"),
        "newmtl stone\nmap_Kd stone.png\n",
    )
    .unwrap();
    image::RgbaImage::from_fn(8, 8, |x, y| {
        image::Rgba([(x * 30) as u8, (y * 30) as u8, 90, 255])
    })
    .save(dir.path().join("stone.png"))
    .unwrap();
    let floor = |centre: &str| {
        format!(
            "mtllib floor.mtl\nusemtl stone\no floor\nv -2 0 -2\nv 0 0 -2\nv 2 0 -2\nv -2 0 0\nv {centre}\nv 2 0 0\nv -2 0 2\n\
             v 0 0 2\nv 2 0 2\nvt 0 0\nvt 0.5 0\nvt 1 0\nvt 0 0.5\nvt 0.5 0.5\nvt 1 0.5\n\
             vt 0 1\nvt 0.5 1\nvt 1 1\nf 1/1 4/4 5/5 2/2\nf 2/2 5/5 6/6 3/3\n\
             f 4/4 7/7 8/8 5/5\nf 5/5 8/8 9/9 6/6\n"
        )
    };
    let (a, b) = (
        cook_obj(dir.path(), "a", &floor("0 0 0")),
        cook_obj(dir.path(), "b", &floor("0.5 0 -0.5")),
    );
    let o = diff_within(&a, &b, "0.001", &["--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let m = &v["meshes"][0];
    assert_eq!(m["same_order"], true, "{m:#}");
    let delta = m["max_position_delta"].as_f64().unwrap();
    // Per axis, as the option is.
    assert!((delta - 0.5).abs() < 1e-6, "{m:#}");
    assert!(
        problems_of(&v)
            .iter()
            .any(|p| p.contains("a vertex moved by 5.000e-1")),
        "{v:#}"
    );
    // Within a tolerance that covers the slide, it passes.
    let o = diff_within(&a, &b, "0.8", &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));

    // Exported by another tool: faces in reverse order, each from another corner, so the
    // triangles are compared as sets. Those round the slid vertex still lie on a's floor; their
    // texture coordinates do not (the vertex kept its own), and that is what is reported.
    let faces = |text: String| {
        let (head, faces): (Vec<&str>, Vec<&str>) =
            text.lines().partition(|l| !l.starts_with("f "));
        let mut out = head.join("\n") + "\n";
        for f in faces.iter().rev() {
            let mut c: Vec<&str> = f.split_whitespace().skip(1).collect();
            c.rotate_left(1);
            out += &format!("f {}\n", c.join(" "));
        }
        out
    };
    let reordered = cook_obj(dir.path(), "c", &faces(floor("0.5 0 -0.5")));
    let o = diff_within(&a, &reordered, "0.001", &["--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let m = &v["meshes"][0];
    assert_eq!(m["same_order"], false, "{m:#}");
    assert_eq!(
        m["off_surface_triangles"],
        serde_json::json!([0, 0]),
        "{m:#}"
    );
    assert!(
        m["retriangulated_uv_changes"].as_u64().unwrap() > 0,
        "{m:#}"
    );
    assert!(
        m["max_retriangulated_uv_delta"].as_f64().unwrap() > 0.05,
        "{m:#}"
    );
    assert!(
        problems_of(&v)
            .iter()
            .any(|p| p.contains("texture coordinates differ from the other's")),
        "{v:#}"
    );
    // The same export without the slide: another order, the same texture on the same floor.
    let reordered = cook_obj(dir.path(), "d", &faces(floor("0 0 0")));
    let o = diff_within(&a, &reordered, "0.001", &[]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
}

/// A negative threshold is refused as NaN is, with the option and the value, not taken for a
/// flag ("unexpected argument '-0' found").
#[test]
fn diff_refuses_a_negative_threshold_by_name() {
    for option in [
        "--max-position-delta",
        "--tolerance-lsb",
        "--max-normal-delta-deg",
        "--max-uv-delta",
    ] {
        let o = cooker(&[&"diff", &"a.pack", &"b.pack", &option, &"-0.5"]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert!(
            text(&o).contains(&format!("{option} must be a finite number >= 0, got -0.5")),
            "{}",
            text(&o)
        );
    }
}

/// A material renamed and nothing else: one line that says so. It was every vertex "changed
/// material", the material missing from b and another new in b, though no vertex changed.
#[test]
fn diff_says_a_renamed_material_is_renamed() {
    let dir = tempfile::tempdir().unwrap();
    // The same model in two folders, its floor's material renamed in the second.
    let room = |folder: &str, floor: &str| {
        let at = dir.path().join(folder);
        std::fs::create_dir_all(&at).unwrap();
        std::fs::write(
            at.join("room.mtl"),
            format!("newmtl {floor}\nKd 0.6 0.5 0.4\nnewmtl wall\nKd 0.8 0.8 0.8\n"),
        )
        .unwrap();
        let obj = format!(
            "mtllib room.mtl\nv -4 0 -4\nv 4 0 -4\nv 4 0 4\nv -4 0 4\nv -4 3 -4\nv 4 3 -4\n\
             usemtl {floor}\nf 1 4 3 2\nusemtl wall\nf 1 2 6 5\n"
        );
        cook_obj(&at, "room", &obj)
    };
    let a = room("a", "floor_stone");
    let b = room("b", "floor_slab");
    let o = cooker(&[&"diff", &a, &b, &"--json"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(
        problems_of(&v),
        ["material \"floor_stone\" is named \"floor_slab\" in b"],
        "{v:#}"
    );
    assert_eq!(v["meshes"][0]["material_id_changes"], 0, "{v:#}");
}
