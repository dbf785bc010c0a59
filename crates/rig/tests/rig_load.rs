//! Loading rigs from glTF: the committed asset, other naming, and bad input.

use glam::{Quat, Vec3};
use serde_json::{Value, json};
use slothsim_rig::{
    CcdParams, ChainPose, JointLimit, Limb, LimbNames, Rig, RigError, RigMap, RootTransform,
    Skeleton, solve,
};

const ASSET: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../assets/sloth.glb");

#[test]
fn committed_asset_equals_code_rig() {
    let loaded = Rig::load(ASSET, &RigMap::sloth()).expect("asset loads");
    assert_eq!(loaded, Rig::sloth());
}

#[test]
fn sloth_proportions_match_spec() {
    let rig = Rig::sloth();
    for limb in Limb::ALL {
        let reach = rig.chain(limb).reach();
        assert!((reach - 0.40).abs() < 1e-4, "{limb}: limb length {reach}");
    }
    let skel = rig.skeleton();
    let mut model = vec![glam::Affine3A::IDENTITY; skel.len()];
    skel.fk(&skel.rest_rotations(), &mut model);
    let nose = model[skel.find("HeadTip").unwrap()].translation.z;
    let hips = model[skel.find("Hips").unwrap()].translation.z;
    let body = nose - hips + 0.07; // rump behind the hip joint
    assert!((0.78..=0.87).contains(&body), "body length {body}");
    // Limbs reach up (+Y) from their roots to the grips above.
    for limb in Limb::ALL {
        let p = rig
            .chain(limb)
            .fk(RootTransform::IDENTITY, &ChainPose::NEUTRAL);
        assert!(p[4].y - p[0].y > 0.25, "{limb} does not reach up");
    }
}

