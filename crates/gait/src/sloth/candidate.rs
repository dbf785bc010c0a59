//! One step-search candidate judged in named stages (thesis §3.3
//! `FindNextStep`, formulas 3–5, conditions "CheckLegsOrder", "within the
//! limb's length", "minimum step"; SPEC "Step search" items 1–5): where the
//! grip would be ([`Placement`]), step length, leg order and head-up, other
//! sloths, then the reach checks. A candidate that passes is traced next
//! frame ([`Sloth::step_search`]). The stages are pure: the order they run
//! in only decides how early a candidate is rejected.

use glam::{Quat, Vec3};
use slothsim_rig::Limb;
use slothsim_scene::{LineTrace, SupportId, SupportKind, TraceRequest};

use crate::path::AxisPoint;

use super::body::{grip_out, support_frame};
use super::route::{SIDE_STEP_AXIAL_SLACK, SideStep};
use super::{Candidate, Grip, LimbPhase, LocoView, Search, Sloth, Transfer};

/// How far outside the surface a grip trace starts.
const TRACE_STANDOFF: f32 = 0.15;

/// Slack (m) of [`Sloth::surely_too_far`]'s bound over f32 rounding: the
/// placement's grip and distance carry errors of ~1e-5 m at forest scale.
const SURELY_FAR_SLACK_M: f32 = 1e-3;

/// Where a step-search candidate is looked for and what the search allows there.
#[derive(Clone, Copy, Debug)]
pub(super) struct CandidateAt {
    /// Limb index.
    pub(super) limb: usize,
    /// The support.
    pub(super) support: SupportId,
    /// Arc length on it.
    pub(super) u: f32,
    /// Travel direction along it.
    pub(super) sdir: f32,
    /// A retreat: the step must go backward ([`Search::retreat`]).
    pub(super) retreat: bool,
    /// A plain step that holds only with the limb lifting off next in the
    /// air may commit that limb's step ([`Sloth::planned_lift`]). Only the
    /// traced search does; the lookahead and the search for a committed step
    /// itself do not.
    may_commit_lift: bool,
}

impl CandidateAt {
    /// The traced search's candidate at `u` of limb `li`'s search `sr`.
    pub(super) fn in_search(li: usize, sr: &Search, u: f32) -> Self {
        CandidateAt {
            limb: li,
            support: sr.support,
            u,
            sdir: sr.sdir,
            retreat: sr.retreat,
            may_commit_lift: true,
        }
    }

    /// A forward candidate at `u` of the range `sr` that commits nothing
    /// (the lookahead and the search for a committed step).
    pub(super) fn probe(li: usize, sr: &Search, u: f32) -> Self {
        CandidateAt {
            retreat: false,
            may_commit_lift: false,
            ..Self::in_search(li, sr, u)
        }
    }
}

/// Where a candidate's grip would be, and the frame it is judged in (stage 1,
/// [`Sloth::place`]).
#[derive(Clone, Copy, Debug)]
struct Placement {
    limb: Limb,
    kind: SupportKind,
    /// The axis point at the candidate's arc length.
    axis: AxisPoint,
    /// A transfer onto the candidate's support.
    transfer: Option<Transfer>,
    /// A side step around the trunk the limb holds.
    side_step: Option<SideStep>,
    /// A step across a branch ↔ trunk junction (onto the transfer's support).
    transfer_step: bool,
    /// Direction from the axis to the grip (the limb's side).
    out: Vec3,
    /// The grip on the support model's surface (formula 3).
    grip: Vec3,
    /// The limb's grip now.
    cur: Vec3,
    /// Travel direction the step length is measured along.
    travel: Vec3,
    /// The body's forward now (leg order is measured along it).
    body_fwd: Vec3,
    /// Longest step allowed.
    max_step: f32,
    /// `transfer_to_branch`'s hind pair: the partner limb, its mirror grip on
    /// the branch's other side at the same arc length, and that grip's out.
    pair: Option<(usize, Vec3, Vec3)>,
    /// A hind step on the trunk before the pair leaves it
    /// ([`Sloth::hind_closing`]): measured along the axis toward the
    /// junction, landing no higher than the partner's grip (from level
    /// with it, no more than a girdle lead higher).
    closing: bool,
    /// A gathering step ([`Sloth::gathering`]): no step length, direction
    /// or leg order but the same side's spacing.
    gathering: bool,
}

impl Placement {
    /// The grip the limb would hold at candidate `at` (untraced).
    fn grip_at(&self, at: &CandidateAt) -> Grip {
        Grip {
            point: self.grip,
            normal: self.out,
            support: at.support,
            u: at.u,
            sdir: at.sdir,
        }
    }

    /// The trace that confirms the grip, and what the search keeps of it.
    fn trace(
        &self,
        at: &CandidateAt,
        back_scale: f32,
        lift: Option<(u8, Grip)>,
    ) -> (TraceRequest, Candidate) {
        let a = self.axis;
        let origin = a.point + self.out * (a.radius + TRACE_STANDOFF);
        let req = TraceRequest::Line(LineTrace {
            origin,
            dir: -self.out,
            max_dist: TRACE_STANDOFF + a.radius,
        });
        (
            req,
            Candidate {
                limb: at.limb as u8,
                support: at.support,
                u: at.u,
                sdir: at.sdir,
                out: self.out,
                point: self.grip,
                pair: self.pair.map(|(pi, p2, out2)| (pi as u8, p2, out2)),
                back_scale,
                lift,
            },
        )
    }
}

