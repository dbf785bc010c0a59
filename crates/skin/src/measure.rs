//! Shape measures for the flexion sweeps: cross-section area of the rings near a joint
//! and the enclosed volume of a limb tube.

use glam::Vec3;

use crate::mesh::{LIMB_SIDES, LIMB_VERTICES, SkinMesh};
use crate::sculpt::{LimbJoint, ZONE_RINGS};
use crate::{ClusterSkin, SkinError};

/// Area of a ring polygon (m²): |½ Σ (p_k − c) × (p_{k+1} − c)|, the area of its
/// projection on the plane that maximises it (exact for a planar ring).
pub fn ring_area(positions: &[Vec3], mesh: &SkinMesh, lj: LimbJoint, ring: usize) -> f32 {
    let c = mesh.ring_centre(positions, lj.limb, ring);
    let mut a = Vec3::ZERO;
    for k in 0..LIMB_SIDES {
        let p = positions[SkinMesh::tube_vertex(lj.limb, ring, k)] - c;
        let q = positions[SkinMesh::tube_vertex(lj.limb, ring, (k + 1) % LIMB_SIDES)] - c;
        a += p.cross(q);
    }
    0.5 * a.length()
}

/// Smallest ratio, over the rings within [`ZONE_RINGS`] of the joint, of posed to bind
/// cross-section area.
pub fn min_area_ratio(positions: &[Vec3], mesh: &SkinMesh, lj: LimbJoint) -> f32 {
    (lj.ring() - ZONE_RINGS..=lj.ring() + ZONE_RINGS)
        .map(|r| ring_area(positions, mesh, lj, r) / ring_area(&mesh.positions, mesh, lj, r))
        .fold(f32::INFINITY, f32::min)
}

/// Signed enclosed volume (m³) of a limb tube (closed by its two caps): ⅙ Σ a·(b × c).
pub fn limb_volume(positions: &[Vec3], mesh: &SkinMesh, lj: LimbJoint) -> f32 {
    let first = SkinMesh::tube_first(lj.limb);
    let range = first as u32..(first + LIMB_VERTICES) as u32;
    let mut v = 0.0f64;
    for t in mesh.indices.chunks_exact(3) {
        if range.contains(&t[0]) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize].as_dvec3());
            v += a.dot(b.cross(c));
        }
    }
    (v / 6.0) as f32
}

/// The three skinning methods compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Method {
    /// Linear blend skinning.
    Lbs,
    /// Dual-quaternion skinning.
    Dqs,
    /// Control clusters.
    Clusters,
}

impl Method {
    /// All three, in table order.
    pub const ALL: [Method; 3] = [Method::Lbs, Method::Dqs, Method::Clusters];

    /// Short name.
    pub fn name(self) -> &'static str {
        match self {
            Method::Lbs => "LBS",
            Method::Dqs => "DQS",
            Method::Clusters => "clusters",
        }
    }
}

/// Skin the mesh with `lj` flexed by `theta` (rad).
pub fn skin_flexed(
    mesh: &SkinMesh,
    clusters: &ClusterSkin,
    lj: LimbJoint,
    theta: f32,
    method: Method,
) -> Result<Vec<Vec3>, SkinError> {
    let posed = mesh.pose(&lj.flexed(mesh, theta)?)?;
    let mut out = Vec::new();
    match method {
        Method::Lbs => mesh.lbs(&posed, &mut out),
        Method::Dqs => mesh.dqs(&posed, &mut out),
        Method::Clusters => {
            let mut lbs = Vec::new();
            clusters.skin(mesh, &posed, &mut lbs, &mut out);
        }
    }
    Ok(out)
}

/// One sample of a flexion sweep.
#[derive(Clone, Copy, Debug)]
pub struct SweepRow {
    /// Flexion from the bind pose (degrees).
    pub deg: f32,
    /// Smallest cross-section near the joint / bind, per method ([`Method::ALL`] order).
    pub area: [f32; 3],
    /// Limb volume / bind, per method.
    pub volume: [f32; 3],
}

/// Flexion sweep of `lj` from 0 to its limit in `step_deg` steps (the limit included).
pub fn sweep(
    mesh: &SkinMesh,
    clusters: &ClusterSkin,
    lj: LimbJoint,
    step_deg: f32,
) -> Result<Vec<SweepRow>, SkinError> {
    let (_, limit) = lj.flexion(mesh)?;
    let limit_deg = limit.to_degrees();
    let mut angles: Vec<f32> = (0..)
        .map(|i| i as f32 * step_deg)
        .take_while(|d| *d < limit_deg - 1e-3)
        .collect();
    angles.push(limit_deg);
    let v0 = limb_volume(&mesh.positions, mesh, lj);
    angles
        .into_iter()
        .map(|deg| {
            let mut row = SweepRow {
                deg,
                area: [0.0; 3],
                volume: [0.0; 3],
            };
            for (m, method) in Method::ALL.into_iter().enumerate() {
                let p = skin_flexed(mesh, clusters, lj, deg.to_radians(), method)?;
                row.area[m] = min_area_ratio(&p, mesh, lj);
                row.volume[m] = limb_volume(&p, mesh, lj) / v0;
            }
            Ok(row)
        })
        .collect()
}
