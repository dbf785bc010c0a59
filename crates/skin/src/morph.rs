//! Corrective morph targets: the cluster correction as glTF morph targets (pose-space
//! deformation), for viewers that only know "morph, then skin".
//!
//! glTF applies morph targets in bind space, before skinning:
//! v′ = Σ_s w_s M_s (v₀ + Σ_k m_k t_k), M_s = W_s B_s⁻¹ (the joint matrices). That is
//! LBS(v₀) + A Σ_k m_k t_k with A = Σ_s w_s R_s, the blend of the bones' rotations. The
//! in-house cluster result is LBS(v₀) + c (c: the correction of [`ClusterSkin::skin`], in
//! model space), so the bind-space correction that reproduces it exactly is
//! δ = A⁻¹ c, per vertex.
//!
//! Per corrected joint, δ on the joint's zone depends only on that joint's local rotation:
//! the zone's vertices are weighted to the joint and its parent bone, R_child = R_parent Q
//! with Q the joint's own rotation, and the spline pass uses distances only. So for each
//! joint we sample δ(θ) densely over its hinge range (1.25 × its limit both ways, 0.25°
//! steps), and take a small orthonormal basis e_k of those samples (greedy pivoted
//! Gram–Schmidt: add the worst-fitted sample's residual until every sampled vertex is
//! within [`CorrectiveTargets::TOLERANCE_M`]). Each basis vector becomes two targets,
//! +s⁺_k e_k and −s⁻_k e_k (s⁺_k, s⁻_k: the largest positive and negative coefficient
//! seen; a sign never seen gets no target), so that every weight lies in [0, 1] (Blender
//! clamps negative shape-key values on import). At export time, per sloth and sample,
//! [`CorrectiveTargets::weights`] gives the coefficients m_k = δ · e_k of each joint: for
//! a hinge rotation within the sampled range, linearly between those of the two
//! neighbouring sampled angles (the pose-space table); otherwise δ is computed exactly
//! from the pose and projected. The world-space error of morph-then-skin against the in-house
//! result is |A (δ − Σ m_k e_k)| ≤ the bind-space residual it returns (‖A‖ ≤ 1).

use glam::{DVec3, Mat3, Quat, Vec3};

use crate::lbs::Posed;
use crate::sculpt::LimbJoint;
use crate::{ClusterSkin, SkinError, SkinMesh};

/// One corrective morph target: bind-space displacements of a few vertices (sparse).
#[derive(Clone, Debug, PartialEq)]
pub struct MorphTarget {
    /// Name (`LF elbow 1+`): the joint, the basis vector, its sign.
    pub name: String,
    /// Displaced vertices, strictly increasing.
    pub vertices: Vec<u32>,
    /// Their bind-space displacements (m).
    pub displacements: Vec<Vec3>,
}

/// One joint's basis and its table of coefficients over the hinge angle.
#[derive(Clone, Debug)]
struct JointBasis {
    label: String,
    /// Skeleton index of the joint, its rest rotation and flexion axis (rest frame).
    joint: usize,
    rest: Quat,
    axis: Vec3,
    /// The vertices the joint's correction moves (sorted).
    vertices: Vec<usize>,
    /// Orthonormal basis vectors over `vertices`.
    basis: Vec<Vec<DVec3>>,
    /// Target scales [s_k⁺, s_k⁻]: the largest positive and negative coefficient over the
    /// samples; `None`: no sample has that sign, no target.
    scale: Vec<[Option<f64>; 2]>,
    /// Sampled hinge angles θ_i (rad, evenly spaced, increasing).
    angles: Vec<f32>,
    /// Coefficients of the basis at each θ_i (as the targets can carry them).
    coeffs: Vec<Vec<f64>>,
    /// Fit residual at each θ_i (m).
    residuals: Vec<f64>,
}

impl JointBasis {
    /// Coefficients of `delta` (bind-space corrections of every vertex) on the basis,
    /// as the targets can carry them (a sign without a target contributes 0), and the
    /// largest per-vertex residual (m).
    fn project(&self, delta: &[DVec3]) -> (Vec<f64>, f64) {
        let mut fit = vec![DVec3::ZERO; self.vertices.len()];
        let mut coeffs = Vec::with_capacity(self.basis.len());
        for (e, [plus, minus]) in self.basis.iter().zip(&self.scale) {
            let c: f64 = self
                .vertices
                .iter()
                .zip(e)
                .map(|(&v, b)| delta[v].dot(*b))
                .sum();
            let c = match (plus, minus) {
                (None, _) => c.min(0.0),
                (_, None) => c.max(0.0),
                _ => c,
            };
            fit.iter_mut().zip(e).for_each(|(f, b)| *f += *b * c);
            coeffs.push(c);
        }
        let residual = self
            .vertices
            .iter()
            .zip(&fit)
            .map(|(&v, f)| delta[v].distance(*f))
            .fold(0.0, f64::max);
        (coeffs, residual)
    }