impl Sloth {
    /// A candidate for `at`, if it passes the cheap checks (step length, leg
    /// order, head up, other sloths) and the reach checks at the stances the
    /// step implies: its trace. `checks` counts the reach checks made.
    pub(super) fn candidate(
        &self,
        env: &LocoView<'_>,
        at: &CandidateAt,
        checks: &mut u32,
    ) -> Option<(TraceRequest, Candidate)> {
        // The lower hind limb's retreat closes up toward its partner instead
        // (see `Sloth::start_retreat`).
        let g = self.limbs[at.limb].grip;
        let closing = (at.retreat && at.support == g.support && (at.u - g.u) * g.sdir > 0.0)
            .then(|| self.hind_closing(env, at.limb, at.support))
            .flatten();
        let forward;
        let at = if closing.is_some() {
            forward = CandidateAt {
                retreat: false,
                ..*at
            };
            &forward
        } else {
            at
        };
        let a = env.adjacency.axis_at(env.scene().support(at.support), at.u);
        let gathering = self.gathering(env, at.limb, at.support);
        if !gathering && self.surely_too_far(env, at, &a) {
            return None;
        }
        let mut p = self.place(env, at, a);
        p.gathering = gathering;
        if let Some(toward) = closing {
            p.travel = toward;
            p.closing = true;
        }
        if !self.step_in_range(env, at, &p) {
            return None;
        }
        // Leg order with the fore grips held now; else, for a hind step, with
        // the fore limb that lifts off during its swing in the air (the step
        // then holds only with that limb's committed step, landing ahead).
        let passed_fore = if self.keeps_leg_order(env, &p, None) {
            None
        } else {
            let lj = self.lifting_fore(env, at, &p)?;
            if !self.keeps_leg_order(env, &p, Some(lj)) {
                return None;
            }
            Some(lj)
        };
        if !self.keeps_head_up(env, &p) || self.crowded(env, &p) {
            return None;
        }
        let (back_scale, lift) = self.reach_at(env, at, &p, passed_fore, checks)?;
        if self.following_hind_past_lead(env, &p) && !self.partner_follows(env, at, &p) {
            return None;
        }
        Some(p.trace(at, back_scale, lift))
    }

    /// Stage 1: where the grip would be (formula 3: on the surface on the
    /// limb's side; around a trunk, turned toward the body), in the body
    /// frame the support implies, and the travel direction the step is
    /// measured along.
    fn place(&self, env: &LocoView<'_>, at: &CandidateAt, a: AxisPoint) -> Placement {
        let (li, sid, sdir) = (at.limb, at.support, at.sdir);
        let limb = Limb::ALL[li];
        let s = env.scene().support(sid);
        // A transfer onto this trunk: the grips sit around the side the body will face it from.
        let transfer = self.transfer.filter(|t| t.to == sid);
        // A side step: around the side the body faces the trunk from, turned toward the goal's.
        let side_step = if sid == self.limbs[li].grip.support {
            self.side_step(env, sid)
        } else {
            None
        };
        let body_side = match (transfer, side_step) {
            (Some(t), _) if t.trunk == sid => t.side,
            (_, Some(ss)) => Quat::from_axis_angle(ss.axis_up, ss.turn) * ss.side_now,
            _ => self.body_pos - a.point,
        };
        let transfer_step = transfer.is_some() && sid != self.limbs[li].grip.support;
        let grip_angle = self.trunk_grip_angle(env, a.radius);
        // Body forward is the travel direction × dir (tail first when dir < 0).
        let frame_out = |side: Vec3| {
            let (f, up) = support_frame(s.kind, a.tangent * (sdir * self.dir), a.tangent, side);
            (f, up, grip_out(s.kind, limb, f, up, grip_angle))
        };
        let (mut f, mut up, mut out) = frame_out(body_side);
        // Leaving a trunk for a branch, a hind limb's grip on it goes around
        // the side the hips are on where that lies nearer the limb's root
        // (see `Sloth::hips_side`).
        if let Some(hips) = self.hips_side(env, limb, sid) {
            let (f2, up2, out2) = frame_out(hips - a.point);
            let root = self.limbs[li].root;
            let from_root = |o: Vec3| (a.point + o * a.radius).distance(root);
            if from_root(out2) < from_root(out) {
                (f, up, out) = (f2, up2, out2);
            }
        }
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
        let max_step = self.max_step_at(env, at);
        // transfer_to_branch's hind pair: the partner steps to the mirror grip
        // on the branch's other side at the same arc length.
        let pair = self.hind_pair(li, sid).map(|pi| {
            let out2 = grip_out(s.kind, Limb::ALL[pi], f, up, grip_angle);
            (pi, a.point + out2 * a.radius, out2)
        });
        Placement {
            limb,
            kind: s.kind,
            axis: a,
            transfer,
            side_step,
            transfer_step,
            out,
            grip: a.point + out * a.radius,
            cur: self.limbs[li].grip.point,
            travel,
            body_fwd: self.body_rot * Vec3::Z,
            max_step,
            pair,
            closing: false,
            gathering: false,
        }
    }

