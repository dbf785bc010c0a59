//! Foreign meshes → supports: each glTF mesh is welded, split into connected
//! parts and skeletonised once (in mesh space); every node placing it then
//! gets its own supports from that skeleton (instancing), cut where the
//! skeleton is too thin to grip and where its tilt changes kind.

use std::collections::HashMap;

use glam::{Mat3, Mat4, Vec3};
use serde::Serialize;

use super::fit::{fit_part, split_parts, weld};
use super::skeleton::{Chain, skeletonise};
use crate::{Support, SupportKind, TriMesh, tilt_of};

/// Thinnest support a sloth grips (radius, m). The thesis measured its
/// sloths on a 40 mm pole (radius 20 mm), the thinnest support the gait is
/// validated on; the 5 cm claws then already reach more than halfway around
/// it (half the circumference is 63 mm), so thinner supports give the hands
/// nothing to hook against. Thinner runs of a skeleton are not used.
pub const MIN_GRIP_RADIUS_M: f32 = 0.02;
/// Shortest grippable run (m): a sloth plants fore and hind limbs about a
/// stride apart (thesis strides 0.21–0.83 m); a run shorter than the
/// shortest stride gives it nothing to stand on.
pub const MIN_GRIP_LENGTH_M: f32 = 0.3;
/// A run of one kind (trunk or branch by tilt) shorter than this takes the
/// kind of its longer neighbour, so a wobble does not split a support.
const MIN_KIND_RUN_M: f32 = 0.5;
/// Parts with fewer triangles are not tubes (a tube has at least 3 sides × 2).
const MIN_PART_TRIANGLES: usize = 6;
/// Plausible tree heights (m); outside, a warning asks about units.
const PLAUSIBLE_HEIGHT_M: (f32, f32) = (0.2, 150.0);

/// What an import made of each mesh and each node placing one.
#[derive(Clone, Debug, Default, Serialize)]
pub struct ImportReport {
    /// Per glTF mesh used by a node without `extras.slothsim`.
    pub meshes: Vec<MeshStats>,
    /// Per node placing such a mesh.
    pub instances: Vec<InstanceStats>,
    /// Warnings naming the node or mesh (degenerate, non-manifold, scale …).
    pub warnings: Vec<String>,
    /// Time spent welding and skeletonising meshes (ms).
    pub skeleton_ms: f64,
}

/// One skeletonised mesh.
#[derive(Clone, Debug, Serialize)]
pub struct MeshStats {
    /// glTF mesh index.
    pub mesh: usize,
    /// Mesh name.
    pub name: Option<String>,
    /// Triangles after welding (degenerate ones dropped).
    pub triangles: usize,
    /// Degenerate triangles dropped.
    pub degenerate: usize,
    /// Edges with one triangle (open tube ends, holes).
    pub open_edges: usize,
    /// Edges shared by more than two triangles.
    pub non_manifold_edges: usize,
    /// Connected parts skeletonised.
    pub parts: usize,
    /// Skeleton chains (one per tube between forks and tips).
    pub chains: usize,
    /// Nodes placing it.
    pub instances: usize,
}

/// One node placing a skeletonised mesh.
#[derive(Clone, Debug, Serialize)]
pub struct InstanceStats {
    /// glTF node index.
    pub node: usize,
    /// Node name.
    pub name: Option<String>,
    /// glTF mesh index.
    pub mesh: usize,
    /// Supports made (trunks + branches).
    pub supports: usize,
    /// Trunk supports.
    pub trunks: usize,
    /// Branch supports.
    pub branches: usize,
    /// Axis length of the supports (m).
    pub grippable_m: f32,
    /// Skeleton length not used: thinner than [`MIN_GRIP_RADIUS_M`] or in runs
    /// shorter than [`MIN_GRIP_LENGTH_M`] (m).
    pub ungrippable_m: f32,
}

/// One part's skeleton in mesh space.
#[derive(Debug)]
struct PartSkeleton {
    positions: Vec<Vec3>,
    triangles: Vec<[u32; 3]>,
    chains: Vec<Chain>,
    /// Per triangle: (chain, arc length along it).
    owner: Vec<(u32, f32)>,
}

/// A mesh skeletonised once, for every node that places it.
#[derive(Debug)]
pub(super) struct MeshSkeleton {
    parts: Vec<PartSkeleton>,
    stats_index: usize,
}

