//! `assets/sloth.glb`: the default sloth skeleton ([`slothsim_rig::Rig::sloth`]) with a
//! skinned low-poly mesh and joint limits in node `extras` (`{"slothsim": {"limit": …}}`).
//! Deterministic: same bytes on every run.
//!
//! The mesh (bind pose = the rig's rest pose) is one continuous body (rump, torso, neck,
//! head lofted along the spine joints) and four limbs, each a continuous tube from its
//! girdle joint to a pointed claw at its tip. Every vertex is weighted across the bone it
//! lies on and, near a joint, the neighbouring bone (50/50 at the joint, smoothstep to
//! all its own over 35 % of the bone), so bends deform smoothly instead of opening
//! gaps between rigid pieces. Smooth normals; one fur-coloured material.

use std::collections::BTreeMap;

use anyhow::Context;
use glam::{Affine3A, Mat4, Vec3};
use gltf_json as json;
use json::validation::{Checked, USize64};
use slothsim_rig::Rig;
use slothsim_rig::rig::{NodeExtras, SlothExtras};

/// Vertices around a limb ring.
const LIMB_SIDES: usize = 16;
/// Vertices around a body ring.
const BODY_SIDES: usize = 24;
/// Rings per limb bone (the ring at the bone's start included; the tip ring is extra).
const LIMB_RINGS_PER_BONE: usize = 8;
/// Share of a bone's length, at each end, over which its weight blends with
/// the neighbouring bone's (50/50 at the joint, all its own beyond).
const BLEND: f32 = 0.35;

struct MeshData {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    joints: Vec<[u16; 4]>,
    weights: Vec<[f32; 4]>,
    indices: Vec<u16>,
}

impl MeshData {
    fn vertex(&mut self, p: Vec3, influences: &[(usize, f32)]) -> u16 {
        let mut j = [0u16; 4];
        let mut w = [0.0f32; 4];
        let total: f32 = influences.iter().map(|(_, w)| w).sum();
        for (k, &(joint, weight)) in influences.iter().take(4).enumerate() {
            j[k] = u16::try_from(joint).expect("small skeleton");
            w[k] = weight / total;
        }
        self.positions.push(p);
        self.normals.push(Vec3::ZERO);
        self.joints.push(j);
        self.weights.push(w);
        u16::try_from(self.positions.len() - 1).expect("mesh under 65k vertices")
    }

    /// Quads between consecutive rings of `sides` vertices each.
    fn stitch(&mut self, rings: &[u16], sides: usize) {
        let s = u16::try_from(sides).expect("small");
        for pair in rings.windows(2) {
            let (a, b) = (pair[0], pair[1]);
            for k in 0..s {
                let k1 = (k + 1) % s;
                self.indices
                    .extend_from_slice(&[a + k, a + k1, b + k, a + k1, b + k1, b + k]);
            }
        }
    }

    /// A fan from the ring starting at `ring` to the pole vertex `pole`
    /// (`outward`: the pole is after the ring along the tube).
    fn cap(&mut self, ring: u16, sides: usize, pole: u16, outward: bool) {
        let s = u16::try_from(sides).expect("small");
        for k in 0..s {
            let k1 = (k + 1) % s;
            if outward {
                self.indices.extend_from_slice(&[ring + k, ring + k1, pole]);
            } else {
                self.indices.extend_from_slice(&[ring + k1, ring + k, pole]);
            }
        }
    }

    /// Smooth normals: area-weighted face normals summed per vertex.
    fn smooth_normals(&mut self) {
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(usize::from);
            let n = (self.positions[b] - self.positions[a])
                .cross(self.positions[c] - self.positions[a]);
            for i in [a, b, c] {
                self.normals[i] += n;
            }
        }
        for n in &mut self.normals {
            *n = n.normalize_or(Vec3::Y);
        }
    }
}

/// Weights of a point at fraction `f` (0..1) along the bone of joint `own`,
/// blending toward `before` (the bone ending at its start) and `after` (the
/// bone starting at its end): 50/50 at each joint, smoothstep over [`BLEND`].
fn blend(own: usize, before: Option<usize>, after: Option<usize>, f: f32) -> Vec<(usize, f32)> {
    let ramp = |x: f32| {
        let x = (x / BLEND).clamp(0.0, 1.0);
        0.5 * (1.0 - x * x * (3.0 - 2.0 * x))
    };
    let mut v = vec![(own, 1.0)];
    if let Some(b) = before {
        let w = ramp(f);
        if w > 0.0 {
            v.push((b, w));
            v[0].1 -= w;
        }
    }
    if let Some(a) = after {
        let w = ramp(1.0 - f);
        if w > 0.0 {
            v.push((a, w));
            v[0].1 -= w;
        }
    }
    v
}

