//! glTF document → scene: parse, load buffers, walk the node graph, turn each
//! mesh node into supports (from our extras, or fitted to its triangles).

use std::path::Path;

use glam::{Mat4, Vec3};
use serde_json::Value;

use super::EXTRAS_KEY;
use super::mesh_import::{
    ImportReport, MeshSkeleton, instance_supports, skeletonise_mesh, trim_embedded,
};
use crate::{Scene, SceneError, Support, SupportKind, TriMesh};

/// Shortest axis segment accepted from extras (same limit as `Scene::new`).
const MIN_SEGMENT: f32 = 1e-4;

/// Everything the node handlers need: the file name for errors and the buffers.
struct Ctx<'a> {
    file: &'a str,
    buffers: &'a [gltf::buffer::Data],
}

impl Ctx<'_> {
    fn err(&self, detail: impl Into<String>) -> SceneError {
        SceneError::Gltf {
            file: self.file.to_string(),
            detail: detail.into(),
        }
    }
}

/// Parses `bytes` (GLB or JSON glTF) into a scene. `base` is the directory
/// external buffers are resolved against; `None` allows only embedded data.
pub(super) fn import(
    bytes: &[u8],
    file: &str,
    base: Option<&Path>,
) -> Result<(Scene, ImportReport), SceneError> {
    // Known panics of the `gltf` crate on malformed input are checked for up
    // front; this is the last resort for unknown ones.
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        import_checked(bytes, file, base)
    }))
    .unwrap_or_else(|_| {
        Err(SceneError::Gltf {
            file: file.to_string(),
            detail: PARSER_PANIC.to_string(),
        })
    })
}

/// Detail of the error returned when the `gltf` crate panicked.
const PARSER_PANIC: &str = "malformed glTF: the glTF reader failed on this file";

fn import_checked(
    bytes: &[u8],
    file: &str,
    base: Option<&Path>,
) -> Result<(Scene, ImportReport), SceneError> {
    let gltf_err = |detail: String| SceneError::Gltf {
        file: file.to_string(),
        detail,
    };
    let invalid = |e: gltf::Error| gltf_err(format!("not a valid glTF/GLB file: {e}"));
    let gltf::Gltf { document, mut blob } =
        gltf::Gltf::from_slice_without_validation(bytes).map_err(invalid)?;
    // gltf-json's validation indexes POSITION accessors unchecked (panics on
    // a dangling index), so check that first, then validate.
    check_position_indices(document.as_json()).map_err(gltf_err)?;
    let document = gltf::Document::from_json(document.into_json()).map_err(invalid)?;
    let buffers = load_buffers(&document, base, &mut blob).map_err(gltf_err)?;
    let ctx = Ctx {
        file,
        buffers: &buffers,
    };

    let mut supports = Vec::new();
    let mut report = ImportReport::default();
    let mut made: Vec<usize> = Vec::new();
    let mut skeletons: std::collections::HashMap<usize, MeshSkeleton> = Default::default();
    for (node, world) in walk(&document) {
        let label = node_label(&node);
        if !world.is_finite() {
            return Err(ctx.err(format!("{label}: world transform is not finite")));
        }
        let Some(mesh) = node.mesh() else { continue };
        match slothsim_extras(&node).map_err(|d| ctx.err(format!("{label}: {d}")))? {
            Some(block) => {
                supports.push(tagged_support(&ctx, &node, &mesh, world, &block, &label)?);
            }
            None => {
                if let std::collections::hash_map::Entry::Vacant(slot) =
                    skeletons.entry(mesh.index())
                {
                    let (positions, triangles) =
                        read_triangles(&ctx, &mesh, Mat4::IDENTITY, &label)?;
                    let mesh_label = match mesh.name() {
                        Some(n) => format!("mesh {} `{n}` (first placed by {label})", mesh.index()),
                        None => format!("mesh {} (first placed by {label})", mesh.index()),
                    };
                    let skel = skeletonise_mesh(
                        mesh.index(),
                        mesh.name(),
                        &positions,
                        &triangles,
                        &mesh_label,
                        &mut report,
                    );
                    slot.insert(skel);
                }
                let skel = &skeletons[&mesh.index()];
                let first = supports.len();
                let base_name = node.name().or_else(|| mesh.name());
                let tag = base_name.and_then(kind_from_name);
                supports.extend(instance_supports(
                    skel,
                    node.index(),
                    node.name(),
                    mesh.index(),
                    base_name,
                    tag,
                    world,
                    &label,
                    &mut report,
                ));
                made.extend(first..supports.len());
            }
        }
    }
    trim_embedded(&mut supports, &made);
    if supports.is_empty() {
        let detail = if report.warnings.is_empty() {
            String::new()
        } else {
            format!(": {}", report.warnings.join("; "))
        };
        return Err(SceneError::NoSupports {
            source_name: file.to_string(),
            detail,
        });
    }
    let scene = Scene::new(supports).map_err(|e| ctx.err(e.to_string()))?;
    Ok((scene, report))
}

