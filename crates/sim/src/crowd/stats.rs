//! What a crowd run reports: every sloth's [`Observer`] (its judge and gait
//! statistics, fed after each tick outside the timed stages) and the crowd
//! statistics folded from them ([`CrowdStats`], the content of `stats.json`).

use bevy_ecs::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;

use slothsim_gait::{LimbLoads, ObserveMemo, SlothObservation, StuckCause};
use slothsim_observe::{GaitReport, GaitStats, Judge, JudgeReport, Tolerances};
use slothsim_scene::{SupportId, SupportKind};

use super::Crowd;
use crate::grip_stats::{GripLoadReport, GripLoadStats, ReleaseCounts};
use crate::world::{Locomotion, SlothId, SlothState};

/// A sloth that has not completed a step for this long at the end of a run is stuck.
pub const STUCK_AFTER_S: f32 = 10.0;

/// A wanderer that has turned back this many times since its body last
/// travelled a max step (`Sloth::stall_from`) is *stalled in place* at the
/// end of a run, whether or not it still steps: the stuck count's step
/// clock ([`STUCK_AFTER_S`]) misses the sloths that re-grip a few
/// centimetres between turn-backs (traced in the 5,000-sloth crowds: wanderers
/// straddling two branches at a junction, about 40 s or more in place).
pub const STALLED_TURNS: u8 = 8;

/// The judge of a wandering sloth: the issue's limits, no time limit (a
/// wanderer has no goal to reach in time).
pub(super) fn crowd_judge() -> Judge {
    Judge::new(Tolerances::issue_limits(), f32::INFINITY)
}

/// Per-sloth judge and gait statistics, fed after every tick (outside the
/// timed stages), and what the crowd statistics count besides.
#[derive(Component)]
pub struct Observer {
    judge: Judge,
    stats: GaitStats,
    /// Every frame's observation, when kept (a lone sloth's scenario run
    /// keeps them for its steady-state statistics and plots; a crowd does not).
    history: Option<Vec<SlothObservation>>,
    planted: [bool; 4],
    /// Simulated time of the last touch-down.
    last_step_s: f32,
    /// Distinct supports a limb of this sloth was planted on, in order of first visit.
    visited: Vec<SupportId>,
    /// Frames on a trunk.
    trunk_frames: u64,
    /// Frames observed.
    frames: u64,
    /// Changes between branch and trunk (the body's `on_trunk` flips).
    kind_changes: u32,
    /// `on_trunk` of the last frame.
    on_trunk: Option<bool>,
    /// Grip loads (issue 22).
    loads: GripLoadStats,
    /// Every frame's grip loads with its time, when the history is kept.
    load_history: Option<Vec<(f32, LimbLoads)>>,
    /// The sloth's observation's dearest measures as last computed
    /// ([`Sloth::observe_memo`](slothsim_gait::Sloth::observe_memo)).
    pub(super) memo: ObserveMemo,
}

impl Observer {
    /// An observer judging with `judge`, of a sloth whose clock reads
    /// `time_s`; it keeps every observation when `keep_history`.
    pub(super) fn new(judge: Judge, time_s: f32, keep_history: bool) -> Self {
        Observer {
            judge,
            stats: GaitStats::new(),
            history: keep_history.then(Vec::new),
            planted: [true; 4],
            last_step_s: time_s,
            visited: Vec::new(),
            trunk_frames: 0,
            frames: 0,
            kind_changes: 0,
            on_trunk: None,
            loads: GripLoadStats::new(),
            load_history: keep_history.then(Vec::new),
            memo: ObserveMemo::default(),
        }
    }

    /// This frame's grip loads (after [`Observer::observe`] of the same frame);
    /// `release_bw` is the release rule's threshold.
    pub(super) fn observe_loads(&mut self, time_s: f32, loads: &LimbLoads, release_bw: f32) {
        self.loads.observe(loads, release_bw);
        if let Some(h) = &mut self.load_history {
            h.push((time_s, *loads));
        }
    }

    /// The grip-load statistics so far.
    pub fn loads(&self) -> &GripLoadStats {
        &self.loads
    }

    /// Every frame's grip loads with its time, oldest first (empty unless kept).
    pub fn load_history(&self) -> &[(f32, LimbLoads)] {
        self.load_history.as_deref().unwrap_or_default()
    }

