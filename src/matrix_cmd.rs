//! `slothsim matrix`: every thesis preset swept over its range (thesis
//! Table 7), the cases run in parallel (rayon; the same results as one after
//! another: each case is its own world), optionally one shard of the case
//! list (`--shard I/N`) whose part `slothsim merge` joins.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use clap::Args;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use slothsim::observe::Tolerances;
use slothsim::rig::Rig;
use slothsim::scene::{Preset, PresetKind};
use slothsim::sim::{ScenarioSpec, TrunkVariant, run_scenario};

use crate::cli_common::{ProfileArg, ShardArgs, load_config, prepare_out, write_json};
use crate::provenance::{Provenance, with_provenance};
use crate::scenario_cmd::goal_of;

/// Smallest angle step of the sweeps (degrees).
pub const MIN_STEP_DEG: f32 = 0.5;

#[derive(Args)]
pub struct MatrixArgs {
    /// Gait profile.
    #[arg(long, value_enum, default_value = "free")]
    profile: ProfileArg,
    /// Locomotion config (TOML); overrides the profile's defaults.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Angle step of the sweeps, degrees (≥ 0.5; the parameter sweeps
    /// `parallel`/`trunk` have no range here).
    #[arg(long, default_value_t = 5.0)]
    step: f32,
    /// Output folder for matrix.json (or, sharded, matrix-part-I-of-N.json).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also draw every case's plots into a subfolder of --out (e.g. `turn-135/`).
    #[arg(long, requires = "out")]
    plots: bool,
    /// Only these sweeps, comma-separated (turn, height_change, branch_trunk,
    /// trunk_branch, parallel, trunk, pole); default: all.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    only: Vec<String>,
    /// Worker threads for the cases (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    #[command(flatten)]
    shard: ShardArgs,
}

/// One row of the matrix: a sweep (at one trunk radius, for the transfers).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MatrixRow {
    pub scenario: String,
    /// branch_trunk / trunk_branch: the trunk's radius (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trunk_radius: Option<f32>,
    pub thesis_range: Option<[f32; 2]>,
    pub runs: Vec<MatrixRun>,
    pub passing: Vec<[f32; 2]>,
}

/// One case's result.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MatrixRun {
    pub parameter: Option<f32>,
    pub variant: Option<TrunkVariant>,
    /// branch_trunk / trunk_branch: the trunk's radius (m).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trunk_radius: Option<f32>,
    pub pass: bool,
    pub goal_time_s: Option<f32>,
    pub failures: Vec<String>,
}

/// `matrix.json`: the rows, the step they were swept at.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Matrix {
    pub step_deg: f32,
    pub rows: Vec<MatrixRow>,
}

/// One shard's part: its cases by their index in the whole sweep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MatrixPart {
    pub step_deg: f32,
    pub shard: [u32; 2],
    /// Cases in the whole sweep (all shards).
    pub total_cases: usize,
    pub cases: Vec<PartCase>,
}

/// A case of a part.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PartCase {
    pub case: usize,
    pub scenario: String,
    pub run: MatrixRun,
}

/// A sweep: row name, preset, its variants, sweep range, thesis range (its
/// strict interior must pass). `trunk_branch` is branch_trunk run the other
/// way (trunk → branch, `transfer_to_branch`): the thesis's test 5 covers
/// both ways, each at every radius of [`TRANSFER_RADII`].
struct Sweep {
    name: &'static str,
    kind: PresetKind,
    variants: &'static [TrunkVariant],
    /// Trunk radii (m) the sweep runs at, each its own row; empty: the preset's own.
    radii: &'static [f32],
    range: Option<[f32; 2]>,
    thesis: Option<[f32; 2]>,
}

const UP: &[TrunkVariant] = &[TrunkVariant::Up];

/// The trunk radii the transfers are swept at (m): thin, the default, and
/// the thickest trunk wanderers take from a branch.
pub const TRANSFER_RADII: &[f32] = &[0.08, 0.15, 0.2];

