//! The projector array: every window's projector texture as one layer of a texture array.

use pack::Toc;

use crate::uniforms;
use crate::{Gpu, RenderError};

/// Projector textures gathered into one array, so the lit pass can reach any window's design
/// with a single binding however many windows a scene has. Each layer is a resampled copy of
/// the levels resident so far, refreshed as larger ones stream in.
pub(crate) struct Projectors {
    /// Texture index of each layer; the layer after the last stays white.
    slots: Vec<u32>,
    texture: wgpu::Texture,
    view: wgpu::TextureView,
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    sampler: wgpu::Sampler,
    size: u32,
    levels: u32,
    /// The resident base level each layer was last copied from.
    copied: Vec<Option<u32>>,
}

/// Layers are square, at most the format's projector size: projectors are pre-blurred, so
/// that keeps their detail while bounding the copy each streamed level costs.
const MAX_PROJECTOR_SIZE: u32 = pack::PROJECTOR_MAX_SIZE;

/// Bytes the array may take, all levels: a 512² layer and its chain is 1.33 MiB, so up to 384
/// windows' projectors keep their full size and more share this at a smaller one (a cathedral
/// of a thousand panes would otherwise ask 1.4 GB). Windows that many are small on the floor,
/// and their projectors are pre-blurred.
const ARRAY_BUDGET: u64 = 512 << 20;

/// The layer size for `layers` layers of at most `size` texels a side within [`ARRAY_BUDGET`]:
/// halved until they fit (not below 16).
fn layer_size(size: u32, layers: u32) -> u32 {
    crate::side_within(size, ARRAY_BUDGET, |s| {
        layers as u64 * (s as u64 * s as u64 * 4) * 4 / 3
    })
}

