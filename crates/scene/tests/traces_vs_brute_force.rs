//! Property tests: BVH traces equal a brute-force scan over every primitive,
//! for random rays, sphere sweeps and oriented boxes, on a procedural forest
//! (analytic capsules) and on a scene with triangle meshes.

use std::sync::OnceLock;

use glam::{Quat, Vec3};
use proptest::prelude::*;
use slothsim_scene::{
    BoxOverlap, ForestConfig, LineTrace, Scene, SphereSweep, Support, SupportKind, TraceError,
    TraceRequest, TraceScene, TriMesh, generate_forest,
};

fn forest() -> &'static TraceScene {
    static F: OnceLock<TraceScene> = OnceLock::new();
    F.get_or_init(|| {
        let cfg = ForestConfig {
            trees: 6,
            area_m: 16.0,
            seed: 7,
            ..Default::default()
        };
        TraceScene::new(generate_forest(&cfg).unwrap())
    })
}

/// A tube tessellated into triangles around the segment `a–b`.
fn tube_mesh(a: Vec3, b: Vec3, r: f32, sides: u32) -> TriMesh {
    let axis = (b - a).normalize();
    let u = axis.any_orthonormal_vector();
    let v = axis.cross(u);
    let mut positions = Vec::new();
    for end in [a, b] {
        for i in 0..sides {
            let t = i as f32 / sides as f32 * std::f32::consts::TAU;
            positions.push(end + (u * t.cos() + v * t.sin()) * r);
        }
    }
    let mut triangles = Vec::new();
    for i in 0..sides {
        let j = (i + 1) % sides;
        triangles.push([i, j, sides + i]);
        triangles.push([j, sides + j, sides + i]);
    }
    TriMesh {
        positions,
        triangles,
    }
}

fn meshes() -> &'static TraceScene {
    static M: OnceLock<TraceScene> = OnceLock::new();
    M.get_or_init(|| {
        let mut supports = Vec::new();
        for i in 0..12 {
            let x = (i % 4) as f32 * 1.5 - 2.0;
            let z = (i / 4) as f32 * 1.5 - 1.5;
            let a = Vec3::new(x, 0.5 + 0.2 * i as f32, z);
            let b = a + Vec3::new(1.0, 0.3 * ((i % 3) as f32 - 1.0), 0.4);
            supports.push(
                Support::new(vec![a, b], vec![0.05, 0.05]).with_mesh(tube_mesh(a, b, 0.05, 10)),
            );
        }
        // Mixed scene: capsules too.
        supports.push(Support::new(
            vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(0.0, 4.0, 0.0)],
            vec![0.2, 0.15],
        ));
        TraceScene::new(Scene::new(supports).unwrap())
    })
}

fn vec3(lo: f32, hi: f32) -> impl Strategy<Value = Vec3> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

fn dir() -> impl Strategy<Value = Vec3> {
    vec3(-1.0, 1.0).prop_filter("non-zero", |d| d.length() > 0.05)
}

/// Rays aimed near supports so most of them hit something.
fn line_in(scene: &'static TraceScene) -> impl Strategy<Value = LineTrace> {
    let b = scene.scene().bounds();
    let (lo, hi) = (b.min.min_element() - 1.0, b.max.max_element() + 1.0);
    (vec3(lo, hi), dir(), 0.0f32..1.0, prop::bool::ANY).prop_map(move |(o, d, frac, aim)| {
        let ss = scene.scene().supports();
        let s = &ss[(frac * ss.len() as f32) as usize % ss.len()];
        let d = if aim {
            (s.nodes[0].lerp(s.nodes[1], frac) - o)
                .try_normalize()
                .unwrap_or(d)
        } else {
            d
        };
        LineTrace {
            origin: o,
            dir: d,
            max_dist: 10.0 + 100.0 * frac,
        }
    })
}

