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
//!    (`hinge_step`/`arc_step` + clamp, no trig), then update the effector (tail-first)
//!    or the joints below (root-first). Early exit as soon as the effector is within
//!    `tolerance`, or when a sweep improves the error by less than `min_improvement`
//!    (unreachable target: the pose settles and stays put, so no frame-to-frame jitter).
//! 5. `polish`: sweeps that stall short of a target within reach hand over to the
//!    limit-aware damped least squares of `refine` (CCD gets trapped at limit corners).
//! 6. Smoothness guard: a warm solve that turned a joint by more than
//!    [`SMOOTH_JOINT_STEP`] is redone by the least squares from the warm start.
//!
//! Degenerate cases: a target on top of a joint gives no direction for that joint, so
//! the joint is skipped; a target beyond reach leaves the limb stretched toward it
//! within its limits (`reached == false`, `error` = remaining distance).

use glam::{Quat, Vec3, Vec3A};

use crate::chain::{CHAIN_JOINTS, ChainPose, LimbChain, RootTransform};
use crate::limits::{JointLimit, clamp_hinge_half, half_sin_cos, hinge_half, hinge_quat};
use crate::refine;

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
    /// When the sweeps stall short of a target within reach, polish with a limit-aware
    /// damped-least-squares stage (all joints at once; see README). Default on.
    pub refine: bool,
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
            refine: true,
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
    /// Joint rotations (root-relative), pose included: `base[i] * pose[i]`.
    rot: [Quat; CHAIN_JOINTS],
    /// Joint rest frames (root-relative), pose excluded: `rot[i-1] * rest[i]`.
    base: [Quat; CHAIN_JOINTS],
}

