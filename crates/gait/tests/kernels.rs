//! The locomotion kernels called directly on small hand-built stances (no
//! ECS): step search, body averaging (formulas 6 and 7), the gait clock's
//! footfall order, and a branch → trunk transfer. Each test measures the
//! property itself (distances, directions, order) rather than trusting a
//! kernel's own flags.

use glam::Vec3;
use slothsim_gait::{
    LimbPhase, LocoEnv, LocoView, LocomotionConfig, NearRing, ObserveMemo, Profile, Sequence,
    Sloth, SpawnHint, Status, TraceBatch, project,
};
use slothsim_rig::{Limb, Rig};
use slothsim_scene::{Preset, SupportKind, TraceScene};

const DT: f32 = 1.0 / 60.0;

/// The shared environment of preset `name` with config `cfg`.
fn env_for(name: &str, cfg: LocomotionConfig) -> (LocoEnv, Preset) {
    let preset = Preset::by_name(name, None).unwrap();
    let env = LocoEnv::new(cfg, &Rig::sloth(), TraceScene::new(preset.scene.clone())).unwrap();
    (env, preset)
}

/// A sloth spawned at the preset's start, walking toward its goal.
fn spawn_at_start(view: &LocoView<'_>, preset: &Preset) -> Sloth {
    let s = preset.start;
    let hint = SpawnHint {
        support: s.support,
        position: s.position,
        forward: s.forward,
        body_side: s.body_side,
    };
    let g = preset.goal;
    let mut sloth = Sloth::spawn(view, &hint, Some((g.support, g.point, g.tolerance)));
    sloth.goal_side = g.side;
    sloth
}

/// One tick, the stages in the sim's order (Trace, StepSearch, BodyAverage,
/// CcdSolve, Transitions).
fn tick(sloth: &mut Sloth, near: &mut NearRing, view: &LocoView<'_>, batch: &mut TraceBatch) {
    batch.run(&view.query);
    sloth.step_search(view, batch, Some(near));
    sloth.body_average(view, DT);
    sloth.solve_limbs(view);
    sloth.transitions(view, DT, batch);
}

/// The first step the search takes on the pole: the new grip lies on the
/// pole's surface on the limb's side, a forward step within
/// [min_step_m, max_step_m] of the old one, and once the limb lands its root
/// is within reach of it and the claw holds it.
#[test]
fn step_search_takes_a_forward_grip_on_the_surface_within_reach() {
    let (env, preset) = env_for("pole", LocomotionConfig::profile(Profile::Free));
    let view = env.view();
    let mut sloth = spawn_at_start(&view, &preset);
    let mut batch = TraceBatch::default();
    let mut near = NearRing::default();
    let travel = preset.start.forward.normalize();
    let pole = view.scene().support(preset.start.support);
    // Tick until a limb's search has started a swing.
    let (li, old, new) = (0..600)
        .find_map(|_| {
            batch.run(&view.query);
            let before = sloth.limbs;
            sloth.step_search(&view, &mut batch, Some(&mut near));
            let started = (0..4).find(|&i| {
                before[i].phase == LimbPhase::Searching
                    && sloth.limbs[i].phase == LimbPhase::Swinging
            });
            let found = started.map(|i| (i, before[i].grip, sloth.limbs[i].grip));
            sloth.body_average(&view, DT);
            sloth.solve_limbs(&view);
            sloth.transitions(&view, DT, &mut batch);
            found
        })
        .expect("a limb starts a step within 10 s");
    // On the surface: the grip's distance from the axis is the radius.
    let a = project(pole, new.point);
    assert!(
        (a.point.distance(new.point) - a.radius).abs() < 1e-4,
        "grip {} m off the surface",
        a.point.distance(new.point) - a.radius
    );
    assert_eq!(new.support, preset.start.support);
    // On the limb's side of the pole (a hanging sloth: right limbs to the
    // right of the travel direction, +Y up).
    let right = travel.cross(Vec3::Y);
    let side = (new.point - a.point).dot(right);
    assert_eq!(
        side > 0.0,
        !Limb::ALL[li].is_left(),
        "limb {li} grips the wrong side"
    );
    // Forward of the old grip, by a step the config allows.
    let step = (new.point - old.point).dot(travel);
    assert!(
        step >= view.cfg.min_step_m && new.point.distance(old.point) <= view.cfg.max_step_m,
        "step {step} m (distance {} m)",
        new.point.distance(old.point)
    );
    // Landed: its root within reach, the claw on the grip.
    for _ in 0..600 {
        if sloth.limbs[li].phase != LimbPhase::Swinging {
            break;
        }
        tick(&mut sloth, &mut near, &view, &mut batch);
    }
    let l = sloth.limbs[li];
    assert_eq!(l.grip, new, "the limb landed where it stepped to");
    let reach = view.rig.reach * view.cfg.max_reach_fraction;
    assert!(
        l.root.distance(new.point) <= reach,
        "root {} m from the grip",
        l.root.distance(new.point)
    );
    assert!(
        l.effector.distance(new.point) < 0.003,
        "claw {} m off the grip after landing",
        l.effector.distance(new.point)
    );
}

