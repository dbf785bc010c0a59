//! Top-down view of the forest and the crowd.
//!
//! Orientation: the camera looks straight down (−Y) onto the X–Z plane. Image right is
//! +X and image *down* is +Z (so image up is −Z): seen from above this is a proper,
//! non-mirrored map of the right-handed world (right × up = +X × −Z = +Y, toward the
//! viewer). A small compass in the footer repeats it.

use std::collections::BTreeMap;

use glam::{Vec2, Vec3};
use slothsim_scene::{Scene, SupportKind};
use tiny_skia::{Pixmap, PixmapPaint, Transform};

use crate::colors as c;
use crate::draw::{
    self, Align, Batch, fill_rect, frame_rect, label, label_boxed, nice_floor, ramp,
};
use crate::types::{SlothPose, TraceLine};

const HEADER: f32 = 40.0;
const FOOTER: f32 = 70.0;
const MARGIN: f32 = 12.0;
/// The zoomed inset is drawn only when the map is coarser than this.
const INSET_BELOW_PX_PER_M: f32 = 60.0;
/// Number of colour bins branches are batched into.
const HEIGHT_BINS: usize = 48;

/// Input of [`draw_topdown`]. Build with [`TopDown::new`] and set the fields you need.
#[derive(Clone)]
pub struct TopDown<'a> {
    /// The forest.
    pub scene: &'a Scene,
    /// Sloths at this instant.
    pub sloths: &'a [SlothPose],
    /// Optional trails (one polyline of body positions per sloth, any order), drawn thin.
    pub trails: &'a [Vec<Vec3>],
    /// The sloth (by [`SlothPose::id`]) whose step-search `traces` are shown: it gets a
    /// ring, and with `inset` a zoomed inset in the top-right corner of the map.
    pub focus: Option<u32>,
    /// Traces of the focus sloth's last step search (hits green, misses red).
    pub traces: &'a [TraceLine],
    /// Simulation time (title).
    pub time_s: f32,
    /// Seed (title).
    pub seed: u64,
    /// Title prefix, e.g. `"slothsim run"`; time, sloth count and seed are appended.
    pub title: String,
    /// World window to draw: `(min, max)` with `x` = world X and `y` = world Z (metres).
    /// `None` fits the scene bounds and every sloth.
    pub view: Option<(Vec2, Vec2)>,
    /// Draw the zoomed inset around the focus sloth (only when `view` is `None` and the
    /// map is coarser than 60 px/m, i.e. when limbs would not be visible otherwise).
    pub inset: bool,
    /// Canvas size in pixels (clamped to `MIN_SIDE..=MAX_SIDE`).
    pub width: u32,
    /// Canvas height in pixels.
    pub height: u32,
}

impl<'a> TopDown<'a> {
    /// Defaults: no sloths, trails or traces, 1600 × 1700 px, auto-fit, inset on.
    pub fn new(scene: &'a Scene) -> Self {
        TopDown {
            scene,
            sloths: &[],
            trails: &[],
            focus: None,
            traces: &[],
            time_s: 0.0,
            seed: 0,
            title: String::from("slothsim"),
            view: None,
            inset: true,
            width: 1600,
            height: 1700,
        }
    }
}

/// World X–Z → pixel mapping of a top-down map (see the module docs for orientation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MapProjection {
    /// Pixels per metre.
    pub scale_px_per_m: f32,
    /// World (X, Z) shown at `origin_px`.
    pub origin_ws: Vec2,
    /// Pixel position of `origin_ws`.
    pub origin_px: Vec2,
    /// The map area on the canvas: (left, top, right, bottom) in pixels.
    pub area_px: [f32; 4],
}

impl MapProjection {
    /// Pixel position of a world point (its Y is dropped): x = +X, y = +Z.
    pub fn to_px(&self, p: Vec3) -> (f32, f32) {
        (
            self.origin_px.x + (p.x - self.origin_ws.x) * self.scale_px_per_m,
            self.origin_px.y + (p.z - self.origin_ws.y) * self.scale_px_per_m,
        )
    }

