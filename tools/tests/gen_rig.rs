//! `gen-rig` is deterministic and the committed asset is its output.

#[test]
fn generated_rig_matches_committed_asset_byte_for_byte() {
    let generated = slothsim_tools::rig_asset::build_sloth_glb().expect("build");
    let again = slothsim_tools::rig_asset::build_sloth_glb().expect("build");
    assert_eq!(generated, again, "generation is not deterministic");
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/sloth.glb");
    let committed = std::fs::read(path).expect("assets/sloth.glb is committed");
    assert!(
        generated == committed,
        "assets/sloth.glb is stale: run `cargo run --release -p slothsim-tools --bin gen-rig -- --out assets/sloth.glb`"
    );
}
