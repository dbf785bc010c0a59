//! The tick, in one place: six stages in order — Trace, StepSearch,
//! BodyAverage, CcdSolve, GripLoad, Transitions. Each stage of a sloth reads only that
//! sloth and what no stage writes during the tick (forest, config, the
//! neighbour grid of the last tick), so they run as one parallel pass over
//! whole table slices (`contiguous_par_iter_mut` on bevy's compute task pool):
//! a worker takes `CHUNK` (32) sloths through all six stages, then the next
//! ones (CcdSolve solves the sloths of a chunk two by two in SIMD lanes). Then
//! the end of Transitions rebuilds the neighbour grid (a stable counting sort
//! in parallel jobs on the same pool). The same bits as
//! six stages over the whole crowd one after another, with one fork/join a
//! tick instead of six and each sloth's state fetched from memory once.
//!
//! Order differs from a naive reading of DESIGN.md in one place: BodyAverage
//! runs *before* CcdSolve, so every limb is solved from the chain roots of the
//! body pose drawn this frame (the body depends only on the IK targets, never
//! on the IK result, so nothing is lost).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use bevy_ecs::batching::BatchingStrategy;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SingleThreadedExecutor;
use bevy_tasks::{ComputeTaskPool, TaskPoolBuilder};
use slothsim_gait::{HashedPoint, Job, Jobs, Serial, Sloth};

use crate::world::{
    BodyAverageMemo, CcdMemo, CrowdNeighbours, CrowdPoints, GripLoad, GripLoadEvery, Locomotion,
    NearStances, SimClock, SlothId, SlothState, Traces,
};

/// The stages of one tick, in order. The first five and the parallel part
/// of Transitions run in one system in [`SimSystems::Trace`] (see the module
/// docs); the neighbour grid's rebuild is in [`SimSystems::Transitions`].
#[derive(SystemSet, Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SimSystems {
    /// Run every sloth's queued trace requests against the forest BVH.
    Trace,
    /// Searching limbs pick their next grip from the trace results (or queue more candidates).
    StepSearch,
    /// Swing arcs advance; body position and rotation from the limbs (formulas 6, 7).
    BodyAverage,
    /// CCD IK of every limb toward its grip or swing-arc point.
    CcdSolve,
    /// Grip loads: centre of mass and the forces the holding claws carry (issue 22).
    GripLoad,
    /// Gait sequencer (footfall order) and support rules; queue the next step searches.
    Transitions,
}

/// Number of stages (columns of [`StageTimings`]).
pub const STAGES: usize = 6;

/// Wall time of each stage, milliseconds, per frame.
#[derive(Resource, Debug, Default, Clone)]
pub struct StageTimings {
    /// The last frame's stage times: trace, step_search, body_average, ccd_solve,
    /// grip_load, transitions.
    pub last: [f64; STAGES],
    /// Every frame's stage times, in order.
    pub history: Vec<[f64; STAGES]>,
    /// Every frame's neighbour-grid rebuild (ms; a part of Transitions' time).
    pub grid_history: Vec<f64>,
    /// Traces run in the last frame.
    pub traces_last: u64,
    /// Traces run in all frames.
    pub traces_total: u64,
    /// CCD iterations of the CcdSolve stage in the last frame (all limbs).
    pub ccd_iterations_last: u64,
    /// CCD iterations of the CcdSolve stage in all frames.
    pub ccd_iterations_total: u64,
}

impl StageTimings {
    /// Stage names in column order.
    pub const NAMES: [&'static str; STAGES] = [
        "trace",
        "step_search",
        "body_average",
        "ccd_solve",
        "grip_load",
        "transitions",
    ];
}

/// How the stages split the sloths between workers: many small batches, so a
/// worker that drew expensive sloths (step checks, stalled IK) does not hold
/// the others up. bevy's default (one batch per thread) left 10,000 sloths on
/// 2 threads at 1.4x the 1-thread speed.
pub const BATCHING: BatchingStrategy = BatchingStrategy {
    batch_size_limits: 1..usize::MAX,
    batches_per_thread: 16,
};

