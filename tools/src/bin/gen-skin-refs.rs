//! Generate the control-cluster reference shapes of the default sloth (issue 25): the
//! offline sculpt of `slothsim_skin::sculpt::reference_shapes`, stored as data.
//!
//! ```text
//! cargo run --release -p slothsim-tools --bin gen-skin-refs -- --out assets/sloth_skin_refs.json
//! ```

use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use slothsim_skin::{SkinMesh, reference_shapes};

/// Write the sloth's cluster reference shapes as JSON.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Output `.json` path.
    #[arg(long, default_value = "assets/sloth_skin_refs.json")]
    out: PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let mesh = SkinMesh::sloth()?;
    let bytes = reference_shapes(&mesh)?.to_json();
    std::fs::write(&args.out, &bytes).with_context(|| format!("writing {}", args.out.display()))?;
    println!("wrote {} ({} bytes)", args.out.display(), bytes.len());
    Ok(())
}
