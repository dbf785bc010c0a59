//! The procedural forest: seeded, deterministic trees with trunks, kinked and
//! forked branches, and canopy bridges that join neighbouring trees so a sloth
//! can travel the whole forest.
//!
//! Same [`ForestConfig`] ⇒ bit-identical scene. [`default_forest`] needs no files.

use glam::{Quat, Vec2, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde::{Deserialize, Serialize};

use crate::{Scene, SceneError, Support, SupportKind};

/// Sizes the procedural forest. All lengths in metres, angles in degrees
/// (this is an edge of the program: config files).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct ForestConfig {
    /// Number of trees.
    pub trees: u32,
    /// Side of the square area the trees stand on, centred on the origin.
    pub area_m: f32,
    /// RNG seed.
    pub seed: u64,
    /// Trunk height range.
    pub trunk_height_m: [f32; 2],
    /// Trunk base radius range (0.1–0.4 m).
    pub trunk_radius_m: [f32; 2],
    /// Branches leaving each trunk (range, inclusive).
    pub branches_per_tree: [u32; 2],
    /// Branch base radius range (20–60 mm).
    pub branch_radius_m: [f32; 2],
    /// Branch length range.
    pub branch_length_m: [f32; 2],
    /// Angle between the trunk's up axis and a branch as it leaves (60–140°).
    pub branch_angle_deg: [f32; 2],
    /// Probability that a branch forks.
    pub fork_probability: f32,
    /// Extra canopy bridges beyond the spanning tree, per tree.
    pub extra_bridges_per_tree: f32,
}

impl Default for ForestConfig {
    fn default() -> Self {
        ForestConfig {
            trees: 64,
            area_m: 80.0,
            seed: 1,
            trunk_height_m: [8.0, 14.0],
            trunk_radius_m: [0.1, 0.4],
            branches_per_tree: [10, 16],
            branch_radius_m: [0.03, 0.06],
            branch_length_m: [2.0, 4.5],
            branch_angle_deg: [60.0, 140.0],
            fork_probability: 0.5,
            extra_bridges_per_tree: 0.5,
        }
    }
}

impl ForestConfig {
    /// Checks every field; errors name the field and its allowed range.
    pub fn validate(&self) -> Result<(), SceneError> {
        let range = |field: &'static str, v: [f32; 2], lo: f32, hi: f32| {
            for x in v {
                if !x.is_finite() || x < lo || x > hi || v[0] > v[1] {
                    return Err(SceneError::OutOfRange {
                        field,
                        value: x as f64,
                        allowed: format!("{lo}..={hi}, min ≤ max"),
                    });
                }
            }
            Ok(())
        };
        if self.trees == 0 || self.trees > 100_000 {
            return Err(SceneError::OutOfRange {
                field: "trees",
                value: self.trees as f64,
                allowed: "1..=100000".into(),
            });
        }
        if !self.area_m.is_finite() || self.area_m < 1.0 {
            return Err(SceneError::OutOfRange {
                field: "area_m",
                value: self.area_m as f64,
                allowed: "≥ 1".into(),
            });
        }
        range("trunk_height_m", self.trunk_height_m, 3.0, 60.0)?;
        range("trunk_radius_m", self.trunk_radius_m, 0.1, 0.4)?;
        range("branch_radius_m", self.branch_radius_m, 0.02, 0.06)?;
        range("branch_length_m", self.branch_length_m, 0.5, 20.0)?;
        range("branch_angle_deg", self.branch_angle_deg, 60.0, 140.0)?;
        let b = self.branches_per_tree;
        if b[0] > b[1] || b[1] > 64 {
            return Err(SceneError::OutOfRange {
                field: "branches_per_tree",
                value: b[1] as f64,
                allowed: "0..=64, min ≤ max".into(),
            });
        }
        for (field, p) in [
            ("fork_probability", self.fork_probability),
            ("extra_bridges_per_tree", self.extra_bridges_per_tree),
        ] {
            if !p.is_finite() || !(0.0..=1.0).contains(&p) {
                return Err(SceneError::OutOfRange {
                    field,
                    value: p as f64,
                    allowed: "0..=1".into(),
                });
            }
        }
        Ok(())
    }
}

/// The embedded default forest ([`ForestConfig::default`]).
pub fn default_forest() -> Scene {
    generate_forest(&ForestConfig::default()).expect("the default forest config is valid")
}

/// One tree's trunk as a straight, slightly leaning, tapering line.
struct Trunk {
    base: Vec3,
    up: Vec3,
    height: f32,
    r_base: f32,
    r_top: f32,
}

