//! Frame-time chart: per-frame stacked stage times, the frame budget band, p50 and p95
//! of the total frame time.

use tiny_skia::Pixmap;

use crate::colors as c;
use crate::draw::{
    self, Align, Batch, fill_rect, fmt_tick, frame_rect, label, label_boxed, nice_step,
    percentile_sorted, ticks,
};

const HEADER: f32 = 40.0;
const FOOTER: f32 = 70.0;
const LEFT: f32 = 70.0;
const RIGHT: f32 = 150.0;

/// Number of stages of the tick (columns of a frame's times).
pub const STAGE_COUNT: usize = 6;

/// The tick's six stages, in schedule order (the default stage names).
pub const DEFAULT_STAGES: [&str; STAGE_COUNT] = [
    "Trace",
    "StepSearch",
    "BodyAverage",
    "CcdSolve",
    "GripLoad",
    "Transitions",
];

/// Input of [`draw_frame_times`].
#[derive(Clone)]
pub struct FrameTimes<'a> {
    /// Title prefix.
    pub title: String,
    /// Stage names, bottom of the stack first.
    pub stage_names: [&'a str; STAGE_COUNT],
    /// Per frame, the wall time of each stage (milliseconds). Non-finite or negative
    /// values count as 0.
    pub frames_ms: &'a [[f64; STAGE_COUNT]],
    /// The frame budget band (ms), shaded; default 12–14 ms (the thesis's one sloth).
    pub budget_ms: (f32, f32),
    /// Canvas width in pixels (clamped to `MIN_SIDE..=MAX_SIDE`).
    pub width: u32,
    /// Canvas height in pixels.
    pub height: u32,
}

impl<'a> FrameTimes<'a> {
    /// Default stage names, 12–14 ms budget, 1400 × 700 px.
    pub fn new(frames_ms: &'a [[f64; STAGE_COUNT]]) -> Self {
        FrameTimes {
            title: String::from("frame times"),
            stage_names: DEFAULT_STAGES,
            frames_ms,
            budget_ms: (12.0, 14.0),
            width: 1400,
            height: 700,
        }
    }
}

/// Where things are in a frame-time chart, and its statistics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameTimesLayout {
    /// Plot area (left, top, right, bottom) pixels.
    pub plot_px: [f32; 4],
    /// Top of the y axis (ms); the bottom is 0.
    pub y_max_ms: f64,
    /// Median total frame time (ms), `None` without frames.
    pub p50_ms: Option<f64>,
    /// 95th percentile (nearest rank) of the total frame time.
    pub p95_ms: Option<f64>,
}

impl FrameTimesLayout {
    /// Pixel y of a time in ms.
    pub fn y_of(&self, ms: f64) -> f32 {
        let [_, t, _, b] = self.plot_px;
        b - (ms / self.y_max_ms) as f32 * (b - t)
    }
}

fn clean(v: f64) -> f64 {
    if v.is_finite() && v > 0.0 { v } else { 0.0 }
}

fn budget(ft: &FrameTimes) -> Option<(f64, f64)> {
    let (a, b) = ft.budget_ms;
    (a.is_finite() && b.is_finite() && a >= 0.0 && b >= 0.0)
        .then(|| (a.min(b) as f64, a.max(b) as f64))
}

/// The layout and statistics [`draw_frame_times`] uses.
pub fn frame_times_layout(ft: &FrameTimes) -> FrameTimesLayout {
    let w = ft.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let h = ft.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let plot = [LEFT, HEADER, w - RIGHT, h - FOOTER];
    let mut totals: Vec<f64> = ft
        .frames_ms
        .iter()
        .map(|f| f.iter().copied().map(clean).sum())
        .collect();
    totals.sort_by(f64::total_cmp);
    let p50 = percentile_sorted(&totals, 0.5);
    let p95 = percentile_sorted(&totals, 0.95);
    let max = totals.last().copied().unwrap_or(0.0);
    let top = max.max(budget(ft).map(|b| b.1).unwrap_or(0.0));
    let y_max = if top > 0.0 { top * 1.12 } else { 1.0 };
    FrameTimesLayout {
        plot_px: plot,
        y_max_ms: y_max,
        p50_ms: p50,
        p95_ms: p95,
    }
}

