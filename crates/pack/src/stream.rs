//! Streaming reader over any `std::io::Read`: sections are handed out, validated, as soon as
//! each one has arrived, in file (= streaming) order. A consumer can draw a first frame from the
//! geometry and the small mips before the large ones are read.

use std::io::Read;
use std::path::{Path, PathBuf};

use crate::error::{Fail, PackError, Problem};
use crate::format::{HEADER_SIZE, Header, SectionEntry, check_section, decode_table};
use crate::reader::AlignedBytes;
use crate::toc::Toc;
use crate::validate::{SectionRole, decode_content, decode_toc, validate_toc};

const EAGER_ALLOCATION: u64 = 64 << 20;

/// One validated section.
#[derive(Debug)]
pub struct StreamSection {
    pub index: u32,
    pub role: SectionRole,
    /// The section's content: a supercompressed texture level arrives decoded.
    pub bytes: AlignedBytes,
}

pub struct StreamReader<R> {
    path: PathBuf,
    source: R,
    header: Header,
    sections: Vec<SectionEntry>,
    roles: Vec<SectionRole>,
    toc: Option<Toc>,
    next: usize,
    position: u64,
    finished: bool,
}

fn read_exact_or<R: Read>(r: &mut R, buf: &mut [u8], what: &str) -> Result<(), ReadFail> {
    let mut filled = 0;
    while filled < buf.len() {
        match r.read(&mut buf[filled..]) {
            Ok(0) => {
                return Err(ReadFail::Bad(
                    Problem::Truncated { what: what.into() }.into(),
                ));
            }
            Ok(n) => filled += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(ReadFail::Io(e)),
        }
    }
    Ok(())
}

enum ReadFail {
    Io(std::io::Error),
    Bad(Fail),
}

impl From<Fail> for ReadFail {
    fn from(f: Fail) -> Self {
        ReadFail::Bad(f)
    }
}

impl<R: Read> StreamReader<R> {
    /// Reads and validates the header and the section table.
    pub fn new(path: impl AsRef<Path>, source: R) -> Result<Self, PackError> {
        Self::with_length(path, source, None)
    }

