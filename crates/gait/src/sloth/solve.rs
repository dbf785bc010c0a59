//! CcdSolve (thesis §3.1–3.3, CCD IK per limb; SPEC "Limb IK"): each limb's
//! chain solved toward its target (four limbs in SIMD lanes, two sloths per
//! solve where they pair), the body pulled back toward planted claws left
//! short so grips do not slide, and the memo keys that skip a solve (or a
//! BodyAverage) that would change nothing.

use glam::Vec3;
use slothsim_rig::{CcdParams, CcdResult, CcdStatus, ChainPose, RootTransform};

use super::checks::STANCE_IK_TOLERANCE;
use super::{LimbPhase, LocoView, Sloth};

/// A limb settled short of its target stays so while the target moves less
/// than this (metres) in the limb's root frame.
const SETTLED_MOVE: f32 = 1e-5;

/// A planted limb's cold restart (see [`Sloth::solve_limbs`]) that did not
/// beat the warm solve by [`COLD_RETRY_GAIN`] is not tried again until the
/// target has moved this far (metres, root frame) from where it failed. At the
/// edge of the reach both end in the same pose (within 0.1 µm in a 1,000-sloth
/// crowd, after 70–80 sweeps): retried every frame, the restarts cost a tenth
/// of the tick.
const COLD_RETRY_MOVE: f32 = 0.02;

/// Most body pulls toward planted claws left short per solve (see
/// [`Sloth::pull_to_grips`]). One pull moves the body by the short claws' mean
/// residual, but near the edge of the stance's reach the other claws' re-solve
/// takes back part of it: in a 5,000-sloth crowd a hind claw at 98 % of its
/// reach, 3.0 mm short, came to 2.6 mm after one pull and 1.3 mm after more;
/// at the start of a fore limb's swing it went 5.6 mm short with one pull,
/// 3.0 mm with up to three.
const PULL_STEPS: usize = 3;

/// The fractions of a body pull tried in turn (see [`Sloth::pull_to_grips`]):
/// the whole pull, then half and a quarter of it where the whole one leaves
/// the worst planted claw no closer. The whole pull first, so a pull that
/// helps is the one it always was (the extra solves run only where it was
/// rejected).
const PULL_FRACTIONS: [f32; 3] = [1.0, 0.5, 0.25];

/// See [`COLD_RETRY_MOVE`] (metres).
const COLD_RETRY_GAIN: f32 = 5e-4;

/// Words of a [`SolveKey`]: the body (position, rotation), then per limb its
/// target and phase: the fields [`Sloth::solve_limbs`] reads that other
/// stages write.
const SOLVE_KEY_LEN: usize = 7 + 4 * (3 + 1);

/// The bits of the fields [`Sloth::solve_limbs`] reads that other stages write
/// (see [`SolveMemo`]).
type SolveKey = [u32; SOLVE_KEY_LEN];

/// Words of a [`SolveOwn`]: per limb its pose, settled target and cold-miss
/// target (each with a flag), root and effector.
const SOLVE_OWN_LEN: usize = 4 * (16 + 4 + 4 + 3 + 3);

/// The bits of the fields [`Sloth::solve_limbs`] reads or writes that only it
/// writes (with the joints, which it only writes).
type SolveOwn = [u32; SOLVE_OWN_LEN];

