//! The automatic judge: measured pass/fail criteria for one run of one sloth
//! (SPEC "Test scenarios": grips held on the surface, reach and joint limits
//! respected, no body/support penetration, head-up on trunks, goal reached in
//! time).
//!
//! [`Judge`] is a streaming accumulator: feed it one [`SlothObservation`] per
//! frame with [`Judge::observe`] (constant memory, no allocation), then read a
//! [`JudgeReport`] with [`Judge::finish`] and decide with
//! [`JudgeReport::verdict`].
//!
//! Units: metres, seconds, radians. Times are the simulation clock
//! (`SlothObservation::time_s`, which starts at 0 when the run starts).
//!
//! Degenerate cases:
//! - A frame with `has_nan` set, or with any non-finite value (checked here
//!   too, see [`observation_is_finite`]), or with a limb whose `limb_length`
//!   is not > 0, counts once in `nan_count`. If its values are not all finite
//!   it takes no part in the other measures, and the grip-slip measure
//!   restarts after it (no slip is measured across it).
//! - Grip slip covers three ways a planted grip can fail to hold: the IK
//!   misses it, it jumps between frames, or it slides slowly over the stance
//!   (distance from where the stance began).
//! - An empty stream gives a report with 0 frames; its verdict fails with
//!   "frames 0" and "goal not reached".

use std::fmt::Write as _;

use glam::Vec3;
use serde::{Deserialize, Serialize};
use slothsim_rig::Limb;

use slothsim_gait::observe::SlothObservation;

/// A joint-limit violation counts when `limit_violation` exceeds this many
/// radians (about 0.006°): above the float noise of a clamped CCD pose, far
/// below anything visible.
pub const LIMIT_VIOLATION_EPSILON_RAD: f32 = 1e-4;

/// Pass/fail limits for a [`JudgeReport`]. `Default` is the issue's limits,
/// the loosest allowed ([`Tolerances::validate`] rejects anything looser).
///
/// Deserialises with defaults for missing fields (e.g. from a TOML table).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Tolerances {
    /// The goal counts as reached when `goal_distance_m` ≤ this, metres.
    /// Default 0.3 m, as `slothsim_scene::Goal::tolerance` of the presets;
    /// set it from the scenario's `Goal::tolerance`.
    pub goal_tolerance_m: f32,
    /// Largest slip of a planted grip, metres (issue: ≤ 5 mm).
    pub max_grip_slip_m: f32,
    /// Largest effector↔support-surface gap of a planted limb, metres (issue: ≤ 1 cm).
    pub max_surface_gap_m: f32,
    /// Largest |effector − root| / limb length (issue: ≤ 1.0).
    pub max_reach_ratio: f32,
    /// Largest number of (frame, limb) joint-limit violations (issue: 0).
    pub max_joint_limit_violations: u64,
    /// A limb's `limit_violation` above this is a violation, radians
    /// (default [`LIMIT_VIOLATION_EPSILON_RAD`]).
    pub limit_violation_epsilon_rad: f32,
    /// Fewest limbs in contact in any frame (issue: ≥ 2).
    pub min_limbs_in_contact: u32,
    /// Deepest body/support penetration, metres (issue: ≤ 1 cm).
    pub max_penetration_m: f32,
    /// Most frames with the head below the hips while on a trunk (0: head-up only).
    pub max_head_below_hips_on_trunk_frames: u64,
    /// Most frames with a NaN/inf value (issue: 0).
    pub max_nan_count: u64,
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances {
            goal_tolerance_m: 0.3,
            max_grip_slip_m: 0.005,
            max_surface_gap_m: 0.01,
            max_reach_ratio: 1.0,
            max_joint_limit_violations: 0,
            limit_violation_epsilon_rad: LIMIT_VIOLATION_EPSILON_RAD,
            min_limbs_in_contact: 2,
            max_penetration_m: 0.01,
            max_head_below_hips_on_trunk_frames: 0,
            max_nan_count: 0,
        }
    }
}

/// A tolerance looser than the issue allows, or not a usable number.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("tolerance `{field}` = {value} is not allowed: {allowed}")]
pub struct ToleranceError {
    /// The field name (as in the serialised form).
    pub field: &'static str,
    /// The offending value.
    pub value: f64,
    /// What is allowed.
    pub allowed: String,
}

impl Tolerances {
    /// The issue's limits (= `Default`), the loosest allowed.
    pub fn issue_limits() -> Self {
        Tolerances::default()
    }