    /// Whether a pixel position lies inside the map area, grown by `pad` pixels.
    fn inside(&self, (x, y): (f32, f32), pad: f32) -> bool {
        let [l, t, r, b] = self.area_px;
        x >= l - pad && x <= r + pad && y >= t - pad && y <= b + pad
    }

    /// A projection that shows the world window `[min, max]` (X, Z) centred in `area`.
    fn fit(min: Vec2, max: Vec2, area: [f32; 4]) -> Self {
        let size = (max - min).max(Vec2::splat(1e-3));
        let (aw, ah) = ((area[2] - area[0]).max(1.0), (area[3] - area[1]).max(1.0));
        let s = (aw / size.x).min(ah / size.y);
        let centre_ws = (min + max) * 0.5;
        MapProjection {
            scale_px_per_m: s,
            origin_ws: centre_ws,
            origin_px: Vec2::new((area[0] + area[2]) * 0.5, (area[1] + area[3]) * 0.5),
            area_px: area,
        }
    }
}

fn canvas_size(input: &TopDown) -> (f32, f32) {
    (
        input.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32,
        input.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32,
    )
}

/// The world window drawn: `view` if given (and sane), else scene ∪ sloths, padded.
fn world_window(input: &TopDown) -> Option<(Vec2, Vec2)> {
    if let Some((a, b)) = input.view
        && a.is_finite()
        && b.is_finite()
    {
        let (lo, hi) = (a.min(b), a.max(b));
        let hi = hi.max(lo + Vec2::splat(0.1));
        return Some((lo, hi));
    }
    let mut lo = Vec2::splat(f32::INFINITY);
    let mut hi = Vec2::splat(f32::NEG_INFINITY);
    let b = input.scene.bounds();
    if b.min.is_finite() && b.max.is_finite() && b.min.x <= b.max.x {
        lo = Vec2::new(b.min.x, b.min.z);
        hi = Vec2::new(b.max.x, b.max.z);
    }
    for s in input.sloths {
        if s.body_pos.is_finite() {
            let p = Vec2::new(s.body_pos.x, s.body_pos.z);
            lo = lo.min(p);
            hi = hi.max(p);
        }
    }
    if !(lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let pad = ((hi - lo).max_element() * 0.02).max(1.0);
    Some((lo - Vec2::splat(pad), hi + Vec2::splat(pad)))
}

/// The projection [`draw_topdown`] uses for this input (tests use it to find sloths).
pub fn topdown_projection(input: &TopDown) -> MapProjection {
    let (w, h) = canvas_size(input);
    let area = [MARGIN, HEADER, w - MARGIN, h - FOOTER];
    let (lo, hi) = world_window(input).unwrap_or((Vec2::splat(-5.0), Vec2::splat(5.0)));
    MapProjection::fit(lo, hi, area)
}

/// Branch heights (min, max) over the whole scene, for stable colours across zooms.
fn height_range(scene: &Scene) -> Option<(f32, f32)> {
    let mut lo = f32::INFINITY;
    let mut hi = f32::NEG_INFINITY;
    for s in scene.supports() {
        if s.kind == SupportKind::Branch {
            for n in &s.nodes {
                lo = lo.min(n.y);
                hi = hi.max(n.y);
            }
        }
    }
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi.max(lo + 0.01)))
}

