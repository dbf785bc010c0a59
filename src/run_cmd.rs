//! `slothsim run`: the main job — a crowd of wandering sloths on a forest.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use slothsim::rig::Rig;
use slothsim::scene::{Scene, generate_forest, read_scene};
use slothsim::sim::record::{RecordSelection, Sampler};
use slothsim::sim::snapshot::CrowdRecorder;
use slothsim::sim::{
    Crowd, CrowdSpec, CrowdStats, ForestSource, Locomotion, StageTimings, forest_for,
    init_compute_pool, scene_hash, write_atomically,
};

use crate::scenario_cmd::{ProfileArg, load_config};

#[derive(Args)]
pub struct RunArgs {
    /// Locomotion config (TOML); overrides the profile's defaults.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Gait profile.
    #[arg(long, value_enum, default_value = "free")]
    profile: ProfileArg,
    /// A glTF forest (.glb/.gltf); default: the embedded procedural forest.
    #[arg(long, value_name = "FILE")]
    forest: Option<PathBuf>,
    /// Number of sloths.
    #[arg(long, default_value_t = 2000, allow_hyphen_values = true)]
    sloths: i64,
    /// Trees of the procedural forest (default: 64, more when the crowd needs room).
    #[arg(long)]
    trees: Option<u32>,
    /// Seed of the procedural forest (default 1).
    #[arg(long)]
    forest_seed: Option<u64>,
    /// Simulated seconds.
    #[arg(long, default_value_t = 60.0, allow_hyphen_values = true)]
    seconds: f32,
    /// Seed of spawning and route choices.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Worker threads (default: all cores).
    #[arg(long)]
    threads: Option<usize>,
    /// Fixed time step (s).
    #[arg(long, default_value_t = 1.0 / 60.0)]
    dt: f32,
    /// Clearance kept between sloths (m).
    #[arg(long, default_value_t = 0.3)]
    clearance: f32,
    /// Output folder (stats.json, timings.csv, plots).
    #[arg(long, default_value = "out/run")]
    out: PathBuf,
    /// Write the final state here (continue with --load-state).
    #[arg(long, value_name = "FILE")]
    save_state: Option<PathBuf>,
    /// Continue from a saved state for --seconds more (forest, config, seed
    /// and sloths come from the state).
    #[arg(long, value_name = "FILE")]
    load_state: Option<PathBuf>,
    /// Do not draw plots.
    #[arg(long)]
    no_plots: bool,
    /// The sloth whose gait and step-search traces are plotted.
    #[arg(long, default_value_t = 0)]
    focus: u32,
    #[command(flatten)]
    record: crate::export_cmd::RecordArgs,
}

/// Builds the crowd: fresh, or from a checkpoint.
fn build_crowd(args: &RunArgs, rig: &Rig) -> Result<Crowd> {
    if let Some(state) = &args.load_state {
        let explicit = std::env::args().any(|a| {
            [
                "--sloths",
                "--trees",
                "--seed",
                "--forest-seed",
                "--config",
                "--profile",
                "--dt",
                "--clearance",
            ]
            .iter()
            .any(|f| a == *f || a.starts_with(&format!("{f}=")))
        });
        if explicit {
            bail!(
                "--load-state takes the forest, config, seed, sloths and time step from the state file; drop --sloths/--trees/--seed/--forest-seed/--config/--profile/--dt/--clearance"
            );
        }
        return load_checkpoint(state, args.forest.as_deref(), rig);
    }
    if args.sloths <= 0 {
        bail!("--sloths must be at least 1 (got {})", args.sloths);
    }
    let sloths = u32::try_from(args.sloths).context("--sloths is too large")?;
    let cfg = load_config(args.profile, args.config.as_deref())?;
    let (scene, source): (Scene, ForestSource) = match &args.forest {
        Some(path) => {
            if args.trees.is_some() || args.forest_seed.is_some() {
                bail!("--trees and --forest-seed size the procedural forest; not with --forest");
            }
            let scene = read_scene(path).with_context(|| format!("forest {}", path.display()))?;
            let hash = scene_hash(&scene);
            (
                scene,
                ForestSource::File {
                    path: path.clone(),
                    scene_hash: hash,
                },
            )
        }
        None => {
            let fc = forest_for(sloths, args.trees, args.forest_seed);
            fc.validate()?;
            (generate_forest(&fc)?, ForestSource::Procedural(fc))
        }
    };
    let spec = CrowdSpec {
        sloths,
        seed: args.seed,
        dt: args.dt,
        cfg,
        clearance_m: args.clearance,
    };
    Ok(Crowd::new(spec, rig, scene, source)?)
}

