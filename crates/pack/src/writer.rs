//! Deterministic pack writer. The caller hands over the TOC and the bulk data; the writer assigns
//! section indices in streaming order, so no caller can get the order wrong.

use std::io::Write;
use std::path::Path;

use crate::error::PackError;
use crate::format::{
    FORMAT_VERSION, HEADER_SIZE, Header, SECTION_ENTRY_SIZE, SectionEntry, SectionKind, align_up,
    crc32,
};
use crate::toc::Toc;
use crate::validate::encode_toc;

/// Bulk data of one mesh, raw little-endian bytes laid out as its `VertexLayout` says.
#[derive(Clone, Debug, Default)]
pub struct MeshData {
    pub vertices: Vec<u8>,
    pub indices: Vec<u8>,
}

/// Everything that goes into the bulk sections, parallel to `Toc::meshes` and `Toc::textures`.
#[derive(Clone, Debug, Default)]
pub struct PackData {
    pub meshes: Vec<MeshData>,
    /// Per texture, per mip level (level 0 first), the stored bytes: tightly packed RGBA8 rows,
    /// or 4x4 blocks in rows of blocks for the block formats (`Texture::level_bytes`), each
    /// level compressed as the texture's `supercompression` says.
    pub textures: Vec<Vec<Vec<u8>>>,
}

/// Encodes a pack in memory. Overwrites every section index in `toc`; validates the result with
/// the reader's own checks, so an invalid pack is never produced.
pub fn encode(toc: Toc, data: &PackData) -> Result<Vec<u8>, PackError> {
    let out = assemble(toc, data)?;
    crate::reader::validate_bytes(&out).map_err(|e| e.with_path(Path::new(IN_MEMORY)))?;
    Ok(out)
}

/// What a pack not yet on disk is called in errors.
const IN_MEMORY: &str = "<pack being written>";

/// The pack's bytes, not yet validated.
fn assemble(mut toc: Toc, data: &PackData) -> Result<Vec<u8>, PackError> {
    let memory = Path::new(IN_MEMORY);
    if data.meshes.len() != toc.meshes.len() || data.textures.len() != toc.textures.len() {
        return Err(crate::error::Fail::toc(format!(
            "writer got data for {} meshes and {} textures, TOC has {} and {}",
            data.meshes.len(),
            data.textures.len(),
            toc.meshes.len(),
            toc.textures.len()
        ))
        .with_path(memory));
    }
    // Streaming order: TOC, geometry, then mips by size (smallest first), ties by texture and
    // level so the order is total and deterministic. The size is the level's texel count (as
    // RGBA8 bytes), so supercompression never puts a texture's large level before its small
    // ones, and every texture gains resolution together whatever its format: ordered by stored
    // bytes, BC7 levels (a quarter of RGBA8's) came a level early, and a block-compressed
    // pack's first frame waited for more of them than an uncompressed pack's did.
    let mut blobs: Vec<(SectionKind, &[u8])> = Vec::new();
    for (mesh, d) in toc.meshes.iter_mut().zip(&data.meshes) {
        mesh.vertex_section = blobs.len() as u32 + 1;
        blobs.push((SectionKind::Vertices, &d.vertices));
        mesh.index_section = blobs.len() as u32 + 1;
        blobs.push((SectionKind::Indices, &d.indices));
    }
    let mut mips: Vec<(u64, usize, usize)> = Vec::new();
    for (ti, levels) in data.textures.iter().enumerate() {
        if levels.len() != toc.textures[ti].mips.len() {
            return Err(crate::error::Fail::toc(format!(
                "texture {ti}: {} mip levels of data, TOC lists {}",
                levels.len(),
                toc.textures[ti].mips.len()
            ))
            .with_path(memory));
        }
        for level in 0..levels.len() {
            mips.push((toc.textures[ti].level_rgba8_bytes(level), ti, level));
        }
    }
    mips.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)).then(b.2.cmp(&a.2)));
    for &(_, ti, level) in &mips {
        toc.textures[ti].mips[level].section = blobs.len() as u32 + 1;
        blobs.push((SectionKind::TextureMip, &data.textures[ti][level]));
    }

    let toc_bytes = encode_toc(&toc);
    let mut sections: Vec<(SectionKind, &[u8])> = vec![(SectionKind::Toc, &toc_bytes)];
    sections.extend(blobs);

    let count = sections.len() as u64;
    let mut entries = Vec::with_capacity(sections.len());
    let mut cursor = HEADER_SIZE + count * SECTION_ENTRY_SIZE;
    for &(kind, bytes) in &sections {
        let offset = align_up(cursor, kind.alignment());
        entries.push(SectionEntry {
            kind,
            align: kind.alignment(),
            offset,
            length: bytes.len() as u64,
            crc: crc32(bytes),
        });
        cursor = offset + bytes.len() as u64;
    }
    let mut table = Vec::with_capacity((count * SECTION_ENTRY_SIZE) as usize);
    for e in &entries {
        e.encode(&mut table);
    }
    let header = Header {
        version: FORMAT_VERSION,
        section_count: count as u32,
        file_length: cursor,
        table_offset: HEADER_SIZE,
        table_crc: crc32(&table),
    };
    let mut out = Vec::with_capacity(cursor as usize);
    out.extend_from_slice(&header.encode());
    out.extend_from_slice(&table);
    for (e, &(_, bytes)) in entries.iter().zip(&sections) {
        out.resize(e.offset as usize, 0);
        out.extend_from_slice(bytes);
    }
    debug_assert_eq!(out.len() as u64, cursor);
    Ok(out)
}

