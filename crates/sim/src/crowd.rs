//! The main job: a crowd of wandering sloths on a forest, in parallel and
//! deterministic. Spawning, the run loop, crowd statistics, the state hash
//! and checkpoints.

use std::path::{Path, PathBuf};

use bevy_ecs::prelude::*;
use glam::Vec3;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use slothsim_gait::{LimbPhase, LocomotionConfig, Sloth, SlothObservation, SpawnHint, TraceBatch};
use slothsim_observe::{GaitReport, GaitStats, Judge, JudgeReport, Tolerances};
use slothsim_rig::Rig;
use slothsim_scene::{ForestConfig, Scene, SupportId, SupportKind, TraceScene};

use crate::StageTimings;
use crate::world::{CrowdNeighbours, Locomotion, SimClock, SlothId, SlothState, Traces, new_world};

/// Spacing of spawn slots along a branch (body ~0.8 m plus clearance).
const SLOT_SPACING_M: f32 = 1.3;
/// Spawn slots keep this far from a branch's ends.
const SLOT_END_MARGIN_M: f32 = 0.6;
/// Branches thicker than this are not spawned on (limbs grip thin supports).
const SLOT_MAX_RADIUS_M: f32 = 0.12;
/// A sloth that has not completed a step for this long at the end of a run is stuck.
pub const STUCK_AFTER_S: f32 = 10.0;

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

/// Per-sloth judge and gait statistics, fed after every tick (outside the
/// timed stages).
#[derive(Component)]
pub struct Observer {
    judge: Judge,
    stats: GaitStats,
    planted: [bool; 4],
    /// Simulated time of the last touch-down.
    last_step_s: f32,
    /// Distinct supports a limb of this sloth was planted on, in order of first visit.
    visited: Vec<SupportId>,
    /// Frames on a trunk.
    trunk_frames: u64,
    /// Frames observed.
    frames: u64,
    /// Changes between branch and trunk (the body's `on_trunk` flips).
    kind_changes: u32,
    /// `on_trunk` of the last frame.
    on_trunk: Option<bool>,
}

impl Observer {
    fn new(tolerances: Tolerances, time_s: f32) -> Self {
        Observer {
            judge: Judge::new(tolerances, f32::INFINITY),
            stats: GaitStats::new(),
            planted: [true; 4],
            last_step_s: time_s,
            visited: Vec::new(),
            trunk_frames: 0,
            frames: 0,
            kind_changes: 0,
            on_trunk: None,
        }
    }

    fn observe(&mut self, obs: &SlothObservation) {
        self.judge.observe(obs);
        self.stats.observe(obs);
        for (i, l) in obs.limbs.iter().enumerate() {
            if l.planted && !self.planted[i] {
                self.last_step_s = obs.time_s;
            }
            self.planted[i] = l.planted;
            // A short list (a sloth holds a few dozen supports in a long run).
            if l.planted && !self.visited.contains(&l.support) {
                self.visited.push(l.support);
            }
        }
        self.frames += 1;
        self.trunk_frames += u64::from(obs.on_trunk);
        if self.on_trunk.is_some_and(|t| t != obs.on_trunk) {
            self.kind_changes += 1;
        }
        self.on_trunk = Some(obs.on_trunk);
    }
}

/// A crowd simulation: the ECS world, its schedule and the run's bookkeeping.
pub struct Crowd {
    world: World,
    schedule: Schedule,
    spec: CrowdSpec,
    forest: ForestSource,
    observe_ms: Vec<f64>,
}

