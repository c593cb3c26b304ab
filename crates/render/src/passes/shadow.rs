//! The shadow maps: opaque geometry drawn depth-only from the light into the layers of one
//! array (`shadow.wgsl`), and a grey view of a layer for the pass views (`shadow_view.wgsl`).
//! The maps do not depend on the camera, so the frame graph draws them only when the light,
//! the geometry or the layout changed.

use pack::MaterialClass;

use super::{Colour, HDR, draw_fullscreen, fullscreen_pipeline, uniform_buffer, uniform_entry};
use crate::scene::vertex_layout;
use crate::shadows::ShadowLayout;
use crate::{Scene, shaders, uniforms};

pub(crate) const SHADOW_DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// Side of the shadow-map view target, in pixels.
pub const SHADOW_VIEW_SIZE: u32 = 512;

/// The array of maps and what drawing into each layer needs.
pub(crate) struct Maps {
    /// All layers, for the lit pass.
    pub view: wgpu::TextureView,
    layers: Vec<(wgpu::TextureView, wgpu::Buffer, wgpu::BindGroup)>,
    /// Per layer, whether it draws the backed windows' uncut walls too.
    uncut_walls: Vec<bool>,
    pub size: u32,
    /// Bumped when the texture is recreated, so bind groups holding it are rebuilt.
    pub version: u64,
}

pub struct ShadowPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    view_pipeline: wgpu::RenderPipeline,
    view_layout: wgpu::BindGroupLayout,
    view_uniforms: wgpu::Buffer,
    pub(crate) maps: Option<Maps>,
    /// One depth texel standing in for the maps when no window has one.
    pub(crate) placeholder: wgpu::TextureView,
    versions: u64,
}

/// Which geometry casts shadows: everything opaque (glass lets light through, the backdrop
/// is painted far away).
pub(crate) fn casts_shadow(class: MaterialClass) -> bool {
    !class.is_window() && class != MaterialClass::Background
}

