//! Set-up shared by the unit tests of the sloth's modules.

use slothsim_rig::Rig;
use slothsim_scene::{Preset, PresetKind, TraceScene};

use super::{NearRing, Sloth, SpawnHint, TraceBatch};
use crate::{LocoEnv, LocoView, LocomotionConfig, Profile};

/// Uniform numbers in 0..1 from an xorshift generator seeded with `s`.
pub(crate) fn xorshift(mut s: u64) -> impl FnMut() -> f32 {
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A crowd fixture (testdata: the forest's config, a serde `Sloth`, and
/// what the test needs besides): its JSON, the sloth, and the free
/// profile's environment on that forest.
pub(crate) fn crowd_fixture(fixture: &str) -> (serde_json::Value, Sloth, LocoEnv) {
    let fx: serde_json::Value = serde_json::from_str(fixture).unwrap();
    let forest: slothsim_scene::ForestConfig =
        serde_json::from_value(fx["forest"].clone()).unwrap();
    let sloth: Sloth = serde_json::from_value(fx["sloth"].clone()).unwrap();
    let scene = slothsim_scene::generate_forest(&forest).unwrap();
    let env = LocoEnv::new(
        LocomotionConfig::profile(Profile::Free),
        &Rig::sloth(),
        TraceScene::new(scene),
    )
    .unwrap();
    (fx, sloth, env)
}

/// Preset `kind`'s environment (free profile) and a sloth spawned at its
/// start, walking toward its goal.
pub(crate) fn preset_sloth(kind: PresetKind) -> (LocoEnv, Sloth) {
    preset_sloth_with(kind, Profile::Free)
}

/// [`preset_sloth`] with gait profile `profile`.
pub(crate) fn preset_sloth_with(kind: PresetKind, profile: Profile) -> (LocoEnv, Sloth) {
    let preset = Preset::by_name(kind.name(), None).unwrap();
    let cfg = LocomotionConfig::profile(profile);
    let env = LocoEnv::new(cfg, &Rig::sloth(), TraceScene::new(preset.scene.clone())).unwrap();
    let s = preset.start;
    let hint = SpawnHint::from(s);
    let g = preset.goal;
    let mut sloth = Sloth::spawn(&env.view(), &hint, Some((g.support, g.point, g.tolerance)));
    sloth.goal_side = g.side;
    (env, sloth)
}

/// One 60 Hz tick of `sloth`, the stages in the sim's order.
pub(crate) fn tick(
    sloth: &mut Sloth,
    near: &mut NearRing,
    view: &LocoView<'_>,
    batch: &mut TraceBatch,
) {
    batch.run(&view.query);
    sloth.step_search(view, batch, Some(near));
    sloth.body_average(view, 1.0 / 60.0);
    sloth.solve_limbs(view);
    sloth.transitions(view, 1.0 / 60.0, batch);
}

/// Walks every preset's sloth for 900 ticks (15 s) and hands `f` the
/// preset, the view, the frame and the sloth as it stands every `every`
/// frames (from frame 0).
pub(crate) fn walk_presets(every: usize, f: impl FnMut(PresetKind, &LocoView<'_>, usize, Sloth)) {
    walk_presets_with(Profile::Free, every, f);
}

/// [`walk_presets`] with gait profile `profile`.
pub(crate) fn walk_presets_with(
    profile: Profile,
    every: usize,
    mut f: impl FnMut(PresetKind, &LocoView<'_>, usize, Sloth),
) {
    for kind in PresetKind::ALL {
        let (env, mut sloth) = preset_sloth_with(kind, profile);
        let view = env.view();
        let mut batch = TraceBatch::default();
        let mut near = NearRing::default();
        for frame in 0..900 {
            tick(&mut sloth, &mut near, &view, &mut batch);
            if frame % every == 0 {
                f(kind, &view, frame, sloth);
            }
        }
    }
}
