//! Transitions (thesis §3.1 fig. 20, DSDC footfall order; §3.3 step timeline
//! and `TimeBetweenSteps`; SPEC "Gait"): the gait clock lifts limbs in
//! footfall order and starts their step searches; goal and stop rules;
//! committed steps lift off by their deadline; transfers end.

use super::{LimbPhase, LocoView, Sloth, Status, TraceBatch};

impl Sloth {
    /// Transitions: gait clock and footfall order, goal check. Limbs whose
    /// turn has come start searching (their first traces go into `batch`).
    pub fn transitions(&mut self, env: &LocoView<'_>, dt: f32, batch: &mut TraceBatch) {
        self.time += dt;
        // Committed steps lift off by their deadline (in the last frame
        // before it), whatever else the sloth does: another limb's swing was
        // checked with them in the air from then on.
        for li in 0..4 {
            if self.limbs[li].fallback.is_some_and(|fb| {
                self.time + dt > fb.by_s && self.limbs[li].phase != LimbPhase::Swinging
            }) {
                self.start_fallback_swing(env, li);
            }
        }
        if let Some((d, true)) = self.goal_distance(env)
            && d <= self.goal_tolerance
        {
            self.status = Status::Arrived;
        }
        if let Some(t) = self.resume_at
            && self.time >= t
        {
            self.resume_at = None;
            self.status = Status::Moving;
            self.stalled_turns = 0;
            self.failed_searches = 0;
        }
        if self.status != Status::Moving {
            return;
        }
        self.end_backoff();
        self.finish_transfer(env);
        self.finish_turn_step(env);
        // At the goal with a limb still swinging (the steady profile's
        // swings overlap, so a moment with all four planted may never come
        // while walking): no limb lifts off until the swings end; then the
        // sloth has arrived, or walks on if the last landing took it out of
        // the goal's tolerance.
        let arriving = self
            .goal_distance_with(env, Self::grips_only)
            .is_some_and(|(d, on)| on && d <= self.goal_tolerance);
        // A limb the release rule holds back keeps its turn: the clock waits
        // with it, so the limbs after it in footfall order do not lift first
        // (and leave it to let go later with fewer grips).
        let waiting = (0..4).any(|li| {
            let l = &self.limbs[li];
            l.due && l.phase == LimbPhase::Planted && self.load.held_since[li] >= 0.0
        });
        let prev = self.clock;
        if !waiting {
            self.clock = (self.clock + dt / env.cycle_s).fract();
        }
        let offsets = env.phase_offsets;
        for (li, &off) in offsets.iter().enumerate() {
            let crossed = if self.clock >= prev {
                off > prev && off <= self.clock
            } else {
                off > prev || off <= self.clock
            };
            if crossed {
                self.limbs[li].due = true;
            }
        }
        let mut held_back = false;
        for li in 0..4 {
            let planted = self
                .limbs
                .iter()
                .filter(|l| l.phase != LimbPhase::Swinging)
                .count();
            let l = self.limbs[li];
            if !l.due || l.phase != LimbPhase::Planted || planted < 3 || arriving {
                continue;
            }
            // Retracing (`retrace.rs`): only the trail's limb steps, back.
            let retracing = self.trail.retrace_left > 0;
            if retracing && self.retrace_limb() != Some(li) {
                self.limbs[li].due = false;
                continue;
            }
            // Release rule (issue 22): the grips that stay must carry the body.
            let hold_starts = self.load.held_since[li] < 0.0;
            if !self.release_allowed(env, li) {
                if !held_back {
                    held_back = true;
                    self.load.held_back_frames += 1;
                }
                // A wanderer whose search has failed searches first, as it
                // starts being held: a search that fails is counted at once,
                // not after the wait (on a trunk, where the rule holds most
                // limbs about 1 s, eight failed searches took ~14 s, longer
                // than the crowd's 10 s stuck window). A step it finds is not
                // taken: the limb waits as before and searches again when
                // the rule lets it go, so every step taken keeps the rule.
                if hold_starts && self.probes_before_release() {
                    self.start_search(env, li, batch, true);
                }
                continue;
            }
            // Down a branch to a trunk the goal is below the junction on:
            // turn around first, then on tail first (see
            // `Sloth::descends_tail_first`).
            if self.descends_tail_first(env) && self.may_turn_around(env, false) {
                self.start_turn(true);
            }
            if self.turn.is_some() {
                // Turning around: the limb's step is the turn's.
                self.turn_search(env, li);
                continue;
            }
            if retracing {
                self.retrace_step(env, li);
                continue;
            }
            self.limbs[li].due = false;
            self.start_search(env, li, batch, false);
        }
    }

