//! Branch ↔ trunk transfers (thesis §3.3 `Transfer to Trunk`, `Transfer to
//! Branch`, Offset Back; SPEC "Trunks and transitions"): a transfer starts
//! when a limb's search moves onto a support of the other kind and ends
//! when all four limbs hold it; the hind pair leaves a trunk together.

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use slothsim_rig::Limb;
use slothsim_rig::unit::UnitOr;
use slothsim_scene::{SupportId, SupportKind};

use crate::path::project;

use super::route::approach_angle;
use super::{LimbPhase, LocoView, Sloth, Status, mix64};

/// On a trunk reached from a branch the body faces the trunk from this angle
/// around it from the branch (radians): beside the branch, head clear of it.
const TRANSFER_SIDE_ANGLE: f32 = std::f32::consts::FRAC_PI_3;

/// A mirrored side is taken only if its fore limbs' longer step is shorter by
/// more than this (metres): f32 rounding of the grips, a symmetric stance
/// keeps the side chosen by the limb.
const SIDE_CHOICE_SLACK_M: f32 = 1e-3;

/// Re-planning a transfer onto a trunk half across (one fore limb on it, see
/// [`Sloth::turned_transfer_side`]): the side turns on this grid (radians).
const SIDE_TURN_STEP: f32 = 5.0 * std::f32::consts::PI / 180.0;

/// … and at most this far in all from the side first chosen (radians):
/// half the side's angle from the branch ([`TRANSFER_SIDE_ANGLE`]), so the
/// body stays beside the branch, not below it (turned 50° at 149.6°, 0.2 m,
/// the transfer went through but the body faced the trunk from under the
/// branch and did not get down the trunk in time).
const SIDE_TURN_MAX: f32 = TRANSFER_SIDE_ANGLE * 0.5;

/// A change between a branch and a trunk in progress (SPEC `transfer_to_trunk`,
/// `transfer_to_branch`). On the trunk the body faces it from `side`; while
/// the limbs move across, the body rolls about its long axis between hanging
/// below the branch and facing the trunk (see `Sloth::body_frame`).
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
    /// The travel direction (`Sloth::dir`) it started with: travelling the
    /// other way (a back-off, a turn back) undoes it.
    #[serde(default = "plus_one")]
    pub dir: f32,
    /// The stances it has taken since it started or last turned toward its
    /// target again (see [`Sloth::note_transfer_stance`]): the last
    /// [`STANCES_KEPT`] as a ring, each by a key of the limb whose step took
    /// it (its place in the footfall order) and the four grips to
    /// [`STANCE_GRID_M`].
    #[serde(default)]
    pub stance_keys: [u32; STANCES_KEPT],
    /// Stances recorded (the ring's next slot is this modulo [`STANCES_KEPT`]).
    #[serde(default)]
    pub stance_count: u32,
    /// Times each of [`Self::stance_keys`] was taken again.
    #[serde(default)]
    pub stance_visits: [u8; STANCES_KEPT],
    /// How far the side has turned about the trunk's axis since it was
    /// chosen (radians, re-plans: [`Sloth::turned_transfer_side`]).
    #[serde(default)]
    pub side_turned: f32,
}

impl Transfer {
    /// Whether one of the stances recorded since the transfer started (or
    /// last turned toward its target) was taken again: its steps go round
    /// a circle ([`Sloth::note_transfer_stance`] gives up at the third).
    pub fn circling(&self) -> bool {
        let kept = (self.stance_count as usize).min(STANCES_KEPT);
        self.stance_visits[..kept].iter().any(|&v| v > 0)
    }
}

/// Stances a transfer remembers (see [`Transfer::stance_keys`]): a circle
/// of steps by two limbs in turn (trunk_branch at 71.7°, 0.2 m: LF and LH)
/// is a dozen steps long.
pub const STANCES_KEPT: usize = 16;

/// Grid of the grips in a stance's key (metres; step candidates lie a
/// back-off, 1 cm, apart; a circle repeats a stance to a micrometre).
const STANCE_GRID_M: f32 = 1e-4;

/// A stance taken again this many times ends the transfer's try (see
/// [`Sloth::note_transfer_stance`]).
const STANCE_CIRCLES: u8 = 2;

/// A stance outside a transfer taken again this many times gives up (see
/// [`Sloth::note_stuck_stance`]): one round more than a transfer's watch
/// allows (branch_trunk at 71.5°, 0.15 m: RH re-gripped round three grips
/// on the trunk, and the fourth round ended elsewhere).
const STUCK_STANCE_CIRCLES: u8 = STANCE_CIRCLES + 1;

