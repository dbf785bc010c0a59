//! What a run records: per sample time and recorded sloth, its body and the
//! local rotations of the joints the simulation moves.

use glam::{Quat, Vec3};

/// One limb of one sloth at one sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LimbSample {
    /// The grip point (held when planted, swung to otherwise), world.
    pub grip: Vec3,
    /// In stance (holding its grip).
    pub planted: bool,
    /// The support of the grip.
    pub support: u32,
}

/// One recorded sloth at one sample time, read from the state after a tick.
#[derive(Clone, Debug, PartialEq)]
pub struct Sample {
    /// Simulated time (s).
    pub t: f32,
    /// Sloth id.
    pub id: u32,
    /// Body (model origin) position, world.
    pub body_pos: Vec3,
    /// Body rotation (model +Z forward, +Y toward the support).
    pub body_rot: Quat,
    /// Local rotations (relative to the parent joint) of the moved joints, in
    /// [`Recording::moved`] order.
    pub joints: Vec<Quat>,
    /// Limbs in `Limb::ALL` order (LF, RF, LH, RH).
    pub limbs: [LimbSample; 4],
    /// Kind of the support under the body (`trunk` when both fore limbs
    /// hold the same trunk, else `branch`).
    pub support_kind: &'static str,
}

/// The animation of one recorded sloth: one entry per sample time.
#[derive(Clone, Debug, Default)]
pub struct Track {
    /// Sloth id.
    pub id: u32,
    /// Root (body) translation per sample.
    pub translation: Vec<[f32; 3]>,
    /// Root (body) rotation per sample (unit, sign-continuous).
    pub rotation: Vec<[f32; 4]>,
    /// Per moved joint, its local rotation per sample (unit, sign-continuous).
    pub joints: Vec<Vec<[f32; 4]>>,
}

/// A recorded run: sample times and one [`Track`] per recorded sloth.
#[derive(Clone, Debug)]
pub struct Recording {
    /// Animation name (names the run).
    pub name: String,
    /// Skeleton indices of the joints the simulation moves (animated).
    pub moved: Vec<usize>,
    /// Sample times (s), strictly increasing.
    pub times: Vec<f32>,
    /// One track per recorded sloth.
    pub tracks: Vec<Track>,
}

/// `q` normalised and flipped onto `prev`'s hemisphere (the same rotation;
/// LINEAR interpolation then takes the short way).
fn continuous(q: Quat, prev: Option<&[f32; 4]>) -> [f32; 4] {
    let q = q.normalize();
    match prev {
        Some(p) if Quat::from_array(*p).dot(q) < 0.0 => (-q).to_array(),
        _ => q.to_array(),
    }
}

impl Recording {
    /// An empty recording of the sloths `ids` (tracks in that order).
    pub fn new(name: impl Into<String>, moved: Vec<usize>, ids: &[u32]) -> Self {
        let tracks = ids
            .iter()
            .map(|&id| Track {
                id,
                joints: vec![Vec::new(); moved.len()],
                ..Track::default()
            })
            .collect();
        Self {
            name: name.into(),
            moved,
            times: Vec::new(),
            tracks,
        }
    }

    /// Reserves room for `samples` more samples per track.
    pub fn reserve(&mut self, samples: usize) {
        self.times.reserve_exact(samples);
        for t in &mut self.tracks {
            t.translation.reserve_exact(samples);
            t.rotation.reserve_exact(samples);
            for j in &mut t.joints {
                j.reserve_exact(samples);
            }
        }
    }

    /// Starts a sample at time `t` (must be later than the last).
    pub fn begin_sample(&mut self, t: f32) {
        debug_assert!(self.times.last().is_none_or(|&l| t > l));
        self.times.push(t);
    }

    /// Adds track `track`'s values for the current sample.
    ///
    /// # Panics
    /// If `sample.joints` does not have one rotation per moved joint.
    pub fn push(&mut self, track: usize, sample: &Sample) {
        assert_eq!(
            sample.joints.len(),
            self.moved.len(),
            "one rotation per moved joint"
        );
        let t = &mut self.tracks[track];
        t.translation.push(sample.body_pos.to_array());
        let r = continuous(sample.body_rot, t.rotation.last());
        t.rotation.push(r);
        for (series, q) in t.joints.iter_mut().zip(&sample.joints) {
            let r = continuous(*q, series.last());
            series.push(r);
        }
    }

    /// Bytes of animation data (outputs) per track.
    pub fn track_bytes(&self) -> usize {
        self.times.len() * 4 * (3 + 4 + 4 * self.moved.len())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quaternions_are_unit_and_sign_continuous() {
        let mut rec = Recording::new("t", vec![3], &[7]);
        let limb = LimbSample {
            grip: Vec3::ZERO,
            planted: true,
            support: 0,
        };
        let mut angle = 0.0f32;
        for k in 0..100 {
            rec.begin_sample(k as f32);
            angle += 0.3;
            // Alternate signs and scales: the same rotations.
            let q = Quat::from_rotation_y(angle) * if k % 2 == 0 { 1.0 } else { -2.0 };
            rec.push(
                0,
                &Sample {
                    t: k as f32,
                    id: 7,
                    body_pos: Vec3::ZERO,
                    body_rot: q,
                    joints: vec![q],
                    limbs: [limb; 4],
                    support_kind: "branch",
                },
            );
        }
        let t = &rec.tracks[0];
        for series in [&t.rotation, &t.joints[0]] {
            for w in series.windows(2) {
                let (a, b) = (Quat::from_array(w[0]), Quat::from_array(w[1]));
                assert!((a.length() - 1.0).abs() < 1e-6);
                assert!(a.dot(b) >= 0.0, "sign flip between samples");
            }
        }
    }
}
