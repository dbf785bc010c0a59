//! Drifting circles in branch ↔ trunk transfers (issue 24): one or two
//! limbs re-grip within a few centimetres of where they were (or go round
//! one circle across the junction) while the others find no step for
//! 20–65 s; each re-grip resets the failed-search count, so no give-up
//! comes, and the circle drifts too far for the exact and 1 cm stance
//! watches. The circle's closing move is tabu (`Sloth::circle_tabu`,
//! `livelock.rs`): a re-grip within 5 cm of a grip the limb held in its
//! last two steps, the goal no nearer, another limb waiting ten stances.
//!
//! Each case below missed its goal on main 44ca0c2 (to-trunk 0.08 m 126.3°,
//! 0.15 m 158.8°, 0.2 m 154.3° of the 0.1° grid; 0.2 m 158.738°, 146.747°,
//! 0.15 m 141.989° of the random draws; to-branch 0.2 m 108.44947°, a
//! draw of `transfers_pass_at_random_angles`). All pass now.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_circles_closing_move_is_tabu_branch_to_trunk() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (126.3, 0.08),
            (158.8, 0.15),
            (154.3, 0.2),
            (158.738, 0.2),
            (146.747, 0.2),
            (141.989, 0.15),
        ],
    );
}

#[test]
fn a_circles_closing_move_is_tabu_trunk_to_branch() {
    common::assert_transfers_pass(TrunkVariant::ToBranch, &[(108.449_47, 0.2)]);
}
