//! Side view of one sloth at several instants, for judging scenarios (turns, height
//! changes, trunk transfers) by eye.
//!
//! Orientation: a vertical image plane. Image up is world +Y; image right is a horizontal
//! unit vector `right_ws`; the camera looks along `look_ws = +Y × right_ws` (horizontal),
//! so the view is not mirrored (right × up points toward the viewer). By default
//! `right_ws` follows the sloth's path (its main horizontal direction, travel to the
//! right); for a path without horizontal extent (a trunk climb) it is the body's
//! horizontal forward, or else its horizontal "toward the support" direction, so the
//! sloth is seen in profile.

use glam::{Vec2, Vec3};
use slothsim_scene::{Scene, SupportKind};
use tiny_skia::Pixmap;

use crate::colors as c;
use crate::draw::{
    self, Align, Batch, Rgba, fill_rect, fmt_tick, frame_rect, label, nice_step, ticks,
};
use crate::types::SlothPose;

const HEADER: f32 = 40.0;
const FOOTER: f32 = 64.0;
const LEFT: f32 = 76.0;
const RIGHT: f32 = 16.0;

/// One pose of the side view and its time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SideInstant {
    /// Simulation time of the pose (seconds).
    pub time_s: f32,
    /// The pose.
    pub pose: SlothPose,
}

/// Input of [`draw_side`]. Build with [`SideView::new`].
#[derive(Clone)]
pub struct SideView<'a> {
    /// The scene (supports near the sloth are drawn).
    pub scene: &'a Scene,
    /// Poses, oldest first; older ones are drawn fainter.
    pub instants: &'a [SideInstant],
    /// Horizontal direction the camera looks along; `None` picks one (module docs).
    pub view_dir: Option<Vec3>,
    /// World box to frame; `None` frames every pose point and silhouette vertex grown by
    /// `margin_m` (or the whole scene when there are no poses).
    pub extent: Option<(Vec3, Vec3)>,
    /// Margin around the poses when `extent` is `None` (metres).
    pub margin_m: f32,
    /// Title prefix.
    pub title: String,
    /// The skinned sloth mesh at each instant (world-space vertex positions, parallel to
    /// `instants`; an empty entry or a short slice draws no mesh for that instant),
    /// drawn as a filled silhouette under the skeleton.
    pub silhouettes: &'a [Vec<Vec3>],
    /// Triangles of the silhouette mesh (vertex indices, three per triangle).
    pub silhouette_triangles: &'a [u32],
    /// Canvas width in pixels (clamped to `MIN_SIDE..=MAX_SIDE`).
    pub width: u32,
    /// Canvas height in pixels.
    pub height: u32,
}

impl<'a> SideView<'a> {
    /// Defaults: automatic view direction and extent, 0.6 m margin, 1400 × 1000 px.
    pub fn new(scene: &'a Scene, instants: &'a [SideInstant]) -> Self {
        SideView {
            scene,
            instants,
            view_dir: None,
            extent: None,
            margin_m: 0.6,
            title: String::from("side view"),
            silhouettes: &[],
            silhouette_triangles: &[],
            width: 1400,
            height: 1000,
        }
    }
}

/// World → pixel mapping of the side view.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SideProjection {
    /// Horizontal unit vector shown as image right.
    pub right_ws: Vec3,
    /// Horizontal unit vector the camera looks along (`+Y × right_ws`).
    pub look_ws: Vec3,
    /// Pixels per metre.
    pub scale_px_per_m: f32,
    /// (along `right_ws`, height) shown at `origin_px`.
    pub origin_uv: Vec2,
    /// Pixel position of `origin_uv`.
    pub origin_px: Vec2,
    /// Plot area: (left, top, right, bottom) pixels.
    pub area_px: [f32; 4],
    /// The world box framed (supports outside it are not drawn).
    pub extent_ws: (Vec3, Vec3),
}

impl SideProjection {
    /// (horizontal coordinate along `right_ws`, height) of a world point.
    pub fn to_uv(&self, p: Vec3) -> Vec2 {
        Vec2::new(p.dot(self.right_ws), p.y)
    }

    /// Pixel position of a world point.
    pub fn to_px(&self, p: Vec3) -> (f32, f32) {
        let uv = self.to_uv(p);
        (
            self.origin_px.x + (uv.x - self.origin_uv.x) * self.scale_px_per_m,
            self.origin_px.y - (uv.y - self.origin_uv.y) * self.scale_px_per_m,
        )
    }

