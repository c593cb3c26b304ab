//! The committed `assets-src/` must be exactly what the generator makes, and what it makes must
//! be a sound scene: closed, consistently wound, planar windows with UVs over their designs,
//! every window's sunlight landing on the floor or a wall, and a manifest that tags it all.

use std::collections::HashMap;
use std::path::Path;

use assetgen::geom::{self, Class, MIN_DOUBLE_AREA, Object, Scene};
use assetgen::{File, Options, generate, read_tree, sun, tree_hash, write};
use glam::{Vec2, Vec3};

fn committed_dir() -> std::path::PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src")
}

fn file<'a>(files: &'a [File], path: &str) -> &'a [u8] {
    &files
        .iter()
        .find(|f| f.path == path)
        .unwrap_or_else(|| panic!("{path} not generated"))
        .bytes
}

#[test]
fn committed_assets_are_what_the_generator_writes() {
    let out = generate(&Options::default()).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    write(tmp.path(), &out.files).unwrap();
    let fresh = read_tree(tmp.path()).unwrap();
    let committed = read_tree(&committed_dir()).unwrap();
    if tree_hash(&fresh) != tree_hash(&committed) {
        let names = |files: &[File]| files.iter().map(|f| f.path.clone()).collect::<Vec<_>>();
        let mut report = Vec::new();
        for f in &fresh {
            match committed.iter().find(|c| c.path == f.path) {
                None => report.push(format!("{} is not committed", f.path)),
                Some(c) if c.bytes != f.bytes => {
                    // Same pixels in different bytes means the PNG encoder changed (an `image`
                    // or `png` update), not the generator; regenerating is still the fix.
                    let pixels = |b: &[u8]| {
                        image::load_from_memory(b)
                            .ok()
                            .map(|i| i.to_rgba8().into_raw())
                    };
                    let same_pixels = f.path.ends_with(".png")
                        && pixels(&c.bytes).is_some_and(|p| Some(p) == pixels(&f.bytes));
                    let why = if same_pixels {
                        " (same pixels: the PNG encoder changed)"
                    } else {
                        ""
                    };
                    report.push(format!("{} differs{why}", f.path))
                }
                Some(_) => {}
            }
        }
        for c in &committed {
            if !fresh.iter().any(|f| f.path == c.path) {
                report.push(format!("{} is committed but not generated", c.path));
            }
        }
        panic!(
            "assets-src is stale: run `cargo run -p assetgen` from the repository root and commit \
             the result.\n{}\ngenerated: {:?}",
            report.join("\n"),
            names(&fresh)
        );
    }
    // What was written is what was generated.
    assert_eq!(tree_hash(&fresh), tree_hash(&out.files));
}

#[test]
fn output_does_not_depend_on_the_thread_count_or_the_run() {
    let opts = Options {
        seed: 99,
        design_size: 200,
    };
    let one = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let four = rayon::ThreadPoolBuilder::new()
        .num_threads(4)
        .build()
        .unwrap();
    let a = one.install(|| generate(&opts)).unwrap();
    let b = four.install(|| generate(&opts)).unwrap();
    let c = four.install(|| generate(&opts)).unwrap();
    assert_eq!(tree_hash(&a.files), tree_hash(&b.files));
    assert_eq!(tree_hash(&b.files), tree_hash(&c.files));
    // And the seed matters: another seed gives other glass.
    let d = generate(&Options {
        seed: 100,
        design_size: 200,
    })
    .unwrap();
    assert_ne!(
        file(&a.files, "windows/mosaic.png"),
        file(&d.files, "windows/mosaic.png")
    );
}

fn scene() -> Scene {
    geom::build(&geom::Layout::default())
}

fn double_area([a, b, c]: [Vec3; 3]) -> f32 {
    (b - a).cross(c - a).length()
}

