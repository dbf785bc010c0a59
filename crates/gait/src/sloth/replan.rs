//! Re-planning instead of stopping (goal mode; issue 24): a sloth whose
//! limbs all found no step for two gait cycles backs off — it walks the
//! other way for a gait cycle, then turns toward its goal again and plans
//! anew from the stance it has then. A transfer locked half way is undone
//! by the back-off (the trailing limbs return to the support the leading
//! ones hold: `Sloth::own_search`) and starts again, from another stance,
//! with the limb whose turn it is then, on that limb's side of the trunk;
//! a stance locked on a trunk (the fore limbs too close above the hind
//! limbs to step down) climbs a cycle and comes down spread. A transfer
//! onto a trunk locked with one fore limb across, the other's trunk grip
//! out of its reach, first turns its side toward that limb
//! (`Sloth::turned_transfer_side`). Wander mode has its own turn back and
//! is not changed.

use serde::{Deserialize, Serialize};

use slothsim_rig::Limb;

use super::{LocoView, NearRing, Sloth, Status, TraceBatch};

/// Re-plans a goal-mode sloth makes before it stops (`no_grip`).
const MAX_REPLANS: u8 = 6;

/// A back-off lasts this many gait cycles, unless a playout chooses
/// another of [`BACKOFF_CHOICES`].
const BACKOFF_CYCLES: f32 = 1.0;

/// The lengths (gait cycles) a fresh back-off may take, in the order they
/// are played out; the first is [`BACKOFF_CYCLES`].
const BACKOFF_CHOICES: [f32; 5] = [BACKOFF_CYCLES, 2.0, 3.0, 4.0, 0.5];

/// How far ahead (simulated seconds) a back-off's playout looks for the
/// arrival.
const PLAYOUT_S: f32 = 60.0;

/// A back-off under way (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Backoff {
    /// Simulated time at which the sloth turns toward its goal again.
    pub until_s: f32,
    /// The travel direction toward the goal (restored then).
    pub dir: f32,
    /// Whether its length was chosen by playouts (`Sloth::plan_backoff`).
    /// Checkpointed (format 29).
    #[serde(default)]
    pub planned: bool,
}

impl Sloth {
    /// Goal mode, no limb has found a step for two gait cycles: re-plan
    /// instead of stopping. Turns a transfer's side toward a fore limb left
    /// behind (not counted: the turn is bounded by itself), else starts a
    /// back-off, or ends one that is itself stuck (toward the goal again).
    /// False once [`MAX_REPLANS`] are spent, and always in wander mode: the
    /// sloth stops.
    pub(super) fn replan(&mut self, env: &LocoView<'_>) -> bool {
        if self.wander || self.goal.is_none() {
            return false;
        }
        // transfer_to_trunk with one fore limb across and the other without
        // a step onto the trunk: the transfer's side turns toward that limb
        // (bounded by the turn itself, not counted among the re-plans).
        if self.backoff.is_none()
            && let Some(tr) = self.turned_transfer_side(env)
        {
            self.transfer = Some(tr);
            self.failed_searches = 0;
            return true;
        }
        if self.replans >= MAX_REPLANS {
            return false;
        }
        self.replans += 1;
        // transfer_to_branch with the fore limbs across and the hind pair
        // stuck on the trunk: the hind limbs go one at a time.
        if let Some(tr) = self.transfer
            && tr.to != tr.trunk
            && !self.hind_single
            && self.hind_pair(Limb::LH.index(), tr.to).is_some()
        {
            self.hind_single = true;
            self.failed_searches = 0;
            return true;
        }
        match self.backoff.take() {
            Some(b) => self.face(b.dir),
            None => {
                self.backoff = Some(Backoff {
                    until_s: self.time + BACKOFF_CYCLES * env.cycle_s,
                    dir: self.dir,
                    planned: false,
                });
                self.face(-self.dir);
            }
        }
        true
    }

    /// A back-off just started (not yet planned): its length is chosen by
    /// playing the sloth out alone, whole frames as the crowd's pass runs
    /// them, from this frame's step search on: the first of
    /// [`BACKOFF_CHOICES`] with which it arrives within [`PLAYOUT_S`]; with
    /// none, the default one cycle. The same back-off every time sent a
    /// circling transfer back into the same circle (branch_trunk to-trunk
    /// 0.15 m 148.6503°: three give-ups 20 s apart, each with the same
    /// one-cycle back-off, to the time limit). When no length arrives, the
    /// lengths are played out again with [`Sloth::close_up`] set (a hind
    /// limb may close up part way to its partner); the first that arrives
    /// sets it for good.
    pub(super) fn plan_backoff(
        &mut self,
        env: &LocoView<'_>,
        batch: &TraceBatch,
        near: Option<&NearRing>,
    ) {
        let Some(b) = self.backoff.filter(|b| !b.planned) else {
            return;
        };
        let from_s = b.until_s - BACKOFF_CYCLES * env.cycle_s;
        let with = |k: f32| {
            let mut s = *self;
            s.backoff = Some(Backoff {
                until_s: from_s + k * env.cycle_s,
                planned: true,
                ..b
            });
            s
        };
        // Without closing up first (as before it existed), then with it.
        let close_ups: &[bool] = if self.close_up {
            &[true]
        } else {
            &[false, true]
        };
        let chosen = close_ups
            .iter()
            .flat_map(|&c| BACKOFF_CHOICES.map(|k| (c, k)))
            .find(|&(c, k)| {
                let mut s = with(k);
                s.close_up = c;
                s.arrives_within(env, batch.clone(), near.copied(), PLAYOUT_S)
            });
        let (close_up, k) = chosen.unwrap_or((self.close_up, BACKOFF_CYCLES));
        *self = with(k);
        self.close_up = close_up;
    }

    /// Whether this sloth, played out alone for `horizon_s` (whole frames,
    /// the crowd pass's stages in order; back-offs met on the way keep
    /// their default length), arrives at its goal.
    fn arrives_within(
        mut self,
        env: &LocoView<'_>,
        mut batch: TraceBatch,
        mut near: Option<NearRing>,
        horizon_s: f32,
    ) -> bool {
        let dt = env.frame_dt;
        let frames = (horizon_s / dt).ceil() as u32;
        for f in 0..frames {
            if f > 0 && self.traces_queued {
                batch.run(&env.query);
            }
            if let Some(b) = &mut self.backoff {
                b.planned = true;
            }
            self.step_search_planned(env, &mut batch, near.as_mut());
            self.body_average(env, dt);
            self.solve_limbs(env);
            self.grip_load(env, dt, 1);
            self.transitions(env, dt, &mut batch);
            match self.status {
                Status::Arrived => return true,
                Status::NoGrip => return false,
                Status::Moving => {}
            }
        }
        false
    }

    /// Ends a back-off whose time is up: the sloth turns toward its goal.
    pub(super) fn end_backoff(&mut self) {
        if let Some(b) = self.backoff
            && self.time >= b.until_s
        {
            self.backoff = None;
            self.face(b.dir);
        }
    }

    /// Travels in direction `dir` (±1; the footfall order continues).
    fn face(&mut self, dir: f32) {
        if self.dir != dir {
            self.dir = dir;
            for l in &mut self.limbs {
                l.grip.sdir = -l.grip.sdir;
            }
        }
        self.failed_searches = 0;
    }
}
