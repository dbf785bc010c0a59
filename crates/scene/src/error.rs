//! Errors of the scene crate. Every variant names what was wrong and where
//! (file, node, support, field) so a CLI can print it as is.

use std::path::PathBuf;

/// Anything that can go wrong building, loading or tracing a scene.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// A support failed validation (NaN, negative radius, zero-length segment …).
    #[error("support {support}: field `{field}`: {detail}")]
    InvalidSupport {
        /// Id or name of the support.
        support: String,
        /// The offending field (`nodes`, `radii`, `id`, …).
        field: &'static str,
        /// What is wrong with it.
        detail: String,
    },
    /// A scene has no supports at all.
    #[error("{source_name}: no usable supports (trunks or branches) found{detail}")]
    NoSupports {
        /// File (or `<memory>`) the scene came from.
        source_name: String,
        /// Why, when the import knows (`: ` and its warnings, naming nodes), else empty.
        detail: String,
    },
    /// A parameter (preset angle, forest config …) is outside its allowed range.
    #[error("`{field}` = {value} is outside the allowed range {allowed}")]
    OutOfRange {
        /// Name of the parameter.
        field: &'static str,
        /// The value given.
        value: f64,
        /// The allowed range, human readable.
        allowed: String,
    },
    /// Unknown preset name.
    #[error(
        "unknown preset `{0}` (known: turn, parallel, trunk, height_change, branch_trunk, pole, branch_end)"
    )]
    UnknownPreset(String),
    /// File could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A glTF file is malformed or unusable.
    #[error("{file}: {detail}")]
    Gltf {
        /// The file (or `<memory>`).
        file: String,
        /// What is wrong, naming node/mesh/field where possible.
        detail: String,
    },
}

/// Errors of trace queries (bad query input; a miss is not an error).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum TraceError {
    /// Direction is zero, NaN or infinite.
    #[error("trace direction must be finite and non-zero")]
    InvalidDirection,
    /// Origin, length, radius or box extents are NaN/infinite/negative.
    #[error("trace parameter `{0}` must be finite (and non-negative)")]
    InvalidParameter(&'static str),
}
