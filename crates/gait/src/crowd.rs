//! Sloths meet sloths: a spatial hash of every sloth's body and grips, brought
//! up to date once per tick from the previous tick's state, so the step search
//! can keep a clearance from other sloths while every sloth is updated in
//! parallel.
//!
//! The grid is built from the points in sloth-id order (a stable counting
//! sort, in parallel jobs when the caller has workers) and only read during
//! the tick, so results never depend on the thread count. A crowd's grid is
//! re-bucketed only when enough points have moved past a slack (see
//! [`CrowdGrid::update_hashed_with`]); its queries test the current points,
//! so they answer as a grid rebuilt every tick.

use glam::{IVec3, Vec3};

/// Points each sloth contributes: body centre, hips, head and its four grips.
pub const POINTS_PER_SLOTH: usize = 7;

/// Partitions of the counting sort: a point's partition is the low
/// `PART_BITS` bits of its cell hash, and each partition is sorted on its own,
/// so the rebuild runs as parallel jobs (see [`CrowdGrid::rebuild_hashed_with`]).
const PART_BITS: u32 = 6;
const PARTS: usize = 1 << PART_BITS;

/// Buckets per point of the grid (before rounding up to a power of two).
const BUCKETS_PER_POINT: usize = 2;

/// Sloths per job of the rebuild's counting and scattering passes.
const SLOTHS_PER_JOB: usize = 1024;

/// One staged point: cell hash, owner, index of the point.
type Staged = (u32, u32, u32);

/// The share of a slack grid's points that may lie farther than the slack
/// from their anchors before [`CrowdGrid::update_hashed_with`] re-buckets
/// them all (the points past it are held in a list sorted by `x`, rebuilt
/// each update, and each query searches both).
pub const MOVED_SHARE: f32 = 1.0 / 16.0;

/// Whether every point of a group is finite, by one test of the sum of
/// their coordinates (a NaN or an infinity in any makes it non-finite):
/// `false` also where finite coordinates overflow the sum, for which the
/// caller tests each point as before. One test a sloth instead of seven.
#[inline]
fn all_finite<const K: usize>(pts: &[HashedPoint; K]) -> bool {
    pts.iter()
        .fold(0.0f32, |s, hp| s + hp.point.x + hp.point.y + hp.point.z)
        .is_finite()
}

/// A job of the parallel rebuild.
pub type Job<'a> = Box<dyn FnOnce() + Send + 'a>;

/// Runs a batch of jobs, in parallel or one after another; every job has
/// finished when `run` returns. The grid is the same for any runner.
pub trait Jobs {
    /// Runs every job once.
    fn run<'a>(&self, jobs: Vec<Job<'a>>);
}

/// Runs jobs one after another on the calling thread.
pub struct Serial;

impl Jobs for Serial {
    fn run<'a>(&self, jobs: Vec<Job<'a>>) {
        for job in jobs {
            job();
        }
    }
}

/// A spatial hash over the sloths' occupied points (owner id + position).
///
/// Built in full by [`CrowdGrid::rebuild_hashed_with`]; a grid made by
/// [`CrowdGrid::with_slack`] can also be kept up to date by
/// [`CrowdGrid::update_hashed_with`], which re-buckets only when the points
/// have moved far enough (a Verlet list's skin): its buckets hold each point
/// where it was at the last re-bucketing (its anchor), every query tests the
/// points where they are now, and a query walks the cells within the
/// clearance plus the slack of its probe. A point farther than the slack from
/// its anchor (a grip that stepped) is held, where it is now, in a list sorted
/// by `x` rebuilt each frame. Every answer is that of a grid rebuilt in
/// full from the current points.
#[derive(Clone, Debug, Default)]
pub struct CrowdGrid {
    /// Keep new grips at least this far from another sloth's points (metres).
    clearance: f32,
    /// How far a point may move from its anchor and still be found through
    /// its anchor's bucket (metres; 0: every update rebuilds in full).
    slack: f32,
    cell: f32,
    mask: u32,
    /// Buckets per partition (the bucket count over [`PARTS`]).
    per_part: u32,
    /// `starts[s]..starts[s + 1]` index `entries` of bucket slot `s` (see
    /// [`CrowdGrid::slot`]).
    starts: Vec<u32>,
    /// Owner and index in `points` of each finite anchor, by bucket.
    entries: Vec<(u32, u32)>,
    /// Points per owner group (`K` of the last full rebuild).
    per_group: usize,
    /// Owner of each group, in the order the grid was given them.
    owners: Vec<u32>,
    /// Every group's points now (`per_group` a group, non-finite ones too).
    points: Vec<Vec3>,
    /// Every group's points at the last full rebuild.
    anchors: Vec<Vec3>,
    /// The finite points now farther than the slack from their anchors (or
    /// not finite at their anchors), with their owners, by `x` (slack 0:
    /// none).
    moved: Vec<(u32, Vec3)>,
    /// Per group: whether any of its points was farther than the slack from
    /// its anchor (or not finite) at the last update or full rebuild (after
    /// one, the anchors are the points: only a non-finite point is far). A group whose points keep their bits keeps
    /// this too ([`CrowdGrid::update_hashed_kept_with`]).
    far: Vec<bool>,
    /// Full rebuilds so far.
    rebuilds: u64,
    /// Scratch: the points grouped by partition, in sloth order within each.
    staging: Vec<Staged>,
    /// Scratch: points per partition counted by each job.
    counts: Vec<[u32; PARTS]>,
    /// Scratch: the moved points' indices, per job of an update.
    moved_idx: Vec<Vec<u32>>,
    /// Scratch: the moved finite points' sort keys (`x`, index).
    moved_keys: Vec<u64>,
}

/// `x.floor() as i32` (saturating, NaN → 0) without the `floorf` call the
/// baseline x86-64 target makes for `f32::floor`: the same integer for every
/// input. Truncation rounds toward zero, so it is one too high exactly when
/// it lands above a negative non-integer `x`; where it saturates (|x| ≥ 2³¹)
/// or `x` is NaN, `floor` saturates and gives 0 alike.
#[inline(always)]
fn floor_i32(x: f32) -> i32 {
    let t = x as i32;
    if (t as f32) > x {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// The cell of `p`: [`floor_i32`] of each coordinate of `p * inv_cell`.
#[inline(always)]
fn cell_of(p: Vec3, inv_cell: f32) -> IVec3 {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE2 is part of the x86-64 baseline.
        unsafe { floor3_sse2(glam::Vec3A::from(p) * inv_cell) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        cell_of_scalar(p, inv_cell)
    }
}

/// [`cell_of`] axis by axis (the reference of [`floor3_sse2`]).
#[cfg_attr(
    target_arch = "x86_64",
    allow(dead_code, reason = "the tests' reference there")
)]
#[inline(always)]
fn cell_of_scalar(p: Vec3, inv_cell: f32) -> IVec3 {
    let q = p * inv_cell;
    IVec3::new(floor_i32(q.x), floor_i32(q.y), floor_i32(q.z))
}

