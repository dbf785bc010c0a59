//! Trace queries against a scene: line traces (closest hit), sphere sweeps and
//! oriented-box overlaps, accelerated by an `obvhs` BVH2 over analytic
//! primitives (tapered capsules; triangles for imported meshes).
//!
//! [`TraceScene`] owns the scene and its BVH and is built once (the forest is
//! static). [`SceneQuery`] is the borrowed view every caller traces through;
//! it offers single queries, a batched API that runs many traces in parallel
//! (rayon), and brute-force twins used as references by tests and baselines.
//!
//! Length: the three query kinds share the BVH traversal and the primitive intersectors; splitting them would scatter one traversal over files.

use std::time::Duration;

use glam::{Quat, Vec3, Vec3A, Vec4};
use obvhs::{
    Boundable, BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh},
    ray::safe_inverse,
};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::{
    Scene, SupportId, SupportKind, TraceError,
    primitive::{HotPrim, Primitive},
};

/// A line trace: from `origin` along `dir` (any length ≠ 0; normalised) up to `max_dist` metres.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LineTrace {
    /// Start point, world space.
    pub origin: Vec3,
    /// Direction, world space (need not be unit).
    pub dir: Vec3,
    /// Maximum distance (metres, ≥ 0; may be infinite).
    pub max_dist: f32,
}

/// A sphere sweep: a sphere of `radius` moving like a [`LineTrace`].
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SphereSweep {
    /// The path of the sphere's centre.
    pub line: LineTrace,
    /// Sphere radius (metres, ≥ 0; 0 is a line trace).
    pub radius: f32,
}

/// An oriented box for overlap queries.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoxOverlap {
    /// Box centre, world space.
    pub center: Vec3,
    /// Half extents along the box's local axes (metres, ≥ 0).
    pub half_extents: Vec3,
    /// Box orientation (local → world).
    pub rotation: Quat,
}

/// One batched trace request.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum TraceRequest {
    /// Closest hit along a line.
    Line(LineTrace),
    /// Closest hit of a swept sphere.
    Sphere(SphereSweep),
}

/// The closest surface hit of a trace.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TraceHit {
    /// Contact point on the support's surface, world space.
    pub point: Vec3,
    /// Outward unit surface normal at `point` (facing the trace).
    pub normal: Vec3,
    /// The support hit.
    pub support: SupportId,
    /// Its kind.
    pub kind: SupportKind,
    /// Distance travelled by the line (or the sphere's centre) to the hit.
    pub distance: f32,
}

/// Result of one trace: `Ok(None)` is a miss.
pub type TraceResult = Result<Option<TraceHit>, TraceError>;

/// BVH statistics, for `scene info`.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct BvhStats {
    /// Traced primitives (capsule segments + triangles).
    pub primitives: usize,
    /// BVH nodes.
    pub nodes: usize,
    /// Leaf nodes.
    pub leaves: usize,
    /// Tree depth.
    pub depth: usize,
    /// Build time, milliseconds.
    pub build_ms: f64,
}

struct PrimBounds(Aabb);

impl Boundable for PrimBounds {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// Deepest wide-BVH tree the fixed traversal stack supports.
const MAX_DEPTH: usize = 64;

/// One node of the traced 8-wide BVH: the topology of obvhs' `CwBvh` (child
/// and primitive bases, inner-child mask, child meta) with its children's
/// exact (uncompressed) boxes, stored as planes for a 4-lane slab test.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct WideNode {
    /// Children 0–3 and 4–7: `[min_x, max_x, min_y, max_y, min_z, max_z]`.
    /// Empty slots hold an inverted (never hit) box.
    planes: [[Vec4; 6]; 2],
    /// `CwBvhNode::child_meta` as a little-endian `u64`.
    meta: u64,
    child_base: u32,
    prim_base: u32,
    /// Inner-child mask (`CwBvhNode::imask`).
    imask: u32,
}

