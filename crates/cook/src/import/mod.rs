//! Source importers. Each turns a file into an [`Imported`] triangle soup: attribute arrays,
//! three [`Corner`]s per triangle, and per triangle the [`Part`] whose source names tagging
//! looks at. Importers check every index and coordinate, so later stages (and meshopt) only
//! ever see valid data.

pub mod gltf;
mod gltf_draco;
mod gltf_meshopt;
pub mod obj;
pub mod ply;
pub mod text;

use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::CookError;
use crate::manifest::NameKind;

/// Marks a missing attribute in a [`Corner`].
pub const NONE: u32 = u32::MAX;

/// One triangle corner: indices into the position, texture-coordinate and normal arrays.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Corner {
    pub p: u32,
    pub t: u32,
    pub n: u32,
}

/// Triangle corners, three per triangle, stored field by field: the texture-coordinate or
/// normal indices are held only when some corner has one, and not at all when every corner's
/// equals its position index. A bare scan's corners take 4 bytes each rather than 12, and a
/// large mesh's corners are held from its import to the end of its deduplication (a
/// 1M-triangle OBJ's were 36 MB of its cook's peak). glTF has one index for every attribute,
/// and many OBJ writers number them alike (`f 7/7/7`): their corners take 4 bytes too (the
/// 819k-triangle grid's import peaked at 76.8 MB with all three fields held).
#[derive(Clone, Debug, Default, Eq)]
pub struct Corners {
    p: Vec<u32>,
    t: Indices,
    n: Indices,
}

/// How a corner field other than the position index is held.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub enum Indices {
    /// No corner has one.
    #[default]
    Absent,
    /// Every corner's is its position index.
    Positions,
    /// One per corner, [`NONE`] where a corner has none.
    Own(Vec<u32>),
}

impl Indices {
    /// `field` (empty, or one per corner of `p`) held as it needs: absent when it holds only
    /// [`NONE`], not held when it is `p` over again.
    pub(crate) fn of(field: Vec<u32>, p: &[u32]) -> Self {
        if field.iter().all(|&i| i == NONE) {
            Indices::Absent
        } else if field == p {
            Indices::Positions
        } else {
            Indices::Own(field)
        }
    }

    /// The field's index for every corner, given the position indices `p`; empty when
    /// absent.
    pub(crate) fn slice<'a>(&'a self, p: &'a [u32]) -> &'a [u32] {
        match self {
            Indices::Absent => &[],
            Indices::Positions => p,
            Indices::Own(v) => v,
        }
    }

    /// The field held one per corner of `p` (the corners so far), as it reads now.
    fn own(&mut self, p: &[u32]) -> &mut Vec<u32> {
        let v = match std::mem::take(self) {
            Indices::Absent => vec![NONE; p.len()],
            Indices::Positions => p.to_vec(),
            Indices::Own(v) => v,
        };
        *self = Indices::Own(v);
        let Indices::Own(v) = self else {
            unreachable!("just set")
        };
        v
    }
}

impl PartialEq for Corners {
    /// Equal corners, however each field is held.
    fn eq(&self, other: &Self) -> bool {
        self.p == other.p
            && self.uv_indices() == other.uv_indices()
            && self.normal_indices() == other.normal_indices()
    }
}

impl Corners {
    /// From whole fields; `t` and `n` are each empty or as long as `p`.
    pub fn from_fields(p: Vec<u32>, t: Vec<u32>, n: Vec<u32>) -> Self {
        assert!(
            (t.is_empty() || t.len() == p.len()) && (n.is_empty() || n.len() == p.len()),
            "a corner field is empty or one per corner"
        );
        let (t, n) = (Indices::of(t, &p), Indices::of(n, &p));
        Self::from_indices(p, t, n)
    }

    /// From the position indices and the other two fields as held.
    pub fn from_indices(p: Vec<u32>, t: Indices, n: Indices) -> Self {
        for f in [&t, &n] {
            if let Indices::Own(v) = f {
                assert_eq!(v.len(), p.len(), "a corner field is one per corner");
            }
        }
        Self { p, t, n }
    }

    pub fn len(&self) -> usize {
        self.p.len()
    }

    pub fn is_empty(&self) -> bool {
        self.p.is_empty()
    }

    /// Corner `i`'s position index (the one field every corner has).
    #[inline]
    pub fn p(&self, i: usize) -> u32 {
        self.p[i]
    }

    /// Every corner's position index.
    pub fn positions(&self) -> &[u32] {
        &self.p
    }

    #[inline]
    pub fn get(&self, i: usize) -> Corner {
        let p = self.p[i];
        let field = |f: &Indices| match f {
            Indices::Absent => NONE,
            Indices::Positions => p,
            Indices::Own(v) => v[i],
        };
        Corner {
            p,
            t: field(&self.t),
            n: field(&self.n),
        }
    }

    /// Triangle `t`'s three corners.
    #[inline]
    pub fn triangle(&self, t: usize) -> [Corner; 3] {
        [0, 1, 2].map(|k| self.get(3 * t + k))
    }