/// What [`Sloth::solve_limbs_memo`] keeps of the sloth's last CcdSolve. The
/// key is written in place before a solve and compared in place after it and
/// in the next frame (no key is built to be compared, nor moved).
///
/// The key holds only the fields the solve reads that other stages write (the
/// body, the targets, the phases: 92 bytes). The fields only the solve writes
/// (poses, settled and cold-miss targets, roots, effectors, joints) are
/// compared with their bits before the solve when it ends (a copy on the
/// stack, see [`SolveMemo::keep`]), not kept: no other code of the tick writes
/// them (spawning and loading a checkpoint start a new memo), so where the
/// solve left them unchanged they hold those bits until the next solve. Code
/// that writes them outside CcdSolve must reset the sloth's memo
/// ([`SolveMemo::default`]). Debug builds keep them too and check that.
#[derive(Clone, Copy, Debug)]
pub struct SolveMemo {
    /// The state before the last solve (valid while `armed`).
    key: SolveKey,
    /// `key` holds the state before the last solve (no limb swung).
    armed: bool,
    /// That solve left the sloth unchanged: `key` is its state now.
    fixed: bool,
    /// That solve's sweep count.
    iterations: u32,
    /// Debug builds: the fields only the solve writes, as it left them.
    #[cfg(debug_assertions)]
    own: SolveOwn,
}

impl Default for SolveMemo {
    fn default() -> Self {
        SolveMemo {
            key: [0; SOLVE_KEY_LEN],
            armed: false,
            fixed: false,
            iterations: 0,
            #[cfg(debug_assertions)]
            own: [0; SOLVE_OWN_LEN],
        }
    }
}

impl SolveMemo {
    /// The sweep count of the unchanged solve whose state `sloth` holds, if it
    /// does (never while a limb swings: its target moves every frame).
    pub(super) fn hit(&self, sloth: &Sloth) -> Option<u32> {
        let hit = self.fixed && !sloth.any_swinging() && sloth.solve_key_is(&self.key);
        #[cfg(debug_assertions)]
        if hit {
            let mut k = KeyEq::new(&self.own);
            sloth.solve_own_into(&mut k);
            debug_assert!(
                k.done(),
                "a solve's own fields were written outside CcdSolve without resetting its memo"
            );
        }
        hit.then_some(self.iterations)
    }

    /// Before a solve of `sloth`: its state, where no limb swings; writes
    /// the fields only the solve writes, as they are before it, into `own`
    /// (for [`SolveMemo::keep`]; in place: a returned `SolveOwn`, 480 bytes,
    /// was copied twice on its way into a batch's pending pair) and returns
    /// whether it did.
    fn arm(&mut self, sloth: &Sloth, own: &mut SolveOwn) -> bool {
        self.fixed = false;
        self.armed = !sloth.any_swinging();
        if self.armed {
            let mut k = KeyBits::<SOLVE_KEY_LEN>::new();
            sloth.solve_key_into(&mut k);
            self.key = k.done();
            let mut o = KeyInto { k: own, at: 0 };
            sloth.solve_own_into(&mut o);
            debug_assert_eq!(o.at, SOLVE_OWN_LEN);
        }
        self.armed
    }

    /// After that solve (`own`: what [`SolveMemo::arm`] returned): kept where
    /// it left the sloth unchanged.
    fn keep(&mut self, sloth: &Sloth, own: Option<&SolveOwn>, iterations: u32) {
        self.fixed = self.armed
            && own.is_some_and(|own| {
                let mut k = KeyEq::new(own);
                sloth.solve_own_into(&mut k);
                k.done()
            })
            && sloth.solve_key_is(&self.key);
        #[cfg(debug_assertions)]
        if let (true, Some(own)) = (self.fixed, own) {
            self.own = *own;
        }
        self.iterations = iterations;
    }
}

/// What [`Sloth::solve_limbs`] computes before its IK: each limb's chain root,
/// target (world space; [`SolvePrep::target_ls`] in its root's frame) and
/// whether it stays settled.
struct SolvePrep {
    roots: [RootTransform; 4],
    targets: [Vec3; 4],
    settled: [bool; 4],
}

impl SolvePrep {
    /// Limb `li`'s target in its chain-root frame: only where a settled or
    /// cold-miss target is compared or kept (the SIMD lanes form their own).
    fn target_ls(&self, li: usize) -> Vec3 {
        self.roots[li]
            .inverse_transform_point(self.targets[li].into())
            .into()
    }

