//! What the window shows: the finished image, an intermediate target, or the false-colour
//! material-ID view. Every view is first drawn into one sRGB "display" image at window size,
//! which is then copied to the window; the screenshot key reads that image, so a screenshot is
//! exactly the current view without the panel.

use render::{FrameReport, Gpu, PassId, Renderer, Scene, TargetId, View};

const SHADER: &str = include_str!("display.wgsl");

/// `display.wgsl` with the render crate's includes (its full-screen triangle) spliced in.
fn display_shader() -> String {
    render::shaders::compose_source("display.wgsl", SHADER)
        .expect("display.wgsl includes only files the render crate compiles in")
}
/// The display image's format: the composite writes it, screenshots read it as RGBA8.
pub const DISPLAY_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ViewMode {
    Final,
    Background,
    WindowMask,
    WindowNormals,
    Lit,
    GodRays,
    MaterialIds,
    ShadowMap,
}

impl ViewMode {
    pub const ALL: [ViewMode; 8] = [
        Self::Final,
        Self::Background,
        Self::WindowMask,
        Self::WindowNormals,
        Self::Lit,
        Self::GodRays,
        Self::MaterialIds,
        Self::ShadowMap,
    ];

    pub fn label(self) -> &'static str {
        match self {
            Self::Final => "final image",
            Self::Background => "0 background",
            Self::WindowMask => "1 window mask",
            Self::WindowNormals => "2 window normals",
            Self::Lit => "3 lit scene",
            Self::GodRays => "god rays alone",
            Self::MaterialIds => "material IDs",
            Self::ShadowMap => "shadow map",
        }
    }

    /// A short name for `--script` and file names.
    pub fn key(self) -> &'static str {
        match self {
            Self::Final => "final",
            Self::Background => "background",
            Self::WindowMask => "mask",
            Self::WindowNormals => "normals",
            Self::Lit => "lit",
            Self::GodRays => "rays",
            Self::MaterialIds => "ids",
            Self::ShadowMap => "shadow",
        }
    }

    pub fn from_key(s: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|m| m.key() == s)
    }

    /// The function key that selects this view (F1 = final … F8 = shadow map).
    pub fn shortcut(self) -> &'static str {
        match self {
            Self::Final => "F1",
            Self::Background => "F2",
            Self::WindowMask => "F3",
            Self::WindowNormals => "F4",
            Self::Lit => "F5",
            Self::GodRays => "F6",
            Self::MaterialIds => "F7",
            Self::ShadowMap => "F8",
        }
    }

    fn target(self) -> Option<(TargetId, PassId)> {
        Some(match self {
            Self::Background => (TargetId::Background, PassId::Background),
            Self::WindowMask => (TargetId::WindowMask, PassId::WindowMask),
            Self::WindowNormals => (TargetId::WindowNormals, PassId::WindowNormals),
            Self::Lit => (TargetId::Lit, PassId::Lit),
            Self::GodRays => (TargetId::GodRays, PassId::GodRays),
            Self::ShadowMap => (TargetId::ShadowMap, PassId::Shadows),
            Self::Final | Self::MaterialIds => return None,
        })
    }
}

/// The false colour of material `index`: hues a golden angle apart, so neighbours in the
/// material table never look alike. sRGB bytes.
pub fn material_colour(index: usize) -> [u8; 3] {
    let h = (index as f32 * 0.618_034 + 0.1).fract() * 6.0;
    // Alternate two saturation/value pairs so that hues that come round again still differ.
    let (s, v) = if index.is_multiple_of(2) {
        (0.75, 0.95)
    } else {
        (0.55, 0.75)
    };
    let c = v * s;
    let x = c * (1.0 - (h % 2.0 - 1.0).abs());
    let (r, g, b) = match h as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r, g, b].map(|k| ((k + m) * 255.0).round() as u8)
}

