//! The corrective morph targets (glTF `--skinning clusters`): basis vectors per joint at
//! several fit tolerances, and the fit residual over a dense sweep of each joint.
//!
//! ```text
//! cargo run --release -p slothsim-skin --example morph_basis
//! ```

use slothsim_skin::{
    ClusterSkin, CorrectiveTargets, LimbJoint, MorphScratch, ReferenceShapes, SkinMesh,
};

fn main() -> Result<(), slothsim_skin::SkinError> {
    let mesh = SkinMesh::sloth()?;
    let clusters = ClusterSkin::new(&mesh, &ReferenceShapes::sloth()?)?;
    for tol in [0.05e-3, 0.1e-3, 0.25e-3, 0.5e-3, 1e-3] {
        let t = CorrectiveTargets::with_tolerance(&mesh, &clusters, tol)?;
        println!(
            "tol {:.2} mm: {} targets {:?}",
            tol * 1e3,
            t.len(),
            t.per_joint()
        );
    }
    let t = std::time::Instant::now();
    let targets = CorrectiveTargets::new(&mesh, &clusters)?;
    println!(
        "built in {:.0} ms: {} targets {:?}",
        t.elapsed().as_secs_f64() * 1e3,
        targets.len(),
        targets.per_joint()
    );
    for t in &targets.targets() {
        println!("{}: {} vertices", t.name, t.vertices.len());
    }
    let mut scratch = MorphScratch::default();
    let mut w = Vec::new();
    for lj in LimbJoint::all() {
        let (_, limit) = lj.flexion(&mesh)?;
        let mut worst = 0.0f32;
        let mut wmax = 0.0f32;
        for i in -200..=200 {
            let theta = limit * i as f32 / 200.0 * 1.1;
            let posed = mesh.pose(&lj.flexed(&mesh, theta)?)?;
            let r = targets.weights(&mesh, &clusters, &posed, &mut scratch, &mut w)?;
            worst = worst.max(r);
            wmax = w.iter().copied().fold(wmax, f32::max);
        }
        let (mut lbs, mut out) = (Vec::new(), Vec::new());
        let posed = mesh.pose(&lj.flexed(&mesh, limit)?)?;
        clusters.skin(&mesh, &posed, &mut lbs, &mut out);
        let corr = lbs
            .iter()
            .zip(&out)
            .map(|(a, b)| a.distance(*b))
            .fold(0.0f32, f32::max);
        println!(
            "{}: max correction at limit {:.2} mm",
            lj.label(),
            corr * 1e3
        );
        println!(
            "{}: residual {:.4} mm, max weight {wmax:.3}",
            lj.label(),
            worst * 1e3
        );
    }
    Ok(())
}
