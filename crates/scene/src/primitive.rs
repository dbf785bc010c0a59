//! Trace primitives and their analytic intersection tests.
//!
//! A capsule segment with a radius at each end is a *round cone* (the convex
//! hull of two spheres). Sweeping a sphere of radius `r` against it equals a
//! ray against the round cone with both radii grown by `r`, so line traces and
//! sphere sweeps share one routine. Imported meshes are triangles; a sphere
//! sweep against a triangle is a ray against its Minkowski sum (two offset
//! faces, three edge cylinders, three vertex spheres).
//!
//! Degenerate cases: rays starting inside a primitive report no hit for it
//! (traces look for surfaces in front of the origin); rays are assumed to have
//! unit-length directions.

use glam::{Vec3, Vec3A, Vec4};
use obvhs::aabb::Aabb;

use crate::SupportId;

/// One traceable piece of a support.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Primitive {
    /// Tapered capsule: segment `a–b`, radius `ra` at `a`, `rb` at `b`.
    Cone {
        /// Segment start.
        a: Vec3,
        /// Segment end.
        b: Vec3,
        /// Radius at `a`.
        ra: f32,
        /// Radius at `b`.
        rb: f32,
        /// Owning support.
        support: SupportId,
    },
    /// A triangle of an imported mesh.
    Tri {
        /// Vertices.
        v: [Vec3; 3],
        /// Owning support.
        support: SupportId,
    },
}

impl Primitive {
    /// The support this primitive belongs to.
    #[inline]
    pub fn support(&self) -> SupportId {
        match *self {
            Primitive::Cone { support, .. } | Primitive::Tri { support, .. } => support,
        }
    }

    /// Bounds grown by `inflate` metres on every side.
    pub fn aabb_inflated(&self, inflate: f32) -> Aabb {
        let (min, max) = match *self {
            Primitive::Cone { a, b, ra, rb, .. } => (
                (a - Vec3::splat(ra)).min(b - Vec3::splat(rb)),
                (a + Vec3::splat(ra)).max(b + Vec3::splat(rb)),
            ),
            Primitive::Tri { v, .. } => (v[0].min(v[1]).min(v[2]), v[0].max(v[1]).max(v[2])),
        };
        Aabb::new(
            (min - Vec3::splat(inflate)).into(),
            (max + Vec3::splat(inflate)).into(),
        )
    }

    /// Closest hit of a sphere of radius `r` (0 = line trace) moving from `o`
    /// along unit `d`: `(t, outward normal at the contact)`, or `None`.
    #[inline]
    pub fn sweep(&self, o: Vec3, d: Vec3, r: f32) -> Option<(f32, Vec3)> {
        match *self {
            Primitive::Cone { a, b, ra, rb, .. } => ray_round_cone(o, d, a, b, ra + r, rb + r),
            Primitive::Tri { v, .. } => {
                if r <= 0.0 {
                    ray_triangle(o, d, v)
                } else {
                    ray_inflated_triangle(o, d, v, r)
                }
            }
        }
    }

    /// Whether the solid primitive overlaps the axis-aligned box `[lo, hi]`.
    pub fn overlaps_box(&self, lo: Vec3, hi: Vec3) -> bool {
        match *self {
            Primitive::Cone { a, b, ra, rb, .. } => round_cone_overlaps_box(a, b, ra, rb, lo, hi),
            Primitive::Tri { v, .. } => triangle_overlaps_box(v, lo, hi),
        }
    }
}

/// A primitive's trace data, laid out for the hot loop (one cache line):
/// round cones with their sweep-independent terms precomputed; triangles are
/// only tagged (their [`Primitive`] is traced instead).
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(64))]
pub(crate) struct HotPrim {
    /// `(a, ra)`.
    a: Vec4,
    /// `(b, rb)`.
    b: Vec4,
    /// `(b - a, |b - a|²)`.
    ba: Vec4,
    /// `rr = ra - rb`, `d2 = |b - a|² - rr²`, triangle tag (1 or 0), and the
    /// owning support's id (its bits).
    k: Vec4,
}

