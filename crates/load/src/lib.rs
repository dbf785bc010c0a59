//! Grip loads of a sloth (issue 22, after seed 003 ch. 2): which force each planted claw
//! carries, and the residual wrench the body would need "from nowhere" when its grips
//! cannot balance it. One small convex QP per sloth per frame:
//!
//! minimise `w_r |residual|² + w_f Σ|f_i|²` over the grip forces `f_i` and the residual
//! wrench, subject to the Newton–Euler balance of the body (equality) and each force in
//! its hooked-claw grip set (a second-order friction cone about the surface normal whose
//! pull toward the support's axis is capped by the grip strength).
//!
//! No ECS: the caller gives positions (centre of mass, its acceleration, claw points and
//! surface normals) and gets forces in newtons. [`solve`] is the specialised solver used
//! per frame; [`solve_reference`] hands the same problem to clarabel and is what the
//! specialised one is proven against (tests/vs_clarabel.rs). The crate README states the
//! formulation, the cone and its reasoning, and the measured cost.

mod active;
mod barrier;
mod closed;
mod dual;
mod error;
mod model;
mod params;
mod reference;

pub use active::{ActiveSet, CONE, PULL, PUSH};
pub use barrier::{solve, solve_from, solve_warm};
pub use error::LoadError;
pub use model::{
    Grip, GripLoads, GripState, MAX_GRIPS, MassPoint, SolveMethod, Stance, centre_of_mass,
    com_acceleration, grip_slacks, grip_states,
};
pub use params::LoadParams;
pub use reference::solve_reference;
