//! glTF 2.0 import (`.gltf` and `.glb`).
//!
//! The document is read without its images (the texture stage decodes what materials use,
//! once), and only the buffers some view needs are loaded: a buffer that only stands in for
//! compressed views (`EXT_meshopt_compression`) has no data to load.
//! Accessors are read by our own bounds-checked reader rather than gltf's: its reader slices
//! buffers without checking every length, underflows on `count == 0`, hits `unreachable!()` on
//! i8/i16 texture coordinates and reads quantized (KHR_mesh_quantization) data as floats.

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::{ImageRef, Imported, NONE, Names, Part, SourceMaterial, Warning, append};
use crate::CookError;

fn bad(path: &Path, message: impl Into<String>) -> CookError {
    CookError::Source {
        path: path.to_path_buf(),
        line: None,
        message: message.into(),
    }
}

/// Checks a GLB header before the gltf crate sees it: gltf 1.4 subtracts the header size from
/// the declared length unchecked (an overflow panic, or a ~4 GiB allocation in release builds,
/// found by fuzzing), so the declared length must cover the header and a chunk header and must
/// not exceed the file.
fn check_glb_header(path: &Path, bytes: &[u8]) -> Result<(), CookError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    if bytes.len() < 20 {
        return Err(bad(
            path,
            format!(
                "GLB file is {} bytes, shorter than its 20-byte headers",
                bytes.len()
            ),
        ));
    }
    let version = u32::from_le_bytes(bytes[4..8].try_into().unwrap());
    let length = u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize;
    if version != 2 {
        return Err(bad(
            path,
            format!("GLB version is {version}, only 2 is supported"),
        ));
    }
    if length < 20 || length > bytes.len() {
        return Err(bad(
            path,
            format!(
                "GLB header declares {length} bytes, but the file has {} (and at least 20 are needed)",
                bytes.len()
            ),
        ));
    }
    Ok(())
}

/// A version's major and minor number ("2.0" is (2, 0); "1.0.3" (1, 0)).
fn version_numbers(v: &str) -> Option<(u32, u32)> {
    let mut parts = v.trim().split('.');
    let major = parts.next()?.parse().ok()?;
    let minor = parts.next()?.parse().ok()?;
    Some((major, minor))
}