/// Every primitive's POSITION attribute must name an existing accessor.
fn check_position_indices(root: &gltf::json::Root) -> Result<(), String> {
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            let position = gltf::json::validation::Checked::Valid(gltf::Semantic::Positions);
            if let Some(index) = prim.attributes.get(&position)
                && index.value() >= root.accessors.len()
            {
                return Err(format!(
                    "not a valid glTF/GLB file: mesh {m} primitive {p}: POSITION accessor {} \
                     does not exist ({} accessors)",
                    index.value(),
                    root.accessors.len()
                ));
            }
        }
    }
    Ok(())
}

/// Loads every buffer (GLB blob, `data:` URI, or a file relative to `base`),
/// naming the buffer and its URI on failure.
fn load_buffers(
    document: &gltf::Document,
    base: Option<&Path>,
    blob: &mut Option<Vec<u8>>,
) -> Result<Vec<gltf::buffer::Data>, String> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let what = match buffer.source() {
            gltf::buffer::Source::Bin => format!("buffer {} (GLB BIN chunk)", buffer.index()),
            gltf::buffer::Source::Uri(uri) => {
                let shown: String = uri.chars().take(80).collect();
                let external = !uri.contains(':') || uri.starts_with("file:");
                if external && base.is_none() {
                    return Err(format!(
                        "buffer {} refers to external file `{shown}`, which cannot be resolved \
                         when importing from memory (use read_scene with a path)",
                        buffer.index()
                    ));
                }
                // `gltf` percent-decodes relative URIs and panics on invalid UTF-8.
                if !uri.contains(':') && !percent_decodes_to_utf8(uri) {
                    return Err(format!(
                        "buffer {}: URI `{shown}` is not valid percent-encoded UTF-8",
                        buffer.index()
                    ));
                }
                format!("buffer {} (`{shown}`)", buffer.index())
            }
        };
        let data = gltf::buffer::Data::from_source_and_blob(buffer.source(), base, blob)
            .map_err(|e| format!("cannot load {what}: {e}"))?;
        if data.len() < buffer.length() {
            return Err(format!(
                "{what} is truncated: {} bytes, expected {}",
                data.len(),
                buffer.length()
            ));
        }
        out.push(data);
    }
    Ok(out)
}

/// Whether percent-decoding `s` yields valid UTF-8 (what `gltf` unwraps).
fn percent_decodes_to_utf8(s: &str) -> bool {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    std::str::from_utf8(&out).is_ok()
}

