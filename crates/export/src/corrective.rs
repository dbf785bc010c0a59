//! `--skinning clusters`: the control-cluster correction (crate `slothsim-skin`) carried
//! to standard viewers as corrective morph targets on the sloth mesh, their weights
//! animated per sloth (glTF applies morph targets in bind space, then skins). See
//! `slothsim_skin::CorrectiveTargets` for how the targets are built and why morph, then
//! skin, reproduces the in-house cluster result.

use glam::Quat;
use rayon::prelude::*;
use slothsim_skin::{
    ClusterSkin, CorrectiveTargets, MorphScratch, MorphTarget, ReferenceShapes, SkinError, SkinMesh,
};

use crate::{ExportError, Recording};

/// How the exported sloth mesh is skinned.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Skinning {
    /// Linear blend skinning only (the glTF default; elbows and knees thin when flexed).
    Lbs,
    /// LBS plus the control-cluster correction as animated corrective morph targets.
    #[default]
    Clusters,
}

impl Skinning {
    /// `lbs` / `clusters`.
    pub fn name(self) -> &'static str {
        match self {
            Skinning::Lbs => "lbs",
            Skinning::Clusters => "clusters",
        }
    }
}

/// The sloth's corrective targets and what computes their weights from a pose.
#[derive(Clone, Debug)]
pub struct Correctives {
    mesh: SkinMesh,
    clusters: ClusterSkin,
    targets: CorrectiveTargets,
    list: Vec<MorphTarget>,
}

/// One track's morph weights: `samples × targets`, sample-major (glTF layout), and the
/// largest bind-space fit residual (m).
pub(crate) struct TrackWeights {
    pub weights: Vec<f32>,
    pub residual_m: f32,
}

impl Correctives {
    /// The default sloth (`assets/sloth.glb`) with its stored reference shapes.
    ///
    /// # Errors
    /// A [`SkinError`] naming the joint, vertex or field when the asset or its reference
    /// shapes are unusable.
    pub fn sloth() -> Result<Self, SkinError> {
        let mesh = SkinMesh::sloth()?;
        let clusters = ClusterSkin::new(&mesh, &ReferenceShapes::sloth()?)?;
        Self::new(mesh, clusters)
    }

    /// Targets for `mesh` skinned by `clusters`.
    ///
    /// # Errors
    /// As [`CorrectiveTargets::new`].
    pub fn new(mesh: SkinMesh, clusters: ClusterSkin) -> Result<Self, SkinError> {
        let targets = CorrectiveTargets::new(&mesh, &clusters)?;
        let list = targets.targets();
        Ok(Self {
            mesh,
            clusters,
            targets,
            list,
        })
    }

    /// The morph targets, in weight order.
    pub fn targets(&self) -> &[MorphTarget] {
        &self.list
    }

    /// The skinned mesh they were built for.
    pub fn mesh(&self) -> &SkinMesh {
        &self.mesh
    }

    /// The cluster skin they reproduce.
    pub fn clusters(&self) -> &ClusterSkin {
        &self.clusters
    }

    /// Weights of track `track` at samples `samples`.
    fn track_weights(
        &self,
        rec: &Recording,
        track: usize,
        samples: std::ops::Range<usize>,
    ) -> Result<TrackWeights, ExportError> {
        let t = &rec.tracks[track];
        let n = self.list.len();
        let mut out = TrackWeights {
            weights: Vec::with_capacity(samples.len() * n),
            residual_m: 0.0,
        };
        let mut scratch = MorphScratch::default();
        let mut w = Vec::with_capacity(n);
        let mut rotations = vec![Quat::IDENTITY; rec.moved.len()];
        for s in samples {
            for (r, series) in rotations.iter_mut().zip(&t.joints) {
                *r = Quat::from_array(series[s]);
            }
            let err = |e: SkinError| ExportError::Pose {
                sloth: t.id,
                time_s: rec.times[s],
                why: e.to_string(),
            };
            let locals = self.mesh.locals_with(&rec.moved, &rotations).map_err(err)?;
            let posed = self.mesh.pose(&locals).map_err(err)?;
            let r = self
                .targets
                .weights(&self.mesh, &self.clusters, &posed, &mut scratch, &mut w)
                .map_err(err)?;
            out.residual_m = out.residual_m.max(r);
            out.weights.extend_from_slice(&w);
        }
        Ok(out)
    }

    /// Weights of the first sample of every track (the nodes' still pose).
    pub(crate) fn first_weights(&self, rec: &Recording) -> Result<Vec<TrackWeights>, ExportError> {
        (0..rec.tracks.len())
            .into_par_iter()
            .map(|k| self.track_weights(rec, k, 0..rec.times.len().min(1)))
            .collect()
    }

    /// Weights of every sample of tracks `tracks` (in parallel; each track's values do
    /// not depend on the thread count).
    pub(crate) fn weights_of(
        &self,
        rec: &Recording,
        tracks: std::ops::Range<usize>,
    ) -> Result<Vec<TrackWeights>, ExportError> {
        tracks
            .into_par_iter()
            .map(|k| self.track_weights(rec, k, 0..rec.times.len()))
            .collect()
    }
}
