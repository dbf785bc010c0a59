//! FABRIK (forward and backward reaching IK) for a 4-joint [`LimbChain`], with the same
//! joint limits as [`crate::ccd`], for comparison with CCD (see crate README).
//!
//! Stages of [`solve`] (same validation, root-frame handling and result type as CCD):
//! 1. `fk_local` of the warm-start pose; early exit if within tolerance.
//! 2. Per iteration: a *backward* pass (effector pinned to the target, each joint pulled
//!    toward its child at bone length) and a *forward* pass (girdle joint pinned back at
//!    its place), on positions only.
//! 3. `positions_to_pose`: root to tip, each joint takes the shortest-arc rotation that
//!    points its bone at the new child position (twist kept from the previous pose, which
//!    positions cannot determine), then, with `apply_limits`, is projected into its limit
//!    (`JointLimit::clamp`: hinges drop off-axis rotation and clamp the angle, balls clamp
//!    swing and twist); the next joint's position is re-derived by FK, so the chain stays
//!    consistent with the limits ("project after each pass" constrained FABRIK).
//! 4. The best pose seen is returned; the solve stops after 8 iterations without a
//!    `min_improvement` gain (projection can make single iterations go uphill).

use crate::unit::UnitOr;
use glam::{Quat, Vec3, Vec3A};

use crate::ccd::{CcdResult, CcdStatus};
use crate::chain::{CHAIN_JOINTS, ChainPose, LimbChain, RootTransform};

/// FABRIK parameters. `Copy`; defaults match [`crate::CcdParams::default`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FabrikParams {
    /// Success distance between effector and target (metres). Default 0.5 mm.
    pub tolerance: f32,
    /// Maximum number of backward+forward iterations. Default 64.
    pub max_iterations: u32,
    /// Stop when an iteration reduces the error by less than this (metres). Default 10 µm.
    pub min_improvement: f32,
    /// Project every joint into its limit after each iteration. Default true; false is
    /// plain (unconstrained) FABRIK, for measuring how far it leaves the limits.
    pub apply_limits: bool,
}

impl Default for FabrikParams {
    fn default() -> Self {
        Self {
            tolerance: 5e-4,
            max_iterations: 64,
            min_improvement: 1e-5,
            apply_limits: true,
        }
    }
}

impl FabrikParams {
    /// Parameters are usable (finite positive tolerance, ≥ 1 iteration, finite
    /// non-negative `min_improvement`)?
    pub fn is_valid(&self) -> bool {
        self.tolerance.is_finite()
            && self.tolerance > 0.0
            && self.max_iterations > 0
            && self.min_improvement.is_finite()
            && self.min_improvement >= 0.0
    }
}

/// Solve `chain` so its effector reaches `target_ws`, from (and into) `pose`. Invalid
/// params or a non-finite target/root return `InvalidParams`/`InvalidTarget` with the
/// pose untouched; a non-finite pose is reset to neutral.
pub fn solve(
    chain: &LimbChain,
    root_ws: impl Into<RootTransform>,
    target_ws: Vec3,
    pose: &mut ChainPose,
    params: &FabrikParams,
) -> CcdResult {
    let rejected = |status| CcdResult {
        reached: false,
        error: f32::NAN,
        iterations: 0,
        status,
    };
    if !params.is_valid() {
        return rejected(CcdStatus::InvalidParams);
    }
    let root = root_ws.into();
    if !target_ws.is_finite() || !root.position.is_finite() || !root.rotation.is_finite() {
        return rejected(CcdStatus::InvalidTarget);
    }
    if !pose.is_finite() {
        *pose = ChainPose::NEUTRAL;
    }
    let target = root.inverse_transform_point(target_ws.into());
    let (mut pos, _) = chain.fk_local(pose);
    let mut err = pos[4].distance(target);
    let mut iterations = 0;
    // Projection can make single iterations go uphill: keep the best pose seen and stop
    // after `STALL_ITERATIONS` iterations without a `min_improvement` gain.
    let mut best = (*pose, err);
    let mut current = *pose;
    let mut since_gain = 0;
    while best.1 > params.tolerance && iterations < params.max_iterations {
        iterations += 1;
        let mut p = pos;
        // Backward: tip to girdle.
        p[4] = target;
        for i in (0..CHAIN_JOINTS).rev() {
            p[i] = p[i + 1] + (p[i] - p[i + 1]).unit_or_zero() * chain.lengths[i];
        }
        // Forward: girdle back at its place, out to the tip.
        p[0] = pos[0];
        for i in 0..CHAIN_JOINTS {
            p[i + 1] = p[i] + (p[i + 1] - p[i]).unit_or_zero() * chain.lengths[i];
        }
        positions_to_pose(chain, &p, &mut current, params.apply_limits);
        pos = chain.fk_local(&current).0;
        err = pos[4].distance(target);
        if err < best.1 - params.min_improvement {
            since_gain = 0;
        } else {
            since_gain += 1;
        }
        if err < best.1 {
            best = (current, err);
        }
        if since_gain >= STALL_ITERATIONS {
            break;
        }
    }
    *pose = best.0;
    let err = best.1;
    let reached = err <= params.tolerance;
    CcdResult {
        reached,
        error: err,
        iterations,
        status: if reached {
            CcdStatus::Reached
        } else if iterations < params.max_iterations {
            CcdStatus::Stalled
        } else {
            CcdStatus::MaxIterations
        },
    }
}

/// Iterations without gain before FABRIK gives up.
const STALL_ITERATIONS: u32 = 8;

/// Rotate each joint (root to tip) so its bone points at `p[j + 1]`, optionally clamped
/// into its limit; positions below are re-derived by FK as it goes.
pub fn positions_to_pose(chain: &LimbChain, p: &[Vec3A; 5], pose: &mut ChainPose, limits: bool) {
    let mut parent_rot = Quat::IDENTITY;
    let mut joint_pos = chain.offsets[0];
    for j in 0..CHAIN_JOINTS {
        let base = parent_rot * chain.rest[j];
        let bone_ls = if j + 1 < CHAIN_JOINTS {
            chain.offsets[j + 1]
        } else {
            chain.effector
        };
        let rot = base * pose.0[j];
        let want_ls = rot.inverse() * (p[j + 1] - joint_pos);
        if want_ls.length_squared() > 1e-14 && bone_ls.length_squared() > 1e-14 {
            let arc = Quat::from_rotation_arc(
                Vec3::from(bone_ls.normalize()),
                Vec3::from(want_ls.normalize()),
            );
            pose.0[j] = (pose.0[j] * arc).normalize();
        }
        if limits {
            pose.0[j] = chain.limits[j].clamp(pose.0[j]);
        }
        parent_rot = base * pose.0[j];
        joint_pos += parent_rot * bone_ls;
    }
}
