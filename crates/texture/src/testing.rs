//! Deterministic inputs for this crate's tests, benchmarks and examples, and for the bench
//! tool: not part of the API.

/// xorshift64*: reproducible pseudo-random numbers without a dependency.
pub struct Rng(pub u64);

impl Rng {
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }

    pub fn byte(&mut self) -> u8 {
        (self.next_u64() >> 56) as u8
    }
}

/// The blur benchmark's opaque RGBA8 content (`w x h`): flat panes of 61 x 47 texels, dark
/// lead lines 3 texels wide, a little noise.
pub fn opaque_design(w: usize, h: usize) -> Vec<u8> {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    let panes: Vec<[u8; 3]> = (0..64)
        .map(|_| [rng.byte(), rng.byte(), rng.byte()])
        .collect();
    let mut out = vec![255u8; w * h * 4];
    for y in 0..h {
        for x in 0..w {
            let o = &mut out[(y * w + x) * 4..][..3];
            if x % 61 < 3 || y % 47 < 3 {
                o.copy_from_slice(&[10, 10, 12]);
            } else {
                let p = panes[((x / 61) * 7 + (y / 47) * 3) % 64];
                let n = rng.byte() % 4;
                for c in 0..3 {
                    o[c] = p[c].saturating_add(n);
                }
            }
        }
    }
    out
}
