//! Trunk → branch into the wedge (issue 24 item 1): `branch_trunk --variant
//! to-branch` with the branch leaving the trunk steeply downward (146–160°),
//! a narrow wedge between branch and trunk below the junction. Once on the
//! branch the body hangs below it, toward the trunk, and rolls about the
//! branch to clear it; the trunk it left lies behind it at the branch's
//! root, and the roll keeps the body's own side in full. Weighed as a trunk
//! beside the branch, a few degrees of yaw halved the roll: the hips hung
//! in the trunk, every step out along the branch was refused and the sloth
//! stalled (main 4a54af1 passed 38 and 35 of 141 tenth-degree angles here
//! at 0.15 and 0.2 m).
//!
//! Seeded fractional draws (never on the half-degree grid), each judged like
//! a matrix case: goal reached, every judge measure within tolerance.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use slothsim::sim::TrunkVariant;

mod common;

/// The trunk radii (m).
const RADII: [f32; 2] = [0.15, 0.2];

/// Branch angles drawn from (degrees).
const ANGLES: std::ops::Range<f32> = 146.0..160.0;

/// Draws per radius.
const DRAWS: usize = 8;

/// The fixed seed.
const SEED: u64 = 146;

/// `draws` seeded (angle, radius) cases per radius of [`RADII`], angles in
/// [`ANGLES`], none on the half-degree grid.
fn draw_cases(seed: u64, draws: usize) -> Vec<(f32, f32)> {
    let mut rng = Pcg64::seed_from_u64(seed);
    RADII
        .iter()
        .flat_map(|&r| std::iter::repeat_n(r, draws))
        .map(|r| {
            let a: f32 = rng.random_range(ANGLES);
            let a = if (a * 2.0).fract() == 0.0 {
                a + 0.01
            } else {
                a
            };
            (a, r)
        })
        .collect()
}

#[test]
fn trunk_to_branch_into_the_wedge() {
    let cases = draw_cases(SEED, DRAWS);
    println!("cases (angle, radius): {cases:?}");
    common::assert_transfers_pass(TrunkVariant::ToBranch, &cases);
}

/// Branch → trunk draws per radius (`branch_to_trunk_in_the_wedge`).
const ONTO_DRAWS: usize = 16;

/// The fixed seed of `branch_to_trunk_in_the_wedge`.
const ONTO_SEED: u64 = 155;

/// Draws of [`ONTO_SEED`] that pass, at 0.15 and 0.2 m, with the body
/// rolled clear of the trunk it approaches alongside (`Sloth::approach_trunk`,
/// docs/scenarios.md); main 7850e2a passed 8 and 2 of these angles (to 3 decimals, by
/// `slothsim scenario`); 12 and 14 once a release wait that cannot pass ends at
/// once (load.rs `wait_is_futile`).
const ONTO_FLOOR: [usize; 2] = [12, 14];

/// Branch → trunk (head first) into the wedge: the branch rises steeply to
/// the trunk (146–160°), and the body hanging below it lies beside the
/// trunk, its back to it. Seeded fractional draws at 0.15 and 0.2 m, each
/// judged like a matrix case; the passing share must not fall below
/// [`ONTO_FLOOR`] (not all pass yet: docs/scenarios.md).
#[test]
fn branch_to_trunk_in_the_wedge() {
    let cases = draw_cases(ONTO_SEED, ONTO_DRAWS);
    let results: Vec<(f32, f32, Vec<String>)> = cases
        .par_iter()
        .map(|&(a, r)| {
            let res = common::run_transfer(TrunkVariant::ToTrunk, a, r);
            (a, r, common::transfer_failures(&res))
        })
        .collect();
    for (a, r, f) in &results {
        println!("{a:.3} {r} {}", if f.is_empty() { "pass" } else { "FAIL" });
    }
    let got = RADII.map(|r| {
        results
            .iter()
            .filter(|(_, rr, f)| *rr == r && f.is_empty())
            .count()
    });
    let fails: Vec<String> = results
        .iter()
        .filter(|(_, _, f)| !f.is_empty())
        .map(|(a, r, f)| format!("  {a:.3}° r {r} m: {}", f.join("; ")))
        .collect();
    println!("passing draws at {RADII:?} m of {ONTO_DRAWS} each: {got:?}");
    assert!(
        got[0] >= ONTO_FLOOR[0] && got[1] >= ONTO_FLOOR[1],
        "passing draws {got:?} fell below {ONTO_FLOOR:?} (of {ONTO_DRAWS} each):\n{}",
        fails.join("\n")
    );
}
