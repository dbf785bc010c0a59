//! StepSearch (thesis §3.3 `FindNextStep`, fig. 12; SPEC "Step search"):
//! each searching limb takes the first traced candidate that still passes
//! its checks, else queues the next candidates (farthest first, 1 cm
//! back-off); the lookahead keeps a step from leaving no limb a step after
//! it; committed steps let the steady profile's swings overlap.

use glam::{Quat, Vec3};
use slothsim_rig::Limb;
use slothsim_scene::{BoxOverlap, LineTrace, SupportId, SupportKind, TraceHit};

use crate::path::project;

use super::body::{BodySide, body_offset};
use super::candidate::CandidateAt;
use super::route::search_ahead;
use super::{
    Candidate, Fallback, Grip, LimbPhase, LocoView, MAX_TRACES, NearRing, Search, Sloth, Status,
    StuckCause, TraceBatch,
};

/// Reach-checked step-search candidates per limb per frame.
const MAX_REACH_CHECKS_PER_FRAME: u32 = 8;

/// Coarse search stride, in back-offs (see [`Sloth::queue_candidates`]).
const COARSE_STRIDE: u32 = 3;

/// Candidates traced per searching limb per frame. One: the search stops at
/// the first candidate that passes the reach checks (farthest first), and its
/// trace almost always confirms it; when it does not, the search goes on
/// from the next candidate in the next frame.
const CANDIDATES_PER_LIMB: usize = 1;

/// A traced grip this close to the candidate's predicted one (and with its
/// normal within [`RECHECK_NORMAL_COS`]) is the grip the reach checks passed.
const RECHECK_DISTANCE: f32 = 1e-4;

/// See [`RECHECK_DISTANCE`].
const RECHECK_NORMAL_COS: f32 = 0.9999;

/// The room a grip needs off its support's surface beyond the claw's length
/// (the hand's thickness), clear of every other support, when another
/// support hides it from the step search's trace ([`trace_in_claw_room`]).
const CLAW_ROOM_MARGIN: f32 = 0.01;

/// Wander mode: stop after this many turn-backs in a row without a step.
const MAX_STALLED_TURNS: u8 = 2;

/// Back-off of the lookahead's coarse candidate scan.
const LOOKAHEAD_STRIDE: f32 = 0.02;

/// Candidates of one lookahead range tried nearest first (a longer range is
/// scanned farthest first; the answer is the same either way).
const LOOKAHEAD_MAX_POINTS: usize = 128;

/// A limb lifting off on the gait clock during another's swing is checked
/// as holding its grip this long past its clock time (its own search may
/// take a few frames) and as in the air from then on: the deadline of its
/// committed step ([`Sloth::next_lift`]).
const LIFT_MARGIN_S: f32 = 0.05;

/// Stride of the search for a committed step ([`Sloth::fallback_step`]).
const FALLBACK_STRIDE: f32 = 0.05;

/// Reach checks the search for a committed step may make.
const FALLBACK_MAX_CHECKS: u32 = 6;

impl Sloth {
    /// StepSearch: evaluate traced candidates (in order: farthest first); the
    /// first valid one becomes the limb's new grip and its swing starts. Limbs
    /// still searching queue their next candidates into `batch`.
    ///
    /// `near`: the goal-mode record of stances taken (`livelock.rs`), kept
    /// beside the sloth; `None` for a sloth that keeps none (a wanderer:
    /// [`Sloth::keeps_near_record`] is false).
    pub fn step_search(
        &mut self,
        env: &LocoView<'_>,
        batch: &mut TraceBatch,
        near: Option<&mut NearRing>,
    ) {
        if self.backoff.is_some_and(|b| !b.planned) {
            self.plan_backoff(env, batch, near.as_deref());
        }
        self.step_search_planned(env, batch, near);
    }

