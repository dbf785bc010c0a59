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

/// `--shard I/N` and `--shards N`: which deterministic slice of a sweep
/// (matrix cases, `run --seeds`) this process runs.
#[derive(clap::Args, Debug, Default)]
pub struct ShardArgs {
    /// Run only shard I of N (0-based: case k runs in shard k mod N), e.g.
    /// `--shard 3/8`. Default: from a Slurm job array
    /// (SLURM_ARRAY_TASK_ID − SLURM_ARRAY_TASK_MIN of SLURM_ARRAY_TASK_COUNT;
    /// a contiguous array) or a Kubernetes Indexed Job (JOB_COMPLETION_INDEX,
    /// with --shards N); else the whole sweep.
    #[arg(long, value_name = "I/N")]
    shard: Option<String>,
    /// Number of shards, for an index taken from JOB_COMPLETION_INDEX.
    #[arg(long, value_name = "N")]
    shards: Option<u32>,
}

/// A slice of a sweep: items `k` with `k mod count == index`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// 0-based index.
    pub index: u32,
    /// Number of shards (≥ 1).
    pub count: u32,
}

impl Shard {
    /// The whole sweep.
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    /// Whether item `k` of the sweep is this shard's.
    pub fn owns(&self, k: usize) -> bool {
        k % self.count as usize == self.index as usize
    }

    /// This shard's items, in sweep order.
    pub fn take<T: Clone>(&self, items: &[T]) -> Vec<T> {
        items
            .iter()
            .enumerate()
            .filter(|(k, _)| self.owns(*k))
            .map(|(_, t)| t.clone())
            .collect()
    }
}

impl ShardArgs {
    /// Whether `--shard` or `--shards` was given.
    pub fn is_given(&self) -> bool {
        self.shard.is_some() || self.shards.is_some()
    }

    /// The shard from the flags, else from the scheduler's environment.
    pub fn resolve(&self) -> Result<Shard> {
        self.resolve_with(|key| std::env::var(key).ok())
    }

    /// [`Self::resolve`] with the environment given (tests).
    pub fn resolve_with(&self, env: impl Fn(&str) -> Option<String>) -> Result<Shard> {
        let number = |what: &str, text: &str| -> Result<u32> {
            text.trim()
                .parse::<u32>()
                .with_context(|| format!("{what} `{text}` is not a whole number ≥ 0"))
        };
        let checked = |index: u32, count: u32, from: &str| -> Result<Shard> {
            if count == 0 {
                bail!("{from}: the shard count must be at least 1");
            }
            if index >= count {
                bail!(
                    "{from}: shard index {index} is not below the shard count {count} (indices are 0-based)"
                );
            }
            if let Some(n) = self.shards
                && n != count
            {
                bail!("--shards {n} disagrees with {from} ({count} shards)");
            }
            Ok(Shard { index, count })
        };
        if let Some(text) = &self.shard {
            let (i, n) = text
                .split_once('/')
                .with_context(|| format!("--shard {text}: expected I/N, e.g. 0/4"))?;
            let from = format!("--shard {text}");
            return checked(
                number("--shard index", i)?,
                number("--shard count", n)?,
                &from,
            );
        }
        if let Some(count) = env("SLURM_ARRAY_TASK_COUNT") {
            let id = env("SLURM_ARRAY_TASK_ID")
                .context("SLURM_ARRAY_TASK_COUNT is set but SLURM_ARRAY_TASK_ID is not")?;
            let min = env("SLURM_ARRAY_TASK_MIN").unwrap_or_else(|| "0".into());
            let (id, min) = (
                number("SLURM_ARRAY_TASK_ID", &id)?,
                number("SLURM_ARRAY_TASK_MIN", &min)?,
            );
            let index = id.checked_sub(min).with_context(|| {
                format!("SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}")
            })?;
            let count = number("SLURM_ARRAY_TASK_COUNT", &count)?;
            return checked(index, count, "the Slurm array (SLURM_ARRAY_TASK_*)");
        }
        if let Some(index) = env("JOB_COMPLETION_INDEX") {
            let index = number("JOB_COMPLETION_INDEX", &index)?;
            let count = self.shards.context(
                "JOB_COMPLETION_INDEX is set: give --shards N (the Indexed Job's completions)",
            )?;
            return checked(index, count, "JOB_COMPLETION_INDEX");
        }
        if let Some(n) = self.shards {
            bail!(
                "--shards {n} needs an index: --shard I/{n}, or run in a Slurm job array or a Kubernetes Indexed Job"
            );
        }
        Ok(Shard::WHOLE)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(shard: Option<&str>, shards: Option<u32>) -> ShardArgs {
        ShardArgs {
            shard: shard.map(str::to_string),
            shards,
        }
    }

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |k| {
            vars.iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| v.to_string())
        }
    }

    #[test]
    fn shard_from_flag_slurm_and_kubernetes() {
        let none = env(&[]);
        assert_eq!(args(None, None).resolve_with(&none).unwrap(), Shard::WHOLE);
        assert_eq!(
            args(Some("2/5"), None).resolve_with(&none).unwrap(),
            Shard { index: 2, count: 5 }
        );
        let slurm = env(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ]);
        assert_eq!(
            args(None, None).resolve_with(&slurm).unwrap(),
            Shard { index: 3, count: 8 }
        );
        let k8s = env(&[("JOB_COMPLETION_INDEX", "6")]);
        assert_eq!(
            args(None, Some(7)).resolve_with(&k8s).unwrap(),
            Shard { index: 6, count: 7 }
        );
    }

    #[test]
    fn bad_shards_are_clear_errors() {
        let none = env(&[]);
        let err = |a: ShardArgs, e: &dyn Fn(&str) -> Option<String>| {
            a.resolve_with(e).unwrap_err().to_string()
        };
        assert!(err(args(Some("3/3"), None), &none).contains("not below the shard count 3"));
        assert!(err(args(Some("0/0"), None), &none).contains("at least 1"));
        assert!(err(args(Some("x/2"), None), &none).contains("`x`"));
        assert!(err(args(Some("1-2"), None), &none).contains("expected I/N"));
        assert!(err(args(None, Some(4)), &none).contains("needs an index"));
        let k8s = env(&[("JOB_COMPLETION_INDEX", "1")]);
        assert!(err(args(None, None), &k8s).contains("give --shards N"));
        assert!(err(args(None, Some(1)), &k8s).contains("not below"));
        assert!(err(args(Some("0/2"), Some(3)), &none).contains("disagrees"));
    }

    #[test]
    fn shards_partition_a_sweep() {
        let items: Vec<u32> = (0..23).collect();
        for count in 1..6 {
            let mut all: Vec<u32> = (0..count)
                .flat_map(|index| Shard { index, count }.take(&items))
                .collect();
            all.sort_unstable();
            assert_eq!(all, items, "{count} shards");
        }
    }
}
