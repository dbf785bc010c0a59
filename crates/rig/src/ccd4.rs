//! Four limb solves at once, one per SIMD lane: [`solve4`]; eight (two animals, or
//! two stances of one) with [`solve8_prepared_tolerances`].
//!
//! The scalar solver ([`crate::ccd::solve`]) is a chain of dependent square roots,
//! divisions and short vector products (each step needs the effector the previous one
//! moved), so a single solve leaves most of the CPU idle. The four limbs of an animal
//! are independent: here lane `i` of every `Vec4` carries limb `i`, and the same
//! instructions advance all four chains.
//!
//! **Bit-identical to [`crate::ccd::solve`]**, lane by lane: every lane performs the
//! scalar solver's IEEE operations in the same order (the vector/quaternion helpers
//! below spell out `glam`'s SSE2 formulas component by component; multiplying by
//! `±1.0` and swapping the operands of `+`/`*` are exact). Only the common path is
//! vectorised: the sloth's joint layout (girdle and shoulder/hip swing–twist balls,
//! elbow/knee and wrist/ankle hinges), tail-first sweeps with the reach step, steps
//! whose ball clamp did not act, and solves that reach the tolerance. A lane that
//! leaves that path (a sweep that does not improve, a ball joint clamped, a hinge
//! warm start with an off-axis part, the smoothness guard or the stall polish, the
//! sweep limit) is finished by the scalar solver, which is deterministic, so its
//! result is exactly the scalar one as well: from the point the scalar solve would
//! be at where that point is a state the vector path holds too (a stalled sweep:
//! from the pose before it, reach steps off; out of sweeps: the polish; the
//! smoothness guard: its retry), else again from its start pose. Other chain
//! layouts or parameters go through the scalar solver limb by limb.
//!
//! The kernel is written once (`ccd_lanes.rs`) over a lane type `F` and its mask
//! `M`, and included twice: four lanes in `glam::Vec4`, and eight in one AVX
//! register (`simd8`, the same operations at 256 bits) where the CPU has
//! AVX2. Eight lanes cost about as much per sweep as four (the ik bench, warm 2 mm
//! steps: 243 → 143 ns per limb), so the sim pairs sloths in its CcdSolve stage
//! and stances in its step checks.

use glam::Vec3;

use crate::ccd::{CcdParams, CcdResult};
use crate::chain::{ChainPose, LimbChain, RootTransform};

/// The kernel at four lanes: `glam`'s `Vec4` (SSE).
mod lanes4 {
    pub(super) type F = glam::Vec4;
    pub(super) type M = glam::BVec4A;
    pub(super) const N: usize = 4;

    /// Lane-wise IEEE square root (as `f32::sqrt`).
    #[inline(always)]
    fn sqrt(x: F) -> F {
        #[cfg(target_arch = "x86_64")]
        {
            // SAFETY: SSE2 is part of the x86-64 baseline.
            unsafe { F::from(std::arch::x86_64::_mm_sqrt_ps(x.into())) }
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            F::from_array(x.to_array().map(f32::sqrt))
        }
    }

    /// Lane `i` of column `k` is `rows[i][k]` (a 4×4 transpose: shuffles
    /// only, every bit unchanged).
    #[inline(always)]
    fn columns(rows: [glam::Vec4; N]) -> [F; 4] {
        let m = glam::Mat4::from_cols(rows[0], rows[1], rows[2], rows[3]).transpose();
        [m.x_axis, m.y_axis, m.z_axis, m.w_axis]
    }

    /// The inverse of [`columns`].
    #[inline(always)]
    fn rows(cols: [F; 4]) -> [glam::Vec4; N] {
        columns(cols)
    }

    include!("ccd_lanes.rs");
}

/// The kernel at eight lanes: one AVX register ([`crate::simd8`]); only ever
/// run inside functions compiled with AVX2 on a CPU that has it.
#[cfg(target_arch = "x86_64")]
#[allow(
    dead_code,
    reason = "the eight-lane instance needs no chain building per call, nor the fk helpers"
)]
mod lanes8 {
    pub(super) type F = crate::simd8::F8;
    pub(super) type M = crate::simd8::M8;
    pub(super) const N: usize = 8;

    /// Lane-wise IEEE square root.
    #[inline(always)]
    fn sqrt(x: F) -> F {
        x.sqrt()
    }

    use crate::simd8::{columns, rows};

    include!("ccd_lanes.rs");
}

use lanes4::{Chains, Layout, Q, V};

