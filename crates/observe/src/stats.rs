//! Gait statistics (SPEC "The animal": contact, swing, stride, footfall
//! order), measured from the per-frame observations, for comparison with the
//! thesis table.
//!
//! [`GaitStats`] is a streaming accumulator: feed it one [`SlothObservation`]
//! per frame with [`GaitStats::observe`] (constant memory, no allocation),
//! then read a [`GaitReport`] with [`GaitStats::finish`]. Crowds fold their
//! per-sloth reports with [`GaitReport::merge`] / [`GaitReport::aggregate`].
//!
//! Definitions (per limb, from the `planted` flag):
//! - lift-off: planted in the previous frame, not planted now; touch-down:
//!   the reverse. An event's time is the `time_s` of the first frame in the
//!   new state, so durations are exact to one frame step.
//! - contact (stance): touch-down → next lift-off; swing: lift-off → next
//!   touch-down. Only complete phases count (a phase under way at the first
//!   or last frame is not measured).
//! - stride: distance between successive footfalls (the `grip_ws` at
//!   touch-down) of the same limb; a limb planted in the first frame has its
//!   grip there as its first footfall.
//! - duty factor: contact time / (contact + swing) time over complete cycles
//!   (a complete stance followed by its complete swing); without any complete
//!   cycle, the fraction of frames the limb was planted.
//! - speed: **path length** of `body_pos` (sum of frame-to-frame
//!   displacements along the travel, so turns and climbs count in full) over
//!   the observed span (last − first frame time).
//! - footfall order: the first [`FOOTFALL_CAPACITY`] lift-offs; limbs lifting
//!   in the same frame are listed in [`Limb::ALL`] order.
//!
//! Frames with a non-finite value (see [`observation_is_finite`]) are skipped
//! (the judge counts them); the statistics continue from the last good frame.
//! Means with no sample are 0 (their count says so).

use glam::Vec3;
use serde::{Deserialize, Serialize};
use slothsim_rig::Limb;

use crate::judge::observation_is_finite;
use slothsim_gait::observe::SlothObservation;

/// How many lift-offs the footfall order keeps.
pub const FOOTFALL_CAPACITY: usize = 32;

/// Diagonal-sequence (DSDC) footfall order, started at RH: each hind limb is
/// followed by the contralateral fore limb.
pub const DIAGONAL_SEQUENCE: [Limb; 4] = [Limb::RH, Limb::LF, Limb::LH, Limb::RF];

/// Lateral-sequence (LSDC) footfall order, started at RH: each hind limb is
/// followed by the ipsilateral fore limb.
pub const LATERAL_SEQUENCE: [Limb; 4] = [Limb::RH, Limb::RF, Limb::LH, Limb::LF];

/// One value per limb; serialises as a map keyed `LF`, `RF`, `LH`, `RH`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PerLimb<T> {
    /// Left fore.
    #[serde(rename = "LF")]
    pub lf: T,
    /// Right fore.
    #[serde(rename = "RF")]
    pub rf: T,
    /// Left hind.
    #[serde(rename = "LH")]
    pub lh: T,
    /// Right hind.
    #[serde(rename = "RH")]
    pub rh: T,
}

impl<T> PerLimb<T> {
    /// Builds each value from its limb.
    pub fn from_fn(mut f: impl FnMut(Limb) -> T) -> Self {
        PerLimb {
            lf: f(Limb::LF),
            rf: f(Limb::RF),
            lh: f(Limb::LH),
            rh: f(Limb::RH),
        }
    }

    /// The value of `limb`.
    pub fn get(&self, limb: Limb) -> &T {
        match limb {
            Limb::LF => &self.lf,
            Limb::RF => &self.rf,
            Limb::LH => &self.lh,
            Limb::RH => &self.rh,
        }
    }

    /// The value of `limb`, mutable.
    pub fn get_mut(&mut self, limb: Limb) -> &mut T {
        match limb {
            Limb::LF => &mut self.lf,
            Limb::RF => &mut self.rf,
            Limb::LH => &mut self.lh,
            Limb::RH => &mut self.rh,
        }
    }
}

