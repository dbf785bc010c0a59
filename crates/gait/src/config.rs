//! Locomotion configuration: every parameter SPEC names, thesis defaults, and
//! two gait profiles. Read from TOML (`[locomotion]` keys, unknown keys are
//! errors); degrees only here at the edge.

use serde::{Deserialize, Serialize};
use slothsim_rig::Limb;

/// Footfall sequence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Sequence {
    /// Diagonal sequence, diagonal couplets: RH → LF → LH → RF (normal travel).
    #[default]
    Dsdc,
    /// Lateral sequence: RH → RF → LH → LF (trunk ↔ branch transitions in the thesis).
    Lsdc,
}

/// Named gait profile: sets timing defaults.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Profile {
    /// The thesis model: one limb at a time, 1 s timeline × step_speed 0.5,
    /// 0.2 s between steps, 27 cm max step ⇒ free-ranging ~0.11 m/s.
    #[default]
    Free,
    /// SPEC Table 1 steady state at 0.2–0.3 m/s: swing fore 0.84 s, hind
    /// 0.67 s, contact fore 1.50 s, hind 1.66 s, stride ~0.60 m.
    Steady,
}

/// All locomotion parameters. Lengths in metres, times in seconds.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LocomotionConfig {
    /// Profile the defaults come from.
    pub profile: Profile,
    /// Footfall sequence.
    pub sequence: Sequence,
    /// Phase lag of the fore limb after its hind limb, as a fraction of the cycle (0.25 default).
    pub limb_phase: f32,
    /// Thesis `StepSpeed`: scales the 1 s step timeline (swing = timeline × step_speed).
    pub step_speed: f32,
    /// Thesis step timeline length.
    pub timeline_s: f32,
    /// Thesis `TimeBetweenSteps`: pause after each step.
    pub time_between_steps_s: f32,
    /// Swing durations (fore, hind); `None` = timeline_s × step_speed.
    pub swing_s: Option<[f32; 2]>,
    /// Gait cycle; `None` = 4 × (swing + time_between_steps) (one limb at a time).
    pub cycle_s: Option<f32>,
    /// Largest step of one limb (thesis model: 0.27 m).
    pub max_step_m: f32,
    /// Step search distance ahead of the current grip (thesis: 0.50 m).
    pub search_distance_m: f32,
    /// Back-off between step-search candidates (thesis: 1 cm).
    pub backoff_m: f32,
    /// Shortest forward step accepted.
    pub min_step_m: f32,
    /// Claw length: the hand joint sits this far back from the grip (formula 4);
    /// the rig's effector is the claw tip, which is placed on the surface.
    pub claw_length_m: f32,
    /// Body below the mean of the paws (formula 7). The thesis' 7 cm is for its
    /// UE model's proportions; the default 0.295 m was chosen on the scenario
    /// matrix for the default rig (0.27 m: no turn passes; 0.31 m: fewer). `None`
    /// = derive it from the rig (80 % of the neutral paw height).
    pub body_vertical_offset_m: Option<f32>,
    /// The same while on a trunk (blended by the share of limbs on a trunk):
    /// the hind limbs' joint limits leave them a wide workspace only with the
    /// body lower, which climbing down tail first needs. `None` = as on branches.
    pub trunk_body_offset_m: Option<f32>,
    /// Smoothing time constant of the body rotation (formula 6).
    pub body_smoothing_s: f32,
    /// Clearance of the swing arc above the support surface.
    pub swing_clearance_m: f32,
    /// Angle (degrees) of the grip around a trunk from the limb's side toward
    /// the body (0 = exactly at the side, as on branches).
    pub trunk_grip_angle_deg: f32,
    /// Fraction of reach a planted limb may use at the predicted stance (safety margin).
    pub max_reach_fraction: f32,
    /// Trace cap of the hind limbs when they follow onto a branch (thesis: 10 cm).
    pub hind_transfer_trace_cap_m: f32,
    /// Hindquarter "offset back" during transfers (thesis: 0.15 m).
    pub offset_back_m: f32,
    /// Fraction of reach a planted limb must keep at least (a grip closer to
    /// its root is too folded).
    pub min_reach_fraction: f32,
    /// Grips keep this far from a support's ends.
    pub end_margin_m: f32,
    /// Leg order: a hind grip stays this far behind every fore grip along the
    /// body, and a trailing fore grip this far ahead of every hind grip.
    pub leg_order_margin_m: f32,
    /// A side's fore and hind grips stay this far apart along the body
    /// (formula 6 takes the body's heading from them).
    pub same_side_spacing_m: f32,
    /// A limb never lands further ahead of the other limb of its girdle than
    /// this fraction of `max_step_m`, so that limb keeps a window to step into.
    pub max_girdle_lead: f32,
    /// Branch → trunk: how far a fore grip may climb ahead of the hind grips
    /// along the body.
    pub max_transfer_spread_m: f32,
    /// A step across a branch ↔ trunk junction may be this many `max_step_m`
    /// long: it reaches around the trunk, and the reach checks bound it.
    pub transfer_step_factor: f32,
    /// Branch → trunk: a fore limb takes the trunk at least this far above the
    /// hind limbs' grips (head up), and the hind limbs on the branch stay this
    /// far below the fore limbs on the trunk.
    pub head_up_margin_m: f32,
    /// On a branch by a trunk, a body hanging below the branch that would come
    /// within this distance of the trunk rolls about the branch clear of it,
    /// all the way (level with the branch) where it would touch it. With 0.08
    /// the scenario matrix's trunk_branch sweep passes the same angles, with
    /// 0.12 it loses 120° and 150°.
    pub hang_clearance_m: f32,
    /// A sloth stops (no grip) after this many step searches in a row found
    /// nothing (8: two full gait cycles in which no limb could move).
    pub stop_after_failed_searches: u8,
    /// Wander mode: a sloth stopped for want of a grip tries again after this
    /// long (sloths that boxed it in may have moved on).
    pub wander_retry_s: f32,
    /// Grip loads (issue 22, crate `slothsim-load`): body mass (SPEC: 6.5–10.6 kg).
    pub mass_kg: f32,
    /// Friction coefficient of pad and claw on a support.
    pub grip_mu: f32,
    /// Grip strength of one limb: the most it pulls toward the support's axis, in body weights.
    pub grip_strength_bw: f32,
    /// Push strength of one limb: the most it presses into a support, in body weights.
    pub push_strength_bw: f32,
    /// Weight of the squared residual wrench in the grip-load objective.
    pub load_w_residual: f32,
    /// Weight of the squared grip forces in the grip-load objective.
    pub load_w_force: f32,
    /// Release rule: a limb lifts only if the other grips carry the body with a residual
    /// of at most this many body weights (else it waits, at most 1 s; at least two grips
    /// stay anyway; the gait clock waits with it). Default 0.05 (the issue's): a
    /// 5,000-sloth crowd over 300 s stays within tolerance (penetration 9.4 mm, slip
    /// 4.2 mm) since the body's pull toward short claws repeats; the steady pole gait stays
    /// within 0.03 with the weight shift below (docs/grip-loads.md).
    pub release_residual_bw: f32,
    /// Weight shift: the most the body moves across its heading toward the grips of
    /// one side while the other side empties (m; 0 = off; docs/grip-loads.md). Default
    /// 0.04: the steady pole gait's same-side stances need 0.032.
    pub weight_shift_max_m: f32,
    /// Crowds (`run`, `bench`) solve each sloth's grip loads every this many frames,
    /// sloths staggered by id (1 = every frame; a lone scenario sloth always every
    /// frame). Default 1: every sloth every frame (+14 % of the crowd tick against every
    /// 4th frame; docs/grip-loads.md).
    pub crowd_load_every: u8,
}

