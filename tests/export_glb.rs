//! `crowd.glb` re-imported with the `gltf` crate and played back by a small
//! evaluator of its own (LINEAR channels, slerp for rotations, the node
//! hierarchy of each skin): every joint's world position against the
//! simulation's own forward kinematics at the same instants.

use std::collections::HashMap;

use glam::{Affine3A, Quat, Vec3};
use slothsim::export::{SlothModel, glb_bytes};
use slothsim::gait::{LimbPhase, LocomotionConfig, Profile};
use slothsim::rig::{Limb, Rig};
use slothsim::scene::generate_forest;
use slothsim::sim::record::Sampler;
use slothsim::sim::{Crowd, CrowdSpec, ForestSource, Locomotion, forest_for};

/// One sloth at one frame, by the simulation: world position of every
/// skeleton joint, and the planted limbs' claw tips' grips.
struct Truth {
    joints: Vec<Vec3>,
    grips: Vec<(usize, Vec3)>,
}

/// World positions of all joints of a sloth by the simulation's FK: limb
/// joints and claw tips from each chain (what the sim solves and draws),
/// spine joints rigid with the body.
fn truth(rig: &Rig, loco: &Locomotion, s: &slothsim::gait::Sloth, rest_ms: &[Affine3A]) -> Truth {
    let mut joints: Vec<Vec3> = rest_ms
        .iter()
        .map(|m| s.body_pos + s.body_rot * Vec3::from(m.translation))
        .collect();
    let mut grips = Vec::new();
    for limb in Limb::ALL {
        let li = limb.index();
        let lj = rig.limb_joints(limb);
        let root = loco.rig.root_ws(li, s.body_pos, s.body_rot);
        let p = loco.rig.chains[li].fk(root, &s.limbs[li].pose);
        for (k, &j) in lj.joints.iter().enumerate() {
            joints[j] = p[k];
        }
        let tip = lj.tip.expect("tip");
        joints[tip] = p[4];
        if s.limbs[li].phase != LimbPhase::Swinging {
            grips.push((tip, s.limbs[li].grip.point));
        }
    }
    Truth { joints, grips }
}

/// A glTF animation channel, read back.
enum Values {
    T(Vec<Vec3>),
    R(Vec<Quat>),
}

struct Channel {
    node: usize,
    times: Vec<f32>,
    values: Values,
}

/// Where `t` falls: key `i` and the share toward `i + 1` (clamped at the ends).
fn locate(times: &[f32], t: f32) -> (usize, f32) {
    if t <= times[0] {
        return (0, 0.0);
    }
    let last = times.len() - 1;
    if t >= times[last] {
        return (last, 0.0);
    }
    let i = times.partition_point(|&k| k <= t) - 1;
    (i, (t - times[i]) / (times[i + 1] - times[i]))
}

/// Local transforms of every node at time `t`: rest TRS, overridden by channels.
fn evaluate(rest: &[(Vec3, Quat)], channels: &[Channel], t: f32) -> Vec<(Vec3, Quat)> {
    let mut local = rest.to_vec();
    for c in channels {
        let (i, f) = locate(&c.times, t);
        match &c.values {
            Values::T(v) => {
                let b = v.get(i + 1).copied().unwrap_or(v[i]);
                local[c.node].0 = v[i].lerp(b, f);
            }
            Values::R(v) => {
                let b = v.get(i + 1).copied().unwrap_or(v[i]);
                local[c.node].1 = v[i].slerp(b, f).normalize();
            }
        }
    }
    local
}

/// World transform of every node from the scene's roots.
fn world_of(doc: &gltf::Document, local: &[(Vec3, Quat)]) -> Vec<Affine3A> {
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
        visit(n, Affine3A::IDENTITY, local, &mut world);
    }
    world
}

