//! Wavefront OBJ import.
//!
//! The geometry parser is our own rather than tobj's: errors must name the line (tobj reports
//! an out-of-range index without one), tagging needs `g`, `o` and `usemtl` names kept apart
//! (tobj folds groups and objects into one model name), n-gons must be ear-clipped rather than
//! fanned, and line and point elements must be skipped with a warning. MTL files are still read
//! with tobj's MTL parser.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use super::{
    Corner, Corners, ImageRef, Imported, Indices, NONE, Names, Part, SourceMaterial, Warning,
    append, text,
};
use crate::CookError;
use crate::triangulate::triangulate;

pub fn import(path: &Path, given: Option<text::TextEncoding>) -> Result<Imported, CookError> {
    use std::io::Read;
    let io = |source| CookError::Io {
        path: path.to_path_buf(),
        source,
    };
    let mut file = std::fs::File::open(path).map_err(io)?;
    let size = file.metadata().map_err(io)?.len();
    if size >= PARALLEL_BYTES as u64 {
        // A file under one block is read into a buffer of its own size.
        let block = BLOCK_BYTES.min(
            usize::try_from(size)
                .unwrap_or(usize::MAX)
                .saturating_add(1),
        );
        return parse_stream(path, &mut file, size, CHUNK_BYTES, block, given).map(place_textures);
    }
    let mut bytes = Vec::with_capacity(size as usize);
    file.read_to_end(&mut bytes).map_err(io)?;
    if let Some(e) = not_text(path, &bytes, true) {
        return Err(e);
    }
    parse_with(path, &bytes, given)
}

/// What Notepad and some Windows exporters put before a UTF-8 file's first statement.
const UTF8_BOM: &[u8] = b"\xEF\xBB\xBF";

/// UTF-16 (what some Windows tools save) would parse as a stream of unknown statements and
/// cook to nothing; says what it is instead. `start`: `bytes` begin the file.
fn not_text(path: &Path, bytes: &[u8], start: bool) -> Option<CookError> {
    let bom = start && (bytes.starts_with(&[0xFF, 0xFE]) || bytes.starts_with(&[0xFE, 0xFF]));
    (bom || bytes.contains(&0)).then(|| {
        bad(
            path,
            1,
            "the file is UTF-16 or binary, not an ASCII/UTF-8 OBJ: save it as UTF-8",
        )
    })
}

fn bad(path: &Path, line: usize, message: impl Into<String>) -> CookError {
    CookError::Source {
        path: path.to_path_buf(),
        line: Some(line),
        message: message.into(),
    }
}

fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace())
        .filter(|t| !t.is_empty())
}

fn text(t: &[u8]) -> String {
    String::from_utf8_lossy(t).into_owned()
}

/// A name: escaped where it is not UTF-8, and decoded once the file is read
/// ([`Statements::decode_names`]).
fn name(t: &[u8]) -> String {
    text::escaped(t).into_owned()
}

pub(crate) fn parse_f32(t: &[u8]) -> Option<f32> {
    simple_f32(t).or_else(|| std::str::from_utf8(t).ok()?.parse().ok())
}

/// Powers of ten a float holds exactly (5^10 < 2^24).
const POW10: [f32; 11] = [1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10];

/// The common case of [`parse_f32`] without the general algorithm: a decimal (sign, digits,
/// point, digits, exponent, in `str::parse`'s grammar) whose digits form an integer `m` below
/// 2^24 and whose decimal exponent `e` is within ±10. Then `m` and `10^|e|` are exact floats
/// and one multiply or divide rounds once, correctly: the value `str::parse` gives. Anything
/// else is `None`, left to `str::parse` (which also rejects what is not a number).
fn simple_f32(t: &[u8]) -> Option<f32> {
    let (negative, rest) = match t {
        [b'-', r @ ..] => (true, r),
        [b'+', r @ ..] => (false, r),
        _ => (false, t),
    };
    // Integer digits, then fraction digits, each a run of its own: one test a byte. `scan`
    // appends the digits from `i` on to `m`, and returns where they end.
    let scan = |mut i: usize, mut m: u64| {
        while let Some(d @ 0..=9) = rest.get(i).map(|b| b.wrapping_sub(b'0')) {
            m = m.wrapping_mul(10).wrapping_add(d as u64);
            i += 1;
        }
        (i, m)
    };
    let (mut i, mut m) = scan(0, 0);
    let mut digits = i;
    let mut fraction = 0i32;
    if rest.get(i) == Some(&b'.') {
        let (end, with_fraction) = scan(i + 1, m);
        fraction = (end - i - 1) as i32;
        digits += end - i - 1;
        (i, m) = (end, with_fraction);
    }
    // Up to 19 digits cannot wrap a u64, and `m` only grows digit by digit, so one test at
    // the end rejects what any prefix over 2^24 would have.
    if digits == 0 || digits > 19 || m >= 1 << 24 {
        return None;
    }
    let mut rest = &rest[i..];
    let mut exponent = 0i32;
    if let [b'e' | b'E', r @ ..] = rest {
        let (sign, mut r) = match r {
            [b'-', r @ ..] => (-1, r),
            [b'+', r @ ..] => (1, r),
            _ => (1, r),
        };
        let mut any = false;
        while let [b @ b'0'..=b'9', rr @ ..] = r {
            exponent = (exponent * 10 + (b - b'0') as i32).min(1000);
            any = true;
            r = rr;
        }
        if !any {
            return None;
        }
        exponent *= sign;
        rest = r;
    }
    if !rest.is_empty() {
        return None;
    }
    let e = exponent - fraction;
    let v = m as f32;
    let v = match e {
        0..=10 => v * POW10[e as usize],
        -10..=-1 => v / POW10[(-e) as usize],
        _ => return None,
    };
    Some(if negative { -v } else { v })
}

/// The same integers `str::parse::<i64>` accepts (optional sign, decimal digits, no
/// overflow), read straight from the bytes: face indices are most of an OBJ's tokens.
fn parse_i64(t: &[u8]) -> Option<i64> {
    let (negative, digits) = match t {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, t),
    };
    if digits.is_empty() {
        return None;
    }
    // Up to 18 digits cannot overflow: no check per digit on the common path.
    if digits.len() <= 18 {
        let mut v: i64 = 0;
        for &b in digits {
            let d = b.wrapping_sub(b'0');
            if d > 9 {
                return None;
            }
            v = v * 10 + d as i64;
        }
        return Some(if negative { -v } else { v });
    }
    let mut v: i64 = 0;
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        // Accumulate negatively so i64::MIN parses too.
        v = v.checked_mul(10)?.checked_sub(d as i64)?;
    }
    if negative { Some(v) } else { v.checked_neg() }
}

fn trim(mut s: &[u8]) -> &[u8] {
    while let [first, rest @ ..] = s {
        if first.is_ascii_whitespace() {
            s = rest
        } else {
            break;
        }
    }
    while let [rest @ .., last] = s {
        if last.is_ascii_whitespace() {
            s = rest
        } else {
            break;
        }
    }
    s
}

/// (material, group, object) names of a part.
type PartKey = (Option<String>, Option<String>, Option<String>);

/// Parser state: the source names in effect and the part they map to.
#[derive(Default)]
struct State {
    material: Option<String>,
    group: Option<String>,
    object: Option<String>,
    part: Option<u32>,
    parts: HashMap<PartKey, u32>,
}

/// From this size on a file is read in chunks on every thread. With the cooker's allocator
/// (mimalloc) the 2.4 MB bunny's import went from 6.0 to 5.1 ms split in half-megabyte chunks;
/// with glibc's it had been slower than line by line, so the bar used to be 8 MB.
const PARALLEL_BYTES: usize = 1 << 20;

/// Bytes per chunk, at least (a chunk ends at a line's end).
const CHUNK_BYTES: usize = 1 << 19;

/// A statement other than a vertex attribute or a face, in file order.
enum Statement {
    Group(Option<String>),
    Object(Option<String>),
    Usemtl(String),
    Mtllib(Vec<u8>),
    Line,
    Point,
    Unknown(String),
}

/// A face as read: its line in the chunk and its number of corners, which follow the previous
/// face's in [`Chunk::raw`]. Eight bytes: a large OBJ's faces are held until the file's end.
#[derive(Clone, Copy)]
struct Face {
    line: u32,
    /// The corner count, with [`BROKEN`] set for a face cut short by a field that is not an
    /// index (its corners are only checked).
    len: u32,
}

const BROKEN: u32 = 1 << 31;

impl Face {
    fn corners(self) -> usize {
        (self.len & !BROKEN) as usize
    }

    fn broken(self) -> bool {
        self.len & BROKEN != 0
    }
}

/// What one run of lines holds, read without knowing the lines before it: attribute arrays,
/// faces with unresolved indices, the other statements (each with the number of faces before
/// it), and the first error that stopped the reading, if any.
#[derive(Default)]
struct Chunk {
    lines: usize,
    positions: Vec<[f32; 3]>,
    /// Vertex colours as written, parallel to `positions` up to the last one with a colour.
    colours: Vec<[f32; 3]>,
    uvs: Vec<[f32; 2]>,
    normals: Vec<[f32; 3]>,
    /// Each face corner's indices as written ([`ABSENT`] for a missing field, [`WIDE`] for
    /// one in `wide`): only the vertex index a corner until a corner has more
    /// (`three_fields`), then all three. i32 rather than i64 took the 819k-triangle grid's
    /// peak heap from 230 to 197 MB when every chunk was held to the file's end, and a file of
    /// bare positions holds 4 bytes a corner rather than 12.
    raw: Vec<i32>,
    three_fields: bool,
    /// Whether any corner has the texture-coordinate (1) and normal (2) field; every corner
    /// has the vertex index (0), which the file stores whatever this says.
    has_field: [bool; 3],
    /// The indices that do not fit in `raw`, by corner and field (3 × corner + field). Only
    /// an error message reads them: no file has 2^31 vertices to reach.
    wide: Vec<(usize, i64)>,
    faces: Vec<Face>,
    /// How many of each attribute the chunk defines before its faces, as runs: (first face,
    /// counts), a run starting where the counts change.
    defined: Vec<(u32, [u32; 3])>,
    /// Triangles its faces of three or more corners make (`n - 2` each).
    triangles: usize,
    statements: Vec<(usize, usize, Statement)>,
    error: Option<(usize, String)>,
    /// Subtracted from every position, in f64, before it is rounded to f32 (see
    /// [`far_origin`]).
    origin: Option<[f64; 3]>,
}

/// Where a model in survey coordinates is moved from before its positions become f32 (see
/// [`super::survey_origin`]): from its first vertex; `None` for a model near the origin, whose
/// positions are read as they always were.
fn far_origin(bytes: &[u8]) -> Option<[f64; 3]> {
    first_vertex(bytes).and_then(super::survey_origin)
}

/// The coordinates of the first `v` line in `bytes` (those that do not read as finite numbers
/// are 0, for the reader to report), or `None` where there is none.
fn first_vertex(bytes: &[u8]) -> Option<[f64; 3]> {
    let line = lines(bytes)
        .map(trim)
        .find(|l| matches!(l, [b'v', b' ' | b'\t', ..]))?;
    let mut first = [0.0f64; 3];
    for (o, t) in first.iter_mut().zip(tokens(&line[1..])) {
        let v = std::str::from_utf8(t)
            .ok()
            .and_then(|t| t.parse::<f64>().ok());
        if let Some(v) = v.filter(|v| v.is_finite()) {
            *o = v;
        }
    }
    Some(first)
}

/// A vertex's three coordinates (`rest` of its line) by the general number reader, with the
/// error both readers give. With an `origin` (see [`far_origin`]) each is read in f64 and
/// rounded to f32 once, less the origin; without, read as f32 (the same bits as ever).
fn vertex(rest: &[u8], origin: Option<[f64; 3]>) -> Result<([f32; 3], &[u8]), String> {
    let mut it = tokens(rest);
    let mut p = [0.0f32; 3];
    let mut after = rest.len();
    for (k, v) in p.iter_mut().enumerate() {
        let t = it
            .next()
            .ok_or_else(|| format!("vertex has {k} coordinates, needs 3"))?;
        after = t.as_ptr() as usize - rest.as_ptr() as usize + t.len();
        let x = match origin {
            None => parse_f32(t).map(f64::from),
            Some(_) => std::str::from_utf8(t).ok().and_then(|s| s.parse().ok()),
        }
        .ok_or_else(|| format!("vertex coordinate {:?} is not a number", text(t)))?;
        let f = x - origin.map_or(0.0, |o| o[k]);
        if !x.is_finite() || (f as f32).is_infinite() {
            let wide = std::str::from_utf8(t)
                .ok()
                .and_then(|s| s.parse::<f64>().ok());
            return Err(if wide.is_some_and(f64::is_finite) {
                format!(
                    "vertex coordinate {:?} is out of range (a position holds at most ±{:e})",
                    text(t),
                    f32::MAX
                )
            } else {
                format!("vertex coordinate {:?} is not finite", text(t))
            });
        }
        *v = f as f32;
    }
    Ok((p, trim(&rest[after..])))
}

/// Where a position has no colour of its own in a file whose other positions have one.
const NO_COLOUR: [f32; 3] = [f32::NAN; 3];

/// The colour after a vertex's coordinates (`v x y z r g b`, as MeshLab, Open3D and scanners
/// write), or `None` for none or a `w` weight (`v x y z w`).
fn vertex_colour(after: &[u8]) -> Result<Option<[f32; 3]>, String> {
    let mut it = tokens(after);
    let (Some(r), Some(g), Some(b)) = (it.next(), it.next(), it.next()) else {
        return Ok(None);
    };
    let mut rgb = [0.0f32; 3];
    for (c, t) in rgb.iter_mut().zip([r, g, b]) {
        *c = parse_f32(t)
            .filter(|v| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| format!("vertex colour {:?} is not a number of 0 or more", text(t)))?;
    }
    Ok(Some(rgb))
}

/// Records `colour` for the last position of `positions`: `colours` runs parallel to them from
/// the first colour on, [`NO_COLOUR`] where one has none.
fn push_colour(colours: &mut Vec<[f32; 3]>, positions: usize, colour: Option<[f32; 3]>) {
    if let Some(c) = colour {
        colours.resize(positions - 1, NO_COLOUR);
        colours.push(c);
    }
}

/// The file's vertex colours, once it is read: sRGB values from 0 to 1 (or to 255, as some
/// tools write them: whole numbers, some over 1) to linear RGBA, white for positions without
/// one. A file of fractions with a few over 1 keeps its scale (clamped), rather than going
/// nearly black.
fn finish_colours(mut out: Imported, raw: Vec<[f32; 3]>) -> Imported {
    if raw.is_empty() {
        return out;
    }
    let written = || raw.iter().flatten().filter(|c| !c.is_nan());
    let bytes = written().any(|&c| c > 1.0) && written().all(|&c| c.fract() == 0.0);
    let scale = if bytes { 1.0 / 255.0 } else { 1.0 };
    let mut colours: Vec<[f32; 4]> = raw
        .into_iter()
        .map(|c| {
            if c[0].is_nan() {
                [1.0; 4]
            } else {
                let l =
                    c.map(|v| texture::srgb::srgb_to_linear((v * scale).min(1.0) as f64) as f32);
                [l[0], l[1], l[2], 1.0]
            }
        })
        .collect();
    colours.resize(out.positions.len(), [1.0; 4]);
    out.colours = colours;
    out
}

const ABSENT: i32 = i32::MIN;
const WIDE: i32 = i32::MIN + 1;

/// Appends a corner's fields to `raw`, one or three of them a corner; the first corner with a
/// texture coordinate or normal index (at a chunk's first face, in most files that have them)
/// widens the corners before it from one field to three.
#[inline(always)]
fn push_corner(raw: &mut Vec<i32>, three_fields: &mut bool, corner: [i32; 3]) {
    if *three_fields {
        raw.extend_from_slice(&corner);
    } else if corner[1] == ABSENT && corner[2] == ABSENT {
        raw.push(corner[0]);
    } else {
        let mut wide = Vec::with_capacity(3 * raw.capacity().max(raw.len() + 1));
        for &p in raw.iter() {
            wide.extend_from_slice(&[p, ABSENT, ABSENT]);
        }
        *raw = wide;
        *three_fields = true;
        raw.extend_from_slice(&corner);
    }
}

impl Chunk {
    fn stride(&self) -> usize {
        if self.three_fields { 3 } else { 1 }
    }

    fn corner_count(&self) -> usize {
        self.raw.len() / self.stride()
    }

    /// Corner `i`'s three fields.
    fn corner(&self, i: usize) -> [i32; 3] {
        if self.three_fields {
            let r = &self.raw[3 * i..3 * i + 3];
            [r[0], r[1], r[2]]
        } else {
            [self.raw[i], ABSENT, ABSENT]
        }
    }

    fn push_corner(&mut self, corner: [i32; 3]) {
        push_corner(&mut self.raw, &mut self.three_fields, corner);
    }

