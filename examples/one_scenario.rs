//! Run one thesis scenario (a branch turning by 120°) and read its verdict
//! and the judge's measures.
//!
//! `cargo run --release --example one_scenario`

use anyhow::Result;
use slothsim::gait::LocomotionConfig;
use slothsim::observe::Tolerances;
use slothsim::rig::Rig;
use slothsim::scene::{Preset, PresetKind};
use slothsim::sim::{ScenarioSpec, TrunkVariant, run_scenario};

fn main() -> Result<()> {
    let spec = ScenarioSpec {
        preset: Preset::new(PresetKind::Turn, Some(120.0))?,
        variant: TrunkVariant::Up,
        cfg: LocomotionConfig::default(),
        dt: 1.0 / 60.0,
        time_limit_s: None,
        tolerances: Tolerances::default(),
    };
    let result = run_scenario(&spec, &Rig::sloth())?;
    let j = &result.judge;
    println!(
        "turn 120°: {} in {:?} s; slip {:.4} m, gap {:.4} m, penetration {:.4} m, reach ratio {:.2}",
        if result.verdict.pass { "pass" } else { "FAIL" },
        j.goal_time_s,
        j.max_grip_slip_m,
        j.max_surface_gap_m,
        j.max_penetration_m,
        j.max_reach_ratio
    );
    for failure in &result.verdict.failures {
        println!("  {failure}");
    }
    anyhow::ensure!(result.verdict.pass, "the scenario failed");
    Ok(())
}
