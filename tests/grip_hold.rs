//! Grips must not slide (SPEC): where formula 7 places the body a little
//! off the stance the step checks approved (they sample a swing at a few arc
//! points only), the CCD stage moves the body by the planted limbs' residual
//! and solves again, so every planted claw stays on its grip.

mod common;

use glam::Vec3;
use slothsim::gait::LimbPhase;
use slothsim::gait::sloth::Sloth;
use slothsim::rig::{CcdParams, ChainPose, solve};
use slothsim::sim::Locomotion;

/// Largest planted claw ↔ target distance.
fn planted_error(s: &Sloth) -> f32 {
    s.limbs
        .iter()
        .filter(|l| l.phase != LimbPhase::Swinging)
        .map(|l| l.effector.distance(l.target))
        .fold(0.0, f32::max)
}

#[test]
fn a_body_placed_off_its_grips_is_moved_until_the_planted_claws_hold() {
    let (world, spawned) = common::pole_sloth();
    let w = world.resource::<Locomotion>().view();
    assert!(planted_error(&spawned) <= 0.0015);
    let mut tested = 0;
    for off in [
        Vec3::new(0.0, -0.10, 0.0),
        Vec3::new(0.0, -0.14, 0.0),
        Vec3::new(0.10, -0.06, 0.0),
        Vec3::new(-0.10, -0.06, 0.0),
        Vec3::new(0.0, -0.06, 0.12),
        Vec3::new(0.0, -0.06, -0.12),
    ] {
        let mut s = spawned;
        s.body_pos += off;
        // The premise: from that body some planted claw is out of reach
        // (the best of a warm and a cold solve, no body move).
        let short = (0..4).any(|i| {
            let root = w.rig.root_ws(i, s.body_pos, s.body_rot);
            let best = [s.limbs[i].pose, ChainPose::NEUTRAL]
                .into_iter()
                .map(|mut pose| {
                    let p = CcdParams {
                        max_iterations: 200,
                        ..*w.ccd
                    };
                    solve(&w.rig.chains[i], root, s.limbs[i].target, &mut pose, &p).error
                })
                .fold(f32::INFINITY, f32::min);
            best > 0.0015
        });
        if !short {
            continue;
        }
        tested += 1;
        s.solve_limbs(&w);
        let err = planted_error(&s);
        assert!(err <= 0.0015, "offset {off:?}: planted error {err} m");
        assert!(s.body_pos.is_finite() && s.body_pos.distance(spawned.body_pos) < off.length());
    }
    assert!(tested >= 3, "only {tested} offsets put a claw out of reach");
}
