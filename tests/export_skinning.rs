//! `--skinning clusters` and `--skinning lbs` in `crowd.glb`, evaluated per the glTF spec
//! by a small evaluator of its own: read the file back with the `gltf` crate, play the
//! animation at each sample time (node TRS channels and the sloth mesh nodes' `weights`
//! channel, LINEAR), apply the morph targets to the bind-pose positions, then skin them
//! with the exported inverse bind matrices and the animated joints (morph, then skin).
//! The result must match the in-house skinning of the simulation's own poses: the
//! control-cluster result for `clusters`, LBS for `lbs`.

use std::collections::HashMap;

use glam::{Affine3A, Mat4, Quat, Vec3};
use slothsim::export::{Correctives, SlothModel, glb_bytes};
use slothsim::gait::{LocomotionConfig, Profile};
use slothsim::rig::{Limb, Rig};
use slothsim::scene::generate_forest;
use slothsim::sim::record::Sampler;
use slothsim::sim::{Crowd, CrowdSpec, ForestSource, SlothId, SlothState, forest_for};
use slothsim::skin::{LIMB_RINGS, LIMB_SIDES, SkinMesh};

/// A glTF animation channel, read back.
enum Values {
    T(Vec<Vec3>),
    R(Vec<Quat>),
    W(Vec<f32>),
}

struct Channel {
    node: usize,
    times: Vec<f32>,
    values: Values,
}

/// Key `i` at time `t` exactly (the test samples only at key times).
fn key(times: &[f32], t: f32) -> usize {
    times
        .iter()
        .position(|&k| k == t)
        .expect("a sample time of the file")
}

/// The file, played at key time `t`: world transform of every node and the morph
/// weights of every node that has them.
struct Played {
    world: Vec<Affine3A>,
    weights: HashMap<usize, Vec<f32>>,
}

fn play(doc: &gltf::Document, channels: &[Channel], t: f32) -> Played {
    let mut local: Vec<(Vec3, Quat)> = doc
        .nodes()
        .map(|n| {
            let (t, r, _) = n.transform().decomposed();
            (Vec3::from(t), Quat::from_array(r))
        })
        .collect();
    let mut weights: HashMap<usize, Vec<f32>> = doc
        .nodes()
        .filter_map(|n| n.weights().map(|w| (n.index(), w.to_vec())))
        .collect();
    for c in channels {
        let i = key(&c.times, t);
        match &c.values {
            Values::T(v) => local[c.node].0 = v[i],
            Values::R(v) => local[c.node].1 = v[i],
            Values::W(v) => {
                let n = v.len() / c.times.len();
                weights.insert(c.node, v[i * n..(i + 1) * n].to_vec());
            }
        }
    }
    let mut world = vec![Affine3A::IDENTITY; local.len()];
    fn visit(n: gltf::Node, parent: Affine3A, local: &[(Vec3, Quat)], world: &mut [Affine3A]) {
        let (t, r) = local[n.index()];
        let m = parent * Affine3A::from_rotation_translation(r, t);
        world[n.index()] = m;
        for c in n.children() {
            visit(c, m, local, world);
        }
    }
    for n in doc.default_scene().expect("scene").nodes() {
        visit(n, Affine3A::IDENTITY, local.as_slice(), &mut world);
    }
    Played { world, weights }
}

/// Every sloth mesh node of the file, as the spec evaluates it at `played`:
/// `id → world-space vertex positions` (morph targets, then skinning).
fn morph_then_skin(
    doc: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    played: &Played,
) -> HashMap<u32, Vec<Vec3>> {
    let mut out = HashMap::new();
    for node in doc.nodes() {
        let (Some(mesh), Some(skin)) = (node.mesh(), node.skin()) else {
            continue;
        };
        let id: u32 = node
            .name()
            .and_then(|n| n.strip_prefix("sloth_"))
            .and_then(|n| n.strip_suffix("_mesh"))
            .and_then(|n| n.parse().ok())
            .expect("sloth_<id>_mesh");
        let prim = mesh.primitives().next().expect("one primitive");
        let r = prim.reader(|b| Some(&buffers[b.index()]));
        let mut pos: Vec<Vec3> = r.read_positions().unwrap().map(Vec3::from).collect();
        let joints: Vec<[u16; 4]> = r.read_joints(0).unwrap().into_u16().collect();
        let wts: Vec<[f32; 4]> = r.read_weights(0).unwrap().into_f32().collect();
        // Morph: v + Σ w_k t_k (node weights, else the mesh's defaults).
        let default = mesh.weights().map(<[f32]>::to_vec).unwrap_or_default();
        let morph = played.weights.get(&node.index()).unwrap_or(&default);
        for (k, (targets, _, _)) in r.read_morph_targets().enumerate() {
            let w = morph[k];
            for (p, d) in pos.iter_mut().zip(targets.expect("POSITION target")) {
                *p += Vec3::from(d) * w;
            }
        }
        // Skin: Σ w_j (world(joint_j) · IBM_j) v.
        let sr = skin.reader(|b| Some(&buffers[b.index()]));
        let ibm: Vec<Affine3A> = sr
            .read_inverse_bind_matrices()
            .unwrap()
            .map(|m| Affine3A::from_mat4(Mat4::from_cols_array_2d(&m)))
            .collect();
        let jm: Vec<Affine3A> = skin
            .joints()
            .zip(&ibm)
            .map(|(j, ib)| played.world[j.index()] * *ib)
            .collect();
        let skinned = pos
            .iter()
            .zip(joints.iter().zip(&wts))
            .map(|(p, (j, w))| {
                (0..4)
                    .map(|k| jm[usize::from(j[k])].transform_point3(*p) * w[k])
                    .sum()
            })
            .collect();
        out.insert(id, skinned);
    }
    out
}

