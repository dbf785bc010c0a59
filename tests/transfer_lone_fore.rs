//! A transfer onto a trunk locked half way (issue 24 item 1): one fore limb
//! on the trunk, its partner still on the branch without a step onto the
//! trunk, and the lone fore limb's steps back onto the branch all too far.
//! The back-off moved only the partner, back and forth on the branch, and
//! the sloth stopped `no_grip` after six re-plans. In that stance the lone
//! fore limb is judged by steps during a back-off, as a wanderer's is
//! (`route.rs` `own_search`), so it steps back down the trunk.
//!
//! Each case below missed its goal on main cadd5a1 (every judge measure in
//! tolerance): branch → trunk at 0.08 m (145.5°, 146°), 0.15 m (156.5°,
//! 157.5°) and 0.2 m (159.7°). All pass now.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_lone_fore_limb_across_steps_back_along_the_trunk() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (145.5, 0.08),
            (146.0, 0.08),
            (156.5, 0.15),
            (157.5, 0.15),
            (159.7, 0.2),
        ],
    );
}
