//! Whole-scene reuse: a second cook of an unchanged scene reads no image and runs no stage.
//!
//! A scene entry is keyed by `cook::cache::scene_key` (the manifest's bytes and path, the
//! settings and the versions); it records every file the cook read with its SHA-256, and the
//! pack's length and CRC. On the next cook, if every recorded file still hashes the same, the
//! pack is taken from the cache (or, when the output already holds exactly that pack, left
//! alone).

use std::path::{Path, PathBuf};

use cook::cache::{Cache, Key, KeyBuilder, Lookup, digest};
use serde::{Deserialize, Serialize};

#[derive(Serialize, Deserialize)]
struct SceneEntry {
    inputs: Vec<(PathBuf, String)>,
    pack_key: String,
    pack_len: u64,
    pack_crc: u32,
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// What a lookup found.
pub enum Reuse {
    /// The output already holds the cached pack byte for byte: nothing to write.
    UpToDate,
    /// The cached pack, to be written to the output.
    Pack(Vec<u8>),
    /// Cook it; the string says why (for `-v`).
    Cook(String),
}

pub fn lookup(cache: &Cache, key: &Key, output: &Path) -> Reuse {
    let entry = match cache.get(key) {
        Lookup::Hit(b) => b,
        Lookup::Miss => return Reuse::Cook("not cooked before with these settings".into()),
        Lookup::Corrupt(why) => {
            return Reuse::Cook(format!("damaged cache entry, re-cooking: {why}"));
        }
    };
    let Ok(entry) = serde_json::from_slice::<SceneEntry>(&entry) else {
        return Reuse::Cook("unreadable scene entry".into());
    };
    for (path, hash) in &entry.inputs {
        match std::fs::read(path) {
            Ok(bytes) if hex(&digest(&bytes)) == *hash => {}
            Ok(_) => return Reuse::Cook(format!("{} changed", path.display())),
            Err(_) => return Reuse::Cook(format!("{} cannot be read", path.display())),
        }
    }
    if let Ok(existing) = std::fs::read(output)
        && existing.len() as u64 == entry.pack_len
        && crc32fast::hash(&existing) == entry.pack_crc
    {
        return Reuse::UpToDate;
    }
    let pack_key = (0..32)
        .map(|i| u8::from_str_radix(entry.pack_key.get(2 * i..2 * i + 2).unwrap_or("zz"), 16));
    let Ok(bytes) = pack_key.collect::<Result<Vec<u8>, _>>() else {
        return Reuse::Cook("unreadable scene entry".into());
    };
    let pack_key = Key(bytes.try_into().expect("32 bytes"));
    match cache.get(&pack_key) {
        Lookup::Hit(pack)
            if pack.len() as u64 == entry.pack_len && crc32fast::hash(&pack) == entry.pack_crc =>
        {
            Reuse::Pack(pack)
        }
        Lookup::Hit(_) => Reuse::Cook("cached pack does not match its scene entry".into()),
        Lookup::Miss => Reuse::Cook("cached pack was evicted".into()),
        Lookup::Corrupt(why) => Reuse::Cook(format!("damaged cached pack, re-cooking: {why}")),
    }
}

/// Records a fresh cook with the hashes of the files it read. (A file edited while the cook
/// was running is recorded with its new content; re-cook after such an edit.)
pub fn store(
    cache: &Cache,
    key: &Key,
    inputs: &[PathBuf],
    pack: &[u8],
) -> Result<(), cook::CookError> {
    let mut hashed = Vec::with_capacity(inputs.len());
    for p in inputs {
        let bytes = std::fs::read(p).map_err(|source| cook::CookError::Io {
            path: p.clone(),
            source,
        })?;
        hashed.push((p.clone(), hex(&digest(&bytes))));
    }
    let pack_key = KeyBuilder::new("pack").bytes("pack", pack).finish();
    cache.put(&pack_key, pack)?;
    let entry = SceneEntry {
        inputs: hashed,
        pack_key: pack_key.hex(),
        pack_len: pack.len() as u64,
        pack_crc: crc32fast::hash(pack),
    };
    cache.put(key, &serde_json::to_vec(&entry).expect("entry serializes"))
}
