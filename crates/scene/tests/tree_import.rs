//! Importing generator-style tree meshes: instancing, the report, and every
//! kind of bad input (never a panic, never a NaN or zero radius).

use glam::{Quat, Vec3};
use slothsim_scene::treegen::{
    Placement, RawMesh, TreeLayout, TreeParams, generate_forest_glb, generate_tree, write_glb,
};
use slothsim_scene::{
    ImportReport, MIN_GRIP_RADIUS_M, Scene, SceneError, SupportKind, import_slice_report,
};

fn place(mesh: usize, name: &str, scale: f32) -> Placement {
    Placement {
        name: name.into(),
        mesh,
        translation: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        scale: Vec3::splat(scale),
    }
}

fn small_tree(layout: TreeLayout) -> RawMesh {
    let params = TreeParams {
        height: 5.0,
        branches: 4,
        sub_branches: 0,
        layout,
        ..TreeParams::default()
    };
    generate_tree(&params, 3, Vec3::ZERO).meshes.swap_remove(0)
}

/// A straight open tube along +Y: `rings` rings of `sides`.
fn tube(r: f32, len: f32, sides: u32, rings: u32) -> RawMesh {
    let mut m = RawMesh::default();
    for k in 0..rings {
        for j in 0..sides {
            let a = j as f32 / sides as f32 * std::f32::consts::TAU;
            m.positions.push(Vec3::new(
                r * a.cos(),
                len * k as f32 / (rings - 1) as f32,
                r * a.sin(),
            ));
        }
    }
    for k in 0..rings - 1 {
        for j in 0..sides {
            let j1 = (j + 1) % sides;
            let (a, b, c, d) = (
                k * sides + j,
                k * sides + j1,
                (k + 1) * sides + j1,
                (k + 1) * sides + j,
            );
            m.triangles.push([a, b, c]);
            m.triangles.push([a, c, d]);
        }
    }
    m
}

fn assert_sane(scene: &Scene) {
    for s in scene.supports() {
        assert!(s.nodes.len() >= 2, "{}", s.label());
        assert!(s.nodes.iter().all(|p| p.is_finite()), "{}", s.label());
        assert!(
            s.radii
                .iter()
                .all(|r| r.is_finite() && *r >= MIN_GRIP_RADIUS_M),
            "{}: {:?}",
            s.label(),
            s.radii
        );
    }
}

fn import(meshes: &[RawMesh], nodes: &[Placement]) -> Result<(Scene, ImportReport), SceneError> {
    import_slice_report(&write_glb(meshes, nodes), "test.glb")
}

#[test]
fn linked_duplicates_are_skeletonised_once_and_placed_per_node() {
    let params = TreeParams {
        height: 5.0,
        branches: 4,
        sub_branches: 1,
        ..TreeParams::default()
    };
    let (glb, trees) = generate_forest_glb(&params, 2, 3, 6.0, 11);
    let (scene, report) = import_slice_report(&glb, "forest.glb").unwrap();
    assert_sane(&scene);
    let distinct: usize = trees.iter().map(|t| t.meshes.len()).sum();
    assert_eq!(report.meshes.len(), distinct, "each mesh skeletonised once");
    // Tree 0's meshes are placed by its own node and three copies.
    assert_eq!(report.meshes[0].instances, 4);
    assert_eq!(report.instances.len(), 2 + 3);
    let originals = &report.instances[0];
    for copy in &report.instances[2..] {
        assert_eq!(copy.mesh, originals.mesh);
        assert_eq!(
            copy.supports, originals.supports,
            "rotation about +Y keeps every tilt"
        );
        assert!((copy.grippable_m - originals.grippable_m).abs() < 1e-3);
    }
    // A copy's supports are the original's, moved.
    let name_of = |s: &slothsim_scene::Support| s.name.clone().unwrap_or_default();
    let orig: Vec<_> = scene
        .supports()
        .iter()
        .filter(|s| name_of(s).starts_with("tree0_0"))
        .collect();
    let copy: Vec<_> = scene
        .supports()
        .iter()
        .filter(|s| name_of(s).starts_with("copy0_0"))
        .collect();
    assert_eq!(orig.len(), copy.len());
    assert!(!orig.is_empty());
    // 2 trees + 3 copies on a 3 × 2 grid 6 m apart: copy 0 is the third spot.
    let xf = glam::Mat4::from_rotation_translation(
        Quat::from_rotation_y(1.3),
        Vec3::new(12.0, 0.0, 0.0),
    );
    for (a, b) in orig.iter().zip(&copy) {
        assert_eq!(a.kind, b.kind);
        assert_eq!(a.nodes.len(), b.nodes.len());
        for (p, q) in a.nodes.iter().zip(&b.nodes) {
            assert!(xf.transform_point3(*p).distance(*q) < 1e-3, "{p} → {q}");
        }
    }
}

