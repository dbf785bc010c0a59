//! The plots, written as PNGs, decoded again and checked for content (sizes, colours,
//! sloth/trace/limb pixels where they belong) — not pixel goldens.

mod common;

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use slothsim_plot::{
    FrameTimes, GaitDiagram, MIN_SIDE, Pixmap, PlotError, Rgba, SideInstant, SideView, TopDown,
    TraceLine, colors, draw_frame_times, draw_gait, draw_side, draw_topdown, frame_times_layout,
    gait_layout, save_png, side_projection, topdown_projection,
};
use slothsim_scene::{Preset, Scene, SupportKind, default_forest};

/// A fresh folder for one test, removed when the test passes (kept for a look when it
/// fails).
struct OutDir(PathBuf);

impl std::ops::Deref for OutDir {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

fn out_dir(test: &str) -> OutDir {
    let dir = std::env::temp_dir().join(format!("slothsim-plot-{test}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    OutDir(dir)
}

/// Writes the pixmap with `save_png`, then decodes the file again.
fn roundtrip(pm: &Pixmap, dir: &Path, name: &str) -> Pixmap {
    let path = dir.join(name);
    save_png(pm, &path).unwrap();
    Pixmap::load_png(&path).unwrap()
}

fn rgb(pm: &Pixmap, x: i64, y: i64) -> Option<(u8, u8, u8)> {
    if x < 0 || y < 0 {
        return None;
    }
    let p = pm.pixel(x as u32, y as u32)?.demultiply();
    Some((p.red(), p.green(), p.blue()))
}

fn close(a: (u8, u8, u8), c: Rgba, tol: i32) -> bool {
    (a.0 as i32 - c.0 as i32).abs() <= tol
        && (a.1 as i32 - c.1 as i32).abs() <= tol
        && (a.2 as i32 - c.2 as i32).abs() <= tol
}

/// Pixels of colour `c` (± tol per channel) within `r` pixels of (x, y).
fn count_near(pm: &Pixmap, (x, y): (f32, f32), r: i64, c: Rgba, tol: i32) -> usize {
    let (x, y) = (x.round() as i64, y.round() as i64);
    let mut n = 0;
    for dy in -r..=r {
        for dx in -r..=r {
            if dx * dx + dy * dy <= r * r
                && let Some(p) = rgb(pm, x + dx, y + dy)
                && close(p, c, tol)
            {
                n += 1;
            }
        }
    }
    n
}

fn count_colour(pm: &Pixmap, c: Rgba, tol: i32) -> usize {
    pm.pixels()
        .iter()
        .filter(|p| {
            let d = p.demultiply();
            close((d.red(), d.green(), d.blue()), c, tol)
        })
        .count()
}

fn distinct_colours(pm: &Pixmap) -> usize {
    pm.pixels()
        .iter()
        .map(|p| (p.red(), p.green(), p.blue()))
        .collect::<HashSet<_>>()
        .len()
}

fn first_hanging(sloths: &[slothsim_plot::SlothPose]) -> &slothsim_plot::SlothPose {
    sloths
        .iter()
        .find(|s| (s.body_rot * Vec3::Y).y > 0.9)
        .expect("a hanging sloth")
}

#[test]
fn topdown_forest_shows_sloths_and_traces() {
    let dir = out_dir("topdown-forest");
    let forest = default_forest();
    let (sloths, trails) = common::crowd(&forest, 300, 1);
    let focus = first_hanging(&sloths);
    let traces = common::step_search(focus, 0.03);
    let mut td = TopDown::new(&forest);
    td.sloths = &sloths;
    td.trails = &trails;
    td.focus = Some(focus.id);
    td.traces = &traces;
    td.time_s = 12.5;
    td.seed = 42;
    td.width = 1200;
    td.height = 1300;
    let pm = roundtrip(&draw_topdown(&td), &dir, "topdown.png");
    assert_eq!((pm.width(), pm.height()), (1200, 1300));
    assert!(distinct_colours(&pm) > 30, "{}", distinct_colours(&pm));

    // The focus inset shows its traces: green hits and red misses.
    assert!(count_colour(&pm, colors::TRACE_HIT, 10) > 20);
    assert!(count_colour(&pm, colors::TRACE_MISS, 10) > 20);
    assert!(count_colour(&pm, colors::FOCUS, 10) > 50);
    // Trunks.
    assert!(count_colour(&pm, colors::TRUNK, 6) > 100);

    // Without the inset, every sloth shows at its projected position: its body (hips ..
    // neck), or for trunk climbers seen from above, their pale head over the body.
    td.inset = false;
    let pm = roundtrip(&draw_topdown(&td), &dir, "topdown_no_inset.png");
    let proj = topdown_projection(&td);
    let found = sloths
        .iter()
        .filter(|s| {
            let p = proj.to_px(s.hips_ws.lerp(s.head_ws, 0.375));
            count_near(&pm, p, 4, colors::SLOTH_BODY, 12) > 0
                || count_near(&pm, p, 2, colors::SLOTH_HEAD, 12) > 0
        })
        .count();
    // In the synthetic crowd some pile up at trunk bases, hidden by their neighbours.
    assert!(
        found * 100 >= sloths.len() * 95,
        "{found} of {}",
        sloths.len()
    );
}

#[test]
fn topdown_sloth_colour_only_where_sloths_are() {
    let dir = out_dir("topdown-where");
    let forest = default_forest();
    let (sloths, _) = common::crowd(&forest, 150, 2);
    let mut td = TopDown::new(&forest);
    td.sloths = &sloths;
    td.width = 900;
    td.height = 960;
    let pm = roundtrip(&draw_topdown(&td), &dir, "topdown.png");
    let proj = topdown_projection(&td);
    let s = proj.scale_px_per_m;
    let near: Vec<(f32, f32)> = sloths.iter().map(|sl| proj.to_px(sl.body_pos)).collect();
    let (mut inside, mut outside) = (0, 0);
    for y in 0..pm.height() {
        for x in 0..pm.width() {
            if !close(rgb(&pm, x as i64, y as i64).unwrap(), colors::SLOTH_BODY, 0) {
                continue;
            }
            let (fx, fy) = (x as f32, y as f32);
            let legend = fy > proj.area_px[3];
            if legend
                || near
                    .iter()
                    .any(|p| (p.0 - fx).hypot(p.1 - fy) < 0.8 * s + 3.0)
            {
                inside += 1;
            } else {
                outside += 1;
            }
        }
    }
    assert!(inside > 150, "{inside}");
    assert_eq!(outside, 0);
}

#[test]
fn topdown_zoom_shows_limbs_and_traces_where_they_are() {
    let dir = out_dir("topdown-zoom");
    let turn = Preset::by_name("turn", Some(120.0)).unwrap();
    let pos = turn.start.position + turn.start.forward * 0.8;
    // LF swings, the others hold.
    let sloth = common::hanging(5, pos, turn.start.forward, 0.02, Some(0));
    let traces = common::step_search(&sloth, 0.02);
    let sloths = [sloth];
    let c = Vec2::new(sloth.body_pos.x, sloth.body_pos.z);
    let mut td = TopDown::new(&turn.scene);
    td.sloths = &sloths;
    td.focus = Some(5);
    td.traces = &traces;
    td.view = Some((c - Vec2::splat(1.5), c + Vec2::splat(1.5)));
    td.width = 800;
    td.height = 850;
    let pm = roundtrip(&draw_topdown(&td), &dir, "zoom.png");
    assert_eq!((pm.width(), pm.height()), (800, 850));
    let proj = topdown_projection(&td);
    assert!(proj.scale_px_per_m > 200.0);

    for tr in &traces {
        let mid = proj.to_px(tr.from.lerp(tr.to, 0.5));
        let (colour, other) = if tr.hit {
            (colors::TRACE_HIT, colors::TRACE_MISS)
        } else {
            (colors::TRACE_MISS, colors::TRACE_HIT)
        };
        assert!(count_near(&pm, mid, 2, colour, 10) > 0, "{tr:?}");
        assert_eq!(count_near(&pm, mid, 1, other, 10), 0, "{tr:?}");
    }
    // Planted limbs: dark pixels along each planted limb's chain; the swinging limb:
    // its lighter colour along its chain.
    for (k, limb) in sloth.limbs.iter().enumerate() {
        let colour = if limb.planted {
            colors::LIMB_PLANTED
        } else {
            colors::LIMB_SWING
        };
        let hits: usize = (0..4)
            .map(|j| {
                let p = proj.to_px(limb.joints_ws[j].lerp(limb.joints_ws[j + 1], 0.5));
                count_near(&pm, p, 4, colour, 12)
            })
            .sum();
        assert!(hits > 0, "limb {k}");
    }
    // The body, the focus ring.
    let mid = proj.to_px(sloth.hips_ws.lerp(sloth.head_ws, 0.2));
    assert!(count_near(&pm, mid, 10, colors::SLOTH_BODY, 6) > 20);
    assert!(count_colour(&pm, colors::FOCUS, 10) > 50);
}

#[test]
fn side_view_pole_shows_the_skeleton_over_time() {
    let dir = out_dir("side-pole");
    let pole = Preset::by_name("pole", None).unwrap();
    let walk = common::walk(pole.start.position, pole.start.forward, 0.02, 5, 16.0);
    let inst: Vec<SideInstant> = walk
        .iter()
        .map(|(t, p)| SideInstant {
            time_s: *t,
            pose: *p,
        })
        .collect();
    let mut sv = SideView::new(&pole.scene, &inst);
    sv.width = 1000;
    sv.height = 700;
    let pm = roundtrip(&draw_side(&sv), &dir, "side.png");
    assert_eq!((pm.width(), pm.height()), (1000, 700));
    assert!(distinct_colours(&pm) > 30);
    let proj = side_projection(&sv);
    // The path runs along +X: travel goes to the right.
    assert!(proj.right_ws.dot(Vec3::X) > 0.99, "{:?}", proj.right_ws);
    let (first, last) = (&inst[0].pose, &inst[4].pose);
    assert!(proj.to_px(last.body_pos).0 > proj.to_px(first.body_pos).0);
    // Newest instant (opaque colours): head, spine, left and right limbs.
    assert!(count_near(&pm, proj.to_px(last.head_ws), 4, colors::SLOTH_HEAD, 6) > 5);
    let spine_mid = proj.to_px(last.hips_ws.lerp(last.head_ws, 0.5));
    assert!(count_near(&pm, spine_mid, 3, colors::SPINE, 8) > 3);
    assert!(count_colour(&pm, colors::LEFT_LIMB, 6) > 100);
    assert!(count_colour(&pm, colors::RIGHT_LIMB, 6) > 100);
    // The pole: a horizontal band of branch colour at its height.
    let (_, pole_y) = proj.to_px(Vec3::new(0.0, 2.0, 0.0));
    let row: usize = (0..pm.width() as i64)
        .filter(|x| {
            rgb(&pm, *x, pole_y.round() as i64 - 3)
                .is_some_and(|p| close(p, colors::BRANCH_SIDE, 8))
        })
        .count();
    assert!(row > 300, "{row}");
}

#[test]
fn side_view_trunk_climb_is_seen_in_profile() {
    let dir = out_dir("side-trunk");
    let trunk = Preset::by_name("trunk", None).unwrap();
    let r = trunk.scene.supports()[0].radii[0];
    let inst: Vec<SideInstant> = (0..4)
        .map(|i| SideInstant {
            time_s: i as f32 * 3.0,
            pose: common::sloth_on(
                0,
                Vec3::new(0.0, 1.0 + 0.3 * i as f32, 0.0),
                Vec3::Y,
                -trunk.start.body_side,
                r,
                Some(i % 4),
            ),
        })
        .collect();
    let sv = SideView::new(&trunk.scene, &inst);
    let pm = roundtrip(&draw_side(&sv), &dir, "side.png");
    let proj = side_projection(&sv);
    assert!(proj.right_ws.y.abs() < 1e-6 && (proj.right_ws.length() - 1.0).abs() < 1e-5);
    assert!(proj.look_ws.dot(proj.right_ws).abs() < 1e-5);
    // In profile: the body sits beside the trunk, not in front of it.
    let body_px = proj.to_px(inst[3].pose.body_pos);
    let axis_px = proj.to_px(Vec3::new(0.0, 1.9, 0.0));
    assert!((body_px.0 - axis_px.0).abs() > (r + 0.1) * proj.scale_px_per_m);
    assert!(count_near(&pm, axis_px, 3, colors::TRUNK, 6) > 5);
    assert!(count_colour(&pm, colors::LEFT_LIMB, 6) > 20);
    assert!(count_colour(&pm, colors::RIGHT_LIMB, 6) > 20);
}

#[test]
fn gait_bars_sit_in_their_rows() {
    let dir = out_dir("gait");
    let contacts = [
        vec![(0.0, 1.0)],
        vec![(1.0, 2.0)],
        vec![(2.0, 3.0)],
        vec![(0.0, 3.0)],
    ];
    let gd = GaitDiagram::new(contacts, 3.0);
    let pm = roundtrip(&draw_gait(&gd), &dir, "gait.png");
    assert_eq!((pm.width(), pm.height()), (gd.width, gd.height));
    let lay = gait_layout(&gd);
    let at = |row: usize, t: f32| {
        let (y0, y1) = lay.rows_px[row];
        rgb(
            &pm,
            lay.x_of(t).round() as i64,
            ((y0 + y1) / 2.0).round() as i64,
        )
        .unwrap()
    };
    let fore = |p| close(p, colors::GAIT_FORE, 0);
    let hind = |p| close(p, colors::GAIT_HIND, 0);
    assert!(fore(at(0, 0.5)) && !fore(at(0, 1.5)) && !fore(at(0, 2.5)));
    assert!(!fore(at(1, 0.5)) && fore(at(1, 1.5)) && !fore(at(1, 2.5)));
    assert!(!hind(at(2, 0.5)) && !hind(at(2, 1.5)) && hind(at(2, 2.5)));
    assert!(hind(at(3, 0.5)) && hind(at(3, 1.5)) && hind(at(3, 2.5)));
    // Bars stay inside their rows.
    let (y0, _) = lay.rows_px[1];
    assert!(!fore(
        rgb(&pm, lay.x_of(1.5) as i64, y0 as i64 + 1).unwrap()
    ));
}

#[test]
fn frame_times_show_stages_budget_and_percentiles() {
    let dir = out_dir("frames");
    let frames: Vec<[f64; 6]> = (0..200)
        .map(|i| {
            if i % 10 == 0 {
                [2.0, 2.0, 2.0, 2.0, 2.0, 0.0]
            } else {
                [1.0, 1.0, 1.0, 1.0, 1.0, 0.0]
            }
        })
        .collect();
    let ft = FrameTimes::new(&frames);
    let pm = roundtrip(&draw_frame_times(&ft), &dir, "frames.png");
    assert_eq!((pm.width(), pm.height()), (ft.width, ft.height));
    let lay = frame_times_layout(&ft);
    assert_eq!(lay.p50_ms, Some(5.0));
    assert_eq!(lay.p95_ms, Some(10.0));
    let [l, _, r, _] = lay.plot_px;
    // Column of frame 5 (a 5 ms frame): each stage's colour in its 1 ms slice.
    let x = (l + (5.5 / 200.0) * (r - l)).round() as i64;
    for k in 0..5 {
        let y = lay.y_of(k as f64 + 0.5).round() as i64;
        assert!(
            close(rgb(&pm, x, y).unwrap(), colors::STAGES[k], 0),
            "stage {k}"
        );
    }
    // The budget band above the bars.
    assert!(close(
        rgb(&pm, x, lay.y_of(13.0).round() as i64).unwrap(),
        colors::BUDGET_BAND,
        0
    ));
    // p50 (solid) and p95 (dashed) lines across the plot.
    let row_has = |ms: f64, c: Rgba| {
        let y = lay.y_of(ms).round() as i64;
        (l as i64..r as i64)
            .filter(|x| (y - 1..=y + 1).any(|y| close(rgb(&pm, *x, y).unwrap(), c, 10)))
            .count()
    };
    assert!(row_has(5.0, colors::P50) as f32 > 0.9 * (r - l));
    assert!(row_has(10.0, colors::P95) as f32 > 0.4 * (r - l));
}

#[test]
fn empty_inputs_draw_empty_charts() {
    let dir = out_dir("empty");
    let empty = Scene::new(Vec::new()).unwrap();
    let plots = [
        ("topdown.png", draw_topdown(&TopDown::new(&empty))),
        ("side.png", draw_side(&SideView::new(&empty, &[]))),
        (
            "gait.png",
            draw_gait(&GaitDiagram::new(Default::default(), 0.0)),
        ),
        ("frames.png", draw_frame_times(&FrameTimes::new(&[]))),
    ];
    for (name, pm) in &plots {
        let back = roundtrip(pm, &dir, name);
        assert_eq!((back.width(), back.height()), (pm.width(), pm.height()));
        // The "no data" label is there.
        assert!(count_colour(&back, colors::TEXT_MUTED, 0) > 50, "{name}");
    }
    // A scene with supports but no sloths is not "empty": the forest is drawn.
    let pole = Preset::by_name("pole", None).unwrap();
    let pm = draw_topdown(&TopDown::new(&pole.scene));
    assert!(distinct_colours(&pm) > 10);
}

#[test]
fn non_finite_inputs_are_skipped() {
    let dir = out_dir("nan");
    let forest = default_forest();
    let (mut sloths, mut trails) = common::crowd(&forest, 20, 3);
    sloths[0].body_pos = Vec3::NAN;
    sloths[1].head_ws = Vec3::new(f32::INFINITY, 0.0, 0.0);
    sloths[2].limbs[0].joints_ws[2] = Vec3::NAN;
    sloths[3].body_rot = glam::Quat::from_xyzw(f32::NAN, 0.0, 0.0, 1.0);
    trails[0].push(Vec3::NAN);
    let traces = [
        TraceLine {
            from: Vec3::NAN,
            to: Vec3::ZERO,
            hit: true,
        },
        TraceLine {
            from: Vec3::ZERO,
            to: Vec3::splat(f32::INFINITY),
            hit: false,
        },
    ];
    let mut td = TopDown::new(&forest);
    td.sloths = &sloths;
    td.trails = &trails;
    td.traces = &traces;
    td.focus = Some(sloths[4].id);
    td.time_s = f32::NAN;
    td.view = Some((Vec2::NAN, Vec2::ZERO)); // ignored: not finite
    td.width = 600;
    td.height = 640;
    roundtrip(&draw_topdown(&td), &dir, "topdown.png");

    let inst: Vec<SideInstant> = sloths[..4]
        .iter()
        .map(|p| SideInstant {
            time_s: f32::NAN,
            pose: *p,
        })
        .collect();
    let mut sv = SideView::new(&forest, &inst);
    sv.view_dir = Some(Vec3::NAN);
    sv.margin_m = f32::NAN;
    roundtrip(&draw_side(&sv), &dir, "side.png");

    let gd = GaitDiagram::new(
        [
            vec![(f32::NAN, 1.0)],
            vec![(2.0, 1.0)],
            vec![(0.0, f32::INFINITY)],
            vec![(0.5, 1.0)],
        ],
        f32::NAN,
    );
    roundtrip(&draw_gait(&gd), &dir, "gait.png");

    let frames = [
        [f64::NAN, 1.0, 1.0, 1.0, 1.0, 0.0],
        [f64::INFINITY, -3.0, 1.0, 1.0, 1.0, 0.0],
        [1.0; 6],
    ];
    let mut ft = FrameTimes::new(&frames);
    ft.budget_ms = (f32::NAN, 14.0);
    let lay = frame_times_layout(&ft);
    assert!(lay.y_max_ms.is_finite());
    assert_eq!(lay.p50_ms, Some(4.0));
    roundtrip(&draw_frame_times(&ft), &dir, "frames.png");
}

#[test]
fn canvas_sizes_are_clamped() {
    let pole = Preset::by_name("pole", None).unwrap();
    let mut td = TopDown::new(&pole.scene);
    td.width = 0;
    td.height = 3;
    let pm = draw_topdown(&td);
    assert_eq!((pm.width(), pm.height()), (MIN_SIDE, MIN_SIDE));
    let mut gd = GaitDiagram::new(Default::default(), 1.0);
    gd.width = 1;
    assert_eq!(draw_gait(&gd).width(), MIN_SIDE);
}

#[test]
fn save_png_into_a_missing_or_unwritable_folder_is_a_clear_error() {
    let dir = out_dir("errors");
    let pm = draw_gait(&GaitDiagram::new(Default::default(), 1.0));

    // Missing folder.
    let missing = dir.join("no/such/folder/gait.png");
    let err = save_png(&pm, &missing).unwrap_err();
    assert!(matches!(err, PlotError::Io { .. }));
    let msg = err.to_string();
    assert!(msg.contains(&missing.display().to_string()), "{msg}");

    // The "folder" is a regular file (works even when running as root, where
    // permission bits would not stop the write).
    let file = dir.join("not-a-folder");
    std::fs::write(&file, b"x").unwrap();
    let inside_file = file.join("gait.png");
    let err = save_png(&pm, &inside_file).unwrap_err();
    assert!(err.to_string().contains("not-a-folder"), "{err}");

    // A path without a file name.
    assert!(save_png(&pm, Path::new("/")).is_err());

    // A read-only folder, when permissions are enforced for this user.
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt;
        let ro = dir.join("read-only");
        std::fs::create_dir(&ro).unwrap();
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o555)).unwrap();
        let enforced = std::fs::write(ro.join("probe"), b"x").is_err();
        if enforced {
            let err = save_png(&pm, &ro.join("gait.png")).unwrap_err();
            assert!(err.to_string().contains("read-only"), "{err}");
        }
        std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o755)).unwrap();
    }

    // Success leaves exactly the PNG: no temporary file behind, and overwriting works.
    let ok = dir.join("ok");
    std::fs::create_dir(&ok).unwrap();
    save_png(&pm, &ok.join("gait.png")).unwrap();
    save_png(&pm, &ok.join("gait.png")).unwrap();
    let names: Vec<String> = std::fs::read_dir(&ok)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["gait.png".to_string()]);
}

