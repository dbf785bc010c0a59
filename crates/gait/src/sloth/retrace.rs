//! Retrace (wander mode): a wanderer in a dead stance steps back the way it
//! came. Every stance it reached came through steps that passed all their
//! checks, so the way back exists: it remembers its last [`TRAIL_KEPT`]
//! steps (the limb and the grip it left, [`Trail`]) and, where a stalled
//! search gives up with no step for any limb even with the other sloths
//! ignored, puts the limbs back on those grips, the most recent step first,
//! each step checked as any step is (reach within the joint limits at the
//! arc's points and the end, the body out of the supports, the other
//! sloths' clearance). Taken in reverse order they restore the stances the
//! sloth stood in before, so the leg order holds by construction (only the
//! same side's spacing, which formula 6 needs, is checked again). After
//! [`RETRACE_MIN`] steps (or fewer, the trail's length) it heads away from
//! where it came from and searches as before.

use serde::{Deserialize, Serialize};
use slothsim_rig::Limb;
use slothsim_scene::SupportId;

use glam::Vec3;

use super::{Grip, LimbPhase, LocoView, Sloth, Status, StuckCause};

/// Steps a wanderer remembers.
pub const TRAIL_KEPT: usize = 8;

/// Steps a retrace takes before the search runs again.
pub const RETRACE_MIN: u8 = 4;

/// One remembered step: the limb and the grip it left, and the travel
/// direction (`Sloth::dir`) it was taken in.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrailStep {
    /// Limb index.
    pub limb: u8,
    /// The grip the limb left.
    pub left: Grip,
    /// `Sloth::dir` when the step was taken.
    pub dir: f32,
}

impl Default for TrailStep {
    fn default() -> Self {
        TrailStep {
            limb: 0,
            left: Grip {
                point: Vec3::ZERO,
                normal: Vec3::Y,
                support: SupportId::default(),
                u: 0.0,
                sdir: 1.0,
            },
            dir: 1.0,
        }
    }
}

/// A wanderer's last steps outside transfers and turns, each between supports
/// of one kind (a ring: the oldest is dropped), and the retrace under way.
/// Checkpointed (format 28).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trail {
    /// The steps, a ring: the most recent at `next - 1`.
    pub steps: [TrailStep; TRAIL_KEPT],
    /// Steps held (at most [`TRAIL_KEPT`]).
    pub len: u8,
    /// The ring's next slot.
    pub next: u8,
    /// Retrace steps still to take before the search runs again (0: none
    /// under way).
    pub retrace_left: u8,
}

impl Trail {
    pub(super) fn clear(&mut self) {
        self.len = 0;
        self.retrace_left = 0;
    }

    fn push(&mut self, s: TrailStep) {
        self.steps[self.next as usize] = s;
        self.next = ((self.next as usize + 1) % TRAIL_KEPT) as u8;
        self.len = (self.len + 1).min(TRAIL_KEPT as u8);
    }

    /// The most recent step.
    pub fn top(&self) -> Option<TrailStep> {
        (self.len > 0).then(|| self.steps[(self.next as usize + TRAIL_KEPT - 1) % TRAIL_KEPT])
    }

    fn pop(&mut self) {
        if self.len > 0 {
            self.next = ((self.next as usize + TRAIL_KEPT - 1) % TRAIL_KEPT) as u8;
            self.len -= 1;
        }
    }
}

impl Sloth {
    /// A step was taken (limb `li` left grip `left` for the grip it now
    /// swings to): a wanderer remembers it, outside transfers and turns and
    /// between supports of one kind; any other step ends the trail (the way
    /// back would cross a transfer or a turn).
    pub(super) fn note_trail(&mut self, env: &LocoView<'_>, li: usize, left: Grip) {
        if !self.wander {
            return;
        }
        let scene = env.scene();
        let to = self.limbs[li].grip.support;
        if self.transfer.is_some()
            || self.turn.is_some()
            || scene.support(left.support).kind != scene.support(to).kind
        {
            self.trail.clear();
            return;
        }
        self.trail.retrace_left = 0;
        self.trail.push(TrailStep {
            limb: li as u8,
            left,
            dir: self.dir,
        });
    }

