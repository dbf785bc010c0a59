//! Newton's method in wrench space (6 unknowns) for stances the closed form leaves: the
//! GripLoad stage's path when a limit binds.
//!
//! With the residual `r = b − Σ A_i x_i` fixed, each grip's part of the objective,
//! `w_f |x_i|² − 2 w_r (A_iᵀ r)·x_i`, is least at the projection of `ρ A_iᵀ r` onto its grip
//! set `K_i` (ρ = w_r / w_f). So the optimum is the root of the 6-D equation
//!
//! ```text
//! F(r) = r − b + Σ A_i P_i(ρ A_iᵀ r) = 0,      x_i = P_i(ρ A_iᵀ r),
//! ```
//!
//! the gradient of the strongly convex `φ(r) = ½|r|² − b·r + Σ h(ρ A_iᵀ r)/ρ` with
//! `h(y) = ½|y|² − ½|y − P(y)|²` (whose gradient is `P(y)`): the dual of the QP, in the
//! space of the closed form's 6×6 system, which is the case `P_i = identity`. `F` is
//! piecewise smooth (the projection onto the truncated cone has a closed form per region:
//! inside, pull or push face, cone surface, the two circular edges), so Newton's method
//! with the projections' Jacobians (semismooth Newton; Qi & Sun, *Math. Programming* 58,
//! 1993) and a backtracking line search on `φ` converges, quadratically near the root:
//! each step is one symmetric positive definite 6×6 solve with
//! `∂F = I + ρ Σ A_i J_i A_iᵀ` — no 12×12 factorisation, no working set.
//!
//! Accepted when `|F(r)|∞ ≤ F_TOL`: then the forces are the exact optimum of the problem
//! with `b` moved by `F(r)` (≤ 1e-12 BW), every force lies in its grip set by
//! construction and the multipliers are ≥ 0 by construction (a projection's normal cone),
//! i.e. the KKT conditions hold. Anything else returns `None` and the caller falls back to
//! the active-set path.

// Dense index arithmetic on 6×6 and 3×3 matrices and per-grip arrays reads best as index
// loops.
#![allow(clippy::needless_range_loop)]

use glam::DVec3;

use crate::active::{ActiveSet, CONE, PULL, PUSH};
use crate::closed::{Wrench, cholesky6};
use crate::model::MAX_GRIPS;

/// `|F(r)|∞` (BW, BW·ℓ) at which the root is accepted outright.
const F_TOL: f64 = 1e-12;
/// A full Newton step that moved no force by more than this (BW) ends the search…
const STEP_TOL: f64 = 1e-7;
/// …where `|F(r)|∞` is at most this.
const F_LOOSE: f64 = 1e-9;
/// Newton steps allowed with a fixed active set.
const MAX_FIXED_STEPS: u32 = 8;
/// `|F(r)|∞` below which a step that halves it is taken even if `φ` (whose differences
/// then drown in rounding) does not show the decrease.
const NEAR: f64 = 1e-6;
/// Newton steps allowed.
const MAX_STEPS: u32 = 30;
/// Halvings of a step allowed in the line search.
const MAX_HALVINGS: u32 = 30;
/// Armijo's sufficient-decrease fraction.
const ARMIJO: f64 = 1e-4;

/// A symmetric 3×3 matrix as rows.
type M3 = [[f64; 3]; 3];

/// One grip's projection: the force, the region's active limits and what the Jacobian
/// needs.
#[derive(Clone, Copy)]
struct Proj {
    x: DVec3,
    bits: u8,
    /// Unit tangent direction of `y` (valid where `bits` has [`CONE`] or the curvature
    /// is needed).
    that: DVec3,
    /// Curvature weight `|x_t| / |y_t|` of the circle through the projection (0 where
    /// the tangential part is not scaled).
    curv: f64,
}

