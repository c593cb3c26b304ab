//! Mesh processing: from a tagged triangle soup to GPU-ready, optimized vertex and index
//! buffers with one draw range per material (window materials last, since they are blended).
//!
//! Order matters: indices are already validated by the importers (meshopt crashes the process
//! on an out-of-range index), -0.0 is normalized before deduplication (meshopt compares raw
//! bits), and vertices shared by two materials are split simply because the material ID is
//! part of the vertex.

use std::time::{Duration, Instant};

use pack::StandardVertex;
use rayon::prelude::*;

use crate::import::{Imported, NONE};

/// Vertex cache optimizer.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum CacheMode {
    /// meshopt's full optimizer (Forsyth-like, best ACMR).
    #[default]
    Full,
    /// meshopt's FIFO optimizer (cache of 16): faster, slightly worse ACMR (docs/bench has both
    /// modes side by side).
    Fifo,
}

#[derive(Clone, Debug)]
pub struct MeshSettings {
    pub cache: CacheMode,
    /// Reorder opaque ranges to reduce overdraw (threshold 1.05).
    pub overdraw: bool,
    /// Faces meeting at a sharper angle than this keep separate generated normals.
    pub crease_angle_deg: f32,
}

impl Default for MeshSettings {
    fn default() -> Self {
        Self {
            cache: CacheMode::Full,
            overdraw: false,
            crease_angle_deg: 60.0,
        }
    }
}

/// What each material needs from mesh processing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MaterialNeeds {
    /// Blended: drawn after every opaque range.
    pub window: bool,
    /// Has a normal map: MikkTSpace tangents are generated.
    pub tangents: bool,
    /// Samples a texture (design, colour or normal map). Without it the texture coordinates
    /// are zeroed before deduplication, so vertices that differ only there merge.
    pub uvs: bool,
    /// Is shaded with its normal (everything but unlit backdrops); zeroed otherwise.
    pub normals: bool,
}

impl MaterialNeeds {
    /// An opaque material that keeps every attribute the source has.
    pub const OPAQUE: MaterialNeeds = MaterialNeeds {
        window: false,
        tangents: false,
        uvs: true,
        normals: true,
    };
}

/// Per-stage numbers, for `cooker cook -v`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshStats {
    pub triangles_in: usize,
    pub degenerate_dropped: usize,
    pub triangles_out: usize,
    pub corners: usize,
    pub vertices_out: usize,
    pub normals_generated: usize,
    pub tangent_triangles: usize,
    /// ACMR with a FIFO cache of 16, before and after cache optimization.
    pub acmr_in: f32,
    pub acmr_out: f32,
    pub overfetch: f32,
    pub stages: Vec<(&'static str, Duration)>,
}

