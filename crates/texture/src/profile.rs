//! Embedded colour profiles (ICC): an image the user names as colour (a window design, say) is
//! shown as an image viewer shows it, so a photo taken in Display P3 or a design saved in
//! Adobe RGB is converted to sRGB, the space the pack stores. Read as sRGB bytes, a P3 photo's
//! colours came out duller than on the phone that took it (P3 (200, 100, 50) is sRGB
//! (215, 93, 31)). Images a model references are not converted: glTF requires that their
//! profiles be ignored, and engines read material textures so.

use std::path::Path;
use std::sync::Arc;

use image::DynamicImage;
use moxcms::{ColorProfile, DataColorSpace, Layout, ProfileText, RenderingIntent};
use rayon::prelude::*;

use crate::TextureError;
use crate::load::{Icc, MAX_PROFILE_BYTES, embedded_profile, load_with_profile};

/// What a file's embedded profile does to its colours.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ProfileUse {
    /// No profile, or one that keeps every colour within two 8-bit steps (an sRGB profile).
    Srgb,
    /// Converted to sRGB; `name` is the profile's description.
    Converted { name: String },
    /// Not applied, so the texels are read as sRGB; `why` says why.
    Ignored { name: String, why: String },
}

impl ProfileUse {
    /// A sentence on what was done, for a cook's notes; `None` for sRGB.
    pub fn said(&self) -> Option<String> {
        let quoted = |n: &str| {
            if n.is_empty() {
                "its ICC profile".to_string()
            } else {
                format!("its ICC profile \"{n}\"")
            }
        };
        match self {
            ProfileUse::Srgb => None,
            ProfileUse::Converted { name } => Some(format!(
                "colours converted from {} to sRGB, as an image viewer shows them",
                quoted(name)
            )),
            ProfileUse::Ignored { name, why } => Some(format!(
                "{} is not applied ({why}): its texels are read as sRGB",
                quoted(name)
            )),
        }
    }
}

/// What [`load_image_in_srgb`] will do with `path`'s profile, from the file's header alone.
pub fn profile_use(path: &Path) -> Result<ProfileUse, TextureError> {
    let (colour, icc) = embedded_profile(path)?;
    Ok(match icc {
        Icc::None => ProfileUse::Srgb,
        Icc::Bytes(icc) => plan(&icc, colour).0,
        Icc::Unreadable(why) => unreadable(why),
    })
}

/// [`crate::load_image`], converted to sRGB where the file embeds a profile other than sRGB
/// (to RGBA at the image's own depth, 8 or 16 bits); see [`ProfileUse`]. Files without one, or with an sRGB one, are returned as `load_image` reads
/// them, texel for texel.
pub fn load_image_in_srgb(path: &Path) -> Result<(DynamicImage, ProfileUse), TextureError> {
    let (image, icc) = load_with_profile(path)?;
    let icc = match icc {
        Icc::None => return Ok((image, ProfileUse::Srgb)),
        Icc::Unreadable(why) => return Ok((image, unreadable(why))),
        Icc::Bytes(icc) => icc,
    };
    let (said, transform) = plan(&icc, image.color());
    let Some(transform) = transform else {
        return Ok((image, said));
    };
    let failed = |e: moxcms::CmsError| TextureError::Decode {
        path: path.to_path_buf(),
        error: image::ImageError::Unsupported(
            image::error::UnsupportedError::from_format_and_kind(
                image::error::ImageFormatHint::Unknown,
                image::error::UnsupportedErrorKind::GenericFeature(format!(
                    "its ICC profile's transform failed: {e}"
                )),
            ),
        ),
    };
    // Bands of rows, each its own transform call, in parallel.
    let band = image.width() as usize * 4 * 16;
    if matches!(
        image.color(),
        image::ColorType::Rgb16 | image::ColorType::Rgba16
    ) {
        let mut texels = image.into_rgba16();
        texels
            .as_mut()
            .par_chunks_mut(band)
            .try_for_each(|rows| {
                let src = rows.to_vec();
                transform.transform(&src, rows)
            })
            .map_err(failed)?;
        return Ok((DynamicImage::ImageRgba16(texels), said));
    }
    // An 8-bit image stays 8-bit, each texel rounded once from the 16-bit transform: what the
    // same design exported in sRGB would hold. Kept at 16 bits, an 8000x6000 photo took the
    // cook from 0.76 to 2.5 GB and 5.4 to 8.3 s, for a level 0 the pack stores at 8 bits.
    let mut texels = image.into_rgba8();
    texels
        .as_mut()
        .par_chunks_mut(band)
        .try_for_each(|rows| {
            let src: Vec<u16> = rows.iter().map(|&v| v as u16 * 257).collect();
            let mut dst = vec![0u16; src.len()];
            transform.transform(&src, &mut dst)?;
            for (out, v) in rows.iter_mut().zip(&dst) {
                *out = ((*v as u32 + 128) / 257) as u8;
            }
            Ok(())
        })
        .map_err(failed)?;
    Ok((DynamicImage::ImageRgba8(texels), said))
}