    /// How far limb `li` would step from its grip onto the trunk `trunk`
    /// at the axis point nearest that grip, placed as the transfer under way
    /// places it (the transfer's side choice: `Sloth::begin_transfer`).
    pub(super) fn trunk_grip_distance(
        &self,
        env: &LocoView<'_>,
        li: usize,
        trunk: SupportId,
    ) -> f32 {
        let g = self.limbs[li].grip;
        let a = crate::path::project(env.scene().support(trunk), g.point);
        let sdir = self
            .neighbour_search(env, li, trunk, 0)
            .map_or(1.0, |sr| sr.sdir);
        let at = CandidateAt {
            limb: li,
            support: trunk,
            u: a.u,
            sdir,
            retreat: false,
            may_commit_lift: false,
        };
        self.place(env, &at, a).grip.distance(g.point)
    }

    /// The longest step to `at` ([`Placement::max_step`]): a transfer step
    /// (onto the support a transfer goes to, from another) reaches further,
    /// and so, in goal mode, does a step from a branch onto another branch
    /// (not onto or off a trunk: with those too, the 0.1° branch → trunk
    /// grid lost 6 cases and gained 3). Across parallel branches the grip
    /// sits on the far one's face on the limb's side (formula 3), so the
    /// first fore limb's step is at least the axes' distance long: at
    /// `parallel` gaps from 0.27 m every candidate of the right fore limb on
    /// branch B failed the plain step length (0.30 m at 0.3 m against
    /// 0.27 m) and the sloth stopped `no_grip` at branch A's end; its reach
    /// checks decide now, up to a transfer step. Wanderers keep the plain
    /// step.
    fn max_step_at(&self, env: &LocoView<'_>, at: &CandidateAt) -> f32 {
        let sid = at.support;
        let held = self.limbs[at.limb].grip.support;
        let other = sid != held;
        let transfer_step = self.transfer.is_some_and(|t| t.to == sid) && other;
        let scene = env.scene();
        let branch_to_branch = other
            && scene.support(sid).kind == SupportKind::Branch
            && scene.support(held).kind == SupportKind::Branch;
        if transfer_step || (branch_to_branch && !self.wander) {
            env.cfg.max_step_m * env.cfg.transfer_step_factor
        } else {
            env.cfg.max_step_m
        }
    }

    /// Stage 2's step length bounded before the placement, from the axis point
    /// `a` at the candidate's arc length alone: the grip lies on the surface,
    /// `a.radius` from `a.point`, so an axis point farther than the longest
    /// step plus that radius (plus [`SURELY_FAR_SLACK_M`]) from the limb's
    /// grip fails [`Self::step_in_range`] whatever the placement. Only a
    /// shortcut: it rejects nothing that the placement would pass (tested).
    /// A search scans from its far end: 71 % of the candidates of a crowd
    /// fail on the step length, most of them here.
    fn surely_too_far(&self, env: &LocoView<'_>, at: &CandidateAt, a: &AxisPoint) -> bool {
        let cur = self.limbs[at.limb].grip.point;
        a.point.distance(cur) - a.radius * (1.0 + SURELY_FAR_SLACK_M)
            > self.max_step_at(env, at) + SURELY_FAR_SLACK_M
    }

    /// `transfer_to_branch`: where the hips are, for hind limb `limb`'s
    /// step on the trunk `sid` the transfer leaves. A grip on a trunk sits
    /// around the side the body faces it from (formula 3), and facing the
    /// trunk head up the hips are on that side, below the body. With the
    /// fore limbs out on the branch the body heads out along it, yawed on
    /// the trunk's surface, and the hips swing round the trunk away from
    /// the branch: a hind grip placed around the body's side was left on the
    /// branch's side of the trunk, 0.38 m across from its root, at its
    /// reach's edge, and every step of the others (the fore limbs out along
    /// the branch, the other hind limb up the trunk) would stretch it
    /// further (trunk_branch at 135°, 0.2 m: the transfer stalled there).
    fn hips_side(&self, env: &LocoView<'_>, limb: Limb, sid: SupportId) -> Option<Vec3> {
        let t = self.transfer?;
        (!limb.is_fore() && t.trunk == sid && t.to != sid)
            .then(|| self.body_pos + self.body_rot * env.rig.hips_ms)
    }

