//! Skeletons of generated tree meshes against the generator's truth: every
//! grippable stretch of every tube is recovered with its axis within 1 cm
//! and its radius within 10 %, and nothing else is made up.

use glam::{Quat, Vec3};
use proptest::prelude::*;
use slothsim_scene::treegen::{
    GeneratedTree, Placement, TreeLayout, TreeParams, generate_tree, write_glb,
};
use slothsim_scene::{MIN_GRIP_LENGTH_M, MIN_GRIP_RADIUS_M, Scene, import_slice_report};

/// Closest point on a polyline: (distance, segment, t).
fn closest(poly: &[Vec3], p: Vec3) -> (f32, usize, f32) {
    let mut best = (f32::INFINITY, 0, 0.0);
    for (i, w) in poly.windows(2).enumerate() {
        let (q, t) = slothsim_scene::closest_on_segment(w[0], w[1], p);
        let d = q.distance(p);
        if d < best.0 {
            best = (d, i, t);
        }
    }
    best
}

fn arc(poly: &[Vec3]) -> Vec<f32> {
    let mut cum = vec![0.0];
    for w in poly.windows(2) {
        cum.push(cum.last().unwrap() + w[0].distance(w[1]));
    }
    cum
}

/// Where a tube's sample is comparable: away from its start (inside or at
/// its parent), its tip and any junction, and where the tube is grippable.
fn comparable(tree: &GeneratedTree, ti: usize, k: usize) -> bool {
    let t = &tree.tubes[ti];
    let cum = arc(&t.axis);
    let (u, r, len) = (cum[k], t.radii[k], *cum.last().unwrap());
    if u < t.parent_radius + 2.0 * r.max(t.radii[0]) || len - u < 2.0 * r + 0.05 {
        return false;
    }
    // Grippable prefix (radii only shrink along a tube), with a margin at the cut.
    let cut = t
        .radii
        .iter()
        .position(|&x| x < MIN_GRIP_RADIUS_M * 1.15)
        .map_or(len, |i| cum[i]);
    if cut < MIN_GRIP_LENGTH_M + 0.2 || u > cut - 2.0 * r {
        return false;
    }
    // Near where another tube starts from this one (welded forks).
    tree.tubes
        .iter()
        .enumerate()
        .all(|(oi, o)| oi == ti || o.axis[0].distance(t.axis[k]) > 2.0 * (r + o.parent_radius))
}

fn check(tree: &GeneratedTree, scene: &Scene) -> Result<(usize, f32, f32), String> {
    let mut checked = 0;
    let (mut worst_axis, mut worst_radius) = (0.0f32, 0.0f32);
    for (ti, t) in tree.tubes.iter().enumerate() {
        for k in 0..t.axis.len() {
            if !comparable(tree, ti, k) {
                continue;
            }
            let p = t.axis[k];
            let (d, s, seg, f) = scene
                .supports()
                .iter()
                .map(|s| {
                    let (d, i, f) = closest(&s.nodes, p);
                    (d, s, i, f)
                })
                .min_by(|a, b| a.0.total_cmp(&b.0))
                .ok_or("no supports")?;
            let r = s.radii[seg] + (s.radii[seg + 1] - s.radii[seg]) * f;
            let rel = (r - t.radii[k]).abs() / t.radii[k];
            worst_axis = worst_axis.max(d);
            worst_radius = worst_radius.max(rel);
            if d > 0.01 || rel > 0.10 {
                return Err(format!(
                    "tube {ti} sample {k} at {p}: axis off by {d:.4} m, radius {r:.4} vs {:.4} \
                     (support {})",
                    t.radii[k],
                    s.label()
                ));
            }
            checked += 1;
        }
    }
    // Nothing made up: support nodes lie on some tube's axis (away from
    // tube starts and tips, where sections are not a single tube's).
    for s in scene.supports() {
        for (n, r) in s.nodes.iter().zip(&s.radii) {
            let near_end = tree.tubes.iter().any(|t| {
                t.axis[0].distance(*n) < t.parent_radius + 2.5 * t.radii[0]
                    || t.axis.last().unwrap().distance(*n) < 3.0 * t.radii[t.radii.len() - 1] + 0.05
            });
            if near_end {
                continue;
            }
            let d = tree
                .tubes
                .iter()
                .map(|t| closest(&t.axis, *n).0)
                .fold(f32::INFINITY, f32::min);
            if d > 0.01 {
                return Err(format!(
                    "support {} node {n} (r {r:.3}) is {d:.4} m from every tube axis",
                    s.label()
                ));
            }
        }
    }
    Ok((checked, worst_axis, worst_radius))
}

fn import_tree(tree: &GeneratedTree, rot: Quat, scale: f32) -> Scene {
    let nodes: Vec<Placement> = (0..tree.meshes.len())
        .map(|m| Placement {
            name: format!("n{m}"),
            mesh: m,
            translation: Vec3::ZERO,
            rotation: rot,
            scale: Vec3::splat(scale),
        })
        .collect();
    let glb = write_glb(&tree.meshes, &nodes);
    import_slice_report(&glb, "tree.glb").unwrap().0
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 32, ..ProptestConfig::default() })]
    #[test]
    fn random_trees_recover_axes_within_1cm_and_radii_within_10pct(
        seed in 0u64..1_000_000,
        welded in any::<bool>(),
        fork in any::<bool>(),
        sides in 8u32..=16,
        height in 4.0f32..8.0,
        trunk_radius in 0.12f32..0.3,
        branches in 2u32..7,
    ) {
        let params = TreeParams {
            height,
            trunk_radius,
            branches,
            sub_branches: 1,
            fork,
            sides,
            layout: if welded { TreeLayout::Welded } else { TreeLayout::PerBranch },
        };
        let tree = generate_tree(&params, seed, Vec3::ZERO);
        let scene = import_tree(&tree, Quat::IDENTITY, 1.0);
        let (checked, axis, radius) = check(&tree, &scene).map_err(TestCaseError::fail)?;
        prop_assert!(checked > 20, "only {checked} samples compared");
        eprintln!("seed {seed}: {checked} samples, worst axis {:.1} mm, worst radius {:.1} %",
            axis * 1e3, radius * 100.0);
    }
}
