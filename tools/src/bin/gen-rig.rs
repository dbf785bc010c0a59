//! Generate the default sloth rig asset.
//!
//! ```text
//! cargo run --release -p slothsim-tools --bin gen-rig -- --out assets/sloth.glb
//! ```
//! The output is byte-identical on every run (tested by `tools/tests/gen_rig.rs`).

use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;

/// Write the two-toed sloth rig (skeleton, skinned low-poly mesh, joint limits) as GLB.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Output `.glb` path.
    #[arg(long, default_value = "assets/sloth.glb")]
    out: PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let bytes = slothsim_tools::rig_asset::build_sloth_glb()?;
    std::fs::write(&args.out, &bytes).with_context(|| format!("writing {}", args.out.display()))?;
    println!("wrote {} ({} bytes)", args.out.display(), bytes.len());
    Ok(())
}
