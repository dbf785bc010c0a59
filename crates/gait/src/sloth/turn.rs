//! Turning around at a branch end (thesis, scenario 4: "at the end point the
//! movement stops, with the option of moving back keeping the order of the
//! limbs, or of changing branch"; issue 24 item 2). A sloth hanging below a
//! branch turns its body about the branch's up (the body's up) by steps: each
//! limb, when the gait clock lifts it (the footfall order goes on), re-grips
//! the branch where its root will be after the step, and the body's heading
//! turns by at most [`TURN_STEP`] during that swing, eased as the claw
//! travels; the body stays below the paws' mean (formula 7). Formula 6 is
//! undefined while the grips gather across the branch, so the heading is the
//! turn's until it has reached the other way; the last step then hands it
//! back to formula 6, blended over that step's swing. Every step passes the
//! stance checks of an ordinary step (reach within the joint limits at the
//! arc's points and the landing, the body out of the supports) with the body
//! drawn as it will be. Then the sloth walks on head first.

use std::f32::consts::PI;

use glam::{Quat, Vec3};
use serde::{Deserialize, Serialize};
use slothsim_rig::Limb;
use slothsim_rig::unit::UnitOr;
use slothsim_scene::{Support, SupportId, SupportKind};

use crate::path::{axis_at, project, surface_gap};

use super::body::{body_offset, grip_out, smoothstep};
use super::{Grip, LimbPhase, LocoView, Sloth};

/// The most the body's heading turns during one limb's swing (radians).
pub const TURN_STEP: f32 = PI / 16.0;

/// The turn hands the heading back to formula 6 only where formula 6 of
/// the stance after the step is within this angle of the way back (cosine).
const HANDOVER_COS: f32 = 0.94;

/// A grip is looked for this far (m) along the branch either side of where
/// the limb's root will be…
const TURN_SEARCH_M: f32 = 0.24;

/// …every this many metres.
const TURN_STRIDE_M: f32 = 0.01;

/// Turning at the other way, a limb looks first for a grip at least this
/// far (m) from the grip of the other limb of its side: a handover there
/// hands formula 6 a side whose direction is all but undefined (a crowd
/// sloth's turn ended with LH 0.7 mm from LF's grip, and LH's lift-off
/// turned formula 6 by 40°: seed 3 of the 5,000 × 300 s crowd). Formula 6
/// is continuous through such a side (see `FORMULA6_SIDE_M`, the same
/// length), but leans on the other side alone there. Only a preference:
/// with no such grip it takes the nearest as before.
const TURN_SIDE_APART_M: f32 = 0.1;

/// Directions around the branch a grip is tried at besides toward the root.
const AROUND: usize = 7;

/// A turn that has made no progress for this many steps (a step that turns
/// the body, or the handover) gives up: the sloth stops.
const TURN_MAX_IDLE: u8 = 8;

/// No limb's swing is turning the body ([`Turn::limb`]).
const NO_LIMB: u8 = u8::MAX;

/// A turning grip farther than this (m) from its branch's surface, as the
/// judge measures it ([`surface_gap`]), is not taken (see [`on_surface`]).
const TURN_GRIP_GAP_M: f32 = 0.001;

/// A turning grip on the surface of branch `s` near `p` (outward normal
/// `out`), and its normal: `p` itself where it lies on the surface (within
/// [`TURN_GRIP_GAP_M`]), else `p` moved along the radius through its
/// nearest axis point to that point's radius. A grip placed from the axis
/// point at its arc length ([`axis_at`]) lies off the surface where the
/// axis bends (its nearest axis point is another segment's): traced in the
/// 5,000 × 300 s crowd, a turn's hind grip 7 mm inside a branch near its
/// fork held for 2 s (the judge's gap). `None` where even that point is
/// more than [`TURN_GRIP_GAP_M`] off the surface (a mesh, a sharp bend).
/// Grips already on the surface are kept bit for bit: re-placing them
/// moved them by rounding only, and that alone lost a transfer case
/// (`branch_trunk` 0.2 m 74.5°, whose goal-mode turn is otherwise as it
/// was).
fn on_surface(env: &LocoView<'_>, s: &Support, p: Vec3, out: Vec3) -> Option<(Vec3, Vec3)> {
    if surface_gap(env.query, s, p) <= TURN_GRIP_GAP_M {
        return Some((p, out));
    }
    let a = project(s, p);
    let n = (p - a.point).try_normalize()?;
    let grip = a.point + n * a.radius;
    (surface_gap(env.query, s, grip) <= TURN_GRIP_GAP_M).then_some((grip, n))
}

