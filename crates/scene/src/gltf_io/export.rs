//! Scene → glTF document (JSON root + one binary buffer).
//!
//! Layout: every support becomes one node (identity transform, geometry in
//! world space) with one mesh of one TRIANGLES primitive, and the scene lists
//! the nodes in support order. Per support the buffer holds, 4-byte aligned:
//! POSITION (f32 VEC3, with min/max), NORMAL (f32 VEC3) and indices (u32), each
//! in its own buffer view. Capsule supports are tessellated as tubes with
//! hemispherical end caps; supports with an imported mesh export that mesh
//! verbatim (same vertex order, same triangles) with area-weighted normals.

use glam::{Quat, Vec3};
use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use serde::Serialize;

use super::{CAP_RINGS, SIDES};
use crate::{Scene, Support, SupportKind};

/// The `extras.slothsim` block of an exported node (see the module docs of
/// `gltf_io` for the schema).
#[derive(Serialize)]
struct SupportExtras<'a> {
    kind: &'static str,
    tagged: bool,
    axis: Vec<[f32; 3]>,
    radii: &'a [f32],
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    mesh: bool,
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    name_generated: bool,
}

#[derive(Serialize)]
struct NodeExtras<'a> {
    #[serde(rename = "slothsim")]
    slothsim: SupportExtras<'a>,
}

/// Triangle surface of one support, ready to be written.
struct Surface {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    indices: Vec<u32>,
}

