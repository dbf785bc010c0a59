//! Scenario presets for the thesis tests (thesis Table 7), each parameterised,
//! each with a start pose hint and a goal.
//!
//! Angle conventions (degrees at this edge, radians inside):
//! - `turn(a)`: interior angle at the joint between the branch the sloth is on
//!   and the next one, in the horizontal plane. 180° = straight on, 90° = a
//!   right-angle turn. Allowed 60–180°.
//! - `height_change(a)`: the same interior angle, in the vertical plane:
//!   a < 180° climbs (135° rises at 45°), a > 180° drops (200° falls at 20°).
//!   Allowed 110–220°.
//! - `branch_trunk(a)`: angle between the trunk's up axis and the branch
//!   direction away from the trunk: 90° horizontal, 60° rising away from the
//!   trunk, 140° falling away from it. Allowed 60–160°.

use glam::Vec3;
use serde::Serialize;

use crate::{Scene, SceneError, Support, SupportId, SupportKind};

/// Radius of preset branches: the laboratory pole's 40 mm diameter.
pub const PRESET_BRANCH_RADIUS: f32 = 0.02;
/// Height of preset branches above the ground.
pub const PRESET_HEIGHT: f32 = 2.0;

/// branch_end: the branch's length (m), the start's distance from its free
/// end (the sloth heads for the end) and the goal's (behind the start: it
/// turns around at the end and walks back).
pub const BRANCH_END_LENGTH: f32 = 4.0;
/// See [`BRANCH_END_LENGTH`].
pub const BRANCH_END_START: f32 = 1.0;
/// See [`BRANCH_END_LENGTH`].
pub const BRANCH_END_GOAL: f32 = 2.0;

/// The branch radii the branch_end preset takes (metres).
pub const BRANCH_END_RADIUS_RANGE: [f32; 2] = [0.02, 0.08];

/// The branch_trunk preset's trunk radius unless given (metres).
pub const BRANCH_TRUNK_RADIUS: f32 = 0.15;

/// The trunk radii the branch_trunk preset takes (metres): those at which
/// both transfers (branch → trunk and trunk → branch) were measured to pass
/// at every branch angle (issue 24; docs/scenarios.md "Thick trunks").
pub const BRANCH_TRUNK_RADIUS_RANGE: [f32; 2] = [0.05, 0.21];

/// The radii the trunk preset takes (its base radius, metres): those at
/// which climbing up, down and around was measured to pass (issue 24).
pub const TRUNK_RADIUS_RANGE: [f32; 2] = [0.1, 0.27];

/// Why a preset takes no thicker trunk (in the out-of-range error).
pub const THICK_TRUNK_REASON: &str = "the rig's limbs do not reach around a thicker trunk";

/// The preset families.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PresetKind {
    /// Two branches joined at an angle in the horizontal plane.
    Turn,
    /// Two parallel branches side by side; change from one to the other.
    Parallel,
    /// A vertical trunk with branches; climb it.
    Trunk,
    /// The next branch climbs or drops.
    HeightChange,
    /// A branch meeting a vertical trunk.
    BranchTrunk,
    /// The 4.2 m × 40 mm horizontal pole of the laboratory rig.
    Pole,
    /// A branch with a free end: walk to the end, turn around, walk back.
    BranchEnd,
}

impl PresetKind {
    /// Every preset.
    pub const ALL: [PresetKind; 7] = [
        PresetKind::Turn,
        PresetKind::Parallel,
        PresetKind::Trunk,
        PresetKind::HeightChange,
        PresetKind::BranchTrunk,
        PresetKind::Pole,
        PresetKind::BranchEnd,
    ];

