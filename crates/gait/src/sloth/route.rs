//! Where a limb searches (thesis §3.3: "the model stops, turns back or
//! changes branch"; `Find Side Step`; SPEC "Step search" item 6 and
//! "Trunks and transitions"): the range on its own support, neighbour
//! supports, the goal's branch first, retreats, wander-mode route choices,
//! side steps around a trunk and the travel direction on a new support.

use glam::Vec3;
use slothsim_rig::Limb;
use slothsim_scene::{SupportId, SupportKind};

use crate::path::project;

use super::{Grip, LocoView, Search, Sloth, mix64};

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

/// `transfer_to_branch`'s approach: the body faces the trunk from this far
/// around its surface from the goal's branch (metres; 60°, the side a
/// branch → trunk transfer ends on, at the default 0.15 m radius) ...
const APPROACH_ARC_M: f32 = 0.15 * std::f32::consts::FRAC_PI_3;

/// ... and at most this far around (radians): on thinner trunks the body
/// side-steps only toward the branch, never away from it.
const APPROACH_MAX_ANGLE: f32 = std::f32::consts::FRAC_PI_3;

/// The angle around a trunk of `radius` (metres) from the goal's branch that
/// the body climbs to it from (`transfer_to_branch`'s approach): the same
/// surface distance from the branch as on the default trunk, at most 60°.
/// Measured by the start's side on `branch_trunk --variant to-branch` at 2°
/// steps: at 0.2 m, 60° passes 60–72° only (the fore limbs climb past the
/// junction), 45–52° pass 60–108°. At 0.08 m, 71–90° pass more angles than
/// 60°, but a hind grip slipped 5–24 mm as the hang roll ended at angles
/// that pass at 60° (docs/locomotion.md): hence the cap.
pub(super) fn approach_angle(radius: f32) -> f32 {
    (APPROACH_ARC_M / radius.max(1e-3)).min(APPROACH_MAX_ANGLE)
}

/// A side step may lose this much height along the axis (metres).
pub(super) const SIDE_STEP_AXIAL_SLACK: f32 = 0.02;

/// A side step around a trunk (see [`Sloth::side_step`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct SideStep {
    /// Signed turn about `axis_up` of the side the step's grip is placed around (radians).
    pub(super) turn: f32,
    /// The trunk's axis, pointing up.
    pub(super) axis_up: Vec3,
    /// Unit direction from the axis to the body now.
    pub(super) side_now: Vec3,
    /// The goal's height along `axis_up` relative to the body's (metres).
    axial_to_goal: f32,
}

/// The step search of a limb holding `g`, on its own support: from one
/// search distance ahead back to the grip.
pub(super) fn search_ahead(env: &LocoView<'_>, g: Grip) -> Search {
    Search {
        support: g.support,
        sdir: g.sdir,
        first_u: g.u + g.sdir * env.cfg.search_distance_m,
        next_u: g.u + g.sdir * env.cfg.search_distance_m,
        last_u: g.u,
        neighbour: u16::MAX,
        retreat: false,
        goal_first: false,
    }
}

/// Goal mode: the lone fore limb across a locked transfer onto a trunk is
/// judged by steps (`Sloth::own_search`) only from its `LONE_FORE_WAIT`-th
/// locked step search to before its `LONE_FORE_END`-th, counted on the sloth
/// across transfers ended and begun again. Before: its partner's moves
/// unlock the stance within four searches in some cases (branch_trunk 0.2 m
/// 137.5°), and a step back along the trunk taken first locked it again, to
/// the time limit. After: a late step back along the trunk broke stances
/// that main's moves unlock late (0.15 m 152°, 0.2 m 124.4°). Branch `bt13`,
/// docs/scenarios.md.
const LONE_FORE_WAIT: u8 = 5;
const LONE_FORE_END: u8 = 11;

/// Goal mode, the lone-fore lock: a limb on the branch searching there
/// prefers its farthest step from which the footfall order's next steps,
/// played out on a copy of the sloth (at most this many after it: with it,
/// three gait cycles), give the partner of the lone fore limb a step onto
/// the trunk (`Sloth::lone_fore_unlocking_u`). A one-step lookahead sees
/// no such step where main unlocks after a sequence (docs/scenarios.md,
/// branch `lone27`; two cycles gave the same matrix).
const LONE_FORE_PLAYOUT: usize = 11;

/// The arc-length stride of that lookahead's candidates (metres; the
/// step lookahead's).
const LONE_FORE_PLAYOUT_STRIDE: f32 = 0.02;