/// `v`'s four `f32`s as a `Vec4`, for the lane transposes (its `w` is
/// whatever `v` holds there, unused).
#[inline(always)]
fn vec4_of(v: glam::Vec3A) -> glam::Vec4 {
    #[cfg(target_arch = "x86_64")]
    {
        glam::Vec4::from(std::arch::x86_64::__m128::from(v))
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        v.extend(0.0)
    }
}

/// Four limb chains prepared for [`solve4_prepared`]: copies of the chains plus their
/// transposed (one chain per SIMD lane) constants and limit trigonometry, computed
/// once here instead of on every [`solve4`] call. It owns its copies, so it can never
/// go stale; a caller that changes a chain builds a new one.
#[derive(Clone, Debug)]
pub struct LimbChains4 {
    chains: [LimbChain; 4],
    /// `None` when the chains do not have the layout the vector path handles.
    soa: Option<Chains>,
    /// The same at eight lanes (lane `i` = chain `i % 4`) with its forward
    /// kinematics' first joint, for [`solve8_prepared_tolerances`] and
    /// [`LimbChains4::fk_joints8`]; `None` also where the CPU lacks AVX2.
    #[cfg(target_arch = "x86_64")]
    soa8: Option<(lanes8::Chains, (lanes8::V, lanes8::Q))>,
    /// The forward kinematics' first joint before its pose: its position
    /// (`0 + 1 · offset₀`) and `1 · rest₀`, the operations [`LimbChain::fk_local`]
    /// starts with (constants of the chains: computed once, the same bits).
    fk_first: Option<(V, Q)>,
}

impl LimbChains4 {
    /// Prepare four chains (lane `i` = `chains[i]`).
    pub fn new(chains: [&LimbChain; 4]) -> Self {
        let soa = Chains::new(chains);
        let fk_first = soa.as_ref().map(lanes4::fk_first);
        #[cfg(target_arch = "x86_64")]
        let soa8 = if std::arch::is_x86_feature_detected!("avx2") {
            let eight = std::array::from_fn(|i| chains[i % 4]);
            // SAFETY: the CPU has AVX2 (checked just above).
            unsafe { chains8_avx2(eight) }
        } else {
            None
        };
        Self {
            chains: chains.map(|c| *c),
            soa,
            #[cfg(target_arch = "x86_64")]
            soa8,
            fk_first,
        }
    }

    /// The chains, lane by lane.
    pub fn chains(&self) -> &[LimbChain; 4] {
        &self.chains
    }

    /// Joints 1..3 and the effector of each lane in world space, lane `i`
    /// exactly `chains()[i].fk(roots[i], &poses[i])[1..5]` (index 3 is
    /// the chain's `fk_effector`, bit for bit).
    pub fn fk_joints(&self, roots: &[RootTransform; 4], poses: &[ChainPose; 4]) -> [[Vec3; 4]; 4] {
        match (&self.soa, self.fk_first) {
            (Some(c), Some(first)) => lanes4::fk_joints(c, first, roots, poses),
            _ => std::array::from_fn(|i| {
                let j = self.chains[i].fk(roots[i], &poses[i]);
                [j[1], j[2], j[3], j[4]]
            }),
        }
    }

    /// [`LimbChains4::fk_joints`] of two sets of the four chains (lane `i` on
    /// chain `i % 4`), in one AVX register where the CPU has AVX2; the same bits.
    pub fn fk_joints8(&self, roots: &[RootTransform; 8], poses: &[ChainPose; 8]) -> [[Vec3; 4]; 8] {
        #[cfg(target_arch = "x86_64")]
        if let Some((c8, first)) = &self.soa8 {
            // SAFETY: `soa8` exists only where the CPU has AVX2 (see `LimbChains4::new`).
            return unsafe { fk_joints8_avx2(c8, *first, roots, poses) };
        }
        let half = |k: usize| {
            self.fk_joints(
                &std::array::from_fn(|i| roots[k + i]),
                &std::array::from_fn(|i| poses[k + i]),
            )
        };
        let (a, b) = (half(0), half(4));
        std::array::from_fn(|i| if i < 4 { a[i] } else { b[i - 4] })
    }
}

/// [`lanes8::fk_joints`], compiled with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn fk_joints8_avx2(
    c: &lanes8::Chains,
    first: (lanes8::V, lanes8::Q),
    roots: &[RootTransform; 8],
    poses: &[ChainPose; 8],
) -> [[Vec3; 4]; 8] {
    lanes8::fk_joints(c, first, roots, poses)
}