    /// CLI name.
    pub fn name(self) -> &'static str {
        match self {
            PresetKind::Turn => "turn",
            PresetKind::Parallel => "parallel",
            PresetKind::Trunk => "trunk",
            PresetKind::HeightChange => "height_change",
            PresetKind::BranchTrunk => "branch_trunk",
            PresetKind::Pole => "pole",
            PresetKind::BranchEnd => "branch_end",
        }
    }

    /// Parses a CLI name (`height-change` also accepted).
    pub fn parse(name: &str) -> Result<Self, SceneError> {
        let n = name.replace('-', "_");
        PresetKind::ALL
            .into_iter()
            .find(|k| k.name() == n)
            .ok_or_else(|| SceneError::UnknownPreset(name.to_string()))
    }

    /// The parameter: (name, unit, allowed range, default).
    pub fn parameter(self) -> Option<(&'static str, &'static str, [f32; 2], f32)> {
        match self {
            PresetKind::Turn => Some(("angle", "deg", [60.0, 180.0], 135.0)),
            PresetKind::Parallel => Some(("gap", "m", [0.08, 0.5], 0.25)),
            PresetKind::Trunk => Some(("radius", "m", TRUNK_RADIUS_RANGE, 0.15)),
            PresetKind::HeightChange => Some(("angle", "deg", [110.0, 220.0], 160.0)),
            PresetKind::BranchTrunk => Some(("angle", "deg", [60.0, 160.0], 110.0)),
            PresetKind::Pole => None,
            PresetKind::BranchEnd => Some(("angle", "deg", [-30.0, 30.0], 0.0)),
        }
    }
}

/// The out-of-range error's reason for a trunk thicker than a preset takes
/// (`thicker`), else nothing.
fn thicker_reason(thicker: bool) -> String {
    if thicker {
        format!(": {THICK_TRUNK_REASON}")
    } else {
        String::new()
    }
}

/// Where and how a sloth starts.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct StartHint {
    /// The support to start on.
    pub support: SupportId,
    /// A point on the support's axis where the body should be centred.
    pub position: Vec3,
    /// Unit direction of travel along the support.
    pub forward: Vec3,
    /// Unit direction from the support's axis to the body (−Y below a branch).
    pub body_side: Vec3,
}

/// Where a sloth should get to.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Goal {
    /// The support the goal is on.
    pub support: SupportId,
    /// A point on that support's axis.
    pub point: Vec3,
    /// Reached when the body centre's closest axis point is within this distance of `point`
    /// (with a `side`, the body centre within this distance of where it
    /// would be facing the support from that side).
    pub tolerance: f32,
    /// On a trunk: the unit direction (perpendicular to the axis) from the
    /// axis toward the body at the goal; `None`: any side.
    pub side: Option<Vec3>,
}

/// A scenario: a small scene, a start and a goal.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Preset {
    /// Which family.
    pub kind: PresetKind,
    /// The parameter value used (degrees or metres), if the family has one.
    pub parameter: Option<f32>,
    /// branch_trunk: the trunk's radius (metres); `None` for other presets.
    pub trunk_radius: Option<f32>,
    /// branch_end: the branch's radius if not the default (metres).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub branch_radius: Option<f32>,
    /// The supports.
    #[serde(skip)]
    pub scene: Scene,
    /// Start hint.
    pub start: StartHint,
    /// Goal.
    pub goal: Goal,
}

impl Preset {
    /// Builds preset `kind` with its parameter (`None` = the default value).
    /// Errors name the parameter and the allowed range.
    pub fn new(kind: PresetKind, param: Option<f32>) -> Result<Preset, SceneError> {
        Preset::with_trunk_radius(kind, param, None)
    }

