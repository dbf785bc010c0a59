//! Branch ↔ trunk transfers at randomly drawn fractional angles (issue 24):
//! seeded draws, spread over the trunk radii the matrix sweeps, each run
//! judged like a matrix case (goal reached with all four limbs on the
//! goal's support, every judge measure within tolerance).
//!
//! `transfers_pass_at_random_angles` is the goal — every draw in
//! 60–160° passes. Its seed is `SLOTHSIM_TEST_SEED`, or else a new one each
//! day (printed), so each day's CI run draws angles no rule was tuned on.
//! It held at seeds 1–40 and at ten seeds of the days around 2026-11-28
//! once a back-off's length was chosen by playouts (before: 2 of seeds 1–20
//! failed); docs/scenarios.md lists the fresh draws that still fail
//! elsewhere. `transfer_pass_share_holds` runs on a fixed seed.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use slothsim::sim::TrunkVariant;

mod common;

/// Draws per transfer scenario per run.
const DRAWS: usize = 42;

/// The radii the matrix sweeps the transfers at (m).
const RADII: [f32; 3] = [0.08, 0.15, 0.2];

/// One drawn case: (variant, angle in degrees, trunk radius).
type Draw = (TrunkVariant, f32, f32);

/// `DRAWS` cases per transfer direction: angles uniform in 60–160° (never
/// on the matrix's half-degree grid), the radii in turn.
fn draws(seed: u64) -> Vec<Draw> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut out = Vec::new();
    for variant in [TrunkVariant::ToTrunk, TrunkVariant::ToBranch] {
        for k in 0..DRAWS {
            let mut a: f32 = rng.random_range(60.0..160.0);
            if (a * 2.0).fract() == 0.0 {
                a += 0.01;
            }
            out.push((variant, a, RADII[k % RADII.len()]));
        }
    }
    out
}

/// The failures of a drawn case (empty: it passed).
fn run((variant, angle, radius): Draw) -> Vec<String> {
    common::transfer_failures(&common::run_transfer(variant, angle, radius))
}

/// Every draw's failures, in draw order.
fn judged(cases: &[Draw]) -> Vec<(Draw, Vec<String>)> {
    cases.par_iter().map(|&c| (c, run(c))).collect()
}

fn report(results: &[(Draw, Vec<String>)]) -> String {
    results
        .iter()
        .filter(|(_, f)| !f.is_empty())
        .map(|((v, a, r), f)| format!("  {v:?} {a:.3}° r {r} m: {}", f.join("; ")))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn transfers_pass_at_random_angles() {
    let seed = std::env::var("SLOTHSIM_TEST_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or_else(|| {
            // A new seed each day.
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .unwrap()
                .as_secs()
                / 86_400
        });
    println!("SLOTHSIM_TEST_SEED={seed}");
    let results = judged(&draws(seed));
    let fails = report(&results);
    assert!(
        fails.is_empty(),
        "seed {seed}: {} of {} draws fail:\n{fails}",
        results.iter().filter(|(_, f)| !f.is_empty()).count(),
        results.len()
    );
}

/// The fixed seed of [`transfer_pass_share_holds`].
const SHARE_SEED: u64 = 24;

/// Draws of [`SHARE_SEED`] that pass, per direction (to the trunk, to the
/// branch), measured when the approach side step onto a goal branch was
/// built (27, 27 with the re-planning transfers; to the branch 30 → 36 when
/// the lower hind limb closed up toward its partner; to the trunk 29 → 30 with
/// the head kept above the hips through the second fore limb's step, 30 → 31
/// with the livelock watch outside transfers, 31 → 39 with the tail-first
/// descent down a branch falling to the trunk; to the branch 36 → 40 with the
/// hind grips on a trunk left for a branch around the hips' side, 40 → 42
/// with the body rolled in full to its own side of a trunk it leaves for a
/// branch; to the trunk 39 → 41 with the body rolled clear of a trunk it
/// approaches alongside; to the trunk 41 → 42 with a release wait that cannot
/// pass ended at once); the goal is all [`DRAWS`].
const SHARE_FLOOR: [usize; 2] = [42, 42];

#[test]
fn transfer_pass_share_holds() {
    let results = judged(&draws(SHARE_SEED));
    let passing = |v: TrunkVariant| {
        results
            .iter()
            .filter(|((variant, ..), f)| *variant == v && f.is_empty())
            .count()
    };
    let got = [
        passing(TrunkVariant::ToTrunk),
        passing(TrunkVariant::ToBranch),
    ];
    println!("passing draws (to trunk, to branch) of {DRAWS} each: {got:?}");
    println!("failing:\n{}", report(&results));
    assert!(
        got[0] >= SHARE_FLOOR[0] && got[1] >= SHARE_FLOOR[1],
        "passing draws {got:?} fell below {SHARE_FLOOR:?} (of {DRAWS} each):\n{}",
        report(&results)
    );
}