/// The stances a sloth took while its search was failing, outside a
/// transfer (see [`Sloth::note_stuck_stance`]): a ring of keys as in
/// [`Transfer::stance_keys`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StanceRing {
    /// The last [`STANCES_KEPT`] stances' keys.
    pub keys: [u32; STANCES_KEPT],
    /// Times each of [`Self::keys`] was taken again.
    pub visits: [u8; STANCES_KEPT],
    /// Stances recorded (the ring's next slot is this modulo [`STANCES_KEPT`]).
    pub count: u32,
}

/// Records stance `key` in a ring of the last [`STANCES_KEPT`] stances
/// (`keys`, their repeat counts `visits`, `count` recorded): true when it was
/// taken `circles` times before, and the ring starts again (the livelock
/// watches, [`Sloth::note_transfer_stance`] and [`Sloth::note_stuck_stance`]).
fn visit_stance(
    keys: &mut [u32; STANCES_KEPT],
    visits: &mut [u8; STANCES_KEPT],
    count: &mut u32,
    key: u32,
    circles: u8,
) -> bool {
    let kept = (*count as usize).min(STANCES_KEPT);
    match (0..kept).find(|&k| keys[k] == key) {
        Some(k) if visits[k] + 1 >= circles => {
            *count = 0;
            true
        }
        Some(k) => {
            visits[k] += 1;
            false
        }
        None => {
            let slot = *count as usize % STANCES_KEPT;
            keys[slot] = key;
            visits[slot] = 0;
            *count = count.wrapping_add(1);
            false
        }
    }
}

/// Transfer `tr` once no limb holds its target, the limbs holding
/// `held`. Not taken. But where limbs hold the trunk and other supports (a
/// step went onto a neighbour of the branch), the body is still between a
/// trunk and a branch: the transfer goes on onto the other support most
/// limbs hold (ties: the first limb's), with its side and its roll, so the
/// body is drawn as before. Ending it jumped the body 0.38 m in one frame
/// with one other support; with two (LF and RF on two branches, the hind
/// limbs on the trunk: seed 3 of the 5,000-sloth crowd under the
/// searching-before-the-wait rule) 17.6 cm, and a transfer set up again
/// from that stance 5 cm back, 18.7 mm into a support. `None`: no limb on
/// the trunk (the transfer undone, or all on other supports).
pub(super) fn transfer_not_taken(tr: Transfer, held: [SupportId; 4]) -> Option<Transfer> {
    if !held.contains(&tr.trunk) {
        return None;
    }
    let count = |s: SupportId| held.iter().filter(|&&h| h == s).count();
    let to = held.iter().copied().filter(|&s| s != tr.trunk).fold(
        None,
        |best: Option<SupportId>, s| match best {
            Some(b) if count(b) >= count(s) => Some(b),
            _ => Some(s),
        },
    )?;
    Some(Transfer {
        to,
        stance_count: 0,
        ..tr
    })
}

fn plus_one() -> f32 {
    1.0
}

