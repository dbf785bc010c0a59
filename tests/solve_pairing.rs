//! CcdSolve solves the sloths of a batch two by two in eight SIMD lanes and
//! skips the ones whose solve would change nothing (`Sloth::solve_limbs_batch`);
//! BodyAverage skips the sloths whose update would change nothing
//! (`Sloth::body_average_memo`). Each sloth must end exactly as the plain
//! `Sloth::solve_limbs` / `Sloth::body_average` leave it, bit for bit: pairing
//! and skipping are speed, never behaviour.

mod common;

use glam::Vec3;
use slothsim::gait::sloth::Sloth;
use slothsim::gait::{BodyMemo, LimbPhase, SolveMemo};
use slothsim::sim::Locomotion;

/// The bits of what a solve writes.
fn bits(s: &Sloth) -> Vec<u32> {
    let mut v: Vec<f32> = s.body_pos.to_array().to_vec();
    for l in &s.limbs {
        v.extend(l.pose.0.iter().flat_map(|q| q.to_array()));
        v.extend(l.effector.to_array());
        v.extend(l.joints.iter().flatten().flat_map(|j| j.to_array()));
        v.extend(l.root.to_array());
        for t in [l.settled_ls, l.cold_miss_ls] {
            v.extend(t.map_or([f32::NAN; 3], |t| t.to_array()));
        }
    }
    v.into_iter().map(f32::to_bits).collect()
}

#[test]
fn paired_and_skipped_solves_match_single_solves_bit_for_bit() {
    let (world, spawned) = common::pole_sloth();
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

#[test]
fn skipped_body_updates_match_plain_updates_bit_for_bit() {
    let (world, spawned) = common::pole_sloth();
    let w = world.resource::<Locomotion>().view();
    let dt = 1.0 / 60.0;
    // Bodies turned and moved off their grips' average (the update eases the
    // rotation back over several frames), some left as spawned.
    let mut memo_sloths: Vec<Sloth> = (0..12)
        .map(|k| {
            let mut s = spawned;
            let a = k as f32 * 0.07;
            s.body_rot = glam::Quat::from_rotation_y(a) * s.body_rot;
            s.body_pos += Vec3::new(a, -a, 0.5 * a) * 0.1;
            s
        })
        .collect();
    let mut plain = memo_sloths.clone();
    let mut memos = vec![BodyMemo::default(); memo_sloths.len()];
    let body_bits = |s: &Sloth| {
        let mut v = s.body_pos.to_array().to_vec();
        v.extend(s.body_rot.to_array());
        v.extend(s.limbs.iter().flat_map(|l| l.target.to_array()));
        v.into_iter().map(f32::to_bits).collect::<Vec<_>>()
    };
    for frame in 0..240 {
        for (k, (a, b)) in memo_sloths.iter_mut().zip(&mut plain).enumerate() {
            a.body_average_memo(&w, dt, &mut memos[k]);
            b.body_average(&w, dt);
            assert_eq!(body_bits(a), body_bits(b), "frame {frame}, sloth {k}");
            // Now and then a grip moves (a step landed).
            if (frame + k) % 97 == 0 {
                a.limbs[k % 4].grip.point.x += 0.01;
                b.limbs[k % 4].grip.point.x += 0.01;
            }
        }
    }
}
