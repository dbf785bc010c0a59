//! The cone active set: the optimum when friction cones bind, by a primal active-set
//! method whose equality-constrained subproblems are solved by Newton's method on their
//! KKT conditions (sequential quadratic programming; Nocedal & Wright, *Numerical
//! Optimization*, 2nd ed., §16.5 active sets and §18.1 Newton–KKT steps).
//!
//! Why: in a crowd about 4 % of the stances have a friction cone binding (a paw on a trunk
//! or a steep branch). The barrier solves those in 30–60 Newton steps (≈ 30–80 µs) and
//! was most of the GripLoad stage's time. Here the working set starts from the linear
//! active set's answer plus the cones it violates; each equality subproblem takes a few
//! Newton steps (the cone `µ(s_n + 2G) − |f_t| = 0` is smooth on its surface, where
//! `|f_t| ≥ µG > 0`); the answer is accepted only if it satisfies the KKT conditions of the whole
//! problem — every multiplier ≥ 0 and every limit held — so it is the unique optimum of
//! this strictly convex problem. Anything else (no convergence, a cycle) returns `None`
//! and the barrier solves the stance as before.

// Dense index arithmetic on ≤ 12×12 matrices reads best as index loops.
#![allow(clippy::needless_range_loop)]

use glam::DVec3;

use crate::barrier::{Cholesky, Mat, N_MAX, VecN, Working, cholesky_solve};
use crate::model::{MAX_GRIPS, Problem};

/// Limits of one grip: 0 pull (`s_n + G ≥ 0`), 1 push (`P − s_n ≥ 0`), 2 friction cone
/// (`µ(s_n + 2G) − |f_t| ≥ 0`).
const KINDS: usize = 3;
/// Most limits active at once: two per grip (a linear limit and the cone).
const M_MAX: usize = 2 * MAX_GRIPS;
/// Newton steps allowed for one working set.
const MAX_NEWTON: u32 = 30;
/// Working-set changes allowed.
const MAX_CHANGES: usize = 12;
/// A Newton step (BW) after which the subproblem is solved (the error left is O(step²)).
const STEP_TOL: f64 = 1e-7;
/// Violation (BW) of an active limit accepted at convergence.
const ACTIVE_TOL: f64 = 1e-9;
/// Violation (BW) of an inactive limit that makes it join the working set.
const FEAS_TOL: f64 = 1e-10;

/// Value, gradient (within the grip's 3-block) and, for the cone, the curvature term of
/// limit `kind` of grip `i` at `x`.
fn limit(p: &Problem, x: &VecN, i: usize, kind: usize) -> (f64, DVec3) {
    let n = p.normal[i];
    let f = Problem::force(x, i);
    let sn = f.dot(n);
    match kind {
        0 => (sn + p.grip, n),
        1 => (p.push - sn, -n),
        _ => {
            let t = f - sn * n;
            let tl = t.length();
            // The surface is smooth wherever |t| > 0; at t = 0 any unit tangent is a
            // subgradient (the start then moves onto the surface).
            let that = if tl > 0.0 {
                t / tl
            } else {
                n.any_orthonormal_vector()
            };
            (p.mu * (sn + 2.0 * p.grip) - tl, p.mu * n - that)
        }
    }
}

/// Active limits of one grip as bits: [`PULL`], [`PUSH`], [`CONE`].
pub type ActiveSet = [u8; MAX_GRIPS];
/// The grip is at its grip-strength limit.
pub const PULL: u8 = 1;
/// The grip is at its push-strength limit.
pub const PUSH: u8 = 2;
/// The grip is on its friction cone.
pub const CONE: u8 = 4;

/// The working set of the linear active set's answer plus the cones it violates.
pub(crate) fn start_set(p: &Problem, x: &VecN, linear: &Working) -> ActiveSet {
    let mut set = [0u8; MAX_GRIPS];
    for i in 0..p.k {
        set[i] = match linear[i] {
            Some(0) => PULL,
            Some(_) => PUSH,
            None => 0,
        };
        if limit(p, x, i, 2).0 < 0.0 {
            set[i] |= CONE;
        }
    }
    set
}

/// Solve the problem from `x_start` with the limits in `start` active (e.g. the linear
/// active set's answer and the cones it violates, or the last frame's active set),
/// adding and dropping limits until the KKT conditions hold. Returns the forces (BW),
/// the Newton steps and the final active set.
pub(crate) fn cone_active_set(
    p: &Problem,
    hq: &Mat,
    gq: &VecN,
    x_start: &VecN,
    start: &ActiveSet,
) -> Option<(VecN, u32, ActiveSet)> {
    let n = p.n();
    let mut active = [[false; KINDS]; MAX_GRIPS];
    for i in 0..p.k {
        for kind in 0..KINDS {
            active[i][kind] = start[i] & (1 << kind) != 0;
        }
        if active[i][0] && active[i][1] {
            active[i][1] = false;
        }
    }
    let mut x = *x_start;
    let mut steps = 0u32;
    for _ in 0..MAX_CHANGES {
        let (xs, lambda, list, m) = newton_kkt(p, hq, gq, &x, &active, &mut steps)?;
        x = xs;
        // The most violated inactive limit joins first (pull and push cannot bind
        // together: the new one replaces the other)…
        let mut worst: Option<(usize, usize, f64)> = None;
        for i in 0..p.k {
            for kind in 0..KINDS {
                if active[i][kind] {
                    continue;
                }
                let (v, _) = limit(p, &x, i, kind);
                if v < -FEAS_TOL && worst.is_none_or(|w| v < w.2) {
                    worst = Some((i, kind, v));
                }
            }
        }
        if let Some((i, kind, _)) = worst {
            if kind < 2 {
                active[i][1 - kind] = false;
            }
            active[i][kind] = true;
            continue;
        }
        // …then, with every limit held, a negative multiplier means that limit does not
        // hold the force back: the most negative one leaves.
        match (0..m)
            .filter(|&j| lambda[j] < 0.0)
            .min_by(|&a, &b| lambda[a].total_cmp(&lambda[b]))
        {
            Some(j) => {
                let (i, kind) = list[j];
                active[i][kind] = false;
            }
            None => {
                let set = std::array::from_fn(|i| {
                    (0..KINDS)
                        .filter(|&kind| active[i][kind])
                        .fold(0u8, |b, kind| b | (1 << kind))
                });
                return x[..n]
                    .iter()
                    .all(|v| v.is_finite())
                    .then_some((x, steps, set));
            }
        }
    }
    None
}

