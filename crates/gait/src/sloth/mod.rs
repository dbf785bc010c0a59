//! One sloth's locomotion state and the per-stage kernels the simulation runs
//! on it (thesis chapter 3; SPEC "The algorithm"). Everything is plain data
//! and pure functions of (sloth, shared read-only [`LocoView`]); the ECS only
//! schedules them.
//!
//! Frame stages (see the sim crate's schedule), and where each lives:
//! 1. **Trace** — the sim runs this sloth's [`TraceBatch`] against the BVH.
//! 2. **StepSearch** — [`Sloth::step_search`] (`search.rs`): limbs that are
//!    searching pick the first valid candidate (farthest first, 1 cm
//!    back-off) and start their swing, or queue the next candidates. A
//!    candidate is judged in `candidate.rs`, its stances in `checks.rs`
//!    (the body's collisions in `collide.rs`); where a limb searches next
//!    (neighbours, retreats, side steps) is `route.rs`; a branch ↔ trunk
//!    change starts in `transfer.rs`.
//! 3. **BodyAverage** — [`Sloth::body_average`] (`body.rs`): swing arcs
//!    advance, then the body is placed by formulas 6 and 7 (smoothed).
//! 4. **CcdSolve** — [`Sloth::solve_limbs`] (`solve.rs`): CCD IK of each limb
//!    toward its grip or swing-arc point.
//! 5. **Transitions** — [`Sloth::transitions`] (`clock.rs`): the gait clock
//!    lifts limbs in footfall order and queues their first step-search
//!    traces; goal and stop rules; transfers end (`transfer.rs`).
//!
//! [`Sloth::spawn`] (`spawn.rs`) places a sloth; [`Sloth::observe`]
//! (`observe.rs`) is what the judge and the statistics see. This file holds
//! the state types and the queries every stage shares.

mod body;
mod candidate;
mod checks;
mod clock;
mod collide;
mod livelock;
mod observe;
mod replan;
mod retrace;
mod route;
mod search;
mod solve;
mod spawn;
#[cfg(test)]
pub(crate) mod test_util;
mod transfer;
mod turn;

pub use body::BodyMemo;
pub use livelock::NearRing;
pub use observe::ObserveMemo;
pub use replan::Backoff;
pub use retrace::{Trail, TrailStep};
pub use solve::SolveMemo;
pub use transfer::Transfer;
pub use turn::{TURN_STEP, Turn};

pub use crate::env::LocoView;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use slothsim_rig::{ChainPose, Limb};
use slothsim_scene::{LineTrace, SceneQuery, SupportId, SupportKind, TraceRequest, TraceResult};

use crate::path::project;

/// Trace slots per sloth per frame.
pub const MAX_TRACES: usize = 8;

/// A grip on a support.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Grip {
    /// Contact point on the surface (world).
    pub point: Vec3,
    /// Surface normal there.
    pub normal: Vec3,
    /// The support.
    pub support: SupportId,
    /// Arc length of the point's axis projection.
    pub u: f32,
    /// Travel direction along the support's axis (+1 increasing `u`).
    pub sdir: f32,
}

/// What a limb is doing.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum LimbPhase {
    /// Holding its grip.
    Planted,
    /// Holding its grip while its step search runs.
    Searching,
    /// Travelling on the swing arc to its new grip.
    Swinging,
}

/// Where a limb's step search stands.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Search {
    /// Support being searched.
    pub support: SupportId,
    /// Travel direction along it.
    pub sdir: f32,
    /// Arc length the search started at (its farthest candidate).
    pub first_u: f32,
    /// Next candidate arc length.
    pub next_u: f32,
    /// Last candidate arc length (inclusive).
    pub last_u: f32,
    /// Index of the next neighbour support to try once this one is exhausted
    /// (`u16::MAX` = searching the current support).
    pub neighbour: u16,
    /// Searching backward on the current support: no forward step was left
    /// anywhere, so the limb re-grips behind to unlock the others.
    pub retreat: bool,
    /// Searching the goal's branch before the trunk the limb holds (see
    /// `Sloth::goal_branch_search`); once exhausted, the trunk is searched.
    pub goal_first: bool,
}

