//! Thesis scenarios run end to end and judged by measured properties (the
//! judge's tolerances are the issue's: slip ≤ 5 mm, gap ≤ 1 cm, reach ≤ 1,
//! no joint-limit violation, ≥ 2 limbs in contact, penetration ≤ 1 cm, no NaN).

use std::process::Command;

use slothsim::gait::{LocomotionConfig, Profile};
use slothsim::observe::Tolerances;
use slothsim::rig::Rig;
use slothsim::scene::Preset;
use slothsim::sim::{
    STEADY_AFTER_CYCLES, STEADY_BEFORE_STOP_CYCLES, ScenarioResult, ScenarioSpec, TrunkVariant,
    run_scenario,
};

fn run(name: &str, param: Option<f32>, variant: TrunkVariant, profile: Profile) -> ScenarioResult {
    let spec = ScenarioSpec {
        preset: Preset::by_name(name, param).unwrap(),
        variant,
        cfg: LocomotionConfig::profile(profile),
        dt: 1.0 / 60.0,
        time_limit_s: None,
        tolerances: Tolerances::default(),
    };
    run_scenario(&spec, &Rig::sloth()).unwrap()
}

fn assert_measures_within_issue_limits(r: &ScenarioResult) {
    let j = &r.judge;
    assert!(
        j.goal_reached,
        "{}: goal not reached: {:?}",
        r.scenario, r.verdict
    );
    assert!(j.max_grip_slip_m <= 0.005, "slip {}", j.max_grip_slip_m);
    assert!(j.max_surface_gap_m <= 0.01, "gap {}", j.max_surface_gap_m);
    assert!(j.max_reach_ratio <= 1.0, "reach {}", j.max_reach_ratio);
    assert_eq!(j.joint_limit_violations, 0);
    assert!(j.min_limbs_in_contact >= 2);
    assert!(
        j.max_penetration_m <= 0.01,
        "penetration {}",
        j.max_penetration_m
    );
    assert_eq!(j.nan_count, 0);
    assert!(r.verdict.pass, "{:?}", r.verdict);
}

#[test]
fn pole_free_profile_walks_at_free_ranging_speed_in_diagonal_sequence() {
    let r = run("pole", None, TrunkVariant::Up, Profile::Free);
    assert_measures_within_issue_limits(&r);
    // SPEC: free-ranging mean speed 0.11 ± 0.04 m/s.
    let v = r.gait.speed_mps_mean;
    assert!((0.07..=0.15).contains(&v), "speed {v}");
    assert!(r.gait.is_diagonal_sequence(), "{:?}", r.gait.footfall_order);
}

/// SPEC's steady-state rows (0.2–0.3 m/s): contact, swing and stride means
/// within one s.d., measured over the steady-state window (`gait_steady`:
/// the first two gait cycles and the last before the goal left out).
#[test]
fn pole_steady_profile_matches_spec_timings_in_the_steady_state() {
    let r = run("pole", None, TrunkVariant::Up, Profile::Steady);
    assert_measures_within_issue_limits(&r);
    assert!(r.gait.is_diagonal_sequence(), "{:?}", r.gait.footfall_order);
    let st = r.gait_steady.as_ref().expect("a steady-state window");
    let cycle = LocomotionConfig::profile(Profile::Steady).cycle_duration();
    let first = r.observations[0].time_s;
    let stopped = r.judge.goal_time_s.expect("goal reached");
    assert!((st.from_s - (first + STEADY_AFTER_CYCLES * cycle)).abs() < 1e-4);
    assert!(st.to_s <= stopped - STEADY_BEFORE_STOP_CYCLES * cycle + 1e-4);
    assert!(st.to_s - st.from_s >= cycle);
    // SPEC: steady state at 0.2–0.3 m/s.
    assert!((0.2..=0.3).contains(&st.gait.speed_mps_mean), "{st:?}");
    let g = &st.gait;
    for (limb, contact, swing, stride) in [
        (&g.limbs.lf, (1.50, 0.20), (0.84, 0.20), (0.59, 0.05)),
        (&g.limbs.rf, (1.50, 0.20), (0.84, 0.20), (0.59, 0.05)),
        (&g.limbs.lh, (1.66, 0.25), (0.67, 0.15), (0.60, 0.05)),
        (&g.limbs.rh, (1.66, 0.25), (0.67, 0.15), (0.60, 0.05)),
    ] {
        assert!(limb.strides >= 3 && limb.contacts >= 3, "{limb:?}");
        assert!(
            (limb.contact_s_mean - contact.0).abs() <= contact.1,
            "{limb:?}"
        );
        assert!((limb.swing_s_mean - swing.0).abs() <= swing.1, "{limb:?}");
        assert!(
            (limb.stride_m_mean - stride.0).abs() <= stride.1,
            "{limb:?}"
        );
    }
    // The window leaves out the start: RH's first step, from the spawn
    // stance, is half a stride, so its steady mean is the longer one.
    assert!(g.limbs.rh.strides < r.gait.limbs.rh.strides);
    assert!(
        g.limbs.rh.stride_m_mean > r.gait.limbs.rh.stride_m_mean,
        "{:?} vs {:?}",
        g.limbs.rh,
        r.gait.limbs.rh
    );
}

