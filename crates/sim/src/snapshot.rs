//! Snapshots for the debug plots: a sloth's pose and its step-search traces
//! as plain world-space data (the CLI hands them to `slothsim-plot`), and a
//! recorder that samples a crowd run for plots.
//!
//! Everything here only reads the simulation (after a tick, outside the timed
//! stages): recording never changes the state or its hash.

use bevy_ecs::prelude::*;
use glam::{Quat, Vec3};
use slothsim_gait::{LimbLoads, LimbPhase, Sloth, TraceBatch};
use slothsim_scene::TraceRequest;

use crate::crowd::Crowd;
use crate::world::{GripLoad, Locomotion, SlothId, SlothState, Traces};

/// One limb at one instant, world space (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimbPose {
    /// Chain root (girdle), shoulder/hip, elbow/knee, wrist/ankle, claw tip.
    pub joints_ws: [Vec3; 5],
    /// Where the claw holds (planted) or the target it swings toward.
    pub grip_ws: Vec3,
    /// The limb holds its grip (stance), not swinging.
    pub planted: bool,
}

/// One sloth at one instant, world space (metres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlothPose {
    /// Sloth id.
    pub id: u32,
    /// Body origin.
    pub body_pos: Vec3,
    /// Body rotation (model +Z forward, +Y toward the support, +X left).
    pub body_rot: Quat,
    /// Head (tip of the spine).
    pub head_ws: Vec3,
    /// Hips (root of the spine).
    pub hips_ws: Vec3,
    /// Limbs in [`slothsim_rig::Limb::index`] order (`LF, RF, LH, RH`).
    pub limbs: [LimbPose; 4],
    /// Local rotations (relative to the parent joint) of each limb's four chain joints,
    /// as recorded for the export (`record::moved_joints` order): what skins the mesh.
    pub limb_locals: [[Quat; 4]; 4],
}

/// A pose and its simulated time (seconds).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PoseAt {
    /// Simulated time of the pose.
    pub time_s: f32,
    /// The pose.
    pub pose: SlothPose,
}

/// One line trace of a step search, world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceLine {
    /// Start of the ray.
    pub from: Vec3,
    /// The hit point if `hit`, else the end of the ray.
    pub to: Vec3,
    /// The trace found a surface.
    pub hit: bool,
}

/// A sloth's pose for the plots: every limb's five joints by forward
/// kinematics from its chain root and solved pose, its grip, planted unless
/// swinging; head and hips from the rig.
pub fn sloth_pose(s: &Sloth, loco: &Locomotion) -> SlothPose {
    let rig = &loco.rig;
    let to_ws = |p: Vec3| s.body_pos + s.body_rot * p;
    let limbs = std::array::from_fn(|li| {
        let l = &s.limbs[li];
        let root = rig.root_ws(li, s.body_pos, s.body_rot);
        LimbPose {
            joints_ws: rig.chains[li].fk(root, &l.pose),
            grip_ws: l.grip.point,
            planted: l.phase != LimbPhase::Swinging,
        }
    });
    let chains = &rig.chains;
    let limb_locals = std::array::from_fn(|li| {
        std::array::from_fn(|j| chains[li].local_rotation(&s.limbs[li].pose, j))
    });
    SlothPose {
        id: s.id,
        body_pos: s.body_pos,
        body_rot: s.body_rot,
        head_ws: to_ws(rig.head_ms),
        hips_ws: to_ws(rig.hips_ms),
        limbs,
        limb_locals,
    }
}

/// The traces of a step search: the batch's queued requests traced against
/// the forest (a copy is traced, exactly as the next Trace stage will; the
/// batch itself is untouched). Hits end at the hit point, misses at the ray's end.
pub fn trace_lines(batch: &TraceBatch, loco: &Locomotion) -> Vec<TraceLine> {
    let mut b = batch.clone();
    b.run(&loco.traces.query());
    (0..b.len.min(b.reqs.len()))
        .map(|i| {
            let line = match &b.reqs[i] {
                TraceRequest::Line(l) => *l,
                TraceRequest::Sphere(s) => s.line,
            };
            let dir = line.dir.normalize_or_zero();
            let far = if line.max_dist.is_finite() {
                line.max_dist
            } else {
                10.0
            };
            match b.results[i] {
                Ok(Some(hit)) => TraceLine {
                    from: line.origin,
                    to: hit.point,
                    hit: true,
                },
                _ => TraceLine {
                    from: line.origin,
                    to: line.origin + dir * far,
                    hit: false,
                },
            }
        })
        .collect()
}

