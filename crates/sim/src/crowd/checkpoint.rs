//! Checkpoints: a run's state (sloths, their queued traces, config, seed,
//! forest source) written to a versioned, checksummed file, and a run
//! resumed from one bit for bit.

use std::path::Path;

use serde::{Deserialize, Serialize};
use slothsim_gait::{LocomotionConfig, NearRing, Sloth, TraceBatch};
use slothsim_rig::Rig;
use slothsim_scene::{Scene, TraceScene};

use super::hash::Fnv;
use super::stats::crowd_judge;
use super::{Crowd, CrowdError, CrowdSpec, ForestSource, scene_hash};
use crate::world::{CrowdNeighbours, Locomotion, NearStances, SlothId, SlothState, Traces};

const MAGIC: &[u8; 16] = b"SLOTHSIM-STATE\0\0";
/// Checkpoint format version; bump on any change of the saved data.
pub const CHECKPOINT_VERSION: u32 = 31;

#[derive(Serialize, Deserialize)]
struct Checkpoint {
    pkg_version: String,
    seed: u64,
    dt: f32,
    clearance_m: f32,
    frame: u64,
    cfg: LocomotionConfig,
    forest: ForestSource,
    sloths: Vec<SavedSloth>,
    traces: Vec<TraceBatch>,
}

/// A sloth as a checkpoint holds it: its state, then its goal-mode stance
/// record ([`NearStances`]; an empty one for a sloth without). Postcard
/// writes a struct as its fields one after another, so these are the bytes
/// of format 27's `Sloth`, whose last field the record was: the format did
/// not change when the record moved out of `Sloth`.
#[derive(Serialize, Deserialize)]
struct SavedSloth {
    sloth: Sloth,
    near: NearRing,
}

/// What a checkpoint holds besides the sloths: enough to rebuild the run.
#[derive(Clone, Debug)]
pub struct CheckpointInfo {
    /// The forest.
    pub forest: ForestSource,
    /// Sloths.
    pub sloths: u32,
    /// Seed.
    pub seed: u64,
    /// Frames simulated before the checkpoint.
    pub frame: u64,
}

impl Crowd {
    /// Writes the state (sloths, their queued traces, config, forest source)
    /// to `path` through a temporary file renamed at the end.
    pub fn save_state(&mut self, path: &Path) -> Result<(), CrowdError> {
        let err = |message: String| CrowdError::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        let Some(forest) = self.forest.clone() else {
            return Err(err(
                "a lone sloth on a scenario preset has no forest to save".into(),
            ));
        };
        let mut q = self
            .world
            .query::<(&SlothId, &SlothState, &Traces, Option<&NearStances>)>();
        let mut rows: Vec<(u32, SavedSloth, TraceBatch)> = q
            .iter(&self.world)
            .map(|(i, s, t, n)| {
                let saved = SavedSloth {
                    sloth: s.0,
                    near: n.map_or_else(NearRing::default, |n| n.0),
                };
                (i.0, saved, t.0.clone())
            })
            .collect();
        rows.sort_unstable_by_key(|r| r.0);
        let (sloths, traces) = rows.into_iter().map(|r| (r.1, r.2)).unzip();
        let cp = Checkpoint {
            pkg_version: env!("CARGO_PKG_VERSION").to_string(),
            seed: self.spec.seed,
            dt: self.spec.dt,
            clearance_m: self.spec.clearance_m,
            frame: self.frame(),
            cfg: self.spec.cfg.clone(),
            forest,
            sloths,
            traces,
        };
        let payload = postcard::to_stdvec(&cp).map_err(|e| err(format!("encode: {e}")))?;
        let mut h = Fnv::new();
        h.bytes(&payload);
        let mut bytes = Vec::with_capacity(payload.len() + 28);
        bytes.extend_from_slice(MAGIC);
        bytes.extend_from_slice(&CHECKPOINT_VERSION.to_le_bytes());
        bytes.extend_from_slice(&h.0.to_le_bytes());
        bytes.extend_from_slice(&payload);
        crate::write_atomically(path, &bytes).map_err(|e| err(e.to_string()))
    }

