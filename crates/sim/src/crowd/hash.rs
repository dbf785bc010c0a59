//! Hashes as determinism checks: of the crowd's state (every body, grip and
//! joint rotation as bits, in sloth-id order: equal for any thread count) and
//! of a scene's supports (a checkpoint's forest file is checked against it).
//! FNV-1a over the values' bits.

use slothsim_gait::Sloth;
use slothsim_scene::{Scene, SupportKind};

use super::Crowd;

/// FNV-1a, 64 bit.
#[derive(Clone, Copy)]
pub(super) struct Fnv(pub(super) u64);

impl Fnv {
    pub(super) fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }
    pub(super) fn bytes(&mut self, b: &[u8]) {
        for &x in b {
            self.0 ^= x as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    fn f32s(&mut self, v: &[f32]) {
        for x in v {
            self.bytes(&x.to_bits().to_le_bytes());
        }
    }
}

/// Hash of a scene's supports (kinds, nodes and radii as bits).
pub fn scene_hash(scene: &Scene) -> u64 {
    let mut h = Fnv::new();
    for s in scene.supports() {
        h.bytes(&[matches!(s.kind, SupportKind::Trunk) as u8]);
        for n in &s.nodes {
            h.f32s(&n.to_array());
        }
        h.f32s(&s.radii);
    }
    h.0
}

/// [`Crowd::state_hash`] of `sloths` (given in id order).
pub fn state_hash_of(sloths: &[Sloth]) -> u64 {
    let mut h = Fnv::new();
    for s in sloths {
        h.bytes(&s.id.to_le_bytes());
        h.f32s(&s.body_pos.to_array());
        h.f32s(&s.body_rot.to_array());
        for l in &s.limbs {
            h.f32s(&l.grip.point.to_array());
            for q in l.pose.0 {
                h.f32s(&q.to_array());
            }
        }
    }
    h.0
}

impl Crowd {
    /// Hash of the state in sloth-id order: body positions and rotations,
    /// grips and every joint rotation, as bits. Equal across thread counts.
    pub fn state_hash(&mut self) -> u64 {
        state_hash_of(&self.sloths())
    }
}
