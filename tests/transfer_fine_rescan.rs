//! A goal-mode step search that finds nothing at the coarse stride while no
//! other limb has a step (a lock) re-scans its range at every back-off point
//! before it counts as failed (issue 24; `Sloth::queue_candidates`,
//! search.rs). Locked on a 0.15–0.2 m trunk after a branch → trunk
//! transfer, every limb's coarse search failed although a fore limb had a
//! valid step between two coarse points; the sloth gave up, backed off into
//! new locks and was still walking at the time limit.
//!
//! The first five cases fail on main d45ee42: the three failures of a 0.01°
//! sweep over 157.50–159.50° at 0.08, 0.15 and 0.2 m (603 angles) and two
//! more of the same sweep widened to 150–160° (3,003 angles).
//! The second test's case (0.2 m 131.112°, which main passes) failed with a
//! re-scan after *every* failing coarse search: a fore limb re-scanned a 5 cm
//! step on the branch where its partner had the trunk, and the sloth circled
//! there until the time limit.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_failing_coarse_search_rescans_at_every_back_off_point() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (158.14, 0.2),
            (159.05, 0.2),
            (159.27, 0.15),
            (159.82, 0.08),
            (151.22, 0.2),
        ],
    );
}

#[test]
fn a_search_that_fails_while_another_limb_can_step_does_not_rescan() {
    common::assert_transfers_pass(TrunkVariant::ToTrunk, &[(131.112, 0.2)]);
}
