//! Shared drawing helpers: colours, batched paths, bitmap text, axis ticks.
//!
//! Every helper skips non-finite coordinates, so no NaN ever reaches tiny-skia.

use tiny_skia::{
    Color, FillRule, LineCap, LineJoin, Paint, Path, PathBuilder, Pixmap, PremultipliedColorU8,
    Rect, Stroke, StrokeDash, Transform,
};

/// Largest canvas side we draw (pixels); requested sizes are clamped to `MIN_SIDE..=MAX_SIDE`.
pub const MAX_SIDE: u32 = 8192;
/// Smallest canvas side we draw (pixels).
pub const MIN_SIDE: u32 = 64;

/// Screen coordinates farther out than this are clamped (tiny-skia paths stay sane).
const FAR: f32 = 1.0e6;

/// An sRGB colour with alpha.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Rgba(pub u8, pub u8, pub u8, pub u8);

impl Rgba {
    /// Opaque colour.
    pub const fn rgb(r: u8, g: u8, b: u8) -> Rgba {
        Rgba(r, g, b, 255)
    }

    /// Same colour with another alpha.
    pub const fn with_alpha(self, a: u8) -> Rgba {
        Rgba(self.0, self.1, self.2, a)
    }

    /// The opaque colour this one gives over `bg` (for bitmap text, which is opaque).
    pub fn over(self, bg: Rgba) -> Rgba {
        let a = self.3 as f32 / 255.0;
        let mix = |f: u8, b: u8| (f as f32 * a + b as f32 * (1.0 - a)).round() as u8;
        Rgba::rgb(mix(self.0, bg.0), mix(self.1, bg.1), mix(self.2, bg.2))
    }

    pub(crate) fn color(self) -> Color {
        Color::from_rgba8(self.0, self.1, self.2, self.3)
    }
}

/// A fresh canvas filled with `bg`; sides clamped to `MIN_SIDE..=MAX_SIDE`.
pub(crate) fn canvas(width: u32, height: u32, bg: Rgba) -> Pixmap {
    let w = width.clamp(MIN_SIDE, MAX_SIDE);
    let h = height.clamp(MIN_SIDE, MAX_SIDE);
    let mut pm = Pixmap::new(w, h).expect("clamped size is valid");
    pm.fill(bg.color());
    pm
}

pub(crate) fn paint(c: Rgba) -> Paint<'static> {
    let mut p = Paint::default();
    p.set_color(c.color());
    p.anti_alias = true;
    p
}

fn finite(x: f32, y: f32) -> Option<(f32, f32)> {
    (x.is_finite() && y.is_finite()).then(|| (x.clamp(-FAR, FAR), y.clamp(-FAR, FAR)))
}

/// Many sub-paths collected into one path, drawn with one call (the fast way to draw
/// thousands of sloths with tiny-skia).
pub(crate) struct Batch {
    pb: PathBuilder,
    empty: bool,
}

impl Batch {
    pub fn new() -> Self {
        Batch {
            pb: PathBuilder::new(),
            empty: true,
        }
    }

    /// A polyline; non-finite points split it.
    pub fn polyline(&mut self, pts: impl IntoIterator<Item = (f32, f32)>) {
        let mut open = false;
        for (x, y) in pts {
            match finite(x, y) {
                Some((x, y)) if open => self.pb.line_to(x, y),
                Some((x, y)) => {
                    self.pb.move_to(x, y);
                    open = true;
                }
                None => open = false,
            }
        }
        self.empty = false;
    }

    /// One segment.
    pub fn line(&mut self, a: (f32, f32), b: (f32, f32)) {
        self.polyline([a, b]);
    }

