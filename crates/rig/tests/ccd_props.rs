//! Property tests of the CCD limb solver. Every check rebuilds forward kinematics and
//! measures; none trusts the solver's own `reached` flag.

use glam::{Quat, Vec3};
use proptest::prelude::*;
use slothsim_rig::{
    CcdParams, CcdStatus, ChainPose, Limb, LimbChain, Rig, RootTransform, solve, solve4,
};

/// 1 mm: the acceptance distance for "reached".
const REACH_MM: f32 = 1e-3;

fn rig() -> &'static Rig {
    static RIG: std::sync::OnceLock<Rig> = std::sync::OnceLock::new();
    RIG.get_or_init(Rig::sloth)
}

fn limb_strategy() -> impl Strategy<Value = Limb> {
    prop::sample::select(Limb::ALL.to_vec())
}

/// Sample-space point of a within-limits pose over the *full* range of every joint
/// (0 and 1 are the limits themselves: workspace corners included).
fn unit12() -> impl Strategy<Value = [f32; 12]> {
    prop::array::uniform12(0.0f32..=1.0)
}

fn root_strategy() -> impl Strategy<Value = RootTransform> {
    (
        prop::array::uniform3(-50.0f32..50.0),
        prop::array::uniform3(-1.0f32..1.0),
        -3.2f32..3.2,
    )
        .prop_map(|(p, axis, angle)| {
            let axis = Vec3::from(axis).try_normalize().unwrap_or(Vec3::Y);
            RootTransform::new(Vec3::from(p), Quat::from_axis_angle(axis, angle))
        })
}

fn fk_error(chain: &LimbChain, root: RootTransform, pose: &ChainPose, target: Vec3) -> f32 {
    chain.fk(root, pose)[4].distance(target)
}

