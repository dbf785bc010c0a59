//! Recording a run for `slothsim-export` (`crowd.glb`, `trajectories.csv`):
//! which sloths ([`RecordSelection`]), when ([`Sampler`] at `hz` samples per
//! simulated second), and what ([`sample_of`]: body, the local rotations of
//! the 16 limb joints, grips).
//!
//! Sampling only reads the state after a tick, outside the stage timings: a
//! run's state and `state_hash` are the same with and without it (tested).

use std::time::{Duration, Instant};

use bevy_ecs::prelude::*;
use glam::Vec3;
use slothsim_export::{LimbSample, Recording, Sample, TrajectoryCsv};
use slothsim_gait::{LimbPhase, Sloth};
use slothsim_rig::{Limb, Rig};
use slothsim_scene::SupportKind;

use crate::crowd::Crowd;
use crate::world::{Locomotion, SlothId, SlothState};

/// Which sloths a run records (`--record`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RecordSelection {
    /// Every sloth.
    All,
    /// This many: the focus sloth and the rest spread over the forest (0 = none).
    Count(u32),
    /// These ids.
    Ids(Vec<u32>),
}

impl RecordSelection {
    /// Parses `all`, `none`, a count `N`, or ids `ID,ID,…` (one id: `ID,`).
    ///
    /// # Errors
    /// A message naming the bad value.
    pub fn parse(s: &str) -> Result<Self, String> {
        let s = s.trim();
        match s {
            "all" => return Ok(Self::All),
            "none" => return Ok(Self::Count(0)),
            _ => {}
        }
        let bad = |p: &str| {
            format!(
                "--record {s:?}: `{p}` is not a sloth id (expected all, none, a count N, or ids ID,ID,…)"
            )
        };
        if s.contains(',') {
            let ids = s
                .split(',')
                .map(str::trim)
                .filter(|p| !p.is_empty())
                .map(|p| p.parse::<u32>().map_err(|_| bad(p)))
                .collect::<Result<Vec<_>, _>>()?;
            if ids.is_empty() {
                return Err(format!("--record {s:?} names no sloth"));
            }
            let mut ids = ids;
            ids.sort_unstable();
            ids.dedup();
            Ok(Self::Ids(ids))
        } else {
            s.parse::<u32>().map(Self::Count).map_err(|_| bad(s))
        }
    }

    /// The recorded ids (sorted) among sloths `0..n` at `positions` (by
    /// id): all; the focus and the `count − 1` sloths farthest from those
    /// already picked (spread over the forest); or the given ids.
    ///
    /// # Errors
    /// A message naming an id that is not a sloth of the run.
    pub fn resolve(&self, positions: &[Vec3], focus: u32) -> Result<Vec<u32>, String> {
        let n = positions.len() as u32;
        match self {
            Self::All => Ok((0..n).collect()),
            Self::Ids(ids) => match ids.iter().find(|&&i| i >= n) {
                Some(i) => Err(format!(
                    "--record: sloth {i} does not exist (this run has sloths 0..{})",
                    n.saturating_sub(1)
                )),
                None => Ok(ids.clone()),
            },
            Self::Count(0) => Ok(Vec::new()),
            Self::Count(k) => Ok(spread(positions, focus.min(n.saturating_sub(1)), *k)),
        }
    }
}

/// `focus` and then, one at a time, the sloth farthest from all picked
/// (lowest id on ties): `k` sloths spread over the forest, sorted by id.
fn spread(positions: &[Vec3], focus: u32, k: u32) -> Vec<u32> {
    let n = positions.len();
    if n == 0 {
        return Vec::new();
    }
    let mut picked = vec![focus];
    let mut dist: Vec<f32> = positions
        .iter()
        .map(|p| p.distance_squared(positions[focus as usize]))
        .collect();
    while picked.len() < (k as usize).min(n) {
        let (best, _) =
            dist.iter()
                .enumerate()
                .fold((0, f32::NEG_INFINITY), |(bi, bd), (i, &d)| {
                    if d > bd { (i, d) } else { (bi, bd) }
                });
        picked.push(best as u32);
        for (d, p) in dist.iter_mut().zip(positions) {
            *d = d.min(p.distance_squared(positions[best]));
        }
    }
    picked.sort_unstable();
    picked
}

