//! A skeleton plus the four limb chains found in it through a [`RigMap`], and glTF
//! import (the `gltf` crate).
//!
//! Joint limits are read from node `extras`:
//! `{"slothsim": {"limit": {"kind": "hinge", "axis": [1,0,0], "min": -0.4, "max": 0.4}}}`
//! or `{"kind": "ball", "twist_axis": [..], "swing_max": .., "twist_min": .., "twist_max": ..}`
//! (radians, joint rest frame, rest-relative). Limb joints without extras get SPEC
//! defaults: ball joints about the bone for girdle and shoulder/hip, hinges about the
//! joint's local +X for elbow/knee and wrist/ankle (see [`default_limit`]).

use std::path::Path;

use glam::{Quat, Vec3, Vec3A};
use serde::{Deserialize, Serialize};

use crate::chain::{CHAIN_JOINTS, LimbChain};
use crate::error::RigError;
use crate::limb::Limb;
use crate::limits::JointLimit;
use crate::skeleton::{RestTransform, Skeleton};
use crate::sloth::{sloth_joint_name, sloth_skeleton};

/// Node names of one limb's chain in a rig file.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LimbNames {
    /// Girdle, proximal, distal, hand/foot joint names.
    pub joints: [String; CHAIN_JOINTS],
    /// Effector node (tip of hand/foot), a child of `joints[3]`. When absent the
    /// effector is placed half a bone length beyond `joints[3]` along the previous bone.
    pub tip: Option<String>,
}

/// Joint role → node name, so rigs with other naming can be used. Indexed by
/// [`Limb::index`].
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct RigMap {
    /// One entry per limb in [`Limb::ALL`] order.
    pub limbs: [LimbNames; 4],
}

impl RigMap {
    /// Names used by `assets/sloth.glb` (`LF_Shoulder`, `LF_UpperArm`, …, `LF_HandTip`).
    pub fn sloth() -> Self {
        Self {
            limbs: Limb::ALL.map(|limb| LimbNames {
                joints: limb.element_names().map(|e| sloth_joint_name(limb, e)),
                tip: Some(sloth_joint_name(limb, limb.tip_name())),
            }),
        }
    }

    /// Names of one limb.
    pub fn limb(&self, limb: Limb) -> &LimbNames {
        &self.limbs[limb.index()]
    }
}

impl Default for RigMap {
    fn default() -> Self {
        Self::sloth()
    }
}

/// Skeleton indices of one limb.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LimbJoints {
    /// The joint the chain hangs from (parent of the girdle joint).
    pub chain_root: usize,
    /// The 4 chain joints, girdle first.
    pub joints: [usize; CHAIN_JOINTS],
    /// Effector node, if the rig has one.
    pub tip: Option<usize>,
}

/// A skeleton with its four limb chains.
#[derive(Clone, Debug, PartialEq)]
pub struct Rig {
    skeleton: Skeleton,
    joints: [LimbJoints; 4],
    chains: [LimbChain; 4],
}

/// SPEC default limit for chain element `element` (0 = girdle) of `limb`, whose bone
/// (toward the next joint or effector) is `bone_ls` in the joint's rest frame.
pub fn default_limit(limb: Limb, element: usize, bone_ls: Vec3A) -> JointLimit {
    let amp = limb.amplitudes_deg()[element].to_radians();
    if element < 2 {
        JointLimit::ball_amplitude(bone_ls.try_normalize().unwrap_or(Vec3A::Y), amp)
    } else {
        JointLimit::hinge_amplitude(Vec3A::X, amp)
    }
}

impl Rig {
    /// The default sloth rig, built in code (no files needed). Equal to loading
    /// `assets/sloth.glb` with [`RigMap::sloth`] (tested).
    pub fn sloth() -> Rig {
        Rig::new(sloth_skeleton(), &RigMap::sloth()).expect("default rig is valid")
    }

