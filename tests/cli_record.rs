//! `--record` / `--record-hz` on `slothsim run` and `scenario`: outputs,
//! the state untouched, and bad input.

mod cli_common;

use cli_common::{ok, slothsim};
use std::path::Path;

fn run(dir: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec![
        "run",
        "--sloths",
        "30",
        "--trees",
        "4",
        "--seconds",
        "2",
        "--no-plots",
        "--out",
        dir.to_str().unwrap(),
    ];
    args.extend_from_slice(extra);
    ok(&slothsim(&args));
    serde_json::from_slice(&std::fs::read(dir.join("stats.json")).unwrap()).unwrap()
}

#[test]
fn recording_reads_the_state_and_never_changes_it() {
    let tmp = tempfile::tempdir().unwrap();
    let none = run(&tmp.path().join("none"), &["--record", "none"]);
    let some = run(&tmp.path().join("some"), &["--record", "5"]);
    let all = run(
        &tmp.path().join("all"),
        &["--record", "all", "--record-hz", "60"],
    );
    assert_eq!(none["state_hash"], some["state_hash"]);
    assert_eq!(none["state_hash"], all["state_hash"]);
    assert!(!tmp.path().join("none/crowd.glb").exists());
    assert!(none.get("record").is_none());
    let r = &some["record"];
    assert_eq!(r["sloths"], 5);
    assert_eq!(r["samples"], 61, "30 Hz over 2 s, both ends");
    assert!(r["record_ms"].as_f64().unwrap() > 0.0);
    assert_eq!(all["record"]["sloths"], 30);
    assert_eq!(all["record"]["samples"], 121);
    let csv = std::fs::read_to_string(tmp.path().join("some/trajectories.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], slothsim::export::CSV_HEADER);
    assert_eq!(lines.len(), 1 + 5 * 61);
    let glb = std::fs::read(tmp.path().join("some/crowd.glb")).unwrap();
    let (doc, _, _) = gltf::import_slice(&glb).expect("crowd.glb loads");
    assert_eq!(doc.skins().count(), 5);
    assert_eq!(doc.animations().count(), 1);
    // No temporary files left.
    for e in std::fs::read_dir(tmp.path().join("some")).unwrap() {
        let name = e.unwrap().file_name();
        assert!(!name.to_string_lossy().starts_with('.'), "{name:?} left");
    }
}

#[test]
fn explicit_ids_are_recorded() {
    let tmp = tempfile::tempdir().unwrap();
    let s = run(tmp.path(), &["--record", "3,17,", "--record-hz", "10"]);
    assert_eq!(s["record"]["sloths"], 2);
    assert_eq!(s["record"]["samples"], 21);
    let csv = std::fs::read_to_string(tmp.path().join("trajectories.csv")).unwrap();
    let ids: std::collections::BTreeSet<&str> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap())
        .collect();
    assert_eq!(ids.into_iter().collect::<Vec<_>>(), ["17", "3"]);
}

#[test]
fn the_default_rate_follows_a_slower_tick() {
    let tmp = tempfile::tempdir().unwrap();
    let s = run(tmp.path(), &["--dt", "0.05", "--record", "2"]);
    assert!((s["record"]["hz"].as_f64().unwrap() - 20.0).abs() < 1e-4);
    assert_eq!(s["record"]["samples"], 41);
}

fn fails(args: &[&str], needle: &str) {
    let out = slothsim(args);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?}: stderr lacks `{needle}`:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn bad_record_input_is_a_clear_error() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let o = out.to_str().unwrap();
    let base = [
        "run",
        "--sloths",
        "20",
        "--trees",
        "4",
        "--seconds",
        "1",
        "--no-plots",
        "--out",
        o,
    ];
    let with = |extra: &[&str]| -> Vec<String> {
        base.iter().chain(extra).map(|s| s.to_string()).collect()
    };
    for (extra, needle) in [
        (&["--record", "5,99"][..], "sloth 99 does not exist"),
        (&["--record", "abc"][..], "is not a sloth id"),
        (
            &["--record-hz", "0"][..],
            "--record-hz must be a positive rate",
        ),
        (
            &["--record-hz", "-3"][..],
            "--record-hz must be a positive rate",
        ),
        (
            &["--record-hz", "NaN"][..],
            "--record-hz must be a positive rate",
        ),
        (&["--record-hz", "61"][..], "above the tick rate"),
    ] {
        let args = with(extra);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        fails(&args, needle);
        assert!(!out.join("crowd.glb").exists(), "{extra:?}");
        assert!(!out.join("trajectories.csv").exists(), "{extra:?}");
    }
    fails(
        &["scenario", "pole", "--out", o, "--record", "1,"],
        "sloth 1 does not exist",
    );
    fails(&["scenario", "pole", "--record", "all"], "give --out DIR");
    fails(
        &["export", "--state", "/no/such/state.bin", "--out", o],
        "expected a .glb file",
    );
}

#[test]
fn scenario_records_its_sloth_and_export_writes_a_checkpoint() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("sc");
    let d = dir.to_str().unwrap();
    let out = slothsim(&[
        "scenario",
        "pole",
        "--seconds",
        "3",
        "--no-plots",
        "--out",
        d,
    ]);
    assert!(out.status.code().is_some_and(|c| c <= 1), "{out:?}");
    let glb = std::fs::read(dir.join("crowd.glb")).unwrap();
    let (doc, _, _) = gltf::import_slice(&glb).unwrap();
    assert_eq!(doc.skins().count(), 1);
    // 2 root + 16 limb joints + the mesh node's morph `weights` (default --skinning clusters).
    let anim = doc.animations().next().unwrap();
    assert_eq!(anim.channels().count(), 19);
    let weights = anim
        .channels()
        .filter(|c| c.target().property() == gltf::animation::Property::MorphTargetWeights)
        .count();
    assert_eq!(weights, 1);

    let state = tmp.path().join("state.bin");
    let run_dir = tmp.path().join("run");
    ok(&slothsim(&[
        "run",
        "--sloths",
        "20",
        "--trees",
        "4",
        "--seconds",
        "1",
        "--no-plots",
        "--record",
        "none",
        "--out",
        run_dir.to_str().unwrap(),
        "--save-state",
        state.to_str().unwrap(),
    ]));
    let still = tmp.path().join("still.glb");
    ok(&slothsim(&[
        "export",
        "--state",
        state.to_str().unwrap(),
        "--out",
        still.to_str().unwrap(),
    ]));
    let (doc, _, _) = gltf::import_slice(std::fs::read(&still).unwrap()).unwrap();
    assert_eq!(doc.skins().count(), 20);
    assert_eq!(doc.animations().count(), 0, "a still pose");
    // Each sloth's mesh node holds its morph weights for that pose.
    let weighted = doc
        .nodes()
        .filter(|n| n.skin().is_some() && n.weights().is_some_and(|w| w.len() == 28))
        .count();
    assert_eq!(weighted, 20);
}
