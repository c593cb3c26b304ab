//! Deterministic inputs for benchmarks, the bench tool and tests: not part of the API.

/// A wavy `n` x `n` height field as OBJ text, vertices in row order and triangles in row order
/// (a plain scan order with a cache-unfriendly stride for large `n`).
pub fn height_field_obj(n: usize) -> String {
    height_field(n, false)
}

/// [`height_field_obj`] with a normal and texture coordinates at every vertex, each corner
/// naming all three (`f a/a/a …`).
pub fn height_field_obj_with_normals_and_uvs(n: usize) -> String {
    height_field(n, true)
}

/// OBJ text `source` with every vertex position scaled by `scale`: the same model in other
/// units.
pub fn scaled_obj(source: &str, scale: f64) -> String {
    source
        .lines()
        .map(|l| match l.strip_prefix("v ") {
            Some(v) => {
                let c: Vec<f64> = v
                    .split_whitespace()
                    .map(|x| x.parse().expect("a vertex line of numbers"))
                    .collect();
                format!("v {} {} {}\n", c[0] * scale, c[1] * scale, c[2] * scale)
            }
            None => format!("{l}\n"),
        })
        .collect()
}

fn height_field(n: usize, attributes: bool) -> String {
    use std::fmt::Write;
    let mut s = String::with_capacity(n * n * 60);
    s.push_str("o terrain\nusemtl ground\n");
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
            let y = 0.05 * (x * 37.0).sin() * (z * 23.0).cos();
            let _ = writeln!(s, "v {x:.6} {y:.6} {z:.6}");
        }
    }
    if attributes {
        for j in 0..=n {
            for i in 0..=n {
                let (x, z) = (i as f32 / n as f32, j as f32 / n as f32);
                let dx = 0.05 * 37.0 * (x * 37.0).cos() * (z * 23.0).cos();
                let dz = -0.05 * 23.0 * (x * 37.0).sin() * (z * 23.0).sin();
                let l = (dx * dx + 1.0 + dz * dz).sqrt();
                let _ = writeln!(s, "vn {:.6} {:.6} {:.6}", -dx / l, 1.0 / l, -dz / l);
            }
        }
        for j in 0..=n {
            for i in 0..=n {
                let _ = writeln!(
                    s,
                    "vt {:.6} {:.6}",
                    i as f32 / n as f32,
                    j as f32 / n as f32
                );
            }
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            if attributes {
                let _ = writeln!(s, "f {a}/{a}/{a} {c}/{c}/{c} {b}/{b}/{b}");
                let _ = writeln!(s, "f {b}/{b}/{b} {c}/{c}/{c} {d}/{d}/{d}");
            } else {
                let _ = writeln!(s, "f {a} {c} {b}\nf {b} {c} {d}");
            }
        }
    }
    s
}

