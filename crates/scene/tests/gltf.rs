//! glTF import/export: round trips, validity of what we write, mesh fitting
//! of foreign files, node transforms, and every bad-input case.
//!
//! Length: one test file for glTF import/export round trips and every bad-input case, sharing its fixtures.

use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3};
use proptest::prelude::*;
use serde_json::{Value, json};
use slothsim_scene::{
    Scene, SceneError, Support, SupportKind, TriMesh, export_glb, export_gltf_json, import_slice,
    read_scene, write_scene,
};

// ---------------------------------------------------------------- helpers

/// A fresh directory under cargo's per-target temp dir.
fn temp_dir(test: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("gltf_{test}"));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Open tube around `a → b`: `rings` rings of `sides` vertices, indexed.
fn tube(a: Vec3, b: Vec3, r: f32, sides: u32, rings: u32) -> (Vec<Vec3>, Vec<u32>) {
    let t = (b - a).normalize();
    let u = t.any_orthonormal_vector();
    let v = t.cross(u);
    let mut p = Vec::new();
    for k in 0..rings {
        let c = a.lerp(b, k as f32 / (rings - 1) as f32);
        for j in 0..sides {
            let (s, co) = (j as f32 / sides as f32 * std::f32::consts::TAU).sin_cos();
            p.push(c + (u * co + v * s) * r);
        }
    }
    let mut idx = Vec::new();
    for k in 0..rings - 1 {
        for j in 0..sides {
            let j1 = (j + 1) % sides;
            let (a0, b0, c0, d0) = (
                k * sides + j,
                k * sides + j1,
                (k + 1) * sides + j1,
                (k + 1) * sides + j,
            );
            idx.extend_from_slice(&[a0, b0, c0, a0, c0, d0]);
        }
    }
    (p, idx)
}

/// Un-indexes a mesh: every triangle gets its own three vertices.
fn soup(p: &[Vec3], idx: &[u32]) -> Vec<Vec3> {
    idx.iter().map(|&i| p[i as usize]).collect()
}

/// Hand-made glTF documents (independent of the exporter under test).
#[derive(Default)]
struct Doc {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
    meshes: Vec<Value>,
    nodes: Vec<Value>,
}

impl Doc {
    fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()}));
        self.bin.extend_from_slice(bytes);
        self.views.len() - 1
    }

    fn positions(&mut self, p: &[Vec3]) -> usize {
        let bytes: Vec<u8> = p
            .iter()
            .flat_map(|v| v.to_array())
            .flat_map(f32::to_le_bytes)
            .collect();
        let view = self.view(&bytes);
        let min = p.iter().fold(Vec3::INFINITY, |a, b| a.min(*b));
        let max = p.iter().fold(Vec3::NEG_INFINITY, |a, b| a.max(*b));
        self.accessors.push(json!({
            "bufferView": view, "componentType": 5126, "count": p.len(), "type": "VEC3",
            "min": min.to_array(), "max": max.to_array(),
        }));
        self.accessors.len() - 1
    }

    fn indices(&mut self, i: &[u32]) -> usize {
        let bytes: Vec<u8> = i.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessors.push(
            json!({"bufferView": view, "componentType": 5125, "count": i.len(), "type": "SCALAR"}),
        );
        self.accessors.len() - 1
    }

    /// A primitive: indexed when `idx` is given; `mode` 4 = TRIANGLES.
    fn prim(&mut self, p: &[Vec3], idx: Option<&[u32]>, mode: u32) -> Value {
        let pos = self.positions(p);
        match idx {
            Some(i) => {
                let ind = self.indices(i);
                json!({"attributes": {"POSITION": pos}, "indices": ind, "mode": mode})
            }
            None => json!({"attributes": {"POSITION": pos}, "mode": mode}),
        }
    }

    fn mesh(&mut self, primitives: Vec<Value>) -> usize {
        self.meshes.push(json!({ "primitives": primitives }));
        self.meshes.len() - 1
    }

    fn node(&mut self, node: Value) -> usize {
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    fn root(&self, roots: &[usize], buffer_uri: Option<&str>) -> Value {
        let mut buffer = json!({"byteLength": self.bin.len()});
        if let Some(uri) = buffer_uri {
            buffer["uri"] = json!(uri);
        }
        let mut root = json!({
            "asset": {"version": "2.0"},
            "scene": 0,
            "scenes": [{"nodes": roots}],
            "nodes": self.nodes,
        });
        if !self.meshes.is_empty() {
            root["meshes"] = json!(self.meshes);
        }
        if !self.bin.is_empty() {
            root["buffers"] = json!([buffer]);
            root["bufferViews"] = json!(self.views);
            root["accessors"] = json!(self.accessors);
        }
        root
    }

    fn glb(&self, roots: &[usize]) -> Vec<u8> {
        let mut json = serde_json::to_vec(&self.root(roots, None)).unwrap();
        while !json.len().is_multiple_of(4) {
            json.push(b' ');
        }
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let total = 12 + 8 + json.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
        let mut out = b"glTF".to_vec();
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        if !bin.is_empty() {
            out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            out.extend_from_slice(&bin);
        }
        out
    }
}

