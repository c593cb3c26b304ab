//! MikkTSpace tangents, computed as Morten S. Mikkelsen's reference implementation computes
//! them (the one the `mikktspace` crate translates and the bakers of normal maps use), so a
//! normal map baked elsewhere stays right here.
//!
//! The result is the reference's, not an approximation of it: the same shared vertices (equal
//! position, normal and texture coordinate), the same pairing of triangles across an edge
//! (including the greedy choice on edges with more than two triangles), the same groups built
//! in the same order (a triangle without texture-space area joins the first group that reaches
//! it), the same sub-groups and the same arithmetic in the same order, so the tangents come
//! out with the same bits. One quirk of the reference is not copied: its edge sort leaves the
//! last run of edges unsorted, so there an edge can miss its partner and a group split; that
//! run depends on its own vertex numbering and quicksort, and is a single edge whenever the
//! last triangle's vertices are new (see the tests).
//!
//! What differs is how: shared vertices by hashing (partitions in parallel) instead of a grid
//! and recursive splitting, edges by a counting sort over vertices instead of three
//! quicksorts, per-triangle values computed once instead of once per pair in a group, no
//! per-corner allocation, and the tangent spaces of the groups in parallel. The bench report
//! (docs/bench, Tangents) compares the times; the tests hold it to the crate bit for bit on
//! awkward meshes and within 1e-5 on a real model.
//!
//! Input is a triangle list (three corners per triangle); quads are not taken.

use std::collections::HashMap;

use glam::Vec3;
use rayon::prelude::*;

use super::weld::plus_zero;
use crate::buckets::{Counts, Grouped};

const NONE: u32 = u32::MAX;
/// The triangle's texture-space area is zero: it joins any group and adds nothing to it.
const GROUP_WITH_ANY: u8 = 4;
/// The texture mapping keeps the triangle's orientation (bitangent sign +1).
const ORIENT_PRESERVING: u8 = 8;

/// Per-corner attributes of a triangle list: corner `3 * t + k` is corner `k` of triangle `t`.
pub trait Corners: Sync {
    /// Number of corners (three per triangle).
    fn corner_count(&self) -> usize;
    fn position(&self, corner: usize) -> [f32; 3];
    fn normal(&self, corner: usize) -> [f32; 3];
    fn uv(&self, corner: usize) -> [f32; 2];
}

/// Corners given as three parallel arrays.
pub struct CornerArrays<'a> {
    pub positions: &'a [[f32; 3]],
    pub normals: &'a [[f32; 3]],
    pub uvs: &'a [[f32; 2]],
}

impl Corners for CornerArrays<'_> {
    fn corner_count(&self) -> usize {
        self.positions.len()
    }
    fn position(&self, c: usize) -> [f32; 3] {
        self.positions[c]
    }
    fn normal(&self, c: usize) -> [f32; 3] {
        self.normals[c]
    }
    fn uv(&self, c: usize) -> [f32; 2] {
        self.uvs[c]
    }
}

fn not_zero(x: f32) -> bool {
    x.abs() > f32::MIN_POSITIVE
}

fn v_not_zero(v: Vec3) -> bool {
    not_zero(v.x) || not_zero(v.y) || not_zero(v.z)
}

/// Scales by the reciprocal of the length, as the reference does (dividing rounds differently).
fn normalize(v: Vec3) -> Vec3 {
    (1.0 / v.length()) * v
}

fn normalize_if_not_zero(v: Vec3) -> Vec3 {
    if v_not_zero(v) { normalize(v) } else { v }
}

/// `v` without its component along `n`, as a unit vector when it is not zero.
fn project(v: Vec3, n: Vec3) -> Vec3 {
    normalize_if_not_zero(v - n.dot(v) * n)
}

#[derive(Clone, Copy, Default)]
struct Tri {
    os: Vec3,
    ot: Vec3,
    flag: u8,
}

