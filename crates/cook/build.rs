//! Fingerprints the source that decides what a cook produces (this crate, `texture`, `pack`,
//! their manifests and the lock file), for the cache key: with only the package version in it,
//! a cooker rebuilt with changed code served packs cooked by the old code, from the local
//! cache and from a shared one alike. FNV-1a over sorted relative paths and contents: stable
//! across machines and toolchains, so machines running the same source share entries.

use std::path::{Path, PathBuf};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else {
            out.push(p);
        }
    }
}

fn main() {
    let here = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let crates = here.parent().expect("crates/cook lies in crates/");
    let root = crates.parent().expect("crates/ lies in the workspace");
    let mut paths = Vec::new();
    for name in ["cook", "texture", "pack"] {
        let dir = crates.join(name);
        files(&dir.join("src"), &mut paths);
        paths.push(dir.join("Cargo.toml"));
        println!("cargo:rerun-if-changed={}", dir.join("src").display());
        println!(
            "cargo:rerun-if-changed={}",
            dir.join("Cargo.toml").display()
        );
    }
    paths.push(root.join("Cargo.lock"));
    println!(
        "cargo:rerun-if-changed={}",
        root.join("Cargo.lock").display()
    );
    let mut named: Vec<(String, PathBuf)> = paths
        .into_iter()
        .map(|p| {
            let rel = p.strip_prefix(root).unwrap_or(&p).to_string_lossy();
            (rel.replace('\\', "/"), p)
        })
        .collect();
    named.sort();
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut eat = |bytes: &[u8]| {
        for &b in bytes {
            h ^= b as u64;
            h = h.wrapping_mul(0x0100_0000_01b3);
        }
    };
    for (rel, path) in &named {
        let body = std::fs::read(path).unwrap_or_default();
        eat(&(rel.len() as u64).to_le_bytes());
        eat(rel.as_bytes());
        eat(&(body.len() as u64).to_le_bytes());
        eat(&body);
    }
    println!("cargo:rustc-env=COOK_SOURCE_FINGERPRINT={h:016x}");
}