impl Sloth {
    /// Starts a branch ↔ trunk transfer from `from` onto `to` (unless one is
    /// under way: a limb holds its target) and picks, once, the side of the
    /// trunk the body faces it from. Onto a trunk: beside the branch (the head is eased
    /// sideways away from it), on the side the body leans to, else on a side
    /// of this sloth's own; off a trunk: the side the body is on. False:
    /// not set up, as the body it would draw at once does not hold (see
    /// below).
    pub(super) fn begin_transfer(
        &mut self,
        env: &LocoView<'_>,
        li: usize,
        from: SupportId,
        to: SupportId,
    ) -> bool {
        if self
            .transfer
            .is_some_and(|t| self.limbs.iter().any(|l| l.grip.support == t.to))
        {
            return true;
        }
        let scene = env.scene();
        let onto_trunk = scene.support(to).kind == SupportKind::Trunk;
        let (trunk, branch) = if onto_trunk { (to, from) } else { (from, to) };
        let a = project(scene.support(trunk), self.body_pos);
        let off_axis = self.body_pos - a.point;
        let off_axis = off_axis - a.tangent * a.tangent.dot(off_axis);
        let fallback = a.tangent.any_orthonormal_vector();
        let bp = project(scene.support(branch), self.body_pos);
        let away = bp.point - a.point;
        let away = (away - a.tangent * a.tangent.dot(away)).unit_or(fallback);
        // The same transfer started again (its first limb searches anew):
        // the stances it took stand.
        let (dir, stance_keys, stance_visits, stance_count) = match self.transfer {
            Some(t) if t.to == to && t.trunk == trunk => {
                (t.dir, t.stance_keys, t.stance_visits, t.stance_count)
            }
            _ => (self.dir, [0; STANCES_KEPT], [0; STANCES_KEPT], 0),
        };
        let side = if onto_trunk {
            let b = bp.tangent;
            let n = a.tangent.cross(b).unit_or(fallback);
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
            let n2 = (nn - a.tangent * a.tangent.dot(nn)).unit_or(fallback);
            // Tail first (`Sloth::descends_tail_first`) the hips come to the
            // trunk next to the branch's root and the hind limbs reach around
            // from there: as far around as trunk → branch climbs up to the
            // branch (`approach_angle`: the same surface distance from the
            // branch as 60° on the default trunk), nearer on a thick trunk.
            let angle = if dir < 0.0 {
                approach_angle(a.radius)
            } else {
                TRANSFER_SIDE_ANGLE
            };
            (away * angle.cos() + n2 * angle.sin()).unit_or(fallback)
        } else {
            off_axis.unit_or(fallback)
        };
        // Head first onto a trunk, of that side and its mirror about the
        // branch's plane, the one from which the farther fore limb reaches
        // its trunk grip the sooner (ties: the side chosen above). The second
        // fore limb reaches around the trunk from the branch's other side:
        // where the branch meets the trunk steeply (branch_trunk at 155°,
        // 0.15 m) or on a thick trunk (112°, 0.2 m) the side chosen for the
        // first put the other's grip 0.5 m from it, out of reach, and the
        // transfer stalled with one fore limb on the trunk. The side is also
        // chosen afresh each time a fore limb's search starts the transfer
        // again, and toward the searching limb's side it flipped with it.
        let transfer = |side: Vec3| Transfer {
            to,
            trunk,
            side,
            away,
            dir,
            stance_keys,
            stance_visits,
            stance_count,
            side_turned: 0.0,
        };
        let side = if onto_trunk && dir > 0.0 {
            let mirror = (2.0 * away * away.dot(side) - side).unit_or(side);
            let longest = |side: Vec3| {
                let probe = Sloth {
                    transfer: Some(transfer(side)),
                    ..*self
                };
                [Limb::LF, Limb::RF]
                    .map(|l| probe.trunk_grip_distance(env, l.index(), trunk))
                    .into_iter()
                    .fold(0.0f32, f32::max)
            };
            // Rolled clear of the trunk alongside on the approach
            // (`Sloth::approach_trunk`): the side the body rolled to, so the
            // transfer's roll goes on the way the body already turned.
            let rolled = self
                .approach_trunk(env)
                .and_then(|_| self.rolled_toward(env));
            if let Some(toward) = rolled {
                if side.dot(toward) >= 0.0 {
                    side
                } else {
                    mirror
                }
            } else if longest(mirror) + SIDE_CHOICE_SLACK_M < longest(side) {
                mirror
            } else {
                side
            }
        } else {
            side
        };
        // Set up from a stance already across the trunk and another support
        // (a limb holds each): no step is taken, yet the body is drawn
        // rolled at once, so no step's checks see it. It is set up only where every
        // limb still reaches its grip with that body, clear of the supports
        // (set up so, with LF and RF on two branches and the hind limbs on
        // the trunk, a crowd sloth's body jumped 5 cm, 18.7 mm into a
        // support).
        let holds = |f: &dyn Fn(SupportId) -> bool| self.limbs.iter().any(|l| f(l.grip.support));
        if holds(&|s| s == trunk) && holds(&|s| s != trunk) {
            let probe = Sloth {
                transfer: Some(transfer(side)),
                ..*self
            };
            if !probe.stance_holds(env) {
                return false;
            }
        }
        self.transfer = Some(transfer(side));
        true
    }

