//! The specialised solver: a closed-form unconstrained optimum when it already lies in
//! every grip set (the common case: a sloth hanging within its grip and friction limits),
//! else a primal log-barrier method (Boyd & Vandenberghe, *Convex Optimization*, §11.3)
//! on ≤ 12 unknowns with dense Cholesky Newton steps, started from the strictly feasible
//! zero force. See the crate README for the measured cost and the proof against clarabel.

// Dense index arithmetic on ≤ 12×12 matrices reads best as index loops.
#![allow(clippy::needless_range_loop)]

use crate::active::{ActiveSet, CONE, PULL, PUSH, cone_active_set, start_set};
use crate::closed::{Closed, Wrench, closed_form, closed_or_wrench};
use crate::dual::{dual_newton, fixed_newton};
use crate::model::{MAX_GRIPS, Problem, slacks_scaled};
use glam::{DVec3, Vec3};

use crate::{GripLoads, LoadError, LoadParams, SolveMethod, Stance};

pub(crate) const N_MAX: usize = 3 * MAX_GRIPS;
pub(crate) type Mat = [[f64; N_MAX]; N_MAX];
pub(crate) type VecN = [f64; N_MAX];

/// Duality-gap bound at which the barrier stops, relative to `w_force`: the force error
/// is then ≤ √(gap / w_force) ≈ 3e-5 BW (the objective is w_force-strongly convex; on the
/// central path it is in practice O(gap), see the comparison with clarabel).
const GAP: f64 = 1.0e-9;
/// Gap accepted when rounding stops the path early (force error in practice ≪ 1e-4 BW).
const LOOSE_GAP: f64 = 1.0e-7;
/// Growth of the barrier parameter between centring steps.
const T_GROWTH: f64 = 16.0;
/// Newton decrement² / 2 at which a centring step is done (the objective is then within
/// this / t of the centre; at large t rounding in the active slacks floors it near 1e-6).
const NEWTON_TOL: f64 = 1.0e-5;
/// A Newton move (BW) below which the centre counts as reached.
const MIN_MOVE: f64 = 1.0e-10;
/// Newton steps allowed in all.
const MAX_NEWTON: u32 = 300;

/// Grip loads by the specialised solver. Errors: invalid parameters or input (named),
/// or a solver failure (never a panic, never NaN).
pub fn solve(params: &LoadParams, stance: &Stance) -> Result<GripLoads, LoadError> {
    solve_from(params, stance, &[0; MAX_GRIPS])
}

/// [`solve`], starting a stance whose friction cones bind from the active set `hint`
/// (per grip, in the order of [`Stance::grips`]: usually the last frame's
/// [`GripLoads::active`]). The answer is the same optimum (the active set is only where
/// the search starts; it is accepted by the KKT conditions of the whole problem), found
/// in fewer Newton steps when the hint is right.
pub fn solve_from(
    params: &LoadParams,
    stance: &Stance,
    hint: &ActiveSet,
) -> Result<GripLoads, LoadError> {
    if let Some(out) = closed_form(params, stance) {
        return Ok(out);
    }
    let p = Problem::new(params, stance)?;
    let (x, iters, method, active) = solve_problem(&p, hint)?;
    let mut out = p.loads(&x[..p.n()], iters)?;
    out.method = method;
    out.active = active;
    Ok(out)
}

