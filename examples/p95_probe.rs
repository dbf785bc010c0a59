//! Per-frame step-search load of a bench crowd (issue 26, "flatten the p95"):
//! for each timed frame, the frame's wall time, the StepSearch and
//! Transitions stage times, the limbs searching at the frame's start and the
//! searches the frame started (limbs Planted → Searching), as CSV.
//!
//! `cargo run --release --example p95_probe -- STATE THREADS WARMUP FRAMES`
//! (STATE: a bench spawn-cache file `crowd-N-seed1-Free.state`).

use std::time::Instant;

use slothsim::gait::LimbPhase;
use slothsim::rig::Rig;
use slothsim::scene::generate_forest;
use slothsim::sim::{Crowd, ForestSource, SlothState, init_compute_pool};

fn phases(crowd: &Crowd) -> Vec<[LimbPhase; 4]> {
    let w = crowd.world();
    let mut q = w.try_query::<&SlothState>().expect("sloths");
    q.iter(w).map(|s| s.0.limbs.map(|l| l.phase)).collect()
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let path = std::path::PathBuf::from(&a[1]);
    let threads: usize = a[2].parse().unwrap();
    let warmup: usize = a[3].parse().unwrap();
    let frames: usize = a[4].parse().unwrap();
    init_compute_pool(Some(threads));
    let info = Crowd::checkpoint_info(&path).unwrap();
    let ForestSource::Procedural(fc) = info.forest else {
        panic!("procedural forest expected")
    };
    let rig = Rig::sloth();
    let mut crowd = Crowd::load_state(&path, &rig, generate_forest(&fc).unwrap()).unwrap();
    for _ in 0..warmup {
        crowd.tick();
    }
    println!("frame,ms,step_search_ms,transitions_ms,searching,started,swinging");
    let mut before = phases(&crowd);
    for f in 0..frames {
        let t = Instant::now();
        crowd.tick();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let last = crowd.timings().last;
        let after = phases(&crowd);
        let searching = before
            .iter()
            .flatten()
            .filter(|p| **p == LimbPhase::Searching)
            .count();
        let started = before
            .iter()
            .zip(&after)
            .flat_map(|(b, a)| b.iter().zip(a))
            .filter(|(b, a)| **b != LimbPhase::Searching && **a == LimbPhase::Searching)
            .count();
        let swinging = after
            .iter()
            .flatten()
            .filter(|p| **p == LimbPhase::Swinging)
            .count();
        println!(
            "{f},{ms:.3},{:.3},{:.3},{searching},{started},{swinging}",
            last[1], last[5]
        );
        before = after;
    }
}
