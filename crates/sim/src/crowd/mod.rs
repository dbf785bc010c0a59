//! The main job: a crowd of wandering sloths on a forest, in parallel and
//! deterministic. [`Crowd`] holds the ECS world and the tick schedule and
//! runs them ([`Crowd::step`]: one tick, then every sloth's [`Observer`]);
//! the rest is by concern:
//! - [`spawn`]: where sloths start (branch slots, the spawn check) and how big
//!   a forest a crowd needs;
//! - [`stats`]: the per-sloth observer (judge and gait statistics) and the
//!   crowd statistics of `stats.json`;
//! - [`hash`]: the state and scene hashes (determinism checks, checkpoints);
//! - [`checkpoint`]: saving and resuming a run.

use std::path::PathBuf;

use bevy_ecs::prelude::*;
use serde::{Deserialize, Serialize};
use slothsim_gait::{LimbPhase, LocomotionConfig, Sloth, TraceBatch};
use slothsim_observe::Judge;
use slothsim_scene::ForestConfig;

use crate::StageTimings;
use crate::world::{
    CrowdNeighbours, GripLoad, GripLoadEvery, Locomotion, NearStances, SimClock, SlothId,
    SlothState, Traces, new_world,
};

pub mod checkpoint;
pub mod hash;
pub mod spawn;
pub mod stats;

pub use checkpoint::{CHECKPOINT_VERSION, CheckpointInfo};
pub use hash::{scene_hash, state_hash_of};
pub use spawn::{SLOTHS_PER_TREE, forest_for};
pub use stats::{
    CauseCount, CrowdStats, Observer, Percentiles, Roaming, STALLED_TURNS, STUCK_AFTER_S, StagesMs,
    StuckReport, WorstSloths,
};

use spawn::SLOT_SPACING_M;

/// Errors of the crowd run (each names what is wrong).
#[derive(Debug, thiserror::Error)]
pub enum CrowdError {
    /// Bad crowd parameters.
    #[error("{field}: {message}")]
    Invalid {
        /// The parameter.
        field: &'static str,
        /// What is wrong.
        message: String,
    },
    /// The locomotion config does not fit the rig.
    #[error(transparent)]
    Config(#[from] slothsim_gait::ConfigError),
    /// The forest cannot hold the crowd.
    #[error(
        "the forest cannot hold {requested} sloths: it has room for {capacity} (branch slots {SLOT_SPACING_M} m apart); use fewer sloths or a bigger forest (--trees)"
    )]
    TooMany {
        /// Sloths asked for.
        requested: u32,
        /// Sloths that fit.
        capacity: u32,
    },
    /// Reading or writing a checkpoint failed.
    #[error("checkpoint {path}: {message}")]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

/// Where the forest came from (kept in checkpoints to rebuild it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum ForestSource {
    /// The procedural forest with this config.
    Procedural(ForestConfig),
    /// A glTF file, with the hash of the scene read from it.
    File {
        /// Path as given.
        path: PathBuf,
        /// [`scene_hash`] of its supports.
        scene_hash: u64,
    },
}

/// What to run.
#[derive(Clone, Debug)]
pub struct CrowdSpec {
    /// Number of sloths.
    pub sloths: u32,
    /// Seed of spawning and route choices.
    pub seed: u64,
    /// Fixed time step (s).
    pub dt: f32,
    /// Locomotion parameters.
    pub cfg: LocomotionConfig,
    /// Clearance between sloths (m).
    pub clearance_m: f32,
}

impl CrowdSpec {
    /// Checks the parameters.
    pub fn validate(&self) -> Result<(), CrowdError> {
        if self.sloths == 0 {
            return Err(CrowdError::Invalid {
                field: "sloths",
                message: "must be at least 1".into(),
            });
        }
        if !(self.dt.is_finite() && self.dt > 0.0 && self.dt <= 0.1) {
            return Err(CrowdError::Invalid {
                field: "dt",
                message: format!("{} s is outside (0, 0.1]", self.dt),
            });
        }
        if !(self.clearance_m.is_finite() && (0.0..=2.0).contains(&self.clearance_m)) {
            return Err(CrowdError::Invalid {
                field: "clearance_m",
                message: format!("{} m is outside 0..=2", self.clearance_m),
            });
        }
        Ok(())
    }
}

/// A crowd simulation: the ECS world, its schedule and the run's bookkeeping.
pub struct Crowd {
    world: World,
    schedule: Schedule,
    spec: CrowdSpec,
    /// Where the forest came from; `None` for a lone sloth on a scenario
    /// preset (not checkpointed).
    forest: Option<ForestSource>,
    observe_ms: Vec<f64>,
}