/// Tangents for every corner: `[x, y, z, w]` with a unit tangent (or the reference's fallback
/// `[1, 0, 0]` where it has none) and the bitangent sign `w` (±1).
pub fn generate<C: Corners>(corners: &C) -> Vec<[f32; 4]> {
    let corner_count = corners.corner_count() / 3 * 3;
    let total = corner_count / 3;
    let mut out = vec![[1.0, 0.0, 0.0, -1.0]; corner_count];
    if total == 0 {
        return out;
    }
    let pos = |c: usize| Vec3::from(corners.position(c));

    let (vid, vertex_count) = shared_vertices(corners, corner_count);

    // Degenerate triangles (two equal positions) are moved behind the good ones exactly as the
    // reference moves them, since the good ones' order decides groups and edge pairing.
    let degenerate = |t: usize| {
        let [a, b, c] = [0, 1, 2].map(|k| pos(3 * t + k));
        a == b || a == c || b == c
    };
    let is_degen: Vec<bool> = (0..total).into_par_iter().map(degenerate).collect();
    let degen_count = is_degen.iter().filter(|&&d| d).count();
    let good = total - degen_count;
    let mut order: Vec<u32> = (0..total as u32).collect();
    if degen_count > 0 {
        let mut deg = is_degen.clone();
        let mut next_good = 1usize;
        let mut t = 0usize;
        while t < good {
            if !deg[t] {
                next_good = next_good.max(t + 2);
            } else {
                while next_good < total && deg[next_good] {
                    next_good += 1;
                }
                if next_good >= total {
                    break;
                }
                order.swap(t, next_good);
                deg.swap(t, next_good);
                next_good += 1;
            }
            t += 1;
        }
    }
    // Shared vertex of corner k of (reordered) triangle t.
    let tv: Vec<[u32; 3]> = order[..good]
        .par_iter()
        .map(|&o| [0, 1, 2].map(|k| vid[3 * o as usize + k]))
        .collect();

    let mut tris: Vec<Tri> = order[..good]
        .par_iter()
        .map(|&o| {
            let c = 3 * o as usize;
            let [v1, v2, v3] = [pos(c), pos(c + 1), pos(c + 2)];
            let [t1, t2, t3] = [corners.uv(c), corners.uv(c + 1), corners.uv(c + 2)];
            let t21x = t2[0] - t1[0];
            let t21y = t2[1] - t1[1];
            let t31x = t3[0] - t1[0];
            let t31y = t3[1] - t1[1];
            let d1 = v2 - v1;
            let d2 = v3 - v1;
            let signed_area = t21x * t31y - t21y * t31x;
            let os = t31y * d1 - t21y * d2;
            let ot = -t31x * d1 + t21x * d2;
            let mut tri = Tri {
                flag: GROUP_WITH_ANY,
                ..Tri::default()
            };
            if signed_area > 0.0 {
                tri.flag |= ORIENT_PRESERVING;
            }
            if not_zero(signed_area) {
                let abs_area = signed_area.abs();
                let len_os = os.length();
                let len_ot = ot.length();
                let s = if tri.flag & ORIENT_PRESERVING == 0 {
                    -1.0
                } else {
                    1.0
                };
                if not_zero(len_os) {
                    tri.os = (s / len_os) * os;
                }
                if not_zero(len_ot) {
                    tri.ot = (s / len_ot) * ot;
                }
                if not_zero(len_os / abs_area) && not_zero(len_ot / abs_area) {
                    tri.flag &= !GROUP_WITH_ANY;
                }
            }
            tri
        })
        .collect();

    let neighbors = build_neighbors(&tv, vertex_count);
    let groups = build_groups(&tv, &neighbors, &mut tris, &order);

    // Tangent spaces, groups in parallel batches: each member of a group is one output corner,
    // and a batch of consecutive groups owns a consecutive run of members.
    let thres_cos = ((180.0f32 * std::f64::consts::PI as f32 / 180.0) as f64).cos() as f32;
    let mut values = vec![[0.0f32; 4]; groups.faces.len()];
    let per_batch = (groups.list.len() / (rayon::current_num_threads() * 16)).max(256);
    let mut jobs = Vec::new();
    let mut rest: &mut [[f32; 4]] = &mut values;
    for batch in groups.list.chunks(per_batch) {
        let len: u32 = batch.iter().map(|g| g.len).sum();
        let (mine, others) = rest.split_at_mut(len as usize);
        jobs.push((batch, mine));
        rest = others;
    }
    let ctx = Context {
        corners,
        tris: &tris,
        faces: &groups.faces,
        slots: &groups.slots,
        thres_cos,
    };
    jobs.into_par_iter().for_each(|(batch, values)| {
        let mut scratch = Scratch::default();
        let mut at = 0;
        for g in batch {
            let len = g.len as usize;
            ctx.group(g, &mut values[at..at + len], &mut scratch);
            at += len;
        }
    });
    for (&slot, v) in groups.slots.iter().zip(&values) {
        out[slot as usize] = *v;
    }
    drop(values);

    // Degenerate triangles take the tangent of the first good corner at the same vertex.
    if degen_count > 0 {
        let mut first: Vec<u32> = vec![NONE; vertex_count];
        for (t, v) in tv.iter().enumerate() {
            for (k, &x) in v.iter().enumerate() {
                if first[x as usize] == NONE {
                    first[x as usize] = (3 * order[t] as usize + k) as u32;
                }
            }
        }
        for &o in &order[good..] {
            for k in 0..3 {
                let c = 3 * o as usize + k;
                let src = first[vid[c] as usize];
                if src != NONE {
                    out[c] = out[src as usize];
                }
            }
        }
    }
    out
}

