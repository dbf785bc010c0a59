//! `slothsim scenario` and `slothsim matrix`: one sloth on thesis presets, judged.

use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::{Args, ValueEnum};
use slothsim::gait::{LocomotionConfig, Profile, Tolerances};
use slothsim::rig::Limb;
use slothsim::rig::Rig;
use slothsim::scene::{Preset, PresetKind};
use slothsim::sim::{
    STEADY_AFTER_CYCLES, STEADY_BEFORE_STOP_CYCLES, ScenarioResult, ScenarioSpec, TrunkVariant,
    run_scenario, run_scenario_observed,
};

/// Gait profile names on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ProfileArg {
    /// The thesis model (0.11 m/s).
    Free,
    /// SPEC Table 1 steady state.
    Steady,
}

/// Scenario variant: trunk `up|down`, branch_trunk `to-trunk|to-branch`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum VariantArg {
    /// trunk: climb up.
    Up,
    /// trunk: climb down, head up.
    Down,
    /// trunk: side-step half way around the trunk's axis.
    Around,
    /// branch_trunk: branch → trunk, then down it head up (transfer_to_trunk).
    ToTrunk,
    /// branch_trunk: trunk → branch, from below the junction (transfer_to_branch).
    ToBranch,
}

/// The variant to run preset `kind` with: `--variant` if it fits the preset,
/// else the preset's default; an error names the variants the preset takes.
pub fn variant_for(kind: PresetKind, arg: Option<VariantArg>) -> Result<TrunkVariant> {
    Ok(match (kind, arg) {
        (PresetKind::Trunk, None | Some(VariantArg::Up)) => TrunkVariant::Up,
        (PresetKind::Trunk, Some(VariantArg::Down)) => TrunkVariant::Down,
        (PresetKind::Trunk, Some(VariantArg::Around)) => TrunkVariant::Around,
        (PresetKind::BranchTrunk, None | Some(VariantArg::ToTrunk)) => TrunkVariant::Up,
        (PresetKind::BranchTrunk, Some(VariantArg::ToBranch)) => TrunkVariant::ToBranch,
        (_, None) => TrunkVariant::Up,
        (PresetKind::Trunk, Some(v)) | (PresetKind::BranchTrunk, Some(v)) => {
            let allowed = if kind == PresetKind::Trunk {
                "up, down, around"
            } else {
                "to-trunk, to-branch"
            };
            bail!(
                "--variant {} does not apply to preset `{}` (allowed: {allowed})",
                format!("{v:?}").to_lowercase(),
                kind.name()
            )
        }
        (_, Some(_)) => bail!(
            "preset `{}` has no variants (--variant is for trunk and branch_trunk)",
            kind.name()
        ),
    })
}