/// Formula 6 (forward = mean of the right and left hind → fore directions)
/// and formula 7 (body = paws' mean − up × offset), computed by hand for a
/// stance with the grips moved off the pole's line, against `body_average`.
#[test]
fn body_average_places_the_body_by_formulas_6_and_7() {
    let cfg = LocomotionConfig {
        // No smoothing: the rotation is formula 6's exactly.
        body_smoothing_s: 0.0,
        ..LocomotionConfig::profile(Profile::Free)
    };
    let (env, preset) = env_for("pole", cfg);
    let view = env.view();
    let mut sloth = spawn_at_start(&view, &preset);
    // A hand-built stance: each planted grip moved by its own offset.
    let moves = [
        Vec3::new(0.04, 0.03, 0.0),
        Vec3::new(-0.02, -0.01, 0.02),
        Vec3::new(0.01, -0.04, -0.01),
        Vec3::new(0.03, 0.02, 0.01),
    ];
    for (l, d) in sloth.limbs.iter_mut().zip(moves) {
        l.grip.point += d;
    }
    sloth.body_average(&view, DT);
    let p = sloth.limbs.map(|l| l.grip.point);
    let (lf, rf, lh, rh) = (
        p[Limb::LF.index()],
        p[Limb::RF.index()],
        p[Limb::LH.index()],
        p[Limb::RH.index()],
    );
    let fwd = ((rf - rh).normalize() + (lf - lh).normalize()).normalize();
    // Hanging below a branch: up is world up made perpendicular to forward.
    let up = (Vec3::Y - fwd * fwd.dot(Vec3::Y)).normalize();
    let mean = (lf + rf + lh + rh) / 4.0;
    let offset = view.cfg.body_vertical_offset_m.unwrap();
    let pos = mean - up * offset;
    // Planted limbs aim at their grips.
    for l in &sloth.limbs {
        assert_eq!(l.target, l.grip.point);
    }
    assert!(
        sloth.body_pos.distance(pos) < 1e-5,
        "body at {} vs {pos}",
        sloth.body_pos
    );
    let rot = sloth.body_rot;
    assert!(
        (rot * Vec3::Z).distance(fwd) < 1e-5,
        "forward {} vs {fwd}",
        rot * Vec3::Z
    );
    assert!(
        (rot * Vec3::Y).distance(up) < 1e-5,
        "up {} vs {up}",
        rot * Vec3::Y
    );
    assert!((rot.length() - 1.0).abs() < 1e-6);
    // The stance was moved enough for the check to mean something.
    assert!(fwd.angle_between(Vec3::X) > 0.02, "forward hardly moved");
}

/// The limbs the gait clock lifts first, in order, with the lift-off times,
/// when only Transitions runs (no search completes, so every limb stays
/// planted or searching and the clock alone decides).
fn lift_order(sequence: Sequence) -> (Vec<usize>, Vec<f32>, f32) {
    let cfg = LocomotionConfig {
        sequence,
        ..LocomotionConfig::profile(Profile::Free)
    };
    let (env, preset) = env_for("pole", cfg);
    let view = env.view();
    let mut sloth = spawn_at_start(&view, &preset);
    let (mut order, mut times) = (Vec::new(), Vec::new());
    for _ in 0..(view.cfg.cycle_duration() * 1.5 / DT) as usize {
        let mut batch = TraceBatch::default();
        let before = sloth.limbs.map(|l| l.phase);
        sloth.transitions(&view, DT, &mut batch);
        for (li, was) in before.into_iter().enumerate() {
            if was == LimbPhase::Planted
                && sloth.limbs[li].phase == LimbPhase::Searching
                && !order.contains(&li)
            {
                order.push(li);
                times.push(sloth.time);
                assert!(batch.len > 0, "a lifted limb queues its first traces");
            }
        }
    }
    (order, times, view.cfg.cycle_duration())
}