    /// Triangle `t`'s three position indices.
    #[inline]
    pub fn triangle_positions(&self, t: usize) -> [u32; 3] {
        let p = &self.p[3 * t..3 * t + 3];
        [p[0], p[1], p[2]]
    }

    pub fn iter(&self) -> impl ExactSizeIterator<Item = Corner> + '_ {
        (0..self.len()).map(|i| self.get(i))
    }

    /// Every corner's texture-coordinate index ([`NONE`] where it has none), or empty when no
    /// corner has one.
    pub fn uv_indices(&self) -> &[u32] {
        self.t.slice(&self.p)
    }

    /// Every corner's normal index, as [`Self::uv_indices`].
    pub fn normal_indices(&self) -> &[u32] {
        self.n.slice(&self.p)
    }

    /// The normal indices as they are held.
    pub fn normal_field(&self) -> &Indices {
        &self.n
    }

    /// Takes the normal indices out, as they are held; the corners have none after.
    pub fn take_normal_indices(&mut self) -> Indices {
        std::mem::take(&mut self.n)
    }

    /// Lets the texture-coordinate indices go; the corners have none after.
    pub fn drop_uv_indices(&mut self) {
        self.t = Indices::Absent;
    }

    /// Appends corners whose position indices are `p` and whose texture-coordinate and normal
    /// indices are each a position index less `p_base` plus the field's base (`None`: the
    /// corners have none), as glTF's one index for every attribute gives them. Taken whole
    /// when there are no corners yet.
    pub fn append_shared(
        &mut self,
        p: Vec<u32>,
        p_base: u32,
        t_base: Option<u32>,
        n_base: Option<u32>,
    ) {
        if p.is_empty() {
            return;
        }
        let start = self.p.len();
        if start == 0 {
            self.p = p;
        } else {
            self.p.extend_from_slice(&p);
        }
        let positions = &self.p;
        for (field, base) in [(&mut self.t, t_base), (&mut self.n, n_base)] {
            let follows = base == Some(p_base);
            match field {
                Indices::Absent if base.is_none() => {}
                Indices::Absent if start == 0 && follows => *field = Indices::Positions,
                Indices::Positions if follows => {}
                _ => field
                    .own(&positions[..start])
                    .extend(positions[start..].iter().map(|&i| match base {
                        Some(b) => i - p_base + b,
                        None => NONE,
                    })),
            }
        }
    }

    pub fn push(&mut self, c: Corner) {
        self.p.push(c.p);
        self.set(self.p.len() - 1, c);
    }

    pub fn set(&mut self, i: usize, c: Corner) {
        self.p[i] = c.p;
        let (p, len) = (&self.p, self.p.len());
        for (field, value) in [(&mut self.t, c.t), (&mut self.n, c.n)] {
            match field {
                Indices::Absent if value == NONE => {}
                // The first corner decides whether a field can follow the positions.
                Indices::Absent if len == 1 && value == c.p => *field = Indices::Positions,
                Indices::Positions if value == c.p => {}
                // A pushed corner is already in `p`, one past an owned field's end.
                _ => {
                    let v = field.own(p);
                    v.resize(len, NONE);
                    v[i] = value;
                }
            }
        }
    }

    pub fn swap(&mut self, i: usize, j: usize) {
        self.p.swap(i, j);
        for field in [&mut self.t, &mut self.n] {
            if let Indices::Own(v) = field {
                v.swap(i, j);
            }
        }
    }
}

/// Moves `more` onto the end of `to`, taking it whole while `to` is empty (an import's first
/// chunk or primitive), so a one-piece model's arrays are never copied.
fn append<T>(to: &mut Vec<T>, mut more: Vec<T>) {
    if to.is_empty() {
        *to = more;
    } else {
        to.append(&mut more);
    }
}

impl FromIterator<Corner> for Corners {
    fn from_iter<I: IntoIterator<Item = Corner>>(iter: I) -> Self {
        let mut out = Self::default();
        for c in iter {
            out.push(c);
        }
        out
    }
}

/// The names a run of triangles carries in its source file.
#[derive(Clone, Debug, Default, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Names {
    pub material: Option<String>,
    pub group: Option<String>,
    pub object: Option<String>,
    pub mesh: Option<String>,
    pub node: Option<String>,
    /// Which copy of an instanced node (`EXT_mesh_gpu_instancing`) the triangles are, where
    /// each copy is a part of its own: its notes are told apart by it. Rules never see it.
    pub instance: Option<u32>,
}

impl Names {
    pub fn get(&self, kind: NameKind) -> Option<&str> {
        match kind {
            NameKind::Material => self.material.as_deref(),
            NameKind::Group => self.group.as_deref(),
            NameKind::Object => self.object.as_deref(),
            NameKind::Mesh => self.mesh.as_deref(),
            NameKind::Node => self.node.as_deref(),
        }
    }

    /// `kind name` pairs, for reports.
    pub fn describe(&self) -> String {
        let parts: Vec<String> = NameKind::ALL
            .iter()
            .filter_map(|&k| self.get(k).map(|n| format!("{} {n:?}", k.name())))
            .collect();
        let names = if parts.is_empty() {
            "(unnamed)".into()
        } else {
            parts.join(", ")
        };
        match self.instance {
            Some(i) => format!("{names}, instance {i}"),
            None => names,
        }
    }
}

