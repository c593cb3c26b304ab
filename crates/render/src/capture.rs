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
/// through here. In bands of rows, each within the device's largest buffer and 64 MiB: an
/// 8192x4608 pass image (8 bytes a texel, 302 MB) asked for one buffer over wgpu's 256 MiB
/// and the viewer panicked after the render.
pub fn read_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    bytes_per_texel: u32,
) -> Result<Vec<u8>, RenderError> {
    read_texture_in_bands(device, queue, texture, bytes_per_texel, 64 << 20)
}

fn read_texture_in_bands(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
    bytes_per_texel: u32,
    band_bytes: u64,
) -> Result<Vec<u8>, RenderError> {
    let (w, h) = (texture.width(), texture.height());
    let row = w * bytes_per_texel;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let most = device.limits().max_buffer_size.min(band_bytes);
    let band = ((most / padded as u64).max(1) as u32).min(h);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: padded as u64 * band as u64,
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let mut out = Vec::with_capacity(row as usize * h as usize);
    for y0 in (0..h).step_by(band as usize) {
        let rows = band.min(h - y0);
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.copy_texture_to_buffer(
            wgpu::TexelCopyTextureInfo {
                texture,
                mip_level: 0,
                origin: wgpu::Origin3d { x: 0, y: y0, z: 0 },
                aspect: wgpu::TextureAspect::All,
            },
            wgpu::TexelCopyBufferInfo {
                buffer: &buffer,
                layout: wgpu::TexelCopyBufferLayout {
                    offset: 0,
                    bytes_per_row: Some(padded),
                    rows_per_image: Some(rows),
                },
            },
            wgpu::Extent3d {
                width: w,
                height: rows,
                depth_or_array_layers: 1,
            },
        );
        queue.submit([encoder.finish()]);
        let data = read_buffer(device, &buffer)?;
        for y in 0..rows as usize {
            out.extend_from_slice(&data[y * padded as usize..y * padded as usize + row as usize]);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A texture read back in bands of a few rows (the last one short) is the texture: its
    /// rows in order, none twice. Fails without a GPU adapter, as every GPU test does.
    #[test]
    fn bands_of_rows_read_back_the_whole_texture() {
        let gpu = crate::Gpu::headless().expect("a GPU adapter (lavapipe in CI)");
        let (w, h) = (37u32, 23u32);
        let texels: Vec<u8> = (0..w * h * 4).map(|i| (i * 7 % 251) as u8).collect();
        let texture = gpu.device.create_texture(&wgpu::TextureDescriptor {
            label: Some("bands"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8Unorm,
            usage: wgpu::TextureUsages::COPY_SRC | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        });
        gpu.queue.write_texture(
            texture.as_image_copy(),
            &texels,
            wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(w * 4),
                rows_per_image: Some(h),
            },
            texture.size(),
        );
        // 256 bytes a padded row: bands of 5 rows, the last of 3.
        for band in [5 * 256, 256, 1 << 20] {
            let back = read_texture_in_bands(&gpu.device, &gpu.queue, &texture, 4, band).unwrap();
            assert!(back == texels, "bands of {band} bytes");
        }
    }

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