/// One limb.
///
/// `repr(C)`, its fields in this order: what every frame of a sloth at rest
/// reads comes first (grip, target, effector, phase, due, joints, the
/// committed step's tag: the first 108 bytes), then what a solve reads and
/// writes, then the swing's and the search's state. At 10,000 sloths a
/// sloth's state comes from memory once a frame, so a frame costs the cache
/// lines it touches (docs/performance.md, the tenth round).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[repr(C)]
pub struct LimbState {
    /// Held grip (planted/searching) or the grip being swung to.
    pub grip: Grip,
    /// IK target this frame.
    pub target: Vec3,
    /// Claw tip after IK (world).
    pub effector: Vec3,
    /// Phase.
    pub phase: LimbPhase,
    /// The gait clock asked this limb to step and it has not yet.
    pub due: bool,
    /// Joints 1..3 (elbow or knee, wrist or ankle, the hand's or foot's base)
    /// after IK (world), written with `effector` by every CcdSolve: with the
    /// effector, the limb's segments for the centre of mass
    /// ([`Sloth::centre_of_mass`]). Body and poses change only in
    /// BodyAverage and CcdSolve, so they hold from CcdSolve to the next
    /// BodyAverage. Not checkpointed (derived): `None` until the first solve.
    #[serde(skip)]
    pub joints: Option<[Vec3; 3]>,
    /// A step this limb takes by a deadline unless its own search finds one
    /// first: another limb's step was checked with this one lifting off on
    /// the gait clock during its swing (`Sloth::next_lift`).
    #[serde(default)]
    pub fallback: Option<Fallback>,
    /// Chain root this frame (world).
    pub root: Vec3,
    /// Warm-started IK pose.
    #[serde(with = "pose_serde")]
    pub pose: ChainPose,
    /// The target (chain-root frame) of the last solve, if that solve ended
    /// short of it (joint limits): the pose is settled there until the target
    /// moves (see [`Sloth::solve_limbs`]).
    pub settled_ls: Option<Vec3>,
    /// The target (chain-root frame) at which a cold restart of this planted
    /// limb's solve last failed to beat its warm solve: not tried again within
    /// `COLD_RETRY_MOVE` of it (cleared when the limb swings).
    pub cold_miss_ls: Option<Vec3>,
    /// Search state (valid while `Searching`).
    pub search: Search,
    /// Swing start point and normal.
    pub from: Vec3,
    /// Surface normal at the swing start.
    pub from_normal: Vec3,
    /// Support held at the swing start.
    pub from_support: SupportId,
    /// Swing progress 0..1.
    pub swing_t: f32,
    /// This limb's search (while `Searching`) only asks whether it has a step: the
    /// release rule holds the limb back, and a wanderer whose search has failed
    /// searches before it waits (`Sloth::transitions`). A step found is not taken:
    /// the limb stays planted and due, and waits for the release rule.
    /// Checkpointed (format 25).
    pub probe: bool,
}

impl LimbState {
    /// Starts a swing from the held grip to `to`.
    pub(super) fn swing_to(&mut self, to: Grip) {
        self.from = self.grip.point;
        self.from_normal = self.grip.normal;
        self.from_support = self.grip.support;
        self.grip = to;
        self.phase = LimbPhase::Swinging;
        self.swing_t = 0.0;
    }
}

/// A limb's committed step (see [`LimbState::fallback`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Fallback {
    /// The grip it steps to (its checks passed there; not traced).
    pub grip: Grip,
    /// Simulated time by which the limb is in the air.
    pub by_s: f32,
}

/// Why a sloth stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Walking.
    Moving,
    /// Reached its goal.
    Arrived,
    /// No limb found a valid grip anywhere within reach for two gait cycles.
    NoGrip,
}

