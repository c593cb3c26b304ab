//! The frame graph: which passes run this frame, their targets, timing and capture.

use glam::Vec3;

use crate::capture::{f16_to_f32, read_buffer, read_texture};
use crate::passes::{
    Colour, CompositeInputs, CompositePass, DEPTH, GeometryPass, GodRayPass, HDR, SHADOW_VIEW_SIZE,
    ShadowPass, SkyPass, frame_layout, geometry_layout, joined, uniform_buffer,
};
use crate::shadows::ShadowLayout;
use crate::uniforms;
use crate::view::{
    GodRaySettings, LightGeometry, View, god_ray_uniforms, window_projector, window_relative_to,
};
use crate::{Gpu, RenderError, Scene};

/// The passes in recording order: the design's numbered passes 0–4, with the unnumbered god
/// rays between 3 and 4 (see [`PassId::name`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum PassId {
    Shadows,
    Background,
    WindowMask,
    WindowNormals,
    Lit,
    GodRays,
    Composite,
}

impl PassId {
    pub const ALL: [PassId; 7] = [
        Self::Shadows,
        Self::Background,
        Self::WindowMask,
        Self::WindowNormals,
        Self::Lit,
        Self::GodRays,
        Self::Composite,
    ];

    pub fn name(self) -> &'static str {
        match self {
            Self::Shadows => "shadow maps",
            Self::Background => "0 background",
            Self::WindowMask => "1 window mask",
            Self::WindowNormals => "2 window normals",
            Self::Lit => "3 lit scene",
            Self::GodRays => "god rays",
            Self::Composite => "4 composite",
        }
    }
}

/// Intermediate images that can be read back (and viewed by the interactive viewer).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TargetId {
    Background,
    WindowMask,
    WindowNormals,
    Lit,
    GodRays,
    /// A grey view of the first shadow map (near the light white), [`SHADOW_VIEW_SIZE`] square.
    ShadowMap,
}

impl TargetId {
    pub const ALL: [TargetId; 6] = [
        Self::Background,
        Self::WindowMask,
        Self::WindowNormals,
        Self::Lit,
        Self::GodRays,
        Self::ShadowMap,
    ];

    /// The pass that draws this target.
    pub fn pass(self) -> PassId {
        match self {
            Self::Background => PassId::Background,
            Self::WindowMask => PassId::WindowMask,
            Self::WindowNormals => PassId::WindowNormals,
            Self::Lit => PassId::Lit,
            Self::GodRays => PassId::GodRays,
            Self::ShadowMap => PassId::Shadows,
        }
    }

    pub fn file_stem(self) -> &'static str {
        match self {
            Self::Background => "pass0-background",
            Self::WindowMask => "pass1-window-mask",
            Self::WindowNormals => "pass2-window-normals",
            Self::Lit => "pass3-lit",
            Self::GodRays => "god-rays",
            Self::ShadowMap => "shadow-map",
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    pub god_rays: GodRaySettings,
    /// Shift of the refracted image per unit of normal perturbation, in screen heights (the
    /// composite samples at `uv + (n.x / aspect, -n.y) * strength`; tests/tests/analytic.rs).
    pub refraction_strength: f32,
    /// Scale applied before tone mapping.
    pub exposure: f32,
    /// Linear RGB ambient light.
    pub ambient: [f32; 3],
    /// Skip the god-ray pass when its fade is zero. Tests turn this off to check that the
    /// shader itself outputs exactly zero then.
    pub skip_invisible_god_rays: bool,
    pub shadows: ShadowSettings,
}

/// Occlusion of the window light by shadow maps.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowSettings {
    /// Off: the window light passes through stone, as plain projective texturing does.
    pub enabled: bool,
    /// Depth bias in texels of the receiving surface's slope (plus half a texel); larger
    /// values cure acne and detach shadows from their casters.
    pub bias: f32,
    /// Smallest filter σ in texels: the softness even a hard edge gets.
    pub filter: f32,
    /// Side of the sun's map in texels; a lamp's maps (one per window) are half as wide.
    pub map_size: u32,
}

impl Default for ShadowSettings {
    fn default() -> Self {
        Self {
            enabled: true,
            bias: 1.0,
            filter: 0.5,
            map_size: 2048,
        }
    }
}

impl ShadowSettings {
    /// The layer size for `light`.
    pub fn layer_size(&self, light: &pack::Light) -> u32 {
        let size = self.map_size.clamp(16, 8192);
        match light.kind {
            pack::LightKind::Directional { .. } => size,
            pack::LightKind::Point { .. } | pack::LightKind::Spot { .. } => (size / 2).max(16),
        }
    }
}

impl Default for Settings {
    fn default() -> Self {
        Self {
            god_rays: GodRaySettings::default(),
            refraction_strength: 0.08,
            exposure: 1.0,
            ambient: [0.08, 0.08, 0.09],
            skip_invisible_god_rays: true,
            shadows: ShadowSettings::default(),
        }
    }
}