#[derive(Args)]
pub struct ScenarioArgs {
    /// turn, parallel, trunk, height_change, branch_trunk, pole.
    name: String,
    /// Preset angle in degrees (turn, height_change, branch_trunk).
    #[arg(long, allow_hyphen_values = true)]
    angle: Option<f32>,
    /// Preset parameter in metres (parallel: gap; trunk: radius).
    #[arg(long, allow_hyphen_values = true)]
    param: Option<f32>,
    /// Gait profile.
    #[arg(long, value_enum, default_value = "free")]
    profile: ProfileArg,
    /// Variant: trunk up|down (default up); branch_trunk to-trunk|to-branch (default to-trunk).
    #[arg(long, value_enum)]
    variant: Option<VariantArg>,
    /// Locomotion config (TOML); overrides the profile's defaults.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Fixed time step (s).
    #[arg(long, default_value_t = 1.0 / 60.0)]
    dt: f32,
    /// Give up after this many simulated seconds (default: from the path length).
    #[arg(long, allow_hyphen_values = true)]
    seconds: Option<f32>,
    /// Output folder for scenario.json and the plots.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Do not draw plots (topdown.png, side.png, gait.png, frame_times.png) into --out.
    #[arg(long)]
    no_plots: bool,
    #[command(flatten)]
    record: crate::export_cmd::RecordArgs,
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

fn print_result(r: &ScenarioResult) {
    let j = &r.judge;
    let p = r.parameter.map_or(String::new(), |v| format!(" {v}"));
    let v = r.variant.map_or(String::new(), |v| {
        format!(
            " ({})",
            serde_json::to_value(v)
                .unwrap_or_default()
                .as_str()
                .unwrap_or("")
        )
    });
    println!(
        "scenario {}{p}{v}: {}",
        r.scenario,
        if r.verdict.pass { "PASS" } else { "FAIL" }
    );
    println!(
        "  status {:?}, goal reached {} at {:?} s (limit {:.0} s)",
        r.status, j.goal_reached, j.goal_time_s, r.time_limit_s
    );
    println!(
        "  slip {:.4} m, gap {:.4} m, reach ratio {:.3}, limit violations {}, min contact {}, penetration {:.4} m, head-below-hips {}, NaN {}",
        j.max_grip_slip_m,
        j.max_surface_gap_m,
        j.max_reach_ratio,
        j.joint_limit_violations,
        j.min_limbs_in_contact,
        j.max_penetration_m,
        j.head_below_hips_on_trunk_frames,
        j.nan_count
    );
    println!(
        "  speed {:.3} m/s, footfall order {:?}",
        r.gait.speed_mps_mean,
        r.gait.footfall_order.iter().take(8).collect::<Vec<_>>()
    );
    print_limbs("whole run", &r.gait);
    match &r.gait_steady {
        Some(st) => print_limbs(
            &format!(
                "steady state {:.1}–{:.1} s, {:.3} m/s",
                st.from_s, st.to_s, st.gait.speed_mps_mean
            ),
            &st.gait,
        ),
        None => println!(
            "  steady state: none (from {STEADY_AFTER_CYCLES} gait cycles after the start to {STEADY_BEFORE_STOP_CYCLES} before the stop is under one cycle)"
        ),
    }
    for f in &r.verdict.failures {
        println!("  failed: {f}");
    }
}

/// One line of per-limb means: contact / swing (s), stride (m).
fn print_limbs(label: &str, g: &slothsim::gait::GaitReport) {
    let limbs = Limb::ALL.map(|limb| {
        let l = g.limbs.get(limb);
        format!(
            "{} {:.2}/{:.2} s {:.3} m",
            limb.name(),
            l.contact_s_mean,
            l.swing_s_mean,
            l.stride_m_mean
        )
    });
    println!("  {label}: contact/swing, stride: {}", limbs.join(", "));
}

/// The goal point as run (variants may swap start and goal; a goal with a
/// side is drawn where the body would be, beside the axis).
fn goal_of(spec: &ScenarioSpec) -> glam::Vec3 {
    let goal = spec.variant.start_goal(&spec.preset).1;
    goal.point + goal.side.map_or(glam::Vec3::ZERO, |side| side * 0.3)
}

/// `slothsim scenario`: exit code 0 pass, 1 fail.
pub fn scenario(args: ScenarioArgs) -> Result<bool> {
    let kind = PresetKind::parse(&args.name)?;
    let value = preset_value(kind, args.angle, args.param)?;
    let preset = Preset::new(kind, value)?;
    if !(args.dt.is_finite() && args.dt > 0.0 && args.dt <= 0.1) {
        bail!("--dt {} is outside the allowed range (0, 0.1] s", args.dt);
    }
    if let Some(s) = args.seconds
        && !(s.is_finite() && s > 0.0)
    {
        bail!("--seconds {s} must be a positive duration");
    }
    let cfg = load_config(args.profile, args.config.as_deref())?;
    let spec = ScenarioSpec {
        preset,
        variant: variant_for(kind, args.variant)?,
        cfg,
        dt: args.dt,
        time_limit_s: args.seconds,
        tolerances: Tolerances::default(),
    };
    if let Some(dir) = &args.out {
        crate::run_cmd::prepare_out(dir)?;
    }
    let rig = Rig::sloth();
    let mut sampler = crate::export_cmd::start_scenario(
        &args.record,
        args.out.as_deref(),
        &rig,
        args.dt,
        &format!("scenario {}", kind.name()),
        args.seconds.unwrap_or(120.0),
    )?;
    let result = match sampler.as_mut() {
        Some(s) => run_scenario_observed(&spec, &rig, &mut |sloth, loco| {
            s.after_tick_sloth(sloth, loco);
        })?,
        None => run_scenario(&spec, &rig)?,
    };
    print_result(&result);
    if let (Some(s), Some(dir)) = (sampler, &args.out) {
        crate::export_cmd::finish(s, &spec.preset.scene, dir)?;
    }
    if let Some(dir) = &args.out {
        let path = write_json(dir, "scenario.json", &result)?;
        println!("wrote {}", path.display());
        if !args.no_plots {
            let costs =
                crate::plots::scenario_plots(dir, &spec.preset.scene, goal_of(&spec), &result)?;
            crate::plots::print_costs(&costs, dir);
        }
    }
    Ok(result.verdict.pass)
}

#[derive(Args)]
pub struct MatrixArgs {
    /// Gait profile.
    #[arg(long, value_enum, default_value = "free")]
    profile: ProfileArg,
    /// Locomotion config (TOML); overrides the profile's defaults.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Angle step of the sweeps, degrees.
    #[arg(long, default_value_t = 5.0)]
    step: f32,
    /// Output folder for matrix.json.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Also draw every case's plots into a subfolder of --out (e.g. `turn-135/`).
    #[arg(long, requires = "out")]
    plots: bool,
}

/// One row of the matrix.
#[derive(serde::Serialize)]
struct MatrixRow {
    scenario: String,
    thesis_range: Option<[f32; 2]>,
    runs: Vec<MatrixRun>,
    passing: Vec<[f32; 2]>,
}

#[derive(serde::Serialize)]
struct MatrixRun {
    parameter: Option<f32>,
    variant: Option<TrunkVariant>,
    pass: bool,
    goal_time_s: Option<f32>,
    failures: Vec<String>,
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

/// `slothsim matrix`: every preset over its range; true when the thesis ranges all pass.
pub fn matrix(args: MatrixArgs) -> Result<bool> {
    if !(args.step.is_finite() && args.step >= 1.0) {
        bail!("--step {} must be at least 1 degree", args.step);
    }
    let cfg = load_config(args.profile, args.config.as_deref())?;
    let rig = Rig::sloth();
    // (row name, preset, its variants, sweep range, thesis range: its
    // strict interior must pass). `trunk_branch` is branch_trunk run the
    // other way (trunk → branch, `transfer_to_branch`): the thesis's test 5
    // covers both ways.
    type Sweep = (
        &'static str,
        PresetKind,
        &'static [TrunkVariant],
        Option<[f32; 2]>,
        Option<[f32; 2]>,
    );
    const UP: &[TrunkVariant] = &[TrunkVariant::Up];
    let sweeps: [Sweep; 7] = [
        (
            "turn",
            PresetKind::Turn,
            UP,
            Some([60.0, 180.0]),
            Some([95.0, 175.0]),
        ),
        (
            "height_change",
            PresetKind::HeightChange,
            UP,
            Some([110.0, 220.0]),
            Some([135.0, 200.0]),
        ),
        (
            "branch_trunk",
            PresetKind::BranchTrunk,
            UP,
            Some([60.0, 160.0]),
            Some([90.0, 140.0]),
        ),
        (
            "trunk_branch",
            PresetKind::BranchTrunk,
            &[TrunkVariant::ToBranch],
            Some([60.0, 160.0]),
            Some([90.0, 140.0]),
        ),
        ("parallel", PresetKind::Parallel, UP, None, None),
        (
            "trunk",
            PresetKind::Trunk,
            &[TrunkVariant::Up, TrunkVariant::Down, TrunkVariant::Around],
            None,
            None,
        ),
        ("pole", PresetKind::Pole, UP, None, None),
    ];
    let mut rows = Vec::new();
    let mut all_ok = true;
    println!("{:<14} {:>8}  {:<6} notes", "scenario", "param", "result");
    for (row_name, kind, variants, sweep, thesis) in sweeps {
        let mut runs = Vec::new();
        let params: Vec<Option<f32>> = match sweep {
            Some([lo, hi]) => {
                let n = ((hi - lo) / args.step).floor() as usize;
                (0..=n).map(|i| Some(lo + i as f32 * args.step)).collect()
            }
            None => vec![None],
        };
        for p in params {
            for &variant in variants {
                let spec = ScenarioSpec {
                    preset: Preset::new(kind, p)?,
                    variant,
                    cfg: cfg.clone(),
                    dt: 1.0 / 60.0,
                    time_limit_s: None,
                    tolerances: Tolerances::default(),
                };
                let r = run_scenario(&spec, &rig)?;
                let label = match (p, variants.len() > 1) {
                    (Some(v), _) => format!("{v}"),
                    (None, true) => format!("{variant:?}").to_lowercase(),
                    (None, false) => "-".into(),
                };
                if args.plots
                    && let Some(dir) = &args.out
                {
                    let sub = match label.as_str() {
                        "-" => dir.join(row_name),
                        l => dir.join(format!("{row_name}-{l}")),
                    };
                    std::fs::create_dir_all(&sub)
                        .with_context(|| format!("cannot create {}", sub.display()))?;
                    crate::plots::scenario_plots(&sub, &spec.preset.scene, goal_of(&spec), &r)?;
                }
                println!(
                    "{:<14} {:>8}  {:<6} {}",
                    row_name,
                    label,
                    if r.verdict.pass { "pass" } else { "FAIL" },
                    r.verdict.failures.first().map_or("", |s| s.as_str())
                );
                let in_thesis = match (thesis, p) {
                    (Some([lo, hi]), Some(v)) => v > lo && v < hi,
                    _ => true,
                };
                if in_thesis && !r.verdict.pass {
                    all_ok = false;
                }
                runs.push(MatrixRun {
                    parameter: p,
                    variant: variant.shown_for(kind).then_some(variant),
                    pass: r.verdict.pass,
                    goal_time_s: r.judge.goal_time_s,
                    failures: r.verdict.failures.clone(),
                });
            }
        }
        let passing = passing_ranges(&runs);
        rows.push(MatrixRow {
            scenario: row_name.into(),
            thesis_range: thesis,
            runs,
            passing,
        });
    }
    println!();
    println!("{:<14} {:<22} passing here", "scenario", "thesis (strict)");
    for row in &rows {
        let thesis = row
            .thesis_range
            .map_or("success".to_string(), |[a, b]| format!("{a} < a < {b}"));
        let here = if row.thesis_range.is_some() {
            row.passing
                .iter()
                .map(|[a, b]| format!("{a}–{b}"))
                .collect::<Vec<_>>()
                .join(", ")
        } else {
            let ok = row.runs.iter().all(|r| r.pass);
            if ok { "success".into() } else { "FAIL".into() }
        };
        println!(
            "{:<14} {:<22} {}",
            row.scenario,
            thesis,
            if here.is_empty() { "none".into() } else { here }
        );
    }
    if let Some(dir) = &args.out {
        let path = write_json(dir, "matrix.json", &rows)?;
        println!("wrote {}", path.display());
    }
    Ok(all_ok)
}
