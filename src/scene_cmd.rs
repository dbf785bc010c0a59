//! `slothsim scene …`: export presets and forests to glTF, describe scenes.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use serde::Serialize;
use slothsim::scene::{
    Bounds, BvhStats, ForestConfig, Preset, PresetKind, Scene, TraceScene, generate_forest,
    read_scene, write_scene,
};

#[derive(Subcommand)]
pub enum SceneCommand {
    /// Write a preset scene or a procedural forest to .glb / .gltf.
    Export(ExportArgs),
    /// Describe a glTF scene (or, with no FILE, the embedded default forest).
    Info(InfoArgs),
}

/// Which forest to build: the embedded default, resized by flags or a TOML config.
#[derive(Args, Clone, Debug, Default)]
pub struct ForestArgs {
    /// Forest config (TOML; keys of `ForestConfig`, unknown keys are errors).
    #[arg(long, value_name = "FILE")]
    pub forest_config: Option<PathBuf>,
    /// Number of trees (overrides the config).
    #[arg(long)]
    pub trees: Option<u32>,
    /// Side of the square forest area in metres (overrides the config).
    #[arg(long)]
    pub area: Option<f32>,
    /// Forest seed (overrides the config).
    #[arg(long)]
    pub seed: Option<u64>,
}

impl ForestArgs {
    /// The forest config these flags describe.
    pub fn config(&self) -> Result<ForestConfig> {
        let mut cfg = match &self.forest_config {
            Some(path) => {
                let text = std::fs::read_to_string(path)
                    .with_context(|| format!("cannot read forest config {}", path.display()))?;
                toml::from_str(&text)
                    .with_context(|| format!("invalid forest config {}", path.display()))?
            }
            None => ForestConfig::default(),
        };
        if let Some(t) = self.trees {
            cfg.trees = t;
        }
        if let Some(a) = self.area {
            cfg.area_m = a;
        }
        if let Some(s) = self.seed {
            cfg.seed = s;
        }
        cfg.validate()?;
        Ok(cfg)
    }
}

#[derive(Args)]
pub struct ExportArgs {
    /// `forest` (procedural) or a scenario preset: turn, parallel, trunk,
    /// height_change, branch_trunk, pole.
    #[arg(long)]
    preset: String,
    /// Preset angle in degrees (turn, height_change, branch_trunk).
    #[arg(long, allow_hyphen_values = true)]
    angle: Option<f32>,
    /// Preset parameter in metres (parallel: gap; trunk: radius).
    #[arg(long, allow_hyphen_values = true)]
    param: Option<f32>,
    #[command(flatten)]
    forest: ForestArgs,
    /// Output file: .glb (binary) or .gltf (JSON, embedded buffer).
    #[arg(long)]
    out: PathBuf,
}

#[derive(Args)]
pub struct InfoArgs {
    /// A .glb / .gltf file; without it the embedded default forest is described.
    file: Option<PathBuf>,
    /// Print JSON instead of text.
    #[arg(long)]
    json: bool,
    #[command(flatten)]
    forest: ForestArgs,
}

pub fn run(cmd: SceneCommand) -> Result<()> {
    match cmd {
        SceneCommand::Export(args) => export(args),
        SceneCommand::Info(args) => info(args),
    }
}

fn export(args: ExportArgs) -> Result<()> {
    let scene = if args.preset == "forest" {
        if args.angle.is_some() || args.param.is_some() {
            bail!(
                "preset `forest` takes no --angle/--param; size it with --trees, --area, --seed or --forest-config"
            );
        }
        generate_forest(&args.forest.config()?)?
    } else {
        let kind = PresetKind::parse(&args.preset)?;
        let value = crate::cli_common::preset_value(kind, args.angle, args.param)?;
        Preset::new(kind, value)?.scene
    };
    write_scene(&scene, &args.out)?;
    let (t, b) = scene.counts();
    println!(
        "wrote {} ({} trunks, {} branches)",
        args.out.display(),
        t,
        b
    );
    Ok(())
}

/// What `scene info` reports.
#[derive(Serialize)]
struct SceneInfo {
    source: String,
    trunks: usize,
    branches: usize,
    triangles: usize,
    bounds: Bounds,
    trunk_length_m: f32,
    branch_length_m: f32,
    bvh: BvhStats,
}

fn describe(source: String, scene: Scene) -> SceneInfo {
    let (trunks, branches) = scene.counts();
    let (trunk_length_m, branch_length_m) = scene.total_length();
    let triangles = scene.triangle_count();
    let bounds = scene.bounds();
    let traces = TraceScene::new(scene);
    SceneInfo {
        source,
        trunks,
        branches,
        triangles,
        bounds,
        trunk_length_m,
        branch_length_m,
        bvh: traces.stats(),
    }
}

fn load(file: &Path) -> Result<Scene> {
    Ok(read_scene(file)?)
}

fn info(args: InfoArgs) -> Result<()> {
    let info = match &args.file {
        Some(file) => describe(file.display().to_string(), load(file)?),
        None => {
            let cfg = args.forest.config()?;
            let source = format!(
                "procedural forest (trees {}, area {} m, seed {})",
                cfg.trees, cfg.area_m, cfg.seed
            );
            describe(source, generate_forest(&cfg)?)
        }
    };
    if args.json {
        println!("{}", serde_json::to_string_pretty(&info)?);
    } else {
        let b = info.bounds;
        println!("scene      {}", info.source);
        println!(
            "trunks     {} ({:.1} m of axis)",
            info.trunks, info.trunk_length_m
        );
        println!(
            "branches   {} ({:.1} m of axis)",
            info.branches, info.branch_length_m
        );
        println!("triangles  {}", info.triangles);
        println!(
            "bounds     min ({:.2}, {:.2}, {:.2}) max ({:.2}, {:.2}, {:.2}) m",
            b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z
        );
        println!(
            "bvh        {} primitives, {} nodes, {} leaves, depth {}, built in {:.2} ms",
            info.bvh.primitives, info.bvh.nodes, info.bvh.leaves, info.bvh.depth, info.bvh.build_ms
        );
    }
    Ok(())
}
