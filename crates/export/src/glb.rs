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

use crate::corrective::TrackWeights;
use crate::{AtomicFile, Correctives, ExportError, Recording, SlothModel};

/// What was written.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GlbSummary {
    /// File size (bytes).
    pub bytes: u64,
    /// Of which JSON (bytes).
    pub json_bytes: u64,
    /// Sloth instances.
    pub sloths: usize,
    /// Sample times (keyframes per channel).
    pub samples: usize,
    /// Corrective morph targets on the sloth mesh (0 with LBS).
    pub morph_targets: usize,
    /// Largest bind-space residual of the morph weights' fit to the cluster correction
    /// over every sloth and sample (m): a bound on how far morph-then-skin is from the
    /// in-house cluster result (0 with LBS).
    pub morph_residual_m: f32,
}

/// A document ready to be streamed: JSON, the binary data before the
/// tracks, and the total binary length.
struct Document {
    json: Vec<u8>,
    head: Vec<u8>,
    bin_len: usize,
    animated: bool,
    /// Morph targets per sloth mesh (0: LBS).
    targets: usize,
    /// Residual of the first samples' weights.
    residual_m: f32,
}

/// Tracks whose morph weights are computed together (bounds the memory they take).
const WEIGHT_CHUNK: usize = 64;

/// Writes the crowd to `path` (temporary name, renamed at the end); with
/// `correctives`, the sloth mesh carries its corrective morph targets and their
/// weights are animated per sloth (`--skinning clusters`), else plain LBS.
///
/// # Errors
/// [`ExportError::Io`] (no file is left under `path`), [`ExportError::TooLarge`]
/// when the data exceeds what a GLB can hold (4 GiB), [`ExportError::Pose`] for a
/// non-finite recorded value (naming sloth, time and joint),
/// [`ExportError::Targets`] when the targets do not fit the model.
pub fn write_glb(
    path: &Path,
    scene: &Scene,
    model: &SlothModel,
    rec: &Recording,
    correctives: Option<&Correctives>,
) -> Result<GlbSummary, ExportError> {
    let doc = build(scene, model, rec, correctives)?;
    let mut file = AtomicFile::create(path)?;
    let summary = match stream(&doc, rec, correctives, &mut file) {
        Ok(s) => s,
        Err(Streamed::Io(e)) => return Err(file.error(e)),
        Err(Streamed::Export(e)) => {
            drop(file);
            return Err(e);
        }
    };
    file.commit()?;
    Ok(summary)
}

/// Why streaming stopped.
enum Streamed {
    Io(std::io::Error),
    Export(ExportError),
}

impl From<std::io::Error> for Streamed {
    fn from(e: std::io::Error) -> Self {
        Streamed::Io(e)
    }
}

/// The crowd as GLB bytes (tests, small exports).
///
/// # Errors
/// [`ExportError::TooLarge`] as [`write_glb`].
pub fn glb_bytes(
    scene: &Scene,
    model: &SlothModel,
    rec: &Recording,
    correctives: Option<&Correctives>,
) -> Result<Vec<u8>, ExportError> {
    let doc = build(scene, model, rec, correctives)?;
    let mut out = Vec::new();
    match stream(&doc, rec, correctives, &mut out) {
        Ok(_) => Ok(out),
        Err(Streamed::Io(source)) => Err(ExportError::Io {
            path: "memory".into(),
            source,
        }),
        Err(Streamed::Export(e)) => Err(e),
    }
}

