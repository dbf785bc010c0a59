//! Torso ↔ support collision (no thesis section: the thesis' model could pass
//! through supports; SPEC "Grips must not slide" and the judge's penetration
//! measure): the torso capsule's depth in a support's segments, with bounds
//! that skip segments (and runs of them) that cannot count.

use glam::{Quat, Vec3};
use slothsim_scene::SupportId;
use smallvec::SmallVec;

use crate::path::{SEGMENT_CHUNK, SegmentBound, SegmentChunk};
use crate::rigdata::BODY_RADIUS;

use super::{LocoView, Sloth};

/// A step may not put the body deeper than this into a support.
pub(super) const STANCE_MAX_PENETRATION: f32 = 0.005;

/// Most bodies [`Sloth::bodies_penetrate_near`] takes at once.
pub(super) const MAX_BODIES: usize = 16;

/// Whether the torso capsule enters a support deeper than `depth`: the same
/// as `torso_penetration(s, torso, depth) > depth`, returning at the first
/// such segment. Runs of segments whose `chunks` bound (see
/// [`SegmentChunk`]) rules out every segment's [`TorsoBound::may_exceed`]
/// are skipped whole; without bounds (`chunks` not matching `s`) every
/// segment is tested.
fn torso_penetrates(
    s: &slothsim_scene::Support,
    chunks: &[SegmentChunk],
    torso: [Vec3; 2],
    depth: f32,
) -> bool {
    torso_penetrates_bounded(s, chunks, torso, &TorsoBound::new(torso), depth)
}

/// [`torso_penetrates`] with the torso's bound `bound` (`TorsoBound::new(torso)`)
/// made once by the caller for every support it tests.
fn torso_penetrates_bounded(
    s: &slothsim_scene::Support,
    chunks: &[SegmentChunk],
    torso: [Vec3; 2],
    bound: &TorsoBound,
    depth: f32,
) -> bool {
    let segments = s.nodes.len().saturating_sub(1);
    if chunks.len() != segments.div_ceil(SEGMENT_CHUNK) {
        return (0..segments)
            .any(|i| bound.may_exceed(s, i, depth) && segment_depth(s, i, torso) > depth);
    }
    chunks.iter().enumerate().any(|(k, c)| {
        bound.may_reach_chunk(c, depth)
            && (k * SEGMENT_CHUNK..((k + 1) * SEGMENT_CHUNK).min(segments)).any(|i| {
                bound.may_exceed_seg(&c.segs[i - k * SEGMENT_CHUNK], depth)
                    && segment_depth(s, i, torso) > depth
            })
    })
}

/// Whether the torso capsule `torso` comes within `margin` of support `s`'s
/// surface (segment by segment, as [`torso_penetrates`] at depth `−margin`).
pub(super) fn torso_within(
    s: &slothsim_scene::Support,
    chunks: &[SegmentChunk],
    torso: [Vec3; 2],
    margin: f32,
) -> bool {
    torso_penetrates(s, chunks, torso, -margin)
}

/// Whether any of the torso capsules `torsos` enters support `s` deeper than
/// `depth`: the same as `torsos.iter().any(|&t| torso_penetrates(s, chunks, t, depth))`
/// (an OR taken in another order), with the sphere `all` around all the
/// torsos' spheres ([`TorsoBound::around`]) tested first: a run of segments,
/// or a segment, it cannot reach is skipped for all the torsos at once (a
/// step's stances put the body within centimetres of itself, so most are
/// skipped once instead of once per stance).
fn torsos_penetrate(
    s: &slothsim_scene::Support,
    chunks: &[SegmentChunk],
    torsos: &[[Vec3; 2]],
    bounds: &[TorsoBound],
    path: &[f32],
    all: &TorsoBound,
    depth: f32,
) -> bool {
    let segments = s.nodes.len().saturating_sub(1);
    if chunks.len() != segments.div_ceil(SEGMENT_CHUNK) {
        return torsos
            .iter()
            .any(|&t| torso_penetrates(s, chunks, t, depth));
    }
    chunks.iter().enumerate().any(|(k, c)| {
        if !all.may_reach_chunk(c, depth) {
            return false;
        }
        (k * SEGMENT_CHUNK..((k + 1) * SEGMENT_CHUNK).min(segments)).any(|i| {
            let seg = &c.segs[i - k * SEGMENT_CHUNK];
            if !all.may_exceed_seg(seg, depth) {
                return false;
            }
            // The last torso whose depth in this segment was measured, and
            // that depth: a torso whose ends lie near its ends is ruled out
            // by it ([`depth_bound_rules_out`]), their distance bounded by
            // the path from one to the other (`path`). A step's stances come
            // in the order of its arc, so the torso measured last is the
            // nearest, and the torsos it rules out follow it in a run.
            let taper = (s.radii[i + 1] - s.radii[i]).abs();
            let mut last: Option<(usize, f32)> = None;
            for t in 0..torsos.len() {
                if let Some((p, dp)) = last
                    && depth_bound_rules_out(path[t] - path[p], depth - dp - taper)
                {
                    continue;
                }
                if !bounds[t].may_exceed_seg(seg, depth) {
                    continue;
                }
                let d = segment_depth(s, i, torsos[t]);
                if d > depth {
                    return true;
                }
                last = Some((t, d));
            }
            false
        })
    })
}

