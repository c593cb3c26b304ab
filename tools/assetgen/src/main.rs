//! `assetgen`: writes the default scene into `assets-src/` (see assets-src/README.md).

use std::path::PathBuf;

use anyhow::Result;
use clap::Parser;

#[derive(Parser)]
#[command(about = "Generate the default stained-glass corridor scene")]
struct Args {
    /// Output folder.
    #[arg(long, default_value = "assets-src")]
    out: PathBuf,
    /// Seed for glass colours, mosaic shapes and textures.
    #[arg(long, default_value_t = assetgen::DEFAULT_SEED)]
    seed: u64,
    /// Long side of each stained-glass design, in pixels.
    #[arg(long, default_value_t = assetgen::DEFAULT_DESIGN_SIZE)]
    size: u32,
}

fn main() -> Result<()> {
    let args = Args::parse();
    let out = assetgen::generate(&assetgen::Options {
        seed: args.seed,
        design_size: args.size,
    })?;
    assetgen::write(&args.out, &out.files)?;
    let mut total = 0;
    for f in &out.files {
        println!("{:>10}  {}", f.bytes.len(), f.path);
        total += f.bytes.len();
    }
    for l in &out.lights {
        println!(
            "sun through {:<16} {}/{} rays land ({} on the floor)",
            l.material, l.received, l.samples, l.on_floor
        );
    }
    println!(
        "{total} bytes in {} files written to {}; hash {:016x}",
        out.files.len(),
        args.out.display(),
        assetgen::tree_hash(&out.files)
    );
    Ok(())
}
