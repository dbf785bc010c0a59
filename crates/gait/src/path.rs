//! Arc-length helpers over a support's axis polyline, and the static support
//! adjacency graph (which supports touch which) built once per forest.

use std::cmp::Ordering;

use glam::Vec3;
use slothsim_scene::{BoxOverlap, SceneQuery, Support, SupportId};

/// A point on a support's axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisPoint {
    /// Arc length from the first node (metres).
    pub u: f32,
    /// Position on the axis.
    pub point: Vec3,
    /// Unit tangent (toward increasing `u`).
    pub tangent: Vec3,
    /// Radius there.
    pub radius: f32,
}

/// The axis point at arc length `u` (clamped to the support).
pub fn axis_at(s: &Support, u: f32) -> AxisPoint {
    let mut acc = 0.0;
    let last = s.nodes.len() - 2;
    for i in 0..=last {
        let (a, b) = (s.nodes[i], s.nodes[i + 1]);
        let len = a.distance(b);
        if u <= acc + len || i == last {
            let t = ((u - acc) / len).clamp(0.0, 1.0);
            return AxisPoint {
                u: acc + t * len,
                point: a.lerp(b, t),
                tangent: (b - a) / len,
                radius: s.radii[i] + (s.radii[i + 1] - s.radii[i]) * t,
            };
        }
        acc += len;
    }
    unreachable!("supports have at least one segment")
}

/// [`axis_at`] from a support's segment arcs ([`segment_arcs`]: each segment's
/// start arc length and length, as `axis_at` sums and measures them): the
/// segment found by a binary search instead of a walk that measures every
/// segment before it. The same segment and the same operations on the same
/// values, so the same bits (tested: `axis_at_arcs_matches_axis_at`).
// Inlined into both callers: out of line (once `Adjacency::project` called it
// too) it cost the step checks' axis look-ups 1.1 M instructions in the
// steady window.
#[inline(always)]
pub(crate) fn axis_at_arcs(s: &Support, arcs: &[(f32, f32)], u: f32) -> AxisPoint {
    let last = s.nodes.len() - 2;
    // `axis_at` stops at the first `i` with `u <= acc + len` (or the last):
    // `acc + len` is the next segment's `acc` (the same sum), non-decreasing
    // in `i`, so the segments before it are a prefix (a NaN `u` passes none).
    let i = arcs[..last].partition_point(|&(acc, len)| {
        !matches!(
            u.partial_cmp(&(acc + len)),
            Some(Ordering::Less | Ordering::Equal)
        )
    });
    let (a, b) = (s.nodes[i], s.nodes[i + 1]);
    let (acc, len) = arcs[i];
    let t = ((u - acc) / len).clamp(0.0, 1.0);
    AxisPoint {
        u: acc + t * len,
        point: a.lerp(b, t),
        tangent: (b - a) / len,
        radius: s.radii[i] + (s.radii[i + 1] - s.radii[i]) * t,
    }
}

/// Each axis segment's start arc length and length, summed and measured as
/// [`axis_at`] does (for [`axis_at_arcs`]).
fn segment_arcs(s: &Support) -> Vec<(f32, f32)> {
    let mut acc = 0.0f32;
    s.nodes
        .windows(2)
        .map(|w| {
            let len = w[0].distance(w[1]);
            let start = acc;
            acc += len;
            (start, len)
        })
        .collect()
}

/// The closest axis point to `p`.
pub fn project(s: &Support, p: Vec3) -> AxisPoint {
    let mut best = (f32::INFINITY, 0.0f32);
    let mut acc = 0.0;
    for w in s.nodes.windows(2) {
        let (q, t) = slothsim_scene::closest_on_segment(w[0], w[1], p);
        let len = w[0].distance(w[1]);
        let d2 = q.distance_squared(p);
        if d2 < best.0 {
            best = (d2, acc + t * len);
        }
        acc += len;
    }
    axis_at(s, best.1)
}

/// [`project`] with `arcs` = [`segment_arcs`] of `s`: each segment's start
/// arc length and length as `project` sums and measures them.
fn project_arcs(s: &Support, arcs: &[(f32, f32)], p: Vec3) -> AxisPoint {
    let mut best = (f32::INFINITY, 0.0f32);
    for (w, &(acc, len)) in s.nodes.windows(2).zip(arcs) {
        let (q, t) = slothsim_scene::closest_on_segment(w[0], w[1], p);
        let d2 = q.distance_squared(p);
        if d2 < best.0 {
            best = (d2, acc + t * len);
        }
    }
    axis_at_arcs(s, arcs, best.1)
}