/// A run of triangles sharing source names and source material.
#[derive(Clone, Debug, PartialEq)]
pub struct Part {
    pub names: Names,
    /// Index into [`Imported::materials`].
    pub material: Option<u32>,
}

/// An image a material refers to.
#[derive(Clone, Debug, PartialEq)]
pub enum ImageRef {
    File(PathBuf),
    /// Bytes embedded in a glTF buffer or data URI; `name` identifies it in reports.
    Embedded {
        name: String,
        bytes: Arc<Vec<u8>>,
    },
    /// Pixels made by the cook (a window design rasterized from the mesh, fitted or masked).
    Raster {
        name: String,
        image: Arc<image::RgbaImage>,
    },
}

impl ImageRef {
    pub fn name(&self) -> String {
        match self {
            ImageRef::File(p) => p.display().to_string(),
            ImageRef::Embedded { name, .. } | ImageRef::Raster { name, .. } => name.clone(),
        }
    }
}

/// Shading parameters as the source states them, in linear RGB.
#[derive(Clone, Debug, PartialEq)]
pub struct SourceMaterial {
    pub name: String,
    pub diffuse: [f32; 3],
    pub specular: [f32; 3],
    pub shininess: f32,
    pub emissive: [f32; 3],
    pub diffuse_texture: Option<ImageRef>,
    pub normal_texture: Option<ImageRef>,
    /// How strongly the normal map tilts the surface: glTF's `normalTexture.scale`, an MTL
    /// bump statement's `-bm`; 1 where the source says nothing.
    pub normal_scale: f32,
    /// What the source says about light passing through it (glass).
    pub transmission: Transmission,
}

/// Light passing through a material, as the source states it. Real models put a glass
/// colour in MTL `Tf` (with `Kd` often black), mark glass with `illum` 4, 6 or 7, `d` < 1 or
/// `Tr` > 0, and in glTF with `KHR_materials_transmission` or alpha blending.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Transmission {
    /// MTL `Tf`, or glTF `KHR_materials_volume` attenuation colour, in linear RGB.
    pub filter: Option<[f32; 3]>,
    /// Opacity: MTL `d`, else 1 − `Tr`; glTF base colour alpha of a blended material.
    pub opacity: Option<f32>,
    /// MTL `illum`.
    pub illum: Option<u8>,
    /// glTF `KHR_materials_transmission` factor.
    pub factor: Option<f32>,
    /// glTF `alphaMode: BLEND` on a material that may let light through (a base colour alpha
    /// below 1, or a colour texture).
    pub blend: bool,
}

fn chroma(c: [f32; 3]) -> f32 {
    c.iter().copied().fold(f32::MIN, f32::max) - c.iter().copied().fold(f32::MAX, f32::min)
}

impl Transmission {
    /// Why the source marks this material as glass, or `None` when nothing does.
    pub fn glass_reason(&self) -> Option<String> {
        if let Some(i @ (4 | 6 | 7)) = self.illum {
            return Some(format!("MTL illum {i} (transparency)"));
        }
        // `Tr 0.6` is an opacity of 1 - 0.6, which f32 prints as 0.39999998.
        let tidy = |v: f32| (v as f64 * 1e4).round() / 1e4;
        if let Some(f) = self.factor.filter(|&f| f > 0.0) {
            return Some(format!("glTF transmission {}", tidy(f)));
        }
        if self.blend {
            return Some("glTF alpha mode BLEND".into());
        }
        if let Some(d) = self.opacity.filter(|&d| d < 0.999) {
            return Some(format!("opacity {} (MTL d / Tr)", tidy(d)));
        }
        if let Some(f) = self.filter.filter(|f| f.iter().any(|&c| c < 0.999)) {
            let [r, g, b] = f.map(tidy);
            return Some(format!("transmission filter Tf {r} {g} {b}"));
        }
        None
    }

    /// The colour light takes through the material, linear RGB, and how much passes (0–1).
    /// `Tf` is the transmitted colour when it has one; an uncoloured `Tf` (grey) only scales a
    /// coloured `Kd`, as exporters that keep the glass colour in `Kd` write it.
    pub fn transmitted(&self, diffuse: [f32; 3]) -> ([f32; 3], f32) {
        let amount = match (self.filter, self.opacity) {
            // glTF's transmission factor is the share of light that passes (the rest is
            // diffused): at 0.9 the pane passed all of it, where MTL `d 0.1` passed 0.9.
            (Some(_), _) => self
                .factor
                .filter(|&f| f > 0.0)
                .map_or(1.0, |f| f.clamp(0.05, 1.0)),
            (None, Some(d)) if d < 0.999 => (1.0 - d).clamp(0.05, 1.0),
            _ => 1.0,
        };
        let colour = match self.filter {
            Some(f) if chroma(f) >= 0.05 || chroma(diffuse) < 0.1 => f,
            Some(f) => {
                let level = (f[0] + f[1] + f[2]) / 3.0;
                let peak = diffuse.iter().copied().fold(1e-6, f32::max);
                diffuse.map(|c| c / peak * level)
            }
            None => diffuse,
        };
        (colour.map(|c| c.clamp(0.0, 1.0)), amount)
    }
}

