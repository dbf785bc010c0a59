//! glTF 2.0 import and export of scenes.
//!
//! Axes and units are glTF's own: metres, +Y up, right-handed, so no
//! conversion happens in either direction.
//!
//! # Export
//!
//! [`export_glb`] writes binary glTF (`.glb`); [`export_gltf_json`] writes a
//! self-contained `.gltf` whose single buffer is embedded as a base64 `data:`
//! URI (no `.bin` beside it). [`write_scene`] picks by file extension and
//! writes atomically (temporary file in the same directory, then rename).
//! Output is deterministic: the same scene gives the same bytes.
//!
//! One node + one mesh per support, in support order, all listed in the
//! default scene. Node transforms are identity: geometry is in world space.
//! Capsule supports are tessellated as tubes (12 sides, a ring per axis node,
//! hemispherical end caps, smooth normals); supports with an imported mesh
//! export that mesh verbatim. The node name is the support's name, else
//! `trunk_<id>` / `branch_<id>`. Each node carries in `extras`:
//!
//! ```json
//! {"slothsim": {
//!     "kind": "trunk" | "branch",   // required
//!     "tagged": true | false,       // optional, default true
//!     "axis": [[x, y, z], ...],     // required, >= 2 nodes, node-local = world on export
//!     "radii": [r, ...],            // required, one per axis node, finite and > 0
//!     "mesh": true,                 // optional: the node's triangles ARE the surface (keep them)
//!     "name_generated": true        // optional: the node name was made up; support has no name
//! }}
//! ```
//!
//! so that export → import reproduces every support exactly (ids, kind, tag,
//! name, axis, radii and imported meshes).
//!
//! # Import
//!
//! [`read_scene`] (external `.bin` files are resolved relative to the file) and
//! [`import_slice`] (only embedded / `data:` buffers). The default scene (else
//! the first scene, else all root nodes) is walked from its roots and node
//! world transforms are applied. Per node with a mesh, in traversal order:
//!
//! - `extras.slothsim` present: one support from axis/radii/kind exactly
//!   (axis transformed by the node's world matrix, radii scaled by its mean
//!   scale); the triangles are dropped unless `"mesh": true`.
//! - otherwise the mesh's TRIANGLES primitives (points and lines are skipped,
//!   normals ignored) are welded, split into connected parts and each part
//!   becomes a support fitted by PCA (see `fit`), keeping its triangles as
//!   the traced surface. A node name starting with `trunk` / `branch`
//!   (case-insensitive) tags the kind; else the tilt rule decides.
//!   Degenerate parts are skipped.
//!
//! Errors name the file and, where it applies, the node (index and name) and
//! the field. No input panics or yields NaN.

mod export;
mod fit;
mod import;
mod mesh_import;
mod skeleton;

pub use mesh_import::{
    ImportReport, InstanceStats, MIN_GRIP_LENGTH_M, MIN_GRIP_RADIUS_M, MeshStats,
};

use std::path::Path;

use base64::Engine as _;

use crate::{Scene, SceneError};

/// Key of our block inside a node's `extras`.
const EXTRAS_KEY: &str = "slothsim";
/// Vertices per tube ring on export.
const SIDES: usize = 12;
/// Latitude steps per hemispherical end cap on export (the last is the pole).
const CAP_RINGS: usize = 3;

/// Encodes `scene` as binary glTF (`.glb`).
pub fn export_glb(scene: &Scene) -> Vec<u8> {
    let (root, bin) = export::build(scene, |_| None);
    // Serialising a gltf-json root (plain data, finite floats) cannot fail.
    let json = serde_json::to_vec(&root).unwrap_or_default();
    glb_container(&json, &bin)
}

/// The glTF document of `scene`: the JSON root and its binary buffer
/// (unpadded; the root's buffer 0 when not empty), for writers that add to it
/// (the animated crowd of `slothsim-export`). Same layout as [`export_glb`].
pub fn export_document(scene: &Scene) -> (gltf_json::Root, Vec<u8>) {
    export::build(scene, |_| None)
}