#[test]
fn animation_reproduces_the_simulated_joints() {
    let rig = Rig::sloth();
    let sloths = 12;
    let fc = forest_for(sloths, Some(4), None);
    let scene = generate_forest(&fc).unwrap();
    let spec = CrowdSpec {
        sloths,
        seed: 5,
        dt: 1.0 / 60.0,
        cfg: LocomotionConfig::profile(Profile::Free),
        clearance_m: 0.3,
    };
    let mut crowd = Crowd::new(spec, &rig, scene.clone(), ForestSource::Procedural(fc)).unwrap();
    let ids: Vec<u32> = (0..sloths).collect();
    let seconds = 4.0;
    let mut sampler = Sampler::for_crowd(&crowd, &rig, &ids, "roundtrip", 30.0, seconds, None);
    let skel = rig.skeleton();
    let mut rest_ms = vec![Affine3A::IDENTITY; skel.len()];
    skel.fk(&skel.rest_rotations(), &mut rest_ms);

    // The truth at every frame (time, per sloth), and whether it was sampled.
    let mut frames: Vec<(f32, bool, Vec<Truth>)> = Vec::new();
    let record = |crowd: &Crowd, sampler: &mut Sampler, frames: &mut Vec<_>| {
        let before = sampler.samples();
        sampler.after_tick(crowd);
        let loco = crowd.world().resource::<Locomotion>();
        let mut all: Vec<(u32, slothsim::gait::Sloth)> = crowd
            .world()
            .try_query::<(&slothsim::sim::SlothId, &slothsim::sim::SlothState)>()
            .unwrap()
            .iter(crowd.world())
            .map(|(i, s)| (i.0, s.0))
            .collect();
        all.sort_by_key(|(i, _)| *i);
        let t = all[0].1.time;
        let truths = all
            .iter()
            .map(|(_, s)| truth(&rig, loco, s, &rest_ms))
            .collect();
        frames.push((t, sampler.samples() > before, truths));
    };
    record(&crowd, &mut sampler, &mut frames);
    for _ in 0..(seconds * 60.0) as usize {
        crowd.step();
        record(&crowd, &mut sampler, &mut frames);
    }
    let (rec, _) = sampler.finish();
    assert_eq!(rec.times.len(), 121, "30 Hz over 4 s, both ends");
    let bytes = glb_bytes(&scene, &SlothModel::sloth(), &rec, None).unwrap();

    // Re-import.
    let (doc, buffers, _) = gltf::import_slice(&bytes).expect("valid glb");
    let rest: Vec<(Vec3, Quat)> = doc
        .nodes()
        .map(|n| {
            let (t, r, _) = n.transform().decomposed();
            (Vec3::from(t), Quat::from_array(r))
        })
        .collect();
    let anim = doc.animations().next().expect("one animation");
    assert_eq!(anim.name(), Some("roundtrip"));
    let mut channels = Vec::new();
    for ch in anim.channels() {
        assert_eq!(
            ch.sampler().interpolation(),
            gltf::animation::Interpolation::Linear
        );
        let r = ch.reader(|b| Some(&buffers[b.index()]));
        let times: Vec<f32> = r.read_inputs().unwrap().collect();
        let values = match r.read_outputs().unwrap() {
            gltf::animation::util::ReadOutputs::Translations(v) => {
                Values::T(v.map(Vec3::from).collect())
            }
            gltf::animation::util::ReadOutputs::Rotations(v) => {
                let q: Vec<Quat> = v.into_f32().map(Quat::from_array).collect();
                for w in q.windows(2) {
                    assert!((w[0].length() - 1.0).abs() < 1e-5, "unit quaternions");
                    assert!(w[0].dot(w[1]) >= 0.0, "sign-continuous");
                }
                Values::R(q)
            }
            _ => panic!("only translation and rotation channels"),
        };
        channels.push(Channel {
            node: ch.target().node().index(),
            times,
            values,
        });
    }
    // 2 root channels + 16 limb joints per sloth.
    assert_eq!(channels.len(), sloths as usize * 18);

    // Each sloth's skin: its joint nodes in skeleton order.
    let mut skins: HashMap<u32, Vec<usize>> = HashMap::new();
    for skin in doc.skins() {
        let id: u32 = skin
            .name()
            .and_then(|n| n.strip_prefix("sloth_"))
            .and_then(|n| n.strip_suffix("_skin"))
            .and_then(|n| n.parse().ok())
            .expect("skin named sloth_<id>_skin");
        skins.insert(id, skin.joints().map(|j| j.index()).collect());
    }
    assert_eq!(skins.len(), sloths as usize, "one skin per sloth");

    let (mut worst_sample, mut worst_between, mut worst_grip) = (0.0f32, 0.0f32, 0.0f32);
    let mut grips_checked = 0;
    for (t, sampled, truths) in &frames {
        let world = world_of(&doc, &evaluate(&rest, &channels, *t));
        for (id, truth) in truths.iter().enumerate() {
            let joints = &skins[&(id as u32)];
            let err = joints
                .iter()
                .zip(&truth.joints)
                .map(|(&n, p)| Vec3::from(world[n].translation).distance(*p))
                .fold(0.0, f32::max);
            if *sampled {
                worst_sample = worst_sample.max(err);
                for &(tip, grip) in &truth.grips {
                    let d = Vec3::from(world[joints[tip]].translation).distance(grip);
                    worst_grip = worst_grip.max(d);
                    grips_checked += 1;
                }
            } else {
                worst_between = worst_between.max(err);
            }
        }
    }
    println!(
        "joint error: at samples {:.3} mm, between samples {:.2} mm; planted claw tip to grip {:.2} mm ({grips_checked} checks)",
        worst_sample * 1e3,
        worst_between * 1e3,
        worst_grip * 1e3
    );
    assert!(worst_sample <= 1e-3, "at samples {worst_sample} m");
    assert!(grips_checked > 1000);
    assert!(
        worst_grip <= 0.01,
        "planted claw tip {worst_grip} m from its grip"
    );
    // Between samples the animation interpolates: half a 30 Hz step of a
    // swinging limb at most.
    assert!(worst_between <= 0.02, "between samples {worst_between} m");
}