/// Which footfall order a gait follows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FootfallSequence {
    /// Fewer than four distinct limbs lifted in a row: not known.
    #[default]
    Unknown,
    /// DSDC: RH → LF → LH → RF (any rotation).
    Diagonal,
    /// LSDC: RH → RF → LH → LF (any rotation).
    Lateral,
    /// Some other 4-limb order.
    Other,
    /// Merged reports of sloths whose sequences differ.
    Mixed,
}

impl FootfallSequence {
    /// Classifies a dominant 4-limb order (as from [`dominant_sequence`]).
    pub fn classify(sequence: Option<[Limb; 4]>) -> Self {
        match sequence.map(canonical_rotation) {
            None => FootfallSequence::Unknown,
            Some(s) if s == DIAGONAL_SEQUENCE => FootfallSequence::Diagonal,
            Some(s) if s == LATERAL_SEQUENCE => FootfallSequence::Lateral,
            Some(_) => FootfallSequence::Other,
        }
    }
}

/// Rotates a 4-limb cycle so that it starts at RH (unchanged if RH is absent).
pub fn canonical_rotation(seq: [Limb; 4]) -> [Limb; 4] {
    let start = seq.iter().position(|&l| l == Limb::RH).unwrap_or(0);
    std::array::from_fn(|i| seq[(start + i) % 4])
}

/// The repeating 4-limb order of a lift-off sequence: every window of four
/// consecutive lift-offs that holds all four limbs is a candidate cycle;
/// cycles equal up to rotation are the same; the most frequent wins (ties:
/// the first seen). Returned rotated to start at RH; `None` if no window
/// holds all four limbs.
pub fn dominant_sequence(order: &[Limb]) -> Option<[Limb; 4]> {
    // At most 3! = 6 distinct cycles of four limbs.
    let mut tally: [([Limb; 4], u32); 6] = [([Limb::RH; 4], 0); 6];
    let mut distinct = 0;
    for w in order.windows(4) {
        let all_four = Limb::ALL.iter().all(|l| w.contains(l));
        if !all_four {
            continue;
        }
        let cycle = canonical_rotation([w[0], w[1], w[2], w[3]]);
        match tally[..distinct].iter_mut().find(|(c, _)| *c == cycle) {
            Some((_, n)) => *n += 1,
            None => {
                tally[distinct] = (cycle, 1);
                distinct += 1;
            }
        }
    }
    let mut best: Option<([Limb; 4], u32)> = None;
    for &(cycle, n) in &tally[..distinct] {
        if best.is_none_or(|(_, b)| n > b) {
            best = Some((cycle, n));
        }
    }
    best.map(|(cycle, _)| cycle)
}

/// Per-limb streaming state.
#[derive(Clone, Copy, Debug, Default)]
struct LimbTrack {
    planted: bool,
    /// Time of the last lift-off/touch-down; `None` while the current phase
    /// began before the first frame.
    phase_start_s: Option<f32>,
    /// Duration of the stance that ended at the last lift-off, if complete
    /// (pairs with the next complete swing into a cycle).
    last_stance_s: Option<f32>,
    last_footfall_ws: Option<Vec3>,
    contact_sum_s: f64,
    contacts: u32,
    swing_sum_s: f64,
    swings: u32,
    stride_sum_m: f64,
    strides: u32,
    cycle_contact_s: f64,
    cycle_swing_s: f64,
    cycles: u32,
    lift_offs: u32,
    touch_downs: u32,
    planted_frames: u64,
}

impl LimbTrack {
    fn report(&self, frames: u64) -> LimbGaitReport {
        let mean = |sum: f64, n: u32| if n > 0 { (sum / n as f64) as f32 } else { 0.0 };
        let cycle_s = self.cycle_contact_s + self.cycle_swing_s;
        let duty_factor = if self.cycles > 0 && cycle_s > 0.0 {
            (self.cycle_contact_s / cycle_s) as f32
        } else if frames > 0 {
            (self.planted_frames as f64 / frames as f64) as f32
        } else {
            0.0
        };
        LimbGaitReport {
            contact_s_mean: mean(self.contact_sum_s, self.contacts),
            swing_s_mean: mean(self.swing_sum_s, self.swings),
            stride_m_mean: mean(self.stride_sum_m, self.strides),
            duty_factor,
            strides: self.strides,
            contacts: self.contacts,
            swings: self.swings,
            cycles: self.cycles,
            lift_offs: self.lift_offs,
            touch_downs: self.touch_downs,
        }
    }
}

