//! Components, resources and world construction.

use bevy_ecs::prelude::*;
use slothsim_gait::{
    Adjacency, BodyMemo, CrowdGrid, HashedPoint, LocomotionConfig, RigData, Sloth, SolveMemo,
    SpawnHint, TraceBatch, World as LocoWorld,
};
use slothsim_rig::{CcdParams, Rig};
use slothsim_scene::{SupportId, TraceScene};

/// Stable sloth id (spawn order); reductions iterate in this order.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct SlothId(pub u32);

/// A sloth's locomotion state.
#[derive(Component, Clone, Debug)]
#[require(CrowdPoints, CcdMemo, BodyAverageMemo)]
pub struct SlothState(pub Sloth);

/// What the CcdSolve stage keeps of a sloth's last solve, to skip the next one
/// where it would change nothing ([`Sloth::solve_limbs_memo`]).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct CcdMemo(pub SolveMemo);

/// What the BodyAverage stage keeps of a sloth's last update, to skip the
/// next one where it would change nothing ([`Sloth::body_average_memo`]).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct BodyAverageMemo(pub BodyMemo);

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
/// neighbour grid's serial rebuild.
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct CrowdPoints(pub [HashedPoint; 7]);

/// A sloth's trace requests and results (filled by the Trace stage).
#[derive(Component, Clone, Debug, Default)]
pub struct Traces(pub TraceBatch);

/// How close each frame's IK brings a claw to its target (metres).
///
/// A hanging sloth's planted limbs often sit with the elbow (knee) at its
/// extension limit, their targets a fraction of a millimetre beyond what the
/// shoulder can aim at: at 0.5 mm, 10 % of the limbs of a 10,000-sloth crowd
/// missed it every frame and went on to the slower plain-CCD sweeps and polish
/// (CcdSolve p95 15.5 ms on 2 threads). At 1 mm they stop after one sweep
/// (11.3 ms); grip slip (2.2 mm) and stuck sloths are unchanged in a
/// 2,000-sloth, 60 s run and the surface gap goes from 4.8 to 5.1 mm, against
/// tolerances of 5 mm and 1 cm. Grips still hold: the step checks ask for
/// 1.5 mm and CcdSolve moves the body when a planted claw is farther off.
pub const IK_TOLERANCE_M: f32 = 1e-3;

/// Everything read-only the kernels share: config, rig, forest BVH, adjacency.
#[derive(Resource)]
pub struct Locomotion {
    /// Parameters (validated).
    pub cfg: LocomotionConfig,
    /// Rig data.
    pub rig: RigData,
    /// Body offset (formula 7), resolved.
    pub body_offset: f32,
    /// The forest with its BVH.
    pub traces: TraceScene,
    /// Support adjacency.
    pub adjacency: Adjacency,
    /// IK parameters.
    pub ccd: CcdParams,
}

impl Locomotion {
    /// Validates `cfg` against the rig and builds the shared data.
    pub fn new(
        cfg: LocomotionConfig,
        rig: &Rig,
        traces: TraceScene,
    ) -> Result<Self, slothsim_gait::ConfigError> {
        let rig = RigData::new(rig);
        cfg.validate(rig.reach)?;
        let body_offset = cfg
            .body_vertical_offset_m
            .unwrap_or_else(|| rig.auto_body_offset());
        // Neighbours: supports a limb can reach from this one (parallel branches
        // included), not only those that touch it.
        let adjacency = Adjacency::build(traces.query(), rig.reach);
        let ccd = CcdParams {
            min_improvement: 1e-7,
            tolerance: IK_TOLERANCE_M,
            ..CcdParams::default()
        };
        Ok(Locomotion {
            cfg,
            rig,
            body_offset,
            traces,
            adjacency,
            ccd,
        })
    }

    /// The kernels' view, with other sloths when in a crowd.
    pub fn view_in<'a>(&'a self, crowd: Option<&'a CrowdNeighbours>) -> LocoWorld<'a> {
        LocoWorld {
            crowd: crowd.map(|c| &c.grid),
            ..self.view()
        }
    }

    /// The kernels' view (a lone sloth).
    pub fn view(&self) -> LocoWorld<'_> {
        LocoWorld {
            cfg: &self.cfg,
            rig: &self.rig,
            body_offset: self.body_offset,
            query: self.traces.query(),
            adjacency: &self.adjacency,
            ccd: &self.ccd,
            crowd: None,
        }
    }
}

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
            grid: CrowdGrid::new(clearance_m),
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

/// The points a sloth occupies for the others: body centre, hips, head and grips.
pub fn crowd_points(rig: &RigData, s: &Sloth) -> [glam::Vec3; 7] {
    let to_ws = |p: glam::Vec3| s.body_pos + s.body_rot * p;
    [
        s.body_pos,
        to_ws(rig.hips_ms),
        to_ws(rig.head_ms),
        s.limbs[0].grip.point,
        s.limbs[1].grip.point,
        s.limbs[2].grip.point,
        s.limbs[3].grip.point,
    ]
}

/// Fixed time step and frame counter.
#[derive(Resource, Clone, Copy, Debug)]
pub struct SimClock {
    /// Time step (s).
    pub dt: f32,
    /// Frames simulated.
    pub frame: u64,
}

/// A world holding the shared resources, ready for sloths.
pub fn new_world(loco: Locomotion, dt: f32) -> World {
    let mut world = World::new();
    world.insert_resource(loco);
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
    world
        .spawn((SlothId(id), SlothState(sloth), Traces::default()))
        .id()
}
