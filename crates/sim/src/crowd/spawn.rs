//! Where a crowd starts: spawn slots along the thin branches of a forest
//! (shuffled by the seed), the check a freshly spawned sloth must pass, and
//! the size of the procedural forest a crowd needs.

use glam::Vec3;
use rand::SeedableRng;
use rand::seq::SliceRandom;
use rand_pcg::Pcg64Mcg;
use rayon::prelude::*;
use slothsim_gait::{Sloth, SlothObservation, SpawnHint, TraceBatch};
use slothsim_observe::Judge;
use slothsim_rig::Rig;
use slothsim_scene::{ForestConfig, Scene, SupportKind, TraceScene};

use super::stats::crowd_judge;
use super::{Crowd, CrowdError, CrowdSpec, ForestSource};
use crate::world::{CrowdNeighbours, Locomotion};

/// Spacing of spawn slots along a branch (body ~0.8 m plus clearance).
pub(super) const SLOT_SPACING_M: f32 = 1.3;
/// Spawn slots keep this far from a branch's ends.
const SLOT_END_MARGIN_M: f32 = 0.6;
/// Branches thicker than this are not spawned on (limbs grip thin supports).
const SLOT_MAX_RADIUS_M: f32 = 0.12;

/// Sloths per tree the auto-sized forest plans for: a tree offers ~40 branch
/// slots of which about half pass the spawn check; 12 leaves room to wander.
pub const SLOTHS_PER_TREE: u32 = 12;

/// A procedural forest config sized for `sloths`: the embedded default (64
/// trees) up to 64 × [`SLOTHS_PER_TREE`] sloths, else more trees on a
/// proportionally larger area (same tree density). `trees` overrides.
pub fn forest_for(sloths: u32, trees: Option<u32>, seed: Option<u64>) -> ForestConfig {
    let mut cfg = ForestConfig::default();
    let trees = trees.unwrap_or_else(|| cfg.trees.max(sloths.div_ceil(SLOTHS_PER_TREE)));
    cfg.area_m *= (trees as f32 / cfg.trees as f32).sqrt();
    cfg.trees = trees;
    if let Some(seed) = seed {
        cfg.seed = seed;
    }
    cfg
}

/// Spawn slots: (support, axis point, axis tangent), in scene order.
fn spawn_slots(scene: &Scene) -> Vec<SpawnHint> {
    let mut slots = Vec::new();
    for s in scene.supports() {
        if s.kind != SupportKind::Branch {
            continue;
        }
        let len = s.length();
        let mut u = SLOT_END_MARGIN_M;
        while u <= len - SLOT_END_MARGIN_M {
            let a = slothsim_gait::axis_at(s, u);
            if a.radius <= SLOT_MAX_RADIUS_M && a.tangent.y.abs() < 0.7 {
                slots.push(SpawnHint {
                    support: s.id,
                    position: a.point,
                    forward: a.tangent,
                    body_side: Vec3::NEG_Y,
                });
            }
            u += SLOT_SPACING_M;
        }
    }
    slots
}

/// Whether a freshly spawned sloth holds all four grips properly.
fn spawn_ok(obs: &SlothObservation) -> bool {
    !obs.has_nan
        && obs.penetration_m <= 0.005
        && obs.limbs.iter().all(|l| {
            l.surface_gap <= 0.005
                && l.effector_ws.distance(l.grip_ws) <= 0.003
                && l.limit_violation <= 1e-4
                && l.root_ws.distance(l.effector_ws) <= l.limb_length
        })
}