impl Default for LocomotionConfig {
    fn default() -> Self {
        LocomotionConfig::profile(Profile::Free)
    }
}

/// A configuration problem: the field, its value and what is allowed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("locomotion config: `{field}` = {value} — {allowed}")]
pub struct ConfigError {
    /// Field name as in the TOML.
    pub field: &'static str,
    /// Value given.
    pub value: String,
    /// Allowed range.
    pub allowed: String,
}

impl LocomotionConfig {
    /// Defaults of a profile.
    pub fn profile(profile: Profile) -> Self {
        let free = LocomotionConfig {
            profile,
            sequence: Sequence::Dsdc,
            limb_phase: 0.25,
            step_speed: 0.5,
            timeline_s: 1.0,
            time_between_steps_s: 0.2,
            swing_s: None,
            cycle_s: None,
            max_step_m: 0.27,
            search_distance_m: 0.50,
            backoff_m: 0.01,
            min_step_m: 0.03,
            claw_length_m: 0.05,
            body_vertical_offset_m: Some(0.295),
            trunk_body_offset_m: Some(0.34),
            body_smoothing_s: 0.05,
            swing_clearance_m: 0.05,
            trunk_grip_angle_deg: 60.0,
            max_reach_fraction: 0.97,
            hind_transfer_trace_cap_m: 0.10,
            offset_back_m: 0.15,
            min_reach_fraction: 0.3,
            end_margin_m: 0.03,
            leg_order_margin_m: 0.0,
            same_side_spacing_m: 0.15,
            max_girdle_lead: 0.8,
            max_transfer_spread_m: 0.55,
            transfer_step_factor: 1.5,
            head_up_margin_m: 0.05,
            hang_clearance_m: 0.1,
            stop_after_failed_searches: 8,
            wander_retry_s: 5.0,
            mass_kg: 8.0,
            grip_mu: 0.6,
            grip_strength_bw: 1.0,
            push_strength_bw: 1.0,
            load_w_residual: 1.0e4,
            load_w_force: 1.0,
            release_residual_bw: 0.05,
            weight_shift_max_m: 0.04,
            crowd_load_every: 1,
        };
        match profile {
            Profile::Free => free,
            Profile::Steady => LocomotionConfig {
                swing_s: Some([0.84, 0.67]),
                cycle_s: Some(2.34),
                max_step_m: 0.60,
                search_distance_m: 0.65,
                ..free
            },
        }
    }

