//! `solve_warm` (the GripLoad stage's solve, its Newton steps started from the last
//! frame's forces) ends at the same optimum as a fresh `solve_from`: over 10,000 random
//! stances, each moved a little as from one frame to the next, every force and the
//! residual agree within 1e-9 body weights (plus the one f32 rounding step of the
//! answers in newtons), the active limits are the same; started from a wrong or
//! mismatched start it is the same again.

mod common;

use common::random_case;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use slothsim_load::{GripLoads, MAX_GRIPS, SolveMethod, Stance, solve_from, solve_warm};

const CASES: usize = 10_000;
/// Agreement of the optimum (body weights).
const TOL_BW: f32 = 1e-9;

/// `a` and `b` (N) agree within `TOL_BW` of `weight` and one f32 rounding.
fn close(a: Vec3, b: Vec3, weight: f32) -> bool {
    (a - b)
        .to_array()
        .iter()
        .zip(a.to_array().iter().zip(b.to_array()))
        .all(|(d, (x, y))| d.abs() <= TOL_BW * weight + f32::EPSILON * x.abs().max(y.abs()))
}

fn same_optimum(warm: &GripLoads, fresh: &GripLoads, weight: f32, what: &str) {
    assert_eq!(warm.count, fresh.count, "{what}");
    for (a, b) in warm.grip_forces().iter().zip(fresh.grip_forces()) {
        assert!(close(*a, *b, weight), "{what}: force {a} vs fresh {b}");
    }
    assert!(
        close(warm.residual_force, fresh.residual_force, weight),
        "{what}: residual force {} vs {}",
        warm.residual_force,
        fresh.residual_force
    );
    assert!(
        close(warm.residual_torque, fresh.residual_torque, weight),
        "{what}: residual torque {} vs {}",
        warm.residual_torque,
        fresh.residual_torque
    );
    assert_eq!(warm.active, fresh.active, "{what}: active limits");
}

#[test]
fn warm_started_solves_match_fresh_solves_within_1e_9_bw() {
    let mut rng = Pcg64::seed_from_u64(26);
    let (mut cone, mut identical, mut compared) = (0, 0, 0);
    for case_no in 0..CASES {
        let mut case = random_case(&mut rng);
        let weight = case.params.body_weight_n() as f32;
        let p = case.params;
        let before = {
            let st = Stance {
                com: case.com,
                com_acc: case.com_acc,
                ang_mom_rate: case.ang_mom_rate,
                grips: &case.grips,
            };
            solve_from(&p, &st, &[0; MAX_GRIPS]).unwrap()
        };
        // One frame later: the body moved up to 2 mm, its acceleration by up to 0.1 m/s².
        let jitter = |rng: &mut Pcg64, s: f32| {
            Vec3::new(
                rng.random_range(-s..s),
                rng.random_range(-s..s),
                rng.random_range(-s..s),
            )
        };
        case.com += jitter(&mut rng, 0.002);
        case.com_acc += jitter(&mut rng, 0.1);
        let st = Stance {
            com: case.com,
            com_acc: case.com_acc,
            ang_mom_rate: case.ang_mom_rate,
            grips: &case.grips,
        };
        let fresh = solve_from(&p, &st, &before.active).unwrap();
        let warm = solve_warm(&p, &st, &before.active, before.grip_forces()).unwrap();
        if fresh.method == SolveMethod::ConeActiveSet {
            cone += 1;
        }
        same_optimum(&warm, &fresh, weight, &format!("case {case_no}"));
        compared += 1;
        identical += usize::from(warm == fresh || warm.grip_forces() == fresh.grip_forces());
        // A wrong start (random forces up to 2 BW) and one of another length.
        let wrong: Vec<Vec3> = (0..case.grips.len())
            .map(|_| jitter(&mut rng, 2.0 * weight))
            .collect();
        let w2 = solve_warm(&p, &st, &before.active, &wrong).unwrap();
        same_optimum(&w2, &fresh, weight, &format!("case {case_no}, wrong start"));
        let w3 = solve_warm(&p, &st, &before.active, &[Vec3::ZERO; 5]).unwrap();
        same_optimum(
            &w3,
            &fresh,
            weight,
            &format!("case {case_no}, mismatched start"),
        );
    }
    println!("{compared} stances, {cone} with a cone binding, {identical} bit-identical");
    assert!(cone >= 200, "too few stances with a binding cone: {cone}");
}