    /// Checks every limit is a finite number no looser than the issue's
    /// ([`Tolerances::issue_limits`]); `goal_tolerance_m` must be > 0 and
    /// `limit_violation_epsilon_rad` in 0..=1e-4. Tighter limits are fine.
    pub fn validate(&self) -> Result<(), ToleranceError> {
        let issue = Tolerances::issue_limits();
        let upper = |field: &'static str, value: f32, max: f32| {
            if value.is_finite() && value >= 0.0 && value <= max {
                Ok(())
            } else {
                Err(ToleranceError {
                    field,
                    value: value as f64,
                    allowed: format!("0..={max}"),
                })
            }
        };
        upper(
            "max_grip_slip_m",
            self.max_grip_slip_m,
            issue.max_grip_slip_m,
        )?;
        upper(
            "max_surface_gap_m",
            self.max_surface_gap_m,
            issue.max_surface_gap_m,
        )?;
        upper(
            "max_reach_ratio",
            self.max_reach_ratio,
            issue.max_reach_ratio,
        )?;
        upper(
            "limit_violation_epsilon_rad",
            self.limit_violation_epsilon_rad,
            issue.limit_violation_epsilon_rad,
        )?;
        upper(
            "max_penetration_m",
            self.max_penetration_m,
            issue.max_penetration_m,
        )?;
        let count = |field: &'static str, value: u64, max: u64| {
            if value <= max {
                Ok(())
            } else {
                Err(ToleranceError {
                    field,
                    value: value as f64,
                    allowed: format!("0..={max}"),
                })
            }
        };
        count(
            "max_joint_limit_violations",
            self.max_joint_limit_violations,
            issue.max_joint_limit_violations,
        )?;
        count(
            "max_head_below_hips_on_trunk_frames",
            self.max_head_below_hips_on_trunk_frames,
            issue.max_head_below_hips_on_trunk_frames,
        )?;
        count("max_nan_count", self.max_nan_count, issue.max_nan_count)?;
        if !(issue.min_limbs_in_contact..=4).contains(&self.min_limbs_in_contact) {
            return Err(ToleranceError {
                field: "min_limbs_in_contact",
                value: self.min_limbs_in_contact as f64,
                allowed: format!("{}..=4", issue.min_limbs_in_contact),
            });
        }
        if !(self.goal_tolerance_m.is_finite() && self.goal_tolerance_m > 0.0) {
            return Err(ToleranceError {
                field: "goal_tolerance_m",
                value: self.goal_tolerance_m as f64,
                allowed: "a finite distance > 0".to_string(),
            });
        }
        Ok(())
    }
}

/// True when every float of the observation is finite and every
/// `limb_length` is > 0. (`has_nan` is not looked at.)
///
/// Asked twice a sloth-frame (the judge and the gait statistics), so without
/// a branch a value: `x * 0.0` is ±0 for a finite `x` and NaN for an
/// infinite or NaN one, and a sum of zeros is zero while one NaN makes it NaN
/// (the answer of testing each value, `observation_is_finite_by_value`).
pub fn observation_is_finite(obs: &SlothObservation) -> bool {
    let mut zero = 0.0f32;
    let mut add = |xs: &[f32]| {
        for &x in xs {
            zero += x * 0.0;
        }
    };
    add(&[obs.time_s, obs.penetration_m, obs.goal_distance_m]);
    add(&obs.body_pos.to_array());
    add(&obs.body_rot.to_array());
    add(&obs.head_ws.to_array());
    add(&obs.hips_ws.to_array());
    let mut lengths_ok = true;
    for l in &obs.limbs {
        add(&l.grip_ws.to_array());
        add(&l.effector_ws.to_array());
        add(&l.root_ws.to_array());
        add(&[l.limb_length, l.surface_gap, l.limit_violation]);
        lengths_ok &= l.limb_length > 0.0;
    }
    zero == 0.0 && lengths_ok
}

/// [`observation_is_finite`] value by value (the reference for its tests).
#[cfg(test)]
pub(crate) fn observation_is_finite_by_value(obs: &SlothObservation) -> bool {
    let v = |v: Vec3| v.is_finite();
    let q = |q: glam::Quat| q.is_finite();
    let limb_ok = |l: &slothsim_gait::observe::LimbObservation| {
        v(l.grip_ws)
            && v(l.effector_ws)
            && v(l.root_ws)
            && l.limb_length.is_finite()
            && l.limb_length > 0.0
            && l.surface_gap.is_finite()
            && l.limit_violation.is_finite()
    };
    obs.time_s.is_finite()
        && v(obs.body_pos)
        && q(obs.body_rot)
        && v(obs.head_ws)
        && v(obs.hips_ws)
        && obs.penetration_m.is_finite()
        && obs.goal_distance_m.is_finite()
        && obs.limbs.iter().all(limb_ok)
}

