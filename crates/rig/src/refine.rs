//! Limit-aware damped least squares ("projected Levenberg–Marquardt"): the fallback the
//! CCD solver uses when its sweeps stall short of a target that may still be reachable.
//!
//! CCD moves one joint at a time; near a corner of the limit box (two or more joints
//! pinned at limits) every single-joint move is blocked or undone by a clamp, and the
//! sweeps stall ~1 mm short of a reachable target. This stage moves all joints at once.
//!
//! Coordinates make the limits simple sets: a ball joint is `swing * twist` with the
//! swing as a rotation vector `(s1, s2)` in the plane normal to the twist axis (limit:
//! the disk `|s| ≤ swing_max`) and the twist angle `t` (limit: an interval); a hinge is
//! its angle (an interval). Each iteration: numeric Jacobian of the effector (8 forward
//! kinematics), an active set (a coordinate at a bound whose gradient points outward is
//! frozen; a swing on its disk rim loses its outward radial part), a damped step
//! `dx = Jᵀ (J Jᵀ + λ² I)⁻¹ e`, projection back into the limits. A step is kept only if
//! it reduces the error (so the error never grows and a settled pose is a fixed point);
//! otherwise λ grows, and the stage stops when λ is huge (no descent left).

use crate::unit::UnitOr;
use glam::{Mat3, Quat, Vec3, Vec3A};

use crate::chain::{CHAIN_JOINTS, ChainPose, LimbChain};
use crate::limits::JointLimit;

/// Finite-difference step (radians).
const H: f32 = 1e-3;

/// A joint's coordinates and limits.
#[derive(Clone, Copy)]
enum Coords {
    Hinge {
        axis: Vec3A,
        min: f32,
        max: f32,
    },
    Ball {
        axis: Vec3A,
        b1: Vec3A,
        b2: Vec3A,
        swing_max: f32,
        twist_min: f32,
        twist_max: f32,
    },
}

impl Coords {
    fn new(limit: &JointLimit) -> Self {
        let ball = |axis: Vec3A, swing_max, twist_min, twist_max| {
            let (b1, b2) = axis.any_orthonormal_pair();
            Coords::Ball {
                axis,
                b1,
                b2,
                swing_max,
                twist_min,
                twist_max,
            }
        };
        match *limit {
            JointLimit::Hinge { axis, min, max } => Coords::Hinge { axis, min, max },
            JointLimit::Ball {
                twist_axis,
                swing_max,
                twist_min,
                twist_max,
            } => ball(twist_axis, swing_max, twist_min, twist_max),
            JointLimit::Free => ball(Vec3A::Y, std::f32::consts::PI, -1e30, 1e30),
        }
    }

    /// Number of coordinates (1 or 3).
    fn dof(&self) -> usize {
        match self {
            Coords::Hinge { .. } => 1,
            Coords::Ball { .. } => 3,
        }
    }

    fn coords_of(&self, q: Quat) -> [f32; 3] {
        let q = if q.w < 0.0 { -q } else { q };
        let v = Vec3A::new(q.x, q.y, q.z);
        match *self {
            Coords::Hinge { axis, .. } => [2.0 * v.dot(axis).atan2(q.w), 0.0, 0.0],
            Coords::Ball { axis, b1, b2, .. } => {
                let p = v.dot(axis);
                let len = (p * p + q.w * q.w).sqrt();
                if len < 1e-9 {
                    let s = v.unit_or_zero() * std::f32::consts::PI;
                    return [s.dot(b1), s.dot(b2), 0.0];
                }
                let t = 2.0 * p.atan2(q.w);
                let twist = axis_angle(axis, t);
                let swing = q * twist.conjugate();
                let sv = Vec3A::new(swing.x, swing.y, swing.z);
                let sl = sv.length();
                let s = if sl > 1e-12 {
                    sv * (2.0 * sl.atan2(swing.w) / sl)
                } else {
                    Vec3A::ZERO
                };
                [s.dot(b1), s.dot(b2), t]
            }
        }
    }

    fn quat_of(&self, x: [f32; 3]) -> Quat {
        self.compose(self.factors(x))
    }

    /// The rotation of its [`Coords::factors`].
    fn compose(&self, (a, b): (Quat, Quat)) -> Quat {
        match *self {
            Coords::Hinge { .. } => a,
            Coords::Ball { .. } => a * b,
        }
    }