/// Draws the top-down view. Never panics; an empty scene without sloths says "no data".
pub fn draw_topdown(input: &TopDown) -> Pixmap {
    let (w, h) = canvas_size(input);
    let mut pm = draw::canvas(w as u32, h as u32, c::BACKGROUND);
    let proj = topdown_projection(input);
    let heights = height_range(input.scene);
    let has_data = world_window(input).is_some();
    let [l, t, r, b] = proj.area_px;

    if has_data {
        fill_rect(&mut pm, l, t, r, b, c::PANEL);
        draw_map(&mut pm, &proj, input, heights);
    }

    // Cover anything drawn outside the map area, then the frame and furniture.
    fill_rect(&mut pm, 0.0, 0.0, w, t, c::BACKGROUND);
    fill_rect(&mut pm, 0.0, b, w, h, c::BACKGROUND);
    fill_rect(&mut pm, 0.0, t, l, b, c::BACKGROUND);
    fill_rect(&mut pm, r, t, w, b, c::BACKGROUND);
    frame_rect(&mut pm, l, t, r, b, c::TEXT_MUTED, 1.0);

    let focus = input
        .focus
        .and_then(|id| input.sloths.iter().find(|s| s.id == id))
        .filter(|s| s.body_pos.is_finite());
    // The inset only helps when the map itself is too coarse to show a sloth's limbs.
    if has_data
        && input.inset
        && input.view.is_none()
        && proj.scale_px_per_m < INSET_BELOW_PX_PER_M
        && let Some(f) = focus
    {
        draw_inset(&mut pm, &proj, input, f, heights);
    }

    let title = draw::title_line(
        &input.title,
        &format!(
            "t = {:.2} s \u{b7} {} sloths \u{b7} seed {}",
            input.time_s,
            input.sloths.len(),
            input.seed
        ),
    );
    draw::title(&mut pm, l, HEADER / 2.0, &title, w - l - 8.0);
    if !has_data {
        draw::no_data(&mut pm, l, t, r, b, "empty scene, no sloths");
    }
    draw_footer(&mut pm, &proj, heights, b, w);
    pm
}

/// Everything inside the map: supports, trails, sloths, focus ring and traces.
fn draw_map(pm: &mut Pixmap, proj: &MapProjection, input: &TopDown, heights: Option<(f32, f32)>) {
    let s = proj.scale_px_per_m;
    // Zoomed in, bottom to top as seen from above: bodies hang below their supports;
    // trails (of the body) are translucent over the supports so they stay visible;
    // limbs reach up around the supports. Zoomed out (a body is a few pixels), the
    // bodies go over supports and trails, or the crowd would vanish under them.
    let detailed = s >= INSET_BELOW_PX_PER_M;
    if detailed {
        draw_bodies(pm, proj, input.sloths);
    }
    draw_supports(pm, proj, input.scene, heights);
    if !input.trails.is_empty() {
        let mut trails = Batch::new();
        for trail in input.trails {
            trails.polyline(trail.iter().map(|p| proj.to_px(*p)));
        }
        trails.stroke(pm, c::TRAIL.with_alpha(110), (0.03 * s).clamp(1.0, 3.0));
    }
    if !detailed {
        draw_bodies(pm, proj, input.sloths);
    }
    draw_limbs(pm, proj, input.sloths);

    // Focus ring and traces on top of everything.
    if let Some(f) = input
        .focus
        .and_then(|id| input.sloths.iter().find(|x| x.id == id))
    {
        let mut ring = Batch::new();
        ring.circle(proj.to_px(f.body_pos), (1.0 * s).max(12.0));
        ring.stroke(pm, c::FOCUS, 2.0);
    }
    draw_traces(pm, proj, input.traces);
}

fn draw_traces(pm: &mut Pixmap, proj: &MapProjection, traces: &[TraceLine]) {
    let s = proj.scale_px_per_m;
    let width = (0.012 * s).clamp(1.0, 3.0);
    let (mut hits, mut misses, mut ends) = (Batch::new(), Batch::new(), Batch::new());
    for tr in traces {
        let (a, b) = (proj.to_px(tr.from), proj.to_px(tr.to));
        if tr.hit {
            hits.line(a, b);
            ends.dot(b, width * 1.5);
        } else {
            misses.line(a, b);
        }
    }
    misses.stroke(pm, c::TRACE_MISS, width);
    hits.stroke(pm, c::TRACE_HIT, width);
    ends.fill(pm, c::TRACE_HIT);
}