/// [`floor_i32`] of `q`'s three lanes at once in SSE2 (the baseline of
/// x86-64), the same integers for every input: the truncation
/// (`cvttps2dq`), less one where it lands above `q` (the same compare of the
/// same rounded conversion); then the lanes where the scalar cast saturates
/// or gives 0: at or above 2³¹ (the truncation's out-of-range value
/// `i32::MIN`, flipped to `i32::MAX`), below −2³¹ (`i32::MIN` less one
/// wrapped to `i32::MAX`, flipped back to `i32::MIN`) and NaN (0). The
/// hashing of a sloth's seven points every frame and the grid queries' cells
/// spent about 36 instructions a point on the three scalar casts and their
/// saturation tests.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "sse2")]
#[inline]
fn floor3_sse2(q: glam::Vec3A) -> IVec3 {
    use std::arch::x86_64::{
        __m128, _mm_add_epi32, _mm_andnot_si128, _mm_castps_si128, _mm_cmpge_ps, _mm_cmpgt_ps,
        _mm_cmplt_ps, _mm_cmpunord_ps, _mm_cvtepi32_ps, _mm_cvttps_epi32, _mm_or_si128,
        _mm_set1_ps, _mm_storeu_si128, _mm_xor_si128,
    };
    let q: __m128 = q.into();
    let t = _mm_cvttps_epi32(q);
    // All ones (−1) where the truncation lies above `q`.
    let above = _mm_castps_si128(_mm_cmpgt_ps(_mm_cvtepi32_ps(t), q));
    let f = _mm_add_epi32(t, above);
    let hi = _mm_castps_si128(_mm_cmpge_ps(q, _mm_set1_ps(2_147_483_648.0)));
    let lo = _mm_castps_si128(_mm_cmplt_ps(q, _mm_set1_ps(-2_147_483_648.0)));
    let nan = _mm_castps_si128(_mm_cmpunord_ps(q, q));
    let f = _mm_andnot_si128(nan, _mm_xor_si128(f, _mm_or_si128(hi, lo)));
    let mut out = [0i32; 4];
    // SAFETY: `out` is 16 writable bytes; `storeu` needs no alignment.
    unsafe { _mm_storeu_si128(out.as_mut_ptr().cast(), f) };
    IVec3::new(out[0], out[1], out[2])
}

/// Margin of [`cell_gaps`] (in cells): far above the rounding of a point's
/// cell coordinates (`p / cell`, a few 1e-5 cells at forest scale).
const CELL_GAP_SLACK: f32 = 0.01;

/// For a point at cell coordinates `q` (`p / cell`) in cell `c`, per axis
/// and per neighbour offset −1, 0, +1: the squared distance from `q` to that
/// neighbour's slab, less [`CELL_GAP_SLACK`], over the squared reach
/// `reach` (the clearance in cells, at most 1) with 0.1 % more. A
/// neighbour cell whose three terms sum above 1 lies farther than the
/// clearance from the point: a point there has `floor(q' ) ≠ c` on each axis
/// where its offset is not 0, so it lies at least the gap away along it, and
/// no point of it passes a `distance² < clearance²` test. Where `q` is not
/// within its cell (coordinates past `i32`'s range, or rounding at a cell's
/// edge) every term is 0: every cell walked, as before.
#[inline]
fn cell_gaps(q: Vec3, c: IVec3, reach: f32) -> [[f32; 3]; 3] {
    let f = q - c.as_vec3();
    let inv_r2 = 1.0 / (reach * reach * 1.002);
    let axis = |f: f32| -> [f32; 3] {
        if !(0.0..=1.0).contains(&f) {
            return [0.0; 3];
        }
        let gap = |g: f32| {
            let g = (g - CELL_GAP_SLACK).max(0.0);
            g * g * inv_r2
        };
        [gap(f), 0.0, gap(1.0 - f)]
    };
    [axis(f.x), axis(f.y), axis(f.z)]
}

fn cell_hash(c: IVec3) -> u32 {
    // Three large primes (Teschner et al. 2003), wrapping.
    (c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791)
}

/// A point with the hash of its grid cell (before the bucket mask): what
/// [`CrowdGrid::rebuild_hashed_with`] takes, so the hashing can run in parallel.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HashedPoint {
    /// Cell hash, see [`CrowdGrid::hashed`].
    pub hash: u32,
    /// The point.
    pub point: Vec3,
}

impl CrowdGrid {
    /// An empty grid keeping `clearance_m` between sloths, rebuilt in full
    /// by every update.
    pub fn new(clearance_m: f32) -> Self {
        Self::with_slack(clearance_m, 0.0)
    }

    /// An empty grid keeping `clearance_m` between sloths whose
    /// [`CrowdGrid::update_hashed_with`] re-buckets only when more than a
    /// share of the points ([`MOVED_SHARE`]) lie farther than `slack_m`
    /// from where they were at the last re-bucketing. Its cells are the
    /// clearance plus the slack: a query walks more points than a grid
    /// without slack.
    pub fn with_slack(clearance_m: f32, slack_m: f32) -> Self {
        let slack = slack_m.max(0.0);
        CrowdGrid {
            clearance: clearance_m,
            slack,
            cell: clearance_m.max(0.05) + slack,
            ..Default::default()
        }
    }

    /// The clearance this grid enforces.
    pub fn clearance(&self) -> f32 {
        self.clearance
    }