/// A small scene that exercises every exported feature.
fn sample_scene() -> Scene {
    let (tp, ti) = tube(
        Vec3::new(3.0, 0.5, 1.0),
        Vec3::new(4.0, 1.0, 1.5),
        0.05,
        6,
        3,
    );
    let mesh = TriMesh {
        positions: tp,
        triangles: ti.chunks(3).map(|t| [t[0], t[1], t[2]]).collect(),
    };
    Scene::new(vec![
        Support::new(vec![Vec3::ZERO, Vec3::new(0.0, 5.0, 0.0)], vec![0.3, 0.2])
            .with_kind(SupportKind::Trunk)
            .with_name("big trunk"),
        Support::new(
            vec![Vec3::new(0.2, 2.0, 0.0), Vec3::new(2.0, 2.5, 0.1)],
            vec![0.08, 0.05],
        ),
        Support::new(
            vec![
                Vec3::new(-0.2, 3.0, 0.0),
                Vec3::new(-1.0, 3.3, 0.4),
                Vec3::new(-1.7, 3.4, 1.1),
                Vec3::new(-2.1, 3.2, 1.9),
            ],
            vec![0.07, 0.06, 0.045, 0.03],
        )
        .with_kind(SupportKind::Branch),
        // A user name that looks like a generated one must survive.
        Support::new(
            vec![Vec3::new(5.0, 0.0, 0.0), Vec3::new(5.1, 6.0, 0.0)],
            vec![0.25, 0.25],
        )
        .with_name("trunk_7"),
        Support::new(
            vec![Vec3::new(3.0, 0.5, 1.0), Vec3::new(4.0, 1.0, 1.5)],
            vec![0.05, 0.05],
        )
        .with_name("imported")
        .with_mesh(mesh),
    ])
    .unwrap()
}

fn assert_same_scene(a: &Scene, b: &Scene) {
    assert_eq!(a.supports().len(), b.supports().len());
    for (x, y) in a.supports().iter().zip(b.supports()) {
        let who = x.label();
        assert_eq!(x.id, y.id, "{who}");
        assert_eq!(x.kind, y.kind, "{who}");
        assert_eq!(x.tagged, y.tagged, "{who}");
        assert_eq!(x.name, y.name, "{who}");
        assert_eq!(x.nodes.len(), y.nodes.len(), "{who}");
        for (p, q) in x.nodes.iter().zip(&y.nodes) {
            assert!(p.distance(*q) <= 1e-5, "{who}: node {p} vs {q}");
        }
        for (r, s) in x.radii.iter().zip(&y.radii) {
            assert!((r - s).abs() <= 1e-5, "{who}: radius {r} vs {s}");
        }
        match (&x.mesh, &y.mesh) {
            (None, None) => {}
            (Some(m), Some(n)) => {
                assert_eq!(m.triangles, n.triangles, "{who}");
                assert_eq!(m.positions.len(), n.positions.len(), "{who}");
                for (p, q) in m.positions.iter().zip(&n.positions) {
                    assert!(p.distance(*q) <= 1e-5, "{who}: vertex {p} vs {q}");
                }
            }
            _ => panic!("{who}: mesh presence differs"),
        }
    }
}

fn gltf_err(result: Result<Scene, SceneError>) -> (String, String) {
    match result {
        Err(SceneError::Gltf { file, detail }) => (file, detail),
        other => panic!("expected SceneError::Gltf, got {other:?}"),
    }
}

/// A GLB whose single node carries `extras`, over a small tube mesh.
fn glb_with_extras(name: &str, extras: Value) -> Vec<u8> {
    let mut doc = Doc::default();
    let (p, i) = tube(Vec3::ZERO, Vec3::Y, 0.1, 6, 2);
    let prim = doc.prim(&p, Some(&i), 4);
    let mesh = doc.mesh(vec![prim]);
    let node = doc.node(json!({"name": name, "mesh": mesh, "extras": extras}));
    doc.glb(&[node])
}

// ---------------------------------------------------------------- round trips

#[test]
fn glb_round_trip_is_exact() {
    let scene = sample_scene();
    let back = import_slice(&export_glb(&scene), "rt.glb").unwrap();
    assert_same_scene(&scene, &back);
}

#[test]
fn gltf_json_round_trip_is_exact() {
    let scene = sample_scene();
    let text = export_gltf_json(&scene);
    assert!(text.contains("data:application/octet-stream;base64,"));
    let back = import_slice(text.as_bytes(), "rt.gltf").unwrap();
    assert_same_scene(&scene, &back);
}

#[test]
fn write_then_read_files_round_trip() {
    let dir = temp_dir("files");
    let scene = sample_scene();
    for name in ["forest.glb", "forest.gltf", "FOREST.GLB"] {
        let path = dir.join(name);
        write_scene(&scene, &path).unwrap();
        assert_same_scene(&scene, &read_scene(&path).unwrap());
    }
    // Only the three files: no temporary leftovers.
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut expected = vec!["FOREST.GLB", "forest.glb", "forest.gltf"];
    expected.sort();
    assert_eq!(names, expected);
}