/// Child hit bits and bit indices for the ray octant `oct_inv4`; obvhs'
/// `CwBvhNode::get_child_and_index_bits`.
#[inline(always)]
fn child_and_index_bits(meta8: u64, oct_inv4: u32) -> (u64, u64) {
    let oct_inv8 = oct_inv4 as u64 | ((oct_inv4 as u64) << 32);
    let is_inner8 = (meta8 & (meta8 << 1)) & 0x1010_1010_1010_1010;
    let inner_mask8 = (is_inner8 >> 4) * 0xff;
    let bit_index8 = (meta8 ^ (oct_inv8 & inner_mask8)) & 0x1f1f_1f1f_1f1f_1f1f;
    let child_bits8 = (meta8 >> 5) & 0x0707_0707_0707_0707;
    (child_bits8, bit_index8)
}

/// Node hit mask in obvhs' layout (inner children in the high byte, leaf
/// primitives in the low 24 bits) from the children hit (`hits`, bit per slot).
#[inline(always)]
fn hit_mask(node: &WideNode, mut hits: u32, oct_inv4: u32) -> u32 {
    let (child_bits8, bit_index8) = child_and_index_bits(node.meta, oct_inv4);
    let mut mask = 0u32;
    while hits != 0 {
        let shift = hits.trailing_zeros() * 8;
        hits &= hits - 1;
        let child_bits = ((child_bits8 >> shift) as u32) & 0xff;
        let bit_index = ((bit_index8 >> shift) as u32) & 0xff;
        mask |= child_bits << bit_index;
    }
    mask
}

/// The wide BVH's nodes (same indices as `cw.nodes`), with exact child boxes
/// from the primitives' bounds (`bounds` in BVH order).
fn wide_nodes(cw: &CwBvh, bounds: &[Aabb]) -> Vec<WideNode> {
    fn fill(cw: &CwBvh, ni: u32, bounds: &[Aabb], out: &mut [WideNode]) -> Aabb {
        let n = &cw.nodes[ni as usize];
        let inverted = [0, 1, 2, 3, 4, 5].map(|k| {
            if k % 2 == 0 {
                Vec4::INFINITY
            } else {
                Vec4::NEG_INFINITY
            }
        });
        let mut planes = [inverted; 2];
        let mut total = Aabb::empty();
        for c in 0..8 {
            if n.is_child_empty(c) {
                continue;
            }
            let b = if n.is_leaf(c) {
                let (first, count) = n.child_primitives(c);
                bounds[first as usize..(first + count) as usize]
                    .iter()
                    .fold(Aabb::empty(), |acc, b| acc.union(b))
            } else {
                fill(cw, n.child_node_index(c), bounds, out)
            };
            for axis in 0..3 {
                planes[c / 4][axis * 2][c % 4] = b.min[axis];
                planes[c / 4][axis * 2 + 1][c % 4] = b.max[axis];
            }
            total = total.union(&b);
        }
        out[ni as usize] = WideNode {
            planes,
            meta: u64::from_le_bytes(n.child_meta),
            child_base: n.child_base_idx,
            prim_base: n.primitive_base_idx,
            imask: n.imask as u32,
        };
        total
    }
    let empty = WideNode {
        planes: [[Vec4::ZERO; 6]; 2],
        meta: 0,
        child_base: 0,
        prim_base: 0,
        imask: 0,
    };
    let mut out = vec![empty; cw.nodes.len()];
    if !cw.nodes.is_empty() {
        fill(cw, 0, bounds, &mut out);
    }
    out
}

/// What a wide-BVH walk does at nodes and primitives.
trait Visit {
    /// Hit mask of `node`'s children (see [`hit_mask`]).
    fn node(&mut self, node: &WideNode) -> u32;
    /// Visits primitive `index` (BVH order).
    fn prim(&mut self, index: u32);
}