/// Welds, splits and skeletonises a mesh (mesh space). Warnings go to `report`.
pub(super) fn skeletonise_mesh(
    mesh: usize,
    name: Option<&str>,
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    label: &str,
    report: &mut ImportReport,
) -> MeshSkeleton {
    let t0 = std::time::Instant::now();
    let (welded, tris) = weld(positions, triangles);
    // Zero-area triangles (collinear, not collapsed by the weld) are dropped too.
    let tris: Vec<[u32; 3]> = tris
        .into_iter()
        .filter(|t| {
            let [a, b, c] = t.map(|i| welded[i as usize]);
            let n = (b - a).cross(c - a).length();
            let scale = (b - a).length_squared().max((c - a).length_squared());
            n > 1e-7 * scale && n.is_finite()
        })
        .collect();
    let degenerate = triangles.len() - tris.len();
    let (open_edges, non_manifold_edges) = edge_counts(&tris);
    let mut parts = Vec::new();
    let mut small = 0;
    for part in split_parts(welded.len(), &tris) {
        if part.len() < MIN_PART_TRIANGLES {
            small += 1;
            continue;
        }
        if let Some(p) = part_skeleton(&welded, &part) {
            parts.push(p);
        }
    }
    if degenerate > 0 {
        report.warnings.push(format!(
            "{label}: {degenerate} degenerate triangle(s) (zero area or repeated vertices) ignored"
        ));
    }
    if non_manifold_edges > 0 {
        report.warnings.push(format!(
            "{label}: {non_manifold_edges} non-manifold edge(s) (shared by 3+ triangles); \
             skeletonised anyway"
        ));
    }
    if small > 0 {
        report.warnings.push(format!(
            "{label}: {small} part(s) with fewer than {MIN_PART_TRIANGLES} triangles are not \
             tubes and were skipped"
        ));
    }
    report.meshes.push(MeshStats {
        mesh,
        name: name.map(str::to_string),
        triangles: tris.len(),
        degenerate,
        open_edges,
        non_manifold_edges,
        parts: parts.len(),
        chains: parts.iter().map(|p| p.chains.len()).sum(),
        instances: 0,
    });
    report.skeleton_ms += t0.elapsed().as_secs_f64() * 1e3;
    MeshSkeleton {
        parts,
        stats_index: report.meshes.len() - 1,
    }
}

/// (edges with one triangle, edges with three or more).
fn edge_counts(tris: &[[u32; 3]]) -> (usize, usize) {
    let mut edges: Vec<(u32, u32)> = tris
        .iter()
        .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
        .map(|(a, b)| (a.min(b), a.max(b)))
        .collect();
    edges.sort_unstable();
    let (mut open, mut many) = (0, 0);
    let mut i = 0;
    while i < edges.len() {
        let j = i + edges[i..].iter().take_while(|e| **e == edges[i]).count();
        match j - i {
            1 => open += 1,
            2 => {}
            _ => many += 1,
        }
        i = j;
    }
    (open, many)
}

/// Skeleton of one part (compact copy of its vertices); a straight PCA fit
/// when it has no skeleton (too coarse); `None` when degenerate.
fn part_skeleton(welded: &[Vec3], part: &[[u32; 3]]) -> Option<PartSkeleton> {
    let mut used: Vec<u32> = part.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let local: HashMap<u32, u32> = used
        .iter()
        .enumerate()
        .map(|(l, &g)| (g, l as u32))
        .collect();
    let positions: Vec<Vec3> = used.iter().map(|&g| welded[g as usize]).collect();
    let triangles: Vec<[u32; 3]> = part.iter().map(|t| t.map(|g| local[&g])).collect();
    if let Some(sk) = skeletonise(&positions, &triangles) {
        return Some(PartSkeleton {
            positions,
            triangles,
            chains: sk.chains,
            owner: sk.owner,
        });
    }
    let fitted = fit_part(&positions, &triangles)?;
    Some(PartSkeleton {
        owner: vec![(0, 0.0); fitted.mesh.triangles.len()],
        positions: fitted.mesh.positions,
        triangles: fitted.mesh.triangles,
        chains: vec![Chain {
            nodes: fitted.nodes,
            radii: fitted.radii,
        }],
    })
}

/// One placed piece of a chain.
struct Piece {
    chain: usize,
    /// Node range (inclusive) and its arc-length range.
    nodes: (usize, usize),
    u: (f32, f32),
    kind: SupportKind,
}