    /// [`Preset::new`] with the branch_trunk preset's trunk radius
    /// (`None`: [`BRANCH_TRUNK_RADIUS`]); an error names the field and its
    /// range when the radius is out of [`BRANCH_TRUNK_RADIUS_RANGE`] or given
    /// for another preset.
    pub fn with_trunk_radius(
        kind: PresetKind,
        param: Option<f32>,
        trunk_radius: Option<f32>,
    ) -> Result<Preset, SceneError> {
        let [rlo, rhi] = BRANCH_TRUNK_RADIUS_RANGE;
        let trunk_radius = match (kind, trunk_radius) {
            (PresetKind::BranchTrunk, None) => Some(BRANCH_TRUNK_RADIUS),
            (PresetKind::BranchTrunk, Some(v)) if v.is_finite() && (rlo..=rhi).contains(&v) => {
                Some(v)
            }
            (_, None) => None,
            (_, Some(v)) => {
                return Err(SceneError::OutOfRange {
                    field: "trunk_radius",
                    value: v as f64,
                    allowed: if kind == PresetKind::BranchTrunk {
                        format!(
                            "{rlo}..={rhi} m for preset `branch_trunk`{}",
                            thicker_reason(v > rhi)
                        )
                    } else {
                        format!(
                            "none: only preset `branch_trunk` takes a trunk radius, not `{}`",
                            kind.name()
                        )
                    },
                });
            }
        };
        let value = match (kind.parameter(), param) {
            (None, None) => None,
            (None, Some(v)) => {
                return Err(SceneError::OutOfRange {
                    field: "angle",
                    value: v as f64,
                    allowed: format!("none: preset `{}` takes no parameter", kind.name()),
                });
            }
            (Some((_, _, _, default)), None) => Some(default),
            (Some((name, unit, [lo, hi], _)), Some(v)) => {
                if !v.is_finite() || v < lo || v > hi {
                    return Err(SceneError::OutOfRange {
                        field: name,
                        value: v as f64,
                        allowed: format!(
                            "{lo}..={hi} {unit} for preset `{}`{}",
                            kind.name(),
                            thicker_reason(kind == PresetKind::Trunk && v > hi)
                        ),
                    });
                }
                Some(v)
            }
        };
        let p = value.unwrap_or(0.0);
        let r = PRESET_BRANCH_RADIUS;
        let h = PRESET_HEIGHT;
        let below = Vec3::NEG_Y;
        let (supports, start, goal) = match kind {
            PresetKind::Turn | PresetKind::HeightChange => {
                let a = (180.0 - p).to_radians();
                let dir2 = if kind == PresetKind::Turn {
                    Vec3::new(a.cos(), 0.0, a.sin())
                } else {
                    Vec3::new(a.cos(), a.sin(), 0.0)
                };
                let joint = Vec3::new(0.0, h, 0.0);
                let s0 = branch(vec![Vec3::new(-3.0, h, 0.0), joint], r, "branch_current");
                let s1 = branch(vec![joint, joint + dir2 * 3.0], r, "branch_next");
                (
                    vec![s0, s1],
                    start(0, Vec3::new(-2.3, h, 0.0), Vec3::X, below),
                    goal(1, joint + dir2 * 2.3),
                )
            }
            PresetKind::Parallel => {
                let a = branch(
                    vec![Vec3::new(-3.0, h, 0.0), Vec3::new(1.0, h, 0.0)],
                    r,
                    "branch_a",
                );
                let b = branch(
                    vec![Vec3::new(-1.0, h, p), Vec3::new(3.0, h, p)],
                    r,
                    "branch_b",
                );
                (
                    vec![a, b],
                    start(0, Vec3::new(-2.3, h, 0.0), Vec3::X, below),
                    goal(1, Vec3::new(2.3, h, p)),
                )
            }
            PresetKind::Trunk => {
                let trunk =
                    Support::new(vec![Vec3::ZERO, Vec3::new(0.0, 8.0, 0.0)], vec![p, p * 0.8])
                        .with_kind(SupportKind::Trunk)
                        .with_name("trunk");
                let b1 = branch(
                    vec![Vec3::new(0.0, 3.0, 0.0), Vec3::new(2.5, 3.3, 0.0)],
                    r,
                    "branch_low",
                );
                let b2 = branch(
                    vec![Vec3::new(0.0, 6.0, 0.0), Vec3::new(0.0, 6.2, -2.5)],
                    r,
                    "branch_high",
                );
                (
                    vec![trunk, b1, b2],
                    start(0, Vec3::new(0.0, 1.0, 0.0), Vec3::Y, Vec3::Z),
                    goal(0, Vec3::new(0.0, 5.0, 0.0)),
                )
            }
            PresetKind::BranchTrunk => {
                let trunk_r = trunk_radius.unwrap_or(BRANCH_TRUNK_RADIUS);
                let a = p.to_radians();
                let away = Vec3::new(a.sin(), a.cos(), 0.0);
                let junction = Vec3::new(0.0, 3.0, 0.0);
                let trunk = Support::new(
                    vec![Vec3::ZERO, Vec3::new(0.0, 6.0, 0.0)],
                    vec![trunk_r, trunk_r],
                )
                .with_kind(SupportKind::Trunk)
                .with_name("trunk");
                let b0 = junction + away * trunk_r * 0.6;
                let b = Support::new(vec![b0, junction + away * 3.0], vec![r, r])
                    .with_kind(SupportKind::Branch)
                    .with_name("branch");
                (
                    vec![trunk, b],
                    start(1, junction + away * 2.3, -away, below),
                    goal(0, Vec3::new(0.0, 1.5, 0.0)),
                )
            }
            PresetKind::BranchEnd => {
                // Inclined by `p` (rising toward its free end for p > 0).
                let a = p.to_radians();
                let dir = Vec3::new(a.cos(), a.sin(), 0.0);
                let base = Vec3::new(-2.5, h, 0.0);
                let tip = base + dir * BRANCH_END_LENGTH;
                (
                    vec![branch(vec![base, tip], r, "branch")],
                    start(0, tip - dir * BRANCH_END_START, dir, below),
                    goal(0, tip - dir * BRANCH_END_GOAL),
                )
            }
            PresetKind::Pole => {
                let pole = branch(
                    vec![Vec3::new(-2.1, h, 0.0), Vec3::new(2.1, h, 0.0)],
                    r,
                    "pole",
                );
                (
                    vec![pole],
                    start(0, Vec3::new(-1.6, h, 0.0), Vec3::X, below),
                    goal(0, Vec3::new(1.6, h, 0.0)),
                )
            }
        };
        Ok(Preset {
            kind,
            parameter: value,
            trunk_radius,
            branch_radius: None,
            scene: Scene::new(supports)?,
            start,
            goal,
        })
    }