/// The torso, neck and head as one lofted tube along the spine joints, with
/// an elliptical section (half-width, half-height in metres) per station.
fn build_body(m: &mut MeshData, rig: &Rig, model: &[Affine3A]) {
    let skel = rig.skeleton();
    let at = |name: &str| {
        let i = skel.find(name).expect("default rig joint");
        (i, Vec3::from(model[i].translation))
    };
    let spine = ["Hips", "Spine", "Chest", "Neck", "Head", "HeadTip"].map(at);
    // Stations: (z, half-width, half-height); z from rump to nose.
    const STATIONS: [(f32, f32, f32); 22] = [
        (-0.350, 0.045, 0.040),
        (-0.335, 0.075, 0.068),
        (-0.310, 0.095, 0.088),
        (-0.275, 0.108, 0.100),
        (-0.230, 0.115, 0.108),
        (-0.180, 0.120, 0.112),
        (-0.120, 0.124, 0.116),
        (-0.060, 0.125, 0.118),
        (0.000, 0.122, 0.116),
        (0.060, 0.115, 0.110),
        (0.120, 0.104, 0.100),
        (0.170, 0.090, 0.088),
        (0.215, 0.072, 0.072),
        (0.255, 0.060, 0.062),
        (0.295, 0.058, 0.060),
        (0.335, 0.066, 0.066),
        (0.375, 0.074, 0.072),
        (0.415, 0.073, 0.070),
        (0.450, 0.062, 0.058),
        (0.480, 0.046, 0.042),
        (0.500, 0.030, 0.028),
        (0.512, 0.014, 0.013),
    ];
    let mut rings = Vec::new();
    for (z, rx, ry) in STATIONS {
        // The spine segment under z (the rump hangs off the hips, the nose off the head).
        let seg = (0..spine.len() - 1)
            .find(|&k| z < spine[k + 1].1.z)
            .unwrap_or(spine.len() - 2);
        let (a, b) = (spine[seg].1, spine[seg + 1].1);
        let f = ((z - a.z) / (b.z - a.z)).clamp(-1.0, 1.0);
        let centre = a + (b - a) * f.max(0.0);
        let centre = Vec3::new(centre.x, centre.y, z);
        let before = (seg > 0).then(|| spine[seg - 1].0);
        let after = (seg + 2 < spine.len() - 1).then(|| spine[seg + 1].0);
        let w = blend(spine[seg].0, before, after, f.max(0.0));
        let first = u16::try_from(m.positions.len()).expect("small mesh");
        for k in 0..BODY_SIDES {
            let t = k as f32 / BODY_SIDES as f32 * std::f32::consts::TAU;
            // Counter-clockwise seen from the nose (+Z): outward-facing quads.
            let p = centre + Vec3::new(rx * t.cos(), ry * t.sin(), 0.0);
            m.vertex(p, &w);
        }
        rings.push(first);
    }
    m.stitch(&rings, BODY_SIDES);
    let rump = m.vertex(
        Vec3::new(0.0, spine[0].1.y, STATIONS[0].0 - 0.01),
        &[(spine[0].0, 1.0)],
    );
    let nose = m.vertex(
        Vec3::new(0.0, spine[5].1.y, STATIONS[STATIONS.len() - 1].0 + 0.004),
        &[(spine[4].0, 1.0)],
    );
    m.cap(rings[0], BODY_SIDES, rump, false);
    m.cap(rings[rings.len() - 1], BODY_SIDES, nose, true);
}

/// Limb tube radius (m) at fraction `s` (0 = girdle joint, 1 = claw tip) of
/// the limb's length: a thick upper limb tapering to a pointed claw.
fn limb_radius(s: f32) -> f32 {
    const PROFILE: [(f32, f32); 7] = [
        (0.00, 0.040),
        (0.15, 0.034),
        (0.50, 0.027),
        (0.78, 0.022),
        (0.84, 0.020),
        (0.93, 0.011),
        (1.00, 0.004),
    ];
    for w in PROFILE.windows(2) {
        let ((s0, r0), (s1, r1)) = (w[0], w[1]);
        if s <= s1 {
            return r0 + (r1 - r0) * ((s - s0) / (s1 - s0)).clamp(0.0, 1.0);
        }
    }
    PROFILE[PROFILE.len() - 1].1
}