impl SourceMaterial {
    pub fn plain(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            diffuse: [0.8; 3],
            specular: [0.0; 3],
            shininess: 1.0,
            emissive: [0.0; 3],
            diffuse_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            transmission: Transmission::default(),
        }
    }
}

/// Something a user can live with, reported and cooked anyway.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    pub path: PathBuf,
    pub line: Option<usize>,
    pub message: String,
    /// Says geometry other than faces was left out (lines, points): what a model with no
    /// faces is told it holds instead.
    pub skipped_geometry: bool,
}

impl Warning {
    pub fn new(path: &Path, line: Option<usize>, message: impl Into<String>) -> Self {
        Self {
            path: path.to_path_buf(),
            line,
            message: message.into(),
            skipped_geometry: false,
        }
    }

    /// A warning that geometry other than faces was left out.
    pub fn skipped_geometry(path: &Path, line: Option<usize>, message: impl Into<String>) -> Self {
        Self {
            skipped_geometry: true,
            ..Self::new(path, line, message)
        }
    }
}

impl std::fmt::Display for Warning {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.line {
            Some(l) => write!(f, "{}:{l}: {}", self.path.display(), self.message),
            None => write!(f, "{}: {}", self.path.display(), self.message),
        }
    }
}

/// A source file as triangles.
#[derive(Clone, Debug, Default)]
pub struct Imported {
    pub path: PathBuf,
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    pub uvs: Vec<[f32; 2]>,
    /// Linear RGBA per position (glTF `COLOR_0`, an OBJ's `v x y z r g b`); empty where the
    /// file has none, white where one primitive has them and another not. Opaque surfaces
    /// keep them as the pack's vertex colours (alpha left out); windows' designs drawn from
    /// their mesh blend them across the panes.
    pub colours: Vec<[f32; 4]>,
    /// Three per triangle.
    pub corners: Corners,
    /// Per triangle: index into `parts`.
    pub tri_part: Vec<u32>,
    /// Triangles per part, counted when the per-triangle parts were released
    /// ([`Imported::release_parts`]); empty before.
    pub(crate) released_part_triangles: Vec<usize>,
    pub parts: Vec<Part>,
    pub materials: Vec<SourceMaterial>,
    pub warnings: Vec<Warning>,
    /// Polygons with more than three corners that were triangulated.
    pub polygons: usize,
    /// Other files read for this source (material libraries, glTF buffers).
    pub files: Vec<PathBuf>,
    /// Files the source names that were not found, and the cook went on without (a
    /// texture, a material library): should one appear, a cache must not reuse this cook.
    pub absent: Vec<Absent>,
    /// Texture placement an OBJ's materials give (MTL `-o` offset, `-s` scale, in u and v),
    /// by material, applied to the coordinates once every face is read.
    pub(crate) uv_transforms: Vec<(u32, [f32; 2], [f32; 2])>,
    /// The encoding an OBJ's or its MTL's names that are not UTF-8 were read with (given or
    /// guessed); `None` where all are UTF-8.
    pub text_encoding: Option<text::TextEncoding>,
    /// Subtracted from the file's positions (in f64, before they were rounded to f32): a
    /// model in survey coordinates, far from the origin; zero for any other.
    pub origin: [f64; 3],
    /// Views the file frames (glTF cameras), placed as its positions are.
    pub views: Vec<pack::Camera>,
    /// The file's sun (a glTF `KHR_lights_punctual` directional light).
    pub sun: Option<FileSun>,
    /// The file's point and spot lights, placed as its positions are.
    pub lamps: Vec<FileLamp>,
}

/// A point or spot light a model's file places.
#[derive(Clone, Debug, PartialEq)]
pub struct FileLamp {
    pub name: String,
    pub position: [f32; 3],
    /// Linear RGB.
    pub colour: [f32; 3],
    /// A spot light's cone; `None` for a point light.
    pub spot: Option<FileSpot>,
    /// glTF's `range`: past this distance the lamp gives no light (in the model's units).
    pub range: Option<f32>,
}

/// A spot light's cone, as glTF's `KHR_lights_punctual` gives it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FileSpot {
    /// Unit; where the light points.
    pub axis: [f32; 3],
    /// Half-angles from the axis in radians: full light within `inner`, none beyond `outer`
    /// (0 ≤ inner ≤ outer ≤ π/2).
    pub inner: f32,
    pub outer: f32,
}

/// A directional light a model's file places.
#[derive(Clone, Debug, PartialEq)]
pub struct FileSun {
    pub name: String,
    /// Where its light travels (unit).
    pub direction: [f32; 3],
    /// Linear RGB.
    pub colour: [f32; 3],
}

impl Imported {
    pub fn triangle_count(&self) -> usize {
        self.corners.len() / 3
    }

