//! One sloth on a thesis scenario preset, judged: the runner behind
//! `slothsim scenario` and `slothsim matrix`.

use bevy_ecs::prelude::*;
use glam::Vec3;
use serde::Serialize;
use slothsim_gait::{LimbLoads, LocomotionConfig, Sloth, SlothObservation, SpawnHint, Status};
use slothsim_observe::{GaitReport, GaitStats, Judge, JudgeReport, Tolerances, Verdict};
use slothsim_rig::Rig;
use slothsim_scene::{Preset, PresetKind, TraceScene};

use crate::crowd::{Crowd, Observer};
use crate::grip_stats::{GripLoadReport, GripLoadStats, ReleaseCounts};
use crate::snapshot::{PoseAt, TraceLine, sloth_pose, trace_lines};
use crate::world::{Locomotion, SlothState, Traces};

/// Seconds between the poses kept for the side view.
pub const POSE_EVERY_S: f32 = 1.0;

/// Which way a scenario is run: the trunk preset climbs up or down, the
/// branch_trunk preset goes from the branch onto the trunk or back. Every
/// other preset runs as `Up`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TrunkVariant {
    /// Climb up the trunk; on branch_trunk the same as `ToTrunk` (the default run).
    Up,
    /// Climb down, head up.
    Down,
    /// trunk: side-step half way around the trunk's axis at the start's height.
    Around,
    /// branch_trunk: from the branch onto the trunk (`transfer_to_trunk`),
    /// then down it head up to a goal below the junction.
    ToTrunk,
    /// branch_trunk: from the trunk below the junction (head up, beside the
    /// branch's plane) up onto the branch (`transfer_to_branch`), to a goal
    /// out on it.
    ToBranch,
}

impl TrunkVariant {
    /// Whether this variant reports itself (a non-default way of a preset).
    pub fn shown_for(self, kind: PresetKind) -> bool {
        kind == PresetKind::Trunk || (kind == PresetKind::BranchTrunk && self != TrunkVariant::Up)
    }

    /// The start and goal of `preset` run this way.
    pub fn start_goal(self, preset: &Preset) -> (slothsim_scene::StartHint, slothsim_scene::Goal) {
        let (mut start, mut goal) = (preset.start, preset.goal);
        match (preset.kind, self) {
            (PresetKind::Trunk, TrunkVariant::Down) => {
                std::mem::swap(&mut start.position, &mut goal.point);
                start.position.y -= 0.5;
                goal.point.y += 0.5;
                start.forward = -start.forward;
            }
            (PresetKind::BranchTrunk, TrunkVariant::ToBranch) => {
                // The reverse run: start where the branch → trunk run ends
                // (on the trunk below the junction, head up, the body 60°
                // around the trunk from the branch's side), and make for where
                // that run starts. Beside the branch's vertical plane, the
                // body climbs past a branch that falls away below the
                // junction without running into it, and its fore limbs still
                // reach the branch.
                let b = preset.scene.support(start.support);
                let along = b.nodes[b.nodes.len() - 1] - b.nodes[0];
                let away = glam::Vec3::new(along.x, 0.0, along.z).normalize_or(glam::Vec3::X);
                let side = glam::Vec3::Y.cross(away);
                let angle = 60f32.to_radians();
                (start.support, goal.support) = (goal.support, start.support);
                std::mem::swap(&mut start.position, &mut goal.point);
                start.forward = glam::Vec3::Y;
                start.body_side = away * angle.cos() + side * angle.sin();
            }
            (PresetKind::Trunk, TrunkVariant::Around) => {
                // Half way around: the start is on the trunk's axis, the body beside it.
                goal.point = start.position;
                goal.side = Some(-start.body_side);
                goal.tolerance = AROUND_GOAL_TOLERANCE;
            }
            _ => {}
        }
        (start, goal)
    }
}

/// The around variant's goal: the body within this distance of where it
/// would be on the far side of the trunk (a chord: about 23° of turn
/// around a 0.15 m trunk), metres.
pub const AROUND_GOAL_TOLERANCE: f32 = 0.1;

/// What to run.
#[derive(Clone, Debug)]
pub struct ScenarioSpec {
    /// The preset (scene, start, goal).
    pub preset: Preset,
    /// Trunk variant (trunk preset only).
    pub variant: TrunkVariant,
    /// Locomotion parameters.
    pub cfg: LocomotionConfig,
    /// Fixed time step.
    pub dt: f32,
    /// Give up after this long (s); `None` = from the path length.
    pub time_limit_s: Option<f32>,
    /// Judge tolerances.
    pub tolerances: Tolerances,
}