#[test]
fn export_is_deterministic() {
    assert_eq!(export_glb(&sample_scene()), export_glb(&sample_scene()));
    assert_eq!(
        export_gltf_json(&sample_scene()),
        export_gltf_json(&sample_scene())
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]
    #[test]
    fn random_supports_round_trip(
        raw in prop::collection::vec(
            (prop::collection::vec((-50.0f32..50.0, -50.0f32..50.0, -50.0f32..50.0, 0.01f32..2.0), 2..6),
             any::<bool>(), any::<bool>()),
            1..5)
    ) {
        let supports: Vec<Support> = raw
            .iter()
            .map(|(nodes, tag, named)| {
                let mut s = Support::new(
                    nodes.iter().map(|n| Vec3::new(n.0, n.1, n.2)).collect(),
                    nodes.iter().map(|n| n.3).collect(),
                );
                if *tag {
                    s = s.with_kind(SupportKind::Trunk);
                }
                if *named {
                    s = s.with_name("n ✓");
                }
                s
            })
            .collect();
        // Random polylines may have (near) zero-length segments: skip those.
        prop_assume!(supports.iter().all(|s| s.nodes.windows(2).all(|w| w[0].distance(w[1]) > 1e-3)));
        let scene = Scene::new(supports).unwrap();
        assert_same_scene(&scene, &import_slice(&export_glb(&scene), "p.glb").unwrap());
    }
}

// ---------------------------------------------------------------- validity of the output

#[test]
fn exported_glb_is_valid_gltf() {
    let scene = sample_scene();
    let bytes = export_glb(&scene);
    assert_eq!(&bytes[..4], b"glTF");
    assert_eq!(bytes.len() % 4, 0);
    assert_eq!(
        u32::from_le_bytes(bytes[8..12].try_into().unwrap()) as usize,
        bytes.len()
    );

    let gltf = gltf::Gltf::from_slice(&bytes).expect("validates");
    let root = gltf.document.as_json();
    assert_eq!(root.asset.version, "2.0");
    let default_scene = gltf.document.default_scene().expect("default scene");
    assert_eq!(default_scene.nodes().count(), scene.supports().len());
    let names: Vec<_> = default_scene
        .nodes()
        .map(|n| n.name().unwrap().to_string())
        .collect();
    assert_eq!(
        names,
        ["big trunk", "branch_1", "branch_2", "trunk_7", "imported"]
    );

    for view in gltf.document.views() {
        assert_eq!(view.offset() % 4, 0, "view {} misaligned", view.index());
    }
    for mesh in gltf.document.meshes() {
        for prim in mesh.primitives() {
            assert_eq!(prim.mode(), gltf::mesh::Mode::Triangles);
            let pos = prim.get(&gltf::Semantic::Positions).expect("POSITION");
            assert!(
                pos.min().is_some() && pos.max().is_some(),
                "POSITION min/max"
            );
            assert!(prim.get(&gltf::Semantic::Normals).is_some(), "NORMAL");
        }
    }

    let (doc, buffers, _) = gltf::import_slice(&bytes).expect("imports");
    // min/max really bound the data.
    for mesh in doc.meshes() {
        for prim in mesh.primitives() {
            let reader = prim.reader(|b| Some(&buffers[b.index()]));
            let acc = prim.get(&gltf::Semantic::Positions).unwrap();
            let min: Vec<f32> = serde_json::from_value(acc.min().unwrap()).unwrap();
            let max: Vec<f32> = serde_json::from_value(acc.max().unwrap()).unwrap();
            for p in reader.read_positions().unwrap() {
                for k in 0..3 {
                    assert!(min[k] <= p[k] && p[k] <= max[k]);
                }
            }
            let n = reader.read_positions().unwrap().count() as u32;
            assert!(reader.read_indices().unwrap().into_u32().all(|i| i < n));
        }
    }
}

#[test]
fn exported_gltf_json_is_valid_gltf() {
    let text = export_gltf_json(&sample_scene());
    gltf::Gltf::from_slice(text.as_bytes()).expect("validates");
    gltf::import_slice(text.as_bytes()).expect("imports");
}

#[test]
fn node_extras_follow_the_schema() {
    let gltf = gltf::Gltf::from_slice(&export_glb(&sample_scene())).unwrap();
    let extras: Vec<Value> = gltf
        .document
        .nodes()
        .map(|n| serde_json::from_str(n.extras().as_ref().unwrap().get()).unwrap())
        .collect();
    assert_eq!(
        extras[0],
        json!({"slothsim": {"kind": "trunk", "tagged": true, "axis": [[0.0, 0.0, 0.0], [0.0, 5.0, 0.0]], "radii": [0.3, 0.2]}})
    );
    assert_eq!(extras[1]["slothsim"]["kind"], "branch");
    assert_eq!(extras[1]["slothsim"]["tagged"], false);
    assert_eq!(extras[1]["slothsim"]["name_generated"], true);
    assert_eq!(extras[4]["slothsim"]["mesh"], true);
}

