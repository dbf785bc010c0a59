//! What locomotion needs from the rig, precomputed once: the four chains, each
//! chain root's transform in model space, reach, the body's vertical offset and
//! the collision capsule of the torso.

use glam::{Affine3A, Quat, Vec3};
use slothsim_rig::{ChainPose, Limb, LimbChain, LimbChains4, Rig, RootTransform};

/// Radius of the torso's collision capsule (hips → chest), metres.
pub const BODY_RADIUS: f32 = 0.07;

/// Rig facts in model space (+Z forward, +Y toward the support, +X left).
#[derive(Clone, Debug)]
pub struct RigData {
    /// Limb chains by `Limb::index`.
    pub chains: [LimbChain; 4],
    /// The same four chains prepared for [`slothsim_rig::solve4_prepared`]
    /// (one SIMD lane a limb).
    pub chains4: LimbChains4,
    /// Chain root (the joint each chain hangs from) in model space.
    pub roots_ms: [RootTransform; 4],
    /// Limb reach (the shortest of the four), metres.
    pub reach: f32,
    /// Neutral claw-tip position of each limb in model space.
    pub neutral_tip_ms: [Vec3; 4],
    /// Head tip (nose) in model space.
    pub head_ms: Vec3,
    /// Hips joint in model space.
    pub hips_ms: Vec3,
    /// Torso capsule end points in model space (radius [`BODY_RADIUS`]).
    pub torso_ms: [Vec3; 2],
}

impl RigData {
    /// Extracts the data from a rig in its rest pose.
    pub fn new(rig: &Rig) -> Self {
        let sk = rig.skeleton();
        let locals = sk.rest_rotations();
        let mut model = vec![Affine3A::IDENTITY; sk.len()];
        sk.fk(&locals, &mut model);
        let chains = Limb::ALL.map(|l| *rig.chain(l));
        let roots_ms =
            Limb::ALL.map(|l| RootTransform::from_affine(&model[rig.limb_joints(l).chain_root]));
        let reach = chains
            .iter()
            .map(|c| c.reach())
            .fold(f32::INFINITY, f32::min);
        let neutral_tip_ms =
            Limb::ALL.map(|l| chains[l.index()].fk(roots_ms[l.index()], &ChainPose::NEUTRAL)[4]);
        let find = |name: &str, fallback: Vec3| {
            sk.find(name)
                .map_or(fallback, |i| model[i].translation.into())
        };
        let hips_ms = find("Hips", roots_ms[Limb::LH.index()].position.into());
        let head_ms = find("HeadTip", roots_ms[Limb::LF.index()].position.into());
        let chest = find("Chest", roots_ms[Limb::LF.index()].position.into());
        RigData {
            chains4: LimbChains4::new([&chains[0], &chains[1], &chains[2], &chains[3]]),
            chains,
            roots_ms,
            reach,
            neutral_tip_ms,
            head_ms,
            hips_ms,
            torso_ms: [hips_ms, chest],
        }
    }

    /// Default body offset below the mean of the paws: 80 % of the neutral
    /// paw height above the body origin (the limbs then hang comfortably bent).
    pub fn auto_body_offset(&self) -> f32 {
        let mean_y = self.neutral_tip_ms.iter().map(|p| p.y).sum::<f32>() / 4.0;
        0.8 * mean_y
    }

    /// World transform of a chain root for a body at `pos`, `rot`.
    #[inline]
    pub fn root_ws(&self, limb: usize, pos: Vec3, rot: Quat) -> RootTransform {
        RootTransform::new(pos, rot).mul(&self.roots_ms[limb])
    }
}
