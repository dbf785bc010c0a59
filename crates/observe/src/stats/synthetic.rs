use glam::{Quat, Vec3};
use slothsim_rig::Limb;
use slothsim_scene::SupportId;

use slothsim_gait::observe::{LimbObservation, SlothObservation};

/// Frame step, seconds.
pub const DT: f32 = 1.0 / 60.0;
/// Limb length, metres.
pub const LIMB_LENGTH: f32 = 0.4;

/// Limb `i` (by [`Limb::index`]) lifts off at frames `offsets[i] + k·cycle_frames`
/// and touches down `swing_frames` later. The body moves at `speed_mps`.
#[derive(Clone, Copy, Debug)]
pub struct Walk {
    pub cycle_frames: i64,
    pub swing_frames: i64,
    pub offsets: [i64; 4],
    pub speed_mps: f32,
    /// Frames 1..=frames are generated (frame k at time k·DT).
    pub frames: i64,
    /// The goal is this far along +Z.
    pub goal_z: f32,
}

impl Walk {
    /// Limbs lift off a quarter cycle apart in `order`, `order[0]` first
    /// (at frame 12); ten cycles long.
    pub fn new(order: [Limb; 4], cycle_frames: i64, swing_frames: i64, speed_mps: f32) -> Walk {
        let mut offsets = [0; 4];
        for (q, limb) in order.into_iter().enumerate() {
            offsets[limb.index()] = 12 + cycle_frames * q as i64 / 4;
        }
        Walk {
            cycle_frames,
            swing_frames,
            offsets,
            speed_mps,
            frames: 10 * cycle_frames,
            goal_z: 5.0,
        }
    }

    /// 2.4 s cycle (1.6 s contact, 0.8 s swing), 0.6 m stride, 0.25 m/s.
    fn with_order(order: [Limb; 4]) -> Walk {
        Walk::new(order, 144, 48, 0.25)
    }

    /// Diagonal sequence, phases RH 0, LF .25, LH .5, RF .75.
    pub fn dsdc() -> Walk {
        Walk::with_order([Limb::RH, Limb::LF, Limb::LH, Limb::RF])
    }

    /// Lateral sequence, phases RH 0, RF .25, LH .5, LF .75.
    pub fn lsdc() -> Walk {
        Walk::with_order([Limb::RH, Limb::RF, Limb::LH, Limb::LF])
    }

    pub fn contact_s(&self) -> f32 {
        (self.cycle_frames - self.swing_frames) as f32 * DT
    }

    pub fn swing_s(&self) -> f32 {
        self.swing_frames as f32 * DT
    }

    pub fn stride_m(&self) -> f32 {
        self.speed_mps * self.cycle_frames as f32 * DT
    }

    pub fn duty_factor(&self) -> f32 {
        (self.cycle_frames - self.swing_frames) as f32 / self.cycle_frames as f32
    }

    /// Time the body reaches the goal tolerance `tol`.
    pub fn goal_time_s(&self, tol: f32) -> f32 {
        (self.goal_z - tol) / self.speed_mps
    }

    fn body_z(&self, frame: i64) -> f32 {
        self.speed_mps * frame as f32 * DT
    }

    fn root_ws(&self, limb: Limb, frame: i64) -> Vec3 {
        let x = if limb.is_left() { 0.1 } else { -0.1 };
        let z = if limb.is_fore() { 0.3 } else { -0.3 };
        Vec3::new(x, 1.85, self.body_z(frame) + z)
    }

    /// Where the limb grips after touching down at `frame`: 0.2 m ahead
    /// of its root, on the underside of the branch (axis y = 2, r = 0.02).
    fn footfall_ws(&self, limb: Limb, frame: i64) -> Vec3 {
        let root = self.root_ws(limb, frame);
        let x = if limb.is_left() { 0.01 } else { -0.01 };
        Vec3::new(x, 1.98, root.z + 0.2)
    }

    pub fn observation(&self, frame: i64) -> SlothObservation {
        let t = frame as f32 * DT;
        let body_pos = Vec3::new(0.0, 1.85, self.body_z(frame));
        let limbs = Limb::ALL.map(|limb| {
            let p = (frame - self.offsets[limb.index()]).rem_euclid(self.cycle_frames);
            let planted = p >= self.swing_frames;
            let root_ws = self.root_ws(limb, frame);
            let (grip_ws, effector_ws) = if planted {
                let grip = self.footfall_ws(limb, frame - (p - self.swing_frames));
                (grip, grip)
            } else {
                let td = frame + (self.swing_frames - p);
                let to = self.footfall_ws(limb, td);
                let from = self.footfall_ws(limb, td - self.cycle_frames);
                let s = p as f32 / self.swing_frames as f32;
                let arc = Vec3::new(0.0, -0.05 * (std::f32::consts::PI * s).sin(), 0.0);
                (to, from.lerp(to, s) + arc)
            };
            LimbObservation {
                planted,
                grip_ws,
                effector_ws,
                root_ws,
                limb_length: LIMB_LENGTH,
                surface_gap: if planted { 0.0 } else { 0.05 },
                limit_violation: 0.0,
                support: SupportId(0),
            }
        });
        SlothObservation {
            time_s: t,
            gait_clock: frame.rem_euclid(self.cycle_frames) as f32 / self.cycle_frames as f32,
            body_pos,
            body_rot: Quat::IDENTITY,
            head_ws: body_pos + Vec3::new(0.0, 0.02, 0.45),
            hips_ws: body_pos + Vec3::new(0.0, 0.0, -0.3),
            on_trunk: false,
            limbs,
            penetration_m: 0.0,
            goal_distance_m: (self.goal_z - body_pos.z).abs(),
            goal_held: true,
            has_nan: false,
            residual_bw: 0.0,
        }
    }

    pub fn observations(&self) -> impl Iterator<Item = SlothObservation> + '_ {
        (1..=self.frames).map(|f| self.observation(f))
    }
}