#[test]
fn no_degenerate_triangles_and_unit_normals_agreeing_with_the_winding() {
    let s = scene();
    for o in &s.objects {
        assert!(!o.triangles.is_empty(), "{} is empty", o.name);
        for v in &o.vertices {
            assert!(
                (v.normal.length() - 1.0).abs() < 1e-4,
                "{}: normal {:?}",
                o.name,
                v.normal
            );
            assert!(v.position.is_finite() && v.uv.is_finite(), "{}", o.name);
        }
        for &t in &o.triangles {
            assert!(
                t.iter().all(|&i| (i as usize) < o.vertices.len()),
                "{}: index out of range",
                o.name
            );
            let p = o.corners(t);
            assert!(
                double_area(p) >= MIN_DOUBLE_AREA,
                "{}: degenerate {p:?}",
                o.name
            );
            let face = (p[1] - p[0]).cross(p[2] - p[0]).normalize();
            for &i in &t {
                let n = o.vertices[i as usize].normal;
                assert!(
                    face.dot(n) > 0.2,
                    "{}: triangle {p:?} wound against its normal {n:?}",
                    o.name
                );
            }
        }
    }
}

/// Undirected edges of the stone shell and the panes, keyed by exact positions.
fn shell_edges(s: &Scene) -> HashMap<([u32; 3], [u32; 3]), (i32, i32)> {
    let key = |p: Vec3| p.to_array().map(|x| if x == 0.0 { 0 } else { x.to_bits() });
    let mut edges: HashMap<_, (i32, i32)> = HashMap::new();
    for o in s
        .objects
        .iter()
        .filter(|o| o.name != "piers" && o.class != Class::Background)
    {
        for &t in &o.triangles {
            let p = o.corners(t);
            for k in 0..3 {
                let (a, b) = (key(p[k]), key(p[(k + 1) % 3]));
                let e = edges
                    .entry(if a < b { (a, b) } else { (b, a) })
                    .or_default();
                if a < b {
                    e.0 += 1;
                } else {
                    e.1 += 1;
                }
            }
        }
    }
    edges
}

#[test]
fn the_shell_is_closed_without_cracks_and_faces_inwards() {
    let s = scene();
    let edges = shell_edges(&s);
    let bad: Vec<_> = edges
        .iter()
        .filter(|(_, v)| **v != (1, 1))
        .take(5)
        .collect();
    assert!(
        bad.is_empty(),
        "edges not shared by exactly two opposite triangles: {bad:?}"
    );
    // Divergence theorem: with normals facing inwards the signed volume is negative, and its
    // size is the corridor's (section times length).
    let mut volume = 0.0f64;
    for o in s
        .objects
        .iter()
        .filter(|o| o.name != "piers" && o.class != Class::Background)
    {
        for &t in &o.triangles {
            let [a, b, c] = o.corners(t).map(|v| v.as_dvec3());
            volume += a.dot(b.cross(c)) / 6.0;
        }
    }
    let profile = s.layout.profile();
    let section: f32 = (0..profile.len())
        .map(|i| profile[i].perp_dot(profile[(i + 1) % profile.len()]))
        .sum::<f32>()
        / 2.0;
    // Plus the embrasures: each pane's area times how far it is set back.
    let panes: f32 = s
        .windows
        .iter()
        .flat_map(|w| {
            let o = s.window_object(w);
            o.triangles.iter().map(|&t| double_area(o.corners(t)) / 2.0)
        })
        .sum();
    let expected = (section * s.layout.length() + panes * s.layout.reveal) as f64;
    assert!(section > 0.0);
    assert!(
        (volume + expected).abs() < 1e-3 * expected,
        "volume {volume}, expected -{expected}"
    );
}

