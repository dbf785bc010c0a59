//! `slothsim run`, end to end through the binary: determinism across thread
//! counts (the compute pool is process-wide, so each count is its own
//! process), checkpoint/resume equality, crowd judge measures, bad input.

mod cli_common;

use cli_common::{ok, slothsim};
use std::path::Path;

fn stats(dir: &Path) -> serde_json::Value {
    let text = std::fs::read_to_string(dir.join("stats.json")).expect("stats.json");
    serde_json::from_str(&text).expect("valid json")
}

/// A small crowd on a small forest: 60 sloths on 6 trees.
const CROWD: [&str; 6] = ["--sloths", "60", "--trees", "6", "--no-plots", "--seed"];

fn run_crowd(dir: &Path, seed: &str, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["run"];
    args.extend_from_slice(&CROWD);
    args.push(seed);
    args.extend_from_slice(&["--out", dir.to_str().unwrap()]);
    args.extend_from_slice(extra);
    let out = slothsim(&args);
    ok(&out);
    stats(dir)
}

#[test]
fn same_seed_same_state_for_1_and_2_threads_and_repeats() {
    let tmp = tempfile::tempdir().unwrap();
    let a = run_crowd(
        &tmp.path().join("a"),
        "7",
        &["--seconds", "4", "--threads", "1"],
    );
    let b = run_crowd(
        &tmp.path().join("b"),
        "7",
        &["--seconds", "4", "--threads", "2"],
    );
    let c = run_crowd(
        &tmp.path().join("c"),
        "7",
        &["--seconds", "4", "--threads", "2"],
    );
    let d = run_crowd(
        &tmp.path().join("d"),
        "8",
        &["--seconds", "4", "--threads", "2"],
    );
    assert_eq!(a["threads"], 1);
    assert_eq!(b["threads"], 2);
    assert_eq!(a["state_hash"], b["state_hash"]);
    assert_eq!(b["state_hash"], c["state_hash"]);
    assert_ne!(a["state_hash"], d["state_hash"], "the seed must matter");
    // The crowd moved and stayed sound.
    assert_eq!(a["sloths"], 60);
    assert_eq!(a["frames"], 240);
    assert!(a["speed_mps_mean"].as_f64().unwrap() > 0.02, "{a}");
    assert_eq!(a["nan_count"], 0);
    assert_eq!(a["joint_limit_violations"], 0);
    assert!(a["min_limbs_in_contact"].as_u64().unwrap() >= 2);
    // Roaming: every sloth planted on at least the support it started on.
    let r = &a["roaming"];
    let visited = r["supports_visited"].as_u64().unwrap();
    assert!(
        visited >= 30 && visited <= r["supports"].as_u64().unwrap(),
        "{r}"
    );
    assert!(r["supports_per_sloth_mean"].as_f64().unwrap() >= 1.0, "{r}");
    assert_eq!(a["roaming"], b["roaming"], "roaming is deterministic too");
    // timings.csv: header + one row a frame.
    let csv = std::fs::read_to_string(tmp.path().join("a/timings.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("frame,trace,step_search,body_average,ccd_solve,grip_load,transitions,total")
    );
    assert_eq!(lines.count(), 240);
}

#[test]
fn checkpoint_then_resume_equals_one_run() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state.bin");
    let whole = run_crowd(&tmp.path().join("whole"), "3", &["--seconds", "6"]);
    run_crowd(
        &tmp.path().join("first"),
        "3",
        &["--seconds", "3", "--save-state", state.to_str().unwrap()],
    );
    assert!(state.exists());
    let out = slothsim(&[
        "run",
        "--load-state",
        state.to_str().unwrap(),
        "--seconds",
        "3",
        "--no-plots",
        "--out",
        tmp.path().join("resumed").to_str().unwrap(),
    ]);
    ok(&out);
    let resumed = stats(&tmp.path().join("resumed"));
    assert_eq!(resumed["state_hash"], whole["state_hash"]);
    assert_eq!(resumed["sloths"], 60);
}

fn fails_without_output(args: &[&str], dir: &Path, needle: &str) {
    let out = slothsim(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "expected failure for {args:?}");
    assert!(
        err.contains(needle),
        "{args:?}: stderr lacks `{needle}`:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        !dir.join("stats.json").exists(),
        "partial output for {args:?}"
    );
}

#[test]
fn bad_input_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = out.to_str().unwrap();
    fails_without_output(&["run", "--sloths", "0", "--out", o], &out, "--sloths");
    fails_without_output(
        &["run", "--sloths", "5000", "--trees", "2", "--out", o],
        &out,
        "cannot hold 5000 sloths",
    );
    fails_without_output(
        &["run", "--config", "/no/such/config.toml", "--out", o],
        &out,
        "/no/such/config.toml",
    );
    fails_without_output(
        &["run", "--forest", "/no/such/forest.glb", "--out", o],
        &out,
        "/no/such/forest.glb",
    );
    let bad = tmp.path().join("bad.toml");
    std::fs::write(&bad, "max_step_m = 0.2\nwings = 2\n").unwrap();
    fails_without_output(
        &["run", "--config", bad.to_str().unwrap(), "--out", o],
        &out,
        "wings",
    );
    // Checkpoints: not one, corrupt, another version.
    let junk = tmp.path().join("junk.bin");
    std::fs::write(&junk, b"hello").unwrap();
    fails_without_output(
        &["run", "--load-state", junk.to_str().unwrap(), "--out", o],
        &out,
        "not a slothsim state file",
    );
    let state = tmp.path().join("state.bin");
    let saved = tmp.path().join("saved");
    ok(&slothsim(&[
        "run",
        "--sloths",
        "5",
        "--trees",
        "2",
        "--seconds",
        "0.5",
        "--no-plots",
        "--out",
        saved.to_str().unwrap(),
        "--save-state",
        state.to_str().unwrap(),
    ]));
    let mut bytes = std::fs::read(&state).unwrap();
    let n = bytes.len();
    bytes[n / 2] ^= 0x5a;
    let corrupt = tmp.path().join("corrupt.bin");
    std::fs::write(&corrupt, &bytes).unwrap();
    fails_without_output(
        &["run", "--load-state", corrupt.to_str().unwrap(), "--out", o],
        &out,
        "corrupt",
    );
    let mut bytes = std::fs::read(&state).unwrap();
    bytes.truncate(n - 100);
    std::fs::write(&corrupt, &bytes).unwrap();
    fails_without_output(
        &["run", "--load-state", corrupt.to_str().unwrap(), "--out", o],
        &out,
        "corrupt",
    );
    let mut bytes = std::fs::read(&state).unwrap();
    bytes[16] = 99;
    let other = tmp.path().join("other.bin");
    std::fs::write(&other, &bytes).unwrap();
    fails_without_output(
        &["run", "--load-state", other.to_str().unwrap(), "--out", o],
        &out,
        "version 99",
    );
    fails_without_output(
        &[
            "run",
            "--load-state",
            state.to_str().unwrap(),
            "--sloths",
            "9",
            "--out",
            o,
        ],
        &out,
        "--load-state takes",
    );
    // An unwritable output folder fails before the run.
    let file = tmp.path().join("a-file");
    std::fs::write(&file, b"").unwrap();
    let under = file.join("out");
    fails_without_output(
        &[
            "run",
            "--sloths",
            "5",
            "--trees",
            "2",
            "--out",
            under.to_str().unwrap(),
        ],
        &under,
        "output folder",
    );
}
