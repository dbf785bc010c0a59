//! Head first onto a trunk (branch → trunk, issue 24 item 1): the hind limbs
//! follow the fore limbs onto it. On main (cafae76) at 0.2 m, 133.5° (and
//! 132.8°, 133.1°, 155.2°, 158.7° off the half-degree grid), the right hind
//! limb took the trunk about 0.28 m up past its partner, left at the
//! branch's root (a transfer step, exempt from the girdle lead): every
//! trunk grip of the left hind limb then failed the step length, the
//! same-side spacing to LF or RH's reach band, and the sloth stopped
//! `no_grip` with LH alone on the branch. Now such a step, landing more
//! than the girdle lead ahead of a partner that keeps a step but none onto
//! the new support, is not taken (`Sloth::partner_follows`, candidate.rs).
//! Each case of the first test fails on main.
//!
//! The second test holds the cases that a plain cap on that lead (branch
//! bt16: 99.416°, 98.604°) or a lookahead without the exemption for a
//! partner left with no step at all (98.604°, 100.466°, 104.9°, 115.09°,
//! 150.3°) lost; each passes on main. After such a step the partner's step
//! comes once the fore limbs have moved.
//!
//! The third test holds a partner left with no step that the fore limbs'
//! steps never freed: at 0.2 m, 131.6° (main 8a3f399; 131.5° and 131.7°
//! pass), RH took the trunk 0.30 m up past LH (at the branch's root) at
//! 33.7 s; every trunk grip of LH then left RH past its reach band at the
//! end of the step (0.395–0.434 m against 0.388 m) or passed LF (leg
//! order), every retreat of RH down the trunk took LH past its band 30 %
//! into the swing, and the back-offs moved LF only: `no_grip` at 84 s.
//! Now a partner with no step after the hind step must have one after some
//! step of a fore limb (a lookahead two steps deep,
//! `Sloth::has_step_then`), one onto the new support.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_following_hind_limb_leaves_its_partner_a_step_onto_the_trunk() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (133.5, 0.2),
            (132.8, 0.2),
            (133.1, 0.2),
            (155.2, 0.2),
            (158.7, 0.2),
        ],
    );
}

#[test]
fn a_partner_left_with_no_step_waits_for_the_fore_limbs() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[
            (99.416, 0.2),
            (98.604, 0.2),
            (100.466, 0.2),
            (104.9, 0.2),
            (115.09, 0.2),
            (150.3, 0.2),
        ],
    );
}

#[test]
fn a_partner_left_with_no_step_gets_one_after_a_fore_step() {
    common::assert_transfers_pass(TrunkVariant::ToTrunk, &[(131.6, 0.2)]);
}
