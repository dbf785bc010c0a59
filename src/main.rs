//! The `slothsim` command line.

mod bench_cmd;
mod cli_common;
mod matrix_cmd;
mod merge_cmd;
mod plots;
mod provenance;
mod run_cmd;
mod scenario_cmd;
mod scene_cmd;

use std::process::ExitCode;

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};

/// Crowds of procedurally animated two-toed sloths climbing a forest.
#[derive(Parser)]
#[command(name = "slothsim", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Forests and scenario scenes: export to glTF, describe.
    #[command(subcommand)]
    Scene(scene_cmd::SceneCommand),
    /// Run one sloth on a thesis scenario preset and judge it (exit 0 pass, 1 fail).
    Scenario(scenario_cmd::ScenarioArgs),
    /// The main job: a crowd of wandering sloths on a forest (stats.json, timings.csv).
    Run(run_cmd::RunArgs),
    /// Frame and stage times of the crowd at several sizes, the largest crowd within a frame budget, and a naive baseline.
    Bench(bench_cmd::BenchArgs),
    /// Sweep every preset over its angle range (thesis Table 7); exit 0 when the thesis ranges pass.
    Matrix(matrix_cmd::MatrixArgs),
    /// Join the parts of a sharded sweep (`matrix --shard`, `run --seeds --shard`) into one output.
    Merge(merge_cmd::MergeArgs),
    /// Re-draw the top-down plot (topdown.png) from a saved state.
    Plot(plots::PlotArgs),
    /// CI: check that PNG plots exist and are not blank (exit 1 otherwise).
    #[command(hide = true)]
    PlotCheck(plots::PlotCheckArgs),
}

fn main() -> ExitCode {
    // Output piped into a reader that stops early (`| head`) ends the
    // process quietly, as other command-line tools do, instead of a panic
    // in `println!`. Files are written under a temporary name and renamed,
    // so an interrupted run leaves no output that looks complete.
    #[cfg(unix)]
    // SAFETY: restoring the default disposition of SIGPIPE before any
    // thread starts; no handler is installed.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Parsed through `ArgMatches` so commands can tell a flag given on the
    // command line from its default (`ArgMatches::value_source`).
    let matches = Cli::command().get_matches();
    let cli = match Cli::from_arg_matches(&matches) {
        Ok(cli) => cli,
        Err(err) => err.exit(),
    };
    let sub = |name: &str| {
        matches
            .subcommand_matches(name)
            .cloned()
            .unwrap_or_default()
    };
    let result = match cli.command {
        Command::Scene(cmd) => scene_cmd::run(cmd).map(|()| true),
        Command::Scenario(args) => scenario_cmd::scenario(args),
        Command::Matrix(args) => matrix_cmd::matrix(args),
        Command::Merge(args) => merge_cmd::merge(args),
        Command::Run(args) => run_cmd::run(args, &sub("run")),
        Command::Bench(args) => bench_cmd::run(args),
        Command::Plot(args) => plots::plot(args),
        Command::PlotCheck(args) => plots::plot_check(args),
    };
    match result {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::from(1),
        Err(err) => {
            eprintln!("error: {}", error_chain(&err));
            ExitCode::from(2)
        }
    }
}

/// `outer: cause: cause`, skipping causes whose text the message already holds.
fn error_chain(err: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in err.chain() {
        let text = cause.to_string();
        if !out.contains(&text) {
            if !out.is_empty() {
                out.push_str(": ");
            }
            out.push_str(&text);
        }
    }
    out
}
