//! Conversion of decoded images to straight (non-premultiplied) linear RGBA in f32.

use image::DynamicImage;

use crate::srgb::{decode8, decode16};

/// One texel: linear red, green, blue (straight, not premultiplied) and alpha.
pub type Texel = [f32; 4];

/// Converts any decoded image to straight linear RGBA. `srgb` says whether the colour channels
/// are sRGB-encoded (alpha never is). Grey expands to RGB; missing alpha is opaque. Float images
/// (Radiance HDR) are linear already and are clamped to [0, 1].
pub fn to_linear(img: &DynamicImage, srgb: bool) -> Vec<Texel> {
    let (d8, d16) = if srgb {
        (Some(decode8()), Some(decode16()))
    } else {
        (None, None)
    };
    let c8 = |v: u8| d8.map_or(v as f32 / 255.0, |t| t[v as usize]);
    let c16 = |v: u16| d16.map_or(v as f32 / 65535.0, |t| t[v as usize]);
    let a8 = |v: u8| v as f32 / 255.0;
    let a16 = |v: u16| v as f32 / 65535.0;
    let cf = |v: f32| if v > 0.0 { v.min(1.0) } else { 0.0 };
    match img {
        DynamicImage::ImageLuma8(i) => i.pixels().map(|p| grey(c8(p[0]), 1.0)).collect(),
        DynamicImage::ImageLumaA8(i) => i.pixels().map(|p| grey(c8(p[0]), a8(p[1]))).collect(),
        DynamicImage::ImageRgb8(i) => i
            .pixels()
            .map(|p| [c8(p[0]), c8(p[1]), c8(p[2]), 1.0])
            .collect(),
        DynamicImage::ImageRgba8(i) => i
            .pixels()
            .map(|p| [c8(p[0]), c8(p[1]), c8(p[2]), a8(p[3])])
            .collect(),
        DynamicImage::ImageLuma16(i) => i.pixels().map(|p| grey(c16(p[0]), 1.0)).collect(),
        DynamicImage::ImageLumaA16(i) => i.pixels().map(|p| grey(c16(p[0]), a16(p[1]))).collect(),
        DynamicImage::ImageRgb16(i) => i
            .pixels()
            .map(|p| [c16(p[0]), c16(p[1]), c16(p[2]), 1.0])
            .collect(),
        DynamicImage::ImageRgba16(i) => i
            .pixels()
            .map(|p| [c16(p[0]), c16(p[1]), c16(p[2]), a16(p[3])])
            .collect(),
        DynamicImage::ImageRgb32F(i) => i
            .pixels()
            .map(|p| [cf(p[0]), cf(p[1]), cf(p[2]), 1.0])
            .collect(),
        DynamicImage::ImageRgba32F(i) => i
            .pixels()
            .map(|p| [cf(p[0]), cf(p[1]), cf(p[2]), cf(p[3])])
            .collect(),
        // Formats added to `image` later: go through its own RGBA32F conversion.
        other => other
            .to_rgba32f()
            .pixels()
            .map(|p| {
                let c = |v: f32| {
                    if srgb {
                        crate::srgb::srgb_to_linear(cf(v) as f64) as f32
                    } else {
                        cf(v)
                    }
                };
                [c(p[0]), c(p[1]), c(p[2]), cf(p[3])]
            })
            .collect(),
    }
}

/// `img` grown to `width x height` (each at least its own) by repeating its last column and
/// row, in its own pixel format, so the padded texels decode exactly like the edge's.
pub fn pad_image(img: &DynamicImage, width: u32, height: u32) -> DynamicImage {
    use image::{ImageBuffer, Pixel};
    fn pad<P: Pixel>(
        i: &ImageBuffer<P, Vec<P::Subpixel>>,
        w: u32,
        h: u32,
    ) -> ImageBuffer<P, Vec<P::Subpixel>> {
        let (iw, ih) = (i.width(), i.height());
        ImageBuffer::from_fn(w.max(iw), h.max(ih), |x, y| {
            *i.get_pixel(x.min(iw - 1), y.min(ih - 1))
        })
    }
    if (img.width(), img.height()) == (width, height) || img.width() == 0 || img.height() == 0 {
        return img.clone();
    }
    match img {
        DynamicImage::ImageLuma8(i) => DynamicImage::ImageLuma8(pad(i, width, height)),
        DynamicImage::ImageLumaA8(i) => DynamicImage::ImageLumaA8(pad(i, width, height)),
        DynamicImage::ImageRgb8(i) => DynamicImage::ImageRgb8(pad(i, width, height)),
        DynamicImage::ImageRgba8(i) => DynamicImage::ImageRgba8(pad(i, width, height)),
        DynamicImage::ImageLuma16(i) => DynamicImage::ImageLuma16(pad(i, width, height)),
        DynamicImage::ImageLumaA16(i) => DynamicImage::ImageLumaA16(pad(i, width, height)),
        DynamicImage::ImageRgb16(i) => DynamicImage::ImageRgb16(pad(i, width, height)),
        DynamicImage::ImageRgba16(i) => DynamicImage::ImageRgba16(pad(i, width, height)),
        DynamicImage::ImageRgb32F(i) => DynamicImage::ImageRgb32F(pad(i, width, height)),
        DynamicImage::ImageRgba32F(i) => DynamicImage::ImageRgba32F(pad(i, width, height)),
        other => DynamicImage::ImageRgba32F(pad(&other.to_rgba32f(), width, height)),
    }
}