/// A crowd from a checkpoint: its forest rebuilt (procedural) or read
/// (`forest` overrides the file path the state names), then the state loaded.
pub fn load_checkpoint(state: &Path, forest: Option<&Path>, rig: &Rig) -> Result<Crowd> {
    let info = Crowd::checkpoint_info(state)?;
    let scene = match &info.forest {
        ForestSource::Procedural(cfg) => generate_forest(cfg)?,
        ForestSource::File { path, .. } => {
            let path = forest.unwrap_or(path);
            read_scene(path).with_context(|| format!("forest {}", path.display()))?
        }
    };
    Ok(Crowd::load_state(state, rig, scene)?)
}

/// Makes sure `dir` exists and is writable before a long run starts.
pub fn prepare_out(dir: &Path) -> Result<()> {
    std::fs::create_dir_all(dir)
        .with_context(|| format!("cannot create output folder {}", dir.display()))?;
    let probe = dir.join(".slothsim-write-probe");
    std::fs::write(&probe, b"")
        .with_context(|| format!("output folder {} is not writable", dir.display()))?;
    let _ = std::fs::remove_file(probe);
    Ok(())
}

pub fn run(args: RunArgs) -> Result<bool> {
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        bail!("--seconds must be > 0 (got {})", args.seconds);
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    if args.load_state.is_none() {
        args.record.hz(args.dt)?;
    }
    args.record.selection(RecordSelection::All)?;
    prepare_out(&args.out)?;
    let threads = init_compute_pool(args.threads);
    // Spawning uses rayon; give it the same number of threads.
    let _ = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build_global();
    let rig = Rig::sloth();
    let t0 = Instant::now();
    let mut crowd = build_crowd(&args, &rig)?;
    let setup_s = t0.elapsed().as_secs_f64();
    let dt = crowd.spec().dt;
    let frames = (args.seconds / dt).round().max(1.0) as u64;
    eprintln!(
        "{} sloths, {frames} frames of {:.4} s, {threads} threads (set up in {setup_s:.1} s)",
        crowd.spec().sloths,
        dt
    );
    if args.focus >= crowd.spec().sloths {
        bail!(
            "--focus {} is not a sloth of this run (0..{})",
            args.focus,
            crowd.spec().sloths
        );
    }
    // Plot samples (trails every second, the focus sloth's gait and traces)
    // are read after each tick, outside the stage timings.
    let mut recorder = (!args.no_plots).then(|| CrowdRecorder::new(&crowd, args.focus, 1.0));
    // So are the recording's samples (crowd.glb, trajectories.csv).
    let mut sampler = crate::export_cmd::start_crowd(
        &args.record,
        &crowd,
        &rig,
        args.focus,
        &args.out,
        args.seconds,
    )?;
    let t1 = Instant::now();
    simulate(&mut crowd, frames, recorder.as_mut(), sampler.as_mut());
    let wall_s = t1.elapsed().as_secs_f64();
    let stats = crowd.stats(threads);
    if let Some(path) = &args.save_state {
        crowd.save_state(path)?;
    }
    let scene = crowd.world().resource::<Locomotion>().traces.scene();
    let record = sampler
        .map(|s| crate::export_cmd::finish(s, scene, &args.out))
        .transpose()?;
    write_outputs(&args.out, &stats, crowd.timings(), record.as_ref())?;
    print_summary(&stats, wall_s, &args.out);
    if let Some(rec) = &mut recorder {
        rec.finish(&crowd);
        let costs = crate::plots::run_plots(&args.out, &crowd, rec)?;
        crate::plots::print_costs(&costs, &args.out);
    }
    Ok(true)
}

