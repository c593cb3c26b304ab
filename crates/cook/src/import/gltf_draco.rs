//! Primitives compressed with `KHR_draco_mesh_compression`: what gltf-pipeline `-d`, Blender's
//! "compression" export option and most web-delivery pipelines write. The primitive's
//! accessors keep their counts and types but usually have no data; the extension names a
//! buffer view holding one Draco stream and, per glTF attribute, the Draco attribute id
//! inside it.
//!
//! The stream is decoded by `draco-oxide-decoder`. Two guards sit around it, since a pack is
//! cooked from files nobody here has seen:
//! - Its counts are read from the stream's header and bounded first (by the stream's length
//!   and by the claims of every other Draco stream in the file), because the decoder sizes its
//!   tables from those counts before it can tell they are false.
//! - The decoder is young and panics on some corrupt streams (about 2% of randomly mutated
//!   ones, by our own mutation run). The panic is caught and reported as a malformed stream;
//!   the panic hook stays quiet on the decoding thread while it decodes, so the user sees the
//!   error, not a panic message.

use std::cell::{Cell, RefCell};
use std::collections::HashMap;
use std::rc::Rc;

use draco_oxide_core::attribute::ComponentDataType as Ty;
use gltf::accessor::DataType;
use serde_json::Value;

/// The extension's name.
pub(super) const NAME: &str = "KHR_draco_mesh_compression";

/// Most triangles one stream may claim per byte of it. The decoder holds about 70 bytes a
/// claimed triangle before it can tell a count is false, so this bounds what a hostile header
/// costs. Measured with gltf-pipeline: the Stanford bunny's stream holds 1.4 triangles a byte,
/// a perfectly regular 320k-triangle grid (zero prediction residuals) 15, or 19 with the
/// valence coder; 32 leaves room above the best case.
const MAX_FACES_PER_BYTE: u64 = 32;
/// Most triangles and points all of a file's Draco streams may claim together (a 32M-triangle
/// model, past what the cooker handles in one file anyway; about 2.3 GB while decoding).
const MAX_TOTAL: u64 = 1 << 25;

/// One primitive's stream, decoded.
pub(super) struct Decoded {
    /// The triangles' corners, three point indices a triangle (Draco stores a triangle list
    /// whatever the primitive's mode).
    pub(super) corners: Vec<u32>,
    /// How many points (glTF vertices) the attributes have.
    pub(super) points: usize,
    /// Each glTF attribute the extension names that the cooker reads, by its semantic
    /// (`"NORMAL"`).
    attributes: Vec<(String, Values)>,
}

/// An attribute's values, one tuple of `comps` per point, as stored: integers not yet
/// normalized (the accessor says whether they are).
struct Values {
    ty: Ty,
    comps: usize,
    data: Vec<f32>,
}

/// A buffer view and the (semantic, Draco id) pairs read from it, sorted.
type StreamKey = (usize, Vec<(String, u64)>);

/// The decoded streams of one file, by buffer view and the attributes read from it: a mesh
/// placed by many nodes, or one stream that several primitives name, is decoded once.
#[derive(Default)]
pub(super) struct Cache {
    decoded: RefCell<HashMap<StreamKey, Rc<Decoded>>>,
    /// Triangles and points claimed by the streams decoded so far.
    claimed: Cell<u64>,
}

impl Cache {
    /// The primitive's decoded stream where it has the extension, else `None`. Errors are
    /// messages that name the mesh and primitive (the caller adds the file).
    pub(super) fn get<'b>(
        &self,
        mesh: usize,
        prim: &gltf::Primitive,
        view_bytes: impl Fn(&gltf::buffer::View) -> Result<&'b [u8], String>,
        document: &gltf::Document,
    ) -> Result<Option<Rc<Decoded>>, String> {
        let Some(ext) = prim.extension_value(NAME) else {
            return Ok(None);
        };
        let what = format!("mesh {mesh} primitive {}: {NAME}", prim.index());
        let view = ext
            .get("bufferView")
            .and_then(Value::as_u64)
            .and_then(|v| document.views().nth(usize::try_from(v).ok()?))
            .ok_or_else(|| format!("{what}: bufferView is missing or names no buffer view"))?;
        let ids = ext
            .get("attributes")
            .and_then(Value::as_object)
            .ok_or_else(|| format!("{what}: attributes is missing or not an object"))?;
        let mut wanted = Vec::with_capacity(ids.len());
        for (semantic, id) in ids {
            let id = id
                .as_u64()
                .ok_or_else(|| format!("{what}: attribute {semantic} has id {id}, not a number"))?;
            // Only what the cooker reads: tangents and custom attributes would be converted
            // for nothing.
            let read = ["POSITION", "NORMAL", "COLOR_0"].contains(&semantic.as_str())
                || ["TEXCOORD_", "JOINTS_", "WEIGHTS_"]
                    .iter()
                    .any(|p| semantic.starts_with(p));
            if read {
                wanted.push((semantic.clone(), id));
            }
        }
        wanted.sort();
        let key = (view.index(), wanted);
        if let Some(d) = self.decoded.borrow().get(&key) {
            return Ok(Some(d.clone()));
        }
        let wanted = &key.1;
        let bytes = view_bytes(&view).map_err(|e| format!("{what}: {e}"))?;
        let claim = claimed_size(bytes).map_err(|e| {
            format!(
                "{what}: buffer view {} is not a Draco mesh: {e}",
                view.index()
            )
        })?;
        let total = self.claimed.get().saturating_add(claim);
        if total > MAX_TOTAL {
            return Err(format!(
                "{what}: the file's Draco streams claim {total} triangles and points, past the \
                 {MAX_TOTAL} the cooker decodes from one file"
            ));
        }
        self.claimed.set(total);
        let decoded = decode(bytes, wanted)
            .map_err(|e| format!("{what}: buffer view {} is malformed: {e}", view.index()))?;
        let decoded = Rc::new(decoded);
        self.decoded.borrow_mut().insert(key, decoded.clone());
        Ok(Some(decoded))
    }
}

