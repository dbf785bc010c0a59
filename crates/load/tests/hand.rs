//! Grip loads with answers derived by hand (crate README, "Hand-derived checks").
//!
//! Geometry: a branch along Z through the origin, the sloth hanging below it: claws on
//! the branch's underside at x = ±0.1 m (left +X), z = ±0.2 m (fore +Z), outward normal
//! −Y; centre of mass 0.2 m below the branch. m = 8 kg, g = 9.81 m/s² ⇒ W = 78.48 N.
//! Every case is checked with both solvers.

use glam::Vec3;
use slothsim_load::{
    Grip, GripLoads, GripState, LoadError, LoadParams, Stance, grip_states, solve, solve_reference,
};

const LF: Vec3 = Vec3::new(0.1, 0.0, 0.2);
const RF: Vec3 = Vec3::new(-0.1, 0.0, 0.2);
const LH: Vec3 = Vec3::new(0.1, 0.0, -0.2);
const RH: Vec3 = Vec3::new(-0.1, 0.0, -0.2);
const COM: Vec3 = Vec3::new(0.0, -0.2, 0.0);

fn under(point: Vec3) -> Grip {
    Grip {
        point,
        normal: Vec3::NEG_Y,
    }
}

fn still(grips: &[Grip], com: Vec3) -> Stance<'_> {
    Stance {
        com,
        com_acc: Vec3::ZERO,
        ang_mom_rate: Vec3::ZERO,
        grips,
    }
}

/// Both solvers' answers.
fn both(params: &LoadParams, stance: &Stance) -> [GripLoads; 2] {
    [
        solve(params, stance).expect("specialised solver"),
        solve_reference(params, stance).expect("clarabel"),
    ]
}

fn assert_close(a: Vec3, b: Vec3, tol: f32, what: &str) {
    assert!((a - b).length() <= tol, "{what}: {a} vs {b} (tol {tol})");
}

/// Four symmetric grips, hanging still. With ρ = w_r/w_f the optimum is, per grip,
/// f = ρ W / (1 + 4ρ) upward and the residual force W / (1 + 4ρ): ¼ W as ρ → ∞.
#[test]
fn four_symmetric_grips_carry_a_quarter_each() {
    let params = LoadParams::default();
    let w = params.body_weight_n() as f32;
    let rho = (params.w_residual / params.w_force) as f32;
    let grips = [under(LF), under(RF), under(LH), under(RH)];
    for loads in both(&params, &still(&grips, COM)) {
        for &f in loads.grip_forces() {
            assert_close(f, Vec3::Y * (rho * w / (1.0 + 4.0 * rho)), 1e-4 * w, "grip");
            assert_close(f, Vec3::Y * (w / 4.0), 1e-4 * w, "quarter BW");
        }
        assert_close(
            loads.residual_force,
            Vec3::Y * (w / (1.0 + 4.0 * rho)),
            1e-5 * w,
            "residual",
        );
        assert!(loads.residual_torque.length() < 1e-5 * w);
        let states = grip_states(&params, &still(&grips, COM), &loads, 1e-6);
        assert!(states.iter().all(|&s| s == GripState::Free), "{states:?}");
    }
}

/// Two diagonal grips (LF, RH) with the CoM below their line: no residual is needed.
/// At the midpoint each carries ½ W (residual W/(1 + 2ρ) ≈ 5e-5 W from the penalty);
/// below the point a quarter of the way from LF (x = 0.05, z = 0.1) the lever rule gives
/// ¾ W to LF and ¼ W to RH, with no force along the line (minimum norm).
#[test]
fn two_diagonal_grips_with_com_below_their_line_need_no_residual() {
    let params = LoadParams::default();
    let w = params.body_weight_n() as f32;
    let rho = (params.w_residual / params.w_force) as f32;
    let grips = [under(LF), under(RH)];
    for loads in both(&params, &still(&grips, COM)) {
        for &f in loads.grip_forces() {
            assert_close(f, Vec3::Y * (w / 2.0), 1e-4 * w, "half BW");
        }
        assert!(loads.residual_bw(&params) <= 1e-4);
        let expect = 1.0 / (1.0 + 2.0 * rho);
        assert!((loads.residual_bw(&params) - expect).abs() < 1e-6);
    }
    let stiff = LoadParams {
        w_residual: 1e7,
        ..params
    };
    let com = Vec3::new(0.05, -0.2, 0.1);
    for loads in both(&stiff, &still(&grips, com)) {
        let f = loads.grip_forces();
        assert_close(f[0], Vec3::Y * (0.75 * w), 1e-5 * w, "LF ¾ W");
        assert_close(f[1], Vec3::Y * (0.25 * w), 1e-5 * w, "RH ¼ W");
        assert!(loads.residual_bw(&stiff) <= 1e-6);
    }
}

