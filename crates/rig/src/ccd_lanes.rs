// The lane-generic CCD kernel of [`crate::ccd4`]: included (`include!`) into a
// module that defines `F` (the lanes of one `f32` each), `M` (its masks), `N`
// (the lane count) and `sqrt`, once per lane width (`Vec4`: 4 lanes; `F8`: 8
// lanes in one AVX register). Lane `i` is exactly the scalar solver on lane
// `i`'s inputs, whatever the width: see the module docs of `ccd4`.
//
// Length: one `include!`d kernel (solve, resume, polish for N lanes) that must stay one unit: every line has a scalar twin in ccd.rs it matches bit for bit.

use glam::{Quat, Vec3, Vec3A, Vec4};

use crate::ccd::{
    CcdOrder, CcdParams, CcdResult, CcdStatus, SMOOTH_COS_HALF, SMOOTH_TRIGGER_DIST, StepCap,
    SweepFrom, resume_local_dispatch, smooth_guard_dispatch, solve_local_dispatch,
};
use crate::chain::{CHAIN_JOINTS, ChainPose, LimbChain, RootTransform};
use crate::limits::{JointLimit, half_sin_cos4};

#[inline(always)]
fn splat(x: f32) -> F {
    F::splat(x)
}

#[inline(always)]
fn sel(m: M, a: F, b: F) -> F {
    F::select(m, a, b)
}

/// `1.0 / x` lane-wise (as `f32::recip`).
#[inline(always)]
fn recip(x: F) -> F {
    F::ONE / x
}

