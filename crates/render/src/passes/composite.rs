//! Pass 4: the composite of the earlier targets into the output.

use super::{
    Colour, draw_fullscreen, fullscreen_pipeline, sampler_entry, texture_entry, uniform_buffer,
    uniform_entry,
};

/// What the composite reads. A pass not recorded this frame is bound as black, never as its
/// stale target.
pub struct CompositeInputs<'a> {
    pub lit: &'a wgpu::TextureView,
    pub background: &'a wgpu::TextureView,
    pub mask: &'a wgpu::TextureView,
    pub normals: &'a wgpu::TextureView,
    pub rays: &'a wgpu::TextureView,
    pub nearest: &'a wgpu::Sampler,
    pub linear: &'a wgpu::Sampler,
}

/// Pass 4: refraction, god rays and tone mapping into the output format.
pub struct CompositePass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    uniforms: wgpu::Buffer,
}

impl CompositePass {
    pub(crate) fn new(device: &wgpu::Device, output: wgpu::TextureFormat) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("composite"),
            entries: &[
                uniform_entry(0, std::mem::size_of::<crate::uniforms::Composite>()),
                texture_entry(1),
                texture_entry(2),
                texture_entry(3),
                texture_entry(4),
                texture_entry(5),
                sampler_entry(6),
                sampler_entry(7),
            ],
        });
        let pipeline = fullscreen_pipeline(device, &layout, "composite.wgsl", output);
        let uniforms = uniform_buffer(
            device,
            "composite",
            std::mem::size_of::<crate::uniforms::Composite>(),
        );
        Self {
            pipeline,
            layout,
            uniforms,
        }
    }

    pub(crate) fn write_uniforms(&self, queue: &wgpu::Queue, u: &crate::uniforms::Composite) {
        queue.write_buffer(&self.uniforms, 0, bytemuck::bytes_of(u));
    }

    /// Combines `inputs` into `output`.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        inputs: &CompositeInputs<'_>,
        output: &wgpu::TextureView,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let tex = |binding, view| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::TextureView(view),
        };
        let sampler = |binding, sampler| wgpu::BindGroupEntry {
            binding,
            resource: wgpu::BindingResource::Sampler(sampler),
        };
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("composite"),
            layout: &self.layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.uniforms.as_entire_binding(),
                },
                tex(1, inputs.lit),
                tex(2, inputs.background),
                tex(3, inputs.mask),
                tex(4, inputs.normals),
                tex(5, inputs.rays),
                sampler(6, inputs.nearest),
                sampler(7, inputs.linear),
            ],
        });
        let target = Colour {
            view: output,
            clear: wgpu::Color::BLACK,
        };
        draw_fullscreen(
            encoder,
            "composite",
            &self.pipeline,
            &group,
            target,
            timestamps,
        );
    }
}