    /// The pixel position back to (u, height).
    fn px_to_uv(&self, x: f32, y: f32) -> Vec2 {
        Vec2::new(
            self.origin_uv.x + (x - self.origin_px.x) / self.scale_px_per_m,
            self.origin_uv.y - (y - self.origin_px.y) / self.scale_px_per_m,
        )
    }
}

fn horizontal(v: Vec3) -> Option<Vec3> {
    let h = Vec3::new(v.x, 0.0, v.z);
    (h.is_finite() && h.length() > 1e-3).then(|| h.normalize())
}

/// Main horizontal axis (unit, in X–Z) and the spread along it, by PCA.
fn principal_xz(points: impl Iterator<Item = Vec3>) -> Option<(Vec3, f32)> {
    let pts: Vec<Vec2> = points
        .filter(|p| p.is_finite())
        .map(|p| Vec2::new(p.x, p.z))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let mean = pts.iter().copied().sum::<Vec2>() / pts.len() as f32;
    let (mut cxx, mut cxz, mut czz) = (0.0f32, 0.0f32, 0.0f32);
    for p in &pts {
        let d = *p - mean;
        cxx += d.x * d.x;
        cxz += d.x * d.y;
        czz += d.y * d.y;
    }
    let angle = 0.5 * (2.0 * cxz).atan2(cxx - czz);
    let axis = Vec3::new(angle.cos(), 0.0, angle.sin());
    let (lo, hi) = pts
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), p| {
            let u = p.x * axis.x + p.y * axis.z;
            (lo.min(u), hi.max(u))
        });
    Some((axis, hi - lo))
}

fn pick_right(input: &SideView) -> Vec3 {
    if let Some(d) = input.view_dir.and_then(horizontal) {
        return d.cross(Vec3::Y);
    }
    let poses = || input.instants.iter().map(|i| &i.pose);
    let path_start = poses().map(|p| p.body_pos).find(|p| p.is_finite());
    let path_end = poses().map(|p| p.body_pos).rfind(|p| p.is_finite());
    if let Some((axis, spread)) = principal_xz(poses().map(|p| p.body_pos))
        && spread > 0.15
    {
        let travel = path_end.unwrap_or(Vec3::ZERO) - path_start.unwrap_or(Vec3::ZERO);
        return if axis.dot(travel) < 0.0 { -axis } else { axis };
    }
    if let Some(last) = poses().rfind(|p| p.body_rot.is_finite()) {
        let fwd = last.body_rot * Vec3::Z;
        let up = last.body_rot * Vec3::Y;
        if Vec3::new(fwd.x, 0.0, fwd.z).length() > 0.3 {
            return horizontal(fwd).unwrap_or(Vec3::X);
        }
        if let Some(h) = horizontal(up) {
            return h;
        }
    }
    if let Some((axis, _)) = principal_xz(
        input
            .scene
            .supports()
            .iter()
            .flat_map(|s| s.nodes.iter().copied()),
    ) {
        return axis;
    }
    Vec3::X
}

fn frame_box(input: &SideView) -> Option<(Vec3, Vec3)> {
    if let Some((a, b)) = input.extent
        && a.is_finite()
        && b.is_finite()
    {
        return Some((a.min(b), a.max(b)));
    }
    let mut lo = Vec3::INFINITY;
    let mut hi = Vec3::NEG_INFINITY;
    let meshes = input.silhouettes.iter().flatten().copied();
    for p in input
        .instants
        .iter()
        .flat_map(|i| i.pose.points())
        .chain(meshes)
        .filter(|p| p.is_finite())
    {
        lo = lo.min(p);
        hi = hi.max(p);
    }
    if lo.is_finite() && hi.is_finite() {
        let m = if input.margin_m.is_finite() {
            input.margin_m.max(0.05)
        } else {
            0.6
        };
        return Some((lo - Vec3::splat(m), hi + Vec3::splat(m)));
    }
    let b = input.scene.bounds();
    (b.min.is_finite() && b.max.is_finite() && b.min.x <= b.max.x).then_some((b.min, b.max))
}