/// Runs `frames` ticks with a progress bar on a terminal, plain lines otherwise.
fn simulate(
    crowd: &mut Crowd,
    frames: u64,
    mut recorder: Option<&mut CrowdRecorder>,
    mut sampler: Option<&mut Sampler>,
) {
    let tty = std::io::stderr().is_terminal();
    let bar = if tty {
        let b = indicatif::ProgressBar::new(frames);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{bar:40} {pos}/{len} frames  {elapsed_precise} ETA {eta}  {msg}",
            )
            .expect("valid template"),
        );
        Some(b)
    } else {
        None
    };
    let tenth = (frames / 10).max(1);
    for f in 1..=frames {
        crowd.step();
        if let Some(r) = recorder.as_deref_mut() {
            r.record(crowd);
        }
        if let Some(s) = sampler.as_deref_mut() {
            s.after_tick(crowd);
        }
        let frame_ms: f64 = crowd.timings().last.iter().sum();
        if let Some(b) = &bar {
            b.set_position(f);
            if f % 30 == 0 {
                b.set_message(format!("{frame_ms:.2} ms/frame"));
            }
        } else if f % tenth == 0 || f == frames {
            eprintln!(
                "frame {f}/{frames} ({:.0} %), {frame_ms:.2} ms/frame",
                f as f64 * 100.0 / frames as f64
            );
        }
    }
    if let Some(b) = bar {
        b.finish_and_clear();
    }
}

fn write_outputs(
    dir: &Path,
    stats: &CrowdStats,
    timings: &StageTimings,
    record: Option<&crate::export_cmd::RecordStats>,
) -> Result<()> {
    let mut value = serde_json::to_value(stats)?;
    if let (Some(r), Some(map)) = (record, value.as_object_mut()) {
        map.insert("record".into(), serde_json::to_value(r)?);
    }
    let json = serde_json::to_string_pretty(&value)?;
    let path = dir.join("stats.json");
    write_atomically(&path, json.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    let mut csv = String::from("frame");
    for n in StageTimings::NAMES {
        csv.push(',');
        csv.push_str(n);
    }
    csv.push_str(",total\n");
    for (i, row) in timings.history.iter().enumerate() {
        csv.push_str(&i.to_string());
        for v in row {
            csv.push_str(&format!(",{v:.4}"));
        }
        csv.push_str(&format!(",{:.4}\n", row.iter().sum::<f64>()));
    }
    let path = dir.join("timings.csv");
    write_atomically(&path, csv.as_bytes())
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

fn print_summary(s: &CrowdStats, wall_s: f64, out: &Path) {
    println!(
        "{} sloths, {} frames ({:.1} s simulated in {:.1} s wall, {} threads)",
        s.sloths,
        s.frames,
        s.frames as f64 * s.dt as f64,
        wall_s,
        s.threads
    );
    println!(
        "frame ms p50 {:.2}, p95 {:.2}, max {:.2}; stages p50: trace {:.2}, step_search {:.2}, body_average {:.2}, ccd_solve {:.2}, transitions {:.2}",
        s.frame_ms.p50,
        s.frame_ms.p95,
        s.frame_ms.max,
        s.stages_ms.trace.p50,
        s.stages_ms.step_search.p50,
        s.stages_ms.body_average.p50,
        s.stages_ms.ccd_solve.p50,
        s.stages_ms.transitions.p50
    );
    println!(
        "speed {:.3} m/s mean; slip {:.4} m, gap {:.4} m, limit violations {}, min contact {}, penetration {:.4} m, NaN {}",
        s.speed_mps_mean,
        s.max_grip_slip_m,
        s.max_surface_gap_m,
        s.joint_limit_violations,
        s.min_limbs_in_contact,
        s.max_penetration_m,
        s.nan_count
    );
    println!(
        "stuck sloths {} (no step in the last 10 s), turn-backs {}",
        s.stuck_sloths, s.turn_backs
    );
    let r = &s.roaming;
    println!(
        "roaming: {} of {} supports visited ({:.1} per sloth), {} trunks climbed, {:.1} % of the time on trunks, {} branch ↔ trunk changes by {} sloths",
        r.supports_visited,
        r.supports,
        r.supports_per_sloth_mean,
        r.trunks_climbed,
        r.trunk_frame_share * 100.0,
        r.branch_trunk_changes,
        r.sloths_changing_kind
    );
    println!("state_hash {}", s.state_hash);
    println!("wrote {}", out.display());
}
