//! Processing: degenerate triangles out, triangles grouped by material, normals generated
//! where missing, tangents where a normal map needs them, vertices deduplicated, then
//! meshopt's vertex cache, overdraw and fetch optimizations.

use std::time::{Duration, Instant};

use glam::Vec3;
use pack::StandardVertex;
use rayon::prelude::*;

use super::weld::{plus_zero, weld};
use super::{CacheMode, MaterialNeeds, MeshSettings, MeshStats, Processed, VertexArrays};
use crate::buckets::{Counts, Grouped};
use crate::import::{Imported, Indices, NONE};

/// `v` scaled to unit length, or zero when it has none. Divides by the length where glam's
/// `normalize_or_zero` multiplies by its reciprocal: that rounds differently, and the cooked
/// normals' bits are pinned by the golden packs.
fn unit(v: Vec3) -> Vec3 {
    let l = v.length();
    if l > 0.0 && l.is_finite() {
        v / l
    } else {
        Vec3::ZERO
    }
}

/// `acos(x)` for `x` in [-1, 1] (clamped), within 1e-6 rad: Abramowitz and Stegun 4.4.46,
/// `sqrt(1 - |x|)` times a degree-7 polynomial (error 2e-8 in exact arithmetic), reflected for
/// negative `x`. Angle weights only weight an average, and glibc's `acosf` was most of the
/// weights' time (3M corners of a 1M-triangle mesh: 47 ms).
fn fast_acos(x: f32) -> f32 {
    const A: [f32; 8] = [
        std::f32::consts::FRAC_PI_2,
        -0.214_598_8,
        0.088_978_99,
        -0.050_174_3,
        0.030_891_88,
        -0.017_088_126,
        0.006_670_09,
        -0.001_262_491_1,
    ];
    let x = x.clamp(-1.0, 1.0);
    let a = x.abs();
    let p = A.iter().rev().fold(0.0f32, |acc, &c| acc * a + c);
    let r = (1.0 - a).sqrt() * p;
    if x < 0.0 { std::f32::consts::PI - r } else { r }
}

/// [`unit`] of four vectors, lane by lane (the same bits) so that the square roots and
/// divisions vectorize.
fn units(v: [Vec3; 4]) -> [Vec3; 4] {
    let len = v.map(|v| v.length());
    std::array::from_fn(|i| {
        let l = len[i];
        if l > 0.0 && l.is_finite() {
            v[i] / l
        } else {
            Vec3::ZERO
        }
    })
}

/// True when the triangle has no area: repeated corners or collinear positions.
pub fn is_degenerate(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> bool {
    let [a, b, c] = [a, b, c].map(Vec3::from);
    let n = (b - a).cross(c - a);
    // Written so NaN counts as degenerate too.
    n.length_squared().partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater)
}

/// The triangles a cook keeps, in draw order. Most meshes drop none and are in material order
/// already (one material, or grouped by their source), and those are held as a count: the
/// 1M-triangle grid's list was 4 MB at its cook's peak of memory.
#[derive(Debug)]
enum Kept {
    /// Source triangles `0..n`, in order.
    All(usize),
    /// Source triangle indices.
    List(Vec<u32>),
}

impl Kept {
    /// Every non-degenerate triangle, grouped by material with windows last (stable, so
    /// source order is kept within a material).
    fn find(src: &Imported, tri_material: &[u16], needs: &[MaterialNeeds]) -> Self {
        // The list is made at the first triangle dropped, if one is.
        let mut list: Option<Vec<u32>> = None;
        for (ti, c) in src.corners.positions().chunks_exact(3).enumerate() {
            let [a, b, d] = [c[0], c[1], c[2]].map(|p| src.positions[p as usize]);
            let kept = c[0] != c[1] && c[1] != c[2] && c[0] != c[2] && !is_degenerate(a, b, d);
            match (&mut list, kept) {
                (Some(l), true) => l.push(ti as u32),
                (None, false) => {
                    let mut l = Vec::with_capacity(src.triangle_count());
                    l.extend(0..ti as u32);
                    list = Some(l);
                }
                _ => {}
            }
        }
        let key = |t: u32| {
            let m = tri_material[t as usize];
            (needs[m as usize].window, m)
        };
        match list {
            None if (0..src.triangle_count() as u32).is_sorted_by_key(key) => {
                Kept::All(src.triangle_count())
            }
            list => {
                let mut list = list.unwrap_or_else(|| (0..src.triangle_count() as u32).collect());
                list.sort_by_key(|&t| key(t));
                Kept::List(list)
            }
        }
    }

    fn len(&self) -> usize {
        match self {
            Kept::All(n) => *n,
            Kept::List(l) => l.len(),
        }
    }

    /// The `k`th kept triangle's source index.
    #[inline]
    fn get(&self, k: usize) -> u32 {
        match self {
            Kept::All(_) => k as u32,
            Kept::List(l) => l[k],
        }
    }

    /// The kept triangles' source indices, in order.
    fn iter(&self) -> impl Iterator<Item = u32> + '_ {
        (0..self.len()).map(|k| self.get(k))
    }

    /// Whether the kept triangles are in source order (none was moved by its material), so
    /// that the `k`th lies at or after source triangle `k`.
    fn in_source_order(&self) -> bool {
        match self {
            Kept::All(_) => true,
            Kept::List(l) => l.is_sorted(),
        }
    }
}

/// A source's normals and its corners' indices into them, taken out of it for the mesh stage
/// ([`deduplicate`]), which turns them into its vertices' normal table and each kept corner's
/// id into that table in place: beside copies, they were 4.9 and 9.8 MB of the 819k-triangle
/// grid's cook.
#[derive(Debug, Default)]
pub struct SourceNormals {
    pub values: Vec<[f32; 3]>,
    /// The corners' indices into them, held as [`crate::import::Corners`] held them.
    pub corners: Indices,
}

impl SourceNormals {
    /// Takes them out of `src` (which keeps neither).
    pub fn take(src: &mut Imported) -> Self {
        Self {
            values: std::mem::take(&mut src.normals),
            corners: src.corners.take_normal_indices(),
        }
    }

    /// Copies of them, `src` left whole.
    pub fn copy(src: &Imported) -> Self {
        Self {
            values: src.normals.clone(),
            corners: src.corners.normal_field().clone(),
        }
    }
}

#[derive(Debug)]
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

/// Each kept corner's source normal, welded by value: (per-corner ids into the table, with
/// [`NONE`] where the source has none or a zero one, or empty when no corner has one; the
/// table of unit normals; how many corners have none).
fn source_normals(
    src: &Imported,
    normals: SourceNormals,
    keep: &Kept,
) -> (Vec<u32>, Vec<[f32; 3]>, usize) {
    let SourceNormals {
        values: mut table,
        corners: corner_n,
    } = normals;
    // In place: the source's own array is unit-scaled and then welded down into the table (a
    // value's id is never above its index), since an array of unit normals and a table beside
    // it were 4.9 MB each of the 819k-triangle grid's cook.
    for n in table.iter_mut() {
        *n = unit(Vec3::from(*n)).to_array();
    }
    let (source_id, count) = weld(&table);
    for (i, &id) in source_id.iter().enumerate() {
        table[id as usize] = table[i].map(plus_zero);
    }
    table.truncate(count);
    table.shrink_to_fit();
    if corner_n == Indices::Absent {
        // Not an array of NONE: [`corner_normals`] writes the ids once the clustering's
        // per-triangle arrays are gone, so a bare mesh never holds both.
        return (Vec::new(), table, keep.len() * 3);
    }
    let mut missing = 0usize;
    let mut id_of = |n: u32| {
        let id = if n == NONE {
            NONE
        } else {
            source_id[n as usize]
        };
        if id == NONE || Vec3::from(table[id as usize]).length_squared() == 0.0 {
            missing += 1;
            NONE
        } else {
            id
        }
    };
    let ids = match corner_n {
        Indices::Own(mut ids) if keep.in_source_order() => {
            // Over the corners' own indices: kept corner 3k + j reads source corner 3t + j, at
            // or after it, before anything is written there.
            for (k, t) in keep.iter().enumerate() {
                for j in 0..3 {
                    ids[3 * k + j] = id_of(ids[3 * t as usize + j]);
                }
            }
            ids.truncate(3 * keep.len());
            ids
        }
        held => {
            let corner_n = held.slice(src.corners.positions());
            (keep.iter())
                .flat_map(|t| [0, 1, 2].map(|j| corner_n[3 * t as usize + j]))
                .map(&mut id_of)
                .collect()
        }
    };
    (ids, table, missing)
}

