//! The per-sloth stage kernels over a prepared crowd (200 sloths on the
//! default forest, 60 frames in), one thread, so the cost per sloth is
//! visible without the scheduler: step_search (with its traces run),
//! body_average, solve_limbs, transitions. `cargo bench --bench stages`

use std::hint::black_box;

use criterion::{BatchSize, Criterion, criterion_group, criterion_main};
use slothsim::gait::{LocomotionConfig, Profile, Sloth, TraceBatch};
use slothsim::rig::Rig;
use slothsim::scene::generate_forest;
use slothsim::sim::{Crowd, CrowdSpec, ForestSource, Locomotion, forest_for};

const SLOTHS: u32 = 200;
const DT: f32 = 1.0 / 60.0;

fn stages(c: &mut Criterion) {
    let rig = Rig::sloth();
    let fc = forest_for(SLOTHS, None, None);
    let spec = CrowdSpec {
        sloths: SLOTHS,
        seed: 1,
        dt: DT,
        cfg: LocomotionConfig::profile(Profile::Free),
        clearance_m: 0.3,
    };
    let mut crowd = Crowd::new(
        spec,
        &rig,
        generate_forest(&fc).unwrap(),
        ForestSource::Procedural(fc),
    )
    .unwrap();
    for _ in 0..60 {
        crowd.tick();
    }
    let sloths = crowd.sloths();
    let loco = crowd.world().resource::<Locomotion>();
    let w = loco.view();
    // Each sloth's pending traces, as its Transitions stage queued them.
    let prepared: Vec<(Sloth, TraceBatch)> = sloths
        .iter()
        .map(|s| {
            let mut s = *s;
            let mut b = TraceBatch::default();
            s.transitions(&w, DT, &mut b);
            b.run(&w.query);
            (s, b)
        })
        .collect();
    let mut g = c.benchmark_group(format!("stages_{SLOTHS}_sloths"));
    g.sample_size(20);
    g.bench_function("trace", |b| {
        b.iter_batched_ref(
            || prepared.clone(),
            |v| v.iter_mut().for_each(|(_, t)| t.run(&w.query)),
            BatchSize::LargeInput,
        )
    });
    g.bench_function("step_search", |b| {
        b.iter_batched_ref(
            || prepared.clone(),
            |v| v.iter_mut().for_each(|(s, t)| s.step_search(&w, t, None)),
            BatchSize::LargeInput,
        )
    });
    g.bench_function("body_average", |b| {
        b.iter_batched_ref(
            || sloths.clone(),
            |v| v.iter_mut().for_each(|s| s.body_average(&w, DT)),
            BatchSize::LargeInput,
        )
    });
    g.bench_function("solve_limbs", |b| {
        b.iter_batched_ref(
            || sloths.clone(),
            |v| {
                v.iter_mut()
                    .map(|s| s.solve_limbs(&w))
                    .fold(0u32, |a, n| black_box(a + n))
            },
            BatchSize::LargeInput,
        )
    });
    g.bench_function("transitions", |b| {
        b.iter_batched_ref(
            || (sloths.clone(), vec![TraceBatch::default(); sloths.len()]),
            |(v, t)| {
                v.iter_mut()
                    .zip(t.iter_mut())
                    .for_each(|(s, b)| s.transitions(&w, DT, b))
            },
            BatchSize::LargeInput,
        )
    });
    g.finish();
}

criterion_group!(benches, stages);
criterion_main!(benches);
