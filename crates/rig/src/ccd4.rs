//! Four limb solves at once, one per SIMD lane: [`solve4`].
//!
//! The scalar solver ([`crate::ccd::solve`]) is a chain of dependent square roots,
//! divisions and short vector products (each step needs the effector the previous one
//! moved), so a single solve leaves most of the CPU idle. The four limbs of an animal
//! are independent: here lane `i` of every `Vec4` carries limb `i`, and the same
//! instructions advance all four chains.
//!
//! **Bit-identical to [`crate::ccd::solve`]**, lane by lane: every lane performs the
//! scalar solver's IEEE operations in the same order (the vector/quaternion helpers
//! below spell out `glam`'s SSE2 formulas component by component; multiplying by
//! `±1.0` and swapping the operands of `+`/`*` are exact). Only the common path is
//! vectorised: the sloth's joint layout (girdle and shoulder/hip swing–twist balls,
//! elbow/knee and wrist/ankle hinges), tail-first sweeps with the reach step, steps
//! whose ball clamp did not act, and solves that reach the tolerance. A lane that
//! leaves that path (a sweep that does not improve, a ball joint clamped, a hinge
//! warm start with an off-axis part, the smoothness guard or the stall polish, the
//! sweep limit) is finished by the scalar solver, which is deterministic, so its
//! result is exactly the scalar one as well: from the point the scalar solve would
//! be at where that point is a state the vector path holds too (a stalled sweep:
//! from the pose before it, reach steps off; out of sweeps: the polish; the
//! smoothness guard: its retry), else again from its start pose. Other chain
//! layouts or parameters go through the scalar solver limb by limb.

use glam::{BVec4A, Mat4, Quat, Vec3, Vec3A, Vec4};

use crate::ccd::{
    CcdOrder, CcdParams, CcdResult, CcdStatus, SMOOTH_COS_HALF, SMOOTH_TRIGGER_DIST, StepCap,
    SweepFrom, resume_local_dispatch, smooth_guard_dispatch, solve_local_dispatch,
};
use crate::chain::{CHAIN_JOINTS, ChainPose, LimbChain, RootTransform};
use crate::limits::{JointLimit, half_sin_cos4};

type F = Vec4;
type M = BVec4A;

#[inline(always)]
fn splat(x: f32) -> F {
    F::splat(x)
}

#[inline(always)]
fn sel(m: M, a: F, b: F) -> F {
    F::select(m, a, b)
}

/// Lane-wise IEEE square root (as `f32::sqrt`).
#[inline(always)]
fn sqrt(x: F) -> F {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { F::from(std::arch::x86_64::_mm_sqrt_ps(x.into())) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        F::from_array(x.to_array().map(f32::sqrt))
    }
}

/// `1.0 / x` lane-wise (as `f32::recip`).
#[inline(always)]
fn recip(x: F) -> F {
    F::ONE / x
}

/// `x.clamp(-1.0, 1.0)` lane-wise, as `f32::clamp` (NaN stays NaN, unlike
/// `Vec4::clamp`).
#[inline(always)]
fn clamp1(x: F) -> F {
    let x = sel(x.cmplt(splat(-1.0)), splat(-1.0), x);
    sel(x.cmpgt(F::ONE), F::ONE, x)
}

/// `(a == b) ? c : d` on masks.
#[inline(always)]
fn msel(m: M, a: M, b: M) -> M {
    (m & a) | (!m & b)
}

/// Four 3-vectors, one per lane.
#[derive(Clone, Copy, Debug)]
struct V {
    x: F,
    y: F,
    z: F,
}

impl V {
    const ZERO: V = V {
        x: F::ZERO,
        y: F::ZERO,
        z: F::ZERO,
    };

    /// Transpose: lane `i` gets `v[i]`.
    #[inline(always)]
    fn gather(a: Vec3A, b: Vec3A, c: Vec3A, d: Vec3A) -> V {
        let m =
            Mat4::from_cols(a.extend(0.0), b.extend(0.0), c.extend(0.0), d.extend(0.0)).transpose();
        V {
            x: m.x_axis,
            y: m.y_axis,
            z: m.z_axis,
        }
    }

    /// Transpose back: the four lanes' vectors.
    #[inline(always)]
    fn scatter(self) -> [Vec3A; 4] {
        let m = Mat4::from_cols(self.x, self.y, self.z, F::ZERO).transpose();
        [m.x_axis, m.y_axis, m.z_axis, m.w_axis].map(Vec3A::from_vec4)
    }

    #[inline(always)]
    fn add(self, o: V) -> V {
        V {
            x: self.x + o.x,
            y: self.y + o.y,
            z: self.z + o.z,
        }
    }

    #[inline(always)]
    fn sub(self, o: V) -> V {
        V {
            x: self.x - o.x,
            y: self.y - o.y,
            z: self.z - o.z,
        }
    }

