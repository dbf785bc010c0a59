//! `slothsim bench`: frame and stage times of the crowd at several sizes, the
//! largest crowd that fits a frame budget, and (`--baseline`) the ratio
//! against a naive object-per-sloth implementation.
//!
//! Method. For each size: the crowd is spawned on a forest sized by
//! `forest_for` (spawning is not timed), ticked `--warmup` frames, then
//! `--frames` frames are timed. A frame is the wall time of one tick (the five
//! stages, without the judge/statistics pass of `slothsim run`); stage times
//! come from the stages' own clocks. `max_sloths_within_budget` is the largest
//! crowd whose p95 frame time is within `--budget-ms`: bracketed by the
//! measured sizes (halving below the smallest or doubling above the largest
//! when needed), then bisected with short runs (`--search-frames` after the
//! same warm-up) to within 5 % of the answer. Frame time is assumed to grow
//! with the crowd; on a noisy machine a probe near the budget can land either
//! side, so the answer is good to about the noise (see the probes in the JSON).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;
use slothsim::gait::LocomotionConfig;
use slothsim::rig::Rig;
use slothsim::scene::generate_forest;
use slothsim::sim::baseline::Baseline;
use slothsim::sim::{
    Crowd, CrowdSpec, ForestSource, Locomotion, Percentiles, StagesMs, forest_for,
    init_compute_pool, state_hash_of, write_atomically,
};

use crate::cli_common::{ProfileArg, load_config};
use crate::provenance::{Provenance, with_provenance};

#[derive(Args)]
pub struct BenchArgs {
    /// Crowd sizes, comma-separated.
    #[arg(
        long,
        default_value = "1000,5000,10000,20000",
        allow_hyphen_values = true
    )]
    sloths: String,
    /// Timed frames per crowd size.
    #[arg(long, default_value_t = 300, allow_hyphen_values = true)]
    frames: i64,
    /// Untimed frames before timing starts.
    #[arg(long, default_value_t = 60, allow_hyphen_values = true)]
    warmup: i64,
    /// Worker threads of the tick (default: all cores). Spawning always uses all cores.
    #[arg(long)]
    threads: Option<usize>,
    /// Frame budget (ms) for `max_sloths_within_budget` (p95 frame time).
    #[arg(long, default_value_t = 12.0, allow_hyphen_values = true)]
    budget_ms: f64,
    /// Timed frames of each probe of the budget search.
    #[arg(long, default_value_t = 120, allow_hyphen_values = true)]
    search_frames: i64,
    /// Do not search for `max_sloths_within_budget` (measured sizes only).
    #[arg(long)]
    no_search: bool,
    /// Write the results as JSON here.
    #[arg(long, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Also run the naive baseline (object per sloth, one thread, brute-force
    /// traces) on the same crowd, at sizes up to --baseline-max-sloths.
    #[arg(long)]
    baseline: bool,
    /// Timed frames of the baseline (after the same warm-up; it is slow).
    #[arg(long, default_value_t = 30, allow_hyphen_values = true)]
    baseline_frames: i64,
    /// Largest crowd the baseline runs on.
    #[arg(long, default_value_t = 1000)]
    baseline_max_sloths: u32,
    /// Trees of the procedural forest (default: sized for each crowd by `forest_for`).
    #[arg(long)]
    trees: Option<u32>,
    /// Seed of spawning and route choices.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Gait profile.
    #[arg(long, value_enum, default_value = "free")]
    profile: ProfileArg,
    /// Locomotion config (TOML); overrides the profile's defaults (e.g.
    /// `crowd_load_every = 1`). A spawn cache holds crowds of one config: give
    /// each config its own --spawn-cache folder.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,
    /// Keep spawned crowds here (state files keyed by size, seed and forest)
    /// and reuse them: spawning 10,000 sloths takes minutes. Delete the folder
    /// after changing the rig or the gait.
    #[arg(long, value_name = "DIR")]
    spawn_cache: Option<PathBuf>,
}

/// Validated parameters.
struct Plan {
    sizes: Vec<u32>,
    frames: usize,
    warmup: usize,
    search_frames: usize,
    baseline_frames: usize,
    budget_ms: f64,
    cfg: LocomotionConfig,
}

