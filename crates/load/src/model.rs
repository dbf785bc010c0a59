//! The model: a stance (centre of mass, its acceleration, planted claws) → the scaled
//! least-squares problem both solvers share, and the answer in newtons.
//!
//! Scaling: forces are solved in body weights (BW = m·g) and torques in BW × `residual_arm_m`,
//! so the weights are dimensionless and the problem is well conditioned for any mass.

use glam::{DVec3, Vec3};

use crate::{LoadError, LoadParams};

/// Most planted claws a stance may have.
pub const MAX_GRIPS: usize = 4;

/// One planted claw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grip {
    /// Contact point on the support surface (m, world).
    pub point: Vec3,
    /// Outward unit normal of the support surface at the contact (from the support's axis
    /// toward the claw); normalised by the solver, must be non-zero.
    pub normal: Vec3,
}

/// The body's state in one frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stance<'a> {
    /// Centre of mass (m, world).
    pub com: Vec3,
    /// Acceleration of the centre of mass (m/s²), e.g. [`com_acceleration`] of the trajectory.
    pub com_acc: Vec3,
    /// Rate of change of the angular momentum about the centre of mass (N·m); zero for the
    /// quasi-static rotation of a kinematic gait.
    pub ang_mom_rate: Vec3,
    /// Planted claws (at most [`MAX_GRIPS`]).
    pub grips: &'a [Grip],
}

/// A point mass of the body or a limb segment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MassPoint {
    /// Position (m, world).
    pub point: Vec3,
    /// Mass (kg or any consistent unit: only ratios matter).
    pub mass: f32,
}

/// Mass-weighted centre of `points`; `None` when the total mass is not positive.
pub fn centre_of_mass(points: &[MassPoint]) -> Option<Vec3> {
    let total: f32 = points.iter().map(|p| p.mass).sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    let sum: Vec3 = points.iter().map(|p| p.point * p.mass).sum();
    Some(sum / total)
}

/// Second central difference of three equally spaced samples of a trajectory
/// (`c(t−2dt)`, `c(t−dt)`, `c(t)`): the acceleration at `t−dt`, used for `t`.
pub fn com_acceleration(prev2: Vec3, prev: Vec3, now: Vec3, dt: f32) -> Vec3 {
    if dt > 0.0 {
        (now - 2.0 * prev + prev2) / (dt * dt)
    } else {
        Vec3::ZERO
    }
}

/// Grip forces and the residual wrench for one stance.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct GripLoads {
    /// Force of the support on the body at each grip (N), in the order of
    /// [`Stance::grips`]; entries past `count` are zero.
    pub forces: [Vec3; MAX_GRIPS],
    /// Number of grips.
    pub count: u8,
    /// Residual force on the body (N), applied at the centre of mass.
    pub residual_force: Vec3,
    /// Residual torque on the body about the centre of mass (N·m).
    pub residual_torque: Vec3,
    /// Newton steps taken (0: closed form or linear active set).
    pub iterations: u32,
    /// Which of the specialised solver's stages found the answer.
    pub method: SolveMethod,
    /// Active limits per grip (bits [`crate::PULL`], [`crate::PUSH`], [`crate::CONE`]):
    /// a hint for the next frame's [`crate::solve_from`].
    pub active: crate::ActiveSet,
}

/// Which stage of [`crate::solve`] found the answer (clarabel's answers say `Reference`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SolveMethod {
    /// The unconstrained optimum lies inside every grip set.
    #[default]
    ClosedForm,
    /// Only pull/push limits bind (linear active set).
    LinearActiveSet,
    /// A friction cone binds: active set with Newton–KKT steps.
    ConeActiveSet,
    /// The log-barrier method (when the active set does not settle).
    Barrier,
    /// clarabel ([`crate::solve_reference`]).
    Reference,
    /// Newton's method in wrench space (`crate::solve_warm`, when the closed form's
    /// optimum leaves a grip set).
    DualNewton,
}

impl GripLoads {
    /// The forces of the stance's grips.
    pub fn grip_forces(&self) -> &[Vec3] {
        &self.forces[..usize::from(self.count)]
    }

