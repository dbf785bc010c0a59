//! The debug plots, end to end through the binary: `run`, `scenario` and
//! `plot --state` write non-trivial PNGs (decoded here: size, colours, sloth
//! pixels where the sloths are), `--no-plots` writes none, bad input is a
//! clear error, and the CI checker tells blank plots from real ones.

use std::collections::HashSet;
use std::path::Path;
use std::process::{Command, Output};

use slothsim::rig::Rig;
use slothsim::scene::generate_forest;
use slothsim::sim::snapshot::crowd_poses;
use slothsim::sim::{Crowd, ForestSource};
use slothsim_plot::{Rgba, TopDown, colors, topdown_projection};
use tiny_skia::Pixmap;

fn slothsim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_slothsim"))
        .args(args)
        .output()
        .expect("run slothsim")
}

fn code(out: &Output, want: i32) {
    assert_eq!(
        out.status.code(),
        Some(want),
        "stdout:\n{}\nstderr:\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn load(path: &Path) -> Pixmap {
    Pixmap::load_png(path).unwrap_or_else(|e| panic!("decode {}: {e}", path.display()))
}

fn colours(pm: &Pixmap) -> usize {
    pm.pixels()
        .iter()
        .map(|p| u32::from_le_bytes([p.red(), p.green(), p.blue(), p.alpha()]))
        .collect::<HashSet<_>>()
        .len()
}

fn near(p: tiny_skia::PremultipliedColorU8, c: Rgba, tol: i32) -> bool {
    (p.red() as i32 - c.0 as i32).abs() <= tol
        && (p.green() as i32 - c.1 as i32).abs() <= tol
        && (p.blue() as i32 - c.2 as i32).abs() <= tol
}

/// Pixels within `tol` of colour `c` (opaque plots: premultiplied = straight).
fn count(pm: &Pixmap, c: Rgba, tol: i32) -> usize {
    pm.pixels().iter().filter(|&&p| near(p, c, tol)).count()
}

/// Whether a pixel of colour `c` lies within `r` px of `(x, y)`.
fn colour_near(pm: &Pixmap, (x, y): (f32, f32), c: Rgba, r: i32) -> bool {
    let (cx, cy) = (x.round() as i32, y.round() as i32);
    (-r..=r).any(|dy| {
        (-r..=r).any(|dx| {
            pm.pixel((cx + dx) as u32, (cy + dy) as u32)
                .is_some_and(|p| near(p, c, 12))
        })
    })
}

/// A written plot: expected size and several distinct colours.
fn plot(dir: &Path, name: &str, size: (u32, u32)) -> Pixmap {
    let pm = load(&dir.join(name));
    assert_eq!((pm.width(), pm.height()), size, "{name} size");
    let n = colours(&pm);
    assert!(n >= 10, "{name}: only {n} distinct colours");
    pm
}

fn state_hash(dir: &Path) -> String {
    let text = std::fs::read_to_string(dir.join("stats.json")).expect("stats.json");
    let v: serde_json::Value = serde_json::from_str(&text).expect("json");
    v["state_hash"].as_str().expect("state_hash").to_string()
}

fn pngs(dir: &Path) -> Vec<String> {
    std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .filter(|n| n.ends_with(".png"))
                .collect()
        })
        .unwrap_or_default()
}

/// Every sloth of a checkpoint has body-coloured pixels where the top-down
/// projection puts it.
fn sloths_where_they_are(pm: &Pixmap, state: &Path) {
    let info = Crowd::checkpoint_info(state).unwrap();
    let ForestSource::Procedural(fc) = &info.forest else {
        panic!("procedural forest expected");
    };
    let scene = generate_forest(fc).unwrap();
    let crowd = Crowd::load_state(state, &Rig::sloth(), scene.clone()).unwrap();
    let sloths = slothsim::to_plot::sloth_poses(&crowd_poses(&crowd));
    assert_eq!(sloths.len() as u32, info.sloths);
    let mut td = TopDown::new(&scene);
    td.sloths = &sloths;
    let proj = topdown_projection(&td);
    let found = sloths
        .iter()
        .filter(|s| colour_near(pm, proj.to_px(s.body_pos), colors::SLOTH_BODY, 8))
        .count();
    // Bodies hang below their branches and are drawn under them when zoomed
    // in; nearly all must still show.
    assert!(
        found * 10 >= sloths.len() * 9,
        "sloth pixels at only {found} of {} sloths",
        sloths.len()
    );
}