fn srgb_to_linear(b: u8) -> f32 {
    let c = b as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct ShowParams {
    mode: u32,
    scale: f32,
    encode: u32,
    pad: u32,
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct IdCamera {
    view_proj: [[f32; 4]; 4],
    eye: [f32; 4],
}

struct Image {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
}

fn image(
    device: &wgpu::Device,
    label: &str,
    size: (u32, u32),
    format: wgpu::TextureFormat,
    usage: wgpu::TextureUsages,
) -> Image {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size.0.max(1),
            height: size.1.max(1),
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());
    Image { texture, view }
}

/// One "show a texture" pipeline per output format, with its parameter block.
struct ShowPipeline {
    pipeline: wgpu::RenderPipeline,
    format: wgpu::TextureFormat,
    params: wgpu::Buffer,
}

/// What one frame drew, for [`Display::draw_view`].
pub struct Drawn<'a> {
    pub renderer: &'a Renderer,
    pub report: Option<&'a FrameReport>,
    pub scene: &'a Scene,
    pub view: &'a View,
    /// Gain of an intermediate target shown alone (its colours, or the normals' perturbation).
    pub gain: f32,
}

pub struct Display {
    size: (u32, u32),
    display: Image,
    depth: Image,
    show_layout: wgpu::BindGroupLayout,
    to_display: ShowPipeline,
    to_window: ShowPipeline,
    sampler: wgpu::Sampler,
    id_pipeline: wgpu::RenderPipeline,
    id_camera: wgpu::Buffer,
    id_camera_group: wgpu::BindGroup,
    swatch_layout: wgpu::BindGroupLayout,
    /// One swatch per material at `swatch_stride` apart, for dynamic offsets.
    swatches: Option<(wgpu::Buffer, wgpu::BindGroup, usize)>,
    swatch_stride: u64,
}

fn show_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    format: wgpu::TextureFormat,
) -> ShowPipeline {
    let pipeline =
        render::passes::fullscreen_pipeline_in(device, "show", module, layout, "fs_show", format);
    let params =
        render::passes::uniform_buffer(device, "show params", std::mem::size_of::<ShowParams>());
    ShowPipeline {
        pipeline,
        format,
        params,
    }
}

fn uniform_layout_entry(
    binding: u32,
    size: usize,
    dynamic: bool,
    visibility: wgpu::ShaderStages,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Uniform,
            has_dynamic_offset: dynamic,
            min_binding_size: wgpu::BufferSize::new(size as u64),
        },
        count: None,
    }
}