/// Skeleton indices of the joints the simulation moves: the four chain
/// joints of each limb, in `Limb::ALL` order (the order of [`Sample::joints`]).
pub fn moved_joints(rig: &Rig) -> Vec<usize> {
    Limb::ALL
        .iter()
        .flat_map(|&l| rig.limb_joints(l).joints)
        .collect()
}

/// What is recorded of sloth `s` now.
pub fn sample_of(s: &Sloth, loco: &Locomotion) -> Sample {
    let chains = &loco.rig.chains;
    let joints = (0..4)
        .flat_map(|li| (0..4).map(move |j| chains[li].local_rotation(&s.limbs[li].pose, j)))
        .collect();
    let limbs = s.limbs.map(|l| LimbSample {
        grip: l.grip.point,
        planted: l.phase != LimbPhase::Swinging,
        support: l.grip.support.0,
    });
    let scene = loco.traces.scene();
    let fore = s.limbs[Limb::LF.index()].grip.support;
    let on_trunk = scene.support(fore).kind == SupportKind::Trunk
        && s.limbs[Limb::RF.index()].grip.support == fore;
    Sample {
        t: s.time,
        id: s.id,
        body_pos: s.body_pos,
        body_rot: s.body_rot,
        joints,
        limbs,
        support_kind: if on_trunk { "trunk" } else { "branch" },
    }
}

/// Checks a sampling rate against the tick: finite, > 0 and at most one
/// sample per tick.
///
/// # Errors
/// A message naming `--record-hz`.
pub fn check_hz(hz: f64, dt: f32) -> Result<(), String> {
    let tick_hz = 1.0 / f64::from(dt);
    if !(hz.is_finite() && hz > 0.0) {
        return Err(format!("--record-hz must be a positive rate (got {hz})"));
    }
    if hz > tick_hz * (1.0 + 1e-6) {
        return Err(format!(
            "--record-hz {hz} is above the tick rate ({tick_hz:.3} Hz): at most one sample per tick"
        ));
    }
    Ok(())
}

/// Samples recorded sloths at `hz` into a [`Recording`] (and the rows of a
/// [`TrajectoryCsv`]), timing itself.
#[derive(Debug)]
pub struct Sampler {
    hz: f64,
    half_tick: f64,
    next: u64,
    entities: Vec<Entity>,
    /// What was recorded so far.
    pub recording: Recording,
    csv: Option<TrajectoryCsv>,
    cost: Duration,
}

impl Sampler {
    /// A sampler of the sloths `ids` (tracks in that order) at `hz` (checked
    /// with [`check_hz`]) for a run stepping by `dt`; `expected_s` of run
    /// time reserves memory up front.
    pub fn new(
        recording: Recording,
        hz: f64,
        dt: f32,
        expected_s: f32,
        csv: Option<TrajectoryCsv>,
    ) -> Self {
        let mut recording = recording;
        recording.reserve((f64::from(expected_s) * hz).ceil() as usize + 2);
        Self {
            hz,
            half_tick: f64::from(dt) * 0.5,
            next: 0,
            entities: Vec::new(),
            recording,
            csv,
            cost: Duration::ZERO,
        }
    }

    /// A sampler of a crowd's sloths `ids` (sorted, existing).
    pub fn for_crowd(
        crowd: &Crowd,
        rig: &Rig,
        ids: &[u32],
        name: &str,
        hz: f64,
        expected_s: f32,
        csv: Option<TrajectoryCsv>,
    ) -> Self {
        let t0 = Instant::now();
        let world = crowd.world();
        let mut by_id: Vec<(u32, Entity)> = world
            .try_query::<(Entity, &SlothId)>()
            .map(|mut q| q.iter(world).map(|(e, i)| (i.0, e)).collect())
            .unwrap_or_default();
        by_id.sort_unstable_by_key(|(i, _)| *i);
        let entities = ids
            .iter()
            .filter_map(|id| {
                by_id
                    .binary_search_by_key(id, |(i, _)| *i)
                    .ok()
                    .map(|k| by_id[k].1)
            })
            .collect();
        let recording = Recording::new(name, moved_joints(rig), ids);
        let mut s = Self::new(recording, hz, crowd.spec().dt, expected_s, csv);
        s.entities = entities;
        s.cost += t0.elapsed();
        s
    }

