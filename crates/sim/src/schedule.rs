//! The tick, in one place: six chained stages, each one system that runs its
//! kernel over every sloth in parallel (`par_iter_mut` on bevy's compute task
//! pool; CcdSolve takes whole table slices with `contiguous_par_iter_mut`, to
//! solve sloths two by two in SIMD lanes) and records its wall time.
//!
//! Order differs from a naive reading of DESIGN.md in one place: BodyAverage
//! runs *before* CcdSolve, so every limb is solved from the chain roots of the
//! body pose drawn this frame (the body depends only on the IK targets, never
//! on the IK result, so nothing is lost).

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use bevy_ecs::batching::BatchingStrategy;
use bevy_ecs::change_detection::ContiguousMut;
use bevy_ecs::prelude::*;
use bevy_ecs::schedule::SingleThreadedExecutor;
use bevy_tasks::{ComputeTaskPool, TaskPoolBuilder};
use slothsim_gait::Sloth;

use crate::world::{
    BodyAverageMemo, CcdMemo, CrowdNeighbours, CrowdPoints, GripLoad, GripLoadEvery, Locomotion,
    SimClock, SlothId, SlothState, Traces, crowd_points,
};

/// The stages of one tick, in order.
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

fn trace_stage(
    loco: Res<Locomotion>,
    mut q: Query<&mut Traces>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    let query = loco.traces.query();
    q.par_iter_mut()
        .batching_strategy(BATCHING)
        .for_each(|mut tr| tr.0.run(&query));
    timings.traces_last = q.iter().map(|t| t.0.len as u64).sum();
    timings.traces_total += timings.traces_last;
    timings.last[0] = ms(t);
}

fn step_search_stage(
    loco: Res<Locomotion>,
    crowd: Option<Res<CrowdNeighbours>>,
    mut q: Query<(&mut SlothState, &mut Traces)>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    let w = loco.view_in(crowd.as_deref());
    q.par_iter_mut()
        .batching_strategy(BATCHING)
        .for_each(|(mut s, mut tr)| s.0.step_search(&w, &mut tr.0));
    timings.last[1] = ms(t);
}

fn body_average_stage(
    loco: Res<Locomotion>,
    clock: Res<SimClock>,
    mut q: Query<(&mut SlothState, &mut BodyAverageMemo)>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    let w = loco.view();
    let dt = clock.dt;
    q.par_iter_mut()
        .batching_strategy(BATCHING)
        .for_each(|(mut s, mut m)| s.0.body_average_memo(&w, dt, &mut m.0));
    timings.last[2] = ms(t);
}

fn ccd_stage(
    loco: Res<Locomotion>,
    mut q: Query<(&mut SlothState, &mut CcdMemo)>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    let w = loco.view();
    // An integer sum: the same for any order of the workers (deterministic).
    let iterations = AtomicU64::new(0);
    // Whole table slices, so the sloths to solve share the SIMD lanes of one
    // solve two by two (`Sloth::solve_limbs_batch`: each ends exactly as its
    // own solve would leave it, so the batching cannot change a bit).
    let batch = |(mut states, mut memos): (ContiguousMut<SlothState>, ContiguousMut<CcdMemo>)| {
        let n = Sloth::solve_limbs_batch(&mut states, &mut memos, &w);
        iterations.fetch_add(n, Ordering::Relaxed);
    };
    match q.contiguous_par_iter_mut() {
        Ok(it) => it.batching_strategy(BATCHING).for_each(batch),
        // Not dense (a sparse-set component was added): one sloth at a time.
        Err(_) => q
            .par_iter_mut()
            .batching_strategy(BATCHING)
            .for_each(|(mut s, mut m)| {
                let n = s.0.solve_limbs_memo(&w, &mut m.0);
                iterations.fetch_add(n as u64, Ordering::Relaxed);
            }),
    }
    timings.last[3] = ms(t);
    timings.ccd_iterations_last = iterations.into_inner();
    timings.ccd_iterations_total += timings.ccd_iterations_last;
}

fn grip_load_stage(
    loco: Res<Locomotion>,
    clock: Res<SimClock>,
    every: Option<Res<GripLoadEvery>>,
    mut q: Query<(&mut SlothState, &mut GripLoad)>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    let w = loco.view();
    let dt = clock.dt;
    let every = every.map_or(1, |e| e.0);
    q.par_iter_mut()
        .batching_strategy(BATCHING)
        .for_each(|(mut s, mut g)| {
            if let Some(loads) = s.0.grip_load(&w, dt, every) {
                g.0 = loads;
            }
        });
    timings.last[4] = ms(t);
}

fn transitions_stage(
    loco: Res<Locomotion>,
    mut crowd: Option<ResMut<CrowdNeighbours>>,
    mut clock: ResMut<SimClock>,
    mut q: Query<(&SlothId, &mut SlothState, &mut Traces, &mut CrowdPoints)>,
    mut timings: ResMut<StageTimings>,
) {
    let t = Instant::now();
    let dt = clock.dt;
    {
        let w = loco.view_in(crowd.as_deref());
        let grid = w.crowd;
        let rig = &loco.rig;
        q.par_iter_mut()
            .batching_strategy(BATCHING)
            .for_each(|(_, mut s, mut tr, mut pts)| {
                s.0.transitions(&w, dt, &mut tr.0);
                // The neighbour grid's points, hashed here in parallel.
                if let Some(g) = grid {
                    pts.0 = crowd_points(rig, &s.0).map(|p| g.hashed(p));
                }
            });
    }
    // Sloths meet sloths: the next tick reads this tick's bodies and grips.
    // The same grid as `CrowdNeighbours::rebuild` of the sloths (id order).
    if let Some(crowd) = crowd.as_deref_mut() {
        crowd
            .grid
            .rebuild_hashed(q.iter().map(|(id, _, _, pts)| (id.0, &pts.0)));
    }
    clock.frame += 1;
    timings.last[5] = ms(t);
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
    s.add_systems((
        trace_stage.in_set(SimSystems::Trace),
        step_search_stage.in_set(SimSystems::StepSearch),
        body_average_stage.in_set(SimSystems::BodyAverage),
        ccd_stage.in_set(SimSystems::CcdSolve),
        grip_load_stage.in_set(SimSystems::GripLoad),
        transitions_stage.in_set(SimSystems::Transitions),
    ));
    s
}

/// Sizes bevy's compute pool (process-wide, first call wins): `threads` or all cores.
/// Returns the pool's thread count.
pub fn init_compute_pool(threads: Option<usize>) -> usize {
    let n = threads.unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()));
    ComputeTaskPool::get_or_init(|| TaskPoolBuilder::new().num_threads(n).build()).thread_num()
}