#[test]
fn forest_branches_are_height_coloured() {
    // Branch pixels come in several ramp colours, the low end (dark blue) among them.
    let forest = default_forest();
    assert!(
        forest
            .supports()
            .iter()
            .any(|s| s.kind == SupportKind::Branch)
    );
    let mut td = TopDown::new(&forest);
    td.width = 800;
    td.height = 860;
    let pm = draw_topdown(&td);
    assert!(count_colour(&pm, Rgba::rgb(0, 40, 100), 30) > 50);
    assert!(distinct_colours(&pm) > 40);
}

#[test]
fn side_view_draws_the_skinned_silhouette_where_the_mesh_is() {
    let dir = out_dir("side-silhouette");
    let pole = Preset::by_name("pole", None).unwrap();
    let walk = common::walk(pole.start.position, pole.start.forward, 0.02, 1, 16.0);
    let inst: Vec<SideInstant> = walk
        .iter()
        .map(|(t, p)| SideInstant {
            time_s: *t,
            pose: *p,
        })
        .collect();
    // A box 0.4 m long, 0.2 m high, 0.6 m below the body: away from the skeleton.
    let c = inst[0].pose.body_pos - Vec3::new(0.0, 0.6, 0.0);
    let h = Vec3::new(0.2, 0.1, 0.1);
    let corners: Vec<Vec3> = (0..8)
        .map(|i| {
            c + Vec3::new(
                if i & 1 == 0 { -h.x } else { h.x },
                if i & 2 == 0 { -h.y } else { h.y },
                if i & 4 == 0 { -h.z } else { h.z },
            )
        })
        .collect();
    #[rustfmt::skip]
    let mut tris: Vec<u32> = vec![
        0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1,
        2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3,
    ];
    // Bad triangles are skipped: an index past the vertices, a non-finite vertex.
    tris.extend([0, 1, 99]);
    let mut verts = corners.clone();
    verts.push(Vec3::NAN);
    tris.extend([0, 1, 8]);
    let meshes = vec![verts];
    let mut sv = SideView::new(&pole.scene, &inst);
    sv.silhouettes = &meshes;
    sv.silhouette_triangles = &tris;
    let pm = roundtrip(&draw_side(&sv), &dir, "side.png");
    let proj = side_projection(&sv);
    let fur = colors::SLOTH_FUR.with_alpha(127).over(colors::PANEL);
    assert!(
        count_near(&pm, proj.to_px(c), 5, fur, 6) > 80,
        "fur at the box"
    );
    // Nowhere outside the box's projection (grown by 3 px of anti-aliasing).
    let (lo, hi) = (proj.to_px(c - h), proj.to_px(c + h));
    let (x0, x1) = (lo.0.min(hi.0) - 3.0, lo.0.max(hi.0) + 3.0);
    let (y0, y1) = (lo.1.min(hi.1) - 3.0, lo.1.max(hi.1) + 3.0);
    let mut outside = 0;
    for y in 0..pm.height() as i64 {
        for x in 0..pm.width() as i64 {
            let inside = (x0..=x1).contains(&(x as f32)) && (y0..=y1).contains(&(y as f32));
            if !inside && rgb(&pm, x, y).is_some_and(|p| close(p, fur, 3)) {
                outside += 1;
            }
        }
    }
    assert!(outside < 20, "{outside} fur pixels outside the box");
    // Without a mesh: no fur at the box.
    sv.silhouettes = &[];
    let pm = draw_side(&sv);
    assert_eq!(count_near(&pm, proj.to_px(c), 5, fur, 6), 0);
}