/// Shared vertices: corners equal in position, normal and texture coordinate get one id.
/// Values compare by their bits after -0.0 → +0.0, which is float equality except for NaN,
/// which equals nothing in the reference: such corners stay alone. Ids are labels only (no
/// order is taken from them), so corners are split by hash into partitions welded in parallel,
/// each with a table small enough to stay in cache.
fn shared_vertices<C: Corners>(corners: &C, corner_count: usize) -> (Vec<u32>, usize) {
    const PART_BITS: u32 = 8;
    const EMPTY: u64 = u64::MAX;
    let key = |c: usize| {
        let (p, n, t) = (corners.position(c), corners.normal(c), corners.uv(c));
        [p[0], p[1], p[2], n[0], n[1], n[2], t[0], t[1]].map(|x| plus_zero(x).to_bits())
    };
    let hashes: Vec<u64> = (0..corner_count)
        .into_par_iter()
        .map(|c| {
            let k = key(c);
            if k.iter().any(|&b| f32::from_bits(b).is_nan()) {
                // Marked by the top partition's last value, never a real hash (see below).
                return EMPTY;
            }
            let mut h = 0u64;
            for w in k {
                h = (h.rotate_left(5) ^ w as u64).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
            }
            h ^= h >> 33;
            h = h.wrapping_mul(0xff51_afd7_ed55_8ccd);
            h ^= h >> 33;
            // Real hashes stay below EMPTY.
            (h ^ (h >> 29)).min(EMPTY - 1)
        })
        .collect();
    let parts = 1usize << PART_BITS;
    let part = |h: u64| (h >> (64 - PART_BITS)) as usize;
    let mut counts = Counts::new(parts);
    for &h in &hashes {
        counts.add(part(h));
    }
    // Each partition's corners, hashes and values side by side (corners ascending), so that
    // welding one touches only its own memory.
    let mut placing = counts.placing((0u32, 0u64, [0u32; 8]));
    for (c, &h) in hashes.iter().enumerate() {
        placing.put(part(h), (c as u32, h, key(c)));
    }
    drop(hashes);
    let members = placing.finish();
    // For each member, the first corner (the smallest) with its value.
    let firsts: Vec<Vec<u32>> = (0..parts)
        .into_par_iter()
        .map(|p| {
            let list = members.group(p);
            let size = (list.len() * 2).next_power_of_two().max(16);
            let mask = size - 1;
            let mut table = vec![u32::MAX; size];
            let mut firsts = Vec::with_capacity(list.len());
            for (m, &(c, h, k)) in list.iter().enumerate() {
                if h == EMPTY {
                    firsts.push(c);
                    continue;
                }
                let mut slot = h as usize & mask;
                loop {
                    let e = table[slot];
                    if e == u32::MAX {
                        table[slot] = m as u32;
                        firsts.push(c);
                        break;
                    }
                    let (first, fh, fk) = list[e as usize];
                    if fh == h && fk == k {
                        firsts.push(first);
                        break;
                    }
                    slot = (slot + 1) & mask;
                }
            }
            firsts
        })
        .collect();
    let mut first = vec![0u32; corner_count];
    for (p, f) in firsts.iter().enumerate() {
        for (&(c, _, _), &r) in members.group(p).iter().zip(f) {
            first[c as usize] = r;
        }
    }
    drop(members);
    // Ids in order of first appearance, which keeps the edge sort's memory access local.
    let mut next = 0u32;
    for c in 0..corner_count {
        let r = first[c] as usize;
        first[c] = if r == c {
            next += 1;
            next - 1
        } else {
            first[r]
        };
    }
    (first, next as usize)
}

/// For each triangle and edge k (corner k to corner k+1), the triangle across it or `NONE`.
/// Pairs as the reference does: edges sorted by (smaller vertex, larger vertex, triangle), and
/// each still unpaired edge takes the first later unpaired edge of the opposite direction.
fn build_neighbors(tv: &[[u32; 3]], vertex_count: usize) -> Vec<[u32; 3]> {
    let n = tv.len();
    let mut counts = Counts::new(vertex_count);
    for v in tv {
        for k in 0..3 {
            counts.add(v[k].min(v[(k + 1) % 3]) as usize);
        }
    }
    // (larger vertex, edge slot 3t+k), in triangle order within each smaller vertex.
    let mut placing = counts.placing((0u32, 0u32));
    for (t, v) in tv.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (v[k], v[(k + 1) % 3]);
            placing.put(a.min(b) as usize, (a.max(b), (3 * t + k) as u32));
        }
    }
    let Grouped {
        start,
        items: mut edges,
    } = placing.finish();
    let mut neighbors = vec![[NONE; 3]; n];
    let directed = |slot: u32| {
        let (t, k) = (slot as usize / 3, slot as usize % 3);
        (tv[t][k], tv[t][(k + 1) % 3])
    };
    for w in start.windows(2) {
        let bucket = &mut edges[w[0] as usize..w[1] as usize];
        if bucket.len() < 2 {
            continue;
        }
        // Stable: triangle order stays within each larger vertex.
        bucket.sort_by_key(|e| e.0);
        let mut i = 0;
        while i < bucket.len() {
            let mut end = i + 1;
            while end < bucket.len() && bucket[end].0 == bucket[i].0 {
                end += 1;
            }
            for a in i..end {
                let sa = bucket[a].1;
                let (ta, ka) = (sa as usize / 3, sa as usize % 3);
                if neighbors[ta][ka] != NONE {
                    continue;
                }
                let (a0, a1) = directed(sa);
                for b in &bucket[a + 1..end] {
                    let sb = b.1;
                    let (tb, kb) = (sb as usize / 3, sb as usize % 3);
                    if directed(sb) == (a1, a0) && neighbors[tb][kb] == NONE {
                        neighbors[ta][ka] = tb as u32;
                        neighbors[tb][kb] = ta as u32;
                        break;
                    }
                }
            }
            i = end;
        }
    }
    neighbors
}

struct Group {
    orient: bool,
    start: u32,
    len: u32,
}

struct Groups {
    list: Vec<Group>,
    /// Member triangles of every group, each group's contiguous.
    faces: Vec<u32>,
    /// For each member, the input corner at the group's vertex.
    slots: Vec<u32>,
}

