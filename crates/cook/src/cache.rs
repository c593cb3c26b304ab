//! The incremental cook cache: a content-addressed store of cooked artifacts.
//!
//! A key is a SHA-256 over everything that can change an artifact: the bytes of every input
//! file, the settings, the cooker's version and source (a fingerprint `build.rs` takes of the
//! code that decides a cook's output) and the pack format version. Settings enter every
//! key in one way, serialized whole (bincode, a canonical encoding): the scene's key takes all
//! of [`Settings`], a texture's its [`TextureSettings`], so no key lists settings one by one
//! and none can miss a new one. The thread count is deliberately not part of any key: cooking
//! is deterministic, so it never changes the output. Changing what goes into a key, or how, is
//! a breaking change: bump `CACHE_VERSION`.
//!
//! Entries are files `<dir>/<key hex>.entry`: magic, payload length, CRC-32 of the payload,
//! payload. (The payload check guards against damage, not an adversary: CRC-32 catches every
//! single-bit flip and burst, and runs at memory speed, where SHA-256 over a pack of tens of
//! megabytes would dominate a cache hit.) A damaged entry (truncated, flipped bits, wrong magic) is reported as corrupt and
//! re-cooked, never used. Entries are written to a temp file and renamed into place, so two
//! cooks sharing a cache only ever see complete entries (both write identical bytes for a key).

use std::path::{Path, PathBuf};
use std::sync::Arc;

use serde::Serialize;
use sha2::{Digest, Sha256};

use crate::{CookError, Settings, TextureSettings};

const MAGIC: &[u8; 8] = b"SGCACHE\x01";
/// Bump when the meaning of keys or payloads changes. 3: block-compressed chains of odd sizes
/// are mipped from a padded level 0, and cooks' notes are no longer warnings. 4: packs stream
/// mips by texel count, and a texture kept RGBA8 notes what each encoder setting reached.
/// 5: draw ranges of over 400k triangles are ordered for the vertex cache in pieces of at most
/// 200k (other meshes' packs are unchanged, but a shared cache must not mix the two).
/// 7: a texture's payload holds a third text, the error budget's choices (`-v`). Since
/// keys carry the source's fingerprint, a change of code needs no bump; a change of what keys
/// hold still does.
pub const CACHE_VERSION: u32 = 7;
const HEADER: usize = 8 + 8 + 4 + 4;

/// A cache key: SHA-256 over an artifact's inputs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Key(pub [u8; 32]);

impl Key {
    pub fn hex(&self) -> String {
        self.0.iter().map(|b| format!("{b:02x}")).collect()
    }
}

/// Builds a key from labelled parts; labels and lengths are hashed too, so no two different
/// part lists can collide by concatenation.
pub struct KeyBuilder(Sha256);

impl KeyBuilder {
    /// Starts a key for one kind of artifact, already bound to the cooker and format versions.
    pub fn new(kind: &str) -> Self {
        let mut b = Self(Sha256::new());
        b.str("kind", kind);
        b.u64("cache version", CACHE_VERSION as u64);
        b.u64("pack format", pack::FORMAT_VERSION as u64);
        b.str("cooker", env!("CARGO_PKG_VERSION"));
        b.str("cooker source", env!("COOK_SOURCE_FINGERPRINT"));
        b
    }

    pub fn bytes(&mut self, label: &str, bytes: &[u8]) -> &mut Self {
        self.frame(label, bytes.len() as u64);
        self.0.update(bytes);
        self
    }

    /// What precedes a part's bytes: its label and its length, each with its length.
    fn frame(&mut self, label: &str, len: u64) {
        self.0.update((label.len() as u64).to_le_bytes());
        self.0.update(label.as_bytes());
        self.0.update(len.to_le_bytes());
    }

    pub fn str(&mut self, label: &str, s: &str) -> &mut Self {
        self.bytes(label, s.as_bytes())
    }

    pub fn u64(&mut self, label: &str, v: u64) -> &mut Self {
        self.bytes(label, &v.to_le_bytes())
    }

    /// Hashes a value's canonical encoding: every field, in declaration order.
    pub fn serialized(&mut self, label: &str, value: &impl Serialize) -> &mut Self {
        let bytes = bincode::serde::encode_to_vec(value, bincode::config::standard())
            // Settings are plain data: structs, enums, numbers, strings, sequences of known
            // length, all of which the encoder represents.
            .expect("settings have a bincode encoding");
        self.bytes(label, &bytes)
    }