/// Processed geometry of one mesh.
#[derive(Clone, Debug, Default)]
pub struct Processed {
    pub vertices: Vec<StandardVertex>,
    pub indices: Vec<u32>,
    pub ranges: Vec<pack::DrawRange>,
    pub bounds_min: [f32; 3],
    pub bounds_max: [f32; 3],
    pub stats: MeshStats,
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn normalize(a: [f32; 3]) -> [f32; 3] {
    let l = dot(a, a).sqrt();
    if l > 0.0 && l.is_finite() {
        [a[0] / l, a[1] / l, a[2] / l]
    } else {
        [0.0; 3]
    }
}

/// True when the triangle has no area: repeated corners or collinear positions.
pub fn is_degenerate(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> bool {
    let n = cross(sub(b, a), sub(c, a));
    // Written so NaN counts as degenerate too.
    dot(n, n).partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
}

fn plus_zero(v: f32) -> f32 {
    // -0.0 == 0.0 compares equal but has different bits; adding +0.0 maps -0.0 to +0.0.
    v + 0.0
}

struct Timer {
    last: Instant,
    stages: Vec<(&'static str, Duration)>,
}

impl Timer {
    fn new() -> Self {
        Self {
            last: Instant::now(),
            stages: Vec::new(),
        }
    }
    fn lap(&mut self, name: &'static str) {
        let now = Instant::now();
        self.stages.push((name, now - self.last));
        self.last = now;
    }
}

/// FxHash (rustc's hasher): the weld map hashes millions of small fixed-size keys, where
/// SipHash's DoS resistance buys nothing.
#[derive(Default, Clone, Copy)]
struct FxHasher(u64);

impl std::hash::Hasher for FxHasher {
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            let mut word = [0u8; 8];
            word.copy_from_slice(c);
            self.write_u64(u64::from_le_bytes(word));
        }
        for &b in chunks.remainder() {
            self.write_u64(b as u64);
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.write_u64(v as u64);
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
    fn finish(&self) -> u64 {
        // Multiplication only moves entropy upwards, and the table indexes by the low bits:
        // keys whose low words are constant (no UVs, one material) would all collide. MurmurHash3's
        // finalizer spreads every input bit over the whole word.
        let mut h = self.0;
        h ^= h >> 33;
        h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
        h ^= h >> 33;
        h = h.wrapping_mul(0xc4ce_b9fe_1a85_ec53);
        h ^ (h >> 33)
    }
}

/// Welds values by their bits (after -0.0 → +0.0): equal values get equal ids, in order of
/// first appearance.
///
/// An open-addressing table of 8-byte slots (hash fingerprint and index of the first
/// occurrence, linear probing, values compared through `values`) rather than a map holding
/// the keys: no key copies, and a probe touches one small slot, which measured about twice as
/// fast as `HashMap<[u32; N], u32>` with FxHash on large grids (the mesh sweep in docs/bench
/// times the whole stage).
fn weld<const N: usize>(values: &[[f32; N]]) -> (Vec<u32>, usize) {
    const EMPTY: u64 = u64::MAX;
    let bits = |v: &[f32; N]| v.map(|c| plus_zero(c).to_bits());
    let size = (values.len() * 2).next_power_of_two().max(16);
    let mask = size - 1;
    // Each slot: the hash's high half as a fingerprint, and the index of the value's first
    // occurrence; values are read back only when fingerprints agree.
    let mut slots = vec![EMPTY; size];
    let mut ids: Vec<u32> = Vec::with_capacity(values.len());
    let mut next = 0u32;
    for (i, v) in values.iter().enumerate() {
        let key = bits(v);
        let mut h = FxHasher::default();
        for k in key {
            std::hash::Hasher::write_u32(&mut h, k);
        }
        let hash = std::hash::Hasher::finish(&h);
        let fingerprint = hash >> 32;
        let mut slot = hash as usize & mask;
        loop {
            let entry = slots[slot];
            if entry == EMPTY {
                slots[slot] = fingerprint << 32 | i as u64;
                ids.push(next);
                next += 1;
                break;
            }
            let at = (entry & 0xffff_ffff) as usize;
            if entry >> 32 == fingerprint && bits(&values[at]) == key {
                ids.push(ids[at]);
                break;
            }
            slot = (slot + 1) & mask;
        }
    }
    (ids, next as usize)
}

/// A normal for every corner (3 per kept triangle), as an index into a table of unit normals.
///
/// Source normals are used as they are. Missing ones are generated, angle-weighted, around
/// each position (welded by value, so unwelded sources still smooth): the corners around a
/// position fall into clusters, each corner joining the first cluster whose first face lies
/// within the crease angle of its own face, so hard edges stay hard and a smooth surface gets
/// one normal per position. Returns (per-corner ids, table, corners generated).
fn corner_normals(
    src: &Imported,
    canon: &[u32],
    welded: usize,
    keep: &[u32],
    tris: &[[u32; 3]],
    face_normals: &[[f32; 3]],
    crease_cos: f32,
) -> (Vec<u32>, Vec<[f32; 3]>, usize) {
    let unit: Vec<[f32; 3]> = src.normals.iter().map(|&n| normalize(n)).collect();
    let (source_id, count) = weld(&unit);
    let mut table = vec![[0.0f32; 3]; count];
    for (n, &id) in unit.iter().zip(&source_id) {
        table[id as usize] = n.map(plus_zero);
    }
    let mut ids: Vec<u32> = Vec::with_capacity(keep.len() * 3);
    let mut missing = 0usize;
    for &t in keep {
        for c in &src.corners[t as usize * 3..t as usize * 3 + 3] {
            let id = if c.n == NONE {
                NONE
            } else {
                source_id[c.n as usize]
            };
            if id == NONE || dot(table[id as usize], table[id as usize]) == 0.0 {
                ids.push(NONE);
                missing += 1;
            } else {
                ids.push(id);
            }
        }
    }
    if missing == 0 {
        return (ids, table, 0);
    }

    // Corners needing a normal, grouped by welded position (counting sort keeps corner order).
    let mut start = vec![0u32; welded + 1];
    for (k, &id) in ids.iter().enumerate() {
        if id == NONE {
            start[canon[tris[k / 3][k % 3] as usize] as usize + 1] += 1;
        }
    }
    for i in 0..welded {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut adj = vec![0u32; missing];
    for (k, &id) in ids.iter().enumerate() {
        if id == NONE {
            let c = canon[tris[k / 3][k % 3] as usize] as usize;
            adj[fill[c] as usize] = k as u32;
            fill[c] += 1;
        }
    }
    drop(fill);
    let weights: Vec<f32> = tris
        .par_iter()
        .flat_map_iter(|t| {
            let [a, b, c] = t.map(|i| src.positions[i as usize]);
            // Each edge normalized once; negating a unit vector is exact, so these are the
            // same angles as normalizing both edges at every corner.
            let (ab, bc, ca) = (
                normalize(sub(b, a)),
                normalize(sub(c, b)),
                normalize(sub(a, c)),
            );
            let angle = |u: [f32; 3], v: [f32; 3]| (-dot(u, v)).clamp(-1.0, 1.0).acos();
            [angle(ab, ca), angle(bc, ab), angle(ca, bc)]
        })
        .collect();
    // Per position: cluster its corners, sum each cluster. Sequential with reused buffers: one
    // short pass over the corners, and ids come out in position order.
    let mut reps: Vec<[f32; 3]> = Vec::new();
    let mut sums: Vec<[f32; 3]> = Vec::new();
    let mut slots: Vec<u32> = Vec::new();
    for c in 0..welded {
        let corners = &adj[start[c] as usize..start[c + 1] as usize];
        if corners.is_empty() {
            continue;
        }
        reps.clear();
        sums.clear();
        slots.clear();
        for &k in corners {
            let f = face_normals[k as usize / 3];
            let slot = match reps.iter().position(|r| dot(*r, f) >= crease_cos) {
                Some(s) => s,
                None => {
                    reps.push(f);
                    sums.push([0.0; 3]);
                    reps.len() - 1
                }
            };
            let w = weights[k as usize];
            let s = &mut sums[slot];
            *s = [s[0] + f[0] * w, s[1] + f[1] * w, s[2] + f[2] * w];
            slots.push(slot as u32);
        }
        let base = table.len() as u32;
        for (s, r) in sums.iter().zip(&reps) {
            let n = normalize(*s);
            table.push(if dot(n, n) > 0.0 {
                n.map(plus_zero)
            } else {
                *r
            });
        }
        for (&k, &slot) in corners.iter().zip(&slots) {
            ids[k as usize] = base + slot;
        }
    }
    (ids, table, missing)
}

fn vertex(
    src: &Imported,
    c: crate::import::Corner,
    normal: [f32; 3],
    material: u16,
    need: MaterialNeeds,
) -> StandardVertex {
    StandardVertex {
        position: src.positions[c.p as usize].map(plus_zero),
        normal: if need.normals { normal } else { [0.0; 3] },
        uv: if c.t == NONE || !need.uvs {
            [0.0; 2]
        } else {
            src.uvs[c.t as usize].map(plus_zero)
        },
        tangent: [0.0; 4],
        material: [material, 0],
    }
}

/// Deduplicates corners by their welded attribute ids (position, texture coordinate,
/// normal, material), without materializing a vertex per corner: the same result as
/// comparing whole vertices, since every attribute is welded by value.
#[allow(clippy::too_many_arguments)]
fn dedupe_by_key(
    src: &Imported,
    canon: &[u32],
    welded: usize,
    keep: &[u32],
    tri_material: &[u16],
    needs: &[MaterialNeeds],
    corner_normal: &[u32],
    normal_table: &[[f32; 3]],
) -> (Vec<StandardVertex>, Vec<u32>) {
    const END: u32 = u32::MAX;
    let (uv, _) = weld(&src.uvs);
    // Every key starts with its welded position, and a position has only a handful of
    // distinct vertices (one per normal, UV seam or material), so a chain per position found
    // through a flat array replaces a hash map: no hashing, and the probe is one cache line.
    // It measured more than twice as fast as an FxHash map on the bunny.
    let mut head = vec![END; welded];
    let mut next: Vec<u32> = Vec::new();
    let mut vertex_keys: Vec<(u32, u32, u16)> = Vec::new();
    let mut vertices = Vec::new();
    let mut indices = Vec::with_capacity(keep.len() * 3);
    for (&t, normals) in keep.iter().zip(corner_normal.chunks_exact(3)) {
        let m = tri_material[t as usize];
        let need = needs[m as usize];
        let corners = &src.corners[t as usize * 3..t as usize * 3 + 3];
        for (&c, &n) in corners.iter().zip(normals) {
            let p = canon[c.p as usize] as usize;
            let uv_id = if c.t == NONE || !need.uvs {
                NONE
            } else {
                uv[c.t as usize]
            };
            let normal_id = if need.normals { n } else { NONE };
            let key = (uv_id, normal_id, m);
            let mut id = head[p];
            while id != END && vertex_keys[id as usize] != key {
                id = next[id as usize];
            }
            if id == END {
                id = vertices.len() as u32;
                vertices.push(vertex(src, c, normal_table[n as usize], m, need));
                vertex_keys.push(key);
                next.push(head[p]);
                head[p] = id;
            }
            indices.push(id);
        }
    }
    (vertices, indices)
}

/// The general path when some material has a normal map: one vertex per corner, MikkTSpace
/// tangents on the triangles that need them, then deduplication of whole vertices.
fn dedupe_with_tangents(
    src: &Imported,
    keep: &[u32],
    tri_material: &[u16],
    needs: &[MaterialNeeds],
    corner_normal: &[u32],
    normal_table: &[[f32; 3]],
) -> (Vec<StandardVertex>, Vec<u32>, usize) {
    let mut corners: Vec<StandardVertex> = Vec::with_capacity(keep.len() * 3);
    for (k, &t) in keep.iter().enumerate() {
        let m = tri_material[t as usize];
        for j in 0..3 {
            let c = src.corners[t as usize * 3 + j];
            corners.push(vertex(
                src,
                c,
                normal_table[corner_normal[k * 3 + j] as usize],
                m,
                needs[m as usize],
            ));
        }
    }
    let tangent_faces: Vec<u32> = keep
        .iter()
        .enumerate()
        .filter(|&(_, &t)| needs[tri_material[t as usize] as usize].tangents)
        .map(|(k, _)| k as u32)
        .collect();
    if !tangent_faces.is_empty() {
        let mut g = Mikk {
            verts: &mut corners,
            faces: &tangent_faces,
        };
        mikktspace::generate_tangents(&mut g);
        for &f in &tangent_faces {
            for v in &mut corners[f as usize * 3..f as usize * 3 + 3] {
                if !v.tangent.iter().all(|c| c.is_finite()) {
                    v.tangent = [1.0, 0.0, 0.0, 1.0];
                }
                v.tangent = v.tangent.map(plus_zero);
            }
        }
    }
    let (unique, remap) = meshopt::generate_vertex_remap(&corners, None);
    let indices = meshopt::remap_index_buffer(None, corners.len(), &remap);
    let vertices = meshopt::remap_vertex_buffer(&corners, unique, &remap);
    (vertices, indices, tangent_faces.len())
}

struct Mikk<'a> {
    verts: &'a mut [StandardVertex],
    /// Triangles (corner offsets / 3) that need tangents.
    faces: &'a [u32],
}

impl mikktspace::Geometry for Mikk<'_> {
    fn num_faces(&self) -> usize {
        self.faces.len()
    }
    fn num_vertices_of_face(&self, _: usize) -> usize {
        3
    }
    fn position(&self, face: usize, vert: usize) -> [f32; 3] {
        self.verts[self.faces[face] as usize * 3 + vert].position
    }
    fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
        self.verts[self.faces[face] as usize * 3 + vert].normal
    }
    fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
        self.verts[self.faces[face] as usize * 3 + vert].uv
    }
    fn set_tangent_encoded(&mut self, tangent: [f32; 4], face: usize, vert: usize) {
        self.verts[self.faces[face] as usize * 3 + vert].tangent = tangent;
    }
}