/// Newton's method on the KKT conditions of `min J` subject to the limits in `active` as
/// equalities, from `x`. Returns the solution, the multipliers of the active limits (in
/// the order of the returned list of `(grip, kind)`) and their number; `None` if it does
/// not converge within [`MAX_NEWTON`] steps or a system is singular.
#[allow(clippy::type_complexity)]
fn newton_kkt(
    p: &Problem,
    hq: &Mat,
    gq: &VecN,
    x0: &VecN,
    active: &[[bool; KINDS]; MAX_GRIPS],
    steps: &mut u32,
) -> Option<(VecN, [f64; M_MAX], [(usize, usize); M_MAX], usize)> {
    let n = p.n();
    let mut list = [(0, 0); M_MAX];
    let mut m = 0;
    for i in 0..p.k {
        for kind in 0..KINDS {
            if active[i][kind] {
                list[m] = (i, kind);
                m += 1;
            }
        }
    }
    let mut x = *x0;
    let mut lambda = [0.0; M_MAX];
    for _ in 0..MAX_NEWTON {
        *steps += 1;
        // Hessian of the Lagrangian J − Σ λ_j c_j: the cone's −∇²c = (I − nnᵀ − t̂t̂ᵀ)/|t|
        // is positive semidefinite, weighted by max(λ, 0) so the system stays definite.
        let mut hl = *hq;
        let mut rows = [[0.0; N_MAX]; M_MAX];
        let mut vals = [0.0; M_MAX];
        for (j, &(i, kind)) in list[..m].iter().enumerate() {
            let (v, grad) = limit(p, &x, i, kind);
            vals[j] = v;
            for c in 0..3 {
                rows[j][3 * i + c] = grad[c];
            }
            if kind == 2 && lambda[j] > 0.0 {
                let nrm = p.normal[i];
                let f = Problem::force(&x, i);
                let t = f - f.dot(nrm) * nrm;
                let tl = t.length();
                if tl > 0.0 {
                    let that = t / tl;
                    for r in 0..3 {
                        for c in 0..3 {
                            let eye = if r == c { 1.0 } else { 0.0 };
                            hl[3 * i + r][3 * i + c] +=
                                lambda[j] * (eye - nrm[r] * nrm[c] - that[r] * that[c]) / tl;
                        }
                    }
                }
            }
        }
        // Gradient of J: r = H x − g. Step: H_L dx = Cᵀλ − r, C dx = −c, i.e.
        // (C H_L⁻¹ Cᵀ) λ = C H_L⁻¹ r − c, dx = H_L⁻¹ (Cᵀλ − r).
        let mut r = [0.0; N_MAX];
        for a in 0..n {
            r[a] = (0..n).map(|b| hq[a][b] * x[b]).sum::<f64>() - gq[a];
        }
        let chol = Cholesky::factor(&hl, n)?;
        let hinv_r = chol.solve(&r);
        let mut hinv_c = [[0.0; N_MAX]; M_MAX];
        for j in 0..m {
            hinv_c[j] = chol.solve(&rows[j]);
        }
        let mut s = [[0.0; N_MAX]; N_MAX];
        let mut rhs = [0.0; N_MAX];
        for j in 0..m {
            for l in 0..m {
                s[j][l] = (0..n).map(|c| rows[j][c] * hinv_c[l][c]).sum();
            }
            rhs[j] = (0..n).map(|c| rows[j][c] * hinv_r[c]).sum::<f64>() - vals[j];
        }
        let lam = if m > 0 {
            cholesky_solve(&s, &rhs, m)?
        } else {
            [0.0; N_MAX]
        };
        let mut dx = hinv_r.map(|v| -v);
        for j in 0..m {
            for c in 0..n {
                dx[c] += lam[j] * hinv_c[j][c];
            }
            lambda[j] = lam[j];
        }
        let mut moved = 0.0f64;
        for c in 0..n {
            x[c] += dx[c];
            moved = moved.max(dx[c].abs());
        }
        if !moved.is_finite() {
            return None;
        }
        // Newton converges quadratically: after a step of δ the error is O(δ²), so a
        // small step whose end holds the active limits is the solution.
        if moved <= STEP_TOL
            && list[..m]
                .iter()
                .all(|&(i, kind)| limit(p, &x, i, kind).0.abs() <= ACTIVE_TOL)
        {
            return Some((x, lambda, list, m));
        }
    }
    None
}