/// Where (frame time) and on which limb a worst value was seen.
#[derive(Clone, Copy, Debug, PartialEq)]
struct At {
    time_s: f32,
    limb: Option<Limb>,
}

impl At {
    fn report(self) -> MeasureAt {
        MeasureAt {
            time_s: self.time_s,
            limb: self.limb.map(|l| l.name().to_string()),
        }
    }
}

/// Streaming judge of one sloth's run. See the module docs.
#[derive(Clone, Debug)]
pub struct Judge {
    tolerances: Tolerances,
    time_limit_s: f32,

    frames: u64,
    last_time_s: f32,
    goal_time_s: Option<f32>,
    min_goal_distance_m: Option<f32>,

    max_grip_slip_m: f32,
    max_surface_gap_m: f32,
    max_reach_ratio: f32,
    joint_limit_violations: u64,
    max_limit_violation_rad: f32,
    min_limbs_in_contact: Option<u32>,
    max_penetration_m: f32,
    head_below_hips_on_trunk_frames: u64,
    nan_count: u64,
    max_residual_bw: f32,

    worst: [Option<At>; WORST_COUNT],

    /// The previous finite frame's limbs (for grip slip).
    prev: Option<[HeldGrip; 4]>,
}

/// A limb's state kept from the previous frame for the grip-slip measure.
#[derive(Clone, Copy, Debug, Default)]
struct HeldGrip {
    planted: bool,
    grip_ws: Vec3,
    /// Where the grip was when this stance was first seen.
    anchor_ws: Vec3,
}

// Indices into `Judge::worst` (same order as `JudgeWorst`'s fields).
const W_GRIP_SLIP: usize = 0;
const W_SURFACE_GAP: usize = 1;
const W_REACH: usize = 2;
const W_LIMIT: usize = 3;
const W_CONTACT: usize = 4;
const W_PENETRATION: usize = 5;
const W_HEAD: usize = 6;
const W_NAN: usize = 7;
const W_RESIDUAL: usize = 8;
const WORST_COUNT: usize = 9;

impl Judge {
    /// A judge for a run that must reach its goal within `time_limit_s`
    /// (simulation clock; a non-finite limit never fails the time check).
    pub fn new(tolerances: Tolerances, time_limit_s: f32) -> Self {
        Judge {
            tolerances,
            time_limit_s,
            frames: 0,
            last_time_s: 0.0,
            goal_time_s: None,
            min_goal_distance_m: None,
            max_grip_slip_m: 0.0,
            max_surface_gap_m: 0.0,
            max_reach_ratio: 0.0,
            joint_limit_violations: 0,
            max_limit_violation_rad: 0.0,
            min_limbs_in_contact: None,
            max_penetration_m: 0.0,
            head_below_hips_on_trunk_frames: 0,
            nan_count: 0,
            max_residual_bw: 0.0,
            worst: [None; WORST_COUNT],
            prev: None,
        }
    }

    /// The tolerances this judge was built with.
    pub fn tolerances(&self) -> &Tolerances {
        &self.tolerances
    }

    /// The goal time limit, seconds.
    pub fn time_limit_s(&self) -> f32 {
        self.time_limit_s
    }

    /// Takes one frame into account. Constant time, no allocation.
    pub fn observe(&mut self, obs: &SlothObservation) {
        self.frames += 1;
        let finite = observation_is_finite(obs);
        if obs.has_nan || !finite {
            self.nan_count += 1;
            if self.worst[W_NAN].is_none() {
                self.worst[W_NAN] = Some(At {
                    time_s: obs.time_s,
                    limb: None,
                });
            }
        }
        if !finite {
            // Nothing else can be trusted in this frame; restart grip tracking.
            self.prev = None;
            return;
        }
        let t = obs.time_s;
        self.last_time_s = t;

        self.measure_goal(obs);
        self.measure_limbs(obs);
        self.measure_body(obs);

        let mut held = [HeldGrip::default(); 4];
        for (i, (h, l)) in held.iter_mut().zip(&obs.limbs).enumerate() {
            let anchor_ws = match &self.prev {
                Some(prev) if prev[i].planted && l.planted => prev[i].anchor_ws,
                _ => l.grip_ws,
            };
            *h = HeldGrip {
                planted: l.planted,
                grip_ws: l.grip_ws,
                anchor_ws,
            };
        }
        self.prev = Some(held);
    }