fn ms(start: Instant) -> f64 {
    start.elapsed().as_secs_f64() * 1e3
}

/// Sloths a worker takes through all six stages before the next ones: their
/// state (about 2.4 KB a sloth) stays in the core's cache from one stage to the
/// next instead of being fetched from memory six times a frame.
const CHUNK: usize = 32;

/// What the workers of one pass add up: nanoseconds per stage, traces run,
/// CCD sweeps (integer sums: the same for any order of the workers).
#[derive(Default)]
struct PassTotals {
    stage_ns: [AtomicU64; STAGES],
    traces: AtomicU64,
    iterations: AtomicU64,
}

impl PassTotals {
    fn add(&self, ns: [u64; STAGES], traces: u64, iterations: u64) {
        for (a, n) in self.stage_ns.iter().zip(ns) {
            a.fetch_add(n, Ordering::Relaxed);
        }
        self.traces.fetch_add(traces, Ordering::Relaxed);
        self.iterations.fetch_add(iterations, Ordering::Relaxed);
    }
}

/// A stopwatch over the stages of a chunk: `lap(k)` adds the time since the
/// last lap to stage `k`.
struct Laps {
    last: Instant,
    ns: [u64; STAGES],
}

impl Laps {
    fn new() -> Self {
        Laps {
            last: Instant::now(),
            ns: [0; STAGES],
        }
    }

    fn lap(&mut self, k: usize) {
        let now = Instant::now();
        self.ns[k] += (now - self.last).as_nanos() as u64;
        self.last = now;
    }
}

