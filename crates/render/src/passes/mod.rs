//! The passes, one unit each: a pass owns its pipeline (and, for the full-screen ones, its
//! bind group layout and uniform buffer) and records itself into the targets the frame graph
//! (`renderer.rs`) hands it. The four geometry passes (0–3) differ only in shader, material
//! filter and targets, so they are one type, [`GeometryPass`]; they share the frame (group 0)
//! and material (group 1) layouts and the vertex shader in `common.wgsl`. God rays and the
//! composite are full-screen passes of their own.

mod composite;
mod geometry;
mod god_rays;
mod shadow;
mod sky;

pub use composite::{CompositeInputs, CompositePass};
pub use geometry::GeometryPass;
pub use god_rays::GodRayPass;
pub(crate) use shadow::casts_shadow;
pub use shadow::{SHADOW_VIEW_SIZE, ShadowPass};
pub use sky::SkyPass;

use crate::shaders;

pub(crate) const HDR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The value of a scoped thread that made pipelines, its panic passed on as it was. Drivers
/// compile a pipeline when it is created, so passes and their pipelines are made side by side.
pub(crate) fn joined<T>(h: std::thread::ScopedJoinHandle<'_, T>) -> T {
    h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
}

pub(crate) fn uniform_entry(binding: u32, size: usize) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size as u64),
        },
        count: None,
    }
}

/// A read-only storage buffer for the fragment stage, at least `size` bytes.
pub(crate) fn storage_entry(binding: u32, size: u64) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only: true },
            has_dynamic_offset: false,
            min_binding_size: wgpu::BufferSize::new(size),
        },
        count: None,
    }
}

/// A filterable 2D texture read by the fragment stage (also for the viewer's own passes).
pub fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

/// A filtering sampler for the fragment stage.
pub fn sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// Group 0 of the geometry passes: the frame's uniforms, the windows' storage buffer, the
/// projector array, a sampler, the shadow maps and their comparison sampler, the windows'
/// planes.
pub(crate) fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let mut entries = vec![
        uniform_entry(0, std::mem::size_of::<crate::uniforms::Frame>()),
        storage_entry(1, crate::uniforms::Windows::buffer_size(1)),
    ];
    entries.push(wgpu::BindGroupLayoutEntry {
        binding: 2,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    });
    entries.push(sampler_entry(3));
    entries.push(shadow::depth_array_entry(4));
    entries.push(wgpu::BindGroupLayoutEntry {
        binding: 5,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Comparison),
        count: None,
    });
    entries.push(storage_entry(
        6,
        std::mem::size_of::<crate::uniforms::WindowPlane>() as u64,
    ));
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("frame"),
        entries: &entries,
    })
}

pub(crate) fn fullscreen_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    shader: &'static str,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    let module = shaders::module(device, shader);
    let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(shader),
        bind_group_layouts: &[Some(layout)],
        immediate_size: 0,
    });
    fullscreen_pipeline_in(device, shader, &module, &pl, "fs_main", format)
}

/// A pipeline drawing one full-screen triangle (`vs_fullscreen` from `fullscreen.wgsl`, which
/// `module` includes) with the fragment entry point `fragment` into one `format` target; also
/// for the viewer's own display passes.
pub fn fullscreen_pipeline_in(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    fragment: &str,
    format: wgpu::TextureFormat,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some(fragment),
            compilation_options: Default::default(),
            targets: &[Some(format.into())],
        }),
        multiview_mask: None,
        cache: None,
    })
}

pub(crate) fn geometry_layout(
    device: &wgpu::Device,
    frame: &wgpu::BindGroupLayout,
    material: &wgpu::BindGroupLayout,
) -> wgpu::PipelineLayout {
    device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("geometry"),
        bind_group_layouts: &[Some(frame), Some(material)],
        immediate_size: 0,
    })
}

pub fn uniform_buffer(device: &wgpu::Device, label: &str, size: usize) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: size as u64,
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// A colour target and what it is cleared to.
#[derive(Clone, Copy)]
pub(crate) struct Colour<'a> {
    pub view: &'a wgpu::TextureView,
    pub clear: wgpu::Color,
}

/// Begins a render pass into colour targets (cleared, stored) and an optional depth target.
pub(crate) fn begin<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    targets: &[Colour<'_>],
    depth: Option<wgpu::RenderPassDepthStencilAttachment<'_>>,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) -> wgpu::RenderPass<'e> {
    let attachments: Vec<_> = targets
        .iter()
        .map(|t| {
            Some(wgpu::RenderPassColorAttachment {
                view: t.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(t.clear),
                    store: wgpu::StoreOp::Store,
                },
            })
        })
        .collect();
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &attachments,
        depth_stencil_attachment: depth,
        timestamp_writes: timestamps,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// Draws one full-screen triangle with `pipeline` and its single bind group.
pub(crate) fn draw_fullscreen(
    encoder: &mut wgpu::CommandEncoder,
    label: &str,
    pipeline: &wgpu::RenderPipeline,
    group: &wgpu::BindGroup,
    target: Colour<'_>,
    timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
) {
    let mut rp = begin(encoder, label, &[target], None, timestamps);
    rp.set_pipeline(pipeline);
    rp.set_bind_group(0, group, &[]);
    rp.draw(0..3, 0..1);
}