fn draw_supports(
    pm: &mut Pixmap,
    proj: &MapProjection,
    scene: &Scene,
    heights: Option<(f32, f32)>,
) {
    let s = proj.scale_px_per_m;
    let (hlo, hhi) = heights.unwrap_or((0.0, 1.0));
    // Branches batched by (height bin, width in half pixels): one stroke call per bucket.
    let mut buckets: BTreeMap<(usize, u32), Batch> = BTreeMap::new();
    let mut trunk_axes: BTreeMap<u32, Batch> = BTreeMap::new();
    let mut trunk_edge = Batch::new();
    let mut trunk_disc = Batch::new();
    for sup in scene.supports() {
        let trunk = sup.kind == SupportKind::Trunk;
        for (i, w) in sup.nodes.windows(2).enumerate() {
            let (a, b) = (proj.to_px(w[0]), proj.to_px(w[1]));
            let r = 0.5 * (sup.radii[i] + sup.radii[i + 1]);
            let width = (2.0 * r * s).max(if trunk { 2.0 } else { 1.0 });
            if !proj.inside(a, width) && !proj.inside(b, width) && !crosses(proj, a, b) {
                continue;
            }
            let wkey = (width * 2.0).round() as u32;
            if trunk {
                trunk_axes.entry(wkey).or_insert_with(Batch::new).line(a, b);
            } else {
                let hm = 0.5 * (w[0].y + w[1].y);
                let f = ((hm - hlo) / (hhi - hlo)).clamp(0.0, 1.0);
                let bin = ((f * HEIGHT_BINS as f32) as usize).min(HEIGHT_BINS - 1);
                buckets
                    .entry((bin, wkey))
                    .or_insert_with(Batch::new)
                    .line(a, b);
            }
        }
        if trunk && let (Some(n0), Some(r0)) = (sup.nodes.first(), sup.radii.first()) {
            let p = proj.to_px(*n0);
            if proj.inside(p, r0 * s + 4.0) {
                let rad = (r0 * s).max(2.5);
                trunk_edge.dot(p, rad + 1.5);
                trunk_disc.dot(p, rad);
            }
        }
    }
    trunk_edge.fill(pm, c::TRUNK_EDGE);
    for (wkey, batch) in trunk_axes {
        batch.stroke(pm, c::TRUNK.with_alpha(200), wkey as f32 * 0.5);
    }
    trunk_disc.fill(pm, c::TRUNK);
    for ((bin, wkey), batch) in buckets {
        let colour = ramp((bin as f32 + 0.5) / HEIGHT_BINS as f32);
        batch.stroke(pm, colour, wkey as f32 * 0.5);
    }
}

/// Whether a segment whose ends are both outside the map may still cross it (a cheap
/// bounding-box test).
fn crosses(proj: &MapProjection, a: (f32, f32), b: (f32, f32)) -> bool {
    let [l, t, r, btm] = proj.area_px;
    !(a.0.max(b.0) < l || a.0.min(b.0) > r || a.1.max(b.1) < t || a.1.min(b.1) > btm)
        && a.0.is_finite()
        && a.1.is_finite()
        && b.0.is_finite()
        && b.1.is_finite()
}

/// Sizes of sloth parts in pixels at scale `s` px/m.
struct SlothPx {
    body_r: f32,
    head_r: f32,
    limb_w: f32,
    grip_r: f32,
    markers: bool,
    pad: f32,
}

impl SlothPx {
    fn new(s: f32) -> Self {
        SlothPx {
            body_r: (0.13 * s).max(2.0),
            head_r: (0.08 * s).max(1.4),
            limb_w: (0.02 * s).clamp(1.0, 4.0),
            grip_r: (0.025 * s).clamp(1.5, 6.0),
            markers: s >= 40.0,
            pad: 2.0 * s + 10.0,
        }
    }
}

