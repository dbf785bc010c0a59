//! CCD limb-solve cost: ns per limb solve, cold (from the neutral pose) and warm
//! (previous frame's pose, target moving ~2 mm per frame: the realistic case).
//! Also prints the mean number of CCD sweeps for both.
//!
//! `*_solve4` cases solve an animal's four limbs together (`solve4_prepared`, one limb
//! per SIMD lane) and report time per limb (each call's time divided by 4); before
//! timing, every solve4 result and pose is checked bit for bit against `solve`.
//! `*_solve8` cases solve two animals' limbs in one call (`solve8_prepared_tolerances`,
//! eight lanes: one AVX register where the CPU has AVX2), time divided by 8; the
//! second animal's targets are the first's of the next step of the same path.
//!
//! `cargo bench --bench ik`

use std::hint::black_box;
use std::time::{Duration, Instant};

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use slothsim_rig::{
    CcdParams, CcdResult, ChainPose, FabrikParams, LimbChain, LimbChains4, Rig, RootTransform,
    fabrik, solve, solve4_prepared, solve8_prepared_tolerances,
};

/// Deterministic uniform in [0, 1) (PCG seeded per bench input set).
fn rnd(rng: &mut Pcg64Mcg) -> f32 {
    rng.random::<f32>()
}

fn random_u(state: &mut Pcg64Mcg) -> [f32; 12] {
    std::array::from_fn(|_| 0.05 + 0.9 * rnd(state))
}

fn root() -> RootTransform {
    RootTransform::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_y(0.7))
}

/// Reachable targets: FK of random within-limits poses.
fn cold_targets(chain: &LimbChain, n: usize, seed: u64) -> Vec<Vec3> {
    let mut s = Pcg64Mcg::seed_from_u64(seed);
    (0..n)
        .map(|_| chain.fk(root(), &chain.sample_pose(&random_u(&mut s)))[4])
        .collect()
}

/// A reachable effector path with `step` metres between frames, ping-ponged so it can
/// be replayed forever without jumps.
fn warm_path(chain: &LimbChain, step: f32, seed: u64) -> Vec<Vec3> {
    let mut s = Pcg64Mcg::seed_from_u64(seed);
    let mut path = vec![];
    let mut ua = random_u(&mut s);
    while path.len() < 2000 {
        let ub = random_u(&mut s);
        let mut last: Option<Vec3> = path.last().copied();
        for k in 0..=4000 {
            let t = k as f32 / 4000.0;
            let u: [f32; 12] = std::array::from_fn(|i| ua[i] + (ub[i] - ua[i]) * t);
            let p = chain.fk(root(), &chain.sample_pose(&u))[4];
            if last.is_none_or(|l| l.distance(p) >= step) {
                path.push(p);
                last = Some(p);
            }
        }
        ua = ub;
    }
    let back: Vec<Vec3> = path.iter().rev().skip(1).copied().collect();
    path.extend(back);
    path
}

struct Stats {
    solves: u64,
    sweeps: u64,
    reached: u64,
}

fn run_cold(chains: &[LimbChain; 4], targets: &[Vec<Vec3>; 4], params: &CcdParams) -> Stats {
    let mut st = Stats {
        solves: 0,
        sweeps: 0,
        reached: 0,
    };
    for (chain, ts) in chains.iter().zip(targets) {
        for &t in ts {
            let mut pose = ChainPose::NEUTRAL;
            let r = solve(chain, root(), t, &mut pose, params);
            st.solves += 1;
            st.sweeps += u64::from(r.iterations);
            st.reached += u64::from(chain.fk(root(), &pose)[4].distance(t) <= 1e-3);
        }
    }
    st
}

fn run_warm(chains: &[LimbChain; 4], paths: &[Vec<Vec3>; 4], params: &CcdParams) -> Stats {
    let mut st = Stats {
        solves: 0,
        sweeps: 0,
        reached: 0,
    };
    for (chain, path) in chains.iter().zip(paths) {
        let mut pose = ChainPose::NEUTRAL;
        solve(chain, root(), path[0], &mut pose, params);
        for &t in &path[1..] {
            let r = solve(chain, root(), t, &mut pose, params);
            st.solves += 1;
            st.sweeps += u64::from(r.iterations);
            st.reached += u64::from(chain.fk(root(), &pose)[4].distance(t) <= 1e-3);
        }
    }
    st
}

