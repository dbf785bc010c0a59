//! End-to-end tests of `slothsim scene …` through the real binary.

use std::process::{Command, Output};

fn slothsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_slothsim"))
        .args(args)
        .output()
        .expect("run slothsim")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn export_turn_then_info_json() {
    let dir = tempfile::tempdir().unwrap();
    let glb = dir.path().join("t.glb");
    let glb_s = glb.to_str().unwrap();
    let o = slothsim(&[
        "scene", "export", "--preset", "turn", "--angle", "135", "--out", glb_s,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));

    // The gltf crate's validator accepts the file.
    let bytes = std::fs::read(&glb).unwrap();
    gltf::Gltf::from_slice(&bytes).expect("valid glTF");
    gltf::import_slice(&bytes).expect("importable glTF");

    let o = slothsim(&["scene", "info", glb_s, "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["trunks"], 0);
    assert_eq!(info["branches"], 2);
    assert_eq!(info["triangles"], 0);
    let min = info["bounds"]["min"].as_array().unwrap();
    let max = info["bounds"]["max"].as_array().unwrap();
    assert_eq!(min.len(), 3);
    assert!(max[0].as_f64().unwrap() > min[0].as_f64().unwrap());
}

#[test]
fn every_preset_and_the_forest_export() {
    let dir = tempfile::tempdir().unwrap();
    for (preset, extra) in [
        ("turn", vec!["--angle", "95"]),
        ("parallel", vec!["--param", "0.3"]),
        ("trunk", vec!["--param", "0.2"]),
        ("height_change", vec!["--angle", "200"]),
        ("branch_trunk", vec!["--angle", "130"]),
        ("pole", vec![]),
        (
            "forest",
            vec!["--trees", "4", "--area", "20", "--seed", "3"],
        ),
    ] {
        let out = dir.path().join(format!("{preset}.gltf"));
        let mut args = vec![
            "scene",
            "export",
            "--preset",
            preset,
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let o = slothsim(&args);
        assert!(o.status.success(), "{preset}: {}", stderr(&o));
        let o = slothsim(&["scene", "info", out.to_str().unwrap()]);
        assert!(o.status.success(), "{preset}: {}", stderr(&o));
    }
}

#[test]
fn default_forest_info_needs_no_files() {
    let o = slothsim(&["scene", "info", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let info: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(info["trunks"], 64);
    assert!(info["branches"].as_u64().unwrap() > 640);
    assert!(info["bvh"]["primitives"].as_u64().unwrap() > 1000);
}

#[test]
fn bad_input_is_a_clear_error_and_nonzero_exit() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.glb");
    let o = slothsim(&["scene", "info", missing.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("missing.glb"), "{}", stderr(&o));

    let junk = dir.path().join("junk.glb");
    std::fs::write(&junk, b"this is not a gltf file").unwrap();
    let o = slothsim(&["scene", "info", junk.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("junk.glb"), "{}", stderr(&o));

    let out = dir.path().join("x.glb");
    let out = out.to_str().unwrap();
    let o = slothsim(&[
        "scene", "export", "--preset", "turn", "--angle", "30", "--out", out,
    ]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("60..=180"), "{}", stderr(&o));
    assert!(!std::path::Path::new(out).exists(), "no output on error");

    let o = slothsim(&["scene", "export", "--preset", "spiral", "--out", out]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("unknown preset"), "{}", stderr(&o));

    let cfg = dir.path().join("forest.toml");
    std::fs::write(&cfg, "trees = 3\nbranchez = 4\n").unwrap();
    let o = slothsim(&["scene", "info", "--forest-config", cfg.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("branchez"), "{}", stderr(&o));

    let o = slothsim(&["scene", "info", "--trees", "0"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("trees"), "{}", stderr(&o));
}
