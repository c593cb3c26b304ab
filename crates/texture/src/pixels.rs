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

/// A channel value of an image buffer, for [`bleed_under_transparent`].
trait Channel: Copy {
    fn to_f64(self) -> f64;
    fn from_f64(v: f64) -> Self;
    fn is_zero(self) -> bool;
}

macro_rules! unorm_channel {
    ($t:ty) => {
        impl Channel for $t {
            fn to_f64(self) -> f64 {
                self as f64
            }
            fn from_f64(v: f64) -> Self {
                v.round().clamp(0.0, <$t>::MAX as f64) as $t
            }
            fn is_zero(self) -> bool {
                self == 0
            }
        }
    };
}

unorm_channel!(u8);
unorm_channel!(u16);

impl Channel for f32 {
    fn to_f64(self) -> f64 {
        self as f64
    }
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    fn is_zero(self) -> bool {
        // A negative or NaN alpha shows nothing either.
        self.is_nan() || self <= 0.0
    }
}

/// `img` with the colour of every fully transparent texel replaced by the mean colour of its
/// nearest texels that show (grown outward a ring at a time, each texel the mean of its
/// already coloured 8-neighbours, as stored), or `None` where no texel is fully transparent
/// or none shows. For a window design, whose colour the viewer filters as stored (straight
/// alpha) before it weighs it by alpha: the colour an image editor leaves under alpha 0
/// (often white) bled into the panes' edges as halos, and two designs that differ only
/// there rendered differently.
pub fn bleed_under_transparent(img: &DynamicImage) -> Option<DynamicImage> {
    let (w, h) = (img.width() as usize, img.height() as usize);
    let mut out = img.clone();
    let changed = match &mut out {
        DynamicImage::ImageRgba8(i) => bleed(i, w, h, 4),
        DynamicImage::ImageLumaA8(i) => bleed(i, w, h, 2),
        DynamicImage::ImageRgba16(i) => bleed(i, w, h, 4),
        DynamicImage::ImageLumaA16(i) => bleed(i, w, h, 2),
        DynamicImage::ImageRgba32F(i) => bleed(i, w, h, 4),
        _ => false,
    };
    changed.then_some(out)
}

/// [`bleed_under_transparent`] on `w x h` texels of `ch` channels, alpha last; whether any
/// texel changed.
fn bleed<C: Channel>(data: &mut [C], w: usize, h: usize, ch: usize) -> bool {
    const HIDDEN: u8 = 0;
    const SHOWN: u8 = 1;
    const QUEUED: u8 = 2;
    let n = w * h;
    if n == 0 || data.len() < n * ch {
        return false;
    }
    let mut state: Vec<u8> = (0..n)
        .map(|i| {
            if data[i * ch + ch - 1].is_zero() {
                HIDDEN
            } else {
                SHOWN
            }
        })
        .collect();
    let hidden = state.iter().filter(|&&s| s == HIDDEN).count();
    if hidden == 0 || hidden == n {
        return false;
    }
    let neighbours = |i: usize| {
        let (x, y) = ((i % w) as isize, (i / w) as isize);
        (-1isize..=1)
            .flat_map(move |dy| (-1isize..=1).map(move |dx| (x + dx, y + dy)))
            .filter(move |&(nx, ny)| {
                (nx, ny) != (x, y) && nx >= 0 && ny >= 0 && nx < w as isize && ny < h as isize
            })
            .map(move |(nx, ny)| ny as usize * w + nx as usize)
    };
    let mut ring: Vec<usize> = (0..n)
        .filter(|&i| state[i] == HIDDEN && neighbours(i).any(|j| state[j] == SHOWN))
        .collect();
    for &i in &ring {
        state[i] = QUEUED;
    }
    let colours = ch - 1;
    let mut mean = Vec::new();
    while !ring.is_empty() {
        // Every texel of the ring from the rings before it only, so the order within a ring
        // does not matter.
        mean.clear();
        for &i in &ring {
            let mut sum = [0.0f64; 3];
            let mut count = 0.0;
            for j in neighbours(i).filter(|&j| state[j] == SHOWN) {
                for c in 0..colours {
                    sum[c] += data[j * ch + c].to_f64();
                }
                count += 1.0;
            }
            mean.push(sum.map(|s| s / count));
        }
        for (&i, m) in ring.iter().zip(&mean) {
            for c in 0..colours {
                data[i * ch + c] = C::from_f64(m[c]);
            }
        }
        for &i in &ring {
            state[i] = SHOWN;
        }
        let mut next = Vec::new();
        for &i in &ring {
            for j in neighbours(i) {
                if state[j] == HIDDEN {
                    state[j] = QUEUED;
                    next.push(j);
                }
            }
        }
        ring = next;
    }
    true
}

#[cfg(test)]
mod bleed_tests {
    use super::*;

    /// A lone opaque texel colours everything hidden around it; what shows is untouched;
    /// an image with nothing hidden, or nothing shown, is left as it is.
    #[test]
    fn hidden_texels_take_the_colour_of_the_nearest_shown() {
        let mut img = image::RgbaImage::from_pixel(5, 4, image::Rgba([255, 255, 255, 0]));
        img.put_pixel(2, 1, image::Rgba([200, 10, 30, 128]));
        let bled = bleed_under_transparent(&DynamicImage::ImageRgba8(img))
            .unwrap()
            .to_rgba8();
        for (x, y, p) in bled.enumerate_pixels() {
            let alpha = if (x, y) == (2, 1) { 128 } else { 0 };
            assert_eq!(*p, image::Rgba([200, 10, 30, alpha]), "{x},{y}");
        }
        // Between two panes, a hidden texel takes the mean of both; further out, of its ring.
        let mut two = image::RgbaImage::from_pixel(3, 1, image::Rgba([9, 9, 9, 0]));
        two.put_pixel(0, 0, image::Rgba([100, 0, 0, 255]));
        two.put_pixel(2, 0, image::Rgba([0, 200, 0, 255]));
        let bled = bleed_under_transparent(&DynamicImage::ImageRgba8(two))
            .unwrap()
            .to_rgba8();
        assert_eq!(*bled.get_pixel(1, 0), image::Rgba([50, 100, 0, 0]));
        let opaque = image::RgbaImage::from_pixel(2, 2, image::Rgba([1, 2, 3, 255]));
        assert!(bleed_under_transparent(&DynamicImage::ImageRgba8(opaque)).is_none());
        let clear = image::RgbaImage::from_pixel(2, 2, image::Rgba([1, 2, 3, 0]));
        assert!(bleed_under_transparent(&DynamicImage::ImageRgba8(clear)).is_none());
        let rgb = image::RgbImage::from_pixel(2, 2, image::Rgb([1, 2, 3]));
        assert!(bleed_under_transparent(&DynamicImage::ImageRgb8(rgb)).is_none());
    }
}