    /// Stage 2: the step's length along the travel direction within
    /// [min, max] (backward for a retreat; around the axis and toward the
    /// goal's height for a side step), the hind pair's partner's step too,
    /// and the pair lifting off only while both fore limbs hold.
    fn step_in_range(&self, env: &LocoView<'_>, at: &CandidateAt, p: &Placement) -> bool {
        let (approx, cur) = (p.grip, p.cur);
        let step = (approx - cur).dot(p.travel);
        let dist = approx.distance(cur);
        // Changing support may be a sideways step (parallel branches): it only
        // must not go backwards.
        let min_step = if at.support == self.limbs[at.limb].grip.support {
            env.cfg.min_step_m
        } else {
            0.0
        };
        let step_ok = if let Some(ss) = p.side_step.filter(|_| !at.retreat) {
            // Around the axis (the way the body turns) and toward the goal's
            // height, never much away from it.
            let d = approx - cur;
            let around = d.dot(ss.axis_up.cross(ss.side_now) * ss.turn.signum());
            let along = d.dot(p.axis.tangent * at.sdir);
            around >= 0.0 && along >= -SIDE_STEP_AXIAL_SLACK && around + along.max(0.0) >= min_step
        } else if at.retreat {
            step <= -env.cfg.min_step_m && self.retreat_keeps_lead(env, at, p)
        } else {
            // A transfer step goes where the other support is (reach decides).
            p.transfer_step || step >= min_step
        };
        if p.gathering {
            return true;
        }
        if !step_ok || dist > p.max_step {
            return false;
        }
        if p.pair
            .is_some_and(|(pi, p2, _)| p2.distance(self.limbs[pi].grip.point) > p.max_step)
        {
            return false;
        }
        // The hind pair lifts off together only while both fore limbs hold:
        // two limbs stay in contact.
        !p.pair.is_some_and(|(pi, ..)| {
            (0..4).any(|k| k != at.limb && k != pi && self.limbs[k].phase == LimbPhase::Swinging)
        })
    }

    /// A retreat (stage 2) of a leading limb a step ahead of its girdle
    /// partner, both on a support that goes on ahead of it, keeps it a step
    /// ahead: the partner has a window to step into, and retreating level
    /// with it closes that (tail first down a 0.08 m trunk from a branch at
    /// 122°, LH retreated level with RH just under the fore limbs, and no
    /// limb had a step left; RH had one down). Near the support's end, with
    /// the girdle across two supports, in a transfer (its retreats rearrange
    /// the limbs) or a back-off (it steps away on purpose), any retreat goes.
    fn retreat_keeps_lead(&self, env: &LocoView<'_>, at: &CandidateAt, p: &Placement) -> bool {
        let g = self.limbs[at.limb].grip;
        let opp = self.limbs[p.limb.opposite().index()].grip;
        let len = env.scene().support(g.support).length();
        let left = if g.sdir > 0.0 { len - g.u } else { g.u };
        let lead = |at: Vec3| (at - opp.point).dot(p.travel);
        !self.leads(p.limb)
            || self.transfer.is_some()
            || self.backoff.is_some()
            || opp.support != g.support
            || left < env.cfg.search_distance_m + env.cfg.end_margin_m
            || lead(p.cur) < env.cfg.min_step_m
            || lead(p.grip) >= env.cfg.min_step_m
    }

    /// The fore limb that lifts off during hind limb `at.limb`'s plain step
    /// ([`Sloth::next_lift`]), if the step may commit its step: when the hind
    /// limb lands, that limb is in the air toward a grip ahead, so the leg
    /// order need not hold against the grip it leaves ([`Self::keeps_leg_order`]).
    fn lifting_fore(&self, env: &LocoView<'_>, at: &CandidateAt, p: &Placement) -> Option<usize> {
        if p.limb.is_fore() || !at.may_commit_lift || !self.is_plain(at, p) {
            return None;
        }
        self.next_lift(env, at.limb)
            .map(|(lj, _)| lj)
            .filter(|&lj| Limb::ALL[lj].is_fore())
    }

    /// A plain step: one limb, forward, along the support it holds (no
    /// transfer, side step or retreat).
    fn is_plain(&self, at: &CandidateAt, p: &Placement) -> bool {
        p.pair.is_none()
            && !p.transfer_step
            && !at.retreat
            && p.side_step.is_none()
            && at.support == self.limbs[at.limb].grip.support
    }

    /// Whether hind limb `li` landing at `point` is level with or ahead of
    /// fore limb `lj`'s grip along the body (leg order then holds only with
    /// `lj` in the air toward its committed step: see [`Self::lifting_fore`]).
    pub(super) fn passes_fore(
        &self,
        env: &LocoView<'_>,
        li: usize,
        lj: usize,
        point: Vec3,
    ) -> bool {
        let fwd = self.body_rot * Vec3::Z;
        !Limb::ALL[li].is_fore()
            && Limb::ALL[lj].is_fore()
            && point.dot(fwd) > self.limbs[lj].grip.point.dot(fwd) - env.cfg.leg_order_margin_m
    }

    /// Goal mode, head first: a hind limb's transfer step with its girdle
    /// partner still on the support it leaves, landing more than the girdle
    /// lead (`max_girdle_lead × max_step_m`) ahead of the partner (a transfer
    /// step is otherwise exempt from the girdle lead: leading limbs reach
    /// around the trunk).
    fn following_hind_past_lead(&self, env: &LocoView<'_>, p: &Placement) -> bool {
        let cfg = env.cfg;
        let limb = p.limb;
        let head_first_hind_transfer =
            p.transfer_step && !self.wander && self.dir > 0.0 && !limb.is_fore();
        if !head_first_hind_transfer {
            return false;
        }
        let partner = self.limbs[limb.opposite().index()].grip;
        partner.support == self.limbs[limb.index()].grip.support
            && (p.grip - partner.point).dot(p.travel) > cfg.max_girdle_lead * cfg.max_step_m
    }

