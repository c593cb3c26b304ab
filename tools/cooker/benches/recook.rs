//! Re-cooking while iterating on a scene, through the real `cooker` binary (process start,
//! manifest parse, input hashing, cache lookup, output check): the target is ≤ 50 ms
//! for an unchanged default scene. Also the cost of the other two incremental cases, so a
//! regression in any of them shows: the output deleted (the cached pack written back), and
//! one window design changed (only that design's colour, normal and projector textures
//! re-cooked, everything else reused).
//!
//! `cargo bench -p cooker --bench recook`

#[path = "../tests/common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::process::Command;

use criterion::{Criterion, criterion_group, criterion_main};

struct Scene {
    _dir: tempfile::TempDir,
    scene: PathBuf,
    out: PathBuf,
    cache: PathBuf,
}

impl Scene {
    fn new() -> Self {
        let dir = tempfile::tempdir().unwrap();
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../assets-src");
        common::copy_dir(&root, &dir.path().join("scene"));
        let s = Scene {
            scene: dir.path().join("scene/scene.toml"),
            out: dir.path().join("out.pack"),
            cache: dir.path().join("cache"),
            _dir: dir,
        };
        let first = s.cook();
        assert!(first.contains("wrote"), "{first}");
        s
    }

    fn cook(&self) -> String {
        let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
            .arg("cook")
            .arg(&self.scene)
            .arg("-o")
            .arg(&self.out)
            .arg("--cache-dir")
            .arg(&self.cache)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        String::from_utf8_lossy(&o.stdout).into_owned()
    }
}

fn recook(c: &mut Criterion) {
    let s = Scene::new();
    let mut g = c.benchmark_group("recook default scene");
    g.sample_size(20);
    g.bench_function("unchanged", |b| {
        b.iter(|| {
            let out = s.cook();
            debug_assert!(out.contains("is up to date"), "{out}");
        })
    });
    g.bench_function("output deleted", |b| {
        b.iter(|| {
            std::fs::remove_file(&s.out).unwrap();
            let out = s.cook();
            debug_assert!(out.contains("reused the cached pack"), "{out}");
        })
    });
    // Alternate between two versions of one design, so each cook sees a change; both
    // versions' textures end up cached, as when a user flips between two edits, which is
    // why this measures re-hashing and reuse plus the pack write rather than a cold cook.
    let design = s.scene.with_file_name("windows/rose.png");
    let original = std::fs::read(&design).unwrap();
    let mut edited = image::open(&design).unwrap().to_rgba8();
    edited.get_pixel_mut(0, 0).0[0] ^= 0x80;
    let mut other = Vec::new();
    edited
        .write_to(
            &mut std::io::Cursor::new(&mut other),
            image::ImageFormat::Png,
        )
        .unwrap();
    let mut flip = false;
    g.sample_size(10);
    g.bench_function("one design changed (both versions cached)", |b| {
        b.iter(|| {
            flip = !flip;
            std::fs::write(&design, if flip { &other } else { &original }).unwrap();
            let out = s.cook();
            debug_assert!(out.contains("wrote"), "{out}");
        })
    });
    g.finish();
}

criterion_group!(benches, recook);
criterion_main!(benches);
