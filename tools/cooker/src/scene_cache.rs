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

use anyhow::Context;
use cook::cache::{Cache, Key, KeyBuilder, Lookup, digest, digest_file, hex, parse_hex32};
use cook::import::Absent;
use serde::{Deserialize, Serialize};

use crate::transcript::Transcript;

/// What the last cook of a scene depended on.
#[derive(Serialize, Deserialize)]
pub struct SceneInputs {
    /// The files it read, relative to the manifest's folder.
    #[serde(with = "cook::path_serde::list")]
    pub inputs: Vec<PathBuf>,
    /// The files its sources named that it did not find (a texture an MTL names, a
    /// material library), or found under another spelling (another letter case): the pack is
    /// only right while the lookups answer the same. Each `dir` is relative to the manifest's
    /// folder, where it lies within it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub absent: Vec<Absent>,
}

/// The first file the import would now find otherwise than the last cook did (one it did
/// not find is there, one it found under another spelling is there under its own), said as
/// a sentence without its full stop.
pub fn lookup_changed(manifest: &Path, absent: &[Absent]) -> Option<String> {
    absent
        .iter()
        .find_map(|a| a.under(&scene_dir(manifest).join(&a.dir)).changed())
}

#[derive(Serialize, Deserialize)]
struct SceneResult {
    pack_sha256: String,
    pack_len: u64,
    pack_crc: u32,
    transcript: Transcript,
}

/// The pack a scene result entry names: its SHA-256, and the length and CRC-32 that tie a
/// local copy to this result.
pub struct CachedPack {
    pub sha: [u8; 32],
    len: u64,
    crc: u32,
}

impl CachedPack {
    fn of(result: &SceneResult) -> Option<Self> {
        Some(Self {
            sha: parse_hex32(&result.pack_sha256)?,
            len: result.pack_len,
            crc: result.pack_crc,
        })
    }

    /// Whether `bytes` are this pack.
    pub fn holds(&self, bytes: &[u8]) -> bool {
        bytes.len() as u64 == self.len && crc32fast::hash(bytes) == self.crc
    }
}

/// The pack a scene result entry names, for `cooker cache explain`: the entry can outlive its
/// pack (`cache verify` removes a damaged blob, trimming may take it).
pub fn pack_of(cache: &Cache, result: &Key) -> Result<CachedPack, String> {
    let bytes = match cache.get(result) {
        Lookup::Hit(b) => b,
        Lookup::Miss => return Err("its scene entry is gone".into()),
        Lookup::Corrupt(why) => return Err(format!("damaged cache entry: {why}")),
    };
    serde_json::from_slice::<SceneResult>(&bytes)
        .ok()
        .and_then(|r| CachedPack::of(&r))
        .ok_or_else(|| "unreadable scene entry".to_string())
}

/// What a lookup found.
pub enum Reuse {
    /// The output already holds the cached pack byte for byte: nothing to write.
    UpToDate(Transcript),
    /// The cached pack, to be written to the output; with its SHA-256 when it came from the
    /// remote and is yet to be kept in the local cache.
    Pack(Vec<u8>, Transcript, Option<[u8; 32]>),
    /// Cook it; the string says why (for `-v`).
    Cook(String),
    /// Cook it: what the cache held was damaged, which is said without `-v` too, as a damaged
    /// texture entry is.
    Damaged(String),
}

/// The folder a manifest's relative paths start from.
fn scene_dir(manifest: &Path) -> &Path {
    manifest.parent().unwrap_or(Path::new(""))
}

/// `path` relative to the scene's folder where it lies within it (as the manifest names it),
/// else absolute. A path outside it is named from the working directory (a `--window` image):
/// kept relative, it was later read against the scene's folder, so a bare cook of
/// `t1/nave.obj --window W=design/x.png` hashed `t1/design/x.png` and reused a stale pack when
/// the design changed.
fn relative(manifest: &Path, path: &Path) -> PathBuf {
    match path.strip_prefix(scene_dir(manifest)) {
        Ok(rel) => rel.to_path_buf(),
        Err(_) => std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf()),
    }
}

/// `settings` as the scene's key and the record of its cook hold them: a `--window` image
/// named as from the manifest's folder where it lies inside it. As typed, `A/mine.png` from
/// one folder and `mine.png` from another, or a second checkout's `B/mine.png`, were other
/// settings, and the scene was never reused across them (the file's content is among the
/// inputs of the result either way).
pub fn keyed(manifest: &Path, settings: &cook::Settings) -> cook::Settings {
    let mut s = settings.clone();
    let dir = match scene_dir(manifest) {
        d if d.as_os_str().is_empty() => std::path::absolute("."),
        d => std::path::absolute(d),
    }
    .ok();
    for o in &mut s.window_overrides {
        for p in [&mut o.design, &mut o.normal_map].into_iter().flatten() {
            if let (Some(dir), Ok(abs)) = (&dir, std::path::absolute(&*p))
                && let Ok(rel) = abs.strip_prefix(dir)
            {
                *p = rel.to_path_buf();
            }
        }
    }
    s
}