/// A `w x h` level grown to `pw x ph` (each at least its own): the new texels are `fill`, or
/// repeat the last column and row when `fill` is `None`.
pub fn pad_texels(
    level: &[Texel],
    w: u32,
    h: u32,
    pw: u32,
    ph: u32,
    fill: Option<Texel>,
) -> Vec<Texel> {
    let mut out = Vec::with_capacity(pw.max(w) as usize * ph.max(h) as usize);
    out.extend_from_slice(level);
    pad_texels_owned(out, w, h, pw, ph, fill)
}

/// [`pad_texels`] in place: the rows moved out to their padded places from the bottom up, so
/// no second level is held while it runs.
pub fn pad_texels_owned(
    mut level: Vec<Texel>,
    w: u32,
    h: u32,
    pw: u32,
    ph: u32,
    fill: Option<Texel>,
) -> Vec<Texel> {
    let (w, h, pw, ph) = (
        w as usize,
        h as usize,
        pw.max(w) as usize,
        ph.max(h) as usize,
    );
    debug_assert_eq!(level.len(), w * h);
    if w == 0 || h == 0 {
        return vec![fill.unwrap_or([0.0; 4]); pw * ph];
    }
    level.resize(pw * ph, [0.0; 4]);
    // A row's padded place starts at or after its own, so the bottom rows go first.
    for y in (0..h).rev() {
        level.copy_within(y * w..(y + 1) * w, y * pw);
        let f = fill.unwrap_or(level[y * pw + w - 1]);
        level[y * pw + w..(y + 1) * pw].fill(f);
    }
    for y in h..ph {
        match fill {
            Some(f) => level[y * pw..(y + 1) * pw].fill(f),
            None => level.copy_within((h - 1) * pw..h * pw, y * pw),
        }
    }
    level
}

/// One sRGB RGBA8 texel as [`to_linear`] decodes it: colour from [`decode8`], alpha `a / 255`.
/// Paths that read 8-bit texels without that copy go through this, so their bits stay its.
#[inline(always)]
pub fn texel8(b: [u8; 4]) -> Texel {
    let lut = decode8();
    [
        lut[b[0] as usize],
        lut[b[1] as usize],
        lut[b[2] as usize],
        b[3] as f32 / 255.0,
    ]
}

/// An 8-bit image's texels as RGBA8 bytes (borrowed when it is RGBA8 already): grey expands to
/// RGB and missing alpha is opaque, so [`to_linear`] gives the same texels from either. `None`
/// for 16-bit and float images.
pub fn rgba8_bytes(img: &DynamicImage) -> Option<std::borrow::Cow<'_, [u8]>> {
    match img {
        DynamicImage::ImageRgba8(i) => Some(std::borrow::Cow::Borrowed(i.as_raw())),
        DynamicImage::ImageRgb8(_) | DynamicImage::ImageLuma8(_) | DynamicImage::ImageLumaA8(_) => {
            Some(std::borrow::Cow::Owned(img.to_rgba8().into_raw()))
        }
        _ => None,
    }
}

fn grey(v: f32, a: f32) -> Texel {
    [v, v, v, a]
}

/// Linear colour channels as unit-interval values without a transfer function, for normal maps
/// (whose bytes are linear encodings of vectors). Alpha is dropped.
pub fn to_unorm_rgb(img: &DynamicImage) -> Vec<[f32; 3]> {
    to_linear(img, false)
        .into_iter()
        .map(|t| [t[0], t[1], t[2]])
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every texel where padding puts it: the level's own in place, then `fill`, or the
    /// nearest edge texel without one; grown on either axis, both or neither.
    #[test]
    fn padding_repeats_the_edge_or_fills() {
        for (w, h, pw, ph) in [
            (5u32, 3u32, 8u32, 4u32),
            (4, 4, 4, 4),
            (1, 1, 4, 4),
            (7, 2, 7, 5),
        ] {
            let level: Vec<Texel> = (0..w * h)
                .map(|i| [i as f32, 0.5 * i as f32, 1.0, 0.25])
                .collect();
            for fill in [None, Some([9.0; 4])] {
                let (w, h, pw, ph) = (w as usize, h as usize, pw as usize, ph as usize);
                let want: Vec<Texel> = (0..pw * ph)
                    .map(|i| {
                        let (x, y) = (i % pw, i / pw);
                        match fill {
                            Some(f) if x >= w || y >= h => f,
                            _ => level[y.min(h - 1) * w + x.min(w - 1)],
                        }
                    })
                    .collect();
                let (a, b, c, d) = (w as u32, h as u32, pw as u32, ph as u32);
                assert_eq!(
                    pad_texels(&level, a, b, c, d, fill),
                    want,
                    "{w}x{h} to {pw}x{ph}"
                );
                assert_eq!(pad_texels_owned(level.clone(), a, b, c, d, fill), want);
            }
        }
    }
}