fn parse_sizes(text: &str) -> Result<Vec<u32>> {
    let mut sizes = Vec::new();
    for part in text.split(',') {
        let part = part.trim();
        if part.is_empty() {
            continue;
        }
        let n: u32 = part.parse().map_err(|_| {
            anyhow::anyhow!("--sloths: {part:?} is not a whole number (expected e.g. 1000,5000)")
        })?;
        if n == 0 {
            bail!("--sloths: crowd sizes must be at least 1 (got 0)");
        }
        sizes.push(n);
    }
    if sizes.is_empty() {
        bail!("--sloths: the list is empty (expected e.g. --sloths 1000,5000)");
    }
    sizes.sort_unstable();
    sizes.dedup();
    Ok(sizes)
}

fn count(name: &str, v: i64, min: i64) -> Result<usize> {
    if v < min {
        bail!("{name} must be at least {min} (got {v})");
    }
    Ok(v as usize)
}

fn plan(args: &BenchArgs) -> Result<Plan> {
    let sizes = parse_sizes(&args.sloths)?;
    let frames = count("--frames", args.frames, 1)?;
    let warmup = count("--warmup", args.warmup, 0)?;
    let search_frames = count("--search-frames", args.search_frames, 1)?;
    let baseline_frames = count("--baseline-frames", args.baseline_frames, 1)?;
    if !(args.budget_ms.is_finite() && args.budget_ms > 0.0) {
        bail!("--budget-ms must be > 0 (got {})", args.budget_ms);
    }
    if args.threads == Some(0) {
        bail!("--threads must be at least 1");
    }
    if args.trees == Some(0) {
        bail!("--trees must be at least 1");
    }
    if let Some(path) = &args.json {
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d,
            _ => Path::new("."),
        };
        if !dir.is_dir() {
            bail!(
                "--json {}: folder {} does not exist",
                path.display(),
                dir.display()
            );
        }
    }
    let cfg = load_config(args.profile, args.config.as_deref())?;
    Ok(Plan {
        sizes,
        frames,
        warmup,
        search_frames,
        baseline_frames,
        budget_ms: args.budget_ms,
        cfg,
    })
}

/// One measured crowd size.
#[derive(Serialize)]
struct RunReport {
    sloths: u32,
    trees: u32,
    frames: usize,
    frame_ms: Percentiles,
    stages_ms: StagesMs,
    /// Frame p50 / sloths (µs).
    us_per_sloth_p50: f64,
    traces_per_frame: f64,
    /// CcdSolve stage: CCD iterations per limb solve (4 a sloth a frame).
    ccd_iterations_per_limb: f64,
    /// Spawning (forest, BVH, sloths) or loading them from the cache (s).
    setup_s: f64,
    /// Peak resident memory of the process so far (MiB; VmHWM).
    peak_rss_mib_so_far: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    baseline: Option<BaselineReport>,
}

#[derive(Serialize)]
struct BaselineReport {
    frames: usize,
    frame_ms: Percentiles,
    /// Baseline frame time / ours, p50.
    ratio_p50: f64,
    /// Baseline frame time / ours, p95.
    ratio_p95: f64,
    /// Both reached the same state after warm-up + these frames.
    same_state: bool,
}

#[derive(Serialize)]
struct Probe {
    sloths: u32,
    p95_ms: f64,
    fits: bool,
}

#[derive(Serialize)]
struct Report {
    threads: usize,
    cpus: usize,
    budget_ms: f64,
    warmup: usize,
    runs: Vec<RunReport>,
    max_sloths_within_budget: Option<u32>,
    /// True when even the largest size tried fits (the answer is a lower bound).
    max_is_lower_bound: bool,
    search_method: &'static str,
    search_probes: Vec<Probe>,
    peak_rss_mib: Option<f64>,
}