fn visible<'s>(
    proj: &MapProjection,
    sloths: &'s [SlothPose],
    pad: f32,
) -> impl Iterator<Item = &'s SlothPose> {
    sloths
        .iter()
        .filter(move |sl| sl.body_pos.is_finite() && proj.inside(proj.to_px(sl.body_pos), pad))
}

/// Bodies (a capsule from the hips to the neck, 3/4 of the way to the head, outlined)
/// and heads. Drawn *under* the supports: the sloths hang below their branches.
fn draw_bodies(pm: &mut Pixmap, proj: &MapProjection, sloths: &[SlothPose]) {
    let px = SlothPx::new(proj.scale_px_per_m);
    let (mut edge, mut body, mut heads) = (Batch::new(), Batch::new(), Batch::new());
    for sl in visible(proj, sloths, px.pad) {
        let neck = sl.hips_ws.lerp(sl.head_ws, 0.75);
        let (a, b) = (proj.to_px(sl.hips_ws), proj.to_px(neck));
        edge.capsule(a, b, px.body_r + 1.0);
        body.capsule(a, b, px.body_r);
        heads.dot(proj.to_px(sl.head_ws), px.head_r);
    }
    edge.fill(pm, c::SLOTH_EDGE);
    body.fill(pm, c::SLOTH_BODY);
    heads.fill(pm, c::SLOTH_HEAD);
}

/// Limbs (planted solid and dark, swinging dashed and lighter) and, when zoomed in,
/// grip markers (planted: filled dot; swing target: ring). Drawn over the supports.
fn draw_limbs(pm: &mut Pixmap, proj: &MapProjection, sloths: &[SlothPose]) {
    let s = proj.scale_px_per_m;
    let px = SlothPx::new(s);
    let (mut planted, mut swing) = (Batch::new(), Batch::new());
    let (mut grips, mut targets) = (Batch::new(), Batch::new());
    for sl in visible(proj, sloths, px.pad) {
        for limb in &sl.limbs {
            let pts = limb.joints_ws.iter().map(|p| proj.to_px(*p));
            if limb.planted {
                planted.polyline(pts);
                if px.markers {
                    grips.dot(proj.to_px(limb.grip_ws), px.grip_r);
                }
            } else {
                swing.polyline(pts);
                if px.markers {
                    targets.circle(proj.to_px(limb.grip_ws), px.grip_r);
                }
            }
        }
    }
    swing.stroke_dashed(
        pm,
        c::LIMB_SWING,
        px.limb_w,
        [(0.05 * s).max(3.0), (0.03 * s).max(2.0)],
    );
    targets.stroke(pm, c::LIMB_SWING, 1.5);
    planted.stroke(pm, c::LIMB_PLANTED, px.limb_w);
    grips.fill(pm, c::LIMB_PLANTED);
}