/// Each input with the SHA-256 of its content now.
pub fn hash_inputs(
    manifest: &Path,
    inputs: &[PathBuf],
) -> Result<Vec<(PathBuf, [u8; 32])>, String> {
    inputs
        .iter()
        .map(|rel| {
            let path = scene_dir(manifest).join(rel);
            let sha =
                digest_file(&path).map_err(|_| format!("{} cannot be read", path.display()))?;
            Ok((rel.clone(), sha))
        })
        .collect()
}

/// The result key: the scene key and each input's path and content.
pub fn result_key(scene: &Key, hashed: &[(PathBuf, [u8; 32])]) -> Key {
    let mut k = KeyBuilder::new("scene result");
    k.bytes("scene", &scene.0);
    for (rel, sha) in hashed {
        k.bytes("input", rel.as_os_str().as_encoded_bytes())
            .bytes("sha256", sha);
    }
    k.finish()
}

/// The inputs the last cook of a scene key read, relative to the manifest's folder: from the
/// local cache, else the remote.
pub fn inputs_of(cache: &Cache, key: &Key) -> Result<SceneInputs, String> {
    match cache.get(key) {
        Lookup::Hit(b) => {
            serde_json::from_slice::<SceneInputs>(&b).map_err(|_| "unreadable scene entry".into())
        }
        Lookup::Miss => Err("not cooked before with these settings".into()),
        Lookup::Corrupt(why) => Err(format!("damaged cache entry, re-cooking: {why}")),
    }
}

/// What the last cook of a scene on this machine was made from, for `cooker cache explain`.
#[derive(Clone, Serialize, Deserialize)]
pub struct Record {
    pub manifest_sha256: String,
    pub settings: serde_json::Value,
    #[serde(with = "cook::path_serde::with_text")]
    pub inputs: Vec<(PathBuf, String)>,
    /// The cooks before it of other manifests or settings, latest first
    /// ([`Record::EARLIER`] at most): after an edit that was reverted, explain compares with
    /// the cook of the manifest as it is now, not with the edited one (which named a file the
    /// manifest no longer does, "cannot be read").
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub earlier: Vec<Record>,
}

impl Record {
    const EARLIER: usize = 7;

    fn same_cook(&self, other: &Record) -> bool {
        self.manifest_sha256 == other.manifest_sha256 && self.settings == other.settings
    }

    /// The latest cook of this manifest and these settings: this one or an earlier one.
    pub fn of(&self, manifest_sha256: &str, settings: &serde_json::Value) -> Option<&Record> {
        std::iter::once(self)
            .chain(&self.earlier)
            .find(|r| r.manifest_sha256 == manifest_sha256 && r.settings == *settings)
    }
}

/// Where the record of the scene at `manifest` is kept (by its canonical path: the record is
/// about this checkout).
pub fn record_path(cache: &Cache, manifest: &Path) -> PathBuf {
    let canonical = std::fs::canonicalize(manifest).unwrap_or_else(|_| manifest.to_path_buf());
    let name = hex(&digest(canonical.as_os_str().as_encoded_bytes()));
    cache.dir().join("scenes").join(format!("{name}.json"))
}

fn write_record(
    cache: &Cache,
    manifest: &Path,
    settings: &cook::Settings,
    hashed: &[(PathBuf, [u8; 32])],
) -> Result<(), anyhow::Error> {
    // The manifest is one of the inputs: its hash is not taken twice.
    let own = relative(manifest, manifest);
    let manifest_sha = match hashed.iter().find(|(rel, _)| *rel == own) {
        Some((_, sha)) => *sha,
        None => digest_file(manifest)?,
    };
    let mut record = Record {
        manifest_sha256: hex(&manifest_sha),
        settings: serde_json::to_value(keyed(manifest, settings))?,
        inputs: hashed.iter().map(|(p, h)| (p.clone(), hex(h))).collect(),
        earlier: Vec::new(),
    };
    let path = record_path(cache, manifest);
    if let Some(mut last) = std::fs::read(&path)
        .ok()
        .and_then(|b| serde_json::from_slice::<Record>(&b).ok())
    {
        let before = std::mem::take(&mut last.earlier);
        record.earlier = std::iter::once(last)
            .chain(before)
            .filter(|r| !r.same_cook(&record))
            .take(Record::EARLIER)
            .collect();
    }
    let folder = path.parent().expect("in the scenes folder");
    std::fs::create_dir_all(folder).with_context(|| folder.display().to_string())?;
    pack::write_atomic(&path, &serde_json::to_vec_pretty(&record)?)
        .with_context(|| path.display().to_string())?;
    Ok(())
}

