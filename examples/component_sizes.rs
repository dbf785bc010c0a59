//! Bytes of a sloth's per-frame state: each component of the tick's sloth
//! query (`std::mem::size_of`), and the parts of `Sloth` (docs/performance.md,
//! the tenth round).
//!
//! `cargo run --release --example component_sizes`

use std::mem::{offset_of, size_of};

use slothsim::gait::{LimbState, LoadTrack, Sloth};
use slothsim::sim::world::CrowdPoints;
use slothsim::sim::{BodyAverageMemo, CcdMemo, GripLoad, NearStances, SlothId, SlothState, Traces};

fn main() {
    let rows: [(&str, usize); 6] = [
        ("SlothState", size_of::<SlothState>()),
        ("Traces", size_of::<Traces>()),
        ("BodyAverageMemo", size_of::<BodyAverageMemo>()),
        ("CcdMemo", size_of::<CcdMemo>()),
        ("GripLoad", size_of::<GripLoad>()),
        ("CrowdPoints", size_of::<CrowdPoints>()),
    ];
    let mut total = size_of::<SlothId>();
    println!("{:<24}{:>6}", "SlothId", size_of::<SlothId>());
    for (name, n) in rows {
        println!("{name:<24}{n:>6}");
        total += n;
    }
    println!("{:<24}{total:>6}", "a sloth's components");
    // Goal-mode sloths only (scenario runs): not in a wanderer's table.
    println!(
        "{:<24}{:>6}",
        "NearStances (goal mode)",
        size_of::<NearStances>()
    );
    println!();
    println!("{:<24}{:>6}", "Sloth", size_of::<Sloth>());
    println!("{:<24}{:>6}", "  LimbState (x4)", size_of::<LimbState>());
    println!("{:<24}{:>6}", "  LoadTrack", size_of::<LoadTrack>());
    println!();
    println!("LimbState fields: offset, size (bytes)");
    macro_rules! field {
        ($t:ty, $f:ident) => {{
            fn size<T, F>(_: fn(&T) -> &F) -> usize {
                size_of::<F>()
            }
            println!(
                "  {:<20}{:>6}{:>6}",
                stringify!($f),
                offset_of!($t, $f),
                size(|x: &$t| &x.$f)
            );
        }};
    }
    field!(LimbState, phase);
    field!(LimbState, grip);
    field!(LimbState, from);
    field!(LimbState, from_normal);
    field!(LimbState, from_support);
    field!(LimbState, swing_t);
    field!(LimbState, target);
    field!(LimbState, pose);
    field!(LimbState, root);
    field!(LimbState, effector);
    field!(LimbState, joints);
    field!(LimbState, search);
    field!(LimbState, due);
    field!(LimbState, settled_ls);
    field!(LimbState, cold_miss_ls);
    field!(LimbState, fallback);
    println!("Sloth fields: offset, size (bytes)");
    field!(Sloth, id);
    field!(Sloth, body_pos);
    field!(Sloth, body_rot);
    field!(Sloth, limbs);
    field!(Sloth, clock);
    field!(Sloth, dir);
    field!(Sloth, time);
    field!(Sloth, status);
    field!(Sloth, goal);
    field!(Sloth, goal_side);
    field!(Sloth, stuck_stances);
    field!(Sloth, seed);
    field!(Sloth, transfer);
    field!(Sloth, hang_side);
    field!(Sloth, hang_trunk);
    field!(Sloth, load);
    println!("LoadTrack fields: offset, size (bytes)");
    field!(LoadTrack, com);
    field!(LoadTrack, vel);
    field!(LoadTrack, acc);
    field!(LoadTrack, residual_bw);
    field!(LoadTrack, skipped);
    field!(LoadTrack, samples);
    field!(LoadTrack, active);
    field!(LoadTrack, solved_from);
    field!(LoadTrack, forces);
    field!(LoadTrack, residual_force);
    field!(LoadTrack, residual_torque);
    field!(LoadTrack, held_since);
    field!(LoadTrack, held_back_frames);
    field!(LoadTrack, failures);
    field!(LoadTrack, forced_releases);
    field!(LoadTrack, release_from);
    field!(Sloth, body_shift);
    field!(Sloth, backoff);
    field!(Sloth, turn);
    field!(Sloth, stall_from);
}