    /// [`Self::step_search`] once a fresh back-off's length is chosen.
    pub(super) fn step_search_planned(
        &mut self,
        env: &LocoView<'_>,
        batch: &mut TraceBatch,
        mut near: Option<&mut NearRing>,
    ) {
        debug_assert!(
            near.is_some() || !self.keeps_near_record(),
            "a goal-mode sloth's step search without its stance record"
        );
        // Nothing queued and no limb searching: the batch is empty and stays
        // so (what follows would read and clear an empty batch).
        if !self.traces_queued && self.limbs.iter().all(|l| l.phase != LimbPhase::Searching) {
            debug_assert_eq!(batch.len, 0, "a queued batch with traces_queued unset");
            return;
        }
        let mut chosen = [false; 4];
        for i in 0..batch.len {
            let m = batch.meta[i];
            let li = m.limb as usize;
            if chosen[li] || self.limbs[li].phase != LimbPhase::Searching {
                continue;
            }
            let Ok(Some(traced)) = batch.results[i] else {
                continue;
            };
            // Goal mode: another support within the trace's standoff (a
            // parallel branch, a fork's other limb) hides the grip: traced
            // again from the claw's room off the surface, where there is room.
            // Wanderers keep refusing such grips (with them a 5,000-sloth
            // crowd's body entered a support by 76 mm: docs/scenarios.md).
            let hit = if traced.support == m.support {
                traced
            } else if !self.wander
                && let Some(hit) = trace_in_claw_room(env, &m)
            {
                hit
            } else {
                continue;
            };
            if hit.support != m.support || hit.normal.dot(m.out) < 0.3 {
                continue;
            }
            // The candidate passed the reach checks at its predicted grip; the
            // hit is re-checked only if the surface is elsewhere.
            let as_checked = hit.point.distance(m.point) <= RECHECK_DISTANCE
                && hit.normal.dot(m.out) >= RECHECK_NORMAL_COS;
            // The hind pair's partner may have started a swing of its own
            // since this candidate was queued.
            let pair = m
                .pair
                .map(|(pi, p, n)| (pi as usize, p, n))
                .filter(|&(pi, ..)| {
                    self.limbs[pi].phase != LimbPhase::Swinging
                        && self.hind_pair(li, m.support) == Some(pi)
                });
            if m.pair.is_some() && pair.is_none() {
                continue;
            }
            let mut back_scale = m.back_scale;
            // A step checked with the next limb lifting off during its swing
            // commits that limb's step: it must still be the next to lift.
            let mut lift = m.lift.map(|(lj, to)| (lj as usize, to));
            let lift_at = lift.and_then(|(lj, _)| {
                self.next_lift(env, li)
                    .filter(|&(k, _)| k == lj)
                    .map(|(_, start)| start)
            });
            if !as_checked {
                let reachable = match pair {
                    Some((pi, p, n)) => {
                        match self.pair_back_scale(
                            env,
                            &[(li, hit.point, hit.normal), (pi, p, n)],
                            m.support,
                        ) {
                            Some(k) => {
                                back_scale = k;
                                true
                            }
                            None => false,
                        }
                    }
                    None => {
                        // Landing past the lifting fore limb's grip, the
                        // step holds only with that limb's committed step.
                        let needs_lift =
                            lift.is_some_and(|(lj, _)| self.passes_fore(env, li, lj, hit.point));
                        if !needs_lift
                            && self.step_reachable(env, li, hit.point, hit.normal, m.support)
                        {
                            lift = None;
                            true
                        } else {
                            matches!((lift, lift_at), (Some((lj, to)), Some(start))
                                if self.lift_reachable(env, li, hit.point, hit.normal, lj, to, start))
                        }
                    }
                };
                if !reachable {
                    continue;
                }
            }
            if lift.is_some() && lift_at.is_none() {
                continue;
            }
            let grip = Grip {
                point: hit.point,
                normal: hit.normal,
                support: m.support,
                u: m.u,
                sdir: m.sdir,
            };
            let pair_grip = pair.map(|(pi, point, normal)| {
                (
                    pi,
                    Grip {
                        point,
                        normal,
                        ..grip
                    },
                )
            });
            // Goal mode, outside transfers: not a stance circled over
            // twice already; in transfers too: not a drifting circle's
            // closing move (see `livelock.rs`).
            if near.as_deref().is_some_and(|r| {
                self.near_refused(li, grip.point, pair_grip, r)
                    || self.circle_tabu(li, grip.point, r)
            }) {
                continue;
            }
            if !self.leaves_a_way_on(env, li, grip, pair_grip) {
                continue;
            }
            // A wanderer climbing a trunk keeps its way back down (with the
            // step it commits another limb to, if any).
            if !self.keeps_way_down(
                env,
                std::iter::once((li, grip)).chain(pair_grip).chain(lift),
            ) {
                continue;
            }
            // A search made only to know whether there is a step: there is,
            // and the limb waits for the release rule (`Sloth::transitions`).
            if self.limbs[li].probe {
                self.end_probe(li, true);
                continue;
            }
            let failing = self.failed_searches > 0;
            let left = self.limbs[li].grip;
            for (lj, g) in std::iter::once((li, grip)).chain(pair_grip) {
                chosen[lj] = true;
                let l = &mut self.limbs[lj];
                l.swing_to(g);
                l.probe = false;
                // Its own search found a step: a committed one is void.
                l.fallback = None;
                if lj != li {
                    // The partner's own turn is taken by this step.
                    l.due = false;
                }
            }
            if let (Some((lj, to)), Some(start)) = (lift, lift_at) {
                self.limbs[lj].fallback = Some(Fallback {
                    grip: to,
                    by_s: self.time + start,
                });
            }
            if pair.is_some() {
                self.hind_back_scale = back_scale;
            }
            self.note_step(env);
            self.note_trail(env, li, left);
            self.note_transfer_stance(env, li);
            self.note_stuck_stance(env, li, failing);
            if let Some(r) = near.as_deref_mut() {
                self.note_near_stance(li, r);
            }
        }
        batch.len = 0;
        self.traces_queued = false;
        for li in 0..4 {
            if self.limbs[li].phase == LimbPhase::Searching {
                self.queue_candidates(env, li, batch);
            }
        }
    }

    /// Queues up to [`CANDIDATES_PER_LIMB`] traces for limb `li`, continuing
    /// its search; moves on to neighbouring supports when the current one is
    /// exhausted; gives up (limb stays planted) when nothing is left.
    pub(super) fn queue_candidates(
        &mut self,
        env: &LocoView<'_>,
        li: usize,
        batch: &mut TraceBatch,
    ) {
        let scene = env.scene();
        let mut queued = 0;
        // Reach checks (CCD solves of hypothetical stances) this frame: a
        // search that needs more continues next frame, so no frame pays for
        // a whole exhaustive search (crowd p95).
        let mut checks = 0u32;
        loop {
            let sr = self.limbs[li].search;
            let s = scene.support(sr.support);
            let len = s.length();
            let mut u = sr.next_u;
            // Back off toward the current grip in coarse strides; the fine
            // (back-off) points above the first coarse candidate that passes
            // are then tried farthest first, so the farthest valid grip is
            // found at about a third of the checks.
            let fine = env.cfg.backoff_m;
            // Stuck (a search gave up since the last step): every back-off
            // point is tried, so a window of valid grips narrower than the
            // coarse stride is not stepped over.
            let stride = if self.stuck_cause.is_some() || self.fine_rescan & (1 << li) != 0 {
                1
            } else {
                COARSE_STRIDE
            };
            let coarse = fine * stride as f32;
            let in_range =
                |u: f32| (env.cfg.end_margin_m..=len - env.cfg.end_margin_m).contains(&u);
            while queued < CANDIDATES_PER_LIMB
                && checks < MAX_REACH_CHECKS_PER_FRAME
                && (u - sr.last_u) * sr.sdir >= -1e-6
            {
                let cand_u = u;
                u -= sr.sdir * coarse;
                if !in_range(cand_u) {
                    continue;
                }
                let mut check =
                    |u: f32| self.candidate(env, &CandidateAt::in_search(li, &sr, u), &mut checks);
                let Some(mut found) = check(cand_u) else {
                    continue;
                };
                for j in (1..stride).rev() {
                    let fu = cand_u + sr.sdir * fine * j as f32;
                    if (fu - sr.first_u) * sr.sdir > 1e-6 || !in_range(fu) {
                        continue;
                    }
                    if let Some(f) = check(fu) {
                        found = f;
                        break;
                    }
                }
                if batch.push(found.0, found.1) {
                    queued += 1;
                    self.traces_queued = true;
                } else {
                    u += sr.sdir * coarse;
                    break;
                }
            }
            self.limbs[li].search.next_u = u;
            if queued > 0 || batch.len == MAX_TRACES || checks >= MAX_REACH_CHECKS_PER_FRAME {
                return;
            }
            // The goal's branch is exhausted: climb on along the trunk (a
            // gathering limb: on along its own support, `gather_search`).
            if sr.goal_first {
                let neighbour = sr.neighbour;
                self.limbs[li].search = Search {
                    neighbour,
                    ..search_ahead(env, self.limbs[li].grip)
                };
                continue;
            }
            // This support is exhausted: try the next neighbour, then a retreat.
            // Nothing better than a committed step: take it.
            if self.limbs[li].fallback.is_some() {
                if self.limbs[li].probe {
                    self.end_probe(li, true);
                } else {
                    self.start_fallback_swing(env, li);
                }
                return;
            }
            if !self.next_neighbour(env, li) && !self.start_retreat(env, li) {
                // Goal mode, a lock: a search that found nothing at the
                // coarse stride while no other limb has a step re-scans its
                // own support (and on, as before) at every back-off point
                // before it counts as failed: the coarse stride passes over
                // a window of valid grips narrower than itself (branch_trunk
                // 0.2 m 158.14°: locked on the trunk after the transfer, the
                // left fore limb's one valid step lay between two coarse
                // points). Where another limb has a step the search fails as
                // before and that limb moves: re-scanned there, a fore limb
                // took a 5 cm step on the branch instead of leaving the
                // trunk to its partner (0.2 m 131.112°, which then circled).
                if self.fine_rescans(env, li) {
                    self.fine_rescan |= 1 << li;
                    self.limbs[li].search = self.own_search(env, li);
                    continue;
                }
                // Nothing anywhere: stay planted.
                if self.limbs[li].probe {
                    self.end_probe(li, false);
                }
                let l = &mut self.limbs[li];
                l.phase = LimbPhase::Planted;
                l.due = false;
                self.failed_searches = self.failed_searches.saturating_add(1);
                if self.failed_searches >= env.cfg.stop_after_failed_searches
                    && self.status == Status::Moving
                {
                    self.give_up(env);
                }
                return;
            }
        }
    }

