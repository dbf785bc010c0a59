//! slothsim — crowds of procedurally animated two-toed sloths climbing a forest.
//!
//! This facade re-exports the library crates; the `slothsim` binary is the CLI.
//! Conventions everywhere: metres, seconds, radians inside (degrees only at the
//! edges), +Y up, right-handed (glTF axes), fixed time step.
//!
//! # Embedding a crowd
//!
//! Build a forest, spawn a [`sim::Crowd`], tick it and read every sloth's pose
//! after each tick (the whole program: `examples/embed_crowd.rs`):
//!
//! ```no_run
//! use slothsim::gait::LocomotionConfig;
//! use slothsim::rig::Rig;
//! use slothsim::scene::{ForestConfig, generate_forest};
//! use slothsim::sim::{Crowd, CrowdSpec, ForestSource, init_compute_pool};
//!
//! # fn main() -> anyhow::Result<()> {
//! let threads = init_compute_pool(None); // the stages' worker pool, all cores
//! let forest = ForestConfig { trees: 6, area_m: 25.0, ..ForestConfig::default() };
//! let scene = generate_forest(&forest)?;
//! let spec = CrowdSpec {
//!     sloths: 40,
//!     seed: 7,
//!     dt: 1.0 / 60.0,
//!     cfg: LocomotionConfig::default(),
//!     clearance_m: 0.3,
//! };
//! let mut crowd = Crowd::new(spec, &Rig::sloth(), scene, ForestSource::Procedural(forest))?;
//! for _ in 0..120 {
//!     crowd.step();
//! }
//! for sloth in crowd.sloths() {
//!     let grips: Vec<_> = sloth.limbs.iter().map(|l| l.grip.point).collect();
//!     println!("sloth {} body {:?} grips {grips:?}", sloth.id, sloth.body_pos);
//! }
//! println!("state_hash {}", crowd.stats(threads).state_hash);
//! # Ok(())
//! # }
//! ```
//!
//! # One scenario
//!
//! Run a thesis test scene and read the judge's verdict
//! (`examples/one_scenario.rs`):
//!
//! ```no_run
//! use slothsim::gait::LocomotionConfig;
//! use slothsim::observe::Tolerances;
//! use slothsim::rig::Rig;
//! use slothsim::scene::{Preset, PresetKind};
//! use slothsim::sim::{ScenarioSpec, TrunkVariant, run_scenario};
//!
//! # fn main() -> anyhow::Result<()> {
//! let spec = ScenarioSpec {
//!     preset: Preset::new(PresetKind::Turn, Some(120.0))?,
//!     variant: TrunkVariant::Up,
//!     cfg: LocomotionConfig::default(),
//!     dt: 1.0 / 60.0,
//!     time_limit_s: None,
//!     tolerances: Tolerances::default(),
//! };
//! let result = run_scenario(&spec, &Rig::sloth())?;
//! println!("pass {}, slip {} m", result.verdict.pass, result.judge.max_grip_slip_m);
//! # Ok(())
//! # }
//! ```
//!
//! # In a bevy app
//!
//! The tick is plain bevy_ecs: [`sim::new_world`] inserts the resources the
//! stages read (`Locomotion`, `SimClock`, `StageTimings`, the memos; add
//! `CrowdNeighbours` for crowds), [`sim::spawn_sloth`] adds a sloth entity
//! (`SlothId`, `SlothState`, `Traces`), and [`sim::build_schedule`] is the tick:
//! six chained [`sim::SimSystems`] sets (the per-sloth work in one pass in
//! the first, the neighbour grid's rebuild in the last), to run as a schedule
//! or to order against the app's own systems.

pub use slothsim_export as export;
pub use slothsim_gait as gait;
pub use slothsim_observe as observe;
pub use slothsim_rig as rig;
pub use slothsim_scene as scene;
pub use slothsim_sim as sim;
pub use slothsim_skin as skin;

pub mod skin_view;
pub mod to_plot;
