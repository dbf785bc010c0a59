//! Livelocks after a transfer, or while one is begun and dropped (issue 24
//! item 1): one limb re-gripping round grips a few millimetres apart while
//! the others find nothing, so neither exact stance watch fires and the
//! sloth circles until its time runs out. A goal-mode step may not take a
//! stance it has taken twice since it last came nearer its goal
//! (`livelock.rs`); the search goes on to a grip it has not circled over.
//!
//! Each case below missed its goal on main 8cc735f (every judge measure in
//! tolerance): trunk → branch at 0.2 m (110.6°, 110.7°, 111°: RF and LH
//! stepping out and back; 135°: LH round four grips, RH at the branch's
//! root), branch → trunk at 0.08 m (143.7°, 144°, 144.4°: circling on the
//! branch before the trunk). All pass now.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_circling_stance_is_not_taken_a_third_time_trunk_to_branch() {
    common::assert_transfers_pass(
        TrunkVariant::ToBranch,
        &[(110.6, 0.2), (110.7, 0.2), (111.0, 0.2), (135.0, 0.2)],
    );
}

#[test]
fn a_circling_stance_is_not_taken_a_third_time_branch_to_trunk() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[(143.7, 0.08), (144.0, 0.08), (144.4, 0.08)],
    );
}