/// Encodes `scene` as glTF JSON with the buffer embedded as a base64 `data:` URI.
pub fn export_gltf_json(scene: &Scene) -> String {
    let (root, _) = export::build(scene, |bin| {
        Some(format!(
            "data:application/octet-stream;base64,{}",
            base64::engine::general_purpose::STANDARD.encode(bin)
        ))
    });
    serde_json::to_string_pretty(&root).unwrap_or_default()
}

/// Writes `scene` to `path` as `.glb` or `.gltf` (by extension, case-insensitive).
///
/// The data goes to a temporary file in the same directory that is then
/// renamed over `path`, so readers never see a partial file.
///
/// # Errors
/// [`SceneError::Gltf`] for another extension, [`SceneError::Io`] when the
/// file cannot be written.
pub fn write_scene(scene: &Scene, path: &Path) -> Result<(), SceneError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let bytes = match ext.as_deref() {
        Some("glb") => export_glb(scene),
        Some("gltf") => export_gltf_json(scene).into_bytes(),
        other => {
            return Err(SceneError::Gltf {
                file: path.display().to_string(),
                detail: format!(
                    "unsupported extension `{}` (expected .glb or .gltf)",
                    other.map(|e| format!(".{e}")).unwrap_or_default()
                ),
            });
        }
    };
    crate::write_atomically(path, &bytes).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// Reads a `.glb` or `.gltf` file (external buffers resolved relative to it).
///
/// # Errors
/// [`SceneError::Io`] if the file (not a buffer it references) cannot be read;
/// [`SceneError::Gltf`] for malformed files, bad extras, unreadable buffers
/// (naming file, node and field); [`SceneError::NoSupports`] if nothing usable remains.
pub fn read_scene(path: &Path) -> Result<Scene, SceneError> {
    read_scene_report(path).map(|(scene, _)| scene)
}

/// [`read_scene`], with what the import made of each mesh and node, and its
/// warnings (see [`ImportReport`]).
///
/// # Errors
/// As [`read_scene`].
pub fn read_scene_report(path: &Path) -> Result<(Scene, ImportReport), SceneError> {
    let bytes = std::fs::read(path).map_err(|source| SceneError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    let base = path.parent().unwrap_or(Path::new(""));
    let base = if base.as_os_str().is_empty() {
        Path::new(".")
    } else {
        base
    };
    import::import(&bytes, &path.display().to_string(), Some(base))
}

/// Reads glTF/GLB bytes; `source_name` names them in errors. Buffers must be
/// the GLB `BIN` chunk or `data:` URIs.
///
/// # Errors
/// As [`read_scene`], with [`SceneError::Gltf`] for external buffer references.
pub fn import_slice(bytes: &[u8], source_name: &str) -> Result<Scene, SceneError> {
    import::import(bytes, source_name, None).map(|(scene, _)| scene)
}

/// [`import_slice`] with the [`ImportReport`].
///
/// # Errors
/// As [`import_slice`].
pub fn import_slice_report(
    bytes: &[u8],
    source_name: &str,
) -> Result<(Scene, ImportReport), SceneError> {
    import::import(bytes, source_name, None)
}

/// Wraps JSON and binary chunks in a GLB container (header, 4-byte padded chunks).
pub(crate) fn glb_container(json: &[u8], bin: &[u8]) -> Vec<u8> {
    let pad = |n: usize| (4 - n % 4) % 4;
    let json_len = json.len() + pad(json.len());
    let bin_len = bin.len() + pad(bin.len());
    let total = 12 + 8 + json_len + if bin.is_empty() { 0 } else { 8 + bin_len };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json_len as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json);
    out.resize(out.len() + pad(json.len()), b' ');
    if !bin.is_empty() {
        out.extend_from_slice(&(bin_len as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(bin);
        out.resize(out.len() + pad(bin.len()), 0);
    }
    out
}