#[test]
fn exported_tube_faces_outward() {
    let scene = sample_scene();
    let (doc, buffers, _) = gltf::import_slice(export_glb(&scene)).unwrap();
    for (support, mesh) in scene.supports().iter().zip(doc.meshes()).take(4) {
        let prim = mesh.primitives().next().unwrap();
        let reader = prim.reader(|b| Some(&buffers[b.index()]));
        let p: Vec<Vec3> = reader
            .read_positions()
            .unwrap()
            .map(Vec3::from_array)
            .collect();
        let n: Vec<Vec3> = reader
            .read_normals()
            .unwrap()
            .map(Vec3::from_array)
            .collect();
        let idx: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
        for t in idx.chunks(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| p[i as usize]);
            let face = (b - a).cross(c - a);
            let centroid = (a + b + c) / 3.0;
            let (on_axis, ..) = support.closest_on_axis(centroid);
            assert!(
                face.dot(centroid - on_axis) > 0.0,
                "{}: inward triangle {t:?}",
                support.label()
            );
            for &i in t {
                assert!(
                    n[i as usize].dot(face) > 0.0,
                    "{}: normal disagrees",
                    support.label()
                );
            }
        }
        // Every vertex lies on the capsule surface (within tessellation of the taper).
        for q in &p {
            let (on_axis, _, _, r) = support.closest_on_axis(*q);
            assert!(
                (q.distance(on_axis) - r).abs() < 0.15 * r + 1e-4,
                "{}",
                support.label()
            );
        }
    }
}

#[test]
fn empty_scene_exports_valid_gltf_and_imports_as_no_supports() {
    let scene = Scene::new(Vec::new()).unwrap();
    let bytes = export_glb(&scene);
    gltf::Gltf::from_slice(&bytes).expect("validates");
    assert!(matches!(
        import_slice(&bytes, "empty.glb"),
        Err(SceneError::NoSupports { .. })
    ));
}

// ---------------------------------------------------------------- foreign meshes

#[test]
fn single_mesh_tree_splits_into_three_supports() {
    let trunk = (Vec3::ZERO, Vec3::new(0.0, 4.0, 0.0), 0.2);
    let branch_a = (Vec3::new(0.25, 2.0, 0.0), Vec3::new(2.25, 2.8, 0.0), 0.06);
    let branch_b = (Vec3::new(0.0, 3.0, 0.25), Vec3::new(0.0, 3.9, 1.8), 0.05);

    let mut doc = Doc::default();
    // Primitive 0: trunk, indexed, with an exact duplicate ring (vertices
    // repeated, triangles referring to both copies).
    let (mut tp, mut ti) = tube(trunk.0, trunk.1, trunk.2, 16, 9);
    let dup_base = tp.len() as u32;
    tp.extend_from_within(0..16);
    for i in ti.iter_mut().take(48) {
        if *i < 16 {
            *i += dup_base;
        }
    }
    let p0 = doc.prim(&tp, Some(&ti), 4);
    // Primitive 1: branch A as a non-indexed triangle soup.
    let (ap, ai) = tube(branch_a.0, branch_a.1, branch_a.2, 12, 8);
    let p1 = doc.prim(&soup(&ap, &ai), None, 4);
    // Primitives 2 and 3: branch B split in halves that duplicate the seam ring.
    let (bp, bi) = tube(branch_b.0, branch_b.1, branch_b.2, 12, 8);
    let half = bi.len() / 2;
    let p2 = doc.prim(&bp, Some(&bi[..half]), 4);
    let p3 = doc.prim(&bp, Some(&bi[half..]), 4);
    // A lines primitive in the same mesh is ignored.
    let lines = doc.prim(&[Vec3::ZERO, Vec3::X * 9.0], None, 1);
    let mesh = doc.mesh(vec![p0, p1, p2, lines, p3]);
    let node = doc.node(json!({"name": "tree", "mesh": mesh}));

    let scene = import_slice(&doc.glb(&[node]), "tree.glb").unwrap();
    let s = scene.supports();
    assert_eq!(s.len(), 3, "{s:#?}");
    let expected = [
        (trunk, SupportKind::Trunk, "tree/0"),
        (branch_a, SupportKind::Branch, "tree/1"),
        (branch_b, SupportKind::Branch, "tree/2"),
    ];
    for (support, ((a, b, r), kind, name)) in s.iter().zip(expected) {
        assert_eq!(support.kind, kind, "{name}");
        assert!(!support.tagged, "{name}");
        assert_eq!(support.name.as_deref(), Some(name));
        let first = support.nodes[0];
        let last = *support.nodes.last().unwrap();
        assert!(
            first.distance(a) < 0.2 * r + 1e-3,
            "{name}: start {first} vs {a}"
        );
        assert!(
            last.distance(b) < 0.2 * r + 1e-3,
            "{name}: end {last} vs {b}"
        );
        for &fitted in &support.radii {
            assert!(
                (fitted - r).abs() <= 0.1 * r,
                "{name}: radius {fitted} vs {r}"
            );
        }
        let mesh = support.mesh.as_ref().expect("keeps triangles");
        assert!(!mesh.triangles.is_empty());
        // Welded: every vertex of a part is distinct.
        for (i, p) in mesh.positions.iter().enumerate() {
            assert!(
                mesh.positions[i + 1..]
                    .iter()
                    .all(|q| q.distance(*p) > 1e-6),
                "{name}: duplicate vertex"
            );
        }
    }
    assert_eq!(s[0].mesh.as_ref().unwrap().positions.len(), 16 * 9);
}

