//! The skinned sloth mesh for the side view (`side.png`): control-cluster skinning
//! (`slothsim-skin`) of the drawn instants only, after the run, from the read-only pose
//! snapshots — never in the tick.

use glam::{Affine3A, Quat, Vec3};
use slothsim_sim::snapshot::SlothPose;
use slothsim_skin::{ClusterSkin, ReferenceShapes, SkinError, SkinMesh};

/// The sloth mesh and its cluster skin, built once per plot.
pub struct Skinner {
    mesh: SkinMesh,
    clusters: ClusterSkin,
    moved: Vec<usize>,
}

impl Skinner {
    /// The default sloth (`assets/sloth.glb`) and its stored reference shapes.
    ///
    /// # Errors
    /// A [`SkinError`] naming the joint, vertex or field of an unusable asset.
    pub fn sloth() -> Result<Self, SkinError> {
        let mesh = SkinMesh::sloth()?;
        let clusters = ClusterSkin::new(&mesh, &ReferenceShapes::sloth()?)?;
        let moved = slothsim_sim::record::moved_joints(&mesh.rig);
        Ok(Self {
            mesh,
            clusters,
            moved,
        })
    }

    /// Triangles of the mesh (three vertex indices each).
    pub fn triangles(&self) -> &[u32] {
        &self.mesh.indices
    }

    /// World-space vertices of `pose`, cluster-skinned.
    ///
    /// # Errors
    /// A non-finite pose, naming the joint.
    pub fn skin(&self, pose: &SlothPose) -> Result<Vec<Vec3>, SkinError> {
        let rotations: Vec<Quat> = pose.limb_locals.iter().flatten().copied().collect();
        let locals = self.mesh.locals_with(&self.moved, &rotations)?;
        let posed = self.mesh.pose(&locals)?;
        let (mut lbs, mut out) = (Vec::new(), Vec::new());
        self.clusters.skin(&self.mesh, &posed, &mut lbs, &mut out);
        if !(pose.body_pos.is_finite() && pose.body_rot.is_finite()) {
            return Err(SkinError::Pose {
                joint: 0,
                name: "body".into(),
                why: "the body transform is not finite".into(),
            });
        }
        let body = Affine3A::from_rotation_translation(pose.body_rot, pose.body_pos);
        Ok(out.iter().map(|p| body.transform_point3(*p)).collect())
    }
}
