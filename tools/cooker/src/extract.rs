//! `cooker extract <pack> <texture-name> [--mip N] -o out.png`

use std::path::PathBuf;

use anyhow::Context;
use image::ImageEncoder;
use pack::Pack;

use crate::exit::{OK, Outcome, UsageError};

#[derive(clap::Args)]
pub struct Args {
    /// The pack to read.
    pack: PathBuf,
    /// Name of the texture, as `cooker info` lists it.
    texture: String,
    /// Mip level to write (0 is the largest).
    #[arg(long, default_value_t = 0)]
    mip: usize,
    /// The PNG to write (replaced atomically; nothing is written on failure).
    #[arg(short, long)]
    output: PathBuf,
}

/// Writes one texture level as an 8-bit RGBA PNG of its logical size, block-compressed levels
/// decoded (`pack::texels`): sRGB-encoded colour for `colour` and `projector` textures (a
/// projector's colour is premultiplied by its coverage), the linear `n·0.5 + 0.5` encoding for
/// `normal` textures (Z rebuilt for two-channel BC5).
pub fn run(args: Args) -> Outcome {
    crate::cook::refuse_a_directory(&args.output, &format!("{}.png", args.texture))?;
    // PNG bytes in a `.jpg` were written without a word.
    if let Some(ext) = args.output.extension()
        && !ext.eq_ignore_ascii_case("png")
    {
        return Err(UsageError(format!(
            "-o {}: extract writes PNG; name a .png file",
            args.output.display()
        ))
        .into());
    }
    crate::cook::refuse_overwriting_an_input(&args.output, [args.pack.as_path()])?;
    let pack = Pack::open(&args.pack)?;
    let toc = pack.toc();
    let Some(index) = toc.textures.iter().position(|t| t.name == args.texture) else {
        let names: Vec<&str> = toc.textures.iter().map(|t| t.name.as_str()).collect();
        return Err(UsageError(format!(
            "{}: no texture named {:?}; it has {}",
            args.pack.display(),
            args.texture,
            if names.is_empty() {
                "no textures".to_string()
            } else {
                format!("{names:?}")
            }
        ))
        .into());
    };
    let texture = &toc.textures[index];
    let Some(level) = texture.mips.get(args.mip) else {
        return Err(UsageError(format!(
            "{}: mip level {} of texture {:?} does not exist: it has {} level(s), 0 to {}",
            args.pack.display(),
            args.mip,
            texture.name,
            texture.mips.len(),
            texture.mips.len().saturating_sub(1)
        ))
        .into());
    };
    let bytes = pack::texels::decode_level(texture, args.mip, pack.mip_bytes(index, args.mip));
    let mut png = Vec::new();
    image::codecs::png::PngEncoder::new(&mut png)
        .write_image(
            &bytes,
            level.width,
            level.height,
            image::ExtendedColorType::Rgba8,
        )
        .with_context(|| {
            format!(
                "encoding level {} of {:?} ({}x{}) as PNG",
                args.mip, texture.name, level.width, level.height
            )
        })?;
    pack::write_atomic(&args.output, &png)?;
    println!(
        "{}: {:?} mip {} ({}x{}, {}, {}, {})",
        args.output.display(),
        texture.name,
        args.mip,
        level.width,
        level.height,
        texture.role,
        texture.colour_space.name(),
        texture.format
    );
    Ok(OK)
}
