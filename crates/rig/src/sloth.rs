//! The default two-toed sloth rig, built in code. `assets/sloth.glb` is generated from
//! this (tools `gen-rig`) and a test asserts that loading the asset gives back exactly
//! this skeleton.
//!
//! Model space: metres, +Y up, body forward +Z, left = +X (glTF). The sloth hangs
//! *below* its branch, so the rest pose has every limb reaching up (+Y) from its
//! shoulder/hip, slightly outward and forward/back. The rest pose is the *neutral* pose
//! of the joint limits (limits are centred on it): the amplitudes are ranges swept
//! during contact, so it is the mid-stance pose, chosen so that at the default hang the
//! claw reaches a band along the support centred near the girdle and as long as the
//! amplitudes allow (see the crate README and `examples/reach_band.rs`).

use glam::{Quat, Vec3, Vec3A};

use crate::limb::Limb;
use crate::limits::JointLimit;
use crate::skeleton::{RestTransform, Skeleton};

/// One limb bone of the neutral pose: length (m) and pitch (degrees from +Y toward +Z).
#[derive(Clone, Copy, Debug)]
struct BoneDef {
    length: f32,
    pitch_deg: f32,
}

const fn bone(length: f32, pitch_deg: f32) -> BoneDef {
    BoneDef { length, pitch_deg }
}

/// Fore limb, girdle first: 0.06 + 0.14 + 0.13 + 0.07 = 0.40 m.
const FORE: [BoneDef; 4] = [
    bone(0.06, 10.0),
    bone(0.14, -35.0),
    bone(0.13, 30.0),
    bone(0.07, 45.0),
];
/// Hind limb, girdle first: 0.05 + 0.15 + 0.13 + 0.07 = 0.40 m.
const HIND: [BoneDef; 4] = [
    bone(0.05, 0.0),
    bone(0.15, 45.0),
    bone(0.13, -20.0),
    bone(0.07, -60.0),
];
/// Outward tilt of the limb plane (degrees).
const FORE_SPLAY_DEG: f32 = 15.0;
const HIND_SPLAY_DEG: f32 = 12.0;
/// Girdle joint position relative to its chain root (left side; right mirrors X).
const FORE_ROOT: Vec3 = Vec3::new(0.07, 0.05, 0.0);
const HIND_ROOT: Vec3 = Vec3::new(0.06, 0.04, 0.0);

/// Spine joints: (name, parent name, translation). Rump at z ≈ −0.32 m, nose (HeadTip)
/// at z = +0.51 m: body length ≈ 0.83 m.
const SPINE: [(&str, Option<&str>, Vec3); 6] = [
    ("Hips", None, Vec3::new(0.0, 0.0, -0.25)),
    ("Spine", Some("Hips"), Vec3::new(0.0, 0.01, 0.20)),
    ("Chest", Some("Spine"), Vec3::new(0.0, 0.01, 0.22)),
    ("Neck", Some("Chest"), Vec3::new(0.0, 0.0, 0.12)),
    ("Head", Some("Neck"), Vec3::new(0.0, -0.01, 0.10)),
    ("HeadTip", Some("Head"), Vec3::new(0.0, 0.0, 0.12)),
];

/// Node name of a limb element in the default rig, e.g. `LF_UpperArm`, `RH_FootTip`.
pub fn sloth_joint_name(limb: Limb, element: &str) -> String {
    format!("{}_{}", limb.name(), element)
}

/// Chain-root joint of a limb in the default rig.
pub const fn sloth_chain_root(limb: Limb) -> &'static str {
    if limb.is_fore() { "Chest" } else { "Hips" }
}

/// Splay rotation of a limb's plane (about +Z, outward).
fn splay(limb: Limb) -> Quat {
    let deg = if limb.is_fore() {
        FORE_SPLAY_DEG
    } else {
        HIND_SPLAY_DEG
    };
    let sign = if limb.is_left() { -1.0 } else { 1.0 };
    Quat::from_rotation_z(sign * deg.to_radians())
}