impl Crowd {
    /// Spawns `spec.sloths` wandering sloths on `scene`, spread over its
    /// branches (slots shuffled by the seed), each with its own seed and heading.
    pub fn new(
        spec: CrowdSpec,
        rig: &Rig,
        scene: Scene,
        forest: ForestSource,
    ) -> Result<Crowd, CrowdError> {
        spec.validate()?;
        let mut slots = spawn_slots(&scene);
        let capacity = slots.len() as u32;
        if spec.sloths > capacity {
            return Err(CrowdError::TooMany {
                requested: spec.sloths,
                capacity,
            });
        }
        let mut rng = Pcg64Mcg::seed_from_u64(spec.seed);
        slots.shuffle(&mut rng);
        let headings: Vec<bool> = (0..slots.len())
            .map(|_| rand::Rng::random_bool(&mut rng, 0.5))
            .collect();
        let loco = Locomotion::new(spec.cfg.clone(), rig, TraceScene::new(scene))?;
        let mut neighbours = CrowdNeighbours::new(spec.clearance_m);
        let mut accepted: Vec<Sloth> = Vec::with_capacity(spec.sloths as usize);
        // Spawn in parallel chunks; accept in slot order (deterministic).
        // The grid holds the sloths accepted before this chunk; those accepted
        // within it are checked one by one (`fresh`), the same test as the
        // grid's, so the result does not depend on chunking and the grid is
        // rebuilt once a chunk instead of once a sloth.
        let r2 = spec.clearance_m * spec.clearance_m;
        let mut fresh: Vec<Vec3> = Vec::new();
        let mut next = 0usize;
        while accepted.len() < spec.sloths as usize && next < slots.len() {
            // Spawning is the costly part: no more at once than still needed
            // (plus a margin for rejects), and enough to keep the pool busy.
            let missing = spec.sloths as usize - accepted.len();
            let chunk = (missing + missing / 4 + 16).min(256);
            let end = (next + chunk).min(slots.len());
            let w = loco.view();
            let spawned: Vec<(Sloth, bool)> = (next..end)
                .into_par_iter()
                .map(|i| {
                    let mut hint = slots[i];
                    if headings[i] {
                        hint.forward = -hint.forward;
                    }
                    let s = Sloth::spawn(&w, &hint, None);
                    let ok = spawn_ok(&s.observe(&w));
                    (s, ok)
                })
                .collect();
            fresh.clear();
            let before = accepted.len();
            for (mut s, ok) in spawned {
                if !ok || accepted.len() == spec.sloths as usize {
                    continue;
                }
                let id = accepted.len() as u32;
                s.id = id;
                let body = [s.body_pos];
                let clear = body
                    .iter()
                    .chain(s.limbs.iter().map(|l| &l.grip.point))
                    .all(|&p| {
                        let near_fresh = p.is_finite()
                            && fresh
                                .iter()
                                .any(|q| q.is_finite() && q.distance_squared(p) < r2);
                        !neighbours.grid.blocked(u32::MAX, p) && !near_fresh
                    });
                if !clear {
                    continue;
                }
                s.wander = true;
                s.seed = slothsim_gait::sloth::mix64(spec.seed ^ ((id as u64) << 20));
                // Sloths do not step in lock-step: each starts at its own gait phase.
                s.clock = (s.seed >> 40) as f32 / (1u64 << 24) as f32;
                fresh.extend(crate::world::crowd_points(&loco.rig, &s));
                accepted.push(s);
            }
            if accepted.len() > before {
                neighbours.rebuild(&loco, accepted.iter().map(|s| (s.id, s)));
            }
            next = end;
        }
        if accepted.len() < spec.sloths as usize {
            return Err(CrowdError::TooMany {
                requested: spec.sloths,
                capacity: accepted.len() as u32,
            });
        }
        let sloths = accepted
            .into_iter()
            .map(|s| (s, TraceBatch::default()))
            .collect();
        Ok(Self::assemble(
            spec,
            loco,
            Some(forest),
            Some(neighbours),
            sloths,
            0,
            crowd_judge(),
        ))
    }

    /// One sloth alone on `loco`'s scene (a scenario run): `sloth` as
    /// spawned there, judged with `judge`, every observation kept (see
    /// [`Observer::history`](super::Observer::history)). No neighbours, no
    /// wandering; not checkpointed.
    pub fn lone(loco: Locomotion, sloth: Sloth, dt: f32, judge: Judge) -> Crowd {
        let spec = CrowdSpec {
            sloths: 1,
            seed: 0,
            dt,
            cfg: loco.cfg.clone(),
            clearance_m: 0.0,
        };
        let sloths = vec![(sloth, TraceBatch::default())];
        Self::assemble(spec, loco, None, None, sloths, 0, judge)
    }
}
