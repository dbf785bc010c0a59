//! Sloth rig: skeleton, limb chains, forward kinematics and CCD inverse kinematics with
//! anatomical joint limits. No ECS, no allocation in the solver.
//!
//! Conventions: metres, radians, right-handed, +Y up, glTF axes (model faces +Z, its
//! left is +X). See the crate README for the joint-limit mapping and solver choices.
//!
//! Typical per-frame use (one limb):
//! ```
//! use slothsim_rig::{ccd, CcdParams, ChainPose, Limb, Rig, RootTransform};
//! use glam::{Quat, Vec3};
//! let rig = Rig::sloth();
//! let chain = rig.chain(Limb::LF);
//! let root = RootTransform::new(Vec3::new(0.0, 1.0, 0.0), Quat::IDENTITY);
//! let mut pose = ChainPose::NEUTRAL; // keep per limb, warm-starts the next frame
//! let grip = chain.fk(root, &ChainPose::NEUTRAL)[4] + Vec3::new(0.0, 0.01, 0.02);
//! let result = ccd::solve(chain, root, grip, &mut pose, &CcdParams::default());
//! assert!(result.reached);
//! ```

/// `avx2_dispatch! { fn dispatch / avx2(args) -> Ret => imp; }` defines
/// `dispatch`, which runs `imp` in its AVX2 build (`avx2`, also defined here)
/// where the CPU has AVX2 and the plain `imp` elsewhere.
///
/// The solvers are short vector code on `glam`'s SSE2 types; with the
/// default x86-64 target those are 2-operand instructions, and about a fifth
/// of a solve was register copies. The VEX (3-operand) encoding of the AVX2
/// build drops most of them. Both builds run the same IEEE operations in the
/// same order (Rust never fuses a multiply and an add), so they give the same
/// bits (tested: `runtime_dispatch_is_bit_identical` and the others).
/// `std` caches the CPU check.
macro_rules! avx2_dispatch {
    ($(#[$attr:meta])* $vis:vis fn $dispatch:ident / $avx2:ident
        ($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty => $imp:path;) => {
        $(#[$attr])*
        $vis fn $dispatch($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            if std::arch::is_x86_feature_detected!("avx2") {
                // SAFETY: the CPU has AVX2 (checked just above), the one
                // requirement for calling a `target_feature(enable = "avx2")`
                // function.
                return unsafe { $avx2($($arg),*) };
            }
            $imp($($arg),*)
        }

        #[doc = concat!("`", stringify!($imp), "` compiled with AVX2 enabled (see `avx2_dispatch!`).")]
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2")]
        fn $avx2($($arg: $ty),*) -> $ret {
            $imp($($arg),*)
        }
    };
}

pub mod ccd;
pub mod ccd4;
pub mod chain;
pub mod error;
pub mod fabrik;
pub mod limb;
pub mod limits;
mod refine;
pub mod rig;
#[cfg(target_arch = "x86_64")]
mod simd8;
pub mod skeleton;
pub mod sloth;
#[cfg(test)]
mod test_rng;
pub mod unit;

pub use ccd::{CcdOrder, CcdParams, CcdResult, CcdStatus, solve};
pub use ccd4::{
    LimbChains4, solve4, solve4_prepared, solve4_prepared_tolerances, solve8_prepared_tolerances,
    solve8_prepared_tolerances_unless,
};
pub use chain::{CHAIN_JOINTS, ChainPose, LimbChain, RootTransform};
pub use error::RigError;
pub use fabrik::FabrikParams;
pub use limb::Limb;
pub use limits::{JointLimit, LimitProblem};
pub use rig::{LimbJoints, LimbNames, Rig, RigMap};
pub use skeleton::{RestTransform, Skeleton};

/// The CPU code path the CCD kernels take on this machine: `"avx2"` where the
/// eight-lane AVX2 kernels run, `"plain"` elsewhere (same results either way).
pub fn simd_path() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        return "avx2";
    }
    "plain"
}
