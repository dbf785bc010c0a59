//! `slothsim run`: the main job — a crowd of wandering sloths on a forest.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::parser::ValueSource;
use clap::{ArgMatches, Args};
use slothsim::gait::LocomotionConfig;
use slothsim::rig::Rig;
use slothsim::scene::{Scene, generate_forest, read_scene};
use slothsim::sim::record::{RecordSelection, Sampler};
use slothsim::sim::snapshot::CrowdRecorder;
use slothsim::sim::{
    Crowd, CrowdSpec, CrowdStats, ForestSource, Locomotion, StageTimings, forest_for,
    init_compute_pool, scene_hash, write_atomically,
};

use crate::cli_common::{ProfileArg, ShardArgs, load_checkpoint, load_config, prepare_out};
use crate::provenance::{
    Provenance, file_sha256, read_provenance, run_provenance, with_provenance,
};

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
    /// Re-run the run a `stats.json` describes (its `provenance`: config,
    /// forest, seed, sloths, time step, clearance, frames) and check that
    /// it reaches the same `state_hash` (exit 1 when not).
    #[arg(long, value_name = "STATS_JSON")]
    from: Option<PathBuf>,
    /// A seed sweep: seeds A..B (both included), each run into OUT/seed-S/.
    /// With --shard I/N (or a Slurm / Kubernetes array index) only every
    /// N-th seed from the I-th.
    #[arg(long, value_name = "A..B")]
    seeds: Option<String>,
    #[command(flatten)]
    shard: ShardArgs,
    #[command(flatten)]
    record: crate::export_cmd::RecordArgs,
}

/// The flags that decide what is simulated; `--load-state` and `--from`
/// take them from their file instead.
const INPUT_FLAGS: [&str; 8] = [
    "sloths",
    "trees",
    "seed",
    "forest_seed",
    "config",
    "profile",
    "dt",
    "clearance",
];

/// Whether flag `id` was given on the command line (not a default).
fn given(m: &ArgMatches, id: &str) -> bool {
    m.value_source(id) == Some(ValueSource::CommandLine)
}

/// `--flag` spelling of an argument id.
fn flag(id: &str) -> String {
    format!("--{}", id.replace('_', "-"))
}

/// What a run simulates, however it was asked for.
struct Plan {
    sloths: u32,
    seed: u64,
    dt: f32,
    clearance_m: f32,
    cfg: LocomotionConfig,
    forest: ForestSource,
}

/// A crowd built, with the hash of its forest's supports.
struct Built {
    crowd: Crowd,
    scene_hash: u64,
}

/// The plan from the flags.
fn plan_from_flags(args: &RunArgs, seed: u64) -> Result<Plan> {
    if args.sloths <= 0 {
        bail!("--sloths must be at least 1 (got {})", args.sloths);
    }
    let sloths = u32::try_from(args.sloths).context("--sloths is too large")?;
    let cfg = load_config(args.profile, args.config.as_deref())?;
    let forest = match &args.forest {
        Some(path) => {
            if args.trees.is_some() || args.forest_seed.is_some() {
                bail!("--trees and --forest-seed size the procedural forest; not with --forest");
            }
            ForestSource::File {
                path: path.clone(),
                scene_hash: 0,
            }
        }
        None => {
            let fc = forest_for(sloths, args.trees, args.forest_seed);
            fc.validate()?;
            ForestSource::Procedural(fc)
        }
    };
    Ok(Plan {
        sloths,
        seed,
        dt: args.dt,
        clearance_m: args.clearance,
        cfg,
        forest,
    })
}

/// Builds the crowd a plan describes.
fn build(plan: Plan, rig: &Rig) -> Result<Built> {
    let (scene, source): (Scene, ForestSource) = match plan.forest {
        ForestSource::File { path, .. } => {
            let scene = read_scene(&path).with_context(|| format!("forest {}", path.display()))?;
            let hash = scene_hash(&scene);
            (
                scene,
                ForestSource::File {
                    path,
                    scene_hash: hash,
                },
            )
        }
        ForestSource::Procedural(fc) => (generate_forest(&fc)?, ForestSource::Procedural(fc)),
    };
    let scene_hash = scene_hash(&scene);
    let spec = CrowdSpec {
        sloths: plan.sloths,
        seed: plan.seed,
        dt: plan.dt,
        cfg: plan.cfg,
        clearance_m: plan.clearance_m,
    };
    Ok(Built {
        crowd: Crowd::new(spec, rig, scene, source)?,
        scene_hash,
    })
}