/// The GripLoad stage's solve. The closed form as in [`solve_from`]; where its optimum
/// leaves a grip set, Newton's method in wrench space (`dual.rs`: six unknowns, one 6×6
/// Cholesky a step), from the closed form's residual: first with the limits of `hint`
/// held (per grip, in the order of [`Stance::grips`]: usually the last frame's
/// [`GripLoads::active`]), accepted only where the grips' points project onto exactly
/// those limits; else with the regions free to change (`SolveMethod::DualNewton` either
/// way). Where neither converges, [`solve_from`]'s path with the Newton steps of a binding
/// friction cone started from `warm` (per grip, its force in newtons: usually the last
/// frame's answer of the same grips) instead of the unconstrained optimum. Every path
/// ends at the same optimum as a cold solve's (within the convergence tolerance,
/// ≪ 1e-9 BW; `tests/warm_start.rs`, and against clarabel in `tests/vs_clarabel.rs`). A
/// `warm` that is not finite or of another length is ignored.
pub fn solve_warm(
    params: &LoadParams,
    stance: &Stance,
    hint: &ActiveSet,
    warm: &[Vec3],
) -> Result<GripLoads, LoadError> {
    match closed_or_wrench(params, stance) {
        Some(Closed::Inside(out)) => return Ok(out),
        Some(Closed::Outside(w, r0)) => {
            let hinted = hint[..w.k].iter().any(|&b| b != 0);
            let found = hinted
                .then(|| fixed_newton(&w, &r0, hint))
                .flatten()
                .or_else(|| dual_newton(&w, &r0));
            if let Some(out) = found.and_then(|found| dual_loads(&w, found)) {
                return Ok(out);
            }
        }
        None => {}
    }
    let p = Problem::new(params, stance)?;
    let weight = params.body_weight_n();
    let start = (warm.len() == p.k && warm.iter().all(|f| f.is_finite())).then(|| {
        let mut x = [0.0; N_MAX];
        for (i, f) in warm.iter().enumerate() {
            let f = DVec3::from(*f) / weight;
            x[3 * i..3 * i + 3].copy_from_slice(&f.to_array());
        }
        x
    });
    let (x, iters, method, active) = solve_problem_from(&p, hint, start.as_ref())?;
    let mut out = p.loads(&x[..p.n()], iters)?;
    out.method = method;
    out.active = active;
    Ok(out)
}

/// Forces (BW), residual, Newton steps and active limits of [`crate::dual`].
type DualAnswer = ([DVec3; MAX_GRIPS], [f64; 6], u32, ActiveSet);

/// A wrench-space Newton answer in newtons; `None` if anything is not finite.
fn dual_loads(w: &Wrench, found: DualAnswer) -> Option<GripLoads> {
    let (x, r, steps, active) = found;
    let mut out = GripLoads {
        count: w.k as u8,
        residual_force: (DVec3::new(r[0], r[1], r[2]) * w.weight).as_vec3(),
        residual_torque: (DVec3::new(r[3], r[4], r[5]) * (w.weight * w.arm)).as_vec3(),
        iterations: steps,
        method: SolveMethod::DualNewton,
        active,
        ..GripLoads::default()
    };
    for i in 0..w.k {
        out.forces[i] = (x[i] * w.weight).as_vec3();
    }
    let all_finite = out.forces.iter().all(|f| f.is_finite())
        && out.residual_force.is_finite()
        && out.residual_torque.is_finite();
    all_finite.then_some(out)
}

/// Hessian 2(w_r AᵀA + w_f I) and linear term 2 w_r Aᵀb of the objective.
pub(crate) fn quadratic(p: &Problem) -> (Mat, VecN) {
    let n = p.n();
    let mut h = [[0.0; N_MAX]; N_MAX];
    let mut g = [0.0; N_MAX];
    for i in 0..n {
        for j in i..n {
            let s: f64 = (0..6).map(|r| p.a[r][i] * p.a[r][j]).sum();
            h[i][j] = 2.0 * p.w_r * s;
            h[j][i] = h[i][j];
        }
        h[i][i] += 2.0 * p.w_f;
        g[i] = 2.0 * p.w_r * (0..6).map(|r| p.a[r][i] * p.b[r]).sum::<f64>();
    }
    (h, g)
}

/// Solve `M y = rhs` for the leading n×n block of a symmetric positive definite `M`
/// by Cholesky with symmetric diagonal (Jacobi) scaling, which keeps the
/// barrier's badly scaled Newton systems factorable; `None` if not positive definite.
pub(crate) fn cholesky_solve(m: &Mat, rhs: &VecN, n: usize) -> Option<VecN> {
    Some(Cholesky::factor(m, n)?.solve(rhs))
}

/// A Jacobi-scaled Cholesky factor of the leading n×n block, for several right-hand sides.
pub(crate) struct Cholesky {
    l: Mat,
    scale: VecN,
    n: usize,
}