    /// Coefficients and residual from the table when the joint's rotation is a hinge
    /// rotation within the sampled range: linear in θ between neighbouring samples (the
    /// residual is the larger of theirs). `None` otherwise.
    fn lookup(&self, local: Quat) -> Option<(Vec<f64>, f64)> {
        let x = crate::cluster::rotation_vector(self.rest.inverse() * local);
        let theta = x.dot(self.axis);
        if (x - self.axis * theta).length() > OFF_AXIS_MAX {
            return None;
        }
        let (first, last) = (self.angles[0], self.angles[self.angles.len() - 1]);
        if !(first..=last).contains(&theta) {
            return None;
        }
        let f = (theta - first) / (last - first) * (self.angles.len() - 1) as f32;
        let i = (f.floor() as usize).min(self.angles.len() - 2);
        let u = f64::from(f - i as f32);
        let (a, b) = (&self.coeffs[i], &self.coeffs[i + 1]);
        let c = a.iter().zip(b).map(|(x, y)| x + (y - x) * u).collect();
        Some((c, self.residuals[i].max(self.residuals[i + 1])))
    }

    /// Push the target weights of coefficients `c`.
    fn push_weights(&self, c: &[f64], weights: &mut Vec<f32>) {
        for (c, scale) in c.iter().zip(&self.scale) {
            for (sign, s) in [1.0, -1.0].into_iter().zip(scale) {
                if let Some(s) = s {
                    weights.push(((sign * c).max(0.0) / s) as f32);
                }
            }
        }
    }
}

/// Reusable buffers for [`CorrectiveTargets::weights`].
#[derive(Clone, Debug, Default)]
pub struct MorphScratch {
    lbs: Vec<Vec3>,
    out: Vec<Vec3>,
    delta: Vec<DVec3>,
}

/// The corrective targets of a cluster skin (see the module doc).
#[derive(Clone, Debug)]
pub struct CorrectiveTargets {
    joints: Vec<JointBasis>,
    vertex_count: usize,
}

/// Hinge range sampled for the basis, as a multiple of the joint's flexion limit.
const SAMPLED_RANGE: f32 = 1.25;
/// Sampling step (rad).
const SAMPLE_STEP: f32 = 0.25 * std::f32::consts::PI / 180.0;
/// A sign of a basis coefficient gets a target when samples reach this share of its range.
const SIGN_EPS: f64 = 0.01;
/// A vertex belongs to a joint's zone when some sample moves it by more than this (m).
const SUPPORT_EPS: f64 = 1e-7;
/// A joint rotation this far (rad) off its hinge axis is projected exactly, not looked up.
const OFF_AXIS_MAX: f32 = 1e-4;

impl CorrectiveTargets {
    /// Largest per-vertex distance (m) between a sampled correction and its projection
    /// on the basis.
    pub const TOLERANCE_M: f64 = 2.5e-4;

    /// Build the basis of every corrected joint of `clusters` (module doc). Errors name
    /// the joint (a singular bone blend, or zones that overlap).
    pub fn new(mesh: &SkinMesh, clusters: &ClusterSkin) -> Result<CorrectiveTargets, SkinError> {
        Self::with_tolerance(mesh, clusters, Self::TOLERANCE_M)
    }

