//! Trace queries against a scene: line traces (closest hit), sphere sweeps and
//! oriented-box overlaps, accelerated by an `obvhs` BVH2 over analytic
//! primitives (tapered capsules; triangles for imported meshes).
//!
//! [`TraceScene`] owns the scene and its BVH and is built once (the forest is
//! static). [`SceneQuery`] is the borrowed view every caller traces through;
//! it offers single queries, a batched API that runs many traces in parallel
//! (rayon), and brute-force twins used as references by tests and baselines.

use std::time::Duration;

use glam::{Quat, UVec2, Vec3, Vec3A, Vec4};
use obvhs::{
    Boundable, BvhBuildParams,
    aabb::Aabb,
    cwbvh::{CwBvh, builder::build_cwbvh, node::CwBvhNode},
    ray::safe_inverse,
};
use rayon::prelude::*;
use serde::Serialize;

use crate::{Scene, SupportId, SupportKind, TraceError, primitive::Primitive};

/// A line trace: from `origin` along `dir` (any length ≠ 0; normalised) up to `max_dist` metres.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LineTrace {
    /// Start point, world space.
    pub origin: Vec3,
    /// Direction, world space (need not be unit).
    pub dir: Vec3,
    /// Maximum distance (metres, ≥ 0; may be infinite).
    pub max_dist: f32,
}

/// A sphere sweep: a sphere of `radius` moving like a [`LineTrace`].
#[derive(Clone, Copy, Debug, PartialEq)]
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
#[derive(Clone, Copy, Debug, PartialEq)]
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

