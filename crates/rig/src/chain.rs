//! A self-contained 4-joint limb chain, its pose, and its forward kinematics.
//!
//! Frames: the chain hangs off a *chain root* (the joint the girdle bone is attached to,
//! e.g. the chest for fore limbs), whose world transform the caller passes as `root_ws`.
//! Joint `i` sits at `offsets[i]` in its parent's frame (joint `i-1`, or the chain root
//! for `i = 0`), has a rest rotation `rest[i]`, and the pose adds a rest-relative
//! rotation `pose.0[i]`:
//!
//! ```text
//! rot_ws[i] = rot_ws[i-1] * rest[i] * pose[i]        (rot_ws[-1] = root rotation)
//! pos_ws[i] = pos_ws[i-1] + rot_ws[i-1] * offsets[i]  (pos_ws[-1] = root position)
//! effector  = pos_ws[3]  + rot_ws[3] * effector
//! ```
//! Joint limits apply to `pose.0[i]`. The identity pose is the rest (neutral) pose.

use glam::{Affine3A, Quat, Vec3, Vec3A};

use crate::limb::Limb;
use crate::limits::JointLimit;

/// Number of joints in a limb chain (girdle, proximal, distal, hand/foot).
pub const CHAIN_JOINTS: usize = 4;

/// Rest-relative local rotations of the 4 chain joints, girdle first. `Copy`; keep one
/// per limb and pass it back next frame to warm-start the solver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChainPose(pub [Quat; CHAIN_JOINTS]);

impl ChainPose {
    /// The neutral (rest) pose.
    pub const NEUTRAL: ChainPose = ChainPose([Quat::IDENTITY; CHAIN_JOINTS]);

    /// All four rotations finite?
    pub fn is_finite(&self) -> bool {
        self.0.iter().all(|q| q.is_finite())
    }

    /// Largest angle (radians) between corresponding joint rotations of two poses.
    pub fn max_joint_delta(&self, other: &ChainPose) -> f32 {
        self.0
            .iter()
            .zip(other.0.iter())
            .map(|(a, b)| a.angle_between(*b))
            .fold(0.0, f32::max)
    }
}

impl Default for ChainPose {
    fn default() -> Self {
        Self::NEUTRAL
    }
}

/// Chain root transform in world space: position + rotation (no scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RootTransform {
    /// World position of the chain root (metres).
    pub position: Vec3A,
    /// World rotation of the chain root.
    pub rotation: Quat,
}

impl RootTransform {
    /// Identity root.
    pub const IDENTITY: RootTransform = RootTransform {
        position: Vec3A::ZERO,
        rotation: Quat::IDENTITY,
    };

    /// Root at `position` rotated by `rotation`.
    pub fn new(position: Vec3, rotation: Quat) -> Self {
        Self {
            position: position.into(),
            rotation,
        }
    }

    /// From an affine transform (its scale is discarded).
    pub fn from_affine(a: &Affine3A) -> Self {
        let (_, rotation, position) = a.to_scale_rotation_translation();
        Self {
            position: position.into(),
            rotation,
        }
    }

    /// `self * other` (other expressed in this frame).
    pub fn mul(&self, other: &RootTransform) -> RootTransform {
        RootTransform {
            position: self.position + self.rotation * other.position,
            rotation: self.rotation * other.rotation,
        }
    }

    /// World point → root-local point.
    #[inline]
    pub fn inverse_transform_point(&self, p: Vec3A) -> Vec3A {
        self.rotation.inverse() * (p - self.position)
    }

    /// Root-local point → world point.
    #[inline]
    pub fn transform_point(&self, p: Vec3A) -> Vec3A {
        self.position + self.rotation * p
    }
}

impl From<Affine3A> for RootTransform {
    fn from(a: Affine3A) -> Self {
        Self::from_affine(&a)
    }
}

impl From<(Vec3, Quat)> for RootTransform {
    fn from((p, q): (Vec3, Quat)) -> Self {
        Self::new(p, q)
    }
}

/// A limb's 4-joint chain, independent of the skeleton it came from. `Copy`, ~300 B.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimbChain {
    /// Which limb.
    pub limb: Limb,
    /// Rest translation of joint `i` in its parent's frame (metres).
    pub offsets: [Vec3A; CHAIN_JOINTS],
    /// Rest rotation of joint `i` relative to its parent.
    pub rest: [Quat; CHAIN_JOINTS],
    /// Effector (tip of hand/foot) in joint 3's frame (metres).
    pub effector: Vec3A,
    /// Per-joint limits on the rest-relative pose rotation.
    pub limits: [JointLimit; CHAIN_JOINTS],
    /// Bone lengths: joint0→1, 1→2, 2→3, 3→effector (metres).
    pub lengths: [f32; CHAIN_JOINTS],
}