/// Projection of `y` onto the grip set `{−G ≤ s ≤ P, |t| ≤ µ(s + 2G)}` about `n`.
fn project(y: DVec3, n: DVec3, mu: f64, grip: f64, push: f64) -> Proj {
    let sn = y.dot(n);
    let t = y - sn * n;
    let tau = t.length();
    let cone = mu * (sn + 2.0 * grip) - tau;
    let free = Proj {
        x: y,
        bits: 0,
        that: DVec3::ZERO,
        curv: 0.0,
    };
    if sn >= -grip && sn <= push && cone >= 0.0 {
        return free;
    }
    // Foot on the cone's generator from the apex (−2G, 0) in the (s, |t|) half-plane.
    let alpha = (sn + 2.0 * grip + mu * tau) / (1.0 + mu * mu);
    if cone < 0.0 && alpha >= grip && alpha <= push + 2.0 * grip {
        // τ > 0 here (τ = 0 with cone < 0 means s < −2G, hence α < 0).
        let that = t / tau;
        return Proj {
            x: (alpha - 2.0 * grip) * n + (mu * alpha) * that,
            bits: CONE,
            that,
            curv: mu * alpha / tau,
        };
    }
    let lower = if cone < 0.0 { alpha < grip } else { sn < -grip };
    let (s, edge, bit) = if lower {
        (-grip, mu * grip, PULL)
    } else {
        (push, mu * (push + 2.0 * grip), PUSH)
    };
    if tau <= edge {
        return Proj {
            x: s * n + t,
            bits: bit,
            ..free
        };
    }
    let that = t / tau;
    Proj {
        x: s * n + edge * that,
        bits: bit | CONE,
        that,
        curv: edge / tau,
    }
}

/// The map of `y` onto the surface of the grip set that the limits `bits` describe, as
/// if that surface were the whole set (the equality-constrained subproblem of a fixed
/// active set: a face is a plane, the cone an infinite cone, an edge its circle); `None`
/// for bits that name no surface or a cone at `|y_t| = 0`, where it is not smooth.
fn project_on(y: DVec3, n: DVec3, bits: u8, mu: f64, grip: f64, push: f64) -> Option<Proj> {
    let sn = y.dot(n);
    let free = Proj {
        x: y,
        bits,
        that: DVec3::ZERO,
        curv: 0.0,
    };
    match bits {
        0 => return Some(free),
        PULL => {
            return Some(Proj {
                x: y - (sn + grip) * n,
                ..free
            });
        }
        PUSH => {
            return Some(Proj {
                x: y - (sn - push) * n,
                ..free
            });
        }
        _ => {}
    }
    let t = y - sn * n;
    let tau = t.length();
    if tau.is_nan() || tau <= 0.0 {
        return None;
    }
    let that = t / tau;
    let (s, edge) = match bits {
        CONE => {
            let alpha = (sn + 2.0 * grip + mu * tau) / (1.0 + mu * mu);
            return Some(Proj {
                x: (alpha - 2.0 * grip) * n + (mu * alpha) * that,
                that,
                curv: mu * alpha / tau,
                ..free
            });
        }
        b if b == PULL | CONE => (-grip, mu * grip),
        b if b == PUSH | CONE => (push, mu * (push + 2.0 * grip)),
        _ => return None,
    };
    Some(Proj {
        x: s * n + edge * that,
        that,
        curv: edge / tau,
        ..free
    })
}

/// Jacobian of the projection at the region of `p` (symmetric, 0 ≼ J ≼ I).
fn jacobian(p: &Proj, n: DVec3, mu: f64) -> M3 {
    let (na, ta) = (n.to_array(), p.that.to_array());
    let mut j = [[0.0; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            let eye = if r == c { 1.0 } else { 0.0 };
            let nn = na[r] * na[c];
            let tt = ta[r] * ta[c];
            j[r][c] = match p.bits {
                0 => eye,
                PULL | PUSH => eye - nn,
                CONE => {
                    let g = [na[r] + mu * ta[r], na[c] + mu * ta[c]];
                    g[0] * g[1] / (1.0 + mu * mu) + p.curv * (eye - nn - tt)
                }
                _ => p.curv * (eye - nn - tt),
            };
        }
    }
    j
}

/// `F(r)`, `φ(r)` and the projections at `r`: onto the grip sets, or with `fixed` onto
/// the surfaces those limits describe ([`project_on`]; `None` where that is not smooth;
/// `φ` is then not needed and only its quadratic part is formed).
#[inline(never)]
fn evaluate(
    w: &Wrench,
    r: &[f64; 6],
    fixed: Option<&ActiveSet>,
) -> Option<([f64; 6], f64, [Proj; MAX_GRIPS])> {
    let rf = DVec3::new(r[0], r[1], r[2]);
    let rt = DVec3::new(r[3], r[4], r[5]);
    let mut f = [0.0; 6];
    let mut phi = 0.0;
    for c in 0..6 {
        f[c] = r[c] - w.b[c];
        phi += r[c] * (0.5 * r[c] - w.b[c]);
    }
    let mut proj = [Proj {
        x: DVec3::ZERO,
        bits: 0,
        that: DVec3::ZERO,
        curv: 0.0,
    }; MAX_GRIPS];
    for i in 0..w.k {
        let y = w.rho * (rf + rt.cross(w.d[i]));
        let p = match fixed {
            None => project(y, w.normal[i], w.mu, w.grip, w.push),
            Some(bits) => project_on(y, w.normal[i], bits[i], w.mu, w.grip, w.push)?,
        };
        let m = w.d[i].cross(p.x);
        f[0] += p.x.x;
        f[1] += p.x.y;
        f[2] += p.x.z;
        f[3] += m.x;
        f[4] += m.y;
        f[5] += m.z;
        if fixed.is_none() {
            phi += 0.5 * (y.length_squared() - (y - p.x).length_squared()) / w.rho;
        }
        proj[i] = p;
    }
    Some((f, phi, proj))
}

