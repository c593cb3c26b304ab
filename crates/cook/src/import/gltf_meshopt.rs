//! Buffer views compressed with `EXT_meshopt_compression` or its ratified successor
//! `KHR_meshopt_compression`: what gltfpack writes with `-c` and `-cc`, and most web
//! pipelines after it. The parent view only names where the decoded bytes would sit, often in
//! a placeholder buffer with no data at all; the extension names the compressed bytes.

use serde_json::Value;

/// The extension names, the ratified one last; their JSON is the same.
pub(super) const NAMES: [&str; 2] = ["EXT_meshopt_compression", "KHR_meshopt_compression"];

/// The most bytes a file's compressed views may decode to, all together: a hostile file may
/// claim any `count`, or point many views at the same bytes. A million-triangle mesh decodes
/// to about 50 MB.
pub(super) const MAX_TOTAL_DECODED: u64 = 1 << 30;
/// The most one view may expand: a stream of bytes that never change costs the attribute
/// codec almost nothing, and its version 1 comes near this ratio.
const MAX_RATIO: u64 = 1024;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
    Color,
}

/// One compressed view, as its extension JSON describes it.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Compressed {
    /// The buffer holding the compressed bytes.
    pub buffer: usize,
    offset: usize,
    length: usize,
    stride: usize,
    count: usize,
    mode: Mode,
    filter: Filter,
}

/// The compression extension of a view's JSON, under either name.
fn extension(extensions: Option<&serde_json::Map<String, Value>>) -> Option<&Value> {
    let e = extensions?;
    NAMES.iter().find_map(|n| e.get(*n))
}

/// The view's compression, if it has one; an error names the bad field.
pub(super) fn of_view(view: &gltf::buffer::View) -> Result<Option<Compressed>, String> {
    let Some(e) = extension(view.extensions()) else {
        return Ok(None);
    };
    let int = |key: &str, default: Option<u64>| -> Result<usize, String> {
        match e.get(key) {
            Some(v) => v
                .as_u64()
                .and_then(|n| usize::try_from(n).ok())
                .ok_or_else(|| format!("`{key}` is {v}, not a non-negative integer")),
            None => default
                .map(|d| d as usize)
                .ok_or_else(|| format!("`{key}` is missing")),
        }
    };
    let text = |key: &str| e.get(key).and_then(Value::as_str);
    let mode = match text("mode") {
        Some("ATTRIBUTES") => Mode::Attributes,
        Some("TRIANGLES") => Mode::Triangles,
        Some("INDICES") => Mode::Indices,
        other => {
            return Err(format!(
                "`mode` is {other:?}, not ATTRIBUTES, TRIANGLES or INDICES"
            ));
        }
    };
    let filter = match text("filter") {
        None | Some("NONE") => Filter::None,
        Some("OCTAHEDRAL") => Filter::Octahedral,
        Some("QUATERNION") => Filter::Quaternion,
        Some("EXPONENTIAL") => Filter::Exponential,
        Some("COLOR") => Filter::Color,
        Some(other) => return Err(format!("`filter` is {other:?}, which no decoder knows")),
    };
    let c = Compressed {
        buffer: int("buffer", None)?,
        offset: int("byteOffset", Some(0))?,
        length: int("byteLength", None)?,
        stride: int("byteStride", None)?,
        count: int("count", None)?,
        mode,
        filter,
    };
    let s = c.stride;
    let shape_ok = match (c.mode, c.filter) {
        (Mode::Attributes, Filter::None | Filter::Exponential) => {
            s.is_multiple_of(4) && (4..=256).contains(&s)
        }
        (Mode::Attributes, Filter::Octahedral | Filter::Color) => s == 4 || s == 8,
        (Mode::Attributes, Filter::Quaternion) => s == 8,
        (Mode::Triangles, Filter::None) => (s == 2 || s == 4) && c.count.is_multiple_of(3),
        (Mode::Indices, Filter::None) => s == 2 || s == 4,
        _ => false,
    };
    if !shape_ok {
        return Err(format!(
            "mode {:?} with filter {:?} cannot have byteStride {s} and count {}",
            c.mode, c.filter, c.count
        ));
    }
    if let Some(v) = view.stride().filter(|&v| v != s) {
        return Err(format!("byteStride {s} differs from the view's own {v}"));
    }
    let decoded = (c.count as u64).saturating_mul(s as u64);
    if decoded != view.length() as u64 {
        return Err(format!(
            "{} elements of {s} bytes do not fill the view's {} bytes",
            c.count,
            view.length()
        ));
    }
    if decoded > MAX_TOTAL_DECODED || decoded > (c.length as u64).saturating_mul(MAX_RATIO) + 4096 {
        return Err(format!(
            "{decoded} bytes claimed from {} compressed ones",
            c.length
        ));
    }
    Ok(Some(c))
}

