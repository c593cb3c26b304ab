//! PLY (the Stanford polygon format) import: ASCII and binary in either byte order, as
//! scanners, photogrammetry tools, MeshLab and Blender write it. Scans carry their colour per
//! vertex, which is why a scanned church comes as PLY as often as OBJ.
//!
//! Read: the `vertex` element's `x y z` (any numeric type; f64 survey coordinates are moved
//! near the origin as an OBJ's are), `nx ny nz`, colour (`red green blue`, `r g b` or
//! `diffuse_*`: 8- and 16-bit values scaled, floats taken as 0–1) and texture coordinates
//! (`s t`, `u v`, `texture_u texture_v`, `texture_s texture_t`); the `face` element's
//! `vertex_indices` (or `vertex_index`) polygons, triangulated by ear clipping, their colours
//! (where the vertices have none) and MeshLab's per-corner `texcoord` lists; MeshLab's
//! `comment TextureFile` image. Every other element and
//! property is read past. A PLY names nothing inside it, so the model is one part named by the
//! file's stem (its `mesh` name, for rules).
//!
//! No PLY crate is in the registry this project builds from offline, hence this reader; it
//! refuses a count the file is too short to hold before allocating for it.

use std::path::Path;

use super::{Corners, ImageRef, Imported, Indices, Names, Part, SourceMaterial, Warning};
use crate::CookError;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Self> {
        Some(match name {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// What a colour channel of this type reads as at full intensity.
    fn full_scale(self) -> f64 {
        match self {
            Self::U8 | Self::I8 => 255.0,
            Self::U16 | Self::I16 => 65535.0,
            Self::U32 | Self::I32 => u32::MAX as f64,
            Self::F32 | Self::F64 => 1.0,
        }
    }
}

#[derive(Clone, Copy, Debug)]
enum Kind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Debug)]
struct Property {
    name: String,
    kind: Kind,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
    /// The header line that declares it.
    line: usize,
}

impl Element {
    /// The fewest bytes one of it takes in the body: a list at least its count.
    fn min_bytes(&self, format: Format) -> u64 {
        self.properties
            .iter()
            .map(|p| match (format, p.kind) {
                // A value and a separator; a list at least its count.
                (Format::Ascii, _) => 2,
                (_, Kind::Scalar(s)) => s.size() as u64,
                (_, Kind::List { count, .. }) => count.size() as u64,
            })
            .sum()
    }
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    texture: Option<(String, usize)>,
    /// Where the body starts, and its first line's number.
    body: usize,
    body_line: usize,
}

fn bad(path: &Path, line: Option<usize>, message: impl Into<String>) -> CookError {
    CookError::Source {
        path: path.to_path_buf(),
        line,
        message: message.into(),
    }
}

fn header(path: &Path, bytes: &[u8]) -> Result<Header, CookError> {
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut texture = None;
    let mut at = 0;
    let mut line_no = 0;
    loop {
        if at >= bytes.len() {
            return Err(bad(
                path,
                None,
                "the PLY header has no `end_header` line (a truncated file?)",
            ));
        }
        let end = bytes[at..]
            .iter()
            .position(|&b| b == b'\n')
            .map_or(bytes.len(), |e| at + e);
        let raw = &bytes[at..end];
        at = (end + 1).min(bytes.len());
        line_no += 1;
        let line = String::from_utf8_lossy(raw);
        let line = line.trim();
        let mut words = line.split_ascii_whitespace();
        let keyword = words.next().unwrap_or("");
        if line_no == 1 {
            if keyword != "ply" || words.next().is_some() {
                return Err(bad(
                    path,
                    Some(1),
                    "not a PLY file: its first line is not `ply`",
                ));
            }
            continue;
        }
        let err = |m: String| bad(path, Some(line_no), m);
        match keyword {
            "" | "obj_info" => {}
            "comment" => {
                // MeshLab's texture statement.
                let rest = line["comment".len()..].trim_start();
                if let Some(file) = rest
                    .strip_prefix("TextureFile")
                    .filter(|f| f.starts_with(char::is_whitespace))
                {
                    texture = Some((file.trim().to_string(), line_no));
                }
            }
            "format" => {
                let f = match words.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Little,
                    Some("binary_big_endian") => Format::Big,
                    other => {
                        return Err(err(format!(
                            "unknown PLY format {:?}: expected ascii, binary_little_endian or \
                             binary_big_endian",
                            other.unwrap_or("")
                        )));
                    }
                };
                if words.next() != Some("1.0") {
                    return Err(err(format!(
                        "PLY version {line:?} is not 1.0, the only one there is"
                    )));
                }
                format = Some(f);
            }
            "element" => {
                let (Some(name), Some(count), None) = (words.next(), words.next(), words.next())
                else {
                    return Err(err(format!("{line:?}: expected `element NAME COUNT`")));
                };
                let count = count.parse::<u64>().map_err(|_| {
                    err(format!(
                        "element {name:?} has count {count:?}, not a whole number of 0 or more"
                    ))
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                    line: line_no,
                });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(err("a property before any element".into()));
                };
                let words: Vec<&str> = words.collect();
                let scalar = |t: &str| {
                    Scalar::parse(t).ok_or_else(|| err(format!("unknown property type {t:?}")))
                };
                let (kind, name) = match words[..] {
                    ["list", count, item, name] => {
                        let count = scalar(count)?;
                        if !count.integer() {
                            return Err(err(format!(
                                "list {name:?} has a count of type {count:?}, not an integer type"
                            )));
                        }
                        (
                            Kind::List {
                                count,
                                item: scalar(item)?,
                            },
                            name,
                        )
                    }
                    [ty, name] => (Kind::Scalar(scalar(ty)?), name),
                    _ => {
                        return Err(err(format!(
                            "{line:?}: expected `property TYPE NAME` or `property list \
                             COUNT_TYPE ITEM_TYPE NAME`"
                        )));
                    }
                };
                element.properties.push(Property {
                    name: name.to_string(),
                    kind,
                });
            }
            "end_header" => break,
            other => {
                return Err(err(format!("unknown PLY header statement {other:?}")));
            }
        }
    }
    let format = format.ok_or_else(|| bad(path, None, "the PLY header has no `format` line"))?;
    Ok(Header {
        format,
        elements,
        texture,
        body: at,
        body_line: line_no + 1,
    })
}

