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

/// A hall standing on open ground, as OBJ text (naming `hall.mtl`) and that MTL: one quad of
/// `ground` reaching `half` each way from the origin; `wall`s at x = ±5 and z = ±3, 4 high;
/// glass (`Tf`, translucent) 1 cm inside them, the largest window alone on the north wall
/// (z = 3) and three smaller ones on the south wall, more glass in all.
pub fn hall_on_open_ground(half: f64) -> (String, String) {
    use std::fmt::Write;
    let mut obj = String::from("mtllib hall.mtl\n");
    let mut vertices = 0;
    let mut quad = |m: &str, o: [f64; 3], a: [f64; 3], b: [f64; 3]| {
        let add = |p: [f64; 3], q: [f64; 3]| [p[0] + q[0], p[1] + q[1], p[2] + q[2]];
        let _ = writeln!(obj, "usemtl {m}");
        for c in [o, add(o, a), add(add(o, a), b), add(o, b)] {
            let _ = writeln!(obj, "v {} {} {}", c[0], c[1], c[2]);
        }
        let n = vertices + 1;
        vertices += 4;
        let _ = writeln!(obj, "f {} {} {} {}", n, n + 1, n + 2, n + 3);
    };
    quad(
        "ground",
        [-half, 0., -half],
        [0., 0., 2. * half],
        [2. * half, 0., 0.],
    );
    quad("wall", [-5., 0., 3.], [10., 0., 0.], [0., 4., 0.]);
    quad("wall", [-5., 0., -3.], [0., 4., 0.], [10., 0., 0.]);
    quad("wall", [-5., 0., -3.], [0., 0., 6.], [0., 4., 0.]);
    quad("wall", [5., 0., -3.], [0., 4., 0.], [0., 0., 6.]);
    quad("glass", [-2., 1.5, 2.99], [4., 0., 0.], [0., 1.6, 0.]);
    for x in [-4.5, -1., 2.5] {
        quad("glass", [x, 1.5, -2.99], [0., 1.5, 0.], [2., 0., 0.]);
    }
    let mtl = "newmtl ground\nKd 0.5 0.5 0.5\n\nnewmtl wall\nKd 0.8 0.8 0.8\n\n\
               newmtl glass\nKd 0.2 0.4 0.8\nTf 0.2 0.4 0.8\nd 0.3\n";
    (obj, mtl.to_string())
}