/// Writes `bytes` to `path` atomically: a temp file in the same directory, fsync, then rename.
/// A failure at any point leaves whatever was at `path` untouched. A symbolic link is
/// followed (the file it names is replaced, the link kept); a device, FIFO or socket at
/// `path` is written as it is (`-o /dev/null` must not replace the device with a file, and
/// `/dev/full` must report its error); a directory is an error.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), PackError> {
    atomic(path, bytes, None)
}

/// [`write_atomic`], running `check` while the temporary file is written and synced (on
/// another thread), and renaming it into place only when `check` succeeds too: the fsync's
/// wait overlaps the check's work, and a failed check leaves `path` untouched.
pub fn write_atomic_checked(
    path: &Path,
    bytes: &[u8],
    check: impl FnOnce() -> Result<(), PackError> + Send,
) -> Result<(), PackError> {
    atomic(path, bytes, Some(Box::new(check)))
}

/// A check to run while the temporary file is written; see [`write_atomic_checked`].
type Check<'a> = Box<dyn FnOnce() -> Result<(), PackError> + Send + 'a>;

/// The temporary file, written and synced (beside `check` when there is one), renamed to
/// `path` only when both succeed.
fn atomic(path: &Path, bytes: &[u8], check: Option<Check<'_>>) -> Result<(), PackError> {
    let io = |source| PackError::Io {
        path: path.to_path_buf(),
        source,
    };
    let target = match destination(path).map_err(io)? {
        Destination::File(target) => target,
        Destination::Special => {
            // No temp file can be renamed over a device: check first, then write.
            if let Some(check) = check {
                check()?;
            }
            let write = || -> std::io::Result<()> {
                let mut f = std::fs::OpenOptions::new().write(true).open(path)?;
                f.write_all(bytes)?;
                f.flush()
            };
            return write().map_err(io);
        }
    };
    let path = target.as_path();
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path.file_name().ok_or_else(|| {
        io(std::io::Error::new(
            std::io::ErrorKind::InvalidInput,
            "output path has no file name",
        ))
    })?;
    sweep_stale_temps(dir, &name.to_string_lossy());
    // Unique per process and call, so concurrent cooks into the same directory never share a
    // temp file.
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let n = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let tmp = dir.join(format!(
        ".{}.tmp-{}-{n}",
        name.to_string_lossy(),
        std::process::id()
    ));
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()
    };
    let (written, checked) = match check {
        // Nothing to overlap with: no thread.
        None => (write(), Ok(())),
        Some(check) => std::thread::scope(|s| {
            let writer = s.spawn(write);
            let checked = check();
            let written = writer
                .join()
                .unwrap_or_else(|_| Err(std::io::Error::other("the pack writer thread panicked")));
            (written, checked)
        }),
    };
    let result = checked.and_then(|()| {
        written
            .and_then(|()| std::fs::rename(&tmp, path))
            .map_err(io)
    });
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}

