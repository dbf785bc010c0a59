//! A flat, depth-first skeleton: joints are array entries, parents are indices and
//! every parent index is smaller than its child's index, so forward kinematics is one
//! forward pass.

use glam::{Affine3A, Quat, Vec3};

use crate::error::RigError;
use crate::limits::JointLimit;

/// Rest (bind) transform of a joint relative to its parent. Metres; scale is not used.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RestTransform {
    /// Translation in the parent's frame (metres).
    pub translation: Vec3,
    /// Rotation relative to the parent.
    pub rotation: Quat,
}

impl RestTransform {
    /// Translation-only rest transform.
    pub const fn from_translation(translation: Vec3) -> Self {
        Self {
            translation,
            rotation: Quat::IDENTITY,
        }
    }
}

/// Joint hierarchy in depth-first order with rest transforms and optional limits.
#[derive(Clone, Debug, PartialEq)]
pub struct Skeleton {
    names: Vec<String>,
    parents: Vec<Option<u16>>,
    rest: Vec<RestTransform>,
    limits: Vec<Option<JointLimit>>,
}

impl Skeleton {
    /// Build from parallel arrays. Errors (naming the joint) if a parent index is not
    /// smaller than its child's index, a name is duplicated, or a limit is malformed.
    pub fn from_parts(
        names: Vec<String>,
        parents: Vec<Option<u16>>,
        rest: Vec<RestTransform>,
        limits: Vec<Option<JointLimit>>,
    ) -> Result<Self, RigError> {
        let n = names.len();
        if parents.len() != n || rest.len() != n || limits.len() != n {
            return Err(RigError::LengthMismatch);
        }
        if n > usize::from(u16::MAX) {
            return Err(RigError::TooManyJoints(n));
        }
        for (i, name) in names.iter().enumerate() {
            if let Some(p) = parents[i]
                && usize::from(p) >= i
            {
                return Err(RigError::ParentAfterChild {
                    joint: name.clone(),
                    parent: names.get(usize::from(p)).cloned().unwrap_or_default(),
                });
            }
            if names[..i].contains(name) {
                return Err(RigError::DuplicateName {
                    joint: name.clone(),
                });
            }
            if !rest[i].translation.is_finite() || !rest[i].rotation.is_finite() {
                return Err(RigError::NonFiniteTransform {
                    joint: name.clone(),
                });
            }
            if let Some(limit) = &limits[i] {
                limit.validate().map_err(|problem| RigError::InvalidLimit {
                    joint: name.clone(),
                    problem,
                })?;
            }
        }
        Ok(Self {
            names,
            parents,
            rest,
            limits,
        })
    }

    /// Number of joints.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// No joints?
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// Joint names, depth-first.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Parent indices (`None` for roots); `parents()[i] < i`.
    pub fn parents(&self) -> &[Option<u16>] {
        &self.parents
    }

    /// Parent of joint `i`.
    pub fn parent(&self, i: usize) -> Option<usize> {
        self.parents[i].map(usize::from)
    }

    /// Rest transforms relative to the parent.
    pub fn rest(&self) -> &[RestTransform] {
        &self.rest
    }

    /// Joint limits (rest-relative), if any.
    pub fn limits(&self) -> &[Option<JointLimit>] {
        &self.limits
    }

    /// Index of the joint called `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// Rest local rotations (a ready-made `locals` buffer for [`Skeleton::fk`]).
    pub fn rest_rotations(&self) -> Vec<Quat> {
        self.rest.iter().map(|r| r.rotation).collect()
    }

    /// Forward kinematics: model-space transform of every joint from local rotations
    /// (`locals[i]` replaces joint i's rest rotation; translations are the rest ones).
    /// The caller owns both buffers; `locals` and `out_ms` must have `len()` entries.
    ///
    /// # Panics
    /// If a buffer has the wrong length.
    pub fn fk(&self, locals: &[Quat], out_ms: &mut [Affine3A]) {
        assert_eq!(locals.len(), self.len(), "locals length");
        assert_eq!(out_ms.len(), self.len(), "output length");
        for i in 0..self.len() {
            let local = Affine3A::from_rotation_translation(locals[i], self.rest[i].translation);
            out_ms[i] = match self.parents[i] {
                Some(p) => out_ms[usize::from(p)] * local,
                None => local,
            };
        }
    }
}