/// A turn around under way (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Turn {
    /// The branch it turns on.
    pub support: SupportId,
    /// The heading when the turn began (unit, perpendicular to `up`).
    pub fwd0: Vec3,
    /// The body's up, which the heading turns about (the branch's up).
    pub up: Vec3,
    /// Which way about `up` it turns (±1).
    pub sense: f32,
    /// The heading the planted stance has reached (radians from `fwd0`, up
    /// to π; below 0 after a wanderer's stopped turn went the other way
    /// round from where it had reached: [`Turn::reverse`]).
    pub angle: f32,
    /// The heading the turning limb's step ends at.
    pub to: f32,
    /// The limb whose swing turns the body ([`NO_LIMB`]: none).
    pub limb: u8,
    /// That swing hands the heading back to formula 6.
    pub handover: bool,
    /// Steps in a row that did not advance the turn.
    pub idle: u8,
    /// The turn readies a tail-first descent onto a trunk (see
    /// `Sloth::descends_tail_first`): once it is over the sloth walks on
    /// tail first, the way it came, instead of head first.
    #[serde(default)]
    pub tail_first: bool,
}

/// A turning step to check: the limb, its grip (point, normal), the heading
/// it ends at and whether it hands over.
#[derive(Clone, Copy)]
pub(super) struct TurnStep {
    pub(super) limb: usize,
    pub(super) grip: Vec3,
    pub(super) normal: Vec3,
    pub(super) to: f32,
    pub(super) handover: bool,
}

impl TurnStep {
    /// Its fields' bits (debug builds compare steps found two ways).
    fn bits(self) -> (usize, [u32; 3], [u32; 3], u32, bool) {
        (
            self.limb,
            self.grip.to_array().map(f32::to_bits),
            self.normal.to_array().map(f32::to_bits),
            self.to.to_bits(),
            self.handover,
        )
    }
}

impl Turn {
    /// The heading at angle `a`.
    fn fwd(&self, a: f32) -> Vec3 {
        Quat::from_axis_angle(self.up, self.sense * a) * self.fwd0
    }

    /// The same heading (bit for bit: `sense · angle` is unchanged), to be
    /// turned on the other way round: a wanderer's turn whose steps were
    /// refused until it stopped (other sloths' clearance on that side,
    /// traced in the 5,000 × 300 s crowd: stopped 8 times from 70 s on at
    /// 17–23° and retried the same way each time) tries the other side
    /// when it resumes, and back again if that stops too.
    fn reverse(&mut self) {
        self.sense = -self.sense;
        self.angle = -self.angle;
        self.to = -self.to;
    }
}

impl Sloth {
    /// Whether a sloth whose search found nothing anywhere may turn around
    /// here: on a branch it alone holds (all four limbs on it, none in the
    /// air), no transfer under way. With `at_end` (goal mode, the goal
    /// behind) only head first, with no transfer set up, and within a search
    /// distance of the branch's end it heads for. Without it (a wanderer
    /// whose turn backs brought no step) also travelling tail first (two
    /// turn backs leave the travel as it was, so a sloth that had stopped
    /// tail first never turned around), and with a transfer only set up by
    /// a search (no limb on its target: a branch's root end with the trunk
    /// taken by other sloths; it rolls the body nothing, so dropping it for
    /// the turn moves nothing).
    pub(super) fn may_turn_around(&self, env: &LocoView<'_>, at_end: bool) -> bool {
        let sid = self.limbs[0].grip.support;
        let transfer_ok = match self.transfer {
            None => true,
            Some(t) => !at_end && self.limbs.iter().all(|l| l.grip.support != t.to),
        };
        self.turn.is_none()
            && (self.dir > 0.0 || !at_end)
            && transfer_ok
            && self.hang_trunk.is_none()
            && env.scene().support(sid).kind == SupportKind::Branch
            && self
                .limbs
                .iter()
                .all(|l| l.grip.support == sid && l.phase != LimbPhase::Swinging)
            && (!at_end || self.at_support_end(env))
    }

    /// Goal mode: the goal lies behind the body on the support it holds
    /// (a turn around at its end heads for it).
    pub(super) fn goal_behind(&self) -> bool {
        self.goal.is_some_and(|(sid, p)| {
            sid == self.limbs[0].grip.support
                && (p - self.body_pos).dot(self.body_rot * Vec3::Z) < 0.0
        })
    }

