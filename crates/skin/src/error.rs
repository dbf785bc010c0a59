//! Errors of the skinning kernels: each names the joint, vertex or field at fault.

/// What went wrong loading a skinned mesh or skinning a pose.
#[derive(Debug, thiserror::Error)]
pub enum SkinError {
    /// The glTF could not be parsed.
    #[error("glTF: {0}")]
    Gltf(#[from] gltf::Error),
    /// The rig in the glTF is invalid.
    #[error("rig: {0}")]
    Rig(#[from] slothsim_rig::RigError),
    /// A required glTF field is missing or malformed.
    #[error("mesh field `{0}`: {1}")]
    Field(&'static str, String),
    /// The limb tube layout does not match the asset generator's.
    #[error("limb {limb}: vertex {vertex}: {why}")]
    Layout {
        /// Limb name.
        limb: String,
        /// Offending vertex index.
        vertex: usize,
        /// What is wrong.
        why: String,
    },
    /// A pose has the wrong length or a non-finite rotation.
    #[error("pose: joint {joint} (`{name}`): {why}")]
    Pose {
        /// Joint index.
        joint: usize,
        /// Joint name.
        name: String,
        /// What is wrong.
        why: String,
    },
    /// A limb joint has no (or too few) reference shapes.
    #[error("reference shapes: joint `{joint}`: {why}")]
    References {
        /// Joint name.
        joint: String,
        /// What is wrong.
        why: String,
    },
    /// A control cluster names a vertex the mesh does not have, or one it cannot use.
    #[error("cluster of joint `{joint}`: vertex {vertex}: {why}")]
    Cluster {
        /// Joint name.
        joint: String,
        /// Vertex index.
        vertex: usize,
        /// What is wrong.
        why: String,
    },
}