/// One recorded sloth at one sample time, skinned in house (world space).
struct Truth {
    clusters: Vec<Vec3>,
    lbs: Vec<Vec3>,
}

fn read_channels(doc: &gltf::Document, buffers: &[gltf::buffer::Data]) -> Vec<Channel> {
    let anim = doc.animations().next().expect("one animation");
    anim.channels()
        .map(|ch| {
            let r = ch.reader(|b| Some(&buffers[b.index()]));
            let times: Vec<f32> = r.read_inputs().unwrap().collect();
            use gltf::animation::util::ReadOutputs as O;
            let values = match r.read_outputs().unwrap() {
                O::Translations(v) => Values::T(v.map(Vec3::from).collect()),
                O::Rotations(v) => Values::R(v.into_f32().map(Quat::from_array).collect()),
                O::MorphTargetWeights(v) => Values::W(v.into_f32().collect()),
                O::Scales(_) => panic!("no scale channels"),
            };
            Channel {
                node: ch.target().node().index(),
                times,
                values,
            }
        })
        .collect()
}

fn limb_vertices() -> impl Iterator<Item = usize> {
    Limb::ALL.into_iter().flat_map(|l| {
        let first = SkinMesh::tube_first(l);
        first..first + LIMB_RINGS * LIMB_SIDES + 2
    })
}