/// Builds the glTF root and the (unpadded) binary buffer for `scene`.
/// `uri` is the buffer's URI (`None` for the GLB `BIN` chunk).
pub(super) fn build(
    scene: &Scene,
    uri: impl FnOnce(&[u8]) -> Option<String>,
) -> (json::Root, Vec<u8>) {
    let mut root = json::Root {
        asset: json::Asset {
            generator: Some(concat!("slothsim-scene ", env!("CARGO_PKG_VERSION")).to_string()),
            ..Default::default()
        },
        ..Default::default()
    };
    let trunk_material = root.push(material("bark_trunk", [0.36, 0.25, 0.17, 1.0]));
    let branch_material = root.push(material("bark_branch", [0.45, 0.33, 0.22, 1.0]));

    let mut bin: Vec<u8> = Vec::new();
    let buffer_index = json::Index::<json::Buffer>::new(0);
    let mut node_indices = Vec::with_capacity(scene.supports().len());

    for support in scene.supports() {
        let surface = match &support.mesh {
            Some(mesh) => mesh_surface(&mesh.positions, &mesh.triangles),
            None => tube_surface(support),
        };
        let label = node_name(support);

        let positions =
            push_vec3_accessor(&mut root, &mut bin, buffer_index, &surface.positions, true);
        let normals =
            push_vec3_accessor(&mut root, &mut bin, buffer_index, &surface.normals, false);
        let indices = push_index_accessor(&mut root, &mut bin, buffer_index, &surface.indices);

        let mut attributes = std::collections::BTreeMap::new();
        attributes.insert(Valid(json::mesh::Semantic::Positions), positions);
        attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
        let mesh = root.push(json::Mesh {
            extensions: None,
            extras: None,
            name: Some(label.clone()),
            primitives: vec![json::mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(indices),
                material: Some(match support.kind {
                    SupportKind::Trunk => trunk_material,
                    SupportKind::Branch => branch_material,
                }),
                mode: Valid(json::mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
        });

        let extras = NodeExtras {
            slothsim: SupportExtras {
                kind: support.kind.as_str(),
                tagged: support.tagged,
                axis: support.nodes.iter().map(|n| n.to_array()).collect(),
                radii: &support.radii,
                mesh: support.mesh.is_some(),
                name_generated: support.name.is_none(),
            },
        };
        // Serialising plain f32/bool/str data cannot fail.
        let extras_json = serde_json::to_string(&extras).unwrap_or_default();
        let node = root.push(json::Node {
            camera: None,
            children: None,
            extensions: None,
            extras: json::extras::RawValue::from_string(extras_json).ok(),
            matrix: None,
            mesh: Some(mesh),
            name: Some(label),
            rotation: None,
            scale: None,
            translation: None,
            skin: None,
            weights: None,
        });
        node_indices.push(node);
    }

    if !bin.is_empty() {
        let uri = uri(&bin);
        root.push(json::Buffer {
            byte_length: USize64::from(bin.len()),
            name: None,
            uri,
            extensions: None,
            extras: None,
        });
    }
    // glTF requires a scene to list at least one node: an empty forest has no scene.
    if !node_indices.is_empty() {
        let scene_index = root.push(json::Scene {
            extensions: None,
            extras: None,
            name: Some("slothsim_forest".to_string()),
            nodes: node_indices,
        });
        root.scene = Some(scene_index);
    }
    (root, bin)
}

/// Node (and mesh) name: the support's name, else `trunk_<id>` / `branch_<id>`.
pub(super) fn node_name(support: &Support) -> String {
    match &support.name {
        Some(n) => n.clone(),
        None => generated_name(support.kind, support.id.0),
    }
}

/// The name given to an unnamed support on export.
pub(super) fn generated_name(kind: SupportKind, id: u32) -> String {
    format!("{}_{id}", kind.as_str())
}

fn material(name: &str, rgba: [f32; 4]) -> json::Material {
    json::Material {
        name: Some(name.to_string()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(rgba),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.9),
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Appends `bytes` to the buffer (4-byte aligned) and adds a view over them.
fn push_view(
    root: &mut json::Root,
    bin: &mut Vec<u8>,
    buffer: json::Index<json::Buffer>,
    bytes: &[u8],
    target: json::buffer::Target,
) -> json::Index<json::buffer::View> {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let offset = bin.len();
    bin.extend_from_slice(bytes);
    root.push(json::buffer::View {
        buffer,
        byte_length: USize64::from(bytes.len()),
        byte_offset: Some(USize64::from(offset)),
        byte_stride: None,
        name: None,
        target: Some(Valid(target)),
        extensions: None,
        extras: None,
    })
}

fn push_vec3_accessor(
    root: &mut json::Root,
    bin: &mut Vec<u8>,
    buffer: json::Index<json::Buffer>,
    data: &[Vec3],
    with_bounds: bool,
) -> json::Index<json::Accessor> {
    let bytes: Vec<u8> = data
        .iter()
        .flat_map(|v| v.to_array())
        .flat_map(f32::to_le_bytes)
        .collect();
    let view = push_view(root, bin, buffer, &bytes, json::buffer::Target::ArrayBuffer);
    let (min, max) = if with_bounds {
        let min = data.iter().fold(Vec3::INFINITY, |a, b| a.min(*b));
        let max = data.iter().fold(Vec3::NEG_INFINITY, |a, b| a.max(*b));
        (
            Some(serde_json::json!(min.to_array())),
            Some(serde_json::json!(max.to_array())),
        )
    } else {
        (None, None)
    };
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: None,
        count: USize64::from(data.len()),
        component_type: Valid(json::accessor::GenericComponentType(
            json::accessor::ComponentType::F32,
        )),
        extensions: None,
        extras: None,
        type_: Valid(json::accessor::Type::Vec3),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    })
}

fn push_index_accessor(
    root: &mut json::Root,
    bin: &mut Vec<u8>,
    buffer: json::Index<json::Buffer>,
    indices: &[u32],
) -> json::Index<json::Accessor> {
    let bytes: Vec<u8> = indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let view = push_view(
        root,
        bin,
        buffer,
        &bytes,
        json::buffer::Target::ElementArrayBuffer,
    );
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: None,
        count: USize64::from(indices.len()),
        component_type: Valid(json::accessor::GenericComponentType(
            json::accessor::ComponentType::U32,
        )),
        extensions: None,
        extras: None,
        type_: Valid(json::accessor::Type::Scalar),
        min: None,
        max: None,
        name: None,
        normalized: false,
        sparse: None,
    })
}

/// An imported mesh, written verbatim, with area-weighted vertex normals
/// (+Y for vertices that touch only degenerate triangles).
fn mesh_surface(positions: &[Vec3], triangles: &[[u32; 3]]) -> Surface {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let n = (b - a).cross(c - a); // length = 2 × area: area weighting
        for &i in t {
            normals[i as usize] += n;
        }
    }
    let normals = normals
        .into_iter()
        .map(|n| n.try_normalize().unwrap_or(Vec3::Y))
        .collect();
    Surface {
        positions: positions.to_vec(),
        normals,
        indices: triangles.iter().flatten().copied().collect(),
    }
}

/// One ring of the tube profile: centre, radius, frame and how far its
/// normals lean along the axis (`sin` of the cap latitude, signed).
struct Ring {
    centre: Vec3,
    radius: f32,
    u: Vec3,
    v: Vec3,
    axial: Vec3,
}

