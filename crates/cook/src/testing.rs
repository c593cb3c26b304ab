//! Deterministic inputs for benchmarks and the bench tool: not part of the API.

/// A wavy `n` x `n` height field as OBJ text, vertices in row order and triangles in row order
/// (a plain scan order with a cache-unfriendly stride for large `n`).
pub fn height_field_obj(n: usize) -> String {
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
    for j in 0..n {
        for i in 0..n {
            let a = j * (n + 1) + i + 1;
            let (b, c, d) = (a + 1, a + n + 1, a + n + 2);
            let _ = writeln!(s, "f {a} {c} {b}\nf {b} {c} {d}");
        }
    }
    s
}