/// Two same-side grips (LF, LH: the line x = 0.1, y = 0 along Z) with the CoM 0.1 m to
/// its side: point claws take no moment about the line, so the residual wrench's moment
/// about it must cancel gravity's, M = W × 0.1 m = 7.848 N·m, exactly. Its cheapest form
/// (force at the CoM plus torque, torque counted over ℓ = 0.2 m) has size
/// M / (W √(ℓ² + r²)) with r = |CoM − line| = √0.05 m: 0.1 / 0.3 = ⅓ BW.
#[test]
fn two_same_side_grips_need_gravitys_moment_about_their_line() {
    let params = LoadParams::default();
    let w = params.body_weight_n() as f32;
    let grips = [under(LF), under(LH)];
    let gravity_moment = ((COM - LF).cross(Vec3::NEG_Y * w)).z;
    assert!(
        (gravity_moment - 0.1 * w).abs() < 1e-5 * w,
        "{gravity_moment}"
    );
    for loads in both(&params, &still(&grips, COM)) {
        let residual_moment = (loads.residual_torque + (COM - LF).cross(loads.residual_force)).z;
        assert!(
            (residual_moment + gravity_moment).abs() < 1e-4 * w,
            "residual moment {residual_moment} vs gravity {gravity_moment}"
        );
        // The claws' own moment about the line is zero (they lie on it).
        let claws: f32 = loads
            .grip_forces()
            .iter()
            .zip([LF, LH])
            .map(|(f, p)| (p - LF).cross(*f).z)
            .sum();
        assert!(claws.abs() < 1e-5 * w);
        assert!(
            (loads.residual_bw(&params) - 1.0 / 3.0).abs() < 1e-3,
            "{}",
            loads.residual_bw(&params)
        );
    }
}

/// One claw directly above the CoM with grip strength ½ BW: it pulls its limit, ½ W, and
/// the other ½ W is residual (exact: the limit binds, the penalty leaves nothing to trade).
#[test]
fn grip_strength_caps_the_pull() {
    let params = LoadParams {
        grip_strength_bw: 0.5,
        ..LoadParams::default()
    };
    let w = params.body_weight_n() as f32;
    let grips = [under(Vec3::ZERO)];
    let stance = still(&grips, COM);
    for loads in both(&params, &stance) {
        assert_close(loads.forces[0], Vec3::Y * (0.5 * w), 1e-5 * w, "pull limit");
        assert_close(
            loads.residual_force,
            Vec3::Y * (0.5 * w),
            1e-5 * w,
            "residual",
        );
        assert_eq!(
            grip_states(&params, &stance, &loads, 1e-6),
            [GripState::PullLimit]
        );
    }
}

/// One claw on a vertical trunk (outward normal +X) at the CoM's height and place, µ = 0.4,
/// G = 1: the weight is tangential and needs 1 BW of friction, but at zero normal force
/// the hooked claw holds 2µG = 0.8 BW. The optimum is the projection of b' = ρ/(1+ρ) ŷ onto
/// the cone |t| ≤ µ(s_n + 2G): s_n = −2G + (2G + µβ)/(1+µ²), |t| = µ(2G + µβ)/(1+µ²) with
/// β = ρ/(1+ρ): ≈ 0.069 BW pressing into the bark and 0.828 BW up the trunk.
#[test]
fn friction_limits_a_claw_on_a_trunk() {
    let params = LoadParams {
        mu: 0.4,
        ..LoadParams::default()
    };
    let w = params.body_weight_n() as f32;
    let (mu, g) = (0.4f64, 1.0f64);
    let rho = params.w_residual / params.w_force;
    let beta = rho / (1.0 + rho);
    let sn = -2.0 * g + (2.0 * g + mu * beta) / (1.0 + mu * mu);
    let t = mu * (2.0 * g + mu * beta) / (1.0 + mu * mu);
    assert!((sn - 0.069).abs() < 1e-3 && (t - 0.828).abs() < 1e-3);
    let grips = [Grip {
        point: Vec3::ZERO,
        normal: Vec3::X,
    }];
    let stance = still(&grips, Vec3::ZERO);
    for loads in both(&params, &stance) {
        let expect = Vec3::new(sn as f32, t as f32, 0.0) * w;
        assert_close(loads.forces[0], expect, 1e-4 * w, "friction-limited force");
        assert_eq!(
            grip_states(&params, &stance, &loads, 1e-6),
            [GripState::Cone]
        );
    }
}