/// Refuses a file of another major version than 2, or one that needs a later 2.x reader
/// (`minVersion`): read as 2.0, a glTF 1.0 file said only that it held no faces.
fn check_version(path: &Path, version: &str, min: Option<&str>) -> Result<(), CookError> {
    let Some((major, _)) = version_numbers(version) else {
        return Err(bad(
            path,
            format!("asset.version {version:?} is no glTF version (\"2.0\" for glTF 2.0)"),
        ));
    };
    if major != 2 {
        return Err(bad(
            path,
            format!(
                "asset.version is {version:?}: only glTF 2.0 files are read{}",
                if major == 1 {
                    " (convert it to 2.0 with a tool such as Blender or gltf-pipeline)"
                } else {
                    ""
                }
            ),
        ));
    }
    if let Some(min) = min {
        match version_numbers(min) {
            Some(v) if v <= (2, 0) => {}
            _ => {
                return Err(bad(
                    path,
                    format!(
                        "asset.minVersion is {min:?}: the file needs a reader of that glTF \
                         version or later, and this one reads 2.0"
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// The version a glTF's JSON says it is, read alone: a glTF 1.0 file is not valid 2.0 JSON
/// (its meshes and accessors are objects keyed by name), so its version is read past that.
fn sniff_version(text: &[u8]) -> Option<String> {
    #[derive(serde::Deserialize)]
    struct Root {
        asset: Asset,
    }
    #[derive(serde::Deserialize)]
    struct Asset {
        version: String,
    }
    serde_json::from_slice::<Root>(text)
        .ok()
        .map(|r| r.asset.version)
}

/// The document, and a GLB's binary chunk in the file's own buffer: gltf's parser copies the
/// chunk out of the file, and both were held through the import (a 20 MB GLB's import peaked
/// at 100 MB of heap).
fn parse(mut bytes: Vec<u8>) -> Result<Parsed, (gltf::Error, Option<String>)> {
    if !bytes.starts_with(b"glTF") {
        // The specification lets a reader skip a byte-order mark, which some editors write.
        let text = bytes.strip_prefix("\u{feff}".as_bytes()).unwrap_or(&bytes);
        let json = gltf::json::deserialize::from_slice(text)
            .map_err(|e| (gltf::Error::from(e), sniff_version(text)))?;
        let exact = exact_locals(text, &json);
        return Ok((
            gltf::Document::from_json_without_validation(json),
            None,
            exact,
        ));
    }
    let glb = gltf::binary::Glb::from_slice(&bytes).map_err(|e| (e, None))?;
    // The JSON chunk is padded with spaces; some writers pad it with zero bytes, which JSON
    // does not allow after the value.
    let end = glb
        .json
        .iter()
        .rposition(|&b| b != 0 && !b.is_ascii_whitespace())
        .map_or(0, |i| i + 1);
    let text = &glb.json[..end];
    let json = gltf::json::deserialize::from_slice(text)
        .map_err(|e| (gltf::Error::from(e), sniff_version(text)))?;
    let exact = exact_locals(text, &json);
    // Where the chunk lies in the file: `Glb::from_slice` borrows it from there.
    let within = |b: &[u8]| {
        let start = (b.as_ptr() as usize).checked_sub(bytes.as_ptr() as usize)?;
        (start + b.len() <= bytes.len()).then_some(start..start + b.len())
    };
    let bin = glb
        .bin
        .as_deref()
        .map(|b| within(b).ok_or_else(|| b.to_vec()));
    drop(glb);
    let blob = bin.map(|at| match at {
        Ok(r) => {
            bytes.truncate(r.end);
            bytes.drain(..r.start);
            bytes
        }
        Err(copy) => copy,
    });
    Ok((
        gltf::Document::from_json_without_validation(json),
        blob,
        exact,
    ))
}

/// The document, a GLB's binary chunk, and [`exact_locals`].
type Parsed = (gltf::Document, Option<Vec<u8>>, Vec<Option<glam::DMat4>>);

/// Node translations past this (2^14 units, where f32 values are 2^-9 apart) are read again
/// in f64: a scan placed in survey coordinates by its root node.
const EXACT_PAST: f32 = 16_384.0;

/// Each node's local transform in f64 from the digits the file writes, where some node is
/// translated far from the origin (gltf reads them as f32: 500000.123 becomes 500000.125);
/// empty for any other file, whose f32 transforms are exact enough. A node the f64 reading
/// cannot give (it failed where gltf's did not) keeps its f32 transform.
fn exact_locals(text: &[u8], json: &gltf::json::Root) -> Vec<Option<glam::DMat4>> {
    let far = json.nodes.iter().any(|n| {
        let t = match (&n.matrix, &n.translation) {
            (Some(m), _) => [m[12], m[13], m[14]],
            (None, Some(t)) => *t,
            (None, None) => return false,
        };
        t.iter().any(|c| c.abs() > EXACT_PAST)
    });
    if !far {
        return Vec::new();
    }
    #[derive(serde::Deserialize)]
    struct Nodes {
        #[serde(default)]
        nodes: Vec<Node>,
    }
    #[derive(serde::Deserialize)]
    struct Node {
        matrix: Option<[f64; 16]>,
        translation: Option<[f64; 3]>,
        rotation: Option<[f64; 4]>,
        scale: Option<[f64; 3]>,
    }
    let Ok(exact) = serde_json::from_slice::<Nodes>(text) else {
        return Vec::new();
    };
    exact
        .nodes
        .into_iter()
        .map(|n| {
            let m = match n.matrix {
                Some(m) => glam::DMat4::from_cols_array(&m),
                // As gltf composes them: translation, then rotation (not renormalized), then
                // scale.
                None => glam::DMat4::from_scale_rotation_translation(
                    n.scale.map_or(glam::DVec3::ONE, glam::DVec3::from),
                    n.rotation
                        .map_or(glam::DQuat::IDENTITY, glam::DQuat::from_array),
                    n.translation.map_or(glam::DVec3::ZERO, glam::DVec3::from),
                ),
            };
            m.is_finite().then_some(m)
        })
        .collect()
}

/// The cameras and the sun a file places on its nodes (glTF cameras, `KHR_lights_punctual`),
/// as the scene graph is walked: a church exported from Blender with its sun set to shine
/// through the rose window and its views framed keeps them rather than guessed ones.
/// A spot light's inner and outer cone half-angles (radians).
type ConeAngles = (f32, f32);

/// A point or spot light where the scene graph places it.
struct PlacedLamp {
    name: String,
    world: glam::DMat4,
    /// Linear RGB.
    colour: [f32; 3],
    /// A spot's inner and outer cone angles.
    cone: Option<ConeAngles>,
    range: Option<f32>,
}

#[derive(Default)]
struct Views {
    /// Name, world transform, vertical field of view (radians), near and far plane.
    cameras: Vec<(String, glam::DMat4, f32, f32, Option<f32>)>,
    /// Name, world transform, linear colour: the first directional light.
    sun: Option<(String, glam::DMat4, [f32; 3])>,
    /// Point and spot lights. The guess takes one that shines in through the windows (a lamp
    /// outside a church's glass); most are lamps indoors, which light no window.
    lamps: Vec<PlacedLamp>,
    /// Cameras and lights a pack cannot hold (orthographic cameras, directional lights after
    /// the first), for one warning.
    unused: Vec<String>,
    /// Lights the file gets wrong (an index past its lights, a type glTF does not define),
    /// a warning each.
    broken: Vec<String>,
}

impl Views {
    fn visit(
        &mut self,
        document: &gltf::Document,
        cameras: &[gltf::json::Camera],
        node: &gltf::Node,
        world: glam::DMat4,
    ) {
        let node_name = || {
            node.name()
                .map_or_else(|| format!("node{}", node.index()), str::to_string)
        };
        if let Some(camera) = node.camera()
            && let Some(json) = cameras.get(camera.index())
        {
            let name = camera.name().map_or_else(node_name, str::to_string);
            use gltf::json::{camera::Type, validation::Checked};
            match (&json.type_, &json.perspective) {
                (Checked::Valid(Type::Perspective), Some(p)) => {
                    self.cameras.push((name, world, p.yfov, p.znear, p.zfar));
                }
                (Checked::Valid(Type::Orthographic), _) => {
                    self.unused.push(format!("orthographic camera {name:?}"))
                }
                _ => self
                    .unused
                    .push(format!("camera {name:?} without a perspective projection")),
            }
        }
        let Some(index) = node
            .extension_value("KHR_lights_punctual")
            .and_then(|e| e.get("light"))
            .and_then(serde_json::Value::as_u64)
        else {
            return;
        };
        let lights = document
            .extension_value("KHR_lights_punctual")
            .and_then(|e| e.get("lights"))
            .and_then(serde_json::Value::as_array);
        let Some(light) = lights.and_then(|l| l.get(usize::try_from(index).ok()?)) else {
            self.broken.push(format!(
                "node {:?} places light {index}, but the file defines {} lights: no light placed \
                 there",
                node_name(),
                lights.map_or(0, Vec::len)
            ));
            return;
        };
        let name = light
            .get("name")
            .and_then(serde_json::Value::as_str)
            .map_or_else(node_name, str::to_string);
        let kind = light.get("type").and_then(serde_json::Value::as_str);
        let colour = light
            .get("color")
            .and_then(serde_json::Value::as_array)
            .filter(|c| c.len() == 3)
            .and_then(|c| {
                let v: Option<Vec<f32>> = c.iter().map(|x| x.as_f64().map(|x| x as f32)).collect();
                v.filter(|v| v.iter().all(|x| x.is_finite() && *x >= 0.0))
            })
            .map_or([1.0; 3], |v| [v[0], v[1], v[2]]);
        // The spec's cut-off, where given; the pack's lamps have none.
        let range = light
            .get("range")
            .and_then(serde_json::Value::as_f64)
            .map(|r| r as f32)
            .filter(|r| r.is_finite() && *r > 0.0);
        match kind {
            Some("directional") if self.sun.is_none() => self.sun = Some((name, world, colour)),
            Some("point") => self.lamps.push(PlacedLamp {
                name,
                world,
                colour,
                cone: None,
                range,
            }),
            Some("spot") => {
                // The spec's defaults are 0 and π/4, with 0 ≤ inner < outer ≤ π/2; a value out
                // of range is clamped into it.
                let angle = |key: &str| {
                    light
                        .get("spot")
                        .and_then(|s| s.get(key))
                        .and_then(serde_json::Value::as_f64)
                        .filter(|a| a.is_finite())
                };
                let outer = angle("outerConeAngle")
                    .filter(|a| *a > 0.0)
                    .map_or(std::f32::consts::FRAC_PI_4, |a| {
                        (a as f32).min(std::f32::consts::FRAC_PI_2)
                    });
                let inner = angle("innerConeAngle").map_or(0.0, |a| (a as f32).clamp(0.0, outer));
                self.lamps.push(PlacedLamp {
                    name,
                    world,
                    colour,
                    cone: Some((inner, outer)),
                    range,
                });
            }
            Some("directional") => self.unused.push(format!("directional light {name:?}")),
            Some(other) => self.broken.push(format!(
                "light {name:?} has type {other:?}, which KHR_lights_punctual does not define \
                 (directional, point, spot): not used"
            )),
            None => self
                .broken
                .push(format!("light {name:?} has no type: not used")),
        }
    }

    /// Onto `out`, once its origin and bounds are known: each camera looking along its -z
    /// axis at the depth of the model's centre, the sun's light along its -z axis.
    fn finish(self, path: &Path, out: &mut Imported) {
        let origin = glam::DVec3::from(out.origin);
        // The model's centre and size, only where a camera needs them: a pass over every
        // position.
        let (centre, diag) = if self.cameras.is_empty() {
            (glam::DVec3::ZERO, 1.0)
        } else {
            let (lo, hi) = out.positions.iter().fold(
                (
                    glam::Vec3::splat(f32::INFINITY),
                    glam::Vec3::splat(f32::NEG_INFINITY),
                ),
                |(lo, hi), p| (lo.min((*p).into()), hi.max((*p).into())),
            );
            if lo.is_finite() && hi.is_finite() {
                (((lo + hi) * 0.5).as_dvec3(), (hi - lo).length() as f64)
            } else {
                (glam::DVec3::ZERO, 1.0)
            }
        };
        for (name, world, yfov, znear, zfar) in self.cameras {
            let eye = world.transform_point3(glam::DVec3::ZERO) - origin;
            let forward = world.transform_vector3(-glam::DVec3::Z).normalize_or_zero();
            let up = world.transform_vector3(glam::DVec3::Y).normalize_or_zero();
            let fov = yfov.to_degrees();
            if forward == glam::DVec3::ZERO
                || up == glam::DVec3::ZERO
                || !eye.is_finite()
                || !(fov > 0.0 && fov < 180.0)
                || znear.is_nan()
                || znear <= 0.0
            {
                out.warnings.push(Warning::new(
                    path,
                    None,
                    format!("camera {name:?} has a degenerate transform or projection: not used"),
                ));
                continue;
            }
            let depth = (centre - eye).dot(forward).max(diag * 1e-3).max(1e-6);
            let far = zfar
                .filter(|f| f.is_finite() && *f > znear)
                .unwrap_or(((centre - eye).length() + diag * 2.0) as f32);
            if !(far > znear && far.is_finite()) {
                out.warnings.push(Warning::new(
                    path,
                    None,
                    format!(
                        "camera {name:?}: near plane {znear} is not before the model: not used"
                    ),
                ));
                continue;
            }
            // Depth over a wider range has no precision left (the manifest refuses it).
            let near = znear.max(far / pack::MAX_FAR_OVER_NEAR as f32);
            if near != znear {
                out.warnings.push(Warning::new(
                    path,
                    None,
                    format!(
                        "camera {name:?}: near plane {znear} is over 1e9 times nearer than its \
                         far plane {far}; moved out to {near}"
                    ),
                ));
            }
            out.views.push(pack::Camera {
                name,
                position: eye.as_vec3().to_array(),
                target: (eye + forward * depth).as_vec3().to_array(),
                up: up.as_vec3().to_array(),
                fov_y: fov,
                near,
                far,
            });
        }
        if let Some((name, world, colour)) = self.sun {
            let d = world.transform_vector3(-glam::DVec3::Z).normalize_or_zero();
            if d != glam::DVec3::ZERO {
                out.sun = Some(super::FileSun {
                    name,
                    direction: d.as_vec3().to_array(),
                    colour,
                });
            }
        }
        for PlacedLamp {
            name,
            world,
            colour,
            cone,
            range,
        } in self.lamps
        {
            let position = world.transform_point3(glam::DVec3::ZERO) - origin;
            let axis = world.transform_vector3(-glam::DVec3::Z).normalize_or_zero();
            if !position.is_finite() || (cone.is_some() && axis == glam::DVec3::ZERO) {
                out.warnings.push(Warning::new(
                    path,
                    None,
                    format!("light {name:?} has a degenerate transform: not used"),
                ));
                continue;
            }
            out.lamps.push(super::FileLamp {
                name,
                position: position.as_vec3().to_array(),
                colour,
                spot: cone.map(|(inner, outer)| super::FileSpot {
                    axis: axis.as_vec3().to_array(),
                    inner,
                    outer,
                }),
                range,
            });
        }
        for b in self.broken {
            out.warnings.push(Warning::new(path, None, b));
        }
        if !self.unused.is_empty() {
            out.warnings.push(Warning::new(
                path,
                None,
                format!(
                    "{} not used: a pack holds perspective cameras and one light",
                    self.unused.join(", ")
                ),
            ));
        }
    }
}

/// Where a node or instance is placed: by the f32 chain of gltf's transforms, which places a
/// model near the origin (bit for bit as ever), and by the same chain in f64, which places one
/// in survey coordinates (see `Imported::origin`).
#[derive(Clone, Copy)]
struct World {
    m: glam::Mat4,
    exact: glam::DMat4,
}

impl World {
    const IDENTITY: World = World {
        m: glam::Mat4::IDENTITY,
        exact: glam::DMat4::IDENTITY,
    };

    /// The child's world: chained in f64 and rounded to f32 once, so error does not grow
    /// with depth (chained in f32, a leaf 10,000 levels down was 4e-4 units off, 100,000
    /// levels down 0.09).
    fn then(self, exact: glam::DMat4) -> World {
        let exact = self.exact * exact;
        World {
            m: exact.as_mat4(),
            exact,
        }
    }
}

pub fn import(path: &Path) -> Result<Imported, CookError> {
    let bytes = std::fs::read(path).map_err(|source| CookError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    check_glb_header(path, &bytes)?;
    let convert = |e: gltf::Error| match e {
        gltf::Error::Io(source) => CookError::Io {
            path: path.to_path_buf(),
            source,
        },
        gltf::Error::Deserialize(j) => CookError::Source {
            path: path.to_path_buf(),
            line: (j.line() > 0).then_some(j.line()),
            message: format!("invalid glTF JSON: {j}"),
        },
        // gltf's message for these already begins "invalid glTF:".
        e @ gltf::Error::Validation(_) => bad(path, e.to_string()),
        other => bad(path, format!("invalid glTF: {other}")),
    };
    let (document, blob, exact) = parse(bytes).map_err(|(e, version)| {
        // A file of another version is said to be one, not a list of what 2.0 misses in it.
        match version.map(|v| check_version(path, &v, None)) {
            Some(Err(said)) => said,
            _ => convert(e),
        }
    })?;
    // gltf-json's validation indexes the POSITION accessor before checking it exists (an
    // out-of-bounds panic found by fuzzing): check every attribute index first.
    let mut json = document.into_json();
    check_version(path, &json.asset.version, json.asset.min_version.as_deref())?;
    let mut warnings = required_extensions(path, std::mem::take(&mut json.extensions_required))?;
    for (mi, mesh) in json.meshes.iter().enumerate() {
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let indices = prim.attributes.values().chain(prim.indices.as_ref());
            for a in indices {
                if a.value() >= json.accessors.len() {
                    return Err(bad(
                        path,
                        format!(
                            "mesh {mi} primitive {pi} uses accessor {}, but there are {}",
                            a.value(),
                            json.accessors.len()
                        ),
                    ));
                }
            }
        }
    }
    // gltf's `Image::source` unwraps the MIME type of a buffer-view image and the URI of any
    // other (a panic found by fuzzing); the spec requires them, so a file without is invalid.
    for (i, image) in json.images.iter().enumerate() {
        let ok = match &image.buffer_view {
            Some(v) => image.mime_type.is_some() && v.value() < json.buffer_views.len(),
            None => image.uri.is_some(),
        };
        if !ok {
            return Err(bad(
                path,
                format!("image {i} needs a uri, or a bufferView with a mimeType"),
            ));
        }
    }
    // Read here rather than through gltf's `Camera::projection`, which unwraps the projection
    // the type names and validation does not require.
    let camera_json = json.cameras.clone();
    let mut unbounded = std::collections::HashSet::new();
    let document = validate(json, &mut unbounded).map_err(convert)?;
    if !unbounded.is_empty() {
        warnings.push(Warning::new(
            path,
            None,
            format!(
                "{} primitive(s) whose POSITION accessor lacks the min and max glTF requires: \
                 read without them",
                unbounded.len()
            ),
        ));
    }
    let base = path.parent().unwrap_or(Path::new(""));
    let mut absent = Vec::new();
    let (buffers, decoded, files) = load_buffers(path, &document, base, blob, &mut absent)?;
    let buffers: Vec<&[u8]> = buffers.iter().map(|b| &b[..]).collect();

    let mut out = Imported {
        path: path.to_path_buf(),
        files,
        warnings,
        absent,
        ..Default::default()
    };
    let mut material_ids: HashMap<usize, u32> = HashMap::new();
    let mut part_ids: HashMap<(Option<usize>, usize, usize, usize), u32> = HashMap::new();
    let mut skipped_modes: Vec<String> = Vec::new();

    // Roots of the default scene, else of the first scene, else every node nobody parents.
    let sceneless = document.scenes().len() == 0;
    let roots: Vec<gltf::Node> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => {
            // glTF lists a scene's roots once each; a root listed twice was cooked twice,
            // one copy over the other.
            let mut listed = vec![0usize; document.nodes().len()];
            let roots: Vec<gltf::Node> = scene
                .nodes()
                .filter(|n| {
                    listed[n.index()] += 1;
                    listed[n.index()] == 1
                })
                .collect();
            if let Some((n, times)) = listed.iter().enumerate().find(|(_, t)| **t > 1) {
                let more = listed.iter().filter(|t| **t > 1).count() - 1;
                out.warnings.push(Warning::new(
                    path,
                    None,
                    format!(
                        "scene {} lists node {n} {times} times{}: each is cooked once (a \
                         scene's nodes are unique in glTF)",
                        scene.index(),
                        if more > 0 {
                            format!(" (and {more} more nodes more than once)")
                        } else {
                            String::new()
                        }
                    ),
                ));
            }
            roots
        }
        None => {
            let mut child = vec![false; document.nodes().len()];
            for n in document.nodes() {
                for c in n.children() {
                    child[c.index()] = true;
                }
            }
            document.nodes().filter(|n| !child[n.index()]).collect()
        }
    };
    let mut stack: Vec<(gltf::Node, World, usize)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, World::IDENTITY, 0))
        .collect();
    let mut visits = 0usize;
    let mut budget = MAX_INSTANCED;
    let draco = super::gltf_draco::Cache::default();
    let mut views = Views::default();
    // Validation does not reject cycles in the node graph. A path from a root longer than
    // there are nodes repeats one: a cycle, found without a fixed bound on depth (one of 256
    // refused 2,000-level chains that gltfpack reads). The walk is bounded too, for graphs
    // that share children many times over without a cycle.
    let node_count = document.nodes().len();
    let mut reached = vec![false; node_count];
    // Every node's world, made at the first skin; each skin's joint matrices; the skinned
    // nodes cooked.
    let mut node_worlds: Option<Vec<glam::DMat4>> = None;
    let mut skins: HashMap<usize, std::rc::Rc<Vec<glam::DMat4>>> = HashMap::new();
    let mut skinned_once: std::collections::HashSet<usize> = std::collections::HashSet::new();
    let mut unskinned: Vec<usize> = Vec::new();
    while let Some((node, parent, depth)) = stack.pop() {
        visits += 1;
        if depth >= node_count {
            return Err(bad(
                path,
                format!(
                    "node hierarchy is cyclic: node {} is reached down a path of {} nodes, \
                     but the file has {node_count}, so some node on it is its own ancestor",
                    node.index(),
                    depth + 1
                ),
            ));
        }
        reached[node.index()] = true;
        if visits > 1_000_000 {
            return Err(bad(
                path,
                "node hierarchy visits over 1,000,000 nodes (children shared by many parents)",
            ));
        }
        let world = parent.then(local_transform(&node, &exact));
        if !world.m.is_finite() {
            return Err(bad(
                path,
                format!("node {} has a non-finite transform", node.index()),
            ));
        }
        views.visit(&document, &camera_json, &node, world.exact);
        // A skinned mesh stands where its joints put it, whichever path reached its node:
        // cooked once.
        let again = node.skin().is_some() && !skinned_once.insert(node.index());
        if let Some(mesh) = node.mesh()
            && !again
        {
            let ctx = Ctx {
                path,
                document: &document,
                buffers: &buffers,
                decoded: &decoded,
                draco: &draco,
            };
            // A skinned mesh is placed by its joints, not by its node (glTF ignores the
            // node's transform): posed as the joints stand, as viewers show it at rest.
            let joints = match node.skin() {
                Some(skin) => {
                    let worlds = node_worlds.get_or_insert_with(|| all_worlds(&document, &exact));
                    let key = skin.index();
                    let matrices = match skins.entry(key) {
                        std::collections::hash_map::Entry::Occupied(e) => e.get().clone(),
                        std::collections::hash_map::Entry::Vacant(e) => {
                            e.insert(joint_matrices(&ctx, &skin, worlds)?).clone()
                        }
                    };
                    Some(matrices)
                }
                None => None,
            };
            let node_worlds_here = instances(&ctx, &document, &node, world)?;
            let skinned_worlds = [World::IDENTITY];
            if joints.is_some() && node_worlds_here.len() > 1 {
                out.warnings.push(Warning::new(
                    path,
                    None,
                    format!(
                        "node {} is skinned and instanced (EXT_mesh_gpu_instancing): its skinned \
                         primitives are cooked once, where the joints put them",
                        node.index()
                    ),
                ));
            }
            for prim in mesh.primitives() {
                let mode = prim.mode();
                if !matches!(
                    mode,
                    Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
                ) {
                    let m = format!("{mode:?}");
                    if !skipped_modes.contains(&m) {
                        skipped_modes.push(m);
                    }
                    continue;
                }
                // A primitive of a skinned node without joints (glTF requires them) stays
                // where its node puts it, with a warning.
                let skinned = joints.is_some() && prim.get(&gltf::Semantic::Joints(0)).is_some();
                if joints.is_some() && !skinned && !unskinned.contains(&mesh.index()) {
                    unskinned.push(mesh.index());
                }
                let worlds: &[World] = if skinned {
                    &skinned_worlds
                } else {
                    &node_worlds_here
                };
                let material = prim.material();
                let mat_id = match material.index() {
                    Some(i) => Some(match material_ids.get(&i) {
                        Some(&id) => id,
                        None => {
                            let id = out.materials.len() as u32;
                            let sm = convert_material(
                                &ctx,
                                &material,
                                &mut out.warnings,
                                &mut out.absent,
                            )?;
                            out.materials.push(sm);
                            material_ids.insert(i, id);
                            id
                        }
                    }),
                    None => None,
                };
                let names = Names {
                    material: material.index().map(|_| material_name(&material)),
                    group: None,
                    object: None,
                    mesh: Some(
                        mesh.name()
                            .map(str::to_string)
                            .unwrap_or_else(|| format!("mesh{}", mesh.index())),
                    ),
                    node: Some(
                        node.name()
                            .map(str::to_string)
                            .unwrap_or_else(|| format!("node{}", node.index())),
                    ),
                    instance: None,
                };
                // Each instance is its own part, as it would be written as its own node: the
                // geometry heuristics judge one pillar, not a row of them. Past a few thousand
                // (grass, tiles) they are one part, which keeps parts and notes bounded.
                let own_parts = worlds.len() <= MAX_INSTANCE_PARTS;
                let parts: Vec<u32> = (0..worlds.len())
                    .map(|instance| {
                        let instance = if own_parts { instance } else { 0 };
                        let key = (material.index(), mesh.index(), node.index(), instance);
                        *part_ids.entry(key).or_insert_with(|| {
                            out.parts.push(Part {
                                names: Names {
                                    instance: (own_parts && worlds.len() > 1)
                                        .then_some(instance as u32),
                                    ..names.clone()
                                },
                                material: mat_id,
                            });
                            (out.parts.len() - 1) as u32
                        })
                    })
                    .collect();
                // The rest pose: the node's morph weights, else the mesh's (zero without).
                let weights = node.weights().or(mesh.weights()).unwrap_or(&[]);
                let placed = Placed {
                    worlds,
                    parts: &parts,
                    weights,
                    joints: joints.as_deref().map(Vec::as_slice).filter(|_| skinned),
                };
                add_primitive(&ctx, &mesh, &prim, placed, &mut out, &mut budget)?;
            }
        }
        for c in node.children().collect::<Vec<_>>().into_iter().rev() {
            stack.push((c, world, depth + 1));
        }
    }
    // Without a scene every node nobody parents is a root, so one left unreached has a parent
    // at every step up: a loop. Its meshes were dropped without a word.
    if sceneless && let Some(n) = reached.iter().position(|&r| !r) {
        return Err(bad(
            path,
            format!(
                "node hierarchy is cyclic: node {n} has no root above it (the file has no \
                 scene, and every node above it has a parent), so some node is its own \
                 ancestor"
            ),
        ));
    }
    if !unskinned.is_empty() {
        out.warnings.push(Warning::new(
            path,
            None,
            format!(
                "mesh(es) {} of skinned nodes have primitives without JOINTS_0 and WEIGHTS_0, \
                 which glTF requires: placed by their nodes, unskinned",
                unskinned
                    .iter()
                    .map(usize::to_string)
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    // A loop the scene does not reach draws nothing either way, but says the file is not what
    // its tool meant to write.
    if !sceneless
        && reached.contains(&false)
        && let Some(n) = node_in_cycle(&document)
    {
        out.warnings.push(Warning::new(
            path,
            None,
            format!(
                "node hierarchy is cyclic at node {n}, which the scene does not reach: those \
                 nodes are ignored"
            ),
        ));
    }
    // Scans and Sketchfab exports mark their materials unlit, their lighting baked into the
    // texture: lit again by the scene, they come out darker and shaded twice.
    let mut unlit: Vec<(usize, String)> = document
        .materials()
        .filter(|m| m.index().is_some_and(|i| material_ids.contains_key(&i)))
        .filter(|m| m.extension_value("KHR_materials_unlit").is_some())
        .map(|m| (m.index().unwrap_or(0), material_name(&m)))
        .collect();
    if !unlit.is_empty() {
        unlit.sort();
        let count = unlit.len();
        let named: Vec<String> = unlit
            .into_iter()
            .take(crate::report::NAMED)
            .map(|(_, n)| format!("{n:?}"))
            .collect();
        out.warnings.push(Warning::new(
            path,
            None,
            format!(
                "{count} material(s) marked unlit (KHR_materials_unlit: {}{}) are cooked as \
                 lit surfaces, so light baked into their textures is lit again",
                named.join(", "),
                if count > named.len() { ", ..." } else { "" }
            ),
        ));
    }
    if !skipped_modes.is_empty() {
        out.warnings.push(Warning::skipped_geometry(
            path,
            None,
            format!(
                "primitives of mode {} ignored: only triangles are cooked",
                skipped_modes.join(", ")
            ),
        ));
    }
    views.finish(path, &mut out);
    if out.tri_part.is_empty() {
        out.warnings.push(Warning::new(
            path,
            None,
            "no triangles in the scene: nothing to cook",
        ));
    }
    Ok(out)
}

/// A node that is its own ancestor, if any: a depth-first walk of every node's children,
/// iterative (a hierarchy can be deeper than the stack), each node entered once.
fn node_in_cycle(document: &gltf::Document) -> Option<usize> {
    const NEW: u8 = 0;
    const OPEN: u8 = 1;
    const DONE: u8 = 2;
    let children: Vec<Vec<usize>> = document
        .nodes()
        .map(|n| n.children().map(|c| c.index()).collect())
        .collect();
    let mut state = vec![NEW; children.len()];
    for start in 0..children.len() {
        if state[start] != NEW {
            continue;
        }
        // (node, index of the next child to enter)
        let mut path: Vec<(usize, usize)> = vec![(start, 0)];
        state[start] = OPEN;
        while let Some(&mut (n, ref mut next)) = path.last_mut() {
            match children[n].get(*next) {
                Some(&c) => {
                    *next += 1;
                    match state[c] {
                        OPEN => return Some(c),
                        NEW => {
                            state[c] = OPEN;
                            path.push((c, 0));
                        }
                        _ => {}
                    }
                }
                None => {
                    state[n] = DONE;
                    path.pop();
                }
            }
        }
    }
    None
}

/// gltf's validation, less one rule the glTF specification does not make: an accessor with
/// neither a buffer view nor sparse data is allowed ("extensions may override the zeros"), and
/// every Draco-compressed primitive's accessors are such. Those of Draco primitives pass; any
/// other still fails, as before, when it is read.
///
/// Less one it makes, too: a POSITION accessor without `min` and `max`, which exporters leave
/// out and the import never reads (it finds the bounds itself), passes; the primitives that
/// have one are listed in `unbounded`, for a warning.
fn validate(
    json: gltf::json::Root,
    unbounded: &mut std::collections::HashSet<String>,
) -> Result<gltf::Document, gltf::Error> {
    use gltf::json::validation::{Error, Validate};
    let mut draco = std::collections::HashSet::new();
    for prim in json.meshes.iter().flat_map(|m| &m.primitives) {
        let compressed = prim
            .extensions
            .as_ref()
            .is_some_and(|e| e.others.contains_key(super::gltf_draco::NAME));
        if compressed {
            let used = prim.attributes.values().chain(prim.indices.as_ref());
            draco.extend(used.map(|a| format!("accessors[{}].bufferView", a.value())));
        }
    }
    let mut errors = Vec::new();
    json.validate(&json, gltf::json::Path::new, &mut |path, error| {
        let path = path();
        let bound = path.as_str().ends_with(r#"["POSITION"].min"#)
            || path.as_str().ends_with(r#"["POSITION"].max"#);
        if matches!(error, Error::Missing) && bound {
            let primitive = path
                .as_str()
                .trim_end_matches(".min")
                .trim_end_matches(".max");
            unbounded.insert(primitive.to_string());
        } else if !(matches!(error, Error::Missing) && draco.contains(path.as_str())) {
            errors.push((path, error));
        }
    });
    if errors.is_empty() {
        Ok(gltf::Document::from_json_without_validation(json))
    } else {
        Err(gltf::Error::Validation(errors))
    }
}

/// Extensions a file may require that the import reads in full.
const READ_EXTENSIONS: &[&str] = &[
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "KHR_materials_transmission",
    "KHR_materials_volume",
    "KHR_materials_emissive_strength",
    "EXT_meshopt_compression",
    "KHR_meshopt_compression",
    "KHR_draco_mesh_compression",
    "EXT_mesh_gpu_instancing",
    "EXT_texture_webp",
    "KHR_texture_basisu",
    "MSFT_texture_dds",
    "KHR_materials_pbrSpecularGlossiness",
    // Every light's type, place, colour and cone; a lamp's `range` bounds the guess's
    // choice; intensities give way to the automatic exposure.
    "KHR_lights_punctual",
];

/// Checks what the file requires (`extensionsRequired`, which gltf's validation would refuse
/// whole, even the quantized and compressed files gltfpack writes by default). Extensions
/// that only change shading the cooker does not model (other `KHR_materials_*`, lights) are
/// warned about; any other one, a texture format without fallback say, is an error that
/// names it, since reading past it would cook missing or wrong data.
fn required_extensions(path: &Path, required: Vec<String>) -> Result<Vec<Warning>, CookError> {
    let mut ignored = Vec::new();
    for name in required {
        if READ_EXTENSIONS.contains(&name.as_str()) {
            continue;
        }
        if name.starts_with("KHR_materials_") {
            ignored.push(name);
            continue;
        }
        let hint = match name.as_str() {
            "EXT_texture_avif" => "; re-export the model with PNG or JPEG textures",
            _ => "",
        };
        return Err(bad(
            path,
            format!(
                "the file requires glTF extension {name}, which the cooker cannot read (it reads \
                 {}){hint}",
                READ_EXTENSIONS.join(", ")
            ),
        ));
    }
    Ok(if ignored.is_empty() {
        Vec::new()
    } else {
        vec![Warning::new(
            path,
            None,
            format!(
                "required extension(s) {} read without their effect: they change shading the \
                 cooker does not model",
                ignored.join(", ")
            ),
        )]
    })
}

/// Per buffer its bytes (empty where no view needs them), per view its decoded bytes where it
/// is compressed, and the external files read. A buffer is loaded only when an uncompressed
/// view lies in it or a compressed view's data does: the placeholder buffer of compressed
/// views has no data, or a fallback file a loader need not read.
type Buffers = (Vec<Vec<u8>>, Vec<Option<Vec<u8>>>, Vec<std::path::PathBuf>);

fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    base: &Path,
    mut blob: Option<Vec<u8>>,
    noted: &mut Vec<super::Absent>,
) -> Result<Buffers, CookError> {
    let compressed = document
        .views()
        .map(|v| {
            super::gltf_meshopt::of_view(&v).map_err(|m| {
                bad(
                    path,
                    format!(
                        "buffer view {} ({}): {m}",
                        v.index(),
                        super::gltf_meshopt::NAMES[0]
                    ),
                )
            })
        })
        .collect::<Result<Vec<_>, _>>()?;
    let count = document.buffers().len();
    let mut needed = vec![false; count];
    for (view, c) in document.views().zip(&compressed) {
        let b = c.as_ref().map_or(view.buffer().index(), |c| c.buffer);
        match needed.get_mut(b) {
            Some(n) => *n = true,
            None => {
                return Err(bad(
                    path,
                    format!(
                        "buffer view {} uses buffer {b}, but there are {count}",
                        view.index()
                    ),
                ));
            }
        }
    }
    let mut buffers = Vec::with_capacity(count);
    let mut files = Vec::new();
    for (b, need) in document.buffers().zip(needed) {
        let source = b.source();
        if !need {
            buffers.push(Vec::new());
            continue;
        }
        if matches!(source, gltf::buffer::Source::Bin) && b.index() > 0 {
            return Err(bad(
                path,
                format!(
                    "buffer {} has no uri: only buffer 0 can be a GLB's binary chunk",
                    b.index()
                ),
            ));
        }
        // Read here rather than by gltf, whose reader unwraps the percent-decoding of a
        // relative uri (a panic on "%FF.bin") and records no path.
        let data = match source {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                bad(
                    path,
                    "buffer 0 has no uri, and the file has no binary chunk",
                )
            })?,
            gltf::buffer::Source::Uri(uri) if uri.starts_with("data:") => {
                decode_data_uri(path, &format!("buffer {}", b.index()), uri)?
            }
            gltf::buffer::Source::Uri(uri) => {
                let file = external_file(base, uri, noted).ok_or_else(|| {
                    bad(
                        path,
                        format!("buffer {}: uri {uri:?} names no file beside it", b.index()),
                    )
                })?;
                let bytes = std::fs::read(&file).map_err(|source| CookError::Io {
                    path: file.clone(),
                    source,
                })?;
                files.push(file);
                bytes
            }
        };
        if data.len() < b.length() {
            return Err(bad(
                path,
                format!(
                    "buffer {} holds {} bytes, but declares {}",
                    b.index(),
                    data.len(),
                    b.length()
                ),
            ));
        }
        buffers.push(data);
    }
    // Only views an accessor or image reads, within one budget for the whole file: many views
    // may name the same few compressed bytes.
    let mut used = vec![false; compressed.len()];
    for a in document.accessors() {
        let sparse = a.sparse().map(|s| [s.indices().view(), s.values().view()]);
        for v in a.view().into_iter().chain(sparse.into_iter().flatten()) {
            used[v.index()] = true;
        }
    }
    for i in document.images() {
        if let gltf::image::Source::View { view, .. } = i.source() {
            used[view.index()] = true;
        }
    }
    let mut total = 0u64;
    let mut decoded = Vec::with_capacity(compressed.len());
    for ((view, c), used) in document.views().zip(&compressed).zip(used) {
        let Some(c) = c.as_ref().filter(|_| used) else {
            decoded.push(None);
            continue;
        };
        total += view.length() as u64;
        let fail = |m: String| bad(path, format!("buffer view {}: {m}", view.index()));
        if total > super::gltf_meshopt::MAX_TOTAL_DECODED {
            return Err(fail(format!(
                "compressed views decode to more than {} bytes in all",
                super::gltf_meshopt::MAX_TOTAL_DECODED
            )));
        }
        let bytes = c
            .decode(c.source(&buffers[c.buffer]).map_err(fail)?)
            .map_err(fail)?;
        decoded.push(Some(bytes));
    }
    Ok((buffers, decoded, files))
}

struct Ctx<'a> {
    path: &'a Path,
    document: &'a gltf::Document,
    buffers: &'a [&'a [u8]],
    /// Per view, its bytes decoded where it is compressed (`EXT_meshopt_compression`).
    decoded: &'a [Option<Vec<u8>>],
    /// Primitives compressed with `KHR_draco_mesh_compression`, decoded.
    draco: &'a super::gltf_draco::Cache,
}

fn components(d: Dimensions) -> usize {
    match d {
        Dimensions::Scalar => 1,
        Dimensions::Vec2 => 2,
        Dimensions::Vec3 => 3,
        Dimensions::Vec4 => 4,
        Dimensions::Mat2 => 4,
        Dimensions::Mat3 => 9,
        Dimensions::Mat4 => 16,
    }
}

fn type_size(t: DataType) -> usize {
    match t {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

fn component(bytes: &[u8], t: DataType, normalized: bool) -> f32 {
    let v = match t {
        DataType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]),
        DataType::U32 => u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f32,
        DataType::I8 => bytes[0] as i8 as f32,
        DataType::U8 => bytes[0] as f32,
        DataType::I16 => i16::from_le_bytes([bytes[0], bytes[1]]) as f32,
        DataType::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as f32,
    };
    if normalized { normalize(v, t) } else { v }
}

/// A normalized integer component (its value as a float) to [0, 1] or [-1, 1], as glTF
/// defines them; 32-bit types are as they are. Shared with the Draco stream's values.
pub(super) fn normalize(v: f32, t: DataType) -> f32 {
    match t {
        DataType::I8 => (v / 127.0).max(-1.0),
        DataType::U8 => v / 255.0,
        DataType::I16 => (v / 32767.0).max(-1.0),
        DataType::U16 => v / 65535.0,
        DataType::U32 | DataType::F32 => v,
    }
}

impl Ctx<'_> {
    /// A view's bytes within its buffer, bounds checked.
    fn view_bytes(&self, view: &gltf::buffer::View, what: &str) -> Result<&[u8], CookError> {
        let buffer = self.buffers.get(view.buffer().index()).ok_or_else(|| {
            bad(
                self.path,
                format!("{what}: buffer {} does not exist", view.buffer().index()),
            )
        })?;
        let view_end = view.offset().checked_add(view.length());
        let data = view_end
            .and_then(|end| buffer.get(view.offset()..end))
            .ok_or_else(|| {
                bad(
                    self.path,
                    format!(
                        "{what}: buffer view {} spans bytes {}..+{} of a {}-byte buffer",
                        view.index(),
                        view.offset(),
                        view.length(),
                        buffer.len()
                    ),
                )
            })?;
        Ok(data)
    }

    /// The bytes of `count` elements of `elem` bytes at `offset` into a view, every bound checked.
    fn view_slice(
        &self,
        view: &gltf::buffer::View,
        offset: usize,
        count: usize,
        elem: usize,
        what: &str,
    ) -> Result<(&[u8], usize), CookError> {
        let data = match self.decoded.get(view.index()) {
            Some(Some(bytes)) => &bytes[..],
            _ => self.view_bytes(view, what)?,
        };
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(bad(
                self.path,
                format!("{what}: byte stride {stride} is smaller than the {elem}-byte element"),
            ));
        }
        if count == 0 {
            return Ok((&[], stride));
        }
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(elem))
            .and_then(|x| x.checked_add(offset));
        match end {
            Some(end) if end <= data.len() => Ok((&data[offset..end], stride)),
            _ => Err(bad(
                self.path,
                format!(
                    "{what}: {count} elements of {elem} bytes (stride {stride}) at offset {offset} overrun buffer view {} of {} bytes",
                    view.index(),
                    data.len()
                ),
            )),
        }
    }

    /// Reads an accessor as `N`-component floats, converting integer and normalized types.
    fn floats<const N: usize>(
        &self,
        acc: &gltf::Accessor,
        what: &str,
    ) -> Result<Vec<[f32; N]>, CookError> {
        let what = format!("{what} (accessor {})", acc.index());
        let dims = components(acc.dimensions());
        if dims != N {
            return Err(bad(
                self.path,
                format!("{what} has {dims} components, expected {N}"),
            ));
        }
        let t = acc.data_type();
        let size = type_size(t);
        let elem = N * size;
        let count = acc.count();
        let mut out = vec![[0.0f32; N]; 0];
        let decode = |bytes: &[u8]| -> [f32; N] {
            std::array::from_fn(|k| component(&bytes[k * size..], t, acc.normalized()))
        };
        match acc.view() {
            Some(view) => {
                let (data, stride) = self.view_slice(&view, acc.offset(), count, elem, &what)?;
                out.reserve_exact(count);
                for i in 0..count {
                    out.push(decode(&data[i * stride..]));
                }
            }
            None => {
                if acc.sparse().is_none() {
                    return Err(bad(
                        self.path,
                        format!("{what} has neither a buffer view nor sparse data"),
                    ));
                }
                if count > 1 << 28 {
                    return Err(bad(
                        self.path,
                        format!("{what}: count {count} is too large"),
                    ));
                }
                out = vec![[0.0; N]; count];
            }
        }
        if let Some(sparse) = acc.sparse() {
            let n = sparse.count();
            let idx = sparse.indices();
            let isize = match idx.index_type() {
                gltf::accessor::sparse::IndexType::U8 => 1,
                gltf::accessor::sparse::IndexType::U16 => 2,
                gltf::accessor::sparse::IndexType::U32 => 4,
            };
            let (ibytes, istride) = self.view_slice(&idx.view(), idx.offset(), n, isize, &what)?;
            let vals = sparse.values();
            let (vbytes, vstride) = self.view_slice(&vals.view(), vals.offset(), n, elem, &what)?;
            for k in 0..n {
                let b = &ibytes[k * istride..];
                let i = match isize {
                    1 => b[0] as usize,
                    2 => u16::from_le_bytes([b[0], b[1]]) as usize,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize,
                };
                let slot = out.get_mut(i).ok_or_else(|| {
                    bad(
                        self.path,
                        format!("{what}: sparse index {i} is out of range (count {count})"),
                    )
                })?;
                *slot = decode(&vbytes[k * vstride..]);
            }
        }
        Ok(out)
    }

    /// Attribute `semantic` from the primitive's Draco stream where that holds it, else from
    /// its accessor. `prim` names the primitive in an error about the stream (a stream is
    /// decoded once for every primitive that names it).
    fn attribute<const N: usize>(
        &self,
        draco: Option<&super::gltf_draco::Decoded>,
        prim: &str,
        acc: &gltf::Accessor,
        semantic: &str,
    ) -> Result<Vec<[f32; N]>, CookError> {
        match draco.and_then(|d| d.floats::<N>(semantic, acc)) {
            Some(values) => values.map_err(|m| bad(self.path, format!("{prim}: {m}"))),
            None => self.floats::<N>(acc, semantic),
        }
    }

    fn indices(&self, acc: &gltf::Accessor) -> Result<Vec<u32>, CookError> {
        let what = format!("indices (accessor {})", acc.index());
        if acc.dimensions() != Dimensions::Scalar
            || !matches!(
                acc.data_type(),
                DataType::U8 | DataType::U16 | DataType::U32
            )
        {
            return Err(bad(
                self.path,
                format!(
                    "{what} are {:?} {:?}, expected unsigned integer scalars",
                    acc.data_type(),
                    acc.dimensions()
                ),
            ));
        }
        if acc.sparse().is_some() || acc.view().is_none() {
            // Exact for any count up to 2^24, which sparse index data never exceeds in practice.
            let f = self.floats::<1>(acc, "indices")?;
            return Ok(f.into_iter().map(|[v]| v as u32).collect());
        }
        let size = type_size(acc.data_type());
        let view = acc
            .view()
            .ok_or_else(|| bad(self.path, format!("{what} have no buffer view")))?;
        let (data, stride) = self.view_slice(&view, acc.offset(), acc.count(), size, &what)?;
        Ok((0..acc.count())
            .map(|i| {
                let b = &data[i * stride..];
                match size {
                    1 => b[0] as u32,
                    2 => u16::from_le_bytes([b[0], b[1]]) as u32,
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                }
            })
            .collect())
    }
}

/// `EXT_mesh_gpu_instancing`: the node's mesh is drawn once per instance, each placed by its
/// translation, rotation and scale within the node. gltfpack's `-mi` and Blender write it for
/// repeated objects (pews, pillars); without reading it, every such object was missing but
/// one. Returns each instance's world transform; a node without instances is drawn once, at
/// `world`, as is one whose instances carry none of the three (only ids, say).
fn instances(
    ctx: &Ctx,
    document: &gltf::Document,
    node: &gltf::Node,
    world: World,
) -> Result<Vec<World>, CookError> {
    let Some(ext) = node.extension_value("EXT_mesh_gpu_instancing") else {
        return Ok(vec![world]);
    };
    let fail = |m: String| {
        bad(
            ctx.path,
            format!("node {} (EXT_mesh_gpu_instancing): {m}", node.index()),
        )
    };
    let attributes = ext
        .get("attributes")
        .and_then(serde_json::Value::as_object)
        .ok_or_else(|| fail("no `attributes` object".into()))?;
    let accessor = |name: &str| -> Result<Option<gltf::Accessor>, CookError> {
        let Some(v) = attributes.get(name) else {
            return Ok(None);
        };
        let i = v
            .as_u64()
            .ok_or_else(|| fail(format!("{name} is {v}, not an accessor index")))?;
        let i = usize::try_from(i).unwrap_or(usize::MAX);
        let a = document
            .accessors()
            .nth(i)
            .ok_or_else(|| fail(format!("{name} accessor {i} does not exist")))?;
        if a.count() > MAX_INSTANCES {
            return Err(fail(format!(
                "{name} holds {} instances, more than the {MAX_INSTANCES} the cooker places",
                a.count()
            )));
        }
        Ok(Some(a))
    };
    let t = match accessor("TRANSLATION")? {
        Some(a) => Some(ctx.floats::<3>(&a, "instance TRANSLATION")?),
        None => None,
    };
    let r = match accessor("ROTATION")? {
        Some(a) => Some(ctx.floats::<4>(&a, "instance ROTATION")?),
        None => None,
    };
    let s = match accessor("SCALE")? {
        Some(a) => Some(ctx.floats::<3>(&a, "instance SCALE")?),
        None => None,
    };
    let counts = [
        t.as_ref().map(Vec::len),
        r.as_ref().map(Vec::len),
        s.as_ref().map(Vec::len),
    ];
    let Some(n) = counts.iter().flatten().copied().next() else {
        return Ok(vec![world]);
    };
    if counts.iter().flatten().any(|&c| c != n) {
        return Err(fail(format!(
            "TRANSLATION, ROTATION and SCALE have different counts ({counts:?})"
        )));
    }
    (0..n)
        .map(|i| {
            let tr = t
                .as_ref()
                .map_or(glam::Vec3::ZERO, |t| glam::Vec3::from(t[i]));
            // Quantized rotations (normalized shorts) are only nearly unit.
            let q = r.as_ref().map_or(glam::Quat::IDENTITY, |r| {
                glam::Quat::from_array(r[i]).normalize()
            });
            let sc = s
                .as_ref()
                .map_or(glam::Vec3::ONE, |s| glam::Vec3::from(s[i]));
            let exact = glam::DMat4::from_scale_rotation_translation(
                sc.as_dvec3(),
                q.as_dquat(),
                tr.as_dvec3(),
            );
            let placed = world.then(exact);
            if placed.m.is_finite() {
                Ok(placed)
            } else {
                Err(fail(format!(
                    "instance {i} (translation {tr}, rotation {q}, scale {sc}) is not a finite \
                     transform"
                )))
            }
        })
        .collect()
}

/// Poses a primitive as its morph `weights` say: each target's position (and normal)
/// displacements, times its weight, added to the base. glTF shows a mesh with weights so at
/// rest; a file that set them (a pillar raised by its target) was cooked unmorphed, silently.
/// Normals are made unit length again where the mesh stage reads them.
fn morph(
    ctx: &Ctx,
    label: &str,
    prim: &gltf::Primitive,
    weights: &[f32],
    positions: &mut [[f32; 3]],
    mut normals: Option<&mut (Vec<[f32; 3]>, usize)>,
) -> Result<(), CookError> {
    for (k, target) in prim.morph_targets().enumerate() {
        let w = weights.get(k).copied().unwrap_or(0.0);
        if !w.is_finite() {
            return Err(bad(
                ctx.path,
                format!("{label}: morph target {k}'s weight is {w}"),
            ));
        }
        if w == 0.0 {
            continue;
        }
        let add = |acc: gltf::Accessor, what: &str, base: &mut [[f32; 3]]| {
            let what = format!("morph target {k} {what}");
            // Counted before it is read: a sparse accessor of no bytes may claim 2^28.
            if acc.count() != base.len() {
                return Err(bad(
                    ctx.path,
                    format!(
                        "{label}: {what} has {} elements but POSITION has {}",
                        acc.count(),
                        base.len()
                    ),
                ));
            }
            let d = ctx.attribute::<3>(None, label, &acc, &what)?;
            if d.len() != base.len() {
                return Err(bad(
                    ctx.path,
                    format!(
                        "{label}: {what} has {} elements but POSITION has {}",
                        d.len(),
                        base.len()
                    ),
                ));
            }
            for (b, d) in base.iter_mut().zip(d) {
                for c in 0..3 {
                    b[c] += w * d[c];
                }
            }
            Ok(())
        };
        if let Some(a) = target.positions() {
            add(a, "POSITION", positions)?;
        }
        if let (Some(a), Some((n, _))) = (target.normals(), normals.as_deref_mut()) {
            add(a, "NORMAL", n)?;
        }
    }
    Ok(())
}

/// Each joint's matrix for a skin at rest: the joint node's world transform ([`all_worlds`])
/// times its inverse bind matrix (identity where the skin gives none).
fn joint_matrices(
    ctx: &Ctx,
    skin: &gltf::Skin,
    worlds: &[glam::DMat4],
) -> Result<std::rc::Rc<Vec<glam::DMat4>>, CookError> {
    let fail = |m: String| bad(ctx.path, format!("skin {}: {m}", skin.index()));
    let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
    let inverse_bind: Vec<glam::DMat4> = match skin.inverse_bind_matrices() {
        // Counted before it is read: a sparse accessor of no bytes may claim 2^28 matrices.
        Some(a) if a.count() != joints.len() => {
            return Err(fail(format!(
                "{} inverse bind matrices for {} joints",
                a.count(),
                joints.len()
            )));
        }
        Some(a) => ctx
            .floats::<16>(&a, "inverseBindMatrices")?
            .into_iter()
            .map(|m| glam::Mat4::from_cols_array(&m).as_dmat4())
            .collect(),
        None => Vec::new(),
    };
    joints
        .iter()
        .enumerate()
        .map(|(j, &node)| {
            let bind = inverse_bind
                .get(j)
                .copied()
                .unwrap_or(glam::DMat4::IDENTITY);
            let m = worlds[node] * bind;
            if m.is_finite() {
                Ok(m)
            } else {
                Err(fail(format!("joint {j}'s matrix is not finite")))
            }
        })
        .collect::<Result<Vec<_>, _>>()
        .map(std::rc::Rc::new)
}

/// A node's transform relative to its parent: [`exact_locals`]'s f64 reading where it has
/// one, else gltf's f32 one.
fn local_transform(node: &gltf::Node, exact: &[Option<glam::DMat4>]) -> glam::DMat4 {
    exact
        .get(node.index())
        .copied()
        .flatten()
        .unwrap_or_else(|| glam::Mat4::from_cols_array_2d(&node.transform().matrix()).as_dmat4())
}

/// A material's name, or `material<index>` for one without (`material0` for the default).
fn material_name(m: &gltf::Material) -> String {
    m.name().map_or_else(
        || format!("material{}", m.index().unwrap_or(0)),
        str::to_string,
    )
}

/// Every node's world transform, chained in f64 down from its root (a node's first parent,
/// where a file shares one; a loop is cut where it closes), each node's once.
fn all_worlds(document: &gltf::Document, exact: &[Option<glam::DMat4>]) -> Vec<glam::DMat4> {
    let nodes: Vec<gltf::Node> = document.nodes().collect();
    let mut parent = vec![None; nodes.len()];
    for n in &nodes {
        for c in n.children() {
            if c.index() != n.index() {
                parent[c.index()].get_or_insert(n.index());
            }
        }
    }
    let mut world: Vec<Option<glam::DMat4>> = vec![None; nodes.len()];
    let mut on_path = vec![false; nodes.len()];
    let mut path = Vec::new();
    for start in 0..nodes.len() {
        // Up to the first node whose world is known (or a root, or a node already on the
        // path: a loop), then down again.
        let mut at = Some(start);
        while let Some(n) = at {
            if world[n].is_some() || on_path[n] {
                break;
            }
            on_path[n] = true;
            path.push(n);
            at = parent[n];
        }
        let mut above = at.and_then(|n| world[n]).unwrap_or(glam::DMat4::IDENTITY);
        for n in path.drain(..).rev() {
            above *= local_transform(&nodes[n], exact);
            world[n] = Some(above);
            on_path[n] = false;
        }
    }
    world
        .into_iter()
        .map(|w| w.unwrap_or(glam::DMat4::IDENTITY))
        .collect()
}

/// Poses a skinned primitive at rest: each vertex by its joints' matrices, blended by its
/// weights (`JOINTS_n`/`WEIGHTS_n`, every set), its normal by the blend's inverse transpose.
/// Weights that do not sum to one are scaled to; a vertex bound to no joint stays where it is.
/// Returns, per vertex, whether its blend mirrors (empty where none does).
fn skin(
    ctx: &Ctx,
    label: &str,
    prim: &gltf::Primitive,
    draco: Option<&super::gltf_draco::Decoded>,
    joints: &[glam::DMat4],
    positions: &mut [[f32; 3]],
    mut normals: Option<&mut (Vec<[f32; 3]>, usize)>,
) -> Result<Vec<bool>, CookError> {
    let mut mirrored = Vec::new();
    let count = positions.len();
    let fail = |m: String| bad(ctx.path, format!("{label}: {m}"));
    let mut sets = Vec::new();
    for set in 0.. {
        match (
            prim.get(&gltf::Semantic::Joints(set)),
            prim.get(&gltf::Semantic::Weights(set)),
        ) {
            (Some(j), Some(w)) => {
                // Counted before they are read (a sparse accessor of no bytes may claim 2^28
                // elements); a Draco stream holds them where it holds the mesh.
                let (jn, wn) = (format!("JOINTS_{set}"), format!("WEIGHTS_{set}"));
                let read = |a: &gltf::Accessor, name: &str| {
                    if draco.is_none() && a.count() != count {
                        return Err(fail(format!(
                            "{name} has {} elements but POSITION has {count}",
                            a.count()
                        )));
                    }
                    let v = ctx.attribute::<4>(draco, label, a, name)?;
                    if v.len() != count {
                        return Err(fail(format!(
                            "{name} has {} elements but POSITION has {count}",
                            v.len()
                        )));
                    }
                    Ok(v)
                };
                sets.push((read(&j, &jn)?, read(&w, &wn)?));
            }
            (None, None) => break,
            _ => {
                return Err(fail(format!(
                    "JOINTS_{set} and WEIGHTS_{set} come in pairs, and one is missing"
                )));
            }
        }
    }
    for (v, p) in positions.iter_mut().enumerate() {
        let mut m = glam::DMat4::ZERO;
        let mut sum = 0.0;
        for (js, ws) in &sets {
            for k in 0..4 {
                let w = ws[v][k] as f64;
                if w == 0.0 {
                    continue;
                }
                let j = js[v][k];
                let joint = (j >= 0.0 && j.fract() == 0.0)
                    .then(|| joints.get(j as usize))
                    .flatten()
                    .ok_or_else(|| {
                        fail(format!(
                            "vertex {v} is bound to joint {j}, but the skin has {}",
                            joints.len()
                        ))
                    })?;
                if !w.is_finite() || w < 0.0 {
                    return Err(fail(format!("vertex {v} has joint weight {w}")));
                }
                m += *joint * w;
                sum += w;
            }
        }
        if sum == 0.0 {
            continue;
        }
        let m = m * (1.0 / sum);
        let at = m.transform_point3(glam::Vec3::from(*p).as_dvec3());
        *p = at.as_vec3().to_array();
        let m3 = glam::DMat3::from_mat4(m);
        let det = m3.determinant();
        if det < 0.0 {
            mirrored.resize(count, false);
            mirrored[v] = true;
        }
        if let Some((n, _)) = normals.as_deref_mut()
            && let Some(n) = n.get_mut(v)
            && det != 0.0
        {
            let turned = m3
                .inverse()
                .transpose()
                .mul_vec3(glam::Vec3::from(*n).as_dvec3());
            *n = turned.as_vec3().to_array();
        }
    }
    Ok(mirrored)
}

/// Instances of one node that get a part each; more share one.
const MAX_INSTANCE_PARTS: usize = 4096;

/// Where a primitive goes: its node's instances, each one's part, and the morph weights.
struct Placed<'a> {
    worlds: &'a [World],
    parts: &'a [u32],
    weights: &'a [f32],
    /// A skinned mesh's joint matrices ([`joint_matrices`]).
    joints: Option<&'a [glam::DMat4]>,
}

fn add_primitive(
    ctx: &Ctx,
    mesh: &gltf::Mesh,
    prim: &gltf::Primitive,
    placed: Placed,
    out: &mut Imported,
    budget: &mut usize,
) -> Result<(), CookError> {
    let Placed {
        worlds,
        parts,
        weights,
        joints,
    } = placed;
    let path = ctx.path;
    let pos_acc = prim
        .get(&gltf::Semantic::Positions)
        .ok_or_else(|| bad(path, "a triangle primitive has no POSITION attribute"))?;
    let stream = |v: &gltf::buffer::View| {
        ctx.view_bytes(v, "Draco stream").map_err(|e| match e {
            CookError::Source { message, .. } => message,
            e => e.to_string(),
        })
    };
    let draco = match ctx.draco.get(mesh.index(), prim, stream, ctx.document) {
        Ok(d) => d,
        // A file may keep an uncompressed copy beside the stream (gltf-pipeline's
        // `--draco.uncompressedFallback`) for loaders without Draco; read that instead.
        Err(m) if has_uncompressed_copy(prim) => {
            out.warnings.push(Warning::new(
                path,
                None,
                format!("{m}; read the uncompressed copy the file also holds"),
            ));
            None
        }
        Err(m) => return Err(bad(path, m)),
    };
    // An attribute the Draco stream holds comes from it (the accessor has no data of its own,
    // or a copy the extension says to ignore); any other from its accessor.
    let label = format!("mesh {} primitive {}", mesh.index(), prim.index());
    let mut positions = ctx.attribute::<3>(draco.as_deref(), &label, &pos_acc, "POSITION")?;
    let mut normals = match prim.get(&gltf::Semantic::Normals) {
        Some(a) => Some((
            ctx.attribute::<3>(draco.as_deref(), &label, &a, "NORMAL")?,
            a.index(),
        )),
        None => None,
    };
    morph(ctx, &label, prim, weights, &mut positions, normals.as_mut())?;
    let mirrored = match joints {
        Some(joints) => skin(
            ctx,
            &label,
            prim,
            draco.as_deref(),
            joints,
            &mut positions,
            normals.as_mut(),
        )?,
        None => Vec::new(),
    };
    if let Some(i) = positions
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite()))
    {
        return Err(bad(
            path,
            format!(
                "POSITION accessor {} element {i} is {:?}: not finite",
                pos_acc.index(),
                positions[i]
            ),
        ));
    }
    let vcount = positions.len();
    let normals = match normals {
        Some((n, index)) => {
            if n.len() != vcount {
                return Err(bad(
                    path,
                    format!(
                        "{label}: NORMAL has {} elements but POSITION has {vcount}",
                        n.len()
                    ),
                ));
            }
            if n.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
                return Err(bad(
                    path,
                    format!("{label}: NORMAL accessor {index} has non-finite values"),
                ));
            }
            Some(n)
        }
        None => None,
    };
    let (set, transform) = base_uvs(&prim.material());
    let uvs = match prim.get(&gltf::Semantic::TexCoords(set)) {
        Some(a) => {
            let t = ctx.attribute::<2>(draco.as_deref(), &label, &a, &format!("TEXCOORD_{set}"))?;
            if t.len() != vcount {
                return Err(bad(
                    path,
                    format!(
                        "TEXCOORD_{set} has {} elements but POSITION has {vcount}",
                        t.len()
                    ),
                ));
            }
            if t.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
                return Err(bad(
                    path,
                    format!(
                        "{label}: TEXCOORD accessor {} has non-finite values",
                        a.index()
                    ),
                ));
            }
            let mut t = t;
            if let Some(tr) = &transform {
                texture_transform(&mut t, tr.offset(), tr.rotation(), tr.scale());
                if t.iter().any(|v| !v.iter().all(|c| c.is_finite())) {
                    return Err(bad(
                        path,
                        format!(
                            "material {:?}: KHR_texture_transform (offset {:?}, rotation {}, \
                             scale {:?}) takes texture coordinates to non-finite values",
                            prim.material().name().unwrap_or(""),
                            tr.offset(),
                            tr.rotation(),
                            tr.scale()
                        ),
                    ));
                }
            }
            Some(t)
        }
        None => None,
    };
    // COLOR_0 (linear, multiplying the base colour), as RGB or RGBA, floats or normalized.
    let colours = match prim.get(&gltf::Semantic::Colors(0)) {
        Some(a) => {
            let c: Vec<[f32; 4]> = match a.dimensions() {
                Dimensions::Vec3 => ctx
                    .attribute::<3>(draco.as_deref(), &label, &a, "COLOR_0")?
                    .into_iter()
                    .map(|[r, g, b]| [r, g, b, 1.0])
                    .collect(),
                _ => ctx.attribute::<4>(draco.as_deref(), &label, &a, "COLOR_0")?,
            };
            if c.len() != vcount {
                return Err(bad(
                    path,
                    format!(
                        "{label}: COLOR_0 has {} elements but POSITION has {vcount}",
                        c.len()
                    ),
                ));
            }
            if let Some(v) = c.iter().find(|v| !v.iter().all(|x| x.is_finite())) {
                return Err(bad(
                    path,
                    format!(
                        "{label}: COLOR_0 accessor {} holds {v:?}: not finite",
                        a.index()
                    ),
                ));
            }
            Some(c)
        }
        None => None,
    };
    let indices: Vec<u32> = match (&draco, prim.indices()) {
        (Some(d), _) => {
            if d.points != vcount {
                return Err(bad(
                    path,
                    format!(
                        "{label}: the Draco stream has {} points but POSITION has {vcount}",
                        d.points
                    ),
                ));
            }
            d.corners.clone()
        }
        (None, Some(a)) => ctx.indices(&a)?,
        (None, None) => (0..vcount as u32).collect(),
    };
    if let Some((k, &i)) = indices
        .iter()
        .enumerate()
        .find(|&(_, &i)| i as usize >= vcount)
    {
        return Err(bad(
            path,
            format!("{label}: index {k} is {i}, out of range for a primitive of {vcount} vertices"),
        ));
    }
    // Each triangle's corners, three indices a triangle: a list's own indices, strips and
    // fans unrolled (Draco's faces are a list whatever the mode).
    let mode = if draco.is_some() {
        Mode::Triangles
    } else {
        prim.mode()
    };
    let mut corners: Vec<u32> = match mode {
        Mode::TriangleStrip => (2..indices.len())
            .flat_map(|i| {
                if i % 2 == 0 {
                    [indices[i - 2], indices[i - 1], indices[i]]
                } else {
                    [indices[i - 1], indices[i - 2], indices[i]]
                }
            })
            .collect(),
        Mode::TriangleFan => (2..indices.len())
            .flat_map(|i| [indices[0], indices[i - 1], indices[i]])
            .collect(),
        _ => {
            if !indices.len().is_multiple_of(3) {
                out.warnings.push(Warning::new(
                    path,
                    None,
                    format!(
                        "{label}: {} {} is not a multiple of 3; the last {} ignored",
                        indices.len(),
                        if prim.indices().is_some() {
                            "indices"
                        } else {
                            "vertices (no indices)"
                        },
                        indices.len() % 3
                    ),
                ));
            }
            let mut list = indices;
            list.truncate(list.len() / 3 * 3);
            list
        }
    };

    // A triangle a mirroring joint blend turns inside out keeps facing out, as one under a
    // mirroring node does: by the most of its corners.
    if !mirrored.is_empty() {
        for t in corners.as_chunks_mut::<3>().0 {
            if t.iter().filter(|&&v| mirrored[v as usize]).count() >= 2 {
                t.swap(1, 2);
            }
        }
    }
    let total = vcount.saturating_mul(worlds.len());
    if worlds.len() > 1 {
        let need = (vcount + corners.len()).saturating_mul(worlds.len());
        if need > *budget {
            return Err(bad(
                path,
                format!(
                    "EXT_mesh_gpu_instancing places {} copies of a primitive of {vcount} \
                     vertices and {} corners: past the {MAX_INSTANCED} vertices and corners \
                     the cooker expands in one file",
                    worlds.len(),
                    corners.len()
                ),
            ));
        }
        *budget -= need;
    }
    if out.positions.len().saturating_add(total) >= NONE as usize {
        return Err(bad(path, "more than 2^32 vertices"));
    }
    let placements: Vec<(World, u32)> = worlds.iter().copied().zip(parts.iter().copied()).collect();
    let Some((&(last, last_part), rest)) = placements.split_last() else {
        return Ok(());
    };
    for &(world, part) in rest {
        let copy = Attributes {
            positions: positions.clone(),
            normals: normals.clone(),
            uvs: uvs.clone(),
            colours: colours.clone(),
            corners: corners.clone(),
        };
        place(out, world, part, copy);
    }
    place(
        out,
        last,
        last_part,
        Attributes {
            positions,
            normals,
            uvs,
            colours,
            corners,
        },
    );
    Ok(())
}