impl Display {
    /// `window_format` is the format of the view the window image is drawn into.
    pub fn new(
        device: &wgpu::Device,
        size: (u32, u32),
        window_format: wgpu::TextureFormat,
    ) -> Self {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("viewer display"),
            source: wgpu::ShaderSource::Wgsl(display_shader().into()),
        });
        let show_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("show"),
            entries: &[
                uniform_layout_entry(
                    0,
                    std::mem::size_of::<ShowParams>(),
                    false,
                    wgpu::ShaderStages::FRAGMENT,
                ),
                render::passes::texture_entry(1),
                render::passes::sampler_entry(2),
            ],
        });
        let show_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("show"),
            bind_group_layouts: &[Some(&show_layout)],
            immediate_size: 0,
        });
        let id_camera_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("id camera"),
            entries: &[uniform_layout_entry(
                0,
                std::mem::size_of::<IdCamera>(),
                false,
                wgpu::ShaderStages::VERTEX_FRAGMENT,
            )],
        });
        let swatch_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("swatch"),
            entries: &[uniform_layout_entry(
                0,
                16,
                true,
                wgpu::ShaderStages::FRAGMENT,
            )],
        });
        let id_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("material ids"),
            bind_group_layouts: &[Some(&id_camera_layout), Some(&swatch_layout)],
            immediate_size: 0,
        });
        let attributes = wgpu::vertex_attr_array![
            0 => Float32x3,
            1 => Float32x3,
        ];
        let id_pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("material ids"),
            layout: Some(&id_pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_ids"),
                compilation_options: Default::default(),
                buffers: &[Some(wgpu::VertexBufferLayout {
                    // The scene's buffers hold `pack::StandardVertex`: position, then normal.
                    array_stride: std::mem::size_of::<pack::StandardVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &attributes,
                })],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                cull_mode: None,
                ..Default::default()
            },
            depth_stencil: Some(wgpu::DepthStencilState {
                format: DEPTH_FORMAT,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_ids"),
                compilation_options: Default::default(),
                targets: &[Some(DISPLAY_FORMAT.into())],
            }),
            multiview_mask: None,
            cache: None,
        });
        let buffer = |label, size: u64| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            })
        };
        let id_camera = buffer("id camera", std::mem::size_of::<IdCamera>() as u64);
        let id_camera_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("id camera"),
            layout: &id_camera_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: id_camera.as_entire_binding(),
            }],
        });
        let stride = device.limits().min_uniform_buffer_offset_alignment.max(16) as u64;
        let (display, depth) = Self::images(device, size);
        Self {
            size,
            display,
            depth,
            to_display: show_pipeline(device, &module, &show_pl, DISPLAY_FORMAT),
            to_window: show_pipeline(device, &module, &show_pl, window_format),
            show_layout,
            sampler: device.create_sampler(&wgpu::SamplerDescriptor {
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                ..Default::default()
            }),
            id_pipeline,
            id_camera,
            id_camera_group,
            swatch_layout,
            swatches: None,
            swatch_stride: stride,
        }
    }

    fn images(device: &wgpu::Device, size: (u32, u32)) -> (Image, Image) {
        (
            image(
                device,
                "display",
                size,
                DISPLAY_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT
                    | wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC,
            ),
            image(
                device,
                "id depth",
                size,
                DEPTH_FORMAT,
                wgpu::TextureUsages::RENDER_ATTACHMENT,
            ),
        )
    }

    pub fn resize(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        if size != self.size {
            self.size = size;
            (self.display, self.depth) = Self::images(device, size);
        }
    }

    pub fn size(&self) -> (u32, u32) {
        self.size
    }

    /// The view the renderer's composite writes into.
    pub fn display_view(&self) -> &wgpu::TextureView {
        &self.display.view
    }

    pub fn display_texture(&self) -> &wgpu::Texture {
        &self.display.texture
    }

    /// Uploads the false colours of a (new) scene's materials.
    pub fn set_materials(&mut self, device: &wgpu::Device, queue: &wgpu::Queue, count: usize) {
        let count = count.max(1);
        let stride = self.swatch_stride as usize;
        let mut bytes = vec![0u8; stride * count];
        for i in 0..count {
            let c = material_colour(i).map(srgb_to_linear);
            let v = [c[0], c[1], c[2], 1.0];
            bytes[i * stride..i * stride + 16].copy_from_slice(bytemuck::cast_slice(&v));
        }
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("swatches"),
            size: bytes.len() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        queue.write_buffer(&buffer, 0, &bytes);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("swatches"),
            layout: &self.swatch_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &buffer,
                    offset: 0,
                    size: wgpu::BufferSize::new(16),
                }),
            }],
        });
        self.swatches = Some((buffer, group, count));
    }

    fn show(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        pipeline: &ShowPipeline,
        params: ShowParams,
        source: &wgpu::TextureView,
        target: &wgpu::TextureView,
    ) {
        gpu.queue
            .write_buffer(&pipeline.params, 0, bytemuck::bytes_of(&params));
        let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("show"),
            layout: &self.show_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: pipeline.params.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(source),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::Sampler(&self.sampler),
                },
            ],
        });
        let mut rp = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("show"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        rp.set_pipeline(&pipeline.pipeline);
        rp.set_bind_group(0, &group, &[]);
        rp.draw(0..3, 0..1);
    }

    /// Draws `mode` into the display image. The final view is already there (the renderer's
    /// composite wrote it); a pass the report lists as skipped shows black, because its target
    /// still holds an older frame.
    pub fn draw_view(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        mode: ViewMode,
        drawn: &Drawn<'_>,
    ) {
        if mode == ViewMode::MaterialIds {
            self.draw_ids(&gpu.queue, encoder, drawn.scene, drawn.view);
            return;
        }
        let Some((target, pass)) = mode.target() else {
            return;
        };
        // Shadow maps are kept between frames: skipped as up to date, they still show.
        let skipped = drawn.report.is_none_or(|r| {
            r.passes
                .iter()
                .any(|p| p.pass == pass && p.skipped.is_some())
        }) && !(target == TargetId::ShadowMap && drawn.renderer.has_shadow_maps());
        let shader_mode = if skipped {
            3
        } else if target == TargetId::WindowNormals {
            2
        } else {
            1
        };
        self.show(
            gpu,
            encoder,
            &self.to_display,
            ShowParams {
                mode: shader_mode,
                scale: drawn.gain,
                encode: 0,
                pad: 0,
            },
            drawn.renderer.target_view(target),
            &self.display.view,
        );
    }

    fn draw_ids(
        &self,
        queue: &wgpu::Queue,
        encoder: &mut wgpu::CommandEncoder,
        scene: &Scene,
        view: &View,
    ) {
        let cam = IdCamera {
            view_proj: view.view_proj_relative().to_cols_array_2d(),
            eye: view.position.extend(1.0).to_array(),
        };
        queue.write_buffer(&self.id_camera, 0, bytemuck::bytes_of(&cam));
        let bg = scene.toc().background.colour;
        let mut rp = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("material ids"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.display.view,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    // A dim version of the scene's background colour: "nothing drawn here".
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: bg[0] as f64 * 0.2,
                        g: bg[1] as f64 * 0.2,
                        b: bg[2] as f64 * 0.2,
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth.view,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        let Some((_, group, count)) = &self.swatches else {
            return;
        };
        rp.set_pipeline(&self.id_pipeline);
        rp.set_bind_group(0, &self.id_camera_group, &[]);
        let stride = self.swatch_stride;
        let count = *count;
        scene.draw_with(&mut rp, |rp, material| {
            // Materials beyond the swatch table (none in a valid pack) reuse the last colour.
            let slot = (material as usize).min(count - 1) as u64;
            rp.set_bind_group(1, group, &[(slot * stride) as u32]);
        });
    }

    /// Copies the display image into the window's image (`encode` when that view is not
    /// sRGB and the shader must encode).
    pub fn present(
        &self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        target: &wgpu::TextureView,
    ) {
        let encode = !self.to_window.format.is_srgb() as u32;
        self.show(
            gpu,
            encoder,
            &self.to_window,
            ShowParams {
                mode: 0,
                scale: 1.0,
                encode,
                pad: 0,
            },
            &self.display.view,
            target,
        );
    }
}

