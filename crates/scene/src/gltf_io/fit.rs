//! Supports from raw triangle soup: weld → split into connected parts → fit
//! a tapered axis to each part by PCA.
//!
//! Stages, all deterministic (input order decides every tie):
//! 1. [`weld`]: vertices closer than `WELD_REL` × max(1 m, mesh extent) merge
//!    (hash grid, 27-cell lookup); triangles that collapse are dropped.
//! 2. [`split_parts`]: union-find over triangle vertices; parts ordered by
//!    their first triangle.
//! 3. [`fit_part`]: principal axis = eigenvector of the largest eigenvalue of
//!    the surface-area-weighted covariance (Jacobi, f64); axis ends = extent of
//!    the vertices projected on it; `K` (1..=8) straight segments with a radius
//!    per node = median distance from the axis of the vertices in the node's
//!    slab (empty slabs interpolated). Degenerate parts (zero area, collinear,
//!    shorter than `MIN_LENGTH`, zero radius) give `None`.

use std::collections::HashMap;

use glam::{DVec3, Vec3};

use crate::TriMesh;

/// Weld tolerance relative to max(1 m, mesh extent).
const WELD_REL: f32 = 1e-5;
/// Shortest fitted support (metres); keeps segments above `Scene::new`'s limit.
const MIN_LENGTH: f64 = 1e-3;
/// Most segments per fitted support.
const MAX_SEGMENTS: usize = 8;

/// A support fitted to one connected part.
#[derive(Debug)]
pub(super) struct FittedPart {
    /// Axis nodes, world space, from the lower end (or −X/−Z end if level).
    pub nodes: Vec<Vec3>,
    /// Radius per node.
    pub radii: Vec<f32>,
    /// The part's triangles, compactly re-indexed.
    pub mesh: TriMesh,
}

/// Merges vertices closer than the weld tolerance. Returns the welded
/// positions and the triangles re-indexed, without collapsed triangles.
pub(super) fn weld(positions: &[Vec3], triangles: &[[u32; 3]]) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    let lo = positions.iter().fold(Vec3::INFINITY, |a, b| a.min(*b));
    let hi = positions.iter().fold(Vec3::NEG_INFINITY, |a, b| a.max(*b));
    let extent = if positions.is_empty() {
        0.0
    } else {
        (hi - lo).max_element()
    };
    let tol = WELD_REL * extent.max(1.0);
    let cell = |p: Vec3| -> [i64; 3] { (p / tol).floor().to_array().map(|c| c as i64) };

    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut welded: Vec<Vec3> = Vec::new();
    let mut remap = Vec::with_capacity(positions.len());
    for &p in positions {
        let c = cell(p);
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    let key = [
                        c[0].saturating_add(dx),
                        c[1].saturating_add(dy),
                        c[2].saturating_add(dz),
                    ];
                    if let Some(list) = grid.get(&key)
                        && let Some(&i) = list
                            .iter()
                            .find(|&&i| welded[i as usize].distance(p) <= tol)
                    {
                        found = Some(i);
                        break 'search;
                    }
                }
            }
        }
        let index = found.unwrap_or_else(|| {
            let i = welded.len() as u32;
            welded.push(p);
            grid.entry(c).or_default().push(i);
            i
        });
        remap.push(index);
    }
    let tris = triangles
        .iter()
        .map(|t| t.map(|i| remap[i as usize]))
        .filter(|[a, b, c]| a != b && b != c && a != c)
        .collect();
    (welded, tris)
}

/// Groups triangles into connected parts (sharing a vertex), ordered by
/// their first triangle; triangles keep their input order within a part.
pub(super) fn split_parts(vertex_count: usize, triangles: &[[u32; 3]]) -> Vec<Vec<[u32; 3]>> {
    let mut parent: Vec<u32> = (0..vertex_count as u32).collect();
    for t in triangles {
        for &v in &t[1..] {
            let a = find_root(&mut parent, t[0]);
            let b = find_root(&mut parent, v);
            // Smaller root wins, so the result depends only on the input order.
            parent[a.max(b) as usize] = a.min(b);
        }
    }
    group(&mut parent, triangles)
}

/// Union-find root with path halving.
fn find_root(parent: &mut [u32], mut x: u32) -> u32 {
    while parent[x as usize] != x {
        let grand = parent[parent[x as usize] as usize];
        parent[x as usize] = grand;
        x = grand;
    }
    x
}

fn group(parent: &mut [u32], triangles: &[[u32; 3]]) -> Vec<Vec<[u32; 3]>> {
    let mut part_of_root: HashMap<u32, usize> = HashMap::new();
    let mut parts: Vec<Vec<[u32; 3]>> = Vec::new();
    for t in triangles {
        let x = find_root(parent, t[0]);
        let k = *part_of_root.entry(x).or_insert_with(|| {
            parts.push(Vec::new());
            parts.len() - 1
        });
        parts[k].push(*t);
    }
    parts
}