/// The outcome of a scenario run.
#[derive(Clone, Debug, Serialize)]
pub struct ScenarioResult {
    /// Preset name.
    pub scenario: String,
    /// Parameter value (degrees or metres).
    pub parameter: Option<f32>,
    /// branch_trunk: the trunk's radius (metres).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trunk_radius: Option<f32>,
    /// Trunk variant.
    pub variant: Option<TrunkVariant>,
    /// Pass/fail with the failing measures.
    pub verdict: Verdict,
    /// Final status of the sloth.
    pub status: Status,
    /// The judge's measures.
    pub judge: JudgeReport,
    /// Gait statistics.
    pub gait: GaitReport,
    /// Gait statistics of the steady state (SPEC's steady-state rows are
    /// strides at constant speed): the frames from [`STEADY_AFTER_CYCLES`]
    /// gait cycles after setting off (the first steps start from the spawn
    /// stance's spacing and are short) until [`STEADY_BEFORE_STOP_CYCLES`]
    /// before the sloth stopped at its goal (its last steps toward the goal
    /// are short), or the end of the run. `None` when that window is shorter
    /// than one gait cycle.
    pub gait_steady: Option<SteadyGait>,
    /// Time limit used.
    pub time_limit_s: f32,
    /// Frames simulated.
    pub frames: u64,
    /// Body positions over time (every 0.5 s), for plots and logs.
    #[serde(skip)]
    pub trail: Vec<Vec3>,
    /// Every frame's observation (for plots).
    #[serde(skip)]
    pub observations: Vec<SlothObservation>,
    /// The sloth's pose every [`POSE_EVERY_S`] and at the last frame (for the side view).
    #[serde(skip)]
    pub poses: Vec<PoseAt>,
    /// Grip loads over the run (issue 22).
    pub grip_load: GripLoadReport,
    /// Grip loads over the steady-state window of `gait_steady`, if any.
    pub grip_load_steady: Option<GripLoadReport>,
    /// Every frame's grip loads with its time (for the loads plot).
    #[serde(skip)]
    pub loads: Vec<(f32, LimbLoads)>,
    /// The release rule's threshold the run used (body weights).
    #[serde(skip)]
    pub release_residual_bw: f32,
    /// The traces of the sloth's last step search (for the top-down view).
    #[serde(skip)]
    pub traces: Vec<TraceLine>,
    /// Per-frame stage times (ms), as in [`crate::StageTimings::history`].
    #[serde(skip)]
    pub stage_ms: Vec<[f64; crate::STAGES]>,
}

/// The steady state's window starts this many gait cycles after the first frame…
pub const STEADY_AFTER_CYCLES: f32 = 2.0;
/// …and ends this many before the sloth stopped (its goal), if it did.
pub const STEADY_BEFORE_STOP_CYCLES: f32 = 1.0;

/// [`GaitReport`] over the steady-state window `[from_s, to_s]`.
#[derive(Clone, Debug, Serialize)]
pub struct SteadyGait {
    /// Window start (s).
    pub from_s: f32,
    /// Window end (s): a cycle before the sloth stopped, or the run's end.
    pub to_s: f32,
    /// The statistics over the window's frames.
    #[serde(flatten)]
    pub gait: GaitReport,
}

/// Gait statistics over the observations from `after_cycles` gait cycles
/// after the first until `until_s`; `None` if that is shorter than a cycle.
pub fn steady_gait(
    observations: &[SlothObservation],
    cycle_s: f32,
    after_cycles: f32,
    until_s: f32,
) -> Option<SteadyGait> {
    let from_s = observations.first()?.time_s + after_cycles * cycle_s;
    if until_s - from_s < cycle_s {
        return None;
    }
    // The frames before the window only follow the limbs, so the strides
    // and phases ending in it count whole.
    let mut before = GaitStats::new();
    for obs in observations.iter().take_while(|o| o.time_s < from_s) {
        before.observe(obs);
    }
    let mut stats = before.restarted();
    for obs in observations
        .iter()
        .filter(|o| (from_s..=until_s).contains(&o.time_s))
    {
        stats.observe(obs);
    }
    Some(SteadyGait {
        from_s,
        to_s: until_s,
        gait: stats.finish(),
    })
}

/// Runs one scenario to the goal, a stop, or the time limit.
pub fn run_scenario(
    spec: &ScenarioSpec,
    rig: &Rig,
) -> Result<ScenarioResult, slothsim_gait::ConfigError> {
    run_scenario_observed(spec, rig, &mut |_, _| {})
}

