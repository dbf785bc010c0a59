//! `assets/sloth.glb`: the default sloth skeleton ([`slothsim_rig::Rig::sloth`]) with a
//! rigidly skinned low-poly mesh (one hexagonal prism per bone) and joint limits in node
//! `extras` (`{"slothsim": {"limit": …}}`). Deterministic: same bytes on every run.

use std::collections::BTreeMap;

use anyhow::Context;
use glam::{Affine3A, Mat4, Vec3};
use gltf_json as json;
use json::validation::{Checked, USize64};
use slothsim_rig::Rig;
use slothsim_rig::rig::{NodeExtras, SlothExtras};

/// Sides of each bone prism.
const SIDES: usize = 6;

/// Prism radius (m) of the bone that starts at the joint called `name`.
fn radius(name: &str) -> f32 {
    match name {
        "Hips" => 0.10,
        "Spine" => 0.11,
        "Chest" => 0.075,
        "Neck" => 0.05,
        "Head" => 0.065,
        n if n.ends_with("Shoulder") || n.ends_with("Pelvis") => 0.035,
        n if n.ends_with("UpperArm") || n.ends_with("Thigh") => 0.03,
        n if n.ends_with("ForeArm") || n.ends_with("LowerLeg") => 0.025,
        _ => 0.02,
    }
}

struct MeshData {
    positions: Vec<[f32; 3]>,
    joints: Vec<[u16; 4]>,
    weights: Vec<[f32; 4]>,
    indices: Vec<u16>,
}

/// One capped prism per parent→child segment, weighted fully to the parent joint.
fn build_mesh(rig: &Rig, model: &[Affine3A]) -> MeshData {
    let skel = rig.skeleton();
    let mut m = MeshData {
        positions: vec![],
        joints: vec![],
        weights: vec![],
        indices: vec![],
    };
    for child in 0..skel.len() {
        let Some(parent) = skel.parent(child) else {
            continue;
        };
        // Limb roots hang off the body: skip the body→girdle segments (inside the body).
        if skel.names()[child].ends_with("Shoulder") || skel.names()[child].ends_with("Pelvis") {
            continue;
        }
        let a = Vec3::from(model[parent].translation);
        let b = Vec3::from(model[child].translation);
        let r = radius(&skel.names()[parent]);
        let axis = (b - a).normalize_or(Vec3::Y);
        let (u, v) = axis.any_orthonormal_pair();
        let base = u16::try_from(m.positions.len()).expect("small mesh");
        let joint = u16::try_from(parent).expect("small skeleton");
        for end in [a, b] {
            for k in 0..SIDES {
                let t = k as f32 / SIDES as f32 * std::f32::consts::TAU;
                m.positions
                    .push((end + (u * t.cos() + v * t.sin()) * r).to_array());
            }
        }
        m.positions.push(a.to_array());
        m.positions.push(b.to_array());
        for _ in 0..(2 * SIDES + 2) {
            m.joints.push([joint, 0, 0, 0]);
            m.weights.push([1.0, 0.0, 0.0, 0.0]);
        }
        let s = SIDES as u16;
        let (cap_a, cap_b) = (base + 2 * s, base + 2 * s + 1);
        for k in 0..s {
            let k1 = (k + 1) % s;
            let (a0, a1, b0, b1) = (base + k, base + k1, base + s + k, base + s + k1);
            m.indices.extend_from_slice(&[a0, b0, a1, a1, b0, b1]);
            m.indices.extend_from_slice(&[cap_a, a1, a0, cap_b, b0, b1]);
        }
    }
    m
}

/// Byte buffer with 4-byte aligned views.
struct Bin {
    data: Vec<u8>,
}

impl Bin {
    fn push(&mut self, bytes: &[u8]) -> (usize, usize) {
        while !self.data.len().is_multiple_of(4) {
            self.data.push(0);
        }
        let offset = self.data.len();
        self.data.extend_from_slice(bytes);
        (offset, bytes.len())
    }
}