/// Fits a tapered straight axis to one part; `None` if the part is degenerate.
pub(super) fn fit_part(positions: &[Vec3], triangles: &[[u32; 3]]) -> Option<FittedPart> {
    // Compact vertex set (ascending global index) and local triangles.
    let mut used: Vec<u32> = triangles.iter().flatten().copied().collect();
    used.sort_unstable();
    used.dedup();
    let local: HashMap<u32, u32> = used
        .iter()
        .enumerate()
        .map(|(l, &g)| (g, l as u32))
        .collect();
    let mesh = TriMesh {
        positions: used.iter().map(|&g| positions[g as usize]).collect(),
        triangles: triangles.iter().map(|t| t.map(|g| local[&g])).collect(),
    };
    let pts: Vec<DVec3> = mesh.positions.iter().map(|p| p.as_dvec3()).collect();
    let origin = pts[0];

    // Area-weighted mean and second moment over the surface, about `origin`.
    let mut area = 0.0;
    let mut mean = DVec3::ZERO;
    let mut m2 = [[0.0f64; 3]; 3];
    for t in &mesh.triangles {
        let [a, b, c] = t.map(|i| pts[i as usize] - origin);
        let w = 0.5 * (b - a).cross(c - a).length();
        if w == 0.0 {
            continue;
        }
        let m = (a + b + c) / 3.0;
        area += w;
        mean += m * w;
        // ∫ x xᵀ dA over a triangle = A/12 (a aᵀ + b bᵀ + c cᵀ + 9 m mᵀ).
        for (r, row) in m2.iter_mut().enumerate() {
            for (col, e) in row.iter_mut().enumerate() {
                *e += w / 12.0
                    * (a[r] * a[col] + b[r] * b[col] + c[r] * c[col] + 9.0 * m[r] * m[col]);
            }
        }
    }
    let scale = pts
        .iter()
        .map(|p| (*p - origin).length())
        .fold(0.0, f64::max);
    if area.is_nan() || area <= 1e-12 * scale * scale || scale <= 0.0 {
        return None;
    }
    mean /= area;
    let mut cov = [[0.0f64; 3]; 3];
    for r in 0..3 {
        for c in 0..3 {
            cov[r][c] = m2[r][c] / area - mean[r] * mean[c];
        }
    }
    let (values, vectors) = jacobi_eigen(cov);
    let (mut order, v) = ([0usize, 1, 2], values);
    order.sort_by(|&i, &j| v[j].total_cmp(&v[i]));
    let (l0, l1) = (values[order[0]], values[order[1]]);
    if l0.is_nan() || l0 <= 0.0 || l1 <= 1e-9 * l0 {
        return None; // collinear
    }
    let mut dir = DVec3::from_array(vectors[order[0]]).normalize();
    if !dir.is_finite() {
        return None;
    }
    // Sign: upward, else towards +X, else +Z.
    let flip = if dir.y.abs() > 1e-9 {
        dir.y < 0.0
    } else if dir.x.abs() > 1e-9 {
        dir.x < 0.0
    } else {
        dir.z < 0.0
    };
    if flip {
        dir = -dir;
    }

    let centre = origin + mean;
    let proj: Vec<(f64, f64)> = pts
        .iter()
        .map(|p| {
            let rel = *p - centre;
            let s = rel.dot(dir);
            (s, (rel - dir * s).length())
        })
        .collect();
    let s_min = proj.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    let s_max = proj.iter().map(|p| p.0).fold(f64::NEG_INFINITY, f64::max);
    let length = s_max - s_min;
    if length.is_nan() || length < MIN_LENGTH {
        return None;
    }
    let r_all = median(proj.iter().map(|p| p.1).collect())?;
    if r_all.is_nan() || r_all <= 1e-6 {
        return None;
    }
    let segments = ((length / (4.0 * r_all)).ceil() as usize)
        .clamp(1, MAX_SEGMENTS)
        .min((length / MIN_LENGTH) as usize)
        .max(1);
    let step = length / segments as f64;
    let slab_radii: Vec<Option<f64>> = (0..=segments)
        .map(|j| {
            let s_j = s_min + step * j as f64;
            let inside: Vec<f64> = proj
                .iter()
                .filter(|p| (p.0 - s_j).abs() <= 0.5 * step)
                .map(|p| p.1)
                .collect();
            median(inside).filter(|r| *r > 1e-6)
        })
        .collect();
    let radii = fill_gaps(&slab_radii, r_all);
    let nodes = (0..=segments)
        .map(|j| (centre + dir * (s_min + step * j as f64)).as_vec3())
        .collect::<Vec<_>>();
    if nodes.iter().any(|n| !n.is_finite()) {
        return None;
    }
    Some(FittedPart {
        nodes,
        radii: radii.into_iter().map(|r| r as f32).collect(),
        mesh,
    })
}

/// Median (lower middle for even counts); `None` when empty.
fn median(mut v: Vec<f64>) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[(v.len() - 1) / 2])
}

