//! Hildebrand-style gait diagram: one row per limb (LF, RF, LH, RH, top to bottom), a
//! bar wherever the limb is in contact, time in seconds along the x axis.

use tiny_skia::Pixmap;

use crate::colors as c;
use crate::draw::{self, Align, Batch, fill_rect, fmt_tick, frame_rect, label, nice_step, ticks};
use crate::types::LIMB_NAMES;

const HEADER: f32 = 40.0;
const FOOTER: f32 = 50.0;
const LEFT: f32 = 56.0;
const RIGHT: f32 = 130.0;

/// Input of [`draw_gait`].
#[derive(Clone, Debug, PartialEq)]
pub struct GaitDiagram {
    /// Title, e.g. `"sloth 3 · pole · free"`.
    pub title: String,
    /// Contact intervals `(start_s, end_s)` per limb, order `LF, RF, LH, RH`.
    pub contacts: [Vec<(f32, f32)>; 4],
    /// The time axis runs from 0 to this (seconds). If it is not a positive number the
    /// axis spans the intervals instead.
    pub duration_s: f32,
    /// Canvas width in pixels (clamped to `MIN_SIDE..=MAX_SIDE`).
    pub width: u32,
    /// Canvas height in pixels.
    pub height: u32,
}

impl GaitDiagram {
    /// A 1400 × 420 px diagram.
    pub fn new(contacts: [Vec<(f32, f32)>; 4], duration_s: f32) -> Self {
        GaitDiagram {
            title: String::from("gait"),
            contacts,
            duration_s,
            width: 1400,
            height: 420,
        }
    }
}

/// Where things are in a gait diagram.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GaitLayout {
    /// Plot area (left, top, right, bottom) in pixels.
    pub plot_px: [f32; 4],
    /// Each limb row's (top, bottom) in pixels, order `LF, RF, LH, RH`.
    pub rows_px: [(f32, f32); 4],
    /// Time range of the x axis (seconds), `None` without any finite data.
    pub time_s: Option<(f32, f32)>,
}

impl GaitLayout {
    /// Pixel x of a time (seconds).
    pub fn x_of(&self, t: f32) -> f32 {
        let [l, _, r, _] = self.plot_px;
        match self.time_s {
            Some((t0, t1)) => l + (t - t0) / (t1 - t0) * (r - l),
            None => l,
        }
    }
}

fn finite_intervals(d: &GaitDiagram) -> impl Iterator<Item = (usize, f32, f32)> + '_ {
    d.contacts.iter().enumerate().flat_map(|(k, v)| {
        v.iter()
            .filter(|(a, b)| a.is_finite() && b.is_finite() && b >= a)
            .map(move |(a, b)| (k, *a, *b))
    })
}

/// The layout [`draw_gait`] uses.
pub fn gait_layout(d: &GaitDiagram) -> GaitLayout {
    let w = d.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let h = d.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE) as f32;
    let plot = [LEFT, HEADER, w - RIGHT, h - FOOTER];
    let row_h = (plot[3] - plot[1]) / 4.0;
    let rows =
        std::array::from_fn(|k| (plot[1] + k as f32 * row_h, plot[1] + (k + 1) as f32 * row_h));
    let time_s = if d.duration_s.is_finite() && d.duration_s > 0.0 {
        Some((0.0, d.duration_s))
    } else {
        let (lo, hi) = finite_intervals(d)
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), (_, a, b)| {
                (lo.min(a), hi.max(b))
            });
        (lo.is_finite() && hi.is_finite()).then(|| (lo, hi.max(lo + 0.1)))
    };
    GaitLayout {
        plot_px: plot,
        rows_px: rows,
        time_s,
    }
}

/// Contact intervals from sampled planted flags: `planted[i][limb]` at `times_s[i]`.
/// A contact runs from the first planted sample to the first sample that is not (or the
/// last sample). Samples with a non-finite time are skipped; extra entries of the longer
/// slice are ignored.
pub fn contact_intervals(times_s: &[f32], planted: &[[bool; 4]]) -> [Vec<(f32, f32)>; 4] {
    let mut out: [Vec<(f32, f32)>; 4] = Default::default();
    let mut start: [Option<f32>; 4] = [None; 4];
    let mut last_t = None;
    for (&t, flags) in times_s.iter().zip(planted) {
        if !t.is_finite() {
            continue;
        }
        for k in 0..4 {
            match (flags[k], start[k]) {
                (true, None) => start[k] = Some(t),
                (false, Some(s)) => {
                    out[k].push((s, t));
                    start[k] = None;
                }
                _ => {}
            }
        }
        last_t = Some(t);
    }
    if let Some(t) = last_t {
        for k in 0..4 {
            if let Some(s) = start[k] {
                out[k].push((s, t));
            }
        }
    }
    out
}