    /// Parses TOML; unknown keys are errors naming the key. A `profile` key
    /// selects the defaults the other keys override.
    pub fn from_toml(text: &str) -> Result<Self, String> {
        #[derive(Deserialize)]
        struct ProfileOnly {
            profile: Option<Profile>,
        }
        let table: toml::Table = toml::from_str(text).map_err(|e| e.to_string())?;
        let profile = toml::Value::Table(table.clone())
            .try_into::<ProfileOnly>()
            .ok()
            .and_then(|p| p.profile)
            .unwrap_or_default();
        let mut merged =
            toml::Table::try_from(LocomotionConfig::profile(profile)).map_err(|e| e.to_string())?;
        for (k, v) in table {
            merged.insert(k, v);
        }
        let cfg: LocomotionConfig = toml::Value::Table(merged)
            .try_into()
            .map_err(|e: toml::de::Error| e.to_string())?;
        Ok(cfg)
    }

    /// Swing duration of a limb.
    pub fn swing_duration(&self, limb: Limb) -> f32 {
        match self.swing_s {
            Some([fore, hind]) => {
                if limb.is_fore() {
                    fore
                } else {
                    hind
                }
            }
            None => self.timeline_s * self.step_speed,
        }
    }

    /// Gait cycle duration.
    pub fn cycle_duration(&self) -> f32 {
        self.cycle_s.unwrap_or_else(|| {
            let longest = self
                .swing_duration(Limb::LF)
                .max(self.swing_duration(Limb::LH));
            4.0 * (longest + self.time_between_steps_s)
        })
    }