/// A quad: material, corner, and the two edges from it.
type Quad = (&'static str, [f64; 3], [f64; 3], [f64; 3]);

/// The hall of [`hall_on_open_ground`] as quads.
fn hall_quads(half: f64) -> Vec<Quad> {
    let mut quads = vec![
        (
            "ground",
            [-half, 0., -half],
            [0., 0., 2. * half],
            [2. * half, 0., 0.],
        ),
        ("wall", [-5., 0., 3.], [10., 0., 0.], [0., 4., 0.]),
        ("wall", [-5., 0., -3.], [0., 4., 0.], [10., 0., 0.]),
        ("wall", [-5., 0., -3.], [0., 0., 6.], [0., 4., 0.]),
        ("wall", [5., 0., -3.], [0., 4., 0.], [0., 0., 6.]),
        ("glass", [-2., 1.5, 2.99], [4., 0., 0.], [0., 1.6, 0.]),
    ];
    for x in [-4.5, -1., 2.5] {
        quads.push(("glass", [x, 1.5, -2.99], [0., 1.5, 0.], [2., 0., 0.]));
    }
    quads
}

/// A quad's four corners, in order around it.
fn quad_corners(o: [f64; 3], a: [f64; 3], b: [f64; 3]) -> [[f64; 3]; 4] {
    let add = |p: [f64; 3], q: [f64; 3]| [p[0] + q[0], p[1] + q[1], p[2] + q[2]];
    [o, add(o, a), add(add(o, a), b), add(o, b)]
}

/// A hall standing on open ground, as OBJ text (naming `hall.mtl`) and that MTL: one quad of
/// `ground` reaching `half` each way from the origin; `wall`s at x = ±5 and z = ±3, 4 high;
/// glass (`Tf`, translucent) 1 cm inside them, the largest window alone on the north wall
/// (z = 3) and three smaller ones on the south wall, more glass in all.
pub fn hall_on_open_ground(half: f64) -> (String, String) {
    use std::fmt::Write;
    let mut obj = String::from("mtllib hall.mtl\n");
    for (q, (m, o, a, b)) in hall_quads(half).into_iter().enumerate() {
        let _ = writeln!(obj, "usemtl {m}");
        for c in quad_corners(o, a, b) {
            let _ = writeln!(obj, "v {} {} {}", c[0], c[1], c[2]);
        }
        let n = 4 * q + 1;
        let _ = writeln!(obj, "f {} {} {} {}", n, n + 1, n + 2, n + 3);
    }
    let mtl = "newmtl ground\nKd 0.5 0.5 0.5\n\nnewmtl wall\nKd 0.8 0.8 0.8\n\n\
               newmtl glass\nKd 0.2 0.4 0.8\nTf 0.2 0.4 0.8\nd 0.3\n";
    (obj, mtl.to_string())
}

/// The hall of [`hall_on_open_ground`] as a glTF (JSON, and the bytes of its `hall.bin`), as
/// a modelling tool writes one: a mesh of three primitives (ground, wall, glass blended) on
/// the scene's first node, and `extra` nodes after it (cameras, lights) with the file's
/// `KHR_lights_punctual` `lights`.
pub fn hall_gltf(
    half: f64,
    extra: Vec<serde_json::Value>,
    lights: Vec<serde_json::Value>,
) -> (serde_json::Value, Vec<u8>) {
    use serde_json::json;
    let quads = hall_quads(half);
    let mut bin = Vec::new();
    let (mut accessors, mut views, mut primitives) = (Vec::new(), Vec::new(), Vec::new());
    for (mi, m) in ["ground", "wall", "glass"].into_iter().enumerate() {
        let corners: Vec<[f64; 3]> = quads
            .iter()
            .filter(|q| q.0 == m)
            .flat_map(|&(_, o, a, b)| quad_corners(o, a, b))
            .collect();
        let mut lo = [f64::INFINITY; 3];
        let mut hi = [f64::NEG_INFINITY; 3];
        let offset = bin.len();
        for c in &corners {
            for k in 0..3 {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
                bin.extend_from_slice(&(c[k] as f32).to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bin.len() - offset}));
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126,
            "count": corners.len(), "type": "VEC3",
            "min": lo.map(|v| v as f32), "max": hi.map(|v| v as f32)}));
        let offset = bin.len();
        let indices: Vec<u16> = (0..corners.len() as u16 / 4)
            .flat_map(|q| [0, 1, 2, 0, 2, 3].map(|k| 4 * q + k))
            .collect();
        for i in &indices {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        views.push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bin.len() - offset}));
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5123,
            "count": indices.len(), "type": "SCALAR"}));
        // Four-byte alignment for the next float view.
        bin.resize(bin.len().next_multiple_of(4), 0);
        primitives.push(json!({"attributes": {"POSITION": accessors.len() - 2},
            "indices": accessors.len() - 1, "material": mi}));
    }
    let mut nodes = vec![json!({"name": "hall", "mesh": 0})];
    nodes.extend(extra);
    let mut gltf = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": [{"name": "hall", "primitives": primitives}],
        // Not metal: glTF's metallicFactor is 1 where a file leaves it out.
        "materials": [
            {"name": "ground", "pbrMetallicRoughness":
                {"baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0}},
            {"name": "wall", "pbrMetallicRoughness":
                {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0}},
            {"name": "glass", "alphaMode": "BLEND", "pbrMetallicRoughness":
                {"baseColorFactor": [0.2, 0.4, 0.8, 0.3], "metallicFactor": 0.0}}
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": "hall.bin", "byteLength": bin.len()}]
    });
    if !lights.is_empty() {
        gltf["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        gltf["extensions"] = json!({"KHR_lights_punctual": {"lights": lights}});
    }
    (gltf, bin)
}

/// OBJ text of quads, each an object in a material (`mtllib m.mtl`).
struct ObjQuads {
    obj: String,
    vertices: usize,
}

impl ObjQuads {
    fn new() -> Self {
        Self {
            obj: String::from("mtllib m.mtl\n"),
            vertices: 0,
        }
    }

    /// A quad of object `object` in `material`: its corner and the two edges from it.
    fn quad(&mut self, object: &str, material: &str, [o, a, b]: [[f64; 3]; 3]) {
        use std::fmt::Write;
        let _ = writeln!(self.obj, "o {object}\nusemtl {material}");
        for c in quad_corners(o, a, b) {
            let _ = writeln!(self.obj, "v {} {} {}", c[0], c[1], c[2]);
        }
        let n = self.vertices;
        let _ = writeln!(self.obj, "f {} {} {} {}", n + 1, n + 2, n + 3, n + 4);
        self.vertices += 4;
    }
}

/// A hall of generic names (Blender's `Plane.001`, `Material.001`), as OBJ text naming `m.mtl`
/// and that MTL: its floor laid as 60 tiles of 1 m², each its own object (`Plane.000` …
/// `Plane.059`), in `Material.001`, or with `colours` 2 every other one in `Material.003`, or
/// with more each tile in one of that many materials `Tile.000` … (a mosaic); walls
/// 4 high (object `Cube`) and a ceiling (`Cube.001`) in `Material.002`; a 1.5 m² rug (`Rug`,
/// `Material.004`) on the floor; and glass (`Plane.900`, `Material.005`, `Tf`) in the north
/// wall.
pub fn tiled_hall(colours: usize) -> (String, String) {
    let mut q = ObjQuads::new();
    for (k, (i, j)) in (0..10)
        .flat_map(|i| (0..6).map(move |j| (i, j)))
        .enumerate()
    {
        let material = match colours {
            2 if (i + j) % 2 == 1 => "Material.003".to_string(),
            0..=2 => "Material.001".to_string(),
            n => format!("Tile.{:03}", k * 7 % n),
        };
        let at = [i as f64 - 5.0, 0.0, j as f64 - 3.0];
        q.quad(
            &format!("Plane.{k:03}"),
            &material,
            [at, [0., 0., 1.], [1., 0., 0.]],
        );
    }
    let rest = [
        (
            "Cube",
            "Material.002",
            [[-5., 0., 3.], [10., 0., 0.], [0., 4., 0.]],
        ),
        (
            "Cube",
            "Material.002",
            [[-5., 0., -3.], [0., 4., 0.], [10., 0., 0.]],
        ),
        (
            "Cube",
            "Material.002",
            [[-5., 0., -3.], [0., 0., 6.], [0., 4., 0.]],
        ),
        (
            "Cube",
            "Material.002",
            [[5., 0., -3.], [0., 4., 0.], [0., 0., 6.]],
        ),
        (
            "Cube.001",
            "Material.002",
            [[-5., 4., -3.], [10., 0., 0.], [0., 0., 6.]],
        ),
        (
            "Rug",
            "Material.004",
            [[-1., 0.01, -1.], [0., 0., 1.], [1.5, 0., 0.]],
        ),
        (
            "Plane.900",
            "Material.005",
            [[-2., 1.5, 2.99], [4., 0., 0.], [0., 1.6, 0.]],
        ),
    ];
    for (object, material, at) in rest {
        q.quad(object, material, at);
    }
    let mut mtl = "newmtl Material.001\nKd 0.5 0.5 0.5\nnewmtl Material.002\nKd 0.8 0.8 0.8\n\
                   newmtl Material.003\nKd 0.2 0.2 0.2\nnewmtl Material.004\nKd 0.6 0.1 0.1\n\
                   newmtl Material.005\nKd 0.2 0.4 0.8\nTf 0.2 0.4 0.8\nd 0.3\n"
        .to_string();
    if colours > 2 {
        for t in 0..colours {
            let grey = 0.2 + 0.6 * t as f64 / colours as f64;
            mtl += &format!("newmtl Tile.{t:03}\nKd {grey:.3} {:.3} 0.4\n", 1.0 - grey);
        }
    }
    (q.obj, mtl)
}

/// A nave 60 x 20 and 20 high of generic names, as OBJ text naming `m.mtl` and that MTL: a
/// floor (`Plane`, `Material.001`); walls built a bay at a time, 32 panels of 5 x 20, each
/// its own object (`Cube.000` …), a roof (`Plane.roof`) and 24 square pillars of 1 x 1 x 20
/// (`Cylinder.000` …), all in `Material.002`; and glass (`Glass`, `Material.003`, `Tf`) in the
/// north wall. `painted`: each panel in a material of its own instead (`Paint.000` …).
pub fn nave_in_bays(painted: bool) -> (String, String) {
    let mut q = ObjQuads::new();
    let stone = "Material.002";
    q.quad(
        "Plane",
        "Material.001",
        [[-30., 0., -10.], [0., 0., 20.], [60., 0., 0.]],
    );
    let mut bays = Vec::new();
    for i in 0..12 {
        let x = -30.0 + 5.0 * i as f64;
        bays.push([[x, 0., 10.], [5., 0., 0.], [0., 20., 0.]]);
        bays.push([[x, 0., -10.], [0., 20., 0.], [5., 0., 0.]]);
    }
    for j in 0..4 {
        let z = -10.0 + 5.0 * j as f64;
        bays.push([[-30., 0., z], [0., 0., 5.], [0., 20., 0.]]);
        bays.push([[30., 0., z], [0., 20., 0.], [0., 0., 5.]]);
    }
    let bay_count = bays.len();
    for (k, bay) in bays.into_iter().enumerate() {
        let paint = format!("Paint.{k:03}");
        q.quad(
            &format!("Cube.{k:03}"),
            if painted { &paint } else { stone },
            bay,
        );
    }
    q.quad(
        "Plane.roof",
        stone,
        [[-30., 20., -10.], [60., 0., 0.], [0., 0., 20.]],
    );
    let up = [0., 20., 0.];
    for c in 0..24 {
        let (x, z) = (
            -27.5 + 5.0 * (c % 12) as f64,
            if c < 12 { -6.0 } else { 6.0 },
        );
        let name = format!("Cylinder.{c:03}");
        q.quad(&name, stone, [[x, 0., z], [1., 0., 0.], up]);
        q.quad(&name, stone, [[x, 0., z + 1.], up, [1., 0., 0.]]);
        q.quad(&name, stone, [[x, 0., z], up, [0., 0., 1.]]);
        q.quad(&name, stone, [[x + 1., 0., z], [0., 0., 1.], up]);
    }
    q.quad(
        "Glass",
        "Material.003",
        [[-2., 8., 9.99], [4., 0., 0.], [0., 6., 0.]],
    );
    let mut mtl = "newmtl Material.001\nKd 0.5 0.5 0.5\nnewmtl Material.002\nKd 0.8 0.8 0.8\n\
                   newmtl Material.003\nKd 0.2 0.4 0.8\nTf 0.2 0.4 0.8\nd 0.3\n"
        .to_string();
    if painted {
        for k in 0..bay_count {
            mtl += &format!("newmtl Paint.{k:03}\nKd 0.7 0.6 {:.3}\n", k as f64 / 40.0);
        }
    }
    (q.obj, mtl)
}

/// A nave 12 x 32 and 10 high, as OBJ text naming `m.mtl` and that MTL: floor, four walls and
/// a roof in stone, five equal windows of 3 x 4 (`Glass.0` … in `Glass`, `Tf`) 1 cm inside the
/// east wall, and five square pillars between them and the nave's middle. With `noise`, every
/// coordinate is moved by up to that much, the same way for the same seed: an export's
/// rounding.
pub fn nave_of_equal_windows(noise: Option<(f64, u64)>) -> (String, String) {
    let mut q = ObjQuads::new();
    let stone = "Stone";
    q.quad(
        "Floor",
        "Floor",
        [[-6., 0., -16.], [0., 0., 32.], [12., 0., 0.]],
    );
    let walls = [
        [[-6., 0., -16.], [0., 10., 0.], [0., 0., 32.]],
        [[6., 0., -16.], [0., 0., 32.], [0., 10., 0.]],
        [[-6., 0., -16.], [12., 0., 0.], [0., 10., 0.]],
        [[-6., 0., 16.], [0., 10., 0.], [12., 0., 0.]],
        [[-6., 10., -16.], [0., 0., 32.], [12., 0., 0.]],
    ];
    for (k, w) in walls.into_iter().enumerate() {
        q.quad(&format!("Wall.{k}"), stone, w);
    }
    for k in 0..5 {
        let z = -13.5 + 6.0 * k as f64;
        q.quad(
            &format!("Glass.{k}"),
            "Glass",
            [[5.99, 3., z], [0., 4., 0.], [0., 0., 3.]],
        );
        let (x, z, up) = (3.0, z + 1.0, [0., 10., 0.]);
        let name = format!("Pillar.{k}");
        q.quad(&name, stone, [[x, 0., z], [1., 0., 0.], up]);
        q.quad(&name, stone, [[x, 0., z + 1.], up, [1., 0., 0.]]);
        q.quad(&name, stone, [[x, 0., z], up, [0., 0., 1.]]);
        q.quad(&name, stone, [[x + 1., 0., z], [0., 0., 1.], up]);
    }
    let obj = match noise {
        None => q.obj,
        Some((amount, seed)) => {
            let mut rng = texture::testing::Rng(seed.max(1));
            q.obj
                .lines()
                .map(|l| match l.strip_prefix("v ") {
                    Some(v) => {
                        let c: Vec<f64> = v
                            .split_whitespace()
                            .map(|x| x.parse::<f64>().expect("a vertex line of numbers"))
                            .map(|x| {
                                let unit = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
                                x + amount * (2.0 * unit - 1.0)
                            })
                            .collect();
                        format!("v {} {} {}\n", c[0], c[1], c[2])
                    }
                    None => format!("{l}\n"),
                })
                .collect()
        }
    };
    let mtl = "newmtl Floor\nKd 0.5 0.5 0.5\nnewmtl Stone\nKd 0.8 0.8 0.8\n\
               newmtl Glass\nKd 0.2 0.4 0.8\nTf 0.2 0.4 0.8\nd 0.3\n"
        .to_string();
    (obj, mtl)
}