    /// Frees the triangles' corners and source normals once the mesh stage has deduplicated
    /// them (its orderings still read the positions and texture coordinates).
    pub fn release_corners(&mut self) {
        self.normals = Vec::new();
        self.colours = Vec::new();
        self.corners = Corners::default();
    }

    /// Frees the per-triangle parts once each triangle's pack material is known; each part's
    /// triangle count stays (tagging notes and the report read it). They were 4 MB of the
    /// 1M-triangle grid's generated normals, its cook's peak of memory.
    pub fn release_parts(&mut self) {
        self.released_part_triangles = self.part_triangles();
        self.tri_part = Vec::new();
    }

    /// Frees the triangles' corners and attribute arrays once the mesh stage has read them;
    /// names and parts stay (pruning and the report read them).
    pub fn release_geometry(&mut self) {
        self.positions = Vec::new();
        self.normals = Vec::new();
        self.uvs = Vec::new();
        self.colours = Vec::new();
        self.corners = Corners::default();
    }

    /// How many triangles each part has.
    pub fn part_triangles(&self) -> Vec<usize> {
        if !self.released_part_triangles.is_empty() {
            return self.released_part_triangles.clone();
        }
        let mut counts = vec![0usize; self.parts.len()];
        for &p in &self.tri_part {
            counts[p as usize] += 1;
        }
        counts
    }

    /// Applies an affine transform to positions and normals; a mirroring transform also flips
    /// the winding so front faces stay front faces.
    pub fn transform(&mut self, m: glam::Mat4) {
        if m == glam::Mat4::IDENTITY {
            return;
        }
        for p in &mut self.positions {
            *p = m.transform_point3(glam::Vec3::from(*p)).to_array();
        }
        for v in &mut self.views {
            v.position = m.transform_point3(v.position.into()).to_array();
            v.target = m.transform_point3(v.target.into()).to_array();
            v.up = m
                .transform_vector3(v.up.into())
                .normalize_or_zero()
                .to_array();
        }
        if let Some(s) = &mut self.sun {
            s.direction = m
                .transform_vector3(s.direction.into())
                .normalize_or_zero()
                .to_array();
        }
        // A distance scales as lengths do (a uniform scale's factor; the cube root of the
        // volume's for any other).
        let length_scale = glam::Mat3::from_mat4(m).determinant().abs().cbrt();
        for l in &mut self.lamps {
            l.position = m.transform_point3(l.position.into()).to_array();
            l.range = l.range.map(|r| r * length_scale);
            if let Some(FileSpot { axis, .. }) = &mut l.spot {
                *axis = m
                    .transform_vector3((*axis).into())
                    .normalize_or_zero()
                    .to_array();
            }
        }
        let nm = glam::Mat3::from_mat4(m).inverse().transpose();
        for n in &mut self.normals {
            let v = nm * glam::Vec3::from(*n);
            *n = v.normalize_or_zero().to_array();
        }
        if glam::Mat3::from_mat4(m).determinant() < 0.0 {
            for t in 0..self.corners.len() / 3 {
                self.corners.swap(3 * t + 1, 3 * t + 2);
            }
        }
    }
}

/// Coordinates farther than this from the origin (2^17 units, where f32 positions are 1/64
/// of a unit apart) are taken as a model placed in survey coordinates: a scanned church
/// exported in UTM metres lies 500,000 east and 5,000,000 north, where f32 positions are 3 cm
/// and 50 cm apart, and the cook's geometry snapped to that grid without a word.
const FAR: f64 = 131_072.0;

/// The origin a model whose first vertex lies at `first` is moved from before its positions
/// become f32 (`Imported::origin`): its far coordinates rounded to whole units, exact in f32
/// and f64 alike; `None` for a model near the origin.
pub(crate) fn survey_origin(first: [f64; 3]) -> Option<[f64; 3]> {
    let origin = first.map(|v| if v.abs() > FAR { v.round() } else { 0.0 });
    (origin != [0.0; 3]).then_some(origin)
}

/// Imports an OBJ, glTF, GLB or PLY file, by extension.
pub fn import(path: &Path) -> Result<Imported, CookError> {
    import_with(path, None)
}

/// [`import`], reading the names of OBJ and MTL files that are not UTF-8 with `text_encoding`
/// rather than the encoding guessed from them (see [`text`]).
pub fn import_with(
    path: &Path,
    text_encoding: Option<text::TextEncoding>,
) -> Result<Imported, CookError> {
    // A zero-length file is a failed write or a truncated copy, never a mesh; a file with
    // content but no faces (lines, points) still cooks, with the importer's warning.
    if let Ok(m) = std::fs::metadata(path)
        && m.is_file()
        && m.len() == 0
    {
        return Err(CookError::Source {
            path: path.to_path_buf(),
            line: None,
            message: "the file is empty (0 bytes)".into(),
        });
    }
    let mut out = match mesh_format(path)? {
        "obj" => obj::import(path, text_encoding),
        "gltf" | "glb" => gltf::import(path),
        _ => ply::import(path),
    }?;
    warn_far_positions(&mut out);
    Ok(out)
}