    /// Re-planning a transfer onto a trunk locked half way (goal mode, issue
    /// 24): one fore limb holds the trunk, the other is still on another
    /// support and has no step onto the trunk: its grip there, placed
    /// around the transfer's side (formula 3), is out of its reach (a
    /// thick trunk, or a branch meeting it steeply: that grip lies a
    /// quarter turn around the trunk from the branch). The side turns about
    /// the trunk's axis toward that limb (the way its trunk grip comes
    /// nearer), by the least multiple of [`SIDE_TURN_STEP`] from which the
    /// stance held now still holds (the body is drawn around the new side at
    /// once) and that limb has a step onto the trunk; the turns of a
    /// transfer add up to [`SIDE_TURN_MAX`] at most. The limb on the trunk
    /// keeps its grip; its next steps there go around the new side. The
    /// transfer turned, or `None`: not such a stance, or no side within the
    /// turn left gives the limb a step.
    pub(super) fn turned_transfer_side(&self, env: &LocoView<'_>) -> Option<Transfer> {
        let tr = self.transfer?;
        if tr.to != tr.trunk || tr.dir < 0.0 || self.dir != tr.dir || self.any_swinging() {
            return None;
        }
        let on_trunk = |l: Limb| self.limbs[l.index()].grip.support == tr.trunk;
        let stuck = match (on_trunk(Limb::LF), on_trunk(Limb::RF)) {
            (true, false) => Limb::RF.index(),
            (false, true) => Limb::LF.index(),
            _ => return None,
        };
        let axis = project(env.scene().support(tr.trunk), self.body_pos).tangent;
        let with_side = |k: i32| {
            let mut probe = *self;
            if let Some(t) = probe.transfer.as_mut() {
                t.side = Quat::from_axis_angle(axis, k as f32 * SIDE_TURN_STEP) * tr.side;
                t.side_turned += k.unsigned_abs() as f32 * SIDE_TURN_STEP;
                t.stance_count = 0;
            }
            probe
        };
        let distance = |k: i32| with_side(k).trunk_grip_distance(env, stuck, tr.trunk);
        // Toward the limb: the way its trunk grip comes nearer.
        let way = if distance(1) <= distance(-1) { 1 } else { -1 };
        let steps = ((SIDE_TURN_MAX - tr.side_turned) / SIDE_TURN_STEP + 1e-3).floor() as i32;
        (1..=steps).map(|k| with_side(way * k)).find_map(|probe| {
            let step = probe
                .neighbour_search(env, stuck, tr.trunk, 0)
                .is_some_and(|sr| probe.range_has_step(env, stuck, &sr));
            (step && probe.stance_holds(env))
                .then_some(probe.transfer)
                .flatten()
        })
    }

    /// Goal mode, walking head first along a branch toward the trunk the
    /// goal is on, below where the branch meets it, down the branch (its
    /// root, the end nearer the trunk's axis, lower along the trunk's up
    /// than the body's point on the branch): the sloth descends tail first
    /// (issue 24). Head first it would reach the trunk head down: the fore
    /// limbs take the trunk first and must pitch the body head up from below
    /// the hind grips (branch_trunk below ~71°: the other fore claw, still
    /// on the branch, fell 1–5 cm short as the body rose). So it turns
    /// around on the branch first (`turn.rs`, [`Turn::tail_first`]) and
    /// walks on tail first: the hind limbs lead onto the trunk below the
    /// junction, the fore limbs follow, and the body ends head up on the
    /// trunk, as real sloths come down. Decided by the signs of the geometry
    /// alone (no slope threshold).
    ///
    /// [`Turn::tail_first`]: super::Turn::tail_first
    pub(super) fn descends_tail_first(&self, env: &LocoView<'_>) -> bool {
        if self.wander
            || self.dir <= 0.0
            || self.transfer.is_some()
            || self.backoff.is_some()
            || self.turn.is_some()
        {
            return false;
        }
        let Some((gs, gp)) = self.goal else {
            return false;
        };
        let scene = env.scene();
        let sid = self.limbs[0].grip.support;
        let (t, b) = (scene.support(gs), scene.support(sid));
        if t.kind != SupportKind::Trunk
            || b.kind != SupportKind::Branch
            || !self.grips_only(sid)
            || !env.adjacency.neighbours(sid).contains(&gs)
        {
            return false;
        }
        // The branch's root: its end nearer the trunk's axis.
        let off = |p: Vec3| p.distance(project(t, p).point);
        let (e0, e1) = (b.nodes[0], b.nodes[b.nodes.len() - 1]);
        let (root, root_u) = if off(e0) <= off(e1) {
            (e0, 0.0)
        } else {
            (e1, b.length())
        };
        // Heading for it: the leading limbs travel toward the root.
        let g = self.limbs[Limb::LF.index()].grip;
        if (root_u - g.u) * g.sdir <= 0.0 {
            return false;
        }
        let a = project(t, root);
        let axis_up = if a.tangent.y >= 0.0 {
            a.tangent
        } else {
            -a.tangent
        };
        let here = project(b, self.body_pos).point;
        (gp - a.point).dot(axis_up) < 0.0 && (root - here).dot(axis_up) < 0.0
    }

