//! Unit tests of the judge, on synthetic walks (`crate::stats::synthetic`).

use super::*;
use crate::stats::synthetic::{DT, Walk};

const TIME_LIMIT_S: f32 = 24.0;

fn judge_stream(
    walk: &Walk,
    time_limit_s: f32,
    mut edit: impl FnMut(i64, &mut SlothObservation),
) -> JudgeReport {
    let mut judge = Judge::new(Tolerances::default(), time_limit_s);
    for f in 1..=walk.frames {
        let mut obs = walk.observation(f);
        edit(f, &mut obs);
        judge.observe(&obs);
    }
    judge.finish()
}

/// Judges the DSDC walk with `edit` applied and returns the failures.
fn failures_with(edit: impl FnMut(i64, &mut SlothObservation)) -> Vec<String> {
    let report = judge_stream(&Walk::dsdc(), TIME_LIMIT_S, edit);
    let verdict = report.verdict(&Tolerances::default());
    assert_eq!(verdict.pass, verdict.failures.is_empty());
    verdict.failures
}

/// Exactly one failure, naming `measure`.
fn assert_single_failure(failures: &[String], measure: &str) {
    assert_eq!(failures.len(), 1, "{failures:?}");
    assert!(failures[0].starts_with(measure), "{failures:?}");
}

#[test]
fn clean_walk_passes() {
    let walk = Walk::dsdc();
    let report = judge_stream(&walk, TIME_LIMIT_S, |_, _| {});
    let verdict = report.verdict(&Tolerances::default());
    assert!(verdict.pass, "{:?}", verdict.failures);
    assert_eq!(report.frames, walk.frames as u64);
    assert!(report.goal_reached);
    let t = report.goal_time_s.unwrap();
    assert!((t - walk.goal_time_s(0.3)).abs() <= 2.0 * DT, "{t}");
    assert!((report.duration_s - walk.frames as f32 * DT).abs() < 1e-3);
    assert!(report.max_grip_slip_m < 1e-5, "{}", report.max_grip_slip_m);
    assert_eq!(report.max_surface_gap_m, 0.0);
    assert!(report.max_reach_ratio > 0.3 && report.max_reach_ratio < 1.0);
    assert_eq!(report.min_limbs_in_contact, 2);
    assert_eq!(report.joint_limit_violations, 0);
    assert_eq!(report.nan_count, 0);
    assert_eq!(report.head_below_hips_on_trunk_frames, 0);
}

#[test]
fn ik_error_at_held_grip_is_a_slip() {
    let f = failures_with(|f, o| {
        let lf = &mut o.limbs[Limb::LF.index()];
        if (400..410).contains(&f) && lf.planted {
            lf.effector_ws.x += 0.0071;
        }
    });
    assert_single_failure(&f, "max_grip_slip_m 0.0071 > 0.005");
    assert!(f[0].contains("LF at t="), "{f:?}");
}

#[test]
fn grip_jump_is_a_slip() {
    let f = failures_with(|f, o| {
        let rh = &mut o.limbs[Limb::RH.index()];
        if f == 100 && rh.planted {
            rh.grip_ws.z += 0.01;
            rh.effector_ws = rh.grip_ws;
        }
    });
    assert_single_failure(&f, "max_grip_slip_m");
}

#[test]
fn slow_slide_adds_up_to_a_slip() {
    // 1 mm per frame: below the limit frame to frame, 2 cm over the stance.
    let mut slide: f32 = 0.0;
    let f = failures_with(|f, o| {
        let lh = &mut o.limbs[Limb::LH.index()];
        if !lh.planted {
            slide = 0.0;
        } else if f > 300 {
            slide += 0.001;
            lh.grip_ws.z += slide.min(0.02);
            lh.effector_ws = lh.grip_ws;
        }
    });
    assert_single_failure(&f, "max_grip_slip_m");
}

#[test]
fn surface_gap_of_planted_limb_fails() {
    let f = failures_with(|f, o| {
        let rf = &mut o.limbs[Limb::RF.index()];
        if f == 500 && rf.planted {
            rf.surface_gap = 0.02;
        }
    });
    assert_single_failure(&f, "max_surface_gap_m 0.02 > 0.01");
    // A swinging limb's gap does not count (the walk's swing gap is 5 cm).
}

#[test]
fn over_reach_fails() {
    let f = failures_with(|f, o| {
        if f == 600 {
            let lh = &mut o.limbs[Limb::LH.index()];
            lh.root_ws = lh.effector_ws - Vec3::new(0.5, 0.0, 0.0);
        }
    });
    assert_single_failure(&f, "max_reach_ratio 1.25 > 1");
    assert!(f[0].contains("LH"), "{f:?}");
}