/// Why a sloth's step search last found nothing anywhere (every limb, its
/// own support, its neighbours and a retreat), judged when it happened
/// (`Sloth::stuck_cause`; `stats.json` counts stuck sloths by it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StuckCause {
    /// At the free end of its support (a branch tip, a trunk's top or foot)
    /// with no other support within reach.
    Tip,
    /// Other sloths hold every step it had, in both directions (it had
    /// already turned back).
    BoxedIn,
    /// In the middle of a branch ↔ trunk transfer, with no step even once
    /// the other sloths are ignored.
    TransferFailed,
    /// Other sloths hold every step it had ahead (without them a step passes;
    /// a wanderer's only where it leads into a stance some limb can leave).
    Crowded,
    /// No grip within reach passes the checks, with no other sloth in the
    /// way and away from a support end.
    NoGrip,
}

impl StuckCause {
    /// Every cause, in the order `stats.json` lists them.
    pub const ALL: [StuckCause; 5] = [
        StuckCause::Tip,
        StuckCause::BoxedIn,
        StuckCause::TransferFailed,
        StuckCause::Crowded,
        StuckCause::NoGrip,
    ];

    /// The name `stats.json` uses.
    pub fn name(self) -> &'static str {
        match self {
            StuckCause::Tip => "tip",
            StuckCause::BoxedIn => "boxed_in",
            StuckCause::TransferFailed => "transfer_failed",
            StuckCause::Crowded => "crowded",
            StuckCause::NoGrip => "no_grip",
        }
    }
}

