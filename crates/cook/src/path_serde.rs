//! Paths in the cache's JSON entries: text where the path is UTF-8, else its bytes. serde's
//! own form of a path fails on one that is not UTF-8 (a model unpacked from a Windows archive
//! with cp1251 file names), and with it every entry of that scene: `cache not updated: path
//! contains invalid UTF-8 characters`, and every cook a miss.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Deserializer, Serialize, Serializer};

#[derive(Serialize, Deserialize)]
#[serde(untagged)]
enum Repr<'a> {
    Text(std::borrow::Cow<'a, str>),
    Bytes(Vec<u8>),
}

fn repr(p: &Path) -> Repr<'_> {
    match p.to_str() {
        Some(t) => Repr::Text(t.into()),
        None => Repr::Bytes(p.as_os_str().as_encoded_bytes().to_vec()),
    }
}

fn path_of(r: Repr<'_>) -> PathBuf {
    match r {
        Repr::Text(t) => PathBuf::from(t.into_owned()),
        Repr::Bytes(b) => bytes_to_path(b),
    }
}

#[cfg(unix)]
fn bytes_to_path(b: Vec<u8>) -> PathBuf {
    use std::os::unix::ffi::OsStringExt;
    PathBuf::from(std::ffi::OsString::from_vec(b))
}

/// Elsewhere a path that is not Unicode cannot be rebuilt from bytes without `unsafe`: the
/// lossy text names no file, so the entry is a miss, as it was.
#[cfg(not(unix))]
fn bytes_to_path(b: Vec<u8>) -> PathBuf {
    PathBuf::from(String::from_utf8_lossy(&b).into_owned())
}

/// One path.
pub mod one {
    use super::*;

    pub fn serialize<S: Serializer>(p: &Path, s: S) -> Result<S::Ok, S::Error> {
        repr(p).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<PathBuf, D::Error> {
        Repr::deserialize(d).map(path_of)
    }
}

/// An optional path.
pub mod option {
    use super::*;

    pub fn serialize<S: Serializer>(p: &Option<PathBuf>, s: S) -> Result<S::Ok, S::Error> {
        p.as_deref().map(repr).serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<PathBuf>, D::Error> {
        Option::<Repr>::deserialize(d).map(|r| r.map(path_of))
    }
}

/// A list of paths.
pub mod list {
    use super::*;

    pub fn serialize<S: Serializer>(p: &[PathBuf], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(p.iter().map(|p| repr(p)))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<PathBuf>, D::Error> {
        Vec::<Repr>::deserialize(d).map(|v| v.into_iter().map(path_of).collect())
    }
}

/// A list of paths, each with a text (a file and its hash).
pub mod with_text {
    use super::*;

    pub fn serialize<S: Serializer>(p: &[(PathBuf, String)], s: S) -> Result<S::Ok, S::Error> {
        s.collect_seq(p.iter().map(|(p, t)| (repr(p), t)))
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(
        d: D,
    ) -> Result<Vec<(PathBuf, String)>, D::Error> {
        Vec::<(Repr, String)>::deserialize(d)
            .map(|v| v.into_iter().map(|(p, t)| (path_of(p), t)).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Serialize, Deserialize, PartialEq, Debug)]
    struct Entry {
        #[serde(with = "list")]
        inputs: Vec<PathBuf>,
        #[serde(with = "option")]
        found: Option<PathBuf>,
    }

    /// A UTF-8 path is written as text, as serde wrote it before (entries already in caches
    /// still read); one that is not is written as its bytes and read back the same.
    #[test]
    fn paths_round_trip_as_text_or_bytes() {
        let text = Entry {
            inputs: vec![PathBuf::from("храм.obj")],
            found: None,
        };
        let json = serde_json::to_string(&text).unwrap();
        assert_eq!(json, r#"{"inputs":["храм.obj"],"found":null}"#);
        assert_eq!(serde_json::from_str::<Entry>(&json).unwrap(), text);
        #[cfg(unix)]
        {
            use std::os::unix::ffi::OsStrExt;
            let raw = PathBuf::from(std::ffi::OsStr::from_bytes(b"\xf5\xf0\xe0\xec.obj"));
            let bytes = Entry {
                inputs: vec![raw.clone()],
                found: Some(raw),
            };
            let json = serde_json::to_string(&bytes).unwrap();
            assert!(json.contains("[245,240,224,236,46,111,98,106]"), "{json}");
            assert_eq!(serde_json::from_str::<Entry>(&json).unwrap(), bytes);
        }
    }
}
