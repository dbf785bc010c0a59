//! The closed form without the general problem: the unconstrained optimum through the
//! 6×6 wrench space, formed from the grips directly. Most stances of a crowd end here
//! (the optimum lies strictly inside every grip set), so this path skips building the
//! 6×12 matrix and the 12×12 Hessian the constrained stages need.
//!
//! Stationarity of `w_r |b − A x|² + w_f |x|²` gives `x = ρ Aᵀ r` with the residual
//! `r = b − A x`, hence `(I + ρ A Aᵀ) r = b` (ρ = w_r / w_f). With `d_i` the claw's offset
//! from the centre of mass in units of ℓ, `A Aᵀ = [[k I, −[S]×], [[S]×, Q]]`, `S = Σ d_i`,
//! `Q = Σ (|d_i|² I − d_i d_iᵀ)`, and each grip's force is `ρ (r_F + r_τ × d_i)`.

// Dense index arithmetic on a 6×6 matrix reads best as index loops.
#![allow(clippy::needless_range_loop)]

use glam::DVec3;

use crate::LoadParams;
use crate::model::{GripLoads, MAX_GRIPS, SolveMethod, Stance};

/// The unconstrained optimum if it lies strictly inside every grip set; `None` otherwise,
/// and for anything the general path must judge (invalid parameters or input, more than
/// [`MAX_GRIPS`] grips, no grips).
pub(crate) fn closed_form(params: &LoadParams, stance: &Stance) -> Option<GripLoads> {
    match closed_or_wrench(params, stance)? {
        Closed::Inside(out) => Some(out),
        Closed::Outside(..) => None,
    }
}

/// What the closed form found: the answer, or (when some force leaves its grip set) the
/// problem in wrench space with the unconstrained optimum's residual `r` (scaled), where
/// [`crate::dual`]'s Newton steps can start. Both on the stack, once per solve.
#[allow(clippy::large_enum_variant)]
pub(crate) enum Closed {
    Inside(GripLoads),
    Outside(Wrench, [f64; 6]),
}

/// [`closed_form`], handing back the wrench-space problem when the optimum is not inside.
/// `None` for what only the general path may judge (as [`closed_form`]).
pub(crate) fn closed_or_wrench(params: &LoadParams, stance: &Stance) -> Option<Closed> {
    let k = stance.grips.len();
    if k == 0 || k > MAX_GRIPS || !params_valid(params) {
        return None;
    }
    // One test for every input: `nan_of` is 0 for a finite vector, NaN otherwise.
    let mut nan = nan_of(stance.com) + nan_of(stance.com_acc) + nan_of(stance.ang_mom_rate);
    for g in stance.grips {
        nan += nan_of(g.point) + nan_of(g.normal);
    }
    if nan.is_nan() {
        return None;
    }
    let weight = params.body_weight_n();
    let arm = params.residual_arm_m;
    let rho = params.w_residual / params.w_force;
    let com = DVec3::from(stance.com);
    let mut d = [DVec3::ZERO; MAX_GRIPS];
    let mut sum = DVec3::ZERO;
    for (i, g) in stance.grips.iter().enumerate() {
        d[i] = (DVec3::from(g.point) - com) / arm;
        sum += d[i];
    }
    let need_f =
        (DVec3::from(stance.com_acc) - DVec3::new(0.0, -params.gravity, 0.0)) / params.gravity;
    let need_t = DVec3::from(stance.ang_mom_rate) / (weight * arm);
    let b = [need_f.x, need_f.y, need_f.z, need_t.x, need_t.y, need_t.z];
    let (r_f, r_t) = wrench_solve(&d[..k], sum, rho, need_f, need_t)?;
    let r = [r_f.x, r_f.y, r_f.z, r_t.x, r_t.y, r_t.z];
    let mut out = GripLoads {
        count: k as u8,
        residual_force: (r_f * weight).as_vec3(),
        residual_torque: (r_t * (weight * arm)).as_vec3(),
        method: SolveMethod::ClosedForm,
        ..GripLoads::default()
    };
    let mut normal = [DVec3::Y; MAX_GRIPS];
    let mut inside = true;
    for (i, g) in stance.grips.iter().enumerate() {
        normal[i] = unit(DVec3::from(g.normal))?;
        if !inside {
            continue;
        }
        let x = rho * (r_f + r_t.cross(d[i]));
        // Strictly inside, as the general path demands (NaN fails too): pull and push
        // slacks > 0, and µ(s_n + 2G) > |x_t| compared squared (|x_t|² = |x|² − s_n²).
        let sn = x.dot(normal[i]);
        let cap = params.mu * (sn + 2.0 * params.grip_strength_bw);
        let inside_i = sn > -params.grip_strength_bw
            && sn < params.push_strength_bw
            && cap > 0.0
            && cap * cap > x.length_squared() - sn * sn;
        if !inside_i {
            inside = false;
            continue;
        }
        out.forces[i] = (x * weight).as_vec3();
    }
    if !inside {
        let w = Wrench {
            k,
            d,
            normal,
            b,
            rho,
            mu: params.mu,
            grip: params.grip_strength_bw,
            push: params.push_strength_bw,
            weight,
            arm,
        };
        return r
            .iter()
            .all(|v| v.is_finite())
            .then_some(Closed::Outside(w, r));
    }
    // Every answer finite in f32 (the conversion may overflow), tested as the inputs are.
    let mut nan = nan_of(out.residual_force) + nan_of(out.residual_torque);
    for f in out.forces {
        nan += nan_of(f);
    }
    (!nan.is_nan()).then_some(Closed::Inside(out))
}

