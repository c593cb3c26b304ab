//! Tangent-space normal maps: decoding supplied maps, filtering with renormalization, and
//! deriving one from a window design.

use image::DynamicImage;
use rayon::prelude::*;

use crate::TextureError;
use crate::mips::{MipChain, check_size};
use crate::pixels::{to_linear, to_unorm_rgb};
use crate::resample::{MipFilter, half, next_level, walk_chain};
use crate::srgb::{linear_to_srgb, unorm8};

/// How a supplied normal map encodes the vector.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum NormalEncoding {
    /// x, y, z in red, green, blue (`v = n·0.5 + 0.5`).
    #[default]
    Rgb,
    /// x, y in red and green; z reconstructed as `sqrt(1 - x² - y²)` (blue ignored).
    Rg,
}

/// Direction of the tangent-space y axis in the green channel.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum GreenAxis {
    /// Green points up the texture (+v towards the image's top row): OpenGL, Blender.
    #[default]
    OpenGl,
    /// Green points down: DirectX, Unreal. Flipped on import.
    DirectX,
}

/// The vector used where filtering leaves no direction (opposite normals cancelled) or a texel
/// encodes none: the unperturbed surface normal.
pub const FALLBACK_NORMAL: [f32; 3] = [0.0, 0.0, 1.0];

/// Vectors shorter than this before renormalization fall back to [`FALLBACK_NORMAL`].
const MIN_LENGTH: f32 = 1e-6;

#[inline]
fn normalize(v: [f32; 4]) -> [f32; 4] {
    let l2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
    let l = l2.sqrt();
    if l.is_finite() && l > MIN_LENGTH {
        [v[0] / l, v[1] / l, v[2] / l, 0.0]
    } else {
        [
            FALLBACK_NORMAL[0],
            FALLBACK_NORMAL[1],
            FALLBACK_NORMAL[2],
            0.0,
        ]
    }
}

/// Decodes a supplied normal map to unit vectors in the OpenGL convention.
pub fn decode_normals(
    img: &DynamicImage,
    encoding: NormalEncoding,
    green: GreenAxis,
) -> Vec<[f32; 4]> {
    decode_scaled_normals(img, encoding, green, 1.0)
}

/// [`decode_normals`] with x and y scaled by `strength` before renormalizing, as glTF's
/// `normalTexture.scale` and an MTL bump statement's `-bm` ask. At 1 the bits are
/// [`decode_normals`]'s.
fn decode_scaled_normals(
    img: &DynamicImage,
    encoding: NormalEncoding,
    green: GreenAxis,
    strength: f32,
) -> Vec<[f32; 4]> {
    scaled_normals(to_unorm_rgb(img), encoding, green, strength)
}

/// [`decode_scaled_normals`] of texels already decoded to unorm RGB.
fn scaled_normals(
    rgb: Vec<[f32; 3]>,
    encoding: NormalEncoding,
    green: GreenAxis,
    strength: f32,
) -> Vec<[f32; 4]> {
    let flip = if green == GreenAxis::DirectX {
        -1.0
    } else {
        1.0
    };
    rgb.into_par_iter()
        .map(|v| {
            let x = v[0] * 2.0 - 1.0;
            let y = (v[1] * 2.0 - 1.0) * flip;
            let z = match encoding {
                NormalEncoding::Rgb => v[2] * 2.0 - 1.0,
                NormalEncoding::Rg => (1.0 - x * x - y * y).max(0.0).sqrt(),
            };
            if strength == 1.0 {
                normalize([x, y, z, 0.0])
            } else {
                normalize([x * strength, y * strength, z, 0.0])
            }
        })
        .collect()
}

/// What a supplied normal map was found to hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SuppliedNormals {
    /// Tangent-space vectors.
    Vectors,
    /// Grey: a height (bump) map, as older exporters write `map_Bump`; its normals were
    /// derived with the full grey range `depth` texels deep ([`BUMP_DEPTH`]).
    Heights { depth: f32 },
    /// Given as RGB, but its blue is near zero throughout: a two-channel (`rg`) map saved as
    /// RGB, read as one (z rebuilt from x and y).
    RgInRgb,
    /// Read as vectors, but `share` of its texels (over [`UNLIKE_SHARE`]) encode none of
    /// about unit length, or one pointing into the surface: most likely a colour image named
    /// as the normal map, whose cooked normals are noise.
    Unlike { share: f64 },
}