/// Solve four limb chains at once (one per SIMD lane; see the module docs). Each lane
/// is exactly `solve(chains[i], roots[i], targets[i], &mut poses[i], params)`: same
/// poses, same results, bit for bit. Per call it transposes the chains and evaluates
/// their limit trigonometry; [`solve4_prepared`] does that once.
pub fn solve4(
    chains: [&LimbChain; 4],
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
) -> [CcdResult; 4] {
    let tols = [params.tolerance; 4];
    solve4_dispatch(chains, Layout::Build, roots, targets, poses, params, tols)
}

/// [`solve4`] on prepared chains (lane `i` = `chains.chains()[i]`); bit-identical to
/// [`crate::ccd::solve`] lane by lane as well.
pub fn solve4_prepared(
    chains: &LimbChains4,
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
) -> [CcdResult; 4] {
    solve4_prepared_tolerances(chains, roots, targets, poses, params, [params.tolerance; 4])
}

/// [`solve4_prepared`] with a tolerance per lane: lane `i` is exactly
/// `solve(chains[i], roots[i], targets[i], &mut poses[i], &CcdParams { tolerance:
/// tolerances[i], ..*params })` (`params.tolerance` is not used). A lane whose
/// tolerance is invalid (see [`CcdParams::validate`]) is rejected with
/// [`CcdStatus::InvalidParams`](crate::CcdStatus::InvalidParams) and left untouched; the others are solved.
pub fn solve4_prepared_tolerances(
    chains: &LimbChains4,
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    poses: &mut [ChainPose; 4],
    params: &CcdParams,
    tolerances: [f32; 4],
) -> [CcdResult; 4] {
    let c = &chains.chains;
    let refs = [&c[0], &c[1], &c[2], &c[3]];
    let layout = Layout::Prepared(chains.soa.as_ref());
    solve4_dispatch(refs, layout, roots, targets, poses, params, tolerances)
}

/// Two [`solve4_prepared_tolerances`] calls in one: lanes `0..4` and `4..8`
/// are two sets of the four chains (two animals, or two stances of one), lane
/// `i` on chain `i % 4`, exactly `solve(chains[i % 4], roots[i], targets[i],
/// &mut poses[i], &CcdParams { tolerance: tolerances[i], ..*params })` bit for
/// bit, as there. Where the CPU has AVX2 the eight lanes share one AVX register
/// (the same instructions advance both sets: about half the work of two
/// calls); elsewhere it is the two calls.
pub fn solve8_prepared_tolerances(
    chains: &LimbChains4,
    roots: [RootTransform; 8],
    targets: [Vec3; 8],
    poses: &mut [ChainPose; 8],
    params: &CcdParams,
    tolerances: [f32; 8],
) -> [CcdResult; 8] {
    #[cfg(target_arch = "x86_64")]
    if let Some((c8, _)) = &chains.soa8 {
        let c = &chains.chains;
        let refs: [&LimbChain; 8] = std::array::from_fn(|i| &c[i % 4]);
        let layout = lanes8::Layout::Prepared(Some(c8));
        // SAFETY: `soa8` exists only where the CPU has AVX2 (see `LimbChains4::new`).
        return unsafe { solve8_avx2(refs, layout, roots, targets, poses, params, tolerances) };
    }
    let half = |k: usize, poses: &mut [ChainPose; 8]| {
        let mut p: [ChainPose; 4] = std::array::from_fn(|i| poses[k + i]);
        let r = solve4_prepared_tolerances(
            chains,
            std::array::from_fn(|i| roots[k + i]),
            std::array::from_fn(|i| targets[k + i]),
            &mut p,
            params,
            std::array::from_fn(|i| tolerances[k + i]),
        );
        poses[k..k + 4].copy_from_slice(&p);
        r
    };
    let (a, b) = (half(0, poses), half(4, poses));
    std::array::from_fn(|i| if i < 4 { a[i] } else { b[i - 4] })
}