fn stream(
    doc: &Document,
    rec: &Recording,
    correctives: Option<&Correctives>,
    w: &mut impl Write,
) -> Result<GlbSummary, Streamed> {
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
    let mut residual_m = doc.residual_m;
    if doc.animated {
        let mut buf = Vec::with_capacity(rec.track_bytes());
        let morphs = correctives.filter(|_| doc.targets > 0);
        for chunk in (0..rec.tracks.len()).step_by(WEIGHT_CHUNK) {
            let tracks = chunk..(chunk + WEIGHT_CHUNK).min(rec.tracks.len());
            let weights: Vec<TrackWeights> = match morphs {
                Some(c) => c
                    .weights_of(rec, tracks.clone())
                    .map_err(Streamed::Export)?,
                None => Vec::new(),
            };
            for (k, t) in rec.tracks[tracks].iter().enumerate() {
                buf.clear();
                buf.extend(t.translation.iter().flatten().flat_map(|v| v.to_le_bytes()));
                buf.extend(t.rotation.iter().flatten().flat_map(|v| v.to_le_bytes()));
                for j in &t.joints {
                    buf.extend(j.iter().flatten().flat_map(|v| v.to_le_bytes()));
                }
                if let Some(tw) = weights.get(k) {
                    buf.extend(tw.weights.iter().flat_map(|v| v.to_le_bytes()));
                    residual_m = residual_m.max(tw.residual_m);
                }
                w.write_all(&buf)?;
            }
        }
    }
    w.flush()?;
    Ok(GlbSummary {
        bytes: total as u64,
        json_bytes: doc.json.len() as u64,
        sloths: rec.tracks.len(),
        samples: rec.times.len(),
        morph_targets: doc.targets,
        morph_residual_m: residual_m,
    })
}

