//! The lookahead judges a transfer-ending step by the sloth after the
//! transfer (issue 24): in goal mode, a step that lands the last limb on a
//! transfer's target ends the transfer at its landing (`finish_transfer`),
//! and the lookahead (`Sloth::leaves_a_step`, search.rs) now checks the
//! other limbs' steps from that sloth. Judged with the transfer still under
//! way, the last fore limb's step onto a 0.2 m trunk, tail first, passed and
//! left a stance in which every limb's step put another out of its reach
//! band: the sloth stood 48 s and stopped `no_grip` after six re-plans.
//!
//! Each case failed on main 9f764a0 (three of 1,500 fresh branch → trunk
//! draws, seed 2213, not used in tuning; a 0.01° sweep around them passed,
//! so they were isolated points).

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_transfer_ending_step_is_judged_by_the_sloth_after_the_transfer() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[(63.937, 0.2), (64.097, 0.2), (109.655, 0.2)],
    );
}

/// A transfer-ending step is judged two steps deep: some other limb has a
/// step after which a limb still has one. Judged one step deep, the left
/// hind limb's landing on the trunk left only the right fore limb a short
/// step, after which no limb had one: main 994fc4a stood there until it gave
/// up, its back-offs ended in such stances twice more, and it arrived
/// 98.657 s, 5 ms past its time limit.
#[test]
fn a_transfer_ending_step_is_judged_two_steps_deep() {
    common::assert_transfers_pass(TrunkVariant::ToTrunk, &[(158.443, 0.2)]);
}