impl Cholesky {
    /// Factor the leading n×n block of symmetric `m`; `None` if not positive definite.
    pub(crate) fn factor(m: &Mat, n: usize) -> Option<Cholesky> {
        let mut scale = [1.0; N_MAX];
        for i in 0..n {
            if m[i][i].is_nan() || m[i][i] <= 0.0 || m[i][i].is_infinite() {
                return None;
            }
            scale[i] = 1.0 / m[i][i].sqrt();
        }
        let mut l = [[0.0; N_MAX]; N_MAX];
        for i in 0..n {
            for j in 0..=i {
                l[i][j] = m[i][j] * scale[i] * scale[j];
            }
        }
        for j in 0..n {
            let mut d = l[j][j];
            for k in 0..j {
                d -= l[j][k] * l[j][k];
            }
            if d.is_nan() || d <= 0.0 || d.is_infinite() {
                return None;
            }
            let d = d.sqrt();
            l[j][j] = d;
            for i in j + 1..n {
                let mut s = l[i][j];
                for k in 0..j {
                    s -= l[i][k] * l[j][k];
                }
                l[i][j] = s / d;
            }
        }
        Some(Cholesky { l, scale, n })
    }

    /// `M⁻¹ rhs`.
    pub(crate) fn solve(&self, rhs: &VecN) -> VecN {
        let (l, n) = (&self.l, self.n);
        let mut y: VecN = std::array::from_fn(|i| rhs[i] * self.scale[i]);
        for i in 0..n {
            for k in 0..i {
                y[i] -= l[i][k] * y[k];
            }
            y[i] /= l[i][i];
        }
        for i in (0..n).rev() {
            for k in i + 1..n {
                y[i] -= l[k][i] * y[k];
            }
            y[i] /= l[i][i];
        }
        for i in 0..n {
            y[i] *= self.scale[i];
        }
        y
    }
}

/// Per-grip barrier arguments (pull slack u, µ²(s_n+2G)² − |t|² = v); `None` outside the
/// interior.
fn barrier_args(p: &Problem, x: &[f64]) -> Option<[(f64, f64, f64); MAX_GRIPS]> {
    let mut out = [(1.0, 1.0, 1.0); MAX_GRIPS];
    for (i, o) in out.iter_mut().enumerate().take(p.k) {
        let n = p.normal[i];
        let f = Problem::force(x, i);
        let sn = f.dot(n);
        let u = sn + p.grip;
        let s = p.mu * (sn + 2.0 * p.grip);
        let t = f - sn * n;
        let v = s * s - t.length_squared();
        let q = p.push - sn;
        if u.is_nan() || v.is_nan() || q.is_nan() || u <= 0.0 || s <= 0.0 || v <= 0.0 || q <= 0.0 {
            return None;
        }
        *o = (u, v, q);
    }
    Some(out)
}

/// Add the barrier's gradient and Hessian to `g`, `h`.
fn add_barrier_derivatives(p: &Problem, x: &[f64], g: &mut VecN, h: &mut Mat) {
    for i in 0..p.k {
        let n = p.normal[i];
        let f = Problem::force(x, i);
        let sn = f.dot(n);
        let u = sn + p.grip;
        let s = p.mu * (sn + 2.0 * p.grip);
        let t = f - sn * n;
        let v = s * s - t.length_squared();
        // ∇v = 2µ s n − 2t ; ∇²v = 2µ² n nᵀ − 2 (I − n nᵀ).
        let q = p.push - sn;
        let dv = 2.0 * p.mu * s * n - 2.0 * t;
        let gi = -n / u - dv / v + n / q;
        let (na, dva) = (n.to_array(), dv.to_array());
        for r in 0..3 {
            g[3 * i + r] += gi[r];
            for c in 0..3 {
                let eye = if r == c { 1.0 } else { 0.0 };
                let nn = na[r] * na[c];
                let d2v = 2.0 * p.mu * p.mu * nn - 2.0 * (eye - nn);
                h[3 * i + r][3 * i + c] +=
                    nn / (u * u) + nn / (q * q) + dva[r] * dva[c] / (v * v) - d2v / v;
            }
        }
    }
}

fn strictly_feasible(p: &Problem, x: &[f64]) -> bool {
    (0..p.k).all(|i| {
        let (u, q, c) = slacks_scaled(p.mu, p.grip, p.push, p.normal[i], Problem::force(x, i));
        u > 0.0 && q > 0.0 && c > 0.0
    })
}

