//! Tail-first descent onto a trunk (issue 24 item 1): down a branch that
//! falls steeply to a trunk whose goal lies below the junction, the sloth
//! turns around on the branch, walks on tail first, and its hind limbs take
//! the trunk first, so it ends head up on the trunk and climbs down it.
//! Head first it reached the trunk head down and failed at every angle
//! below ~71° at all three radii the matrix sweeps. Seeded fractional
//! angles in 60–72° (never on the matrix's half-degree grid), each run
//! judged like a matrix case.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use slothsim::scene::{Preset, PresetKind};
use slothsim::sim::TrunkVariant;

mod common;

/// The radii the matrix sweeps the transfers at (m).
const RADII: [f32; 3] = [0.08, 0.15, 0.2];

/// Draws per radius.
const DRAWS: usize = 4;

/// The seed of the draws.
const SEED: u64 = 2411;

/// The failures of branch_trunk to-trunk at `angle`, `radius` (empty: it
/// passed), and a failure too where a fore limb took the trunk before
/// both hind limbs held it (the descent was not tail first).
fn run(angle: f32, radius: f32) -> Vec<String> {
    let trunk = Preset::with_trunk_radius(PresetKind::BranchTrunk, Some(angle), Some(radius))
        .unwrap()
        .goal
        .support;
    let r = common::run_transfer(TrunkVariant::ToTrunk, angle, radius);
    let mut failures = common::transfer_failures(&r);
    // Limbs 0, 1 fore (LF, RF), 2, 3 hind (LH, RH).
    let first_fore = r
        .observations
        .iter()
        .find(|o| o.limbs[..2].iter().any(|l| l.support == trunk));
    match first_fore {
        Some(o) if !o.limbs[2..].iter().all(|l| l.support == trunk) => failures.push(format!(
            "a fore limb took the trunk at {:.2} s before both hind limbs held it",
            o.time_s
        )),
        None => failures.push("no fore limb took the trunk".into()),
        _ => {}
    }
    failures
}

#[test]
fn steep_branch_to_trunk_descends_tail_first() {
    let mut rng = Pcg64::seed_from_u64(SEED);
    let mut cases = Vec::new();
    for &radius in &RADII {
        for _ in 0..DRAWS {
            let mut a: f32 = rng.random_range(60.0..72.0);
            if (a * 2.0).fract() == 0.0 {
                a += 0.01;
            }
            cases.push((a, radius));
        }
    }
    println!("draws (angle °, radius m): {cases:?}");
    let results: Vec<_> = cases
        .par_iter()
        .map(|&(a, r)| ((a, r), run(a, r)))
        .collect();
    let fails: Vec<String> = results
        .iter()
        .filter(|(_, f)| !f.is_empty())
        .map(|((a, r), f)| format!("  {a:.3}° r {r} m: {}", f.join("; ")))
        .collect();
    assert!(
        fails.is_empty(),
        "{} of {} draws fail:\n{}",
        fails.len(),
        results.len(),
        fails.join("\n")
    );
}