type Transform = Arc<moxcms::Transform16BitExecutor>;

fn unreadable(why: String) -> ProfileUse {
    ProfileUse::Ignored {
        name: String::new(),
        why: format!("it cannot be read: {why}"),
    }
}

/// What a message may print of a profile's description, which is the file's text: control
/// characters (a newline, a terminal's escape) replaced, at most 64 characters.
fn printable(name: &str) -> String {
    let mut out: String = name
        .chars()
        .map(|c| if c.is_control() { '?' } else { c })
        .take(64)
        .collect();
    if name.chars().count() > 64 {
        out.push('…');
    }
    out
}

/// A texel type as a message says it.
fn texels(colour: image::ColorType) -> String {
    use image::ColorType as C;
    let bits = colour.bits_per_pixel() / colour.channel_count() as u16;
    let kind = match colour {
        C::L8 | C::L16 => "grey",
        C::La8 | C::La16 => "grey and alpha",
        C::Rgb32F | C::Rgba32F => "floating-point RGB",
        _ => "RGB",
    };
    format!("{kind} {bits}-bit")
}

/// The profile's use for an image of `colour`, with the transform to sRGB where it converts.
fn plan(icc: &[u8], colour: image::ColorType) -> (ProfileUse, Option<Transform>) {
    let ignored = |name: &str, why: String| {
        let name = name.to_string();
        (ProfileUse::Ignored { name, why }, None)
    };
    if icc.len() > MAX_PROFILE_BYTES {
        let mb = icc.len() as f64 / 1e6;
        return ignored(
            "",
            format!("it is {mb:.0} MB, more than any colour profile takes"),
        );
    }
    let profile = match ColorProfile::new_from_slice(icc) {
        Ok(p) => p,
        Err(e) => return (unreadable(e.to_string()), None),
    };
    let name = printable(&profile.description.as_ref().map(text).unwrap_or_default());
    if profile.color_space != DataColorSpace::Rgb {
        let space = match profile.color_space {
            DataColorSpace::Gray => "grey".to_string(),
            DataColorSpace::Cmyk => "CMYK".to_string(),
            other => format!("{other:?}"),
        };
        return ignored(
            &name,
            format!("a {space} profile; only RGB ones are converted"),
        );
    }
    use image::ColorType as C;
    if !matches!(colour, C::Rgb8 | C::Rgba8 | C::Rgb16 | C::Rgba16) {
        return ignored(
            &name,
            format!(
                "an RGB profile on {} texels; only 8- and 16-bit RGB ones are converted",
                texels(colour)
            ),
        );
    }
    let options = moxcms::TransformOptions {
        rendering_intent: RenderingIntent::RelativeColorimetric,
        prefer_fixed_point: false,
        ..Default::default()
    };
    let transform = match profile.create_transform_16bit(
        Layout::Rgba,
        &ColorProfile::new_srgb(),
        Layout::Rgba,
        options,
    ) {
        Ok(t) => t,
        Err(e) => return ignored(&name, format!("no transform to sRGB: {e}")),
    };
    if maps_to_itself(&*transform) {
        return (ProfileUse::Srgb, None);
    }
    (ProfileUse::Converted { name }, Some(transform))
}

/// True when every 8-bit value on a 18-step grid of the RGB cube (every 15th level, both ends
/// included) comes back from the transform within two 8-bit steps: an sRGB profile, however
/// it was written (there are many, with their colorants rounded each its own way), which is
/// then not applied at all. One written by hand from sRGB's numbers sent (15, 255, 255) to
/// red 13.76 (its cyan a hair outside the gamut, clipped) and every colour of a design within
/// 0.11; Display P3 moves colours by tens of steps.
fn maps_to_itself(t: &moxcms::Transform16BitExecutor) -> bool {
    let levels: Vec<u16> = (0..=255u16).step_by(15).map(|v| v * 257).collect();
    let mut src = Vec::with_capacity(levels.len().pow(3) * 4);
    for &r in &levels {
        for &g in &levels {
            for &b in &levels {
                src.extend([r, g, b, u16::MAX]);
            }
        }
    }
    let mut dst = vec![0u16; src.len()];
    if t.transform(&src, &mut dst).is_err() {
        return false;
    }
    src.iter()
        .zip(&dst)
        .all(|(a, b)| (*a as i32 - *b as i32).abs() < 2 * 257)
}

