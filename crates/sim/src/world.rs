//! Components, resources and world construction.

use bevy_ecs::prelude::*;
// Re-exported so `crate::world::crowd_points` (crowd.rs) keeps working; it lives in gait.
pub use slothsim_gait::crowd_points;
use slothsim_gait::{
    BodyMemo, CrowdGrid, HashedPoint, LimbLoads, LocoEnv, LocoView, LocomotionConfig, NearRing,
    Sloth, SolveMemo, SpawnHint, TraceBatch,
};
use slothsim_rig::Rig;
use slothsim_scene::{SupportId, TraceScene};

/// Stable sloth id (spawn order); reductions iterate in this order.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SlothId(pub u32);

/// A sloth's locomotion state.
#[derive(Component, Clone, Debug)]
#[require(CrowdPoints, CcdMemo, BodyAverageMemo, GripLoad)]
pub struct SlothState(pub Sloth);

/// A goal-mode sloth's record of the stances it took since it last came
/// nearer its goal ([`NearRing`], read and written by its step search). Only
/// sloths that keep one ([`Sloth::keeps_near_record`]: scenario runs) have
/// this component; a crowd of wanderers carries none of its 840 bytes.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct NearStances(pub NearRing);

/// What the CcdSolve stage keeps of a sloth's last solve, to skip the next one
/// where it would change nothing ([`Sloth::solve_limbs_memo`]).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct CcdMemo(pub SolveMemo);

/// What the BodyAverage stage keeps of a sloth's last update, to skip the
/// next one where it would change nothing ([`Sloth::body_average_memo`]).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct BodyAverageMemo(pub BodyMemo);

/// How often the GripLoad stage solves each sloth's loads: every this many frames,
/// sloths staggered by id (a crowd: [`CROWD_LOAD_EVERY`]; a lone scenario sloth: 1).
#[derive(Resource, Clone, Copy, Debug)]
pub struct GripLoadEvery(pub u32);

/// Crowds solve each sloth's grip loads every frame by default. The config key
/// `crowd_load_every` sets a lower rate (every Nth frame, sloths staggered by id; the
/// loads change over a stride, ~1 s); release decisions always solve when they are
/// asked, with the body as it is then. This is the key's default.
pub const CROWD_LOAD_EVERY: u32 = 1;

/// A sloth's grip loads this frame (written by the GripLoad stage): the force on each
/// holding limb and the residual wrench (see `slothsim-load`).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct GripLoad(pub LimbLoads);

impl AsMut<Sloth> for SlothState {
    fn as_mut(&mut self) -> &mut Sloth {
        &mut self.0
    }
}

impl AsMut<SolveMemo> for CcdMemo {
    fn as_mut(&mut self) -> &mut SolveMemo {
        &mut self.0
    }
}

/// The points a sloth occupies for the others ([`crowd_points`]) with their
/// grid-cell hashes, written by the Transitions stage in parallel for the
/// neighbour grid's update; the bits of the body rotation they
/// were made from (`None`: not made yet); and whether the last
/// [`CrowdPoints::update`] kept them (the same bits as the update before:
/// the neighbour grid's update then neither copies nor tests them again,
/// `CrowdGrid::update_hashed_kept_with`).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct CrowdPoints(pub [HashedPoint; 7], pub Option<[u32; 4]>, pub bool);

impl CrowdPoints {
    /// Makes `s`'s points hashed for `g`, unless these are they already: the
    /// points are a function of the body (position, rotation) and the four
    /// grips alone, so where those hold the bits the points were made from
    /// (the body position and the grips are points 0 and 3–6 themselves),
    /// making them again would write the same bits (a sloth at rest: about
    /// half the sloth-frames of a crowd). `g` must hash as the grid the
    /// points were made for did (one grid, one cell size, a run).
    #[inline]
    pub fn update(&mut self, rig: &slothsim_gait::RigData, s: &Sloth, g: &CrowdGrid) {
        let bits = |v: glam::Vec3| v.to_array().map(f32::to_bits);
        let rot = s.body_rot.to_array().map(f32::to_bits);
        let kept = self.1 == Some(rot)
            && bits(self.0[0].point) == bits(s.body_pos)
            && (0..4).all(|k| bits(self.0[3 + k].point) == bits(s.limbs[k].grip.point));
        if kept {
            debug_assert!(
                crowd_points(rig, s)
                    .map(|p| g.hashed(p))
                    .iter()
                    .zip(&self.0)
                    .all(|(a, b)| a.hash == b.hash && bits(a.point) == bits(b.point)),
                "kept crowd points differ from the sloth's"
            );
            self.2 = true;
            return;
        }
        self.0 = crowd_points(rig, s).map(|p| g.hashed(p));
        self.1 = Some(rot);
        self.2 = false;
    }
}

