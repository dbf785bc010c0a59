//! One sloth's locomotion state and the per-stage kernels the simulation runs
//! on it (thesis chapter 3). Everything is plain data and pure functions of
//! (sloth, shared read-only world); the ECS only schedules them.
//!
//! Frame stages (see the sim crate's schedule):
//! 1. **Trace** — the sim runs this sloth's [`TraceBatch`] against the BVH.
//! 2. **StepSearch** — [`Sloth::step_search`]: limbs that are searching pick
//!    the first valid candidate (farthest first, 1 cm back-off) and start
//!    their swing, or queue the next candidates.
//! 3. **BodyAverage** — [`Sloth::body_average`]: swing arcs advance, then the
//!    body is placed by formulas 6 and 7 (smoothed).
//! 4. **CcdSolve** — [`Sloth::solve_limbs`]: CCD IK of each limb toward its
//!    grip or swing-arc point.
//! 5. **Transitions** — [`Sloth::transitions`]: the gait clock lifts limbs in
//!    footfall order and queues their first step-search traces; goal and
//!    stop rules.

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use slothsim_rig::{CcdParams, CcdResult, ChainPose, Limb, RootTransform};
use slothsim_scene::{
    LineTrace, Scene, SceneQuery, SupportId, SupportKind, TraceRequest, TraceResult,
};

use crate::config::LocomotionConfig;
use crate::crowd::CrowdGrid;
use crate::observe::{LimbObservation, SlothObservation};
use crate::path::{Adjacency, SEGMENT_CHUNK, SegmentChunk, axis_at, project};
use crate::rigdata::{BODY_RADIUS, RigData};

/// Trace slots per sloth per frame.
pub const MAX_TRACES: usize = 8;
/// Reach-checked step-search candidates per limb per frame.
const MAX_REACH_CHECKS_PER_FRAME: u32 = 8;
/// Coarse search stride, in back-offs (see [`Sloth::queue_candidates`]).
const COARSE_STRIDE: u32 = 3;
/// Candidates traced per searching limb per frame. One: the search stops at
/// the first candidate that passes the reach checks (farthest first), and its
/// trace almost always confirms it; when it does not, the search goes on
/// from the next candidate in the next frame.
const CANDIDATES_PER_LIMB: usize = 1;
/// A traced grip this close to the candidate's predicted one (and with its
/// normal within [`RECHECK_NORMAL_COS`]) is the grip the reach checks passed.
const RECHECK_DISTANCE: f32 = 1e-4;
/// Reach checks give up once a sweep gains less than this (metres)…
const CHECK_MIN_IMPROVEMENT: f32 = 1e-5;
/// …or after this many sweeps.
const CHECK_MAX_ITERATIONS: u32 = 32;
/// A reach check polishes (see `slothsim_rig::refine`) only sweeps that
/// stalled within this distance (metres) of the target.
const CHECK_POLISH_MAX_ERROR: f32 = 0.01;
/// The body turns up to this fast (rad/s) without smoothing lag; faster
/// changes of formula 6's rotation are smoothed (`body_smoothing_s`).
const BODY_FREE_TURN_RATE: f32 = 1.5;
/// A limb settled short of its target stays so while the target moves less
/// than this (metres) in the limb's root frame.
const SETTLED_MOVE: f32 = 1e-5;
/// A planted limb's cold restart (see [`Sloth::solve_limbs`]) that did not
/// beat the warm solve by [`COLD_RETRY_GAIN`] is not tried again until the
/// target has moved this far (metres, root frame) from where it failed. At the
/// edge of the reach both end in the same pose (within 0.1 µm in a 1,000-sloth
/// crowd, after 70–80 sweeps): retried every frame, the restarts cost a tenth
/// of the tick.
const COLD_RETRY_MOVE: f32 = 0.02;
/// See [`COLD_RETRY_MOVE`] (metres).
const COLD_RETRY_GAIN: f32 = 5e-4;
/// See [`RECHECK_DISTANCE`].
const RECHECK_NORMAL_COS: f32 = 0.9999;
/// How far outside the surface a grip trace starts.
const TRACE_STANDOFF: f32 = 0.15;
/// Grips keep this far from a support's ends.
const END_MARGIN: f32 = 0.03;
/// A grip closer to its root than this fraction of reach is too folded.
const MIN_REACH_FRACTION: f32 = 0.3;
/// The sloth stops (no grip) after this many step searches in a row found
/// nothing: two full gait cycles in which no limb could move.
const STOP_AFTER_FAILED_SEARCHES: u8 = 8;
/// Wander mode: stop after this many turn-backs in a row without a step.
const MAX_STALLED_TURNS: u8 = 2;
/// Wander mode: a sloth stopped that way tries again after this long
/// (seconds): sloths that boxed it in may have moved on.
const WANDER_RETRY_S: f32 = 5.0;
/// A step is taken only if CCD (within joint limits) gets the stepping limb's
/// claw this close to its new grip from the stance that step implies…
const STANCE_IK_TOLERANCE: f32 = 0.0015;
/// …and every other claw this close to the grip it holds.
const HOLD_IK_TOLERANCE: f32 = 0.003;
/// A step may not put the body deeper than this into a support.
const STANCE_MAX_PENETRATION: f32 = 0.005;
/// The same while the stepping limb is on its arc (transient; checked at
/// [`SWING_CHECKS`]).
const SWING_IK_TOLERANCE: f32 = 0.0035;

/// Leg order: a hind grip stays this far behind every fore grip along the body (m).
const LEG_ORDER_MARGIN: f32 = 0.0;
/// A branch → trunk transfer: how far a fore grip may lead the hind grips along the body (m).
const MAX_TRANSFER_SPREAD: f32 = 0.55;
/// A side's fore and hind grips stay this far apart along the body (m).
const SAME_SIDE_SPACING: f32 = 0.15;
/// A limb never steps further ahead of the other limb of its girdle than this
/// fraction of the max step, so that limb keeps a window to step into (it
/// may not land behind this one).
const MAX_GIRDLE_LEAD: f32 = 0.8;
/// Back-off of the lookahead's coarse candidate scan.
const LOOKAHEAD_STRIDE: f32 = 0.02;
/// On a trunk reached from a branch the body faces the trunk from this angle
/// around it from the branch (radians): beside the branch, head clear of it.
const TRANSFER_SIDE_ANGLE: f32 = std::f32::consts::FRAC_PI_3;
/// A step across a branch ↔ trunk junction may be this many max steps long:
/// it reaches around the trunk, and the IK reach checks bound it.
const TRANSFER_STEP_FACTOR: f32 = 1.5;
/// The body's roll over a transfer follows the share of limbs on the trunk to this power.
const TRANSFER_ROLL_POWER: f32 = 0.75;
/// Mid-transfer the body's up leans this much (at most) away from the trunk,
/// so the body clears it while the hind limbs are still on the branch. No
/// more: every centimetre the body is pushed off the trunk is one the limbs
/// reaching around it lack (0.3 stranded the second fore limb on a branch
/// meeting the trunk from below at 135–140°; the stance checks reject any
/// penetration a smaller lean would cause).
const TRANSFER_AWAY: f32 = 0.15;
/// On a branch by a trunk, the body hanging below the branch that would come
/// within this distance of the trunk rolls about the branch toward its own
/// side, all the way ([`HANG_MAX_ROLL`]) where it would touch the trunk (m).
/// In the narrow fork under a branch that falls away from its trunk
/// (trunk_branch at 135°–150°) the body has no room below the branch. With
/// 0.08 the matrix's trunk_branch sweep passes the same angles, with 0.12
/// it loses 120° and 150°.
const HANG_CLEARANCE: f32 = 0.1;
/// A body less than this far off its branch's vertical plane hangs in it
/// (m): it rolls to the right of its heading (see `Sloth::keep_hang_side`).
const HANG_SIDE_TIE: f32 = 0.01;
/// A trunk whose direction from the body is this far (cosine) to a side of
/// the branch's vertical plane or more decides the roll: away from it; one
/// in the plane (the fork below a branch) leaves it to the body's own side
/// ([`Sloth::hang_side`]), with no roll where the two disagree halfway (a
/// crowd sloth rolled its own way into a trunk beside the branch).
const HANG_TRUNK_SIDE: f32 = 0.3;
/// The most the body rolls about a branch to clear a trunk: level with the
/// branch, beside it (radians).
const HANG_MAX_ROLL: f32 = std::f32::consts::FRAC_PI_2;
/// The roll is full only with the body heading out from the trunk at least
/// this steeply (cosine to the trunk's radial direction), none heading
/// across or toward it: a body coming along a branch to its trunk keeps
/// below it until the transfer turns it (see `transfer_to_trunk`).
const HANG_OUT_COS: f32 = 0.5;
/// A fore limb takes a trunk at least this far above the hind limbs' grips (head up).
const HEAD_UP_MARGIN: f32 = 0.05;
/// Wander mode: a branch → trunk change is taken walking at most this steeply
/// down toward the trunk (sine of the slope).
const WANDER_MAX_DESCENT_SIN: f32 = -0.05;
/// Wander mode: trunks taken from a branch are at most this thick where the
/// branch meets them (metres; thicker ones the limbs cannot climb: README).
const WANDER_MAX_TRUNK_RADIUS: f32 = 0.2;
/// Wander mode: a trunk is left for a branch rising at least this steeply
/// from it (sine; 80° from the trunk's up axis: trunk → branch passes 60–80°).
const WANDER_MIN_RISE_SIN: f32 = 0.17;
/// Side steps around a trunk (SPEC `find_side_step`): each step places its
/// grip around the side the body faces the trunk from, turned about the axis
/// toward the goal's side by at most this much (radians) and ...
const SIDE_STEP_MAX_TURN: f32 = 0.35;
/// ... by at most this much of the trunk's surface (metres) ...
const SIDE_STEP_MAX_ARC: f32 = 0.05;
/// ... until the body faces the trunk from within this angle of that side.
const SIDE_STEP_DONE: f32 = 0.05;
/// A side step may lose this much height along the axis (metres).
const SIDE_STEP_AXIAL_SLACK: f32 = 0.02;

/// A change between a branch and a trunk in progress (SPEC `transfer_to_trunk`,
/// `transfer_to_branch`). On the trunk the body faces it from `side`; while
/// the limbs move across, the body rolls about its long axis between hanging
/// below the branch and facing the trunk (see [`Sloth::body_frame`]).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Transfer {
    /// The support the limbs move onto.
    pub to: SupportId,
    /// The trunk.
    pub trunk: SupportId,
    /// Unit direction from the trunk's axis toward the body on the trunk,
    /// perpendicular to the axis; chosen once when the transfer starts.
    pub side: Vec3,
    /// Unit direction from the trunk's axis toward the branch, perpendicular to the axis.
    pub away: Vec3,
}

/// A side step around a trunk (see [`Sloth::side_step`]).
#[derive(Clone, Copy, Debug)]
struct SideStep {
    /// Signed turn about `axis_up` of the side the step's grip is placed around (radians).
    turn: f32,
    /// The trunk's axis, pointing up.
    axis_up: Vec3,
    /// Unit direction from the axis to the body now.
    side_now: Vec3,
    /// The goal's height along `axis_up` relative to the body's (metres).
    axial_to_goal: f32,
}

/// Shared read-only inputs of the kernels.
#[derive(Clone, Copy)]
pub struct World<'a> {
    /// Locomotion parameters (validated).
    pub cfg: &'a LocomotionConfig,
    /// Rig data.
    pub rig: &'a RigData,
    /// Body offset below the paws (formula 7), resolved.
    pub body_offset: f32,
    /// Trace queries over the forest.
    pub query: SceneQuery<'a>,
    /// Support adjacency.
    pub adjacency: &'a Adjacency,
    /// IK parameters.
    pub ccd: &'a CcdParams,
    /// Other sloths' bodies and grips (previous tick), when in a crowd.
    pub crowd: Option<&'a CrowdGrid>,
}

impl World<'_> {
    fn scene(&self) -> &Scene {
        self.query.scene()
    }
}

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
    /// [`Sloth::goal_branch_search`]); once exhausted, the trunk is searched.
    pub goal_first: bool,
}

/// One limb.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LimbState {
    /// Phase.
    pub phase: LimbPhase,
    /// Held grip (planted/searching) or the grip being swung to.
    pub grip: Grip,
    /// Swing start point and normal.
    pub from: Vec3,
    /// Surface normal at the swing start.
    pub from_normal: Vec3,
    /// Support held at the swing start.
    pub from_support: SupportId,
    /// Swing progress 0..1.
    pub swing_t: f32,
    /// IK target this frame.
    pub target: Vec3,
    /// Warm-started IK pose.
    #[serde(with = "pose_serde")]
    pub pose: ChainPose,
    /// Chain root this frame (world).
    pub root: Vec3,
    /// Claw tip after IK (world).
    pub effector: Vec3,
    /// Search state (valid while `Searching`).
    pub search: Search,
    /// The gait clock asked this limb to step and it has not yet.
    pub due: bool,
    /// The target (chain-root frame) of the last solve, if that solve ended
    /// short of it (joint limits): the pose is settled there until the target
    /// moves (see [`Sloth::solve_limbs`]).
    pub settled_ls: Option<Vec3>,
    /// The target (chain-root frame) at which a cold restart of this planted
    /// limb's solve last failed to beat its warm solve: not tried again within
    /// [`COLD_RETRY_MOVE`] of it (cleared when the limb swings).
    pub cold_miss_ls: Option<Vec3>,
    /// A step this limb takes by a deadline unless its own search finds one
    /// first: another limb's step was checked with this one lifting off on
    /// the gait clock during its swing ([`Sloth::next_lift`]).
    #[serde(default)]
    pub fallback: Option<Fallback>,
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

/// One sloth.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Sloth {
    /// Stable id (crowd neighbour checks skip the sloth's own points).
    pub id: u32,
    /// Body position (model origin) and rotation (model +Z forward, +Y toward the support).
    pub body_pos: Vec3,
    /// Body rotation.
    pub body_rot: Quat,
    /// Limbs by `Limb::index`.
    pub limbs: [LimbState; 4],
    /// Gait clock phase 0..1.
    pub clock: f32,
    /// +1: travel head first; −1: tail first (descending a trunk head-up).
    pub dir: f32,
    /// Simulated time.
    pub time: f32,
    /// Status.
    pub status: Status,
    /// Goal: support and point, if any.
    pub goal: Option<(SupportId, Vec3)>,
    /// Goal tolerance (metres).
    pub goal_tolerance: f32,
    /// On a trunk goal: the unit direction from the trunk's axis toward the
    /// body at the goal (the body moves around the axis with side steps until
    /// it faces the trunk from there). `None`: any side.
    #[serde(default)]
    pub goal_side: Option<Vec3>,
    /// Step searches that found nothing since the last step taken.
    pub failed_searches: u8,
    /// Autorun: no goal; at a dead end (or blocked by other sloths) turn
    /// back instead of stopping, and pick among neighbour supports by `seed`.
    pub wander: bool,
    /// Seed of this sloth's route choices (wander mode).
    pub seed: u64,
    /// Times this sloth turned back (wander mode); varies route choices.
    pub turns: u32,
    /// Turn-backs since the last step taken (wander mode).
    pub stalled_turns: u8,
    /// Branch ↔ trunk transfer in progress, if any.
    pub transfer: Option<Transfer>,
    /// The share of `offset_back_m` the hind pair's swing onto a branch
    /// uses (the most its stance checks allowed).
    pub hind_back_scale: f32,
    /// The side of its branch the body is on (from the paws' mean), kept
    /// while it rolls about the branch to clear a trunk: in the fork below a
    /// branch the roll goes that way (see [`Sloth::hang_roll`]). It is
    /// state, not read off the drawn body, so the step checks roll a stance
    /// the way the drawn body will.
    pub hang_side: Vec3,
    /// Off a trunk onto a branch (`transfer_to_branch`): that trunk, which
    /// the body still rolls clear of while it walks out of the fork, until
    /// a step search starts unrolled (see [`Sloth::hang_roll`]).
    pub hang_trunk: Option<SupportId>,
    /// Wander mode, stopped (`NoGrip`): the time it tries again (the way
    /// may have been blocked by sloths that since moved on).
    pub resume_at: Option<f32>,
}

/// Words of a [`SolveKey`]: the body (position, rotation), then per limb its
/// target, pose, settled target and cold-miss target (each with a flag),
/// phase, root and effector.
const SOLVE_KEY_LEN: usize = 7 + 4 * (3 + 16 + 4 + 4 + 1 + 3 + 3);