/// Walks the wide BVH (obvhs' `traverse!` ordering: children in the ray
/// octant's order, primitives of a node before its children).
#[inline(always)]
fn walk<V: Visit>(nodes: &[WideNode], oct_inv4: u32, v: &mut V) {
    if nodes.is_empty() {
        return;
    }
    let mut stack = [(0u32, 0u32); MAX_DEPTH];
    let mut sp = 0usize;
    // (child base, hit bits << 24 | inner mask); the root as a group of one.
    let mut group = (0u32, 0x8000_0000u32);
    let mut prims = (0u32, 0u32);
    loop {
        while prims.1 != 0 {
            let local = 31 - prims.1.leading_zeros();
            prims.1 &= !(1 << local);
            v.prim(prims.0 + local);
        }
        if group.1 & 0xff00_0000 != 0 {
            let hits_imask = group.1;
            let offset = 31 - hits_imask.leading_zeros();
            group.1 &= !(1 << offset);
            if group.1 & 0xff00_0000 != 0 {
                stack[sp] = group;
                sp += 1;
            }
            let slot = (offset - 24) ^ (oct_inv4 & 0xff);
            let relative = (hits_imask & !(u32::MAX << slot)).count_ones();
            let node = &nodes[(group.0 + relative) as usize];
            let hits = v.node(node);
            group = (node.child_base, (hits & 0xff00_0000) | node.imask);
            prims = (node.prim_base, hits & 0x00ff_ffff);
        } else {
            group.1 = 0;
        }
        if prims.1 == 0 && group.1 & 0xff00_0000 == 0 {
            if sp == 0 {
                break;
            }
            sp -= 1;
            group = stack[sp];
        }
    }
}

/// A scene with its BVH, ready to trace. Built once; immutable.
pub struct TraceScene {
    scene: Scene,
    /// 8-wide BVH: built by obvhs (`build_cwbvh`), traversed with exact
    /// child boxes grown by the sweep radius.
    nodes: Vec<WideNode>,
    /// Primitives in BVH order (`primitive_indices` applied), so leaf
    /// primitive ids index this array directly.
    prims: Vec<Primitive>,
    /// `prims` in their hot-loop layout.
    hot: Vec<HotPrim>,
    /// Each support's kind, by id (a compact copy for trace hits).
    kinds: Vec<SupportKind>,
    stats: BvhStats,
}

impl std::fmt::Debug for TraceScene {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TraceScene")
            .field("stats", &self.stats)
            .finish()
    }
}