    fn measure_goal(&mut self, obs: &SlothObservation) {
        let d = obs.goal_distance_m;
        self.min_goal_distance_m = Some(self.min_goal_distance_m.map_or(d, |m| m.min(d)));
        if self.goal_time_s.is_none() && obs.goal_held && d <= self.tolerances.goal_tolerance_m {
            self.goal_time_s = Some(obs.time_s);
        }
    }

    fn measure_limbs(&mut self, obs: &SlothObservation) {
        let t = obs.time_s;
        let eps = self.tolerances.limit_violation_epsilon_rad;
        for limb in Limb::ALL {
            let l = obs.limb(limb);
            let at = Some(At {
                time_s: t,
                limb: Some(limb),
            });

            // Grip slip: only for a limb planted in this and the previous frame.
            if let Some(prev) = &self.prev {
                let held = prev[limb.index()];
                if held.planted && l.planted {
                    let ik_error = l.effector_ws.distance(l.grip_ws);
                    let grip_moved = l.grip_ws.distance(held.grip_ws);
                    let grip_slid = l.grip_ws.distance(held.anchor_ws);
                    let slip = ik_error.max(grip_moved).max(grip_slid);
                    if slip > self.max_grip_slip_m {
                        self.max_grip_slip_m = slip;
                        self.worst[W_GRIP_SLIP] = at;
                    }
                }
            }

            if l.planted {
                let gap = l.surface_gap.abs();
                if gap > self.max_surface_gap_m {
                    self.max_surface_gap_m = gap;
                    self.worst[W_SURFACE_GAP] = at;
                }
            }

            let reach = l.effector_ws.distance(l.root_ws) / l.limb_length;
            if reach > self.max_reach_ratio {
                self.max_reach_ratio = reach;
                self.worst[W_REACH] = at;
            }

            if l.limit_violation > eps {
                self.joint_limit_violations += 1;
            }
            if l.limit_violation > self.max_limit_violation_rad {
                self.max_limit_violation_rad = l.limit_violation;
                self.worst[W_LIMIT] = at;
            }
        }
    }

    fn measure_body(&mut self, obs: &SlothObservation) {
        let at = Some(At {
            time_s: obs.time_s,
            limb: None,
        });
        let contact = obs.limbs_in_contact() as u32;
        if self.min_limbs_in_contact.is_none_or(|m| contact < m) {
            self.min_limbs_in_contact = Some(contact);
            self.worst[W_CONTACT] = at;
        }
        if obs.penetration_m > self.max_penetration_m {
            self.max_penetration_m = obs.penetration_m;
            self.worst[W_PENETRATION] = at;
        }
        if obs.residual_bw > self.max_residual_bw {
            self.max_residual_bw = obs.residual_bw;
            self.worst[W_RESIDUAL] = at;
        }
        if obs.on_trunk && obs.head_ws.y < obs.hips_ws.y {
            self.head_below_hips_on_trunk_frames += 1;
            if self.worst[W_HEAD].is_none() {
                self.worst[W_HEAD] = at;
            }
        }
    }

    /// The report so far (the judge can keep observing afterwards).
    pub fn finish(&self) -> JudgeReport {
        let w = |i: usize| self.worst[i].map(At::report);
        JudgeReport {
            sloths: 1,
            frames: self.frames,
            duration_s: self.last_time_s,
            time_limit_s: self.time_limit_s,
            goal_reached: self.goal_time_s.is_some(),
            goal_time_s: self.goal_time_s,
            min_goal_distance_m: self.min_goal_distance_m,
            goal_tolerance_m: self.tolerances.goal_tolerance_m,
            max_grip_slip_m: self.max_grip_slip_m,
            max_surface_gap_m: self.max_surface_gap_m,
            max_reach_ratio: self.max_reach_ratio,
            joint_limit_violations: self.joint_limit_violations,
            max_limit_violation_rad: self.max_limit_violation_rad,
            min_limbs_in_contact: self.min_limbs_in_contact.unwrap_or(0),
            max_penetration_m: self.max_penetration_m,
            head_below_hips_on_trunk_frames: self.head_below_hips_on_trunk_frames,
            nan_count: self.nan_count,
            max_residual_bw: self.max_residual_bw,
            worst: JudgeWorst {
                max_grip_slip_m: w(W_GRIP_SLIP),
                max_surface_gap_m: w(W_SURFACE_GAP),
                max_reach_ratio: w(W_REACH),
                max_limit_violation_rad: w(W_LIMIT),
                min_limbs_in_contact: w(W_CONTACT),
                max_penetration_m: w(W_PENETRATION),
                head_below_hips_on_trunk_frames: w(W_HEAD),
                nan_count: w(W_NAN),
                max_residual_bw: w(W_RESIDUAL),
            },
        }
    }
}

