//! Forest scene for slothsim: supports (trunks and branches), the procedural
//! forest, the thesis scenario presets, glTF import/export and BVH traces.
//!
//! Conventions: metres, radians, +Y up, right-handed (glTF axes). No ECS here.

mod atomic;
mod error;
mod forest;
mod gltf_io;
mod model;
mod percentile;
mod presets;
mod primitive;
mod trace;
pub mod treegen;

pub use atomic::{temp_path, write_atomically};
pub use error::{SceneError, TraceError};
pub use forest::{ForestConfig, default_forest, generate_forest};
pub use gltf_io::{
    ImportReport, InstanceStats, MIN_GRIP_LENGTH_M, MIN_GRIP_RADIUS_M, MeshStats, export_document,
    export_glb, export_gltf_json, import_slice, import_slice_report, read_scene, read_scene_report,
    write_scene,
};
pub use model::{
    Bounds, Scene, Support, SupportId, SupportKind, TRUNK_TILT_DEG, TriMesh, closest_on_segment,
    tilt_of,
};
pub use percentile::percentile_sorted;
pub use presets::{
    BRANCH_TRUNK_RADIUS, BRANCH_TRUNK_RADIUS_RANGE, Goal, PRESET_BRANCH_RADIUS, PRESET_HEIGHT,
    Preset, PresetKind, StartHint, THICK_TRUNK_REASON, TRUNK_RADIUS_RANGE,
};
pub use trace::{
    BoxOverlap, BvhStats, LineTrace, SceneQuery, SphereSweep, TraceHit, TraceRequest, TraceResult,
    TraceScene,
};