/// Whether every accessor of the primitive has data of its own, as an uncompressed copy
/// beside a Draco stream does.
fn has_uncompressed_copy(prim: &gltf::Primitive) -> bool {
    let viewed = |a: gltf::Accessor| a.view().is_some() || a.sparse().is_some();
    prim.attributes().all(|(_, a)| viewed(a)) && prim.indices().is_none_or(viewed)
}

/// The most vertices and corners instancing may expand to in one file, and the most instances
/// of one node: instancing multiplies what a file holds, so a small hostile file could
/// otherwise ask for any amount of memory.
const MAX_INSTANCED: usize = 1 << 27;
const MAX_INSTANCES: usize = 1 << 20;

/// One primitive's vertex data as read, before it is placed in the world.
struct Attributes {
    positions: Vec<[f32; 3]>,
    normals: Option<Vec<[f32; 3]>>,
    uvs: Option<Vec<[f32; 2]>>,
    colours: Option<Vec<[f32; 4]>>,
    corners: Vec<u32>,
}

/// Appends a primitive's data placed by `world` to `out`. The first vertex placed decides
/// whether the model lies in survey coordinates, as an OBJ's first vertex does.
fn place(out: &mut Imported, world: World, part: u32, a: Attributes) {
    let Attributes {
        mut positions,
        normals,
        uvs,
        colours,
        mut corners,
    } = a;
    // Parallel to the positions once any primitive has them: white for those without.
    match colours {
        Some(c) => {
            out.colours.resize(out.positions.len(), [1.0; 4]);
            append(&mut out.colours, c);
        }
        None if !out.colours.is_empty() => {
            out.colours
                .resize(out.positions.len() + positions.len(), [1.0; 4]);
        }
        None => {}
    }
    let base_p = out.positions.len() as u32;
    let base_n = out.normals.len() as u32;
    let base_t = out.uvs.len() as u32;
    let (has_normals, has_uvs) = (normals.is_some(), uvs.is_some());
    if out.positions.is_empty()
        && let Some(first) = positions.first()
        && let Some(origin) = super::survey_origin(
            world
                .exact
                .transform_point3(first.map(f64::from).into())
                .into(),
        )
    {
        out.origin = origin;
    }
    // Transformed where they were read, and taken whole by the first primitive: a copy of
    // each array beside it was the large mesh's import peak.
    if out.origin == [0.0; 3] {
        for p in &mut positions {
            *p = world.m.transform_point3(glam::Vec3::from(*p)).to_array();
        }
    } else {
        let origin = glam::DVec3::from(out.origin);
        for p in &mut positions {
            let placed = world.exact.transform_point3(p.map(f64::from).into());
            *p = (placed - origin).as_vec3().to_array();
        }
    }
    let world = world.m;
    append(&mut out.positions, positions);
    if let Some(mut n) = normals {
        let nm = glam::Mat3::from_mat4(world).inverse().transpose();
        for v in &mut n {
            *v = (nm * glam::Vec3::from(*v)).normalize_or_zero().to_array();
        }
        append(&mut out.normals, n);
    }
    if let Some(t) = uvs {
        append(&mut out.uvs, t);
    }
    let mirror = glam::Mat3::from_mat4(world).determinant() < 0.0;
    for t in corners.as_chunks_mut::<3>().0 {
        if mirror {
            t.swap(1, 2);
        }
        for i in t {
            *i += base_p;
        }
    }
    let triangles = corners.len() / 3;
    // The indices become the corners' position indices in place (the whole array for the
    // first primitive); the other fields follow them.
    out.corners.append_shared(
        corners,
        base_p,
        has_uvs.then_some(base_t),
        has_normals.then_some(base_n),
    );
    out.tri_part.resize(out.tri_part.len() + triangles, part);
}

