//! The scene model: supports (trunks and branches) and the scene that holds them.
//!
//! Units are metres, +Y up, right-handed. A support is a polyline of nodes
//! (its axis) with a radius per node; consecutive nodes form tapered capsule
//! segments ("round cones"). Supports imported from arbitrary meshes keep that
//! mesh, which is then what traces hit; their polyline is the principal axis.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::SceneError;

/// A support counts as a trunk when it tilts more than this from horizontal
/// (unless explicitly tagged).
pub const TRUNK_TILT_DEG: f32 = 70.0;

/// Stable identifier of a support inside its scene (its index in `Scene::supports`).
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize,
)]
pub struct SupportId(pub u32);

impl std::fmt::Display for SupportId {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "#{}", self.0)
    }
}

/// Trunk or branch. Sloths climb trunks head-up and hang below branches.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SupportKind {
    /// Near-vertical support (tagged, or tilt > 70° from horizontal).
    Trunk,
    /// Everything else.
    Branch,
}

impl SupportKind {
    /// Classification by tilt (radians from horizontal, 0..=π/2).
    pub fn from_tilt(tilt_rad: f32) -> Self {
        if tilt_rad > TRUNK_TILT_DEG.to_radians() {
            SupportKind::Trunk
        } else {
            SupportKind::Branch
        }
    }

    /// Lower-case name (`trunk` / `branch`), as used in glTF extras.
    pub fn as_str(self) -> &'static str {
        match self {
            SupportKind::Trunk => "trunk",
            SupportKind::Branch => "branch",
        }
    }

    /// Parses `trunk` / `branch` (case-insensitive).
    pub fn parse(s: &str) -> Option<Self> {
        match s.to_ascii_lowercase().as_str() {
            "trunk" => Some(SupportKind::Trunk),
            "branch" => Some(SupportKind::Branch),
            _ => None,
        }
    }
}

/// Tilt of a direction from the horizontal plane, radians in `0..=π/2`.
/// A zero vector has tilt 0.
pub fn tilt_of(dir: Vec3) -> f32 {
    let len = dir.length();
    if len <= f32::EPSILON {
        return 0.0;
    }
    (dir.y.abs() / len).clamp(0.0, 1.0).asin()
}

/// Triangle geometry of an imported support, in world space.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TriMesh {
    /// Vertex positions (world space).
    pub positions: Vec<Vec3>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

/// One trunk or branch.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Support {
    /// Stable id (index in the scene).
    pub id: SupportId,
    /// Trunk or branch.
    pub kind: SupportKind,
    /// Whether `kind` came from an explicit tag rather than the tilt rule.
    pub tagged: bool,
    /// Optional human name (glTF node name).
    pub name: Option<String>,
    /// Axis polyline, world space, at least two nodes.
    pub nodes: Vec<Vec3>,
    /// Radius at each node (metres), same length as `nodes`.
    pub radii: Vec<f32>,
    /// Imported triangle surface, traced instead of the capsules when present.
    pub mesh: Option<TriMesh>,
}

impl Support {
    /// A support classified by tilt; the id is assigned by [`Scene::new`].
    pub fn new(nodes: Vec<Vec3>, radii: Vec<f32>) -> Self {
        let mut s = Support {
            id: SupportId(0),
            kind: SupportKind::Branch,
            tagged: false,
            name: None,
            nodes,
            radii,
            mesh: None,
        };
        s.kind = SupportKind::from_tilt(s.tilt());
        s
    }

    /// Sets an explicit kind tag (overrides the tilt rule).
    pub fn with_kind(mut self, kind: SupportKind) -> Self {
        self.kind = kind;
        self.tagged = true;
        self
    }

    /// Sets the name.
    pub fn with_name(mut self, name: impl Into<String>) -> Self {
        self.name = Some(name.into());
        self
    }

    /// Attaches a triangle surface.
    pub fn with_mesh(mut self, mesh: TriMesh) -> Self {
        self.mesh = Some(mesh);
        self
    }

    /// Overall tilt from horizontal (radians) of the chord first → last node.
    pub fn tilt(&self) -> f32 {
        match (self.nodes.first(), self.nodes.last()) {
            (Some(a), Some(b)) => tilt_of(*b - *a),
            _ => 0.0,
        }
    }

    /// Sum of segment lengths.
    pub fn length(&self) -> f32 {
        self.nodes.windows(2).map(|w| w[0].distance(w[1])).sum()
    }

    /// Number of capsule segments.
    pub fn segment_count(&self) -> usize {
        self.nodes.len().saturating_sub(1)
    }

    /// Label used in error messages: the name if any, else the id.
    pub fn label(&self) -> String {
        match &self.name {
            Some(n) => format!("{} ({n})", self.id),
            None => self.id.to_string(),
        }
    }

    /// Closest point on the axis polyline to `p`: (point, segment index, t in segment, radius there).
    pub fn closest_on_axis(&self, p: Vec3) -> (Vec3, usize, f32, f32) {
        let mut best = (self.nodes[0], 0, 0.0, self.radii[0]);
        let mut best_d2 = f32::INFINITY;
        for (i, w) in self.nodes.windows(2).enumerate() {
            let (q, t) = closest_on_segment(w[0], w[1], p);
            let d2 = q.distance_squared(p);
            if d2 < best_d2 {
                best_d2 = d2;
                let r = self.radii[i] + (self.radii[i + 1] - self.radii[i]) * t;
                best = (q, i, t, r);
            }
        }
        best
    }

