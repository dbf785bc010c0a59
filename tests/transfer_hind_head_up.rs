//! Branch → trunk with both fore limbs across and the hind limbs locked on
//! the branch (issue 24 item 1). The hind limbs still on the branch keep
//! the head-up margin below the fore limbs on the trunk; measured against
//! the lower fore grip, a fore limb that took the trunk just the margin
//! above the hind grips locked the stance: the hind limbs could not step
//! up a branch rising to the trunk, the trunk lay just beyond a transfer
//! step, and the fore limbs stood at the transfer's spread cap
//! (branch_trunk at 114.5°, 0.2 m, for 70 s). Measured against the mean
//! height of the fore grips on the trunk (the shoulders' there), the hind
//! limbs close up and step across.
//!
//! Fractional angles (never on the half-degree grid) from a low-discrepancy
//! sequence over four bands around the angles the rule gained in
//! `matrix --step 0.5`; the count that passes must not fall.

use slothsim::sim::TrunkVariant;

mod common;

/// The bands (lowest and highest angle in degrees, the trunk's radius in m).
const BANDS: [(f64, f64, f32); 4] = [
    (98.0, 100.0, 0.2),
    (113.5, 115.5, 0.2),
    (123.5, 125.5, 0.08),
    (131.0, 133.0, 0.08),
];

/// Draws per band.
const DRAWS: usize = 6;

/// Passing draws of all bands, measured with the mean height (main a264781:
/// 22 of 24; 98.472° at 0.2 m and 131.944° at 0.08 m failed).
const FLOOR: usize = 24;

#[test]
fn hind_limbs_close_up_below_the_fore_grips_mean_height() {
    let cases = common::band_draws(&BANDS, DRAWS);
    let fails = common::transfer_case_failures(TrunkVariant::ToTrunk, &cases);
    let passing = cases.len() - fails.len();
    println!(
        "{passing} of {} pass; failing:\n{}",
        cases.len(),
        fails.join("\n")
    );
    assert!(
        passing >= FLOOR,
        "{passing} of {} draws pass (floor {FLOOR}):\n{}",
        cases.len(),
        fails.join("\n")
    );
}
