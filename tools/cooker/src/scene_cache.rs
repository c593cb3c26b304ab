//! Whole-scene reuse: a second cook of an unchanged scene reads no image and runs no stage.
//!
//! Two entries per scene, as in a compiler cache's manifest mode:
//! - under `cook::cache::scene_key` (the manifest's name and bytes, the settings, the
//!   versions): the files the last cook read, relative to the manifest's folder;
//! - under the result key (the scene key plus each of those files with its SHA-256): the
//!   cooked pack's SHA-256, length and CRC, and the cook's [`Transcript`].
//!
//! The pack itself is a content-addressed blob. Every variant of a scene (a design changed and
//! back) keeps its own result, and two checkouts of one scene (on one machine or, through a
//! remote cache, on two) share them.

use std::path::{Path, PathBuf};

use cook::cache::{Cache, Key, KeyBuilder, Lookup, digest, hex, parse_hex32};
use serde::{Deserialize, Serialize};

use crate::transcript::Transcript;

#[derive(Serialize, Deserialize)]
struct SceneInputs {
    inputs: Vec<PathBuf>,
}

#[derive(Serialize, Deserialize)]
struct SceneResult {
    pack_sha256: String,
    pack_len: u64,
    pack_crc: u32,
    transcript: Transcript,
}

/// What a lookup found.
pub enum Reuse {
    /// The output already holds the cached pack byte for byte: nothing to write.
    UpToDate(Transcript),
    /// The cached pack, to be written to the output.
    Pack(Vec<u8>, Transcript),
    /// Cook it; the string says why (for `-v`).
    Cook(String),
}

/// The folder a manifest's relative paths start from.
fn scene_dir(manifest: &Path) -> &Path {
    manifest.parent().unwrap_or(Path::new(""))
}

/// `path` relative to the scene's folder where it lies within it (as the manifest names it),
/// else as it is.
fn relative(manifest: &Path, path: &Path) -> PathBuf {
    path.strip_prefix(scene_dir(manifest))
        .map(Path::to_path_buf)
        .unwrap_or_else(|_| path.to_path_buf())
}

/// The result key: the scene key and each input's path and content.
fn result_key(scene: &Key, manifest: &Path, inputs: &[PathBuf]) -> Result<Key, String> {
    let mut k = KeyBuilder::new("scene result");
    k.bytes("scene", &scene.0);
    for rel in inputs {
        let path = scene_dir(manifest).join(rel);
        let bytes =
            std::fs::read(&path).map_err(|_| format!("{} cannot be read", path.display()))?;
        k.bytes("input", rel.as_os_str().as_encoded_bytes())
            .bytes("sha256", &digest(&bytes));
    }
    Ok(k.finish())
}

pub fn lookup(cache: &Cache, key: &Key, manifest: &Path, output: &Path) -> Reuse {
    let inputs = match cache.get(key) {
        Lookup::Hit(b) => b,
        Lookup::Miss => return Reuse::Cook("not cooked before with these settings".into()),
        Lookup::Corrupt(why) => {
            return Reuse::Cook(format!("damaged cache entry, re-cooking: {why}"));
        }
    };
    let Ok(inputs) = serde_json::from_slice::<SceneInputs>(&inputs) else {
        return Reuse::Cook("unreadable scene entry".into());
    };
    let result_key = match result_key(key, manifest, &inputs.inputs) {
        Ok(k) => k,
        Err(why) => return Reuse::Cook(why),
    };
    let result = match cache.get(&result_key) {
        Lookup::Hit(b) => b,
        Lookup::Miss => {
            return Reuse::Cook("an input changed since the last cook with these settings".into());
        }
        Lookup::Corrupt(why) => {
            return Reuse::Cook(format!("damaged cache entry, re-cooking: {why}"));
        }
    };
    let Ok(result) = serde_json::from_slice::<SceneResult>(&result) else {
        return Reuse::Cook("unreadable scene entry".into());
    };
    let Some(pack_sha) = parse_hex32(&result.pack_sha256) else {
        return Reuse::Cook("unreadable scene entry".into());
    };
    let transcript = result.transcript.localized(manifest);
    if let Ok(existing) = std::fs::read(output)
        && existing.len() as u64 == result.pack_len
        && crc32fast::hash(&existing) == result.pack_crc
        && cache.has_local_blob(&pack_sha)
    {
        return Reuse::UpToDate(transcript);
    }
    match cache.get_blob(&pack_sha) {
        Lookup::Hit(pack)
            if pack.len() as u64 == result.pack_len
                && crc32fast::hash(&pack) == result.pack_crc =>
        {
            Reuse::Pack(pack, transcript)
        }
        Lookup::Hit(_) => Reuse::Cook("cached pack does not match its scene entry".into()),
        Lookup::Miss => Reuse::Cook("cached pack was evicted".into()),
        Lookup::Corrupt(why) => Reuse::Cook(format!("damaged cached pack, re-cooking: {why}")),
    }
}

/// Records a fresh cook: the files it read, and under their content the pack and what the
/// cook said. (A file edited while the cook was running is recorded with its new content;
/// re-cook after such an edit.)
pub fn store(
    cache: &Cache,
    key: &Key,
    manifest: &Path,
    inputs: &[PathBuf],
    pack: &[u8],
    transcript: &Transcript,
) -> Result<(), anyhow::Error> {
    let inputs: Vec<PathBuf> = inputs.iter().map(|p| relative(manifest, p)).collect();
    let result_key = result_key(key, manifest, &inputs).map_err(anyhow::Error::msg)?;
    let pack_sha = cache.put_blob(pack)?;
    let result = SceneResult {
        pack_sha256: hex(&pack_sha),
        pack_len: pack.len() as u64,
        pack_crc: crc32fast::hash(pack),
        transcript: transcript.portable(manifest),
    };
    // The result before the list that leads to it, so no reader follows a list to nothing.
    cache.put(
        &result_key,
        &serde_json::to_vec(&result).expect("entry serializes"),
    )?;
    cache.put(
        key,
        &serde_json::to_vec(&SceneInputs { inputs }).expect("entry serializes"),
    )?;
    Ok(())
}
