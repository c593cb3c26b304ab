//! `cooker diff <a.pack> <b.pack> [--json] [--tolerance-lsb LSB] [--max-position-delta D]`
//!
//! Compares two packs section by section and explains the differences: geometry (largest
//! position change, material ID changes, normals, tangents and texture coordinates; when the two meshes are not in the same order, as
//! exports from two tools rarely are, triangles matched in any order and corner turn) and, per
//! texture and mip level, the largest error in 8-bit steps, PSNR and FLIP mean of the decoded
//! texels (whatever each pack stores them in: RGBA8 or a block format). Exit 0 when within
//! the thresholds (identical by default), 1 otherwise, so a user's CI can gate on it.

use std::collections::BTreeMap;
use std::path::PathBuf;

use pack::{Pack, SectionRole, TextureRole};
use serde_json::{Value, json};

use crate::exit::{FOUND_PROBLEMS, OK, Outcome, UsageError};

mod surface;
mod triangles;

use triangles::{Shading, ShadingChanges, ShadingTolerance, corner_delta};

#[derive(clap::Args)]
pub struct Args {
    /// The reference pack.
    a: PathBuf,
    /// The pack compared against it.
    b: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    json: bool,
    /// Largest texel difference accepted in any texture level, in 8-bit steps (LSB). Without
    /// any threshold the packs must be identical byte for byte; any threshold, 0 included,
    /// compares what they hold (decoded texels, vertices), not how it is stored.
    /// `--max-error` is the old spelling.
    #[arg(
        long = "tolerance-lsb",
        alias = "max-error",
        value_name = "LSB",
        allow_negative_numbers = true
    )]
    tolerance_lsb: Option<f64>,
    /// Largest vertex position change accepted (scene units, per axis); default: identical.
    /// Triangulated another way, a surface is matched to within this or 4 f32 ulps of the
    /// mesh's largest coordinate, whichever is larger; a window frame to within this or 4 ulps
    /// of its own.
    /// Given, the same triangles in another vertex or triangle order are accepted too, and
    /// cameras, window frames and the light the cook placed from the geometry may move with it.
    #[arg(long, value_name = "D", allow_negative_numbers = true)]
    max_position_delta: Option<f64>,
    /// Largest turn of a vertex normal or tangent accepted, in degrees; default: 0.1 with
    /// `--max-position-delta` (a 16-bit octahedral normal is within 0.01), identical without.
    #[arg(long, value_name = "DEG", allow_negative_numbers = true)]
    max_normal_delta_deg: Option<f64>,
    /// Largest change of a texture coordinate accepted (per axis); default: 1e-4 with
    /// `--max-position-delta` (under half a texel of an 8192 texture), identical without.
    #[arg(long, value_name = "D", allow_negative_numbers = true)]
    max_uv_delta: Option<f64>,
}

/// [`Args::max_normal_delta_deg`]'s default with `--max-position-delta`.
const DEFAULT_NORMAL_DELTA_DEG: f64 = 0.1;
/// [`Args::max_uv_delta`]'s default with `--max-position-delta`.
const DEFAULT_UV_DELTA: f64 = 1e-4;

/// What differs about one texture level.
struct LevelDiff {
    level: usize,
    width: u32,
    height: u32,
    max_error: u32,
    psnr: f64,
    flip_mean: Option<f32>,
}

/// One texture of a, or of b alone, as the diff compared it: its name in each, the state
/// (`compared`, `compared from a level on` where a size cap left one chain the other's tail,
/// `sizes differ`, `only in a`, `only in b`), each pack's `[width, height, mips]` (null for
/// the pack without it) and the levels compared.
struct TextureDiff {
    name: String,
    name_in_b: Option<String>,
    state: &'static str,
    size_a: Option<[u32; 3]>,
    size_b: Option<[u32; 3]>,
    levels: Vec<LevelDiff>,
}

impl TextureDiff {
    fn size(t: &pack::Texture) -> [u32; 3] {
        [t.width, t.height, t.mips.len() as u32]
    }

    fn of(
        a: &pack::Texture,
        b: &pack::Texture,
        state: &'static str,
        levels: Vec<LevelDiff>,
    ) -> Self {
        TextureDiff {
            name: a.name.clone(),
            name_in_b: Some(b.name.clone()),
            state,
            size_a: Some(Self::size(a)),
            size_b: Some(Self::size(b)),
            levels,
        }
    }

    /// A texture only one pack holds: a's where `in_a`, else b's.
    fn only(t: &pack::Texture, in_a: bool) -> Self {
        TextureDiff {
            name: t.name.clone(),
            name_in_b: (!in_a).then(|| t.name.clone()),
            state: if in_a { "only in a" } else { "only in b" },
            size_a: in_a.then(|| Self::size(t)),
            size_b: (!in_a).then(|| Self::size(t)),
            levels: Vec::new(),
        }
    }

    /// Both packs hold it at one size with every level's texels equal.
    fn texels_equal(&self) -> bool {
        self.state == "compared" && self.levels.iter().all(|d| d.max_error == 0)
    }
}

fn level_diff(role: TextureRole, level: usize, w: u32, h: u32, a: &[u8], b: &[u8]) -> LevelDiff {
    // A projector's alpha is never sampled (the light is its colour), and its block-compressed
    // copy is encoded opaque: an RGBA8 pack and a BC one differed by 255 there, always.
    let channels = if role == TextureRole::Projector { 3 } else { 4 };
    let mut max_error = 0u32;
    let mut sq = 0f64;
    let mut n = 0usize;
    for (x, y) in a.chunks_exact(4).zip(b.chunks_exact(4)) {
        for c in 0..channels {
            let d = x[c].abs_diff(y[c]) as u32;
            max_error = max_error.max(d);
            sq += (d * d) as f64;
        }
        n += channels;
    }
    let mse = sq / n.max(1) as f64;
    let psnr = if mse == 0.0 {
        f64::INFINITY
    } else {
        10.0 * (255.0f64 * 255.0 / mse).log10()
    };
    // FLIP models human perception of colour images; it says nothing useful about normal maps,
    // and needs a few texels of neighbourhood.
    let flip_mean = (role != TextureRole::Normal && w >= 8 && h >= 8 && max_error > 0).then(|| {
        let rgb = |src: &[u8]| -> Vec<u8> {
            src.chunks_exact(4)
                .flat_map(|p| [p[0], p[1], p[2]])
                .collect()
        };
        let ra = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(a));
        let rb = nv_flip::FlipImageRgb8::with_data(w, h, &rgb(b));
        let err = nv_flip::flip(ra, rb, nv_flip::DEFAULT_PIXELS_PER_DEGREE);
        nv_flip::FlipPool::from_image(&err).mean()
    });
    let flip_mean = if max_error == 0 { Some(0.0) } else { flip_mean };
    LevelDiff {
        level,
        width: w,
        height: h,
        max_error,
        psnr,
        flip_mean,
    }
}

fn positions(pack: &Pack, mesh: &pack::Mesh) -> Vec<[f32; 3]> {
    let l = &mesh.layout;
    pack.vertex_bytes(mesh)
        .chunks_exact(l.stride as usize)
        .map(|v| l.position(v).expect("validated layout"))
        .collect()
}

fn shading(pack: &Pack, mesh: &pack::Mesh) -> Vec<Shading> {
    let l = &mesh.layout;
    pack.vertex_bytes(mesh)
        .chunks_exact(l.stride as usize)
        .map(|v| {
            let d = l.decode(v);
            Shading {
                normal: d.normal,
                tangent: d.tangent,
                uv: d.uv,
            }
        })
        .collect()
}