/// The projection [`draw_side`] uses for this input.
pub fn side_projection(input: &SideView) -> SideProjection {
    let w = input.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let h = input.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let area = [LEFT, HEADER, w - RIGHT, h - FOOTER];
    let right = pick_right(input);
    let look = Vec3::Y.cross(right);
    let extent = frame_box(input).unwrap_or((Vec3::splat(-1.0), Vec3::splat(1.0)));
    let (mut ulo, mut uhi) = (f32::INFINITY, f32::NEG_INFINITY);
    for i in 0..8 {
        let corner = Vec3::new(
            if i & 1 == 0 { extent.0.x } else { extent.1.x },
            0.0,
            if i & 2 == 0 { extent.0.z } else { extent.1.z },
        );
        let u = corner.dot(right);
        ulo = ulo.min(u);
        uhi = uhi.max(u);
    }
    // Only the poses' spread along `right` matters for the width when fitting poses; the
    // box corners overestimate it for diagonal paths, which only adds margin.
    let lo = Vec2::new(ulo, extent.0.y);
    let hi = Vec2::new(uhi, extent.1.y).max(lo + Vec2::splat(0.05));
    let size = hi - lo;
    let (aw, ah) = ((area[2] - area[0]).max(1.0), (area[3] - area[1]).max(1.0));
    let s = (aw / size.x).min(ah / size.y);
    SideProjection {
        right_ws: right,
        look_ws: look,
        scale_px_per_m: s,
        origin_uv: (lo + hi) * 0.5,
        origin_px: Vec2::new((area[0] + area[2]) * 0.5, (area[1] + area[3]) * 0.5),
        area_px: area,
        extent_ws: extent,
    }
}

/// Draws the side view. Never panics; no poses and no scene gives "no data".
pub fn draw_side(input: &SideView) -> Pixmap {
    let w = input.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let h = input.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let mut pm = draw::canvas(w as u32, h as u32, c::BACKGROUND);
    let proj = side_projection(input);
    let [l, t, r, b] = proj.area_px;
    let has_data = frame_box(input).is_some();
    fill_rect(&mut pm, l, t, r, b, c::PANEL);

    let (tick_u, tick_v) = if has_data {
        let lo = proj.px_to_uv(l, b);
        let hi = proj.px_to_uv(r, t);
        let step = nice_step(((hi.x - lo.x).max(hi.y - lo.y)) as f64, 8.0);
        let tu = ticks(lo.x as f64, hi.x as f64, step);
        let tv = ticks(lo.y as f64, hi.y as f64, step);
        let mut grid = Batch::new();
        for u in &tu {
            let x = proj.origin_px.x + (*u as f32 - proj.origin_uv.x) * proj.scale_px_per_m;
            grid.line((x, t), (x, b));
        }
        for v in &tv {
            let y = proj.origin_px.y - (*v as f32 - proj.origin_uv.y) * proj.scale_px_per_m;
            grid.line((l, y), (r, y));
        }
        grid.stroke(&mut pm, c::GRID, 1.0);
        draw_supports(&mut pm, &proj, input.scene);
        draw_poses(&mut pm, &proj, input);
        (tu.into_iter().map(|u| (u, step)).collect(), tv)
    } else {
        (Vec::new(), Vec::new())
    };

    // Furniture (covering whatever spilled outside the plot area).
    fill_rect(&mut pm, 0.0, 0.0, w, t, c::BACKGROUND);
    fill_rect(&mut pm, 0.0, b, w, h, c::BACKGROUND);
    fill_rect(&mut pm, 0.0, t, l, b, c::BACKGROUND);
    fill_rect(&mut pm, r, t, w, b, c::BACKGROUND);
    frame_rect(&mut pm, l, t, r, b, c::TEXT_MUTED, 1.0);
    let step = tick_u.first().map(|(_, s)| *s).unwrap_or(1.0);
    for (u, _) in &tick_u {
        let x = proj.origin_px.x + (*u as f32 - proj.origin_uv.x) * proj.scale_px_per_m;
        label(
            &mut pm,
            x,
            b + 12.0,
            &fmt_tick(*u, step),
            1,
            c::TEXT,
            Align::Center,
        );
    }
    for v in &tick_v {
        let y = proj.origin_px.y - (*v as f32 - proj.origin_uv.y) * proj.scale_px_per_m;
        label(
            &mut pm,
            l - 6.0,
            y,
            &fmt_tick(*v, step),
            1,
            c::TEXT,
            Align::Right,
        );
    }
    label(&mut pm, 8.0, t - 10.0, "Y (m)", 1, c::TEXT, Align::Left);
    let rw = proj.right_ws;
    label(
        &mut pm,
        (l + r) / 2.0,
        b + 28.0,
        &format!(
            "m along ({:.2}, 0, {:.2}) \u{b7} looking along ({:.2}, 0, {:.2})",
            rw.x, rw.z, proj.look_ws.x, proj.look_ws.z
        ),
        1,
        c::TEXT_MUTED,
        Align::Center,
    );

    let times: Vec<f32> = input
        .instants
        .iter()
        .map(|i| i.time_s)
        .filter(|t| t.is_finite())
        .collect();
    let span = match (times.first(), times.last()) {
        (Some(a), Some(z)) => format!(" \u{b7} t = {a:.2}-{z:.2} s"),
        _ => String::new(),
    };
    let title = draw::title_line(
        &input.title,
        &format!("{} instants{}", input.instants.len(), span),
    );
    draw::title(&mut pm, l, HEADER / 2.0, &title, w - l - 8.0);
    if input.instants.is_empty() {
        draw::no_data(&mut pm, l, t, r, b, "no sloth poses");
    }
    side_legend(&mut pm, l, b + 48.0);
    pm
}