/// The optimum with only the pull and push limits (linear in the force) by a primal
/// active-set method, with its working set (per grip: `Some(0)` pull, `Some(1)` push).
/// It is the answer when every friction cone holds there strictly (adding constraints
/// that hold at the relaxed optimum does not move it); otherwise it starts the cone
/// active set. `None` when the method does not settle.
fn linear_active_set(p: &Problem, hq: &Mat, gq: &VecN) -> Option<(VecN, Working)> {
    let n = p.n();
    // Constraint j of grip i: a·x ≥ b with a = ±n_i on the grip's block;
    // 0: pull (n·x ≥ −G), 1: push (−n·x ≥ −P). At most one per grip can bind.
    let row = |i: usize, kind: usize| -> (VecN, f64) {
        let mut a = [0.0; N_MAX];
        let sign = if kind == 0 { 1.0 } else { -1.0 };
        for c in 0..3 {
            a[3 * i + c] = sign * p.normal[i][c];
        }
        (a, if kind == 0 { -p.grip } else { -p.push })
    };
    let h_chol = Cholesky::factor(hq, n)?;
    let solve_h = |rhs: &VecN| Some(h_chol.solve(rhs));
    let hinv_g = solve_h(gq)?;
    let mut working: [Option<usize>; MAX_GRIPS] = [None; MAX_GRIPS];
    for _ in 0..12 {
        let active: Vec<(usize, usize)> = (0..p.k)
            .filter_map(|i| working[i].map(|kind| (i, kind)))
            .collect();
        let rows: Vec<(VecN, f64)> = active.iter().map(|&(i, k)| row(i, k)).collect();
        let hinv_a: Vec<VecN> = rows
            .iter()
            .map(|(a, _)| solve_h(a))
            .collect::<Option<_>>()?;
        // (A H⁻¹ Aᵀ) µ = b − A H⁻¹ g, then x = H⁻¹ (g + Aᵀ µ).
        let m = rows.len();
        let mut s = [[0.0; N_MAX]; N_MAX];
        let mut r = [0.0; N_MAX];
        for (j, (aj, bj)) in rows.iter().enumerate() {
            for (l, hl) in hinv_a.iter().enumerate() {
                s[j][l] = (0..n).map(|c| aj[c] * hl[c]).sum();
            }
            r[j] = bj - (0..n).map(|c| aj[c] * hinv_g[c]).sum::<f64>();
        }
        let mu = if m > 0 {
            cholesky_solve(&s, &r, m)?
        } else {
            [0.0; N_MAX]
        };
        let mut x = hinv_g;
        for (j, hl) in hinv_a.iter().enumerate() {
            for c in 0..n {
                x[c] += mu[j] * hl[c];
            }
        }
        // A negative multiplier: that limit does not hold the force back; drop it.
        if let Some((j, _)) = (0..m)
            .map(|j| (j, mu[j]))
            .filter(|&(_, v)| v < 0.0)
            .min_by(|a, b| a.1.total_cmp(&b.1))
        {
            working[active[j].0] = None;
            continue;
        }
        // The most violated limit outside the working set joins it.
        let mut worst: Option<(usize, usize, f64)> = None;
        for i in (0..p.k).filter(|&i| working[i].is_none()) {
            for kind in 0..2 {
                let (a, b) = row(i, kind);
                let v = (0..n).map(|c| a[c] * x[c]).sum::<f64>() - b;
                if v < 0.0 && worst.is_none_or(|w| v < w.2) {
                    worst = Some((i, kind, v));
                }
            }
        }
        if let Some((i, kind, _)) = worst {
            working[i] = Some(kind);
            continue;
        }
        // Linear limits hold with valid multipliers.
        return Some((x, working));
    }
    None
}

/// Per grip, the linear limit in a working set: `Some(0)` pull, `Some(1)` push.
pub(crate) type Working = [Option<usize>; MAX_GRIPS];

fn cones_hold(p: &Problem, x: &VecN) -> bool {
    (0..p.k).all(|i| {
        let (_, _, c) = slacks_scaled(p.mu, p.grip, p.push, p.normal[i], Problem::force(x, i));
        c > 0.0
    })
}