impl Decoded {
    /// The values of attribute `semantic` where the stream has it, as `N` floats a point,
    /// integers normalized as `acc` says (the stream's own type decides the values).
    pub(super) fn floats<const N: usize>(
        &self,
        semantic: &str,
        acc: &gltf::Accessor,
    ) -> Option<Result<Vec<[f32; N]>, String>> {
        let (_, v) = self.attributes.iter().find(|(s, _)| s == semantic)?;
        if v.comps != N {
            return Some(Err(format!(
                "{NAME}: attribute {semantic} has {} components, expected {N}",
                v.comps
            )));
        }
        let normalized = match (acc.normalized(), v.ty) {
            (false, _) | (true, Ty::F32) => None,
            (true, Ty::U8) => Some(DataType::U8),
            (true, Ty::I8) => Some(DataType::I8),
            (true, Ty::U16) => Some(DataType::U16),
            (true, Ty::I16) => Some(DataType::I16),
            (true, ty) => {
                return Some(Err(format!(
                    "{NAME}: attribute {semantic} is normalized {ty:?}, which glTF does not allow"
                )));
            }
        };
        Some(Ok(v
            .data
            .chunks_exact(N)
            .map(|c| {
                std::array::from_fn(|k| match normalized {
                    Some(t) => super::gltf::normalize(c[k], t),
                    None => c[k],
                })
            })
            .collect()))
    }
}

/// Reads a little-endian base-128 number.
fn leb128(bytes: &[u8], at: &mut usize) -> Result<u64, String> {
    let mut v = 0u64;
    for shift in (0..64).step_by(7) {
        let b = *bytes.get(*at).ok_or("the stream ends inside its header")?;
        *at += 1;
        v |= u64::from(b & 0x7f) << shift;
        if b & 0x80 == 0 {
            return Ok(v);
        }
    }
    Err("a number in the header runs past 64 bits".into())
}

fn byte(bytes: &[u8], at: &mut usize) -> Result<u8, String> {
    let b = *bytes.get(*at).ok_or("the stream ends inside its header")?;
    *at += 1;
    Ok(b)
}

/// Deepest metadata nesting read: stricter than the reference decoder's 1000 on purpose (the
/// skip recurses, and exporters write one or two levels).
const MAX_METADATA_DEPTH: usize = 32;

/// Steps over one metadata block (entries, then named sub-blocks).
fn skip_metadata(bytes: &[u8], at: &mut usize, depth: usize) -> Result<(), String> {
    if depth > MAX_METADATA_DEPTH {
        return Err(format!("metadata nested deeper than {MAX_METADATA_DEPTH}"));
    }
    let skip = |n: u64, at: &mut usize| -> Result<(), String> {
        let end = usize::try_from(n)
            .ok()
            .and_then(|n| at.checked_add(n))
            .filter(|&e| e <= bytes.len())
            .ok_or("metadata runs past the stream")?;
        *at = end;
        Ok(())
    };
    for _ in 0..leb128(bytes, at)? {
        let name = byte(bytes, at)?;
        skip(u64::from(name), at)?;
        let value = leb128(bytes, at)?;
        skip(value, at)?;
    }
    for _ in 0..leb128(bytes, at)? {
        let name = byte(bytes, at)?;
        skip(u64::from(name), at)?;
        skip_metadata(bytes, at, depth + 1)?;
    }
    Ok(())
}