fn same(a: &CcdResult, b: &CcdResult, pa: &ChainPose, pb: &ChainPose) -> bool {
    let bits = |p: &ChainPose| p.0.map(|q| q.to_array().map(f32::to_bits));
    a.reached == b.reached
        && a.error.to_bits() == b.error.to_bits()
        && a.iterations == b.iterations
        && a.status == b.status
        && bits(pa) == bits(pb)
}

/// Replay the cold targets and warm paths with `solve4_prepared` and `solve` side by
/// side; panics on the first difference. Returns the number of limb solves compared.
fn check_solve4(
    chains: &[LimbChain; 4],
    prepared: &LimbChains4,
    cold: &[Vec<Vec3>; 4],
    warm: &[Vec<Vec3>; 4],
    params: &CcdParams,
) -> usize {
    let mut n = 0;
    let mut compare = |targets: [Vec3; 4], a: &mut [ChainPose; 4], b: &mut [ChainPose; 4]| {
        let r4 = solve4_prepared(prepared, [root(); 4], targets, a, params);
        for i in 0..4 {
            let r = solve(&chains[i], root(), targets[i], &mut b[i], params);
            assert!(same(&r4[i], &r, &a[i], &b[i]), "solve4 differs from solve");
        }
        n += 4;
    };
    for k in 0..cold[0].len() {
        let targets = std::array::from_fn(|i| cold[i][k % cold[i].len()]);
        compare(
            targets,
            &mut [ChainPose::NEUTRAL; 4],
            &mut [ChainPose::NEUTRAL; 4],
        );
    }
    let (mut a, mut b) = ([ChainPose::NEUTRAL; 4], [ChainPose::NEUTRAL; 4]);
    let frames = warm.iter().map(Vec::len).max().unwrap_or(0);
    for f in 0..frames {
        let targets = std::array::from_fn(|i| warm[i][f % warm[i].len()]);
        compare(targets, &mut a, &mut b);
    }
    n
}

fn report(name: &str, st: &Stats) {
    println!(
        "ik/{name}: mean CCD sweeps {:.2}, reached (FK, 1 mm) {:.2} % of {} solves",
        st.sweeps as f64 / st.solves as f64,
        100.0 * st.reached as f64 / st.solves as f64,
        st.solves
    );
}

