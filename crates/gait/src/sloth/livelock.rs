//! Livelock by nearby stances, goal mode (issue 24): a step may not take a
//! stance the sloth has already taken twice since it last came nearer its
//! goal; the limb takes its next candidate instead, or none.
//!
//! The exact watches (`Sloth::note_transfer_stance`,
//! `Sloth::note_stuck_stance`) key a stance on a 0.1 mm grid, and the
//! stuck-stance watch starts again at every step made with the search not
//! failing. After a transfer onto a branch, trunk_branch at 111° and 135°
//! (0.2 m) circled for the rest of the run: RF and LH stepping out and
//! back over grips a few millimetres apart (111°), or LH alone round four
//! grips while the other three failed (135°), one limb's step always
//! found, so neither watch kept a record and no re-plan came. Giving up
//! there (a back-off) would come late and be undone by the walk back, so
//! the plan changes at the step itself: the greedy farthest-first search
//! goes on to a grip it has not circled over.
//!
//! Refused outside transfers only: inside one, the transfer's own watch gives up
//! on the third exact visit, and its back-off unlocks transfers that
//! refusing the visit would leave circling (branch_trunk at 98°, 125° and
//! 126°, 0.2 m, were lost that way).
//!
//! Circles that drift by centimetres escape that 1 cm test (branch ↔
//! trunk, issue 24: one or two limbs re-gripping near where they were
//! while the others wait 20–65 s, each re-grip resetting the failed-search
//! count). Their closing move is tabu (`Sloth::circle_tabu`, read from the
//! same record, inside transfers too): a re-grip near the limb's recent
//! grips while another limb has long waited is passed by.
//!
//! The record ([`NearRing`], 840 bytes) is not a part of [`Sloth`]: a
//! wanderer never reads it, and `Sloth` is copied whole for every stance a
//! step check looks ahead to. The caller keeps it beside the sloth (the sim:
//! a component of goal-mode sloths only) and hands it to
//! [`Sloth::step_search`].

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::{Grip, Sloth};

/// Stances the record keeps (a circle of two limbs in turn is about a
/// dozen steps: see `transfer::STANCES_KEPT`).
pub const NEAR_KEPT: usize = 16;

/// Two stances are the same when every grip lies within this of the
/// other's (metres; step candidates lie a back-off, 1 cm, apart).
pub const NEAR_TOLERANCE_M: f32 = 0.01;

/// The record starts again once the grips' centroid comes this much
/// nearer the goal than it has been since it started (metres; the shortest
/// step, `min_step_m`, is 3 cm, and a circling stance's centroid wanders
/// by about 2 cm).
pub const NEAR_PROGRESS_M: f32 = 0.05;

/// A stance taken this many times is not taken again.
const NEAR_TAKEN_MAX: u8 = 2;

/// One recorded stance: the limb whose step took it (its index) and the
/// four grips.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NearStance {
    pub limb: u8,
    pub grips: [[f32; 3]; 4],
    /// Times it was taken (1 when recorded).
    pub taken: u8,
}

/// The stances taken since the sloth last came nearer its goal (see the
/// module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NearRing {
    pub stances: [NearStance; NEAR_KEPT],
    /// Stances recorded (the next slot is this modulo [`NEAR_KEPT`]; 0:
    /// the record is empty).
    pub count: u32,
    /// The grips' centroid's least distance to the goal since the record
    /// started (metres).
    pub best: f32,
}

impl NearRing {
    /// The recorded stance of limb `li`'s step within [`NEAR_TOLERANCE_M`]
    /// of `grips`, if any.
    fn find(&self, li: usize, grips: &[Vec3; 4]) -> Option<usize> {
        let kept = (self.count as usize).min(NEAR_KEPT);
        (0..kept).find(|&k| {
            let s = &self.stances[k];
            s.limb == li as u8
                && s.grips
                    .iter()
                    .zip(grips)
                    .all(|(a, b)| Vec3::from(*a).distance(*b) <= NEAR_TOLERANCE_M)
        })
    }
}

impl Sloth {
    /// Whether the record is kept: goal mode, no back-off or turn under way
    /// (each steps away on purpose). Steps during a transfer are recorded
    /// too (branch_trunk at 144°, 0.08 m, begins a transfer and drops it
    /// again and again while it circles on the branch).
    fn near_recorded(&self) -> bool {
        self.goal.is_some() && !self.wander && self.backoff.is_none() && self.turn.is_none()
    }

    /// Whether this sloth keeps a [`NearRing`] (goal mode, not wandering):
    /// a sloth for which this is true must be handed its record by every
    /// [`Sloth::step_search`].
    pub fn keeps_near_record(&self) -> bool {
        self.goal.is_some() && !self.wander
    }