/// Statistics of a crowd run (the content of `stats.json`).
#[derive(Clone, Debug, Serialize)]
pub struct CrowdStats {
    /// Sloths.
    pub sloths: u32,
    /// Frames simulated in this run (a resumed run counts its own).
    pub frames: u64,
    /// Time step (s).
    pub dt: f32,
    /// Simulated time at the end (s), including any resumed part.
    pub time_s: f32,
    /// Worker threads of the compute pool.
    pub threads: usize,
    /// Seed.
    pub seed: u64,
    /// Hash of the final state (hex), see [`Crowd::state_hash`].
    pub state_hash: String,
    /// Mean body speed over all sloths (m/s).
    pub speed_mps_mean: f32,
    /// Frame time (ms): p50, p95, max.
    pub frame_ms: Percentiles,
    /// Per stage p50/p95 (ms).
    pub stages_ms: StagesMs,
    /// Judge/statistics pass per frame, outside the stages (ms): p50, p95, max.
    pub observe_ms: Percentiles,
    /// Traces per frame (mean).
    pub traces_per_frame_mean: f64,
    /// Per-limb gait statistics over the crowd.
    pub gait: GaitReport,
    /// Judge measures over the crowd (worst sloth).
    pub max_grip_slip_m: f32,
    /// Largest grip ↔ surface distance of a planted limb.
    pub max_surface_gap_m: f32,
    /// Largest root → effector distance over limb length.
    pub max_reach_ratio: f32,
    /// Frames × limbs outside a joint limit.
    pub joint_limit_violations: u64,
    /// Fewest limbs in contact of any sloth at any frame.
    pub min_limbs_in_contact: u32,
    /// Deepest body/support penetration.
    pub max_penetration_m: f32,
    /// Frames where a sloth on a trunk had its head below its hips.
    pub head_below_hips_on_trunk_frames: u64,
    /// Non-finite values seen.
    pub nan_count: u64,
    /// Sloths that completed no step in the last [`STUCK_AFTER_S`] s.
    pub stuck_sloths: u32,
    /// Ids of the stuck sloths (first 100).
    pub stuck_ids: Vec<u32>,
    /// Times sloths turned back (dead ends or blocked), summed.
    pub turn_backs: u64,
    /// How much of the forest the crowd roamed in this run.
    pub roaming: Roaming,
    /// Which sloth holds the worst value of each measure (id), for follow-up.
    pub worst_sloths: WorstSloths,
    /// The full judge report over the crowd.
    pub judge: JudgeReport,
}

/// How much of the forest a crowd run covered (this run's frames; a resumed
/// run counts its own part).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Roaming {
    /// Supports of the forest.
    pub supports: u32,
    /// Supports some sloth planted a limb on.
    pub supports_visited: u32,
    /// Mean over sloths of the distinct supports each planted a limb on.
    pub supports_per_sloth_mean: f32,
    /// Trunks some sloth planted a limb on.
    pub trunks_climbed: u32,
    /// Share of sloth-frames spent on a trunk.
    pub trunk_frame_share: f32,
    /// Changes between branch and trunk (either way), summed over sloths.
    pub branch_trunk_changes: u64,
    /// Sloths that changed between branch and trunk at least once.
    pub sloths_changing_kind: u32,
}

/// The sloth with the worst value of each judge measure.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct WorstSloths {
    /// Largest grip slip.
    pub max_grip_slip: Option<u32>,
    /// Largest grip ↔ surface gap.
    pub max_surface_gap: Option<u32>,
    /// Largest reach ratio.
    pub max_reach_ratio: Option<u32>,
    /// Deepest penetration.
    pub max_penetration: Option<u32>,
    /// Fewest limbs in contact.
    pub min_limbs_in_contact: Option<u32>,
}

fn worst_by<'a>(
    rows: impl Iterator<Item = (u32, &'a JudgeReport)>,
    key: impl Fn(&JudgeReport) -> f32,
) -> Option<u32> {
    rows.max_by(|a, b| key(a.1).total_cmp(&key(b.1)).then(b.0.cmp(&a.0)))
        .map(|r| r.0)
}

/// p50 / p95 / max.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Percentiles {
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

impl Percentiles {
    /// Of `values` (nearest-rank); zeros when empty.
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Percentiles::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let at = |q: f64| v[((q * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1];
        Percentiles {
            p50: at(0.5),
            p95: at(0.95),
            max: v[v.len() - 1],
        }
    }
}

/// Per stage p50/p95 (ms).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StagesMs {
    /// Trace stage.
    pub trace: Percentiles,
    /// StepSearch stage.
    pub step_search: Percentiles,
    /// BodyAverage stage.
    pub body_average: Percentiles,
    /// CcdSolve stage.
    pub ccd_solve: Percentiles,
    /// Transitions stage (includes rebuilding the neighbour grid).
    pub transitions: Percentiles,
}

