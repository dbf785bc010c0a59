//! Wander mode (the crowd's autorun) across supports of different kinds:
//! a wanderer walking along a branch into a trunk takes the trunk head up
//! and climbs it, judged like a scenario (slip, gap, reach, limits, contact,
//! penetration, head below hips on the trunk, NaN).

use slothsim::gait::{LimbPhase, LocomotionConfig, Profile, SpawnHint, Status};
use slothsim::observe::{Judge, Tolerances};
use slothsim::rig::Rig;
use slothsim::scene::{Preset, SupportId, TraceScene};
use slothsim::sim::{Locomotion, SlothState, TrunkVariant, build_schedule, new_world, spawn_sloth};

/// Runs one wanderer from the branch_trunk preset's start for `seconds`:
/// (first time all four limbs held the trunk, the judge's report, the final
/// direction of travel).
fn wander_into_trunk(
    angle: f32,
    seed: u64,
    seconds: f32,
) -> (Option<f32>, slothsim::observe::JudgeReport, f32) {
    wander(angle, TrunkVariant::Up, SupportId(0), seed, seconds)
}

/// A world with one wanderer (`seed`) spawned at `start` on `preset`'s
/// scene, free profile: (world, its entity, the time step).
fn spawn_wanderer(
    preset: &Preset,
    start: slothsim::scene::StartHint,
    seed: u64,
) -> (bevy_ecs::world::World, bevy_ecs::entity::Entity, f32) {
    let dt = 1.0 / 60.0;
    let loco = Locomotion::new(
        LocomotionConfig::profile(Profile::Free),
        &Rig::sloth(),
        TraceScene::new(preset.scene.clone()),
    )
    .unwrap();
    let mut world = new_world(loco, dt);
    let hint = SpawnHint {
        support: start.support,
        position: start.position,
        forward: start.forward,
        body_side: start.body_side,
    };
    let e = spawn_sloth(&mut world, 0, &hint, None);
    {
        let mut s = world.get_mut::<SlothState>(e).unwrap();
        s.0.wander = true;
        s.0.seed = seed;
    }
    (world, e, dt)
}

/// Runs one wanderer from the start of the branch_trunk preset run
/// `variant` for `seconds`: (first time all four limbs held `target`, the
/// judge's report, the final direction of travel).
fn wander(
    angle: f32,
    variant: TrunkVariant,
    target: SupportId,
    seed: u64,
    seconds: f32,
) -> (Option<f32>, slothsim::observe::JudgeReport, f32) {
    let preset = Preset::by_name("branch_trunk", Some(angle)).unwrap();
    let (st, _) = variant.start_goal(&preset);
    let (mut world, e, dt) = spawn_wanderer(&preset, st, seed);
    let mut schedule = build_schedule();
    let mut judge = Judge::new(Tolerances::default(), f32::INFINITY);
    let mut on_target_at = None;
    for _ in 0..(seconds / dt) as usize {
        schedule.run(&mut world);
        let s = world.get::<SlothState>(e).unwrap().0;
        let obs = s.observe(&world.resource::<Locomotion>().view());
        judge.observe(&obs);
        assert_eq!(
            s.status,
            Status::Moving,
            "the wanderer stopped at {}",
            s.time
        );
        if on_target_at.is_none()
            && s.limbs
                .iter()
                .all(|l| l.grip.support == target && l.phase == LimbPhase::Planted)
        {
            on_target_at = Some(s.time);
        }
    }
    let dir = world.get::<SlothState>(e).unwrap().0.dir;
    (on_target_at, judge.finish(), dir)
}