    /// After limb `li` took a step: records the stance in `r` (see the
    /// module docs); clears the record where it does not apply, or where
    /// the grips came [`NEAR_PROGRESS_M`] nearer the goal.
    pub(super) fn note_near_stance(&self, li: usize, r: &mut NearRing) {
        let Some((_, goal)) = self.goal else { return };
        if !self.near_recorded() {
            r.count = 0;
            return;
        }
        let grips = self.limb_map(|l| l.grip.point);
        let d = (grips.iter().copied().sum::<Vec3>() * 0.25).distance(goal);
        if r.count == 0 || d < r.best - NEAR_PROGRESS_M {
            r.count = 0;
            r.best = d;
        }
        match r.find(li, &grips) {
            Some(k) => r.stances[k].taken = r.stances[k].taken.saturating_add(1),
            None => {
                r.stances[r.count as usize % NEAR_KEPT] = NearStance {
                    limb: li as u8,
                    grips: grips.map(|g| g.to_array()),
                    taken: 1,
                };
                r.count = r.count.wrapping_add(1);
            }
        }
    }

    /// Whether limb `li`'s step to `point` (with the hind pair's partner's
    /// step `pair`) would take a stance taken [`NEAR_TAKEN_MAX`] times
    /// since the sloth last came nearer its goal (record `r`): the search
    /// passes it by.
    pub(super) fn near_refused(
        &self,
        li: usize,
        point: Vec3,
        pair: Option<(usize, Grip)>,
        r: &NearRing,
    ) -> bool {
        // Goal mode first: a wanderer's search does not touch the record's lines.
        if !self.near_recorded() || self.transfer.is_some() || r.count == 0 {
            return false;
        }
        let mut grips = self.limb_map(|l| l.grip.point);
        grips[li] = point;
        if let Some((pi, g)) = pair {
            grips[pi] = g.point;
        }
        r.find(li, &grips)
            .is_some_and(|k| r.stances[k].taken >= NEAR_TAKEN_MAX)
    }
}

/// Circle tabu: a limb's re-grip within this of a grip it held lately is
/// refused while the circle lasts (metres; the circles re-gripped within a
/// few centimetres; 4 cm and 6 cm each lost cases main passes).
pub const TABU_RADIUS_M: f32 = 0.05;

/// Circle tabu: the stepping limb's own recorded steps looked back over (3 and
/// 4 lost branch_trunk 0.2 m 98°, docs/scenarios.md).
const TABU_OWN_STEPS: usize = 2;

/// Circle tabu: applies once another limb has not stepped for this many
/// recorded stances (in a walk each limb steps every fourth; at 6 or 8 the
/// tabu lost cases of the 0.1° grid that main passes: docs/scenarios.md).
const TABU_WAITED: usize = 10;

impl Sloth {
    /// Circle tabu (issue 24, branch ↔ trunk): whether limb `li`'s re-grip
    /// at `point` closes a circle: it lies within [`TABU_RADIUS_M`] of the
    /// limb's grip now or in one of its last [`TABU_OWN_STEPS`] steps in
    /// record `r` (the goal no nearer: the record starts again where the
    /// grips come [`NEAR_PROGRESS_M`] nearer it), while another limb has
    /// not stepped for [`TABU_WAITED`] recorded stances. The search passes
    /// it by and takes a candidate farther off, or none: then the limb's
    /// search fails and the waiting limbs search, as after any failed
    /// search. Inside transfers too (outside them only, to-branch 0.2 m
    /// 108.44947° and to-trunk 0.2 m 146.747° still failed).
    /// Not a give-up: the record, the failed-search count and the plan are
    /// left as they are.
    pub(super) fn circle_tabu(&self, li: usize, point: Vec3, r: &NearRing) -> bool {
        if !self.near_recorded() || r.count == 0 {
            return false;
        }
        let kept = (r.count as usize).min(NEAR_KEPT);
        // The recorded stances, newest first.
        let at = |j: usize| &r.stances[(r.count as usize - 1 - j) % NEAR_KEPT];
        // Stances since another limb last stepped (all kept where it has not).
        let waited = (0..4)
            .filter(|&k| k != li)
            .map(|k| (0..kept).find(|&j| at(j).limb == k as u8).unwrap_or(kept))
            .max()
            .unwrap_or(0);
        if waited < TABU_WAITED {
            return false;
        }
        let near = |g: Vec3| g.distance(point) <= TABU_RADIUS_M;
        near(self.limbs[li].grip.point)
            || (0..kept)
                .map(at)
                .filter(|s| s.limb == li as u8)
                .take(TABU_OWN_STEPS)
                .any(|s| near(Vec3::from(s.grips[li])))
    }
}