    fn decode(path: &Path) -> Result<Checkpoint, CrowdError> {
        let err = |message: String| CrowdError::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        let bytes = std::fs::read(path).map_err(|e| err(format!("cannot read: {e}")))?;
        if bytes.len() < 28 || &bytes[..16] != MAGIC {
            return Err(err("not a slothsim state file (bad magic)".into()));
        }
        let version = u32::from_le_bytes(bytes[16..20].try_into().expect("4 bytes"));
        if version != CHECKPOINT_VERSION {
            return Err(err(format!(
                "format version {version}, this slothsim reads version {CHECKPOINT_VERSION}"
            )));
        }
        let sum = u64::from_le_bytes(bytes[20..28].try_into().expect("8 bytes"));
        let mut h = Fnv::new();
        h.bytes(&bytes[28..]);
        if h.0 != sum {
            return Err(err("corrupt: checksum mismatch".into()));
        }
        let cp: Checkpoint =
            postcard::from_bytes(&bytes[28..]).map_err(|e| err(format!("corrupt: {e}")))?;
        if cp.pkg_version != env!("CARGO_PKG_VERSION") {
            return Err(err(format!(
                "written by slothsim {}, this is {}",
                cp.pkg_version,
                env!("CARGO_PKG_VERSION")
            )));
        }
        if cp.sloths.len() != cp.traces.len() || cp.sloths.is_empty() {
            return Err(err("corrupt: sloth count".into()));
        }
        if cp.sloths.iter().map(|s| &s.sloth).any(|s| {
            !(s.body_pos.is_finite()
                && s.body_rot.is_finite()
                && s.limbs.iter().all(|l| l.pose.is_finite()))
        }) {
            return Err(err("corrupt: non-finite sloth state".into()));
        }
        Ok(cp)
    }

    /// Reads what a checkpoint needs to rebuild its run (to load its forest).
    pub fn checkpoint_info(path: &Path) -> Result<CheckpointInfo, CrowdError> {
        let cp = Self::decode(path)?;
        Ok(CheckpointInfo {
            forest: cp.forest,
            sloths: cp.sloths.len() as u32,
            seed: cp.seed,
            frame: cp.frame,
        })
    }

    /// Continues a run from a checkpoint on `scene` (which must be the
    /// checkpoint's forest: its hash is checked).
    pub fn load_state(path: &Path, rig: &Rig, scene: Scene) -> Result<Crowd, CrowdError> {
        let cp = Self::decode(path)?;
        let err = |message: String| CrowdError::Checkpoint {
            path: path.to_path_buf(),
            message,
        };
        if let ForestSource::File { scene_hash: h, .. } = &cp.forest
            && *h != scene_hash(&scene)
        {
            return Err(err(
                "the forest file differs from the one the state was saved on".into(),
            ));
        }
        let n = scene.supports().len() as u32;
        if cp.sloths.iter().map(|s| &s.sloth).any(|s| {
            s.limbs
                .iter()
                .any(|l| l.grip.support.0 >= n || l.search.support.0 >= n)
        }) {
            return Err(err("refers to supports the forest does not have".into()));
        }
        let spec = CrowdSpec {
            sloths: cp.sloths.len() as u32,
            seed: cp.seed,
            dt: cp.dt,
            cfg: cp.cfg,
            clearance_m: cp.clearance_m,
        };
        spec.validate()?;
        let loco = Locomotion::new(spec.cfg.clone(), rig, TraceScene::new(scene))?;
        let neighbours = CrowdNeighbours::new(spec.clearance_m);
        // The stance records of the sloths that keep one (none in a crowd of
        // wanderers), in id order (the checkpoint's), put back once the
        // sloths are assembled.
        let records: Vec<(u32, NearRing)> = cp
            .sloths
            .iter()
            .filter(|s| s.sloth.keeps_near_record())
            .map(|s| (s.sloth.id, s.near))
            .collect();
        let sloths = cp
            .sloths
            .into_iter()
            .map(|s| s.sloth)
            .zip(cp.traces)
            .collect();
        let mut crowd = Self::assemble(
            spec,
            loco,
            Some(cp.forest),
            Some(neighbours),
            sloths,
            cp.frame,
            crowd_judge(),
        );
        if !records.is_empty() {
            let mut q = crowd.world.query::<(&SlothId, &mut NearStances)>();
            for (i, mut n) in q.iter_mut(&mut crowd.world) {
                if let Ok(k) = records.binary_search_by_key(&i.0, |r| r.0) {
                    n.0 = records[k].1;
                }
            }
        }
        Ok(crowd)
    }
}