    /// The factors of [`Coords::quat_of`]: a ball joint's swing (of `x[0]`,
    /// `x[1]`) and twist (of `x[2]`), whose product it is; a hinge's rotation
    /// (and the identity, unused).
    fn factors(&self, x: [f32; 3]) -> (Quat, Quat) {
        match *self {
            Coords::Hinge { axis, .. } => (axis_angle(axis, x[0]), Quat::IDENTITY),
            Coords::Ball { axis, .. } => (self.swing_of(x), axis_angle(axis, x[2])),
        }
    }

    /// A ball joint's swing factor (of `x[0]`, `x[1]`; a hinge: unused).
    fn swing_of(&self, x: [f32; 3]) -> Quat {
        match *self {
            Coords::Hinge { .. } => Quat::IDENTITY,
            Coords::Ball { b1, b2, .. } => {
                let s = b1 * x[0] + b2 * x[1];
                let a = s.length();
                if a > 1e-12 {
                    axis_angle(s / a, a)
                } else {
                    Quat::IDENTITY
                }
            }
        }
    }

    /// [`Coords::quat_of`] of `x` moved by `h` in coordinate `k` from `base`, whose
    /// factors are `parts` ([`Coords::factors`]): the same quaternion, but a ball
    /// joint recomputes only the factor that coordinate changes.
    fn quat_of_moved(&self, base: [f32; 3], parts: (Quat, Quat), k: usize, h: f32) -> Quat {
        let mut x = base;
        x[k] += h;
        match *self {
            Coords::Hinge { .. } => self.quat_of(x),
            Coords::Ball { axis, .. } if k == 2 => parts.0 * axis_angle(axis, x[2]),
            Coords::Ball { .. } => self.swing_of(x) * parts.1,
        }
    }

    fn project(&self, x: &mut [f32; 3]) {
        match *self {
            Coords::Hinge { min, max, .. } => x[0] = x[0].clamp(min, max),
            Coords::Ball {
                swing_max,
                twist_min,
                twist_max,
                ..
            } => {
                let a = (x[0] * x[0] + x[1] * x[1]).sqrt();
                if a > swing_max {
                    x[0] *= swing_max / a;
                    x[1] *= swing_max / a;
                }
                x[2] = x[2].clamp(twist_min, twist_max);
            }
        }
    }
}

fn axis_angle(axis: Vec3A, angle: f32) -> Quat {
    Quat::from_axis_angle(Vec3::from(axis), angle)
}

/// Forward kinematics of `q` (joint positions, effector last, and rotations).
type Fk = ([Vec3A; 5], [Quat; CHAIN_JOINTS]);

fn fk(chain: &LimbChain, q: &[Quat; CHAIN_JOINTS]) -> Fk {
    chain.fk_local(&ChainPose(*q))
}

/// The effector of `q` with joint `j` turned to `qj` instead, from `fk` (the forward
/// kinematics of `q`): the joints above `j` are where `fk` has them, so only the chain
/// from `j` on is recomputed, with [`LimbChain::fk_local`]'s operations in its order
/// (the same bits as the full forward kinematics).
fn effector_moved(
    chain: &LimbChain,
    fk: &Fk,
    q: &[Quat; CHAIN_JOINTS],
    j: usize,
    qj: Quat,
) -> Vec3A {
    let (pos, rot) = fk;
    let parent = if j == 0 { Quat::IDENTITY } else { rot[j - 1] };
    let mut parent_rot = parent * chain.rest[j] * qj;
    let mut parent_pos = pos[j];
    // Indexed: three arrays in step (an iterator chain of `zip`s and `skip`
    // compiled to 9 % more instructions in the polish).
    #[allow(clippy::needless_range_loop)]
    for i in j + 1..CHAIN_JOINTS {
        let p = parent_pos + parent_rot * chain.offsets[i];
        parent_rot = parent_rot * chain.rest[i] * q[i];
        parent_pos = p;
    }
    parent_pos + parent_rot * chain.effector
}

/// Outcome of [`refine`].
pub(crate) struct Refined {
    /// Final effector–target distance (metres).
    pub error: f32,
    /// Iterations (Jacobian evaluations).
    pub iterations: u32,
}

