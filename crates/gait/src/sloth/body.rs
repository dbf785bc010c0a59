//! BodyAverage (thesis §3.3, formulas 6 and 7; SPEC "Body averaging"): the
//! swing arc each lifted limb travels, the body frame the paws imply
//! (forward from formula 6, up toward the support, the roll about a branch
//! that keeps the body clear of a trunk and the roll of a branch ↔ trunk
//! transfer), and the body placed below the paws' mean (formula 7).

use glam::{Quat, Vec3};
use slothsim_rig::Limb;
use slothsim_rig::unit::UnitOr;
use slothsim_scene::{SupportId, SupportKind};

use crate::path::project;

use super::collide::{torso_box_meets, torso_penetration};
use super::solve::{KeyBits, KeyEq, KeySink};
use super::{LimbPhase, LimbState, LocoView, Sloth};

/// The body turns up to this fast (rad/s) without smoothing lag; faster
/// changes of formula 6's rotation are smoothed (`body_smoothing_s`).
pub(super) const BODY_FREE_TURN_RATE: f32 = 1.5;

/// The body's roll over a transfer follows the share of limbs on the trunk to this power.
const TRANSFER_ROLL_POWER: f32 = 0.75;

/// Mid-transfer the body's up leans this much (at most) away from the trunk,
/// so the body clears it while the hind limbs are still on the branch. No
/// more: every centimetre the body is pushed off the trunk is one the limbs
/// reaching around it lack (0.3 stranded the second fore limb on a branch
/// meeting the trunk from below at 135–140°; the stance checks reject any
/// penetration a smaller lean would cause).
const TRANSFER_AWAY: f32 = 0.15;

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

/// Approaching a trunk along a branch (goal mode, head first), the body rolls
/// clear of the trunk in full where the branch runs within 40° of the
/// trunk's axis (the sine of that angle: the branch's direction across the
/// axis), and not at all beyond 50° (`Sloth::approach_trunk`). Heading into
/// the trunk (branch_trunk below ~130°) the head meets the trunk and the
/// fore limbs take it ahead of the body: rolled there, the stances changed
/// and transfers at 97–112° (0.2 m) were lost. Swept at 0.5° over 60–160°
/// at the three radii against main's 539 of 603: full/none at 40°/50° 560
/// (14 lost), 40.5°/48.6° 560 (11 lost), 30°/44.4° 550 (20 lost). The
/// transfer's side must follow the roll (`Sloth::begin_transfer`): an earlier
/// form of this roll without that passed 486; that side choice without the
/// roll, 533.
const APPROACH_ALONG_FULL_SIN: f32 = 0.643;

/// See [`APPROACH_ALONG_FULL_SIN`] (sin 50°).
const APPROACH_ALONG_NONE_SIN: f32 = 0.766;

/// The weight shift ([`Sloth::weight_shift`]) fades out as the shifted torso
/// comes this close to a support near the grips (m).
const SHIFT_CLEARANCE: f32 = 0.05;

/// A holding claw left this far short of its grip lowers the weight shift (m).
const SHIFT_SHORT_M: f32 = 0.001;

/// How fast the weight shift's gain changes (per second).
const SHIFT_GAIN_RATE: f32 = 4.0;

/// The most the weight shift moves the body (m/s).
const SHIFT_SPEED: f32 = 0.15;

/// Formula 6's sides (a side's hind → fore grip) shorter than this (m)
/// count in proportion to their length instead of as a unit direction: the
/// direction of two grips on one point is undefined, and the heading (and
/// the body placed from it) jumped as one of them lifted off. A turn around
/// left a crowd sloth's LH 0.7 mm from LF's grip; LH's first 5 mm of swing
/// turned formula 6 by 40° and moved the body 8.6 cm (seed 3 of the 5,000 ×
/// 300 s crowd: its torso 14.5 mm into the branch). Longer sides count as
/// before, bit for bit; the walk keeps a side's grips
/// [`same_side_spacing_m`](crate::LocomotionConfig::same_side_spacing_m)
/// (0.15 m) apart along the body, and the 1,000-sloth crowd's sides are all
/// longer than 0.12 m.
const FORMULA6_SIDE_M: f32 = 0.1;

/// Formula 6's two sides summing to less than this (two unit sides over
/// 150° apart, or short ones) lean on the body's heading now, fully at a
/// zero sum: the heading from nearly opposite sides is undefined too.
const FORMULA6_SUM_MIN: f32 = 0.5;

/// A side of formula 6 (`v`: hind → fore grip): its direction, scaled by its
/// length below [`FORMULA6_SIDE_M`] (so continuous through two grips on one
/// point). At or above it, exactly `v.unit_or_zero()`.
fn formula6_side(v: Vec3) -> Vec3 {
    let len = v.length();
    if len >= FORMULA6_SIDE_M {
        v.unit_or_zero()
    } else if len.is_finite() {
        v / FORMULA6_SIDE_M
    } else {
        Vec3::ZERO
    }
}

/// Formula 6's heading from the sum of its sides, `now` (the body's heading)
/// where they nearly cancel ([`FORMULA6_SUM_MIN`]): continuous in the sum
/// except where it points back against `now` at half that length. At or
/// above it, exactly `sum.unit_or(now)`.
fn formula6_heading(sum: Vec3, now: Vec3) -> Vec3 {
    let len = sum.length();
    if len >= FORMULA6_SUM_MIN {
        sum.unit_or(now)
    } else {
        (sum + now * (FORMULA6_SUM_MIN - len)).unit_or(now)
    }
}

/// Words of a `BodyKey`: the body (position, rotation), the weight shift, the hang side and flag,
/// the transfer (flag, supports, side, away), then per limb its phase, grip
/// point and support. Not the targets: see [`Sloth::body_average_memo`].
const BODY_KEY_LEN: usize = 7 + 3 + 4 + 9 + 4 * 5;

