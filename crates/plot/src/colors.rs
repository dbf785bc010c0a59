//! The palette, public so tests (and people) can look for these colours in the PNGs.
//! Height ramp colours are blue → grey → yellow, deliberately free of the sloth, trace
//! and stage colours.

use crate::Rgba;

/// Canvas background.
pub const BACKGROUND: Rgba = Rgba::rgb(246, 245, 240);
/// Chart panel background (gait, frame times).
pub const PANEL: Rgba = Rgba::rgb(255, 255, 255);
/// Grid lines.
pub const GRID: Rgba = Rgba::rgb(222, 222, 216);
/// Axes, ticks, main text.
pub const TEXT: Rgba = Rgba::rgb(30, 30, 30);
/// Secondary text ("no data", units).
pub const TEXT_MUTED: Rgba = Rgba::rgb(110, 110, 110);

/// Trunks (top-down discs, side-view fill).
pub const TRUNK: Rgba = Rgba::rgb(96, 62, 40);
/// Trunk outline.
pub const TRUNK_EDGE: Rgba = Rgba::rgb(50, 30, 18);
/// Branch fill in the side view.
pub const BRANCH_SIDE: Rgba = Rgba::rgb(170, 140, 105);
/// Support outline in the side view.
pub const SUPPORT_EDGE: Rgba = Rgba::rgb(80, 60, 40);

/// Sloth body (top-down) — a saturated orange-brown no other element uses.
pub const SLOTH_BODY: Rgba = Rgba::rgb(214, 96, 24);
/// Sloth body outline.
pub const SLOTH_EDGE: Rgba = Rgba::rgb(60, 25, 5);
/// Sloth head (two-toed sloths have pale faces).
pub const SLOTH_HEAD: Rgba = Rgba::rgb(250, 225, 185);
/// Side view: the skinned sloth mesh's silhouette (fur).
pub const SLOTH_FUR: Rgba = Rgba::rgb(150, 118, 84);
/// Planted limbs (solid).
pub const LIMB_PLANTED: Rgba = Rgba::rgb(70, 30, 10);
/// Swinging limbs (dashed, lighter).
pub const LIMB_SWING: Rgba = Rgba::rgb(150, 95, 60);
/// Trails (drawn translucent).
pub const TRAIL: Rgba = Rgba::rgb(214, 96, 24);
/// Ring around the focus sloth.
pub const FOCUS: Rgba = Rgba::rgb(200, 0, 200);
/// Trace that hit a surface.
pub const TRACE_HIT: Rgba = Rgba::rgb(0, 190, 0);
/// Trace that missed.
pub const TRACE_MISS: Rgba = Rgba::rgb(230, 0, 0);

/// Side view: spine and head.
pub const SPINE: Rgba = Rgba::rgb(120, 60, 20);
/// Side view: left limbs (LF, LH).
pub const LEFT_LIMB: Rgba = Rgba::rgb(30, 90, 210);
/// Side view: right limbs (RF, RH).
pub const RIGHT_LIMB: Rgba = Rgba::rgb(235, 120, 0);

/// Gait diagram: fore limb contact bars.
pub const GAIT_FORE: Rgba = Rgba::rgb(30, 80, 160);
/// Gait diagram: hind limb contact bars.
pub const GAIT_HIND: Rgba = Rgba::rgb(200, 95, 0);
/// Gait diagram: alternate row shading.
pub const GAIT_ROW: Rgba = Rgba::rgb(238, 240, 245);

/// Frame-time chart: one colour per stage (Trace, StepSearch, BodyAverage, CcdSolve,
/// GripLoad, Transitions).
pub const STAGES: [Rgba; 6] = [
    Rgba::rgb(31, 119, 180),
    Rgba::rgb(255, 127, 14),
    Rgba::rgb(44, 160, 44),
    Rgba::rgb(214, 39, 40),
    Rgba::rgb(140, 86, 75),
    Rgba::rgb(148, 103, 189),
];
/// Frame-time chart: the budget band.
pub const BUDGET_BAND: Rgba = Rgba::rgb(255, 236, 150);
/// Frame-time chart: p50 line.
pub const P50: Rgba = Rgba::rgb(20, 20, 20);
/// Frame-time chart: p95 line.
pub const P95: Rgba = Rgba::rgb(160, 0, 90);
