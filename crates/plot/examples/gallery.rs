//! Renders every plot from synthetic data into a folder (default `/tmp/plots`) and times
//! the top-down view at 2,000 sloths on the default forest.
//!
//! ```sh
//! cargo run -p slothsim-plot --release --example gallery [-- OUT_DIR]
//! ```

#[path = "../tests/common/mod.rs"]
mod common;

use std::path::PathBuf;
use std::time::Instant;

use glam::{Vec2, Vec3};
use slothsim_plot::{
    FrameTimes, GaitDiagram, SideInstant, SideView, TopDown, draw_frame_times, draw_gait,
    draw_side, draw_topdown, save_png,
};
use slothsim_scene::{Preset, Scene, SupportKind, default_forest};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(
        std::env::args()
            .nth(1)
            .unwrap_or_else(|| "/tmp/plots".into()),
    );
    std::fs::create_dir_all(&out)?;

    // --- Top-down: the default forest with 2,000 sloths.
    let t = Instant::now();
    let forest = default_forest();
    println!("default forest generated in {:.0} ms", ms(t));
    let segments: usize = forest.supports().iter().map(|s| s.segment_count()).sum();
    let (sloths, trails) = common::crowd(&forest, 2000, 7);
    // Focus: the first sloth hanging below a branch.
    let focus = sloths
        .iter()
        .find(|s| (s.body_rot * Vec3::Y).y > 0.9)
        .expect("a hanging sloth");
    let r = forest
        .supports()
        .iter()
        .filter(|s| s.kind == SupportKind::Branch)
        .map(|s| s.closest_on_axis(focus.body_pos + Vec3::Y * 0.3))
        .min_by(|a, b| {
            a.0.distance(focus.body_pos)
                .total_cmp(&b.0.distance(focus.body_pos))
        })
        .map(|c| c.3)
        .unwrap_or(0.03);
    let traces = common::step_search(focus, r);
    let mut td = TopDown::new(&forest);
    td.sloths = &sloths;
    td.trails = &trails;
    td.focus = Some(focus.id);
    td.traces = &traces;
    td.time_s = 42.5;
    td.seed = 7;
    td.title = "slothsim run (synthetic poses)".into();

    let runs = 5;
    let mut best = f64::INFINITY;
    let mut total = 0.0;
    let mut pm = draw_topdown(&td); // warm-up
    for _ in 0..runs {
        let t = Instant::now();
        pm = draw_topdown(&td);
        let e = ms(t);
        best = best.min(e);
        total += e;
    }
    println!(
        "topdown: {} sloths, {} supports, {} segments, {}x{} px: {:.1} ms/plot (mean of {runs}), best {:.1} ms",
        sloths.len(),
        forest.supports().len(),
        segments,
        pm.width(),
        pm.height(),
        total / runs as f64,
        best
    );
    let t = Instant::now();
    save_png(&pm, &out.join("topdown_forest.png"))?;
    println!("  PNG encode + write: {:.1} ms", ms(t));

    // The same without trails, inset or traces (the bare crowd).
    let mut bare = td.clone();
    bare.trails = &[];
    bare.focus = None;
    bare.traces = &[];
    let t = Instant::now();
    let pm = draw_topdown(&bare);
    println!("topdown (no trails/inset): {:.1} ms/plot", ms(t));
    save_png(&pm, &out.join("topdown_bare.png"))?;

    // Zoom on the focus sloth.
    let c = Vec2::new(focus.body_pos.x, focus.body_pos.z);
    let mut zoom = td.clone();
    zoom.view = Some((c - Vec2::splat(3.0), c + Vec2::splat(3.0)));
    zoom.width = 1000;
    zoom.height = 1100;
    let t = Instant::now();
    let pm = draw_topdown(&zoom);
    println!("topdown zoom: {:.1} ms/plot", ms(t));
    save_png(&pm, &out.join("topdown_zoom.png"))?;

    // --- Side views.
    let pole = Preset::by_name("pole", None)?;
    let walk = common::walk(pole.start.position, pole.start.forward, 0.02, 6, 20.0);
    let inst: Vec<SideInstant> = walk
        .iter()
        .map(|(t, p)| SideInstant {
            time_s: *t,
            pose: *p,
        })
        .collect();
    let mut sv = SideView::new(&pole.scene, &inst);
    sv.title = "pole (synthetic)".into();
    let t = Instant::now();
    let pm = draw_side(&sv);
    println!("side: {:.1} ms/plot", ms(t));
    save_png(&pm, &out.join("side_pole.png"))?;

    let trunk = Preset::by_name("trunk", None)?;
    let tr = trunk.scene.supports()[0].radii[0];
    let climb: Vec<SideInstant> = (0..5)
        .map(|i| {
            let h = 1.0 + 0.35 * i as f32;
            SideInstant {
                time_s: 4.0 * i as f32,
                pose: common::sloth_on(
                    0,
                    Vec3::new(0.0, h, 0.0),
                    Vec3::Y,
                    -trunk.start.body_side,
                    tr,
                    Some([3, 0, 2, 1][i % 4]),
                ),
            }
        })
        .collect();
    let mut sv = SideView::new(&trunk.scene, &climb);
    sv.title = "trunk climb (synthetic)".into();
    save_png(&draw_side(&sv), &out.join("side_trunk.png"))?;

    // Turn preset from above, zoomed, one sloth at the junction.
    let turn = Preset::by_name("turn", Some(120.0))?;
    let s0 = common::hanging(
        1,
        turn.start.position + turn.start.forward * 1.5,
        turn.start.forward,
        0.02,
        Some(1),
    );
    let traces_turn = common::step_search(&s0, 0.02);
    let one = [s0];
    let mut tt = TopDown::new(&turn.scene);
    tt.sloths = &one;
    tt.focus = Some(1);
    tt.traces = &traces_turn;
    tt.title = "turn 120 deg (synthetic)".into();
    tt.width = 1000;
    tt.height = 900;
    save_png(&draw_topdown(&tt), &out.join("topdown_turn.png"))?;

    // --- Gait diagram: a DSDC walk (RH, LF, LH, RF), 2.8 s cycle, 0.5 s swings.
    let cycle = 2.8f32;
    let offsets = [0.25f32, 0.75, 0.5, 0.0]; // LF RF LH RH
    let duration = 12.0f32;
    let contacts = std::array::from_fn(|k| {
        let mut v = Vec::new();
        let mut start = 0.0f32;
        let mut lift = offsets[k] * cycle;
        while start < duration {
            let end = lift.min(duration);
            if end > start {
                v.push((start, end));
            }
            start = lift + 0.5;
            lift += cycle;
        }
        v
    });
    let mut gd = GaitDiagram::new(contacts, duration);
    gd.title = "sloth 0 \u{b7} DSDC (synthetic)".into();
    let t = Instant::now();
    let pm = draw_gait(&gd);
    println!("gait: {:.1} ms/plot", ms(t));
    save_png(&pm, &out.join("gait.png"))?;

    // --- Frame times: 600 frames around 7 ms with a few spikes.
    let mut rng = common::Rng::new(3);
    let frames: Vec<[f64; 6]> = (0..600)
        .map(|i| {
            let spike = if i % 97 == 50 { 9.0 } else { 0.0 };
            [
                2.0 + rng.f32() as f64 * 0.8 + spike,
                1.2 + rng.f32() as f64 * 0.5,
                0.6 + rng.f32() as f64 * 0.2,
                2.2 + rng.f32() as f64 * 0.9,
                0.1 + rng.f32() as f64 * 0.05,
                0.3 + rng.f32() as f64 * 0.1,
            ]
        })
        .collect();
    let mut ft = FrameTimes::new(&frames);
    ft.title = "2000 sloths (synthetic)".into();
    let t = Instant::now();
    let pm = draw_frame_times(&ft);
    println!("frame times: {:.1} ms/plot", ms(t));
    save_png(&pm, &out.join("frame_times.png"))?;

    // --- Empty inputs.
    let empty = Scene::new(Vec::new())?;
    save_png(
        &draw_topdown(&TopDown::new(&empty)),
        &out.join("empty_topdown.png"),
    )?;
    save_png(
        &draw_side(&SideView::new(&empty, &[])),
        &out.join("empty_side.png"),
    )?;
    save_png(
        &draw_gait(&GaitDiagram::new(Default::default(), 0.0)),
        &out.join("empty_gait.png"),
    )?;
    save_png(
        &draw_frame_times(&FrameTimes::new(&[])),
        &out.join("empty_frame_times.png"),
    )?;
    println!("wrote {}", out.display());
    Ok(())
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