/// Nodes with their world matrices, depth-first from the roots of the default
/// scene (else the first scene, else every node that is nobody's child).
/// Each node is visited at most once, so malformed cyclic graphs terminate.
fn walk(document: &gltf::Document) -> Vec<(gltf::Node<'_>, Mat4)> {
    let roots: Vec<gltf::Node> = match document
        .default_scene()
        .or_else(|| document.scenes().next())
    {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; document.nodes().len()];
            for n in document.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            document.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    let mut visited = vec![false; document.nodes().len()];
    let mut out = Vec::new();
    let mut stack: Vec<(gltf::Node, Mat4)> = roots
        .into_iter()
        .rev()
        .map(|n| (n, Mat4::IDENTITY))
        .collect();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            continue;
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        let children: Vec<gltf::Node> = node.children().collect();
        stack.extend(children.into_iter().rev().map(|c| (c, world)));
        out.push((node, world));
    }
    out
}

/// `node 3 `name`` or `node 3`, for messages.
fn node_label(node: &gltf::Node) -> String {
    match node.name() {
        Some(n) => format!("node {} `{n}`", node.index()),
        None => format!("node {}", node.index()),
    }
}

/// The node's `extras.slothsim` object, if any.
fn slothsim_extras(node: &gltf::Node) -> Result<Option<serde_json::Map<String, Value>>, String> {
    let Some(raw) = node.extras() else {
        return Ok(None);
    };
    let Ok(Value::Object(mut extras)) = serde_json::from_str::<Value>(raw.get()) else {
        return Ok(None);
    };
    match extras.remove(EXTRAS_KEY) {
        None => Ok(None),
        Some(Value::Object(block)) => Ok(Some(block)),
        Some(other) => Err(format!(
            "extras.{EXTRAS_KEY} must be an object, is `{other}`"
        )),
    }
}

/// A support exactly as described by `extras.slothsim` (axis in node space).
fn tagged_support(
    ctx: &Ctx,
    node: &gltf::Node,
    mesh: &gltf::Mesh,
    world: Mat4,
    block: &serde_json::Map<String, Value>,
    label: &str,
) -> Result<Support, SceneError> {
    let field_err = |field: &str, detail: String| {
        ctx.err(format!("{label}: extras.{EXTRAS_KEY}.{field}: {detail}"))
    };
    let kind = match block.get("kind") {
        Some(Value::String(s)) => SupportKind::parse(s).ok_or_else(|| {
            field_err(
                "kind",
                format!("expected \"trunk\" or \"branch\", got \"{s}\""),
            )
        })?,
        Some(other) => {
            return Err(field_err(
                "kind",
                format!("expected a string, got `{other}`"),
            ));
        }
        None => return Err(field_err("kind", "missing".into())),
    };
    let flag = |field: &str, default: bool| match block.get(field) {
        None => Ok(default),
        Some(Value::Bool(b)) => Ok(*b),
        Some(other) => Err(field_err(
            field,
            format!("expected true or false, got `{other}`"),
        )),
    };
    let tagged = flag("tagged", true)?;
    let keep_mesh = flag("mesh", false)?;
    let name_generated = flag("name_generated", false)?;

    let number = |v: &Value| v.as_f64().map(|x| x as f32).unwrap_or(f32::NAN);
    let axis_json = match block.get("axis") {
        Some(Value::Array(a)) => a,
        Some(other) => {
            return Err(field_err(
                "axis",
                format!("expected an array, got `{other}`"),
            ));
        }
        None => return Err(field_err("axis", "missing".into())),
    };
    let radii_json = match block.get("radii") {
        Some(Value::Array(a)) => a,
        Some(other) => {
            return Err(field_err(
                "radii",
                format!("expected an array, got `{other}`"),
            ));
        }
        None => return Err(field_err("radii", "missing".into())),
    };
    let mut axis = Vec::with_capacity(axis_json.len());
    for (i, p) in axis_json.iter().enumerate() {
        let xyz = match p {
            Value::Array(c) if c.len() == 3 => {
                Vec3::new(number(&c[0]), number(&c[1]), number(&c[2]))
            }
            _ => Vec3::NAN,
        };
        if !xyz.is_finite() {
            return Err(field_err(
                "axis",
                format!("node {i} must be three finite numbers [x, y, z], is `{p}`"),
            ));
        }
        axis.push(xyz);
    }
    let mut radii = Vec::with_capacity(radii_json.len());
    for (i, r) in radii_json.iter().enumerate() {
        let value = number(r);
        if !(value.is_finite() && value > 0.0) {
            let shown = if r.is_null() {
                "null (NaN)".to_string()
            } else {
                r.to_string()
            };
            return Err(field_err(
                "radii",
                format!("radius {i} must be finite and > 0, is {shown}"),
            ));
        }
        radii.push(value);
    }
    if axis.len() < 2 {
        return Err(field_err(
            "axis",
            format!("needs at least 2 nodes, has {}", axis.len()),
        ));
    }
    if radii.len() != axis.len() {
        return Err(field_err(
            "radii",
            format!("has {} values for {} axis nodes", radii.len(), axis.len()),
        ));
    }
    if world != Mat4::IDENTITY {
        let scale = mean_scale(world);
        for p in &mut axis {
            *p = world.transform_point3(*p);
        }
        for r in &mut radii {
            *r *= scale;
        }
        if axis.iter().any(|p| !p.is_finite()) || radii.iter().any(|r| !(r.is_finite() && *r > 0.0))
        {
            return Err(ctx.err(format!(
                "{label}: node transform makes the axis or radii degenerate"
            )));
        }
    }
    for (i, w) in axis.windows(2).enumerate() {
        let len = w[0].distance(w[1]);
        if len < MIN_SEGMENT {
            return Err(field_err(
                "axis",
                format!("segment {i} has zero length ({len} m)"),
            ));
        }
    }

    let node_name = node.name().map(str::to_string);
    let generated = node_name.as_deref().is_none_or(is_generated_name);
    let mut support = Support::new(axis, radii);
    support.kind = kind;
    support.tagged = tagged;
    support.name = if name_generated && generated {
        None
    } else {
        node_name
    };
    if keep_mesh {
        let (positions, triangles) = read_triangles(ctx, mesh, world, label)?;
        if !triangles.is_empty() {
            support.mesh = Some(TriMesh {
                positions,
                triangles,
            });
        }
    }
    Ok(support)
}