#[test]
fn windows_are_planar_with_affine_uvs_spanning_the_design() {
    let s = scene();
    assert_eq!(s.windows.len(), 2 * s.layout.bays + 1);
    for w in &s.windows {
        let o: &Object = s.window_object(w);
        assert!(o.class.is_window() && o.class == w.class);
        let p0 = o.vertices[0].position;
        let (mut lo, mut hi) = (Vec2::splat(f32::INFINITY), Vec2::splat(f32::NEG_INFINITY));
        for v in &o.vertices {
            assert!(
                (v.position - p0).dot(w.inward).abs() < 1e-5,
                "{} is not planar",
                w.material
            );
            assert!(
                (v.normal - w.inward).length() < 1e-6,
                "{}: normal {:?}",
                w.material,
                v.normal
            );
            assert!(
                v.uv.cmpge(Vec2::ZERO).all() && v.uv.cmple(Vec2::ONE).all(),
                "{}: uv {:?}",
                w.material,
                v.uv
            );
            lo = lo.min(v.uv);
            hi = hi.max(v.uv);
        }
        assert!(
            lo.abs_diff_eq(Vec2::ZERO, 1e-3) && hi.abs_diff_eq(Vec2::ONE, 1e-3),
            "{}: uv {lo}..{hi}",
            w.material
        );
        // A planar projection keeps the ratio of UV area to surface area the same everywhere.
        let ratios: Vec<f32> = o
            .triangles
            .iter()
            .map(|&t| {
                let uv = t.map(|i| o.vertices[i as usize].uv);
                (uv[1] - uv[0]).perp_dot(uv[2] - uv[0]).abs() / double_area(o.corners(t))
            })
            .collect();
        for r in &ratios {
            assert!(
                (r / ratios[0] - 1.0).abs() < 1e-3,
                "{}: UV mapping is not planar",
                w.material
            );
        }
        // u runs left to right as seen from inside: right = forward x up, forward = -inward.
        let right = (-w.inward).cross(Vec3::Y);
        let t = o.triangles[0];
        let [a, b, _] = t.map(|i| o.vertices[i as usize]);
        let du = b.uv.x - a.uv.x;
        let dx = (b.position - a.position).dot(right);
        assert!(du * dx >= 0.0, "{}: u runs right to left", w.material);
    }
}

#[test]
fn the_sun_shines_through_every_window_onto_the_floor_or_a_wall() {
    let s = scene();
    let lights = sun::trace(&s);
    sun::check(&lights).unwrap();
    assert_eq!(lights.len(), s.windows.len());
    let l = &s.layout;
    for li in &lights {
        assert!(
            li.incidence > 0.05 && li.samples > 0 && li.received == li.samples,
            "{li:?}"
        );
        let p = li.landing;
        assert!(
            p.x.abs() <= l.half_width + 1e-3
                && p.y >= -1e-3
                && p.z <= 1e-3
                && p.z >= -l.length() - 1e-3,
            "{}: light lands outside the corridor at {p}",
            li.material
        );
    }
    assert!(
        lights.iter().map(|l| l.on_floor).sum::<usize>() > 0,
        "no window lights the floor"
    );
    // The check itself must be able to fail: a sun from the shaded side lights nothing.
    let mut dark = s.clone();
    dark.layout.sun = Vec3::new(0.5, -0.7, 0.5).normalize();
    assert!(sun::check(&sun::trace(&dark)).is_err());
}

/// Enough of glob matching for the manifest's rules: `*`, `?` and `{a,b}`.
fn glob(pattern: &str, name: &str) -> bool {
    if let (Some(open), Some(close)) = (pattern.find('{'), pattern.find('}')) {
        let (head, tail) = (&pattern[..open], &pattern[close + 1..]);
        return pattern[open + 1..close]
            .split(',')
            .any(|alt| glob(&format!("{head}{alt}{tail}"), name));
    }
    fn rec(p: &[u8], n: &[u8]) -> bool {
        match (p.first(), n.first()) {
            (None, None) => true,
            (Some(b'*'), _) => rec(&p[1..], n) || (!n.is_empty() && rec(p, &n[1..])),
            (Some(b'?'), Some(_)) => rec(&p[1..], &n[1..]),
            (Some(a), Some(b)) if a == b => rec(&p[1..], &n[1..]),
            _ => false,
        }
    }
    rec(pattern.as_bytes(), name.as_bytes())
}

