//! The skinned sloth mesh (bind-pose positions, joints, weights, triangles) read from
//! `assets/sloth.glb`, and the limb-tube layout written by `tools/src/rig_asset.rs`.

use glam::{Affine3A, Vec3};
use slothsim_rig::{Limb, Rig, RigMap};

use crate::SkinError;

/// Vertices around a limb ring (`rig_asset::LIMB_SIDES`).
pub const LIMB_SIDES: usize = 16;
/// Rings per limb bone (`rig_asset::LIMB_RINGS_PER_BONE`).
pub const LIMB_RINGS_PER_BONE: usize = 8;
/// Rings along a limb tube: 4 bones and the claw-tip ring.
pub const LIMB_RINGS: usize = 4 * LIMB_RINGS_PER_BONE + 1;
/// Vertices of the body loft (22 rings of 24 and two poles).
pub const BODY_VERTICES: usize = 22 * 24 + 2;
/// Vertices of one limb tube (rings and two cap poles).
pub const LIMB_VERTICES: usize = LIMB_RINGS * LIMB_SIDES + 2;

/// A skinned triangle mesh in its bind pose plus the rig it is bound to.
#[derive(Clone, Debug)]
pub struct SkinMesh {
    /// The skeleton and its limb chains.
    pub rig: Rig,
    /// Bind-pose model-space joint transforms B_i (seed formula 1).
    pub bind: Vec<Affine3A>,
    /// Inverse bind transforms B_i⁻¹.
    pub inv_bind: Vec<Affine3A>,
    /// Bind-pose vertex positions v0 (m).
    pub positions: Vec<Vec3>,
    /// Up to four joint indices per vertex.
    pub joints: Vec<[u16; 4]>,
    /// Their weights (sum 1).
    pub weights: Vec<[f32; 4]>,
    /// Triangle list.
    pub indices: Vec<u32>,
}

impl SkinMesh {
    /// The default sloth asset, embedded at compile time.
    pub fn sloth() -> Result<SkinMesh, SkinError> {
        SkinMesh::from_glb(include_bytes!("../../../assets/sloth.glb"))
    }

    /// Read the first skinned primitive of a GLB and its rig (joint order = skeleton order).
    pub fn from_glb(bytes: &[u8]) -> Result<SkinMesh, SkinError> {
        let rig = Rig::from_gltf_slice(bytes, &RigMap::sloth())?;
        let gltf = gltf::Gltf::from_slice(bytes)?;
        let blob = gltf
            .blob
            .as_deref()
            .ok_or_else(|| SkinError::Field("BIN chunk", "missing".into()))?;
        let prim = gltf
            .document
            .meshes()
            .flat_map(|m| m.primitives())
            .next()
            .ok_or_else(|| SkinError::Field("meshes[0].primitives[0]", "no primitive".into()))?;
        let reader = prim.reader(|_| Some(blob));
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| SkinError::Field("POSITION", "missing".into()))?
            .map(Vec3::from)
            .collect();
        let joints: Vec<[u16; 4]> = reader
            .read_joints(0)
            .ok_or_else(|| SkinError::Field("JOINTS_0", "missing".into()))?
            .into_u16()
            .collect();
        let weights: Vec<[f32; 4]> = reader
            .read_weights(0)
            .ok_or_else(|| SkinError::Field("WEIGHTS_0", "missing".into()))?
            .into_f32()
            .collect();
        let indices: Vec<u32> = reader
            .read_indices()
            .ok_or_else(|| SkinError::Field("indices", "missing".into()))?
            .into_u32()
            .collect();
        let n = positions.len();
        if joints.len() != n || weights.len() != n {
            return Err(SkinError::Field(
                "JOINTS_0/WEIGHTS_0",
                format!(
                    "{} / {} entries for {n} positions",
                    joints.len(),
                    weights.len()
                ),
            ));
        }
        let skel = rig.skeleton();
        for (v, j) in joints.iter().enumerate() {
            if let Some(bad) = j.iter().find(|&&j| usize::from(j) >= skel.len()) {
                return Err(SkinError::Field(
                    "JOINTS_0",
                    format!(
                        "vertex {v} names joint {bad}, the skeleton has {}",
                        skel.len()
                    ),
                ));
            }
        }
        if let Some(t) = indices.iter().position(|&i| i as usize >= n) {
            return Err(SkinError::Field(
                "indices",
                format!("entry {t} is past the {n} vertices"),
            ));
        }
        let mut bind = vec![Affine3A::IDENTITY; skel.len()];
        skel.fk(&skel.rest_rotations(), &mut bind);
        let inv_bind = bind.iter().map(|b| b.inverse()).collect();
        let mesh = SkinMesh {
            rig,
            bind,
            inv_bind,
            positions,
            joints,
            weights,
            indices,
        };
        for limb in Limb::ALL {
            mesh.check_tube(limb)?;
        }
        Ok(mesh)
    }

    /// First vertex of a limb's tube (rings in order, girdle first).
    pub fn tube_first(limb: Limb) -> usize {
        BODY_VERTICES + limb.index() * LIMB_VERTICES
    }

    /// Vertex index of `side` on ring `ring` of a limb's tube.
    pub fn tube_vertex(limb: Limb, ring: usize, side: usize) -> usize {
        Self::tube_first(limb) + ring * LIMB_SIDES + side
    }

    /// Ring index of limb chain joint `element` (0 = girdle … 3 = wrist/ankle).
    pub fn joint_ring(element: usize) -> usize {
        element * LIMB_RINGS_PER_BONE
    }

    /// Check a limb tube has the asset generator's layout: every vertex weighted only
    /// to the limb's joints (or its chain root), each ring centred near its bone.
    fn check_tube(&self, limb: Limb) -> Result<(), SkinError> {
        let lj = self.rig.limb_joints(limb);
        let err = |vertex: usize, why: String| SkinError::Layout {
            limb: limb.name().into(),
            vertex,
            why,
        };
        let last = Self::tube_first(limb) + LIMB_VERTICES;
        if last > self.positions.len() {
            return Err(err(last - 1, "mesh too short for the limb tubes".into()));
        }
        for v in Self::tube_first(limb)..last {
            for k in 0..4 {
                let j = usize::from(self.joints[v][k]);
                if self.weights[v][k] > 0.0 && j != lj.chain_root && !lj.joints.contains(&j) {
                    return Err(err(v, format!("weighted to joint {j}, not of this limb")));
                }
            }
        }
        for e in 0..4 {
            let ring = Self::joint_ring(e);
            let c = self.ring_centre(&self.positions, limb, ring);
            let joint = Vec3::from(self.bind[lj.joints[e]].translation);
            if c.distance(joint) > 1e-3 {
                return Err(err(
                    Self::tube_vertex(limb, ring, 0),
                    format!("ring {ring} is not centred on joint {}", lj.joints[e]),
                ));
            }
        }
        Ok(())
    }

    /// Centroid of a ring of `positions`.
    pub fn ring_centre(&self, positions: &[Vec3], limb: Limb, ring: usize) -> Vec3 {
        let s: Vec3 = (0..LIMB_SIDES)
            .map(|k| positions[Self::tube_vertex(limb, ring, k)])
            .sum();
        s / LIMB_SIDES as f32
    }
}