    /// Nothing to solve: every limb keeps its settled pose.
    fn all_settled(&self) -> bool {
        self.settled.iter().all(|&s| s)
    }
}

impl AsMut<Sloth> for Sloth {
    fn as_mut(&mut self) -> &mut Sloth {
        self
    }
}

impl AsMut<SolveMemo> for SolveMemo {
    fn as_mut(&mut self) -> &mut SolveMemo {
        self
    }
}

/// Where a memo key's words go, in order: written ([`KeyBits`]) or compared
/// with a key kept ([`KeyEq`]).
pub(super) trait KeySink {
    fn u32s<const M: usize>(&mut self, v: [u32; M]);
    fn f32s<const M: usize>(&mut self, v: [f32; M]);
}

/// A memo key being compared with `k`: the differing bits of every word
/// written are gathered (without a branch per word; nothing more is compared
/// once some word differs).
pub(super) struct KeyEq<'a, const N: usize> {
    k: &'a [u32; N],
    at: usize,
    diff: u32,
}

impl<'a, const N: usize> KeyEq<'a, N> {
    pub(super) fn new(k: &'a [u32; N]) -> Self {
        KeyEq { k, at: 0, diff: 0 }
    }

    /// Whether every word written equals `k`'s (all `N` written).
    pub(super) fn done(self) -> bool {
        debug_assert!(self.diff != 0 || self.at == N);
        self.diff == 0
    }
}

impl<const N: usize> KeySink for KeyEq<'_, N> {
    fn u32s<const M: usize>(&mut self, v: [u32; M]) {
        if self.diff == 0 {
            let k = &self.k[self.at..self.at + M];
            self.diff = k.iter().zip(v).fold(0, |d, (&w, x)| d | (w ^ x));
        }
        self.at += M;
    }

    fn f32s<const M: usize>(&mut self, v: [f32; M]) {
        self.u32s(v.map(f32::to_bits));
    }
}

/// A memo key being written: `N` words of bits, filled in order.
pub(super) struct KeyBits<const N: usize> {
    k: [u32; N],
    at: usize,
}

impl<const N: usize> KeyBits<N> {
    pub(super) fn new() -> Self {
        KeyBits { k: [0; N], at: 0 }
    }

    /// The key (every word written).
    pub(super) fn done(self) -> [u32; N] {
        debug_assert_eq!(self.at, N);
        self.k
    }
}

impl<const N: usize> KeySink for KeyBits<N> {
    fn u32s<const M: usize>(&mut self, v: [u32; M]) {
        self.k[self.at..self.at + M].copy_from_slice(&v);
        self.at += M;
    }

    fn f32s<const M: usize>(&mut self, v: [f32; M]) {
        self.u32s(v.map(f32::to_bits));
    }
}

/// A memo's words written in place into `k` (see [`SolveMemo::arm`]).
struct KeyInto<'a, const N: usize> {
    k: &'a mut [u32; N],
    at: usize,
}

impl<const N: usize> KeySink for KeyInto<'_, N> {
    fn u32s<const M: usize>(&mut self, v: [u32; M]) {
        self.k[self.at..self.at + M].copy_from_slice(&v);
        self.at += M;
    }

    fn f32s<const M: usize>(&mut self, v: [f32; M]) {
        self.u32s(v.map(f32::to_bits));
    }
}

/// Eight SIMD lanes' values: `a`'s in lanes 0..4, `b`'s in 4..8.
pub(super) fn lanes8<T: Copy>(a: [T; 4], b: [T; 4]) -> [T; 8] {
    std::array::from_fn(|i| if i < 4 { a[i] } else { b[i - 4] })
}

/// Lanes `k..k + 4` of eight.
fn lanes4<T: Copy>(v: &[T; 8], k: usize) -> [T; 4] {
    std::array::from_fn(|i| v[k + i])
}

