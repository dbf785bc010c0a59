//! A recorded run, for people to watch and analyse it outside slothsim:
//!
//! - [`write_glb`]: binary glTF 2.0 — the forest's meshes, one skinned sloth
//!   instance (its own skin) per recorded sloth, and one animation with, per
//!   sloth, its root's translation and rotation and the rotation of every
//!   joint the simulation moves, LINEAR at the sample times (quaternions
//!   normalised and sign-continuous). A single sample gives a still pose and
//!   no animation. With [`Skinning::Clusters`] (the CLI default) the sloth mesh
//!   also carries corrective morph targets ([`Correctives`]) whose weights are
//!   animated per sloth, so viewers show the control-cluster skinning.
//! - [`TrajectoryCsv`]: one row per recorded sloth per sample (see
//!   [`CSV_HEADER`] and `docs/export.md`).
//! - [`AtomicFile`]: both are written under a temporary name in the target
//!   folder and renamed at the end, so a failed write (disk full) never leaves
//!   a file under the final name.
//!
//! The data is plain: the simulation fills [`Recording`] with [`Sample`]s
//! (its own sampler reads the state after a tick); nothing here knows the ECS.

mod atomic;
mod corrective;
mod csv;
mod glb;
mod model;
mod recording;

pub use atomic::AtomicFile;
pub use corrective::{Correctives, Skinning};
pub use csv::{CSV_HEADER, TrajectoryCsv};
pub use glb::{GlbSummary, glb_bytes, write_glb};
pub use model::{ModelError, SlothModel};
pub use recording::{LimbSample, Recording, Sample, Track};

/// Errors writing a recording.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Writing failed (the temporary file was removed).
    #[error("cannot write {path}: {source}")]
    Io {
        /// The file that was being written.
        path: std::path::PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The binary chunk would exceed the 4 GiB a GLB can address.
    #[error("{0}")]
    TooLarge(String),
    /// The corrective targets do not fit the sloth model.
    #[error("corrective morph targets: {0}")]
    Targets(String),
    /// A recorded pose cannot be written (a non-finite value) or skinned.
    #[error("sloth {sloth} at t = {time_s} s: {why}")]
    Pose {
        /// Sloth id.
        sloth: u32,
        /// Sample time (s).
        time_s: f32,
        /// What is wrong, naming the joint.
        why: String,
    },
}
