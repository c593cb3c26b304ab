//! Regression tests on cooked output of the default scene: byte-identical packs whatever the
//! thread count (block compression included), and a golden description (`info --json` with
//! per-section checksums) of the RGBA8 cook that an intended change re-blesses with `BLESS=1`.
//!
//! The golden is of `--texture-format rgba8`: every byte of it is the cooker's own arithmetic.
//! Block-compressed bytes come from the ISPC kernels the CPU selects at run time (SSE4, AVX2,
//! AVX-512), which need not agree bit for bit between machines; the default cook is pinned by
//! its determinism across thread counts, its texture formats and its size instead.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn cook(out: &Path, threads: &str, extra: &[&str]) {
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("cook")
        .arg(root().join("assets-src/scene.toml"))
        .arg("-o")
        .arg(out)
        .arg("--no-cache")
        .args(extra)
        .env("RAYON_NUM_THREADS", threads)
        .output()
        .unwrap();
    assert!(
        o.status.success(),
        "cook with {threads} threads failed: {}{}",
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr)
    );
}

fn info_json(pack: &Path) -> serde_json::Value {
    let o = Command::new(env!("CARGO_BIN_EXE_cooker"))
        .arg("info")
        .arg("--json")
        .arg(pack)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let mut v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    // The description is about content, not about where the pack was written.
    v.as_object_mut().unwrap().remove("path");
    v
}

/// One test, so the default scene is cooked three times in all rather than once per test.
#[test]
fn default_scene_is_deterministic_and_matches_golden() {
    let dir = tempfile::tempdir().unwrap();
    let packs: Vec<PathBuf> = ["1", "2", "8"]
        .iter()
        .map(|t| {
            let p = dir.path().join(format!("scene-{t}.pack"));
            cook(&p, t, &[]);
            p
        })
        .collect();
    let first = std::fs::read(&packs[0]).unwrap();
    for p in &packs[1..] {
        assert!(
            std::fs::read(p).unwrap() == first,
            "{} differs from the single-threaded cook: run `cooker diff {} {}`",
            p.display(),
            packs[0].display(),
            p.display()
        );
    }

    // The default cook compresses: BC7 stone and sky, BC5 normal maps, RGBA8 where no setting
    // fits the budget (the window designs, whose budget is 1 LSB, and the projectors), every
    // texture zstd-supercompressed; the whole pack within the 12 MB.
    let auto = info_json(&packs[0]);
    let formats: std::collections::BTreeMap<&str, String> = auto["textures"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            (
                t["name"].as_str().unwrap(),
                format!(
                    "{}+{}",
                    t["format"].as_str().unwrap(),
                    t["supercompression"].as_str().unwrap()
                ),
            )
        })
        .collect();
    for (names, want) in [
        (&["floor", "wall", "sky"][..], "bc7+zstd"),
        (
            &[
                "hammered.normal",
                "reeded.normal",
                "mosaic.masked.derived-normal",
            ],
            "bc5+zstd",
        ),
        (
            &[
                "lancet.masked",
                "border.masked",
                "mosaic.masked",
                "rose.masked",
                "rose.masked.projector",
            ],
            "rgba8+zstd",
        ),
    ] {
        for name in names {
            assert_eq!(
                formats.get(name).map(String::as_str),
                Some(want),
                "{name}: {formats:?}"
            );
        }
    }
    let size = auto["file_length"].as_u64().unwrap();
    assert!(size <= 12_000_000, "default pack is {size} bytes");

    let rgba8 = dir.path().join("scene-rgba8.pack");
    cook(&rgba8, "2", &["--texture-format", "rgba8"]);
    let golden_path = root().join("tests/data/golden/default-scene.info.json");
    let actual = info_json(&rgba8);
    if std::env::var_os("BLESS").is_some() {
        std::fs::write(
            &golden_path,
            serde_json::to_string_pretty(&actual).unwrap() + "\n",
        )
        .unwrap();
    }
    let golden: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&golden_path).unwrap_or_else(|e| {
            panic!(
                "{}: {e}; run with BLESS=1 to create it",
                golden_path.display()
            )
        }))
        .unwrap();
    if golden != actual {
        let kept = root().join("target/default-scene-actual.pack");
        let _ = std::fs::copy(&rgba8, &kept);
        let actual_path = golden_path.with_extension("actual.json");
        let _ = std::fs::write(&actual_path, serde_json::to_string_pretty(&actual).unwrap());
        let by_holds = |v: &serde_json::Value| -> std::collections::BTreeMap<String, String> {
            v["sections"]
                .as_array()
                .into_iter()
                .flatten()
                .map(|s| {
                    (
                        s["holds"].as_str().unwrap_or("").to_string(),
                        s["crc32"].as_str().unwrap_or("").to_string(),
                    )
                })
                .collect()
        };
        let (g, a) = (by_holds(&golden), by_holds(&actual));
        let changed: Vec<_> = g
            .keys()
            .chain(a.keys())
            .filter(|k| g.get(*k) != a.get(*k))
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        panic!(
            "cooked default scene no longer matches {}.\nSections that changed: {changed:?}\n\
             The new description is in {}, the new pack in {}; compare it with a pack cooked \
             before the change using `cooker diff <old.pack> {}`. If the change is intended, \
             re-bless with BLESS=1.",
            golden_path.display(),
            actual_path.display(),
            kept.display(),
            kept.display()
        );
    }
}