/// Issue 22: in the steady pole gait the grips carry the body with a
/// residual of at most 5 % of body weight, and the release rule at the
/// issue's 0.05 BW holds no limb back. The weight shift does it: without it the
/// same-side two-limb stances need about 0.1 BW (the CoM 32 mm beside the
/// line through the two claws; docs/grip-loads.md).
#[test]
fn pole_steady_gait_grips_carry_the_body_within_five_percent_bw() {
    let spec = |cfg: LocomotionConfig| ScenarioSpec {
        preset: Preset::by_name("pole", None).unwrap(),
        variant: TrunkVariant::Up,
        cfg,
        dt: 1.0 / 60.0,
        time_limit_s: None,
        tolerances: Tolerances::default(),
    };
    let cfg = LocomotionConfig::profile(Profile::Steady);
    assert_eq!(cfg.release_residual_bw, 0.05, "the issue's default");
    let r = run_scenario(&spec(cfg.clone()), &Rig::sloth()).unwrap();
    assert_measures_within_issue_limits(&r);
    let g = r.grip_load_steady.as_ref().expect("a steady-state window");
    assert!(g.max_residual_bw <= 0.05, "{g:?}");
    assert_eq!(g.frames_held_back, 0, "{g:?}");
    assert_eq!(r.grip_load.forced_releases, 0);

    // The same gait without the weight shift (and the rule off).
    let off = LocomotionConfig {
        weight_shift_max_m: 0.0,
        release_residual_bw: 100.0,
        ..cfg
    };
    let r = run_scenario(&spec(off), &Rig::sloth()).unwrap();
    let g = r.grip_load_steady.as_ref().expect("a steady-state window");
    assert!(g.max_residual_bw > 0.09, "{g:?}");
}

#[test]
fn trunk_climb_up_head_up() {
    let r = run("trunk", None, TrunkVariant::Up, Profile::Free);
    assert_measures_within_issue_limits(&r);
    assert_eq!(r.judge.head_below_hips_on_trunk_frames, 0);
}

#[test]
fn trunk_side_steps_half_way_around_head_up() {
    for radius in [0.1, 0.15, 0.2] {
        let r = run("trunk", Some(radius), TrunkVariant::Around, Profile::Free);
        assert_measures_within_issue_limits(&r);
        assert_eq!(r.judge.head_below_hips_on_trunk_frames, 0);
        // The body went around the axis (the trunk stands at x = z = 0; the
        // start faces it from +Z) to the far side, at about the same height.
        let (first, last) = (r.trail[0], *r.trail.last().unwrap());
        let side = |p: glam::Vec3| glam::Vec2::new(p.x, p.z).normalize();
        let turned = side(first).angle_to(side(last)).abs();
        assert!(
            turned >= 150f32.to_radians(),
            "radius {radius}: turned {}°",
            turned.to_degrees()
        );
        assert!((last.y - first.y).abs() < 0.15, "{first} → {last}");
    }
}

#[test]
fn trunk_climb_down_tail_first_head_up() {
    let r = run("trunk", None, TrunkVariant::Down, Profile::Free);
    assert_measures_within_issue_limits(&r);
    assert_eq!(r.judge.head_below_hips_on_trunk_frames, 0);
    // Tail first: the body ends lower than it started, still facing up.
    let (first, last) = (&r.observations[0], r.observations.last().unwrap());
    assert!(last.body_pos.y < first.body_pos.y - 1.5);
    assert!((last.body_rot * glam::Vec3::Z).y > 0.9);
}

