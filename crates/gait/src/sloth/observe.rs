//! What the judge and the gait statistics see of a sloth each frame (SPEC
//! "Test scenarios": the measures behind thesis Table 7).

use glam::Vec3;

use crate::observe::{LimbObservation, SlothObservation};

use super::collide::torso_penetration;
use super::{LimbPhase, LocoView, Sloth};

/// Words of a limb's [`ObserveMemo`] key: the support, the effector, the pose.
const LIMB_KEY_LEN: usize = 1 + 3 + 4 * slothsim_rig::CHAIN_JOINTS;

/// Words of the body's [`ObserveMemo`] key: position, rotation, the four
/// held supports.
const BODY_KEY_LEN: usize = 3 + 4 + 4;

/// The dearest measures of [`Sloth::observe`] as last computed, with the bits
/// of what each is a function of (for a run's one `env`): per limb the
/// surface gap (support, effector) and the joint-limit violation (pose); the
/// torso's penetration (body position and rotation, the held supports, whose
/// neighbours it searches). A resting sloth keeps all of them from frame to
/// frame (about half of a crowd's sloth-frames), and a function of the same
/// bits gives the same bits. Keep one per sloth ([`Sloth::observe_memo`]);
/// `Default` holds nothing.
#[derive(Clone, Debug, Default)]
pub struct ObserveMemo {
    limbs: [Option<([u32; LIMB_KEY_LEN], f32, f32)>; 4],
    body: Option<([u32; BODY_KEY_LEN], f32)>,
}

fn bits<const N: usize>(v: [f32; N]) -> [u32; N] {
    v.map(f32::to_bits)
}

impl Sloth {
    /// What the judge and the statistics see this frame.
    pub fn observe(&self, env: &LocoView<'_>) -> SlothObservation {
        self.observe_memo(env, &mut ObserveMemo::default())
    }

    /// [`Sloth::observe`], its surface gaps, joint-limit violations and
    /// torso penetration taken from `memo` where their inputs hold the bits
    /// they were computed from (the same observation, bit for bit), and
    /// `memo` brought up to date. `memo` belongs to this sloth and `env`.
    pub fn observe_memo(&self, env: &LocoView<'_>, memo: &mut ObserveMemo) -> SlothObservation {
        let scene = env.scene();
        let limbs: [LimbObservation; 4] = std::array::from_fn(|li| {
            let l = &self.limbs[li];
            let mut key = [0u32; LIMB_KEY_LEN];
            key[0] = l.grip.support.0;
            key[1..4].copy_from_slice(&bits(l.effector.to_array()));
            for (k, q) in l.pose.0.iter().enumerate() {
                key[4 + 4 * k..8 + 4 * k].copy_from_slice(&bits(q.to_array()));
            }
            let (surface_gap, limit_violation) = match memo.limbs[li] {
                Some((k, gap, violation)) if k == key => (gap, violation),
                _ => {
                    let s = scene.support(l.grip.support);
                    let gap = env.adjacency.surface_gap(env.query, s, l.effector);
                    let violation = env.rig.chains[li].limit_violation(&l.pose);
                    memo.limbs[li] = Some((key, gap, violation));
                    (gap, violation)
                }
            };
            LimbObservation {
                planted: l.phase != LimbPhase::Swinging,
                grip_ws: l.grip.point,
                effector_ws: l.effector,
                root_ws: l.root,
                limb_length: env.rig.chains[li].reach(),
                surface_gap,
                limit_violation,
                support: l.grip.support,
            }
        });
        let to_ws = |p: Vec3| self.body_pos + self.body_rot * p;
        let head = to_ws(env.rig.head_ms);
        let hips = to_ws(env.rig.hips_ms);
        let on_trunk = self.fore_on_trunk(env);
        let mut key = [0u32; BODY_KEY_LEN];
        key[..3].copy_from_slice(&bits(self.body_pos.to_array()));
        key[3..7].copy_from_slice(&bits(self.body_rot.to_array()));
        for (k, l) in self.limbs.iter().enumerate() {
            key[7 + k] = l.grip.support.0;
        }
        let penetration = match memo.body {
            Some((k, p)) if k == key => p,
            _ => {
                let torso = [to_ws(env.rig.torso_ms[0]), to_ws(env.rig.torso_ms[1])];
                let p = self.near_supports(env).fold(0.0, |p, id| {
                    torso_penetration(
                        scene.support(id),
                        env.adjacency.segment_chunks(id),
                        torso,
                        p,
                    )
                });
                memo.body = Some((key, p));
                p
            }
        };
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
