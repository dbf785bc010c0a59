//! Recording a run or scenario into `crowd.glb` + `trajectories.csv`
//! (`--record`, `--record-hz`), and `slothsim export` (a checkpoint's instant
//! as a still glTF). The data and writers are in `slothsim-export`, the
//! sampler in `slothsim_sim::record`; this is the command-line glue.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, anyhow, bail};
use clap::Args;
use serde::Serialize;
use slothsim::export::{Correctives, GlbSummary, Skinning, SlothModel, TrajectoryCsv, write_glb};
use slothsim::rig::Rig;
use slothsim::scene::Scene;
use slothsim::sim::record::{RecordSelection, Sampler, check_hz};
use slothsim::sim::{Crowd, SlothState};

/// `--record` / `--record-hz`.
#[derive(Args, Clone, Debug)]
pub struct RecordArgs {
    /// Sloths recorded into crowd.glb and trajectories.csv: all, none, a count N (the focus
    /// sloth and N−1 others spread over the forest) or ids ID,ID,… (one id: ID,). Default:
    /// `run` the focus sloth and 50 others; `scenario` its sloth.
    #[arg(long, value_name = "all|none|N|ID,…")]
    pub record: Option<String>,
    /// Recording samples per simulated second, at most the tick rate [default: 30, or the
    /// tick rate when slower].
    #[arg(long, allow_hyphen_values = true)]
    pub record_hz: Option<f64>,
    /// How crowd.glb skins the sloths: `clusters` (control-cluster correction as animated
    /// corrective morph targets) or `lbs` (plain linear blend skinning).
    #[arg(long, value_enum, default_value_t = SkinningArg::Clusters)]
    pub skinning: SkinningArg,
}

/// `--skinning lbs|clusters`.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SkinningArg {
    /// Linear blend skinning only.
    Lbs,
    /// LBS + control clusters as corrective morph targets (default).
    Clusters,
}

impl SkinningArg {
    fn skinning(self) -> Skinning {
        match self {
            SkinningArg::Lbs => Skinning::Lbs,
            SkinningArg::Clusters => Skinning::Clusters,
        }
    }
}

/// Writes `rec` as `path` with `skinning` (building the corrective targets for clusters).
fn write_crowd_glb(
    path: &Path,
    scene: &Scene,
    rec: &slothsim::export::Recording,
    skinning: SkinningArg,
) -> Result<GlbSummary> {
    let correctives = match skinning.skinning() {
        Skinning::Lbs => None,
        Skinning::Clusters => Some(
            Correctives::sloth().map_err(|e| anyhow!("--skinning clusters: sloth asset: {e}"))?,
        ),
    };
    Ok(write_glb(
        path,
        scene,
        &SlothModel::sloth(),
        rec,
        correctives.as_ref(),
    )?)
}

/// Default recording rate (samples per simulated second).
const DEFAULT_HZ: f64 = 30.0;

/// What recording cost and wrote (the `record` block of stats.json).
#[derive(Clone, Debug, Serialize)]
pub struct RecordStats {
    /// Recorded sloths.
    pub sloths: usize,
    /// Sample times.
    pub samples: usize,
    /// Samples per simulated second.
    pub hz: f64,
    /// Sampling (after the ticks, outside the stage timings), total ms.
    pub record_ms: f64,
    /// Sampling per sample time (all recorded sloths), ms.
    pub record_ms_per_sample: f64,
    /// crowd.glb size (bytes).
    pub glb_bytes: u64,
    /// Building and writing crowd.glb, ms.
    pub glb_write_ms: f64,
    /// `lbs` or `clusters` (`--skinning`).
    pub skinning: &'static str,
    /// Corrective morph targets on the sloth mesh (0 with lbs).
    pub morph_targets: usize,
    /// Largest fit residual of the morph weights to the cluster correction, mm: a bound
    /// on morph-then-skin's distance from the in-house cluster result (0 with lbs).
    pub morph_residual_mm: f64,
    /// trajectories.csv rows.
    pub csv_rows: u64,
    /// Finishing trajectories.csv (rows are written while sampling), ms.
    pub csv_finish_ms: f64,
}