avx2_dispatch! {
    /// Polish `pose` toward `target` (chain-root frame) within the limits, up to
    /// `max_iterations` Jacobians or until within `tolerance`. The pose is replaced
    /// only if the error went down. Runs [`refine_impl`] in its AVX2 build where
    /// the CPU has AVX2.
    pub(crate) fn refine / refine_avx2(
        chain: &LimbChain,
        target: Vec3A,
        pose: &mut ChainPose,
        tolerance: f32,
        max_iterations: u32,
    ) -> Refined => refine_impl;
}

/// [`refine`] for any CPU.
#[inline(always)]
fn refine_impl(
    chain: &LimbChain,
    target: Vec3A,
    pose: &mut ChainPose,
    tolerance: f32,
    max_iterations: u32,
) -> Refined {
    let coords: [Coords; CHAIN_JOINTS] = std::array::from_fn(|j| Coords::new(&chain.limits[j]));
    let mut x: [[f32; 3]; CHAIN_JOINTS] = std::array::from_fn(|j| {
        let mut x = coords[j].coords_of(pose.0[j]);
        coords[j].project(&mut x);
        x
    });
    let mut parts: [(Quat, Quat); CHAIN_JOINTS] = std::array::from_fn(|j| coords[j].factors(x[j]));
    let mut q: [Quat; CHAIN_JOINTS] = std::array::from_fn(|j| coords[j].compose(parts[j]));
    let start_err = chain.fk_local(pose).0[4].distance(target);
    let mut fk_q = fk(chain, &q);
    let mut eff = fk_q.0[4];
    let mut err = eff.distance(target);
    let mut lambda2 = 1e-4f32;
    let mut iterations = 0;
    while iterations < max_iterations && err > tolerance {
        iterations += 1;
        let e = target - eff;
        // Jacobian columns (3 per joint; unused / frozen ones stay zero).
        let mut cols = [Vec3A::ZERO; 3 * CHAIN_JOINTS];
        for j in 0..CHAIN_JOINTS {
            for k in 0..coords[j].dof() {
                let qj = coords[j].quat_of_moved(x[j], parts[j], k, H);
                cols[3 * j + k] = (effector_moved(chain, &fk_q, &q, j, qj) - eff) * (1.0 / H);
            }
            // Active set: coordinates at a bound whose descent direction points out.
            match coords[j] {
                Coords::Hinge { min, max, .. } => {
                    freeze_at_bound(&mut cols[3 * j], x[j][0], min, max, e);
                }
                Coords::Ball {
                    swing_max,
                    twist_min,
                    twist_max,
                    ..
                } => {
                    let (s1, s2) = (x[j][0], x[j][1]);
                    let a = (s1 * s1 + s2 * s2).sqrt();
                    if a >= swing_max * (1.0 - 1e-4) && a > 0.0 {
                        let (n1, n2) = (s1 / a, s2 / a);
                        let (c1, c2) = (cols[3 * j], cols[3 * j + 1]);
                        let radial = c1 * n1 + c2 * n2;
                        if radial.dot(e) > 0.0 {
                            cols[3 * j] = c1 - radial * n1;
                            cols[3 * j + 1] = c2 - radial * n2;
                        }
                    }
                    freeze_at_bound(&mut cols[3 * j + 2], x[j][2], twist_min, twist_max, e);
                }
            }
        }
        let jjt = cols.iter().fold(Mat3::ZERO, |m, c| {
            let c = Vec3::from(*c);
            m + Mat3::from_cols(c * c.x, c * c.y, c * c.z)
        });
        let mut improved = false;
        while lambda2 < 1e2 {
            let m = jjt + Mat3::from_diagonal(Vec3::splat(lambda2));
            let y = Vec3A::from(m.inverse() * Vec3::from(e));
            let mut x1 = x;
            for j in 0..CHAIN_JOINTS {
                for k in 0..coords[j].dof() {
                    x1[j][k] += cols[3 * j + k].dot(y);
                }
                coords[j].project(&mut x1[j]);
            }
            let parts1: [(Quat, Quat); CHAIN_JOINTS] =
                std::array::from_fn(|j| coords[j].factors(x1[j]));
            let q1: [Quat; CHAIN_JOINTS] = std::array::from_fn(|j| coords[j].compose(parts1[j]));
            let fk1 = fk(chain, &q1);
            let eff1 = fk1.0[4];
            let err1 = eff1.distance(target);
            if err1 < err - 1e-7 {
                (x, q, eff, err) = (x1, q1, eff1, err1);
                (parts, fk_q) = (parts1, fk1);
                lambda2 = (lambda2 * 0.25).max(1e-6);
                improved = true;
                break;
            }
            lambda2 *= 8.0;
        }
        if !improved {
            break;
        }
    }
    if err < start_err {
        *pose = ChainPose(q);
        Refined {
            error: err,
            iterations,
        }
    } else {
        Refined {
            error: start_err,
            iterations,
        }
    }
}