/// The reference's groups: for each triangle with texture-space area and each of its corners
/// not yet in a group, a new group around that corner's vertex, grown depth-first across edges
/// around the vertex (left neighbour first) through triangles of the same orientation. A
/// triangle without area takes the orientation of the first group to reach it.
fn build_groups(
    tv: &[[u32; 3]],
    neighbors: &[[u32; 3]],
    tris: &mut [Tri],
    order: &[u32],
) -> Groups {
    let mut assigned = vec![[NONE; 3]; tv.len()];
    let mut list: Vec<Group> = Vec::new();
    let mut faces: Vec<u32> = Vec::with_capacity(tv.len() * 3);
    let mut slots: Vec<u32> = Vec::with_capacity(tv.len() * 3);
    let mut stack: Vec<u32> = Vec::new();
    for f in 0..tv.len() {
        for i in 0..3 {
            if tris[f].flag & GROUP_WITH_ANY != 0 || assigned[f][i] != NONE {
                continue;
            }
            let g = list.len() as u32;
            let rep = tv[f][i];
            let orient = tris[f].flag & ORIENT_PRESERVING != 0;
            let start = faces.len() as u32;
            assigned[f][i] = g;
            faces.push(f as u32);
            slots.push(3 * order[f] + i as u32);
            // Popped left first, as the reference recurses left before right.
            for nb in [neighbors[f][(i + 2) % 3], neighbors[f][i]] {
                if nb != NONE {
                    stack.push(nb);
                }
            }
            while let Some(t) = stack.pop() {
                let t = t as usize;
                let Some(k) = tv[t].iter().position(|&x| x == rep) else {
                    continue;
                };
                if assigned[t][k] != NONE {
                    continue;
                }
                if tris[t].flag & GROUP_WITH_ANY != 0 && assigned[t] == [NONE; 3] {
                    tris[t].flag &= !ORIENT_PRESERVING;
                    if orient {
                        tris[t].flag |= ORIENT_PRESERVING;
                    }
                }
                if (tris[t].flag & ORIENT_PRESERVING != 0) != orient {
                    continue;
                }
                faces.push(t as u32);
                slots.push(3 * order[t] + k as u32);
                assigned[t][k] = g;
                for nb in [neighbors[t][(k + 2) % 3], neighbors[t][k]] {
                    if nb != NONE {
                        stack.push(nb);
                    }
                }
            }
            list.push(Group {
                orient,
                start,
                len: faces.len() as u32 - start,
            });
        }
    }
    Groups { list, faces, slots }
}

struct Context<'a, C> {
    corners: &'a C,
    tris: &'a [Tri],
    faces: &'a [u32],
    slots: &'a [u32],
    thres_cos: f32,
}

/// Buffers reused from group to group.
#[derive(Default)]
struct Scratch {
    os: Vec<Vec3>,
    ot: Vec<Vec3>,
    any: Vec<bool>,
    members: Vec<u32>,
    /// Sub-groups found so far: (start, end) in `member_lists`, and their tangent.
    subgroups: Vec<(usize, usize, Vec3)>,
    member_lists: Vec<u32>,
}

