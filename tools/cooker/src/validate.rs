//! `cooker validate <scene.toml|mesh file|pack> [--json]`: exit 0 when clean, 1 with findings.

use std::path::PathBuf;

use cook::Manifest;

use crate::exit::{FOUND_PROBLEMS, OK, Outcome};

#[derive(clap::Args)]
pub struct Args {
    /// A scene manifest, a bare mesh file (.obj/.gltf/.glb), or a cooked pack.
    input: PathBuf,
    /// Print one JSON object: `findings` ({code, message}) and `materials`.
    #[arg(long)]
    json: bool,
    /// The up axis of a bare model, as `cooker cook --up`.
    #[arg(long, value_name = "y|z", default_value = "y", value_parser = cook::UpAxis::from_arg)]
    up: cook::UpAxis,
}

pub fn run(args: Args) -> Outcome {
    let ext = args
        .input
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let validation = if matches!(ext.as_str(), "toml" | "obj" | "gltf" | "glb") {
        cook::validate::validate_scene(&Manifest::open(&args.input)?, args.up)?
    } else {
        if args.up != cook::UpAxis::Y {
            return Err(crate::exit::UsageError(format!(
                "--up turns a bare model; {} is a cooked pack",
                args.input.display()
            ))
            .into());
        }
        cook::validate::validate_pack(&pack::Pack::open(&args.input)?)
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&validation.to_json())?);
    } else {
        print!("{}", validation.to_text());
    }
    Ok(if validation.is_clean() {
        OK
    } else {
        FOUND_PROBLEMS
    })
}