impl Crowd {
    /// The world of `sloths` with their queued traces at `frame`, each
    /// with an [`Observer`] judging with `judge`. With `neighbours`, sloths
    /// keep clear of each other; without, a sloth is alone (a scenario run,
    /// whose observer also keeps every observation). A sloth that keeps a
    /// goal-mode stance record ([`Sloth::keeps_near_record`]) gets an empty
    /// [`NearStances`].
    fn assemble(
        spec: CrowdSpec,
        loco: Locomotion,
        forest: Option<ForestSource>,
        neighbours: Option<CrowdNeighbours>,
        sloths: Vec<(Sloth, TraceBatch)>,
        frame: u64,
        judge: Judge,
    ) -> Crowd {
        let keep_history = neighbours.is_none();
        let neighbours = neighbours.map(|mut n| {
            n.rebuild(&loco, sloths.iter().map(|(s, _)| (s.id, s)));
            n
        });
        let mut world = new_world(loco, spec.dt);
        world.resource_mut::<SimClock>().frame = frame;
        world.insert_resource(GripLoadEvery(if keep_history {
            1
        } else {
            u32::from(spec.cfg.crowd_load_every)
        }));
        if let Some(n) = neighbours {
            world.insert_resource(n);
        }
        let keeps: Vec<bool> = sloths.iter().map(|(s, _)| s.keeps_near_record()).collect();
        let entities: Vec<Entity> = world
            .spawn_batch(
                sloths
                    .into_iter()
                    .map(|(s, tr)| {
                        (
                            SlothId(s.id),
                            Observer::new(judge.clone(), s.time, keep_history),
                            SlothState(s),
                            Traces(tr),
                        )
                    })
                    .collect::<Vec<_>>(),
            )
            .collect();
        for (e, keeps) in entities.into_iter().zip(keeps) {
            if keeps {
                world.entity_mut(e).insert(NearStances::default());
            }
        }
        Crowd {
            world,
            schedule: crate::build_schedule(),
            spec,
            forest,
            observe_ms: Vec::new(),
        }
    }

    /// Where the forest came from; `None` for a lone sloth on a scenario preset.
    pub fn forest_source(&self) -> Option<&ForestSource> {
        self.forest.as_ref()
    }

    /// The spec.
    pub fn spec(&self) -> &CrowdSpec {
        &self.spec
    }

    /// Frames simulated since the crowd was created (or since the checkpoint's start).
    pub fn frame(&self) -> u64 {
        self.world.resource::<SimClock>().frame
    }

    /// The ECS world (read-only).
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The entity of sloth `id`.
    pub fn entity(&self, id: u32) -> Option<Entity> {
        let mut q = self.world.try_query::<(Entity, &SlothId)>()?;
        q.iter(&self.world).find(|(_, i)| i.0 == id).map(|(e, _)| e)
    }

    /// Per-frame stage timings so far.
    pub fn timings(&self) -> &StageTimings {
        self.world.resource::<StageTimings>()
    }

    /// One tick (the six stages) without the judge/statistics pass: what
    /// `slothsim bench` times. The run's judge misses the frames run this way.
    pub fn tick(&mut self) {
        self.schedule.run(&mut self.world);
    }

    /// One tick, then the judge/statistics pass (not part of the stage timings).
    pub fn step(&mut self) {
        self.schedule.run(&mut self.world);
        let t = std::time::Instant::now();
        let mut q = self
            .world
            .query::<(&SlothState, &GripLoad, &mut Observer)>();
        self.world.resource_scope(|world, loco: Mut<Locomotion>| {
            let w = loco.view();
            let release = w.cfg.release_residual_bw;
            q.par_iter_mut(world)
                .batching_strategy(crate::schedule::BATCHING)
                .for_each(|(s, g, mut o)| {
                    let o = &mut *o;
                    let seen = s.0.observe_memo(&w, &mut o.memo);
                    o.observe(&seen);
                    o.observe_loads(s.0.time, &g.0, release);
                });
        });
        self.observe_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }

    /// Every sloth, in id order.
    pub fn sloths(&mut self) -> Vec<Sloth> {
        let mut q = self.world.query::<(&SlothId, &SlothState)>();
        let mut v: Vec<(u32, Sloth)> = q.iter(&self.world).map(|(i, s)| (i.0, s.0)).collect();
        v.sort_unstable_by_key(|(i, _)| *i);
        v.into_iter().map(|(_, s)| s).collect()
    }

    /// How many limbs are swinging right now (for progress lines).
    pub fn swinging(&mut self) -> usize {
        let mut q = self.world.query::<&SlothState>();
        q.iter(&self.world)
            .map(|s| {
                s.0.limbs
                    .iter()
                    .filter(|l| l.phase == LimbPhase::Swinging)
                    .count()
            })
            .sum()
    }
}