    /// Hashes a file's content (not its name or timestamps: a touched but unchanged file still
    /// hits).
    ///
    /// Read in pieces, as [`bytes`](Self::bytes) would hash it whole: a bare mesh is its own
    /// manifest, and holding an 85 MB OBJ to hash it cost a cache hit more time in fresh
    /// pages than the hash itself.
    pub fn file(&mut self, label: &str, path: &Path) -> Result<&mut Self, CookError> {
        let io = |source| CookError::Io {
            path: path.to_path_buf(),
            source,
        };
        let mut file = std::fs::File::open(path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        self.frame(label, len);
        let read = hash_stream(&mut file, &mut self.0).map_err(io)?;
        if read != len {
            return Err(io(std::io::Error::other(format!(
                "it changed while it was read ({len} bytes, then {read})"
            ))));
        }
        Ok(self)
    }

    pub fn finish(&self) -> Key {
        Key(self.0.clone().finalize().into())
    }
}

/// The key of a whole scene cooked from `manifest` (a scene.toml or a bare mesh file): the
/// manifest's file name and bytes and all the settings. The other files the cook reads are not
/// known before it runs; the scene's entry lists them, relative to the manifest's folder, and
/// their hashes complete the key of the cook's result. The folder itself is left out so that
/// two checkouts of one scene, on one machine or two, share their entries.
pub fn scene_key(manifest: &Path, settings: &Settings) -> Result<Key, CookError> {
    let mut k = KeyBuilder::new("scene");
    let name = manifest.file_name().unwrap_or(manifest.as_os_str());
    k.bytes("file name", name.as_encoded_bytes());
    k.file("manifest", manifest)?;
    k.serialized("settings", settings);
    Ok(k.finish())
}

/// The start of a texture's key: the texture settings. The texture stage adds what the job
/// makes and the image it reads.
pub fn texture_key(settings: &TextureSettings) -> KeyBuilder {
    let mut k = KeyBuilder::new("texture");
    k.serialized("settings", settings);
    k
}

/// SHA-256 of some bytes, for recording what an artifact depended on.
pub fn digest(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// SHA-256 of a file's content, read in pieces (see [`KeyBuilder::file`]).
pub fn digest_file(path: &Path) -> std::io::Result<[u8; 32]> {
    let mut hasher = Sha256::new();
    hash_stream(&mut std::fs::File::open(path)?, &mut hasher)?;
    Ok(hasher.finalize().into())
}

/// Feeds everything `reader` holds to `hasher` through one reused buffer; the bytes read.
fn hash_stream(reader: &mut impl std::io::Read, hasher: &mut Sha256) -> std::io::Result<u64> {
    let mut buf = vec![0u8; 256 << 10];
    let mut total = 0u64;
    loop {
        match reader.read(&mut buf) {
            Ok(0) => return Ok(total),
            Ok(n) => {
                hasher.update(&buf[..n]);
                total += n as u64;
            }
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// Lower-case hex of some bytes.
pub fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The bytes of a 64-digit hex string, `None` for anything else.
pub fn parse_hex32(s: &str) -> Option<[u8; 32]> {
    if s.len() != 64 {
        return None;
    }
    let mut out = [0u8; 32];
    for (i, o) in out.iter_mut().enumerate() {
        *o = u8::from_str_radix(s.get(2 * i..2 * i + 2)?, 16).ok()?;
    }
    Some(out)
}

/// The outcome of a lookup.
#[derive(Debug)]
pub enum Lookup {
    Hit(Vec<u8>),
    Miss,
    /// The entry exists but failed its checks; it has been removed and must be re-cooked.
    Corrupt(String),
}

/// A second cache level shared between machines (a network share, an object store, a key-value
/// server), consulted after a local miss and filled after a cook.
///
/// It never fails a lookup or a store: an unreachable, slow, refusing or lying server is a
/// miss, recorded by the implementation for its summary. Everything it returns has been
/// checked against the SHA-256 it was stored under.
pub trait Remote: Send + Sync + std::fmt::Debug {
    /// The payload stored for an action (a cook step's key).
    fn get(&self, key: &Key) -> Option<Vec<u8>>;
    /// Records an action's payload.
    fn put(&self, key: &Key, payload: &[u8]);
    /// A content-addressed blob.
    fn get_blob(&self, digest: &[u8; 32]) -> Option<Vec<u8>>;
    /// Stores a blob under its SHA-256.
    fn put_blob(&self, digest: &[u8; 32], bytes: &[u8]);
    /// Makes sure a writable remote holds an action's payload found locally, storing it where
    /// it does not; whether it had to. A writer's local hits were never uploaded, so the
    /// machines that read its remote missed what it had cooked before it had a remote.
    fn publish(&self, _key: &Key, _payload: &[u8]) -> bool {
        false
    }
    /// [`Remote::publish`] for a blob.
    fn publish_blob(&self, _digest: &[u8; 32], _bytes: &[u8]) {}
}

/// The default local size cap: 5 GiB.
pub const DEFAULT_MAX_SIZE: u64 = 5 << 30;

/// A cache directory, optionally backed by a [`Remote`].
#[derive(Clone, Debug)]
pub struct Cache {
    dir: PathBuf,
    max_size: u64,
    remote: Option<Arc<dyn Remote>>,
}

impl Cache {
    /// Opens (creating if needed) a cache directory, capped at [`DEFAULT_MAX_SIZE`].
    pub fn open(dir: impl Into<PathBuf>) -> Result<Self, CookError> {
        let dir = dir.into();
        let io = |source| CookError::Io {
            path: dir.clone(),
            source,
        };
        // create_dir_all on a file says only "File exists".
        if dir.exists() && !dir.is_dir() {
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::NotADirectory,
                "a file, not a directory",
            )));
        }
        std::fs::create_dir_all(&dir).map_err(io)?;
        Ok(Self {
            dir,
            max_size: DEFAULT_MAX_SIZE,
            remote: None,
        })
    }

    /// The size [`Cache::trim`] keeps the directory under.
    pub fn with_max_size(mut self, bytes: u64) -> Self {
        self.max_size = bytes;
        self
    }

    /// Consults `remote` after a local miss, and stores there too.
    pub fn with_remote(mut self, remote: Arc<dyn Remote>) -> Self {
        self.remote = Some(remote);
        self
    }

    pub fn max_size(&self) -> u64 {
        self.max_size
    }

    /// The default location: `$STAINED_GLASS_CACHE`, else `$XDG_CACHE_HOME/stained-glass`, else
    /// `~/.cache/stained-glass`, else a folder in the system temp directory.
    pub fn default_dir() -> PathBuf {
        if let Some(d) = std::env::var_os("STAINED_GLASS_CACHE").filter(|d| !d.is_empty()) {
            return PathBuf::from(d);
        }
        if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
            return PathBuf::from(d).join("stained-glass");
        }
        if let Some(h) = std::env::var_os("HOME").filter(|d| !d.is_empty()) {
            return PathBuf::from(h).join(".cache/stained-glass");
        }
        std::env::temp_dir().join("stained-glass-cache")
    }

    pub fn dir(&self) -> &Path {
        &self.dir
    }

    fn path(&self, key: &Key) -> PathBuf {
        self.dir.join(format!("{}.entry", key.hex()))
    }

    fn blob_path(&self, digest: &[u8; 32]) -> PathBuf {
        self.dir.join(format!("{}.blob", hex(digest)))
    }

    /// An action's payload: the local entry (published to a writable remote that lacks it),
    /// else the remote's (then kept locally).
    pub fn get(&self, key: &Key) -> Lookup {
        self.get_published(key).0
    }

    /// [`Cache::get`], and whether the remote lacked a payload found locally (and was given it).
    pub fn get_published(&self, key: &Key) -> (Lookup, bool) {
        match read_entry(&self.path(key)) {
            Lookup::Miss => {}
            Lookup::Hit(payload) => {
                let published = self
                    .remote
                    .as_ref()
                    .is_some_and(|r| r.publish(key, &payload));
                return (Lookup::Hit(payload), published);
            }
            found => return (found, false),
        }
        match self.remote.as_ref().and_then(|r| r.get(key)) {
            Some(payload) => {
                let _ = self.put_local(&self.path(key), &payload);
                (Lookup::Hit(payload), false)
            }
            None => (Lookup::Miss, false),
        }
    }

    /// Stores an action's payload here and on the remote.
    pub fn put(&self, key: &Key, payload: &[u8]) -> Result<(), CookError> {
        if let Some(r) = &self.remote {
            r.put(key, payload);
        }
        self.put_local(&self.path(key), payload)
    }

    /// A blob by its SHA-256: the local copy, else the remote's (then kept locally).
    pub fn get_blob(&self, digest: &[u8; 32]) -> Lookup {
        let (found, from_remote) = self.fetch_blob(digest);
        if let (Lookup::Hit(bytes), true) = (&found, from_remote) {
            let _ = self.keep_blob(digest, bytes);
        }
        found
    }

    /// A blob by its SHA-256, the local copy else the remote's, and whether it came from the
    /// remote: then the caller keeps it locally ([`Cache::keep_blob`]) when it suits it, say
    /// while it writes the same bytes elsewhere.
    pub fn fetch_blob(&self, digest: &[u8; 32]) -> (Lookup, bool) {
        match read_entry(&self.blob_path(digest)) {
            Lookup::Miss => {}
            Lookup::Hit(bytes) => {
                if let Some(r) = &self.remote {
                    r.publish_blob(digest, &bytes);
                }
                return (Lookup::Hit(bytes), false);
            }
            found => return (found, false),
        }
        match self.remote.as_ref().and_then(|r| r.get_blob(digest)) {
            Some(bytes) => (Lookup::Hit(bytes), true),
            None => (Lookup::Miss, false),
        }
    }

    /// Stores a blob, already checked against its SHA-256 `digest`, locally only (one the
    /// remote already holds).
    pub fn keep_blob(&self, digest: &[u8; 32], bytes: &[u8]) -> Result<(), CookError> {
        self.put_local(&self.blob_path(digest), bytes)
    }

    /// Stores a blob here and on the remote; returns its SHA-256.
    pub fn put_blob(&self, bytes: &[u8]) -> Result<[u8; 32], CookError> {
        let d = digest(bytes);
        if let Some(r) = &self.remote {
            r.put_blob(&d, bytes);
        }
        self.put_local(&self.blob_path(&d), bytes)?;
        Ok(d)
    }

    /// Whether the blob is held locally; marks it used, as a read would.
    pub fn has_local_blob(&self, digest: &[u8; 32]) -> bool {
        let path = self.blob_path(digest);
        touch(&path);
        path.exists()
    }

    /// Writes an entry to a temp file and renames it into place. Unlike a pack, an entry is
    /// not synced to disk first: after a crash a torn entry fails its checksum and is cooked
    /// again, so the sync would buy nothing and costs a cache hit the disk's write latency.
    fn put_local(&self, path: &Path, payload: &[u8]) -> Result<(), CookError> {
        let mut header = Vec::with_capacity(HEADER);
        header.extend_from_slice(MAGIC);
        header.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        header.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
        header.extend_from_slice(&[0; 4]);
        static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let name = path.file_name().unwrap_or_default().to_string_lossy();
        // Unique per process and call; trim recognizes (and ages out) the `.tmp-` names.
        let tmp = path.with_file_name(format!(".{name}.tmp-{}-{n}", std::process::id()));
        let result = (|| {
            use std::io::Write;
            let mut f = std::fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .open(&tmp)?;
            f.write_all(&header)?;
            f.write_all(payload)?;
            drop(f);
            std::fs::rename(&tmp, path)
        })();
        result.map_err(|source| {
            let _ = std::fs::remove_file(&tmp);
            CookError::Io {
                path: path.to_path_buf(),
                source,
            }
        })
    }
}

/// What [`Cache::trim`] did.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Trim {
    /// Bytes held before and after.
    pub before: u64,
    pub after: u64,
    pub evicted: usize,
    /// Another process was trimming the directory; this one left it alone.
    pub skipped: bool,
}