/// Removes the temp files an earlier write of `name` in `dir` left when its process was killed
/// (SIGKILL, a power cut: nothing of it ran to clean up), each as large as the output. A temp
/// file is stale when the process its name holds is gone (`/proc` says), or, where there is no
/// `/proc`, a day old; a live process's write is never touched. Best effort: errors are ignored.
fn sweep_stale_temps(dir: &Path, name: &str) {
    let prefix = format!(".{name}.tmp-");
    let Ok(listing) = std::fs::read_dir(dir) else {
        return;
    };
    let proc_fs = Path::new("/proc/self").exists();
    for e in listing.flatten() {
        let file = e.file_name();
        let Some(rest) = file.to_str().and_then(|f| f.strip_prefix(&prefix)) else {
            continue;
        };
        let Some(pid) = rest.split('-').next().and_then(|p| p.parse::<u32>().ok()) else {
            continue;
        };
        let stale = if pid == std::process::id() {
            false
        } else if proc_fs {
            !Path::new("/proc").join(pid.to_string()).exists()
        } else {
            e.metadata()
                .and_then(|m| m.modified())
                .ok()
                .and_then(|t| t.elapsed().ok())
                .is_some_and(|age| age > std::time::Duration::from_secs(24 * 3600))
        };
        if stale {
            let _ = std::fs::remove_file(e.path());
        }
    }
}

/// What an output path names once symbolic links are followed.
enum Destination {
    /// A regular file, or nothing yet: written through a temp file and a rename.
    File(std::path::PathBuf),
    /// A device, FIFO or socket: written in place.
    Special,
}

fn destination(path: &Path) -> std::io::Result<Destination> {
    let mut at = path.to_path_buf();
    // As the kernel's own limit on links followed in one lookup.
    for _ in 0..40 {
        let meta = match std::fs::symlink_metadata(&at) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Destination::File(at)),
            Err(e) => return Err(e),
        };
        let kind = meta.file_type();
        if kind.is_symlink() {
            let link = std::fs::read_link(&at)?;
            at = match at.parent() {
                Some(dir) if link.is_relative() => dir.join(link),
                _ => link,
            };
        } else if kind.is_dir() {
            return Err(std::io::Error::new(
                std::io::ErrorKind::IsADirectory,
                "is a directory, not a file to write",
            ));
        } else if kind.is_file() {
            return Ok(Destination::File(at));
        } else {
            return Ok(Destination::Special);
        }
    }
    Err(std::io::Error::other("too many levels of symbolic links"))
}

/// Encodes and writes a pack atomically, validating it with the reader's checks while the
/// file is written and synced; the pack is renamed into place only when valid. Returns the
/// pack's bytes.
pub fn write_pack(path: &Path, toc: Toc, data: &PackData) -> Result<Vec<u8>, PackError> {
    let named = |e: PackError| match e {
        PackError::Invalid {
            offset, problem, ..
        } => PackError::Invalid {
            path: path.to_path_buf(),
            offset,
            problem,
        },
        other => other,
    };
    let bytes = assemble(toc, data).map_err(named)?;
    write_atomic_checked(path, &bytes, || {
        crate::reader::validate_bytes(&bytes)
            .map(drop)
            .map_err(|e| named(e.with_path(path)))
    })?;
    Ok(bytes)
}
