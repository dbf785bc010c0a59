//! Generated tree meshes through the binary: spawn capacity of one tree,
//! a short crowd run judged on the real surface, and `scene info`'s
//! per-mesh and per-instance counts.

mod cli_common;

use cli_common::{ok, slothsim};
use std::path::{Path, PathBuf};

use slothsim::scene::treegen::{TreeParams, generate_forest_glb};

fn temp_dir(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("cli_trees_{test}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `trees` default 7 m generated trees (plus `instances` copies of the first).
fn forest(dir: &Path, trees: u32, instances: u32) -> PathBuf {
    let (glb, _) = generate_forest_glb(&TreeParams::default(), trees, instances, 6.0, 1);
    let path = dir.join("trees.glb");
    std::fs::write(&path, glb).unwrap();
    path
}

#[test]
fn one_seven_metre_tree_holds_twelve_sloths_gripping_its_surface() {
    let dir = temp_dir("capacity");
    let file = forest(&dir, 1, 0);
    let out_dir = dir.join("run");
    let out = slothsim(&[
        "run",
        "--forest",
        file.to_str().unwrap(),
        "--sloths",
        "12",
        "--seconds",
        "3",
        "--no-plots",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    ok(&out);
    let text = std::fs::read_to_string(out_dir.join("stats.json")).unwrap();
    let stats: serde_json::Value = serde_json::from_str(&text).unwrap();
    let gap = stats["max_surface_gap_m"].as_f64().unwrap();
    let slip = stats["max_grip_slip_m"].as_f64().unwrap();
    assert!(gap <= 0.01, "surface gap {gap} m");
    assert!(slip <= 0.005, "grip slip {slip} m");
    assert_eq!(stats["nan_count"].as_u64(), Some(0));
}

#[test]
fn scene_info_counts_meshes_once_and_instances_per_node() {
    let dir = temp_dir("info");
    let file = forest(&dir, 1, 2);
    let out = slothsim(&["scene", "info", file.to_str().unwrap(), "--json"]);
    ok(&out);
    let info: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let import = &info["import"];
    assert_eq!(import["meshes"].as_array().unwrap().len(), 1);
    assert_eq!(import["meshes"][0]["instances"].as_u64(), Some(3));
    let inst = import["instances"].as_array().unwrap();
    assert_eq!(inst.len(), 3);
    let supports = inst[0]["supports"].as_u64().unwrap();
    assert!(supports > 10, "{supports}");
    assert!(
        inst.iter()
            .all(|i| i["supports"].as_u64() == Some(supports))
    );
    assert!(info["import_ms"].as_f64().unwrap() > 0.0);
    // Text mode prints the same lines.
    let out = slothsim(&["scene", "info", file.to_str().unwrap()]);
    ok(&out);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("3 instance(s)") && text.contains("grippable"),
        "{text}"
    );
}