/// The unconstrained optimum of `w_r |b − A x|² + w_f |x|²` through the 6×6 wrench
/// space instead of the 12×12 force space: stationarity gives `x = ρ Aᵀ r` with the
/// residual `r = b − A x`, hence `(I + ρ A Aᵀ) r = b` (ρ = w_r / w_f).
fn unconstrained(p: &Problem) -> Option<VecN> {
    let n = p.n();
    let rho = p.w_r / p.w_f;
    let mut m = [[0.0; N_MAX]; N_MAX];
    for r in 0..6 {
        for s in r..6 {
            let dot: f64 = (0..n).map(|c| p.a[r][c] * p.a[s][c]).sum();
            m[r][s] = rho * dot + if r == s { 1.0 } else { 0.0 };
            m[s][r] = m[r][s];
        }
    }
    let mut b = [0.0; N_MAX];
    b[..6].copy_from_slice(&p.b);
    let res = cholesky_solve(&m, &b, 6)?;
    let mut x = [0.0; N_MAX];
    for c in 0..n {
        x[c] = rho * (0..6).map(|r| p.a[r][c] * res[r]).sum::<f64>();
    }
    Some(x)
}

/// Solve the scaled problem; returns the forces (BW) and the Newton steps taken.
pub(crate) fn solve_problem(
    p: &Problem,
    hint: &ActiveSet,
) -> Result<(VecN, u32, SolveMethod, ActiveSet), LoadError> {
    solve_problem_from(p, hint, None)
}

/// [`solve_problem`], a hinted cone active set's Newton steps started from `warm`
/// where given (else from the unconstrained optimum).
pub(crate) fn solve_problem_from(
    p: &Problem,
    hint: &ActiveSet,
    warm: Option<&VecN>,
) -> Result<(VecN, u32, SolveMethod, ActiveSet), LoadError> {
    let n = p.n();
    let none = [0; MAX_GRIPS];
    if n == 0 {
        return Ok(([0.0; N_MAX], 0, SolveMethod::ClosedForm, none));
    }
    // Unconstrained optimum: if it lies strictly inside every grip set it is the answer.
    let x0 = unconstrained(p)
        .ok_or_else(|| LoadError::SolverFailed("objective not positive definite".into()))?;
    if strictly_feasible(p, &x0[..n]) {
        return Ok((x0, 0, SolveMethod::ClosedForm, none));
    }
    let (hq, gq) = quadratic(p);
    // A hint with a cone in it: the cone active set from there (from the warm start
    // first, where one is given; where that does not settle, from the unconstrained
    // optimum as without one).
    if hint[..p.k].iter().any(|&b| b & CONE != 0) {
        let from_warm = warm.and_then(|w| cone_active_set(p, &hq, &gq, w, hint));
        if let Some((x, steps, set)) = from_warm.or_else(|| cone_active_set(p, &hq, &gq, &x0, hint))
        {
            return Ok((x, steps, SolveMethod::ConeActiveSet, set));
        }
    }
    let linear = linear_active_set(p, &hq, &gq);
    if let Some((x, w)) = linear.filter(|(x, _)| cones_hold(p, x)) {
        let set = std::array::from_fn(|i| match w[i] {
            Some(0) => PULL,
            Some(_) => PUSH,
            None => 0,
        });
        return Ok((x, 0, SolveMethod::LinearActiveSet, set));
    }
    if let Some((x, steps, set)) =
        linear.and_then(|(x, w)| cone_active_set(p, &hq, &gq, &x, &start_set(p, &x, &w)))
    {
        return Ok((x, steps, SolveMethod::ConeActiveSet, set));
    }
    let (x, steps) = barrier(p, &hq, &gq, &x0)?;
    let set = std::array::from_fn(|i| {
        if i >= p.k {
            return 0;
        }
        let (u, q, c) = slacks_scaled(p.mu, p.grip, p.push, p.normal[i], Problem::force(&x, i));
        let tol = 1e-6;
        (u8::from(u <= tol) * PULL) | (u8::from(q <= tol) * PUSH) | (u8::from(c <= tol) * CONE)
    });
    Ok((x, steps, SolveMethod::Barrier, set))
}