    /// The branch_end preset at inclination `angle` (degrees, `None`: 0)
    /// on a branch of `radius` (metres, `None`: [`PRESET_BRANCH_RADIUS`]);
    /// an error names the field and its range ([`BRANCH_END_RADIUS_RANGE`]).
    pub fn branch_end(angle: Option<f32>, radius: Option<f32>) -> Result<Preset, SceneError> {
        let mut p = Preset::new(PresetKind::BranchEnd, angle)?;
        let Some(r) = radius else {
            return Ok(p);
        };
        let [lo, hi] = BRANCH_END_RADIUS_RANGE;
        if !(r.is_finite() && (lo..=hi).contains(&r)) {
            return Err(SceneError::OutOfRange {
                field: "branch_radius",
                value: r as f64,
                allowed: format!("{lo}..={hi} m for preset `branch_end`"),
            });
        }
        let b = p.scene.support(SupportId(0));
        p.scene = Scene::new(vec![branch(b.nodes.clone(), r, "branch")])?;
        p.branch_radius = Some(r);
        Ok(p)
    }

    /// Builds a preset by CLI name.
    pub fn by_name(name: &str, param: Option<f32>) -> Result<Preset, SceneError> {
        Preset::new(PresetKind::parse(name)?, param)
    }
}

fn branch(nodes: Vec<Vec3>, r: f32, name: &str) -> Support {
    let radii = vec![r; nodes.len()];
    Support::new(nodes, radii)
        .with_kind(SupportKind::Branch)
        .with_name(name)
}

fn start(support: u32, position: Vec3, forward: Vec3, body_side: Vec3) -> StartHint {
    StartHint {
        support: SupportId(support),
        position,
        forward,
        body_side,
    }
}