impl LimbChain {
    /// Build a chain; lengths are derived from the offsets.
    pub fn new(
        limb: Limb,
        offsets: [Vec3A; CHAIN_JOINTS],
        rest: [Quat; CHAIN_JOINTS],
        effector: Vec3A,
        limits: [JointLimit; CHAIN_JOINTS],
    ) -> Self {
        let lengths = [
            offsets[1].length(),
            offsets[2].length(),
            offsets[3].length(),
            effector.length(),
        ];
        Self {
            limb,
            offsets,
            rest,
            effector,
            limits,
            lengths,
        }
    }

    /// Sum of the bone lengths from joint 0 to the effector (metres).
    pub fn reach(&self) -> f32 {
        self.lengths.iter().sum()
    }

    /// Forward kinematics: world positions of joints 0..3 and the effector (index 4).
    pub fn fk(&self, root_ws: impl Into<RootTransform>, pose: &ChainPose) -> [Vec3; 5] {
        let root = root_ws.into();
        let (pos, _) = self.fk_local(pose);
        pos.map(|p| Vec3::from(root.transform_point(p)))
    }

    /// The effector of [`LimbChain::fk`] (its index 4), bit for bit, without
    /// moving the joints to world space.
    #[inline]
    pub fn fk_effector(&self, root_ws: impl Into<RootTransform>, pose: &ChainPose) -> Vec3 {
        let root = root_ws.into();
        let (pos, _) = self.fk_local(pose);
        Vec3::from(root.transform_point(pos[4]))
    }

    /// Forward kinematics in the chain-root frame: joint/effector positions and the
    /// joint rotations (root-relative).
    #[inline]
    pub fn fk_local(&self, pose: &ChainPose) -> ([Vec3A; 5], [Quat; CHAIN_JOINTS]) {
        let mut pos = [Vec3A::ZERO; 5];
        let mut rot = [Quat::IDENTITY; CHAIN_JOINTS];
        let mut parent_rot = Quat::IDENTITY;
        let mut parent_pos = Vec3A::ZERO;
        for i in 0..CHAIN_JOINTS {
            pos[i] = parent_pos + parent_rot * self.offsets[i];
            rot[i] = parent_rot * self.rest[i] * pose.0[i];
            parent_pos = pos[i];
            parent_rot = rot[i];
        }
        pos[4] = parent_pos + parent_rot * self.effector;
        (pos, rot)
    }

    /// Per-joint limit violation of `pose` (radians, 0 = inside the limit).
    pub fn joint_violations(&self, pose: &ChainPose) -> [f32; CHAIN_JOINTS] {
        std::array::from_fn(|i| self.limits[i].violation(pose.0[i]))
    }

    /// Largest joint-limit violation of `pose` (radians; 0 = every joint within limits).
    pub fn limit_violation(&self, pose: &ChainPose) -> f32 {
        self.joint_violations(pose).into_iter().fold(0.0, f32::max)
    }

    /// Clamp every joint of `pose` into its limit.
    pub fn clamp_pose(&self, pose: &mut ChainPose) {
        for i in 0..CHAIN_JOINTS {
            pose.0[i] = self.limits[i].clamp(pose.0[i]);
        }
    }

    /// A within-limits pose from 12 numbers in `[0, 1]` (3 per joint, see
    /// [`JointLimit::sample_unit`]); continuous in `u`.
    pub fn sample_pose(&self, u: &[f32; 12]) -> ChainPose {
        ChainPose(std::array::from_fn(|i| {
            self.limits[i].sample_unit([u[3 * i], u[3 * i + 1], u[3 * i + 2]])
        }))
    }

    /// Skeleton local rotation of chain joint `i` for a pose (`rest[i] * pose[i]`), to
    /// write back into a [`crate::Skeleton::fk`] `locals` buffer.
    pub fn local_rotation(&self, pose: &ChainPose, i: usize) -> Quat {
        self.rest[i] * pose.0[i]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rig;

    #[test]
    fn fk_effector_is_fk_index_4_bit_for_bit() {
        let rig = Rig::sloth();
        let mut rnd = crate::test_rng::uniform(0x1234_5678_u64);
        for chain in rig.chains() {
            for _ in 0..500 {
                let u: [f32; 12] = std::array::from_fn(|_| rnd());
                let pose = chain.sample_pose(&u);
                let root = RootTransform::new(
                    Vec3::new(rnd() * 40.0 - 20.0, rnd() * 30.0, rnd() * 40.0 - 20.0),
                    Quat::from_euler(glam::EulerRot::YXZ, rnd() * 6.0, rnd() * 3.0, rnd()),
                );
                let a = chain.fk(root, &pose)[4];
                let b = chain.fk_effector(root, &pose);
                assert_eq!(
                    a.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits)
                );
            }
        }
    }
}
