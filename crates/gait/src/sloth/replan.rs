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

use super::{LocoView, Sloth};

/// Re-plans a goal-mode sloth makes before it stops (`no_grip`).
const MAX_REPLANS: u8 = 6;

/// A back-off lasts this many gait cycles.
const BACKOFF_CYCLES: f32 = 1.0;

/// A back-off under way (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Backoff {
    /// Simulated time at which the sloth turns toward its goal again.
    pub until_s: f32,
    /// The travel direction toward the goal (restored then).
    pub dir: f32,
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
                });
                self.face(-self.dir);
            }
        }
        true
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
