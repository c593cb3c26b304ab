//! DDS textures (what game pipelines and older Windows tools write, and `MSFT_texture_dds`
//! names): level 0 decoded by `image_dds` (BC1-BC7 through `bcdec_rs`, and the plain
//! formats), so the cook makes its own mips and block compression from it, as from a PNG.

use std::path::Path;

use image::DynamicImage;
use image_dds::ddsfile::{Caps2, D3D10ResourceDimension, Dds, DxgiFormat, MiscFlag};
use image_dds::{ImageFormat, SurfaceRgba8, SurfaceRgba32Float};

use crate::TextureError;
use crate::load::check_claimed_size;

/// True when `bytes` start like a DDS file (the magic `DDS `).
pub fn is_dds(bytes: &[u8]) -> bool {
    bytes.starts_with(b"DDS ")
}

/// Decodes level 0 of a 2D DDS file: 8-bit and block formats to RGBA8, float ones (BC6H,
/// 16- and 32-bit float) to RGBA f32. The size is checked against [`MAX_SIDE`](crate::MAX_SIDE) before the
/// texels are decoded. Cube maps, arrays and volumes are refused: a material samples one 2D
/// image. A decoder panic on damaged data is reported as the file's error.
pub fn decode_dds(bytes: &[u8], path: &Path) -> Result<DynamicImage, TextureError> {
    let decoded = crate::guard::catch_decoder_panic(|| decode(bytes, path));
    decoded.map_err(|why| TextureError::Dds {
        path: path.to_path_buf(),
        reason: format!("the decoder failed on it ({why})"),
    })?
}

/// A typeless DXGI format (the bits, with the view's type left to the program: DirectXTex and
/// Pillow write them) as its UNORM twin, which the decoder reads. The texels are the same; the
/// cook decides the colour space from the material, as for any image.
fn typed(f: DxgiFormat) -> DxgiFormat {
    match f {
        DxgiFormat::BC1_Typeless => DxgiFormat::BC1_UNorm,
        DxgiFormat::BC2_Typeless => DxgiFormat::BC2_UNorm,
        DxgiFormat::BC3_Typeless => DxgiFormat::BC3_UNorm,
        DxgiFormat::BC4_Typeless => DxgiFormat::BC4_UNorm,
        DxgiFormat::BC5_Typeless => DxgiFormat::BC5_UNorm,
        DxgiFormat::BC6H_Typeless => DxgiFormat::BC6H_UF16,
        DxgiFormat::BC7_Typeless => DxgiFormat::BC7_UNorm,
        DxgiFormat::R8G8B8A8_Typeless => DxgiFormat::R8G8B8A8_UNorm,
        DxgiFormat::B8G8R8A8_Typeless => DxgiFormat::B8G8R8A8_UNorm,
        DxgiFormat::B8G8R8X8_Typeless => DxgiFormat::B8G8R8X8_UNorm,
        other => other,
    }
}

fn decode(bytes: &[u8], path: &Path) -> Result<DynamicImage, TextureError> {
    let bad = |reason: String| TextureError::Dds {
        path: path.to_path_buf(),
        reason,
    };
    let dds = Dds::read(bytes).map_err(|e| bad(format!("unreadable header ({e})")))?;
    let (width, height) = (dds.get_width(), dds.get_height());
    check_claimed_size(path, width, height)?;
    let cube = dds.header.caps2.contains(Caps2::CUBEMAP)
        || dds
            .header10
            .as_ref()
            .is_some_and(|h| h.misc_flag.contains(MiscFlag::TEXTURECUBE));
    let volume = dds.get_depth() > 1
        || dds
            .header10
            .as_ref()
            .is_some_and(|h| h.resource_dimension == D3D10ResourceDimension::Texture3D);
    let layers = dds.get_num_array_layers();
    if cube || volume || layers > 1 {
        let what = if cube {
            "a cube map"
        } else if volume {
            "a volume texture"
        } else {
            "an array"
        };
        return Err(bad(format!(
            "holds {what}; a material samples one 2D image"
        )));
    }
    let mut dds = dds;
    if let Some(h) = dds.header10.as_mut() {
        h.dxgi_format = typed(h.dxgi_format);
    }
    let format = image_dds::dds_image_format(&dds).map_err(|info| {
        bad(format!(
            "its pixel format is not one the decoder reads ({info:?})"
        ))
    })?;
    let float = matches!(
        format,
        ImageFormat::BC6hRgbUfloat
            | ImageFormat::BC6hRgbSfloat
            | ImageFormat::Rgba16Float
            | ImageFormat::Rgba32Float
            | ImageFormat::R16Float
            | ImageFormat::Rg16Float
            | ImageFormat::R32Float
            | ImageFormat::Rg32Float
            | ImageFormat::Rgb32Float
    );
    let short = |e: image_dds::error::SurfaceError| bad(format!("level 0 does not decode ({e})"));
    let image = if float {
        let surface =
            SurfaceRgba32Float::decode_layers_mipmaps_dds(&dds, 0..1, 0..1).map_err(short)?;
        image::Rgba32FImage::from_raw(width, height, surface.data).map(DynamicImage::ImageRgba32F)
    } else {
        let surface = SurfaceRgba8::decode_layers_mipmaps_dds(&dds, 0..1, 0..1).map_err(short)?;
        image::RgbaImage::from_raw(width, height, surface.data).map(DynamicImage::ImageRgba8)
    };
    image.ok_or_else(|| bad("level 0 decoded to the wrong size".to_string()))
}