/// The share of texels that are no tangent-space normal above which a map is said to be
/// [`SuppliedNormals::Unlike`] one. Normal maps from baking tools, also after JPEG, stay well
/// under it (their vectors' lengths within a few percent of 1, blue above 0.5).
pub const UNLIKE_SHARE: f64 = 0.25;

/// The share of RGB texels whose vector (2c − 1) is not of about unit length (0.75 to 1.25),
/// or points into the surface (z < −0.1).
fn not_normals_share(rgb: &[[f32; 3]]) -> f64 {
    let off = rgb
        .par_iter()
        .filter(|t| {
            let [x, y, z] = t.map(|c| c * 2.0 - 1.0);
            let len2 = x * x + y * y + z * z;
            !(0.5625..=1.5625).contains(&len2) || z < -0.1
        })
        .count();
    off as f64 / rgb.len().max(1) as f64
}

/// Whether an RGB normal map's blue is under 64 (z below −0.5) in at least 99 % of its texels:
/// no tangent-space normal points that far into the surface, so it is x and y alone, as a
/// two-channel map saved as RGB has them. Read as RGB its normals pointed backwards.
fn blue_is_empty(rgb: &[[f32; 3]]) -> bool {
    let low = rgb.par_iter().filter(|t| t[2] < 64.0 / 255.0).count();
    low as f64 >= 0.99 * rgb.len().max(1) as f64
}

/// The depth a height map's full range spans at strength 1, as a fraction of its longer side:
/// 4 texels on a 1024² map, so a bump that rises over a few texels tilts the surface by tens
/// of degrees, as a brick's mortar should. Bump maps carry no unit; `-bm` (or glTF's scale)
/// multiplies it.
pub const BUMP_DEPTH: f32 = 1.0 / 256.0;

/// Texels whose channels differ by at most this (of 255) count as grey: JPEG's chroma noise
/// on a grey image stays within it, while a normal map's blue sits far above its red and
/// green (a flat texel is (128, 128, 255)).
const GREY_SPREAD: u8 = 8;

/// True when at least 99 % of the texels are grey: a height map. No normal map is grey,
/// since a grey texel would encode a vector along (1, 1, 1).
pub fn is_height_map(img: &DynamicImage) -> bool {
    let grey_share = |bytes: &[u8], channels: usize| {
        let grey = bytes
            .par_chunks_exact(channels)
            .filter(|t| {
                let (lo, hi) = (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]));
                hi - lo <= GREY_SPREAD
            })
            .count();
        grey as f64 / (bytes.len() / channels).max(1) as f64
    };
    let share = match img {
        DynamicImage::ImageLuma8(_)
        | DynamicImage::ImageLumaA8(_)
        | DynamicImage::ImageLuma16(_)
        | DynamicImage::ImageLumaA16(_) => 1.0,
        DynamicImage::ImageRgb8(b) => grey_share(b.as_raw(), 3),
        DynamicImage::ImageRgba8(b) => grey_share(b.as_raw(), 4),
        other => grey_share(other.to_rgb8().as_raw(), 3),
    };
    share >= 0.99
}

