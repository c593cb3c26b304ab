//! Fingerprints the source that decides what a cook produces (this crate, `texture`, `pack`,
//! their manifests, the workspace's and the lock file), for the cache key: with only the
//! package version in it, a cooker rebuilt with changed code served packs cooked by the old
//! code, from the local cache and from a shared one alike. FNV-1a over sorted relative paths
//! and contents: stable across machines and toolchains, so machines running the same source
//! share entries.

use std::path::{Path, PathBuf};

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let source = matches!(
            p.extension().and_then(|e| e.to_str()),
            Some("rs" | "json" | "toml")
        );
        if p.is_dir() {
            files(&p, out);
        } else if source {
            // Only sources: an editor's swap or backup file must not change the key.
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
    // The lock file pins the dependencies; the workspace manifest picks their features
    // (which image decoders exist, say).
    for f in ["Cargo.lock", "Cargo.toml"] {
        paths.push(root.join(f));
        println!("cargo:rerun-if-changed={}", root.join(f).display());
    }
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
        // Line ends as git stores them, so a Windows checkout keys alike.
        let mut body = std::fs::read(path).unwrap_or_default();
        body.retain(|&b| b != b'\r');
        eat(&(rel.len() as u64).to_le_bytes());
        eat(rel.as_bytes());
        eat(&(body.len() as u64).to_le_bytes());
        eat(&body);
    }
    println!("cargo:rustc-env=COOK_SOURCE_FINGERPRINT={h:016x}");
}