impl Sloth {
    /// The search of limb `li` on the support it holds: from the search
    /// distance ahead of its grip back to the grip. Side-stepping around a
    /// trunk, the range goes toward the goal's height and no farther, down
    /// to a step at the grip's own height.
    pub(super) fn own_search(&self, env: &LocoView<'_>, li: usize) -> Search {
        let g = self.limbs[li].grip;
        let mut search = search_ahead(env, g);
        // Undoing a transfer (turned back with the trailing limbs on its
        // target): no steps along the target; the limb goes back to the
        // support the leading limbs hold (see `next_neighbour`). Unless no
        // step onto that support passes its checks (judged as the lookahead
        // judges one): then it steps back along the target toward it (its
        // travel sign turned with the sloth's), so that a transfer locked
        // half way can be undone (crowds: fore limbs high on a trunk, hind
        // limbs on the branch out of their reach, sat there turning back and
        // forth: `transfer_failed`). The root distance alone passed there —
        // the branch's root runs within reach of a fore limb's root — while
        // every grip on it was more than a step below the fore claws.
        // Wanderers only: a goal-mode back-off is one gait cycle, then it
        // plans from where it stands (judged by steps, it gained
        // branch_trunk at 0.15 m 148.5° and lost 0.2 m 103.5°).
        let undoing = |t: &super::Transfer| {
            t.to == g.support
                && !self.leads(Limb::ALL[li])
                && Limb::ALL
                    .iter()
                    .all(|&l| !self.leads(l) || self.limbs[l.index()].grip.support != t.to)
        };
        // Goal mode, a head-first transfer onto a trunk with one fore limb
        // across and its partner without a step onto the trunk (the stance
        // locked half way): that fore limb is judged by steps as well, so
        // with no step back to the branch it steps back along the trunk
        // (issue 24: its branch candidates were all too far, and the
        // back-off moved only its partner, back and forth on the branch).
        // Only within a bounded window of its locked searches (see
        // `LONE_FORE_WAIT`).
        let by_steps = || {
            self.wander
                || ((LONE_FORE_WAIT..LONE_FORE_END).contains(&self.lone_fore_searches)
                    && self.lone_fore_locked(env, li))
        };
        let lead_in_reach = || {
            let by_steps = by_steps();
            Limb::ALL.iter().any(|&l| {
                self.leads(l)
                    && self
                        .neighbour_search(env, li, self.limbs[l.index()].grip.support, 0)
                        .is_some_and(|sr| !by_steps || self.range_has_step(env, li, &sr))
            })
        };
        if self.transfer.is_some_and(|t| undoing(&t)) && lead_in_reach() {
            search.next_u = g.u - g.sdir;
            search.first_u = search.next_u;
            return search;
        }
        if let Some(ss) = self.side_step(env, g.support) {
            let sdir = if ss.axial_to_goal >= 0.0 { 1.0 } else { -1.0 };
            let ahead = ss.axial_to_goal.abs().min(env.cfg.search_distance_m);
            search.sdir = sdir;
            search.first_u = g.u + sdir * ahead;
            search.next_u = search.first_u;
            search.last_u = g.u - sdir * SIDE_STEP_AXIAL_SLACK;
        }
        search
    }

    /// Where limb `li` is the one fore limb across a head-first transfer
    /// onto a trunk (its partner still on another support): the transfer and
    /// the partner's index.
    fn lone_fore_across(&self, li: usize) -> Option<(super::Transfer, usize)> {
        let limb = Limb::ALL[li];
        let t = self.transfer?;
        let partner = limb.opposite().index();
        (limb.is_fore()
            && t.to == t.trunk
            && t.dir > 0.0
            && self.limbs[li].grip.support == t.trunk
            && self.limbs[partner].grip.support != t.trunk)
            .then_some((t, partner))
    }

    /// [`Self::lone_fore_across`], and its partner, travelling toward the
    /// goal again, would have no step onto the trunk either: the stance the
    /// back-off cannot undo from the branch side.
    pub(super) fn lone_fore_locked(&self, env: &LocoView<'_>, li: usize) -> bool {
        let Some((t, partner)) = self.lone_fore_across(li) else {
            return false;
        };
        let mut probe = *self;
        if probe.dir != t.dir {
            probe.dir = t.dir;
            for l in &mut probe.limbs {
                l.grip.sdir = -l.grip.sdir;
            }
        }
        probe.backoff = None;
        !probe
            .neighbour_search(env, partner, t.trunk, 0)
            .is_some_and(|sr| probe.range_has_step(env, partner, &sr))
    }

    /// Goal mode, the lone-fore lock ([`Self::lone_fore_locked`]) going
    /// round a circle (the transfer's livelock watch has seen one of its
    /// stances again, [`super::Transfer::circling`]), outside a back-off:
    /// the transfer's side turns toward the partner where a turn within the
    /// transfer's bound gives it a step onto the trunk and the stance holds
    /// ([`Self::turned_transfer_side`], the re-plan's turn). The re-plan
    /// makes that turn only with no limb in the air, and the watch's
    /// give-up comes at a step's landing, with the next limb swinging:
    /// branch_trunk 0.2 m 124.5°, LF alone on the trunk from 18 s, the
    /// turn of 30° ready at every search, refused at both give-ups (51.8 s,
    /// 85.4 s), the circle to the time limit. Made while a limb swung, the
    /// body jumped 18 mm into the trunk. A lock that does not circle is
    /// left to the steps (turned at its first search, 0.2 m 137.5°, 155.5°,
    /// 156°, 0.15 m 151° were lost: main's own steps unlock those).
    pub(super) fn turn_side_in_lone_lock(&mut self, env: &LocoView<'_>) {
        if self.wander || self.backoff.is_some() || !self.transfer.is_some_and(|t| t.circling()) {
            return;
        }
        let locked = [Limb::LF.index(), Limb::RF.index()]
            .into_iter()
            .any(|f| self.lone_fore_locked(env, f));
        if locked && let Some(tr) = self.turned_transfer_side(env) {
            self.transfer = Some(tr);
        }
    }