/// Draws the chart. More frames than pixel columns are averaged per column (each stage's
/// mean over the frames of that column). Never panics; no frames gives "no data".
pub fn draw_frame_times(ft: &FrameTimes) -> Pixmap {
    let w = ft.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE);
    let h = ft.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE);
    let mut pm = draw::canvas(w, h, c::BACKGROUND);
    let lay = frame_times_layout(ft);
    let [l, t, r, b] = lay.plot_px;
    fill_rect(&mut pm, l, t, r, b, c::PANEL);
    let n = ft.frames_ms.len();

    // Budget band (behind the bars; its edges are redrawn on top).
    let band = budget(ft);
    if let Some((lo, hi)) = band {
        fill_rect(&mut pm, l, lay.y_of(hi), r, lay.y_of(lo), c::BUDGET_BAND);
    }
    // Y grid and ticks.
    let step = nice_step(lay.y_max_ms, 8.0);
    let yt = ticks(0.0, lay.y_max_ms, step);
    let mut grid = Batch::new();
    for v in &yt {
        grid.line((l, lay.y_of(*v)), (r, lay.y_of(*v)));
    }
    grid.stroke(&mut pm, c::GRID, 1.0);
    for v in &yt {
        label(
            &mut pm,
            l - 8.0,
            lay.y_of(*v),
            &fmt_tick(*v, step),
            1,
            c::TEXT,
            Align::Right,
        );
    }

    if n > 0 {
        // Stacked bars, one column per frame (or per group of frames).
        let width_px = (r - l).max(1.0);
        let cols = (n as f32).min(width_px.floor()).max(1.0) as usize;
        let mut stages: [Batch; STAGE_COUNT] = std::array::from_fn(|_| Batch::new());
        for col in 0..cols {
            let f0 = col * n / cols;
            let f1 = ((col + 1) * n / cols).max(f0 + 1);
            let mut mean = [0.0f64; STAGE_COUNT];
            for f in &ft.frames_ms[f0..f1] {
                for (m, v) in mean.iter_mut().zip(f) {
                    *m += clean(*v);
                }
            }
            let x0 = l + col as f32 * width_px / cols as f32;
            let x1 = l + (col + 1) as f32 * width_px / cols as f32;
            // A 1 px gap between bars when they are wide enough to show it.
            let x1g = if x1 - x0 >= 4.0 { x1 - 1.0 } else { x1 };
            let mut acc = 0.0;
            for (k, m) in mean.iter().enumerate() {
                let v = m / (f1 - f0) as f64;
                if v > 0.0 {
                    stages[k].rect(x0, lay.y_of(acc + v), x1g, lay.y_of(acc));
                }
                acc += v;
            }
        }
        for (k, batch) in stages.into_iter().enumerate() {
            batch.fill_crisp(&mut pm, c::STAGES[k]);
        }
        // X ticks: frame numbers.
        let xstep = nice_step(n as f64, 10.0).max(1.0);
        for v in ticks(0.0, n as f64, xstep) {
            let x = l + (v as f32 / n as f32) * width_px;
            let mut tk = Batch::new();
            tk.line((x, b), (x, b + 5.0));
            tk.stroke(&mut pm, c::TEXT, 1.0);
            label(
                &mut pm,
                x,
                b + 14.0,
                &fmt_tick(v, xstep),
                1,
                c::TEXT,
                Align::Center,
            );
        }
    } else {
        draw::no_data(&mut pm, l, t, r, b, "no frames");
    }

    if let Some((lo, hi)) = band {
        let mut edges = Batch::new();
        edges.line((l, lay.y_of(lo)), (r, lay.y_of(lo)));
        edges.line((l, lay.y_of(hi)), (r, lay.y_of(hi)));
        edges.stroke_dashed(&mut pm, c::BUDGET_BAND.over(c::TEXT_MUTED), 1.0, [6.0, 4.0]);
        label(
            &mut pm,
            r + 8.0,
            lay.y_of((lo + hi) / 2.0),
            &format!("budget {lo}-{hi} ms"),
            1,
            c::TEXT,
            Align::Left,
        );
    }
    // Percentile lines, labelled at the right margin (nudged apart if they overlap).
    let mut last_label_y = f32::NEG_INFINITY;
    for (name, value, colour, dashed) in [
        ("p50", lay.p50_ms, c::P50, false),
        ("p95", lay.p95_ms, c::P95, true),
    ] {
        let Some(v) = value else { continue };
        let y = lay.y_of(v);
        let mut line = Batch::new();
        line.line((l, y), (r, y));
        if dashed {
            line.stroke_dashed(&mut pm, colour, 2.0, [8.0, 4.0]);
        } else {
            line.stroke(&mut pm, colour, 2.0);
        }
        let mut ly = y;
        if (ly - last_label_y).abs() < 14.0 {
            ly = last_label_y - 14.0;
        }
        last_label_y = ly;
        label_boxed(
            &mut pm,
            r + 8.0,
            ly,
            &format!("{name} {v:.2} ms"),
            1,
            [colour, c::BACKGROUND],
        );
    }

    frame_rect(&mut pm, l, t, r, b, c::TEXT_MUTED, 1.0);
    label(&mut pm, 8.0, t - 12.0, "ms", 1, c::TEXT, Align::Left);
    label(
        &mut pm,
        (l + r) / 2.0,
        b + 30.0,
        "frame",
        1,
        c::TEXT,
        Align::Center,
    );
    // Stage legend.
    let mut x = l;
    let y = b + 52.0;
    for (k, name) in ft.stage_names.iter().enumerate() {
        fill_rect(&mut pm, x, y - 6.0, x + 14.0, y + 6.0, c::STAGES[k]);
        x += 20.0 + label_w(&mut pm, x + 20.0, y, name) + 26.0;
    }
    let mean = if n > 0 {
        ft.frames_ms
            .iter()
            .map(|f| f.iter().copied().map(clean).sum::<f64>())
            .sum::<f64>()
            / n as f64
    } else {
        0.0
    };
    let title = draw::title_line(
        &ft.title,
        &format!("{n} frames \u{b7} mean {mean:.2} ms/frame \u{b7} stacked by stage"),
    );
    draw::title(&mut pm, l, HEADER / 2.0, &title, w as f32 - l - 8.0);
    pm
}

fn label_w(pm: &mut Pixmap, x: f32, y: f32, s: &str) -> f32 {
    label(pm, x, y, s, 1, c::TEXT, Align::Left);
    draw::text_width(s, 1)
}