/// [`solve8_prepared_tolerances`] for a caller that needs every lane within
/// its `stop` (at least its tolerance; +∞: any end will do) and nothing more
/// where one is not: `None` if some lane `i` ends farther than `stop[i]` from
/// its target, else every lane's result and pose, bit for bit as
/// [`solve8_prepared_tolerances`]. Lanes the vector path leaves to the scalar
/// solver are finished in lane order, and after the first that ends beyond
/// its `stop` the rest are not (the poses are then anywhere): a step check
/// that fails on one stance's lane spares the others' scalar solves. A build
/// of the kernel of its own (a const parameter): CcdSolve's
/// [`solve8_prepared_tolerances`] keeps the kernel's code without the stops.
pub fn solve8_prepared_tolerances_unless(
    chains: &LimbChains4,
    roots: [RootTransform; 8],
    targets: [Vec3; 8],
    poses: &mut [ChainPose; 8],
    params: &CcdParams,
    tolerances: [f32; 8],
    stop: [f32; 8],
) -> Option<[CcdResult; 8]> {
    debug_assert!(
        (0..8).all(|i| stop[i].partial_cmp(&tolerances[i]) != Some(std::cmp::Ordering::Less)),
        "a stop below its lane's tolerance"
    );
    #[cfg(target_arch = "x86_64")]
    if let Some((c8, _)) = &chains.soa8 {
        let c = &chains.chains;
        let refs: [&LimbChain; 8] = std::array::from_fn(|i| &c[i % 4]);
        let layout = lanes8::Layout::Prepared(Some(c8));
        // SAFETY: `soa8` exists only where the CPU has AVX2 (see `LimbChains4::new`).
        let mut stopped = false;
        let r = unsafe {
            solve8_unless_avx2(
                refs,
                layout,
                roots,
                targets,
                poses,
                params,
                tolerances,
                stop,
                &mut stopped,
            )
        };
        return (!stopped).then_some(r);
    }
    let r = solve8_prepared_tolerances(chains, roots, targets, poses, params, tolerances);
    (!(0..8).any(|i| r[i].error > stop[i])).then_some(r)
}

/// The eight-lane kernel with its stops ([`solve8_prepared_tolerances_unless`]),
/// compiled with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
#[allow(
    clippy::too_many_arguments,
    reason = "the kernel's arguments and the stops"
)]
fn solve8_unless_avx2(
    chains: [&LimbChain; 8],
    layout: lanes8::Layout<'_>,
    roots: [RootTransform; 8],
    targets: [Vec3; 8],
    poses: &mut [ChainPose; 8],
    params: &CcdParams,
    tols: [f32; 8],
    stop: [f32; 8],
    stopped: &mut bool,
) -> [CcdResult; 8] {
    lanes8::solve_impl_unless::<true>(
        chains, layout, roots, targets, poses, params, tols, stop, stopped,
    )
}

/// The eight-lane transposed chains and their first joint, built with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn chains8_avx2(chains: [&LimbChain; 8]) -> Option<(lanes8::Chains, (lanes8::V, lanes8::Q))> {
    lanes8::Chains::new(chains).map(|c| {
        let first = lanes8::fk_first(&c);
        (c, first)
    })
}

/// The eight-lane kernel, compiled with AVX2.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn solve8_avx2(
    chains: [&LimbChain; 8],
    layout: lanes8::Layout<'_>,
    roots: [RootTransform; 8],
    targets: [Vec3; 8],
    poses: &mut [ChainPose; 8],
    params: &CcdParams,
    tols: [f32; 8],
) -> [CcdResult; 8] {
    lanes8::solve_impl(chains, layout, roots, targets, poses, params, tols)
}

