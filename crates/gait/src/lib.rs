//! Sloth locomotion rules (thesis chapter 3) as plain kernels: step search,
//! gait sequencer, swing arc, body averaging, trunk/branch transitions, plus
//! the automatic judge and gait statistics. No ECS here: the `sim` crate wires
//! these into systems.
//!
//! Conventions: metres, seconds, radians, +Y up, right-handed.

pub mod observe;

pub use observe::{LimbObservation, SlothObservation};
pub mod judge;
pub mod stats;
pub use judge::{Judge, JudgeReport, JudgeWorst, MeasureAt, ToleranceError, Tolerances, Verdict};
pub use stats::{FootfallSequence, GaitReport, GaitStats, LimbGaitReport, PerLimb};
