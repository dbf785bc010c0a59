//! The baseline `slothsim bench --baseline` measures the crowd against: what a
//! first attempt would be. One heap object per sloth, one thread, each sloth's
//! six stages run back to back, and each of its trace requests answered on
//! the spot by a brute-force test against every primitive of the forest (no
//! BVH, no batching, no ECS, no parallelism).
//!
//! It runs the same gait kernels on the same forest and the same spawned
//! sloths, so it computes the same crowd: per sloth the stages only read the
//! shared world and the neighbour grid, which both versions rebuild once a
//! frame after every sloth has moved. It exists to be beaten.

use std::time::Instant;

use slothsim_gait::{Sloth, TraceBatch};

use crate::world::{CrowdNeighbours, Locomotion};

/// One sloth as an object: its state and its pending trace requests.
struct SlothObject {
    sloth: Sloth,
    traces: TraceBatch,
}

impl SlothObject {
    /// A whole frame of this sloth: trace, step search, body, IK, grip loads (at the
    /// crowd's rate), gait clock.
    fn update(&mut self, loco: &Locomotion, grid: &CrowdNeighbours, dt: f32) {
        let w = loco.view_in(Some(grid));
        for i in 0..self.traces.len {
            self.traces.results[i] = w.query.trace_brute_force(&self.traces.reqs[i]);
        }
        // A crowd's sloths wander: no goal-mode stance record.
        self.sloth.step_search(&w, &mut self.traces, None);
        self.sloth.body_average(&w, dt);
        self.sloth.solve_limbs(&w);
        self.sloth.grip_load(&w, dt, crate::world::CROWD_LOAD_EVERY);
        self.sloth.transitions(&w, dt, &mut self.traces);
    }
}

/// The object-per-sloth, single-threaded, brute-force crowd.
pub struct Baseline<'a> {
    loco: &'a Locomotion,
    // Deliberately one heap allocation per sloth, as a first attempt would.
    #[allow(clippy::vec_box)]
    sloths: Vec<Box<SlothObject>>,
    grid: CrowdNeighbours,
    dt: f32,
    /// Wall time of every frame run so far (ms).
    pub frame_ms: Vec<f64>,
}

impl<'a> Baseline<'a> {
    /// A baseline crowd of `sloths` (freshly spawned: no traces pending) on
    /// the forest and config of `loco`.
    pub fn new(loco: &'a Locomotion, sloths: Vec<Sloth>, clearance_m: f32, dt: f32) -> Self {
        let mut grid = CrowdNeighbours::new(clearance_m);
        grid.rebuild(loco, sloths.iter().map(|s| (s.id, s)));
        Baseline {
            loco,
            sloths: sloths
                .into_iter()
                .map(|sloth| {
                    Box::new(SlothObject {
                        sloth,
                        traces: TraceBatch::default(),
                    })
                })
                .collect(),
            grid,
            dt,
            frame_ms: Vec::new(),
        }
    }

    /// One frame: every sloth in turn, then the neighbour grid.
    pub fn frame(&mut self) {
        let t = Instant::now();
        for s in &mut self.sloths {
            s.update(self.loco, &self.grid, self.dt);
        }
        self.grid.rebuild(
            self.loco,
            self.sloths.iter().map(|s| (s.sloth.id, &s.sloth)),
        );
        self.frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
    }

    /// The sloths, in id order.
    pub fn sloths(&self) -> Vec<Sloth> {
        self.sloths.iter().map(|s| s.sloth).collect()
    }
}
