//! The crowd as binary glTF: the forest (from `slothsim-scene`), one skinned
//! sloth per track, one animation.
//!
//! Layout of the binary chunk: the forest's data, the sloth mesh (shared by
//! every instance), the inverse bind matrices (shared by every skin) and the
//! sample times (shared by every sampler), then one block per track —
//! root translations, root rotations, then each moved joint's rotations, all
//! `f32` — written straight from the [`Recording`] (no second copy in
//! memory). Every instance's nodes start at the first sample's pose, so a
//! viewer without animation shows the start.

use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;

use glam::{Quat, Vec3};
use gltf_json as json;
use json::validation::{Checked::Valid, USize64};
use slothsim_scene::Scene;

use crate::{AtomicFile, ExportError, Recording, SlothModel};

/// What was written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GlbSummary {
    /// File size (bytes).
    pub bytes: u64,
    /// Of which JSON (bytes).
    pub json_bytes: u64,
    /// Sloth instances.
    pub sloths: usize,
    /// Sample times (keyframes per channel).
    pub samples: usize,
}

/// A document ready to be streamed: JSON, the binary data before the
/// tracks, and the total binary length.
struct Document {
    json: Vec<u8>,
    head: Vec<u8>,
    bin_len: usize,
    animated: bool,
}

/// Writes the crowd to `path` (temporary name, renamed at the end).
///
/// # Errors
/// [`ExportError::Io`] (no file is left under `path`), [`ExportError::TooLarge`]
/// when the data exceeds what a GLB can hold (4 GiB).
pub fn write_glb(
    path: &Path,
    scene: &Scene,
    model: &SlothModel,
    rec: &Recording,
) -> Result<GlbSummary, ExportError> {
    let doc = build(scene, model, rec)?;
    let mut file = AtomicFile::create(path)?;
    let summary = stream(&doc, rec, &mut file).map_err(|e| file.error(e))?;
    file.commit()?;
    Ok(summary)
}

/// The crowd as GLB bytes (tests, small exports).
///
/// # Errors
/// [`ExportError::TooLarge`] as [`write_glb`].
pub fn glb_bytes(
    scene: &Scene,
    model: &SlothModel,
    rec: &Recording,
) -> Result<Vec<u8>, ExportError> {
    let doc = build(scene, model, rec)?;
    let mut out = Vec::new();
    stream(&doc, rec, &mut out).map_err(|source| ExportError::Io {
        path: "memory".into(),
        source,
    })?;
    Ok(out)
}

fn stream(doc: &Document, rec: &Recording, w: &mut impl Write) -> std::io::Result<GlbSummary> {
    let total = 12 + 8 + doc.json.len() + 8 + doc.bin_len;
    let u32le = |v: usize| {
        u32::try_from(v)
            .expect("size checked in build")
            .to_le_bytes()
    };
    w.write_all(b"glTF")?;
    w.write_all(&2u32.to_le_bytes())?;
    w.write_all(&u32le(total))?;
    w.write_all(&u32le(doc.json.len()))?;
    w.write_all(b"JSON")?;
    w.write_all(&doc.json)?;
    w.write_all(&u32le(doc.bin_len))?;
    w.write_all(b"BIN\0")?;
    w.write_all(&doc.head)?;
    if doc.animated {
        let mut buf = Vec::with_capacity(rec.track_bytes());
        for t in &rec.tracks {
            buf.clear();
            buf.extend(t.translation.iter().flatten().flat_map(|v| v.to_le_bytes()));
            buf.extend(t.rotation.iter().flatten().flat_map(|v| v.to_le_bytes()));
            for j in &t.joints {
                buf.extend(j.iter().flatten().flat_map(|v| v.to_le_bytes()));
            }
            w.write_all(&buf)?;
        }
    }
    w.flush()?;
    Ok(GlbSummary {
        bytes: total as u64,
        json_bytes: doc.json.len() as u64,
        sloths: rec.tracks.len(),
        samples: rec.times.len(),
    })
}