    /// A closed polygon (for fills); skipped if any point is non-finite. Every polygon
    /// is emitted clockwise on screen, like tiny-skia's circles, so overlapping shapes
    /// of one batch add up under the non-zero rule instead of cancelling into holes.
    pub fn polygon(&mut self, pts: &[(f32, f32)]) {
        if pts.len() < 3 || pts.iter().any(|p| finite(p.0, p.1).is_none()) {
            return;
        }
        let twice_area: f32 = pts
            .iter()
            .zip(pts.iter().cycle().skip(1))
            .map(|(a, b)| a.0 * b.1 - b.0 * a.1)
            .sum();
        let mut emit = |i: usize, first: bool| {
            let p = pts[i];
            if first {
                self.pb.move_to(p.0, p.1);
            } else {
                self.pb.line_to(p.0, p.1);
            }
        };
        if twice_area >= 0.0 {
            (0..pts.len()).for_each(|i| emit(i, i == 0));
        } else {
            (0..pts.len())
                .rev()
                .for_each(|i| emit(i, i == pts.len() - 1));
        }
        self.pb.close();
        self.empty = false;
    }

    pub fn circle(&mut self, c: (f32, f32), r: f32) {
        if let Some((x, y)) = finite(c.0, c.1)
            && r.is_finite()
            && r > 0.0
        {
            self.pb.push_circle(x, y, r);
            self.empty = false;
        }
    }

    /// A disc: a polygon when small (much cheaper for tiny-skia than conic circles,
    /// and indistinguishable below a few pixels), else a true circle.
    pub fn dot(&mut self, c: (f32, f32), r: f32) {
        if !(r.is_finite() && r > 0.0) {
            return;
        }
        if r >= 6.0 {
            self.circle(c, r);
            return;
        }
        const N: usize = 8;
        let pts: [(f32, f32); N] = std::array::from_fn(|i| {
            let a = i as f32 * std::f32::consts::TAU / N as f32;
            (c.0 + r * a.cos(), c.1 + r * a.sin())
        });
        self.polygon(&pts);
    }

    /// A filled capsule (stadium) from `a` to `b` with radius `r`, as one polygon.
    pub fn capsule(&mut self, a: (f32, f32), b: (f32, f32), r: f32) {
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        let len = dx.hypot(dy);
        if !(len.is_finite() && r.is_finite()) || r <= 0.0 {
            return;
        }
        if len < 1e-3 {
            self.dot(a, r);
            return;
        }
        // Half-circle steps: more when large.
        let steps = if r < 4.0 {
            4
        } else if r < 12.0 {
            8
        } else {
            16
        };
        let base = dy.atan2(dx);
        let mut pts = Vec::with_capacity(2 * steps + 2);
        for (centre, start) in [
            (b, base - std::f32::consts::FRAC_PI_2),
            (a, base + std::f32::consts::FRAC_PI_2),
        ] {
            for i in 0..=steps {
                let ang = start + std::f32::consts::PI * i as f32 / steps as f32;
                pts.push((centre.0 + r * ang.cos(), centre.1 + r * ang.sin()));
            }
        }
        self.polygon(&pts);
    }

    pub fn rect(&mut self, x0: f32, y0: f32, x1: f32, y1: f32) {
        if let Some(r) = rect(x0, y0, x1, y1) {
            self.pb.push_rect(r);
            self.empty = false;
        }
    }

    fn finish(self) -> Option<Path> {
        if self.empty {
            return None;
        }
        self.pb.finish()
    }

    pub fn fill(self, pm: &mut Pixmap, c: Rgba) {
        if let Some(path) = self.finish() {
            fill_path(pm, &path, c);
        }
    }

    /// Fill without anti-aliasing (crisp chart bars).
    pub fn fill_crisp(self, pm: &mut Pixmap, c: Rgba) {
        if let Some(path) = self.finish() {
            let mut p = paint(c);
            p.anti_alias = false;
            pm.fill_path(&path, &p, FillRule::Winding, Transform::identity(), None);
        }
    }

    pub fn stroke(self, pm: &mut Pixmap, c: Rgba, width: f32) {
        self.stroke_styled(pm, c, width, None);
    }

    pub fn stroke_dashed(self, pm: &mut Pixmap, c: Rgba, width: f32, dash: [f32; 2]) {
        self.stroke_styled(pm, c, width, Some(dash));
    }

