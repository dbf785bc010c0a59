//! `slothsim merge`: joins the parts of a sharded sweep into one output —
//! matrix parts (`matrix --shard I/N`) into the `matrix.json` an unsharded
//! run writes, or the `stats.json` files of a seed sweep (`run --seeds`)
//! into `sweep.json`. Parts from another build, config or sweep are refused,
//! naming the file.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use clap::Args;
use serde::Serialize;

use crate::cli_common::{prepare_out, write_json};
use crate::matrix_cmd::{Matrix, MatrixPart, rows_of, summarise};
use crate::provenance::{Provenance, RunProvenance, read_provenance, with_provenance};

#[derive(Args)]
pub struct MergeArgs {
    /// The parts: `matrix-part-I-of-N.json` files of one matrix, or the
    /// `stats.json` files of one `run --seeds` sweep.
    #[arg(required = true, value_name = "PART")]
    parts: Vec<PathBuf>,
    /// Output folder (matrix.json or sweep.json).
    #[arg(long)]
    out: PathBuf,
}

/// A part read back: its file, provenance and body.
struct Part {
    path: PathBuf,
    provenance: Provenance,
    value: serde_json::Value,
}

/// Refuses `part` unless the same build with the same config wrote it as `first`.
fn same_origin(first: &Part, part: &Part) -> Result<()> {
    if !first.provenance.same_program(&part.provenance) {
        bail!(
            "{} was written by {}, {} by {}: parts of different builds cannot be merged",
            part.path.display(),
            part.provenance.program_text(),
            first.path.display(),
            first.provenance.program_text()
        );
    }
    if first.provenance.config != part.provenance.config {
        bail!(
            "{} ran another locomotion config than {}: parts of different sweeps cannot be merged",
            part.path.display(),
            first.path.display()
        );
    }
    Ok(())
}

pub fn merge(args: MergeArgs) -> Result<bool> {
    let mut parts = Vec::new();
    for path in &args.parts {
        let (provenance, value) = read_provenance(path)?;
        parts.push(Part {
            path: path.clone(),
            provenance,
            value,
        });
    }
    prepare_out(&args.out)?;
    let first = &parts[0];
    for part in &parts[1..] {
        same_origin(first, part)?;
    }
    let mut provenance = first.provenance.clone();
    provenance.command_line = std::env::args().collect();
    if first.value.get("cases").is_some() {
        merge_matrix(&parts, provenance, &args.out)
    } else if first.value.get("state_hash").is_some() {
        merge_seeds(&parts, provenance, &args.out)
    } else {
        bail!(
            "{} is neither a matrix part nor a run's stats.json",
            first.path.display()
        )
    }
}

fn merge_matrix(parts: &[Part], provenance: Provenance, out: &Path) -> Result<bool> {
    let mut read = Vec::new();
    for part in parts {
        let body: MatrixPart = serde_json::from_value(part.value.clone())
            .with_context(|| format!("{} is not a matrix part", part.path.display()))?;
        read.push((part, body));
    }
    let (first, head) = &read[0];
    let [_, count] = head.shard;
    let mut seen: BTreeMap<u32, &Path> = BTreeMap::new();
    let mut cases = BTreeMap::new();
    for (part, body) in &read {
        let name = part.path.display();
        if body.step_deg != head.step_deg || body.total_cases != head.total_cases {
            bail!(
                "{name} swept at {}° ({} cases), {} at {}° ({} cases): not one matrix",
                body.step_deg,
                body.total_cases,
                first.path.display(),
                head.step_deg,
                head.total_cases
            );
        }
        let [index, n] = body.shard;
        if n != count {
            bail!(
                "{name} is shard {index} of {n}, {} of {count}: not one split",
                first.path.display()
            );
        }
        if let Some(other) = seen.insert(index, &part.path) {
            bail!(
                "shard {index}/{count} given twice: {} and {name}",
                other.display()
            );
        }
        for c in &body.cases {
            if c.case >= body.total_cases || cases.insert(c.case, c.clone()).is_some() {
                bail!("{name}: case {} is out of range or in two parts", c.case);
            }
        }
    }
    if let Some(missing) = (0..count).find(|i| !seen.contains_key(i)) {
        bail!("shard {missing}/{count} is missing (give every part)");
    }
    if cases.len() != head.total_cases {
        bail!(
            "the parts hold {} of {} cases",
            cases.len(),
            head.total_cases
        );
    }
    let rows = rows_of(cases.into_values().map(|c| (c.scenario, c.run)).collect());
    let ok = summarise(&rows);
    let matrix = Matrix {
        step_deg: head.step_deg,
        rows,
    };
    let path = write_json(out, "matrix.json", &with_provenance(&matrix, &provenance))?;
    println!("merged {} parts into {}", parts.len(), path.display());
    Ok(ok)
}

/// One seed's row of `sweep.json`.
#[derive(Serialize)]
struct SeedRow {
    seed: u64,
    file: String,
    state_hash: serde_json::Value,
    speed_mps_mean: serde_json::Value,
    stuck_sloths: serde_json::Value,
    max_grip_slip_m: serde_json::Value,
    max_surface_gap_m: serde_json::Value,
    max_penetration_m: serde_json::Value,
    nan_count: serde_json::Value,
}

/// `sweep.json`: one row per seed, sorted by seed.
#[derive(Serialize)]
struct Sweep {
    runs: Vec<SeedRow>,
}

fn merge_seeds(parts: &[Part], mut provenance: Provenance, out: &Path) -> Result<bool> {
    let run_of = |part: &Part| -> Result<RunProvenance> {
        part.provenance
            .run
            .clone()
            .with_context(|| format!("{}: field `provenance.run` is missing", part.path.display()))
    };
    let head = run_of(&parts[0])?;
    let mut rows = BTreeMap::new();
    for part in parts {
        let run = run_of(part)?;
        let same = run.sloths == head.sloths
            && run.dt == head.dt
            && run.clearance_m == head.clearance_m
            && run.frames == head.frames
            && run.forest == head.forest;
        if !same {
            bail!(
                "{} ran another crowd (sloths, time step, clearance, frames or forest) than {}: not one seed sweep",
                part.path.display(),
                parts[0].path.display()
            );
        }
        let v = &part.value;
        let row = SeedRow {
            seed: run.seed,
            file: part.path.display().to_string(),
            state_hash: v["state_hash"].clone(),
            speed_mps_mean: v["speed_mps_mean"].clone(),
            stuck_sloths: v["stuck_sloths"].clone(),
            max_grip_slip_m: v["max_grip_slip_m"].clone(),
            max_surface_gap_m: v["max_surface_gap_m"].clone(),
            max_penetration_m: v["max_penetration_m"].clone(),
            nan_count: v["nan_count"].clone(),
        };
        if let Some(other) = rows.insert(run.seed, row) {
            bail!(
                "seed {} given twice: {} and {}",
                run.seed,
                other.file,
                part.path.display()
            );
        }
    }
    if let Some(run) = provenance.run.as_mut() {
        run.seed = 0;
    }
    let sweep = Sweep {
        runs: rows.into_values().collect(),
    };
    let path = write_json(out, "sweep.json", &with_provenance(&sweep, &provenance))?;
    println!("merged {} seeds into {}", parts.len(), path.display());
    Ok(true)
}
