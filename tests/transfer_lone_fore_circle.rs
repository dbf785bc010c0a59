//! The lone-fore lock (issue 24 item 1) going round a circle: one fore limb
//! on the trunk, its partner on the branch without a step onto it, the
//! branch limbs stepping back and forth over the same stances. A turn of
//! the transfer's side toward the partner gives it a trunk step, but the
//! re-plan that would turn it comes at the circle watch's give-up, at a
//! step's landing with the next limb in the air, and the turn is refused
//! then. At a search in such a circling lock the side now turns
//! (`route.rs` `turn_side_in_lone_lock`).
//!
//! The first test's cases missed their goal on main 599e980 (every judge
//! measure in tolerance): branch → trunk at 0.2 m, 120.718–125.742°. The
//! second test's cases pass on main and were lost by the turn made at the
//! lock's first search (no circle yet): they must pass.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_circling_lone_fore_lock_turns_the_transfer_side() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (124.5, 0.2),
            (124.3, 0.2),
            (125.6, 0.2),
            (125.742, 0.2),
            (120.718, 0.2),
        ],
    );
}

#[test]
fn a_lock_that_does_not_circle_is_left_to_the_steps() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (137.5, 0.2),
            (155.5, 0.2),
            (156.0, 0.2),
            (151.0, 0.15),
            (153.0, 0.15),
        ],
    );
}
