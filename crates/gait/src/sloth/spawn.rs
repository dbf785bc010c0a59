//! Spawn: a sloth placed with all four limbs gripping around a point of a
//! support, the stance settled by a few rounds of body averaging and grips
//! slid to where each limb reaches best (the thesis' starting pose, §3.3;
//! SPEC "The algorithm": formulas 3 and 7 place the grips and the body).

use glam::Vec3;
use slothsim_rig::{CcdParams, ChainPose, Limb};
use slothsim_scene::{SupportId, SupportKind};

use crate::path::{axis_at, project};

use super::body::{grip_out, rotation_from, support_frame, trunk_grip_angle};
use super::checks::{STANCE_IK_TOLERANCE, reach_check};
use super::{Grip, LimbPhase, LimbState, LocoView, Search, Sloth, SpawnHint, Status};

impl Sloth {
    /// Places a sloth with all four limbs gripping around `hint`, body
    /// averaged, limbs solved. Grips are placed analytically on the surface.
    pub fn spawn(
        env: &LocoView<'_>,
        hint: &SpawnHint,
        goal: Option<(SupportId, Vec3, f32)>,
    ) -> Sloth {
        let scene = env.scene();
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
            joints: None,
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
            probe: false,
            cold_miss_ls: None,
            fallback: None,
        }; 4];
        let len = s.length();
        let margin = env.cfg.end_margin_m;
        for limb in Limb::ALL {
            // `along` metres ahead along the body's forward axis.
            let along = env.rig.neutral_tip_ms[limb.index()].z * 0.9;
            let u = (c.u + along * f.dot(c.tangent).signum()).clamp(margin, len - margin);
            let a = axis_at(s, u);
            // Goal mode (a goal given) as `Sloth::trunk_grip_angle`.
            let angle = env.cfg.trunk_grip_angle_deg.to_radians();
            let angle = if goal.is_some() {
                trunk_grip_angle(angle, a.radius)
            } else {
                angle
            };
            let out = grip_out(s.kind, limb, f, up, angle);
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
            body_pos: c.point - up * env.body_offset,
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
            stuck_stances: Default::default(),
            trail: Default::default(),
            wander: false,
            traces_queued: false,
            seed: 0,
            turns: 0,
            stalled_turns: 0,
            stall_from: None,
            resume_at: None,
            load: crate::load::LoadTrack::default(),
            backoff: None,
            replans: 0,
            hind_single: false,
            close_up: false,
            fine_rescan: 0,
            lone_fore_searches: 0,
            turn: None,
            stuck_cause: None,
            transfer: None,
            hind_back_scale: 1.0,
            shift_gain: 0.0,
            body_shift: Vec3::ZERO,
            hang_side: Vec3::ZERO,
            hang_trunk: None,
        };
        // Settle the stance: a few rounds of (body from grips; each grip slid
        // along the support to where its limb reaches it best, searched in
        // 1 cm steps around the current one).
        let cold = CcdParams {
            max_iterations: 256,
            ..*env.ccd
        };
        for _round in 0..3 {
            let (pos, rot) = sloth.averaged_body(env);
            sloth.body_pos = pos;
            sloth.body_rot = rot;
            for limb in Limb::ALL {
                let li = limb.index();
                let root = env.rig.root_ws(li, pos, rot);
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
                    let u = (u0 + k as f32 * 0.01).clamp(margin, len - margin);
                    let a = axis_at(s, u);
                    let p = a.point + out * a.radius;
                    let chain = &env.rig.chains[li];
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
        let (pos, rot) = sloth.averaged_body(env);
        sloth.body_pos = pos;
        sloth.body_rot = rot;
        sloth.keep_hang_side(env);
        for _ in 0..4 {
            sloth.solve_limbs_with(env, &cold);
        }
        sloth
    }
}