/// How per-pass times were measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TimingMethod {
    /// GPU timestamp queries around each pass.
    GpuTimestamps,
    /// Each pass submitted alone and waited for: CPU wall time, including submission overhead.
    CpuWallClock,
    None,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PassTime {
    pub pass: PassId,
    /// Milliseconds, when recorded and measured.
    pub ms: Option<f64>,
    /// Why the pass was not recorded.
    pub skipped: Option<&'static str>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct FrameReport {
    pub method: TimingMethod,
    pub passes: Vec<PassTime>,
    /// The god rays' view fade (0 when not drawn).
    pub god_ray_fade: f32,
}

struct Target {
    texture: wgpu::Texture,
    view: wgpu::TextureView,
}

fn target(
    device: &wgpu::Device,
    label: &str,
    size: (u32, u32),
    format: wgpu::TextureFormat,
) -> Target {
    let texture = device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d {
            width: size.0,
            height: size.1,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = texture.create_view(&Default::default());
    Target { texture, view }
}

struct Targets {
    size: (u32, u32),
    rays_size: (u32, u32),
    background: Target,
    mask: Target,
    /// Pass 1's second target: each window's colour times the share of the light it passes,
    /// which the god rays blur (a window the light does not come through casts no shaft).
    rays_source: Target,
    normals: Target,
    lit: Target,
    rays: Target,
    depth: Target,
    shadow_view: Target,
    output: Option<Target>,
}

impl Targets {
    fn new(
        device: &wgpu::Device,
        size: (u32, u32),
        rays_scale: f32,
        output: Option<wgpu::TextureFormat>,
    ) -> Self {
        let scale = if rays_scale.is_finite() {
            rays_scale.clamp(0.125, 1.0)
        } else {
            1.0
        };
        let rays_size = (
            ((size.0 as f32 * scale).round() as u32).max(1),
            ((size.1 as f32 * scale).round() as u32).max(1),
        );
        Self {
            size,
            rays_size,
            background: target(device, "pass0 background", size, HDR),
            mask: target(device, "pass1 window mask", size, HDR),
            rays_source: target(device, "pass1 god-ray source", size, HDR),
            normals: target(device, "pass2 window normals", size, HDR),
            lit: target(device, "pass3 lit", size, HDR),
            rays: target(device, "god rays", rays_size, HDR),
            depth: target(device, "depth", size, DEPTH),
            shadow_view: target(
                device,
                "shadow map view",
                (SHADOW_VIEW_SIZE, SHADOW_VIEW_SIZE),
                HDR,
            ),
            output: output.map(|f| target(device, "output", size, f)),
        }
    }

    fn get(&self, id: TargetId) -> &Target {
        match id {
            TargetId::Background => &self.background,
            TargetId::WindowMask => &self.mask,
            TargetId::WindowNormals => &self.normals,
            TargetId::Lit => &self.lit,
            TargetId::GodRays => &self.rays,
            TargetId::ShadowMap => &self.shadow_view,
        }
    }
}

struct Timestamps {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
}

/// Everything one pass's recording reads.
#[derive(Clone, Copy)]
struct Recording<'a> {
    gpu: &'a Gpu,
    scene: &'a Scene,
    plan: &'a Plan,
    output: &'a wgpu::TextureView,
    timed: bool,
}

/// What this frame records, decided from the scene and the view.
struct Plan {
    /// The shadow maps are drawn this frame (they were missing or stale).
    shadows: bool,
    windows: bool,
    refraction: bool,
    god_rays: bool,
    fade: f32,
    passes: Vec<PassTime>,
}

pub struct Renderer {
    settings: Settings,
    output_format: wgpu::TextureFormat,
    targets: Targets,
    frame_layout: wgpu::BindGroupLayout,
    frame_buffer: wgpu::Buffer,
    /// Room for the most windows a scene drawn so far had; grown (and the frame group rebuilt)
    /// when a scene has more.
    windows_buffer: wgpu::Buffer,
    /// The windows' distinct planes ([`uniforms::WindowPlane`]), grown likewise.
    planes_buffer: wgpu::Buffer,
    /// The frame bind group and the (scene generation, shadow-map version, windows and planes
    /// buffer sizes) it was built for.
    frame_group: Option<((u64, u64, u64, u64), wgpu::BindGroup)>,
    linear_clamp: wgpu::Sampler,
    shadow_cmp: wgpu::Sampler,
    nearest_clamp: wgpu::Sampler,
    background: GeometryPass,
    mask: GeometryPass,
    normals: GeometryPass,
    lit: GeometryPass,
    rays: GodRayPass,
    composite: CompositePass,
    shadow: ShadowPass,
    /// Made with the first scene that has a panorama.
    sky: Option<SkyPass>,
    shadow_layout: ShadowLayout,
    /// What the maps hold: (scene id, the scene's shadow generation, settings) when drawn.
    shadows_drawn: Option<(u64, u64, ShadowSettings)>,
    timestamps: Option<Timestamps>,
    frame_index: u32,
}

const HEADLESS_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

