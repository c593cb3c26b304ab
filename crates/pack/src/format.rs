//! Byte layout of the header and the section table. See `docs/pack-format.md`.

use crate::error::{Fail, Problem};

pub const MAGIC: [u8; 8] = *b"SGPACK\r\n";
/// Bump on any change to the byte layout or to the TOC's types (the golden-bytes test enforces it).
pub const FORMAT_VERSION: u32 = 5;
pub const HEADER_SIZE: u64 = 64;
pub const SECTION_ENTRY_SIZE: u64 = 32;

/// Limits that bound every allocation a reader makes from values in the file.
pub const MAX_SECTIONS: u64 = 1 << 16;
pub const MAX_TOC_BYTES: u64 = 64 << 20;
pub const MAX_SECTION_ALIGN: u64 = 4096;
pub const MAX_TEXTURE_SIZE: u32 = 16384;
pub const MAX_FILE_BYTES: u64 = 1 << 40;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u32)]
pub enum SectionKind {
    Toc = 1,
    Vertices = 2,
    Indices = 3,
    TextureMip = 4,
}

impl SectionKind {
    pub fn from_u32(v: u32) -> Option<Self> {
        Some(match v {
            1 => Self::Toc,
            2 => Self::Vertices,
            3 => Self::Indices,
            4 => Self::TextureMip,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Self::Toc => "toc",
            Self::Vertices => "vertices",
            Self::Indices => "indices",
            Self::TextureMip => "texture-mip",
        }
    }

    /// Alignment the writer gives sections of this kind (enough for zero-copy `f32`/`u32` casts;
    /// vertex data gets 16 for SIMD-friendly loads).
    pub fn alignment(self) -> u64 {
        match self {
            Self::Toc => 8,
            Self::Vertices => 16,
            Self::Indices | Self::TextureMip => 4,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    pub version: u32,
    pub section_count: u32,
    pub file_length: u64,
    pub table_offset: u64,
    pub table_crc: u32,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SectionEntry {
    pub kind: SectionKind,
    pub align: u64,
    pub offset: u64,
    pub length: u64,
    pub crc: u32,
}

pub fn crc32(bytes: &[u8]) -> u32 {
    crc32fast::hash(bytes)
}

pub fn align_up(v: u64, align: u64) -> u64 {
    v.div_ceil(align) * align
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap())
}

fn u64_at(b: &[u8], at: usize) -> u64 {
    u64::from_le_bytes(b[at..at + 8].try_into().unwrap())
}

impl Header {
    pub fn encode(&self) -> [u8; HEADER_SIZE as usize] {
        let mut b = [0u8; HEADER_SIZE as usize];
        b[0..8].copy_from_slice(&MAGIC);
        b[8..12].copy_from_slice(&self.version.to_le_bytes());
        b[12..16].copy_from_slice(&(HEADER_SIZE as u32).to_le_bytes());
        b[16..20].copy_from_slice(&self.section_count.to_le_bytes());
        // 20..24: flags, reserved (zero)
        b[24..32].copy_from_slice(&self.file_length.to_le_bytes());
        b[32..40].copy_from_slice(&self.table_offset.to_le_bytes());
        b[40..44].copy_from_slice(&self.table_crc.to_le_bytes());
        // 44..60: reserved (zero)
        let crc = crc32(&b[0..60]);
        b[60..64].copy_from_slice(&crc.to_le_bytes());
        b
    }

    /// Decodes and checks the header. `available` is the file length when known (mmap) or
    /// `None` for a stream.
    pub fn decode(b: &[u8], available: Option<u64>) -> Result<Self, Fail> {
        if (b.len() as u64) < HEADER_SIZE {
            return Err(Problem::TooShort {
                len: b.len() as u64,
                need: HEADER_SIZE,
            }
            .into());
        }
        let magic: [u8; 8] = b[0..8].try_into().unwrap();
        if magic != MAGIC {
            return Err(Fail::at(0, Problem::BadMagic { found: magic }));
        }
        let version = u32_at(b, 8);
        let stored = u32_at(b, 60);
        let computed = crc32(&b[0..60]);
        if version != FORMAT_VERSION {
            // Only trust the version field when the header is intact; a bit flip there is
            // corruption, not an old pack.
            if stored == computed {
                return Err(Fail::at(
                    8,
                    Problem::Version {
                        found: version,
                        expected: FORMAT_VERSION,
                    },
                ));
            }
        }
        if stored != computed {
            return Err(Fail::at(
                60,
                Problem::Checksum {
                    what: "header".into(),
                    stored,
                    computed,
                },
            ));
        }
        let header_size = u32_at(b, 12) as u64;
        if header_size != HEADER_SIZE {
            return Err(Fail::at(
                12,
                Problem::Field {
                    what: "header size".into(),
                    found: header_size,
                    expected: HEADER_SIZE,
                },
            ));
        }
        // The offset of the first byte that is not zero, so a tool reading the message finds
        // it (the flags are at 20, the reserved run at 44).
        if let Some(at) = (20..24).chain(44..60).find(|&i| b[i] != 0) {
            return Err(Fail::at(at as u64, Problem::NonZeroPadding));
        }
        let section_count = u32_at(b, 16);
        if section_count == 0 || section_count as u64 > MAX_SECTIONS {
            return Err(Fail::at(
                16,
                Problem::Range {
                    what: "section count".into(),
                    found: section_count as u64,
                    min: 1,
                    max: MAX_SECTIONS,
                },
            ));
        }
        let file_length = u64_at(b, 24);
        if file_length > MAX_FILE_BYTES {
            return Err(Fail::at(
                24,
                Problem::Limit {
                    what: "file length".into(),
                    found: file_length,
                    max: MAX_FILE_BYTES,
                },
            ));
        }
        if let Some(actual) = available
            && actual != file_length
        {
            return Err(if actual > file_length {
                Fail::at(file_length, Problem::TrailingData)
            } else {
                Fail::at(
                    24,
                    Problem::Length {
                        declared: file_length,
                        actual,
                    },
                )
            });
        }
        let table_offset = u64_at(b, 32);
        if table_offset != HEADER_SIZE {
            return Err(Fail::at(
                32,
                Problem::Field {
                    what: "table offset".into(),
                    found: table_offset,
                    expected: HEADER_SIZE,
                },
            ));
        }
        let table_end = table_offset + section_count as u64 * SECTION_ENTRY_SIZE;
        if table_end > file_length {
            return Err(Fail::at(
                16,
                Problem::TableTooLong {
                    sections: section_count as u64,
                    end: table_end,
                    length: file_length,
                },
            ));
        }
        Ok(Self {
            version,
            section_count,
            file_length,
            table_offset,
            table_crc: u32_at(b, 40),
        })
    }

    pub fn table_len(&self) -> u64 {
        self.section_count as u64 * SECTION_ENTRY_SIZE
    }

    /// Where the first section may start.
    pub fn data_start(&self) -> u64 {
        self.table_offset + self.table_len()
    }
}

impl SectionEntry {
    pub fn encode(&self, out: &mut Vec<u8>) {
        out.extend_from_slice(&(self.kind as u32).to_le_bytes());
        out.extend_from_slice(&(self.align as u32).to_le_bytes());
        out.extend_from_slice(&self.offset.to_le_bytes());
        out.extend_from_slice(&self.length.to_le_bytes());
        out.extend_from_slice(&self.crc.to_le_bytes());
        out.extend_from_slice(&0u32.to_le_bytes());
    }

    pub fn end(&self) -> u64 {
        self.offset + self.length
    }
}

/// Decodes the section table and checks the layout of the sections in the file: known kinds,
/// power-of-two alignment, sections in file order without overlap, each starting at the first
/// aligned offset after its predecessor (so the only gaps are padding), the last one ending
/// exactly at the end of the file.
pub fn decode_table(header: &Header, table: &[u8]) -> Result<Vec<SectionEntry>, Fail> {
    debug_assert_eq!(table.len() as u64, header.table_len());
    let computed = crc32(table);
    if computed != header.table_crc {
        return Err(Fail::at(
            header.table_offset,
            Problem::Checksum {
                what: "section table".into(),
                stored: header.table_crc,
                computed,
            },
        ));
    }
    let mut entries: Vec<SectionEntry> = Vec::with_capacity(header.section_count as usize);
    let mut cursor = header.data_start();
    for (i, chunk) in table.chunks_exact(SECTION_ENTRY_SIZE as usize).enumerate() {
        let index = i as u32;
        let at = header.table_offset + i as u64 * SECTION_ENTRY_SIZE;
        let kind_raw = u32_at(chunk, 0);
        let kind = SectionKind::from_u32(kind_raw).ok_or_else(|| {
            Fail::at(
                at,
                Problem::UnknownSection {
                    index,
                    kind: kind_raw,
                },
            )
        })?;
        let align = u32_at(chunk, 4) as u64;
        if align == 0 || !align.is_power_of_two() || align > MAX_SECTION_ALIGN {
            return Err(Fail::at(
                at + 4,
                Problem::Field {
                    what: format!("section {index} alignment"),
                    found: align,
                    expected: kind.alignment(),
                },
            ));
        }
        if align != kind.alignment() {
            return Err(Fail::at(
                at + 4,
                Problem::Field {
                    what: format!("section {index} alignment"),
                    found: align,
                    expected: kind.alignment(),
                },
            ));
        }
        let offset = u64_at(chunk, 8);
        let length = u64_at(chunk, 16);
        let crc = u32_at(chunk, 24);
        if u32_at(chunk, 28) != 0 {
            return Err(Fail::at(at + 28, Problem::NonZeroPadding));
        }
        if !offset.is_multiple_of(align) {
            return Err(Fail::at(
                at + 8,
                Problem::Alignment {
                    index,
                    offset,
                    align,
                },
            ));
        }
        let expected_offset = align_up(cursor, align);
        let end = offset.saturating_add(length);
        // A section not where the one before ends is told apart from one running past the
        // file: a shortened length in one entry was blamed on the next section.
        if offset != expected_offset {
            let after = match entries.last() {
                Some(prev) => format!(
                    "where section {} ({}..{}, {} bytes long) ends, aligned to {align}",
                    index - 1,
                    prev.offset,
                    prev.offset + prev.length,
                    prev.length
                ),
                None => format!("after the header and the section table, aligned to {align}"),
            };
            return Err(Fail::at(
                at + 8,
                Problem::SectionPlace {
                    index,
                    start: offset,
                    expected: expected_offset,
                    after,
                },
            ));
        }
        if end > header.file_length {
            return Err(Fail::at(
                at + 8,
                Problem::SectionBounds {
                    index,
                    start: offset,
                    end,
                    min: expected_offset,
                    max: header.file_length,
                },
            ));
        }
        cursor = end;
        entries.push(SectionEntry {
            kind,
            align,
            offset,
            length,
            crc,
        });
    }
    if cursor != header.file_length {
        return Err(Fail::at(cursor, Problem::TrailingData));
    }
    if entries[0].kind != SectionKind::Toc {
        return Err(Fail::toc("section 0 must be the table of contents"));
    }
    if entries[0].length > MAX_TOC_BYTES {
        return Err(Problem::Limit {
            what: "table of contents size".into(),
            found: entries[0].length,
            max: MAX_TOC_BYTES,
        }
        .into());
    }
    Ok(entries)
}

/// Checks a section's bytes against its table entry.
pub fn check_section(index: usize, entry: &SectionEntry, bytes: &[u8]) -> Result<(), Fail> {
    let computed = crc32(bytes);
    if computed != entry.crc {
        return Err(Fail::at(
            entry.offset,
            Problem::Checksum {
                what: format!("section {index} ({})", entry.kind.name()),
                stored: entry.crc,
                computed,
            },
        ));
    }
    Ok(())
}