/// The shading attributes one mesh's layout has and the other's lacks, as problems: a mesh
/// that lost its normals or texture coordinates renders otherwise whatever the values.
fn attributes_differ(ma: &pack::Mesh, mb: &pack::Mesh) -> Vec<String> {
    use pack::Semantic::{Normal, Tangent, TexCoord};
    [
        (Normal, "normals"),
        (Tangent, "tangents"),
        (TexCoord, "texture coordinates"),
    ]
    .into_iter()
    .filter_map(|(s, what)| {
        match (
            ma.layout.attribute(s).is_some(),
            mb.layout.attribute(s).is_some(),
        ) {
            (true, false) => Some(format!("mesh {:?}: {what} in a, none in b", ma.name)),
            (false, true) => Some(format!("mesh {:?}: {what} in b, none in a", ma.name)),
            _ => None,
        }
    })
    .collect()
}

fn colours(pack: &Pack, mesh: &pack::Mesh) -> Vec<[u8; 4]> {
    let l = &mesh.layout;
    pack.vertex_bytes(mesh)
        .chunks_exact(l.stride as usize)
        .map(|v| l.colour(v))
        .collect()
}

/// Each vertex's material as a key shared by both packs: their material tables may list the
/// same names in another order.
fn material_keys(pack: &Pack, mesh: &pack::Mesh, names: &MaterialNames) -> Vec<u32> {
    let l = &mesh.layout;
    let materials = &pack.toc().materials;
    pack.vertex_bytes(mesh)
        .chunks_exact(l.stride as usize)
        .map(|v| {
            let id = l.material_id(v).expect("validated layout") as usize;
            materials
                .get(id)
                .map_or(u32::MAX, |m| names[m.name.as_str()])
        })
        .collect()
}

type MaterialNames<'a> = BTreeMap<&'a str, u32>;

fn mesh_triangles(
    pack: &Pack,
    mesh: &pack::Mesh,
    names: &MaterialNames,
) -> Vec<triangles::Triangle> {
    let (p, m) = (positions(pack, mesh), material_keys(pack, mesh, names));
    let s = shading(pack, mesh);
    pack.indices(mesh)
        .chunks_exact(3)
        .map(|t| triangles::Triangle {
            corners: [0, 1, 2].map(|k| p[t[k] as usize]),
            materials: [0, 1, 2].map(|k| m[t[k] as usize]),
            shading: [0, 1, 2].map(|k| s[t[k] as usize]),
        })
        .collect()
}

/// How far apart two directions may be when geometry may move (positions differ at all).
fn direction_tolerance(max_delta: f64) -> f64 {
    if max_delta > 0.0 { 1e-3 } else { 0.0 }
}

/// How far a guessed camera's clip planes may move per unit of `--max-position-delta`: the
/// far plane is three times the model's bounding-box diagonal, which moves by at most
/// `2 * sqrt(3)` times the delta (each end by the delta on every axis). A hall scaled by 1e-4
/// (2 mm at its ground's edge) moved its far plane 17 mm, and the cameras differed.
const CLIP_PER_DELTA: f64 = 6.0 * SQRT_3;

/// How far a guessed camera's position and target may move per unit of
/// `--max-position-delta`: a view stands up to the model's bounding-box diagonal from a point
/// of the box, so it moves by the delta plus the diagonal's `2 * sqrt(3)` times it. Held to
/// the delta itself, a gltfpack-quantized export (vertices 1.2e-4 off) failed a 2e-4 diff on
/// a camera moved 4.1e-4, its geometry passing.
const CAMERA_PER_DELTA: f64 = 1.0 + 2.0 * SQRT_3;

const SQRT_3: f64 = 1.732_050_807_568_877_2;

/// How far rounding alone may move a coordinate, relative to the largest one it is computed
/// with: 4 f32 ulps.
const ROUNDING_ULPS: f64 = 4.0 * f32::EPSILON as f64;

/// [`ROUNDING_ULPS`] of the largest magnitude among `coords`.
fn rounding_of<'a>(coords: impl IntoIterator<Item = &'a f32>) -> f64 {
    ROUNDING_ULPS
        * coords
            .into_iter()
            .fold(0.0f64, |m, &c| m.max((c as f64).abs()))
}

/// Whether the camera presets differ by more than geometry moved `max_delta` explains: what
/// differs, with the names of the presets that moved, were renamed, added or dropped (every
/// one: a re-export that moves three views is not one change). Presets are matched by name,
/// so one renamed preset does not make every other one differ and hide one that moved; the
/// same presets in another order (the viewer's keys 1–9) differ, every name listed.
fn cameras_differ(
    a: &[pack::Camera],
    b: &[pack::Camera],
    max_delta: f64,
) -> Option<(String, Vec<String>)> {
    let mut found: Vec<(String, String)> = Vec::new();
    // A name's k-th preset pairs with the other's k-th of that name (names may repeat).
    fn partner<'a>(
        list: &[pack::Camera],
        i: usize,
        other: &'a [pack::Camera],
    ) -> Option<&'a pack::Camera> {
        let name = &list[i].name;
        let k = list[..i].iter().filter(|c| c.name == *name).count();
        other.iter().filter(|c| c.name == *name).nth(k)
    }
    for (list, other, side) in [(a, b, "a"), (b, a, "b")] {
        for (i, c) in list.iter().enumerate() {
            if partner(list, i, other).is_none() {
                found.push((c.name.clone(), format!("{:?} only in {side}", c.name)));
            }
        }
    }
    for (x, y) in (0..a.len()).filter_map(|i| Some((&a[i], partner(a, i, b)?))) {
        let points = corner_delta(&x.position, &y.position).max(corner_delta(&x.target, &y.target));
        let clip = (x.near as f64 - y.near as f64)
            .abs()
            .max((x.far as f64 - y.far as f64).abs());
        let up = corner_delta(&x.up, &y.up);
        if points > CAMERA_PER_DELTA * max_delta
            || clip > CLIP_PER_DELTA * max_delta
            || up > direction_tolerance(max_delta)
            || x.fov_y != y.fov_y
        {
            found.push((
                x.name.clone(),
                format!(
                    "{:?}: position or target moved by {points:.3e}, clip planes by \
                     {clip:.3e}, up by {up:.3e}, field of view {} and {} degrees",
                    x.name, x.fov_y, y.fov_y
                ),
            ));
        }
    }
    let names = |c: &[pack::Camera]| c.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
    if found.is_empty() && names(a) != names(b) {
        let order = format!(
            "the same presets in another order: {:?} in a, {:?} in b",
            names(a),
            names(b)
        );
        return Some((order, names(a)));
    }
    if found.is_empty() {
        return None;
    }
    let (names, what): (Vec<String>, Vec<String>) = found.into_iter().unzip();
    Some((what.join("; "), names))
}

/// How far a guessed sun's intensity may move with its direction: it is `0.85 / (albedo *
/// max(cos, 0.2))` of the angle to the vertical, so a direction moved by `t` per axis changes
/// it by at most `t / 0.2`, relatively.
const SUN_INTENSITY_PER_DIRECTION: f64 = 5.0;