avx2_dispatch! {
    /// [`lanes4::solve_impl`], in its AVX2 build where the CPU has AVX2.
    fn solve4_dispatch / solve4_avx2(
        chains: [&LimbChain; 4],
        layout: Layout<'_>,
        roots: [RootTransform; 4],
        targets: [Vec3; 4],
        poses: &mut [ChainPose; 4],
        params: &CcdParams,
        tols: [f32; 4],
    ) -> [CcdResult; 4] => lanes4::solve_impl;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{JointLimit, Rig};
    use glam::Quat;
    use std::cell::Cell;

    thread_local! {
        /// Lanes handed to the scalar solver (diagnostics).
        pub(in crate::ccd4) static SCALAR_LANES: Cell<u64> = const { Cell::new(0) };
        /// Why: off-axis hinge, ball 0 degenerate, ball 1 degenerate, stall, smooth,
        /// sweeps (out of them, or the last lane sweeping).
        static REASONS: Cell<[u64; 6]> = const { Cell::new([0; 6]) };
    }

    /// Count the lanes in `bitmask` (lane `i` in bit `i`) that left the vector
    /// path for `reason`.
    pub(in crate::ccd4) fn note(reason: usize, bitmask: u32) {
        REASONS.with(|r| {
            let mut a = r.get();
            a[reason] += u64::from(bitmask.count_ones());
            r.set(a);
        });
    }

    fn rnd(state: &mut u64) -> f32 {
        *state ^= *state << 13;
        *state ^= *state >> 7;
        *state ^= *state << 17;
        (*state >> 40) as f32 / (1u64 << 24) as f32
    }

    fn bits(p: &ChainPose) -> [[u32; 4]; 4] {
        p.0.map(|q| q.to_array().map(f32::to_bits))
    }

    fn same(a: &CcdResult, b: &CcdResult) -> bool {
        a.reached == b.reached
            && a.error.to_bits() == b.error.to_bits()
            && a.iterations == b.iterations
            && a.status == b.status
    }

    /// Run `solve4` and the scalar `solve` on the same inputs; assert bit-identical.
    fn check(
        chains: [&LimbChain; 4],
        roots: [RootTransform; 4],
        targets: [Vec3; 4],
        a: &mut [ChainPose; 4],
        b: &mut [ChainPose; 4],
        params: &CcdParams,
    ) {
        let mut a2 = *a;
        let r4 = solve4(chains, roots, targets, a, params);
        let prepared = LimbChains4::new(chains);
        let r4p = solve4_prepared(&prepared, roots, targets, &mut a2, params);
        for i in 0..4 {
            assert!(same(&r4[i], &r4p[i]) && bits(&a[i]) == bits(&a2[i]));
        }
        for i in 0..4 {
            let r = crate::solve(chains[i], roots[i], targets[i], &mut b[i], params);
            assert!(
                same(&r4[i], &r) && bits(&a[i]) == bits(&b[i]),
                "lane {i}: {:?} vs {r:?}\n{:?}\nvs {:?}",
                r4[i],
                a[i],
                b[i]
            );
        }
    }

    fn root(s: &mut u64) -> RootTransform {
        let axis = Vec3::new(rnd(s) - 0.5, rnd(s) - 0.5, rnd(s) - 0.5)
            .try_normalize()
            .unwrap_or(Vec3::Y);
        RootTransform::new(
            Vec3::new(rnd(s) * 10.0, rnd(s) * 10.0, rnd(s) * 10.0),
            Quat::from_axis_angle(axis, 6.0 * rnd(s) - 3.0),
        )
    }

    /// The SIMD forward kinematics (four and eight lanes) equal the scalar one,
    /// bit for bit, joint by joint and at the effector.
    #[test]
    fn fk_joints_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let mut s = 0xf9_u64;
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        for _ in 0..3000 {
            let roots: [RootTransform; 8] = std::array::from_fn(|_| root(&mut s));
            let poses: [ChainPose; 8] = std::array::from_fn(|i| {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                chains[i % 4].sample_pose(&u)
            });
            let j8 = prepared.fk_joints8(&roots, &poses);
            let j4 = prepared.fk_joints(
                &std::array::from_fn(|i| roots[i]),
                &std::array::from_fn(|i| poses[i]),
            );
            for i in 0..8 {
                let want = chains[i % 4].fk(roots[i], &poses[i]);
                for k in 0..4 {
                    assert_eq!(bits(j8[i][k]), bits(want[1 + k]), "lane {i} joint {k}");
                    if i < 4 {
                        assert_eq!(bits(j4[i][k]), bits(want[1 + k]), "lane {i} joint {k}");
                    }
                }
                let eff = chains[i % 4].fk_effector(roots[i], &poses[i]);
                assert_eq!(bits(j8[i][3]), bits(eff));
            }
        }
    }

    /// A tolerance per lane (the step checks' use: 1.5–3.5 mm, and +∞ for a lane
    /// that does not matter): each lane is the scalar solve with its tolerance.
    #[test]
    fn per_lane_tolerances_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let mut s = 0x70_1e_u64;
        let base = CcdParams {
            refine: false,
            max_iterations: 32,
            ..CcdParams::default()
        };
        let (mut moved, mut skipped) = (0, 0);
        for k in 0..3000 {
            let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
            let tols: [f32; 4] = std::array::from_fn(|_| {
                [0.0015, 0.003, 0.0035, f32::INFINITY][(rnd(&mut s) * 4.0) as usize % 4]
            });
            let targets: [Vec3; 4] = std::array::from_fn(|i| {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                let p = chains[i].fk(roots[i], &chains[i].sample_pose(&u))[4];
                let d = if k % 3 == 0 { 0.3 } else { 0.02 };
                p + d * Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5)
            });
            let start: [ChainPose; 4] = std::array::from_fn(|i| {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                chains[i].sample_pose(&u)
            });
            let mut a = start;
            let r4 = solve4_prepared_tolerances(&prepared, roots, targets, &mut a, &base, tols);
            for i in 0..4 {
                let params = CcdParams {
                    tolerance: tols[i],
                    ..base
                };
                let mut b = start[i];
                let r = crate::solve(chains[i], roots[i], targets[i], &mut b, &params);
                assert!(
                    same(&r4[i], &r) && bits(&a[i]) == bits(&b),
                    "lane {i}, tol {}",
                    tols[i]
                );
                if tols[i].is_infinite() {
                    // Nothing to do: the pose stays, the error is measured.
                    assert!(r.reached && r.iterations == 0 && bits(&b) == bits(&start[i]));
                    skipped += 1;
                } else if r.iterations > 0 {
                    moved += 1;
                }
            }
        }
        assert!(
            moved > 1000 && skipped > 1000,
            "{moved} solved, {skipped} skipped"
        );
    }

    /// One eight-lane call's inputs (two sets of the four chains).
    struct Case8 {
        roots: [RootTransform; 8],
        tols: [f32; 8],
        targets: [Vec3; 8],
        start: [ChainPose; 8],
    }

    /// The two parameter sets the eight-lane tests run: the sloth's, and
    /// without the polish with a longer sweep budget.
    fn case8_params() -> [CcdParams; 2] {
        [
            CcdParams::default(),
            CcdParams {
                refine: false,
                max_iterations: 32,
                ..CcdParams::default()
            },
        ]
    }

    /// Call `k`'s inputs drawn from `s`: random roots; per-lane tolerances
    /// (`params`' own, 3 mm, 1.5 mm, +∞); targets at, near, far from and out
    /// of the reach of random poses' claws (a non-finite one every 97th
    /// call); warm starts from random poses, cold (neutral) every 5th call.
    fn case8(chains: [&LimbChain; 4], params: &CcdParams, k: usize, s: &mut u64) -> Case8 {
        let roots: [RootTransform; 8] = std::array::from_fn(|_| root(s));
        let tols: [f32; 8] = std::array::from_fn(|_| {
            [params.tolerance, 0.003, 0.0015, f32::INFINITY][(rnd(s) * 4.0) as usize % 4]
        });
        let mut targets: [Vec3; 8] = std::array::from_fn(|i| {
            let c = chains[i % 4];
            let u: [f32; 12] = std::array::from_fn(|_| rnd(s));
            let p = c.fk(roots[i], &c.sample_pose(&u))[4];
            let d = [0.0, 0.005, 0.03, 0.5][(k + i) % 4];
            p + d * Vec3::new(rnd(s) - 0.5, rnd(s) - 0.5, rnd(s) - 0.5)
        });
        if k.is_multiple_of(97) {
            targets[k % 8] = Vec3::NAN;
        }
        let start: [ChainPose; 8] = std::array::from_fn(|i| {
            if k.is_multiple_of(5) {
                ChainPose::NEUTRAL
            } else {
                let u: [f32; 12] = std::array::from_fn(|_| rnd(s));
                chains[i % 4].sample_pose(&u)
            }
        });
        Case8 {
            roots,
            tols,
            targets,
            start,
        }
    }

    /// Eight lanes (two sets of the four chains) give the scalar solver's bits lane
    /// by lane: warm and cold, near, far and unreachable targets, per-lane
    /// tolerances (infinite ones too), with and without the polish, and a lane
    /// with a non-finite target (the whole call then goes lane by lane).
    #[test]
    fn eight_lanes_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let mut s = 0x8_1a_u64;
        let (mut moved, mut vector) = (0, 0);
        for params in case8_params() {
            for k in 0..1500 {
                let Case8 {
                    roots,
                    tols,
                    targets,
                    start,
                } = case8(chains, &params, k, &mut s);
                let before = SCALAR_LANES.with(|n| n.get());
                let mut a = start;
                let r8 =
                    solve8_prepared_tolerances(&prepared, roots, targets, &mut a, &params, tols);
                vector += 8 - (SCALAR_LANES.with(|n| n.get()) - before);
                for i in 0..8 {
                    let lane_params = CcdParams {
                        tolerance: tols[i],
                        ..params
                    };
                    let mut b = start[i];
                    let r = crate::solve(chains[i % 4], roots[i], targets[i], &mut b, &lane_params);
                    assert!(
                        same(&r8[i], &r) && bits(&a[i]) == bits(&b),
                        "lane {i}, call {k}: {:?} vs {r:?}",
                        r8[i]
                    );
                    moved += usize::from(r.iterations > 0);
                }
            }
        }
        assert!(
            moved > 5000 && vector > 10_000,
            "{moved} moved, {vector} vector lanes"
        );
    }

    /// The eight lanes with stops (the step checks' use): `None` exactly where a
    /// lane of the plain call ends beyond its stop, and otherwise the plain
    /// call's results and poses, bit for bit. Stops at the tolerance, at 1 cm
    /// (the checks' polish limit) and +∞; targets near, far and unreachable,
    /// warm and cold, with and without the polish, a non-finite target now and
    /// then; some calls stop with later lanes still to finish.
    #[test]
    fn eight_lanes_with_stops_are_the_plain_call_or_none() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let mut s = 0x5_70_b5_u64;
        let (mut stopped, mut kept, mut spared) = (0, 0, 0u64);
        for params in case8_params() {
            for k in 0..1500 {
                let Case8 {
                    roots,
                    tols,
                    targets,
                    start,
                } = case8(chains, &params, k, &mut s);
                let stop: [f32; 8] = std::array::from_fn(|i| {
                    [tols[i], tols[i].max(0.01), f32::INFINITY][(rnd(&mut s) * 3.0) as usize % 3]
                });
                let mut a = start;
                let plain =
                    solve8_prepared_tolerances(&prepared, roots, targets, &mut a, &params, tols);
                let before = SCALAR_LANES.with(|n| n.get());
                let mut b = start;
                let r = solve8_prepared_tolerances_unless(
                    &prepared, roots, targets, &mut b, &params, tols, stop,
                );
                let scalar = SCALAR_LANES.with(|n| n.get()) - before;
                let beyond = (0..8).any(|i| plain[i].error > stop[i]);
                match r {
                    Some(r) => {
                        assert!(!beyond, "call {k}: a lane beyond its stop answered");
                        for i in 0..8 {
                            assert!(
                                same(&r[i], &plain[i]) && bits(&a[i]) == bits(&b[i]),
                                "lane {i}, call {k}: {:?} vs {:?}",
                                r[i],
                                plain[i]
                            );
                        }
                        kept += 1;
                    }
                    None => {
                        assert!(beyond, "call {k}: stopped with every lane within its stop");
                        stopped += 1;
                        // The scalar lanes the plain call finished and this one did not.
                        let all = SCALAR_LANES.with(|n| n.get());
                        let mut again = start;
                        solve8_prepared_tolerances(
                            &prepared, roots, targets, &mut again, &params, tols,
                        );
                        spared += (SCALAR_LANES.with(|n| n.get()) - all) - scalar;
                    }
                }
            }
        }
        assert!(
            stopped > 300 && kept > 300 && spared > 100,
            "{stopped} stopped, {kept} answered, {spared} scalar lanes spared"
        );
    }

    /// Cold solves of reachable and unreachable targets, from neutral and from random
    /// within-limit poses, under random roots.
    #[test]
    fn cold_solves_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let mut s = 0x5eed_u64;
        for params in [CcdParams::default(), CcdParams::precise()] {
            for k in 0..3000 {
                let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
                let targets: [Vec3; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    let p = chains[i].fk(roots[i], &chains[i].sample_pose(&u))[4];
                    if k % 5 == 0 {
                        // Anywhere nearby, reachable or not.
                        p + Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5)
                    } else {
                        p
                    }
                });
                let mut a: [ChainPose; 4] = std::array::from_fn(|i| {
                    if k % 2 == 0 {
                        ChainPose::NEUTRAL
                    } else {
                        let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                        chains[i].sample_pose(&u)
                    }
                });
                let mut b = a;
                check(chains, roots, targets, &mut a, &mut b, &params);
            }
        }
    }

    /// Warm tracking (1–8 mm per frame, moving roots) over many frames: poses are
    /// carried from frame to frame on both sides and must stay identical.
    #[test]
    fn warm_tracking_matches_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let params = CcdParams::default();
        let mut s = 0xbeef_u64;
        let mut solves = 0u64;
        SCALAR_LANES.with(|n| n.set(0));
        for step_mm in [1.0f32, 2.0, 4.0, 8.0] {
            let mut a = [ChainPose::NEUTRAL; 4];
            let mut b = a;
            let mut ua: [[f32; 12]; 4] =
                std::array::from_fn(|_| std::array::from_fn(|_| rnd(&mut s)));
            for _ in 0..12 {
                let ub: [[f32; 12]; 4] =
                    std::array::from_fn(|_| std::array::from_fn(|_| rnd(&mut s)));
                let n = (200.0 / step_mm) as usize;
                for f in 0..=n {
                    let t = f as f32 / n as f32;
                    let root = RootTransform::new(
                        Vec3::new(t, 1.0, 0.5 * t),
                        Quat::from_rotation_y(0.3 * t),
                    );
                    let roots = [root; 4];
                    let targets: [Vec3; 4] = std::array::from_fn(|i| {
                        let u: [f32; 12] =
                            std::array::from_fn(|k| ua[i][k] + (ub[i][k] - ua[i][k]) * t);
                        chains[i].fk(root, &chains[i].sample_pose(&u))[4]
                    });
                    check(chains, roots, targets, &mut a, &mut b, &params);
                    solves += 4;
                }
                ua = ub;
            }
        }
        let scalar = SCALAR_LANES.with(|n| n.get());
        let reasons = REASONS.with(|r| r.get());
        println!("warm: {scalar} of {solves} lanes went to the scalar solver: {reasons:?}");
    }

    /// The AVX2 build of the vector solver (where the CPU has AVX2) gives the plain
    /// SSE2 build's bits, lane by lane, cold and warm, near and far targets.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn avx2_build_matches_plain_bit_for_bit() {
        if !std::arch::is_x86_feature_detected!("avx2") {
            return;
        }
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let prepared = LimbChains4::new(chains);
        let layout = Layout::Prepared(prepared.soa.as_ref());
        let mut s = 0xb11d_u64;
        for params in [CcdParams::default(), CcdParams::precise()] {
            for k in 0..2000 {
                let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
                let targets: [Vec3; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    let p = chains[i].fk(roots[i], &chains[i].sample_pose(&u))[4];
                    let d = [0.0, 0.005, 0.03, 0.5][k % 4];
                    p + d * Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5)
                });
                let start: [ChainPose; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    chains[i].sample_pose(&u)
                });
                let tols = [params.tolerance; 4];
                let (mut a, mut b) = (start, start);
                let ra = lanes4::solve_impl(chains, layout, roots, targets, &mut a, &params, tols);
                // SAFETY: the CPU has AVX2 (checked above).
                let rb =
                    unsafe { solve4_avx2(chains, layout, roots, targets, &mut b, &params, tols) };
                for i in 0..4 {
                    assert!(same(&ra[i], &rb[i]) && bits(&a[i]) == bits(&b[i]));
                }
            }
        }
    }

    /// Far and huge (but finite) targets: squares overflow to infinity and NaNs appear
    /// inside the steps; the lanes must still follow the scalar solver exactly.
    #[test]
    fn extreme_targets_match_scalar_bit_for_bit() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let mut s = 0xfa7_u64;
        for scale in [1e3f32, 1e6, 1e18, 1e19, 1e20, 3e38] {
            for _ in 0..50 {
                let roots: [RootTransform; 4] = std::array::from_fn(|_| root(&mut s));
                let targets: [Vec3; 4] = std::array::from_fn(|_| {
                    Vec3::new(rnd(&mut s) - 0.5, rnd(&mut s) - 0.5, rnd(&mut s) - 0.5) * scale
                });
                let mut a: [ChainPose; 4] = std::array::from_fn(|i| {
                    let u: [f32; 12] = std::array::from_fn(|_| rnd(&mut s));
                    chains[i].sample_pose(&u)
                });
                let mut b = a;
                check(
                    chains,
                    roots,
                    targets,
                    &mut a,
                    &mut b,
                    &CcdParams::default(),
                );
            }
        }
    }

    /// Bad input per lane: that lane is rejected (pose untouched), the others solve.
    #[test]
    fn invalid_lanes_are_rejected_like_scalar() {
        let rig = Rig::sloth();
        let chains: [&LimbChain; 4] = std::array::from_fn(|i| &rig.chains()[i]);
        let roots = [RootTransform::IDENTITY; 4];
        let mut targets: [Vec3; 4] =
            std::array::from_fn(|i| chains[i].fk(roots[i], &ChainPose::NEUTRAL)[4]);
        targets[1] = Vec3::new(f32::NAN, 0.0, 0.0);
        targets[2] += Vec3::new(0.01, 0.02, 0.0);
        let mut a = [ChainPose::NEUTRAL; 4];
        a[3].0[1] = Quat::from_xyzw(f32::INFINITY, 0.0, 0.0, 1.0);
        let mut b = a;
        check(
            chains,
            roots,
            targets,
            &mut a,
            &mut b,
            &CcdParams::default(),
        );
        let bad = CcdParams {
            tolerance: -1.0,
            ..CcdParams::default()
        };
        check(chains, roots, targets, &mut a, &mut b, &bad);
        // Not the sloth layout: every lane goes through the scalar solver.
        let mut free = *chains[0];
        free.limits[3] = JointLimit::Free;
        let mixed = [&free, chains[1], chains[2], chains[3]];
        check(mixed, roots, targets, &mut a, &mut b, &CcdParams::default());
    }
}
