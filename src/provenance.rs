//! Where an output came from: the program (version, git revision, the CPU
//! code path), the command line, and what the run needs to be repeated — the
//! resolved locomotion config (every value), the forest source with its
//! content hash, seed, sloths, time step, clearance, frames and threads.
//!
//! Every JSON output (`stats.json`, `scenario.json`, `matrix.json`, matrix
//! parts, `bench --json`) carries one as `provenance`. `run --from
//! stats.json` rebuilds the run from it; `merge` refuses parts whose
//! provenance differs.

use std::path::Path;

use anyhow::{Context, Result};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use slothsim::gait::LocomotionConfig;
use slothsim::sim::{Crowd, ForestSource};

/// The program that wrote an output and how it was called.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// `slothsim`.
    pub program: String,
    /// The package version.
    pub version: String,
    /// `git rev-parse HEAD` at build time (`-dirty` when tracked files had
    /// changes); `null` when not built from a checkout.
    pub git_revision: Option<String>,
    /// The CCD kernels' code path on this machine: `avx2` or `plain`
    /// (same results either way).
    pub cpu_path: String,
    /// Worker threads.
    pub threads: usize,
    /// The command line as given.
    pub command_line: Vec<String>,
    /// The resolved locomotion config (every value, not the file name).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub config: Option<LocomotionConfig>,
    /// What a crowd run needs to be repeated (`run`, `bench` sizes omit it).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub run: Option<RunProvenance>,
}

/// The inputs of one crowd run.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RunProvenance {
    /// Sloths spawned.
    pub sloths: u32,
    /// Seed of spawning and route choices.
    pub seed: u64,
    /// Fixed time step (s).
    pub dt: f32,
    /// Clearance between sloths (m).
    pub clearance_m: f32,
    /// Frame the run started at (0, or the checkpoint's frame).
    pub start_frame: u64,
    /// Frames simulated.
    pub frames: u64,
    /// Where the forest came from.
    pub forest: ForestProvenance,
    /// A checkpoint the run continued from (`--load-state`), if any.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub load_state: Option<String>,
}

/// A forest's source and the hashes that identify its content.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ForestProvenance {
    /// The procedural forest's config, or the glTF file's path.
    pub source: ForestSource,
    /// Hash of the supports as simulated (hex; `sim::scene_hash`).
    pub scene_hash: String,
    /// SHA-256 of the glTF file's bytes (hex); `null` for the procedural forest.
    #[serde(default)]
    pub file_sha256: Option<String>,
}

impl Provenance {
    /// This program, called with this process's command line, on `threads`.
    pub fn here(threads: usize, config: Option<&LocomotionConfig>) -> Self {
        Provenance {
            program: env!("CARGO_PKG_NAME").into(),
            version: env!("CARGO_PKG_VERSION").into(),
            git_revision: option_env!("SLOTHSIM_GIT_REV").map(str::to_string),
            cpu_path: slothsim::rig::simd_path().into(),
            threads,
            command_line: std::env::args().collect(),
            config: config.cloned(),
            run: None,
        }
    }

    /// Whether `other` was written by the same build (version and revision).
    pub fn same_program(&self, other: &Provenance) -> bool {
        self.program == other.program
            && self.version == other.version
            && self.git_revision == other.git_revision
    }

    /// `slothsim 0.1.0 (rev …)` for messages.
    pub fn program_text(&self) -> String {
        format!(
            "{} {} (git revision {})",
            self.program,
            self.version,
            self.git_revision.as_deref().unwrap_or("unknown")
        )
    }
}

/// The provenance of a crowd's run: its spec, forest and the frames run.
pub fn run_provenance(
    crowd: &Crowd,
    scene_hash: u64,
    start_frame: u64,
    frames: u64,
    load_state: Option<&Path>,
) -> Result<RunProvenance> {
    let source = crowd
        .forest_source()
        .context("this crowd has no forest source to record")?
        .clone();
    let file_sha256 = match &source {
        ForestSource::Procedural(_) => None,
        ForestSource::File { path, .. } => Some(file_sha256(path)?),
    };
    let spec = crowd.spec();
    Ok(RunProvenance {
        sloths: spec.sloths,
        seed: spec.seed,
        dt: spec.dt,
        clearance_m: spec.clearance_m,
        start_frame,
        frames,
        forest: ForestProvenance {
            source,
            scene_hash: format!("{scene_hash:016x}"),
            file_sha256,
        },
        load_state: load_state.map(|p| p.display().to_string()),
    })
}

/// SHA-256 of a file's bytes, hex.
pub fn file_sha256(path: &Path) -> Result<String> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(format!("{:x}", Sha256::digest(&bytes)))
}

/// An output with its `provenance` as the first key, the output's own
/// fields after it (serialised as they are: `f32` stays `f32`).
#[derive(Serialize)]
pub struct Stamped<'a, T: Serialize> {
    provenance: &'a Provenance,
    #[serde(flatten)]
    body: &'a T,
}

/// `body` (a struct or map) stamped with `provenance`.
pub fn with_provenance<'a, T: Serialize>(
    body: &'a T,
    provenance: &'a Provenance,
) -> Stamped<'a, T> {
    Stamped { provenance, body }
}

/// Reads the `provenance` block of a JSON output written by slothsim.
pub fn read_provenance(path: &Path) -> Result<(Provenance, serde_json::Value)> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let value: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))?;
    let block = value.get("provenance").with_context(|| {
        format!(
            "{} has no `provenance` block (written by an older slothsim, or not a slothsim output)",
            path.display()
        )
    })?;
    let prov: Provenance = serde_json::from_value(block.clone())
        .with_context(|| format!("{}: field `provenance`", path.display()))?;
    Ok((prov, value))
}
