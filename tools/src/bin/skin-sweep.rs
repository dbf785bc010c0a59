//! `skin_sweep.png`: the left fore limb's silhouette (projected on the elbow's hinge
//! plane) under LBS, DQS and control clusters at a 90° elbow and at the elbow's flexion
//! limit, and the smallest cross-section near each joint vs flexion for the three methods.
//!
//! ```text
//! cargo run --release -p slothsim-tools --bin skin-sweep -- --out skin_sweep.png
//! ```

use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;
use glam::{Vec2, Vec3};
use slothsim_skin::measure::{Method, skin_flexed, sweep};
use slothsim_skin::{ClusterSkin, LimbJoint, ReferenceShapes, SkinMesh};
use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// Plot the skinning flexion sweep (issue 25).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Args {
    /// Output `.png` path.
    #[arg(long, default_value = "skin_sweep.png")]
    out: PathBuf,
}

const COLORS: [(u8, u8, u8); 3] = [(220, 50, 40), (40, 110, 220), (20, 150, 60)];

fn paint(r: u8, g: u8, b: u8, a: u8) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(Color::from_rgba8(r, g, b, a));
    p.anti_alias = true;
    p
}

/// Bitmap text (font8x8, scale 2).
fn text(pm: &mut Pixmap, x: i32, y: i32, s: &str) {
    let w = pm.width() as i32;
    let h = pm.height() as i32;
    let data = pm.data_mut();
    for (i, ch) in s.chars().enumerate() {
        let glyph = font8x8::legacy::BASIC_LEGACY[(ch as usize).min(127)];
        for (row, bits) in glyph.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) != 0 {
                    for (dx, dy) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                        let px = x + (i as i32 * 8 + col) * 2 + dx;
                        let py = y + row as i32 * 2 + dy;
                        if (0..w).contains(&px) && (0..h).contains(&py) {
                            let o = 4 * (py * w + px) as usize;
                            data[o..o + 4].copy_from_slice(&[20, 20, 20, 255]);
                        }
                    }
                }
            }
        }
    }
}

