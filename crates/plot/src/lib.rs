//! Debug plots for slothsim, drawn with tiny-skia into PNGs. A pure drawing library:
//! plain input types in, [`tiny_skia::Pixmap`] out, no ECS (the sim crate fills the
//! inputs from its snapshots and statistics).
//!
//! - [`draw_topdown`]: the forest from above with every sloth, its limbs, trails and one
//!   sloth's step-search traces.
//! - [`draw_side`]: one sloth's skeleton at several instants, seen from the side, over
//!   the silhouette of its skinned mesh when the caller gives one.
//! - [`draw_gait`]: Hildebrand gait diagram (contact phases per limb over time).
//! - [`draw_frame_times`]: stacked per-stage frame times with the budget band and p50/p95.
//! - [`save_png`]: atomic PNG write (temporary file + rename), errors name the path.
//!
//! Conventions: metres, seconds, +Y up, right-handed. Limb order everywhere is
//! `LF, RF, LH, RH` ([`LIMB_NAMES`]). Non-finite input points are skipped, never drawn;
//! empty inputs give a chart with a "no data" label, never a panic.

mod draw;
mod error;
mod frame_times;
mod gait;
mod loads;
mod side;
mod topdown;
mod types;

pub mod colors;

pub use draw::{MAX_SIDE, MIN_SIDE, Rgba};
pub use error::{PlotError, encode_png, save_png};
pub use frame_times::{
    DEFAULT_STAGES, FrameTimes, FrameTimesLayout, STAGE_COUNT, draw_frame_times, frame_times_layout,
};
pub use gait::{GaitDiagram, GaitLayout, contact_intervals, draw_gait, gait_layout};
pub use loads::{LoadChart, draw_loads};
pub use side::{SideInstant, SideProjection, SideView, draw_side, side_projection};
pub use topdown::{MapProjection, TopDown, draw_topdown, topdown_projection};
pub use types::{LIMB_NAMES, LimbPose, SlothPose, TraceLine};

pub use tiny_skia::Pixmap;
