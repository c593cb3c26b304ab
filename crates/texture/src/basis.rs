//! KTX2 textures with Basis Universal payloads (ETC1S or UASTC, what `KHR_texture_basisu` and
//! tools such as glTF Transform and toktx write), transcoded to plain texels: the cook makes
//! its own mips and block compression from level 0, like from a PNG.

use std::path::Path;

use basisu::{DecodeFlags, SourceFormat, TargetFormat, Transcoder};
use image::DynamicImage;

use crate::TextureError;
use crate::load::check_claimed_size;

/// The 12-byte identifier every KTX2 file starts with.
pub const KTX2_IDENTIFIER: [u8; 12] = [
    0xAB, b'K', b'T', b'X', b' ', b'2', b'0', 0xBB, b'\r', b'\n', 0x1A, b'\n',
];

/// True when `bytes` start like a KTX2 file (what [`decode_ktx2`] reads).
pub fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&KTX2_IDENTIFIER)
}

/// Decodes level 0 of a KTX2 file with a Basis Universal payload: LDR sources to RGBA8 (RGB8
/// where the file says it has no alpha, as a PNG without alpha would be), HDR ones (UASTC HDR,
/// ASTC HDR 6x6) to RGBA f32. The size is checked against [`MAX_SIDE`](crate::MAX_SIDE) before the output is
/// allocated. Arrays, cube maps and video are refused: a material samples one 2D image, and
/// taking one layer of several would cook a silently wrong texture. A decoder panic on damaged
/// data is reported as the file's error.
pub fn decode_ktx2(bytes: &[u8], path: &Path) -> Result<DynamicImage, TextureError> {
    let bad = |reason: String| TextureError::Basis {
        path: path.to_path_buf(),
        reason,
    };
    let decoded = crate::guard::catch_decoder_panic(|| transcode(bytes, path));
    decoded.map_err(|why| bad(format!("the transcoder failed on it ({why})")))?
}

fn transcode(bytes: &[u8], path: &Path) -> Result<DynamicImage, TextureError> {
    let bad = |reason: String| TextureError::Basis {
        path: path.to_path_buf(),
        reason,
    };
    // Basis payloads leave the Vulkan format undefined (0); a KTX2 that names one holds plain
    // or block-compressed texels, which KHR_texture_basisu does not allow.
    if let Some(&[a, b, c, d]) = bytes.get(12..16)
        && let vk_format @ 1.. = u32::from_le_bytes([a, b, c, d])
    {
        return Err(bad(format!(
            "it holds texels of Vulkan format {vk_format}, not a Basis Universal payload; the \
             cooker reads KTX2 as KHR_texture_basisu defines it (ETC1S or UASTC): convert it \
             with `toktx --encode uastc` or save it as PNG"
        )));
    }
    check_level0_claim(bytes).map_err(bad)?;
    let t = Transcoder::new(bytes).map_err(|e| {
        bad(format!(
            "not a KTX2 file with a Basis Universal (ETC1S or UASTC) payload, or damaged ({e:?})"
        ))
    })?;
    let (width, height) = t.base_dimensions();
    check_claimed_size(path, width, height)?;
    let (layers, faces) = (t.layer_count(), t.face_count());
    if layers > 1 || faces > 1 || t.is_video() {
        return Err(bad(format!(
            "holds {} (layers {layers}, faces {faces}); a material samples one 2D image",
            if t.is_video() {
                "a video"
            } else if faces > 1 {
                "a cube map"
            } else {
                "an array"
            }
        )));
    }
    let hdr = matches!(
        t.source_format(),
        SourceFormat::UastcHdr4x4 | SourceFormat::AstcHdr6x6 | SourceFormat::UastcHdr6x6
    );
    let target = if hdr {
        TargetFormat::RgbaHalf
    } else {
        TargetFormat::Rgba32
    };
    let level0 = t
        .transcode(0, target, DecodeFlags::NONE)
        .map_err(|e| bad(format!("level 0 does not transcode ({e:?})")))?;
    let texels = width as usize * height as usize;
    if level0.len() != texels * target.bytes_per_block_or_pixel() {
        return Err(bad(format!(
            "level 0 transcoded to {} bytes, not the {texels} texels its {width}x{height} hold",
            level0.len()
        )));
    }
    let image = if hdr {
        let floats = level0
            .chunks_exact(2)
            .map(|h| f16_to_f32(u16::from_le_bytes([h[0], h[1]])))
            .collect();
        image::Rgba32FImage::from_raw(width, height, floats).map(DynamicImage::ImageRgba32F)
    } else if t.has_alpha() {
        image::RgbaImage::from_raw(width, height, level0).map(DynamicImage::ImageRgba8)
    } else {
        let rgb = level0
            .chunks_exact(4)
            .flat_map(|p| [p[0], p[1], p[2]])
            .collect();
        image::RgbImage::from_raw(width, height, rgb).map(DynamicImage::ImageRgb8)
    };
    // The length was checked above, so the buffer always fits.
    image.ok_or_else(|| bad("level 0 has the wrong size".to_string()))
}

