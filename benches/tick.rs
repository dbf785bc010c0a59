//! A whole tick (the five stages) of the wandering crowd at 1,000 and 10,000
//! sloths, on a forest sized by `forest_for`, after 60 warm-up frames.
//!
//! Spawning 10,000 sloths takes minutes, so spawned crowds are kept in
//! `target/bench-cache` (or `$SLOTHSIM_BENCH_CACHE`) and reused; delete it
//! after changing the rig or the gait. `cargo bench --bench tick`

use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};
use slothsim::gait::{LocomotionConfig, Profile};
use slothsim::rig::Rig;
use slothsim::scene::generate_forest;
use slothsim::sim::{Crowd, CrowdSpec, ForestSource, forest_for};

/// The crowd of `n` sloths (seed 1, free profile), from the cache when there.
pub fn crowd(n: u32) -> Crowd {
    let rig = Rig::sloth();
    let fc = forest_for(n, None, None);
    let dir = std::env::var_os("SLOTHSIM_BENCH_CACHE")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/bench-cache"));
    let path = dir.join(format!("crowd-{n}-seed1-Free.state"));
    let source = ForestSource::Procedural(fc.clone());
    if let Ok(info) = Crowd::checkpoint_info(&path)
        && info.forest == source
        && info.sloths == n
        && info.frame == 0
        && let Ok(c) = Crowd::load_state(&path, &rig, generate_forest(&fc).unwrap())
    {
        return c;
    }
    let spec = CrowdSpec {
        sloths: n,
        seed: 1,
        dt: 1.0 / 60.0,
        cfg: LocomotionConfig::profile(Profile::Free),
        clearance_m: 0.3,
    };
    let mut c = Crowd::new(spec, &rig, generate_forest(&fc).unwrap(), source).unwrap();
    std::fs::create_dir_all(&dir).unwrap();
    c.save_state(&path).unwrap();
    c
}

fn tick(c: &mut Criterion) {
    let mut g = c.benchmark_group("tick");
    g.sample_size(10);
    for n in [1000u32, 10_000] {
        let mut crowd = crowd(n);
        for _ in 0..60 {
            crowd.tick();
        }
        g.bench_function(format!("{n}_sloths"), |b| b.iter(|| crowd.tick()));
    }
    g.finish();
}

criterion_group!(benches, tick);
criterion_main!(benches);