/// Neutral bone vectors (model space, = local space since rest rotations are identity)
/// from joint i to joint i+1 (index 3: to the effector).
fn limb_bones(limb: Limb) -> [Vec3; 4] {
    let defs = if limb.is_fore() { FORE } else { HIND };
    let s = splay(limb);
    defs.map(|b| {
        let p = b.pitch_deg.to_radians();
        s * Vec3::new(0.0, p.cos(), p.sin()) * b.length
    })
}

/// Joint limits of a limb from SPEC's amplitude table (see README "joint-limit
/// mapping"): girdle and shoulder/hip are swing–twist ball joints around the bone,
/// elbow/knee and wrist/ankle are hinges about the limb plane's normal; every range is
/// the full amplitude centred on the neutral pose.
pub fn sloth_limb_limits(limb: Limb) -> [JointLimit; 4] {
    let amp = limb.amplitudes_deg().map(f32::to_radians);
    let bones = limb_bones(limb);
    let hinge_axis = Vec3A::from(splay(limb) * Vec3::X);
    [
        JointLimit::ball_amplitude(Vec3A::from(bones[0].normalize()), amp[0]),
        JointLimit::ball_amplitude(Vec3A::from(bones[1].normalize()), amp[1]),
        JointLimit::hinge_amplitude(hinge_axis, amp[2]),
        JointLimit::hinge_amplitude(hinge_axis, amp[3]),
    ]
}

struct Builder {
    names: Vec<String>,
    parents: Vec<Option<u16>>,
    rest: Vec<RestTransform>,
    limits: Vec<Option<JointLimit>>,
}

impl Builder {
    fn push(&mut self, name: String, parent: Option<&str>, t: Vec3, limit: Option<JointLimit>) {
        let parent = parent.map(|p| {
            let i = self
                .names
                .iter()
                .position(|n| n == p)
                .expect("parent pushed first");
            u16::try_from(i).expect("small skeleton")
        });
        self.names.push(name);
        self.parents.push(parent);
        self.rest.push(RestTransform::from_translation(t));
        self.limits.push(limit);
    }

    fn push_limb(&mut self, limb: Limb) {
        let bones = limb_bones(limb);
        let lim = sloth_limb_limits(limb);
        let mut root = if limb.is_fore() { FORE_ROOT } else { HIND_ROOT };
        if !limb.is_left() {
            root.x = -root.x;
        }
        let elements = limb.element_names();
        let mut parent = sloth_chain_root(limb).to_string();
        for i in 0..4 {
            let t = if i == 0 { root } else { bones[i - 1] };
            let name = sloth_joint_name(limb, elements[i]);
            self.push(name.clone(), Some(&parent), t, Some(lim[i]));
            parent = name;
        }
        self.push(
            sloth_joint_name(limb, limb.tip_name()),
            Some(&parent),
            bones[3],
            None,
        );
    }
}

/// Build the default sloth skeleton (depth-first: Hips, LH, RH, Spine, Chest, LF, RF,
/// Neck, Head, HeadTip).
pub fn sloth_skeleton() -> Skeleton {
    let mut b = Builder {
        names: Vec::new(),
        parents: Vec::new(),
        rest: Vec::new(),
        limits: Vec::new(),
    };
    let spine = |b: &mut Builder, i: usize| {
        let (name, parent, t) = SPINE[i];
        b.push(name.into(), parent, t, None);
    };
    spine(&mut b, 0);
    b.push_limb(Limb::LH);
    b.push_limb(Limb::RH);
    spine(&mut b, 1);
    spine(&mut b, 2);
    b.push_limb(Limb::LF);
    b.push_limb(Limb::RF);
    for i in 3..SPINE.len() {
        spine(&mut b, i);
    }
    Skeleton::from_parts(b.names, b.parents, b.rest, b.limits).expect("default sloth rig is valid")
}
