//! Reading images back from the GPU: whole textures to tightly packed rows, half floats to
//! f32, and intermediate targets to viewable images. The headless frames, the pass images, the
//! viewer's screenshots and the bench all read back through here.

use crate::{RenderError, TargetId};

/// Image of an intermediate target for viewing: radiance targets tone-mapped as the composite
/// shows them at exposure 1 ([`crate::reference::tone_mapped`]), the window mask clamped and
/// sRGB-encoded, normals mapped from [-1, 1] to [0, 1].
pub fn target_image(id: TargetId, w: u32, h: u32, px: &[[f32; 4]]) -> image::RgbaImage {
    let enc = |v: f32| {
        let v = if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        };
        let s = if v <= 0.0031308 {
            v * 12.92
        } else {
            1.055 * v.powf(1.0 / 2.4) - 0.055
        };
        (s * 255.0 + 0.5) as u8
    };
    let lin = |v: f32| {
        ((if v.is_finite() {
            v.clamp(0.0, 1.0)
        } else {
            0.0
        }) * 255.0
            + 0.5) as u8
    };
    // Radiance (the sky, the lit scene, the god rays) runs past 1: clamped, the default
    // scene's background pass was pure white. Shown as the composite shows it.
    let hdr = matches!(id, TargetId::Background | TargetId::Lit | TargetId::GodRays);
    let mut img = image::RgbaImage::new(w, h);
    for (p, out) in px.iter().zip(img.pixels_mut()) {
        *out = if hdr {
            let [r, g, b] = crate::reference::tone_map(*p);
            image::Rgba([r, g, b, 255])
        } else if id == TargetId::WindowNormals {
            image::Rgba([
                lin(p[0] * 0.5 + 0.5),
                lin(p[1] * 0.5 + 0.5),
                lin(p[2] * 0.5 + 0.5),
                255,
            ])
        } else {
            image::Rgba([enc(p[0]), enc(p[1]), enc(p[2]), 255])
        };
    }
    img
}

/// IEEE half to single precision.
pub fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = ((h >> 10) & 0x1f) as i32;
    let frac = (h & 0x3ff) as f32;
    match exp {
        0 => sign * frac * 2f32.powi(-24),
        31 => {
            if frac == 0.0 {
                sign * f32::INFINITY
            } else {
                f32::NAN
            }
        }
        e => sign * (1.0 + frac / 1024.0) * 2f32.powi(e - 15),
    }
}

pub(crate) fn read_buffer(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
) -> Result<Vec<u8>, RenderError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| RenderError::Device(e.to_string()))?;
    rx.recv()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let data = buffer
        .get_mapped_range(..)
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .to_vec();
    buffer.unmap();
    Ok(data)
}

/// Copies a whole 2D texture (`bytes_per_texel` bytes each) back to the CPU, rows tightly
/// packed: the headless frames, the pass images and the viewer's screenshots all read back
/// through here.
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    bytes_per_texel: u32,
) -> Result<Vec<u8>, RenderError> {
    let (w, h) = (texture.width(), texture.height());
    let row = w * bytes_per_texel;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded as u64 * h as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    queue.submit([encoder.finish()]);
    let data = read_buffer(device, &buffer)?;
    let mut out = Vec::with_capacity((row * h) as usize);
    for y in 0..h as usize {
        out.extend_from_slice(&data[y * padded as usize..y * padded as usize + row as usize]);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The default scene's sky is radiance 1.5 to 4: clamped, its background pass was white.
    #[test]
    fn radiance_passes_are_tone_mapped_and_the_mask_is_not() {
        let px = [[0.5, 2.0, 4.0, 1.0]];
        let sky = target_image(TargetId::Background, 1, 1, &px)
            .get_pixel(0, 0)
            .0;
        assert_eq!(&sky[..3], &crate::reference::tone_map(px[0])[..]);
        assert!(sky[..3].iter().all(|&c| c < 255), "{sky:?}");
        assert!(sky[0] < sky[1] && sky[1] < sky[2], "{sky:?}");
        let lit = target_image(TargetId::Lit, 1, 1, &px).get_pixel(0, 0).0;
        assert_eq!(lit, sky);
        let mask = target_image(TargetId::WindowMask, 1, 1, &px)
            .get_pixel(0, 0)
            .0;
        assert_eq!(&mask[1..3], &[255, 255]);
    }
}