/// Processes one imported source whose triangles carry pack material IDs (`tri_material`,
/// parallel to `src.tri_part`).
pub fn process(
    src: &Imported,
    tri_material: &[u16],
    needs: &[MaterialNeeds],
    settings: &MeshSettings,
) -> Processed {
    let mut timer = Timer::new();
    let mut stats = MeshStats {
        triangles_in: src.triangle_count(),
        ..Default::default()
    };

    // Drop degenerate triangles before anything divides by their area.
    let mut keep: Vec<u32> = Vec::with_capacity(src.triangle_count());
    for (ti, c) in src.corners.chunks_exact(3).enumerate() {
        let [a, b, d] = [c[0], c[1], c[2]].map(|c| src.positions[c.p as usize]);
        if c[0].p != c[1].p && c[1].p != c[2].p && c[0].p != c[2].p && !is_degenerate(a, b, d) {
            keep.push(ti as u32);
        }
    }
    stats.degenerate_dropped = src.triangle_count() - keep.len();
    // Group by material, windows last; stable, so source order is kept within a material.
    keep.sort_by_key(|&t| {
        let m = tri_material[t as usize];
        (needs[m as usize].window, m)
    });
    timer.lap("filter+group");

    let tris: Vec<[u32; 3]> = keep
        .iter()
        .map(|&t| {
            let c = &src.corners[t as usize * 3..t as usize * 3 + 3];
            [c[0].p, c[1].p, c[2].p]
        })
        .collect();
    let face_normals: Vec<[f32; 3]> = tris
        .par_iter()
        .map(|t| {
            let [a, b, c] = t.map(|i| src.positions[i as usize]);
            normalize(cross(sub(b, a), sub(c, a)))
        })
        .collect();
    let crease = settings.crease_angle_deg.to_radians().cos();
    let (canon, welded) = weld(&src.positions);
    let (corner_normal, normal_table, generated) =
        corner_normals(src, &canon, welded, &keep, &tris, &face_normals, crease);
    stats.normals_generated = generated;
    stats.corners = keep.len() * 3;
    timer.lap("normals");

    let any_tangents = needs.iter().any(|n| n.tangents);
    let (vertices, mut indices) = if any_tangents {
        let (v, i, tangent_triangles) = dedupe_with_tangents(
            src,
            &keep,
            tri_material,
            needs,
            &corner_normal,
            &normal_table,
        );
        stats.tangent_triangles = tangent_triangles;
        timer.lap("tangents+dedupe");
        (v, i)
    } else {
        let (v, i) = dedupe_by_key(
            src,
            &canon,
            welded,
            &keep,
            tri_material,
            needs,
            &corner_normal,
            &normal_table,
        );
        timer.lap("dedupe");
        (v, i)
    };

    let mut ranges: Vec<pack::DrawRange> = Vec::new();
    for (k, &t) in keep.iter().enumerate() {
        let m = tri_material[t as usize];
        match ranges.last_mut() {
            Some(r) if r.material == m => r.index_count += 3,
            _ => ranges.push(pack::DrawRange {
                material: m,
                first_index: (k * 3) as u32,
                index_count: 3,
            }),
        }
    }
    stats.acmr_in = if indices.is_empty() {
        0.0
    } else {
        meshopt::analyze_vertex_cache(&indices, vertices.len(), 16, 0, 0).acmr
    };
    for r in &ranges {
        let span = &mut indices[r.first_index as usize..(r.first_index + r.index_count) as usize];
        match settings.cache {
            CacheMode::Full => meshopt::optimize_vertex_cache_in_place(span, vertices.len()),
            CacheMode::Fifo => {
                meshopt::optimize_vertex_cache_fifo_in_place(span, vertices.len(), 16)
            }
        }
    }
    timer.lap("vertex cache");
    if settings.overdraw {
        let bytes: &[u8] = bytemuck::cast_slice(&vertices);
        if let Ok(adapter) =
            meshopt::VertexDataAdapter::new(bytes, std::mem::size_of::<StandardVertex>(), 0)
        {
            for r in ranges.iter().filter(|r| !needs[r.material as usize].window) {
                let span =
                    &mut indices[r.first_index as usize..(r.first_index + r.index_count) as usize];
                meshopt::optimize_overdraw_in_place(span, &adapter, 1.05);
            }
        }
        timer.lap("overdraw");
    }
    // Drops unreferenced vertices too; the returned buffer is exactly the used ones.
    let vertices = meshopt::optimize_vertex_fetch(&mut indices, &vertices);
    timer.lap("vertex fetch");

    stats.triangles_out = indices.len() / 3;
    stats.vertices_out = vertices.len();
    if !indices.is_empty() {
        stats.acmr_out = meshopt::analyze_vertex_cache(&indices, vertices.len(), 16, 0, 0).acmr;
        stats.overfetch = meshopt::analyze_vertex_fetch(
            &indices,
            vertices.len(),
            std::mem::size_of::<StandardVertex>(),
        )
        .overfetch;
    }
    let mut bounds_min = [f32::INFINITY; 3];
    let mut bounds_max = [f32::NEG_INFINITY; 3];
    for v in &vertices {
        for k in 0..3 {
            bounds_min[k] = bounds_min[k].min(v.position[k]);
            bounds_max[k] = bounds_max[k].max(v.position[k]);
        }
    }
    if vertices.is_empty() {
        bounds_min = [0.0; 3];
        bounds_max = [0.0; 3];
    }
    stats.stages = timer.stages;
    Processed {
        vertices,
        indices,
        ranges,
        bounds_min,
        bounds_max,
        stats,
    }
}