    fn validate(&self) -> Result<(), SceneError> {
        let err = |field, detail: String| SceneError::InvalidSupport {
            support: self.label(),
            field,
            detail,
        };
        if self.nodes.len() < 2 {
            return Err(err(
                "nodes",
                format!("needs at least 2 nodes, has {}", self.nodes.len()),
            ));
        }
        if self.radii.len() != self.nodes.len() {
            return Err(err(
                "radii",
                format!(
                    "has {} radii for {} nodes",
                    self.radii.len(),
                    self.nodes.len()
                ),
            ));
        }
        for (i, n) in self.nodes.iter().enumerate() {
            if !n.is_finite() {
                return Err(err("nodes", format!("node {i} is not finite: {n}")));
            }
        }
        for (i, r) in self.radii.iter().enumerate() {
            if !r.is_finite() || *r <= 0.0 {
                return Err(err(
                    "radii",
                    format!("radius {i} must be finite and > 0, is {r}"),
                ));
            }
        }
        for (i, w) in self.nodes.windows(2).enumerate() {
            let len = w[0].distance(w[1]);
            if len < 1e-4 {
                return Err(err(
                    "nodes",
                    format!("segment {i} has zero length ({len} m)"),
                ));
            }
        }
        if let Some(mesh) = &self.mesh {
            if mesh.triangles.is_empty() {
                return Err(err("mesh", "mesh has no triangles".into()));
            }
            if let Some(p) = mesh.positions.iter().find(|p| !p.is_finite()) {
                return Err(err("mesh", format!("vertex is not finite: {p}")));
            }
            let n = mesh.positions.len() as u32;
            if mesh.triangles.iter().flatten().any(|&i| i >= n) {
                return Err(err("mesh", "triangle index out of range".into()));
            }
        }
        Ok(())
    }
}

/// Closest point on segment `a–b` to `p`, and its parameter in `0..=1`.
pub fn closest_on_segment(a: Vec3, b: Vec3, p: Vec3) -> (Vec3, f32) {
    let ab = b - a;
    let len2 = ab.length_squared();
    let t = if len2 > 0.0 {
        ((p - a).dot(ab) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (a + ab * t, t)
}

/// Axis-aligned bounds (world space, metres).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Bounds {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Bounds {
    /// Empty bounds (min = +inf, max = -inf).
    pub const EMPTY: Bounds = Bounds {
        min: Vec3::INFINITY,
        max: Vec3::NEG_INFINITY,
    };

    /// Grows to contain a sphere.
    pub fn grow_sphere(&mut self, c: Vec3, r: f32) {
        self.min = self.min.min(c - Vec3::splat(r));
        self.max = self.max.max(c + Vec3::splat(r));
    }

    /// Size along each axis.
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }
}

/// A set of supports plus their bounds. Immutable once built.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Scene {
    supports: Vec<Support>,
    bounds: Bounds,
}

impl Scene {
    /// Validates the supports, assigns ids `0..n` in order and computes bounds.
    ///
    /// Errors name the support and field: fewer than 2 nodes, NaN/inf node,
    /// radius ≤ 0 or NaN, zero-length segment, mesh without triangles.
    pub fn new(mut supports: Vec<Support>) -> Result<Scene, SceneError> {
        let mut bounds = Bounds::EMPTY;
        for (i, s) in supports.iter_mut().enumerate() {
            s.id = SupportId(i as u32);
            s.validate()?;
            for (n, r) in s.nodes.iter().zip(&s.radii) {
                bounds.grow_sphere(*n, *r);
            }
            if let Some(m) = &s.mesh {
                for p in &m.positions {
                    bounds.grow_sphere(*p, 0.0);
                }
            }
        }
        Ok(Scene { supports, bounds })
    }

    /// All supports, indexed by `SupportId.0`.
    pub fn supports(&self) -> &[Support] {
        &self.supports
    }

    /// One support.
    pub fn support(&self, id: SupportId) -> &Support {
        &self.supports[id.0 as usize]
    }

    /// World bounds of all supports.
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// Number of trunks and branches.
    pub fn counts(&self) -> (usize, usize) {
        let trunks = self
            .supports
            .iter()
            .filter(|s| s.kind == SupportKind::Trunk)
            .count();
        (trunks, self.supports.len() - trunks)
    }

    /// Total triangles of imported meshes.
    pub fn triangle_count(&self) -> usize {
        self.supports
            .iter()
            .filter_map(|s| s.mesh.as_ref())
            .map(|m| m.triangles.len())
            .sum()
    }

    /// Total axis length of all supports, per kind: (trunks, branches).
    pub fn total_length(&self) -> (f32, f32) {
        let mut out = (0.0, 0.0);
        for s in &self.supports {
            match s.kind {
                SupportKind::Trunk => out.0 += s.length(),
                SupportKind::Branch => out.1 += s.length(),
            }
        }
        out
    }
}