/// The bits of the fields [`Sloth::body_average`] reads or writes while no
/// limb swings, but the targets (each the bits of its grip's point where the
/// memo is kept).
type BodyKey = [u32; BODY_KEY_LEN];

/// What [`Sloth::body_average_memo`] keeps of the sloth's last BodyAverage
/// (its key written and compared in place).
#[derive(Clone, Copy, Debug)]
pub struct BodyMemo {
    /// The state before the last BodyAverage (with no limb swinging).
    key: BodyKey,
    /// That BodyAverage left the sloth unchanged: `key` is its state now.
    fixed: bool,
}

impl Default for BodyMemo {
    fn default() -> Self {
        BodyMemo {
            key: [0; BODY_KEY_LEN],
            fixed: false,
        }
    }
}

#[inline]
pub(super) fn smoothstep(t: f32) -> f32 {
    let t = t.clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// The swing arc at progress `t` from grip `from` to grip `to` (points and
/// surface normals): eased along the chord, lifted clear of the support
/// along the normals' mean (`fallback`, the body's down, where they cancel).
pub(super) fn swing_point(
    from: (Vec3, Vec3),
    to: (Vec3, Vec3),
    t: f32,
    clearance: f32,
    fallback: Vec3,
) -> Vec3 {
    let lift_dir = swing_lift_dir(from.1, to.1, fallback);
    swing_point_along(from.0, to.0, lift_dir, t, clearance)
}

/// The direction [`swing_point`]'s arc between surface normals `from_n` and
/// `to_n` is lifted along (the same all along the arc).
pub(super) fn swing_lift_dir(from_n: Vec3, to_n: Vec3, fallback: Vec3) -> Vec3 {
    // Between nearly opposite normals (a grip crossing to the other side of
    // a support) their mean says little: it leans toward `fallback` (away
    // from the body's supports), so the arc does not swing on a rounding.
    let sum = from_n + to_n;
    (sum + fallback * (1.0 - sum.length()).max(0.0)).unit_or(fallback)
}

/// [`swing_point`] with its lift direction given ([`swing_lift_dir`]).
pub(super) fn swing_point_along(
    from: Vec3,
    to: Vec3,
    lift_dir: Vec3,
    t: f32,
    clearance: f32,
) -> Vec3 {
    let lift = clearance * (std::f32::consts::PI * t).sin();
    from.lerp(to, smoothstep(t)) + lift_dir * lift
}

/// 1 for a trunk, 0 for a branch; from `a` to `b` eased by swing progress `t`.
pub(super) fn trunk_blend(env: &LocoView<'_>, a: SupportId, b: SupportId, t: f32) -> f32 {
    kind_blend(trunk_kind(env, a), trunk_kind(env, b), t)
}

/// 1 for a trunk, 0 for a branch.
pub(super) fn trunk_kind(env: &LocoView<'_>, sid: SupportId) -> f32 {
    f32::from(env.scene().support(sid).kind == SupportKind::Trunk)
}

/// [`trunk_blend`] from the supports' kinds ([`trunk_kind`]).
pub(super) fn kind_blend(ka: f32, kb: f32, t: f32) -> f32 {
    ka + (kb - ka) * smoothstep(t)
}

/// Formula 7's offset of the body below the paws, and the share of limbs on
/// a trunk it was blended by (a branch ↔ trunk transfer also rolls the body
/// by that share: see [`Sloth::body_frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct BodyOffset {
    /// Metres below the mean of the paws.
    pub(super) metres: f32,
    /// Share of limbs on a trunk, 0..1.
    trunk_share: f32,
    /// `transfer_to_branch`'s "offset back": metres the hindquarters are
    /// moved off the trunk while the hind pair swings onto the branch.
    pub(super) hind_back_m: f32,
}

/// The body's rotation one frame (`dt`) after `from`, turned toward formula
/// 6's `to` (outside transfers and turns): a slow turn (at most
/// [`BODY_FREE_TURN_RATE`]) is followed exactly, a jump is smoothed over
/// `body_smoothing_s`.
pub(super) fn smoothed_rotation(env: &LocoView<'_>, from: Quat, to: Quat, dt: f32) -> Quat {
    let k = if env.cfg.body_smoothing_s > 0.0 {
        let smooth = 1.0 - (-dt / env.cfg.body_smoothing_s).exp();
        let angle = from.angle_between(to);
        let free = BODY_FREE_TURN_RATE * dt;
        if angle <= free {
            1.0
        } else {
            smooth.max(free / angle)
        }
    } else {
        1.0
    };
    from.slerp(to, k).normalize()
}

/// Which side a body walking a trunk faces it from (see [`Sloth::body_frame`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum BodySide {
    /// From where the body is now: what `body_average` draws, frame by
    /// frame, so the drawn side follows the grips' mean a few frames late.
    Body,
    /// From the grips' mean: where the drawn side settles.
    Grips,
}

/// Formula 7's offset of the body below the paws for limbs with trunk
/// weights `weights`: the branch offset, blended toward the trunk offset by
/// the share of limbs on a trunk.
pub(super) fn body_offset(env: &LocoView<'_>, weights: [f32; 4]) -> BodyOffset {
    let trunk = env.cfg.trunk_body_offset_m.unwrap_or(env.body_offset);
    let share = weights.iter().sum::<f32>() * 0.25;
    BodyOffset {
        metres: env.body_offset + (trunk - env.body_offset) * share,
        trunk_share: share,
        hind_back_m: 0.0,
    }
}

/// The hindquarters' "offset back" at swing progress `t` of the hind pair,
/// as a share of `offset_back_m`: sin²(πt) rises from 0 and returns to 0 with
/// zero slope at both ends, so the body never jumps.
pub(super) fn hind_back_share(t: f32) -> f32 {
    (std::f32::consts::PI * t.clamp(0.0, 1.0)).sin().powi(2)
}