/// `KHR_texture_transform` applied to texture coordinates, as the extension defines it:
/// scale, then rotate by `rotation` radians (counter-clockwise in UV space), then offset. The
/// base colour texture's transform is applied where the coordinates are read, so the design,
/// its mips and its projector see the coordinates a glTF viewer samples with; Blender writes
/// it for a Mapping node, and without it a window's design sat scaled and shifted.
fn texture_transform(uvs: &mut [[f32; 2]], offset: [f32; 2], rotation: f32, scale: [f32; 2]) {
    let (s, c) = rotation.sin_cos();
    for uv in uvs {
        let (x, y) = (uv[0] * scale[0], uv[1] * scale[1]);
        *uv = [c * x + s * y + offset[0], -s * x + c * y + offset[1]];
    }
}

/// The `file:` scheme's path of a URI that has one.
fn file_uri_path(uri: &str) -> Option<&str> {
    uri.strip_prefix("file://localhost/")
        .map(|rest| &uri[uri.len() - rest.len() - 1..])
        .or_else(|| uri.strip_prefix("file://"))
        .or_else(|| uri.strip_prefix("file:"))
}

/// The name [`external_file`] looks for with `locate`, for a file that is not found.
fn uri_name(uri: &str) -> String {
    percent_decode(file_uri_path(uri).unwrap_or(uri))
}

/// The file a relative uri names beside the glTF, as written or percent-decoded (exporters
/// do both), or a `file:` uri's path (some exporters write absolute ones). Buffers and images
/// are found the same way.
/// Each lookup whose answer could change is noted in `noted` (see `import::Absent`).
fn external_file(
    base: &Path,
    uri: &str,
    noted: &mut Vec<super::Absent>,
) -> Option<std::path::PathBuf> {
    let decoded = uri_name(uri);
    // A name with `%` in it written as is, not percent-encoded as URIs should be: read where
    // no file has the decoded name exactly, before any looser match of it (another case, a
    // path's end), since the file the uri spells is there. A file of the literal name beside
    // the decoded one (a pack cooked to `-o my%20tex.png`, say) does not hide it.
    if file_uri_path(uri).is_none()
        && uri.contains('%')
        && !base.join(super::text::path_of(&decoded)).is_file()
    {
        let as_written = base.join(uri);
        if as_written.is_file() {
            noted.push(super::Absent::new(base, &decoded));
            return Some(as_written);
        }
        noted.push(super::Absent::new(base, uri));
    }
    // The percent-decoded name, as a URI means it, then as Windows exporters mean it; an
    // absolute `file:///C:/...` from the exporting machine has its end looked for beside the
    // glTF.
    super::locate_noted(base, &decoded, noted)
}

fn percent_decode(s: &str) -> String {
    let b = s.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%'
            && i + 2 < b.len()
            && let Ok(v) =
                u8::from_str_radix(std::str::from_utf8(&b[i + 1..i + 3]).unwrap_or("zz"), 16)
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    // A name percent-encoded from a Windows code page is not UTF-8: kept as its bytes, which
    // is what the file is named on disk.
    super::text::escaped(&out).into_owned()
}