/// Temp files older than this are leftovers of a writer that died before its rename.
const STALE_TEMP: std::time::Duration = std::time::Duration::from_secs(3600);

impl Cache {
    /// Keeps the directory under its size cap by deleting the least recently used entries
    /// (written or read longest ago), and temp files a crashed writer left.
    ///
    /// Safe while other cooks use the directory: one trims at a time (a lock file; another
    /// skips rather than waits), entries are replaced by rename so a deletion never leaves a
    /// partial one, and a reader that loses an entry to eviction sees a miss and cooks again
    /// (an open file stays readable after its deletion).
    pub fn trim(&self) -> Result<Trim, CookError> {
        let io = |source| CookError::Io {
            path: self.dir.clone(),
            source,
        };
        let lock = std::fs::File::options()
            .create(true)
            .truncate(false)
            .write(true)
            .open(self.dir.join(".trim.lock"))
            .map_err(io)?;
        if lock.try_lock().is_err() {
            return Ok(Trim {
                skipped: true,
                ..Trim::default()
            });
        }
        let now = std::time::SystemTime::now();
        let mut entries = Vec::new();
        for e in std::fs::read_dir(&self.dir).map_err(io)? {
            let Ok(e) = e else { continue };
            let name = e.file_name();
            let name = name.to_string_lossy();
            // Vanished since the listing: another cook's rename or eviction.
            let Ok(meta) = e.metadata() else { continue };
            let modified = meta.modified().unwrap_or(now);
            if name.starts_with('.') && name.contains(".tmp-") {
                if now.duration_since(modified).unwrap_or_default() > STALE_TEMP {
                    let _ = std::fs::remove_file(e.path());
                }
                continue;
            }
            if meta.is_file() && (name.ends_with(".entry") || name.ends_with(".blob")) {
                entries.push((modified, meta.len(), e.path()));
            }
        }
        let before: u64 = entries.iter().map(|e| e.1).sum();
        let mut trim = Trim {
            before,
            after: before,
            ..Trim::default()
        };
        if before <= self.max_size {
            return Ok(trim);
        }
        // Files larger than the cap go first: they can never stay, and evicting everything
        // older before reaching them (a 6 MB scene pack under a 3 MB cap) emptied the cache
        // of the textures that fit. Then oldest first; the path breaks ties so the order does
        // not depend on the listing.
        let cap = self.max_size;
        entries.sort_by(|a, b| (a.1 <= cap, a).cmp(&(b.1 <= cap, b)));
        for (_, len, path) in entries {
            if trim.after <= self.max_size {
                break;
            }
            if std::fs::remove_file(&path).is_ok() {
                trim.after -= len;
                trim.evicted += 1;
            }
        }
        Ok(trim)
    }
}

