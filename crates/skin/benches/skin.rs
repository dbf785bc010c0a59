//! µs per sloth mesh (2,650 vertices) for LBS, DQS and control clusters, at a pose with
//! every limb's elbow/knee and wrist/ankle flexed to half its limit.

use criterion::{Criterion, criterion_group, criterion_main};
use slothsim_skin::{ClusterSkin, LimbJoint, ReferenceShapes, SkinMesh};

fn bench(c: &mut Criterion) {
    let mesh = SkinMesh::sloth().expect("asset");
    let clusters = ClusterSkin::new(&mesh, &ReferenceShapes::sloth().expect("refs")).expect("skin");
    let mut locals = mesh.rig.skeleton().rest_rotations();
    for lj in LimbJoint::all() {
        let (axis, limit) = lj.flexion(&mesh).expect("hinge");
        let j = lj.joint(&mesh);
        locals[j] *= glam::Quat::from_axis_angle(axis, 0.5 * limit);
    }
    let posed = mesh.pose(&locals).expect("pose");
    let (mut out, mut lbs) = (Vec::new(), Vec::new());
    let mut g = c.benchmark_group("skin");
    g.bench_function("lbs", |b| b.iter(|| mesh.lbs(&posed, &mut out)));
    g.bench_function("dqs", |b| b.iter(|| mesh.dqs(&posed, &mut out)));
    g.bench_function("clusters", |b| {
        b.iter(|| clusters.skin(&mesh, &posed, &mut lbs, &mut out))
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