    /// Ends a face of the corners pushed since `corners_before`.
    fn push_face(&mut self, line: usize, corners_before: usize, broken: bool) {
        let counts = [self.positions.len(), self.uvs.len(), self.normals.len()].map(|n| n as u32);
        if self.defined.last().is_none_or(|d| d.1 != counts) {
            self.defined.push((self.faces.len() as u32, counts));
        }
        let len = (self.corner_count() - corners_before) as u32;
        self.faces.push(Face {
            line: line as u32,
            len: if broken { len | BROKEN } else { len },
        });
    }
}

/// Reads a chunk's lines, numbered from 1 within the chunk.
fn read_chunk(bytes: &[u8], origin: Option<[f64; 3]>) -> Chunk {
    let mut c = Chunk {
        origin,
        ..Chunk::default()
    };
    // Sized from the lines' keywords first (a triangle's three corners each; a polygon grows
    // the corners), so the large vectors do not grow: each doubling touched fresh memory,
    // and its page faults were a tenth of a 100k-triangle cook.
    // A first face with more than vertex indices sets three fields a corner from the start.
    let (mut positions, mut faces, mut three_fields) = (0, 0, false);
    for line in lines(bytes) {
        match line {
            [b'v', b' ' | b'\t', ..] => positions += 1,
            [b'f', b' ' | b'\t', ..] => {
                if faces == 0 && memchr::memchr(b'/', line).is_some() {
                    three_fields = true;
                }
                faces += 1;
            }
            _ => {}
        }
    }
    c.positions.reserve(positions);
    c.faces.reserve(faces);
    c.three_fields = three_fields;
    c.raw.reserve(3 * c.stride() * faces);
    for (index, raw) in lines(bytes).enumerate() {
        c.lines = index + 1;
        if let Err(message) = read_line(&mut c, index + 1, raw) {
            c.error = Some((index + 1, message));
            // The lines after it still count for the chunks after this one.
            c.lines = memchr::memchr_iter(b'\n', bytes).count() + 1;
            break;
        }
    }
    if c.three_fields {
        for k in 1..3 {
            c.has_field[k] = c.raw.chunks_exact(3).any(|f| f[k] != ABSENT);
        }
    }
    c
}

/// Whether any line of `text` is continued on the next (ends in a backslash).
fn continued(text: &[u8]) -> bool {
    memchr::memchr_iter(b'\\', text).any(|i| continues(text, i + 1))
}

/// Whether a backslash before `text[at..]` continues its line: a line end follows it, or the
/// end of the file (a continuation onto nothing, as a wrapped face written last leaves it).
/// Blocks and chunks are cut at line ends, so the end of `text` is the end of the file.
fn continues(text: &[u8], at: usize) -> bool {
    matches!(text.get(at..), Some([] | [b'\n', ..] | [b'\r', b'\n', ..]))
}

/// The last line end in `text[from..]` that ends a line not continued on the next.
fn last_line_end(text: &[u8], from: usize) -> Option<usize> {
    memchr::memrchr_iter(b'\n', &text[from..])
        .map(|i| from + i)
        .find(|&i| {
            let before = &text[..i];
            !(before.ends_with(b"\\") || before.ends_with(b"\\\r"))
        })
}

/// `text` with its continued lines joined ([`join_continued_lines`]), copied only where it
/// has any.
fn with_lines_joined(text: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    if continued(text) {
        let mut b = text.to_vec();
        join_continued_lines(&mut b);
        b.into()
    } else {
        text.into()
    }
}

/// Joins lines continued with a backslash at their end, as the OBJ format allows (older
/// exporters wrap long faces so): each backslash and line end becomes a space, and the line
/// ends taken out are put back after the joined line. The text keeps its length and every
/// later line its number; an error in a joined line names its first line. Only statements of
/// numbers (vertices, faces, lines...) are joined: a comment or a name ending in a backslash
/// is a path, and must not swallow the statement after it.
fn join_continued_lines(text: &mut [u8]) {
    let (mut read, mut write) = (0, 0);
    // Line ends taken out of the logical line being copied.
    let mut joined = 0;
    let mut line_start = true;
    let mut verbatim = false;
    while read < text.len() {
        let b = text[read];
        if line_start && !b.is_ascii_whitespace() {
            let word = text[read..]
                .split(|c| c.is_ascii_whitespace())
                .next()
                .unwrap_or(b"");
            verbatim = !matches!(
                word,
                b"v" | b"vt"
                    | b"vn"
                    | b"vp"
                    | b"f"
                    | b"fo"
                    | b"l"
                    | b"p"
                    | b"curv"
                    | b"curv2"
                    | b"surf"
                    | b"parm"
                    | b"trim"
                    | b"hole"
                    | b"scrv"
                    | b"sp"
                    | b"deg"
            );
            line_start = false;
        }
        if b == b'\\' && !verbatim && continues(text, read + 1) {
            text[write] = b' ';
            write += 1;
            match text.get(read + 1) {
                None => read += 1,
                Some(b'\n') => (read, joined) = (read + 2, joined + 1),
                Some(_) => (read, joined) = (read + 3, joined + 1),
            }
            continue;
        }
        if b == b'\n' {
            // The gap left by the joins: spaces, then the line ends they took out.
            let gap = read - write;
            text[write..write + gap - joined].fill(b' ');
            text[write + gap - joined..read].fill(b'\n');
            joined = 0;
            line_start = true;
            verbatim = false;
            write = read;
        }
        text[write] = b;
        write += 1;
        read += 1;
    }
    let gap = read - write;
    text[write..write + gap - joined].fill(b' ');
    text[write + gap - joined..].fill(b'\n');
}

/// The lines of `bytes` as `split` on `\n` gives them (the piece after the last one too,
/// empty or not), their ends found with memchr: a byte-by-byte split was a quarter of the
/// parse.
fn lines(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    let mut rest = Some(bytes);
    std::iter::from_fn(move || {
        let r = rest?;
        match memchr::memchr(b'\n', r) {
            Some(i) => {
                rest = Some(&r[i + 1..]);
                Some(&r[..i])
            }
            None => {
                rest = None;
                Some(r)
            }
        }
    })
}

fn read_line(c: &mut Chunk, line_no: usize, raw: &[u8]) -> Result<(), String> {
    let line = trim(raw);
    if line.is_empty() || line[0] == b'#' {
        return Ok(());
    }
    let mut it = tokens(line);
    let keyword = it.next().unwrap_or_default();
    let rest = trim(&line[keyword.len()..]);
    let statement = match keyword {
        b"v" => {
            if c.origin.is_none()
                && let Some((p, after)) = plain_floats_and_rest(rest)
            {
                c.positions.push(p);
                if !after.is_empty() {
                    push_colour(&mut c.colours, c.positions.len(), vertex_colour(after)?);
                }
                return Ok(());
            }
            let (p, after) = vertex(rest, c.origin)?;
            c.positions.push(p);
            push_colour(&mut c.colours, c.positions.len(), vertex_colour(after)?);
            return Ok(());
        }
        b"vt" => {
            if let Some([u, v]) = plain_floats(rest) {
                c.uvs.push([u, 1.0 - v]);
                return Ok(());
            }
            let mut uv = [0.0f32; 2];
            for (k, v) in uv.iter_mut().enumerate() {
                match it.next() {
                    Some(t) => {
                        *v = parse_f32(t).filter(|v| v.is_finite()).ok_or_else(|| {
                            format!("texture coordinate {:?} is not a finite number", text(t))
                        })?
                    }
                    None if k == 0 => return Err("texture coordinate has no values".into()),
                    None => {}
                }
            }
            // OBJ puts v = 0 at the bottom of an image; the pack, glTF and the GPU put it at
            // the top row.
            c.uvs.push([uv[0], 1.0 - uv[1]]);
            return Ok(());
        }
        b"vn" => {
            if let Some(n) = plain_floats(rest) {
                c.normals.push(n);
                return Ok(());
            }
            let mut n = [0.0f32; 3];
            for (k, v) in n.iter_mut().enumerate() {
                let t = it
                    .next()
                    .ok_or_else(|| format!("normal has {k} components, needs 3"))?;
                *v = parse_f32(t).filter(|v| v.is_finite()).ok_or_else(|| {
                    format!("normal component {:?} is not a finite number", text(t))
                })?;
            }
            c.normals.push(n);
            return Ok(());
        }
        b"f" => {
            let start = c.corner_count();
            // A chunk ends at a line's end, so only one line of gigabytes could overflow.
            if u32::try_from(start).is_err() || c.faces.len() >= BROKEN as usize {
                return Err(
                    "more than 2 billion faces or 4 billion corners in one run of lines".into(),
                );
            }
            if !plain_corners(c, rest) {
                for t in it {
                    let (fields, error) = match read_corner(t) {
                        Ok(fields) => (fields, None),
                        Err((fields, message)) => (fields, Some(message)),
                    };
                    let at = 3 * c.corner_count();
                    let mut corner = [ABSENT; 3];
                    for (k, field) in fields.iter().enumerate() {
                        if let Some(i) = *field {
                            corner[k] = match i32::try_from(i) {
                                Ok(n) if n > WIDE => n,
                                _ => {
                                    c.wide.push((at + k, i));
                                    WIDE
                                }
                            };
                        }
                    }
                    c.push_corner(corner);
                    if let Some(message) = error {
                        // Line by line, the indices before the bad field are checked first:
                        // keep them as a face that makes no triangles, for that check.
                        c.push_face(line_no, start, true);
                        return Err(message);
                    }
                }
            }
            c.triangles += (c.corner_count() - start).saturating_sub(2);
            // A chunk is far below 4 GiB, so its line and attribute counts fit.
            c.push_face(line_no, start, false);
            return Ok(());
        }
        other => match statement(other, rest) {
            Some(s) => s,
            None => return Ok(()),
        },
    };
    c.statements.push((c.faces.len(), line_no, statement));
    Ok(())
}

/// The statement a line of `keyword` and `rest` (trimmed) makes, other than an attribute or a
/// face; `None` for one that is skipped without a word.
fn statement(keyword: &[u8], rest: &[u8]) -> Option<Statement> {
    Some(match keyword {
        b"l" => Statement::Line,
        b"p" => Statement::Point,
        b"g" => Statement::Group((!rest.is_empty()).then(|| name(rest))),
        b"o" => Statement::Object((!rest.is_empty()).then(|| name(rest))),
        b"usemtl" => Statement::Usemtl(name(rest)),
        b"mtllib" => Statement::Mtllib(rest.to_vec()),
        // Smoothing groups, free-form geometry and display attributes: normals are generated
        // with a crease angle instead, and the rest has no meaning here.
        b"s" | b"vp" | b"cstype" | b"deg" | b"bmat" | b"step" | b"curv" | b"curv2" | b"surf"
        | b"parm" | b"trim" | b"hole" | b"scrv" | b"sp" | b"end" | b"con" | b"mg" | b"lod"
        | b"bevel" | b"c_interp" | b"d_interp" | b"usemap" | b"maplib" | b"shadow_obj"
        | b"trace_obj" | b"ctech" | b"stech" => return None,
        other => Statement::Unknown(text(other)),
    })
}

/// What a file's statements leave, applied in file order by both readers: the names in
/// effect, the materials its libraries define, and what to warn of.
#[derive(Default)]
struct Statements {
    state: State,
    material_ids: HashMap<String, u32>,
    missing_textures: Vec<(String, Warning)>,
    unknown_materials: Vec<(String, usize)>,
    /// (line elements, points, first line)
    skipped_lines: (usize, usize, usize),
    unknown_keywords: Vec<(String, usize)>,
    empty_groups: Vec<String>,
    /// The group in effect and its faces so far.
    group_faces: Option<(String, usize)>,
    short_faces: Vec<usize>,
    /// `--text-encoding`: how names that are not UTF-8 are read.
    given: Option<text::TextEncoding>,
    /// The encoding the first material library that is not UTF-8 was read with: the OBJ's
    /// names, written by the same tool, are read with it too.
    mtl_encoding: Option<&'static encoding_rs::Encoding>,
}

impl Statements {
    fn new(given: Option<text::TextEncoding>) -> Self {
        Statements {
            given,
            ..Default::default()
        }
    }

    /// The part of the next `faces` whole faces, which count for their group.
    fn part(&mut self, faces: usize, out: &mut Imported) -> u32 {
        if let Some((_, n)) = &mut self.group_faces {
            *n += faces;
        }
        current_part(&mut self.state, out, &self.material_ids)
    }

    /// Applies statement `s` of line `line` of the file at `path`; the error is a material
    /// library's.
    fn apply(
        &mut self,
        path: &Path,
        line: usize,
        s: &Statement,
        out: &mut Imported,
    ) -> Result<(), CookError> {
        match s {
            Statement::Line | Statement::Point => {
                let skipped = &mut self.skipped_lines;
                if skipped.0 + skipped.1 == 0 {
                    skipped.2 = line;
                }
                if matches!(s, Statement::Line) {
                    skipped.0 += 1
                } else {
                    skipped.1 += 1
                }
            }
            Statement::Group(name) => {
                if let Some((name, 0)) = self.group_faces.take() {
                    self.empty_groups.push(name);
                }
                self.group_faces = name.clone().map(|n| (n, 0));
                self.state.group = name.clone();
                self.state.part = None;
            }
            Statement::Object(name) => {
                self.state.object = name.clone();
                self.state.part = None;
            }
            Statement::Usemtl(name) => {
                if !name.is_empty()
                    && !self.material_ids.contains_key(name)
                    && !self.unknown_materials.iter().any(|(n, _)| n == name)
                {
                    self.unknown_materials.push((name.clone(), line));
                }
                self.state.material = (!name.is_empty()).then(|| name.clone());
                self.state.part = None;
            }
            Statement::Mtllib(rest) => {
                let read = load_mtllib(
                    path,
                    line,
                    rest,
                    out,
                    &mut self.material_ids,
                    &mut self.missing_textures,
                    self.given,
                )?;
                if let Some(text::Decoded::Legacy { encoding, .. }) = read {
                    self.mtl_encoding.get_or_insert(encoding);
                }
            }
            Statement::Unknown(k) => {
                if !self.unknown_keywords.iter().any(|(n, _)| n == k) {
                    self.unknown_keywords.push((k.clone(), line));
                }
            }
        }
        Ok(())
    }

    /// Once the whole file is read: the parts' names that are not UTF-8 decoded, with the
    /// encoding given, else the material library's, else the one guessed from the names; the
    /// parts whose material the escaped name did not find get it by the decoded one. Returns
    /// how they were read, for the warnings to be decoded alike.
    fn decode_names(&mut self, out: &mut Imported) -> Option<text::Decoded> {
        let escaped = |n: &Option<String>| n.as_deref().is_some_and(text::is_escaped);
        fn names(p: &Part) -> [&Option<String>; 3] {
            [&p.names.material, &p.names.group, &p.names.object]
        }
        let any = out.parts.iter().any(|p| names(p).into_iter().any(escaped))
            || self
                .group_faces
                .as_ref()
                .is_some_and(|(n, _)| text::is_escaped(n))
            || self.empty_groups.iter().any(|n| text::is_escaped(n))
            || self
                .unknown_materials
                .iter()
                .any(|(n, _)| text::is_escaped(n));
        if !any {
            return None;
        }
        let (encoding, guessed) = match (self.given, self.mtl_encoding) {
            (None, Some(encoding)) => (encoding, true),
            (given, _) => {
                let samples: Vec<Vec<u8>> = out
                    .parts
                    .iter()
                    .flat_map(|p| names(p).into_iter().flatten())
                    .filter(|n| text::is_escaped(n))
                    .map(|n| text::raw(n))
                    .collect();
                text::choose(given, samples.iter().map(Vec::as_slice))
            }
        };
        let decoded = text::Decoded::Legacy { encoding, guessed };
        for part in &mut out.parts {
            for n in [
                &mut part.names.material,
                &mut part.names.group,
                &mut part.names.object,
            ]
            .into_iter()
            .flatten()
            {
                *n = text::decode_escaped(n, encoding);
            }
            if part.material.is_none() {
                part.material = part
                    .names
                    .material
                    .as_ref()
                    .and_then(|n| self.material_ids.get(n).copied());
            }
        }
        // What the warnings below name, so a `usemtl` found by its decoded name (a library
        // saved again as UTF-8) is not reported missing.
        for (n, _) in &mut self.unknown_materials {
            *n = text::decode_escaped(n, encoding);
        }
        for n in &mut self.empty_groups {
            *n = text::decode_escaped(n, encoding);
        }
        if let Some((n, _)) = &mut self.group_faces {
            *n = text::decode_escaped(n, encoding);
        }
        Some(decoded)
    }