fn main() -> anyhow::Result<()> {
    let args = Args::parse();
    let mesh = SkinMesh::sloth()?;
    let clusters = ClusterSkin::new(&mesh, &ReferenceShapes::sloth()?)?;
    let joints = LimbJoint::all();
    let elbow = joints[0];
    let (axis, limit) = elbow.flexion(&mesh)?;
    // Flexion that makes the elbow's included angle 90°.
    let lj = mesh.rig.limb_joints(elbow.limb);
    let p = |i: usize| Vec3::from(mesh.bind[i].translation);
    let bind_turn =
        (p(lj.joints[2]) - p(lj.joints[1])).angle_between(p(lj.joints[3]) - p(lj.joints[2]));
    let right = std::f32::consts::FRAC_PI_2 - bind_turn;
    let u = (p(lj.joints[2]) - p(lj.joints[1])).normalize();
    let v = axis.cross(u).normalize();
    let first = SkinMesh::tube_vertex(elbow.limb, 0, 0) as u32;
    let last = first + (slothsim_skin::LIMB_RINGS * slothsim_skin::LIMB_SIDES + 2) as u32;

    let (panel, pad) = (300.0f32, 10.0f32);
    let mut pm = Pixmap::new(900, 900).context("canvas")?;
    pm.fill(Color::from_rgba8(246, 245, 240, 255));
    let centre = p(lj.joints[2]);
    for (row, theta) in [right, limit].into_iter().enumerate() {
        for (col, m) in Method::ALL.into_iter().enumerate() {
            let pos = skin_flexed(&mesh, &clusters, elbow, theta, m)?;
            let ox = col as f32 * panel;
            let oy = row as f32 * panel;
            let to = |q: Vec3| {
                let d = q - centre;
                let s = Vec2::new(d.dot(u), d.dot(v)) * 1000.0;
                (panel * 0.62 + s.x, panel * 0.5 - s.y)
            };
            let mut pb = PathBuilder::new();
            for t in mesh.indices.chunks_exact(3) {
                if (first..last).contains(&t[0]) {
                    let [a, mut b, mut c] = [t[0], t[1], t[2]].map(|i| to(pos[i as usize]));
                    // One orientation for all, so front and back faces add up (winding).
                    if (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0) < 0.0 {
                        std::mem::swap(&mut b, &mut c);
                    }
                    pb.move_to(a.0, a.1);
                    pb.line_to(b.0, b.1);
                    pb.line_to(c.0, c.1);
                    pb.close();
                }
            }
            let (r, g, b) = COLORS[col];
            let mut sub = Pixmap::new(panel as u32 - 4, panel as u32 - 4).context("panel")?;
            sub.fill(Color::from_rgba8(255, 255, 255, 255));
            if let Some(path) = pb.finish() {
                sub.fill_path(
                    &path,
                    &paint(r, g, b, 255),
                    FillRule::Winding,
                    Transform::identity(),
                    None,
                );
            }
            pm.draw_pixmap(
                ox as i32 + 2,
                oy as i32 + 2,
                sub.as_ref(),
                &tiny_skia::PixmapPaint::default(),
                Transform::identity(),
                None,
            );
            let label = format!(
                "{} {}",
                m.name(),
                if row == 0 {
                    "90 deg".to_string()
                } else {
                    format!("+{:.0} limit", theta.to_degrees())
                }
            );
            text(&mut pm, (ox + pad) as i32, (oy + pad) as i32, &label);
        }
    }
    // Area curves: one panel per joint kind (left limbs).
    let curves: Vec<LimbJoint> = joints.into_iter().filter(|j| j.limb.is_left()).collect();
    let (cw, ch, top) = (225.0f32, 260.0f32, 620.0f32);
    for (k, j) in curves.into_iter().enumerate() {
        let rows = sweep(&mesh, &clusters, j, 1.0)?;
        let max_deg = rows.last().map_or(1.0, |r| r.deg);
        let ox = k as f32 * cw;
        let (x0, x1, y0, y1) = (ox + 30.0, ox + cw - 10.0, top + 40.0, top + ch - 30.0);
        let x_of = |d: f32| x0 + (x1 - x0) * d / max_deg;
        let y_of = |a: f32| y1 - (y1 - y0) * (a - 0.85) / 0.17;
        let mut axes = PathBuilder::new();
        axes.move_to(x0, y0);
        axes.line_to(x0, y1);
        axes.line_to(x1, y1);
        let stroke = Stroke {
            width: 1.5,
            ..Stroke::default()
        };
        if let Some(path) = axes.finish() {
            pm.stroke_path(
                &path,
                &paint(60, 60, 60, 255),
                &stroke,
                Transform::identity(),
                None,
            );
        }
        let mut ninety = PathBuilder::new();
        ninety.move_to(x0, y_of(0.9));
        ninety.line_to(x1, y_of(0.9));
        if let Some(path) = ninety.finish() {
            pm.stroke_path(
                &path,
                &paint(150, 150, 150, 255),
                &stroke,
                Transform::identity(),
                None,
            );
        }
        for (m, &(r, g, b)) in COLORS.iter().enumerate() {
            let mut pb = PathBuilder::new();
            for (i, r) in rows.iter().enumerate() {
                let (x, y) = (x_of(r.deg), y_of(r.area[m].min(1.02)));
                if i == 0 {
                    pb.move_to(x, y)
                } else {
                    pb.line_to(x, y)
                }
            }
            if let Some(path) = pb.finish() {
                let s = Stroke {
                    width: 2.5,
                    ..Stroke::default()
                };
                pm.stroke_path(&path, &paint(r, g, b, 220), &s, Transform::identity(), None);
            }
        }
        text(&mut pm, ox as i32 + 8, top as i32 + 4, &j.label());
        text(
            &mut pm,
            ox as i32 + 8,
            top as i32 + 20,
            &format!("0-{max_deg:.0} deg"),
        );
        text(&mut pm, x0 as i32 + 4, y_of(0.9) as i32 + 3, "90%");
    }
    text(
        &mut pm,
        10,
        602,
        "min section/bind: LBS red DQS blue clusters green",
    );
    pm.save_png(&args.out)
        .with_context(|| format!("writing {}", args.out.display()))?;
    println!("wrote {}", args.out.display());
    Ok(())
}
