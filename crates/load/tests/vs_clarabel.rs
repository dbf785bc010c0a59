//! The specialised solver against clarabel over 10,000 random stances: every grip force
//! and the residual within 1e-4 body weights, and the same active limits (friction cone,
//! grip strength) at every claw.

mod common;

use common::{Case, random_case};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use slothsim_load::{
    GripLoads, MAX_GRIPS, SolveMethod, Stance, grip_states, solve, solve_from, solve_reference,
    solve_warm,
};

const CASES: usize = 10_000;
/// Force agreement (body weights).
const FORCE_TOL_BW: f32 = 1e-4;
/// A limit is active when its slack is below this (body weights). 1e-6 splits one
/// degenerate case of 10,000 (a cone limit active with a zero multiplier: slack −2e-9 here,
/// 1.5e-6 in clarabel) below the forces' own agreement (3e-5 BW).
const ACTIVE_TOL_BW: f64 = 1e-5;

fn stance(c: &Case) -> Stance<'_> {
    Stance {
        com: c.com,
        com_acc: c.com_acc,
        ang_mom_rate: c.ang_mom_rate,
        grips: &c.grips,
    }
}

/// Asserts that `ours` is clarabel's optimum `reference` for `case` (`what`: the case
/// and start, for the message): every grip force and the residual within
/// [`FORCE_TOL_BW`], the same active limits. Returns the largest force difference (BW).
fn assert_same_optimum(what: &str, case: &Case, ours: &GripLoads, reference: &GripLoads) -> f32 {
    let (p, st) = (&case.params, stance(case));
    let w = p.body_weight_n() as f32;
    let mut worst = 0f32;
    for (a, b) in ours.grip_forces().iter().zip(reference.grip_forces()) {
        let d = (*a - *b).length() / w;
        worst = worst.max(d);
        assert!(
            d <= FORCE_TOL_BW,
            "{what}: force {a} vs clarabel {b} ({d} BW)\n{case:?}"
        );
    }
    let dr = (ours.residual_bw(p) - reference.residual_bw(p)).abs();
    assert!(dr <= FORCE_TOL_BW, "{what}: residual differs by {dr} BW");
    assert_eq!(
        grip_states(p, &st, ours, ACTIVE_TOL_BW),
        grip_states(p, &st, reference, ACTIVE_TOL_BW),
        "{what}: active sets differ\n{case:?}\n{ours:?}\n{reference:?}"
    );
    worst
}

#[test]
fn specialised_solver_matches_clarabel_on_10k_random_stances() {
    let mut rng = Pcg64::seed_from_u64(22);
    let mut counts = [0usize; 6];
    let mut methods = [0usize; 4];
    let mut worst = 0f32;
    for case_no in 0..CASES {
        let case = random_case(&mut rng);
        let st = stance(&case);
        let p = &case.params;
        let ours = solve(p, &st).unwrap_or_else(|e| panic!("case {case_no}: {e}\n{case:?}"));
        let reference =
            solve_reference(p, &st).unwrap_or_else(|e| panic!("case {case_no}: {e}\n{case:?}"));
        methods[ours.method as usize] += 1;
        let what = format!("case {case_no}");
        worst = worst.max(assert_same_optimum(&what, &case, &ours, &reference));
        // Started from any active set (its own: a right hint; a random one: a wrong
        // hint, as after a frame's change of stance), the solve ends at the same optimum.
        let wrong: [u8; MAX_GRIPS] = std::array::from_fn(|i| ((case_no * 7 + i * 3) % 8) as u8);
        for hint in [ours.active, wrong] {
            let again = solve_from(p, &st, &hint)
                .unwrap_or_else(|e| panic!("case {case_no} from {hint:?}: {e}\n{case:?}"));
            let what = format!("case {case_no} from {hint:?}");
            worst = worst.max(assert_same_optimum(&what, &case, &again, &reference));
        }
        let sa = grip_states(p, &st, &ours, ACTIVE_TOL_BW);
        for s in sa {
            counts[s as usize] += 1;
        }
    }
    eprintln!(
        "{CASES} stances: grips free/cone/pull-limit/corner/push-limit/push-corner = {counts:?}, solved by closed form/linear active set/cone active set/barrier = {methods:?}, worst force difference {worst:.2e} BW"
    );
    // The comparison must exercise every kind of active set.
    assert!(counts.iter().all(|&n| n > 100), "{counts:?}");
    // …and every stage of the solver.
    assert!(methods.iter().all(|&n| n > 100), "{methods:?}");
}

/// `solve_warm` (the GripLoad stage's solve: where the closed form's optimum leaves a grip
/// set, Newton's method in wrench space, else the path above) against clarabel on the
/// same kind of 10,000 random stances, started cold, from a wrong start and hint, and from
/// the right active set: every force and the residual within 1e-4 BW, the same active
/// limits, and the wrench-space Newton answering at least 90 % of the stances the closed
/// form does not.
#[test]
fn warm_solver_matches_clarabel_on_10k_random_stances() {
    let mut rng = Pcg64::seed_from_u64(22);
    let mut methods = [0usize; 6];
    let mut steps = 0u32;
    let mut worst = 0f32;
    for case_no in 0..CASES {
        let case = random_case(&mut rng);
        let st = stance(&case);
        let p = &case.params;
        let w = p.body_weight_n() as f32;
        let reference =
            solve_reference(p, &st).unwrap_or_else(|e| panic!("case {case_no}: {e}\n{case:?}"));
        let wrong: Vec<glam::Vec3> = (0..case.grips.len())
            .map(|i| glam::Vec3::new(1.0, -2.0, 0.5) * (w * (i as f32 - 1.5)))
            .collect();
        let right = solve(p, &st)
            .unwrap_or_else(|e| panic!("case {case_no}: {e}\n{case:?}"))
            .active;
        let wrong_hint: [u8; MAX_GRIPS] =
            std::array::from_fn(|i| ((case_no * 7 + i * 3) % 8) as u8);
        for (start, warm, hint) in [
            ("cold", &[][..], [0; MAX_GRIPS]),
            ("wrong", &wrong[..], wrong_hint),
            ("right hint", &[][..], right),
        ] {
            let ours = solve_warm(p, &st, &hint, warm)
                .unwrap_or_else(|e| panic!("case {case_no} {start}: {e}\n{case:?}"));
            methods[ours.method as usize] += 1;
            if ours.method == SolveMethod::DualNewton {
                steps += ours.iterations;
            }
            let what = format!("case {case_no} {start}");
            worst = worst.max(assert_same_optimum(&what, &case, &ours, &reference));
        }
    }
    let newton = methods[SolveMethod::DualNewton as usize];
    let others: usize = methods[1..4].iter().sum();
    eprintln!(
        "{CASES} stances × 3 starts: closed form/linear/cone active set/barrier/-/wrench Newton = {methods:?}, {:.2} Newton steps a wrench-Newton solve, worst force difference {worst:.2e} BW",
        f64::from(steps) / newton.max(1) as f64
    );
    assert!(newton > 2_000, "{methods:?}");
    // Measured 7,138 of 7,500 (95 %); the rest are the active-set path's, as before.
    assert!(newton * 10 >= (newton + others) * 9, "{methods:?}");
}