/// Replaces missing slab radii by linear interpolation between the nearest
/// known ones (constant beyond the ends; `fallback` if none is known).
fn fill_gaps(values: &[Option<f64>], fallback: f64) -> Vec<f64> {
    let known: Vec<(usize, f64)> = values
        .iter()
        .enumerate()
        .filter_map(|(i, v)| v.map(|v| (i, v)))
        .collect();
    (0..values.len())
        .map(|i| {
            if let Some(v) = values[i] {
                return v;
            }
            let before = known.iter().rev().find(|k| k.0 < i);
            let after = known.iter().find(|k| k.0 > i);
            match (before, after) {
                (Some(&(i0, v0)), Some(&(i1, v1))) => {
                    v0 + (v1 - v0) * (i - i0) as f64 / (i1 - i0) as f64
                }
                (Some(&(_, v)), None) | (None, Some(&(_, v))) => v,
                (None, None) => fallback,
            }
        })
        .collect()
}

/// Eigen decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations.
/// Returns eigenvalues and the matching unit eigenvectors (unordered).
fn jacobi_eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]; // columns = eigenvectors
    for _sweep in 0..50 {
        let off = a[0][1].powi(2) + a[0][2].powi(2) + a[1][2].powi(2);
        let diag = a[0][0].powi(2) + a[1][1].powi(2) + a[2][2].powi(2);
        if off <= 1e-30 * diag || off == 0.0 {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            if a[p][q] == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * a[p][q]);
            let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
            let t = if theta == 0.0 { 1.0 } else { t };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            // A ← Jᵀ A J with the rotation in the (p, q) plane.
            for row in &mut a {
                let (akp, akq) = (row[p], row[q]);
                row[p] = c * akp - s * akq;
                row[q] = s * akp + c * akq;
            }
            let (row_p, row_q) = (a[p], a[q]);
            a[p] = std::array::from_fn(|k| c * row_p[k] - s * row_q[k]);
            a[q] = std::array::from_fn(|k| s * row_p[k] + c * row_q[k]);
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    let values = [a[0][0], a[1][1], a[2][2]];
    let vectors = [0, 1, 2].map(|k| [v[0][k], v[1][k], v[2][k]]);
    (values, vectors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jacobi_recovers_known_eigenpairs() {
        // Rotate diag(5, 2, 1) by an arbitrary rotation and recover it.
        let r = glam::DMat3::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1);
        let m = r * glam::DMat3::from_diagonal(DVec3::new(5.0, 2.0, 1.0)) * r.transpose();
        let a = [0, 1, 2].map(|i| [0, 1, 2].map(|j| m.col(j)[i]));
        let (values, vectors) = jacobi_eigen(a);
        for k in 0..3 {
            let v = DVec3::from_array(vectors[k]);
            assert!((m * v - v * values[k]).length() < 1e-9, "pair {k}");
        }
        let mut sorted = values;
        sorted.sort_by(f64::total_cmp);
        assert!((sorted[2] - 5.0).abs() < 1e-9 && (sorted[0] - 1.0).abs() < 1e-9);
    }

    #[test]
    fn weld_merges_near_duplicates_and_drops_collapsed_triangles() {
        let p = [
            Vec3::ZERO,
            Vec3::X,
            Vec3::Y,
            Vec3::new(1.0, 0.0, 1e-7), // duplicate of X
            Vec3::new(0.0, 1e-7, 0.0), // duplicate of 0 → collapses triangle 2
        ];
        let (pos, tris) = weld(&p, &[[0, 1, 2], [3, 2, 0], [0, 4, 1]]);
        assert_eq!(pos.len(), 3);
        assert_eq!(tris, vec![[0, 1, 2], [1, 2, 0]]);
    }

    #[test]
    fn split_parts_separates_disjoint_triangles() {
        let tris = [[0, 1, 2], [3, 4, 5], [2, 1, 6], [5, 7, 3]];
        let parts = split_parts(8, &tris);
        assert_eq!(
            parts,
            vec![vec![[0, 1, 2], [2, 1, 6]], vec![[3, 4, 5], [5, 7, 3]]]
        );
    }

    #[test]
    fn split_parts_joins_through_later_triangles() {
        // Triangle 2 joins parts that looked separate until then.
        let tris = [[3, 4, 5], [0, 1, 2], [2, 6, 4]];
        let parts = split_parts(7, &tris);
        assert_eq!(parts.len(), 1);
        assert_eq!(parts[0].len(), 3);
    }

    #[test]
    fn fill_gaps_interpolates() {
        let v = fill_gaps(&[None, Some(1.0), None, None, Some(4.0), None], 9.0);
        assert_eq!(v, vec![1.0, 1.0, 2.0, 3.0, 4.0, 4.0]);
        assert_eq!(fill_gaps(&[None, None], 9.0), vec![9.0, 9.0]);
    }

    #[test]
    fn collinear_part_is_degenerate() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::X * 2.0];
        assert!(fit_part(&p, &[[0, 1, 2]]).is_none());
    }
}
