//! What the judge and the gait statistics see of a sloth each frame (SPEC
//! "Test scenarios": the measures behind thesis Table 7).

use glam::Vec3;

use crate::observe::{LimbObservation, SlothObservation};

use super::collide::torso_penetration;
use super::{LimbPhase, LocoView, Sloth};

impl Sloth {
    /// What the judge and the statistics see this frame.
    pub fn observe(&self, env: &LocoView<'_>) -> SlothObservation {
        let scene = env.scene();
        let limbs: [LimbObservation; 4] = std::array::from_fn(|li| {
            let l = &self.limbs[li];
            let s = scene.support(l.grip.support);
            LimbObservation {
                planted: l.phase != LimbPhase::Swinging,
                grip_ws: l.grip.point,
                effector_ws: l.effector,
                root_ws: l.root,
                limb_length: env.rig.chains[li].reach(),
                surface_gap: crate::path::surface_gap(env.query, s, l.effector),
                limit_violation: env.rig.chains[li].limit_violation(&l.pose),
                support: l.grip.support,
            }
        });
        let to_ws = |p: Vec3| self.body_pos + self.body_rot * p;
        let head = to_ws(env.rig.head_ms);
        let hips = to_ws(env.rig.hips_ms);
        let torso = [to_ws(env.rig.torso_ms[0]), to_ws(env.rig.torso_ms[1])];
        let on_trunk = self.fore_on_trunk(env);
        let penetration = self.near_supports(env).fold(0.0, |p, id| {
            torso_penetration(
                scene.support(id),
                env.adjacency.segment_chunks(id),
                torso,
                p,
            )
        });
        let goal_distance_m = self.goal_distance(env).map_or(f32::INFINITY, |(d, _)| d);
        let has_nan = !(self.body_pos.is_finite()
            && self.body_rot.is_finite()
            && self
                .limbs
                .iter()
                .all(|l| l.pose.is_finite() && l.target.is_finite()));
        SlothObservation {
            time_s: self.time,
            gait_clock: self.clock,
            body_pos: self.body_pos,
            body_rot: self.body_rot,
            head_ws: head,
            hips_ws: hips,
            on_trunk,
            limbs,
            penetration_m: penetration,
            goal_distance_m: if goal_distance_m.is_finite() {
                goal_distance_m
            } else {
                f32::MAX
            },
            goal_held: self.goal.is_none_or(|(gs, _)| self.holds_only(gs)),
            has_nan,
            residual_bw: self.load.residual_bw,
        }
    }
}