/// How far [`surface_gap`] looks for an imported mesh's triangles (m).
const SURFACE_GAP_SEARCH_M: f32 = 0.05;

/// Gap between `p` and the real surface of support `s`: the distance to its
/// triangles for an imported mesh (whose axis and radii are only a guide;
/// at least 5 cm when none is that close), else to its capsules.
pub fn surface_gap(query: SceneQuery<'_>, s: &Support, p: Vec3) -> f32 {
    surface_gap_from(query, s, p, project(s, p))
}

/// [`surface_gap`] from `a`, the closest axis point to `p`.
fn surface_gap_from(query: SceneQuery<'_>, s: &Support, p: Vec3, a: AxisPoint) -> f32 {
    let model = (a.point.distance(p) - a.radius).abs();
    if s.mesh.is_none() {
        return model;
    }
    query
        .surface_distance(s.id, p, SURFACE_GAP_SEARCH_M)
        .unwrap_or(model.max(SURFACE_GAP_SEARCH_M))
}

/// Which supports touch or nearly touch which: `neighbours(id)` lists the
/// supports whose surfaces come within `gap` of it. Built once (static forest).
#[derive(Clone, Debug, Default)]
pub struct Adjacency {
    lists: Vec<Vec<SupportId>>,
    /// Per support, the box holding its surface (min, max corners).
    bounds: Vec<(Vec3, Vec3)>,
    /// Per support, bounds of its axis segments in runs of [`SEGMENT_CHUNK`].
    chunks: Vec<Vec<SegmentChunk>>,
    /// Per support, each axis segment's start arc length and length
    /// ([`segment_arcs`]).
    arcs: Vec<Vec<(f32, f32)>>,
}

/// Axis segments per [`SegmentChunk`].
pub(crate) const SEGMENT_CHUNK: usize = 8;

/// A sphere holding the bounding spheres (midpoint, half length) of a run of
/// axis segments, and the run's largest radius: lets a distance test rule
/// out the whole run before testing its segments.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SegmentChunk {
    /// Centre.
    pub(crate) centre: Vec3,
    /// Radius: the largest `|midpoint − centre| + half length` of the run.
    pub(crate) radius: f32,
    /// Largest support radius at the run's nodes.
    pub(crate) max_radius: f32,
    /// Each segment's own bound ([`SegmentBound::of`]), in run order (the
    /// slots past a short last run unused).
    pub(crate) segs: [SegmentBound; SEGMENT_CHUNK],
}

/// One axis segment's bounding sphere as the torso tests measure it: its
/// midpoint, half its length and the larger of its two end radii, made once
/// per forest instead of at every test (the same values: the same
/// operations on the same nodes).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct SegmentBound {
    /// Midpoint, `(a + b) * 0.5`.
    pub(crate) mid: Vec3,
    /// Half the length, `a.distance(b) * 0.5`.
    pub(crate) half: f32,
    /// The larger radius of the segment's two nodes.
    pub(crate) max_radius: f32,
}

impl SegmentBound {
    /// Segment `i` of support `s`.
    pub(crate) fn of(s: &Support, i: usize) -> Self {
        let (a, b) = (s.nodes[i], s.nodes[i + 1]);
        SegmentBound {
            mid: (a + b) * 0.5,
            half: a.distance(b) * 0.5,
            max_radius: s.radii[i].max(s.radii[i + 1]),
        }
    }
}

pub(crate) fn segment_chunks(s: &Support) -> Vec<SegmentChunk> {
    let segments = s.nodes.len().saturating_sub(1);
    (0..segments.div_ceil(SEGMENT_CHUNK))
        .map(|k| {
            let run = k * SEGMENT_CHUNK..((k + 1) * SEGMENT_CHUNK).min(segments);
            let mid = |i: usize| (s.nodes[i] + s.nodes[i + 1]) * 0.5;
            let half = |i: usize| s.nodes[i].distance(s.nodes[i + 1]) * 0.5;
            let (lo, hi) = run
                .clone()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), i| {
                    (lo.min(mid(i)), hi.max(mid(i)))
                });
            let centre = (lo + hi) * 0.5;
            let radius = run
                .clone()
                .map(|i| mid(i).distance(centre) + half(i))
                .fold(0.0, f32::max);
            let max_radius = s.radii[run.start..=run.end]
                .iter()
                .copied()
                .fold(0.0, f32::max);
            let mut segs = [SegmentBound::default(); SEGMENT_CHUNK];
            for i in run.clone() {
                segs[i - run.start] = SegmentBound::of(s, i);
            }
            SegmentChunk {
                centre,
                radius,
                max_radius,
                segs,
            }
        })
        .collect()
}