    /// Whether limb `li`'s search, exhausted, re-scans at the fine stride
    /// (see [`Self::queue_candidates`]): goal mode, not a probe, searched at
    /// the coarse stride (not stuck), not re-scanned already, and a lock: no
    /// other limb is in the air or has a step the search would take (one
    /// after which yet another limb has a step, as the lookahead judges).
    fn fine_rescans(&self, env: &LocoView<'_>, li: usize) -> bool {
        !self.wander
            && !self.limbs[li].probe
            && self.stuck_cause.is_none()
            && self.fine_rescan & (1 << li) == 0
            && (0..4).all(|lj| {
                lj == li
                    || (self.limbs[lj].phase != LimbPhase::Swinging
                        && !self.has_step_then(env, lj, |after| {
                            (0..4).any(|lk| lk != lj && after.has_step(env, lk))
                        }))
            })
    }

    /// The search gave up (no limb found a step for two gait cycles, or a
    /// transfer made no progress for as long: `Sloth::watch_transfer`):
    /// the cause is noted, then the sloth tries what it has. Wander mode:
    /// turn back, unless turning back already failed to bring a step
    /// (tail-first walking is mostly out of the limbs' reach: see README);
    /// then stop here. Goal mode at a branch end with the goal behind, or a
    /// wanderer whose turn backs brought no step (it would stop): turn the
    /// body around. Goal mode otherwise: re-plan (`replan.rs`), else stop.
    /// A wanderer first turns its limbs' travel along their branches the way
    /// its body travels ([`Sloth::align_to_travel`]).
    pub(super) fn give_up(&mut self, env: &LocoView<'_>) {
        self.stuck_cause = Some(self.diagnose_stuck(env));
        if self.wander && self.turn.is_none() {
            self.align_to_travel(env);
        }
        let stalled = self.stalled();
        if (stalled && self.may_turn_around(env, false))
            || (self.goal_behind() && self.may_turn_around(env, true))
        {
            self.start_turn(false);
        } else if stalled && self.may_retrace() {
            // No step anywhere, even with the others ignored: back the way
            // it came (`retrace.rs`).
            self.start_retrace();
        } else if self.wander && self.stalled_turns < MAX_STALLED_TURNS {
            self.turn_back();
        } else if self.replan(env) {
            // Goal mode: backed off (or toward the goal again).
        } else {
            self.status = Status::NoGrip;
            if self.wander {
                self.resume_at = Some(self.time + env.cfg.wander_retry_s);
            }
        }
    }

    /// This sloth once the given limbs hold the given grips: the body at
    /// those grips (formulas 6, 7) and the chain roots it implies.
    pub(super) fn after_steps(
        &self,
        env: &LocoView<'_>,
        steps: impl IntoIterator<Item = (usize, Grip)>,
    ) -> Sloth {
        let mut next = *self;
        for (lj, g) in steps {
            next.limbs[lj].grip = g;
            next.limbs[lj].target = g.point;
        }
        let grips = next.limb_map(|l| l.grip.point);
        let offset = body_offset(env, next.trunk_weights(env));
        (next.body_pos, next.body_rot) = next.body_for_targets(env, &grips, offset, BodySide::Body);
        for lj in 0..4 {
            let root = env.rig.root_ws(lj, next.body_pos, next.body_rot);
            next.limbs[lj].root = root.position.into();
        }
        next
    }

    /// Lookahead: after limb `li` steps to `grip`, at least one other limb
    /// (tried in footfall order from the next) still has a step (cheap checks
    /// and reach, without traces). Keeps the greedy farthest-first search
    /// out of stances from which no limb can move.
    fn leaves_a_step(
        &self,
        env: &LocoView<'_>,
        li: usize,
        grip: Grip,
        pair: Option<(usize, Grip)>,
    ) -> bool {
        let mut next = self.after_steps(env, std::iter::once((li, grip)).chain(pair));
        // Goal mode, a step that lands the last limb on a transfer's target:
        // the transfer ends at the landing (`finish_transfer`: the travel
        // heads for the goal along the new support), so the lookahead judges
        // the sloth as it will be then. Judged with the transfer still under
        // way, the last fore limb's step onto a 0.2 m trunk, tail first
        // (branch_trunk 63.937°, 64.097°, 109.655°), passed, and left a
        // stance in which every limb's step put another out of its reach
        // band: stopped `no_grip` on the trunk.
        let ends_transfer = if !self.wander
            && let Some(tr) = next.transfer
            && next.limbs.iter().all(|l| l.grip.support == tr.to)
        {
            for l in &mut next.limbs {
                l.phase = LimbPhase::Planted;
            }
            next.finish_transfer(env);
            true
        } else {
            false
        };
        // The limbs other than `from` (and the pair's partner), in footfall
        // order from the next.
        let others = |from: usize, pair: Option<(usize, Grip)>| {
            footfall_order_from(env, from)
                .into_iter()
                .filter(move |&lj| lj != from && pair.is_none_or(|(pi, _)| lj != pi))
        };
        others(li, pair).any(|lj| {
            if ends_transfer {
                // Judged two steps deep (`has_step_then`): some other limb
                // has a step after which a limb other than that one still
                // has one, as the search will judge that step by this
                // lookahead. One step deep, branch_trunk 0.2 m 158.443°
                // passed the left hind limb's landing on the trunk with only
                // the right fore limb left a 4 cm step, after which no limb
                // had one: the sloth stood 5.6 s until it gave up, and its
                // back-offs ended in such stances twice more (arriving 5 ms
                // past the time limit; docs/scenarios.md).
                next.has_step_then(env, lj, |s| others(lj, None).any(|k| s.has_step(env, k)))
            } else {
                next.has_step(env, lj)
            }
        })
    }

