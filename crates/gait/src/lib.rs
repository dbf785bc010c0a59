//! Sloth locomotion rules (thesis chapter 3) as plain kernels: step search,
//! gait sequencer, swing arc, body averaging, trunk/branch transitions, and
//! what a sloth reports of itself each frame ([`observe`]; the judge and the
//! gait statistics that read it are in `slothsim-observe`). No ECS here: the
//! `sim` crate wires these into systems.
//!
//! Conventions: metres, seconds, radians, +Y up, right-handed.

pub mod observe;

pub use observe::{LimbObservation, SlothObservation};
pub mod config;
pub mod crowd;
pub mod env;
pub mod load;
pub mod path;
pub mod rigdata;
pub mod sloth;

pub use config::{ConfigError, LocomotionConfig, Profile, Sequence};
pub use crowd::{CrowdGrid, HashedPoint, Job, Jobs, Serial};
pub use env::{IK_TOLERANCE_M, LocoEnv, LocoView, crowd_points};
pub use load::{LimbLoads, LoadTrack, load_params};
pub use path::{Adjacency, AxisPoint, axis_at, project, surface_gap};
pub use rigdata::RigData;
pub use sloth::{
    BodyMemo, Fallback, Grip, LimbPhase, LimbState, NearRing, ObserveMemo, Sloth, SolveMemo,
    SpawnHint, Status, StuckCause, TraceBatch,
};