impl Sloth {
    /// CcdSolve: each limb from its root toward its target.
    ///
    /// Grips must not slide (SPEC): where the averaged body leaves a planted
    /// claw short of its grip (the step checks sample a swing at a few arc
    /// points only), the body is moved by the planted limbs' mean residual
    /// (or a part of it, see [`Sloth::pull_to_grips`]) and the limbs solved
    /// again; kept only if that brings the worst claw closer.
    pub fn solve_limbs(&mut self, env: &LocoView<'_>) -> u32 {
        let iterations = self.solve_limbs_with(env, env.ccd);
        self.pull_to_grips(env, iterations)
    }

    /// [`Sloth::solve_limbs`] of two sloths at once: their limbs share the
    /// SIMD lanes of one solve where both have limbs to solve (about half the
    /// work of two calls on CPUs with AVX2). Each sloth ends exactly as its own
    /// `solve_limbs` would leave it, bit for bit.
    pub fn solve_limbs_pair(a: &mut Sloth, b: &mut Sloth, env: &LocoView<'_>) -> [u32; 2] {
        let params = env.ccd;
        let (pa, pb) = (a.solve_prepare(env), b.solve_prepare(env));
        let (sa, sb) = match (pa.all_settled(), pb.all_settled()) {
            (false, false) => {
                let mut poses = lanes8(a.limb_map(|l| l.pose), b.limb_map(|l| l.pose));
                let r = slothsim_rig::solve8_prepared_tolerances(
                    &env.rig.chains4,
                    lanes8(pa.roots, pb.roots),
                    lanes8(pa.targets, pb.targets),
                    &mut poses,
                    params,
                    [params.tolerance; 8],
                );
                let half = |k: usize| (lanes4(&poses, k), lanes4(&r, k));
                (Some(half(0)), Some(half(4)))
            }
            (false, true) => (Some(a.solve_lanes(env, &pa, params)), None),
            (true, false) => (None, Some(b.solve_lanes(env, &pb, params))),
            (true, true) => (None, None),
        };
        let ia = a.solve_finish_limbs(env, params, &pa, sa);
        let ib = b.solve_finish_limbs(env, params, &pb, sb);
        let poses = lanes8(a.limb_map(|l| l.pose), b.limb_map(|l| l.pose));
        let fk = env
            .rig
            .chains4
            .fk_joints8(&lanes8(pa.roots, pb.roots), &poses);
        a.set_joints(lanes4(&fk, 0));
        b.set_joints(lanes4(&fk, 4));
        [a.pull_to_grips(env, ia), b.pull_to_grips(env, ib)]
    }

    /// The second half of [`Sloth::solve_limbs`] after a first solve of
    /// `iterations` sweeps: the body pulled toward planted claws left short,
    /// again while that brings them closer (at most [`PULL_STEPS`] times).
    ///
    /// A pull that does not bring the worst planted claw closer is tried
    /// again at [`PULL_FRACTIONS`] of its length (a backtracking line
    /// search); the first that does is kept. Where two planted claws pinned
    /// at their limits want the body moved in opposite ways, the whole pull
    /// holds one claw and leaves the other shorter than the first was, while
    /// a part of it shares the shortfall between them (docs/locomotion.md,
    /// "Known slip at seed 5").
    fn pull_to_grips(&mut self, env: &LocoView<'_>, mut iterations: u32) -> u32 {
        for _ in 0..PULL_STEPS {
            let (residual, err) = self.planted_residual();
            if err <= STANCE_IK_TOLERANCE {
                break;
            }
            let saved = (self.body_pos, self.limbs);
            let mut closer = false;
            for f in PULL_FRACTIONS {
                self.body_pos = saved.0 + residual * f;
                iterations += self.solve_limbs_with(env, env.ccd);
                if self.planted_residual().1 < err {
                    closer = true;
                    break;
                }
                (self.body_pos, self.limbs) = saved;
            }
            if !closer {
                break;
            }
        }
        iterations
    }

