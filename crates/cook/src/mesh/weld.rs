//! Welding values by their bits: equal values get one id.

/// -0.0 == 0.0 compares equal but has different bits; adding +0.0 maps -0.0 to +0.0.
pub(super) fn plus_zero(v: f32) -> f32 {
    v + 0.0
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
/// An open-addressing table of 4-byte slots (the index of the first occurrence, linear
/// probing, values compared through `values`) rather than a map holding the keys: no key
/// copies, and a probe touches one small slot, which measured about twice as fast as
/// `HashMap<[u32; N], u32>` with FxHash on large grids (the mesh sweep in docs/bench times the
/// whole stage). Slots of 8 bytes with a 32-bit hash fingerprint beside the index, which
/// spared reading a colliding value back, were as fast and took the 819k-triangle grid's
/// two tables, built at once for positions and normals, to 16.8 MB of its cook's peak.
pub(super) fn weld<const N: usize>(values: &[[f32; N]]) -> (Vec<u32>, usize) {
    const EMPTY: u32 = u32::MAX;
    let bits = |v: &[f32; N]| v.map(|c| plus_zero(c).to_bits());
    let size = (values.len() * 2).next_power_of_two().max(16);
    let mask = size - 1;
    // Corners index values with u32, so no index is EMPTY.
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
        let mut slot = hash as usize & mask;
        loop {
            let at = slots[slot];
            if at == EMPTY {
                slots[slot] = i as u32;
                ids.push(next);
                next += 1;
                break;
            }
            if bits(&values[at as usize]) == key {
                ids.push(ids[at as usize]);
                break;
            }
            slot = (slot + 1) & mask;
        }
    }
    (ids, next as usize)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

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
    }
}