/// The body's values, one at a time, whatever its format.
struct Body<'a> {
    bytes: &'a [u8],
    at: usize,
    format: Format,
    /// ASCII: the line of the value read last.
    line: usize,
    /// ASCII: float-typed values may be read as f32 (the model is near the origin).
    f32_exact: bool,
}

impl Body<'_> {
    fn remaining(&self) -> u64 {
        (self.bytes.len() - self.at) as u64
    }

    /// The next value as f64 (exact for every PLY type), or why there is none.
    #[inline(always)]
    fn value(&mut self, ty: Scalar) -> Result<f64, String> {
        match self.format {
            Format::Ascii => {
                while self.at < self.bytes.len() && self.bytes[self.at].is_ascii_whitespace() {
                    if self.bytes[self.at] == b'\n' {
                        self.line += 1;
                    }
                    self.at += 1;
                }
                let start = self.at;
                while self.at < self.bytes.len() && !self.bytes[self.at].is_ascii_whitespace() {
                    self.at += 1;
                }
                if start == self.at {
                    return Err("the file ends early".into());
                }
                let token = &self.bytes[start..self.at];
                // The common cases without the general algorithm: a whole number (a count,
                // an index, an 8-bit colour), or a float-typed value read as an OBJ's is,
                // exact in f32, while no survey origin needs its every digit.
                if ty.integer() {
                    if let Some(v) = whole(token) {
                        return Ok(v);
                    }
                } else if ty == Scalar::F32
                    && self.f32_exact
                    && let Some(v) = super::obj::parse_f32(token).filter(|v| v.is_finite())
                {
                    return Ok(v as f64);
                }
                let text = std::str::from_utf8(token).unwrap_or("");
                let v = text.parse::<f64>().map_err(|_| {
                    format!(
                        "{:?} is not a number",
                        String::from_utf8_lossy(token)
                            .chars()
                            .take(40)
                            .collect::<String>()
                    )
                })?;
                if ty.integer() && (v.fract() != 0.0 || !v.is_finite()) {
                    return Err(format!("{text:?} is not a whole number, as its type says"));
                }
                Ok(v)
            }
            Format::Little | Format::Big => {
                let n = ty.size();
                let Some(b) = self.bytes.get(self.at..self.at + n) else {
                    return Err("the file ends early".into());
                };
                self.at += n;
                Ok(decode(b, ty, self.format == Format::Big))
            }
        }
    }

    /// A list's length.
    fn count(&mut self, ty: Scalar) -> Result<usize, String> {
        let n = self.value(ty)?;
        if n < 0.0 {
            return Err(format!("a list of length {n}"));
        }
        Ok(n as usize)
    }
}

/// A run of up to 15 decimal digits, optionally signed, as its value.
fn whole(t: &[u8]) -> Option<f64> {
    let (negative, digits) = match t {
        [b'-', r @ ..] => (true, r),
        [b'+', r @ ..] => (false, r),
        _ => (false, t),
    };
    if digits.is_empty() || digits.len() > 15 {
        return None;
    }
    let mut v = 0u64;
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d > 9 {
            return None;
        }
        v = v * 10 + d as u64;
    }
    Some(if negative { -(v as f64) } else { v as f64 })
}