    /// Starts a turn around from the current stance (see the module docs);
    /// `tail_first`: see [`Turn::tail_first`].
    pub(super) fn start_turn(&mut self, tail_first: bool) {
        // A transfer only set up (see `may_turn_around`) is given up.
        self.transfer = None;
        // The way back would cross the turn.
        self.trail.clear();
        let t = self.limb_map(|l| l.target);
        // The frame the body has now (formula 6, below the branch).
        let fwd0 = self.formula6_fwd(&t);
        let up = (Vec3::Y - fwd0 * fwd0.dot(Vec3::Y)).unit_or(self.body_rot * Vec3::Y);
        for l in &mut self.limbs {
            l.fallback = None;
            l.due = false;
            if l.phase == LimbPhase::Searching {
                l.phase = LimbPhase::Planted;
            }
        }
        self.turn = Some(Turn {
            support: self.limbs[0].grip.support,
            fwd0,
            up,
            sense: if self.id.is_multiple_of(2) { 1.0 } else { -1.0 },
            angle: 0.0,
            to: 0.0,
            limb: NO_LIMB,
            handover: false,
            idle: 0,
            tail_first,
        });
        self.failed_searches = 0;
    }

    /// Swing progress of the step turning the body (0 with none).
    fn turn_progress(&self, tr: &Turn) -> f32 {
        match self.limbs.get(tr.limb as usize) {
            Some(l) if l.phase == LimbPhase::Swinging => l.swing_t,
            Some(_) => 1.0,
            None => 0.0,
        }
    }

    /// The body frame (forward, up) of a turn `tr` at progress `p` of its
    /// turning step: the heading eased from `angle` to `to`; a handover
    /// blends it into formula 6 of `landed`, the grips once the step has
    /// landed (and the up into the branch's plain up) as the step goes. Not
    /// formula 6 of the swing arc: a turn bunches the grips (fore and hind
    /// claws a few cm apart), and a claw's lift on its arc pitched that
    /// heading by up to 50° (a crowd sloth's body rolled 45° during a 7 cm
    /// step and snapped back when it landed, 12 mm into its branch).
    pub(super) fn turn_frame(&self, tr: &Turn, landed: &[Vec3; 4], p: f32) -> (Vec3, Vec3) {
        let e = smoothstep(p);
        let f = tr.fwd(tr.angle + (tr.to - tr.angle) * e);
        let (f, up) = if tr.handover {
            let f6 = self.formula6_fwd(landed);
            let f = (f * (1.0 - e) + f6 * e).unit_or(f6);
            (f, tr.up * (1.0 - e) + Vec3::Y * e)
        } else {
            (f, tr.up)
        };
        let up = (up - f * f.dot(up)).unit_or(tr.up);
        (f, up)
    }

    /// [`Self::turn_frame`] of the turn under way, at its step's progress
    /// now, for IK targets `t` (the turning limb lands on its grip).
    pub(super) fn turn_frame_now(&self, t: &[Vec3; 4]) -> Option<(Vec3, Vec3)> {
        let tr = self.turn?;
        let mut landed = *t;
        if let Some(l) = self.limbs.get(tr.limb as usize)
            && l.phase == LimbPhase::Swinging
        {
            landed[tr.limb as usize] = l.grip.point;
        }
        Some(self.turn_frame(&tr, &landed, self.turn_progress(&tr)))
    }

    /// The turning limb's step has landed: the heading is where it ended,
    /// and after the handover the turn is over: the sloth walks on head first
    /// the way it now faces (or, readying a tail-first descent, tail first
    /// the way it came).
    pub(super) fn finish_turn_step(&mut self, env: &LocoView<'_>) {
        let Some(mut tr) = self.turn else {
            return;
        };
        let Some(l) = self.limbs.get(tr.limb as usize) else {
            return;
        };
        if l.phase == LimbPhase::Swinging {
            return;
        }
        tr.angle = tr.to;
        tr.limb = NO_LIMB;
        if !tr.handover {
            self.turn = Some(tr);
            return;
        }
        self.turn = None;
        let dir = if tr.tail_first { -1.0 } else { 1.0 };
        let travel = self.body_rot * Vec3::Z * dir;
        let s = env.scene().support(tr.support);
        for l in &mut self.limbs {
            let a = axis_at(s, l.grip.u);
            l.grip.sdir = if a.tangent.dot(travel) >= 0.0 {
                1.0
            } else {
                -1.0
            };
        }
        self.dir = dir;
        self.turns = self.turns.wrapping_add(1);
        self.failed_searches = 0;
        self.stalled_turns = 0;
        // A wanderer keeps its turn-backs counted since the body last
        // travelled (`stall_from`; only travel ends the count, `note_step`):
        // turned around in place, and blocked the new way too (a sloth that
        // walked up behind it while it turned), its next give-up turns it
        // around again rather than back, tail first. Traced in the 5,000 ×
        // 300 s crowd at seed 10 (docs/locomotion.md, "Blocked again after a
        // turn around"): the count cleared here, such sloths turned back
        // twice (~11 s without a step) before turning again.
        if !self.wander {
            self.stall_from = None;
        }
        self.stuck_cause = None;
    }

