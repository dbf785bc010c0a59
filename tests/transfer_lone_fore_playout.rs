//! The lone-fore lock (issue 24 item 1): one fore limb on the trunk, its
//! partner on the branch without a step onto it. Where the stance unlocks,
//! it does so after a sequence of steps (a hind limb closing up, then the
//! partner), which a one-step lookahead does not see. A limb on the branch
//! searching in that stance now takes the farthest step from which the
//! footfall order's next steps, played out on a copy of the sloth (three
//! gait cycles), leave the partner a step onto the trunk
//! (`route.rs` `lone_fore_unlocking_u`).
//!
//! The first test's cases missed their goal on main 6996f3e (every judge
//! measure in tolerance): branch → trunk at 0.08 m (144.9°), 0.15 m
//! (139.5°, 139.8°, 138.137°) and 0.2 m (125.2°). The second test's cases
//! pass on main and were lost by the rule's one-step form (the step that
//! leaves the partner any step toward the trunk): they must pass.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_branch_limb_takes_the_step_that_unlocks_the_lone_fore_stance() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (144.9, 0.08),
            (139.5, 0.15),
            (139.8, 0.15),
            (138.137, 0.15),
            (125.2, 0.2),
        ],
    );
}

#[test]
fn the_playout_leaves_stances_main_unlocks() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (98.0, 0.2),
            (115.0, 0.2),
            (120.0, 0.2),
            (151.5, 0.15),
            (153.0, 0.15),
        ],
    );
}