/// One limb as a continuous tube along its joints (girdle → claw tip), each
/// ring at right angles to its bone (at a joint: to the mean of the two
/// bones), its frame carried along the limb without twist.
fn build_limb(m: &mut MeshData, rig: &Rig, model: &[Affine3A], limb: slothsim_rig::Limb) {
    let lj = rig.limb_joints(limb);
    let tip = lj.tip.expect("default rig has claw tips");
    let nodes: Vec<usize> = lj.joints.iter().copied().chain([tip]).collect();
    let pts: Vec<Vec3> = nodes
        .iter()
        .map(|&i| Vec3::from(model[i].translation))
        .collect();
    let total: f32 = pts.windows(2).map(|w| w[0].distance(w[1])).sum();
    let mut along = 0.0;
    let mut frame_u: Option<Vec3> = None;
    let mut rings = Vec::new();
    for bone in 0..4 {
        let (a, b) = (pts[bone], pts[bone + 1]);
        let len = a.distance(b);
        let dir = (b - a) / len;
        let before = Some(if bone == 0 {
            lj.chain_root
        } else {
            nodes[bone - 1]
        });
        let after = (bone < 3).then(|| nodes[bone + 1]);
        let last = bone == 3;
        let count = LIMB_RINGS_PER_BONE + usize::from(last);
        for r in 0..count {
            let f = r as f32 / LIMB_RINGS_PER_BONE as f32;
            let centre = a + (b - a) * f;
            let normal = if r == 0 && bone > 0 {
                ((pts[bone] - pts[bone - 1]).normalize() + dir).normalize()
            } else {
                dir
            };
            // Parallel transport of the ring frame.
            let u = match frame_u {
                Some(u) => {
                    (u - normal * u.dot(normal)).normalize_or(normal.any_orthogonal_vector())
                }
                None => normal.any_orthonormal_pair().0,
            };
            frame_u = Some(u);
            let v = normal.cross(u);
            let radius = limb_radius((along + f * len) / total);
            let w = blend(nodes[bone], before, after, f);
            let first = u16::try_from(m.positions.len()).expect("small mesh");
            for k in 0..LIMB_SIDES {
                let t = k as f32 / LIMB_SIDES as f32 * std::f32::consts::TAU;
                m.vertex(centre + (u * t.cos() + v * t.sin()) * radius, &w);
            }
            rings.push(first);
        }
        along += len;
    }
    m.stitch(&rings, LIMB_SIDES);
    let hand = nodes[3];
    let start = m.vertex(
        pts[0] - (pts[1] - pts[0]).normalize() * 0.01,
        &[(nodes[0], 1.0)],
    );
    let end = m.vertex(
        pts[4] + (pts[4] - pts[3]).normalize() * 0.004,
        &[(hand, 1.0)],
    );
    m.cap(rings[0], LIMB_SIDES, start, false);
    m.cap(rings[rings.len() - 1], LIMB_SIDES, end, true);
}

/// The body and four limb tubes, smoothly weighted across the two bones at
/// each joint, in the rig's bind (rest) pose.
fn build_mesh(rig: &Rig, model: &[Affine3A]) -> MeshData {
    let mut m = MeshData {
        positions: vec![],
        normals: vec![],
        joints: vec![],
        weights: vec![],
        indices: vec![],
    };
    build_body(&mut m, rig, model);
    for limb in slothsim_rig::Limb::ALL {
        build_limb(&mut m, rig, model, limb);
    }
    m.smooth_normals();
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
        min = min.min(*p);
        max = max.max(*p);
    }
    let n = mesh.positions.len();
    let pos = add_accessor(
        &mut root,
        &mut bin,
        &f32_bytes(mesh.positions.iter().flat_map(|p| p.to_array())),
        n,
        C::F32,
        T::Vec3,
        Some(json::buffer::Target::ArrayBuffer),
        Some((
            serde_json::json!(min.to_array()),
            serde_json::json!(max.to_array()),
        )),
    );
    let normals = add_accessor(
        &mut root,
        &mut bin,
        &f32_bytes(mesh.normals.iter().flat_map(|p| p.to_array())),
        n,
        C::F32,
        T::Vec3,
        Some(json::buffer::Target::ArrayBuffer),
        None,
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
    attributes.insert(Checked::Valid(json::mesh::Semantic::Normals), normals);
    attributes.insert(Checked::Valid(json::mesh::Semantic::Joints(0)), joints);
    attributes.insert(Checked::Valid(json::mesh::Semantic::Weights(0)), weights);
    let fur = root.push(json::Material {
        name: Some("SlothFur".into()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor([0.55, 0.47, 0.36, 1.0]),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.95),
            ..Default::default()
        },
        ..Default::default()
    });
    let mesh_index = root.push(json::Mesh {
        extensions: None,
        extras: Default::default(),
        name: Some("SlothBody".into()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: Default::default(),
            indices: Some(indices),
            material: Some(fur),
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