#[test]
fn tapered_mesh_gives_tapered_radii() {
    // A cone frustum from r = 0.3 at the bottom to 0.1 at the top, 6 m long.
    let mut doc = Doc::default();
    let (mut p, i) = tube(Vec3::ZERO, Vec3::new(0.0, 6.0, 0.0), 1.0, 16, 13);
    for q in &mut p {
        let r = 0.3 - 0.2 * q.y / 6.0;
        *q = Vec3::new(q.x * r, q.y, q.z * r);
    }
    let prim = doc.prim(&p, Some(&i), 4);
    let mesh = doc.mesh(vec![prim]);
    let node = doc.node(json!({"mesh": mesh}));
    let scene = import_slice(&doc.glb(&[node]), "cone.glb").unwrap();
    let s = &scene.supports()[0];
    assert!(s.nodes.len() > 2);
    for (n, r) in s.nodes.iter().zip(&s.radii) {
        let expected = 0.3 - 0.2 * n.y / 6.0;
        assert!(
            (r - expected).abs() < 0.1 * expected,
            "radius {r} at y {} vs {expected}",
            n.y
        );
    }
}

#[test]
fn name_prefix_tags_kind() {
    let mut doc = Doc::default();
    // Tilted 30°: the tilt rule would say branch, the name says trunk.
    let (p, i) = tube(
        Vec3::ZERO,
        Vec3::new(2.0, 2.0 * 30f32.to_radians().tan(), 0.0),
        0.1,
        8,
        4,
    );
    let prim = doc.prim(&p, Some(&i), 4);
    let m0 = doc.mesh(vec![prim]);
    // Vertical: tilt rule says trunk, the name says branch.
    let (p, i) = tube(
        Vec3::new(5.0, 0.0, 0.0),
        Vec3::new(5.0, 3.0, 0.0),
        0.1,
        8,
        4,
    );
    let prim = doc.prim(&p, Some(&i), 4);
    let m1 = doc.mesh(vec![prim]);
    // Untagged vertical: trunk by tilt.
    let (p, i) = tube(
        Vec3::new(9.0, 0.0, 0.0),
        Vec3::new(9.0, 3.0, 0.0),
        0.1,
        8,
        4,
    );
    let prim = doc.prim(&p, Some(&i), 4);
    let m2 = doc.mesh(vec![prim]);
    let n0 = doc.node(json!({"name": "Trunk.001", "mesh": m0}));
    let n1 = doc.node(json!({"name": "BRANCH_left", "mesh": m1}));
    let n2 = doc.node(json!({"name": "pole", "mesh": m2}));
    let scene = import_slice(&doc.glb(&[n0, n1, n2]), "tags.glb").unwrap();
    let got: Vec<_> = scene
        .supports()
        .iter()
        .map(|s| (s.kind, s.tagged, s.name.clone().unwrap()))
        .collect();
    assert_eq!(
        got,
        [
            (SupportKind::Trunk, true, "Trunk.001".to_string()),
            (SupportKind::Branch, true, "BRANCH_left".to_string()),
            (SupportKind::Trunk, false, "pole".to_string()),
        ]
    );
}