/// A normal for every corner (3 per kept triangle), as an index into a table of unit normals:
/// the [`source_normals`], and the missing ones generated.
///
/// Missing normals are generated, angle-weighted, around each position (welded by value, so
/// unwelded sources still smooth): the corners around a position fall into clusters, each
/// corner joining the first cluster whose first face lies within the crease angle of its own
/// face, so hard edges stay hard and a smooth surface gets one normal per position. Returns
/// (per-corner ids, table, corners generated). `keep_faces`: hold the face normals in an
/// array rather than find them again at each corner (the same bits either way).
fn corner_normals(
    src: &Imported,
    canon: &[u32],
    welded: usize,
    keep: &Kept,
    source: (Vec<u32>, Vec<[f32; 3]>, usize),
    crease_cos: f32,
    keep_faces: bool,
) -> (Vec<u32>, Vec<[f32; 3]>, usize) {
    let (ids, mut table, missing) = source;
    if missing == 0 {
        return (ids, table, 0);
    }
    // One pass over the triangles: their unit face normals and corner angles. Each chunk takes
    // its angles' cosines first and their arc cosines in a second loop: one triangle's three
    // polynomials are chains of dependent operations, and a loop over the chunk's cosines
    // vectorizes and overlaps them. A large mesh finds each corner's face normal again at the
    // corner instead of keeping them (the same bits): the 1M-triangle grid's 12 MB array was
    // its cook's peak of memory, while on the bunny it saved 1.2 ms of normals.
    const CHUNK: usize = 1024;
    let face_normal = |t: u32| {
        let p = src.corners.triangle_positions(t as usize);
        let [a, b, d] = p.map(|i| Vec3::from(src.positions[i as usize]));
        unit((b - a).cross(d - a))
    };
    let mut face_normals = vec![Vec3::ZERO; if keep_faces { keep.len() } else { 0 }];
    let mut weights = vec![0.0f32; keep.len() * 3];
    // Empty chunks where the face normals are not kept.
    let mut face_chunks: Vec<&mut [Vec3]> = face_normals.chunks_mut(CHUNK).collect();
    face_chunks.resize_with(keep.len().div_ceil(CHUNK), Default::default);
    weights
        .par_chunks_mut(3 * CHUNK)
        .zip(face_chunks)
        .enumerate()
        .for_each(|(chunk, (w, faces))| {
            for k in 0..w.len() / 3 {
                let t = keep.get(chunk * CHUNK + k);
                let p = src.corners.triangle_positions(t as usize);
                let [a, b, d] = p.map(|i| Vec3::from(src.positions[i as usize]));
                // The face normal and each edge normalized once, lane by lane so that the
                // square roots and divisions vectorize; negating a unit vector is exact, so
                // these are the same angles as normalizing both edges at every corner.
                let [n, ab, bd, da] = units([(b - a).cross(d - a), b - a, d - b, a - d]);
                if let Some(f) = faces.get_mut(k) {
                    *f = n;
                }
                w[3 * k..3 * k + 3].copy_from_slice(&[-ab.dot(da), -bd.dot(ab), -da.dot(bd)]);
            }
            for w in w.iter_mut() {
                *w = fast_acos(*w);
            }
        });
    // Corners needing a normal, grouped by welded position (counting sort keeps corner order).
    // Each pass looks the welded positions up again rather than keeping them: an array of
    // them beside `adj` was another id per corner at the stage's peak. `ids` is empty when
    // every corner needs one.
    // A generic fn rather than a closure taking `dyn FnMut`: the call per corner inlines.
    fn each_corner(src: &Imported, keep: &Kept, canon: &[u32], mut f: impl FnMut(usize, usize)) {
        for (ti, t) in keep.iter().enumerate() {
            let at = src.corners.triangle_positions(t as usize);
            for (j, &p) in at.iter().enumerate() {
                f(3 * ti + j, canon[p as usize] as usize);
            }
        }
    }
    let wants = |ids: &[u32], k: usize| ids.get(k).is_none_or(|&id| id == NONE);
    let mut counts = Counts::new(welded);
    each_corner(src, keep, canon, |k, c| {
        if wants(&ids, k) {
            counts.add(c);
        }
    });
    let mut placing = counts.placing(0u32);
    each_corner(src, keep, canon, |k, c| {
        if wants(&ids, k) {
            placing.put(c, k as u32);
        }
    });
    let Grouped {
        start,
        items: mut adj,
    } = placing.finish();
    debug_assert_eq!(adj.len(), missing);
    // Per position: cluster its corners, sum each cluster. Positions are independent, so runs
    // of them are clustered in parallel, each into its own table, and each corner's slot in
    // its run's table overwrites the corner's own entry in `adj` (a run owns its positions'
    // stretch of it). The tables are then appended in position order: the normals of one
    // pass in position order whatever the thread count. The slots go to the corners only
    // after the face normals and weights are let go, so that a bare mesh's per-corner ids are
    // not held beside them (12 MB of a 1M-triangle mesh's peak).
    const RUN: usize = 4096;
    let mut stretches: Vec<&mut [u32]> = Vec::with_capacity(welded.div_ceil(RUN));
    let mut rest = adj.as_mut_slice();
    for r in 0..welded.div_ceil(RUN) {
        let (first, last) = (r * RUN, ((r + 1) * RUN).min(welded));
        let (head, tail) = rest.split_at_mut((start[last] - start[first]) as usize);
        stretches.push(head);
        rest = tail;
    }
    let runs: Vec<Vec<[f32; 3]>> = stretches
        .into_par_iter()
        .enumerate()
        .map(|(r, stretch)| {
            let (first, last) = (r * RUN, ((r + 1) * RUN).min(welded));
            let offset = start[first] as usize;
            // About one cluster per position.
            let mut local: Vec<[f32; 3]> = Vec::with_capacity(last - first);
            let mut reps: Vec<Vec3> = Vec::new();
            let mut sums: Vec<Vec3> = Vec::new();
            for c in first..last {
                let corners =
                    &mut stretch[start[c] as usize - offset..start[c + 1] as usize - offset];
                if corners.is_empty() {
                    continue;
                }
                reps.clear();
                sums.clear();
                let base = local.len() as u32;
                for entry in corners {
                    let k = *entry as usize;
                    let f = match face_normals.get(k / 3) {
                        Some(&f) => f,
                        None => face_normal(keep.get(k / 3)),
                    };
                    let slot = match reps.iter().position(|r| r.dot(f) >= crease_cos) {
                        Some(s) => s,
                        None => {
                            reps.push(f);
                            sums.push(Vec3::ZERO);
                            reps.len() - 1
                        }
                    };
                    sums[slot] += f * weights[k];
                    *entry = base + slot as u32;
                }
                for (s, r) in sums.iter().zip(&reps) {
                    let n = unit(*s);
                    local.push(if n.length_squared() > 0.0 {
                        n.to_array().map(plus_zero)
                    } else {
                        r.to_array()
                    });
                }
            }
            local
        })
        .collect();
    drop(face_normals);
    // Every corner needs one: the weights' block, spent, takes the ids. A new block of that
    // size landed above the heap in some runs of the 1M-triangle grid (its peak RSS 75 or 86
    // MB, as the threads' smaller blocks happened to fall).
    let every = ids.is_empty();
    let mut ids: Vec<u32> = if every {
        bytemuck::allocation::cast_vec(weights)
    } else {
        drop(weights);
        ids
    };
    // Each run's first slot in the whole table.
    let mut bases = Vec::with_capacity(runs.len());
    let mut slots = table.len() as u32;
    for local in &runs {
        bases.push(slots);
        slots += local.len() as u32;
    }
    // The corners in the order that filled `adj`, so each finds its entry again.
    let mut fill = start;
    let mut id_of = |c: usize| {
        let id = adj[fill[c] as usize] + bases[c / RUN];
        fill[c] += 1;
        id
    };
    // The weights' bits are no ids: with `every`, each entry is written, none read.
    each_corner(src, keep, canon, |k, c| {
        if every || ids[k] == NONE {
            ids[k] = id_of(c);
        }
    });
    // The runs' tables are joined only once `adj` is gone, whose block the whole table can
    // take: the 1M-triangle grid's were 12 MB beside it.
    drop((adj, fill));
    table.reserve_exact(slots as usize - table.len());
    for local in runs {
        table.extend_from_slice(&local);
    }
    (ids, table, missing)
}

/// Generated normals keep an array of face normals for meshes of fewer triangles than this
/// (3 MB), and find them again at each corner for larger ones.
const KEPT_FACE_NORMALS: usize = 256 * 1024;

/// A deduplicated vertex before its values are gathered: its first corner's source position
/// and texture coordinate ([`NONE`] where its material samples no texture), its normal's id
/// in the normal table ([`NONE`] where its material is unshaded) and its material. 16 bytes
/// where a [`StandardVertex`] is 52: the vertices of a large mesh are held through its
/// deduplication and orderings this way and gathered once, in fetch order.
#[derive(Clone, Copy, Debug)]
struct VertexRef {
    p: u32,
    t: u32,
    n: u32,
    m: u16,
}