    /// Whether a stalled wanderer whose search gave up retraces: nothing in
    /// the air, no transfer or turn, steps remembered, and no limb with a
    /// step even with the other sloths ignored (`StuckCause::Tip`,
    /// `StuckCause::NoGrip`).
    pub(super) fn may_retrace(&self) -> bool {
        self.wander
            && self.transfer.is_none()
            && self.turn.is_none()
            && self.trail.len > 0
            && matches!(self.stuck_cause, Some(StuckCause::Tip | StuckCause::NoGrip))
            && !self.any_swinging()
    }

    /// Starts a retrace (see the module): the limbs wait for the trail's
    /// steps, the most recent first.
    pub(super) fn start_retrace(&mut self) {
        self.trail.retrace_left = RETRACE_MIN.min(self.trail.len);
        self.failed_searches = 0;
        for l in &mut self.limbs {
            l.fallback = None;
            l.due = false;
            l.probe = false;
            if l.phase == LimbPhase::Searching {
                l.phase = LimbPhase::Planted;
            }
        }
    }

    /// The limb whose turn the gait clock gives while a retrace is under
    /// way: the most recent step's limb, else `None` (that limb waits for
    /// the trail's limb's turn).
    pub(super) fn retrace_limb(&self) -> Option<usize> {
        self.trail.top().map(|s| s.limb as usize)
    }

    /// The grip limb `li` steps back to: the trail's most recent step's,
    /// its travel sign flipped with the travel since.
    fn retrace_grip(&self) -> Option<(usize, Grip, f32)> {
        let s = self.trail.top()?;
        let mut g = s.left;
        if s.dir != self.dir {
            g.sdir = -g.sdir;
        }
        Some((s.limb as usize, g, s.dir))
    }

    /// Whether limb `li` may step back to `g`: every check a step makes
    /// (see the module; no transfer is under way, so the head-up margins
    /// have nothing to check).
    pub(super) fn retrace_passes(&self, env: &LocoView<'_>, li: usize, g: Grip) -> bool {
        let limb = Limb::ALL[li];
        let cur = self.limbs[li].grip.point;
        let fwd = self.body_rot * Vec3::Z;
        let same_side = self.limbs[limb.same_side().index()].grip.point;
        (g.point - same_side).dot(fwd).abs() >= env.cfg.same_side_spacing_m
            && !self.crowd_blocked(env, cur, g.point)
            && self.step_reachable(env, li, g.point, g.normal, g.support)
    }

    /// Limb `li`'s turn during a retrace: it steps back to the trail's most
    /// recent grip if that passes its checks; else the retrace ends and the
    /// sloth stops and retries later, as it did before retraces.
    pub(super) fn retrace_step(&mut self, env: &LocoView<'_>, li: usize) {
        self.limbs[li].due = false;
        let Some((lj, g, dir_in)) = self.retrace_grip() else {
            self.trail.retrace_left = 0;
            return;
        };
        debug_assert_eq!(lj, li, "a retrace step of another limb");
        if !self.retrace_passes(env, li, g) {
            self.trail.clear();
            self.status = Status::NoGrip;
            self.resume_at = Some(self.time + env.cfg.wander_retry_s);
            return;
        }
        let l = &mut self.limbs[li];
        l.swing_to(g);
        l.fallback = None;
        // One step popped, one fewer to take: `retrace_left` never exceeds
        // the record's length (a retrace starts at most at it).
        self.trail.pop();
        self.trail.retrace_left -= 1;
        self.note_step(env);
        if self.trail.retrace_left == 0 && self.dir == dir_in {
            // Back where it came from: head away from the dead end (not a
            // turn back: the stall counts are the steps').
            self.dir = -self.dir;
            for l in &mut self.limbs {
                l.grip.sdir = -l.grip.sdir;
            }
            self.align_to_travel(env);
        }
    }
}

#[cfg(test)]
mod tests {
    use slothsim_rig::Rig;
    use slothsim_scene::{Preset, PresetKind, TraceScene};

    use super::super::test_util::{tick, xorshift};
    use super::super::{NearRing, SpawnHint, TraceBatch};
    use super::*;
    use crate::{LocoEnv, LocomotionConfig, Profile};

    /// The four grips, as bits (stances compared exactly).
    fn key(s: &Sloth) -> [[u32; 3]; 4] {
        s.limb_map(|l| l.grip.point.to_array().map(f32::to_bits))
    }