#[test]
fn limit_violation_fails_above_epsilon_only() {
    let f = failures_with(|f, o| {
        if f == 700 {
            o.limbs[Limb::RF.index()].limit_violation = 0.01;
        }
    });
    assert_single_failure(&f, "joint_limit_violations 1 > 0");
    let f = failures_with(|_, o| o.limbs[0].limit_violation = 0.5 * LIMIT_VIOLATION_EPSILON_RAD);
    assert!(f.is_empty(), "{f:?}");
}

#[test]
fn one_limb_contact_fails() {
    let f = failures_with(|f, o| {
        if f == 800 {
            // Keep only the first planted limb planted.
            let keep = o.limbs.iter().position(|l| l.planted).unwrap();
            for (i, l) in o.limbs.iter_mut().enumerate() {
                l.planted &= i == keep;
            }
        }
    });
    assert_single_failure(&f, "min_limbs_in_contact 1 < 2");
}

#[test]
fn penetration_fails() {
    let f = failures_with(|f, o| {
        if (900..905).contains(&f) {
            o.penetration_m = 0.015;
        }
    });
    assert_single_failure(&f, "max_penetration_m 0.015 > 0.01");
}

#[test]
fn head_below_hips_on_trunk_fails_only_on_trunk() {
    let f = failures_with(|f, o| {
        o.on_trunk = true;
        if (100..103).contains(&f) {
            o.head_ws.y = o.hips_ws.y - 0.1;
        }
    });
    assert_single_failure(&f, "head_below_hips_on_trunk_frames 3 > 0");
    let f = failures_with(|_, o| o.head_ws.y = o.hips_ws.y - 0.1);
    assert!(f.is_empty(), "{f:?}");
}

#[test]
fn nan_flag_and_non_finite_values_fail() {
    let f = failures_with(|f, o| o.has_nan = f == 10);
    assert_single_failure(&f, "nan_count 1 > 0");

    let walk = Walk::dsdc();
    let report = judge_stream(&walk, TIME_LIMIT_S, |f, o| {
        if f == 20 {
            o.limbs[2].effector_ws.y = f32::NAN;
            o.penetration_m = f32::INFINITY;
        }
        if f == 30 {
            o.limbs[3].limb_length = 0.0;
        }
    });
    assert_eq!(report.nan_count, 2);
    // The bad frames do not poison the other measures.
    assert!(report.max_penetration_m == 0.0 && report.max_reach_ratio < 1.0);
    let f = report.verdict(&Tolerances::default()).failures;
    assert_single_failure(&f, "nan_count 2 > 0");
    serde_json::to_string(&report).unwrap();
}

#[test]
fn goal_counts_only_while_held() {
    // Near the goal but not holding its support (e.g. under the branch
    // beside a goal on a trunk): not reached, and the failure says why.
    let report = judge_stream(&Walk::dsdc(), TIME_LIMIT_S, |_, o| o.goal_held = false);
    assert!(!report.goal_reached && report.goal_time_s.is_none());
    assert!(report.min_goal_distance_m.unwrap() <= 0.3);
    let f = report.verdict(&Tolerances::default()).failures;
    assert_single_failure(&f, "goal_reached false: within 0.3");
    assert!(f[0].contains("all four limbs"), "{f:?}");
    // Held from frame 600 on: reached then (or at the first in-range frame after).
    let walk = Walk::dsdc();
    let late = judge_stream(&walk, TIME_LIMIT_S, |i, o| o.goal_held = i >= 600);
    let t = late.goal_time_s.unwrap();
    assert!(
        t >= 600.0 * DT - 1e-3 && t >= walk.goal_time_s(0.3) - 2.0 * DT,
        "{t}"
    );
}

#[test]
fn goal_not_reached_in_time_fails() {
    let walk = Walk::dsdc();
    let report = judge_stream(&walk, 10.0, |_, _| {});
    assert!(report.goal_reached);
    let f = report.verdict(&Tolerances::default()).failures;
    assert_single_failure(&f, "goal_time_s 18.8");
    assert!(f[0].contains("> time_limit_s 10"), "{f:?}");

    let far = Walk {
        goal_z: 100.0,
        ..walk
    };
    let report = judge_stream(&far, TIME_LIMIT_S, |_, _| {});
    assert!(!report.goal_reached && report.goal_time_s.is_none());
    let f = report.verdict(&Tolerances::default()).failures;
    assert_single_failure(&f, "goal_reached false: goal not reached");
}