impl StagesMs {
    /// From per-frame stage times (columns in [`StageTimings::NAMES`] order).
    pub fn of(history: &[[f64; 5]]) -> Self {
        let col = |i: usize| Percentiles::of(&history.iter().map(|r| r[i]).collect::<Vec<_>>());
        StagesMs {
            trace: col(0),
            step_search: col(1),
            body_average: col(2),
            ccd_solve: col(3),
            transitions: col(4),
        }
    }
}

/// FNV-1a, 64 bit.
#[derive(Clone, Copy)]
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
}

/// Hash of a scene's supports (kinds, nodes and radii as bits).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Fnv::new();
    for s in scene.supports() {
        h.bytes(&[matches!(s.kind, SupportKind::Trunk) as u8]);
        for n in &s.nodes {
            h.f32s(&n.to_array());
        }
        h.f32s(&s.radii);
    }
    h.0
}

/// Sloths per tree the auto-sized forest plans for: a tree offers ~40 branch
/// slots of which about half pass the spawn check; 12 leaves room to wander.
pub const SLOTHS_PER_TREE: u32 = 12;

/// [`Crowd::state_hash`] of `sloths` (given in id order).
pub fn state_hash_of(sloths: &[Sloth]) -> u64 {
    let mut h = Fnv::new();
    for s in sloths {
        h.bytes(&s.id.to_le_bytes());
        h.f32s(&s.body_pos.to_array());
        h.f32s(&s.body_rot.to_array());
        for l in &s.limbs {
            h.f32s(&l.grip.point.to_array());
            for q in l.pose.0 {
                h.f32s(&q.to_array());
            }
        }
    }
    h.0
}

/// A procedural forest config sized for `sloths`: the embedded default (64
/// trees) up to 64 × [`SLOTHS_PER_TREE`] sloths, else more trees on a
/// proportionally larger area (same tree density). `trees` overrides.
pub fn forest_for(sloths: u32, trees: Option<u32>, seed: Option<u64>) -> ForestConfig {
    let mut cfg = ForestConfig::default();
    let trees = trees.unwrap_or_else(|| cfg.trees.max(sloths.div_ceil(SLOTHS_PER_TREE)));
    cfg.area_m *= (trees as f32 / cfg.trees as f32).sqrt();
    cfg.trees = trees;
    if let Some(seed) = seed {
        cfg.seed = seed;
    }
    cfg
}

/// Spawn slots: (support, axis point, axis tangent), in scene order.
fn spawn_slots(scene: &Scene) -> Vec<SpawnHint> {
    let mut slots = Vec::new();
    for s in scene.supports() {
        if s.kind != SupportKind::Branch {
            continue;
        }
        let len = s.length();
        let mut u = SLOT_END_MARGIN_M;
        while u <= len - SLOT_END_MARGIN_M {
            let a = slothsim_gait::axis_at(s, u);
            if a.radius <= SLOT_MAX_RADIUS_M && a.tangent.y.abs() < 0.7 {
                slots.push(SpawnHint {
                    support: s.id,
                    position: a.point,
                    forward: a.tangent,
                    body_side: Vec3::NEG_Y,
                });
            }
            u += SLOT_SPACING_M;
        }
    }
    slots
}

/// Whether a freshly spawned sloth holds all four grips properly.
fn spawn_ok(obs: &SlothObservation) -> bool {
    !obs.has_nan
        && obs.penetration_m <= 0.005
        && obs.limbs.iter().all(|l| {
            l.surface_gap <= 0.005
                && l.effector_ws.distance(l.grip_ws) <= 0.003
                && l.limit_violation <= 1e-4
                && l.root_ws.distance(l.effector_ws) <= l.limb_length
        })
}