impl Trunk {
    fn axis_at(&self, h: f32) -> Vec3 {
        self.base + self.up * h
    }
    fn radius_at(&self, h: f32) -> f32 {
        self.r_base + (self.r_top - self.r_base) * (h / self.height).clamp(0.0, 1.0)
    }
}

/// Generates the forest for `cfg`. Deterministic per config.
pub fn generate_forest(cfg: &ForestConfig) -> Result<Scene, SceneError> {
    cfg.validate()?;
    let mut rng = Pcg64Mcg::seed_from_u64(cfg.seed);
    let positions = place_trees(cfg, &mut rng);
    let mut supports = Vec::new();
    let mut trunks = Vec::with_capacity(positions.len());

    for (ti, p) in positions.iter().enumerate() {
        let lean_dir = rng.random_range(0.0..std::f32::consts::TAU);
        let lean = rng.random_range(0.0f32..4.0).to_radians();
        let up =
            Quat::from_axis_angle(Vec3::new(lean_dir.cos(), 0.0, lean_dir.sin()), lean) * Vec3::Y;
        let r_base = rng.random_range(cfg.trunk_radius_m[0]..=cfg.trunk_radius_m[1]);
        let trunk = Trunk {
            base: Vec3::new(p.x, 0.0, p.y),
            up,
            height: rng.random_range(cfg.trunk_height_m[0]..=cfg.trunk_height_m[1]),
            r_base,
            r_top: (r_base * 0.6).max(0.1),
        };
        let nodes: Vec<Vec3> = (0..=4)
            .map(|i| trunk.axis_at(trunk.height * i as f32 / 4.0))
            .collect();
        let radii = (0..=4)
            .map(|i| trunk.radius_at(trunk.height * i as f32 / 4.0))
            .collect();
        supports.push(
            Support::new(nodes, radii)
                .with_kind(SupportKind::Trunk)
                .with_name(format!("tree{ti}_trunk")),
        );

        let n_branches = rng.random_range(cfg.branches_per_tree[0]..=cfg.branches_per_tree[1]);
        let azimuth0 = rng.random_range(0.0..std::f32::consts::TAU);
        for bi in 0..n_branches {
            // Spread branches up the trunk and around it (golden angle + jitter).
            let frac = (bi as f32 + rng.random_range(0.2f32..0.8)) / n_branches.max(1) as f32;
            let h = 2.0 + frac * (trunk.height - 2.5);
            let azimuth = azimuth0 + bi as f32 * 2.399_963 + rng.random_range(-0.3f32..0.3);
            let angle = rng.random_range(cfg.branch_angle_deg[0]..=cfg.branch_angle_deg[1]);
            let elevation = (90.0 - angle).to_radians();
            let dir = Vec3::new(
                azimuth.cos() * elevation.cos(),
                elevation.sin(),
                azimuth.sin() * elevation.cos(),
            );
            let start = trunk.axis_at(h) + horizontal(dir) * trunk.radius_at(h) * 0.6;
            let length = rng.random_range(cfg.branch_length_m[0]..=cfg.branch_length_m[1]);
            let radius = rng.random_range(cfg.branch_radius_m[0]..=cfg.branch_radius_m[1]);
            let (nodes, radii) = grow_branch(&mut rng, start, dir, length, radius);
            let fork_from = if rng.random_bool(cfg.fork_probability as f64) {
                Some(rng.random_range(1..nodes.len() - 1))
            } else {
                None
            };
            if let Some(k) = fork_from {
                let yaw =
                    rng.random_range(0.5f32..0.9) * if rng.random_bool(0.5) { 1.0 } else { -1.0 };
                let parent_dir = (nodes[k + 1] - nodes[k]).normalize();
                let fdir = Quat::from_rotation_y(yaw) * parent_dir;
                let flen = rng.random_range(1.0f32..2.5).min(length);
                let fr = (radii[k] * 0.8).max(0.02);
                let (fnodes, fradii) = grow_branch(&mut rng, nodes[k], fdir, flen, fr);
                supports.push(
                    Support::new(fnodes, fradii)
                        .with_kind(SupportKind::Branch)
                        .with_name(format!("tree{ti}_branch{bi}_fork")),
                );
            }
            supports.push(
                Support::new(nodes, radii)
                    .with_kind(SupportKind::Branch)
                    .with_name(format!("tree{ti}_branch{bi}")),
            );
        }
        trunks.push(trunk);
    }

    for (bi, (a, b)) in bridge_pairs(cfg, &positions, &mut rng)
        .into_iter()
        .enumerate()
    {
        let (ta, tb) = (&trunks[a], &trunks[b]);
        let ha = rng.random_range(0.5f32..0.8) * ta.height;
        let hb = rng.random_range(0.5f32..0.8) * tb.height;
        let dir_ab = horizontal(tb.axis_at(hb) - ta.axis_at(ha));
        let p0 = ta.axis_at(ha) + dir_ab * ta.radius_at(ha) * 0.6;
        let p1 = tb.axis_at(hb) - dir_ab * tb.radius_at(hb) * 0.6;
        let span = p0.distance(p1);
        let segments = ((span / 1.5).ceil() as usize).clamp(3, 24);
        let sag = rng.random_range(0.1f32..0.12) * span;
        let side = Vec3::Y.cross(dir_ab);
        let wobble = rng.random_range(-0.05f32..0.05) * span;
        let radius = rng.random_range(0.035f32..0.05);
        let nodes: Vec<Vec3> = (0..=segments)
            .map(|i| {
                let s = i as f32 / segments as f32;
                let bump = 4.0 * s * (1.0 - s);
                p0.lerp(p1, s) - Vec3::Y * sag * bump + side * wobble * bump
            })
            .collect();
        let radii = vec![radius; nodes.len()];
        supports.push(
            Support::new(nodes, radii)
                .with_kind(SupportKind::Branch)
                .with_name(format!("bridge{bi}_tree{a}_tree{b}")),
        );
    }
    Scene::new(supports)
}