/// Streaming gait statistics of one sloth. See the module docs.
#[derive(Clone, Debug)]
pub struct GaitStats {
    limbs: [LimbTrack; 4],
    frames: u64,
    skipped_frames: u64,
    first_time_s: Option<f32>,
    last_time_s: f32,
    last_body_pos: Option<Vec3>,
    path_length_m: f64,
    footfalls: [Limb; FOOTFALL_CAPACITY],
    footfall_len: usize,
    /// The limbs' phases are being followed (false until the first frame:
    /// then they are only recorded).
    limbs_tracked: bool,
}

impl Default for GaitStats {
    fn default() -> Self {
        GaitStats::new()
    }
}

impl GaitStats {
    /// No frames yet.
    pub fn new() -> Self {
        GaitStats {
            limbs: [LimbTrack::default(); 4],
            frames: 0,
            skipped_frames: 0,
            first_time_s: None,
            last_time_s: 0.0,
            last_body_pos: None,
            path_length_m: 0.0,
            footfalls: [Limb::RH; FOOTFALL_CAPACITY],
            footfall_len: 0,
            limbs_tracked: false,
        }
    }

    /// Statistics from the next frame on, following the limbs from where
    /// these left them: a stance, swing or stride that ends later counts
    /// whole though it began before (a window of a run counts the strides
    /// whose footfalls are in it, the first one included). Time, path and
    /// footfall order start afresh.
    pub fn restarted(&self) -> GaitStats {
        let mut next = GaitStats::new();
        for (n, t) in next.limbs.iter_mut().zip(&self.limbs) {
            n.planted = t.planted;
            n.last_footfall_ws = t.last_footfall_ws;
            n.phase_start_s = t.phase_start_s;
            n.last_stance_s = t.last_stance_s;
        }
        next.limbs_tracked = self.limbs_tracked;
        next
    }

    /// Takes one frame into account. Constant time, no allocation.
    pub fn observe(&mut self, obs: &SlothObservation) {
        if !observation_is_finite(obs) {
            self.skipped_frames += 1;
            return;
        }
        let t = obs.time_s;
        if self.first_time_s.is_none() {
            self.first_time_s = Some(t);
        }
        let first = !self.limbs_tracked;
        self.limbs_tracked = true;
        self.frames += 1;
        self.last_time_s = t;
        if let Some(prev) = self.last_body_pos {
            self.path_length_m += prev.distance(obs.body_pos) as f64;
        }
        self.last_body_pos = Some(obs.body_pos);

        for limb in Limb::ALL {
            let l = obs.limb(limb);
            let track = &mut self.limbs[limb.index()];
            if l.planted {
                track.planted_frames += 1;
            }
            if first {
                track.planted = l.planted;
                if l.planted {
                    track.last_footfall_ws = Some(l.grip_ws);
                }
                continue;
            }
            match (track.planted, l.planted) {
                (true, false) => {
                    // Lift-off: a stance ends.
                    track.lift_offs += 1;
                    track.last_stance_s = track.phase_start_s.map(|start| t - start);
                    if let Some(d) = track.last_stance_s {
                        track.contact_sum_s += d as f64;
                        track.contacts += 1;
                    }
                    track.phase_start_s = Some(t);
                    if self.footfall_len < FOOTFALL_CAPACITY {
                        self.footfalls[self.footfall_len] = limb;
                        self.footfall_len += 1;
                    }
                }
                (false, true) => {
                    // Touch-down: a swing ends, a footfall is placed.
                    track.touch_downs += 1;
                    if let Some(start) = track.phase_start_s {
                        let swing = t - start;
                        track.swing_sum_s += swing as f64;
                        track.swings += 1;
                        if let Some(stance) = track.last_stance_s {
                            track.cycle_contact_s += stance as f64;
                            track.cycle_swing_s += swing as f64;
                            track.cycles += 1;
                        }
                    }
                    track.last_stance_s = None;
                    if let Some(prev) = track.last_footfall_ws {
                        track.stride_sum_m += prev.distance(l.grip_ws) as f64;
                        track.strides += 1;
                    }
                    track.last_footfall_ws = Some(l.grip_ws);
                    track.phase_start_s = Some(t);
                }
                _ => {}
            }
            track.planted = l.planted;
        }
    }

