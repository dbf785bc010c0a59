//! `slothsim scenario`: one sloth on a thesis preset, judged.

use std::path::PathBuf;

use anyhow::{Result, bail};
use clap::{Args, ValueEnum};
use slothsim::observe::Tolerances;
use slothsim::rig::Limb;
use slothsim::rig::Rig;
use slothsim::scene::{Preset, PresetKind};
use slothsim::sim::{
    STEADY_AFTER_CYCLES, STEADY_BEFORE_STOP_CYCLES, ScenarioResult, ScenarioSpec, TrunkVariant,
    run_scenario, run_scenario_observed,
};

use crate::cli_common::{ProfileArg, load_config, prepare_out, preset_value, write_json};
use crate::provenance::{Provenance, with_provenance};

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
    /// turn, parallel, trunk, height_change, branch_trunk, pole, branch_end.
    name: String,
    /// Preset angle in degrees (turn, height_change, branch_trunk; branch_end: the branch's inclination).
    #[arg(long, allow_hyphen_values = true)]
    angle: Option<f32>,
    /// Preset parameter in metres (parallel: gap; trunk: radius).
    #[arg(long, allow_hyphen_values = true)]
    param: Option<f32>,
    /// branch_trunk: the trunk's radius in metres (0.05–0.21; default 0.15).
    #[arg(long, allow_hyphen_values = true)]
    trunk_radius: Option<f32>,
    /// branch_end: the branch's radius in metres (0.02–0.08; default 0.02).
    #[arg(long, allow_hyphen_values = true)]
    branch_radius: Option<f32>,
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
fn print_limbs(label: &str, g: &slothsim::observe::GaitReport) {
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
pub fn goal_of(spec: &ScenarioSpec) -> glam::Vec3 {
    let goal = spec.variant.start_goal(&spec.preset).1;
    goal.point + goal.side.map_or(glam::Vec3::ZERO, |side| side * 0.3)
}

/// `slothsim scenario`: exit code 0 pass, 1 fail.
pub fn scenario(args: ScenarioArgs) -> Result<bool> {
    let kind = PresetKind::parse(&args.name)?;
    let value = preset_value(kind, args.angle, args.param)?;
    let preset = match (kind, args.branch_radius) {
        (PresetKind::BranchEnd, r) if args.trunk_radius.is_none() => Preset::branch_end(value, r)?,
        (_, Some(_)) => bail!("--branch-radius is for preset `branch_end` only"),
        _ => Preset::with_trunk_radius(kind, value, args.trunk_radius)?,
    };
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
        prepare_out(dir)?;
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
        crate::export_cmd::finish(s, &spec.preset.scene, dir, &args.record)?;
    }
    if let Some(dir) = &args.out {
        let provenance = Provenance::here(1, Some(&spec.cfg));
        let path = write_json(dir, "scenario.json", &with_provenance(&result, &provenance))?;
        println!("wrote {}", path.display());
        if !args.no_plots {
            let costs =
                crate::plots::scenario_plots(dir, &spec.preset.scene, goal_of(&spec), &result)?;
            crate::plots::print_costs(&costs, dir);
        }
    }
    Ok(result.verdict.pass)
}