/// `trunk_<n>` / `branch_<n>`: the names export makes up for unnamed supports.
fn is_generated_name(name: &str) -> bool {
    let rest = name
        .strip_prefix("trunk_")
        .or_else(|| name.strip_prefix("branch_"));
    rest.is_some_and(|d| !d.is_empty() && d.bytes().all(|b| b.is_ascii_digit()))
}

/// Cube root of |det| of the linear part: the scale applied to radii.
fn mean_scale(world: Mat4) -> f32 {
    glam::Mat3::from_mat4(world).determinant().abs().cbrt()
}

/// `trunk…` / `branch…` (case-insensitive) tags the kind.
fn kind_from_name(name: &str) -> Option<SupportKind> {
    let lower = name.to_ascii_lowercase();
    if lower.starts_with("trunk") {
        Some(SupportKind::Trunk)
    } else if lower.starts_with("branch") {
        Some(SupportKind::Branch)
    } else {
        None
    }
}

/// All TRIANGLES primitives of `mesh` (indexed or not) in world space,
/// concatenated in primitive order. Other modes and primitives without
/// POSITION are skipped; normals are ignored.
fn read_triangles(
    ctx: &Ctx,
    mesh: &gltf::Mesh,
    world: Mat4,
    label: &str,
) -> Result<(Vec<Vec3>, Vec<[u32; 3]>), SceneError> {
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for primitive in mesh.primitives() {
        if primitive.mode() != gltf::mesh::Mode::Triangles {
            continue;
        }
        let prim_err = |detail: String| {
            ctx.err(format!(
                "{label}: primitive {}: {detail}",
                primitive.index()
            ))
        };
        let Some(pos_accessor) = primitive.get(&gltf::Semantic::Positions) else {
            continue;
        };
        check_accessor(&pos_accessor, ctx.buffers, AccessorUse::Positions)
            .map_err(|d| prim_err(format!("POSITION accessor {}: {d}", pos_accessor.index())))?;
        if pos_accessor.count() == 0 {
            continue;
        }
        let reader = primitive.reader(|b| ctx.buffers.get(b.index()).map(|d| &d.0[..]));
        let Some(read) = reader.read_positions() else {
            return Err(prim_err("POSITION data lies outside its buffer".into()));
        };
        let first = positions.len() as u32;
        for p in read {
            let p = world.transform_point3(Vec3::from_array(p));
            if !p.is_finite() {
                return Err(prim_err(format!(
                    "vertex {} is not finite",
                    positions.len() as u32 - first
                )));
            }
            positions.push(p);
        }
        let count = positions.len() as u32 - first;
        let indices: Vec<u32> = match primitive.indices() {
            Some(acc) => {
                check_accessor(&acc, ctx.buffers, AccessorUse::Indices)
                    .map_err(|d| prim_err(format!("index accessor {}: {d}", acc.index())))?;
                if acc.count() == 0 {
                    continue;
                }
                let Some(read) = reader.read_indices() else {
                    return Err(prim_err("index data lies outside its buffer".into()));
                };
                read.into_u32().collect()
            }
            None => (0..count).collect(),
        };
        if let Some(&bad) = indices.iter().find(|&&i| i >= count) {
            return Err(prim_err(format!(
                "index {bad} out of range ({count} vertices)"
            )));
        }
        triangles.extend(
            indices
                .chunks_exact(3)
                .map(|t| [t[0] + first, t[1] + first, t[2] + first]),
        );
    }
    Ok((positions, triangles))
}

