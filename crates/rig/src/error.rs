//! Errors from building or loading a rig. Every variant names the joint involved.

use std::path::PathBuf;

use crate::limits::LimitProblem;

/// Failure to build or load a [`crate::Rig`] / [`crate::Skeleton`].
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// The file is not valid glTF/GLB.
    #[error("invalid glTF: {0}")]
    Gltf(#[from] gltf::Error),
    /// The file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// File path.
        path: PathBuf,
        /// Cause.
        source: std::io::Error,
    },
    /// The glTF has no scene nodes usable as joints.
    #[error("the rig has no joints")]
    Empty,
    /// A joint required by the name map is not in the rig.
    #[error("missing joint `{name}` (role {role})")]
    MissingJoint {
        /// Role, e.g. `LF.UpperArm`.
        role: String,
        /// Node name the map asked for.
        name: String,
    },
    /// A node is listed as the child of two nodes (or twice by one).
    #[error("joint `{joint}` has more than one parent")]
    MultipleParents {
        /// Joint name.
        joint: String,
    },
    /// The hierarchy has a cycle through this joint.
    #[error("joint `{joint}` is part of a cycle in the node hierarchy")]
    Cycle {
        /// Joint name.
        joint: String,
    },
    /// In a flat joint array, a joint's parent index is not smaller than its own.
    #[error("joint `{joint}` comes before (or is) its parent `{parent}`")]
    ParentAfterChild {
        /// Joint name.
        joint: String,
        /// Parent name (empty if the index is out of range).
        parent: String,
    },
    /// Two joints share a name.
    #[error("duplicate joint name `{joint}`")]
    DuplicateName {
        /// Joint name.
        joint: String,
    },
    /// A rest transform has NaN/inf components.
    #[error("joint `{joint}` has a non-finite rest transform")]
    NonFiniteTransform {
        /// Joint name.
        joint: String,
    },
    /// A joint limit is malformed (e.g. min > max).
    #[error("joint `{joint}` has an invalid limit: {problem}")]
    InvalidLimit {
        /// Joint name.
        joint: String,
        /// What is wrong.
        problem: LimitProblem,
    },
    /// A node's `extras` could not be parsed.
    #[error("joint `{joint}` has unreadable extras: {message}")]
    BadExtras {
        /// Joint name.
        joint: String,
        /// Parser message.
        message: String,
    },
    /// The joints mapped to a limb do not form a parent → child chain.
    #[error("joint `{joint}` ({role}) is not a child of `{expected_parent}`")]
    NotAChain {
        /// Joint name.
        joint: String,
        /// Role, e.g. `LH.LowerLeg`.
        role: String,
        /// The joint it should hang from.
        expected_parent: String,
    },
    /// The girdle joint of a limb has no parent to serve as the chain root.
    #[error("limb girdle joint `{joint}` has no parent to act as chain root")]
    NoChainRoot {
        /// Joint name.
        joint: String,
    },
    /// Skeleton arrays of different lengths were passed.
    #[error("skeleton arrays differ in length")]
    LengthMismatch,
    /// More joints than a `u16` index can address.
    #[error("too many joints: {0}")]
    TooManyJoints(usize),
}