/// `∂F = I + ρ Σ A_i J_i A_iᵀ` with `A_i = [I; [d_i]×]`: its lower triangle (what
/// [`cholesky6`] reads; the upper entries are left 0).
#[inline(never)]
fn newton_matrix(w: &Wrench, proj: &[Proj; MAX_GRIPS]) -> [[f64; 6]; 6] {
    let mut h = [[0.0; 6]; 6];
    for i in 0..w.k {
        let d = w.d[i];
        if proj[i].bits == 0 {
            // J = I: the blocks are I, K and K Kᵀ = |d|² I − d dᵀ.
            let (da, dd) = (d.to_array(), d.length_squared());
            for r in 0..3 {
                h[r][r] += 1.0;
                for c in 0..=r {
                    let eye = if r == c { dd } else { 0.0 };
                    h[3 + r][3 + c] += eye - da[r] * da[c];
                }
            }
            h[3][1] -= da[2];
            h[3][2] += da[1];
            h[4][0] += da[2];
            h[4][2] -= da[0];
            h[5][0] -= da[1];
            h[5][1] += da[0];
            continue;
        }
        let j = jacobian(&proj[i], w.normal[i], w.mu);
        // K J (K v = d × v): column c is d × (column c of J).
        let mut kj = [[0.0; 3]; 3];
        for c in 0..3 {
            let col = d.cross(DVec3::new(j[0][c], j[1][c], j[2][c]));
            kj[0][c] = col.x;
            kj[1][c] = col.y;
            kj[2][c] = col.z;
        }
        // K J Kᵀ = K (K J)ᵀ: column c is d × (row c of K J).
        let mut kjk = [[0.0; 3]; 3];
        for c in 0..3 {
            let col = d.cross(DVec3::new(kj[c][0], kj[c][1], kj[c][2]));
            kjk[0][c] = col.x;
            kjk[1][c] = col.y;
            kjk[2][c] = col.z;
        }
        for r in 0..3 {
            for c in 0..3 {
                h[3 + r][c] += kj[r][c];
            }
            for c in 0..=r {
                h[r][c] += j[r][c];
                h[3 + r][3 + c] += kjk[r][c];
            }
        }
    }
    for r in 0..6 {
        for c in 0..=r {
            h[r][c] = w.rho * h[r][c] + if r == c { 1.0 } else { 0.0 };
        }
    }
    h
}

fn max_abs(v: &[f64; 6]) -> f64 {
    v.iter().fold(0.0, |m, x| m.max(x.abs()))
}

/// Largest change of a force (BW) between two projections.
fn moved(a: &[Proj; MAX_GRIPS], b: &[Proj; MAX_GRIPS], k: usize) -> f64 {
    (0..k).fold(0.0, |m, i| {
        let d = (a[i].x - b[i].x).abs();
        m.max(d.x).max(d.y).max(d.z)
    })
}

/// The answer at a root: forces (BW), the residual `b − Σ A_i x_i` and the active limits.
fn answer(
    w: &Wrench,
    proj: &[Proj; MAX_GRIPS],
) -> Option<([DVec3; MAX_GRIPS], [f64; 6], ActiveSet)> {
    let mut x = [DVec3::ZERO; MAX_GRIPS];
    let mut res = w.b;
    let mut active = [0u8; MAX_GRIPS];
    for i in 0..w.k {
        x[i] = proj[i].x;
        active[i] = proj[i].bits;
        let m = w.d[i].cross(x[i]);
        for c in 0..3 {
            res[c] -= x[i][c];
            res[3 + c] -= m[c];
        }
    }
    let finite = x.iter().all(|v| v.is_finite()) && res.iter().all(|v| v.is_finite());
    finite.then_some((x, res, active))
}