    /// Find the limb chains of `skeleton` through `map`.
    pub fn new(skeleton: Skeleton, map: &RigMap) -> Result<Rig, RigError> {
        let mut joints = [LimbJoints {
            chain_root: 0,
            joints: [0; 4],
            tip: None,
        }; 4];
        for limb in Limb::ALL {
            joints[limb.index()] = find_limb(&skeleton, map, limb)?;
        }
        let chains = Limb::ALL.map(|limb| build_chain(&skeleton, limb, &joints[limb.index()]));
        Ok(Rig {
            skeleton,
            joints,
            chains,
        })
    }

    /// Load a `.glb`/`.gltf` file (with embedded or no buffers).
    pub fn load(path: impl AsRef<Path>, map: &RigMap) -> Result<Rig, RigError> {
        let path = path.as_ref();
        let bytes = std::fs::read(path).map_err(|source| RigError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Rig::from_gltf_slice(&bytes, map)
    }

    /// Parse glTF JSON or GLB bytes.
    pub fn from_gltf_slice(bytes: &[u8], map: &RigMap) -> Result<Rig, RigError> {
        let skeleton = skeleton_from_gltf(bytes)?;
        Rig::new(skeleton, map)
    }

    /// The skeleton.
    pub fn skeleton(&self) -> &Skeleton {
        &self.skeleton
    }

    /// The self-contained chain of a limb.
    pub fn chain(&self, limb: Limb) -> &LimbChain {
        &self.chains[limb.index()]
    }

    /// All four chains in [`Limb::ALL`] order.
    pub fn chains(&self) -> &[LimbChain; 4] {
        &self.chains
    }

    /// Skeleton indices of a limb's joints.
    pub fn limb_joints(&self, limb: Limb) -> &LimbJoints {
        &self.joints[limb.index()]
    }

    /// Write a limb's solved pose into a skeleton `locals` buffer (see [`Skeleton::fk`]).
    pub fn write_pose(&self, limb: Limb, pose: &crate::ChainPose, locals: &mut [Quat]) {
        let chain = self.chain(limb);
        for (i, &j) in self.joints[limb.index()].joints.iter().enumerate() {
            locals[j] = chain.local_rotation(pose, i);
        }
    }
}

fn find_limb(skeleton: &Skeleton, map: &RigMap, limb: Limb) -> Result<LimbJoints, RigError> {
    let names = map.limb(limb);
    let elements = limb.element_names();
    let role = |i: usize| format!("{}.{}", limb.name(), elements[i]);
    let mut joints = [0usize; CHAIN_JOINTS];
    for i in 0..CHAIN_JOINTS {
        let name = &names.joints[i];
        let j = skeleton.find(name).ok_or_else(|| RigError::MissingJoint {
            role: role(i),
            name: name.clone(),
        })?;
        if i > 0 && skeleton.parent(j) != Some(joints[i - 1]) {
            return Err(RigError::NotAChain {
                joint: name.clone(),
                role: role(i),
                expected_parent: names.joints[i - 1].clone(),
            });
        }
        joints[i] = j;
    }
    let chain_root = skeleton
        .parent(joints[0])
        .ok_or_else(|| RigError::NoChainRoot {
            joint: names.joints[0].clone(),
        })?;
    let tip = match &names.tip {
        None => None,
        Some(name) => {
            let t = skeleton.find(name).ok_or_else(|| RigError::MissingJoint {
                role: format!("{}.{}", limb.name(), limb.tip_name()),
                name: name.clone(),
            })?;
            if skeleton.parent(t) != Some(joints[3]) {
                return Err(RigError::NotAChain {
                    joint: name.clone(),
                    role: format!("{}.{}", limb.name(), limb.tip_name()),
                    expected_parent: names.joints[3].clone(),
                });
            }
            Some(t)
        }
    };
    Ok(LimbJoints {
        chain_root,
        joints,
        tip,
    })
}

fn build_chain(skeleton: &Skeleton, limb: Limb, lj: &LimbJoints) -> LimbChain {
    let rest = skeleton.rest();
    let offsets = lj.joints.map(|j| Vec3A::from(rest[j].translation));
    let rots = lj.joints.map(|j| rest[j].rotation);
    let effector = match lj.tip {
        Some(t) => Vec3A::from(rest[t].translation),
        // Half the previous bone, continued straight, expressed in joint 3's frame.
        None => rots[3].inverse() * offsets[3] * 0.5,
    };
    let bones_ls: [Vec3A; CHAIN_JOINTS] = std::array::from_fn(|i| {
        if i + 1 < CHAIN_JOINTS {
            offsets[i + 1]
        } else {
            effector
        }
    });
    let limits = std::array::from_fn(|i| {
        skeleton.limits()[lj.joints[i]].unwrap_or_else(|| default_limit(limb, i, bones_ls[i]))
    });
    LimbChain::new(limb, offsets, rots, effector, limits)
}

/// `extras` content on a node.
#[derive(Debug, Default, Serialize, Deserialize)]
pub struct NodeExtras {
    /// Our namespace.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub slothsim: Option<SlothExtras>,
}

/// `extras.slothsim` on a node.
#[derive(Debug, Default, Serialize, Deserialize)]
pub struct SlothExtras {
    /// Joint limit on the rest-relative rotation.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limit: Option<JointLimit>,
}

/// Read the node hierarchy of a glTF/GLB as a depth-first [`Skeleton`].
///
/// Every node of the file is a joint except leaf nodes carrying a mesh. Parents come
/// from `children` lists; a node listed twice is an error, as is a cycle. Roots are
/// visited in node order, children in listed order. Node scale is ignored.
pub fn skeleton_from_gltf(bytes: &[u8]) -> Result<Skeleton, RigError> {
    let gltf = gltf::Gltf::from_slice(bytes)?;
    let doc = &gltf.document;
    let nodes: Vec<gltf::Node<'_>> = doc.nodes().collect();
    let name_of = |i: usize| {
        nodes[i]
            .name()
            .map_or_else(|| format!("node{i}"), ToString::to_string)
    };
    let n = nodes.len();
    let mut parent: Vec<Option<usize>> = vec![None; n];
    for node in &nodes {
        for child in node.children() {
            let c = child.index();
            if parent[c].is_some() {
                return Err(RigError::MultipleParents { joint: name_of(c) });
            }
            parent[c] = Some(node.index());
        }
    }
    let is_joint = |i: usize| !(nodes[i].mesh().is_some() && nodes[i].children().len() == 0);
    // Depth-first order.
    let mut order: Vec<usize> = Vec::with_capacity(n);
    let mut new_index: Vec<Option<usize>> = vec![None; n];
    let mut visited = vec![false; n];
    let mut stack: Vec<usize> = Vec::new();
    for root in (0..n).filter(|&i| parent[i].is_none()) {
        stack.push(root);
        while let Some(i) = stack.pop() {
            visited[i] = true;
            if is_joint(i) {
                new_index[i] = Some(order.len());
                order.push(i);
            }
            let children: Vec<usize> = nodes[i].children().map(|c| c.index()).collect();
            stack.extend(children.into_iter().rev());
        }
    }
    if let Some(i) = (0..n).find(|&i| !visited[i]) {
        return Err(RigError::Cycle { joint: name_of(i) });
    }
    if order.is_empty() {
        return Err(RigError::Empty);
    }
    let mut names = Vec::with_capacity(order.len());
    let mut parents = Vec::with_capacity(order.len());
    let mut rest = Vec::with_capacity(order.len());
    let mut limits = Vec::with_capacity(order.len());
    for &i in &order {
        let name = name_of(i);
        let (t, r, _s) = nodes[i].transform().decomposed();
        let p = parent[i].and_then(|p| new_index[p]);
        parents.push(p.map(|p| u16::try_from(p).unwrap_or(u16::MAX)));
        rest.push(RestTransform {
            translation: Vec3::from(t),
            rotation: Quat::from_array(r),
        });
        let limit = match nodes[i].extras() {
            None => None,
            Some(raw) => {
                let extras: NodeExtras =
                    serde_json::from_str(raw.get()).map_err(|e| RigError::BadExtras {
                        joint: name.clone(),
                        message: e.to_string(),
                    })?;
                extras.slothsim.and_then(|s| s.limit)
            }
        };
        limits.push(limit);
        names.push(name);
    }
    if order.len() > usize::from(u16::MAX) {
        return Err(RigError::TooManyJoints(order.len()));
    }
    Skeleton::from_parts(names, parents, rest, limits)
}
