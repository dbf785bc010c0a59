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
        normal[i] = DVec3::from(g.normal).try_normalize()?;
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
    let all_finite = out.forces.iter().all(|f| f.is_finite())
        && out.residual_force.is_finite()
        && out.residual_torque.is_finite();
    all_finite.then_some(Closed::Inside(out))
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

/// [`LoadParams::validate`] as a test (every parameter finite and > 0), without forming
/// an error.
fn params_valid(p: &LoadParams) -> bool {
    let ok = |v: f64| v > 0.0 && v < f64::INFINITY;
    ok(p.mass_kg)
        && ok(p.gravity)
        && ok(p.mu)
        && ok(p.grip_strength_bw)
        && ok(p.push_strength_bw)
        && ok(p.w_residual)
        && ok(p.w_force)
        && ok(p.residual_arm_m)
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
    let positive = |v: f64| v > 0.0 && v < f64::INFINITY;
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