/// The supports of one node placing `skel` with `world`.
#[allow(clippy::too_many_arguments)]
pub(super) fn instance_supports(
    skel: &MeshSkeleton,
    node: usize,
    node_name: Option<&str>,
    mesh: usize,
    base_name: Option<&str>,
    tag: Option<SupportKind>,
    world: Mat4,
    label: &str,
    report: &mut ImportReport,
) -> Vec<Support> {
    let lin = Mat3::from_mat4(world);
    let scale = lin.determinant().abs().cbrt();
    let axes = [
        lin.x_axis.length(),
        lin.y_axis.length(),
        lin.z_axis.length(),
    ];
    let (lo, hi) = (
        axes.iter().copied().fold(f32::INFINITY, f32::min),
        axes.iter().copied().fold(0.0f32, f32::max),
    );
    if hi > 1.01 * lo {
        report.warnings.push(format!(
            "{label}: non-uniform scale {axes:?}: radii use the mean scale {scale}"
        ));
    }
    let mut out = Vec::new();
    let (mut grippable, mut ungrippable) = (0.0f32, 0.0f32);
    let (mut y_lo, mut y_hi) = (f32::INFINITY, f32::NEG_INFINITY);
    for part in &skel.parts {
        let positions: Vec<Vec3> = part
            .positions
            .iter()
            .map(|p| world.transform_point3(*p))
            .collect();
        if positions.iter().any(|p| !p.is_finite()) || !(scale.is_finite() && scale > 0.0) {
            report.warnings.push(format!(
                "{label}: the node transform makes the mesh degenerate or not finite; skipped"
            ));
            continue;
        }
        for p in &positions {
            y_lo = y_lo.min(p.y);
            y_hi = y_hi.max(p.y);
        }
        let chains: Vec<(Vec<Vec3>, Vec<f32>)> = part
            .chains
            .iter()
            .map(|c| {
                (
                    c.nodes.iter().map(|p| world.transform_point3(*p)).collect(),
                    c.radii.iter().map(|r| r * scale).collect(),
                )
            })
            .collect();
        let mut pieces: Vec<Piece> = Vec::new();
        for (ci, (nodes, radii)) in chains.iter().enumerate() {
            let cum = cumulative(nodes);
            for (a, b) in grippable_runs(radii, &cum) {
                let run_len = cum[b] - cum[a];
                grippable += run_len;
                for (i0, i1, kind) in kind_runs(nodes, &cum, a, b, tag) {
                    pieces.push(Piece {
                        chain: ci,
                        nodes: (i0, i1),
                        u: (cum[i0], cum[i1]),
                        kind,
                    });
                }
            }
            ungrippable += cum.last().copied().unwrap_or(0.0);
        }
        ungrippable -= pieces.iter().map(|p| p.u.1 - p.u.0).sum::<f32>();
        // Triangles to the piece of their owner (none: ungrippable, dropped).
        let mut tri_lists: Vec<Vec<[u32; 3]>> = vec![Vec::new(); pieces.len()];
        let by_chain = |c: usize| pieces.iter().enumerate().filter(move |p| p.1.chain == c);
        for (t, &(c, u)) in part.triangles.iter().zip(&part.owner) {
            let mut best: Option<(f32, usize)> = None;
            for (k, p) in by_chain(c as usize) {
                let d = if u < p.u.0 {
                    p.u.0 - u
                } else if u > p.u.1 {
                    u - p.u.1
                } else {
                    0.0
                };
                if best.is_none_or(|b| d < b.0) {
                    best = Some((d, k));
                }
            }
            // Owned by a thin run: keep only when next to a kept piece (the
            // rim where a thin tip starts), else drop with it.
            if let Some((d, k)) = best {
                let r = chains[c as usize].1.iter().copied().fold(0.0, f32::max);
                if d <= r {
                    tri_lists[k].push(*t);
                }
            }
        }
        for (p, tris) in pieces.iter().zip(tri_lists) {
            let (nodes, radii) = &chains[p.chain];
            let (mut n, mut r) = (Vec::new(), Vec::new());
            for i in p.nodes.0..=p.nodes.1 {
                if n.last().is_none_or(|q: &Vec3| q.distance(nodes[i]) >= 1e-4) {
                    n.push(nodes[i]);
                    r.push(radii[i]);
                }
            }
            if n.len() < 2 || r.iter().any(|x| !(x.is_finite() && *x > 0.0)) {
                continue;
            }
            // Canonical direction: upward, else toward +X, else +Z.
            let d = n[n.len() - 1] - n[0];
            let eps = 1e-4 * d.length();
            let flip = if d.y.abs() > eps {
                d.y < 0.0
            } else if d.x.abs() > eps {
                d.x < 0.0
            } else {
                d.z < 0.0
            };
            if flip {
                n.reverse();
                r.reverse();
            }
            let mut s = Support::new(n, r);
            s.kind = p.kind;
            s.tagged = tag.is_some();
            if !tris.is_empty() {
                s.mesh = Some(compact(&positions, &tris));
            }
            out.push(s);
        }
    }
    let many = out.len() > 1;
    for (k, s) in out.iter_mut().enumerate() {
        s.name = base_name.map(|n| {
            if many {
                format!("{n}/{k}")
            } else {
                n.to_string()
            }
        });
    }
    let height = y_hi - y_lo;
    if height.is_finite() && (height < PLAUSIBLE_HEIGHT_M.0 || height > PLAUSIBLE_HEIGHT_M.1) {
        report.warnings.push(format!(
            "{label}: placed mesh is {height:.4} m tall; glTF units are metres — is the file \
             exported in another unit (cm, mm, km)?"
        ));
    }
    if out.is_empty() && !skel.parts.is_empty() {
        report.warnings.push(format!(
            "{label}: nothing to grip: {ungrippable:.3} m of skeleton, all thinner than \
             {MIN_GRIP_RADIUS_M} m radius or in runs shorter than {MIN_GRIP_LENGTH_M} m"
        ));
    }
    let trunks = out.iter().filter(|s| s.kind == SupportKind::Trunk).count();
    report.instances.push(InstanceStats {
        node,
        name: node_name.map(str::to_string),
        mesh,
        supports: out.len(),
        trunks,
        branches: out.len() - trunks,
        grippable_m: grippable,
        ungrippable_m: ungrippable.max(0.0),
    });
    report.meshes[skel.stats_index].instances += 1;
    out
}

