//! Whole-file reader over a memory map (or owned bytes). Everything is validated on open: after
//! `Pack::open` succeeds, every accessor is infallible and every cast is in bounds.

use std::path::{Path, PathBuf};

use rayon::prelude::*;

use crate::error::{Fail, PackError};
use crate::format::{HEADER_SIZE, Header, SectionEntry, check_section, decode_table};
use crate::toc::{IndexFormat, Mesh, Toc};
use crate::validate::{SectionRole, decode_content, decode_toc, validate_toc};

/// Heap bytes aligned to 16, so sections cast with bytemuck like mapped ones do.
#[derive(Clone, Default)]
pub struct AlignedBytes {
    words: Vec<u128>,
    len: usize,
}

impl AlignedBytes {
    pub fn zeroed(len: usize) -> Self {
        Self {
            words: vec![0u128; len.div_ceil(16)],
            len,
        }
    }
    pub fn from_slice(bytes: &[u8]) -> Self {
        let mut b = Self::zeroed(bytes.len());
        b.as_mut_slice().copy_from_slice(bytes);
        b
    }
    pub fn as_slice(&self) -> &[u8] {
        &bytemuck::cast_slice(&self.words)[..self.len]
    }
    pub fn as_mut_slice(&mut self) -> &mut [u8] {
        &mut bytemuck::cast_slice_mut(&mut self.words)[..self.len]
    }
}

impl std::ops::Deref for AlignedBytes {
    type Target = [u8];
    fn deref(&self) -> &[u8] {
        self.as_slice()
    }
}

impl std::fmt::Debug for AlignedBytes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "AlignedBytes({} bytes)", self.len)
    }
}

enum Backing {
    Map(memmap2::Mmap),
    Owned(AlignedBytes),
}

impl std::fmt::Debug for Pack {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Pack")
            .field("path", &self.path)
            .field("sections", &self.sections.len())
            .finish_non_exhaustive()
    }
}

/// A validated pack.
pub struct Pack {
    path: PathBuf,
    backing: Backing,
    header: Header,
    sections: Vec<SectionEntry>,
    roles: Vec<SectionRole>,
    toc: Toc,
    /// Per section: the decoded level of a supercompressed texture, decoded (and so checked)
    /// once when the pack is opened.
    decoded: Vec<Option<AlignedBytes>>,
}

struct Parsed {
    header: Header,
    sections: Vec<SectionEntry>,
    roles: Vec<SectionRole>,
    toc: Toc,
    decoded: Vec<Option<AlignedBytes>>,
}

fn parse(bytes: &[u8]) -> Result<Parsed, Fail> {
    let header = Header::decode(bytes, Some(bytes.len() as u64))?;
    let table_start = header.table_offset as usize;
    let table = &bytes[table_start..table_start + header.table_len() as usize];
    let sections = decode_table(&header, table)?;
    // Padding between the table and each section must be zero.
    let mut cursor = header.data_start() as usize;
    for (i, s) in sections.iter().enumerate() {
        if bytes[cursor..s.offset as usize].iter().any(|&b| b != 0) {
            return Err(Fail::at(
                cursor as u64,
                crate::error::Problem::NonZeroPadding,
            ));
        }
        check_section(i, s, &bytes[s.offset as usize..s.end() as usize])?;
        cursor = s.end() as usize;
    }
    let toc_entry = &sections[0];
    let toc = decode_toc(
        &bytes[toc_entry.offset as usize..toc_entry.end() as usize],
        toc_entry.offset,
    )?;
    let roles = validate_toc(&toc, &sections)?;
    // Sections decode side by side (zstd levels most of the time: the writer's check of the
    // default scene's pack took 35 ms on one thread); the first failure in section order is
    // the one reported, whatever finished first.
    let decoded: Vec<Result<_, Fail>> = (sections.par_iter().zip(&roles))
        .map(|(s, &role)| {
            decode_content(&toc, role, &bytes[s.offset as usize..s.end() as usize]).map_err(|f| {
                Fail {
                    offset: f.offset.or(Some(s.offset)),
                    problem: f.problem,
                }
            })
        })
        .collect();
    let decoded = decoded.into_iter().collect::<Result<_, _>>()?;
    Ok(Parsed {
        header,
        sections,
        roles,
        toc,
        decoded,
    })
}