/// The bits of the fields [`Sloth::solve_limbs`] reads or writes.
type SolveKey = [u32; SOLVE_KEY_LEN];

/// Words of a [`BodyKey`]: the body (position, rotation), the hang side and flag,
/// the transfer (flag, supports, side, away), then per limb its phase, grip
/// point and support, and target.
const BODY_KEY_LEN: usize = 7 + 4 + 9 + 4 * 8;

/// The bits of the fields [`Sloth::body_average`] reads or writes while no
/// limb swings.
type BodyKey = [u32; BODY_KEY_LEN];

/// What [`Sloth::body_average_memo`] keeps of the sloth's last BodyAverage.
#[derive(Clone, Copy, Debug, Default)]
pub struct BodyMemo {
    /// The state a BodyAverage left unchanged.
    fixed: Option<BodyKey>,
}

/// What [`Sloth::solve_limbs_memo`] keeps of the sloth's last CcdSolve.
#[derive(Clone, Copy, Debug, Default)]
pub struct SolveMemo {
    /// The state a solve left unchanged and its sweep count; `None` after a
    /// solve that changed something.
    fixed: Option<(SolveKey, u32)>,
}

impl SolveMemo {
    /// The sweep count of the unchanged solve `key` matches, if it does.
    fn hit(&self, key: &Option<SolveKey>) -> Option<u32> {
        match (&self.fixed, key) {
            (Some((fixed, iterations)), Some(key)) => (fixed == key).then_some(*iterations),
            _ => None,
        }
    }

    /// After a solve from `key`: kept where it left the sloth unchanged.
    fn keep(&mut self, sloth: &Sloth, key: Option<SolveKey>, iterations: u32) {
        self.fixed = key
            .filter(|key| sloth.solve_key().as_ref() == Some(key))
            .map(|key| (key, iterations));
    }
}

/// What [`Sloth::solve_limbs`] computes before its IK: each limb's chain root,
/// target (world and root space) and whether it stays settled.
struct SolvePrep {
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    targets_ls: [Vec3; 4],
    settled: [bool; 4],
}

impl SolvePrep {
    /// Nothing to solve: every limb keeps its settled pose.
    fn all_settled(&self) -> bool {
        self.settled.iter().all(|&s| s)
    }
}

impl AsMut<Sloth> for Sloth {
    fn as_mut(&mut self) -> &mut Sloth {
        self
    }
}

impl AsMut<SolveMemo> for SolveMemo {
    fn as_mut(&mut self) -> &mut SolveMemo {
        self
    }
}

/// A memo key being written: `N` words of bits, filled in order.
struct KeyBits<const N: usize> {
    k: [u32; N],
    at: usize,
}

impl<const N: usize> KeyBits<N> {
    fn new() -> Self {
        KeyBits { k: [0; N], at: 0 }
    }

    fn u32s(&mut self, v: &[u32]) {
        self.k[self.at..self.at + v.len()].copy_from_slice(v);
        self.at += v.len();
    }

    fn f32s(&mut self, v: &[f32]) {
        for (d, x) in self.k[self.at..self.at + v.len()].iter_mut().zip(v) {
            *d = x.to_bits();
        }
        self.at += v.len();
    }

    /// The key (every word written).
    fn done(self) -> [u32; N] {
        debug_assert_eq!(self.at, N);
        self.k
    }
}

/// Eight SIMD lanes' values: `a`'s in lanes 0..4, `b`'s in 4..8.
fn lanes8<T: Copy>(a: [T; 4], b: [T; 4]) -> [T; 8] {
    std::array::from_fn(|i| if i < 4 { a[i] } else { b[i - 4] })
}