    fn stroke_styled(self, pm: &mut Pixmap, c: Rgba, width: f32, dash: Option<[f32; 2]>) {
        if let Some(path) = self.finish() {
            stroke_path(pm, &path, c, width, dash);
        }
    }
}

/// Fills a finished path (anti-aliased, non-zero winding).
pub(crate) fn fill_path(pm: &mut Pixmap, path: &Path, c: Rgba) {
    pm.fill_path(
        path,
        &paint(c),
        FillRule::Winding,
        Transform::identity(),
        None,
    );
}

/// Strokes a finished path (round caps and joins; butt caps when dashed).
pub(crate) fn stroke_path(
    pm: &mut Pixmap,
    path: &Path,
    c: Rgba,
    width: f32,
    dash: Option<[f32; 2]>,
) {
    let stroke = Stroke {
        width: width.max(0.1),
        line_cap: if dash.is_some() {
            LineCap::Butt
        } else {
            LineCap::Round
        },
        line_join: LineJoin::Round,
        dash: dash.and_then(|d| StrokeDash::new(d.to_vec(), 0.0)),
        ..Stroke::default()
    };
    pm.stroke_path(path, &paint(c), &stroke, Transform::identity(), None);
}

pub(crate) fn rect(x0: f32, y0: f32, x1: f32, y1: f32) -> Option<Rect> {
    let (x0, y0) = finite(x0, y0)?;
    let (x1, y1) = finite(x1, y1)?;
    Rect::from_ltrb(x0.min(x1), y0.min(y1), x0.max(x1), y0.max(y1))
}

/// Fills an axis-aligned rectangle (no anti-aliasing).
pub(crate) fn fill_rect(pm: &mut Pixmap, x0: f32, y0: f32, x1: f32, y1: f32, c: Rgba) {
    if let Some(r) = rect(x0, y0, x1, y1) {
        let mut p = paint(c);
        p.anti_alias = false;
        pm.fill_rect(r, &p, Transform::identity(), None);
    }
}

/// A rectangle outline.
pub(crate) fn frame_rect(pm: &mut Pixmap, x0: f32, y0: f32, x1: f32, y1: f32, c: Rgba, w: f32) {
    let mut b = Batch::new();
    b.polyline([(x0, y0), (x1, y0), (x1, y1), (x0, y1), (x0, y0)]);
    b.stroke(pm, c, w);
}

// ---------------------------------------------------------------------------------------
// Bitmap text (font8x8, scaled by an integer factor, written straight into the pixels).

/// Glyph cell size (pixels) at scale 1.
pub(crate) const GLYPH: u32 = 8;

fn glyph(ch: char) -> [u8; 8] {
    let c = ch as u32;
    if c < 128 {
        font8x8::legacy::BASIC_LEGACY[c as usize]
    } else if (0xA0..0x100).contains(&c) {
        font8x8::legacy::LATIN_LEGACY[(c - 0xA0) as usize]
    } else if ch == '–' || ch == '—' || ch == '−' {
        font8x8::legacy::BASIC_LEGACY['-' as usize]
    } else {
        font8x8::legacy::BASIC_LEGACY['?' as usize]
    }
}

/// Width in pixels of `s` at `scale`.
pub(crate) fn text_width(s: &str, scale: u32) -> f32 {
    (s.chars().count() as u32 * GLYPH * scale) as f32
}

/// Height in pixels of one text line at `scale`.
pub(crate) fn text_height(scale: u32) -> f32 {
    (GLYPH * scale) as f32
}