/// A root is reached when `|F|∞ ≤ F_TOL`, or when a full Newton step moved no force by
/// more than [`STEP_TOL`] and left `|F|∞ ≤ F_LOOSE` (the error after a step of δ is
/// O(δ²); `F` itself then floors at rounding, ≈ ε ρ |r| |A|²).
fn converged(size: f64, full_step_moved: f64) -> bool {
    size <= F_TOL || (full_step_moved <= STEP_TOL && size <= F_LOOSE)
}

/// The optimum for the active limits `hint` (per grip, bits [`PULL`], [`PUSH`], [`CONE`],
/// e.g. the last frame's): Newton's method on `F(r) = 0` with each grip's force on the
/// surface its limits describe (smooth: full steps), from `r0`; then the answer only if
/// every grip's point projects onto exactly that surface of its grip set (so `F` is the
/// true one, every force in its set and every multiplier ≥ 0: the KKT conditions). `None`
/// otherwise.
#[inline(never)]
pub(crate) fn fixed_newton(
    w: &Wrench,
    r0: &[f64; 6],
    hint: &ActiveSet,
) -> Option<([DVec3; MAX_GRIPS], [f64; 6], u32, ActiveSet)> {
    let mut r = *r0;
    let (mut f, _, mut proj) = evaluate(w, &r, Some(hint))?;
    let mut steps = 0;
    let mut last_move = f64::INFINITY;
    loop {
        let size = max_abs(&f);
        if !size.is_finite() {
            return None;
        }
        if converged(size, last_move) {
            break;
        }
        if steps == MAX_FIXED_STEPS {
            return None;
        }
        steps += 1;
        let h = newton_matrix(w, &proj);
        let dr = cholesky6(&h, f.map(|v| -v))?;
        for c in 0..6 {
            r[c] += dr[c];
        }
        let (tf, _, tproj) = evaluate(w, &r, Some(hint))?;
        last_move = moved(&proj, &tproj, w.k);
        (f, proj) = (tf, tproj);
    }
    // The true projections must land on the same surfaces.
    let rf = DVec3::new(r[0], r[1], r[2]);
    let rt = DVec3::new(r[3], r[4], r[5]);
    for i in 0..w.k {
        let y = w.rho * (rf + rt.cross(w.d[i]));
        if project(y, w.normal[i], w.mu, w.grip, w.push).bits != proj[i].bits {
            return None;
        }
    }
    let (x, res, active) = answer(w, &proj)?;
    Some((x, res, steps, active))
}

/// The optimum by Newton's method on `F(r) = 0` from the residual `r0` (semismooth: the
/// projections' regions may change from step to step; a backtracking line search on `φ`):
/// the forces (BW), the residual `b − Σ A_i x_i`, the Newton steps and the active limits;
/// `None` when it does not converge (or anything is not finite).
#[inline(never)]
pub(crate) fn dual_newton(
    w: &Wrench,
    r0: &[f64; 6],
) -> Option<([DVec3; MAX_GRIPS], [f64; 6], u32, ActiveSet)> {
    let mut r = *r0;
    let (mut f, mut phi, mut proj) = evaluate(w, &r, None)?;
    let mut steps = 0;
    let mut last_move = f64::INFINITY;
    loop {
        let size = max_abs(&f);
        if !(size.is_finite() && phi.is_finite()) {
            return None;
        }
        if converged(size, last_move) {
            break;
        }
        if steps == MAX_STEPS {
            return None;
        }
        steps += 1;
        let h = newton_matrix(w, &proj);
        let dr = cholesky6(&h, f.map(|v| -v))?;
        let slope: f64 = (0..6).map(|c| f[c] * dr[c]).sum();
        let mut t = 1.0;
        let mut halvings = 0;
        loop {
            let trial: [f64; 6] = std::array::from_fn(|c| r[c] + t * dr[c]);
            let (tf, tphi, tproj) = evaluate(w, &trial, None)?;
            // Sufficient decrease of φ; near the root, where φ's differences drown in
            // rounding, a halving of |F| does as well.
            if tphi <= phi + ARMIJO * t * slope || (size <= NEAR && max_abs(&tf) <= 0.5 * size) {
                last_move = if t == 1.0 {
                    moved(&proj, &tproj, w.k)
                } else {
                    f64::INFINITY
                };
                (r, f, phi, proj) = (trial, tf, tphi, tproj);
                break;
            }
            halvings += 1;
            if halvings == MAX_HALVINGS {
                return None;
            }
            t *= 0.5;
        }
    }
    let (x, res, active) = answer(w, &proj)?;
    Some((x, res, steps, active))
}