/// Transitions: the gait clock lifts the limbs in DSDC order (RH → LF → LH
/// → RF), a quarter cycle apart; LSDC gives RH → RF → LH → LF.
#[test]
fn gait_clock_lifts_limbs_in_footfall_order() {
    let (order, times, cycle) = lift_order(Sequence::Dsdc);
    let dsdc = [Limb::RH, Limb::LF, Limb::LH, Limb::RF].map(Limb::index);
    assert_eq!(order, dsdc, "DSDC lift order");
    for k in 1..4 {
        let gap = times[k] - times[k - 1];
        assert!(
            (gap - 0.25 * cycle).abs() <= DT * 1.01,
            "lift {k} after {gap} s"
        );
    }
    let (order, _, _) = lift_order(Sequence::Lsdc);
    let lsdc = [Limb::RH, Limb::RF, Limb::LH, Limb::LF].map(Limb::index);
    assert_eq!(order, lsdc, "LSDC lift order");
}

/// A view's gait timing (made once a view, read every sloth-frame by the
/// clock) is its config's, bit for bit, for both sequences, every profile, a
/// set cycle and swing, and another limb phase.
#[test]
fn view_gait_timing_is_the_configs() {
    let mut cfgs = Vec::new();
    for profile in [Profile::Free, Profile::Steady] {
        for sequence in [Sequence::Dsdc, Sequence::Lsdc] {
            let base = LocomotionConfig {
                sequence,
                ..LocomotionConfig::profile(profile)
            };
            cfgs.push(base.clone());
            cfgs.push(LocomotionConfig {
                cycle_s: Some(3.1),
                swing_s: Some([0.9, 0.7]),
                limb_phase: 0.37,
                ..base
            });
        }
    }
    for cfg in cfgs {
        let (env, _) = env_for("pole", cfg);
        for view in [env.view(), env.view_with(None)] {
            assert_eq!(
                view.phase_offsets.map(f32::to_bits),
                env.cfg.phase_offsets().map(f32::to_bits)
            );
            assert_eq!(view.cycle_s.to_bits(), env.cfg.cycle_duration().to_bits());
        }
    }
}

/// The observation through a memo kept across frames is the plain
/// observation, bit for bit, frame after frame, while sloths walk, rest
/// between steps (the memo's inputs unchanged: counted, so the test covers
/// its hits) and change supports (branch → trunk).
#[test]
fn observe_memo_is_the_plain_observation() {
    for name in ["pole", "branch_trunk"] {
        let (env, preset) = env_for(name, LocomotionConfig::profile(Profile::Free));
        let view = env.view();
        let mut sloth = spawn_at_start(&view, &preset);
        let (mut near, mut batch, mut memo) = (
            NearRing::default(),
            TraceBatch::default(),
            ObserveMemo::default(),
        );
        let key = |s: &Sloth| {
            let mut k: Vec<u32> = s.body_pos.to_array().map(f32::to_bits).to_vec();
            for l in &s.limbs {
                k.extend(l.effector.to_array().map(f32::to_bits));
                k.extend(l.pose.0.iter().flat_map(|q| q.to_array().map(f32::to_bits)));
            }
            k
        };
        let (mut last, mut kept) = (Vec::new(), 0);
        for frame in 0..900 {
            tick(&mut sloth, &mut near, &view, &mut batch);
            let k = key(&sloth);
            kept += usize::from(k == last);
            last = k;
            let memo_seen = sloth.observe_memo(&view, &mut memo);
            let plain = sloth.observe(&view);
            assert_eq!(
                format!("{memo_seen:?}"),
                format!("{plain:?}"),
                "{name}, frame {frame}"
            );
        }
        assert!(kept > 0, "{name}: no frame kept the memo's inputs");
    }
}