/// The binary value of type `ty` at the start of `b` (which holds at least its size).
#[inline(always)]
fn decode(b: &[u8], ty: Scalar, big: bool) -> f64 {
    macro_rules! num {
        ($t:ty, $n:expr) => {{
            let a: [u8; $n] = b[..$n].try_into().unwrap_or([0; $n]);
            if big {
                <$t>::from_be_bytes(a) as f64
            } else {
                <$t>::from_le_bytes(a) as f64
            }
        }};
    }
    match ty {
        Scalar::I8 => b[0] as i8 as f64,
        Scalar::U8 => b[0] as f64,
        Scalar::I16 => num!(i16, 2),
        Scalar::U16 => num!(u16, 2),
        Scalar::I32 => num!(i32, 4),
        Scalar::U32 => num!(u32, 4),
        Scalar::F32 => num!(f32, 4),
        Scalar::F64 => num!(f64, 8),
    }
}

/// What a vertex property is to the cook.
#[derive(Clone, Copy, PartialEq)]
enum Role {
    Position(usize),
    Normal(usize),
    Colour(usize),
    Uv(usize),
    Other,
}

fn vertex_role(name: &str) -> Role {
    match name {
        "x" => Role::Position(0),
        "y" => Role::Position(1),
        "z" => Role::Position(2),
        "nx" => Role::Normal(0),
        "ny" => Role::Normal(1),
        "nz" => Role::Normal(2),
        "red" | "r" | "diffuse_red" => Role::Colour(0),
        "green" | "g" | "diffuse_green" => Role::Colour(1),
        "blue" | "b" | "diffuse_blue" => Role::Colour(2),
        "s" | "u" | "texture_u" | "texture_s" => Role::Uv(0),
        "t" | "v" | "texture_v" | "texture_t" => Role::Uv(1),
        _ => Role::Other,
    }
}

pub fn import(path: &Path) -> Result<Imported, CookError> {
    let bytes = std::fs::read(path).map_err(|e| CookError::Io {
        path: path.to_path_buf(),
        source: e,
    })?;
    parse(path, &bytes)
}

