//! How often the GripLoad stage solves: a crowd solves each sloth every
//! `crowd_load_every`-th frame (default `CROWD_LOAD_EVERY` = 1: every frame), sloths
//! staggered by id so every frame solves the same share of them; a lone (scenario)
//! sloth is solved every frame.

use slothsim_gait::LocomotionConfig;
use slothsim_rig::Rig;
use slothsim_scene::{ForestConfig, generate_forest};
use slothsim_sim::{CROWD_LOAD_EVERY, Crowd, CrowdSpec, ForestSource, GripLoad, Locomotion};

/// 40 sloths with default locomotion on a small six-tree forest.
fn small_crowd(seed: u64) -> Crowd {
    small_crowd_with(seed, LocomotionConfig::default())
}

/// 40 sloths with locomotion `cfg` on a small six-tree forest.
fn small_crowd_with(seed: u64, cfg: LocomotionConfig) -> Crowd {
    let forest = ForestConfig {
        trees: 6,
        area_m: 25.0,
        ..ForestConfig::default()
    };
    let spec = CrowdSpec {
        sloths: 40,
        seed,
        dt: 1.0 / 60.0,
        cfg,
        clearance_m: 0.3,
    };
    let scene = generate_forest(&forest).unwrap();
    Crowd::new(spec, &Rig::sloth(), scene, ForestSource::Procedural(forest)).unwrap()
}

/// The solved sloths of each of `frames` ticks (after 10 untimed ones): every
/// frame `40 / every` of them, one id class mod `every`, each sloth `frames / every`
/// times; then every sloth holds finite loads carried by ≥ 2 grips.
fn assert_solves_every(mut crowd: Crowd, every: usize) {
    for _ in 0..10 {
        crowd.tick();
    }
    let frames = 4 * every.max(2);
    let mut solved = vec![0usize; 40];
    for _ in 0..frames {
        crowd.tick();
        let sloths = crowd.sloths();
        // `skipped == 0`: solved in this frame.
        let now: Vec<u32> = sloths
            .iter()
            .filter(|s| s.load.skipped == 0)
            .map(|s| s.id)
            .collect();
        assert_eq!(now.len(), 40 / every, "{now:?}");
        let phase = now[0] as usize % every;
        assert!(
            now.iter().all(|&id| id as usize % every == phase),
            "{now:?}"
        );
        for id in now {
            solved[id as usize] += 1;
        }
    }
    assert!(solved.iter().all(|&n| n == frames / every), "{solved:?}");
    // Every sloth holds loads (solved, finite, ≥ 2 grips carry it).
    let world = crowd.world();
    for id in 0..40 {
        let e = crowd.entity(id).unwrap();
        let g = world.get::<GripLoad>(e).unwrap().0;
        assert!(g.ok, "sloth {id}");
        assert!(g.force.iter().all(|f| f.is_finite()) && g.residual_bw.is_finite());
        assert!(
            g.force.iter().filter(|f| f.length() > 0.0).count() >= 2,
            "{g:?}"
        );
    }
}

#[test]
fn a_default_crowd_solves_every_sloth_every_frame() {
    assert_eq!(CROWD_LOAD_EVERY, 1);
    assert_eq!(LocomotionConfig::default().crowd_load_every, 1);
    assert_solves_every(small_crowd(7), 1);
}

#[test]
fn a_crowd_at_every_fourth_frame_solves_each_sloth_staggered_by_id() {
    let cfg = LocomotionConfig {
        crowd_load_every: 4,
        ..LocomotionConfig::default()
    };
    assert_solves_every(small_crowd_with(7, cfg), 4);
}

/// The GripLoad stage's centre of mass comes from the joints CcdSolve wrote
/// (`LimbState::joints`): between CcdSolve and the next BodyAverage it must be
/// exactly the forward kinematics of the poses, for every sloth of a moving
/// crowd (paired, single and skipped solves alike).
#[test]
fn centre_of_mass_from_solved_joints_is_forward_kinematics_bit_for_bit() {
    let mut crowd = small_crowd(11);
    let mut checked = 0;
    for _ in 0..240 {
        crowd.tick();
        let sloths = crowd.sloths();
        let world = crowd.world();
        let w = world.resource::<Locomotion>().view();
        for s in &sloths {
            assert!(s.limbs.iter().all(|l| l.joints.is_some()), "sloth {}", s.id);
            let cached = s.centre_of_mass(&w).to_array().map(f32::to_bits);
            let fk = s.centre_of_mass_fk(&w).to_array().map(f32::to_bits);
            assert_eq!(cached, fk, "sloth {}", s.id);
            checked += 1;
        }
    }
    assert_eq!(checked, 240 * 40);
}