    /// [`Sloth::solve_limbs`], skipped where it would change nothing. The solve
    /// is a deterministic function of the fields it reads (body, targets, limb
    /// phases, poses, settled targets) and of `env`; when all of those and the
    /// fields it writes (poses, settled targets, roots, effectors, body) hold
    /// exactly the bits that a call through `memo` left unchanged, this call
    /// would leave them unchanged again: it returns that call's sweep count
    /// (the memo compares the fields only the solve writes when it keeps a
    /// solve, not again: see [`SolveMemo`]).
    /// A resting sloth's solves are such (about a third of the sloth-frames of
    /// a 10,000-sloth crowd). `memo` belongs to this sloth and to `env` (start it
    /// with [`SolveMemo::default`]).
    pub fn solve_limbs_memo(&mut self, env: &LocoView<'_>, memo: &mut SolveMemo) -> u32 {
        match memo.hit(self) {
            Some(iterations) => iterations,
            None => {
                let mut own = [0; SOLVE_OWN_LEN];
                let armed = memo.arm(self, &mut own);
                self.solve_limbs_kept(env, memo, armed.then_some(&own))
            }
        }
    }

    /// [`Sloth::solve_limbs`] from the state `memo` was armed with (`own`: what
    /// its `arm` returned), remembered in `memo`.
    fn solve_limbs_kept(
        &mut self,
        env: &LocoView<'_>,
        memo: &mut SolveMemo,
        own: Option<&SolveOwn>,
    ) -> u32 {
        let iterations = self.solve_limbs(env);
        memo.keep(self, own, iterations);
        iterations
    }

    /// [`Sloth::solve_limbs_memo`] of every sloth of a batch (`memos[i]` is
    /// `sloths[i]`'s), the solves that are not skipped paired two by two as in
    /// [`Sloth::solve_limbs_pair`] (in batch order, so each sloth ends exactly
    /// as its own solve would leave it). Returns the sweeps of all.
    pub fn solve_limbs_batch<S: AsMut<Sloth>, M: AsMut<SolveMemo>>(
        sloths: &mut [S],
        memos: &mut [M],
        env: &LocoView<'_>,
    ) -> u64 {
        assert_eq!(sloths.len(), memos.len(), "one memo per sloth");
        let mut sweeps = 0u64;
        // A sloth to solve, waiting for a partner (its memo armed), whether
        // its memo was armed and the slot of `owns` holding its solve's own
        // fields before the solve (written there in place, never moved).
        let mut owns = [[0; SOLVE_OWN_LEN]; 2];
        let mut pending: Option<(usize, bool, usize)> = None;
        for i in 0..sloths.len() {
            let (sloth, memo) = (sloths[i].as_mut(), memos[i].as_mut());
            if let Some(n) = memo.hit(sloth) {
                sweeps += u64::from(n);
                continue;
            }
            // The slot the pending sloth does not use.
            let slot = pending.map_or(0, |(_, _, s)| 1 - s);
            let armed = memo.arm(sloth, &mut owns[slot]);
            let Some((j, armed_j, slot_j)) = pending.take() else {
                pending = Some((i, armed, slot));
                continue;
            };
            let (s_lo, s_hi) = sloths.split_at_mut(i);
            let (m_lo, m_hi) = memos.split_at_mut(i);
            let (a, b) = (s_lo[j].as_mut(), s_hi[0].as_mut());
            let [na, nb] = Sloth::solve_limbs_pair(a, b, env);
            m_lo[j]
                .as_mut()
                .keep(a, armed_j.then_some(&owns[slot_j]), na);
            m_hi[0].as_mut().keep(b, armed.then_some(&owns[slot]), nb);
            sweeps += u64::from(na) + u64::from(nb);
        }
        if let Some((j, armed, slot)) = pending {
            let n = sloths[j].as_mut().solve_limbs_kept(
                env,
                memos[j].as_mut(),
                armed.then_some(&owns[slot]),
            );
            sweeps += u64::from(n);
        }
        sweeps
    }

