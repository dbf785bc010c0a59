//! Skinning kernels for the sloth mesh (issue 25, seed 004): linear blend skinning
//! (formula 1, the reference), dual-quaternion skinning (the usual fix) and the
//! control-cluster method (formulas 2–4). No ECS: plain functions over a [`SkinMesh`]
//! and a pose (one local rotation per joint). See the crate README for the method, the
//! offline reference step and the measured flexion sweeps.

mod cluster;
mod error;
mod lbs;
pub mod measure;
mod mesh;
mod morph;
pub mod sculpt;

pub use cluster::{ClusterSkin, DEFAULT_TENSION};
pub use error::SkinError;
pub use lbs::Posed;
pub use mesh::{LIMB_RINGS, LIMB_SIDES, SkinMesh};
pub use morph::{CorrectiveTargets, MorphScratch, MorphTarget};
pub use sculpt::{JointReferences, LimbJoint, ReferenceShapes, reference_shapes};