/// Draws `s` with its top-left corner at (x, y), opaque colour `c`. Returns the width.
pub(crate) fn text(pm: &mut Pixmap, x: f32, y: f32, s: &str, scale: u32, c: Rgba) -> f32 {
    if !x.is_finite() || !y.is_finite() {
        return 0.0;
    }
    let scale = scale.max(1) as i64;
    let (w, h) = (pm.width() as i64, pm.height() as i64);
    let px = PremultipliedColorU8::from_rgba(c.0, c.1, c.2, 255).expect("opaque is valid");
    let pixels = pm.pixels_mut();
    let (x0, y0) = (x.round() as i64, y.round() as i64);
    for (i, ch) in s.chars().enumerate() {
        let g = glyph(ch);
        let gx = x0 + i as i64 * 8 * scale;
        for (row, bits) in g.iter().enumerate() {
            for col in 0..8 {
                if bits & (1 << col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    let py = y0 + row as i64 * scale + dy;
                    if py < 0 || py >= h {
                        continue;
                    }
                    for dx in 0..scale {
                        let pxx = gx + col as i64 * scale + dx;
                        if pxx >= 0 && pxx < w {
                            pixels[(py * w + pxx) as usize] = px;
                        }
                    }
                }
            }
        }
    }
    text_width(s, scale as u32)
}

/// Horizontal text alignment.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Align {
    Left,
    Center,
    Right,
}

/// Text positioned by its anchor: x by `align`, y = vertical centre.
pub(crate) fn label(pm: &mut Pixmap, x: f32, y: f32, s: &str, scale: u32, c: Rgba, a: Align) {
    let w = text_width(s, scale);
    let x = match a {
        Align::Left => x,
        Align::Center => x - w / 2.0,
        Align::Right => x - w,
    };
    text(pm, x, y - text_height(scale) / 2.0, s, scale, c);
}

/// A plot's title line: the caller's `prefix` (e.g. the run's name), then
/// what the plot shows, joined by a middle dot when there is a prefix.
pub(crate) fn title_line(prefix: &str, what: &str) -> String {
    if prefix.is_empty() {
        what.to_string()
    } else {
        format!("{prefix}  \u{b7}  {what}")
    }
}

/// A plot title at (x, centre y): double size if it fits in `max_w` pixels, else single.
pub(crate) fn title(pm: &mut Pixmap, x: f32, y: f32, s: &str, max_w: f32) {
    let scale = if text_width(s, 2) <= max_w { 2 } else { 1 };
    label(pm, x, y, s, scale, crate::colors::TEXT, Align::Left);
}

/// Left-aligned text on a filled box (readable over busy map content); y = centre.
pub(crate) fn label_boxed(pm: &mut Pixmap, x: f32, y: f32, s: &str, scale: u32, colors: [Rgba; 2]) {
    let [fg, bg] = colors;
    let w = text_width(s, scale);
    let h = text_height(scale);
    fill_rect(
        pm,
        x - 3.0,
        y - h / 2.0 - 3.0,
        x + w + 3.0,
        y + h / 2.0 + 3.0,
        bg,
    );
    text(pm, x, y - h / 2.0, s, scale, fg);
}

/// The "no data" label, centred in the given box.
pub(crate) fn no_data(pm: &mut Pixmap, x0: f32, y0: f32, x1: f32, y1: f32, what: &str) {
    let s = format!("no data ({what})");
    label(
        pm,
        (x0 + x1) / 2.0,
        (y0 + y1) / 2.0,
        &s,
        2,
        crate::colors::TEXT_MUTED,
        Align::Center,
    );
}

// ---------------------------------------------------------------------------------------
// Numbers and axes.

/// A "nice" step (1, 2 or 5 × 10^k) so that `span` holds about `target` steps.
pub(crate) fn nice_step(span: f64, target: f64) -> f64 {
    if !(span.is_finite() && span > 0.0) {
        return 1.0;
    }
    let raw = span / target.max(1.0);
    let mag = 10f64.powf(raw.log10().floor());
    let norm = raw / mag;
    let nice = if norm < 1.5 {
        1.0
    } else if norm < 3.5 {
        2.0
    } else if norm < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * mag
}

/// The largest 1/2/5 × 10^k not above `x` (for scale bars).
pub(crate) fn nice_floor(x: f64) -> f64 {
    if !(x.is_finite() && x > 0.0) {
        return 1.0;
    }
    let mag = 10f64.powf(x.log10().floor());
    let norm = x / mag;
    let n = if norm >= 5.0 {
        5.0
    } else if norm >= 2.0 {
        2.0
    } else {
        1.0
    };
    n * mag
}

