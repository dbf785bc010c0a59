//! Synthetic tree meshes made the way tree generators make them, with the
//! true axes and radii kept: test data for the mesh skeletoniser.
//!
//! A tree is a set of tubes along cubic Bézier splines, tapered, with
//! parallel-transport ring frames (`sides` vertices a ring, rings about one
//! radius apart): a curved trunk, optionally forking at its top into two
//! children that share the trunk's last ring (welded, as one surface), side
//! branches whose first ring starts on the parent's axis (they grow out of
//! the parent's surface without being welded to it, as Blender's Sapling and
//! most generators do), and sub-branches on those. Tips are open or capped.
//!
//! [`TreeLayout::Welded`] puts everything into one mesh (fork children
//! welded to the trunk); [`TreeLayout::PerBranch`] writes one mesh per tube.
//! [`write_glb`] writes meshes and the nodes that place them (instancing: a
//! mesh may be placed by several nodes).

use glam::{Mat4, Quat, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;
use serde_json::{Value, json};

/// How tubes are grouped into meshes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TreeLayout {
    /// One mesh; fork children share the parent's last ring.
    Welded,
    /// One mesh per tube.
    PerBranch,
}

/// Parameters of a generated tree.
#[derive(Clone, Debug)]
pub struct TreeParams {
    /// Trunk height (m).
    pub height: f32,
    /// Trunk radius at the base (m).
    pub trunk_radius: f32,
    /// Side branches on the trunk (and on each fork child, half as many).
    pub branches: u32,
    /// Sub-branches per side branch (at most).
    pub sub_branches: u32,
    /// Whether the trunk forks into two at its top.
    pub fork: bool,
    /// Vertices per ring.
    pub sides: u32,
    /// Mesh grouping.
    pub layout: TreeLayout,
}

impl Default for TreeParams {
    fn default() -> Self {
        TreeParams {
            height: 7.0,
            trunk_radius: 0.16,
            branches: 12,
            sub_branches: 2,
            fork: true,
            sides: 12,
            layout: TreeLayout::Welded,
        }
    }
}

/// The truth of one tube: its axis polyline (ring centres) and ring radii.
#[derive(Clone, Debug)]
pub struct TubeTruth {
    /// Ring centres, base to tip.
    pub axis: Vec<Vec3>,
    /// Ring radii (vertex distance from the centre).
    pub radii: Vec<f32>,
    /// The tube it grows from, if any.
    pub parent: Option<usize>,
    /// Radius of the parent where this tube starts (0 for the trunk).
    pub parent_radius: f32,
    /// Whether its first ring is the parent's last ring (welded fork).
    pub welded: bool,
}

/// A triangle mesh as a generator writes it.
#[derive(Clone, Debug, Default)]
pub struct RawMesh {
    /// Mesh name.
    pub name: String,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Triangles.
    pub triangles: Vec<[u32; 3]>,
}

/// A generated tree: the truth per tube and the meshes.
#[derive(Clone, Debug)]
pub struct GeneratedTree {
    /// Every tube, trunk first.
    pub tubes: Vec<TubeTruth>,
    /// The meshes (one, or one per tube).
    pub meshes: Vec<RawMesh>,
}

impl GeneratedTree {
    /// Total axis length of all tubes (m).
    pub fn axis_length(&self) -> f32 {
        self.tubes
            .iter()
            .map(|t| t.axis.windows(2).map(|w| w[0].distance(w[1])).sum::<f32>())
            .sum()
    }

    /// Total triangles.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.triangles.len()).sum()
    }
}

/// Points of a cubic Bézier from `p0` (direction `d0`) to `p3` (arriving
/// along `d1`), sampled `n + 1` times.
fn bezier(p0: Vec3, d0: Vec3, p3: Vec3, d1: Vec3, n: usize) -> Vec<Vec3> {
    let len = p0.distance(p3);
    let p1 = p0 + d0 * len / 3.0;
    let p2 = p3 - d1 * len / 3.0;
    (0..=n)
        .map(|i| {
            let t = i as f32 / n as f32;
            let u = 1.0 - t;
            p0 * (u * u * u) + p1 * (3.0 * u * u * t) + p2 * (3.0 * u * t * t) + p3 * (t * t * t)
        })
        .collect()
}