    /// Livelock watch of a transfer under way (issue 24), after limb `li`
    /// took a step: a stance it took twice before (since it started, or
    /// last turned toward its target) is taken a third time, each time by
    /// the same limb's step (at the same place in the footfall order), its
    /// grips on the same 0.1 mm grid. The
    /// steps between went round the same circle twice — one limb
    /// re-gripping while the others find nothing, each of its steps
    /// resetting the failed-search count (trunk_branch at 71.5°, 0.2 m: LF
    /// among three grips for ever) — so the search gives up as if no limb
    /// had found a step (`Sloth::give_up`: the cause is `transfer_failed`;
    /// goal mode re-plans, wander mode turns back). Once round is not
    /// enough: what the stance does not show (the limbs' warm-started IK
    /// poses) can let the second round end differently (trunk_branch at
    /// 123°, 0.2 m, went round twice, then the fore limbs found their way
    /// out on the branch). A back-off, a turn or travel turned back
    /// (undoing the transfer) steps away from the target on purpose: the
    /// record starts again after it.
    pub(super) fn note_transfer_stance(&mut self, env: &LocoView<'_>, li: usize) {
        let Some(mut tr) = self.transfer else { return };
        if self.backoff.is_some() || self.turn.is_some() || self.dir != tr.dir {
            tr.stance_count = 0;
            self.transfer = Some(tr);
            return;
        }
        let key = self.stance_key(li);
        let circled = visit_stance(
            &mut tr.stance_keys,
            &mut tr.stance_visits,
            &mut tr.stance_count,
            key,
            STANCE_CIRCLES,
        );
        self.transfer = Some(tr);
        if circled && self.status == Status::Moving {
            self.give_up(env);
        }
    }

    /// The key of the stance limb `li`'s step took: the limb (its place in
    /// the footfall order) and the four grips on a [`STANCE_GRID_M`] grid.
    fn stance_key(&self, li: usize) -> u32 {
        let mut key = mix64(li as u64);
        for l in &self.limbs {
            for c in l.grip.point.to_array() {
                key = mix64(key ^ ((c / STANCE_GRID_M).round() as i64 as u64));
            }
        }
        key as u32
    }

    /// Livelock watch outside a transfer (issue 24), after limb `li` took a
    /// step; `failing`: the search had failed since the step before. A limb
    /// that re-grips round a few grips while the others find nothing
    /// resets the failed-search count with each step, so the search never
    /// gives up (trunk_branch at 144.5°, 0.08 m: the transfer done, LH went
    /// 0.669 → 0.629 → 0.589 m and forward to 0.669 m again, for ever). A
    /// stance such a step took [`STUCK_STANCE_CIRCLES`] times before is
    /// taken again: the search gives up (`Sloth::give_up`). A step taken
    /// with the search not failing (progress), a transfer, a back-off or a
    /// turn starts the record again.
    pub(super) fn note_stuck_stance(&mut self, env: &LocoView<'_>, li: usize, failing: bool) {
        let mut r = self.stuck_stances;
        if !failing || self.transfer.is_some() || self.backoff.is_some() || self.turn.is_some() {
            self.stuck_stances.count = 0;
            return;
        }
        let key = self.stance_key(li);
        let circled = visit_stance(
            &mut r.keys,
            &mut r.visits,
            &mut r.count,
            key,
            STUCK_STANCE_CIRCLES,
        );
        self.stuck_stances = r;
        if circled && self.status == Status::Moving {
            self.give_up(env);
        }
    }