    /// Limb `li`'s step of the turn, when the gait clock lifts it: the first
    /// grip near where its root will be (closest first, every
    /// [`TURN_STRIDE_M`]) whose step turns the body by [`TURN_STEP`] (or
    /// half, or none) and passes the stance checks; once the heading is the
    /// other way, a step that hands it back to formula 6. Grips that the limb
    /// still reaches at the heading of its next turn are preferred. Found, the
    /// limb swings; else it stays planted and the turn waits for the next
    /// limb (a turn that makes no progress for [`TURN_MAX_IDLE`] steps stops
    /// the sloth).
    pub(super) fn turn_search(&mut self, env: &LocoView<'_>, li: usize) -> bool {
        let Some(tr) = self.turn else {
            return false;
        };
        let l = &mut self.limbs[li];
        l.due = false;
        l.phase = LimbPhase::Planted;
        let remaining = PI - tr.angle;
        let incs = [TURN_STEP, TURN_STEP * 0.5, 0.0].map(|d| d.min(remaining));
        // With the lookahead first; else the first step of the scan without
        // it. That scan would judge the same grips in the same order, each by
        // the same pure checks: its answer for each increment is the first
        // grip the first scan found passing every check but the lookahead
        // (`without`), so it is taken from there instead of judged again.
        let mut without = [None; 3];
        let found = incs
            .iter()
            .enumerate()
            .find_map(|(k, &inc)| {
                if k > 0 && inc >= incs[k - 1] {
                    return None;
                }
                self.turn_step_for(env, &tr, li, inc, true, &mut without[k])
            })
            .or_else(|| without.into_iter().flatten().next());
        // Debug builds: the same step as both scans made in full.
        debug_assert!(
            {
                let full = [true, false].into_iter().find_map(|lookahead| {
                    incs.iter().enumerate().find_map(|(k, &inc)| {
                        if k > 0 && inc >= incs[k - 1] {
                            return None;
                        }
                        self.turn_step_for(env, &tr, li, inc, lookahead, &mut None)
                    })
                });
                full.map(TurnStep::bits) == found.map(TurnStep::bits)
            },
            "a turn step taken from the first scan differs from the second scan's"
        );
        let Some(step) = found else {
            self.turn_idle(env);
            return false;
        };
        let s = env.scene().support(tr.support);
        let a = project(s, step.grip);
        let l = &mut self.limbs[li];
        l.swing_to(Grip {
            point: step.grip,
            normal: step.normal,
            support: tr.support,
            u: a.u,
            sdir: l.grip.sdir,
        });
        let advanced = step.to > tr.angle || step.handover;
        self.turn = Some(Turn {
            to: step.to,
            limb: li as u8,
            handover: step.handover,
            idle: if advanced { 0 } else { tr.idle + 1 },
            ..tr
        });
        self.failed_searches = 0;
        if !advanced && tr.idle + 1 >= TURN_MAX_IDLE {
            self.turn_idle(env);
        }
        true
    }

    /// A turn that cannot go on stops the sloth where it is (its cause: the
    /// one judged when the turn began, else the branch's end); a wanderer
    /// tries again later, the turn still under way, the other way round
    /// ([`Turn::reverse`]) unless it has reached the other way.
    fn turn_idle(&mut self, env: &LocoView<'_>) {
        let Some(tr) = self.turn.as_mut() else {
            return;
        };
        tr.idle = tr.idle.saturating_add(1);
        if tr.idle >= TURN_MAX_IDLE && self.status == super::Status::Moving {
            tr.idle = 0;
            if self.wander && tr.angle < PI - 1e-4 {
                tr.reverse();
            }
            self.stuck_cause.get_or_insert(super::StuckCause::Tip);
            self.status = super::Status::NoGrip;
            if self.wander {
                self.resume_at = Some(self.time + env.cfg.wander_retry_s);
            }
        }
    }