/// Branches level out rather than grow below this height (metres).
const MIN_BRANCH_HEIGHT: f32 = 1.0;

/// Horizontal part of `v`, normalised (X if `v` is vertical).
fn horizontal(v: Vec3) -> Vec3 {
    Vec3::new(v.x, 0.0, v.z).try_normalize().unwrap_or(Vec3::X)
}

/// A kinked branch from `start` heading `dir`: 4–6 segments, each turning a
/// little in yaw and pitch (height changes), elevation kept within ±50°,
/// radius tapering to 60 % (never below 20 mm).
fn grow_branch(
    rng: &mut Pcg64Mcg,
    start: Vec3,
    dir: Vec3,
    length: f32,
    radius: f32,
) -> (Vec<Vec3>, Vec<f32>) {
    let segments = rng.random_range(4..=6);
    let seg_len = length / segments as f32;
    let mut yaw = dir.z.atan2(dir.x);
    let mut pitch = dir.y.clamp(-1.0, 1.0).asin();
    let mut nodes = vec![start];
    let mut radii = vec![radius];
    let r_tip = (radius * 0.6).max(0.02);
    for i in 1..=segments {
        if i > 1 {
            yaw += rng.random_range(-0.45f32..0.45);
            pitch = (pitch + rng.random_range(-0.25f32..0.25)).clamp(-0.87, 0.6);
        }
        let d = Vec3::new(
            yaw.cos() * pitch.cos(),
            pitch.sin(),
            yaw.sin() * pitch.cos(),
        );
        let mut p = *nodes.last().expect("nodes start non-empty") + d * seg_len;
        if p.y < MIN_BRANCH_HEIGHT {
            // Level out instead of growing into the ground.
            pitch = pitch.max(0.0);
            let d = Vec3::new(
                yaw.cos() * pitch.cos(),
                pitch.sin(),
                yaw.sin() * pitch.cos(),
            );
            p = *nodes.last().expect("nodes start non-empty") + d * seg_len;
        }
        nodes.push(p);
        radii.push(radius + (r_tip - radius) * i as f32 / segments as f32);
    }
    (nodes, radii)
}

/// Tree positions in the square area, rejection-sampled with a minimum spacing.
fn place_trees(cfg: &ForestConfig, rng: &mut Pcg64Mcg) -> Vec<Vec2> {
    let half = cfg.area_m * 0.5;
    let min_gap = (cfg.area_m / (cfg.trees as f32).sqrt() * 0.6).min(12.0);
    let mut out: Vec<Vec2> = Vec::with_capacity(cfg.trees as usize);
    while out.len() < cfg.trees as usize {
        let mut p = Vec2::ZERO;
        for attempt in 0..30 {
            p = Vec2::new(
                rng.random_range(-half..=half),
                rng.random_range(-half..=half),
            );
            if attempt == 29 || out.iter().all(|q| q.distance(p) >= min_gap) {
                break;
            }
        }
        out.push(p);
    }
    out
}