/// A sloth's trace requests and results (filled by the Trace stage).
#[derive(Component, Clone, Debug, Default)]
pub struct Traces(pub TraceBatch);

/// The locomotion kernels' shared environment ([`LocoEnv`]: config, rig,
/// forest BVH, adjacency, IK parameters) as the world's resource; it reads as
/// a [`LocoEnv`] (`Deref`).
#[derive(Resource)]
pub struct Locomotion(pub LocoEnv);

impl Locomotion {
    /// Validates `cfg` against the rig and builds the shared data ([`LocoEnv::new`]).
    pub fn new(
        cfg: LocomotionConfig,
        rig: &Rig,
        traces: TraceScene,
    ) -> Result<Self, slothsim_gait::ConfigError> {
        LocoEnv::new(cfg, rig, traces).map(Locomotion)
    }

    /// The kernels' view, with other sloths when in a crowd.
    pub fn view_in<'a>(&'a self, crowd: Option<&'a CrowdNeighbours>) -> LocoView<'a> {
        self.0.view_with(crowd.map(|c| &c.grid))
    }
}

impl std::ops::Deref for Locomotion {
    type Target = LocoEnv;

    fn deref(&self) -> &LocoEnv {
        &self.0
    }
}

/// How far a crowd point may move before the neighbour grid holds it apart
/// (see [`CrowdGrid::with_slack`]): 4 to 6 cm gave the same instructions
/// in the first two seconds of a 1,000-sloth crowd (docs/performance.md,
/// twentieth round).
pub const GRID_SLACK_M: f32 = 0.05;

/// Sloths meet sloths: every sloth's body and grips from the previous tick
/// (rebuilt at the end of each Transitions stage), present in crowd runs.
#[derive(Resource, Clone, Debug)]
pub struct CrowdNeighbours {
    /// The spatial hash.
    pub grid: CrowdGrid,
}

impl CrowdNeighbours {
    /// An empty structure keeping `clearance_m` between sloths.
    pub fn new(clearance_m: f32) -> Self {
        CrowdNeighbours {
            grid: CrowdGrid::with_slack(clearance_m, GRID_SLACK_M),
        }
    }

    /// Rebuilds from `(id, sloth)` pairs: body centre, hips, head and grips.
    pub fn rebuild<'a>(
        &mut self,
        loco: &Locomotion,
        sloths: impl Iterator<Item = (u32, &'a Sloth)>,
    ) {
        let rig = &loco.rig;
        self.grid
            .rebuild_groups(sloths.map(|(id, s)| (id, crowd_points(rig, s))));
    }
}

/// Fixed time step and frame counter.
#[derive(Resource, Clone, Copy, Debug)]
pub struct SimClock {
    /// Time step (s).
    pub dt: f32,
    /// Frames simulated.
    pub frame: u64,
}

/// A world holding the shared resources, ready for sloths, ticking every
/// `dt` seconds (the step checks draw a trunk walk's body at that rate).
pub fn new_world(loco: Locomotion, dt: f32) -> World {
    let mut world = World::new();
    world.insert_resource(Locomotion(loco.0.with_frame_dt(dt)));
    world.insert_resource(SimClock { dt, frame: 0 });
    world.insert_resource(crate::StageTimings::default());
    world
}

/// Spawns one sloth (its limbs gripping around `hint`).
pub fn spawn_sloth(
    world: &mut World,
    id: u32,
    hint: &SpawnHint,
    goal: Option<(SupportId, glam::Vec3, f32)>,
) -> Entity {
    let sloth = {
        let loco = world.resource::<Locomotion>();
        Sloth::spawn(&loco.view(), hint, goal)
    };
    let mut e = world.spawn((SlothId(id), SlothState(sloth), Traces::default()));
    if sloth.keeps_near_record() {
        e.insert(NearStances::default());
    }
    e.id()
}