/// Rounding allowance of [`depth_bound_rules_out`] (metres): 1 mm, far
/// above the rounding of [`segment_depth`] at forest-scale coordinates.
const DEPTH_BOUND_MARGIN: f32 = 1e-3;

/// Whether torso `b` is surely no deeper in a segment than `room` more than
/// torso `a` is (`room`: the depth limit less `a`'s depth and the segment's
/// taper |r₁ − r₀|), given `moved`, at least the larger distance of `b`'s
/// ends from `a`'s ([`ends_moved`], or a sum of them along a path of
/// torsos): `moved` is within `room` less [`DEPTH_BOUND_MARGIN`]. Each point
/// of `b`'s axis, `b₀ + s (b₁ − b₀)`, lies within `moved` of `a`'s point at
/// the same `s`, so `b`'s distance to the segment is at most `a`'s plus
/// `moved`; the segment's radius at `b`'s closest point differs from that at
/// `a`'s by at most the taper; so `b`'s [`segment_depth`] is at most `a`'s
/// plus `moved` plus the taper (a Lipschitz bound of the depth in the
/// torso's ends). NaN rules nothing out.
#[inline]
fn depth_bound_rules_out(moved: f32, room: f32) -> bool {
    moved <= room - DEPTH_BOUND_MARGIN
}

/// The larger distance of torso `b`'s ends from torso `a`'s.
fn ends_moved(a: [Vec3; 2], b: [Vec3; 2]) -> f32 {
    a[0].distance(b[0]).max(a[1].distance(b[1]))
}

/// The path along torsos `torsos` in their order: `path[k]` sums
/// [`ends_moved`] from each torso to the next up to torso `k` (so
/// `path[t] − path[p]`, `p < t`, is at least `ends_moved(torsos[p], torsos[t])`,
/// by the triangle inequality in each end).
fn torso_path(torsos: &[[Vec3; 2]]) -> [f32; MAX_BODIES] {
    let mut path = [0.0; MAX_BODIES];
    for k in 1..torsos.len() {
        path[k] = path[k - 1] + ends_moved(torsos[k - 1], torsos[k]);
    }
    path
}

/// Deepest penetration of the torso capsule (radius [`BODY_RADIUS`]) into a
/// support, or `floor` if none is deeper. Segments whose bounding spheres
/// rule out beating `floor` are skipped (most of them).
/// Runs of segments whose `chunks` bound rules them all out are skipped
/// whole (as in [`torso_penetrates`]; every segment is tested without bounds).
pub(super) fn torso_penetration(
    s: &slothsim_scene::Support,
    chunks: &[SegmentChunk],
    torso: [Vec3; 2],
    floor: f32,
) -> f32 {
    let bound = TorsoBound::new(torso);
    let segments = s.nodes.len().saturating_sub(1);
    let mut depth = floor;
    if chunks.len() != segments.div_ceil(SEGMENT_CHUNK) {
        for i in 0..segments {
            if bound.may_exceed(s, i, depth) {
                depth = depth.max(segment_depth(s, i, torso));
            }
        }
        return depth;
    }
    for (k, c) in chunks.iter().enumerate() {
        if bound.may_reach_chunk(c, depth) {
            for i in k * SEGMENT_CHUNK..((k + 1) * SEGMENT_CHUNK).min(segments) {
                if bound.may_exceed_seg(&c.segs[i - k * SEGMENT_CHUNK], depth) {
                    depth = depth.max(segment_depth(s, i, torso));
                }
            }
        }
    }
    depth
}

