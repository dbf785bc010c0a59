//! Print the flexion-sweep table of the crate README (markdown).

use slothsim_skin::measure::sweep;
use slothsim_skin::{ClusterSkin, LimbJoint, ReferenceShapes, SkinMesh};

fn main() -> Result<(), slothsim_skin::SkinError> {
    let mesh = SkinMesh::sloth()?;
    let clusters = ClusterSkin::new(&mesh, &ReferenceShapes::sloth()?)?;
    println!(
        "| joint | flex ° | area LBS | area DQS | area clusters | vol LBS | vol DQS | vol clusters |"
    );
    println!("|---|---|---|---|---|---|---|---|");
    for lj in LimbJoint::all() {
        if !lj.limb.is_left() {
            continue;
        }
        for r in sweep(&mesh, &clusters, lj, 5.0)? {
            println!(
                "| {} | {:.1} | {:.1} % | {:.1} % | {:.1} % | {:.2} % | {:.2} % | {:.2} % |",
                lj.label(),
                r.deg,
                100.0 * r.area[0],
                100.0 * r.area[1],
                100.0 * r.area[2],
                100.0 * r.volume[0],
                100.0 * r.volume[1],
                100.0 * r.volume[2]
            );
        }
    }
    Ok(())
}
