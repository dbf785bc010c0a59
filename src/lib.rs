//! slothsim — crowds of procedurally animated two-toed sloths climbing a forest.
//!
//! This facade re-exports the library crates; the `slothsim` binary is the CLI.
//! Conventions everywhere: metres, seconds, radians inside (degrees only at the
//! edges), +Y up, right-handed (glTF axes), fixed time step.

pub use slothsim_gait as gait;
pub use slothsim_observe as observe;
pub use slothsim_rig as rig;
pub use slothsim_scene as scene;
pub use slothsim_sim as sim;

pub mod to_plot;