/// Refuses a level 0 whose index claims more uncompressed bytes than its size can hold: the
/// transcoder allocates a zstd-supercompressed level's claimed length before inflating it, and
/// a damaged claim (2^48 bytes, found by mutating a real file) aborted the process. No Basis
/// payload needs more than 16 bytes per 4x4 block. What the header cannot say (a file too short
/// for its index) is left to the transcoder's own checks.
fn check_level0_claim(bytes: &[u8]) -> Result<(), String> {
    let u32_at = |at: usize| -> Option<u64> {
        Some(u64::from(u32::from_le_bytes(
            bytes.get(at..at + 4)?.try_into().ok()?,
        )))
    };
    let u64_at = |at: usize| -> Option<u64> {
        Some(u64::from_le_bytes(bytes.get(at..at + 8)?.try_into().ok()?))
    };
    // Header: width at 20, height at 24, layers at 32, faces at 36; level 0's index entry
    // (offset, length, uncompressed length) at 80.
    let (Some(width), Some(height), Some(layers), Some(faces), Some(claimed)) =
        (u32_at(20), u32_at(24), u32_at(32), u32_at(36), u64_at(96))
    else {
        return Ok(());
    };
    // Saturating: a damaged header may claim sides up to 2^32 (refused after this check).
    let blocks = width.div_ceil(4).saturating_mul(height.max(1).div_ceil(4));
    let most = blocks
        .saturating_mul(16)
        .saturating_mul(layers.max(1))
        .saturating_mul(faces.max(1));
    if claimed > most {
        return Err(format!(
            "level 0 claims {claimed} bytes uncompressed, more than the {most} its {width}x{height} \
             texels can hold"
        ));
    }
    Ok(())
}

/// IEEE binary16 to f32, exactly (every half is a float).
fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let mantissa = f32::from(h & 0x3ff);
    sign * match exp {
        0 => mantissa * 2f32.powi(-24),
        31 if mantissa == 0.0 => f32::INFINITY,
        31 => f32::NAN,
        _ => (1.0 + mantissa / 1024.0) * 2f32.powi(exp - 15),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn halves_convert_exactly() {
        assert_eq!(f16_to_f32(0x0000), 0.0);
        assert_eq!(f16_to_f32(0x3c00), 1.0);
        assert_eq!(f16_to_f32(0xc000), -2.0);
        assert_eq!(f16_to_f32(0x7bff), 65504.0);
        assert_eq!(f16_to_f32(0x0001), 2f32.powi(-24));
        assert_eq!(f16_to_f32(0x03ff), 1023.0 * 2f32.powi(-24));
        assert_eq!(f16_to_f32(0x3555), 0.333_251_95);
        assert_eq!(f16_to_f32(0x7c00), f32::INFINITY);
        assert!(f16_to_f32(0x7e00).is_nan());
    }

    fn fixture(name: &str) -> Vec<u8> {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../tests/data/third_party/ktx2");
        std::fs::read(dir.join(name)).unwrap()
    }

    /// The mutation that aborted the process (a zstd level claiming 2^48 bytes uncompressed)
    /// is refused before the transcoder allocates; the file it came from decodes.
    #[test]
    fn a_level_claiming_more_than_its_size_holds_is_refused() {
        let good = fixture("template_uastc.ktx2");
        let img = decode_ktx2(&good, Path::new("t.ktx2")).unwrap();
        assert_eq!((img.width(), img.height()), (512, 512));
        let mut bad = good.clone();
        bad[96..104].copy_from_slice(&(1u64 << 48).to_le_bytes());
        let e = decode_ktx2(&bad, Path::new("t.ktx2"))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("t.ktx2") && e.contains("281474976710656 bytes"),
            "{e}"
        );
        // Sides of 2^32 - 1 do not overflow the bound (a panic would say "failed on it").
        bad[20..28].fill(0xff);
        let e = decode_ktx2(&bad, Path::new("t.ktx2"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("t.ktx2") && !e.contains("failed on it"), "{e}");
    }

    #[test]
    fn what_is_not_a_basis_ktx2_is_an_error_naming_the_file() {
        let p = Path::new("t/window.ktx2");
        let mut bytes = KTX2_IDENTIFIER.to_vec();
        bytes.extend([0u8; 60]);
        for data in [&bytes[..], &bytes[..12], &[0u8; 3][..]] {
            let e = decode_ktx2(data, p).unwrap_err().to_string();
            assert!(e.contains("t/window.ktx2") && e.contains("Basis"), "{e}");
        }
    }
}
