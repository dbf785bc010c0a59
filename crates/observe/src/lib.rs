//! What only watches the sloths: the automatic [`judge`] (measured pass/fail
//! criteria of a run) and the gait [`stats`] (contact, swing, stride,
//! footfall order). Both are streaming accumulators fed one
//! [`SlothObservation`] per frame (what `slothsim-gait` reports of a sloth);
//! neither changes the simulation.
//!
//! Conventions: metres, seconds, radians, +Y up, right-handed.

pub mod judge;
pub mod stats;

pub use judge::{Judge, JudgeReport, JudgeWorst, MeasureAt, ToleranceError, Tolerances, Verdict};
pub use slothsim_gait::observe::{LimbObservation, SlothObservation};
pub use stats::{FootfallSequence, GaitReport, GaitStats, LimbGaitReport, PerLimb};