impl<C: Corners> Context<'_, C> {
    /// The tangent of each member of one group (`out`, in member order): the members split
    /// into sub-groups whose projected tangent directions agree with each member's, each
    /// sub-group's tangent the angle-weighted sum over its members.
    fn group(&self, g: &Group, out: &mut [[f32; 4]], s: &mut Scratch) {
        let range = g.start as usize..(g.start + g.len) as usize;
        let faces = &self.faces[range.clone()];
        let slots = &self.slots[range];
        let n = Vec3::from(self.corners.normal(slots[0] as usize));
        // Projected directions of each member: the reference recomputes them for every pair,
        // with the same operations, so computing them once gives the same bits.
        s.os.clear();
        s.ot.clear();
        s.any.clear();
        for &t in faces {
            let tri = &self.tris[t as usize];
            s.os.push(project(tri.os, n));
            s.ot.push(project(tri.ot, n));
            s.any.push(tri.flag & GROUP_WITH_ANY != 0);
        }
        let sign = if g.orient { 1.0 } else { -1.0 };
        let k = faces.len();
        let similar = |a: usize, b: usize| {
            s.any[a]
                || s.any[b]
                || a == b
                || (s.os[a].dot(s.os[b]) > self.thres_cos && s.ot[a].dot(s.ot[b]) > self.thres_cos)
        };
        // Usually every member agrees with every other: one sub-group, the whole group.
        let all_similar = if self.thres_cos == -1.0 {
            !(some_pair_not_above_minus_one(&s.os, &s.any)
                || some_pair_not_above_minus_one(&s.ot, &s.any))
        } else {
            (0..k).all(|a| (a + 1..k).all(|b| similar(a, b)))
        };
        if all_similar {
            s.members.clear();
            s.members.extend(0..k as u32);
            s.members.sort_unstable_by_key(|&m| faces[m as usize]);
            let t = self.eval(&s.members, faces, slots, &s.os, n);
            out.fill([t.x, t.y, t.z, sign]);
            return;
        }
        if self.thres_cos == -1.0
            && let Some(e) = exceptions(&s.os, &s.ot, &s.any)
            && self
                .by_exceptions(&e, faces, slots, &s.os, n, sign, out)
                .is_some()
        {
            return;
        }
        s.subgroups.clear();
        s.member_lists.clear();
        for (a, out) in out.iter_mut().enumerate() {
            s.members.clear();
            for b in 0..k {
                if similar(a, b) {
                    s.members.push(b as u32);
                }
            }
            s.members.sort_unstable_by_key(|&m| faces[m as usize]);
            let found = s
                .subgroups
                .iter()
                .find(|&&(from, to, _)| s.member_lists[from..to] == s.members[..]);
            let t = match found {
                Some(&(_, _, t)) => t,
                None => {
                    let t = self.eval(&s.members, faces, slots, &s.os, n);
                    let from = s.member_lists.len();
                    s.member_lists.extend_from_slice(&s.members);
                    s.subgroups.push((from, s.member_lists.len(), t));
                    t
                }
            };
            *out = [t.x, t.y, t.z, sign];
        }
    }

    /// Angle-weighted sum of the members' projected tangent directions at the group's vertex,
    /// as a unit vector (or zero). `members` index the group's members, in ascending order of
    /// their triangles (the reference's summation order); `faces`, `slots` and `os` describe
    /// the whole group.
    fn eval(&self, members: &[u32], faces: &[u32], slots: &[u32], os: &[Vec3], n: Vec3) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for &m in members {
            if let Some(c) = self.contribution(m as usize, faces, slots, os, n) {
                sum += c;
            }
        }
        normalize_if_not_zero(sum)
    }

    /// Member `m`'s term of [`Self::eval`]'s sum: its projected tangent direction times its
    /// triangle's angle at the vertex; `None` for a triangle that groups with any.
    fn contribution(
        &self,
        m: usize,
        faces: &[u32],
        slots: &[u32],
        os: &[Vec3],
        n: Vec3,
    ) -> Option<Vec3> {
        if self.tris[faces[m] as usize].flag & GROUP_WITH_ANY != 0 {
            return None;
        }
        let slot = slots[m] as usize;
        let (base, i) = (slot - slot % 3, slot % 3);
        let p0 = Vec3::from(self.corners.position(base + if i > 0 { i - 1 } else { 2 }));
        let p1 = Vec3::from(self.corners.position(base + i));
        let p2 = Vec3::from(self.corners.position(base + if i < 2 { i + 1 } else { 0 }));
        let v1 = p0 - p1;
        let v2 = p2 - p1;
        let v1 = normalize_if_not_zero(v1 - n.dot(v1) * n);
        let v2 = normalize_if_not_zero(v2 - n.dot(v2) * n);
        let cos = v1.dot(v2).clamp(-1.0, 1.0);
        let angle = (cos as f64).acos() as f32;
        Some(angle * os[m])
    }

    /// Each member's tangent where some members differ (`exceptions`: per member, the members
    /// whose directions are opposite to its own, sorted), at the reference's 180-degree
    /// threshold: a member's sub-group is every member but its exceptions, so members with
    /// the same exceptions share a sub-group, and each sub-group's sum runs over the members
    /// in the reference's order with each term computed once. The reference compares every
    /// pair for every member; a 20,000-triangle fan whose UVs wrap twice round its centre
    /// took 23 s. `None` where two members share a triangle (their order is then not the
    /// triangles').
    #[allow(clippy::too_many_arguments)]
    fn by_exceptions(
        &self,
        exceptions: &[Vec<u32>],
        faces: &[u32],
        slots: &[u32],
        os: &[Vec3],
        n: Vec3,
        sign: f32,
        out: &mut [[f32; 4]],
    ) -> Option<()> {
        let k = faces.len();
        let mut order: Vec<u32> = (0..k as u32).collect();
        order.sort_unstable_by_key(|&m| faces[m as usize]);
        if order
            .windows(2)
            .any(|w| faces[w[0] as usize] == faces[w[1] as usize])
        {
            return None;
        }
        let terms: Vec<Option<Vec3>> = (0..k)
            .map(|m| self.contribution(m, faces, slots, os, n))
            .collect();
        let mut known: HashMap<&[u32], Vec3> = HashMap::new();
        let mut left_out = vec![usize::MAX; k];
        for (a, out) in out.iter_mut().enumerate() {
            let t = match known.get(exceptions[a].as_slice()) {
                Some(&t) => t,
                None => {
                    for &b in &exceptions[a] {
                        left_out[b as usize] = a;
                    }
                    let mut sum = Vec3::ZERO;
                    for &m in &order {
                        if left_out[m as usize] != a
                            && let Some(c) = terms[m as usize]
                        {
                            sum += c;
                        }
                    }
                    let t = normalize_if_not_zero(sum);
                    known.insert(&exceptions[a], t);
                    t
                }
            };
            *out = [t.x, t.y, t.z, sign];
        }
        Some(())
    }
}

/// Whether `a · b` is not above -1 (NaN included): the pairwise test's failure.
fn not_above_minus_one(a: Vec3, b: Vec3) -> bool {
    a.dot(b).partial_cmp(&-1.0) != Some(std::cmp::Ordering::Greater)
}

/// The vectors of a group's members (those `skip` leaves out aside) in the cells of a grid
/// 1/32 wide, to find the ones opposite each. Unit vectors with a product of -1 or less lie
/// within 0.0064 of each other's opposite, so only the cells around a vector's opposite can
/// hold them.
struct Opposites {
    grid: std::collections::BTreeMap<[i32; 3], Vec<usize>>,
}

