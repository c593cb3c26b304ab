//! Texture cooking for the stained-glass toolchain: what turns a source image into the RGBA8
//! mip levels a pack stores.
//!
//! - [`load_image`], [`load_image_bytes`]: decode with limits (a tiny file claiming a huge size
//!   fails before any allocation); errors name the file. KTX2 files with a Basis Universal
//!   payload are transcoded ([`basis`]), DDS files decoded ([`dds`]).
//! - [`colour_mips`]: sRGB-correct mip chain: decoded exactly to linear light (tables for 8- and
//!   16-bit codes), alpha-weighted (premultiplied) filtering in f32, polyphase reduction for odd
//!   and non-power-of-two sizes ([`MipFilter::Box`] by default, Kaiser or Lanczos3 on request),
//!   re-encoded once per level with correct rounding. An 8-bit sRGB source keeps its bytes at
//!   level 0, and a constant image stays exactly constant.
//! - [`normal_mips`]: supplied normal maps (RGB or RG, OpenGL or DirectX green), filtered and
//!   renormalized at every level; a texel whose normals cancel becomes (0, 0, 1).
//! - [`derive_normal_map`]: a normal map from a design: lead came raised, hammered glass.
//! - [`projector()`]: the design blurred by a Gaussian in linear light (see [`blur`] for the
//!   method and its accuracy) with a zero border, σ from [`sigma_from_light`].
//!
//! Every [`MipChain`] holds RGBA8 levels, level 0 first, each `max(1, previous / 2)` texels on
//! each axis down to 1x1, as `pack::Texture` expects. Colour and projector levels are
//! sRGB-encoded colour with linear alpha (`ColourSpace::Srgb`); normal levels are linear.
//! Results are identical on any number of threads.
//!
//! Error unit used by tests and benchmarks: 1 LSB is one step of the 8-bit sRGB output; error is
//! `|our byte − unrounded sRGB encoding of an f64 linear-light reference|`, so 0.5 is the floor.

pub mod basis;
pub mod bc;
pub mod blur;
pub mod dds;
mod error;
mod fir;
pub mod guard;
mod load;
pub mod mips;
pub mod normal;
pub mod pixels;
pub mod profile;
pub mod projector;
mod real;
pub mod resample;
pub mod srgb;
#[doc(hidden)]
pub mod testing;

pub use blur::{
    BlurMethod, ErrorLsb, MAX_SIGMA, Sigma2, blur_linear, blur_srgb8, error_lsb, reference_blur,
    reference_blur_xy,
};
pub use error::TextureError;
pub use load::{MAX_DECODE_BYTES, MAX_SIDE, load_image, load_image_bytes, probe_image};
pub use mips::{
    ColourOptions, MipChain, colour_mips, colour_mips_reference, first_level_within, level_count,
    level_size,
};
pub use normal::{
    BUMP_DEPTH, FALLBACK_NORMAL, GreenAxis, NormalEncoding, SuppliedNormals, derive_normal_map,
    derive_normal_map_padded, is_height_map, normal_mips, supplied_normal_mips,
};
pub use profile::{ProfileUse, load_image_in_srgb, profile_use};
pub use projector::{
    MARGIN_SIGMAS, ProjectorOptions, ProjectorReport, projector, projector_margin,
    projector_with_unpadded, sigma_from_light,
};
pub use resample::MipFilter;
