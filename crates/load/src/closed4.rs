//! [`closed_or_wrench`](crate::closed::closed_or_wrench) for four stances at once: the
//! same operations in the same order on four `f64` lanes (one AVX register where the CPU
//! has AVX2), so each lane's answer is the scalar call's bit for bit (Rust never fuses a
//! multiply and an add, and the square roots and divisions are IEEE in either form).
//! The branches of the scalar form become per-lane masks: a lane fails where the scalar
//! call returns `None`, and a grip past a stance's count leaves its lane's sums as they
//! were (selected, not added). The GripLoad stage solves a chunk's sloths four by four
//! (`solve_warm4`).

// Lane loops over fixed-size arrays read best as index loops.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, Div, Mul, Sub};

use glam::DVec3;

use crate::LoadParams;
use crate::closed::{Closed, Wrench, nan_of, params_valid};
use crate::model::{GripLoads, MAX_GRIPS, SolveMethod, Stance};

/// Lanes.
const W: usize = 4;

/// Four `f64`s, one per stance.
#[derive(Clone, Copy)]
struct L([f64; W]);

/// A mask, one per lane.
type Mask = [bool; W];

impl L {
    #[inline(always)]
    fn splat(v: f64) -> L {
        L([v; W])
    }
    #[inline(always)]
    fn sqrt(self) -> L {
        let mut o = self.0;
        for v in &mut o {
            *v = v.sqrt();
        }
        L(o)
    }
    #[inline(always)]
    fn lane(self, i: usize) -> f64 {
        self.0[i]
    }
    /// `m ? a : b`, lane by lane.
    #[inline(always)]
    fn sel(m: Mask, a: L, b: L) -> L {
        let mut o = b.0;
        for i in 0..W {
            if m[i] {
                o[i] = a.0[i];
            }
        }
        L(o)
    }
    /// `(v > 0) & (v <= f64::MAX)` lane by lane (the scalar `positive_finite`).
    #[inline(always)]
    fn positive_finite(self) -> Mask {
        let mut m = [false; W];
        for i in 0..W {
            m[i] = (self.0[i] > 0.0) & (self.0[i] <= f64::MAX);
        }
        m
    }
    /// `v.is_finite()` lane by lane.
    #[inline(always)]
    fn finite(self) -> Mask {
        let mut m = [false; W];
        for i in 0..W {
            m[i] = self.0[i].is_finite();
        }
        m
    }
}

macro_rules! lane_op {
    ($tr:ident, $f:ident, $op:tt) => {
        impl $tr for L {
            type Output = L;
            #[inline(always)]
            fn $f(self, o: L) -> L {
                let mut r = self.0;
                for i in 0..W {
                    r[i] = r[i] $op o.0[i];
                }
                L(r)
            }
        }
    };
}
lane_op!(Add, add, +);
lane_op!(Sub, sub, -);
lane_op!(Mul, mul, *);
lane_op!(Div, div, /);

/// A `DVec3` per lane.
#[derive(Clone, Copy)]
struct V {
    x: L,
    y: L,
    z: L,
}