impl TraceScene {
    /// Builds the BVH over every capsule segment (and mesh triangle) of `scene`.
    pub fn new(scene: Scene) -> Self {
        let start = std::time::Instant::now();
        let mut prims = Vec::new();
        for s in scene.supports() {
            match &s.mesh {
                Some(mesh) => prims.extend(mesh.triangles.iter().map(|t| Primitive::Tri {
                    v: t.map(|i| mesh.positions[i as usize]),
                    support: s.id,
                })),
                None => prims.extend((0..s.segment_count()).map(|i| Primitive::Cone {
                    a: s.nodes[i],
                    b: s.nodes[i + 1],
                    ra: s.radii[i],
                    rb: s.radii[i + 1],
                    support: s.id,
                })),
            }
        }
        let bounds: Vec<PrimBounds> = prims
            .iter()
            .map(|p| PrimBounds(p.aabb_inflated(0.0)))
            .collect();
        let mut build_time = Duration::ZERO;
        let cw = if prims.is_empty() {
            CwBvh::default()
        } else {
            build_cwbvh(&bounds, BvhBuildParams::medium_build(), &mut build_time)
        };
        let order = |i: &u32| *i as usize;
        let prims: Vec<Primitive> = cw
            .primitive_indices
            .iter()
            .map(|i| prims[order(i)])
            .collect();
        let bounds: Vec<Aabb> = cw
            .primitive_indices
            .iter()
            .map(|i| bounds[order(i)].0)
            .collect();
        let hot = prims.iter().map(HotPrim::new).collect();
        let nodes = wide_nodes(&cw, &bounds);
        let (leaves, depth) = cwbvh_shape(&cw);
        assert!(
            depth < MAX_DEPTH,
            "BVH depth {depth} exceeds the traversal stack ({MAX_DEPTH})"
        );
        let stats = BvhStats {
            primitives: prims.len(),
            nodes: nodes.len(),
            leaves,
            depth,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        let kinds = scene.supports().iter().map(|s| s.kind).collect();
        TraceScene {
            scene,
            kinds,
            nodes,
            prims,
            hot,
            stats,
        }
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// BVH statistics.
    pub fn stats(&self) -> BvhStats {
        self.stats
    }

    /// The borrowed query view.
    pub fn query(&self) -> SceneQuery<'_> {
        SceneQuery { traces: self }
    }
}

/// Leaf count and depth (in wide nodes, leaves included) of a `CwBvh`.
fn cwbvh_shape(bvh: &CwBvh) -> (usize, usize) {
    fn walk(bvh: &CwBvh, ni: u32, depth: usize, leaves: &mut usize, max_depth: &mut usize) {
        let node = &bvh.nodes[ni as usize];
        for child in 0..8 {
            if node.is_child_empty(child) {
                continue;
            }
            if node.is_leaf(child) {
                *leaves += 1;
                *max_depth = (*max_depth).max(depth + 1);
            } else {
                walk(
                    bvh,
                    node.child_node_index(child),
                    depth + 1,
                    leaves,
                    max_depth,
                );
            }
        }
    }
    let (mut leaves, mut depth) = (0, 0);
    if !bvh.nodes.is_empty() {
        walk(bvh, 0, 1, &mut leaves, &mut depth);
    }
    (leaves, depth)
}

/// Validated ray: unit direction, finite origin, `tmax ≥ 0`.
fn validate_line(line: &LineTrace) -> Result<(Vec3, Vec3, f32), TraceError> {
    if !line.origin.is_finite() {
        return Err(TraceError::InvalidParameter("origin"));
    }
    let dir = line
        .dir
        .try_normalize()
        .ok_or(TraceError::InvalidDirection)?;
    if line.max_dist.is_nan() || line.max_dist < 0.0 {
        return Err(TraceError::InvalidParameter("max_dist"));
    }
    Ok((line.origin, dir, line.max_dist))
}

/// Closest-hit sphere sweep (radius 0: line trace) through the wide BVH.
struct Sweep<'a> {
    prims: &'a [Primitive],
    hot: &'a [HotPrim],
    o: Vec3A,
    d: Vec3A,
    radius: f32,
    /// Slab planes facing the ray per axis (index into `WideNode::planes`),
    /// and the far ones.
    near: [usize; 3],
    far: [usize; 3],
    /// Origin moved by the radius toward the near / far planes (child boxes
    /// are grown by the radius), per axis, splat.
    o_near: [Vec4; 3],
    o_far: [Vec4; 3],
    inv_dir: [Vec4; 3],
    oct_inv4: u32,
    t_best: f32,
    best: Option<(Vec3, u32)>,
}

impl<'a> Sweep<'a> {
    #[inline(always)]
    fn new(traces: &'a TraceScene, o: Vec3, d: Vec3, tmax: f32, radius: f32) -> Self {
        let inv = Vec3::new(safe_inverse(d.x), safe_inverse(d.y), safe_inverse(d.z));
        // Signs from the inverse: `safe_inverse(-0.0)` is negative.
        let neg = [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0];
        let near = neg.map(usize::from);
        // Near plane of a box grown by r: min - r (d ≥ 0) or max + r (d < 0).
        let shift = |axis: usize| if neg[axis] { -radius } else { radius };
        Sweep {
            prims: &traces.prims,
            hot: &traces.hot,
            o: o.into(),
            d: d.into(),
            radius,
            near: [near[0], 2 + near[1], 4 + near[2]],
            far: [1 - near[0], 3 - near[1], 5 - near[2]],
            o_near: [0, 1, 2].map(|a| Vec4::splat(o[a] + shift(a))),
            o_far: [0, 1, 2].map(|a| Vec4::splat(o[a] - shift(a))),
            inv_dir: [0, 1, 2].map(|a| Vec4::splat(inv[a])),
            // Ray octant, as obvhs' traversal expects it (`ray_get_octant_inv4`).
            oct_inv4: (if neg[0] { 0 } else { 0x0404_0404 })
                | (if neg[1] { 0 } else { 0x0202_0202 })
                | (if neg[2] { 0 } else { 0x0101_0101 }),
            t_best: tmax,
            best: None,
        }
    }
}