fn f32_bytes(v: impl IntoIterator<Item = f32>) -> Vec<u8> {
    v.into_iter().flat_map(f32::to_le_bytes).collect()
}

fn u16_bytes(v: impl IntoIterator<Item = u16>) -> Vec<u8> {
    v.into_iter().flat_map(u16::to_le_bytes).collect()
}

#[allow(clippy::too_many_arguments)]
fn add_accessor(
    root: &mut json::Root,
    bin: &mut Bin,
    bytes: &[u8],
    count: usize,
    component: json::accessor::ComponentType,
    type_: json::accessor::Type,
    target: Option<json::buffer::Target>,
    min_max: Option<(serde_json::Value, serde_json::Value)>,
) -> json::Index<json::Accessor> {
    let (offset, len) = bin.push(bytes);
    let view = root.push(json::buffer::View {
        buffer: json::Index::new(0),
        byte_length: USize64::from(len),
        byte_offset: Some(USize64::from(offset)),
        byte_stride: None,
        name: None,
        target: target.map(Checked::Valid),
        extensions: None,
        extras: Default::default(),
    });
    let (min, max) = match min_max {
        Some((a, b)) => (Some(a), Some(b)),
        None => (None, None),
    };
    root.push(json::Accessor {
        buffer_view: Some(view),
        byte_offset: Some(USize64(0)),
        count: USize64::from(count),
        component_type: Checked::Valid(json::accessor::GenericComponentType(component)),
        extensions: None,
        extras: Default::default(),
        type_: Checked::Valid(type_),
        min,
        max,
        name: None,
        normalized: false,
        sparse: None,
    })
}