fn draw_supports(pm: &mut Pixmap, proj: &SideProjection, scene: &Scene) {
    let s = proj.scale_px_per_m;
    let (elo, ehi) = proj.extent_ws;
    let mut edge = [Batch::new(), Batch::new()];
    let mut fill = [Batch::new(), Batch::new()];
    for sup in scene.supports() {
        let k = usize::from(sup.kind == SupportKind::Trunk);
        for (i, w) in sup.nodes.windows(2).enumerate() {
            let (ra, rb) = (sup.radii[i], sup.radii[i + 1]);
            let r = ra.max(rb);
            let (slo, shi) = (
                w[0].min(w[1]) - Vec3::splat(r),
                w[0].max(w[1]) + Vec3::splat(r),
            );
            if shi.cmplt(elo).any() || slo.cmpgt(ehi).any() {
                continue;
            }
            let (a, b) = (proj.to_px(w[0]), proj.to_px(w[1]));
            for (batch, grow) in [(&mut edge[k], 1.5), (&mut fill[k], 0.0)] {
                round_cone(batch, a, b, ra * s + grow, rb * s + grow);
            }
        }
    }
    let [e0, e1] = edge;
    let [f0, f1] = fill;
    e0.fill(pm, c::SUPPORT_EDGE);
    f0.fill(pm, c::BRANCH_SIDE);
    e1.fill(pm, c::TRUNK_EDGE);
    f1.fill(pm, c::TRUNK);
}

/// The outline of a projected tapered capsule: a quad between two discs.
fn round_cone(batch: &mut Batch, a: (f32, f32), b: (f32, f32), ra: f32, rb: f32) {
    let ra = ra.max(0.75);
    let rb = rb.max(0.75);
    batch.circle(a, ra);
    batch.circle(b, rb);
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len = dx.hypot(dy);
    if len > 1e-3 {
        let (nx, ny) = (-dy / len, dx / len);
        batch.polygon(&[
            (a.0 + nx * ra, a.1 + ny * ra),
            (b.0 + nx * rb, b.1 + ny * rb),
            (b.0 - nx * rb, b.1 - ny * rb),
            (a.0 - nx * ra, a.1 - ny * ra),
        ]);
    }
}

/// The silhouette of one skinned mesh: every triangle projected (consistently oriented,
/// so they add up under the non-zero rule), filled at once. Triangles with a vertex out
/// of range or non-finite are skipped.
fn draw_silhouette(
    pm: &mut Pixmap,
    proj: &SideProjection,
    vertices: &[Vec3],
    triangles: &[u32],
    alpha: u8,
) {
    let px: Vec<(f32, f32)> = vertices.iter().map(|p| proj.to_px(*p)).collect();
    let mut fur = Batch::new();
    for t in triangles.chunks_exact(3) {
        let corner = |k: usize| px.get(t[k] as usize).copied();
        if let (Some(a), Some(b), Some(c)) = (corner(0), corner(1), corner(2)) {
            fur.polygon(&[a, b, c]);
        }
    }
    fur.fill(pm, c::SLOTH_FUR.with_alpha(alpha));
}