    /// Whether the step of limb `li` to `grip` (and the hind pair's partner
    /// to its grip) leaves the sloth a way on: the lookahead
    /// ([`Self::leaves_a_step`]); stuck (a search gave up since the last
    /// step), any step that passes its checks changes the stance and may
    /// unlock it, so the lookahead is skipped, but a wanderer does not step
    /// into a stance no limb can leave either way ([`Self::keeps_a_way`]).
    pub(super) fn leaves_a_way_on(
        &self,
        env: &LocoView<'_>,
        li: usize,
        grip: Grip,
        pair: Option<(usize, Grip)>,
    ) -> bool {
        if self.stuck_cause.is_none() {
            self.leaves_a_step(env, li, grip, pair)
        } else {
            self.keeps_a_way(env, li, grip, pair)
        }
    }

    /// Wander mode, stuck (a search gave up since the last step, so the
    /// lookahead [`Self::leaves_a_step`] is skipped): after limb `li` steps
    /// to `grip` (and the hind pair's partner to its grip), some limb still
    /// has a step, with the other sloths ignored, travelling either way (as
    /// now or turned back), unless the stance has none already (then any step
    /// may change that). The other sloths move on and a turn back is what a
    /// give-up does next, so a stance with a step either way is one the
    /// wanderer can leave; one with none it never leaves. Traced in the
    /// 5,000 × 300 s crowd at seed 11 (docs/locomotion.md, "Dead stances"):
    /// half-done branch ↔ trunk transfers whose last step, taken without the
    /// lookahead after a give-up, left every limb without a step both ways,
    /// and the wanderer turned back and waited there for the rest of the run.
    /// Goal mode: true (it re-plans).
    pub(super) fn keeps_a_way(
        &self,
        env: &LocoView<'_>,
        li: usize,
        grip: Grip,
        pair: Option<(usize, Grip)>,
    ) -> bool {
        if !self.wander {
            return true;
        }
        !self.has_a_way(env)
            || self
                .after_steps(env, std::iter::once((li, grip)).chain(pair))
                .has_a_way(env)
    }

    /// Whether some limb has a step with the other sloths ignored, travelling
    /// as now or turned back (see [`Self::keeps_a_way`]).
    pub(super) fn has_a_way(&self, env: &LocoView<'_>) -> bool {
        let alone = LocoView {
            crowd: None,
            ..*env
        };
        let mut back = *self;
        back.dir = -back.dir;
        for l in &mut back.limbs {
            l.grip.sdir = -l.grip.sdir;
        }
        [self, &back]
            .iter()
            .any(|s| (0..4).any(|lj| s.has_step(&alone, lj)))
    }

    /// Wander mode, climbing a trunk head up with all four limbs on it (no
    /// turn under way; a transfer only set up by a search holds nothing
    /// elsewhere): a step along the trunk (with the step it commits another
    /// limb to) is taken only if, after it, a hind limb still has a step
    /// down the trunk (tail first, as after a turn back; the other sloths
    /// ignored: a way back the body can take once they move on), unless the
    /// stance has none already (then any step may change that). Traced in
    /// the 5,000 × 300 s crowds (seeds 3 and 5, 240 → 300 s): trunk sloths
    /// whose fore limbs were held by a sloth just above had closed their
    /// hind limbs up to the same side's spacing (0.15–0.2 m below the fore
    /// grips; a fore limb's short step down committed by a hind step did the
    /// same); turned back, every hind step down failed reach or the girdle
    /// lead, and the fore limbs may not step down level with the hind ones,
    /// so they turned back and forth for minutes (`no_grip`, `boxed_in`,
    /// `crowded`). Goal mode and any other step: true.
    pub(super) fn keeps_way_down(
        &self,
        env: &LocoView<'_>,
        steps: impl Iterator<Item = (usize, Grip)> + Clone,
    ) -> bool {
        let scene = env.scene();
        let sid = self.limbs[0].grip.support;
        if !self.wander
            || self.dir <= 0.0
            || self.turn.is_some()
            || scene.support(sid).kind != SupportKind::Trunk
            || self.limbs.iter().any(|l| l.grip.support != sid)
            || steps.clone().any(|(_, g)| g.support != sid)
        {
            return true;
        }
        let alone = LocoView {
            crowd: None,
            ..*env
        };
        let way_down = |s: &Sloth| {
            let mut back = *s;
            // All four on the trunk: a transfer only set up by a search (or
            // one ending there) holds nothing elsewhere.
            back.transfer = None;
            back.dir = -back.dir;
            for l in &mut back.limbs {
                l.grip.sdir = -l.grip.sdir;
                l.phase = LimbPhase::Planted;
            }
            [Limb::LH, Limb::RH]
                .iter()
                .any(|h| back.has_step(&alone, h.index()))
        };
        // A stance with no way down already: any step may change that.
        !way_down(self) || way_down(&self.after_steps(env, steps))
    }

    /// Whether limb `li` has any candidate passing the cheap checks and the
    /// reach check on its support or an admissible neighbour (no traces).
    pub(super) fn has_step(&self, env: &LocoView<'_>, li: usize) -> bool {
        self.any_search_range(env, li, |sr| self.range_has_step(env, li, sr))
    }

    /// Whether `scan` holds of limb `li`'s range on its own support or on
    /// one of the neighbours it may take (the leading limbs change support
    /// first; the others follow, `Sloth::may_follow`), own range first.
    fn any_search_range(
        &self,
        env: &LocoView<'_>,
        li: usize,
        scan: impl Fn(&Search) -> bool,
    ) -> bool {
        scan(&self.own_search(env, li))
            || env
                .adjacency
                .neighbours(self.limbs[li].grip.support)
                .iter()
                .any(|&sid| {
                    self.may_follow(env, li, sid)
                        && self
                            .neighbour_search(env, li, sid, 0)
                            .is_some_and(|sr| scan(&sr))
                })
    }

    /// Whether limb `li` has a step (a candidate [`Self::has_step`] would
    /// find: on its own support or an admissible neighbour, every
    /// [`LOOKAHEAD_STRIDE`], no traces) after which `then` holds of the
    /// sloth: a lookahead two steps deep. Each passing candidate places the
    /// body again, so it is kept to the rare stances that need it
    /// ([`Sloth::partner_follows`]; a goal-mode transfer-ending step,
    /// [`Self::leaves_a_step`]).
    pub(super) fn has_step_then(
        &self,
        env: &LocoView<'_>,
        li: usize,
        then: impl Fn(&Sloth) -> bool,
    ) -> bool {
        self.any_search_range(env, li, |sr| {
            let len = env.scene().support(sr.support).length();
            let mut u = sr.next_u;
            while (u - sr.last_u) * sr.sdir >= -1e-6 {
                if (env.cfg.end_margin_m..=len - env.cfg.end_margin_m).contains(&u)
                    && let Some((_, c)) =
                        self.candidate(env, &CandidateAt::probe(li, sr, u), &mut 0)
                {
                    let grip = Grip {
                        point: c.point,
                        normal: c.out,
                        support: c.support,
                        u: c.u,
                        sdir: c.sdir,
                    };
                    if then(&self.after_steps(env, [(li, grip)])) {
                        return true;
                    }
                }
                u -= sr.sdir * LOOKAHEAD_STRIDE;
            }
            false
        })
    }