    /// Whether the bits of every field [`Sloth::solve_limbs`] reads that other
    /// stages write are `key`'s.
    fn solve_key_is(&self, key: &SolveKey) -> bool {
        let mut k = KeyEq::new(key);
        self.solve_key_into(&mut k);
        k.done()
    }

    /// The bits of every field [`Sloth::solve_limbs`] reads that other stages
    /// write, in order: the body, then per limb its target and phase.
    fn solve_key_into(&self, k: &mut impl KeySink) {
        k.f32s(self.body_pos.to_array());
        k.f32s(self.body_rot.to_array());
        for l in &self.limbs {
            k.f32s(l.target.to_array());
            k.f32s([l.phase as u32 as f32]);
        }
    }

    /// The bits of every field [`Sloth::solve_limbs`] reads or writes that
    /// only it writes, in order, per limb: pose, settled and cold-miss
    /// targets, root and effector (the joints, which it only writes, follow
    /// from the roots and poses).
    fn solve_own_into(&self, k: &mut impl KeySink) {
        for l in &self.limbs {
            for q in l.pose.0 {
                k.f32s(q.to_array());
            }
            for v in [l.settled_ls, l.cold_miss_ls] {
                match v {
                    Some(t) => k.f32s([1.0, t.x, t.y, t.z]),
                    None => k.f32s([0.0; 4]),
                }
            }
            k.f32s(l.root.to_array());
            k.f32s(l.effector.to_array());
        }
    }

    /// The mean of the planted limbs' claw → target vectors over those off
    /// by more than [`STANCE_IK_TOLERANCE`], and the largest planted error.
    fn planted_residual(&self) -> (Vec3, f32) {
        let (mut sum, mut n, mut max) = (Vec3::ZERO, 0.0f32, 0.0f32);
        for l in self.limbs.iter().filter(|l| l.phase != LimbPhase::Swinging) {
            let r = l.target - l.effector;
            let e = r.length();
            max = max.max(e);
            if e > STANCE_IK_TOLERANCE {
                sum += r;
                n += 1.0;
            }
        }
        (if n > 0.0 { sum / n } else { Vec3::ZERO }, max)
    }

    pub(super) fn solve_limbs_with(&mut self, env: &LocoView<'_>, params: &CcdParams) -> u32 {
        let prep = self.solve_prepare(env);
        let solved = (!prep.all_settled()).then(|| self.solve_lanes(env, &prep, params));
        self.solve_finish(env, params, &prep, solved)
    }

    /// The roots, targets and settled limbs of a solve (see [`SolvePrep`]).
    fn solve_prepare(&self, env: &LocoView<'_>) -> SolvePrep {
        let roots: [RootTransform; 4] =
            std::array::from_fn(|li| env.rig.root_ws(li, self.body_pos, self.body_rot));
        let targets = self.targets();
        // A limb that could not reach its target keeps its settled pose while
        // the target stays put in its root frame (a resting sloth): solving
        // again would only repeat the polish of the last frame.
        let settled: [bool; 4] = std::array::from_fn(|li| {
            self.limbs[li].settled_ls.is_some_and(|t| {
                let target_ls: Vec3 = roots[li].inverse_transform_point(targets[li].into()).into();
                t.distance_squared(target_ls) <= SETTLED_MOVE * SETTLED_MOVE
            })
        });
        SolvePrep {
            roots,
            targets,
            settled,
        }
    }

    /// The four limbs in SIMD lanes, each lane exactly the single-limb solve:
    /// the solved poses and results (the settled limbs' are not used).
    fn solve_lanes(
        &self,
        env: &LocoView<'_>,
        prep: &SolvePrep,
        params: &CcdParams,
    ) -> ([ChainPose; 4], [CcdResult; 4]) {
        let mut poses = self.limb_map(|l| l.pose);
        let results = slothsim_rig::solve4_prepared(
            &env.rig.chains4,
            prep.roots,
            prep.targets,
            &mut poses,
            params,
        );
        (poses, results)
    }