/// Lanes `k..k + 4` of eight.
fn lanes4<T: Copy>(v: &[T; 8], k: usize) -> [T; 4] {
    std::array::from_fn(|i| v[k + i])
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
    /// [`Sloth::pair_back_scale`]).
    pub back_scale: f32,
    /// The limb its checks let lift off during the swing and that limb's
    /// committed step ([`Sloth::next_lift`]); `None`: every other limb holds.
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

#[inline]
fn smoothstep(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The swing arc at progress `t` from grip `from` to grip `to` (points and
/// surface normals): eased along the chord, lifted clear of the support
/// along the normals' mean (`fallback`, the body's down, where they cancel).
fn swing_point(
    from: (Vec3, Vec3),
    to: (Vec3, Vec3),
    t: f32,
    clearance: f32,
    fallback: Vec3,
) -> Vec3 {
    // Between nearly opposite normals (a grip crossing to the other side of
    // a support) their mean says little: it leans toward `fallback` (away
    // from the body's supports), so the arc does not swing on a rounding.
    let sum = from.1 + to.1;
    let n = (sum + fallback * (1.0 - sum.length()).max(0.0)).normalize_or(fallback);
    let lift = clearance * (std::f32::consts::PI * t).sin();
    from.0.lerp(to.0, smoothstep(t)) + n * lift
}

/// 1 for a trunk, 0 for a branch; from `a` to `b` eased by swing progress `t`.
fn trunk_blend(w: &World<'_>, a: SupportId, b: SupportId, t: f32) -> f32 {
    let k = |sid| f32::from(w.scene().support(sid).kind == SupportKind::Trunk);
    let (ka, kb) = (k(a), k(b));
    ka + (kb - ka) * smoothstep(t)
}

/// Formula 7's offset of the body below the paws, and the share of limbs on
/// a trunk it was blended by (a branch ↔ trunk transfer also rolls the body
/// by that share: see [`Sloth::body_frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct BodyOffset {
    /// Metres below the mean of the paws.
    metres: f32,
    /// Share of limbs on a trunk, 0..1.
    trunk_share: f32,
    /// `transfer_to_branch`'s "offset back": metres the hindquarters are
    /// moved off the trunk while the hind pair swings onto the branch.
    hind_back_m: f32,
}

/// Which side a body walking a trunk faces it from (see [`Sloth::body_frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum BodySide {
    /// From where the body is now: what `body_average` draws, frame by
    /// frame, so the drawn side follows the grips' mean a few frames late.
    Body,
    /// From the grips' mean: where the drawn side settles.
    Grips,
}

/// Formula 7's offset of the body below the paws for limbs with trunk
/// weights `weights`: the branch offset, blended toward the trunk offset by
/// the share of limbs on a trunk.
fn body_offset(w: &World<'_>, weights: [f32; 4]) -> BodyOffset {
    let trunk = w.cfg.trunk_body_offset_m.unwrap_or(w.body_offset);
    let share = weights.iter().sum::<f32>() * 0.25;
    BodyOffset {
        metres: w.body_offset + (trunk - w.body_offset) * share,
        trunk_share: share,
        hind_back_m: 0.0,
    }
}

/// The hindquarters' "offset back" at swing progress `t` of the hind pair,
/// as a share of `offset_back_m`: sin²(πt) rises from 0 and returns to 0 with
/// zero slope at both ends, so the body never jumps.
fn hind_back_share(t: f32) -> f32 {
    (std::f32::consts::PI * t.clamp(0.0, 1.0)).sin().powi(2)
}

/// The step search of a limb holding `g`, on its own support: from one
/// search distance ahead back to the grip.
fn search_ahead(w: &World<'_>, g: Grip) -> Search {
    Search {
        support: g.support,
        sdir: g.sdir,
        first_u: g.u + g.sdir * w.cfg.search_distance_m,
        next_u: g.u + g.sdir * w.cfg.search_distance_m,
        last_u: g.u,
        neighbour: u16::MAX,
        retreat: false,
        goal_first: false,
    }
}

/// A limb lifting off on the gait clock during another's swing is checked
/// as holding its grip this long past its clock time (its own search may
/// take a few frames) and as in the air from then on: the deadline of its
/// committed step ([`Sloth::next_lift`]).
const LIFT_MARGIN_S: f32 = 0.05;

/// Stride of the search for a committed step ([`Sloth::fallback_step`]).
const FALLBACK_STRIDE: f32 = 0.05;

/// Reach checks the search for a committed step may make.
const FALLBACK_MAX_CHECKS: u32 = 6;

/// Swing progress points at which a step's transient stance is checked.
const SWING_CHECKS: [f32; 3] = [0.3, 0.55, 0.8];

/// Stances a step with a lift-off during its swing passes through (see
/// [`Sloth::lift_reachable`]): both limbs' arc points and both ends.
const MAX_STANCES: usize = 2 * (SWING_CHECKS.len() + 1) + 1;

/// Stances a step check solves: the arc's points and the end.
const STANCE_CHECKS: usize = SWING_CHECKS.len() + 1;

/// Further swing progress points at which a branch ↔ trunk step's body is
/// checked for penetration (every 5 % with [`SWING_CHECKS`]).
const TRANSFER_BODY_CHECKS: [f32; 16] = [
    0.05, 0.1, 0.15, 0.2, 0.25, 0.35, 0.4, 0.45, 0.5, 0.6, 0.65, 0.7, 0.75, 0.85, 0.9, 0.95,
];

/// Body frame for a support: (forward, up toward the support) at an axis point.
/// Branch: up = world +Y made perpendicular to forward. Trunk: forward = the
/// axis pointing up (head up), up = from the body toward the axis.
fn support_frame(
    kind: SupportKind,
    tangent_travel: Vec3,
    axis_tangent: Vec3,
    body_side: Vec3,
) -> (Vec3, Vec3) {
    match kind {
        SupportKind::Branch => {
            let f = tangent_travel;
            let up =
                (Vec3::Y - f * f.dot(Vec3::Y)).normalize_or(Vec3::Z.cross(f).normalize_or(Vec3::X));
            (f, up)
        }
        SupportKind::Trunk => {
            let f = if axis_tangent.y >= 0.0 {
                axis_tangent
            } else {
                -axis_tangent
            };
            let up = -(body_side - f * f.dot(body_side)).normalize_or(f.any_orthonormal_vector());
            (f, up)
        }
    }
}

/// Which way from the axis a limb's grip sits: its side, turned toward the
/// body on trunks.
fn grip_out(kind: SupportKind, limb: Limb, f: Vec3, up: Vec3, trunk_angle: f32) -> Vec3 {
    let right = f.cross(up);
    let side = if limb.is_left() { -right } else { right };
    match kind {
        SupportKind::Branch => side,
        SupportKind::Trunk => (side * trunk_angle.cos() - up * trunk_angle.sin()).normalize(),
    }
}

/// The mean of four IK targets (formula 7's paws' mean).
fn paws_mean(t: &[Vec3; 4]) -> Vec3 {
    (t[0] + t[1] + t[2] + t[3]) * 0.25
}

fn rotation_from(f: Vec3, up: Vec3) -> Quat {
    let z = f.normalize_or(Vec3::Z);
    let y = (up - z * z.dot(up)).normalize_or(z.any_orthonormal_vector());
    let x = y.cross(z);
    Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize()
}

/// Whether CCD within the joint limits, from `pose`, gets the claw within
/// `tol` of `target_ws` (and the error it ends at); `pose` is left where the
/// solve ended. Solved only as close as the check needs (a passing check stops
/// early); the limit-aware polish (see `slothsim_rig::refine`) runs only for
/// sweeps that stalled within [`CHECK_POLISH_MAX_ERROR`] — close to a corner
/// of the joint limits it may still get there, far off it would not.
fn reach_check(
    chain: &slothsim_rig::LimbChain,
    root: slothsim_rig::RootTransform,
    target_ws: Vec3,
    pose: &mut ChainPose,
    tol: f32,
    base: &CcdParams,
) -> (bool, f32) {
    let params = CcdParams {
        tolerance: tol,
        ..check_params(base)
    };
    let r = slothsim_rig::solve(chain, root, target_ws, pose, &params);
    reach_check_polish(chain, root, target_ws, pose, tol, base, r.error)
}

/// The sweeps' parameters of [`reach_check`] (tolerance aside).
fn check_params(base: &CcdParams) -> CcdParams {
    CcdParams {
        min_improvement: CHECK_MIN_IMPROVEMENT,
        refine: false,
        ..*base
    }
}

/// The rest of [`reach_check`] after its sweeps ended at `error` with the
/// limb at `pose`: the polish where it may help.
fn reach_check_polish(
    chain: &slothsim_rig::LimbChain,
    root: slothsim_rig::RootTransform,
    target_ws: Vec3,
    pose: &mut ChainPose,
    tol: f32,
    base: &CcdParams,
    error: f32,
) -> (bool, f32) {
    if error <= tol || error > CHECK_POLISH_MAX_ERROR || !base.refine {
        return (error <= tol, error);
    }
    let params = CcdParams {
        tolerance: tol,
        refine: true,
        ..check_params(base)
    };
    let r = slothsim_rig::solve(chain, root, target_ws, pose, &params);
    (r.error <= tol, r.error)
}

/// One stance a step passes through (see [`Sloth::step_reachable`]): the
/// four IK targets, how close each claw must get, and the body they imply.
#[derive(Clone, Copy)]
struct StanceCheck {
    grips: [Vec3; 4],
    tol: [f32; 4],
    pos: Vec3,
    rot: Quat,
    /// The body offset it was placed with.
    offset: BodyOffset,
    /// The chain roots of that body.
    roots: [RootTransform; 4],
}

impl Sloth {
    /// Places a sloth with all four limbs gripping around `hint`, body
    /// averaged, limbs solved. Grips are placed analytically on the surface.
    pub fn spawn(w: &World<'_>, hint: &SpawnHint, goal: Option<(SupportId, Vec3, f32)>) -> Sloth {
        let scene = w.scene();
        let s = scene.support(hint.support);
        let c = project(s, hint.position);
        let sdir = if c.tangent.dot(hint.forward) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let (f, up) = support_frame(s.kind, c.tangent * sdir, c.tangent, hint.body_side);
        let dir = if s.kind == SupportKind::Trunk && hint.forward.dot(f) < 0.0 {
            -1.0
        } else {
            1.0
        };
        // Paws above their roots, roughly where the neutral pose puts them.
        let mut limbs = [LimbState {
            phase: LimbPhase::Planted,
            grip: Grip {
                point: c.point,
                normal: Vec3::Y,
                support: hint.support,
                u: c.u,
                sdir,
            },
            from: c.point,
            from_normal: Vec3::Y,
            from_support: hint.support,
            swing_t: 0.0,
            target: c.point,
            pose: ChainPose::NEUTRAL,
            root: c.point,
            effector: c.point,
            search: Search {
                support: hint.support,
                sdir,
                first_u: 0.0,
                next_u: 0.0,
                last_u: 0.0,
                neighbour: u16::MAX,
                retreat: false,
                goal_first: false,
            },
            due: false,
            settled_ls: None,
            cold_miss_ls: None,
            fallback: None,
        }; 4];
        let len = s.length();
        for limb in Limb::ALL {
            // `along` metres ahead along the body's forward axis.
            let along = w.rig.neutral_tip_ms[limb.index()].z * 0.9;
            let u = (c.u + along * f.dot(c.tangent).signum()).clamp(END_MARGIN, len - END_MARGIN);
            let a = axis_at(s, u);
            let out = grip_out(s.kind, limb, f, up, w.cfg.trunk_grip_angle_deg.to_radians());
            let l = &mut limbs[limb.index()];
            l.grip = Grip {
                point: a.point + out * a.radius,
                normal: out,
                support: hint.support,
                u,
                sdir,
            };
            l.target = l.grip.point;
            l.from = l.grip.point;
            l.from_normal = out;
        }
        let mut sloth = Sloth {
            id: 0,
            body_pos: c.point - up * w.body_offset,
            body_rot: rotation_from(f, up),
            limbs,
            clock: 0.999,
            dir,
            time: 0.0,
            status: Status::Moving,
            goal: goal.map(|(s, p, _)| (s, p)),
            goal_tolerance: goal.map_or(0.3, |g| g.2),
            goal_side: None,
            failed_searches: 0,
            wander: false,
            seed: 0,
            turns: 0,
            stalled_turns: 0,
            resume_at: None,
            transfer: None,
            hind_back_scale: 1.0,
            hang_side: Vec3::ZERO,
            hang_trunk: None,
        };
        // Settle the stance: a few rounds of (body from grips; each grip slid
        // along the support to where its limb reaches it best, searched in
        // 1 cm steps around the current one).
        let cold = CcdParams {
            max_iterations: 256,
            ..*w.ccd
        };
        for _round in 0..3 {
            let (pos, rot) = sloth.averaged_body(w);
            sloth.body_pos = pos;
            sloth.body_rot = rot;
            for limb in Limb::ALL {
                let li = limb.index();
                let root = w.rig.root_ws(li, pos, rot);
                let out = sloth.limbs[li].grip.normal;
                let u0 = sloth.limbs[li].grip.u;
                let mut best = (f32::INFINITY, u0, sloth.limbs[li].pose);
                // Reachable grips: the middle of the reachable run (the
                // stance then has room both ways); else the nearest miss.
                let mut reachable = [(0.0f32, ChainPose::NEUTRAL); 31];
                let mut n_reachable = 0;
                // The scan moves the target 1 cm at a time: each solve starts
                // warm from the last (a cold solve costs ~40 warm ones).
                let mut pose = ChainPose::NEUTRAL;
                for k in -15..=15 {
                    let u = (u0 + k as f32 * 0.01).clamp(END_MARGIN, len - END_MARGIN);
                    let a = axis_at(s, u);
                    let p = a.point + out * a.radius;
                    let chain = &w.rig.chains[li];
                    let (ok, error) =
                        reach_check(chain, root, p, &mut pose, STANCE_IK_TOLERANCE, &cold);
                    if ok {
                        reachable[n_reachable] = (u, pose);
                        n_reachable += 1;
                    }
                    let score = error + 0.001 * (k as f32).abs();
                    if score < best.0 {
                        best = (score, u, pose);
                    }
                }
                if n_reachable > 0 {
                    let (u, pose) = reachable[n_reachable / 2];
                    best = (0.0, u, pose);
                }
                let a = axis_at(s, best.1);
                let l = &mut sloth.limbs[li];
                l.grip.u = best.1;
                l.grip.point = a.point + out * a.radius;
                l.target = l.grip.point;
                l.from = l.grip.point;
                l.pose = best.2;
            }
        }
        let (pos, rot) = sloth.averaged_body(w);
        sloth.body_pos = pos;
        sloth.body_rot = rot;
        sloth.keep_hang_side(w);
        for _ in 0..4 {
            sloth.solve_limbs_with(w, &cold);
        }
        sloth
    }

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
    fn goal_distance(&self, w: &World<'_>) -> Option<(f32, bool)> {
        self.goal_distance_with(w, Self::holds_only)
    }

    /// [`Self::goal_distance`] with `on(self, goal support)` deciding
    /// whether the goal's support is held.
    fn goal_distance_with(
        &self,
        w: &World<'_>,
        on: fn(&Self, SupportId) -> bool,
    ) -> Option<(f32, bool)> {
        let (gs, gp) = self.goal?;
        let a = project(w.scene().support(gs), self.body_pos);
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
        self.limbs.map(|l| l.target)
    }

    /// Body frame toward the support the fore limbs hold (formula 6 gives
    /// forward). During a branch ↔ trunk transfer the body's up (toward the
    /// support) is blended by `trunk_share` (the share of limbs on a trunk)
    /// from world up (hanging below the branch) to facing the trunk from the
    /// transfer's side: a roll about the long axis in one direction, chosen
    /// when the transfer started, so it never passes through the degenerate
    /// "up toward the trunk along forward" of a body facing the trunk.
    fn body_frame(
        &self,
        w: &World<'_>,
        t: &[Vec3; 4],
        offset: BodyOffset,
        side: BodySide,
    ) -> (Vec3, Vec3) {
        let fwd = self.formula6_fwd(t);
        let mean = paws_mean(t);
        let s = w.scene().support(self.limbs[Limb::LF.index()].grip.support);
        let on_trunk = self.fore_on_trunk(w);
        let up = if let Some(tr) = self.transfer {
            // Rolled by a power of the share (the roll leads the limbs a
            // little), and pushed off the trunk mid-transfer so the body
            // clears it while the hind limbs are still on the branch.
            let r = offset.trunk_share.powf(TRANSFER_ROLL_POWER);
            let hang = self.hang_up(fwd, self.hang_roll(w, fwd, mean, offset.metres));
            hang * (1.0 - r) - tr.side * r - tr.away * (TRANSFER_AWAY * 4.0 * r * (1.0 - r))
        } else if on_trunk {
            let a = project(s, mean);
            let body_side = match side {
                BodySide::Body => self.body_pos - a.point,
                BodySide::Grips => mean - a.point,
            };
            -(body_side - fwd * fwd.dot(body_side)).normalize_or(self.body_rot * Vec3::Y * -1.0)
        } else {
            // On branches: below them, clear of the trunks they meet.
            self.hang_up(fwd, self.hang_roll(w, fwd, mean, offset.metres))
        };
        let up = (up - fwd * fwd.dot(up)).normalize_or(self.body_rot * Vec3::Y);
        (fwd, up)
    }

    /// Formula 6 for IK targets `t`: the average of the hind → fore
    /// directions of both sides.
    fn formula6_fwd(&self, t: &[Vec3; 4]) -> Vec3 {
        let (lf, rf, lh, rh) = (
            t[Limb::LF.index()],
            t[Limb::RF.index()],
            t[Limb::LH.index()],
            t[Limb::RH.index()],
        );
        ((rf - rh).normalize_or_zero() + (lf - lh).normalize_or_zero())
            .normalize_or(self.body_rot * Vec3::Z)
    }

    /// How far the body (heading `fwd`, paws' mean `mean`, `metres` below
    /// it) rolls about its branch to clear a trunk, as a share of
    /// [`HANG_MAX_ROLL`] (signed: + toward heading × up): in a transfer
    /// under way, from its trunk; after a transfer onto a branch, from the trunk left
    /// ([`Sloth::hang_trunk`]); else none (rolling from any trunk a branch
    /// held meets, a crowd's sloths walking past trunks slipped grips by
    /// 2 cm). From that trunk: none unless the body hanging below the branch
    /// would come within [`HANG_CLEARANCE`] of it, all where it would touch
    /// it, and only heading out from it ([`HANG_OUT_COS`]). Continuous in
    /// the paws: the body never jumps between frames or stance checks.
    fn hang_roll(&self, w: &World<'_>, fwd: Vec3, mean: Vec3, metres: f32) -> f32 {
        // A transfer only set up by a search (no limb on its target yet)
        // rolls nothing: one that is not taken leaves no jump behind.
        let under_way = self
            .transfer
            .filter(|tr| self.limbs.iter().any(|l| l.grip.support == tr.to));
        let trunk = match (under_way, self.hang_trunk) {
            (Some(tr), _) => tr.trunk,
            (None, Some(trunk)) if !self.fore_on_trunk(w) => trunk,
            _ => return 0.0,
        };
        let scene = w.scene();
        let up0 = (Vec3::Y - fwd * fwd.dot(Vec3::Y)).normalize_or(Vec3::Y);
        let lateral = fwd.cross(Vec3::Y).normalize_or_zero();
        let own_side = if lateral.dot(self.hang_side) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let pos = mean - up0 * metres;
        let rot = rotation_from(fwd, up0);
        let torso = [pos + rot * w.rig.torso_ms[0], pos + rot * w.rig.torso_ms[1]];
        // The box the torso capsule grown by the clearance fills: a trunk's
        // box apart from it is too far to matter (most trunks, most frames).
        let grow = Vec3::splat(BODY_RADIUS + HANG_CLEARANCE);
        let (lo, hi) = (torso[0].min(torso[1]) - grow, torso[0].max(torso[1]) + grow);
        let (blo, bhi) = w.adjacency.bounds(trunk);
        if blo.cmpgt(hi).any() || bhi.cmplt(lo).any() {
            return 0.0;
        }
        let s = scene.support(trunk);
        let depth = torso_penetration(s, w.adjacency.segment_chunks(trunk), torso, -HANG_CLEARANCE);
        if depth <= -HANG_CLEARANCE {
            return 0.0;
        }
        let a = project(s, mean);
        let radial = (mean - a.point) - a.tangent * a.tangent.dot(mean - a.point);
        let heading_out = (fwd.dot(radial.normalize_or_zero()) / HANG_OUT_COS).clamp(0.0, 1.0);
        let need = heading_out * ((depth + HANG_CLEARANCE) / HANG_CLEARANCE).clamp(0.0, 1.0);
        // Away from a trunk off to a side of the branch; toward the body's
        // own side of it where the trunk is below it (the fork), passing
        // through no roll in between (continuous).
        let trunk_side =
            (lateral.dot((mean - a.point).normalize_or_zero()) / HANG_TRUNK_SIDE).clamp(-1.0, 1.0);
        need * (trunk_side + (1.0 - trunk_side.abs()) * own_side)
    }

    /// At the start of a step search with no other limb in a step (and at
    /// spawn), while the body does not roll about its branch
    /// ([`Self::hang_roll`]): keeps the side of the branch it is on for the
    /// next roll ([`Sloth::hang_side`]): across the heading, horizontal, the
    /// way the body is off the branch's vertical plane (the right of the
    /// heading when it hangs in it: a choice that holds while the heading
    /// turns a little, unlike one read off the body's centimetres). The
    /// step checks that follow and the drawn body roll the same way.
    fn keep_hang_side(&mut self, w: &World<'_>) {
        let t = self.targets();
        let fwd = self.formula6_fwd(&t);
        let mean = paws_mean(&t);
        let metres = body_offset(w, self.trunk_weights(w)).metres;
        if self.hang_roll(w, fwd, mean, metres) != 0.0 {
            return;
        }
        self.hang_trunk = None;
        let lateral = fwd.cross(Vec3::Y).normalize_or_zero();
        self.hang_side = if lateral.dot(self.body_pos - mean) < -HANG_SIDE_TIE {
            -lateral
        } else {
            lateral
        };
    }

    /// The body's up on a branch heading `fwd`: world up turned about the
    /// heading by the signed share `roll` of [`HANG_MAX_ROLL`]
    /// ([`Self::hang_roll`]; + moves the body toward heading × up).
    fn hang_up(&self, fwd: Vec3, roll: f32) -> Vec3 {
        if roll == 0.0 {
            return Vec3::Y;
        }
        // Turning up about the heading by -angle moves the body (below it)
        // toward heading × up.
        Quat::from_axis_angle(fwd, -roll * HANG_MAX_ROLL) * Vec3::Y
    }

    /// Both fore limbs hold the same trunk (the body faces it).
    fn fore_on_trunk(&self, w: &World<'_>) -> bool {
        let fore = self.limbs[Limb::LF.index()].grip.support;
        w.scene().support(fore).kind == SupportKind::Trunk
            && self.limbs[Limb::RF.index()].grip.support == fore
    }

    /// Formulas 6 and 7 for the current targets: (position, rotation).
    fn averaged_body(&self, w: &World<'_>) -> (Vec3, Quat) {
        let mut offset = body_offset(w, self.trunk_weights(w));
        if let Some(t) = self.hind_pair_swing_t() {
            offset.hind_back_m = w.cfg.offset_back_m * self.hind_back_scale * hind_back_share(t);
        }
        self.body_for_targets(w, &self.targets(), offset, BodySide::Body)
    }

    /// Swing progress of `transfer_to_branch`'s hind pair while it travels
    /// from the trunk onto the branch together (see [`Self::hind_pair`]).
    fn hind_pair_swing_t(&self) -> Option<f32> {
        let tr = self.transfer?;
        let (lh, rh) = (self.limbs[Limb::LH.index()], self.limbs[Limb::RH.index()]);
        let pair = [lh, rh].iter().all(|l| {
            l.phase == LimbPhase::Swinging && l.from_support == tr.trunk && l.grip.support == tr.to
        });
        (pair && tr.to != tr.trunk).then_some(lh.swing_t.min(rh.swing_t))
    }

    /// `transfer_to_branch`: once no fore limb is on the trunk, the hind
    /// limbs leave it together (SPEC: the one exception to one limb at a
    /// time). The partner of hind limb `li` stepping onto branch `sid`, if
    /// this is that step.
    fn hind_pair(&self, li: usize, sid: SupportId) -> Option<usize> {
        let tr = self.transfer?;
        let limb = Limb::ALL[li];
        if limb.is_fore() || self.dir < 0.0 || tr.to != sid || tr.trunk == sid {
            return None;
        }
        let partner = limb.opposite().index();
        let on_trunk = |i: usize| self.limbs[i].grip.support == tr.trunk;
        let ready = on_trunk(li)
            && on_trunk(partner)
            && self.limbs[partner].phase != LimbPhase::Swinging
            && !on_trunk(Limb::LF.index())
            && !on_trunk(Limb::RF.index());
        ready.then_some(partner)
    }

    fn body_for_targets(
        &self,
        w: &World<'_>,
        t: &[Vec3; 4],
        offset: BodyOffset,
        side: BodySide,
    ) -> (Vec3, Quat) {
        let (f, up) = self.body_frame(w, t, offset, side);
        let mean = paws_mean(t);
        let (pos, rot) = (mean - up * offset.metres, rotation_from(f, up));
        match self.transfer {
            Some(tr) if offset.hind_back_m > 0.0 => {
                self.hindquarters_back(w, tr.trunk, pos, rot, offset.hind_back_m)
            }
            _ => (pos, rot),
        }
    }

    /// The body turned about its shoulders so that the hips move `back_m`
    /// straight off the trunk's axis: the hindquarters swing out clear of
    /// the trunk while the hind pair travels up onto the branch, and the
    /// planted fore limbs' roots hardly move.
    fn hindquarters_back(
        &self,
        w: &World<'_>,
        trunk: SupportId,
        pos: Vec3,
        rot: Quat,
        back_m: f32,
    ) -> (Vec3, Quat) {
        let fore_ms = (Vec3::from(w.rig.roots_ms[Limb::LF.index()].position)
            + Vec3::from(w.rig.roots_ms[Limb::RF.index()].position))
            * 0.5;
        let shoulders = pos + rot * fore_ms;
        let hips = pos + rot * w.rig.hips_ms;
        let a = project(w.scene().support(trunk), hips);
        let radial = hips - a.point;
        let out = (radial - a.tangent * a.tangent.dot(radial)).normalize_or_zero();
        let from = (hips - shoulders).normalize_or_zero();
        let to = (hips + out * back_m - shoulders).normalize_or_zero();
        if from == Vec3::ZERO || to == Vec3::ZERO {
            return (pos, rot);
        }
        let q = Quat::from_rotation_arc(from, to);
        (shoulders + q * (pos - shoulders), (q * rot).normalize())
    }

    /// How much each limb is on a trunk (1) or a branch (0); a swinging limb
    /// blends its old and new support as it travels, so the body offset that
    /// depends on it (see [`body_offset`]) changes continuously.
    fn trunk_weights(&self, w: &World<'_>) -> [f32; 4] {
        self.limbs.map(|l| match l.phase {
            LimbPhase::Swinging => trunk_blend(w, l.from_support, l.grip.support, l.swing_t),
            _ => trunk_blend(w, l.grip.support, l.grip.support, 1.0),
        })
    }

    /// Whether limb `li` can step to `grip` (surface `normal`): with the
    /// stepping limb at points along its arc the others still reach their
    /// grips (transient tolerance), and at the end every limb reaches its grip
    /// (the stepping limb tightly); no stance pushes the body into a support.
    ///
    /// The checks run cheapest first over all four stances (root distances,
    /// then torso penetration, then CCD within the joint limits), so most
    /// rejections cost no IK at all.
    fn step_reachable(
        &self,
        w: &World<'_>,
        li: usize,
        grip: Vec3,
        normal: Vec3,
        support: SupportId,
    ) -> bool {
        self.steps_reachable(w, &[(li, grip, normal)], support, 0.0)
    }

    /// The limb that lifts off next on the gait clock, if it does so while
    /// limb `li`, about to step, is still in the air, and when (seconds from
    /// now, [`LIFT_MARGIN_S`] included). The steady profile's swings
    /// overlap: a limb lifting off during a step's swing need not hold its
    /// grip to the step's landing, provided it surely lifts off — the step
    /// commits that limb's next step ([`Self::fallback_step`],
    /// [`LimbState::fallback`]). Only for plain steps (no transfer), with
    /// that limb planted and no step of its own committed, and every other
    /// limb planted or landing before it lifts off, none due: no other limb
    /// can lift off first.
    fn next_lift(&self, w: &World<'_>, li: usize) -> Option<(usize, f32)> {
        if self.transfer.is_some() {
            return None;
        }
        let offsets = w.cfg.phase_offsets();
        let cycle = w.cfg.cycle_duration();
        let (lj, wait) = (0..4)
            .filter(|&j| j != li)
            .map(|j| (j, (offsets[j] - self.clock).rem_euclid(1.0) * cycle))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        let start = wait + LIFT_MARGIN_S;
        let a = &self.limbs[lj];
        if start >= w.cfg.swing_duration(Limb::ALL[li])
            || a.phase != LimbPhase::Planted
            || a.due
            || a.fallback.is_some()
        {
            return None;
        }
        let others_clear = (0..4).filter(|&k| k != li && k != lj).all(|k| {
            let l = &self.limbs[k];
            !l.due
                && l.fallback.is_none()
                && match l.phase {
                    LimbPhase::Planted => true,
                    LimbPhase::Searching => false,
                    LimbPhase::Swinging => {
                        (1.0 - l.swing_t) * w.cfg.swing_duration(Limb::ALL[k]) < wait
                    }
                }
        });
        others_clear.then_some((lj, start))
    }

    /// A step for limb `lj` to commit to once limb `li` holds `grip` (see
    /// [`Self::next_lift`]): the farthest of a few candidates on its own
    /// support, every [`FALLBACK_STRIDE`], that passes all of a step's checks
    /// with the other limbs holding. Not traced: the grip is the support
    /// model's surface point (as the hind pair's partner's).
    fn fallback_step(
        &self,
        w: &World<'_>,
        li: usize,
        grip: Grip,
        lj: usize,
        checks: &mut u32,
    ) -> Option<Grip> {
        let next = self.after_steps(w, [(li, grip)]);
        let sr = next.own_search(w, lj);
        if sr.support != self.limbs[lj].grip.support || sr.retreat {
            return None;
        }
        let len = w.scene().support(sr.support).length();
        let mut own_checks = 0;
        let mut u = sr.next_u;
        while (u - sr.last_u) * sr.sdir >= -1e-6 && own_checks < FALLBACK_MAX_CHECKS {
            if (END_MARGIN..=len - END_MARGIN).contains(&u)
                && let Some((_, c)) =
                    next.candidate(w, lj, sr.support, u, sr.sdir, false, false, &mut own_checks)
            {
                *checks += own_checks;
                return Some(Grip {
                    point: c.point,
                    normal: c.out,
                    support: sr.support,
                    u,
                    sdir: sr.sdir,
                });
            }
            u -= sr.sdir * FALLBACK_STRIDE;
        }
        *checks += own_checks;
        None
    }

    /// [`Self::step_reachable`] for limb `li` stepping to `grip` while limb
    /// `lj` lifts off `start_s` into the swing, toward its committed step
    /// `to` ([`Self::next_lift`]): the stances at both swings' arc points
    /// and landings and at that limb's lift-off, each limb holding its grip
    /// until it lifts off and from when it lands.
    #[allow(clippy::too_many_arguments)]
    fn lift_reachable(
        &self,
        w: &World<'_>,
        li: usize,
        grip: Vec3,
        normal: Vec3,
        lj: usize,
        to: Grip,
        start_s: f32,
    ) -> bool {
        let dur_i = w.cfg.swing_duration(Limb::ALL[li]);
        let dur_j = w.cfg.swing_duration(Limb::ALL[lj]);
        let n = SWING_CHECKS.len();
        let mut times = [0.0f32; MAX_STANCES];
        for (k, &t) in SWING_CHECKS.iter().enumerate() {
            times[k] = t * dur_i;
            times[n + 1 + k] = start_s + t * dur_j;
        }
        times[n] = dur_i;
        // The last moment it holds (the body is farthest from its grip).
        times[2 * n + 1] = start_s;
        times[MAX_STANCES - 1] = start_s + dur_j;
        times.sort_by(f32::total_cmp);
        let offset = body_offset(w, self.trunk_weights(w));
        let down = self.body_rot * Vec3::NEG_Y;
        let cur = self.limbs.map(|l| (l.grip.point, l.grip.normal));
        let swings = [
            (li, (grip, normal), 0.0, dur_i),
            (lj, (to.point, to.normal), start_s, dur_j),
        ];
        let stances: [StanceCheck; MAX_STANCES] = std::array::from_fn(|k| {
            let tau = times[k];
            let mut grips = cur.map(|(p, _)| p);
            let mut tol = [HOLD_IK_TOLERANCE; 4];
            for &(l, (p, nrm), s0, dur) in &swings {
                let progress = (tau - s0) / dur;
                if progress >= 1.0 {
                    grips[l] = p;
                    // Checked as closely as a landing at its own landing.
                    if k == MAX_STANCES - 1 || tau == s0 + dur {
                        tol[l] = STANCE_IK_TOLERANCE;
                    }
                } else if progress > 0.0 {
                    grips[l] =
                        swing_point(cur[l], (p, nrm), progress, w.cfg.swing_clearance_m, down);
                    tol[l] = f32::INFINITY;
                }
            }
            self.stance_check(w, grips, tol, offset)
        });
        self.stances_pass(w, &stances)
    }

    /// A plain step of limb `li` to `grip` that holds only with the limb
    /// lifting off next in the air before it lands ([`Self::next_lift`]):
    /// that limb and its committed step, if one passes with it.
    fn planned_lift(
        &self,
        w: &World<'_>,
        li: usize,
        grip: Grip,
        checks: &mut u32,
    ) -> Option<(u8, Grip)> {
        let (lj, start) = self.next_lift(w, li)?;
        let to = self.fallback_step(w, li, grip, lj, checks)?;
        *checks += 1;
        self.lift_reachable(w, li, grip.point, grip.normal, lj, to, start)
            .then_some((lj as u8, to))
    }

    /// Starts limb `li`'s swing to its committed step, if it has one (see
    /// [`LimbState::fallback`]).
    fn start_fallback_swing(&mut self, li: usize) {
        let Some(fb) = self.limbs[li].fallback.take() else {
            return;
        };
        let l = &mut self.limbs[li];
        l.from = l.grip.point;
        l.from_normal = l.grip.normal;
        l.from_support = l.grip.support;
        l.grip = fb.grip;
        l.phase = LimbPhase::Swinging;
        l.swing_t = 0.0;
        l.due = false;
        self.failed_searches = 0;
        self.stalled_turns = 0;
    }

    /// The hind pair's step onto a branch (`transfer_to_branch`): the largest
    /// share of the offset back (all, half, none) with which every stance of
    /// the step holds, if any. The thesis' Offset Back is a visual offset of
    /// the hindquarters by the spine rig; on this rigid torso it moves the
    /// hind limbs' roots, and all of it can take the branch out of their reach.
    fn pair_back_scale(
        &self,
        w: &World<'_>,
        steps: &[(usize, Vec3, Vec3)],
        support: SupportId,
    ) -> Option<f32> {
        let scales: &[f32] = if w.cfg.offset_back_m > 0.0 {
            &[1.0, 0.5, 0.0]
        } else {
            &[0.0]
        };
        scales
            .iter()
            .copied()
            .find(|&k| self.steps_reachable(w, steps, support, k))
    }

    /// [`Self::step_reachable`] for one or more limbs stepping together onto
    /// `support` (`transfer_to_branch`'s hind pair: both on their arcs at the
    /// same progress, the hindquarters offset back as they go).
    fn steps_reachable(
        &self,
        w: &World<'_>,
        steps: &[(usize, Vec3, Vec3)],
        support: SupportId,
        back_scale: f32,
    ) -> bool {
        let mut grips = self.limbs.map(|l| l.grip.point);
        let from = self.limbs.map(|l| (l.grip.point, l.grip.normal));
        let mut weights = self.trunk_weights(w);
        let pair = steps.len() > 1;
        // Points of the arc as `body_average` will draw them (`Some(t)`), or the end.
        let mut stance_at = |at: Option<f32>| {
            let mut tol;
            let mut offset_back = 0.0;
            if let Some(t) = at {
                tol = [SWING_IK_TOLERANCE; 4];
                for &(li, grip, normal) in steps {
                    grips[li] = swing_point(
                        from[li],
                        (grip, normal),
                        t,
                        w.cfg.swing_clearance_m,
                        self.body_rot * Vec3::NEG_Y,
                    );
                    weights[li] = trunk_blend(w, self.limbs[li].grip.support, support, t);
                    // The stepping limb is in the air: its pose is free.
                    tol[li] = f32::INFINITY;
                }
                if pair {
                    offset_back = w.cfg.offset_back_m * back_scale * hind_back_share(t);
                }
            } else {
                tol = [HOLD_IK_TOLERANCE; 4];
                for &(li, grip, _) in steps {
                    grips[li] = grip;
                    weights[li] = trunk_blend(w, support, support, 1.0);
                    tol[li] = STANCE_IK_TOLERANCE;
                }
            }
            let mut offset = body_offset(w, weights);
            offset.hind_back_m = offset_back;
            self.stance_check(w, grips, tol, offset)
        };
        let stances: [StanceCheck; STANCE_CHECKS] =
            std::array::from_fn(|k| stance_at(SWING_CHECKS.get(k).copied()));
        // A step between a branch and a trunk rolls the body fast: between
        // the IK checks' arc points it could enter a support the points do
        // not show, so the body is also checked at every 5 % of the arc.
        let scene = w.scene();
        let kind_change = steps.iter().any(|&(li, ..)| {
            scene.support(self.limbs[li].grip.support).kind != scene.support(support).kind
        });
        if kind_change
            && TRANSFER_BODY_CHECKS.iter().any(|&t| {
                let st = stance_at(Some(t));
                self.body_penetrates(w, st.pos, st.rot)
            })
        {
            return false;
        }
        self.stances_pass(w, &stances)
    }

    /// The stance of IK targets `grips` (claws within `tol`) with the body
    /// they imply.
    fn stance_check(
        &self,
        w: &World<'_>,
        grips: [Vec3; 4],
        tol: [f32; 4],
        offset: BodyOffset,
    ) -> StanceCheck {
        let (pos, rot) = self.body_for_targets(w, &grips, offset, BodySide::Body);
        StanceCheck {
            grips,
            tol,
            pos,
            rot,
            offset,
            roots: std::array::from_fn(|i| w.rig.root_ws(i, pos, rot)),
        }
    }

    /// The checks every stance of a step passes: each planted limb's root
    /// within its reach band of its grip, the body clear of the supports
    /// near the grips, and every limb with a finite tolerance reaching its
    /// target ([`Self::stances_hold`]). The last stance is the step's end.
    fn stances_pass(&self, w: &World<'_>, stances: &[StanceCheck]) -> bool {
        let max = w.rig.reach * w.cfg.max_reach_fraction;
        let min = w.rig.reach * MIN_REACH_FRACTION;
        let in_band = stances.iter().all(|st| {
            (0..4).all(|i| {
                let root = Vec3::from(st.roots[i].position);
                let d = root.distance(st.grips[i]);
                !(d > max || d < min)
            })
        });
        // Walking a trunk, the drawn body faces it from a side that lags
        // the grips' mean by a few frames: each stance's body is checked
        // from where the body is now and from where it settles (the grips'
        // mean), so the side drawn in between is covered too.
        let trunk_walk = self.transfer.is_none() && self.fore_on_trunk(w);
        let penetrates = |st: &StanceCheck| {
            self.body_penetrates(w, st.pos, st.rot)
                || (trunk_walk && {
                    let (pos, rot) =
                        self.body_for_targets(w, &st.grips, st.offset, BodySide::Grips);
                    self.body_penetrates(w, pos, rot)
                })
        };
        in_band && !stances.iter().any(penetrates) && self.stances_hold(w, stances)
    }

    /// The CCD part of [`Self::step_reachable`]: every limb with a finite
    /// tolerance reaches its target in every stance ([`reach_check`] from the
    /// limb's pose, the four limbs of a stance at once in SIMD lanes, two
    /// stances per call: each lane is exactly that scalar check). The end
    /// stance goes first: its stepping limb is the check that fails most
    /// often (the search tries the farthest candidates first); it is solved
    /// with the first arc point (nearly every call that gets this far checks
    /// all of them).
    fn stances_hold(&self, w: &World<'_>, stances: &[StanceCheck]) -> bool {
        let base = CcdParams {
            max_iterations: CHECK_MAX_ITERATIONS,
            ..*w.ccd
        };
        let params = check_params(&base);
        // The end stance (the last), then the arc's points in order.
        let n = stances.len();
        let order: [usize; MAX_STANCES] = std::array::from_fn(|k| (k + n - 1) % n);
        let order = &order[..n];
        let holds = |st: &StanceCheck, poses: &mut [ChainPose], r: &[CcdResult]| {
            (0..4).all(|i| {
                // An infinite tolerance: the stepping limb is in the air.
                st.tol[i] == f32::INFINITY
                    || reach_check_polish(
                        &w.rig.chains[i],
                        st.roots[i],
                        st.grips[i],
                        &mut poses[i],
                        st.tol[i],
                        &base,
                        r[i].error,
                    )
                    .0
            })
        };
        order.chunks(2).all(|ks| match *ks {
            [a, b] => {
                let (sa, sb) = (&stances[a], &stances[b]);
                let pose = self.limbs.map(|l| l.pose);
                let mut poses = lanes8(pose, pose);
                let r = slothsim_rig::solve8_prepared_tolerances(
                    &w.rig.chains4,
                    lanes8(sa.roots, sb.roots),
                    lanes8(sa.grips, sb.grips),
                    &mut poses,
                    &params,
                    lanes8(sa.tol, sb.tol),
                );
                let (pa, pb) = poses.split_at_mut(4);
                holds(sa, pa, &r[..4]) && holds(sb, pb, &r[4..])
            }
            [k] => {
                let st = &stances[k];
                let mut poses = self.limbs.map(|l| l.pose);
                let r = slothsim_rig::solve4_prepared_tolerances(
                    &w.rig.chains4,
                    st.roots,
                    st.grips,
                    &mut poses,
                    &params,
                    st.tol,
                );
                holds(st, &mut poses, &r)
            }
            _ => unreachable!("chunks of two"),
        })
    }

    /// Whether a body at (`pos`, `rot`) would enter a support near the grips
    /// (e.g. walking a branch into its trunk).
    fn body_penetrates(&self, w: &World<'_>, pos: Vec3, rot: Quat) -> bool {
        let scene = w.scene();
        let torso = [pos + rot * w.rig.torso_ms[0], pos + rot * w.rig.torso_ms[1]];
        self.near_supports(w).any(|id| {
            torso_penetrates(
                scene.support(id),
                w.adjacency.segment_chunks(id),
                torso,
                STANCE_MAX_PENETRATION,
            )
        })
    }

    /// The supports the limbs hold (each once) and their neighbours: where
    /// the body could enter a support (the judge and the step checks alike).
    fn near_supports<'w>(&self, w: &'w World<'_>) -> impl Iterator<Item = SupportId> + 'w {
        let held = self.limbs.map(|l| l.grip.support);
        (0..4)
            .filter(move |&k| !held[..k].contains(&held[k]))
            .flat_map(move |k| {
                std::iter::once(held[k]).chain(w.adjacency.neighbours(held[k]).iter().copied())
            })
    }

    /// Travel vector (unit): body forward × dir.
    fn travel(&self) -> Vec3 {
        self.body_rot * Vec3::Z * self.dir
    }

    // ---------------------------------------------------------------- stage 2

    /// StepSearch: evaluate traced candidates (in order: farthest first); the
    /// first valid one becomes the limb's new grip and its swing starts. Limbs
    /// still searching queue their next candidates into `batch`.
    pub fn step_search(&mut self, w: &World<'_>, batch: &mut TraceBatch) {
        let mut chosen = [false; 4];
        for i in 0..batch.len {
            let m = batch.meta[i];
            let li = m.limb as usize;
            if chosen[li] || self.limbs[li].phase != LimbPhase::Searching {
                continue;
            }
            let Ok(Some(hit)) = batch.results[i] else {
                continue;
            };
            if hit.support != m.support || hit.normal.dot(m.out) < 0.3 {
                continue;
            }
            // The candidate passed the reach checks at its predicted grip; the
            // hit is re-checked only if the surface is elsewhere.
            let as_checked = hit.point.distance(m.point) <= RECHECK_DISTANCE
                && hit.normal.dot(m.out) >= RECHECK_NORMAL_COS;
            // The hind pair's partner may have started a swing of its own
            // since this candidate was queued.
            let pair = m
                .pair
                .map(|(pi, p, n)| (pi as usize, p, n))
                .filter(|&(pi, ..)| {
                    self.limbs[pi].phase != LimbPhase::Swinging
                        && self.hind_pair(li, m.support) == Some(pi)
                });
            if m.pair.is_some() && pair.is_none() {
                continue;
            }
            let mut back_scale = m.back_scale;
            // A step checked with the next limb lifting off during its swing
            // commits that limb's step: it must still be the next to lift.
            let mut lift = m.lift.map(|(lj, to)| (lj as usize, to));
            let lift_at = lift.and_then(|(lj, _)| {
                self.next_lift(w, li)
                    .filter(|&(k, _)| k == lj)
                    .map(|(_, start)| start)
            });
            if !as_checked {
                let reachable = match pair {
                    Some((pi, p, n)) => {
                        match self.pair_back_scale(
                            w,
                            &[(li, hit.point, hit.normal), (pi, p, n)],
                            m.support,
                        ) {
                            Some(k) => {
                                back_scale = k;
                                true
                            }
                            None => false,
                        }
                    }
                    None => {
                        if self.step_reachable(w, li, hit.point, hit.normal, m.support) {
                            lift = None;
                            true
                        } else {
                            matches!((lift, lift_at), (Some((lj, to)), Some(start))
                                if self.lift_reachable(w, li, hit.point, hit.normal, lj, to, start))
                        }
                    }
                };
                if !reachable {
                    continue;
                }
            }
            if lift.is_some() && lift_at.is_none() {
                continue;
            }
            let grip = Grip {
                point: hit.point,
                normal: hit.normal,
                support: m.support,
                u: m.u,
                sdir: m.sdir,
            };
            let pair_grip = pair.map(|(pi, point, normal)| {
                (
                    pi,
                    Grip {
                        point,
                        normal,
                        ..grip
                    },
                )
            });
            if !self.leaves_a_step(w, li, grip, pair_grip) {
                continue;
            }
            for (lj, g) in std::iter::once((li, grip)).chain(pair_grip) {
                chosen[lj] = true;
                let l = &mut self.limbs[lj];
                l.from = l.grip.point;
                l.from_normal = l.grip.normal;
                l.from_support = l.grip.support;
                l.grip = g;
                l.phase = LimbPhase::Swinging;
                l.swing_t = 0.0;
                // Its own search found a step: a committed one is void.
                l.fallback = None;
                if lj != li {
                    // The partner's own turn is taken by this step.
                    l.due = false;
                }
            }
            if let (Some((lj, to)), Some(start)) = (lift, lift_at) {
                self.limbs[lj].fallback = Some(Fallback {
                    grip: to,
                    by_s: self.time + start,
                });
            }
            if pair.is_some() {
                self.hind_back_scale = back_scale;
            }
            self.failed_searches = 0;
            self.stalled_turns = 0;
        }
        batch.len = 0;
        for li in 0..4 {
            if self.limbs[li].phase == LimbPhase::Searching {
                self.queue_candidates(w, li, batch);
            }
        }
    }

    /// Queues up to [`CANDIDATES_PER_LIMB`] traces for limb `li`, continuing
    /// its search; moves on to neighbouring supports when the current one is
    /// exhausted; gives up (limb stays planted) when nothing is left.
    fn queue_candidates(&mut self, w: &World<'_>, li: usize, batch: &mut TraceBatch) {
        let scene = w.scene();
        let mut queued = 0;
        // Reach checks (CCD solves of hypothetical stances) this frame: a
        // search that needs more continues next frame, so no frame pays for
        // a whole exhaustive search (crowd p95).
        let mut checks = 0u32;
        loop {
            let sr = self.limbs[li].search;
            let s = scene.support(sr.support);
            let len = s.length();
            let mut u = sr.next_u;
            // Back off toward the current grip in coarse strides; the fine
            // (back-off) points above the first coarse candidate that passes
            // are then tried farthest first, so the farthest valid grip is
            // found at about a third of the checks.
            let fine = w.cfg.backoff_m;
            let coarse = fine * COARSE_STRIDE as f32;
            let in_range = |u: f32| (END_MARGIN..=len - END_MARGIN).contains(&u);
            while queued < CANDIDATES_PER_LIMB
                && checks < MAX_REACH_CHECKS_PER_FRAME
                && (u - sr.last_u) * sr.sdir >= -1e-6
            {
                let cand_u = u;
                u -= sr.sdir * coarse;
                if !in_range(cand_u) {
                    continue;
                }
                let mut check = |u: f32| {
                    self.candidate(w, li, sr.support, u, sr.sdir, sr.retreat, true, &mut checks)
                };
                let Some(mut found) = check(cand_u) else {
                    continue;
                };
                for j in (1..COARSE_STRIDE).rev() {
                    let fu = cand_u + sr.sdir * fine * j as f32;
                    if (fu - sr.first_u) * sr.sdir > 1e-6 || !in_range(fu) {
                        continue;
                    }
                    if let Some(f) = check(fu) {
                        found = f;
                        break;
                    }
                }
                if batch.push(found.0, found.1) {
                    queued += 1;
                } else {
                    u += sr.sdir * coarse;
                    break;
                }
            }
            self.limbs[li].search.next_u = u;
            if queued > 0 || batch.len == MAX_TRACES || checks >= MAX_REACH_CHECKS_PER_FRAME {
                return;
            }
            // The goal's branch is exhausted: climb on along the trunk.
            if sr.goal_first {
                let neighbour = sr.neighbour;
                self.limbs[li].search = Search {
                    neighbour,
                    ..search_ahead(w, self.limbs[li].grip)
                };
                continue;
            }
            // This support is exhausted: try the next neighbour, then a retreat.
            // Nothing better than a committed step: take it.
            if self.limbs[li].fallback.is_some() {
                self.start_fallback_swing(li);
                return;
            }
            if !self.next_neighbour(w, li) && !self.start_retreat(w, li) {
                // Nothing anywhere: stay planted.
                let l = &mut self.limbs[li];
                l.phase = LimbPhase::Planted;
                l.due = false;
                self.failed_searches = self.failed_searches.saturating_add(1);
                if self.failed_searches >= STOP_AFTER_FAILED_SEARCHES
                    && self.status == Status::Moving
                {
                    // Wander mode: turn back, unless turning back already
                    // failed to bring a step (tail-first walking is mostly out
                    // of the limbs' reach: see README); then stop here.
                    if self.wander && self.stalled_turns < MAX_STALLED_TURNS {
                        self.turn_back();
                    } else {
                        self.status = Status::NoGrip;
                        if self.wander {
                            self.resume_at = Some(self.time + WANDER_RETRY_S);
                        }
                    }
                }
                return;
            }
        }
    }

    /// A leading limb on a trunk whose goal is on a branch leaving it tries
    /// that branch first (`transfer_to_branch`): a branch ends at its trunk,
    /// so a limb on a branch reaches the trunk once the branch is exhausted,
    /// but a trunk goes on past the branch, and climbing it would never end.
    /// `None` when the branch is out of reach: the limb climbs the trunk.
    fn goal_branch_search(&mut self, w: &World<'_>, li: usize) -> Option<Search> {
        let cur = self.limbs[li].grip.support;
        let gs = if self.wander {
            self.wander_branch(w, li, cur)?
        } else {
            self.goal?.0
        };
        let scene = w.scene();
        let neighbours = w.adjacency.neighbours(cur);
        if !self.leads(Limb::ALL[li])
            || scene.support(cur).kind != SupportKind::Trunk
            || scene.support(gs).kind != SupportKind::Branch
            || !neighbours.contains(&gs)
        {
            return None;
        }
        let transfer = self.transfer;
        self.begin_transfer(w, li, cur, gs);
        // Neighbours count as tried: once the branch is exhausted the limb
        // searches the trunk, then retreats (see `queue_candidates`).
        let tried = u16::try_from(neighbours.len()).unwrap_or(u16::MAX - 1);
        let search = self.neighbour_search(w, li, gs, tried).map(|sr| Search {
            goal_first: true,
            ..sr
        });
        if search.is_none() {
            self.transfer = transfer;
        }
        search
    }

    /// Wander mode: a branch to leave trunk `trunk` for, tried before the
    /// trunk by a fore limb climbing past it (head first, no transfer under
    /// way): a neighbouring branch rising from the trunk (its first metres at
    /// least [`WANDER_MIN_RISE_SIN`] uphill: trunk → branch holds there), taken
    /// or passed by this sloth's own choice.
    fn wander_branch(&self, w: &World<'_>, li: usize, trunk: SupportId) -> Option<SupportId> {
        let scene = w.scene();
        if self.dir <= 0.0
            || self.transfer.is_some()
            || scene.support(trunk).kind != SupportKind::Trunk
        {
            return None;
        }
        let grip = self.limbs[li].grip.point;
        w.adjacency.neighbours(trunk).iter().copied().find(|&b| {
            let s = scene.support(b);
            if s.kind != SupportKind::Branch {
                return false;
            }
            let a = project(s, grip);
            // Away from the trunk: toward the branch end farther from it.
            let away = if a.u < 0.5 * s.length() {
                a.tangent
            } else {
                -a.tangent
            };
            let take =
                mix64(self.seed ^ mix64(u64::from(b.0) ^ (u64::from(self.turns) << 32))) & 1 == 0;
            take && away.y >= WANDER_MIN_RISE_SIN
        })
    }

    /// Wander mode, at a dead end or blocked: reverse the travel direction
    /// (the same footfall order continues, tail first) and vary later route choices.
    fn turn_back(&mut self) {
        self.dir = -self.dir;
        for l in &mut self.limbs {
            l.grip.sdir = -l.grip.sdir;
        }
        self.failed_searches = 0;
        self.turns = self.turns.wrapping_add(1);
        self.stalled_turns += 1;
    }

    /// Whether `limb` belongs to the pair that leads in the travel direction
    /// (fore limbs head first, hind limbs tail first).
    fn leads(&self, limb: Limb) -> bool {
        limb.is_fore() == (self.dir > 0.0)
    }

    /// Once no forward step is left anywhere: search backward on the current
    /// support (up to one max step behind the grip). A retreat is taken only
    /// if it leaves another limb a forward step (see [`Self::leaves_a_step`]),
    /// so it unlocks a stance in which every limb was stuck. False if this
    /// limb has already retreated in this search.
    fn start_retreat(&mut self, w: &World<'_>, li: usize) -> bool {
        let g = self.limbs[li].grip;
        if self.limbs[li].search.retreat {
            return false;
        }
        self.limbs[li].search = Search {
            support: g.support,
            sdir: g.sdir,
            first_u: g.u - g.sdir * w.cfg.min_step_m,
            next_u: g.u - g.sdir * w.cfg.min_step_m,
            last_u: g.u - g.sdir * w.cfg.max_step_m,
            // Neighbours are exhausted.
            neighbour: u16::try_from(w.adjacency.neighbours(g.support).len())
                .unwrap_or(u16::MAX - 1),
            retreat: true,
            goal_first: false,
        };
        true
    }

    /// Sets up the search on the next admissible neighbour support. False when none is left.
    fn next_neighbour(&mut self, w: &World<'_>, li: usize) -> bool {
        let limb = Limb::ALL[li];
        let cur = self.limbs[li].grip;
        let neighbours = w.adjacency.neighbours(cur.support);
        let mut k = match self.limbs[li].search.neighbour {
            u16::MAX => 0usize,
            n => n as usize,
        };
        // The supports the leading limbs hold: they transfer first.
        let lead = if self.dir > 0.0 {
            [Limb::LF, Limb::RF]
        } else {
            [Limb::LH, Limb::RH]
        };
        let lead_supports = lead.map(|l| self.limbs[l.index()].grip.support);
        let lead_on_cur = lead_supports.contains(&cur.support);
        // Wander mode: neighbours in an order of this sloth's own (the same
        // for all its limbs at this support, so they pick the same one).
        let rotate = if self.wander && !neighbours.is_empty() {
            (mix64(self.seed ^ mix64(cur.support.0 as u64 ^ ((self.turns as u64) << 32)))
                % neighbours.len() as u64) as usize
        } else {
            0
        };
        while k < neighbours.len() {
            let sid = neighbours[(k + rotate) % neighbours.len()];
            k += 1;
            let scene = w.scene();
            if self.wander
                && scene.support(sid).kind != scene.support(cur.support).kind
                && !self.may_wander_across(w, cur.support, sid)
            {
                continue;
            }
            // Trailing limbs only follow onto a support a leading limb already
            // holds, and leave a trunk only when no leading limb is on it.
            if !self.leads(limb) && (!lead_supports.contains(&sid) || lead_on_cur) {
                continue;
            }
            // A branch ↔ trunk change: the transfer (and its side) is set up
            // first, as the search on the new support depends on it.
            if scene.support(sid).kind != scene.support(cur.support).kind {
                self.begin_transfer(w, li, cur.support, sid);
            }
            if let Some(search) = self.neighbour_search(w, li, sid, k as u16) {
                self.limbs[li].search = search;
                return true;
            }
        }
        self.limbs[li].search.neighbour = k as u16;
        false
    }

    /// Wander mode: whether this sloth may change between a branch and a
    /// trunk, from support `from` onto `to`, now. A transfer under way may go
    /// on or be undone (after a turn back). A new one only head first, so the
    /// fore limbs transfer first and the body stays head up (SPEC
    /// `transfer_to_branch`, `transfer_to_trunk`): off a trunk only climbing
    /// (a descent turns back at the trunk's foot and leaves higher up); onto
    /// a trunk only walking level or uphill toward it (coming down a rising
    /// branch the fore limbs cannot take the trunk above the hind limbs), and
    /// only a trunk thin enough to climb.
    fn may_wander_across(&self, w: &World<'_>, from: SupportId, to: SupportId) -> bool {
        if self.transfer.is_some() {
            return true;
        }
        if self.dir <= 0.0 {
            return false;
        }
        let scene = w.scene();
        scene.support(from).kind == SupportKind::Trunk
            || (self.travel().y >= WANDER_MAX_DESCENT_SIN
                && project(scene.support(to), self.body_pos).radius <= WANDER_MAX_TRUNK_RADIUS)
    }

    /// Starts a branch ↔ trunk transfer from `from` onto `to` (unless one is
    /// under way: a limb holds its target) and picks, once, the side of the
    /// trunk the body faces it from. Onto a trunk: beside the branch (the head is eased
    /// sideways away from it), on the side the body leans to, else on a side
    /// of this sloth's own; off a trunk: the side the body is on.
    fn begin_transfer(&mut self, w: &World<'_>, li: usize, from: SupportId, to: SupportId) {
        if self
            .transfer
            .is_some_and(|t| self.limbs.iter().any(|l| l.grip.support == t.to))
        {
            return;
        }
        let scene = w.scene();
        let onto_trunk = scene.support(to).kind == SupportKind::Trunk;
        let (trunk, branch) = if onto_trunk { (to, from) } else { (from, to) };
        let a = project(scene.support(trunk), self.body_pos);
        let off_axis = self.body_pos - a.point;
        let off_axis = off_axis - a.tangent * a.tangent.dot(off_axis);
        let fallback = a.tangent.any_orthonormal_vector();
        let bp = project(scene.support(branch), self.body_pos);
        let away = bp.point - a.point;
        let away = (away - a.tangent * a.tangent.dot(away)).normalize_or(fallback);
        let side = if onto_trunk {
            let b = bp.tangent;
            let n = a.tangent.cross(b).normalize_or(fallback);
            // Toward the side of the limb that starts the transfer: it takes
            // the trunk next to the branch, its pair reaches around.
            let model_side = if Limb::ALL[li].is_left() {
                Vec3::X
            } else {
                Vec3::NEG_X
            };
            let nn = if n.dot(self.body_rot * model_side) >= 0.0 {
                n
            } else {
                -n
            };
            let n2 = (nn - a.tangent * a.tangent.dot(nn)).normalize_or(fallback);
            (away * TRANSFER_SIDE_ANGLE.cos() + n2 * TRANSFER_SIDE_ANGLE.sin())
                .normalize_or(fallback)
        } else {
            off_axis.normalize_or(fallback)
        };
        self.transfer = Some(Transfer {
            to,
            trunk,
            side,
            away,
        });
    }

    /// Ends the transfer once all four limbs hold its target support (or
    /// when no limb holds it nor searches any more: it was not taken). On a
    /// trunk the body faces up (head up); the travel turns toward the goal:
    /// tail first when it is below.
    fn finish_transfer(&mut self, w: &World<'_>) {
        let Some(tr) = self.transfer else { return };
        if self
            .limbs
            .iter()
            .all(|l| l.phase == LimbPhase::Planted && l.grip.support != tr.to)
        {
            // Not taken. But where limbs hold the trunk and another support
            // (a step went onto a neighbour of the branch), the body is still
            // between a trunk and a branch: the transfer goes on onto that
            // one (ending it here jumped the body 0.38 m in one frame).
            let others = self.limbs.map(|l| l.grip.support);
            let other = others.iter().copied().find(|&s| s != tr.trunk);
            let one_other = other.filter(|&o| others.iter().all(|&s| s == tr.trunk || s == o));
            self.transfer = match one_other {
                Some(to) if others.contains(&tr.trunk) => Some(Transfer { to, ..tr }),
                _ => None,
            };
            return;
        }
        if !self
            .limbs
            .iter()
            .all(|l| l.phase == LimbPhase::Planted && l.grip.support == tr.to)
        {
            return;
        }
        self.transfer = None;
        let s = w.scene().support(tr.to);
        if s.kind != SupportKind::Trunk {
            self.hang_trunk = Some(tr.trunk);
            return;
        }
        let here = project(s, self.body_pos);
        let up_u = if here.tangent.y >= 0.0 { 1.0 } else { -1.0 };
        let dir = match self.goal {
            Some((gs, gp)) if gs == tr.to => {
                if (project(s, gp).u - here.u) * up_u >= 0.0 {
                    1.0
                } else {
                    -1.0
                }
            }
            // Wander mode: up or down, by this sloth's own choice.
            _ if self.wander => {
                if mix64(self.seed ^ mix64(u64::from(tr.to.0) ^ (u64::from(self.turns) << 32))) & 1
                    == 0
                {
                    1.0
                } else {
                    -1.0
                }
            }
            _ => 1.0,
        };
        self.dir = dir;
        for l in &mut self.limbs {
            l.grip.sdir = dir * up_u;
        }
    }

    /// The search of limb `li` on the support it holds: from the search
    /// distance ahead of its grip back to the grip. Side-stepping around a
    /// trunk, the range goes toward the goal's height and no farther, down
    /// to a step at the grip's own height.
    fn own_search(&self, w: &World<'_>, li: usize) -> Search {
        let g = self.limbs[li].grip;
        let mut search = search_ahead(w, g);
        // Undoing a transfer (turned back with the trailing limbs on its
        // target): no steps along the target; the limb goes back to the
        // support the leading limbs hold (see `next_neighbour`).
        if self.transfer.is_some_and(|t| {
            t.to == g.support
                && !self.leads(Limb::ALL[li])
                && Limb::ALL
                    .iter()
                    .all(|&l| !self.leads(l) || self.limbs[l.index()].grip.support != t.to)
        }) {
            search.next_u = g.u - g.sdir;
            search.first_u = search.next_u;
            return search;
        }
        if let Some(ss) = self.side_step(w, g.support) {
            let sdir = if ss.axial_to_goal >= 0.0 { 1.0 } else { -1.0 };
            let ahead = ss.axial_to_goal.abs().min(w.cfg.search_distance_m);
            search.sdir = sdir;
            search.first_u = g.u + sdir * ahead;
            search.next_u = search.first_u;
            search.last_u = g.u - sdir * SIDE_STEP_AXIAL_SLACK;
        }
        search
    }

    /// Side steps around trunk `sid` (SPEC `find_side_step`): when the goal
    /// is on this trunk with a side the body does not yet face it from, the
    /// turn about the axis the next step makes (toward the goal's side, the
    /// shorter way) and the goal's distance along the axis from the body.
    fn side_step(&self, w: &World<'_>, sid: SupportId) -> Option<SideStep> {
        let (gs, gp) = self.goal?;
        let goal_side = self.goal_side?;
        let s = w.scene().support(sid);
        if gs != sid || s.kind != SupportKind::Trunk || self.transfer.is_some() {
            return None;
        }
        let a = project(s, self.body_pos);
        let axis_up = if a.tangent.y >= 0.0 {
            a.tangent
        } else {
            -a.tangent
        };
        let off_axis = self.body_pos - a.point;
        let side_now = (off_axis - axis_up * axis_up.dot(off_axis)).try_normalize()?;
        let turn = axis_up
            .dot(side_now.cross(goal_side))
            .atan2(side_now.dot(goal_side));
        if turn.abs() <= SIDE_STEP_DONE {
            return None;
        }
        let max_turn = SIDE_STEP_MAX_TURN.min(SIDE_STEP_MAX_ARC / a.radius.max(1e-3));
        Some(SideStep {
            turn: turn.clamp(-max_turn, max_turn),
            axis_up,
            side_now,
            axial_to_goal: (project(s, gp).u - a.u) * (axis_up.dot(a.tangent)),
        })
    }

    /// The candidate range of limb `li` on neighbour support `sid`, if its
    /// surface comes within reach of the limb's root.
    fn neighbour_search(&self, w: &World<'_>, li: usize, sid: SupportId, k: u16) -> Option<Search> {
        let s2 = w.scene().support(sid);
        let cur = self.limbs[li].grip;
        let root = self.limbs[li].root;
        let entry = project(s2, (cur.point + root) * 0.5);
        // transfer_to_branch's hind pair is judged by its reach check at the
        // stance after the step (with the hindquarters' offset back): before
        // the pair moves, the hips low on the trunk are seldom within reach
        // of a branch that falls away from the junction (trunk_branch at
        // 110°–130° stopped there).
        if self.hind_pair(li, sid).is_none()
            && entry.point.distance(root) - entry.radius > w.rig.reach
        {
            return None;
        }
        let sdir = self.choose_sdir(w, sid, entry.tangent);
        // transfer_to_branch: the hind pair's trace is capped (thesis: 10 cm)
        // so the feet take the branch close to the trunk, under the body.
        let reach_u = if self.hind_pair(li, sid).is_some() {
            w.cfg.hind_transfer_trace_cap_m
        } else {
            w.cfg.search_distance_m
        };
        Some(Search {
            support: sid,
            sdir,
            first_u: entry.u + sdir * reach_u,
            next_u: entry.u + sdir * reach_u,
            last_u: entry.u - sdir * 0.15,
            neighbour: k,
            retreat: false,
            goal_first: false,
        })
    }

    /// This sloth once the given limbs hold the given grips: the body at
    /// those grips (formulas 6, 7) and the chain roots it implies.
    fn after_steps(&self, w: &World<'_>, steps: impl IntoIterator<Item = (usize, Grip)>) -> Sloth {
        let mut next = *self;
        for (lj, g) in steps {
            next.limbs[lj].grip = g;
            next.limbs[lj].target = g.point;
        }
        let grips = next.limbs.map(|l| l.grip.point);
        let offset = body_offset(w, next.trunk_weights(w));
        (next.body_pos, next.body_rot) = next.body_for_targets(w, &grips, offset, BodySide::Body);
        for lj in 0..4 {
            let root = w.rig.root_ws(lj, next.body_pos, next.body_rot);
            next.limbs[lj].root = root.position.into();
        }
        next
    }

    /// Lookahead: after limb `li` steps to `grip`, at least one other limb
    /// (tried in footfall order from the next) still has a step (cheap checks
    /// and reach, without traces). Keeps the greedy farthest-first search
    /// out of stances from which no limb can move.
    fn leaves_a_step(
        &self,
        w: &World<'_>,
        li: usize,
        grip: Grip,
        pair: Option<(usize, Grip)>,
    ) -> bool {
        let next = self.after_steps(w, std::iter::once((li, grip)).chain(pair));
        let offsets = w.cfg.phase_offsets();
        let mut order = [0usize, 1, 2, 3];
        order.sort_by(|&a, &b| {
            let da = (offsets[a] - offsets[li]).rem_euclid(1.0);
            let db = (offsets[b] - offsets[li]).rem_euclid(1.0);
            da.total_cmp(&db)
        });
        order
            .into_iter()
            .filter(|&lj| lj != li && pair.is_none_or(|(pi, _)| lj != pi))
            .any(|lj| next.has_step(w, lj))
    }

    /// Whether limb `li` has any candidate passing the cheap checks and the
    /// reach check on its support or an admissible neighbour (no traces).
    fn has_step(&self, w: &World<'_>, li: usize) -> bool {
        let limb = Limb::ALL[li];
        let g = self.limbs[li].grip;
        let scan = |sr: &Search| {
            let len = w.scene().support(sr.support).length();
            let mut u = sr.next_u;
            while (u - sr.last_u) * sr.sdir >= -1e-6 {
                if (END_MARGIN..=len - END_MARGIN).contains(&u)
                    && self
                        .candidate(w, li, sr.support, u, sr.sdir, false, false, &mut 0)
                        .is_some()
                {
                    return true;
                }
                u -= sr.sdir * LOOKAHEAD_STRIDE;
            }
            false
        };
        if scan(&self.own_search(w, li)) {
            return true;
        }
        let fore_supports = [
            self.limbs[Limb::LF.index()].grip.support,
            self.limbs[Limb::RF.index()].grip.support,
        ];
        let fore_on_cur = fore_supports.contains(&g.support);
        w.adjacency.neighbours(g.support).iter().any(|&sid| {
            (limb.is_fore() || (fore_supports.contains(&sid) && !fore_on_cur))
                && self
                    .neighbour_search(w, li, sid, 0)
                    .is_some_and(|sr| scan(&sr))
        })
    }

    /// Travel direction along a new support: toward the goal if it is on it,
    /// else for a trunk up (+1 travel) or down per `dir`, else the direction
    /// that continues the current travel.
    fn choose_sdir(&self, w: &World<'_>, sid: SupportId, tangent: Vec3) -> f32 {
        let s = w.scene().support(sid);
        // Onto a trunk only head up: the limbs climb it until all four are across.
        if self
            .transfer
            .is_some_and(|t| t.to == sid && s.kind == SupportKind::Trunk)
        {
            return if tangent.y >= 0.0 { 1.0 } else { -1.0 };
        }
        if let Some((gs, gp)) = self.goal {
            let g = project(s, gp);
            let here = project(s, self.body_pos);
            if gs == sid || g.point.distance(gp) < 1.0 {
                return if g.u >= here.u { 1.0 } else { -1.0 };
            }
        }
        let want = if s.kind == SupportKind::Trunk {
            Vec3::Y * self.dir
        } else {
            self.travel()
        };
        if tangent.dot(want) >= 0.0 { 1.0 } else { -1.0 }
    }

    /// A candidate at arc length `u` of support `sid`, if it passes the cheap
    /// checks (step length, leg order, reach at the predicted stance): its trace.
    #[allow(clippy::too_many_arguments)] // one call site each; a struct would only rename them
    fn candidate(
        &self,
        w: &World<'_>,
        li: usize,
        sid: SupportId,
        u: f32,
        sdir: f32,
        retreat: bool,
        relax: bool,
        checks: &mut u32,
    ) -> Option<(TraceRequest, Candidate)> {
        let limb = Limb::ALL[li];
        let s = w.scene().support(sid);
        let a = axis_at(s, u);
        // A transfer onto this trunk: the grips sit around the side the body will face it from.
        let transfer = self.transfer.filter(|t| t.to == sid);
        // A side step: around the side the body faces the trunk from, turned toward the goal's.
        let side_step = if sid == self.limbs[li].grip.support {
            self.side_step(w, sid)
        } else {
            None
        };
        let body_side = match (transfer, side_step) {
            (Some(t), _) if t.trunk == sid => t.side,
            (_, Some(ss)) => Quat::from_axis_angle(ss.axis_up, ss.turn) * ss.side_now,
            _ => self.body_pos - a.point,
        };
        let transfer_step = transfer.is_some() && sid != self.limbs[li].grip.support;
        // Body forward is the travel direction × dir (tail first when dir < 0).
        let (f, up) = support_frame(s.kind, a.tangent * (sdir * self.dir), a.tangent, body_side);
        let out = grip_out(s.kind, limb, f, up, w.cfg.trunk_grip_angle_deg.to_radians());
        let approx = a.point + out * a.radius;
        let cur = self.limbs[li].grip.point;
        // On the trunk being transferred to, steps go up its axis (head up)
        // whichever way the body still faces.
        // So do a fore limb's steps along the branch being transferred to:
        // the body, still facing up the trunk, turns to the branch only as
        // they go (a branch falling away from the junction is behind the
        // body's heading: trunk_branch at 140°–160° stopped there).
        let travel = match transfer {
            Some(t) if t.trunk == sid && !transfer_step => a.tangent * sdir,
            Some(_) if limb.is_fore() && !transfer_step => a.tangent * sdir,
            _ => self.travel(),
        };
        let body_fwd = self.body_rot * Vec3::Z;
        // Step length (along the travel direction) within [min, max].
        let step = (approx - cur).dot(travel);
        let dist = approx.distance(cur);
        // Changing support may be a sideways step (parallel branches): it only
        // must not go backwards.
        let min_step = if sid == self.limbs[li].grip.support {
            w.cfg.min_step_m
        } else {
            0.0
        };
        let step_ok = if let Some(ss) = side_step.filter(|_| !retreat) {
            // Around the axis (the way the body turns) and toward the goal's
            // height, never much away from it.
            let d = approx - cur;
            let around = d.dot(ss.axis_up.cross(ss.side_now) * ss.turn.signum());
            let along = d.dot(a.tangent * sdir);
            around >= 0.0 && along >= -SIDE_STEP_AXIAL_SLACK && around + along.max(0.0) >= min_step
        } else if retreat {
            step <= -w.cfg.min_step_m
        } else {
            // A transfer step goes where the other support is (reach decides).
            transfer_step || step >= min_step
        };
        let max_step = if transfer_step {
            w.cfg.max_step_m * TRANSFER_STEP_FACTOR
        } else {
            w.cfg.max_step_m
        };
        if !step_ok || dist > max_step {
            return None;
        }
        // transfer_to_branch's hind pair: the partner steps to the mirror grip
        // on the branch's other side at the same arc length.
        let pair = self.hind_pair(li, sid).map(|pi| {
            let out2 = grip_out(
                s.kind,
                Limb::ALL[pi],
                f,
                up,
                w.cfg.trunk_grip_angle_deg.to_radians(),
            );
            (pi, a.point + out2 * a.radius, out2)
        });
        if pair.is_some_and(|(pi, p2, _)| p2.distance(self.limbs[pi].grip.point) > max_step) {
            return None;
        }
        // The hind pair lifts off together only while both fore limbs hold:
        // two limbs stay in contact.
        if pair.is_some_and(|(pi, ..)| {
            (0..4).any(|k| k != li && k != pi && self.limbs[k].phase == LimbPhase::Swinging)
        }) {
            return None;
        }
        // Leg order: hind never ahead of a fore limb; never behind the opposite limb of the girdle.
        let proj = |p: Vec3| p.dot(body_fwd);
        let fore_min = proj(self.limbs[Limb::LF.index()].grip.point)
            .min(proj(self.limbs[Limb::RF.index()].grip.point));
        let hind_max = proj(self.limbs[Limb::LH.index()].grip.point)
            .max(proj(self.limbs[Limb::RH.index()].grip.point));
        if !limb.is_fore() && proj(approx) > fore_min - LEG_ORDER_MARGIN {
            return None;
        }
        // Tail first, the trailing fore limbs step toward the hind limbs:
        // never level with them (formula 6's hind → fore directions would
        // turn the body on centimetres of grip change).
        if limb.is_fore() && proj(approx) < hind_max + LEG_ORDER_MARGIN {
            return None;
        }
        // Onto a trunk, the fore limbs climb no further ahead of the hind
        // limbs than the hind limbs can follow from the branch.
        if transfer.is_some()
            && limb.is_fore()
            && s.kind == SupportKind::Trunk
            && proj(approx) - hind_max > MAX_TRANSFER_SPREAD
        {
            return None;
        }
        // A side's fore and hind grips keep apart along the body: formula 6
        // takes the body's heading from them.
        let same_side = self.limbs[limb.same_side().index()].grip.point;
        if (proj(approx) - proj(same_side)).abs() < SAME_SIDE_SPACING {
            return None;
        }
        if pair.is_some_and(|(_, p2, _)| proj(p2) > fore_min - LEG_ORDER_MARGIN) {
            return None;
        }
        let opp = self.limbs[limb.opposite().index()].grip.point;
        let lead = (approx - opp).dot(travel);
        // A limb normally lands level with or ahead of its girdle partner. One
        // left more than a step behind it (transfer steps reach around a
        // trunk and may split a girdle by more than a step) could never land
        // level, and its partner may not lead further: it closes the gap as
        // far as a step goes instead (the farthest valid candidate wins).
        let cur_lead = (cur - opp).dot(travel);
        let min_lead = if cur_lead < -(w.cfg.max_step_m - w.cfg.min_step_m) {
            cur_lead + w.cfg.min_step_m
        } else {
            0.0
        };
        let lead_ok = match side_step {
            // Side-stepping, the girdle's limbs keep about level on the axis
            // (around it, the pair is always apart by the grip angle).
            Some(ss) => (approx - opp).dot(ss.axis_up).abs() <= MAX_GIRDLE_LEAD * w.cfg.max_step_m,
            None => {
                transfer_step || (min_lead..=MAX_GIRDLE_LEAD * w.cfg.max_step_m).contains(&lead)
            }
        };
        if !lead_ok {
            return None;
        }
        // Onto a trunk head up: a fore limb takes it above the hind limbs,
        // and so do its next steps while the hind limbs are on the branch.
        if transfer.is_some() && limb.is_fore() && s.kind == SupportKind::Trunk {
            let axis_up = if a.tangent.y >= 0.0 {
                a.tangent
            } else {
                -a.tangent
            };
            let hind_top = [Limb::LH, Limb::RH]
                .map(|h| self.limbs[h.index()].grip.point.dot(axis_up))
                .into_iter()
                .fold(f32::NEG_INFINITY, f32::max);
            if approx.dot(axis_up) < hind_top + HEAD_UP_MARGIN {
                return None;
            }
        } else if self.transfer.is_some_and(|t| t.to == t.trunk)
            && !limb.is_fore()
            && s.kind != SupportKind::Trunk
        {
            // …and the hind limbs, still on the branch, stay HEAD_UP_MARGIN
            // below the fore limbs on the trunk (stepping up a branch to a
            // trunk grip at branch height, the hips rose above the head:
            // 1,453 sloth-frames in a 2,000-sloth run).
            let fore_on_trunk_bottom = [Limb::LF, Limb::RF]
                .map(|f| self.limbs[f.index()].grip)
                .into_iter()
                .filter(|g| w.scene().support(g.support).kind == SupportKind::Trunk)
                .map(|g| g.point.y)
                .reduce(f32::min);
            if fore_on_trunk_bottom.is_some_and(|y| approx.y > y - HEAD_UP_MARGIN) {
                return None;
            }
        }
        // Keep clear of other sloths' bodies and grips.
        if w.crowd.is_some_and(|g| {
            g.blocked(self.id, approx) || pair.is_some_and(|(_, p2, _)| g.blocked(self.id, p2))
        }) {
            return None;
        }
        *checks += 1;
        let mut back_scale = 0.0;
        let reachable = match pair {
            Some((pi, p2, out2)) => {
                match self.pair_back_scale(w, &[(li, approx, out), (pi, p2, out2)], sid) {
                    Some(k) => {
                        back_scale = k;
                        true
                    }
                    None => false,
                }
            }
            None => self.step_reachable(w, li, approx, out, sid),
        };
        // Held only with the next limb to lift off in the air by the
        // landing: a plain step commits that limb's step.
        let plain = pair.is_none()
            && !transfer_step
            && !retreat
            && side_step.is_none()
            && sid == self.limbs[li].grip.support;
        let lift = if !reachable && relax && plain {
            let grip = Grip {
                point: approx,
                normal: out,
                support: sid,
                u,
                sdir,
            };
            self.planned_lift(w, li, grip, checks)
        } else {
            None
        };
        if !reachable && lift.is_none() {
            return None;
        }
        let origin = a.point + out * (a.radius + TRACE_STANDOFF);
        let req = TraceRequest::Line(LineTrace {
            origin,
            dir: -out,
            max_dist: TRACE_STANDOFF + a.radius,
        });
        Some((
            req,
            Candidate {
                limb: li as u8,
                support: sid,
                u,
                sdir,
                out,
                point: approx,
                pair: pair.map(|(pi, p2, out2)| (pi as u8, p2, out2)),
                back_scale,
                lift,
            },
        ))
    }

    // ---------------------------------------------------------------- stage 3

    /// BodyAverage: advance swing arcs, then place the body (formulas 6, 7), smoothed.
    pub fn body_average(&mut self, w: &World<'_>, dt: f32) {
        for (li, l) in self.limbs.iter_mut().enumerate() {
            match l.phase {
                LimbPhase::Planted | LimbPhase::Searching => l.target = l.grip.point,
                LimbPhase::Swinging => {
                    let dur = w.cfg.swing_duration(Limb::ALL[li]);
                    l.swing_t = (l.swing_t + dt / dur).min(1.0);
                    l.target = swing_point(
                        (l.from, l.from_normal),
                        (l.grip.point, l.grip.normal),
                        l.swing_t,
                        w.cfg.swing_clearance_m,
                        self.body_rot * Vec3::NEG_Y,
                    );
                    if l.swing_t >= 1.0 {
                        l.phase = LimbPhase::Planted;
                        l.target = l.grip.point;
                    }
                }
            }
        }
        // Formula 7's position is already continuous (swing arcs are), so it
        // is used as is: lagging it would pull planted limbs off their grips.
        // The rotation (formula 6) is smoothed against jumps (support changes,
        // touch-down), but follows a slow, continuous turn exactly: any lag
        // turns the hips away from the stance the step checks approved (a
        // 0.6° lag moved a hind claw 4 mm off its grip in a 2,000-sloth run).
        // Not at all during a branch ↔ trunk transfer: the roll is continuous
        // already, and lagging it would pull planted limbs off their grips.
        let (pos, rot) = self.averaged_body(w);
        let k = if w.cfg.body_smoothing_s > 0.0 && self.transfer.is_none() {
            let smooth = 1.0 - (-dt / w.cfg.body_smoothing_s).exp();
            let angle = self.body_rot.angle_between(rot);
            let free = BODY_FREE_TURN_RATE * dt;
            if angle <= free {
                1.0
            } else {
                smooth.max(free / angle)
            }
        } else {
            1.0
        };
        self.body_rot = self.body_rot.slerp(rot, k).normalize();
        self.body_pos = pos;
    }

    /// [`Sloth::body_average`], skipped where it would change nothing: while
    /// no limb swings it is a deterministic function of the fields in a
    /// [`BodyKey`] (and of `w` and `dt`, fixed for a run); when they hold the
    /// bits a call through `memo` left unchanged, this call would leave them
    /// unchanged again (a sloth between steps: about 40 % of the sloth-frames
    /// of a crowd). `memo` belongs to this sloth, `w` and `dt`.
    pub fn body_average_memo(&mut self, w: &World<'_>, dt: f32, memo: &mut BodyMemo) {
        let key = self.body_key();
        if key.is_some() && memo.fixed == key {
            return;
        }
        self.body_average(w, dt);
        memo.fixed = key.filter(|k| self.body_key().as_ref() == Some(k));
    }

    /// The bits of every field [`Sloth::body_average`] reads or writes; `None`
    /// while a limb swings.
    fn body_key(&self) -> Option<BodyKey> {
        if self.any_swinging() {
            return None;
        }
        let mut k = KeyBits::<BODY_KEY_LEN>::new();
        k.f32s(&self.body_pos.to_array());
        k.f32s(&self.body_rot.to_array());
        k.f32s(&self.hang_side.to_array());
        k.u32s(&[self.hang_trunk.map_or(u32::MAX, |t| t.0)]);
        match self.transfer {
            Some(t) => {
                k.u32s(&[1, t.to.0, t.trunk.0]);
                k.f32s(&t.side.to_array());
                k.f32s(&t.away.to_array());
            }
            None => k.u32s(&[0; 9]),
        }
        for l in &self.limbs {
            k.u32s(&[l.phase as u32]);
            k.f32s(&l.grip.point.to_array());
            k.u32s(&[l.grip.support.0]);
            k.f32s(&l.target.to_array());
        }
        Some(k.done())
    }

    /// Whether a limb is in the air.
    fn any_swinging(&self) -> bool {
        self.limbs.iter().any(|l| l.phase == LimbPhase::Swinging)
    }

    // ---------------------------------------------------------------- stage 4

    /// CcdSolve: each limb from its root toward its target.
    ///
    /// Grips must not slide (SPEC): where the averaged body leaves a planted
    /// claw short of its grip (the step checks sample a swing at a few arc
    /// points only), the body is moved by the planted limbs' mean residual
    /// and the limbs solved again; kept only if that brings the claws closer.
    pub fn solve_limbs(&mut self, w: &World<'_>) -> u32 {
        let iterations = self.solve_limbs_with(w, w.ccd);
        self.pull_to_grips(w, iterations)
    }

    /// [`Sloth::solve_limbs`] of two sloths at once: their limbs share the
    /// SIMD lanes of one solve where both have limbs to solve (about half the
    /// work of two calls on CPUs with AVX2). Each sloth ends exactly as its own
    /// `solve_limbs` would leave it, bit for bit.
    pub fn solve_limbs_pair(a: &mut Sloth, b: &mut Sloth, w: &World<'_>) -> [u32; 2] {
        let params = w.ccd;
        let (pa, pb) = (a.solve_prepare(w), b.solve_prepare(w));
        let (sa, sb) = match (pa.all_settled(), pb.all_settled()) {
            (false, false) => {
                let mut poses = lanes8(a.limbs.map(|l| l.pose), b.limbs.map(|l| l.pose));
                let r = slothsim_rig::solve8_prepared_tolerances(
                    &w.rig.chains4,
                    lanes8(pa.roots, pb.roots),
                    lanes8(pa.targets, pb.targets),
                    &mut poses,
                    params,
                    [params.tolerance; 8],
                );
                let half = |k: usize| (lanes4(&poses, k), lanes4(&r, k));
                (Some(half(0)), Some(half(4)))
            }
            (false, true) => (Some(a.solve_lanes(w, &pa, params)), None),
            (true, false) => (None, Some(b.solve_lanes(w, &pb, params))),
            (true, true) => (None, None),
        };
        let ia = a.solve_finish_limbs(w, params, &pa, sa);
        let ib = b.solve_finish_limbs(w, params, &pb, sb);
        let poses = lanes8(a.limbs.map(|l| l.pose), b.limbs.map(|l| l.pose));
        let fk = w
            .rig
            .chains4
            .fk_effectors8(&lanes8(pa.roots, pb.roots), &poses);
        a.set_effectors(lanes4(&fk, 0));
        b.set_effectors(lanes4(&fk, 4));
        [a.pull_to_grips(w, ia), b.pull_to_grips(w, ib)]
    }

    /// The second half of [`Sloth::solve_limbs`] after a first solve of
    /// `iterations` sweeps: the body pulled toward planted claws left short.
    fn pull_to_grips(&mut self, w: &World<'_>, mut iterations: u32) -> u32 {
        let (residual, err) = self.planted_residual();
        if err > STANCE_IK_TOLERANCE {
            let saved = (self.body_pos, self.limbs);
            self.body_pos += residual;
            iterations += self.solve_limbs_with(w, w.ccd);
            if self.planted_residual().1 >= err {
                (self.body_pos, self.limbs) = saved;
            }
        }
        iterations
    }

    /// [`Sloth::solve_limbs`], skipped where it would change nothing. The solve
    /// is a deterministic function of the fields it reads (body, targets, limb
    /// phases, poses, settled targets) and of `w`; when all of those and the
    /// fields it writes (poses, settled targets, roots, effectors, body) hold
    /// exactly the bits that a call through `memo` left unchanged, this call
    /// would leave them unchanged again: it returns that call's sweep count.
    /// A resting sloth's solves are such (about a third of the sloth-frames of
    /// a 10,000-sloth crowd). `memo` belongs to this sloth and to `w` (start it
    /// with [`SolveMemo::default`]).
    pub fn solve_limbs_memo(&mut self, w: &World<'_>, memo: &mut SolveMemo) -> u32 {
        let key = self.solve_key();
        match memo.hit(&key) {
            Some(iterations) => iterations,
            None => self.solve_limbs_kept(w, memo, key),
        }
    }

    /// [`Sloth::solve_limbs`] from the state `key`, remembered in `memo`.
    fn solve_limbs_kept(
        &mut self,
        w: &World<'_>,
        memo: &mut SolveMemo,
        key: Option<SolveKey>,
    ) -> u32 {
        let iterations = self.solve_limbs(w);
        memo.keep(self, key, iterations);
        iterations
    }

    /// [`Sloth::solve_limbs_memo`] of every sloth of a batch (`memos[i]` is
    /// `sloths[i]`'s), the solves that are not skipped paired two by two as in
    /// [`Sloth::solve_limbs_pair`] (in batch order, so each sloth ends exactly
    /// as its own solve would leave it). Returns the sweeps of all.
    pub fn solve_limbs_batch<S: AsMut<Sloth>, M: AsMut<SolveMemo>>(
        sloths: &mut [S],
        memos: &mut [M],
        w: &World<'_>,
    ) -> u64 {
        assert_eq!(sloths.len(), memos.len(), "one memo per sloth");
        let mut sweeps = 0u64;
        // A sloth to solve, waiting for a partner, and its state's key.
        let mut pending: Option<(usize, Option<SolveKey>)> = None;
        for i in 0..sloths.len() {
            let key = sloths[i].as_mut().solve_key();
            if let Some(n) = memos[i].as_mut().hit(&key) {
                sweeps += u64::from(n);
                continue;
            }
            let Some((j, key_j)) = pending.take() else {
                pending = Some((i, key));
                continue;
            };
            let (s_lo, s_hi) = sloths.split_at_mut(i);
            let (m_lo, m_hi) = memos.split_at_mut(i);
            let (a, b) = (s_lo[j].as_mut(), s_hi[0].as_mut());
            let [na, nb] = Sloth::solve_limbs_pair(a, b, w);
            m_lo[j].as_mut().keep(a, key_j, na);
            m_hi[0].as_mut().keep(b, key, nb);
            sweeps += u64::from(na) + u64::from(nb);
        }
        if let Some((j, key_j)) = pending {
            let n = sloths[j]
                .as_mut()
                .solve_limbs_kept(w, memos[j].as_mut(), key_j);
            sweeps += u64::from(n);
        }
        sweeps
    }

    /// The bits of every field [`Sloth::solve_limbs`] reads or writes; `None`
    /// while a limb swings (its target moves every frame: never skipped).
    fn solve_key(&self) -> Option<SolveKey> {
        if self.any_swinging() {
            return None;
        }
        let mut k = KeyBits::<SOLVE_KEY_LEN>::new();
        k.f32s(&self.body_pos.to_array());
        k.f32s(&self.body_rot.to_array());
        for l in &self.limbs {
            k.f32s(&l.target.to_array());
            for q in l.pose.0 {
                k.f32s(&q.to_array());
            }
            for v in [l.settled_ls, l.cold_miss_ls] {
                match v {
                    Some(t) => k.f32s(&[1.0, t.x, t.y, t.z]),
                    None => k.f32s(&[0.0; 4]),
                }
            }
            k.f32s(&[l.phase as u32 as f32]);
            k.f32s(&l.root.to_array());
            k.f32s(&l.effector.to_array());
        }
        Some(k.done())
    }

    /// The mean of the planted limbs' claw → target vectors over those off
    /// by more than [`STANCE_IK_TOLERANCE`], and the largest planted error.
    fn planted_residual(&self) -> (Vec3, f32) {
        let (mut sum, mut n, mut max) = (Vec3::ZERO, 0.0f32, 0.0f32);
        for l in self.limbs.iter().filter(|l| l.phase != LimbPhase::Swinging) {
            let r = l.target - l.effector;
            let e = r.length();
            max = max.max(e);
            if e > STANCE_IK_TOLERANCE {
                sum += r;
                n += 1.0;
            }
        }
        (if n > 0.0 { sum / n } else { Vec3::ZERO }, max)
    }

    fn solve_limbs_with(&mut self, w: &World<'_>, params: &CcdParams) -> u32 {
        let prep = self.solve_prepare(w);
        let solved = (!prep.all_settled()).then(|| self.solve_lanes(w, &prep, params));
        self.solve_finish(w, params, &prep, solved)
    }

    /// The roots, targets and settled limbs of a solve (see [`SolvePrep`]).
    fn solve_prepare(&self, w: &World<'_>) -> SolvePrep {
        let roots: [RootTransform; 4] =
            std::array::from_fn(|li| w.rig.root_ws(li, self.body_pos, self.body_rot));
        let targets = self.targets();
        let targets_ls: [Vec3; 4] =
            std::array::from_fn(|li| roots[li].inverse_transform_point(targets[li].into()).into());
        // A limb that could not reach its target keeps its settled pose while
        // the target stays put in its root frame (a resting sloth): solving
        // again would only repeat the polish of the last frame.
        let settled: [bool; 4] = std::array::from_fn(|li| {
            self.limbs[li]
                .settled_ls
                .is_some_and(|t| t.distance_squared(targets_ls[li]) <= SETTLED_MOVE * SETTLED_MOVE)
        });
        SolvePrep {
            roots,
            targets,
            targets_ls,
            settled,
        }
    }

    /// The four limbs in SIMD lanes, each lane exactly the single-limb solve:
    /// the solved poses and results (the settled limbs' are not used).
    fn solve_lanes(
        &self,
        w: &World<'_>,
        prep: &SolvePrep,
        params: &CcdParams,
    ) -> ([ChainPose; 4], [CcdResult; 4]) {
        let mut poses = self.limbs.map(|l| l.pose);
        let results = slothsim_rig::solve4_prepared(
            &w.rig.chains4,
            prep.roots,
            prep.targets,
            &mut poses,
            params,
        );
        (poses, results)
    }

    /// The rest of a solve after its SIMD lanes (`solved`: `None` where every
    /// limb is settled): [`Sloth::solve_finish_limbs`], then the effectors.
    fn solve_finish(
        &mut self,
        w: &World<'_>,
        params: &CcdParams,
        prep: &SolvePrep,
        solved: Option<([ChainPose; 4], [CcdResult; 4])>,
    ) -> u32 {
        let iterations = self.solve_finish_limbs(w, params, prep, solved);
        let poses = self.limbs.map(|l| l.pose);
        self.set_effectors(w.rig.chains4.fk_effectors(&prep.roots, &poses));
        iterations
    }

    /// Resumed and cold solves where the SIMD lanes fell short, the settled
    /// targets and the roots (not the effectors). Returns the sweeps.
    fn solve_finish_limbs(
        &mut self,
        w: &World<'_>,
        params: &CcdParams,
        prep: &SolvePrep,
        solved: Option<([ChainPose; 4], [CcdResult; 4])>,
    ) -> u32 {
        let SolvePrep {
            roots,
            targets_ls,
            settled,
            ..
        } = *prep;
        let mut iterations = 0;
        for li in 0..4 {
            let root = roots[li];
            let l = &mut self.limbs[li];
            if l.phase == LimbPhase::Swinging {
                l.cold_miss_ls = None;
            }
            if let (false, Some((poses, results))) = (settled[li], &solved) {
                l.pose = poses[li];
                let mut r = results[li];
                iterations += r.iterations;
                // A warm solve may stop short when its smoothness guard caps a
                // large joint move; resume from where it stopped (rare).
                for _ in 0..3 {
                    if r.error <= params.tolerance {
                        break;
                    }
                    let prev = r.error;
                    r = slothsim_rig::solve(&w.rig.chains[li], root, l.target, &mut l.pose, params);
                    iterations += r.iterations;
                    if r.error > prev * 0.9 {
                        break;
                    }
                }
                // A planted claw the warm start left off its grip: the swing
                // may have carried the limb into a fold (a local minimum at
                // the joint limits) the step check, started elsewhere, did not
                // use. A cold start gets another chance (rare: a limb stays
                // settled until its target moves), but not again near where
                // one failed.
                let tried_here = l.cold_miss_ls.is_some_and(|t| {
                    t.distance_squared(targets_ls[li]) <= COLD_RETRY_MOVE * COLD_RETRY_MOVE
                });
                if l.phase != LimbPhase::Swinging && r.error > STANCE_IK_TOLERANCE && !tried_here {
                    let mut cold = ChainPose::NEUTRAL;
                    let c =
                        slothsim_rig::solve(&w.rig.chains[li], root, l.target, &mut cold, params);
                    iterations += c.iterations;
                    l.cold_miss_ls =
                        (c.error > r.error - COLD_RETRY_GAIN).then_some(targets_ls[li]);
                    if c.error < r.error {
                        l.pose = cold;
                        r = c;
                    }
                }
                l.settled_ls = (r.error > params.tolerance).then_some(targets_ls[li]);
            }
            l.root = root.position.into();
        }
        iterations
    }

    /// The claws where the limbs' poses put them (world space).
    fn set_effectors(&mut self, effectors: [Vec3; 4]) {
        for (l, effector) in self.limbs.iter_mut().zip(effectors) {
            l.effector = effector;
        }
    }

    // ---------------------------------------------------------------- stage 5

    /// Transitions: gait clock and footfall order, goal check. Limbs whose
    /// turn has come start searching (their first traces go into `batch`).
    pub fn transitions(&mut self, w: &World<'_>, dt: f32, batch: &mut TraceBatch) {
        self.time += dt;
        // Committed steps lift off by their deadline (in the last frame
        // before it), whatever else the sloth does: another limb's swing was
        // checked with them in the air from then on.
        for li in 0..4 {
            if self.limbs[li].fallback.is_some_and(|fb| {
                self.time + dt > fb.by_s && self.limbs[li].phase != LimbPhase::Swinging
            }) {
                self.start_fallback_swing(li);
            }
        }
        if let Some((d, true)) = self.goal_distance(w)
            && d <= self.goal_tolerance
        {
            self.status = Status::Arrived;
        }
        if let Some(t) = self.resume_at
            && self.time >= t
        {
            self.resume_at = None;
            self.status = Status::Moving;
            self.stalled_turns = 0;
            self.failed_searches = 0;
        }
        if self.status != Status::Moving {
            return;
        }
        self.finish_transfer(w);
        // At the goal with a limb still swinging (the steady profile's
        // swings overlap, so a moment with all four planted may never come
        // while walking): no limb lifts off until the swings end; then the
        // sloth has arrived, or walks on if the last landing took it out of
        // the goal's tolerance.
        let arriving = self
            .goal_distance_with(w, Self::grips_only)
            .is_some_and(|(d, on)| on && d <= self.goal_tolerance);
        let prev = self.clock;
        self.clock = (self.clock + dt / w.cfg.cycle_duration()).fract();
        let offsets = w.cfg.phase_offsets();
        for (li, &off) in offsets.iter().enumerate() {
            let crossed = if self.clock >= prev {
                off > prev && off <= self.clock
            } else {
                off > prev || off <= self.clock
            };
            if crossed {
                self.limbs[li].due = true;
            }
        }
        for li in 0..4 {
            let planted = self
                .limbs
                .iter()
                .filter(|l| l.phase != LimbPhase::Swinging)
                .count();
            let l = self.limbs[li];
            if !l.due || l.phase != LimbPhase::Planted || planted < 3 || arriving {
                continue;
            }
            self.limbs[li].due = false;
            if self.limbs.iter().all(|l| l.phase == LimbPhase::Planted) {
                self.keep_hang_side(w);
            }
            self.limbs[li].phase = LimbPhase::Searching;
            self.limbs[li].search = self
                .goal_branch_search(w, li)
                .unwrap_or_else(|| self.own_search(w, li));
            self.queue_candidates(w, li, batch);
        }
    }

    // ---------------------------------------------------------------- judge

    /// What the judge and the statistics see this frame.
    pub fn observe(&self, w: &World<'_>) -> SlothObservation {
        let scene = w.scene();
        let limbs: [LimbObservation; 4] = std::array::from_fn(|li| {
            let l = &self.limbs[li];
            let s = scene.support(l.grip.support);
            LimbObservation {
                planted: l.phase != LimbPhase::Swinging,
                grip_ws: l.grip.point,
                effector_ws: l.effector,
                root_ws: l.root,
                limb_length: w.rig.chains[li].reach(),
                surface_gap: crate::path::surface_gap(w.query, s, l.effector),
                limit_violation: w.rig.chains[li].limit_violation(&l.pose),
                support: l.grip.support,
            }
        });
        let to_ws = |p: Vec3| self.body_pos + self.body_rot * p;
        let head = to_ws(w.rig.head_ms);
        let hips = to_ws(w.rig.hips_ms);
        let torso = [to_ws(w.rig.torso_ms[0]), to_ws(w.rig.torso_ms[1])];
        let on_trunk = self.fore_on_trunk(w);
        let penetration = self.near_supports(w).fold(0.0, |p, id| {
            torso_penetration(scene.support(id), w.adjacency.segment_chunks(id), torso, p)
        });
        let goal_distance_m = self.goal_distance(w).map_or(f32::INFINITY, |(d, _)| d);
        let has_nan = !(self.body_pos.is_finite()
            && self.body_rot.is_finite()
            && self
                .limbs
                .iter()
                .all(|l| l.pose.is_finite() && l.target.is_finite()));
        SlothObservation {
            time_s: self.time,
            body_pos: self.body_pos,
            body_rot: self.body_rot,
            head_ws: head,
            hips_ws: hips,
            on_trunk,
            limbs,
            penetration_m: penetration,
            goal_distance_m: if goal_distance_m.is_finite() {
                goal_distance_m
            } else {
                f32::MAX
            },
            goal_held: self.goal.is_none_or(|(gs, _)| self.holds_only(gs)),
            has_nan,
        }
    }
}

/// Whether the torso capsule enters a support deeper than `depth`: the same
/// as `torso_penetration(s, torso, depth) > depth`, returning at the first
/// such segment. Runs of segments whose `chunks` bound (see
/// [`SegmentChunk`]) rules out every segment's [`TorsoBound::may_exceed`]
/// are skipped whole; without bounds (`chunks` not matching `s`) every
/// segment is tested.
fn torso_penetrates(
    s: &slothsim_scene::Support,
    chunks: &[SegmentChunk],
    torso: [Vec3; 2],
    depth: f32,
) -> bool {
    let bound = TorsoBound::new(torso);
    let segments = s.nodes.len().saturating_sub(1);
    let hit = |i: usize| bound.may_exceed(s, i, depth) && segment_depth(s, i, torso) > depth;
    if chunks.len() != segments.div_ceil(SEGMENT_CHUNK) {
        return (0..segments).any(hit);
    }
    chunks.iter().enumerate().any(|(k, c)| {
        bound.may_reach_chunk(c, depth)
            && (k * SEGMENT_CHUNK..((k + 1) * SEGMENT_CHUNK).min(segments)).any(hit)
    })
}

/// Deepest penetration of the torso capsule (radius [`BODY_RADIUS`]) into a
/// support, or `floor` if none is deeper. Segments whose bounding spheres
/// rule out beating `floor` are skipped (most of them).
/// Runs of segments whose `chunks` bound rules them all out are skipped
/// whole (as in [`torso_penetrates`]; every segment is tested without bounds).
fn torso_penetration(
    s: &slothsim_scene::Support,
    chunks: &[SegmentChunk],
    torso: [Vec3; 2],
    floor: f32,
) -> f32 {
    let bound = TorsoBound::new(torso);
    let segments = s.nodes.len().saturating_sub(1);
    let mut depth = floor;
    let run = |range: std::ops::Range<usize>, depth: &mut f32| {
        for i in range {
            if bound.may_exceed(s, i, *depth) {
                *depth = depth.max(segment_depth(s, i, torso));
            }
        }
    };
    if chunks.len() != segments.div_ceil(SEGMENT_CHUNK) {
        run(0..segments, &mut depth);
        return depth;
    }
    for (k, c) in chunks.iter().enumerate() {
        if bound.may_reach_chunk(c, depth) {
            run(
                k * SEGMENT_CHUNK..((k + 1) * SEGMENT_CHUNK).min(segments),
                &mut depth,
            );
        }
    }
    depth
}

/// Depth of the torso capsule in segment `i` of support `s`.
fn segment_depth(s: &slothsim_scene::Support, i: usize, torso: [Vec3; 2]) -> f32 {
    let (d, t) = segment_distance(torso[0], torso[1], s.nodes[i], s.nodes[i + 1]);
    let r = s.radii[i] + (s.radii[i + 1] - s.radii[i]) * t;
    BODY_RADIUS + r - d
}

/// The torso's bounding sphere (centre, half length).
struct TorsoBound {
    centre: Vec3,
    half: f32,
}

impl TorsoBound {
    fn new(torso: [Vec3; 2]) -> Self {
        Self {
            centre: (torso[0] + torso[1]) * 0.5,
            half: torso[0].distance(torso[1]) * 0.5,
        }
    }

    /// Whether segment `i` of `s` could hold the torso deeper than `depth`:
    /// the segment distance is at least |centres| − both half lengths
    /// (triangle inequality); 0.1 mm margin.
    fn may_exceed(&self, s: &slothsim_scene::Support, i: usize, depth: f32) -> bool {
        let (a, b) = (s.nodes[i], s.nodes[i + 1]);
        let c = (a + b) * 0.5;
        let k = a.distance(b) * 0.5;
        let reach = BODY_RADIUS + s.radii[i].max(s.radii[i + 1]) - depth + self.half + k + 1e-4;
        reach > 0.0 && self.centre.distance_squared(c) <= reach * reach
    }

    /// False only if [`TorsoBound::may_exceed`] is false for every segment of
    /// the run `chunk` bounds. Segment `i`'s test distance is at most
    /// `BODY_RADIUS + max_radius − depth + half + k_i + 1e-4`, and its
    /// midpoint lies within `chunk.radius − k_i` of the chunk's centre, so
    /// beyond this sphere (1 mm more for rounding) no segment passes.
    fn may_reach_chunk(&self, chunk: &SegmentChunk, depth: f32) -> bool {
        let reach = chunk.radius + BODY_RADIUS + chunk.max_radius - depth + self.half + 1e-4 + 1e-3;
        reach <= 0.0 || self.centre.distance_squared(chunk.centre) <= reach * reach
    }
}

/// Distance between segments p0–p1 and q0–q1, and the parameter on q.
fn segment_distance(p0: Vec3, p1: Vec3, q0: Vec3, q1: Vec3) -> (f32, f32) {
    let d1 = p1 - p0;
    let d2 = q1 - q0;
    let r = p0 - q0;
    let a = d1.dot(d1);
    let e = d2.dot(d2);
    let f = d2.dot(r);
    let (s, t);
    if a <= 1e-12 && e <= 1e-12 {
        return (p0.distance(q0), 0.0);
    }
    if a <= 1e-12 {
        s = 0.0;
        t = (f / e).clamp(0.0, 1.0);
    } else {
        let c = d1.dot(r);
        if e <= 1e-12 {
            t = 0.0;
            s = (-c / a).clamp(0.0, 1.0);
        } else {
            let b = d1.dot(d2);
            let denom = a * e - b * b;
            let mut s0 = if denom > 1e-12 {
                ((b * f - c * e) / denom).clamp(0.0, 1.0)
            } else {
                0.0
            };
            let mut t0 = (b * s0 + f) / e;
            if t0 < 0.0 {
                t0 = 0.0;
                s0 = (-c / a).clamp(0.0, 1.0);
            } else if t0 > 1.0 {
                t0 = 1.0;
                s0 = ((b - c) / a).clamp(0.0, 1.0);
            }
            s = s0;
            t = t0;
        }
    }
    ((p0 + d1 * s).distance(q0 + d2 * t), t)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The chunk bounds only skip segments that could not count: the same
    /// answer as testing every segment, on random polylines and torsos.
    #[test]
    fn chunked_torso_penetrates_matches_every_segment() {
        let mut s = 0xfeed_u64;
        let mut rnd = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut hits = 0;
        for n in [2usize, 3, 8, 9, 17, 40] {
            for _ in 0..60 {
                let mut p = Vec3::new(rnd() * 20.0, rnd() * 10.0, rnd() * 20.0);
                let mut nodes = Vec::new();
                let mut radii = Vec::new();
                for _ in 0..n {
                    nodes.push(p);
                    radii.push(0.02 + rnd() * 0.3);
                    p += Vec3::new(rnd() - 0.5, rnd() * 0.6 - 0.2, rnd() - 0.5) * 0.8;
                }
                let sup = slothsim_scene::Support::new(nodes.clone(), radii);
                let chunks = crate::path::segment_chunks(&sup);
                for _ in 0..200 {
                    let k = (rnd() * (n - 1) as f32) as usize;
                    let near = nodes[k].lerp(nodes[k + 1], rnd());
                    let c = near + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 1.5;
                    let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.6;
                    let torso = [c - d, c + d];
                    for depth in [-0.2, 0.0, STANCE_MAX_PENETRATION, 0.05] {
                        let all = torso_penetrates(&sup, &[], torso, depth);
                        assert_eq!(all, torso_penetrates(&sup, &chunks, torso, depth));
                        hits += usize::from(all);
                        // The judge's deepest penetration: the same bits either way.
                        let deepest = torso_penetration(&sup, &[], torso, depth);
                        assert_eq!(
                            deepest.to_bits(),
                            torso_penetration(&sup, &chunks, torso, depth).to_bits()
                        );
                    }
                }
            }
        }
        assert!(hits > 100, "{hits}");
    }
}