/// The asset as glTF JSON (no buffers): a convenient base for malformed variants.
fn asset_json_nodes() -> Value {
    let doc = gltf::Gltf::open(ASSET).expect("asset");
    let mut v: Value = serde_json::from_slice(&doc.document.into_json().to_vec().unwrap()).unwrap();
    // Keep only the node hierarchy.
    let nodes: Vec<Value> = v["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|n| n.get("mesh").is_none())
        .cloned()
        .collect();
    v = json!({"asset": {"version": "2.0"}, "nodes": nodes, "scenes": [{"nodes": [0]}], "scene": 0});
    v
}

fn node_index(v: &Value, name: &str) -> usize {
    v["nodes"]
        .as_array()
        .unwrap()
        .iter()
        .position(|n| n["name"] == name)
        .unwrap()
}

fn load_json(v: &Value) -> Result<Rig, RigError> {
    Rig::from_gltf_slice(&serde_json::to_vec(v).unwrap(), &RigMap::sloth())
}

#[test]
fn json_copy_of_asset_loads() {
    assert_eq!(load_json(&asset_json_nodes()).unwrap(), Rig::sloth());
}

#[test]
fn missing_joint_is_named() {
    let mut v = asset_json_nodes();
    let i = node_index(&v, "LH_LowerLeg");
    v["nodes"][i]["name"] = json!("Knee");
    match load_json(&v) {
        Err(e @ RigError::MissingJoint { .. }) => {
            assert!(e.to_string().contains("LH_LowerLeg"), "{e}");
            assert!(e.to_string().contains("LH.LowerLeg"), "{e}");
        }
        other => panic!("expected MissingJoint, got {other:?}"),
    }
}

#[test]
fn cycle_is_reported() {
    let mut v = asset_json_nodes();
    // Hand → UpperArm closes a loop UpperArm → ForeArm → Hand → UpperArm; UpperArm's
    // old parent must drop it so every node still has one parent.
    let shoulder = node_index(&v, "RF_Shoulder");
    let upper = node_index(&v, "RF_UpperArm");
    let hand = node_index(&v, "RF_Hand");
    v["nodes"][shoulder]
        .as_object_mut()
        .unwrap()
        .remove("children");
    v["nodes"][hand]["children"]
        .as_array_mut()
        .unwrap()
        .push(json!(upper));
    match load_json(&v) {
        Err(RigError::Cycle { joint }) => assert!(joint.starts_with("RF_"), "{joint}"),
        other => panic!("expected Cycle, got {other:?}"),
    }
}

#[test]
fn node_with_two_parents_is_reported() {
    let mut v = asset_json_nodes();
    let thigh = node_index(&v, "LH_Thigh");
    let spine = node_index(&v, "Spine");
    v["nodes"][spine]["children"]
        .as_array_mut()
        .unwrap()
        .push(json!(thigh));
    match load_json(&v) {
        Err(RigError::MultipleParents { joint }) => assert_eq!(joint, "LH_Thigh"),
        other => panic!("expected MultipleParents, got {other:?}"),
    }
}

#[test]
fn limit_with_min_above_max_is_reported() {
    let mut v = asset_json_nodes();
    let i = node_index(&v, "LF_ForeArm");
    v["nodes"][i]["extras"]["slothsim"]["limit"]["min"] = json!(0.9);
    v["nodes"][i]["extras"]["slothsim"]["limit"]["max"] = json!(0.1);
    match load_json(&v) {
        Err(e @ RigError::InvalidLimit { .. }) => {
            assert!(e.to_string().contains("LF_ForeArm") && e.to_string().contains("min > max"))
        }
        other => panic!("expected InvalidLimit, got {other:?}"),
    }
}

#[test]
fn unreadable_extras_are_reported() {
    let mut v = asset_json_nodes();
    let i = node_index(&v, "RH_Foot");
    v["nodes"][i]["extras"]["slothsim"]["limit"] = json!({"kind": "spring"});
    match load_json(&v) {
        Err(RigError::BadExtras { joint, .. }) => assert_eq!(joint, "RH_Foot"),
        other => panic!("expected BadExtras, got {other:?}"),
    }
}

#[test]
fn flat_array_with_parent_after_child_is_reported() {
    let skel = Rig::sloth().skeleton().clone();
    let mut parents = skel.parents().to_vec();
    parents[1] = Some(5);
    let err = Skeleton::from_parts(
        skel.names().to_vec(),
        parents,
        skel.rest().to_vec(),
        skel.limits().to_vec(),
    )
    .unwrap_err();
    assert!(matches!(&err, RigError::ParentAfterChild { joint, .. } if joint == &skel.names()[1]));
}

#[test]
fn flat_array_with_min_above_max_is_reported() {
    let skel = Rig::sloth().skeleton().clone();
    let mut limits = skel.limits().to_vec();
    let i = skel.find("LH_Foot").unwrap();
    limits[i] = Some(JointLimit::Hinge {
        axis: glam::Vec3A::X,
        min: 0.2,
        max: -0.2,
    });
    let err = Skeleton::from_parts(
        skel.names().to_vec(),
        skel.parents().to_vec(),
        skel.rest().to_vec(),
        limits,
    )
    .unwrap_err();
    assert!(
        matches!(&err, RigError::InvalidLimit { joint, .. } if joint == "LH_Foot"),
        "{err}"
    );
}

#[test]
fn garbage_bytes_are_an_error_not_a_panic() {
    assert!(matches!(
        Rig::from_gltf_slice(b"not a gltf", &RigMap::sloth()),
        Err(RigError::Gltf(_))
    ));
}

/// A "third-party" quadruped: other joint names, non-identity rest rotations, no
/// limits in extras, no tip nodes, and nodes listed children-first. Same geometry.
fn third_party_json() -> (Value, RigMap) {
    let rig = Rig::sloth();
    let skel = rig.skeleton();
    let mut model = vec![glam::Affine3A::IDENTITY; skel.len()];
    skel.fk(&skel.rest_rotations(), &mut model);
    let rename = |n: &str| format!("mixamorig:{}", n.replace('_', ""));
    // Arbitrary but fixed world rest rotations per joint.
    let world_rot: Vec<Quat> = (0..skel.len())
        .map(|i| Quat::from_euler(glam::EulerRot::XYZ, 0.3 * i as f32, -0.2 * i as f32, 0.1))
        .collect();
    let keep: Vec<usize> = (0..skel.len())
        .filter(|&i| !skel.names()[i].ends_with("Tip"))
        .collect();
    // Reverse node order so children come before parents in the file.
    let file_index = |i: usize| keep.len() - 1 - keep.iter().position(|&k| k == i).unwrap();
    let mut nodes = vec![Value::Null; keep.len()];
    for &i in &keep {
        let (pr, pp) = match skel.parent(i) {
            Some(p) => (world_rot[p], Vec3::from(model[p].translation)),
            None => (Quat::IDENTITY, Vec3::ZERO),
        };
        let local_rot = pr.inverse() * world_rot[i];
        let t = pr.inverse() * (Vec3::from(model[i].translation) - pp);
        let children: Vec<usize> = keep
            .iter()
            .copied()
            .filter(|&c| skel.parent(c) == Some(i))
            .map(file_index)
            .collect();
        let mut node = json!({
            "name": rename(&skel.names()[i]),
            "translation": t.to_array(),
            "rotation": local_rot.to_array(),
        });
        if !children.is_empty() {
            node["children"] = json!(children);
        }
        nodes[file_index(i)] = node;
    }
    let v = json!({"asset": {"version": "2.0"}, "nodes": nodes,
                   "scenes": [{"nodes": [file_index(0)]}], "scene": 0});
    let map = RigMap {
        limbs: Limb::ALL.map(|limb| LimbNames {
            joints: limb
                .element_names()
                .map(|e| rename(&format!("{}_{}", limb.name(), e))),
            tip: None,
        }),
    };
    (v, map)
}

#[test]
fn third_party_rig_loads_through_a_name_map_and_solves() {
    let (v, map) = third_party_json();
    let bytes = serde_json::to_vec(&v).unwrap();
    // Default names are absent.
    assert!(matches!(
        Rig::from_gltf_slice(&bytes, &RigMap::sloth()),
        Err(RigError::MissingJoint { .. })
    ));
    let other = Rig::from_gltf_slice(&bytes, &map).expect("loads with its map");
    let sloth = Rig::sloth();
    for limb in Limb::ALL {
        let a = other.chain(limb);
        let b = sloth.chain(limb);
        // Same rest geometry for the joints (the effector is extrapolated: no tip node).
        let pa = a.fk(RootTransform::IDENTITY, &ChainPose::NEUTRAL);
        let root_rot = {
            let j = other.limb_joints(limb).chain_root;
            let mut model = vec![glam::Affine3A::IDENTITY; other.skeleton().len()];
            other
                .skeleton()
                .fk(&other.skeleton().rest_rotations(), &mut model);
            model[j]
        };
        let pb = b.fk(RootTransform::IDENTITY, &ChainPose::NEUTRAL);
        for k in 0..4 {
            let pa_model = root_rot.transform_point3(pa[k]);
            let root_b = {
                let j = sloth.limb_joints(limb).chain_root;
                let mut model = vec![glam::Affine3A::IDENTITY; sloth.skeleton().len()];
                sloth
                    .skeleton()
                    .fk(&sloth.skeleton().rest_rotations(), &mut model);
                model[j]
            };
            let pb_model = root_b.transform_point3(pb[k]);
            assert!(pa_model.distance(pb_model) < 1e-4, "{limb} joint {k}");
        }
        // Its chain solves reachable targets (default SPEC limits, no extras).
        let u = [
            0.3f32, 0.6, 0.4, 0.2, 0.5, 0.5, 0.6, 0.2, 0.7, 0.4, 0.5, 0.5,
        ];
        let target = a.fk(RootTransform::IDENTITY, &a.sample_pose(&u))[4];
        let mut pose = ChainPose::NEUTRAL;
        solve(
            a,
            RootTransform::IDENTITY,
            target,
            &mut pose,
            &CcdParams::default(),
        );
        let err = a.fk(RootTransform::IDENTITY, &pose)[4].distance(target);
        assert!(err <= 1e-3, "{limb}: {err}");
        assert!(a.limit_violation(&pose) <= 1e-4);
    }
}
