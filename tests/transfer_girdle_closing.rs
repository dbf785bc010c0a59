//! A hind limb left behind its girdle partner closes up part way (issue
//! 24): in goal mode, outside transfers, once the search is failing, a hind
//! limb behind its partner by more than a minimum step may land short of
//! level with it (`Sloth::keeps_leg_order`, `candidate.rs`), for a sloth
//! whose back-offs would not arrive without it (`Sloth::close_up`, chosen
//! by the back-off's playouts, `replan.rs`). Before, only a limb more than
//! a whole step behind could (and hind limbs in two approach cases):
//! trunk → branch at 0.08 m, on the branch RH stood 0.13–0.21 m behind LH,
//! under that threshold; it could land neither level (out of reach or too
//! near RF) nor short of level, every other limb's step was barred, and the
//! sloth stood there to the time limit.
//!
//! Each case below failed on main 6fdc0df: 143.978° and 153.227° of an
//! earlier session's fresh draws, 153.160° and 153.197° of 1,500 fresh
//! draws (seed 2212), and the narrow bands around them found by a 0.01°
//! sweep (15 of 122 angles over 143.80–144.20° and 152.80–153.60° failed).
//! The cases the rule broke when it applied to every goal-mode sloth
//! (to-branch 0.15 m 153.354°) or after any re-plan (0.08 m 146.4577°)
//! are checked too: they must still pass.

use slothsim::sim::TrunkVariant;

mod common;

#[test]
fn a_limb_left_behind_its_partner_closes_up_part_way() {
    common::assert_transfers_pass(
        TrunkVariant::ToBranch,
        &[
            (143.978, 0.08),
            (153.227, 0.08),
            (153.160, 0.08),
            (153.197, 0.08),
            (152.99, 0.08),
            (153.29, 0.08),
            (143.87, 0.08),
            (144.13, 0.08),
            (153.354, 0.15),
            (146.4577, 0.08),
        ],
    );
}