/// Reads an RGBA8 texture back into an image (for screenshots).
pub fn read_rgba8(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> anyhow::Result<image::RgbaImage> {
    let bytes = render::read_texture(device, queue, texture, 4)
        .map_err(|e| anyhow::anyhow!("reading the screenshot back: {e}"))?;
    let (w, h) = (texture.width(), texture.height());
    image::RgbaImage::from_raw(w, h, bytes)
        .ok_or_else(|| anyhow::anyhow!("screenshot of {w}x{h} has the wrong size"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_display_shader_validates() {
        let module = naga::front::wgsl::parse_str(&display_shader()).expect("parses");
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .expect("validates");
        let sizes = [("Show", 16), ("IdCamera", 80), ("Swatch", 16)];
        for (name, size) in sizes {
            let ty = module
                .types
                .iter()
                .find(|(_, t)| t.name.as_deref() == Some(name))
                .unwrap_or_else(|| panic!("{name} declared"));
            let mut layouter = naga::proc::Layouter::default();
            layouter.update(module.to_ctx()).unwrap();
            assert_eq!(layouter[ty.0].size, size, "{name}");
        }
        assert_eq!(std::mem::size_of::<ShowParams>(), 16);
        assert_eq!(std::mem::size_of::<IdCamera>(), 80);
    }

    #[test]
    fn neighbouring_materials_get_distinct_colours() {
        let colours: Vec<[u8; 3]> = (0..24).map(material_colour).collect();
        for (i, a) in colours.iter().enumerate() {
            for b in &colours[i + 1..(i + 6).min(colours.len())] {
                let d: i32 = a
                    .iter()
                    .zip(b)
                    .map(|(x, y)| (*x as i32 - *y as i32).abs())
                    .sum();
                assert!(d > 60, "{i}: {a:?} vs {b:?}");
            }
        }
    }

    #[test]
    fn view_keys_round_trip() {
        for m in ViewMode::ALL {
            assert_eq!(ViewMode::from_key(m.key()), Some(m));
        }
    }
}
