//! The simulation: the only bevy_ecs crate. One sloth = one entity; the tick
//! is one schedule of six stages (see [`schedule`]), run as one parallel pass
//! of the per-sloth kernels (from `slothsim-gait`) over all sloths, each stage
//! timed into [`StageTimings`]. [`crowd`] is the main job: a crowd of
//! wandering sloths on a forest; [`scenario`] runs one sloth on a preset.

pub mod baseline;
pub mod crowd;
pub mod grip_stats;
pub mod record;
pub mod scenario;
pub mod schedule;
pub mod snapshot;
pub mod world;

pub use crowd::{
    CheckpointInfo, Crowd, CrowdError, CrowdSpec, CrowdStats, ForestSource, Percentiles, StagesMs,
    WorstSloths, forest_for, scene_hash, state_hash_of,
};
pub use grip_stats::{GripLoadReport, GripLoadStats, LimbLoadReport, ReleaseCounts};
pub use scenario::{
    STEADY_AFTER_CYCLES, STEADY_BEFORE_STOP_CYCLES, ScenarioResult, ScenarioSpec, SteadyGait,
    TrunkVariant, run_scenario, run_scenario_observed, steady_gait,
};
pub use schedule::{STAGES, SimSystems, StageTimings, build_schedule, init_compute_pool};
pub use world::{
    BodyAverageMemo, CROWD_LOAD_EVERY, CcdMemo, CrowdNeighbours, GripLoad, GripLoadEvery,
    Locomotion, NearStances, SimClock, SlothId, SlothState, Traces, new_world, spawn_sloth,
};

/// Writes a file through a temporary name (the scene crate's one helper).
pub use slothsim_scene::write_atomically;