impl V {
    const ZERO: V = V {
        x: L([0.0; W]),
        y: L([0.0; W]),
        z: L([0.0; W]),
    };
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
    /// `self * s` (glam's `DVec3 * f64`, and `f64 * DVec3`: the same products).
    #[inline(always)]
    fn scale(self, s: L) -> V {
        V {
            x: self.x * s,
            y: self.y * s,
            z: self.z * s,
        }
    }
    #[inline(always)]
    fn div(self, s: L) -> V {
        V {
            x: self.x / s,
            y: self.y / s,
            z: self.z / s,
        }
    }
    /// glam's `dot`: `(x·x') + (y·y') + (z·z')`, left to right.
    #[inline(always)]
    fn dot(self, o: V) -> L {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    /// glam's `cross`.
    #[inline(always)]
    fn cross(self, o: V) -> V {
        V {
            x: self.y * o.z - o.y * self.z,
            y: self.z * o.x - o.z * self.x,
            z: self.x * o.y - o.x * self.y,
        }
    }
    #[inline(always)]
    fn sel(m: Mask, a: V, b: V) -> V {
        V {
            x: L::sel(m, a.x, b.x),
            y: L::sel(m, a.y, b.y),
            z: L::sel(m, a.z, b.z),
        }
    }
    #[inline(always)]
    fn finite(self) -> Mask {
        let (x, y, z) = (self.x.finite(), self.y.finite(), self.z.finite());
        std::array::from_fn(|i| x[i] & y[i] & z[i])
    }
    #[inline(always)]
    fn lane(self, i: usize) -> DVec3 {
        DVec3::new(self.x.lane(i), self.y.lane(i), self.z.lane(i))
    }
    /// Lane `i` set to `v`.
    #[inline(always)]
    fn set(&mut self, i: usize, v: DVec3) {
        self.x.0[i] = v.x;
        self.y.0[i] = v.y;
        self.z.0[i] = v.z;
    }
}

/// [`crate::closed::closed_or_wrench`] of each stance, lane by lane bit for bit (`None`
/// lanes: no stance, and `None` answers).
pub(crate) fn closed_or_wrench4(
    params: &LoadParams,
    stances: [Option<&Stance<'_>>; W],
) -> [Option<Closed>; W] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has AVX2 (checked just above), the one requirement for
        // calling a `target_feature(enable = "avx2")` function.
        return unsafe { closed4_avx2(params, stances) };
    }
    closed4(params, stances)
}

/// [`closed4`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn closed4_avx2(params: &LoadParams, stances: [Option<&Stance<'_>>; W]) -> [Option<Closed>; W] {
    closed4(params, stances)
}