fn cumulative(nodes: &[Vec3]) -> Vec<f32> {
    let mut cum = vec![0.0f32];
    for w in nodes.windows(2) {
        cum.push(cum.last().copied().unwrap_or(0.0) + w[0].distance(w[1]));
    }
    cum
}

/// Maximal node runs `(first, last)` with radius ≥ [`MIN_GRIP_RADIUS_M`] and
/// length ≥ [`MIN_GRIP_LENGTH_M`].
fn grippable_runs(radii: &[f32], cum: &[f32]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < radii.len() {
        if radii[i] < MIN_GRIP_RADIUS_M {
            i += 1;
            continue;
        }
        let j = i + radii[i..]
            .iter()
            .take_while(|r| **r >= MIN_GRIP_RADIUS_M)
            .count()
            - 1;
        if j > i && cum[j] - cum[i] >= MIN_GRIP_LENGTH_M {
            out.push((i, j));
        }
        i = j + 1;
    }
    out
}

/// Splits nodes `a..=b` where the kind by tilt changes (SPEC: trunk when
/// tilted more than 70° from horizontal), tilt measured over ±25 cm; runs
/// shorter than [`MIN_KIND_RUN_M`] take their neighbour's kind. A name tag
/// gives one kind throughout.
fn kind_runs(
    nodes: &[Vec3],
    cum: &[f32],
    a: usize,
    b: usize,
    tag: Option<SupportKind>,
) -> Vec<(usize, usize, SupportKind)> {
    if let Some(kind) = tag {
        return vec![(a, b, kind)];
    }
    // Kind per segment i (nodes i → i+1).
    let mut kinds: Vec<SupportKind> = (a..b)
        .map(|i| {
            let mid = 0.5 * (cum[i] + cum[i + 1]);
            let lo = (a..=i).rev().find(|&k| cum[k] <= mid - 0.25).unwrap_or(a);
            let hi = (i + 1..=b).find(|&k| cum[k] >= mid + 0.25).unwrap_or(b);
            SupportKind::from_tilt(tilt_of(nodes[hi] - nodes[lo]))
        })
        .collect();
    // Absorb short runs (shortest first, repeatedly).
    loop {
        let runs = runs_of(&kinds);
        if runs.len() <= 1 {
            break;
        }
        let len = |r: &(usize, usize)| cum[a + r.1 + 1] - cum[a + r.0];
        let Some(short) = runs
            .iter()
            .filter(|r| len(r) < MIN_KIND_RUN_M)
            .min_by(|x, y| len(x).total_cmp(&len(y)))
        else {
            break;
        };
        let flip = match kinds[short.0] {
            SupportKind::Trunk => SupportKind::Branch,
            SupportKind::Branch => SupportKind::Trunk,
        };
        for k in &mut kinds[short.0..=short.1] {
            *k = flip;
        }
    }
    runs_of(&kinds)
        .into_iter()
        .map(|(s, e)| (a + s, a + e + 1, kinds[s]))
        .collect()
}