impl Visit for Sweep<'_> {
    #[inline(always)]
    fn node(&mut self, node: &WideNode) -> u32 {
        let tmax = Vec4::splat(self.t_best);
        let mut hits = 0u32;
        for (half, p) in node.planes.iter().enumerate() {
            let slab = |axis: usize, plane: usize, o: &[Vec4; 3]| {
                (p[plane] - o[axis]) * self.inv_dir[axis]
            };
            let t_near = slab(0, self.near[0], &self.o_near)
                .max(slab(1, self.near[1], &self.o_near))
                .max(slab(2, self.near[2], &self.o_near))
                .max(Vec4::ZERO);
            let t_far = slab(0, self.far[0], &self.o_far)
                .min(slab(1, self.far[1], &self.o_far))
                .min(slab(2, self.far[2], &self.o_far))
                .min(tmax);
            hits |= t_near.cmple(t_far).bitmask() << (half * 4);
        }
        hit_mask(node, hits, self.oct_inv4)
    }

    #[inline(always)]
    fn prim(&mut self, index: u32) {
        let i = index as usize;
        if let Some((t, n)) = self.hot[i].sweep(&self.prims[i], self.o, self.d, self.radius)
            && (t < self.t_best
                || (t == self.t_best && self.best.is_some_and(|(_, bi)| index < bi)))
        {
            // Exact ties go to the lowest index, like the brute-force scan.
            self.t_best = t;
            self.best = Some((n, index));
        }
    }
}

/// Box-overlap candidates: children whose boxes overlap `[lo, hi]`.
struct Overlap<F> {
    lo: [Vec4; 3],
    hi: [Vec4; 3],
    on_prim: F,
}

impl<F: FnMut(u32)> Visit for Overlap<F> {
    #[inline(always)]
    fn node(&mut self, node: &WideNode) -> u32 {
        let mut hits = 0u32;
        for (half, p) in node.planes.iter().enumerate() {
            let mut ok = glam::BVec4A::splat(true);
            for axis in 0..3 {
                ok &= p[axis * 2].cmple(self.hi[axis]) & p[axis * 2 + 1].cmpge(self.lo[axis]);
            }
            hits |= ok.bitmask() << (half * 4);
        }
        hit_mask(node, hits, 0)
    }

    #[inline(always)]
    fn prim(&mut self, index: u32) {
        (self.on_prim)(index);
    }
}

/// Borrowed view for tracing a [`TraceScene`]. Cheap to copy; `Send + Sync`.
#[derive(Clone, Copy)]
pub struct SceneQuery<'a> {
    traces: &'a TraceScene,
}