    /// Whether limb `li` has a forward candidate in range `sr` passing the
    /// cheap checks and the reach check (no traces; every
    /// [`LOOKAHEAD_STRIDE`]).
    ///
    /// The answer does not depend on the order the candidates are tried in
    /// (each is a pure function of the sloth and its arc length), so they are
    /// tried nearest first: the far ones fail on the step length or at the
    /// edge of the reach (the reach checks of a lookahead fail 39 % of the
    /// time farthest first). The arc lengths are those of the farthest-first
    /// scan (stepped back from `next_u`), only visited in reverse.
    pub(super) fn range_has_step(&self, env: &LocoView<'_>, li: usize, sr: &Search) -> bool {
        let len = env.scene().support(sr.support).length();
        let in_range = |u: f32| (env.cfg.end_margin_m..=len - env.cfg.end_margin_m).contains(&u);
        let passes = |u: f32| {
            self.candidate(env, &CandidateAt::probe(li, sr, u), &mut 0)
                .is_some()
        };
        let mut us = [0.0f32; LOOKAHEAD_MAX_POINTS];
        let mut n = 0;
        let mut u = sr.next_u;
        while (u - sr.last_u) * sr.sdir >= -1e-6 {
            if in_range(u) {
                if n == us.len() {
                    // A range longer than the buffer: farthest first, as it comes.
                    return us.iter().any(|&v| passes(v)) || {
                        while (u - sr.last_u) * sr.sdir >= -1e-6 {
                            if in_range(u) && passes(u) {
                                return true;
                            }
                            u -= sr.sdir * LOOKAHEAD_STRIDE;
                        }
                        false
                    };
                }
                us[n] = u;
                n += 1;
            }
            u -= sr.sdir * LOOKAHEAD_STRIDE;
        }
        us[..n].iter().rev().any(|&v| passes(v))
    }

    /// The limb that lifts off next on the gait clock, if it does so while
    /// limb `li`, about to step, is still in the air, and when (seconds from
    /// now, [`LIFT_MARGIN_S`] included). The steady profile's swings
    /// overlap: a limb lifting off during a step's swing need not hold its
    /// grip to the step's landing, provided it surely lifts off — the step
    /// commits that limb's next step ([`Self::fallback_step`],
    /// [`LimbState::fallback`]). Only for plain steps (no transfer), with
    /// that limb planted and no step of its own committed, and every other
    /// limb planted or landing before it lifts off, none due: no other limb
    /// can lift off first.
    pub(super) fn next_lift(&self, env: &LocoView<'_>, li: usize) -> Option<(usize, f32)> {
        if self.transfer.is_some() {
            return None;
        }
        let offsets = env.phase_offsets;
        let cycle = env.cycle_s;
        let (lj, wait) = (0..4)
            .filter(|&j| j != li)
            .map(|j| (j, (offsets[j] - self.clock).rem_euclid(1.0) * cycle))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        let start = wait + LIFT_MARGIN_S;
        let a = &self.limbs[lj];
        if start >= env.cfg.swing_duration(Limb::ALL[li])
            || a.phase != LimbPhase::Planted
            || a.due
            || a.fallback.is_some()
        {
            return None;
        }
        let others_clear = (0..4).filter(|&k| k != li && k != lj).all(|k| {
            let l = &self.limbs[k];
            !l.due
                && l.fallback.is_none()
                && match l.phase {
                    LimbPhase::Planted => true,
                    LimbPhase::Searching => false,
                    LimbPhase::Swinging => {
                        (1.0 - l.swing_t) * env.cfg.swing_duration(Limb::ALL[k]) < wait
                    }
                }
        });
        others_clear.then_some((lj, start))
    }

    /// A step for limb `lj` to commit to once limb `li` holds `grip` (see
    /// [`Self::next_lift`]): the farthest of a few candidates on its own
    /// support, every [`FALLBACK_STRIDE`], that passes all of a step's checks
    /// with the other limbs holding. Not traced: the grip is the support
    /// model's surface point (as the hind pair's partner's).
    fn fallback_step(
        &self,
        env: &LocoView<'_>,
        li: usize,
        grip: Grip,
        lj: usize,
        checks: &mut u32,
    ) -> Option<Grip> {
        let next = self.after_steps(env, [(li, grip)]);
        let sr = next.own_search(env, lj);
        if sr.support != self.limbs[lj].grip.support || sr.retreat {
            return None;
        }
        let len = env.scene().support(sr.support).length();
        let mut own_checks = 0;
        let mut u = sr.next_u;
        while (u - sr.last_u) * sr.sdir >= -1e-6 && own_checks < FALLBACK_MAX_CHECKS {
            if (env.cfg.end_margin_m..=len - env.cfg.end_margin_m).contains(&u)
                && let Some((_, c)) =
                    next.candidate(env, &CandidateAt::probe(lj, &sr, u), &mut own_checks)
            {
                *checks += own_checks;
                return Some(Grip {
                    point: c.point,
                    normal: c.out,
                    support: sr.support,
                    u,
                    sdir: sr.sdir,
                });
            }
            u -= sr.sdir * FALLBACK_STRIDE;
        }
        *checks += own_checks;
        None
    }

    /// A plain step of limb `li` to `grip` that holds only with the limb
    /// lifting off next in the air before it lands ([`Self::next_lift`]):
    /// that limb and its committed step, if one passes with it.
    pub(super) fn planned_lift(
        &self,
        env: &LocoView<'_>,
        li: usize,
        grip: Grip,
        checks: &mut u32,
    ) -> Option<(u8, Grip)> {
        let (lj, start) = self.next_lift(env, li)?;
        let to = self.fallback_step(env, li, grip, lj, checks)?;
        *checks += 1;
        self.lift_reachable(env, li, grip.point, grip.normal, lj, to, start)
            .then_some((lj as u8, to))
    }

    /// Starts limb `li`'s swing to its committed step, if it has one (see
    /// [`LimbState::fallback`]).
    pub(super) fn start_fallback_swing(&mut self, env: &LocoView<'_>, li: usize) {
        let Some(fb) = self.limbs[li].fallback.take() else {
            return;
        };
        let l = &mut self.limbs[li];
        let left = l.grip;
        l.swing_to(fb.grip);
        l.due = false;
        self.note_step(env);
        self.note_trail(env, li, left);
    }