impl VertexRef {
    /// The whole vertex but its colour: -0.0 made +0.0 (as welding compares them), a [`NONE`]
    /// attribute zero.
    fn gather(self, src: &Imported, normals: &[[f32; 3]]) -> Corner {
        Corner {
            position: self.position(src),
            normal: self.normal(normals),
            uv: self.uv(src),
            tangent: [0.0; 4],
            material: [self.m, 0],
        }
    }

    fn position(self, src: &Imported) -> [f32; 3] {
        src.positions[self.p as usize].map(plus_zero)
    }

    fn normal(self, normals: &[[f32; 3]]) -> [f32; 3] {
        if self.n == NONE {
            [0.0; 3]
        } else {
            normals[self.n as usize]
        }
    }

    fn uv(self, src: &Imported) -> [f32; 2] {
        if self.t == NONE {
            [0.0; 2]
        } else {
            src.uvs[self.t as usize].map(plus_zero)
        }
    }
}

/// A source's deduplicated vertices, between [`deduplicate`] and [`optimize`].
#[derive(Debug)]
enum Vertices {
    /// Whole vertices: the tangent path builds one per corner before deduplicating.
    Values(Vec<StandardVertex>),
    /// References into the source's positions and texture coordinates and into `normals`,
    /// with each one's colour where the source has vertex colours (else empty).
    Refs {
        refs: Vec<VertexRef>,
        normals: Vec<[f32; 3]>,
        colours: Vec<[u8; 4]>,
    },
    /// Gathered, attribute by attribute ([`Deduplicated::gather`]): the source's attributes
    /// may be gone.
    Arrays(VertexArrays),
}

impl Vertices {
    /// The vertices in their order, attribute by attribute: an attribute no reference has is
    /// left out. Gathered already, they are as they were.
    fn into_arrays(self, src: &Imported) -> VertexArrays {
        match self {
            Vertices::Values(v) => v.into_iter().collect(),
            Vertices::Arrays(a) => a,
            Vertices::Refs {
                refs,
                normals,
                colours,
            } => {
                let any = |f: fn(&VertexRef) -> u32| refs.iter().any(|r| f(r) != NONE);
                let colours = if colours.iter().any(|&c| c != pack::vertex::WHITE) {
                    colours
                } else {
                    Vec::new()
                };
                VertexArrays {
                    positions: refs.par_iter().map(|r| r.position(src)).collect(),
                    normals: if any(|r| r.n) {
                        refs.par_iter().map(|r| r.normal(&normals)).collect()
                    } else {
                        Vec::new()
                    },
                    uvs: if any(|r| r.t) {
                        refs.par_iter().map(|r| r.uv(src)).collect()
                    } else {
                        Vec::new()
                    },
                    tangents: Vec::new(),
                    materials: refs.par_iter().map(|r| r.m).collect(),
                    colours,
                }
            }
        }
    }
}

/// Deduplicates corners by their welded attribute ids (position, texture coordinate,
/// normal, material), without materializing a vertex per corner: the same result as
/// comparing whole vertices, since every attribute is welded by value. Each corner's vertex
/// id overwrites its normal id in `corner_normal`, which becomes the index buffer.
#[allow(clippy::too_many_arguments)]
fn dedupe_by_key(
    src: &Imported,
    canon: &[u32],
    welded: usize,
    uv: Option<&[u32]>,
    keep: &Kept,
    tri_material: &[u16],
    needs: &[MaterialNeeds],
    corner_normal: Vec<u32>,
    colours: &SourceColours,
) -> (Vec<VertexRef>, Vec<[u8; 4]>, Vec<u32>) {
    const END: u32 = u32::MAX;
    // Every key starts with its welded position, and a position has only a handful of
    // distinct vertices (one per normal, UV seam or material), so a chain per position found
    // through a flat array replaces a hash map: no hashing, and the probe is one cache line.
    // It measured more than twice as fast as an FxHash map on the bunny.
    let mut head = vec![END; welded];
    // Every used position has at least one vertex, and in a smooth mesh few have more: sized
    // so, these do not reallocate there (each doubling touched fresh pages, which the kernel
    // zeroes). Flat-shaded boxes (three vertices a position) double twice, a cost taken on
    // purpose: sized for one vertex per corner, the 1M-triangle grid's peak rose from 64 to
    // 82 MB, the untouched capacity a hole in the heap that later blocks fill with fresh pages.
    let expected = welded + welded / 16;
    let mut next: Vec<u32> = Vec::with_capacity(expected);
    let mut refs: Vec<VertexRef> = Vec::with_capacity(expected);
    // Parallel to `refs` where the source has colours: two corners at one welded position
    // with colours of their own (a seam between faces painted apart) are two vertices.
    let mut ref_colours: Vec<[u8; 4]> = Vec::new();
    let coloured = colours.any();
    let mut indices = corner_normal;
    // Field by field: a bare mesh's corners have no texture-coordinate indices to read, and
    // without welded ones (no material samples a texture) none is read.
    let corner_p = src.corners.positions();
    let corner_t = if uv.is_some() {
        src.corners.uv_indices()
    } else {
        &[]
    };
    let uv_id = |t: u32| match uv {
        Some(uv) if t != NONE => uv[t as usize],
        _ => NONE,
    };
    for (t, ids) in keep.iter().zip(indices.chunks_exact_mut(3)) {
        let m = tri_material[t as usize];
        let need = needs[m as usize];
        let base = t as usize * 3;
        for (k, slot) in ids.iter_mut().enumerate() {
            let cp = corner_p[base + k];
            let ct = match corner_t.get(base + k) {
                Some(&ct) if need.uvs => ct,
                _ => NONE,
            };
            let p = canon[cp as usize] as usize;
            let uv_key = uv_id(ct);
            let normal_id = if need.normals { *slot } else { NONE };
            let colour = colours.of(cp, need);
            let mut id = head[p];
            while id != END && {
                let r = &refs[id as usize];
                r.n != normal_id
                    || r.m != m
                    || uv_id(r.t) != uv_key
                    || (coloured && ref_colours[id as usize] != colour)
            } {
                id = next[id as usize];
            }
            if id == END {
                id = refs.len() as u32;
                refs.push(VertexRef {
                    p: cp,
                    // The first corner's own coordinate is gathered; its welded id keys it.
                    t: if uv_key == NONE { NONE } else { ct },
                    n: normal_id,
                    m,
                });
                if coloured {
                    ref_colours.push(colour);
                }
                next.push(head[p]);
                head[p] = id;
            }
            *slot = id;
        }
    }
    (refs, ref_colours, indices)
}

/// A source's vertex colours as the pack stores them (8-bit sRGB, one per position), for the
/// materials that show them: windows do not (their designs hold the colours of the panes).
struct SourceColours {
    srgb: Vec<[u8; 4]>,
}

impl SourceColours {
    fn new(src: &Imported, needs: &[MaterialNeeds]) -> Self {
        let encode = texture::srgb::encode8;
        let srgb = if needs.iter().any(|n| n.colours) {
            src.colours
                .par_iter()
                .map(|c| [encode(c[0]), encode(c[1]), encode(c[2]), 0])
                .collect()
        } else {
            Vec::new()
        };
        Self { srgb }
    }

    /// Whether any position has a colour other than white.
    fn any(&self) -> bool {
        self.srgb.iter().any(|&c| c != pack::vertex::WHITE)
    }

    /// The colour of position `p` in a material that needs what `need` says.
    fn of(&self, p: u32, need: MaterialNeeds) -> [u8; 4] {
        match self.srgb.get(p as usize) {
            Some(&c) if need.colours => c,
            _ => pack::vertex::WHITE,
        }
    }
}

/// A vertex of the tangent path before its colour: a [`StandardVertex`] but for the colour,
/// which is its own stream (4 bytes a corner, and none at all for a model without colours).
/// The path holds one of these per corner, the cook's largest array on a large mesh with a
/// normal map: 52 bytes where a whole vertex is 56 (the 720k-triangle grid's 2.16M corners
/// held 8.6 MB more with the colour inside).
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct Corner {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    tangent: [f32; 4],
    material: [u16; 2],
}