    /// Once the whole file is read: its warnings, onto `out`'s.
    fn warn(mut self, path: &Path, out: &mut Imported) {
        let decoded = self.decode_names(out);
        if let Some((name, 0)) = self.group_faces.take() {
            self.empty_groups.push(name);
        }
        // Unknown `usemtl` names stay names for tagging; only shading falls back to a default.
        let material_ids = &self.material_ids;
        self.unknown_materials
            .retain(|(n, _)| !material_ids.contains_key(n));
        for (name, line) in self.unknown_materials {
            out.warnings.push(Warning::new(
                path,
                Some(line),
                format!("material {name:?} is not defined in any mtllib; using default shading"),
            ));
        }
        let skipped = self.skipped_lines;
        if skipped.0 + skipped.1 > 0 {
            out.warnings.push(Warning::skipped_geometry(
                path,
                Some(skipped.2),
                format!(
                    "{} line and {} point elements ignored: only faces are cooked",
                    skipped.0, skipped.1
                ),
            ));
        }
        if let Some(&first) = self.short_faces.first() {
            out.warnings.push(Warning::new(
                path,
                Some(first),
                format!(
                    "{} faces with fewer than 3 vertices ignored",
                    self.short_faces.len()
                ),
            ));
        }
        if !self.empty_groups.is_empty() {
            out.warnings.push(Warning::new(
                path,
                None,
                format!("groups without faces: {}", self.empty_groups.join(", ")),
            ));
        }
        for (k, line) in self.unknown_keywords {
            out.warnings.push(Warning::new(
                path,
                Some(line),
                format!("unknown statement {k:?} ignored"),
            ));
        }
        if out.tri_part.is_empty() {
            out.warnings
                .push(Warning::new(path, None, "no faces: nothing to cook"));
        }
        // A missing texture matters only to a material some face uses.
        let mut used = vec![false; out.materials.len()];
        for &p in &out.tri_part {
            if let Some(m) = out.parts[p as usize].material {
                used[m as usize] = true;
            }
        }
        for (name, w) in self.missing_textures {
            if material_ids.get(&name).is_some_and(|&i| used[i as usize]) {
                out.warnings.push(w);
            }
        }
        out.text_encoding = match decoded {
            Some(text::Decoded::Legacy { encoding, .. }) => Some(encoding),
            _ => self.mtl_encoding,
        }
        .map(text::TextEncoding::of);
        if let Some(decoded @ text::Decoded::Legacy { encoding, .. }) = decoded {
            // The OBJ's own warnings name its names as read, escaped.
            for w in &mut out.warnings {
                w.message = text::decode_message(&w.message, encoding);
            }
            out.warnings
                .extend(decoded.describe().map(|how| Warning::new(path, None, how)));
        }
    }
}

/// The first `N` numbers of an attribute line's values (`rest`, trimmed) when [`simple_f32`]
/// reads them all (then they are finite), found without a token iterator; `None` for the
/// general path to read, or to report (too few values, other number forms).
fn plain_floats<const N: usize>(rest: &[u8]) -> Option<[f32; N]> {
    plain_floats_and_rest(rest).map(|(v, _)| v)
}

/// [`plain_floats`], and the text after them (trimmed).
fn plain_floats_and_rest<const N: usize>(rest: &[u8]) -> Option<([f32; N], &[u8])> {
    let mut out = [0.0f32; N];
    let mut i = 0;
    for v in &mut out {
        while rest.get(i).is_some_and(|b| b.is_ascii_whitespace()) {
            i += 1;
        }
        let first = i;
        while rest.get(i).is_some_and(|b| !b.is_ascii_whitespace()) {
            i += 1;
        }
        *v = simple_f32(&rest[first..i])?;
    }
    Some((out, trim(&rest[i..])))
}

/// Reads a face's corners (`rest`, trimmed) onto the chunk's when they are all plain: fields
/// of up to 9 digits with an optional minus, an empty texture coordinate or normal field
/// absent. These are what [`read_corner`] would read, straight from the bytes with no token or
/// field splitting (the face lines are most of a mesh's text). Anything else (a plus sign,
/// longer numbers, a fourth field, a bad character) leaves the corners as they were and
/// returns false, for the general path to read or to report.
fn plain_corners(c: &mut Chunk, rest: &[u8]) -> bool {
    // The vector and its width as locals: through `c` the loop reloaded them every corner
    // (the 819k-triangle grid's import was 5 % slower).
    let mut three_fields = c.three_fields;
    let start = c.corner_count();
    let read = plain_corners_onto(&mut c.raw, &mut three_fields, rest);
    c.three_fields = three_fields;
    // A widening on the way stays: the corners before `start` are the same in three fields.
    if !read {
        c.raw.truncate(start * c.stride());
    }
    read
}

fn plain_corners_onto(raw: &mut Vec<i32>, three_fields: &mut bool, rest: &[u8]) -> bool {
    let n = rest.len();
    let mut i = 0;
    while i < n {
        let mut corner = [ABSENT; 3];
        for (k, field) in corner.iter_mut().enumerate() {
            if k > 0 {
                if rest[i..].first() != Some(&b'/') {
                    break;
                }
                i += 1;
            }
            let negative = rest[i..].first() == Some(&b'-');
            i += usize::from(negative);
            let first = i;
            let mut v: i32 = 0;
            while let Some(d) = rest
                .get(i)
                .map(|b| b.wrapping_sub(b'0'))
                .filter(|&d| d <= 9)
            {
                if i - first == 9 {
                    return false;
                }
                v = v * 10 + i32::from(d);
                i += 1;
            }
            if i == first {
                if negative || k == 0 {
                    return false;
                }
                continue;
            }
            *field = if negative { -v } else { v };
        }
        match rest.get(i) {
            None => {}
            Some(b) if b.is_ascii_whitespace() => {
                while rest.get(i).is_some_and(|b| b.is_ascii_whitespace()) {
                    i += 1;
                }
            }
            Some(_) => return false,
        }
        push_corner(raw, three_fields, corner);
    }
    true
}

/// A corner's vertex, texture coordinate and normal indices as written, where present.
type Fields = [Option<i64>; 3];

/// A face corner's fields as integers, unresolved; on an error, the fields read before it.
fn read_corner(tok: &[u8]) -> Result<Fields, (Fields, String)> {
    let mut fields = tok.split(|&b| b == b'/');
    let mut out = [None; 3];
    for (k, what) in ["vertex", "texture coordinate", "normal"]
        .iter()
        .enumerate()
    {
        match fields.next() {
            Some(f) if !f.is_empty() || k == 0 => match parse_i64(f) {
                Some(i) => out[k] = Some(i),
                None => {
                    return Err((out, format!("{what} index {:?} is not an integer", text(f))));
                }
            },
            _ => {}
        }
    }
    if fields.next().is_some() {
        return Err((
            out,
            format!("face corner {:?} has more than 3 fields", text(tok)),
        ));
    }
    Ok(out)
}

/// Splits `bytes` into runs of whole lines of about `chunk_bytes` or more, enough for every
/// thread.
fn chunks(bytes: &[u8], chunk_bytes: usize) -> Vec<&[u8]> {
    let pieces = (bytes.len() / chunk_bytes.max(1)).clamp(1, 4 * rayon::current_num_threads());
    let size = bytes.len().div_ceil(pieces).max(1);
    let mut out = Vec::with_capacity(pieces);
    let mut rest = bytes;
    while !rest.is_empty() {
        let cut = if rest.len() <= size {
            rest.len()
        } else {
            rest[size..]
                .iter()
                .position(|&b| b == b'\n')
                .map_or(rest.len(), |i| size + i + 1)
        };
        out.push(&rest[..cut]);
        rest = &rest[cut..];
    }
    if out.is_empty() {
        out.push(bytes);
    }
    out
}

/// Parses OBJ text. `path` names the file in errors and locates `mtllib` files. Large texts
/// are split into runs of lines read on every thread, with the same result.
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Imported, CookError> {
    parse_with(path, bytes, None)
}

/// [`parse`], reading names that are not UTF-8 as `given` says (see [`text`]).
pub fn parse_with(
    path: &Path,
    bytes: &[u8],
    given: Option<text::TextEncoding>,
) -> Result<Imported, CookError> {
    let joined = with_lines_joined(bytes.strip_prefix(UTF8_BOM).unwrap_or(bytes));
    let bytes = &joined[..];
    if bytes.len() >= PARALLEL_BYTES {
        parse_chunked(path, bytes, CHUNK_BYTES, given)
    } else {
        parse_lines(path, bytes, given)
    }
    .map(place_textures)
}

/// Applies the materials' texture placement (MTL `-o`, `-s`) to the texture coordinates of
/// their triangles, as glTF's `KHR_texture_transform` is: the pack has one set of coordinates
/// and no per-material transform. Placed coordinates are new ones (once per material and
/// coordinate), so a coordinate another material shares keeps its place there.
fn place_textures(mut out: Imported) -> Imported {
    let transforms = std::mem::take(&mut out.uv_transforms);
    if transforms.is_empty() || out.corners.uv_indices().is_empty() {
        return out;
    }
    let placement: HashMap<u32, ([f32; 2], [f32; 2])> = transforms
        .into_iter()
        .map(|(m, offset, scale)| (m, (offset, scale)))
        .collect();
    // Per material placed, the coordinates already made for it.
    let mut made: HashMap<(u32, u32), u32> = HashMap::new();
    for t in 0..out.tri_part.len().min(out.corners.len() / 3) {
        let Some(material) = out.parts[out.tri_part[t] as usize].material else {
            continue;
        };
        let Some(&(offset, scale)) = placement.get(&material) else {
            continue;
        };
        for k in 0..3 {
            let mut c = out.corners.get(3 * t + k);
            if c.t == NONE {
                continue;
            }
            let uvs = &mut out.uvs;
            c.t = *made.entry((material, c.t)).or_insert_with(|| {
                // Stored with v flipped (images top row first); the MTL's v runs up.
                let [u, v] = uvs[c.t as usize];
                let (u, v) = (u * scale[0] + offset[0], (1.0 - v) * scale[1] + offset[1]);
                uvs.push([u, 1.0 - v]);
                (uvs.len() - 1) as u32
            });
            out.corners.set(3 * t + k, c);
        }
    }
    out
}

/// Parses OBJ text line by line: the reference [`parse_chunked`] must agree with, and what
/// files too small to split run (splitting costs more than it saves there).
fn parse_lines(
    path: &Path,
    bytes: &[u8],
    given: Option<text::TextEncoding>,
) -> Result<Imported, CookError> {
    let mut out = Imported {
        path: path.to_path_buf(),
        ..Default::default()
    };
    let mut statements = Statements::new(given);
    let origin = far_origin(bytes);
    out.origin = origin.unwrap_or_default();
    let mut face: Vec<Corner> = Vec::new();
    let mut poly: Vec<[f32; 3]> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    let mut colours: Vec<[f32; 3]> = Vec::new();

    for (index, raw) in lines(bytes).enumerate() {
        let line_no = index + 1;
        let line = trim(raw);
        if line.is_empty() || line[0] == b'#' {
            continue;
        }
        let mut it = tokens(line);
        let keyword = it.next().unwrap_or_default();
        let rest = trim(&line[keyword.len()..]);
        match keyword {
            b"v" => {
                let (p, colour) = vertex(rest, origin)
                    .and_then(|(p, after)| Ok((p, vertex_colour(after)?)))
                    .map_err(|m| bad(path, line_no, m))?;
                out.positions.push(p);
                push_colour(&mut colours, out.positions.len(), colour);
            }
            b"vt" => {
                let mut uv = [0.0f32; 2];
                for (k, c) in uv.iter_mut().enumerate() {
                    match it.next() {
                        Some(t) => {
                            *c = parse_f32(t).filter(|v| v.is_finite()).ok_or_else(|| {
                                bad(
                                    path,
                                    line_no,
                                    format!(
                                        "texture coordinate {:?} is not a finite number",
                                        text(t)
                                    ),
                                )
                            })?
                        }
                        None if k == 0 => {
                            return Err(bad(path, line_no, "texture coordinate has no values"));
                        }
                        None => {}
                    }
                }
                // OBJ puts v = 0 at the bottom of an image; the pack, glTF and the GPU put it
                // at the top row.
                out.uvs.push([uv[0], 1.0 - uv[1]]);
            }
            b"vn" => {
                let mut n = [0.0f32; 3];
                for (k, c) in n.iter_mut().enumerate() {
                    let t = it.next().ok_or_else(|| {
                        bad(path, line_no, format!("normal has {k} components, needs 3"))
                    })?;
                    *c = parse_f32(t).filter(|v| v.is_finite()).ok_or_else(|| {
                        bad(
                            path,
                            line_no,
                            format!("normal component {:?} is not a finite number", text(t)),
                        )
                    })?;
                }
                out.normals.push(n);
            }
            b"f" => {
                face.clear();
                for t in it {
                    face.push(parse_corner(path, line_no, t, &out)?);
                }
                if face.len() < 3 {
                    statements.short_faces.push(line_no);
                    continue;
                }
                let part = statements.part(1, &mut out);
                if face.len() == 3 {
                    for &c in &face {
                        out.corners.push(c);
                    }
                    out.tri_part.push(part);
                } else {
                    out.polygons += 1;
                    poly.clear();
                    poly.extend(face.iter().map(|c| out.positions[c.p as usize]));
                    tris.clear();
                    triangulate(&poly, &mut tris);
                    for t in &tris {
                        for &i in t {
                            out.corners.push(face[i as usize]);
                        }
                        out.tri_part.push(part);
                    }
                }
            }
            other => {
                if let Some(s) = statement(other, rest) {
                    statements.apply(path, line_no, &s, &mut out)?;
                }
            }
        }
    }
    statements.warn(path, &mut out);
    Ok(finish_colours(out, colours))
}

fn parse_corner(path: &Path, line: usize, tok: &[u8], out: &Imported) -> Result<Corner, CookError> {
    let mut fields = tok.split(|&b| b == b'/');
    let p = fields.next().unwrap_or_default();
    let p = resolve_text(path, line, p, out.positions.len(), "vertex")?;
    let t = match fields.next() {
        Some(f) if !f.is_empty() => {
            resolve_text(path, line, f, out.uvs.len(), "texture coordinate")?
        }
        _ => NONE,
    };
    let n = match fields.next() {
        Some(f) if !f.is_empty() => resolve_text(path, line, f, out.normals.len(), "normal")?,
        _ => NONE,
    };
    if fields.next().is_some() {
        return Err(bad(
            path,
            line,
            format!("face corner {:?} has more than 3 fields", text(tok)),
        ));
    }
    Ok(Corner { p, t, n })
}

/// [`resolve`] of an index as written.
fn resolve_text(
    path: &Path,
    line: usize,
    raw: &[u8],
    count: usize,
    what: &str,
) -> Result<u32, CookError> {
    let i = parse_i64(raw).ok_or_else(|| {
        bad(
            path,
            line,
            format!("{what} index {:?} is not an integer", text(raw)),
        )
    })?;
    resolve(path, line, i, count, what)
}

/// Large files are read in chunks of lines on every thread (vertex attributes and faces with
/// their indices as written), then put together in file order: names and material libraries
/// one statement after another, then each chunk's faces resolved against everything defined
/// before them. The result, errors and warnings are those of [`parse_lines`] (the first error
/// in the file wins) whatever the chunking.
fn parse_chunked(
    path: &Path,
    bytes: &[u8],
    chunk_bytes: usize,
    given: Option<text::TextEncoding>,
) -> Result<Imported, CookError> {
    let mut assembler = Assembler::new(path, given);
    assembler.set_origin(bytes);
    assembler.read(&chunks(bytes, chunk_bytes), 0);
    assembler.finish()
}

/// Bytes read from a file per block when it is streamed: the file is never held whole (an
/// 85 MB OBJ held 85 MB through its whole import), and the block buffers are reused, so
/// their pages are touched once. A block's chunks, read, are held until it is assembled: 4 MB
/// blocks put the 819k-triangle grid's import at 57–61 MB resident, 2 MB at 52–55 MB with the
/// same import time, 1 MB at 48–50 MB but slower, and its mesh stage then reached past them.
const BLOCK_BYTES: usize = 2 << 20;

/// Parses an OBJ read from `reader` block by block: each block's whole lines are split into
/// chunks of about `chunk_bytes` and read on every thread while the next block is read in.
/// The same result as [`parse_chunked`] on the whole text. `size`: the bytes expected, which
/// sizes the file's arrays ahead (any other number gives the same result).
fn parse_stream(
    path: &Path,
    reader: &mut (impl std::io::Read + Send),
    size: u64,
    chunk_bytes: usize,
    block_bytes: usize,
    given: Option<text::TextEncoding>,
) -> Result<Imported, CookError> {
    let io = |source| CookError::Io {
        path: path.to_path_buf(),
        source,
    };
    let block_bytes = block_bytes.max(1);
    // Appends up to `block_bytes` to `buf`; true at the end of the file. Room is made first,
    // exactly: left to `read_to_end`, a buffer holding a carried-over line doubled to twice
    // the block.
    let fill = |reader: &mut dyn std::io::Read, buf: &mut Vec<u8>| -> std::io::Result<bool> {
        let start = buf.len();
        buf.reserve_exact(block_bytes);
        std::io::Read::read_to_end(&mut std::io::Read::take(reader, block_bytes as u64), buf)?;
        Ok(buf.len() - start < block_bytes)
    };
    let mut assembler = Assembler::new(path, given);
    let mut consumed = 0u64;
    // With room for a line carried over, so that the buffers are not grown block after block.
    let room = block_bytes + (64 << 10);
    let mut block: Vec<u8> = Vec::with_capacity(room);
    let mut next: Vec<u8> = Vec::with_capacity(room);
    let mut end = fill(reader, &mut block).map_err(io)?;
    if block.starts_with(UTF8_BOM) {
        block.drain(..UTF8_BOM.len());
    }
    // The bytes of `block` already checked: a line carried over, or read on, is not checked
    // again (a file of one long line would be, block after block).
    let mut checked = 0;
    loop {
        if let Some(e) = not_text(path, &block[checked..], checked == 0 && !assembler.started) {
            return Err(e);
        }
        // Whole lines only; a line longer than a block reads on into the next.
        let cut = if end {
            block.len()
        } else {
            match last_line_end(&block, checked) {
                Some(i) => i + 1,
                None => {
                    checked = block.len();
                    end = fill(reader, &mut block).map_err(io)?;
                    continue;
                }
            }
        };
        next.clear();
        next.extend_from_slice(&block[cut..]);
        checked = next.len();
        if continued(&block[..cut]) {
            join_continued_lines(&mut block[..cut]);
        }
        let text = &block[..cut];
        // From the first block of whole lines with a vertex in it, whatever the block size.
        assembler.set_origin(text);
        consumed += text.len() as u64;
        let rest = size.saturating_sub(consumed);
        let (read, ()) = if end {
            (Ok(true), assembler.read(&chunks(text, chunk_bytes), 0))
        } else {
            rayon::join(
                || fill(reader, &mut next),
                || assembler.read(&chunks(text, chunk_bytes), rest),
            )
        };
        if end {
            break;
        }
        end = read.map_err(io)?;
        std::mem::swap(&mut block, &mut next);
    }
    assembler.finish()
}