    /// Lookahead for [`Self::following_hind_past_lead`] (cheap checks and
    /// reach, no traces): after the step, the partner left on the old
    /// support has a step onto the new one, or no step at all. One that keeps
    /// only steps along the old support is left there: branch_trunk at
    /// 133.5°, 0.2 m, RH took the trunk 0.28 m up past LH (at the branch's
    /// root), and every trunk grip of LH then failed the step length, the
    /// same-side spacing to LF or RH's reach band, those of RH the girdle
    /// lead or LH's reach band: stopped `no_grip`, LH alone on the branch.
    /// A partner with no step at all may be waiting for the fore limbs
    /// (0.2 m 98.604°, 104.9°, 150.3° failed with the step held back; see
    /// docs/scenarios.md): the step is taken if, after some step of a fore
    /// limb, the partner has a step onto the new support
    /// ([`Sloth::has_step_then`]). Trusted without that lookahead, such a
    /// step locked 0.2 m 131.6°: RH took the trunk 0.30 m past LH, no fore
    /// step ever gave LH a trunk grip that left RH in its reach band, and
    /// no retreat of RH kept LH in its own (docs/locomotion.md).
    fn partner_follows(&self, env: &LocoView<'_>, at: &CandidateAt, p: &Placement) -> bool {
        let next = self.after_steps(env, [(at.limb, p.grip_at(at))]);
        let pi = p.limb.opposite().index();
        let onto_new = |s: &Sloth| {
            s.may_follow(env, pi, at.support)
                && s.neighbour_search(env, pi, at.support, 0)
                    .is_some_and(|sr| s.range_has_step(env, pi, &sr))
        };
        if next.has_step(env, pi) {
            return onto_new(&next);
        }
        [Limb::LF, Limb::RF]
            .iter()
            .any(|f| next.has_step_then(env, f.index(), onto_new))
    }

