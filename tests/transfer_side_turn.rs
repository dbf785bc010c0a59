//! Branch → trunk with one fore limb across (issue 24 item 1):
//! `branch_trunk --variant to-trunk` at 115–122°, 0.2 m. The second fore
//! limb's trunk grip, placed around the transfer's side, lay farther than a
//! transfer step (0.42 m at 118°; a transfer step reaches 0.405 m), and the
//! back-offs locked the same stance again (`transfer_failed`). A transfer
//! locked that way turns its side about the trunk's axis toward the limb
//! left behind, by the least multiple of 5° (at most 30° in all) at which
//! the stance still holds and that limb has a step onto the trunk
//! (`Sloth::turned_transfer_side`).
//!
//! Fractional angles (never on the half-degree grid) from a low-discrepancy
//! sequence over the band; every 0.1° of it passed 43 of 71 times on main
//! 6112305 and 70 of 71 with the rule (120.7° fails). The count that passes
//! must not fall.

use slothsim::sim::TrunkVariant;

mod common;

/// The band (degrees) and the trunk's radius (m).
const BAND: (f64, f64, f32) = (115.0, 122.0, 0.2);

/// Draws per run.
const DRAWS: usize = 12;

/// Passing draws, measured with the side turned (main 6112305: 7).
const FLOOR: usize = 11;

#[test]
fn locked_transfer_turns_its_side_toward_the_fore_limb_left_behind() {
    let cases = common::band_draws(&[BAND], DRAWS);
    let fails = common::transfer_case_failures(TrunkVariant::ToTrunk, &cases);
    let passing = DRAWS - fails.len();
    println!("{passing} of {DRAWS} pass; failing:\n{}", fails.join("\n"));
    assert!(
        passing >= FLOOR,
        "{passing} of {DRAWS} draws pass (floor {FLOOR}):\n{}",
        fails.join("\n")
    );
}
