//! Corrective morph targets (the glTF carrier of the cluster correction): applied in bind
//! space and then skinned by LBS (glTF's "morph, then skin"), they reproduce the in-house
//! cluster result.

use glam::{Quat, Vec3};
use slothsim_skin::{
    ClusterSkin, CorrectiveTargets, LimbJoint, MorphScratch, ReferenceShapes, SkinMesh,
};

fn setup() -> (SkinMesh, ClusterSkin, CorrectiveTargets) {
    let mesh = SkinMesh::sloth().expect("asset");
    let clusters = ClusterSkin::new(&mesh, &ReferenceShapes::sloth().expect("refs")).unwrap();
    let targets = CorrectiveTargets::new(&mesh, &clusters).expect("targets");
    (mesh, clusters, targets)
}

/// A deterministic uniform sequence in [0, 1).
fn lcg(seed: u64) -> impl FnMut() -> f32 {
    let mut s = seed;
    move || {
        s = s
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// glTF's evaluation: bind positions + Σ m_k t_k, then LBS.
fn morph_then_lbs(
    mesh: &SkinMesh,
    targets: &CorrectiveTargets,
    locals: &[Quat],
    w: &[f32],
) -> Vec<Vec3> {
    let mut morphed = mesh.clone();
    morphed.positions = targets.morphed(mesh, w);
    let mut out = Vec::new();
    morphed.lbs(&morphed.pose(locals).unwrap(), &mut out);
    out
}

#[test]
fn morph_then_lbs_reproduces_the_cluster_result_with_every_hinge_flexed() {
    let (mesh, clusters, targets) = setup();
    assert!(
        !targets.is_empty() && targets.len() <= 40,
        "{}",
        targets.len()
    );
    let mut rnd = lcg(7);
    let skel = mesh.rig.skeleton();
    let root = (0..skel.len()).find(|&i| skel.parent(i).is_none()).unwrap();
    let (mut scratch, mut w, mut w_exact) = (MorphScratch::default(), Vec::new(), Vec::new());
    let (mut worst, mut worst_correction, mut worst_table) = (0.0f32, 0.0f32, 0.0f32);
    for _ in 0..40 {
        let mut locals = skel.rest_rotations();
        locals[root] = Quat::from_euler(glam::EulerRot::YXZ, rnd() * 6.0, rnd() - 0.5, rnd());
        for lj in LimbJoint::all() {
            let (axis, limit) = lj.flexion(&mesh).unwrap();
            locals[lj.joint(&mesh)] *= Quat::from_axis_angle(axis, (2.0 * rnd() - 1.0) * limit);
        }
        let posed = mesh.pose(&locals).unwrap();
        let residual = targets
            .weights(&mesh, &clusters, &posed, &mut scratch, &mut w)
            .unwrap();
        targets
            .weights_exact(&mesh, &clusters, &posed, &mut scratch, &mut w_exact)
            .unwrap();
        assert_eq!(w.len(), targets.len());
        assert!(w.iter().all(|m| (0.0..=1.0).contains(m)), "weights {w:?}");
        for (a, b) in w.iter().zip(&w_exact) {
            worst_table = worst_table.max((a - b).abs());
        }
        let (mut lbs, mut want) = (Vec::new(), Vec::new());
        clusters.skin(&mesh, &posed, &mut lbs, &mut want);
        let got = morph_then_lbs(&mesh, &targets, &locals, &w);
        for ((g, c), l) in got.iter().zip(&want).zip(&lbs) {
            worst = worst.max(g.distance(*c));
            worst_correction = worst_correction.max(c.distance(*l));
        }
        assert!(residual <= 3e-4, "residual {residual}");
    }
    println!(
        "morph-then-LBS vs clusters {:.3} mm (corrections up to {:.2} mm); table vs exact weights {:.2e}",
        worst * 1e3,
        worst_correction * 1e3,
        worst_table
    );
    assert!(worst <= 3e-4, "{worst} m");
    assert!(
        worst_correction > 3e-3,
        "the poses flex: {worst_correction}"
    );
    assert!(worst_table < 1e-3, "{worst_table}");
}

#[test]
fn an_off_hinge_rotation_is_projected_exactly_and_its_error_is_bounded_by_the_residual() {
    let (mesh, clusters, targets) = setup();
    let lj = LimbJoint::all()[0];
    let (axis, limit) = lj.flexion(&mesh).unwrap();
    let mut locals = mesh.rig.skeleton().rest_rotations();
    let off = axis.any_orthonormal_vector();
    locals[lj.joint(&mesh)] *=
        Quat::from_axis_angle(axis, 0.7 * limit) * Quat::from_axis_angle(off, 0.05);
    let posed = mesh.pose(&locals).unwrap();
    let (mut scratch, mut w) = (MorphScratch::default(), Vec::new());
    let residual = targets
        .weights(&mesh, &clusters, &posed, &mut scratch, &mut w)
        .unwrap();
    let (mut lbs, mut want) = (Vec::new(), Vec::new());
    clusters.skin(&mesh, &posed, &mut lbs, &mut want);
    let got = morph_then_lbs(&mesh, &targets, &locals, &w);
    let err = got
        .iter()
        .zip(&want)
        .map(|(g, c)| g.distance(*c))
        .fold(0.0f32, f32::max);
    println!(
        "off-hinge by 0.05 rad: error {:.3} mm, residual {:.3} mm",
        err * 1e3,
        residual * 1e3
    );
    assert!(err <= residual + 1e-6, "{err} > {residual}");
    assert!(w.iter().all(|m| m.is_finite()));
}

#[test]
fn locals_with_names_a_missing_joint_and_a_nan_pose_is_an_error() {
    let (mesh, clusters, targets) = setup();
    let e = mesh.locals_with(&[999], &[Quat::IDENTITY]).unwrap_err();
    assert!(e.to_string().contains("999"), "{e}");
    let e = mesh.locals_with(&[1, 2], &[Quat::IDENTITY]).unwrap_err();
    assert!(e.to_string().contains("moved joints"), "{e}");
    let lj = LimbJoint::all()[2];
    let j = lj.joint(&mesh);
    let locals = mesh
        .locals_with(&[j], &[Quat::from_xyzw(0.0, f32::NAN, 0.0, 1.0)])
        .unwrap();
    let e = mesh.pose(&locals).unwrap_err();
    assert!(
        e.to_string().contains(&mesh.rig.skeleton().names()[j]),
        "{e}"
    );
    let _ = (clusters, targets);
}

#[test]
fn bad_reference_shapes_are_errors_naming_the_joint_and_vertex() {
    let mesh = SkinMesh::sloth().unwrap();
    let good = ReferenceShapes::sloth().unwrap();
    let joint = good.joints[2].joint.clone();
    let check = |refs: &ReferenceShapes, needles: &[&str]| {
        let e = ClusterSkin::new(&mesh, refs).unwrap_err().to_string();
        for n in needles {
            assert!(e.contains(n), "`{e}` lacks `{n}`");
        }
    };
    // A joint with no clusters.
    let mut refs = good.clone();
    refs.joints[2].pairs.clear();
    check(&refs, &[&joint, "no control clusters"]);
    // A vertex named by two clusters.
    let mut refs = good.clone();
    let v = refs.joints[2].pairs[0][0];
    refs.joints[2].pairs[1][0] = v;
    check(&refs, &[&joint, &v.to_string(), "two clusters"]);
    // A vertex of another limb (not weighted to the joint's bones).
    let mut refs = good.clone();
    refs.joints[2].pairs[0][1] = good.joints[6].pairs[0][0];
    check(&refs, &[&joint, "not weighted to the joint's bones"]);
    // A non-finite reference position.
    let mut refs = good.clone();
    refs.joints[2].shapes[3][5] = Vec3::new(0.0, f32::NAN, 0.0);
    check(&refs, &[&joint, "shape 3 is not finite"]);
    // A joint missing altogether (the rig asset lacks its reference shapes).
    let mut refs = good.clone();
    refs.joints.retain(|j| j.joint != joint);
    check(&refs, &[&joint, "missing reference shapes"]);
    // Fewer shapes than configurations.
    let mut refs = good;
    refs.joints[2].shapes.pop();
    check(&refs, &[&joint, "need ≥ 2, equal"]);
}