/// The bytes of a base64 `data:` URI (what glTF exporters embed). Anything else, or a payload
/// that does not decode, is an error naming the file: the texture was meant to be there.
fn decode_data_uri(path: &Path, name: &str, uri: &str) -> Result<Vec<u8>, CookError> {
    let rest = uri.strip_prefix("data:").unwrap_or(uri);
    let Some((header, payload)) = rest.split_once(',') else {
        return Err(bad(
            path,
            format!("image {name}: data URI has no ',' before its data"),
        ));
    };
    if !header
        .split(';')
        .any(|p| p.trim().eq_ignore_ascii_case("base64"))
    {
        return Err(bad(
            path,
            format!(
                "image {name}: data URI {header:?} is not base64; only base64 data URIs are \
                 supported"
            ),
        ));
    }
    // The decoded size is known before decoding: refuse what the image decoder would refuse
    // anyway, before allocating it.
    let decoded = payload.len() / 4 * 3;
    if decoded as u64 > texture::MAX_DECODE_BYTES {
        return Err(bad(
            path,
            format!(
                "image {name}: data URI holds about {decoded} bytes, over the limit of {}",
                texture::MAX_DECODE_BYTES
            ),
        ));
    }
    let bytes = base64::decode(payload.trim()).map_err(|e| {
        bad(
            path,
            format!("image {name}: malformed base64 in data URI: {e}"),
        )
    })?;
    if bytes.is_empty() {
        return Err(bad(path, format!("image {name}: data URI is empty")));
    }
    Ok(bytes)
}

/// The image a texture samples: its `EXT_texture_webp` source where it has one (the texture
/// stage decodes WebP like PNG, and a file that requires the extension gives no other), else
/// its plain `source`, else its `KHR_texture_basisu` or `MSFT_texture_dds` source. Basis and
/// BC blocks are lossy (ETC1S blocks carry few colours), so where the file keeps a PNG or JPEG
/// fallback the cook reads that; a file that requires the extension has only the KTX2 or DDS.
fn texture_ref(
    ctx: &Ctx,
    texture: &gltf::Texture,
    warnings: &mut Vec<Warning>,
    absent: &mut Vec<super::Absent>,
) -> Result<Option<ImageRef>, CookError> {
    let extension_source = |name: &str| {
        let index = texture.extension_value(name)?.get("source")?.as_u64()?;
        ctx.document.images().nth(usize::try_from(index).ok()?)
    };
    let image = extension_source("EXT_texture_webp")
        .or_else(|| texture.source())
        .or_else(|| extension_source("KHR_texture_basisu"))
        .or_else(|| extension_source("MSFT_texture_dds"));
    match image {
        Some(image) => image_ref(ctx, image, warnings, absent),
        None => {
            warnings.push(Warning::new(
                ctx.path,
                None,
                format!(
                    "texture {} names no image it can be read from; texture ignored",
                    texture.index()
                ),
            ));
            Ok(None)
        }
    }
}

fn image_ref(
    ctx: &Ctx,
    image: gltf::Image,
    warnings: &mut Vec<Warning>,
    absent: &mut Vec<super::Absent>,
) -> Result<Option<ImageRef>, CookError> {
    let name = image
        .name()
        .map(str::to_string)
        .unwrap_or_else(|| format!("image{}", image.index()));
    Ok(match image.source() {
        gltf::image::Source::View { view, .. } => {
            match ctx.view_slice(&view, 0, view.length(), 1, &format!("image {name}")) {
                Ok((bytes, _)) => Some(ImageRef::Embedded {
                    name: format!("{}#{name}", ctx.path.display()),
                    bytes: Arc::new(bytes.to_vec()),
                }),
                Err(e) => {
                    warnings.push(Warning::new(
                        ctx.path,
                        None,
                        format!("{e}; texture ignored"),
                    ));
                    None
                }
            }
        }
        gltf::image::Source::Uri { uri, .. } => {
            if uri.starts_with("data:") {
                let bytes = decode_data_uri(ctx.path, &name, uri)?;
                return Ok(Some(ImageRef::Embedded {
                    name: format!("{}#{name}", ctx.path.display()),
                    bytes: Arc::new(bytes),
                }));
            }
            let dir = ctx.path.parent().unwrap_or(Path::new(""));
            match external_file(dir, uri, absent) {
                Some(p) => Some(ImageRef::File(p)),
                None => {
                    warnings.push(Warning::new(
                        ctx.path,
                        None,
                        format!("image {uri:?} not found; texture ignored"),
                    ));
                    None
                }
            }
        }
    })
}

/// Glass in glTF: `KHR_materials_transmission` (its colour is the base colour, tinted by
/// `KHR_materials_volume`'s attenuation colour) or an alpha-blended material that lets light
/// through: a base colour alpha below 1, or a colour texture, whose alpha may. Blender and
/// Sketchfab exports mark opaque stone and floors `BLEND` too (alpha 1, no texture); taken
/// as glass they became windows and the floor went missing.
fn gltf_transmission(m: &gltf::Material) -> super::Transmission {
    let base = base_colour(m);
    let factor = m.transmission().map(|t| t.transmission_factor());
    let blend = m.alpha_mode() == gltf::material::AlphaMode::Blend
        && (base[3] < 0.999 || colour_texture(m).is_some());
    let attenuation = m.volume().map(|v| v.attenuation_color());
    let filter = (factor.is_some_and(|f| f > 0.0) || blend).then(|| {
        let a = attenuation.unwrap_or([1.0; 3]);
        [0, 1, 2].map(|k| (base[k] * a[k]).clamp(0.0, 1.0))
    });
    super::Transmission {
        filter,
        opacity: blend.then_some(base[3].clamp(0.0, 1.0)),
        illum: None,
        factor,
        blend,
    }
}

/// A material's colour: `KHR_materials_pbrSpecularGlossiness`'s diffuse where it has it (older
/// exporters, 3ds Max and Babylon among them, wrote only that, leaving the metallic-roughness
/// colour white), else the base colour.
fn base_colour(m: &gltf::Material) -> [f32; 4] {
    match m.pbr_specular_glossiness() {
        Some(sg) => sg.diffuse_factor(),
        None => m.pbr_metallic_roughness().base_color_factor(),
    }
}

/// The texture of [`base_colour`].
fn colour_texture<'a>(m: &gltf::Material<'a>) -> Option<gltf::texture::Info<'a>> {
    match m.pbr_specular_glossiness() {
        Some(sg) => sg.diffuse_texture(),
        None => m.pbr_metallic_roughness().base_color_texture(),
    }
}

/// The texture coordinates a material's vertices keep: the set its base colour reads (0 without
/// one) and the transform that places the texture on them.
fn base_uvs<'a>(m: &gltf::Material<'a>) -> (u32, Option<gltf::texture::TextureTransform<'a>>) {
    let base = colour_texture(m);
    let transform = base.as_ref().and_then(|t| t.texture_transform());
    let set = transform
        .as_ref()
        .and_then(|t| t.tex_coord())
        .or(base.as_ref().map(|t| t.tex_coord()))
        .unwrap_or(0);
    (set, transform)
}

/// Where a material's normal map is not placed as its base colour is (another `texCoord`
/// set, another `KHR_texture_transform`), what differs. The import keeps one set of texture
/// coordinates per vertex, the base colour's, placed by its transform.
fn normal_uvs_differ(m: &gltf::Material) -> Option<String> {
    let normal = m.normal_texture()?;
    let (base_set, base_tr) = base_uvs(m);
    let base_place = base_tr.map_or(([0.0, 0.0], 0.0, [1.0, 1.0]), |t| {
        (t.offset(), t.rotation(), t.scale())
    });
    let tr = normal.extension_value("KHR_texture_transform");
    let field = |k: &str| tr.and_then(|t| t.get(k));
    let pair = |k: &str, default: [f32; 2]| {
        field(k)
            .and_then(|v| v.as_array())
            .and_then(|a| Some([a.first()?.as_f64()? as f32, a.get(1)?.as_f64()? as f32]))
            .unwrap_or(default)
    };
    let set = field("texCoord")
        .and_then(|v| v.as_u64())
        .unwrap_or(u64::from(normal.tex_coord()));
    let place = (
        pair("offset", [0.0, 0.0]),
        field("rotation").and_then(|v| v.as_f64()).unwrap_or(0.0) as f32,
        pair("scale", [1.0, 1.0]),
    );
    if set != u64::from(base_set) {
        Some(format!(
            "reads TEXCOORD_{set}, its base colour TEXCOORD_{base_set}"
        ))
    } else if place != base_place {
        Some("has another KHR_texture_transform than its base colour".to_string())
    } else {
        None
    }
}