    pub(super) fn observe(&mut self, obs: &SlothObservation) {
        self.judge.observe(obs);
        self.stats.observe(obs);
        if let Some(h) = &mut self.history {
            h.push(*obs);
        }
        for (i, l) in obs.limbs.iter().enumerate() {
            if l.planted && !self.planted[i] {
                self.last_step_s = obs.time_s;
            }
            self.planted[i] = l.planted;
            // A short list (a sloth holds a few dozen supports in a long run).
            if l.planted && !self.visited.contains(&l.support) {
                self.visited.push(l.support);
            }
        }
        self.frames += 1;
        self.trunk_frames += u64::from(obs.on_trunk);
        if self.on_trunk.is_some_and(|t| t != obs.on_trunk) {
            self.kind_changes += 1;
        }
        self.on_trunk = Some(obs.on_trunk);
    }

    /// The judge so far.
    pub fn judge(&self) -> &Judge {
        &self.judge
    }

    /// The gait statistics so far.
    pub fn gait(&self) -> &GaitStats {
        &self.stats
    }

    /// Every frame's observation, oldest first (empty unless kept).
    pub fn history(&self) -> &[SlothObservation] {
        self.history.as_deref().unwrap_or_default()
    }
}

/// Statistics of a crowd run (the content of `stats.json`).
#[derive(Clone, Debug, Serialize)]
pub struct CrowdStats {
    /// Sloths.
    pub sloths: u32,
    /// Frames simulated in this run (a resumed run counts its own).
    pub frames: u64,
    /// Time step (s).
    pub dt: f32,
    /// Simulated time at the end (s), including any resumed part.
    pub time_s: f32,
    /// Worker threads of the compute pool.
    pub threads: usize,
    /// Seed.
    pub seed: u64,
    /// Hash of the final state (hex), see [`Crowd::state_hash`].
    pub state_hash: String,
    /// Mean body speed over all sloths (m/s).
    pub speed_mps_mean: f32,
    /// Frame time (ms): p50, p95, max.
    pub frame_ms: Percentiles,
    /// Per stage p50/p95 (ms).
    pub stages_ms: StagesMs,
    /// Judge/statistics pass per frame, outside the stages (ms): p50, p95, max.
    pub observe_ms: Percentiles,
    /// Traces per frame (mean).
    pub traces_per_frame_mean: f64,
    /// Per-limb gait statistics over the crowd.
    pub gait: GaitReport,
    /// Judge measures over the crowd (worst sloth).
    pub max_grip_slip_m: f32,
    /// Largest grip ↔ surface distance of a planted limb.
    pub max_surface_gap_m: f32,
    /// Largest root → effector distance over limb length.
    pub max_reach_ratio: f32,
    /// Frames × limbs outside a joint limit.
    pub joint_limit_violations: u64,
    /// Fewest limbs in contact of any sloth at any frame.
    pub min_limbs_in_contact: u32,
    /// Deepest body/support penetration.
    pub max_penetration_m: f32,
    /// Frames where a sloth on a trunk had its head below its hips.
    pub head_below_hips_on_trunk_frames: u64,
    /// Non-finite values seen.
    pub nan_count: u64,
    /// Sloths that completed no step in the last [`STUCK_AFTER_S`] s.
    pub stuck_sloths: u32,
    /// Ids of the stuck sloths (first 100).
    pub stuck_ids: Vec<u32>,
    /// The stuck sloths by cause (see [`StuckReport`]).
    pub stuck: StuckReport,
    /// Times sloths turned back (dead ends or blocked), summed.
    pub turn_backs: u64,
    /// How much of the forest the crowd roamed in this run.
    pub roaming: Roaming,
    /// Which sloth holds the worst value of each measure (id), for follow-up.
    pub worst_sloths: WorstSloths,
    /// Grip loads over the crowd (issue 22).
    pub grip_load: GripLoadReport,
    /// The full judge report over the crowd.
    pub judge: JudgeReport,
}

/// Stuck sloths (no step completed in the last [`STUCK_AFTER_S`] s) by
/// the cause their step search last gave up with ([`StuckCause`]); a stuck
/// sloth whose search has not given up since its last step counts as
/// `searching`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct StuckReport {
    /// Stuck sloths.
    pub sloths: u32,
    /// Their share of the crowd (0..1).
    pub share: f32,
    /// Per cause (every cause listed, zero counts included).
    pub by_cause: BTreeMap<&'static str, CauseCount>,
    /// Wanderers stalled in place ([`STALLED_TURNS`]), stuck or not.
    pub stalled_in_place: CauseCount,
    /// The stuck sloths by how long they have stood since their last step
    /// (or since this run began, for a resumed run): `10_15_s` (mostly
    /// pauses the 10 s clock catches), `15_60_s` and `over_60_s` (frozen).
    pub stood: BTreeMap<&'static str, CauseCount>,
}