fn assert_same(scene: &TraceScene, req: TraceRequest) {
    let q = scene.query();
    let bvh = q.trace(&req).unwrap();
    let brute = q.trace_brute_force(&req).unwrap();
    match (bvh, brute) {
        (None, None) => {}
        (Some(a), Some(b)) => {
            assert!((a.distance - b.distance).abs() < 1e-5, "{a:?} vs {b:?}");
            assert!(a.point.distance(b.point) < 1e-4, "{a:?} vs {b:?}");
            assert_eq!(a.kind, scene.scene().support(a.support).kind);
            assert!(a.point.is_finite() && a.normal.is_finite());
            assert!(
                (a.normal.length() - 1.0).abs() < 1e-3,
                "normal {:?} len {} for {req:?}, hit {a:?}",
                a.normal,
                a.normal.length()
            );
            // Equal distance but different support only on exact ties.
            if a.support != b.support {
                assert!((a.distance - b.distance).abs() < 1e-6);
            }
        }
        (a, b) => panic!("bvh {a:?} vs brute force {b:?} for {req:?}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn line_traces_match_brute_force_on_forest(line in line_in(forest())) {
        assert_same(forest(), TraceRequest::Line(line));
    }

    #[test]
    fn sphere_sweeps_match_brute_force_on_forest(line in line_in(forest()), r in 0.0f32..0.5) {
        assert_same(forest(), TraceRequest::Sphere(SphereSweep { line, radius: r }));
    }

    #[test]
    fn traces_match_brute_force_on_meshes(line in line_in(meshes()), r in 0.0f32..0.2) {
        assert_same(meshes(), TraceRequest::Line(line));
        assert_same(meshes(), TraceRequest::Sphere(SphereSweep { line, radius: r }));
    }

    #[test]
    fn box_overlaps_match_brute_force(
        c in vec3(-8.0, 12.0),
        h in vec3(0.0, 1.5),
        axis in dir(),
        angle in 0.0f32..3.2,
        on_mesh in prop::bool::ANY,
    ) {
        let scene = if on_mesh { meshes() } else { forest() };
        let bx = BoxOverlap { center: c, half_extents: h, rotation: Quat::from_axis_angle(axis.normalize(), angle) };
        let (mut a, mut b) = (Vec::new(), Vec::new());
        scene.query().overlap_box(&bx, &mut a).unwrap();
        scene.query().overlap_box_brute_force(&bx, &mut b).unwrap();
        prop_assert_eq!(a, b);
    }
}

#[test]
fn line_hits_lie_on_capsule_surfaces() {
    let scene = forest();
    let q = scene.query();
    let mut hits = 0;
    for s in scene.scene().supports() {
        let mid = s.nodes[0].lerp(s.nodes[1], 0.5);
        let side = (s.nodes[1] - s.nodes[0]).any_orthonormal_vector();
        let line = LineTrace {
            origin: mid + side * 2.0,
            dir: -side,
            max_dist: 5.0,
        };
        if let Some(hit) = q.line(&line).unwrap()
            && hit.support == s.id
        {
            hits += 1;
            let (axis_pt, _, _, r) = s.closest_on_axis(hit.point);
            assert!((axis_pt.distance(hit.point) - r).abs() < 1e-3);
        }
    }
    assert!(hits > scene.scene().supports().len() / 2);
}

#[test]
fn batched_traces_equal_single_traces() {
    let scene = forest();
    let q = scene.query();
    let reqs: Vec<TraceRequest> = (0..2000)
        .map(|i| {
            let t = i as f32 * 0.731;
            TraceRequest::Line(LineTrace {
                origin: Vec3::new(8.0 * t.cos(), 1.0 + (i % 13) as f32, 8.0 * t.sin()),
                dir: Vec3::new(-t.cos(), 0.1 * ((i % 5) as f32 - 2.0), -t.sin()),
                max_dist: 20.0,
            })
        })
        .collect();
    let mut par = vec![Ok(None); reqs.len()];
    let mut ser = vec![Ok(None); reqs.len()];
    q.trace_batch(&reqs, &mut par);
    q.trace_batch_serial(&reqs, &mut ser);
    assert_eq!(par, ser);
    assert!(par.iter().filter(|r| matches!(r, Ok(Some(_)))).count() > 200);
}

#[test]
fn bad_trace_input_is_an_error_not_a_nan() {
    let q = forest().query();
    for d in [Vec3::ZERO, Vec3::NAN, Vec3::new(f32::INFINITY, 0.0, 0.0)] {
        let r = q.line(&LineTrace {
            origin: Vec3::ZERO,
            dir: d,
            max_dist: 1.0,
        });
        assert_eq!(r, Err(TraceError::InvalidDirection));
    }
    let line = LineTrace {
        origin: Vec3::NAN,
        dir: Vec3::X,
        max_dist: 1.0,
    };
    assert!(q.line(&line).is_err());
    let line = LineTrace {
        origin: Vec3::ZERO,
        dir: Vec3::X,
        max_dist: f32::NAN,
    };
    assert!(q.line(&line).is_err());
    let sweep = SphereSweep {
        line: LineTrace {
            origin: Vec3::ZERO,
            dir: Vec3::X,
            max_dist: 1.0,
        },
        radius: -1.0,
    };
    assert!(q.sphere(&sweep).is_err());
    let bx = BoxOverlap {
        center: Vec3::ZERO,
        half_extents: Vec3::new(-1.0, 1.0, 1.0),
        rotation: Quat::IDENTITY,
    };
    assert!(q.overlap_box(&bx, &mut Vec::new()).is_err());
}

#[test]
fn classification_by_tilt() {
    let mk = |deg: f32| {
        let d = Vec3::new(deg.to_radians().cos(), deg.to_radians().sin(), 0.0);
        Support::new(vec![Vec3::ZERO, d * 2.0], vec![0.05, 0.05]).kind
    };
    assert_eq!(mk(0.0), SupportKind::Branch);
    assert_eq!(mk(45.0), SupportKind::Branch);
    assert_eq!(mk(69.5), SupportKind::Branch);
    assert_eq!(mk(70.5), SupportKind::Trunk);
    assert_eq!(mk(90.0), SupportKind::Trunk);
    assert_eq!(mk(-80.0), SupportKind::Trunk);
    // An explicit tag wins over the tilt rule.
    let tagged =
        Support::new(vec![Vec3::ZERO, Vec3::Y], vec![0.05, 0.05]).with_kind(SupportKind::Branch);
    assert_eq!(tagged.kind, SupportKind::Branch);
    assert!(tagged.tagged);
}