#[inline(always)]
fn closed4(params: &LoadParams, stances: [Option<&Stance<'_>>; W]) -> [Option<Closed>; W] {
    let mut out: [Option<Closed>; W] = [None, None, None, None];
    if !params_valid(params) {
        return out;
    }
    // The lanes' inputs; a lane without a stance, or whose stance the scalar call
    // rejects before any arithmetic, stays out of `live` (its inputs zero).
    let mut live = [false; W];
    let mut k = [0usize; W];
    let (mut com, mut acc, mut amr) = (V::ZERO, V::ZERO, V::ZERO);
    let mut point = [V::ZERO; MAX_GRIPS];
    let mut normal_in = [V::ZERO; MAX_GRIPS];
    for l in 0..W {
        let Some(s) = stances[l] else { continue };
        let n = s.grips.len();
        if n == 0 || n > MAX_GRIPS {
            continue;
        }
        let mut nan = nan_of(s.com) + nan_of(s.com_acc) + nan_of(s.ang_mom_rate);
        for g in s.grips {
            nan += nan_of(g.point) + nan_of(g.normal);
        }
        if nan.is_nan() {
            continue;
        }
        live[l] = true;
        k[l] = n;
        com.set(l, DVec3::from(s.com));
        acc.set(l, DVec3::from(s.com_acc));
        amr.set(l, DVec3::from(s.ang_mom_rate));
        for (i, g) in s.grips.iter().enumerate() {
            point[i].set(l, DVec3::from(g.point));
            normal_in[i].set(l, DVec3::from(g.normal));
        }
    }
    if !live.iter().any(|&b| b) {
        return out;
    }
    let has: [Mask; MAX_GRIPS] = std::array::from_fn(|i| std::array::from_fn(|l| i < k[l]));
    let weight = params.body_weight_n();
    let arm = params.residual_arm_m;
    let rho = params.w_residual / params.w_force;
    let (arm_l, rho_l) = (L::splat(arm), L::splat(rho));
    let mut d = [V::ZERO; MAX_GRIPS];
    let mut sum = V::ZERO;
    for i in 0..MAX_GRIPS {
        d[i] = V::sel(has[i], point[i].sub(com).div(arm_l), V::ZERO);
        sum = V::sel(has[i], sum.add(d[i]), sum);
    }
    let g = L::splat(params.gravity);
    let need_f = acc
        .sub(V {
            x: L::splat(0.0),
            y: L::splat(-params.gravity),
            z: L::splat(0.0),
        })
        .div(g);
    let need_t = amr.div(L::splat(weight * arm));
    // `wrench_solve`.
    let kf = L(k.map(|n| n as f64));
    let one = L::splat(1.0);
    let a = one + rho_l * kf;
    let mean = sum.div(kf);
    let mut q = [L::splat(0.0); 6];
    for i in 0..MAX_GRIPS {
        let e = d[i].sub(mean);
        let ee = e.dot(e);
        let m = has[i];
        q[0] = L::sel(m, q[0] + (ee - e.x * e.x), q[0]);
        q[1] = L::sel(m, q[1] + (ee - e.y * e.y), q[1]);
        q[2] = L::sel(m, q[2] + (ee - e.z * e.z), q[2]);
        q[3] = L::sel(m, q[3] - e.x * e.y, q[3]);
        q[4] = L::sel(m, q[4] - e.x * e.z, q[4]);
        q[5] = L::sel(m, q[5] - e.y * e.z, q[5]);
    }
    let w = rho_l / (kf * a);
    let ss = sum.dot(sum);
    let n00 = one + rho_l * q[0] + w * (ss - sum.x * sum.x);
    let n11 = one + rho_l * q[1] + w * (ss - sum.y * sum.y);
    let n22 = one + rho_l * q[2] + w * (ss - sum.z * sum.z);
    let n10 = rho_l * q[3] - w * sum.x * sum.y;
    let n20 = rho_l * q[4] - w * sum.x * sum.z;
    let n21 = rho_l * q[5] - w * sum.y * sum.z;
    let c = need_t.sub(sum.cross(need_f).scale(rho_l / a));
    // `chol3`.
    let ok0 = n00.positive_finite();
    let l00 = n00.sqrt();
    let l10 = n10 / l00;
    let l20 = n20 / l00;
    let d11 = n11 - l10 * l10;
    let ok1 = d11.positive_finite();
    let l11 = d11.sqrt();
    let l21 = (n21 - l20 * l10) / l11;
    let d22 = n22 - l20 * l20 - l21 * l21;
    let ok2 = d22.positive_finite();
    let l22 = d22.sqrt();
    // `forward3`, `backward3`.
    let y0 = c.x / l00;
    let y1 = (c.y - l10 * y0) / l11;
    let y2 = (c.z - l20 * y0 - l21 * y1) / l22;
    let x2 = y2 / l22;
    let x1 = (y1 - l21 * x2) / l11;
    let x0 = (y0 - l10 * x1 - l20 * x2) / l00;
    let r_t = V {
        x: x0,
        y: x1,
        z: x2,
    };
    let r_f = need_f.add(sum.cross(r_t).scale(rho_l)).div(a);
    let (fin_f, fin_t) = (r_f.finite(), r_t.finite());
    for l in 0..W {
        live[l] &= ok0[l] & ok1[l] & ok2[l] & fin_f[l] & fin_t[l];
    }
    // The grips: unit normals (a lane whose normal is not fails), forces, inside.
    let mut normal = [V::ZERO; MAX_GRIPS];
    let mut x = [V::ZERO; MAX_GRIPS];
    let mut inside = [true; W];
    let (mu, grip) = (L::splat(params.mu), L::splat(params.grip_strength_bw));
    for i in 0..MAX_GRIPS {
        let rcp = one / normal_in[i].dot(normal_in[i]).sqrt();
        let unit_ok = rcp.positive_finite();
        normal[i] = normal_in[i].scale(rcp);
        x[i] = r_f.add(r_t.cross(d[i])).scale(rho_l);
        let sn = x[i].dot(normal[i]);
        let cap = mu * (sn + L::splat(2.0) * grip);
        let lhs = cap * cap;
        let rhs = x[i].dot(x[i]) - sn * sn;
        for l in 0..W {
            if has[i][l] {
                live[l] &= unit_ok[l];
                let sn = sn.lane(l);
                inside[l] &= sn > -params.grip_strength_bw
                    && sn < params.push_strength_bw
                    && cap.lane(l) > 0.0
                    && lhs.lane(l) > rhs.lane(l);
            }
        }
    }
    // Each lane's answer, as the scalar call forms it.
    for l in 0..W {
        if !live[l] {
            continue;
        }
        let (rf, rt) = (r_f.lane(l), r_t.lane(l));
        let r = [rf.x, rf.y, rf.z, rt.x, rt.y, rt.z];
        if inside[l] {
            let mut o = GripLoads {
                count: k[l] as u8,
                residual_force: (rf * weight).as_vec3(),
                residual_torque: (rt * (weight * arm)).as_vec3(),
                method: SolveMethod::ClosedForm,
                ..GripLoads::default()
            };
            for i in 0..k[l] {
                o.forces[i] = (x[i].lane(l) * weight).as_vec3();
            }
            let mut nan = nan_of(o.residual_force) + nan_of(o.residual_torque);
            for f in o.forces {
                nan += nan_of(f);
            }
            if !nan.is_nan() {
                out[l] = Some(Closed::Inside(o));
            }
        } else {
            let mut dd = [DVec3::ZERO; MAX_GRIPS];
            let mut nn = [DVec3::Y; MAX_GRIPS];
            for i in 0..k[l] {
                dd[i] = d[i].lane(l);
                nn[i] = normal[i].lane(l);
            }
            let (nf, nt) = (need_f.lane(l), need_t.lane(l));
            let w = Wrench {
                k: k[l],
                d: dd,
                normal: nn,
                b: [nf.x, nf.y, nf.z, nt.x, nt.y, nt.z],
                rho,
                mu: params.mu,
                grip: params.grip_strength_bw,
                push: params.push_strength_bw,
                weight,
                arm,
            };
            if r.iter().all(|v| v.is_finite()) {
                out[l] = Some(Closed::Outside(w, r));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use glam::Vec3;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    use super::*;
    use crate::closed::closed_or_wrench;
    use crate::model::Grip;

    fn v3(rng: &mut Pcg64, half: f32) -> Vec3 {
        Vec3::new(
            rng.random_range(-half..half),
            rng.random_range(-half..half),
            rng.random_range(-half..half),
        )
    }

    /// An input value now and then out of the ordinary: NaN, ±∞, zero, huge, tiny.
    fn odd(rng: &mut Pcg64, v: Vec3) -> Vec3 {
        if rng.random_range(0..60) != 0 {
            return v;
        }
        let x = [
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            0.0,
            1e30,
            1e-30,
            f32::MAX,
        ][rng.random_range(0..7)];
        match rng.random_range(0..4) {
            0 => Vec3::new(x, v.y, v.z),
            1 => Vec3::new(v.x, x, v.z),
            2 => Vec3::new(v.x, v.y, x),
            _ => Vec3::splat(x),
        }
    }

    fn bits3(v: DVec3) -> [u64; 3] {
        v.to_array().map(f64::to_bits)
    }

    fn bitsf(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    /// The two answers the same, bit for bit.
    fn same(a: &Option<Closed>, b: &Option<Closed>) -> bool {
        match (a, b) {
            (None, None) => true,
            (Some(Closed::Inside(a)), Some(Closed::Inside(b))) => {
                a.count == b.count
                    && a.method == b.method
                    && a.iterations == b.iterations
                    && a.active == b.active
                    && bitsf(a.residual_force) == bitsf(b.residual_force)
                    && bitsf(a.residual_torque) == bitsf(b.residual_torque)
                    && (0..MAX_GRIPS).all(|i| bitsf(a.forces[i]) == bitsf(b.forces[i]))
            }
            (Some(Closed::Outside(a, ra)), Some(Closed::Outside(b, rb))) => {
                a.k == b.k
                    && (0..MAX_GRIPS).all(|i| {
                        bits3(a.d[i]) == bits3(b.d[i]) && bits3(a.normal[i]) == bits3(b.normal[i])
                    })
                    && a.b.map(f64::to_bits) == b.b.map(f64::to_bits)
                    && [a.rho, a.mu, a.grip, a.push, a.weight, a.arm].map(f64::to_bits)
                        == [b.rho, b.mu, b.grip, b.push, b.weight, b.arm].map(f64::to_bits)
                    && ra.map(f64::to_bits) == rb.map(f64::to_bits)
            }
            _ => false,
        }
    }

    /// Every lane of [`closed_or_wrench4`] is [`closed_or_wrench`] of its stance, bit
    /// for bit: 40,000 calls of four lanes (some empty), stances of 0 to 5 grips around
    /// the centre of mass (inside and outside the grip sets, several grips at one
    /// point), random parameters (now and then invalid), and now and then a NaN, ±∞,
    /// zero, huge or tiny input value (a zero, huge or tiny normal among them). Both
    /// kinds of answer and `None` must come up often.
    #[test]
    fn four_lanes_are_the_scalar_closed_form_bit_for_bit() {
        let mut rng = Pcg64::seed_from_u64(0x10ad_4);
        let (mut inside, mut outside, mut none) = (0, 0, 0);
        for call in 0..40_000 {
            let mut params = LoadParams {
                mass_kg: rng.random_range(6.5..10.6),
                mu: rng.random_range(0.2..1.2),
                grip_strength_bw: rng.random_range(0.3..2.0),
                push_strength_bw: rng.random_range(0.3..3.0),
                w_residual: 10f64.powf(rng.random_range(2.0..5.0)),
                w_force: 10f64.powf(rng.random_range(-1.0..1.0)),
                residual_arm_m: rng.random_range(0.1..0.4),
                ..LoadParams::default()
            };
            if call % 2 == 0 {
                params = LoadParams::default();
            }
            if call % 997 == 0 {
                params.mu = [0.0, f64::NAN, -1.0][call % 3];
            }
            let grips: [Vec<Grip>; W] = std::array::from_fn(|_| {
                let k = [0, 1, 2, 2, 3, 3, 3, 4, 4, 4, 4, 4, 5][rng.random_range(0..13)];
                let shared = rng.random_range(0..10) == 0;
                let p0 = v3(&mut rng, 0.4);
                (0..k)
                    .map(|_| {
                        let point = if shared { p0 } else { v3(&mut rng, 0.4) };
                        let normal = if rng.random_range(0..3) == 0 {
                            Vec3::Y
                        } else {
                            v3(&mut rng, 1.0)
                        };
                        Grip {
                            point: odd(&mut rng, point),
                            normal: odd(&mut rng, normal),
                        }
                    })
                    .collect()
            });
            let stances: [Stance<'_>; W] = std::array::from_fn(|l| {
                let com = v3(&mut rng, 0.1) + Vec3::new(0.0, -0.2, 0.0);
                let com = odd(&mut rng, com);
                let com_acc = if rng.random_range(0..4) == 0 {
                    Vec3::ZERO
                } else {
                    let a = v3(&mut rng, 3.0);
                    odd(&mut rng, a)
                };
                let ang_mom_rate = if rng.random_range(0..3) == 0 {
                    let t = v3(&mut rng, 1.0);
                    odd(&mut rng, t)
                } else {
                    Vec3::ZERO
                };
                Stance {
                    com,
                    com_acc,
                    ang_mom_rate,
                    grips: &grips[l],
                }
            });
            let lanes: [Option<&Stance<'_>>; W] =
                std::array::from_fn(|l| (rng.random_range(0..8) != 0).then_some(&stances[l]));
            let four = closed_or_wrench4(&params, lanes);
            for l in 0..W {
                let want = lanes[l].and_then(|s| closed_or_wrench(&params, s));
                assert!(
                    same(&four[l], &want),
                    "call {call}, lane {l}: {:?}",
                    lanes[l]
                );
                match want {
                    Some(Closed::Inside(_)) => inside += 1,
                    Some(Closed::Outside(..)) => outside += 1,
                    None => none += 1,
                }
            }
        }
        assert!(
            inside > 10_000 && outside > 10_000 && none > 5_000,
            "{inside} inside, {outside} outside, {none} none"
        );
    }
}