impl Adjacency {
    /// Builds the graph with box overlaps around every segment, grown by `gap`.
    pub fn build(query: SceneQuery<'_>, gap: f32) -> Self {
        let scene = query.scene();
        let mut lists = vec![Vec::new(); scene.supports().len()];
        let mut found = Vec::new();
        for s in scene.supports() {
            let mut near: Vec<SupportId> = Vec::new();
            for (i, w) in s.nodes.windows(2).enumerate() {
                let r = s.radii[i].max(s.radii[i + 1]) + gap;
                let (a, b) = (w[0], w[1]);
                let axis = (b - a).normalize();
                let rot = glam::Quat::from_rotation_arc(Vec3::Z, axis);
                let bx = BoxOverlap {
                    center: (a + b) * 0.5,
                    half_extents: Vec3::new(r, r, a.distance(b) * 0.5 + r),
                    rotation: rot,
                };
                if query.overlap_box(&bx, &mut found).is_ok() {
                    near.extend(found.iter().copied().filter(|&o| o != s.id));
                }
            }
            near.sort_unstable();
            near.dedup();
            lists[s.id.0 as usize] = near;
        }
        let chunks = scene.supports().iter().map(segment_chunks).collect();
        let arcs = scene.supports().iter().map(segment_arcs).collect();
        let bounds = scene
            .supports()
            .iter()
            .map(|s| {
                s.nodes.iter().zip(&s.radii).fold(
                    (Vec3::INFINITY, Vec3::NEG_INFINITY),
                    |(lo, hi), (&p, &r)| (lo.min(p - Vec3::splat(r)), hi.max(p + Vec3::splat(r))),
                )
            })
            .collect();
        Adjacency {
            lists,
            bounds,
            chunks,
            arcs,
        }
    }

    /// [`axis_at`] on support `s` (this graph's forest), from its segment
    /// arcs where they are known (the same bits: [`axis_at_arcs`]).
    pub(crate) fn axis_at(&self, s: &Support, u: f32) -> AxisPoint {
        match self.arcs.get(s.id.0 as usize) {
            Some(arcs) if !arcs.is_empty() && arcs.len() + 1 == s.nodes.len() => {
                axis_at_arcs(s, arcs, u)
            }
            _ => axis_at(s, u),
        }
    }

    /// [`project`] on support `s` (this graph's forest), each segment's length
    /// and start arc length read from its segment arcs where they are known,
    /// not measured again, and the axis point by [`axis_at_arcs`]: the same
    /// sums of the same lengths, so the same bits (`project_arcs_matches_project`).
    pub fn project(&self, s: &Support, p: Vec3) -> AxisPoint {
        match self.arcs.get(s.id.0 as usize) {
            Some(arcs) if !arcs.is_empty() && arcs.len() + 1 == s.nodes.len() => {
                project_arcs(s, arcs, p)
            }
            _ => project(s, p),
        }
    }

    /// [`surface_gap`] with the axis point from [`Adjacency::project`] (the
    /// same bits).
    pub fn surface_gap(&self, query: SceneQuery<'_>, s: &Support, p: Vec3) -> f32 {
        surface_gap_from(query, s, p, self.project(s, p))
    }

    /// The box holding a support's surface (min, max corners; empty for an
    /// unknown support).
    pub fn bounds(&self, id: SupportId) -> (Vec3, Vec3) {
        self.bounds
            .get(id.0 as usize)
            .copied()
            .unwrap_or((Vec3::INFINITY, Vec3::NEG_INFINITY))
    }

    /// Bounds of a support's axis segments in runs of [`SEGMENT_CHUNK`]
    /// (empty for an unknown support).
    pub(crate) fn segment_chunks(&self, id: SupportId) -> &[SegmentChunk] {
        self.chunks.get(id.0 as usize).map_or(&[], |v| v.as_slice())
    }