    #[inline(always)]
    fn scale(self, s: F) -> V {
        V {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }

    #[inline(always)]
    fn div(self, s: F) -> V {
        V {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }

    /// `glam`'s `dot3`: `(x·x' + y·y') + z·z'`.
    #[inline(always)]
    fn dot(self, o: V) -> F {
        (self.x * o.x + self.y * o.y) + self.z * o.z
    }

    /// `glam`'s `Vec3A::cross` (same products and differences).
    #[inline(always)]
    fn cross(self, o: V) -> V {
        V {
            x: self.y * o.z - self.z * o.y,
            y: self.z * o.x - self.x * o.z,
            z: self.x * o.y - self.y * o.x,
        }
    }

    #[inline(always)]
    fn length_squared(self) -> F {
        self.dot(self)
    }

    #[inline(always)]
    fn select(m: M, a: V, b: V) -> V {
        V {
            x: sel(m, a.x, b.x),
            y: sel(m, a.y, b.y),
            z: sel(m, a.z, b.z),
        }
    }
}

/// Four quaternions, one per lane.
#[derive(Clone, Copy, Debug)]
struct Q {
    x: F,
    y: F,
    z: F,
    w: F,
}

impl Q {
    const IDENTITY: Q = Q {
        x: F::ZERO,
        y: F::ZERO,
        z: F::ZERO,
        w: F::ONE,
    };

    /// Transpose: lane `i` gets `q[i]`.
    #[inline(always)]
    fn gather(a: Quat, b: Quat, c: Quat, d: Quat) -> Q {
        let m = Mat4::from_cols(a.into(), b.into(), c.into(), d.into()).transpose();
        Q {
            x: m.x_axis,
            y: m.y_axis,
            z: m.z_axis,
            w: m.w_axis,
        }
    }

    /// Transpose back: the four lanes' quaternions.
    #[inline(always)]
    fn scatter(self) -> [Quat; 4] {
        let m = Mat4::from_cols(self.x, self.y, self.z, self.w).transpose();
        [
            Quat::from_vec4(m.x_axis),
            Quat::from_vec4(m.y_axis),
            Quat::from_vec4(m.z_axis),
            Quat::from_vec4(m.w_axis),
        ]
    }

    #[inline(always)]
    fn xyz(self) -> V {
        V {
            x: self.x,
            y: self.y,
            z: self.z,
        }
    }

    #[inline(always)]
    fn select(m: M, a: Q, b: Q) -> Q {
        Q {
            x: sel(m, a.x, b.x),
            y: sel(m, a.y, b.y),
            z: sel(m, a.z, b.z),
            w: sel(m, a.w, b.w),
        }
    }

    /// `glam`'s SSE2 `Quat::mul_quat` (rtm's `quat_mul`), lane by lane: the two
    /// partial sums it adds, with its `±1` control multiplies written as negations.
    #[inline(always)]
    fn mul(self, r: Q) -> Q {
        let l = self;
        Q {
            x: (l.x * r.w + l.w * r.x) + (-(l.z * r.y) + l.y * r.z),
            y: (-(l.x * r.z) + l.w * r.y) + (l.z * r.x + l.y * r.w),
            z: (l.x * r.y + l.w * r.z) + (l.z * r.w + -(l.y * r.x)),
            w: (-(l.x * r.x) + l.w * r.w) + (-(l.z * r.z) + -(l.y * r.y)),
        }
    }

    /// `glam`'s SSE2 `Quat::mul_vec3a`:
    /// `(v (w² − b·b) + b (2 (v·b))) + (b × v) (2 w)`.
    #[inline(always)]
    fn rotate(self, v: V) -> V {
        let b = self.xyz();
        let b2 = b.dot(b);
        let k0 = self.w * self.w - b2;
        let k1 = v.dot(b) * splat(2.0);
        let k2 = self.w * splat(2.0);
        let c = b.cross(v);
        V {
            x: (v.x * k0 + b.x * k1) + c.x * k2,
            y: (v.y * k0 + b.y * k1) + c.y * k2,
            z: (v.z * k0 + b.z * k1) + c.z * k2,
        }
    }

    #[inline(always)]
    fn conjugate(self) -> Q {
        Q {
            x: -self.x,
            y: -self.y,
            z: -self.z,
            w: self.w,
        }
    }

    /// `glam`'s `dot4`: `(x·x' + z·z') + (y·y' + w·w')`.
    #[inline(always)]
    fn dot(self, o: Q) -> F {
        (self.x * o.x + self.z * o.z) + (self.y * o.y + self.w * o.w)
    }

    #[inline(always)]
    fn length_squared(self) -> F {
        self.dot(self)
    }
}

/// Half-angle range of a hinge or twist limit: `(cos, sin)` of `min/2` and `max/2`.
#[derive(Clone, Copy, Debug)]
struct Range4 {
    lo: (F, F),
    hi: (F, F),
}

/// The four chains, transposed, with their limits' half-angle trigonometry.
#[derive(Clone, Debug)]
struct Chains4 {
    offsets: [V; CHAIN_JOINTS],
    rest: [Q; CHAIN_JOINTS],
    effector: V,
    /// Twist axes (joints 0, 1) and hinge axes (joints 2, 3).
    axis: [V; CHAIN_JOINTS],
    /// Ball joints 0 and 1: `(cos, sin)` of half the largest swing.
    swing: [(F, F); 2],
    /// Twist ranges (joints 0, 1) and hinge ranges (joints 2, 3).
    range: [Range4; CHAIN_JOINTS],
}

impl Chains4 {
    /// `None` unless every chain has the sloth layout (ball, ball, hinge, hinge).
    #[inline(always)]
    fn new(chains: [&LimbChain; 4]) -> Option<Self> {
        // Per joint: (axis, a, b, swing) with (a, b) = (min, max) or (twist_min, twist_max).
        let mut axis = [[Vec3A::ZERO; 4]; CHAIN_JOINTS];
        let mut lo = [[0.0f32; 4]; CHAIN_JOINTS];
        let mut hi = [[0.0f32; 4]; CHAIN_JOINTS];
        let mut swing = [[0.0f32; 4]; 2];
        for (l, chain) in chains.iter().enumerate() {
            for j in 0..CHAIN_JOINTS {
                match (j, chain.limits[j]) {
                    (
                        0 | 1,
                        JointLimit::Ball {
                            twist_axis,
                            swing_max,
                            twist_min,
                            twist_max,
                        },
                    ) => {
                        axis[j][l] = twist_axis;
                        lo[j][l] = twist_min;
                        hi[j][l] = twist_max;
                        swing[j][l] = swing_max;
                    }
                    (2 | 3, JointLimit::Hinge { axis: a, min, max }) => {
                        axis[j][l] = a;
                        lo[j][l] = min;
                        hi[j][l] = max;
                    }
                    _ => return None,
                }
            }
        }
        // Same polynomial, lane by lane, as the scalar solver's `prepare_limits`.
        let half = |a: [f32; 4]| {
            let (s, c) = half_sin_cos4(F::from_array(a));
            (c, s)
        };
        let [c0, c1, c2, c3] = chains;
        let mut offsets = [V::ZERO; CHAIN_JOINTS];
        let mut rest = [Q::IDENTITY; CHAIN_JOINTS];
        let mut axes = [V::ZERO; CHAIN_JOINTS];
        let mut range = [Range4 {
            lo: (F::ZERO, F::ZERO),
            hi: (F::ZERO, F::ZERO),
        }; CHAIN_JOINTS];
        for j in 0..CHAIN_JOINTS {
            offsets[j] = V::gather(c0.offsets[j], c1.offsets[j], c2.offsets[j], c3.offsets[j]);
            rest[j] = Q::gather(c0.rest[j], c1.rest[j], c2.rest[j], c3.rest[j]);
            let a = &axis[j];
            axes[j] = V::gather(a[0], a[1], a[2], a[3]);
            range[j] = Range4 {
                lo: half(lo[j]),
                hi: half(hi[j]),
            };
        }
        Some(Chains4 {
            offsets,
            rest,
            effector: V::gather(c0.effector, c1.effector, c2.effector, c3.effector),
            axis: axes,
            swing: [half(swing[0]), half(swing[1])],
            range,
        })
    }
}

/// Joint frames of the four chains in their chain-root frames (as the scalar `Frames`).
struct Frames4 {
    pos: [V; 5],
    rot: [Q; CHAIN_JOINTS],
}

impl Frames4 {
    #[inline(always)]
    fn new(c: &Chains4, pose: &[Q; CHAIN_JOINTS]) -> Self {
        let local = [
            c.rest[0].mul(pose[0]),
            c.rest[1].mul(pose[1]),
            c.rest[2].mul(pose[2]),
            c.rest[3].mul(pose[3]),
        ];
        let mut rot = local;
        let mut pos = [c.offsets[0]; 5];
        for i in 1..CHAIN_JOINTS {
            rot[i] = rot[i - 1].mul(local[i]);
            pos[i] = pos[i - 1].add(rot[i - 1].rotate(c.offsets[i]));
        }
        pos[4] = pos[3].add(rot[3].rotate(c.effector));
        Frames4 { pos, rot }
    }

    #[inline(always)]
    fn dir_to_root(&self, j: usize, v: V) -> V {
        self.rot[j]
            .rotate(v)
            .scale(recip(self.rot[j].length_squared()))
    }

    #[inline(always)]
    fn dir_to_joint(&self, j: usize, v: V) -> V {
        self.rot[j]
            .conjugate()
            .rotate(v)
            .scale(recip(self.rot[j].length_squared()))
    }
}

/// The step cap, splatted.
struct Cap4 {
    cos: F,
    cos_half: F,
    sin_half: F,
}

impl Cap4 {
    /// Scalar `StepCap::capped_half`, lane-wise.
    #[inline(always)]
    fn capped_half(&self, cos: F, sin: F) -> (F, F) {
        let capped = cos.cmplt(self.cos);
        let c = sqrt((splat(0.5) * (F::ONE + cos)).max(F::ZERO));
        let s = sqrt((splat(0.5) * (F::ONE - cos)).max(F::ZERO)).copysign(sin);
        (
            sel(capped, self.cos_half, c),
            sel(capped, self.sin_half.copysign(sin), s),
        )
    }
}

/// Scalar `clamp_hinge_half`, lane-wise: clamped `(w, p)` and whether it changed.
#[inline(always)]
fn clamp_hinge_half(w: F, p: F, r: &Range4) -> (F, F, M) {
    let neg = w.cmplt(F::ZERO);
    let p_nonneg = p.cmpge(F::ZERO);
    let above = p.cmpgt(r.hi.1);
    let to_hi = msel(neg, p_nonneg, above);
    let to_lo = msel(neg, !p_nonneg, !above & p.cmplt(r.lo.1));
    let w2 = sel(to_hi, r.hi.0, sel(to_lo, r.lo.0, w));
    let p2 = sel(to_hi, r.hi.1, sel(to_lo, r.lo.1, p));
    (w2, p2, to_hi | to_lo)
}

/// Scalar `turn_hinge`: new half-angle, mask of lanes where it changed, clamp mask.
#[inline(always)]
fn turn_hinge((w, p): (F, F), (c, s): (F, F), r: &Range4) -> ((F, F), M, M) {
    let (w1, p1) = (w * c - p * s, w * s + p * c);
    let (w2, p2, clamped) = clamp_hinge_half(w1, p1, r);
    let eps = splat(1e-9);
    let same = (w2 - w).abs().cmple(eps) & (p2 - p).abs().cmple(eps);
    ((w2, p2), !same, clamped)
}

/// Scalar `rotate_half`.
#[inline(always)]
fn rotate_half(v: V, axis: V, (c, s): (F, F)) -> V {
    let k1 = splat(2.0) * c * s;
    let k2 = splat(2.0) * s * s;
    v.add(axis.cross(v).scale(k1))
        .add(axis.scale(axis.dot(v)).sub(v).scale(k2))
}

/// Scalar `hinge_half` (of the pose rotation about its hinge axis).
#[inline(always)]
fn hinge_half(q: Q, axis: V) -> (F, F) {
    let p = q.xyz().dot(axis);
    let neg = q.w.cmplt(F::ZERO);
    let w = sel(neg, -q.w, q.w);
    let p = sel(neg, -p, p);
    let len_sq = w * w + p * p;
    let tiny = len_sq.cmplt(splat(1e-18));
    let inv = recip(sqrt(len_sq));
    (sel(tiny, F::ONE, w * inv), sel(tiny, F::ZERO, p * inv))
}

/// Scalar `Hinge`: axis in the root frame, current half-angle, purity mask.
struct Hinge4 {
    axis: V,
    axis_rs: V,
    current: (F, F),
    pure: M,
}

impl Hinge4 {
    #[inline(always)]
    fn new(frames: &Frames4, q: Q, j: usize, axis: V) -> Self {
        let v = q.xyz();
        Hinge4 {
            axis,
            axis_rs: frames.dir_to_root(j, axis),
            current: hinge_half(q, axis),
            pure: v
                .sub(axis.scale(v.dot(axis)))
                .length_squared()
                .cmple(splat(1e-12)),
        }
    }

    /// Pure-hinge `Hinge::turn`: the new pose rotation and the new effector.
    #[inline(always)]
    fn turn(&self, joint_pos: V, e: V, new: (F, F)) -> (Q, V) {
        let v = self.axis.scale(new.1);
        let q = Q {
            x: v.x,
            y: v.y,
            z: v.z,
            w: new.0,
        };
        let (w, p) = self.current;
        let delta = (new.0 * w + new.1 * p, new.1 * w - new.0 * p);
        (q, joint_pos.add(rotate_half(e, self.axis_rs, delta)))
    }
}

/// Scalar `arc_step`: axis, half-angle, mask of lanes with a step.
#[inline(always)]
fn arc_step(from: V, to: V, cap: &Cap4) -> (V, (F, F), M) {
    let ff = from.length_squared();
    let tt = to.length_squared();
    let tiny = splat(1e-14);
    let ok = !(ff.cmplt(tiny) | tt.cmplt(tiny));
    let inv = recip(sqrt(ff * tt));
    let cos = clamp1(from.dot(to) * inv);
    let axis = from.cross(to);
    let sin_len = axis.length_squared();
    let ok = ok & !sin_len.cmplt(splat(1e-18));
    let axis = axis.scale(recip(sqrt(sin_len)));
    (axis, cap.capped_half(cos, F::ONE), ok)
}

/// Scalar `ball_reach_step`.
#[inline(always)]
fn ball_reach_step(b: V, d: V, s: F, cap: &Cap4) -> (V, (F, F), M) {
    let ll = b.length_squared();
    let dd = d.length_squared();
    let tiny = splat(1e-14);
    let ok = !(ll.cmplt(tiny) | dd.cmplt(tiny));
    let ld = sqrt(ll * dd);
    let cos_want = clamp1((ll + dd - s * s) / (splat(2.0) * ld));
    let sin_want = sqrt((F::ONE - cos_want * cos_want).max(F::ZERO));
    let axis = b.cross(d);
    let axis_len = sqrt(axis.length_squared());
    let ok = ok & !axis_len.cmplt(splat(1e-9));
    let (cos_now, sin_now) = (b.dot(d) / ld, axis_len / ld);
    let cos_d = clamp1(cos_now * cos_want + sin_now * sin_want);
    let sin_d = sin_now * cos_want - cos_now * sin_want;
    let ok = ok & !(sin_d.abs().cmplt(splat(1e-7)) & cos_d.cmpgt(F::ZERO));
    (axis.div(axis_len), cap.capped_half(cos_d, sin_d), ok)
}

/// Scalar `reach_hinge_step`: new half-angle, mask of lanes with a change, and the
/// `saturated` mask.
#[inline(always)]
fn reach_hinge_step(
    hinge: &Hinge4,
    range: &Range4,
    eff: V,
    r: V,
    want: F,
    cap: &Cap4,
) -> ((F, F), M, M) {
    let axis = hinge.axis_rs;
    let ea = axis.dot(eff);
    let ra = axis.dot(r);
    let e = eff.sub(axis.scale(ea));
    let r_perp = r.sub(axis.scale(ra));
    let ee = e.length_squared();
    let rr = r_perp.length_squared();
    let tiny = splat(1e-14);
    let ok = !(ee.cmplt(tiny) | rr.cmplt(tiny));
    let elrl = sqrt(ee * rr);
    let k = eff.length_squared() + r.length_squared() - splat(2.0) * ea * ra;
    let cos_raw = (k - want * want) / (splat(2.0) * elrl);
    let cos_psi = clamp1(cos_raw);
    let sin_psi = sqrt((F::ONE - cos_psi * cos_psi).max(F::ZERO));
    let inv = recip(elrl);
    let (cc, sc) = (e.dot(r_perp) * inv, axis.dot(e.cross(r_perp)) * inv);
    let d1 = (cc * cos_psi + sc * sin_psi, sc * cos_psi - cc * sin_psi);
    let d2 = (cc * cos_psi - sc * sin_psi, sc * cos_psi + cc * sin_psi);
    let current = hinge.current;
    let (s_min, s_max) = (range.lo.1, range.hi.1);
    let outside = |(c, s): (F, F)| {
        let hc = sqrt((splat(0.5) * (F::ONE + c)).max(F::ZERO));
        let hs = sqrt((splat(0.5) * (F::ONE - c)).max(F::ZERO)).copysign(s);
        let w1 = current.0 * hc - current.1 * hs;
        let p1 = current.0 * hs + current.1 * hc;
        sel(
            w1.cmplt(F::ZERO),
            splat(2.0) + w1.abs(),
            (s_min - p1).max(p1 - s_max).max(F::ZERO),
        )
    };
    let (o1, o2) = (outside(d1), outside(d2));
    // (o1, -c1) <= (o2, -c2), lexicographically.
    let first = msel(o1.cmpeq(o2), (-d1.0).cmple(-d2.0), o1.cmple(o2));
    let (cos_d, sin_d) = (sel(first, d1.0, d2.0), sel(first, d1.1, d2.1));
    let (new, changed, clamped) = turn_hinge(current, cap.capped_half(cos_d, sin_d), range);
    let saturated = ok & (cos_raw.abs().cmpgt(F::ONE) | clamped);
    (new, ok & changed, saturated)
}

/// Scalar `clamp_ball`: the clamped rotation, the mask of lanes where the clamp acted,
/// and the mask of degenerate lanes (a 180° swing: left to the scalar solver).
#[inline(always)]
fn clamp_ball(q: Q, axis: V, swing: (F, F), twist: &Range4) -> (Q, M, M) {
    let (cos_half_swing, sin_half_swing) = swing;
    let neg = q.w.cmplt(F::ZERO);
    let q = Q::select(
        neg,
        Q {
            x: -q.x,
            y: -q.y,
            z: -q.z,
            w: -q.w,
        },
        q,
    );
    let v = q.xyz();
    let p = v.dot(axis);
    let twist_len_sq = p * p + q.w * q.w;
    let degenerate = twist_len_sq.cmplt(splat(1e-18));
    let len = sqrt(twist_len_sq);
    let inv_len = recip(len);
    let (tw, tp) = (q.w * inv_len, p * inv_len);
    let swing_over = len.cmplt(cos_half_swing);
    let (tw_c, tp_c, twist_over) = clamp_hinge_half(tw, tp, twist);
    let clamped = swing_over | twist_over;
    if !clamped.any() {
        return (q, clamped, degenerate);
    }
    // swing = q · conj(twist), as `q * hinge_quat(axis, tw, -tp)`.
    let a = axis.scale(-tp);
    let swing = q.mul(Q {
        x: a.x,
        y: a.y,
        z: a.z,
        w: tw,
    });
    // `normalize_or_zero` of the swing's vector part, times the largest swing's sine.
    let sv = swing.xyz();
    let rcp = recip(sqrt(sv.length_squared()));
    let ok = rcp.abs().cmplt(splat(f32::INFINITY)) & rcp.cmpgt(F::ZERO);
    let sv = V::select(ok, sv.scale(rcp), V::ZERO).scale(sin_half_swing);
    let limited = Q {
        x: sv.x,
        y: sv.y,
        z: sv.z,
        w: cos_half_swing,
    };
    let swing = Q::select(swing_over, limited, swing);
    let t = axis.scale(tp_c);
    let out = swing.mul(Q {
        x: t.x,
        y: t.y,
        z: t.z,
        w: tw_c,
    });
    (Q::select(clamped, out, q), clamped, degenerate)
}

/// Lanes that finished on the vector path.
struct Lanes {
    /// Still sweeping.
    active: M,
    /// Must be redone by the scalar solver.
    scalar: M,
    /// Sweeps of the finished lanes (small integers, exact in `f32`).
    iterations: F,
}

/// Where the scalar solver takes over a lane that left the vector path at a point
/// the scalar solve passes through as well (so only the rest is solved again):
#[derive(Clone, Copy)]
struct Handover {
    /// A sweep that did not improve (the scalar solver undoes it and goes on
    /// without reach steps)…
    stall: M,
    /// …from the pose before that sweep,
    stall_pose: [Q; CHAIN_JOINTS],
    /// the error before that sweep,
    stall_prev_err: F,
    /// and the sweep's index (small integers, exact in `f32`).
    stall_iter: F,
    /// Out of sweeps (the scalar solver polishes from the final pose).
    out_of_sweeps: M,
    /// Reached, but the smoothness guard retries (from the final pose).
    smooth: M,
    /// The error at the warm start.
    start_err: F,
}

impl Lanes {
    /// Lanes in `m` (active ones) finished after `iterations` sweeps.
    #[inline(always)]
    fn finish(&mut self, m: M, iterations: u32) {
        self.iterations = sel(m, splat(iterations as f32), self.iterations);
        self.active &= !m;
    }
}

/// The vector path (see the module docs); returns the lanes the scalar solver must
/// redo, and the sweep counts of the others (all `Reached`).
#[inline(always)]
fn sweeps4(
    c: &Chains4,
    target: V,
    pose: &mut [Q; CHAIN_JOINTS],
    params: &CcdParams,
    tols: F,
) -> (M, F, F, Handover) {
    let start = *pose;
    let none = M::new(false, false, false, false);
    let mut frames = Frames4::new(c, pose);
    let tol_sq = tols * tols;
    let mut err_sq = frames.pos[4].sub(target).length_squared();
    let start_err = sqrt(err_sq);
    let at_start = err_sq.cmple(tol_sq);
    let mut lanes = Lanes {
        active: M::new(true, true, true, true),
        scalar: M::new(false, false, false, false),
        iterations: F::ZERO,
    };
    lanes.finish(at_start, 0);
    let mut handover = Handover {
        stall: none,
        stall_pose: start,
        stall_prev_err: F::ZERO,
        stall_iter: F::ZERO,
        out_of_sweeps: none,
        smooth: none,
        start_err,
    };
    let cap = StepCap::new(params.max_step_angle);
    let cap = Cap4 {
        cos: splat(cap.cos),
        cos_half: splat(cap.cos_half),
        sin_half: splat(cap.sin_half),
    };
    let mut prev_err = start_err;
    let mut mid_saturated = M::new(false, false, false, false);
    let min_improvement = splat(params.min_improvement);
    let mut iter = 0;
    while lanes.active.any() {
        if iter == params.max_iterations {
            // Out of sweeps: the scalar solver's stall polish decides.
            lanes.scalar |= lanes.active;
            handover.out_of_sweeps = lanes.active;
            #[cfg(test)]
            tests::note(5, lanes.active);
            break;
        }
        if iter > 0 {
            frames = Frames4::new(c, pose);
        }
        let sweep_start = *pose;
        for j in (0..CHAIN_JOINTS).rev() {
            // The elbow/knee reach step's saturation and wanted distance, with
            // the lanes active then (see `mid_saturated` below).
            let mut reach_saturated = None;
            let joint_pos = frames.pos[j];
            let e = frames.pos[4].sub(joint_pos);
            let (q, eff, some) = match j {
                3 | 2 => {
                    let hinge = Hinge4::new(&frames, pose[j], j, c.axis[j]);
                    let range = &c.range[j];
                    let (new, some) = if j == 3 {
                        let (new, some, _) =
                            hinge_turn_step(&hinge, range, e, target.sub(joint_pos), &cap);
                        (new, some)
                    } else {
                        let r = frames.pos[1].sub(joint_pos);
                        let want = sqrt(target.sub(frames.pos[1]).length_squared());
                        let (new, some, saturated) =
                            reach_hinge_step(&hinge, range, e, r, want, &cap);
                        reach_saturated = Some((lanes.active, saturated, want));
                        (new, some)
                    };
                    // A warm start with an off-axis part rebuilds the joint frame: scalar.
                    let off_axis = lanes.active & some & !hinge.pure;
                    lanes.scalar |= off_axis;
                    #[cfg(test)]
                    tests::note(0, off_axis);
                    lanes.active &= !off_axis;
                    let (q, eff) = hinge.turn(joint_pos, e, new);
                    (q, eff, some)
                }
                _ => {
                    let (axis, half, some) = {
                        let (a1, h1, s1) = arc_step(e, target.sub(joint_pos), &cap);
                        if j == 0 && (mid_saturated & lanes.active).any() {
                            let b = frames.pos[1].sub(joint_pos);
                            let d = target.sub(joint_pos);
                            let s = sqrt(frames.pos[4].sub(frames.pos[1]).length_squared());
                            let (a2, h2, s2) = ball_reach_step(b, d, s, &cap);
                            let m = mid_saturated;
                            (
                                V::select(m, a2, a1),
                                (sel(m, h2.0, h1.0), sel(m, h2.1, h1.1)),
                                msel(m, s2, s1),
                            )
                        } else {
                            (a1, h1, s1)
                        }
                    };
                    let v = frames.dir_to_joint(j, axis).scale(half.1);
                    let turned = pose[j].mul(Q {
                        x: v.x,
                        y: v.y,
                        z: v.z,
                        w: half.0,
                    });
                    let (q, clamped, degenerate) =
                        clamp_ball(turned, c.axis[j], c.swing[j], &c.range[j]);
                    let degenerate = lanes.active & some & degenerate;
                    lanes.scalar |= degenerate;
                    #[cfg(test)]
                    tests::note(1 + j, degenerate);
                    lanes.active &= !degenerate;
                    let mut e_new = rotate_half(e, axis, half);
                    if (lanes.active & some & clamped).any() {
                        // The clamp changed the rotation: rebuild the joint's frame,
                        // `(base_j · q) · (rot_j⁻¹ · e)`.
                        let base = if j == 0 {
                            c.rest[0]
                        } else {
                            frames.rot[j - 1].mul(c.rest[j])
                        };
                        let rebuilt = base.mul(q).rotate(frames.rot[j].conjugate().rotate(e));
                        e_new = V::select(clamped, rebuilt, e_new);
                    }
                    (q, joint_pos.add(e_new), some)
                }
            };
            let apply = lanes.active & some;
            pose[j] = Q::select(apply, q, pose[j]);
            frames.pos[4] = V::select(apply, eff, frames.pos[4]);
            if let Some((active, saturated, want)) = reach_saturated {
                // As the scalar step: the girdle reach only for a limb held
                // short at full extension, not at full flexion.
                let far = (want * want).cmpgt(frames.pos[4].sub(frames.pos[1]).length_squared());
                mid_saturated = sel_mask(active, saturated & far, mid_saturated);
            }
            err_sq = sel(apply, frames.pos[4].sub(target).length_squared(), err_sq);
            lanes.finish(apply & err_sq.cmple(tol_sq), iter + 1);
            if !lanes.active.any() {
                break;
            }
        }
        // A sweep that improves less than `min_improvement` is undone by the scalar
        // solver (then reach steps off, plain CCD, polish): all of that is scalar.
        let err = sqrt(err_sq);
        let stalled = lanes.active & (prev_err - err).cmplt(min_improvement);
        lanes.scalar |= stalled;
        if stalled.any() {
            for (h, q) in handover.stall_pose.iter_mut().zip(sweep_start) {
                *h = Q::select(stalled, q, *h);
            }
            handover.stall_prev_err = sel(stalled, prev_err, handover.stall_prev_err);
            handover.stall_iter = sel(stalled, splat(iter as f32), handover.stall_iter);
            handover.stall |= stalled;
        }
        #[cfg(test)]
        tests::note(3, stalled);
        lanes.active &= !stalled;
        prev_err = err;
        iter += 1;
    }
    // The smoothness guard (its retry is scalar).
    if params.refine {
        // `max_joint_cos_half`: the smallest `|start_j · pose_j|` (dot4 as glam's).
        let mut cos_half = F::ONE;
        for j in 0..CHAIN_JOINTS {
            // `minps` returns its second operand when one is NaN: as `f32::min`, a
            // NaN dot product leaves the running minimum alone.
            cos_half = start[j].dot(pose[j]).abs().min(cos_half);
        }
        let retry = lanes.iterations.cmpgt(F::ZERO)
            & start_err.cmple(splat(SMOOTH_TRIGGER_DIST))
            & cos_half.cmplt(splat(SMOOTH_COS_HALF));
        lanes.scalar |= retry;
        handover.smooth = retry;
        #[cfg(test)]
        tests::note(4, retry);
    }
    (lanes.scalar, lanes.iterations, err_sq, handover)
}

/// `(m ? a : b)` on masks.
#[inline(always)]
fn sel_mask(m: M, a: M, b: M) -> M {
    msel(m, a, b)
}

/// Scalar `hinge_step` followed by the change test of `turn_hinge`.
#[inline(always)]
fn hinge_turn_step(
    hinge: &Hinge4,
    range: &Range4,
    eff: V,
    target: V,
    cap: &Cap4,
) -> ((F, F), M, M) {
    let axis = hinge.axis_rs;
    let e = eff.sub(axis.scale(axis.dot(eff)));
    let t = target.sub(axis.scale(axis.dot(target)));
    let ee = e.length_squared();
    let tt = t.length_squared();
    let tiny = splat(1e-14);
    let ok = !(ee.cmplt(tiny) | tt.cmplt(tiny));
    let inv = recip(sqrt(ee * tt));
    let cos = clamp1(e.dot(t) * inv);
    let sin = axis.dot(e.cross(t)) * inv;
    let half = cap.capped_half(cos, sin);
    let (new, changed, clamped) = turn_hinge(hinge.current, half, range);
    (new, ok & changed, clamped)
}

/// Four limb chains prepared for [`solve4_prepared`]: copies of the chains plus their
/// transposed (one chain per SIMD lane) constants and limit trigonometry, computed
/// once here instead of on every [`solve4`] call. It owns its copies, so it can never
/// go stale; a caller that changes a chain builds a new one.
#[derive(Clone, Debug)]
pub struct LimbChains4 {
    chains: [LimbChain; 4],
    /// `None` when the chains do not have the layout the vector path handles.
    soa: Option<Chains4>,
    /// The forward kinematics' first joint before its pose: its position
    /// (`0 + 1 · offset₀`) and `1 · rest₀`, the operations [`LimbChain::fk_local`]
    /// starts with (constants of the chains: computed once, the same bits).
    fk_first: Option<(V, Q)>,
}

impl LimbChains4 {
    /// Prepare four chains (lane `i` = `chains[i]`).
    pub fn new(chains: [&LimbChain; 4]) -> Self {
        let soa = Chains4::new(chains);
        let fk_first = soa.as_ref().map(|c| {
            (
                V::ZERO.add(Q::IDENTITY.rotate(c.offsets[0])),
                Q::IDENTITY.mul(c.rest[0]),
            )
        });
        Self {
            chains: chains.map(|c| *c),
            soa,
            fk_first,
        }
    }

    /// The chains, lane by lane.
    pub fn chains(&self) -> &[LimbChain; 4] {
        &self.chains
    }

    /// The four effectors in world space, lane `i` exactly
    /// `chains()[i].fk_effector(roots[i], &poses[i])` (the forward kinematics
    /// of [`LimbChain::fk_local`] in SIMD lanes, its operations in its order).
    pub fn fk_effectors(&self, roots: &[RootTransform; 4], poses: &[ChainPose; 4]) -> [Vec3; 4] {
        let (Some(c), Some((first_pos, first_rest))) = (&self.soa, self.fk_first) else {
            return std::array::from_fn(|i| self.chains[i].fk_effector(roots[i], &poses[i]));
        };
        let [p0, p1, p2, p3] = poses;
        let pose = |j: usize| Q::gather(p0.0[j], p1.0[j], p2.0[j], p3.0[j]);
        let mut parent_pos = first_pos;
        let mut parent_rot = first_rest.mul(pose(0));
        for j in 1..CHAIN_JOINTS {
            parent_pos = parent_pos.add(parent_rot.rotate(c.offsets[j]));
            parent_rot = parent_rot.mul(c.rest[j]).mul(pose(j));
        }
        let local = parent_pos.add(parent_rot.rotate(c.effector));
        let [r0, r1, r2, r3] = roots;
        let rot = Q::gather(r0.rotation, r1.rotation, r2.rotation, r3.rotation);
        let pos = V::gather(r0.position, r1.position, r2.position, r3.position);
        // `RootTransform::transform_point`: `position + rotation * p`.
        pos.add(rot.rotate(local)).scatter().map(Vec3::from)
    }
}

/// Where [`solve4_impl`] gets the transposed chains.
#[derive(Clone, Copy)]
enum Layout<'a> {
    /// Already prepared (`None`: not the sloth layout, scalar solves).
    Prepared(Option<&'a Chains4>),
    /// Build them now.
    Build,
}

/// Solve four limb chains at once (one per SIMD lane; see the module docs). Each lane
/// is exactly `solve(chains[i], roots[i], targets[i], &mut poses[i], params)`: same
/// poses, same results, bit for bit. Per call it transposes the chains and evaluates
/// their limit trigonometry; [`solve4_prepared`] does that once.
pub fn solve4(
    chains: [&LimbChain; 4],
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
) -> [CcdResult; 4] {
    let tols = [params.tolerance; 4];
    solve4_dispatch(chains, Layout::Build, roots, targets, poses, params, tols)
}

/// [`solve4`] on prepared chains (lane `i` = `chains.chains()[i]`); bit-identical to
/// [`crate::ccd::solve`] lane by lane as well.
pub fn solve4_prepared(
    chains: &LimbChains4,
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
) -> [CcdResult; 4] {
    solve4_prepared_tolerances(chains, roots, targets, poses, params, [params.tolerance; 4])
}

/// [`solve4_prepared`] with a tolerance per lane: lane `i` is exactly
/// `solve(chains[i], roots[i], targets[i], &mut poses[i], &CcdParams { tolerance:
/// tolerances[i], ..*params })` (`params.tolerance` is not used). A lane whose
/// tolerance is invalid (see [`CcdParams::validate`]) is rejected with
/// [`CcdStatus::InvalidParams`] and left untouched; the others are solved.
pub fn solve4_prepared_tolerances(
    chains: &LimbChains4,
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
    tolerances: [f32; 4],
) -> [CcdResult; 4] {
    let c = &chains.chains;
    let refs = [&c[0], &c[1], &c[2], &c[3]];
    let layout = Layout::Prepared(chains.soa.as_ref());
    solve4_dispatch(refs, layout, roots, targets, poses, params, tolerances)
}

/// [`solve4_impl`], in its AVX2 build where the CPU has AVX2.
fn solve4_dispatch(
    chains: [&LimbChain; 4],
    layout: Layout<'_>,
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
    tols: [f32; 4],
) -> [CcdResult; 4] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above).
        return unsafe { solve4_avx2(chains, layout, roots, targets, poses, params, tols) };
    }
    solve4_impl(chains, layout, roots, targets, poses, params, tols)
}