/// The general path when some material has a normal map: one vertex per corner, MikkTSpace
/// tangents on the triangles that need them, then deduplication of whole vertices (the
/// colour stream, where there is one, compared with the rest).
fn dedupe_with_tangents(
    src: &Imported,
    keep: &Kept,
    tri_material: &[u16],
    needs: &[MaterialNeeds],
    corner_normal: &[u32],
    normal_table: &[[f32; 3]],
    colours: &SourceColours,
) -> (Vec<StandardVertex>, Vec<u32>, usize) {
    let mut corners: Vec<Corner> = Vec::with_capacity(keep.len() * 3);
    let mut corner_colours: Vec<[u8; 4]> = Vec::new();
    if !colours.srgb.is_empty() {
        corner_colours.reserve_exact(keep.len() * 3);
    }
    for (k, t) in keep.iter().enumerate() {
        let m = tri_material[t as usize];
        let need = needs[m as usize];
        for j in 0..3 {
            let c = src.corners.get(t as usize * 3 + j);
            let r = VertexRef {
                p: c.p,
                t: if need.uvs { c.t } else { NONE },
                n: if need.normals {
                    corner_normal[k * 3 + j]
                } else {
                    NONE
                },
                m,
            };
            corners.push(r.gather(src, normal_table));
            if !colours.srgb.is_empty() {
                corner_colours.push(colours.of(c.p, need));
            }
        }
    }
    let tangent_faces: Vec<u32> = keep
        .iter()
        .enumerate()
        .filter(|&(_, t)| needs[tri_material[t as usize] as usize].tangents)
        .map(|(k, _)| k as u32)
        .collect();
    if !tangent_faces.is_empty() {
        let view = TangentCorners {
            verts: &corners,
            faces: &tangent_faces,
        };
        let tangents = super::tangents::generate(&view);
        for (c, t) in tangents.into_iter().enumerate() {
            let v = &mut corners[tangent_faces[c / 3] as usize * 3 + c % 3];
            // The pack's v runs down the image (row 0 at v = 0), a baker's and MikkTSpace's
            // up (OpenGL): the bitangent a normal map's +y (green, up the image) follows is
            // the reference's for (u, -v), whose tangent has the same bits and the opposite
            // sign. Unflipped, every normal map's y (the default scene's derived ones
            // included) tilted the glass the wrong way up.
            v.tangent = if t.iter().all(|x| x.is_finite()) {
                [t[0], t[1], t[2], -t[3]].map(plus_zero)
            } else {
                [1.0, 0.0, 0.0, 1.0]
            };
        }
    }
    // Ids in order of first use either way, so a model without colours gets the ids (and
    // the pack) that one stream of whole vertices gave.
    let (unique, remap) = if corner_colours.is_empty() {
        meshopt::generate_vertex_remap(&corners, None)
    } else {
        let streams = [
            meshopt::VertexStream::new(corners.as_ptr()),
            meshopt::VertexStream::new(corner_colours.as_ptr()),
        ];
        meshopt::generate_vertex_remap_multi(corners.len(), &streams, None)
    };
    let indices = meshopt::remap_index_buffer(None, corners.len(), &remap);
    let mut vertices = vec![StandardVertex::default(); unique];
    for (i, (&id, c)) in remap.iter().zip(&corners).enumerate() {
        vertices[id as usize] = StandardVertex {
            position: c.position,
            normal: c.normal,
            uv: c.uv,
            tangent: c.tangent,
            material: c.material,
            colour: corner_colours
                .get(i)
                .copied()
                .unwrap_or(pack::vertex::WHITE),
        };
    }
    (vertices, indices, tangent_faces.len())
}

/// The corners of the triangles that need tangents.
struct TangentCorners<'a> {
    verts: &'a [Corner],
    /// Triangles (corner offsets / 3) that need tangents.
    faces: &'a [u32],
}

impl TangentCorners<'_> {
    fn vertex(&self, c: usize) -> &Corner {
        &self.verts[self.faces[c / 3] as usize * 3 + c % 3]
    }
}

impl super::tangents::Corners for TangentCorners<'_> {
    fn corner_count(&self) -> usize {
        self.faces.len() * 3
    }
    fn position(&self, c: usize) -> [f32; 3] {
        self.vertex(c).position
    }
    fn normal(&self, c: usize) -> [f32; 3] {
        self.vertex(c).normal
    }
    fn uv(&self, c: usize) -> [f32; 2] {
        self.vertex(c).uv
    }
}

/// Draw ranges of at least this many triangles are cut in two for the vertex cache optimizer.
///
/// The optimizer is one serial pass over a range and the largest single step of a cook (13-17
/// of the bunny's 40 ms), so a large range is cut by a plane into two halves that are ordered
/// in parallel. The cut depends on the geometry alone, never on the thread count, so packs stay
/// byte-identical. Its cost is the vertices on the cut, loaded by both halves: one row of a
/// grid, a fraction of a percent of a large mesh's (ACMR 0.625 against 0.625 on the 819k grid).
/// Two halves fill this machine's two cores, and each further cut adds its own row of
/// reloaded vertices, so a range is cut into more pieces only where they grow past
/// [`CACHE_PIECE_TRIANGLES`].
const CACHE_SPLIT_TRIANGLES: usize = 48 * 1024;

/// The most triangles a piece of a cut range holds, unless it is cut in two only. meshopt's
/// optimizer allocates about 35 bytes a triangle of the piece it orders, and two pieces are
/// ordered at once: the 819k-triangle grid's halves took 29 MB of scratch together, the
/// cook's peak of memory. Where the cuts fall moves the ACMR of a grid by about a percent
/// either way (measured at pieces of 100k to 600k triangles: 0.624–0.646); at 200k the 819k
/// grid keeps its 0.625 and the 1M grid goes from 0.636 to 0.630, while the 1M grid's peak
/// resident memory fell from 76 to 64 MB.
const CACHE_PIECE_TRIANGLES: usize = 200_000;

/// The most triangles one vertex is seen to share when meshopt's optimizer orders a piece.
///
/// The optimizer rescores every live triangle of each vertex in its cache after each triangle
/// it emits, so a vertex shared by `n` triangles costs `n²/2` steps: a 50,000-triangle fan
/// (a disc, or an n-gon exported as a fan) took 0.48 s to order and a 200,000-triangle one
/// 7.4 s (native gltfpack: 1.9 and 28 s). Past this many, the vertex is ordered as copies of
/// this many consecutive triangles each ([`order_for_cache`]); its score saturates at eight
/// live triangles, so the copies change little, and each is still one vertex once ordered.
const CACHE_MAX_VALENCE: u32 = 256;

/// Orders a piece's triangles for the vertex cache with meshopt's optimizer, as it orders
/// them, unless some vertex is shared by more than [`CACHE_MAX_VALENCE`] triangles: then
/// such a vertex's uses, in the piece's order, are split into runs of that many, each run
/// ordered as a vertex of its own, and the ordered triangles get their vertices back. Returns
/// how many copies that made.
fn order_for_cache(span: &mut [u32], vertex_count: usize, max_valence: u32) -> usize {
    let mut valence = vec![0u32; vertex_count];
    for &i in span.iter() {
        valence[i as usize] += 1;
    }
    if valence.iter().all(|&v| v <= max_valence) {
        meshopt::optimize_vertex_cache_in_place(span, vertex_count);
        return 0;
    }
    // `valence` now counts each vertex's uses so far; `copy` is its current run's id.
    let mut original: Vec<u32> = (0..vertex_count as u32).collect();
    let mut copy: Vec<u32> = original.clone();
    let heavy: Vec<bool> = valence.iter().map(|&v| v > max_valence).collect();
    valence.fill(0);
    let mut split: Vec<u32> = span
        .iter()
        .map(|&i| {
            let v = i as usize;
            if heavy[v] {
                if valence[v] > 0 && valence[v].is_multiple_of(max_valence) {
                    copy[v] = original.len() as u32;
                    original.push(i);
                }
                valence[v] += 1;
            }
            copy[v]
        })
        .collect();
    meshopt::optimize_vertex_cache_in_place(&mut split, original.len());
    for (out, s) in span.iter_mut().zip(&split) {
        *out = original[*s as usize];
    }
    original.len() - vertex_count
}

/// `f`'s bits, mapped so that unsigned order is float order (negative values below positive).
fn ordered_bits(f: f32) -> u32 {
    let b = f.to_bits();
    if b >> 31 == 1 { !b } else { b | 1 << 31 }
}