impl HotPrim {
    /// The hot-loop form of `p`.
    pub(crate) fn new(p: &Primitive) -> Self {
        match *p {
            Primitive::Cone { a, b, ra, rb, .. } => {
                let ba = b - a;
                let m0 = ba.dot(ba);
                let rr = ra - rb;
                HotPrim {
                    a: a.extend(ra),
                    b: b.extend(rb),
                    ba: ba.extend(m0),
                    k: Vec4::new(rr, m0 - rr * rr, 0.0, f32::from_bits(p.support().0)),
                }
            }
            Primitive::Tri { .. } => HotPrim {
                a: Vec4::ZERO,
                b: Vec4::ZERO,
                ba: Vec4::ZERO,
                k: Vec4::new(0.0, 0.0, 1.0, f32::from_bits(p.support().0)),
            },
        }
    }

    /// The support this primitive belongs to.
    #[inline(always)]
    pub(crate) fn support(&self) -> SupportId {
        SupportId(self.k.w.to_bits())
    }

    /// Closest hit of a sphere of radius `r` (0 = line trace) moving from `o`
    /// along unit `d`, like [`Primitive::sweep`]; `full` is this primitive's
    /// [`Primitive`] (read for triangles only).
    #[inline(always)]
    pub(crate) fn sweep(
        &self,
        full: &Primitive,
        o: Vec3A,
        d: Vec3A,
        r: f32,
    ) -> Option<(f32, Vec3)> {
        let [rr, d2, tri, _] = self.k.to_array();
        if d2 <= 1e-12 {
            if tri != 0.0 {
                return full.sweep(o.into(), d.into(), r);
            }
            // One sphere contains the other: the hull is the larger sphere.
            let (ra, rb) = (self.a.w + r, self.b.w + r);
            return if ra >= rb {
                ray_sphere_a(o, d, Vec3A::from_vec4(self.a), ra)
            } else {
                ray_sphere_a(o, d, Vec3A::from_vec4(self.b), rb)
            };
        }
        let a = Vec3A::from_vec4(self.a);
        let ba = Vec3A::from_vec4(self.ba);
        let m0 = self.ba.w;
        let ra = self.a.w + r;
        let oa = o - a;
        let m1 = ba.dot(oa);
        let m2 = ba.dot(d);
        let m3 = d.dot(oa);
        let m5 = oa.dot(oa);

        // Conical body.
        let k2 = d2 - m2 * m2;
        let k1 = d2 * m3 - m1 * m2 + m2 * rr * ra;
        let k0 = d2 * m5 - m1 * m1 + m1 * rr * ra * 2.0 - m0 * ra * ra;
        let h = k1 * k1 - k0 * k2;
        if h < 0.0 {
            return None;
        }
        if k2.abs() > 1e-12 {
            let t = (-h.sqrt() - k1) / k2;
            let y = m1 - ra * rr + t * m2;
            if y > 0.0 && y < d2 {
                if t < 0.0 {
                    return None;
                }
                let n = (d2 * (oa + d * t) - ba * y).normalize_or_zero();
                return Some((t, n.into()));
            }
        }
        // Spherical caps.
        let hit_a = ray_sphere_a(o, d, a, ra);
        let hit_b = ray_sphere_a(o, d, Vec3A::from_vec4(self.b), self.b.w + r);
        match (hit_a, hit_b) {
            (Some(x), Some(y)) => Some(if y.0 < x.0 { y } else { x }),
            (x, y) => x.or(y),
        }
    }
}

/// [`ray_sphere`] on `Vec3A`.
#[inline(always)]
fn ray_sphere_a(o: Vec3A, d: Vec3A, c: Vec3A, r: f32) -> Option<(f32, Vec3)> {
    let oc = o - c;
    let cc = oc.dot(oc) - r * r;
    if cc < 0.0 {
        return None;
    }
    let b = -oc.dot(d);
    let f = oc + d * b;
    let disc = r * r - f.dot(f);
    if disc < 0.0 || b <= 0.0 {
        return None;
    }
    let q = b + disc.sqrt();
    let t = cc / q;
    if t < 0.0 {
        return None;
    }
    Some((t, (oc + d * t).normalize_or(-d).into()))
}

