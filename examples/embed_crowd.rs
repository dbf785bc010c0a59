//! Embed a crowd in your own program: build a forest, spawn sloths, tick the
//! simulation and read every sloth's pose after each tick.
//!
//! `cargo run --release --example embed_crowd`

use anyhow::Result;
use slothsim::gait::{LimbPhase, LocomotionConfig};
use slothsim::rig::{Limb, Rig};
use slothsim::scene::{ForestConfig, generate_forest};
use slothsim::sim::{Crowd, CrowdSpec, ForestSource, init_compute_pool};

fn main() -> Result<()> {
    // The tick's stages run on bevy's compute pool: size it once (all cores).
    let threads = init_compute_pool(None);

    // A small procedural forest (any glTF forest works too: `scene::read_scene`).
    let forest = ForestConfig {
        trees: 6,
        area_m: 25.0,
        ..ForestConfig::default()
    };
    let scene = generate_forest(&forest)?;

    // 40 wandering sloths with the thesis's free-ranging gait.
    let spec = CrowdSpec {
        sloths: 40,
        seed: 7,
        dt: 1.0 / 60.0,
        cfg: LocomotionConfig::default(),
        clearance_m: 0.3,
    };
    let mut crowd = Crowd::new(spec, &Rig::sloth(), scene, ForestSource::Procedural(forest))?;

    // Two simulated seconds; read the poses after every tick, as a renderer would.
    let mut swinging_max = 0;
    for _ in 0..120 {
        crowd.step();
        swinging_max = swinging_max.max(crowd.swinging());
    }
    println!(
        "{} sloths after {} frames on {threads} threads; at most {swinging_max} limbs swung at once",
        crowd.spec().sloths,
        crowd.frame()
    );
    for sloth in crowd.sloths().iter().take(3) {
        let p = sloth.body_pos;
        println!(
            "sloth {}: body at ({:.3}, {:.3}, {:.3}) m",
            sloth.id, p.x, p.y, p.z
        );
        for (limb, state) in Limb::ALL.iter().zip(&sloth.limbs) {
            let phase = match state.phase {
                LimbPhase::Planted => "planted",
                LimbPhase::Searching => "searching",
                LimbPhase::Swinging => "swinging",
            };
            let g = state.grip.point;
            println!(
                "  {limb:?} {phase:<9} grip ({:.3}, {:.3}, {:.3}) on support {:?}",
                g.x, g.y, g.z, state.grip.support
            );
        }
    }
    let stats = crowd.stats(threads);
    println!(
        "state_hash {}, max grip slip {:.4} m, NaN {}",
        stats.state_hash, stats.max_grip_slip_m, stats.nan_count
    );
    anyhow::ensure!(stats.nan_count == 0, "NaN in the crowd");
    Ok(())
}