#[test]
fn steep_branch_base_is_trunk_there_only() {
    // A tube rising vertically for 1.5 m, then bending to level for 2 m.
    let mut m = RawMesh::default();
    let mut axis = Vec::new();
    for k in 0..=15 {
        axis.push(Vec3::new(0.0, k as f32 * 0.1, 0.0));
    }
    for k in 1..=12 {
        let a = k as f32 / 12.0 * std::f32::consts::FRAC_PI_2;
        axis.push(Vec3::new(0.5 - 0.5 * a.cos(), 1.5 + 0.5 * a.sin(), 0.0));
    }
    for k in 1..=15 {
        axis.push(Vec3::new(0.5 + k as f32 * 0.1, 2.0, 0.0));
    }
    let sides = 12u32;
    for (i, c) in axis.iter().enumerate() {
        let t = (axis[(i + 1).min(axis.len() - 1)] - axis[i.saturating_sub(1)]).normalize();
        let u = Vec3::Z;
        let v = t.cross(u);
        for j in 0..sides {
            let a = j as f32 / sides as f32 * std::f32::consts::TAU;
            m.positions.push(*c + (u * a.cos() + v * a.sin()) * 0.06);
        }
    }
    for k in 0..axis.len() as u32 - 1 {
        for j in 0..sides {
            let j1 = (j + 1) % sides;
            let (a, b, c, d) = (
                k * sides + j,
                k * sides + j1,
                (k + 1) * sides + j1,
                (k + 1) * sides + j,
            );
            m.triangles.push([a, b, c]);
            m.triangles.push([a, c, d]);
        }
    }
    let (scene, _) = import(&[m], &[place(0, "limb", 1.0)]).unwrap();
    assert_sane(&scene);
    let kinds: Vec<_> = scene
        .supports()
        .iter()
        .map(|s| (s.kind, s.nodes[0], *s.nodes.last().unwrap()))
        .collect();
    assert_eq!(kinds.len(), 2, "{kinds:?}");
    let trunk = kinds
        .iter()
        .find(|k| k.0 == SupportKind::Trunk)
        .expect("a trunk piece");
    let branch = kinds
        .iter()
        .find(|k| k.0 == SupportKind::Branch)
        .expect("a branch piece");
    assert!(
        trunk.1.y < 0.05 && trunk.2.y > 1.2 && trunk.2.y < 1.9,
        "{kinds:?}"
    );
    assert!(branch.2.x > 1.9, "{kinds:?}");
    // The pieces meet.
    assert!(trunk.2.distance(branch.1) < 1e-3, "{kinds:?}");
}

#[test]
fn degenerate_triangles_are_dropped_with_a_warning_naming_the_node() {
    let mut m = tube(0.1, 3.0, 10, 16);
    let n = m.positions.len() as u32;
    m.positions.push(Vec3::new(0.1, 1.0, 0.0));
    m.triangles.push([0, 0, 1]); // repeated vertex
    m.triangles.push([0, 10, 20]); // collinear (one column of the tube)
    m.triangles.push([n, n, n]);
    let (scene, report) = import(&[m], &[place(0, "pole", 1.0)]).unwrap();
    assert_sane(&scene);
    assert_eq!(scene.supports().len(), 1);
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("pole") && w.contains("degenerate")),
        "{:?}",
        report.warnings
    );
}

#[test]
fn non_manifold_and_open_meshes_import_with_a_warning() {
    let m = small_tree(TreeLayout::Welded);
    let (scene, report) = import(&[m], &[place(0, "tree", 1.0)]).unwrap();
    assert_sane(&scene);
    assert!(report.meshes[0].open_edges > 0);
    assert!(
        report.meshes[0].non_manifold_edges > 0,
        "the welded fork shares a ring three ways"
    );
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("non-manifold") && w.contains("tree"))
    );
    let (t, b) = scene.counts();
    assert!(t >= 1 && b >= 3, "{t} trunks, {b} branches");
}

#[test]
fn one_triangle_mesh_is_a_clear_error() {
    let m = RawMesh {
        name: "leaf".into(),
        positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
        triangles: vec![[0, 1, 2]],
    };
    let err = import(&[m], &[place(0, "leafnode", 1.0)])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("test.glb") && err.contains("leafnode") && err.contains("fewer than"),
        "{err}"
    );
}

#[test]
fn kilometre_tree_warns_about_units_and_stays_sane() {
    let m = small_tree(TreeLayout::PerBranch);
    let (scene, report) = import(&[m], &[place(0, "giant", 200.0)]).unwrap();
    assert_sane(&scene);
    assert!(
        report
            .warnings
            .iter()
            .any(|w| w.contains("giant") && w.contains("metres")),
        "{:?}",
        report.warnings
    );
}

#[test]
fn millimetre_tree_is_a_clear_error_naming_the_node() {
    let m = small_tree(TreeLayout::Welded);
    let err = import(&[m], &[place(0, "bonsai", 1.0 / 5000.0)])
        .unwrap_err()
        .to_string();
    assert!(err.contains("bonsai") && err.contains("metres"), "{err}");
    assert!(err.contains("thinner than"), "{err}");
}

