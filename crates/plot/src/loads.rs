//! Grip-load chart (issue 22): the force each limb's grip carries over time, stacked
//! (LF, RF, LH, RH from the bottom, in body weights), with the residual wrench as a line
//! and the release rule's threshold dashed.

use tiny_skia::Pixmap;

use crate::colors as c;
use crate::draw::{self, Align, Batch, fill_rect, fmt_tick, frame_rect, label, nice_step, ticks};
use crate::types::LIMB_NAMES;

const HEADER: f32 = 40.0;
const FOOTER: f32 = 50.0;
const LEFT: f32 = 70.0;
const RIGHT: f32 = 150.0;

/// One colour per limb (LF, RF, LH, RH): fore blues, hind oranges.
const LIMB_COLORS: [draw::Rgba; 4] = [
    draw::Rgba::rgb(31, 119, 180),
    draw::Rgba::rgb(120, 175, 220),
    draw::Rgba::rgb(200, 95, 0),
    draw::Rgba::rgb(245, 170, 90),
];
const RESIDUAL: draw::Rgba = draw::Rgba::rgb(200, 0, 60);

/// Input of [`draw_loads`].
#[derive(Clone, Debug, PartialEq)]
pub struct LoadChart {
    /// Title, e.g. `"sloth 0 · pole · steady"`.
    pub title: String,
    /// Sample times (seconds), increasing.
    pub times_s: Vec<f32>,
    /// Per sample, the force magnitude of each limb's grip in body weights (0 when it
    /// swings), order LF, RF, LH, RH.
    pub force_bw: Vec<[f32; 4]>,
    /// Per sample, the residual wrench in body weights.
    pub residual_bw: Vec<f32>,
    /// The release rule's threshold (body weights), drawn dashed; not drawn if not finite.
    pub release_bw: f32,
    /// Canvas width in pixels (clamped to `MIN_SIDE..=MAX_SIDE`).
    pub width: u32,
    /// Canvas height in pixels.
    pub height: u32,
}

impl LoadChart {
    /// A 1400 × 600 px chart.
    pub fn new(times_s: Vec<f32>, force_bw: Vec<[f32; 4]>, residual_bw: Vec<f32>) -> Self {
        LoadChart {
            title: String::from("grip loads"),
            times_s,
            force_bw,
            residual_bw,
            release_bw: 0.05,
            width: 1400,
            height: 600,
        }
    }
}

fn finite(v: f32) -> f32 {
    if v.is_finite() { v.max(0.0) } else { 0.0 }
}