/// The file assembled batch by batch as its chunks come in, in file order: each batch's
/// attribute arrays are moved onto the file's, its statements run, and its faces are resolved
/// and triangulated onto the file's corners, before the next batch is read. A chunk's faces
/// (12 bytes a corner as written) are gone once resolved: holding every chunk until the end
/// of the file, beside the resolved corners, set the 819k-triangle grid's peak.
struct Assembler<'p> {
    path: &'p Path,
    out: Imported,
    /// The corners' fields so far; the texture-coordinate (1) and normal (2) fields are
    /// empty until a corner has one, and are then filled with [`NONE`] for the corners before.
    fields: [Vec<u32>; 3],
    /// Which of `fields` are stored.
    stored: [bool; 3],
    /// Which stored fields have been the position indices over again in every corner so far:
    /// such a field holds only the last batch's, to compare, and is not kept.
    same: [bool; 3],
    /// Lines in the chunks before.
    lines_before: usize,
    /// Whether any batch has come in.
    started: bool,
    /// The file's first error: no batch after it is read.
    error: Option<CookError>,
    statements: Statements,
    /// See [`Chunk::origin`].
    origin: Option<[f64; 3]>,
    /// Whether `origin` is decided: by the first batch with a vertex in it.
    origin_placed: bool,
    /// See [`Chunk::colours`].
    colours: Vec<[f32; 3]>,
}

impl<'p> Assembler<'p> {
    fn new(path: &'p Path, given: Option<text::TextEncoding>) -> Self {
        Self {
            path,
            out: Imported {
                path: path.to_path_buf(),
                ..Default::default()
            },
            fields: Default::default(),
            stored: [true, false, false],
            same: [false; 3],
            lines_before: 0,
            started: false,
            error: None,
            statements: Statements::new(given),
            origin: None,
            origin_placed: false,
            colours: Vec::new(),
        }
    }

    /// Moves the file's positions by [`far_origin`] of its first bytes; before any batch.
    fn set_origin(&mut self, text: &[u8]) {
        if self.origin_placed {
            return;
        }
        if let Some(first) = first_vertex(text) {
            self.origin_placed = true;
            self.origin = super::survey_origin(first);
            self.out.origin = self.origin.unwrap_or_default();
        }
    }

    /// Reads consecutive runs of whole lines (one thread each) and assembles them; nothing
    /// once the file has had an error. `rest`: the bytes expected after them.
    fn read(&mut self, pieces: &[&[u8]], rest: u64) {
        use rayon::prelude::*;
        self.started = true;
        if self.error.is_some() {
            return;
        }
        let chunks: Vec<Chunk> = if pieces.len() == 1 {
            vec![read_chunk(pieces[0], self.origin)]
        } else {
            pieces
                .par_iter()
                .map(|b| read_chunk(b, self.origin))
                .collect()
        };
        let bytes: usize = pieces.iter().map(|p| p.len()).sum();
        let ahead = rest as f64 / bytes.max(1) as f64;
        if let Err(e) = self.add(chunks, ahead) {
            self.error = Some(e);
        }
    }

    /// One batch of chunks, in file order after those before; `ahead`: how many times the
    /// batch's bytes are still to come.
    fn add(&mut self, mut chunks: Vec<Chunk>, ahead: f64) -> Result<(), CookError> {
        use rayon::prelude::*;
        let path = self.path;
        // How many of each attribute the chunks before each one define, and the line each
        // starts after: each chunk but the file's last ends with a newline, which its line
        // count includes as an empty last line.
        let mut before = Vec::with_capacity(chunks.len());
        let mut offset = Vec::with_capacity(chunks.len());
        for c in &mut chunks {
            let out = &mut self.out;
            before.push([out.positions.len(), out.uvs.len(), out.normals.len()]);
            if !c.colours.is_empty() {
                self.colours.resize(out.positions.len(), NO_COLOUR);
                append(&mut self.colours, std::mem::take(&mut c.colours));
            }
            append(&mut out.positions, std::mem::take(&mut c.positions));
            append(&mut out.uvs, std::mem::take(&mut c.uvs));
            append(&mut out.normals, std::mem::take(&mut c.normals));
            offset.push(self.lines_before);
            self.lines_before += c.lines.saturating_sub(1);
        }
        // The first error in the batch: a chunk stops at its own, so no later line matters.
        let mut first_error = chunks
            .iter()
            .zip(&offset)
            .find_map(|(c, o)| c.error.as_ref().map(|(line, m)| (o + line, m)))
            .map(|(line, m)| (line, bad(path, line, m.clone())));

        // Names, parts and material libraries, statement by statement in file order. Each
        // chunk's faces get their part by runs: `runs[c]` holds (first face, part) pairs.
        let mut runs: Vec<Vec<(usize, u32)>> = Vec::with_capacity(chunks.len());
        'chunks: for (c, offset) in chunks.iter().zip(&offset) {
            let mut chunk_runs = Vec::new();
            let mut face = 0;
            let mut statements = c.statements.iter().peekable();
            loop {
                let next = statements.peek().map_or(c.faces.len(), |s| s.0);
                // Faces up to the next statement: one part for the run (made by its first
                // face with three corners, as line by line), and counted for their group.
                let whole = c.faces[face..next]
                    .iter()
                    .filter(|f| f.corners() >= 3 && !f.broken())
                    .count();
                if whole > 0 {
                    chunk_runs.push((face, self.statements.part(whole, &mut self.out)));
                }
                face = next;
                let Some((_, line_no, statement)) = statements.next() else {
                    break;
                };
                let line_no = offset + line_no;
                if first_error.as_ref().is_some_and(|(l, _)| *l < line_no) {
                    runs.push(chunk_runs);
                    break 'chunks;
                }
                if let Err(e) = self
                    .statements
                    .apply(path, line_no, statement, &mut self.out)
                {
                    first_error = Some((line_no, e));
                    runs.push(chunk_runs);
                    break 'chunks;
                }
            }
            runs.push(chunk_runs);
        }

        // Every chunk's faces, resolved and triangulated on its own thread straight into its
        // share of the file's corners.
        struct Resolved {
            polygons: usize,
            short: Vec<usize>,
            error: Option<(usize, CookError)>,
        }
        let resolving = &chunks[..runs.len()];
        let triangles: usize = resolving.iter().map(|c| c.triangles).sum();
        let corners_before = self.fields[0].len();
        // A field no corner has had yet is not stored; the first corner with one fills it in
        // for the corners before.
        for k in 1..3 {
            if !self.stored[k] && resolving.iter().any(|c| c.has_field[k]) {
                self.fields[k] = vec![NONE; corners_before];
                self.stored[k] = true;
                self.same[k] = corners_before == 0;
            }
        }
        let lens: [usize; 3] = self.stored.map(|s| if s { 3 * triangles } else { 0 });
        for ((f, &len), &same) in self.fields.iter_mut().zip(&lens).zip(&self.same) {
            if same {
                // The batch before matched the positions: this one's is written over it.
                f.clear();
                f.reserve_exact(len);
            } else {
                reserve_ahead(f, len, ahead);
            }
        }
        let tri_part = &mut self.out.tri_part;
        reserve_ahead(tri_part, triangles, ahead);
        let mut shares = Vec::with_capacity(resolving.len());
        {
            let mut rest = std::array::from_fn::<_, 3, _>(|_| Default::default());
            for ((r, f), &len) in rest.iter_mut().zip(&mut self.fields).zip(&lens) {
                *r = &mut f.spare_capacity_mut()[..len];
            }
            let mut ps = &mut tri_part.spare_capacity_mut()[..triangles];
            for c in resolving {
                let share = rest.each_mut().map(|f| {
                    let n = if f.is_empty() { 0 } else { 3 * c.triangles };
                    let (mine, others) = std::mem::take(f).split_at_mut(n);
                    *f = others;
                    mine
                });
                let (p1, p_rest) = ps.split_at_mut(c.triangles);
                shares.push((share, p1));
                ps = p_rest;
            }
        }
        let positions = &self.out.positions;
        let mut resolved: Vec<Resolved> = resolving
            .par_iter()
            .zip(shares)
            .zip(&before)
            .zip(&runs)
            .zip(&offset)
            .map(|((((c, (mut c3, p1)), before), runs), &offset)| {
                let mut r = Resolved {
                    polygons: 0,
                    short: Vec::new(),
                    error: None,
                };
                let mut face: Vec<Corner> = Vec::new();
                let mut poly: Vec<[f32; 3]> = Vec::new();
                let mut tris: Vec<[u32; 3]> = Vec::new();
                let (mut run, mut at) = (0, 0);
                let (mut counts, mut start) = (0, 0);
                for (i, &f) in c.faces.iter().enumerate() {
                    let line = offset + f.line as usize;
                    while counts + 1 < c.defined.len() && c.defined[counts + 1].0 as usize <= i {
                        counts += 1;
                    }
                    let defined: [usize; 3] =
                        std::array::from_fn(|k| before[k] + c.defined[counts].1[k] as usize);
                    face.clear();
                    let corners = start..start + f.corners();
                    start = corners.end;
                    for at in corners {
                        let raw = c.corner(at);
                        let index = |k: usize| match raw[k] {
                            ABSENT => None,
                            WIDE => Some(
                                c.wide
                                    .iter()
                                    .find(|w| w.0 == 3 * at + k)
                                    .expect("every WIDE field has its value in `wide`")
                                    .1,
                            ),
                            i => Some(i64::from(i)),
                        };
                        match resolve_corner(path, line, [index(0), index(1), index(2)], defined) {
                            Ok(corner) => face.push(corner),
                            Err(e) => {
                                r.error = Some((line, e));
                                return r;
                            }
                        }
                    }
                    if f.broken() {
                        continue;
                    }
                    if face.len() < 3 {
                        r.short.push(line);
                        continue;
                    }
                    while run + 1 < runs.len() && runs[run + 1].0 <= i {
                        run += 1;
                    }
                    let part = runs.get(run).map_or(0, |r| r.1);
                    let mut put = |t: [Corner; 3]| {
                        for (k, corner) in t.into_iter().enumerate() {
                            for (field, value) in c3.iter_mut().zip([corner.p, corner.t, corner.n])
                            {
                                if let Some(slot) = field.get_mut(3 * at + k) {
                                    slot.write(value);
                                }
                            }
                        }
                        p1[at].write(part);
                        at += 1;
                    };
                    if face.len() == 3 {
                        put([face[0], face[1], face[2]]);
                    } else {
                        r.polygons += 1;
                        poly.clear();
                        poly.extend(face.iter().map(|c| positions[c.p as usize]));
                        tris.clear();
                        triangulate(&poly, &mut tris);
                        for t in &tris {
                            put(t.map(|i| face[i as usize]));
                        }
                    }
                }
                assert_eq!(at, c.triangles, "a chunk's triangles fill its share");
                r
            })
            .collect();
        let earliest = resolved
            .iter()
            .enumerate()
            .filter_map(|(i, r)| r.error.as_ref().map(|(line, _)| (*line, i)))
            .min();
        // On the line a chunk stopped at, an index checked before the bad field comes first.
        if let Some((line, i)) = earliest
            && first_error.as_ref().is_none_or(|(l, _)| line <= *l)
        {
            first_error = resolved[i].error.take();
        }
        if let Some((_, e)) = first_error {
            return Err(e);
        }
        // SAFETY: no chunk failed (an error returned above, and a chunk stopped early by a
        // syntax error or a material library has its error there too), so every chunk wrote
        // exactly its share, checked by the assertion: all `triangles` entries past the
        // lengths are written.
        unsafe {
            for (f, len) in self.fields.iter_mut().zip(lens) {
                f.set_len(f.len() + len);
            }
            tri_part.set_len(tri_part.len() + triangles);
        }
        for k in 1..3 {
            if self.same[k] && self.fields[k] != self.fields[0][corners_before..] {
                // Held from here on: the positions so far, then this batch's own.
                let mut whole = Vec::with_capacity(self.fields[0].capacity());
                whole.extend_from_slice(&self.fields[0][..corners_before]);
                whole.extend_from_slice(&self.fields[k]);
                self.fields[k] = whole;
                self.same[k] = false;
            }
        }
        for r in resolved {
            self.out.polygons += r.polygons;
            self.statements.short_faces.extend(r.short);
        }
        Ok(())
    }

    /// The file, or its first error.
    fn finish(self) -> Result<Imported, CookError> {
        if let Some(e) = self.error {
            return Err(e);
        }
        let mut out = self.out;
        // Sized ahead as blocks came in: the spare capacity goes back to the heap for the
        // mesh stage's arrays.
        out.positions.shrink_to_fit();
        out.uvs.shrink_to_fit();
        out.normals.shrink_to_fit();
        out.tri_part.shrink_to_fit();
        let [mut p, mut t, mut n] = self.fields;
        for f in [&mut p, &mut t, &mut n] {
            f.shrink_to_fit();
        }
        let held = |f: Vec<u32>, same: bool| {
            if same {
                Indices::Positions
            } else {
                Indices::of(f, &p)
            }
        };
        let (t, n) = (held(t, self.same[1]), held(n, self.same[2]));
        out.corners = Corners::from_indices(p, t, n);
        self.statements.warn(self.path, &mut out);
        Ok(finish_colours(out, self.colours))
    }
}

/// Where `more` items do not fit in `v`, makes room for them and `ahead` times as many again:
/// the rest of the file is expected to hold as many for its size as this batch. A vector
/// grown by doubling instead left each old block behind as a hole in the heap (the
/// 819k-triangle grid's import peaked at 104 MB resident rather than 93 MB); one sized too
/// large wastes only pages never touched. Where that expects less than half as much again as
/// `v` holds (a file longer than its size said), `v` grows as a vector does, so that it is not
/// copied batch after batch.
fn reserve_ahead<T>(v: &mut Vec<T>, more: usize, ahead: f64) {
    if more <= v.capacity() - v.len() {
        return;
    }
    let extra = (more as f64 * ahead).min(usize::MAX as f64 / 2.0) as usize;
    if more.saturating_add(extra) < v.len() / 2 {
        v.reserve(more);
    } else {
        v.reserve_exact(more.saturating_add(extra));
    }
}

fn current_part(state: &mut State, out: &mut Imported, material_ids: &HashMap<String, u32>) -> u32 {
    if let Some(p) = state.part {
        return p;
    }
    let key = (
        state.material.clone(),
        state.group.clone(),
        state.object.clone(),
    );
    let next = out.parts.len() as u32;
    let id = *state.parts.entry(key).or_insert_with(|| {
        out.parts.push(Part {
            names: Names {
                material: state.material.clone(),
                group: state.group.clone(),
                object: state.object.clone(),
                mesh: None,
                node: None,
                instance: None,
            },
            material: state
                .material
                .as_ref()
                .and_then(|m| material_ids.get(m).copied()),
        });
        next
    });
    state.part = Some(id);
    id
}

/// A face corner's indices, each checked against what is defined before its line.
fn resolve_corner(
    path: &Path,
    line: usize,
    raw: Fields,
    defined: [usize; 3],
) -> Result<Corner, CookError> {
    // Only a broken face's last corner can lack its vertex: nothing to check then.
    let p = match raw[0] {
        None => NONE,
        Some(i) => resolve(path, line, i, defined[0], "vertex")?,
    };
    let other = |k: usize, what: &str| match raw[k] {
        None => Ok(NONE),
        Some(i) => resolve(path, line, i, defined[k], what),
    };
    let t = other(1, "texture coordinate")?;
    let n = other(2, "normal")?;
    Ok(Corner { p, t, n })
}

fn resolve(path: &Path, line: usize, i: i64, count: usize, what: &str) -> Result<u32, CookError> {
    let resolved = if i > 0 {
        i - 1
    } else if i < 0 {
        count as i64 + i
    } else {
        return Err(bad(
            path,
            line,
            format!("{what} index 0 is invalid: OBJ indices start at 1"),
        ));
    };
    if resolved < 0 || resolved >= count as i64 || resolved >= NONE as i64 {
        return Err(bad(
            path,
            line,
            format!(
                "{what} index {i} is out of range: {count} {} defined before this line",
                plural(what, count)
            ),
        ));
    }
    Ok(resolved as u32)
}