#[test]
fn height_change_inside_the_thesis_range_reaches_the_next_branch() {
    for angle in [140.0, 160.0, 195.0] {
        let r = run(
            "height_change",
            Some(angle),
            TrunkVariant::Up,
            Profile::Free,
        );
        assert_measures_within_issue_limits(&r);
    }
}

#[test]
fn turn_onto_the_next_branch() {
    // The thesis range is 95° < a < 175°: both ends and the middle.
    for angle in [95.0, 100.0, 125.0, 140.0, 170.0, 180.0] {
        let r = run("turn", Some(angle), TrunkVariant::Up, Profile::Free);
        assert_measures_within_issue_limits(&r);
    }
}

#[test]
fn scenario_cli_writes_json_and_exit_code_tells_pass() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_slothsim"))
        .args(["scenario", "pole", "--out", dir.path().to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stdout)
    );
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("scenario.json")).unwrap()).unwrap();
    for key in [
        "max_grip_slip_m",
        "max_surface_gap_m",
        "max_reach_ratio",
        "joint_limit_violations",
        "min_limbs_in_contact",
        "max_penetration_m",
        "nan_count",
        "goal_reached",
    ] {
        assert!(json["judge"].get(key).is_some(), "judge.{key} missing");
    }
    for limb in ["LF", "RF", "LH", "RH"] {
        for key in [
            "contact_s_mean",
            "swing_s_mean",
            "stride_m_mean",
            "duty_factor",
        ] {
            assert!(
                json["gait"]["limbs"][limb].get(key).is_some(),
                "gait.limbs.{limb}.{key} missing"
            );
        }
    }
    assert!(json["gait"]["speed_mps_mean"].as_f64().unwrap() > 0.05);
    // The steady-state window: its bounds and the same per-limb keys.
    let steady = &json["gait_steady"];
    assert!(steady["from_s"].as_f64().unwrap() < steady["to_s"].as_f64().unwrap());
    assert!(steady["limbs"]["RH"]["stride_m_mean"].as_f64().unwrap() > 0.1);
    assert!(json["gait"]["footfall_order"].as_array().unwrap().len() >= 8);

    // A run that cannot reach its goal in time fails with exit code 1.
    let out = Command::new(env!("CARGO_BIN_EXE_slothsim"))
        .args(["scenario", "pole", "--seconds", "2"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
}

#[test]
fn scenario_bad_input_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let bad_cfg = dir.path().join("bad.toml");
    std::fs::write(&bad_cfg, "max_stepp = 0.3\n").unwrap();
    let long_step = dir.path().join("long.toml");
    std::fs::write(&long_step, "max_step_m = 0.9\n").unwrap();
    let cases: [(&[&str], &str); 7] = [
        (&["scenario", "spiral"], "unknown preset"),
        (&["scenario", "turn", "--angle", "30"], "60..=180"),
        (
            &["scenario", "pole", "--config", bad_cfg.to_str().unwrap()],
            "max_stepp",
        ),
        (
            &["scenario", "pole", "--config", long_step.to_str().unwrap()],
            "max_step_m",
        ),
        (&["scenario", "pole", "--seconds", "-3"], "seconds"),
        // Variants belong to their presets and say which ones they take.
        (&["scenario", "trunk", "--variant", "to-branch"], "up, down"),
        (
            &["scenario", "branch_trunk", "--variant", "down"],
            "to-trunk, to-branch",
        ),
    ];
    for (args, needle) in cases {
        let out = Command::new(env!("CARGO_BIN_EXE_slothsim"))
            .args(args)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
    }
}

/// The parallel preset at each of `gaps` passes, every measure within the
/// issue's limits, the sloth ending on the second branch (the goal's).
fn assert_parallel_passes(gaps: &[f32]) {
    for &gap in gaps {
        let r = run("parallel", Some(gap), TrunkVariant::Up, Profile::Free);
        assert!(r.verdict.pass, "gap {gap}: {:?}", r.verdict);
        assert_measures_within_issue_limits(&r);
        assert_eq!(
            r.observations.last().unwrap().limbs[0].support.0,
            1,
            "gap {gap}"
        );
    }
}

#[test]
fn parallel_branches_change_from_one_to_the_other() {
    assert_parallel_passes(&[0.15, 0.25]);
}

