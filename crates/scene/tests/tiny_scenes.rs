//! Regression: scenes with one or a few primitives (the scenario presets) must
//! trace exactly like the brute-force scan, from every side.

use glam::Vec3;
use slothsim_scene::{LineTrace, Preset, PresetKind, SphereSweep, TraceRequest, TraceScene};

#[test]
fn single_pole_is_hit_from_every_side() {
    for kind in PresetKind::ALL {
        let p = Preset::new(kind, None).unwrap();
        let t = TraceScene::new(p.scene.clone());
        let q = t.query();
        let mut hits = 0;
        for s in p.scene.supports() {
            for k in 0..40 {
                let frac = k as f32 / 39.0;
                let a = s.nodes[0].lerp(s.nodes[1], 0.05 + 0.9 * frac);
                let axis = (s.nodes[1] - s.nodes[0]).normalize();
                let ang = k as f32 * 0.7;
                let u = axis.any_orthonormal_vector();
                let out = (u * ang.cos() + axis.cross(u) * ang.sin()).normalize();
                let line = LineTrace {
                    origin: a + out * (s.radii[0] + 0.15),
                    dir: -out,
                    max_dist: 0.17 + s.radii[0],
                };
                for req in [
                    TraceRequest::Line(line),
                    TraceRequest::Sphere(SphereSweep { line, radius: 0.01 }),
                    TraceRequest::Sphere(SphereSweep { line, radius: 0.5 }),
                ] {
                    let bvh = q.trace(&req).unwrap().map(|h| (h.support, h.distance));
                    let brute = q
                        .trace_brute_force(&req)
                        .unwrap()
                        .map(|h| (h.support, h.distance));
                    match (bvh, brute) {
                        (Some(a), Some(b)) => {
                            assert_eq!(a.0, b.0);
                            assert!((a.1 - b.1).abs() < 1e-5);
                            hits += 1;
                        }
                        (None, None) => {}
                        (a, b) => panic!("{kind:?}: bvh {a:?} vs brute force {b:?} for {req:?}"),
                    }
                }
            }
        }
        assert!(hits > 0, "{kind:?}: nothing hit");
    }
    let _ = Vec3::ZERO;
}