/// When (and on which limb, if a limb measure) a worst value was first seen.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MeasureAt {
    /// Frame time, seconds.
    pub time_s: f32,
    /// `"LF"`, `"RF"`, `"LH"`, `"RH"`, or absent for a body measure.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub limb: Option<String>,
}

/// Where each worst value of a [`JudgeReport`] happened (`None`: never, e.g.
/// no slip at all). Head-below-hips and NaN give their first frame.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct JudgeWorst {
    /// Frame/limb of `max_grip_slip_m`.
    pub max_grip_slip_m: Option<MeasureAt>,
    /// Frame/limb of `max_surface_gap_m`.
    pub max_surface_gap_m: Option<MeasureAt>,
    /// Frame/limb of `max_reach_ratio`.
    pub max_reach_ratio: Option<MeasureAt>,
    /// Frame/limb of `max_limit_violation_rad`.
    pub max_limit_violation_rad: Option<MeasureAt>,
    /// Frame of `min_limbs_in_contact`.
    pub min_limbs_in_contact: Option<MeasureAt>,
    /// Frame of `max_penetration_m`.
    pub max_penetration_m: Option<MeasureAt>,
    /// First frame with the head below the hips on a trunk.
    pub head_below_hips_on_trunk_frames: Option<MeasureAt>,
    /// First frame with a NaN.
    pub nan_count: Option<MeasureAt>,
    /// Frame of `max_residual_bw`.
    #[serde(default)]
    pub max_residual_bw: Option<MeasureAt>,
}

/// What the judge measured over a run (or, merged, over a crowd).
///
/// JSON keys are the field names. Maxima start at 0 (nothing measured yet).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JudgeReport {
    /// Sloths this report covers (1 for one run; a crowd after [`JudgeReport::merge`]).
    pub sloths: u32,
    /// Frames observed (summed over sloths when merged).
    pub frames: u64,
    /// Simulation time of the last finite frame, seconds (clock starts at 0).
    pub duration_s: f32,
    /// The goal had to be reached by this time, seconds.
    pub time_limit_s: f32,
    /// Some frame had `goal_distance_m` ≤ `goal_tolerance_m` (at any time;
    /// the verdict also checks `goal_time_s` ≤ `time_limit_s`). Merged: every sloth.
    pub goal_reached: bool,
    /// Time of the first such frame. Merged: the latest arrival, if all arrived.
    pub goal_time_s: Option<f32>,
    /// Closest approach to the goal, metres (`None` without frames). Merged: the farthest sloth's.
    pub min_goal_distance_m: Option<f32>,
    /// The goal tolerance used, metres.
    pub goal_tolerance_m: f32,
    /// Largest planted-grip slip, metres: for a limb planted in the previous
    /// and the current frame, max of |effector − grip| (IK error at a held
    /// grip), the grip's movement since the previous frame, and its movement
    /// since the stance began (so a slow slide adds up).
    pub max_grip_slip_m: f32,
    /// Largest `surface_gap` of a planted limb, metres.
    pub max_surface_gap_m: f32,
    /// Largest |effector − root| / limb_length over all limbs and frames.
    pub max_reach_ratio: f32,
    /// Count of (frame, limb) with `limit_violation` > the epsilon.
    pub joint_limit_violations: u64,
    /// Largest `limit_violation`, radians.
    pub max_limit_violation_rad: f32,
    /// Fewest planted limbs in any frame (0 without frames).
    pub min_limbs_in_contact: u32,
    /// Deepest body/support penetration, metres.
    pub max_penetration_m: f32,
    /// Frames with `on_trunk` and the head lower (y) than the hips.
    pub head_below_hips_on_trunk_frames: u64,
    /// Frames with `has_nan` or a non-finite value.
    pub nan_count: u64,
    /// Largest residual wrench of the grip loads, body weights (issue 22): how far the
    /// kinematic motion was from what the holding claws can carry. Reported, not judged.
    #[serde(default)]
    pub max_residual_bw: f32,
    /// Where the worst values happened.
    #[serde(default)]
    pub worst: JudgeWorst,
}

