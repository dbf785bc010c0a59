//! The simulation's snapshots as `slothsim-plot` input: `slothsim-sim` keeps
//! its own plain pose and trace types (it does not depend on the plots); the
//! CLI converts them here, field for field.

use slothsim_plot as plot;
use slothsim_sim::snapshot;

/// A sloth's pose.
pub fn sloth_pose(p: &snapshot::SlothPose) -> plot::SlothPose {
    plot::SlothPose {
        id: p.id,
        body_pos: p.body_pos,
        body_rot: p.body_rot,
        head_ws: p.head_ws,
        hips_ws: p.hips_ws,
        limbs: p.limbs.map(|l| plot::LimbPose {
            joints_ws: l.joints_ws,
            grip_ws: l.grip_ws,
            planted: l.planted,
        }),
    }
}

/// Poses, in the same order.
pub fn sloth_poses(poses: &[snapshot::SlothPose]) -> Vec<plot::SlothPose> {
    poses.iter().map(sloth_pose).collect()
}

/// Timed poses as side-view instants, in the same order.
pub fn side_instants(poses: &[snapshot::PoseAt]) -> Vec<plot::SideInstant> {
    poses
        .iter()
        .map(|p| plot::SideInstant {
            time_s: p.time_s,
            pose: sloth_pose(&p.pose),
        })
        .collect()
}

/// Step-search traces, in the same order.
pub fn trace_lines(traces: &[snapshot::TraceLine]) -> Vec<plot::TraceLine> {
    traces
        .iter()
        .map(|t| plot::TraceLine {
            from: t.from,
            to: t.to,
            hit: t.hit,
        })
        .collect()
}
