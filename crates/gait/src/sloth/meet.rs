//! Two wanderers meeting head on along one branch (issue 24, "never
//! frozen"). Neither can pass the other (each keeps its grips out of the
//! other's clearance), so before this rule both searches failed for two gait
//! cycles (`crowded`), both turned back and walked tail first, which their
//! limbs mostly cannot reach, both gave up again (`boxed_in`), and only then
//! did each turn its body around — over 11 s without a step, past the 10 s
//! that counts a sloth as stuck (traced in the 5,000 × 300 s crowd, seed 10;
//! docs/locomotion.md, "Blocked ahead" and "Head on").
//!
//! Now the first of the two whose search fails turns its body around at
//! once (the turn around of `turn.rs`, by steps) and walks back the way it
//! came; the other sees it turning (the crowd grid's tag) and waits: its
//! give-ups neither turn it back nor around while that turn goes on, its
//! way on being the one the turning sloth clears. Both see the same grid
//! (the previous tick's), so one yields and the other waits, unless both
//! fail in the same tick (then both turn). The other sloth is read off the
//! crowd grid: its body centre, hips and head give its heading, its grips
//! whether it holds this branch, its tag ([`crate::crowd_tag`]) whether it
//! travels head first and whether it is turning around. Goal mode is
//! untouched.

use glam::Vec3;
use slothsim_rig::Limb;

use crate::crowd::{TAG_HEAD_FIRST, TAG_TURNING};
use crate::path::project;

use super::{LocoView, Sloth};

/// The other sloth faces this one: their headings at least this far apart
/// (cosine; 135°).
const FACING_COS: f32 = -0.7;

/// The other sloth's grips hold this branch: each within this of its surface
/// (metres).
const ON_BRANCH_M: f32 = 0.02;

/// What a wanderer meets ahead on its branch ([`Sloth::head_on`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum HeadOn {
    /// A sloth facing it, travelling head first too: it turns around now.
    Facing,
    /// A sloth turning around: it waits.
    Turning,
}

impl Sloth {
    /// Wander mode, head first on a branch it alone holds (all four limbs,
    /// none in the air, no turn or transfer: [`Sloth::may_turn_around`]):
    /// another sloth ahead within the clearance of its head or a leading
    /// grip, holding the same branch with all four limbs (as the crowd grid
    /// has it, with its tag: [`crate::crowd_tag`]), that faces it and
    /// travels head first (`Facing`; it decides over a turning one), or
    /// that turns around (`Turning`). `None` otherwise (goal mode, no crowd,
    /// tail first, a sloth behind, alongside, heading the same way or
    /// walking away tail first).
    pub(super) fn head_on(&self, env: &LocoView<'_>) -> Option<HeadOn> {
        let grid = env.crowd?;
        if !self.wander || self.dir <= 0.0 || !self.may_turn_around(env, false) {
            return None;
        }
        let s = env.scene().support(self.limbs[0].grip.support);
        let fwd = self.body_rot * Vec3::Z;
        let on_branch = |p: Vec3| {
            let a = project(s, p);
            (a.point.distance(p) - a.radius).abs() <= ON_BRANCH_M
        };
        let meeting = |o: u32| -> Option<HeadOn> {
            let (pts, tag) = grid.points_of(o)?;
            if pts.len() != crate::crowd::POINTS_PER_SLOTH {
                return None;
            }
            let [body, hips, head] = [pts[0], pts[1], pts[2]];
            if (body - self.body_pos).dot(fwd) <= 0.0 || !pts[3..].iter().all(|&g| on_branch(g)) {
                return None;
            }
            if tag & TAG_TURNING != 0 {
                return Some(HeadOn::Turning);
            }
            let heading = (head - hips).try_normalize()?;
            (tag & TAG_HEAD_FIRST != 0 && heading.dot(fwd) < FACING_COS).then_some(HeadOn::Facing)
        };
        let head = self.body_pos + self.body_rot * env.rig.head_ms;
        let probes = std::iter::once(head).chain(
            Limb::ALL
                .iter()
                .filter(|&&l| self.leads(l))
                .map(|&l| self.limbs[l.index()].grip.point),
        );
        let mut found = None;
        for p in probes {
            let Some(o) = grid.find_owner_near(self.id, p, |o| meeting(o).is_some()) else {
                continue;
            };
            found = meeting(o);
            if found == Some(HeadOn::Facing) {
                break;
            }
        }
        found
    }

    /// A wanderer meeting another head on turns its body around now (see
    /// the module docs), counted as a turn back of its travel
    /// ([`Sloth::turns`], [`Sloth::stall_from`]).
    pub(super) fn yield_head_on(&mut self, env: &LocoView<'_>) {
        self.align_to_travel(env);
        self.start_turn(false);
        self.turns = self.turns.wrapping_add(1);
        let (_, n) = self.stall_from.get_or_insert((self.body_pos, 0));
        *n = n.saturating_add(1);
    }
}

#[cfg(test)]
mod tests {
    use glam::Quat;
    use slothsim_scene::{Preset, PresetKind, Support};

    use super::super::SpawnHint;
    use super::super::test_util::preset_sloth;
    use super::*;
    use crate::CrowdGrid;