pub fn parse(path: &Path, bytes: &[u8]) -> Result<Imported, CookError> {
    let h = header(path, bytes)?;
    let mut out = Imported {
        path: path.to_path_buf(),
        ..Default::default()
    };
    let mut body = Body {
        bytes,
        at: h.body,
        format: h.format,
        line: h.body_line,
        f32_exact: false,
    };
    let vertex = h.elements.iter().position(|e| e.name == "vertex");
    let face = h.elements.iter().position(|e| e.name == "face");
    let Some(vertex) = vertex else {
        return Err(bad(path, None, "the PLY file has no `vertex` element"));
    };
    let roles: Vec<Role> = h.elements[vertex]
        .properties
        .iter()
        .map(|p| match p.kind {
            Kind::Scalar(_) => vertex_role(&p.name),
            Kind::List { .. } => Role::Other,
        })
        .collect();
    let has = |f: fn(Role) -> bool| roles.iter().filter(|&&r| f(r)).count() == 3;
    for axis in 0..3 {
        if !roles.contains(&Role::Position(axis)) {
            return Err(bad(
                path,
                Some(h.elements[vertex].line),
                format!(
                    "the vertex element has no {:?} property",
                    ["x", "y", "z"][axis]
                ),
            ));
        }
    }
    let normals = has(|r| matches!(r, Role::Normal(_)));
    let colours = has(|r| matches!(r, Role::Colour(_)));
    let uvs = roles.iter().filter(|r| matches!(r, Role::Uv(_))).count() == 2;

    // Per element and property: 1 for a face's corner indices, 2 for its texture
    // coordinates, 0 for anything read past.
    let list_roles: Vec<Vec<u8>> = h
        .elements
        .iter()
        .enumerate()
        .map(|(ei, e)| {
            e.properties
                .iter()
                .map(|p| match (face == Some(ei), p.name.as_str()) {
                    (true, "vertex_indices" | "vertex_index") => 1,
                    (true, "texcoord") => 2,
                    _ => 0,
                })
                .collect()
        })
        .collect();
    let mut raw_colours: Vec<[f64; 3]> = Vec::new();
    let mut raw_normals_ok = true;
    // Per face: its polygon's position indices, and its corners' texture coordinates.
    let mut polygon: Vec<u32> = Vec::new();
    let mut face_uv: Vec<f64> = Vec::new();
    let mut p: Vec<u32> = Vec::new();
    let mut t: Vec<u32> = Vec::new();
    let mut tris: Vec<[u32; 3]> = Vec::new();
    let mut points: Vec<[f32; 3]> = Vec::new();
    let mut skipped_faces = 0usize;
    let mut face_uvs = false;
    let mut face_colours = false;
    // Per triangle, its face's colour, where faces have colours and vertices none.
    let mut tri_colours: Vec<[f64; 3]> = Vec::new();

    for (ei, element) in h.elements.iter().enumerate() {
        // A count the rest of the file cannot hold is refused before anything is allocated
        // for it.
        let min = element.min_bytes(h.format);
        // (An ASCII file's last value may lack its separator.)
        let slack = u64::from(h.format == Format::Ascii);
        if element.count > 0 && min > 0 && element.count > (body.remaining() + slack) / min {
            return Err(bad(
                path,
                Some(element.line),
                format!(
                    "element {:?} claims {} items, more than the {} bytes after it can hold",
                    element.name,
                    element.count,
                    body.remaining()
                ),
            ));
        }
        // An element of no properties takes no bytes, however many it claims.
        if element.properties.is_empty() {
            continue;
        }
        let count = element.count as usize;
        if ei == vertex {
            out.positions.reserve_exact(count);
            if normals {
                out.normals.reserve_exact(count);
            }
            if colours {
                raw_colours.reserve_exact(count);
            }
            if uvs {
                out.uvs.reserve_exact(count);
            }
        }
        // A binary element of scalars only is records of one size: each is sliced once and
        // its values decoded at fixed offsets, without a bounds check each (the count was
        // checked against the file's size above).
        let big = h.format == Format::Big;
        let fixed: Option<(usize, Vec<usize>)> = (h.format != Format::Ascii
            && element
                .properties
                .iter()
                .all(|p| matches!(p.kind, Kind::Scalar(_))))
        .then(|| {
            let mut offsets = Vec::with_capacity(element.properties.len());
            let mut stride = 0;
            for p in &element.properties {
                offsets.push(stride);
                if let Kind::Scalar(ty) = p.kind {
                    stride += ty.size();
                }
            }
            (stride, offsets)
        });
        // A binary face element of the corner list alone (what scanners and MeshLab write):
        // its triangles are read straight into the corners; anything else (a polygon, a bad
        // index) takes the general path below, which also says what is wrong.
        let triangles: Option<(Scalar, Scalar)> = match element.properties[..] {
            [
                Property {
                    kind: Kind::List { count, item },
                    ..
                },
            ] if h.format != Format::Ascii && list_roles[ei][0] == 1 => Some((count, item)),
            _ => None,
        };
        for item in 0..count {
            if let Some((cty, ity)) = triangles {
                let (cs, is) = (cty.size(), ity.size());
                if let Some(b) = bytes.get(body.at..body.at + cs + 3 * is)
                    && decode(b, cty, big) == 3.0
                {
                    // Written out: `array::map` here was a call per face.
                    let v = [
                        decode(&b[cs..], ity, big),
                        decode(&b[cs + is..], ity, big),
                        decode(&b[cs + 2 * is..], ity, big),
                    ];
                    let i = [v[0] as u32, v[1] as u32, v[2] as u32];
                    let n = out.positions.len();
                    let ok = |k: usize| i[k] as f64 == v[k] && (i[k] as usize) < n;
                    if ok(0) && ok(1) && ok(2) {
                        body.at += cs + 3 * is;
                        p.extend_from_slice(&i);
                        if face_uvs {
                            t.extend(i.map(|i| if uvs { i } else { super::NONE }));
                        }
                        continue;
                    }
                }
            }
            let record = match &fixed {
                Some((stride, _)) => {
                    let r = &bytes[body.at..body.at + stride];
                    body.at += stride;
                    r
                }
                None => &[][..],
            };
            let at_err = |body: &Body, m: String| {
                let line = (h.format == Format::Ascii).then_some(body.line);
                bad(
                    path,
                    line,
                    format!("{} {item} of {}: {m}", element.name, element.count),
                )
            };
            let mut pos = [0.0f64; 3];
            let mut normal = [0.0f32; 3];
            let mut colour = [1.0f64; 3];
            let mut uv = [0.0f32; 2];
            polygon.clear();
            face_uv.clear();
            for (pi, prop) in element.properties.iter().enumerate() {
                match prop.kind {
                    Kind::Scalar(ty) => {
                        let v = match &fixed {
                            Some((_, offsets)) => decode(&record[offsets[pi]..], ty, big),
                            None => body.value(ty).map_err(|m| at_err(&body, m))?,
                        };
                        if ei == vertex {
                            match roles[pi] {
                                Role::Position(a) => pos[a] = v,
                                Role::Normal(a) => normal[a] = v as f32,
                                Role::Colour(a) => colour[a] = v / ty.full_scale(),
                                Role::Uv(a) => uv[a] = v as f32,
                                Role::Other => {}
                            }
                        } else if face == Some(ei)
                            && let Role::Colour(a) = vertex_role(&prop.name)
                        {
                            face_colours = true;
                            colour[a] = v / ty.full_scale();
                        }
                    }
                    Kind::List { count, item: ty } => {
                        let n = body.count(count).map_err(|m| at_err(&body, m))?;
                        let min_item = if h.format == Format::Ascii {
                            2
                        } else {
                            ty.size()
                        };
                        if n as u64 > body.remaining() / min_item as u64 + 1 {
                            return Err(at_err(
                                &body,
                                format!("a list of {n} values, more than the file holds"),
                            ));
                        }
                        let role = list_roles[ei][pi];
                        for _ in 0..n {
                            let v = body.value(ty).map_err(|m| at_err(&body, m))?;
                            match role {
                                1 => {
                                    let i = v as u32;
                                    if i as f64 != v || i as usize >= out.positions.len() {
                                        return Err(at_err(
                                            &body,
                                            format!(
                                                "vertex index {v}, but the file has {} vertices",
                                                out.positions.len()
                                            ),
                                        ));
                                    }
                                    polygon.push(i);
                                }
                                2 => face_uv.push(v),
                                _ => {}
                            }
                        }
                    }
                }
            }
            if ei == vertex {
                if pos.iter().any(|c| !c.is_finite()) {
                    return Err(at_err(&body, format!("position {pos:?} is not finite")));
                }
                // The first vertex places the survey origin, as in an OBJ.
                if out.positions.is_empty() {
                    out.origin = super::survey_origin(pos).unwrap_or_default();
                    body.f32_exact = out.origin == [0.0; 3];
                }
                let origin = out.origin;
                out.positions.push([
                    (pos[0] - origin[0]) as f32,
                    (pos[1] - origin[1]) as f32,
                    (pos[2] - origin[2]) as f32,
                ]);
                if normals {
                    raw_normals_ok &=
                        normal.iter().all(|c| c.is_finite()) && normal.iter().any(|&c| c != 0.0);
                    out.normals.push(normal);
                }
                if colours {
                    raw_colours.push(colour.map(|c| if c.is_finite() { c.max(0.0) } else { 1.0 }));
                }
                if uvs {
                    if !uv.iter().all(|c| c.is_finite()) {
                        return Err(at_err(
                            &body,
                            format!("texture coordinate {uv:?} is not finite"),
                        ));
                    }
                    out.uvs.push(uv);
                }
            } else if face == Some(ei) {
                if polygon.len() < 3 {
                    skipped_faces += 1;
                    continue;
                }
                // MeshLab's per-corner texture coordinates, where the face has all of them.
                let corner_uvs =
                    face_uv.len() == polygon.len() * 2 && face_uv.iter().all(|c| c.is_finite());
                if corner_uvs && !face_uvs {
                    // Per-corner coordinates (appended after any per-vertex ones) from here
                    // on; the faces before keep their vertices' own, or none.
                    face_uvs = true;
                    t = if uvs {
                        p.clone()
                    } else {
                        vec![super::NONE; p.len()]
                    };
                }
                tris.clear();
                if polygon.len() == 3 {
                    tris.push([0, 1, 2]);
                } else {
                    points.clear();
                    points.extend(polygon.iter().map(|&i| out.positions[i as usize]));
                    crate::triangulate::triangulate(&points, &mut tris);
                    out.polygons += 1;
                }
                if face_colours && !colours {
                    tri_colours.resize(p.len() / 3, [1.0; 3]);
                    tri_colours.extend(std::iter::repeat_n(
                        colour.map(|c| if c.is_finite() { c.max(0.0) } else { 1.0 }),
                        tris.len(),
                    ));
                }
                for tri in &tris {
                    for &c in tri {
                        p.push(polygon[c as usize]);
                        if face_uvs {
                            if corner_uvs {
                                let k = c as usize * 2;
                                t.push(out.uvs.len() as u32);
                                out.uvs.push([face_uv[k] as f32, face_uv[k + 1] as f32]);
                            } else if uvs {
                                t.push(polygon[c as usize]);
                            } else {
                                t.push(super::NONE);
                            }
                        }
                    }
                }
            }
        }
    }
    // Faces painted apart (CAD exports, segmented scans): each corner of a coloured face gets
    // its own copy of its vertex with the face's colour, which the mesh stage welds back
    // wherever neighbouring faces share a colour.
    if !tri_colours.is_empty() {
        tri_colours.resize(p.len() / 3, [1.0; 3]);
        raw_colours = vec![[1.0; 3]; out.positions.len()];
        let per_vertex_uvs = uvs && !face_uvs;
        for (k, c) in p.iter_mut().enumerate() {
            let v = *c as usize;
            *c = out.positions.len() as u32;
            out.positions.push(out.positions[v]);
            if normals {
                out.normals.push(out.normals[v]);
            }
            if per_vertex_uvs {
                out.uvs.push(out.uvs[v]);
            }
            raw_colours.push(tri_colours[k / 3]);
        }
    }
    // Float colours written 0–255 (whole numbers, some over 1) are bytes; other floats are
    // fractions, clamped.
    let bytes = raw_colours.iter().flatten().any(|&c| c > 1.0)
        && raw_colours.iter().flatten().all(|&c| c.fract() == 0.0);
    let scale = if bytes { 1.0 / 255.0 } else { 1.0 };
    out.colours = raw_colours
        .into_iter()
        .map(|c| {
            let l = c.map(|v| texture::srgb::srgb_to_linear((v * scale).min(1.0)) as f32);
            [l[0], l[1], l[2], 1.0]
        })
        .collect();
    if skipped_faces > 0 {
        out.warnings.push(Warning::new(
            path,
            None,
            format!("{skipped_faces} faces of fewer than three corners skipped"),
        ));
    }
    if face_colours && colours {
        out.warnings.push(Warning::new(
            path,
            None,
            "the faces' colours are not read: the vertices' own are",
        ));
    }
    if normals && !raw_normals_ok {
        out.warnings.push(Warning::new(
            path,
            None,
            "some vertex normals are zero or not finite: all are generated instead",
        ));
        out.normals = Vec::new();
    }
    if p.is_empty() {
        out.warnings.push(Warning::new(
            path,
            None,
            if face.is_none() {
                "no faces (a point cloud?): nothing to cook"
            } else {
                "no faces: nothing to cook"
            },
        ));
    }
    // Per-vertex normals and coordinates are indexed as the positions are: said so, rather
    // than written out per corner and compared back.
    let n = if out.normals.is_empty() {
        Indices::Absent
    } else {
        Indices::Positions
    };
    let t = if face_uvs {
        Indices::of(t, &p)
    } else if uvs {
        Indices::Positions
    } else {
        Indices::Absent
    };
    out.tri_part = vec![0; p.len() / 3];
    out.corners = Corners::from_indices(p, t, n);

    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut material = None;
    if let Some((file, line)) = &h.texture {
        let dir = path.parent().unwrap_or(Path::new(""));
        if let Some(image) = super::locate_noted(dir, file, &mut out.absent) {
            let mut m = SourceMaterial::plain(file.clone());
            m.diffuse = [1.0; 3];
            m.diffuse_texture = Some(ImageRef::File(image));
            out.materials.push(m);
            material = Some(0);
        } else {
            out.warnings.push(Warning::new(
                path,
                Some(*line),
                format!(
                    "texture {} not found; the model is untextured",
                    dir.join(file).display()
                ),
            ));
        }
    }
    out.parts.push(Part {
        names: Names {
            mesh: Some(stem),
            ..Default::default()
        },
        material,
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn third_party(rel: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/third_party")
            .join(rel)
    }

    fn read(rel: &str) -> Vec<u8> {
        std::fs::read(third_party(rel)).unwrap()
    }

    /// The ASCII PLY `ascii` rewritten in binary (big-endian or little), value by value with
    /// each property's declared type: the same model in the encoding most scanners write.
    fn to_binary(ascii: &[u8], big: bool) -> Vec<u8> {
        let path = Path::new("in.ply");
        let h = header(path, ascii).unwrap();
        let head = String::from_utf8_lossy(&ascii[..h.body]).replace(
            "format ascii 1.0",
            if big {
                "format binary_big_endian 1.0"
            } else {
                "format binary_little_endian 1.0"
            },
        );
        let mut out = head.into_bytes();
        let mut body = Body {
            bytes: ascii,
            at: h.body,
            format: Format::Ascii,
            line: h.body_line,
            f32_exact: false,
        };
        let put = |out: &mut Vec<u8>, ty: Scalar, v: f64| {
            let mut b: Vec<u8> = match ty {
                Scalar::I8 => (v as i8).to_le_bytes().to_vec(),
                Scalar::U8 => (v as u8).to_le_bytes().to_vec(),
                Scalar::I16 => (v as i16).to_le_bytes().to_vec(),
                Scalar::U16 => (v as u16).to_le_bytes().to_vec(),
                Scalar::I32 => (v as i32).to_le_bytes().to_vec(),
                Scalar::U32 => (v as u32).to_le_bytes().to_vec(),
                Scalar::F32 => (v as f32).to_le_bytes().to_vec(),
                Scalar::F64 => v.to_le_bytes().to_vec(),
            };
            if big {
                b.reverse();
            }
            out.extend_from_slice(&b);
        };
        for e in &h.elements {
            for _ in 0..e.count {
                for p in &e.properties {
                    match p.kind {
                        Kind::Scalar(ty) => {
                            let v = body.value(ty).unwrap();
                            put(&mut out, ty, v);
                        }
                        Kind::List { count, item } => {
                            let n = body.count(count).unwrap();
                            put(&mut out, count, n as f64);
                            for _ in 0..n {
                                let v = body.value(item).unwrap();
                                put(&mut out, item, v);
                            }
                        }
                    }
                }
            }
        }
        out
    }

    #[test]
    fn blender_s_cube_reads_as_written_in_ascii_and_both_binary_orders() {
        let ascii = read("ply/cube_uv.ply");
        let a = parse(Path::new("cube_uv.ply"), &ascii).unwrap();
        assert_eq!(a.positions.len(), 24);
        assert_eq!(a.positions[7], [0.999999, -1.000001, 1.0]);
        assert_eq!(a.normals[0], [0.0, 0.0, -1.0]);
        assert_eq!(a.uvs[2], [1.0, 1.0]);
        // Six quads, each two triangles of its own four vertices, with their own normals and
        // texture coordinates.
        assert_eq!((a.triangle_count(), a.polygons), (12, 6));
        assert!(a.warnings.is_empty(), "{:?}", a.warnings);
        for k in 0..a.corners.len() {
            let c = a.corners.get(k);
            assert_eq!((c.t, c.n), (c.p, c.p));
            assert_eq!(c.p / 4, k as u32 / 6, "corner {k} of quad {}", k / 6);
        }
        assert_eq!(a.parts[0].names.mesh.as_deref(), Some("cube_uv"));
        for big in [false, true] {
            let b = parse(Path::new("cube_uv.ply"), &to_binary(&ascii, big)).unwrap();
            assert_eq!(
                (&b.positions, &b.normals, &b.uvs, &b.corners, &b.tri_part),
                (&a.positions, &a.normals, &a.uvs, &a.corners, &a.tri_part),
                "big-endian: {big}"
            );
        }
    }

    #[test]
    fn meshlab_float_colours_and_other_type_names_read() {
        // VCG's float colours with alpha: blue, exactly.
        let f = parse(Path::new("float-color.ply"), &read("ply/float-color.ply")).unwrap();
        assert_eq!(f.colours, vec![[0.0, 0.0, 1.0, 1.0]; 3]);
        assert_eq!(f.positions[2], [200.0, 200.0, 0.0]);
        // float32/uint8/int32 type names, `vertex_index`, trailing blanks in the header.
        let c = parse(Path::new("cube.ply"), &read("ply/cube.ply")).unwrap();
        assert_eq!((c.positions.len(), c.triangle_count()), (8, 12));
        assert!(c.normals.is_empty() && c.uvs.is_empty() && c.colours.is_empty());
        // 8-bit colours are sRGB, decoded exactly.
        let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                    property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n\
                    element face 1\nproperty list uchar int vertex_indices\nend_header\n\
                    0 0 0 255 128 0\n1 0 0 255 128 0\n0 1 0 255 128 0\n3 0 1 2\n";
        let u = parse(Path::new("u.ply"), text.as_bytes()).unwrap();
        let g = texture::srgb::srgb_to_linear(128.0 / 255.0) as f32;
        assert_eq!(u.colours, vec![[1.0, g, 0.0, 1.0]; 3]);
    }

    /// Faces painted apart: each corner of a coloured face gets its own copy of its vertex,
    /// with the face's colour (sRGB bytes decoded exactly).
    #[test]
    fn per_face_colours_paint_copies_of_their_vertices() {
        let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
                    property float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
                    element face 2\nproperty list uchar int vertex_indices\n\
                    property uchar red\nproperty uchar green\nproperty uchar blue\nend_header\n\
                    0 0 0 0 0 1\n1 0 0 0 0 1\n1 1 0 0 0 1\n0 1 0 0 0 1\n\
                    3 0 1 2 255 0 0\n3 0 2 3 0 0 255\n";
        let m = parse(Path::new("f.ply"), text.as_bytes()).unwrap();
        assert_eq!(m.positions.len(), 4 + 6);
        assert_eq!(m.normals.len(), 10);
        let corner = |k: usize| {
            let c = m.corners.get(k);
            (
                m.positions[c.p as usize],
                m.colours[c.p as usize],
                c.n == c.p,
            )
        };
        let (red, blue) = ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]);
        assert_eq!(corner(0), ([0.0, 0.0, 0.0], red, true));
        assert_eq!(corner(4), ([1.0, 1.0, 0.0], blue, true));
        assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    }

    #[test]
    fn meshlab_per_corner_texture_coordinates_and_its_texture_file() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("scan.png"), b"not read here").unwrap();
        let body = "ply\nformat ascii 1.0\ncomment TextureFile scan.png\nelement vertex 4\n\
                    property float x\nproperty float y\nproperty float z\nelement face 2\n\
                    property list uchar int vertex_indices\nproperty list uchar float texcoord\n\
                    end_header\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n\
                    3 0 1 2 6 0 0 0.5 0 0.5 0.5\n3 0 2 3 6 0 0 0.5 0.5 0 0.5\n";
        let path = dir.path().join("scan.ply");
        let m = parse(&path, body.as_bytes()).unwrap();
        assert_eq!(m.uvs.len(), 6, "one per corner");
        assert_eq!(m.uvs[4], [0.5, 0.5]);
        let c = m.corners.get(5);
        assert_eq!((c.p, m.uvs[c.t as usize]), (3, [0.0, 0.5]));
        assert_eq!(
            m.materials[0].diffuse_texture,
            Some(ImageRef::File(dir.path().join("scan.png")))
        );
        assert_eq!(m.parts[0].material, Some(0));
        // A texture that is not there is said, and the model cooks untextured.
        let m = parse(
            &dir.path().join("x.ply"),
            body.replace("scan.png", "gone.png").as_bytes(),
        )
        .unwrap();
        assert!(m.materials.is_empty());
        assert!(
            m.warnings[0].message.contains("gone.png"),
            "{:?}",
            m.warnings
        );
        assert_eq!(m.warnings[0].line, Some(3));
    }

    /// Survey coordinates keep their every digit, in doubles and in ASCII floats alike (the
    /// text has them, whatever the declared type), and move near the origin.
    #[test]
    fn survey_coordinates_move_near_the_origin() {
        for ty in ["double", "float"] {
            let text = format!(
                "ply\nformat ascii 1.0\nelement vertex 3\nproperty {ty} x\n\
                 property {ty} y\nproperty {ty} z\nelement face 1\n\
                 property list uchar uint vertex_indices\nend_header\n\
                 5432109.25 120.5 -6543210.75\n5432110.1 120.1 -6543210.75\n\
                 5432109.25 121.5 -6543210.75\n3 0 1 2\n"
            );
            let m = parse(Path::new("s.ply"), text.as_bytes()).unwrap();
            assert_eq!(m.origin, [5432109.0, 0.0, -6543211.0]);
            assert_eq!(
                m.positions[1],
                [(5432110.1f64 - 5432109.0) as f32, 120.1, 0.25]
            );
        }
    }

    #[test]
    fn bad_files_say_what_and_where() {
        let err = |text: &[u8]| parse(Path::new("b.ply"), text).unwrap_err().to_string();
        let head = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                    property float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                    end_header\n";
        assert!(err(b"solid x\n").contains("b.ply:1: not a PLY file"));
        assert!(err(b"ply\nformat ascii 1.0\nelement vertex 1\n").contains("no `end_header`"));
        assert!(
            err(b"ply\nformat binary_middle_endian 1.0\nend_header\n")
                .contains("b.ply:2: unknown PLY format")
        );
        assert!(err(b"ply\nformat ascii 1.0\nend_header\n").contains("no `vertex` element"));
        let e = err(format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n").as_bytes());
        assert!(
            e.contains("b.ply:13: face 0 of 1: vertex index 3, but the file has 3"),
            "{e}"
        );
        let e = err(format!("{head}0 0 0\n1 zero 0\n0 1 0\n3 0 1 2\n").as_bytes());
        assert!(
            e.contains("b.ply:11: vertex 1 of 3: \"zero\" is not a number"),
            "{e}"
        );
        let e = err(format!("{head}0 0 0\n1 0 0\n0 1 0\n3 0 1").as_bytes());
        assert!(e.contains("face 0 of 1: the file ends early"), "{e}");
        // Four billion vertices claimed by a few bytes: refused before any allocation.
        let huge = "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\n\
                    property float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
        let e = err(huge.as_bytes());
        assert!(
            e.contains("b.ply:3: element \"vertex\" claims 4000000000 items"),
            "{e}"
        );
        // Four billion items of nothing take no time.
        let empty = "ply\nformat binary_little_endian 1.0\nelement nothing 4000000000\n\
                     element vertex 0\nproperty float x\nproperty float y\nproperty float z\n\
                     end_header\n";
        let m = parse(Path::new("e.ply"), empty.as_bytes()).unwrap();
        assert!(m.positions.is_empty());
        let truncated = to_binary(&read("ply/cube_uv.ply"), false);
        let e = err(&truncated[..truncated.len() - 3]);
        assert!(e.contains("face 5 of 6: the file ends early"), "{e}");
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// Any damage to a real file, in either encoding, gives a model or an error: never a
        /// panic, and every corner of a model points at a vertex.
        #[test]
        fn damaged_files_never_panic(
            big in any::<bool>(),
            ascii in any::<bool>(),
            edits in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
            cut in any::<prop::sample::Index>(),
        ) {
            let text = read("ply/cube_uv.ply");
            let mut bytes = if ascii { text } else { to_binary(&text, big) };
            for (at, b) in edits {
                let i = at.index(bytes.len());
                bytes[i] = b;
            }
            bytes.truncate(cut.index(bytes.len() + 1).max(1));
            if let Ok(m) = parse(Path::new("d.ply"), &bytes) {
                for k in 0..m.corners.len() {
                    let c = m.corners.get(k);
                    prop_assert!((c.p as usize) < m.positions.len());
                    prop_assert!(c.t == crate::import::NONE || (c.t as usize) < m.uvs.len());
                    prop_assert!(c.n == crate::import::NONE || (c.n as usize) < m.normals.len());
                }
            }
        }
    }
}
