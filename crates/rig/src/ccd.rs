//! Cyclic-coordinate-descent IK for a 4-joint [`LimbChain`] with joint limits.
//!
//! The job is the pair (`LimbChain`, [`CcdParams`]) plus caller-owned state (the
//! [`ChainPose`], warm-started from the previous frame). No allocation, no hidden state.
//!
//! Stages of [`solve`]:
//! 1. `validate`: reject bad params / non-finite targets *without touching the pose*.
//! 2. `to_root_space`: the target goes into the chain-root frame once, so the result is
//!    invariant under moving/rotating the root and nothing else needs transforming.
//! 3. `fk_local`: positions/rotations of the warm-start pose; early exit if in tolerance.
//! 4. sweeps: for each joint (tail-first by default) rotate it so the effector points at
//!    the target, capped at `max_step_angle`, then clamp into the joint limit
//!    (`hinge_step`/`ball_step`), then update the joints below it. Early exit as soon as
//!    the effector is within `tolerance`, or when a sweep improves the error by less
//!    than `min_improvement` (unreachable target: the pose settles and stays put, so
//!    there is no frame-to-frame jitter).
//!
//! Degenerate cases: a target on top of a joint gives no direction for that joint, so
//! the joint is skipped; a target beyond reach leaves the limb stretched toward it
//! within its limits (`reached == false`, `error` = remaining distance).

use glam::{Quat, Vec3, Vec3A};

use crate::chain::{CHAIN_JOINTS, ChainPose, LimbChain, RootTransform};
use crate::limits::{JointLimit, quat_axis_angle, twist_angle};

/// Joint visiting order inside one CCD sweep.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CcdOrder {
    /// Hand/foot first, girdle last (classic CCD). Default: see crate README.
    #[default]
    TailFirst,
    /// Girdle first, hand/foot last.
    RootFirst,
}

/// Solver parameters. `Copy`; defaults are safe for real-time use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CcdParams {
    /// Success distance between effector and target (metres). Default 0.5 mm.
    pub tolerance: f32,
    /// Maximum number of sweeps over the 4 joints. Default 64.
    pub max_iterations: u32,
    /// Largest rotation a single joint may make in one step (radians). Default 0.6.
    pub max_step_angle: f32,
    /// Stop when a full sweep reduces the error by less than this (metres). Default 10 µm.
    pub min_improvement: f32,
    /// Joint order within a sweep.
    pub order: CcdOrder,
    /// Mid-joint (elbow/knee) "reach" step: instead of aiming, set the hinge so the
    /// effector is as far from the proximal ball joint as the target is (the proximal
    /// joint then only has to aim). Much faster convergence near full extension.
    pub reach_step: bool,
}

impl Default for CcdParams {
    fn default() -> Self {
        Self {
            tolerance: 5e-4,
            max_iterations: 64,
            max_step_angle: 0.6,
            min_improvement: 1e-5,
            order: CcdOrder::TailFirst,
            reach_step: true,
        }
    }
}

/// Why parameters are invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CcdParamsError {
    /// `tolerance` must be finite and > 0.
    #[error("tolerance must be finite and > 0")]
    Tolerance,
    /// `max_iterations` must be ≥ 1.
    #[error("max_iterations must be >= 1")]
    MaxIterations,
    /// `max_step_angle` must be in (0, π].
    #[error("max_step_angle must be in (0, pi]")]
    MaxStepAngle,
    /// `min_improvement` must be finite and ≥ 0.
    #[error("min_improvement must be finite and >= 0")]
    MinImprovement,
}

impl CcdParams {
    /// Tighter and slower: 0.1 mm tolerance, 64 sweeps.
    pub fn precise() -> Self {
        Self {
            tolerance: 1e-4,
            max_iterations: 64,
            ..Self::default()
        }
    }

    /// Check the parameters.
    pub fn validate(&self) -> Result<(), CcdParamsError> {
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(CcdParamsError::Tolerance);
        }
        if self.max_iterations == 0 {
            return Err(CcdParamsError::MaxIterations);
        }
        if !(self.max_step_angle > 0.0 && self.max_step_angle <= std::f32::consts::PI) {
            return Err(CcdParamsError::MaxStepAngle);
        }
        if !(self.min_improvement.is_finite() && self.min_improvement >= 0.0) {
            return Err(CcdParamsError::MinImprovement);
        }
        Ok(())
    }
}

/// How a solve ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CcdStatus {
    /// Effector within tolerance.
    Reached,
    /// Sweeps stopped improving (target out of reach or blocked by limits).
    Stalled,
    /// Ran out of iterations while still improving.
    MaxIterations,
    /// Target (or root) was NaN/infinite; pose untouched.
    InvalidTarget,
    /// Parameters failed [`CcdParams::validate`]; pose untouched.
    InvalidParams,
}