/// One sloth.
///
/// `repr(C)`: the fields a frame of a sloth at rest reads come first (body,
/// clock, status, hang and transfer state, then the limbs and the load
/// track), the ones read only on a step or a failed search last
/// (docs/performance.md, the tenth round). Checkpoints (postcard) write the
/// fields in this order. Aligned to a cache line: each sloth's hot fields
/// then start a line (at 2,160 bytes, unaligned, 10,000 sloths at two
/// threads ran 15–20 % slower; docs/performance.md, the twelfth round).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[repr(C, align(64))]
pub struct Sloth {
    /// Body position (model origin) and rotation (model +Z forward, +Y toward the support).
    pub body_pos: Vec3,
    /// Body rotation.
    pub body_rot: Quat,
    /// Stable id (crowd neighbour checks skip the sloth's own points).
    pub id: u32,
    /// Gait clock phase 0..1.
    pub clock: f32,
    /// +1: travel head first; −1: tail first (descending a trunk head-up).
    pub dir: f32,
    /// Simulated time.
    pub time: f32,
    /// Goal tolerance (metres).
    pub goal_tolerance: f32,
    /// Weight shift (issue 22, `Sloth::weight_shift`): the share of it the
    /// body takes (0..1), lowered while a holding claw is left short.
    #[serde(default)]
    pub shift_gain: f32,
    /// The share of `offset_back_m` the hind pair's swing onto a branch
    /// uses (the most its stance checks allowed).
    pub hind_back_scale: f32,
    /// The weight shift the body has now (world, m; see `Sloth::weight_shift`).
    #[serde(default)]
    pub body_shift: Vec3,
    /// The side of its branch the body is on (from the paws' mean), kept
    /// while it rolls about the branch to clear a trunk: in the fork below a
    /// branch the roll goes that way (see `Sloth::hang_roll`). It is
    /// state, not read off the drawn body, so the step checks roll a stance
    /// the way the drawn body will.
    pub hang_side: Vec3,
    /// Status.
    pub status: Status,
    /// Autorun: no goal; at a dead end (or blocked by other sloths) turn
    /// back instead of stopping, and pick among neighbour supports by `seed`.
    pub wander: bool,
    /// Whether its trace batch holds requests (`TraceBatch::len > 0`): set
    /// where `queue_candidates` queues one, cleared where `step_search`
    /// empties the batch. The crowd pass reads it instead of the batch's
    /// `len` (a cache line of its own at rest) and skips an empty batch; true
    /// with an empty batch is harmless (the batch is then run and searched as
    /// before). A batch with requests must never meet a sloth with this false.
    #[serde(default)]
    pub traces_queued: bool,
    /// Off a trunk onto a branch (`transfer_to_branch`): that trunk, which
    /// the body still rolls clear of while it walks out of the fork, until
    /// a step search starts unrolled (see `Sloth::hang_roll`).
    pub hang_trunk: Option<SupportId>,
    /// Wander mode, stopped (`NoGrip`): the time it tries again (the way
    /// may have been blocked by sloths that since moved on).
    pub resume_at: Option<f32>,
    /// Goal: support and point, if any.
    pub goal: Option<(SupportId, Vec3)>,
    /// On a trunk goal: the unit direction from the trunk's axis toward the
    /// body at the goal (the body moves around the axis with side steps until
    /// it faces the trunk from there). `None`: any side.
    #[serde(default)]
    pub goal_side: Option<Vec3>,
    /// Branch ↔ trunk transfer in progress, if any.
    pub transfer: Option<Transfer>,
    /// Turning around at a branch end, if under way (see `turn.rs`).
    #[serde(default)]
    pub turn: Option<Turn>,
    /// Goal mode: a back-off under way, re-planning a stuck step (see `replan.rs`).
    #[serde(default)]
    pub backoff: Option<Backoff>,
    /// Limbs by `Limb::index`.
    pub limbs: [LimbState; 4],
    /// Grip loads: centre-of-mass history and the release rule's counters.
    #[serde(default)]
    pub load: crate::load::LoadTrack,
    /// Step searches that found nothing since the last step taken.
    pub failed_searches: u8,
    /// Turn-backs since the last step taken (wander mode).
    pub stalled_turns: u8,
    /// Goal mode: re-plans made (each a back-off started or ended early).
    #[serde(default)]
    pub replans: u8,
    /// Goal mode, `transfer_to_branch`: the hind pair found no step together
    /// and re-planned: the hind limbs leave the trunk one at a time.
    #[serde(default)]
    pub hind_single: bool,
    /// Goal mode: a hind limb behind its girdle partner by more than a
    /// minimum step may close up part way while the search is failing
    /// (`Sloth::keeps_leg_order`). Set by a back-off's playouts when no
    /// back-off arrives without it (`Sloth::plan_backoff`), then kept.
    /// Checkpointed (format 30).
    #[serde(default)]
    pub close_up: bool,
    /// Goal mode: the limbs (bit `1 << li`) whose current step search found
    /// nothing at the coarse stride in a lock and re-scans its range at
    /// every back-off point before it counts as failed
    /// (`Sloth::queue_candidates`, `Sloth::fine_rescans`); cleared when the
    /// limb starts a search. Checkpointed (format 31).
    #[serde(default)]
    pub fine_rescan: u8,
    /// Goal mode: step searches the lone fore limb across a locked transfer
    /// onto a trunk has started (see `Sloth::own_search`), kept across
    /// transfers ended and begun again, cleared when a transfer is
    /// completed. Checkpointed (format 27).
    #[serde(default)]
    pub lone_fore_searches: u8,
    /// Why its step search last found nothing anywhere (`None`: it never
    /// failed). Not part of the state hash: a diagnosis, not locomotion.
    #[serde(default)]
    pub stuck_cause: Option<StuckCause>,
    /// Times this sloth turned back (wander mode); varies route choices.
    pub turns: u32,
    /// Seed of this sloth's route choices (wander mode).
    pub seed: u64,
    /// Wander mode: where the body was at the first turn-back since it last
    /// travelled a max step, and the turn-backs since (see
    /// `Sloth::note_step`): steps that leave the body near where it turned
    /// back do not end this stall, as they end [`Self::stalled_turns`].
    #[serde(default)]
    pub stall_from: Option<(Vec3, u8)>,
    /// Livelock watch outside transfers: the stances taken by steps made
    /// while the search was failing (see [`Sloth::note_stuck_stance`]).
    #[serde(default)]
    pub stuck_stances: transfer::StanceRing,
    /// Wander mode: the last steps taken and the retrace under way (see
    /// `retrace.rs`). Checkpointed (format 28).
    #[serde(default)]
    pub trail: Trail,
    // Goal mode's record of the stances taken since the sloth last came
    // nearer its goal ([`NearRing`], `livelock.rs`) is kept beside the
    // sloth, not in it: see `Sloth::step_search`.
}