/// Draws the gait diagram. Never panics; no finite intervals gives "no data".
pub fn draw_gait(d: &GaitDiagram) -> Pixmap {
    let w = d.width.clamp(draw::MIN_SIDE, draw::MAX_SIDE);
    let h = d.height.clamp(draw::MIN_SIDE, draw::MAX_SIDE);
    let mut pm = draw::canvas(w, h, c::BACKGROUND);
    let lay = gait_layout(d);
    let [l, t, r, b] = lay.plot_px;
    fill_rect(&mut pm, l, t, r, b, c::PANEL);
    for (k, (y0, y1)) in lay.rows_px.iter().enumerate() {
        if k % 2 == 1 {
            fill_rect(&mut pm, l, *y0, r, *y1, c::GAIT_ROW);
        }
        label(
            &mut pm,
            l - 10.0,
            (y0 + y1) / 2.0,
            LIMB_NAMES[k],
            2,
            c::TEXT,
            Align::Right,
        );
    }

    let has_data = finite_intervals(d).next().is_some();
    if let (Some((t0, t1)), true) = (lay.time_s, has_data) {
        // Grid and ticks.
        let step = nice_step((t1 - t0) as f64, 12.0);
        let mut grid = Batch::new();
        let tk = ticks(t0 as f64, t1 as f64, step);
        for tv in &tk {
            let x = lay.x_of(*tv as f32);
            grid.line((x, t), (x, b));
        }
        grid.stroke(&mut pm, c::GRID, 1.0);
        for tv in &tk {
            let x = lay.x_of(*tv as f32);
            let mut tick = Batch::new();
            tick.line((x, b), (x, b + 5.0));
            tick.stroke(&mut pm, c::TEXT, 1.0);
            label(
                &mut pm,
                x,
                b + 14.0,
                &fmt_tick(*tv, step),
                1,
                c::TEXT,
                Align::Center,
            );
        }
        // Bars: the middle 60 % of each row, clipped to the axis.
        let mut bars = [Batch::new(), Batch::new()];
        let mut contact_time = [0.0f32; 4];
        for (k, a, e) in finite_intervals(d) {
            let (a, e) = (a.max(t0), e.min(t1));
            if e <= a {
                continue;
            }
            contact_time[k] += e - a;
            let (y0, y1) = lay.rows_px[k];
            let pad = (y1 - y0) * 0.2;
            let (x0, x1) = (lay.x_of(a), lay.x_of(e).max(lay.x_of(a) + 1.0));
            bars[k / 2].rect(x0, y0 + pad, x1, y1 - pad);
        }
        let [fore, hind] = bars;
        fore.fill_crisp(&mut pm, c::GAIT_FORE);
        hind.fill_crisp(&mut pm, c::GAIT_HIND);
        // Duty factor (fraction of the time in contact) at the right of each row.
        for (k, (y0, y1)) in lay.rows_px.iter().enumerate() {
            let duty = contact_time[k] / (t1 - t0);
            label(
                &mut pm,
                r + 10.0,
                (y0 + y1) / 2.0,
                &format!("duty {:.0} %", duty * 100.0),
                1,
                c::TEXT,
                Align::Left,
            );
        }
    } else {
        draw::no_data(&mut pm, l, t, r, b, "no contacts");
    }
    frame_rect(&mut pm, l, t, r, b, c::TEXT_MUTED, 1.0);
    label(
        &mut pm,
        (l + r) / 2.0,
        b + 34.0,
        "time (s)",
        1,
        c::TEXT,
        Align::Center,
    );
    let title = draw::title_line(&d.title, "contact phases (bars = limb holds its grip)");
    draw::title(&mut pm, l, HEADER / 2.0, &title, w as f32 - l - 8.0);
    pm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn intervals_from_samples() {
        let times = [0.0, 0.1, 0.2, 0.3, f32::NAN, 0.4];
        let p = [
            [true, false, true, true],
            [true, true, false, true],
            [false, true, false, true],
            [true, true, true, true],
            [false, false, false, false],
            [true, true, true, true],
        ];
        let iv = contact_intervals(&times, &p);
        assert_eq!(iv[0], vec![(0.0, 0.2), (0.3, 0.4)]);
        assert_eq!(iv[1], vec![(0.1, 0.4)]);
        assert_eq!(iv[2], vec![(0.0, 0.1), (0.3, 0.4)]);
        assert_eq!(iv[3], vec![(0.0, 0.4)]);
        assert_eq!(
            contact_intervals(&[], &[]),
            <[Vec<(f32, f32)>; 4]>::default()
        );
    }
}