impl ShadowPass {
    pub(crate) fn new(device: &wgpu::Device) -> Self {
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow pass"),
            entries: &[uniform_entry(
                0,
                std::mem::size_of::<uniforms::ShadowPass>(),
            )],
        });
        let module = shaders::module(device, "shadow.wgsl");
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shadow pass"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("shadow pass"),
            layout: Some(&pl),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[Some(vertex_layout())],
            },
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::TriangleList,
                // Single-sided quads (walls) block light from either side.
                cull_mode: None,
                ..Default::default()
            },
            // No raster bias: the lit pass biases each comparison by the receiver's own slope
            // (and the viewer can tune it live), see `shadow_visibility` in `lit.wgsl`.
            depth_stencil: Some(wgpu::DepthStencilState {
                format: SHADOW_DEPTH,
                depth_write_enabled: Some(true),
                depth_compare: Some(wgpu::CompareFunction::Less),
                stencil: Default::default(),
                bias: Default::default(),
            }),
            multisample: Default::default(),
            fragment: None,
            multiview_mask: None,
            cache: None,
        });
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shadow view"),
            entries: &[
                uniform_entry(0, std::mem::size_of::<uniforms::ShadowView>()),
                depth_array_entry(1),
            ],
        });
        let view_pipeline = fullscreen_pipeline(device, &view_layout, "shadow_view.wgsl", HDR);
        let placeholder = depth_array(device, 1, 1, "shadow map placeholder")
            .create_view(&array_view_descriptor());
        Self {
            pipeline,
            layout,
            view_pipeline,
            view_layout,
            view_uniforms: uniform_buffer(
                device,
                "shadow view",
                std::mem::size_of::<uniforms::ShadowView>(),
            ),
            maps: None,
            placeholder,
            versions: 0,
        }
    }

    /// Makes the array hold `layout`'s layers at `size` texels, reusing it when it already
    /// does, and writes each layer's matrix. A texture is kept even with no layers, so the
    /// view of it stays valid.
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layout: &ShadowLayout,
        size: u32,
    ) {
        let layers = layout.layers.len() as u32;
        if layers == 0 {
            return;
        }
        let fits = self
            .maps
            .as_ref()
            .is_some_and(|m| m.size == size && m.layers.len() as u32 == layers);
        if !fits {
            let texture = depth_array(device, size, layers, "shadow maps");
            let view = texture.create_view(&array_view_descriptor());
            let per_layer = (0..layers)
                .map(|l| {
                    let v = texture.create_view(&wgpu::TextureViewDescriptor {
                        label: Some("shadow map layer"),
                        dimension: Some(wgpu::TextureViewDimension::D2),
                        base_array_layer: l,
                        array_layer_count: Some(1),
                        ..Default::default()
                    });
                    let buffer = uniform_buffer(
                        device,
                        "shadow layer",
                        std::mem::size_of::<uniforms::ShadowPass>(),
                    );
                    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
                        label: Some("shadow layer"),
                        layout: &self.layout,
                        entries: &[wgpu::BindGroupEntry {
                            binding: 0,
                            resource: buffer.as_entire_binding(),
                        }],
                    });
                    (v, buffer, group)
                })
                .collect();
            self.versions += 1;
            self.maps = Some(Maps {
                view,
                layers: per_layer,
                uncut_walls: Vec::new(),
                size,
                version: self.versions,
            });
        }
        let maps = self.maps.as_mut().expect("created above");
        maps.uncut_walls = layout.layers.iter().map(|l| l.uncut_walls).collect();
        for (layer, (_, buffer, _)) in layout.layers.iter().zip(&maps.layers) {
            let u = uniforms::ShadowPass {
                view_proj: layer.view_proj.to_cols_array_2d(),
                origin: layer.origin.as_vec3().extend(0.0).to_array(),
            };
            queue.write_buffer(buffer, 0, bytemuck::bytes_of(&u));
        }
    }

    /// The maps' view for the lit pass (the placeholder when there are none) and its version.
    pub(crate) fn binding(&self) -> (&wgpu::TextureView, u64) {
        match &self.maps {
            Some(m) => (&m.view, m.version),
            None => (&self.placeholder, 0),
        }
    }

    /// The layer size the lit pass addresses (1 for the placeholder).
    pub(crate) fn binding_size(&self) -> u32 {
        self.maps.as_ref().map_or(1, |m| m.size)
    }

    /// Draws every layer; the timestamps bracket all of them.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene: &Scene,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let Some(maps) = &self.maps else {
            return;
        };
        let last = maps.layers.len().saturating_sub(1);
        for (i, (view, _, group)) in maps.layers.iter().enumerate() {
            // Only the first layer's pass writes the start and the last's the end: wgpu refuses
            // a pass's timestamp writes with neither, so the layers between get none (three
            // or more layers, a lamp's maps, failed the frame under `--bench`).
            let ts = timestamps
                .as_ref()
                .filter(|_| i == 0 || i == last)
                .map(|t| wgpu::RenderPassTimestampWrites {
                    query_set: t.query_set,
                    beginning_of_pass_write_index: if i == 0 {
                        t.beginning_of_pass_write_index
                    } else {
                        None
                    },
                    end_of_pass_write_index: if i == last {
                        t.end_of_pass_write_index
                    } else {
                        None
                    },
                });
            let mut rp = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("shadow map"),
                color_attachments: &[],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Store,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: ts,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            rp.set_bind_group(0, group, &[]);
            let uncut_walls = maps.uncut_walls.get(i).copied().unwrap_or(false);
            scene.draw_casters(&mut rp, &self.pipeline, uncut_walls);
        }
    }

    /// Draws `layer` of the maps as grey into `target` (an HDR view target).
    pub(crate) fn record_view(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        layer: u32,
        target: &wgpu::TextureView,
    ) {
        let (view, size, layer) = match &self.maps {
            Some(m) => (&m.view, m.size, layer.min(m.layers.len() as u32 - 1)),
            None => (&self.placeholder, 1, 0),
        };
        let u = uniforms::ShadowView {
            params: [layer, size, 0, 0],
        };
        queue.write_buffer(&self.view_uniforms, 0, bytemuck::bytes_of(&u));
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shadow view"),
            layout: &self.view_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.view_uniforms.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: wgpu::BindingResource::TextureView(view),
                },
            ],
        });
        let target = Colour {
            view: target,
            clear: wgpu::Color::BLACK,
        };
        draw_fullscreen(
            encoder,
            "shadow view",
            &self.view_pipeline,
            &group,
            target,
            None,
        );
    }
}

fn depth_array(device: &wgpu::Device, size: u32, layers: u32, label: &str) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: layers,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: SHADOW_DEPTH,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    })
}

fn array_view_descriptor() -> wgpu::TextureViewDescriptor<'static> {
    wgpu::TextureViewDescriptor {
        label: Some("shadow maps"),
        dimension: Some(wgpu::TextureViewDimension::D2Array),
        aspect: wgpu::TextureAspect::DepthOnly,
        ..Default::default()
    }
}

/// A depth 2D array read by the fragment stage (the lit pass and the shadow view).
pub(crate) fn depth_array_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Depth,
            view_dimension: wgpu::TextureViewDimension::D2Array,
            multisampled: false,
        },
        count: None,
    }
}