/// A zoomed copy of the map around the focus sloth, top-right in the map.
fn draw_inset(
    pm: &mut Pixmap,
    proj: &MapProjection,
    input: &TopDown,
    focus: &SlothPose,
    heights: Option<(f32, f32)>,
) {
    let [l, t, r, b] = proj.area_px;
    let side = ((r - l).min(b - t) * 0.34).floor();
    if side < 60.0 {
        return;
    }
    // World box: the sloth and its traces, at least 3 m across.
    let mut lo = Vec2::new(focus.body_pos.x, focus.body_pos.z);
    let mut hi = lo;
    for p in focus
        .points()
        .chain(input.traces.iter().flat_map(|t| [t.from, t.to]))
    {
        if p.is_finite() && p.distance(focus.body_pos) < 5.0 {
            lo = lo.min(Vec2::new(p.x, p.z));
            hi = hi.max(Vec2::new(p.x, p.z));
        }
    }
    let centre = (lo + hi) * 0.5;
    let half = ((hi - lo).max_element() * 0.5 + 0.4).max(1.5);
    let Some(mut sub) = Pixmap::new(side as u32, side as u32) else {
        return;
    };
    sub.fill(c::PANEL.color());
    let sub_proj = MapProjection::fit(
        centre - Vec2::splat(half),
        centre + Vec2::splat(half),
        [0.0, 0.0, side, side],
    );
    let one = std::slice::from_ref(focus);
    draw_bodies(&mut sub, &sub_proj, one);
    draw_supports(&mut sub, &sub_proj, input.scene, heights);
    draw_limbs(&mut sub, &sub_proj, one);
    draw_traces(&mut sub, &sub_proj, input.traces);
    // Scale bar inside the inset.
    let len = nice_floor(2.0 * half as f64 * 0.3) as f32;
    let px = len * sub_proj.scale_px_per_m;
    let mut bar = Batch::new();
    bar.polyline([
        (8.0, side - 18.0),
        (8.0, side - 12.0),
        (8.0 + px, side - 12.0),
        (8.0 + px, side - 18.0),
    ]);
    bar.stroke(&mut sub, c::TEXT, 2.0);
    label(
        &mut sub,
        14.0 + px,
        side - 14.0,
        &format!("{len} m"),
        1,
        c::TEXT,
        Align::Left,
    );

    // The corner of the map that hides the least: fewest sloths and support nodes.
    let corners = [
        (r - side - 8.0, t + 8.0),
        (l + 8.0, t + 8.0),
        (r - side - 8.0, b - side - 30.0),
        (l + 8.0, b - side - 30.0),
    ];
    let cost = |&(x0, y0): &(f32, f32)| {
        let inside = |(x, y): (f32, f32)| {
            x >= x0 - 4.0 && x <= x0 + side + 4.0 && y >= y0 - 4.0 && y <= y0 + side + 24.0
        };
        let sloths = input
            .sloths
            .iter()
            .filter(|s| inside(proj.to_px(s.body_pos)))
            .count();
        let nodes = input
            .scene
            .supports()
            .iter()
            .flat_map(|s| &s.nodes)
            .filter(|n| inside(proj.to_px(**n)))
            .count();
        // The focus sloth itself must stay visible.
        let covers_focus = inside(proj.to_px(focus.body_pos));
        sloths * 4 + nodes + if covers_focus { 1_000_000 } else { 0 }
    };
    let (x0, y0) = corners
        .iter()
        .copied()
        .min_by_key(cost)
        .unwrap_or(corners[0]);
    pm.draw_pixmap(
        x0 as i32,
        y0 as i32,
        sub.as_ref(),
        &PixmapPaint::default(),
        Transform::identity(),
        None,
    );
    frame_rect(
        pm,
        x0.round(),
        y0.round(),
        x0.round() + side,
        y0.round() + side,
        c::FOCUS,
        2.0,
    );
    label_boxed(
        pm,
        x0 + 6.0,
        y0 + side + 14.0,
        &format!("sloth {} (zoom)", focus.id),
        1,
        [c::TEXT, c::PANEL],
    );
}