    /// The rest of a solve after its SIMD lanes (`solved`: `None` where every
    /// limb is settled): [`Sloth::solve_finish_limbs`], then the effectors.
    fn solve_finish(
        &mut self,
        env: &LocoView<'_>,
        params: &CcdParams,
        prep: &SolvePrep,
        solved: Option<([ChainPose; 4], [CcdResult; 4])>,
    ) -> u32 {
        let iterations = self.solve_finish_limbs(env, params, prep, solved);
        let poses = self.limb_map(|l| l.pose);
        self.set_joints(env.rig.chains4.fk_joints(&prep.roots, &poses));
        iterations
    }

    /// Resumed and cold solves where the SIMD lanes fell short, the settled
    /// targets and the roots (not the effectors). Returns the sweeps.
    fn solve_finish_limbs(
        &mut self,
        env: &LocoView<'_>,
        params: &CcdParams,
        prep: &SolvePrep,
        solved: Option<([ChainPose; 4], [CcdResult; 4])>,
    ) -> u32 {
        let SolvePrep { roots, settled, .. } = *prep;
        let mut iterations = 0;
        for li in 0..4 {
            let root = roots[li];
            let l = &mut self.limbs[li];
            if l.phase == LimbPhase::Swinging {
                l.cold_miss_ls = None;
            }
            if let (false, Some((poses, results))) = (settled[li], &solved) {
                l.pose = poses[li];
                let mut r = results[li];
                iterations += r.iterations;
                // A warm solve may stop short when its smoothness guard caps a
                // large joint move, or run out of sweeps: resume from where it
                // stopped (rare). Not where it stalled (joint limits): solved
                // again from there it stalls again (issue 26: of 1,047 such
                // solves in a 1,000-sloth crowd's first two seconds none came
                // 10 % closer, 75 % left the pose as it was).
                for _ in 0..3 {
                    if r.error <= params.tolerance
                        || !matches!(r.status, CcdStatus::Smoothed | CcdStatus::MaxIterations)
                    {
                        break;
                    }
                    let prev = r.error;
                    r = slothsim_rig::solve(
                        &env.rig.chains[li],
                        root,
                        l.target,
                        &mut l.pose,
                        params,
                    );
                    iterations += r.iterations;
                    if r.error > prev * 0.9 {
                        break;
                    }
                }
                // A planted claw the warm start left off its grip: the swing
                // may have carried the limb into a fold (a local minimum at
                // the joint limits) the step check, started elsewhere, did not
                // use. A cold start gets another chance (rare: a limb stays
                // settled until its target moves), but not again near where
                // one failed.
                let tried_here = l.cold_miss_ls.is_some_and(|t| {
                    t.distance_squared(prep.target_ls(li)) <= COLD_RETRY_MOVE * COLD_RETRY_MOVE
                });
                if l.phase != LimbPhase::Swinging && r.error > STANCE_IK_TOLERANCE && !tried_here {
                    let mut cold = ChainPose::NEUTRAL;
                    let c =
                        slothsim_rig::solve(&env.rig.chains[li], root, l.target, &mut cold, params);
                    iterations += c.iterations;
                    l.cold_miss_ls =
                        (c.error > r.error - COLD_RETRY_GAIN).then(|| prep.target_ls(li));
                    if c.error < r.error {
                        l.pose = cold;
                        r = c;
                    }
                }
                l.settled_ls = (r.error > params.tolerance).then(|| prep.target_ls(li));
            }
            l.root = root.position.into();
        }
        iterations
    }

    /// The joints and claws where the limbs' poses put them (world space;
    /// per limb joints 1..3 and the effector, [`LimbChains4::fk_joints`]).
    ///
    /// [`LimbChains4::fk_joints`]: slothsim_rig::LimbChains4::fk_joints
    fn set_joints(&mut self, joints: [[Vec3; 4]; 4]) {
        for (l, [j1, j2, j3, effector]) in self.limbs.iter_mut().zip(joints) {
            l.joints = Some([j1, j2, j3]);
            l.effector = effector;
        }
    }
}

