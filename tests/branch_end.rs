//! Turning around at a branch end (issue 24 item 2; thesis scenario 4): the
//! sloth walks to the free end of a branch, turns its body around by steps
//! and walks back head first to a goal behind its start. Seeded draws of
//! fractional inclinations (−30..30°) and branch radii (0.02–0.08 m), each
//! judged like a matrix case: goal reached, every judge measure within
//! tolerance over every frame, the body turned around (the scenario's
//! verdict checks it), the diagonal footfall order kept.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use slothsim::gait::{LocomotionConfig, Status};
use slothsim::observe::Tolerances;
use slothsim::rig::Rig;
use slothsim::scene::Preset;
use slothsim::sim::{ScenarioSpec, TrunkVariant, run_scenario};

/// Draws per run.
const DRAWS: usize = 40;

/// Fixed seed (CI).
const SEED: u64 = 0x51_07_4e_d0;

/// The failures of branch_end at inclination `angle` (deg) on a branch of
/// `radius` (m); empty: it passed.
fn run(angle: f32, radius: f32) -> Vec<String> {
    let spec = ScenarioSpec {
        preset: Preset::branch_end(Some(angle), Some(radius)).unwrap(),
        variant: TrunkVariant::Up,
        cfg: LocomotionConfig::default(),
        dt: 1.0 / 60.0,
        time_limit_s: None,
        tolerances: Tolerances::default(),
    };
    let r = run_scenario(&spec, &Rig::sloth()).unwrap();
    let mut failures = r.verdict.failures.clone();
    if r.status != Status::Arrived {
        failures.push(format!("status {:?}", r.status));
    }
    // Every lift-off of the run, the turn included, in the diagonal
    // sequence (RH, LF, LH, RF; indices LF 0, RF 1, LH 2, RH 3).
    let mut lifts = Vec::new();
    for w in r.observations.windows(2) {
        for i in 0..4 {
            if w[0].limbs[i].planted && !w[1].limbs[i].planted {
                lifts.push(i);
            }
        }
    }
    let next = |i: usize| match i {
        3 => 0,
        0 => 2,
        2 => 1,
        _ => 3,
    };
    // A limb whose step the search skipped (none found) is passed over: the
    // next lift-off is a later limb of the sequence, never an earlier one.
    if let Some(w) = lifts.windows(2).find(|w| w[1] == w[0]) {
        failures.push(format!("a limb lifted twice in a row: {w:?}"));
    }
    let in_order = lifts
        .windows(2)
        .filter(|w| next(w[0]) == w[1])
        .count();
    if lifts.len() > 1 && in_order * 10 < (lifts.len() - 1) * 9 {
        failures.push(format!(
            "footfall order: {in_order} of {} lift-offs in the diagonal sequence",
            lifts.len() - 1
        ));
    }
    failures
}

#[test]
fn turns_around_at_the_default_branch_end() {
    let f = run(0.0, 0.02);
    assert!(f.is_empty(), "branch_end 0°: {f:?}");
}

#[test]
fn turns_around_at_random_inclinations_and_radii() {
    let mut rng = Pcg64::seed_from_u64(SEED);
    let draws: Vec<(f32, f32)> = (0..DRAWS)
        .map(|_| (rng.random_range(-30.0..30.0), rng.random_range(0.02..0.08)))
        .collect();
    let failed: Vec<String> = draws
        .par_iter()
        .filter_map(|&(a, r)| {
            let f = run(a, r);
            (!f.is_empty()).then(|| format!("{a:.3}° r {r:.4} m: {f:?}"))
        })
        .collect();
    assert!(
        failed.is_empty(),
        "{} of {DRAWS} draws failed:\n{}",
        failed.len(),
        failed.join("\n")
    );
}

#[test]
fn branch_radius_out_of_range_is_a_clear_error() {
    for r in [0.0, 0.01, 0.2, f32::NAN] {
        let e = Preset::branch_end(None, Some(r)).unwrap_err().to_string();
        assert!(e.contains("branch_radius"), "{r}: {e}");
    }
    assert!(Preset::branch_end(Some(45.0), None).is_err());
}
