//! `slothsim bench`, end to end through the binary: bad input fails fast with
//! a clear message, and a tiny run writes the JSON report. Timings are never
//! asserted (targets belong in the benchmark, not in tests).

use std::process::{Command, Output};

fn slothsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_slothsim"))
        .args(args)
        .output()
        .expect("run slothsim")
}

fn fails(args: &[&str], needle: &str) {
    let mut all = vec!["bench"];
    all.extend_from_slice(args);
    let out = slothsim(&all);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        !out.status.success(),
        "{args:?} should fail; stderr:\n{err}"
    );
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?}: expected {needle:?} in:\n{err}"
    );
}

#[test]
fn bad_input_is_a_clear_error() {
    fails(&["--sloths", ""], "--sloths: the list is empty");
    fails(&["--sloths", " , "], "--sloths: the list is empty");
    fails(&["--sloths", "abc"], "\"abc\" is not a whole number");
    fails(&["--sloths", "100,x"], "\"x\" is not a whole number");
    fails(&["--sloths", "-5"], "\"-5\" is not a whole number");
    fails(&["--sloths", "0"], "at least 1");
    fails(
        &["--sloths", "10", "--frames", "0"],
        "--frames must be at least 1",
    );
    fails(
        &["--sloths", "10", "--budget-ms", "0"],
        "--budget-ms must be > 0",
    );
    fails(
        &["--sloths", "10", "--budget-ms", "-3"],
        "--budget-ms must be > 0",
    );
    fails(
        &["--sloths", "10", "--budget-ms", "NaN"],
        "--budget-ms must be > 0",
    );
    fails(
        &["--sloths", "10", "--threads", "0"],
        "--threads must be at least 1",
    );
    fails(
        &["--sloths", "10", "--json", "/nonexistent-dir/b.json"],
        "does not exist",
    );
}

#[test]
fn tiny_run_writes_the_json_report() {
    let tmp = tempfile::tempdir().unwrap();
    let json = tmp.path().join("bench.json");
    let out = slothsim(&[
        "bench",
        "--sloths",
        "6,3",
        "--trees",
        "4",
        "--frames",
        "4",
        "--warmup",
        "2",
        "--search-frames",
        "2",
        "--threads",
        "1",
        // Nothing fits: the search halves down to one sloth, quickly.
        "--budget-ms",
        "0.000001",
        "--baseline",
        "--baseline-frames",
        "4",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "stderr:\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["threads"], 1);
    assert!(v["max_sloths_within_budget"].is_null(), "{v}");
    let runs = v["runs"].as_array().unwrap();
    // Sizes sorted ascending.
    assert_eq!(runs.len(), 2);
    assert_eq!(runs[0]["sloths"], 3);
    assert_eq!(runs[1]["sloths"], 6);
    for r in runs {
        for k in ["p50", "p95", "max"] {
            assert!(r["frame_ms"][k].as_f64().unwrap() > 0.0, "{r}");
        }
        for stage in [
            "trace",
            "step_search",
            "ccd_solve",
            "body_average",
            "transitions",
        ] {
            for k in ["p50", "p95"] {
                assert!(r["stages_ms"][stage][k].as_f64().unwrap() >= 0.0, "{r}");
            }
        }
        assert!(r["traces_per_frame"].as_f64().unwrap() >= 0.0);
        // Limbs are solved every frame; a warm solve already within
        // tolerance exits before any sweep, so the mean may be below 1.
        assert!(r["ccd_iterations_per_limb"].as_f64().unwrap() > 0.0, "{r}");
        // The baseline computes the same crowd.
        let b = &r["baseline"];
        assert_eq!(b["frames"], 4);
        assert_eq!(b["same_state"], true, "{r}");
        assert!(b["ratio_p50"].as_f64().unwrap() > 0.0);
    }
    assert!(!v["search_probes"].as_array().unwrap().is_empty());
}