impl Compressed {
    /// The compressed bytes within `buffer` (the buffer this view's extension names).
    pub(super) fn source<'a>(&self, buffer: &'a [u8]) -> Result<&'a [u8], String> {
        self.offset
            .checked_add(self.length)
            .and_then(|end| buffer.get(self.offset..end))
            .ok_or_else(|| {
                format!(
                    "compressed bytes {}..+{} lie outside buffer {} of {} bytes",
                    self.offset,
                    self.length,
                    self.buffer,
                    buffer.len()
                )
            })
    }

    /// The view's bytes, decoded and filtered, little-endian as an uncompressed view holds them.
    pub(super) fn decode(&self, source: &[u8]) -> Result<Vec<u8>, String> {
        let failed = |e: meshopt::Error| format!("the {:?} stream does not decode: {e}", self.mode);
        use meshopt::encoding::{decode_index_buffer, decode_index_sequence};
        let (n, f) = (self.count, failed);
        match (self.mode, self.stride) {
            (Mode::Triangles, 2) => Ok(le_bytes(
                decode_index_buffer(source, n).map_err(f)?,
                u16::to_le_bytes,
            )),
            (Mode::Triangles, _) => Ok(le_bytes(
                decode_index_buffer(source, n).map_err(f)?,
                u32::to_le_bytes,
            )),
            (Mode::Indices, 2) => Ok(le_bytes(
                decode_index_sequence(source, n).map_err(f)?,
                u16::to_le_bytes,
            )),
            (Mode::Indices, _) => Ok(le_bytes(
                decode_index_sequence(source, n).map_err(f)?,
                u32::to_le_bytes,
            )),
            (Mode::Attributes, stride) => {
                // Words, not bytes: the filters read 16- and 32-bit lanes in place, which wants
                // their alignment, and every attribute stride is a multiple of four.
                let mut words = vec![0u32; self.count * stride / 4];
                // SAFETY: `words` holds exactly `count * stride` bytes, the size the decoder
                // writes and the filters rewrite; meshoptimizer's decoders are documented as
                // safe on untrusted input (a bad stream returns an error code).
                let code = unsafe {
                    meshopt::ffi::meshopt_decodeVertexBuffer(
                        words.as_mut_ptr().cast(),
                        self.count,
                        stride,
                        source.as_ptr(),
                        source.len(),
                    )
                };
                if code != 0 {
                    return Err(failed(meshopt::Error::Native(code)));
                }
                let data = words.as_mut_ptr().cast();
                // SAFETY: as above; each filter's stride was checked against its kind in
                // `of_view` (octahedral and colour 4 or 8, quaternion 8, exponential any
                // multiple of 4).
                unsafe {
                    match self.filter {
                        Filter::None => {}
                        Filter::Octahedral => {
                            meshopt::ffi::meshopt_decodeFilterOct(data, self.count, stride)
                        }
                        Filter::Quaternion => {
                            meshopt::ffi::meshopt_decodeFilterQuat(data, self.count, stride)
                        }
                        Filter::Exponential => {
                            meshopt::ffi::meshopt_decodeFilterExp(data, self.count, stride)
                        }
                        Filter::Color => {
                            meshopt::ffi::meshopt_decodeFilterColor(data, self.count, stride)
                        }
                    }
                }
                Ok(words.iter().flat_map(|w| w.to_ne_bytes()).collect())
            }
        }
    }
}

fn le_bytes<T: Copy, const N: usize>(values: Vec<T>, bytes: fn(T) -> [u8; N]) -> Vec<u8> {
    values.into_iter().flat_map(bytes).collect()
}