pub fn lookup(
    cache: &Cache,
    key: &Key,
    manifest: &Path,
    settings: &cook::Settings,
    output: &Path,
) -> Reuse {
    let SceneInputs { inputs, absent } = match inputs_of(cache, key) {
        Ok(i) => i,
        Err(why) => return Reuse::Cook(why),
    };
    if let Some(why) = lookup_changed(manifest, &absent) {
        return Reuse::Cook(why);
    }
    let hashed = match hash_inputs(manifest, &inputs) {
        Ok(h) => h,
        Err(why) => return Reuse::Cook(why),
    };
    // The cook refuses such an output; the cached pack must not slip past that.
    if let Some(rel) = inputs
        .iter()
        .find(|rel| crate::cook::same_file(output, &scene_dir(manifest).join(rel)))
    {
        return Reuse::Cook(format!("the output is the input {}", rel.display()));
    }
    let result_key = result_key(key, &hashed);
    let result = match cache.get_published(&result_key) {
        // A writer's remote that lacked this scene lacks its steps too (textures another
        // design shares): the cook runs, from the local cache, so that each is shared.
        (Lookup::Hit(_), true) => {
            return Reuse::Cook(
                "the remote cache lacks this scene: cooking from the local cache to share \
                 its steps"
                    .into(),
            );
        }
        (Lookup::Hit(b), false) => b,
        (Lookup::Miss, _) => {
            return Reuse::Cook("an input changed since the last cook with these settings".into());
        }
        (Lookup::Corrupt(why), _) => {
            return Reuse::Damaged(format!("damaged cache entry, re-cooking: {why}"));
        }
    };
    let Ok(result) = serde_json::from_slice::<SceneResult>(&result) else {
        return Reuse::Cook("unreadable scene entry".into());
    };
    let Some(pack) = CachedPack::of(&result) else {
        return Reuse::Cook("unreadable scene entry".into());
    };
    let transcript = result.transcript.localized(manifest);
    // What this checkout's pack is made of, for `cooker cache explain`, however it was had.
    let _ = write_record(cache, manifest, settings, &hashed);
    // Only a regular file of the pack's length can hold it: read unbounded, `-o /dev/zero`
    // (or /dev/full, or a FIFO) filled memory until the cook was killed.
    let same_length =
        std::fs::metadata(output).is_ok_and(|m| m.is_file() && m.len() == result.pack_len);
    if same_length
        && let Ok(existing) = std::fs::read(output)
        && pack.holds(&existing)
        && cache.has_local_blob(&pack.sha)
    {
        return Reuse::UpToDate(transcript);
    }
    let (found, from_remote) = cache.fetch_blob(&pack.sha);
    match found {
        // A remote blob has just been checked against this very SHA-256 (its length is
        // checked still); a local one by its entry's CRC, which is what ties it to this result.
        Lookup::Hit(bytes)
            if (from_remote && bytes.len() as u64 == result.pack_len) || pack.holds(&bytes) =>
        {
            Reuse::Pack(bytes, transcript, from_remote.then_some(pack.sha))
        }
        Lookup::Hit(_) => Reuse::Cook("cached pack does not match its scene entry".into()),
        Lookup::Miss => Reuse::Cook("cached pack was evicted".into()),
        Lookup::Corrupt(why) => Reuse::Damaged(format!("damaged cached pack, re-cooking: {why}")),
    }
}

/// Records a fresh cook: the files it read, and under their content the pack and what the
/// cook said. (A file edited while the cook was running is recorded with its new content;
/// re-cook after such an edit.)
pub struct Cooked<'a> {
    pub key: &'a Key,
    pub manifest: &'a Path,
    pub settings: &'a cook::Settings,
    pub inputs: &'a [PathBuf],
    pub absent: &'a [Absent],
    pub pack: &'a [u8],
    pub transcript: &'a Transcript,
}

pub fn store(cache: &Cache, c: Cooked) -> Result<(), anyhow::Error> {
    let Cooked {
        key,
        manifest,
        settings,
        inputs,
        absent,
        pack,
        transcript,
    } = c;
    let inputs: Vec<PathBuf> = inputs.iter().map(|p| relative(manifest, p)).collect();
    let mut absent: Vec<Absent> = absent
        .iter()
        .map(|a| a.under(&relative(manifest, &a.dir)))
        .collect();
    // A name two materials give is looked up twice.
    absent.sort();
    absent.dedup();
    let hashed = hash_inputs(manifest, &inputs).map_err(anyhow::Error::msg)?;
    let result_key = result_key(key, &hashed);
    write_record(cache, manifest, settings, &hashed)?;
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
        &serde_json::to_vec(&SceneInputs { inputs, absent }).expect("entry serializes"),
    )?;
    Ok(())
}