/// The log-barrier path from a strictly feasible start; returns the forces (BW) and the
/// Newton steps taken.
fn barrier(p: &Problem, hq: &Mat, gq: &VecN, x0: &VecN) -> Result<(VecN, u32), LoadError> {
    let n = p.n();
    // Barrier path. Start on the segment from 0 (strictly inside: pull slack G, cone
    // slack 2µG) toward the unconstrained optimum, 90 % of the way to the first limit;
    // t₀ = degree / (J(start) − J(unconstrained)), the duality gap the start is worth.
    let mut lo = 0.0;
    let mut hi = 1.0;
    for _ in 0..30 {
        let mid = 0.5 * (lo + hi);
        if strictly_feasible(p, &x0.map(|v| v * mid)[..n]) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let mut x = x0.map(|v| v * 0.9 * lo);
    let degree = 4.0 * p.k as f64; // 2 (half-spaces) + 2 (second-order cone) per grip
    let d: VecN = std::array::from_fn(|i| x[i] - x0[i]);
    let gap0: f64 = (0..n)
        .map(|r| 0.5 * d[r] * (0..n).map(|c| hq[r][c] * d[c]).sum::<f64>())
        .sum();
    let mut t = degree / gap0.max(1e-12);
    let mut steps = 0u32;
    let mut centred = None;
    loop {
        // Centre: Newton on t·J + barrier.
        loop {
            if steps >= MAX_NEWTON {
                return Err(LoadError::SolverFailed(format!(
                    "barrier: no convergence in {MAX_NEWTON} Newton steps"
                )));
            }
            steps += 1;
            let mut g = [0.0; N_MAX];
            let mut h = [[0.0; N_MAX]; N_MAX];
            let mut gx = [0.0; N_MAX];
            for r in 0..n {
                gx[r] = (0..n).map(|c| hq[r][c] * x[c]).sum();
                g[r] = t * (gx[r] - gq[r]);
                for c in 0..n {
                    h[r][c] = t * hq[r][c];
                }
            }
            add_barrier_derivatives(p, &x[..n], &mut g, &mut h);
            let neg_g = g.map(|v| -v);
            let step_dir = cholesky_solve(&h, &neg_g, n).and_then(|dx| {
                let decrement2: f64 = (0..n).map(|i| -g[i] * dx[i]).sum();
                decrement2.is_finite().then_some((dx, decrement2))
            });
            let Some((dx, decrement2)) = step_dir else {
                // Rounding broke the Newton system (huge internal forces at large t): the
                // last centre is the answer if its gap is already small.
                return match centred {
                    Some(tc) if degree / tc < LOOSE_GAP * p.w_f => Ok((x, steps)),
                    _ => Err(LoadError::SolverFailed(
                        "barrier: Newton system singular".into(),
                    )),
                };
            };
            if decrement2 / 2.0 <= NEWTON_TOL {
                break;
            }
            // Backtracking: stay strictly inside, then sufficient decrease (α = 0.25,
            // β = 0.5). The change of t·J + barrier is formed from differences (exact for
            // the quadratic J, log-ratios for the barrier) so that it stays accurate when
            // t·J is huge.
            let args0 = barrier_args(p, &x[..n])
                .ok_or_else(|| LoadError::SolverFailed("barrier: left the interior".into()))?;
            let mut hdx = [0.0; N_MAX];
            for r in 0..n {
                hdx[r] = (0..n).map(|c| hq[r][c] * dx[c]).sum();
            }
            let gj_dx: f64 = (0..n).map(|r| (gx[r] - gq[r]) * dx[r]).sum();
            let dx_h_dx: f64 = (0..n).map(|r| dx[r] * hdx[r]).sum();
            let mut step = 1.0;
            let mut trial = [0.0; N_MAX];
            let accepted = loop {
                for i in 0..n {
                    trial[i] = x[i] + step * dx[i];
                }
                if let Some(args) = barrier_args(p, &trial[..n]) {
                    let dj = step * gj_dx + 0.5 * step * step * dx_h_dx;
                    let db: f64 = (0..p.k)
                        .map(|i| {
                            -(args[i].0 / args0[i].0).ln()
                                - (args[i].1 / args0[i].1).ln()
                                - (args[i].2 / args0[i].2).ln()
                        })
                        .sum();
                    if t * dj + db <= -0.25 * step * decrement2 {
                        break true;
                    }
                }
                step *= 0.5;
                if step < 1e-12 {
                    break false;
                }
            };
            let moved = step * dx[..n].iter().fold(0.0f64, |m, v| m.max(v.abs()));
            if !accepted || moved < MIN_MOVE {
                // No decrease, or a move below rounding: the centre is reached at the
                // precision the active slacks allow.
                break;
            }
            x = trial;
        }
        centred = Some(t);
        if degree / t < GAP * p.w_f {
            return Ok((x, steps));
        }
        t *= T_GROWTH;
    }
}