pub use pack::vertex::{Encoded, PositionBits};

/// Which optional vertex attributes a mesh stores; position and material ID always are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Attributes {
    pub normal: bool,
    pub uv: bool,
    pub tangent: bool,
}

impl Attributes {
    pub const ALL: Attributes = Attributes {
        normal: true,
        uv: true,
        tangent: true,
    };

    /// What the given materials need: an attribute no material of the mesh uses is dropped.
    pub fn for_materials(
        needs: &[MaterialNeeds],
        materials: impl IntoIterator<Item = u16>,
    ) -> Self {
        let mut a = Attributes {
            normal: false,
            uv: false,
            tangent: false,
        };
        for m in materials {
            let n = needs[m as usize];
            a.normal |= n.normals || n.tangents;
            a.uv |= n.uvs || n.tangents;
            a.tangent |= n.tangents;
        }
        a
    }

    /// Names of the attributes left out, for the report.
    pub fn dropped(&self) -> Vec<&'static str> {
        [
            (self.normal, "normal"),
            (self.uv, "uv"),
            (self.tangent, "tangent"),
        ]
        .into_iter()
        .filter(|(kept, _)| !kept)
        .map(|(_, name)| name)
        .collect()
    }
}

/// Encodes vertices with the attributes `attrs` keeps, quantized when `quantize` gives the
/// position bits; the layouts are [`pack::vertex::encode`]'s.
pub fn encode(
    vertices: &[StandardVertex],
    bounds_min: [f32; 3],
    bounds_max: [f32; 3],
    attrs: Attributes,
    quantize: Option<PositionBits>,
) -> Encoded {
    let encoding = pack::vertex::Encoding {
        normal: attrs.normal,
        uv: attrs.uv,
        tangent: attrs.tangent,
        quantize,
    };
    pack::vertex::encode(vertices, bounds_min, bounds_max, encoding)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::import::{Corner, Part};
    use proptest::prelude::*;

    fn soup(positions: Vec<[f32; 3]>, tris: Vec<[u32; 3]>) -> Imported {
        let n = tris.len();
        Imported {
            positions,
            corners: tris
                .iter()
                .flatten()
                .map(|&p| Corner {
                    p,
                    t: NONE,
                    n: NONE,
                })
                .collect(),
            tri_part: vec![0; n],
            parts: vec![Part {
                names: Default::default(),
                material: None,
            }],
            ..Default::default()
        }
    }

    const OPAQUE: MaterialNeeds = MaterialNeeds::OPAQUE;
    const WINDOW: MaterialNeeds = MaterialNeeds {
        window: true,
        ..MaterialNeeds::OPAQUE
    };

    #[test]
    fn shared_vertices_are_split_per_material_and_windows_come_last() {
        // Two triangles sharing an edge, different materials; window material has the lower ID.
        let s = soup(
            vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [1., 1., 0.]],
            vec![[0, 1, 2], [2, 1, 3]],
        );
        let p = process(&s, &[0, 1], &[WINDOW, OPAQUE], &MeshSettings::default());
        assert_eq!(p.vertices.len(), 6, "the shared edge must be split");
        assert_eq!(
            p.ranges.iter().map(|r| r.material).collect::<Vec<_>>(),
            vec![1, 0]
        );
        for r in &p.ranges {
            for &i in &p.indices[r.first_index as usize..(r.first_index + r.index_count) as usize] {
                assert_eq!(p.vertices[i as usize].material[0], r.material);
            }
        }
        // Generated normals of a flat quad are exactly +Z.
        assert!(p.vertices.iter().all(|v| v.normal == [0.0, 0.0, 1.0]));
    }

    #[test]
    fn negative_zero_is_deduplicated() {
        let s = soup(
            vec![
                [0., 0., 0.],
                [1., 0., 0.],
                [0., 1., 0.],
                [-0.0, 0., -0.0],
                [1., 1., 0.],
            ],
            vec![[0, 1, 2], [3, 4, 2]],
        );
        let p = process(&s, &[0, 0], &[OPAQUE], &MeshSettings::default());
        assert_eq!(p.vertices.len(), 4);
        assert!(p.vertices.iter().all(|v| {
            v.position
                .iter()
                .all(|c| c.to_bits() != (-0.0f32).to_bits())
        }));
    }

    #[test]
    fn crease_angle_keeps_box_edges_hard() {
        // Two faces at 90 degrees sharing an edge: normals must stay per face.
        let s = soup(
            vec![[0., 0., 0.], [1., 0., 0.], [0., 1., 0.], [0., 0., 1.]],
            vec![[0, 1, 2], [0, 3, 1]],
        );
        let p = process(&s, &[0, 0], &[OPAQUE], &MeshSettings::default());
        assert_eq!(p.vertices.len(), 6);
    }

    #[test]
    fn quantization_error_is_bounded() {
        let s = soup(
            vec![[0., 0., 0.], [10., 0., 0.], [0., 3., 1.]],
            vec![[0, 1, 2]],
        );
        let p = process(&s, &[0], &[OPAQUE], &MeshSettings::default());
        let q = encode(
            &p.vertices,
            p.bounds_min,
            p.bounds_max,
            Attributes::ALL,
            Some(PositionBits::B16),
        );
        assert_eq!(q.bytes.len(), p.vertices.len() * q.layout.stride as usize);
        assert!(
            q.max_position_error <= 10.0 / 65535.0 * 0.51,
            "{}",
            q.max_position_error
        );
        assert!(q.max_normal_error_deg < 0.01, "{}", q.max_normal_error_deg);
    }

    proptest! {
        /// The table weld gives the ids a map keyed by the values' bits would, in order of
        /// first appearance, with -0.0 and +0.0 merged.
        #[test]
        fn weld_matches_a_map(values in prop::collection::vec(prop::array::uniform3(prop::sample::select(vec![-1.0f32, -0.0, 0.0, 0.5, 1e30, f32::MIN_POSITIVE])), 0..200)) {
            let (ids, count) = weld(&values);
            let mut map = std::collections::HashMap::new();
            let want: Vec<u32> = values
                .iter()
                .map(|v| {
                    let n = map.len() as u32;
                    *map.entry(v.map(|c| (c + 0.0).to_bits())).or_insert(n)
                })
                .collect();
            prop_assert_eq!(ids, want);
            prop_assert_eq!(count, map.len());
        }

        /// Arbitrary (often degenerate) soups: every output triangle is non-degenerate, every
        /// index is in range, ranges tile the index buffer and vertices agree with their range.
        #[test]
        fn arbitrary_soups_process_cleanly(
            pts in prop::collection::vec(prop::array::uniform3(prop::sample::select(vec![-1.0f32, -0.0, 0.0, 0.5, 1.0, 2.0])), 1..12),
            raw in prop::collection::vec((0u32..12, 0u32..12, 0u32..12, 0u16..3), 0..40),
            fifo in any::<bool>(),
        ) {
            let n = pts.len() as u32;
            let tris: Vec<[u32; 3]> = raw.iter().map(|&(a, b, c, _)| [a % n, b % n, c % n]).collect();
            let mats: Vec<u16> = raw.iter().map(|r| r.3).collect();
            let s = soup(pts.clone(), tris.clone());
            let needs = [OPAQUE, WINDOW, MaterialNeeds { tangents: true, ..OPAQUE }];
            let settings = MeshSettings { cache: if fifo { CacheMode::Fifo } else { CacheMode::Full }, overdraw: true, ..Default::default() };
            let p = process(&s, &mats, &needs, &settings);
            let expected = tris.iter().filter(|t| {
                let [a, b, c] = t.map(|i| pts[i as usize]);
                t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && !is_degenerate(a, b, c)
            }).count();
            prop_assert_eq!(p.indices.len(), expected * 3);
            prop_assert!(p.indices.iter().all(|&i| (i as usize) < p.vertices.len()));
            let mut next = 0;
            let mut seen_window = false;
            for r in &p.ranges {
                prop_assert_eq!(r.first_index, next);
                next += r.index_count;
                let w = needs[r.material as usize].window;
                prop_assert!(!seen_window || w, "opaque range after a window range");
                seen_window |= w;
                for &i in &p.indices[r.first_index as usize..(r.first_index + r.index_count) as usize] {
                    prop_assert_eq!(p.vertices[i as usize].material[0], r.material);
                }
            }
            prop_assert_eq!(next as usize, p.indices.len());
            for t in p.indices.chunks_exact(3) {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| p.vertices[i as usize].position);
                prop_assert!(!is_degenerate(a, b, c));
            }
            for v in &p.vertices {
                prop_assert!(v.normal.iter().chain(&v.tangent).all(|c| c.is_finite()));
                let l = dot(v.normal, v.normal);
                prop_assert!((l - 1.0).abs() < 1e-3, "normal {:?}", v.normal);
            }
        }
    }
}
