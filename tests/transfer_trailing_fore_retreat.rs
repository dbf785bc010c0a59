//! Head first onto a trunk and then down it tail first (branch → trunk,
//! issue 24 item 1). On main (cafae76) at 0.2 m, 100.1° (and 100.3, 127.7,
//! 130.3, 158.4°, and 0.15 m 148.6° with the following-hind lookahead of
//! `tests/transfer_following_hind.rs`), all four limbs took the trunk in
//! time, then a trailing fore limb whose forward search failed retreated up
//! the trunk while a hind limb had a step down; the limbs circled near the
//! junction to the time limit. Now, in goal mode, tail first down a trunk,
//! a trailing fore limb retreats only where no other limb has a forward step
//! (`Sloth::start_retreat`, route.rs). Each case fails without the rule.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_trailing_fore_limb_does_not_retreat_while_another_limb_can_step() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (100.1, 0.2),
            (100.3, 0.2),
            (127.7, 0.2),
            (130.3, 0.2),
            (158.4, 0.2),
            (148.6, 0.15),
        ],
    );
}