fn draw_poses(pm: &mut Pixmap, proj: &SideProjection, input: &SideView) {
    let instants = input.instants;
    let s = proj.scale_px_per_m;
    let n = instants.len();
    let spine_w = (0.03 * s).clamp(3.0, 10.0);
    let limb_w = (0.012 * s).clamp(2.0, 5.0);
    let joint_r = (0.01 * s).clamp(2.0, 4.0);
    let head_r = (0.05 * s).clamp(4.0, 16.0);
    let grip_r = (0.015 * s).clamp(3.0, 6.0);
    for (i, inst) in instants.iter().enumerate() {
        let p = &inst.pose;
        let age = if n > 1 {
            i as f32 / (n - 1) as f32
        } else {
            1.0
        };
        let alpha = (70.0 + 185.0 * age) as u8;
        if let Some(mesh) = input.silhouettes.get(i).filter(|m| !m.is_empty()) {
            draw_silhouette(
                pm,
                proj,
                mesh,
                input.silhouette_triangles,
                (alpha / 2).max(30),
            );
        }
        let mut spine = Batch::new();
        spine.line(proj.to_px(p.hips_ws), proj.to_px(p.head_ws));
        spine.stroke(pm, c::SPINE.with_alpha(alpha), spine_w);
        for (k, limb) in p.limbs.iter().enumerate() {
            let colour = if k % 2 == 0 {
                c::LEFT_LIMB
            } else {
                c::RIGHT_LIMB
            };
            // Girdle: from the nearest spine point to the chain root.
            let (q, _) =
                slothsim_scene::closest_on_segment(p.hips_ws, p.head_ws, limb.joints_ws[0]);
            let mut bones = Batch::new();
            bones.line(proj.to_px(q), proj.to_px(limb.joints_ws[0]));
            bones.polyline(limb.joints_ws.iter().map(|j| proj.to_px(*j)));
            bones.stroke(pm, colour.with_alpha(alpha), limb_w);
            let mut joints = Batch::new();
            for j in &limb.joints_ws {
                joints.circle(proj.to_px(*j), joint_r);
            }
            joints.fill(pm, colour.with_alpha(alpha));
            let mut grip = Batch::new();
            grip.circle(proj.to_px(limb.grip_ws), grip_r);
            if limb.planted {
                grip.fill(pm, colour.with_alpha(alpha));
            } else {
                grip.stroke(pm, colour.with_alpha(alpha), 1.5);
            }
        }
        let mut head = Batch::new();
        head.circle(proj.to_px(p.head_ws), head_r);
        let mut edge = Batch::new();
        edge.circle(proj.to_px(p.head_ws), head_r);
        head.fill(pm, c::SLOTH_HEAD.with_alpha(alpha));
        edge.stroke(pm, c::SPINE.with_alpha(alpha), 1.5);
        if inst.time_s.is_finite() {
            let (hx, hy) = proj.to_px(p.head_ws);
            let txt = format!("{:.1} s", inst.time_s);
            let col = c::TEXT.with_alpha(alpha).over(c::PANEL);
            label(
                pm,
                hx + head_r + 4.0,
                hy - head_r - 6.0,
                &txt,
                1,
                col,
                Align::Left,
            );
        }
    }
}

fn side_legend(pm: &mut Pixmap, x: f32, y: f32) {
    let items: [(&str, Rgba, u8); 7] = [
        ("skinned mesh", c::SLOTH_FUR.with_alpha(128), 3),
        ("spine + head", c::SPINE, 0),
        ("left limbs (LF, LH)", c::LEFT_LIMB, 0),
        ("right limbs (RF, RH)", c::RIGHT_LIMB, 0),
        ("planted grip", c::TEXT, 1),
        ("swing target", c::TEXT, 2),
        ("older = fainter", c::TEXT.with_alpha(90), 0),
    ];
    let mut ix = x;
    for (name, col, kind) in items {
        let mut sw = Batch::new();
        match kind {
            0 => {
                sw.line((ix, y), (ix + 22.0, y));
                sw.stroke(pm, col, 3.0);
            }
            1 => {
                sw.circle((ix + 11.0, y), 4.0);
                sw.fill(pm, col);
            }
            3 => {
                sw.rect(ix, y - 5.0, ix + 22.0, y + 5.0);
                sw.fill(pm, col);
            }
            _ => {
                sw.circle((ix + 11.0, y), 4.0);
                sw.stroke(pm, col, 1.5);
            }
        }
        label(pm, ix + 28.0, y, name, 1, c::TEXT, Align::Left);
        ix += 28.0 + draw::text_width(name, 1) + 24.0;
    }
}