/// The scaled problem in wrench space: claw offsets `d` from the centre of mass (units of
/// ℓ), unit normals, the wrench `b` the grips must supply (BW, BW·ℓ) and the parameters.
pub(crate) struct Wrench {
    pub k: usize,
    pub d: [DVec3; MAX_GRIPS],
    pub normal: [DVec3; MAX_GRIPS],
    pub b: [f64; 6],
    /// ρ = w_r / w_f.
    pub rho: f64,
    pub mu: f64,
    /// Grip and push strength (BW).
    pub grip: f64,
    pub push: f64,
    /// Body weight (N) and residual arm (m), to convert back.
    pub weight: f64,
    pub arm: f64,
}

/// `v − v`: zero where `v` is finite, NaN in each component that is not.
#[allow(clippy::eq_op)]
fn nan_of(v: glam::Vec3) -> glam::Vec3 {
    v - v
}

/// `v > 0` and finite (false for NaN), written `v <= f64::MAX` rather than
/// `v < f64::INFINITY` or `v.is_finite()`: the same answer for every `f64`, but LLVM folds
/// those forms into a floating-point class test that x86 lowers to about sixteen integer
/// instructions a value, where this one stays two SSE compares (≈ 190 of the closed
/// form's ≈ 1,160 instructions a call went to such tests; docs/performance.md).
#[inline]
fn positive_finite(v: f64) -> bool {
    (v > 0.0) & (v <= f64::MAX)
}

/// [`LoadParams::validate`] as a test (every parameter finite and > 0), without forming
/// an error. Evaluated without short cuts, so the eight compare as two vectors.
fn params_valid(p: &LoadParams) -> bool {
    positive_finite(p.mass_kg)
        & positive_finite(p.gravity)
        & positive_finite(p.mu)
        & positive_finite(p.grip_strength_bw)
        & positive_finite(p.push_strength_bw)
        & positive_finite(p.w_residual)
        & positive_finite(p.w_force)
        & positive_finite(p.residual_arm_m)
}

/// `v` scaled to unit length, bit for bit glam's `DVec3::try_normalize` (the same
/// reciprocal of the length and product; `None` where that reciprocal is not finite and
/// positive), with its test as [`positive_finite`].
#[inline]
fn unit(v: DVec3) -> Option<DVec3> {
    let rcp = 1.0 / v.length();
    positive_finite(rcp).then(|| v * rcp)
}

/// The residual `(r_F, r_τ)` of the unconstrained optimum: `(I + ρ A Aᵀ) r = b` by block
/// elimination. Its force block is `(1 + ρk) I`, so `r_F = (b_F + ρ S × r_τ) / a`
/// (`a = 1 + ρk`) and `r_τ` solves the 3×3 Schur complement
/// `N = I + ρ Q_c + ρ/(k a) (|S|² I − S Sᵀ)`, right-hand side `b_τ − (ρ/a) S × b_F`, where
/// `Q_c = Σ (|e_i|² I − e_i e_iᵀ)` is formed about the claws' centroid (`e_i = d_i − S/k`),
/// so every term is positive semidefinite and nothing cancels. `None` if `N` is not
/// positive definite (or not finite).
fn wrench_solve(
    d: &[DVec3],
    sum: DVec3,
    rho: f64,
    b_f: DVec3,
    b_t: DVec3,
) -> Option<(DVec3, DVec3)> {
    let k = d.len() as f64;
    let a = 1.0 + rho * k;
    let mean = sum / k;
    let mut q = [0.0; 6]; // xx, yy, zz, xy, xz, yz of Q_c
    for &di in d {
        let e = di - mean;
        let ee = e.length_squared();
        q[0] += ee - e.x * e.x;
        q[1] += ee - e.y * e.y;
        q[2] += ee - e.z * e.z;
        q[3] -= e.x * e.y;
        q[4] -= e.x * e.z;
        q[5] -= e.y * e.z;
    }
    let w = rho / (k * a);
    let ss = sum.length_squared();
    let n00 = 1.0 + rho * q[0] + w * (ss - sum.x * sum.x);
    let n11 = 1.0 + rho * q[1] + w * (ss - sum.y * sum.y);
    let n22 = 1.0 + rho * q[2] + w * (ss - sum.z * sum.z);
    let n10 = rho * q[3] - w * sum.x * sum.y;
    let n20 = rho * q[4] - w * sum.x * sum.z;
    let n21 = rho * q[5] - w * sum.y * sum.z;
    let c = b_t - (rho / a) * sum.cross(b_f);
    let l = chol3([n00, n10, n11, n20, n21, n22])?;
    let z = backward3(&l, forward3(&l, c.to_array()));
    let r_t = DVec3::from_array(z);
    let r_f = (b_f + rho * sum.cross(r_t)) / a;
    (r_f.is_finite() && r_t.is_finite()).then_some((r_f, r_t))
}