#[test]
fn the_manifest_tags_every_material_and_names_existing_files() {
    let out = generate(&Options::default()).unwrap();
    let text = std::str::from_utf8(file(&out.files, "scene.toml")).unwrap();
    let m: toml::Table = toml::from_str(text).unwrap();
    let obj = std::str::from_utf8(file(&out.files, "corridor.obj")).unwrap();
    let mtl = std::str::from_utf8(file(&out.files, "corridor.mtl")).unwrap();
    let used: Vec<&str> = obj
        .lines()
        .filter_map(|l| l.strip_prefix("usemtl "))
        .collect();
    let defined: Vec<&str> = mtl
        .lines()
        .filter_map(|l| l.strip_prefix("newmtl "))
        .collect();
    let rules = m["rule"].as_array().unwrap();
    let mut classes = HashMap::new();
    for name in &used {
        assert!(defined.contains(name), "{name} is used but not in the MTL");
        let rule = rules
            .iter()
            .find(|r| glob(r["match"].as_str().unwrap(), name))
            .unwrap_or_else(|| panic!("no rule tags {name}"));
        classes.insert(*name, rule["class"].as_str().unwrap().to_string());
    }
    for class in [
        "floor",
        "wall",
        "window-upper",
        "window-lower",
        "background",
    ] {
        assert!(
            classes.values().any(|c| c == class),
            "nothing is tagged {class}"
        );
    }
    for t in mtl.lines().filter_map(|l| l.strip_prefix("map_Kd ")) {
        file(&out.files, t);
    }
    let windows = m["window"].as_array().unwrap();
    assert_eq!(windows.len(), out.scene.windows.len());
    let mut designs = std::collections::BTreeSet::new();
    let mut normals = std::collections::BTreeSet::new();
    for w in windows {
        let material = w["material"].as_str().unwrap();
        assert!(classes[material].starts_with("window-"), "{material}");
        let design = w["design"].as_str().unwrap();
        let img = image::load_from_memory(file(&out.files, design)).unwrap();
        assert!(
            img.width().max(img.height()) >= 1024,
            "{design} is too small"
        );
        designs.insert(design);
        match w.get("normal_map") {
            Some(n) => {
                let n = n.as_str().unwrap();
                let img = image::load_from_memory(file(&out.files, n))
                    .unwrap()
                    .to_rgb8();
                // Tangent-space: +Z up everywhere, unit length after decoding.
                for p in img.pixels().step_by(97) {
                    let v = Vec3::from_array(p.0.map(|c| c as f32 / 127.5 - 1.0));
                    assert!(v.z > 0.5 && (v.length() - 1.0).abs() < 0.02, "{n}: {v}");
                }
                normals.insert(n);
            }
            None => {
                normals.insert("(derived)");
            }
        }
    }
    assert!(designs.len() >= 4, "{designs:?}");
    assert!(
        normals.len() >= 3,
        "need two normal maps and a window without one: {normals:?}"
    );
    let light = m["light"].as_table().unwrap();
    assert_eq!(light["type"].as_str(), Some("directional"));
    assert_eq!(light["angular_size_deg"].as_float(), Some(0.53));
    let cams: Vec<&str> = m["camera"]
        .as_array()
        .unwrap()
        .iter()
        .map(|c| c["name"].as_str().unwrap())
        .collect();
    for name in ["nave", "clerestory", "floor", "rose"] {
        assert!(cams.contains(&name), "no camera {name}");
    }
    let total: usize = out.files.iter().map(|f| f.bytes.len()).sum();
    assert!(total < 4 << 20, "assets-src would be {total} bytes");
}