fn text(t: &ProfileText) -> String {
    match t {
        ProfileText::PlainString(s) => s.clone(),
        ProfileText::Localizable(v) => v
            .iter()
            .find(|s| s.language == "en")
            .or(v.first())
            .map(|s| s.value.clone())
            .unwrap_or_default(),
        ProfileText::Description(d) => d.ascii_string.clone(),
    }
    .trim_end_matches('\0')
    .trim()
    .to_string()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::srgb::{linear_to_srgb, srgb_to_linear};

    /// A PNG of `img` embedding `icc`.
    fn png_with_profile(img: &image::RgbImage, icc: Option<Vec<u8>>, path: &Path) {
        use image::ImageEncoder;
        let mut bytes = Vec::new();
        let mut enc = image::codecs::png::PngEncoder::new(&mut bytes);
        if let Some(icc) = icc {
            enc.set_icc_profile(icc).unwrap();
        }
        enc.write_image(
            img.as_raw(),
            img.width(),
            img.height(),
            image::ExtendedColorType::Rgb8,
        )
        .unwrap();
        std::fs::write(path, bytes).unwrap();
    }

    /// Every 8-bit level of each channel against the others at a few levels.
    fn ramp() -> image::RgbImage {
        image::RgbImage::from_fn(256, 16, |x, y| {
            let o = [0u8, 60, 128, 255][(y % 4) as usize];
            let p = [0u8, 200, 90, 255][(y / 4) as usize];
            image::Rgb([x as u8, o, p])
        })
    }

    /// xy chromaticities of red, green, blue and white to the matrix from linear RGB to XYZ.
    fn to_xyz(p: [[f64; 2]; 4]) -> [[f64; 3]; 3] {
        let col = |[x, y]: [f64; 2]| [x / y, 1.0, (1.0 - x - y) / y];
        let (r, g, b, w) = (col(p[0]), col(p[1]), col(p[2]), col(p[3]));
        let m = [[r[0], g[0], b[0]], [r[1], g[1], b[1]], [r[2], g[2], b[2]]];
        let s = mul(inverse(m), w);
        let mut out = m;
        for row in &mut out {
            for (c, v) in row.iter_mut().enumerate() {
                *v *= s[c];
            }
        }
        out
    }

    fn mul(m: [[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
        m.map(|r| r[0] * v[0] + r[1] * v[1] + r[2] * v[2])
    }

    fn inverse(m: [[f64; 3]; 3]) -> [[f64; 3]; 3] {
        let c = |r: usize, k: usize| {
            let (r0, r1) = ((r + 1) % 3, (r + 2) % 3);
            let (k0, k1) = ((k + 1) % 3, (k + 2) % 3);
            m[r0][k0] * m[r1][k1] - m[r0][k1] * m[r1][k0]
        };
        let det = m[0][0] * c(0, 0) + m[0][1] * c(0, 1) + m[0][2] * c(0, 2);
        let mut out = [[0.0; 3]; 3];
        for (r, row) in out.iter_mut().enumerate() {
            for (k, v) in row.iter_mut().enumerate() {
                *v = c(k, r) / det;
            }
        }
        out
    }

    /// A Display P3 image (a phone's photo) converts to sRGB as the published primaries say:
    /// within half an 8-bit step of an f64 conversion, clipped to the sRGB gamut. Read as
    /// sRGB bytes, its saturated colours came out dull.
    #[test]
    fn display_p3_converts_to_srgb_as_its_primaries_say() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p3.png");
        let img = ramp();
        let icc = ColorProfile::new_display_p3().encode().unwrap();
        png_with_profile(&img, Some(icc), &path);
        assert!(matches!(
            profile_use(&path).unwrap(),
            ProfileUse::Converted { .. }
        ));
        let (got, used) = load_image_in_srgb(&path).unwrap();
        assert!(matches!(used, ProfileUse::Converted { .. }), "{used:?}");
        let got = got.as_rgba8().expect("8-bit RGBA, as the file").clone();
        let d65 = [0.3127, 0.3290];
        let p3 = to_xyz([[0.680, 0.320], [0.265, 0.690], [0.150, 0.060], d65]);
        let srgb = to_xyz([[0.64, 0.33], [0.30, 0.60], [0.15, 0.06], d65]);
        let m = |v| mul(inverse(srgb), mul(p3, v));
        let mut worst = 0.0f64;
        for (src, out) in img.pixels().zip(got.pixels()) {
            let lin = m(src.0.map(|c| srgb_to_linear(c as f64 / 255.0)));
            for c in 0..3 {
                let want = linear_to_srgb(lin[c].clamp(0.0, 1.0)) * 255.0;
                worst = worst.max((out[c] as f64 - want).abs());
            }
            assert_eq!(out[3], 255);
        }
        // Rounded to 8 bits once (0.5) from 16 bits within 0.43 of exact (the library's
        // curves are tables).
        assert!(worst <= 0.93, "off by {worst} LSB");
        // P3's red lies past sRGB's: it is clipped to pure red.
        assert_eq!(got.get_pixel(255, 0).0, [255, 0, 0, 255]);
        // 16 bits a channel stay 16: the profile's precision is kept where the file has it.
        let wide = image::ImageBuffer::<image::Rgb<u16>, _>::from_fn(256, 16, |x, y| {
            image::Rgb(img.get_pixel(x, y).0.map(|c| c as u16 * 257))
        });
        let mut bytes = Vec::new();
        let mut enc = image::codecs::png::PngEncoder::new(&mut bytes);
        image::ImageEncoder::set_icc_profile(
            &mut enc,
            ColorProfile::new_display_p3().encode().unwrap(),
        )
        .unwrap();
        image::ImageEncoder::write_image(
            enc,
            // 16-bit samples as the encoder takes them: native byte order.
            &wide
                .as_raw()
                .iter()
                .flat_map(|v| v.to_ne_bytes())
                .collect::<Vec<u8>>(),
            256,
            16,
            image::ExtendedColorType::Rgb16,
        )
        .unwrap();
        std::fs::write(&path, bytes).unwrap();
        let (wide_got, _) = load_image_in_srgb(&path).unwrap();
        let wide_got = wide_got
            .as_rgba16()
            .expect("16-bit RGBA, as the file")
            .clone();
        for (a, b) in got.pixels().zip(wide_got.pixels()) {
            for c in 0..3 {
                assert!(
                    (a[c] as f64 - b[c] as f64 / 257.0).abs() <= 0.5,
                    "{a:?} {b:?}"
                );
            }
        }
    }

    /// An sRGB profile, however written, changes nothing: the texels are `load_image`'s. A
    /// file without one is sRGB.
    #[test]
    fn an_srgb_profile_or_none_keeps_the_texels() {
        let dir = tempfile::tempdir().unwrap();
        let img = ramp();
        for (name, icc) in [
            ("srgb.png", Some(ColorProfile::new_srgb().encode().unwrap())),
            ("none.png", None),
        ] {
            let path = dir.path().join(name);
            png_with_profile(&img, icc, &path);
            assert_eq!(profile_use(&path).unwrap(), ProfileUse::Srgb, "{name}");
            let (got, used) = load_image_in_srgb(&path).unwrap();
            assert_eq!(used, ProfileUse::Srgb);
            assert_eq!(got, crate::load_image(&path).unwrap(), "{name}");
        }
    }

    /// Cesium's logo in glTF-Sample-Models embeds Apple's "Generic RGB Profile" (gamma 1.8):
    /// its greys convert to sRGB's brighter codes, as the profile's curve says; a damaged
    /// profile is named and not applied.
    #[test]
    fn a_third_party_generic_rgb_profile_brightens_greys_and_a_damaged_one_is_ignored() {
        let logo = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../tests/data/third_party/gltf/BoxTextured/CesiumLogoFlat.png");
        let Icc::Bytes(icc) = load_with_profile(&logo).unwrap().1 else {
            panic!("the logo embeds a profile");
        };
        match profile_use(&logo).unwrap() {
            ProfileUse::Converted { name } => assert_eq!(name, "Generic RGB Profile"),
            other => panic!("{other:?}"),
        }
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("grey.png");
        let grey = image::RgbImage::from_fn(256, 1, |x, _| image::Rgb([x as u8; 3]));
        png_with_profile(&grey, Some(icc.clone()), &path);
        let (got, _) = load_image_in_srgb(&path).unwrap();
        let got = got.as_rgba8().unwrap().clone();
        let mut worst = 0.0f64;
        for x in 0..256u32 {
            let out = got.get_pixel(x, 0).0;
            let want = linear_to_srgb((x as f64 / 255.0).powf(1.8)) * 255.0;
            for c in &out[..3] {
                worst = worst.max((*c as f64 - want).abs());
            }
        }
        // Rounded once (0.5) from within 0.054 of the curve.
        assert!(worst <= 0.56, "greys off a 1.8 curve by {worst} LSB");

        let mut bad = icc;
        bad.truncate(60);
        png_with_profile(&grey, Some(bad), &path);
        let used = profile_use(&path).unwrap();
        assert!(
            matches!(&used, ProfileUse::Ignored { why, .. } if why.contains("cannot be read")),
            "{used:?}"
        );
        let (got, _) = load_image_in_srgb(&path).unwrap();
        assert_eq!(got, crate::load_image(&path).unwrap());
    }

    fn crc32(bytes: &[u8]) -> u32 {
        let mut c = !0u32;
        for &b in bytes {
            c ^= b as u32;
            for _ in 0..8 {
                c = if c & 1 != 0 {
                    0xEDB8_8320 ^ (c >> 1)
                } else {
                    c >> 1
                };
            }
        }
        !c
    }

    /// `png` with an `iCCP` chunk holding `zlib` inserted after its header.
    fn with_iccp(png: &[u8], zlib: &[u8]) -> Vec<u8> {
        let mut body = b"iCCPbomb\0\0".to_vec();
        body.extend_from_slice(zlib);
        let mut chunk = ((body.len() - 4) as u32).to_be_bytes().to_vec();
        chunk.extend_from_slice(&body);
        chunk.extend_from_slice(&crc32(&body).to_be_bytes());
        let at = 8 + 25; // signature, then IHDR's 13 bytes in a chunk
        [&png[..at], &chunk, &png[at..]].concat()
    }

    /// A PNG whose `iCCP` inflates to 64 MB (from 64 kB of deflate) or whose deflate stream is
    /// cut is named in the reason and its texels read as sRGB, without the PNG decoder
    /// inflating it (it did, with no bound, to a gigabyte); so is a JPEG whose ICC segments do
    /// not make a whole profile (the decoder dropped them without a word).
    #[test]
    fn a_bombed_damaged_or_incomplete_profile_is_named_and_the_texels_read_as_srgb() {
        let dir = tempfile::tempdir().unwrap();
        let img = ramp();
        let path = dir.path().join("plain.png");
        png_with_profile(&img, None, &path);
        let plain = std::fs::read(&path).unwrap();
        let bomb = fdeflate::compress_to_vec(&vec![0u8; 64 << 20]);
        let p3 = fdeflate::compress_to_vec(&ColorProfile::new_display_p3().encode().unwrap());
        for (name, zlib, says) in [
            ("bomb.png", &bomb[..], "inflates past 4 MB"),
            ("cut.png", &p3[..p3.len() / 2], "deflate stream is damaged"),
        ] {
            let path = dir.path().join(name);
            std::fs::write(&path, with_iccp(&plain, zlib)).unwrap();
            for used in [
                profile_use(&path).unwrap(),
                load_image_in_srgb(&path).unwrap().1,
            ] {
                assert!(
                    matches!(&used, ProfileUse::Ignored { why, .. } if why.contains(says)),
                    "{name}: {used:?}"
                );
            }
            let (got, _) = load_image_in_srgb(&path).unwrap();
            assert_eq!(got.to_rgb8(), img, "{name}");
        }
        // The whole profile, for contrast, is applied.
        let path = dir.path().join("whole.png");
        std::fs::write(&path, with_iccp(&plain, &p3)).unwrap();
        assert!(matches!(
            profile_use(&path).unwrap(),
            ProfileUse::Converted { .. }
        ));

        use image::ImageEncoder;
        let mut jpeg = Vec::new();
        let mut enc = image::codecs::jpeg::JpegEncoder::new_with_quality(&mut jpeg, 95);
        enc.set_icc_profile(ColorProfile::new_display_p3().encode().unwrap())
            .unwrap();
        enc.write_image(img.as_raw(), 256, 16, image::ExtendedColorType::Rgb8)
            .unwrap();
        let path = dir.path().join("p3.jpg");
        std::fs::write(&path, &jpeg).unwrap();
        assert!(matches!(
            profile_use(&path).unwrap(),
            ProfileUse::Converted { .. }
        ));
        // Segment 1 of 2, the second never written.
        let at = jpeg
            .windows(12)
            .position(|w| w == b"ICC_PROFILE\0")
            .unwrap();
        jpeg[at + 13] = 2;
        std::fs::write(&path, &jpeg).unwrap();
        for used in [
            profile_use(&path).unwrap(),
            load_image_in_srgb(&path).unwrap().1,
        ] {
            assert!(
                matches!(&used, ProfileUse::Ignored { why, .. }
                    if why.contains("one ICC_PROFILE segment does not make a whole profile")),
                "{used:?}"
            );
        }
    }
}