    /// Stage 3: leg order (thesis `CheckLegsOrder`), measured along the
    /// body: hind grips never ahead of a fore grip, trailing fore limbs never
    /// level with the hind ones, a side's fore and hind grips apart, onto a
    /// trunk the fore limbs no further ahead than the hind limbs can follow,
    /// and a limb landing level with or ahead of its girdle partner, never
    /// more than [`crate::LocomotionConfig::max_girdle_lead`] ahead. A hind
    /// step is judged without the grip of fore limb `lifting`, if given (it
    /// is in the air when the step lands: [`Self::lifting_fore`]).
    fn keeps_leg_order(&self, env: &LocoView<'_>, p: &Placement, lifting: Option<usize>) -> bool {
        let cfg = env.cfg;
        let (limb, approx) = (p.limb, p.grip);
        // Leg order: hind never ahead of a fore limb; never behind the opposite limb of the girdle.
        let proj = |v: Vec3| v.dot(p.body_fwd);
        if p.gathering {
            let same_side = self.limbs[limb.same_side().index()].grip.point;
            return (proj(approx) - proj(same_side)).abs() >= cfg.same_side_spacing_m;
        }
        let fore_at = |f: Limb| {
            if lifting == Some(f.index()) {
                f32::INFINITY
            } else {
                proj(self.limbs[f.index()].grip.point)
            }
        };
        let fore_min = fore_at(Limb::LF).min(fore_at(Limb::RF));
        let hind_max = proj(self.limbs[Limb::LH.index()].grip.point)
            .max(proj(self.limbs[Limb::RH.index()].grip.point));
        if !limb.is_fore() && proj(approx) > fore_min - cfg.leg_order_margin_m {
            return false;
        }
        // Tail first, the trailing fore limbs step toward the hind limbs:
        // never level with them (formula 6's hind → fore directions would
        // turn the body on centimetres of grip change).
        if limb.is_fore() && proj(approx) < hind_max + cfg.leg_order_margin_m {
            return false;
        }
        // Onto a trunk, the fore limbs climb no further ahead of the hind
        // limbs than the hind limbs can follow from the branch. Not for a
        // stuck wanderer (its search gave up): the cap keeps a walking
        // sloth's fore limbs from outclimbing its hind limbs, but half-done
        // transfers stood locked at it in crowds (fore limbs at the cap on
        // the trunk, the hind limbs on the branch unable to reach the trunk
        // or step on it), where a step up by a fore limb (its reach, head
        // up and every other check kept) changes the stance the hind limbs
        // must reach from. Goal mode keeps the cap (it re-plans).
        if p.transfer.is_some()
            && !(self.wander && self.stuck_cause.is_some())
            && limb.is_fore()
            && p.kind == SupportKind::Trunk
            && proj(approx) - hind_max > cfg.max_transfer_spread_m
        {
            return false;
        }

        // A side's fore and hind grips keep apart along the body: formula 6
        // takes the body's heading from them.
        let same_side = self.limbs[limb.same_side().index()].grip.point;
        if (proj(approx) - proj(same_side)).abs() < cfg.same_side_spacing_m {
            return false;
        }
        if p.pair
            .is_some_and(|(_, p2, _)| proj(p2) > fore_min - cfg.leg_order_margin_m)
        {
            return false;
        }
        let opp = self.limbs[limb.opposite().index()].grip.point;
        let lead = (approx - opp).dot(p.travel);
        if p.closing {
            // Up toward the partner, never past it (the pair lands level);
            // from level, up to a girdle lead past it (`Sloth::hind_closing`).
            let from_level = (p.cur - opp).dot(p.travel) > -cfg.min_step_m;
            let cap = if from_level {
                cfg.max_girdle_lead * cfg.max_step_m
            } else {
                0.0
            };
            return lead <= cap;
        }
        // A limb normally lands level with or ahead of its girdle partner. One
        // left more than a step behind it (transfer steps reach around a
        // trunk and may split a girdle by more than a step) could never land
        // level, and its partner may not lead further: it closes the gap as
        // far as a step goes instead (the farthest valid candidate wins).
        // So may a hind limb on the approach to the goal's trunk
        // ([`Self::approach_trunk`]) while the search is failing, once its
        // partner leads by more than the girdle lead less a step (the
        // partner may not step ahead either: only this limb can move the
        // girdle): with the fore limbs held up at the junction, a level
        // step there moves the body far enough to leave another limb past
        // its reach where a shorter one holds (branch_trunk at 139.5°, 0.2 m:
        // LH 0.21 m behind RH from 13 s, its level steps too near LF or
        // leaving RH 10–13 mm short of its grip, until the time ran out).
        //
        // Tail first down a branch to the goal's trunk (the hind limbs lead
        // onto it; no transfer begun yet), a hind limb behind its partner by
        // more than a minimum step may close up part way as well while the
        // search is failing: the hind girdle then takes the trunk level. The
        // transfer step of the limb behind had split it by 0.13 m, which grew
        // to 0.20 m down the trunk, where the fore girdle trailed split the
        // other way and no limb could land level with its partner (the level
        // grips out of reach or too near the same side's fore grip, those
        // behind barred here): branch_trunk at 74.5° and 75.5°, 0.2 m,
        // stopped `no_grip` on the trunk 1.15 m from the goal.
        let cur_lead = (p.cur - opp).dot(p.travel);
        let failing_hind = !limb.is_fore() && self.failed_searches > 0;
        let girdle_locked = failing_hind
            && -cur_lead > cfg.max_girdle_lead * cfg.max_step_m - cfg.min_step_m
            && self.approach_trunk(env).is_some();
        let tail_first_closing = failing_hind
            && self.dir < 0.0
            && self.transfer.is_none()
            && -cur_lead > cfg.min_step_m
            && self.approach_trunk(env).is_some();
        // Goal mode, a sloth whose back-offs without it would not arrive
        // (`Sloth::close_up`, chosen by the playouts), no transfer under
        // way, the search failing: a hind limb behind its partner by more
        // than a minimum step may close up part way too (trunk → branch at
        // 0.08 m, around 143.9° and 153.2°: on the branch RH 0.13–0.21 m
        // behind LH, its level grips out of reach or too near RF, every
        // other limb's step barred, six back-offs to the time limit). For
        // every goal-mode sloth, or after any re-plan, the rule changed
        // transfers the back-offs alone carry through (to-branch 0.15 m
        // 153.354°, 0.08 m 146.4577°).
        // (Only goal-mode back-offs set `close_up`.)
        let failing_closing =
            self.close_up && failing_hind && self.transfer.is_none() && -cur_lead > cfg.min_step_m;
        let min_lead = if cur_lead < -(cfg.max_step_m - cfg.min_step_m)
            || girdle_locked
            || tail_first_closing
            || failing_closing
        {
            cur_lead + cfg.min_step_m
        } else {
            0.0
        };
        match p.side_step {
            // Side-stepping, the girdle's limbs keep about level on the axis
            // (around it, the pair is always apart by the grip angle).
            Some(ss) => {
                (approx - opp).dot(ss.axis_up).abs() <= cfg.max_girdle_lead * cfg.max_step_m
            }
            None => {
                p.transfer_step || (min_lead..=cfg.max_girdle_lead * cfg.max_step_m).contains(&lead)
            }
        }
    }