impl Projectors {
    /// One layer per distinct projector texture of the TOC's windows, in window order.
    pub(crate) fn new(gpu: &Gpu, toc: &Toc) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let mut slots: Vec<u32> = Vec::new();
        for w in &toc.windows {
            if let Some(p) = toc.materials[w.material as usize].projector_texture
                && !slots.contains(&p)
            {
                slots.push(p);
            }
        }
        let max_layers = device.limits().max_texture_array_layers as usize;
        if slots.len() > max_layers {
            return Err(RenderError::TooManyProjectors {
                found: slots.len(),
                max: max_layers,
            });
        }
        let size = slots
            .iter()
            .map(|&t| {
                toc.textures[t as usize]
                    .width
                    .max(toc.textures[t as usize].height)
            })
            .max()
            .unwrap_or(1)
            .min(MAX_PROJECTOR_SIZE);
        // One layer per projector plus a white one for windows without a projector texture.
        let layers = slots.len() as u32 + 1;
        let full = size;
        let size = layer_size(full, layers);
        if size < full {
            eprintln!(
                "note: {} window projectors share {} MiB of projector array: each is {size} \
                 texels a side instead of {full}",
                slots.len(),
                ARRAY_BUDGET >> 20
            );
        }
        // A full chain: floors seen at grazing angles minify the patterns strongly.
        let levels = 32 - size.leading_zeros();
        let texture = device.create_texture(&wgpu::TextureDescriptor {
            label: Some("projectors"),
            size: wgpu::Extent3d {
                width: size,
                height: size,
                depth_or_array_layers: layers,
            },
            mip_level_count: levels,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::RENDER_ATTACHMENT,
            view_formats: &[],
        });
        let view = texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2Array),
            ..Default::default()
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("projector copy"),
            entries: &[
                crate::passes::texture_entry(0),
                crate::passes::sampler_entry(1),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let pipeline = crate::passes::fullscreen_pipeline(
            device,
            &layout,
            "blit.wgsl",
            wgpu::TextureFormat::Rgba8UnormSrgb,
        );
        let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
            mag_filter: wgpu::FilterMode::Linear,
            min_filter: wgpu::FilterMode::Linear,
            mipmap_filter: wgpu::MipmapFilterMode::Linear,
            ..Default::default()
        });
        let p = Self {
            slots,
            texture,
            view,
            pipeline,
            layout,
            sampler,
            size,
            levels,
            copied: vec![None; layers as usize],
        };
        // Until a projector's first level arrives its layer is white: unfiltered light.
        let mut encoder = device.create_command_encoder(&Default::default());
        for layer in 0..layers {
            for level in 0..levels {
                p.layer_pass(&mut encoder, layer, level, true);
            }
        }
        gpu.queue.submit([encoder.finish()]);
        Ok(p)
    }

    /// The array: every window's projector texture, one layer each.
    pub(crate) fn view(&self) -> &wgpu::TextureView {
        &self.view
    }

    /// The layer that stays white: unfiltered light, for windows without a projector.
    pub(crate) fn white_layer(&self) -> u32 {
        self.slots.len() as u32
    }

    /// The layer of a projector texture.
    pub(crate) fn slot(&self, texture: Option<u32>) -> Option<u32> {
        let t = texture?;
        self.slots.iter().position(|&p| p == t).map(|s| s as u32)
    }

    fn layer_pass<'e>(
        &self,
        encoder: &'e mut wgpu::CommandEncoder,
        layer: u32,
        level: u32,
        clear_white: bool,
    ) -> wgpu::RenderPass<'e> {
        let view = self.texture.create_view(&wgpu::TextureViewDescriptor {
            dimension: Some(wgpu::TextureViewDimension::D2),
            base_array_layer: layer,
            array_layer_count: Some(1),
            base_mip_level: level,
            mip_level_count: Some(1),
            ..Default::default()
        });
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("projector copy"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(if clear_white {
                        wgpu::Color::WHITE
                    } else {
                        wgpu::Color::BLACK
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        })
    }

    /// Copies each layer whose texture gained levels since its last copy. `resident` gives a
    /// texture's resident base level and a view of the resident levels, once it has any, with
    /// the GPU texture's size and the share of it the image covers.
    pub(crate) fn update<'t>(
        &mut self,
        gpu: &Gpu,
        resident: impl Fn(u32) -> Option<(u32, &'t wgpu::TextureView, (u32, u32), [f32; 2])>,
    ) {
        use wgpu::util::DeviceExt;
        let mut encoder = gpu.device.create_command_encoder(&Default::default());
        let mut any = false;
        for (layer, &t) in self.slots.iter().enumerate() {
            // GPU sizes (`scene::gpu_extent`): a projector sampled as blocks is padded to whole
            // blocks, and its image covers `scale` of it.
            let Some((base, view, (w, h), scale)) = resident(t) else {
                continue;
            };
            if self.copied[layer] == Some(base) {
                continue;
            }
            for level in 0..self.levels {
                // Source levels of about this array level's size across and down, relative to
                // the view's base: a narrow design's projector (14 x 306) took the level of its
                // longer side, whose few columns at the array's smaller levels mixed its
                // colours to white on the floor seen from afar.
                let lod = |side: u32| {
                    (side as f32 / self.size as f32).log2() + level as f32 - base as f32
                };
                let texel = 1.0 / (self.size >> level).max(1) as f32;
                let u = uniforms::Blit {
                    lod: [lod(w), lod(h), texel, 0.0],
                    scale: [scale[0], scale[1], 0.0, 0.0],
                };
                let buffer = gpu
                    .device
                    .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                        label: Some("projector copy"),
                        contents: bytemuck::bytes_of(&u),
                        usage: wgpu::BufferUsages::UNIFORM,
                    });
                let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: Some("projector copy"),
                    layout: &self.layout,
                    entries: &[
                        wgpu::BindGroupEntry {
                            binding: 0,
                            resource: wgpu::BindingResource::TextureView(view),
                        },
                        wgpu::BindGroupEntry {
                            binding: 1,
                            resource: wgpu::BindingResource::Sampler(&self.sampler),
                        },
                        wgpu::BindGroupEntry {
                            binding: 2,
                            resource: buffer.as_entire_binding(),
                        },
                    ],
                });
                let mut pass = self.layer_pass(&mut encoder, layer as u32, level, false);
                pass.set_pipeline(&self.pipeline);
                pass.set_bind_group(0, &group, &[]);
                pass.draw(0..3, 0..1);
            }
            self.copied[layer] = Some(base);
            any = true;
        }
        if any {
            gpu.queue.submit([encoder.finish()]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn many_layers_share_the_budget_at_a_smaller_size() {
        // A few hundred windows keep their full size; a thousand halve it, and the array
        // stays within the budget whatever the count.
        assert_eq!(layer_size(512, 193), 512);
        assert_eq!(layer_size(512, 384), 512);
        assert_eq!(layer_size(512, 385), 256);
        assert_eq!((layer_size(300, 1025), layer_size(300, 1500)), (300, 150));
        assert_eq!(layer_size(512, 100_000), 16);
        for layers in [1, 200, 385, 1025, 2048] {
            let s = layer_size(512, layers) as u64;
            assert!(layers as u64 * s * s * 16 / 3 <= ARRAY_BUDGET, "{layers}");
        }
    }
}
