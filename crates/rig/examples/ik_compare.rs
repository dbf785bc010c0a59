//! CCD vs FABRIK on the same random reachable targets (FK of within-limits poses over
//! the full ranges) and the same 2 mm/frame tracking paths, all four limbs. Prints the
//! README table: `cargo run --release -p slothsim-rig --example ik_compare`.

use glam::{Quat, Vec3};
use slothsim_rig::{
    CcdParams, CcdResult, ChainPose, FabrikParams, JointLimit, LimbChain, Rig, RootTransform,
    fabrik,
};

fn rnd(state: &mut u64) -> f32 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 40) as f32 / (1u64 << 24) as f32
}

#[derive(Clone, Copy)]
enum Solver {
    Ccd,
    CcdFree,
    Fabrik,
    FabrikFree,
}

impl Solver {
    fn name(self) -> &'static str {
        match self {
            Solver::Ccd => "CCD (limits)",
            Solver::CcdFree => "CCD (no limits)",
            Solver::Fabrik => "FABRIK (limits projected)",
            Solver::FabrikFree => "FABRIK (no limits)",
        }
    }

    fn solve(
        self,
        chain: &LimbChain,
        root: RootTransform,
        t: Vec3,
        p: &mut ChainPose,
    ) -> CcdResult {
        match self {
            Solver::Ccd => slothsim_rig::solve(chain, root, t, p, &CcdParams::default()),
            Solver::CcdFree => {
                slothsim_rig::solve(&widened(chain), root, t, p, &CcdParams::default())
            }
            Solver::Fabrik => fabrik::solve(chain, root, t, p, &FabrikParams::default()),
            Solver::FabrikFree => {
                let params = FabrikParams {
                    apply_limits: false,
                    ..FabrikParams::default()
                };
                fabrik::solve(chain, root, t, p, &params)
            }
        }
    }
}

/// The chain with every limit opened to the full circle (same joint kinds).
fn widened(chain: &LimbChain) -> LimbChain {
    let mut c = *chain;
    let pi = std::f32::consts::PI;
    for l in &mut c.limits {
        *l = match *l {
            JointLimit::Hinge { axis, .. } => JointLimit::Hinge {
                axis,
                min: -pi,
                max: pi,
            },
            JointLimit::Ball { twist_axis, .. } => JointLimit::Ball {
                twist_axis,
                swing_max: pi,
                twist_min: -pi,
                twist_max: pi,
            },
            JointLimit::Free => JointLimit::Free,
        };
    }
    c
}

/// Elbow/knee bend (degrees): angle between upper and lower long bone.
fn bend_deg(chain: &LimbChain, root: RootTransform, pose: &ChainPose) -> f32 {
    let p = chain.fk(root, pose);
    (p[2] - p[1]).angle_between(p[3] - p[2]).to_degrees()
}

#[derive(Default)]
struct Acc {
    n: usize,
    reached: usize,
    err_sum: f64,
    err_max: f32,
    viol_sum: f64,
    viol_max: f32,
    bend_sum: f64,
    change_sum: f64,
    change_max: f32,
    iters: u64,
}

fn main() {
    let rig = Rig::sloth();
    let root = RootTransform::new(Vec3::new(1.0, 2.0, 3.0), Quat::from_rotation_y(0.7));
    let n_targets = 1000;
    let solvers = [
        Solver::Ccd,
        Solver::Fabrik,
        Solver::CcdFree,
        Solver::FabrikFree,
    ];
    println!("cold: {n_targets} targets per limb from the neutral pose; warm: 2 mm/frame paths");
    println!(
        "| solver | reached ≤ 1 mm (cold) | mean / max error mm | mean / max limit violation ° | mean elbow/knee bend ° | mean change from start ° | mean iterations | reached (warm) | mean / max change per frame ° |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut s0 = 1u64;
    let targets: Vec<Vec<Vec3>> = rig
        .chains()
        .iter()
        .map(|chain| {
            (0..n_targets)
                .map(|_| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s0));
                    chain.fk(root, &chain.sample_pose(&u))[4]
                })
                .collect()
        })
        .collect();
    let mut s1 = 99u64;
    let paths: Vec<Vec<Vec3>> = rig
        .chains()
        .iter()
        .map(|chain| {
            let mut path: Vec<Vec3> = vec![];
            let mut ua: [f32; 12] = std::array::from_fn(|_| rnd(&mut s1));
            while path.len() < 1500 {
                let ub: [f32; 12] = std::array::from_fn(|_| rnd(&mut s1));
                for k in 0..=4000 {
                    let t = k as f32 / 4000.0;
                    let u: [f32; 12] = std::array::from_fn(|i| ua[i] + (ub[i] - ua[i]) * t);
                    let p = chain.fk(root, &chain.sample_pose(&u))[4];
                    if path.last().is_none_or(|l| l.distance(p) >= 2e-3) {
                        path.push(p);
                    }
                }
                ua = ub;
            }
            path
        })
        .collect();
    for solver in solvers {
        let mut cold = Acc::default();
        let mut warm = Acc::default();
        for (li, chain) in rig.chains().iter().enumerate() {
            for &t in &targets[li] {
                let mut pose = ChainPose::NEUTRAL;
                let r = solver.solve(chain, root, t, &mut pose);
                let err = chain.fk(root, &pose)[4].distance(t);
                let viol = chain.limit_violation(&pose).to_degrees();
                cold.n += 1;
                cold.reached += usize::from(err <= 1e-3);
                cold.err_sum += f64::from(err);
                cold.err_max = cold.err_max.max(err);
                cold.viol_sum += f64::from(viol);
                cold.viol_max = cold.viol_max.max(viol);
                cold.bend_sum += f64::from(bend_deg(chain, root, &pose));
                cold.change_sum +=
                    f64::from(ChainPose::NEUTRAL.max_joint_delta(&pose).to_degrees());
                cold.iters += u64::from(r.iterations);
            }
            let mut pose = ChainPose::NEUTRAL;
            solver.solve(chain, root, paths[li][0], &mut pose);
            for &t in &paths[li][1..] {
                let before = pose;
                solver.solve(chain, root, t, &mut pose);
                let err = chain.fk(root, &pose)[4].distance(t);
                let change = before.max_joint_delta(&pose).to_degrees();
                warm.n += 1;
                warm.reached += usize::from(err <= 1e-3);
                warm.change_sum += f64::from(change);
                warm.change_max = warm.change_max.max(change);
            }
        }
        let n = cold.n as f64;
        println!(
            "| {} | {:.1} % | {:.3} / {:.1} | {:.2} / {:.1} | {:.1} | {:.1} | {:.2} | {:.2} % | {:.2} / {:.1} |",
            solver.name(),
            100.0 * cold.reached as f64 / n,
            1e3 * cold.err_sum / n,
            1e3 * cold.err_max,
            cold.viol_sum / n,
            cold.viol_max,
            cold.bend_sum / n,
            cold.change_sum / n,
            cold.iters as f64 / n,
            100.0 * warm.reached as f64 / warm.n as f64,
            warm.change_sum / warm.n as f64,
            warm.change_max,
        );
    }
    // Reference: the poses the targets were made from.
    let mut s0 = 1u64;
    let mut bend = 0.0f64;
    for chain in rig.chains() {
        for _ in 0..n_targets {
            let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s0));
            bend += f64::from(bend_deg(chain, root, &chain.sample_pose(&u)));
        }
    }
    println!(
        "| (generating poses) | | | 0 | {:.1} | | | | |",
        bend / (4 * n_targets) as f64
    );
}