    /// Ends limb `li`'s search made before the release rule lets it go
    /// ([`LimbState::probe`]). It `found` a step: the limb is planted and
    /// due again, held as before. It found none: the failure counts as any
    /// search's (the caller's), and the limb's wait is over with its turn.
    fn end_probe(&mut self, li: usize, found: bool) {
        let l = &mut self.limbs[li];
        l.probe = false;
        l.phase = LimbPhase::Planted;
        if !found {
            self.load.held_since[li] = -1.0;
        }
    }

    /// A step was taken: the search's failures and the turn-backs without a
    /// step ([`Sloth::stalled_turns`]) are over. The turn-backs since the
    /// body last travelled ([`Sloth::stall_from`]) count on until it is a
    /// max step from where the first of them was made: a wanderer boxed in
    /// at a junction re-gripped a few centimetres back and forth between its
    /// turn-backs, each step clearing the count, so it never reached the
    /// turn around (and, at a branch's root, kept a sloth on the trunk
    /// beside it stuck).
    pub(super) fn note_step(&mut self, env: &LocoView<'_>) {
        self.failed_searches = 0;
        self.stalled_turns = 0;
        self.stuck_cause = None;
        if self
            .stall_from
            .is_some_and(|(p, _)| p.distance(self.body_pos) >= env.cfg.max_step_m)
        {
            self.stall_from = None;
        }
    }

    /// Wander mode, stalled ([`Self::stalled`]) straddling two branches (a
    /// junction: its limbs on two branches, no transfer or turn under way):
    /// the branch its limbs gather on, the one most of them hold, at two
    /// and two the one nearer the body (its surface), at a tie the lower
    /// id. Such a sloth can never turn around (`may_turn_around` needs all
    /// four limbs on one branch), and its turn-backs re-gripped a few
    /// centimetres back and forth (traced in the 5,000 × 300 s crowd: most
    /// wanderers stalled in place, 2026-11-27). Its limbs off that branch
    /// search it first ([`Sloth::gather_search`]), by the relaxed checks
    /// of a gathering step ([`Sloth::gathering`]), then as before. Once
    /// all four hold it, the turn around applies at the next give-up.
    pub(super) fn gather_onto(&self, env: &LocoView<'_>) -> Option<SupportId> {
        if !self.stalled()
            || self.turn.is_some()
            || self.transfer.is_some()
            || self.hang_trunk.is_some()
        {
            return None;
        }
        let a = self.limbs[0].grip.support;
        let b = self
            .limbs
            .iter()
            .map(|l| l.grip.support)
            .find(|&s| s != a)?;
        let scene = env.scene();
        let mut held = [0usize; 2];
        for l in &self.limbs {
            if l.grip.support == a {
                held[0] += 1;
            } else if l.grip.support == b {
                held[1] += 1;
            } else {
                return None;
            }
        }
        if [a, b]
            .iter()
            .any(|&s| scene.support(s).kind != SupportKind::Branch)
        {
            return None;
        }
        if held[0] != held[1] {
            return Some(if held[0] > held[1] { a } else { b });
        }
        let gap = |s: SupportId| {
            let p = project(scene.support(s), self.body_pos);
            p.point.distance(self.body_pos) - p.radius
        };
        let (ga, gb) = (gap(a), gap(b));
        Some(if ga < gb || (ga == gb && a.0 < b.0) {
            a
        } else {
            b
        })
    }

    /// A gathering step: limb `li` onto `sid`, the branch a stalled
    /// straddler gathers on ([`Self::gather_onto`]). Its step length and
    /// direction and the leg order (but the same side's spacing) are not
    /// checked: the other branch runs out of a step's length from the limb
    /// at most such junctions (the limbs a body's length apart on branches
    /// that part), and its reach (the joint limits at the swing and the
    /// landing), head up, the other sloths' clearance and the body out of
    /// the supports decide.
    pub(super) fn gathering(&self, env: &LocoView<'_>, li: usize, sid: SupportId) -> bool {
        self.wander && self.limbs[li].grip.support != sid && self.gather_onto(env) == Some(sid)
    }

    /// Wander mode: turn-backs have brought no way on — two without a step,
    /// or two since the body last travelled a max step.
    fn stalled(&self) -> bool {
        self.wander
            && (self.stalled_turns >= MAX_STALLED_TURNS
                || self.stall_from.is_some_and(|(_, n)| n >= MAX_STALLED_TURNS))
    }

    /// Why no limb found a step (called when the search gives up): other
    /// sloths in the way (some limb has a step once they are ignored; a
    /// wanderer's step only counts where it leads into a stance some limb
    /// can leave, as its stuck search will judge it),
    /// after a turn back in both directions; else a transfer under way; the
    /// leading limbs within a search distance of their support's end; else
    /// nothing within reach. Other sloths come first also mid-transfer:
    /// traced in the 5,000 × 300 s crowd, about 9 of 24 sloths counted as
    /// `transfer_failed` had a step once the others were ignored.
    fn diagnose_stuck(&self, env: &LocoView<'_>) -> StuckCause {
        if env.crowd.is_some() {
            let alone = LocoView {
                crowd: None,
                ..*env
            };
            // A wanderer's step counts only where its search, stuck from
            // now on, would take it: into a stance some limb can leave
            // ([`Self::keeps_a_way`]). Traced in the 5,000 × 300 s crowd
            // (seed 1's 1706, frozen 227 s astride two branches): its one
            // step led into a dead stance, so every search failed, yet the
            // step counted it `crowded` / `boxed_in`, and a sloth so counted
            // never retraced the trail it held.
            let usable = |lj: usize| {
                if self.wander {
                    self.has_step_then(&alone, lj, |after| after.has_a_way(env))
                } else {
                    self.has_step(&alone, lj)
                }
            };
            if (0..4).any(usable) {
                return if self.stalled_turns > 0 {
                    StuckCause::BoxedIn
                } else {
                    StuckCause::Crowded
                };
            }
        }
        if self.transfer.is_some() {
            return StuckCause::TransferFailed;
        }
        if self.at_support_end(env) {
            StuckCause::Tip
        } else {
            StuckCause::NoGrip
        }
    }

    /// Whether a leading limb holds its support within one search distance
    /// (plus the end margin) of the support's end it travels toward.
    pub(super) fn at_support_end(&self, env: &LocoView<'_>) -> bool {
        let scene = env.scene();
        Limb::ALL.iter().any(|&limb| {
            let g = self.limbs[limb.index()].grip;
            let len = scene.support(g.support).length();
            let left = if g.sdir > 0.0 { len - g.u } else { g.u };
            self.leads(limb) && left < env.cfg.search_distance_m + env.cfg.end_margin_m
        })
    }
}