/// Ray vs round cone (convex hull of spheres `(a, ra)` and `(b, rb)`).
/// After Inigo Quilez's analytic intersector. Returns the entry `t ≥ 0`.
pub fn ray_round_cone(o: Vec3, d: Vec3, a: Vec3, b: Vec3, ra: f32, rb: f32) -> Option<(f32, Vec3)> {
    let ba = b - a;
    let oa = o - a;
    let rr = ra - rb;
    let m0 = ba.dot(ba);
    let d2 = m0 - rr * rr;
    if d2 <= 1e-12 {
        // One sphere contains the other: the hull is the larger sphere.
        return if ra >= rb {
            ray_sphere(o, d, a, ra)
        } else {
            ray_sphere(o, d, b, rb)
        };
    }
    let m1 = ba.dot(oa);
    let m2 = ba.dot(d);
    let m3 = d.dot(oa);
    let m5 = oa.dot(oa);

    // Conical body.
    let k2 = d2 - m2 * m2;
    let k1 = d2 * m3 - m1 * m2 + m2 * rr * ra;
    let k0 = d2 * m5 - m1 * m1 + m1 * rr * ra * 2.0 - m0 * ra * ra;
    let h = k1 * k1 - k0 * k2;
    if h < 0.0 {
        return None;
    }
    if k2.abs() > 1e-12 {
        let t = (-h.sqrt() - k1) / k2;
        let y = m1 - ra * rr + t * m2;
        if y > 0.0 && y < d2 {
            if t < 0.0 {
                return None;
            }
            let n = (d2 * (oa + d * t) - ba * y).normalize_or_zero();
            return Some((t, n));
        }
    }
    // Spherical caps.
    let hit_a = ray_sphere(o, d, a, ra);
    let hit_b = ray_sphere(o, d, b, rb);
    match (hit_a, hit_b) {
        (Some(x), Some(y)) => Some(if y.0 < x.0 { y } else { x }),
        (x, y) => x.or(y),
    }
}

/// Ray vs sphere; entry point with `t ≥ 0` (origin inside ⇒ `None`).
/// Uses the numerically robust form (Haines et al., *Ray Tracing Gems* ch. 7)
/// so distant origins still give points on the surface.
#[inline]
pub fn ray_sphere(o: Vec3, d: Vec3, c: Vec3, r: f32) -> Option<(f32, Vec3)> {
    let oc = o - c;
    let cc = oc.dot(oc) - r * r;
    if cc < 0.0 {
        return None;
    }
    let b = -oc.dot(d);
    let f = oc + d * b;
    let disc = r * r - f.dot(f);
    if disc < 0.0 || b <= 0.0 {
        return None;
    }
    let q = b + disc.sqrt();
    let t = cc / q;
    if t < 0.0 {
        return None;
    }
    Some((t, (oc + d * t).normalize_or(-d)))
}