/// Branches closer than the step search's trace standoff (0.15 m off the
/// surface): the other branch hid every grip on the side facing it, and at
/// gaps under 0.15 m the hind limb on that side never stepped again (each
/// of these gaps failed on main 0d0f6ba). Where the claw and hand have room
/// between the two (`claw_length_m` + 1 cm), the grip is traced again from
/// inside that room (`search.rs` `trace_in_claw_room`).
#[test]
fn parallel_branches_closer_than_the_trace_standoff() {
    assert_parallel_passes(&[0.1091, 0.1191, 0.1263, 0.1317, 0.1389, 0.1426, 0.1473]);
}

/// Branches wider apart than a plain step (0.27 m, free profile): the first
/// fore limb's grip on the far branch lies on its face on the limb's side,
/// at least the gap away, and every candidate failed the step length (each
/// of these gaps failed on main f6966c0, stopped `no_grip` at the end of the
/// first branch). In goal mode a step onto another support may be as long
/// as a transfer step; the reach checks decide (`candidate.rs`
/// `max_step_at`).
#[test]
fn parallel_branches_wider_than_a_plain_step() {
    assert_parallel_passes(&[0.2763, 0.2918, 0.3195, 0.3478, 0.3657, 0.3888]);
}

#[test]
fn branch_to_trunk_head_up_inside_the_thesis_range() {
    // transfer_to_trunk: fore limbs take the trunk above the hind limbs, the
    // body rolls to face the trunk from beside the branch, then climbs down
    // tail first (head up) to the goal on the trunk.
    for angle in [95.0, 110.0, 125.0, 135.0] {
        let r = run("branch_trunk", Some(angle), TrunkVariant::Up, Profile::Free);
        assert_measures_within_issue_limits(&r);
        assert_eq!(r.judge.head_below_hips_on_trunk_frames, 0);
        // Arrived means all four limbs hold the trunk (support 0).
        let last = r.observations.last().unwrap();
        assert!(last.limbs.iter().all(|l| l.support.0 == 0));
        assert!((last.body_rot * glam::Vec3::Z).y > 0.9, "head up");
    }
}

#[test]
fn branch_to_trunk_down_a_rising_branch_keeps_the_head_up() {
    // Down a branch rising away from the trunk (73°, 0.15 m) the second fore
    // limb's step onto the trunk had the head below the hips for 6 frames
    // from its lift-off (the judge counts it on the trunk once both fore
    // limbs hold it). Such a step is refused now, and the transfer finds
    // another way down to the goal.
    let r = run("branch_trunk", Some(73.0), TrunkVariant::Up, Profile::Free);
    assert_measures_within_issue_limits(&r);
    assert_eq!(r.judge.head_below_hips_on_trunk_frames, 0);
    assert!(r.judge.goal_reached, "{:?}", r.verdict.failures);
}

#[test]
fn trunk_to_branch_hind_pair_together() {
    // transfer_to_branch: climbing the trunk head up, the fore limbs take a
    // branch rising from it (60°–80°) or falling away from it (100°–150°),
    // the hind limbs leave the trunk only when no fore limb is on it, and
    // then both lift together (two limbs in contact) onto the branch, out to
    // the goal on it (support 1). On a falling branch the hips are out of
    // the branch's reach until the pair has stepped (110°–130° stopped
    // before the pair's reach check judged the stance after the step); in
    // the narrow fork below a steeply falling branch (135°–150°) the body
    // rolls about the branch clear of the trunk, and the fore limbs walk out
    // along the branch while the body still faces up the trunk.
    for angle in [
        60.0, 70.0, 80.0, 100.0, 110.0, 120.0, 130.0, 135.0, 140.0, 150.0,
    ] {
        let r = run(
            "branch_trunk",
            Some(angle),
            TrunkVariant::ToBranch,
            Profile::Free,
        );
        assert_measures_within_issue_limits(&r);
        assert_eq!(r.judge.head_below_hips_on_trunk_frames, 0);
        let last = r.observations.last().unwrap();
        assert!(last.limbs.iter().all(|l| l.support.0 == 1), "{angle}°");
        // The hind pair's step: both hind limbs in the air at once, the fore
        // limbs on the branch and the hind limbs coming off the trunk.
        let together = r.observations.windows(2).any(|o| {
            let (a, b) = (&o[0], &o[1]);
            let hind = [slothsim::rig::Limb::LH, slothsim::rig::Limb::RH];
            hind.iter()
                .all(|&h| !b.limb(h).planted && a.limb(h).support.0 == 0)
                && b.limbs_in_contact() == 2
        });
        assert!(together, "{angle}°: the hind pair never lifted together");
    }
}