/// Body frame for a support: (forward, up toward the support) at an axis point.
/// Branch: up = world +Y made perpendicular to forward. Trunk: forward = the
/// axis pointing up (head up), up = from the body toward the axis.
pub(super) fn support_frame(
    kind: SupportKind,
    tangent_travel: Vec3,
    axis_tangent: Vec3,
    body_side: Vec3,
) -> (Vec3, Vec3) {
    match kind {
        SupportKind::Branch => {
            let f = tangent_travel;
            let up = (Vec3::Y - f * f.dot(Vec3::Y)).unit_or(Vec3::Z.cross(f).unit_or(Vec3::X));
            (f, up)
        }
        SupportKind::Trunk => {
            let f = if axis_tangent.y >= 0.0 {
                axis_tangent
            } else {
                -axis_tangent
            };
            let up = -(body_side - f * f.dot(body_side)).unit_or(f.any_orthonormal_vector());
            (f, up)
        }
    }
}

/// Goal mode: around a trunk a grip sits at most this far to the side of
/// the body's midplane (metres): where the grips at `trunk_grip_angle_deg`
/// (60°) sit on a 0.2 m trunk, the thickest the matrix checks. On a thicker
/// trunk the angle grows so the grips stay this close (issue 24): at the
/// fixed 60° the grips on a 0.25 m trunk sit 0.125 m out and the limbs
/// splay to their reach's edge (branch → trunk passed 12 of 50 angles at
/// 0.25 m, 29 with this cap; at 0.23 m 38 → 46; `trunk --param` climbs up,
/// down and around to 0.25 m before, to 0.29 m with it). Wander mode keeps
/// the configured angle (the crowd's figures were measured with it).
pub(super) const TRUNK_GRIP_LATERAL_MAX_M: f32 = 0.1;

/// The angle of the grip around a trunk of `radius` (metres) from the limb's
/// side toward the body (radians): `trunk_angle` (the configured one), or
/// more where that would put the grip farther than
/// [`TRUNK_GRIP_LATERAL_MAX_M`] to the side of the body's midplane
/// (goal mode: [`Sloth::trunk_grip_angle`]).
pub(super) fn trunk_grip_angle(trunk_angle: f32, radius: f32) -> f32 {
    if radius * trunk_angle.cos() > TRUNK_GRIP_LATERAL_MAX_M {
        (TRUNK_GRIP_LATERAL_MAX_M / radius).acos()
    } else {
        trunk_angle
    }
}