/// Appends 4-byte aligned data to the binary buffer and adds views and
/// accessors over it.
struct Builder {
    root: json::Root,
    head: Vec<u8>,
}

impl Builder {
    fn view(
        &mut self,
        offset: usize,
        len: usize,
        target: Option<json::buffer::Target>,
    ) -> json::Index<json::buffer::View> {
        self.root.push(json::buffer::View {
            buffer: json::Index::new(0),
            byte_length: USize64::from(len),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: None,
        })
    }

    fn data(
        &mut self,
        bytes: &[u8],
        target: Option<json::buffer::Target>,
    ) -> json::Index<json::buffer::View> {
        while !self.head.len().is_multiple_of(4) {
            self.head.push(0);
        }
        let offset = self.head.len();
        self.head.extend_from_slice(bytes);
        self.view(offset, bytes.len(), target)
    }

    #[allow(clippy::too_many_arguments)]
    fn accessor(
        &mut self,
        view: json::Index<json::buffer::View>,
        offset: usize,
        count: usize,
        component: json::accessor::ComponentType,
        type_: json::accessor::Type,
        min_max: Option<(Vec<f32>, Vec<f32>)>,
    ) -> json::Index<json::Accessor> {
        let (min, max) = match min_max {
            Some((a, b)) => (Some(serde_json::json!(a)), Some(serde_json::json!(b))),
            None => (None, None),
        };
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: (offset > 0).then(|| USize64::from(offset)),
            count: USize64::from(count),
            component_type: Valid(json::accessor::GenericComponentType(component)),
            extensions: None,
            extras: None,
            type_: Valid(type_),
            min,
            max,
            name: None,
            normalized: false,
            sparse: None,
        })
    }
}

fn f32_bytes<const N: usize>(v: &[[f32; N]]) -> Vec<u8> {
    v.iter().flatten().flat_map(|x| x.to_le_bytes()).collect()
}

/// The shared sloth mesh (one primitive, skinned) and its material.
fn sloth_mesh(b: &mut Builder, model: &SlothModel) -> json::Index<json::Mesh> {
    use json::accessor::{ComponentType as C, Type as T};
    use json::buffer::Target::{ArrayBuffer, ElementArrayBuffer};
    let n = model.positions.len();
    let (mut min, mut max) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
    for p in &model.positions {
        min = min.min(Vec3::from(*p));
        max = max.max(Vec3::from(*p));
    }
    let v = b.data(&f32_bytes(&model.positions), Some(ArrayBuffer));
    let pos = b.accessor(
        v,
        0,
        n,
        C::F32,
        T::Vec3,
        Some((min.to_array().to_vec(), max.to_array().to_vec())),
    );
    let v = b.data(&f32_bytes(&model.normals), Some(ArrayBuffer));
    let normals = b.accessor(v, 0, n, C::F32, T::Vec3, None);
    let joints: Vec<u8> = model
        .joints
        .iter()
        .flatten()
        .flat_map(|j| j.to_le_bytes())
        .collect();
    let v = b.data(&joints, Some(ArrayBuffer));
    let joints = b.accessor(v, 0, n, C::U16, T::Vec4, None);
    let v = b.data(&f32_bytes(&model.weights), Some(ArrayBuffer));
    let weights = b.accessor(v, 0, n, C::F32, T::Vec4, None);
    let idx: Vec<u8> = model.indices.iter().flat_map(|i| i.to_le_bytes()).collect();
    let v = b.data(&idx, Some(ElementArrayBuffer));
    let indices = b.accessor(v, 0, model.indices.len(), C::U32, T::Scalar, None);
    let material = b.root.push(json::Material {
        name: Some("sloth_fur".into()),
        pbr_metallic_roughness: json::material::PbrMetallicRoughness {
            base_color_factor: json::material::PbrBaseColorFactor(model.color),
            metallic_factor: json::material::StrengthFactor(0.0),
            roughness_factor: json::material::StrengthFactor(0.95),
            ..Default::default()
        },
        ..Default::default()
    });
    let mut attributes = BTreeMap::new();
    attributes.insert(Valid(json::mesh::Semantic::Positions), pos);
    attributes.insert(Valid(json::mesh::Semantic::Normals), normals);
    attributes.insert(Valid(json::mesh::Semantic::Joints(0)), joints);
    attributes.insert(Valid(json::mesh::Semantic::Weights(0)), weights);
    b.root.push(json::Mesh {
        extensions: None,
        extras: None,
        name: Some("sloth".into()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: None,
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: None,
        }],
        weights: None,
    })
}

