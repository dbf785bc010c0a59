//! Tail first down a branch to a trunk (branch → trunk below ~90°, issue
//! 24 item 1): the hind limbs lead onto the trunk. On main (358f19c) at
//! 0.2 m, 74.5° and 75.5° (and 75.4°, 75.8° off the half-degree grid), the
//! right hind limb, 0.13 m behind its partner at the branch's end, stepped
//! onto the trunk from there; the hind girdle stayed split (0.20 m) down
//! the trunk, the fore girdle trailed split the other way, and no limb
//! could land level with its partner: the sloth stopped `no_grip` 1.15 m
//! from the goal (every judge measure in tolerance). Now a hind limb behind
//! its partner there may close up part way on the branch while the search
//! is failing (`keeps_leg_order`, candidate.rs), so the girdle takes the
//! trunk level. Each case fails on main.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_tail_first_hind_girdle_takes_the_trunk_level() {
    common::assert_transfers_pass(
        TrunkVariant::ToTrunk,
        &[(74.5, 0.2), (75.4, 0.2), (75.5, 0.2), (75.8, 0.2)],
    );
}