/// Validates a whole pack held in memory (what the writer checks its output with).
pub(crate) fn validate_bytes(bytes: &[u8]) -> Result<Toc, crate::error::Fail> {
    parse(bytes).map(|p| p.toc)
}

impl Pack {
    /// Maps and validates a pack file.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, PackError> {
        let path = path.as_ref();
        let io = |source| PackError::Io {
            path: path.to_path_buf(),
            source,
        };
        let file = std::fs::File::open(path).map_err(io)?;
        let meta = file.metadata().map_err(io)?;
        if meta.is_dir() {
            // Opening a directory succeeds and mapping it fails with "No such device".
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "is a directory, not a pack file",
            )));
        }
        if !meta.is_file() {
            // A pipe or a device reports no length: `/dev/zero` was read to the end of memory
            // before its magic was looked at, and a FIFO cannot be mapped.
            return Err(io(std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                "is not a regular file (a pipe or a device); a pack is read in place, from a file",
            )));
        }
        let len = meta.len();
        if len < HEADER_SIZE {
            // Too short to be a pack; also avoids mapping an empty file, which fails on some
            // platforms with a confusing error.
            let mut bytes = Vec::new();
            std::io::Read::read_to_end(&mut &file, &mut bytes).map_err(io)?;
            return Self::from_bytes(path, &bytes);
        }
        // SAFETY: the map is read-only. A file truncated or rewritten by another process while
        // mapped is outside what any mmap-based reader can defend against; the cooker replaces
        // packs by rename, so its own writes never alter a mapped file.
        let map = unsafe { memmap2::Mmap::map(&file) }.map_err(io)?;
        let p = parse(&map).map_err(|f| f.with_path(path))?;
        Ok(Self::from_parsed(path, Backing::Map(map), p))
    }

    /// Validates a pack from bytes; `path` names it in errors.
    pub fn from_bytes(path: impl AsRef<Path>, bytes: &[u8]) -> Result<Self, PackError> {
        let path = path.as_ref();
        let p = parse(bytes).map_err(|f| f.with_path(path))?;
        Ok(Self::from_parsed(
            path,
            Backing::Owned(AlignedBytes::from_slice(bytes)),
            p,
        ))
    }

    fn from_parsed(path: &Path, backing: Backing, p: Parsed) -> Self {
        Self {
            path: path.to_path_buf(),
            backing,
            header: p.header,
            sections: p.sections,
            roles: p.roles,
            toc: p.toc,
            decoded: p.decoded,
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }
    pub fn toc(&self) -> &Toc {
        &self.toc
    }
    pub fn header(&self) -> &Header {
        &self.header
    }
    pub fn sections(&self) -> &[SectionEntry] {
        &self.sections
    }
    pub fn roles(&self) -> &[SectionRole] {
        &self.roles
    }
    pub fn bytes(&self) -> &[u8] {
        match &self.backing {
            Backing::Map(m) => m,
            Backing::Owned(b) => b,
        }
    }

    /// A section's bytes as stored in the file (a supercompressed level's zstd frame).
    pub fn section_bytes(&self, index: u32) -> &[u8] {
        let s = &self.sections[index as usize];
        &self.bytes()[s.offset as usize..s.end() as usize]
    }

    /// A section's content: the stored bytes, or a supercompressed level's decoded bytes.
    pub fn section_data(&self, index: u32) -> &[u8] {
        match &self.decoded[index as usize] {
            Some(d) => d,
            None => self.section_bytes(index),
        }
    }

    pub fn vertex_bytes(&self, mesh: &Mesh) -> &[u8] {
        self.section_bytes(mesh.vertex_section)
    }

    /// Indices widened to u32 (borrowed when stored as u32).
    pub fn indices(&self, mesh: &Mesh) -> std::borrow::Cow<'_, [u32]> {
        let b = self.section_bytes(mesh.index_section);
        match mesh.index_format {
            IndexFormat::U32 => std::borrow::Cow::Borrowed(bytemuck::cast_slice(b)),
            IndexFormat::U16 => std::borrow::Cow::Owned(
                bytemuck::cast_slice::<u8, u16>(b)
                    .iter()
                    .map(|&i| i as u32)
                    .collect(),
            ),
        }
    }

    /// A level's bytes in its texture's format (decoded if supercompressed).
    pub fn mip_bytes(&self, texture: usize, level: usize) -> &[u8] {
        self.section_data(self.toc.textures[texture].mips[level].section)
    }
}