#[test]
fn node_transforms_are_applied() {
    let mut doc = Doc::default();
    // A vertical tube in the child's frame, 2 m long, r 0.1.
    let (p, i) = tube(Vec3::ZERO, Vec3::new(0.0, 2.0, 0.0), 0.1, 8, 5);
    let prim = doc.prim(&p, Some(&i), 4);
    let mesh = doc.mesh(vec![prim]);
    let rot = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2);
    let child = doc.node(json!({"name": "limb", "mesh": mesh, "translation": [0.0, 1.0, 0.0]}));
    // A tagged support under the same parent, scaled by 2.
    let tagged = doc.node(json!({
        "name": "tagged", "mesh": mesh, "scale": [2.0, 2.0, 2.0],
        "extras": {"slothsim": {"kind": "trunk", "axis": [[0, 0, 0], [0, 1, 0]], "radii": [0.1, 0.05]}},
    }));
    let parent = doc.node(json!({
        "name": "parent",
        "translation": [10.0, 0.0, 5.0],
        "rotation": rot.to_array(),
        "children": [child, tagged],
    }));
    let scene = import_slice(&doc.glb(&[parent]), "xf.glb").unwrap();
    let world = Mat4::from_rotation_translation(rot, Vec3::new(10.0, 0.0, 5.0))
        * Mat4::from_translation(Vec3::Y);
    let (a, b) = (
        world.transform_point3(Vec3::ZERO),
        world.transform_point3(Vec3::new(0.0, 2.0, 0.0)),
    );
    let s = &scene.supports()[0];
    assert_eq!(s.kind, SupportKind::Branch, "rotated to horizontal");
    let (first, last) = (s.nodes[0], *s.nodes.last().unwrap());
    // Direction sign is canonical (+X when level), so compare as a set.
    let ok = (first.distance(a) < 0.02 && last.distance(b) < 0.02)
        || (first.distance(b) < 0.02 && last.distance(a) < 0.02);
    assert!(ok, "{first} {last} vs {a} {b}");
    let mesh_world = s.mesh.as_ref().unwrap();
    let expected = world.transform_point3(p[0]);
    assert!(
        mesh_world
            .positions
            .iter()
            .any(|q| q.distance(expected) < 1e-5)
    );

    let t = &scene.supports()[1];
    let tw = Mat4::from_rotation_translation(rot, Vec3::new(10.0, 0.0, 5.0))
        * Mat4::from_scale(Vec3::splat(2.0));
    assert!(t.nodes[0].distance(tw.transform_point3(Vec3::ZERO)) < 1e-5);
    assert!(t.nodes[1].distance(tw.transform_point3(Vec3::Y)) < 1e-5);
    assert!((t.radii[0] - 0.2).abs() < 1e-5 && (t.radii[1] - 0.1).abs() < 1e-5);
    assert_eq!(
        (t.kind, t.tagged, t.mesh.is_none()),
        (SupportKind::Trunk, true, true)
    );
}

#[test]
fn degenerate_parts_are_skipped() {
    let mut doc = Doc::default();
    let (p, i) = tube(Vec3::ZERO, Vec3::new(0.0, 3.0, 0.0), 0.1, 8, 4);
    let good = doc.prim(&p, Some(&i), 4);
    // Collinear triangles and a zero-area sliver, disconnected from the tube.
    let line = [
        Vec3::new(5.0, 0.0, 0.0),
        Vec3::new(6.0, 0.0, 0.0),
        Vec3::new(7.0, 0.0, 0.0),
    ];
    let bad = doc.prim(&line, None, 4);
    let points = doc.prim(&[Vec3::ONE, Vec3::ZERO, Vec3::X], None, 0);
    let mesh = doc.mesh(vec![bad, good, points]);
    let node = doc.node(json!({"name": "stick", "mesh": mesh}));
    let scene = import_slice(&doc.glb(&[node]), "mixed.glb").unwrap();
    assert_eq!(scene.supports().len(), 1);
    assert_eq!(scene.supports()[0].name.as_deref(), Some("stick"));
}

#[test]
fn external_bin_is_resolved_relative_to_the_file() {
    let dir = temp_dir("external");
    let mut doc = Doc::default();
    let (p, i) = tube(Vec3::ZERO, Vec3::new(0.0, 3.0, 0.0), 0.1, 8, 4);
    let prim = doc.prim(&p, Some(&i), 4);
    let mesh = doc.mesh(vec![prim]);
    let node = doc.node(json!({"name": "ext", "mesh": mesh}));
    let root = doc.root(&[node], Some("ext%20data.bin"));
    std::fs::write(dir.join("ext data.bin"), &doc.bin).unwrap();
    let path = dir.join("ext.gltf");
    std::fs::write(&path, serde_json::to_vec(&root).unwrap()).unwrap();
    let scene = read_scene(&path).unwrap();
    assert_eq!(scene.supports().len(), 1);

    // From memory the same document is refused, naming the buffer.
    let bytes = std::fs::read(&path).unwrap();
    let (file, detail) = gltf_err(import_slice(&bytes, "mem.gltf"));
    assert_eq!(file, "mem.gltf");
    assert!(
        detail.contains("external") && detail.contains("ext%20data.bin"),
        "{detail}"
    );

    // A missing .bin names the buffer and the file.
    std::fs::remove_file(dir.join("ext data.bin")).unwrap();
    let (file, detail) = gltf_err(read_scene(&path));
    assert!(file.ends_with("ext.gltf"), "{file}");
    assert!(detail.contains("buffer 0"), "{detail}");
}

// ---------------------------------------------------------------- bad input

#[test]
fn missing_file_is_io_error_naming_it() {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("no_such_forest.glb");
    let err = read_scene(&path).unwrap_err();
    assert!(matches!(err, SceneError::Io { .. }), "{err:?}");
    assert!(err.to_string().contains("no_such_forest.glb"), "{err}");
}

#[test]
fn truncated_glb_is_rejected() {
    let bytes = export_glb(&sample_scene());
    for cut in [0, 7, 20, bytes.len() / 2, bytes.len() - 1] {
        let (file, detail) = gltf_err(import_slice(&bytes[..cut], "cut.glb"));
        assert_eq!(file, "cut.glb");
        assert!(!detail.is_empty());
    }
    let dir = temp_dir("truncated");
    let path = dir.join("cut.glb");
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let err = read_scene(&path).unwrap_err();
    assert!(
        matches!(err, SceneError::Gltf { .. }) && err.to_string().contains("cut.glb"),
        "{err}"
    );
}

