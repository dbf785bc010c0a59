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
use crate::model::{GripLoads, MAX_GRIPS, SolveMethod, Stance, slacks_scaled};

/// The unconstrained optimum if it lies strictly inside every grip set; `None` otherwise,
/// and for anything the general path must judge (invalid parameters or input, more than
/// [`MAX_GRIPS`] grips, no grips).
pub(crate) fn closed_form(params: &LoadParams, stance: &Stance) -> Option<GripLoads> {
    let k = stance.grips.len();
    if k == 0 || k > MAX_GRIPS || params.validate().is_err() {
        return None;
    }
    let finite = stance.com.is_finite()
        && stance.com_acc.is_finite()
        && stance.ang_mom_rate.is_finite()
        && stance
            .grips
            .iter()
            .all(|g| g.point.is_finite() && g.normal.is_finite());
    if !finite {
        return None;
    }
    let weight = params.body_weight_n();
    let arm = params.residual_arm_m;
    let rho = params.w_residual / params.w_force;
    let com = DVec3::from(stance.com);
    let mut d = [DVec3::ZERO; MAX_GRIPS];
    let mut sum = DVec3::ZERO;
    let mut q = [[0.0; 3]; 3];
    for (i, g) in stance.grips.iter().enumerate() {
        d[i] = (DVec3::from(g.point) - com) / arm;
        sum += d[i];
        let dd = d[i].length_squared();
        let di = d[i].to_array();
        for r in 0..3 {
            for c in 0..3 {
                q[r][c] += if r == c { dd } else { 0.0 } - di[r] * di[c];
            }
        }
    }
    // M = I + ρ A Aᵀ; [S]× v = S × v.
    let s = sum.to_array();
    let cross = [[0.0, -s[2], s[1]], [s[2], 0.0, -s[0]], [-s[1], s[0], 0.0]];
    let mut m = [[0.0; 6]; 6];
    for r in 0..3 {
        for c in 0..3 {
            m[r][c] = if r == c { k as f64 } else { 0.0 };
            m[r][3 + c] = -cross[r][c];
            m[3 + r][c] = cross[r][c];
            m[3 + r][3 + c] = q[r][c];
        }
    }
    for r in 0..6 {
        for c in 0..6 {
            m[r][c] = rho * m[r][c] + if r == c { 1.0 } else { 0.0 };
        }
    }
    let need_f =
        (DVec3::from(stance.com_acc) - DVec3::new(0.0, -params.gravity, 0.0)) / params.gravity;
    let need_t = DVec3::from(stance.ang_mom_rate) / (weight * arm);
    let b = [need_f.x, need_f.y, need_f.z, need_t.x, need_t.y, need_t.z];
    let r = cholesky6(&mut m, b)?;
    let r_f = DVec3::new(r[0], r[1], r[2]);
    let r_t = DVec3::new(r[3], r[4], r[5]);
    let mut out = GripLoads {
        count: k as u8,
        residual_force: (r_f * weight).as_vec3(),
        residual_torque: (r_t * (weight * arm)).as_vec3(),
        method: SolveMethod::ClosedForm,
        ..GripLoads::default()
    };
    for (i, g) in stance.grips.iter().enumerate() {
        let n = DVec3::from(g.normal).try_normalize()?;
        let x = rho * (r_f + r_t.cross(d[i]));
        let (u, p, c) = slacks_scaled(
            params.mu,
            params.grip_strength_bw,
            params.push_strength_bw,
            n,
            x,
        );
        // Strictly inside, as the general path demands (NaN fails too).
        if !(u > 0.0 && p > 0.0 && c > 0.0) {
            return None;
        }
        out.forces[i] = (x * weight).as_vec3();
    }
    let all_finite = out.forces.iter().all(|f| f.is_finite())
        && out.residual_force.is_finite()
        && out.residual_torque.is_finite();
    all_finite.then_some(out)
}

/// Solve `M y = b` for symmetric positive definite 6×6 `M` (overwritten) by Cholesky;
/// `None` if not positive definite.
fn cholesky6(m: &mut [[f64; 6]; 6], b: [f64; 6]) -> Option<[f64; 6]> {
    for j in 0..6 {
        let mut dj = m[j][j];
        for k in 0..j {
            dj -= m[j][k] * m[j][k];
        }
        if dj.is_nan() || dj <= 0.0 || dj.is_infinite() {
            return None;
        }
        let dj = dj.sqrt();
        m[j][j] = dj;
        for i in j + 1..6 {
            let mut s = m[i][j];
            for k in 0..j {
                s -= m[i][k] * m[j][k];
            }
            m[i][j] = s / dj;
        }
    }
    let mut y = b;
    for i in 0..6 {
        for k in 0..i {
            y[i] -= m[i][k] * y[k];
        }
        y[i] /= m[i][i];
    }
    for i in (0..6).rev() {
        for k in i + 1..6 {
            y[i] -= m[k][i] * y[k];
        }
        y[i] /= m[i][i];
    }
    Some(y)
}