fn convert_material(
    ctx: &Ctx,
    m: &gltf::Material,
    warnings: &mut Vec<Warning>,
    absent: &mut Vec<super::Absent>,
) -> Result<SourceMaterial, CookError> {
    let pbr = m.pbr_metallic_roughness();
    let base = base_colour(m);
    let (diffuse, specular, rough) = match m.pbr_specular_glossiness() {
        Some(sg) => (
            [base[0], base[1], base[2]],
            sg.specular_factor(),
            (1.0 - sg.glossiness_factor()).clamp(0.02, 1.0),
        ),
        None => {
            let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
            let rough = pbr.roughness_factor().clamp(0.02, 1.0);
            // The viewer lights with lamps and an even ambient, with no surroundings for a
            // metal to reflect: glTF's defaults (metallic 1, roughness 1, which a file that
            // gives only a base colour gets) made it black but for a highlight, its texture
            // unseen. A rough metal spreads its reflection as widely as a diffuse surface
            // does: that part (roughness² of it, all of it at roughness 1) is kept as diffuse
            // in the base colour, the rest stays specular.
            let scattered = metallic * rough * rough;
            (
                [0, 1, 2].map(|k| base[k] * (1.0 - metallic + scattered)),
                [0, 1, 2].map(|k| 0.04 * (1.0 - metallic) + base[k] * (metallic - scattered)),
                rough,
            )
        }
    };
    // Blinn-Phong exponent of the same lobe width as a GGX roughness (alpha = roughness²).
    let a = rough * rough;
    let shininess = (2.0 / (a * a) - 2.0).clamp(1.0, 2048.0);
    let sm = SourceMaterial {
        name: material_name(m),
        diffuse,
        specular,
        shininess,
        // Blender writes a strength above 1 as this extension, the factor kept within 0..1.
        emissive: m
            .emissive_factor()
            .map(|c| c * m.emissive_strength().unwrap_or(1.0)),
        diffuse_texture: match colour_texture(m) {
            Some(t) => texture_ref(ctx, &t.texture(), warnings, absent)?,
            None => None,
        },
        normal_texture: match m.normal_texture() {
            Some(t) => texture_ref(ctx, &t.texture(), warnings, absent)?,
            None => None,
        },
        normal_scale: m
            .normal_texture()
            .map(|t| t.scale())
            .filter(|s| s.is_finite())
            .unwrap_or(1.0),
        transmission: gltf_transmission(m),
    };
    if m.emissive_strength().is_some_and(|s| s.is_nan() || s < 0.0) {
        return Err(bad(
            ctx.path,
            format!(
                "material {:?}: KHR_materials_emissive_strength's emissiveStrength is {}, \
                 not zero or more",
                sm.name,
                m.emissive_strength().unwrap_or_default()
            ),
        ));
    }
    if !sm
        .diffuse
        .iter()
        .chain(&sm.specular)
        .chain(&sm.emissive)
        .all(|v| v.is_finite())
    {
        return Err(bad(
            ctx.path,
            format!("material {:?} has non-finite factors", sm.name),
        ));
    }
    if sm.normal_texture.is_some()
        && let Some(why) = normal_uvs_differ(m)
    {
        warnings.push(Warning::new(
            ctx.path,
            None,
            format!(
                "material {:?}: its normal map {why}; a pack holds one set of texture \
                 coordinates, the base colour's, so the normal map is sampled with them",
                sm.name
            ),
        ));
    }
    Ok(sm)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A uri percent-encoding a windows-1250 name ("okno_č.png", `%E8` for `č`) finds the file
    /// named by those bytes, as an archive from a Windows machine unpacks it.
    #[cfg(unix)]
    #[test]
    fn percent_encoded_code_page_names_find_their_file() {
        use std::os::unix::ffi::OsStringExt;
        let dir = tempfile::tempdir().unwrap();
        let raw = std::ffi::OsString::from_vec(b"okno_\xE8.png".to_vec());
        std::fs::write(dir.path().join(&raw), b"x").unwrap();
        assert_eq!(
            external_file(dir.path(), "okno_%E8.png", &mut Vec::new()),
            Some(dir.path().join(&raw))
        );
        assert_eq!(
            external_file(dir.path(), "OKNO_%E8.PNG", &mut Vec::new()),
            Some(dir.path().join(&raw))
        );
        assert_eq!(
            external_file(dir.path(), "okno_%E9.png", &mut Vec::new()),
            None
        );
    }

    #[test]
    fn texture_transform_scales_rotates_then_offsets() {
        let mut uv = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [0.25, 0.5]];
        texture_transform(&mut uv, [0.5, 0.0], 0.0, [2.0, 2.0]);
        assert_eq!(uv, [[0.5, 0.0], [2.5, 0.0], [0.5, 2.0], [1.0, 1.0]]);
        // A quarter turn counter-clockwise in UV space takes +u to -v.
        let mut uv = [[1.0, 0.0], [0.0, 1.0]];
        texture_transform(&mut uv, [0.0, 0.0], std::f32::consts::FRAC_PI_2, [1.0, 1.0]);
        for (got, want) in uv.iter().zip([[0.0, -1.0], [1.0, 0.0]]) {
            assert!((got[0] - want[0]).abs() < 1e-6 && (got[1] - want[1]).abs() < 1e-6);
        }
    }

    /// A glass quad whose base colour texture carries `KHR_texture_transform` (listed in
    /// `extensionsRequired`, as Blender writes it) imports with the transformed coordinates,
    /// from the texture coordinate set the transform names.
    #[test]
    fn gltf_texture_transform_is_applied_to_the_coordinates_read() {
        let dir = tempfile::tempdir().unwrap();
        let pos: [[f32; 3]; 4] = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.]];
        let uv0: [[f32; 2]; 4] = [[9., 9.]; 4];
        let uv1: [[f32; 2]; 4] = [[0., 1.], [1., 1.], [1., 0.], [0., 0.]];
        let idx: [u32; 6] = [0, 1, 2, 0, 2, 3];
        let mut bin: Vec<u8> = Vec::new();
        bin.extend(pos.iter().flatten().flat_map(|f| f.to_le_bytes()));
        bin.extend(uv0.iter().flatten().flat_map(|f| f.to_le_bytes()));
        bin.extend(uv1.iter().flatten().flat_map(|f| f.to_le_bytes()));
        bin.extend(idx.iter().flat_map(|i| i.to_le_bytes()));
        std::fs::write(dir.path().join("q.bin"), &bin).unwrap();
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}},
            "extensionsUsed": ["KHR_texture_transform"],
            "extensionsRequired": ["KHR_texture_transform"],
            "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1,
                "TEXCOORD_1": 2}}, "indices": 3, "material": 0}}]}}],
            "materials": [{{"name": "vitrail", "pbrMetallicRoughness": {{"baseColorTexture":
                {{"index": 0, "extensions": {{"KHR_texture_transform": {{"offset": [0.5, 0.0],
                "scale": [2.0, 3.0], "texCoord": 1}}}}}}}}}}],
            "textures": [{{"source": 0}}], "images": [{{"uri": "design.png"}}],
            "accessors": [
                {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
                  "min": [0, 0, 0], "max": [1, 1, 0]}},
                {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
                {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"}},
                {{"bufferView": 3, "componentType": 5125, "count": 6, "type": "SCALAR"}}],
            "bufferViews": [
                {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
                {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
                {{"buffer": 0, "byteOffset": 80, "byteLength": 32}},
                {{"buffer": 0, "byteOffset": 112, "byteLength": 24}}],
            "buffers": [{{"byteLength": {}, "uri": "q.bin"}}]}}"#,
            bin.len()
        );
        let path = dir.path().join("q.gltf");
        std::fs::write(&path, json).unwrap();
        let imported = import(&path).unwrap();
        let want: Vec<[f32; 2]> = uv1.iter().map(|t| [t[0] * 2.0 + 0.5, t[1] * 3.0]).collect();
        assert_eq!(imported.uvs, want);
    }

    fn third_party(rel: &str) -> std::path::PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/third_party")
            .join(rel)
    }

    /// A triangle's corners: position, normal and texture coordinates.
    type Triangle = [([f32; 3], [f32; 3], [f32; 2]); 3];

    /// Each triangle's corners in world space, normal and texture coordinates where present,
    /// turned to start at its least position (the winding kept): meshopt's triangle codec may
    /// turn a triangle's corners.
    fn corners(m: &Imported) -> Vec<Triangle> {
        (0..m.tri_part.len())
            .map(|t| {
                let mut c: [_; 3] = std::array::from_fn(|k| {
                    let c = m.corners.get(t * 3 + k);
                    let n = m.normals.get(c.n as usize).copied().unwrap_or_default();
                    let uv = m.uvs.get(c.t as usize).copied().unwrap_or_default();
                    (m.positions[c.p as usize], n, uv)
                });
                let least = (0..3)
                    .min_by(|&a, &b| c[a].0.partial_cmp(&c[b].0).unwrap())
                    .unwrap();
                c.rotate_left(least);
                c
            })
            .collect()
    }

    /// The largest distance from a corner of a triangle of `a` to the nearest corner of the
    /// nearest triangle of `b`, and the same corners' normal and texture coordinate gaps:
    /// order-free, since gltfpack's `-cc` reorders for compression.
    fn gap(a: &Imported, b: &Imported) -> [f32; 3] {
        let (ta, tb) = (corners(a), corners(b));
        assert_eq!(ta.len(), tb.len(), "triangle counts differ");
        let d3 = |x: [f32; 3], y: [f32; 3]| glam::Vec3::from(x).distance(glam::Vec3::from(y));
        let centre = |t: &Triangle| {
            (t.iter().map(|c| glam::Vec3::from(c.0)).sum::<glam::Vec3>() / 3.0).to_array()
        };
        let mut worst = [0.0f32; 3];
        for t in &ta {
            let near = tb
                .iter()
                .min_by(|u, v| d3(centre(t), centre(u)).total_cmp(&d3(centre(t), centre(v))))
                .unwrap();
            for c in t {
                let m = near
                    .iter()
                    .min_by(|u, v| d3(c.0, u.0).total_cmp(&d3(c.0, v.0)))
                    .unwrap();
                worst[0] = worst[0].max(d3(c.0, m.0));
                worst[1] = worst[1].max(d3(c.1, m.1));
                worst[2] = worst[2].max(glam::Vec2::from(c.2).distance(glam::Vec2::from(m.2)));
            }
        }
        worst
    }

    /// A chain of 10,000 nodes, each moving the next by 1/1000 along x, places the leaf's
    /// triangle 10 units along, to f32's precision there (256 levels were refused, and
    /// gltfpack reads this; chained in f32 it was 4e-4 off). A chain that closes on itself
    /// is still refused, by the path outgrowing the nodes.
    #[test]
    fn deep_node_chains_import_and_cycles_do_not() {
        let dir = tempfile::tempdir().unwrap();
        let pos: [[f32; 3]; 3] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]];
        let bin: Vec<u8> = pos.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        std::fs::write(dir.path().join("t.bin"), &bin).unwrap();
        let chain = |n: usize, close: bool| {
            let nodes: Vec<String> = (0..n)
                .map(|i| match (i + 1 < n, close) {
                    (true, _) => format!(
                        r#"{{"translation": [0.001, 0, 0], "children": [{}]}}"#,
                        i + 1
                    ),
                    (false, false) => r#"{"translation": [0.001, 0, 0], "mesh": 0}"#.into(),
                    (false, true) => r#"{"mesh": 0, "children": [0]}"#.into(),
                })
                .collect();
            format!(
                r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
                "nodes": [{}],
                "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
                "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3,
                    "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
                "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
                "buffers": [{{"byteLength": 36, "uri": "t.bin"}}]}}"#,
                nodes.join(",")
            )
        };
        let deep = dir.path().join("deep.gltf");
        std::fs::write(&deep, chain(10_000, false)).unwrap();
        let m = import(&deep).unwrap();
        let (lo, hi) = bounds(&m);
        assert!(
            (lo.x - 10.0).abs() < 2e-6 && (hi.x - 11.0).abs() < 2e-6,
            "{lo} {hi}"
        );
        let cyclic = dir.path().join("cyclic.gltf");
        std::fs::write(&cyclic, chain(300, true)).unwrap();
        let e = import(&cyclic).unwrap_err().to_string();
        assert!(e.contains("node hierarchy is cyclic"), "{e}");
        // Without a scene, a loop has no root to be found from: refused, not dropped.
        let sceneless = chain(3, true).replace(r#""scene": 0, "scenes": [{"nodes": [0]}],"#, "");
        assert!(!sceneless.contains("scenes"));
        std::fs::write(&cyclic, sceneless).unwrap();
        let e = import(&cyclic).unwrap_err().to_string();
        assert!(e.contains("node 0 has no root above it"), "{e}");
        // A loop the scene does not reach: the scene cooks, with a warning.
        let aside = chain(3, true)
            .replace(
                r#""scenes": [{"nodes": [0]}]"#,
                r#""scenes": [{"nodes": [3]}]"#,
            )
            .replace(
                r#"{"mesh": 0, "children": [0]}"#,
                r#"{"mesh": 0, "children": [0]}, {"mesh": 0}"#,
            );
        std::fs::write(&cyclic, aside).unwrap();
        let m = import(&cyclic).unwrap();
        assert_eq!(m.tri_part.len(), 1);
        let w: Vec<String> = m.warnings.iter().map(|w| w.to_string()).collect();
        assert!(
            w.iter()
                .any(|w| w.contains("cyclic at node 0, which the scene does not reach")),
            "{w:?}"
        );
    }

    /// A root the scene lists twice is cooked once, with a warning; a chain is not a cycle.
    #[test]
    fn a_root_listed_twice_is_cooked_once() {
        let dir = tempfile::tempdir().unwrap();
        let pos: [[f32; 3]; 3] = [[0., 0., 0.], [1., 0., 0.], [0., 1., 0.]];
        let bin: Vec<u8> = pos.iter().flatten().flat_map(|f| f.to_le_bytes()).collect();
        std::fs::write(dir.path().join("t.bin"), &bin).unwrap();
        let file = |roots: &str| {
            format!(
                r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": {roots}}}],
                "nodes": [{{"mesh": 0, "children": [1]}}, {{"mesh": 0, "translation": [2, 0, 0]}}],
                "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
                "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3,
                    "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
                "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
                "buffers": [{{"byteLength": 36, "uri": "t.bin"}}]}}"#
            )
        };
        let path = dir.path().join("twice.gltf");
        for (roots, triangles, warned) in [("[0]", 2, false), ("[0, 0, 0]", 2, true)] {
            std::fs::write(&path, file(roots)).unwrap();
            let m = import(&path).unwrap();
            assert_eq!(m.tri_part.len(), triangles, "{roots}");
            let w: Vec<String> = m.warnings.iter().map(|w| w.to_string()).collect();
            assert_eq!(
                w.iter()
                    .any(|w| w.contains("scene 0 lists node 0 3 times: each is cooked once")),
                warned,
                "{roots}: {w:?}"
            );
            assert!(!w.iter().any(|w| w.contains("cyclic")), "{w:?}");
        }
    }

    /// The least and greatest corner of the positions' box.
    fn bounds(m: &Imported) -> (glam::Vec3, glam::Vec3) {
        m.positions.iter().fold(
            (glam::Vec3::INFINITY, glam::Vec3::NEG_INFINITY),
            |(lo, hi), p| (lo.min((*p).into()), hi.max((*p).into())),
        )
    }

    /// gltfpack's default output (`KHR_mesh_quantization`, required) and its `-c` output
    /// (`EXT_meshopt_compression` over a placeholder buffer with no data) of the same model
    /// import to the same data, bit for bit, and to the model gltfpack read within its 14-bit
    /// quantization. Both were refused before ("extensionsRequired[0] = KHR_mesh_quantization:
    /// Unsupported extension").
    #[test]
    fn gltfpack_quantized_and_meshopt_compressed_files_import() {
        let q = import(&third_party("gltfpack/spot_q.glb")).unwrap();
        let c = import(&third_party("gltfpack/spot_c.glb")).unwrap();
        assert!(q.positions == c.positions, "positions differ");
        assert!(corners(&q) == corners(&c), "triangles differ");
        assert_eq!(q.tri_part.len(), 5856);
        let obj = super::super::obj::import(&third_party("classic/spot.obj"), None).unwrap();
        let ((lo_q, hi_q), (lo_o, hi_o)) = (bounds(&q), bounds(&obj));
        let size = (hi_o - lo_o).max_element();
        assert!(lo_q.distance(lo_o) < size * 2e-4 && hi_q.distance(hi_o) < size * 2e-4);
        assert_eq!(obj.tri_part.len(), q.tri_part.len());
        assert!(gap(&q, &obj)[0] < size * 2e-4, "{:?}", gap(&q, &obj));
    }

    /// `-cc` adds the octahedral filter on 8-bit normals and reorders; the texture stays an
    /// uncompressed view beside the compressed ones.
    #[test]
    fn gltfpack_cc_normals_texture_and_materials_import() {
        let q = import(&third_party("gltfpack/boxtex_q.glb")).unwrap();
        let cc = import(&third_party("gltfpack/boxtex_cc.glb")).unwrap();
        let [dp, dn, duv] = gap(&q, &cc);
        assert!(dp < 1e-6 && dn < 0.02 && duv < 1e-6, "{dp} {dn} {duv}");
        assert!(
            cc.normals
                .iter()
                .all(|n| (glam::Vec3::from(*n).length() - 1.0).abs() < 1e-3)
        );
        match &cc.materials[0].diffuse_texture {
            Some(ImageRef::Embedded { bytes, .. }) => assert!(bytes.starts_with(b"\x89PNG")),
            other => panic!("no embedded design: {other:?}"),
        }
        let q = import(&third_party("gltfpack/cornell_q.glb")).unwrap();
        let cc = import(&third_party("gltfpack/cornell_cc.glb")).unwrap();
        assert!(gap(&q, &cc)[0] < 1e-3, "{:?}", gap(&q, &cc));
        let names = |m: &Imported| {
            let mut v: Vec<String> = m.materials.iter().map(|m| m.name.clone()).collect();
            v.sort();
            v
        };
        assert_eq!(names(&q), names(&cc));
        assert_eq!(names(&q), ["green", "red", "white"]);
    }

    /// gltf-pipeline's Draco output (`-d`: draco3d 1.5.9, 11 bits of position, 8 of normal,
    /// 10 of texture coordinates) of third-party models imports as the models it compressed,
    /// within that quantization: Edgebreaker and the sequential method, normals and texture
    /// coordinates, three primitives, one mesh placed by six nodes. Refused before ("requires
    /// glTF extension KHR_draco_mesh_compression").
    #[test]
    fn draco_compressed_files_import_as_the_models_they_compress() {
        let size = |m: &Imported| {
            let (lo, hi) = bounds(m);
            (hi - lo).max_element()
        };
        // Half a quantization step of the largest extent, and a little rounding.
        let step = |bits: i32| 0.5 / (2f32.powi(bits) - 1.0) * 1.01;
        let obj = |rel: &str| super::super::obj::import(&third_party(rel), None).unwrap();
        for (draco, original) in [
            (
                import(&third_party("draco/spot_d.glb")).unwrap(),
                obj("classic/spot.obj"),
            ),
            // Against gltfpack's quantized export (14 bits), which splits the quads as the
            // Draco file does; the cooker's OBJ import splits them along the other diagonal.
            (
                import(&third_party("draco/cornell_d.glb")).unwrap(),
                import(&third_party("gltfpack/cornell_q.glb")).unwrap(),
            ),
        ] {
            let s = size(&original);
            let [dp, ..] = gap(&draco, &original);
            assert!(dp <= s * step(11) * 3f32.sqrt(), "{dp} of {s}");
            assert_eq!(flipped(&draco, &original), 0);
            assert!(draco.warnings.is_empty(), "{:?}", draco.warnings);
        }
        let cornell = import(&third_party("draco/cornell_d.glb")).unwrap();
        let mut names: Vec<&str> = cornell.materials.iter().map(|m| m.name.as_str()).collect();
        names.sort();
        assert_eq!(names, ["green", "red", "white"]);

        for (draco, original, uv) in [
            (
                "draco/boxtex_d.glb",
                "gltf/BoxTextured/BoxTextured.glb",
                true,
            ),
            ("draco/box_d_seq.glb", "gltf/Box/Box.glb", false),
        ] {
            let (d, o) = (
                import(&third_party(draco)).unwrap(),
                import(&third_party(original)).unwrap(),
            );
            let [dp, dn, duv] = gap(&d, &o);
            assert!(dp <= size(&o) * step(11) * 3f32.sqrt(), "{draco}: {dp}");
            // Octahedral normals at 8 bits: a step of about 1/127 radian either way.
            assert!(dn < 0.02, "{draco}: normals {dn}");
            let uv_size = o.uvs.iter().fold(0f32, |m, a| {
                o.uvs.iter().fold(m, |m, b| {
                    m.max((a[0] - b[0]).abs().max((a[1] - b[1]).abs()))
                })
            });
            assert!(duv <= uv_size * step(10) * 2f32.sqrt(), "{draco}: uv {duv}");
            assert_eq!(d.uvs.is_empty(), !uv, "{draco}");
        }

        // A damaged stream with an uncompressed copy beside it: the copy is read, with a
        // warning that names the damage.
        let mut glb = std::fs::read(third_party("draco/box_d_fallback.glb")).unwrap();
        let (at, len) = draco_stream(&glb);
        glb[at + 20..at + len].fill(0);
        let dir = tempfile::tempdir().unwrap();
        let damaged = dir.path().join("fallback.glb");
        std::fs::write(&damaged, &glb).unwrap();
        let copy = import(&damaged).unwrap();
        let box_ = import(&third_party("gltf/Box/Box.glb")).unwrap();
        assert_eq!(gap(&copy, &box_), [0.0; 3]);
        assert!(
            copy.warnings
                .iter()
                .any(|w| w.message.contains("uncompressed copy")),
            "{:?}",
            copy.warnings
        );
        // Undamaged, the stream is read (as the extension asks), within its quantization.
        let stream = import(&third_party("draco/box_d_fallback.glb")).unwrap();
        assert!(stream.warnings.is_empty() && gap(&stream, &box_)[0] < 1e-3);

        let placed = import(&third_party("draco/boxes_d.glb")).unwrap();
        let nodes = import(&third_party("gltfpack/boxes.gltf")).unwrap();
        assert_eq!(placed.parts.len(), 6);
        assert_eq!(placed.tri_part.len(), nodes.tri_part.len());
        assert!(gap(&placed, &nodes)[0] < size(&nodes) * step(11) * 2.0);
    }

    /// How many triangles of `a` face away from the nearest triangle of `b` (by centroid): the
    /// corner gap alone would not see a winding turned round.
    fn flipped(a: &Imported, b: &Imported) -> usize {
        let geometry = |t: &Triangle| {
            let [p, q, r] = t.map(|c| glam::Vec3::from(c.0));
            ((p + q + r) / 3.0, (q - p).cross(r - p))
        };
        let tb: Vec<_> = corners(b).iter().map(geometry).collect();
        corners(a)
            .iter()
            .map(geometry)
            .filter(|(c, n)| {
                let near = tb
                    .iter()
                    .min_by(|u, v| c.distance(u.0).total_cmp(&c.distance(v.0)))
                    .unwrap();
                n.dot(near.1) < 0.0
            })
            .count()
    }

    /// The buffer view of the first Draco stream in a GLB: where it starts in the file and its
    /// length.
    fn draco_stream(glb: &[u8]) -> (usize, usize) {
        let n = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
        let j: serde_json::Value = serde_json::from_slice(&glb[20..20 + n]).unwrap();
        let ext = &j["meshes"][0]["primitives"][0]["extensions"]["KHR_draco_mesh_compression"];
        let view = &j["bufferViews"][ext["bufferView"].as_u64().unwrap() as usize];
        let at = 20 + n + 8 + view["byteOffset"].as_u64().unwrap_or(0) as usize;
        (at, view["byteLength"].as_u64().unwrap() as usize)
    }

    /// Draco streams damaged at random (bytes replaced, bits flipped, the stream cut short) are
    /// read or refused with an error naming the file, never a panic: the decoder panics on
    /// some of them (caught and reported as malformed, its message kept off the terminal), and
    /// what it returns is checked like any other file's data.
    #[test]
    fn damaged_draco_streams_are_errors_never_panics() {
        let dir = tempfile::tempdir().unwrap();
        let mut seed = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            seed
        };
        let (mut read, mut refused) = (0, 0);
        for name in ["spot_d.glb", "boxtex_d.glb", "box_d_seq.glb"] {
            let glb = std::fs::read(third_party(&format!("draco/{name}"))).unwrap();
            let (at, len) = draco_stream(&glb);
            for i in 0..150 {
                let mut bytes = glb.clone();
                for _ in 0..1 + next() % 3 {
                    let k = at + (next() as usize) % len;
                    match next() % 3 {
                        0 => bytes[k] = next() as u8,
                        1 => bytes[k] ^= 1 << (next() % 8),
                        // Cut short: zeros from here to the view's end.
                        _ => bytes[k..at + len].fill(0),
                    }
                }
                let path = dir.path().join(format!("{i}_{name}"));
                std::fs::write(&path, &bytes).unwrap();
                match import(&path) {
                    Ok(_) => read += 1,
                    Err(e) => {
                        let e = e.to_string();
                        assert!(e.contains(&format!("{i}_{name}")), "{e}");
                        refused += 1;
                    }
                }
            }
        }
        assert!(refused > 100 && read > 0, "{refused} refused, {read} read");
    }

    /// A header that claims more than its stream could hold is refused before the decoder
    /// sizes its tables by it.
    #[test]
    fn a_draco_header_claiming_too_much_is_refused() {
        let mut glb = std::fs::read(third_party("draco/spot_d.glb")).unwrap();
        let (at, _) = draco_stream(&glb);
        // DRACO 2.2, mesh, Edgebreaker, flags; then the traversal byte and the vertex count
        // (two bytes of LEB128 for Spot's 2930), then the face count, made 2^32 - 1.
        assert_eq!(&glb[at..at + 9], b"DRACO\x02\x02\x01\x01");
        let faces = at + 11 + 1 + 2;
        glb[faces..faces + 5].copy_from_slice(&[0xff, 0xff, 0xff, 0xff, 0x0f]);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("claims.glb");
        std::fs::write(&path, &glb).unwrap();
        let e = import(&path).unwrap_err().to_string();
        assert!(
            e.contains("claims.glb") && e.contains("bytes of Draco can hold"),
            "{e}"
        );
    }

    /// `EXT_mesh_gpu_instancing` (gltfpack `-mi`, with its quaternion and exponential filters):
    /// one mesh placed six times by instance attributes imports as the six placed copies that
    /// six nodes give, each its own part, as each node is (the geometry heuristics then judge
    /// one box, not the row). Before, the extension was refused, and read past it only one box
    /// stood.
    #[test]
    fn instanced_meshes_import_as_their_placed_copies() {
        let nodes = import(&third_party("gltfpack/boxes.gltf")).unwrap();
        let q = import(&third_party("gltfpack/boxes_q.glb")).unwrap();
        let mi = import(&third_party("gltfpack/boxes_mi_cc.glb")).unwrap();
        assert_eq!(nodes.tri_part.len(), 72);
        // 14-bit positions on a 12-unit row, 16-bit quaternions.
        assert!(gap(&nodes, &q)[0] < 2e-3, "{:?}", gap(&nodes, &q));
        assert!(gap(&nodes, &mi)[0] < 2e-3, "{:?}", gap(&nodes, &mi));
        assert!(gap(&q, &mi)[1] < 0.02, "{:?}", gap(&q, &mi));
        let boxes = |m: &Imported| {
            let mut per_part = vec![0; m.parts.len()];
            for &p in &m.tri_part {
                per_part[p as usize] += 1;
            }
            per_part
        };
        assert_eq!(boxes(&nodes), vec![12; 6]);
        assert_eq!(boxes(&mi), boxes(&nodes));
        // Each instance's notes say which copy it is (six identical lines before); names as
        // rules see them stay the node's.
        let described: std::collections::BTreeSet<String> =
            mi.parts.iter().map(|p| p.names.describe()).collect();
        assert_eq!(described.len(), 6, "{described:?}");
        assert!(described.iter().any(|d| d.ends_with(", instance 5")));
        assert!(
            mi.parts
                .iter()
                .all(|p| p.names.node == mi.parts[0].names.node)
        );
    }

    /// gltfpack's `boxes.gltf` as JSON to edit, its buffer copied into `dir`.
    fn boxes_json(dir: &Path) -> serde_json::Value {
        let source = third_party("gltfpack/boxes.gltf");
        std::fs::copy(source.with_file_name("Box0.bin"), dir.join("Box0.bin")).unwrap();
        serde_json::from_slice(&std::fs::read(&source).unwrap()).unwrap()
    }

    /// `boxes.gltf` moved far from the origin, as a scan in UTM metres is: by a root node's
    /// matrix, or by each node's own translation.
    fn boxes_far_away(dir: &Path, at: [f64; 3], by_root: bool) -> std::path::PathBuf {
        let mut json = boxes_json(dir);
        let count = json["nodes"].as_array().unwrap().len();
        if by_root {
            let mut matrix = vec![serde_json::json!(0.0); 16];
            for k in [0, 5, 10, 15] {
                matrix[k] = serde_json::json!(1.0);
            }
            for k in 0..3 {
                matrix[12 + k] = serde_json::json!(at[k]);
            }
            let root =
                serde_json::json!({"matrix": matrix, "children": (0..count).collect::<Vec<_>>()});
            json["nodes"].as_array_mut().unwrap().push(root);
            json["scenes"][0]["nodes"] = serde_json::json!([count]);
        } else {
            for n in json["nodes"].as_array_mut().unwrap() {
                for k in 0..3 {
                    let t = n["translation"][k].as_f64().unwrap();
                    n["translation"][k] = serde_json::json!(t + at[k]);
                }
            }
        }
        let path = dir.join(if by_root { "root.gltf" } else { "nodes.gltf" });
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        path
    }

    /// A glTF placed far from the origin keeps the geometry it has near it: its node
    /// transforms are read and chained in f64 from the file's digits (gltf's f32 reading moved
    /// 500000.123 to 500000.125, and positions snapped to a half-unit grid at 5,000,000).
    #[test]
    fn a_gltf_in_survey_coordinates_keeps_its_precision() {
        let dir = tempfile::tempdir().unwrap();
        let near = import(&third_party("gltfpack/boxes.gltf")).unwrap();
        assert_eq!(near.origin, [0.0; 3]);
        let at = [500_000.123, 7.5, 5_000_000.456];
        for by_root in [true, false] {
            let far = import(&boxes_far_away(dir.path(), at, by_root)).unwrap();
            // The first vertex's far coordinates, in whole units.
            let first = glam::DVec3::from(at) + glam::DVec3::from(near.positions[0].map(f64::from));
            assert_eq!(far.origin, [first.x.round(), 0.0, first.z.round()]);
            assert_eq!(far.positions.len(), near.positions.len());
            let offset = glam::DVec3::from(at) - glam::DVec3::from(far.origin);
            let worst = near
                .positions
                .iter()
                .zip(&far.positions)
                .map(|(a, b)| {
                    let a = glam::DVec3::from(a.map(f64::from)) + offset;
                    (a - glam::DVec3::from(b.map(f64::from)))
                        .abs()
                        .max_element()
                })
                .fold(0.0, f64::max);
            assert!(worst < 2e-6, "by root {by_root}: {worst}");
            assert_eq!(far.corners.len(), near.corners.len());
        }

        // Positions far in the file itself (the exporter baked the placement): moved exactly.
        let bin: Vec<u8> = [
            500_000.5f32,
            0.,
            5e6,
            500_001.5,
            0.,
            5e6,
            500_000.5,
            1.,
            5e6,
        ]
        .iter()
        .flat_map(|f| f.to_le_bytes())
        .collect();
        let view = r#"{"buffer": 0, "byteLength": 36}"#;
        let baked = import(&write_gltf(dir.path(), &bin, view, "")).unwrap();
        assert_eq!(baked.origin, [500_001.0, 0.0, 5_000_000.0]);
        assert_eq!(
            baked.positions,
            [[-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], [-0.5, 1.0, 0.0]]
        );
    }

    /// `COLOR_0` is read as RGB floats or normalized RGBA bytes; a primitive without it is
    /// white beside one with it, and a count that differs from the positions' is an error.
    #[test]
    fn vertex_colours_are_read_whatever_their_type() {
        let dir = tempfile::tempdir().unwrap();
        let mut bin = triangle_bytes();
        // RGB floats (36 bytes at 36), RGBA bytes (12 at 72).
        for c in [0.5f32, 0.25, 1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0] {
            bin.extend(c.to_le_bytes());
        }
        bin.extend([255, 0, 0, 255, 0, 255, 0, 128, 0, 0, 255, 0]);
        let write = |colours: &str, count: usize| {
            std::fs::write(dir.path().join("c.bin"), &bin).unwrap();
            let json = format!(
                r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
                "nodes": [{{"mesh": 0}}],
                "meshes": [{{"primitives": [
                    {{"attributes": {{"POSITION": 0, "COLOR_0": {colours}}}}},
                    {{"attributes": {{"POSITION": 0}}}}]}}],
                "accessors": [
                    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]}},
                    {{"bufferView": 1, "componentType": 5126, "count": {count}, "type": "VEC3"}},
                    {{"bufferView": 2, "componentType": 5121, "normalized": true, "count": 3,
                      "type": "VEC4"}}],
                "bufferViews": [
                    {{"buffer": 0, "byteLength": 36}},
                    {{"buffer": 0, "byteOffset": 36, "byteLength": 36}},
                    {{"buffer": 0, "byteOffset": 72, "byteLength": 12}}],
                "buffers": [{{"byteLength": {}, "uri": "c.bin"}}]}}"#,
                bin.len()
            );
            let path = dir.path().join("c.gltf");
            std::fs::write(&path, json).unwrap();
            import(&path)
        };
        let floats = write("1", 3).unwrap();
        let white = [[1.0; 4]; 3];
        assert_eq!(
            floats.colours,
            [
                [[0.5, 0.25, 1.0, 1.0], [0.0, 1.0, 0.0, 1.0], [1.0; 4]].as_slice(),
                &white
            ]
            .concat()
        );
        let bytes = write("2", 3).unwrap();
        let half = 128.0 / 255.0;
        assert_eq!(
            bytes.colours[..3],
            [
                [1.0, 0.0, 0.0, 1.0],
                [0.0, 1.0, 0.0, half],
                [0.0, 0.0, 1.0, 0.0]
            ]
        );
        assert_eq!(bytes.colours[3..], white);
        let err = write("1", 2).unwrap_err().to_string();
        assert!(
            err.contains("COLOR_0 has 2 elements but POSITION has 3"),
            "{err}"
        );
    }

    /// `boxes.gltf` with a camera and a sun of its own, as Blender exports a framed scene,
    /// with a point light and a spot light for the guess, and cameras and lights a pack cannot
    /// hold (orthographic cameras, a second sun, an area light).
    fn boxes_with_views(dir: &Path) -> std::path::PathBuf {
        let mut json = boxes_json(dir);
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let count = json["nodes"].as_array().unwrap().len();
        json["nodes"].as_array_mut().unwrap().extend([
            serde_json::json!({"name": "Eye", "camera": 0, "translation": [5.0, 2.0, 10.0]}),
            serde_json::json!({"name": "Sun", "rotation": [-h, 0.0, 0.0, h],
                "extensions": {"KHR_lights_punctual": {"light": 0}}}),
            serde_json::json!({"extensions": {"KHR_lights_punctual": {"light": 1}},
                "translation": [1.0, 2.0, 3.0]}),
            serde_json::json!({"camera": 1}),
            serde_json::json!({"camera": 2}),
            // Turned a quarter about y: its axis, -z, points along -x.
            serde_json::json!({"name": "Strahlerknoten", "translation": [0.0, 5.0, 0.0],
                "rotation": [0.0, h, 0.0, h],
                "extensions": {"KHR_lights_punctual": {"light": 2}}}),
            serde_json::json!({"extensions": {"KHR_lights_punctual": {"light": 3}}}),
            serde_json::json!({"extensions": {"KHR_lights_punctual": {"light": 4}}}),
        ]);
        let scene = json["scenes"][0]["nodes"].as_array_mut().unwrap();
        scene.extend((count..count + 8).map(|i| serde_json::json!(i)));
        json["cameras"] = serde_json::json!([
            {"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.05, "zfar": 200.0}},
            {"type": "orthographic", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0, "zfar": 9}},
            // Its type says perspective, its data is orthographic (gltf's `projection` unwraps).
            {"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "znear": 0, "zfar": 9}}
        ]);
        json["extensionsUsed"] = serde_json::json!(["KHR_lights_punctual"]);
        json["extensions"] = serde_json::json!({"KHR_lights_punctual": {"lights": [
            {"type": "directional", "name": "Sonne", "color": [1.0, 0.5, 0.25]},
            {"type": "point", "name": "Kerze"},
            {"type": "spot", "color": [0.5, 0.5, 1.0], "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.3}},
            {"type": "directional", "name": "Mond"},
            {"type": "area", "name": "Fenster"}
        ]}});
        let path = dir.join("views.gltf");
        std::fs::write(&path, serde_json::to_vec(&json).unwrap()).unwrap();
        path
    }

    /// A glTF's perspective cameras and first directional light are read from its nodes, in
    /// world space; what a pack cannot hold is named.
    #[test]
    fn cameras_and_sun_come_from_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let m = import(&boxes_with_views(dir.path())).unwrap();
        assert_eq!(m.views.len(), 1, "{:?}", m.views);
        let eye = &m.views[0];
        assert_eq!(eye.name, "Eye");
        assert_eq!(eye.position, [5.0, 2.0, 10.0]);
        // Along -z, to the depth of the boxes' centre.
        assert_eq!(eye.target[..2], [5.0, 2.0]);
        assert!(eye.target[2] < 10.0);
        assert_eq!(eye.up, [0.0, 1.0, 0.0]);
        assert!((eye.fov_y - 0.8f32.to_degrees()).abs() < 1e-4);
        assert_eq!((eye.near, eye.far), (0.05, 200.0));
        let sun = m.sun.as_ref().unwrap();
        assert_eq!(sun.name, "Sonne");
        assert_eq!(sun.colour, [1.0, 0.5, 0.25]);
        let d = glam::Vec3::from(sun.direction);
        assert!((d - glam::Vec3::NEG_Y).length() < 1e-6, "{d}");
        // Point and spot lights are kept for the guess, which takes one that shines in
        // through the windows.
        assert_eq!(m.lamps.len(), 2, "{:?}", m.lamps);
        assert_eq!(m.lamps[0].name, "Kerze");
        assert_eq!(m.lamps[0].position, [1.0, 2.0, 3.0]);
        assert_eq!((m.lamps[0].colour, m.lamps[0].spot), ([1.0; 3], None));
        let spot = &m.lamps[1];
        assert_eq!(spot.name, "Strahlerknoten");
        assert_eq!(
            (spot.position, spot.colour),
            ([0.0, 5.0, 0.0], [0.5, 0.5, 1.0])
        );
        let cone = spot.spot.unwrap();
        assert!(
            (glam::Vec3::from(cone.axis) - glam::Vec3::NEG_X).length() < 1e-6,
            "{cone:?}"
        );
        assert_eq!((cone.inner, cone.outer), (0.1, 0.3));
        let said: Vec<&str> = m.warnings.iter().map(|w| w.message.as_str()).collect();
        assert!(
            said.iter()
                .any(|w| w.contains("orthographic camera \"node9\"")
                    && w.contains("camera \"node10\" without a perspective projection")
                    && w.contains("directional light \"Mond\"")
                    && !w.contains("Kerze")
                    && w.ends_with("not used: a pack holds perspective cameras and one light")),
            "{said:?}"
        );
        // A type glTF does not define is said as such, not as one more light.
        assert!(
            said.contains(
                &"light \"Fenster\" has type \"area\", which KHR_lights_punctual does not \
                  define (directional, point, spot): not used"
            ),
            "{said:?}"
        );
    }

    /// One triangle's positions, as a little-endian float buffer.
    fn triangle_bytes() -> Vec<u8> {
        [0f32, 0., 0., 1., 0., 0., 0., 1., 0.]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect()
    }

    fn write_gltf(dir: &Path, bin: &[u8], views: &str, extra: &str) -> std::path::PathBuf {
        std::fs::write(dir.join("b.bin"), bin).unwrap();
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}}, {extra}
            "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}}}]}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3,
                "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
            "bufferViews": [{views}],
            "buffers": [{{"byteLength": {}, "uri": "b.bin"}}, {{"byteLength": 36}}]}}"#,
            bin.len()
        );
        let path = dir.join("m.gltf");
        std::fs::write(&path, json).unwrap();
        path
    }

    /// glTF's defaults make a material that gives only a base colour a rough metal (metallic
    /// 1, roughness 1). The viewer has no surroundings for a metal to reflect, and such a
    /// material was cooked black (diffuse 0) with its texture unseen. A rough metal keeps its
    /// base colour as diffuse; a polished one is mostly specular; a dielectric is as it was.
    #[test]
    fn a_rough_metal_keeps_its_base_colour_and_a_polished_one_reflects_it() {
        let dir = tempfile::tempdir().unwrap();
        let tri = triangle_bytes();
        std::fs::write(dir.path().join("b.bin"), &tri).unwrap();
        let json = r#"{"asset": {"version": "2.0"},
            "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [
                {"attributes": {"POSITION": 0}, "material": 0},
                {"attributes": {"POSITION": 0}, "material": 1},
                {"attributes": {"POSITION": 0}, "material": 2}]}],
            "materials": [
                {"name": "defaults", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1]}},
                {"name": "plastic", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1],
                    "metallicFactor": 0}},
                {"name": "brass", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.4, 0.2, 1],
                    "roughnessFactor": 0.2}}],
            "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3,
                "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}],
            "bufferViews": [{"buffer": 0, "byteLength": 36}],
            "buffers": [{"byteLength": 36, "uri": "b.bin"}]}"#;
        let path = dir.path().join("m.gltf");
        std::fs::write(&path, json).unwrap();
        let m = import(&path).unwrap();
        let get = |name: &str| m.materials.iter().find(|x| x.name == name).unwrap();
        let near = |a: [f32; 3], b: [f32; 3]| a.iter().zip(b).all(|(x, y)| (x - y).abs() < 1e-5);
        let base = [0.8, 0.4, 0.2];
        assert!(
            near(get("defaults").diffuse, base),
            "{:?}",
            get("defaults").diffuse
        );
        assert!(near(get("plastic").diffuse, base));
        assert!(near(get("plastic").specular, [0.04; 3]));
        let brass = get("brass");
        assert!(
            near(brass.diffuse, base.map(|c| c * 0.04)),
            "{:?}",
            brass.diffuse
        );
        assert!(
            near(brass.specular, base.map(|c| c * 0.96)),
            "{:?}",
            brass.specular
        );
    }

    #[test]
    fn required_extensions_the_cooker_cannot_read_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let tri = triangle_bytes();
        let view = r#"{"buffer": 0, "byteLength": 36}"#;
        let avif = write_gltf(
            dir.path(),
            &tri,
            view,
            r#""extensionsRequired": ["EXT_texture_avif"],"#,
        );
        let e = import(&avif).unwrap_err().to_string();
        assert!(
            e.contains("m.gltf") && e.contains("EXT_texture_avif") && e.contains("PNG"),
            "{e}"
        );
        // Shading-only extensions cook, with a warning.
        let sg = write_gltf(
            dir.path(),
            &tri,
            view,
            r#""extensionsRequired": ["KHR_materials_clearcoat"],"#,
        );
        let m = import(&sg).unwrap();
        assert_eq!(m.tri_part.len(), 1);
        assert!(
            m.warnings
                .iter()
                .any(|w| w.message.contains("KHR_materials_clearcoat"))
        );
    }

    /// A byte-order mark before a .gltf's JSON and zero bytes padding a GLB's JSON chunk (both
    /// written in the wild) are read past; a version other than 2.x, or one that needs a
    /// later reader, is refused by name (a glTF 1.0 file said only that it had no faces).
    #[test]
    fn marks_padding_and_versions() {
        let dir = tempfile::tempdir().unwrap();
        let tri = triangle_bytes();
        let view = r#"{"buffer": 0, "byteLength": 36}"#;
        let path = write_gltf(dir.path(), &tri, view, "");
        let json = std::fs::read(&path).unwrap();
        let bom = dir.path().join("bom.gltf");
        std::fs::write(&bom, [&[0xef, 0xbb, 0xbf][..], &json].concat()).unwrap();
        assert_eq!(import(&bom).unwrap().tri_part.len(), 1);
        // The GLB of the same JSON, its buffer 0 as the binary chunk, the JSON padded by NULs.
        let text = String::from_utf8(json.clone()).unwrap().replace(
            r#"{"byteLength": 36, "uri": "b.bin"}"#,
            r#"{"byteLength": 36}"#,
        );
        let mut chunk = text.into_bytes();
        chunk.resize(chunk.len().next_multiple_of(4) + 4, 0);
        let total = 12 + 8 + chunk.len() + 8 + tri.len();
        let mut glb = b"glTF".to_vec();
        for v in [2, total as u32, chunk.len() as u32] {
            glb.extend(v.to_le_bytes());
        }
        glb.extend(b"JSON");
        glb.extend(&chunk);
        glb.extend((tri.len() as u32).to_le_bytes());
        glb.extend(b"BIN\0");
        glb.extend(&tri);
        let padded = dir.path().join("nul.glb");
        std::fs::write(&padded, glb).unwrap();
        assert_eq!(import(&padded).unwrap().tri_part.len(), 1);
        // A glTF 1.0 file as one is written (objects keyed by name): said to be 1.0, not a
        // list of what 2.0 misses in it.
        let old = dir.path().join("old.gltf");
        std::fs::write(
            &old,
            r#"{"asset": {"version": "1.0.3"}, "meshes": {"m": {"primitives": []}},
                "accessors": {"a": {"bufferView": "v"}}}"#,
        )
        .unwrap();
        let e = import(&old).unwrap_err().to_string();
        assert!(
            e.contains(r#"asset.version is "1.0.3": only glTF 2.0"#),
            "{e}"
        );
        for (asset, said) in [
            (
                r#""version": "1.0""#,
                "only glTF 2.0 files are read (convert",
            ),
            (r#""version": "3.0""#, r#"asset.version is "3.0""#),
            (r#""version": "two""#, "is no glTF version"),
            (
                r#""version": "2.0", "minVersion": "2.1""#,
                "needs a reader of that",
            ),
        ] {
            let text = String::from_utf8(json.clone())
                .unwrap()
                .replace(r#""version": "2.0""#, asset);
            std::fs::write(&path, text).unwrap();
            let e = import(&path).unwrap_err().to_string();
            assert!(e.contains("m.gltf") && e.contains(said), "{asset}: {e}");
        }
    }

    /// A mesh is posed by its morph weights, a node's overriding its mesh's, as glTF shows it
    /// at rest; it was cooked unmorphed.
    #[test]
    fn morph_weights_pose_the_mesh() {
        let dir = tempfile::tempdir().unwrap();
        let mut bin = triangle_bytes();
        // Target 0 raises the third corner by 2 along z; target 1 moves all along x by 7.
        for d in [[0f32, 0., 0.], [0., 0., 0.], [0., 0., 2.]] {
            bin.extend(d.iter().flat_map(|f| f.to_le_bytes()));
        }
        for _ in 0..3 {
            bin.extend([7f32, 0., 0.].iter().flat_map(|f| f.to_le_bytes()));
        }
        std::fs::write(dir.path().join("b.bin"), &bin).unwrap();
        let file = |mesh_weights: &str, node_weights: &str| {
            format!(
                r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}],
                "nodes": [{{"mesh": 0 {node_weights}}}],
                "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}},
                    "targets": [{{"POSITION": 1}}, {{"POSITION": 2}}]}}] {mesh_weights}}}],
                "accessors": [
                    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]}},
                    {{"bufferView": 0, "byteOffset": 36, "componentType": 5126, "count": 3,
                      "type": "VEC3", "min": [0, 0, 0], "max": [0, 0, 2]}},
                    {{"bufferView": 0, "byteOffset": 72, "componentType": 5126, "count": 3,
                      "type": "VEC3", "min": [7, 0, 0], "max": [7, 0, 0]}}],
                "bufferViews": [{{"buffer": 0, "byteLength": 108}}],
                "buffers": [{{"byteLength": 108, "uri": "b.bin"}}]}}"#
            )
        };
        let path = dir.path().join("morph.gltf");
        for (mesh_w, node_w, top_z, shift_x) in [
            ("", "", 0.0, 0.0),
            (r#", "weights": [0.5, 0]"#, "", 1.0, 0.0),
            (
                r#", "weights": [0.5, 0]"#,
                r#", "weights": [1, 0.25]"#,
                2.0,
                1.75,
            ),
        ] {
            std::fs::write(&path, file(mesh_w, node_w)).unwrap();
            let m = import(&path).unwrap();
            let (lo, hi) = bounds(&m);
            assert_eq!(hi.z, top_z, "{mesh_w} {node_w}");
            assert_eq!(lo.x, shift_x, "{mesh_w} {node_w}");
        }
        std::fs::write(&path, file(r#", "weights": [1e39, 0]"#, "")).unwrap();
        let e = import(&path).unwrap_err().to_string();
        assert!(e.contains("morph target 0's weight is inf"), "{e}");
    }

    /// A skinned mesh is posed by its joints at rest (the node's own transform is ignored, as
    /// glTF says): it was cooked where the node put it, unskinned, without a word.
    #[test]
    fn a_skinned_mesh_is_posed_by_its_joints() {
        let dir = tempfile::tempdir().unwrap();
        let mut bin = triangle_bytes();
        // JOINTS_0 as u8 (joint 0 and 1 for every vertex), WEIGHTS_0 as floats.
        for _ in 0..3 {
            bin.extend([0u8, 1, 0, 0]);
        }
        let weights_at = bin.len();
        for _ in 0..3 {
            bin.extend([0.25f32, 0.75, 0., 0.].iter().flat_map(|f| f.to_le_bytes()));
        }
        // Inverse bind matrices: joint 0's undoes its x + 2; joint 1's is the identity.
        let ibm_at = bin.len();
        let shifted = glam::Mat4::from_translation(glam::vec3(-2., 0., 0.)).to_cols_array();
        for m in [shifted, glam::Mat4::IDENTITY.to_cols_array()] {
            bin.extend(m.iter().flat_map(|f| f.to_le_bytes()));
        }
        std::fs::write(dir.path().join("b.bin"), &bin).unwrap();
        let file = |ibm: &str| {
            format!(
                r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0, 1]}}],
                "nodes": [{{"mesh": 0, "skin": 0, "translation": [100, 0, 0]}},
                          {{"translation": [0, 0, 5], "children": [2, 3]}},
                          {{"translation": [2, 0, 0]}}, {{"translation": [4, 0, 0]}}],
                "skins": [{{"joints": [2, 3] {ibm}}}],
                "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0,
                    "JOINTS_0": 1, "WEIGHTS_0": 2}}}}]}}],
                "accessors": [
                    {{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                      "min": [0, 0, 0], "max": [1, 1, 0]}},
                    {{"bufferView": 0, "byteOffset": 36, "componentType": 5121, "count": 3,
                      "type": "VEC4"}},
                    {{"bufferView": 0, "byteOffset": {weights_at}, "componentType": 5126,
                      "count": 3, "type": "VEC4"}},
                    {{"bufferView": 0, "byteOffset": {ibm_at}, "componentType": 5126,
                      "count": 2, "type": "MAT4"}}],
                "bufferViews": [{{"buffer": 0, "byteLength": {len}}}],
                "buffers": [{{"byteLength": {len}, "uri": "b.bin"}}]}}"#,
                len = bin.len()
            )
        };
        let path = dir.path().join("skin.gltf");
        // Without inverse bind matrices: 0.25 of x + 2 and 0.75 of x + 4, all up z by 5.
        // With them, joint 0 stands where it was bound: 0.75 of x + 4.
        for (ibm, x) in [("", 3.5), (r#", "inverseBindMatrices": 3"#, 3.0)] {
            std::fs::write(&path, file(ibm)).unwrap();
            let m = import(&path).unwrap();
            let (lo, hi) = bounds(&m);
            assert_eq!((lo.x, lo.z, hi.z), (x, 5.0, 5.0), "{ibm}");
        }
        let bad_joint = file("").replace(r#""joints": [2, 3]"#, r#""joints": [2]"#);
        std::fs::write(&path, &bad_joint).unwrap();
        let e = import(&path).unwrap_err().to_string();
        assert!(e.contains("bound to joint 1, but the skin has 1"), "{e}");
        // Inverse bind matrices are counted before they are read.
        let short = bad_joint.replace(
            r#""joints": [2]"#,
            r#""joints": [2], "inverseBindMatrices": 3"#,
        );
        std::fs::write(&path, short).unwrap();
        let e = import(&path).unwrap_err().to_string();
        assert!(
            e.contains("skin 0: 2 inverse bind matrices for 1 joints"),
            "{e}"
        );
        // A skinned node reached down two paths is cooked once, where its joints put it.
        let twice = file("")
            .replace(r#""nodes": [0, 1]}]"#, r#""nodes": [0, 1, 4]}]"#)
            .replace(
                r#"{"translation": [4, 0, 0]}],"#,
                r#"{"translation": [4, 0, 0]}, {"translation": [9, 9, 9], "children": [0]}],"#,
            );
        assert!(twice.contains("[0, 1, 4]") && twice.contains("[9, 9, 9]"));
        std::fs::write(&path, twice).unwrap();
        let m = import(&path).unwrap();
        assert_eq!(m.tri_part.len(), 1);
        assert_eq!(bounds(&m).0.x, 3.5);
        // Instanced too: cooked once, said.
        let instanced = file("")
            .replace(
                r#""skin": 0, "translation": [100, 0, 0]"#,
                r#""skin": 0, "translation": [100, 0, 0], "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": 4}}}"#,
            )
            .replace(
                r#""count": 2, "type": "MAT4"}"#,
                r#""count": 2, "type": "MAT4"}, {"bufferView": 0, "componentType": 5126, "count": 2, "type": "VEC3"}"#,
            );
        assert!(
            instanced.contains("TRANSLATION")
                && instanced.contains(r#""count": 2, "type": "VEC3""#)
        );
        std::fs::write(&path, instanced).unwrap();
        let m = import(&path).unwrap();
        assert_eq!(m.tri_part.len(), 1);
        assert!(
            m.warnings
                .iter()
                .any(|w| w.message.contains("is skinned and instanced")),
            "{:?}",
            m.warnings
        );
        // A primitive without joints on a skinned node stays where the node puts it.
        let bare = file("").replace(r#""JOINTS_0": 1, "WEIGHTS_0": 2"#, r#""NORMAL": 0"#);
        std::fs::write(&path, bare).unwrap();
        let m = import(&path).unwrap();
        assert_eq!(bounds(&m).0.x, 100.0);
        assert!(
            m.warnings
                .iter()
                .any(|w| w.message.contains("without JOINTS_0 and WEIGHTS_0")),
            "{:?}",
            m.warnings
        );
    }

    /// A POSITION accessor without `min` and `max` (exporters leave them out) is read, with a
    /// warning; it was refused, two errors per primitive.
    #[test]
    fn positions_without_bounds_are_read() {
        let dir = tempfile::tempdir().unwrap();
        let tri = triangle_bytes();
        let view = r#"{"buffer": 0, "byteLength": 36}"#;
        let path = write_gltf(dir.path(), &tri, view, "");
        let text = String::from_utf8(std::fs::read(&path).unwrap())
            .unwrap()
            .replace(r#", "min": [0, 0, 0], "max": [1, 1, 0]"#, "");
        assert!(!text.contains("min"));
        std::fs::write(&path, text).unwrap();
        let m = import(&path).unwrap();
        assert_eq!(m.tri_part.len(), 1);
        assert!(
            m.warnings.iter().any(|w| w
                .message
                .contains("1 primitive(s) whose POSITION accessor lacks the min and max")),
            "{:?}",
            m.warnings
        );
    }

    /// `KHR_materials_emissive_strength` scales the emissive factor (Blender writes a strength
    /// over 1 so); a negative one is refused.
    #[test]
    fn emissive_strength_scales_the_emissive_factor() {
        let dir = tempfile::tempdir().unwrap();
        let tri = triangle_bytes();
        let view = r#"{"buffer": 0, "byteLength": 36}"#;
        let path = write_gltf(dir.path(), &tri, view, "");
        let json = String::from_utf8(std::fs::read(&path).unwrap()).unwrap();
        let with = |material: &str| {
            let text = json
                .replace(
                    r#""attributes": {"POSITION": 0}"#,
                    r#""attributes": {"POSITION": 0}, "material": 0"#,
                )
                .replace(
                    r#""scene": 0,"#,
                    &format!(r#""materials": [{material}], "scene": 0,"#),
                );
            std::fs::write(&path, text).unwrap();
            import(&path)
        };
        let plain = with(r#"{"emissiveFactor": [1, 0.5, 0]}"#).unwrap();
        assert_eq!(plain.materials[0].emissive, [1.0, 0.5, 0.0]);
        let strong = with(
            r#"{"emissiveFactor": [1, 0.5, 0],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5}}}"#,
        )
        .unwrap();
        assert_eq!(strong.materials[0].emissive, [5.0, 2.5, 0.0]);
        let e = with(
            r#"{"emissiveFactor": [1, 0.5, 0],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": -2}}}"#,
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("emissiveStrength is -2"), "{e}");
        // An unlit material (a scan's) is named in a warning: it is lit as any other.
        let scan = with(r#"{"name": "scan", "extensions": {"KHR_materials_unlit": {}}}"#).unwrap();
        assert!(
            scan.warnings.iter().any(|w| w
                .message
                .contains(r#"1 material(s) marked unlit (KHR_materials_unlit: "scan")"#)),
            "{:?}",
            scan.warnings
        );
        assert!(!plain.warnings.iter().any(|w| w.message.contains("unlit")));
    }

    /// Compressed views that lie or do not decode are errors naming the view, never a panic
    /// or a read past the data.
    #[test]
    fn malformed_meshopt_views_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let cases = [
            // Not a meshopt stream (header byte 0).
            (
                r#""count": 3, "byteStride": 12, "mode": "ATTRIBUTES""#,
                "does not decode",
            ),
            // A stride the attribute codec cannot have.
            (
                r#""count": 2, "byteStride": 18, "mode": "ATTRIBUTES""#,
                "byteStride 18",
            ),
            // More elements than the view holds.
            (
                r#""count": 4, "byteStride": 12, "mode": "ATTRIBUTES""#,
                "do not fill",
            ),
            (
                r#""count": 3, "byteStride": 12, "mode": "WAVELET""#,
                "WAVELET",
            ),
            (
                r#""count": 3, "byteStride": 12, "mode": "ATTRIBUTES", "filter": "OCTAHEDRAL""#,
                "filter",
            ),
        ];
        for (ext, want) in cases {
            let view = format!(
                r#"{{"buffer": 1, "byteLength": 36, "extensions": {{"EXT_meshopt_compression":
                    {{"buffer": 0, "byteLength": 40, {ext}}}}}}}"#
            );
            let path = write_gltf(
                dir.path(),
                &[0u8; 40],
                &view,
                r#""extensionsRequired": ["EXT_meshopt_compression"],"#,
            );
            let e = import(&path).unwrap_err().to_string();
            assert!(
                e.contains("buffer view 0") && e.contains(want),
                "{ext}: {e}"
            );
        }
        // Compressed bytes past the end of their buffer.
        let view = r#"{"buffer": 1, "byteLength": 36, "extensions": {"EXT_meshopt_compression":
            {"buffer": 0, "byteOffset": 30, "byteLength": 40, "count": 3, "byteStride": 12,
            "mode": "ATTRIBUTES"}}}"#;
        let path = write_gltf(dir.path(), &[0u8; 40], view, "");
        let e = import(&path).unwrap_err().to_string();
        assert!(e.contains("outside buffer 0"), "{e}");
        // A view whose own stride is not the stride it was compressed with.
        let view = r#"{"buffer": 1, "byteLength": 36, "byteStride": 12, "extensions":
            {"EXT_meshopt_compression": {"buffer": 0, "byteLength": 40, "count": 9,
            "byteStride": 4, "mode": "ATTRIBUTES"}}}"#;
        let path = write_gltf(dir.path(), &[0u8; 40], view, "");
        let e = import(&path).unwrap_err().to_string();
        assert!(e.contains("byteStride 4 differs"), "{e}");
    }

    /// Hostile or odd files around instancing and buffers: an instance count past the cap
    /// (an accessor of sparse data needs no bytes behind it) is refused before anything is
    /// allocated; instances without a transform place the mesh once; a buffer uri that does
    /// not percent-decode to text (gltf's reader panicked on it) is an error naming it.
    #[test]
    fn instancing_caps_and_buffer_uris() {
        let dir = tempfile::tempdir().unwrap();
        let tri = triangle_bytes();
        let view = r#"{"buffer": 0, "byteLength": 36}"#;
        let path = write_gltf(dir.path(), &tri, view, "");
        let json = std::fs::read_to_string(&path).unwrap();
        let instanced = |attributes: &str, accessor: &str| {
            json.replace(
                r#""nodes": [{"mesh": 0}]"#,
                &format!(
                    r#""nodes": [{{"mesh": 0, "extensions": {{"EXT_mesh_gpu_instancing":
                        {{"attributes": {attributes}}}}}}}]"#
                ),
            )
            .replace(r#""accessors": ["#, &format!(r#""accessors": [{accessor}"#))
        };
        // Accessor 0 is the instances' (sparse, no bytes), so POSITION moves to 1.
        let many = instanced(
            r#"{"TRANSLATION": 0}"#,
            r#"{"componentType": 5126, "count": 2000000, "type": "VEC3", "sparse":
                {"count": 1, "indices": {"bufferView": 0, "componentType": 5125},
                "values": {"bufferView": 0}}},"#,
        )
        .replace(r#""POSITION": 0"#, r#""POSITION": 1"#);
        std::fs::write(&path, many).unwrap();
        let e = import(&path).unwrap_err().to_string();
        assert!(e.contains("2000000 instances"), "{e}");
        let ids_only = instanced(r#"{"_ID": 0}"#, "");
        std::fs::write(&path, ids_only).unwrap();
        assert_eq!(import(&path).unwrap().tri_part.len(), 1);
        std::fs::write(&path, json.replace("b.bin", "%FF.bin")).unwrap();
        let e = import(&path).unwrap_err().to_string();
        assert!(e.contains("%FF.bin") && e.contains("buffer 0"), "{e}");
    }

    /// Writes `t.gltf`: one triangle whose material is `material`, with one texture and one
    /// image, the file requiring `extension`.
    fn textured_triangle(
        dir: &Path,
        extension: &str,
        material: &str,
        texture: &str,
        image: &str,
    ) -> std::path::PathBuf {
        let tri = triangle_bytes();
        std::fs::write(dir.join("b.bin"), &tri).unwrap();
        let json = format!(
            r#"{{"asset": {{"version": "2.0"}},
            "extensionsUsed": ["{extension}"], "extensionsRequired": ["{extension}"],
            "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
            "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "material": 0}}]}}],
            "materials": [{material}], "textures": [{texture}], "images": [{{"uri": "{image}"}}],
            "accessors": [{{"bufferView": 0, "componentType": 5126, "count": 3,
                "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}}],
            "bufferViews": [{{"buffer": 0, "byteLength": 36}}],
            "buffers": [{{"byteLength": 36, "uri": "b.bin"}}]}}"#
        );
        let path = dir.join("t.gltf");
        std::fs::write(&path, json).unwrap();
        path
    }

    /// [`textured_triangle`] whose base colour is the WebP image at `uri`, the file requiring
    /// `EXT_texture_webp`.
    fn webp_triangle(dir: &Path, uri: &str) -> std::path::PathBuf {
        textured_triangle(
            dir,
            "EXT_texture_webp",
            r#"{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}"#,
            r#"{"extensions": {"EXT_texture_webp": {"source": 0}}}"#,
            uri,
        )
    }

    /// Images are found as buffers are: percent-decoded, as written, or by a `file:` uri.
    #[test]
    fn image_uris_resolve_like_buffer_uris() {
        let dir = tempfile::tempdir().unwrap();
        let sub = dir.path().join("my textures");
        std::fs::create_dir(&sub).unwrap();
        let file = sub.join("design.webp");
        image::RgbaImage::from_pixel(2, 2, image::Rgba([9, 8, 7, 255]))
            .save(&file)
            .unwrap();
        let abs = file.to_str().unwrap().replace(' ', "%20");
        for uri in [
            "my textures/design.webp".to_string(),
            "my%20textures/design.webp".to_string(),
            format!("file://{abs}"),
            format!("file://localhost{abs}"),
        ] {
            let path = webp_triangle(dir.path(), &uri);
            let m = import(&path).unwrap();
            assert_eq!(
                m.materials[0].diffuse_texture,
                Some(ImageRef::File(file.clone())),
                "{uri}"
            );
        }
        // An absolute uri from the exporting machine: the file of that name beside the glTF.
        std::fs::copy(&file, dir.path().join("Beside.webp")).unwrap();
        let path = webp_triangle(dir.path(), "file:///C:/Users/me/export/beside.webp");
        assert_eq!(
            import(&path).unwrap().materials[0].diffuse_texture,
            Some(ImageRef::File(dir.path().join("Beside.webp")))
        );
        // A file of the encoded name beside the decoded one does not hide it; alone, it is
        // read (a name with `%` written as is).
        let encoded = dir.path().join("my%20textures");
        std::fs::create_dir(&encoded).unwrap();
        std::fs::write(encoded.join("design.webp"), b"not the design").unwrap();
        let path = webp_triangle(dir.path(), "my%20textures/design.webp");
        assert_eq!(
            import(&path).unwrap().materials[0].diffuse_texture,
            Some(ImageRef::File(file.clone()))
        );
        // Without the decoded name exactly, the literal one wins over a looser match of the
        // decoded (a file of its last component beside the glTF).
        std::fs::rename(&file, dir.path().join("design.webp")).unwrap();
        assert_eq!(
            import(&path).unwrap().materials[0].diffuse_texture,
            Some(ImageRef::File(encoded.join("design.webp")))
        );
    }

    /// A texture given only as WebP (`EXT_texture_webp`, required: no PNG beside it, as
    /// gltf-transform's `webp` writes it) is read, and decodes.
    #[test]
    fn webp_textures_are_read_where_a_file_requires_them() {
        let dir = tempfile::tempdir().unwrap();
        let design = image::RgbaImage::from_fn(4, 2, |x, y| {
            image::Rgba([200, 40 * x as u8, 90 * y as u8, 255])
        });
        design.save(dir.path().join("design.webp")).unwrap();
        let path = webp_triangle(dir.path(), "design.webp");
        let m = import(&path).unwrap();
        let texture = m.materials[0].diffuse_texture.clone().expect("a design");
        assert_eq!(texture, ImageRef::File(dir.path().join("design.webp")));
        let decoded = crate::textures::decode(&texture).unwrap().to_rgba8();
        assert_eq!(decoded, design);
    }

    /// `alphaMode: BLEND` makes glass only where light may pass: a base colour alpha below 1
    /// or a colour texture; an opaque blended material (as exporters mark stone) is not.
    #[test]
    fn only_a_blended_material_that_lets_light_through_is_glass() {
        let dir = tempfile::tempdir().unwrap();
        image::RgbaImage::from_pixel(2, 2, image::Rgba([9, 9, 9, 128]))
            .save(dir.path().join("d.png"))
            .unwrap();
        let glass = |material: &str| {
            let path = textured_triangle(
                dir.path(),
                "KHR_texture_transform",
                material,
                r#"{"source": 0}"#,
                "d.png",
            );
            import(&path).unwrap().materials[0]
                .transmission
                .glass_reason()
        };
        assert_eq!(glass(r#"{"name": "Stone", "alphaMode": "BLEND"}"#), None);
        assert_eq!(
            glass(
                r#"{"name": "Stone", "alphaMode": "BLEND",
                    "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}}"#
            ),
            None
        );
        for see_through in [
            r#"{"name": "Glass", "alphaMode": "BLEND",
                "pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.4, 0.8, 0.3]}}"#,
            r#"{"name": "Glass", "alphaMode": "BLEND",
                "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}"#,
        ] {
            assert_eq!(
                glass(see_through).as_deref(),
                Some("glTF alpha mode BLEND"),
                "{see_through}"
            );
        }
    }

    /// A specular-glossiness material (older exporters write only that, and require it) gives
    /// its diffuse colour and texture, and a blended one is glass of that colour; before, the
    /// file was refused, and read past the extension every such material was white.
    #[test]
    fn specular_glossiness_materials_give_their_diffuse_colour() {
        let dir = tempfile::tempdir().unwrap();
        image::RgbaImage::from_pixel(2, 2, image::Rgba([9, 9, 9, 255]))
            .save(dir.path().join("d.png"))
            .unwrap();
        let path = textured_triangle(
            dir.path(),
            "KHR_materials_pbrSpecularGlossiness",
            r#"{"name": "vitrail", "alphaMode": "BLEND", "extensions": {
                "KHR_materials_pbrSpecularGlossiness": {"diffuseFactor": [0.8, 0.1, 0.2, 0.4],
                "specularFactor": [0.5, 0.5, 0.5], "glossinessFactor": 0.9,
                "diffuseTexture": {"index": 0}}}}"#,
            r#"{"source": 0}"#,
            "d.png",
        );
        let m = import(&path).unwrap();
        let mat = &m.materials[0];
        assert_eq!(mat.diffuse, [0.8, 0.1, 0.2]);
        assert_eq!(mat.specular, [0.5, 0.5, 0.5]);
        assert_eq!(
            mat.diffuse_texture,
            Some(ImageRef::File(dir.path().join("d.png")))
        );
        assert!(mat.transmission.glass_reason().is_some());
        assert_eq!(mat.transmission.filter, Some([0.8, 0.1, 0.2]));
        assert_eq!(mat.transmission.opacity, Some(0.4));
    }
}