#[test]
fn a_wanderer_takes_a_trunk_from_a_branch_head_up_and_climbs_it() {
    let mut dirs = Vec::new();
    // (Steeper branches are slow to walk up: 130° takes about a minute.)
    for (angle, seed) in [(100.0, 1), (120.0, 2), (110.0, 3), (130.0, 4), (140.0, 5)] {
        let (at, j, dir) = wander_into_trunk(angle, seed, 120.0);
        assert!(
            at.is_some(),
            "{angle}°: never held the trunk with all four limbs"
        );
        assert!(
            j.max_grip_slip_m <= 0.005,
            "{angle}°: slip {}",
            j.max_grip_slip_m
        );
        assert!(
            j.max_surface_gap_m <= 0.01,
            "{angle}°: gap {}",
            j.max_surface_gap_m
        );
        assert!(
            j.max_reach_ratio <= 1.0,
            "{angle}°: reach {}",
            j.max_reach_ratio
        );
        assert_eq!(j.joint_limit_violations, 0, "{angle}°");
        assert!(j.min_limbs_in_contact >= 2, "{angle}°");
        assert!(
            j.max_penetration_m <= 0.01,
            "{angle}°: pen {}",
            j.max_penetration_m
        );
        assert_eq!(
            j.head_below_hips_on_trunk_frames, 0,
            "{angle}°: head below hips"
        );
        assert_eq!(j.nan_count, 0);
        dirs.push(dir);
    }
    // Up or down the trunk is the wanderer's own choice: both happen.
    assert!(dirs.contains(&1.0) && dirs.contains(&-1.0), "{dirs:?}");
}

#[test]
fn a_wanderer_climbing_a_trunk_may_leave_it_for_a_rising_branch() {
    // Climbing head up past a branch that rises from the trunk, a wanderer
    // takes it or climbs on, by its own choice: some of these seeds take it.
    let mut took = 0;
    for seed in 1..=6 {
        let (at, j, _) = wander(70.0, TrunkVariant::ToBranch, SupportId(1), seed, 90.0);
        took += usize::from(at.is_some());
        assert!(
            j.max_grip_slip_m <= 0.005,
            "seed {seed}: slip {}",
            j.max_grip_slip_m
        );
        assert!(
            j.max_surface_gap_m <= 0.01,
            "seed {seed}: gap {}",
            j.max_surface_gap_m
        );
        assert!(j.max_reach_ratio <= 1.0, "seed {seed}");
        assert_eq!(j.joint_limit_violations, 0, "seed {seed}");
        assert!(j.min_limbs_in_contact >= 2, "seed {seed}");
        assert!(
            j.max_penetration_m <= 0.01,
            "seed {seed}: pen {}",
            j.max_penetration_m
        );
        assert_eq!(j.head_below_hips_on_trunk_frames, 0, "seed {seed}");
        assert_eq!(j.nan_count, 0);
    }
    assert!((1..6).contains(&took), "{took} of 6 took the branch");
}

#[test]
fn a_stopped_wanderer_tries_again_after_a_wait() {
    // A wanderer that found no step after two turn-backs stops (`NoGrip`)
    // and tries again 5 s later: sloths that boxed it in may have moved on.
    let preset = Preset::by_name("pole", None).unwrap();
    let (mut world, e, dt) = spawn_wanderer(&preset, preset.start, 0);
    {
        let mut s = world.get_mut::<SlothState>(e).unwrap();
        s.0.status = Status::NoGrip;
        s.0.stalled_turns = 2;
        s.0.resume_at = Some(5.0);
    }
    let mut schedule = build_schedule();
    let mut resumed_at = None;
    let mut first_step_at = None;
    for _ in 0..(12.0 / dt) as usize {
        schedule.run(&mut world);
        let s = world.get::<SlothState>(e).unwrap().0;
        if s.time < 5.0 - 1e-3 {
            assert_eq!(
                s.status,
                Status::NoGrip,
                "moved while waiting at {}",
                s.time
            );
            assert!(s.limbs.iter().all(|l| l.phase == LimbPhase::Planted));
        }
        if resumed_at.is_none() && s.status == Status::Moving {
            resumed_at = Some(s.time);
            assert_eq!((s.stalled_turns, s.resume_at), (0, None));
        }
        if first_step_at.is_none() && s.limbs.iter().any(|l| l.phase == LimbPhase::Swinging) {
            first_step_at = Some(s.time);
        }
    }
    let resumed = resumed_at.expect("the wanderer never tried again");
    assert!((resumed - 5.0).abs() <= dt * 1.5, "resumed at {resumed}");
    let stepped = first_step_at.expect("no step after resuming");
    assert!(
        stepped >= resumed,
        "stepped at {stepped}, before resuming at {resumed}"
    );
}