/// Runs of equal values: (first, last) indices.
fn runs_of(kinds: &[SupportKind]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < kinds.len() {
        let j = i + kinds[i..].iter().take_while(|k| **k == kinds[i]).count();
        out.push((i, j - 1));
        i = j;
    }
    out
}

/// The triangles with their vertices, compactly re-indexed.
fn compact(positions: &[Vec3], tris: &[[u32; 3]]) -> TriMesh {
    let mut map: HashMap<u32, u32> = HashMap::new();
    let mut out = TriMesh::default();
    for t in tris {
        let t2 = t.map(|v| {
            *map.entry(v).or_insert_with(|| {
                out.positions.push(positions[v as usize]);
                (out.positions.len() - 1) as u32
            })
        });
        out.triangles.push(t2);
    }
    out
}

/// How deep a support may reach into another's tube (fraction of that
/// tube's radius from its axis): the procedural forest starts branches at
/// 0.6 radii from the trunk's axis, which the transfers are made for.
const EMBED_DEPTH: f32 = 0.6;

/// Trims the ends of skeleton supports (`made`: their indices) that reach
/// deeper than [`EMBED_DEPTH`] into another support's tube (a branch growing
/// out of a trunk, a side chain leaving its fork; skeleton supports only)
/// back to that depth; drops
/// those that lie wholly inside. Supports that share an end node (pieces of
/// one chain) are not trimmed against each other.
pub(super) fn trim_embedded(supports: &mut Vec<Support>, made: &[usize]) {
    let boxes: Vec<(Vec3, Vec3)> = supports
        .iter()
        .map(|s| {
            let r = s.radii.iter().copied().fold(0.0, f32::max);
            s.nodes
                .iter()
                .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
                    (lo.min(*p - r), hi.max(*p + r))
                })
        })
        .collect();
    let mut drop = vec![false; supports.len()];
    let mut trimmed: Vec<(usize, Vec<Vec3>, Vec<f32>)> = Vec::new();
    for &i in made {
        let s = &supports[i];
        let ends = [s.nodes[0], s.nodes[s.nodes.len() - 1]];
        let others: Vec<usize> = made
            .iter()
            .copied()
            .filter(|&j| {
                let o = &supports[j];
                let (lo, hi) = boxes[j];
                j != i
                    && ends.iter().any(|e| e.cmpge(lo).all() && e.cmple(hi).all())
                    && !ends.iter().any(|e| {
                        e.distance(o.nodes[0]) < 1e-3
                            || e.distance(o.nodes[o.nodes.len() - 1]) < 1e-3
                    })
            })
            .collect();
        if others.is_empty() {
            continue;
        }
        let inside = |p: Vec3| {
            others.iter().any(|&j| {
                let (q, _, _, r) = supports[j].closest_on_axis(p);
                q.distance(p) < EMBED_DEPTH * r
            })
        };
        let (mut nodes, mut radii) = (s.nodes.clone(), s.radii.clone());
        for _end in 0..2 {
            let k = nodes.iter().take_while(|p| inside(**p)).count();
            if k == nodes.len() {
                drop[i] = true;
                break;
            }
            if k > 0 {
                // Bisect the crossing between node k-1 (inside) and k.
                let (mut a, mut b) = (0.0f32, 1.0f32);
                for _ in 0..24 {
                    let m = 0.5 * (a + b);
                    if inside(nodes[k - 1].lerp(nodes[k], m)) {
                        a = m;
                    } else {
                        b = m;
                    }
                }
                let p = nodes[k - 1].lerp(nodes[k], b);
                let r = radii[k - 1] + (radii[k] - radii[k - 1]) * b;
                nodes.drain(..k);
                radii.drain(..k);
                if p.distance(nodes[0]) >= 1e-3 {
                    nodes.insert(0, p);
                    radii.insert(0, r);
                }
            }
            nodes.reverse();
            radii.reverse();
        }
        if !drop[i] && nodes.len() >= 2 && nodes != s.nodes {
            trimmed.push((i, nodes, radii));
        } else if nodes.len() < 2 {
            drop[i] = true;
        }
    }
    for (i, nodes, radii) in trimmed {
        supports[i].nodes = nodes;
        supports[i].radii = radii;
    }
    let mut k = 0;
    supports.retain(|_| {
        k += 1;
        !drop[k - 1]
    });
}