/// A model file's format by its extension (lower case: "obj", "gltf", "glb" or "ply"), or the
/// error naming the file for any other.
pub fn mesh_format(path: &Path) -> Result<&'static str, CookError> {
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    ["obj", "gltf", "glb", "ply"]
        .into_iter()
        .find(|f| *f == ext)
        .ok_or_else(|| CookError::Source {
            path: path.to_path_buf(),
            line: None,
            message: format!("unsupported mesh format {ext:?}: expected .obj, .gltf, .glb or .ply"),
        })
}

/// A model whose first vertex lies near the origin but whose others lie in survey coordinates
/// (a small object at the origin written before the scan) is not moved, so those positions
/// were rounded to f32 far out: said rather than cooked coarse without a word.
fn warn_far_positions(out: &mut Imported) {
    if out.origin != [0.0; 3] {
        return;
    }
    let Some(far) = out
        .positions
        .iter()
        .map(|p| p.iter().fold(0.0f32, |m, c| m.max(c.abs())))
        .max_by(f32::total_cmp)
        .filter(|&m| m as f64 > FAR)
    else {
        return;
    };
    // The distance between neighbouring f32 values there.
    let step = f32::from_bits(far.to_bits() + 1) - far;
    out.warnings.push(Warning::new(
        &out.path,
        None,
        format!(
            "positions reach {far:.0} units from the origin, where 32-bit positions are {step} \
             units apart, but the first vertex lies near it, so the model was not moved; \
             translate the file's model near the origin before export, or write the far \
             geometry first"
        ),
    ));
}

/// A file a source names whose lookup ([`locate`]) could answer otherwise while every file
/// the cook read stays as it was: `name` as written, looked for under `dir`, found nowhere
/// (`found` is `None`) or found under another spelling (`found`, relative to `dir`: another
/// letter case, an absolute path's end). If the file of that very name appears, the import
/// takes it. A cache entry keeps these, `dir` made relative to the scene's folder.
#[derive(
    Clone, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct Absent {
    #[serde(with = "crate::path_serde::one")]
    pub dir: PathBuf,
    pub name: String,
    #[serde(
        default,
        skip_serializing_if = "Option::is_none",
        with = "crate::path_serde::option"
    )]
    pub found: Option<PathBuf>,
}

impl Absent {
    /// A file not found.
    pub fn new(dir: &Path, name: &str) -> Self {
        Self {
            dir: dir.to_path_buf(),
            name: name.to_string(),
            found: None,
        }
    }

    /// The lookup of `name` under `dir` that answered `answer`, where that answer could
    /// change: `None` for the file of exactly that name, which stays the answer while it is
    /// there.
    fn of_lookup(dir: &Path, name: &str, answer: Option<&Path>) -> Option<Self> {
        match answer {
            Some(p) if p == dir.join(text::path_of(name)) => None,
            Some(p) => Some(Self {
                found: Some(p.strip_prefix(dir).unwrap_or(p).to_path_buf()),
                ..Self::new(dir, name)
            }),
            None => Some(Self::new(dir, name)),
        }
    }

    /// The same lookup under another folder (a scene's, moved or made relative).
    pub fn under(&self, dir: &Path) -> Self {
        Self {
            dir: dir.to_path_buf(),
            ..self.clone()
        }
    }

    /// Where the lookup finds the file now, if that differs from what the cook found, as a
    /// sentence's subject and verb: "`dir/tex.png` was not found by the last cook and is
    /// there now".
    pub fn changed(&self) -> Option<String> {
        let now = locate(&self.dir, &self.name);
        let now_rel = now
            .as_deref()
            .map(|p| p.strip_prefix(&self.dir).unwrap_or(p));
        if now_rel == self.found.as_deref() {
            return None;
        }
        let asked = self.dir.join(&self.name);
        Some(match (&self.found, now_rel) {
            (None, _) => format!(
                "{} was not found by the last cook and is there now",
                asked.display()
            ),
            (Some(was), Some(is)) => format!(
                "{} was found as {} by the last cook and is {} now",
                asked.display(),
                was.display(),
                is.display()
            ),
            (Some(was), None) => format!(
                "{} was found as {} by the last cook and is not there now",
                asked.display(),
                was.display()
            ),
        })
    }
}

/// [`locate`], noting the lookup in `noted` where its answer could change (see [`Absent`]).
pub(crate) fn locate_noted(dir: &Path, name: &str, noted: &mut Vec<Absent>) -> Option<PathBuf> {
    let found = locate(dir, name);
    noted.extend(Absent::of_lookup(dir, name, found.as_deref()));
    found
}

