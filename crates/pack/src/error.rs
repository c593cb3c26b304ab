use std::path::PathBuf;

/// An error reading or writing a pack, naming the file.
///
/// The operating system's error is the `source`, not part of the message: `{:#}` of an
/// `anyhow::Error` prints each link of the chain once.
#[derive(Debug, thiserror::Error)]
pub enum PackError {
    #[error("{}", path.display())]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: {}", path.display(), describe(*offset, problem))]
    Invalid {
        path: PathBuf,
        /// Byte offset in the file where the problem was found, when there is one.
        offset: Option<u64>,
        problem: Problem,
    },
}

fn describe(offset: Option<u64>, problem: &Problem) -> String {
    match offset {
        Some(o) => format!("at byte offset {o}: {problem}"),
        None => problem.to_string(),
    }
}

impl PackError {
    pub fn problem(&self) -> Option<&Problem> {
        match self {
            PackError::Invalid { problem, .. } => Some(problem),
            PackError::Io { .. } => None,
        }
    }

    /// True for I/O failures of the operating system (as opposed to invalid content).
    pub fn is_io(&self) -> bool {
        matches!(self, PackError::Io { .. })
    }
}

/// What is wrong with a pack's bytes.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Problem {
    #[error("file is {len} bytes, shorter than the {need}-byte header: truncated or not a pack")]
    TooShort { len: u64, need: u64 },
    #[error(
        "bad magic {found:02x?}: not a stained-glass pack{}",
        source_hint(found)
    )]
    BadMagic { found: [u8; 8] },
    #[error(
        "pack format version {found}, but this build reads version {expected}: {}",
        if .found > .expected {
            "the pack is from a newer cooker; read it with the viewer and cooker of its version"
        } else {
            "re-cook the pack with this cooker"
        }
    )]
    Version { found: u32, expected: u32 },
    #[error("{what} checksum mismatch: stored {stored:#010x}, computed {computed:#010x}")]
    Checksum {
        what: String,
        stored: u32,
        computed: u32,
    },
    #[error("{what} is {found} but must be {expected}")]
    Field {
        what: String,
        found: u64,
        expected: u64,
    },
    #[error("{what} is {found} but at most {max} is allowed")]
    Limit { what: String, found: u64, max: u64 },
    #[error("file length is {actual} bytes but the header says {declared}")]
    Length { declared: u64, actual: u64 },
    #[error("trailing data after the last section")]
    TrailingData,
    #[error("unknown section kind {kind} in section {index}")]
    UnknownSection { index: u32, kind: u32 },
    #[error(
        "section {index} spans bytes {start}..{end}, which is outside the valid range {min}..{max}"
    )]
    SectionBounds {
        index: u32,
        start: u64,
        end: u64,
        min: u64,
        max: u64,
    },
    #[error(
        "section {index} starts at byte {start}, but sections lie back to back: it must start \
         at {expected}, {after}, so either that length or this offset is wrong"
    )]
    SectionPlace {
        index: u32,
        start: u64,
        expected: u64,
        /// Where the expected start comes from, in words: the section before, or the table.
        after: String,
    },
    #[error("section {index} at offset {offset} is not aligned to {align}")]
    Alignment { index: u32, offset: u64, align: u64 },
    #[error("non-zero padding or reserved byte")]
    NonZeroPadding,
    #[error("table of contents could not be decoded: {0}")]
    TocDecode(String),
    #[error("table of contents is invalid: {0}")]
    Toc(String),
    /// A vertex or index section that contradicts the table of contents (they were said to be
    /// the table's fault, at the geometry's offset).
    #[error("geometry is invalid: {0}")]
    Geometry(String),
    #[error("{what} is {found} but must be from {min} to {max}")]
    Range {
        what: String,
        found: u64,
        min: u64,
        max: u64,
    },
    #[error(
        "the section table's {sections} entries end at byte {end}, past the file's end at {length}"
    )]
    TableTooLong {
        sections: u64,
        end: u64,
        length: u64,
    },
    #[error("{what} cannot be decompressed: {reason}")]
    Supercompression { what: String, reason: String },
    #[error("unexpected end of stream while reading {what}")]
    Truncated { what: String },
}

/// A failure inside the byte-level code, before a path is attached.
#[derive(Debug, Clone)]
pub struct Fail {
    pub offset: Option<u64>,
    pub problem: Problem,
}

impl Fail {
    pub fn at(offset: u64, problem: Problem) -> Self {
        Self {
            offset: Some(offset),
            problem,
        }
    }
    pub fn toc(msg: impl Into<String>) -> Self {
        Self {
            offset: None,
            problem: Problem::Toc(msg.into()),
        }
    }
    pub fn geometry(msg: impl Into<String>) -> Self {
        Self {
            offset: None,
            problem: Problem::Geometry(msg.into()),
        }
    }
    pub fn with_path(self, path: impl Into<PathBuf>) -> PackError {
        PackError::Invalid {
            path: path.into(),
            offset: self.offset,
            problem: self.problem,
        }
    }
}

impl From<Problem> for Fail {
    fn from(problem: Problem) -> Self {
        Self {
            offset: None,
            problem,
        }
    }
}

/// What a file that is no pack looks like it is, where its first bytes say: a model or scene
/// given where a pack was wanted (`cooker info chapel.obj`) is one `cooker cook` away.
fn source_hint(found: &[u8; 8]) -> &'static str {
    let text = String::from_utf8_lossy(found);
    let first = text.split_whitespace().next().unwrap_or("");
    if found.starts_with(b"glTF") {
        " (it is a GLB model: `cooker cook` makes a pack of it)"
    } else if found.starts_with(b"ply") {
        " (it is a PLY model: `cooker cook` makes a pack of it)"
    } else if matches!(
        first,
        "v" | "vn" | "vt" | "f" | "o" | "g" | "mtllib" | "usemtl" | "#"
    ) {
        " (it reads as text, an OBJ model or a scene: `cooker cook` makes a pack of one)"
    } else if first.starts_with('{') {
        " (it reads as JSON, a glTF model perhaps: `cooker cook` makes a pack of one)"
    } else if first.starts_with('[') {
        " (it reads as a scene manifest: `cooker cook` makes a pack of it)"
    } else {
        ""
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A model or scene given where a pack was wanted says what it looks like; other bytes
    /// say only that they are no pack.
    #[test]
    fn a_model_given_for_a_pack_is_said_to_be_one() {
        let said = |b: &[u8; 8]| Problem::BadMagic { found: *b }.to_string();
        assert!(said(b"mtllib c").ends_with(
            "(it reads as text, an OBJ model or a scene: `cooker cook` makes a pack of one)"
        ));
        assert!(said(b"glTF\x02\0\0\0").contains("it is a GLB model"));
        assert!(said(b"ply\nform").contains("it is a PLY model"));
        assert!(said(b"{\"asset\"").contains("glTF model perhaps"));
        assert!(said(b"[[mesh]]").contains("scene manifest"));
        assert!(said(b"\x89PNG\r\n\x1a\n").ends_with("not a stained-glass pack"));
    }
}
