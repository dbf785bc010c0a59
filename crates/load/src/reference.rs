//! The reference solver: the same problem handed to clarabel (interior-point conic
//! solver, second-order cones) in its standard form
//! `min ½ zᵀPz + qᵀz  s.t.  A z + s = b,  s ∈ K`.
//!
//! Unknowns z = [grip forces x (BW, 3 per grip), residual r (6)]; P = diag(2w_f, 2w_r);
//! K = {0}⁶ (balance `A_bal x + r = b_bal`) × per grip: ℝ₊ (pull slack `G + n·x_i`),
//! ℝ₊ (push slack `P − n·x_i`) and SOC³ (`(µ(n·x_i + 2G), e₁·x_i, e₂·x_i)`, e₁, e₂ tangent
//! to the surface).

use clarabel::algebra::CscMatrix;
use clarabel::solver::{
    DefaultSettingsBuilder, DefaultSolver, IPSolver, SolverStatus, SupportedConeT,
};

use crate::model::Problem;
use crate::{GripLoads, LoadError, LoadParams, Stance};

/// Grip loads by clarabel (slow; the reference the specialised solver is proven against).
pub fn solve_reference(params: &LoadParams, stance: &Stance) -> Result<GripLoads, LoadError> {
    let p = Problem::new(params, stance)?;
    let n = p.n();
    if n == 0 {
        return p.loads(&[], 0);
    }
    let nz = n + 6;
    let mut pmat = vec![vec![0.0; nz]; nz];
    for (i, row) in pmat.iter_mut().enumerate() {
        row[i] = if i < n { 2.0 * p.w_f } else { 2.0 * p.w_r };
    }
    let q = vec![0.0; nz];
    let mut a: Vec<Vec<f64>> = Vec::new();
    let mut b = Vec::new();
    let mut cones = vec![SupportedConeT::ZeroConeT(6)];
    for r in 0..6 {
        let mut row = vec![0.0; nz];
        row[..n].copy_from_slice(&p.a[r][..n]);
        row[n + r] = 1.0;
        a.push(row);
        b.push(p.b[r]);
    }
    for i in 0..p.k {
        let nrm = p.normal[i];
        let (e1, e2) = nrm.any_orthonormal_pair();
        let row = |v: glam::DVec3, scale: f64| {
            let mut row = vec![0.0; nz];
            for c in 0..3 {
                row[3 * i + c] = -scale * v[c];
            }
            row
        };
        a.push(row(nrm, 1.0));
        b.push(p.grip);
        a.push(row(nrm, -1.0));
        b.push(p.push);
        cones.push(SupportedConeT::NonnegativeConeT(2));
        a.push(row(nrm, p.mu));
        b.push(2.0 * p.mu * p.grip);
        a.push(row(e1, 1.0));
        b.push(0.0);
        a.push(row(e2, 1.0));
        b.push(0.0);
        cones.push(SupportedConeT::SecondOrderConeT(3));
    }
    let settings = DefaultSettingsBuilder::default()
        .verbose(false)
        .tol_gap_abs(1e-10)
        .tol_gap_rel(1e-10)
        .tol_feas(1e-10)
        .build()
        .map_err(|e| LoadError::SolverFailed(format!("clarabel settings: {e}")))?;
    let pm = CscMatrix::from(&pmat);
    let am = CscMatrix::from(&a);
    let mut solver = DefaultSolver::new(&pm, &q, &am, &b, &cones, settings)
        .map_err(|e| LoadError::SolverFailed(format!("clarabel setup: {e}")))?;
    solver.solve();
    let sol = &solver.solution;
    // Tolerances are tight (1e-10); `AlmostSolved` is clarabel's answer at its reduced
    // accuracy (1e-5 relative), still well inside the 1e-4 BW comparisons.
    if !matches!(
        sol.status,
        SolverStatus::Solved | SolverStatus::AlmostSolved
    ) {
        return Err(LoadError::SolverFailed(format!(
            "clarabel: {:?}",
            sol.status
        )));
    }
    let mut out = p.loads(&sol.x[..n], sol.iterations)?;
    out.method = crate::SolveMethod::Reference;
    Ok(out)
}