    /// The first grip for limb `li`'s turning step by `inc` (see
    /// [`Self::turn_search`]).
    fn turn_step_for(
        &self,
        env: &LocoView<'_>,
        tr: &Turn,
        li: usize,
        inc: f32,
        lookahead: bool,
        without: &mut Option<TurnStep>,
    ) -> Option<TurnStep> {
        let to = tr.angle + inc;
        let done = to >= PI - 1e-4;
        // Where the limb's root will be: between the step's end and its next
        // turn (four steps on), the body below the paws' mean.
        let ahead = if done {
            PI
        } else {
            (to + 1.5 * TURN_STEP).min(PI)
        };
        let s = env.scene().support(tr.support);
        let t = self.limb_map(|l| l.target);
        let offset = body_offset(env, self.trunk_weights(env));
        let mean = (t[0] + t[1] + t[2] + t[3]) * 0.25;
        // The limb's root at the step's end heading and at `ahead`.
        let root_at = |a: f32| {
            let at = Turn {
                angle: a,
                to: a,
                handover: false,
                ..*tr
            };
            let (f, up) = self.turn_frame(&at, &t, 1.0);
            let pos = mean - up * offset.metres;
            let rot = super::body::rotation_from(f, up);
            Vec3::from(env.rig.root_ws(li, pos, rot).position)
        };
        let roots = [root_at(to), root_at(ahead)];
        let centre = (project(s, roots[0]).u + project(s, roots[1]).u) * 0.5;
        let len = s.length();
        let margin = env.cfg.end_margin_m;
        let n = (TURN_SEARCH_M / TURN_STRIDE_M).round() as i32;
        // The steps at the other way (`done`) first look for a grip on the
        // limb's own side, within 60° of it, at every point of the window,
        // and only then anywhere: the handover wants every limb on its side,
        // and a limb left at the bottom or past it (the nearest reachable
        // grip) holds the walk's first steps at its joint limits. On its
        // side, first [`TURN_SIDE_APART_M`] from the grip of the other limb
        // of that side (see there).
        let same_side = self.limbs[Limb::ALL[li].same_side().index()].grip.point;
        let passes: &[(bool, bool)] = if done {
            &[(true, true), (true, false), (false, false)]
        } else {
            &[(false, false)]
        };
        passes.iter().find_map(|&(own_side_only, apart)| {
            (0..=2 * n).find_map(|k| {
                // 0, +1, −1, +2, −2, …
                let j = if k % 2 == 1 { (k + 1) / 2 } else { -(k / 2) };
                let u = centre + j as f32 * TURN_STRIDE_M;
                if !(margin..=len - margin).contains(&u) {
                    return None;
                }
                let a = axis_at(s, u);
                // Around the branch: toward the root at the step's end, toward
                // it at `ahead`, and between.
                let out_to = |root: Vec3| {
                    let radial = root - a.point;
                    (radial - a.tangent * a.tangent.dot(radial)).unit_or(-tr.up)
                };
                let (o0, o1) = (out_to(roots[0]), out_to(roots[1]));
                let mid = (o0 + o1).unit_or(o0);
                // First the limb's own side at the step's end heading, where the
                // walk grips it ([`grip_out`]), while that heading is within 60°
                // of the branch's axis (across it, the side lies along the axis):
                // the turn ends with each limb on its side for the handover.
                let own = {
                    let g = grip_out(SupportKind::Branch, Limb::ALL[li], tr.fwd(to), tr.up, 0.0);
                    let g = g - a.tangent * a.tangent.dot(g);
                    (g.length() >= 0.5).then(|| g.normalize())
                };
                let side = own.unwrap_or(o0);
                // …then every 45° on around the branch from between them.
                let mut outs = [mid; AROUND + 3];
                outs[0] = side;
                outs[1] = o0;
                outs[2] = o1;
                for (m, o) in outs.iter_mut().skip(3).enumerate() {
                    let k = (m / 2 + 1) as f32 * if m % 2 == 0 { 1.0 } else { -1.0 };
                    *o = Quat::from_axis_angle(a.tangent, k * std::f32::consts::FRAC_PI_4) * mid;
                }
                outs.iter().enumerate().find_map(|(m, &out)| {
                    if outs[..m].iter().any(|o| o.dot(out) > 0.999) {
                        return None;
                    }
                    if own_side_only && !own.is_some_and(|g| g.dot(out) >= 0.5) {
                        return None;
                    }
                    let (grip, out) = on_surface(env, s, a.point + out * a.radius, out)?;
                    if apart && grip.distance(same_side) < TURN_SIDE_APART_M {
                        return None;
                    }
                    if self.crowd_blocked(env, self.limbs[li].grip.point, grip) {
                        return None;
                    }
                    let handover = done && self.hands_over(tr, li, grip, out);
                    let step = TurnStep {
                        limb: li,
                        grip,
                        normal: out,
                        to,
                        handover,
                    };
                    if !self.turn_step_reachable(env, tr, &step) {
                        return None;
                    }
                    if lookahead && !done && !self.turn_holds_ahead(env, tr, &step) {
                        // Passes all but the lookahead: the scan without it
                        // takes the first such grip (see `turn_search`).
                        without.get_or_insert(step);
                        return None;
                    }
                    Some(step)
                })
            })
        })
    }