/// Depth of the torso capsule in segment `i` of support `s`.
fn segment_depth(s: &slothsim_scene::Support, i: usize, torso: [Vec3; 2]) -> f32 {
    let (d, t) = segment_distance(torso[0], torso[1], s.nodes[i], s.nodes[i + 1]);
    let r = s.radii[i] + (s.radii[i + 1] - s.radii[i]) * t;
    BODY_RADIUS + r - d
}

/// The torso's bounding sphere (centre, half length).
#[derive(Clone, Copy)]
struct TorsoBound {
    centre: Vec3,
    half: f32,
}

impl TorsoBound {
    pub(super) fn new(torso: [Vec3; 2]) -> Self {
        Self {
            centre: (torso[0] + torso[1]) * 0.5,
            half: torso[0].distance(torso[1]) * 0.5,
        }
    }

    /// A sphere holding every sphere of `bounds`: centred on their centres'
    /// mean, its half length the farthest reach of one of them from there,
    /// 0.1 mm more for rounding. Whatever segment or run one of them may
    /// reach ([`Self::may_exceed`], [`Self::may_reach_chunk`]: both only
    /// grow with `half`), it may reach too: `|centre − c| ≤ |centre_i − c|
    /// + |centre − centre_i|` (triangle inequality).
    fn around(bounds: &[TorsoBound]) -> Self {
        let centre =
            bounds.iter().fold(Vec3::ZERO, |a, b| a + b.centre) / bounds.len().max(1) as f32;
        let half = bounds
            .iter()
            .map(|b| b.centre.distance(centre) + b.half)
            .fold(0.0, f32::max);
        Self {
            centre,
            half: half + 1e-4,
        }
    }

    /// Whether segment `i` of `s` could hold the torso deeper than `depth`:
    /// the segment distance is at least |centres| − both half lengths
    /// (triangle inequality); 0.1 mm margin.
    fn may_exceed(&self, s: &slothsim_scene::Support, i: usize, depth: f32) -> bool {
        self.may_exceed_seg(&SegmentBound::of(s, i), depth)
    }

    /// [`Self::may_exceed`] for the segment of bound `seg` ([`SegmentBound::of`],
    /// kept in its [`SegmentChunk`]): the same expression on the same values.
    #[inline]
    fn may_exceed_seg(&self, seg: &SegmentBound, depth: f32) -> bool {
        let reach = BODY_RADIUS + seg.max_radius - depth + self.half + seg.half + 1e-4;
        reach > 0.0 && self.centre.distance_squared(seg.mid) <= reach * reach
    }

    /// False only if [`TorsoBound::may_exceed`] is false for every segment of
    /// the run `chunk` bounds. Segment `i`'s test distance is at most
    /// `BODY_RADIUS + max_radius − depth + half + k_i + 1e-4`, and its
    /// midpoint lies within `chunk.radius − k_i` of the chunk's centre, so
    /// beyond this sphere (1 mm more for rounding) no segment passes.
    fn may_reach_chunk(&self, chunk: &SegmentChunk, depth: f32) -> bool {
        let reach = chunk.radius + BODY_RADIUS + chunk.max_radius - depth + self.half + 1e-4 + 1e-3;
        reach <= 0.0 || self.centre.distance_squared(chunk.centre) <= reach * reach
    }
}