/// The plan a `stats.json` records, checked against this program and the
/// forest file it names; also the frames and the `state_hash` to reach.
fn plan_from_stats(path: &Path) -> Result<(Plan, u64, String)> {
    let (prov, value) = read_provenance(path)?;
    let here = Provenance::here(1, None);
    if !here.same_program(&prov) {
        bail!(
            "{} was written by {}; this is {}: re-run it with that build",
            path.display(),
            prov.program_text(),
            here.program_text()
        );
    }
    let field = |name: &str| format!("{}: field `provenance.{name}` is missing", path.display());
    let run = prov.run.with_context(|| field("run"))?;
    let cfg = prov.config.with_context(|| field("config"))?;
    if run.load_state.is_some() || run.start_frame != 0 {
        bail!(
            "{} continues a checkpoint (--load-state {}); re-run that with --load-state",
            path.display(),
            run.load_state.as_deref().unwrap_or("?")
        );
    }
    if let ForestSource::File { path: forest, .. } = &run.forest.source {
        let sha = file_sha256(forest)?;
        if run.forest.file_sha256.as_deref() != Some(sha.as_str()) {
            bail!(
                "{}: the forest {} has changed since (SHA-256 {sha}, the run had {})",
                path.display(),
                forest.display(),
                run.forest.file_sha256.as_deref().unwrap_or("none")
            );
        }
    }
    let hash = value
        .get("state_hash")
        .and_then(|h| h.as_str())
        .with_context(|| format!("{}: field `state_hash` is missing", path.display()))?
        .to_string();
    let plan = Plan {
        sloths: run.sloths,
        seed: run.seed,
        dt: run.dt,
        clearance_m: run.clearance_m,
        cfg,
        forest: run.forest.source,
    };
    Ok((plan, run.frames, hash))
}

/// Parses `A..B` (both included).
fn parse_seeds(text: &str) -> Result<Vec<u64>> {
    let (a, b) = text
        .split_once("..")
        .with_context(|| format!("--seeds {text}: expected A..B, e.g. 1..16"))?;
    let b = b.strip_prefix('=').unwrap_or(b);
    let a: u64 = a
        .trim()
        .parse()
        .with_context(|| format!("--seeds {text}: `{a}` is not a seed"))?;
    let b: u64 = b
        .trim()
        .parse()
        .with_context(|| format!("--seeds {text}: `{b}` is not a seed"))?;
    if b < a {
        bail!("--seeds {text}: the last seed is below the first");
    }
    if b - a >= 100_000 {
        bail!("--seeds {text}: more than 100,000 seeds");
    }
    Ok((a..=b).collect())
}

/// Refuses `flags` given on the command line beside `mode`.
fn refuse_beside(m: &ArgMatches, mode: &str, what: &str, flags: &[&str]) -> Result<()> {
    let given: Vec<String> = flags
        .iter()
        .filter(|id| given(m, id))
        .map(|id| flag(id))
        .collect();
    if !given.is_empty() {
        bail!("{mode} takes {what}; drop {}", given.join("/"));
    }
    Ok(())
}