impl<'a> SceneQuery<'a> {
    /// The scene being traced.
    pub fn scene(&self) -> &'a Scene {
        &self.traces.scene
    }

    /// Closest hit along a line.
    pub fn line(&self, line: &LineTrace) -> TraceResult {
        self.sweep(line, 0.0)
    }

    /// Closest hit of a sphere swept along a line. `point` is the contact
    /// point on the surface; `distance` is how far the centre travelled.
    pub fn sphere(&self, sweep: &SphereSweep) -> TraceResult {
        if !sweep.radius.is_finite() || sweep.radius < 0.0 {
            return Err(TraceError::InvalidParameter("radius"));
        }
        self.sweep(&sweep.line, sweep.radius)
    }

    /// Runs one request of either kind.
    pub fn trace(&self, req: &TraceRequest) -> TraceResult {
        match req {
            TraceRequest::Line(l) => self.line(l),
            TraceRequest::Sphere(s) => self.sphere(s),
        }
    }

    fn sweep(&self, line: &LineTrace, radius: f32) -> TraceResult {
        let (o, d, tmax) = validate_line(line)?;
        let mut sweep = Sweep::new(self.traces, o, d, tmax, radius);
        walk(&self.traces.nodes, sweep.oct_inv4, &mut sweep);
        Ok(sweep
            .best
            .map(|(n, pi)| self.hit(o, d, radius, sweep.t_best, n, pi)))
    }

    fn hit(&self, o: Vec3, d: Vec3, radius: f32, t: f32, n: Vec3, pi: u32) -> TraceHit {
        let support = self.traces.hot[pi as usize].support();
        TraceHit {
            point: o + d * t - n * radius,
            normal: n,
            support,
            kind: self.traces.kinds[support.0 as usize],
            distance: t,
        }
    }

    /// Ids of supports whose solid overlaps the oriented box, sorted and
    /// deduplicated, written into `out` (cleared first).
    pub fn overlap_box(&self, bx: &BoxOverlap, out: &mut Vec<SupportId>) -> Result<(), TraceError> {
        out.clear();
        let (to_local, world_aabb) = validate_box(bx)?;
        let prims = &self.traces.prims;
        if prims.is_empty() {
            return Ok(());
        }
        let (lo, hi) = (world_aabb.min, world_aabb.max);
        let mut visit = Overlap {
            lo: [0, 1, 2].map(|a| Vec4::splat(lo[a])),
            hi: [0, 1, 2].map(|a| Vec4::splat(hi[a])),
            on_prim: |i: u32| {
                let p = &prims[i as usize];
                if prim_overlaps_local_box(p, &to_local, bx.half_extents) {
                    out.push(p.support());
                }
            },
        };
        walk(&self.traces.nodes, 0, &mut visit);
        out.sort_unstable();
        out.dedup();
        Ok(())
    }

    /// Distance from `p` to the surface of `support` (its triangles, or its
    /// capsules), looking no farther than `max` metres; `None` when none of
    /// its surface is that close. This is the grip gap the judge measures.
    pub fn surface_distance(&self, support: SupportId, p: Vec3, max: f32) -> Option<f32> {
        if !(p.is_finite() && max.is_finite() && max >= 0.0) {
            return None;
        }
        let prims = &self.traces.prims;
        let (lo, hi) = (p - Vec3::splat(max), p + Vec3::splat(max));
        let mut best = f32::INFINITY;
        let mut visit = Overlap {
            lo: [0, 1, 2].map(|a| Vec4::splat(lo[a])),
            hi: [0, 1, 2].map(|a| Vec4::splat(hi[a])),
            on_prim: |i: u32| {
                let d = match prims[i as usize] {
                    Primitive::Tri { v, support: s } if s == support => {
                        closest_on_triangle(p, v).distance(p)
                    }
                    Primitive::Cone {
                        a,
                        b,
                        ra,
                        rb,
                        support: s,
                    } if s == support => {
                        let (q, t) = crate::closest_on_segment(a, b, p);
                        (q.distance(p) - (ra + (rb - ra) * t)).abs()
                    }
                    _ => f32::INFINITY,
                };
                best = best.min(d);
            },
        };
        walk(&self.traces.nodes, 0, &mut visit);
        (best <= max).then_some(best)
    }

    /// Runs many traces in parallel (rayon); `out[i]` answers `reqs[i]`.
    ///
    /// # Panics
    /// If `out.len() != reqs.len()`.
    pub fn trace_batch(&self, reqs: &[TraceRequest], out: &mut [TraceResult]) {
        assert_eq!(reqs.len(), out.len(), "one output slot per request");
        reqs.par_iter()
            .with_min_len(64)
            .zip(out.par_iter_mut())
            .for_each(|(r, o)| *o = self.trace(r));
    }

    /// Sequential twin of [`Self::trace_batch`].
    pub fn trace_batch_serial(&self, reqs: &[TraceRequest], out: &mut [TraceResult]) {
        assert_eq!(reqs.len(), out.len(), "one output slot per request");
        for (r, o) in reqs.iter().zip(out.iter_mut()) {
            *o = self.trace(r);
        }
    }

    /// Reference: closest hit by scanning every primitive (no BVH).
    pub fn trace_brute_force(&self, req: &TraceRequest) -> TraceResult {
        let (line, radius) = match req {
            TraceRequest::Line(l) => (l, 0.0),
            TraceRequest::Sphere(s) => {
                if !s.radius.is_finite() || s.radius < 0.0 {
                    return Err(TraceError::InvalidParameter("radius"));
                }
                (&s.line, s.radius)
            }
        };
        let (o, d, tmax) = validate_line(line)?;
        // The same primitive intersector as the BVH walk (`HotPrim::sweep`,
        // unit-tested against `Primitive::sweep`), so results compare exactly.
        let (oa, da) = (Vec3A::from(o), Vec3A::from(d));
        let mut best: Option<(f32, Vec3, u32)> = None;
        for (i, (p, h)) in self.traces.prims.iter().zip(&self.traces.hot).enumerate() {
            if let Some((t, n)) = h.sweep(p, oa, da, radius)
                && t < tmax
                && best.is_none_or(|b| t < b.0)
            {
                best = Some((t, n, i as u32));
            }
        }
        Ok(best.map(|(t, n, pi)| self.hit(o, d, radius, t, n, pi)))
    }

    /// Reference: box overlap by scanning every primitive (no BVH).
    pub fn overlap_box_brute_force(
        &self,
        bx: &BoxOverlap,
        out: &mut Vec<SupportId>,
    ) -> Result<(), TraceError> {
        out.clear();
        let (to_local, _) = validate_box(bx)?;
        for p in &self.traces.prims {
            if prim_overlaps_local_box(p, &to_local, bx.half_extents) {
                out.push(p.support());
            }
        }
        out.sort_unstable();
        out.dedup();
        Ok(())
    }
}