/// Peak resident set of this process (MiB), from /proc/self/status.
fn peak_rss_mib() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Spawns the crowd for `n` sloths (or loads it from the spawn cache).
fn build(args: &BenchArgs, plan: &Plan, rig: &Rig, n: u32) -> Result<(Crowd, u32)> {
    let fc = forest_for(n, args.trees, None);
    fc.validate()?;
    let trees = fc.trees;
    let source = ForestSource::Procedural(fc.clone());
    let cached = args.spawn_cache.as_ref().map(|d| {
        d.join(format!(
            "crowd-{n}-seed{}-{:?}.state",
            args.seed, args.profile
        ))
    });
    if let Some(path) = cached.as_ref().filter(|p| p.is_file())
        && let Ok(info) = Crowd::checkpoint_info(path)
        && info.forest == source
        && info.sloths == n
        && info.seed == args.seed
        && info.frame == 0
    {
        let crowd = Crowd::load_state(path, rig, generate_forest(&fc)?)?;
        if crowd.spec().cfg == plan.cfg {
            return Ok((crowd, trees));
        }
    }
    let spec = CrowdSpec {
        sloths: n,
        seed: args.seed,
        dt: 1.0 / 60.0,
        cfg: plan.cfg.clone(),
        clearance_m: 0.3,
    };
    let mut crowd = Crowd::new(spec, rig, generate_forest(&fc)?, source)
        .with_context(|| format!("spawning {n} sloths"))?;
    if let Some(path) = &cached {
        std::fs::create_dir_all(path.parent().expect("a file in a folder"))
            .with_context(|| format!("cannot create {}", path.display()))?;
        crowd.save_state(path)?;
    }
    Ok((crowd, trees))
}

/// Timed frames of `crowd` after `warmup`: per frame wall (ms), the stage
/// rows, traces and CCD iterations over the timed frames.
struct Measured {
    frame_ms: Vec<f64>,
    stages: Vec<[f64; slothsim_sim::STAGES]>,
    /// The neighbour grid's rebuild per frame (ms, a part of Transitions).
    grid: Vec<f64>,
    traces: u64,
    ccd_iterations: u64,
    /// State hash after `hash_at` frames, when asked.
    hash: Option<u64>,
}

fn measure(crowd: &mut Crowd, warmup: usize, frames: usize, hash_at: Option<usize>) -> Measured {
    let mut hash = None;
    let mut hash_if_due = |crowd: &mut Crowd, done: usize| {
        if hash_at == Some(done) {
            hash = Some(crowd.state_hash());
        }
    };
    for f in 0..warmup {
        crowd.tick();
        hash_if_due(crowd, f + 1);
    }
    let (traces0, iters0, rows0) = {
        let t = crowd.timings();
        (t.traces_total, t.ccd_iterations_total, t.history.len())
    };
    let mut frame_ms = Vec::with_capacity(frames);
    for f in 0..frames {
        let t = Instant::now();
        crowd.tick();
        frame_ms.push(t.elapsed().as_secs_f64() * 1e3);
        // Between frames, outside the clock.
        hash_if_due(crowd, warmup + f + 1);
    }
    let t = crowd.timings();
    let stages = t.history[rows0..rows0 + frames].to_vec();
    let grid = t.grid_history[rows0..rows0 + frames].to_vec();
    let traces = t.traces_total - traces0;
    let ccd_iterations = t.ccd_iterations_total - iters0;
    // The baseline ran longer than the timed run: catch up for the state check.
    let mut done = warmup + frames;
    while hash_at.is_some_and(|h| h > done) {
        crowd.tick();
        done += 1;
        hash_if_due(crowd, done);
    }
    Measured {
        frame_ms,
        stages,
        grid,
        traces,
        ccd_iterations,
        hash,
    }
}

