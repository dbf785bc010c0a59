//! Unit tests of the gait statistics, on synthetic walks ([`super::synthetic`]).

use super::synthetic::{DT, Walk};
use super::*;

fn stats_of(obs: impl IntoIterator<Item = SlothObservation>) -> GaitStats {
    let mut stats = GaitStats::new();
    for o in obs {
        stats.observe(&o);
    }
    stats
}

fn assert_recovers(walk: &Walk, report: &GaitReport) {
    for limb in Limb::ALL {
        let l = report.limbs.get(limb);
        let name = limb.name();
        assert!(l.contacts >= 8, "{name}: {l:?}");
        assert!(l.swings >= 8, "{name}: {l:?}");
        assert!(l.strides >= 8, "{name}: {l:?}");
        assert!(l.cycles >= 8, "{name}: {l:?}");
        assert!(
            (l.contact_s_mean - walk.contact_s()).abs() <= DT,
            "{name} contact {} vs {}",
            l.contact_s_mean,
            walk.contact_s()
        );
        assert!(
            (l.swing_s_mean - walk.swing_s()).abs() <= DT,
            "{name} swing {} vs {}",
            l.swing_s_mean,
            walk.swing_s()
        );
        assert!(
            (l.stride_m_mean - walk.stride_m()).abs() <= walk.speed_mps * DT,
            "{name} stride {} vs {}",
            l.stride_m_mean,
            walk.stride_m()
        );
        assert!(
            (l.duty_factor - walk.duty_factor()).abs() <= 1.0 / walk.cycle_frames as f32,
            "{name} duty {} vs {}",
            l.duty_factor,
            walk.duty_factor()
        );
    }
    assert!(
        (report.speed_mps_mean - walk.speed_mps).abs() < 1e-3,
        "speed {}",
        report.speed_mps_mean
    );
}

#[test]
fn dsdc_walk_recovers_parameters_and_diagonal_order() {
    let walk = Walk::dsdc();
    let stats = stats_of(walk.observations());
    let report = stats.finish();
    assert_eq!(report.frames, walk.frames as u64);
    assert_recovers(&walk, &report);
    assert_eq!(&report.footfall_order[..4], ["RH", "LF", "LH", "RF"]);
    assert_eq!(report.footfall_order.len(), FOOTFALL_CAPACITY);
    assert_eq!(stats.dominant_sequence(), Some(DIAGONAL_SEQUENCE));
    assert!(stats.is_diagonal_sequence());
    assert!(!stats.is_lateral_sequence());
    assert_eq!(report.sequence, FootfallSequence::Diagonal);
    assert!(report.is_diagonal_sequence());
    assert_eq!(report.dominant_sequence(), Some(DIAGONAL_SEQUENCE));
}

#[test]
fn lsdc_walk_recovers_parameters_and_lateral_order() {
    let walk = Walk::lsdc();
    let stats = stats_of(walk.observations());
    let report = stats.finish();
    assert_recovers(&walk, &report);
    assert_eq!(&report.footfall_order[..4], ["RH", "RF", "LH", "LF"]);
    assert_eq!(stats.dominant_sequence(), Some(LATERAL_SEQUENCE));
    assert!(stats.is_lateral_sequence());
    assert!(!stats.is_diagonal_sequence());
    assert_eq!(report.sequence, FootfallSequence::Lateral);
    assert!(report.is_lateral_sequence());
}

#[test]
fn sequence_counts_from_any_starting_limb() {
    use Limb::*;
    assert_eq!(
        dominant_sequence(&[LH, RF, RH, LF]),
        Some(DIAGONAL_SEQUENCE)
    );
    assert_eq!(
        dominant_sequence(&[LF, LH, RF, RH, LF]),
        Some(DIAGONAL_SEQUENCE)
    );
    assert_eq!(
        dominant_sequence(&[LF, RH, RF, LH, LF]),
        Some(LATERAL_SEQUENCE)
    );
    assert_eq!(
        FootfallSequence::classify(Some([LH, LF, RH, RF])),
        FootfallSequence::Lateral
    );
    // Other order: a trot-like pairing RH, LF, RF, LH.
    assert_eq!(
        FootfallSequence::classify(dominant_sequence(&[RH, LF, RF, LH])),
        FootfallSequence::Other
    );
}

#[test]
fn dominant_sequence_ignores_noise_and_needs_four_limbs() {
    use Limb::*;
    assert_eq!(dominant_sequence(&[]), None);
    assert_eq!(dominant_sequence(&[RH, LF, LH]), None);
    assert_eq!(dominant_sequence(&[RH, RH, LF, LF, LH, LH]), None);
    // Two diagonal cycles with one lateral window at the start.
    let order = [RH, RF, LH, LF, LH, RF, RH, LF, LH, RF, RH, LF, LH];
    assert_eq!(dominant_sequence(&order), Some(DIAGONAL_SEQUENCE));
}