/// The bands of [`StuckReport::stood`]: name and lower bound in seconds.
pub const STOOD_BANDS: [(&str, f32); 3] =
    [("10_15_s", 0.0), ("15_60_s", 15.0), ("over_60_s", 60.0)];

/// Stuck sloths of one cause.
#[derive(Clone, Debug, Default, Serialize)]
pub struct CauseCount {
    /// How many.
    pub count: u32,
    /// Some of their ids (the lowest, at most [`CAUSE_EXAMPLES`]).
    pub example_ids: Vec<u32>,
}

/// Ids listed per stuck cause.
pub const CAUSE_EXAMPLES: usize = 10;

/// Name of the stuck sloths whose search has not given up (see [`StuckReport`]).
pub const SEARCHING: &str = "searching";

impl StuckReport {
    /// Of `(id, cause, seconds stood)` for every stuck sloth and the ids of
    /// the sloths stalled in place, in id order, among `sloths`.
    pub fn of(stuck: &[(u32, Option<StuckCause>, f32)], stalled: &[u32], sloths: u32) -> Self {
        let mut by_cause: BTreeMap<&'static str, CauseCount> = StuckCause::ALL
            .iter()
            .map(|c| c.name())
            .chain([SEARCHING])
            .map(|n| (n, CauseCount::default()))
            .collect();
        let mut stood: BTreeMap<&'static str, CauseCount> = STOOD_BANDS
            .iter()
            .map(|&(n, _)| (n, CauseCount::default()))
            .collect();
        for &(id, cause, stood_s) in stuck {
            let band = STOOD_BANDS
                .iter()
                .rev()
                .find(|&&(_, from)| stood_s >= from)
                .map_or(STOOD_BANDS[0].0, |&(n, _)| n);
            for e in [
                by_cause
                    .entry(cause.map_or(SEARCHING, StuckCause::name))
                    .or_default(),
                stood.entry(band).or_default(),
            ] {
                e.count += 1;
                if e.example_ids.len() < CAUSE_EXAMPLES {
                    e.example_ids.push(id);
                }
            }
        }
        StuckReport {
            sloths: stuck.len() as u32,
            share: stuck.len() as f32 / sloths.max(1) as f32,
            by_cause,
            stalled_in_place: CauseCount {
                count: stalled.len() as u32,
                example_ids: stalled.iter().copied().take(CAUSE_EXAMPLES).collect(),
            },
            stood,
        }
    }
}

/// How much of the forest a crowd run covered (this run's frames; a resumed
/// run counts its own part).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Roaming {
    /// Supports of the forest.
    pub supports: u32,
    /// Supports some sloth planted a limb on.
    pub supports_visited: u32,
    /// Mean over sloths of the distinct supports each planted a limb on.
    pub supports_per_sloth_mean: f32,
    /// Trunks some sloth planted a limb on.
    pub trunks_climbed: u32,
    /// Share of sloth-frames spent on a trunk.
    pub trunk_frame_share: f32,
    /// Changes between branch and trunk (either way), summed over sloths.
    pub branch_trunk_changes: u64,
    /// Sloths that changed between branch and trunk at least once.
    pub sloths_changing_kind: u32,
}

/// The sloth with the worst value of each judge measure.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct WorstSloths {
    /// Largest grip slip.
    pub max_grip_slip: Option<u32>,
    /// Largest grip ↔ surface gap.
    pub max_surface_gap: Option<u32>,
    /// Largest reach ratio.
    pub max_reach_ratio: Option<u32>,
    /// Deepest penetration.
    pub max_penetration: Option<u32>,
    /// Fewest limbs in contact.
    pub min_limbs_in_contact: Option<u32>,
}

fn worst_by<'a>(
    rows: impl Iterator<Item = (u32, &'a JudgeReport)>,
    key: impl Fn(&JudgeReport) -> f32,
) -> Option<u32> {
    rows.max_by(|a, b| key(a.1).total_cmp(&key(b.1)).then(b.0.cmp(&a.0)))
        .map(|r| r.0)
}

/// p50 / p95 / max.
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct Percentiles {
    /// Median.
    pub p50: f64,
    /// 95th percentile.
    pub p95: f64,
    /// Maximum.
    pub max: f64,
}

impl Percentiles {
    /// Of `values` (nearest-rank); zeros when empty.
    pub fn of(values: &[f64]) -> Self {
        if values.is_empty() {
            return Percentiles::default();
        }
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let at = |q: f64| slothsim_scene::percentile_sorted(&v, q).unwrap_or(0.0);
        Percentiles {
            p50: at(0.5),
            p95: at(0.95),
            max: v[v.len() - 1],
        }
    }
}