pub fn run(args: RunArgs, m: &ArgMatches) -> Result<bool> {
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        bail!("--seconds must be > 0 (got {})", args.seconds);
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    if args.load_state.is_some() {
        refuse_beside(
            m,
            "--load-state",
            "the forest, config, seed, sloths and time step from the state file",
            &INPUT_FLAGS,
        )?;
        refuse_beside(m, "--load-state", "one state", &["from", "seeds"])?;
    }
    if args.from.is_some() {
        let mut flags = INPUT_FLAGS.to_vec();
        flags.extend(["forest", "seconds", "seeds"]);
        refuse_beside(
            m,
            "--from",
            "the forest, config, seed, sloths, time step and frames from the stats file",
            &flags,
        )?;
    }
    if args.seeds.is_some() {
        refuse_beside(
            m,
            "--seeds",
            "the seeds of the sweep",
            &["seed", "save_state"],
        )?;
    } else if args.shard.is_given() {
        bail!("--shard/--shards split a --seeds sweep (or a matrix); give --seeds A..B");
    }
    if args.load_state.is_none() && args.from.is_none() {
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
    let frames_of = |dt: f32| (args.seconds / dt).round().max(1.0) as u64;
    if let Some(from) = &args.from {
        let (plan, frames, expected) = plan_from_stats(from)?;
        let built = build(plan, &rig)?;
        let stats = run_one(&args, &rig, built, frames, &args.out, threads, None)?;
        if stats.state_hash != expected {
            eprintln!(
                "error: state_hash {} differs from {}'s {expected}",
                stats.state_hash,
                from.display()
            );
            return Ok(false);
        }
        println!("reproduced state_hash {expected} of {}", from.display());
        return Ok(true);
    }
    if let Some(state) = &args.load_state {
        let t0 = Instant::now();
        let crowd = load_checkpoint(state, args.forest.as_deref(), &rig)?;
        let scene_hash = match crowd.forest_source() {
            Some(ForestSource::Procedural(fc)) => scene_hash(&generate_forest(fc)?),
            Some(ForestSource::File { scene_hash, .. }) => *scene_hash,
            None => 0,
        };
        eprintln!("state loaded in {:.1} s", t0.elapsed().as_secs_f64());
        let frames = frames_of(crowd.spec().dt);
        let built = Built { crowd, scene_hash };
        run_one(&args, &rig, built, frames, &args.out, threads, Some(state))?;
        return Ok(true);
    }
    if let Some(text) = &args.seeds {
        let seeds = parse_seeds(text)?;
        let shard = args.shard.resolve()?;
        let mine = shard.take(&seeds);
        eprintln!(
            "seed sweep {text}: shard {}/{} runs {} of {} seeds",
            shard.index,
            shard.count,
            mine.len(),
            seeds.len()
        );
        for seed in mine {
            let dir = args.out.join(format!("seed-{seed}"));
            prepare_out(&dir)?;
            let built = build(plan_from_flags(&args, seed)?, &rig)?;
            let frames = frames_of(built.crowd.spec().dt);
            run_one(&args, &rig, built, frames, &dir, threads, None)?;
        }
        return Ok(true);
    }
    let built = build(plan_from_flags(&args, args.seed)?, &rig)?;
    let frames = frames_of(built.crowd.spec().dt);
    run_one(&args, &rig, built, frames, &args.out, threads, None)?;
    Ok(true)
}

/// Runs one crowd for `frames` and writes its outputs into `out`.
fn run_one(
    args: &RunArgs,
    rig: &Rig,
    built: Built,
    frames: u64,
    out: &Path,
    threads: usize,
    load_state: Option<&Path>,
) -> Result<CrowdStats> {
    let Built {
        mut crowd,
        scene_hash,
    } = built;
    let start_frame = crowd.frame();
    let dt = crowd.spec().dt;
    eprintln!(
        "{} sloths, {frames} frames of {:.4} s, {threads} threads",
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
    let mut provenance = Provenance::here(threads, Some(&crowd.spec().cfg));
    provenance.run = Some(run_provenance(
        &crowd,
        scene_hash,
        start_frame,
        frames,
        load_state,
    )?);
    // Plot samples (trails every second, the focus sloth's gait and traces)
    // are read after each tick, outside the stage timings.
    let mut recorder = (!args.no_plots).then(|| CrowdRecorder::new(&crowd, args.focus, 1.0));
    // So are the recording's samples (crowd.glb, trajectories.csv).
    let mut sampler = crate::export_cmd::start_crowd(
        &args.record,
        &crowd,
        rig,
        args.focus,
        out,
        frames as f32 * dt,
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
        .map(|s| crate::export_cmd::finish(s, scene, out, &args.record))
        .transpose()?;
    let output = RunOutput {
        stats: &stats,
        record: record.as_ref(),
    };
    write_outputs(out, &output, &provenance, crowd.timings())?;
    print_summary(&stats, wall_s, out);
    if let Some(rec) = &mut recorder {
        rec.finish(&crowd);
        let costs = crate::plots::run_plots(out, &crowd, rec)?;
        crate::plots::print_costs(&costs, out);
    }
    Ok(stats)
}

/// `stats.json`'s body: the crowd's statistics and what recording cost.
#[derive(serde::Serialize)]
struct RunOutput<'a> {
    #[serde(flatten)]
    stats: &'a CrowdStats,
    #[serde(skip_serializing_if = "Option::is_none")]
    record: Option<&'a crate::export_cmd::RecordStats>,
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
    stats: &RunOutput,
    provenance: &Provenance,
    timings: &StageTimings,
) -> Result<()> {
    let json = serde_json::to_string_pretty(&with_provenance(stats, provenance))?;
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
        "frame ms p50 {:.2}, p95 {:.2}, max {:.2}; stages p50: trace {:.2}, step_search {:.2}, body_average {:.2}, ccd_solve {:.2}, grip_load {:.2}, transitions {:.2}",
        s.frame_ms.p50,
        s.frame_ms.p95,
        s.frame_ms.max,
        s.stages_ms.trace.p50,
        s.stages_ms.step_search.p50,
        s.stages_ms.body_average.p50,
        s.stages_ms.ccd_solve.p50,
        s.stages_ms.grip_load.p50,
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
        "stuck sloths {} (no step in the last 10 s; {} of them for over 60 s), stalled in place {} ({}+ turn-backs without travelling a step), turn-backs {}",
        s.stuck_sloths,
        s.stuck.stood.get("over_60_s").map_or(0, |c| c.count),
        s.stuck.stalled_in_place.count,
        slothsim_sim::crowd::STALLED_TURNS,
        s.turn_backs
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