/// Resamples a dense polyline with steps of about `step(radius)`.
fn resample(
    dense: &[Vec3],
    r0: f32,
    r1: f32,
    step_of: impl Fn(f32) -> f32,
) -> (Vec<Vec3>, Vec<f32>) {
    let mut cum = vec![0.0f32];
    for w in dense.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    let total = *cum.last().unwrap_or(&0.0);
    let radius_at = |s: f32| r0 + (r1 - r0) * (s / total).clamp(0.0, 1.0);
    let point_at = |s: f32| {
        let i = cum.partition_point(|&c| c <= s).clamp(1, dense.len() - 1);
        let t = ((s - cum[i - 1]) / (cum[i] - cum[i - 1]).max(1e-9)).clamp(0.0, 1.0);
        dense[i - 1].lerp(dense[i], t)
    };
    let mut s = 0.0;
    let (mut axis, mut radii) = (Vec::new(), Vec::new());
    loop {
        axis.push(point_at(s));
        radii.push(radius_at(s));
        if s >= total {
            break;
        }
        s = (s + step_of(radius_at(s))).min(total);
        if total - s < 0.3 * step_of(radius_at(s)) {
            s = total;
        }
    }
    (axis, radii)
}

/// Ring frames by parallel transport along `axis`.
fn frames(axis: &[Vec3], first_u: Option<Vec3>) -> Vec<(Vec3, Vec3)> {
    let n = axis.len();
    let tangent = |i: usize| {
        let a = axis[i.saturating_sub(1)];
        let b = axis[(i + 1).min(n - 1)];
        (b - a).normalize_or(Vec3::Y)
    };
    let t0 = tangent(0);
    let mut u = first_u
        .map(|u| (u - t0 * u.dot(t0)).normalize_or(t0.any_orthonormal_vector()))
        .unwrap_or_else(|| t0.any_orthonormal_vector());
    let mut out = Vec::with_capacity(n);
    let mut prev_t = t0;
    for i in 0..n {
        let t = tangent(i);
        u = Quat::from_rotation_arc(prev_t, t) * u;
        u = (u - t * u.dot(t)).normalize_or(t.any_orthonormal_vector());
        out.push((u, t.cross(u)));
        prev_t = t;
    }
    out
}

/// Appends a tube to `mesh`. `first_ring`: indices of an existing ring to
/// start from (welded fork); `first_u`: the first ring's frame. Returns
/// the indices of the last ring and that ring's `u` vector.
fn add_tube(
    mesh: &mut RawMesh,
    axis: &[Vec3],
    radii: &[f32],
    sides: u32,
    first_ring: Option<&[u32]>,
    first_u: Option<Vec3>,
    cap: bool,
) -> (Vec<u32>, Vec3) {
    let fr = frames(axis, first_u);
    let mut prev: Vec<u32> = Vec::new();
    for (k, (&c, &r)) in axis.iter().zip(radii).enumerate() {
        let ring: Vec<u32> = match (k, first_ring) {
            (0, Some(ring)) => ring.to_vec(),
            _ => (0..sides)
                .map(|j| {
                    let (s, co) = (j as f32 / sides as f32 * std::f32::consts::TAU).sin_cos();
                    let (u, v) = fr[k];
                    mesh.positions.push(c + (u * co + v * s) * r);
                    (mesh.positions.len() - 1) as u32
                })
                .collect(),
        };
        if k > 0 {
            for j in 0..sides as usize {
                let j1 = (j + 1) % sides as usize;
                let (a, b, c2, d) = (prev[j], prev[j1], ring[j1], ring[j]);
                mesh.triangles.push([a, b, c2]);
                mesh.triangles.push([a, c2, d]);
            }
        }
        prev = ring;
    }
    if cap {
        let n = axis.len();
        let t = (axis[n - 1] - axis[n - 2]).normalize_or(Vec3::Y);
        mesh.positions.push(axis[n - 1] + t * radii[n - 1] * 0.5);
        let apex = (mesh.positions.len() - 1) as u32;
        for j in 0..sides as usize {
            let j1 = (j + 1) % sides as usize;
            mesh.triangles.push([prev[j], prev[j1], apex]);
        }
    }
    (prev, fr[fr.len() - 1].0)
}