/// Per stage p50/p95 (ms).
#[derive(Clone, Copy, Debug, Default, Serialize)]
pub struct StagesMs {
    /// Trace stage.
    pub trace: Percentiles,
    /// StepSearch stage.
    pub step_search: Percentiles,
    /// BodyAverage stage.
    pub body_average: Percentiles,
    /// CcdSolve stage.
    pub ccd_solve: Percentiles,
    /// GripLoad stage.
    pub grip_load: Percentiles,
    /// Transitions stage (includes rebuilding the neighbour grid).
    pub transitions: Percentiles,
    /// The neighbour grid's rebuild alone (a part of `transitions`).
    pub grid_rebuild: Percentiles,
}

impl StagesMs {
    /// From per-frame stage times (columns in [`StageTimings::NAMES`](crate::StageTimings::NAMES) order)
    /// and per-frame grid rebuild times.
    pub fn of(history: &[[f64; crate::STAGES]], grid: &[f64]) -> Self {
        let col = |i: usize| Percentiles::of(&history.iter().map(|r| r[i]).collect::<Vec<_>>());
        StagesMs {
            trace: col(0),
            step_search: col(1),
            body_average: col(2),
            ccd_solve: col(3),
            grip_load: col(4),
            transitions: col(5),
            grid_rebuild: Percentiles::of(grid),
        }
    }
}

impl Crowd {
    /// Crowd statistics of the run so far.
    pub fn stats(&mut self, threads: usize) -> CrowdStats {
        let frames = self.timings().history.len() as u64;
        let history = self.timings().history.clone();
        let frame_ms: Vec<f64> = history.iter().map(|r| r.iter().sum()).collect();
        let mut q = self.world.query::<(&SlothId, &SlothState, &Observer)>();
        type Row = (
            u32,
            f32,
            u32,
            JudgeReport,
            GaitReport,
            bool,
            Option<StuckCause>,
            bool,
            f32,
        );
        let mut rows: Vec<Row> = q
            .iter(&self.world)
            .map(|(id, s, o)| {
                let stuck = s.0.time - o.last_step_s > STUCK_AFTER_S;
                (
                    id.0,
                    s.0.time,
                    s.0.turns,
                    o.judge.finish(),
                    o.stats.finish(),
                    stuck,
                    s.0.stuck_cause,
                    s.0.wander && s.0.stall_from.is_some_and(|(_, n)| n >= STALLED_TURNS),
                    s.0.time - o.last_step_s,
                )
            })
            .collect();
        rows.sort_unstable_by_key(|r| r.0);
        let judge = JudgeReport::aggregate(rows.iter().map(|r| &r.3))
            .unwrap_or_else(|| crowd_judge().finish());
        let gait = GaitReport::aggregate(rows.iter().map(|r| &r.4));
        let stuck_causes: Vec<(u32, Option<StuckCause>, f32)> = rows
            .iter()
            .filter(|r| r.5)
            .map(|r| (r.0, r.6, r.8))
            .collect();
        let stalled: Vec<u32> = rows.iter().filter(|r| r.7).map(|r| r.0).collect();
        let stuck = StuckReport::of(&stuck_causes, &stalled, rows.len() as u32);
        let stuck_ids: Vec<u32> = stuck_causes.iter().map(|r| r.0).collect();
        let roaming = self.roaming();
        let reports = || rows.iter().map(|r| (r.0, &r.3));
        let worst_sloths = WorstSloths {
            max_grip_slip: worst_by(reports(), |j| j.max_grip_slip_m),
            max_surface_gap: worst_by(reports(), |j| j.max_surface_gap_m),
            max_reach_ratio: worst_by(reports(), |j| j.max_reach_ratio),
            max_penetration: worst_by(reports(), |j| j.max_penetration_m),
            min_limbs_in_contact: worst_by(reports(), |j| -(j.min_limbs_in_contact as f32)),
        };
        let time_s = rows.first().map_or(0.0, |r| r.1);
        let grip_load = {
            let mut q = self.world.query::<(&SlothState, &Observer)>();
            let mut counts = ReleaseCounts::default();
            let mut parts = Vec::new();
            for (s, o) in q.iter(&self.world) {
                counts.add(&s.0.load);
                parts.push(&o.loads);
            }
            GripLoadStats::report(parts, counts)
        };
        let state_hash = format!("{:016x}", self.state_hash());
        CrowdStats {
            sloths: rows.len() as u32,
            frames,
            dt: self.spec.dt,
            time_s,
            threads,
            seed: self.spec.seed,
            state_hash,
            speed_mps_mean: gait.speed_mps_mean,
            frame_ms: Percentiles::of(&frame_ms),
            stages_ms: StagesMs::of(&history, &self.timings().grid_history.clone()),
            observe_ms: Percentiles::of(&self.observe_ms),
            traces_per_frame_mean: self.timings().traces_total as f64 / frames.max(1) as f64,
            max_grip_slip_m: judge.max_grip_slip_m,
            max_surface_gap_m: judge.max_surface_gap_m,
            max_reach_ratio: judge.max_reach_ratio,
            joint_limit_violations: judge.joint_limit_violations,
            min_limbs_in_contact: judge.min_limbs_in_contact,
            max_penetration_m: judge.max_penetration_m,
            head_below_hips_on_trunk_frames: judge.head_below_hips_on_trunk_frames,
            nan_count: judge.nan_count,
            stuck_sloths: stuck_ids.len() as u32,
            stuck_ids: stuck_ids.into_iter().take(100).collect(),
            stuck,
            turn_backs: rows.iter().map(|r| r.2 as u64).sum(),
            roaming,
            worst_sloths,
            gait,
            grip_load,
            judge,
        }
    }

