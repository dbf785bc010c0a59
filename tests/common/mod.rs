//! Set-up shared by the integration tests.

use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;
use slothsim::gait::SpawnHint;
use slothsim::gait::sloth::Sloth;
use slothsim::gait::{LocomotionConfig, Profile};
use slothsim::rig::Rig;
use slothsim::scene::{Preset, TraceScene};
use slothsim::sim::Locomotion;
use slothsim::sim::{SlothState, new_world, spawn_sloth};

/// A world holding the pole preset (free profile, 60 Hz) and one sloth
/// spawned at its start, as spawned.
#[allow(dead_code)]
pub fn pole_sloth() -> (World, Sloth) {
    let (world, e) = pole_world(Profile::Free);
    let spawned = world.get::<SlothState>(e).unwrap().0;
    (world, spawned)
}

/// A world holding the pole preset (gait `profile`, 60 Hz) and the entity
/// of one sloth spawned at its start, walking toward the pole's far end.
#[allow(dead_code)]
pub fn pole_world(profile: Profile) -> (World, Entity) {
    let preset = Preset::by_name("pole", None).unwrap();
    let loco = Locomotion::new(
        LocomotionConfig::profile(profile),
        &Rig::sloth(),
        TraceScene::new(preset.scene.clone()),
    )
    .unwrap();
    let mut world = new_world(loco, 1.0 / 60.0);
    let hint = SpawnHint {
        support: preset.start.support,
        position: preset.start.position,
        forward: preset.start.forward,
        body_side: preset.start.body_side,
    };
    let e = spawn_sloth(&mut world, 0, &hint, None);
    (world, e)
}

/// One `branch_trunk` run (`variant`, branch angle in degrees, trunk radius
/// in metres) as the matrix runs its cases: free profile, 60 Hz, the
/// scenario's own time limit and the default tolerances.
#[allow(dead_code)]
pub fn run_transfer(
    variant: slothsim::sim::TrunkVariant,
    angle: f32,
    radius: f32,
) -> slothsim::sim::ScenarioResult {
    use slothsim::scene::PresetKind;
    let spec = slothsim::sim::ScenarioSpec {
        preset: Preset::with_trunk_radius(PresetKind::BranchTrunk, Some(angle), Some(radius))
            .unwrap(),
        variant,
        cfg: LocomotionConfig::default(),
        dt: 1.0 / 60.0,
        time_limit_s: None,
        tolerances: slothsim::observe::Tolerances::default(),
    };
    slothsim::sim::run_scenario(&spec, &Rig::sloth()).unwrap()
}

/// The judge's failures of run `r`, and "goal not reached" where the goal
/// was missed with every measure in tolerance (empty: it passed).
#[allow(dead_code)]
pub fn transfer_failures(r: &slothsim::sim::ScenarioResult) -> Vec<String> {
    let mut failures = r.verdict.failures.clone();
    if !r.judge.goal_reached && failures.is_empty() {
        failures.push("goal not reached".into());
    }
    failures
}

/// Runs transfer `variant` at every `(angle, trunk radius)` of `cases` in
/// parallel: one line per failing case (angle, radius, its failures).
#[allow(dead_code)]
pub fn transfer_case_failures(
    variant: slothsim::sim::TrunkVariant,
    cases: &[(f32, f32)],
) -> Vec<String> {
    use rayon::prelude::*;
    cases
        .par_iter()
        .filter_map(|&(a, r)| {
            let f = transfer_failures(&run_transfer(variant, a, r));
            (!f.is_empty()).then(|| format!("  {a:.3}° r {r} m: {}", f.join("; ")))
        })
        .collect()
}

/// Asserts that transfer `variant` passes at every `(angle, trunk radius)`
/// of `cases` (the failing ones listed otherwise).
#[allow(dead_code)]
pub fn assert_transfers_pass(variant: slothsim::sim::TrunkVariant, cases: &[(f32, f32)]) {
    let fails = transfer_case_failures(variant, cases);
    assert!(
        fails.is_empty(),
        "{} of {} draws fail:\n{}",
        fails.len(),
        cases.len(),
        fails.join("\n")
    );
}

/// `draws` fractional angles in each band `(lowest, highest, trunk radius)`
/// (degrees, m), band by band: lowest + width × frac((k + 1) φ) for draw
/// `k`, a low-discrepancy sequence, rounded to 0.001° (never on the
/// half-degree grid of `matrix --step 0.5`).
#[allow(dead_code)]
pub fn band_draws(bands: &[(f64, f64, f32)], draws: usize) -> Vec<(f32, f32)> {
    let phi = (5.0f64.sqrt() - 1.0) / 2.0;
    bands
        .iter()
        .flat_map(|&(lo, hi, r)| {
            (0..draws).map(move |k| {
                let a = lo + (hi - lo) * (((k + 1) as f64 * phi) % 1.0);
                ((a * 1000.0).round() as f32 / 1000.0, r)
            })
        })
        .collect()
}