fn goal(support: u32, point: Vec3) -> Goal {
    Goal {
        support: SupportId(support),
        point,
        tolerance: 0.3,
        side: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_preset_builds_with_default_and_extremes() {
        for kind in PresetKind::ALL {
            let p = Preset::new(kind, None).unwrap();
            assert!(!p.scene.supports().is_empty());
            if let Some((_, _, [lo, hi], _)) = kind.parameter() {
                Preset::new(kind, Some(lo)).unwrap();
                Preset::new(kind, Some(hi)).unwrap();
            }
            // Start and goal lie on their supports' axes.
            for (sid, pt) in [
                (p.start.support, p.start.position),
                (p.goal.support, p.goal.point),
            ] {
                let s = p.scene.support(sid);
                let (q, ..) = s.closest_on_axis(pt);
                assert!(q.distance(pt) < 1e-4, "{:?} point off axis", kind);
            }
        }
    }

    #[test]
    fn branch_trunk_takes_a_trunk_radius() {
        for r in [0.08f32, 0.15, 0.2] {
            let p =
                Preset::with_trunk_radius(PresetKind::BranchTrunk, Some(117.5), Some(r)).unwrap();
            assert_eq!(p.trunk_radius, Some(r));
            let trunk = p.scene.support(p.goal.support);
            assert_eq!(trunk.kind, SupportKind::Trunk);
            let (.., radius) = trunk.closest_on_axis(Vec3::new(0.0, 2.0, 0.0));
            assert!((radius - r).abs() < 1e-6, "{radius} != {r}");
        }
        let default = Preset::new(PresetKind::BranchTrunk, None).unwrap();
        assert_eq!(default.trunk_radius, Some(BRANCH_TRUNK_RADIUS));
        let [lo, hi] = BRANCH_TRUNK_RADIUS_RANGE;
        let err = Preset::with_trunk_radius(PresetKind::BranchTrunk, None, Some(hi + 0.01))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("trunk_radius")
                && err.contains(&format!("{lo}..={hi}"))
                && err.contains(THICK_TRUNK_REASON),
            "{err}"
        );
        Preset::with_trunk_radius(PresetKind::BranchTrunk, None, Some(hi)).unwrap();
        let [lo, hi] = TRUNK_RADIUS_RANGE;
        let err = Preset::new(PresetKind::Trunk, Some(hi + 0.01))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("radius")
                && err.contains(&format!("{lo}..={hi}"))
                && err.contains(THICK_TRUNK_REASON),
            "{err}"
        );
        let err = Preset::new(PresetKind::Trunk, Some(lo - 0.01))
            .unwrap_err()
            .to_string();
        assert!(!err.contains(THICK_TRUNK_REASON), "{err}");
        let err = Preset::with_trunk_radius(PresetKind::Turn, None, Some(0.1))
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("trunk_radius") && err.contains("turn"),
            "{err}"
        );
        assert_eq!(
            Preset::new(PresetKind::Turn, None).unwrap().trunk_radius,
            None
        );
    }

    #[test]
    fn angles_outside_range_name_the_range() {
        let err = Preset::by_name("turn", Some(20.0)).unwrap_err().to_string();
        assert!(err.contains("angle") && err.contains("60..=180"), "{err}");
        assert!(Preset::by_name("pole", Some(90.0)).is_err());
        assert!(matches!(
            Preset::by_name("nope", None),
            Err(SceneError::UnknownPreset(_))
        ));
    }

    #[test]
    fn turn_angle_is_interior_angle() {
        for a in [60.0f32, 95.0, 135.0, 180.0] {
            let p = Preset::by_name("turn", Some(a)).unwrap();
            let s = p.scene.supports();
            let back = (s[0].nodes[0] - s[0].nodes[1]).normalize();
            let next = (s[1].nodes[1] - s[1].nodes[0]).normalize();
            assert!((back.angle_between(next).to_degrees() - a).abs() < 1e-3);
        }
    }

    #[test]
    fn height_change_climbs_below_180_and_drops_above() {
        let up = Preset::by_name("height_change", Some(135.0)).unwrap();
        assert!(up.goal.point.y > PRESET_HEIGHT + 1.0);
        let down = Preset::by_name("height_change", Some(200.0)).unwrap();
        assert!(down.goal.point.y < PRESET_HEIGHT - 0.5);
    }

    #[test]
    fn pole_is_the_laboratory_rig() {
        let p = Preset::by_name("pole", None).unwrap();
        let s = &p.scene.supports()[0];
        assert!((s.length() - 4.2).abs() < 1e-5);
        assert!((s.radii[0] * 2.0 - 0.040).abs() < 1e-6);
        assert_eq!(s.kind, SupportKind::Branch);
    }
}
