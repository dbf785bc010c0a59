//! Trunk → branch onto a branch falling steeply from the trunk (issue 24
//! item 1): `branch_trunk --variant to-branch` where the fore limbs walk out
//! along the branch while both hind limbs stand level on the trunk far
//! below the junction. From there one hind limb was always farther than a
//! transfer step (0.405 m) from the pair's grips on the branch, and each
//! hind limb alone stopped short of it (138°, 0.2 m: the hind grips 0.45 m
//! below the junction; 147.5° and 156° at 0.08 m). A hind limb level with
//! its partner and more than a step below the branch's root now climbs
//! toward the junction, and the partner closes up (`Sloth::hind_closing`).
//!
//! Fractional angles (never on the half-degree grid) from a low-discrepancy
//! sequence over the three bands where every 0.1° failed before
//! (137.6–138.2° at 0.2 m, 147.5–147.9° and 156.0–156.5° at 0.08 m: 17 of
//! 21 tenths failed on main 6112305); every draw must pass.

use slothsim::sim::TrunkVariant;

mod common;

/// The bands (lowest angle, highest angle, trunk radius), degrees and m.
const BANDS: [(f64, f64, f32); 3] = [
    (137.55, 138.25, 0.2),
    (147.45, 147.95, 0.08),
    (155.95, 156.55, 0.08),
];

/// Draws per band.
const DRAWS: usize = 5;

#[test]
fn hind_limbs_climb_to_a_branch_falling_from_the_trunk() {
    let cases = common::band_draws(&BANDS, DRAWS);
    common::assert_transfers_pass(TrunkVariant::ToBranch, &cases);
}