/// What a cache directory holds.
#[derive(Debug, Default, PartialEq, Eq)]
pub struct Usage {
    pub entries: usize,
    pub blobs: usize,
    pub bytes: u64,
}

impl Cache {
    /// Counts the entries and blobs held locally.
    pub fn usage(&self) -> Result<Usage, CookError> {
        let mut u = Usage::default();
        for (path, len) in self.local_files()? {
            if path.extension().is_some_and(|e| e == "blob") {
                u.blobs += 1;
            } else {
                u.entries += 1;
            }
            u.bytes += len;
        }
        Ok(u)
    }

    /// Checks every local entry and blob (blobs also against their SHA-256 name), removing the
    /// damaged ones; returns them with what was wrong, and how many were checked.
    pub fn verify(&self) -> Result<(usize, Vec<Damaged>), CookError> {
        let files = self.local_files()?;
        let mut damaged = Vec::new();
        for (path, _) in &files {
            let why = match read_entry(path) {
                // The lookup's reason names the file already, for the cook's warning.
                Lookup::Corrupt(why) => {
                    let prefix = format!("{}: ", path.display());
                    why.strip_prefix(&prefix)
                        .map_or(why.clone(), str::to_string)
                }
                Lookup::Hit(payload) if path.extension().is_some_and(|e| e == "blob") => {
                    let name = path.file_stem().unwrap_or_default().to_string_lossy();
                    if parse_hex32(&name) == Some(digest(&payload)) {
                        continue;
                    }
                    "content does not match its SHA-256 name".into()
                }
                _ => continue,
            };
            // The lookup removed it where it could; a read-only cache keeps it, and says so
            // rather than "removed" on every run.
            let kept = match std::fs::remove_file(path) {
                Err(e) if e.kind() != std::io::ErrorKind::NotFound => Some(e.to_string()),
                _ => None,
            };
            damaged.push(Damaged {
                path: path.clone(),
                why,
                kept,
            });
        }
        Ok((files.len(), damaged))
    }

