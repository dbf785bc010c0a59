//! The offline step: control clusters and their reference shapes.
//!
//! **Clusters** (seed §3.1): pairs ⟨v_i, v_j⟩ of vertices across a limb joint whose
//! segment is orthogonal, in the bind pose, to the bone pair (the bone the ring lies on;
//! at the joint ring, the bisector of the two bones). On a limb tube these are opposite
//! vertices of a ring; we take the rings at [`CLUSTER_RING_OFFSETS`] from the joint ring
//! (all blended between the two bones). Vertices weighted to one bone only join the
//! control set automatically (they need no reference, LBS moves them rigidly).
//!
//! **Reference shapes** (the seed's ⟨X_i, S_i⟩): for each limb joint, the limb is flexed
//! at several hinge angles X_i and the blend zone (rings within [`ZONE_RINGS`] of the
//! joint ring) is sculpted by bending the tube along its centreline while keeping every
//! ring rigid (cross-section kept exactly) and every centreline segment its bind length
//! (so volume ≈ area × length is kept, Pappus): ring r turns by α_r θ, α_r rising
//! linearly in arclength from 0 (parent side) to 1 (child side) — a circular arc — and
//! the small end mismatch with the child bone is spread linearly along the zone; as the
//! bent centreline is then shorter, inner rings widen by k √(L0/L), k solved (secant)
//! so the limb's volume — as the cluster method rebuilds it from these cluster
//! positions, free rings by its spline — equals its bind volume: a volume-preserving sculpt.
//! Only the cluster vertices' positions are stored (seed: "references are needed only
//! for the cluster vertices"). [`reference_shapes`] computes them in code; the data
//! ([`ReferenceShapes`]) is what [`crate::ClusterSkin`] consumes.

use glam::{Quat, Vec3};
use slothsim_rig::{JointLimit, Limb};

use crate::SkinError;
use crate::mesh::{LIMB_SIDES, SkinMesh};

/// Rings on each side of a joint ring sculpted by the reference step (the blend zone
/// of the asset's weights is ±2.8 rings, so ring ±3 is already rigid).
pub const ZONE_RINGS: usize = 3;
/// Ring offsets from the joint ring that hold control clusters.
pub const CLUSTER_RING_OFFSETS: [isize; 3] = [-2, 0, 2];
/// Largest spacing of reference flexion angles (rad).
pub const MAX_REFERENCE_STEP: f32 = 7.5 * std::f32::consts::PI / 180.0;

/// A limb joint that gets control clusters: elbow/knee (element 2) or wrist/ankle (3).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LimbJoint {
    /// The limb.
    pub limb: Limb,
    /// Chain element: 2 = elbow/knee, 3 = wrist/ankle.
    pub element: usize,
}

impl LimbJoint {
    /// The eight corrected joints: elbow/knee and wrist/ankle of every limb.
    pub fn all() -> Vec<LimbJoint> {
        Limb::ALL
            .into_iter()
            .flat_map(|limb| [2, 3].map(|element| LimbJoint { limb, element }))
            .collect()
    }

    /// Common name: `LF elbow`, `RH ankle`, ….
    pub fn label(self) -> String {
        let kind = match (self.limb.is_fore(), self.element) {
            (true, 2) => "elbow",
            (true, _) => "wrist",
            (false, 2) => "knee",
            (false, _) => "ankle",
        };
        format!("{} {kind}", self.limb.name())
    }

    /// Skeleton index of the joint.
    pub fn joint(self, mesh: &SkinMesh) -> usize {
        mesh.rig.limb_joints(self.limb).joints[self.element]
    }

    /// Ring index of the joint on its limb tube.
    pub fn ring(self) -> usize {
        SkinMesh::joint_ring(self.element)
    }

