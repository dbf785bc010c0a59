//! The skinned sloth that every recorded sloth instantiates: the rig's
//! skeleton (names, parents, rest transforms) and the skinned mesh of a rig
//! file (by default the committed `assets/sloth.glb`).

use glam::{Quat, Vec3};
use slothsim_rig::Rig;

/// The default rig file, embedded (its skeleton is [`Rig::sloth`], tested).
const SLOTH_GLB: &[u8] = include_bytes!("../../../assets/sloth.glb");

/// A rig file without a usable skinned mesh.
#[derive(Debug, thiserror::Error)]
#[error("sloth model: {0}")]
pub struct ModelError(String);

/// Skeleton + skinned mesh, ready to be instantiated.
#[derive(Clone, Debug)]
pub struct SlothModel {
    /// Joint names, depth-first (the rig's skeleton order).
    pub names: Vec<String>,
    /// Parent of each joint (`None` for the root).
    pub parents: Vec<Option<usize>>,
    /// Rest translation of each joint in its parent's frame.
    pub rest_translation: Vec<Vec3>,
    /// Rest rotation of each joint relative to its parent.
    pub rest_rotation: Vec<Quat>,
    /// Inverse bind matrix per joint (column-major), skeleton order.
    pub inverse_bind: Vec<[f32; 16]>,
    /// Vertex positions (bind pose, model space).
    pub positions: Vec<[f32; 3]>,
    /// Vertex normals (unit).
    pub normals: Vec<[f32; 3]>,
    /// Four joint indices (skeleton order) per vertex.
    pub joints: Vec<[u16; 4]>,
    /// Four weights per vertex (sum 1).
    pub weights: Vec<[f32; 4]>,
    /// Triangle list.
    pub indices: Vec<u32>,
    /// Base colour (linear RGBA).
    pub color: [f32; 4],
}

impl SlothModel {
    /// The default sloth: [`Rig::sloth`] with the mesh of `assets/sloth.glb`.
    ///
    /// # Panics
    /// Never for the committed asset (tested).
    pub fn sloth() -> Self {
        Self::from_glb(SLOTH_GLB, &Rig::sloth()).expect("assets/sloth.glb has a skinned mesh")
    }

    /// `rig`'s skeleton with the first skinned mesh of a glTF file whose
    /// skin's joints are named as the rig's joints.
    ///
    /// # Errors
    /// [`ModelError`] when the file has no skinned triangle mesh, or names a
    /// joint the rig does not have.
    pub fn from_glb(bytes: &[u8], rig: &Rig) -> Result<Self, ModelError> {
        let err = |m: String| ModelError(m);
        let (doc, buffers, _) =
            gltf::import_slice(bytes).map_err(|e| err(format!("not a glTF file: {e}")))?;
        let skel = rig.skeleton();
        let node = doc
            .nodes()
            .find(|n| n.mesh().is_some() && n.skin().is_some())
            .ok_or_else(|| err("no skinned mesh".into()))?;
        let (mesh, skin) = (node.mesh().expect("checked"), node.skin().expect("checked"));
        // File joint index → skeleton joint index.
        let map = skin
            .joints()
            .map(|j| {
                let name = j.name().unwrap_or_default();
                skel.find(name)
                    .ok_or_else(|| err(format!("skin joint `{name}` is not a joint of the rig")))
            })
            .collect::<Result<Vec<_>, _>>()?;
        let reader = skin.reader(|b| Some(&buffers[b.index()]));
        let mut inverse_bind = vec![glam::Mat4::IDENTITY.to_cols_array(); skel.len()];
        if let Some(ibm) = reader.read_inverse_bind_matrices() {
            for (k, m) in ibm.enumerate() {
                if let Some(&j) = map.get(k) {
                    inverse_bind[j] = glam::Mat4::from_cols_array_2d(&m).to_cols_array();
                }
            }
        }
        let prim = mesh
            .primitives()
            .find(|p| p.mode() == gltf::mesh::Mode::Triangles)
            .ok_or_else(|| err("the skinned mesh has no triangles".into()))?;
        let r = prim.reader(|b| Some(&buffers[b.index()]));
        let positions: Vec<[f32; 3]> = r
            .read_positions()
            .ok_or_else(|| err("mesh without POSITION".into()))?
            .collect();
        let normals = match r.read_normals() {
            Some(n) => n.collect(),
            None => vec![[0.0, 1.0, 0.0]; positions.len()],
        };
        let joints = r
            .read_joints(0)
            .ok_or_else(|| err("mesh without JOINTS_0".into()))?
            .into_u16()
            .map(|j| {
                j.map(|k| {
                    let s = map.get(usize::from(k)).copied().unwrap_or(0);
                    u16::try_from(s).unwrap_or(0)
                })
            })
            .collect();
        let weights = r
            .read_weights(0)
            .ok_or_else(|| err("mesh without WEIGHTS_0".into()))?
            .into_f32()
            .collect();
        let indices = match r.read_indices() {
            Some(i) => i.into_u32().collect(),
            None => (0..u32::try_from(positions.len()).unwrap_or(0)).collect(),
        };
        let color = prim.material().pbr_metallic_roughness().base_color_factor();
        Ok(Self {
            names: skel.names().to_vec(),
            parents: (0..skel.len()).map(|i| skel.parent(i)).collect(),
            rest_translation: skel.rest().iter().map(|r| r.translation).collect(),
            rest_rotation: skel.rest().iter().map(|r| r.rotation).collect(),
            inverse_bind,
            positions,
            normals,
            joints,
            weights,
            indices,
            color,
        })
    }

    /// Number of joints.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// No joints?
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn committed_asset_gives_a_skinned_mesh_of_the_rig() {
        let m = SlothModel::sloth();
        assert_eq!(m.len(), Rig::sloth().skeleton().len());
        assert!(
            (2000..=6000).contains(&m.positions.len()),
            "{} vertices",
            m.positions.len()
        );
        assert_eq!(m.indices.len() % 3, 0);
        for (j, w) in m.joints.iter().zip(&m.weights) {
            assert!(j.iter().all(|&k| usize::from(k) < m.len()));
            let sum: f32 = w.iter().sum();
            assert!((sum - 1.0).abs() < 1e-4, "weights sum {sum}");
        }
    }
}