/// Whether the two packs' lights differ by more than geometry moved `max_delta` explains, and
/// if so, what (an empty string where any difference counts). The cook places a guessed
/// light from the geometry, as it places cameras and window frames: a sun's direction and
/// exposure follow the windows and the floor, a file's lamp's radius and intensity follow how
/// far its light travels. So, with `--max-position-delta`, a lamp may move that far, its
/// radius too, directions by the directions' tolerance, and the intensity by what those
/// moves can change: a lamp's is its exposure times the squared distance its light travels,
/// which is at least the distance to the nearest window of `a`, and which each end of the
/// path moves by at most `max_delta` per axis. Colour, kind and the sun's size come from the
/// file or the manifest and must be equal. Without `--max-position-delta`, any difference
/// counts.
fn light_differs(ta: &pack::Toc, tb: &pack::Toc, max_delta: f64) -> Option<String> {
    let (a, b) = match (&ta.light, &tb.light) {
        (Some(a), Some(b)) => (a, b),
        (None, None) => return None,
        _ => return Some(String::new()),
    };
    if a == b {
        return None;
    }
    if max_delta <= 0.0 || a.colour != b.colour {
        return Some(String::new());
    }
    let turn = direction_tolerance(max_delta);
    let exposure = turn * SUN_INTENSITY_PER_DIRECTION;
    let (moved, intensity_bound) = match (&a.kind, &b.kind) {
        (
            pack::LightKind::Directional {
                direction: d,
                angular_size: s,
            },
            pack::LightKind::Directional {
                direction: e,
                angular_size: t,
            },
        ) => {
            if s != t {
                return Some(String::new());
            }
            let by = corner_delta(d, e);
            (
                (by > turn).then(|| format!(" (its direction moved by {by:.3e} > {turn:.0e})")),
                exposure,
            )
        }
        (
            pack::LightKind::Point { .. } | pack::LightKind::Spot { .. },
            pack::LightKind::Point { .. } | pack::LightKind::Spot { .. },
        ) => {
            // A spot's cone comes from the model's file, not the geometry: it must be equal.
            let (Some((p, r)), Some((q, s))) = (a.kind.lamp(), b.kind.lamp()) else {
                return Some(String::new());
            };
            let (p, q) = (&p, &q);
            if a.kind.cone() != b.kind.cone() {
                return Some(String::new());
            }
            let by = corner_delta(p, q).max((r as f64 - s as f64).abs());
            // Both ends of the light's path move, each by `max_delta` on every axis.
            let reach = ta
                .windows
                .iter()
                .map(|w| distance_to_window(p, w))
                .fold(f64::INFINITY, f64::min);
            let stretch = 1.0 + 2.0 * SQRT_3 * max_delta / reach;
            (
                (by > max_delta).then(|| {
                    format!(" (its position or radius moved by {by:.3e} > {max_delta:.3e})")
                }),
                (1.0 + exposure) * stretch * stretch - 1.0,
            )
        }
        _ => return Some(String::new()),
    };
    if moved.is_some() {
        return moved;
    }
    let (i, j) = (a.intensity as f64, b.intensity as f64);
    let change = if i == j {
        0.0
    } else {
        (j / i).max(i / j) - 1.0
    };
    // 1e-6 for the f32 the intensity is stored in; NaN (zero against another) is a change.
    if change <= intensity_bound + 1e-6 {
        None
    } else {
        Some(format!(
            " (its intensity by {change:.3e} relatively, more than the {intensity_bound:.3e} \
             the geometry's moves allow)"
        ))
    }
}

/// The distance from `p` to a window's rectangle.
fn distance_to_window(p: &[f32; 3], w: &pack::Window) -> f64 {
    let v = |a: &[f32; 3]| glam::DVec3::from(a.map(f64::from));
    let (o, u, t) = (v(&w.origin), v(&w.u_axis), v(&w.v_axis));
    let d = v(p) - o;
    let along = |axis: glam::DVec3| {
        let len2 = axis.length_squared();
        if len2 > 0.0 {
            axis * (d.dot(axis) / len2).clamp(0.0, 1.0)
        } else {
            glam::DVec3::ZERO
        }
    };
    // The rectangle's axes are at right angles, so the nearest point clamps each on its own.
    (d - along(u) - along(t)).length()
}

/// The window frames of the two packs, each of a's paired with the nearest of b's not yet
/// taken (glass of the same source materials first): a model exported with its objects in
/// another order lists its windows in another order, and compared by index every frame had
/// moved. Returns what differs, the first few pairs named.
fn windows_differ(ta: &pack::Toc, tb: &pack::Toc, max_delta: f64, exact: bool) -> Option<String> {
    let (a, b) = (&ta.windows, &tb.windows);
    // Material tables may be ordered differently: compare names.
    let material = |t: &pack::Toc, w: &pack::Window| {
        t.materials.get(w.material as usize).map(|m| m.name.clone())
    };
    if a.len() != b.len() {
        return Some(format!("{} in a, {} in b", a.len(), b.len()));
    }
    let moved = |x: &pack::Window, y: &pack::Window| {
        corner_delta(&x.origin, &y.origin)
            .max(corner_delta(&x.u_axis, &y.u_axis))
            .max(corner_delta(&x.v_axis, &y.v_axis))
    };
    let mut taken = vec![false; b.len()];
    let mut differ = Vec::new();
    for (i, x) in a.iter().enumerate() {
        let j = (0..b.len())
            .filter(|&j| !taken[j])
            .min_by(|&j, &k| {
                let key =
                    |y: &pack::Window| (y.source_materials != x.source_materials, moved(x, y));
                let (p, q) = (key(&b[j]), key(&b[k]));
                p.0.cmp(&q.0).then(p.1.total_cmp(&q.1))
            })
            .expect("as many windows in b");
        taken[j] = true;
        let y = &b[j];
        let points = moved(x, y);
        let normal = corner_delta(&x.normal, &y.normal);
        // The frame is fitted to the glass's triangles in their order: another order (the
        // FIFO cache optimizer's) rounds it a few ulps away, as a surface triangulated another
        // way does. Without --max-position-delta, as there, any move counts.
        let (reach, turn) = if exact {
            (max_delta, direction_tolerance(max_delta))
        } else {
            let frame = [x.origin, x.u_axis, x.v_axis];
            (
                max_delta.max(rounding_of(frame.iter().flatten())),
                direction_tolerance(max_delta).max(ROUNDING_ULPS),
            )
        };
        if points > reach
            || normal > turn
            || material(ta, x) != material(tb, y)
            || x.source_materials != y.source_materials
        {
            let name = |t: &pack::Toc, w: &pack::Window| material(t, w).unwrap_or_default();
            differ.push(format!(
                "window {i} ({:?}) and b's window {j} ({:?}): corner or edges moved by \
                 {points:.3e}, normal by {normal:.3e}, glass {:?} and {:?}",
                name(ta, x),
                name(tb, y),
                x.source_materials,
                y.source_materials
            ));
        }
    }
    const SHOWN: usize = 3;
    match differ.len() {
        0 => None,
        n if n <= SHOWN => Some(differ.join("; ")),
        n => Some(format!(
            "{}; and {} more of {n}",
            differ[..SHOWN].join("; "),
            n - SHOWN
        )),
    }
}

/// How meshes' geometry is compared.
struct Geometry<'a> {
    names: &'a MaterialNames<'a>,
    max_delta: f64,
    /// No --max-position-delta: any difference, order included, is a problem.
    exact: bool,
    shading: ShadingTolerance,
}