    /// Index of the sample time at or just before `t` (half a tick early
    /// counts: float time steps).
    fn slot(&self, t: f32) -> u64 {
        ((f64::from(t) + self.half_tick) * self.hz).floor().max(0.0) as u64
    }

    /// Whether a sample is due at time `t`; a run's first call always samples.
    fn due(&mut self, t: f32) -> bool {
        let k = self.slot(t);
        if self.recording.times.is_empty() || k >= self.next {
            self.next = k + 1;
            true
        } else {
            false
        }
    }

    fn take(&mut self, track: usize, s: &Sloth, loco: &Locomotion) {
        let sample = sample_of(s, loco);
        self.recording.push(track, &sample);
        if let Some(csv) = &mut self.csv {
            csv.row(&sample);
        }
    }

    /// Samples the crowd if a sample time is due: call at the start and
    /// after every step.
    pub fn after_tick(&mut self, crowd: &Crowd) {
        let t0 = Instant::now();
        let world = crowd.world();
        let loco = world.resource::<Locomotion>();
        let Some(time) = self
            .entities
            .first()
            .and_then(|&e| world.get::<SlothState>(e))
            .map(|s| s.0.time)
        else {
            return;
        };
        if !self.due(time) {
            self.cost += t0.elapsed();
            return;
        }
        self.recording.begin_sample(time);
        for k in 0..self.entities.len() {
            if let Some(s) = world.get::<SlothState>(self.entities[k]) {
                self.take(k, &s.0, loco);
            }
        }
        self.cost += t0.elapsed();
    }

    /// Samples a lone sloth (track 0) if a sample time is due.
    pub fn after_tick_sloth(&mut self, s: &Sloth, loco: &Locomotion) {
        let t0 = Instant::now();
        if self.due(s.time) {
            self.recording.begin_sample(s.time);
            self.take(0, s, loco);
        }
        self.cost += t0.elapsed();
    }

    /// Time spent sampling (reading the state, storing, CSV rows).
    pub fn cost(&self) -> Duration {
        self.cost
    }

    /// Samples per simulated second.
    pub fn hz(&self) -> f64 {
        self.hz
    }

    /// Sample times taken.
    pub fn samples(&self) -> usize {
        self.recording.times.len()
    }

    /// The recording and the CSV (still to be finished).
    pub fn finish(self) -> (Recording, Option<TrajectoryCsv>) {
        (self.recording, self.csv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn selections_parse() {
        assert_eq!(RecordSelection::parse("all"), Ok(RecordSelection::All));
        assert_eq!(
            RecordSelection::parse("none"),
            Ok(RecordSelection::Count(0))
        );
        assert_eq!(RecordSelection::parse("12"), Ok(RecordSelection::Count(12)));
        assert_eq!(
            RecordSelection::parse("5,3, 5"),
            Ok(RecordSelection::Ids(vec![3, 5]))
        );
        assert_eq!(
            RecordSelection::parse("7,"),
            Ok(RecordSelection::Ids(vec![7]))
        );
        for bad in ["", "x", "-1", "1,a", ",", "1.5"] {
            assert!(RecordSelection::parse(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn unknown_ids_are_refused() {
        let pos = vec![Vec3::ZERO; 4];
        let err = RecordSelection::Ids(vec![1, 9])
            .resolve(&pos, 0)
            .unwrap_err();
        assert!(err.contains("sloth 9 does not exist"), "{err}");
    }

    #[test]
    fn a_count_spreads_from_the_focus() {
        let pos: Vec<Vec3> = (0..10).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
        let ids = RecordSelection::Count(3).resolve(&pos, 4).unwrap();
        assert_eq!(ids, vec![0, 4, 9]);
        assert_eq!(
            RecordSelection::Count(50).resolve(&pos, 0).unwrap().len(),
            10
        );
    }

    #[test]
    fn rates_are_checked_against_the_tick() {
        let dt = 1.0 / 60.0;
        assert!(check_hz(30.0, dt).is_ok());
        assert!(check_hz(60.0, dt).is_ok());
        for bad in [0.0, -1.0, f64::NAN, f64::INFINITY, 61.0] {
            assert!(check_hz(bad, dt).is_err(), "{bad}");
        }
    }
}