impl Opposites {
    /// `None` where the vectors are not all finite and at most unit length (plus rounding):
    /// then every pair must be compared.
    fn new(v: &[Vec3], skip: &[bool]) -> Option<Self> {
        const CELLS: f32 = 32.0;
        let mut grid: std::collections::BTreeMap<[i32; 3], Vec<usize>> = Default::default();
        for i in (0..v.len()).filter(|&i| !skip[i]) {
            let len2 = v[i].length_squared();
            if len2.is_nan() || len2 > 1.000_02 {
                return None;
            }
            let cell = v[i].to_array().map(|x| (x * CELLS).floor() as i32);
            grid.entry(cell).or_default().push(i);
        }
        Some(Self { grid })
    }

    /// Calls `f` with each cell's members and the members of the cells around their opposite
    /// (themselves among them, where a cell is its own neighbour), until it returns true;
    /// returns whether it did.
    fn any_cell(&self, mut f: impl FnMut(&[usize], &[usize]) -> bool) -> bool {
        let mut near = Vec::new();
        for (c, members) in &self.grid {
            // The opposite of a point in cell `c` lies in cell `-c - 1` or `-c`; anything
            // within a cell's width of it, one further either way.
            near.clear();
            for dx in -2..=1 {
                for dy in -2..=1 {
                    for dz in -2..=1 {
                        if let Some(m) = self.grid.get(&[-c[0] + dx, -c[1] + dy, -c[2] + dz]) {
                            near.extend_from_slice(m);
                        }
                    }
                }
            }
            if f(members, &near) {
                return true;
            }
        }
        false
    }
}

/// Whether two of the vectors `v` (those `skip` marks left out) have a dot product that is not
/// above -1: -1 or less, or NaN. That is the reference's test of two members' tangent
/// directions at its 180-degree threshold, which it makes for every pair of a group's members:
/// `k²/2` products, and a disc fanned from its centre shares one vertex among all its
/// triangles (200,000 took 34 s). Each is compared only with those around its opposite
/// ([`Opposites`]), with the same product as the pairwise test; where the vectors are not all
/// finite and at most unit length, or few, every pair is compared.
fn some_pair_not_above_minus_one(v: &[Vec3], skip: &[bool]) -> bool {
    let kept: Vec<usize> = (0..v.len()).filter(|&i| !skip[i]).collect();
    let pairwise = || {
        kept.iter().enumerate().any(|(x, &a)| {
            kept[x + 1..]
                .iter()
                .any(|&b| not_above_minus_one(v[a], v[b]))
        })
    };
    if kept.len() < 64 {
        return pairwise();
    }
    match Opposites::new(v, skip) {
        Some(grid) => grid.any_cell(|members, near| {
            members.iter().any(|&a| {
                near.iter()
                    .any(|&b| a != b && not_above_minus_one(v[a], v[b]))
            })
        }),
        None => pairwise(),
    }
}

/// Per member, sorted, the members whose tangent or bitangent direction has a product of -1
/// or less (or NaN) with its own: those it does not share a sub-group with at the 180-degree
/// threshold (members that group with any are skipped, and have none). `None` where the grid
/// cannot be used ([`Opposites::new`]).
fn exceptions(os: &[Vec3], ot: &[Vec3], skip: &[bool]) -> Option<Vec<Vec<u32>>> {
    let grids = [
        (Opposites::new(os, skip)?, os),
        (Opposites::new(ot, skip)?, ot),
    ];
    let mut out = vec![Vec::new(); os.len()];
    for (grid, v) in &grids {
        grid.any_cell(|members, near| {
            for &a in members {
                for &b in near {
                    if a != b && not_above_minus_one(v[a], v[b]) {
                        out[a].push(b as u32);
                    }
                }
            }
            false
        });
    }
    for e in &mut out {
        e.sort_unstable();
        e.dedup();
    }
    Some(out)
}

