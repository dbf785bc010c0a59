//! Generate tree meshes the way tree generators write them (curved tapered
//! tubes along splines, forks, branches growing out of the trunk), as test
//! forests for `slothsim run --forest`.
//!
//! ```text
//! cargo run --release -p slothsim-tools --bin gen-trees -- --trees 9 --out trees.glb
//! ```
//! Same arguments, same bytes. See docs/trees.md.

use std::path::PathBuf;

use anyhow::{Context, bail};
use clap::Parser;
use slothsim_scene::treegen::{TreeLayout, TreeParams, generate_forest_glb};

/// Write a forest of generated trees as GLB.
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Distinct trees (each its own meshes, placed once).
    #[arg(long, default_value_t = 9)]
    trees: u32,
    /// Extra placements of the first tree's meshes (linked duplicates).
    #[arg(long, default_value_t = 0)]
    instances: u32,
    /// Trunk height (m).
    #[arg(long, default_value_t = 7.0)]
    height: f32,
    /// Trunk radius at the base (m).
    #[arg(long, default_value_t = 0.16)]
    trunk_radius: f32,
    /// Side branches on the trunk.
    #[arg(long, default_value_t = 12)]
    branches: u32,
    /// Most sub-branches per side branch.
    #[arg(long, default_value_t = 2)]
    sub_branches: u32,
    /// Vertices per ring.
    #[arg(long, default_value_t = 12)]
    sides: u32,
    /// `welded` (one mesh a tree, fork welded) or `per-branch` (one mesh a tube).
    #[arg(long, default_value = "welded")]
    layout: String,
    /// No fork at the top of the trunk.
    #[arg(long)]
    no_fork: bool,
    /// Distance between trees (m).
    #[arg(long, default_value_t = 6.0)]
    spacing: f32,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output `.glb` path.
    #[arg(long)]
    out: PathBuf,
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let layout = match args.layout.as_str() {
        "welded" => TreeLayout::Welded,
        "per-branch" => TreeLayout::PerBranch,
        other => bail!("--layout must be `welded` or `per-branch`, got `{other}`"),
    };
    for (name, v) in [
        ("--height", args.height),
        ("--trunk-radius", args.trunk_radius),
        ("--spacing", args.spacing),
    ] {
        if !(v.is_finite() && v > 0.0) {
            bail!("{name} must be a positive number, got {v}");
        }
    }
    if args.sides < 3 {
        bail!("--sides must be at least 3, got {}", args.sides);
    }
    let params = TreeParams {
        height: args.height,
        trunk_radius: args.trunk_radius,
        branches: args.branches,
        sub_branches: args.sub_branches,
        fork: !args.no_fork,
        sides: args.sides,
        layout,
    };
    let (bytes, trees) =
        generate_forest_glb(&params, args.trees, args.instances, args.spacing, args.seed);
    std::fs::write(&args.out, &bytes).with_context(|| format!("writing {}", args.out.display()))?;
    let axis: f32 = trees.iter().map(|t| t.axis_length()).sum();
    let tris: usize = trees.iter().map(|t| t.triangle_count()).sum();
    let tubes: usize = trees.iter().map(|t| t.tubes.len()).sum();
    println!(
        "wrote {} ({} bytes): {} trees + {} instances, {} tubes, {:.1} m of axis, {} triangles \
         (distinct meshes)",
        args.out.display(),
        bytes.len(),
        args.trees,
        args.instances,
        tubes,
        axis,
        tris
    );
    Ok(())
}
