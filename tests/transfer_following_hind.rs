//! Head first onto a trunk (branch → trunk, issue 24 item 1): the hind limbs
//! follow the fore limbs onto it. On main (5106f5e) at 0.2 m, 133.5° (and
//! 132.8°, 133.1°, 138.535° off the half-degree grid), the right hind limb
//! took the trunk 0.28 m up past its partner, left at the branch's root (a
//! transfer step, exempt from the girdle lead); every trunk grip of the
//! left hind limb then failed the same-side spacing to LF or left RH 2–8 mm
//! past its reach band, and the sloth stopped `no_grip` (every judge
//! measure in tolerance). Now a hind limb following head first with its
//! partner still on the support it leaves lands no more than the girdle
//! lead ahead of it (`keeps_leg_order`, candidate.rs). Each case fails on
//! main.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_following_hind_limb_keeps_its_partner_within_a_girdle_lead() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[(133.5, 0.2), (132.8, 0.2), (133.1, 0.2), (138.535, 0.2)],
    );
}
