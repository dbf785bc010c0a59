//! The control-cluster method (seed §3): LBS, then cluster vertices corrected by
//! RBF-blended offsets in their bones' frames (formulas 2–3), then free vertices moved
//! by cardinal-spline interpolation of the corrections along the limb (§3.3, formula 4).

use glam::{Quat, Vec3};
use slothsim_rig::Limb;

use crate::SkinError;
use crate::lbs::Posed;
use crate::mesh::{LIMB_RINGS, LIMB_SIDES, SkinMesh};
use crate::sculpt::{LimbJoint, ReferenceShapes};

/// Default spline tension q (seed §3.3.2).
pub const DEFAULT_TENSION: f32 = -0.5;

/// One joint's clusters, ready to evaluate.
#[derive(Clone, Debug)]
struct JointClusters {
    joint: usize,
    rest: Quat,
    configs: Vec<Vec3>,
    /// Gaussian width σ (rad): the mean spacing of the configurations.
    sigma: f32,
    vertices: Vec<usize>,
    /// `omega[i][k]`: RBF weights ω_i of vertex k, one offset per influence slot.
    omega: Vec<Vec<[Vec3; 4]>>,
}

/// Cluster skinning of a [`SkinMesh`].
#[derive(Clone, Debug)]
pub struct ClusterSkin {
    joints: Vec<JointClusters>,
    /// Per vertex: cluster member or weighted to a single bone (a control vertex).
    control: Vec<bool>,
    /// Spline tension q.
    pub tension: f32,
}

/// Gaussian radial basis function φ(r) = exp(−(r/σ)²).
fn phi(r: f32, sigma: f32) -> f32 {
    (-(r / sigma).powi(2)).exp()
}

/// Rotation vector of `q` (axis × angle, angle in [0, π]).
pub(crate) fn rotation_vector(q: Quat) -> Vec3 {
    let q = if q.w < 0.0 { -q } else { q };
    let (axis, angle) = q.to_axis_angle();
    axis * angle
}

/// Invert a small dense matrix (Gauss–Jordan with partial pivoting); `None` if singular.
fn invert(mut a: Vec<Vec<f64>>) -> Option<Vec<Vec<f64>>> {
    let n = a.len();
    let mut inv: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    for c in 0..n {
        let p = (c..n).max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))?;
        if a[p][c].abs() < 1e-12 {
            return None;
        }
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for j in 0..n {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for r in 0..n {
            if r != c {
                let f = a[r][c];
                for j in 0..n {
                    a[r][j] -= f * a[c][j];
                    inv[r][j] -= f * inv[c][j];
                }
            }
        }
    }
    Some(inv)
}