/// Lower Cholesky factor `[l00, l10, l11, l20, l21, l22]` of the symmetric 3×3 matrix with
/// lower triangle `[a00, a10, a11, a20, a21, a22]`; `None` if not positive definite.
fn chol3(a: [f64; 6]) -> Option<[f64; 6]> {
    let positive = positive_finite;
    if !positive(a[0]) {
        return None;
    }
    let l00 = a[0].sqrt();
    let l10 = a[1] / l00;
    let l20 = a[3] / l00;
    let d11 = a[2] - l10 * l10;
    if !positive(d11) {
        return None;
    }
    let l11 = d11.sqrt();
    let l21 = (a[4] - l20 * l10) / l11;
    let d22 = a[5] - l20 * l20 - l21 * l21;
    if !positive(d22) {
        return None;
    }
    Some([l00, l10, l11, l20, l21, d22.sqrt()])
}

/// `L⁻¹ b` for a [`chol3`] factor.
fn forward3(l: &[f64; 6], b: [f64; 3]) -> [f64; 3] {
    let y0 = b[0] / l[0];
    let y1 = (b[1] - l[1] * y0) / l[2];
    let y2 = (b[2] - l[3] * y0 - l[4] * y1) / l[5];
    [y0, y1, y2]
}

/// `L⁻ᵀ y` for a [`chol3`] factor.
fn backward3(l: &[f64; 6], y: [f64; 3]) -> [f64; 3] {
    let x2 = y[2] / l[5];
    let x1 = (y[1] - l[4] * x2) / l[2];
    let x0 = (y[0] - l[1] * x1 - l[3] * x2) / l[0];
    [x0, x1, x2]
}