const SWEEPS: [Sweep; 8] = [
    Sweep {
        name: "turn",
        kind: PresetKind::Turn,
        variants: UP,
        radii: &[],
        range: Some([60.0, 180.0]),
        thesis: Some([95.0, 175.0]),
    },
    Sweep {
        name: "height_change",
        kind: PresetKind::HeightChange,
        variants: UP,
        radii: &[],
        range: Some([110.0, 220.0]),
        thesis: Some([135.0, 200.0]),
    },
    Sweep {
        name: "branch_trunk",
        kind: PresetKind::BranchTrunk,
        variants: UP,
        radii: TRANSFER_RADII,
        range: Some([60.0, 160.0]),
        thesis: Some([90.0, 140.0]),
    },
    Sweep {
        name: "trunk_branch",
        kind: PresetKind::BranchTrunk,
        variants: &[TrunkVariant::ToBranch],
        radii: TRANSFER_RADII,
        range: Some([60.0, 160.0]),
        thesis: Some([90.0, 140.0]),
    },
    Sweep {
        name: "parallel",
        kind: PresetKind::Parallel,
        variants: UP,
        radii: &[],
        range: None,
        thesis: None,
    },
    Sweep {
        name: "trunk",
        kind: PresetKind::Trunk,
        variants: &[TrunkVariant::Up, TrunkVariant::Down, TrunkVariant::Around],
        radii: &[],
        range: None,
        thesis: None,
    },
    Sweep {
        name: "branch_end",
        kind: PresetKind::BranchEnd,
        variants: UP,
        radii: &[],
        range: Some([-30.0, 30.0]),
        thesis: None,
    },
    Sweep {
        name: "pole",
        kind: PresetKind::Pole,
        variants: UP,
        radii: &[],
        range: None,
        thesis: None,
    },
];

/// One case of the whole sweep.
#[derive(Clone, Copy)]
struct Case {
    sweep: usize,
    parameter: Option<f32>,
    variant: TrunkVariant,
    trunk_radius: Option<f32>,
}

/// Every case of the sweeps named in `only` (all when empty), in sweep
/// order (the order of `matrix.json`).
fn cases(step: f32, only: &[String]) -> Result<Vec<Case>> {
    if let Some(bad) = only
        .iter()
        .find(|n| !SWEEPS.iter().any(|s| s.name == n.as_str()))
    {
        let names: Vec<&str> = SWEEPS.iter().map(|s| s.name).collect();
        bail!("--only {bad}: no such sweep (one of {})", names.join(", "));
    }
    let mut out = Vec::new();
    for (i, sweep) in SWEEPS.iter().enumerate() {
        if !only.is_empty() && !only.iter().any(|n| n == sweep.name) {
            continue;
        }
        let params: Vec<Option<f32>> = match sweep.range {
            Some([lo, hi]) => {
                let n = ((hi - lo) / step + 1e-4).floor() as usize;
                (0..=n).map(|k| Some(lo + k as f32 * step)).collect()
            }
            None => vec![None],
        };
        let radii: Vec<Option<f32>> = if sweep.radii.is_empty() {
            vec![None]
        } else {
            sweep.radii.iter().copied().map(Some).collect()
        };
        for trunk_radius in radii {
            for &parameter in &params {
                for &variant in sweep.variants {
                    out.push(Case {
                        sweep: i,
                        parameter,
                        variant,
                        trunk_radius,
                    });
                }
            }
        }
    }
    Ok(out)
}

/// The case's label in tables and plot folders.
fn label(case: &Case) -> String {
    let sweep = &SWEEPS[case.sweep];
    let l = match (case.parameter, sweep.variants.len() > 1) {
        (Some(v), _) => format!("{v}"),
        (None, true) => format!("{:?}", case.variant).to_lowercase(),
        (None, false) => "-".into(),
    };
    match case.trunk_radius {
        Some(r) => format!("{l}-r{r}"),
        None => l,
    }
}

