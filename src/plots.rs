//! Debug plots of crowd runs, scenarios and checkpoints (drawn by `slothsim-plot`
//! after the simulation, outside the per-frame timings); `slothsim plot` and the
//! hidden `slothsim plot-check` used by CI.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use glam::{Vec2, Vec3};
use slothsim::rig::Rig;
use slothsim::scene::Scene;
use slothsim::sim::snapshot::{CrowdRecorder, crowd_poses, crowd_traces};
use slothsim::sim::{Crowd, ScenarioResult};
use slothsim::to_plot;
use slothsim_plot::{
    FrameTimes, GaitDiagram, LoadChart, Pixmap, SideView, TopDown, contact_intervals,
    draw_frame_times, draw_gait, draw_loads, draw_side, draw_topdown, save_png,
};

use crate::cli_common::{load_checkpoint, prepare_out};

/// Cost of one plot: drawing and writing the PNG, milliseconds.
#[derive(Clone, Debug)]
pub struct PlotCost {
    /// File name.
    pub name: &'static str,
    /// Drawing.
    pub draw_ms: f64,
    /// Encoding and writing.
    pub write_ms: f64,
}

/// Draws one plot and writes `dir/name`, timing both.
fn render(
    dir: &Path,
    name: &'static str,
    costs: &mut Vec<PlotCost>,
    draw: impl FnOnce() -> Pixmap,
) -> Result<()> {
    let t = Instant::now();
    let pm = draw();
    let draw_ms = t.elapsed().as_secs_f64() * 1e3;
    let t = Instant::now();
    let path = dir.join(name);
    save_png(&pm, &path).with_context(|| format!("cannot write plot {}", path.display()))?;
    costs.push(PlotCost {
        name,
        draw_ms,
        write_ms: t.elapsed().as_secs_f64() * 1e3,
    });
    Ok(())
}

/// `plots: topdown.png 95 ms (draw 70 + write 25), …`
pub fn print_costs(costs: &[PlotCost], dir: &Path) {
    let parts: Vec<String> = costs
        .iter()
        .map(|c| {
            format!(
                "{} {:.0} ms (draw {:.0} + write {:.0})",
                c.name,
                c.draw_ms + c.write_ms,
                c.draw_ms,
                c.write_ms
            )
        })
        .collect();
    println!("plots in {}: {}", dir.display(), parts.join(", "));
}

/// The grip-load chart (`loads.png`) of one sloth's frames.
fn load_chart(
    title: String,
    times: &[f32],
    loads: &[slothsim::gait::LimbLoads],
    release_bw: f32,
) -> Pixmap {
    let force_bw = loads
        .iter()
        .map(|l| {
            l.force
                .map(|f| if l.ok { f.length() / l.weight_n } else { 0.0 })
        })
        .collect();
    let residual_bw = loads.iter().map(|l| l.residual_bw).collect();
    let mut chart = LoadChart::new(times.to_vec(), force_bw, residual_bw);
    chart.title = title;
    chart.release_bw = release_bw;
    draw_loads(&chart)
}

/// Gait diagram time axis: from 0 when the samples start at the beginning, else fitted.
fn gait_duration(times: &[f32]) -> f32 {
    match (times.first(), times.last()) {
        (Some(&a), Some(&b)) if a < 0.5 => b,
        _ => 0.0,
    }
}

/// The plots of a crowd run: `topdown.png`, `gait.png`, `loads.png`, `frame_times.png`.
pub fn run_plots(dir: &Path, crowd: &Crowd, rec: &CrowdRecorder) -> Result<Vec<PlotCost>> {
    let mut costs = Vec::new();
    let sloths = to_plot::sloth_poses(&crowd_poses(crowd));
    let traces = to_plot::trace_lines(&rec.traces(crowd));
    let scene = crowd.world().resource::<slothsim::sim::Locomotion>();
    let time_s = rec.gait_times.last().copied().unwrap_or(0.0);
    render(dir, "topdown.png", &mut costs, || {
        let mut td = TopDown::new(scene.traces.scene());
        td.sloths = &sloths;
        td.trails = &rec.trails;
        td.focus = Some(rec.focus());
        td.traces = &traces;
        td.time_s = time_s;
        td.seed = crowd.spec().seed;
        td.title = "slothsim run".into();
        draw_topdown(&td)
    })?;
    render(dir, "gait.png", &mut costs, || {
        let contacts = contact_intervals(&rec.gait_times, &rec.gait_planted);
        let mut g = GaitDiagram::new(contacts, gait_duration(&rec.gait_times));
        g.title = format!("gait of sloth {}", rec.focus());
        draw_gait(&g)
    })?;
    render(dir, "loads.png", &mut costs, || {
        load_chart(
            format!("grip loads of sloth {}", rec.focus()),
            &rec.gait_times,
            &rec.loads,
            crowd.spec().cfg.release_residual_bw,
        )
    })?;
    render(dir, "frame_times.png", &mut costs, || {
        let history = &crowd.timings().history;
        let mut ft = FrameTimes::new(history);
        ft.title = format!("stage times per frame, {} sloths", crowd.spec().sloths);
        draw_frame_times(&ft)
    })?;
    Ok(costs)
}

