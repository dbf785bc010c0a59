//! The trunk radii the presets accept (issue 24: a tool must not accept
//! inputs it cannot do): `branch_trunk --trunk-radius` within
//! [`BRANCH_TRUNK_RADIUS_RANGE`] and `trunk --param` within
//! [`TRUNK_RADIUS_RANGE`], the ranges measured to pass (docs/scenarios.md
//! "Thick trunks"). Seeded random radii across the whole accepted range,
//! each with a fractional branch angle (never on the half-degree grid of
//! `matrix --step 0.5`), both transfers, and the trunk's three climbs at
//! random radii; each run judged like a matrix case.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use slothsim::gait::LocomotionConfig;
use slothsim::observe::Tolerances;
use slothsim::rig::Rig;
use slothsim::scene::{BRANCH_TRUNK_RADIUS_RANGE, Preset, PresetKind, TRUNK_RADIUS_RANGE};
use slothsim::sim::{ScenarioSpec, TrunkVariant, run_scenario};

mod common;

/// The fixed seed.
const SEED: u64 = 38;

/// branch_trunk draws per transfer (radius × angle).
const TRANSFER_DRAWS: usize = 24;

/// Trunk radii drawn for the trunk preset (each climbed up, down, around).
const TRUNK_DRAWS: usize = 4;

/// A value drawn from `[lo, hi]`.
fn draw(rng: &mut Pcg64, [lo, hi]: [f32; 2]) -> f32 {
    lo + (hi - lo) * rng.random::<f32>()
}

#[test]
fn both_transfers_pass_across_the_accepted_trunk_radii() {
    let mut rng = Pcg64::seed_from_u64(SEED);
    for variant in [TrunkVariant::ToTrunk, TrunkVariant::ToBranch] {
        let cases: Vec<(f32, f32)> = (0..TRANSFER_DRAWS)
            .map(|_| {
                let r = draw(&mut rng, BRANCH_TRUNK_RADIUS_RANGE);
                let a = draw(&mut rng, [60.0, 160.0]);
                let a = if (a * 2.0).fract() == 0.0 {
                    a + 0.01
                } else {
                    a
                };
                (a, r)
            })
            .collect();
        common::assert_transfers_pass(variant, &cases);
    }
}

#[test]
fn the_trunk_is_climbed_across_its_accepted_radii() {
    let mut rng = Pcg64::seed_from_u64(SEED + 1);
    let mut radii: Vec<f32> = (0..TRUNK_DRAWS)
        .map(|_| draw(&mut rng, TRUNK_RADIUS_RANGE))
        .collect();
    // The thickest accepted trunk, always.
    radii.push(TRUNK_RADIUS_RANGE[1]);
    let cases: Vec<(TrunkVariant, f32)> = radii
        .iter()
        .flat_map(|&r| [TrunkVariant::Up, TrunkVariant::Down, TrunkVariant::Around].map(|v| (v, r)))
        .collect();
    let fails: Vec<String> = cases
        .par_iter()
        .filter_map(|&(variant, r)| {
            let spec = ScenarioSpec {
                preset: Preset::new(PresetKind::Trunk, Some(r)).unwrap(),
                variant,
                cfg: LocomotionConfig::default(),
                dt: 1.0 / 60.0,
                time_limit_s: None,
                tolerances: Tolerances::default(),
            };
            let result = run_scenario(&spec, &Rig::sloth()).unwrap();
            let f = common::transfer_failures(&result);
            (!f.is_empty()).then(|| format!("  {variant:?} r {r:.4} m: {}", f.join("; ")))
        })
        .collect();
    assert!(
        fails.is_empty(),
        "{} of {} trunk climbs fail:\n{}",
        fails.len(),
        cases.len(),
        fails.join("\n")
    );
}