    /// Hinge axis (joint rest frame) signed so that a positive angle flexes (closes) the
    /// joint, and the flexion limit (rad) from the joint's limit (SPEC Table 2).
    pub fn flexion(self, mesh: &SkinMesh) -> Result<(Vec3, f32), SkinError> {
        let j = self.joint(mesh);
        let skel = mesh.rig.skeleton();
        let Some(JointLimit::Hinge { axis, min, max }) = skel.limits()[j] else {
            return Err(SkinError::References {
                joint: skel.names()[j].clone(),
                why: "not a hinge joint".into(),
            });
        };
        let axis = Vec3::from(axis);
        // Turn between the bones before and after the joint, at a small positive angle.
        let turn = |q: Quat| {
            let mut locals = skel.rest_rotations();
            locals[j] *= q;
            let posed = mesh.pose(&locals).expect("finite rotation");
            let lj = mesh.rig.limb_joints(self.limb);
            let next = if self.element < 3 {
                lj.joints[self.element + 1]
            } else {
                lj.tip.unwrap_or(j)
            };
            let p = |i: usize| Vec3::from(posed.world[i].translation);
            let a = p(j) - p(lj.joints[self.element - 1]);
            let b = p(next) - p(j);
            a.angle_between(b)
        };
        let opens = turn(Quat::from_axis_angle(axis, 0.05)) < turn(Quat::IDENTITY);
        Ok(if opens { (-axis, -min) } else { (axis, max) })
    }

    /// Local rotations of the bind pose with this joint flexed by `theta` (rad).
    pub fn flexed(self, mesh: &SkinMesh, theta: f32) -> Result<Vec<Quat>, SkinError> {
        let (axis, _) = self.flexion(mesh)?;
        let mut locals = mesh.rig.skeleton().rest_rotations();
        let j = self.joint(mesh);
        locals[j] *= Quat::from_axis_angle(axis, theta);
        Ok(locals)
    }
}

/// Reference shapes of one joint's clusters (plain data).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointReferences {
    /// Skeleton joint name.
    pub joint: String,
    /// Configurations X_i: the joint's local rotation relative to rest, as a rotation
    /// vector (rad).
    pub configs: Vec<Vec3>,
    /// Cluster vertex pairs.
    pub pairs: Vec<[usize; 2]>,
    /// `shapes[i][2 * p + s]`: reference position of `pairs[p][s]` at `configs[i]`.
    pub shapes: Vec<Vec<Vec3>>,
}

/// Reference shapes of every corrected joint (stored as `assets/sloth_skin_refs.json`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ReferenceShapes {
    /// One entry per joint.
    pub joints: Vec<JointReferences>,
}

impl ReferenceShapes {
    /// The stored reference shapes of the default sloth (`assets/sloth_skin_refs.json`,
    /// written by `cargo run -p slothsim-tools --bin gen-skin-refs`).
    pub fn sloth() -> Result<ReferenceShapes, SkinError> {
        ReferenceShapes::from_json(include_bytes!("../../../assets/sloth_skin_refs.json"))
    }

    /// Parse stored reference shapes; a malformed file is an error naming the field.
    pub fn from_json(bytes: &[u8]) -> Result<ReferenceShapes, SkinError> {
        serde_json::from_slice(bytes)
            .map_err(|e| SkinError::Field("reference shapes JSON", e.to_string()))
    }

    /// Serialise (compact JSON; deterministic).
    pub fn to_json(&self) -> Vec<u8> {
        serde_json::to_vec(self).expect("plain data serialises")
    }
}