    /// [`Self::new`] with another fit tolerance (m).
    pub fn with_tolerance(
        mesh: &SkinMesh,
        clusters: &ClusterSkin,
        tolerance_m: f64,
    ) -> Result<CorrectiveTargets, SkinError> {
        let mut scratch = MorphScratch::default();
        let mut joints: Vec<JointBasis> = Vec::new();
        let mut owner: Vec<Option<usize>> = vec![None; mesh.positions.len()];
        for lj in LimbJoint::all() {
            let label = lj.label();
            let (axis, limit) = lj.flexion(mesh)?;
            let half = (SAMPLED_RANGE * limit / SAMPLE_STEP).ceil() as i32;
            let angles: Vec<f32> = (-half..=half)
                .map(|i| SAMPLED_RANGE * limit * i as f32 / half as f32)
                .collect();
            let mut samples: Vec<Vec<DVec3>> = Vec::new();
            for &theta in &angles {
                let posed = mesh.pose(&lj.flexed(mesh, theta)?)?;
                bind_corrections(mesh, clusters, &posed, &mut scratch)?;
                samples.push(scratch.delta.clone());
            }
            let vertices: Vec<usize> = (0..mesh.positions.len())
                .filter(|&v| samples.iter().any(|s| s[v].length() > SUPPORT_EPS))
                .collect();
            for &v in &vertices {
                if let Some(other) = owner[v] {
                    return Err(SkinError::References {
                        joint: label,
                        why: format!(
                            "its correction moves vertex {v}, which {} also moves (zones overlap)",
                            joints[other].label
                        ),
                    });
                }
                owner[v] = Some(joints.len());
            }
            let mut residual: Vec<Vec<DVec3>> = samples
                .iter()
                .map(|s| vertices.iter().map(|&v| s[v]).collect())
                .collect();
            let worst = |r: &[DVec3]| r.iter().map(|d| d.length()).fold(0.0, f64::max);
            let mut basis: Vec<Vec<DVec3>> = Vec::new();
            while basis.len() < vertices.len() * 3 {
                let (pick, err) = residual
                    .iter()
                    .enumerate()
                    .map(|(i, r)| (i, worst(r)))
                    .fold((0, 0.0), |a, b| if b.1 > a.1 { b } else { a });
                if err <= tolerance_m {
                    break;
                }
                let mut e = residual[pick].clone();
                // Re-orthogonalise against the basis (modified Gram–Schmidt).
                for b in &basis {
                    let d = dot(&e, b);
                    e.iter_mut().zip(b).for_each(|(x, y)| *x -= *y * d);
                }
                let n = dot(&e, &e).sqrt();
                e.iter_mut().for_each(|x| *x /= n);
                for r in &mut residual {
                    let d = dot(r, &e);
                    r.iter_mut().zip(&e).for_each(|(x, y)| *x -= *y * d);
                }
                basis.push(e);
            }
            // Coefficient range of each basis vector over the samples: the `+` target is
            // scaled by the largest positive coefficient, the `−` one by the largest
            // negative one; a sign no sample takes gets no target.
            let scale = basis
                .iter()
                .map(|e| {
                    let (lo, hi) = samples.iter().fold((0.0f64, 0.0f64), |(lo, hi), s| {
                        let c: f64 = vertices.iter().zip(e).map(|(&v, b)| s[v].dot(*b)).sum();
                        (lo.min(c), hi.max(c))
                    });
                    let keep = |x: f64| (x > SIGN_EPS * (hi - lo)).then_some(x);
                    [keep(hi), keep(-lo)]
                })
                .collect();
            let mut jb = JointBasis {
                label,
                joint: lj.joint(mesh),
                rest: mesh.rig.skeleton().rest_rotations()[lj.joint(mesh)],
                axis,
                vertices,
                basis,
                scale,
                angles,
                coeffs: Vec::new(),
                residuals: Vec::new(),
            };
            for s in &samples {
                let (c, r) = jb.project(s);
                jb.coeffs.push(c);
                jb.residuals.push(r);
            }
            joints.push(jb);
        }
        Ok(CorrectiveTargets {
            joints,
            vertex_count: mesh.positions.len(),
        })
    }

    /// Number of morph targets (one or two per basis vector).
    pub fn len(&self) -> usize {
        self.joints
            .iter()
            .flat_map(|j| j.scale.iter().flatten())
            .filter(|s| s.is_some())
            .count()
    }

    /// No targets?
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Vertices of the mesh the targets were built for.
    pub fn vertex_count(&self) -> usize {
        self.vertex_count
    }

    /// Basis vectors per joint, `(label, count)`.
    pub fn per_joint(&self) -> Vec<(String, usize)> {
        self.joints
            .iter()
            .map(|j| (j.label.clone(), j.basis.len()))
            .collect()
    }

    /// The targets, in weight order: per joint, per basis vector, `+` then `−` (where
    /// the samples take that sign).
    pub fn targets(&self) -> Vec<MorphTarget> {
        let mut out = Vec::with_capacity(self.len());
        for j in &self.joints {
            for (k, (e, scale)) in j.basis.iter().zip(&j.scale).enumerate() {
                for ((sign, tag), s) in [(1.0, '+'), (-1.0, '-')].into_iter().zip(scale) {
                    if let Some(s) = s {
                        out.push(MorphTarget {
                            name: format!("{} {}{tag}", j.label, k + 1),
                            vertices: j.vertices.iter().map(|&v| v as u32).collect(),
                            displacements: e.iter().map(|d| (*d * (sign * s)).as_vec3()).collect(),
                        });
                    }
                }
            }
        }
        out
    }