/// Outcome of one solve.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CcdResult {
    /// Effector within `tolerance` of the target.
    pub reached: bool,
    /// Final effector–target distance (metres); NaN when the target was invalid.
    pub error: f32,
    /// Sweeps started (0 when the warm start was already within tolerance).
    pub iterations: u32,
    /// How it ended.
    pub status: CcdStatus,
}

impl CcdResult {
    fn rejected(status: CcdStatus) -> Self {
        Self {
            reached: false,
            error: f32::NAN,
            iterations: 0,
            status,
        }
    }
}

/// Working state of one solve, in the chain-root frame.
struct Frames {
    /// Joint positions 0..3 and effector (4).
    pos: [Vec3A; 5],
    /// Joint rotations (root-relative), pose included.
    rot: [Quat; CHAIN_JOINTS],
    /// The last mid-joint reach step could not set the wanted distance (limit hit).
    mid_saturated: bool,
}

impl Frames {
    #[inline]
    fn new(chain: &LimbChain, pose: &ChainPose) -> Self {
        let (pos, rot) = chain.fk_local(pose);
        Self {
            pos,
            rot,
            mid_saturated: false,
        }
    }

    /// Recompute joint `j`'s rotation and everything below it after `pose[j]` changed.
    #[inline]
    fn update_from(&mut self, chain: &LimbChain, pose: &ChainPose, j: usize) {
        let mut parent_rot = if j == 0 {
            Quat::IDENTITY
        } else {
            self.rot[j - 1]
        };
        for i in j..CHAIN_JOINTS {
            if i > j {
                self.pos[i] = self.pos[i - 1] + parent_rot * chain.offsets[i];
            }
            self.rot[i] = parent_rot * chain.rest[i] * pose.0[i];
            parent_rot = self.rot[i];
        }
        self.pos[4] = self.pos[3] + parent_rot * chain.effector;
    }
}

/// Solve `chain` so that its effector reaches `target_ws`, starting from (and writing
/// to) `pose`. `root_ws` is the world transform of the chain root. See module docs.
///
/// A non-finite target or root, or invalid `params`, returns immediately with
/// `reached == false` and leaves `pose` untouched. A non-finite `pose` is reset to
/// neutral before solving.
pub fn solve(
    chain: &LimbChain,
    root_ws: impl Into<RootTransform>,
    target_ws: Vec3,
    pose: &mut ChainPose,
    params: &CcdParams,
) -> CcdResult {
    if params.validate().is_err() {
        return CcdResult::rejected(CcdStatus::InvalidParams);
    }
    let root = root_ws.into();
    if !target_ws.is_finite() || !root.position.is_finite() || !root.rotation.is_finite() {
        return CcdResult::rejected(CcdStatus::InvalidTarget);
    }
    if !pose.is_finite() {
        *pose = ChainPose::NEUTRAL;
    }
    let target = root.inverse_transform_point(target_ws.into());
    solve_local(chain, target, pose, params)
}

/// [`solve`] with the target already in the chain-root frame and params already
/// validated (no checks).
fn solve_local(
    chain: &LimbChain,
    target: Vec3A,
    pose: &mut ChainPose,
    params: &CcdParams,
) -> CcdResult {
    let mut frames = Frames::new(chain, pose);
    let tol_sq = params.tolerance * params.tolerance;
    let mut err_sq = frames.pos[4].distance_squared(target);
    if err_sq <= tol_sq {
        return CcdResult {
            reached: true,
            error: err_sq.sqrt(),
            iterations: 0,
            status: CcdStatus::Reached,
        };
    }
    let (cos_cap, sin_half_cap, cos_half_cap) = {
        let (s, c) = (0.5 * params.max_step_angle).sin_cos();
        (params.max_step_angle.cos(), s, c)
    };
    let cap = StepCap {
        max_angle: params.max_step_angle,
        cos_cap,
        sin_half_cap,
        cos_half_cap,
    };
    let mut prev_err = err_sq.sqrt();
    let mut reach_step = params.reach_step;
    for iter in 0..params.max_iterations {
        let sweep_start = *pose;
        for k in 0..CHAIN_JOINTS {
            let j = match params.order {
                CcdOrder::TailFirst => CHAIN_JOINTS - 1 - k,
                CcdOrder::RootFirst => k,
            };
            if step_joint(chain, &mut frames, pose, j, target, &cap, reach_step) {
                err_sq = frames.pos[4].distance_squared(target);
                if err_sq <= tol_sq {
                    return CcdResult {
                        reached: true,
                        error: err_sq.sqrt(),
                        iterations: iter + 1,
                        status: CcdStatus::Reached,
                    };
                }
            }
        }
        let err = err_sq.sqrt();
        if prev_err - err < params.min_improvement {
            // A sweep is kept only if it improved the error by `min_improvement`:
            // undo it, so an already-settled pose stays exactly where it was and
            // unreachable targets do not jitter from frame to frame.
            *pose = sweep_start;
            if reach_step {
                // Reach steps stopped helping (a limit blocks them): go on with plain
                // aiming CCD from the same pose.
                reach_step = false;
                frames = Frames::new(chain, pose);
                err_sq = prev_err * prev_err;
                continue;
            }
            return CcdResult {
                reached: false,
                error: prev_err,
                iterations: iter + 1,
                status: CcdStatus::Stalled,
            };
        }
        prev_err = err;
    }
    CcdResult {
        reached: false,
        error: err_sq.sqrt(),
        iterations: params.max_iterations,
        status: CcdStatus::MaxIterations,
    }
}