/// Distance between segments p0–p1 and q0–q1, and the parameter on q.
fn segment_distance(p0: Vec3, p1: Vec3, q0: Vec3, q1: Vec3) -> (f32, f32) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    let (s, t);
    if a <= 1e-12 && e <= 1e-12 {
        return (p0.distance(q0), 0.0);
    }
    if a <= 1e-12 {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(r);
        if e <= 1e-12 {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > 1e-12 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    ((p0 + d1 * s).distance(q0 + d2 * t), t)
}

/// Whether support `id`'s bounding box comes within `margin` of the torso
/// capsule `torso` (its box grown by the body's radius and `margin`): a
/// support apart from that box cannot be within `margin` of the body.
pub(super) fn torso_box_meets(
    env: &LocoView<'_>,
    torso: [Vec3; 2],
    margin: f32,
    id: SupportId,
) -> bool {
    let grow = Vec3::splat(BODY_RADIUS + margin);
    let (lo, hi) = (torso[0].min(torso[1]) - grow, torso[0].max(torso[1]) + grow);
    let (blo, bhi) = env.adjacency.bounds(id);
    !(blo.cmpgt(hi).any() || bhi.cmplt(lo).any())
}

/// A sloth's [`Sloth::near_supports`] listed once
/// ([`Sloth::near_supports_list`]): a step check tests the bodies of its
/// stances, of its arc and of its end against the supports near the grips
/// of the sloth as it stands, the same list each time (the same supports in
/// the same order, so each test is the same `any` over the same pure tests).
pub(super) struct NearSupports(SmallVec<[SupportId; 32]>);

impl NearSupports {
    /// The supports, in [`Sloth::near_supports`]'s order.
    pub(super) fn iter(&self) -> impl Iterator<Item = SupportId> + '_ {
        self.0.iter().copied()
    }
}

impl Sloth {
    /// Whether a body at (`pos`, `rot`) would enter a support near the grips
    /// (e.g. walking a branch into its trunk).
    ///
    /// Each support is tested once ([`Self::near_supports_list`]), with the
    /// torso's bound made once: the same `any` over the same pure tests.
    pub(super) fn body_penetrates(&self, env: &LocoView<'_>, pos: Vec3, rot: Quat) -> bool {
        Self::body_penetrates_near(env, &self.near_supports_list(env), pos, rot)
    }

    /// [`Self::body_penetrates`] among the supports `near` (a sloth's
    /// [`NearSupports`]).
    pub(super) fn body_penetrates_near(
        env: &LocoView<'_>,
        near: &NearSupports,
        pos: Vec3,
        rot: Quat,
    ) -> bool {
        let scene = env.scene();
        let torso = [
            pos + rot * env.rig.torso_ms[0],
            pos + rot * env.rig.torso_ms[1],
        ];
        let bound = TorsoBound::new(torso);
        near.0.iter().any(|&id| {
            torso_penetrates_bounded(
                scene.support(id),
                env.adjacency.segment_chunks(id),
                torso,
                &bound,
                STANCE_MAX_PENETRATION,
            )
        })
    }

    /// Whether any of the bodies `bodies` (position, rotation; at most
    /// [`MAX_BODIES`]) would enter a support among `near` (a sloth's
    /// [`NearSupports`]): the same as
    /// `bodies.iter().any(|&(pos, rot)| Self::body_penetrates_near(env, near, pos, rot))`,
    /// each support looked up once for all of them (see [`torsos_penetrate`]).
    pub(super) fn bodies_penetrate_near(
        env: &LocoView<'_>,
        near: &NearSupports,
        bodies: &[(Vec3, Quat)],
    ) -> bool {
        Self::bodies_deeper_near(env, near, bodies, STANCE_MAX_PENETRATION)
    }

    /// Whether any of the bodies `bodies` (at most [`MAX_BODIES`]) enters a
    /// support among `near` deeper than `depth` (negative: comes within
    /// `−depth` of its surface): [`Self::bodies_penetrate_near`] at another
    /// depth, the same exact test of each torso ([`torsos_penetrate`]).
    pub(super) fn bodies_deeper_near(
        env: &LocoView<'_>,
        near: &NearSupports,
        bodies: &[(Vec3, Quat)],
        depth: f32,
    ) -> bool {
        assert!(bodies.len() <= MAX_BODIES, "at most {MAX_BODIES} bodies");
        if bodies.is_empty() {
            return false;
        }
        let scene = env.scene();
        let mut torsos = [[Vec3::ZERO; 2]; MAX_BODIES];
        for (t, &(pos, rot)) in torsos.iter_mut().zip(bodies) {
            *t = [
                pos + rot * env.rig.torso_ms[0],
                pos + rot * env.rig.torso_ms[1],
            ];
        }
        let torsos = &torsos[..bodies.len()];
        // Only the bodies' own bounds are made (the rest stay unused).
        let mut bounds = [TorsoBound {
            centre: Vec3::ZERO,
            half: 0.0,
        }; MAX_BODIES];
        for (b, &t) in bounds.iter_mut().zip(torsos) {
            *b = TorsoBound::new(t);
        }
        let bounds = &bounds[..bodies.len()];
        let all = TorsoBound::around(bounds);
        let path = torso_path(torsos);
        near.0.iter().any(|&id| {
            torsos_penetrate(
                scene.support(id),
                env.adjacency.segment_chunks(id),
                torsos,
                bounds,
                &path,
                &all,
                depth,
            )
        })
    }