    /// The `turn` preset at `angle`, the free profile's environment there,
    /// and one with the longest step cut to 31 mm (where most straddles of
    /// a walk have no step).
    fn turn_envs(angle: f32) -> (Preset, LocoEnv, LocoEnv) {
        let preset = Preset::new(PresetKind::Turn, Some(angle)).unwrap();
        let cfg = LocomotionConfig::profile(Profile::Free);
        let short = LocomotionConfig {
            max_step_m: 0.031,
            ..cfg.clone()
        };
        let env = LocoEnv::new(cfg, &Rig::sloth(), TraceScene::new(preset.scene.clone())).unwrap();
        let dead_env =
            LocoEnv::new(short, &Rig::sloth(), TraceScene::new(preset.scene.clone())).unwrap();
        (preset, env, dead_env)
    }

    /// Wanderers walked across the junction of the `turn` preset (angles
    /// drawn at random), taken where they straddle its two branches (all
    /// limbs planted, no transfer or turn) with steps remembered. Each such
    /// stance is made dead: with the longest step cut to 31 mm no limb has
    /// a step (a forward one, onto a neighbour, a retreat or a gathering
    /// step), stalled or not. Stalled there, the search's give-up starts a
    /// retrace (before the rule it turned back or stopped), and the sloth
    /// then steps back by the trail's limbs, the most recent first: each
    /// step passes [`Sloth::retrace_passes`] in the stance it starts from,
    /// lands the sloth exactly in a stance it stood in before (the grips as
    /// bits, in reverse order of the walk), the body never enters a support,
    /// and at the end the sloth heads away from where it came from.
    #[test]
    fn a_dead_stance_is_left_by_retracing_the_steps_into_it() {
        let mut rnd = xorshift(41);
        let (mut cases, mut steps_back) = (0, 0);
        for _ in 0..12 {
            let angle = 60.0 + 120.0 * rnd();
            let (preset, env, dead_env) = turn_envs(angle);
            let (view, dead_view) = (env.view(), dead_env.view());
            let mut sloth = Sloth::spawn(&view, &SpawnHint::from(preset.start), None);
            sloth.wander = true;
            let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
            // Every stance the walk stood in, in order.
            let mut walked = vec![key(&sloth)];
            let mut straddles = Vec::new();
            for frame in 0..2400 {
                tick(&mut sloth, &mut near, &view, &mut batch);
                if walked.last() != Some(&key(&sloth)) {
                    walked.push(key(&sloth));
                }
                let a = sloth.limbs[0].grip.support;
                if frame % 20 == 0
                    && sloth.limbs.iter().any(|l| l.grip.support != a)
                    && sloth.limbs.iter().all(|l| l.phase == LimbPhase::Planted)
                    && sloth.transfer.is_none()
                    && sloth.turn.is_none()
                    && sloth.trail.len as usize >= RETRACE_MIN as usize
                {
                    straddles.push((sloth, walked.len()));
                }
            }
            for &(plain, walked_len) in &straddles {
                let mut stalled = plain;
                stalled.stall_from = Some((stalled.body_pos, 2));
                stalled.stalled_turns = 2;
                let no_step = |s: &Sloth| (0..4).all(|li| !s.has_step(&dead_view, li));
                if !no_step(&plain) || !no_step(&stalled) {
                    continue;
                }
                assert!(stalled.may_retrace() || stalled.stuck_cause.is_none());
                stalled.give_up(&dead_view);
                assert!(
                    stalled.trail.retrace_left > 0,
                    "angle {angle}: a dead stance retraces ({:?})",
                    stalled.stuck_cause
                );
                let dir_in = stalled.trail.top().unwrap().dir;
                // The stances before this one, most recent first.
                let mut back = walked[..walked_len - 1].iter().rev();
                let mut sl = stalled;
                let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
                let mut last_dir_in = dir_in;
                for _ in 0..1200 {
                    if sl.trail.retrace_left == 0 {
                        break;
                    }
                    batch.run(&dead_view.query);
                    sl.step_search(&dead_view, &mut batch, Some(&mut near));
                    sl.body_average(&dead_view, 1.0 / 60.0);
                    sl.solve_limbs(&dead_view);
                    let before = sl;
                    sl.transitions(&dead_view, 1.0 / 60.0, &mut batch);
                    assert!(sl.body_pos.is_finite(), "angle {angle}");
                    assert!(
                        !sl.body_penetrates(&dead_view, sl.body_pos, sl.body_rot),
                        "angle {angle}: the body in a support"
                    );
                    if sl.trail.len < before.trail.len {
                        let top = before.trail.top().unwrap();
                        let li = top.limb as usize;
                        last_dir_in = top.dir;
                        assert_eq!(sl.limbs[li].phase, LimbPhase::Swinging);
                        assert!(before.retrace_passes(&dead_view, li, sl.limbs[li].grip));
                        // The landing stance: one the walk stood in, going back.
                        let k = key(&sl);
                        assert!(
                            back.any(|w| *w == k),
                            "angle {angle}: a retrace step lands in an earlier stance"
                        );
                        steps_back += 1;
                    }
                }
                assert_eq!(sl.trail.retrace_left, 0, "angle {angle}: the retrace ends");
                assert_eq!(sl.status, Status::Moving, "angle {angle}");
                assert_eq!(sl.dir, -last_dir_in, "angle {angle}: heading away");
                cases += 1;
            }
        }
        assert!(
            cases >= 5 && steps_back >= cases * RETRACE_MIN as usize,
            "{cases} dead straddles, {steps_back} steps back"
        );
    }