/// Formats a tick value with just enough decimals for `step`.
pub(crate) fn fmt_tick(v: f64, step: f64) -> String {
    let decimals = if step >= 1.0 {
        0
    } else {
        (-step.log10().floor()) as usize
    };
    let v = if v.abs() < step * 1e-6 { 0.0 } else { v };
    format!("{v:.decimals$}")
}

/// Ticks of `step` inside `[lo, hi]`.
pub(crate) fn ticks(lo: f64, hi: f64, step: f64) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite() && step > 0.0) || hi < lo {
        return Vec::new();
    }
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    if last - first > 1000 {
        return Vec::new();
    }
    (first..=last).map(|i| i as f64 * step).collect()
}

pub(crate) use slothsim_scene::percentile_sorted;

/// The height colour ramp (a cividis-like blue → grey → yellow; no red or green so trace
/// and sloth colours stay distinct). `t` in 0..=1.
pub(crate) fn ramp(t: f32) -> Rgba {
    const STOPS: [(f32, [f32; 3]); 5] = [
        (0.0, [0.0, 40.0, 100.0]),
        (0.25, [60.0, 77.0, 110.0]),
        (0.5, [124.0, 123.0, 120.0]),
        (0.75, [188.0, 175.0, 111.0]),
        (1.0, [232.0, 192.0, 20.0]),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.5
    };
    for w in STOPS.windows(2) {
        let (t0, c0) = w[0];
        let (t1, c1) = w[1];
        if t <= t1 {
            let f = (t - t0) / (t1 - t0);
            let m = |i: usize| (c0[i] + (c1[i] - c0[i]) * f).round() as u8;
            return Rgba::rgb(m(0), m(1), m(2));
        }
    }
    Rgba::rgb(232, 192, 20)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nice_numbers() {
        assert_eq!(nice_step(10.0, 5.0), 2.0);
        assert_eq!(nice_step(80.0, 8.0), 10.0);
        assert_eq!(nice_step(0.3, 3.0), 0.1);
        assert_eq!(nice_floor(17.0), 10.0);
        assert_eq!(nice_floor(0.3), 0.2);
        assert_eq!(fmt_tick(0.30000001, 0.1), "0.3");
        assert_eq!(fmt_tick(20.0, 10.0), "20");
        assert_eq!(ticks(0.0, 1.0, 0.5), vec![0.0, 0.5, 1.0]);
        assert!(ticks(f64::NAN, 1.0, 0.5).is_empty());
    }

    #[test]
    fn percentiles() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile_sorted(&v, 0.5), Some(50.0));
        assert_eq!(percentile_sorted(&v, 0.95), Some(95.0));
        assert_eq!(percentile_sorted(&[], 0.5), None);
    }

    #[test]
    fn overlapping_shapes_do_not_cancel() {
        // A counter-clockwise quad over a circle: both must stay filled.
        let mut pm = canvas(64, 64, Rgba::rgb(255, 255, 255));
        let mut b = Batch::new();
        b.circle((32.0, 32.0), 12.0);
        b.polygon(&[(20.0, 20.0), (20.0, 44.0), (44.0, 44.0), (44.0, 20.0)]);
        b.polygon(&[(30.0, 30.0), (30.0, 34.0), (34.0, 34.0), (34.0, 30.0)]);
        b.fill(&mut pm, Rgba::rgb(0, 0, 0));
        let px = pm.pixel(32, 32).unwrap();
        assert_eq!((px.red(), px.green(), px.blue()), (0, 0, 0));
    }

    #[test]
    fn ramp_ends() {
        assert_eq!(ramp(0.0), Rgba::rgb(0, 40, 100));
        assert_eq!(ramp(1.0), Rgba::rgb(232, 192, 20));
        assert_eq!(ramp(f32::NAN), ramp(0.5));
    }
}