#[test]
fn run_writes_plots_and_plot_redraws_the_checkpoint() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("run");
    let state = tmp.path().join("state.bin");
    let o = slothsim(&[
        "run",
        "--sloths",
        "20",
        "--trees",
        "2",
        "--seconds",
        "2",
        "--out",
        out.to_str().unwrap(),
        "--save-state",
        state.to_str().unwrap(),
    ]);
    code(&o, 0);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("topdown.png") && stdout.contains(" ms"),
        "{stdout}"
    );

    let top = plot(&out, "topdown.png", (1600, 1700));
    sloths_where_they_are(&top, &state);
    assert!(count(&top, colors::FOCUS, 10) > 50, "focus ring");
    let gait = plot(&out, "gait.png", (1400, 420));
    assert!(
        count(&gait, colors::GAIT_FORE, 4) > 500,
        "fore limb contacts"
    );
    assert!(
        count(&gait, colors::GAIT_HIND, 4) > 500,
        "hind limb contacts"
    );
    let ft = plot(&out, "frame_times.png", (1400, 700));
    assert!(count(&ft, colors::BUDGET_BAND, 4) > 1000, "budget band");

    // Sampling for the plots does not change the simulation.
    let plain = tmp.path().join("plain");
    code(
        &slothsim(&[
            "run",
            "--sloths",
            "20",
            "--trees",
            "2",
            "--seconds",
            "2",
            "--no-plots",
            "--out",
            plain.to_str().unwrap(),
        ]),
        0,
    );
    assert_eq!(state_hash(&out), state_hash(&plain));

    // The same state, re-drawn without simulating.
    let again = tmp.path().join("plot");
    let o = slothsim(&[
        "plot",
        "--state",
        state.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    code(&o, 0);
    assert_eq!(pngs(&again), vec!["topdown.png".to_string()]);
    let top2 = plot(&again, "topdown.png", (1600, 1700));
    sloths_where_they_are(&top2, &state);

    // The CI checker accepts all of them.
    let files: Vec<String> = ["topdown.png", "gait.png", "frame_times.png"]
        .iter()
        .map(|n| out.join(n).to_string_lossy().into_owned())
        .collect();
    let mut args = vec!["plot-check"];
    args.extend(files.iter().map(|s| s.as_str()));
    code(&slothsim(&args), 0);
}

#[test]
fn scenario_writes_four_plots() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let o = slothsim(&[
        "scenario",
        "pole",
        "--seconds",
        "5",
        "--out",
        dir.to_str().unwrap(),
    ]);
    // 5 s is too short to reach the goal: judged a fail (1), not an error.
    assert!(matches!(o.status.code(), Some(0 | 1)), "{o:?}");
    assert!(dir.join("scenario.json").exists());
    let top = plot(dir, "topdown.png", (1600, 1700));
    assert!(count(&top, colors::SLOTH_BODY, 12) > 200, "sloth body");
    let side = plot(dir, "side.png", (1400, 1000));
    assert!(count(&side, colors::LEFT_LIMB, 12) > 50, "left limbs");
    assert!(count(&side, colors::RIGHT_LIMB, 12) > 50, "right limbs");
    // The cluster-skinned mesh under the skeleton (the newest instant: half-opaque fur).
    let fur = colors::SLOTH_FUR.with_alpha(127).over(colors::PANEL);
    assert!(count(&side, fur, 12) > 300, "skinned silhouette");
    let gait = plot(dir, "gait.png", (1400, 420));
    assert!(
        count(&gait, colors::GAIT_FORE, 4) > 500,
        "fore limb contacts"
    );
    plot(dir, "frame_times.png", (1400, 700));
}

#[test]
fn no_plots_writes_no_png() {
    let tmp = tempfile::tempdir().unwrap();
    let run = tmp.path().join("run");
    code(
        &slothsim(&[
            "run",
            "--sloths",
            "5",
            "--trees",
            "2",
            "--seconds",
            "0.5",
            "--no-plots",
            "--out",
            run.to_str().unwrap(),
        ]),
        0,
    );
    assert!(run.join("stats.json").exists());
    assert!(pngs(&run).is_empty(), "{:?}", pngs(&run));
    let sc = tmp.path().join("scenario");
    let o = slothsim(&[
        "scenario",
        "pole",
        "--seconds",
        "1",
        "--no-plots",
        "--out",
        sc.to_str().unwrap(),
    ]);
    assert!(matches!(o.status.code(), Some(0 | 1)), "{o:?}");
    assert!(sc.join("scenario.json").exists());
    assert!(pngs(&sc).is_empty(), "{:?}", pngs(&sc));
}

