//! The steady profile's swings overlap: a step may be checked with the limb
//! that lifts off next on the gait clock in the air by its landing, and it
//! then commits that limb's next step (`LimbState::fallback`). The committed
//! step is taken by its deadline whatever else happens — here the sloth stops
//! (no gait clock, no search) right after the commitment — and the grips
//! hold.

mod common;

use bevy_ecs::entity::Entity;
use bevy_ecs::world::World;
use slothsim::gait::sloth::Sloth;
use slothsim::gait::{Fallback, LimbPhase, Profile, Status};
use slothsim::sim::{SlothState, build_schedule};

/// Largest planted claw ↔ grip distance, and the limbs in contact.
fn planted(s: &Sloth) -> (f32, usize) {
    let held = s.limbs.iter().filter(|l| l.phase != LimbPhase::Swinging);
    let err = held
        .clone()
        .map(|l| l.effector.distance(l.grip.point))
        .fold(0.0, f32::max);
    (err, held.count())
}

/// Commitments looked at from this time on (the steady state).
const AFTER_S: f32 = 5.0;

/// Runs the pole with the steady profile until a step commits another
/// limb's step (from [`AFTER_S`] on); then stops the sloth. Returns the
/// committed limb and step, and per frame after it the sloth's state.
fn stop_after_a_commitment() -> (usize, Fallback, Vec<Sloth>) {
    let (mut world, e): (World, Entity) = common::pole_world(Profile::Steady);
    let mut schedule = build_schedule();
    for _ in 0..60 * 20 {
        schedule.run(&mut world);
        let s = &mut world.get_mut::<SlothState>(e).unwrap().0;
        let found = (0..4).find(|&k| s.limbs[k].fallback.is_some());
        let Some(lj) = found.filter(|_| s.time >= AFTER_S) else {
            continue;
        };
        let fb = s.limbs[lj].fallback.unwrap();
        s.status = Status::Arrived;
        let mut after = Vec::new();
        for _ in 0..60 * 2 {
            schedule.run(&mut world);
            after.push(world.get::<SlothState>(e).unwrap().0);
        }
        return (lj, fb, after);
    }
    panic!("no step was committed in 20 s of steady walking");
}

#[test]
fn a_committed_step_is_taken_by_its_deadline_and_the_grips_hold() {
    let (lj, fb, after) = stop_after_a_commitment();
    let lifted = after
        .iter()
        .find(|s| s.limbs[lj].phase == LimbPhase::Swinging)
        .expect("the committed limb lifts off");
    assert!(
        lifted.time <= fb.by_s + 1e-3,
        "{} > {}",
        lifted.time,
        fb.by_s
    );
    assert_eq!(lifted.limbs[lj].grip, fb.grip);
    let last = after.last().unwrap();
    assert!(last.limbs.iter().all(|l| l.phase == LimbPhase::Planted));
    assert_eq!(last.limbs[lj].grip, fb.grip);
    for s in &after {
        let (err, contact) = planted(s);
        assert!(
            err <= 0.005,
            "t {}: planted claw {err} m off its grip",
            s.time
        );
        assert!(contact >= 2, "t {}: {contact} limbs in contact", s.time);
    }
}