struct StepCap {
    max_angle: f32,
    cos_cap: f32,
    sin_half_cap: f32,
    cos_half_cap: f32,
}

/// One CCD step on joint `j`. Returns whether the pose changed.
#[inline]
fn step_joint(
    chain: &LimbChain,
    frames: &mut Frames,
    pose: &mut ChainPose,
    j: usize,
    target: Vec3A,
    cap: &StepCap,
    reach_step: bool,
) -> bool {
    let joint_pos = frames.pos[j];
    if reach_step
        && j == 0
        && frames.mid_saturated
        && matches!(chain.limits[0], JointLimit::Ball { .. })
    {
        // Girdle reach: move the proximal joint (on its sphere about the girdle) to a
        // point as far from the target as the effector is from it now.
        let inv_rot = frames.rot[0].inverse();
        let b_ls = inv_rot * (frames.pos[1] - joint_pos);
        let d_ls = inv_rot * (target - joint_pos);
        let s = (frames.pos[4] - frames.pos[1]).length();
        return match ball_reach_step(b_ls, d_ls, s, cap.max_angle) {
            Some(delta) => {
                pose.0[0] = chain.limits[0].clamp(pose.0[0] * delta);
                frames.update_from(chain, pose, 0);
                true
            }
            None => false,
        };
    }
    if reach_step
        && j == 2
        && let JointLimit::Hinge { axis, min, max } = chain.limits[j]
    {
        let inv_rot = frames.rot[j].inverse();
        let eff_ls = inv_rot * (frames.pos[4] - joint_pos);
        let ref_ls = inv_rot * (frames.pos[1] - joint_pos);
        let want = (target - frames.pos[1]).length();
        let (step, saturated) = reach_hinge_step(
            pose.0[j],
            axis,
            min,
            max,
            eff_ls,
            ref_ls,
            want,
            cap.max_angle,
        );
        frames.mid_saturated = saturated;
        return match step {
            Some(q) => {
                pose.0[j] = q;
                frames.update_from(chain, pose, j);
                true
            }
            None => false,
        };
    }
    let inv_rot = frames.rot[j].inverse();
    // Effector and target directions in joint j's own (posed) frame.
    let eff_ls = inv_rot * (frames.pos[4] - joint_pos);
    let target_ls = inv_rot * (target - joint_pos);
    let new_q = match chain.limits[j] {
        JointLimit::Hinge { axis, min, max } => {
            match hinge_step(pose.0[j], axis, min, max, eff_ls, target_ls, cap.max_angle) {
                Some(q) => q,
                None => return false,
            }
        }
        limit => match arc_step(eff_ls, target_ls, cap) {
            Some(delta) => limit.clamp(pose.0[j] * delta),
            None => return false,
        },
    };
    pose.0[j] = new_q;
    frames.update_from(chain, pose, j);
    true
}

/// Hinge step: the best rotation about `axis` (which is the same vector in the posed
/// and rest frames) bringing `eff_ls` toward `target_ls`, capped and clamped.
#[inline]
fn hinge_step(
    q: Quat,
    axis: Vec3A,
    min: f32,
    max: f32,
    eff_ls: Vec3A,
    target_ls: Vec3A,
    max_angle: f32,
) -> Option<Quat> {
    let e = eff_ls - axis * axis.dot(eff_ls);
    let t = target_ls - axis * axis.dot(target_ls);
    let ee = e.length_squared();
    let tt = t.length_squared();
    if ee < 1e-14 || tt < 1e-14 {
        return None;
    }
    let delta = axis
        .dot(e.cross(t))
        .atan2(e.dot(t))
        .clamp(-max_angle, max_angle);
    let current = twist_angle(q, axis);
    let wanted = (current + delta).clamp(min, max);
    if wanted == current {
        return None;
    }
    Some(quat_axis_angle(axis, wanted))
}