impl Geometry<'_> {
    /// Two meshes not in the same vertex or triangle order (another tool, or an optimizer that
    /// changed): their triangles matched as sets, and what is left measured against the other
    /// mesh's surface, since a tool that triangulates polygons its own way cuts the same surface
    /// into other triangles. Pushes the problems found, fills `entry`; returns a summary line.
    fn compare_as_sets(
        &self,
        (a, ma): (&Pack, &pack::Mesh),
        (b, mb): (&Pack, &pack::Mesh),
        problems: &mut Vec<String>,
        entry: &mut Value,
    ) -> String {
        let (ta, tb) = (
            mesh_triangles(a, ma, self.names),
            mesh_triangles(b, mb, self.names),
        );
        let m = triangles::compare(&ta, &tb, self.max_delta, self.shading);
        let [ua, ub] = &m.unmatched;
        // Exact comparison still allows the rounding of a point on another triangulation: a
        // few ulps of the largest coordinate. It was a millionth of the mesh's diagonal, which
        // on a 100 m floor let a vertex move 1.4e-4 past `--max-position-delta 0`.
        let reach = self
            .max_delta
            .max(rounding_of(ma.bounds_min.iter().chain(&ma.bounds_max)));
        let (ca, cb) = if ua.is_empty() && ub.is_empty() {
            Default::default()
        } else {
            (
                surface::cover(&ta, ua, &surface::Bvh::new(&tb), reach, self.shading.uv),
                surface::cover(&tb, ub, &surface::Bvh::new(&ta), reach, self.shading.uv),
            )
        };
        let name = &ma.name;
        let (na, nb) = (ma.index_count / 3, mb.index_count / 3);
        if ca.off_surface > 0 || cb.off_surface > 0 {
            problems.push(format!(
                "mesh {name:?}: {} of a's {na} triangles are off b's surface (farther than \
                 {reach:.3e}, or facing the other way), {} of b's {nb} off a's",
                ca.off_surface, cb.off_surface
            ));
        } else if self.exact && !(ua.is_empty() && ub.is_empty()) {
            problems.push(format!(
                "mesh {name:?}: the same surface, triangulated another way ({} of a's {na} \
                 triangles and {} of b's {nb}); give --max-position-delta to accept",
                ua.len(),
                ub.len()
            ));
        } else if self.exact {
            problems.push(format!(
                "mesh {name:?}: the same triangles in another order (vertices {} in a, {} in b); \
                 give --max-position-delta to accept",
                ma.vertex_count, mb.vertex_count
            ));
        }
        let material_changes = m.material_changes + ca.material_changes + cb.material_changes;
        if material_changes > 0 {
            problems.push(format!(
                "mesh {name:?}: {} triangle corners and {} retriangulated triangles changed \
                 material",
                m.material_changes,
                ca.material_changes + cb.material_changes
            ));
        }
        problems.extend(m.shading.problems(name, "corners"));
        shading_json(entry, &m.shading);
        let uv_changes = ca.uv_changes + cb.uv_changes;
        if uv_changes > 0 {
            problems.push(format!(
                "mesh {name:?}: {uv_changes} retriangulated triangles' texture coordinates \
                 differ from the other's on the same surface, by up to {:.3e}",
                ca.max_uv_delta.max(cb.max_uv_delta)
            ));
        }
        entry["retriangulated_uv_changes"] = json!(uv_changes);
        entry["max_retriangulated_uv_delta"] = json!(ca.max_uv_delta.max(cb.max_uv_delta));
        let gap = ca.max_gap.max(cb.max_gap);
        // The corner move is over matched triangles and the gap over unmatched ones on the
        // other's surface; with none of either they said 0, next to triangles off by more.
        let matched = (na as usize).saturating_sub(ua.len());
        let on_surface = ua.len() + ub.len() - ca.off_surface - cb.off_surface;
        entry["same_order"] = json!(false);
        entry["max_position_delta"] = json!((matched > 0).then_some(m.max_delta));
        entry["unmatched_triangles"] = json!([ua.len(), ub.len()]);
        entry["off_surface_triangles"] = json!([ca.off_surface, cb.off_surface]);
        entry["surface_gap"] = json!((on_surface > 0).then_some(gap));
        entry["material_corner_changes"] = json!(m.material_changes);
        entry["retriangulated_material_changes"] = json!(ca.material_changes + cb.material_changes);
        let moved = if matched > 0 {
            format!(
                "largest corner move of the {matched} matched {:.3e}",
                m.max_delta
            )
        } else if ca.off_surface + cb.off_surface == 0 {
            // Quads split along the other diagonal: nothing pairs up, nothing moved.
            "none matched one to one, all on the other's surface: the same surface cut into \
             other triangles"
                .to_string()
        } else {
            "none matched".to_string()
        };
        let gap = if on_surface > 0 {
            format!(", largest surface gap of the {on_surface} on it {gap:.3e}")
        } else {
            String::new()
        };
        format!(
            "mesh {name:?}: triangles compared in any order: {} of a and {} of b unmatched, \
             {} and {} of those off the other's surface; {moved}{gap}",
            ua.len(),
            ub.len(),
            ca.off_surface,
            cb.off_surface,
        )
    }
}

/// Per material of `a`, its counterpart in `b`: the one of the same name; else, where `b` has
/// no material of that name, the one material of `b` whose name `a` lacks and which is the
/// same in all but its name (class, shading, triangles, textures by `textures`' pairing): a
/// material renamed. A rename was "53 vertices changed material", one missing and one new.
fn material_partners(
    a: &pack::Toc,
    b: &pack::Toc,
    textures: &[Option<usize>],
) -> Vec<Option<usize>> {
    let (tria, trib) = (a.triangles_per_material(), b.triangles_per_material());
    let unnamed_in_a: Vec<usize> = (0..b.materials.len())
        .filter(|&j| !a.materials.iter().any(|m| m.name == b.materials[j].name))
        .collect();
    let alike = |i: usize, j: usize| {
        let (m, n) = (&a.materials[i], &b.materials[j]);
        let same_textures = texture_slots(m)
            .into_iter()
            .zip(texture_slots(n))
            .all(|((_, x), (_, y))| same_texture(textures, x, y));
        m.class == n.class && tria[i] == trib[j] && same_shading(m, n) && same_textures
    };
    let mut taken = vec![false; b.materials.len()];
    (0..a.materials.len())
        .map(|i| {
            if let Some(j) = b
                .materials
                .iter()
                .position(|n| n.name == a.materials[i].name)
            {
                return Some(j);
            }
            let candidates: Vec<usize> = unnamed_in_a
                .iter()
                .copied()
                .filter(|&j| !taken[j] && alike(i, j))
                .collect();
            match candidates[..] {
                [j] => {
                    taken[j] = true;
                    Some(j)
                }
                _ => None,
            }
        })
        .collect()
}

/// Whether two materials shade alike: diffuse, specular, shininess and emissive.
fn same_shading(m: &pack::Material, n: &pack::Material) -> bool {
    m.diffuse == n.diffuse
        && m.specular == n.specular
        && m.shininess == n.shininess
        && m.emissive == n.emissive
}

/// Whether a slot holding texture `x` in a and `y` in b holds the same texture, by the textures'
/// pairing (`partners`, a's index to b's): both empty, or paired.
fn same_texture(partners: &[Option<usize>], x: Option<u32>, y: Option<u32>) -> bool {
    match (x, y) {
        (None, None) => true,
        (Some(x), Some(y)) => partners[x as usize] == Some(y as usize),
        _ => false,
    }
}