fn run_size(args: &BenchArgs, plan: &Plan, rig: &Rig, n: u32) -> Result<RunReport> {
    let t0 = Instant::now();
    let (mut crowd, trees) = build(args, plan, rig, n)?;
    let setup_s = t0.elapsed().as_secs_f64();
    eprintln!("{n} sloths on {trees} trees: set up in {setup_s:.1} s");
    // The baseline first, from the freshly spawned sloths.
    let baseline = if args.baseline && n <= args.baseline_max_sloths {
        let frames = plan.warmup + plan.baseline_frames;
        eprintln!(
            "  baseline: {} warm-up + {} timed frames, one thread, brute-force traces…",
            plan.warmup, plan.baseline_frames
        );
        let sloths = crowd.sloths();
        let (ms, hash) = {
            let loco = crowd.world().resource::<Locomotion>();
            let mut b = Baseline::new(loco, sloths, crowd.spec().clearance_m, crowd.spec().dt);
            for _ in 0..frames {
                b.frame();
            }
            (
                b.frame_ms[plan.warmup..].to_vec(),
                state_hash_of(&b.sloths()),
            )
        };
        Some((ms, hash))
    } else {
        None
    };
    let hash_at = baseline
        .as_ref()
        .map(|_| plan.warmup + plan.baseline_frames);
    let m = measure(&mut crowd, plan.warmup, plan.frames, hash_at);
    let frame_ms = Percentiles::of(&m.frame_ms);
    let baseline = match baseline {
        Some((ms, hash)) => {
            let same_state = m.hash == Some(hash);
            let b = Percentiles::of(&ms);
            Some(BaselineReport {
                frames: ms.len(),
                frame_ms: b,
                ratio_p50: b.p50 / frame_ms.p50,
                ratio_p95: b.p95 / frame_ms.p95,
                same_state,
            })
        }
        None => None,
    };
    let frames = m.frame_ms.len();
    Ok(RunReport {
        sloths: n,
        trees,
        frames,
        frame_ms,
        stages_ms: StagesMs::of(&m.stages, &m.grid),
        us_per_sloth_p50: frame_ms.p50 * 1e3 / n as f64,
        traces_per_frame: m.traces as f64 / frames as f64,
        ccd_iterations_per_limb: m.ccd_iterations as f64 / (frames as f64 * n as f64 * 4.0),
        setup_s,
        peak_rss_mib_so_far: peak_rss_mib(),
        baseline,
    })
}