    /// Goal mode, the lone-fore lock (a fore limb alone across a head-first
    /// transfer onto a trunk, its partner with no step onto it: see
    /// [`Self::lone_fore_locked`]): the farthest arc length in the range
    /// `sr` of limb `li` (on the branch) whose step, passing the lookahead's
    /// checks, unlocks the stance within [`LONE_FORE_PLAYOUT`] steps of the
    /// footfall order played out on a copy of the sloth
    /// ([`Self::playout_unlocks`]). `None` where the stance is not so
    /// locked, or no step of the range unlocks it that way (the search is
    /// left as it is). The farthest step that unlocks is the search's own
    /// where its farthest does.
    pub(super) fn lone_fore_unlocking_u(
        &self,
        env: &LocoView<'_>,
        li: usize,
        sr: &Search,
    ) -> Option<f32> {
        if self.wander || sr.retreat {
            return None;
        }
        let (lone, t, partner) =
            [Limb::LF.index(), Limb::RF.index()]
                .into_iter()
                .find_map(|f| {
                    self.lone_fore_across(f)
                        .filter(|_| self.lone_fore_locked(env, f))
                        .map(|(t, p)| (f, t, p))
                })?;
        if li == lone || self.limbs[li].grip.support == t.trunk {
            return None;
        }
        self.probe_steps(env, li, sr)
            .find(|&grip| {
                // Played out facing the goal (a back-off's step too: the
                // back-off ends within a cycle).
                let mut next = self.after_steps(env, [(li, grip)]);
                if next.dir != t.dir {
                    next.dir = t.dir;
                    for l in &mut next.limbs {
                        l.grip.sdir = -l.grip.sdir;
                    }
                }
                next.backoff = None;
                next.partner_has_trunk_step(env, t, partner)
                    || next.playout_unlocks(env, li, t, partner)
            })
            .map(|grip| grip.u)
    }

