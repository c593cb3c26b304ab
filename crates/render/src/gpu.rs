//! Device setup. Headless today; `Gpu::new` takes an optional surface so the interactive
//! viewer can ask for an adapter that presents to its window.

use crate::RenderError;

/// The wgpu objects every part of the renderer needs.
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    /// True when the device was created with timestamp queries (per-pass GPU times).
    pub timestamps: bool,
    /// True when block-compressed mips are uploaded as they are: the device samples BC1-7
    /// and is not a CPU rasterizer. Otherwise they are decoded to RGBA8 on the CPU at load:
    /// lavapipe has the feature but decodes blocks in software at every sample, which made
    /// the default scene's passes about ten times slower than RGBA8 (docs/bench). Tests set it
    /// (where the device has the feature) to take the block path on lavapipe.
    pub block_compression: bool,
    /// The largest side a texture is loaded at: the device's limit, or less where the user asks
    /// (`viewer --max-texture-size`). A pack texture larger than this is loaded from its first
    /// level that fits, so a pack cooked for a large GPU still opens on a small one.
    pub max_texture_side: u32,
}

/// What decides how a pack's textures are placed on a device ([`Gpu::texture_caps`]): whether
/// block-compressed levels are sampled as they are, and the largest side loaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TextureCaps {
    pub block_compression: bool,
    pub max_side: u32,
}

impl Gpu {
    /// A device without a window. Honours `WGPU_BACKEND`, `WGPU_ADAPTER_NAME` and the Vulkan
    /// loader's `VK_DRIVER_FILES` (force lavapipe for reproducible images).
    pub fn headless() -> Result<Self, RenderError> {
        Self::new(headless_instance(), None)
    }

    /// A device without a window on the first adapter `wanted` accepts, among those the
    /// environment allows (as [`headless`](Self::headless)); `what` names it in the error
    /// ("no {what} adapter"). For images compared closely with renders made on one
    /// rasterizer: another GPU filters textures and rasterizes edges differently by tens of
    /// 8-bit steps.
    pub fn headless_matching(
        what: &str,
        wanted: impl Fn(&wgpu::AdapterInfo) -> bool,
    ) -> Result<Self, RenderError> {
        let instance = headless_instance();
        let adapters = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::all()));
        let found: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        let Some(adapter) = adapters.into_iter().find(|a| wanted(&a.get_info())) else {
            return Err(RenderError::AdapterNotFound {
                wanted: what.to_owned(),
                found,
            });
        };
        Self::on_adapter(instance, adapter)
    }

    /// A device on an adapter that can present to `surface` when one is given.
    pub fn new(
        instance: wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Self, RenderError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            ..Default::default()
        }))
        .map_err(|e| RenderError::NoAdapter(e.to_string()))?;
        Self::on_adapter(instance, adapter)
    }

    fn on_adapter(instance: wgpu::Instance, adapter: wgpu::Adapter) -> Result<Self, RenderError> {
        if adapter.get_info().backend == wgpu::Backend::Gl {
            return Err(RenderError::NoAdapter(format!(
                "{} is OpenGL, whose shaders cannot read depth textures as the shadow lookup \
                 does; a Vulkan, Metal or DirectX 12 driver is needed",
                adapter.get_info().name
            )));
        }
        let wanted = wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::TEXTURE_COMPRESSION_BC;
        let features = adapter.features() & wanted;
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("render"),
            required_features: features,
            // The adapter's array layers too: the projector array has one layer per window
            // design and a lamp's shadow maps one per window, and a cathedral has more than
            // the default 256.
            required_limits: wgpu::Limits {
                max_texture_array_layers: adapter.limits().max_texture_array_layers,
                ..wgpu::Limits::default().using_resolution(adapter.limits())
            },
            ..Default::default()
        }))
        .map_err(|e| RenderError::Device(e.to_string()))?;
        let block_compression = features.contains(wgpu::Features::TEXTURE_COMPRESSION_BC)
            && adapter.get_info().device_type != wgpu::DeviceType::Cpu;
        let max_texture_side = device.limits().max_texture_dimension_2d;
        Ok(Self {
            instance,
            adapter,
            device,
            queue,
            timestamps: features.contains(wgpu::Features::TIMESTAMP_QUERY),
            block_compression,
            max_texture_side,
        })
    }

    pub fn texture_caps(&self) -> TextureCaps {
        TextureCaps {
            block_compression: self.block_compression,
            max_side: self
                .max_texture_side
                .min(self.device.limits().max_texture_dimension_2d),
        }
    }

    /// "name (backend, device type)", for logs and reports.
    pub fn describe(&self) -> String {
        let info = self.adapter.get_info();
        format!(
            "{} ({:?}, {:?}, driver {})",
            info.name, info.backend, info.device_type, info.driver_info
        )
    }

    /// The first frame of a scene is drawn at the output size divided by this, and shown
    /// scaled up until the next frame. On a CPU rasterizer a frame's cost grows with its pixels
    /// and is most of the time to first frame (scene and pipeline creation and the uploads are
    /// small beside it: `viewer -v` prints the split), so there a quarter of the pixels comes
    /// first; a GPU draws the whole frame in milliseconds, so there the divisor is 1.
    pub fn first_frame_divisor(&self) -> u32 {
        if self.adapter.get_info().device_type == wgpu::DeviceType::Cpu {
            2
        } else {
            1
        }
    }

    /// Blocks until the GPU has finished all submitted work.
    pub fn wait(&self) -> Result<(), RenderError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| RenderError::Device(e.to_string()))
    }
}

/// An instance for devices without a window, with the backends the environment allows.
fn headless_instance() -> wgpu::Instance {
    wgpu::Instance::new(supported_backends(
        wgpu::InstanceDescriptor::new_without_display_handle_from_env(),
    ))
}

/// `desc` without OpenGL: its shaders cannot load from depth textures, which the shadow
/// lookup does, so a machine with OpenGL and no Vulkan driver fell back to it and panicked at
/// the first pipeline. Without another backend there is no adapter, which is said plainly.
pub fn supported_backends(mut desc: wgpu::InstanceDescriptor) -> wgpu::InstanceDescriptor {
    desc.backends.remove(wgpu::Backends::GL);
    desc
}