/// The largest crowd whose p95 fits the budget: bracket, then bisect.
fn search(
    args: &BenchArgs,
    plan: &Plan,
    rig: &Rig,
    runs: &[RunReport],
) -> Result<(Option<u32>, bool, Vec<Probe>)> {
    let mut probes = Vec::new();
    let probe = |n: u32, probes: &mut Vec<Probe>| -> Result<bool> {
        let (mut crowd, _) = build(args, plan, rig, n)?;
        let m = measure(&mut crowd, plan.warmup, plan.search_frames, None);
        let p95 = Percentiles::of(&m.frame_ms).p95;
        let fits = p95 <= plan.budget_ms;
        eprintln!(
            "  probe {n} sloths: p95 {p95:.2} ms ({})",
            if fits { "fits" } else { "over" }
        );
        probes.push(Probe {
            sloths: n,
            p95_ms: p95,
            fits,
        });
        Ok(fits)
    };
    let fits = |r: &RunReport| r.frame_ms.p95 <= plan.budget_ms;
    let mut lo = runs.iter().filter(|r| fits(r)).map(|r| r.sloths).max();
    let mut hi = runs
        .iter()
        .filter(|r| !fits(r) && lo.is_none_or(|l| r.sloths > l))
        .map(|r| r.sloths)
        .min();
    // Bracket below: halve until a crowd fits.
    while lo.is_none() {
        let h = hi.expect("some size was measured");
        if h == 1 {
            return Ok((None, false, probes));
        }
        let n = h / 2;
        if probe(n, &mut probes)? {
            lo = Some(n);
        } else {
            hi = Some(n);
        }
    }
    // Bracket above: double, up to 16× the largest measured size (at 4× a
    // one-thread run of 1,000 sloths already reached the cap); a crowd that
    // still fits there is reported as a lower bound.
    let cap = runs
        .iter()
        .map(|r| r.sloths)
        .max()
        .unwrap_or(1)
        .saturating_mul(16);
    while hi.is_none() {
        let l = lo.expect("bracketed below");
        let n = l.saturating_mul(2).min(cap);
        if n <= l {
            return Ok((lo, true, probes));
        }
        if probe(n, &mut probes)? {
            lo = Some(n);
        } else {
            hi = Some(n);
        }
    }
    let (mut lo, mut hi) = (lo.expect("bracketed"), hi.expect("bracketed"));
    while hi - lo > (lo / 20).max(1) {
        let mid = lo + (hi - lo) / 2;
        if probe(mid, &mut probes)? {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok((Some(lo), false, probes))
}

pub fn run(args: BenchArgs) -> Result<bool> {
    let plan = plan(&args)?;
    let threads = init_compute_pool(args.threads);
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let rig = Rig::sloth();
    eprintln!(
        "bench: sizes {:?}, {} warm-up + {} timed frames, {threads} threads (of {cpus} cpus), budget {} ms",
        plan.sizes, plan.warmup, plan.frames, plan.budget_ms
    );
    let mut runs = Vec::new();
    for &n in &plan.sizes {
        let r = run_size(&args, &plan, &rig, n)?;
        print_run(&r);
        runs.push(r);
    }
    let (max, lower_bound, probes) = if args.no_search {
        (None, false, Vec::new())
    } else {
        eprintln!(
            "searching the largest crowd with p95 ≤ {} ms…",
            plan.budget_ms
        );
        search(&args, &plan, &rig, &runs)?
    };
    let report = Report {
        threads,
        cpus,
        budget_ms: plan.budget_ms,
        warmup: plan.warmup,
        runs,
        max_sloths_within_budget: max,
        max_is_lower_bound: lower_bound,
        search_method: "bracket by the measured sizes (halve/double when needed), then bisect with short runs to 5 %",
        search_probes: probes,
        peak_rss_mib: peak_rss_mib(),
    };
    match (max, args.no_search) {
        (_, true) => {}
        (Some(m), _) => println!(
            "max_sloths_within_budget {m}{} (p95 ≤ {} ms, {threads} threads)",
            if lower_bound { " (or more)" } else { "" },
            plan.budget_ms
        ),
        (None, _) => println!(
            "max_sloths_within_budget: none (even 1 sloth is over {} ms)",
            plan.budget_ms
        ),
    }
    if let Some(rss) = report.peak_rss_mib {
        println!("peak RSS {rss:.0} MiB");
    }
    if let Some(path) = &args.json {
        let provenance = Provenance::here(threads, Some(&plan.cfg));
        let json = serde_json::to_string_pretty(&with_provenance(&report, &provenance))?;
        write_atomically(path, json.as_bytes())
            .with_context(|| format!("cannot write {}", path.display()))?;
        println!("wrote {}", path.display());
    }
    Ok(true)
}

fn print_run(r: &RunReport) {
    let s = &r.stages_ms;
    println!(
        "{} sloths: frame ms p50 {:.2}, p95 {:.2}, max {:.2} ({:.2} µs/sloth); stage p50/p95: trace {:.2}/{:.2}, step_search {:.2}/{:.2}, body_average {:.2}/{:.2}, ccd_solve {:.2}/{:.2}, grip_load {:.2}/{:.2}, transitions {:.2}/{:.2} (grid rebuild {:.2}/{:.2}); {:.0} traces/frame, {:.2} CCD iterations/limb",
        r.sloths,
        r.frame_ms.p50,
        r.frame_ms.p95,
        r.frame_ms.max,
        r.us_per_sloth_p50,
        s.trace.p50,
        s.trace.p95,
        s.step_search.p50,
        s.step_search.p95,
        s.body_average.p50,
        s.body_average.p95,
        s.ccd_solve.p50,
        s.ccd_solve.p95,
        s.grip_load.p50,
        s.grip_load.p95,
        s.transitions.p50,
        s.transitions.p95,
        s.grid_rebuild.p50,
        s.grid_rebuild.p95,
        r.traces_per_frame,
        r.ccd_iterations_per_limb
    );
    if let Some(b) = &r.baseline {
        println!(
            "  baseline (object per sloth, 1 thread, brute-force traces; {} frames): p50 {:.2}, p95 {:.2} ms → ours is {:.1}× faster (p50), {:.1}× (p95); same state: {}",
            b.frames, b.frame_ms.p50, b.frame_ms.p95, b.ratio_p50, b.ratio_p95, b.same_state
        );
    }
}