/// The file `name` (relative to `dir`, or absolute) means, as a file written on Windows means
/// it too: with backslashes for separators, in any letter case (`Textures\glass.PNG` for
/// `textures/Glass.png`), or given by an absolute path from the machine it was made on, or by
/// a relative one whose folders are not there, whose end is then looked for under `dir`.
///
/// A name escaped by [`text::escaped`] (not UTF-8) means the file of those bytes.
pub(crate) fn locate(dir: &Path, name: &str) -> Option<PathBuf> {
    let exact = dir.join(text::path_of(name));
    if exact.is_file() {
        return Some(exact);
    }
    if let Some(p) = as_written_on_windows(dir, name) {
        return Some(p);
    }
    let slashed = name.replace('\\', "/");
    let relative = slashed.trim();
    let relative = relative.strip_prefix("./").unwrap_or(relative);
    // `C:/Users/me/kirche/Textures/glass.png`, `/home/me/...`: the model's folder was moved
    // with its files, so the path's end is under `dir`: `kirche/Textures/glass.png`,
    // `Textures/glass.png`, then `glass.png`. A relative `textures\glass.png` whose folder
    // is gone is the same: an archive that put every file beside the model.
    let parts: Vec<&str> = relative.split('/').filter(|c| !c.is_empty()).collect();
    (1..parts.len()).find_map(|start| any_case(dir, &parts[start..].join("/")))
}

/// The file `name` under `dir` means where it was written on Windows: with backslashes for
/// separators, or in another letter case than the file's. Unlike [`locate`], no shorter end of
/// the path is looked for: a scene manifest's paths are the user's own, not a moved model's.
pub(crate) fn as_written_on_windows(dir: &Path, name: &str) -> Option<PathBuf> {
    let slashed = name.replace('\\', "/");
    let slashed = slashed.trim();
    if slashed.is_empty() {
        return None;
    }
    let relative = slashed.strip_prefix("./").unwrap_or(slashed);
    let candidate = dir.join(text::path_of(relative));
    if candidate.is_file() {
        return Some(candidate);
    }
    any_case(dir, relative)
}

