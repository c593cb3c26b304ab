//! The god rays: a full-screen radial blur of the window mask towards the light
//! (`godrays.wgsl`), at full or reduced resolution.

use super::{
    Colour, HDR, draw_fullscreen, fullscreen_pipeline, sampler_entry, texture_entry,
    uniform_buffer, uniform_entry,
};

/// Radial blur of the window mask towards the light, at full or reduced resolution.
pub struct GodRayPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
}

impl GodRayPass {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("god rays"),
            entries: &[
                uniform_entry(0, std::mem::size_of::<crate::uniforms::GodRays>()),
                texture_entry(1),
                sampler_entry(2),
            ],
        });
        let pipeline = fullscreen_pipeline(device, &layout, "godrays.wgsl", HDR);
        let uniforms = uniform_buffer(
            device,
            "god rays",
            std::mem::size_of::<crate::uniforms::GodRays>(),
        );
        Self {
            pipeline,
            layout,
            uniforms,
        }
    }

    pub(crate) fn write_uniforms(&self, queue: &wgpu::Queue, u: &crate::uniforms::GodRays) {
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(u));
    }

    /// Blurs `mask` (pass 1's target) towards the light into `target`.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        mask: &wgpu::TextureView,
        sampler: &wgpu::Sampler,
        target: &wgpu::TextureView,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("god rays"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(mask),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(sampler),
                },
            ],
        });
        let target = Colour {
            view: target,
            clear: wgpu::Color::BLACK,
        };
        draw_fullscreen(
            encoder,
            "god rays",
            &self.pipeline,
            &group,
            target,
            timestamps,
        );
    }
}