/// A non-finite recorded value, named: sloth, time and what.
fn check_finite(model: &SlothModel, rec: &Recording) -> Result<(), ExportError> {
    for t in &rec.tracks {
        let bad = |s: usize, what: String| ExportError::Pose {
            sloth: t.id,
            time_s: rec.times.get(s).copied().unwrap_or(f32::NAN),
            why: format!("{what} is not finite"),
        };
        if let Some(s) = t
            .translation
            .iter()
            .position(|v| !v.iter().all(|x| x.is_finite()))
        {
            return Err(bad(s, "the body position".into()));
        }
        if let Some(s) = t
            .rotation
            .iter()
            .position(|v| !v.iter().all(|x| x.is_finite()))
        {
            return Err(bad(s, "the body rotation".into()));
        }
        for (k, series) in t.joints.iter().enumerate() {
            if let Some(s) = series.iter().position(|v| !v.iter().all(|x| x.is_finite())) {
                let j = rec.moved[k];
                let name = model.names.get(j).map_or("?", String::as_str);
                return Err(bad(s, format!("the rotation of joint {j} (`{name}`)")));
            }
        }
    }
    Ok(())
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

/// The shared sloth mesh (one primitive, skinned, with `targets` as corrective morph
/// targets) and its material.
fn sloth_mesh(
    b: &mut Builder,
    model: &SlothModel,
    targets: &[slothsim_skin::MorphTarget],
) -> json::Index<json::Mesh> {
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
    let morphs: Vec<json::mesh::MorphTarget> = targets
        .iter()
        .map(|t| json::mesh::MorphTarget {
            positions: Some(sparse_target(b, n, t)),
            normals: None,
            tangents: None,
        })
        .collect();
    // `extras.targetNames`: the names Blender and three.js give the shape keys.
    let names: Vec<&str> = targets.iter().map(|t| t.name.as_str()).collect();
    let extras = (!targets.is_empty())
        .then(|| {
            json::extras::RawValue::from_string(
                serde_json::json!({ "targetNames": names }).to_string(),
            )
            .ok()
        })
        .flatten();
    b.root.push(json::Mesh {
        extensions: None,
        extras,
        name: Some("sloth".into()),
        primitives: vec![json::mesh::Primitive {
            attributes,
            extensions: None,
            extras: None,
            indices: Some(indices),
            material: Some(material),
            mode: Valid(json::mesh::Mode::Triangles),
            targets: (!morphs.is_empty()).then_some(morphs),
        }],
        // No mesh default weights (zeros by the spec): every sloth node sets its own.
        weights: None,
    })
}

/// A morph target's POSITION displacements as a sparse accessor over `n` vertices
/// (zeros but for the target's vertices; min/max over all `n`, as the spec asks).
fn sparse_target(
    b: &mut Builder,
    n: usize,
    t: &slothsim_skin::MorphTarget,
) -> json::Index<json::Accessor> {
    use json::accessor::{ComponentType as C, Type as T, sparse};
    let (mut min, mut max) = (Vec3::ZERO, Vec3::ZERO);
    for d in &t.displacements {
        min = min.min(*d);
        max = max.max(*d);
    }
    let (index_bytes, index_type): (Vec<u8>, _) = if n <= usize::from(u16::MAX) {
        let idx = t.vertices.iter().flat_map(|&v| (v as u16).to_le_bytes());
        (idx.collect(), json::accessor::IndexComponentType(C::U16))
    } else {
        let idx = t.vertices.iter().flat_map(|&v| v.to_le_bytes());
        (idx.collect(), json::accessor::IndexComponentType(C::U32))
    };
    let indices = b.data(&index_bytes, None);
    let values: Vec<[f32; 3]> = t.displacements.iter().map(|d| d.to_array()).collect();
    let values = b.data(&f32_bytes(&values), None);
    b.root.push(json::Accessor {
        buffer_view: None,
        byte_offset: None,
        count: USize64::from(n),
        component_type: Valid(json::accessor::GenericComponentType(C::F32)),
        extensions: None,
        extras: None,
        type_: Valid(T::Vec3),
        min: Some(serde_json::json!(min.to_array())),
        max: Some(serde_json::json!(max.to_array())),
        name: None,
        normalized: false,
        sparse: Some(sparse::Sparse {
            count: USize64::from(t.vertices.len()),
            indices: sparse::Indices {
                buffer_view: indices,
                byte_offset: USize64(0),
                component_type: Valid(index_type),
                extensions: None,
                extras: None,
            },
            values: sparse::Values {
                buffer_view: values,
                byte_offset: USize64(0),
                extensions: None,
                extras: None,
            },
            extensions: None,
            extras: None,
        }),
    })
}

fn build(
    scene: &Scene,
    model: &SlothModel,
    rec: &Recording,
    correctives: Option<&Correctives>,
) -> Result<Document, ExportError> {
    use json::accessor::{ComponentType as C, Type as T};
    check_finite(model, rec)?;
    let targets = correctives.map_or(&[][..], Correctives::targets);
    if let Some(c) = correctives {
        let n = c.mesh().positions.len();
        if n != model.positions.len() {
            return Err(ExportError::Targets(format!(
                "built for a mesh of {n} vertices, the sloth model has {}",
                model.positions.len()
            )));
        }
    }
    // The nodes' still pose: each sloth's weights at the first sample.
    let first: Vec<TrackWeights> = match correctives {
        Some(c) if !targets.is_empty() => c.first_weights(rec)?,
        _ => Vec::new(),
    };
    let residual_m = first.iter().map(|w| w.residual_m).fold(0.0, f32::max);
    let weights_len = samples_bytes(rec.times.len()) * targets.len();
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

    let mesh = sloth_mesh(&mut b, model, targets);
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
    let track_len = rec.track_bytes() + weights_len;
    let moved_slot: Vec<Option<usize>> = (0..model.len())
        .map(|j| rec.moved.iter().position(|&m| m == j))
        .collect();
    for (ti, t) in rec.tracks.iter().enumerate() {
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
            weights: first.get(ti).map(|w| w.weights.clone()),
            ..Default::default()
        });
        scene_nodes.push(root_node);
        scene_nodes.push(mesh_node);

        if let Some(input) = times {
            let view = b.view(track_offset, track_len, None);
            let mut offset = 0;
            // One sampler + channel per animated property: `per_sample`
            // accessor elements of `type_` a sample (weights: one scalar per
            // morph target, sample-major), packed one after another in `view`.
            let mut channel = |b: &mut Builder,
                               node: json::Index<json::Node>,
                               path: json::animation::Property,
                               type_: T,
                               per_sample: usize| {
                let count = samples * per_sample;
                let output = b.accessor(view, offset, count, C::F32, type_, None);
                offset += count * type_.multiplicity() * 4;
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
            use json::animation::Property::{MorphTargetWeights, Rotation, Translation};
            channel(&mut b, root_node, Translation, T::Vec3, 1);
            channel(&mut b, root_node, Rotation, T::Vec4, 1);
            for &j in &rec.moved {
                channel(&mut b, node_of(j), Rotation, T::Vec4, 1);
            }
            if !targets.is_empty() {
                channel(
                    &mut b,
                    mesh_node,
                    MorphTargetWeights,
                    T::Scalar,
                    targets.len(),
                );
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
        targets: targets.len(),
        residual_m,
    })
}

/// Bytes of one f32 per sample.
fn samples_bytes(samples: usize) -> usize {
    4 * samples
}
