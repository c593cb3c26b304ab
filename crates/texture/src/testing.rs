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

/// The pane grid of [`design`]: panes `width` × `height` texels, lead lines `lead` texels wide
/// along the left and top of each.
#[derive(Clone, Copy, Debug)]
pub struct Panes {
    pub width: usize,
    pub height: usize,
    pub lead: usize,
}

/// A stained-glass-like RGBA8 image (`w x h`): panes of random colour (some very dark, some
/// saturated, some translucent), dark lead lines, a little noise. Hard edges and dark regions
/// are where a blur's or a mip filter's errors show most in sRGB.
pub fn design(w: usize, h: usize, seed: u64, panes: Panes) -> Vec<u8> {
    let mut rng = Rng(seed | 1);
    let colours: Vec<[u8; 4]> = (0..64)
        .map(|i| match i % 4 {
            0 => [rng.byte() / 16, rng.byte() / 16, rng.byte() / 16, 255],
            1 => [rng.byte(), rng.byte(), rng.byte(), 255],
            2 => [
                rng.byte(),
                rng.byte() / 4,
                rng.byte() / 8,
                128 + rng.byte() / 2,
            ],
            _ => [255, 250, rng.byte(), 255],
        })
        .collect();
    let Panes {
        width: pw,
        height: ph,
        lead,
    } = panes;
    let mut out = vec![0u8; w * h * 4];
    for y in 0..h {
        for x in 0..w {
            let p = if x % pw < lead || y % ph < lead {
                [8, 8, 10, 255]
            } else {
                colours[((x / pw) * 7 + (y / ph) * 3) % 64]
            };
            let noise = rng.byte() % 3;
            let o = &mut out[(y * w + x) * 4..][..4];
            for c in 0..3 {
                o[c] = p[c].saturating_add(noise);
            }
            o[3] = p[3];
        }
    }
    out
}

/// RGBA8 `bytes` (`w x h`) inside a frame of `m` transparent texels on each side: what a
/// projector's margin must blur like.
pub fn framed(bytes: &[u8], w: usize, h: usize, m: [usize; 2]) -> Vec<u8> {
    let [mx, my] = m;
    let row = (w + 2 * mx) * 4;
    let mut out = vec![0u8; row * (h + 2 * my)];
    for (y, src) in bytes.chunks_exact(w * 4).enumerate() {
        out[(y + my) * row + mx * 4..][..w * 4].copy_from_slice(src);
    }
    out
}