impl Crowd {
    /// Spawns `spec.sloths` wandering sloths on `scene`, spread over its
    /// branches (slots shuffled by the seed), each with its own seed and heading.
    pub fn new(
        spec: CrowdSpec,
        rig: &Rig,
        scene: Scene,
        forest: ForestSource,
    ) -> Result<Crowd, CrowdError> {
        spec.validate()?;
        let mut slots = spawn_slots(&scene);
        let capacity = slots.len() as u32;
        if spec.sloths > capacity {
            return Err(CrowdError::TooMany {
                requested: spec.sloths,
                capacity,
            });
        }
        let mut rng = Pcg64Mcg::seed_from_u64(spec.seed);
        slots.shuffle(&mut rng);
        let headings: Vec<bool> = (0..slots.len())
            .map(|_| rand::Rng::random_bool(&mut rng, 0.5))
            .collect();
        let loco = Locomotion::new(spec.cfg.clone(), rig, TraceScene::new(scene))?;
        let mut neighbours = CrowdNeighbours::new(spec.clearance_m);
        let mut accepted: Vec<Sloth> = Vec::with_capacity(spec.sloths as usize);
        // Spawn in parallel chunks; accept in slot order (deterministic).
        // The grid holds the sloths accepted before this chunk; those accepted
        // within it are checked one by one (`fresh`), the same test as the
        // grid's, so the result does not depend on chunking and the grid is
        // rebuilt once a chunk instead of once a sloth.
        let r2 = spec.clearance_m * spec.clearance_m;
        let mut fresh: Vec<Vec3> = Vec::new();
        let mut next = 0usize;
        while accepted.len() < spec.sloths as usize && next < slots.len() {
            // Spawning is the costly part: no more at once than still needed
            // (plus a margin for rejects), and enough to keep the pool busy.
            let missing = spec.sloths as usize - accepted.len();
            let chunk = (missing + missing / 4 + 16).min(256);
            let end = (next + chunk).min(slots.len());
            let w = loco.view();
            let spawned: Vec<(Sloth, bool)> = (next..end)
                .into_par_iter()
                .map(|i| {
                    let mut hint = slots[i];
                    if headings[i] {
                        hint.forward = -hint.forward;
                    }
                    let s = Sloth::spawn(&w, &hint, None);
                    let ok = spawn_ok(&s.observe(&w));
                    (s, ok)
                })
                .collect();
            fresh.clear();
            let before = accepted.len();
            for (mut s, ok) in spawned {
                if !ok || accepted.len() == spec.sloths as usize {
                    continue;
                }
                let id = accepted.len() as u32;
                s.id = id;
                let body = [s.body_pos];
                let clear = body
                    .iter()
                    .chain(s.limbs.iter().map(|l| &l.grip.point))
                    .all(|&p| {
                        let near_fresh = p.is_finite()
                            && fresh
                                .iter()
                                .any(|q| q.is_finite() && q.distance_squared(p) < r2);
                        !neighbours.grid.blocked(u32::MAX, p) && !near_fresh
                    });
                if !clear {
                    continue;
                }
                s.wander = true;
                s.seed = slothsim_gait::sloth::mix64(spec.seed ^ ((id as u64) << 20));
                // Sloths do not step in lock-step: each starts at its own gait phase.
                s.clock = (s.seed >> 40) as f32 / (1u64 << 24) as f32;
                fresh.extend(crate::world::crowd_points(&loco.rig, &s));
                accepted.push(s);
            }
            if accepted.len() > before {
                neighbours.rebuild(&loco, accepted.iter().map(|s| (s.id, s)));
            }
            next = end;
        }
        if accepted.len() < spec.sloths as usize {
            return Err(CrowdError::TooMany {
                requested: spec.sloths,
                capacity: accepted.len() as u32,
            });
        }
        Ok(Self::assemble(
            spec, loco, forest, neighbours, accepted, None, 0,
        ))
    }

