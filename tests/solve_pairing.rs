//! CcdSolve solves the sloths of a batch two by two in eight SIMD lanes and
//! skips the ones whose solve would change nothing (`Sloth::solve_limbs_batch`).
//! Each sloth must end exactly as its own `Sloth::solve_limbs` leaves it, bit
//! for bit: pairing and skipping are speed, never behaviour.

use glam::Vec3;
use slothsim::gait::sloth::Sloth;
use slothsim::gait::{LimbPhase, LocomotionConfig, Profile, SolveMemo, SpawnHint};
use slothsim::rig::Rig;
use slothsim::scene::{Preset, TraceScene};
use slothsim::sim::{Locomotion, SlothState, new_world, spawn_sloth};

/// The bits of what a solve writes.
fn bits(s: &Sloth) -> Vec<u32> {
    let mut v: Vec<f32> = s.body_pos.to_array().to_vec();
    for l in &s.limbs {
        v.extend(l.pose.0.iter().flat_map(|q| q.to_array()));
        v.extend(l.effector.to_array());
        v.extend(l.root.to_array());
        for t in [l.settled_ls, l.cold_miss_ls] {
            v.extend(t.map_or([f32::NAN; 3], |t| t.to_array()));
        }
    }
    v.into_iter().map(f32::to_bits).collect()
}

#[test]
fn paired_and_skipped_solves_match_single_solves_bit_for_bit() {
    let preset = Preset::by_name("pole", None).unwrap();
    let loco = Locomotion::new(
        LocomotionConfig::profile(Profile::Free),
        &Rig::sloth(),
        TraceScene::new(preset.scene.clone()),
    )
    .unwrap();
    let mut world = new_world(loco, 1.0 / 60.0);
    let hint = SpawnHint {
        support: preset.start.support,
        position: preset.start.position,
        forward: preset.start.forward,
        body_side: preset.start.body_side,
    };
    let e = spawn_sloth(&mut world, 0, &hint, None);
    let spawned = world.get::<SlothState>(e).unwrap().0;
    let w = world.resource::<Locomotion>().view();
    // Sloths whose bodies sit off their grips by up to 8 cm (some claws out
    // of reach: resumed and cold solves, the body pulled back), one limb
    // swinging in some; a few left exactly as spawned (nothing to solve).
    let mut seed = 0x5eed_u64;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5
    };
    let mut sloths: Vec<Sloth> = (0..61)
        .map(|k| {
            let mut s = spawned;
            if k % 7 != 0 {
                s.body_pos += Vec3::new(rnd(), rnd(), rnd()) * 0.16;
            }
            if k % 3 == 1 {
                s.limbs[k % 4].phase = LimbPhase::Swinging;
                s.limbs[k % 4].target += Vec3::new(rnd(), rnd(), rnd()) * 0.1;
            }
            s
        })
        .collect();
    let mut singles = sloths.clone();
    let mut memos = vec![SolveMemo::default(); sloths.len()];
    // Three rounds: the second and third skip the sloths the first left
    // unchanged; between them half the sloths move a little.
    for round in 0..3 {
        let batch_sweeps = Sloth::solve_limbs_batch(&mut sloths, &mut memos, &w);
        let single_sweeps: u64 = singles
            .iter_mut()
            .map(|s| u64::from(s.solve_limbs(&w)))
            .sum();
        assert_eq!(batch_sweeps, single_sweeps, "round {round}: sweeps");
        for (k, (a, b)) in sloths.iter().zip(&singles).enumerate() {
            assert_eq!(bits(a), bits(b), "round {round}, sloth {k}");
        }
        for (k, (a, b)) in sloths.iter_mut().zip(&mut singles).enumerate() {
            if k % 2 == round % 2 {
                let d = Vec3::new(rnd(), rnd(), rnd()) * 0.01;
                a.body_pos += d;
                b.body_pos += d;
            }
        }
    }
}