#[cfg(test)]
mod tests {
    use slothsim_scene::PresetKind;

    use super::super::test_util::preset_sloth;
    use super::*;

    /// The branch_trunk preset's sloth with its grips moved by `shift`.
    fn shifted(s: &Sloth, shift: [Vec3; 4]) -> Sloth {
        let mut t = *s;
        for (l, d) in t.limbs.iter_mut().zip(shift) {
            l.grip.point += d;
        }
        t
    }

    #[test]
    fn a_stance_taken_twice_is_refused_within_the_tolerance() {
        let (_env, s) = preset_sloth(PresetKind::BranchTrunk);
        let (_, goal) = s.goal.unwrap();
        let mut s = s;
        let mut r = NearRing::default();
        // Three stances of a circle: LH (index 2) out, back, out again.
        let out = Vec3::new(0.03, 0.0, 0.0);
        let lh = |d: Vec3| [Vec3::ZERO, Vec3::ZERO, d, Vec3::ZERO];
        let base = s;
        for d in [out, Vec3::ZERO, out] {
            s.limbs = shifted(&base, lh(d)).limbs;
            s.note_near_stance(2, &mut r);
        }
        let there = base.limbs[2].grip.point + out;
        // Taken twice: refused, also 5 mm off; 2 cm off it is another stance.
        assert!(s.near_refused(2, there, None, &r));
        assert!(s.near_refused(2, there + Vec3::new(0.0, 0.005, 0.0), None, &r));
        assert!(!s.near_refused(2, there + Vec3::new(0.0, 0.02, 0.0), None, &r));
        // Taken once (LH back home) is not refused; another limb's step to
        // the same stance is another stance.
        assert!(!s.near_refused(2, base.limbs[2].grip.point, None, &r));
        // In wander mode or without a goal: never.
        let mut w = s;
        w.wander = true;
        assert!(!w.near_refused(2, there, None, &r));
        let mut g = s;
        g.goal = None;
        assert!(!g.near_refused(2, there, None, &r));
        // Coming nearer the goal by more than NEAR_PROGRESS_M starts the
        // record again.
        let centroid = s.limbs.iter().map(|l| l.grip.point).sum::<Vec3>() * 0.25;
        let toward = (goal - centroid).normalize() * (NEAR_PROGRESS_M + 0.02);
        let p = shifted(&s, [toward; 4]);
        let mut rp = r;
        p.note_near_stance(1, &mut rp);
        let there2 = there + toward;
        assert_eq!(rp.count, 1);
        assert!(!p.near_refused(2, there2, None, &rp));
    }

    #[test]
    fn a_circles_closing_move_is_tabu_while_another_limb_waits() {
        let (_env, s) = preset_sloth(PresetKind::BranchTrunk);
        let rh = 3;
        let home = s.limbs[rh].grip.point;
        let x = Vec3::new(0.02, 0.0, 0.0);
        // RH alone steps `n` times, out and back by 2 cm (the others wait).
        let record = |n: usize| {
            let mut r = NearRing::default();
            for k in 0..n {
                let mut grips = s.limb_map(|l| l.grip.point.to_array());
                grips[rh] = (home + x * (k % 2) as f32).to_array();
                r.stances[k % NEAR_KEPT] = NearStance {
                    limb: rh as u8,
                    grips,
                    taken: 1,
                };
            }
            r.count = n as u32;
            r
        };
        let r = record(TABU_WAITED);
        // Within 5 cm of a grip it held: tabu; 8 cm off: not.
        assert!(s.circle_tabu(rh, home + Vec3::new(0.0, 0.04, 0.0), &r));
        assert!(s.circle_tabu(rh, home + x * 3.0, &r));
        assert!(!s.circle_tabu(rh, home + Vec3::new(0.0, 0.08, 0.0), &r));
        // The others have not waited long enough: not tabu.
        let short = record(TABU_WAITED - 1);
        assert!(!s.circle_tabu(rh, home + x * 3.0, &short));
        // Every limb stepping in turn (a walk, however slow): not tabu.
        let mut walk = record(NEAR_KEPT);
        for (k, st) in walk.stances.iter_mut().enumerate() {
            st.limb = (k % 4) as u8;
        }
        assert!(!s.circle_tabu(rh, home + x * 3.0, &walk));
        // No record (a back-off cleared it), wander mode, no goal: never.
        assert!(!s.circle_tabu(rh, home, &NearRing::default()));
        let mut w = s;
        w.wander = true;
        assert!(!w.circle_tabu(rh, home, &r));
        let mut g = s;
        g.goal = None;
        assert!(!g.circle_tabu(rh, home, &r));
    }
}