    /// The supports the limbs hold (each once) and their neighbours: where
    /// the body could enter a support (the judge and the step checks alike).
    pub(super) fn near_supports<'w>(
        &self,
        env: &'w LocoView<'_>,
    ) -> impl Iterator<Item = SupportId> + 'w {
        let held = self.limb_map(|l| l.grip.support);
        (0..4)
            .filter(move |&k| !held[..k].contains(&held[k]))
            .flat_map(move |k| {
                std::iter::once(held[k]).chain(env.adjacency.neighbours(held[k]).iter().copied())
            })
    }

    /// [`Self::near_supports_list`] listed, for the several body tests of
    /// one step check.
    /// Each support once, in the order of its first mention (a held
    /// support is also its held neighbour's neighbour).
    pub(super) fn near_supports_list(&self, env: &LocoView<'_>) -> NearSupports {
        let mut ids = SmallVec::new();
        let mut add = |id: SupportId| {
            if !ids.contains(&id) {
                ids.push(id);
            }
        };
        for k in 0..4 {
            let held = self.limbs[k].grip.support;
            if (0..k).any(|j| self.limbs[j].grip.support == held) {
                continue;
            }
            add(held);
            for &id in env.adjacency.neighbours(held) {
                add(id);
            }
        }
        NearSupports(ids)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sloth::test_util::{walk_presets, xorshift};

    /// The list a step check shares among its body tests
    /// (`near_supports_list`) is `near_supports` each once, in the order of
    /// first mention, and a body test over it answers as one over
    /// `near_supports` itself (every preset's walk, bodies moved up to 0.3 m
    /// around the sloth's own).
    #[test]
    fn near_supports_list_matches_near_supports() {
        let mut rnd = xorshift(0x4e45);
        let (mut bodies, mut hits) = (0, 0);
        walk_presets(10, |_, view, _, sloth| {
            let list = sloth.near_supports_list(view);
            let mut want: Vec<SupportId> = Vec::new();
            for id in sloth.near_supports(view) {
                if !want.contains(&id) {
                    want.push(id);
                }
            }
            assert_eq!(list.iter().collect::<Vec<_>>(), want);
            let scene = view.scene();
            for _ in 0..8 {
                let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.6;
                let (pos, rot) = (sloth.body_pos + d, sloth.body_rot);
                let torso = [
                    pos + rot * view.rig.torso_ms[0],
                    pos + rot * view.rig.torso_ms[1],
                ];
                let each = sloth.near_supports(view).any(|id| {
                    torso_penetrates(scene.support(id), &[], torso, STANCE_MAX_PENETRATION)
                });
                assert_eq!(Sloth::body_penetrates_near(view, &list, pos, rot), each);
                assert_eq!(
                    Sloth::bodies_penetrate_near(view, &list, &[(sloth.body_pos, rot), (pos, rot)]),
                    each || sloth.body_penetrates(view, sloth.body_pos, rot)
                );
                bodies += 1;
                hits += usize::from(each);
            }
        });
        assert!(
            hits > 0 && hits < bodies,
            "{hits} of {bodies} bodies in a support"
        );
    }

    /// A random polyline support of `n` nodes (radii 0.02–0.32 m), its
    /// segment chunks and its nodes.
    fn random_support(
        rnd: &mut impl FnMut() -> f32,
        n: usize,
    ) -> (slothsim_scene::Support, Vec<SegmentChunk>, Vec<Vec3>) {
        let mut p = Vec3::new(rnd() * 20.0, rnd() * 10.0, rnd() * 20.0);
        let mut nodes = Vec::new();
        let mut radii = Vec::new();
        for _ in 0..n {
            nodes.push(p);
            radii.push(0.02 + rnd() * 0.3);
            p += Vec3::new(rnd() - 0.5, rnd() * 0.6 - 0.2, rnd() - 0.5) * 0.8;
        }
        let sup = slothsim_scene::Support::new(nodes.clone(), radii);
        let chunks = crate::path::segment_chunks(&sup);
        (sup, chunks, nodes)
    }

    /// The chunk bounds only skip segments that could not count: the same
    /// answer as testing every segment, on random polylines and torsos (the
    /// chunked path with the segments' bounds kept in their chunks, the other
    /// making them at each test).
    #[test]
    fn chunked_torso_penetrates_matches_every_segment() {
        let mut rnd = xorshift(0xfeed);
        let mut hits = 0;
        for n in [2usize, 3, 8, 9, 17, 40] {
            for _ in 0..60 {
                let (sup, chunks, nodes) = random_support(&mut rnd, n);
                for _ in 0..200 {
                    let k = (rnd() * (n - 1) as f32) as usize;
                    let near = nodes[k].lerp(nodes[k + 1], rnd());
                    let c = near + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 1.5;
                    let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.6;
                    let torso = [c - d, c + d];
                    for depth in [-0.2, 0.0, STANCE_MAX_PENETRATION, 0.05] {
                        let all = torso_penetrates(&sup, &[], torso, depth);
                        assert_eq!(all, torso_penetrates(&sup, &chunks, torso, depth));
                        hits += usize::from(all);
                        // The judge's deepest penetration: the same bits either way.
                        let deepest = torso_penetration(&sup, &[], torso, depth);
                        assert_eq!(
                            deepest.to_bits(),
                            torso_penetration(&sup, &chunks, torso, depth).to_bits()
                        );
                    }
                }
            }
        }
        assert!(hits > 100, "{hits}");
    }

    /// Several torsos at once (with the bound around them all): the same
    /// answer as each torso on its own, on random polylines and clusters of
    /// torsos (close, as a step's stances, and far apart).
    /// [`torsos_penetrate`] over `torsos` at each of `depths` gives the answer
    /// of each torso tested on its own; counts the hits (`counts[0]`) and
    /// misses (`counts[1]`).
    fn at_once_matches_one_by_one(
        sup: &slothsim_scene::Support,
        chunks: &[SegmentChunk],
        torsos: &[[Vec3; 2]],
        depths: [f32; 4],
        counts: &mut [usize; 2],
    ) {
        let bounds: Vec<TorsoBound> = torsos.iter().map(|&t| TorsoBound::new(t)).collect();
        let all = TorsoBound::around(&bounds);
        let path = torso_path(torsos);
        for depth in depths {
            let one_by_one = torsos
                .iter()
                .any(|&t| torso_penetrates(sup, chunks, t, depth));
            let at_once = torsos_penetrate(sup, chunks, torsos, &bounds, &path, &all, depth);
            assert_eq!(one_by_one, at_once);
            counts[usize::from(!one_by_one)] += 1;
        }
    }

    #[test]
    fn torsos_at_once_match_one_by_one() {
        let mut rnd = xorshift(0x5eed);
        let mut counts = [0usize; 2];
        for n in [2usize, 3, 8, 9, 17, 40] {
            for _ in 0..40 {
                let (sup, chunks, nodes) = random_support(&mut rnd, n);
                for _ in 0..200 {
                    let k = (rnd() * (n - 1) as f32) as usize;
                    let near = nodes[k].lerp(nodes[k + 1], rnd());
                    let spread = [0.02, 0.1, 1.0][(rnd() * 3.0) as usize % 3];
                    let count = 1 + (rnd() * MAX_BODIES as f32) as usize % MAX_BODIES;
                    let c = near + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 1.5;
                    let torsos: Vec<[Vec3; 2]> = (0..count)
                        .map(|_| {
                            let ck = c + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * spread;
                            let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.6;
                            [ck - d, ck + d]
                        })
                        .collect();
                    let depths = [-0.2, 0.0, STANCE_MAX_PENETRATION, 0.05];
                    at_once_matches_one_by_one(&sup, &chunks, &torsos, depths, &mut counts);
                }
            }
        }
        let [hits, misses] = counts;
        assert!(hits > 100 && misses > 100, "{hits} {misses}");
    }

    /// The depth bound of [`depth_bound_rules_out`]: where it rules a torso
    /// out, that torso's [`segment_depth`] is within the limit. Random
    /// segments (tapering, short and long, some nearly parallel to the
    /// torsos) and pairs of torsos a few centimetres apart, the first placed
    /// so that its depth lies around the limit.
    #[test]
    fn depth_bound_never_rules_out_a_deeper_torso() {
        let mut rnd = xorshift(0xb0d1);
        let mut v = || Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
        let mut ruled_out = 0;
        for _ in 0..200_000 {
            let q0 = v() * 40.0;
            let len = [0.01, 0.2, 1.0][(v().x + 0.5) as usize % 3 + usize::from(v().y > 0.0)];
            let dir = v().normalize_or(Vec3::X);
            let q1 = q0 + dir * len;
            let radii = vec![0.02 + (v().x + 0.5) * 0.3, 0.02 + (v().y + 0.5) * 0.3];
            let sup = slothsim_scene::Support::new(vec![q0, q1], radii);
            // The first torso: nearly parallel to the segment or not, its
            // axis about BODY_RADIUS + r from the segment's (depth ~ 0).
            let along = if v().x > 0.0 {
                dir + v() * 0.02
            } else {
                v().normalize_or(Vec3::Y)
            } * 0.3;
            let off = dir
                .any_orthonormal_vector()
                .lerp(v(), 0.3)
                .normalize_or(Vec3::Y);
            let gap = BODY_RADIUS + sup.radii[0] + v().x * 0.04;
            let c = q0.lerp(q1, v().y + 0.5) + off * gap;
            let a = [c - along, c + along];
            let step = [0.002, 0.01, 0.05][(v().z + 0.5) as usize % 3 + usize::from(v().x > 0.2)];
            let b = [a[0] + v() * step, a[1] + v() * step];
            let taper = (sup.radii[1] - sup.radii[0]).abs();
            for depth in [-0.05, 0.0, STANCE_MAX_PENETRATION, 0.02] {
                let da = segment_depth(&sup, 0, a);
                if depth_bound_rules_out(ends_moved(a, b), depth - da - taper) {
                    ruled_out += 1;
                    let db = segment_depth(&sup, 0, b);
                    assert!(db <= depth, "{a:?} {b:?} {q0} {q1} {depth} {da} {db}");
                }
            }
        }
        assert!(ruled_out > 20_000, "{ruled_out}");
    }

    /// A step's arc of torsos (sixteen, each a few millimetres to
    /// centimetres on from the last, turning as they go) passing along and
    /// into random polylines: [`torsos_penetrate`], which rules torsos out by
    /// the depth of the last one measured, gives the answer of each torso
    /// tested on its own.
    #[test]
    fn torsos_along_an_arc_match_one_by_one() {
        let mut rnd = xorshift(0xa7c5);
        let mut counts = [0usize; 2];
        for n in [2usize, 3, 9, 17] {
            for _ in 0..60 {
                let (sup, chunks, nodes) = random_support(&mut rnd, n);
                for _ in 0..300 {
                    let k = (rnd() * (n - 1) as f32) as usize;
                    let axis = nodes[k + 1] - nodes[k];
                    let near = nodes[k].lerp(nodes[k + 1], rnd());
                    let r = sup.radii[k];
                    let side = axis
                        .any_orthonormal_vector()
                        .lerp(Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5), 0.5)
                        .normalize_or(Vec3::Y);
                    let mut c = near + side * (BODY_RADIUS + r + (rnd() - 0.5) * 0.06);
                    let mut along = if rnd() > 0.5 {
                        axis.normalize_or(Vec3::X)
                    } else {
                        Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize_or(Vec3::Z)
                    } * 0.25;
                    let step = [0.003, 0.01, 0.03][(rnd() * 3.0) as usize % 3];
                    let count = 2 + (rnd() * (MAX_BODIES - 1) as f32) as usize % (MAX_BODIES - 1);
                    let torsos: Vec<[Vec3; 2]> = (0..count)
                        .map(|_| {
                            c += Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * step;
                            along = (along
                                + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * step)
                                .normalize_or(Vec3::Z)
                                * 0.25;
                            [c - along, c + along]
                        })
                        .collect();
                    let depths = [-0.02, 0.0, STANCE_MAX_PENETRATION, 0.02];
                    at_once_matches_one_by_one(&sup, &chunks, &torsos, depths, &mut counts);
                }
            }
        }
        let [hits, misses] = counts;
        assert!(hits > 1_000 && misses > 1_000, "{hits} {misses}");
    }
}