impl ClusterSkin {
    /// Build from reference shapes. Every corrected joint ([`LimbJoint::all`]) needs
    /// references (≥ 2 finite configurations); every cluster vertex must exist and be
    /// weighted to the joint or its parent. Errors name the joint and vertex.
    pub fn new(mesh: &SkinMesh, refs: &ReferenceShapes) -> Result<ClusterSkin, SkinError> {
        let skel = mesh.rig.skeleton();
        let rest = skel.rest_rotations();
        let mut joints = Vec::new();
        let mut control: Vec<bool> = mesh.weights.iter().map(|w| w[0] >= 1.0 - 1e-6).collect();
        for lj in LimbJoint::all() {
            let j = lj.joint(mesh);
            let name = skel.names()[j].clone();
            let rerr = |why: String| SkinError::References {
                joint: name.clone(),
                why,
            };
            let r = refs
                .joints
                .iter()
                .find(|r| r.joint == name)
                .ok_or_else(|| rerr("missing reference shapes".into()))?;
            if r.configs.len() < 2 || r.shapes.len() != r.configs.len() {
                return Err(rerr(format!(
                    "{} configurations and {} shapes (need ≥ 2, equal)",
                    r.configs.len(),
                    r.shapes.len()
                )));
            }
            let parent = mesh.rig.limb_joints(lj.limb).joints[lj.element - 1];
            let vertices: Vec<usize> = r.pairs.iter().flatten().copied().collect();
            if vertices.is_empty() {
                return Err(rerr("no control clusters (empty `pairs`)".into()));
            }
            for (k, &v) in vertices.iter().enumerate() {
                if vertices[..k].contains(&v) {
                    return Err(SkinError::Cluster {
                        joint: name.clone(),
                        vertex: v,
                        why: "named by two clusters (it would be corrected twice)".into(),
                    });
                }
            }
            for &v in &vertices {
                let cerr = |why: &str| SkinError::Cluster {
                    joint: name.clone(),
                    vertex: v,
                    why: why.into(),
                };
                if v >= mesh.positions.len() {
                    return Err(cerr("no such vertex"));
                }
                let on_joint = (0..4).any(|k| {
                    mesh.weights[v][k] > 0.0
                        && [j, parent].contains(&usize::from(mesh.joints[v][k]))
                });
                if !on_joint {
                    return Err(cerr("not weighted to the joint's bones"));
                }
            }
            for (i, s) in r.shapes.iter().enumerate() {
                if s.len() != vertices.len() {
                    return Err(rerr(format!(
                        "shape {i} has {} positions for {} cluster vertices",
                        s.len(),
                        vertices.len()
                    )));
                }
                if !r.configs[i].is_finite() || s.iter().any(|p| !p.is_finite()) {
                    return Err(rerr(format!("shape {i} is not finite")));
                }
            }
            // Offsets d_j in each bone's frame at every X_i (seed §3.2): the reference
            // position minus LBS, seen from bone j: Σ_j w_j R_j d_j = v_ref − LBS(v0).
            let mut offsets = Vec::new();
            for (x, shape) in r.configs.iter().zip(&r.shapes) {
                let mut locals = rest.clone();
                let angle = x.length();
                let q = if angle > 0.0 {
                    Quat::from_axis_angle(*x / angle, angle)
                } else {
                    Quat::IDENTITY
                };
                locals[j] = rest[j] * q;
                let posed = mesh.pose(&locals)?;
                let d: Vec<[Vec3; 4]> = vertices
                    .iter()
                    .zip(shape)
                    .map(|(&v, &target)| {
                        let lbs = crate::lbs::lbs_vertex(
                            &posed.skin,
                            mesh.positions[v],
                            &mesh.joints[v],
                            &mesh.weights[v],
                        );
                        let delta = target - lbs;
                        std::array::from_fn(|k| {
                            let (_, rot, _) = posed.skin[usize::from(mesh.joints[v][k])]
                                .to_scale_rotation_translation();
                            rot.inverse() * delta
                        })
                    })
                    .collect();
                offsets.push(d);
            }
            // Formula (3): d(X) = Σ_i ω_i φ(‖X_i − X‖), ω solving Φ ω = D (exact at X_i).
            let n = r.configs.len();
            let mut spacing = 0.0;
            for i in 1..n {
                spacing += r.configs[i].distance(r.configs[i - 1]);
            }
            let sigma = (spacing / (n - 1) as f32).max(1e-3);
            let phi_m: Vec<Vec<f64>> = (0..n)
                .map(|a| {
                    (0..n)
                        .map(|b| f64::from(phi(r.configs[a].distance(r.configs[b]), sigma)))
                        .collect()
                })
                .collect();
            let inv = invert(phi_m).ok_or_else(|| rerr("configurations coincide".into()))?;
            let omega: Vec<Vec<[Vec3; 4]>> = (0..n)
                .map(|i| {
                    (0..vertices.len())
                        .map(|k| {
                            std::array::from_fn(|s| {
                                let mut acc = glam::DVec3::ZERO;
                                for (m, d) in offsets.iter().enumerate() {
                                    acc += d[k][s].as_dvec3() * inv[i][m];
                                }
                                acc.as_vec3()
                            })
                        })
                        .collect()
                })
                .collect();
            for &v in &vertices {
                control[v] = true;
            }
            joints.push(JointClusters {
                joint: j,
                rest: rest[j],
                configs: r.configs.clone(),
                sigma,
                vertices,
                omega,
            });
        }
        Ok(ClusterSkin {
            joints,
            control,
            tension: DEFAULT_TENSION,
        })
    }

