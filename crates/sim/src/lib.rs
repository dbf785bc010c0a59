//! The simulation: the only bevy_ecs crate. One sloth = one entity; the tick
//! is one schedule of five chained stages (see [`schedule`]); each stage runs
//! its per-sloth kernel (from `slothsim-gait`) in parallel over all sloths and
//! times itself into [`StageTimings`].

pub mod scenario;
pub mod schedule;
pub mod world;

pub use scenario::{ScenarioResult, ScenarioSpec, TrunkVariant, run_scenario};
pub use schedule::{SimSystems, StageTimings, build_schedule, init_compute_pool};
pub use world::{Locomotion, SimClock, SlothId, SlothState, Traces, new_world, spawn_sloth};