/// Tessellates a capsule support: a ring of [`SIDES`] vertices per axis node
/// (frames carried by parallel transport so the tube does not twist),
/// [`CAP_RINGS`] − 1 latitude rings plus a pole vertex per hemispherical
/// end cap. Triangles wind counter-clockwise seen from outside.
fn tube_surface(support: &Support) -> Surface {
    let nodes = &support.nodes;
    let n = nodes.len();
    let seg_dir: Vec<Vec3> = nodes
        .windows(2)
        .map(|w| (w[1] - w[0]).normalize_or_zero())
        .collect();
    let tangent = |i: usize| -> Vec3 {
        let prev = if i > 0 { seg_dir[i - 1] } else { Vec3::ZERO };
        let next = if i + 1 < n { seg_dir[i] } else { Vec3::ZERO };
        (prev + next)
            .try_normalize()
            .or_else(|| next.try_normalize())
            .or_else(|| prev.try_normalize())
            .unwrap_or(Vec3::Y)
    };

    // Frames by parallel transport.
    let mut frames = Vec::with_capacity(n);
    let t0 = tangent(0);
    let mut u = t0.any_orthonormal_vector();
    let mut t_prev = t0;
    for i in 0..n {
        let t = tangent(i);
        u = Quat::from_rotation_arc(t_prev, t) * u;
        u = (u - t * u.dot(t))
            .try_normalize()
            .unwrap_or_else(|| t.any_orthonormal_vector());
        frames.push((t, u, t.cross(u)));
        t_prev = t;
    }

    // Profile rings from the start pole to the end pole.
    let mut rings = Vec::with_capacity(n + 2 * CAP_RINGS);
    let lat = |k: usize| (k as f32) * std::f32::consts::FRAC_PI_2 / CAP_RINGS as f32;
    let (ts, us, vs) = frames[0];
    for k in (1..CAP_RINGS).rev() {
        let (s, c) = lat(k).sin_cos();
        rings.push(Ring {
            centre: nodes[0] - ts * support.radii[0] * s,
            radius: support.radii[0] * c,
            u: us,
            v: vs,
            axial: -ts * s,
        });
    }
    for i in 0..n {
        let (_, u, v) = frames[i];
        rings.push(Ring {
            centre: nodes[i],
            radius: support.radii[i],
            u,
            v,
            axial: Vec3::ZERO,
        });
    }
    let (te, ue, ve) = frames[n - 1];
    for k in 1..CAP_RINGS {
        let (s, c) = lat(k).sin_cos();
        rings.push(Ring {
            centre: nodes[n - 1] + te * support.radii[n - 1] * s,
            radius: support.radii[n - 1] * c,
            u: ue,
            v: ve,
            axial: te * s,
        });
    }

    let mut positions = Vec::with_capacity(rings.len() * SIDES + 2);
    let mut normals = Vec::with_capacity(positions.capacity());
    positions.push(nodes[0] - ts * support.radii[0]);
    normals.push(-ts);
    for ring in &rings {
        let cos_lat = (1.0 - ring.axial.length_squared()).max(0.0).sqrt();
        for j in 0..SIDES {
            let (s, c) = (j as f32 * std::f32::consts::TAU / SIDES as f32).sin_cos();
            let radial = ring.u * c + ring.v * s;
            positions.push(ring.centre + radial * ring.radius);
            normals.push((radial * cos_lat + ring.axial).normalize_or(radial));
        }
    }
    let end_pole = positions.len() as u32;
    positions.push(nodes[n - 1] + te * support.radii[n - 1]);
    normals.push(te);

    let ring_start = |r: usize| 1 + (r * SIDES) as u32;
    let mut indices = Vec::with_capacity((rings.len() + 1) * SIDES * 6);
    for j in 0..SIDES as u32 {
        let j1 = (j + 1) % SIDES as u32;
        // Start pole fan.
        indices.extend_from_slice(&[0, ring_start(0) + j1, ring_start(0) + j]);
        // Quads between consecutive rings.
        for r in 0..rings.len() - 1 {
            let (a, b) = (ring_start(r) + j, ring_start(r) + j1);
            let (d, c) = (ring_start(r + 1) + j, ring_start(r + 1) + j1);
            indices.extend_from_slice(&[a, b, c, a, c, d]);
        }
        // End pole fan.
        let last = ring_start(rings.len() - 1);
        indices.extend_from_slice(&[last + j, last + j1, end_pole]);
    }
    Surface {
        positions,
        normals,
        indices,
    }
}