    /// Skin `posed` with control clusters into `out` (LBS first, into `lbs`).
    pub fn skin(&self, mesh: &SkinMesh, posed: &Posed, lbs: &mut Vec<Vec3>, out: &mut Vec<Vec3>) {
        mesh.lbs(posed, lbs);
        out.clear();
        out.extend_from_slice(lbs);
        // Cluster vertices, formulas (2) and (3). R_j: rotation of W_j B_j⁻¹.
        let rots: Vec<Quat> = posed
            .skin
            .iter()
            .map(|m| m.to_scale_rotation_translation().1)
            .collect();
        for jc in &self.joints {
            let x = rotation_vector(jc.rest.inverse() * posed.locals[jc.joint]);
            let phis: Vec<f32> = jc
                .configs
                .iter()
                .map(|c| phi(c.distance(x), jc.sigma))
                .collect();
            for (k, &v) in jc.vertices.iter().enumerate() {
                let mut corr = Vec3::ZERO;
                for s in 0..4 {
                    let w = mesh.weights[v][s];
                    if w > 0.0 {
                        let mut d = Vec3::ZERO;
                        for (i, p) in phis.iter().enumerate() {
                            d += jc.omega[i][k][s] * *p;
                        }
                        corr += rots[usize::from(mesh.joints[v][s])] * d * w;
                    }
                }
                out[v] += corr;
            }
        }
        // Free vertices, §3.3: cardinal spline along each line of the limb tube.
        for limb in Limb::ALL {
            for side in 0..LIMB_SIDES {
                spline_line(&self.control, self.tension, limb, side, lbs, out);
            }
        }
    }
}

/// The spline pass over one longitudinal line of a limb tube (§3.3): interpolate the
/// corrections of its free vertices between neighbouring control vertices p_{i−1},
/// p_{i+1} (with p_{i−2}, p_{i+2}, reflected where the line ends), chord-length parameter
/// t_{i+1} = t_i + |p_{i+1} − p_i|, tangents m_k = (1 − q)(p_{k+1} − p_{k−1}) /
/// (t_{k+1} − t_{k−1}) (formula 4), cubic Hermite in between. `control` marks control
/// vertices.
pub(crate) fn spline_line(
    control: &[bool],
    tension: f32,
    limb: Limb,
    side: usize,
    lbs: &[Vec3],
    out: &mut [Vec3],
) {
    {
        let vid = |r: usize| SkinMesh::tube_vertex(limb, r, side);
        let ctrl: Vec<usize> = (0..LIMB_RINGS).filter(|&r| control[vid(r)]).collect();
        let line: Vec<Vec3> = (0..LIMB_RINGS).map(|r| out[vid(r)]).collect();
        let corr = |r: usize| line[r] - lbs[vid(r)];
        for w in 0..ctrl.len().saturating_sub(1) {
            let (a, b) = (ctrl[w], ctrl[w + 1]);
            if b == a + 1 {
                continue;
            }
            let (pa, pb) = (line[a], line[b]);
            let (ca, cb) = (corr(a), corr(b));
            let tb = pa.distance(pb).max(1e-9);
            // Neighbours beyond: the next control vertex, or reflection p_{i+2} = p_{i+1} + (p_{i+1} − p_{i−1}).
            let (c_prev, t_prev) = match w.checked_sub(1).map(|i| ctrl[i]) {
                Some(p) => (corr(p), -line[p].distance(pa)),
                None => (ca + (ca - cb), -tb),
            };
            let (c_next, t_next) = match ctrl.get(w + 2) {
                Some(&n) => (corr(n), tb + line[n].distance(pb)),
                None => (cb + (cb - ca), 2.0 * tb),
            };
            let k = 1.0 - tension;
            let ma = (cb - c_prev) * (k / (tb - t_prev).max(1e-9));
            let mb = (c_next - ca) * (k / t_next.max(1e-9));
            // Free vertex parameter: its share of the bind arclength from a to b.
            let mut arc = Vec::with_capacity(b - a + 1);
            let mut s = 0.0f32;
            arc.push(0.0);
            for r in a + 1..=b {
                s += lbs[vid(r)].distance(lbs[vid(r - 1)]);
                arc.push(s);
            }
            for r in a + 1..b {
                let u = if s > 0.0 { arc[r - a] / s } else { 0.5 };
                let (u2, u3) = (u * u, u * u * u);
                let h00 = 2.0 * u3 - 3.0 * u2 + 1.0;
                let h10 = u3 - 2.0 * u2 + u;
                let h01 = -2.0 * u3 + 3.0 * u2;
                let h11 = u3 - u2;
                let c = ca * h00 + ma * (h10 * tb) + cb * h01 + mb * (h11 * tb);
                out[vid(r)] = lbs[vid(r)] + c;
            }
        }
    }
}