#[test]
fn nan_vertex_is_a_clear_error_naming_the_node() {
    let mut m = tube(0.1, 3.0, 10, 16);
    m.positions[7] = Vec3::new(f32::NAN, 0.0, 0.0);
    let err = import(&[m], &[place(0, "broken", 1.0)])
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("broken") && err.contains("not finite"),
        "{err}"
    );
}

#[test]
fn coarse_and_tiny_tubes_never_give_nan_or_zero_radius() {
    // Few rings, few sides, thin: skeleton or straight fallback, or nothing.
    for (r, len, sides, rings) in [
        (0.05, 2.0, 3, 2),
        (0.3, 0.5, 4, 2),
        (0.021, 1.0, 5, 3),
        (0.2, 8.0, 6, 40),
    ] {
        let m = tube(r, len, sides, rings);
        match import(&[m], &[place(0, "t", 1.0)]) {
            Ok((scene, _)) => assert_sane(&scene),
            Err(e) => assert!(e.to_string().contains("test.glb"), "{e}"),
        }
    }
}

/// An open tube of radius `r` along the polyline `axis` (rings at its nodes,
/// mitred at corners: each ring lies in the plane bisecting the corner).
fn tube_along(axis: &[Vec3], r: f32, sides: u32) -> RawMesh {
    let mut m = RawMesh::default();
    let n = axis.len();
    let mut u = (axis[1] - axis[0]).normalize().any_orthonormal_vector();
    for i in 0..n {
        let t_in = (axis[i] - axis[i.saturating_sub(1)]).normalize_or_zero();
        let t_out = (axis[(i + 1).min(n - 1)] - axis[i]).normalize_or_zero();
        let t = (t_in + t_out).normalize();
        u = (u - t * u.dot(t)).normalize();
        let v = t.cross(u);
        // Mitre: stretch the ring across the corner so both tubes stay round.
        let stretch = 1.0 / t_in.dot(t).max(t_out.dot(t)).max(0.3);
        let bend = if t_in != Vec3::ZERO && t_out != Vec3::ZERO && t_in.dot(t_out) < 0.9999 {
            (t_out - t_in).normalize()
        } else {
            Vec3::ZERO
        };
        for j in 0..sides {
            let a = j as f32 / sides as f32 * std::f32::consts::TAU;
            let d = u * a.cos() + v * a.sin();
            let along_bend = d.dot(bend);
            m.positions
                .push(axis[i] + (d + bend * along_bend * (stretch - 1.0)) * r);
        }
    }
    for k in 0..n as u32 - 1 {
        for j in 0..sides {
            let j1 = (j + 1) % sides;
            let (a, b, c, d) = (
                k * sides + j,
                k * sides + j1,
                (k + 1) * sides + j1,
                (k + 1) * sides + j,
            );
            m.triangles.push([a, b, c]);
            m.triangles.push([a, c, d]);
        }
    }
    m
}

#[test]
fn sharp_kink_is_followed() {
    // 1.5 m level, then a 50° kink, then 1.5 m on; rings every 5 cm.
    let corner = Vec3::new(1.5, 1.0, 0.0);
    let dir2 = Vec3::new(50f32.to_radians().cos(), 0.0, 50f32.to_radians().sin());
    let mut axis: Vec<Vec3> = (0..=30)
        .map(|k| Vec3::new(k as f32 * 0.05, 1.0, 0.0))
        .collect();
    axis.extend((1..=30).map(|k| corner + dir2 * (k as f32 * 0.05)));
    let r = 0.05;
    let (scene, _) = import(&[tube_along(&axis, r, 12)], &[place(0, "kinked", 1.0)]).unwrap();
    assert_sane(&scene);
    let nodes: Vec<(Vec3, f32)> = scene
        .supports()
        .iter()
        .flat_map(|s| s.nodes.iter().copied().zip(s.radii.iter().copied()))
        .collect();
    let to_truth = |p: Vec3| {
        axis.windows(2)
            .map(|w| {
                slothsim_scene::closest_on_segment(w[0], w[1], p)
                    .0
                    .distance(p)
            })
            .fold(f32::INFINITY, f32::min)
    };
    for &(p, rad) in &nodes {
        if p.distance(corner) < 2.0 * r {
            continue;
        }
        assert!(
            to_truth(p) < 0.01,
            "node {p} is {} m off the axis",
            to_truth(p)
        );
        assert!((rad - r).abs() < 0.1 * r, "node {p}: radius {rad}");
    }
    // The skeleton turns at the kink: a node within 2 cm of the corner.
    let nearest = nodes
        .iter()
        .map(|(p, _)| p.distance(corner))
        .fold(f32::INFINITY, f32::min);
    assert!(
        nearest < 0.02,
        "closest node to the kink is {nearest} m away"
    );
    // Both legs are covered end to end.
    for end in [axis[0], axis[axis.len() - 1]] {
        let d = nodes
            .iter()
            .map(|(p, _)| p.distance(end))
            .fold(f32::INFINITY, f32::min);
        assert!(d < 0.02, "end {end} not reached ({d} m)");
    }
}