fn build(scene: &Scene, model: &SlothModel, rec: &Recording) -> Result<Document, ExportError> {
    use json::accessor::{ComponentType as C, Type as T};
    let (mut root, head) = slothsim_scene::export_document(scene);
    root.asset.generator = Some(concat!("slothsim-export ", env!("CARGO_PKG_VERSION")).into());
    let forest_nodes = root
        .scene
        .map(|s| root.scenes[s.value()].nodes.clone())
        .unwrap_or_default();
    root.scenes.clear();
    root.scene = None;
    root.buffers.clear();
    let mut b = Builder { root, head };
    let samples = rec.times.len();
    let animated = samples >= 2;

    let mesh = sloth_mesh(&mut b, model);
    let v = b.data(&f32_bytes(&model.inverse_bind), None);
    let ibm = b.accessor(v, 0, model.len(), C::F32, T::Mat4, None);
    let times = animated.then(|| {
        let bytes: Vec<u8> = rec.times.iter().flat_map(|t| t.to_le_bytes()).collect();
        let v = b.data(&bytes, None);
        let (lo, hi) = (rec.times[0], rec.times[samples - 1]);
        b.accessor(v, 0, samples, C::F32, T::Scalar, Some((vec![lo], vec![hi])))
    });
    while !b.head.len().is_multiple_of(4) {
        b.head.push(0);
    }

    let skeleton_root = (0..model.len())
        .find(|&i| model.parents[i].is_none())
        .unwrap_or(0);
    let mut scene_nodes = forest_nodes;
    let mut channels = Vec::new();
    let mut samplers = Vec::new();
    let mut track_offset = b.head.len();
    let track_len = rec.track_bytes();
    let moved_slot: Vec<Option<usize>> = (0..model.len())
        .map(|j| rec.moved.iter().position(|&m| m == j))
        .collect();
    for t in &rec.tracks {
        let first_rot = |series: &[[f32; 4]]| series.first().copied();
        // Instance root: the body transform.
        let root_node = b.root.push(json::Node {
            name: Some(format!("sloth_{}", t.id)),
            translation: t.translation.first().copied(),
            rotation: first_rot(&t.rotation).map(json::scene::UnitQuaternion),
            extras: json::extras::RawValue::from_string(format!(
                "{{\"slothsim\":{{\"sloth\":{}}}}}",
                t.id
            ))
            .ok(),
            ..Default::default()
        });
        let base = b.root.nodes.len();
        let node_of = |j: usize| json::Index::<json::Node>::new((base + j) as u32);
        for (j, slot) in moved_slot.iter().enumerate() {
            let children: Vec<_> = (0..model.len())
                .filter(|&c| model.parents[c] == Some(j))
                .map(node_of)
                .collect();
            let rotation = match slot.and_then(|k| first_rot(&t.joints[k])) {
                Some(q) => Some(q),
                None => (model.rest_rotation[j] != Quat::IDENTITY)
                    .then(|| model.rest_rotation[j].to_array()),
            };
            b.root.push(json::Node {
                name: Some(format!("s{}_{}", t.id, model.names[j])),
                translation: Some(model.rest_translation[j].to_array()),
                rotation: rotation.map(json::scene::UnitQuaternion),
                children: (!children.is_empty()).then_some(children),
                ..Default::default()
            });
        }
        b.root.nodes[root_node.value()].children = Some(
            (0..model.len())
                .filter(|&j| model.parents[j].is_none())
                .map(node_of)
                .collect(),
        );
        let skin = b.root.push(json::Skin {
            extensions: None,
            extras: None,
            inverse_bind_matrices: Some(ibm),
            joints: (0..model.len()).map(node_of).collect(),
            name: Some(format!("sloth_{}_skin", t.id)),
            skeleton: Some(node_of(skeleton_root)),
        });
        let mesh_node = b.root.push(json::Node {
            name: Some(format!("sloth_{}_mesh", t.id)),
            mesh: Some(mesh),
            skin: Some(skin),
            ..Default::default()
        });
        scene_nodes.push(root_node);
        scene_nodes.push(mesh_node);

        if let Some(input) = times {
            let view = b.view(track_offset, track_len, None);
            let mut offset = 0;
            let mut channel = |b: &mut Builder,
                               node: json::Index<json::Node>,
                               path: json::animation::Property,
                               type_: T,
                               width: usize| {
                let output = b.accessor(view, offset, samples, C::F32, type_, None);
                offset += samples * width * 4;
                let sampler = json::Index::new(samplers.len() as u32);
                samplers.push(json::animation::Sampler {
                    extensions: None,
                    extras: None,
                    input,
                    interpolation: Valid(json::animation::Interpolation::Linear),
                    output,
                });
                channels.push(json::animation::Channel {
                    sampler,
                    target: json::animation::Target {
                        extensions: None,
                        extras: None,
                        node,
                        path: Valid(path),
                    },
                    extensions: None,
                    extras: None,
                });
            };
            use json::animation::Property::{Rotation, Translation};
            channel(&mut b, root_node, Translation, T::Vec3, 3);
            channel(&mut b, root_node, Rotation, T::Vec4, 4);
            for &j in &rec.moved {
                channel(&mut b, node_of(j), Rotation, T::Vec4, 4);
            }
            track_offset += track_len;
        }
    }
    if animated && !rec.tracks.is_empty() {
        b.root.push(json::Animation {
            extensions: None,
            extras: None,
            channels,
            name: Some(rec.name.clone()),
            samplers,
        });
    }
    let bin_len = if animated { track_offset } else { b.head.len() };
    // The JSON chunk and headers come on top; keep well inside u32.
    if bin_len as u64 + (64 << 20) > u64::from(u32::MAX) {
        return Err(ExportError::TooLarge(format!(
            "{} sloths × {samples} samples need {:.2} GiB of animation data; a GLB holds at most 4 GiB: record fewer sloths (--record) or fewer samples (--record-hz)",
            rec.tracks.len(),
            bin_len as f64 / f64::from(1u32 << 30)
        )));
    }
    b.root.push(json::Buffer {
        byte_length: USize64::from(bin_len),
        name: None,
        uri: None,
        extensions: None,
        extras: None,
    });
    if !scene_nodes.is_empty() {
        let s = b.root.push(json::Scene {
            extensions: None,
            extras: None,
            name: Some(rec.name.clone()),
            nodes: scene_nodes,
        });
        b.root.scene = Some(s);
    }
    let mut json = b
        .root
        .to_vec()
        .map_err(|e| ExportError::TooLarge(format!("serialising glTF JSON: {e}")))?;
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    if json.len() as u64 + bin_len as u64 + 64 > u64::from(u32::MAX) {
        return Err(ExportError::TooLarge(
            "the glTF exceeds the 4 GiB a GLB can hold: record fewer sloths or samples".into(),
        ));
    }
    Ok(Document {
        json,
        head: b.head,
        bin_len,
        animated,
    })
}
