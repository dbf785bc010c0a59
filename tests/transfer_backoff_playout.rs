//! A back-off's length chosen by playouts (issue 24): a goal-mode sloth
//! that gives up and backs off first plays itself out alone (whole frames,
//! the crowd pass's stages) with each back-off length in turn — one gait
//! cycle, then two, three, four, half a cycle — and takes the first with
//! which it arrives within 60 s (`Sloth::plan_backoff`, `replan.rs`). With
//! the same one-cycle back-off every time, these transfers went back into
//! the same circle at every give-up (20 s apart) to the time limit.
//!
//! Each case below missed its goal on main 6d01660: 0.15 m 148.6503° and
//! 0.2 m 132.375° of an earlier session's fresh draws, 0.2 m 115.012054°
//! (a draw of `transfers_pass_at_random_angles`), and 0.15 m 148.626°,
//! 0.2 m 131.078°, 0.15 m 138.412°, 0.2 m 158.447° of 1,500 fresh to-trunk
//! draws; to-branch 0.15 m 153.354° of 1,500 fresh to-branch draws.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_back_off_that_would_circle_is_played_out_longer_branch_to_trunk() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (148.6503, 0.15),
            (132.375, 0.2),
            (115.012_054, 0.2),
            (148.626, 0.15),
            (131.078, 0.2),
            (138.412, 0.15),
            (158.447, 0.2),
        ],
    );
}

#[test]
fn a_back_off_that_would_circle_is_played_out_longer_trunk_to_branch() {
    common::assert_transfers_pass(TrunkVariant::ToBranch, &[(153.354, 0.15)]);
}