    /// Whether, with limb `li` at `grip` (surface normal `normal`), the
    /// heading the other way can be handed back to formula 6: formula 6 of
    /// that stance within [`HANDOVER_COS`] of it, both fore grips ahead of
    /// both hind grips along it (the leg order the walk goes on with), and
    /// every grip on its own limb's side of the branch (not past the
    /// vertical plane through the axis toward the other side: the walk grips
    /// each limb at its side, [`grip_out`], and a limb crossed under the body
    /// to the far side of a thick branch finds no step back to it).
    fn hands_over(&self, tr: &Turn, li: usize, grip: Vec3, normal: Vec3) -> bool {
        let mut t = self.limb_map(|l| l.grip.point);
        let mut n = self.limb_map(|l| l.grip.normal);
        t[li] = grip;
        n[li] = normal;
        let back = tr.fwd(PI);
        let f6 = self.formula6_fwd(&t);
        let along = |l: Limb| t[l.index()].dot(back);
        let fore = along(Limb::LF).min(along(Limb::RF));
        let hind = along(Limb::LH).max(along(Limb::RH));
        let own_side = Limb::ALL
            .iter()
            .all(|&l| n[l.index()].dot(grip_out(SupportKind::Branch, l, back, tr.up, 0.0)) >= 0.0);
        // Every limb has re-gripped at the other way without reaching its
        // side: hand over as it stands rather than stop.
        let tried = tr.angle >= PI - 1e-4 && usize::from(tr.idle) >= Limb::ALL.len();
        f6.dot(back) >= HANDOVER_COS && fore > hind && (own_side || tried)
    }

    /// Whether limb `li`, once at its turning step's grip, still reaches it
    /// at the heading of its next turning step (the others holding theirs).
    fn turn_holds_ahead(&self, env: &LocoView<'_>, tr: &Turn, step: &TurnStep) -> bool {
        let ahead = (step.to + 3.0 * TURN_STEP).min(PI);
        let mut t = self.limb_map(|l| l.grip.point);
        t[step.limb] = step.grip;
        let future = Turn {
            angle: ahead,
            to: ahead,
            handover: false,
            ..*tr
        };
        self.turn_hold_check(env, &future, t, step.limb)
    }
}

#[cfg(test)]
mod tests {
    use slothsim_scene::PresetKind;

    use super::super::test_util::{preset_sloth, xorshift};
    use super::super::{Status, StuckCause};
    use super::*;