/// What an accessor is read as.
#[derive(Clone, Copy, PartialEq)]
enum AccessorUse {
    Positions,
    Indices,
}

/// Checks what the `gltf` reader assumes but does not verify (it panics or
/// overflows otherwise): a dense accessor of the right type whose elements lie
/// inside its view, and a view inside its loaded buffer. Count 0 is fine.
fn check_accessor(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
    usage: AccessorUse,
) -> Result<(), String> {
    use gltf::accessor::{DataType, Dimensions};
    if acc.sparse().is_some() {
        return Err("sparse accessors are not supported".into());
    }
    let type_ok = match usage {
        AccessorUse::Positions => {
            acc.data_type() == DataType::F32 && acc.dimensions() == Dimensions::Vec3
        }
        AccessorUse::Indices => {
            matches!(
                acc.data_type(),
                DataType::U8 | DataType::U16 | DataType::U32
            ) && acc.dimensions() == Dimensions::Scalar
        }
    };
    if !type_ok {
        return Err(format!(
            "unexpected type {:?} {:?}",
            acc.data_type(),
            acc.dimensions()
        ));
    }
    if acc.count() == 0 {
        return Ok(());
    }
    let Some(view) = acc.view() else {
        return Err("has no buffer view".into());
    };
    let size = acc.size();
    let stride = view.stride().unwrap_or(size);
    if stride < size {
        return Err(format!(
            "byte stride {stride} is smaller than an element ({size} bytes)"
        ));
    }
    let end = stride
        .checked_mul(acc.count() - 1)
        .and_then(|n| n.checked_add(size))
        .and_then(|n| n.checked_add(acc.offset()));
    if end.is_none_or(|end| end > view.length()) {
        return Err(format!(
            "{} elements at offset {} do not fit its buffer view ({} bytes)",
            acc.count(),
            acc.offset(),
            view.length()
        ));
    }
    let buffer_len = buffers.get(view.buffer().index()).map_or(0, |d| d.len());
    if view
        .offset()
        .checked_add(view.length())
        .is_none_or(|end| end > buffer_len)
    {
        return Err(format!(
            "buffer view {} ({} bytes at offset {}) lies outside its buffer ({buffer_len} bytes)",
            view.index(),
            view.length(),
            view.offset()
        ));
    }
    Ok(())
}