/// Serde for [`ChainPose`] (four quaternions, bit-exact through serde's f32).
mod pose_serde {
    use glam::Quat;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};
    use slothsim_rig::ChainPose;

    pub fn serialize<S: Serializer>(p: &ChainPose, s: S) -> Result<S::Ok, S::Error> {
        p.0.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<ChainPose, D::Error> {
        <[Quat; 4]>::deserialize(d).map(ChainPose)
    }
}

/// SplitMix64 finaliser: a well-mixed hash of `x`.
pub fn mix64(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// This sloth's trace requests for the next Trace stage and their results.
/// Checkpoints keep the queued requests; results are recomputed by the next
/// Trace stage before anything reads them.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TraceBatch {
    /// Requests (first `len`).
    pub reqs: [TraceRequest; MAX_TRACES],
    /// Which candidate each request traces.
    pub meta: [Candidate; MAX_TRACES],
    /// Results, filled by the Trace stage.
    #[serde(skip, default = "no_results")]
    pub results: [TraceResult; MAX_TRACES],
    /// Number of requests.
    pub len: usize,
}

fn no_results() -> [TraceResult; MAX_TRACES] {
    [Ok(None); MAX_TRACES]
}

impl Default for TraceBatch {
    fn default() -> Self {
        let req = TraceRequest::Line(LineTrace {
            origin: Vec3::ZERO,
            dir: Vec3::Y,
            max_dist: 0.0,
        });
        TraceBatch {
            reqs: [req; MAX_TRACES],
            meta: [Candidate::default(); MAX_TRACES],
            results: [Ok(None); MAX_TRACES],
            len: 0,
        }
    }
}

impl TraceBatch {
    /// Runs the requests (the Trace stage does exactly this, batched over sloths).
    pub fn run(&mut self, query: &SceneQuery<'_>) {
        for i in 0..self.len {
            self.results[i] = query.trace(&self.reqs[i]);
        }
    }

    fn push(&mut self, req: TraceRequest, meta: Candidate) -> bool {
        if self.len == MAX_TRACES {
            return false;
        }
        self.reqs[self.len] = req;
        self.meta[self.len] = meta;
        self.results[self.len] = Ok(None);
        self.len += 1;
        true
    }
}

/// A step-search candidate being traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Candidate {
    /// Limb index.
    pub limb: u8,
    /// Support the candidate is on.
    pub support: SupportId,
    /// Arc length on it.
    pub u: f32,
    /// Travel direction along it.
    pub sdir: f32,
    /// Direction from the axis toward the trace origin (the limb's side).
    pub out: Vec3,
    /// The grip the reach checks passed at (on the support model's surface).
    pub point: Vec3,
    /// `transfer_to_branch`'s hind pair: the partner limb, its grip and
    /// surface normal (it steps together with `limb`).
    pub pair: Option<(u8, Vec3, Vec3)>,
    /// The hind pair's share of the offset back its checks passed with (see
    /// `Sloth::pair_back_scale`).
    pub back_scale: f32,
    /// The limb its checks let lift off during the swing and that limb's
    /// committed step (`Sloth::next_lift`); `None`: every other limb holds.
    pub lift: Option<(u8, Grip)>,
}