    /// Number of finite points held at the last full rebuild.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether the grid holds no points.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty() && self.moved.is_empty()
    }

    /// Points held apart (moved past the slack since the last full
    /// rebuild) now.
    pub fn moved_len(&self) -> usize {
        self.moved.len()
    }

    /// Full rebuilds so far (by any of the rebuild or update methods).
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// Rebuilds the grid from `(owner, point)` pairs (order kept within a
    /// bucket, so queries are deterministic).
    pub fn rebuild(&mut self, points: impl IntoIterator<Item = (u32, Vec3)>) {
        self.rebuild_groups(points.into_iter().map(|(o, p)| (o, [p])));
    }

    /// [`CrowdGrid::rebuild`] from groups of `K` points per owner (the same
    /// grid as the flattened pairs).
    pub fn rebuild_groups<const K: usize>(
        &mut self,
        groups: impl IntoIterator<Item = (u32, [Vec3; K])>,
    ) {
        let hashed: Vec<(u32, [HashedPoint; K])> = groups
            .into_iter()
            .map(|(o, ps)| (o, ps.map(|p| self.hashed(p))))
            .collect();
        self.rebuild_hashed_with(hashed.len(), |i| (hashed[i].0, &hashed[i].1), &Serial);
    }

    /// `p` with its cell hash for [`CrowdGrid::rebuild_hashed_with`] (this grid's cell size).
    #[inline]
    pub fn hashed(&self, p: Vec3) -> HashedPoint {
        HashedPoint {
            hash: cell_hash(cell_of(p, 1.0 / self.cell)),
            point: p,
        }
    }

    /// Brings the grid to `sloths` groups of points hashed by
    /// [`CrowdGrid::hashed`] (as [`CrowdGrid::rebuild_hashed_with`]): with
    /// the same owners in the same order as the last full rebuild, and at
    /// most a share [`MOVED_SHARE`] of the points farther than the slack
    /// from where they were then, only the current points are copied (and
    /// those moved points gathered into a list sorted by `x`);
    /// otherwise (no slack, other owners, more moved points) the grid is
    /// rebuilt in full. The queries answer the same either way: that of a
    /// full rebuild from these points. Which points count as moved is
    /// decided point by point, so the grid is the same for any runner.
    pub fn update_hashed_with<'a, const K: usize, G>(
        &mut self,
        sloths: usize,
        group: G,
        jobs: &impl Jobs,
    ) where
        G: Fn(usize) -> (u32, &'a [HashedPoint; K]) + Sync,
    {
        self.update_hashed_kept_with(
            sloths,
            |i| {
                let (o, p) = group(i);
                (o, p, false)
            },
            jobs,
        );
    }

    /// [`CrowdGrid::update_hashed_with`], told which groups kept their
    /// points: `group(i)` also says whether the `i`-th group's points hold
    /// exactly the bits they held at this grid's last update or rebuild (a
    /// sloth at rest, about half of a crowd's sloth-frames). Such a group
    /// with no point past the slack then was none now either: its points are
    /// neither copied nor tested again (nor read: only its owner is). The
    /// grid is the one [`CrowdGrid::update_hashed_with`] makes, provided the
    /// flags are true only where the bits are the same.
    pub fn update_hashed_kept_with<'a, const K: usize, G>(
        &mut self,
        sloths: usize,
        group: G,
        jobs: &impl Jobs,
    ) where
        G: Fn(usize) -> (u32, &'a [HashedPoint; K], bool) + Sync,
    {
        let plain = |i| {
            let (o, p, _) = group(i);
            (o, p)
        };
        if self.slack <= 0.0 || self.per_group != K || self.owners.len() != sloths {
            return self.rebuild_hashed_with(sloths, plain, jobs);
        }
        let group = &group;
        let blocks = sloths.div_ceil(SLOTHS_PER_JOB);
        self.moved_idx.resize_with(blocks, Vec::new);
        let s2 = self.slack * self.slack;
        // NaN (a point not finite now or at its anchor) is not near: held
        // apart, or left out there.
        let near = move |p: Vec3, anchor: Vec3| p.distance_squared(anchor) <= s2;
        let mut same = vec![true; blocks];
        let jobs_list: Vec<Job<'_>> = self
            .points
            .chunks_mut(SLOTHS_PER_JOB * K)
            .zip(self.anchors.chunks(SLOTHS_PER_JOB * K))
            .zip(self.owners.chunks(SLOTHS_PER_JOB))
            .zip(self.far.chunks_mut(SLOTHS_PER_JOB))
            .zip(self.moved_idx.iter_mut())
            .zip(same.iter_mut())
            .enumerate()
            .map(|(b, (((((pts, anchors), owners), fars), moved), same))| {
                Box::new(move || {
                    moved.clear();
                    let first = b * SLOTHS_PER_JOB;
                    let groups = pts.chunks_exact_mut(K).zip(anchors.chunks_exact(K));
                    let groups = groups.zip(owners).zip(fars.iter_mut());
                    for (j, (((pts, anchors), &owner), was_far)) in groups.enumerate() {
                        let (o, hps, kept) = group(first + j);
                        if o != owner {
                            *same = false;
                            return;
                        }
                        // The same bits as last time, none past the slack
                        // then: none now (`pts` holds them already).
                        if kept && !*was_far {
                            debug_assert!(
                                (0..K).all(|k| pts[k].to_array().map(f32::to_bits)
                                    == hps[k].point.to_array().map(f32::to_bits)),
                                "a group flagged kept whose points changed"
                            );
                            continue;
                        }
                        let mut far = false;
                        for k in 0..K {
                            pts[k] = hps[k].point;
                            far |= !near(hps[k].point, anchors[k]);
                        }
                        *was_far = far;
                        if far {
                            for k in 0..K {
                                if !near(pts[k], anchors[k]) {
                                    moved.push(((first + j) * K + k) as u32);
                                }
                            }
                        }
                    }
                }) as Job<'_>
            })
            .collect();
        jobs.run(jobs_list);
        let moved: usize = self.moved_idx.iter().map(Vec::len).sum();
        let limit = (self.points.len() as f32 * MOVED_SHARE) as usize;
        if same.contains(&false) || moved > limit {
            return self.rebuild_hashed_with(sloths, plain, jobs);
        }
        // By `x` (its bits in `f32::total_cmp`'s order), then by index: one
        // order for any runner.
        let (points, owners) = (&self.points, &self.owners);
        let order = |x: f32| {
            let b = x.to_bits();
            (b ^ ((((b as i32) >> 31) as u32) >> 1) ^ (1 << 31)) as u64
        };
        self.moved_keys.clear();
        self.moved_keys.extend(
            self.moved_idx
                .iter()
                .flatten()
                .filter(|&&i| points[i as usize].is_finite())
                .map(|&i| order(points[i as usize].x) << 32 | i as u64),
        );
        self.moved_keys.sort_unstable();
        self.moved.clear();
        self.moved.extend(self.moved_keys.iter().map(|&k| {
            let i = k as u32 as usize;
            (owners[i / K], points[i])
        }));
    }

    /// Rebuilds the grid from `sloths` groups of points already hashed by
    /// [`CrowdGrid::hashed`] (`group(i)`: owner and points of the `i`-th, in
    /// id order; non-finite points are left out), running its passes as
    /// `jobs`: count each partition's points per block of sloths (copying
    /// the points), scatter them into their partitions (blocks in order),
    /// then counting-sort each partition into its buckets. Each pass is
    /// stable, so every bucket holds its points in sloth order, for any
    /// runner (the same grid as [`CrowdGrid::rebuild`] of the flattened
    /// pairs).
    pub fn rebuild_hashed_with<'a, const K: usize, G>(
        &mut self,
        sloths: usize,
        group: G,
        jobs: &impl Jobs,
    ) where
        G: Fn(usize) -> (u32, &'a [HashedPoint; K]) + Sync,
    {
        let group = &group;
        let blocks = sloths.div_ceil(SLOTHS_PER_JOB);
        let block = move |b: usize| b * SLOTHS_PER_JOB..((b + 1) * SLOTHS_PER_JOB).min(sloths);
        let part = |hash: u32| (hash as usize) & (PARTS - 1);
        self.rebuilds += 1;
        self.per_group = K;
        self.owners.resize(sloths, 0);
        self.points.resize(sloths * K, Vec3::ZERO);
        self.far.resize(sloths, false);
        self.moved.clear();
        // 1. Points per partition, per block of sloths; the points copied.
        self.counts.clear();
        self.counts.resize(blocks, [0; PARTS]);
        jobs.run(
            self.counts
                .iter_mut()
                .zip(self.points.chunks_mut(SLOTHS_PER_JOB * K))
                .zip(self.owners.chunks_mut(SLOTHS_PER_JOB))
                .zip(self.far.chunks_mut(SLOTHS_PER_JOB))
                .enumerate()
                .map(|(b, (((counts, points), owners), fars))| {
                    Box::new(move || {
                        let first = b * SLOTHS_PER_JOB;
                        for i in block(b) {
                            let (owner, pts) = group(i);
                            owners[i - first] = owner;
                            let all = all_finite(pts);
                            // At its anchor (itself) a point is within the
                            // slack unless it is not finite.
                            fars[i - first] = !all;
                            for (k, hp) in pts.iter().enumerate() {
                                points[(i - first) * K + k] = hp.point;
                                if all || hp.point.is_finite() {
                                    counts[part(hp.hash)] += 1;
                                }
                            }
                        }
                    }) as Job<'_>
                })
                .collect(),
        );
        if self.slack > 0.0 {
            self.anchors.clone_from(&self.points);
        }

        let mut part_len = [0usize; PARTS];
        for counts in &self.counts {
            for (l, &c) in part_len.iter_mut().zip(counts) {
                *l += c as usize;
            }
        }
        let n: usize = part_len.iter().sum();
        // Half a point to one point a bucket: a query walks about 21 cells,
        // most of them empty, and each cell's bucket brings the points of
        // every other cell hashed to it (tested and rejected on distance);
        // with two points a bucket those were most of a query's tests.
        let buckets = (n * BUCKETS_PER_POINT).next_power_of_two().max(PARTS);
        self.mask = buckets as u32 - 1;
        self.per_part = (buckets / PARTS) as u32;
        // 2. Scatter into the partitions: partition-major, then block order.
        if self.staging.len() < n {
            self.staging.resize(n, (0, 0, 0));
        }
        let mut rest = &mut self.staging[..n];
        let mut outs: Vec<Vec<&mut [Staged]>> =
            (0..blocks).map(|_| Vec::with_capacity(PARTS)).collect();
        for p in 0..PARTS {
            for (b, out) in outs.iter_mut().enumerate() {
                let (head, tail) =
                    std::mem::take(&mut rest).split_at_mut(self.counts[b][p] as usize);
                out.push(head);
                rest = tail;
            }
        }
        jobs.run(
            outs.into_iter()
                .enumerate()
                .map(|(b, mut out)| {
                    Box::new(move || {
                        let mut next = [0usize; PARTS];
                        for i in block(b) {
                            let (owner, pts) = group(i);
                            let all = all_finite(pts);
                            for (k, hp) in pts.iter().enumerate() {
                                if all || hp.point.is_finite() {
                                    let p = part(hp.hash);
                                    out[p][next[p]] = (hp.hash, owner, (i * K + k) as u32);
                                    next[p] += 1;
                                }
                            }
                        }
                    }) as Job<'_>
                })
                .collect(),
        );
        // 3. Each partition into its buckets. Partition `p` holds the slots
        // `p * per_part ..`; its sort writes `starts[s + 1]` (the end of slot
        // `s`, which is where the next slot starts) for each of them.
        if self.entries.len() != n {
            self.entries.resize(n, (0, 0));
        }
        self.starts.resize(buckets + 1, 0);
        self.starts[0] = 0;
        let (mask, per_part) = (self.mask, self.per_part as usize);
        let mut staged = &self.staging[..n];
        let mut entries = &mut self.entries[..];
        let mut ends = &mut self.starts[1..];
        let mut sorts: Vec<Job<'_>> = Vec::with_capacity(PARTS);
        let mut base = 0u32;
        for &len in &part_len {
            let (src, s_rest) = staged.split_at(len);
            let (dst, e_rest) = std::mem::take(&mut entries).split_at_mut(len);
            let (end, x_rest) = std::mem::take(&mut ends).split_at_mut(per_part);
            (staged, entries, ends) = (s_rest, e_rest, x_rest);
            let start = base;
            base += len as u32;
            sorts.push(Box::new(move || {
                let local = |hash: u32| ((hash & mask) >> PART_BITS) as usize;
                end.fill(0);
                for e in src {
                    end[local(e.0)] += 1;
                }
                let mut at = start;
                for x in end.iter_mut() {
                    let c = *x;
                    *x = at;
                    at += c;
                }
                for &(hash, owner, idx) in src {
                    let x = &mut end[local(hash)];
                    dst[(*x - start) as usize] = (owner, idx);
                    *x += 1;
                }
            }));
        }
        jobs.run(sorts);
    }

    /// The slot in `starts` of the bucket of cell `c`: partition-major (see
    /// [`CrowdGrid::rebuild_hashed_with`]).
    #[inline]
    fn slot(&self, c: IVec3) -> usize {
        let b = cell_hash(c) & self.mask;
        (b as usize & (PARTS - 1)) * self.per_part as usize + (b >> PART_BITS) as usize
    }

    /// Whether a point of a sloth other than `me` lies within the clearance of `p`.
    pub fn blocked(&self, me: u32, p: Vec3) -> bool {
        self.any_within(me, p, |_, _| true)
    }

    /// [`CrowdGrid::blocked`] for a grip moving from `from` to `p`: only
    /// the points within the clearance of `p` that `p` is not farther from
    /// than `from` is block it. A grip already within another sloth's
    /// clearance may so step away from its points, never toward them; a
    /// grip outside every clearance is blocked as by [`CrowdGrid::blocked`].
    pub fn blocked_from(&self, me: u32, from: Vec3, p: Vec3) -> bool {
        if !from.is_finite() {
            return self.blocked(me, p);
        }
        self.any_within(me, p, |q, d2| d2 <= q.distance_squared(from))
    }

    /// Whether a point `q` of a sloth other than `me` within the clearance
    /// of `p` has `counts(q, |q − p|²)`: the points found through their
    /// anchors' buckets, then those held apart.
    #[inline]
    fn any_within(&self, me: u32, p: Vec3, counts: impl Fn(Vec3, f32) -> bool + Copy) -> bool {
        if !p.is_finite() {
            return false;
        }
        if !self.entries.is_empty() && self.any_held(me, p, counts) {
            return true;
        }
        self.any_moved(me, p, counts)
    }

    /// [`CrowdGrid::any_within`] of the points held apart (`p` finite): those
    /// whose `x` lies within the clearance of `p`'s, found by bisection. A
    /// point within the clearance has `|q.x − p.x|` below it (`d²` is at
    /// least `dx²` as rounded); the window is 1 % (and a rounding of `p.x`)
    /// wider.
    #[inline]
    fn any_moved(&self, me: u32, p: Vec3, counts: impl Fn(Vec3, f32) -> bool) -> bool {
        if self.moved.is_empty() {
            return false;
        }
        let r2 = self.clearance * self.clearance;
        let w = self.clearance * 1.01 + p.x.abs() * 1e-6;
        let (lo, hi) = (p.x - w, p.x + w);
        let first = self.moved.partition_point(|e| e.1.x < lo);
        for &(owner, q) in &self.moved[first..] {
            if q.x > hi {
                break;
            }
            if owner != me {
                let d2 = q.distance_squared(p);
                if d2 < r2 && counts(q, d2) {
                    return true;
                }
            }
        }
        false
    }

    /// [`CrowdGrid::any_within`] of the bucketed points alone (`p` finite).
    #[inline]
    fn any_held(&self, me: u32, p: Vec3, counts: impl Fn(Vec3, f32) -> bool) -> bool {
        let inv = 1.0 / self.cell;
        let c = cell_of(p, inv);
        let r2 = self.clearance * self.clearance;
        // The cell is at least the clearance plus the slack, so the 27 cells
        // around `p` hold every anchor within that reach (a point within the
        // clearance of `p` lies within the slack of its anchor, or is held
        // apart); a cell whose box lies farther than that from `p` holds no
        // such anchor and is not walked (see [`cell_gaps`]).
        let [gx, gy, gz] = cell_gaps(p * inv, c, (self.clearance + self.slack) * inv);
        for dz in -1..=1 {
            for dy in -1..=1 {
                for dx in -1..=1 {
                    if gx[(dx + 1) as usize] + gy[(dy + 1) as usize] + gz[(dz + 1) as usize] > 1.0 {
                        continue;
                    }
                    let s = self.slot(c + IVec3::new(dx, dy, dz));
                    let (s, e) = (self.starts[s] as usize, self.starts[s + 1] as usize);
                    for &(owner, i) in &self.entries[s..e] {
                        if owner != me {
                            // A point not finite now fails the distance test.
                            let q = self.points[i as usize];
                            let d2 = q.distance_squared(p);
                            if d2 < r2 && counts(q, d2) {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    }

    /// Every current point with its owner (non-finite ones too).
    fn current(&self) -> impl Iterator<Item = (u32, Vec3)> + '_ {
        let per = self.per_group.max(1);
        self.points
            .iter()
            .enumerate()
            .map(move |(i, &q)| (self.owners[i / per], q))
    }

    /// Brute-force reference for [`CrowdGrid::blocked_from`] (tests): every
    /// current point tested.
    pub fn blocked_from_brute_force(&self, me: u32, from: Vec3, p: Vec3) -> bool {
        if !from.is_finite() {
            return self.blocked_brute_force(me, p);
        }
        let r2 = self.clearance * self.clearance;
        self.current().any(|(o, q)| {
            let d2 = q.distance_squared(p);
            o != me && d2 < r2 && d2 <= q.distance_squared(from)
        })
    }

    /// Brute-force reference for [`CrowdGrid::blocked`] (tests): every
    /// current point tested.
    pub fn blocked_brute_force(&self, me: u32, p: Vec3) -> bool {
        let r2 = self.clearance * self.clearance;
        self.current()
            .any(|(o, q)| o != me && q.distance_squared(p) < r2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The bucketed points with their owners, at their current positions.
    fn held(g: &CrowdGrid) -> Vec<(u32, Vec3)> {
        g.entries
            .iter()
            .map(|&(o, i)| (o, g.points[i as usize]))
            .collect()
    }

    /// One frame's move of a point: a drift of up to 2 cm a frame (which
    /// passes the 5 cm slack in a few frames), now and then a step of up to
    /// 40 cm, a point turned non-finite or finite again.
    fn moved(p: Vec3, kind: u8, d: Vec3) -> Vec3 {
        match kind {
            0..=2 => Vec3::NAN,
            3..=5 if !p.is_finite() => d * 20.0,
            3..=9 => p + d * 20.0,
            _ if !p.is_finite() => p,
            _ => p + d,
        }
    }

    /// A grid's state as bits: buckets, current points, the moved list, rebuilds.
    type GridBits = (
        Vec<(u32, u32)>,
        Vec<u32>,
        Vec<[u32; 3]>,
        Vec<(u32, [u32; 3])>,
        u64,
    );

    fn grid_bits(g: &CrowdGrid) -> GridBits {
        let bits = |p: Vec3| p.to_array().map(f32::to_bits);
        (
            g.entries.clone(),
            g.starts.clone(),
            g.points.iter().map(|&p| bits(p)).collect(),
            g.moved.iter().map(|&(o, p)| (o, bits(p))).collect(),
            g.rebuilds,
        )
    }

    proptest! {
        /// [`CrowdGrid::update_hashed_kept_with`], told truly which groups
        /// kept their points' bits since the last update (about half of
        /// them each frame, the others drifting past the slack, stepping or
        /// turning non-finite), makes exactly the grid that
        /// [`CrowdGrid::update_hashed_with`] makes from the same points,
        /// frame after frame, serially and on threads (also when owners
        /// change or a group is dropped).
        #[test]
        fn kept_groups_update_as_the_full_update(
            start in prop::collection::vec(
                prop::array::uniform7((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)),
                3..40,
            ),
            frames in prop::collection::vec(
                (
                    prop::collection::vec(
                        (
                            0u8..2,
                            prop::array::uniform7((0u8..200, -0.02f32..0.02, -0.02f32..0.02, -0.02f32..0.02)),
                        ),
                        40,
                    ),
                    0u8..30,
                ),
                1..16,
            ),
        ) {
            let mut full = CrowdGrid::with_slack(0.3, 0.05);
            let mut kept_serial = full.clone();
            let mut kept_threaded = full.clone();
            let mut owners: Vec<u32> = (0..start.len() as u32).collect();
            let mut pts: Vec<[Vec3; 7]> = start
                .iter()
                .map(|g| g.map(|(x, y, z)| Vec3::new(x, y, z)))
                .collect();
            let mut last: Option<Vec<[HashedPoint; 7]>> = None;
            for (f, (moves, owner_change)) in frames.iter().enumerate() {
                if f > 0 {
                    for (g, (rest, m)) in pts.iter_mut().zip(moves) {
                        if *rest == 1 {
                            continue;
                        }
                        for (p, &(kind, x, y, z)) in g.iter_mut().zip(m) {
                            *p = moved(*p, kind, Vec3::new(x, y, z));
                        }
                    }
                    match owner_change {
                        0 if pts.len() > 1 => {
                            pts.pop();
                            owners.pop();
                        }
                        1 => owners[0] += 100,
                        _ => {}
                    }
                }
                let hashed: Vec<[HashedPoint; 7]> =
                    pts.iter().map(|g| g.map(|p| full.hashed(p))).collect();
                let bits = |g: &[HashedPoint; 7]| g.map(|h| h.point.to_array().map(f32::to_bits));
                let kept: Vec<bool> = (0..hashed.len())
                    .map(|i| {
                        last.as_ref()
                            .and_then(|l| l.get(i))
                            .is_some_and(|l| bits(l) == bits(&hashed[i]))
                    })
                    .collect();
                full.update_hashed_with(hashed.len(), |i| (owners[i], &hashed[i]), &Serial);
                let get = |i: usize| (owners[i], &hashed[i], kept[i]);
                kept_serial.update_hashed_kept_with(hashed.len(), get, &Serial);
                kept_threaded.update_hashed_kept_with(hashed.len(), get, &Threads);
                prop_assert_eq!(grid_bits(&kept_serial), grid_bits(&full), "frame {}", f);
                prop_assert_eq!(grid_bits(&kept_threaded), grid_bits(&full), "frame {}", f);
                last = Some(hashed);
            }
        }

        /// A grid kept by [`CrowdGrid::update_hashed_with`] answers every
        /// probe as a grid rebuilt in full from the same points and as the
        /// brute force, frame after frame, while its points drift past the
        /// slack, step, turn non-finite and back, and its owners change; it
        /// is the same grid with the jobs run serially or on threads.
        #[test]
        fn updated_grid_matches_full_rebuild_across_frames(
            start in prop::collection::vec(
                prop::array::uniform7((-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0)),
                3..40,
            ),
            frames in prop::collection::vec(
                (
                    prop::collection::vec(
                        prop::array::uniform7((0u8..200, -0.02f32..0.02, -0.02f32..0.02, -0.02f32..0.02)),
                        40,
                    ),
                    0u8..20,
                    prop::collection::vec(
                        (0u32..41, 0usize..280, -1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0, 0.9f32..1.1),
                        1..40,
                    ),
                ),
                1..12,
            ),
        ) {
            let clearance = 0.3;
            let mut serial = CrowdGrid::with_slack(clearance, 0.05);
            let mut threaded = serial.clone();
            let mut owners: Vec<u32> = (0..start.len() as u32).collect();
            let mut pts: Vec<[Vec3; 7]> = start
                .iter()
                .map(|g| g.map(|(x, y, z)| Vec3::new(x, y, z)))
                .collect();
            for (f, (moves, owner_change, probes)) in frames.iter().enumerate() {
                if f > 0 {
                    for (g, m) in pts.iter_mut().zip(moves) {
                        for (p, &(kind, x, y, z)) in g.iter_mut().zip(m) {
                            *p = moved(*p, kind, Vec3::new(x, y, z));
                        }
                    }
                    match owner_change {
                        0 if pts.len() > 1 => {
                            pts.pop();
                            owners.pop();
                        }
                        1 => owners[0] += 100,
                        _ => {}
                    }
                }
                let hashed: Vec<[HashedPoint; 7]> =
                    pts.iter().map(|g| g.map(|p| serial.hashed(p))).collect();
                let get = |i: usize| (owners[i], &hashed[i]);
                serial.update_hashed_with(pts.len(), get, &Serial);
                threaded.update_hashed_with(pts.len(), get, &Threads);
                prop_assert_eq!(&serial.entries, &threaded.entries);
                prop_assert_eq!(&serial.starts, &threaded.starts);
                prop_assert_eq!(
                    serial.moved.iter().map(|&(o, q)| (o, q.to_array().map(f32::to_bits))).collect::<Vec<_>>(),
                    threaded.moved.iter().map(|&(o, q)| (o, q.to_array().map(f32::to_bits))).collect::<Vec<_>>()
                );
                prop_assert_eq!(serial.rebuilds(), threaded.rebuilds());
                let mut full = CrowdGrid::new(clearance);
                full.rebuild_groups(owners.iter().copied().zip(pts.iter().copied()));
                let all: Vec<Vec3> = pts.iter().flatten().copied().filter(|p| p.is_finite()).collect();
                for &(me, i, x, y, z, k) in probes {
                    let Some(dir) = Vec3::new(x, y, z).try_normalize() else { continue };
                    let base = if all.is_empty() { Vec3::ZERO } else { all[i % all.len()] };
                    let p = base + dir * (clearance * k);
                    let from = p + dir * 0.05;
                    let b = serial.blocked(me, p);
                    prop_assert_eq!(b, full.blocked(me, p), "frame {} probe {}", f, p);
                    prop_assert_eq!(b, serial.blocked_brute_force(me, p));
                    let b = serial.blocked_from(me, from, p);
                    prop_assert_eq!(b, full.blocked_from(me, from, p), "frame {} probe {}", f, p);
                    prop_assert_eq!(b, serial.blocked_from_brute_force(me, from, p));
                }
            }
        }
    }

    #[test]
    fn update_re_buckets_only_past_the_moved_share() {
        let mut g = CrowdGrid::with_slack(0.3, 0.05);
        let mut pts: Vec<[Vec3; 7]> = (0..100)
            .map(|i| [(); 7].map(|_| Vec3::new(i as f32 * 0.1, 0.0, 0.0)))
            .map(|mut g| {
                for (k, p) in g.iter_mut().enumerate() {
                    p.y = k as f32 * 0.1;
                }
                g
            })
            .collect();
        let update = |g: &mut CrowdGrid, pts: &[[Vec3; 7]]| {
            let hashed: Vec<[HashedPoint; 7]> =
                pts.iter().map(|ps| ps.map(|p| g.hashed(p))).collect();
            g.update_hashed_with(pts.len(), |i| (i as u32, &hashed[i]), &Serial);
        };
        update(&mut g, &pts);
        assert_eq!((g.rebuilds(), g.moved_len()), (1, 0));
        // A drift within the slack and two steps past it: kept.
        for _ in 0..4 {
            for ps in &mut pts {
                for p in ps.iter_mut() {
                    p.z += 0.01;
                }
            }
            update(&mut g, &pts);
        }
        pts[3][4].x += 0.4;
        pts[50][0] = Vec3::NAN;
        update(&mut g, &pts);
        assert_eq!((g.rebuilds(), g.moved_len()), (1, 1));
        assert!(g.blocked(7, pts[3][4] + Vec3::X * 0.29));
        // Every point past the slack: rebuilt, none held apart.
        for ps in &mut pts {
            for p in ps.iter_mut() {
                p.z += 0.02;
            }
        }
        update(&mut g, &pts);
        assert_eq!((g.rebuilds(), g.moved_len()), (2, 0));
        // Other owners: rebuilt.
        pts.pop();
        update(&mut g, &pts);
        assert_eq!(g.rebuilds(), 3);
    }

    proptest! {
        #[test]
        fn grid_matches_brute_force(
            pts in prop::collection::vec((0u32..20, -3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0), 0..200),
            probes in prop::collection::vec((0u32..20, -3.5f32..3.5, -3.5f32..3.5, -3.5f32..3.5), 1..50),
        ) {
            let mut g = CrowdGrid::new(0.3);
            g.rebuild(pts.iter().map(|&(o, x, y, z)| (o, Vec3::new(x, y, z))));
            prop_assert_eq!(g.len(), pts.len());
            for &(me, x, y, z) in &probes {
                let p = Vec3::new(x, y, z);
                prop_assert_eq!(g.blocked(me, p), g.blocked_brute_force(me, p));
            }
        }

        /// [`CrowdGrid::blocked_from`] matches its brute force, blocks no
        /// more than [`CrowdGrid::blocked`], and as much where `from` lies
        /// outside every clearance.
        #[test]
        fn blocked_from_matches_brute_force(
            pts in prop::collection::vec((0u32..20, -1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0), 0..100),
            probes in prop::collection::vec(
                (0u32..20, -1.2f32..1.2, -1.2f32..1.2, -1.2f32..1.2, -0.2f32..0.2, -0.2f32..0.2, -0.2f32..0.2),
                1..50,
            ),
        ) {
            let mut g = CrowdGrid::new(0.3);
            g.rebuild(pts.iter().map(|&(o, x, y, z)| (o, Vec3::new(x, y, z))));
            for &(me, x, y, z, dx, dy, dz) in &probes {
                let from = Vec3::new(x, y, z);
                let p = from + Vec3::new(dx, dy, dz);
                let b = g.blocked_from(me, from, p);
                prop_assert_eq!(b, g.blocked_from_brute_force(me, from, p));
                prop_assert!(!b || g.blocked(me, p));
                if !g.blocked(me, from) {
                    prop_assert_eq!(b, g.blocked(me, p));
                }
            }
        }
    }

    proptest! {
        /// The cells [`cell_gaps`] leaves out hold no blocking point: probes
        /// just inside and just outside another sloth's clearance (0.97–1.001
        /// of it, in any direction), at forest-scale coordinates, for
        /// clearances below, at and above the smallest cell, answer as the
        /// brute force ([`CrowdGrid::blocked`] and [`CrowdGrid::blocked_from`]).
        #[test]
        fn blocked_at_the_clearance_edge_matches_brute_force(
            base in (-150.0f32..150.0, -5.0f32..40.0, -150.0f32..150.0),
            clearance in prop::sample::select(vec![0.02f32, 0.05, 0.1, 0.3, 0.45]),
            pts in prop::collection::vec((0u32..5, -0.6f32..0.6, -0.6f32..0.6, -0.6f32..0.6), 1..40),
            probes in prop::collection::vec(
                (0usize..40, -1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0, 0.97f32..1.001, 0u32..5),
                1..60,
            ),
        ) {
            let base = Vec3::new(base.0, base.1, base.2);
            let pts: Vec<(u32, Vec3)> =
                pts.iter().map(|&(o, x, y, z)| (o, base + Vec3::new(x, y, z))).collect();
            let mut g = CrowdGrid::new(clearance);
            g.rebuild(pts.iter().copied());
            for &(i, x, y, z, k, me) in &probes {
                let Some(dir) = Vec3::new(x, y, z).try_normalize() else { continue };
                let q = pts[i % pts.len()].1;
                let p = q + dir * (clearance * k);
                prop_assert_eq!(g.blocked(me, p), g.blocked_brute_force(me, p));
                let from = p + dir * (clearance * 0.3 * (k - 0.985) * 50.0);
                prop_assert_eq!(
                    g.blocked_from(me, from, p),
                    g.blocked_from_brute_force(me, from, p)
                );
            }
        }
    }

    /// Special `f32` values for the cell tests: zeros, halves, the
    /// 2²³–2²⁴ and ±2³¹ boundaries, the extremes, subnormals, ±∞, NaN.
    const SPECIAL_F32: [f32; 28] = [
        0.0f32,
        -0.0,
        0.5,
        -0.5,
        1.0,
        -1.0,
        -1.5,
        2.999_999_8,
        -2.999_999_8,
        8_388_607.5,
        -8_388_607.5,
        16_777_217.0,
        -16_777_217.0,
        2_147_483_520.0,
        2_147_483_648.0,
        -2_147_483_648.0,
        -2_147_483_904.0,
        3e9,
        -3e9,
        f32::MAX,
        f32::MIN,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        1e-45,
        -1e-45,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];

    #[test]
    fn floor_i32_matches_floor_cast() {
        let mut xs = SPECIAL_F32.to_vec();
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        for _ in 0..200_000 {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            xs.push(f32::from_bits(state as u32));
        }
        for x in xs {
            assert_eq!(floor_i32(x), x.floor() as i32, "{x:e}");
        }
    }

    /// The cells of points (`cell_of`, three lanes at once where SSE2 is)
    /// are [`floor_i32`] of each coordinate times the inverse cell: the
    /// special values (zeros, halves, the 2²³–2²⁴ and ±2³¹ boundaries, the
    /// extremes, subnormals, ±∞, NaN) in every position, and random bit
    /// patterns, at the crowd's inverse cell and at random ones.
    #[test]
    fn cell_of_is_floor_i32_per_axis() {
        let special = SPECIAL_F32;
        let bits = |c: IVec3| c.to_array();
        for &x in &special {
            for &y in &special {
                for &z in &special {
                    let p = Vec3::new(x, y, z);
                    assert_eq!(bits(cell_of(p, 1.0)), bits(cell_of_scalar(p, 1.0)), "{p:?}");
                }
            }
        }
        let mut state = 0x2545_F491_4F6C_DD1Du64;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        for k in 0..300_000 {
            let r = next();
            let v = next();
            let p = if k % 2 == 0 {
                Vec3::new(
                    f32::from_bits(r as u32),
                    f32::from_bits((r >> 32) as u32),
                    f32::from_bits(v as u32),
                )
            } else {
                // Forest-scale coordinates.
                let u = |b: u64| (b % 2_000_001) as f32 / 1000.0 - 1000.0;
                Vec3::new(u(r), u(r >> 21), u(v))
            };
            let inv = if k % 3 == 0 {
                1.0 / 0.35
            } else {
                f32::from_bits((v >> 32) as u32)
            };
            assert_eq!(
                bits(cell_of(p, inv)),
                bits(cell_of_scalar(p, inv)),
                "{p:?} × {inv:e}"
            );
        }
    }

    #[test]
    fn grouped_rebuild_equals_flat() {
        let groups: Vec<(u32, [Vec3; 3])> = (0..50u32)
            .map(|i| {
                let f = i as f32;
                (
                    i,
                    [
                        Vec3::new(f * 0.37 - 9.0, f * -0.11, 0.2 * f),
                        Vec3::new(-f * 0.05, f.sin(), f.cos()),
                        if i == 7 {
                            Vec3::NAN
                        } else {
                            Vec3::splat(f * 0.01)
                        },
                    ],
                )
            })
            .collect();
        let mut a = CrowdGrid::new(0.3);
        a.rebuild(groups.iter().flat_map(|&(o, ps)| ps.map(|p| (o, p))));
        let mut b = CrowdGrid::new(0.3);
        b.rebuild_groups(groups.iter().copied());
        assert_eq!(a.starts, b.starts);
        assert_eq!(a.entries, b.entries);
        let hashed: Vec<(u32, [HashedPoint; 3])> = groups
            .iter()
            .map(|&(o, ps)| (o, ps.map(|p| b.hashed(p))))
            .collect();
        let mut c = CrowdGrid::new(0.3);
        c.rebuild_hashed_with(hashed.len(), |i| (hashed[i].0, &hashed[i].1), &Serial);
        assert_eq!(a.starts, c.starts);
        assert_eq!(a.entries, c.entries);
    }

    /// Runs each job on its own thread.
    struct Threads;

    impl Jobs for Threads {
        fn run<'a>(&self, jobs: Vec<Job<'a>>) {
            std::thread::scope(|s| {
                for job in jobs {
                    s.spawn(job);
                }
            });
        }
    }

    #[test]
    fn parallel_rebuild_equals_serial_and_brute_force() {
        // Sizes around the job block (1024 sloths) and the bucket counts.
        for (sloths, seed) in [
            (0usize, 1u64),
            (1, 2),
            (1023, 3),
            (1024, 4),
            (1025, 5),
            (3333, 6),
        ] {
            let mut state = seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1;
            let mut unit = || {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                (state >> 40) as f32 / (1u64 << 24) as f32
            };
            let grid = CrowdGrid::new(0.3);
            let groups: Vec<(u32, [HashedPoint; 7])> = (0..sloths as u32)
                .map(|o| {
                    let centre =
                        Vec3::new(unit() * 40.0 - 20.0, unit() * 10.0, unit() * 40.0 - 20.0);
                    let pts = [(); 7].map(|_| {
                        let p = centre + Vec3::new(unit(), unit(), unit()) - 0.5;
                        grid.hashed(if unit() < 0.01 { Vec3::NAN } else { p })
                    });
                    (o, pts)
                })
                .collect();
            let get = |i: usize| (groups[i].0, &groups[i].1);
            let mut serial = grid.clone();
            serial.rebuild_hashed_with(sloths, get, &Serial);
            let mut threaded = grid.clone();
            threaded.rebuild_hashed_with(sloths, get, &Threads);
            assert_eq!(serial.starts, threaded.starts);
            assert_eq!(serial.entries, threaded.entries);
            let finite = groups
                .iter()
                .flat_map(|g| g.1)
                .filter(|h| h.point.is_finite())
                .count();
            assert_eq!(threaded.len(), finite);
            let mut flat = grid.clone();
            flat.rebuild(groups.iter().flat_map(|g| g.1.map(|h| (g.0, h.point))));
            assert_eq!(flat.entries, serial.entries);
            for k in 0..300 {
                let me = (k * 7) as u32 % sloths.max(1) as u32;
                let p = Vec3::new(
                    unit() * 44.0 - 22.0,
                    unit() * 11.0 - 0.5,
                    unit() * 44.0 - 22.0,
                );
                assert_eq!(threaded.blocked(me, p), threaded.blocked_brute_force(me, p));
                // Near a held point too (the brute force is the reference).
                if let Some(&(_, q)) = held(&threaded).get(k * 13 % threaded.len().max(1)) {
                    let p = q + Vec3::new(unit(), unit(), unit()) * 0.4 - 0.2;
                    assert_eq!(threaded.blocked(me, p), threaded.blocked_brute_force(me, p));
                }
            }
        }
    }

    #[test]
    fn group_finite_test_keeps_overflowing_points_and_drops_non_finite() {
        // `all_finite` tests a group by the sum of its coordinates: finite
        // points whose sum overflows must still be kept (the per-point test
        // decides), and any infinity or NaN, of either sign, must be dropped.
        let big = f32::MAX * 0.75;
        let cases: [[Vec3; 3]; 6] = [
            [Vec3::splat(big), Vec3::splat(big), Vec3::ONE],
            [Vec3::splat(-big), Vec3::splat(-big), Vec3::ZERO],
            [
                Vec3::new(big, -big, big),
                Vec3::splat(big),
                Vec3::splat(big),
            ],
            [Vec3::new(f32::INFINITY, 0.0, 0.0), Vec3::ONE, Vec3::ZERO],
            [
                Vec3::new(0.0, f32::NEG_INFINITY, f32::INFINITY),
                Vec3::ONE,
                Vec3::ONE,
            ],
            [Vec3::ONE, Vec3::new(0.0, 0.0, f32::NAN), Vec3::splat(2.0)],
        ];
        let grid = CrowdGrid::new(0.3);
        let groups: Vec<(u32, [HashedPoint; 3])> = cases
            .iter()
            .enumerate()
            .map(|(o, ps)| (o as u32, ps.map(|p| grid.hashed(p))))
            .collect();
        let mut g = grid.clone();
        g.rebuild_hashed_with(groups.len(), |i| (groups[i].0, &groups[i].1), &Serial);
        let finite: Vec<(u32, Vec3)> = cases
            .iter()
            .enumerate()
            .flat_map(|(o, ps)| ps.map(|p| (o as u32, p)))
            .filter(|(_, p)| p.is_finite())
            .collect();
        assert_eq!(g.len(), finite.len());
        assert_eq!(finite.len(), 3 * 3 + 2 + 2 + 2);
        let held = held(&g);
        for &(o, p) in &finite {
            assert!(held.contains(&(o, p)), "finite point {p} of {o} kept");
        }
        assert!(held.iter().all(|(_, p)| p.is_finite()));
    }

    #[test]
    fn own_points_never_block_and_nan_is_ignored() {
        let mut g = CrowdGrid::new(0.3);
        g.rebuild([
            (1, Vec3::ZERO),
            (2, Vec3::new(0.29, 0.0, 0.0)),
            (3, Vec3::NAN),
        ]);
        assert_eq!(g.len(), 2);
        assert!(!g.blocked(1, Vec3::new(0.7, 0.0, 0.0)));
        assert!(g.blocked(1, Vec3::new(0.31, 0.0, 0.0)));
        assert!(!g.blocked(2, Vec3::new(0.31, 0.0, 0.0)));
        assert!(!g.blocked(1, Vec3::NAN));
    }
}