    /// Frames taken into account.
    pub fn frames(&self) -> u64 {
        self.frames
    }

    /// Frames skipped for non-finite values.
    pub fn skipped_frames(&self) -> u64 {
        self.skipped_frames
    }

    /// The first [`FOOTFALL_CAPACITY`] lift-offs, in order.
    pub fn footfall_order(&self) -> &[Limb] {
        &self.footfalls[..self.footfall_len]
    }

    /// The repeating 4-limb lift-off order, rotated to start at RH
    /// (see [`dominant_sequence`]).
    pub fn dominant_sequence(&self) -> Option<[Limb; 4]> {
        dominant_sequence(self.footfall_order())
    }

    /// The dominant order is the diagonal sequence RH → LF → LH → RF.
    pub fn is_diagonal_sequence(&self) -> bool {
        self.sequence() == FootfallSequence::Diagonal
    }

    /// The dominant order is the lateral sequence RH → RF → LH → LF.
    pub fn is_lateral_sequence(&self) -> bool {
        self.sequence() == FootfallSequence::Lateral
    }

    /// The classified dominant order.
    pub fn sequence(&self) -> FootfallSequence {
        FootfallSequence::classify(self.dominant_sequence())
    }

    /// The report so far (observing may continue afterwards).
    pub fn finish(&self) -> GaitReport {
        let duration_s = self
            .first_time_s
            .map_or(0.0, |first| (self.last_time_s - first).max(0.0));
        let speed_mps_mean = if duration_s > 0.0 {
            (self.path_length_m / duration_s as f64) as f32
        } else {
            0.0
        };
        GaitReport {
            sloths: 1,
            frames: self.frames,
            duration_s,
            path_length_m: self.path_length_m as f32,
            speed_mps_mean,
            limbs: PerLimb::from_fn(|limb| self.limbs[limb.index()].report(self.frames)),
            footfall_order: self
                .footfall_order()
                .iter()
                .map(|l| l.name().to_string())
                .collect(),
            sequence: self.sequence(),
        }
    }
}

/// One limb's gait numbers. Means are 0 when their count is 0.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LimbGaitReport {
    /// Mean complete stance duration, seconds (`contacts` samples).
    pub contact_s_mean: f32,
    /// Mean complete swing duration, seconds (`swings` samples).
    pub swing_s_mean: f32,
    /// Mean distance between successive footfalls, metres (`strides` samples).
    pub stride_m_mean: f32,
    /// Contact / (contact + swing) over `cycles` complete cycles; if none,
    /// the fraction of frames planted.
    pub duty_factor: f32,
    /// Strides measured.
    pub strides: u32,
    /// Complete stances measured.
    pub contacts: u32,
    /// Complete swings measured.
    pub swings: u32,
    /// Complete stance+swing cycles behind `duty_factor` (0: frame fraction).
    pub cycles: u32,
    /// Lift-offs seen.
    pub lift_offs: u32,
    /// Touch-downs seen.
    pub touch_downs: u32,
}

/// Mean of two means weighted by their sample counts.
fn weighted(a: f32, wa: f64, b: f32, wb: f64) -> f32 {
    if wa + wb > 0.0 {
        ((a as f64 * wa + b as f64 * wb) / (wa + wb)) as f32
    } else {
        0.0
    }
}

impl LimbGaitReport {
    /// Folds `other` in: each mean weighted by its count; duty factors
    /// weighted by cycles when either has complete cycles (then a side with
    /// none does not count), else by frames (`frames_self`, `frames_other`).
    pub fn merge(&mut self, other: &LimbGaitReport, frames_self: u64, frames_other: u64) {
        self.contact_s_mean = weighted(
            self.contact_s_mean,
            self.contacts as f64,
            other.contact_s_mean,
            other.contacts as f64,
        );
        self.swing_s_mean = weighted(
            self.swing_s_mean,
            self.swings as f64,
            other.swing_s_mean,
            other.swings as f64,
        );
        self.stride_m_mean = weighted(
            self.stride_m_mean,
            self.strides as f64,
            other.stride_m_mean,
            other.strides as f64,
        );
        self.duty_factor = if self.cycles + other.cycles > 0 {
            weighted(
                self.duty_factor,
                self.cycles as f64,
                other.duty_factor,
                other.cycles as f64,
            )
        } else {
            weighted(
                self.duty_factor,
                frames_self as f64,
                other.duty_factor,
                frames_other as f64,
            )
        };
        self.strides += other.strides;
        self.contacts += other.contacts;
        self.swings += other.swings;
        self.cycles += other.cycles;
        self.lift_offs += other.lift_offs;
        self.touch_downs += other.touch_downs;
    }
}