/// Two claws pinching a thin vertical pole from opposite sides (normals ±X, 2 cm apart),
/// level with the CoM, the body accelerating up at 3 g: the claws must supply 4 W upward,
/// tangential at both. A claw holds |t| ≤ µ(s_n + 2G) with s_n ≤ P: with P = 0.5 BW at most
/// 0.6 × 2.5 = 1.5 BW each, pressing 0.5 BW into the pole (`PushCorner`); 3 W together,
/// residual 1 W. Without the push limit the pinch could press without bound.
#[test]
fn push_strength_caps_a_pinch() {
    let params = LoadParams {
        push_strength_bw: 0.5,
        ..LoadParams::default()
    };
    let w = params.body_weight_n() as f32;
    let grips = [
        Grip {
            point: Vec3::new(0.01, 0.0, 0.0),
            normal: Vec3::X,
        },
        Grip {
            point: Vec3::new(-0.01, 0.0, 0.0),
            normal: Vec3::NEG_X,
        },
    ];
    let stance = Stance {
        com_acc: Vec3::Y * (3.0 * params.gravity as f32),
        ..still(&grips, Vec3::ZERO)
    };
    for loads in both(&params, &stance) {
        let f = loads.grip_forces();
        assert_close(f[0], Vec3::new(0.5, 1.5, 0.0) * w, 1e-3 * w, "right claw");
        assert_close(f[1], Vec3::new(-0.5, 1.5, 0.0) * w, 1e-3 * w, "left claw");
        assert_eq!(
            grip_states(&params, &stance, &loads, 1e-5),
            [GripState::PushCorner, GripState::PushCorner]
        );
        assert!((loads.residual_bw(&params) - 1.0).abs() < 1e-3);
    }
}

/// Accelerating the body upward at 0.5 g with four grips: each carries 1.5/4 W.
#[test]
fn acceleration_enters_the_balance() {
    let params = LoadParams::default();
    let w = params.body_weight_n() as f32;
    let grips = [under(LF), under(RF), under(LH), under(RH)];
    let stance = Stance {
        com_acc: Vec3::Y * (0.5 * params.gravity as f32),
        ..still(&grips, COM)
    };
    for loads in both(&params, &stance) {
        for &f in loads.grip_forces() {
            assert_close(f, Vec3::Y * (1.5 * w / 4.0), 1e-4 * w, "1.5 W / 4");
        }
    }
}

#[test]
fn bad_parameters_name_the_field() {
    let grips = [under(LF)];
    let stance = still(&grips, COM);
    type Spoil = fn(&mut LoadParams);
    let cases: [(&str, Spoil); 8] = [
        ("mass_kg", |p| p.mass_kg = f64::NAN),
        ("mass_kg", |p| p.mass_kg = 0.0),
        ("mu", |p| p.mu = -0.5),
        ("grip_strength_bw", |p| p.grip_strength_bw = 0.0),
        ("push_strength_bw", |p| p.push_strength_bw = f64::NAN),
        ("w_residual", |p| p.w_residual = f64::INFINITY),
        ("w_force", |p| p.w_force = f64::NAN),
        ("residual_arm_m", |p| p.residual_arm_m = -1.0),
    ];
    for (field, spoil) in cases {
        let mut params = LoadParams::default();
        spoil(&mut params);
        for result in [solve(&params, &stance), solve_reference(&params, &stance)] {
            match result {
                Err(e @ LoadError::InvalidParam { field: f, .. }) => {
                    assert_eq!(f, field);
                    assert!(e.to_string().contains(field), "{e}");
                }
                other => panic!("{field}: expected InvalidParam, got {other:?}"),
            }
        }
    }
}

#[test]
fn bad_stances_are_errors_not_nan() {
    let params = LoadParams::default();
    let nan_com = [under(LF)];
    let zero_normal = [Grip {
        point: LF,
        normal: Vec3::ZERO,
    }];
    let five = [under(LF); 5];
    let nan_point = [under(Vec3::new(f32::NAN, 0.0, 0.0))];
    let cases = [
        still(&nan_com, Vec3::splat(f32::NAN)),
        still(&zero_normal, COM),
        still(&five, COM),
        still(&nan_point, COM),
    ];
    for stance in cases {
        assert!(matches!(
            solve(&params, &stance),
            Err(LoadError::BadInput(_))
        ));
        assert!(matches!(
            solve_reference(&params, &stance),
            Err(LoadError::BadInput(_))
        ));
    }
}

/// No grips: everything is residual (1 BW), no solve.
#[test]
fn no_grips_all_residual() {
    let params = LoadParams::default();
    let loads = solve(&params, &still(&[], COM)).unwrap();
    assert!((loads.residual_bw(&params) - 1.0).abs() < 1e-6);
    assert_eq!(loads.grip_forces().len(), 0);
}
