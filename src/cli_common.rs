//! What several commands share: the gait profile flag and the locomotion
//! config it loads, preset parameters, output folders and files, and crowds
//! read back from checkpoints. The command modules use this one; it uses
//! none of them.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::ValueEnum;
use slothsim::gait::{LocomotionConfig, Profile};
use slothsim::rig::Rig;
use slothsim::scene::{PresetKind, generate_forest, read_scene};
use slothsim::sim::{Crowd, ForestSource};

/// Gait profile names on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ProfileArg {
    /// The thesis model (0.11 m/s).
    Free,
    /// SPEC Table 1 steady state.
    Steady,
}

/// The locomotion config: profile defaults, overridden by a TOML file.
pub fn load_config(profile: ProfileArg, file: Option<&Path>) -> Result<LocomotionConfig> {
    let profile = match profile {
        ProfileArg::Free => Profile::Free,
        ProfileArg::Steady => Profile::Steady,
    };
    match file {
        None => Ok(LocomotionConfig::profile(profile)),
        Some(path) => {
            let text = std::fs::read_to_string(path)
                .with_context(|| format!("cannot read config {}", path.display()))?;
            let mut text = text;
            if !text.contains("profile") {
                text = format!(
                    "profile = \"{}\"\n{text}",
                    match profile {
                        Profile::Free => "free",
                        Profile::Steady => "steady",
                    }
                );
            }
            LocomotionConfig::from_toml(&text)
                .map_err(|e| anyhow::anyhow!("invalid config {}: {e}", path.display()))
        }
    }
}

/// The preset parameter from `--angle` (degrees) or `--param` (metres), whichever
/// the preset takes; an error names the right flag.
pub fn preset_value(
    kind: PresetKind,
    angle: Option<f32>,
    param: Option<f32>,
) -> Result<Option<f32>> {
    Ok(match (kind.parameter(), angle, param) {
        (_, Some(_), Some(_)) => bail!("give either --angle or --param, not both"),
        (Some((name, unit, ..)), Some(_), None) if unit != "deg" => {
            bail!(
                "preset `{}` takes --param ({name} in {unit}), not --angle",
                kind.name()
            )
        }
        (Some((name, "deg", ..)), None, Some(_)) => {
            bail!(
                "preset `{}` takes --angle ({name} in degrees), not --param",
                kind.name()
            )
        }
        (_, a, p) => a.or(p),
    })
}

/// Makes sure `dir` exists and is writable before a long run starts.
pub fn prepare_out(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))?;
    let probe = dir.join(".slothsim-write-probe");
    std::fs::write(&probe, b"")
        .with_context(|| format!("output folder {} is not writable", dir.display()))?;
    let _ = std::fs::remove_file(probe);
    Ok(())
}

/// Writes `value` as pretty JSON to `dir/name`, through a temporary file.
pub fn write_json(dir: &Path, name: &str, value: &impl serde::Serialize) -> Result<PathBuf> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))?;
    let path = dir.join(name);
    let text = serde_json::to_string_pretty(value)?;
    slothsim::sim::write_atomically(&path, text.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(path)
}

/// A crowd from a checkpoint: its forest rebuilt (procedural) or read
/// (`forest` overrides the file path the state names), then the state loaded.
pub fn load_checkpoint(state: &Path, forest: Option<&Path>, rig: &Rig) -> Result<Crowd> {
    let info = Crowd::checkpoint_info(state)?;
    let scene = match &info.forest {
        ForestSource::Procedural(cfg) => generate_forest(cfg)?,
        ForestSource::File { path, .. } => {
            let path = forest.unwrap_or(path);
            read_scene(path).with_context(|| format!("forest {}", path.display()))?
        }
    };
    Ok(Crowd::load_state(state, rig, scene)?)
}