    /// Limb `li` starts its step search (its goal's branch first, else its own
    /// support) and queues the first candidates; `probe`: a search made before
    /// the release rule lets the limb go (its step, if found, is not taken).
    fn start_search(&mut self, env: &LocoView<'_>, li: usize, batch: &mut TraceBatch, probe: bool) {
        if self.limbs.iter().all(|l| l.phase == LimbPhase::Planted) {
            self.keep_hang_side(env);
        }
        self.limbs[li].phase = LimbPhase::Searching;
        self.limbs[li].probe = probe;
        self.fine_rescan &= !(1 << li);
        // Goal mode, the lone-fore lock going round a circle: where a turn of
        // the transfer's side gives the partner a step onto the trunk, it
        // turns now, with no limb in the air (`Sloth::turn_side_in_lone_lock`).
        if !probe {
            self.turn_side_in_lone_lock(env);
        }
        // Goal mode: a search of the lone fore limb across a locked
        // transfer onto a trunk is counted (`Sloth::own_search`).
        let goal_branch = self
            .goal_branch_search(env, li)
            .or_else(|| self.gather_search(env, li));
        let by_own = goal_branch.is_none();
        self.limbs[li].search = goal_branch.unwrap_or_else(|| self.own_search(env, li));
        if by_own && !probe && !self.wander && self.lone_fore_locked(env, li) {
            self.lone_fore_searches = self.lone_fore_searches.saturating_add(1);
        }
        // Goal mode, the lone-fore lock: a limb on the branch takes the
        // farthest step that unlocks it within a few steps of the footfall
        // order (`Sloth::lone_fore_unlocking_u`), where one does.
        if !probe && !self.wander {
            let sr = self.limbs[li].search;
            if let Some(u) = self.lone_fore_unlocking_u(env, li, &sr) {
                self.limbs[li].search.first_u = u;
                self.limbs[li].search.next_u = u;
            }
        }
        self.queue_candidates(env, li, batch);
    }

    /// Whether a limb the release rule starts holding back searches first
    /// (see [`Sloth::transitions`]): a wanderer, not turning, whose search
    /// has failed since its last step.
    fn probes_before_release(&self) -> bool {
        self.wander
            && self.turn.is_none()
            && self.failed_searches > 0
            && self.trail.retrace_left == 0
    }
}

#[cfg(test)]
mod tests {
    use slothsim_scene::PresetKind;

    use super::super::NearRing;
    use super::super::test_util::{preset_sloth, tick};
    use super::*;

    /// A wanderer whose search has failed searches before the release rule's
    /// wait (`Sloth::probes_before_release`): a search that fails is counted
    /// in the frame it ends, the limb's wait over; a search that finds a step
    /// takes none, and the limb waits, planted and due, as before. Every
    /// preset's sloth made a wanderer, the rule made to hold back nearly every
    /// limb (the lowest residual the config allows), a failed search kept on
    /// the count.
    #[test]
    fn a_failed_wanderer_searches_before_the_release_wait() {
        let (mut found, mut failed, mut steps) = (0, 0, 0);
        // Also with no step anywhere: every search range empty (its shortest
        // step past its longest).
        for (kind, no_step) in PresetKind::ALL
            .map(|k| (k, false))
            .into_iter()
            .chain([PresetKind::Trunk, PresetKind::Turn].map(|k| (k, true)))
        {
            let (mut env, mut sloth) = preset_sloth(kind);
            env.cfg.release_residual_bw = 1e-4;
            if no_step {
                env.cfg.min_step_m = env.cfg.search_distance_m + 0.1;
            }
            let view = env.view();
            sloth.wander = true;
            let mut batch = TraceBatch::default();
            let mut near = NearRing::default();
            for _ in 0..900 {
                if sloth.failed_searches == 0 {
                    sloth.failed_searches = 1;
                }
                let before = sloth;
                tick(&mut sloth, &mut near, &view, &mut batch);
                for li in 0..4 {
                    let (a, b) = (before.limbs[li], sloth.limbs[li]);
                    if a.phase == LimbPhase::Searching && !a.probe {
                        steps += usize::from(b.phase == LimbPhase::Swinging);
                    }
                    if !(a.phase == LimbPhase::Searching && a.probe) || b.probe {
                        continue;
                    }
                    // The probe ended this tick (`step_search`), and the clock
                    // may have started the limb's search again (released).
                    assert_ne!(b.phase, LimbPhase::Swinging, "{kind:?} limb {li}");
                    if b.due || b.phase == LimbPhase::Searching {
                        found += 1;
                        // The wait goes on from where it started, or the rule
                        // let the limb go this tick.
                        let since = sloth.load.held_since[li];
                        assert!(
                            since == before.load.held_since[li]
                                || (since < 0.0 && b.phase == LimbPhase::Searching),
                            "{kind:?} limb {li}: held since {since}"
                        );
                    }
                }
                if no_step {
                    failed += usize::from(
                        sloth.failed_searches > before.failed_searches
                            || sloth.stuck_cause.is_some() && before.stuck_cause.is_none(),
                    );
                }
            }
            if no_step {
                // Held back, yet no limb waited out the rule's second: each
                // search failed as the wait began.
                assert!(sloth.load.held_back_frames > 0, "{kind:?}");
                assert_eq!(sloth.load.forced_releases, 0, "{kind:?}");
            }
        }
        assert!(
            found > 0 && failed > 0 && steps > 0,
            "{found} {failed} {steps}"
        );
    }
}