    /// Ends the transfer once all four limbs hold its target support (or
    /// when no limb holds it nor searches any more: it was not taken). On a
    /// trunk the body faces up (head up); the travel turns toward the goal:
    /// tail first when it is below.
    pub(super) fn finish_transfer(&mut self, env: &LocoView<'_>) {
        let Some(tr) = self.transfer else { return };
        if self
            .limbs
            .iter()
            .all(|l| l.phase == LimbPhase::Planted && l.grip.support != tr.to)
        {
            self.transfer = transfer_not_taken(tr, self.limb_map(|l| l.grip.support));
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
        self.hind_single = false;
        self.lone_fore_searches = 0;
        let s = env.scene().support(tr.to);
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
        // A back-off under way ends: the travel now heads for the goal.
        self.backoff = None;
        for l in &mut self.limbs {
            l.grip.sdir = dir * up_u;
        }
    }

    /// `transfer_to_branch`: once no fore limb is on the trunk, the hind
    /// limbs leave it together (SPEC: the one exception to one limb at a
    /// time). The partner of hind limb `li` stepping onto branch `sid`, if
    /// this is that step.
    pub(super) fn hind_pair(&self, li: usize, sid: SupportId) -> Option<usize> {
        let tr = self.transfer?;
        let limb = Limb::ALL[li];
        if limb.is_fore() || self.dir < 0.0 || tr.to != sid || tr.trunk == sid || self.hind_single {
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

    /// `transfer_to_branch` with the fore limbs across and both hind limbs
    /// still on the trunk (the pair's stage, see [`Self::hind_pair`]): the
    /// unit direction along the trunk's axis toward the junction, for hind
    /// limb `li`'s step on the trunk `sid`. The pair must land level on the
    /// branch (one arc length), so a hind limb below its partner steps up
    /// toward it, never past it (see `Sloth::keeps_leg_order`): measured
    /// along the body (which by then heads out along the branch), steps up
    /// the trunk counted as backward and steps down as forward, so the hind
    /// grips drifted apart and down (trunk_branch at 0.2 m, 130°: 0.17 m
    /// apart, one of them always farther than a transfer step from the
    /// pair's grips on the branch). A hind limb level with its partner
    /// and more than a step below the branch's root climbs toward the
    /// junction too, up to a girdle lead past the partner.
    pub(super) fn hind_closing(
        &self,
        env: &LocoView<'_>,
        li: usize,
        sid: SupportId,
    ) -> Option<Vec3> {
        let tr = self.transfer?;
        let limb = Limb::ALL[li];
        let on_trunk = |i: usize| self.limbs[i].grip.support == tr.trunk;
        if limb.is_fore()
            || self.dir < 0.0
            || self.hind_single
            || tr.to == tr.trunk
            || sid != tr.trunk
            || !on_trunk(li)
            || !on_trunk(limb.opposite().index())
            || on_trunk(Limb::LF.index())
            || on_trunk(Limb::RF.index())
        {
            return None;
        }
        let scene = env.scene();
        let (t, b) = (scene.support(tr.trunk), scene.support(tr.to));
        // The branch's root: its end nearer the trunk's axis.
        let off = |p: Vec3| p.distance(project(t, p).point);
        let (e0, e1) = (b.nodes[0], b.nodes[b.nodes.len() - 1]);
        let root = if off(e0) <= off(e1) { e0 } else { e1 };
        let here = project(t, self.limbs[li].grip.point);
        let du = project(t, root).u - here.u;
        let toward = here.tangent * if du >= 0.0 { 1.0 } else { -1.0 };
        let partner = self.limbs[limb.opposite().index()].grip.point;
        let behind = (partner - self.limbs[li].grip.point).dot(toward);
        // Level with the partner, a hind limb more than a step below the
        // branch's root climbs toward it, up to a girdle lead past the
        // partner (which then closes up): level grips far below the root
        // may have no pair step onto the branch (trunk_branch at 138°,
        // 0.2 m: the hind grips 0.45 m below the junction, one of them
        // 0.42 m from the pair's grips, a transfer step reaches 0.405 m).
        let level = behind > -env.cfg.min_step_m && du.abs() > env.cfg.max_step_m;
        (behind >= env.cfg.min_step_m || level).then_some(toward)
    }

    /// Swing progress of `transfer_to_branch`'s hind pair while it travels
    /// from the trunk onto the branch together (see [`Self::hind_pair`]).
    pub(super) fn hind_pair_swing_t(&self) -> Option<f32> {
        let tr = self.transfer?;
        let (lh, rh) = (self.limbs[Limb::LH.index()], self.limbs[Limb::RH.index()]);
        let pair = [lh, rh].iter().all(|l| {
            l.phase == LimbPhase::Swinging && l.from_support == tr.trunk && l.grip.support == tr.to
        });
        (pair && tr.to != tr.trunk).then_some(lh.swing_t.min(rh.swing_t))
    }
}

#[cfg(test)]
mod tests {
    use slothsim_scene::{SupportId, SupportKind};

    use slothsim_rig::Rig;
    use slothsim_scene::{Preset, Scene, Support, TraceScene};

    use super::super::test_util::tick;
    use super::super::{NearRing, SpawnHint, TraceBatch};
    use super::*;
    use crate::{LocoEnv, LocomotionConfig, Profile};

    /// A transfer whose target no limb holds any more, every limb planted,
    /// the limbs on its trunk and on two other branches (LF and RF on two
    /// branches, the hind limbs on the trunk: a crowd sloth's fore limb had
    /// landed off the target): it goes on (`transfer_not_taken`) onto the
    /// branch most limbs hold, and the body is drawn as before, to the bit.
    /// Ending it redrew the body without the transfer's roll at once, no
    /// step taken (17.6 cm in one frame in the crowd). Every stance, no limb
    /// swinging, of branch_trunk run trunk → branch (120 s) with two limbs or
    /// more on the transfer's branch and one on the trunk: those limbs
    /// relabelled onto two branches far away that no limb holds.
    #[test]
    fn a_transfer_off_its_target_goes_on_without_a_jump() {
        // The branch_trunk preset (a branch meeting a trunk) and two
        // branches far from it, no limb's.
        let preset = Preset::by_name("branch_trunk", None).unwrap();
        let mut supports = preset.scene.supports().to_vec();
        for z in [20.0, 30.0] {
            supports.push(
                Support::new(
                    vec![Vec3::new(0.0, 3.0, z), Vec3::new(2.0, 3.0, z)],
                    vec![0.05; 2],
                )
                .with_kind(SupportKind::Branch),
            );
        }
        let scene = Scene::new(supports).unwrap();
        let cfg = LocomotionConfig::profile(Profile::Free);
        let env = LocoEnv::new(cfg, &Rig::sloth(), TraceScene::new(scene)).unwrap();
        let view = env.view();
        // Run the other way (trunk → branch), as the transfer matrix's
        // trunk_branch does: from the trunk below the junction, head up, the
        // body 60° around it from the branch's side, to where branch_trunk
        // starts.
        let (mut s, mut g) = (preset.start, preset.goal);
        let b = preset.scene.support(s.support);
        let along = b.nodes[b.nodes.len() - 1] - b.nodes[0];
        let away = Vec3::new(along.x, 0.0, along.z).unit_or(Vec3::X);
        let angle = 60f32.to_radians();
        (s.support, g.support) = (g.support, s.support);
        std::mem::swap(&mut s.position, &mut g.point);
        s.forward = Vec3::Y;
        s.body_side = away * angle.cos() + Vec3::Y.cross(away) * angle.sin();
        let hint = SpawnHint::from(s);
        let mut sloth = Sloth::spawn(&view, &hint, Some((g.support, g.point, g.tolerance)));
        sloth.goal_side = g.side;
        let mut batch = TraceBatch::default();
        let mut near = NearRing::default();
        let mut cases = 0;
        for frame in 0..7200 {
            tick(&mut sloth, &mut near, &view, &mut batch);
            check(&view, frame, sloth, &mut cases);
        }
        assert!(cases > 20, "{cases} stances tried");
    }

    fn check(view: &LocoView<'_>, frame: usize, sloth: Sloth, cases: &mut usize) {
        let Some(tr) = sloth.transfer else { return };
        let held = sloth.limbs.map(|l| l.grip.support);
        let on_to: Vec<usize> = (0..4).filter(|&k| held[k] == tr.to).collect();
        if sloth.limbs.iter().any(|l| l.phase != LimbPhase::Planted)
            || tr.to == tr.trunk
            || !held.contains(&tr.trunk)
            || on_to.len() < 2
        {
            return;
        }
        let scene = view.scene();
        let spare: Vec<SupportId> = (0..scene.supports().len() as u32)
            .map(SupportId)
            .filter(|&s| scene.support(s).kind == SupportKind::Branch && !held.contains(&s))
            .take(2)
            .collect();
        let [a, b] = spare[..] else { return };
        let mut s = sloth;
        s.limbs[on_to[0]].grip.support = a;
        for &k in &on_to[1..] {
            s.limbs[k].grip.support = b;
        }
        let before = s.averaged_body(view);
        s.finish_transfer(view);
        let after = s.averaged_body(view);
        assert_eq!(
            s.transfer.map(|t| t.to),
            Some(if on_to.len() > 2 { b } else { a }),
            "frame {frame}"
        );
        assert!(
            before.0 == after.0 && before.1 == after.1,
            "frame {frame}: the body jumped {:.4} m",
            before.0.distance(after.0)
        );
        *cases += 1;
    }
}

#[cfg(test)]
mod head_up_tests {
    use glam::Vec3;
    use slothsim_rig::Rig;
    use slothsim_scene::{Preset, SupportKind, TraceScene};

    use super::super::test_util::tick;
    use super::super::{LimbPhase, LocoView, NearRing, Sloth, SpawnHint, TraceBatch};
    use crate::{LocoEnv, LocomotionConfig, Profile};

    /// Head minus hips height of the sloth's body (metres; the judge's
    /// measure on a trunk).
    fn head_over_hips(view: &LocoView<'_>, s: &Sloth) -> f32 {
        let head = s.body_pos + s.body_rot * view.rig.head_ms;
        let hips = s.body_pos + s.body_rot * view.rig.hips_ms;
        head.y - hips.y
    }

    /// A wanderer climbing the trunk of branch_trunk at 60–75° (the branch
    /// rising away from the trunk) leaves it for the branch; at every stance
    /// of that transfer with both fore limbs on the branch and both hind
    /// limbs on the trunk (all planted), a copy turns back (as a crowd
    /// sloth does when the branch ahead is crowded) and walks on 20 s. Its
    /// head never drops below its hips while its hind limbs hold the trunk
    /// and its fore limbs do not, nor with both fore limbs on the trunk.
    /// Without the rules (`Sloth::steps_reachable`) the fore limbs walked
    /// back down the rising branch and onto the trunk at its root, below
    /// the hind grips, and stood there head down (seed 6 of the
    /// 5,000-sloth crowd: 2,403 frames).
    #[test]
    fn a_wanderer_turned_back_off_a_rising_branch_keeps_its_head_up() {
        let (mut forks, mut took) = (0, 0);
        for angle in [60.0, 65.0, 70.0, 75.0] {
            let preset = Preset::by_name("branch_trunk", Some(angle)).unwrap();
            let cfg = LocomotionConfig::profile(Profile::Free);
            let env =
                LocoEnv::new(cfg, &Rig::sloth(), TraceScene::new(preset.scene.clone())).unwrap();
            let view = env.view();
            // From the trunk below the junction, head up, the body 60°
            // around it from the branch's side (as trunk_branch starts).
            let (mut s, g) = (preset.start, preset.goal);
            let b = preset.scene.support(s.support);
            let along = b.nodes[b.nodes.len() - 1] - b.nodes[0];
            let away = Vec3::new(along.x, 0.0, along.z).normalize_or(Vec3::X);
            let side = 60f32.to_radians();
            s.support = g.support;
            s.position = g.point;
            s.forward = Vec3::Y;
            s.body_side = away * side.cos() + Vec3::Y.cross(away) * side.sin();
            let trunk = g.support;
            for seed in 0..4u64 {
                let mut sloth = Sloth::spawn(&view, &SpawnHint::from(s), None);
                sloth.wander = true;
                sloth.seed = seed;
                let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
                let mut last_fork = None;
                for frame in 0..3600 {
                    tick(&mut sloth, &mut near, &view, &mut batch);
                    let held = sloth.limbs.map(|l| l.grip.support);
                    let across = sloth.transfer.is_some_and(|t| t.to != t.trunk)
                        && held[2] == trunk
                        && held[3] == trunk
                        && held[0] != trunk
                        && held[1] != trunk
                        && sloth.limbs.iter().all(|l| l.phase == LimbPhase::Planted);
                    // Once per stance.
                    let stance = sloth.limbs.map(|l| l.grip.point);
                    if !across || last_fork == Some(stance) {
                        continue;
                    }
                    took += usize::from(last_fork.is_none());
                    last_fork = Some(stance);
                    let mut back = sloth;
                    back.turn_back();
                    let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
                    let up_at_turn = head_over_hips(&view, &back) >= 0.0;
                    forks += 1;
                    for k in 0..1200 {
                        tick(&mut back, &mut near, &view, &mut batch);
                        let held = back.limbs.map(|l| l.grip.support);
                        let kind = |i: usize| view.scene().support(held[i]).kind;
                        let fore_on_trunk = held[0] == held[1] && kind(0) == SupportKind::Trunk;
                        let hind_only = held[2] == held[3]
                            && kind(2) == SupportKind::Trunk
                            && !(held[0] == held[2] && held[1] == held[2]);
                        let d = head_over_hips(&view, &back);
                        assert!(
                            !fore_on_trunk || d >= 0.0,
                            "{angle}° seed {seed} frame {frame}+{k}: head {d:.3} m below the hips on the trunk"
                        );
                        assert!(
                            !(up_at_turn && hind_only) || d >= 0.0,
                            "{angle}° seed {seed} frame {frame}+{k}: head {d:.3} m below the hips, hind limbs on the trunk"
                        );
                    }
                }
            }
        }
        println!("{took} transfers, {forks} turned back");
        assert!(
            took >= 4 && forks >= 20,
            "{took} transfers, {forks} turned back"
        );
    }
}