#[test]
fn non_gltf_bytes_are_rejected() {
    for bytes in [
        &b"hello world"[..],
        b"{\"not\": \"gltf\"}",
        b"glTF\x02\0\0\0",
        &[0xff; 64],
    ] {
        let (file, detail) = gltf_err(import_slice(bytes, "junk.bin"));
        assert_eq!(file, "junk.bin");
        assert!(detail.contains("not a valid glTF"), "{detail}");
    }
}

#[test]
fn file_without_usable_supports_is_no_supports() {
    let mut doc = Doc::default();
    let empty = doc.node(json!({"name": "camera rig"}));
    let err = import_slice(&doc.glb(&[empty]), "bare.glb").unwrap_err();
    assert!(
        matches!(&err, SceneError::NoSupports { source_name, .. } if source_name == "bare.glb"),
        "{err:?}"
    );
    assert!(err.to_string().contains("bare.glb"));

    // Only lines and degenerate triangles.
    let mut doc = Doc::default();
    let lines = doc.prim(&[Vec3::ZERO, Vec3::Y], None, 1);
    let flat = doc.prim(&[Vec3::ZERO, Vec3::Y, Vec3::Y * 2.0], None, 4);
    let mesh = doc.mesh(vec![lines, flat]);
    let node = doc.node(json!({"mesh": mesh}));
    let err = import_slice(&doc.glb(&[node]), "lines.glb").unwrap_err();
    assert!(matches!(err, SceneError::NoSupports { .. }), "{err:?}");
}

fn extras_error(name: &str, block: Value) -> String {
    let (file, detail) = gltf_err(import_slice(
        &glb_with_extras(name, json!({ "slothsim": block })),
        "bad.glb",
    ));
    assert_eq!(file, "bad.glb");
    assert!(detail.contains(&format!("node 0 `{name}`")), "{detail}");
    detail
}

#[test]
fn nan_radius_in_extras_is_rejected() {
    // serde_json writes NaN as null.
    let d = extras_error(
        "nan",
        json!({"kind": "branch", "axis": [[0, 0, 0], [1, 0, 0]], "radii": [0.1, null]}),
    );
    assert!(
        d.contains("radii") && d.contains("radius 1") && d.contains("NaN"),
        "{d}"
    );
    let d = extras_error(
        "huge",
        json!({"kind": "branch", "axis": [[0, 0, 0], [1, 0, 0]], "radii": [0.1, 1e300]}),
    );
    assert!(d.contains("radii"), "{d}");
    let d = extras_error(
        "nan axis",
        json!({"kind": "branch", "axis": [[0, 0, 0], [1, null, 0]], "radii": [0.1, 0.1]}),
    );
    assert!(d.contains("axis") && d.contains("node 1"), "{d}");
}

#[test]
fn negative_radius_in_extras_is_rejected() {
    let d = extras_error(
        "neg",
        json!({"kind": "trunk", "axis": [[0, 0, 0], [0, 1, 0]], "radii": [-0.5, 0.1]}),
    );
    assert!(d.contains("radii") && d.contains("-0.5"), "{d}");
}

#[test]
fn zero_length_segment_in_extras_is_rejected() {
    let d = extras_error(
        "zero",
        json!({"kind": "trunk", "axis": [[0, 0, 0], [0, 1, 0], [0, 1, 0]], "radii": [0.1, 0.1, 0.1]}),
    );
    assert!(
        d.contains("axis") && d.contains("segment 1") && d.contains("zero length"),
        "{d}"
    );
}

#[test]
fn mismatched_axis_and_radii_are_rejected() {
    let d = extras_error(
        "mismatch",
        json!({"kind": "trunk", "axis": [[0, 0, 0], [0, 1, 0], [0, 2, 0]], "radii": [0.1, 0.1]}),
    );
    assert!(
        d.contains("radii") && d.contains("2 values for 3 axis nodes"),
        "{d}"
    );
}

#[test]
fn malformed_extras_fields_are_rejected() {
    let d = extras_error(
        "kind",
        json!({"kind": "twig", "axis": [[0, 0, 0], [0, 1, 0]], "radii": [0.1, 0.1]}),
    );
    assert!(d.contains("kind") && d.contains("twig"), "{d}");
    let d = extras_error("no axis", json!({"kind": "trunk", "radii": [0.1, 0.1]}));
    assert!(d.contains("axis") && d.contains("missing"), "{d}");
    let d = extras_error(
        "one node",
        json!({"kind": "trunk", "axis": [[0, 0, 0]], "radii": [0.1]}),
    );
    assert!(d.contains("at least 2"), "{d}");
    let d = extras_error(
        "flag",
        json!({"kind": "trunk", "tagged": "yes", "axis": [[0, 0, 0], [0, 1, 0]], "radii": [0.1, 0.1]}),
    );
    assert!(d.contains("tagged"), "{d}");
    let (_, d) = gltf_err(import_slice(
        &glb_with_extras("scalar", json!({"slothsim": 3})),
        "bad.glb",
    ));
    assert!(
        d.contains("node 0 `scalar`") && d.contains("must be an object"),
        "{d}"
    );
}