impl Renderer {
    /// A renderer writing into its own sRGB image of `width`×`height` (read it with
    /// [`Renderer::read_output`]).
    pub fn headless(
        gpu: &Gpu,
        scene: &Scene,
        width: u32,
        height: u32,
        settings: Settings,
    ) -> Result<Self, RenderError> {
        Self::new(gpu, scene, width, height, HEADLESS_FORMAT, true, settings)
    }

    /// A renderer whose composite writes `output_format` (a surface's, say) into a view the
    /// caller passes to [`Renderer::render_to`]. `own_output` also allocates a headless image.
    pub fn new(
        gpu: &Gpu,
        scene: &Scene,
        width: u32,
        height: u32,
        output_format: wgpu::TextureFormat,
        own_output: bool,
        settings: Settings,
    ) -> Result<Self, RenderError> {
        let max = gpu.device.limits().max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(RenderError::Size { width, height, max });
        }
        let device = &gpu.device;
        let frame_layout = frame_layout(device);
        let layout = geometry_layout(device, &frame_layout, &scene.material_layout);
        let clamp_sampler = |filter| {
            device.create_sampler(&wgpu::SamplerDescriptor {
                mag_filter: filter,
                min_filter: filter,
                mipmap_filter: wgpu::MipmapFilterMode::Linear,
                ..Default::default()
            })
        };
        let timestamps = gpu.timestamps.then(|| {
            let count = 2 * PassId::ALL.len() as u32;
            Timestamps {
                queries: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass times"),
                    ty: wgpu::QueryType::Timestamp,
                    count,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("pass times"),
                    size: count as u64 * 8,
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                readback: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("pass times readback"),
                    size: count as u64 * 8,
                    usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                    mapped_at_creation: false,
                }),
            }
        });
        // A GPU driver compiles each pipeline when it is created: one after another they took
        // 380 ms on a fresh H100 (no driver shader cache), where side by side they take about
        // the longest one's time. lavapipe compiles at the first draw instead.
        let padded = scene.has_padded_textures();
        let (background, mask, normals, lit, rays, composite, shadow) = std::thread::scope(|s| {
            let layout = &layout;
            let background = s.spawn(|| GeometryPass::background(device, layout, padded));
            let mask = s.spawn(|| GeometryPass::window_mask(device, layout, padded));
            let normals = s.spawn(|| GeometryPass::window_normals(device, layout, padded));
            let lit = s.spawn(|| GeometryPass::lit(device, layout, padded));
            let rays = s.spawn(|| GodRayPass::new(device));
            let composite = s.spawn(|| CompositePass::new(device, output_format));
            let shadow = ShadowPass::new(device);
            (
                joined(background),
                joined(mask),
                joined(normals),
                joined(lit),
                joined(rays),
                joined(composite),
                shadow,
            )
        });
        Ok(Self {
            targets: Targets::new(
                device,
                (width, height),
                settings.god_rays.resolution_scale,
                own_output.then_some(output_format),
            ),
            settings,
            output_format,
            frame_buffer: uniform_buffer(device, "frame", std::mem::size_of::<uniforms::Frame>()),
            windows_buffer: storage_buffer(device, "windows", uniforms::Windows::buffer_size(1)),
            planes_buffer: storage_buffer(device, "window planes", planes_size(1)),
            frame_layout,
            frame_group: None,
            linear_clamp: clamp_sampler(wgpu::FilterMode::Linear),
            nearest_clamp: clamp_sampler(wgpu::FilterMode::Nearest),
            shadow_cmp: device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("shadow comparison"),
                mag_filter: wgpu::FilterMode::Linear,
                min_filter: wgpu::FilterMode::Linear,
                compare: Some(wgpu::CompareFunction::LessEqual),
                ..Default::default()
            }),
            background,
            mask,
            normals,
            lit,
            rays,
            composite,
            shadow,
            sky: None,
            shadow_layout: ShadowLayout::default(),
            shadows_drawn: None,
            timestamps,
            frame_index: 0,
        })
    }

    pub fn settings(&self) -> &Settings {
        &self.settings
    }

    /// Changes settings; targets are recreated when the god-ray resolution changes.
    pub fn set_settings(&mut self, gpu: &Gpu, settings: Settings) {
        let rescale = settings.god_rays.resolution_scale != self.settings.god_rays.resolution_scale;
        self.settings = settings;
        if rescale {
            self.resize(gpu, self.targets.size.0, self.targets.size.1);
        }
    }

    pub fn size(&self) -> (u32, u32) {
        self.targets.size
    }

    /// An intermediate target's view (HDR, `Rgba16Float`), for display. It holds the last
    /// frame that recorded its pass; a pass the [`FrameReport`] lists as skipped left stale
    /// contents. The god-ray target is smaller when its resolution scale is below 1.
    pub fn target_view(&self, id: TargetId) -> &wgpu::TextureView {
        &self.targets.get(id).view
    }

    /// Recreates the targets for a new output size (a window resize).
    pub fn resize(&mut self, gpu: &Gpu, width: u32, height: u32) {
        let own = self.targets.output.is_some().then_some(self.output_format);
        self.targets = Targets::new(
            &gpu.device,
            (width.max(1), height.max(1)),
            self.settings.god_rays.resolution_scale,
            own,
        );
    }

    /// The view for a pack camera at this renderer's aspect ratio.
    pub fn view_for(&self, camera: &pack::Camera) -> View {
        View::from_camera(
            camera,
            self.targets.size.0 as f32 / self.targets.size.1 as f32,
        )
    }

    /// Forgets that the shadow maps are up to date, so the next frame draws them again (for
    /// timing the shadow pass; they are otherwise drawn only when the light or geometry changes).
    pub fn invalidate_shadow_maps(&mut self) {
        self.shadows_drawn = None;
    }

    /// True when the last frame had shadow maps (drawn then or kept from before).
    pub fn has_shadow_maps(&self) -> bool {
        !self.shadow_layout.layers.is_empty()
    }

    /// The shadow maps' layout of the last frame: which windows have a map, and where.
    pub fn shadow_layout(&self) -> &ShadowLayout {
        &self.shadow_layout
    }

    /// Lays the shadow maps out for the scene's light and makes their texture fit.
    fn update_shadows(&mut self, gpu: &Gpu, scene: &Scene) {
        let toc = scene.toc();
        let Some(light) = &toc.light else {
            self.shadow_layout = ShadowLayout::default();
            return;
        };
        // Over the projectors' frames: a map must cover the light's penumbra past a window's
        // edge as far as its projector carries it.
        let layout = |size| match self.settings.shadows.enabled {
            true if scene.has_windows() => crate::shadows::layout(
                scene.projector_frames(),
                scene.window_shadows(),
                light,
                scene.occluder_bounds(),
                scene.beyond_windows(),
                size,
            ),
            _ => ShadowLayout::default(),
        };
        let wanted = self.settings.shadows.layer_size(light);
        let mut shadow_layout = layout(wanted);
        // A lamp has a map per window it shines through: many windows share the budget.
        let size = crate::shadows::fitted_layer_size(wanted, shadow_layout.layers.len());
        if size < wanted {
            shadow_layout = layout(size);
        }
        self.shadow_layout = shadow_layout;
        self.shadow
            .prepare(&gpu.device, &gpu.queue, &self.shadow_layout, size);
    }

    /// What the maps' contents depend on (bias and filter width are applied when reading).
    fn shadow_key(&self, scene: &Scene) -> (u64, u64, ShadowSettings) {
        let s = self.settings.shadows;
        let drawn = ShadowSettings {
            bias: 0.0,
            filter: 0.0,
            ..s
        };
        (scene.id(), scene.shadow_generation(), drawn)
    }

    fn plan(&self, scene: &Scene, view: &View) -> (Plan, Option<uniforms::GodRays>) {
        let windows = scene.has_windows();
        let refraction =
            windows && scene.has_window_normal_maps() && self.settings.refraction_strength != 0.0;
        let light = scene.toc().light.as_ref();
        let mut rays = None;
        let mut fade = 0.0;
        if let (true, Some(l)) = (windows, light) {
            let geometry = LightGeometry::from_light(l);
            // Over the windows the scene found at load to let the light in: asking each
            // window again (a spot's cone test searches its edges) cost every frame.
            let passing = (scene.toc().windows.iter().enumerate())
                .filter(|(i, _)| scene.window_passes_light(*i))
                .map(|(_, w)| w);
            let colour = Vec3::from(l.colour) * l.intensity * falloff_over(l, passing);
            let (u, f) = god_ray_uniforms(
                &self.settings.god_rays,
                view,
                &geometry,
                colour,
                self.frame_index,
            );
            fade = f;
            if f > 0.0 || !self.settings.skip_invisible_god_rays {
                rays = Some(u);
            }
        }
        let skip = |id, reason: Option<&'static str>| PassTime {
            pass: id,
            ms: None,
            skipped: reason,
        };
        let shadow_skip = if !self.settings.shadows.enabled {
            Some("occlusion off")
        } else if !windows {
            Some("no windows")
        } else if light.is_none() {
            Some("no light")
        } else if self.shadow_layout.layers.is_empty() {
            Some("nothing can block any window's light")
        } else if self.shadows_drawn == Some(self.shadow_key(scene)) {
            Some("up to date: the light and the geometry have not changed")
        } else {
            None
        };
        let passes = vec![
            skip(PassId::Shadows, shadow_skip),
            skip(PassId::Background, None),
            skip(PassId::WindowMask, (!windows).then_some("no windows")),
            skip(
                PassId::WindowNormals,
                if !windows {
                    Some("no windows")
                } else if !refraction {
                    Some("no window normal maps")
                } else {
                    None
                },
            ),
            skip(PassId::Lit, None),
            skip(
                PassId::GodRays,
                if !windows {
                    Some("no windows")
                } else if light.is_none() {
                    Some("no light")
                } else if !scene.light_through_windows() {
                    Some("the light comes in through no window")
                } else if rays.is_none() {
                    Some("light out of view")
                } else {
                    None
                },
            ),
            skip(PassId::Composite, None),
        ];
        (
            Plan {
                shadows: shadow_skip.is_none(),
                windows,
                refraction,
                god_rays: rays.is_some(),
                fade,
                passes,
            },
            rays,
        )
    }

    fn write_uniforms(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        view: &View,
        plan: &Plan,
        rays: Option<uniforms::GodRays>,
    ) {
        let toc = scene.toc();
        let light = toc.light.as_ref();
        // The shaders work relative to the camera (`vs_main` subtracts `camera_pos` from each
        // vertex), so nothing uploaded here carries a large translation that f32 products
        // would have to cancel: far from the origin that loses ~0.01 units.
        let geometry = light.map(|l| LightGeometry::from_light(l).relative_to(view.position));
        if let Some(b) = scene.panorama() {
            let sky = self.sky.get_or_insert_with(|| SkyPass::new(&gpu.device));
            sky.write_uniforms(
                &gpu.queue,
                &uniforms::Sky {
                    clip_to_ray: view.view_proj_relative().inverse().to_cols_array_2d(),
                    scale: [b[0], b[1], b[2], 0.0],
                },
            );
        }
        let mut frame = uniforms::Frame {
            view_proj: view.view_proj_relative().to_cols_array_2d(),
            view: view.rotation().to_cols_array_2d(),
            camera_pos: view.position.extend(1.0).to_array(),
            ambient: [
                self.settings.ambient[0],
                self.settings.ambient[1],
                self.settings.ambient[2],
                0.0,
            ],
            counts: [
                toc.windows.len().min(uniforms::MAX_WINDOWS) as u32,
                !toc.windows.is_empty() as u32,
                0,
                0,
            ],
            shadow: [
                self.settings.shadows.bias.max(0.0),
                self.settings.shadows.filter.max(0.0),
                self.shadow.binding_size() as f32,
                (self.settings.shadows.enabled && !self.shadow_layout.layers.is_empty()) as u32
                    as f32,
            ],
            spot: uniforms::Frame::spot_ramp(light.map(|l| &l.kind)),
            lengths: {
                let (lo, hi) = scene.bounds();
                uniforms::Frame::lengths((hi - lo).length())
            },
            ..Default::default()
        };
        let mut windows = uniforms::Windows::new(toc.windows.len().min(uniforms::MAX_WINDOWS));
        let relative: Vec<pack::Window> = toc
            .windows
            .iter()
            .map(|w| window_relative_to(w, view.position))
            .collect();
        // Where each window's plane is, whatever the light: the lit pass tells inside from
        // outside by them.
        for (i, (slot, w)) in windows.items.iter_mut().zip(&relative).enumerate() {
            let wall = scene.backing_wall(i).unwrap_or(0.0) as f32;
            slot.origin = Vec3::from(w.origin).extend(wall).to_array();
            slot.normal = Vec3::from(w.normal)
                .normalize_or_zero()
                .extend(0.0)
                .to_array();
        }
        if let (Some(l), Some(g)) = (light, geometry) {
            let projector_frames: Vec<pack::Window> = scene
                .projector_frames()
                .iter()
                .map(|w| window_relative_to(w, view.position))
                .collect();
            frame.light_pos = g.homogeneous().to_array();
            let c = Vec3::from(l.colour) * l.intensity;
            let radius = match g {
                LightGeometry::Point { radius, .. } => radius,
                LightGeometry::Directional { .. } => 0.0,
            };
            frame.light_colour = c.extend(radius).to_array();
            let map_size = self.shadow.binding_size();
            for (i, (slot, w)) in windows.items.iter_mut().zip(&projector_frames).enumerate() {
                let mat = &toc.materials[w.material as usize];
                let projector = window_projector(w, &g);
                let tex_slot = scene.projector_slot(mat.projector_texture);
                slot.projector = projector.unwrap_or(glam::Mat4::ZERO).to_cols_array_2d();
                // A window without a projector texture (a pack cooked without textures) still
                // passes light, tinted by its glass colour through the array's white layer.
                let (layer, tint) = match tex_slot {
                    Some(l) => (l, [1.0; 4]),
                    None => {
                        let d = mat.diffuse;
                        (scene.white_projector_layer(), [d[0], d[1], d[2], 1.0])
                    }
                };
                slot.tint = tint;
                // A window the light does not come through (a spot's cone misses it) is left
                // out of the lit pass's loop.
                let passes = projector.is_some() && scene.window_passes_light(i);
                slot.params = [layer, passes as u32, 0, 0];
                if let Some(Some(map)) = self.shadow_layout.windows.get(i) {
                    map_slot(slot, map, view.position);
                    let aperture = projector.and_then(|p| {
                        map.aperture(view.position, p, w, mat.projector_margin, map_size)
                    });
                    // Without one, every tap counts.
                    let (map, bounds) = aperture.map_or(
                        (
                            glam::DMat4::IDENTITY,
                            [f64::MIN, f64::MIN, f64::MAX, f64::MAX],
                        ),
                        |a| (a.map, a.bounds),
                    );
                    slot.aperture = map.as_mat4().to_cols_array_2d();
                    slot.aperture_box = bounds.map(|b| b as f32);
                }
            }
            if let Some(map) = &self.shadow_layout.direct {
                map_slot(&mut windows.direct, map, view.position);
            }
        }
        // The windows the light comes in through first, in their order: the lit pass projects
        // through those alone (`counts.z`), and tests every window's plane (`counts.x`). Each
        // entry carries its own layers, so the order is the buffer's alone; a stable sort keeps
        // the sum over the lit ones in window order. Half a hall's windows face away from the
        // sun, and each lit fragment tested them all.
        // Planes before the sort, while the entries are in window order.
        let buildings: Vec<Option<[Vec3; 2]>> = (0..windows.items.len())
            .map(|i| {
                scene.window_building(i).map(|[lo, hi]| {
                    let rel = |c: Vec3| (c.as_dvec3() - view.position.as_dvec3()).as_vec3();
                    [rel(lo), rel(hi)]
                })
            })
            .collect();
        let planes = uniforms::WindowPlane::distinct(&windows.items, &buildings, frame.lengths[1]);
        windows.items.sort_by_key(|w| w.params[1] == 0);
        frame.counts[2] = windows.items.iter().filter(|w| w.params[1] != 0).count() as u32;
        frame.counts[3] = planes.len() as u32;
        gpu.queue
            .write_buffer(&self.frame_buffer, 0, bytemuck::bytes_of(&frame));
        let needed = uniforms::Windows::buffer_size(windows.items.len());
        if self.windows_buffer.size() < needed {
            self.windows_buffer = storage_buffer(&gpu.device, "windows", needed);
        }
        gpu.queue
            .write_buffer(&self.windows_buffer, 0, &windows.bytes());
        if self.planes_buffer.size() < planes_size(planes.len()) {
            self.planes_buffer =
                storage_buffer(&gpu.device, "window planes", planes_size(planes.len()));
        }
        if !planes.is_empty() {
            gpu.queue
                .write_buffer(&self.planes_buffer, 0, bytemuck::cast_slice(&planes));
        }
        if let Some(r) = rays {
            self.rays.write_uniforms(&gpu.queue, &r);
        }
        let comp = uniforms::Composite {
            params: [
                self.settings.refraction_strength,
                self.settings.exposure,
                self.targets.size.0 as f32 / self.targets.size.1 as f32,
                0.0,
            ],
            flags: [
                plan.refraction as u32,
                plan.god_rays as u32,
                (!self.output_format.is_srgb()) as u32,
                plan.windows as u32,
            ],
        };
        self.composite.write_uniforms(&gpu.queue, &comp);
        let (maps, maps_version) = self.shadow.binding();
        let key = (
            scene.generation(),
            maps_version,
            self.windows_buffer.size(),
            self.planes_buffer.size(),
        );
        if self.frame_group.as_ref().map(|(g, _)| *g) != Some(key) {
            let entries = [
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: self.frame_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: self.windows_buffer.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: wgpu::BindingResource::TextureView(scene.projector_array()),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: wgpu::BindingResource::Sampler(&self.linear_clamp),
                },
                wgpu::BindGroupEntry {
                    binding: 4,
                    resource: wgpu::BindingResource::TextureView(maps),
                },
                wgpu::BindGroupEntry {
                    binding: 5,
                    resource: wgpu::BindingResource::Sampler(&self.shadow_cmp),
                },
                wgpu::BindGroupEntry {
                    binding: 6,
                    resource: self.planes_buffer.as_entire_binding(),
                },
            ];
            let group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("frame"),
                layout: &self.frame_layout,
                entries: &entries,
            });
            self.frame_group = Some((key, group));
        }
    }

    /// The panorama where the pass left the far plane, once the scene has one with a level in.
    fn record_sky(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        gpu: &Gpu,
        scene: &Scene,
        target: &wgpu::TextureView,
        depth: &wgpu::TextureView,
    ) {
        if let (Some(sky), Some(panorama)) = (&self.sky, scene.panorama_view()) {
            sky.record(encoder, &gpu.device, panorama, target, depth);
        }
    }

    fn timestamp_writes(&self, pass: PassId) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let i = PassId::ALL.iter().position(|&p| p == pass).unwrap_or(0) as u32;
        self.timestamps
            .as_ref()
            .map(|t| wgpu::RenderPassTimestampWrites {
                query_set: &t.queries,
                beginning_of_pass_write_index: Some(2 * i),
                end_of_pass_write_index: Some(2 * i + 1),
            })
    }

    /// Records one pass: the frame graph's part is which targets each pass reads and writes.
    fn record(&self, pass: PassId, encoder: &mut wgpu::CommandEncoder, rec: &Recording<'_>) {
        let Recording {
            gpu,
            scene,
            plan,
            output,
            timed,
        } = *rec;
        let ts = if timed {
            self.timestamp_writes(pass)
        } else {
            None
        };
        let t = &self.targets;
        let frame = &self.frame_group.as_ref().expect("uniforms written").1;
        let background = {
            let c = scene.toc().background.colour;
            wgpu::Color {
                r: c[0] as f64,
                g: c[1] as f64,
                b: c[2] as f64,
                a: 1.0,
            }
        };
        fn into(target: &Target, clear: wgpu::Color) -> Colour<'_> {
            Colour {
                view: &target.view,
                clear,
            }
        }
        let clear = wgpu::Color::TRANSPARENT;
        let depth = &t.depth.view;
        match pass {
            PassId::Shadows => {
                self.shadow.record(encoder, scene, ts);
                self.shadow
                    .record_view(encoder, &gpu.device, &gpu.queue, 0, &t.shadow_view.view);
            }
            PassId::Background => {
                let target = into(&t.background, background);
                self.background
                    .record(encoder, &[target], depth, true, frame, scene, ts);
                self.record_sky(encoder, gpu, scene, &t.background.view, depth);
            }
            PassId::WindowMask => {
                let targets = [into(&t.mask, clear), into(&t.rays_source, clear)];
                self.mask
                    .record(encoder, &targets, depth, true, frame, scene, ts)
            }
            // Passes 2 and 3 test against the depth pass 1 laid down (pass 3 clears it only
            // when pass 1 did not run).
            PassId::WindowNormals => {
                let target = into(&t.normals, clear);
                self.normals
                    .record(encoder, &[target], depth, false, frame, scene, ts)
            }
            PassId::Lit => {
                let target = into(&t.lit, background);
                self.lit
                    .record(encoder, &[target], depth, !plan.windows, frame, scene, ts);
                self.record_sky(encoder, gpu, scene, &t.lit.view, depth);
            }
            PassId::GodRays => self.rays.record(
                encoder,
                &gpu.device,
                &t.rays_source.view,
                &self.linear_clamp,
                &t.rays.view,
                ts,
            ),
            PassId::Composite => {
                let black = &scene.placeholders.black_hdr;
                fn used<'a>(
                    used: bool,
                    target: &'a Target,
                    black: &'a wgpu::TextureView,
                ) -> &'a wgpu::TextureView {
                    if used { &target.view } else { black }
                }
                let inputs = CompositeInputs {
                    lit: &t.lit.view,
                    background: &t.background.view,
                    mask: used(plan.windows, &t.mask, black),
                    normals: used(plan.refraction, &t.normals, black),
                    rays: used(plan.god_rays, &t.rays, black),
                    nearest: &self.nearest_clamp,
                    linear: &self.linear_clamp,
                };
                self.composite
                    .record(encoder, &gpu.device, &inputs, output, ts)
            }
        }
    }

    /// Renders one frame into the renderer's own output image.
    pub fn render(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        view: &View,
        timing: TimingMethod,
    ) -> Result<FrameReport, RenderError> {
        let output = self
            .targets
            .output
            .as_ref()
            .ok_or(RenderError::NoOutput)?
            .view
            .clone();
        self.render_to(gpu, scene, view, &output, timing)
    }

    /// Renders one frame into `output` (a view of the renderer's output format and size).
    /// `timing` asks for per-pass times: GPU timestamps where the device has them (else the
    /// CPU wall clock is used and the report says so); `None` records one command buffer.
    pub fn render_to(
        &mut self,
        gpu: &Gpu,
        scene: &Scene,
        view: &View,
        output: &wgpu::TextureView,
        timing: TimingMethod,
    ) -> Result<FrameReport, RenderError> {
        self.update_shadows(gpu, scene);
        let (mut plan, rays) = self.plan(scene, view);
        self.write_uniforms(gpu, scene, view, &plan, rays);
        if plan.shadows {
            self.shadows_drawn = Some(self.shadow_key(scene));
        }
        self.frame_index = self.frame_index.wrapping_add(1);
        let recorded: Vec<PassId> = plan
            .passes
            .iter()
            .filter(|p| p.skipped.is_none())
            .map(|p| p.pass)
            .collect();
        let method = match timing {
            TimingMethod::None => TimingMethod::None,
            _ if self.timestamps.is_some() && timing == TimingMethod::GpuTimestamps => {
                TimingMethod::GpuTimestamps
            }
            _ => TimingMethod::CpuWallClock,
        };
        match method {
            TimingMethod::CpuWallClock => {
                // Each pass alone, waited for: crude but available everywhere.
                gpu.wait()?;
                for &id in &recorded {
                    let start = std::time::Instant::now();
                    let mut encoder = gpu.device.create_command_encoder(&Default::default());
                    let rec = Recording {
                        gpu,
                        scene,
                        plan: &plan,
                        output,
                        timed: false,
                    };
                    self.record(id, &mut encoder, &rec);
                    gpu.queue.submit([encoder.finish()]);
                    gpu.wait()?;
                    let ms = start.elapsed().as_secs_f64() * 1e3;
                    if let Some(p) = plan.passes.iter_mut().find(|p| p.pass == id) {
                        p.ms = Some(ms);
                    }
                }
            }
            TimingMethod::GpuTimestamps | TimingMethod::None => {
                let timed = method == TimingMethod::GpuTimestamps;
                let mut encoder = gpu.device.create_command_encoder(&Default::default());
                for &id in &recorded {
                    self.record(
                        id,
                        &mut encoder,
                        &Recording {
                            gpu,
                            scene,
                            plan: &plan,
                            output,
                            timed,
                        },
                    );
                }
                if let (true, Some(t)) = (timed, &self.timestamps) {
                    let count = 2 * PassId::ALL.len() as u32;
                    encoder.resolve_query_set(&t.queries, 0..count, &t.resolve, 0);
                    encoder.copy_buffer_to_buffer(&t.resolve, 0, &t.readback, 0, count as u64 * 8);
                }
                gpu.queue.submit([encoder.finish()]);
                if let (true, Some(t)) = (timed, &self.timestamps) {
                    let ticks = read_buffer(&gpu.device, &t.readback)?;
                    let ticks: &[u64] = bytemuck::cast_slice(&ticks);
                    let period = gpu.queue.get_timestamp_period() as f64;
                    for (i, id) in PassId::ALL.iter().enumerate() {
                        if let Some(p) = plan
                            .passes
                            .iter_mut()
                            .find(|p| p.pass == *id && p.skipped.is_none())
                        {
                            let d = ticks[2 * i + 1].saturating_sub(ticks[2 * i]);
                            p.ms = Some(d as f64 * period / 1e6);
                        }
                    }
                }
            }
        }
        Ok(FrameReport {
            method,
            passes: plan.passes,
            god_ray_fade: if plan.god_rays { plan.fade } else { 0.0 },
        })
    }

    /// The final image (sRGB, RGBA8) of the last headless frame.
    pub fn read_output(&self, gpu: &Gpu) -> Result<image::RgbaImage, RenderError> {
        let t = self.targets.output.as_ref().ok_or(RenderError::NoOutput)?;
        let (w, h) = self.targets.size;
        let bytes = read_texture(&gpu.device, &gpu.queue, &t.texture, 4)?;
        image::RgbaImage::from_raw(w, h, bytes).ok_or(RenderError::Readback("output size".into()))
    }

    /// An intermediate target as linear RGBA f32, with its size.
    pub fn read_target(
        &self,
        gpu: &Gpu,
        id: TargetId,
    ) -> Result<(u32, u32, Vec<[f32; 4]>), RenderError> {
        let t = self.targets.get(id);
        let (w, h) = match id {
            TargetId::GodRays => self.targets.rays_size,
            TargetId::ShadowMap => (SHADOW_VIEW_SIZE, SHADOW_VIEW_SIZE),
            _ => self.targets.size,
        };
        let bytes = read_texture(&gpu.device, &gpu.queue, &t.texture, 8)?;
        let halfs: &[u16] = bytemuck::cast_slice(&bytes);
        let px = halfs
            .chunks_exact(4)
            .map(|c| [0, 1, 2, 3].map(|k| f16_to_f32(c[k])))
            .collect();
        Ok((w, h, px))
    }
}

