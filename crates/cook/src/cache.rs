//! The incremental cook cache: a content-addressed store of cooked artifacts.
//!
//! A key is a SHA-256 over everything that can change an artifact: the bytes of every input
//! file, the settings, the cooker's version and the pack format version. The thread count is
//! deliberately not part of it: cooking is deterministic, so it never changes the output.
//! Changing what goes into a key, or how, is a breaking change: bump `CACHE_VERSION`.
//!
//! Entries are files `<dir>/<key hex>.entry`: magic, payload length, CRC-32 of the payload,
//! payload. (The payload check guards against damage, not an adversary: CRC-32 catches every
//! single-bit flip and burst, and runs at memory speed, where SHA-256 over a pack of tens of
//! megabytes would dominate a cache hit.) A damaged entry (truncated, flipped bits, wrong magic) is reported as corrupt and
//! re-cooked, never used. Entries are written to a temp file and renamed into place, so two
//! cooks sharing a cache only ever see complete entries (both write identical bytes for a key).

use std::path::{Path, PathBuf};

use sha2::{Digest, Sha256};

use crate::CookError;

const MAGIC: &[u8; 8] = b"SGCACHE\x01";
/// Bump when the meaning of keys or payloads changes.
pub const CACHE_VERSION: u32 = 1;
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
        b
    }

    pub fn bytes(&mut self, label: &str, bytes: &[u8]) -> &mut Self {
        self.0.update((label.len() as u64).to_le_bytes());
        self.0.update(label.as_bytes());
        self.0.update((bytes.len() as u64).to_le_bytes());
        self.0.update(bytes);
        self
    }

    pub fn str(&mut self, label: &str, s: &str) -> &mut Self {
        self.bytes(label, s.as_bytes())
    }

    pub fn u64(&mut self, label: &str, v: u64) -> &mut Self {
        self.bytes(label, &v.to_le_bytes())
    }

    /// Hashes a file's content (not its name or timestamps: a touched but unchanged file still
    /// hits).
    pub fn file(&mut self, label: &str, path: &Path) -> Result<&mut Self, CookError> {
        let bytes = std::fs::read(path).map_err(|source| CookError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Ok(self.bytes(label, &bytes))
    }

    pub fn finish(&self) -> Key {
        Key(self.0.clone().finalize().into())
    }
}

/// SHA-256 of some bytes, for recording what an artifact depended on.
pub fn digest(bytes: &[u8]) -> [u8; 32] {
    Sha256::digest(bytes).into()
}

/// The outcome of a lookup.
#[derive(Debug)]
pub enum Lookup {
    Hit(Vec<u8>),
    Miss,
    /// The entry exists but failed its checks; it has been removed and must be re-cooked.
    Corrupt(String),
}

/// A cache directory.
#[derive(Clone, Debug)]
pub struct Cache {
    dir: PathBuf,
}

impl Cache {
    /// Opens (creating if needed) a cache directory.
    pub fn open(dir: impl Into<PathBuf>) -> Result<Self, CookError> {
        let dir = dir.into();
        std::fs::create_dir_all(&dir).map_err(|source| CookError::Io {
            path: dir.clone(),
            source,
        })?;
        Ok(Self { dir })
    }

    /// The default location: `$STAINED_GLASS_CACHE`, else `$XDG_CACHE_HOME/stained-glass`, else
    /// `~/.cache/stained-glass`, else a folder in the system temp directory.
    pub fn default_dir() -> PathBuf {
        if let Some(d) = std::env::var_os("STAINED_GLASS_CACHE") {
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

    pub fn get(&self, key: &Key) -> Lookup {
        let path = self.path(key);
        let bytes = match std::fs::read(&path) {
            Ok(b) => b,
            // Missing, unreadable or vanished under a concurrent writer: cook it again.
            Err(_) => return Lookup::Miss,
        };
        match check_entry(&bytes) {
            Ok(()) => Lookup::Hit(bytes[HEADER..].to_vec()),
            Err(why) => {
                let _ = std::fs::remove_file(&path);
                Lookup::Corrupt(format!("{}: {why}", path.display()))
            }
        }
    }

    pub fn put(&self, key: &Key, payload: &[u8]) -> Result<(), CookError> {
        let mut bytes = Vec::with_capacity(HEADER + payload.len());
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
        bytes.extend_from_slice(&crc32fast::hash(payload).to_le_bytes());
        bytes.extend_from_slice(&[0; 4]);
        bytes.extend_from_slice(payload);
        pack::write_atomic(&self.path(key), &bytes)?;
        Ok(())
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
