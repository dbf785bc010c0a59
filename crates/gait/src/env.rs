//! The locomotion kernels' shared, read-only environment: the validated
//! config, the rig's derived data, the forest with its BVH, the supports'
//! adjacency and the IK parameters ([`LocoEnv`], owned, built once per run),
//! and the borrowed view every kernel reads ([`LocoView`], with the other
//! sloths when in a crowd). The sim crate keeps a [`LocoEnv`] as a resource;
//! tests build one directly.

use glam::Vec3;
use slothsim_rig::{CcdParams, Rig};
use slothsim_scene::{Scene, SceneQuery, TraceScene};

use crate::config::{ConfigError, LocomotionConfig};
use crate::crowd::CrowdGrid;
use crate::path::Adjacency;
use crate::rigdata::RigData;
use crate::sloth::Sloth;

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

/// The fixed time step a [`LocoEnv`] assumes until told the run's
/// ([`LocoEnv::with_frame_dt`]): 60 ticks a second.
pub const DEFAULT_FRAME_DT: f32 = 1.0 / 60.0;

/// Everything read-only the locomotion kernels share: config, rig data,
/// forest BVH, adjacency, IK parameters.
pub struct LocoEnv {
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
    /// The run's fixed time step (s): the step checks draw a trunk walk's
    /// body frame by frame as `body_average` will (see
    /// `Sloth::trunk_walk_frames_penetrate`).
    pub frame_dt: f32,
}

impl LocoEnv {
    /// Validates `cfg` against the rig and builds the shared data.
    pub fn new(cfg: LocomotionConfig, rig: &Rig, traces: TraceScene) -> Result<Self, ConfigError> {
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
        Ok(LocoEnv {
            cfg,
            rig,
            body_offset,
            traces,
            adjacency,
            ccd,
            frame_dt: DEFAULT_FRAME_DT,
        })
    }

    /// The same environment for a run ticking every `dt` seconds (finite,
    /// positive; [`DEFAULT_FRAME_DT`] until set).
    pub fn with_frame_dt(self, dt: f32) -> Self {
        assert!(dt.is_finite() && dt > 0.0, "frame dt {dt} must be positive");
        LocoEnv {
            frame_dt: dt,
            ..self
        }
    }

    /// The kernels' view, with other sloths (`crowd`) when in a crowd.
    pub fn view_with<'a>(&'a self, crowd: Option<&'a CrowdGrid>) -> LocoView<'a> {
        LocoView {
            crowd,
            ..self.view()
        }
    }

    /// The kernels' view (a lone sloth).
    pub fn view(&self) -> LocoView<'_> {
        LocoView {
            cfg: &self.cfg,
            rig: &self.rig,
            body_offset: self.body_offset,
            query: self.traces.query(),
            adjacency: &self.adjacency,
            ccd: &self.ccd,
            crowd: None,
            phase_offsets: self.cfg.phase_offsets(),
            cycle_s: self.cfg.cycle_duration(),
            frame_dt: self.frame_dt,
        }
    }
}

/// What a kernel reads besides its sloth: a borrowed view of a [`LocoEnv`]
/// and, in a crowd, the other sloths of the previous tick.
#[derive(Clone, Copy)]
pub struct LocoView<'a> {
    /// Locomotion parameters (validated).
    pub cfg: &'a LocomotionConfig,
    /// Rig data.
    pub rig: &'a RigData,
    /// Body offset below the paws (formula 7), resolved.
    pub body_offset: f32,
    /// Trace queries over the forest.
    pub query: SceneQuery<'a>,
    /// Support adjacency.
    pub adjacency: &'a Adjacency,
    /// IK parameters.
    pub ccd: &'a CcdParams,
    /// Other sloths' bodies and grips (previous tick), when in a crowd.
    pub crowd: Option<&'a CrowdGrid>,
    /// `cfg.phase_offsets()`, made once a view (the gait clock reads them
    /// every sloth-frame; two `rem_euclid` calls each time).
    pub phase_offsets: [f32; 4],
    /// `cfg.cycle_duration()`, made once a view.
    pub cycle_s: f32,
    /// The run's fixed time step (s).
    pub frame_dt: f32,
}

impl<'a> LocoView<'a> {
    /// The forest.
    pub fn scene(&self) -> &'a Scene {
        self.query.scene()
    }
}

/// The points a sloth occupies for the others (what [`CrowdGrid`] holds):
/// body centre, hips, head and the four grips.
pub fn crowd_points(rig: &RigData, s: &Sloth) -> [Vec3; 7] {
    let to_ws = |p: Vec3| s.body_pos + s.body_rot * p;
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