    /// The morph weights ([`Self::len`] of them, each in [0, 1] within the sampled
    /// range) that reproduce the cluster result of `posed`, into `weights`; returns the
    /// fit residual (m), a bound on morph-then-skin's distance from the in-house result.
    ///
    /// A joint whose rotation is a hinge rotation within the sampled range is looked up
    /// in its table (linear between the neighbouring sampled angles; the residual is
    /// theirs); any other is computed exactly (cluster skin of the pose, δ = A⁻¹ c,
    /// projected on the basis).
    pub fn weights(
        &self,
        mesh: &SkinMesh,
        clusters: &ClusterSkin,
        posed: &Posed,
        scratch: &mut MorphScratch,
        weights: &mut Vec<f32>,
    ) -> Result<f32, SkinError> {
        weights.clear();
        let mut worst = 0.0f64;
        let mut exact = false;
        for j in &self.joints {
            let (c, r) = match j.lookup(posed.locals[j.joint]) {
                Some(hit) => hit,
                None => {
                    if !exact {
                        bind_corrections(mesh, clusters, posed, scratch)?;
                        exact = true;
                    }
                    j.project(&scratch.delta)
                }
            };
            worst = worst.max(r);
            j.push_weights(&c, weights);
        }
        Ok(worst as f32)
    }

    /// [`Self::weights`] computed exactly, never from the table (for tests).
    pub fn weights_exact(
        &self,
        mesh: &SkinMesh,
        clusters: &ClusterSkin,
        posed: &Posed,
        scratch: &mut MorphScratch,
        weights: &mut Vec<f32>,
    ) -> Result<f32, SkinError> {
        weights.clear();
        bind_corrections(mesh, clusters, posed, scratch)?;
        let mut worst = 0.0f64;
        for j in &self.joints {
            let (c, r) = j.project(&scratch.delta);
            worst = worst.max(r);
            j.push_weights(&c, weights);
        }
        Ok(worst as f32)
    }

    /// Bind-pose positions with `weights` applied (glTF: v₀ + Σ_k m_k t_k).
    pub fn morphed(&self, mesh: &SkinMesh, weights: &[f32]) -> Vec<Vec3> {
        let mut p = mesh.positions.clone();
        for (t, &m) in self.targets().iter().zip(weights) {
            for (&v, d) in t.vertices.iter().zip(&t.displacements) {
                p[v as usize] += *d * m;
            }
        }
        p
    }
}

fn dot(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x.dot(*y)).sum()
}

/// The exact bind-space correction δ = A⁻¹ c of every vertex at `posed` into
/// `scratch.delta` (module doc).
fn bind_corrections(
    mesh: &SkinMesh,
    clusters: &ClusterSkin,
    posed: &Posed,
    scratch: &mut MorphScratch,
) -> Result<(), SkinError> {
    clusters.skin(mesh, posed, &mut scratch.lbs, &mut scratch.out);
    scratch.delta.clear();
    for v in 0..mesh.positions.len() {
        let c = scratch.out[v] - scratch.lbs[v];
        if c == Vec3::ZERO {
            scratch.delta.push(DVec3::ZERO);
            continue;
        }
        let mut a = Mat3::ZERO;
        for s in 0..4 {
            let w = mesh.weights[v][s];
            if w > 0.0 {
                a += Mat3::from(posed.skin[usize::from(mesh.joints[v][s])].matrix3) * w;
            }
        }
        let det = a.determinant();
        if det.is_nan() || det.abs() <= 1e-6 || !c.is_finite() {
            return Err(SkinError::Cluster {
                joint: bone_name(mesh, v),
                vertex: v,
                why: format!(
                    "cannot carry its correction to bind space (bone blend determinant {det}, correction {c})"
                ),
            });
        }
        scratch.delta.push(a.as_dmat3().inverse() * c.as_dvec3());
    }
    Ok(())
}

/// Name of the first bone a vertex is weighted to (for errors).
fn bone_name(mesh: &SkinMesh, v: usize) -> String {
    mesh.rig.skeleton().names()[usize::from(mesh.joints[v][0])].clone()
}

impl SkinMesh {
    /// The local rotations of a pose given only its moved joints: rest rotations, then
    /// `rotations[k]` for joint `moved[k]` (the export's and the recording's layout).
    /// A moved joint past the skeleton is an error naming it.
    pub fn locals_with(&self, moved: &[usize], rotations: &[Quat]) -> Result<Vec<Quat>, SkinError> {
        let skel = self.rig.skeleton();
        let mut locals = skel.rest_rotations();
        if moved.len() != rotations.len() {
            return Err(SkinError::Pose {
                joint: moved.len().min(rotations.len()),
                name: "-".into(),
                why: format!(
                    "{} rotations for {} moved joints",
                    rotations.len(),
                    moved.len()
                ),
            });
        }
        for (&j, q) in moved.iter().zip(rotations) {
            let slot = locals.get_mut(j).ok_or_else(|| SkinError::Pose {
                joint: j,
                name: "-".into(),
                why: format!("no such joint (the skeleton has {})", skel.len()),
            })?;
            *slot = *q;
        }
        Ok(locals)
    }
}