    fn local_files(&self) -> Result<Vec<(PathBuf, u64)>, CookError> {
        let io = |source| CookError::Io {
            path: self.dir.clone(),
            source,
        };
        let mut out = Vec::new();
        for e in std::fs::read_dir(&self.dir).map_err(io)? {
            let Ok(e) = e else { continue };
            let name = e.file_name();
            let name = name.to_string_lossy();
            if name.starts_with('.') || !(name.ends_with(".entry") || name.ends_with(".blob")) {
                continue;
            }
            // Not only regular files: a FIFO in an entry's place is damage for `verify` to
            // report (a cook that read it blocked for ever).
            if let Ok(m) = e.metadata()
                && !m.is_dir()
            {
                out.push((e.path(), m.len()));
            }
        }
        out.sort();
        Ok(out)
    }
}

/// A damaged entry [`Cache::verify`] found.
#[derive(Debug)]
pub struct Damaged {
    pub path: PathBuf,
    pub why: String,
    /// Why it could not be removed (a read-only cache), where it was not.
    pub kept: Option<String>,
}

/// Marks an entry as just used, for least-recently-used eviction. Access times are unreliable
/// (`noatime`, `relatime` mounts), so the modification time carries it.
fn touch(path: &Path) {
    if let Ok(f) = std::fs::File::options().write(true).open(path) {
        let _ = f.set_modified(std::time::SystemTime::now());
    }
}

fn read_entry(path: &Path) -> Lookup {
    // Reading a FIFO blocks until something writes to it: only regular files are read.
    match std::fs::metadata(path) {
        Ok(m) if !m.is_file() => {
            let _ = std::fs::remove_file(path);
            let what = if m.is_dir() {
                "a folder"
            } else {
                "a FIFO, socket or device"
            };
            return Lookup::Corrupt(format!("{}: not a regular file ({what})", path.display()));
        }
        Ok(_) => {}
        Err(_) => return Lookup::Miss,
    }
    let bytes = match std::fs::read(path) {
        Ok(b) => b,
        // Missing, unreadable, evicted or vanished under a concurrent writer: cook it again.
        Err(_) => return Lookup::Miss,
    };
    match check_entry(&bytes) {
        Ok(()) => {
            touch(path);
            let mut bytes = bytes;
            bytes.drain(..HEADER);
            Lookup::Hit(bytes)
        }
        Err(why) => {
            let _ = std::fs::remove_file(path);
            Lookup::Corrupt(format!("{}: {why}", path.display()))
        }
    }
}