/// Cooks a map given as a material's normal map, whatever it holds: tangent-space vectors
/// (x and y scaled by `strength`), or, where it is grey ([`is_height_map`]), heights whose
/// normals are derived by central differences, the full range spanning [`BUMP_DEPTH`] of the
/// longer side times `strength`. Stored like [`normal_mips`].
pub fn supplied_normal_mips(
    img: &DynamicImage,
    encoding: NormalEncoding,
    green: GreenAxis,
    strength: f32,
) -> Result<(MipChain, SuppliedNormals), TextureError> {
    let (w, h) = (img.width(), img.height());
    check_size(w, h)?;
    // Two-channel maps are often saved as grey with alpha: given as `rg`, x is the grey and y
    // the alpha, and the image is no height map (it was read as one, its normals flat).
    if encoding == NormalEncoding::Rg
        && matches!(img.color(), image::ColorType::La8 | image::ColorType::La16)
    {
        let unorm = |v: u16| v as f32 / 65535.0;
        let rg = (img.to_luma_alpha16().pixels())
            .map(|p| [unorm(p[0]), unorm(p[1]), 0.0])
            .collect();
        let normals = scaled_normals(rg, encoding, green, strength);
        return Ok((chain(normals, w, h), SuppliedNormals::Vectors));
    }
    if !is_height_map(img) {
        // Decoded once, for the blue test and the normals both.
        let rgb = to_unorm_rgb(img);
        if encoding == NormalEncoding::Rgb && blue_is_empty(&rgb) {
            let normals = scaled_normals(rgb, NormalEncoding::Rg, green, strength);
            return Ok((chain(normals, w, h), SuppliedNormals::RgInRgb));
        }
        let held = match encoding {
            NormalEncoding::Rgb => match not_normals_share(&rgb) {
                share if share > UNLIKE_SHARE => SuppliedNormals::Unlike { share },
                _ => SuppliedNormals::Vectors,
            },
            NormalEncoding::Rg => SuppliedNormals::Vectors,
        };
        let normals = scaled_normals(rgb, encoding, green, strength);
        return Ok((chain(normals, w, h), held));
    }
    let depth = strength * w.max(h) as f32 * BUMP_DEPTH;
    let height: Vec<f32> = to_unorm_rgb(img)
        .into_par_iter()
        .map(|t| (t[0] + t[1] + t[2]) / 3.0 * depth)
        .collect();
    let normals = height_to_normals(&height, w, h);
    drop(height);
    Ok((chain(normals, w, h), SuppliedNormals::Heights { depth }))
}

/// Filters unit vectors down a full chain (box, polyphase for odd sizes) and renormalizes every
/// level. Level `i` holds unit vectors (xyz; w unused) before quantization.
pub fn normal_levels(level0: Vec<[f32; 4]>, w: u32, h: u32) -> Vec<Vec<[f32; 4]>> {
    let mut levels = Vec::new();
    walk_chain(level0, w, h, next_normals, |l| levels.push(l));
    levels
}

/// Through `next_level`, so an even-sized level is reduced in one pass, without the half-size
/// intermediate (5.6 MB for the 1024² rose's first step). A zero component sums to +0 there
/// and may stay -0 in one pass, which the renormalization and the 8-bit encoding both map to
/// the same bits.
fn next_normals(level: &[[f32; 4]], w: u32, h: u32) -> Vec<[f32; 4]> {
    next_level(level, w, h, MipFilter::Box, |t| t, normalize)
}

fn encode_normals(level: &[[f32; 4]]) -> Vec<u8> {
    level
        .par_iter()
        .flat_map_iter(|n| {
            [
                unorm8(n[0] * 0.5 + 0.5),
                unorm8(n[1] * 0.5 + 0.5),
                unorm8(n[2] * 0.5 + 0.5),
                255,
            ]
        })
        .collect()
}

fn chain(level0: Vec<[f32; 4]>, w: u32, h: u32) -> MipChain {
    let mut levels = Vec::new();
    walk_chain(level0, w, h, next_normals, |l| {
        levels.push(encode_normals(&l))
    });
    MipChain {
        width: w,
        height: h,
        levels,
    }
}

/// Cooks a supplied normal map. Stored linearly (sample through a non-sRGB view) as
/// `rgb = n·0.5 + 0.5` with z in blue whatever the source encoding, OpenGL green convention,
/// alpha 255.
pub fn normal_mips(
    img: &DynamicImage,
    encoding: NormalEncoding,
    green: GreenAxis,
) -> Result<MipChain, TextureError> {
    check_size(img.width(), img.height())?;
    Ok(chain(
        decode_normals(img, encoding, green),
        img.width(),
        img.height(),
    ))
}

// ---- Deriving a normal map from a design ----