/// Which way from the axis a limb's grip sits: its side, turned toward the
/// body on trunks.
pub(super) fn grip_out(kind: SupportKind, limb: Limb, f: Vec3, up: Vec3, trunk_angle: f32) -> Vec3 {
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

pub(super) fn rotation_from(f: Vec3, up: Vec3) -> Quat {
    let z = f.unit_or(Vec3::Z);
    let y = (up - z * z.dot(up)).unit_or(z.any_orthonormal_vector());
    let x = y.cross(z);
    Quat::from_mat3(&glam::Mat3::from_cols(x, y, z)).normalize()
}

impl Sloth {
    /// The angle of a grip around a trunk of `radius` (metres) from the
    /// limb's side toward the body (radians): goal mode
    /// [`trunk_grip_angle`], wander mode the configured angle.
    pub(super) fn trunk_grip_angle(&self, env: &LocoView<'_>, radius: f32) -> f32 {
        let angle = env.cfg.trunk_grip_angle_deg.to_radians();
        if self.wander {
            angle
        } else {
            trunk_grip_angle(angle, radius)
        }
    }

    /// BodyAverage: advance swing arcs, then place the body (formulas 6, 7), smoothed.
    pub fn body_average(&mut self, env: &LocoView<'_>, dt: f32) {
        for (li, l) in self.limbs.iter_mut().enumerate() {
            match l.phase {
                LimbPhase::Planted | LimbPhase::Searching => l.target = l.grip.point,
                LimbPhase::Swinging => {
                    let dur = env.cfg.swing_duration(Limb::ALL[li]);
                    l.swing_t = (l.swing_t + dt / dur).min(1.0);
                    l.target = swing_point(
                        (l.from, l.from_normal),
                        (l.grip.point, l.grip.normal),
                        l.swing_t,
                        env.cfg.swing_clearance_m,
                        self.body_rot * Vec3::NEG_Y,
                    );
                    if l.swing_t >= 1.0 {
                        l.phase = LimbPhase::Planted;
                        l.target = l.grip.point;
                    }
                }
            }
        }
        // How far the last solve left a holding claw short (nothing below
        // changes the claws or the grips).
        let short = self.holding_short();
        if self.any_swinging() {
            self.update_shift_gain(env, dt, short);
        }
        // Formula 7's position is already continuous (swing arcs are), so it
        // is used as is: lagging it would pull planted limbs off their grips.
        // The rotation (formula 6) is smoothed against jumps (support changes,
        // touch-down), but follows a slow, continuous turn exactly: any lag
        // turns the hips away from the stance the step checks approved (a
        // 0.6° lag moved a hind claw 4 mm off its grip in a 2,000-sloth run).
        // Not at all during a branch ↔ trunk transfer: the roll is continuous
        // already, and lagging it would pull planted limbs off their grips.
        let (pos, rot) = self.averaged_body(env);
        // The weight shift follows its aim at most SHIFT_SPEED fast.
        let mut aim = self.weight_shift(env, pos, rot);
        // A holding claw the last solve left short of its grip (the body moved
        // where that limb could not follow: joint limits the reach guard does
        // not see): the shift backs off at once by as much as the claw is
        // short beyond SHIFT_SHORT_M, and its gain with it, so the claw holds
        // again in the next frame instead of while the gain fades.
        if short > SHIFT_SHORT_M && aim != Vec3::ZERO {
            let cap = (self.body_shift.length() - (short - SHIFT_SHORT_M)).max(0.0);
            let len = aim.length();
            if len > cap {
                self.shift_gain *= cap / len;
                aim *= cap / len;
            }
        }
        let step = SHIFT_SPEED * dt;
        let to_aim = aim - self.body_shift;
        self.body_shift += to_aim * (step / to_aim.length().max(step));
        let pos = pos + self.body_shift;
        self.body_rot = if self.transfer.is_none() && self.turn.is_none() {
            smoothed_rotation(env, self.body_rot, rot, dt)
        } else {
            self.body_rot.slerp(rot, 1.0).normalize()
        };
        self.body_pos = pos;
    }

    /// [`Sloth::body_average`], skipped where it would change nothing: while
    /// no limb swings it is a deterministic function of the fields in a
    /// `BodyKey` and the targets (and of `env` and `dt`, fixed for a run);
    /// when they hold the
    /// bits a call through `memo` left unchanged, this call would leave them
    /// unchanged again (a sloth between steps: about 40 % of the sloth-frames
    /// of a crowd). `memo` belongs to this sloth, `env` and `dt`.
    pub fn body_average_memo(&mut self, env: &LocoView<'_>, dt: f32, memo: &mut BodyMemo) {
        let armed = !self.any_swinging();
        if armed && memo.fixed && self.targets_on_grips() && self.body_key_is(&memo.key) {
            return;
        }
        let on_grips = armed && self.targets_on_grips();
        if armed {
            let mut k = KeyBits::<BODY_KEY_LEN>::new();
            self.body_key_into(&mut k);
            memo.key = k.done();
        }
        self.body_average(env, dt);
        memo.fixed = on_grips && self.targets_on_grips() && self.body_key_is(&memo.key);
    }

    /// Whether every limb's target holds the bits of its grip's point. With
    /// no limb swinging, BodyAverage sets each target to its grip's point, so
    /// an update that changed nothing found them so: the memo's key holds the
    /// grips' points once, and the targets are compared with the sloth's
    /// grips (unchanged where the key matches) instead of a copy of their own.
    fn targets_on_grips(&self) -> bool {
        self.limbs.iter().all(|l| {
            l.target.to_array().map(f32::to_bits) == l.grip.point.to_array().map(f32::to_bits)
        })
    }

    /// Whether the bits of every field [`Sloth::body_average`] reads or
    /// writes (while no limb swings), but the targets, are `key`'s.
    fn body_key_is(&self, key: &BodyKey) -> bool {
        let mut k = KeyEq::new(key);
        self.body_key_into(&mut k);
        k.done()
    }

    /// The bits of every field [`Sloth::body_average`] reads or writes while
    /// no limb swings, but the targets ([`Sloth::targets_on_grips`]), in order.
    fn body_key_into(&self, k: &mut impl KeySink) {
        k.f32s(self.body_pos.to_array());
        k.f32s(self.body_rot.to_array());
        k.f32s(self.hang_side.to_array());
        k.f32s(self.body_shift.to_array());
        k.u32s([self.hang_trunk.map_or(u32::MAX, |t| t.0)]);
        match self.transfer {
            Some(t) => {
                k.u32s([1, t.to.0, t.trunk.0]);
                k.f32s(t.side.to_array());
                k.f32s(t.away.to_array());
            }
            None => k.u32s([0; 9]),
        }
        for l in &self.limbs {
            k.u32s([l.phase as u32]);
            k.f32s(l.grip.point.to_array());
            k.u32s([l.grip.support.0]);
        }
    }

    /// Formulas 6 and 7 for the current targets: (position, rotation).
    pub(super) fn averaged_body(&self, env: &LocoView<'_>) -> (Vec3, Quat) {
        let mut offset = body_offset(env, self.trunk_weights(env));
        if let Some(t) = self.hind_pair_swing_t() {
            offset.hind_back_m = env.cfg.offset_back_m * self.hind_back_scale * hind_back_share(t);
        }
        self.body_for_targets(env, &self.targets(), offset, BodySide::Body)
    }

    /// Weight shift (issue 22; seed 003's centre-of-mass objective): where
    /// the body at (`pos`, `rot`) should move while a side empties
    /// ([`Sloth::side_emptying`]): across its heading, horizontally, toward
    /// the line of the other side's grips, by at most `weight_shift_max_m`, so
    /// that those two grips can carry it (the diagonal-sequence footfall
    /// order of the steady profile lifts a hind limb while its fore limb
    /// still swings). `body_average` moves the body toward this aim at most
    /// [`SHIFT_SPEED`] fast. Zero while no limb swings; scaled by
    /// [`Sloth::shift_gain`] (0 on trunks, in transfers and while a holding
    /// claw is left short). Guards: no limb's root moves beyond its reach
    /// band (`max_reach_fraction`) of its target, or further out if it is
    /// already; the shift shrinks to nothing as the fully shifted torso comes
    /// within [`SHIFT_CLEARANCE`] of a support near the grips.
    fn weight_shift(&self, env: &LocoView<'_>, pos: Vec3, rot: Quat) -> Vec3 {
        let max = env.cfg.weight_shift_max_m;
        if max <= 0.0 || self.shift_gain <= 0.0 || !self.any_swinging() || self.turn.is_some() {
            return Vec3::ZERO;
        }
        let t = self.targets();
        // Across the heading, horizontally; less as the heading steepens.
        let across = self.formula6_fwd(&t).cross(Vec3::Y);
        let (lateral, level) = (across.unit_or_zero(), across.length().min(1.0));
        if lateral == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let side_lat = |left: bool| {
            let [fore, hind] = if left {
                [Limb::LF, Limb::LH]
            } else {
                [Limb::RF, Limb::RH]
            };
            lateral.dot(t[fore.index()] + t[hind.index()]) * 0.5
        };
        let mean = lateral.dot(paws_mean(&t));
        let unload = |x: Limb, y: Limb| f32::from(self.side_emptying(env, x, y));
        let (u_left, u_right) = (unload(Limb::LF, Limb::LH), unload(Limb::RF, Limb::RH));
        let mut shift = (u_left * (side_lat(false) - mean) + u_right * (side_lat(true) - mean))
            .clamp(-max, max);
        if shift == 0.0 {
            return Vec3::ZERO;
        }
        // Reach: |a + s·lateral| ≤ max(R, |a|) for each limb's root-to-target a.
        let reach = env.rig.reach * env.cfg.max_reach_fraction;
        for (i, target) in t.iter().enumerate() {
            let a = Vec3::from(env.rig.root_ws(i, pos, rot).position) - *target;
            let (b, r) = (a.dot(lateral), reach.max(a.length()));
            let root = (b * b - a.length_squared() + r * r).max(0.0).sqrt();
            shift = shift.clamp((-b - root).min(0.0), (-b + root).max(0.0));
        }
        // Clearance of the fully shifted torso from the supports near the grips.
        let moved = pos + lateral * shift;
        let torso = [
            moved + rot * env.rig.torso_ms[0],
            moved + rot * env.rig.torso_ms[1],
        ];
        let scene = env.scene();
        let depth = self
            .near_supports(env)
            .map(|id| {
                torso_penetration(
                    scene.support(id),
                    env.adjacency.segment_chunks(id),
                    torso,
                    -SHIFT_CLEARANCE,
                )
            })
            .fold(-SHIFT_CLEARANCE, f32::max);
        lateral * shift * (-depth / SHIFT_CLEARANCE).clamp(0.0, 1.0) * self.shift_gain * level
    }

    /// Whether the side of limbs `x` and `y` holds nothing now or will
    /// before its swing ends: both swing, or one swings and the other is
    /// due, searching, or due by the gait clock before the swinging one lands.
    fn side_emptying(&self, env: &LocoView<'_>, x: Limb, y: Limb) -> bool {
        let (lx, ly) = (self.limbs[x.index()], self.limbs[y.index()]);
        let swinging = |l: LimbState| l.phase == LimbPhase::Swinging;
        let (swing, other, other_limb) = match (swinging(lx), swinging(ly)) {
            (true, true) => return true,
            (false, false) => return false,
            (true, false) => (x, ly, y),
            (false, true) => (y, lx, x),
        };
        if other.due || other.phase == LimbPhase::Searching {
            return true;
        }
        let lands_in = (1.0 - self.limbs[swing.index()].swing_t) * env.cfg.swing_duration(swing);
        let off = env.phase_offsets[other_limb.index()];
        let due_in = (off - self.clock).rem_euclid(1.0) * env.cycle_s;
        due_in <= lands_in
    }

    /// While a limb swings: [`Sloth::shift_gain`] falls toward 0 on a trunk,
    /// in a transfer, or while a holding claw was left more than
    /// [`SHIFT_SHORT_M`] short of its grip by the last solve (joint limits the
    /// reach guard does not see), else rises toward 1, at
    /// [`SHIFT_GAIN_RATE`] per second either way.
    /// `short`: [`Sloth::holding_short`].
    fn update_shift_gain(&mut self, env: &LocoView<'_>, dt: f32, short: f32) {
        let allowed = self.transfer.is_none()
            && self.turn.is_none()
            && self.hang_trunk.is_none()
            && self.trunk_weights(env).iter().all(|&w| w == 0.0);
        let step = SHIFT_GAIN_RATE * dt;
        self.shift_gain = if !allowed || short > SHIFT_SHORT_M {
            (self.shift_gain - step).max(0.0)
        } else {
            (self.shift_gain + step).min(1.0)
        };
    }

    /// How far the last solve left the holding claw farthest from its grip (m).
    fn holding_short(&self) -> f32 {
        self.limbs
            .iter()
            .filter(|l| l.phase != LimbPhase::Swinging)
            .map(|l| l.effector.distance(l.grip.point))
            .fold(0.0, f32::max)
    }

    pub(super) fn body_for_targets(
        &self,
        env: &LocoView<'_>,
        t: &[Vec3; 4],
        offset: BodyOffset,
        side: BodySide,
    ) -> (Vec3, Quat) {
        let (f, up) = self.body_frame(env, t, offset, side);
        let mean = paws_mean(t);
        let (pos, rot) = (mean - up * offset.metres, rotation_from(f, up));
        match self.transfer {
            Some(tr) if offset.hind_back_m > 0.0 => {
                self.hindquarters_back(env, tr.trunk, pos, rot, offset.hind_back_m)
            }
            _ => (pos, rot),
        }
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
        env: &LocoView<'_>,
        t: &[Vec3; 4],
        offset: BodyOffset,
        side: BodySide,
    ) -> (Vec3, Vec3) {
        // Turning around at a branch end: the turn sets the heading.
        if let Some(frame) = self.turn_frame_now(t) {
            return frame;
        }
        let fwd = self.formula6_fwd(t);
        let mean = paws_mean(t);
        let s = env
            .scene()
            .support(self.limbs[Limb::LF.index()].grip.support);
        let on_trunk = self.fore_on_trunk(env);
        let up = if let Some(tr) = self.transfer {
            // Rolled by a power of the share (the roll leads the limbs a
            // little), and pushed off the trunk mid-transfer so the body
            // clears it while the hind limbs are still on the branch.
            let r = offset.trunk_share.powf(TRANSFER_ROLL_POWER);
            let hang = self.hang_up(fwd, self.hang_roll(env, fwd, mean, offset.metres));
            hang * (1.0 - r) - tr.side * r - tr.away * (TRANSFER_AWAY * 4.0 * r * (1.0 - r))
        } else if on_trunk {
            let a = project(s, mean);
            let body_side = match side {
                BodySide::Body => self.body_pos - a.point,
                BodySide::Grips => mean - a.point,
            };
            -(body_side - fwd * fwd.dot(body_side)).unit_or(self.body_rot * Vec3::Y * -1.0)
        } else {
            // On branches: below them, clear of the trunks they meet.
            self.hang_up(fwd, self.hang_roll(env, fwd, mean, offset.metres))
        };
        let up = (up - fwd * fwd.dot(up)).unit_or(self.body_rot * Vec3::Y);
        (fwd, up)
    }

    /// Formula 6 for IK targets `t`: the average of the hind → fore
    /// directions of both sides, continuous in the targets (a side whose
    /// grips come within [`FORMULA6_SIDE_M`] counts less, see
    /// [`formula6_side`] and [`formula6_heading`]).
    pub(super) fn formula6_fwd(&self, t: &[Vec3; 4]) -> Vec3 {
        let (lf, rf, lh, rh) = (
            t[Limb::LF.index()],
            t[Limb::RF.index()],
            t[Limb::LH.index()],
            t[Limb::RH.index()],
        );
        formula6_heading(
            formula6_side(rf - rh) + formula6_side(lf - lh),
            self.body_rot * Vec3::Z,
        )
    }

    /// How far the body (heading `fwd`, paws' mean `mean`, `metres` below
    /// it) rolls about its branch to clear a trunk, as a share of
    /// [`HANG_MAX_ROLL`] (signed: + toward heading × up): in a transfer
    /// under way, from its trunk; after a transfer onto a branch, from the trunk left
    /// ([`Sloth::hang_trunk`]); else none (rolling from any trunk a branch
    /// held meets, a crowd's sloths walking past trunks slipped grips by
    /// 2 cm). From that trunk: none unless the body hanging below the branch
    /// would come within [`hang_clearance_m`](crate::LocomotionConfig::hang_clearance_m) of it, all where it would touch
    /// it, and only heading out from it ([`HANG_OUT_COS`]). Continuous in
    /// the paws: the body never jumps between frames or stance checks.
    fn hang_roll(&self, env: &LocoView<'_>, fwd: Vec3, mean: Vec3, metres: f32) -> f32 {
        let roll = self.hang_roll_from(env, fwd, mean, metres, None);
        match self.approach_trunk(env) {
            Some(trunk) => {
                (roll + self.hang_roll_from(env, fwd, mean, metres, Some(trunk))).clamp(-1.0, 1.0)
            }
            None => roll,
        }
    }

    /// [`Self::hang_roll`] from the trunk of a transfer under way or the
    /// trunk left ([`Sloth::hang_trunk`]); or, given `approach`, from the
    /// trunk the body approaches alongside ([`Sloth::approach_trunk`]): to
    /// the body's own side, in full where the branch it holds runs within
    /// [`APPROACH_ALONG_FULL_SIN`] of the trunk's axis, none beyond
    /// [`APPROACH_ALONG_NONE_SIN`].
    fn hang_roll_from(
        &self,
        env: &LocoView<'_>,
        fwd: Vec3,
        mean: Vec3,
        metres: f32,
        approach: Option<SupportId>,
    ) -> f32 {
        // A transfer only set up by a search (no limb across yet)
        // rolls nothing: one that is not taken leaves no jump behind.
        // Nor does a tail-first one onto a trunk (`Sloth::descends_tail_first`):
        // the body heads out from the trunk there all along, so it would roll
        // the moment the first hind limb lifts off toward the trunk, a jump
        // the step's checks (drawn before it) never saw.
        // Under way: a limb holds its target, or limbs hold its trunk and
        // another support (a neighbour a step went onto off the target, where
        // the transfer goes on: `transfer_not_taken`), so the roll neither
        // drops nor returns as a limb lifts off the target or lands off it.
        let under_way = self.transfer.filter(|tr| {
            let holds =
                |f: &dyn Fn(SupportId) -> bool| self.limbs.iter().any(|l| f(l.grip.support));
            (holds(&|s| s == tr.to) || (holds(&|s| s == tr.trunk) && holds(&|s| s != tr.trunk)))
                && !(tr.to == tr.trunk && tr.dir < 0.0)
        });
        // Leaving the trunk for a branch (a transfer onto a branch, or
        // still rolled after one): the trunk is the one the branch leaves,
        // behind the body at the branch's root (see the roll's side below).
        let (trunk, leaving) = match (approach, under_way, self.hang_trunk) {
            (Some(trunk), ..) => (trunk, true),
            (None, Some(tr), _) => (tr.trunk, tr.to != tr.trunk),
            (None, None, Some(trunk)) if !self.fore_on_trunk(env) => (trunk, true),
            _ => return 0.0,
        };
        let scene = env.scene();
        let up0 = (Vec3::Y - fwd * fwd.dot(Vec3::Y)).unit_or(Vec3::Y);
        let lateral = fwd.cross(Vec3::Y).unit_or_zero();
        let own_side = if lateral.dot(self.hang_side) >= 0.0 {
            1.0
        } else {
            -1.0
        };
        let pos = mean - up0 * metres;
        let rot = rotation_from(fwd, up0);
        let torso = [
            pos + rot * env.rig.torso_ms[0],
            pos + rot * env.rig.torso_ms[1],
        ];
        // The box the torso capsule grown by the clearance fills: a trunk's
        // box apart from it is too far to matter (most trunks, most frames).
        let clearance = env.cfg.hang_clearance_m;
        if !torso_box_meets(env, torso, clearance, trunk) {
            return 0.0;
        }
        let s = scene.support(trunk);
        let depth = torso_penetration(s, env.adjacency.segment_chunks(trunk), torso, -clearance);
        if depth <= -clearance {
            return 0.0;
        }
        let a = project(s, mean);
        let radial = (mean - a.point) - a.tangent * a.tangent.dot(mean - a.point);
        let heading_out = match approach {
            // Alongside: the branch's direction across the trunk's axis (the
            // sine of its angle to the axis), from the branch's geometry
            // alone, so it holds while the heading turns in a transfer.
            Some(_) => {
                let across = self.approach_branch(env, trunk).map_or(1.0, |b| {
                    project(scene.support(b), mean)
                        .tangent
                        .dot(radial.unit_or_zero())
                        .abs()
                });
                ((APPROACH_ALONG_NONE_SIN - across)
                    / (APPROACH_ALONG_NONE_SIN - APPROACH_ALONG_FULL_SIN))
                    .clamp(0.0, 1.0)
            }
            None => (fwd.dot(radial.unit_or_zero()) / HANG_OUT_COS).clamp(0.0, 1.0),
        };
        let need = heading_out * ((depth + clearance) / clearance).clamp(0.0, 1.0);
        // Away from a trunk off to a side of the branch; toward the body's
        // own side of it where the trunk is below it (the fork), passing
        // through no roll in between (continuous). A trunk the body leaves
        // for a branch lies behind it, at the branch's root, and the body
        // clears it on either side: it keeps its own side. Measured as a
        // side, that trunk swung with the heading's yaw (the cosine of its
        // direction from the paws: 3.7° of yaw made a fifth of the way to
        // "beside") and halved the roll where it mattered most, below a
        // branch leaving the trunk steeply downward (trunk_branch at 150.8°,
        // 0.15 m: the hips hung 4.5 cm in the trunk, so every step out
        // along the branch was refused and the sloth stalled).
        if leaving {
            return need * own_side;
        }
        let trunk_side =
            (lateral.dot((mean - a.point).unit_or_zero()) / HANG_TRUNK_SIDE).clamp(-1.0, 1.0);
        need * (trunk_side + (1.0 - trunk_side.abs()) * own_side)
    }

    /// Goal mode, along a branch to the trunk the goal is on (a fore limb
    /// on a branch next to it, or a transfer onto it): that trunk. Below a branch that runs along the trunk (the wedge of
    /// branch_trunk above ~140°) the hanging body lies beside the trunk,
    /// with its back to it, and rolls clear of it to its own side
    /// ([`Self::hang_roll`]); unrolled, every step up the branch toward the
    /// junction put the body in the trunk (branch_trunk 155°, 0.2 m: the fore
    /// grips stalled 0.5 m below the junction, from where the second fore
    /// limb's trunk grip, across the branch, was 0.54 m off, past the
    /// 0.405 m a transfer step may reach). Wander mode is unchanged.
    pub(super) fn approach_trunk(&self, env: &LocoView<'_>) -> Option<SupportId> {
        if self.wander || self.hang_trunk.is_some() {
            return None;
        }
        let (gs, _) = self.goal?;
        let scene = env.scene();
        if scene.support(gs).kind != SupportKind::Trunk {
            return None;
        }
        // A transfer onto that trunk: rolled as on the approach until it
        // ends. Nothing else about the transfer or the travel direction
        // counts: a back-off (or a search starting a transfer during one)
        // had dropped the roll for a frame and the body jumped 29 cm
        // (branch_trunk 144.984°, 0.2 m: 10.6 cm into the trunk). Tail first
        // down a branch to the trunk (below ~90°) the branch runs far from
        // the trunk's axis, so it rolls nothing (see `APPROACH_ALONG_NONE_SIN`).
        if self.transfer.is_some_and(|tr| tr.to == gs) {
            return Some(gs);
        }
        [Limb::LF, Limb::RF]
            .map(|l| self.limbs[l.index()].grip.support)
            .into_iter()
            .any(|b| {
                scene.support(b).kind == SupportKind::Branch
                    && env.adjacency.neighbours(b).contains(&gs)
            })
            .then_some(gs)
    }

    /// A branch next to trunk `trunk` that a limb holds (the fore limbs' first).
    fn approach_branch(&self, env: &LocoView<'_>, trunk: SupportId) -> Option<SupportId> {
        let scene = env.scene();
        self.limbs.iter().map(|l| l.grip.support).find(|&b| {
            scene.support(b).kind == SupportKind::Branch
                && env.adjacency.neighbours(b).contains(&trunk)
        })
    }

    /// The way the body is rolled clear of a trunk now (across its heading,
    /// horizontal), if it is ([`Self::hang_roll`]).
    pub(super) fn rolled_toward(&self, env: &LocoView<'_>) -> Option<Vec3> {
        let t = self.targets();
        let fwd = self.formula6_fwd(&t);
        let mean = paws_mean(&t);
        let metres = body_offset(env, self.trunk_weights(env)).metres;
        let roll = self.hang_roll(env, fwd, mean, metres);
        (roll != 0.0).then(|| fwd.cross(Vec3::Y).unit_or_zero() * roll.signum())
    }

    /// At the start of a step search with no other limb in a step (and at
    /// spawn), while the body does not roll about its branch
    /// ([`Self::hang_roll`]): keeps the side of the branch it is on for the
    /// next roll ([`Sloth::hang_side`]): across the heading, horizontal, the
    /// way the body is off the branch's vertical plane (the right of the
    /// heading when it hangs in it: a choice that holds while the heading
    /// turns a little, unlike one read off the body's centimetres). The
    /// step checks that follow and the drawn body roll the same way.
    pub(super) fn keep_hang_side(&mut self, env: &LocoView<'_>) {
        let t = self.targets();
        let fwd = self.formula6_fwd(&t);
        let mean = paws_mean(&t);
        let metres = body_offset(env, self.trunk_weights(env)).metres;
        if self.hang_roll(env, fwd, mean, metres) != 0.0 {
            return;
        }
        self.hang_trunk = None;
        let lateral = fwd.cross(Vec3::Y).unit_or_zero();
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

    /// The body turned about its shoulders so that the hips move `back_m`
    /// straight off the trunk's axis: the hindquarters swing out clear of
    /// the trunk while the hind pair travels up onto the branch, and the
    /// planted fore limbs' roots hardly move.
    fn hindquarters_back(
        &self,
        env: &LocoView<'_>,
        trunk: SupportId,
        pos: Vec3,
        rot: Quat,
        back_m: f32,
    ) -> (Vec3, Quat) {
        let fore_ms = (Vec3::from(env.rig.roots_ms[Limb::LF.index()].position)
            + Vec3::from(env.rig.roots_ms[Limb::RF.index()].position))
            * 0.5;
        let shoulders = pos + rot * fore_ms;
        let hips = pos + rot * env.rig.hips_ms;
        let a = project(env.scene().support(trunk), hips);
        let radial = hips - a.point;
        let out = (radial - a.tangent * a.tangent.dot(radial)).unit_or_zero();
        let from = (hips - shoulders).unit_or_zero();
        let to = (hips + out * back_m - shoulders).unit_or_zero();
        if from == Vec3::ZERO || to == Vec3::ZERO {
            return (pos, rot);
        }
        let q = Quat::from_rotation_arc(from, to);
        (shoulders + q * (pos - shoulders), (q * rot).normalize())
    }

    /// How much each limb is on a trunk (1) or a branch (0); a swinging limb
    /// blends its old and new support as it travels, so the body offset that
    /// depends on it (see [`body_offset`]) changes continuously.
    pub(super) fn trunk_weights(&self, env: &LocoView<'_>) -> [f32; 4] {
        self.limb_map(|l| match l.phase {
            LimbPhase::Swinging => trunk_blend(env, l.from_support, l.grip.support, l.swing_t),
            _ => trunk_blend(env, l.grip.support, l.grip.support, 1.0),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sloth::test_util::{walk_presets, xorshift};

    /// The grip angle around a trunk is the configured one up to 0.2 m (bit
    /// for bit: the matrix's radii keep their figures) and grows beyond so
    /// the grip stays [`TRUNK_GRIP_LATERAL_MAX_M`] from the body's midplane.
    #[test]
    fn trunk_grip_angle_keeps_thick_trunk_grips_close() {
        let g = crate::LocomotionConfig::default()
            .trunk_grip_angle_deg
            .to_radians();
        for r in [0.05f32, 0.08, 0.15, 0.2] {
            assert_eq!(trunk_grip_angle(g, r).to_bits(), g.to_bits(), "r {r}");
        }
        for r in [0.201f32, 0.25, 0.3] {
            let a = trunk_grip_angle(g, r);
            assert!(a > g, "r {r}");
            assert!(
                (r * a.cos() - TRUNK_GRIP_LATERAL_MAX_M).abs() < 1e-6,
                "r {r}"
            );
        }
    }

    /// The body placed from the grips is continuous in them where two grips
    /// coincide (issue 24: a turn left a crowd sloth's LH 0.7 mm from LF's
    /// grip, and LH's first 5 mm of swing turned formula 6 by 40° and moved
    /// the body 8.6 cm): on every preset, for sloths walking, one limb put
    /// within 0.1 mm of another's grip (its side's other limb, or its
    /// girdle partner) and then moved 1 mm at random turns formula 6 and
    /// the body by a few hundredths of a radian at most and moves the body
    /// by a few millimetres. Where no side is shorter than
    /// [`FORMULA6_SIDE_M`] formula 6 is, bit for bit, the plain average of
    /// the two sides' unit directions.
    #[test]
    fn body_continuous_through_coinciding_grips() {
        let mut rnd = xorshift(0xf06);
        let mut unit = move || Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).unit_or(Vec3::X);
        let pairs = [
            (Limb::LH, Limb::LF),
            (Limb::LF, Limb::LH),
            (Limb::RH, Limb::RF),
            (Limb::RF, Limb::RH),
            (Limb::LH, Limb::RH),
            (Limb::RF, Limb::LF),
        ];
        let (mut probes, mut plain) = (0u32, 0u32);
        let (mut worst_f6, mut worst_turn, mut worst_move) = (0.0f32, 0.0f32, 0.0f32);
        walk_presets(15, |kind, view, frame, sloth| {
            let offset = body_offset(view, sloth.trunk_weights(view));
            let base = sloth.limbs.map(|l| l.grip.point);
            let (lf, rf, lh, rh) = (base[0], base[1], base[2], base[3]);
            if (lf - lh).length() >= FORMULA6_SIDE_M && (rf - rh).length() >= FORMULA6_SIDE_M {
                let old = ((rf - rh).unit_or_zero() + (lf - lh).unit_or_zero())
                    .unit_or(sloth.body_rot * Vec3::Z);
                assert_eq!(
                    sloth.formula6_fwd(&base),
                    old,
                    "{} frame {frame}",
                    kind.name()
                );
                plain += 1;
            }
            for (a, b) in pairs {
                let mut t = base;
                t[a.index()] = t[b.index()] + unit() * 1e-4;
                let mut moved = t;
                moved[a.index()] += unit() * 1e-3;
                let f6 = sloth
                    .formula6_fwd(&t)
                    .angle_between(sloth.formula6_fwd(&moved));
                let (p0, r0) = sloth.body_for_targets(view, &t, offset, BodySide::Body);
                let (p1, r1) = sloth.body_for_targets(view, &moved, offset, BodySide::Body);
                let (turn, shift) = (r0.angle_between(r1), p0.distance(p1));
                assert!(
                    f6 <= 0.03 && turn <= 0.03 && shift <= 0.01,
                    "{} frame {frame}: {a:?} onto {b:?}'s grip, moved 1 mm: formula 6 \
                     turns {f6} rad, the body {turn} rad and moves {shift} m",
                    kind.name()
                );
                worst_f6 = worst_f6.max(f6);
                worst_turn = worst_turn.max(turn);
                worst_move = worst_move.max(shift);
                probes += 1;
            }
        });
        println!(
            "{probes} probes: formula 6 turned {worst_f6} rad at most, the body {worst_turn} rad, \
             moved {worst_move} m; {plain} stances plain"
        );
        assert!(probes > 1000 && plain > 100, "{probes} {plain}");
    }
}