/// Every draw range's indices, as the pieces the vertex cache optimizer orders one by one: a
/// range of [`CACHE_SPLIT_TRIANGLES`] or more is reordered into two halves (or more, of at
/// most [`CACHE_PIECE_TRIANGLES`]) by the quantiles of its triangles' centroids along one axis,
/// `along` giving a vertex's coordinate (the caller takes the mesh's longest: a cut across it
/// is the shortest for most shapes), source order kept within each piece, so neighbouring
/// pieces touch along one plane only.
///
/// Each piece's vertices are renumbered `0..` in the order the piece first uses them, and
/// each piece comes with its table from those ids back to the vertices' own. meshopt's
/// optimizer allocates, clears and scores arrays over every id below the vertex count it is
/// given, whatever a piece uses: each half of the 1M-triangle grid held 6 MB for the other
/// half's vertices at the cook's peak of memory, and a mesh of many materials paid a pass
/// over all its vertices for every draw range. Its result does not depend on the vertices'
/// numbering (a property test checks it), so packs are unchanged; the FIFO optimizer's does
/// (after a dead end it takes the lowest-numbered vertex left), and numbered in order of
/// first use, a piece's vertices lead it back to where the piece's triangles begin.
fn cache_pieces<'a>(
    indices: &'a mut [u32],
    ranges: &[pack::DrawRange],
    vertex_count: usize,
    along: impl Fn(u32) -> f32 + Sync,
    piece_triangles: usize,
) -> Vec<(&'a mut [u32], Vec<u32>)> {
    // Each vertex's id in the lower and the upper piece of its range (a vertex on a cut is
    // in both); one table a side for every range, each range's entries reset after it. The
    // upper side's only where some range is cut.
    let cut = |r: &pack::DrawRange| r.index_count as usize / 3 >= CACHE_SPLIT_TRIANGLES;
    let upper_table = if ranges.iter().any(cut) {
        vertex_count
    } else {
        0
    };
    let mut local = [vec![u32::MAX; vertex_count], vec![u32::MAX; upper_table]];
    fn renumber(local: &mut [u32], i: u32, global: &mut Vec<u32>) -> u32 {
        let l = &mut local[i as usize];
        if *l == u32::MAX {
            *l = global.len() as u32;
            global.push(i);
        }
        *l
    }
    let mut pieces = Vec::new();
    let mut rest = indices;
    for r in ranges {
        let (range, tail) = rest.split_at_mut(r.index_count as usize);
        rest = tail;
        let triangles = range.len() / 3;
        if !cut(r) {
            let mut global = Vec::new();
            for i in range.iter_mut() {
                *i = renumber(&mut local[0], *i, &mut global);
            }
            for &g in &global {
                local[0][g as usize] = u32::MAX;
            }
            pieces.push((range, global));
            continue;
        }
        // Triangles keyed by the sum of their corners' coordinates along the axis, ties by
        // source position, packed into one integer so the median is cheap.
        let key = |t: usize, c: &[u32]| {
            let sum: f32 = c.iter().map(|&i| along(i)).sum();
            (u64::from(ordered_bits(sum)) << 32) | t as u64
        };
        let mut keys: Vec<u64> = range
            .par_chunks_exact(3)
            .enumerate()
            .map(|(t, c)| key(t, c))
            .collect();
        // Keys are distinct, so exactly `ends[j]` of them lie below `pivots[j]`. The selection
        // reorders the keys, so each triangle's key is found again below: a copy of the keys
        // in their order, and of the whole range to partition from, were 20 MB of the
        // 1M-triangle grid's peak.
        // Pieces are numbered in a byte; a range of over 51M triangles has larger ones.
        let count = triangles
            .div_ceil(piece_triangles)
            .clamp(2, u8::MAX as usize);
        let ends: Vec<usize> = (1..=count).map(|j| triangles * j / count).collect();
        let mut pivots = Vec::with_capacity(count - 1);
        let mut from = 0;
        for &end in &ends[..count - 1] {
            // Each selection leaves the keys above its pivot after it, for the next.
            pivots.push(*keys[from..].select_nth_unstable(end - from).1);
            from = end;
        }
        drop(keys);
        // Stable partition, the pieces gathered and renumbered two at a time, one a core.
        let piece: Vec<u8> = range
            .par_chunks_exact(3)
            .enumerate()
            .map(|(t, c)| {
                let k = key(t, c);
                pivots.partition_point(|&p| p <= k) as u8
            })
            .collect();
        let side = |which: usize, local: &mut [u32]| {
            let start = if which == 0 { 0 } else { ends[which - 1] };
            let mut out: Vec<u32> = Vec::with_capacity(3 * (ends[which] - start));
            let mut global = Vec::new();
            for (c, &p) in range.chunks_exact(3).zip(&piece) {
                if usize::from(p) == which {
                    out.extend(c.iter().map(|&i| renumber(local, i, &mut global)));
                }
            }
            for &g in &global {
                local[g as usize] = u32::MAX;
            }
            (out, global)
        };
        let mut sides = Vec::with_capacity(count);
        for pair in (0..count).step_by(2) {
            let [l0, l1] = &mut local;
            let (a, b) = rayon::join(
                || side(pair, l0),
                || (pair + 1 < count).then(|| side(pair + 1, l1)),
            );
            sides.push(a);
            sides.extend(b);
        }
        drop(piece);
        let mut rest = range;
        for (out, global) in sides {
            debug_assert_eq!(out.len() % 3, 0);
            let (a, b) = rest.split_at_mut(out.len());
            a.copy_from_slice(&out);
            rest = b;
            pieces.push((a, global));
        }
    }
    pieces
}

/// Processes one imported source whose triangles carry pack material IDs (`tri_material`,
/// parallel to `src.tri_part`): [`deduplicate`], then [`optimize`].
pub fn process(
    src: &Imported,
    tri_material: &[u16],
    needs: &[MaterialNeeds],
    settings: &MeshSettings,
) -> Processed {
    optimize(
        deduplicate(src, SourceNormals::copy(src), tri_material, needs, settings),
        src,
        needs,
        settings,
    )
}

/// A source's indexed vertices, grouped into draw ranges, before the orderings: the last
/// step that reads the imported triangles. A caller that holds them for nothing else drops
/// them before [`optimize`] (which reads the source's positions and texture coordinates
/// still), whose vertex cache step allocates as much again.
#[derive(Debug)]
pub struct Deduplicated {
    vertices: Vertices,
    indices: Vec<u32>,
    ranges: Vec<pack::DrawRange>,
    stats: MeshStats,
    timer: Timer,
}

impl Deduplicated {
    /// The vertices' values, read from `src` now (attribute by attribute, an attribute no
    /// vertex has left out), so that the source's positions and texture coordinates can go
    /// before [`optimize`]: the 1M-triangle grid's references, normal table and positions were
    /// 20 MB beside the vertex cache step's tables, where its gathered vertices are 13 MB.
    /// Gathered already, they are as they were.
    pub fn gather(self, src: &Imported) -> Self {
        Self {
            vertices: Vertices::Arrays(self.vertices.into_arrays(src)),
            ..self
        }
    }
}

