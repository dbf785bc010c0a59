//! The specialised solver against clarabel over 10,000 random stances: every grip force
//! and the residual within 1e-4 body weights, and the same active limits (friction cone,
//! grip strength) at every claw.

mod common;

use common::{Case, random_case};
use rand::SeedableRng;
use rand_pcg::Pcg64;
use slothsim_load::{MAX_GRIPS, Stance, grip_states, solve, solve_from, solve_reference};

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
        let w = p.body_weight_n() as f32;
        let ours = solve(p, &st).unwrap_or_else(|e| panic!("case {case_no}: {e}\n{case:?}"));
        let reference =
            solve_reference(p, &st).unwrap_or_else(|e| panic!("case {case_no}: {e}\n{case:?}"));
        methods[ours.method as usize] += 1;
        for (a, b) in ours.grip_forces().iter().zip(reference.grip_forces()) {
            let d = (*a - *b).length() / w;
            worst = worst.max(d);
            assert!(
                d <= FORCE_TOL_BW,
                "case {case_no}: force {a} vs clarabel {b} ({d} BW)\n{case:?}"
            );
        }
        // Started from any active set (its own: a right hint; a random one: a wrong
        // hint, as after a frame's change of stance), the solve ends at the same optimum.
        let wrong: [u8; MAX_GRIPS] = std::array::from_fn(|i| ((case_no * 7 + i * 3) % 8) as u8);
        for hint in [ours.active, wrong] {
            let again = solve_from(p, &st, &hint)
                .unwrap_or_else(|e| panic!("case {case_no} from {hint:?}: {e}\n{case:?}"));
            for (a, b) in again.grip_forces().iter().zip(reference.grip_forces()) {
                let d = (*a - *b).length() / w;
                worst = worst.max(d);
                assert!(
                    d <= FORCE_TOL_BW,
                    "case {case_no} from {hint:?}: force {a} vs clarabel {b} ({d} BW)"
                );
            }
        }
        let dr = (ours.residual_bw(p) - reference.residual_bw(p)).abs();
        assert!(
            dr <= FORCE_TOL_BW,
            "case {case_no}: residual differs by {dr} BW"
        );
        let sa = grip_states(p, &st, &ours, ACTIVE_TOL_BW);
        let sb = grip_states(p, &st, &reference, ACTIVE_TOL_BW);
        assert_eq!(
            sa, sb,
            "case {case_no}: active sets differ\n{case:?}\n{ours:?}\n{reference:?}"
        );
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
