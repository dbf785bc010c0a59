//! Property tests of the FABRIK comparison solver: limits hold, bones keep their
//! lengths, bad input is refused, and without limits it reaches (checked by FK).

use glam::Vec3;
use proptest::prelude::*;
use slothsim_rig::{CcdStatus, ChainPose, FabrikParams, Limb, Rig, RootTransform, fabrik};

fn rig() -> &'static Rig {
    static RIG: std::sync::OnceLock<Rig> = std::sync::OnceLock::new();
    RIG.get_or_init(Rig::sloth)
}

fn limb_strategy() -> impl Strategy<Value = Limb> {
    prop::sample::select(Limb::ALL.to_vec())
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 128,
        rng_seed: proptest::test_runner::RngSeed::Fixed(0xfab1_2c00),
        ..ProptestConfig::default()
    })]

    /// With limits projected, no joint ever leaves its limit and no bone changes length.
    #[test]
    fn limits_and_bone_lengths_hold(
        limb in limb_strategy(),
        start in prop::array::uniform12(0.0f32..=1.0),
        target in prop::array::uniform3(-0.8f32..0.8),
    ) {
        let chain = rig().chain(limb);
        let mut pose = chain.sample_pose(&start);
        fabrik::solve(chain, RootTransform::IDENTITY, Vec3::from(target), &mut pose, &FabrikParams::default());
        let v = chain.limit_violation(&pose);
        prop_assert!(v <= 1e-4, "violation {v} rad");
        let p = chain.fk(RootTransform::IDENTITY, &pose);
        for i in 0..4 {
            let len = p[i].distance(p[i + 1]);
            prop_assert!((len - chain.lengths[i]).abs() <= 1e-5, "bone {i}: {len}");
        }
    }

    /// Plain FABRIK (no limits) reaches FK-made targets within 1 mm.
    #[test]
    fn unconstrained_reaches(limb in limb_strategy(), u in prop::array::uniform12(0.0f32..=1.0)) {
        let chain = rig().chain(limb);
        let target = chain.fk(RootTransform::IDENTITY, &chain.sample_pose(&u))[4];
        let mut pose = ChainPose::NEUTRAL;
        let params = FabrikParams { apply_limits: false, ..FabrikParams::default() };
        fabrik::solve(chain, RootTransform::IDENTITY, target, &mut pose, &params);
        let err = chain.fk(RootTransform::IDENTITY, &pose)[4].distance(target);
        prop_assert!(err <= 1e-3, "FK error {err} m");
    }
}

/// NaN targets and bad params are refused without touching the pose.
#[test]
fn bad_input_is_rejected() {
    let chain = rig().chain(Limb::RH);
    let mut pose = ChainPose::NEUTRAL;
    let r = fabrik::solve(
        chain,
        RootTransform::IDENTITY,
        Vec3::new(f32::NAN, 0.2, 0.0),
        &mut pose,
        &FabrikParams::default(),
    );
    assert_eq!(r.status, CcdStatus::InvalidTarget);
    let bad = FabrikParams {
        tolerance: 0.0,
        ..FabrikParams::default()
    };
    let r = fabrik::solve(
        chain,
        RootTransform::IDENTITY,
        Vec3::Y * 0.3,
        &mut pose,
        &bad,
    );
    assert_eq!(r.status, CcdStatus::InvalidParams);
    assert_eq!(pose, ChainPose::NEUTRAL);
}