    /// [`StreamReader::new`] for a source whose length is known (a file, not a pipe): the
    /// header's file length is checked against it first, as the mapping reader checks it, so a
    /// pack cut short (or with data after its end) is said to be at once, not after a first
    /// frame drawn from the sections before the cut.
    pub fn with_length(
        path: impl AsRef<Path>,
        mut source: R,
        length: Option<u64>,
    ) -> Result<Self, PackError> {
        let path = path.as_ref().to_path_buf();
        let wrap = |e: ReadFail| match e {
            ReadFail::Io(source) => PackError::Io {
                path: path.clone(),
                source,
            },
            ReadFail::Bad(f) => f.with_path(&path),
        };
        let mut head = [0u8; HEADER_SIZE as usize];
        let mut filled = 0;
        while filled < head.len() {
            match source.read(&mut head[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(PackError::Io { path, source: e }),
            }
        }
        let header = Header::decode(&head[..filled], length).map_err(|f| f.with_path(&path))?;
        let mut table = vec![0u8; header.table_len() as usize];
        read_exact_or(&mut source, &mut table, "the section table").map_err(wrap)?;
        let sections = decode_table(&header, &table).map_err(|f| f.with_path(&path))?;
        Ok(Self {
            position: header.data_start(),
            path,
            source,
            header,
            sections,
            roles: Vec::new(),
            toc: None,
            next: 0,
            finished: false,
        })
    }

    pub fn header(&self) -> &Header {
        &self.header
    }
    pub fn sections(&self) -> &[SectionEntry] {
        &self.sections
    }
    /// The TOC, once the first section has been read.
    pub fn toc(&self) -> Option<&Toc> {
        self.toc.as_ref()
    }
    /// Bytes read so far and in all, for progress reports.
    pub fn progress(&self) -> (u64, u64) {
        (self.position, self.header.file_length)
    }

    /// The next validated section, or `None` after the last one (when the stream has also been
    /// checked to end there).
    pub fn next_section(&mut self) -> Result<Option<StreamSection>, PackError> {
        match self.next_raw()? {
            Some(raw) => {
                let toc = self.toc.as_ref().expect("the TOC is section 0");
                raw.decode(toc).map(Some)
            }
            None => Ok(None),
        }
    }

    /// [`StreamReader::next_section`] up to its content's decoding: the section is read, its
    /// checksum checked and (section 0) the TOC validated; [`RawSection::decode`] does the rest
    /// (zstd, the content's checks), so a reader can decode sections in parallel and keep
    /// their order itself.
    pub fn next_raw(&mut self) -> Result<Option<RawSection>, PackError> {
        let path = self.path.clone();
        self.read_next().map_err(|e| match e {
            ReadFail::Io(source) => PackError::Io { path, source },
            ReadFail::Bad(f) => f.with_path(&path),
        })
    }

    fn read_next(&mut self) -> Result<Option<RawSection>, ReadFail> {
        if self.finished {
            return Ok(None);
        }
        if self.next == self.sections.len() {
            let mut one = [0u8; 1];
            loop {
                match self.source.read(&mut one) {
                    Ok(0) => break,
                    Ok(_) => return Err(Fail::at(self.position, Problem::TrailingData).into()),
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(ReadFail::Io(e)),
                }
            }
            self.finished = true;
            return Ok(None);
        }
        let index = self.next;
        let entry = self.sections[index];
        let pad = (entry.offset - self.position) as usize;
        if pad > 0 {
            let mut buf = [0u8; 4096];
            read_exact_or(&mut self.source, &mut buf[..pad], "padding")?;
            if buf[..pad].iter().any(|&b| b != 0) {
                return Err(Fail::at(self.position, Problem::NonZeroPadding).into());
            }
        }
        // The table was checked against the declared file length, and the TOC's size against its
        // own limit; a bulk section's length is only trusted once the TOC has vouched for it.
        let what = format!("section {index} ({})", entry.kind.name());
        let bytes = if entry.length <= EAGER_ALLOCATION {
            let mut bytes = AlignedBytes::zeroed(entry.length as usize);
            read_exact_or(&mut self.source, bytes.as_mut_slice(), &what)?;
            bytes
        } else {
            // A stream's length is unknown, so a huge declared section is only believed as far
            // as bytes actually arrive: memory grows with the data, not with the claim.
            let mut v = Vec::new();
            (&mut self.source)
                .take(entry.length)
                .read_to_end(&mut v)
                .map_err(ReadFail::Io)?;
            if (v.len() as u64) < entry.length {
                return Err(Fail::from(Problem::Truncated { what }).into());
            }
            AlignedBytes::from_slice(&v)
        };
        self.position = entry.end();
        check_section(index, &entry, &bytes)?;
        let role = if index == 0 {
            let toc = decode_toc(&bytes, entry.offset)?;
            self.roles = validate_toc(&toc, &self.sections)?;
            self.toc = Some(toc);
            SectionRole::Toc
        } else {
            self.roles[index]
        };
        self.next += 1;
        Ok(Some(RawSection {
            path: self.path.clone(),
            offset: entry.offset,
            section: StreamSection {
                index: index as u32,
                role,
                bytes,
            },
        }))
    }
}

/// A section as [`StreamReader::next_raw`] hands it out: checked, its content not decoded yet.
#[derive(Debug)]
pub struct RawSection {
    path: PathBuf,
    offset: u64,
    section: StreamSection,
}

impl RawSection {
    pub fn role(&self) -> SectionRole {
        self.section.role
    }

    /// Decodes and checks the content (a supercompressed level is decompressed) against `toc`,
    /// the stream's validated TOC ([`StreamReader::toc`]).
    pub fn decode(self, toc: &Toc) -> Result<StreamSection, PackError> {
        let Self {
            path,
            offset,
            mut section,
        } = self;
        if section.role != SectionRole::Toc {
            let decoded = decode_content(toc, section.role, &section.bytes).map_err(|f| {
                Fail {
                    offset: f.offset.or(Some(offset)),
                    problem: f.problem,
                }
                .with_path(&path)
            })?;
            if let Some(decoded) = decoded {
                section.bytes = decoded;
            }
        }
        Ok(section)
    }
}