    /// The straddles of the walks above (the `turn` preset at random
    /// angles, steps remembered), made nearly dead: with the longest step
    /// cut to 31 mm some limb still has a step, but every such step leads
    /// into a stance no limb can leave either way (the stuck search refuses
    /// it: [`Sloth::keeps_a_way`]). Stalled in a crowd (the crowd grid
    /// present, no other sloth near), the give-up counts no usable step, so
    /// the cause is not `crowded` / `boxed_in`, and the sloth retraces.
    /// Before, the unusable step counted the sloth `crowded`, and a sloth
    /// so counted never retraced: seed 1's 1706 stood 227 s astride two
    /// branches of the 5,000-sloth crowd.
    #[test]
    fn a_straddler_whose_only_steps_lead_into_dead_stances_retraces() {
        let mut rnd = xorshift(47);
        let (mut cases, mut seen) = (0, 0);
        for _ in 0..12 {
            let angle = 60.0 + 120.0 * rnd();
            let (preset, env, dead_env) = turn_envs(angle);
            let mut grid = crate::CrowdGrid::new(0.3);
            grid.rebuild(std::iter::empty());
            let (view, dead_view) = (env.view(), dead_env.view_with(Some(&grid)));
            let mut sloth = Sloth::spawn(&view, &SpawnHint::from(preset.start), None);
            sloth.wander = true;
            let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
            for frame in 0..2400 {
                tick(&mut sloth, &mut near, &view, &mut batch);
                let a = sloth.limbs[0].grip.support;
                if frame % 20 != 0
                    || sloth.limbs.iter().all(|l| l.grip.support == a)
                    || sloth.limbs.iter().any(|l| l.phase != LimbPhase::Planted)
                    || sloth.transfer.is_some()
                    || sloth.turn.is_some()
                    || sloth.trail.len == 0
                {
                    continue;
                }
                let mut stalled = sloth;
                stalled.stall_from = Some((stalled.body_pos, 2));
                stalled.stalled_turns = 2;
                seen += 1;
                let stepping: Vec<usize> = (0..4)
                    .filter(|&li| stalled.has_step(&dead_view, li))
                    .collect();
                if stepping.is_empty()
                    || stepping.iter().any(|&li| {
                        stalled.has_step_then(&dead_view, li, |after| after.has_a_way(&dead_view))
                    })
                {
                    continue;
                }
                stalled.give_up(&dead_view);
                assert!(
                    !matches!(
                        stalled.stuck_cause,
                        Some(StuckCause::Crowded | StuckCause::BoxedIn)
                    ),
                    "angle {angle}: {:?}",
                    stalled.stuck_cause
                );
                assert!(
                    stalled.trail.retrace_left > 0,
                    "angle {angle}: retraces ({:?})",
                    stalled.stuck_cause
                );
                cases += 1;
            }
        }
        eprintln!("{cases} of {seen} straddles with only dead-end steps");
        assert!(
            cases >= 5,
            "{cases} of {seen} straddles with only dead-end steps"
        );
    }
}