proptest! {
    #![proptest_config(ProptestConfig {
        // RIG_PROPTEST_CASES=4000 for a longer soak (one known root-motion case fails; see README).
        cases: std::env::var("RIG_PROPTEST_CASES").ok().and_then(|c| c.parse().ok()).unwrap_or(256),
        rng_seed: proptest::test_runner::RngSeed::Fixed(0x5107_4ee5),
        ..ProptestConfig::default()
    })]

    /// A target made by FK of a random within-limits pose is reached (cold start).
    #[test]
    fn reachable_targets_are_reached(limb in limb_strategy(), u in unit12(), root in root_strategy()) {
        let chain = rig().chain(limb);
        let target = chain.fk(root, &chain.sample_pose(&u))[4];
        let mut pose = ChainPose::NEUTRAL;
        let r = solve(chain, root, target, &mut pose, &CcdParams::default());
        let err = fk_error(chain, root, &pose, target);
        prop_assert!(err <= REACH_MM, "FK error {err} m, result {r:?}");
    }

    /// Whatever the target (reachable or not) and the warm start, limits hold.
    #[test]
    fn joint_limits_never_exceeded(
        limb in limb_strategy(),
        start in unit12(),
        target in prop::array::uniform3(-0.8f32..0.8),
    ) {
        let chain = rig().chain(limb);
        let mut pose = chain.sample_pose(&start);
        solve(chain, RootTransform::IDENTITY, Vec3::from(target), &mut pose, &CcdParams::default());
        let v = chain.limit_violation(&pose);
        prop_assert!(v <= 1e-4, "violation {v} rad, pose {pose:?}");
    }

    /// Solving never stretches or shrinks a bone.
    #[test]
    fn bone_lengths_are_preserved(
        limb in limb_strategy(),
        root in root_strategy(),
        target in prop::array::uniform3(-0.8f32..0.8),
    ) {
        let chain = rig().chain(limb);
        let mut pose = ChainPose::NEUTRAL;
        let target_ws = root.transform_point(Vec3::from(target).into()).into();
        solve(chain, root, target_ws, &mut pose, &CcdParams::default());
        let p = chain.fk(root, &pose);
        for i in 0..4 {
            let len = p[i].distance(p[i + 1]);
            prop_assert!((len - chain.lengths[i]).abs() <= 1e-5, "bone {i}: {len} vs {}", chain.lengths[i]);
        }
    }

    /// Moving/rotating the chain root together with the target changes nothing.
    #[test]
    fn invariant_under_root_motion(
        limb in limb_strategy(),
        u in unit12(),
        a in root_strategy(),
        b in root_strategy(),
    ) {
        let chain = rig().chain(limb);
        let target_local = chain.fk(RootTransform::IDENTITY, &chain.sample_pose(&u))[4];
        let params = CcdParams::default();
        let mut pose_a = ChainPose::NEUTRAL;
        let mut pose_b = ChainPose::NEUTRAL;
        let ta: Vec3 = a.transform_point(target_local.into()).into();
        let tb: Vec3 = b.transform_point(target_local.into()).into();
        solve(chain, a, ta, &mut pose_a, &params);
        solve(chain, b, tb, &mut pose_b, &params);
        prop_assert!(fk_error(chain, a, &pose_a, ta) <= REACH_MM);
        prop_assert!(fk_error(chain, b, &pose_b, tb) <= REACH_MM);
        let d = pose_a.max_joint_delta(&pose_b);
        prop_assert!(d <= 2e-2, "poses differ by {d} rad");
    }

    /// A target moving 1–6 mm per frame along a reachable path (FK of within-limits
    /// poses, end points anywhere in the full ranges) is tracked within 1 mm on *every*
    /// frame by warm starts, and no joint turns more than 0.15 rad per frame.
    #[test]
    fn warm_start_tracks_moving_target_smoothly(
        limb in limb_strategy(),
        ua in unit12(),
        ub in unit12(),
        step_mm in 1.0f32..6.0,
        root in root_strategy(),
    ) {
        let chain = rig().chain(limb);
        let path = target_path(chain, root, &ua, &ub, step_mm * 1e-3);
        let params = CcdParams::default();
        let mut pose = ChainPose::NEUTRAL;
        solve(chain, root, path[0], &mut pose, &params);
        prop_assert!(fk_error(chain, root, &pose, path[0]) <= REACH_MM);
        for (frame, &target) in path.iter().enumerate().skip(1) {
            let before = pose;
            let r = solve(chain, root, target, &mut pose, &params);
            let err = fk_error(chain, root, &pose, target);
            prop_assert!(err <= REACH_MM, "frame {frame}: FK error {err} m, {r:?}");
            let delta = before.max_joint_delta(&pose);
            prop_assert!(delta <= MAX_JOINT_DELTA_PER_FRAME, "frame {frame}: joint jump {delta} rad, {r:?}");
        }
    }

    /// `solve4` (the four limbs in SIMD lanes) gives exactly `solve`'s poses and
    /// results, lane by lane: cold and warm starts, reachable targets and anywhere nearby.
    #[test]
    fn solve4_is_bit_identical_to_solve(
        targets_u in prop::array::uniform4(unit12()),
        starts in prop::array::uniform4(unit12()),
        roots in prop::array::uniform4(root_strategy()),
        offsets in prop::array::uniform4(prop::array::uniform3(-0.3f32..0.3)),
        kind in 0u8..4,
    ) {
        // kind: 0 cold reachable, 1 cold anywhere nearby, 2 warm reachable, 3 warm anywhere.
        let chains = rig().chains();
        let refs = [&chains[0], &chains[1], &chains[2], &chains[3]];
        let targets: [Vec3; 4] = std::array::from_fn(|i| {
            let p = chains[i].fk(roots[i], &chains[i].sample_pose(&targets_u[i]))[4];
            if kind % 2 == 1 { p + Vec3::from(offsets[i]) } else { p }
        });
        let mut a: [ChainPose; 4] = std::array::from_fn(|i| {
            if kind >= 2 { chains[i].sample_pose(&starts[i]) } else { ChainPose::NEUTRAL }
        });
        let mut b = a;
        let params = CcdParams::default();
        let r4 = solve4(refs, roots, targets, &mut a, &params);
        let bits = |p: &ChainPose| p.0.map(|q| q.to_array().map(f32::to_bits));
        for i in 0..4 {
            let r = solve(&chains[i], roots[i], targets[i], &mut b[i], &params);
            prop_assert_eq!(bits(&a[i]), bits(&b[i]), "lane {} pose", i);
            prop_assert_eq!(r4[i].error.to_bits(), r.error.to_bits(), "lane {} error", i);
            prop_assert_eq!(
                (r4[i].reached, r4[i].iterations, r4[i].status),
                (r.reached, r.iterations, r.status)
            );
        }
    }

    /// NaN/inf targets are rejected and the pose is left as it was.
    #[test]
    fn non_finite_targets_are_rejected(
        limb in limb_strategy(),
        start in unit12(),
        bad in prop::sample::select(vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY]),
        axis in 0usize..3,
    ) {
        let chain = rig().chain(limb);
        let mut pose = chain.sample_pose(&start);
        let before = pose;
        let mut target = [0.1f32, 0.3, 0.1];
        target[axis] = bad;
        let r = solve(chain, RootTransform::IDENTITY, Vec3::from(target), &mut pose, &CcdParams::default());
        prop_assert_eq!(r.status, CcdStatus::InvalidTarget);
        prop_assert!(!r.reached);
        prop_assert!(pose.is_finite());
        prop_assert_eq!(pose, before);
    }
}