fn bench_ik(c: &mut Criterion) {
    let rig = Rig::sloth();
    let chains = *rig.chains();
    let params = CcdParams::default();
    let cold: [Vec<Vec3>; 4] =
        std::array::from_fn(|i| cold_targets(&chains[i], 1024, 11 + i as u64));
    let warm: [Vec<Vec3>; 4] = std::array::from_fn(|i| warm_path(&chains[i], 2e-3, 101 + i as u64));
    report("cold", &run_cold(&chains, &cold, &params));
    report("warm_2mm", &run_warm(&chains, &warm, &params));
    let prepared = LimbChains4::new([&chains[0], &chains[1], &chains[2], &chains[3]]);
    let compared = check_solve4(&chains, &prepared, &cold, &warm, &params);
    println!("ik/solve4: bit-identical to solve on {compared} limb solves (cold + warm_2mm)");

    let mut group = c.benchmark_group("ik");
    group.bench_function("cold_limb_solve", |b| {
        let mut k = 0usize;
        b.iter(|| {
            let limb = k % 4;
            let t = cold[limb][(k / 4) % cold[limb].len()];
            k += 1;
            let mut pose = ChainPose::NEUTRAL;
            black_box(solve(
                &chains[limb],
                root(),
                black_box(t),
                &mut pose,
                &params,
            ));
            pose
        })
    });
    group.bench_function("warm_2mm_limb_solve", |b| {
        let mut poses = [ChainPose::NEUTRAL; 4];
        for (i, pose) in poses.iter_mut().enumerate() {
            solve(&chains[i], root(), warm[i][0], pose, &params);
        }
        let mut frame = [1usize; 4];
        let mut k = 0usize;
        b.iter(|| {
            let limb = k % 4;
            k += 1;
            let path = &warm[limb];
            let t = path[frame[limb] % path.len()];
            frame[limb] += 1;
            black_box(solve(
                &chains[limb],
                root(),
                black_box(t),
                &mut poses[limb],
                &params,
            ))
        })
    });
    group.bench_function("cold_limb_solve4", |b| {
        let mut k = 0usize;
        b.iter_custom(|iters| {
            let t0 = Instant::now();
            for _ in 0..iters {
                let targets: [Vec3; 4] = std::array::from_fn(|i| cold[i][k % cold[i].len()]);
                k += 1;
                let mut poses = [ChainPose::NEUTRAL; 4];
                black_box(solve4_prepared(
                    &prepared,
                    [root(); 4],
                    black_box(targets),
                    &mut poses,
                    &params,
                ));
                black_box(&poses);
            }
            // One iteration solves four limbs: report per limb.
            t0.elapsed() / 4
        })
    });
    group.bench_function("warm_2mm_limb_solve4", |b| {
        let mut poses = [ChainPose::NEUTRAL; 4];
        for (i, pose) in poses.iter_mut().enumerate() {
            solve(&chains[i], root(), warm[i][0], pose, &params);
        }
        let mut frame = 1usize;
        b.iter_custom(|iters| {
            let t0 = Instant::now();
            for _ in 0..iters {
                let targets: [Vec3; 4] = std::array::from_fn(|i| warm[i][frame % warm[i].len()]);
                frame += 1;
                black_box(solve4_prepared(
                    &prepared,
                    [root(); 4],
                    black_box(targets),
                    &mut poses,
                    &params,
                ));
            }
            let per_limb: Duration = t0.elapsed() / 4;
            per_limb
        })
    });
    group.bench_function("cold_limb_solve8", |b| {
        let mut k = 0usize;
        b.iter_custom(|iters| {
            let t0 = Instant::now();
            for _ in 0..iters {
                let targets: [Vec3; 8] =
                    std::array::from_fn(|i| cold[i % 4][(k + i / 4) % cold[i % 4].len()]);
                k += 2;
                let mut poses = [ChainPose::NEUTRAL; 8];
                black_box(solve8_prepared_tolerances(
                    &prepared,
                    [root(); 8],
                    black_box(targets),
                    &mut poses,
                    &params,
                    [params.tolerance; 8],
                ));
                black_box(&poses);
            }
            // One iteration solves eight limbs: report per limb.
            t0.elapsed() / 8
        })
    });
    group.bench_function("warm_2mm_limb_solve8", |b| {
        let mut poses = [ChainPose::NEUTRAL; 8];
        for (i, pose) in poses.iter_mut().enumerate() {
            solve(&chains[i % 4], root(), warm[i % 4][i / 4], pose, &params);
        }
        let mut frame = 1usize;
        b.iter_custom(|iters| {
            let t0 = Instant::now();
            for _ in 0..iters {
                let targets: [Vec3; 8] =
                    std::array::from_fn(|i| warm[i % 4][(frame + i / 4) % warm[i % 4].len()]);
                frame += 1;
                black_box(solve8_prepared_tolerances(
                    &prepared,
                    [root(); 8],
                    black_box(targets),
                    &mut poses,
                    &params,
                    [params.tolerance; 8],
                ));
            }
            let per_limb: Duration = t0.elapsed() / 8;
            per_limb
        })
    });
    let fparams = FabrikParams::default();
    group.bench_function("fabrik_cold_limb_solve", |b| {
        let mut k = 0usize;
        b.iter(|| {
            let limb = k % 4;
            let t = cold[limb][(k / 4) % cold[limb].len()];
            k += 1;
            let mut pose = ChainPose::NEUTRAL;
            black_box(fabrik::solve(
                &chains[limb],
                root(),
                black_box(t),
                &mut pose,
                &fparams,
            ));
            pose
        })
    });
    group.bench_function("fabrik_warm_2mm_limb_solve", |b| {
        let mut poses = [ChainPose::NEUTRAL; 4];
        for (i, pose) in poses.iter_mut().enumerate() {
            fabrik::solve(&chains[i], root(), warm[i][0], pose, &fparams);
        }
        let mut frame = [1usize; 4];
        let mut k = 0usize;
        b.iter(|| {
            let limb = k % 4;
            k += 1;
            let path = &warm[limb];
            let t = path[frame[limb] % path.len()];
            frame[limb] += 1;
            black_box(fabrik::solve(
                &chains[limb],
                root(),
                black_box(t),
                &mut poses[limb],
                &fparams,
            ))
        })
    });
    group.finish();
}

criterion_group!(benches, bench_ik);
criterion_main!(benches);