/// Contiguous passing ranges of a sweep.
fn passing_ranges(runs: &[MatrixRun]) -> Vec<[f32; 2]> {
    let mut out: Vec<[f32; 2]> = Vec::new();
    let mut open: Option<[f32; 2]> = None;
    for r in runs {
        let Some(p) = r.parameter else { continue };
        match (&mut open, r.pass) {
            (Some(range), true) => range[1] = p,
            (None, true) => open = Some([p, p]),
            (Some(range), false) => {
                out.push(*range);
                open = None;
            }
            (None, false) => {}
        }
    }
    out.extend(open);
    out
}

/// Whether a failure of this run breaks the thesis range.
fn breaks_thesis(scenario: &str, run: &MatrixRun) -> bool {
    let Some(sweep) = SWEEPS.iter().find(|s| s.name == scenario) else {
        return false;
    };
    let in_thesis = match (sweep.thesis, run.parameter) {
        (Some([lo, hi]), Some(v)) => v > lo && v < hi,
        _ => true,
    };
    in_thesis && !run.pass
}

/// The rows from every case's run (in sweep order).
pub fn rows_of(runs: Vec<(String, MatrixRun)>) -> Vec<MatrixRow> {
    let mut rows: Vec<MatrixRow> = Vec::new();
    for (scenario, run) in runs {
        match rows.last_mut() {
            Some(row) if row.scenario == scenario && row.trunk_radius == run.trunk_radius => {
                row.runs.push(run)
            }
            _ => rows.push(MatrixRow {
                thesis_range: SWEEPS
                    .iter()
                    .find(|s| s.name == scenario)
                    .and_then(|s| s.thesis),
                trunk_radius: run.trunk_radius,
                scenario,
                runs: vec![run],
                passing: Vec::new(),
            }),
        }
    }
    for row in &mut rows {
        row.passing = passing_ranges(&row.runs);
    }
    rows
}

/// Prints the summary table; true when every thesis range passes.
pub fn summarise(rows: &[MatrixRow]) -> bool {
    println!();
    println!(
        "{:<14} {:<8} {:<22} passing here",
        "scenario", "trunk r", "thesis (strict)"
    );
    for row in rows {
        let thesis = row
            .thesis_range
            .map_or("success".to_string(), |[a, b]| format!("{a} < a < {b}"));
        let here = if row.thesis_range.is_some() {
            row.passing
                .iter()
                .map(|[a, b]| format!("{a}–{b}"))
                .collect::<Vec<_>>()
                .join(", ")
        } else if row.runs.iter().all(|r| r.pass) {
            "success".into()
        } else {
            "FAIL".into()
        };
        let fails = row.runs.iter().filter(|r| !r.pass).count();
        println!(
            "{:<14} {:<8} {:<22} {}  ({} of {} pass)",
            row.scenario,
            row.trunk_radius.map_or("-".into(), |r| format!("{r} m")),
            thesis,
            if here.is_empty() { "none".into() } else { here },
            row.runs.len() - fails,
            row.runs.len()
        );
    }
    !rows
        .iter()
        .any(|row| row.runs.iter().any(|r| breaks_thesis(&row.scenario, r)))
}