/// Cluster pairs of a joint (seed §3.1): opposite ring vertices on the cluster rings whose
/// bind segment is orthogonal to the bone the ring lies on (bisector at the joint ring).
pub fn find_clusters(mesh: &SkinMesh, lj: LimbJoint) -> Vec<[usize; 2]> {
    let joints = mesh.rig.limb_joints(lj.limb);
    let p = |i: usize| Vec3::from(mesh.bind[i].translation);
    let next = if lj.element < 3 {
        joints.joints[lj.element + 1]
    } else {
        joints.tip.unwrap_or(joints.joints[3])
    };
    let jp = p(lj.joint(mesh));
    let parent_dir = (jp - p(joints.joints[lj.element - 1])).normalize();
    let child_dir = (p(next) - jp).normalize();
    let mut pairs = Vec::new();
    for off in CLUSTER_RING_OFFSETS {
        let ring = lj.ring().strict_add_signed(off);
        let dir = match off.signum() {
            -1 => parent_dir,
            1 => child_dir,
            _ => (parent_dir + child_dir).normalize(),
        };
        for k in 0..LIMB_SIDES / 2 {
            let a = SkinMesh::tube_vertex(lj.limb, ring, k);
            let b = SkinMesh::tube_vertex(lj.limb, ring, k + LIMB_SIDES / 2);
            let seg = mesh.positions[b] - mesh.positions[a];
            let blended = [a, b].iter().all(|&v| mesh.weights[v][0] < 1.0);
            if blended && seg.normalize().dot(dir).abs() < 0.02 {
                pairs.push([a, b]);
            }
        }
    }
    pairs
}

/// The sculpted (volume-keeping) positions of the zone rings of `lj` flexed by `theta`,
/// as `(vertex, position)`.
pub fn sculpt(mesh: &SkinMesh, lj: LimbJoint, theta: f32) -> Result<Vec<(usize, Vec3)>, SkinError> {
    let posed = mesh.pose(&lj.flexed(mesh, theta)?)?;
    let mut full = Vec::new();
    mesh.lbs(&posed, &mut full);
    let bind_volume = crate::measure::limb_volume(&mesh.positions, mesh, lj);
    // Control vertices as the cluster method sees them: single-bone ones and the clusters.
    let mut control: Vec<bool> = mesh.weights.iter().map(|w| w[0] >= 1.0 - 1e-6).collect();
    for v in find_clusters(mesh, lj).into_iter().flatten() {
        control[v] = true;
    }
    // Volume of the limb as the cluster method rebuilds it from this reference (cluster
    // vertices sculpted at extra widening `k`, free vertices by the spline pass).
    let volume = |k: f32| {
        let mut p = full.clone();
        for (v, x) in bent_zone(mesh, lj, &posed, k) {
            if control[v] {
                p[v] = x;
            }
        }
        for side in 0..LIMB_SIDES {
            crate::cluster::spline_line(
                &control,
                crate::DEFAULT_TENSION,
                lj.limb,
                side,
                &full,
                &mut p,
            );
        }
        crate::measure::limb_volume(&p, mesh, lj)
    };
    // Secant on k so that volume equals the bind volume (folds on the inside of the bend
    // and the spline's overshoot change it a little beyond the length rule).
    let (mut k0, mut k1) = (1.0f32, 1.01f32);
    let (mut v0, mut v1) = (volume(k0), volume(k1));
    for _ in 0..6 {
        if (v1 - v0).abs() < 1e-12 || (v1 - bind_volume).abs() < 1e-9 * bind_volume {
            break;
        }
        let k2 = (k1 + (bind_volume - v1) * (k1 - k0) / (v1 - v0)).clamp(0.8, 1.5);
        (k0, v0) = (k1, v1);
        k1 = k2;
        v1 = volume(k1);
    }
    Ok(bent_zone(mesh, lj, &posed, k1))
}