impl RecordArgs {
    /// The selection, checked (exit 2 on bad input).
    pub fn selection(&self, default: RecordSelection) -> Result<RecordSelection> {
        match &self.record {
            Some(s) => RecordSelection::parse(s).map_err(|e| anyhow!(e)),
            None => Ok(default),
        }
    }

    /// `--record-hz`, checked against the tick (default 30 Hz, or the tick
    /// rate when that is slower).
    pub fn hz(&self, dt: f32) -> Result<f64> {
        let hz = self
            .record_hz
            .unwrap_or_else(|| DEFAULT_HZ.min(1.0 / f64::from(dt)));
        check_hz(hz, dt).map_err(|e| anyhow!(e))?;
        Ok(hz)
    }
}

/// The animation's name: the output folder's name.
fn run_name(dir: &Path, fallback: &str) -> String {
    dir.file_name()
        .and_then(|n| n.to_str())
        .filter(|n| !n.is_empty() && *n != ".")
        .unwrap_or(fallback)
        .to_string()
}

/// Starts recording `crowd` into `dir` (its current state is the first
/// sample); `None` when nothing is to be recorded.
pub fn start_crowd(
    args: &RecordArgs,
    crowd: &Crowd,
    rig: &Rig,
    focus: u32,
    dir: &Path,
    expected_s: f32,
) -> Result<Option<Sampler>> {
    let hz = args.hz(crowd.spec().dt)?;
    let sel = args.selection(RecordSelection::Count(51))?;
    let ids = sel
        .resolve(&body_positions(crowd), focus)
        .map_err(|e| anyhow!(e))?;
    if ids.is_empty() {
        return Ok(None);
    }
    let csv = TrajectoryCsv::create(&dir.join("trajectories.csv"))?;
    let name = run_name(dir, "run");
    let mut s = Sampler::for_crowd(crowd, rig, &ids, &name, hz, expected_s, Some(csv));
    s.after_tick(crowd);
    Ok(Some(s))
}

/// Body positions by sloth id.
fn body_positions(crowd: &Crowd) -> Vec<glam::Vec3> {
    let world = crowd.world();
    let mut v: Vec<(u32, glam::Vec3)> = world
        .try_query::<(&slothsim::sim::SlothId, &SlothState)>()
        .map(|mut q| q.iter(world).map(|(i, s)| (i.0, s.0.body_pos)).collect())
        .unwrap_or_default();
    v.sort_unstable_by_key(|(i, _)| *i);
    v.into_iter().map(|(_, p)| p).collect()
}

/// A sampler for a scenario's sloth, or `None` (`--record none`, or no
/// output folder and no `--record`).
pub fn start_scenario(
    args: &RecordArgs,
    dir: Option<&Path>,
    rig: &Rig,
    dt: f32,
    name: &str,
    expected_s: f32,
) -> Result<Option<Sampler>> {
    let hz = args.hz(dt)?;
    let sel = args.selection(RecordSelection::All)?;
    let ids = sel
        .resolve(&[glam::Vec3::ZERO], 0)
        .map_err(|e| anyhow!(e))?;
    let Some(dir) = dir else {
        if args.record.is_some() && !ids.is_empty() {
            bail!("--record writes crowd.glb and trajectories.csv into --out: give --out DIR");
        }
        return Ok(None);
    };
    if ids.is_empty() {
        return Ok(None);
    }
    let csv = TrajectoryCsv::create(&dir.join("trajectories.csv"))?;
    let rec =
        slothsim::export::Recording::new(name, slothsim::sim::record::moved_joints(rig), &ids);
    Ok(Some(Sampler::new(rec, hz, dt, expected_s, Some(csv))))
}