#[test]
fn out_of_range_index_is_rejected() {
    let mut doc = Doc::default();
    let prim = doc.prim(&[Vec3::ZERO, Vec3::X, Vec3::Y], Some(&[0, 1, 7]), 4);
    let mesh = doc.mesh(vec![prim]);
    let node = doc.node(json!({"name": "broken", "mesh": mesh}));
    let (_, d) = gltf_err(import_slice(&doc.glb(&[node]), "idx.glb"));
    assert!(
        d.contains("node 0 `broken`") && d.contains("index 7 out of range"),
        "{d}"
    );
}

#[test]
fn unknown_extension_is_rejected_without_writing() {
    let dir = temp_dir("ext");
    let path = dir.join("forest.obj");
    let (file, detail) = match write_scene(&sample_scene(), &path) {
        Err(SceneError::Gltf { file, detail }) => (file, detail),
        other => panic!("{other:?}"),
    };
    assert!(file.ends_with("forest.obj"));
    assert!(detail.contains(".obj"), "{detail}");
    assert!(write_scene(&sample_scene(), &dir.join("forest")).is_err());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
}

#[test]
fn write_into_missing_directory_is_io_error() {
    let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join("no_such_dir/forest.glb");
    let err = write_scene(&sample_scene(), &path).unwrap_err();
    assert!(
        matches!(err, SceneError::Io { .. }) && err.to_string().contains("forest.glb"),
        "{err}"
    );
}

#[test]
fn far_away_tiny_mesh_does_not_overflow_the_weld_grid() {
    let mut doc = Doc::default();
    let (p, i) = tube(Vec3::ZERO, Vec3::new(0.0, 3.0, 0.0), 0.1, 8, 4);
    let far: Vec<Vec3> = p.iter().map(|q| *q + Vec3::splat(1e30)).collect();
    let prim = doc.prim(&far, Some(&i), 4);
    let mesh = doc.mesh(vec![prim]);
    let node = doc.node(json!({"mesh": mesh}));
    // All vertices collapse at this magnitude: an error, not a panic.
    let _ = import_slice(&doc.glb(&[node]), "far.glb");
}

/// A corrupted file gives a valid scene or an error that the up-front checks
/// produced (not the catch-all for a panicking glTF reader).
fn check_fuzz_result(result: Result<Scene, SceneError>) -> Result<(), TestCaseError> {
    match result {
        Ok(scene) => {
            for s in scene.supports() {
                prop_assert!(s.nodes.iter().all(|n| n.is_finite()));
                prop_assert!(s.radii.iter().all(|r| r.is_finite() && *r > 0.0));
            }
        }
        Err(e) => prop_assert!(!e.to_string().contains("reader failed"), "{e}"),
    }
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]
    /// Corrupted files give an error or a valid scene, never a panic or NaN.
    #[test]
    fn corrupted_files_never_panic(
        edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        gltf_text in any::<bool>(),
    ) {
        let mut bytes = if gltf_text {
            export_gltf_json(&sample_scene()).into_bytes()
        } else {
            export_glb(&sample_scene())
        };
        for (at, value) in edits {
            let i = at.index(bytes.len());
            bytes[i] = value;
        }
        check_fuzz_result(import_slice(&bytes, "fuzz.glb"))?;
    }
}

/// Pointers (RFC 6901) to every number in a JSON value.
fn number_pointers(v: &Value, at: String, out: &mut Vec<String>) {
    match v {
        Value::Number(_) => out.push(at),
        Value::Array(a) => a
            .iter()
            .enumerate()
            .for_each(|(i, x)| number_pointers(x, format!("{at}/{i}"), out)),
        Value::Object(o) => o
            .iter()
            .for_each(|(k, x)| number_pointers(x, format!("{at}/{k}"), out)),
        _ => {}
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]
    /// Well-formed JSON with wrong numbers (indices, counts, offsets, extras)
    /// gives an error or a valid scene, never a panic.
    #[test]
    fn wrong_numbers_never_panic(
        edits in prop::collection::vec(
            (any::<prop::sample::Index>(),
             prop_oneof![Just(json!(0)), Just(json!(1)), Just(json!(-1)), Just(json!(7)), Just(json!(1000)),
                         Just(json!(4294967295u64)), Just(json!(1e39)), Just(json!(0.5))]),
            1..4),
    ) {
        let mut root: Value = serde_json::from_str(&export_gltf_json(&sample_scene())).unwrap();
        let mut pointers = Vec::new();
        number_pointers(&root, String::new(), &mut pointers);
        for (at, value) in edits {
            let pointer = &pointers[at.index(pointers.len())];
            *root.pointer_mut(pointer).unwrap() = value;
        }
        let bytes = serde_json::to_vec(&root).unwrap();
        check_fuzz_result(import_slice(&bytes, "fuzz.gltf"))?;
    }
}