/// The bent zone (see the module doc) with inner rings widened by `k` √(L0 / L).
fn bent_zone(mesh: &SkinMesh, lj: LimbJoint, posed: &crate::Posed, k: f32) -> Vec<(usize, Vec3)> {
    let joints = mesh.rig.limb_joints(lj.limb);
    let mp = posed.skin[joints.joints[lj.element - 1]];
    let mc = posed.skin[lj.joint(mesh)];
    let (_, rp, _) = mp.to_scale_rotation_translation();
    let (_, rc, _) = mc.to_scale_rotation_translation();
    let (axis, angle) = (rc * rp.inverse()).to_axis_angle();
    let turn = |a: f32| Quat::from_axis_angle(axis, a * angle) * rp;
    let rings: Vec<usize> = (lj.ring() - ZONE_RINGS..=lj.ring() + ZONE_RINGS).collect();
    let centres: Vec<Vec3> = rings
        .iter()
        .map(|&r| mesh.ring_centre(&mesh.positions, lj.limb, r))
        .collect();
    let mut arc = vec![0.0f32; rings.len()];
    for i in 1..rings.len() {
        arc[i] = arc[i - 1] + centres[i].distance(centres[i - 1]);
    }
    let alpha: Vec<f32> = arc.iter().map(|s| s / arc[arc.len() - 1]).collect();
    let mut bent = vec![mp.transform_point3(centres[0])];
    for i in 1..rings.len() {
        let mid = 0.5 * (alpha[i] + alpha[i - 1]);
        let step = turn(mid) * (centres[i] - centres[i - 1]);
        bent.push(bent[i - 1] + step);
    }
    let last = rings.len() - 1;
    let miss = bent[last] - mc.transform_point3(centres[last]);
    let bent: Vec<Vec3> = (0..rings.len())
        .map(|i| bent[i] - miss * alpha[i])
        .collect();
    // Volume kept: the zone's end rings are fixed by the bones, so the bent centreline
    // comes out shorter than the bind one; each inner ring is widened by √(L0 / L) (its
    // two half-segments' bind / bent length) so area × length, the volume, is kept.
    let half = |c: &[Vec3], i: usize| {
        let before = if i > 0 { c[i].distance(c[i - 1]) } else { 0.0 };
        let after = if i < last {
            c[i].distance(c[i + 1])
        } else {
            0.0
        };
        0.5 * (before + after)
    };
    let mut out = Vec::with_capacity(rings.len() * LIMB_SIDES);
    for (i, &r) in rings.iter().enumerate() {
        let widen = if i == 0 || i == last {
            1.0
        } else {
            k * (half(&centres, i) / half(&bent, i).max(1e-9)).sqrt()
        };
        let q = turn(alpha[i]);
        for k in 0..LIMB_SIDES {
            let v = SkinMesh::tube_vertex(lj.limb, r, k);
            out.push((v, bent[i] + q * (mesh.positions[v] - centres[i]) * widen));
        }
    }
    out
}

/// Reference flexion angles of a joint: from −limit to +limit, at most
/// [`MAX_REFERENCE_STEP`] apart (the bind pose, 0, included).
pub fn reference_angles(limit: f32) -> Vec<f32> {
    let half = (limit / MAX_REFERENCE_STEP).ceil().max(1.0) as i32;
    (-half..=half)
        .map(|i| limit * i as f32 / half as f32)
        .collect()
}

/// The offline step: clusters and their sculpted reference shapes for every
/// corrected joint of `mesh`.
pub fn reference_shapes(mesh: &SkinMesh) -> Result<ReferenceShapes, SkinError> {
    let mut joints = Vec::new();
    for lj in LimbJoint::all() {
        let (axis, limit) = lj.flexion(mesh)?;
        let pairs = find_clusters(mesh, lj);
        let mut configs = Vec::new();
        let mut shapes = Vec::new();
        for theta in reference_angles(limit) {
            let sculpted = sculpt(mesh, lj, theta)?;
            let at = |v: usize| {
                sculpted
                    .iter()
                    .find(|(i, _)| *i == v)
                    .map(|(_, p)| *p)
                    .expect("cluster rings lie in the zone")
            };
            configs.push(axis * theta);
            shapes.push(pairs.iter().flat_map(|&[a, b]| [at(a), at(b)]).collect());
        }
        joints.push(JointReferences {
            joint: mesh.rig.skeleton().names()[lj.joint(mesh)].clone(),
            configs,
            pairs,
            shapes,
        });
    }
    Ok(ReferenceShapes { joints })
}