/// The plots of a scenario run: `topdown.png` (zoomed on the sloth's path),
/// `side.png`, `gait.png`, `loads.png`, `frame_times.png`.
pub fn scenario_plots(
    dir: &Path,
    scene: &Scene,
    goal: Vec3,
    r: &ScenarioResult,
) -> Result<Vec<PlotCost>> {
    let mut costs = Vec::new();
    let label = scenario_label(r);
    let poses = to_plot::side_instants(&r.poses);
    let traces = to_plot::trace_lines(&r.traces);
    let last = poses.last().map(|i| i.pose);
    let sloths: Vec<_> = last.into_iter().collect();
    let mut trail: Vec<Vec3> = r.trail.clone();
    if let Some(p) = &last {
        trail.push(p.body_pos);
    }
    // The window: the path, the poses and the goal, 1 m around.
    let mut lo = Vec2::new(goal.x, goal.z);
    let mut hi = lo;
    for p in poses
        .iter()
        .flat_map(|i| i.pose.points().collect::<Vec<_>>())
        .chain(trail.iter().copied())
    {
        if p.is_finite() {
            lo = lo.min(Vec2::new(p.x, p.z));
            hi = hi.max(Vec2::new(p.x, p.z));
        }
    }
    let view = (lo - Vec2::splat(1.0), hi + Vec2::splat(1.0));
    let trails = [trail];
    let time_s = r.observations.last().map_or(0.0, |o| o.time_s);
    render(dir, "topdown.png", &mut costs, || {
        let mut td = TopDown::new(scene);
        td.sloths = &sloths;
        td.trails = &trails;
        td.focus = Some(0);
        td.traces = &traces;
        td.time_s = time_s;
        td.title = label.clone();
        td.view = Some(view);
        draw_topdown(&td)
    })?;
    // Side view: up to 8 instants spread over the run, always the last one, each over
    // its cluster-skinned mesh (skinned here, for the drawn instants only).
    let n = poses.len();
    let idx: Vec<usize> = if n <= 8 {
        (0..n).collect()
    } else {
        let mut idx: Vec<usize> = (0..8).map(|k| k * (n - 1) / 7).collect();
        idx.dedup();
        idx
    };
    let picks: Vec<_> = idx.iter().map(|&i| poses[i]).collect();
    let skinner = slothsim::skin_view::Skinner::sloth();
    let silhouettes: Vec<Vec<Vec3>> = idx
        .iter()
        .map(|&i| match &skinner {
            Ok(s) => s.skin(&r.poses[i].pose).unwrap_or_else(|e| {
                eprintln!("side.png: no mesh at t = {:.2} s: {e}", r.poses[i].time_s);
                Vec::new()
            }),
            Err(_) => Vec::new(),
        })
        .collect();
    if let Err(e) = &skinner {
        eprintln!("side.png: skeleton only, the sloth mesh cannot be skinned: {e}");
    }
    let triangles = skinner.as_ref().map_or(&[][..], |s| s.triangles());
    render(dir, "side.png", &mut costs, || {
        let mut sv = SideView::new(scene, &picks);
        sv.title = format!("{label}: side view");
        sv.silhouettes = &silhouettes;
        sv.silhouette_triangles = triangles;
        draw_side(&sv)
    })?;
    render(dir, "gait.png", &mut costs, || {
        let times: Vec<f32> = r.observations.iter().map(|o| o.time_s).collect();
        let planted: Vec<[bool; 4]> = r
            .observations
            .iter()
            .map(|o| o.limbs.map(|l| l.planted))
            .collect();
        let mut g = GaitDiagram::new(contact_intervals(&times, &planted), gait_duration(&times));
        g.title = format!("{label}: gait");
        draw_gait(&g)
    })?;
    render(dir, "loads.png", &mut costs, || {
        let times: Vec<f32> = r.loads.iter().map(|l| l.0).collect();
        let loads: Vec<_> = r.loads.iter().map(|l| l.1).collect();
        load_chart(
            format!("{label}: grip loads"),
            &times,
            &loads,
            r.release_residual_bw,
        )
    })?;
    render(dir, "frame_times.png", &mut costs, || {
        let mut ft = FrameTimes::new(&r.stage_ms);
        ft.title = format!("{label}: stage times per frame");
        draw_frame_times(&ft)
    })?;
    Ok(costs)
}

