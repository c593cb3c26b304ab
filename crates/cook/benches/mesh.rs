//! OBJ → pack, end to end (parse, tag, normals, dedupe, vertex cache and fetch optimization,
//! encode, atomic write), reported as triangles per second. Also the OBJ parser alone against
//! tobj's, since parsing was measured as the largest single cost.
//!
//! `cargo bench -p cook --bench mesh`; the ACMR of each cooked mesh is printed once per input.

use std::path::{Path, PathBuf};

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};

fn bunny() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/data/third_party/classic/stanford-bunny.obj")
}

fn cook_and_write(input: &Path, out: &Path, cache: cook::CacheMode) -> cook::CookOutput {
    let manifest = cook::Manifest::open(input).unwrap();
    let mut settings = cook::Settings::new(&manifest);
    settings.mesh.cache = cache;
    let cooked = cook::cook(&manifest, &settings).unwrap();
    cooked.write(out).unwrap();
    cooked
}

fn end_to_end(c: &mut Criterion) {
    let dir = tempfile::tempdir().unwrap();
    let big = dir.path().join("grid-1m.obj");
    std::fs::write(&big, cook::testing::height_field_obj(707)).unwrap();
    let inputs = [
        ("stanford bunny", bunny()),
        ("generated 1M-triangle grid", big),
    ];
    let out = dir.path().join("out.pack");

    let mut group = c.benchmark_group("obj to pack");
    for (name, path) in &inputs {
        for (mode, cache) in [
            ("full", cook::CacheMode::Full),
            ("fifo", cook::CacheMode::Fifo),
        ] {
            let cooked = cook_and_write(path, &out, cache);
            let s = &cooked.report.meshes[0].stats;
            eprintln!(
                "{name} ({mode}): {} triangles, acmr_in={:.3} acmr_out={:.3} overfetch={:.3}",
                s.triangles_out, s.acmr_in, s.acmr_out, s.overfetch
            );
            group.throughput(Throughput::Elements(s.triangles_in as u64));
            group.bench_with_input(
                BenchmarkId::new(format!("{name}, {mode} cache"), s.triangles_in),
                path,
                |b, p| b.iter(|| cook_and_write(p, &out, cache)),
            );
        }
    }
    group.finish();

    let mut group = c.benchmark_group("obj parse");
    let bytes = std::fs::read(bunny()).unwrap();
    group.throughput(Throughput::Bytes(bytes.len() as u64));
    group.bench_function("cook::import::obj (stanford bunny)", |b| {
        b.iter(|| cook::import::obj::parse(&bunny(), &bytes).unwrap())
    });
    // Like for like: the same bytes already in memory, and the same work as ours (triangulate,
    // keep one index per attribute instead of unifying them into single-index vertices, which
    // ours leaves to the mesh stage). No material library: the bunny names none.
    let options = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ignore_points: true,
        ignore_lines: true,
    };
    group.bench_function(
        "tobj load_obj_buf, triangulate, separate indices (stanford bunny)",
        |b| {
            b.iter(|| {
                tobj::load_obj_buf(&mut std::io::Cursor::new(&bytes), &options, |_| {
                    Err(tobj::LoadError::OpenFileFailed)
                })
                .unwrap()
            })
        },
    );
    group.finish();

    // The same bunny as a scanner writes it: binary little-endian PLY (float positions, uchar
    // counts, int indices) and ASCII PLY, parsed from memory.
    let mut group = c.benchmark_group("ply parse");
    let model = cook::import::obj::parse(&bunny(), &bytes).unwrap();
    for binary in [true, false] {
        let ply = bunny_ply(&model, binary);
        let name = if binary { "binary" } else { "ascii" };
        group.throughput(Throughput::Bytes(ply.len() as u64));
        group.bench_function(format!("cook::import::ply, {name} (stanford bunny)"), |b| {
            b.iter(|| cook::import::ply::parse(std::path::Path::new("bunny.ply"), &ply).unwrap())
        });
    }
    group.finish();

    // One face of 50,000 corners, as a CAD export's round cap or a traced outline: a star
    // (every other corner reflex) and a unit circle written to 6 decimals (half its corners
    // flat or reflex once rounded). See docs/performance.md, round of 2026-11-29.
    let mut group = c.benchmark_group("huge face");
    group.sample_size(10);
    let n = 50_000;
    let angle = |i: usize| i as f64 / n as f64 * std::f64::consts::TAU;
    let star: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let r = if i % 2 == 0 { 10.0 } else { 6.0 };
            [
                (r * angle(i).cos()) as f32,
                0.0,
                (r * angle(i).sin()) as f32,
            ]
        })
        .collect();
    let circle: Vec<[f32; 3]> = (0..n)
        .map(|i| {
            let round = |x: f64| ((x * 1e6).round() / 1e6) as f32;
            [round(angle(i).cos()), 0.0, round(angle(i).sin())]
        })
        .collect();
    for (name, face) in [("star", &star), ("circle", &circle)] {
        group.bench_function(format!("cook::triangulate, 50,000-corner {name}"), |b| {
            let mut out = Vec::with_capacity(n);
            b.iter(|| {
                out.clear();
                cook::triangulate::triangulate(face, &mut out);
                out.len()
            })
        });
    }
    group.finish();
}

fn bunny_ply(m: &cook::import::Imported, binary: bool) -> Vec<u8> {
    use std::io::Write as _;
    let tris = m.triangle_count();
    let mut out = format!(
        "ply\nformat {} 1.0\nelement vertex {}\nproperty float x\nproperty float y\n\
         property float z\nelement face {tris}\nproperty list uchar int vertex_indices\n\
         end_header\n",
        if binary {
            "binary_little_endian"
        } else {
            "ascii"
        },
        m.positions.len()
    )
    .into_bytes();
    for p in &m.positions {
        if binary {
            for c in p {
                out.extend_from_slice(&c.to_le_bytes());
            }
        } else {
            writeln!(out, "{} {} {}", p[0], p[1], p[2]).unwrap();
        }
    }
    for t in 0..tris {
        let c = [0, 1, 2].map(|k| m.corners.get(t * 3 + k).p);
        if binary {
            out.push(3);
            for i in c {
                out.extend_from_slice(&(i as i32).to_le_bytes());
            }
        } else {
            writeln!(out, "3 {} {} {}", c[0], c[1], c[2]).unwrap();
        }
    }
    out
}

criterion_group!(benches, end_to_end);
criterion_main!(benches);