/// The limbs in footfall order from limb `li` (`li` first, then the limbs
/// lifting after it within the gait cycle).
pub(super) fn footfall_order_from(env: &LocoView<'_>, li: usize) -> [usize; 4] {
    let offsets = env.phase_offsets;
    let mut order = [0usize, 1, 2, 3];
    order.sort_by(|&a, &b| {
        let da = (offsets[a] - offsets[li]).rem_euclid(1.0);
        let db = (offsets[b] - offsets[li]).rem_euclid(1.0);
        da.total_cmp(&db)
    });
    order
}

/// The confirming trace of candidate `m` for a grip that another support
/// hides: that trace starts `TRACE_STANDOFF` off the support, so a parallel
/// branch or a fork's other limb within that distance of the grip's side is
/// hit first (at `parallel` gaps under 0.15 m every grip on the side facing
/// the other branch was refused, and the hind limb there never stepped again).
/// The claw and hand need `claw_length_m` + [`CLAW_ROOM_MARGIN`] off the
/// surface (SPEC step 5, formula 4): where no other support's solid lies in
/// that room, the grip is traced again from its far side. `None`: no room,
/// or the surface is not there.
fn trace_in_claw_room(env: &LocoView<'_>, m: &Candidate) -> Option<TraceHit> {
    let room = env.cfg.claw_length_m + CLAW_ROOM_MARGIN;
    // The room: a cube of the room's side standing on the grip, facing out.
    let bx = BoxOverlap {
        center: m.point + m.out * (0.5 * room),
        half_extents: Vec3::splat(0.5 * room),
        rotation: Quat::from_rotation_arc(Vec3::Z, m.out.normalize()),
    };
    let mut found = Vec::new();
    env.query.overlap_box(&bx, &mut found).ok()?;
    if found.iter().any(|&s| s != m.support) {
        return None;
    }
    let line = LineTrace {
        origin: m.point + m.out * room,
        dir: -m.out,
        max_dist: 2.0 * room,
    };
    env.query
        .line(&line)
        .ok()
        .flatten()
        .filter(|h| h.support == m.support)
}

#[cfg(test)]
mod way_down_tests {
    use glam::Vec3;
    use slothsim_rig::Rig;
    use slothsim_scene::{Preset, PresetKind, TraceScene};

    use super::super::test_util::tick;
    use super::super::{LimbPhase, NearRing, Sloth, SpawnHint, TraceBatch};
    use crate::{CrowdGrid, LocoEnv, LocoView, LocomotionConfig, Profile};

    /// Whether a hind limb of `s` has a step down its trunk once turned back
    /// (tail first), the other sloths ignored.
    fn has_way_down(view: &LocoView<'_>, s: &Sloth) -> bool {
        let mut back = *s;
        back.turn_back();
        let alone = LocoView {
            crowd: None,
            ..*view
        };
        [2, 3].iter().any(|&h| back.has_step(&alone, h))
    }

    /// A wanderer climbing the `trunk` preset (radii 0.1–0.16 m) with a
    /// sloth just above it (a copy of its own points moved up the trunk by
    /// its fore–hind spread and 0.2 m: its fore limbs have no step up within
    /// the clearance, its hind limbs have room to close up): at every stance
    /// it takes head up (all four limbs planted on the trunk) a hind limb
    /// has a step down the trunk ([`Sloth::keeps_way_down`]). Without the
    /// rule the hind limbs closed up under the held fore limbs to the same
    /// side's spacing, where every hind step down failed reach (crowds:
    /// stuck for minutes, turning back and forth).
    #[test]
    fn a_wanderer_held_from_above_on_a_trunk_keeps_its_way_down() {
        let mut stances = 0;
        for radius in [0.1, 0.13, 0.16] {
            let preset = Preset::new(PresetKind::Trunk, Some(radius)).unwrap();
            let cfg = LocomotionConfig::profile(Profile::Free);
            let env =
                LocoEnv::new(cfg, &Rig::sloth(), TraceScene::new(preset.scene.clone())).unwrap();
            let view = env.view();
            let hint = SpawnHint::from(preset.start);
            let mut sloth = Sloth::spawn(&view, &hint, None);
            sloth.wander = true;
            let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
            let on_trunk = |s: &Sloth| {
                s.transfer.is_none()
                    && s.limbs.iter().all(|l| {
                        l.grip.support == preset.start.support && l.phase == LimbPhase::Planted
                    })
            };
            for _ in 0..60 {
                tick(&mut sloth, &mut near, &view, &mut batch);
            }
            for _ in 0..300 {
                if on_trunk(&sloth) {
                    break;
                }
                tick(&mut sloth, &mut near, &view, &mut batch);
            }
            assert!(on_trunk(&sloth), "r {radius}: on the trunk");
            assert!(
                has_way_down(&view, &sloth),
                "r {radius}: a way down at the start"
            );
            let y = |li: usize| sloth.limbs[li].grip.point.y;
            let spread = y(0).max(y(1)) - y(2).min(y(3));
            let above = Vec3::Y * (spread + 0.2);
            let other = crate::crowd_points(view.rig, &sloth).map(|p| p + above);
            let mut grid = CrowdGrid::new(0.3);
            grid.rebuild(other.iter().map(|&p| (1000, p)));
            let crowd = env.view_with(Some(&grid));
            let mut closed = f32::INFINITY;
            for frame in 0..1800 {
                tick(&mut sloth, &mut near, &crowd, &mut batch);
                assert!(sloth.body_pos.is_finite(), "r {radius} frame {frame}");
                if sloth.dir > 0.0 && on_trunk(&sloth) {
                    stances += 1;
                    let y = |li: usize| sloth.limbs[li].grip.point.y;
                    closed = closed.min((y(0) - y(2)).min(y(1) - y(3)));
                    assert!(
                        has_way_down(&view, &sloth),
                        "r {radius} frame {frame}: no hind step down (fore − hind {:.3} / {:.3} m)",
                        y(0) - y(2),
                        y(1) - y(3)
                    );
                }
            }
            assert!(closed.is_finite(), "r {radius}: no stance head up");
        }
        assert!(stances > 0);
    }
}

#[cfg(test)]
mod gather_tests {
    use slothsim_rig::Rig;
    use slothsim_scene::{Preset, PresetKind, TraceScene};

    use super::super::test_util::{tick, xorshift};
    use super::super::{NearRing, SpawnHint};
    use super::*;
    use crate::{LocoEnv, LocomotionConfig, Profile};

