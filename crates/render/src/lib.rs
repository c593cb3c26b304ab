//! The stained-glass renderer (wgpu), fed from a pack.
//!
//! The design numbers its passes 0–4; [`PassId`] has seven because the shadow maps (drawn
//! first, and only when stale) and god rays, a full-screen pass of their own between 3 and 4,
//! are timed and skipped separately: `Shadows` = depth from the light for the window light's
//! occlusion ([`shadows`], [`occlusion`]); `Background` = 0 background alone; `WindowMask` = 1 windows coloured, everything else black;
//! `WindowNormals` = 2 window normal maps; `Lit` = 3 the lit scene with projectors through the
//! windows; `GodRays` = the radial blur of pass 1 (no number); `Composite` = 4 refraction, god
//! rays and tone mapping. [`Scene`] holds the GPU copy of a pack and accepts sections as they
//! stream in; [`Renderer`] owns the targets and the frame graph, [`passes`] the passes;
//! [`reference`](mod@reference) is a CPU ray tracer of the lit pass to judge them against.

pub mod budget;
mod capture;
mod gpu;
pub mod occlusion;
pub mod passes;
mod projectors;
pub mod reference;
mod renderer;
mod scene;
pub mod shaders;
pub mod shadows;
pub mod uniforms;
pub mod view;

/// The largest of `size`, `size/2`, `size/4`, … (rounded up, not below 16) at which
/// `bytes(side)` is within `budget`: for texture arrays of one layer per window, whose layers
/// shrink together once a cathedral has more windows than the budget holds at full size.
pub(crate) fn side_within(size: u32, budget: u64, bytes: impl Fn(u32) -> u64) -> u32 {
    let mut s = size;
    while s > 16 && bytes(s) > budget {
        s = s.div_ceil(2);
    }
    s
}

pub use capture::{f16_to_f32, read_texture, target_image};
pub use gpu::{Gpu, TextureCaps, supported_backends};
pub use renderer::{
    FrameReport, PassId, PassTime, Renderer, Settings, ShadowSettings, TargetId, TimingMethod,
    god_ray_falloff,
};
pub use scene::{LoadStatus, SMALL_MIP_BYTES, Scene, Upload};
pub use uniforms::{MAX_GOD_RAY_SAMPLES, MAX_WINDOWS};
pub use view::{GodRaySettings, LightGeometry, View};

/// A renderer failure, with the values involved.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    #[error(
        "no GPU adapter found ({0}); on a machine without a GPU install lavapipe (mesa-vulkan-drivers)"
    )]
    NoAdapter(String),
    #[error("no {wanted} adapter among those found: {found:?}")]
    AdapterNotFound { wanted: String, found: Vec<String> },
    #[error("GPU device error: {0}")]
    Device(String),
    #[error("texture {name:?} is {width}x{height}, but this device allows at most {max}")]
    TextureTooLarge {
        name: String,
        width: u32,
        height: u32,
        max: u32,
    },
    #[error("{found} distinct projector textures, but the lit pass binds at most {max}")]
    TooManyProjectors { found: usize, max: usize },
    #[error("mesh {mesh:?}: {reason}")]
    VertexLayout { mesh: String, reason: String },
    #[error("render size {width}x{height} is invalid (1..={max} on each axis)")]
    Size { width: u32, height: u32, max: u32 },
    #[error("this renderer draws into a caller's view and has no image of its own to read")]
    NoOutput,
    #[error("reading back from the GPU failed: {0}")]
    Readback(String),
}