/// The sloths' part of the tick: every sloth through Trace, StepSearch,
/// BodyAverage, CcdSolve, GripLoad and Transitions, [`CHUNK`] sloths at a time per
/// worker, in one parallel pass. Each stage of a sloth reads only that
/// sloth's state and what no stage writes (the forest, the config, the
/// neighbour grid of the last frame, rebuilt after the pass), so a sloth ends
/// the frame exactly as the six stages run one after another over the whole
/// crowd would leave it; one fork/join a frame instead of six, and each
/// sloth's state is fetched once. The stages' times are the pass's wall time
/// shared in proportion to each stage's summed time over the workers.
#[allow(clippy::type_complexity)]
fn sloth_pass(
    loco: Res<Locomotion>,
    crowd: Option<Res<CrowdNeighbours>>,
    clock: Res<SimClock>,
    every: Option<Res<GripLoadEvery>>,
    mut q: Query<(
        &mut SlothState,
        &mut Traces,
        &mut BodyAverageMemo,
        &mut CcdMemo,
        &mut GripLoad,
        &mut CrowdPoints,
        Option<&mut NearStances>,
    )>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    let dt = clock.dt;
    let every = every.map_or(1, |e| e.0);
    let totals = PassTotals::default();
    {
        let query = loco.traces.query();
        let searching = loco.view_in(crowd.as_deref());
        let w = loco.view();
        let grid = searching.crowd;
        let rig = &loco.rig;
        let chunk = |states: &mut [SlothState],
                     traces: &mut [Traces],
                     bodies: &mut [BodyAverageMemo],
                     solves: &mut [CcdMemo],
                     loads: &mut [GripLoad],
                     points: &mut [CrowdPoints],
                     near: Option<&mut [NearStances]>| {
            let mut laps = Laps::new();
            let mut traced = 0;
            // `traces_queued` instead of the batch's `len`: an empty batch's
            // line is not touched.
            for (s, tr) in states.iter().zip(traces.iter_mut()) {
                if s.0.traces_queued {
                    tr.0.run(&query);
                    traced += tr.0.len as u64;
                }
            }
            laps.lap(0);
            // Goal-mode sloths (a table of their own) hand the search
            // their stance record; wanderers have none.
            let mut near = near.map(|n| n.iter_mut());
            for (s, tr) in states.iter_mut().zip(traces.iter_mut()) {
                let record = near.as_mut().and_then(Iterator::next).map(|n| &mut n.0);
                s.0.step_search(&searching, &mut tr.0, record);
            }
            laps.lap(1);
            for (s, m) in states.iter_mut().zip(bodies.iter_mut()) {
                s.0.body_average_memo(&w, dt, &mut m.0);
            }
            laps.lap(2);
            // Sloths to solve share the SIMD lanes of one solve two by two
            // (`Sloth::solve_limbs_batch`: each ends exactly as its own solve
            // would leave it, so the pairing cannot change a bit).
            let iterations = Sloth::solve_limbs_batch(states, solves, &w);
            laps.lap(3);
            for (s, g) in states.iter_mut().zip(loads.iter_mut()) {
                if let Some(l) = s.0.grip_load(&w, dt, every) {
                    g.0 = l;
                }
            }
            laps.lap(4);
            for ((s, tr), pts) in states.iter_mut().zip(traces).zip(points) {
                s.0.transitions(&searching, dt, &mut tr.0);
                // The neighbour grid's points, hashed here in parallel.
                if let Some(g) = grid {
                    pts.update(rig, &s.0, g);
                }
            }
            laps.lap(5);
            totals.add(laps.ns, traced, iterations);
        };
        match q.contiguous_par_iter_mut() {
            Ok(it) => it.batching_strategy(BATCHING).for_each(
                |(
                    mut states,
                    mut traces,
                    mut bodies,
                    mut solves,
                    mut loads,
                    mut points,
                    mut near,
                )| {
                    // Once a batch: each `DerefMut` marks the whole batch changed.
                    let (states, traces, bodies, solves, loads, points) = (
                        &mut *states,
                        &mut *traces,
                        &mut *bodies,
                        &mut *solves,
                        &mut *loads,
                        &mut *points,
                    );
                    let n = states.len();
                    for a in (0..n).step_by(CHUNK) {
                        let b = (a + CHUNK).min(n);
                        chunk(
                            &mut states[a..b],
                            &mut traces[a..b],
                            &mut bodies[a..b],
                            &mut solves[a..b],
                            &mut loads[a..b],
                            &mut points[a..b],
                            near.as_deref_mut().map(|n| &mut n[a..b]),
                        );
                    }
                },
            ),
            // Not dense (a sparse-set component was added): one sloth at a time.
            Err(_) => q.par_iter_mut().batching_strategy(BATCHING).for_each(
                |(mut s, mut tr, mut b, mut m, mut g, mut p, mut n)| {
                    chunk(
                        std::slice::from_mut(&mut *s),
                        std::slice::from_mut(&mut *tr),
                        std::slice::from_mut(&mut *b),
                        std::slice::from_mut(&mut *m),
                        std::slice::from_mut(&mut *g),
                        std::slice::from_mut(&mut *p),
                        n.as_deref_mut().map(std::slice::from_mut),
                    );
                },
            ),
        }
    }
    let pass_ms = ms(t);
    let stage_ns = totals.stage_ns.map(AtomicU64::into_inner);
    let busy = stage_ns.iter().sum::<u64>().max(1) as f64;
    timings.last = stage_ns.map(|ns| pass_ms * ns as f64 / busy);
    timings.traces_last = totals.traces.into_inner();
    timings.traces_total += timings.traces_last;
    timings.ccd_iterations_last = totals.iterations.into_inner();
    timings.ccd_iterations_total += timings.ccd_iterations_last;
}

/// Runs the grid rebuild's jobs on bevy's compute pool: in order on the
/// calling thread where the pool has one worker, else as one task per run of
/// consecutive jobs, [`TASKS_PER_THREAD`] runs a worker (a task costs about as
/// much as sorting one of the 64 partitions of a 1,000-sloth crowd).
struct PoolJobs;