/// Spawn description: a support, a point on its axis, travel direction and the body side.
#[derive(Clone, Copy, Debug)]
pub struct SpawnHint {
    /// Support.
    pub support: SupportId,
    /// Point on the axis (body centre's projection).
    pub position: Vec3,
    /// Travel direction.
    pub forward: Vec3,
    /// Direction from the axis to the body.
    pub body_side: Vec3,
}

impl From<slothsim_scene::StartHint> for SpawnHint {
    /// A preset's start.
    fn from(s: slothsim_scene::StartHint) -> Self {
        SpawnHint {
            support: s.support,
            position: s.position,
            forward: s.forward,
            body_side: s.body_side,
        }
    }
}

impl Sloth {
    /// Whether all four limbs' grips are on support `sid`, a swinging limb's
    /// being the one it swings to.
    fn grips_only(&self, sid: SupportId) -> bool {
        self.limbs.iter().all(|l| l.grip.support == sid)
    }

    /// Whether all four limbs hold support `sid` (none swinging).
    fn holds_only(&self, sid: SupportId) -> bool {
        self.limbs
            .iter()
            .all(|l| l.phase != LimbPhase::Swinging && l.grip.support == sid)
    }

    /// Distance from the body to the goal, and whether the goal's support is
    /// held: all four limbs on it, body beside it. Held, the distance is from
    /// the body's closest axis point to the goal point, or with a goal side,
    /// from the body to where it would be facing the support from that side
    /// (a chord around a trunk). Not held (e.g. still under a branch that
    /// passes near the goal on a trunk), the body's straight distance to the
    /// goal point. `None` without a goal.
    fn goal_distance(&self, env: &LocoView<'_>) -> Option<(f32, bool)> {
        self.goal_distance_with(env, Self::holds_only)
    }

    /// [`Self::goal_distance`] with `on(self, goal support)` deciding
    /// whether the goal's support is held.
    fn goal_distance_with(
        &self,
        env: &LocoView<'_>,
        on: fn(&Self, SupportId) -> bool,
    ) -> Option<(f32, bool)> {
        let (gs, gp) = self.goal?;
        let a = project(env.scene().support(gs), self.body_pos);
        let off_axis = self.body_pos - a.point;
        if !(on(self, gs) && off_axis.length() < 0.6) {
            return Some((self.body_pos.distance(gp), false));
        }
        let d = match self.goal_side {
            Some(side) => self.body_pos.distance(gp + side * off_axis.length()),
            None => a.point.distance(gp),
        };
        Some((d, true))
    }

    fn targets(&self) -> [Vec3; 4] {
        self.limb_map(|l| l.target)
    }

    /// `f` of each limb, by reference: `self.limbs.map(f)` moves a copy of
    /// the four `LimbState`s (1,280 bytes, a `memcpy` a call) into `map`
    /// wherever the compiler does not see through it.
    #[inline]
    pub(super) fn limb_map<T>(&self, mut f: impl FnMut(&LimbState) -> T) -> [T; 4] {
        std::array::from_fn(|i| f(&self.limbs[i]))
    }

    /// Both fore limbs hold the same trunk (the body faces it).
    fn fore_on_trunk(&self, env: &LocoView<'_>) -> bool {
        let fore = self.limbs[Limb::LF.index()].grip.support;
        env.scene().support(fore).kind == SupportKind::Trunk
            && self.limbs[Limb::RF.index()].grip.support == fore
    }

    /// Travel vector (unit): body forward × dir.
    fn travel(&self) -> Vec3 {
        self.body_rot * Vec3::Z * self.dir
    }

    /// Whether `limb` belongs to the pair that leads in the travel direction
    /// (fore limbs head first, hind limbs tail first).
    fn leads(&self, limb: Limb) -> bool {
        limb.is_fore() == (self.dir > 0.0)
    }

    /// Whether a limb is in the air.
    fn any_swinging(&self) -> bool {
        self.limbs.iter().any(|l| l.phase == LimbPhase::Swinging)
    }
}