    /// Stage 4: head up across a branch → trunk transfer (SPEC
    /// `transfer_to_trunk`): a fore limb takes the trunk (and steps on it
    /// while the hind limbs are on the branch) at least
    /// [`crate::LocomotionConfig::head_up_margin_m`] above the hind grips, and
    /// the hind limbs on the branch keep that far below the fore limbs on the
    /// trunk (their mean height).
    fn keeps_head_up(&self, env: &LocoView<'_>, p: &Placement) -> bool {
        let (limb, approx, a) = (p.limb, p.grip, p.axis);
        let margin = env.cfg.head_up_margin_m;
        let axis_up = if a.tangent.y >= 0.0 {
            a.tangent
        } else {
            -a.tangent
        };
        if p.transfer.is_some_and(|t| t.dir < 0.0)
            && !limb.is_fore()
            && p.kind == SupportKind::Trunk
        {
            // Tail first (`Sloth::descends_tail_first`): a hind limb takes
            // the trunk (and steps down it) at least the margin below the
            // fore grips.
            let fore_bottom = [Limb::LF, Limb::RF]
                .map(|f| self.limbs[f.index()].grip.point.dot(axis_up))
                .into_iter()
                .fold(f32::INFINITY, f32::min);
            if approx.dot(axis_up) > fore_bottom - margin {
                return false;
            }
        } else if p.transfer.is_some() && limb.is_fore() && p.kind == SupportKind::Trunk {
            let hind_top = [Limb::LH, Limb::RH]
                .map(|h| self.limbs[h.index()].grip.point.dot(axis_up))
                .into_iter()
                .fold(f32::NEG_INFINITY, f32::max);
            if approx.dot(axis_up) < hind_top + margin {
                return false;
            }
        } else if self.transfer.is_some_and(|t| t.to == t.trunk)
            && !limb.is_fore()
            && p.kind != SupportKind::Trunk
        {
            // …and the hind limbs, still on the branch, stay that far below
            // the fore limbs on the trunk (stepping up a branch to a trunk
            // grip at branch height, the hips rose above the head: 1,453
            // sloth-frames in a 2,000-sloth run): below the mean height of
            // the fore grips on the trunk (the shoulders' there), not the
            // lower one. Against the lower one a fore grip taken just the
            // margin above the hind grips locked the stance: the hind
            // limbs could not step up a branch rising to the trunk, the
            // trunk lay just beyond a transfer step (0.42 m against 0.405 m)
            // and the fore limbs stood at the transfer's spread cap
            // (branch_trunk at 114.5°, 0.2 m: RF 5 cm above the hind grips,
            // LF 17 cm; for 70 s). Goal mode only: a wanderer keeps below
            // the lower fore grip (it may turn back and take another way;
            // with the mean, 5,000 × 300 s crowds ended with more stuck
            // sloths at each of three seeds: 32 / 35 / 36 → 40 / 36 / 45).
            let fore_on_trunk = [Limb::LF, Limb::RF]
                .map(|f| self.limbs[f.index()].grip)
                .into_iter()
                .filter(|g| env.scene().support(g.support).kind == SupportKind::Trunk)
                .map(|g| g.point.y);
            let ceiling = if self.wander {
                fore_on_trunk.reduce(f32::min)
            } else {
                let (sum, count) =
                    fore_on_trunk.fold((0.0f32, 0u8), |(sum, count), y| (sum + y, count + 1));
                (count > 0).then(|| sum / f32::from(count))
            };
            if ceiling.is_some_and(|y| approx.y > y - margin) {
                return false;
            }
        }
        true
    }

    /// Stage 5: the grip (and the hind pair's partner's) within another
    /// sloth's clearance (their bodies and grips of the previous tick). A
    /// wanderer's grip may step away from points whose clearance its grip
    /// is already within ([`Sloth::crowd_blocked`]).
    fn crowded(&self, env: &LocoView<'_>, p: &Placement) -> bool {
        self.crowd_blocked(env, p.cur, p.grip)
            || p.pair
                .is_some_and(|(pi, p2, _)| self.crowd_blocked(env, self.limbs[pi].grip.point, p2))
    }

    /// Whether a grip moving from `from` to `to` comes within another
    /// sloth's clearance. Goal mode: any point of theirs within it blocks
    /// ([`CrowdGrid::blocked`]). A wanderer: only those `to` is no farther
    /// from than `from` ([`CrowdGrid::blocked_from`]), so a grip already
    /// within their clearance (a sloth behind it walked in: traced in the
    /// 5,000 × 300 s crowd, a follower's head 2–8 cm from a stopped
    /// sloth's body) may step away from them, never toward them.
    pub(super) fn crowd_blocked(&self, env: &LocoView<'_>, from: Vec3, to: Vec3) -> bool {
        env.crowd.is_some_and(|g| {
            if self.wander {
                g.blocked_from(self.id, from, to)
            } else {
                g.blocked(self.id, to)
            }
        })
    }