/// Largest rotation any joint may make in one frame when the target moves ≤ 6 mm.
const MAX_JOINT_DELTA_PER_FRAME: f32 = 0.15;

/// Effector path between two within-limits poses (interpolated in sample space, so it
/// stays reachable), resampled to steps of `step` metres.
fn target_path(
    chain: &LimbChain,
    root: RootTransform,
    ua: &[f32; 12],
    ub: &[f32; 12],
    step: f32,
) -> Vec<Vec3> {
    let at = |t: f32| {
        let u: [f32; 12] = std::array::from_fn(|i| ua[i] + (ub[i] - ua[i]) * t);
        chain.fk(root, &chain.sample_pose(&u))[4]
    };
    let mut path = vec![at(0.0)];
    let n = 4000;
    for k in 1..=n {
        let p = at(k as f32 / n as f32);
        if p.distance(*path.last().expect("non-empty")) >= step {
            path.push(p);
        }
        if path.len() >= 150 {
            break;
        }
    }
    path
}

/// An unreachable target: the limb stretches toward it within limits and then holds
/// still frame after frame (no jitter).
#[test]
fn unreachable_target_is_stable() {
    for limb in Limb::ALL {
        let chain = rig().chain(limb);
        for dir in [
            Vec3::Y,
            Vec3::new(0.3, 1.0, 0.5),
            Vec3::new(-1.0, 0.2, 0.0),
            Vec3::NEG_Y,
        ] {
            let target = dir.normalize() * 2.0 * chain.reach();
            let mut pose = ChainPose::NEUTRAL;
            let params = CcdParams::default();
            let mut last_err = f32::INFINITY;
            for frame in 0..30 {
                let before = pose;
                let r = solve(chain, RootTransform::IDENTITY, target, &mut pose, &params);
                assert!(!r.reached);
                let err = chain.fk(RootTransform::IDENTITY, &pose)[4].distance(target);
                assert!(chain.limit_violation(&pose) <= 1e-4);
                if frame > 0 {
                    // No jitter: the error never grows and the pose only creeps.
                    assert!(
                        err <= last_err + 1e-6,
                        "{limb} {dir}: error grew {last_err} -> {err}"
                    );
                    let delta = before.max_joint_delta(&pose);
                    assert!(
                        delta <= 5e-3,
                        "{limb} {dir}: frame {frame} moved {delta} rad"
                    );
                }
                last_err = err;
            }
        }
    }
}

/// Invalid parameters are refused without touching the pose.
#[test]
fn invalid_params_are_rejected() {
    let chain = rig().chain(Limb::LF);
    let mut pose = ChainPose::NEUTRAL;
    let params = CcdParams {
        tolerance: -1.0,
        ..CcdParams::default()
    };
    assert!(params.validate().is_err());
    let r = solve(
        chain,
        RootTransform::IDENTITY,
        Vec3::Y * 0.3,
        &mut pose,
        &params,
    );
    assert_eq!(r.status, CcdStatus::InvalidParams);
    assert_eq!(pose, ChainPose::NEUTRAL);
    assert!(CcdParams::default().validate().is_ok());
    assert!(CcdParams::precise().validate().is_ok());
}