    /// Another sloth `gap` metres ahead of `s`'s head on its branch `st`:
    /// `s`'s points turned half round about the branch's up (square to its
    /// axis) through the axis point below a point `gap / 2` ahead of its
    /// head (head to head, the grips on the same branch), or, with `facing`
    /// false, moved ahead by a body's length and `gap` (heading the same
    /// way, a queue).
    fn other(env: &LocoView<'_>, st: &Support, s: &Sloth, gap: f32, facing: bool) -> [Vec3; 7] {
        let fwd = s.body_rot * Vec3::Z;
        let pts = crate::crowd_points(env.rig, s);
        if !facing {
            let hips = pts[1];
            let head = pts[2];
            return pts.map(|p| p + fwd * ((head - hips).dot(fwd) + gap));
        }
        let a = project(st, pts[2] + fwd * (gap * 0.5));
        let up = s.body_rot * Vec3::Y;
        let up = (up - a.tangent * up.dot(a.tangent)).normalize();
        let half = Quat::from_axis_angle(up, std::f32::consts::PI);
        pts.map(|p| a.point + half * (p - a.point))
    }

    /// A wanderer with another head to head 10 cm ahead on its branch,
    /// travelling head first too: it turns
    /// around at its first failed search (its travel kept, counted as a
    /// turn back). With that sloth turning around instead, its failed
    /// searches do not turn it, and its give-ups neither turn it back nor
    /// around (it waits, counted as a turn back without a step); once that
    /// sloth stops turning and walks away tail first, the next give-up
    /// turns it back as before. A sloth ahead heading the same way (a
    /// queue), one facing it but walking away tail first, goal mode, and a
    /// wanderer travelling tail first meet nothing: one failed search is
    /// counted, no more. Without the rule the first failed search turns
    /// nobody around (checked: "turns around").
    #[test]
    fn a_wanderer_meeting_another_head_on_turns_around_and_waits_for_a_turning_one() {
        let (env, base) = preset_sloth(PresetKind::BranchEnd);
        let view0 = env.view();
        // The preset's start heading the other way, toward the branch's
        // root: room for another sloth ahead.
        let preset = Preset::by_name(PresetKind::BranchEnd.name(), None).unwrap();
        let mut hint = SpawnHint::from(preset.start);
        hint.forward = -hint.forward;
        let back = Sloth::spawn(&view0, &hint, None);
        let sid = base.limbs[0].grip.support;
        assert!(back.limbs.iter().all(|l| l.grip.support == sid));
        // Cases: 0 head on, 1 a queue, 2 goal mode, 3 tail first, 4 the
        // other walks away tail first, 5 the other turns around.
        for case in 0..6 {
            let kind = case;
            let mut sloth = back;
            sloth.id = 7;
            sloth.goal = None;
            sloth.wander = kind != 2;
            if kind == 3 {
                sloth.dir = -sloth.dir;
                for l in &mut sloth.limbs {
                    l.grip.sdir = -l.grip.sdir;
                }
            }
            let st = view0.scene().support(sid);
            let pts = other(&view0, st, &sloth, 0.1, kind != 1);
            for g in &pts[3..] {
                let a = project(st, *g);
                assert!(
                    (a.point.distance(*g) - a.radius).abs() < 0.005,
                    "case {case}"
                );
            }
            let tag = match kind {
                4 => 0,
                5 => TAG_HEAD_FIRST | TAG_TURNING,
                _ => TAG_HEAD_FIRST,
            };
            let mut grid = CrowdGrid::new(0.3);
            grid.rebuild_groups([(1000, pts)]);
            grid.set_tags(|_| tag);
            let view = env.view_with(Some(&grid));
            let (dir, turns) = (sloth.dir, sloth.turns);
            let want = match kind {
                0 => Some(HeadOn::Facing),
                5 => Some(HeadOn::Turning),
                _ => None,
            };
            assert_eq!(sloth.head_on(&view), want, "case {case}");
            sloth.search_failed(&view);
            if kind == 0 {
                assert!(sloth.turn.is_some(), "case {case}: turns around");
                assert_eq!(sloth.dir, dir, "case {case}");
                assert_eq!(sloth.turns, turns + 1, "case {case}");
                assert_eq!(sloth.stall_from.map(|(_, n)| n), Some(1), "case {case}");
                assert_eq!(sloth.failed_searches, 0, "case {case}");
                continue;
            }
            assert!(sloth.turn.is_none(), "case {case}");
            assert_eq!(sloth.failed_searches, 1, "case {case}");
            if kind == 5 {
                for _ in 0..3 {
                    sloth.give_up(&view);
                    assert!(sloth.turn.is_none(), "case {case}");
                    assert_eq!(sloth.dir, dir, "case {case}: turned back");
                    assert_eq!(sloth.stalled_turns, 1, "case {case}");
                    assert_eq!(sloth.failed_searches, 0, "case {case}");
                }
                // The other is done turning and walks away tail first.
                grid.set_tags(|_| 0);
                sloth.give_up(&env.view_with(Some(&grid)));
                assert_eq!(sloth.dir, -dir, "case {case}: turns back");
            }
        }
    }
}