    /// Phase (0..1) of each limb's lift-off within the cycle, indexed by `Limb::index`.
    pub fn phase_offsets(&self) -> [f32; 4] {
        let p = self.limb_phase;
        let mut out = [0.0; 4];
        let order = match self.sequence {
            Sequence::Dsdc => [
                (Limb::RH, 0.0),
                (Limb::LF, p),
                (Limb::LH, 0.5),
                (Limb::RF, 0.5 + p),
            ],
            Sequence::Lsdc => [
                (Limb::RH, 0.0),
                (Limb::RF, p),
                (Limb::LH, 0.5),
                (Limb::LF, 0.5 + p),
            ],
        };
        for (limb, ph) in order {
            out[limb.index()] = ph.rem_euclid(1.0);
        }
        out
    }

    /// Checks every field against its range and against the limb `reach`.
    pub fn validate(&self, reach: f32) -> Result<(), ConfigError> {
        let check = |field: &'static str, v: f32, lo: f32, hi: f32| {
            if v.is_finite() && v >= lo && v <= hi {
                Ok(())
            } else {
                Err(ConfigError {
                    field,
                    value: v.to_string(),
                    allowed: format!("allowed {lo}..={hi}"),
                })
            }
        };
        check("limb_phase", self.limb_phase, 0.0, 0.5)?;
        check("step_speed", self.step_speed, 0.05, 4.0)?;
        check("timeline_s", self.timeline_s, 0.05, 10.0)?;
        check("time_between_steps_s", self.time_between_steps_s, 0.0, 10.0)?;
        if let Some([f, h]) = self.swing_s {
            check("swing_s", f, 0.05, 10.0)?;
            check("swing_s", h, 0.05, 10.0)?;
        }
        if let Some(c) = self.cycle_s {
            check("cycle_s", c, 0.2, 60.0)?;
        }
        let longest = self
            .swing_duration(Limb::LF)
            .max(self.swing_duration(Limb::LH));
        if self.cycle_duration() < longest * 1.05 {
            return Err(ConfigError {
                field: "cycle_s",
                value: self.cycle_duration().to_string(),
                allowed: format!("must exceed the longest swing ({longest} s)"),
            });
        }
        check("max_step_m", self.max_step_m, 0.02, 2.0 * reach)?;
        if self.max_step_m > 2.0 * reach * self.max_reach_fraction {
            return Err(ConfigError {
                field: "max_step_m",
                value: self.max_step_m.to_string(),
                allowed: format!(
                    "a step longer than the reach allows ({:.3} m) can never be taken",
                    2.0 * reach * self.max_reach_fraction
                ),
            });
        }
        check("search_distance_m", self.search_distance_m, 0.02, 2.0)?;
        check("backoff_m", self.backoff_m, 0.001, 0.1)?;
        check("min_step_m", self.min_step_m, 0.0, self.max_step_m)?;
        check("claw_length_m", self.claw_length_m, 0.0, 0.2)?;
        if let Some(o) = self.body_vertical_offset_m {
            check("body_vertical_offset_m", o, 0.0, reach)?;
        }
        if let Some(o) = self.trunk_body_offset_m {
            check("trunk_body_offset_m", o, 0.0, reach)?;
        }
        check("body_smoothing_s", self.body_smoothing_s, 0.0, 5.0)?;
        check("swing_clearance_m", self.swing_clearance_m, 0.0, 0.5)?;
        check("trunk_grip_angle_deg", self.trunk_grip_angle_deg, 0.0, 80.0)?;
        check("max_reach_fraction", self.max_reach_fraction, 0.5, 1.0)?;
        check(
            "hind_transfer_trace_cap_m",
            self.hind_transfer_trace_cap_m,
            0.01,
            1.0,
        )?;
        check("offset_back_m", self.offset_back_m, 0.0, 0.5)?;
        check(
            "min_reach_fraction",
            self.min_reach_fraction,
            0.0,
            self.max_reach_fraction,
        )?;
        check("end_margin_m", self.end_margin_m, 0.0, 0.5)?;
        check("leg_order_margin_m", self.leg_order_margin_m, 0.0, 0.3)?;
        check("same_side_spacing_m", self.same_side_spacing_m, 0.0, 1.0)?;
        check("max_girdle_lead", self.max_girdle_lead, 0.0, 2.0)?;
        check(
            "max_transfer_spread_m",
            self.max_transfer_spread_m,
            0.0,
            2.0,
        )?;
        check("transfer_step_factor", self.transfer_step_factor, 1.0, 3.0)?;
        check("head_up_margin_m", self.head_up_margin_m, 0.0, 0.5)?;
        check("hang_clearance_m", self.hang_clearance_m, 0.001, 0.5)?;
        check(
            "stop_after_failed_searches",
            f32::from(self.stop_after_failed_searches),
            1.0,
            255.0,
        )?;
        check("wander_retry_s", self.wander_retry_s, 0.0, 600.0)?;
        check("mass_kg", self.mass_kg, 0.1, 1000.0)?;
        check("grip_mu", self.grip_mu, 1e-3, 10.0)?;
        check("grip_strength_bw", self.grip_strength_bw, 1e-3, 100.0)?;
        check("push_strength_bw", self.push_strength_bw, 1e-3, 100.0)?;
        check("load_w_residual", self.load_w_residual, 1e-6, 1e9)?;
        check("load_w_force", self.load_w_force, 1e-6, 1e9)?;
        check("release_residual_bw", self.release_residual_bw, 1e-4, 100.0)?;
        check("weight_shift_max_m", self.weight_shift_max_m, 0.0, 0.2)?;
        check(
            "crowd_load_every",
            f32::from(self.crowd_load_every),
            1.0,
            60.0,
        )?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn free_profile_is_one_limb_at_a_time() {
        let c = LocomotionConfig::default();
        assert!((c.swing_duration(Limb::LF) - 0.5).abs() < 1e-6);
        assert!((c.cycle_duration() - 2.8).abs() < 1e-6);
        let ph = c.phase_offsets();
        assert_eq!(ph[Limb::RH.index()], 0.0);
        assert_eq!(ph[Limb::LF.index()], 0.25);
        assert_eq!(ph[Limb::LH.index()], 0.5);
        assert_eq!(ph[Limb::RF.index()], 0.75);
        c.validate(0.4).unwrap();
    }