fn draw_footer(
    pm: &mut Pixmap,
    proj: &MapProjection,
    heights: Option<(f32, f32)>,
    top: f32,
    w: f32,
) {
    let y = top + FOOTER / 2.0 + 4.0;
    let x = proj.area_px[0];
    // Scale bar: a round length near a fifth of the map width.
    let map_w_m = (proj.area_px[2] - proj.area_px[0]) / proj.scale_px_per_m;
    let len = nice_floor(map_w_m as f64 * 0.15) as f32;
    let px = len * proj.scale_px_per_m;
    let mut bar = Batch::new();
    bar.polyline([(x, y - 6.0), (x, y), (x + px, y), (x + px, y - 6.0)]);
    bar.stroke(pm, c::TEXT, 2.0);
    label(
        pm,
        x + px / 2.0,
        y + 12.0,
        &format!("{len} m"),
        2,
        c::TEXT,
        Align::Center,
    );

    // Height legend.
    let mut lx = x + px.max(60.0) + 40.0;
    if let Some((lo, hi)) = heights {
        label(pm, lx, y - 16.0, "branch height", 1, c::TEXT, Align::Left);
        let bw = 200.0;
        for i in 0..bw as usize {
            let col = ramp(i as f32 / (bw - 1.0));
            fill_rect(
                pm,
                lx + i as f32,
                y - 8.0,
                lx + i as f32 + 1.0,
                y + 6.0,
                col,
            );
        }
        label(
            pm,
            lx,
            y + 16.0,
            &format!("{lo:.1} m"),
            1,
            c::TEXT,
            Align::Left,
        );
        label(
            pm,
            lx + bw,
            y + 16.0,
            &format!("{hi:.1} m"),
            1,
            c::TEXT,
            Align::Right,
        );
        lx += bw + 40.0;
    }

    // Symbol legend.
    let items: [(&str, u8); 6] = [
        ("trunk", 0),
        ("sloth (pale = head)", 1),
        ("planted limb", 2),
        ("swinging limb", 3),
        ("trace hit", 4),
        ("trace miss", 5),
    ];
    let mut ix = lx;
    let mut iy = y - 10.0;
    for (name, kind) in items {
        let item_w = 30.0 + draw::text_width(name, 1) + 20.0;
        if ix + item_w > w - 150.0 {
            ix = lx;
            iy += 20.0;
        }
        let mut sw = Batch::new();
        match kind {
            0 => {
                sw.circle((ix + 10.0, iy), 5.0);
                sw.fill(pm, c::TRUNK);
            }
            1 => {
                sw.line((ix + 2.0, iy), (ix + 16.0, iy));
                sw.stroke(pm, c::SLOTH_BODY, 7.0);
                let mut hd = Batch::new();
                hd.circle((ix + 20.0, iy), 3.0);
                hd.fill(pm, c::SLOTH_HEAD);
            }
            2 => {
                sw.line((ix, iy), (ix + 22.0, iy));
                sw.stroke(pm, c::LIMB_PLANTED, 2.0);
            }
            3 => {
                sw.line((ix, iy), (ix + 22.0, iy));
                sw.stroke_dashed(pm, c::LIMB_SWING, 2.0, [4.0, 3.0]);
            }
            4 => {
                sw.line((ix, iy), (ix + 22.0, iy));
                sw.stroke(pm, c::TRACE_HIT, 2.0);
            }
            _ => {
                sw.line((ix, iy), (ix + 22.0, iy));
                sw.stroke(pm, c::TRACE_MISS, 2.0);
            }
        }
        label(pm, ix + 28.0, iy, name, 1, c::TEXT, Align::Left);
        ix += item_w;
    }

    // Compass: +X right, +Z down.
    let (cx, cy) = (w - 100.0, y - 4.0);
    let mut arrows = Batch::new();
    arrows.polyline([(cx, cy), (cx + 30.0, cy)]);
    arrows.polyline([
        (cx + 24.0, cy - 4.0),
        (cx + 30.0, cy),
        (cx + 24.0, cy + 4.0),
    ]);
    arrows.polyline([(cx, cy), (cx, cy + 24.0)]);
    arrows.polyline([
        (cx - 4.0, cy + 18.0),
        (cx, cy + 24.0),
        (cx + 4.0, cy + 18.0),
    ]);
    arrows.stroke(pm, c::TEXT, 1.5);
    label(pm, cx + 34.0, cy, "+X", 1, c::TEXT, Align::Left);
    label(pm, cx + 8.0, cy + 22.0, "+Z", 1, c::TEXT, Align::Left);
    label(
        pm,
        cx - 8.0,
        cy - 14.0,
        "top view (-Y)",
        1,
        c::TEXT_MUTED,
        Align::Left,
    );
}
