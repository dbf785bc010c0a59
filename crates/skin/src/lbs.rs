//! Pose → skinning transforms, linear blend skinning (seed formula 1) and
//! dual-quaternion skinning (the usual fix for LBS's collapsing joints).

use glam::{Affine3A, Quat, Vec3};

use crate::{SkinError, SkinMesh};

/// Model-space joint transforms W_i and skinning transforms W_i B_i⁻¹ of one pose.
#[derive(Clone, Debug)]
pub struct Posed {
    /// Local joint rotations the pose was built from.
    pub locals: Vec<Quat>,
    /// Model-space joint transforms W_i.
    pub world: Vec<Affine3A>,
    /// Skinning transforms W_i B_i⁻¹.
    pub skin: Vec<Affine3A>,
}

impl SkinMesh {
    /// Forward kinematics of `locals` (one local rotation per joint). A wrong length or a
    /// non-finite / non-unit rotation is an error naming the joint.
    pub fn pose(&self, locals: &[Quat]) -> Result<Posed, SkinError> {
        let skel = self.rig.skeleton();
        if locals.len() != skel.len() {
            return Err(SkinError::Pose {
                joint: locals.len().min(skel.len()),
                name: "-".into(),
                why: format!("{} rotations for {} joints", locals.len(), skel.len()),
            });
        }
        for (i, q) in locals.iter().enumerate() {
            if !q.is_finite() || (q.length() - 1.0).abs() > 1e-3 {
                return Err(SkinError::Pose {
                    joint: i,
                    name: skel.names()[i].clone(),
                    why: format!("rotation {q} is not a finite unit quaternion"),
                });
            }
        }
        let mut world = vec![Affine3A::IDENTITY; skel.len()];
        skel.fk(locals, &mut world);
        let skin = world
            .iter()
            .zip(&self.inv_bind)
            .map(|(w, ib)| *w * *ib)
            .collect();
        Ok(Posed {
            locals: locals.to_vec(),
            world,
            skin,
        })
    }

    /// Linear blend skinning, seed formula (1): v' = Σ_i w_i W_i B_i⁻¹ v.
    pub fn lbs(&self, posed: &Posed, out: &mut Vec<Vec3>) {
        out.clear();
        out.extend(
            self.positions
                .iter()
                .zip(&self.joints)
                .zip(&self.weights)
                .map(|((&v, j), w)| lbs_vertex(&posed.skin, v, j, w)),
        );
    }

    /// Dual-quaternion skinning (Kavan et al. 2007): blend the unit dual quaternions of
    /// W_i B_i⁻¹ (signs aligned to the first), normalise, apply as a rigid transform.
    pub fn dqs(&self, posed: &Posed, out: &mut Vec<Vec3>) {
        let dq: Vec<DualQuat> = posed.skin.iter().map(DualQuat::from_affine).collect();
        out.clear();
        out.extend(
            self.positions
                .iter()
                .zip(&self.joints)
                .zip(&self.weights)
                .map(|((&v, j), w)| {
                    let first = dq[usize::from(j[0])].real;
                    let mut acc = DualQuat::ZERO;
                    for k in 0..4 {
                        if w[k] > 0.0 {
                            let d = dq[usize::from(j[k])];
                            let s = if d.real.dot(first) < 0.0 { -w[k] } else { w[k] };
                            acc.real += d.real * s;
                            acc.dual += d.dual * s;
                        }
                    }
                    acc.transform(v)
                }),
        );
    }
}

/// One vertex of formula (1).
#[inline]
pub(crate) fn lbs_vertex(skin: &[Affine3A], v: Vec3, j: &[u16; 4], w: &[f32; 4]) -> Vec3 {
    let mut acc = Vec3::ZERO;
    for k in 0..4 {
        if w[k] > 0.0 {
            acc += skin[usize::from(j[k])].transform_point3(v) * w[k];
        }
    }
    acc
}

/// A dual quaternion real + ε dual (rigid transforms; rotation part unit).
#[derive(Clone, Copy, Debug)]
struct DualQuat {
    real: Quat,
    dual: Quat,
}

impl DualQuat {
    const ZERO: DualQuat = DualQuat {
        real: Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
        dual: Quat::from_xyzw(0.0, 0.0, 0.0, 0.0),
    };

    fn from_affine(a: &Affine3A) -> DualQuat {
        let (_, r, t) = a.to_scale_rotation_translation();
        let tq = Quat::from_xyzw(t.x, t.y, t.z, 0.0);
        DualQuat {
            real: r,
            dual: (tq * r) * 0.5,
        }
    }

    /// Normalise and apply to a point.
    fn transform(self, v: Vec3) -> Vec3 {
        let n = self.real.length();
        let (r, d) = (self.real / n, self.dual / n);
        // Translation t = 2 d r*; rotation r.
        let t = (d * r.conjugate()) * 2.0;
        r * v + Vec3::new(t.x, t.y, t.z)
    }
}