    /// Size of the residual wrench in body weights: √(|F|² + |τ/ℓ|²) / (m·g), ℓ =
    /// `residual_arm_m`.
    pub fn residual_bw(&self, params: &LoadParams) -> f32 {
        let f = DVec3::from(self.residual_force);
        let t = DVec3::from(self.residual_torque) / params.residual_arm_m;
        ((f.length_squared() + t.length_squared()).sqrt() / params.body_weight_n()) as f32
    }
}

/// Which limits of a claw's grip set bind at the optimum.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GripState {
    /// Inside: neither friction nor grip strength limits the force.
    Free,
    /// On the friction cone's surface (slipping would start).
    Cone,
    /// At the grip-strength limit of the pull toward the support's axis.
    PullLimit,
    /// Cone and pull limit.
    Corner,
    /// At the push-strength limit (pressing into the support).
    PushLimit,
    /// Cone and push limit.
    PushCorner,
}

/// Slacks of one claw's grip set in body weights: (pull slack `s_n + G`, push slack
/// `P − s_n`, distance inside the friction cone `(µ(s_n + 2G) − |f_t|)/√(1+µ²)`), where
/// `s_n` is the force along the outward normal in BW. All are ≥ 0 for a feasible force.
pub fn grip_slacks(params: &LoadParams, normal: Vec3, force_n: Vec3) -> (f64, f64, f64) {
    let n = DVec3::from(normal).normalize_or_zero();
    let x = DVec3::from(force_n) / params.body_weight_n();
    let (u, p, c) = slacks_scaled(
        params.mu,
        params.grip_strength_bw,
        params.push_strength_bw,
        n,
        x,
    );
    (u, p, c / (1.0 + params.mu * params.mu).sqrt())
}

/// Active limits of each grip of `loads` (a limit is active when its slack is ≤ `tol_bw`).
pub fn grip_states(
    params: &LoadParams,
    stance: &Stance,
    loads: &GripLoads,
    tol_bw: f64,
) -> Vec<GripState> {
    stance
        .grips
        .iter()
        .zip(loads.grip_forces())
        .map(|(g, &f)| {
            let (u, p, c) = grip_slacks(params, g.normal, f);
            match (u <= tol_bw, p <= tol_bw, c <= tol_bw) {
                (true, _, false) => GripState::PullLimit,
                (true, _, true) => GripState::Corner,
                (false, true, false) => GripState::PushLimit,
                (false, true, true) => GripState::PushCorner,
                (false, false, false) => GripState::Free,
                (false, false, true) => GripState::Cone,
            }
        })
        .collect()
}

/// (pull slack s_n + G, push slack P − s_n, cone slack µ(s_n + 2G) − |t|) of a force `x`
/// in BW about unit normal `n`.
pub(crate) fn slacks_scaled(mu: f64, grip: f64, push: f64, n: DVec3, x: DVec3) -> (f64, f64, f64) {
    let sn = x.dot(n);
    let t = x - sn * n;
    (sn + grip, push - sn, mu * (sn + 2.0 * grip) - t.length())
}

/// The scaled problem: minimise `w_r |b − A x|² + w_f |x|²` over the grip forces `x` (BW,
/// 3 per grip) with each grip's force in its set (pull, push and cone slacks ≥ 0).
/// `b − A x` is the residual wrench (force in BW, torque in BW·ℓ).
#[derive(Clone, Debug)]
pub(crate) struct Problem {
    /// Number of grips.
    pub k: usize,
    /// Rows: Σ forces (3), Σ moments about the CoM / ℓ (3); columns: 3 per grip.
    pub a: [[f64; 3 * MAX_GRIPS]; 6],
    /// Wrench the grips must supply: m(c̈ − g)/W and L̇/(W ℓ).
    pub b: [f64; 6],
    /// Unit outward normals.
    pub normal: [DVec3; MAX_GRIPS],
    pub mu: f64,
    /// Grip strength (BW).
    pub grip: f64,
    /// Push strength (BW).
    pub push: f64,
    pub w_r: f64,
    pub w_f: f64,
    /// Body weight (N) and residual arm (m), to convert back.
    weight: f64,
    arm: f64,
}