/// `scenario turn 135` / `scenario trunk (down)`.
fn scenario_label(r: &ScenarioResult) -> String {
    let p = r.parameter.map_or(String::new(), |v| format!(" {v}"));
    let v = r
        .variant
        .map_or(String::new(), |v| format!(" ({v:?})").to_lowercase());
    format!(
        "scenario {}{p}{v} {}",
        r.scenario,
        if r.verdict.pass { "PASS" } else { "FAIL" }
    )
}

#[derive(Args)]
pub struct PlotArgs {
    /// A checkpoint written by `slothsim run --save-state`.
    #[arg(long, value_name = "FILE")]
    state: PathBuf,
    /// The glTF forest, when the run used one that has moved since.
    #[arg(long, value_name = "FILE")]
    forest: Option<PathBuf>,
    /// The sloth whose pending step-search traces are drawn.
    #[arg(long, default_value_t = 0)]
    focus: u32,
    /// Output folder (topdown.png).
    #[arg(long, default_value = "out/plot")]
    out: PathBuf,
}

/// `slothsim plot --state FILE --out DIR`: the top-down view of a checkpoint.
pub fn plot(args: PlotArgs) -> Result<bool> {
    prepare_out(&args.out)?;
    let crowd = load_checkpoint(&args.state, args.forest.as_deref(), &Rig::sloth())?;
    let n = crowd.spec().sloths;
    if args.focus >= n {
        bail!(
            "--focus {} is not a sloth of this state (0..{n})",
            args.focus
        );
    }
    let sloths = to_plot::sloth_poses(&crowd_poses(&crowd));
    let traces = to_plot::trace_lines(&crowd_traces(&crowd, args.focus));
    let loco = crowd.world().resource::<slothsim::sim::Locomotion>();
    let mut costs = Vec::new();
    render(&args.out, "topdown.png", &mut costs, || {
        let mut td = TopDown::new(loco.traces.scene());
        td.sloths = &sloths;
        td.focus = Some(args.focus);
        td.traces = &traces;
        td.time_s = crowd.frame() as f32 * crowd.spec().dt;
        td.seed = crowd.spec().seed;
        td.title = format!("checkpoint {}", args.state.display());
        draw_topdown(&td)
    })?;
    print_costs(&costs, &args.out);
    Ok(true)
}

#[derive(Args)]
pub struct PlotCheckArgs {
    /// Fewest distinct colours a plot must have.
    #[arg(long, default_value_t = 8)]
    min_colours: usize,
    /// PNG files that must exist and show something.
    #[arg(required = true)]
    files: Vec<PathBuf>,
}

/// What a PNG holds: size, distinct colours, share of the most common colour.
#[derive(Clone, Copy, Debug)]
pub struct PngSummary {
    /// Width.
    pub width: u32,
    /// Height.
    pub height: u32,
    /// Distinct RGBA values.
    pub colours: usize,
    /// Share of pixels with the most common colour (0..=1).
    pub dominant: f64,
}

/// Decodes a PNG and summarises its pixels.
pub fn png_summary(path: &Path) -> Result<PngSummary> {
    let pm = Pixmap::load_png(path).with_context(|| format!("cannot decode {}", path.display()))?;
    let mut counts: HashMap<u32, u32> = HashMap::new();
    for p in pm.pixels() {
        let key = u32::from_le_bytes([p.red(), p.green(), p.blue(), p.alpha()]);
        *counts.entry(key).or_default() += 1;
    }
    let top = counts.values().copied().max().unwrap_or(0);
    Ok(PngSummary {
        width: pm.width(),
        height: pm.height(),
        colours: counts.len(),
        dominant: top as f64 / (pm.width() as f64 * pm.height() as f64).max(1.0),
    })
}

/// `slothsim plot-check FILE…`: every file exists, decodes, is at least
/// 64 × 64 px with `--min-colours` distinct colours and no colour covering
/// more than 99 % of it. Exit 1 when one is missing or blank.
pub fn plot_check(args: PlotCheckArgs) -> Result<bool> {
    let mut ok = true;
    for f in &args.files {
        match png_summary(f) {
            Ok(s) => {
                let blank = s.width < 64
                    || s.height < 64
                    || s.colours < args.min_colours
                    || s.dominant > 0.99;
                println!(
                    "{} {}: {}x{} px, {} colours, {:.1} % background",
                    if blank { "BLANK" } else { "ok   " },
                    f.display(),
                    s.width,
                    s.height,
                    s.colours,
                    s.dominant * 100.0
                );
                ok &= !blank;
            }
            Err(e) => {
                let missing = !f.exists();
                println!(
                    "{} {}: {e:#}",
                    if missing { "MISSING" } else { "BAD  " },
                    f.display()
                );
                ok = false;
            }
        }
    }
    if !ok {
        eprintln!("plot-check: some plots are missing or blank");
    }
    Ok(ok)
}