    #[test]
    fn toml_overrides_profile_and_rejects_unknown_keys() {
        let c = LocomotionConfig::from_toml("profile = \"steady\"\nmax_step_m = 0.5\n").unwrap();
        assert_eq!(c.profile, Profile::Steady);
        assert_eq!(c.max_step_m, 0.5);
        assert_eq!(c.swing_s, Some([0.84, 0.67]));
        let err = LocomotionConfig::from_toml("max_stepp = 0.5\n").unwrap_err();
        assert!(err.contains("max_stepp"), "{err}");
    }

    #[test]
    fn grip_load_parameters_are_validated_by_name() {
        type Spoil = fn(&mut LocomotionConfig);
        let cases: [(&str, Spoil); 11] = [
            ("mass_kg", |c| c.mass_kg = f32::NAN),
            ("mass_kg", |c| c.mass_kg = 0.0),
            ("grip_mu", |c| c.grip_mu = -0.1),
            ("grip_strength_bw", |c| c.grip_strength_bw = 0.0),
            ("push_strength_bw", |c| c.push_strength_bw = -1.0),
            ("load_w_residual", |c| c.load_w_residual = f32::INFINITY),
            ("load_w_force", |c| c.load_w_force = f32::NAN),
            ("release_residual_bw", |c| c.release_residual_bw = 0.0),
            ("weight_shift_max_m", |c| c.weight_shift_max_m = f32::NAN),
            ("weight_shift_max_m", |c| c.weight_shift_max_m = -0.01),
            ("crowd_load_every", |c| c.crowd_load_every = 0),
        ];
        for (field, spoil) in cases {
            let mut c = LocomotionConfig::default();
            spoil(&mut c);
            let err = c.validate(0.4).unwrap_err();
            assert_eq!(err.field, field);
            assert!(err.to_string().contains(field));
        }
    }

    #[test]
    fn max_step_longer_than_reach_is_rejected() {
        let c = LocomotionConfig {
            max_step_m: 1.5,
            ..Default::default()
        };
        let err = c.validate(0.4).unwrap_err();
        assert_eq!(err.field, "max_step_m");
    }
}
