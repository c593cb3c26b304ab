//! One struct per pass. Geometry passes (0–3) share the frame (group 0) and material (group 1)
//! layouts and the vertex shader in `common.wgsl`; god rays and the composite are full-screen.

use crate::scene::vertex_layout;
use crate::shaders;

pub(crate) const HDR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba16Float;
pub(crate) const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

fn uniform_entry(binding: u32, size: usize) -> wgpu::BindGroupLayoutEntry {
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

pub(crate) fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
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

pub(crate) fn sampler_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    }
}

/// Group 0 of the geometry passes: frame and window uniforms, the projector array, a sampler.
pub(crate) fn frame_layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let mut entries = vec![
        uniform_entry(0, std::mem::size_of::<crate::uniforms::Frame>()),
        uniform_entry(1, std::mem::size_of::<crate::uniforms::Windows>()),
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
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("frame"),
        entries: &entries,
    })
}

fn geometry_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    shader: &'static str,
) -> wgpu::RenderPipeline {
    let module = shaders::module(device, shader);
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(shader),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(vertex_layout())],
        },
        primitive: wgpu::PrimitiveState {
            topology: wgpu::PrimitiveTopology::TriangleList,
            // Scenes hold single-sided quads (walls, windows) seen from both sides.
            cull_mode: None,
            ..Default::default()
        },
        depth_stencil: Some(wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(true),
            // LessEqual lets passes 2 and 3 reuse the depth pass 1 wrote: the same vertex shader
            // yields the same depths.
            depth_compare: Some(wgpu::CompareFunction::LessEqual),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(HDR.into())],
        }),
        multiview_mask: None,
        cache: None,
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
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(shader),
        layout: Some(&pl),
        vertex: wgpu::VertexState {
            module: &module,
            entry_point: Some("vs_fullscreen"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module: &module,
            entry_point: Some("fs_main"),
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

/// Pass 0: background-class geometry alone into its own target.
pub struct BackgroundPass {
    pub(crate) pipeline: wgpu::RenderPipeline,
}

impl BackgroundPass {
    pub(crate) fn new(device: &wgpu::Device, layout: &wgpu::PipelineLayout) -> Self {
        Self {
            pipeline: geometry_pipeline(device, layout, "background.wgsl"),
        }
    }
}

/// Pass 1: window colour, everything else black; also lays down the depth passes 2–3 reuse.
pub struct WindowMaskPass {
    pub(crate) pipeline: wgpu::RenderPipeline,
}

impl WindowMaskPass {
    pub(crate) fn new(device: &wgpu::Device, layout: &wgpu::PipelineLayout) -> Self {
        Self {
            pipeline: geometry_pipeline(device, layout, "windows.wgsl"),
        }
    }
}

/// Pass 2: window normal-map perturbation in view space, everything else zero.
pub struct WindowNormalPass {
    pub(crate) pipeline: wgpu::RenderPipeline,
}

impl WindowNormalPass {
    pub(crate) fn new(device: &wgpu::Device, layout: &wgpu::PipelineLayout) -> Self {
        Self {
            pipeline: geometry_pipeline(device, layout, "normals.wgsl"),
        }
    }
}

/// Pass 3: the lit scene, windows black, projectors through the windows.
pub struct LitPass {
    pub(crate) pipeline: wgpu::RenderPipeline,
}

impl LitPass {
    pub(crate) fn new(device: &wgpu::Device, layout: &wgpu::PipelineLayout) -> Self {
        Self {
            pipeline: geometry_pipeline(device, layout, "lit.wgsl"),
        }
    }
}

/// Radial blur of the window mask towards the light, at full or reduced resolution.
pub struct GodRayPass {
    pub(crate) pipeline: wgpu::RenderPipeline,
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) uniforms: wgpu::Buffer,
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
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("god rays"),
            size: std::mem::size_of::<crate::uniforms::GodRays>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            layout,
            uniforms,
        }
    }
}

/// Pass 4: refraction, god rays and tone mapping into the output format.
pub struct CompositePass {
    pub(crate) pipeline: wgpu::RenderPipeline,
    pub(crate) layout: wgpu::BindGroupLayout,
    pub(crate) uniforms: wgpu::Buffer,
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
        let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("composite"),
            size: std::mem::size_of::<crate::uniforms::Composite>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            pipeline,
            layout,
            uniforms,
        }
    }
}