/// Ray vs triangle (two-sided Möller–Trumbore). Normal faces the ray.
#[inline]
pub fn ray_triangle(o: Vec3, d: Vec3, v: [Vec3; 3]) -> Option<(f32, Vec3)> {
    let e1 = v[1] - v[0];
    let e2 = v[2] - v[0];
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det.abs() < 1e-12 {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - v[0];
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let w = d.dot(q) * inv;
    if w < 0.0 || u + w > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    if t < 0.0 {
        return None;
    }
    let n = e1.cross(e2).normalize_or_zero();
    Some((t, if n.dot(d) > 0.0 { -n } else { n }))
}

/// Ray vs the Minkowski sum of a triangle and a sphere of radius `r`.
fn ray_inflated_triangle(o: Vec3, d: Vec3, v: [Vec3; 3], r: f32) -> Option<(f32, Vec3)> {
    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
    let mut best: Option<(f32, Vec3)> = None;
    let mut take = |hit: Option<(f32, Vec3)>| {
        if let Some(h) = hit
            && best.is_none_or(|b| h.0 < b.0)
        {
            best = Some(h);
        }
    };
    if n != Vec3::ZERO {
        for side in [n * r, -n * r] {
            take(ray_triangle(o, d, [v[0] + side, v[1] + side, v[2] + side]));
        }
    }
    for i in 0..3 {
        take(ray_round_cone(o, d, v[i], v[(i + 1) % 3], r, r));
    }
    best
}

/// Solid round cone vs axis-aligned box. The distance from a point moving
/// along the axis to the (convex) box minus the linearly varying radius is a
/// convex function of the axis parameter, so a golden-section search finds
/// its minimum.
fn round_cone_overlaps_box(a: Vec3, b: Vec3, ra: f32, rb: f32, lo: Vec3, hi: Vec3) -> bool {
    let f = |t: f32| {
        let p = a.lerp(b, t);
        let q = p.clamp(lo, hi);
        p.distance(q) - (ra + (rb - ra) * t)
    };
    const INV_PHI: f32 = 0.618_034;
    let (mut x0, mut x1) = (0.0f32, 1.0f32);
    let mut c = x1 - (x1 - x0) * INV_PHI;
    let mut e = x0 + (x1 - x0) * INV_PHI;
    let (mut fc, mut fe) = (f(c), f(e));
    for _ in 0..40 {
        if fc.min(fe) <= 0.0 {
            return true;
        }
        if fc < fe {
            x1 = e;
            e = c;
            fe = fc;
            c = x1 - (x1 - x0) * INV_PHI;
            fc = f(c);
        } else {
            x0 = c;
            c = e;
            fc = fe;
            e = x0 + (x1 - x0) * INV_PHI;
            fe = f(e);
        }
    }
    f(0.0).min(f(1.0)).min(fc).min(fe) <= 0.0
}

/// Triangle vs axis-aligned box, separating-axis test (Akenine-Möller).
fn triangle_overlaps_box(v: [Vec3; 3], lo: Vec3, hi: Vec3) -> bool {
    let c = (lo + hi) * 0.5;
    let h = (hi - lo) * 0.5;
    let p = [v[0] - c, v[1] - c, v[2] - c];
    let e = [p[1] - p[0], p[2] - p[1], p[0] - p[2]];
    let separated = |axis: Vec3| {
        if axis.length_squared() < 1e-20 {
            return false;
        }
        let proj = [p[0].dot(axis), p[1].dot(axis), p[2].dot(axis)];
        let r = h.x * axis.x.abs() + h.y * axis.y.abs() + h.z * axis.z.abs();
        proj[0].min(proj[1]).min(proj[2]) > r || proj[0].max(proj[1]).max(proj[2]) < -r
    };
    for box_axis in [Vec3::X, Vec3::Y, Vec3::Z] {
        if separated(box_axis) {
            return false;
        }
        for edge in e {
            if separated(box_axis.cross(edge)) {
                return false;
            }
        }
    }
    !separated(e[0].cross(e[1]))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Signed distance to a round cone, by brute force over the axis.
    fn sdf_round_cone(p: Vec3, a: Vec3, b: Vec3, ra: f32, rb: f32) -> f32 {
        (0..=2000)
            .map(|i| {
                let t = i as f32 / 2000.0;
                p.distance(a.lerp(b, t)) - (ra + (rb - ra) * t)
            })
            .fold(f32::INFINITY, f32::min)
    }

    #[test]
    fn round_cone_hit_lies_on_surface_and_matches_marching() {
        let (a, b, ra, rb) = (Vec3::new(0.0, 1.0, 0.0), Vec3::new(2.0, 1.5, 0.3), 0.3, 0.1);
        let mut hits = 0;
        for i in 0..200 {
            let ang = i as f32 * 0.37;
            let o = Vec3::new(
                1.0 + 3.0 * ang.cos(),
                1.2 + (i as f32 * 0.13).sin(),
                3.0 * ang.sin(),
            );
            let target =
                a.lerp(b, (i % 7) as f32 / 6.0) + Vec3::new(0.0, 0.2 * ((i % 5) as f32 - 2.0), 0.0);
            let d = (target - o).normalize();
            // March the SDF to find the reference hit.
            let mut t = 0.0;
            let mut marched = None;
            for _ in 0..400 {
                let s = sdf_round_cone(o + d * t, a, b, ra, rb);
                if s < 1e-4 {
                    marched = Some(t);
                    break;
                }
                t += s;
                if t > 10.0 {
                    break;
                }
            }
            let hit = ray_round_cone(o, d, a, b, ra, rb);
            match (hit, marched) {
                (Some((t, n)), Some(tm)) => {
                    hits += 1;
                    assert!((t - tm).abs() < 2e-3, "t {t} vs marched {tm}");
                    assert!(sdf_round_cone(o + d * t, a, b, ra, rb).abs() < 1e-3);
                    assert!((n.length() - 1.0).abs() < 1e-3);
                    assert!(n.dot(d) < 0.0, "normal must face the ray");
                }
                (None, None) => {}
                (h, m) => panic!("analytic {h:?} vs marched {m:?}"),
            }
        }
        assert!(hits > 100);
    }

    #[test]
    fn hot_sweep_matches_primitive_sweep() {
        let support = crate::SupportId(0);
        let cones = [
            (Vec3::new(0.0, 1.0, 0.0), Vec3::new(2.0, 1.5, 0.3), 0.3, 0.1),
            (
                Vec3::new(-1.0, 0.0, 0.5),
                Vec3::new(-1.0, 3.0, 0.5),
                0.2,
                0.2,
            ),
            (
                Vec3::new(0.5, 0.5, 0.5),
                Vec3::new(0.6, 0.5, 0.5),
                0.05,
                0.4,
            ),
            (Vec3::new(1.0, 2.0, 3.0), Vec3::new(1.0, 2.0, 3.0), 0.3, 0.3),
        ];
        let mut hits = 0;
        for (ci, &(a, b, ra, rb)) in cones.iter().enumerate() {
            let p = Primitive::Cone {
                a,
                b,
                ra,
                rb,
                support,
            };
            let hot = HotPrim::new(&p);
            for i in 0..400 {
                let f = i as f32;
                let o = Vec3::new(
                    3.0 * (f * 0.37).cos(),
                    1.5 + 2.0 * (f * 0.13).sin(),
                    3.0 * (f * 0.71).sin(),
                );
                let target = a.lerp(b, (i % 9) as f32 / 8.0)
                    + Vec3::new(
                        0.1 * ((i % 5) as f32 - 2.0),
                        0.1 * ((i % 3) as f32 - 1.0),
                        0.0,
                    );
                let d = (target - o).normalize();
                for r in [0.0, 0.05, 0.3] {
                    let want = p.sweep(o, d, r);
                    let got = hot.sweep(&p, o.into(), d.into(), r);
                    match (want, got) {
                        (Some((tw, nw)), Some((tg, ng))) => {
                            hits += 1;
                            assert!((tw - tg).abs() < 1e-5, "cone {ci}: t {tw} vs {tg}");
                            assert!(nw.distance(ng) < 1e-4, "cone {ci}: n {nw} vs {ng}");
                        }
                        (None, None) => {}
                        (w, g) => panic!("cone {ci}, ray {i}, r {r}: {w:?} vs hot {g:?}"),
                    }
                }
            }
        }
        assert!(hits > 1000, "{hits}");
        let tri = Primitive::Tri {
            v: [Vec3::ZERO, Vec3::X, Vec3::Y],
            support,
        };
        let (o, d) = (Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z);
        for r in [0.0, 0.1] {
            assert_eq!(
                HotPrim::new(&tri).sweep(&tri, o.into(), d.into(), r),
                tri.sweep(o, d, r)
            );
        }
    }

    #[test]
    fn triangle_box_overlap_cases() {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(triangle_overlaps_box(
            tri,
            Vec3::splat(-0.1),
            Vec3::splat(0.1)
        ));
        assert!(!triangle_overlaps_box(
            tri,
            Vec3::new(0.6, 0.6, -0.1),
            Vec3::new(0.9, 0.9, 0.1)
        ));
        assert!(!triangle_overlaps_box(
            tri,
            Vec3::new(0.0, 0.0, 0.2),
            Vec3::new(1.0, 1.0, 0.3)
        ));
    }

    #[test]
    fn cone_box_overlap_cases() {
        let (a, b) = (Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0));
        assert!(round_cone_overlaps_box(
            a,
            b,
            0.1,
            0.1,
            Vec3::new(0.9, 0.05, -0.1),
            Vec3::new(1.1, 0.5, 0.1)
        ));
        assert!(!round_cone_overlaps_box(
            a,
            b,
            0.1,
            0.1,
            Vec3::new(0.9, 0.15, -0.1),
            Vec3::new(1.1, 0.5, 0.1)
        ));
        // Box inside the solid counts as overlap.
        assert!(round_cone_overlaps_box(
            a,
            b,
            0.5,
            0.5,
            Vec3::splat(-0.01) + Vec3::X,
            Vec3::splat(0.01) + Vec3::X
        ));
    }
}
