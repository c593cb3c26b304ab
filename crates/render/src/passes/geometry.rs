//! Passes 0–3: scene geometry drawn with one shader each over the frame and material groups.

use pack::MaterialClass;

use super::{Colour, DEPTH, HDR, begin, joined};
use crate::scene::vertex_layout;
use crate::{Scene, shaders};

/// One geometry pass: its pipelines, and which draws each material class with.
pub struct GeometryPass {
    label: &'static str,
    /// How many colour targets (all HDR) its shaders write.
    targets: usize,
    pipelines: Vec<wgpu::RenderPipeline>,
    /// The same fragment entries for materials with a texture padded to whole blocks
    /// (`PADDED_TEXTURES` set); empty where the scene has none.
    padded: Vec<wgpu::RenderPipeline>,
    /// The index in `pipelines` (and `padded`) a class is drawn with; `None`: not drawn in this
    /// pass.
    pick: fn(MaterialClass) -> Option<usize>,
}

impl GeometryPass {
    /// Pass 0: background-class geometry alone into its own target, unoccluded (refraction
    /// reads it).
    pub(crate) fn background(
        device: &wgpu::Device,
        layout: &wgpu::PipelineLayout,
        padded: bool,
    ) -> Self {
        Self::new(
            device,
            layout,
            padded,
            "pass0 background",
            "background.wgsl",
            1,
            &["fs_main"],
            |c| (c == MaterialClass::Background).then_some(0),
        )
    }

    /// Pass 1: window colour, everything else black; also lays down the depth passes 2–3
    /// reuse. Its second target is what the god rays blur: the colour times the share of the
    /// light each window passes.
    pub(crate) fn window_mask(
        device: &wgpu::Device,
        layout: &wgpu::PipelineLayout,
        padded: bool,
    ) -> Self {
        Self::new(
            device,
            layout,
            padded,
            "pass1 window mask",
            "windows.wgsl",
            2,
            &["fs_main", "fs_occluder"],
            |c| Some(if c.is_window() { 0 } else { 1 }),
        )
    }

    /// Pass 2: window normal-map perturbation in view space, everything else zero (the clear
    /// value: only windows are drawn, against pass 1's depth).
    pub(crate) fn window_normals(
        device: &wgpu::Device,
        layout: &wgpu::PipelineLayout,
        padded: bool,
    ) -> Self {
        Self::new(
            device,
            layout,
            padded,
            "pass2 window normals",
            "normals.wgsl",
            1,
            &["fs_main"],
            |c| c.is_window().then_some(0),
        )
    }

    /// Pass 3: the lit scene, windows black, projectors through the windows.
    pub(crate) fn lit(device: &wgpu::Device, layout: &wgpu::PipelineLayout, padded: bool) -> Self {
        Self::new(
            device,
            layout,
            padded,
            "pass3 lit",
            "lit.wgsl",
            1,
            &["fs_main", "fs_window", "fs_background"],
            |c| {
                Some(match c {
                    c if c.is_window() => 1,
                    MaterialClass::Background => 2,
                    _ => 0,
                })
            },
        )
    }

    /// A pass whose pipelines share `shader`'s vertex stage (so every pass computes the same
    /// depths) and differ in their fragment entry points; with `padded`, each entry twice.
    #[allow(clippy::too_many_arguments)]
    fn new(
        device: &wgpu::Device,
        layout: &wgpu::PipelineLayout,
        padded: bool,
        label: &'static str,
        shader: &'static str,
        targets: usize,
        fragments: &[&str],
        pick: fn(MaterialClass) -> Option<usize>,
    ) -> Self {
        let module = shaders::module(device, shader);
        // Side by side, as the passes are (`Renderer::new`).
        let variants: &[bool] = if padded { &[false, true] } else { &[false] };
        let mut pipelines: Vec<_> = std::thread::scope(|s| {
            let module = &module;
            let handles: Vec<_> = variants
                .iter()
                .flat_map(|&p| fragments.iter().map(move |f| (p, f)))
                .map(|(p, f)| {
                    s.spawn(move || {
                        geometry_pipeline(device, layout, shader, module, f, targets, p)
                    })
                })
                .collect();
            handles.into_iter().map(joined).collect()
        });
        let padded = pipelines.split_off(fragments.len());
        Self {
            label,
            targets,
            pipelines,
            padded,
            pick,
        }
    }

    /// Draws the scene's ranges this pass takes into `targets` (as many as its shaders
    /// write), testing against `depth` (cleared first when `clear_depth`, else kept from an
    /// earlier pass).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        targets: &[Colour<'_>],
        depth: &wgpu::TextureView,
        clear_depth: bool,
        frame: &wgpu::BindGroup,
        scene: &Scene,
        timestamps: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let depth = wgpu::RenderPassDepthStencilAttachment {
            view: depth,
            depth_ops: Some(wgpu::Operations {
                load: if clear_depth {
                    wgpu::LoadOp::Clear(1.0)
                } else {
                    wgpu::LoadOp::Load
                },
                store: wgpu::StoreOp::Store,
            }),
            stencil_ops: None,
        };
        debug_assert_eq!(targets.len(), self.targets, "{}", self.label);
        let mut rp = begin(encoder, self.label, targets, Some(depth), timestamps);
        rp.set_bind_group(0, frame, &[]);
        scene.draw(&mut rp, |class, padded| {
            let set = if padded && !self.padded.is_empty() {
                &self.padded
            } else {
                &self.pipelines
            };
            (self.pick)(class).map(|i| &set[i])
        });
    }
}

fn geometry_pipeline(
    device: &wgpu::Device,
    layout: &wgpu::PipelineLayout,
    shader: &'static str,
    module: &wgpu::ShaderModule,
    fragment: &str,
    targets: usize,
    padded: bool,
) -> wgpu::RenderPipeline {
    let formats = vec![Some(wgpu::ColorTargetState::from(HDR)); targets];
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(shader),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
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
            module,
            entry_point: Some(fragment),
            compilation_options: wgpu::PipelineCompilationOptions {
                constants: &[("PADDED_TEXTURES", f64::from(u8::from(padded)))],
                ..Default::default()
            },
            targets: &formats,
        }),
        multiview_mask: None,
        cache: None,
    })
}