/// Build the GLB bytes of the default sloth rig.
pub fn build_sloth_glb() -> anyhow::Result<Vec<u8>> {
    use json::accessor::{ComponentType as C, Type as T};
    let rig = Rig::sloth();
    let skel = rig.skeleton();
    let mut model = vec![Affine3A::IDENTITY; skel.len()];
    skel.fk(&skel.rest_rotations(), &mut model);
    let mesh = build_mesh(&rig, &model);

    let mut root = json::Root {
        asset: json::Asset {
            copyright: None,
            extensions: None,
            extras: Default::default(),
            generator: Some("slothsim-tools gen-rig".into()),
            min_version: None,
            version: "2.0".into(),
        },
        ..Default::default()
    };
    let mut bin = Bin { data: Vec::new() };

    // Joint nodes, in skeleton (depth-first) order.
    for i in 0..skel.len() {
        let rest = skel.rest()[i];
        let children: Vec<json::Index<json::Node>> = (0..skel.len())
            .filter(|&c| skel.parent(c) == Some(i))
            .map(|c| json::Index::new(u32::try_from(c).expect("small")))
            .collect();
        let extras = match skel.limits()[i] {
            Some(limit) => Some(
                serde_json::value::to_raw_value(&NodeExtras {
                    slothsim: Some(SlothExtras { limit: Some(limit) }),
                })
                .context("serialising limit")?,
            ),
            None => None,
        };
        let rotation = (rest.rotation != glam::Quat::IDENTITY)
            .then(|| json::scene::UnitQuaternion(rest.rotation.to_array()));
        root.push(json::Node {
            children: (!children.is_empty()).then_some(children),
            extras,
            name: Some(skel.names()[i].clone()),
            rotation,
            translation: Some(rest.translation.to_array()),
            ..Default::default()
        });
    }

    let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for p in &mesh.positions {
        min = min.min(Vec3::from(*p));
        max = max.max(Vec3::from(*p));
    }
    let n = mesh.positions.len();
    let pos = add_accessor(
        &mut root,
        &mut bin,
        &f32_bytes(mesh.positions.iter().flatten().copied()),
        n,
        C::F32,
        T::Vec3,
        Some(json::buffer::Target::ArrayBuffer),
        Some((
            serde_json::json!(min.to_array()),
            serde_json::json!(max.to_array()),
        )),
    );
    let joints = add_accessor(
        &mut root,
        &mut bin,
        &u16_bytes(mesh.joints.iter().flatten().copied()),
        n,
        C::U16,
        T::Vec4,
        Some(json::buffer::Target::ArrayBuffer),
        None,
    );
    let weights = add_accessor(
        &mut root,
        &mut bin,
        &f32_bytes(mesh.weights.iter().flatten().copied()),
        n,
        C::F32,
        T::Vec4,
        Some(json::buffer::Target::ArrayBuffer),
        None,
    );
    let indices = add_accessor(
        &mut root,
        &mut bin,
        &u16_bytes(mesh.indices.iter().copied()),
        mesh.indices.len(),
        C::U16,
        T::Scalar,
        Some(json::buffer::Target::ElementArrayBuffer),
        None,
    );
    let ibm = add_accessor(
        &mut root,
        &mut bin,
        &f32_bytes(
            model
                .iter()
                .flat_map(|m| Mat4::from(m.inverse()).to_cols_array()),
        ),
        skel.len(),
        C::F32,
        T::Mat4,
        None,
        None,
    );
    while !bin.data.len().is_multiple_of(4) {
        bin.data.push(0);
    }
    root.push(json::Buffer {
        byte_length: USize64::from(bin.data.len()),
        name: None,
        uri: None,
        extensions: None,
        extras: Default::default(),
    });

    let mut attributes = BTreeMap::new();
    attributes.insert(Checked::Valid(json::mesh::Semantic::Positions), pos);
    attributes.insert(Checked::Valid(json::mesh::Semantic::Joints(0)), joints);
    attributes.insert(Checked::Valid(json::mesh::Semantic::Weights(0)), weights);
    let mesh_index = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("SlothBody".into()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: None,
            mode: Checked::Valid(json::mesh::Mode::Triangles),
            targets: None,
        }],
        weights: None,
    });
    let skin = root.push(json::Skin {
        extensions: None,
        extras: Default::default(),
        inverse_bind_matrices: Some(ibm),
        joints: (0..skel.len())
            .map(|i| json::Index::new(u32::try_from(i).expect("small")))
            .collect(),
        name: Some("SlothSkin".into()),
        skeleton: Some(json::Index::new(0)),
    });
    let mesh_node = root.push(json::Node {
        mesh: Some(mesh_index),
        skin: Some(skin),
        name: Some("SlothMesh".into()),
        ..Default::default()
    });
    let roots: Vec<json::Index<json::Node>> = (0..skel.len())
        .filter(|&i| skel.parent(i).is_none())
        .map(|i| json::Index::new(u32::try_from(i).expect("small")))
        .chain(std::iter::once(mesh_node))
        .collect();
    let scene = root.push(json::Scene {
        extensions: None,
        extras: Default::default(),
        name: Some("Sloth".into()),
        nodes: roots,
    });
    root.scene = Some(scene);

    let mut json_bytes = root.to_vec().context("serialising glTF JSON")?;
    while !json_bytes.len().is_multiple_of(4) {
        json_bytes.push(b' ');
    }
    Ok(glb(&json_bytes, &bin.data))
}

/// Assemble a GLB container (both chunks already 4-byte padded).
fn glb(json_chunk: &[u8], bin_chunk: &[u8]) -> Vec<u8> {
    let total = 12 + 8 + json_chunk.len() + 8 + bin_chunk.len();
    let mut out = Vec::with_capacity(total);
    let u32le = |v: usize| u32::try_from(v).expect("GLB under 4 GiB").to_le_bytes();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&u32le(total));
    out.extend_from_slice(&u32le(json_chunk.len()));
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json_chunk);
    out.extend_from_slice(&u32le(bin_chunk.len()));
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin_chunk);
    out
}