    /// A wanderer turning around with a sloth walked into it from behind
    /// (a copy of its own points moved back along its heading by less than
    /// the clearance, and aside at random: every grip within that sloth's
    /// clearance) has turning steps whose grips move away from every point
    /// of that sloth they are within the clearance of, and none toward one;
    /// some of its steps lie within that clearance (the plain clearance
    /// refuses those: without the rule all 180 steps found lie outside it).
    /// Goal mode keeps the plain clearance.
    #[test]
    fn a_boxed_wanderers_turn_steps_away_from_a_sloth_in_its_clearance() {
        let (env, base) = preset_sloth(PresetKind::BranchEnd);
        let clearance = 0.3;
        let mut rnd = xorshift(25);
        let (mut inside, mut cases) = (0, 0);
        for case in 0..40u32 {
            let mut sloth = base;
            sloth.wander = case % 4 != 0;
            sloth.id = case;
            sloth.start_turn(false);
            let tr = sloth.turn.unwrap();
            let back = -(sloth.body_rot * Vec3::Z);
            let aside = sloth.body_rot * Vec3::X;
            let shift = back * (0.05 + 0.2 * rnd()) + aside * (0.1 * rnd() - 0.05);
            let other = crate::crowd_points(env.view().rig, &sloth).map(|p| p + shift);
            let mut grid = crate::CrowdGrid::new(clearance);
            grid.rebuild(other.iter().map(|&p| (1000, p)));
            let view = env.view_with(Some(&grid));
            for li in 0..4 {
                let from = sloth.limbs[li].grip.point;
                assert!(
                    other.iter().any(|q| q.distance(from) < clearance),
                    "case {case}"
                );
                for inc in [TURN_STEP, TURN_STEP * 0.5, 0.0] {
                    let Some(step) = sloth.turn_step_for(&view, &tr, li, inc, false, &mut None)
                    else {
                        continue;
                    };
                    cases += 1;
                    for q in other {
                        let d = q.distance(step.grip);
                        if d < clearance {
                            assert!(sloth.wander, "case {case}: goal mode keeps the clearance");
                            inside += 1;
                            assert!(d > q.distance(from), "case {case} limb {li}: toward {q}");
                        }
                    }
                }
            }
        }
        assert!(
            cases > 0 && inside > 0,
            "{cases} steps, {inside} within the clearance"
        );
    }

    /// A turn that stops (its steps refused [`TURN_MAX_IDLE`] times in a
    /// row) is tried the other way round when a wanderer resumes, from the
    /// heading it has reached (bit for bit), and back again if that stops
    /// too; a goal-mode turn, and a turn already at the other way (waiting
    /// for its handover), stop as before. Angles drawn at random, both
    /// senses.
    #[test]
    fn a_wanderers_stopped_turn_tries_the_other_way_round() {
        let (env, base) = preset_sloth(PresetKind::BranchEnd);
        let view = env.view();
        let mut rnd = xorshift(24);
        for case in 0..60 {
            let mut sloth = base;
            sloth.wander = case % 3 != 0;
            sloth.id = case;
            sloth.start_turn(false);
            let at_other_way = case % 5 == 0;
            let angle = if at_other_way {
                PI
            } else {
                rnd() * (PI - 0.01)
            };
            {
                let tr = sloth.turn.as_mut().unwrap();
                tr.angle = angle;
                tr.to = angle;
            }
            let before = sloth.turn.unwrap();
            let heading = |tr: &Turn| tr.fwd(tr.angle).to_array().map(f32::to_bits);
            sloth.status = Status::Moving;
            sloth.stuck_cause = Some(StuckCause::Crowded);
            for _ in 0..TURN_MAX_IDLE {
                sloth.turn_idle(&view);
            }
            assert_eq!(sloth.status, Status::NoGrip, "case {case}");
            let tr = sloth.turn.unwrap();
            assert_eq!(heading(&tr), heading(&before), "case {case}");
            let reversed = sloth.wander && !at_other_way;
            assert_eq!(tr.sense == -before.sense, reversed, "case {case}");
            // Stopped again the other way: back to the first sense.
            sloth.status = Status::Moving;
            for _ in 0..TURN_MAX_IDLE {
                sloth.turn_idle(&view);
            }
            let tr = sloth.turn.unwrap();
            assert_eq!(tr.sense, before.sense, "case {case}");
            assert_eq!(heading(&tr), heading(&before), "case {case}");
        }
    }