/// splitmix64 finalizer: a well-mixed hash of the lattice point, so noise needs no state and
/// no generator order (and so cannot depend on the thread count).
fn hash(seed: u64, x: i64, y: i64) -> f32 {
    let mut z = seed
        ^ (x as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
        ^ (y as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 40) as f32 / (1u64 << 23) as f32 - 1.0
}

/// Smooth value noise in [-1, 1] with lattice spacing `cell` texels.
fn value_noise(seed: u64, x: f32, y: f32, cell: f32) -> f32 {
    let (fx, fy) = (x / cell, y / cell);
    let (ix, iy) = (fx.floor(), fy.floor());
    let (tx, ty) = (fx - ix, fy - iy);
    // Quintic fade: continuous slope, so the relief has no creases at cell borders.
    let fade = |t: f32| t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
    let (sx, sy) = (fade(tx), fade(ty));
    let (ix, iy) = (ix as i64, iy as i64);
    let v00 = hash(seed, ix, iy);
    let v10 = hash(seed, ix + 1, iy);
    let v01 = hash(seed, ix, iy + 1);
    let v11 = hash(seed, ix + 1, iy + 1);
    let a = v00 + (v10 - v00) * sx;
    let b = v01 + (v11 - v01) * sx;
    a + (b - a) * sy
}

fn smoothstep(e0: f32, e1: f32, x: f32) -> f32 {
    let t = ((x - e0) / (e1 - e0)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// How strongly a texel looks like lead came: dark and unsaturated (or transparent: no glass).
fn lead_score(t: [f32; 4]) -> f32 {
    let lum = 0.2126 * t[0] + 0.7152 * t[1] + 0.0722 * t[2];
    let lightness = linear_to_srgb(lum as f64) as f32;
    let enc = |v: f32| linear_to_srgb(v as f64) as f32;
    let (r, g, b) = (enc(t[0]), enc(t[1]), enc(t[2]));
    let max = r.max(g).max(b);
    let min = r.min(g).min(b);
    let saturation = if max > 1e-6 { (max - min) / max } else { 0.0 };
    let lead = smoothstep(0.35, 0.15, lightness) * smoothstep(0.5, 0.25, saturation);
    let no_glass = smoothstep(0.5, 0.1, t[3]);
    lead.max(no_glass)
}

/// [`lead_score`] of 8-bit sRGB texels, remembered in a small direct-mapped table by colour.
struct ScoreMemo {
    slots: Vec<Option<(u32, f32)>>,
}

impl Default for ScoreMemo {
    fn default() -> Self {
        Self {
            slots: vec![None; 1 << 12],
        }
    }
}

impl ScoreMemo {
    fn score(&mut self, rgba: [u8; 4]) -> f32 {
        let key = u32::from_le_bytes(rgba);
        let slot = (key.wrapping_mul(0x9E37_79B1) >> 20) as usize;
        match self.slots[slot] {
            Some((k, score)) if k == key => score,
            _ => {
                let score = lead_score(crate::pixels::texel8(rgba));
                self.slots[slot] = Some((key, score));
                score
            }
        }
    }
}

/// Height field of a design, in texels: lead came raised with a rounded profile, glass with a
/// low hammered relief.
pub fn design_height(design: &DynamicImage, seed: u64) -> Result<Vec<f32>, TextureError> {
    let (w, h) = (design.width(), design.height());
    check_size(w, h)?;
    let mask: Vec<f32> = match crate::pixels::rgba8_bytes(design) {
        // A design has few colours (flat panes of glass), and the score is a function of a
        // texel's four bytes: remembered per colour, it is computed once a pane, not four
        // powers a texel. The texels are `to_linear`'s, read from the bytes without its copy.
        Some(bytes) => bytes
            .par_chunks_exact(4)
            .map_init(ScoreMemo::default, |memo, b| {
                memo.score([b[0], b[1], b[2], b[3]])
            })
            .collect(),
        None => to_linear(design, true)
            .par_iter()
            .map(|&t| lead_score(t))
            .collect(),
    };
    let side = w.min(h) as f32;
    // The came's rounded profile: the lead mask softened over about a texel of a 512² design.
    let came_sigma = (side / 400.0).clamp(0.75, 4.0);
    let came_height = 2.0 * came_sigma;
    let soft = blur_plane(&mask, w, h, came_sigma)?;
    // Hammer dimples a few percent of the window across; two octaves, slopes about 0.1.
    let cell = (side / 24.0).clamp(3.0, 64.0);
    let glass_amp = 0.05 * cell;
    let wu = w as usize;
    Ok((0..wu * h as usize)
        .into_par_iter()
        .map(|i| {
            let (x, y) = ((i % wu) as f32, (i / wu) as f32);
            let m = mask[i];
            let relief =
                value_noise(seed, x, y, cell) + 0.5 * value_noise(seed ^ 0x5EED, x, y, cell * 0.5);
            // The blurred mask can exceed the hard mask's support; clamp keeps it a height.
            came_height * soft[i].clamp(0.0, 1.0) + glass_amp * relief * (1.0 - m)
        })
        .collect())
}

/// The blur of one channel (`w x h`, zero border) with the bits [`crate::blur::blur_linear`]
/// gives it as the first channel of four (σ below the decimated method's, so the blur is
/// direct). The blur filters four channels at once: here they carry four bands of rows, each
/// with the rows the kernel reaches beyond it, so the work and memory are a quarter of a
/// texel a channel and three zero channels. Every output is the same sum of the same taps in
/// the same order as in the whole image: a band's rows outside the image are zero, as the
/// whole image's border is.
fn blur_plane(plane: &[f32], w: u32, h: u32, sigma: f32) -> Result<Vec<f32>, TextureError> {
    let method = crate::BlurMethod::Auto;
    let r = crate::blur::kernel_radius(sigma as f64);
    let (wu, hu) = (w as usize, h as usize);
    if method.resolve_sized(sigma, w, h) != crate::BlurMethod::Direct || hu <= r {
        // Bands would change the kernel (cut at the image's height) or the method.
        let quads: Vec<[f32; 4]> = plane.iter().map(|&m| [m, 0.0, 0.0, 0.0]).collect();
        let soft = crate::blur::blur_linear(&quads, w, h, sigma, method)?;
        return Ok(soft.into_iter().map(|t| t[0]).collect());
    }
    let band = hu.div_ceil(4);
    let rows = band + 2 * r;
    // Row `y` of band `b` is image row `b·band + y - r`.
    let source = |b: usize, y: usize| (b * band + y).checked_sub(r).filter(|&row| row < hu);
    let mut bands = vec![[0.0f32; 4]; wu * rows];
    bands.par_chunks_mut(wu).enumerate().for_each(|(y, out)| {
        for b in 0..4 {
            if let Some(row) = source(b, y) {
                for (o, &m) in out.iter_mut().zip(&plane[row * wu..(row + 1) * wu]) {
                    o[b] = m;
                }
            }
        }
    });
    let soft = crate::blur::blur_linear(&bands, w, rows as u32, sigma, method)?;
    drop(bands);
    let mut out = vec![0.0f32; wu * hu];
    out.par_chunks_mut(wu).enumerate().for_each(|(row, o)| {
        let (b, y) = (row / band, row % band + r);
        for (o, t) in o.iter_mut().zip(&soft[y * wu..(y + 1) * wu]) {
            *o = t[b];
        }
    });
    Ok(out)
}

/// Tangent-space normals (OpenGL convention) of a height field by central differences,
/// one-sided at the edges.
pub fn height_to_normals(height: &[f32], w: u32, h: u32) -> Vec<[f32; 4]> {
    height_to_normals_padded(height, w, h, w, h)
}

/// [`height_to_normals`] grown to `pw x ph` by repeating its last column and row, as
/// `pixels::pad_texels` grows a level, written once: the 1024² rose's normals and their
/// padded copy were 11 MB each, side by side at the default scene's peak.
fn height_to_normals_padded(height: &[f32], w: u32, h: u32, pw: u32, ph: u32) -> Vec<[f32; 4]> {
    let ph = (ph as usize).max(h as usize);
    normal_rows(height, w, h, pw, 0..ph)
}

/// Rows `rows` of [`height_to_normals_padded`]'s level, `pw` texels each.
fn normal_rows(
    height: &[f32],
    w: u32,
    h: u32,
    pw: u32,
    rows: std::ops::Range<usize>,
) -> Vec<[f32; 4]> {
    let (w, h) = (w as usize, h as usize);
    let pw = (pw as usize).max(w);
    let normal = |x: usize, y: usize| {
        let at = |x: usize, y: usize| height[y * w + x];
        let (x0, x1) = (x.saturating_sub(1), (x + 1).min(w - 1));
        let (y0, y1) = (y.saturating_sub(1), (y + 1).min(h - 1));
        let dx = if x1 > x0 {
            (at(x1, y) - at(x0, y)) / (x1 - x0) as f32
        } else {
            0.0
        };
        // Rows run down the image and +y of the tangent frame runs up it.
        let dy_down = if y1 > y0 {
            (at(x, y1) - at(x, y0)) / (y1 - y0) as f32
        } else {
            0.0
        };
        normalize([-dx, dy_down, 1.0, 0.0])
    };
    let first = rows.start;
    let mut out = vec![[0.0; 4]; pw * rows.len()];
    out.par_chunks_mut(pw).enumerate().for_each(|(y, row)| {
        for (x, t) in row.iter_mut().enumerate() {
            *t = normal(x.min(w - 1), (first + y).min(h - 1));
        }
    });
    out
}

/// Rows of level 0 made, encoded and reduced to level 1 at a time by
/// [`derive_normal_map_padded`] (even, so each band holds whole 2x2 blocks).
const NORMAL_BAND_ROWS: usize = 64;

/// Derives a glass normal map from a design: lead came (dark, low-saturation texels, and
/// transparent ones) raised with a rounded profile, glass with a subtle hammered relief from
/// seeded value noise. Deterministic for a given image and seed, on any number of threads.
/// Stored like [`normal_mips`].
pub fn derive_normal_map(design: &DynamicImage, seed: u64) -> Result<MipChain, TextureError> {
    derive_normal_map_padded(design, seed, 1.0, design.width(), design.height())
}

/// As [`derive_normal_map`], its relief's height times `strength` (a negative one sinks the
/// came), with level 0 grown to `pw x ph` by repeating its last column and row before the
/// lower levels are made from it (`crate::bc::block_padded_size`).
pub fn derive_normal_map_padded(
    design: &DynamicImage,
    seed: u64,
    strength: f32,
    pw: u32,
    ph: u32,
) -> Result<MipChain, TextureError> {
    let (w, h) = (design.width(), design.height());
    let mut height = design_height(design, seed)?;
    if strength != 1.0 {
        height.par_iter_mut().for_each(|v| *v *= strength);
    }
    let (pw, ph) = (pw.max(w), ph.max(h));
    if !(pw.is_multiple_of(2) && ph.is_multiple_of(2)) {
        let level0 = height_to_normals_padded(&height, w, h, pw, ph);
        drop(height);
        return Ok(chain(level0, pw, ph));
    }
    // Level 0 a band of rows at a time, encoded and reduced as `chain` would (an even
    // level's box reduction works block by block, so a band of even height reduces alone),
    // so its f32 normals (16 bytes a texel, 11 MB for the 687x1024 border design) are never
    // held whole.
    let (pw_, ph_) = (pw as usize, ph as usize);
    let mut level0 = Vec::with_capacity(pw_ * ph_ * 4);
    let mut level1 = Vec::with_capacity(pw_ / 2 * (ph_ / 2));
    for y0 in (0..ph_).step_by(NORMAL_BAND_ROWS) {
        let rows = y0..(y0 + NORMAL_BAND_ROWS).min(ph_);
        let band_height = rows.len() as u32;
        let band = normal_rows(&height, w, h, pw, rows);
        level0.extend(encode_normals(&band));
        level1.extend(next_normals(&band, pw, band_height));
    }
    drop(height);
    let mut rest = chain(level1, half(pw), half(ph));
    rest.levels.insert(0, level0);
    Ok(MipChain {
        width: pw,
        height: ph,
        levels: rest.levels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::Rng;

    /// Grey (exactly, or within JPEG's chroma noise, in 99 % of texels) is a height map; a
    /// normal map, flat or tilted, never is, nor is a colour design.
    #[test]
    fn grey_maps_are_heights_and_normal_maps_are_not() {
        let mut rng = Rng(7);
        let img = |f: &mut dyn FnMut(usize) -> [u8; 4]| {
            let bytes: Vec<u8> = (0..64 * 64).flat_map(&mut *f).collect();
            DynamicImage::ImageRgba8(image::RgbaImage::from_raw(64, 64, bytes).unwrap())
        };
        let grey = img(&mut |_| {
            let v = rng.byte();
            let n = |r: &mut Rng| v.saturating_add(r.byte() % 5);
            [n(&mut rng), n(&mut rng), n(&mut rng), 255]
        });
        assert!(is_height_map(&grey));
        let luma =
            DynamicImage::ImageLuma16(image::ImageBuffer::from_pixel(8, 8, image::Luma([300u16])));
        assert!(is_height_map(&luma));
        let flat = img(&mut |_| [128, 128, 255, 255]);
        assert!(!is_height_map(&flat));
        let tilted = img(&mut |i| [(i % 256) as u8, 100, 230, 255]);
        assert!(!is_height_map(&tilted));
        // 2 % colour texels in a grey map: not grey enough to be sure.
        let spotted = img(&mut |i| {
            if i % 50 == 0 {
                [200, 10, 10, 255]
            } else {
                [90; 4]
            }
        });
        assert!(!is_height_map(&spotted));
    }

    /// Strength 1 gives [`normal_mips`]'s bits; 0 flattens every vector.
    #[test]
    fn strength_scales_the_tilt_of_vectors() {
        let mut rng = Rng(3);
        let bytes: Vec<u8> = (0..32 * 32)
            .flat_map(|_| [rng.byte(), rng.byte(), 128 + rng.byte() / 2, 255])
            .collect();
        let img = DynamicImage::ImageRgba8(image::RgbaImage::from_raw(32, 32, bytes).unwrap());
        let (enc, green) = (NormalEncoding::Rgb, GreenAxis::OpenGl);
        let (one, held) = supplied_normal_mips(&img, enc, green, 1.0).unwrap();
        // Random bytes are no normal map, and said to be unlike one, but read as vectors.
        assert!(matches!(held, SuppliedNormals::Unlike { .. }), "{held:?}");
        assert_eq!(one.levels, normal_mips(&img, enc, green).unwrap().levels);
        let (flat, _) = supplied_normal_mips(&img, enc, green, 0.0).unwrap();
        assert!(flat.levels[0].chunks(4).all(|t| t[..3] == [128, 128, 255]));
    }

    /// A derived normal map made in bands is the whole-level chain's, bit for bit: sizes
    /// padded to even ones, bands cut short at the bottom, one band, and a 2-row level.
    #[test]
    fn banded_derived_normals_are_the_whole_chain() {
        let mut rng = Rng(5);
        for (w, h, pw, ph) in [
            (37u32, 61u32, 40u32, 64u32),
            (64, 64, 64, 64),
            (23, 150, 24, 152),
            (50, 2, 52, 2),
            (9, 131, 12, 132),
        ] {
            let img = image::RgbaImage::from_fn(w, h, |_, _| {
                image::Rgba([rng.byte(), rng.byte(), rng.byte(), rng.byte()])
            });
            let design = DynamicImage::ImageRgba8(img);
            let banded = derive_normal_map_padded(&design, 7, 1.0, pw, ph).unwrap();
            let height = design_height(&design, 7).unwrap();
            let whole = chain(height_to_normals_padded(&height, w, h, pw, ph), pw, ph);
            assert_eq!((banded.width, banded.height), (whole.width, whole.height));
            assert!(banded.levels == whole.levels, "{w}x{h} padded to {pw}x{ph}");
        }
    }

    /// Bands of rows in the four channels give the bits of the plane blurred as the first
    /// channel of four: heights not a multiple of four, a plane too short for bands, and the
    /// came's whole range of σ.
    #[test]
    fn banded_blur_is_the_first_channel_of_the_whole_one() {
        let mut rng = Rng(11);
        for (w, h) in [(37u32, 61u32), (64, 64), (23, 5), (50, 2), (9, 131)] {
            let plane: Vec<f32> = (0..w * h)
                .map(|_| match rng.byte() % 3 {
                    0 => 0.0,
                    1 => 1.0,
                    _ => rng.byte() as f32 / 255.0,
                })
                .collect();
            let quads: Vec<[f32; 4]> = plane.iter().map(|&m| [m, 0.0, 0.0, 0.0]).collect();
            for sigma in [0.75f32, 1.6, 2.3, 4.0] {
                let whole =
                    crate::blur::blur_linear(&quads, w, h, sigma, crate::BlurMethod::Auto).unwrap();
                let banded = blur_plane(&plane, w, h, sigma).unwrap();
                let bits =
                    |v: &mut dyn Iterator<Item = f32>| v.map(f32::to_bits).collect::<Vec<_>>();
                assert!(
                    bits(&mut whole.iter().map(|t| t[0])) == bits(&mut banded.iter().copied()),
                    "{w}x{h} sigma {sigma}"
                );
            }
        }
    }

    /// An `rg` map saved as grey with alpha holds x in the grey and y in the alpha: the same
    /// normals as the RGB image (x, y, 0); as a plain grey image it is a height map.
    #[test]
    fn an_rg_map_in_grey_and_alpha_is_read_as_x_and_y() {
        let la = DynamicImage::ImageLumaA8(image::ImageBuffer::from_fn(6, 4, |x, y| {
            image::LumaA([(150 + 10 * x) as u8, (90 + 20 * y) as u8])
        }));
        let rgb = DynamicImage::ImageRgb8(image::ImageBuffer::from_fn(6, 4, |x, y| {
            image::Rgb([(150 + 10 * x) as u8, (90 + 20 * y) as u8, 0])
        }));
        let (a, held) =
            supplied_normal_mips(&la, NormalEncoding::Rg, GreenAxis::OpenGl, 1.0).unwrap();
        let (b, _) =
            supplied_normal_mips(&rgb, NormalEncoding::Rg, GreenAxis::OpenGl, 1.0).unwrap();
        assert_eq!(held, SuppliedNormals::Vectors);
        assert_eq!(a.levels, b.levels);
        let (_, held) =
            supplied_normal_mips(&la, NormalEncoding::Rgb, GreenAxis::OpenGl, 1.0).unwrap();
        assert!(matches!(held, SuppliedNormals::Heights { .. }));
    }

    /// A colour image named as a normal map is said to be unlike one; a real normal map, also
    /// with its vectors off unit length by 8-bit rounding and JPEG-like noise, is not.
    #[test]
    fn a_colour_image_is_told_from_a_normal_map() {
        let mut rng = Rng(5);
        let bumps = DynamicImage::ImageRgb8(image::ImageBuffer::from_fn(64, 64, |x, y| {
            let (a, b) = ((x as f32 * 0.3).sin() * 0.4, (y as f32 * 0.2).cos() * 0.3);
            let z = (1.0 - a * a - b * b).sqrt();
            let mut noise = |v: f32| (v * 0.5 + 0.5) * 255.0 + (rng.byte() % 9) as f32 - 4.0;
            image::Rgb([noise(a), noise(b), noise(z)].map(|c| c.round().clamp(0.0, 255.0) as u8))
        }));
        let (_, held) =
            supplied_normal_mips(&bumps, NormalEncoding::Rgb, GreenAxis::OpenGl, 1.0).unwrap();
        assert_eq!(held, SuppliedNormals::Vectors);
        // Sandstone: warm browns and greys, light and dark.
        let stone = DynamicImage::ImageRgb8(image::ImageBuffer::from_fn(64, 64, |x, y| {
            let l = 60 + ((x * 7 + y * 3) % 140) as u8;
            image::Rgb([l.saturating_add(40), l.saturating_add(20), l])
        }));
        let (_, held) =
            supplied_normal_mips(&stone, NormalEncoding::Rgb, GreenAxis::OpenGl, 1.0).unwrap();
        assert!(
            matches!(held, SuppliedNormals::Unlike { share } if share > 0.5),
            "{held:?}"
        );
    }

    /// A two-channel map saved as RGB (blue 0) and given as `rgb` is read as `rg`: its normals
    /// pointed into the surface (z = −1 from blue 0).
    #[test]
    fn an_rgb_map_without_blue_is_read_as_rg() {
        let img = DynamicImage::ImageRgb8(image::ImageBuffer::from_fn(6, 4, |x, y| {
            image::Rgb([(120 + 10 * x) as u8, (100 + 20 * y) as u8, 0])
        }));
        let (a, held) =
            supplied_normal_mips(&img, NormalEncoding::Rgb, GreenAxis::OpenGl, 1.0).unwrap();
        let (b, _) =
            supplied_normal_mips(&img, NormalEncoding::Rg, GreenAxis::OpenGl, 1.0).unwrap();
        assert_eq!(held, SuppliedNormals::RgInRgb);
        assert_eq!(a.levels, b.levels);
        // A real RGB map keeps its blue.
        let flat = DynamicImage::ImageRgb8(image::ImageBuffer::from_pixel(
            4,
            4,
            image::Rgb([128, 128, 255]),
        ));
        let (_, held) =
            supplied_normal_mips(&flat, NormalEncoding::Rgb, GreenAxis::OpenGl, 1.0).unwrap();
        assert_eq!(held, SuppliedNormals::Vectors);
    }
}
