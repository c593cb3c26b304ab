//! Stateless seeded hashing: every random choice is a pure function of (seed, indices), so
//! pixels and panes can be computed in any order, on any number of threads, with the same result.

/// SplitMix64's finaliser: a bijective mix with good avalanche.
pub fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Hash of a seed and any number of integers.
pub fn hash(seed: u64, parts: &[i64]) -> u64 {
    parts.iter().fold(mix(seed), |h, &p| mix(h ^ (p as u64)))
}

/// A float in [0, 1).
pub fn unit(seed: u64, parts: &[i64]) -> f64 {
    (hash(seed, parts) >> 11) as f64 / (1u64 << 53) as f64
}

/// A float in [-1, 1).
pub fn signed(seed: u64, parts: &[i64]) -> f64 {
    unit(seed, parts) * 2.0 - 1.0
}