/// Pass/fail and why.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Verdict {
    /// No failures.
    pub pass: bool,
    /// One line per failed measure: name, value, limit (e.g.
    /// `"max_grip_slip_m 0.0071 > 0.005 (LF at t=3.2 s)"`).
    pub failures: Vec<String>,
}

/// Formats a measured float with up to 6 decimals, trailing zeros removed.
fn num(v: f32) -> String {
    let s = format!("{v:.6}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s.is_empty() || s == "-" || s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

fn with_at(mut msg: String, at: &Option<MeasureAt>) -> String {
    if let Some(at) = at {
        match &at.limb {
            Some(limb) => write!(msg, " ({limb} at t={} s)", num(at.time_s)),
            None => write!(msg, " (at t={} s)", num(at.time_s)),
        }
        .expect("writing to a String cannot fail");
    }
    msg
}

impl JudgeReport {
    /// Decides pass/fail against `tol` (the goal tolerance of the report's
    /// own judge decided `goal_reached`; `tol.goal_tolerance_m` is not
    /// re-applied). A value equal to its limit passes.
    pub fn verdict(&self, tol: &Tolerances) -> Verdict {
        let mut failures = Vec::new();
        let w = &self.worst;
        if self.frames == 0 {
            failures.push("frames 0: nothing observed".to_string());
        }
        match self.goal_time_s {
            None => failures.push(match self.min_goal_distance_m {
                Some(d) if d <= self.goal_tolerance_m => format!(
                    "goal_reached false: within {} of the goal (min_goal_distance_m {}) but never with all four limbs on the goal's support",
                    num(self.goal_tolerance_m),
                    num(d)
                ),
                Some(d) => format!(
                    "goal_reached false: goal not reached (min_goal_distance_m {} > {})",
                    num(d),
                    num(self.goal_tolerance_m)
                ),
                None => "goal_reached false: goal not reached".to_string(),
            }),
            Some(t) if t > self.time_limit_s => failures.push(format!(
                "goal_time_s {} > time_limit_s {}: goal not reached in time",
                num(t),
                num(self.time_limit_s)
            )),
            Some(_) => {}
        }
        if !self.goal_reached && self.goal_time_s.is_some() {
            // Inconsistent merged/edited report: be strict.
            failures.push("goal_reached false: goal not reached".to_string());
        }
        let mut upper = |name: &str, value: f32, max: f32, at: &Option<MeasureAt>| {
            if value.is_nan() || value > max {
                failures.push(with_at(format!("{name} {} > {}", num(value), num(max)), at));
            }
        };
        upper(
            "max_grip_slip_m",
            self.max_grip_slip_m,
            tol.max_grip_slip_m,
            &w.max_grip_slip_m,
        );
        upper(
            "max_surface_gap_m",
            self.max_surface_gap_m,
            tol.max_surface_gap_m,
            &w.max_surface_gap_m,
        );
        upper(
            "max_reach_ratio",
            self.max_reach_ratio,
            tol.max_reach_ratio,
            &w.max_reach_ratio,
        );
        upper(
            "max_penetration_m",
            self.max_penetration_m,
            tol.max_penetration_m,
            &w.max_penetration_m,
        );
        if self.joint_limit_violations > tol.max_joint_limit_violations {
            failures.push(with_at(
                format!(
                    "joint_limit_violations {} > {} (max_limit_violation_rad {})",
                    self.joint_limit_violations,
                    tol.max_joint_limit_violations,
                    num(self.max_limit_violation_rad)
                ),
                &w.max_limit_violation_rad,
            ));
        }
        if self.frames > 0 && self.min_limbs_in_contact < tol.min_limbs_in_contact {
            failures.push(with_at(
                format!(
                    "min_limbs_in_contact {} < {}",
                    self.min_limbs_in_contact, tol.min_limbs_in_contact
                ),
                &w.min_limbs_in_contact,
            ));
        }
        if self.head_below_hips_on_trunk_frames > tol.max_head_below_hips_on_trunk_frames {
            failures.push(with_at(
                format!(
                    "head_below_hips_on_trunk_frames {} > {}",
                    self.head_below_hips_on_trunk_frames, tol.max_head_below_hips_on_trunk_frames
                ),
                &w.head_below_hips_on_trunk_frames,
            ));
        }
        if self.nan_count > tol.max_nan_count {
            failures.push(with_at(
                format!("nan_count {} > {}", self.nan_count, tol.max_nan_count),
                &w.nan_count,
            ));
        }
        Verdict {
            pass: failures.is_empty(),
            failures,
        }
    }

    /// One report for a crowd, folding with [`JudgeReport::merge`]; `None` if
    /// there are no reports.
    pub fn aggregate<'a>(reports: impl IntoIterator<Item = &'a JudgeReport>) -> Option<Self> {
        let mut it = reports.into_iter();
        let mut crowd = it.next()?.clone();
        for r in it {
            crowd.merge(r);
        }
        Some(crowd)
    }

    /// Folds `other` into `self` for a crowd: worst values win (max of
    /// maxima, min of minima, sums of counts and frames); the goal counts as
    /// reached only if every sloth reached it, at the latest arrival time;
    /// `min_goal_distance_m` becomes the farthest sloth's closest approach;
    /// `duration_s`, `time_limit_s` and `goal_tolerance_m` take the max.
    /// A report with 0 sloths is the identity.
    pub fn merge(&mut self, other: &JudgeReport) {
        if other.sloths == 0 {
            return;
        }
        if self.sloths == 0 {
            *self = other.clone();
            return;
        }
        fn worse_max(a: &mut f32, a_at: &mut Option<MeasureAt>, b: f32, b_at: &Option<MeasureAt>) {
            if b > *a {
                *a = b;
                *a_at = b_at.clone();
            }
        }
        let w = &other.worst;
        self.sloths += other.sloths;
        self.duration_s = self.duration_s.max(other.duration_s);
        self.time_limit_s = self.time_limit_s.max(other.time_limit_s);
        self.goal_tolerance_m = self.goal_tolerance_m.max(other.goal_tolerance_m);
        self.goal_reached &= other.goal_reached;
        self.goal_time_s = match (self.goal_time_s, other.goal_time_s) {
            (Some(a), Some(b)) if self.goal_reached => Some(a.max(b)),
            _ => None,
        };
        self.min_goal_distance_m = match (self.min_goal_distance_m, other.min_goal_distance_m) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        worse_max(
            &mut self.max_grip_slip_m,
            &mut self.worst.max_grip_slip_m,
            other.max_grip_slip_m,
            &w.max_grip_slip_m,
        );
        worse_max(
            &mut self.max_surface_gap_m,
            &mut self.worst.max_surface_gap_m,
            other.max_surface_gap_m,
            &w.max_surface_gap_m,
        );
        worse_max(
            &mut self.max_reach_ratio,
            &mut self.worst.max_reach_ratio,
            other.max_reach_ratio,
            &w.max_reach_ratio,
        );
        worse_max(
            &mut self.max_limit_violation_rad,
            &mut self.worst.max_limit_violation_rad,
            other.max_limit_violation_rad,
            &w.max_limit_violation_rad,
        );
        worse_max(
            &mut self.max_penetration_m,
            &mut self.worst.max_penetration_m,
            other.max_penetration_m,
            &w.max_penetration_m,
        );
        worse_max(
            &mut self.max_residual_bw,
            &mut self.worst.max_residual_bw,
            other.max_residual_bw,
            &w.max_residual_bw,
        );
        self.joint_limit_violations += other.joint_limit_violations;
        if other.frames > 0
            && (self.frames == 0 || other.min_limbs_in_contact < self.min_limbs_in_contact)
        {
            self.min_limbs_in_contact = other.min_limbs_in_contact;
            self.worst.min_limbs_in_contact = w.min_limbs_in_contact.clone();
        }
        self.frames += other.frames;
        self.head_below_hips_on_trunk_frames += other.head_below_hips_on_trunk_frames;
        if self.worst.head_below_hips_on_trunk_frames.is_none() {
            self.worst.head_below_hips_on_trunk_frames = w.head_below_hips_on_trunk_frames.clone();
        }
        self.nan_count += other.nan_count;
        if self.worst.nan_count.is_none() {
            self.worst.nan_count = w.nan_count.clone();
        }
    }
}

#[cfg(test)]
mod tests;