    /// Coverage of the forest by the crowd (see [`Roaming`]).
    fn roaming(&mut self) -> Roaming {
        let scene = self.world.resource::<Locomotion>().traces.scene();
        let n = scene.supports().len();
        let kinds: Vec<SupportKind> = scene.supports().iter().map(|s| s.kind).collect();
        let mut visited = vec![false; n];
        let mut climbed = vec![false; n];
        let mut r = Roaming {
            supports: n as u32,
            ..Roaming::default()
        };
        let (mut frames, mut trunk_frames, mut per_sloth) = (0u64, 0u64, 0u64);
        let mut sloths = 0u32;
        let mut q = self.world.query::<&Observer>();
        for o in q.iter(&self.world) {
            sloths += 1;
            per_sloth += o.visited.len() as u64;
            for &sid in &o.visited {
                visited[sid.0 as usize] = true;
                climbed[sid.0 as usize] = kinds[sid.0 as usize] == SupportKind::Trunk;
            }
            frames += o.frames;
            trunk_frames += o.trunk_frames;
            r.branch_trunk_changes += u64::from(o.kind_changes);
            r.sloths_changing_kind += u32::from(o.kind_changes > 0);
        }
        r.supports_visited = visited.iter().filter(|&&v| v).count() as u32;
        r.trunks_climbed = climbed.iter().filter(|&&v| v).count() as u32;
        r.supports_per_sloth_mean = per_sloth as f32 / sloths.max(1) as f32;
        r.trunk_frame_share = trunk_frames as f32 / frames.max(1) as f32;
        r
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every stuck sloth is counted under its cause (`searching` where the
    /// search has not given up), the stalled ones apart, stuck or not, each
    /// list with its lowest [`CAUSE_EXAMPLES`] ids.
    #[test]
    fn stuck_report_counts_causes_and_stalled_sloths() {
        let stuck: Vec<(u32, Option<StuckCause>, f32)> = (0..30)
            .map(|id| {
                let stood_s = 10.5 + 3.0 * id as f32;
                (id, (id % 3 != 0).then_some(StuckCause::NoGrip), stood_s)
            })
            .collect();
        let stalled: Vec<u32> = (5..50).step_by(2).collect();
        let r = StuckReport::of(&stuck, &stalled, 1000);
        assert_eq!(r.sloths, 30);
        assert!((r.share - 0.03).abs() < 1e-6);
        assert_eq!(r.by_cause[SEARCHING].count, 10);
        assert_eq!(r.by_cause["no_grip"].count, 20);
        assert_eq!(
            r.by_cause["no_grip"].example_ids,
            [1, 2, 4, 5, 7, 8, 10, 11, 13, 14]
        );
        let counted: u32 = r.by_cause.values().map(|c| c.count).sum();
        assert_eq!(counted, 30);
        assert_eq!(r.stalled_in_place.count, stalled.len() as u32);
        assert_eq!(r.stalled_in_place.example_ids, stalled[..CAUSE_EXAMPLES]);
        // Stood 10.5 + 3 id s: ids 0..=1 under 15 s, 2..=16 under 60 s, 17.. over.
        assert_eq!(r.stood["10_15_s"].count, 2);
        assert_eq!(r.stood["15_60_s"].count, 15);
        assert_eq!(r.stood["over_60_s"].count, 13);
        assert_eq!(
            r.stood["over_60_s"].example_ids,
            (17..27).collect::<Vec<_>>()
        );
    }
}