/// A storage buffer the CPU fills: the windows' or their planes'.
fn storage_buffer(device: &wgpu::Device, label: &str, size: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    })
}

/// Bytes of `count` window planes (at least one: no binding is empty).
fn planes_size(count: usize) -> u64 {
    (count.max(1) * std::mem::size_of::<uniforms::WindowPlane>()) as u64
}

/// Points `slot`'s shadow fields at `map`, for a camera at `camera`.
fn map_slot(slot: &mut uniforms::WindowProjector, map: &crate::shadows::WindowMap, camera: Vec3) {
    slot.params[2] = map.layer;
    slot.params[3] = 1;
    slot.shadow = map.lookup_relative(camera).to_cols_array_2d();
    slot.shadow_x = map.x_dir.extend(map.texel[0]).to_array();
    slot.shadow_y = map.y_dir.extend(map.texel[1]).to_array();
    slot.shadow_depth = [map.near, map.far, map.lamp_distance, map.light_size];
    slot.shadow_dir = map.depth_dir.extend(0.0).to_array();
}

/// A lamp's inverse-square falloff where its light enters: averaged over the centres of the
/// windows it comes in through (`view::window_passes_light`, the only ones whose god rays
/// shine; for a spot, those its cone reaches), so god rays match the brightness of the light
/// patches they lead to. 1 for the sun, and where the light passes no window.
pub fn god_ray_falloff(toc: &pack::Toc, light: &pack::Light) -> f32 {
    falloff_over(
        light,
        (toc.windows.iter()).filter(|w| crate::view::window_passes_light(w, light)),
    )
}

/// [`god_ray_falloff`] over `windows`, those the light comes in through.
fn falloff_over<'a>(light: &pack::Light, windows: impl Iterator<Item = &'a pack::Window>) -> f32 {
    let Some((position, radius)) = light.kind.lamp() else {
        return 1.0;
    };
    let position = Vec3::from(position);
    let falloffs: Vec<f32> = windows
        .map(|w| {
            let centre = Vec3::from(w.origin) + (Vec3::from(w.u_axis) + Vec3::from(w.v_axis)) * 0.5;
            1.0 / position
                .distance_squared(centre)
                .max(radius * radius)
                .max(1e-12)
        })
        .collect();
    if falloffs.is_empty() {
        return 1.0;
    }
    falloffs.iter().sum::<f32>() / falloffs.len() as f32
}