    /// Wanderers walked across the junction of the `turn` preset (angles
    /// drawn at random), taken where they straddle its two branches (all
    /// limbs planted, no transfer or turn), then stalled (eight turn-backs
    /// without travel, `Sloth::stall_from`; every other one turned back):
    /// [`Sloth::gather_onto`] names the branch most limbs hold, and the
    /// sloth stands on one branch within 30 s, on that one in at least half
    /// the cases (the others walked on onto the other branch: the way on is
    /// free here). Some limbs off that branch have a step onto it only as a
    /// gathering step (the same stance not stalled has none: the step
    /// length, its direction or the leg order refuses them), and every step
    /// onto it the plain checks allow is a gathering step too. Not stalled,
    /// or in goal mode, there is nothing to gather.
    #[test]
    fn a_stalled_straddler_gathers_on_one_branch() {
        let mut rnd = xorshift(26);
        let (mut cases, mut only_gathering, mut gathered) = (0, 0, 0);
        for _ in 0..6 {
            let angle = 60.0 + 120.0 * rnd();
            let preset = Preset::new(PresetKind::Turn, Some(angle)).unwrap();
            let cfg = LocomotionConfig::profile(Profile::Free);
            let env =
                LocoEnv::new(cfg, &Rig::sloth(), TraceScene::new(preset.scene.clone())).unwrap();
            let view = env.view();
            let s = preset.start;
            let hint = SpawnHint::from(s);
            let mut sloth = Sloth::spawn(&view, &hint, None);
            sloth.wander = true;
            let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
            let mut straddles = Vec::new();
            for frame in 0..2400 {
                tick(&mut sloth, &mut near, &view, &mut batch);
                let a = sloth.limbs[0].grip.support;
                if frame % 10 == 0
                    && sloth.limbs.iter().any(|l| l.grip.support != a)
                    && sloth.limbs.iter().all(|l| l.phase == LimbPhase::Planted)
                    && sloth.transfer.is_none()
                    && sloth.turn.is_none()
                {
                    straddles.push(sloth);
                }
            }
            for (k, &plain) in straddles.iter().enumerate() {
                assert_eq!(plain.gather_onto(&view), None, "angle {angle}: not stalled");
                let mut stalled = plain;
                if k % 2 == 1 {
                    // Turned back: tail first.
                    stalled.turn_back();
                }
                stalled.stall_from = Some((stalled.body_pos, 8));
                stalled.stalled_turns = 0;
                let mut goal_mode = stalled;
                goal_mode.wander = false;
                assert_eq!(
                    goal_mode.gather_onto(&view),
                    None,
                    "angle {angle}: goal mode"
                );
                let sid = stalled
                    .gather_onto(&view)
                    .expect("a stalled straddler gathers");
                let held =
                    |s: &Sloth, sid| s.limbs.iter().filter(|l| l.grip.support == sid).count();
                assert!(
                    2 * held(&stalled, sid) >= 4,
                    "angle {angle}: the branch most hold"
                );
                for li in 0..4 {
                    if stalled.limbs[li].grip.support == sid {
                        continue;
                    }
                    let has = |s: &Sloth| {
                        s.neighbour_search(&view, li, sid, 0)
                            .is_some_and(|sr| s.range_has_step(&view, li, &sr))
                    };
                    let mut plain_dir = plain;
                    plain_dir.dir = stalled.dir;
                    for (p, q) in plain_dir.limbs.iter_mut().zip(&stalled.limbs) {
                        p.grip.sdir = q.grip.sdir;
                    }
                    let (p, g) = (has(&plain_dir), has(&stalled));
                    assert!(
                        !p || g,
                        "angle {angle} case {k} limb {li}: a plain step refused"
                    );
                    only_gathering += usize::from(g && !p);
                }
                let mut sl = stalled;
                let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
                let mut one = None;
                for _ in 0..1800 {
                    tick(&mut sl, &mut near, &view, &mut batch);
                    assert!(sl.body_pos.is_finite(), "angle {angle} case {k}");
                    let a = sl.limbs[0].grip.support;
                    if held(&sl, a) == 4 && sl.limbs.iter().all(|l| l.phase == LimbPhase::Planted) {
                        one = Some(a);
                        break;
                    }
                }
                let one = one.expect("on one branch within 30 s");
                gathered += usize::from(one == sid);
                cases += 1;
            }
        }
        assert!(
            cases >= 10 && only_gathering > 0 && 2 * gathered >= cases,
            "{cases} straddles, {gathered} gathered, {only_gathering} limbs with gathering steps only"
        );
    }
}

#[cfg(test)]
mod dead_stance_tests {
    use slothsim_scene::SupportId;

    use super::super::Grip;
    use super::super::test_util::crowd_fixture;

    /// Issue 24 (the seed-11 crowd, wanderer 1403 at 19.93 s; fixture
    /// `testdata/dead_stance.json`). Stuck (its search gave up, then it
    /// turned back) half across a branch → trunk transfer, the left fore
    /// limb on the trunk and the other three on the branch by its root, the
    /// wanderer has a step (some limb, one way or the other, the other
    /// sloths ignored); its right fore limb's step onto the trunk passes
    /// every check, and after it no limb has a step either way: the step is
    /// refused ([`Sloth::keeps_a_way`]; main took it, without the lookahead,
    /// and the wanderer stood there from 19.93 s to the end of the run).
    #[test]
    fn a_stuck_wanderers_step_into_a_dead_stance_is_refused() {
        let (fx, sloth, env) = crowd_fixture(include_str!("testdata/dead_stance.json"));
        let step = &fx["step"];
        let v =
            |x: &serde_json::Value| -> glam::Vec3 { serde_json::from_value(x.clone()).unwrap() };
        let li = step["limb"].as_u64().unwrap() as usize;
        let grip = Grip {
            point: v(&step["point"]),
            normal: v(&step["normal"]),
            support: SupportId(step["support"].as_u64().unwrap() as u32),
            u: step["u"].as_f64().unwrap() as f32,
            sdir: step["sdir"].as_f64().unwrap() as f32,
        };
        let view = env.view();
        for l in &sloth.limbs {
            let s = view.scene().support(l.grip.support);
            let gap = crate::path::surface_gap(view.query, s, l.grip.point);
            assert!(gap.abs() < 1e-3, "grip {gap} m off its support");
        }
        assert!(sloth.wander && sloth.stuck_cause.is_some() && sloth.transfer.is_some());
        // The step passes its checks (reach within the joint limits,
        // penetration, leg order, head up: the search queued and traced it).
        assert!(sloth.step_reachable(&view, li, grip.point, grip.normal, grip.support));
        assert!(sloth.has_a_way(&view), "the stance before has a way");
        let after = sloth.after_steps(&view, [(li, grip)]);
        assert!(!after.has_a_way(&view), "the stance after has a way");
        assert!(
            !sloth.leaves_a_way_on(&view, li, grip, None),
            "the step into a dead stance is taken"
        );
    }
}