    /// The steps of limb `lj` in the range `sr` the lookahead's checks pass
    /// (no traces), farthest first, every [`LONE_FORE_PLAYOUT_STRIDE`].
    fn probe_steps<'a>(
        &'a self,
        env: &'a LocoView<'_>,
        lj: usize,
        sr: &'a Search,
    ) -> impl Iterator<Item = Grip> + 'a {
        let len = env.scene().support(sr.support).length();
        let ends = env.cfg.end_margin_m..=len - env.cfg.end_margin_m;
        std::iter::successors(Some(sr.next_u), move |u| {
            Some(u - sr.sdir * LONE_FORE_PLAYOUT_STRIDE)
        })
        .take_while(move |u| (u - sr.last_u) * sr.sdir >= -1e-6)
        .filter(move |u| ends.contains(u))
        .filter_map(move |at| {
            let at_probe = super::candidate::CandidateAt::probe(lj, sr, at);
            let (_, c) = self.candidate(env, &at_probe, &mut 0)?;
            Some(Grip {
                point: c.point,
                normal: c.out,
                support: sr.support,
                u: at,
                sdir: sr.sdir,
            })
        })
    }

    /// Goal mode, head first onto a trunk: limb `li` would be the first
    /// fore limb to take it (range `sr` on `sid`), and after its farthest
    /// step there (the lookahead's checks) the partner would have no step
    /// onto the trunk, nor would the footfall order's next steps played out
    /// give it one ([`Self::playout_unlocks`]): the step would enter the
    /// lone-fore lock ([`Self::lone_fore_locked`]). The trunk is then
    /// passed by (`Sloth::next_neighbour`: the limb's search goes on to the
    /// next neighbour, a retreat, or fails), and the limbs walk on along the
    /// branch toward the junction. branch_trunk 0.2 m 159.5°: RF took the
    /// trunk at 8.3 s across 0.38 m, 1 m below the junction on a branch
    /// 20.5° off the trunk, LF's trunk grips 0.56–0.62 m away to the time
    /// limit; now RF takes it at 23.2 s from 0.16 m, LF follows, and the
    /// sloth arrives at 57.9 s (docs/scenarios.md, branch `lone32`).
    ///
    /// Only where a search has failed since the last step taken
    /// (`Sloth::failed_searches` > 0); with none failed, the trunk step is
    /// taken as before. branch_trunk 0.2 m 129.8°: the step was passed by
    /// once at 30.1 s, right after a step (no search failed), and no later
    /// stance had a trunk step before 97 s (back-offs round and round); now
    /// RF takes it and the sloth arrives at 63.5 s, as before the rule
    /// (docs/scenarios.md, branch `lone34`).
    fn first_fore_strands_partner(
        &self,
        env: &LocoView<'_>,
        li: usize,
        sid: SupportId,
        sr: &Search,
    ) -> bool {
        let limb = Limb::ALL[li];
        let Some(t) = self.transfer else {
            return false;
        };
        if self.wander
            || !limb.is_fore()
            || self.backoff.is_some()
            || sid != t.trunk
            || t.to != t.trunk
            || t.dir < 0.0
            || self.dir != t.dir
            // Only where a search has failed since the last step taken:
            // with none failed the trunk step is taken as before the rule.
            || self.failed_searches == 0
        {
            return false;
        }
        let partner = limb.opposite().index();
        if self.limbs[partner].grip.support == t.trunk {
            return false;
        }
        let Some(grip) = self.probe_steps(env, li, sr).next() else {
            return false;
        };
        let next = self.after_steps(env, [(li, grip)]);
        !(next.partner_has_trunk_step(env, t, partner) || next.playout_unlocks(env, li, t, partner))
    }

    /// Whether the fore limb `partner` has a step onto the transfer's trunk.
    fn partner_has_trunk_step(
        &self,
        env: &LocoView<'_>,
        t: super::Transfer,
        partner: usize,
    ) -> bool {
        self.neighbour_search(env, partner, t.trunk, 0)
            .is_some_and(|s| self.range_has_step(env, partner, &s))
    }

    /// The steps of the footfall order after limb `li`'s (which this copy
    /// has taken), up to [`LONE_FORE_PLAYOUT`], played out on a copy: each
    /// limb takes the farthest step the lookahead's checks pass on its own
    /// support or a neighbour it may follow onto (none: it stays; a full
    /// cycle of none ends the play). Whether the partner takes the trunk or
    /// is left a step onto it on the way.
    fn playout_unlocks(
        &self,
        env: &LocoView<'_>,
        li: usize,
        t: super::Transfer,
        partner: usize,
    ) -> bool {
        let order = super::search::footfall_order_from(env, li);
        let mut sim = *self;
        let mut idle = 0;
        for k in 1..=LONE_FORE_PLAYOUT {
            let lj = order[k % 4];
            if let Some(grip) = sim.farthest_probe_step(env, lj) {
                if lj == partner && grip.support == t.trunk {
                    return true;
                }
                sim = sim.after_steps(env, [(lj, grip)]);
                idle = 0;
            } else {
                idle += 1;
                if idle >= 4 {
                    return false;
                }
            }
            if sim.partner_has_trunk_step(env, t, partner) {
                return true;
            }
        }
        false
    }

    /// The farthest step of limb `lj` the lookahead's checks pass (no
    /// traces; every [`LONE_FORE_PLAYOUT_STRIDE`]): on its own support, else
    /// a neighbour it may follow onto.
    fn farthest_probe_step(&self, env: &LocoView<'_>, lj: usize) -> Option<Grip> {
        let scan = |sr: &Search| self.probe_steps(env, lj, sr).next();
        let g = self.limbs[lj].grip;
        scan(&self.own_search(env, lj)).or_else(|| {
            env.adjacency.neighbours(g.support).iter().find_map(|&sid| {
                if !self.may_follow(env, lj, sid) {
                    return None;
                }
                self.neighbour_search(env, lj, sid, 0)
                    .and_then(|sr| scan(&sr))
            })
        })
    }

    /// The candidate range of limb `li` on neighbour support `sid`, if its
    /// surface comes within reach of the limb's root.
    pub(super) fn neighbour_search(
        &self,
        env: &LocoView<'_>,
        li: usize,
        sid: SupportId,
        k: u16,
    ) -> Option<Search> {
        let s2 = env.scene().support(sid);
        let cur = self.limbs[li].grip;
        let root = self.limbs[li].root;
        let entry = project(s2, (cur.point + root) * 0.5);
        // A step onto the goal's support (goal mode) by a limb following the
        // leading ones, or by a leading limb climbed level with the end of
        // that support nearest it, is judged by its reach checks alone: on a
        // 0.2 m trunk the fore limbs climbed past the goal's branch without
        // searching it (trunk_branch passed at no angle), and hind limbs
        // stepping one at a time onto it (see `replan.rs`) start low. Lower
        // down, a fore limb taking a branch that falls away toward it left
        // the hind limbs out of reach below (trunk_branch at 140°).
        // transfer_to_branch's hind pair is judged by its reach check at the
        // stance after the step (with the hindquarters' offset back): before
        // the pair moves, the hips low on the trunk are seldom within reach
        // of a branch that falls away from the junction (trunk_branch at
        // 110°–130° stopped there).
        if self.hind_pair(li, sid).is_none()
            && !self.reach_decides(env, li, sid)
            && entry.point.distance(root) - entry.radius > env.rig.reach
        {
            return None;
        }
        let sdir = self.choose_sdir(env, sid, entry.tangent);
        // transfer_to_branch: the hind pair's trace is capped (thesis: 10 cm)
        // so the feet take the branch close to the trunk, under the body.
        let reach_u = if self.hind_pair(li, sid).is_some() {
            env.cfg.hind_transfer_trace_cap_m
        } else {
            env.cfg.search_distance_m
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

    /// A leading limb on a trunk whose goal is on a branch leaving it tries
    /// that branch first (`transfer_to_branch`): a branch ends at its trunk,
    /// so a limb on a branch reaches the trunk once the branch is exhausted,
    /// but a trunk goes on past the branch, and climbing it would never end.
    /// `None` when the branch is out of reach: the limb climbs the trunk.
    pub(super) fn goal_branch_search(&mut self, env: &LocoView<'_>, li: usize) -> Option<Search> {
        let cur = self.limbs[li].grip.support;
        let gs = if self.wander {
            self.wander_branch(env, li, cur)?
        } else {
            self.goal?.0
        };
        let scene = env.scene();
        let neighbours = env.adjacency.neighbours(cur);
        if !self.leads(Limb::ALL[li])
            || scene.support(cur).kind != SupportKind::Trunk
            || scene.support(gs).kind != SupportKind::Branch
            || !neighbours.contains(&gs)
        {
            return None;
        }
        let transfer = self.transfer;
        if !self.begin_transfer(env, li, cur, gs) {
            return None;
        }
        // Neighbours count as tried: once the branch is exhausted the limb
        // searches the trunk, then retreats (see `queue_candidates`).
        let tried = u16::try_from(neighbours.len()).unwrap_or(u16::MAX - 1);
        let search = self.neighbour_search(env, li, gs, tried).map(|sr| Search {
            goal_first: true,
            ..sr
        });
        if search.is_none() {
            self.transfer = transfer;
        }
        search
    }

    /// A stalled straddler's limb off the branch it gathers on
    /// ([`Sloth::gather_onto`]) searches that branch first, where it comes
    /// within reach, then as before (its own support, its neighbours, a
    /// retreat).
    pub(super) fn gather_search(&self, env: &LocoView<'_>, li: usize) -> Option<Search> {
        let sid = self.gather_onto(env)?;
        if sid == self.limbs[li].grip.support {
            return None;
        }
        self.neighbour_search(env, li, sid, 0).map(|sr| Search {
            goal_first: true,
            ..sr
        })
    }

    /// Wander mode: a branch to leave trunk `trunk` for, tried before the
    /// trunk by a fore limb climbing past it (head first, no transfer under
    /// way): a neighbouring branch rising from the trunk (its first metres at
    /// least [`WANDER_MIN_RISE_SIN`] uphill: trunk → branch holds there), taken
    /// or passed by this sloth's own choice.
    fn wander_branch(&self, env: &LocoView<'_>, li: usize, trunk: SupportId) -> Option<SupportId> {
        let scene = env.scene();
        if self.dir <= 0.0
            || self.transfer.is_some()
            || scene.support(trunk).kind != SupportKind::Trunk
        {
            return None;
        }
        let grip = self.limbs[li].grip.point;
        env.adjacency.neighbours(trunk).iter().copied().find(|&b| {
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

    /// Sets up the search on the next admissible neighbour support. False when none is left.
    pub(super) fn next_neighbour(&mut self, env: &LocoView<'_>, li: usize) -> bool {
        let cur = self.limbs[li].grip;
        let neighbours = if self.keeps_to(cur.support) {
            &[]
        } else {
            env.adjacency.neighbours(cur.support)
        };
        let mut k = match self.limbs[li].search.neighbour {
            u16::MAX => 0usize,
            n => n as usize,
        };
        // Wander mode: neighbours in an order of this sloth's own (the same
        // for all its limbs at this support, so they pick the same one).
        let rotate = if self.wander && !neighbours.is_empty() {
            (mix64(self.seed ^ mix64(cur.support.0 as u64 ^ ((self.turns as u64) << 32)))
                % neighbours.len() as u64) as usize
        } else {
            0
        };
        let transfer_before = self.transfer;
        while k < neighbours.len() {
            let sid = neighbours[(k + rotate) % neighbours.len()];
            k += 1;
            let scene = env.scene();
            if self.wander
                && scene.support(sid).kind != scene.support(cur.support).kind
                && !self.may_wander_across(env, cur.support, sid)
            {
                continue;
            }
            if !self.may_follow(env, li, sid) {
                continue;
            }
            // A branch ↔ trunk change: the transfer (and its side) is set up
            // first, as the search on the new support depends on it.
            if scene.support(sid).kind != scene.support(cur.support).kind
                && !self.begin_transfer(env, li, cur.support, sid)
            {
                continue;
            }
            if let Some(search) = self.neighbour_search(env, li, sid, k as u16) {
                // Goal mode: not the first fore step onto a trunk its
                // partner could not follow (the lone-fore lock).
                if self.first_fore_strands_partner(env, li, sid, &search) {
                    self.transfer = transfer_before;
                    continue;
                }
                self.limbs[li].search = search;
                return true;
            }
        }
        self.limbs[li].search.neighbour = k as u16;
        false
    }

    /// Whether limb `li` may step onto neighbour support `sid` of the one
    /// it holds. The leading limbs (fore head first, hind tail first)
    /// change support first; the others follow onto a support a leading
    /// limb holds, and leave theirs only when no leading limb is on it.
    /// A wanderer's leading limbs split across a fork of two branches (one
    /// on each) hold both ways on: once its search has failed, a trailing
    /// limb on one of them may follow the other leading limb onto the other
    /// branch, if that branch holds at least as many of its limbs (the limbs
    /// gather on one branch, never spread further). Traced from main's
    /// 280 s checkpoint of the 5,000 × 300 s crowd (sloth 676): the left
    /// limbs on one branch, the right ones on the other, the right fore
    /// limb out of reach of the left branch, and the right hind limb, with
    /// valid steps onto the left branch, held to its own by the right fore
    /// limb: no limb had a step either way, for minutes.
    ///
    /// No limb steps from one trunk onto another (the two stems above a
    /// fork, imported and generated trees): the body is placed beside a
    /// trunk only while both fore limbs hold the same one
    /// ([`Sloth::fore_on_trunk`]), so with the fore limbs on two trunks it
    /// would be drawn hanging as below a branch, and no transfer (branch ↔
    /// trunk) blends between the two. Traced on a `gen-trees` forest (600
    /// sloths, seed 7 trees, 128.68 s): a wanderer's fore limb lifting
    /// from a trunk onto its fork's other stem moved the body 28 cm in one
    /// frame, 50 mm into a support. At a fork a sloth turns back as at a
    /// tip.
    pub(super) fn may_follow(&self, env: &LocoView<'_>, li: usize, sid: SupportId) -> bool {
        let cur = self.limbs[li].grip.support;
        let trunk = |s: SupportId| env.scene().support(s).kind == SupportKind::Trunk;
        if sid != cur && trunk(sid) && trunk(cur) {
            return false;
        }
        let limb = Limb::ALL[li];
        if self.leads(limb) {
            return true;
        }
        let lead = if self.dir > 0.0 {
            [Limb::LF, Limb::RF]
        } else {
            [Limb::LH, Limb::RH]
        };
        let [a, b] = lead.map(|l| self.limbs[l.index()].grip.support);
        if sid != a && sid != b {
            return false;
        }
        if cur != a && cur != b {
            return true;
        }
        let branch = |s: SupportId| env.scene().support(s).kind == SupportKind::Branch;
        let held = |s: SupportId| self.limbs.iter().filter(|l| l.grip.support == s).count();
        let failing = self.failed_searches > 0 || self.stuck_cause.is_some();
        self.wander && failing && a != b && branch(a) && branch(b) && held(sid) >= held(cur)
    }

    /// Goal mode: `sid` is the goal's support.
    fn goal_support(&self, sid: SupportId) -> bool {
        !self.wander && self.goal.is_some_and(|(gs, _)| gs == sid)
    }

    /// Goal mode: whether limb `li`'s step onto the goal's support `sid` is
    /// judged by its reach checks alone (see [`Self::neighbour_search`]): a
    /// following limb's, or a leading limb's level with or above the end of
    /// that support nearest its grip.
    fn reach_decides(&self, env: &LocoView<'_>, li: usize, sid: SupportId) -> bool {
        if !self.goal_support(sid) {
            return false;
        }
        if !self.leads(Limb::ALL[li]) {
            return true;
        }
        let s = env.scene().support(sid);
        let cur = self.limbs[li].grip.point;
        let (a, b) = (s.nodes[0], s.nodes[s.nodes.len() - 1]);
        let end = if a.distance(cur) <= b.distance(cur) {
            a
        } else {
            b
        };
        cur.y >= end.y
    }

    /// Goal mode: once all four limbs hold the goal's support, the sloth
    /// keeps to it (its neighbours lead away: descending a trunk to its
    /// goal, the leading hind limbs took a branch falling away below the
    /// junction and walked out on it). Before that a limb may step back off
    /// it (a fore limb on the goal's branch back onto the trunk, to let the
    /// hind pair follow).
    pub(super) fn keeps_to(&self, sid: SupportId) -> bool {
        self.goal_support(sid) && self.grips_only(sid)
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
    fn may_wander_across(&self, env: &LocoView<'_>, from: SupportId, to: SupportId) -> bool {
        if self.transfer.is_some() {
            return true;
        }
        if self.dir <= 0.0 {
            return false;
        }
        let scene = env.scene();
        scene.support(from).kind == SupportKind::Trunk
            || (self.travel().y >= WANDER_MAX_DESCENT_SIN
                && project(scene.support(to), self.body_pos).radius <= WANDER_MAX_TRUNK_RADIUS)
    }

    /// Once no forward step is left anywhere: search backward on the current
    /// support (up to one max step behind the grip). A retreat is taken only
    /// if it leaves another limb a forward step (see [`Self::leaves_a_step`]),
    /// so it unlocks a stance in which every limb was stuck. False if this
    /// limb has already retreated in this search.
    pub(super) fn start_retreat(&mut self, env: &LocoView<'_>, li: usize) -> bool {
        let g = self.limbs[li].grip;
        let sr = self.limbs[li].search;
        // Its close-up (below) was tried: a plain retreat is left.
        let closed_up = sr.retreat && sr.support == g.support && (sr.first_u - g.u) * g.sdir > 0.0;
        if sr.retreat && !closed_up {
            return false;
        }
        // Goal mode, tail first down a trunk (the transfer done), a trailing
        // fore limb retreats only where no other limb has a forward step: a
        // retreat unlocks a stance every limb is stuck in, and where one has a
        // step the retreat only takes the fore limbs back up. branch_trunk at
        // 100.1°, 0.2 m: all four limbs on the trunk at 37.8 s, RF's search
        // failed and it retreated 0.1 m up the trunk (3.49 → 3.59 m) where
        // RH had a step down; from 52 s the limbs circled 2.8–3.6 m up to the
        // time limit (main at 100.3, 127.7, 130.3, 158.4° the same end).
        if !self.wander
            && self.dir < 0.0
            && self.transfer.is_none()
            && slothsim_rig::Limb::ALL[li].is_fore()
            && env.scene().support(g.support).kind == SupportKind::Trunk
            && (0..4).any(|lj| lj != li && self.has_step(env, lj))
        {
            return false;
        }
        let neighbour =
            u16::try_from(env.adjacency.neighbours(g.support).len()).unwrap_or(u16::MAX - 1);
        // transfer_to_branch, a hind limb below its partner on the trunk
        // while the fore limbs are across: before it retreats, it steps up
        // toward the partner, never past it (`Sloth::hind_closing`): the pair
        // lands level on the branch, and a step down parts it further. Its
        // range lies ahead of the grip (a retreat's lies behind).
        if !closed_up
            && self.hind_closing(env, li, g.support).is_some_and(|toward| {
                toward.dot(project(env.scene().support(g.support), g.point).tangent) * g.sdir > 0.0
            })
        {
            self.limbs[li].search = Search {
                support: g.support,
                sdir: g.sdir,
                first_u: g.u + g.sdir * env.cfg.search_distance_m,
                next_u: g.u + g.sdir * env.cfg.search_distance_m,
                last_u: g.u + g.sdir * env.cfg.min_step_m,
                neighbour,
                retreat: true,
                goal_first: false,
            };
            return true;
        }
        self.limbs[li].search = Search {
            support: g.support,
            sdir: g.sdir,
            first_u: g.u - g.sdir * env.cfg.min_step_m,
            next_u: g.u - g.sdir * env.cfg.min_step_m,
            last_u: g.u - g.sdir * env.cfg.max_step_m,
            // Neighbours are exhausted.
            neighbour: u16::try_from(env.adjacency.neighbours(g.support).len())
                .unwrap_or(u16::MAX - 1),
            retreat: true,
            goal_first: false,
        };
        true
    }

    /// Wander mode, at a dead end or blocked: reverse the travel direction
    /// (the same footfall order continues, tail first) and vary later route choices.
    pub(super) fn turn_back(&mut self) {
        self.dir = -self.dir;
        for l in &mut self.limbs {
            l.grip.sdir = -l.grip.sdir;
        }
        self.failed_searches = 0;
        self.turns = self.turns.wrapping_add(1);
        self.stalled_turns += 1;
        let (_, n) = self.stall_from.get_or_insert((self.body_pos, 0));
        *n = n.saturating_add(1);
    }

    /// Wander mode, the search gave up: each limb on a branch searches along
    /// it the way the body travels. A grip's travel sign along its support
    /// is set where the limb takes it (and flips with every turn back); at
    /// a fork the body's heading turns as limbs take the other branch, and
    /// wanderers stood frozen at forks with every limb's sign pointing
    /// back along the body (its support's tangent × sign · travel −0.16 to
    /// −0.37): every step was backward, in both directions of travel, as
    /// a turn back flips the travel and the signs together.
    pub(super) fn align_to_travel(&mut self, env: &LocoView<'_>) {
        let travel = self.travel();
        let scene = env.scene();
        for l in &mut self.limbs {
            let s = scene.support(l.grip.support);
            if s.kind == SupportKind::Branch
                && project(s, l.grip.point).tangent.dot(travel) * l.grip.sdir < 0.0
            {
                l.grip.sdir = -l.grip.sdir;
            }
        }
    }

    /// Side steps around trunk `sid` (SPEC `find_side_step`): when the goal
    /// is on this trunk with a side the body does not yet face it from, the
    /// turn about the axis the next step makes (toward the goal's side, the
    /// shorter way) and the goal's distance along the axis from the body.
    pub(super) fn side_step(&self, env: &LocoView<'_>, sid: SupportId) -> Option<SideStep> {
        let (gs, gp) = self.goal?;
        let s = env.scene().support(sid);
        if s.kind != SupportKind::Trunk || self.transfer.is_some() {
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
        let (goal_side, gp) = if gs == sid {
            (self.goal_side?, gp)
        } else {
            self.approach_side(env, sid, gs, axis_up, side_now)?
        };
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

    /// `transfer_to_branch`'s approach (goal mode): climbing trunk `trunk`
    /// toward goal branch `branch` leaving it, the side to face the trunk
    /// from (see [`approach_angle`]; on the side of the branch's vertical
    /// plane the body is on) and the branch's root on the axis, the height
    /// the side steps climb to. `None` when `branch` does not leave `trunk`,
    /// or the root is not above the body (the approach is over).
    fn approach_side(
        &self,
        env: &LocoView<'_>,
        trunk: SupportId,
        branch: SupportId,
        axis_up: Vec3,
        side_now: Vec3,
    ) -> Option<(Vec3, Vec3)> {
        let scene = env.scene();
        let b = scene.support(branch);
        if self.dir <= 0.0
            || b.kind != SupportKind::Branch
            || !env.adjacency.neighbours(trunk).contains(&branch)
        {
            return None;
        }
        let t = scene.support(trunk);
        // The branch's root is its end nearer the trunk's axis; away from
        // the axis toward its other end.
        let radial = |p: Vec3| {
            let a = project(t, p);
            let d = p - a.point;
            (a, d - a.tangent * a.tangent.dot(d))
        };
        let (e0, e1) = (b.nodes[0], b.nodes[b.nodes.len() - 1]);
        let ((ra, _), (_, far)) = if radial(e0).1.length() <= radial(e1).1.length() {
            (radial(e0), radial(e1))
        } else {
            (radial(e1), radial(e0))
        };
        let body = project(t, self.body_pos);
        if (ra.point - body.point).dot(axis_up) <= 0.0 {
            return None;
        }
        let away = far.try_normalize()?;
        let normal = axis_up.cross(away);
        let normal = if normal.dot(side_now) >= 0.0 {
            normal
        } else {
            -normal
        };
        let angle = approach_angle(body.radius);
        Some((away * angle.cos() + normal * angle.sin(), ra.point))
    }

    /// Travel direction along a new support: toward the goal if it is on it,
    /// else for a trunk up (+1 travel) or down per `dir`, else the direction
    /// that continues the current travel.
    fn choose_sdir(&self, env: &LocoView<'_>, sid: SupportId, tangent: Vec3) -> f32 {
        let s = env.scene().support(sid);
        // Onto a trunk only head up: the limbs climb it until all four are
        // across. A tail-first transfer (`Sloth::descends_tail_first`): the
        // body still faces up, and the limbs travel down it.
        if let Some(t) = self
            .transfer
            .filter(|t| t.to == sid && s.kind == SupportKind::Trunk)
        {
            let up = if tangent.y >= 0.0 { 1.0 } else { -1.0 };
            return if t.dir < 0.0 { up * self.dir } else { up };
        }
        // A support other limbs already hold: the way they travel on it. The
        // body's forward a grip implies (its sdir × dir) is the same for all
        // limbs on a support, so each grips on its own side of a branch. (A
        // back-off turns every grip's sdir; toward the goal, a hind limb
        // following the others onto the goal's branch then gripped it on
        // the other limb's side: trunk_branch at 72°, r 0.2 m.)
        if let Some(l) = self.limbs.iter().find(|l| l.grip.support == sid) {
            return l.grip.sdir;
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
}

#[cfg(test)]
mod fork_tests {
    use glam::Vec3;
    use slothsim_rig::Rig;
    use slothsim_scene::{Scene, Support, SupportKind, TraceScene};

    use super::super::test_util::tick;
    use super::super::{NearRing, Sloth, SpawnHint, TraceBatch};
    use crate::{LocoEnv, LocomotionConfig, Profile};

    /// A wanderer climbing a trunk that forks at its top (the trunk's end and
    /// the stem going on from it are both trunks, as in imported and
    /// generated trees) never steps onto the other stem: the body beside a
    /// trunk is placed only with both fore limbs on one trunk, so a fore
    /// limb on the stem would draw it hanging as below a branch (a `gen-trees`
    /// forest's wanderer jumped 28 cm in one frame, 50 mm into a support).
    /// Without the rule the fore limbs take the stem and the body jumps.
    #[test]
    fn a_wanderer_does_not_step_from_a_trunk_onto_its_forks_stem() {
        let trunk = Support::new(vec![Vec3::ZERO, Vec3::new(0.0, 4.0, 0.0)], vec![0.12, 0.11])
            .with_kind(SupportKind::Trunk)
            .with_name("trunk");
        let stem = Support::new(
            vec![Vec3::new(0.0, 4.0, 0.0), Vec3::new(0.6, 7.5, 0.0)],
            vec![0.11, 0.09],
        )
        .with_kind(SupportKind::Trunk)
        .with_name("stem");
        let scene = Scene::new(vec![trunk, stem]).unwrap();
        let env = LocoEnv::new(
            LocomotionConfig::profile(Profile::Free),
            &Rig::sloth(),
            TraceScene::new(scene),
        )
        .unwrap();
        let view = env.view();
        let (t, s) = (slothsim_scene::SupportId(0), slothsim_scene::SupportId(1));
        assert!(
            env.adjacency.neighbours(t).contains(&s),
            "the stem neighbours the trunk"
        );
        let hint = SpawnHint {
            support: t,
            position: Vec3::new(0.0, 2.6, 0.0),
            forward: Vec3::Y,
            body_side: Vec3::Z,
        };
        let mut sloth = Sloth::spawn(&view, &hint, None);
        sloth.wander = true;
        let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
        let (mut worst_jump, mut on_stem, mut top) = (0.0f32, 0, 0.0f32);
        for _ in 0..2400 {
            let before = sloth.body_pos;
            tick(&mut sloth, &mut near, &view, &mut batch);
            worst_jump = worst_jump.max(sloth.body_pos.distance(before));
            on_stem += usize::from(sloth.limbs.iter().any(|l| l.grip.support == s));
            top = top.max(
                sloth
                    .limbs
                    .iter()
                    .map(|l| l.grip.point.y)
                    .fold(0.0, f32::max),
            );
        }
        assert!(
            top > 3.5,
            "the sloth climbs to the fork (highest grip {top} m)"
        );
        assert_eq!(on_stem, 0, "frames with a limb on the stem");
        assert!(
            worst_jump < 0.02,
            "the body moved {worst_jump} m in one frame"
        );
    }
}