fn plural(what: &str, n: usize) -> String {
    match (what, n) {
        ("vertex", 1) => "vertex is".to_string(),
        ("vertex", _) => "vertices are".to_string(),
        (w, 1) => format!("{w} is"),
        (w, _) => format!("{w}s are"),
    }
}

/// Finds a file named in an MTL or `mtllib` statement: the whole rest of the line first (names
/// may contain spaces), then each word (several files, or options before the name).
///
/// A name that is not UTF-8 means the file of those bytes, else the name decoded as `given`
/// says or as guessed from it. Each lookup whose answer could change is noted in `noted`
/// (see `import::Absent`).
fn find_file(
    dir: &Path,
    rest: &[u8],
    given: Option<text::TextEncoding>,
    noted: &mut Vec<super::Absent>,
) -> (Vec<PathBuf>, Vec<String>) {
    let mut locate = |name: &[u8]| {
        let escaped = text::escaped(name);
        if let Some(p) = super::locate_noted(dir, &escaped, noted) {
            return Some(p);
        }
        // Only a name that is not UTF-8 has another reading, and only then is the encoding
        // worth guessing.
        if !text::is_escaped(&escaped) {
            return None;
        }
        let (encoding, guessed) = text::choose(given, [name]);
        if let Some(p) = super::locate_noted(dir, &text::decode_escaped(&escaped, encoding), noted)
        {
            return Some(p);
        }
        // A few letters are too little to guess from: `mtllib храм.mtl` in windows-1251 was
        // read as another encoding, not found, and the library beside the OBJ taken with a
        // warning. Each common encoding is tried; the file on disk tells which it was.
        if !guessed {
            return None;
        }
        text::COMMON
            .iter()
            .filter(|&&e| e != encoding)
            .find_map(|&e| super::locate_noted(dir, &text::decode_escaped(&escaped, e), noted))
    };
    if let Some(p) = locate(rest) {
        return (vec![p], Vec::new());
    }
    let mut found = Vec::new();
    let mut missing = Vec::new();
    for w in tokens(rest) {
        match locate(w) {
            Some(p) => found.push(p),
            None => missing.push(name(w)),
        }
    }
    (found, missing)
}

/// CIE XYZ (D65 white) to linear sRGB: IEC 61966-2-1's matrix. A single value is a grey,
/// the same in X, Y and Z as the MTL specification writes it, not D65's chromaticity: kept
/// grey, as it is meant.
fn xyz_to_linear_srgb(c: [f32; 3]) -> [f32; 3] {
    if c[0] == c[1] && c[1] == c[2] {
        return c;
    }
    let m = [
        [3.240_454_2, -1.537_138_5, -0.498_531_4],
        [-0.969_266, 1.876_010_8, 0.041_556],
        [0.055_643_4, -0.204_025_9, 1.057_225_2],
    ];
    m.map(|r| r[0] * c[0] + r[1] * c[1] + r[2] * c[2])
}

/// A `Tf` no channel of which is above this is black.
const BLACK_FILTER: f32 = 1e-3;

/// `Tf`, `d`/`Tr` and `illum` of an MTL entry; unparsable values count as absent.
fn mtl_transmission(m: &tobj::Material) -> super::Transmission {
    let parse = |text: &str| -> Option<Vec<f32>> {
        let v: Vec<f32> = text
            .split_whitespace()
            .map_while(|t| t.parse::<f32>().ok())
            .filter(|f| f.is_finite())
            .collect();
        (!v.is_empty()).then_some(v)
    };
    let floats = |key: &str| parse(m.unknown_param.get(key)?);
    // `Tf` may be written as one grey value, as RGB, as CIE XYZ (`Tf xyz X Y Z`, converted
    // to linear sRGB) or as `Tf spectral file.rfl` (no colour without the file: ignored).
    let tf = m.unknown_param.get("Tf").map_or("", String::as_str);
    let (xyz, values) = match tf.trim_start().strip_prefix("xyz") {
        Some(rest) => (true, rest),
        None => (false, tf),
    };
    let filter = parse(values).map(|v| {
        let c = match v.len() {
            1 | 2 => [v[0]; 3],
            _ => [v[0], v[1], v[2]],
        };
        if xyz { xyz_to_linear_srgb(c) } else { c }
    });
    let opacity = m
        .dissolve
        .filter(|d| d.is_finite())
        // `Tr 1` alone is how some exporters write "opaque" (the inverted convention), so a
        // fully transparent `Tr` without `d` is not believed.
        .or_else(|| {
            floats("Tr")
                .map(|t| t[0])
                .filter(|&t| t < 0.999)
                .map(|t| 1.0 - t)
        })
        .map(|d| d.clamp(0.0, 1.0));
    super::Transmission {
        // A black filter passes no light: Rhino writes `Tf 0 0 0` on every opaque material
        // (as 3ds Max writes a white one), and on glass it says nothing `d` does not.
        filter: filter
            .map(|f| f.map(|c| c.clamp(0.0, 1.0)))
            .filter(|f| f.iter().any(|&c| c > BLACK_FILTER)),
        opacity,
        illum: m.illumination_model,
        factor: None,
        blend: false,
    }
}

/// An MTL library as tobj can read it, every line checked here first so that a bad value is
/// an error naming its line (tobj's names none, and panicked on a one-value colour) and the
/// forms real files use read as they mean:
/// - colours (`Ka`, `Kd`, `Ks`, `Ke`, the transmission filter `Tf`) of one value are grey,
///   `xyz` ones are converted to linear sRGB, `spectral` ones (a curve in another file) are
///   dropped with a warning;
/// - `d -halo f` is `d f`; keywords in another case (`map_kd`, `KD`) are the keywords;
/// - text that is not UTF-8 has been decoded by the caller ([`text::decode_file`]).
///
/// Lines keep their numbers: a dropped line becomes empty.
fn clean_mtl(
    path: &Path,
    text: &str,
    warnings: &mut Vec<Warning>,
) -> Result<(String, TextureLines), CookError> {
    let fail = |line: usize, message: String| CookError::Source {
        path: path.to_path_buf(),
        line: Some(line),
        message,
    };
    // Those read here or by tobj, in their own case.
    const KEYWORDS: [&str; 19] = [
        "newmtl", "Ka", "Kd", "Ks", "Ke", "Ns", "Ni", "d", "Tr", "Tf", "illum", "map_Ka", "map_Kd",
        "map_Ks", "map_Ns", "map_Bump", "bump", "map_d", "norm",
    ];
    let mut out = String::with_capacity(text.len());
    let mut texture_lines = TextureLines::new();
    let mut material = String::new();
    // Each material's first line: a second definition is said.
    let mut defined: HashMap<String, usize> = HashMap::new();
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = raw.trim();
        let (word, rest) = line
            .split_once(char::is_whitespace)
            .map_or((line, ""), |(w, r)| (w, r.trim()));
        let key = KEYWORDS
            .iter()
            .find(|k| k.eq_ignore_ascii_case(word))
            .copied()
            .unwrap_or(word);
        // The numbers before any trailing comment, all of them numbers.
        let numbers = |rest: &str| -> Option<Vec<f32>> {
            rest.split_whitespace()
                .take_while(|t| !t.starts_with('#'))
                .map(|t| t.parse::<f32>().ok().filter(|v| v.is_finite()))
                .collect()
        };
        let cleaned = match key {
            "Ka" | "Kd" | "Ks" | "Ke" | "Tf" => {
                let (first, tail) = rest
                    .split_once(char::is_whitespace)
                    .map_or((rest, ""), |(f, t)| (f, t.trim_start()));
                let (space, values) = if first.eq_ignore_ascii_case("xyz") {
                    ("xyz", tail)
                } else if first.eq_ignore_ascii_case("spectral") {
                    ("spectral", "")
                } else {
                    ("rgb", rest)
                };
                if space == "spectral" {
                    warnings.push(Warning::new(
                        path,
                        Some(n),
                        format!(
                            "{key} spectral (a reflectance curve) is not read; {key} left unset"
                        ),
                    ));
                    String::new()
                } else {
                    let v = numbers(values).filter(|v| !v.is_empty()).ok_or_else(|| {
                        fail(n, format!("{key} wants 1 or 3 numbers, got {rest:?}"))
                    })?;
                    if v.len() > 3 {
                        // Some exporters append an alpha; nothing reads it.
                        warnings.push(Warning::new(
                            path,
                            Some(n),
                            format!(
                                "{key} takes 1 or 3 numbers, got {}; the ones after the third \
                                 are ignored",
                                v.len()
                            ),
                        ));
                    }
                    // One value is a grey; a missing component repeats the one before.
                    let c = [v[0], v[v.len().min(2) - 1], v[v.len().min(3) - 1]];
                    let c = if space == "xyz" {
                        xyz_to_linear_srgb(c)
                    } else {
                        c
                    };
                    format!("{key} {} {} {}", c[0], c[1], c[2])
                }
            }
            "Ns" | "Ni" | "d" | "Tr" => {
                let value = if key == "d" {
                    rest.strip_prefix("-halo").map_or(rest, str::trim_start)
                } else {
                    rest
                };
                let v = value
                    .split_whitespace()
                    .next()
                    .and_then(|t| t.parse::<f32>().ok())
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| fail(n, format!("{key} wants a number, got {rest:?}")))?;
                if matches!(key, "d" | "Tr") && !(0.0..=1.0).contains(&v) {
                    warnings.push(Warning::new(
                        path,
                        Some(n),
                        format!("{key} {v} is outside 0–1; read as {}", v.clamp(0.0, 1.0)),
                    ));
                }
                format!("{key} {v}")
            }
            "illum" => {
                let v = rest
                    .split_whitespace()
                    .next()
                    .and_then(|t| t.parse::<f32>().ok())
                    .filter(|v| v.fract() == 0.0 && (0.0..=255.0).contains(v))
                    .ok_or_else(|| {
                        fail(
                            n,
                            format!("illum wants an illumination model number, got {rest:?}"),
                        )
                    })?;
                format!("illum {}", v as u8)
            }
            "newmtl" if rest.is_empty() => {
                return Err(fail(n, "newmtl without a material name".into()));
            }
            "map_Ka" | "map_Kd" | "map_Ks" | "map_Ns" | "map_Bump" | "bump" | "map_d"
                if rest.is_empty() =>
            {
                warnings.push(Warning::new(
                    path,
                    Some(n),
                    format!("{key} names no file; ignored"),
                ));
                String::new()
            }
            _ if key != word => format!("{key} {rest}"),
            _ => raw.to_string(),
        };
        if key == "newmtl" {
            material = rest.to_string();
            if let Some(first) = defined.insert(material.clone(), n) {
                warnings.push(Warning::new(
                    path,
                    Some(n),
                    format!(
                        "material {material:?} is defined again (first on line {first}); this \
                         definition replaces that one"
                    ),
                ));
            }
        } else if let Some(k) = TextureKey::of(key).filter(|_| !rest.is_empty()) {
            texture_lines.insert((material.clone(), k), n);
        }
        out.push_str(&cleaned);
        out.push('\n');
    }
    Ok((out, texture_lines))
}

/// Which texture statement of a material a line held, so that its warnings name the line
/// (tobj keeps none).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum TextureKey {
    Diffuse,
    Bump,
    Norm,
}

impl TextureKey {
    /// The statement a (case-corrected) MTL keyword makes, where it names a texture read.
    fn of(keyword: &str) -> Option<Self> {
        match keyword {
            "map_Kd" => Some(Self::Diffuse),
            "map_Bump" | "bump" => Some(Self::Bump),
            "norm" => Some(Self::Norm),
            _ => None,
        }
    }
}

type TextureLines = HashMap<(String, TextureKey), usize>;

/// What warnings call a material's bump or normal map statement (the one `-bm` applies to).
const NORMAL_MAP: &str = "normal map";

/// An MTL texture statement (`map_Kd -s 2 2 1 -clamp on my design.png`): its options, then
/// the file name, which may contain spaces.
#[derive(Debug, PartialEq)]
struct TextureStatement<'a> {
    file: &'a str,
    /// `-o` and `-s` in u and v: a coordinate `uv` reads the texture at `uv * scale + offset`.
    offset: [f32; 2],
    scale: [f32; 2],
    /// `-bm`: the bump multiplier, which only a bump or normal map statement applies.
    bump_multiplier: Option<f32>,
    /// Options given that the cook does not model (`-clamp`, `-imfchan`, ...), by name.
    ignored: Vec<&'a str>,
}

impl<'a> TextureStatement<'a> {
    fn parse(rest: &'a str) -> Self {
        let mut st = TextureStatement {
            file: rest.trim(),
            offset: [0.0; 2],
            scale: [1.0; 2],
            bump_multiplier: None,
            ignored: Vec::new(),
        };
        let mut at = rest;
        loop {
            let trimmed = at.trim_start();
            let (word, after) = trimmed
                .split_once(char::is_whitespace)
                .unwrap_or((trimmed, ""));
            // Options and how many words follow them (-o, -s, -t: up to three numbers).
            let arity = match word {
                "-blendu" | "-blendv" | "-bm" | "-boost" | "-cc" | "-clamp" | "-imfchan"
                | "-texres" | "-type" | "-colorspace" => 1,
                "-mm" => 2,
                "-o" | "-s" | "-t" => 3,
                // An option we do not know (tools add their own), taken to have one value so
                // the options after it are still read: it ended the options, and `-o` after
                // it was lost with it. A name that starts with '-' and ends the line is the file.
                w if w.len() > 1
                    && w.starts_with('-')
                    && w.parse::<f32>().is_err()
                    && !after.trim().is_empty() =>
                {
                    1
                }
                _ => {
                    let file = trimmed.trim_end();
                    // Some exporters quote a name with spaces; no file is named so.
                    st.file = file
                        .strip_prefix('"')
                        .and_then(|f| f.strip_suffix('"'))
                        .filter(|f| !f.is_empty())
                        .unwrap_or(file);
                    return st;
                }
            };
            let mut after = after;
            let mut values = Vec::new();
            let mut first_arg = None;
            for _ in 0..arity {
                let t = after.trim_start();
                let (arg, next) = t.split_once(char::is_whitespace).unwrap_or((t, ""));
                let number = arg.parse::<f32>().ok().filter(|v| v.is_finite());
                // The file name is the last word, never an option's value; -o, -s and -t take
                // numbers only.
                if arg.is_empty() || next.trim().is_empty() || arity == 3 && number.is_none() {
                    break;
                }
                values.push(number);
                first_arg = first_arg.or(Some(arg));
                after = next;
            }
            match (word, values.as_slice()) {
                ("-o", [Some(u), rest @ ..]) => {
                    st.offset = [*u, rest.first().copied().flatten().unwrap_or(0.0)]
                }
                ("-s", [Some(u), rest @ ..]) => {
                    st.scale = [*u, rest.first().copied().flatten().unwrap_or(1.0)]
                }
                ("-bm", [Some(m)]) => st.bump_multiplier = Some(*m),
                ("-blendu" | "-blendv", _) => {}
                // What a colour texture is read as already.
                ("-colorspace", [_])
                    if first_arg.is_some_and(|a| a.eq_ignore_ascii_case("srgb")) => {}
                _ => st.ignored.push(word),
            }
            at = after;
        }
    }
}

