//! `cooker validate <scene.toml|mesh file|pack> [--json]`: exit 0 when clean, 1 with findings.

use std::path::PathBuf;

use cook::Manifest;

use crate::exit::{FOUND_PROBLEMS, OK, Outcome};

#[derive(clap::Args)]
pub struct Args {
    /// A scene manifest, a bare mesh file (.obj/.gltf/.glb/.ply), or a cooked pack.
    input: PathBuf,
    /// Print one JSON object: `findings` ({code, message, allowed}) and `materials`.
    #[arg(long)]
    json: bool,
    /// Findings with this code are still listed, marked "(allowed)", but do not make the exit
    /// code 1: for a gate on models whose exporter leaves, say, unused materials behind.
    /// Repeatable.
    #[arg(long, value_name = "CODE", value_parser = finding_codes())]
    allow: Vec<String>,
    #[command(flatten)]
    model: cook::cli::ModelArgs,
}

fn finding_codes() -> clap::builder::PossibleValuesParser {
    cook::validate::FINDING_CODES
        .iter()
        .map(|&(code, help)| clap::builder::PossibleValue::new(code).help(help))
        .collect::<Vec<_>>()
        .into()
}

pub fn run(args: Args) -> Outcome {
    let ext = args
        .input
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    let validation = if matches!(ext.as_str(), "toml" | "obj" | "gltf" | "glb" | "ply") {
        let manifest = Manifest::open(&args.input)?;
        let mut settings = cook::Settings::new(&manifest);
        args.model.apply(&mut settings);
        cook::validate::validate_scene_with(&manifest, &settings)?
    } else {
        if args.model.up != cook::UpAxis::Y {
            return Err(crate::exit::UsageError(format!(
                "--up turns a bare model; {} is a cooked pack",
                args.input.display()
            ))
            .into());
        }
        if args.model.text_encoding.is_some() {
            return Err(crate::exit::UsageError(format!(
                "--text-encoding reads OBJ and MTL files; {} is a cooked pack",
                args.input.display()
            ))
            .into());
        }
        // A model of a format the cooker does not read (`model.stl`) was "bad magic [ef, bb,
        // bf, …]: not a stained-glass pack", where `cook` names the formats it reads.
        let mut head = [0u8; 8];
        let is_pack = std::fs::File::open(&args.input)
            .and_then(|mut f| std::io::Read::read_exact(&mut f, &mut head))
            .map_or(true, |()| head == pack::format::MAGIC);
        if !is_pack && !matches!(ext.as_str(), "" | "pack") {
            anyhow::bail!(
                "{}: not a stained-glass pack, and .{ext} is no format the cooker reads: \
                 validate takes a pack, a scene.toml or a model (.obj, .gltf, .glb, .ply)",
                args.input.display()
            );
        }
        cook::validate::validate_pack(&pack::Pack::open(&args.input)?)
    };
    if args.json {
        let json = validation.to_json(&args.allow);
        println!("{}", serde_json::to_string_pretty(&json)?);
    } else {
        print!("{}", validation.to_text(&args.allow));
    }
    Ok(if validation.is_clean_allowing(&args.allow) {
        OK
    } else {
        FOUND_PROBLEMS
    })
}