#[cfg(test)]
mod tests {
    use slothsim_rig::Limb;
    use slothsim_scene::PresetKind;

    use super::super::test_util::{preset_sloth, xorshift};
    use super::*;

    /// The largest planted claw-to-grip distance.
    fn worst_grip_error(s: &Sloth) -> f32 {
        s.limbs
            .iter()
            .filter(|l| l.phase != LimbPhase::Swinging)
            .map(|l| l.grip.point.distance(l.effector))
            .fold(0.0, f32::max)
    }

    /// Both hind claws planted at the edge of their reach, in opposite
    /// directions (the seed-5 slip of docs/locomotion.md): LH's grip 3.5 to
    /// 6.5 mm beyond its reach, RH's up to 1.4 mm beyond (within the stance
    /// tolerance, so the pull follows LH alone). Pulling the body by LH's
    /// whole residual holds LH but leaves RH farther off than LH was (the
    /// whole pull is rejected); a part of it shares the shortfall, so the
    /// solve leaves the worst planted claw at least 0.5 mm nearer its grip
    /// than without a pull (11 of the 32 cases; the old all-or-nothing pull
    /// kept their error as it was). Directions drawn at random about the
    /// body's sideways axis; in every case the pull leaves the worst claw no worse off.
    #[test]
    fn a_pull_rejected_whole_is_taken_in_part() {
        let (env, base) = preset_sloth(PresetKind::BranchEnd);
        let view = env.view();
        let mut rnd = xorshift(36);
        let (a, b) = (Limb::LH.index(), Limb::RH.index());
        let mut rejected = 0;
        for case in 0..32 {
            let mut sloth = base;
            sloth.solve_limbs(&view);
            // The body's sideways axis, toward LH's claw.
            let x = sloth.body_rot * Vec3::X;
            let apart = sloth.limbs[a].effector - sloth.limbs[b].effector;
            let side = if x.dot(apart) >= 0.0 { x } else { -x };
            let tilt = Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5) * 0.8;
            let u = (side + tilt).normalize();
            // Each hind claw as far along ±u as it reaches.
            sloth.limbs[a].target = sloth.limbs[a].root + u;
            sloth.limbs[b].target = sloth.limbs[b].root - u;
            sloth.solve_limbs_with(&view, view.ccd);
            let over_a = 0.0035 + 0.003 * rnd();
            let over_b = 0.0014 * rnd();
            let grips = [
                (a, sloth.limbs[a].effector + u * over_a),
                (b, sloth.limbs[b].effector - u * over_b),
            ];
            for (li, p) in grips {
                sloth.limbs[li].target = p;
                sloth.limbs[li].grip.point = p;
            }
            assert!(sloth.limbs.iter().all(|l| l.phase != LimbPhase::Swinging));
            // The solve without a pull, and with the whole pull only.
            let mut plain = sloth;
            plain.solve_limbs_with(&view, view.ccd);
            let before = worst_grip_error(&plain);
            let mut whole = plain;
            whole.body_pos += whole.planted_residual().0;
            whole.solve_limbs_with(&view, view.ccd);
            let whole_rejected = worst_grip_error(&whole) >= before;
            let mut pulled = sloth;
            pulled.solve_limbs(&view);
            let after = worst_grip_error(&pulled);
            assert!(after.is_finite() && pulled.body_pos.is_finite());
            assert!(after <= before, "case {case}: {before} -> {after}");
            if whole_rejected && before > STANCE_IK_TOLERANCE {
                rejected += 1;
                assert!(
                    after < before - 0.0005,
                    "case {case}: whole pull rejected, {before} -> {after} m"
                );
            }
        }
        assert!(
            rejected >= 6,
            "{rejected} of 32 cases reject the whole pull"
        );
    }
}