#[test]
fn empty_stream_fails_goal_without_panic() {
    let judge = Judge::new(Tolerances::default(), TIME_LIMIT_S);
    let report = judge.finish();
    assert_eq!(report.frames, 0);
    assert!(!report.goal_reached);
    let verdict = report.verdict(&Tolerances::default());
    assert!(!verdict.pass);
    assert!(
        verdict
            .failures
            .iter()
            .any(|f| f.contains("goal not reached")),
        "{verdict:?}"
    );
    assert!(verdict.failures.iter().any(|f| f.starts_with("frames 0")));
    let json = serde_json::to_string(&report).unwrap();
    let back: JudgeReport = serde_json::from_str(&json).unwrap();
    assert_eq!(back, report);
}

#[test]
fn json_keys_match_the_issue() {
    let report = judge_stream(&Walk::dsdc(), TIME_LIMIT_S, |_, _| {});
    let v = serde_json::to_value(&report).unwrap();
    for key in [
        "goal_reached",
        "goal_time_s",
        "max_grip_slip_m",
        "max_surface_gap_m",
        "max_reach_ratio",
        "joint_limit_violations",
        "max_limit_violation_rad",
        "min_limbs_in_contact",
        "max_penetration_m",
        "head_below_hips_on_trunk_frames",
        "nan_count",
        "frames",
        "duration_s",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    let back: JudgeReport = serde_json::from_value(v).unwrap();
    assert_eq!(back, report);
}

#[test]
fn tolerances_default_to_issue_limits_and_reject_looser() {
    let t = Tolerances::default();
    assert_eq!(t.max_grip_slip_m, 0.005);
    assert_eq!(t.max_surface_gap_m, 0.01);
    assert_eq!(t.max_reach_ratio, 1.0);
    assert_eq!(t.max_joint_limit_violations, 0);
    assert_eq!(t.min_limbs_in_contact, 2);
    assert_eq!(t.max_penetration_m, 0.01);
    assert_eq!(t.max_nan_count, 0);
    assert_eq!(t.max_head_below_hips_on_trunk_frames, 0);
    assert_eq!(t.goal_tolerance_m, 0.3);
    t.validate().unwrap();

    let tighter = Tolerances {
        max_grip_slip_m: 0.002,
        min_limbs_in_contact: 3,
        ..t
    };
    tighter.validate().unwrap();
    let looser = Tolerances {
        max_grip_slip_m: 0.006,
        ..t
    };
    assert_eq!(looser.validate().unwrap_err().field, "max_grip_slip_m");
    let one_limb = Tolerances {
        min_limbs_in_contact: 1,
        ..t
    };
    assert_eq!(
        one_limb.validate().unwrap_err().field,
        "min_limbs_in_contact"
    );
    let nan = Tolerances {
        max_penetration_m: f32::NAN,
        ..t
    };
    assert!(nan.validate().is_err());

    // Partial TOML keeps the defaults for what it leaves out.
    let parsed: Tolerances = toml::from_str("max_grip_slip_m = 0.003").unwrap();
    assert_eq!(parsed.max_grip_slip_m, 0.003);
    assert_eq!(parsed.max_surface_gap_m, 0.01);
    assert!(toml::from_str::<Tolerances>("max_grip_slp_m = 0.003").is_err());
}

#[test]
fn tighter_tolerance_judges_the_same_report_stricter() {
    let report = judge_stream(&Walk::dsdc(), TIME_LIMIT_S, |_, _| {});
    let strict = Tolerances {
        max_reach_ratio: 0.5,
        ..Tolerances::default()
    };
    let f = report.verdict(&strict).failures;
    assert_single_failure(&f, "max_reach_ratio");
}

#[test]
fn crowd_merge_keeps_the_worst() {
    let clean = judge_stream(&Walk::dsdc(), TIME_LIMIT_S, |_, _| {});
    let slipping = judge_stream(&Walk::dsdc(), TIME_LIMIT_S, |f, o| {
        if f == 200 {
            assert!(o.limbs[Limb::LH.index()].planted);
            o.limbs[Limb::LH.index()].effector_ws.x += 0.02;
            o.penetration_m = 0.003;
        }
    });
    let lost = judge_stream(
        &Walk {
            goal_z: 100.0,
            ..Walk::dsdc()
        },
        TIME_LIMIT_S,
        |_, _| {},
    );
    let crowd = JudgeReport::aggregate([&clean, &slipping]).unwrap();
    assert_eq!(crowd.sloths, 2);
    assert_eq!(crowd.frames, clean.frames * 2);
    assert_eq!(crowd.max_grip_slip_m, slipping.max_grip_slip_m);
    assert_eq!(crowd.worst.max_grip_slip_m, slipping.worst.max_grip_slip_m);
    assert_eq!(crowd.max_penetration_m, 0.003);
    assert!(crowd.goal_reached);
    let f = crowd.verdict(&Tolerances::default()).failures;
    assert_single_failure(&f, "max_grip_slip_m");

    let crowd = JudgeReport::aggregate([&clean, &lost]).unwrap();
    assert!(!crowd.goal_reached && crowd.goal_time_s.is_none());
    assert!(crowd.min_goal_distance_m.unwrap() > 90.0);
    assert!(JudgeReport::aggregate([]).is_none());
}

/// `o` with its `i`-th float (in [`observation_is_finite`]'s order: time,
/// penetration, goal distance, body, rotation, head, hips, then per limb its
/// grip, effector, root, length, gap and violation; 64 in all) set to `x`.
fn with_value(o: &SlothObservation, i: usize, x: f32) -> SlothObservation {
    let mut o = *o;
    let mut k = i;
    let mut put = |a: &mut [f32]| {
        if k < a.len() {
            a[k] = x;
        }
        k = k.wrapping_sub(a.len());
    };
    let v3 = |v: &mut glam::Vec3, put: &mut dyn FnMut(&mut [f32])| {
        let mut a = v.to_array();
        put(&mut a);
        *v = glam::Vec3::from_array(a);
    };
    let mut t = [o.time_s, o.penetration_m, o.goal_distance_m];
    put(&mut t);
    [o.time_s, o.penetration_m, o.goal_distance_m] = t;
    v3(&mut o.body_pos, &mut put);
    let mut r = o.body_rot.to_array();
    put(&mut r);
    o.body_rot = glam::Quat::from_array(r);
    v3(&mut o.head_ws, &mut put);
    v3(&mut o.hips_ws, &mut put);
    for l in &mut o.limbs {
        v3(&mut l.grip_ws, &mut put);
        v3(&mut l.effector_ws, &mut put);
        v3(&mut l.root_ws, &mut put);
        let mut a = [l.limb_length, l.surface_gap, l.limit_violation];
        put(&mut a);
        [l.limb_length, l.surface_gap, l.limit_violation] = a;
    }
    o
}

/// The branch-free [`observation_is_finite`] answers as the value-by-value
/// test: the synthetic walk's observations as they are, then with one value
/// (any of the 64 floats) made +∞, −∞, NaN, the largest finite or a
/// subnormal, or a limb length made 0, −0 or negative, and with two values at
/// once (an infinity and its negation, whose sum alone would be NaN too).
#[test]
fn observation_is_finite_matches_the_value_by_value_test() {
    let walk = Walk::dsdc();
    let values = [
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        f32::MAX,
        -f32::MAX,
        1e-40,
        0.0,
        -0.0,
        -1.0,
    ];
    let (mut checked, mut finite, mut not) = (0, 0, 0);
    for f in (1..=walk.frames).step_by(97) {
        let base = walk.observation(f);
        assert_eq!(
            observation_is_finite(&base),
            observation_is_finite_by_value(&base)
        );
        // Index 63 is the last float (the fourth limb's violation), 64 none.
        assert_eq!(with_value(&base, 64, f32::NAN), base);
        assert_ne!(
            observation_is_finite_by_value(&with_value(&base, 63, f32::NAN)),
            observation_is_finite_by_value(&base)
        );
        for i in 0..64 {
            for &x in &values {
                let o = with_value(&base, i, x);
                let got = observation_is_finite(&o);
                assert_eq!(
                    got,
                    observation_is_finite_by_value(&o),
                    "frame {f} value {i} = {x}"
                );
                finite += usize::from(got);
                not += usize::from(!got);
                checked += 1;
                let j = (i * 7 + 3) % 64;
                if j != i {
                    let o = with_value(&o, j, -x);
                    assert_eq!(
                        observation_is_finite(&o),
                        observation_is_finite_by_value(&o),
                        "frame {f} values {i}, {j} = {x}"
                    );
                    checked += 1;
                }
            }
        }
    }
    assert!(
        checked > 1000 && finite > 0 && not > 0,
        "{checked} {finite} {not}"
    );
}