fn load_mtllib(
    path: &Path,
    line: usize,
    rest: &[u8],
    out: &mut Imported,
    ids: &mut HashMap<String, u32>,
    missing_textures: &mut Vec<(String, Warning)>,
    given: Option<text::TextEncoding>,
) -> Result<Option<text::Decoded>, CookError> {
    let dir = path.parent().unwrap_or(Path::new(""));
    let (mut found, missing) = find_file(dir, rest, given, &mut out.absent);
    if found.is_empty() {
        // Exporters often name a library that was never shipped (`untitled.mtl`) while the
        // real one sits beside the OBJ under the OBJ's own name.
        let beside_name = path.with_extension("mtl");
        let beside_name = beside_name.file_name().map(text::file_name_text);
        let beside = beside_name
            .as_deref()
            .and_then(|n| super::locate_noted(dir, n, &mut out.absent));
        if let Some(beside) = beside.filter(|b| !out.files.contains(b)) {
            out.warnings.push(Warning::new(
                path,
                Some(line),
                format!(
                    "material library {:?} not found; using {} beside the OBJ instead",
                    name(rest),
                    beside.display()
                ),
            ));
            found.push(beside);
        } else {
            out.warnings.push(Warning::new(
                path,
                Some(line),
                format!("material library {:?} not found; materials keep their names but get default shading", name(rest)),
            ));
            return Ok(None);
        }
    }
    if !missing.is_empty() && found.len() > 1 {
        out.warnings.push(Warning::new(
            path,
            Some(line),
            format!("material libraries not found: {}", missing.join(", ")),
        ));
    }
    let mut read = None;
    for mtl in found {
        out.files.push(mtl.clone());
        let bytes = std::fs::read(&mtl).map_err(|source| CookError::Io {
            path: mtl.clone(),
            source,
        })?;
        let (mtl_text, decoded) =
            text::decode_file(bytes.strip_prefix(UTF8_BOM).unwrap_or(&bytes), given);
        if let Some(how) = decoded.describe() {
            out.warnings.push(Warning::new(&mtl, None, how));
        }
        if matches!(decoded, text::Decoded::Legacy { .. }) {
            read.get_or_insert(decoded);
        }
        let legacy = match decoded {
            text::Decoded::Legacy { encoding, .. } => Some(encoding),
            text::Decoded::Utf8 => None,
        };
        let (cleaned, texture_lines) = clean_mtl(&mtl, &mtl_text, &mut out.warnings)?;
        let (materials, _) =
            tobj::load_mtl_buf(&mut cleaned.as_bytes()).map_err(|e| CookError::Source {
                path: mtl.clone(),
                line: None,
                message: format!("material library cannot be parsed: {e}"),
            })?;
        let mtl_dir = mtl.parent().unwrap_or(Path::new("")).to_path_buf();
        for m in materials {
            let mut transforms = Vec::new();
            let mut bump_multiplier = None;
            let line_of = |k: TextureKey| texture_lines.get(&(m.name.clone(), k)).copied();
            let mut texture = |name: &Option<String>, what: &str, line: Option<usize>| {
                let name = name.as_deref()?.trim();
                if name.is_empty() {
                    return None;
                }
                let mut statement = TextureStatement::parse(name);
                if what == NORMAL_MAP {
                    bump_multiplier = statement.bump_multiplier;
                } else if statement.bump_multiplier.is_some() {
                    statement.ignored.push("-bm");
                }
                if !statement.ignored.is_empty() {
                    out.warnings.push(Warning::new(
                        &mtl,
                        line,
                        format!(
                            "{what} of material {:?}: options {} not applied",
                            m.name,
                            statement.ignored.join(", ")
                        ),
                    ));
                }
                // The parsed name, else the whole rest or one of its words.
                // A library that is not UTF-8 names files in its encoding: on disk they may
                // be named by those bytes (unpacked from a Windows archive) or in Unicode.
                let raw_bytes = |n: &str| legacy.map(|e| e.encode(n).0.into_owned());
                let noted = &mut out.absent;
                let file = super::locate_noted(&mtl_dir, statement.file, noted)
                    .or_else(|| find_file(&mtl_dir, name.as_bytes(), given, noted).0.pop())
                    .or_else(|| {
                        let raw = raw_bytes(statement.file)?;
                        super::locate_noted(&mtl_dir, &text::escaped(&raw), noted)
                    })
                    .or_else(|| {
                        let raw = raw_bytes(name)?;
                        find_file(&mtl_dir, &raw, given, noted).0.pop()
                    });
                match file {
                    Some(f) => {
                        // Only a texture read places the coordinates.
                        transforms.push((what.to_string(), statement.offset, statement.scale));
                        Some(ImageRef::File(f))
                    }
                    None => {
                        let w = Warning::new(
                            &mtl,
                            line,
                            format!(
                                "{what} {:?} of material {:?} not found; ignored",
                                statement.file, m.name
                            ),
                        );
                        missing_textures.push((m.name.clone(), w));
                        None
                    }
                }
            };
            let diffuse_texture = texture(
                &m.diffuse_texture,
                "diffuse texture",
                line_of(TextureKey::Diffuse),
            );
            // A bump statement first, as tobj reads it; a `norm` where its file is missing.
            let normal_texture = texture(&m.normal_texture, NORMAL_MAP, line_of(TextureKey::Bump))
                .or_else(|| {
                    texture(
                        &m.unknown_param.get("norm").cloned(),
                        NORMAL_MAP,
                        line_of(TextureKey::Norm),
                    )
                });
            // One set of coordinates serves both maps: the design's placement wins.
            let placed: Vec<_> = transforms
                .iter()
                .filter(|t| t.1 != [0.0; 2] || t.2 != [1.0; 2])
                .collect();
            let uv_transform = placed.first().map(|t| (t.1, t.2));
            if let [first, second] = placed[..]
                && (first.1, first.2) != (second.1, second.2)
            {
                out.warnings.push(Warning::new(
                    &mtl,
                    None,
                    format!(
                        "material {:?}: the {} is placed by other -o/-s options than the {}; \
                         both use the {}'s",
                        m.name, second.0, first.0, first.0
                    ),
                ));
            }
            let sm = SourceMaterial {
                name: m.name.clone(),
                diffuse: m.diffuse.unwrap_or([0.8; 3]),
                specular: m.specular.unwrap_or([0.0; 3]),
                shininess: m.shininess.unwrap_or(1.0),
                emissive: m.emissive.unwrap_or([0.0; 3]),
                diffuse_texture,
                normal_texture,
                normal_scale: bump_multiplier.unwrap_or(1.0),
                transmission: mtl_transmission(&m),
            };
            let finite = sm
                .diffuse
                .iter()
                .chain(&sm.specular)
                .chain(&sm.emissive)
                .all(|v| v.is_finite())
                && sm.shininess.is_finite();
            if !finite {
                return Err(CookError::Source {
                    path: mtl.clone(),
                    line: None,
                    message: format!("material {:?} has a non-finite colour or shininess", m.name),
                });
            }
            // A later definition of the same name wins, as in every OBJ reader.
            let id = match ids.get(&m.name) {
                Some(&i) => {
                    out.materials[i as usize] = sm;
                    i
                }
                None => {
                    ids.insert(m.name.clone(), out.materials.len() as u32);
                    out.materials.push(sm);
                    out.materials.len() as u32 - 1
                }
            };
            // The OBJ's `usemtl` names it by the same bytes, escaped until the OBJ is read.
            if let Some(e) = legacy {
                let raw = e.encode(&m.name).0;
                if std::str::from_utf8(&raw).is_err() {
                    ids.insert(text::escaped(&raw).into_owned(), id);
                }
            }
            out.uv_transforms.retain(|t| t.0 != id);
            if let Some((offset, scale)) = uv_transform {
                out.uv_transforms.push((id, offset, scale));
            }
        }
    }
    // Parts created before this mtllib could not resolve their material.
    for part in &mut out.parts {
        if part.material.is_none() {
            part.material = part
                .names
                .material
                .as_ref()
                .and_then(|n| ids.get(n).copied());
        }
    }
    Ok(read)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A model in survey coordinates: positions read in f64 less the first vertex's whole
    /// units, by the line reader, the chunked one and the streamed one alike.
    #[test]
    fn survey_coordinates_are_read_relative_to_the_first_vertex() {
        let text = "# scan\nv 500000.125 12.5 5000000.375\nv 500001.25 12.5 5000003.5\n\
                    v 500000.125 14.75 5000000.375\nf 1 2 3\n";
        let path = Path::new("scan.obj");
        let lines = parse_lines(path, text.as_bytes(), None).unwrap();
        assert_eq!(lines.origin, [500000.0, 0.0, 5000000.0]);
        assert_eq!(
            lines.positions,
            [
                [0.125, 12.5, 0.375],
                [1.25, 12.5, 3.5],
                [0.125, 14.75, 0.375]
            ]
        );
        let chunked = parse_chunked(path, text.as_bytes(), 16, None).unwrap();
        let mut reader = std::io::Cursor::new(text.as_bytes());
        let streamed = parse_stream(path, &mut reader, text.len() as u64, 16, 64, None).unwrap();
        for other in [chunked, streamed] {
            assert_eq!(other.origin, lines.origin);
            assert_eq!(other.positions, lines.positions);
        }
        // Near the origin nothing moves.
        let near = parse_lines(path, b"v 131000 1 2\nv 1 2 3\nv 0 0 1\nf 1 2 3\n", None).unwrap();
        assert_eq!(near.origin, [0.0; 3]);
        assert_eq!(near.positions[0], [131000.0, 1.0, 2.0]);
    }

    /// Vertex colours (`v x y z r g b`) are read by each reader alike: sRGB to linear, from 0–1
    /// or (where any is over 1) 0–255, white for a position without one; a `w` weight is not a
    /// colour; a colour that is not a number is an error naming the line.
    #[test]
    fn vertex_colours_are_read_as_scanners_write_them() {
        let path = Path::new("scan.obj");
        let text = "v 0 0 0\nv 1 0 0 1 0.5 0\nv 0 1 0 0.2 0.2 0.2\nv 0 0 1\nf 1 2 3\nf 2 3 4\n";
        let lines = parse_lines(path, text.as_bytes(), None).unwrap();
        let half = texture::srgb::srgb_to_linear(0.5) as f32;
        let fifth = texture::srgb::srgb_to_linear(0.2) as f32;
        assert_eq!(
            lines.colours,
            [
                [1.0; 4],
                [1.0, half, 0.0, 1.0],
                [fifth, fifth, fifth, 1.0],
                [1.0; 4]
            ]
        );
        let chunked = parse_chunked(path, text.as_bytes(), 16, None).unwrap();
        let mut reader = std::io::Cursor::new(text.as_bytes());
        let streamed = parse_stream(path, &mut reader, text.len() as u64, 16, 64, None).unwrap();
        for other in [chunked, streamed] {
            assert_eq!(other.colours, lines.colours);
        }
        let bytes = parse_lines(path, b"v 0 0 0 255 0 51\nv 1 0 0 0 255 0\n", None).unwrap();
        let want = [1.0, 0.0, fifth, 1.0];
        assert!(
            (0..4).all(|k| (bytes.colours[0][k] - want[k]).abs() < 1e-6),
            "{:?}",
            bytes.colours
        );
        // Fractions, one over 1: not bytes.
        let over = parse_lines(path, b"v 0 0 0 1.5 0.5 0\nv 1 0 0\n", None).unwrap();
        assert_eq!(over.colours[0], [1.0, half, 0.0, 1.0]);
        let plain = parse_lines(path, b"v 0 0 0 1\nv 1 0 0\n", None).unwrap();
        assert!(plain.colours.is_empty());
        let err = parse_lines(path, b"v 0 0 0\nv 1 0 0 0.5 red 0\n", None).unwrap_err();
        assert_eq!(
            err.to_string(),
            "scan.obj:2: vertex colour \"red\" is not a number of 0 or more"
        );
    }

    /// Rhino writes `Tf 0 0 0` on every opaque material and 3ds Max `Tf 1 1 1`: neither says
    /// glass. A coloured `Tf` does; on glass marked by `d`, a black `Tf` leaves the colour to
    /// `Kd`.
    #[test]
    fn black_and_white_transmission_filters_are_not_glass() {
        let dir = tempfile::tempdir().unwrap();
        let mtl = "newmtl rhino_wall\nKd 0.8 0.8 0.8\nTf 0.0000 0.0000 0.0000\nd 1.0000\n\
                   newmtl max_wall\nKd 0.8 0.8 0.8\nTf 1.0000 1.0000 1.0000\nd 1.0\n\
                   newmtl rhino_glass\nKd 0.9 0.1 0.1\nTf 0 0 0\nd 0.3\n\
                   newmtl tinted\nKd 1 1 1\nTf 0.9 0.1 0.1\nd 1\n";
        std::fs::write(dir.path().join("m.mtl"), mtl).unwrap();
        let mut obj = String::from("mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\n");
        for m in ["rhino_wall", "max_wall", "rhino_glass", "tinted"] {
            obj += &format!("usemtl {m}\nf 1 2 3\n");
        }
        std::fs::write(dir.path().join("m.obj"), obj).unwrap();
        let m = import(&dir.path().join("m.obj"), None).unwrap();
        let of = |name: &str| {
            let mat = m.materials.iter().find(|x| x.name == name).unwrap();
            (
                mat.transmission.glass_reason(),
                mat.transmission.transmitted(mat.diffuse),
            )
        };
        assert_eq!(of("rhino_wall").0, None);
        assert_eq!(of("max_wall").0, None);
        let (reason, (colour, amount)) = of("rhino_glass");
        assert_eq!(reason.as_deref(), Some("opacity 0.3 (MTL d / Tr)"));
        assert_eq!(colour, [0.9, 0.1, 0.1]);
        assert!((amount - 0.7).abs() < 1e-6);
        let (reason, (colour, _)) = of("tinted");
        assert_eq!(
            reason.as_deref(),
            Some("transmission filter Tf 0.9 0.1 0.1")
        );
        assert_eq!(colour, [0.9, 0.1, 0.1]);
    }

    /// An OBJ in windows-1251 beside its library saved again as UTF-8: the names are decoded
    /// (guessed from the OBJ's own), and `usemtl` finds its material by the decoded name.
    #[test]
    fn a_code_page_obj_finds_its_materials_in_a_utf8_library() {
        let dir = tempfile::tempdir().unwrap();
        let obj = "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\no Окно_южное\nusemtl Витраж_розы\nf 1 2 3\n\
                   g Пустая_группа\nusemtl Нет_такого\n";
        let bytes = encoding_rs::WINDOWS_1251.encode(obj).0;
        std::fs::write(dir.path().join("m.obj"), &bytes).unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl Витраж_розы\nKd 0.2 0.4 0.8\n",
        )
        .unwrap();
        let m = import(&dir.path().join("m.obj"), None).unwrap();
        let part = &m.parts[0];
        assert_eq!(part.names.object.as_deref(), Some("Окно_южное"));
        assert_eq!(part.names.material.as_deref(), Some("Витраж_розы"));
        assert_eq!(
            m.materials[part.material.unwrap() as usize].diffuse,
            [0.2, 0.4, 0.8]
        );
        assert_eq!(m.text_encoding.map(|e| e.name()), Some("windows-1251"));
        let warnings: Vec<String> = m.warnings.iter().map(|w| w.to_string()).collect();
        assert!(
            !warnings.iter().any(|w| w.contains("Витраж_розы")),
            "{warnings:?}"
        );
        // The ones that are missing are named in their letters.
        assert!(
            warnings
                .iter()
                .any(|w| w.contains("\"Нет_такого\" is not defined")),
            "{warnings:?}"
        );
        assert!(
            warnings
                .iter()
                .any(|w| w.contains("groups without faces: Пустая_группа")),
            "{warnings:?}"
        );
    }

    /// `mtllib храм.mtl` written in windows-1251, the library on disk under its Unicode name
    /// (a few letters are too little to guess an encoding from): found by its name, not
    /// replaced by the library beside the OBJ with a warning.
    #[test]
    fn a_library_named_in_a_code_page_is_found_by_its_letters() {
        let dir = tempfile::tempdir().unwrap();
        let obj = "mtllib храм.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl Стекло\nf 1 2 3\n";
        let bytes = encoding_rs::WINDOWS_1251.encode(obj).0;
        std::fs::write(dir.path().join("model.obj"), &bytes).unwrap();
        std::fs::write(
            dir.path().join("храм.mtl"),
            "newmtl Стекло\nKd 0.2 0.4 0.8\n",
        )
        .unwrap();
        let m = import(&dir.path().join("model.obj"), None).unwrap();
        let warnings: Vec<String> = m.warnings.iter().map(|w| w.to_string()).collect();
        assert!(
            !warnings.iter().any(|w| w.contains("not found")),
            "{warnings:?}"
        );
        assert_eq!(m.materials[0].diffuse, [0.2, 0.4, 0.8]);
    }

    /// MTL forms real files use: one-value colours (tobj panicked on them), CIE XYZ and
    /// spectral colours, `d -halo`, keywords in other cases, trailing comments, text that is
    /// not UTF-8; bad values are errors naming their line.
    #[test]
    fn mtl_lines_are_checked_and_read_as_they_mean() {
        let path = Path::new("m.mtl");
        let mut warnings = Vec::new();
        let text = "newmtl grey\nKd 0.5\nKA spectral wood.rfl 1\nks xyz 0.5\n\
                    newmtl caf\u{e9}\r\nD -halo 0.25\nKd 1 0 0.5 # red\nMAP_KD a.png\nillum 4\n";
        let bytes: Vec<u8> = text.chars().map(|c| c as u32 as u8).collect();
        // Latin-1 bytes: read as windows-1252, as guessed.
        let (decoded, how) = text::decode_file(&bytes, None);
        assert_eq!(
            how.describe().unwrap().split(';').nth(1).unwrap().trim(),
            "read as windows-1252 (guessed from the text"
        );
        let (cleaned, lines) = clean_mtl(path, &decoded, &mut warnings).unwrap();
        assert_eq!(cleaned.lines().count(), text.lines().count());
        assert_eq!(lines[&("caf\u{e9}".to_string(), TextureKey::Diffuse)], 8);
        assert!(warnings[0].to_string().contains("m.mtl:3"), "{warnings:?}");
        let (materials, _) = tobj::load_mtl_buf(&mut cleaned.as_bytes()).unwrap();
        assert_eq!(materials[0].diffuse, Some([0.5; 3]));
        assert_eq!(materials[0].ambient, None);
        assert_eq!(materials[0].specular, Some([0.5; 3]));
        assert_eq!(materials[1].name, "caf\u{e9}");
        assert_eq!(materials[1].dissolve, Some(0.25));
        assert_eq!(materials[1].diffuse, Some([1.0, 0.0, 0.5]));
        assert_eq!(materials[1].diffuse_texture.as_deref(), Some("a.png"));
        assert_eq!(materials[1].illumination_model, Some(4));
        // The transmission filter reads as the colours do.
        let mut tf_warnings = Vec::new();
        let text = "newmtl g\ntf spectral glass.rfl 1.0\nnewmtl h\nTf xyz 0.5\nTr 0.25\n";
        let (cleaned, _) = clean_mtl(path, text, &mut tf_warnings).unwrap();
        assert_eq!(
            cleaned, "newmtl g\n\nnewmtl h\nTf 0.5 0.5 0.5\nTr 0.25\n",
            "{tf_warnings:?}"
        );
        assert_eq!(tf_warnings.len(), 1);
        // Keywords in any case; extra colour values and opacities outside 0–1 are said.
        let mut odd = Vec::new();
        let text = "newmtl h\nTF XYZ 0.5\nKd 0.8 0.8 0.8 1.0\nd 1.7\nTr -0.5\nKs Spectral x.rfl\n";
        let (cleaned, _) = clean_mtl(path, text, &mut odd).unwrap();
        assert_eq!(
            cleaned,
            "newmtl h\nTf 0.5 0.5 0.5\nKd 0.8 0.8 0.8\nd 1.7\nTr -0.5\n\n"
        );
        assert_eq!(
            odd.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
            [
                "m.mtl:3: Kd takes 1 or 3 numbers, got 4; the ones after the third are ignored",
                "m.mtl:4: d 1.7 is outside 0–1; read as 1",
                "m.mtl:5: Tr -0.5 is outside 0–1; read as 0",
                "m.mtl:6: Ks spectral (a reflectance curve) is not read; Ks left unset",
            ]
        );
        // A material defined twice in one library: the later one is read, and said.
        let mut twice = Vec::new();
        clean_mtl(
            path,
            "newmtl a\nKd 1 0 0\nnewmtl b\nnewmtl a\nKd 0 0 1\n",
            &mut twice,
        )
        .unwrap();
        assert_eq!(
            twice.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
            [
                "m.mtl:4: material \"a\" is defined again (first on line 1); this definition \
              replaces that one"
            ]
        );
        assert!(
            tf_warnings[0].to_string().contains("m.mtl:2")
                && tf_warnings[0].to_string().contains("Tf spectral"),
            "{tf_warnings:?}"
        );
        for (bad, line, what) in [
            ("newmtl a\nKd 0.5 x 1\n", 2, "Kd wants 1 or 3 numbers"),
            ("newmtl a\n\nNs high\n", 3, "Ns wants a number"),
            // Half a colour is not a grey, and decimal commas are not numbers.
            ("newmtl a\nTf 0.9 abc 0.1\n", 2, "Tf wants 1 or 3 numbers"),
            ("newmtl a\nTf 0,9 0,1 0,1\n", 2, "Tf wants 1 or 3 numbers"),
            ("newmtl a\nd 1\nTr 0,5\n", 3, "Tr wants a number"),
            (
                "newmtl a\nillum 2.5\n",
                2,
                "illum wants an illumination model number",
            ),
            ("newmtl\n", 1, "newmtl without a material name"),
        ] {
            let e = clean_mtl(path, bad, &mut warnings).unwrap_err().to_string();
            assert!(
                e.contains(&format!("m.mtl:{line}")) && e.contains(what),
                "{e}"
            );
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(500))]
        /// Whatever an MTL holds, checking it either names a bad line or gives text tobj reads
        /// without failing or panicking (it panicked on a one-value colour).
        #[test]
        fn any_mtl_is_refused_by_line_or_read(
            lines in prop::collection::vec(
                (
                    prop::sample::select(vec![
                        "newmtl", "Ka", "Kd", "KD", "Ks", "Ke", "Ns", "Ni", "d", "D", "Tr", "Tf",
                        "illum", "map_Kd", "map_kd", "map_Ka", "map_Ks", "map_Ns", "map_Bump",
                        "map_bump", "bump", "map_d", "norm", "#", "", "frob", "newmtl\u{e9}",
                    ]),
                    prop::collection::vec(
                        prop::sample::select(vec![
                            "0.5", "1", "-2", "1e40", "nan", "inf", "x", "xyz", "spectral",
                            "-halo", "#", "a.png", "-s", "-o", "-clamp", "on", "\u{e9}", "",
                        ]),
                        0..5,
                    ),
                    prop::sample::select(vec!["\n", "\r\n"]),
                ),
                0..12,
            ),
        ) {
            let text: String = lines
                .iter()
                .map(|(k, words, end)| format!("{k} {}{end}", words.join(" ")))
                .collect();
            let mut warnings = Vec::new();
            match clean_mtl(Path::new("m.mtl"), &text, &mut warnings) {
                Ok((cleaned, _)) => {
                    prop_assert_eq!(cleaned.lines().count(), text.lines().count());
                    let read = tobj::load_mtl_buf(&mut cleaned.as_bytes());
                    prop_assert!(read.is_ok(), "{}", cleaned);
                }
                Err(e) => prop_assert!(e.to_string().contains("m.mtl:"), "{}", e),
            }
        }
    }

    /// Texture and library names as Windows exporters write them: backslashes, another
    /// letter case, an absolute path from the machine they were made on, a folder that the
    /// archive did not keep.
    #[test]
    fn files_are_found_as_windows_exporters_name_them() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("Textures")).unwrap();
        let file = dir.path().join("Textures").join("Glass Red.png");
        std::fs::write(&file, b"x").unwrap();
        std::fs::write(dir.path().join("beside.png"), b"x").unwrap();
        let d = dir.path();
        for name in [
            "Textures/Glass Red.png",
            "Textures\\Glass Red.png",
            "textures\\glass red.PNG",
            "./TEXTURES/glass red.png",
        ] {
            assert_eq!(super::super::locate(d, name), Some(file.clone()), "{name}");
        }
        assert_eq!(
            super::super::locate(d, "C:\\Users\\me\\Desktop\\Beside.png"),
            Some(d.join("beside.png"))
        );
        assert_eq!(
            super::super::locate(d, "C:\\Projekte\\Kirche\\textures\\GLASS red.png"),
            Some(file.clone())
        );
        assert_eq!(
            super::super::locate(d, "/home/me/Textures/glass red.png"),
            Some(file.clone())
        );
        // A relative folder that is not there, or does not hold the file: an archive that put
        // every file beside the model (Sponza's `textures\\...` flattened).
        for name in ["maps\\Beside.PNG", "textures\\beside.png", "a/b/beside.png"] {
            assert_eq!(
                super::super::locate(d, name),
                Some(d.join("beside.png")),
                "{name}"
            );
        }
        assert_eq!(super::super::locate(d, "missing.png"), None);
        assert_eq!(super::super::locate(d, "maps\\missing.png"), None);
        assert_eq!(super::super::locate(d, "Textures"), None);
    }

    #[test]
    fn texture_statements_give_options_then_a_file_name_with_spaces() {
        let st = TextureStatement::parse("-s 2 3 1 -o 0.5 -clamp on -bm 0.3 my design.png ");
        assert_eq!(
            st,
            TextureStatement {
                file: "my design.png",
                offset: [0.5, 0.0],
                scale: [2.0, 3.0],
                bump_multiplier: Some(0.3),
                ignored: vec!["-clamp"],
            }
        );
        // -s with one number scales u only; a name is what follows the last option.
        let st = TextureStatement::parse("-s 2 -blendu off design.png");
        assert_eq!(
            (st.file, st.scale, st.ignored.len()),
            ("design.png", [2.0, 1.0], 0)
        );
        assert_eq!(TextureStatement::parse("plain.png").file, "plain.png");
        // A quoted name is the name inside the quotes.
        assert_eq!(
            TextureStatement::parse("-s 2 2 1 \"My Rose.png\"").file,
            "My Rose.png"
        );
        assert_eq!(TextureStatement::parse("\"\"").file, "\"\"");
        assert_eq!(TextureStatement::parse("-frob.png").file, "-frob.png");
        // An option missing its value does not take the file name.
        assert_eq!(
            TextureStatement::parse("-clamp design.png").file,
            "design.png"
        );
        assert_eq!(TextureStatement::parse("-o design.png").file, "design.png");
        assert_eq!(TextureStatement::parse("-s 2 design.png").scale, [2.0, 1.0]);
        // `-colorspace` (tinyobjloader's, and its `colorspace-issue-184.mtl`) and options no
        // one here knows take one value, and the options after them still count; sRGB is
        // what a colour map is read as, so only another space is named as not applied.
        let st = TextureStatement::parse("-colorspace sRGB -o 0.5 0.25 d.png");
        assert_eq!(
            (st.file, st.offset, st.ignored.len()),
            ("d.png", [0.5, 0.25], 0)
        );
        let st = TextureStatement::parse("-colorspace linear -bm 3 bumpmap.jpg");
        assert_eq!(
            (st.file, st.bump_multiplier, st.ignored),
            ("bumpmap.jpg", Some(3.0), vec!["-colorspace"])
        );
        let st = TextureStatement::parse("-frobnicate 3 -s 2 2 1 my d.png");
        assert_eq!(
            (st.file, st.scale, st.ignored),
            ("my d.png", [2.0, 2.0], vec!["-frobnicate"])
        );
    }

    /// `map_Kd -o/-s` place the texture on the material's triangles; a coordinate shared
    /// with another material keeps its place there; a file name after options may hold
    /// spaces.
    #[test]
    fn mtl_texture_options_place_the_texture() {
        let dir = tempfile::tempdir().unwrap();
        image::RgbaImage::from_pixel(2, 2, image::Rgba([1, 2, 3, 255]))
            .save(dir.path().join("a design.png"))
            .unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl glass\nmap_Kd -s 2 4 1 -o 0.5 0.25 0 -cc on a design.png\n\
             newmtl stone\nKd 0.5 0.5 0.5\n",
        )
        .unwrap();
        let obj = dir.path().join("m.obj");
        std::fs::write(
            &obj,
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
             usemtl glass\nf 1/1 2/2 3/3\nusemtl stone\nf 1/1 3/3 2/2\n",
        )
        .unwrap();
        let m = import(&obj, None).unwrap();
        assert_eq!(
            m.materials[0].diffuse_texture,
            Some(ImageRef::File(dir.path().join("a design.png")))
        );
        let uv = |t: usize, k: usize| {
            let [u, v] = m.uvs[m.corners.get(3 * t + k).t as usize];
            [u, 1.0 - v]
        };
        // Glass: uv * (2, 4) + (0.5, 0.25); stone as written.
        assert_eq!(
            [uv(0, 0), uv(0, 1), uv(0, 2)],
            [[0.5, 0.25], [2.5, 0.25], [2.5, 4.25]]
        );
        assert_eq!(
            [uv(1, 0), uv(1, 1), uv(1, 2)],
            [[0.0, 0.0], [1.0, 1.0], [1.0, 0.0]]
        );
        assert!(
            m.warnings.iter().any(|w| w.to_string().contains(
                "m.mtl:2: diffuse texture of material \"glass\": options -cc not applied"
            )),
            "{:?}",
            m.warnings
        );
    }

    /// A missing bump map leaves the material's `norm` map in use, its placement does not
    /// move the coordinates, and the warning names the file without its options.
    #[test]
    fn a_missing_bump_map_falls_back_to_norm() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::create_dir(dir.path().join("Textures")).unwrap();
        image::RgbaImage::from_pixel(2, 2, image::Rgba([128, 128, 255, 255]))
            .save(dir.path().join("Textures/stone.png"))
            .unwrap();
        std::fs::write(
            dir.path().join("m.mtl"),
            "newmtl stone\nmap_Bump -s 4 4 1 -bm 2 gone.png\nnorm Textures/stone.png\n",
        )
        .unwrap();
        let obj = dir.path().join("m.obj");
        std::fs::write(
            &obj,
            "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
             usemtl stone\nf 1/1 2/2 3/3\n",
        )
        .unwrap();
        let m = import(&obj, None).unwrap();
        assert_eq!(
            m.materials[0].normal_texture,
            Some(ImageRef::File(dir.path().join("Textures/stone.png")))
        );
        // `vt 1 0` as written (v is stored flipped), not scaled by the missing map's `-s 4`.
        assert_eq!(m.uvs[m.corners.get(1).t as usize], [1.0, 1.0]);
        assert!(
            m.warnings.iter().any(|w| w
                .to_string()
                .contains("m.mtl:2: normal map \"gone.png\" of material \"stone\" not found")),
            "{:?}",
            m.warnings
        );
    }

    #[test]
    fn tf_in_rgb_grey_and_cie_xyz_is_a_linear_rgb_filter() {
        let filter = |tf: &str| {
            let mut m = tobj::Material::default();
            m.unknown_param.insert("Tf".into(), tf.into());
            mtl_transmission(&m).filter
        };
        assert_eq!(filter("0.8 0.1 0.1"), Some([0.8, 0.1, 0.1]));
        assert_eq!(filter("0.5"), Some([0.5; 3]));
        assert_eq!(filter("spectral glass.rfl"), None);
        // D65 white is white; an sRGB red's XYZ is that red.
        let white = filter("xyz 0.9505 1.0 1.089").unwrap();
        assert!(white.iter().all(|c| (c - 1.0).abs() < 1e-3), "{white:?}");
        let red = filter("xyz 0.4124 0.2126 0.0193").unwrap();
        assert!((red[0] - 1.0).abs() < 1e-3 && red[1].abs() < 1e-3 && red[2].abs() < 1e-3);
        assert_eq!(filter("xyz 0.3"), Some([0.3; 3]));
    }

    proptest! {
        #[test]
        fn lines_are_those_split_gives(s in "[a\n]{0,12}") {
            let want: Vec<&[u8]> = s.as_bytes().split(|&b| b == b'\n').collect();
            prop_assert_eq!(lines(s.as_bytes()).collect::<Vec<_>>(), want);
        }

        #[test]
        fn integers_parse_as_std_does(s in "[-+]?[0-9]{0,21}|[-+0-9a ]{0,4}", n in any::<i64>()) {
            prop_assert_eq!(parse_i64(s.as_bytes()), s.parse::<i64>().ok());
            let t = n.to_string();
            prop_assert_eq!(parse_i64(t.as_bytes()), Some(n));
        }
    }

    proptest! {
        #[test]
        fn floats_parse_as_std_does(
            s in "[-+]?[0-9]{0,9}(\\.[0-9]{0,9})?([eE][-+]?[0-9]{0,3})?|[-+0-9.eE a]{0,6}|0{10,30}[1-9]?\\.?[0-9]{0,4}",
            v in any::<f32>(),
        ) {
            prop_assert_eq!(
                parse_f32(s.as_bytes()).map(f32::to_bits),
                s.parse::<f32>().ok().map(f32::to_bits)
            );
            let t = v.to_string();
            prop_assert_eq!(parse_f32(t.as_bytes()).map(f32::to_bits), Some(v.to_bits()));
        }
    }

    #[test]
    fn simple_floats_are_the_correctly_rounded_ones() {
        // Every 7-digit mantissa at a few exponents, against str::parse.
        for m in (0..=9_999_999u32).step_by(7) {
            for e in [-10, -7, -3, 0, 4] {
                let t = format!("{m}e{e}");
                assert_eq!(
                    simple_f32(t.as_bytes()).map(f32::to_bits),
                    t.parse::<f32>()
                        .ok()
                        .map(f32::to_bits)
                        .filter(|_| m < 1 << 24),
                    "{t}"
                );
            }
        }
    }

    /// Everything an import says, for comparing two parses.
    fn summary(r: Result<Imported, CookError>) -> String {
        match r {
            Ok(m) => format!(
                "{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{:?}\n{}\n{:?}\n{:?}",
                m.colours
                    .iter()
                    .flatten()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                m.positions
                    .iter()
                    .flatten()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                m.uvs
                    .iter()
                    .flatten()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                m.normals
                    .iter()
                    .flatten()
                    .map(|v| v.to_bits())
                    .collect::<Vec<_>>(),
                m.corners,
                m.tri_part,
                m.parts,
                m.polygons,
                m.warnings.iter().map(|w| w.to_string()).collect::<Vec<_>>(),
                m.materials,
            ),
            Err(e) => format!("error: {e}"),
        }
    }

    fn obj_line() -> impl Strategy<Value = String> {
        let index = prop_oneof![
            (1i64..12).prop_map(|i| i.to_string()),
            (-12i64..0).prop_map(|i| i.to_string()),
            Just("0".to_string()),
            Just("x".to_string()),
            // Beyond what a chunk stores in 32 bits, and the i64 edges.
            prop::sample::select(vec![
                "2147483647",
                "2147483648",
                "-2147483646",
                "-2147483647",
                "-2147483648",
                "-2147483649",
                "9223372036854775807",
                "-9223372036854775808",
                "9223372036854775808",
                // Where plain corners end: 9 digits, 10, signs, leading zeros.
                "000000003",
                "0000000003",
                "-000000003",
                "+3",
                "-",
                "--2",
                "",
            ])
            .prop_map(str::to_string),
        ];
        let corner = prop_oneof![
            index.clone(),
            (index.clone(), index.clone()).prop_map(|(a, b)| format!("{a}/{b}")),
            (index.clone(), index.clone()).prop_map(|(a, b)| format!("{a}//{b}")),
            (index.clone(), index.clone(), index).prop_map(|(a, b, c)| format!("{a}/{b}/{c}")),
        ];
        let number = prop_oneof![
            (-1000i32..1000).prop_map(|i| format!("{}", i as f32 / 7.0)),
            Just("1e3".to_string()),
            Just("nan".to_string()),
        ];
        prop_oneof![
            6 => prop::collection::vec(number.clone(), 3).prop_map(|v| format!("v {}", v.join(" "))),
            // With a colour (MeshLab's `v x y z r g b`), on some positions only.
            2 => prop::collection::vec(number.clone(), 6).prop_map(|v| format!("v {}", v.join(" "))),
            2 => prop::collection::vec(number.clone(), 2).prop_map(|v| format!("vt {}", v.join(" "))),
            2 => prop::collection::vec(number.clone(), 3).prop_map(|v| format!("vn {}", v.join(" "))),
            // Attribute lines of other lengths, spacing and number forms, plain or not.
            3 => (
                prop::sample::select(vec!["v", "vt", "vn"]),
                prop::collection::vec(
                    (
                        prop_oneof![
                            number,
                            prop::sample::select(vec!["inf", "-0", "+.5", "5.", "1e40", "1e-45", "0x1", "1e", "16777217", "123456789012", "x"])
                                .prop_map(str::to_string),
                        ],
                        prop::sample::select(vec![" ", "  ", "\t", " \r"]),
                    ),
                    0..5,
                ),
            )
                .prop_map(|(k, v)| format!("{k} {}", v.into_iter().map(|(n, s)| n + s).collect::<String>())),
            8 => prop::collection::vec(corner.clone(), 2..6).prop_map(|v| format!("f {}", v.join(" "))),
            // Corners with other spacing and trailing fields, read by the plain path or not.
            2 => prop::collection::vec((prop_oneof![corner, prop::sample::select(vec!["/1", "-/1", "1/-", "/", "1/+2", "-1//-1", "1/1/1"]).prop_map(str::to_string)], prop::sample::select(vec![" ", "  ", "\t", " \r", "/", "//", "/1/2/3 "])), 1..5)
                .prop_map(|v| format!("f {}", v.into_iter().map(|(c, s)| c + s).collect::<String>())),
            1 => "[abc]{0,2}".prop_map(|n| format!("g {n}")),
            1 => "[ab]{1}".prop_map(|n| format!("o {n}")),
            1 => "[xy]{0,1}".prop_map(|n| format!("usemtl {n}")),
            1 => Just("l 1 2".to_string()),
            1 => Just("p 1".to_string()),
            1 => Just("# comment".to_string()),
            1 => Just("frobnicate 3".to_string()),
            1 => Just("".to_string()),
        ]
    }

    /// [`summary`] of `text` streamed in chunks of `chunk` and blocks of `block` bytes, with
    /// `size` bytes expected (its own length if `None`).
    fn streamed(text: &str, size: Option<u64>, chunk: usize, block: usize) -> String {
        let mut reader = std::io::Cursor::new(text.as_bytes());
        let size = size.unwrap_or(text.len() as u64);
        summary(parse_stream(
            Path::new("test.obj"),
            &mut reader,
            size,
            chunk,
            block,
            None,
        ))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Split into chunks of a few lines, an OBJ reads as it does line by line, errors and
        /// warnings included.
        #[test]
        fn chunked_parse_agrees_with_line_by_line(
            lines in prop::collection::vec(obj_line(), 0..60),
            chunk in 1usize..200,
        ) {
            let text = lines.join("\n");
            let path = Path::new("test.obj");
            prop_assert_eq!(
                summary(parse_chunked(path, text.as_bytes(), chunk, None)),
                summary(parse_lines(path, text.as_bytes(), None))
            );
        }

        /// Streamed in blocks of a few bytes (lines longer than a block carried into the
        /// next), an OBJ reads as it does line by line; a NUL anywhere is the binary-file error.
        #[test]
        fn streamed_parse_agrees_with_line_by_line(
            lines in prop::collection::vec(obj_line(), 0..60),
            chunk in 1usize..200,
            block in 1usize..300,
            nul in prop::option::of(0usize..60),
            size in prop::option::of(0u64..10_000),
        ) {
            let mut text = lines.join("\n");
            if let Some(at) = nul {
                text.insert(text.len().min(at * 7), '\0');
            }
            let path = Path::new("test.obj");
            let want = match not_text(path, text.as_bytes(), true) {
                Some(e) => Err(e),
                None => parse_lines(path, text.as_bytes(), None),
            };
            prop_assert_eq!(streamed(&text, size, chunk, block), summary(want));
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        /// Lines continued with a backslash (LF or CRLF) read the same streamed in blocks of a
        /// few bytes, where a continued line may straddle blocks, as joined whole.
        #[test]
        fn continued_lines_stream_as_they_read_whole(
            lines in prop::collection::vec(
                (obj_line(), prop::sample::select(vec!["\n", "\n", "\\\n", "\\\r\n", "\r\n"])),
                0..60,
            ),
            chunk in 1usize..200,
            block in 1usize..300,
        ) {
            let text: String = lines.into_iter().map(|(l, end)| l + end).collect();
            let path = Path::new("test.obj");
            prop_assert_eq!(
                streamed(&text, None, chunk, block),
                summary(parse(path, text.as_bytes()))
            );
        }
    }

    #[test]
    fn a_vertex_continuing_a_line_does_not_place_the_survey_origin() {
        // The `v` after the backslash belongs to the line before; the file's first vertex is
        // the far one, so both readers move the file by it.
        let text = "l 1 2\\\nv 0 0 0\nv 500000 20 30\nv 500001 20 30\nv 500000 21 30\nf 1 2 3\n";
        let whole = parse(Path::new("test.obj"), text.as_bytes()).unwrap();
        assert_eq!(whole.origin, [500000.0, 0.0, 0.0]);
        for block in [1, 7, 64] {
            let mut reader = std::io::Cursor::new(text.as_bytes());
            let streamed = parse_stream(
                Path::new("test.obj"),
                &mut reader,
                text.len() as u64,
                16,
                block,
                None,
            )
            .unwrap();
            assert_eq!(streamed.origin, whole.origin, "block {block}");
            assert_eq!(streamed.positions, whole.positions, "block {block}");
        }
    }

    #[test]
    fn continued_lines_are_joined_in_place() {
        let join = |s: &str| {
            let mut b = s.as_bytes().to_vec();
            join_continued_lines(&mut b);
            String::from_utf8(b).unwrap()
        };
        assert_eq!(join("f 1 2 \\\n 3\nv\n"), "f 1 2   3\n\nv\n");
        assert_eq!(join("f 1 \\\r\n2 \\\n3\r\nv"), "f 1  2  3\r \n\n\nv");
        // A comment or a name is not joined; a backslash inside a line is kept.
        assert_eq!(join("# C:\\dir\\\nv 1 2 3\\\n"), "# C:\\dir\\\nv 1 2 3 \n");
        assert_eq!(
            join("g C:\\export\\\nf 1 2 3\n"),
            "g C:\\export\\\nf 1 2 3\n"
        );
        assert_eq!(join("usemtl a\\b\n"), "usemtl a\\b\n");
        // A face wrapped over three lines reads as one, and later lines keep their numbers.
        let m = parse_str("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 \\\n3 \\\n 4\nf 1 2 x\n");
        let e = m.unwrap_err().to_string();
        assert!(e.contains("test.obj:8"), "{e}");
        let m = parse_str("v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 \\\r\n3 \\\n 4\n").unwrap();
        assert_eq!(m.tri_part.len(), 2);
        // A continuation onto the end of a file without a last line end continues onto nothing.
        assert_eq!(join("f 1 2 3 \\"), "f 1 2 3  ");
        let m = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 \\").unwrap();
        assert_eq!(m.tri_part.len(), 1);
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(100))]
        /// Faces whose texture-coordinate and normal indices are their position indices, as
        /// many writers number them, stream into corners that hold the position indices only,
        /// and a face numbered otherwise anywhere in the file reads as it does line by line.
        #[test]
        fn fields_that_follow_the_positions_are_not_held(
            faces in 1usize..400,
            odd in prop::option::of((0usize..400, 0usize..3)),
            chunk in 1usize..300,
            block in 20usize..600,
        ) {
            let mut text = String::new();
            for i in 0..12 {
                text += &format!("v {i} {} 0\nvt 0.{i} 0.5\nvn 0 0 1\n", i % 3);
            }
            let form = |f: usize, i: usize, k: usize| match odd {
                Some((at, field)) if at % faces == f && k == 0 => match field {
                    0 => format!("{i}/{}/{i}", i % 12 + 1),
                    1 => format!("{i}/{i}/{}", i % 12 + 1),
                    _ => format!("{i}/{i}"),
                },
                _ => format!("{i}/{i}/{i}"),
            };
            for f in 0..faces {
                let c: Vec<String> = (0..3).map(|k| form(f, (f + k) % 12 + 1, k)).collect();
                text += &format!("f {}\n", c.join(" "));
            }
            let path = Path::new("test.obj");
            let lines = parse_lines(path, text.as_bytes(), None);
            prop_assert_eq!(streamed(&text, None, chunk, block), summary(lines));
            let m = streamed_imported(&text, chunk, block);
            let held = [&m.corners.t, &m.corners.n];
            match odd {
                None => prop_assert_eq!(held, [&Indices::Positions; 2]),
                Some((_, field)) => prop_assert!(matches!(
                    held[field.min(1)],
                    Indices::Own(_)
                )),
            }
        }
    }

    fn streamed_imported(text: &str, chunk: usize, block: usize) -> Imported {
        let mut reader = std::io::Cursor::new(text.as_bytes());
        let size = text.len() as u64;
        parse_stream(Path::new("test.obj"), &mut reader, size, chunk, block, None).unwrap()
    }

    /// A valid OBJ from `ops`: vertex, texture-coordinate and normal lines, and faces whose
    /// corners use only what is defined before them, in every corner form, so texture
    /// coordinates and normals first appear anywhere in the file.
    fn valid_obj(ops: &[(u8, u32, u8, u8)]) -> String {
        let (mut v, mut t, mut n) = (0u32, 0u32, 0u32);
        let mut text = String::new();
        for &(kind, seed, form, corners) in ops {
            match kind {
                0 => {
                    v += 1;
                    text += &format!("v {} {} {}\n", seed % 7, seed % 5, v % 3);
                }
                1 => {
                    t += 1;
                    text += &format!("vt 0.{} 0.{}\n", seed % 10, t % 10);
                }
                2 => {
                    n += 1;
                    text += &format!("vn 0 {} 1\n", seed % 3);
                }
                _ if v > 0 => {
                    // Absolute or relative, from the seed's bits.
                    let index = |count: u32, k: u32| {
                        let i = (seed >> (3 * k)) % count;
                        if (seed >> (20 + k % 8)) & 1 == 0 {
                            (i + 1).to_string()
                        } else {
                            format!("-{}", count - i)
                        }
                    };
                    let corner = |k: u32| match form {
                        1 if t > 0 => format!("{}/{}", index(v, k), index(t, k + 1)),
                        2 if n > 0 => format!("{}//{}", index(v, k), index(n, k + 2)),
                        3 if t > 0 && n > 0 => {
                            format!("{}/{}/{}", index(v, k), index(t, k + 1), index(n, k + 2))
                        }
                        _ => index(v, k),
                    };
                    let corners: Vec<String> = (0..u32::from(corners)).map(corner).collect();
                    text += &format!("f {}\n", corners.join(" "));
                }
                _ => {}
            }
        }
        text
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        /// Valid files streamed in blocks of any size, with a wrong size expected or not,
        /// read as they do line by line.
        #[test]
        fn valid_files_stream_as_they_read_line_by_line(
            ops in prop::collection::vec((0u8..6, any::<u32>(), 0u8..4, 3u8..6), 0..120),
            chunk in 1usize..200,
            block in 1usize..400,
            size in prop::option::of(0u64..20_000),
        ) {
            let text = valid_obj(&ops);
            let want = parse_lines(Path::new("test.obj"), text.as_bytes(), None);
            prop_assert!(want.is_ok(), "{:?}", want.err());
            prop_assert_eq!(streamed(&text, size, chunk, block), summary(want));
        }
    }

    #[test]
    fn arrays_are_sized_ahead_and_grow_geometrically_past_the_expected_size() {
        let mut v: Vec<u32> = Vec::new();
        // A batch of 1000 with three times its bytes still to come: room for 4000.
        reserve_ahead(&mut v, 1000, 3.0);
        assert!(v.capacity() >= 4000, "{}", v.capacity());
        v.resize(4000, 0);
        // Past it (a file longer than its size said), not copied batch after batch.
        let (mut copies, mut capacity) = (0, v.capacity());
        for _ in 0..1000 {
            reserve_ahead(&mut v, 1000, 0.0);
            v.extend(std::iter::repeat_n(0, 1000));
            if v.capacity() != capacity {
                copies += 1;
                capacity = v.capacity();
            }
        }
        assert!(copies <= 10, "{copies} copies");
    }

    #[test]
    fn a_large_obj_is_streamed_from_its_file() {
        // Over PARALLEL_BYTES, so it takes the streamed path (in one block here: the proptest
        // above cuts blocks of a few bytes), with a CRLF line and a face far from its vertices.
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.obj");
        let mut text = String::from("v 0 0 0\r\nv 1 0 0\nv 0 1 0\n");
        while text.len() < PARALLEL_BYTES + 1000 {
            text.push_str("# padding of comments\n");
        }
        text.push_str("f 1 2 3\nf -3 -2 -1");
        std::fs::write(&path, &text).unwrap();
        assert_eq!(
            summary(import(&path, None)),
            summary(parse_lines(&path, text.as_bytes(), None))
        );
        let m = import(&path, None).unwrap();
        assert_eq!(m.triangle_count(), 2);
        std::fs::write(&path, format!("{text}\n\0")).unwrap();
        let e = import(&path, None).unwrap_err().to_string();
        assert!(e.contains("big.obj:1: the file is UTF-16 or binary"), "{e}");
    }

    fn parse_str(s: &str) -> Result<Imported, CookError> {
        parse(Path::new("test.obj"), s.as_bytes())
    }

    /// Notepad's byte-order mark before the first statement (`mtllib`, often) is not part of
    /// it, read whole or streamed.
    #[test]
    fn a_utf8_byte_order_mark_is_skipped() {
        let text = "o pane\nv 0 0 0\nv 1 0 0\nv 1 1 0\nusemtl Glass\nf 1 2 3\n";
        let with_bom = format!("\u{feff}{text}");
        let m = parse_str(&with_bom).unwrap();
        assert_eq!(m.triangle_count(), 1);
        let unknown = |m: &Imported| {
            m.warnings
                .iter()
                .filter(|w| w.to_string().contains("unknown statement"))
                .count()
        };
        assert_eq!(unknown(&m), 0, "{:?}", m.warnings);
        assert_eq!(m.parts[0].names.object.as_deref(), Some("pane"));
        assert_eq!(summary(Ok(m)), summary(parse_str(text)));
        let streamed = streamed_imported(&with_bom, 16, 64);
        assert_eq!(unknown(&streamed), 0, "{:?}", streamed.warnings);
        assert_eq!(summary(Ok(streamed)), summary(parse_str(text)));
    }

    #[test]
    fn names_and_relative_indices() {
        let m = parse_str(
            "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\no box\ng front\nusemtl red\nf -4 -3 -2 -1\n",
        )
        .unwrap();
        assert_eq!(m.triangle_count(), 2);
        assert_eq!(m.polygons, 1);
        assert_eq!(m.parts.len(), 1);
        let n = &m.parts[0].names;
        assert_eq!(
            (
                n.object.as_deref(),
                n.group.as_deref(),
                n.material.as_deref()
            ),
            (Some("box"), Some("front"), Some("red"))
        );
        assert_eq!(m.warnings.len(), 1, "{:?}", m.warnings); // red is not defined
    }

    #[test]
    fn errors_name_the_line() {
        let e = parse_str("v 0 0 0\nv 1 0 0\n\nf 1 2 3\n").unwrap_err();
        assert!(
            e.to_string()
                .starts_with("test.obj:4: vertex index 3 is out of range"),
            "{e}"
        );
        let e = parse_str("v 0 0 0\nv nan 0 0\n").unwrap_err();
        assert!(e.to_string().starts_with("test.obj:2:"), "{e}");
        let e = parse_str("v 0 0 inf\n").unwrap_err();
        assert!(e.to_string().contains("not finite"), "{e}");
        let e = parse_str("v 0 0 0\nv 1e39 0 0\n").unwrap_err();
        assert_eq!(
            e.to_string(),
            "test.obj:2: vertex coordinate \"1e39\" is out of range (a position holds at most \
             ±3.4028235e38)"
        );
        let e = parse_str("v 0 0 0\nf 0 1 1\n").unwrap_err();
        assert!(
            e.to_string().starts_with("test.obj:2: vertex index 0"),
            "{e}"
        );
    }

    #[test]
    fn lines_points_and_short_faces_warn() {
        let m = parse_str("v 0 0 0\nv 1 0 0\nv 0 1 0\nl 1 2\np 3\nf 1 2\nf 1 2 3\n").unwrap();
        assert_eq!(m.triangle_count(), 1);
        assert_eq!(m.warnings.len(), 2, "{:?}", m.warnings);
    }
}
