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
            self.clock = (self.clock + dt / env.cfg.cycle_duration()).fract();
        }
        let offsets = env.cfg.phase_offsets();
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
            // Release rule (issue 22): the grips that stay must carry the body.
            if !self.release_allowed(env, li) {
                if !held_back {
                    held_back = true;
                    self.load.held_back_frames += 1;
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
            self.limbs[li].due = false;
            if self.limbs.iter().all(|l| l.phase == LimbPhase::Planted) {
                self.keep_hang_side(env);
            }
            self.limbs[li].phase = LimbPhase::Searching;
            self.limbs[li].search = self
                .goal_branch_search(env, li)
                .unwrap_or_else(|| self.own_search(env, li));
            self.queue_candidates(env, li, batch);
        }
    }
}