/// `slothsim matrix`: every preset over its range; true when the thesis ranges all pass.
pub fn matrix(args: MatrixArgs) -> Result<bool> {
    if !(args.step.is_finite() && args.step >= MIN_STEP_DEG) {
        bail!(
            "--step {} must be at least {MIN_STEP_DEG} degrees",
            args.step
        );
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    let shard = args.shard.resolve()?;
    if shard.count > 1 && args.out.is_none() {
        bail!("a sharded matrix writes its part into --out DIR; give --out");
    }
    let cfg = load_config(args.profile, args.config.as_deref())?;
    if let Some(dir) = &args.out {
        prepare_out(dir)?;
    }
    let rig = Rig::sloth();
    let all = cases(args.step, &args.only)?;
    let mine: Vec<(usize, Case)> = all
        .iter()
        .copied()
        .enumerate()
        .filter(|(k, _)| shard.owns(*k))
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(args.threads.unwrap_or(0))
        .build()
        .context("cannot start the worker threads")?;
    eprintln!(
        "{} of {} cases (shard {}/{}) on {} threads",
        mine.len(),
        all.len(),
        shard.index,
        shard.count,
        pool.current_num_threads()
    );
    let results: Vec<Result<(usize, String, MatrixRun)>> = pool.install(|| {
        mine.par_iter()
            .map(|&(k, case)| {
                let sweep = &SWEEPS[case.sweep];
                let spec = ScenarioSpec {
                    preset: Preset::with_trunk_radius(
                        sweep.kind,
                        case.parameter,
                        case.trunk_radius,
                    )?,
                    variant: case.variant,
                    cfg: cfg.clone(),
                    dt: 1.0 / 60.0,
                    time_limit_s: None,
                    tolerances: Tolerances::default(),
                };
                let r = run_scenario(&spec, &rig)?;
                if args.plots
                    && let Some(dir) = &args.out
                {
                    let sub = match label(&case).as_str() {
                        "-" => dir.join(sweep.name),
                        l => dir.join(format!("{}-{l}", sweep.name)),
                    };
                    std::fs::create_dir_all(&sub)
                        .with_context(|| format!("cannot create {}", sub.display()))?;
                    crate::plots::scenario_plots(&sub, &spec.preset.scene, goal_of(&spec), &r)?;
                }
                let run = MatrixRun {
                    parameter: case.parameter,
                    variant: case.variant.shown_for(sweep.kind).then_some(case.variant),
                    trunk_radius: case.trunk_radius,
                    pass: r.verdict.pass,
                    goal_time_s: r.judge.goal_time_s,
                    failures: r.verdict.failures.clone(),
                };
                Ok((k, sweep.name.to_string(), run))
            })
            .collect()
    });
    let mut done = Vec::with_capacity(results.len());
    for r in results {
        done.push(r?);
    }
    println!("{:<14} {:>8}  {:<6} notes", "scenario", "param", "result");
    for (k, name, run) in &done {
        println!(
            "{:<14} {:>8}  {:<6} {}",
            name,
            label(&all[*k]),
            if run.pass { "pass" } else { "FAIL" },
            run.failures.first().map_or("", |s| s.as_str())
        );
    }
    let provenance = Provenance::here(pool.current_num_threads(), Some(&cfg));
    if shard.count > 1 {
        let part = MatrixPart {
            step_deg: args.step,
            shard: [shard.index, shard.count],
            total_cases: all.len(),
            cases: done
                .into_iter()
                .map(|(case, scenario, run)| PartCase {
                    case,
                    scenario,
                    run,
                })
                .collect(),
        };
        let ok = !part
            .cases
            .iter()
            .any(|c| breaks_thesis(&c.scenario, &c.run));
        let dir = args.out.as_ref().context("--out")?;
        let name = format!("matrix-part-{}-of-{}.json", shard.index, shard.count);
        let path = write_json(dir, &name, &with_provenance(&part, &provenance))?;
        println!(
            "wrote {} (join the parts with `slothsim merge`)",
            path.display()
        );
        return Ok(ok);
    }
    let rows = rows_of(done.into_iter().map(|(_, n, r)| (n, r)).collect());
    let all_ok = summarise(&rows);
    if let Some(dir) = &args.out {
        let matrix = Matrix {
            step_deg: args.step,
            rows,
        };
        let path = write_json(dir, "matrix.json", &with_provenance(&matrix, &provenance))?;
        println!("wrote {}", path.display());
    }
    Ok(all_ok)
}