/// Draws the chart. Never panics; no samples gives "no data".
pub fn draw_loads(d: &LoadChart) -> Pixmap {
    let w = d.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE);
    let h = d.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE);
    let mut pm = draw::canvas(w, h, c::BACKGROUND);
    let (l, t, r, b) = (LEFT, HEADER, w as f32 - RIGHT, h as f32 - FOOTER);
    fill_rect(&mut pm, l, t, r, b, c::PANEL);
    let n = d
        .times_s
        .len()
        .min(d.force_bw.len())
        .min(d.residual_bw.len());
    let samples: Vec<(f32, [f32; 4], f32)> = (0..n)
        .filter(|&i| d.times_s[i].is_finite())
        .map(|i| {
            (
                d.times_s[i],
                d.force_bw[i].map(finite),
                finite(d.residual_bw[i]),
            )
        })
        .collect();
    if samples.len() < 2 {
        draw::no_data(&mut pm, l, t, r, b, "no loads");
        frame_rect(&mut pm, l, t, r, b, c::TEXT_MUTED, 1.0);
        return pm;
    }
    let t0 = samples[0].0;
    let t1 = samples[samples.len() - 1].0.max(t0 + 0.1);
    let top = samples
        .iter()
        .map(|s| s.1.iter().sum::<f32>().max(s.2))
        .fold(1.0f32, f32::max)
        * 1.1;
    let x_of = |tv: f32| l + (tv - t0) / (t1 - t0) * (r - l);
    let y_of = |v: f32| b - v / top * (b - t);
    // Grid and ticks.
    let tstep = nice_step((t1 - t0) as f64, 12.0);
    let vstep = nice_step(top as f64, 8.0);
    let mut grid = Batch::new();
    let tt = ticks(t0 as f64, t1 as f64, tstep);
    let vt = ticks(0.0, top as f64, vstep);
    for tv in &tt {
        grid.line((x_of(*tv as f32), t), (x_of(*tv as f32), b));
    }
    for v in &vt {
        grid.line((l, y_of(*v as f32)), (r, y_of(*v as f32)));
    }
    grid.stroke(&mut pm, c::GRID, 1.0);
    for tv in &tt {
        let x = x_of(*tv as f32);
        label(
            &mut pm,
            x,
            b + 14.0,
            &fmt_tick(*tv, tstep),
            1,
            c::TEXT,
            Align::Center,
        );
    }
    for v in &vt {
        let y = y_of(*v as f32);
        label(
            &mut pm,
            l - 6.0,
            y,
            &fmt_tick(*v, vstep),
            1,
            c::TEXT,
            Align::Right,
        );
    }
    // Stacked limb forces: one rectangle per sample interval and limb.
    let mut bands: [Batch; 4] = std::array::from_fn(|_| Batch::new());
    for pair in samples.windows(2) {
        let (ta, f, _) = pair[0];
        let x0 = x_of(ta);
        let x1 = x_of(pair[1].0).max(x0 + 0.5);
        let mut base = 0.0;
        for k in 0..4 {
            if f[k] > 0.0 {
                bands[k].rect(x0, y_of(base + f[k]), x1, y_of(base));
            }
            base += f[k];
        }
    }
    for (k, band) in bands.into_iter().enumerate() {
        band.fill_crisp(&mut pm, LIMB_COLORS[k]);
    }
    // Release threshold and residual.
    if d.release_bw.is_finite() && d.release_bw > 0.0 && d.release_bw < top {
        let mut th = Batch::new();
        th.line((l, y_of(d.release_bw)), (r, y_of(d.release_bw)));
        th.stroke_dashed(&mut pm, RESIDUAL, 1.0, [6.0, 4.0]);
    }
    let mut res = Batch::new();
    res.polyline(samples.iter().map(|s| (x_of(s.0), y_of(s.2))));
    res.stroke(&mut pm, RESIDUAL, 2.0);
    frame_rect(&mut pm, l, t, r, b, c::TEXT_MUTED, 1.0);
    // Legend.
    for (k, name) in LIMB_NAMES.iter().enumerate() {
        let y = t + 12.0 + 20.0 * (3 - k) as f32;
        fill_rect(
            &mut pm,
            r + 10.0,
            y - 6.0,
            r + 24.0,
            y + 6.0,
            LIMB_COLORS[k],
        );
        label(&mut pm, r + 30.0, y, name, 1, c::TEXT, Align::Left);
    }
    let y = t + 12.0 + 20.0 * 4.0;
    fill_rect(&mut pm, r + 10.0, y - 1.0, r + 24.0, y + 1.0, RESIDUAL);
    label(&mut pm, r + 30.0, y, "residual", 1, c::TEXT, Align::Left);
    label(
        &mut pm,
        (l + r) / 2.0,
        b + 34.0,
        "time (s)",
        1,
        c::TEXT,
        Align::Center,
    );
    label(
        &mut pm,
        8.0,
        t - 12.0,
        "body weights",
        1,
        c::TEXT,
        Align::Left,
    );
    let title = draw::title_line(&d.title, "grip force per limb (stacked) and residual, BW");
    draw::title(&mut pm, l, HEADER / 2.0, &title, w as f32 - l - 8.0);
    pm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_stacked_loads_and_survives_bad_input() {
        let times: Vec<f32> = (0..100).map(|i| i as f32 * 0.1).collect();
        let forces = vec![[0.25f32; 4]; 100];
        let residual = vec![0.01; 100];
        let pm = draw_loads(&LoadChart::new(times.clone(), forces, residual));
        assert_eq!((pm.width(), pm.height()), (1400, 600));
        // The LF band colours the bottom of the plot area.
        let px = pm.pixel(700, 600 - FOOTER as u32 - 3).unwrap();
        assert_eq!((px.red(), px.green(), px.blue()), (31, 119, 180));
        let bad = LoadChart::new(vec![f32::NAN, 1.0], vec![[f32::NAN; 4]; 2], vec![-1.0; 2]);
        draw_loads(&bad);
        draw_loads(&LoadChart::new(vec![], vec![], vec![]));
    }
}