impl Frames {
    #[inline]
    fn new(chain: &LimbChain, pose: &ChainPose) -> Self {
        let mut f = Frames {
            pos: [Vec3A::ZERO; 5],
            rot: [Quat::IDENTITY; CHAIN_JOINTS],
            base: [Quat::IDENTITY; CHAIN_JOINTS],
        };
        f.pos[0] = chain.offsets[0];
        f.update_from(chain, pose, 0);
        f
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
            self.base[i] = parent_rot * chain.rest[i];
            self.rot[i] = self.base[i] * pose.0[i];
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
/// validated (no checks): CCD sweeps, then the smoothness guard.
///
/// Smoothness guard: near full extension of the elbow/knee the reach step puts all of
/// a small radial target move on that one hinge (0.18 rad for 5 mm at a 14° bend). When
/// a warm start (target within [`SMOOTH_TRIGGER_DIST`] of the effector) moved some joint
/// by more than [`SMOOTH_JOINT_STEP`], the solve is redone from the warm start by the
/// damped least squares of [`refine`], whose minimum-norm steps spread the move over all
/// joints; its pose is kept if it reaches and moves the joints less.
#[inline]
fn solve_local(
    chain: &LimbChain,
    target: Vec3A,
    pose: &mut ChainPose,
    params: &CcdParams,
) -> CcdResult {
    let start = *pose;
    let (result, start_err) = ccd_sweeps(chain, target, pose, params);
    if result.iterations == 0
        || !params.refine
        || start_err > SMOOTH_TRIGGER_DIST
        || max_joint_cos_half(&start, pose) >= SMOOTH_COS_HALF
    {
        return result;
    }
    smooth_retry(chain, target, &start, pose, params, result)
}

/// Target moves up to this far (metres) count as frame-to-frame tracking.
pub const SMOOTH_TRIGGER_DIST: f32 = 0.02;
/// Joint change per solve (radians) above which a tracking solve is redone smoothly.
pub const SMOOTH_JOINT_STEP: f32 = 0.1;
/// `cos(SMOOTH_JOINT_STEP / 2)`.
const SMOOTH_COS_HALF: f32 = 0.998_750_26;

/// Smallest `|a_i · b_i|` over the joints: the cosine of half the largest joint change.
#[inline]
fn max_joint_cos_half(a: &ChainPose, b: &ChainPose) -> f32 {
    (0..CHAIN_JOINTS)
        .map(|i| a.0[i].dot(b.0[i]).abs())
        .fold(1.0, f32::min)
}

#[cold]
fn smooth_retry(
    chain: &LimbChain,
    target: Vec3A,
    start: &ChainPose,
    pose: &mut ChainPose,
    params: &CcdParams,
    result: CcdResult,
) -> CcdResult {
    let mut alt = *start;
    let r = refine::refine(
        chain,
        target,
        &mut alt,
        params.tolerance,
        params.max_iterations,
    );
    if r.error <= params.tolerance.max(result.error)
        && max_joint_cos_half(start, &alt) > max_joint_cos_half(start, pose)
    {
        *pose = alt;
        return CcdResult {
            reached: r.error <= params.tolerance,
            error: r.error,
            iterations: result.iterations + r.iterations,
            status: if r.error <= params.tolerance {
                CcdStatus::Reached
            } else {
                result.status
            },
        };
    }
    CcdResult {
        iterations: result.iterations + r.iterations,
        ..result
    }
}

/// The CCD sweeps (and the stall polish). Returns the result and the starting error.
///
/// Tail-first sweeps update only the effector after each step: a step on joint `j`
/// moves nothing above it, and the next step (joint `j-1`) needs only joint `j-1`'s own
/// frame, joint 1's position and the effector. The full FK is redone once per sweep.
#[inline]
fn ccd_sweeps(
    chain: &LimbChain,
    target: Vec3A,
    pose: &mut ChainPose,
    params: &CcdParams,
) -> (CcdResult, f32) {
    let mut frames = Frames::new(chain, pose);
    let tol_sq = params.tolerance * params.tolerance;
    let mut err_sq = frames.pos[4].distance_squared(target);
    let start_err = err_sq.sqrt();
    if err_sq <= tol_sq {
        let r = CcdResult {
            reached: true,
            error: start_err,
            iterations: 0,
            status: CcdStatus::Reached,
        };
        return (r, start_err);
    }
    let cap = StepCap::new(params.max_step_angle);
    let tail_first = params.order == CcdOrder::TailFirst;
    let mut prev_err = start_err;
    let mut reach_step = params.reach_step;
    let mut frames_stale = false;
    let mut mid_saturated = false;
    for iter in 0..params.max_iterations {
        if frames_stale {
            frames = Frames::new(chain, pose);
            frames_stale = false;
        }
        let sweep_start = *pose;
        for k in 0..CHAIN_JOINTS {
            let j = if tail_first { CHAIN_JOINTS - 1 - k } else { k };
            let Some((q, eff_ls)) = step_joint(
                chain,
                &frames,
                pose.0[j],
                j,
                target,
                &cap,
                reach_step,
                &mut mid_saturated,
            ) else {
                continue;
            };
            pose.0[j] = q;
            if tail_first {
                frames.pos[4] = frames.pos[j] + (frames.base[j] * q) * eff_ls;
                frames_stale = true;
            } else {
                frames.update_from(chain, pose, j);
            }
            err_sq = frames.pos[4].distance_squared(target);
            if err_sq <= tol_sq {
                let r = CcdResult {
                    reached: true,
                    error: err_sq.sqrt(),
                    iterations: iter + 1,
                    status: CcdStatus::Reached,
                };
                return (r, start_err);
            }
        }
        let err = err_sq.sqrt();
        if prev_err - err < params.min_improvement {
            // A sweep is kept only if it improved the error by `min_improvement`:
            // undo it, so an already-settled pose stays exactly where it was and
            // unreachable targets do not jitter from frame to frame.
            *pose = sweep_start;
            frames_stale = true;
            err_sq = prev_err * prev_err;
            if reach_step {
                // Reach steps stopped helping (a limit blocks them): go on with plain
                // aiming CCD from the same pose.
                reach_step = false;
                continue;
            }
            let r = polish(
                chain,
                target,
                pose,
                params,
                prev_err,
                iter + 1,
                CcdStatus::Stalled,
            );
            return (r, start_err);
        }
        prev_err = err;
    }
    let err = err_sq.sqrt();
    let r = polish(
        chain,
        target,
        pose,
        params,
        err,
        params.max_iterations,
        CcdStatus::MaxIterations,
    );
    (r, start_err)
}

/// CCD stopped short of the target (`error` > tolerance): if the target is within the
/// chain's reach, polish with the limit-aware damped least squares of [`refine`]
/// (CCD gets trapped where several joints sit at limits at once). `status` is what to
/// report if the polish does not reach either.
#[cold]
fn polish(
    chain: &LimbChain,
    target: Vec3A,
    pose: &mut ChainPose,
    params: &CcdParams,
    error: f32,
    iterations: u32,
    status: CcdStatus,
) -> CcdResult {
    let mut result = CcdResult {
        reached: false,
        error,
        iterations,
        status,
    };
    if !params.refine || target.distance(chain.offsets[0]) > chain.reach() + params.tolerance {
        return result;
    }
    let r = refine::refine(chain, target, pose, params.tolerance, params.max_iterations);
    result.iterations += r.iterations;
    result.error = r.error;
    if r.error <= params.tolerance {
        result.reached = true;
        result.status = CcdStatus::Reached;
    }
    result
}

/// The per-step rotation cap as cos (full angle) and cos/sin (half angle): no trig in the steps.
struct StepCap {
    cos: f32,
    cos_half: f32,
    sin_half: f32,
}

impl StepCap {
    #[inline]
    fn new(max_angle: f32) -> Self {
        let (sin_half, cos_half) = half_sin_cos(max_angle);
        Self {
            cos: cos_half * cos_half - sin_half * sin_half,
            cos_half,
            sin_half,
        }
    }

    /// Cap a rotation given as `(cos δ, sin δ)` (unit) at the step angle and return its
    /// half-angle `(cos δ/2 ≥ 0, sin δ/2)`.
    #[inline]
    fn capped_half(&self, cos: f32, sin: f32) -> (f32, f32) {
        if cos < self.cos {
            return (self.cos_half, self.sin_half.copysign(sin));
        }
        let c = (0.5 * (1.0 + cos)).max(0.0).sqrt();
        let s = (0.5 * (1.0 - cos)).max(0.0).sqrt().copysign(sin);
        (c, s)
    }
}

/// One CCD step on joint `j` from the current `frames` (joint `j`'s frame, joint 1 and
/// the effector must be up to date). Returns the new pose rotation of joint `j` and the
/// effector in joint `j`'s (old) posed frame, or `None` when nothing changes.
#[allow(clippy::too_many_arguments)]
#[inline]
fn step_joint(
    chain: &LimbChain,
    frames: &Frames,
    q: Quat,
    j: usize,
    target: Vec3A,
    cap: &StepCap,
    reach_step: bool,
    mid_saturated: &mut bool,
) -> Option<(Quat, Vec3A)> {
    let joint_pos = frames.pos[j];
    let inv_rot = frames.rot[j].inverse();
    // Effector and target in joint j's own (posed) frame.
    let eff_ls = inv_rot * (frames.pos[4] - joint_pos);
    let limit = chain.limits[j];
    if reach_step && j == 0 && *mid_saturated && matches!(limit, JointLimit::Ball { .. }) {
        // Girdle reach: move the proximal joint (on its sphere about the girdle) to a
        // point as far from the target as the effector is from it now.
        let b_ls = inv_rot * (frames.pos[1] - joint_pos);
        let d_ls = inv_rot * (target - joint_pos);
        let s = (frames.pos[4] - frames.pos[1]).length();
        let delta = ball_reach_step(b_ls, d_ls, s, cap)?;
        return Some((limit.clamp(q * delta), eff_ls));
    }
    if reach_step
        && j == 2
        && let JointLimit::Hinge { axis, min, max } = limit
    {
        let ref_ls = inv_rot * (frames.pos[1] - joint_pos);
        let want = (target - frames.pos[1]).length();
        let (step, saturated) = reach_hinge_step(q, axis, min, max, eff_ls, ref_ls, want, cap);
        *mid_saturated = saturated;
        return step.map(|q| (q, eff_ls));
    }
    let target_ls = inv_rot * (target - joint_pos);
    let new_q = match limit {
        JointLimit::Hinge { axis, min, max } => {
            hinge_step(q, axis, min, max, eff_ls, target_ls, cap)?
        }
        limit => limit.clamp(q * arc_step(eff_ls, target_ls, cap)?),
    };
    Some((new_q, eff_ls))
}

/// Rotate the hinge half-angle `(w, p)` by a delta half-angle `(c, s)`, clamp into the
/// limits; `None` if the result equals the current angle (pinned at a limit).
#[inline]
fn turn_hinge(
    axis: Vec3A,
    (w, p): (f32, f32),
    (c, s): (f32, f32),
    min: f32,
    max: f32,
) -> (Option<Quat>, bool) {
    let (w1, p1) = (w * c - p * s, w * s + p * c);
    let (w2, p2, clamped) = clamp_hinge_half(w1, p1, min, max);
    if (w2 - w).abs() <= 1e-9 && (p2 - p).abs() <= 1e-9 {
        return (None, clamped);
    }
    (Some(hinge_quat(axis, w2, p2)), clamped)
}

/// Hinge step: the best rotation about `axis` (which is the same vector in the posed
/// and rest frames) bringing `eff_ls` toward `target_ls`, capped and clamped. Works on
/// half-angle unit complex numbers: no trig.
#[inline]
fn hinge_step(
    q: Quat,
    axis: Vec3A,
    min: f32,
    max: f32,
    eff_ls: Vec3A,
    target_ls: Vec3A,
    cap: &StepCap,
) -> Option<Quat> {
    let e = eff_ls - axis * axis.dot(eff_ls);
    let t = target_ls - axis * axis.dot(target_ls);
    let ee = e.length_squared();
    let tt = t.length_squared();
    if ee < 1e-14 || tt < 1e-14 {
        return None;
    }
    let inv = (ee * tt).sqrt().recip();
    let cos = (e.dot(t) * inv).clamp(-1.0, 1.0);
    let sin = axis.dot(e.cross(t)) * inv;
    let half = cap.capped_half(cos, sin);
    turn_hinge(axis, hinge_half(q, axis), half, min, max).0
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
    // Half-angle formulas: no trig.
    let (c, s) = cap.capped_half(cos, 1.0);
    let v = axis * s;
    Some(Quat::from_xyzw(v.x, v.y, v.z, c))
}

/// Reach step for a hinge: the angle change about `axis` that makes the effector's
/// distance to the reference point `ref_ls` (the proximal joint) equal `want`, nearest
/// to the current angle, capped and clamped. Returns the new rotation (if it changes)
/// and whether the wanted distance could not be set (out of range or limit hit).
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
    cap: &StepCap,
) -> (Option<Quat>, bool) {
    // |e(φ) − r|² = |e|² + |r|² − 2 (e_a·r_a + |e⊥||r⊥| cos(φ − φ0)), φ = rotation of e⊥.
    let ea = axis.dot(eff_ls);
    let ra = axis.dot(ref_ls);
    let e = eff_ls - axis * ea;
    let r = ref_ls - axis * ra;
    let ee = e.length_squared();
    let rr = r.length_squared();
    if ee < 1e-14 || rr < 1e-14 {
        return (None, false);
    }
    let elrl = (ee * rr).sqrt();
    let k = eff_ls.length_squared() + ref_ls.length_squared() - 2.0 * ea * ra;
    // want² = k − 2 el rl cos(ψ), ψ = angle from e⊥ to r⊥ after rotating e by δ
    let cos_raw = (k - want * want) / (2.0 * elrl);
    let cos_psi = cos_raw.clamp(-1.0, 1.0);
    let sin_psi = (1.0 - cos_psi * cos_psi).max(0.0).sqrt();
    // current signed angle `cur` from e⊥ to r⊥ about axis, as (cos, sin)
    let inv = elrl.recip();
    let (cc, sc) = (e.dot(r) * inv, axis.dot(e.cross(r)) * inv);
    // rotating e by δ changes the angle to r by −δ: need cur − δ = ±ψ, δ = cur ∓ ψ
    // (complex products give δ wrapped into (−π, π]).
    let d1 = (cc * cos_psi + sc * sin_psi, sc * cos_psi - cc * sin_psi);
    let d2 = (cc * cos_psi - sc * sin_psi, sc * cos_psi + cc * sin_psi);
    let current = hinge_half(q, axis);
    // Of the two hinge angles giving that distance, prefer one inside the limits (or the
    // less outside, measured on sin θ/2), then the smaller change (larger cos δ).
    let (s_min, _) = half_sin_cos(min);
    let (s_max, _) = half_sin_cos(max);
    let score = |(c, s): (f32, f32)| {
        let (hc, hs) = (
            (0.5 * (1.0 + c)).max(0.0).sqrt(),
            (0.5 * (1.0 - c)).max(0.0).sqrt().copysign(s),
        );
        let (w1, p1) = (
            current.0 * hc - current.1 * hs,
            current.0 * hs + current.1 * hc,
        );
        let outside = if w1 < 0.0 {
            2.0 + w1.abs()
        } else {
            (s_min - p1).max(p1 - s_max).max(0.0)
        };
        (outside, -c)
    };
    let (cos_d, sin_d) = if score(d1) <= score(d2) { d1 } else { d2 };
    let (step, clamped) = turn_hinge(axis, current, cap.capped_half(cos_d, sin_d), min, max);
    (step, cos_raw.abs() > 1.0 || clamped)
}

/// Reach step for the girdle ball joint: the smallest rotation of `b_ls` (proximal joint
/// relative to the girdle) that puts its end at distance `s` from `d_ls` (the target),
/// capped. `None` when nothing needs to (or can) change.
#[inline]
fn ball_reach_step(b_ls: Vec3A, d_ls: Vec3A, s: f32, cap: &StepCap) -> Option<Quat> {
    let ll = b_ls.length_squared();
    let dd = d_ls.length_squared();
    if ll < 1e-14 || dd < 1e-14 {
        return None;
    }
    let ld = (ll * dd).sqrt();
    let cos_want = ((ll + dd - s * s) / (2.0 * ld)).clamp(-1.0, 1.0);
    let sin_want = (1.0 - cos_want * cos_want).max(0.0).sqrt();
    let axis = b_ls.cross(d_ls);
    let axis_len = axis.length();
    if axis_len < 1e-9 {
        return None;
    }
    // now = angle(b, d) ∈ [0, π]; δ = now − want
    let (cos_now, sin_now) = (b_ls.dot(d_ls) / ld, axis_len / ld);
    let cos_d = (cos_now * cos_want + sin_now * sin_want).clamp(-1.0, 1.0);
    let sin_d = sin_now * cos_want - cos_now * sin_want;
    if sin_d.abs() < 1e-7 && cos_d > 0.0 {
        return None;
    }
    let (c, s) = cap.capped_half(cos_d, sin_d);
    let v = axis * (s / axis_len);
    Some(Quat::from_xyzw(v.x, v.y, v.z, c))
}