/// Branch → trunk (SPEC `transfer_to_trunk`) on the branch_trunk preset: a
/// transfer starts when a limb's search reaches the trunk and ends once all
/// four limbs hold it, the body then facing the trunk head up.
#[test]
fn branch_to_trunk_transfer_starts_and_finishes() {
    let (env, preset) = env_for("branch_trunk", LocomotionConfig::profile(Profile::Free));
    let view = env.view();
    let trunk = preset.goal.support;
    assert_eq!(view.scene().support(trunk).kind, SupportKind::Trunk);
    let mut sloth = spawn_at_start(&view, &preset);
    assert!(sloth.transfer.is_none());
    let mut batch = TraceBatch::default();
    let mut near = NearRing::default();
    let (mut started, mut finished) = (None, None);
    for frame in 0..(120.0 / DT) as u32 {
        tick(&mut sloth, &mut near, &view, &mut batch);
        assert!(sloth.status != Status::NoGrip, "stuck at frame {frame}");
        match (sloth.transfer, started) {
            (Some(tr), None) => {
                // Started: toward the trunk, from the branch; no limb on it yet.
                assert_eq!((tr.to, tr.trunk), (trunk, trunk));
                assert!(sloth.limbs.iter().all(|l| l.from_support != trunk));
                assert!((tr.side.length() - 1.0).abs() < 1e-4);
                started = Some(frame);
            }
            (None, Some(_)) if sloth.limbs.iter().all(|l| l.grip.support == trunk) => {
                finished = Some(frame);
                break;
            }
            _ => {}
        }
    }
    let (Some(s), Some(f)) = (started, finished) else {
        panic!("transfer started at {started:?}, finished at {finished:?}");
    };
    assert!(f > s);
    // All four limbs planted on the trunk, the body beside it, head up.
    for l in &sloth.limbs {
        assert_eq!(l.phase, LimbPhase::Planted);
        let a = project(view.scene().support(trunk), l.grip.point);
        assert!((a.point.distance(l.grip.point) - a.radius).abs() < 1e-3);
    }
    // The body's forward settles onto the trunk's axis within a few frames.
    for _ in 0..30 {
        tick(&mut sloth, &mut near, &view, &mut batch);
    }
    let head_up = (sloth.body_rot * Vec3::Z).y;
    assert!(head_up > 0.9, "body forward·up = {head_up} on the trunk");
}

/// A turn's handover step with the grips bunched as a turn leaves them (fore
/// and hind claws a few cm apart): the body's rotation while the claw swings
/// is the same whether its arc lifts it clear of the branch or not (formula 6
/// of the stance it lands in, blended with the turn's heading). Formula 6 of
/// the arc instead rolled a crowd sloth's body 45° during a 7 cm step, and it
/// snapped back at the landing 12 mm into its branch.
#[test]
fn turn_handover_rotation_ignores_the_claws_lift() {
    use slothsim_gait::sloth::Turn;
    let rot_during_swing = |clearance: f32| -> Vec<glam::Quat> {
        let cfg = LocomotionConfig {
            swing_clearance_m: clearance,
            ..LocomotionConfig::profile(Profile::Free)
        };
        let (env, preset) = env_for("pole", cfg);
        let view = env.view();
        let mut sloth = spawn_at_start(&view, &preset);
        let fwd = sloth.body_rot * Vec3::Z;
        let fwd = (fwd - Vec3::Y * fwd.y).normalize();
        let g = |l: Limb| sloth.limbs[l.index()].grip.point;
        // Bunched: the hind claws a few cm behind the fore claws on their sides.
        let (lf, rf) = (g(Limb::LF), g(Limb::RF));
        sloth.limbs[Limb::RH.index()].grip.point = rf - fwd * 0.12;
        sloth.limbs[Limb::RH.index()].target = rf - fwd * 0.12;
        let support = sloth.limbs[Limb::LH.index()].grip.support;
        let lh = &mut sloth.limbs[Limb::LH.index()];
        lh.from = rf - fwd * 0.12 + (lf - rf) * 0.5;
        lh.from_normal = lh.grip.normal;
        lh.from_support = support;
        lh.grip.point = lf - fwd * 0.02;
        lh.phase = LimbPhase::Swinging;
        lh.swing_t = 0.0;
        sloth.turn = Some(Turn {
            support,
            fwd0: fwd,
            up: Vec3::Y,
            sense: 1.0,
            angle: 2.9,
            to: std::f32::consts::PI,
            limb: Limb::LH.index() as u8,
            handover: true,
            idle: 0,
            tail_first: false,
        });
        let mut rots = Vec::new();
        while sloth.limbs[Limb::LH.index()].phase == LimbPhase::Swinging {
            sloth.body_average(&view, DT);
            rots.push(sloth.body_rot);
        }
        rots
    };
    let lifted = rot_during_swing(0.05);
    let flat = rot_during_swing(0.0);
    assert_eq!(lifted.len(), flat.len());
    assert!(lifted.len() > 10, "the swing took {} frames", lifted.len());
    let worst = lifted
        .iter()
        .zip(&flat)
        .map(|(a, b)| a.angle_between(*b))
        .fold(0.0f32, f32::max);
    assert!(worst < 1e-4, "the lift turned the body by {worst} rad");
}
