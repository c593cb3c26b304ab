//! The stained-glass pack format: one file holding a scene's cooked geometry and textures.
//!
//! Layout (all integers little endian; full description in `docs/pack-format.md`):
//! a 64-byte header (magic, version, section count, file length, table CRC, header CRC), a
//! table of 32-byte section entries (kind, alignment, offset, length, CRC-32), then the
//! sections in streaming order: the bincode-encoded [`Toc`], geometry, then texture mips from
//! the smallest to the largest. Padding and reserved bytes are zero, and every byte of the file
//! is covered by a CRC-32 or a zero/structure check, so any single flipped bit is detected.

mod error;
pub mod format;
mod reader;
mod stream;
#[doc(hidden)]
pub mod testing;
pub mod texels;
pub mod toc;
mod validate;
pub mod vertex;
mod writer;

pub use error::{PackError, Problem};
pub use format::{FORMAT_VERSION, SectionEntry, SectionKind};
pub use reader::{AlignedBytes, Pack};
pub use stream::{RawSection, StreamReader, StreamSection};
pub use toc::*;
pub use validate::{SectionRole, encode_toc};
pub use writer::{MeshData, PackData, encode, write_atomic, write_pack};