/// A material's texture slots, by the name diff gives them, and the texture each holds.
fn texture_slots(m: &pack::Material) -> [(&'static str, Option<u32>); 3] {
    [
        ("colour", m.diffuse_texture),
        ("normal", m.normal_texture),
        ("projector", m.projector_texture),
    ]
}

/// Each of a's textures' partner in b. First a texture of the same name and the same bits:
/// a design that one window kept while the others that shared it were given another image is
/// still itself. Then the texture of the same role that most of the same materials use in
/// the same slots (the same name breaking ties): a texture is named after its image's file, so
/// a design file renamed, or a second file of the same stem added to the scene (which shifts
/// the names to `t.2`), left the texture "missing from b" and "new in b", or compared it with
/// another image. Then, for textures no material uses, the same name.
fn texture_partners(a: &Pack, b: &Pack) -> Vec<Option<usize>> {
    let (ta, tb) = (a.toc(), b.toc());
    // Material names are unique in a pack and a slot holds one texture, so a non-empty key
    // names at most one texture of each pack.
    fn uses(t: &pack::Toc, i: usize) -> Vec<(&str, &'static str)> {
        let i = Some(i as u32);
        let mut uses: Vec<_> = t
            .materials
            .iter()
            .flat_map(|m| {
                texture_slots(m)
                    .into_iter()
                    .filter(move |&(_, x)| x == i)
                    .map(move |(slot, _)| (m.name.as_str(), slot))
            })
            .collect();
        uses.sort_unstable();
        uses
    }
    let same_bits = |i: usize, j: usize| {
        let (t, u) = (&ta.textures[i], &tb.textures[j]);
        t.name == u.name
            && (t.role, t.format, t.width, t.height, t.mips.len())
                == (u.role, u.format, u.width, u.height, u.mips.len())
            && (0..t.mips.len()).all(|l| a.mip_bytes(i, l) == b.mip_bytes(j, l))
    };
    let keys_b: Vec<_> = (0..tb.textures.len()).map(|j| uses(tb, j)).collect();
    let mut taken = vec![false; tb.textures.len()];
    let mut partners: Vec<Option<usize>> = (0..ta.textures.len())
        .map(|i| {
            let j = (0..tb.textures.len()).find(|&j| !taken[j] && same_bits(i, j))?;
            taken[j] = true;
            Some(j)
        })
        .collect();
    for (i, p) in partners.iter_mut().enumerate().filter(|(_, p)| p.is_none()) {
        *p = {
            let key = uses(ta, i);
            let t = &ta.textures[i];
            let shared = |j: usize| keys_b[j].iter().filter(|u| key.contains(u)).count();
            let j = (0..tb.textures.len())
                .filter(|&j| !taken[j] && tb.textures[j].role == t.role && shared(j) > 0)
                .max_by_key(|&j| (shared(j), tb.textures[j].name == t.name, usize::MAX - j));
            if let Some(j) = j {
                taken[j] = true;
            }
            j
        };
    }
    for (i, p) in partners.iter_mut().enumerate() {
        if p.is_none() {
            *p = (0..tb.textures.len())
                .find(|&j| !taken[j] && tb.textures[j].name == ta.textures[i].name);
            if let Some(j) = *p {
                taken[j] = true;
            }
        }
    }
    partners
}

fn shading_json(entry: &mut Value, s: &ShadingChanges) {
    entry["normal_changes"] = json!(s.normals);
    entry["max_normal_delta_deg"] = json!(s.max_normal_angle.to_degrees());
    entry["tangent_changes"] = json!(s.tangents);
    entry["max_tangent_delta_deg"] = json!(s.max_tangent_angle.to_degrees());
    entry["uv_changes"] = json!(s.uvs);
    entry["max_uv_delta"] = json!(s.max_uv_delta);
}

/// A section's key: what it holds, named as in pack a. `names` gives the names its meshes and
/// textures go by (for b, those of the a meshes and textures they were paired with), so a
/// renamed design's mips are compared with its partner's, not listed as only in a and only in b.
fn role_key(toc: &pack::Toc, role: SectionRole, names: &SectionNames) -> String {
    match role {
        SectionRole::Toc => "toc".into(),
        SectionRole::Vertices { mesh } => format!("vertices/{}", names.meshes[mesh as usize]),
        SectionRole::Indices { mesh } => format!("indices/{}", names.meshes[mesh as usize]),
        // A level by its size, not its index: a chain capped by `--max-texture-size` starts
        // at another's level 1, and by index every level was "different" (identical bytes
        // included) and the last "only in a".
        SectionRole::Mip { texture, level } => {
            let l = &toc.textures[texture as usize].mips[level as usize];
            format!(
                "mip/{}/{}x{}",
                names.textures[texture as usize], l.width, l.height
            )
        }
    }
}

/// The names a pack's meshes and textures are keyed by in the section list.
struct SectionNames {
    meshes: Vec<String>,
    textures: Vec<String>,
}

impl SectionNames {
    fn own(t: &pack::Toc) -> Self {
        SectionNames {
            meshes: t.meshes.iter().map(|m| m.name.clone()).collect(),
            textures: t.textures.iter().map(|x| x.name.clone()).collect(),
        }
    }

    /// b's names: each paired mesh and texture goes by its partner's name in a; one left
    /// unpaired whose name a gave to another is marked, so it is not taken for that one.
    fn paired(
        ta: &pack::Toc,
        tb: &pack::Toc,
        mesh_partners: &[Option<usize>],
        texture_partners: &[Option<usize>],
    ) -> Self {
        fn rename(names: &mut [String], a_names: &[&str], partners: &[Option<usize>]) {
            let mut paired = vec![false; names.len()];
            for (i, j) in partners.iter().enumerate() {
                if let Some(j) = *j {
                    names[j] = a_names[i].to_string();
                    paired[j] = true;
                }
            }
            for (name, _) in names.iter_mut().zip(paired).filter(|(_, p)| !p) {
                if a_names.contains(&name.as_str()) {
                    name.push_str(" (another in b)");
                }
            }
        }
        let mut names = SectionNames::own(tb);
        let a_meshes: Vec<&str> = ta.meshes.iter().map(|m| m.name.as_str()).collect();
        let a_textures: Vec<&str> = ta.textures.iter().map(|t| t.name.as_str()).collect();
        rename(&mut names.meshes, &a_meshes, mesh_partners);
        rename(&mut names.textures, &a_textures, texture_partners);
        names
    }
}

pub fn run(args: Args) -> Outcome {
    for (name, v) in [
        ("--tolerance-lsb", args.tolerance_lsb),
        ("--max-position-delta", args.max_position_delta),
        ("--max-normal-delta-deg", args.max_normal_delta_deg),
        ("--max-uv-delta", args.max_uv_delta),
    ] {
        // Negatives are parsed (not taken for a flag, "unexpected argument '-0'") to be
        // refused here with the rest.
        if let Some(v) = v
            && !(v.is_finite() && v >= 0.0)
        {
            return Err(UsageError(format!("{name} must be a finite number >= 0, got {v}")).into());
        }
    }
    let a = Pack::open(&args.a)?;
    let b = Pack::open(&args.b)?;
    let (ta, tb) = (a.toc(), b.toc());
    let mut problems: Vec<String> = Vec::new();

    // A pack's mesh is named after its source file, so two exports of one model (`church.obj`
    // and `church.glb`) name it differently: when one mesh in each pack is left unmatched by
    // name, those two are compared.
    let unmatched = |x: &pack::Toc, y: &pack::Toc| -> Vec<usize> {
        (0..x.meshes.len())
            .filter(|&i| !y.meshes.iter().any(|m| m.name == x.meshes[i].name))
            .collect()
    };
    let renamed = match (&unmatched(ta, tb)[..], &unmatched(tb, ta)[..]) {
        (&[i], &[j]) => Some((i, j)),
        _ => None,
    };
    let mesh_partners: Vec<Option<usize>> = (0..ta.meshes.len())
        .map(|i| match renamed {
            Some((ri, rj)) if ri == i => Some(rj),
            _ => tb.meshes.iter().position(|m| m.name == ta.meshes[i].name),
        })
        .collect();
    let partner = |i: usize| mesh_partners[i].map(|j| &tb.meshes[j]);
    // Textures paired by the material slots that hold them, so a material's textures can be
    // followed through a rename.
    let partners = texture_partners(&a, &b);

    // Sections, matched by what they hold rather than by index, and compared by content: a
    // supercompressed level by its decoded bytes.
    let index = |p: &Pack, names: &SectionNames| -> BTreeMap<String, u32> {
        p.roles()
            .iter()
            .zip(p.sections())
            .enumerate()
            .map(|(i, (&r, s))| {
                let data = p.section_data(i as u32);
                let crc = if data.len() as u64 == s.length && data == p.section_bytes(i as u32) {
                    s.crc
                } else {
                    pack::format::crc32(data)
                };
                (role_key(p.toc(), r, names), crc)
            })
            .collect()
    };
    let sa = index(&a, &SectionNames::own(ta));
    let sb = index(&b, &SectionNames::paired(ta, tb, &mesh_partners, &partners));
    let mut sections = Vec::new();
    for key in sa.keys().chain(sb.keys().filter(|k| !sa.contains_key(*k))) {
        let state = match (sa.get(key), sb.get(key)) {
            (Some(x), Some(y)) if x == y => "equal",
            (Some(_), Some(_)) => "different",
            (Some(_), None) => "only in a",
            _ => "only in b",
        };
        sections.push(json!({"section": key, "state": state}));
    }
    let identical = a.bytes() == b.bytes();

    // Geometry, meshes matched by name. Without --max-position-delta geometry must be equal,
    // order included.
    let max_delta = args.max_position_delta.unwrap_or(0.0);
    let exact_geometry = args.max_position_delta.is_none();
    let loose = |default: f64| if exact_geometry { 0.0 } else { default };
    let shading_tolerance = ShadingTolerance {
        angle: args
            .max_normal_delta_deg
            .unwrap_or(loose(DEFAULT_NORMAL_DELTA_DEG))
            .to_radians(),
        uv: args.max_uv_delta.unwrap_or(loose(DEFAULT_UV_DELTA)),
    };
    let material_partner = material_partners(ta, tb, &partners);
    // A renamed material keeps its key, so its vertices are not "changed material".
    let mut names = MaterialNames::new();
    for m in &ta.materials {
        let next = names.len() as u32;
        names.entry(m.name.as_str()).or_insert(next);
    }
    for (i, j) in material_partner.iter().enumerate() {
        if let Some(j) = *j {
            let key = names[ta.materials[i].name.as_str()];
            names.entry(tb.materials[j].name.as_str()).or_insert(key);
        }
    }
    for m in &tb.materials {
        let next = names.len() as u32;
        names.entry(m.name.as_str()).or_insert(next);
    }
    let mut meshes = Vec::new();
    let mut reordered = Vec::new();
    for (i, ma) in ta.meshes.iter().enumerate() {
        let Some(mb) = partner(i) else {
            problems.push(format!("mesh {:?} is missing from b", ma.name));
            meshes.push(json!({"name": ma.name, "state": "only in a"}));
            continue;
        };
        if mb.name != ma.name && exact_geometry {
            problems.push(format!("mesh {:?} is named {:?} in b", ma.name, mb.name));
        }
        let mut entry = json!({
            "name": ma.name,
            "name_in_b": mb.name,
            "vertices": [ma.vertex_count, mb.vertex_count],
            "triangles": [ma.index_count / 3, mb.index_count / 3],
        });
        problems.extend(attributes_differ(ma, mb));
        let (ia, ib) = (a.indices(ma), b.indices(mb));
        // The same index buffer says the same order only if the vertices agree too: two
        // exports whose triangles are listed alike over vertices in another order (objects'
        // faces reversed) share the indices 0, 1, 2, … and nothing else. With a tolerance, a
        // vertex order that does not hold is compared as a set of triangles instead.
        // The largest move of a vertex, where the index buffers are equal.
        let delta_in_order = (ma.vertex_count == mb.vertex_count && ia == ib).then(|| {
            let (pa, pb) = (positions(&a, ma), positions(&b, mb));
            pa.iter()
                .zip(&pb)
                .map(|(p, q)| corner_delta(p, q))
                .fold(0.0, f64::max)
        });
        if let Some(delta) = delta_in_order.filter(|&d| exact_geometry || d <= max_delta) {
            // The same vertices in the same order: compare them one by one.
            let (ka, kb) = (material_keys(&a, ma, &names), material_keys(&b, mb, &names));
            let changed = ka.iter().zip(&kb).filter(|(x, y)| x != y).count();
            if delta > max_delta {
                problems.push(format!("mesh {:?}: a vertex moved by {delta:.3e}", ma.name));
            }
            if changed > 0 {
                problems.push(format!(
                    "mesh {:?}: {changed} vertices changed material",
                    ma.name
                ));
            }
            // Vertex colours, in 8-bit sRGB steps: stored as bytes, so any change is real.
            let (recoloured, colour_delta) = colours(&a, ma)
                .iter()
                .zip(&colours(&b, mb))
                .filter(|(x, y)| x != y)
                .fold((0usize, 0u8), |(n, d), (x, y)| {
                    let step = (0..3).map(|k| x[k].abs_diff(y[k])).max().unwrap_or(0);
                    (n + 1, d.max(step))
                });
            if recoloured > 0 {
                problems.push(format!(
                    "mesh {:?}: {recoloured} vertices changed colour, by up to {colour_delta} \
                     sRGB steps",
                    ma.name
                ));
            }
            let mut shaded = ShadingChanges::default();
            for (x, y) in shading(&a, ma).iter().zip(&shading(&b, mb)) {
                shaded.add(x, y, shading_tolerance);
            }
            problems.extend(shaded.problems(&ma.name, "vertices"));
            shading_json(&mut entry, &shaded);
            entry["same_order"] = json!(true);
            entry["max_position_delta"] = json!(delta);
            entry["material_id_changes"] = json!(changed);
            entry["colour_changes"] = json!(recoloured);
            entry["max_colour_delta"] = json!(colour_delta);
        } else {
            let geometry = Geometry {
                names: &names,
                max_delta,
                exact: exact_geometry,
                shading: shading_tolerance,
            };
            let said = geometry.compare_as_sets((&a, ma), (&b, mb), &mut problems, &mut entry);
            // The same index buffer and triangles that do not all match as sets: not another
            // order but vertices that moved, as far as they moved. Measured on the surface
            // alone, a floor vertex slid 0.5 along the floor passed `--max-position-delta
            // 0.001` while its texture stretched.
            let unmatched = entry["unmatched_triangles"] != json!([0, 0]);
            match delta_in_order {
                Some(delta) if unmatched => {
                    problems.push(format!(
                        "mesh {:?}: a vertex moved by {delta:.3e} (the vertices in the same \
                         order)",
                        ma.name
                    ));
                    entry["same_order"] = json!(true);
                    entry["max_position_delta"] = json!(delta);
                }
                _ => reordered.push(said),
            }
        }
        meshes.push(entry);
    }
    for (j, mb) in tb.meshes.iter().enumerate() {
        if !ta.meshes.iter().any(|m| m.name == mb.name) && renamed.is_none_or(|r| r.1 != j) {
            problems.push(format!("mesh {:?} is new in b", mb.name));
            meshes.push(json!({"name": mb.name, "state": "only in b"}));
        }
    }

    // Materials, by name.
    let mut materials = Vec::new();
    // Per material compared: its entry in `materials` and the textures its slots name in a,
    // so `textures_equal` can say whether their texels are equal too.
    let mut material_textures = Vec::new();
    let (tria, trib) = (ta.triangles_per_material(), tb.triangles_per_material());
    for (i, m) in ta.materials.iter().enumerate() {
        match material_partner[i] {
            None => problems.push(format!("material {:?} is missing from b", m.name)),
            Some(j) => {
                let n = &tb.materials[j];
                if n.name != m.name {
                    problems.push(format!("material {:?} is named {:?} in b", m.name, n.name));
                }
                if n.class != m.class || tria[i] != trib[j] {
                    problems.push(format!(
                        "material {:?}: {} with {} triangles in a, {} with {} in b",
                        m.name, m.class, tria[i], n.class, trib[j]
                    ));
                }
                let shading_equal = same_shading(m, n);
                if !shading_equal {
                    problems.push(format!(
                        "material {:?}: shading differs: diffuse {:?}, specular {:?}, \
                         shininess {}, emissive {:?} in a; {:?}, {:?}, {}, {:?} in b",
                        m.name,
                        m.diffuse,
                        m.specular,
                        m.shininess,
                        m.emissive,
                        n.diffuse,
                        n.specular,
                        n.shininess,
                        n.emissive
                    ));
                }
                // Which texture a slot names: a material given another image (a window's
                // design switched to a new file) was only "texture … is new in b".
                let mut textures_equal = true;
                for ((slot, x), (_, y)) in texture_slots(m).into_iter().zip(texture_slots(n)) {
                    if !same_texture(&partners, x, y) {
                        textures_equal = false;
                        let name = |t: &pack::Toc, k: Option<u32>| {
                            k.map_or("none".to_string(), |k| {
                                format!("{:?}", t.textures[k as usize].name)
                            })
                        };
                        problems.push(format!(
                            "material {:?}: its {slot} texture is {} in a and {} in b{}",
                            m.name,
                            name(ta, x),
                            name(tb, y),
                            if x.is_some() && y.is_some() {
                                ", another image"
                            } else {
                                ""
                            }
                        ));
                    }
                }
                material_textures.push((materials.len(), texture_slots(m)));
                materials.push(json!({
                    "name": m.name, "name_in_b": n.name,
                    "class": [m.class.name(), n.class.name()],
                    "triangles": [tria[i], trib[j]],
                    "shading_equal": shading_equal,
                    "textures_equal": textures_equal,
                }));
            }
        }
    }
    for (j, m) in tb.materials.iter().enumerate() {
        if !material_partner.contains(&Some(j)) {
            problems.push(format!("material {:?} is new in b", m.name));
        }
    }

    // Textures, paired by the materials that use them, else by name; level by level.
    let tolerance = args.tolerance_lsb.unwrap_or(0.0);
    let mut textures = Vec::new();
    for (i, t) in ta.textures.iter().enumerate() {
        let Some((j, u)) = partners[i].map(|j| (j, &tb.textures[j])) else {
            problems.push(format!("texture {:?} is missing from b", t.name));
            textures.push(TextureDiff::only(t, true));
            continue;
        };
        if u.name != t.name && args.tolerance_lsb.is_none() {
            problems.push(format!("texture {:?} is named {:?} in b", t.name, u.name));
        }
        // Where one chain is the other's from a level on, as a size cap leaves it
        // (`--max-texture-size`), the levels they share are compared.
        let shared = shared_levels(t, u);
        if shared != Some((0, 0)) {
            problems.push(format!(
                "texture {:?}: {} {}x{} with {} mips in a, {} {}x{} with {} in b{}",
                t.name,
                t.role,
                t.width,
                t.height,
                t.mips.len(),
                u.role,
                u.width,
                u.height,
                u.mips.len(),
                match shared {
                    Some((0, k)) =>
                        format!("; a's levels are b's from level {k} on, compared as such"),
                    Some((k, _)) =>
                        format!("; b's levels are a's from level {k} on, compared as such"),
                    None => String::new(),
                }
            ));
        }
        let Some((from_a, from_b)) = shared else {
            textures.push(TextureDiff::of(t, u, "sizes differ", Vec::new()));
            continue;
        };
        let mut levels = Vec::new();
        for (level, m) in t.mips.iter().enumerate().skip(from_a) {
            let level_b = level - from_a + from_b;
            // Decoded texels, so an RGBA8 pack and a block-compressed one compare.
            let d = level_diff(
                t.role,
                level,
                m.width,
                m.height,
                &pack::texels::decode_level(t, level, a.mip_bytes(i, level)),
                &pack::texels::decode_level(u, level_b, b.mip_bytes(j, level_b)),
            );
            if d.max_error as f64 > tolerance {
                problems.push(format!(
                    "texture {:?} mip {level} ({}x{}): max error {} LSB > {tolerance}, PSNR {:.2} dB",
                    t.name, d.width, d.height, d.max_error, d.psnr
                ));
            }
            levels.push(d);
        }
        let state = if shared == Some((0, 0)) {
            "compared"
        } else {
            "compared from a level on"
        };
        textures.push(TextureDiff::of(t, u, state, levels));
    }
    for (j, t) in tb.textures.iter().enumerate() {
        if !partners.contains(&Some(j)) {
            problems.push(format!("texture {:?} is new in b", t.name));
            textures.push(TextureDiff::only(t, false));
        }
    }
    // A material whose slots name the partner textures still differs where their texels do
    // (a window's design file edited in place keeps every name). `textures` holds one entry
    // per texture of a, in a's order, before those only in b.
    for (k, slots) in material_textures {
        let texels_equal = slots
            .iter()
            .filter_map(|(_, x)| *x)
            .all(|x| textures[x as usize].texels_equal());
        if !texels_equal {
            materials[k]["textures_equal"] = json!(false);
        }
    }
    // Scene parameters outside geometry and textures, each also a field of `--json`'s
    // `scene`, so a script need not parse the problems' text.
    let light = light_differs(ta, tb, max_delta);
    if let Some(why) = &light {
        problems.push(format!(
            "the light differs{why}: {} in a, {} in b",
            describe_light(ta.light.as_ref()),
            describe_light(tb.light.as_ref())
        ));
    }
    // Cameras and window frames are placed from the geometry, so they move with it: with
    // --max-position-delta their points may move that far too, their directions by 1e-3.
    let cameras = cameras_differ(&ta.cameras, &tb.cameras, max_delta);
    if let Some((what, _)) = &cameras {
        problems.push(format!("the camera presets differ: {what}"));
    }
    let frames = windows_differ(ta, tb, max_delta, exact_geometry);
    if let Some(what) = &frames {
        problems.push(format!("the window frames differ: {what}"));
    }
    let background_equal = ta.background == tb.background;
    if !background_equal {
        let show = |b: &pack::Background| {
            let c = b.colour;
            format!(
                "colour [{:.3}, {:.3}, {:.3}]{}",
                c[0],
                c[1],
                c[2],
                b.panorama
                    .map_or(String::new(), |t| format!(", panorama texture {t}"))
            )
        };
        problems.push(format!(
            "the background differs: {} in a, {} in b",
            show(&ta.background),
            show(&tb.background)
        ));
    }
    let scene = json!({
        "light_equal": light.is_none(),
        "cameras_equal": cameras.is_none(),
        "cameras_differing": cameras.as_ref().map_or(Vec::new(), |c| c.1.clone()),
        "window_frames_equal": frames.is_none(),
        "background_equal": background_equal,
    });
    // Identical by default: without thresholds any byte difference (even one no rule above
    // explains, such as reordered sections) is a difference.
    let strict = args.tolerance_lsb.is_none()
        && args.max_position_delta.is_none()
        && args.max_normal_delta_deg.is_none()
        && args.max_uv_delta.is_none();
    if strict && !identical && problems.is_empty() {
        problems.push(
            "the packs differ in bytes (section order, supercompression or TOC encoding)".into(),
        );
    }
    let within = problems.is_empty();

    if args.json {
        let tex_json: Vec<Value> = textures
            .iter()
            .map(|t| {
                json!({
                    "name": t.name,
                    "name_in_b": t.name_in_b,
                    "state": t.state,
                    "size": [t.size_a, t.size_b],
                    "levels": t.levels.iter().map(|d| json!({
                        "level": d.level, "width": d.width, "height": d.height,
                        "max_error": d.max_error,
                        // JSON has no infinity: an equal level's PSNR is null, and `equal`
                        // says why, so a reader's numbers stay numbers.
                        "psnr": d.psnr.is_finite().then_some(d.psnr),
                        "equal": d.max_error == 0,
                        "flip_mean": d.flip_mean,
                    })).collect::<Vec<_>>(),
                })
            })
            .collect();
        println!(
            "{}",
            serde_json::to_string_pretty(&json!({
                "a": args.a, "b": args.b,
                "identical": identical,
                "within_thresholds": within,
                "sections": sections,
                "meshes": meshes,
                "materials": materials,
                "textures": tex_json,
                "scene": scene,
                "problems": problems,
            }))?
        );
    } else {
        println!("a: {}\nb: {}", args.a.display(), args.b.display());
        if identical {
            println!("identical: every byte is equal");
        }
        let differing: Vec<_> = sections.iter().filter(|s| s["state"] != "equal").collect();
        println!(
            "sections: {} compared, {} differ",
            sections.len(),
            differing.len()
        );
        for s in differing {
            println!(
                "  {:<40} {}",
                s["section"].as_str().unwrap_or(""),
                s["state"].as_str().unwrap_or("")
            );
        }
        for line in &reordered {
            println!("  {line}");
        }
        for TextureDiff { name, levels, .. } in &textures {
            for d in levels.iter().filter(|d| d.max_error > 0) {
                let flip = d
                    .flip_mean
                    .map(|f| format!("{f:.4}"))
                    .unwrap_or_else(|| "-".into());
                println!(
                    "  texture {name:?} mip {} ({}x{}): max error {} LSB, PSNR {:.2} dB, FLIP mean {flip}",
                    d.level, d.width, d.height, d.max_error, d.psnr
                );
            }
        }
        if within {
            println!("result: within thresholds");
        } else {
            println!("result: {} problem(s)", problems.len());
            for (i, p) in problems.iter().enumerate() {
                println!("  {}. {p}", i + 1);
            }
        }
    }
    Ok(if within { OK } else { FOUND_PROBLEMS })
}

/// Where one texture's chain is the other's from a level on (the same role, and the longer
/// chain's levels from there the same sizes as the shorter's): the first level each compares
/// from, one of them 0; both for textures of one shape.
fn shared_levels(t: &pack::Texture, u: &pack::Texture) -> Option<(usize, usize)> {
    if t.role != u.role {
        return None;
    }
    let sizes = |x: &pack::Texture, from: usize| -> Vec<(u32, u32)> {
        x.mips[from..].iter().map(|m| (m.width, m.height)).collect()
    };
    let (n, m) = (t.mips.len(), u.mips.len());
    if n >= m && sizes(t, n - m) == sizes(u, 0) {
        Some((n - m, 0))
    } else if m > n && sizes(u, m - n) == sizes(t, 0) {
        Some((0, m - n))
    } else {
        None
    }
}

/// A pack's light in words, every field at full precision, so two that differ read apart
/// (`diff`; `info` prints it too).
pub(crate) fn describe_light(light: Option<&pack::Light>) -> String {
    let Some(l) = light else {
        return "no light".into();
    };
    let kind = match &l.kind {
        pack::LightKind::Directional {
            direction,
            angular_size,
        } => format!(
            "a sun along {direction:?}, {} degrees across",
            angular_size.to_degrees()
        ),
        pack::LightKind::Point { position, radius } => {
            format!("a point light at {position:?} of radius {radius}")
        }
        pack::LightKind::Spot {
            position,
            radius,
            direction,
            inner,
            outer,
        } => format!(
            "a spot light at {position:?} of radius {radius} along {direction:?}, its cone {} to {} degrees",
            inner.to_degrees(),
            outer.to_degrees()
        ),
    };
    format!("{kind}, colour {:?}, intensity {}", l.colour, l.intensity)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn camera(name: &str, x: f32) -> pack::Camera {
        pack::Camera {
            name: name.into(),
            position: [x, 1.0, 2.0],
            target: [0.0; 3],
            up: [0.0, 1.0, 0.0],
            fov_y: 60.0,
            near: 0.1,
            far: 100.0,
        }
    }

    /// One preset renamed is that preset, not every one; a preset that moved beside it is
    /// still named as moved.
    #[test]
    fn presets_are_matched_by_name() {
        let a = [
            camera("nave", 0.0),
            camera("rose", 1.0),
            camera("glass", 2.0),
        ];
        let b = [
            camera("nave", 0.0),
            camera("rose", 1.5),
            camera("glass2", 2.0),
        ];
        let (what, names) = cameras_differ(&a, &b, 0.0).unwrap();
        assert_eq!(names, ["glass", "glass2", "rose"]);
        assert!(what.contains("\"glass\" only in a; \"glass2\" only in b; \"rose\": position or target moved by 5.000e-1"), "{what}");
        assert_eq!(cameras_differ(&a, &a, 0.0), None);
        let mut swapped = a.clone();
        swapped.swap(0, 1);
        let (what, names) = cameras_differ(&a, &swapped, 0.0).unwrap();
        assert!(
            what.starts_with("the same presets in another order"),
            "{what}"
        );
        assert_eq!(names, ["nave", "rose", "glass"]);
        // A repeated name pairs occurrence by occurrence.
        let twice = [camera("c", 0.0), camera("c", 1.0)];
        let moved = [camera("c", 0.0), camera("c", 2.0)];
        let (what, names) = cameras_differ(&twice, &moved, 0.0).unwrap();
        assert_eq!(names, ["c"]);
        assert!(what.contains("moved by 1.000e0"), "{what}");
        let (what, _) = cameras_differ(&twice[..1], &twice, 0.0).unwrap();
        assert_eq!(what, "\"c\" only in b");
    }
}