/// Tasks per worker of a [`PoolJobs`] batch (a few, so uneven jobs balance).
const TASKS_PER_THREAD: usize = 2;

impl Jobs for PoolJobs {
    fn run<'a>(&self, mut jobs: Vec<Job<'a>>) {
        let pool = ComputeTaskPool::get();
        let threads = pool.thread_num();
        if threads <= 1 || jobs.len() <= 1 {
            return Serial.run(jobs);
        }
        let per_task = jobs.len().div_ceil(threads * TASKS_PER_THREAD);
        pool.scope(|s| {
            while !jobs.is_empty() {
                let run: Vec<Job<'a>> = jobs.drain(..per_task.min(jobs.len())).collect();
                s.spawn(async move { Serial.run(run) });
            }
        });
    }
}

/// The end of the tick, after [`sloth_pass`]: the neighbour grid brought up to
/// date with the points the pass hashed (`CrowdGrid::update_hashed_with`:
/// re-bucketed only when enough points moved past its slack; counted in
/// Transitions' time, and on its own in [`StageTimings::grid_history`]), the
/// frame count.
fn grid_rebuild(
    mut crowd: Option<ResMut<CrowdNeighbours>>,
    mut clock: ResMut<SimClock>,
    q: Query<(&SlothId, &CrowdPoints)>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    // Sloths meet sloths: the next tick reads this tick's bodies and grips.
    // Answers as `CrowdNeighbours::rebuild` of the sloths (id order) would.
    if let Some(crowd) = crowd.as_deref_mut() {
        let tables: Vec<(&[SlothId], &[CrowdPoints])> = match q.contiguous_iter() {
            Ok(it) => it.collect(),
            Err(_) => Vec::new(),
        };
        // A sloth whose points kept their bits this tick (`CrowdPoints::update`,
        // run every tick the grid is) holds those of the grid's last update.
        if let [(ids, pts)] = tables[..] {
            crowd.grid.update_hashed_kept_with(
                ids.len(),
                |i| (ids[i].0, &pts[i].0, pts[i].2),
                &PoolJobs,
            );
        } else {
            // Several tables (or none): the points gathered in query order first.
            let all: Vec<(u32, &[HashedPoint; 7], bool)> =
                q.iter().map(|(id, pts)| (id.0, &pts.0, pts.2)).collect();
            crowd
                .grid
                .update_hashed_kept_with(all.len(), |i| all[i], &PoolJobs);
        }
    }
    clock.frame += 1;
    let grid_ms = ms(t);
    timings.last[5] += grid_ms;
    timings.grid_history.push(grid_ms);
    let last = timings.last;
    timings.history.push(last);
}

/// The tick schedule: the six stages chained in order. Makes sure bevy's
/// compute pool exists (all cores unless [`init_compute_pool`] ran first).
pub fn build_schedule() -> Schedule {
    init_compute_pool(None);
    let mut s = Schedule::default();
    // Stages are strictly ordered; parallelism is inside each stage.
    s.set_executor(SingleThreadedExecutor::new());
    s.configure_sets(
        (
            SimSystems::Trace,
            SimSystems::StepSearch,
            SimSystems::BodyAverage,
            SimSystems::CcdSolve,
            SimSystems::GripLoad,
            SimSystems::Transitions,
        )
            .chain(),
    );
    // The six stages run as one per-sloth pass (see `sloth_pass`), then
    // the end of Transitions (the grid rebuild).
    s.add_systems((
        sloth_pass.in_set(SimSystems::Trace),
        grid_rebuild.in_set(SimSystems::Transitions),
    ));
    s
}

/// Sizes bevy's compute pool (process-wide, first call wins): `threads` or all cores.
/// Returns the pool's thread count.
pub fn init_compute_pool(threads: Option<usize>) -> usize {
    let n = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    ComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(n).build()).thread_num()
}