fn check_entry(bytes: &[u8]) -> Result<(), String> {
    if bytes.len() < HEADER {
        return Err(format!(
            "{} bytes, shorter than the {HEADER}-byte entry header",
            bytes.len()
        ));
    }
    if &bytes[..8] != MAGIC {
        return Err("bad magic".into());
    }
    let len = u64::from_le_bytes(bytes[8..16].try_into().unwrap());
    if len != (bytes.len() - HEADER) as u64 {
        return Err(format!(
            "payload is {} bytes but the header says {len}",
            bytes.len() - HEADER
        ));
    }
    if crc32fast::hash(&bytes[HEADER..]).to_le_bytes()[..] != bytes[16..20]
        || bytes[20..24] != [0; 4]
    {
        return Err("checksum mismatch".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::manifest::WindowDesign;
    use crate::mesh::{CacheMode, MeshSettings, PositionBits};
    use texture::MipFilter;

    /// Every setting spelled out, so this does not depend on what the defaults are.
    fn settings() -> Settings {
        Settings {
            mesh: MeshSettings {
                cache: CacheMode::Full,
                overdraw: false,
                crease_angle_deg: 60.0,
                analyze: true,
            },
            quantize: false,
            position_bits: PositionBits::B16,
            cook_textures: true,
            textures: TextureSettings {
                mip_filter: MipFilter::Box,
                max_error_lsb: None,
                format: None,
                supercompression: None,
                max_size: None,
            },
            window_overrides: Vec::new(),
            up: crate::UpAxis::Y,
            text_encoding: None,
            cache: None,
        }
    }

    fn manifest(dir: &Path) -> PathBuf {
        let path = dir.join("scene.toml");
        std::fs::write(&path, "[[mesh]]\nsource = \"m.obj\"\n").unwrap();
        path
    }

    /// Paths of the leaves of a serialized value: `mesh.cache`, `quantize`, …
    fn leaves(prefix: &str, v: &serde_json::Value, out: &mut Vec<String>) {
        match v {
            serde_json::Value::Object(fields) => {
                for (k, v) in fields {
                    let path = if prefix.is_empty() {
                        k.clone()
                    } else {
                        format!("{prefix}.{k}")
                    };
                    leaves(&path, v, out);
                }
            }
            _ => out.push(prefix.to_string()),
        }
    }

    #[test]
    fn every_setting_changes_the_scene_key_and_texture_settings_the_texture_keys() {
        let dir = tempfile::tempdir().unwrap();
        let manifest = manifest(dir.path());
        let base = settings();
        // No `..`: a field added to the settings fails to compile here until it has a case.
        let Settings {
            mesh:
                MeshSettings {
                    cache: vertex_cache,
                    overdraw,
                    crease_angle_deg,
                    // Report statistics only; `irrelevant_things_change_no_key` checks it.
                    analyze: _,
                },
            quantize,
            position_bits,
            cook_textures,
            textures:
                TextureSettings {
                    mip_filter,
                    max_error_lsb,
                    format,
                    supercompression,
                    max_size,
                },
            window_overrides,
            up,
            text_encoding,
            // Not a knob; `irrelevant_things_change_no_key` checks it changes nothing.
            cache: _,
        } = base.clone();
        let changed = |f: &dyn Fn(&mut Settings)| {
            let mut s = base.clone();
            f(&mut s);
            s
        };
        // (the field as serialized, the settings with it changed, whether textures depend on it)
        let cases = [
            (
                "mesh.cache",
                changed(&|s| {
                    s.mesh.cache = match vertex_cache {
                        CacheMode::Full => CacheMode::Fifo,
                        CacheMode::Fifo => CacheMode::Full,
                    }
                }),
                false,
            ),
            (
                "mesh.overdraw",
                changed(&|s| s.mesh.overdraw = !overdraw),
                false,
            ),
            (
                "mesh.crease_angle_deg",
                changed(&|s| s.mesh.crease_angle_deg = crease_angle_deg + 1.0),
                false,
            ),
            ("quantize", changed(&|s| s.quantize = !quantize), false),
            (
                "position_bits",
                changed(&|s| {
                    s.position_bits = match position_bits {
                        PositionBits::B8 => PositionBits::B10,
                        _ => PositionBits::B8,
                    }
                }),
                false,
            ),
            (
                "cook_textures",
                changed(&|s| s.cook_textures = !cook_textures),
                false,
            ),
            (
                "textures.mip_filter",
                changed(&|s| {
                    s.textures.mip_filter = match mip_filter {
                        MipFilter::Box => MipFilter::Kaiser,
                        _ => MipFilter::Box,
                    }
                }),
                true,
            ),
            (
                "textures.max_error_lsb",
                changed(&|s| s.textures.max_error_lsb = Some(max_error_lsb.unwrap_or(0.5) + 1.0)),
                true,
            ),
            (
                "textures.format",
                changed(&|s| {
                    s.textures.format = match format {
                        Some(crate::manifest::TextureFormatChoice::Rgba8) => {
                            Some(crate::manifest::TextureFormatChoice::Bc)
                        }
                        _ => Some(crate::manifest::TextureFormatChoice::Rgba8),
                    }
                }),
                true,
            ),
            (
                "textures.supercompression",
                changed(&|s| {
                    s.textures.supercompression = match supercompression {
                        Some(pack::Supercompression::None) => Some(pack::Supercompression::Zstd),
                        _ => Some(pack::Supercompression::None),
                    }
                }),
                true,
            ),
            (
                "textures.max_size",
                changed(&|s| s.textures.max_size = Some(max_size.map_or(1024, |m| m / 2))),
                true,
            ),
            (
                "window_overrides",
                changed(&|s| {
                    s.window_overrides = window_overrides.clone();
                    s.window_overrides
                        .push(WindowDesign::from_override("lancet*", "a.png".into()));
                }),
                false,
            ),
            (
                "up",
                changed(&|s| {
                    s.up = match up {
                        crate::UpAxis::Y => crate::UpAxis::Z,
                        crate::UpAxis::Z => crate::UpAxis::Y,
                    }
                }),
                false,
            ),
            (
                "text_encoding",
                changed(&|s| {
                    s.text_encoding = match text_encoding {
                        None => crate::import::text::TextEncoding::from_label("cp1251").ok(),
                        Some(_) => None,
                    }
                }),
                false,
            ),
        ];
        // `up` and `text_encoding` at their defaults are left out, so keys made before they
        // existed still hold.
        assert!(!serde_json::to_string(&base).unwrap().contains("\"up\""));
        assert!(
            !serde_json::to_string(&base)
                .unwrap()
                .contains("text_encoding")
        );
        // And at run time: every field the settings serialize has a case. A field left out
        // at its default (`up`) is serialized by its case.
        let mut fields = Vec::new();
        for s in std::iter::once(&base).chain(cases.iter().map(|c| &c.1)) {
            leaves("", &serde_json::to_value(s).unwrap(), &mut fields);
        }
        let mut named: Vec<String> = cases.iter().map(|c| c.0.to_string()).collect();
        fields.sort();
        fields.dedup();
        named.sort();
        assert_eq!(fields, named, "each setting needs a case here");

        let scene = scene_key(&manifest, &base).unwrap();
        let texture = texture_key(&base.textures).finish();
        for (name, s, shapes_textures) in &cases {
            assert_ne!(
                scene_key(&manifest, s).unwrap(),
                scene,
                "{name} must change the scene key"
            );
            assert_eq!(
                texture_key(&s.textures).finish() != texture,
                *shapes_textures,
                "{name} changes texture keys exactly when it shapes textures"
            );
        }
        // A nested change counts too: the same override with another image.
        let a = changed(&|s| {
            s.window_overrides = vec![WindowDesign::from_override("w", "a.png".into())]
        });
        let b = changed(&|s| {
            s.window_overrides = vec![WindowDesign::from_override("w", "b.png".into())]
        });
        assert_ne!(
            scene_key(&manifest, &a).unwrap(),
            scene_key(&manifest, &b).unwrap()
        );
    }

    #[test]
    fn irrelevant_things_change_no_key() {
        let dir = tempfile::tempdir().unwrap();
        let manifest = manifest(dir.path());
        let base = settings();
        let keys: Vec<(Key, Key)> = [1, 2, 8]
            .iter()
            .map(|&n| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(n)
                    .build()
                    .unwrap();
                pool.install(|| {
                    (
                        scene_key(&manifest, &base).unwrap(),
                        texture_key(&base.textures).finish(),
                    )
                })
            })
            .collect();
        assert!(
            keys.iter().all(|k| *k == keys[0]),
            "thread count changed a key"
        );
        let mut quiet = base.clone();
        quiet.mesh.analyze = false;
        assert_eq!(
            scene_key(&manifest, &quiet).unwrap(),
            keys[0].0,
            "measuring ACMR for the report changed the key"
        );
        let cached = Settings {
            cache: Some(Cache::open(dir.path().join("cache")).unwrap()),
            ..base.clone()
        };
        assert_eq!(
            scene_key(&manifest, &cached).unwrap(),
            keys[0].0,
            "the cache's location changed the key"
        );
        // The manifest's content is in the key, its timestamps are not.
        let text = std::fs::read(&manifest).unwrap();
        std::fs::write(&manifest, &text).unwrap();
        assert_eq!(scene_key(&manifest, &base).unwrap(), keys[0].0);
        std::fs::write(&manifest, [&text[..], b"\n"].concat()).unwrap();
        assert_ne!(scene_key(&manifest, &base).unwrap(), keys[0].0);
    }

    #[test]
    fn a_file_hashes_as_its_bytes_do() {
        // Over several reads of the streaming buffer, and not a multiple of it.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.obj");
        let bytes: Vec<u8> = (0..700_001u32).map(|i| (i * 31 % 251) as u8).collect();
        std::fs::write(&path, &bytes).unwrap();
        let mut from_file = KeyBuilder::new("test");
        from_file.file("f", &path).unwrap();
        let mut from_bytes = KeyBuilder::new("test");
        from_bytes.bytes("f", &bytes);
        assert_eq!(from_file.finish(), from_bytes.finish());
        assert_eq!(digest_file(&path).unwrap(), digest(&bytes));
        let missing = dir.path().join("gone.obj");
        let e = KeyBuilder::new("test").file("f", &missing).err().unwrap();
        assert!(e.to_string().contains("gone.obj"), "{e}");
    }

    fn key(s: &str) -> Key {
        KeyBuilder::new("test").str("s", s).finish()
    }

    #[test]
    fn put_get_and_distinct_keys() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::open(dir.path()).unwrap();
        assert!(matches!(c.get(&key("a")), Lookup::Miss));
        c.put(&key("a"), b"payload").unwrap();
        assert!(matches!(c.get(&key("a")), Lookup::Hit(p) if p == b"payload"));
        assert!(matches!(c.get(&key("b")), Lookup::Miss));
        // Labels and lengths are hashed, so shifting bytes between parts changes the key.
        let ab = KeyBuilder::new("t").str("x", "ab").str("y", "c").finish();
        let a_bc = KeyBuilder::new("t").str("x", "a").str("y", "bc").finish();
        assert_ne!(ab, a_bc);
    }

    #[test]
    fn every_damaged_entry_is_detected_and_removed() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::open(dir.path()).unwrap();
        c.put(&key("a"), b"some cooked bytes").unwrap();
        let path = c.path(&key("a"));
        let good = std::fs::read(&path).unwrap();
        for i in 0..good.len() {
            let mut bad = good.clone();
            bad[i] ^= 0x04;
            std::fs::write(&path, &bad).unwrap();
            assert!(
                matches!(c.get(&key("a")), Lookup::Corrupt(_)),
                "flip at {i} accepted"
            );
            assert!(!path.exists(), "corrupt entry removed");
        }
        for len in 0..good.len() {
            std::fs::write(&path, &good[..len]).unwrap();
            assert!(
                matches!(c.get(&key("a")), Lookup::Corrupt(_)),
                "prefix {len} accepted"
            );
        }
    }

    /// A FIFO in an entry's place is damage, found by a lookup and by `verify`, not read:
    /// reading it blocked the cook for ever.
    #[cfg(unix)]
    #[test]
    fn a_fifo_in_an_entrys_place_is_damage_not_a_wait() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::open(dir.path()).unwrap();
        let path = c.path(&key("a"));
        let fifo = |p: &Path| {
            let made = std::process::Command::new("mkfifo")
                .arg(p)
                .status()
                .unwrap();
            assert!(made.success());
        };
        fifo(&path);
        assert!(
            matches!(c.get(&key("a")), Lookup::Corrupt(ref why) if why.contains("not a regular file"))
        );
        assert!(!path.exists(), "removed");
        fifo(&path);
        let (checked, damaged) = c.verify().unwrap();
        assert_eq!((checked, damaged.len()), (1, 1), "{damaged:?}");
        assert!(damaged[0].why.contains("not a regular file"), "{damaged:?}");
        assert_eq!(damaged[0].kept, None);
        assert!(!path.exists());
    }

    #[test]
    fn trim_evicts_a_file_over_the_cap_before_older_ones_that_fit() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::open(dir.path()).unwrap().with_max_size(3000);
        let t0 = std::time::SystemTime::now() - std::time::Duration::from_secs(10_000);
        for (i, name) in ["a", "b"].iter().enumerate() {
            c.put(&key(name), &[i as u8; 1000]).unwrap();
            std::fs::File::options()
                .write(true)
                .open(c.path(&key(name)))
                .unwrap()
                .set_modified(t0 + std::time::Duration::from_secs(i as u64))
                .unwrap();
        }
        // The newest, a scene's pack larger than the whole cap.
        let big = c.put_blob(&[7u8; 5000]).unwrap();
        let t = c.trim().unwrap();
        assert_eq!(t.evicted, 1, "{t:?}");
        assert!(!c.blob_path(&big).exists());
        assert!(c.path(&key("a")).exists() && c.path(&key("b")).exists());
    }

    #[test]
    fn trim_evicts_the_least_recently_used_and_stale_temp_files() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::open(dir.path()).unwrap().with_max_size(3000);
        let t0 = std::time::SystemTime::now() - std::time::Duration::from_secs(10_000);
        let age = |path: &Path, secs: u64| {
            std::fs::File::options()
                .write(true)
                .open(path)
                .unwrap()
                .set_modified(t0 + std::time::Duration::from_secs(secs))
                .unwrap();
        };
        for (i, name) in ["a", "b", "c", "d"].iter().enumerate() {
            c.put(&key(name), &[i as u8; 1000]).unwrap();
            age(&c.path(&key(name)), i as u64);
        }
        let blob = c.put_blob(&[9u8; 500]).unwrap();
        age(&c.blob_path(&blob), 1);
        // Reading "a", the oldest, makes it the most recently used.
        assert!(matches!(c.get(&key("a")), Lookup::Hit(_)));
        let stale = dir.path().join(".x.entry.tmp-1-0");
        std::fs::write(&stale, b"partial").unwrap();
        age(&stale, 0);
        let fresh = dir.path().join(".y.entry.tmp-2-0");
        std::fs::write(&fresh, b"being written").unwrap();

        let t = c.trim().unwrap();
        let header = HEADER as u64;
        assert_eq!(t.before, 4 * (1000 + header) + 500 + header);
        assert!(t.after <= 3000 && t.evicted == 3, "{t:?}");
        // Left: the two most recently used. Evicted, oldest first: b (1), the blob (1), c (2).
        for (name, kept) in [("a", true), ("b", false), ("c", false), ("d", true)] {
            assert_eq!(c.path(&key(name)).exists(), kept, "{name}");
        }
        assert!(!c.blob_path(&blob).exists());
        assert!(!stale.exists() && fresh.exists());
        // Under the cap: nothing to do.
        assert_eq!(c.trim().unwrap().evicted, 0);

        // While another process holds the lock, a trim leaves everything alone.
        let lock = std::fs::File::open(dir.path().join(".trim.lock")).unwrap();
        lock.lock().unwrap();
        let tiny = c.clone().with_max_size(0);
        assert!(tiny.trim().unwrap().skipped);
        assert!(c.path(&key("a")).exists());
        drop(lock);
        assert_eq!(tiny.trim().unwrap().after, 0);
    }

    #[test]
    fn concurrent_writers_leave_a_complete_entry() {
        let dir = tempfile::tempdir().unwrap();
        let c = Cache::open(dir.path()).unwrap();
        let payload = vec![7u8; 1 << 20];
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| c.put(&key("x"), &payload).unwrap());
                s.spawn(|| {
                    if let Lookup::Corrupt(w) = c.get(&key("x")) {
                        panic!("reader saw a partial entry: {w}");
                    }
                });
            }
        });
        assert!(matches!(c.get(&key("x")), Lookup::Hit(p) if p == payload));
        let leftovers = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(leftovers, 1, "no temp files left behind");
    }
}
