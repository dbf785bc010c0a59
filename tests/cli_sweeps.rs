//! Provenance, re-runs and sharded sweeps through the binary: every output
//! says where it came from; `run --from stats.json` reproduces the run's
//! `state_hash`; matrix shards merged equal the unsharded matrix; seed
//! sweeps split and merge; parts of other builds or sweeps are refused.

mod cli_common;

use cli_common::ok;
use std::path::Path;
use std::process::{Command, Output};

fn slothsim(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_slothsim"));
    cmd.args(args);
    for key in [
        "SLURM_ARRAY_TASK_ID",
        "SLURM_ARRAY_TASK_MIN",
        "SLURM_ARRAY_TASK_COUNT",
        "JOB_COMPLETION_INDEX",
    ] {
        cmd.env_remove(key);
    }
    cmd.envs(env.iter().copied());
    cmd.output().expect("run slothsim")
}

fn fails(out: &Output, needle: &str) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "expected exit 2: {err}");
    assert!(err.contains(needle), "stderr lacks `{needle}`:\n{err}");
    assert!(!err.contains("panicked"), "{err}");
}

fn json(path: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).expect("valid json")
}

fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

#[test]
fn run_from_its_stats_reproduces_the_state_hash() {
    let tmp = tempfile::tempdir().unwrap();
    let a = tmp.path().join("a");
    ok(&slothsim(
        &[
            "run",
            "--sloths",
            "30",
            "--trees",
            "4",
            "--seconds",
            "1.5",
            "--seed",
            "5",
            "--profile",
            "steady",
            "--clearance",
            "0.25",
            "--no-plots",
            "--out",
            s(&a),
        ],
        &[],
    ));
    let stats = json(&a.join("stats.json"));
    let prov = &stats["provenance"];
    assert_eq!(prov["program"], "slothsim");
    assert_eq!(prov["version"], env!("CARGO_PKG_VERSION"));
    assert!(prov["cpu_path"] == "avx2" || prov["cpu_path"] == "plain");
    assert_eq!(prov["run"]["sloths"], 30);
    assert_eq!(prov["run"]["seed"], 5);
    assert_eq!(prov["run"]["frames"], 90);
    assert!((prov["run"]["clearance_m"].as_f64().unwrap() - 0.25).abs() < 1e-6);
    // The resolved config: every value, the steady profile's.
    assert_eq!(prov["config"]["profile"], "steady");
    assert!(prov["config"].as_object().unwrap().len() > 20);
    assert!(prov["run"]["forest"]["source"]["Procedural"].is_object());
    assert!(prov["command_line"].as_array().unwrap().len() > 3);

    // --from on a thread count of its own: the same state.
    let b = tmp.path().join("b");
    let out = ok(&slothsim(
        &[
            "run",
            "--from",
            s(&a.join("stats.json")),
            "--threads",
            "1",
            "--no-plots",
            "--out",
            s(&b),
        ],
        &[],
    ));
    assert!(out.contains("reproduced state_hash"), "{out}");
    assert_eq!(
        json(&b.join("stats.json"))["state_hash"],
        stats["state_hash"]
    );

    // Another build's file is refused, naming it; so are flags beside --from.
    let mut other = stats.clone();
    other["provenance"]["version"] = "0.0.1".into();
    let other_path = tmp.path().join("other.json");
    std::fs::write(&other_path, other.to_string()).unwrap();
    let c = tmp.path().join("c");
    fails(
        &slothsim(&["run", "--from", s(&other_path), "--out", s(&c)], &[]),
        "other.json was written by slothsim 0.0.1",
    );
    fails(
        &slothsim(
            &[
                "run",
                "--from",
                s(&a.join("stats.json")),
                "--sloths",
                "3",
                "--out",
                s(&c),
            ],
            &[],
        ),
        "drop --sloths",
    );
    let mut bare = stats.clone();
    bare.as_object_mut().unwrap().remove("provenance");
    std::fs::write(&other_path, bare.to_string()).unwrap();
    fails(
        &slothsim(&["run", "--from", s(&other_path), "--out", s(&c)], &[]),
        "has no `provenance` block",
    );
    assert!(!c.join("stats.json").exists());
}

