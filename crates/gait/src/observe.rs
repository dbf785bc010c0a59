//! What the simulation reports about one sloth each frame, for the judge and
//! the gait statistics. Plain data, world space, metres/seconds/radians.
//!
//! The simulation fills these from its state after the frame's stages ran
//! (IK solved, body placed); nothing here knows about the ECS.

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use slothsim_rig::Limb;
use slothsim_scene::SupportId;

/// One limb, one frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LimbObservation {
    /// In contact (stance): the limb holds `grip_ws`.
    pub planted: bool,
    /// The grip point the limb holds (planted) or is travelling to (swinging), on the support surface.
    pub grip_ws: Vec3,
    /// Claw tip after IK, by forward kinematics.
    pub effector_ws: Vec3,
    /// Limb root (shoulder blade / pelvis joint).
    pub root_ws: Vec3,
    /// Reach of the limb (sum of bone lengths), metres.
    pub limb_length: f32,
    /// Distance between the effector and the surface of the gripped support
    /// (|distance to axis − radius|); meaningful when planted.
    pub surface_gap: f32,
    /// Largest joint-limit violation of the solved pose (radians, 0 = within limits).
    pub limit_violation: f32,
    /// The support the grip is on.
    pub support: SupportId,
}

/// One sloth, one frame.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlothObservation {
    /// Simulated time at the end of the frame, seconds.
    pub time_s: f32,
    /// Phase of the gait clock at the end of the frame (0–1 of a cycle; a limb is due when
    /// it crosses the limb's phase offset). It stops while the release rule holds a due
    /// limb back, so it is not `time_s` over the cycle.
    #[serde(default)]
    pub gait_clock: f32,
    /// Body (pelvis-to-chest centre) position.
    pub body_pos: Vec3,
    /// Body rotation (model +Z forward, +Y toward the support).
    pub body_rot: Quat,
    /// Head position.
    pub head_ws: Vec3,
    /// Hip (pelvis) position.
    pub hips_ws: Vec3,
    /// The body is on a trunk (its fore limbs grip a trunk).
    pub on_trunk: bool,
    /// The limbs, indexed by [`Limb::index`].
    pub limbs: [LimbObservation; 4],
    /// Deepest penetration of the body's collision capsule into any support, metres (0 = none).
    pub penetration_m: f32,
    /// Distance from the body to the goal (see `slothsim_scene::Goal`), metres.
    pub goal_distance_m: f32,
    /// All four limbs hold the goal's support (or the goal names no support):
    /// only then does being within the goal tolerance count as reached (a
    /// body passing near a goal on a trunk while still under the branch has
    /// not reached it).
    pub goal_held: bool,
    /// Some value of this sloth's state was NaN/inf this frame.
    pub has_nan: bool,
    /// Residual wrench of the grip loads (issue 22) in body weights: what the holding
    /// claws could not supply (0 before the first GripLoad stage).
    pub residual_bw: f32,
}

impl SlothObservation {
    /// The limb observation for `limb`.
    pub fn limb(&self, limb: Limb) -> &LimbObservation {
        &self.limbs[limb.index()]
    }

    /// Number of planted limbs.
    pub fn limbs_in_contact(&self) -> usize {
        self.limbs.iter().filter(|l| l.planted).count()
    }
}