/// Lane `i` of `x`.
#[inline(always)]
fn lane(x: F, i: usize) -> f32 {
    x.to_array()[i]
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

/// `N` 3-vectors, one per lane.
#[derive(Clone, Copy, Debug)]
pub(super) struct V {
    pub(super) x: F,
    pub(super) y: F,
    pub(super) z: F,
}

impl V {
    pub(super) const ZERO: V = V {
        x: F::ZERO,
        y: F::ZERO,
        z: F::ZERO,
    };

    /// Transpose: lane `i` gets `v[i]`.
    #[inline(always)]
    pub(super) fn gather(v: [Vec3A; N]) -> V {
        let [x, y, z, _] = columns(v.map(super::vec4_of));
        V { x, y, z }
    }

    /// Transpose back: the lanes' vectors.
    #[inline(always)]
    pub(super) fn scatter(self) -> [Vec3A; N] {
        rows([self.x, self.y, self.z, F::ZERO]).map(Vec3A::from_vec4)
    }

    #[inline(always)]
    pub(super) fn add(self, o: V) -> V {
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

/// `N` quaternions, one per lane.
#[derive(Clone, Copy, Debug)]
pub(super) struct Q {
    pub(super) x: F,
    pub(super) y: F,
    pub(super) z: F,
    pub(super) w: F,
}

impl Q {
    pub(super) const IDENTITY: Q = Q {
        x: F::ZERO,
        y: F::ZERO,
        z: F::ZERO,
        w: F::ONE,
    };

    /// Transpose: lane `i` gets `q[i]`.
    #[inline(always)]
    pub(super) fn gather(q: [Quat; N]) -> Q {
        let [x, y, z, w] = columns(q.map(Vec4::from));
        Q { x, y, z, w }
    }

    /// Transpose back: the lanes' quaternions.
    #[inline(always)]
    fn scatter(self) -> [Quat; N] {
        rows([self.x, self.y, self.z, self.w]).map(Quat::from_vec4)
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
    pub(super) fn mul(self, r: Q) -> Q {
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
    pub(super) fn rotate(self, v: V) -> V {
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
struct Ranges {
    lo: (F, F),
    hi: (F, F),
}

/// The chains, transposed (one per lane), with their limits' half-angle trigonometry.
#[derive(Clone, Debug)]
pub(super) struct Chains {
    pub(super) offsets: [V; CHAIN_JOINTS],
    pub(super) rest: [Q; CHAIN_JOINTS],
    pub(super) effector: V,
    /// Twist axes (joints 0, 1) and hinge axes (joints 2, 3).
    axis: [V; CHAIN_JOINTS],
    /// Ball joints 0 and 1: `(cos, sin)` of half the largest swing.
    swing: [(F, F); 2],
    /// Twist ranges (joints 0, 1) and hinge ranges (joints 2, 3).
    range: [Ranges; CHAIN_JOINTS],
}

impl Chains {
    /// `None` unless every chain has the sloth layout (ball, ball, hinge, hinge).
    #[inline(always)]
    pub(super) fn new(chains: [&LimbChain; N]) -> Option<Self> {
        // Per joint: (axis, a, b, swing) with (a, b) = (min, max) or (twist_min, twist_max).
        let mut axis = [[Vec3A::ZERO; N]; CHAIN_JOINTS];
        let mut lo = [[0.0f32; N]; CHAIN_JOINTS];
        let mut hi = [[0.0f32; N]; CHAIN_JOINTS];
        let mut swing = [[0.0f32; N]; 2];
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
        // (Four lanes at a time: the polynomial's `Vec4` form.)
        let half = |a: [f32; N]| {
            let (mut s, mut c) = ([0.0f32; N], [0.0f32; N]);
            for k in (0..N).step_by(4) {
                let (s4, c4) = half_sin_cos4(Vec4::from_slice(&a[k..k + 4]));
                s[k..k + 4].copy_from_slice(&s4.to_array());
                c[k..k + 4].copy_from_slice(&c4.to_array());
            }
            (F::from_array(c), F::from_array(s))
        };
        let mut offsets = [V::ZERO; CHAIN_JOINTS];
        let mut rest = [Q::IDENTITY; CHAIN_JOINTS];
        let mut axes = [V::ZERO; CHAIN_JOINTS];
        let mut range = [Ranges {
            lo: (F::ZERO, F::ZERO),
            hi: (F::ZERO, F::ZERO),
        }; CHAIN_JOINTS];
        for j in 0..CHAIN_JOINTS {
            offsets[j] = V::gather(chains.map(|c| c.offsets[j]));
            rest[j] = Q::gather(chains.map(|c| c.rest[j]));
            axes[j] = V::gather(axis[j]);
            range[j] = Ranges {
                lo: half(lo[j]),
                hi: half(hi[j]),
            };
        }
        Some(Chains {
            offsets,
            rest,
            effector: V::gather(chains.map(|c| c.effector)),
            axis: axes,
            swing: [half(swing[0]), half(swing[1])],
            range,
        })
    }
}

/// Joint frames of the chains in their chain-root frames (as the scalar `Frames`).
struct Frames {
    pos: [V; 5],
    rot: [Q; CHAIN_JOINTS],
}

impl Frames {
    #[inline(always)]
    fn new(c: &Chains, pose: &[Q; CHAIN_JOINTS]) -> Self {
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
        Frames { pos, rot }
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
struct Cap {
    cos: F,
    cos_half: F,
    sin_half: F,
}

impl Cap {
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
fn clamp_hinge_half(w: F, p: F, r: &Ranges) -> (F, F, M) {
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
fn turn_hinge((w, p): (F, F), (c, s): (F, F), r: &Ranges) -> ((F, F), M, M) {
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
struct Hinge {
    axis: V,
    axis_rs: V,
    current: (F, F),
    pure: M,
}

impl Hinge {
    #[inline(always)]
    fn new(frames: &Frames, q: Q, j: usize, axis: V) -> Self {
        let v = q.xyz();
        Hinge {
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
fn arc_step(from: V, to: V, cap: &Cap) -> (V, (F, F), M) {
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
fn ball_reach_step(b: V, d: V, s: F, cap: &Cap) -> (V, (F, F), M) {
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
    hinge: &Hinge,
    range: &Ranges,
    eff: V,
    r: V,
    want: F,
    cap: &Cap,
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
    // (A function, not a closure: closures do not inherit the caller's
    // target features, and the eight-lane kernel's AVX must inline.)
    #[inline(always)]
    fn outside(current: (F, F), (s_min, s_max): (F, F), (c, s): (F, F)) -> F {
        let hc = sqrt((splat(0.5) * (F::ONE + c)).max(F::ZERO));
        let hs = sqrt((splat(0.5) * (F::ONE - c)).max(F::ZERO)).copysign(s);
        let w1 = current.0 * hc - current.1 * hs;
        let p1 = current.0 * hs + current.1 * hc;
        sel(
            w1.cmplt(F::ZERO),
            splat(2.0) + w1.abs(),
            (s_min - p1).max(p1 - s_max).max(F::ZERO),
        )
    }
    let bounds = (s_min, s_max);
    let (o1, o2) = (outside(current, bounds, d1), outside(current, bounds, d2));
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
fn clamp_ball(q: Q, axis: V, swing: (F, F), twist: &Ranges) -> (Q, M, M) {
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
    // Scale-free (see the scalar `clamp_ball`): `len / |q|` against the cosine.
    let swing_over = twist_len_sq.cmplt(cos_half_swing * cos_half_swing * q.length_squared());
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
    /// Left between two sweeps: out of sweeps (the scalar solver polishes
    /// from the final pose), or the last lane still sweeping (the scalar
    /// solver goes on with its sweeps: one lane's work instead of `N`)…
    resume: M,
    /// …from this sweep.
    resume_iter: u32,
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
fn sweeps(
    c: &Chains,
    target: V,
    pose: &mut [Q; CHAIN_JOINTS],
    params: &CcdParams,
    tols: F,
) -> (M, F, F, Handover) {
    let start = *pose;
    let none = M::splat(false);
    let mut frames = Frames::new(c, pose);
    let tol_sq = tols * tols;
    let mut err_sq = frames.pos[4].sub(target).length_squared();
    let start_err = sqrt(err_sq);
    let at_start = err_sq.cmple(tol_sq);
    let mut lanes = Lanes {
        active: M::splat(true),
        scalar: M::splat(false),
        iterations: F::ZERO,
    };
    lanes.finish(at_start, 0);
    let mut handover = Handover {
        stall: none,
        stall_pose: start,
        stall_prev_err: F::ZERO,
        stall_iter: F::ZERO,
        resume: none,
        resume_iter: 0,
        smooth: none,
        start_err,
    };
    let cap = StepCap::new(params.max_step_angle);
    let cap = Cap {
        cos: splat(cap.cos),
        cos_half: splat(cap.cos_half),
        sin_half: splat(cap.sin_half),
    };
    let mut prev_err = start_err;
    let mut mid_saturated = M::splat(false);
    let min_improvement = splat(params.min_improvement);
    let mut iter = 0;
    while lanes.active.any() {
        // Out of sweeps: the scalar solver's stall polish decides. One lane
        // left sweeping (the others reached or left): the scalar solver
        // finishes it from here, the same sweeps without the idle lanes'
        // work (a lane slow to converge held whole calls: in a crowd's
        // CcdSolve, calls whose last lane swept 3 or more times did half
        // of the sweeps). Not before the third sweep: most lanes end within
        // two, where the scalar solve's set-up would cost what it saves.
        let last_lane = iter >= 2 && lanes.active.bitmask().count_ones() == 1;
        if iter == params.max_iterations || last_lane {
            lanes.scalar |= lanes.active;
            handover.resume = lanes.active;
            handover.resume_iter = iter;
            #[cfg(test)]
            crate::ccd4::tests::note(5, lanes.active.bitmask());
            break;
        }
        if iter > 0 {
            frames = Frames::new(c, pose);
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
                    let hinge = Hinge::new(&frames, pose[j], j, c.axis[j]);
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
                    crate::ccd4::tests::note(0, off_axis.bitmask());
                    lanes.active &= !off_axis;
                    let (q, eff) = hinge.turn(joint_pos, e, new);
                    (q, eff, some)
                }
                _ => {
                    let (axis, half, some) = if j == 0 && (mid_saturated & lanes.active).any() {
                        let b = frames.pos[1].sub(joint_pos);
                        let d = target.sub(joint_pos);
                        let s = sqrt(frames.pos[4].sub(frames.pos[1]).length_squared());
                        let (a2, h2, s2) = ball_reach_step(b, d, s, &cap);
                        if (lanes.active & !mid_saturated).any() {
                            let (a1, h1, s1) = arc_step(e, target.sub(joint_pos), &cap);
                            let m = mid_saturated;
                            (
                                V::select(m, a2, a1),
                                (sel(m, h2.0, h1.0), sel(m, h2.1, h1.1)),
                                msel(m, s2, s1),
                            )
                        } else {
                            // Every active lane takes the girdle reach: the
                            // aiming step would be computed only for idle
                            // lanes, whose results are never applied.
                            (a2, h2, s2)
                        }
                    } else {
                        arc_step(e, target.sub(joint_pos), &cap)
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
                    crate::ccd4::tests::note(1 + j, degenerate.bitmask());
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
        crate::ccd4::tests::note(3, stalled.bitmask());
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
        crate::ccd4::tests::note(4, retry.bitmask());
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
fn hinge_turn_step(hinge: &Hinge, range: &Ranges, eff: V, target: V, cap: &Cap) -> ((F, F), M, M) {
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

/// Where [`solve_impl`] gets the transposed chains.
#[derive(Clone, Copy)]
pub(super) enum Layout<'a> {
    /// Already prepared (`None`: not the sloth layout, scalar solves).
    Prepared(Option<&'a Chains>),
    /// Build them now.
    Build,
}

/// Solve `N` chains, lane `i` exactly `solve(chains[i], roots[i], targets[i],
/// poses[i])` with tolerance `tols[i]`: the vector path where every lane is valid
/// and the parameters are the sloth's (tail-first sweeps with reach steps), else
/// the scalar solver lane by lane.
#[inline(always)]
pub(super) fn solve_impl(
    chains: [&LimbChain; N],
    layout: Layout<'_>,
    roots: [RootTransform; N],
    targets: [Vec3; N],
    poses: &mut [ChainPose; N],
    params: &CcdParams,
    tols: [f32; N],
) -> [CcdResult; N] {
    // Without stops (`STOP` false: the checks compile away, the same code as
    // a kernel without them).
    let mut stopped = false;
    solve_impl_unless::<false>(
        chains,
        layout,
        roots,
        targets,
        poses,
        params,
        tols,
        [f32::INFINITY; N],
        &mut stopped,
    )
}

/// [`solve_impl`] with stops where `STOP` (else `stop` is not read): setting
/// `stopped` as soon as it is known that some lane `i` ends farther than
/// `stop[i]` from its target (`stop[i]` at least `tols[i]`): the lanes handed
/// to the scalar solver are finished in lane order, and those after the first
/// one that ends beyond its `stop` are left unsolved (their results and poses
/// anything). Otherwise every lane as [`solve_impl`], bit for bit, and
/// `stopped` is left as it was. Two builds of one kernel: with `STOP` false
/// (CcdSolve's) every stop test is a constant and folds away, so its code is
/// that of a kernel without stops.
#[inline(always)]
#[allow(clippy::too_many_arguments, reason = "solve_impl's arguments and the stops")]
pub(super) fn solve_impl_unless<const STOP: bool>(
    chains: [&LimbChain; N],
    layout: Layout<'_>,
    roots: [RootTransform; N],
    targets: [Vec3; N],
    poses: &mut [ChainPose; N],
    params: &CcdParams,
    tols: [f32; N],
    stop: [f32; N],
    stopped: &mut bool,
) -> [CcdResult; N] {
    let vector = params.order == CcdOrder::TailFirst && params.reach_step;
    if let (true, Layout::Prepared(Some(c))) = (vector, layout)
        && let Some(inputs) = Inputs::gather(&roots, &targets, poses, params, &tols)
    {
        return run::<STOP>(chains, c, inputs, poses, params, &stop, stopped);
    }
    let lane_params: [CcdParams; N] = std::array::from_fn(|i| CcdParams {
        tolerance: tols[i],
        ..*params
    });
    let mut results = [CcdResult::rejected(CcdStatus::InvalidTarget); N];
    let mut valid = [false; N];
    let mut local = [Vec3A::ZERO; N];
    for i in 0..N {
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
    if valid == [true; N] && vector {
        let built;
        let c = match layout {
            Layout::Prepared(c) => c,
            Layout::Build => {
                built = Chains::new(chains);
                built.as_ref()
            }
        };
        if let Some(c) = c {
            let inputs = Inputs {
                target: V::gather(local),
                tols: F::from_array(tols),
                pose: gather_poses(poses),
            };
            return run::<STOP>(chains, c, inputs, poses, params, &stop, stopped);
        }
    }
    for i in 0..N {
        if valid[i] {
            results[i] = solve_local_dispatch(chains[i], local[i], &mut poses[i], &lane_params[i]);
        }
    }
    if STOP && (0..N).any(|i| results[i].error > stop[i]) {
        *stopped = true;
    }
    results
}

/// The vector path's inputs: the targets in the chain-root frames, the
/// tolerances and the warm-start poses, lane by lane.
struct Inputs {
    target: V,
    tols: F,
    pose: [Q; CHAIN_JOINTS],
}

impl Inputs {
    /// The inputs of `N` lanes that all pass the scalar solver's checks
    /// (valid parameters, finite target and root, finite pose), all lanes at
    /// once; `None` where one does not (the lane-by-lane checks decide).
    /// `root.inverse_transform_point(target)` in lanes: `rotation⁻¹ · (target −
    /// position)`, glam's `inverse` being its conjugate and `Quat * Vec3A` the
    /// formula of [`Q::rotate`]: the same bits.
    #[inline(always)]
    fn gather(
        roots: &[RootTransform; N],
        targets: &[Vec3; N],
        poses: &[ChainPose; N],
        params: &CcdParams,
        tols: &[f32; N],
    ) -> Option<Inputs> {
        // The lanes' parameters differ in their tolerance only: validate the
        // rest once (with a valid tolerance), then each tolerance (`> 0`, NaN
        // fails, +∞ passes: as `CcdParams::validate`).
        let shared = CcdParams {
            tolerance: 1.0,
            ..*params
        };
        if shared.validate().is_err() {
            return None;
        }
        let tols = F::from_array(*tols);
        let position = V::gather(roots.map(|r| r.position));
        let rotation = Q::gather(roots.map(|r| r.rotation));
        let target = V::gather(targets.map(Vec3A::from));
        let pose = gather_poses(poses);
        // (Functions, not closures: closures do not inherit the caller's
        // target features, and the eight-lane kernel's AVX must inline.)
        #[inline(always)]
        fn finite(x: F) -> M {
            x.abs().cmplt(splat(f32::INFINITY))
        }
        #[inline(always)]
        fn finite_v(v: &V) -> M {
            finite(v.x) & finite(v.y) & finite(v.z)
        }
        let mut ok = tols.cmpgt(F::ZERO) & finite_v(&position) & finite_v(&target);
        ok &= finite_v(&rotation.xyz()) & finite(rotation.w);
        for q in &pose {
            ok &= finite_v(&q.xyz()) & finite(q.w);
        }
        if ok.bitmask() != (1 << N) - 1 {
            return None;
        }
        Some(Inputs {
            target: rotation.conjugate().rotate(target.sub(position)),
            tols,
            pose,
        })
    }
}

/// The lanes' poses, joint by joint.
#[inline(always)]
fn gather_poses(poses: &[ChainPose; N]) -> [Q; CHAIN_JOINTS] {
    let mut pose = [Q::IDENTITY; CHAIN_JOINTS];
    for (j, q) in pose.iter_mut().enumerate() {
        *q = Q::gather(poses.map(|p| p.0[j]));
    }
    pose
}

/// The vector path for `N` valid lanes (`poses`: their warm starts, the
/// same as `inputs.pose`), then the scalar solver for the lanes that left it,
/// in lane order; `stopped` set once one of those ends beyond its `stop` (see
/// [`solve_impl_unless`]; a lane the vector path finishes has reached its
/// tolerance, within its `stop`).
#[inline(always)]
fn run<const STOP: bool>(
    chains: [&LimbChain; N],
    c: &Chains,
    inputs: Inputs,
    poses: &mut [ChainPose; N],
    params: &CcdParams,
    stop: &[f32; N],
    stopped: &mut bool,
) -> [CcdResult; N] {
    let Inputs {
        target,
        tols,
        mut pose,
    } = inputs;
    let (scalar, iterations, err_sq, h) = sweeps(c, target, &mut pose, params, tols);
    let error = sqrt(err_sq);
    // The scalar lanes' warm starts, before `poses` is overwritten.
    let scalar_bits = scalar.bitmask();
    let start = if scalar_bits != 0 { *poses } else { [ChainPose::NEUTRAL; N] };
    for (j, q) in pose.iter().enumerate() {
        for (p, q) in poses.iter_mut().zip(q.scatter()) {
            p.0[j] = q;
        }
    }
    let (error_a, iterations_a) = (error.to_array(), iterations.to_array());
    let mut results: [CcdResult; N] = std::array::from_fn(|i| CcdResult {
        reached: true,
        error: error_a[i],
        iterations: iterations_a[i] as u32,
        status: CcdStatus::Reached,
    });
    if scalar_bits == 0 {
        return results;
    }
    let local = target.scatter();
    let tols = tols.to_array();
    for i in 0..N {
        if scalar_bits & (1 << i) == 0 {
            continue;
        }
        let params = &CcdParams {
            tolerance: tols[i],
            ..*params
        };
        #[cfg(test)]
        crate::ccd4::tests::SCALAR_LANES.with(|n| n.set(n.get() + 1));
        let start_err = lane(h.start_err, i);
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
            let prev_err = lane(h.stall_prev_err, i);
            let from = SweepFrom {
                iter: lane(h.stall_iter, i) as u32 + 1,
                prev_err,
                err_sq: prev_err * prev_err,
                reach_step: false,
            };
            resume(&mut poses[i], from)
        } else if h.resume.test(i) {
            // The scalar solve goes on from the next sweep (none left at
            // `max_iterations`: it polishes from this pose).
            let from = SweepFrom {
                iter: h.resume_iter,
                prev_err: error_a[i],
                err_sq: lane(err_sq, i),
                reach_step: true,
            };
            resume(&mut poses[i], from)
        } else if h.smooth.test(i) {
            smooth_guard_dispatch(
                chains[i],
                local[i],
                &start[i],
                start_err,
                &mut poses[i],
                params,
                results[i],
            )
        } else {
            poses[i] = start[i];
            solve_local_dispatch(chains[i], local[i], &mut poses[i], params)
        };
        if STOP && results[i].error > stop[i] {
            *stopped = true;
            return results;
        }
    }
    results
}
/// Joints 1..3 and the effector in world space, lane `i` exactly `fk(roots[i],
/// &poses[i])[1..5]` of its chain (the forward kinematics of
/// [`LimbChain::fk_local`] in SIMD lanes, its operations in its order; index 3
/// is the effector).
#[inline(always)]
pub(super) fn fk_joints(
    c: &Chains,
    (first_pos, first_rest): (V, Q),
    roots: &[RootTransform; N],
    poses: &[ChainPose; N],
) -> [[Vec3; 4]; N] {
    let mut pose = [Q::IDENTITY; CHAIN_JOINTS];
    for (j, q) in pose.iter_mut().enumerate() {
        *q = Q::gather(poses.map(|p| p.0[j]));
    }
    let rot = Q::gather(roots.map(|r| r.rotation));
    let pos = V::gather(roots.map(|r| r.position));
    let mut world = [[Vec3::ZERO; 4]; N];
    let mut parent_pos = first_pos;
    let mut parent_rot = first_rest.mul(pose[0]);
    for (k, ((offset, rest), q)) in c.offsets.iter().zip(&c.rest).zip(&pose).skip(1).enumerate() {
        parent_pos = parent_pos.add(parent_rot.rotate(*offset));
        parent_rot = parent_rot.mul(*rest).mul(*q);
        // `RootTransform::transform_point`: `position + rotation * p`.
        let w = pos.add(rot.rotate(parent_pos)).scatter();
        for (lane, p) in world.iter_mut().zip(w) {
            lane[k] = Vec3::from(p);
        }
    }
    let local = parent_pos.add(parent_rot.rotate(c.effector));
    let w = pos.add(rot.rotate(local)).scatter();
    for (lane, p) in world.iter_mut().zip(w) {
        lane[3] = Vec3::from(p);
    }
    world
}

/// The forward kinematics' first joint before its pose: its position
/// (`0 + 1 · offset₀`) and `1 · rest₀`, the operations
/// [`LimbChain::fk_local`] starts with (constants of the chains).
#[inline(always)]
pub(super) fn fk_first(c: &Chains) -> (V, Q) {
    (
        V::ZERO.add(Q::IDENTITY.rotate(c.offsets[0])),
        Q::IDENTITY.mul(c.rest[0]),
    )
}