/// [`solve4_impl`] compiled with AVX2 (VEX encoding; same IEEE operations).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn solve4_avx2(
    chains: [&LimbChain; 4],
    layout: Layout<'_>,
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
    tols: [f32; 4],
) -> [CcdResult; 4] {
    solve4_impl(chains, layout, roots, targets, poses, params, tols)
}

#[inline(always)]
fn solve4_impl(
    chains: [&LimbChain; 4],
    layout: Layout<'_>,
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
    tols: [f32; 4],
) -> [CcdResult; 4] {
    let lane_params: [CcdParams; 4] = std::array::from_fn(|i| CcdParams {
        tolerance: tols[i],
        ..*params
    });
    let mut results = [CcdResult::rejected(CcdStatus::InvalidTarget); 4];
    let mut valid = [false; 4];
    let mut local = [Vec3A::ZERO; 4];
    for i in 0..4 {
        if lane_params[i].validate().is_err() {
            results[i] = CcdResult::rejected(CcdStatus::InvalidParams);
            continue;
        }
        let root = roots[i];
        valid[i] = targets[i].is_finite() && root.position.is_finite() && root.rotation.is_finite();
        if valid[i] {
            if !poses[i].is_finite() {
                poses[i] = ChainPose::NEUTRAL;
            }
            local[i] = root.inverse_transform_point(targets[i].into());
        }
    }
    if valid == [true; 4] && params.order == CcdOrder::TailFirst && params.reach_step {
        match layout {
            Layout::Prepared(Some(c)) => return run4(chains, c, &local, poses, &lane_params),
            Layout::Prepared(None) => {}
            Layout::Build => {
                if let Some(c) = Chains4::new(chains) {
                    return run4(chains, &c, &local, poses, &lane_params);
                }
            }
        }
    }
    for i in 0..4 {
        if valid[i] {
            results[i] = solve_local_dispatch(chains[i], local[i], &mut poses[i], &lane_params[i]);
        }
    }
    results
}