/// Ring spacing for a tube of radius `r`: about one radius, 3–25 cm.
fn ring_step(r: f32) -> f32 {
    r.clamp(0.03, 0.25)
}

/// A random unit direction `elevation` radians above horizontal at `azimuth`.
fn dir_from(azimuth: f32, elevation: f32) -> Vec3 {
    Vec3::new(
        elevation.cos() * azimuth.cos(),
        elevation.sin(),
        elevation.cos() * azimuth.sin(),
    )
}

/// A curved tube from `start` heading `d0`, `length` long, bending by up to
/// `bend` radians toward a random side and `droop` radians downward.
fn spline(
    rng: &mut Pcg64Mcg,
    start: Vec3,
    d0: Vec3,
    length: f32,
    bend: f32,
    droop: f32,
) -> (Vec3, Vec3, Vec<Vec3>) {
    let side = d0.any_orthonormal_vector();
    let spin = Quat::from_axis_angle(d0, rng.random_range(0.0..std::f32::consts::TAU));
    let axis_of_bend = (spin * side).normalize();
    let d1 = Quat::from_axis_angle(axis_of_bend, rng.random_range(-bend..=bend)) * d0;
    let horiz = Vec3::new(d1.x, 0.0, d1.z);
    let d1 = if horiz.length() > 1e-3 {
        let down = horiz.normalize().cross(Vec3::Y).normalize();
        (Quat::from_axis_angle(down, droop) * d1).normalize()
    } else {
        d1
    };
    let chord = ((d0 + d1) * 0.5).normalize_or(d0);
    let end = start + chord * length;
    (d1, end, bezier(start, d0, end, d1, 64))
}