    /// Stage 6: the reach checks ([`Sloth::step_reachable`]; the hind pair's
    /// with the largest offset back that holds), counted in `checks`. A plain
    /// step that holds only with the limb lifting off next in the air
    /// commits that limb's step where `at` allows it; a hind step past the
    /// grip of fore limb `passed_fore` only with that limb's committed step,
    /// landing ahead of it. The hind pair's share of the offset back and the
    /// committed step, if the step passes.
    fn reach_at(
        &self,
        env: &LocoView<'_>,
        at: &CandidateAt,
        p: &Placement,
        passed_fore: Option<usize>,
        checks: &mut u32,
    ) -> Option<(f32, Option<(u8, Grip)>)> {
        let (li, sid) = (at.limb, at.support);
        *checks += 1;
        let mut back_scale = 0.0;
        let reachable = passed_fore.is_none()
            && match p.pair {
                Some((pi, p2, out2)) => {
                    match self.pair_back_scale(env, &[(li, p.grip, p.out), (pi, p2, out2)], sid) {
                        Some(k) => {
                            back_scale = k;
                            true
                        }
                        None => false,
                    }
                }
                None => self.step_reachable(env, li, p.grip, p.out, sid),
            };
        // Held only with the next limb to lift off in the air by the
        // landing: a plain step commits that limb's step.
        let lift = if !reachable && at.may_commit_lift && self.is_plain(at, p) {
            self.planned_lift(env, li, p.grip_at(at), checks)
        } else {
            None
        };
        // Past a fore grip: that fore limb's committed step lands ahead.
        let proj = |v: Vec3| v.dot(p.body_fwd);
        let lift = lift.filter(|(lj, to)| {
            passed_fore.is_none_or(|pf| {
                pf == *lj as usize && proj(to.point) >= proj(p.grip) + env.cfg.leg_order_margin_m
            })
        });
        if !reachable && lift.is_none() {
            return None;
        }
        Some((back_scale, lift))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::path::axis_at;
    use crate::sloth::test_util::{walk_presets, xorshift};

    /// [`Sloth::surely_too_far`] against the placement it spares: on every
    /// preset, for sloths walking (transfers included) and with their grips
    /// moved at random, every candidate every 5 mm along every support, both
    /// ways, for each limb: a candidate the bound rejects fails the step
    /// length of the full placement (so `candidate` answers the same), and
    /// the bound rejects most of those that fail it.
    #[test]
    fn surely_too_far_rejects_only_steps_too_long() {
        let mut rnd = xorshift(0x5107);
        let (mut rejected, mut too_long, mut kept) = (0u64, 0u64, 0u64);
        walk_presets(30, |kind, view, frame, sloth| {
            for moved in [false, true] {
                let mut probe = sloth;
                if moved {
                    for l in &mut probe.limbs {
                        let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
                        l.grip.point += d * 0.6;
                    }
                }
                for li in 0..4 {
                    for (sid, sup) in view.scene().supports().iter().enumerate() {
                        let support = SupportId(sid as u32);
                        let len = sup.length();
                        let mut u = 0.0;
                        while u <= len {
                            for sdir in [1.0, -1.0] {
                                let at = CandidateAt {
                                    limb: li,
                                    support,
                                    u,
                                    sdir,
                                    retreat: false,
                                    may_commit_lift: true,
                                };
                                let a = axis_at(sup, u);
                                let p = probe.place(view, &at, a);
                                let long = p.grip.distance(p.cur) > p.max_step;
                                if probe.surely_too_far(view, &at, &a) {
                                    assert!(
                                        long && !probe.step_in_range(view, &at, &p),
                                        "{} frame {frame} limb {li} support {sid} u {u}: \
                                             rejected a step of {} m (longest {} m)",
                                        kind.name(),
                                        p.grip.distance(p.cur),
                                        p.max_step
                                    );
                                    rejected += 1;
                                } else if long {
                                    too_long += 1;
                                } else {
                                    kept += 1;
                                }
                            }
                            u += 0.005;
                        }
                    }
                }
            }
        });
        println!("rejected early {rejected}, too long but placed {too_long}, in range {kept}");
        assert!(rejected > 10 * too_long, "{rejected} vs {too_long}");
        assert!(kept > 1000, "{kept}");
    }

    /// The lookahead's range scan farthest first, as it was: every arc length
    /// from `next_u` back to `last_u`, the first candidate that passes.
    fn range_has_step_farthest_first(
        sloth: &Sloth,
        env: &LocoView<'_>,
        li: usize,
        sr: &Search,
    ) -> bool {
        let len = env.scene().support(sr.support).length();
        let mut u = sr.next_u;
        while (u - sr.last_u) * sr.sdir >= -1e-6 {
            if (env.cfg.end_margin_m..=len - env.cfg.end_margin_m).contains(&u)
                && sloth
                    .candidate(env, &CandidateAt::probe(li, sr, u), &mut 0)
                    .is_some()
            {
                return true;
            }
            u -= sr.sdir * 0.02;
        }
        false
    }

    /// [`Sloth::range_has_step`] (nearest first) answers as the farthest-first
    /// scan on every preset, for sloths walking and with their grips and body
    /// moved at random, each limb's own range and every neighbour's.
    #[test]
    fn range_has_step_nearest_first_matches_farthest_first() {
        let mut rnd = xorshift(0xa11);
        let (mut yes, mut no) = (0u32, 0u32);
        walk_presets(15, |kind, view, frame, sloth| {
            for moved in [0.0, 0.05, 0.2] {
                let mut probe = sloth;
                for l in &mut probe.limbs {
                    let d = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5);
                    l.grip.point += d * moved;
                }
                probe.body_pos += Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * moved;
                for li in 0..4 {
                    let g = probe.limbs[li].grip;
                    let mut ranges = vec![probe.own_search(view, li)];
                    for &sid in view.adjacency.neighbours(g.support) {
                        ranges.extend(probe.neighbour_search(view, li, sid, 0));
                    }
                    // Each also stretched over 3 m back: longer than
                    // the nearest-first buffer (the farthest-first path).
                    let stretched: Vec<Search> = ranges
                        .iter()
                        .map(|sr| Search {
                            last_u: sr.next_u - sr.sdir * 3.0,
                            ..*sr
                        })
                        .collect();
                    for sr in ranges.iter().chain(&stretched) {
                        let want = range_has_step_farthest_first(&probe, view, li, sr);
                        assert_eq!(
                            probe.range_has_step(view, li, sr),
                            want,
                            "{} frame {frame} limb {li} moved {moved}",
                            kind.name()
                        );
                        if want {
                            yes += 1;
                        } else {
                            no += 1;
                        }
                    }
                }
            }
        });
        println!("{yes} ranges with a step, {no} without");
        assert!(yes > 500 && no > 500, "{yes} {no}");
    }
}
