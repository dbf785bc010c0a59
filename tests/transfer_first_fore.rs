//! Head first onto a trunk (issue 24 item 1), the first fore limb takes
//! the trunk only where its partner can follow: after its step there the
//! partner has a step onto the trunk, or the footfall order's next steps
//! give it one (`route.rs` `first_fore_strands_partner`). Before, the
//! first fore limb took the trunk wherever its branch search was exhausted
//! (at 0.2 m 159.5°, from 0.4 m out along a branch 20.5° off the trunk),
//! and the stance locked with its partner's trunk grips out of reach (the
//! lone-fore lock).
//!
//! The first test's cases missed their goal on main 2180e5a (every judge
//! measure in tolerance). The second test's cases pass on main and were
//! lost by a side turn made at the lone-fore lock's first search (branch
//! `lone30`): they must pass. The third test's case missed its goal on
//! main d71370f: the trunk step was passed by right after a step (no search
//! failed since), and no later stance had one (branch `lone34`).

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn the_first_fore_limb_takes_the_trunk_where_its_partner_can_follow() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (159.5, 0.2),
            (159.6, 0.2),
            (137.316, 0.2),
            (145.5, 0.08),
            (144.3, 0.08),
            (144.827, 0.08),
            (157.147, 0.15),
        ],
    );
}

#[test]
fn locks_main_unlocks_by_steps_still_pass() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[(150.5, 0.08), (159.5, 0.15), (156.5, 0.2), (137.5, 0.2)],
    );
}

#[test]
fn the_trunk_step_is_passed_by_only_once_a_search_has_failed() {
    common::assert_transfers_pass(TrunkVariant::ToTrunk, &[(129.8, 0.2)]);
}
