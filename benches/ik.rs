//! CCD limb-solve cost: ns per limb solve, cold (from the neutral pose) and warm
//! (previous frame's pose, target moving ~2 mm per frame: the realistic case).
//! Also prints the mean number of CCD sweeps for both.
//!
//! `cargo bench --bench ik`

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use slothsim_rig::{
    CcdParams, ChainPose, FabrikParams, LimbChain, Rig, RootTransform, fabrik, solve,
};

/// Deterministic xorshift in [0, 1).
fn rnd(state: &mut u64) -> f32 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 40) as f32 / (1u64 << 24) as f32
}

fn random_u(state: &mut u64) -> [f32; 12] {
    std::array::from_fn(|_| 0.05 + 0.9 * rnd(state))
}

fn root() -> RootTransform {
    RootTransform::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_y(0.7))
}

/// Reachable targets: FK of random within-limits poses.
fn cold_targets(chain: &LimbChain, n: usize, seed: u64) -> Vec<Vec3> {
    let mut s = seed;
    (0..n)
        .map(|_| chain.fk(root(), &chain.sample_pose(&random_u(&mut s)))[4])
        .collect()
}

/// A reachable effector path with `step` metres between frames, ping-ponged so it can
/// be replayed forever without jumps.
fn warm_path(chain: &LimbChain, step: f32, seed: u64) -> Vec<Vec3> {
    let mut s = seed;
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