/// Generates one tree with its base at `base`.
pub fn generate_tree(params: &TreeParams, seed: u64, base: Vec3) -> GeneratedTree {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    let sides = params.sides.max(3);
    let mut tubes: Vec<TubeTruth> = Vec::new();
    let mut meshes: Vec<RawMesh> = Vec::new();
    let per_branch = params.layout == TreeLayout::PerBranch;
    let new_mesh = |meshes: &mut Vec<RawMesh>, name: String| {
        if per_branch || meshes.is_empty() {
            meshes.push(RawMesh {
                name,
                ..RawMesh::default()
            });
        }
        meshes.len() - 1
    };

    // Trunk: gently curved, tapering to 45 % (to 70 % if it forks).
    let trunk_len = if params.fork {
        params.height * 0.62
    } else {
        params.height
    };
    let lean = dir_from(rng.random_range(0.0..std::f32::consts::TAU), 1.45);
    let (_, _, dense) = spline(&mut rng, base, lean, trunk_len, 0.15, 0.0);
    let r0 = params.trunk_radius;
    let r_top = if params.fork { 0.7 * r0 } else { 0.45 * r0 };
    let (axis, radii) = resample(&dense, r0, r_top, ring_step);
    let m = new_mesh(&mut meshes, "trunk".into());
    let (last_ring, last_u) = add_tube(
        &mut meshes[m],
        &axis,
        &radii,
        sides,
        None,
        None,
        !params.fork,
    );
    tubes.push(TubeTruth {
        axis,
        radii,
        parent: None,
        parent_radius: 0.0,
        welded: false,
    });

    let mut stems = vec![0usize];
    if params.fork {
        let trunk = &tubes[0];
        let top = *trunk.axis.last().unwrap_or(&base);
        let n = trunk.axis.len();
        let t_top = (trunk.axis[n - 1] - trunk.axis[n - 2]).normalize_or(Vec3::Y);
        let az = rng.random_range(0.0..std::f32::consts::TAU);
        for k in 0..2 {
            let a = az + k as f32 * std::f32::consts::PI;
            let d0 = (t_top + dir_from(a, 0.0) * 0.35).normalize();
            let len = params.height - trunk_len + rng.random_range(-0.3..0.3);
            let (_, _, dense) = spline(&mut rng, top, d0, len, 0.3, 0.0);
            let (axis, radii) = resample(&dense, r_top, 0.35 * r_top, ring_step);
            let m = new_mesh(&mut meshes, format!("fork{k}"));
            // One mesh: share the trunk's last ring. Separate meshes: the
            // same ring positions, own vertices.
            let weld = (!per_branch).then_some(last_ring.as_slice());
            add_tube(
                &mut meshes[m],
                &axis,
                &radii,
                sides,
                weld,
                Some(last_u),
                true,
            );
            tubes.push(TubeTruth {
                axis,
                radii,
                parent: Some(0),
                parent_radius: r_top,
                welded: true,
            });
            stems.push(tubes.len() - 1);
        }
    }

    // Side branches on the stems, sub-branches on those.
    let mut count = 0;
    let mut queue: Vec<(usize, u32, f32, f32)> = stems
        .iter()
        .enumerate()
        .map(|(i, &t)| {
            let n = if i == 0 {
                params.branches
            } else {
                params.branches / 2
            };
            (t, n, if i == 0 { 0.25 } else { 0.15 }, 0.9)
        })
        .collect();
    let mut level_of = vec![0u32; tubes.len()];
    while let Some((parent, n, lo, hi)) = queue.pop() {
        let az0 = rng.random_range(0.0..std::f32::consts::TAU);
        for b in 0..n {
            let p = &tubes[parent];
            let len_p: f32 = p.axis.windows(2).map(|w| w[0].distance(w[1])).sum();
            let frac = lo + (hi - lo) * (b as f32 + rng.random_range(0.2..0.8)) / n as f32;
            // Point on the parent's axis at `frac` of its length.
            let (mut acc, mut k) = (0.0, 0);
            while k + 2 < p.axis.len() && acc + p.axis[k].distance(p.axis[k + 1]) < frac * len_p {
                acc += p.axis[k].distance(p.axis[k + 1]);
                k += 1;
            }
            let t = ((frac * len_p - acc) / p.axis[k].distance(p.axis[k + 1])).clamp(0.0, 1.0);
            let start = p.axis[k].lerp(p.axis[k + 1], t);
            let pr = p.radii[k] + (p.radii[k + 1] - p.radii[k]) * t;
            let tangent = (p.axis[k + 1] - p.axis[k]).normalize();
            let level = level_of[parent] + 1;
            // Around the parent, golden-angle azimuths; from 26° down to 40°
            // up (the limbs of many trees are level or hang).
            let az = az0 + b as f32 * 2.4;
            let out = {
                let h = dir_from(az, 0.0);
                (h - tangent * h.dot(tangent)).normalize_or(tangent.any_orthonormal_vector())
            };
            let elev: f32 = rng.random_range(-0.45..0.7);
            let d0 = (out * elev.cos() + Vec3::Y * elev.sin()).normalize();
            let len = if level == 1 {
                rng.random_range(2.0..4.0)
            } else {
                rng.random_range(0.8..1.6)
            };
            let droop = rng.random_range(0.0..0.5);
            let (_, _, dense) = spline(&mut rng, start, d0, len, 0.5, droop);
            let rb = pr * rng.random_range(0.4..0.6);
            let (axis, radii) = resample(&dense, rb, rb * rng.random_range(0.35..0.6), ring_step);
            let m = new_mesh(&mut meshes, format!("branch{count}"));
            count += 1;
            let cap = rng.random_bool(0.5);
            add_tube(&mut meshes[m], &axis, &radii, sides, None, None, cap);
            tubes.push(TubeTruth {
                axis,
                radii,
                parent: Some(parent),
                parent_radius: pr,
                welded: false,
            });
            level_of.push(level);
            if level == 1 && params.sub_branches > 0 {
                let k = rng.random_range(0..=params.sub_branches);
                queue.push((tubes.len() - 1, k, 0.3, 0.8));
            }
        }
    }
    GeneratedTree { tubes, meshes }
}

/// A node placing mesh `mesh` with `transform` (translation, rotation, uniform scale).
#[derive(Clone, Debug)]
pub struct Placement {
    /// Node name.
    pub name: String,
    /// Index into the meshes passed to [`write_glb`].
    pub mesh: usize,
    /// Translation.
    pub translation: Vec3,
    /// Rotation.
    pub rotation: Quat,
    /// Scale.
    pub scale: Vec3,
}