/// Gait statistics of one sloth (or, merged, of a crowd). JSON keys are the
/// field names; `limbs` is keyed `LF`, `RF`, `LH`, `RH`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct GaitReport {
    /// Sloths this report covers (0: the empty crowd, identity of `merge`).
    pub sloths: u32,
    /// Frames used (summed when merged).
    pub frames: u64,
    /// Observed span, last − first frame time, seconds (summed when merged: sloth-seconds).
    pub duration_s: f32,
    /// Path length of the body over that span, metres (summed when merged).
    pub path_length_m: f32,
    /// `path_length_m / duration_s` (merged: per-sloth means weighted by duration).
    pub speed_mps_mean: f32,
    /// Per-limb numbers.
    pub limbs: PerLimb<LimbGaitReport>,
    /// The first lift-offs, as limb names (merged: the first sloth's).
    pub footfall_order: Vec<String>,
    /// The dominant footfall order's kind (merged: `mixed` when sloths differ).
    pub sequence: FootfallSequence,
}

impl GaitReport {
    /// The repeating 4-limb order of `footfall_order` (unknown names ignored),
    /// rotated to start at RH.
    pub fn dominant_sequence(&self) -> Option<[Limb; 4]> {
        let mut order = [Limb::RH; FOOTFALL_CAPACITY];
        let mut n = 0;
        for limb in self
            .footfall_order
            .iter()
            .filter_map(|s| Limb::from_name(s))
        {
            if n == FOOTFALL_CAPACITY {
                break;
            }
            order[n] = limb;
            n += 1;
        }
        dominant_sequence(&order[..n])
    }

    /// `footfall_order` repeats the diagonal sequence.
    pub fn is_diagonal_sequence(&self) -> bool {
        FootfallSequence::classify(self.dominant_sequence()) == FootfallSequence::Diagonal
    }

    /// `footfall_order` repeats the lateral sequence.
    pub fn is_lateral_sequence(&self) -> bool {
        FootfallSequence::classify(self.dominant_sequence()) == FootfallSequence::Lateral
    }

    /// Folds another sloth's (or crowd's) report in: means weighted by their
    /// counts (speed by duration), counts summed. A report with 0 sloths is
    /// the identity.
    pub fn merge(&mut self, other: &GaitReport) {
        if other.sloths == 0 {
            return;
        }
        if self.sloths == 0 {
            *self = other.clone();
            return;
        }
        for limb in Limb::ALL {
            self.limbs
                .get_mut(limb)
                .merge(other.limbs.get(limb), self.frames, other.frames);
        }
        self.speed_mps_mean = weighted(
            self.speed_mps_mean,
            self.duration_s as f64,
            other.speed_mps_mean,
            other.duration_s as f64,
        );
        self.sloths += other.sloths;
        self.frames += other.frames;
        self.duration_s += other.duration_s;
        self.path_length_m += other.path_length_m;
        if self.footfall_order.is_empty() {
            self.footfall_order = other.footfall_order.clone();
        }
        self.sequence = match (self.sequence, other.sequence) {
            (a, b) if a == b => a,
            (FootfallSequence::Unknown, b) => b,
            (a, FootfallSequence::Unknown) => a,
            _ => FootfallSequence::Mixed,
        };
    }

    /// One report for a crowd (the empty report, 0 sloths, if none).
    pub fn aggregate<'a>(reports: impl IntoIterator<Item = &'a GaitReport>) -> GaitReport {
        let mut crowd = GaitReport::default();
        for r in reports {
            crowd.merge(r);
        }
        crowd
    }
}

/// A synthetic, perfectly regular walk along +Z below a horizontal branch,
/// for the statistics and judge tests.
#[cfg(test)]
pub(crate) mod synthetic;

#[cfg(test)]
mod tests;