/// `relative` under `dir`, each component matched without regard to letter case.
fn any_case(dir: &Path, relative: &str) -> Option<PathBuf> {
    let mut at = dir.to_path_buf();
    let parts: Vec<&str> = relative
        .split('/')
        .filter(|c| !c.is_empty() && *c != ".")
        .collect();
    for (i, part) in parts.iter().enumerate() {
        let next = if *part == ".." {
            at.join("..")
        } else {
            let entries = std::fs::read_dir(if at.as_os_str().is_empty() {
                Path::new(".")
            } else {
                &at
            })
            .ok()?;
            let lower = part.to_lowercase();
            // A name on disk that is not UTF-8 (`узор.png` in windows-1251 bytes) is compared
            // as the common encodings read it: the model names it in its own letters
            // (`Узор.PNG`), and its escaped bytes have no letter case.
            let same = |n: &std::ffi::OsStr| {
                let t = text::file_name_text(n);
                t.to_lowercase() == lower
                    || (text::is_escaped(&t)
                        && text::COMMON
                            .iter()
                            .any(|&e| text::decode_escaped(&t, e).to_lowercase() == lower))
            };
            let found = entries
                .filter_map(Result::ok)
                .map(|e| e.file_name())
                .filter(|n| same(n))
                .min()?;
            at.join(found)
        };
        let last = i + 1 == parts.len();
        if (last && next.is_file()) || (!last && next.is_dir()) {
            at = next;
        } else {
            return None;
        }
    }
    (!parts.is_empty()).then_some(at)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// How much light a pane passes: MTL `d 0.1` and glTF transmission 0.9 alike pass 0.9;
    /// a `Tf` filter passes its colour whole; a glTF transmission of 1 all of it. The
    /// glass reason prints the numbers as written (`Tr 0.6`: opacity 0.4).
    #[test]
    fn mtl_opacity_and_gltf_transmission_pass_the_same_share() {
        let mtl = Transmission {
            opacity: Some(0.1),
            ..Transmission::default()
        };
        let gltf = |f: f32| Transmission {
            filter: Some([0.2, 0.4, 0.9]),
            factor: Some(f),
            ..Transmission::default()
        };
        assert!((mtl.transmitted([0.2, 0.4, 0.9]).1 - 0.9).abs() < 1e-6);
        assert_eq!(gltf(0.9).transmitted([1.0; 3]), ([0.2, 0.4, 0.9], 0.9));
        assert_eq!(gltf(1.0).transmitted([1.0; 3]).1, 1.0);
        let tf = Transmission {
            filter: Some([0.8, 0.1, 0.1]),
            ..Transmission::default()
        };
        assert_eq!(tf.transmitted([0.0; 3]).1, 1.0);
        let tr = Transmission {
            opacity: Some(1.0 - 0.6f32),
            ..Transmission::default()
        };
        assert_eq!(
            tr.glass_reason().as_deref(),
            Some("opacity 0.4 (MTL d / Tr)")
        );
    }

    /// Far positions behind a first vertex near the origin are not moved, and said so.
    #[test]
    fn far_positions_the_move_missed_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("m.obj");
        let far = "v 500000 0 0\nv 500001 0 0\nv 500000 1 0\nf 1 2 3\n";
        std::fs::write(&path, format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n{far}")).unwrap();
        let m = import(&path).unwrap();
        assert_eq!(m.origin, [0.0; 3]);
        let said: Vec<String> = m.warnings.iter().map(|w| w.message.clone()).collect();
        assert!(
            said.iter().any(|w| w.starts_with(
                "positions reach 500001 units from the origin, where 32-bit positions are 0.03125 \
                 units apart"
            )),
            "{said:?}"
        );
        // Moved (the far vertex first) or near throughout: nothing to say.
        std::fs::write(&path, far).unwrap();
        let moved = import(&path).unwrap();
        assert_eq!(moved.origin, [500000.0, 0.0, 0.0]);
        assert!(
            !moved
                .warnings
                .iter()
                .any(|w| w.message.contains("positions reach"))
        );
    }

    proptest! {
        /// Appended primitive by primitive as glTF's shared indices, the corners read back as
        /// pushed one by one, and a field is held only where it does not follow the positions.
        #[test]
        fn shared_indices_append_as_pushed(
            prims in prop::collection::vec(
                (prop::collection::vec(0u32..6, 0..12), any::<bool>(), any::<bool>()),
                0..5,
            ),
        ) {
            let (mut appended, mut pushed) = (Corners::default(), Corners::default());
            let mut bases = [0u32; 3];
            for (indices, uvs, normals) in prims {
                let [p, t, n] = bases;
                let t = uvs.then_some(t);
                let n = normals.then_some(n);
                for &i in &indices {
                    pushed.push(Corner {
                        p: p + i,
                        t: t.map_or(NONE, |t| t + i),
                        n: n.map_or(NONE, |n| n + i),
                    });
                }
                appended.append_shared(indices.iter().map(|&i| p + i).collect(), p, t, n);
                // Six vertices a primitive, each attribute's array grown only by those that have it.
                bases = [p + 6, t.map_or(bases[1], |t| t + 6), n.map_or(bases[2], |n| n + 6)];
            }
            prop_assert_eq!(appended.iter().collect::<Vec<_>>(), pushed.iter().collect::<Vec<_>>());
            for (held, field) in [(&appended.t, appended.uv_indices()), (&appended.n, appended.normal_indices())] {
                if let Indices::Own(v) = held {
                    prop_assert!(v != appended.positions(), "a field that follows the positions is held");
                }
                prop_assert!(field.len() == appended.len() || field.is_empty());
            }
        }

        /// Pushed, set and swapped, the field-by-field corners read back as a plain vector of
        /// corners does, hold a texture-coordinate or normal field only while some corner
        /// has one, and do not hold one that is the position indices over again.
        #[test]
        fn corners_read_back_as_pushed(
            pushed in prop::collection::vec((0u32..9, prop::option::of(0u32..9), prop::option::of(0u32..9)), 0..40),
            edits in prop::collection::vec((0usize..40, 0usize..40, prop::option::of(0u32..9)), 0..10),
            same in (any::<bool>(), any::<bool>()),
        ) {
            // Fields that follow the positions, as glTF's and many OBJ writers' do.
            let corner = |(p, t, n): (u32, Option<u32>, Option<u32>)| Corner {
                p,
                t: if same.0 { p } else { t.unwrap_or(NONE) },
                n: if same.1 { p } else { n.unwrap_or(NONE) },
            };
            let mut want: Vec<Corner> = pushed.iter().map(|&c| corner(c)).collect();
            let mut got: Corners = want.iter().copied().collect();
            let follows = |want: &[Corner], f: fn(&Corner) -> u32| {
                !want.is_empty() && want.iter().all(|c| f(c) == c.p)
            };
            prop_assert_eq!(follows(&want, |c| c.t), got.t == Indices::Positions);
            prop_assert_eq!(follows(&want, |c| c.n), got.n == Indices::Positions);
            if same.0 && !want.is_empty() {
                prop_assert_eq!(&got.t, &Indices::Positions);
            }
            for (i, j, t) in edits {
                if want.is_empty() {
                    break;
                }
                let (i, j) = (i % want.len(), j % want.len());
                want.swap(i, j);
                got.swap(i, j);
                want[i].t = t.unwrap_or(NONE);
                got.set(i, Corner { t: t.unwrap_or(NONE), ..got.get(i) });
            }
            prop_assert_eq!(got.iter().collect::<Vec<_>>(), want.clone());
            prop_assert_eq!(!got.normal_indices().is_empty(), want.iter().any(|c| c.n != NONE));
            if want.iter().any(|c| c.t != NONE) {
                prop_assert!(!got.uv_indices().is_empty());
            }
            let fields = |f: fn(&Corner) -> u32| want.iter().map(f).collect::<Vec<_>>();
            let whole = Corners::from_fields(fields(|c| c.p), fields(|c| c.t), fields(|c| c.n));
            prop_assert_eq!(whole.iter().collect::<Vec<_>>(), want.clone());
            prop_assert_eq!(whole.t == Indices::Positions, follows(&want, |c| c.t));
            prop_assert_eq!(whole.n == Indices::Positions, follows(&want, |c| c.n));
            prop_assert_eq!(!whole.uv_indices().is_empty(), want.iter().any(|c| c.t != NONE));
        }
    }
}