#[test]
fn morph_then_skin_matches_the_in_house_cluster_and_lbs_results() {
    let rig = Rig::sloth();
    let sloths = 6;
    let fc = forest_for(sloths, Some(4), None);
    let scene = generate_forest(&fc).unwrap();
    let spec = CrowdSpec {
        sloths,
        seed: 11,
        dt: 1.0 / 60.0,
        cfg: LocomotionConfig::profile(Profile::Free),
        clearance_m: 0.3,
    };
    let mut crowd = Crowd::new(spec, &rig, scene.clone(), ForestSource::Procedural(fc)).unwrap();
    let ids: Vec<u32> = (0..sloths).collect();
    let seconds = 6.0;
    let mut sampler = Sampler::for_crowd(&crowd, &rig, &ids, "skinning", 10.0, seconds, None);
    let correctives = Correctives::sloth().expect("sloth correctives");
    let mesh = correctives.mesh();
    let clusters = correctives.clusters();

    // In-house skinning of the simulation's own poses at every sampled frame.
    let mut truths: Vec<(f32, Vec<Truth>)> = Vec::new();
    let record = |crowd: &Crowd, sampler: &mut Sampler, truths: &mut Vec<_>| {
        let before = sampler.samples();
        sampler.after_tick(crowd);
        if sampler.samples() == before {
            return;
        }
        let mut all: Vec<(u32, slothsim::gait::Sloth)> = crowd
            .world()
            .try_query::<(&SlothId, &SlothState)>()
            .unwrap()
            .iter(crowd.world())
            .map(|(i, s)| (i.0, s.0))
            .collect();
        all.sort_by_key(|(i, _)| *i);
        let t = all[0].1.time;
        let skinned = all
            .iter()
            .map(|(_, s)| {
                let mut locals = rig.skeleton().rest_rotations();
                for limb in Limb::ALL {
                    rig.write_pose(limb, &s.limbs[limb.index()].pose, &mut locals);
                }
                let posed = mesh.pose(&locals).expect("finite pose");
                let body = Affine3A::from_rotation_translation(s.body_rot, s.body_pos);
                let (mut lbs, mut out) = (Vec::new(), Vec::new());
                clusters.skin(mesh, &posed, &mut lbs, &mut out);
                let ws = |v: &[Vec3]| v.iter().map(|p| body.transform_point3(*p)).collect();
                Truth {
                    clusters: ws(&out),
                    lbs: ws(&lbs),
                }
            })
            .collect();
        truths.push((t, skinned));
    };
    record(&crowd, &mut sampler, &mut truths);
    for _ in 0..(seconds * 60.0) as usize {
        crowd.step();
        record(&crowd, &mut sampler, &mut truths);
    }
    let (rec, _) = sampler.finish();
    assert_eq!(truths.len(), rec.times.len());

    let model = SlothModel::sloth();
    let limb: Vec<usize> = limb_vertices().collect();
    let mut report = Vec::new();
    for with_clusters in [true, false] {
        let bytes = glb_bytes(&scene, &model, &rec, with_clusters.then_some(&correctives)).unwrap();
        let (doc, buffers, _) = gltf::import_slice(&bytes).expect("valid glb");
        let channels = read_channels(&doc, &buffers);
        let weight_channels = channels
            .iter()
            .filter(|c| matches!(c.values, Values::W(_)))
            .count();
        assert_eq!(
            weight_channels,
            if with_clusters { sloths as usize } else { 0 }
        );
        let (mut worst, mut worst_other, mut all_worst) = (0.0f32, 0.0f32, 0.0f32);
        for (t, truth) in &truths {
            let played = play(&doc, &channels, *t);
            let file = morph_then_skin(&doc, &buffers, &played);
            for (id, tr) in truth.iter().enumerate() {
                let got = &file[&(id as u32)];
                let (want, other) = if with_clusters {
                    (&tr.clusters, &tr.lbs)
                } else {
                    (&tr.lbs, &tr.clusters)
                };
                for &v in &limb {
                    worst = worst.max(got[v].distance(want[v]));
                    worst_other = worst_other.max(got[v].distance(other[v]));
                }
                for (g, w) in got.iter().zip(want) {
                    all_worst = all_worst.max(g.distance(*w));
                }
            }
        }
        let mode = if with_clusters { "clusters" } else { "lbs" };
        report.push(format!(
            "{mode}: {} bytes; limb vertices vs in-house {mode} max {:.3} mm (all vertices {:.3} mm), vs the other method {:.2} mm",
            bytes.len(),
            worst * 1e3,
            all_worst * 1e3,
            worst_other * 1e3
        ));
        assert!(worst <= 2e-3, "{mode}: {worst} m from the in-house result");
        assert!(all_worst <= 2e-3, "{mode}: {all_worst} m over all vertices");
        // The check can tell the methods apart: the correction is larger than the tolerance.
        assert!(
            worst_other > 2e-3,
            "{mode}: the run never flexed enough to tell lbs from clusters ({worst_other} m)"
        );
    }
    println!("{}", report.join("\n"));
}

#[test]
fn a_non_finite_recorded_rotation_is_an_error_naming_sloth_time_and_joint() {
    use slothsim::export::{LimbSample, Recording, Sample};
    let rig = Rig::sloth();
    let fc = forest_for(1, Some(4), None);
    let scene = generate_forest(&fc).unwrap();
    let moved = slothsim::sim::record::moved_joints(&rig);
    let mut rec = Recording::new("nan", moved.clone(), &[3]);
    let limb = LimbSample {
        grip: Vec3::ZERO,
        planted: true,
        support: 0,
    };
    for k in 0..3 {
        rec.begin_sample(k as f32 * 0.5);
        let mut joints: Vec<Quat> = moved
            .iter()
            .map(|&j| rig.skeleton().rest_rotations()[j])
            .collect();
        if k == 2 {
            joints[6] = Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0);
        }
        rec.push(
            0,
            &Sample {
                t: k as f32 * 0.5,
                id: 3,
                body_pos: Vec3::new(0.0, 2.0, 0.0),
                body_rot: Quat::IDENTITY,
                joints,
                limbs: [limb; 4],
                support_kind: "branch",
            },
        );
    }
    let name = &rig.skeleton().names()[moved[6]];
    let correctives = Correctives::sloth().unwrap();
    for c in [None, Some(&correctives)] {
        let e = glb_bytes(&scene, &SlothModel::sloth(), &rec, c).unwrap_err();
        let msg = e.to_string();
        assert!(
            msg.contains("sloth 3") && msg.contains("t = 1 s") && msg.contains(name.as_str()),
            "{msg}"
        );
    }
}