/// The `mikktspace` crate's tangents for the same corners, as `set_tangent_encoded` gives
/// them (tests and the bench hold ours to it); `None` when the crate reports failure.
#[cfg(any(test, feature = "reference-tangents"))]
pub fn reference(c: &CornerArrays) -> Option<Vec<[f32; 4]>> {
    struct G<'a> {
        c: &'a CornerArrays<'a>,
        out: Vec<[f32; 4]>,
    }
    impl mikktspace::Geometry for G<'_> {
        fn num_faces(&self) -> usize {
            self.c.positions.len() / 3
        }
        fn num_vertices_of_face(&self, _: usize) -> usize {
            3
        }
        fn position(&self, f: usize, v: usize) -> [f32; 3] {
            self.c.positions[f * 3 + v]
        }
        fn normal(&self, f: usize, v: usize) -> [f32; 3] {
            self.c.normals[f * 3 + v]
        }
        fn tex_coord(&self, f: usize, v: usize) -> [f32; 2] {
            self.c.uvs[f * 3 + v]
        }
        fn set_tangent_encoded(&mut self, t: [f32; 4], f: usize, v: usize) {
            self.out[f * 3 + v] = t;
        }
    }
    let mut g = G {
        c,
        out: vec![[f32::NAN; 4]; c.positions.len()],
    };
    mikktspace::generate_tangents(&mut g).then_some(g.out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The reference crate through its callbacks, on the same corners.
    ///
    /// The reference sorts edges by their first vertex, then each run of equal first vertices
    /// by the second, then each run of equal edges by triangle, but skips the last run at each
    /// step (a quirk of the original code): there edges stay in its quicksort's order, so edges
    /// of one vertex can miss their partner and a group can split. An isolated triangle at the
    /// end, whose vertices have the largest indices, makes that last run a single edge; its
    /// corners are not compared.
    fn reference(c: &CornerArrays) -> Vec<[f32; 4]> {
        reference_as_is(&with_isolated_triangle(c).as_arrays())[..c.positions.len()].to_vec()
    }

    #[derive(Debug)]
    struct Owned(Vec<[f32; 3]>, Vec<[f32; 3]>, Vec<[f32; 2]>);

    impl Owned {
        fn as_arrays(&self) -> CornerArrays<'_> {
            CornerArrays {
                positions: &self.0,
                normals: &self.1,
                uvs: &self.2,
            }
        }
    }

    fn with_isolated_triangle(c: &CornerArrays) -> Owned {
        let mut positions = c.positions.to_vec();
        let mut normals = c.normals.to_vec();
        let mut uvs = c.uvs.to_vec();
        positions.extend([
            [1e4, 1e4, 1e4],
            [1e4 + 1.0, 1e4, 1e4],
            [1e4, 1e4 + 1.0, 1e4],
        ]);
        normals.extend([[0.0, 0.0, 1.0]; 3]);
        uvs.extend([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]);
        Owned(positions, normals, uvs)
    }

    fn reference_as_is(c: &CornerArrays) -> Vec<[f32; 4]> {
        super::reference(c).expect("the mikktspace crate generates tangents")
    }

    fn assert_close(ours: &[[f32; 4]], theirs: &[[f32; 4]]) {
        assert_eq!(ours.len(), theirs.len());
        for (i, (a, b)) in ours.iter().zip(theirs).enumerate() {
            assert_eq!(a[3], b[3], "corner {i}: sign {a:?} against {b:?}");
            for k in 0..3 {
                assert!(
                    (a[k] - b[k]).abs() <= 1e-5,
                    "corner {i}: {a:?} against the reference's {b:?}"
                );
            }
        }
    }

    /// Keenan Crane's Spot (UVs with seams, generated normals), as the cooker processes it.
    #[test]
    fn matches_the_reference_crate_on_a_real_model() {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/third_party/classic/spot.obj");
        let src = crate::import::import(&path).expect("spot.obj imports");
        let needs = [crate::mesh::MaterialNeeds {
            tangents: true,
            ..crate::mesh::MaterialNeeds::OPAQUE
        }];
        let p = crate::mesh::process(
            &src,
            &vec![0; src.triangle_count()],
            &needs,
            &crate::mesh::MeshSettings::default(),
        );
        let corner = |i: &u32| p.vertices.get(*i as usize);
        let positions: Vec<[f32; 3]> = p.indices.iter().map(|i| corner(i).position).collect();
        let normals: Vec<[f32; 3]> = p.indices.iter().map(|i| corner(i).normal).collect();
        let uvs: Vec<[f32; 2]> = p.indices.iter().map(|i| corner(i).uv).collect();
        assert!(positions.len() > 15_000, "{} corners", positions.len());
        let c = CornerArrays {
            positions: &positions,
            normals: &normals,
            uvs: &uvs,
        };
        let ours = generate(&c);
        assert_close(&ours, &reference(&c));
        // The reference's unsorted last edge run changes nothing on this model either.
        assert_close(&ours, &reference_as_is(&c));
        // Seams split vertices, so tangents are not all alike.
        assert!(ours.iter().any(|t| t[0] < 0.5));
    }

    #[test]
    fn quad_with_mirrored_half() {
        // Two triangles sharing an edge; the second's UVs mirrored, so it flips orientation.
        let positions = vec![
            [0., 0., 0.],
            [1., 0., 0.],
            [0., 1., 0.],
            [0., 1., 0.],
            [1., 0., 0.],
            [1., 1., 0.],
        ];
        let normals = vec![[0., 0., 1.]; 6];
        let uvs = vec![[0., 0.], [1., 0.], [0., 1.], [0., 1.], [1., 0.], [0., 0.]];
        let c = CornerArrays {
            positions: &positions,
            normals: &normals,
            uvs: &uvs,
        };
        let ours = generate(&c);
        assert_close(&ours, &reference(&c));
        assert_eq!(ours[0], [1.0, 0.0, 0.0, 1.0]);
    }

    /// Small meshes drawn from few positions, normals and UVs, so that vertices are shared,
    /// edges carry one, two or more triangles in either direction, texture areas vanish,
    /// mirror or repeat, and some triangles are degenerate.
    fn small_mesh() -> impl Strategy<Value = Owned> {
        // A corner takes its position's usual normal and UV most of the time (so edges are
        // shared), another one otherwise (seams, hard edges, mirrored or collapsed UVs).
        let corner = (0usize..6, 0usize..12);
        prop::collection::vec(prop::array::uniform3(corner), 1..32).prop_map(|tris| {
            let ps = [
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [1.0, 1.0, 0.2],
                [0.5, 0.5, 1.0],
                [-1.0, 0.3, 0.1],
            ];
            let usual_n = [0, 1, 0, 2, 1, 0];
            let usual_t = [0, 1, 2, 3, 4, 1];
            let ns = [[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.0, -0.6, 0.8]];
            let ts = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.0]];
            let mut p = Vec::new();
            let mut n = Vec::new();
            let mut t = Vec::new();
            for tri in tris {
                for (a, v) in tri {
                    p.push(ps[a]);
                    let (ni, ti) = if v < 8 {
                        (usual_n[a], usual_t[a])
                    } else {
                        ((a + v) % 3, (a + v) % 5)
                    };
                    n.push(ns[ni]);
                    t.push(ts[ti]);
                }
            }
            Owned(p, n, t)
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]
        #[test]
        fn matches_the_reference_on_awkward_meshes(mesh in small_mesh()) {
            let c = mesh.as_arrays();
            let ours = generate(&c);
            let theirs = reference(&c);
            for (a, b) in ours.iter().zip(&theirs) {
                prop_assert_eq!(a.map(f32::to_bits), b.map(f32::to_bits));
            }
        }
    }

    /// A disc of 256 triangles fanned from its centre, its centre shared by all of them: with
    /// a planar UV map (one group, every member alike: the grid finds no opposite pair), and
    /// with one that wraps twice round the centre (`z²`, each rim point's opposite exactly
    /// its negation with the same UV): tangents of opposite triangles are exact opposites in
    /// one group, the grid finds them, and sub-groups are made. The reference's bits either way.
    #[test]
    fn a_disc_fanned_from_its_centre_matches_the_reference() {
        let n = 256usize;
        let half: Vec<[f32; 2]> = (0..n / 2)
            .map(|k| {
                let a = std::f32::consts::TAU * k as f32 / n as f32;
                [a.cos(), a.sin()]
            })
            .collect();
        let rim = |k: usize| {
            let [x, y] = half[k % (n / 2)];
            if k % n < n / 2 { [x, y] } else { [-x, -y] }
        };
        for wrapped in [false, true] {
            let (mut p, mut nm, mut t) = (Vec::new(), Vec::new(), Vec::new());
            for k in 0..n {
                for [x, y] in [[0.0, 0.0], rim(k), rim(k + 1)] {
                    p.push([x, y, 0.0]);
                    nm.push([0.0, 0.0, 1.0]);
                    t.push(if wrapped {
                        [0.5 + 0.25 * (x * x - y * y), 0.5 + 0.25 * (2.0 * x * y)]
                    } else {
                        [0.5 + 0.5 * x, 0.5 + 0.5 * y]
                    });
                }
            }
            let mesh = Owned(p, nm, t);
            let c = mesh.as_arrays();
            let ours = generate(&c);
            for (i, (a, b)) in ours.iter().zip(&reference(&c)).enumerate() {
                assert_eq!(
                    a.map(f32::to_bits),
                    b.map(f32::to_bits),
                    "wrapped {wrapped}, corner {i}: {a:?} against {b:?}"
                );
            }
            // The centre's corners: one tangent, or, wrapped, sub-groups of their own.
            let centre: std::collections::BTreeSet<[u32; 4]> =
                (0..n).map(|k| ours[3 * k].map(f32::to_bits)).collect();
            assert_eq!(centre.len() > 1, wrapped, "{} tangents", centre.len());
        }
    }

    /// The grid search for a pair of (nearly) opposite vectors gives the pairwise answer: unit
    /// vectors spread over the sphere or bunched, some with the exact opposite of another or
    /// one a hair off it (1e-7 to 1e-2), some left out, a few not unit or not finite.
    #[test]
    fn the_opposite_pair_search_agrees_with_every_pair_compared() {
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut found, mut cases) = (0, 0);
        for case in 0..400 {
            let k = 64 + (next() * 200.0) as usize;
            let spread = if case % 2 == 0 { 1.0 } else { 0.05 };
            let mut v: Vec<Vec3> = (0..k)
                .map(|_| {
                    let r = Vec3::new(
                        1.0 + spread * (next() - 0.5),
                        spread * (next() - 0.5),
                        spread * (next() - 0.5),
                    );
                    normalize(r)
                })
                .collect();
            let skip: Vec<bool> = (0..k).map(|_| next() < 0.05).collect();
            match case % 5 {
                1 => v[k - 1] = -v[0],
                2 => {
                    let hair = 10f32.powf(-7.0 + 5.0 * next());
                    v[k - 1] = normalize(-v[1] + Vec3::new(0.0, hair, -hair));
                }
                3 if case % 3 == 0 => v[2] = Vec3::new(f32::NAN, 0.0, 0.0),
                3 => v[2] *= 1.5,
                _ => {}
            }
            let pairwise = (0..k).any(|a| {
                (a + 1..k).any(|b| !skip[a] && !skip[b] && not_above_minus_one(v[a], v[b]))
            });
            assert_eq!(
                some_pair_not_above_minus_one(&v, &skip),
                pairwise,
                "case {case}"
            );
            found += usize::from(pairwise);
            cases += 1;
        }
        // Both answers are tried.
        assert!(found > 40 && found < cases - 40, "{found} of {cases}");
    }
}
