//! Trace queries against a scene: line traces (closest hit), sphere sweeps and
//! oriented-box overlaps, accelerated by an `obvhs` BVH2 over analytic
//! primitives (tapered capsules; triangles for imported meshes).
//!
//! [`TraceScene`] owns the scene and its BVH and is built once (the forest is
//! static). [`SceneQuery`] is the borrowed view every caller traces through;
//! it offers single queries, a batched API that runs many traces in parallel
//! (rayon), and brute-force twins used as references by tests and baselines.

use std::time::Duration;

use glam::{Quat, Vec3};
use obvhs::{
    Boundable, BvhBuildParams,
    aabb::Aabb,
    bvh2::{Bvh2, builder::build_bvh2},
    ray::{Ray, RayHit},
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
    bvh: Bvh2,
    /// Primitives in BVH order (`bvh.primitive_indices` applied), so leaf
    /// ranges index this array directly.
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
            Bvh2::default()
        } else {
            build_bvh2(&bounds, BvhBuildParams::medium_build(), &mut build_time)
        };
        let prims: Vec<Primitive> = bvh
            .primitive_indices
            .iter()
            .map(|&i| prims[i as usize])
            .collect();
        let leaves = bvh.nodes.iter().filter(|n| n.is_leaf()).count();
        let stats = BvhStats {
            primitives: prims.len(),
            nodes: bvh.nodes.len(),
            leaves,
            depth: if bvh.nodes.is_empty() {
                0
            } else {
                bvh.depth(0)
            },
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
        // The BVH bounds the primitives without any sphere radius, so a sweep
        // walks it with node boxes grown by the radius (`sphere_traverse`).
        let ray = Ray::new(o.into(), d.into(), 0.0, tmax);
        let mut hit = RayHit::none();
        let mut best_n = Vec3::ZERO;
        let found = if radius == 0.0 {
            self.traces.bvh.ray_traverse(ray, &mut hit, |ray, id| {
                match prims[id].sweep(o, d, 0.0) {
                    Some((t, n)) if t < ray.tmax => {
                        best_n = n;
                        t
                    }
                    _ => f32::INFINITY,
                }
            })
        } else {
            self.sphere_traverse(o, d, tmax, radius, &mut hit, &mut best_n)
        };
        if !found {
            return Ok(None);
        }
        let p = &prims[hit.primitive_id as usize];
        let support = p.support();
        let t = hit.t;
        Ok(Some(TraceHit {
            point: o + d * t - best_n * radius,
            normal: best_n,
            support,
            kind: self.traces.scene.support(support).kind,
            distance: t,
        }))
    }

    /// Sphere sweep: walks the BVH with node boxes grown by `radius`
    /// (slab test against the inflated box), then the inflated primitives.
    fn sphere_traverse(
        &self,
        o: Vec3,
        d: Vec3,
        tmax: f32,
        radius: f32,
        hit: &mut RayHit,
        best_n: &mut Vec3,
    ) -> bool {
        let bvh = &self.traces.bvh;
        let prims = &self.traces.prims;
        let inv_d = Vec3::new(
            obvhs::ray::safe_inverse(d.x),
            obvhs::ray::safe_inverse(d.y),
            obvhs::ray::safe_inverse(d.z),
        );
        let grow = Vec3::splat(radius);
        let mut t_best = tmax;
        let mut found = false;
        let slab = |min: Vec3, max: Vec3, t_best: f32| -> bool {
            let t1 = (min - grow - o) * inv_d;
            let t2 = (max + grow - o) * inv_d;
            let tmin = t1.min(t2).max_element().max(0.0);
            let tmax = t1.max(t2).min_element().min(t_best);
            tmin <= tmax
        };
        let mut stack: Vec<u32> = Vec::with_capacity(64);
        let root = &bvh.nodes[0];
        if !slab(root.aabb().min.into(), root.aabb().max.into(), t_best) {
            return false;
        }
        stack.push(0);
        while let Some(ni) = stack.pop() {
            let node = &bvh.nodes[ni as usize];
            if !slab(node.aabb().min.into(), node.aabb().max.into(), t_best) {
                continue;
            }
            if node.is_leaf() {
                for pi in node.first_index..node.first_index + node.prim_count {
                    if let Some((t, n)) = prims[pi as usize].sweep(o, d, radius)
                        && t < t_best
                    {
                        t_best = t;
                        *best_n = n;
                        hit.t = t;
                        hit.primitive_id = pi;
                        found = true;
                    }
                }
            } else {
                stack.push(node.first_index);
                stack.push(node.first_index + 1);
            }
        }
        found
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
        self.traces.bvh.aabb_traverse(world_aabb, |bvh, ni| {
            let node = &bvh.nodes[ni as usize];
            for pi in node.first_index..node.first_index + node.prim_count {
                let p = &prims[pi as usize];
                if prim_overlaps_local_box(p, &to_local, bx.half_extents) {
                    out.push(p.support());
                }
            }
            true
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