#[test]
fn restarted_stats_count_the_strides_ending_after_the_restart() {
    let walk = Walk::dsdc();
    // Split mid-cycle, with some limb in the air.
    let split = 12 + walk.cycle_frames * 4 + walk.swing_frames / 2;
    let before = stats_of((1..=split).map(|f| walk.observation(f)));
    assert!((0..4).any(|i| !before.limbs[i].planted));
    let after = (split + 1..=walk.frames).map(|f| walk.observation(f));
    let mut continued = before.restarted();
    let mut fresh = GaitStats::new();
    for o in after {
        continued.observe(&o);
        fresh.observe(&o);
    }
    let (continued, fresh) = (continued.finish(), fresh.finish());
    for limb in Limb::ALL {
        let (c, f) = (continued.limbs.get(limb), fresh.limbs.get(limb));
        // Every touch-down after the split ends a counted stride.
        assert_eq!(c.strides, c.touch_downs, "{}: {c:?}", limb.name());
        assert!(c.strides >= f.strides);
        assert!((c.stride_m_mean - walk.stride_m()).abs() <= walk.speed_mps * DT);
        assert!((c.swing_s_mean - walk.swing_s()).abs() <= DT);
    }
    // A limb in the air at the split: its first footfall after it is a
    // stride only when the limbs are followed across the split.
    assert!(
        Limb::ALL
            .iter()
            .any(|&l| { continued.limbs.get(l).strides > fresh.limbs.get(l).strides })
    );
    assert_eq!(continued.frames, (walk.frames - split) as u64);
}

#[test]
fn empty_stream_reports_zeros() {
    let stats = GaitStats::new();
    let report = stats.finish();
    assert_eq!(report.frames, 0);
    assert_eq!(report.speed_mps_mean, 0.0);
    assert_eq!(report.duration_s, 0.0);
    assert!(report.footfall_order.is_empty());
    assert_eq!(report.sequence, FootfallSequence::Unknown);
    assert_eq!(report.limbs.get(Limb::LF), &LimbGaitReport::default());
    serde_json::to_string(&report).unwrap();
}

#[test]
fn limb_that_never_lifts_has_duty_one_and_no_strides() {
    let walk = Walk::dsdc();
    let first = walk.observation(1);
    let stats = stats_of(walk.observations().map(|mut o| {
        o.limbs[Limb::LF.index()] = first.limbs[Limb::LF.index()];
        o
    }));
    let report = stats.finish();
    let lf = report.limbs.get(Limb::LF);
    assert_eq!(lf.duty_factor, 1.0);
    assert_eq!(
        (lf.strides, lf.contacts, lf.swings, lf.cycles),
        (0, 0, 0, 0)
    );
    assert_eq!((lf.lift_offs, lf.touch_downs), (0, 0));
    assert_eq!(lf.stride_m_mean, 0.0);
    assert!(!report.footfall_order.iter().any(|l| l == "LF"));
    assert_eq!(stats.dominant_sequence(), None);
    // The other limbs are still measured.
    let rh = report.limbs.get(Limb::RH);
    assert!((rh.contact_s_mean - walk.contact_s()).abs() <= DT);
}

#[test]
fn standing_still_uses_frame_fraction_and_zero_speed() {
    let obs = Walk::dsdc().observation(1);
    let mut standing = obs;
    for l in &mut standing.limbs {
        l.planted = true;
    }
    let stats = stats_of((0..100).map(|i| SlothObservation {
        time_s: i as f32 * DT,
        ..standing
    }));
    let report = stats.finish();
    assert_eq!(report.speed_mps_mean, 0.0);
    for limb in Limb::ALL {
        assert_eq!(report.limbs.get(limb).duty_factor, 1.0);
    }
}

#[test]
fn non_finite_frames_are_skipped() {
    let walk = Walk::dsdc();
    let clean = stats_of(walk.observations()).finish();
    let mut stats = GaitStats::new();
    for (i, o) in walk.observations().enumerate() {
        stats.observe(&o);
        if i % 100 == 50 {
            let mut bad = o;
            bad.body_pos.x = f32::NAN;
            stats.observe(&bad);
        }
    }
    assert_eq!(stats.skipped_frames(), 14);
    assert_eq!(stats.finish(), clean);
}