/// Zero the Jacobian column of an interval coordinate sitting at a bound when the
/// error-reducing direction (`col · e` > 0 increases it) points outside.
fn freeze_at_bound(col: &mut Vec3A, x: f32, min: f32, max: f32, e: Vec3A) {
    let g = col.dot(e);
    let eps = 1e-5;
    if (x >= max - eps && g > 0.0) || (x <= min + eps && g < 0.0) {
        *col = Vec3A::ZERO;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rig;

    /// The Jacobian's shortcuts give exactly the straightforward values: a joint's
    /// moved rotation from the factor its coordinate changes, and the effector from
    /// the moved joint on (the forward kinematics of the joints above it kept).
    #[test]
    fn jacobian_shortcuts_are_bit_identical() {
        let rig = Rig::sloth();
        let mut rnd = crate::test_rng::uniform(0x1ac0_u64);
        for chain in rig.chains() {
            let coords: [Coords; CHAIN_JOINTS] =
                std::array::from_fn(|j| Coords::new(&chain.limits[j]));
            for _ in 0..2000 {
                let u: [f32; 12] = std::array::from_fn(|_| rnd());
                let pose = chain.sample_pose(&u);
                let x: [[f32; 3]; CHAIN_JOINTS] =
                    std::array::from_fn(|j| coords[j].coords_of(pose.0[j]));
                let q: [Quat; CHAIN_JOINTS] = std::array::from_fn(|j| coords[j].quat_of(x[j]));
                let fk_q = fk(chain, &q);
                for j in 0..CHAIN_JOINTS {
                    let parts = coords[j].factors(x[j]);
                    for k in 0..coords[j].dof() {
                        let mut xj = x[j];
                        xj[k] += H;
                        let mut qq = q;
                        qq[j] = coords[j].quat_of(xj);
                        let qj = coords[j].quat_of_moved(x[j], parts, k, H);
                        assert_eq!(
                            qj.to_array().map(f32::to_bits),
                            qq[j].to_array().map(f32::to_bits)
                        );
                        let want = fk(chain, &qq).0[4];
                        let got = effector_moved(chain, &fk_q, &q, j, qj);
                        assert_eq!(
                            got.to_array().map(f32::to_bits),
                            want.to_array().map(f32::to_bits)
                        );
                    }
                }
            }
        }
    }

    /// The AVX2 build of the polish gives the baseline build's result bit for bit,
    /// from random poses toward targets near, at and beyond the limits and the reach.
    #[test]
    fn avx2_dispatch_is_bit_identical() {
        let rig = Rig::sloth();
        let mut rnd = crate::test_rng::uniform(0x5eed_u64);
        for chain in rig.chains() {
            for k in 0..400 {
                let u: [f32; 12] = std::array::from_fn(|_| rnd());
                let v: [f32; 12] = std::array::from_fn(|_| rnd());
                let aim = chain.fk_local(&chain.sample_pose(&u)).0[4];
                let off =
                    Vec3A::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * (0.02 * (k % 5) as f32);
                let target = aim + off;
                let start = chain.sample_pose(&v);
                let (mut a, mut b) = (start, start);
                let ra = refine(chain, target, &mut a, 5e-4, 64);
                let rb = refine_impl(chain, target, &mut b, 5e-4, 64);
                assert_eq!(ra.error.to_bits(), rb.error.to_bits());
                assert_eq!(ra.iterations, rb.iterations);
                for j in 0..CHAIN_JOINTS {
                    assert_eq!(
                        a.0[j].to_array().map(f32::to_bits),
                        b.0[j].to_array().map(f32::to_bits)
                    );
                }
            }
        }
    }
}