fn finite(v: Vec3, what: &str) -> Result<DVec3, LoadError> {
    if v.is_finite() {
        Ok(DVec3::from(v))
    } else {
        Err(LoadError::BadInput(format!("{what} is not finite ({v})")))
    }
}

impl Problem {
    pub fn new(params: &LoadParams, stance: &Stance) -> Result<Problem, LoadError> {
        params.validate()?;
        let k = stance.grips.len();
        if k > MAX_GRIPS {
            return Err(LoadError::BadInput(format!(
                "{k} grips (at most {MAX_GRIPS})"
            )));
        }
        let com = finite(stance.com, "centre of mass")?;
        let acc = finite(stance.com_acc, "centre-of-mass acceleration")?;
        let ldot = finite(stance.ang_mom_rate, "angular momentum rate")?;
        let weight = params.body_weight_n();
        let arm = params.residual_arm_m;
        let mut a = [[0.0; 3 * MAX_GRIPS]; 6];
        let mut normal = [DVec3::Y; MAX_GRIPS];
        for (i, g) in stance.grips.iter().enumerate() {
            let p = finite(g.point, "grip point")?;
            let n = finite(g.normal, "grip normal")?;
            normal[i] = n
                .try_normalize()
                .ok_or_else(|| LoadError::BadInput(format!("grip normal {n} has no direction")))?;
            let d = (p - com) / arm;
            for c in 0..3 {
                let e = DVec3::AXES[c];
                a[c][3 * i + c] = 1.0;
                let m = d.cross(e);
                a[3][3 * i + c] = m.x;
                a[4][3 * i + c] = m.y;
                a[5][3 * i + c] = m.z;
            }
        }
        // Newton: Σf + F_r + m g = m c̈  ⇒  Σf + F_r = m (c̈ − g);  in BW: (c̈ − g)/|g|.
        let need_f = (acc - DVec3::new(0.0, -params.gravity, 0.0)) / params.gravity;
        // Euler about the CoM: Σ (p − c) × f + τ_r = L̇.
        let need_t = ldot / (weight * arm);
        Ok(Problem {
            k,
            a,
            b: [need_f.x, need_f.y, need_f.z, need_t.x, need_t.y, need_t.z],
            normal,
            mu: params.mu,
            grip: params.grip_strength_bw,
            push: params.push_strength_bw,
            w_r: params.w_residual,
            w_f: params.w_force,
            weight,
            arm,
        })
    }

    /// Number of unknowns (3 per grip).
    pub fn n(&self) -> usize {
        3 * self.k
    }

    /// Residual `b − A x`.
    pub fn residual(&self, x: &[f64]) -> [f64; 6] {
        let mut r = self.b;
        for (row, ri) in self.a.iter().zip(r.iter_mut()) {
            *ri -= row[..x.len()]
                .iter()
                .zip(x)
                .map(|(a, x)| a * x)
                .sum::<f64>();
        }
        r
    }

    /// Force of grip `i` in BW.
    pub fn force(x: &[f64], i: usize) -> DVec3 {
        DVec3::new(x[3 * i], x[3 * i + 1], x[3 * i + 2])
    }

    /// The answer in newtons; `Err` if anything is not finite (never hand out NaN).
    pub fn loads(&self, x: &[f64], iterations: u32) -> Result<GripLoads, LoadError> {
        let r = self.residual(x);
        let mut out = GripLoads {
            count: self.k as u8,
            residual_force: (DVec3::new(r[0], r[1], r[2]) * self.weight).as_vec3(),
            residual_torque: (DVec3::new(r[3], r[4], r[5]) * (self.weight * self.arm)).as_vec3(),
            iterations,
            ..GripLoads::default()
        };
        for i in 0..self.k {
            out.forces[i] = (Self::force(x, i) * self.weight).as_vec3();
        }
        let all_finite = out.forces.iter().all(|f| f.is_finite())
            && out.residual_force.is_finite()
            && out.residual_torque.is_finite();
        if all_finite {
            Ok(out)
        } else {
            Err(LoadError::SolverFailed("non-finite result".into()))
        }
    }
}