    fn assemble(
        spec: CrowdSpec,
        loco: Locomotion,
        forest: ForestSource,
        mut neighbours: CrowdNeighbours,
        sloths: Vec<Sloth>,
        traces: Option<Vec<TraceBatch>>,
        frame: u64,
    ) -> Crowd {
        neighbours.rebuild(&loco, sloths.iter().map(|s| (s.id, s)));
        let mut world = new_world(loco, spec.dt);
        world.resource_mut::<SimClock>().frame = frame;
        world.insert_resource(neighbours);
        let tol = Tolerances::issue_limits();
        let mut traces = traces.map(|t| t.into_iter());
        world.spawn_batch(
            sloths
                .into_iter()
                .map(|s| {
                    let tr = traces.as_mut().and_then(|t| t.next()).unwrap_or_default();
                    (
                        SlothId(s.id),
                        Observer::new(tol, s.time),
                        SlothState(s),
                        Traces(tr),
                    )
                })
                .collect::<Vec<_>>(),
        );
        Crowd {
            world,
            schedule: crate::build_schedule(),
            spec,
            forest,
            observe_ms: Vec::new(),
        }
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

    /// Per-frame stage timings so far.
    pub fn timings(&self) -> &StageTimings {
        self.world.resource::<StageTimings>()
    }

    /// One tick (the five stages) without the judge/statistics pass: what
    /// `slothsim bench` times. The run's judge misses the frames run this way.
    pub fn tick(&mut self) {
        self.schedule.run(&mut self.world);
    }

    /// One tick, then the judge/statistics pass (not part of the stage timings).
    pub fn step(&mut self) {
        self.schedule.run(&mut self.world);
        let t = std::time::Instant::now();
        let mut q = self.world.query::<(&SlothState, &mut Observer)>();
        self.world.resource_scope(|world, loco: Mut<Locomotion>| {
            let w = loco.view();
            q.par_iter_mut(world)
                .batching_strategy(crate::schedule::BATCHING)
                .for_each(|(s, mut o)| o.observe(&s.0.observe(&w)));
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

    /// Hash of the state in sloth-id order: body positions and rotations,
    /// grips and every joint rotation, as bits. Equal across thread counts.
    pub fn state_hash(&mut self) -> u64 {
        state_hash_of(&self.sloths())
    }

    /// Crowd statistics of the run so far.
    pub fn stats(&mut self, threads: usize) -> CrowdStats {
        let frames = self.timings().history.len() as u64;
        let history = self.timings().history.clone();
        let frame_ms: Vec<f64> = history.iter().map(|r| r.iter().sum()).collect();
        let mut q = self.world.query::<(&SlothId, &SlothState, &Observer)>();
        let mut rows: Vec<(u32, f32, u32, JudgeReport, GaitReport, bool)> = q
            .iter(&self.world)
            .map(|(id, s, o)| {
                let stuck = s.0.time - o.last_step_s > STUCK_AFTER_S;
                (
                    id.0,
                    s.0.time,
                    s.0.turns,
                    o.judge.finish(),
                    o.stats.finish(),
                    stuck,
                )
            })
            .collect();
        rows.sort_unstable_by_key(|r| r.0);
        let judge = JudgeReport::aggregate(rows.iter().map(|r| &r.3))
            .unwrap_or_else(|| Judge::new(Tolerances::issue_limits(), f32::INFINITY).finish());
        let gait = GaitReport::aggregate(rows.iter().map(|r| &r.4));
        let stuck_ids: Vec<u32> = rows.iter().filter(|r| r.5).map(|r| r.0).collect();
        let roaming = self.roaming();
        let reports = || rows.iter().map(|r| (r.0, &r.3));
        let worst_sloths = WorstSloths {
            max_grip_slip: worst_by(reports(), |j| j.max_grip_slip_m),
            max_surface_gap: worst_by(reports(), |j| j.max_surface_gap_m),
            max_reach_ratio: worst_by(reports(), |j| j.max_reach_ratio),
            max_penetration: worst_by(reports(), |j| j.max_penetration_m),
            min_limbs_in_contact: worst_by(reports(), |j| -(j.min_limbs_in_contact as f32)),
        };
        let time_s = rows.first().map_or(0.0, |r| r.1);
        let state_hash = format!("{:016x}", self.state_hash());
        CrowdStats {
            sloths: rows.len() as u32,
            frames,
            dt: self.spec.dt,
            time_s,
            threads,
            seed: self.spec.seed,
            state_hash,
            speed_mps_mean: gait.speed_mps_mean,
            frame_ms: Percentiles::of(&frame_ms),
            stages_ms: StagesMs::of(&history),
            observe_ms: Percentiles::of(&self.observe_ms),
            traces_per_frame_mean: self.timings().traces_total as f64 / frames.max(1) as f64,
            max_grip_slip_m: judge.max_grip_slip_m,
            max_surface_gap_m: judge.max_surface_gap_m,
            max_reach_ratio: judge.max_reach_ratio,
            joint_limit_violations: judge.joint_limit_violations,
            min_limbs_in_contact: judge.min_limbs_in_contact,
            max_penetration_m: judge.max_penetration_m,
            head_below_hips_on_trunk_frames: judge.head_below_hips_on_trunk_frames,
            nan_count: judge.nan_count,
            stuck_sloths: stuck_ids.len() as u32,
            stuck_ids: stuck_ids.into_iter().take(100).collect(),
            turn_backs: rows.iter().map(|r| r.2 as u64).sum(),
            roaming,
            worst_sloths,
            gait,
            judge,
        }
    }

    /// Coverage of the forest by the crowd (see [`Roaming`]).
    fn roaming(&mut self) -> Roaming {
        let scene = self.world.resource::<Locomotion>().traces.scene();
        let n = scene.supports().len();
        let kinds: Vec<SupportKind> = scene.supports().iter().map(|s| s.kind).collect();
        let mut visited = vec![false; n];
        let mut climbed = vec![false; n];
        let mut r = Roaming {
            supports: n as u32,
            ..Roaming::default()
        };
        let (mut frames, mut trunk_frames, mut per_sloth) = (0u64, 0u64, 0u64);
        let mut sloths = 0u32;
        let mut q = self.world.query::<&Observer>();
        for o in q.iter(&self.world) {
            sloths += 1;
            per_sloth += o.visited.len() as u64;
            for &sid in &o.visited {
                visited[sid.0 as usize] = true;
                climbed[sid.0 as usize] = kinds[sid.0 as usize] == SupportKind::Trunk;
            }
            frames += o.frames;
            trunk_frames += o.trunk_frames;
            r.branch_trunk_changes += u64::from(o.kind_changes);
            r.sloths_changing_kind += u32::from(o.kind_changes > 0);
        }
        r.supports_visited = visited.iter().filter(|&&v| v).count() as u32;
        r.trunks_climbed = climbed.iter().filter(|&&v| v).count() as u32;
        r.supports_per_sloth_mean = per_sloth as f32 / sloths.max(1) as f32;
        r.trunk_frame_share = trunk_frames as f32 / frames.max(1) as f32;
        r
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

// ------------------------------------------------------------- checkpoints

const MAGIC: &[u8; 16] = b"SLOTHSIM-STATE\0\0";
/// Checkpoint format version; bump on any change of the saved data.
pub const CHECKPOINT_VERSION: u32 = 11;

#[derive(Serialize, Deserialize)]
struct Checkpoint {
    pkg_version: String,
    seed: u64,
    dt: f32,
    clearance_m: f32,
    frame: u64,
    cfg: LocomotionConfig,
    forest: ForestSource,
    sloths: Vec<Sloth>,
    traces: Vec<TraceBatch>,
}

/// What a checkpoint holds besides the sloths: enough to rebuild the run.
#[derive(Clone, Debug)]
pub struct CheckpointInfo {
    /// The forest.
    pub forest: ForestSource,
    /// Sloths.
    pub sloths: u32,
    /// Seed.
    pub seed: u64,
    /// Frames simulated before the checkpoint.
    pub frame: u64,
}

impl Crowd {
    /// Writes the state (sloths, their queued traces, config, forest source)
    /// to `path` through a temporary file renamed at the end.
    pub fn save_state(&mut self, path: &Path) -> Result<(), CrowdError> {
        let err = |message: String| CrowdError::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        let mut q = self.world.query::<(&SlothId, &SlothState, &Traces)>();
        let mut rows: Vec<(u32, Sloth, TraceBatch)> = q
            .iter(&self.world)
            .map(|(i, s, t)| (i.0, s.0, t.0.clone()))
            .collect();
        rows.sort_unstable_by_key(|r| r.0);
        let cp = Checkpoint {
            pkg_version: env!("CARGO_PKG_VERSION").to_string(),
            seed: self.spec.seed,
            dt: self.spec.dt,
            clearance_m: self.spec.clearance_m,
            frame: self.frame(),
            cfg: self.spec.cfg.clone(),
            forest: self.forest.clone(),
            sloths: rows.iter().map(|r| r.1).collect(),
            traces: rows.into_iter().map(|r| r.2).collect(),
        };
        let payload = postcard::to_stdvec(&cp).map_err(|e| err(format!("encode: {e}")))?;
        let mut h = Fnv::new();
        h.bytes(&payload);
        let mut bytes = Vec::with_capacity(payload.len() + 28);
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
        bytes.extend_from_slice(&h.0.to_le_bytes());
        bytes.extend_from_slice(&payload);
        crate::write_atomically(path, &bytes).map_err(|e| err(e.to_string()))
    }

    fn decode(path: &Path) -> Result<Checkpoint, CrowdError> {
        let err = |message: String| CrowdError::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read: {e}")))?;
        if bytes.len() < 28 || &bytes[..16] != MAGIC {
            return Err(err("not a slothsim state file (bad magic)".into()));
        }
        let version = u32::from_le_bytes(bytes[16..20].try_into().expect("4 bytes"));
        if version != CHECKPOINT_VERSION {
            return Err(err(format!(
                "format version {version}, this slothsim reads version {CHECKPOINT_VERSION}"
            )));
        }
        let sum = u64::from_le_bytes(bytes[20..28].try_into().expect("8 bytes"));
        let mut h = Fnv::new();
        h.bytes(&bytes[28..]);
        if h.0 != sum {
            return Err(err("corrupt: checksum mismatch".into()));
        }
        let cp: Checkpoint =
            postcard::from_bytes(&bytes[28..]).map_err(|e| err(format!("corrupt: {e}")))?;
        if cp.pkg_version != env!("CARGO_PKG_VERSION") {
            return Err(err(format!(
                "written by slothsim {}, this is {}",
                cp.pkg_version,
                env!("CARGO_PKG_VERSION")
            )));
        }
        if cp.sloths.len() != cp.traces.len() || cp.sloths.is_empty() {
            return Err(err("corrupt: sloth count".into()));
        }
        if cp.sloths.iter().any(|s| {
            !(s.body_pos.is_finite()
                && s.body_rot.is_finite()
                && s.limbs.iter().all(|l| l.pose.is_finite()))
        }) {
            return Err(err("corrupt: non-finite sloth state".into()));
        }
        Ok(cp)
    }

    /// Reads what a checkpoint needs to rebuild its run (to load its forest).
    pub fn checkpoint_info(path: &Path) -> Result<CheckpointInfo, CrowdError> {
        let cp = Self::decode(path)?;
        Ok(CheckpointInfo {
            forest: cp.forest,
            sloths: cp.sloths.len() as u32,
            seed: cp.seed,
            frame: cp.frame,
        })
    }

    /// Continues a run from a checkpoint on `scene` (which must be the
    /// checkpoint's forest: its hash is checked).
    pub fn load_state(path: &Path, rig: &Rig, scene: Scene) -> Result<Crowd, CrowdError> {
        let cp = Self::decode(path)?;
        let err = |message: String| CrowdError::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        if let ForestSource::File { scene_hash: h, .. } = &cp.forest
            && *h != scene_hash(&scene)
        {
            return Err(err(
                "the forest file differs from the one the state was saved on".into(),
            ));
        }
        let n = scene.supports().len() as u32;
        if cp.sloths.iter().any(|s| {
            s.limbs
                .iter()
                .any(|l| l.grip.support.0 >= n || l.search.support.0 >= n)
        }) {
            return Err(err("refers to supports the forest does not have".into()));
        }
        let spec = CrowdSpec {
            sloths: cp.sloths.len() as u32,
            seed: cp.seed,
            dt: cp.dt,
            cfg: cp.cfg,
            clearance_m: cp.clearance_m,
        };
        spec.validate()?;
        let loco = Locomotion::new(spec.cfg.clone(), rig, TraceScene::new(scene))?;
        let neighbours = CrowdNeighbours::new(spec.clearance_m);
        Ok(Self::assemble(
            spec,
            loco,
            cp.forest,
            neighbours,
            cp.sloths,
            Some(cp.traces),
            cp.frame,
        ))
    }
}