/// Solve `M y = b` for symmetric positive definite 6×6 `M` (its lower triangle is read)
/// by block Cholesky: `M = [[P, Bᵀ], [B, C]]`, `P = L_P L_Pᵀ`, `W = B L_P⁻ᵀ`, and the
/// Schur complement `C − W Wᵀ = L_S L_Sᵀ` (3×3 factors throughout); `None` if not
/// positive definite.
pub(crate) fn cholesky6(m: &[[f64; 6]; 6], b: [f64; 6]) -> Option<[f64; 6]> {
    let lp = chol3([m[0][0], m[1][0], m[1][1], m[2][0], m[2][1], m[2][2]])?;
    let w: [[f64; 3]; 3] =
        std::array::from_fn(|r| forward3(&lp, [m[3 + r][0], m[3 + r][1], m[3 + r][2]]));
    let dot = |a: &[f64; 3], c: &[f64; 3]| a[0] * c[0] + a[1] * c[1] + a[2] * c[2];
    let ls = chol3([
        m[3][3] - dot(&w[0], &w[0]),
        m[4][3] - dot(&w[1], &w[0]),
        m[4][4] - dot(&w[1], &w[1]),
        m[5][3] - dot(&w[2], &w[0]),
        m[5][4] - dot(&w[2], &w[1]),
        m[5][5] - dot(&w[2], &w[2]),
    ])?;
    let y1 = forward3(&lp, [b[0], b[1], b[2]]);
    let y2 = forward3(
        &ls,
        [
            b[3] - dot(&w[0], &y1),
            b[4] - dot(&w[1], &y1),
            b[5] - dot(&w[2], &y1),
        ],
    );
    let x2 = backward3(&ls, y2);
    let x1 = backward3(
        &lp,
        [
            y1[0] - (w[0][0] * x2[0] + w[1][0] * x2[1] + w[2][0] * x2[2]),
            y1[1] - (w[0][1] * x2[0] + w[1][1] * x2[1] + w[2][1] * x2[2]),
            y1[2] - (w[0][2] * x2[0] + w[1][2] * x2[1] + w[2][2] * x2[2]),
        ],
    );
    Some([x1[0], x1[1], x1[2], x2[0], x2[1], x2[2]])
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// Values at every class boundary of an `f64`, both signs.
    fn special() -> Vec<f64> {
        let pos = [
            0.0,
            f64::from_bits(1),
            f64::MIN_POSITIVE / 2.0,
            f64::MIN_POSITIVE,
            1e-300,
            0.2,
            1.0,
            9.81,
            1e4,
            1e300,
            f64::MAX,
            f64::INFINITY,
            f64::NAN,
        ];
        pos.iter().flat_map(|&v| [v, -v]).collect()
    }

    /// Random bit patterns (every exponent, NaN payloads included) and random values of
    /// every magnitude.
    fn random(rng: &mut Pcg64) -> f64 {
        match rng.random_range(0..3) {
            0 => f64::from_bits(rng.random()),
            1 => rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(-320..=308)),
            _ => special()[rng.random_range(0..special().len())],
        }
    }

    #[test]
    fn positive_finite_is_the_class_test() {
        let old = |v: f64| v > 0.0 && v < f64::INFINITY;
        for v in special() {
            assert_eq!(positive_finite(v), old(v), "{v:e}");
            assert_eq!(positive_finite(v), v.is_finite() && v > 0.0, "{v:e}");
        }
        let mut rng = Pcg64::seed_from_u64(61);
        for _ in 0..1_000_000 {
            let v = random(&mut rng);
            assert_eq!(positive_finite(v), old(v), "{v:e} ({:#x})", v.to_bits());
        }
    }

    #[test]
    fn summed_nan_of_is_all_finite() {
        let mut rng = Pcg64::seed_from_u64(64);
        let f32s = |rng: &mut Pcg64| match rng.random_range(0..4) {
            0 => f32::from_bits(rng.random()),
            1 => [
                0.0,
                -0.0,
                f32::MAX,
                -f32::MAX,
                f32::INFINITY,
                f32::NEG_INFINITY,
                f32::NAN,
            ][rng.random_range(0..7)],
            _ => rng.random_range(-1e3..1e3),
        };
        for _ in 0..1_000_000 {
            let v: [glam::Vec3; 6] = std::array::from_fn(|_| {
                glam::Vec3::new(f32s(&mut rng), f32s(&mut rng), f32s(&mut rng))
            });
            let mut nan = nan_of(v[0]) + nan_of(v[1]);
            for f in &v[2..] {
                nan += nan_of(*f);
            }
            assert_eq!(!nan.is_nan(), v.iter().all(|f| f.is_finite()), "{v:?}");
        }
    }

    #[test]
    fn params_valid_is_validate() {
        let mut rng = Pcg64::seed_from_u64(62);
        for n in 0..200_000 {
            let mut v = [
                8.0, 9.81, 0.6, 1.0, 1.0, 1.0e4, 1.0, 0.2, // the defaults
            ];
            // Mostly one field off, sometimes several.
            for _ in 0..1 + n % 3 {
                v[rng.random_range(0..8)] = random(&mut rng);
            }
            let p = LoadParams {
                mass_kg: v[0],
                gravity: v[1],
                mu: v[2],
                grip_strength_bw: v[3],
                push_strength_bw: v[4],
                w_residual: v[5],
                w_force: v[6],
                residual_arm_m: v[7],
            };
            assert_eq!(params_valid(&p), p.validate().is_ok(), "{p:?}");
        }
        assert!(params_valid(&LoadParams::default()));
    }

    #[test]
    fn unit_is_try_normalize_bit_for_bit() {
        let bits = |v: Option<DVec3>| v.map(|v| v.to_array().map(f64::to_bits));
        let mut rng = Pcg64::seed_from_u64(63);
        for n in 0..1_000_000 {
            let v = if n % 4 == 0 {
                DVec3::new(random(&mut rng), random(&mut rng), random(&mut rng))
            } else {
                // Normals as the stage hands them (f32, near unit length), and any scale.
                let s = 10f64.powi(rng.random_range(-160..=160));
                DVec3::from(glam::Vec3::new(
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                    rng.random_range(-1.0..1.0),
                )) * if n % 4 == 1 { s } else { 1.0 }
            };
            assert_eq!(bits(unit(v)), bits(v.try_normalize()), "{v:?}");
        }
        for x in special() {
            for v in [
                DVec3::new(x, 0.0, 0.0),
                DVec3::new(0.0, x, 1.0),
                DVec3::splat(x),
            ] {
                assert_eq!(bits(unit(v)), bits(v.try_normalize()), "{v:?}");
            }
        }
    }
}