    /// A wanderer that turned around because its turn backs brought no step
    /// (two counted since its body last travelled a max step,
    /// `Sloth::stall_from`) and whose search gives up again before the body
    /// has travelled (blocked the new way too: a sloth walked up behind it
    /// while it turned) turns around again at that give-up, not back (tail
    /// first, mostly out of its limbs' reach): the turn's handover keeps the
    /// count, which only travel ends. Once the body has travelled a max step,
    /// a give-up turns it back as before; in goal mode the handover ends the
    /// count as before. Without the rule the give-up after the handover
    /// turns it back (checked: the count is gone after the handover).
    #[test]
    fn a_wanderer_blocked_again_after_its_turn_around_turns_around_again() {
        let (env, base) = preset_sloth(PresetKind::BranchEnd);
        let view = env.view();
        for (case, wander) in [true, false].into_iter().enumerate() {
            let mut sloth = base;
            sloth.wander = wander;
            sloth.status = Status::Moving;
            // Two turn backs without travelling: the turn around begins.
            sloth.stall_from = Some((sloth.body_pos, 2));
            sloth.stalled_turns = 2;
            sloth.start_turn(false);
            // The turn at the other way, its handover step landed.
            {
                let tr = sloth.turn.as_mut().unwrap();
                tr.angle = PI;
                tr.to = PI;
                tr.handover = true;
                tr.limb = 0;
            }
            assert_ne!(sloth.limbs[0].phase, LimbPhase::Swinging);
            sloth.finish_turn_step(&view);
            assert!(sloth.turn.is_none(), "case {case}: handed over");
            assert_eq!(sloth.stalled_turns, 0, "case {case}");
            if !wander {
                assert_eq!(sloth.stall_from, None, "case {case}: goal mode");
                continue;
            }
            assert_eq!(sloth.stall_from.map(|(_, n)| n), Some(2), "case {case}");
            let dir = sloth.dir;
            let mut again = sloth;
            again.give_up(&view);
            assert!(again.turn.is_some(), "case {case}: turns around again");
            assert_eq!(again.dir, dir, "case {case}");
            // Travelled a max step since: the count is over, a give-up
            // turns it back.
            let mut walked = sloth;
            walked.body_pos += walked.body_rot * Vec3::Z * view.cfg.max_step_m;
            walked.note_step(&view);
            assert_eq!(walked.stall_from, None, "case {case}");
            walked.give_up(&view);
            assert!(walked.turn.is_none(), "case {case}: turns back");
            assert_eq!(walked.dir, -dir, "case {case}: turns back");
        }
    }

    /// Issue 24 item 3 (the seed-1 crowd with the stall count kept through a
    /// turn around, wanderer 4105 at 250.70 s; fixture
    /// `testdata/turn_lands_short.json`: the sloth as its step search begins
    /// a turning step of its left fore limb, all four limbs on one branch).
    /// The crowd took LF to a grip its pose at the step's start reached
    /// within 1.4 mm; drawn along the arc, the limb came to rest at its joint
    /// limits 8.2 mm short, and `pull_to_grips` moved the body 8.2 mm toward
    /// the claw, 12.8 mm into a branch no limb holds. The search takes no
    /// turning step of LF there now (none passes); one it takes is not the
    /// crowd's, and drawn frame by frame (the sim's stages, as the crowd
    /// draws it) until it lands, its body stays within
    /// `STANCE_MAX_PENETRATION` of the supports. Without the check of the
    /// stepping limb's end from its pose on the arc (checks.rs
    /// `lands_as_drawn`) the search takes the crowd's step, and drawn, its
    /// body goes 12.77 mm deep (checked: both assertions fail).
    #[test]
    fn a_turning_step_whose_drawn_limb_lands_short_is_not_taken() {
        use super::super::collide::STANCE_MAX_PENETRATION;
        use super::super::test_util::{crowd_fixture, tick};
        use super::super::{NearRing, TraceBatch};

        let (fx, sloth, env) = crowd_fixture(include_str!("testdata/turn_lands_short.json"));
        let view = env.view();
        let li = fx["limb"].as_u64().unwrap() as usize;
        let crowds: Vec3 = serde_json::from_value(fx["step"]["point"].clone()).unwrap();
        let mut s = sloth;
        if !s.turn_search(&view, li) {
            // No turning step of that limb passes (the turn waits).
            println!("no turning step taken");
            return;
        }
        let grip = s.limbs[li].grip.point;
        assert!(grip.distance(crowds) > 1e-4, "the crowd's step is taken");
        let (mut batch, mut near) = (TraceBatch::default(), NearRing::default());
        let mut deepest = f32::NEG_INFINITY;
        for frame in 0..120 {
            if frame == 0 {
                // The rest of the frame the search took the step in.
                s.body_average(&view, 1.0 / 60.0);
                s.solve_limbs(&view);
                s.transitions(&view, 1.0 / 60.0, &mut batch);
            } else {
                tick(&mut s, &mut near, &view, &mut batch);
            }
            deepest = deepest.max(s.observe(&view).penetration_m);
            if s.limbs[li].phase != LimbPhase::Swinging {
                break;
            }
        }
        assert_ne!(s.limbs[li].phase, LimbPhase::Swinging, "landed");
        println!("turning step to {grip}: body {deepest} m deep");
        assert!(deepest <= STANCE_MAX_PENETRATION, "{deepest}");
    }
}
