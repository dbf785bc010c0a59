//! Measured cost per solve of the specialised solver and of clarabel:
//! `cargo run --release -p slothsim-load --example cost`.

#[path = "../tests/common/mod.rs"]
mod common;

use std::hint::black_box;
use std::time::Instant;

use glam::Vec3;
use rand::SeedableRng;
use rand_pcg::Pcg64;
use slothsim_load::{Grip, GripLoads, LoadError, LoadParams, Stance, solve, solve_reference};

type Solver = fn(&LoadParams, &Stance) -> Result<GripLoads, LoadError>;

/// Mean µs per solve over `cases` (repeated until ~0.3 s have passed).
fn time(solver: Solver, cases: &[(LoadParams, Vec<Grip>, Vec3, Vec3, Vec3)]) -> f64 {
    let mut runs = 0usize;
    let start = Instant::now();
    while start.elapsed().as_secs_f64() < 0.3 {
        for (p, grips, com, acc, ldot) in cases {
            let st = Stance {
                com: *com,
                com_acc: *acc,
                ang_mom_rate: *ldot,
                grips,
            };
            black_box(solver(p, &st)).ok();
            runs += 1;
        }
    }
    start.elapsed().as_secs_f64() * 1e6 / runs as f64
}

fn main() {
    let p = LoadParams::default();
    let under = |x: f32, z: f32| Grip {
        point: Vec3::new(x, 0.0, z),
        normal: Vec3::NEG_Y,
    };
    let com = Vec3::new(0.0, -0.2, 0.0);
    let hanging = vec![
        (
            p,
            vec![
                under(0.1, 0.2),
                under(-0.1, 0.2),
                under(0.1, -0.2),
                under(-0.1, -0.2),
            ],
            com,
            Vec3::new(0.0, 0.1, 0.3),
            Vec3::ZERO,
        ),
        (
            p,
            vec![under(0.1, 0.2), under(-0.1, 0.25), under(0.1, -0.2)],
            com,
            Vec3::ZERO,
            Vec3::ZERO,
        ),
    ];
    let mut rng = Pcg64::seed_from_u64(7);
    let (mut closed, mut barrier) = (Vec::new(), Vec::new());
    while closed.len() < 2000 || barrier.len() < 2000 {
        let c = common::random_case(&mut rng);
        let st = Stance {
            com: c.com,
            com_acc: c.com_acc,
            ang_mom_rate: c.ang_mom_rate,
            grips: &c.grips,
        };
        let Ok(l) = solve(&c.params, &st) else {
            continue;
        };
        let entry = (c.params, c.grips.clone(), c.com, c.com_acc, c.ang_mom_rate);
        if l.iterations == 0 && !c.grips.is_empty() {
            closed.push(entry);
        } else if l.iterations > 0 {
            barrier.push(entry);
        }
    }
    let newton: f64 = barrier
        .iter()
        .map(|(p, g, c, a, l)| {
            let st = Stance {
                com: *c,
                com_acc: *a,
                ang_mom_rate: *l,
                grips: g,
            };
            f64::from(solve(p, &st).unwrap().iterations)
        })
        .sum::<f64>()
        / barrier.len() as f64;
    println!("µs per solve         specialised   clarabel");
    for (name, set) in [
        ("hanging (2 stances)", &hanging),
        ("random, closed form", &closed),
        ("random, limits bind", &barrier),
    ] {
        println!(
            "{name:<20} {:>11.2} {:>10.2}",
            time(solve, set),
            time(solve_reference, set)
        );
    }
    println!("Newton steps per barrier solve: {newton:.1}");
}
