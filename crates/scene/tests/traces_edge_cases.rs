//! Traces that stress the BVH walk's corner cases against the brute-force
//! scan: axis-aligned directions (with ±0 components), large sweep radii,
//! rays starting on or inside supports, one-primitive and empty scenes.

use std::sync::OnceLock;

use glam::Vec3;
use proptest::prelude::*;
use slothsim_scene::{
    ForestConfig, LineTrace, Scene, SphereSweep, Support, TraceRequest, TraceScene, generate_forest,
};

fn forest() -> &'static TraceScene {
    static F: OnceLock<TraceScene> = OnceLock::new();
    F.get_or_init(|| {
        let cfg = ForestConfig {
            trees: 5,
            area_m: 12.0,
            seed: 11,
            ..Default::default()
        };
        TraceScene::new(generate_forest(&cfg).unwrap())
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
            if a.support != b.support {
                assert!((a.distance - b.distance).abs() < 1e-6);
            }
        }
        (a, b) => panic!("bvh {a:?} vs brute force {b:?} for {req:?}"),
    }
}

fn both(scene: &TraceScene, line: LineTrace, radius: f32) {
    assert_same(scene, TraceRequest::Line(line));
    assert_same(scene, TraceRequest::Sphere(SphereSweep { line, radius }));
}

/// Axis directions, with each zero component as +0 and as -0.
fn axis_dirs() -> Vec<Vec3> {
    let mut dirs = Vec::new();
    for axis in 0..3 {
        for sign in [1.0f32, -1.0] {
            for zeros in 0..4u32 {
                let mut v = [0.0f32; 3];
                let mut z = 0;
                for (k, c) in v.iter_mut().enumerate() {
                    if k == axis {
                        *c = sign;
                    } else {
                        *c = if zeros & (1 << z) != 0 { -0.0 } else { 0.0 };
                        z += 1;
                    }
                }
                dirs.push(Vec3::from_array(v));
            }
        }
    }
    dirs
}

#[test]
fn axis_aligned_traces_match_brute_force() {
    let scene = forest();
    let mut hits = 0;
    for s in scene.scene().supports() {
        for (k, d) in axis_dirs().into_iter().enumerate() {
            let target = s.nodes[0].lerp(s.nodes[1], (k % 7) as f32 / 6.0);
            let line = LineTrace {
                origin: target - d * (s.radii[0] + 0.3),
                dir: d,
                max_dist: 2.0,
            };
            for r in [0.0, 0.05, 0.3, 1.0] {
                both(scene, line, r);
            }
            if scene.query().line(&line).unwrap().is_some() {
                hits += 1;
            }
        }
    }
    assert!(hits > 100, "{hits}");
}

#[test]
fn one_primitive_and_empty_scenes() {
    let one = TraceScene::new(
        Scene::new(vec![Support::new(
            vec![Vec3::ZERO, Vec3::new(0.0, 3.0, 0.0)],
            vec![0.2, 0.1],
        )])
        .unwrap(),
    );
    assert_eq!(one.stats().primitives, 1);
    let mut hits = 0;
    for k in 0..64 {
        let a = k as f32 * 0.41;
        let o = Vec3::new(2.0 * a.cos(), 0.05 * k as f32, 2.0 * a.sin());
        let line = LineTrace {
            origin: o,
            dir: Vec3::new(0.0, 1.5, 0.0) - o,
            max_dist: 5.0,
        };
        both(&one, line, 0.1);
        hits += usize::from(one.query().line(&line).unwrap().is_some());
    }
    assert!(hits > 32);
    if let Ok(empty) = Scene::new(Vec::new()) {
        let t = TraceScene::new(empty);
        let line = LineTrace {
            origin: Vec3::ZERO,
            dir: Vec3::X,
            max_dist: 1.0,
        };
        assert_eq!(t.query().line(&line), Ok(None));
        assert_eq!(
            t.query().sphere(&SphereSweep { line, radius: 0.3 }),
            Ok(None)
        );
    }
}

fn vec3(lo: f32, hi: f32) -> impl Strategy<Value = Vec3> {
    (lo..hi, lo..hi, lo..hi).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    /// Short step-search-like rays from near (or inside) a support's surface,
    /// with sweep radii from 0 up to well above any fast-path limit.
    #[test]
    fn near_surface_sweeps_match_brute_force(
        pick in 0.0f32..1.0,
        along in 0.0f32..1.0,
        off in vec3(-1.0, 1.0),
        gap in -0.1f32..0.6,
        jitter in vec3(-0.3, 0.3),
        max_dist in 0.0f32..1.5,
        r in prop_oneof![Just(0.0f32), 0.0f32..0.12, 0.1f32..2.0],
    ) {
        let scene = forest();
        let ss = scene.scene().supports();
        let s = &ss[(pick * ss.len() as f32) as usize % ss.len()];
        let axis_pt = s.nodes[0].lerp(s.nodes[1], along);
        let side = off.cross(s.nodes[1] - s.nodes[0]).normalize_or(Vec3::X);
        let origin = axis_pt + side * (s.radii[0] + gap);
        let dir = (axis_pt - origin).normalize_or(Vec3::Y) + jitter;
        prop_assume!(dir.length() > 1e-3);
        both(scene, LineTrace { origin, dir, max_dist }, r);
    }
}