/// World → box-local transform and the box's world AABB.
fn validate_box(bx: &BoxOverlap) -> Result<((Quat, Vec3), Aabb), TraceError> {
    if !bx.center.is_finite() {
        return Err(TraceError::InvalidParameter("center"));
    }
    if !bx.half_extents.is_finite() || bx.half_extents.min_element() < 0.0 {
        return Err(TraceError::InvalidParameter("half_extents"));
    }
    if !bx.rotation.is_finite() || bx.rotation.length_squared() < 1e-12 {
        return Err(TraceError::InvalidParameter("rotation"));
    }
    let rot = bx.rotation.normalize();
    let m = glam::Mat3::from_quat(rot);
    let h = bx.half_extents;
    let world_half = m.x_axis.abs() * h.x + m.y_axis.abs() * h.y + m.z_axis.abs() * h.z;
    let aabb = Aabb::new(
        (bx.center - world_half).into(),
        (bx.center + world_half).into(),
    );
    Ok(((rot.inverse(), bx.center), aabb))
}

fn prim_overlaps_local_box(p: &Primitive, to_local: &(Quat, Vec3), half: Vec3) -> bool {
    let (inv, c) = *to_local;
    let local = |v: Vec3| inv * (v - c);
    let lp = match *p {
        Primitive::Cone {
            a,
            b,
            ra,
            rb,
            support,
        } => Primitive::Cone {
            a: local(a),
            b: local(b),
            ra,
            rb,
            support,
        },
        Primitive::Tri { v, support } => Primitive::Tri {
            v: v.map(local),
            support,
        },
    };
    lp.overlaps_box(-half, half)
}

/// Closest point to `p` on triangle `v` (Ericson, Real-Time Collision Detection 5.1.5).
fn closest_on_triangle(p: Vec3, v: [Vec3; 3]) -> Vec3 {
    let [a, b, c] = v;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = va + vb + vc;
    if denom.abs() <= f32::MIN_POSITIVE {
        return a;
    }
    let (v2, w2) = (vb / denom, vc / denom);
    a + ab * v2 + ac * w2
}

#[cfg(test)]
mod surface_tests {
    use super::*;

    #[test]
    fn closest_on_triangle_regions() {
        let t = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let inside = closest_on_triangle(Vec3::new(0.2, 0.2, 1.0), t);
        assert!((inside - Vec3::new(0.2, 0.2, 0.0)).length() < 1e-6);
        assert_eq!(
            closest_on_triangle(Vec3::new(-1.0, -1.0, 0.0), t),
            Vec3::ZERO
        );
        assert_eq!(closest_on_triangle(Vec3::new(2.0, -0.5, 0.0), t), Vec3::X);
        let e = closest_on_triangle(Vec3::new(0.5, -1.0, 0.0), t);
        assert!((e - Vec3::new(0.5, 0.0, 0.0)).length() < 1e-6);
        let h = closest_on_triangle(Vec3::new(1.0, 1.0, 0.0), t);
        assert!((h - Vec3::new(0.5, 0.5, 0.0)).length() < 1e-6);
    }
}
