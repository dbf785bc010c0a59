//! Line traces and sphere sweeps per second on the default forest, one thread
//! and all threads, side by side with parry3d's BVH ray casts on the same
//! capsules.
//!
//! The forest's supports taper; parry3d's capsules do not. So both libraries
//! trace a copy of the default forest in which every support keeps its mean
//! radius: identical capsules on both sides. The bench first checks that both
//! find the same hits before timing anything.
//!
//! Rays are step-search-like: from 0.1–0.5 m off a support's surface toward it (with
//! noise) or in a random direction, at most 1 m long.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use parry3d::{
    bounding_volume::{Aabb, BoundingVolume},
    partitioning::{Bvh, BvhBuildStrategy},
    query::{Ray, RayCast},
    shape::Capsule,
};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use slothsim::scene::{
    LineTrace, Scene, SphereSweep, Support, TraceRequest, TraceScene, default_forest,
};

const RAYS: usize = 20_000;
const SWEEP_RADIUS: f32 = 0.05;

fn capsule_forest() -> Scene {
    let supports = default_forest()
        .supports()
        .iter()
        .map(|s| {
            let mean = s.radii.iter().sum::<f32>() / s.radii.len() as f32;
            let mut c = Support::new(s.nodes.clone(), vec![mean; s.nodes.len()]);
            c.kind = s.kind;
            c
        })
        .collect();
    Scene::new(supports).expect("valid")
}

fn rays(scene: &Scene) -> Vec<LineTrace> {
    let mut rng = Pcg64Mcg::seed_from_u64(42);
    let supports = scene.supports();
    (0..RAYS)
        .map(|_| {
            let s = &supports[rng.random_range(0..supports.len())];
            let seg = rng.random_range(0..s.segment_count());
            let on_axis = s.nodes[seg].lerp(s.nodes[seg + 1], rng.random::<f32>());
            let random_dir = Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
            .normalize_or(Vec3::Y);
            let off = random_dir
                .cross(s.nodes[seg + 1] - s.nodes[seg])
                .normalize_or(Vec3::X);
            let origin = on_axis + off * (s.radii[seg] + rng.random_range(0.1..0.5));
            let dir = if rng.random_bool(0.7) {
                (on_axis - origin).normalize() + random_dir * 0.2
            } else {
                random_dir
            };
            LineTrace {
                origin,
                dir: dir.normalize(),
                max_dist: 1.0,
            }
        })
        .collect()
}

/// The same capsules in parry3d, with its BVH: one over the capsules, one
/// over capsules grown by the sweep radius (parry's BVH has no inflated
/// traversal, so sphere sweeps get leaves loosened by the radius).
struct ParryForest {
    capsules: Vec<Capsule>,
    bvh: Bvh,
    bvh_swept: Bvh,
}

impl ParryForest {
    fn new(scene: &Scene) -> Self {
        let mut capsules = Vec::new();
        for s in scene.supports() {
            for w in s.nodes.windows(2) {
                let v = |p: Vec3| parry3d::math::Vector::new(p.x, p.y, p.z);
                capsules.push(Capsule::new(v(w[0]), v(w[1]), s.radii[0]));
            }
        }
        let leaves: Vec<Aabb> = capsules.iter().map(|c| c.local_aabb()).collect();
        let bvh = Bvh::from_leaves(BvhBuildStrategy::Binned, &leaves);
        let swept: Vec<Aabb> = leaves.iter().map(|a| a.loosened(SWEEP_RADIUS)).collect();
        let bvh_swept = Bvh::from_leaves(BvhBuildStrategy::Binned, &swept);
        ParryForest {
            capsules,
            bvh,
            bvh_swept,
        }
    }

    /// Closest hit distance, with the sphere radius added to the capsules.
    fn cast(&self, l: &LineTrace, inflate: f32) -> Option<f32> {
        let v = |p: Vec3| parry3d::math::Vector::new(p.x, p.y, p.z);
        let ray = Ray::new(v(l.origin), v(l.dir));
        let bvh = if inflate == 0.0 {
            &self.bvh
        } else {
            assert_eq!(
                inflate, SWEEP_RADIUS,
                "bvh_swept is loosened by SWEEP_RADIUS"
            );
            &self.bvh_swept
        };
        bvh.cast_ray(&ray, l.max_dist, |i, best| {
            let c = &self.capsules[i as usize];
            if inflate == 0.0 {
                c.cast_local_ray(&ray, best, true)
            } else {
                Capsule::new(c.segment.a, c.segment.b, c.radius + inflate)
                    .cast_local_ray(&ray, best, true)
            }
        })
        .map(|(_, t)| t)
    }
}

fn check_agreement(traces: &TraceScene, parry: &ParryForest, lines: &[LineTrace]) {
    let q = traces.query();
    let (mut hits, mut disagree, mut inside) = (0, 0, 0);
    for l in lines {
        for r in [0.0, SWEEP_RADIUS] {
            let ours = q
                .sphere(&SphereSweep {
                    line: *l,
                    radius: r,
                })
                .expect("valid ray")
                .map(|h| h.distance);
            let theirs = parry.cast(l, r);
            match (ours, theirs) {
                // Origin inside another support: parry reports t = 0, we skip it.
                (_, Some(0.0)) => inside += 1,
                (Some(a), Some(b)) if (a - b).abs() < 1e-3 => hits += 1,
                (None, None) => {}
                _ => {
                    if disagree < 5 {
                        eprintln!("disagree r={r}: ours {ours:?} parry {theirs:?} {l:?}");
                    }
                    disagree += 1
                }
            }
        }
    }
    eprintln!(
        "traces: {} rays × (line, sphere r={SWEEP_RADIUS}): {hits} hits agree, {disagree} disagree with parry3d, {inside} start inside a support",
        lines.len()
    );
    assert!(
        disagree * 1000 <= lines.len(),
        "slothsim and parry3d disagree"
    );
}

fn bench(c: &mut Criterion) {
    let scene = capsule_forest();
    let lines = rays(&scene);
    let traces = TraceScene::new(scene.clone());
    let parry = ParryForest::new(&scene);
    check_agreement(&traces, &parry, &lines);

    let threads_all = std::thread::available_parallelism().map_or(1, |n| n.get());
    let q = traces.query();
    for (kind, radius) in [("line", 0.0f32), ("sphere", SWEEP_RADIUS)] {
        let reqs: Vec<TraceRequest> = lines
            .iter()
            .map(|l| {
                if radius == 0.0 {
                    TraceRequest::Line(*l)
                } else {
                    TraceRequest::Sphere(SphereSweep { line: *l, radius })
                }
            })
            .collect();
        let mut out = vec![Ok(None); reqs.len()];
        let mut g = c.benchmark_group(format!("traces_{kind}"));
        g.throughput(Throughput::Elements(reqs.len() as u64));
        g.sample_size(20);
        for threads in [1, threads_all] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("thread pool");
            g.bench_function(
                BenchmarkId::new("slothsim_obvhs", format!("{threads}t")),
                |b| b.iter(|| pool.install(|| q.trace_batch(&reqs, &mut out))),
            );
            let mut pout = vec![None; lines.len()];
            g.bench_function(BenchmarkId::new("parry3d", format!("{threads}t")), |b| {
                b.iter(|| {
                    pool.install(|| {
                        lines
                            .par_iter()
                            .with_min_len(64)
                            .zip(pout.par_iter_mut())
                            .for_each(|(l, o)| *o = parry.cast(l, radius))
                    })
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