#[test]
fn matrix_shards_merge_into_the_unsharded_matrix() {
    let tmp = tempfile::tempdir().unwrap();
    let sweep = ["matrix", "--only", "turn,parallel,pole", "--step", "40"];
    let run = |extra: &[&str], env: &[(&str, &str)]| {
        let mut args = sweep.to_vec();
        args.extend_from_slice(extra);
        slothsim(&args, env)
    };
    let whole = tmp.path().join("whole");
    ok(&run(&["--out", s(&whole)], &[]));
    let (p0, p1, p2) = (
        tmp.path().join("p0"),
        tmp.path().join("p1"),
        tmp.path().join("p2"),
    );
    ok(&run(&["--shard", "0/3", "--out", s(&p0)], &[]));
    // The index from a Slurm array (1-based task ids) and a Kubernetes Indexed Job.
    ok(&run(
        &["--out", s(&p1)],
        &[
            ("SLURM_ARRAY_TASK_ID", "2"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "3"),
        ],
    ));
    ok(&run(
        &["--shards", "3", "--out", s(&p2)],
        &[("JOB_COMPLETION_INDEX", "2")],
    ));
    let parts = [
        p0.join("matrix-part-0-of-3.json"),
        p1.join("matrix-part-1-of-3.json"),
        p2.join("matrix-part-2-of-3.json"),
    ];
    let merged = tmp.path().join("merged");
    ok(&slothsim(
        &[
            "merge",
            s(&parts[2]),
            s(&parts[0]),
            s(&parts[1]),
            "--out",
            s(&merged),
        ],
        &[],
    ));
    let a = json(&whole.join("matrix.json"));
    let b = json(&merged.join("matrix.json"));
    // Byte for byte, but for the provenance's command line (and threads).
    let body = |v: &serde_json::Value| {
        let mut v = v.clone();
        v.as_object_mut().unwrap().remove("provenance");
        serde_json::to_string_pretty(&v).unwrap()
    };
    assert_eq!(body(&a), body(&b));
    assert_eq!(a["rows"].as_array().unwrap().len(), 3);
    assert_eq!(a["provenance"]["config"], b["provenance"]["config"]);

    // Bad shards and bad merges.
    let bad = tmp.path().join("bad");
    fails(
        &run(&["--shard", "3/3", "--out", s(&bad)], &[]),
        "not below the shard count 3",
    );
    fails(
        &run(&["--shard", "0/0", "--out", s(&bad)], &[]),
        "at least 1",
    );
    fails(
        &slothsim(
            &["merge", s(&parts[0]), s(&parts[1]), "--out", s(&bad)],
            &[],
        ),
        "shard 2/3 is missing",
    );
    fails(
        &slothsim(
            &[
                "merge",
                s(&parts[0]),
                s(&parts[0]),
                s(&parts[1]),
                "--out",
                s(&bad),
            ],
            &[],
        ),
        "given twice",
    );
    // Part 1 of another build, then of another config, in place of the real one.
    let other_path = tmp.path().join("other-part.json");
    let merge_with_other = |field: &[&str], value: serde_json::Value, needle: &str| {
        let mut other = json(&parts[1]);
        let mut at = &mut other["provenance"];
        for key in field {
            at = &mut at[*key];
        }
        *at = value;
        std::fs::write(&other_path, other.to_string()).unwrap();
        let args = [
            "merge",
            s(&parts[0]),
            s(&other_path),
            s(&parts[2]),
            "--out",
            s(&bad),
        ];
        fails(&slothsim(&args, &[]), needle);
    };
    merge_with_other(
        &["version"],
        "9.9.9".into(),
        "other-part.json was written by slothsim 9.9.9",
    );
    merge_with_other(
        &["config", "max_step_m"],
        0.2.into(),
        "other-part.json ran another locomotion config",
    );
    assert!(!bad.join("matrix.json").exists());
}

#[test]
fn seed_sweeps_split_by_shard_and_merge() {
    let tmp = tempfile::tempdir().unwrap();
    let crowd = [
        "run",
        "--sloths",
        "12",
        "--trees",
        "2",
        "--seconds",
        "0.5",
        "--no-plots",
        "--seeds",
        "3..5",
    ];
    let (a, b) = (tmp.path().join("a"), tmp.path().join("b"));
    let run = |dir: &Path, shard: &str| {
        let mut args = crowd.to_vec();
        args.extend_from_slice(&["--shard", shard, "--out", s(dir)]);
        ok(&slothsim(&args, &[]));
    };
    run(&a, "0/2");
    run(&b, "1/2");
    assert!(a.join("seed-3/stats.json").exists() && a.join("seed-5/stats.json").exists());
    assert!(b.join("seed-4/stats.json").exists() && !b.join("seed-3").exists());
    let merged = tmp.path().join("merged");
    ok(&slothsim(
        &[
            "merge",
            s(&a.join("seed-5/stats.json")),
            s(&b.join("seed-4/stats.json")),
            s(&a.join("seed-3/stats.json")),
            "--out",
            s(&merged),
        ],
        &[],
    ));
    let sweep = json(&merged.join("sweep.json"));
    let seeds: Vec<u64> = sweep["runs"]
        .as_array()
        .unwrap()
        .iter()
        .map(|r| r["seed"].as_u64().unwrap())
        .collect();
    assert_eq!(seeds, [3, 4, 5]);
    let four = json(&b.join("seed-4/stats.json"));
    assert_eq!(sweep["runs"][1]["state_hash"], four["state_hash"]);
    fails(
        &slothsim(&["run", "--seeds", "5..3", "--out", s(&merged)], &[]),
        "below the first",
    );
    fails(
        &slothsim(&["run", "--shard", "0/2", "--out", s(&merged)], &[]),
        "give --seeds",
    );
}
