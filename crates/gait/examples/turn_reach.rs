//! Can a sloth turn its body around on one branch by steps? A turn in place
//! passes through every heading between along the branch and back, so each
//! heading needs a stance: every limb's claw on the branch within the
//! joint limits. For body headings `yaw` (degrees from the branch's axis) and
//! hang depths below the axis, this searches grips on the whole surface
//! (every 2 cm along, every 30° around) for each limb from the default rig's
//! roots, CCD from the neutral pose and random within-limit poses, and
//! prints which limbs reach the branch at all.
//!
//! `cargo run --release -p slothsim-gait --example turn_reach -- [radius]`
//!
//! An upper bound on what a turn could use: the body may sit anywhere along
//! the branch and at any of the depths, not only where formula 7 puts it.
use glam::{Quat, Vec3};
use slothsim_gait::RigData;
use slothsim_rig::{CcdParams, ChainPose, Limb, Rig, solve};

fn rnd(state: &mut u64) -> f32 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 40) as f32 / (1u64 << 24) as f32
}

/// Whether limb `li` of a body at `pos`, `rot` gets its claw within 1.5 mm
/// of some point of a branch along world Z through the origin.
fn reaches(rig: &RigData, li: usize, pos: Vec3, rot: Quat, radius: f32, seed: &mut u64) -> bool {
    let params = CcdParams::default();
    let root = rig.root_ws(li, pos, rot);
    let chain = &rig.chains[li];
    for k in -30..=30 {
        let z = k as f32 * 0.02;
        for a in 0..12 {
            let phi = a as f32 * std::f32::consts::TAU / 12.0;
            let target = Vec3::new(radius * phi.cos(), radius * phi.sin(), z);
            if Vec3::from(root.position).distance(target) > chain.reach() + 1e-3 {
                continue;
            }
            for start in 0..4 {
                let mut pose = if start == 0 {
                    ChainPose::NEUTRAL
                } else {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(seed));
                    chain.sample_pose(&u)
                };
                if solve(chain, root, target, &mut pose, &params).error < 1.5e-3 {
                    return true;
                }
            }
        }
    }
    false
}

fn main() {
    let radius: f32 = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(0.02);
    let rig = RigData::new(&Rig::sloth());
    let mut seed = 7u64;
    println!(
        "branch radius {radius} m; limbs reaching the branch (LF RF LH RH) per depth below its axis"
    );
    let depths = [0.2f32, 0.25, 0.295, 0.34];
    print!("yaw°");
    for d in depths {
        print!("  depth {d:.3}");
    }
    println!();
    for yaw_deg in (0..=180).step_by(15) {
        let rot = Quat::from_rotation_y((yaw_deg as f32).to_radians());
        print!("{yaw_deg:4}");
        for depth in depths {
            let pos = Vec3::new(0.0, -depth, 0.0);
            let row: String = Limb::ALL
                .iter()
                .map(|l| {
                    if reaches(&rig, l.index(), pos, rot, radius, &mut seed) {
                        '+'
                    } else {
                        '.'
                    }
                })
                .collect();
            print!("  {row:>11}");
        }
        println!();
    }
}