impl Placement {
    /// The node's matrix.
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

/// Writes `meshes` placed by `nodes` as a GLB file's bytes (positions as
/// f32, indices as u32, one primitive per mesh, all nodes at the root).
pub fn write_glb(meshes: &[RawMesh], nodes: &[Placement]) -> Vec<u8> {
    let mut bin: Vec<u8> = Vec::new();
    let mut views: Vec<Value> = Vec::new();
    let mut accessors: Vec<Value> = Vec::new();
    let mut json_meshes: Vec<Value> = Vec::new();
    for m in meshes {
        let (lo, hi) = m.positions.iter().fold(
            (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN)),
            |(lo, hi), p| (lo.min(*p), hi.max(*p)),
        );
        let off = bin.len();
        for p in &m.positions {
            for c in p.to_array() {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": off, "byteLength": bin.len() - off}));
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5126, "count": m.positions.len(),
            "type": "VEC3", "min": lo.to_array(), "max": hi.to_array(),
        }));
        let pos = accessors.len() - 1;
        let off = bin.len();
        for t in &m.triangles {
            for i in t {
                bin.extend_from_slice(&i.to_le_bytes());
            }
        }
        views.push(json!({"buffer": 0, "byteOffset": off, "byteLength": bin.len() - off}));
        accessors.push(json!({
            "bufferView": views.len() - 1, "componentType": 5125,
            "count": m.triangles.len() * 3, "type": "SCALAR",
        }));
        json_meshes.push(json!({
            "name": m.name,
            "primitives": [{"attributes": {"POSITION": pos}, "indices": accessors.len() - 1, "mode": 4}],
        }));
    }
    let json_nodes: Vec<Value> = nodes
        .iter()
        .map(|n| {
            json!({
                "name": n.name, "mesh": n.mesh,
                "translation": n.translation.to_array(),
                "rotation": n.rotation.to_array(),
                "scale": n.scale.to_array(),
            })
        })
        .collect();
    let root = json!({
        "asset": {"version": "2.0", "generator": "slothsim treegen"},
        "scene": 0,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": json_nodes,
        "meshes": json_meshes,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    let json = serde_json::to_vec(&root).unwrap_or_default();
    crate::gltf_io::glb_container(&json, &bin)
}

/// A forest of `trees` generated trees, each a distinct mesh set placed once,
/// on a grid `spacing` metres apart; plus `instances` extra placements of the
/// first tree's meshes (linked duplicates), rotated about +Y.
pub fn generate_forest_glb(
    params: &TreeParams,
    trees: u32,
    instances: u32,
    spacing: f32,
    seed: u64,
) -> (Vec<u8>, Vec<GeneratedTree>) {
    let mut meshes: Vec<RawMesh> = Vec::new();
    let mut nodes: Vec<Placement> = Vec::new();
    let mut out = Vec::new();
    let total = trees + instances;
    let side = (total as f32).sqrt().ceil().max(1.0) as u32;
    let spot = |i: u32| {
        Vec3::new(
            (i % side) as f32 * spacing,
            0.0,
            (i / side) as f32 * spacing,
        )
    };
    let mut first_tree_meshes = 0..0;
    for t in 0..trees {
        let tree = generate_tree(params, seed.wrapping_add(t as u64 * 7919), Vec3::ZERO);
        let first = meshes.len();
        for (k, m) in tree.meshes.iter().enumerate() {
            meshes.push(RawMesh {
                name: format!("tree{t}_{}", m.name),
                ..m.clone()
            });
            nodes.push(Placement {
                name: format!("tree{t}_{k}"),
                mesh: first + k,
                translation: spot(t),
                rotation: Quat::IDENTITY,
                scale: Vec3::ONE,
            });
        }
        if t == 0 {
            first_tree_meshes = first..meshes.len();
        }
        out.push(tree);
    }
    for i in 0..instances {
        let rot = Quat::from_rotation_y(1.3 * (i + 1) as f32);
        for m in first_tree_meshes.clone() {
            nodes.push(Placement {
                name: format!("copy{i}_{}", m - first_tree_meshes.start),
                mesh: m,
                translation: spot(trees + i),
                rotation: rot,
                scale: Vec3::ONE,
            });
        }
    }
    (write_glb(&meshes, &nodes), out)
}
