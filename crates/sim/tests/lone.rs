//! A crowd of one (`Crowd::lone`, what the scenario runner steps): its
//! observer keeps every frame's observation and feeds exactly those to the
//! judge it was given; it has no forest source, so saving it is a clear
//! error, not a panic and not a file.

use slothsim_gait::{LocomotionConfig, Profile, Sloth, SpawnHint};
use slothsim_observe::{Judge, Tolerances};
use slothsim_rig::Rig;
use slothsim_scene::{Preset, TraceScene};
use slothsim_sim::crowd::Observer;
use slothsim_sim::{Crowd, CrowdError, Locomotion};

const DT: f32 = 1.0 / 60.0;

fn lone_on_pole(judge: Judge) -> Crowd {
    let preset = Preset::by_name("pole", None).unwrap();
    let loco = Locomotion::new(
        LocomotionConfig::profile(Profile::Free),
        &Rig::sloth(),
        TraceScene::new(preset.scene.clone()),
    )
    .unwrap();
    let start = preset.start;
    let hint = SpawnHint {
        support: start.support,
        position: start.position,
        forward: start.forward,
        body_side: start.body_side,
    };
    let sloth = Sloth::spawn(&loco.view(), &hint, None);
    Crowd::lone(loco, sloth, DT, judge)
}

#[test]
fn lone_crowd_keeps_every_observation_for_its_judge() {
    let judge = Judge::new(Tolerances::default(), 5.0);
    let mut crowd = lone_on_pole(judge.clone());
    let frames = 90;
    for _ in 0..frames {
        crowd.step();
    }
    assert_eq!(crowd.frame(), frames);
    assert_eq!(crowd.timings().history.len() as u64, frames);
    // A lone sloth's grip loads are solved every frame.
    assert_eq!(crowd.sloths()[0].load.skipped, 0);
    let e = crowd.entity(0).expect("sloth 0");
    assert_eq!(crowd.entity(1), None);
    let o = crowd.world().get::<Observer>(e).expect("an observer");
    let history = o.history();
    assert_eq!(history.len() as u64, frames);
    for (i, obs) in history.iter().enumerate() {
        let want = (i + 1) as f32 * DT;
        assert!(
            (obs.time_s - want).abs() < 1e-4,
            "frame {i}: {}",
            obs.time_s
        );
    }
    // The observer's judge saw exactly these frames, with the given limits.
    let mut again = judge;
    for obs in history {
        again.observe(obs);
    }
    let report = o.judge().finish();
    assert_eq!(report, again.finish());
    assert_eq!(report.frames, frames);
    assert_eq!(report.time_limit_s, 5.0);
}

#[test]
fn lone_crowd_is_not_checkpointed() {
    let mut crowd = lone_on_pole(Judge::new(Tolerances::default(), 5.0));
    crowd.step();
    let path = std::env::temp_dir().join(format!("slothsim-lone-{}.bin", std::process::id()));
    let err = crowd.save_state(&path).unwrap_err();
    assert!(matches!(err, CrowdError::Checkpoint { .. }), "{err}");
    assert!(err.to_string().contains("no forest to save"), "{err}");
    assert!(!path.exists());
}
