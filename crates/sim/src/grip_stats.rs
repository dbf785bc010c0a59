//! Grip-load statistics (issue 22): per limb mean and peak force in body weights, the
//! fore/hind share of the load, the residual, and the frames the release rule held a
//! limb back. Fed from the GripLoad stage's component after each tick.

use serde::Serialize;
use slothsim_gait::LimbLoads;

/// Accumulates one sloth's (or a scenario's) grip loads over frames.
#[derive(Clone, Debug, Default)]
pub struct GripLoadStats {
    frames: u64,
    failed_frames: u64,
    holding_frames: [u64; 4],
    sum_bw: [f64; 4],
    peak_bw: [f32; 4],
    residual_sum_bw: f64,
    residual_max_bw: f32,
    residual_over: u64,
    /// Histogram of the residual: bins of [`BIN_BW`], the last one open-ended.
    hist: Vec<u32>,
}

/// Width of a residual histogram bin (body weights): the resolution of the p95.
pub const BIN_BW: f32 = 0.0025;
const BINS: usize = 400;

/// Force statistics of one limb (body weights).
#[derive(Clone, Copy, Debug, Default, Serialize, PartialEq)]
pub struct LimbLoadReport {
    /// Mean force while the limb holds.
    pub mean_bw: f32,
    /// Largest force.
    pub peak_bw: f32,
}

/// Grip-load report (`stats.json` → `grip_load`).
#[derive(Clone, Debug, Default, Serialize, PartialEq)]
pub struct GripLoadReport {
    /// Sloth-frames with loads.
    pub frames: u64,
    /// Per limb, in `Limb::ALL` order (LF, RF, LH, RH).
    pub lf: LimbLoadReport,
    /// Right fore.
    pub rf: LimbLoadReport,
    /// Left hind.
    pub lh: LimbLoadReport,
    /// Right hind.
    pub rh: LimbLoadReport,
    /// Share of the summed grip force carried by the fore limbs (0–1).
    pub fore_share: f32,
    /// Share carried by the hind limbs.
    pub hind_share: f32,
    /// Largest residual wrench (body weights).
    pub max_residual_bw: f32,
    /// Mean residual.
    pub mean_residual_bw: f32,
    /// 95th percentile of the residual (to [`BIN_BW`]).
    pub p95_residual_bw: f32,
    /// Share of frames with a residual above `release_residual_bw`.
    pub over_release_share: f32,
    /// Frames in which the release rule held a due limb back (summed over sloths).
    pub frames_held_back: u64,
    /// Limbs that let go after waiting the release rule's longest wait (1 s) although
    /// the others could not carry the body.
    pub forced_releases: u64,
    /// Grip-load solves that failed (counted, the sloth kept the thesis rule).
    pub solver_failures: u64,
}

/// The release rule's counters summed over sloths (from `Sloth::load`).
#[derive(Clone, Copy, Debug, Default)]
pub struct ReleaseCounts {
    /// Frames a due limb was held back.
    pub held_back: u64,
    /// Limbs released after the longest wait.
    pub forced: u64,
    /// Failed solves.
    pub failures: u64,
}

impl ReleaseCounts {
    /// Adds one sloth's counters.
    pub fn add(&mut self, t: &slothsim_gait::LoadTrack) {
        self.held_back += u64::from(t.held_back_frames);
        self.forced += u64::from(t.forced_releases);
        self.failures += u64::from(t.failures);
    }
}

impl GripLoadStats {
    /// An empty accumulator.
    pub fn new() -> Self {
        Self::default()
    }

    /// One frame's loads; `release_bw` is the release rule's threshold.
    pub fn observe(&mut self, l: &LimbLoads, release_bw: f32) {
        if !l.ok || l.weight_n <= 0.0 {
            self.failed_frames += 1;
            return;
        }
        self.frames += 1;
        for li in 0..4 {
            let f = l.force[li].length() / l.weight_n;
            if f > 0.0 {
                self.holding_frames[li] += 1;
                self.sum_bw[li] += f64::from(f);
                self.peak_bw[li] = self.peak_bw[li].max(f);
            }
        }
        self.residual_sum_bw += f64::from(l.residual_bw);
        self.residual_max_bw = self.residual_max_bw.max(l.residual_bw);
        self.residual_over += u64::from(l.residual_bw > release_bw);
        if self.hist.is_empty() {
            self.hist = vec![0; BINS];
        }
        let bin = ((l.residual_bw / BIN_BW) as usize).min(BINS - 1);
        self.hist[bin] += 1;
    }

    /// The report; the release counters come from the sloth.
    pub fn finish(&self, counts: ReleaseCounts) -> GripLoadReport {
        Self::report([self], counts)
    }

    /// One report over several accumulators (a crowd).
    pub fn report<'a>(
        parts: impl IntoIterator<Item = &'a GripLoadStats>,
        counts: ReleaseCounts,
    ) -> GripLoadReport {
        let mut all = GripLoadStats::new();
        for p in parts {
            all.frames += p.frames;
            all.failed_frames += p.failed_frames;
            for li in 0..4 {
                all.holding_frames[li] += p.holding_frames[li];
                all.sum_bw[li] += p.sum_bw[li];
                all.peak_bw[li] = all.peak_bw[li].max(p.peak_bw[li]);
            }
            all.residual_sum_bw += p.residual_sum_bw;
            all.residual_max_bw = all.residual_max_bw.max(p.residual_max_bw);
            all.residual_over += p.residual_over;
            if !p.hist.is_empty() {
                all.hist.resize(BINS, 0);
                for (a, b) in all.hist.iter_mut().zip(&p.hist) {
                    *a += b;
                }
            }
        }
        let limb = |li: usize| LimbLoadReport {
            mean_bw: (all.sum_bw[li] / all.holding_frames[li].max(1) as f64) as f32,
            peak_bw: all.peak_bw[li],
        };
        let total: f64 = all.sum_bw.iter().sum();
        let fore = all.sum_bw[0] + all.sum_bw[1];
        let fore_share = if total > 0.0 {
            (fore / total) as f32
        } else {
            0.0
        };
        // Upper edge of the bin holding the 95th percentile (nearest rank).
        let rank = (all.frames as f64 * 0.95).ceil() as u64;
        let mut seen = 0u64;
        let mut p95 = 0.0;
        for (i, &n) in all.hist.iter().enumerate() {
            seen += u64::from(n);
            if seen >= rank && n > 0 {
                p95 = if i == BINS - 1 {
                    all.residual_max_bw
                } else {
                    (i + 1) as f32 * BIN_BW
                };
                break;
            }
        }
        let frames = all.frames.max(1) as f64;
        GripLoadReport {
            frames: all.frames,
            lf: limb(0),
            rf: limb(1),
            lh: limb(2),
            rh: limb(3),
            fore_share,
            hind_share: if total > 0.0 { 1.0 - fore_share } else { 0.0 },
            max_residual_bw: all.residual_max_bw,
            mean_residual_bw: (all.residual_sum_bw / frames) as f32,
            p95_residual_bw: p95,
            over_release_share: (all.residual_over as f64 / frames) as f32,
            frames_held_back: counts.held_back,
            forced_releases: counts.forced,
            solver_failures: counts.failures,
        }
    }
}
