//! Plain input data shared by the plots (filled by the sim from its snapshots).

use glam::{Quat, Vec3};

/// Limb names in the order used by every per-limb array: left fore, right fore,
/// left hind, right hind.
pub const LIMB_NAMES: [&str; 4] = ["LF", "RF", "LH", "RH"];

/// One limb at one instant, world space (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimbPose {
    /// Joint positions along the chain: chain root (girdle), shoulder/hip, elbow/knee,
    /// wrist/ankle, claw tip (the effector). Four bones between five points.
    pub joints_ws: [Vec3; 5],
    /// The grip: where the claw holds (planted) or the target it swings toward.
    pub grip_ws: Vec3,
    /// `true` while the limb holds its grip (stance), `false` while it swings.
    pub planted: bool,
}

/// One sloth at one instant, world space (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlothPose {
    /// Entity/sloth id (used to pick the focus sloth in the top-down view).
    pub id: u32,
    /// Body origin.
    pub body_pos: Vec3,
    /// Body rotation: model +Z is forward (head), model +Y points toward the support
    /// (up while hanging below a branch), model +X is the sloth's left.
    pub body_rot: Quat,
    /// Head (tip of the spine).
    pub head_ws: Vec3,
    /// Hips (root of the spine).
    pub hips_ws: Vec3,
    /// Limbs in the order `LF, RF, LH, RH`.
    pub limbs: [LimbPose; 4],
}

impl SlothPose {
    /// Every point of the pose (for fitting views).
    pub fn points(&self) -> impl Iterator<Item = Vec3> + '_ {
        [self.body_pos, self.head_ws, self.hips_ws]
            .into_iter()
            .chain(self.limbs.iter().flat_map(|l| {
                l.joints_ws
                    .iter()
                    .copied()
                    .chain(std::iter::once(l.grip_ws))
            }))
    }
}

/// One line trace of a step search, world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceLine {
    /// Start of the ray.
    pub from: Vec3,
    /// Hit point if `hit`, else the end of the ray.
    pub to: Vec3,
    /// Whether the trace found a surface (drawn green) or not (red).
    pub hit: bool,
}