/// Pairs of trees joined by a canopy bridge: a minimum spanning tree over the
/// tree positions (so the forest is connected) plus a few short extra edges.
fn bridge_pairs(cfg: &ForestConfig, pos: &[Vec2], rng: &mut Pcg64Mcg) -> Vec<(usize, usize)> {
    let n = pos.len();
    if n < 2 {
        return Vec::new();
    }
    // Prim's algorithm, O(n²): fine for the forest sizes we use.
    let mut in_tree = vec![false; n];
    let mut best = vec![(f32::INFINITY, 0usize); n];
    let mut edges = Vec::with_capacity(n - 1);
    in_tree[0] = true;
    for j in 1..n {
        best[j] = (pos[0].distance(pos[j]), 0);
    }
    for _ in 1..n {
        let (j, _) = (0..n)
            .filter(|&j| !in_tree[j])
            .map(|j| (j, best[j].0))
            .fold(
                (usize::MAX, f32::INFINITY),
                |a, b| if b.1 < a.1 { b } else { a },
            );
        in_tree[j] = true;
        edges.push((best[j].1.min(j), best[j].1.max(j)));
        for k in 0..n {
            let d = pos[j].distance(pos[k]);
            if !in_tree[k] && d < best[k].0 {
                best[k] = (d, j);
            }
        }
    }
    let extra = (cfg.extra_bridges_per_tree * n as f32).round() as usize;
    let spacing = cfg.area_m / (n as f32).sqrt();
    for _ in 0..extra {
        let a = rng.random_range(0..n);
        let b = (0..n)
            .filter(|&b| b != a && !edges.contains(&(a.min(b), a.max(b))))
            .min_by(|&x, &y| pos[a].distance(pos[x]).total_cmp(&pos[a].distance(pos[y])));
        if let Some(b) = b
            && pos[a].distance(pos[b]) < 1.8 * spacing
        {
            edges.push((a.min(b), a.max(b)));
        }
    }
    edges
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_seed_same_forest_other_seed_differs() {
        let cfg = ForestConfig {
            trees: 8,
            area_m: 30.0,
            ..Default::default()
        };
        let a = generate_forest(&cfg).unwrap();
        let b = generate_forest(&cfg).unwrap();
        assert_eq!(a, b);
        let c = generate_forest(&ForestConfig { seed: 2, ..cfg }).unwrap();
        assert_ne!(a, c);
    }

    #[test]
    fn forest_respects_ranges() {
        let scene = default_forest();
        let (trunks, branches) = scene.counts();
        assert_eq!(trunks, 64);
        assert!(branches > 64 * 10);
        for s in scene.supports() {
            match s.kind {
                SupportKind::Trunk => {
                    assert!(s.radii[0] >= 0.1 && s.radii[0] <= 0.4, "{}", s.label());
                    assert!(s.length() > 5.0);
                }
                SupportKind::Branch => {
                    for r in &s.radii {
                        assert!((0.02..=0.06).contains(r), "{} radius {r}", s.label());
                    }
                    // Branches are branches by tilt too (≤ 70°) segment by segment.
                    for w in s.nodes.windows(2) {
                        assert!(
                            crate::tilt_of(w[1] - w[0]).to_degrees() <= 70.0,
                            "{}",
                            s.label()
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn bridges_connect_every_tree() {
        let cfg = ForestConfig {
            trees: 20,
            area_m: 60.0,
            ..Default::default()
        };
        let scene = generate_forest(&cfg).unwrap();
        let mut parent: Vec<usize> = (0..20).collect();
        fn find(p: &mut [usize], x: usize) -> usize {
            if p[x] != x {
                let r = find(p, p[x]);
                p[x] = r;
            }
            p[x]
        }
        for s in scene.supports() {
            let Some(name) = s.name.as_deref().filter(|n| n.starts_with("bridge")) else {
                continue;
            };
            let ids: Vec<usize> = name
                .split("_tree")
                .skip(1)
                .map(|x| x.parse().unwrap())
                .collect();
            let (a, b) = (find(&mut parent, ids[0]), find(&mut parent, ids[1]));
            parent[a] = b;
        }
        let root = find(&mut parent, 0);
        assert!(
            (0..20).all(|i| find(&mut parent, i) == root),
            "forest is not connected"
        );
    }

    #[test]
    fn bad_config_names_field() {
        let err = generate_forest(&ForestConfig {
            trunk_radius_m: [0.05, 0.3],
            ..Default::default()
        })
        .unwrap_err();
        assert!(err.to_string().contains("trunk_radius_m"), "{err}");
        let err = generate_forest(&ForestConfig {
            trees: 0,
            ..Default::default()
        })
        .unwrap_err();
        assert!(err.to_string().contains("trees"), "{err}");
    }
}