#[test]
fn json_keys_match_the_issue() {
    let report = stats_of(Walk::dsdc().observations()).finish();
    let v = serde_json::to_value(&report).unwrap();
    for key in ["speed_mps_mean", "footfall_order", "limbs", "sequence"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    for limb in ["LF", "RF", "LH", "RH"] {
        let l = &v["limbs"][limb];
        for key in [
            "contact_s_mean",
            "swing_s_mean",
            "stride_m_mean",
            "duty_factor",
            "strides",
        ] {
            assert!(l.get(key).is_some(), "missing {limb}.{key}");
        }
    }
    assert_eq!(v["sequence"], "diagonal");
    assert_eq!(v["footfall_order"][0], "RH");
    let back: GaitReport = serde_json::from_value(v).unwrap();
    assert_eq!(back, report);
}

#[test]
fn merge_weights_means_by_counts() {
    let a = stats_of(Walk::dsdc().observations()).finish();
    let slow = Walk {
        speed_mps: 0.125,
        frames: 720,
        ..Walk::dsdc()
    };
    let b = stats_of(slow.observations()).finish();
    let crowd = GaitReport::aggregate([&a, &b]);
    assert_eq!(crowd.sloths, 2);
    assert_eq!(crowd.frames, a.frames + b.frames);
    for limb in Limb::ALL {
        let (la, lb, lc) = (a.limbs.get(limb), b.limbs.get(limb), crowd.limbs.get(limb));
        assert_eq!(lc.strides, la.strides + lb.strides);
        let expect = (la.stride_m_mean * la.strides as f32 + lb.stride_m_mean * lb.strides as f32)
            / (la.strides + lb.strides) as f32;
        assert!((lc.stride_m_mean - expect).abs() < 1e-5);
        assert!((lc.contact_s_mean - la.contact_s_mean).abs() < 1e-4);
    }
    let speed = (a.path_length_m + b.path_length_m) / (a.duration_s + b.duration_s);
    assert!((crowd.speed_mps_mean - speed).abs() < 1e-5);
    assert_eq!(crowd.footfall_order, a.footfall_order);
    assert_eq!(crowd.sequence, FootfallSequence::Diagonal);

    let c = stats_of(Walk::lsdc().observations()).finish();
    assert_eq!(
        GaitReport::aggregate([&a, &c]).sequence,
        FootfallSequence::Mixed
    );
    // The empty report is the identity.
    assert_eq!(GaitReport::aggregate([&GaitReport::default(), &a]), a);
    assert_eq!(GaitReport::aggregate([]).sloths, 0);
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

    /// Any regular walk (cycle, swing share, speed, footfall order) is
    /// recovered within a frame, and its order is found up to rotation.
    #[test]
    fn any_regular_walk_is_recovered(
        quarter in 10i64..60,
        swing_share in 0.15f32..0.6,
        speed in 0.03f32..0.5,
        order_index in 0usize..24,
    ) {
        let mut order = Limb::ALL;
        let mut k = order_index;
        for i in (1..4).rev() {
            order.swap(i, k % (i + 1));
            k /= i + 1;
        }
        let cycle = 4 * quarter;
        let swing = ((cycle as f32 * swing_share) as i64).max(1);
        let walk = Walk::new(order, cycle, swing, speed);
        let stats = stats_of(walk.observations());
        let report = stats.finish();
        assert_recovers(&walk, &report);
        proptest::prop_assert_eq!(stats.dominant_sequence(), Some(canonical_rotation(order)));
    }

    /// Arbitrary, partly non-finite streams never panic and always serialise.
    #[test]
    fn arbitrary_streams_do_not_panic(
        frames in proptest::collection::vec(
            (proptest::bool::ANY, proptest::bool::ANY, -1.0f32..1.0, 0u8..8), 0..80),
    ) {
        let base = Walk::dsdc().observation(1);
        let mut stats = GaitStats::new();
        let mut judge = crate::judge::Judge::new(crate::judge::Tolerances::default(), 5.0);
        for (i, (planted_a, planted_b, x, poison)) in frames.into_iter().enumerate() {
            let mut o = base;
            o.time_s = i as f32 * DT;
            o.body_pos.x = x;
            o.limbs[0].planted = planted_a;
            o.limbs[3].planted = planted_b;
            o.limbs[3].grip_ws.z += x;
            match poison {
                0 => o.limbs[1].root_ws.y = f32::NAN,
                1 => o.goal_distance_m = f32::INFINITY,
                2 => o.has_nan = true,
                _ => {}
            }
            stats.observe(&o);
            judge.observe(&o);
        }
        let report = stats.finish();
        let judged = judge.finish();
        proptest::prop_assert!(report.speed_mps_mean.is_finite());
        proptest::prop_assert!(judged.nan_count <= judged.frames);
        serde_json::to_string(&report).unwrap();
        let json = serde_json::to_string(&judged).unwrap();
        let back: crate::judge::JudgeReport = serde_json::from_str(&json).unwrap();
        proptest::prop_assert_eq!(back, judged.clone());
        let _ = judged.verdict(&crate::judge::Tolerances::default());
    }
}