/// Every sloth of the crowd as a plot pose, in id order.
pub fn crowd_poses(crowd: &Crowd) -> Vec<SlothPose> {
    let world = crowd.world();
    let loco = world.resource::<Locomotion>();
    let Some(mut q) = world.try_query::<(&SlothId, &SlothState)>() else {
        return Vec::new();
    };
    let mut v: Vec<(u32, SlothPose)> = q
        .iter(world)
        .map(|(id, s)| (id.0, sloth_pose(&s.0, loco)))
        .collect();
    v.sort_unstable_by_key(|(i, _)| *i);
    v.into_iter().map(|(_, p)| p).collect()
}

/// The traces queued by sloth `id`'s current step search (empty when none
/// of its limbs is searching).
pub fn crowd_traces(crowd: &Crowd, id: u32) -> Vec<TraceLine> {
    let world = crowd.world();
    let loco = world.resource::<Locomotion>();
    let Some(mut q) = world.try_query::<(&SlothId, &Traces)>() else {
        return Vec::new();
    };
    q.iter(world)
        .find(|(i, _)| i.0 == id)
        .map(|(_, t)| trace_lines(&t.0, loco))
        .unwrap_or_default()
}

/// Samples a crowd run for the plots: body trails of every sloth (every
/// `trail_every` frames), the focus sloth's planted flags every frame (gait
/// diagram) and its last non-empty step search (traces). Costs one entity
/// look-up per frame plus one pass over the crowd per trail sample.
#[derive(Debug)]
pub struct CrowdRecorder {
    focus: u32,
    focus_entity: Option<Entity>,
    trail_every: u64,
    frames: u64,
    /// Body positions per sloth (index = id), oldest first.
    pub trails: Vec<Vec<Vec3>>,
    /// The focus sloth's simulated time per frame.
    pub gait_times: Vec<f32>,
    /// The focus sloth's planted flags per frame (`LF, RF, LH, RH`).
    pub gait_planted: Vec<[bool; 4]>,
    /// The focus sloth's grip loads per frame (same times as `gait_times`).
    pub loads: Vec<LimbLoads>,
    last_search: Option<TraceBatch>,
}

impl CrowdRecorder {
    /// Starts recording `crowd` (its current positions are the trails' first
    /// points), following sloth `focus` (clamped to the crowd), sampling
    /// trails every `trail_every_s` simulated seconds.
    pub fn new(crowd: &Crowd, focus: u32, trail_every_s: f32) -> Self {
        let n = crowd.spec().sloths;
        let focus = focus.min(n.saturating_sub(1));
        let world = crowd.world();
        let focus_entity = world
            .try_query::<(Entity, &SlothId)>()
            .and_then(|mut q| q.iter(world).find(|(_, i)| i.0 == focus).map(|(e, _)| e));
        let dt = crowd.spec().dt;
        let mut r = CrowdRecorder {
            focus,
            focus_entity,
            trail_every: ((trail_every_s / dt).round() as u64).max(1),
            frames: 0,
            trails: vec![Vec::new(); n as usize],
            gait_times: Vec::new(),
            gait_planted: Vec::new(),
            loads: Vec::new(),
            last_search: None,
        };
        r.sample_trails(crowd);
        r
    }

    /// The focus sloth's id.
    pub fn focus(&self) -> u32 {
        self.focus
    }

    fn sample_trails(&mut self, crowd: &Crowd) {
        let world = crowd.world();
        if let Some(mut q) = world.try_query::<(&SlothId, &SlothState)>() {
            for (id, s) in q.iter(world) {
                if let Some(t) = self.trails.get_mut(id.0 as usize) {
                    t.push(s.0.body_pos);
                }
            }
        }
    }

    /// Records the state after one [`Crowd::step`].
    pub fn record(&mut self, crowd: &Crowd) {
        self.frames += 1;
        if self.frames.is_multiple_of(self.trail_every) {
            self.sample_trails(crowd);
        }
        let Some(e) = self.focus_entity else { return };
        let world = crowd.world();
        if let Some(s) = world.get::<SlothState>(e) {
            self.gait_times.push(s.0.time);
            self.gait_planted
                .push(s.0.limbs.map(|l| l.phase != LimbPhase::Swinging));
            self.loads.push(
                world
                    .get::<GripLoad>(e)
                    .map_or_else(LimbLoads::default, |g| g.0),
            );
        }
        if let Some(t) = world.get::<Traces>(e)
            && t.0.len > 0
        {
            self.last_search = Some(t.0.clone());
        }
    }

    /// Ends the trails at the current positions (unless just sampled).
    pub fn finish(&mut self, crowd: &Crowd) {
        if !self.frames.is_multiple_of(self.trail_every) {
            self.sample_trails(crowd);
        }
    }

    /// The focus sloth's last step search, traced.
    pub fn traces(&self, crowd: &Crowd) -> Vec<TraceLine> {
        match &self.last_search {
            Some(b) => trace_lines(b, crowd.world().resource::<Locomotion>()),
            None => crowd_traces(crowd, self.focus),
        }
    }
}