/// The vector path for four valid lanes, then the scalar solver for the lanes that
/// left it.
#[inline(always)]
fn run4(
    chains: [&LimbChain; 4],
    c: &Chains4,
    local: &[Vec3A; 4],
    poses: &mut [ChainPose; 4],
    lane_params: &[CcdParams; 4],
) -> [CcdResult; 4] {
    // The lanes differ in their tolerance only.
    let params = &lane_params[0];
    let start = *poses;
    let [p0, p1, p2, p3] = &start;
    let mut pose = [Q::IDENTITY; CHAIN_JOINTS];
    for (j, q) in pose.iter_mut().enumerate() {
        *q = Q::gather(p0.0[j], p1.0[j], p2.0[j], p3.0[j]);
    }
    let target = V::gather(local[0], local[1], local[2], local[3]);
    let tols = F::new(
        lane_params[0].tolerance,
        lane_params[1].tolerance,
        lane_params[2].tolerance,
        lane_params[3].tolerance,
    );
    let (scalar, iterations, err_sq, h) = sweeps4(c, target, &mut pose, params, tols);
    let error = sqrt(err_sq);
    for (j, q) in pose.iter().enumerate() {
        for (p, q) in poses.iter_mut().zip(q.scatter()) {
            p.0[j] = q;
        }
    }
    let mut results = [CcdResult::rejected(CcdStatus::InvalidTarget); 4];
    for i in 0..4 {
        if scalar.test(i) {
            let params = &lane_params[i];
            #[cfg(test)]
            tests::SCALAR_LANES.with(|n| n.set(n.get() + 1));
            let start_err = h.start_err[i];
            let resume = |pose: &mut ChainPose, from: SweepFrom| {
                resume_local_dispatch(
                    chains[i], local[i], &start[i], start_err, pose, params, from,
                )
            };
            results[i] = if h.stall.test(i) {
                // The scalar solve undoes the stalled sweep and goes on without
                // reach steps from the next one.
                for j in 0..CHAIN_JOINTS {
                    poses[i].0[j] = h.stall_pose[j].scatter()[i];
                }
                let prev_err = h.stall_prev_err[i];
                let from = SweepFrom {
                    iter: h.stall_iter[i] as u32 + 1,
                    prev_err,
                    err_sq: prev_err * prev_err,
                    reach_step: false,
                };
                resume(&mut poses[i], from)
            } else if h.out_of_sweeps.test(i) {
                // No sweep left: the scalar solve polishes from this pose.
                let from = SweepFrom {
                    iter: params.max_iterations,
                    prev_err: error[i],
                    err_sq: err_sq[i],
                    reach_step: true,
                };
                resume(&mut poses[i], from)
            } else if h.smooth.test(i) {
                let reached = CcdResult {
                    reached: true,
                    error: error[i],
                    iterations: iterations[i] as u32,
                    status: CcdStatus::Reached,
                };
                smooth_guard_dispatch(
                    chains[i],
                    local[i],
                    &start[i],
                    start_err,
                    &mut poses[i],
                    params,
                    reached,
                )
            } else {
                poses[i] = start[i];
                solve_local_dispatch(chains[i], local[i], &mut poses[i], params)
            };
        } else {
            results[i] = CcdResult {
                reached: true,
                error: error[i],
                iterations: iterations[i] as u32,
                status: CcdStatus::Reached,
            };
        }
    }
    results
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Rig;
    use glam::Quat;
    use std::cell::Cell;

    thread_local! {
        /// Lanes handed to the scalar solver (diagnostics).
        pub(super) static SCALAR_LANES: Cell<u64> = const { Cell::new(0) };
        /// Why: off-axis hinge, ball 0 degenerate, ball 1 degenerate, stall, smooth, sweeps.
        static REASONS: Cell<[u64; 6]> = const { Cell::new([0; 6]) };
    }

    pub(super) fn note(reason: usize, m: M) {
        REASONS.with(|r| {
            let mut a = r.get();
            a[reason] += u64::from(m.bitmask().count_ones());
            r.set(a);
        });
    }

    fn rnd(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    fn bits(p: &ChainPose) -> [[u32; 4]; 4] {
        p.0.map(|q| q.to_array().map(f32::to_bits))
    }

    fn same(a: &CcdResult, b: &CcdResult) -> bool {
        a.reached == b.reached
            && a.error.to_bits() == b.error.to_bits()
            && a.iterations == b.iterations
            && a.status == b.status
    }

    /// Run `solve4` and the scalar `solve` on the same inputs; assert bit-identical.
    fn check(
        chains: [&LimbChain; 4],
        roots: [RootTransform; 4],
        targets: [Vec3; 4],
        a: &mut [ChainPose; 4],
        b: &mut [ChainPose; 4],
        params: &CcdParams,
    ) {
        let mut a2 = *a;
        let r4 = solve4(chains, roots, targets, a, params);
        let prepared = LimbChains4::new(chains);
        let r4p = solve4_prepared(&prepared, roots, targets, &mut a2, params);
        for i in 0..4 {
            assert!(same(&r4[i], &r4p[i]) && bits(&a[i]) == bits(&a2[i]));
        }
        for i in 0..4 {
            let r = crate::solve(chains[i], roots[i], targets[i], &mut b[i], params);
            assert!(
                same(&r4[i], &r) && bits(&a[i]) == bits(&b[i]),
                "lane {i}: {:?} vs {r:?}\n{:?}\nvs {:?}",
                r4[i],
                a[i],
                b[i]
            );
        }
    }

    fn root(s: &mut u64) -> RootTransform {
        let axis = Vec3::new(rnd(s) - 0.5, rnd(s) - 0.5, rnd(s) - 0.5)
            .try_normalize()
            .unwrap_or(Vec3::Y);
        RootTransform::new(
            Vec3::new(rnd(s) * 10.0, rnd(s) * 10.0, rnd(s) * 10.0),
            Quat::from_axis_angle(axis, 6.0 * rnd(s) - 3.0),
        )
    }

    /// The SIMD forward kinematics equal the scalar one, bit for bit.
    #[test]
    fn fk_effectors_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let mut s = 0xf00d_u64;
        for _ in 0..5000 {
            let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
            let poses: [ChainPose; 4] = std::array::from_fn(|i| {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                chains[i].sample_pose(&u)
            });
            let fk = prepared.fk_effectors(&roots, &poses);
            for i in 0..4 {
                let want = chains[i].fk_effector(roots[i], &poses[i]);
                assert_eq!(
                    fk[i].to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits)
                );
            }
        }
    }

    /// A tolerance per lane (the step checks' use: 1.5–3.5 mm, and +∞ for a lane
    /// that does not matter): each lane is the scalar solve with its tolerance.
    #[test]
    fn per_lane_tolerances_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let mut s = 0x70_1e_u64;
        let base = CcdParams {
            refine: false,
            max_iterations: 32,
            ..CcdParams::default()
        };
        let (mut moved, mut skipped) = (0, 0);
        for k in 0..3000 {
            let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
            let tols: [f32; 4] = std::array::from_fn(|_| {
                [0.0015, 0.003, 0.0035, f32::INFINITY][(rnd(&mut s) * 4.0) as usize % 4]
            });
            let targets: [Vec3; 4] = std::array::from_fn(|i| {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                let p = chains[i].fk(roots[i], &chains[i].sample_pose(&u))[4];
                let d = if k % 3 == 0 { 0.3 } else { 0.02 };
                p + d * Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5)
            });
            let start: [ChainPose; 4] = std::array::from_fn(|i| {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                chains[i].sample_pose(&u)
            });
            let mut a = start;
            let r4 = solve4_prepared_tolerances(&prepared, roots, targets, &mut a, &base, tols);
            for i in 0..4 {
                let params = CcdParams {
                    tolerance: tols[i],
                    ..base
                };
                let mut b = start[i];
                let r = crate::solve(chains[i], roots[i], targets[i], &mut b, &params);
                assert!(
                    same(&r4[i], &r) && bits(&a[i]) == bits(&b),
                    "lane {i}, tol {}",
                    tols[i]
                );
                if tols[i].is_infinite() {
                    // Nothing to do: the pose stays, the error is measured.
                    assert!(r.reached && r.iterations == 0 && bits(&b) == bits(&start[i]));
                    skipped += 1;
                } else if r.iterations > 0 {
                    moved += 1;
                }
            }
        }
        assert!(
            moved > 1000 && skipped > 1000,
            "{moved} solved, {skipped} skipped"
        );
    }

    /// Cold solves of reachable and unreachable targets, from neutral and from random
    /// within-limit poses, under random roots.
    #[test]
    fn cold_solves_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let mut s = 0x5eed_u64;
        for params in [CcdParams::default(), CcdParams::precise()] {
            for k in 0..3000 {
                let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
                let targets: [Vec3; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    let p = chains[i].fk(roots[i], &chains[i].sample_pose(&u))[4];
                    if k % 5 == 0 {
                        // Anywhere nearby, reachable or not.
                        p + Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5)
                    } else {
                        p
                    }
                });
                let mut a: [ChainPose; 4] = std::array::from_fn(|i| {
                    if k % 2 == 0 {
                        ChainPose::NEUTRAL
                    } else {
                        let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                        chains[i].sample_pose(&u)
                    }
                });
                let mut b = a;
                check(chains, roots, targets, &mut a, &mut b, &params);
            }
        }
    }

    /// Warm tracking (1–8 mm per frame, moving roots) over many frames: poses are
    /// carried from frame to frame on both sides and must stay identical.
    #[test]
    fn warm_tracking_matches_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let params = CcdParams::default();
        let mut s = 0xbeef_u64;
        let mut solves = 0u64;
        SCALAR_LANES.with(|n| n.set(0));
        for step_mm in [1.0f32, 2.0, 4.0, 8.0] {
            let mut a = [ChainPose::NEUTRAL; 4];
            let mut b = a;
            let mut ua: [[f32; 12]; 4] =
                std::array::from_fn(|_| std::array::from_fn(|_| rnd(&mut s)));
            for _ in 0..12 {
                let ub: [[f32; 12]; 4] =
                    std::array::from_fn(|_| std::array::from_fn(|_| rnd(&mut s)));
                let n = (200.0 / step_mm) as usize;
                for f in 0..=n {
                    let t = f as f32 / n as f32;
                    let root = RootTransform::new(
                        Vec3::new(t, 1.0, 0.5 * t),
                        Quat::from_rotation_y(0.3 * t),
                    );
                    let roots = [root; 4];
                    let targets: [Vec3; 4] = std::array::from_fn(|i| {
                        let u: [f32; 12] =
                            std::array::from_fn(|k| ua[i][k] + (ub[i][k] - ua[i][k]) * t);
                        chains[i].fk(root, &chains[i].sample_pose(&u))[4]
                    });
                    check(chains, roots, targets, &mut a, &mut b, &params);
                    solves += 4;
                }
                ua = ub;
            }
        }
        let scalar = SCALAR_LANES.with(|n| n.get());
        let reasons = REASONS.with(|r| r.get());
        println!("warm: {scalar} of {solves} lanes went to the scalar solver: {reasons:?}");
    }

    /// The AVX2 build of the vector solver (where the CPU has AVX2) gives the plain
    /// SSE2 build's bits, lane by lane, cold and warm, near and far targets.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_build_matches_plain_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let layout = Layout::Prepared(prepared.soa.as_ref());
        let mut s = 0xb11d_u64;
        for params in [CcdParams::default(), CcdParams::precise()] {
            for k in 0..2000 {
                let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
                let targets: [Vec3; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    let p = chains[i].fk(roots[i], &chains[i].sample_pose(&u))[4];
                    let d = [0.0, 0.005, 0.03, 0.5][k % 4];
                    p + d * Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5)
                });
                let start: [ChainPose; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    chains[i].sample_pose(&u)
                });
                let tols = [params.tolerance; 4];
                let (mut a, mut b) = (start, start);
                let ra = solve4_impl(chains, layout, roots, targets, &mut a, &params, tols);
                // SAFETY: the CPU has AVX2 (checked above).
                let rb =
                    unsafe { solve4_avx2(chains, layout, roots, targets, &mut b, &params, tols) };
                for i in 0..4 {
                    assert!(same(&ra[i], &rb[i]) && bits(&a[i]) == bits(&b[i]));
                }
            }
        }
    }

    /// Far and huge (but finite) targets: squares overflow to infinity and NaNs appear
    /// inside the steps; the lanes must still follow the scalar solver exactly.
    #[test]
    fn extreme_targets_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let mut s = 0xfa7_u64;
        for scale in [1e3f32, 1e6, 1e18, 1e19, 1e20, 3e38] {
            for _ in 0..50 {
                let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
                let targets: [Vec3; 4] = std::array::from_fn(|_| {
                    Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5) * scale
                });
                let mut a: [ChainPose; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    chains[i].sample_pose(&u)
                });
                let mut b = a;
                check(
                    chains,
                    roots,
                    targets,
                    &mut a,
                    &mut b,
                    &CcdParams::default(),
                );
            }
        }
    }

    /// Bad input per lane: that lane is rejected (pose untouched), the others solve.
    #[test]
    fn invalid_lanes_are_rejected_like_scalar() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let roots = [RootTransform::IDENTITY; 4];
        let mut targets: [Vec3; 4] =
            std::array::from_fn(|i| chains[i].fk(roots[i], &ChainPose::NEUTRAL)[4]);
        targets[1] = Vec3::new(f32::NAN, 0.0, 0.0);
        targets[2] += Vec3::new(0.01, 0.02, 0.0);
        let mut a = [ChainPose::NEUTRAL; 4];
        a[3].0[1] = Quat::from_xyzw(f32::INFINITY, 0.0, 0.0, 1.0);
        let mut b = a;
        check(
            chains,
            roots,
            targets,
            &mut a,
            &mut b,
            &CcdParams::default(),
        );
        let bad = CcdParams {
            tolerance: -1.0,
            ..CcdParams::default()
        };
        check(chains, roots, targets, &mut a, &mut b, &bad);
        // Not the sloth layout: every lane goes through the scalar solver.
        let mut free = *chains[0];
        free.limits[3] = JointLimit::Free;
        let mixed = [&free, chains[1], chains[2], chains[3]];
        check(mixed, roots, targets, &mut a, &mut b, &CcdParams::default());
    }
}