/// Writes `dir/crowd.glb` and finishes `dir/trajectories.csv`.
pub fn finish(
    sampler: Sampler,
    scene: &Scene,
    dir: &Path,
    args: &RecordArgs,
) -> Result<RecordStats> {
    let record_ms = sampler.cost().as_secs_f64() * 1e3;
    let samples = sampler.samples();
    let hz = sampler.hz();
    let (rec, csv) = sampler.finish();
    let t = Instant::now();
    let path = dir.join("crowd.glb");
    let glb = write_crowd_glb(&path, scene, &rec, args.skinning)?;
    let glb_write_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let csv_rows = csv.as_ref().map_or(0, TrajectoryCsv::rows);
    if let Some(csv) = csv {
        csv.finish()?;
    }
    let stats = RecordStats {
        sloths: rec.tracks.len(),
        samples,
        hz,
        record_ms,
        record_ms_per_sample: record_ms / samples.max(1) as f64,
        glb_bytes: glb.bytes,
        glb_write_ms,
        skinning: args.skinning.skinning().name(),
        morph_targets: glb.morph_targets,
        morph_residual_mm: f64::from(glb.morph_residual_m) * 1e3,
        csv_rows,
        csv_finish_ms: t.elapsed().as_secs_f64() * 1e3,
    };
    println!(
        "recorded {} sloths × {} samples at {} Hz: sampling {:.1} ms ({:.3} ms a sample); {} ({:.1} MB, skinning {}{}) in {:.0} ms, trajectories.csv ({} rows)",
        stats.sloths,
        stats.samples,
        stats.hz,
        stats.record_ms,
        stats.record_ms_per_sample,
        path.display(),
        stats.glb_bytes as f64 / 1e6,
        stats.skinning,
        morph_note(&glb),
        stats.glb_write_ms,
        stats.csv_rows
    );
    Ok(stats)
}

/// `: 28 corrective morph targets, fit within 0.21 mm` (nothing with lbs).
fn morph_note(glb: &GlbSummary) -> String {
    if glb.morph_targets == 0 {
        return String::new();
    }
    format!(
        ": {} corrective morph targets, fit within {:.2} mm",
        glb.morph_targets,
        glb.morph_residual_m * 1e3
    )
}

/// `slothsim export`: one instant of a checkpoint as glTF (pose only).
#[derive(Args)]
pub struct ExportArgs {
    /// A checkpoint written by `slothsim run --save-state`.
    #[arg(long, value_name = "FILE")]
    state: PathBuf,
    /// The .glb to write.
    #[arg(long, value_name = "FILE", default_value = "crowd.glb")]
    out: PathBuf,
    /// The forest file, if it moved since the state was saved.
    #[arg(long, value_name = "FILE")]
    forest: Option<PathBuf>,
    /// Sloths to include: all (default), a count N (spread over the forest, from sloth 0), or ids ID,ID,…
    #[arg(long, value_name = "all|N|ID,…")]
    record: Option<String>,
    /// How the sloths are skinned: clusters (corrective morph targets) or lbs.
    #[arg(long, value_enum, default_value_t = SkinningArg::Clusters)]
    skinning: SkinningArg,
}

pub fn export(args: ExportArgs) -> Result<bool> {
    let ext = args.out.extension().and_then(|e| e.to_str());
    if !ext.is_some_and(|e| e.eq_ignore_ascii_case("glb")) {
        bail!("--out {}: expected a .glb file", args.out.display());
    }
    let sel = match &args.record {
        Some(s) => RecordSelection::parse(s).map_err(|e| anyhow!(e))?,
        None => RecordSelection::All,
    };
    let rig = Rig::sloth();
    let crowd = crate::cli_common::load_checkpoint(&args.state, args.forest.as_deref(), &rig)
        .with_context(|| format!("checkpoint {}", args.state.display()))?;
    let ids = sel
        .resolve(&body_positions(&crowd), 0)
        .map_err(|e| anyhow!(e))?;
    let name = args
        .state
        .file_stem()
        .and_then(|n| n.to_str())
        .unwrap_or("state")
        .to_string();
    let hz = 1.0 / f64::from(crowd.spec().dt);
    let mut s = Sampler::for_crowd(&crowd, &rig, &ids, &name, hz, 0.0, None);
    s.after_tick(&crowd);
    let (rec, _) = s.finish();
    let scene = crowd
        .world()
        .resource::<slothsim::sim::Locomotion>()
        .traces
        .scene();
    let t = Instant::now();
    let glb = write_crowd_glb(&args.out, scene, &rec, args.skinning)?;
    println!(
        "wrote {} ({} sloths at t = {:.2} s, {:.1} MB, skinning {}{}, {:.0} ms)",
        args.out.display(),
        rec.tracks.len(),
        rec.times.first().copied().unwrap_or(0.0),
        glb.bytes as f64 / 1e6,
        args.skinning.skinning().name(),
        morph_note(&glb),
        t.elapsed().as_secs_f64() * 1e3
    );
    Ok(true)
}