/// [`run_scenario`], showing `observe` the sloth after spawning and after
/// every tick (read-only: recording, see [`crate::record`]).
pub fn run_scenario_observed(
    spec: &ScenarioSpec,
    rig: &Rig,
    observe: &mut dyn FnMut(&Sloth, &Locomotion),
) -> Result<ScenarioResult, slothsim_gait::ConfigError> {
    let preset = &spec.preset;
    let variant = spec.variant;
    let (start, goal) = variant.start_goal(preset);
    // The way around counts at about the body's distance from a trunk's axis.
    let around = goal
        .side
        .map_or(0.0, |side| side.angle_between(start.body_side) * 0.3);
    let path_len = start.position.distance(goal.point) + around + 1.0;
    let time_limit_s = spec.time_limit_s.unwrap_or(30.0 + path_len / 0.03);
    let loco = Locomotion::new(spec.cfg.clone(), rig, TraceScene::new(preset.scene.clone()))?;
    let hint = SpawnHint::from(start);
    let mut sloth = Sloth::spawn(
        &loco.view(),
        &hint,
        Some((goal.support, goal.point, goal.tolerance)),
    );
    sloth.goal_side = goal.side;
    let judge = Judge::new(
        Tolerances {
            goal_tolerance_m: goal.tolerance,
            ..spec.tolerances
        },
        time_limit_s,
    );
    // The crowd's world, schedule and observer, for one sloth.
    let mut crowd = Crowd::lone(loco, sloth, spec.dt, judge);
    let entity = crowd.entity(0).expect("the lone sloth");
    {
        let world = crowd.world();
        let s = &world.get::<SlothState>(entity).expect("the lone sloth").0;
        observe(s, world.resource::<Locomotion>());
    }
    let mut trail = Vec::new();
    let frames_max = (time_limit_s / spec.dt).ceil() as u64;
    let mut status = Status::Moving;
    let mut frames = 0;
    let mut after_stop = 0;
    let mut stopped_s = None;
    let mut poses = Vec::new();
    let mut last_search = None;
    let pose_every = ((POSE_EVERY_S / spec.dt).round() as u64).max(1);
    let trail_every = ((0.5 / spec.dt).round() as u64).max(1);
    let pose_at = |world: &World, s: &Sloth| PoseAt {
        time_s: s.time,
        pose: sloth_pose(s, world.resource::<Locomotion>()),
    };
    while frames < frames_max {
        crowd.step();
        frames += 1;
        let world = crowd.world();
        let s = &world.get::<SlothState>(entity).expect("the lone sloth").0;
        observe(s, world.resource::<Locomotion>());
        if frames.is_multiple_of(pose_every) {
            poses.push(pose_at(world, s));
        }
        if let Some(tr) = world.get::<Traces>(entity)
            && tr.0.len > 0
        {
            last_search = Some(tr.0.clone());
        }
        if frames.is_multiple_of(trail_every) {
            trail.push(s.body_pos);
        }
        status = s.status;
        if status != Status::Moving {
            stopped_s.get_or_insert(s.time);
            // Let the last swing settle, then stop.
            after_stop += 1;
            if after_stop as f32 * spec.dt > 1.0 {
                break;
            }
        }
    }
    let world = crowd.world();
    let s = &world.get::<SlothState>(entity).expect("the lone sloth").0;
    if !frames.is_multiple_of(pose_every) {
        poses.push(pose_at(world, s));
    }
    let loco = world.resource::<Locomotion>();
    let traces = last_search.map_or_else(Vec::new, |b| trace_lines(&b, loco));
    let stage_ms = crowd.timings().history.clone();
    let observer = world.get::<Observer>(entity).expect("the lone sloth");
    let observations = observer.history().to_vec();
    // A sloth that stopped (at its goal) shortened its last steps toward it.
    let cycle_s = spec.cfg.cycle_duration();
    let until_s = match stopped_s {
        Some(t) => Some(t - STEADY_BEFORE_STOP_CYCLES * cycle_s),
        None => observations.last().map(|o| o.time_s),
    };
    let gait_steady = until_s
        .and_then(|until_s| steady_gait(&observations, cycle_s, STEADY_AFTER_CYCLES, until_s));
    let loads = observer.load_history().to_vec();
    let release = spec.cfg.release_residual_bw;
    let mut counts = ReleaseCounts::default();
    counts.add(&s.load);
    let load_report = |window: Option<(f32, f32)>| {
        let mut st = GripLoadStats::new();
        for (t, l) in &loads {
            if window.is_none_or(|(a, b)| (a..=b).contains(t)) {
                st.observe(l, release);
            }
        }
        st.finish(counts)
    };
    let grip_load = load_report(None);
    let grip_load_steady = gait_steady
        .as_ref()
        .map(|g| load_report(Some((g.from_s, g.to_s))));
    let report = observer.judge().finish();
    let mut verdict = report.verdict(observer.judge().tolerances());
    // branch_end: the sloth must come back head first (its body turned
    // around at the end), not tail first.
    if preset.kind == slothsim_scene::PresetKind::BranchEnd
        && (s.body_rot * Vec3::Z).dot(start.forward) >= 0.0
    {
        verdict.pass = false;
        verdict
            .failures
            .push("turned_around false: the body still heads for the branch's end".into());
    }
    Ok(ScenarioResult {
        scenario: preset.kind.name().to_string(),
        parameter: preset.parameter,
        trunk_radius: preset.trunk_radius,
        variant: variant.shown_for(preset.kind).then_some(variant),
        verdict,
        status,
        judge: report,
        gait: observer.gait().finish(),
        gait_steady,
        time_limit_s,
        frames,
        trail,
        observations,
        poses,
        traces,
        grip_load,
        grip_load_steady,
        loads,
        release_residual_bw: release,
        stage_ms,
    })
}