/// The triangles plus points the stream's header claims, refused where the stream could not
/// hold them: read before the decoder, which allocates by these counts.
fn claimed_size(bytes: &[u8]) -> Result<u64, String> {
    if bytes.get(..5) != Some(b"DRACO") {
        return Err("it does not start with DRACO".into());
    }
    let mut at = 5;
    let (major, minor) = (byte(bytes, &mut at)?, byte(bytes, &mut at)?);
    let geometry = byte(bytes, &mut at)?;
    if geometry != 1 {
        return Err(format!(
            "geometry type {geometry} (a point cloud, or unknown), not a triangle mesh"
        ));
    }
    if (major, minor) != (2, 2) {
        return Err(format!(
            "Draco bitstream {major}.{minor}; the decoder reads 2.2, what Draco 1.4 and 1.5 \
             write (re-export the model with a current encoder)"
        ));
    }
    let method = byte(bytes, &mut at)?;
    let flags = u16::from(byte(bytes, &mut at)?) | (u16::from(byte(bytes, &mut at)?) << 8);
    if flags & 0x8000 != 0 {
        for _ in 0..leb128(bytes, &mut at)? {
            leb128(bytes, &mut at)?;
            skip_metadata(bytes, &mut at, 0)?;
        }
        skip_metadata(bytes, &mut at, 0)?;
    }
    let (faces, points) = match method {
        0 => {
            let faces = leb128(bytes, &mut at)?;
            (faces, leb128(bytes, &mut at)?)
        }
        1 => {
            let _traversal = byte(bytes, &mut at)?;
            let vertices = leb128(bytes, &mut at)?;
            let faces = leb128(bytes, &mut at)?;
            let _attribute_data = byte(bytes, &mut at)?;
            let _symbols = leb128(bytes, &mut at)?;
            let splits = leb128(bytes, &mut at)?;
            (faces, vertices.saturating_add(splits))
        }
        m => return Err(format!("unknown encoder method {m}")),
    };
    let most = (bytes.len() as u64)
        .saturating_mul(MAX_FACES_PER_BYTE)
        .saturating_add(1024);
    if faces > most || points > most.saturating_mul(3) {
        return Err(format!(
            "its header claims {faces} triangles and {points} points, more than {} bytes of \
             Draco can hold",
            bytes.len()
        ));
    }
    Ok(faces.saturating_add(points))
}

/// Decodes the stream and gathers the attributes `wanted` (semantic, Draco id).
fn decode(bytes: &[u8], wanted: &[(String, u64)]) -> Result<Decoded, String> {
    let mesh = match texture::guard::catch_decoder_panic(|| draco_oxide_decoder::decode_mesh(bytes))
    {
        Ok(Ok(mesh)) => mesh,
        Ok(Err(e)) => return Err(e.to_string()),
        Err(why) => return Err(format!("the decoder failed on it ({why})")),
    };
    let mut points = None;
    let mut attributes = Vec::with_capacity(wanted.len());
    for (semantic, id) in wanted {
        let a = mesh
            .attributes
            .iter()
            .find(|a| a.get_id().as_usize() as u64 == *id)
            .ok_or_else(|| format!("{semantic} names Draco attribute {id}, which it lacks"))?;
        let n = a.len();
        if *points.get_or_insert(n) != n {
            return Err(format!(
                "attribute {semantic} has {n} points, another one {}",
                points.unwrap_or(0)
            ));
        }
        attributes.push((semantic.clone(), values(a, semantic)?));
    }
    let points = points.unwrap_or(0);
    let mut corners = Vec::with_capacity(mesh.faces.len() * 3);
    for f in &mesh.faces {
        for &p in f {
            let p = usize::from(p);
            if p >= points {
                return Err(format!(
                    "a triangle uses point {p}, out of range for {points} points"
                ));
            }
            corners.push(p as u32);
        }
    }
    Ok(Decoded {
        corners,
        points,
        attributes,
    })
}

/// An attribute's values, one tuple a point (through its point-to-value map where it has one).
fn values(a: &draco_oxide_core::attribute::Attribute, semantic: &str) -> Result<Values, String> {
    let ty = a.get_component_type();
    let comps = a.get_num_components();
    let size = match ty {
        Ty::U8 | Ty::I8 => 1,
        Ty::U16 | Ty::I16 => 2,
        Ty::U32 | Ty::I32 | Ty::F32 => 4,
        other => {
            return Err(format!(
                "{semantic} holds {other:?} values, which glTF cannot"
            ));
        }
    };
    let raw = a.get_data_as_bytes();
    let unique = raw.len() / (size * comps).max(1);
    let read = |v: usize, k: usize| -> f32 {
        let b = &raw[(v * comps + k) * size..][..size];
        match ty {
            Ty::U8 => f32::from(b[0]),
            Ty::I8 => f32::from(b[0] as i8),
            Ty::U16 => f32::from(u16::from_le_bytes([b[0], b[1]])),
            Ty::I16 => f32::from(i16::from_le_bytes([b[0], b[1]])),
            Ty::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
            Ty::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f32,
            _ => f32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        }
    };
    let n = a.len();
    let map = a.point_map_as_slice();
    let mut data = Vec::with_capacity(n * comps);
    for p in 0..n {
        let v = match map {
            Some(map) => usize::from(map[p]),
            None => p,
        };
        if v >= unique {
            return Err(format!(
                "{semantic}: point {p} maps to value {v} of {unique}"
            ));
        }
        data.extend((0..comps).map(|k| read(v, k)));
    }
    Ok(Values { ty, comps, data })
}