    /// Neighbours of a support, sorted by id.
    pub fn neighbours(&self, id: SupportId) -> &[SupportId] {
        self.lists.get(id.0 as usize).map_or(&[], |v| v.as_slice())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sloth::test_util::xorshift;

    fn bits(a: AxisPoint) -> [u32; 8] {
        [
            a.u.to_bits(),
            a.point.x.to_bits(),
            a.point.y.to_bits(),
            a.point.z.to_bits(),
            a.tangent.x.to_bits(),
            a.tangent.y.to_bits(),
            a.tangent.z.to_bits(),
            a.radius.to_bits(),
        ]
    }

    /// [`axis_at_arcs`] gives [`axis_at`]'s bits: random polylines (2–40
    /// nodes, some segments very short or of zero length), arc lengths every
    /// millimetre and at random from before the first node to past the last,
    /// each segment's end exactly, infinities and NaN.
    #[test]
    fn axis_at_arcs_matches_axis_at() {
        let mut rnd = xorshift(0x9e37_79b9_7f4a_7c15);
        let mut checked = 0u64;
        for case in 0..300 {
            let n = 2 + (rnd() * 39.0) as usize;
            let mut p = Vec3::new(rnd() * 200.0 - 100.0, rnd() * 30.0, rnd() * 200.0 - 100.0);
            let (mut nodes, mut radii) = (Vec::new(), Vec::new());
            for _ in 0..n {
                nodes.push(p);
                radii.push(0.01 + rnd() * 0.4);
                let step = match case % 5 {
                    0 if rnd() < 0.2 => 0.0,
                    1 if rnd() < 0.3 => 1e-6,
                    _ => 0.05 + rnd() * 0.8,
                };
                p += Vec3::new(rnd() - 0.5, rnd() - 0.3, rnd() - 0.5) * step;
            }
            let sup = Support::new(nodes, radii);
            let arcs = segment_arcs(&sup);
            let len = sup.length();
            let mut us: Vec<f32> = vec![f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 0.0, -0.0, len];
            us.extend(
                arcs.iter()
                    .flat_map(|&(acc, l)| [acc, acc + l, (acc + l).next_up()]),
            );
            let mut u = -0.5f32;
            while u < len + 0.5 {
                us.push(u);
                u += 0.001;
            }
            us.extend((0..200).map(|_| rnd() * (len + 1.0) - 0.5));
            for &u in &us {
                assert_eq!(
                    bits(axis_at_arcs(&sup, &arcs, u)),
                    bits(axis_at(&sup, u)),
                    "case {case} u {u}"
                );
                checked += 1;
            }
        }
        assert!(checked > 100_000, "{checked}");
    }

    /// [`project_arcs`] gives [`project`]'s bits: random polylines (2–40
    /// nodes, some segments very short or of zero length), points near the
    /// axis, far from it, at its nodes and segment midpoints, past its ends,
    /// infinite and NaN.
    #[test]
    fn project_arcs_matches_project() {
        let mut rnd = xorshift(0x2545_f491_4f6c_dd1d);
        let mut checked = 0u64;
        for case in 0..300 {
            let n = 2 + (rnd() * 39.0) as usize;
            let mut p = Vec3::new(rnd() * 200.0 - 100.0, rnd() * 30.0, rnd() * 200.0 - 100.0);
            let (mut nodes, mut radii) = (Vec::new(), Vec::new());
            for _ in 0..n {
                nodes.push(p);
                radii.push(0.01 + rnd() * 0.4);
                let step = match case % 5 {
                    0 if rnd() < 0.2 => 0.0,
                    1 if rnd() < 0.3 => 1e-6,
                    _ => 0.05 + rnd() * 0.8,
                };
                p += Vec3::new(rnd() - 0.5, rnd() - 0.3, rnd() - 0.5) * step;
            }
            let sup = Support::new(nodes.clone(), radii);
            let arcs = segment_arcs(&sup);
            let mut ps = vec![
                Vec3::NAN,
                Vec3::INFINITY,
                Vec3::new(f32::NEG_INFINITY, 0.0, 1.0),
            ];
            ps.extend(nodes.iter().copied());
            ps.extend(nodes.windows(2).map(|w| (w[0] + w[1]) * 0.5));
            for _ in 0..400 {
                let at = nodes[(rnd() * n as f32) as usize % n];
                let scale = [0.01, 0.3, 2.0, 50.0][(rnd() * 4.0) as usize % 4];
                ps.push(at + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * scale);
            }
            for &q in &ps {
                assert_eq!(
                    bits(project_arcs(&sup, &arcs, q)),
                    bits(project(&sup, q)),
                    "case {case} p {q}"
                );
                checked += 1;
            }
        }
        assert!(checked > 100_000, "{checked}");
    }
}
