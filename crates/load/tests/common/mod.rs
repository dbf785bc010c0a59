//! Random stances for the solver comparison and the cost example.

use glam::Vec3;
use rand::Rng;
use slothsim_load::{Grip, LoadParams, MAX_GRIPS};

/// One random case: parameters, grips, centre of mass, accelerations.
#[derive(Clone, Debug)]
pub struct Case {
    pub params: LoadParams,
    pub grips: Vec<Grip>,
    pub com: Vec3,
    pub com_acc: Vec3,
    pub ang_mom_rate: Vec3,
}

fn unit(rng: &mut impl Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
            rng.random_range(-1.0..1.0),
        );
        if let Some(u) = v.try_normalize().filter(|_| v.length() <= 1.0) {
            return u;
        }
    }
}

fn in_box(rng: &mut impl Rng, half: Vec3) -> Vec3 {
    Vec3::new(
        rng.random_range(-half.x..half.x),
        rng.random_range(-half.y..half.y),
        rng.random_range(-half.z..half.z),
    )
}

/// A random stance: 0–4 claws (mostly 2–4) around a body hanging below, on top of or
/// beside its supports, any surface normal, parameters across their plausible ranges,
/// accelerations mostly gait-like (≤ 3 m/s²) and sometimes violent (≤ 20 m/s²).
pub fn random_case(rng: &mut impl Rng) -> Case {
    let params = LoadParams {
        mass_kg: rng.random_range(6.5..10.6),
        gravity: 9.81,
        mu: rng.random_range(0.2..1.2),
        grip_strength_bw: rng.random_range(0.3..2.0),
        push_strength_bw: rng.random_range(0.3..3.0),
        w_residual: 10f64.powf(rng.random_range(2.0..5.0)),
        w_force: 10f64.powf(rng.random_range(-1.0..1.0)),
        residual_arm_m: rng.random_range(0.1..0.4),
    };
    let k = match rng.random_range(0..20) {
        0 => 0,
        1..=2 => 1,
        3..=6 => 2,
        7..=12 => 3,
        _ => MAX_GRIPS,
    };
    let com = in_box(rng, Vec3::splat(0.05));
    let lift = rng.random_range(-0.3..0.3);
    let grips = (0..k)
        .map(|_| {
            let point = com + Vec3::new(0.0, lift, 0.0) + in_box(rng, Vec3::new(0.3, 0.1, 0.4));
            // Half the claws on a support's underside or top (normal ≈ ∓Y), half anywhere.
            let normal = if rng.random_bool(0.5) {
                let s = if rng.random_bool(0.7) { -1.0 } else { 1.0 };
                (Vec3::Y * s + 0.5 * unit(rng)).normalize()
            } else {
                unit(rng)
            };
            Grip { point, normal }
        })
        .collect();
    let acc_scale = if rng.random_bool(0.9) { 3.0 } else { 20.0 };
    Case {
        params,
        grips,
        com,
        com_acc: unit(rng) * rng.random_range(0.0..acc_scale),
        ang_mom_rate: unit(rng) * rng.random_range(0.0..2.0),
    }
}
