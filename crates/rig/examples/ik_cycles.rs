//! Fixed-work timing loop for `perf stat` / `valgrind --tool=cachegrind` (instruction
//! counts are robust to a loaded box):
//! `cargo run --release -p slothsim-rig --example ik_cycles -- warm|cold|warm4|cold4|warm4u|cold4u [solves]`.
//! The `…4` modes solve the four limbs together with `solve4_prepared` (`…4u`: `solve4`,
//! chains transposed on every call); `solves` counts limbs.
use glam::{Quat, Vec3};
use slothsim_rig::{
    CcdParams, ChainPose, LimbChains4, Rig, RootTransform, solve, solve4, solve4_prepared,
};

fn rnd(state: &mut u64) -> f32 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 40) as f32 / (1u64 << 24) as f32
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let mode = args.get(1).map_or("warm", |s| s.as_str()).to_owned();
    let n: usize = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(400_000);
    let rig = Rig::sloth();
    let root = RootTransform::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_y(0.7));
    let params = CcdParams::default();
    let mut s = 7u64;
    let mut paths = vec![];
    for chain in rig.chains() {
        let mut path: Vec<Vec3> = vec![];
        let mut ua: [f32; 12] = std::array::from_fn(|_| 0.05 + 0.9 * rnd(&mut s));
        while path.len() < 2000 {
            let ub: [f32; 12] = std::array::from_fn(|_| 0.05 + 0.9 * rnd(&mut s));
            for k in 0..=4000 {
                let t = k as f32 / 4000.0;
                let u: [f32; 12] = std::array::from_fn(|i| ua[i] + (ub[i] - ua[i]) * t);
                let p = chain.fk(root, &chain.sample_pose(&u))[4];
                let step = if mode.starts_with("warm") { 2e-3 } else { 0.05 };
                if path.last().is_none_or(|l| l.distance(p) >= step) {
                    path.push(p);
                }
            }
            ua = ub;
        }
        paths.push(path);
    }
    let mut poses = [ChainPose::NEUTRAL; 4];
    let t0 = std::time::Instant::now();
    let mut sweeps = 0u64;
    if mode.contains('4') {
        let chains = rig.chains();
        let chains = [&chains[0], &chains[1], &chains[2], &chains[3]];
        let prepared = LimbChains4::new(chains);
        for k in 0..n / 4 {
            let targets: [Vec3; 4] = std::array::from_fn(|limb| {
                let path = &paths[limb];
                let i = k % (2 * path.len() - 2);
                path[if i < path.len() {
                    i
                } else {
                    2 * path.len() - 2 - i
                }]
            });
            if mode.starts_with("cold") {
                poses = [ChainPose::NEUTRAL; 4];
            }
            let targets = std::hint::black_box(targets);
            let r = if mode.ends_with('u') {
                solve4(chains, [root; 4], targets, &mut poses, &params)
            } else {
                solve4_prepared(&prepared, [root; 4], targets, &mut poses, &params)
            };
            sweeps += r.iter().map(|r| u64::from(r.iterations)).sum::<u64>();
        }
        let dt = t0.elapsed();
        println!(
            "{mode}: {:.1} ns/limb solve, mean sweeps {:.3}",
            dt.as_nanos() as f64 / (n / 4 * 4) as f64,
            sweeps as f64 / (n / 4 * 4) as f64
        );
        return;
    }
    for k in 0..n {
        let limb = k % 4;
        let path = &paths[limb];
        let i = (k / 4) % (2 * path.len() - 2);
        let t = path[if i < path.len() {
            i
        } else {
            2 * path.len() - 2 - i
        }];
        if mode == "cold" {
            poses[limb] = ChainPose::NEUTRAL;
        }
        let r = solve(
            &rig.chains()[limb],
            root,
            std::hint::black_box(t),
            &mut poses[limb],
            &params,
        );
        sweeps += u64::from(r.iterations);
    }
    let dt = t0.elapsed();
    println!(
        "{mode}: {:.1} ns/solve, mean sweeps {:.3}",
        dt.as_nanos() as f64 / n as f64,
        sweeps as f64 / n as f64
    );
}