/// A scene with its BVH, ready to trace. Built once; immutable.
pub struct TraceScene {
    scene: Scene,
    /// Compressed 8-wide BVH (obvhs `CwBvh`); traversed by [`SceneQuery`]
    /// with its own node test, which grows child boxes by the sweep radius.
    bvh: CwBvh,
    /// Primitives in BVH order (`bvh.primitive_indices` applied), so leaf
    /// primitive ids index this array directly.
    prims: Vec<Primitive>,
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
        let bvh = if prims.is_empty() {
            CwBvh::default()
        } else {
            build_cwbvh(&bounds, BvhBuildParams::medium_build(), &mut build_time)
        };
        let prims: Vec<Primitive> = bvh
            .primitive_indices
            .iter()
            .map(|&i| prims[i as usize])
            .collect();
        let (leaves, depth) = cwbvh_shape(&bvh);
        let stats = BvhStats {
            primitives: prims.len(),
            nodes: bvh.nodes.len(),
            leaves,
            depth,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        TraceScene {
            scene,
            bvh,
            prims,
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

/// Per-ray constants of the wide-node slab test.
struct NodeRay {
    origin: Vec3A,
    inv_dir: Vec3A,
    /// `radius · |inv_dir|`: how far the sweep radius moves each slab plane
    /// along the ray (child boxes are grown by the radius).
    grow: Vec3A,
    neg: [bool; 3],
    oct_inv4: u32,
}

impl NodeRay {
    #[inline(always)]
    fn new(o: Vec3, d: Vec3, radius: f32) -> Self {
        let inv_dir = Vec3A::new(safe_inverse(d.x), safe_inverse(d.y), safe_inverse(d.z));
        NodeRay {
            origin: o.into(),
            inv_dir,
            grow: inv_dir.abs() * radius,
            neg: [d.x < 0.0, d.y < 0.0, d.z < 0.0],
            // Ray octant, as obvhs' traversal expects it (`ray_get_octant_inv4`).
            oct_inv4: (if d.x < 0.0 { 0 } else { 0x0404_0404 })
                | (if d.y < 0.0 { 0 } else { 0x0202_0202 })
                | (if d.z < 0.0 { 0 } else { 0x0101_0101 }),
        }
    }

    /// Hit mask (obvhs `CwBvhNode::intersect_ray` layout) of the node's
    /// children whose boxes, grown by the sweep radius, the segment
    /// `[0, tmax]` crosses.
    #[inline(always)]
    fn intersect(&self, node: &CwBvhNode, tmax: f32) -> u32 {
        let adj = node.compute_extent() * self.inv_dir;
        let base = (Vec3A::from(node.p) - self.origin) * self.inv_dir;
        let near = base - self.grow;
        let far = base + self.grow;
        let (nx, fx) = if self.neg[0] {
            (&node.child_max_x, &node.child_min_x)
        } else {
            (&node.child_min_x, &node.child_max_x)
        };
        let (ny, fy) = if self.neg[1] {
            (&node.child_max_y, &node.child_min_y)
        } else {
            (&node.child_min_y, &node.child_max_y)
        };
        let (nz, fz) = if self.neg[2] {
            (&node.child_max_z, &node.child_min_z)
        } else {
            (&node.child_min_z, &node.child_max_z)
        };
        let (child_bits8, bit_index8) = node.get_child_and_index_bits(self.oct_inv4);
        let mut hit_mask = 0u32;
        for i in 0..2 {
            #[inline(always)]
            fn q(v: &[u8; 8], i: usize) -> Vec4 {
                Vec4::new(
                    v[i * 4] as f32,
                    v[i * 4 + 1] as f32,
                    v[i * 4 + 2] as f32,
                    v[i * 4 + 3] as f32,
                )
            }
            let t_near = (q(nx, i) * adj.x + Vec4::splat(near.x))
                .max(q(ny, i) * adj.y + Vec4::splat(near.y))
                .max(q(nz, i) * adj.z + Vec4::splat(near.z))
                .max(Vec4::ZERO);
            let t_far = (q(fx, i) * adj.x + Vec4::splat(far.x))
                .min(q(fy, i) * adj.y + Vec4::splat(far.y))
                .min(q(fz, i) * adj.z + Vec4::splat(far.z))
                .min(Vec4::splat(tmax));
            let mask = t_near.cmple(t_far).bitmask();
            for j in 0..4 {
                if mask & (1 << j) != 0 {
                    let offset = (i * 4 + j) * 8;
                    let child_bits = ((child_bits8 >> offset) as u32) & 0xff;
                    let bit_index = ((bit_index8 >> offset) as u32) & 0xff;
                    hit_mask |= child_bits << bit_index;
                }
            }
        }
        hit_mask
    }
}

/// Hit mask (obvhs `CwBvhNode::intersect_ray` layout) of the node's children
/// whose boxes overlap the box `[lo, hi]` (world space).
#[inline(always)]
fn aabb_hits(node: &CwBvhNode, lo: Vec3A, hi: Vec3A, oct_inv4: u32) -> u32 {
    let e = node.compute_extent();
    let p = Vec3A::from(node.p);
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hit_mask = 0u32;
    for child in 0..8 {
        let local = node.local_child_aabb(child);
        let (cmin, cmax) = (p + local.min * e, p + local.max * e);
        if cmin.cmple(hi).all() && cmax.cmpge(lo).all() {
            let offset = child * 8;
            let child_bits = ((child_bits8 >> offset) as u32) & 0xff;
            let bit_index = ((bit_index8 >> offset) as u32) & 0xff;
            hit_mask |= child_bits << bit_index;
        }
    }
    hit_mask
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
        let prims = &self.traces.prims;
        if prims.is_empty() {
            return Ok(None);
        }
        let Some((t, n, pi)) = self.closest(o, d, tmax, radius) else {
            return Ok(None);
        };
        let support = prims[pi].support();
        Ok(Some(TraceHit {
            point: o + d * t - n * radius,
            normal: n,
            support,
            kind: self.traces.scene.support(support).kind,
            distance: t,
        }))
    }

    /// Closest hit `(t, normal, primitive)` with `t < tmax` of a sphere of
    /// `radius` (0: a line) moving from `o` along unit `d`. Walks the wide
    /// BVH with child boxes grown by the radius, near children first.
    #[inline]
    fn closest(&self, o: Vec3, d: Vec3, tmax: f32, radius: f32) -> Option<(f32, Vec3, usize)> {
        let bvh = &self.traces.bvh;
        let prims = &self.traces.prims;
        let nr = NodeRay::new(o, d, radius);
        let mut state = bvh.new_traversal(d.into());
        state.oct_inv4 = nr.oct_inv4;
        let mut t_best = tmax;
        let mut best: Option<(Vec3, usize)> = None;
        let mut node;
        obvhs::traverse!(bvh, node, state, nr.intersect(node, t_best), {
            let pi = state.primitive_id as usize;
            if let Some((t, n)) = prims[pi].sweep(o, d, radius)
                && (t < t_best || (t == t_best && best.is_some_and(|(_, bi)| pi < bi)))
            {
                // Exact ties go to the lowest index, like the brute-force scan.
                t_best = t;
                best = Some((n, pi));
            }
        });
        best.map(|(n, pi)| (t_best, n, pi))
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
        let bvh = &self.traces.bvh;
        let (lo, hi) = (Vec3A::from(world_aabb.min), Vec3A::from(world_aabb.max));
        let mut state = bvh.new_traversal(Vec3A::X);
        let mut node;
        obvhs::traverse!(bvh, node, state, aabb_hits(node, lo, hi, state.oct_inv4), {
            let p = &prims[state.primitive_id as usize];
            if prim_overlaps_local_box(p, &to_local, bx.half_extents) {
                out.push(p.support());
            }
        });
        out.sort_unstable();
        out.dedup();
        Ok(())
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
        let mut best: Option<(f32, Vec3, SupportId)> = None;
        for p in &self.traces.prims {
            if let Some((t, n)) = p.sweep(o, d, radius)
                && t < tmax
                && best.is_none_or(|b| t < b.0)
            {
                best = Some((t, n, p.support()));
            }
        }
        Ok(best.map(|(t, n, support)| TraceHit {
            point: o + d * t - n * radius,
            normal: n,
            support,
            kind: self.traces.scene.support(support).kind,
            distance: t,
        }))
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