/// Drops degenerate triangles, groups the rest by material, finds each corner's normal and
/// deduplicates the corners into vertices. `normals`: the source's, taken out of it or
/// copied.
pub fn deduplicate(
    src: &Imported,
    normals: SourceNormals,
    tri_material: &[u16],
    needs: &[MaterialNeeds],
    settings: &MeshSettings,
) -> Deduplicated {
    let mut timer = Timer::new();
    let mut stats = MeshStats {
        triangles_in: src.triangle_count(),
        ..Default::default()
    };

    // Degenerate triangles go before anything divides by their area.
    let keep = Kept::find(src, tri_material, needs);
    stats.degenerate_dropped = src.triangle_count() - keep.len();
    timer.lap("filter+group");

    let crease = settings.crease_angle_deg.to_radians().cos();
    let any_tangents = needs.iter().any(|n| n.tangents);
    // Texture coordinates are welded only for the path that keys vertices by them, and only
    // when some material samples a texture (else they are zeroed before deduplication).
    let weld_uvs = !any_tangents && needs.iter().any(|n| n.uvs);
    // The three welds are independent serial passes over hash tables.
    let ((canon, welded), (source, uv_ids)) = rayon::join(
        || weld(&src.positions),
        || {
            rayon::join(
                || source_normals(src, normals, &keep),
                || weld_uvs.then(|| weld(&src.uvs).0),
            )
        },
    );
    let (corner_normal, normal_table, generated) = corner_normals(
        src,
        &canon,
        welded,
        &keep,
        source,
        crease,
        keep.len() < KEPT_FACE_NORMALS,
    );
    stats.normals_generated = generated;
    stats.corners = keep.len() * 3;
    timer.lap("normals");

    let colours = SourceColours::new(src, needs);
    let (vertices, indices) = if any_tangents {
        let (v, i, tangent_triangles) = dedupe_with_tangents(
            src,
            &keep,
            tri_material,
            needs,
            &corner_normal,
            &normal_table,
            &colours,
        );
        stats.tangent_triangles = tangent_triangles;
        timer.lap("tangents+dedupe");
        (Vertices::Values(v), i)
    } else {
        let (refs, colours, i) = dedupe_by_key(
            src,
            &canon,
            welded,
            uv_ids.as_deref(),
            &keep,
            tri_material,
            needs,
            corner_normal,
            &colours,
        );
        timer.lap("dedupe");
        (
            Vertices::Refs {
                refs,
                normals: normal_table,
                colours,
            },
            i,
        )
    };
    // Dropped as soon as they are spent: the vertex cache and fetch steps that follow are the
    // peak of a large mesh's cook.
    drop((canon, uv_ids));
    let mut ranges: Vec<pack::DrawRange> = Vec::new();
    for (k, t) in keep.iter().enumerate() {
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
    Deduplicated {
        vertices,
        indices,
        ranges,
        stats,
        timer,
    }
}

/// Orders the triangles for the vertex cache (and overdraw, when asked) and the vertices for
/// fetch, dropping unreferenced ones. `src` is the source [`deduplicate`] read, whose
/// attributes are read here unless the caller has gathered them ([`Deduplicated::gather`]).
pub fn optimize(
    d: Deduplicated,
    src: &Imported,
    needs: &[MaterialNeeds],
    settings: &MeshSettings,
) -> Processed {
    let Deduplicated {
        vertices,
        mut indices,
        ranges,
        mut stats,
        mut timer,
    } = d;
    let vertices = vertices.into_arrays(src);
    // The stages here are timed from now: the caller may have waited between the two halves.
    timer.last = Instant::now();
    stats.acmr_in = if indices.is_empty() || !settings.analyze {
        0.0
    } else {
        meshopt::analyze_vertex_cache(&indices, vertices.len(), 16, 0, 0).acmr
    };
    // Every deduplicated vertex is referenced, so these are the bounds of what vertex fetch
    // keeps; the vertex cache's cut needs them first.
    // In parallel: min and max are exact and ignore NaN either way round, so the split
    // cannot change the result.
    let empty = || ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    let (mut bounds_min, mut bounds_max) = (0..vertices.len())
        .into_par_iter()
        .fold(empty, |(mut lo, mut hi), i| {
            let p = vertices.positions[i];
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
            (lo, hi)
        })
        .reduce(empty, |(a_lo, a_hi), (b_lo, b_hi)| {
            (
                std::array::from_fn(|k| a_lo[k].min(b_lo[k])),
                std::array::from_fn(|k| a_hi[k].max(b_hi[k])),
            )
        });
    if vertices.is_empty() {
        bounds_min = [0.0; 3];
        bounds_max = [0.0; 3];
    }
    let extent = Vec3::from(bounds_max) - Vec3::from(bounds_min);
    let longest_axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let along = |i: u32| vertices.positions[i as usize][longest_axis];
    cache_pieces(
        &mut indices,
        &ranges,
        vertices.len(),
        along,
        CACHE_PIECE_TRIANGLES,
    )
    .into_par_iter()
    .for_each(|(span, global)| {
        match settings.cache {
            CacheMode::Full => {
                order_for_cache(span, global.len(), CACHE_MAX_VALENCE);
            }
            CacheMode::Fifo => meshopt::optimize_vertex_cache_fifo_in_place(span, global.len(), 16),
        }
        for i in span.iter_mut() {
            *i = global[*i as usize];
        }
    });
    timer.lap("vertex cache");
    if settings.overdraw {
        let bytes: &[u8] = bytemuck::cast_slice(&vertices.positions);
        if let Ok(adapter) = meshopt::VertexDataAdapter::new(bytes, 12, 0) {
            for r in ranges.iter().filter(|r| !needs[r.material as usize].window) {
                let span =
                    &mut indices[r.first_index as usize..(r.first_index + r.index_count) as usize];
                meshopt::optimize_overdraw_in_place(span, &adapter, 1.05);
            }
        }
        timer.lap("overdraw");
    }
    // Vertices in the order the indices first reference them (meshopt's vertex fetch order),
    // unreferenced ones dropped; gathered only now, so a mesh without tangents holds its
    // 52-byte vertices once, exactly as many as it keeps.
    let mut remap = vec![u32::MAX; vertices.len()];
    let mut order: Vec<u32> = Vec::with_capacity(vertices.len());
    for i in indices.iter_mut() {
        let r = &mut remap[*i as usize];
        if *r == u32::MAX {
            *r = order.len() as u32;
            order.push(*i);
        }
        *i = *r;
    }
    drop(remap);
    let vertices = vertices.permuted(&order);
    drop(order);
    timer.lap("vertex fetch");

    stats.triangles_out = indices.len() / 3;
    stats.vertices_out = vertices.len();
    if !indices.is_empty() && settings.analyze {
        stats.acmr_out = meshopt::analyze_vertex_cache(&indices, vertices.len(), 16, 0, 0).acmr;
        stats.overfetch = meshopt::analyze_vertex_fetch(
            &indices,
            vertices.len(),
            // The standard layout's stride, with or without colours, as it always was.
            pack::VertexLayout::standard().stride as usize,
        )
        .overfetch;
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

#[cfg(test)]
mod tests {
    use super::*;

    use crate::mesh::soup;
    use proptest::prelude::*;

    const OPAQUE: MaterialNeeds = MaterialNeeds::OPAQUE;
    const WINDOW: MaterialNeeds = MaterialNeeds {
        window: true,
        ..MaterialNeeds::OPAQUE
    };

    /// Two corners at one position with colours of their own (faces painted apart, each with
    /// its own copy of the position, as exporters write a colour seam) are two vertices, on
    /// both deduplication paths; one colour, or none, welds them. Windows show no colour.
    #[test]
    fn colour_seams_split_vertices_and_windows_stay_white() {
        let positions = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [1., 1., 0.],
        ];
        let tris = vec![[0, 1, 2], [4, 3, 5]];
        let (red, blue) = ([1.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]);
        let tangents = MaterialNeeds {
            tangents: true,
            ..OPAQUE
        };
        for need in [OPAQUE, tangents] {
            let mut s = soup(positions.clone(), tris.clone());
            let vertices = |s: &Imported, need| {
                process(s, &[0, 0], &[need], &MeshSettings::default()).vertices
            };
            assert_eq!(vertices(&s, need).len(), 4, "no colours: welded");
            s.colours = vec![red; 6];
            let v = vertices(&s, need);
            assert_eq!(v.len(), 4, "one colour: welded");
            assert_eq!(v.colours, vec![[255, 0, 0, 0]; 4]);
            s.colours[3..].fill(blue);
            let v = vertices(&s, need);
            assert_eq!(v.len(), 6, "a colour seam: split");
            let mut got = v.colours.clone();
            got.sort();
            assert_eq!(
                got,
                [[0, 0, 255, 0]; 3]
                    .into_iter()
                    .chain([[255, 0, 0, 0]; 3])
                    .collect::<Vec<_>>()
            );
            let glass = MaterialNeeds {
                window: true,
                colours: false,
                ..need
            };
            let v = vertices(&s, glass);
            assert_eq!(v.len(), 4, "windows show no colour: welded");
            assert!(v.colours.is_empty());
        }
    }

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
                assert_eq!(p.vertices.materials[i as usize], r.material);
            }
        }
        // Generated normals of a flat quad are exactly +Z.
        assert!(p.vertices.iter().all(|v| v.normal == [0.0, 0.0, 1.0]));
    }

    /// A UV sphere without its poles, `rings` x `segments` quads, its triangles in a scrambled order
    /// (like a range scan's, where neighbours in the file are far apart on the surface).
    fn scrambled_sphere(rings: u32, segments: u32) -> crate::import::Imported {
        let mut positions = Vec::new();
        for r in 0..=rings {
            let theta = std::f32::consts::PI * (r + 1) as f32 / (rings + 2) as f32;
            for s in 0..segments {
                let phi = std::f32::consts::TAU * s as f32 / segments as f32;
                positions.push([
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                ]);
            }
        }
        let at = |r: u32, s: u32| r * segments + s % segments;
        let mut tris = Vec::new();
        for r in 0..rings {
            for s in 0..segments {
                tris.push([at(r, s), at(r + 1, s), at(r + 1, s + 1)]);
                tris.push([at(r, s), at(r + 1, s + 1), at(r, s + 1)]);
            }
        }
        // A multiplier coprime with the count permutes the triangles.
        let n = tris.len();
        let scrambled = (0..n).map(|i| tris[(i * 7919) % n]).collect();
        soup(positions, scrambled)
    }

    #[test]
    fn a_range_past_the_piece_size_is_cut_at_its_quantiles_in_source_order() {
        let s = scrambled_sphere(150, 180);
        let n = s.triangle_count();
        let d = deduplicate(
            &s,
            SourceNormals::copy(&s),
            &vec![0; n],
            &[OPAQUE],
            &Default::default(),
        );
        let v = d.vertices.into_arrays(&s);
        let along = |i: u32| v.positions[i as usize][1];
        let key = |t: &[u32]| t.iter().map(|&i| along(i)).sum::<f32>();
        let mut indices = d.indices.clone();
        // 6 pieces of at most 10 000 triangles (the sphere has 53 640).
        let pieces = cache_pieces(&mut indices, &d.ranges, v.len(), along, 10_000);
        assert_eq!(pieces.len(), 6);
        let mut seen = Vec::new();
        let mut below = f32::NEG_INFINITY;
        for (piece, global) in &pieces {
            let tris: Vec<[u32; 3]> = (piece.chunks_exact(3))
                .map(|t| [t[0], t[1], t[2]].map(|l| global[l as usize]))
                .collect();
            assert!(tris.len().abs_diff(n / 6) <= 1, "{} of {n}", tris.len());
            // Each piece lies above the one before it along the axis.
            let keys: Vec<f32> = tris.iter().map(|t| key(t)).collect();
            let lo = keys.iter().copied().fold(f32::INFINITY, f32::min);
            assert!(lo >= below, "{lo} below {below}");
            below = keys.iter().copied().fold(below, f32::max);
            seen.extend(tris);
        }
        // Every triangle once, each piece in source order.
        let source: Vec<[u32; 3]> = (d.indices.chunks_exact(3))
            .map(|t| [t[0], t[1], t[2]])
            .collect();
        let at: std::collections::HashMap<[u32; 3], usize> =
            source.iter().enumerate().map(|(i, &t)| (t, i)).collect();
        assert_eq!(at.len(), n);
        let mut order: Vec<usize> = seen.iter().map(|t| at[t]).collect();
        let mut start = 0;
        for (piece, _) in &pieces {
            let end = start + piece.len() / 3;
            assert!(order[start..end].is_sorted());
            start = end;
        }
        order.sort();
        assert!(order.iter().enumerate().all(|(i, &o)| i == o));
        // Ordered piece by piece, within a percent of the whole range ordered as one.
        for (piece, global) in pieces {
            meshopt::optimize_vertex_cache_in_place(piece, global.len());
            for i in piece.iter_mut() {
                *i = global[*i as usize];
            }
        }
        let acmr = |i: &[u32]| meshopt::analyze_vertex_cache(i, v.len(), 16, 0, 0).acmr;
        let mut whole = d.indices.clone();
        meshopt::optimize_vertex_cache_in_place(&mut whole, v.len());
        let (cut, one) = (acmr(&indices), acmr(&whole));
        assert!(cut <= one * 1.01, "ACMR {cut} in pieces against {one}");
    }

    /// A disc of 3,000 triangles fanned from its centre, in order round it and scrambled:
    /// ordered with the centre as runs of 256 triangles, the same triangles (each as its
    /// corners turned or not), and as cache-efficient as meshopt's own order of the whole,
    /// which rescores all of the centre's live triangles at each step (0.48 s on a
    /// 50,000-triangle fan).
    #[test]
    fn a_vertex_shared_by_thousands_of_triangles_is_ordered_in_runs_as_well_as_whole() {
        let n = 3000u32;
        let fan: Vec<u32> = (0..n).flat_map(|i| [0, 1 + (i + 1) % n, 1 + i]).collect();
        // A scrambled order: every 7th triangle, round the fan.
        let scrambled: Vec<u32> = (0..n as usize)
            .flat_map(|t| {
                let t = (t * 7) % n as usize;
                fan[3 * t..3 * t + 3].to_vec()
            })
            .collect();
        for (what, input, vertices) in [("fan", &fan, n + 1), ("scrambled", &scrambled, n + 1)] {
            let acmr =
                |i: &[u32]| meshopt::analyze_vertex_cache(i, vertices as usize, 16, 0, 0).acmr;
            let mut runs = input.clone();
            let copies = order_for_cache(&mut runs, vertices as usize, 256);
            assert_eq!(copies, (n as usize).div_ceil(256) - 1, "{what}");
            let turned = |i: &[u32]| {
                let mut t: Vec<[u32; 3]> = i
                    .chunks_exact(3)
                    .map(|c| {
                        let r = (0..3).min_by_key(|&k| c[k]).unwrap();
                        [c[r], c[(r + 1) % 3], c[(r + 2) % 3]]
                    })
                    .collect();
                t.sort();
                t
            };
            assert_eq!(turned(&runs), turned(input), "{what}");
            let mut whole = input.clone();
            meshopt::optimize_vertex_cache_in_place(&mut whole, vertices as usize);
            let (r, w) = (acmr(&runs), acmr(&whole));
            assert!(r <= w * 1.01, "{what}: ACMR {r} in runs against {w}");
            // Below the limit, meshopt's order exactly.
            let mut below = input.clone();
            assert_eq!(order_for_cache(&mut below, vertices as usize, n), 0);
            assert_eq!(below, whole, "{what}");
        }
    }

    #[test]
    fn a_large_range_is_ordered_in_two_halves_without_losing_cache_efficiency() {
        let s = scrambled_sphere(150, 180);
        let n = s.triangle_count();
        assert!(n >= CACHE_SPLIT_TRIANGLES && !n.is_multiple_of(7919), "{n}");
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| process(&s, &vec![0; n], &[OPAQUE], &MeshSettings::default()))
        };
        let p = run(2);
        for threads in [1, 8] {
            let q = run(threads);
            assert_eq!(q.indices, p.indices, "{threads} threads");
            assert_eq!(q.vertices.len(), p.vertices.len());
        }
        // Every triangle is still there (as its three positions, whatever the rotation).
        let key = |ps: [[f32; 3]; 3]| {
            let mut k = ps.map(|p| p.map(|c| plus_zero(c).to_bits()));
            k.sort();
            k
        };
        // The output's triangles in source order: every triangle is still there.
        let by_key: std::collections::HashMap<_, [u32; 3]> = p
            .indices
            .chunks_exact(3)
            .map(|t| {
                let t = [t[0], t[1], t[2]];
                (key(t.map(|i| p.vertices.positions[i as usize])), t)
            })
            .collect();
        assert_eq!(by_key.len(), n);
        let source: Vec<u32> = s
            .corners
            .positions()
            .chunks_exact(3)
            .flat_map(|c| by_key[&key([0, 1, 2].map(|i| s.positions[c[i] as usize]))])
            .collect();
        // Within half a percent of ordering the whole range as one piece.
        let acmr = |i: &[u32]| meshopt::analyze_vertex_cache(i, p.vertices.len(), 16, 0, 0).acmr;
        let mut whole = source.clone();
        meshopt::optimize_vertex_cache_in_place(&mut whole, p.vertices.len());
        let (split, one) = (acmr(&p.indices), acmr(&whole));
        assert!(
            split <= one * 1.005,
            "ACMR {split} in halves against {one} in one piece"
        );
        // Cut by source order instead, the halves would share most of their vertices.
        let mut naive = source;
        let (a, b) = naive.split_at_mut(n / 2 * 3);
        meshopt::optimize_vertex_cache_in_place(a, p.vertices.len());
        meshopt::optimize_vertex_cache_in_place(b, p.vertices.len());
        assert!(acmr(&naive) > one * 1.05, "{} against {one}", acmr(&naive));
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
    fn fast_acos_is_within_a_micro_radian_everywhere() {
        let mut worst = 0.0f64;
        for i in 0..=2_000_000u32 {
            let x = -1.0 + 2.0 * i as f32 / 2_000_000.0;
            let e = (fast_acos(x) as f64 - (x as f64).acos()).abs();
            worst = worst.max(e);
        }
        for x in [
            -1.0f32,
            -0.0,
            0.0,
            1.0,
            f32::MIN_POSITIVE,
            1.0 - f32::EPSILON,
            2.0,
            -3.0,
        ] {
            let e = (fast_acos(x) as f64 - (x.clamp(-1.0, 1.0) as f64).acos()).abs();
            worst = worst.max(e);
        }
        assert!(worst < 1e-6, "max error {worst} rad");
    }

    proptest! {
        /// meshopt's vertex cache order does not depend on how the vertices are numbered, so
        /// each piece is ordered on its own ids (`cache_pieces`): the order on vertices
        /// renumbered by any permutation is the same triangles, renumbered. (Not the FIFO
        /// optimizer's: after a dead end it takes the lowest-numbered vertex left.)
        #[test]
        fn the_vertex_cache_order_ignores_vertex_numbering(
            raw in prop::collection::vec((0u32..40, 0u32..40, 0u32..40), 1..120),
            perm_seed in any::<u64>(),
        ) {
            let indices: Vec<u32> = raw.iter().flat_map(|&(a, b, c)| [a, b, c]).collect();
            let mut perm: Vec<u32> = (0..40).collect();
            let mut state = perm_seed | 1;
            for i in (1..perm.len()).rev() {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                perm.swap(i, (state % (i as u64 + 1)) as usize);
            }
            let order = |mut i: Vec<u32>, count: usize| {
                meshopt::optimize_vertex_cache_in_place(&mut i, count);
                i
            };
            let renamed: Vec<u32> = indices.iter().map(|&i| perm[i as usize]).collect();
            let want: Vec<u32> = order(indices, 40).iter().map(|&i| perm[i as usize]).collect();
            prop_assert_eq!(order(renamed, 40), want);
        }

        /// The kept triangles are the non-degenerate ones, stably grouped by material with
        /// windows last, whether held as a count or as a list.
        #[test]
        fn kept_triangles_are_the_filtered_and_grouped_ones(
            pts in prop::collection::vec(prop::array::uniform3(prop::sample::select(vec![-1.0f32, 0.0, 1.0, 2.0])), 3..8),
            raw in prop::collection::vec((0u32..8, 0u32..8, 0u32..8, 0u16..3), 0..30),
        ) {
            let n = pts.len() as u32;
            let tris: Vec<[u32; 3]> = raw.iter().map(|&(a, b, c, _)| [a % n, b % n, c % n]).collect();
            let mats: Vec<u16> = raw.iter().map(|r| r.3).collect();
            let s = soup(pts, tris);
            let needs = [OPAQUE, WINDOW, OPAQUE];
            let mut want: Vec<u32> = (0..s.triangle_count() as u32)
                .filter(|&t| {
                    let [a, b, c] = s.corners.triangle_positions(t as usize);
                    a != b && b != c && a != c
                        && !is_degenerate(s.positions[a as usize], s.positions[b as usize], s.positions[c as usize])
                })
                .collect();
            want.sort_by_key(|&t| (needs[mats[t as usize] as usize].window, mats[t as usize]));
            let kept = Kept::find(&s, &mats, &needs);
            let identity = want.iter().enumerate().all(|(k, &t)| k as u32 == t)
                && want.len() == s.triangle_count();
            prop_assert_eq!(matches!(kept, Kept::All(_)), identity);
            prop_assert_eq!(kept.iter().collect::<Vec<_>>(), want);
        }

        /// Each kept corner's id names its source normal made unit (or NONE where it has none
        /// or a zero one), whether the kept triangles are all, some in source order (the ids
        /// written over the corners' indices) or moved by material.
        #[test]
        fn source_normal_ids_name_each_kept_corners_normal(
            values in prop::collection::vec(0usize..5, 1..12),
            corners in prop::collection::vec(prop::option::of(0usize..12), 3..60),
            picks in prop::collection::vec(any::<bool>(), 20),
            order in 0u8..3,
            follow in any::<bool>(),
        ) {
            const SET: [[f32; 3]; 5] = [[0.0, 2.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [-0.0, 3.0, 0.0], [0.6, 0.8, 0.0]];
            let values: Vec<[f32; 3]> = values.iter().map(|&v| SET[v]).collect();
            let triangles = corners.len() / 3;
            let corner_n: Vec<u32> = corners[..3 * triangles]
                .iter()
                .map(|c| c.map_or(NONE, |i| (i % values.len()) as u32))
                .collect();
            let keep = match order {
                0 => Kept::All(triangles),
                1 => Kept::List((0..triangles as u32).filter(|&t| picks[t as usize % 20]).collect()),
                _ => Kept::List((0..triangles as u32).rev().collect()),
            };
            // Normal indices that are the position indices over again are not held.
            let p = if follow && !corner_n.contains(&NONE) {
                corner_n.clone()
            } else {
                vec![0; corner_n.len()]
            };
            let s = crate::import::Imported {
                corners: crate::import::Corners::from_fields(p, Vec::new(), Vec::new()),
                ..Default::default()
            };
            let normals = SourceNormals { values: values.clone(), corners: Indices::of(corner_n.clone(), s.corners.positions()) };
            let (ids, table, missing) = source_normals(&s, normals, &keep);
            if corner_n.iter().all(|&n| n == NONE) {
                // No corner has one: no ids, every kept corner missing.
                prop_assert!(ids.is_empty());
                prop_assert_eq!(missing, 3 * keep.len());
                return Ok(());
            }
            prop_assert_eq!(ids.len(), 3 * keep.len());
            let mut none = 0;
            for (k, t) in keep.iter().enumerate() {
                for j in 0..3 {
                    let n = corner_n[3 * t as usize + j];
                    let want = (n != NONE)
                        .then(|| unit(Vec3::from(values[n as usize])).to_array().map(plus_zero))
                        .filter(|v| Vec3::from(*v).length_squared() > 0.0);
                    match want {
                        None => {
                            prop_assert_eq!(ids[3 * k + j], NONE);
                            none += 1;
                        }
                        Some(v) => prop_assert_eq!(
                            table[ids[3 * k + j] as usize].map(f32::to_bits),
                            v.map(f32::to_bits)
                        ),
                    }
                }
            }
            prop_assert_eq!(missing, none);
        }

        /// Generated normals are the same bits whether the face normals are held in an array
        /// (small meshes) or found again at each corner (large ones).
        #[test]
        fn face_normals_found_again_are_the_held_ones(
            pts in prop::collection::vec(prop::array::uniform3(-4.0f32..4.0), 3..10),
            raw in prop::collection::vec((0u32..10, 0u32..10, 0u32..10), 1..40),
            crease_deg in 0.0f32..180.0,
        ) {
            let n = pts.len() as u32;
            let tris: Vec<[u32; 3]> = raw.iter().map(|&(a, b, c)| [a % n, b % n, c % n]).collect();
            let s = soup(pts, tris);
            let keep = Kept::find(&s, &vec![0; s.triangle_count()], &[OPAQUE]);
            let (canon, welded) = weld(&s.positions);
            let crease = crease_deg.to_radians().cos();
            let run = |held| corner_normals(&s, &canon, welded, &keep, source_normals(&s, SourceNormals::copy(&s), &keep), crease, held);
            let (held, found) = (run(true), run(false));
            prop_assert_eq!(&held.0, &found.0);
            prop_assert_eq!(held.2, found.2);
            let bits = |t: &[[f32; 3]]| t.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
            prop_assert_eq!(bits(&held.1), bits(&found.1));
        }

        /// Arbitrary (often degenerate) soups: every output triangle is non-degenerate, every
        /// index is in range, ranges tile the index buffer and vertices agree with their range;
        /// the kept triangles' positions come out (reordered) and the vertices are in the order
        /// the indices first use them, every one used. With a normal-mapped
        /// material the whole-vertex path runs, without one the by-reference path.
        #[test]
        fn arbitrary_soups_process_cleanly(
            pts in prop::collection::vec(prop::array::uniform3(prop::sample::select(vec![-1.0f32, -0.0, 0.0, 0.5, 1.0, 2.0])), 1..12),
            raw in prop::collection::vec((0u32..12, 0u32..12, 0u32..12, 0u16..3), 0..40),
            fifo in any::<bool>(),
            tangents in any::<bool>(),
        ) {
            let n = pts.len() as u32;
            let tris: Vec<[u32; 3]> = raw.iter().map(|&(a, b, c, _)| [a % n, b % n, c % n]).collect();
            let mats: Vec<u16> = raw.iter().map(|r| r.3).collect();
            let s = soup(pts.clone(), tris.clone());
            let needs = [OPAQUE, WINDOW, MaterialNeeds { tangents, uvs: tangents, ..OPAQUE }];
            let settings = MeshSettings { cache: if fifo { CacheMode::Fifo } else { CacheMode::Full }, overdraw: true, ..Default::default() };
            let p = process(&s, &mats, &needs, &settings);
            let kept: Vec<&[u32; 3]> = tris.iter().filter(|t| {
                let [a, b, c] = t.map(|i| pts[i as usize]);
                t[0] != t[1] && t[1] != t[2] && t[0] != t[2] && !is_degenerate(a, b, c)
            }).collect();
            prop_assert_eq!(p.indices.len(), kept.len() * 3);
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
                    prop_assert_eq!(p.vertices.materials[i as usize], r.material);
                }
            }
            prop_assert_eq!(next as usize, p.indices.len());
            for t in p.indices.chunks_exact(3) {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| p.vertices.positions[i as usize]);
                prop_assert!(!is_degenerate(a, b, c));
            }
            for v in p.vertices.iter() {
                prop_assert!(v.normal.iter().chain(&v.tangent).all(|c| c.is_finite()));
                let l = Vec3::from(v.normal).length_squared();
                prop_assert!((l - 1.0).abs() < 1e-3, "normal {:?}", v.normal);
            }
            let bits = |p: [f32; 3]| p.map(|c| plus_zero(c).to_bits());
            let mut kept: Vec<[[u32; 3]; 3]> =
                kept.iter().map(|t| t.map(|i| bits(pts[i as usize]))).collect();
            let mut out: Vec<[[u32; 3]; 3]> = p.indices.chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]].map(|i| bits(p.vertices.positions[i as usize])))
                .collect();
            kept.sort_unstable();
            out.sort_unstable();
            prop_assert_eq!(kept, out);
            let mut first_use = 0u32;
            for &i in &p.indices {
                prop_assert!(i <= first_use, "vertex {} used before vertex {}", i, first_use);
                first_use = first_use.max(i + 1);
            }
            prop_assert_eq!(first_use as usize, p.vertices.len());
        }
    }
}