/// Shortest-arc rotation taking direction `from` toward `to`, capped at the step angle.
#[inline]
fn arc_step(from: Vec3A, to: Vec3A, cap: &StepCap) -> Option<Quat> {
    let ff = from.length_squared();
    let tt = to.length_squared();
    if ff < 1e-14 || tt < 1e-14 {
        return None;
    }
    let inv = (ff * tt).sqrt().recip();
    let cos = (from.dot(to) * inv).clamp(-1.0, 1.0);
    let axis = from.cross(to);
    let sin_len = axis.length_squared();
    if sin_len < 1e-18 {
        // Parallel: nothing to do. Anti-parallel: ambiguous axis; let other joints move.
        return None;
    }
    let axis = axis * sin_len.sqrt().recip();
    if cos < cap.cos_cap {
        let v = axis * cap.sin_half_cap;
        return Some(Quat::from_xyzw(v.x, v.y, v.z, cap.cos_half_cap));
    }
    // Half-angle formulas: no trig on the common (uncapped) path.
    let cos_half = (0.5 * (1.0 + cos)).max(0.0).sqrt();
    let sin_half = (0.5 * (1.0 - cos)).max(0.0).sqrt();
    let v = axis * sin_half;
    Some(Quat::from_xyzw(v.x, v.y, v.z, cos_half))
}

/// Reach step for a hinge: the angle change about `axis` that makes the effector's
/// distance to the reference point `ref_ls` (the proximal joint) equal `want`, nearest
/// to the current angle, capped and clamped.
#[allow(clippy::too_many_arguments)]
#[inline]
fn reach_hinge_step(
    q: Quat,
    axis: Vec3A,
    min: f32,
    max: f32,
    eff_ls: Vec3A,
    ref_ls: Vec3A,
    want: f32,
    max_angle: f32,
) -> (Option<Quat>, bool) {
    // |e(φ) − r|² = |e|² + |r|² − 2 (e_a·r_a + |e⊥||r⊥| cos(φ − φ0)), φ = rotation of e⊥.
    let ea = axis.dot(eff_ls);
    let ra = axis.dot(ref_ls);
    let e = eff_ls - axis * ea;
    let r = ref_ls - axis * ra;
    let el = e.length();
    let rl = r.length();
    if el < 1e-7 || rl < 1e-7 {
        return (None, false);
    }
    let k = eff_ls.length_squared() + ref_ls.length_squared() - 2.0 * ea * ra;
    // want² = k − 2 el rl cos(ψ), ψ = angle from e⊥ to r⊥ after rotating e by δ
    let cos_raw = (k - want * want) / (2.0 * el * rl);
    let cos_psi = cos_raw.clamp(-1.0, 1.0);
    let psi = cos_psi.acos();
    // current signed angle from e⊥ to r⊥ about axis
    let cur = axis.dot(e.cross(r)).atan2(e.dot(r));
    // rotating e by δ changes the angle to r by −δ: need cur − δ = ±psi
    let current = twist_angle(q, axis);
    // Of the two hinge angles giving that distance, prefer one inside the limits, then
    // the smaller change.
    let score = |d: f32| {
        let a = current + d;
        let outside = (min - a).max(a - max).max(0.0);
        (outside, d.abs())
    };
    let d1 = wrap(cur - psi);
    let d2 = wrap(cur + psi);
    let delta = if score(d1) <= score(d2) { d1 } else { d2 };
    let delta = delta.clamp(-max_angle, max_angle);
    let unclamped = current + delta;
    let wanted = unclamped.clamp(min, max);
    let saturated = cos_raw.abs() > 1.0 || wanted != unclamped;
    if wanted == current {
        return (None, saturated);
    }
    (Some(quat_axis_angle(axis, wanted)), saturated)
}

#[inline]
fn wrap(a: f32) -> f32 {
    use std::f32::consts::{PI, TAU};
    if a > PI {
        a - TAU
    } else if a < -PI {
        a + TAU
    } else {
        a
    }
}

/// Reach step for the girdle ball joint: the smallest rotation of `b_ls` (proximal joint
/// relative to the girdle) that puts its end at distance `s` from `d_ls` (the target),
/// capped. `None` when nothing needs to (or can) change.
#[inline]
fn ball_reach_step(b_ls: Vec3A, d_ls: Vec3A, s: f32, max_angle: f32) -> Option<Quat> {
    let l = b_ls.length();
    let d = d_ls.length();
    if l < 1e-7 || d < 1e-7 {
        return None;
    }
    let cos_want = ((l * l + d * d - s * s) / (2.0 * l * d)).clamp(-1.0, 1.0);
    let axis = b_ls.cross(d_ls);
    let axis_len = axis.length();
    if axis_len < 1e-9 {
        return None;
    }
    let now = axis_len.atan2(b_ls.dot(d_ls));
    let delta = (now - cos_want.acos()).clamp(-max_angle, max_angle);
    if delta.abs() < 1e-7 {
        return None;
    }
    Some(quat_axis_angle(axis / axis_len, delta))
}