fn fails(args: &[&str], needle: &str) {
    let o = slothsim(args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    assert!(
        err.contains(needle),
        "{args:?}: stderr lacks `{needle}`:\n{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn plot_rejects_bad_input() {
    let tmp = tempfile::tempdir().unwrap();
    let state = tmp.path().join("state.bin");
    code(
        &slothsim(&[
            "run",
            "--sloths",
            "5",
            "--trees",
            "2",
            "--seconds",
            "0.5",
            "--no-plots",
            "--out",
            tmp.path().join("run").to_str().unwrap(),
            "--save-state",
            state.to_str().unwrap(),
        ]),
        0,
    );
    let out = tmp.path().join("out");
    let o = out.to_str().unwrap();
    let s = state.to_str().unwrap();
    // A state file from another format version.
    let mut bytes = std::fs::read(&state).unwrap();
    bytes[16..20].copy_from_slice(&99u32.to_le_bytes());
    let other = tmp.path().join("other.bin");
    std::fs::write(&other, &bytes).unwrap();
    fails(
        &["plot", "--state", other.to_str().unwrap(), "--out", o],
        "format version 99",
    );
    // Not a state file at all; a missing one.
    let junk = tmp.path().join("junk.bin");
    std::fs::write(&junk, b"hello").unwrap();
    fails(
        &["plot", "--state", junk.to_str().unwrap(), "--out", o],
        "not a slothsim state file",
    );
    fails(
        &["plot", "--state", "/no/such/state.bin", "--out", o],
        "/no/such/state.bin",
    );
    assert!(pngs(&out).is_empty());
    // An output folder that cannot be created (a file is in the way).
    let file = tmp.path().join("file");
    std::fs::write(&file, b"x").unwrap();
    let blocked = file.join("plots");
    fails(
        &["plot", "--state", s, "--out", blocked.to_str().unwrap()],
        "cannot create output folder",
    );
    // A focus sloth the state does not have.
    fails(
        &["plot", "--state", s, "--focus", "99", "--out", o],
        "--focus 99",
    );
    // Run and scenario refuse an unusable output folder before simulating.
    fails(
        &[
            "scenario",
            "pole",
            "--seconds",
            "1",
            "--out",
            blocked.to_str().unwrap(),
        ],
        "cannot create output folder",
    );
}

#[test]
fn plot_check_tells_blank_and_missing_from_real_plots() {
    let tmp = tempfile::tempdir().unwrap();
    let blank = tmp.path().join("blank.png");
    let mut pm = Pixmap::new(200, 100).unwrap();
    pm.fill(tiny_skia::Color::WHITE);
    pm.save_png(&blank).unwrap();
    let o = slothsim(&["plot-check", blank.to_str().unwrap()]);
    code(&o, 1);
    assert!(String::from_utf8_lossy(&o.stdout).contains("BLANK"));
    let missing = tmp.path().join("missing.png");
    let o = slothsim(&["plot-check", missing.to_str().unwrap()]);
    code(&o, 1);
    assert!(String::from_utf8_lossy(&o.stdout).contains("MISSING"));
    // A picture with some content passes.
    let real = tmp.path().join("real.png");
    let mut pm = Pixmap::new(200, 100).unwrap();
    pm.fill(tiny_skia::Color::WHITE);
    for i in 0..40u32 {
        let mut paint = tiny_skia::Paint::default();
        paint.set_color_rgba8((i * 6) as u8, 100, 200 - i as u8, 255);
        let r = tiny_skia::Rect::from_xywh(i as f32 * 5.0, 10.0, 5.0, 80.0).unwrap();
        pm.fill_rect(r, &paint, tiny_skia::Transform::identity(), None);
    }
    pm.save_png(&real).unwrap();
    code(&slothsim(&["plot-check", real.to_str().unwrap()]), 0);
}
