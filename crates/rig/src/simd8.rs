//! Eight `f32` lanes in one AVX register, with the part of `glam::Vec4`'s and
//! `glam::BVec4A`'s API the lane-generic CCD kernel uses ([`crate::ccd4`]).
//!
//! Every operation is the 256-bit form of the SSE instruction `glam` uses for
//! the same `Vec4` method (`addps` → `vaddps ymm`, `minps` → `vminps ymm`, the
//! same ordered compares, sign bits by the same masks), so lane `i` gives the
//! bits the `Vec4` code gives, for NaN too.
//!
//! **Only for code compiled with AVX enabled** (`#[target_feature(enable =
//! "avx2")]` functions reached after `is_x86_feature_detected!("avx2")`): the
//! methods are `#[inline(always)]` wrappers of AVX intrinsics, inlined into
//! such a function; the crate constructs these types nowhere else.

use std::arch::x86_64::*;
use std::ops::{Add, BitAnd, BitAndAssign, BitOr, BitOrAssign, Div, Mul, Neg, Not, Sub};

/// Eight `f32` lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct F8(__m256);

/// Eight lane masks (all bits set or clear per lane), as `BVec4A`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct M8(__m256);

// SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
// Every `unsafe` block below is an AVX intrinsic: it runs only inside functions
// compiled with AVX2 enabled, reached after the CPU check (see the module docs).

impl F8 {
    pub(crate) const ZERO: F8 = F8::from_bits_const(0);
    pub(crate) const ONE: F8 = F8::from_bits_const(0x3f80_0000);

    const fn from_bits_const(b: u32) -> F8 {
        // SAFETY: `__m256` is eight `f32`s; a plain bit pattern.
        F8(unsafe { std::mem::transmute::<[u32; 8], __m256>([b; 8]) })
    }

    #[inline(always)]
    pub(crate) fn splat(x: f32) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_set1_ps(x)) }
    }

    #[inline(always)]
    pub(crate) fn from_array(a: [f32; 8]) -> F8 {
        // SAFETY: AVX (module docs); the unaligned load reads the 8 `f32`s of `a`.
        unsafe { F8(_mm256_loadu_ps(a.as_ptr())) }
    }

    #[inline(always)]
    pub(crate) fn to_array(self) -> [f32; 8] {
        let mut a = [0.0f32; 8];
        // SAFETY: AVX (module docs); the unaligned store writes the 8 `f32`s of `a`.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }

    /// `m ? a : b` lane-wise (as `Vec4::select`).
    #[inline(always)]
    pub(crate) fn select(m: M8, a: F8, b: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_blendv_ps(b.0, a.0, m.0)) }
    }

    #[inline(always)]
    pub(crate) fn cmplt(self, o: F8) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_cmp_ps::<_CMP_LT_OQ>(self.0, o.0)) }
    }

    #[inline(always)]
    pub(crate) fn cmple(self, o: F8) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)) }
    }

    #[inline(always)]
    pub(crate) fn cmpgt(self, o: F8) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_cmp_ps::<_CMP_GT_OQ>(self.0, o.0)) }
    }

    #[inline(always)]
    pub(crate) fn cmpge(self, o: F8) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_cmp_ps::<_CMP_GE_OQ>(self.0, o.0)) }
    }

    #[inline(always)]
    pub(crate) fn cmpeq(self, o: F8) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_cmp_ps::<_CMP_EQ_OQ>(self.0, o.0)) }
    }

    /// Clears the sign bits (as `Vec4::abs`).
    #[inline(always)]
    pub(crate) fn abs(self) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_andnot_ps(_mm256_set1_ps(-0.0), self.0)) }
    }

    /// `minps` order: the second operand where either is NaN (as `Vec4::min`).
    #[inline(always)]
    pub(crate) fn min(self, o: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_min_ps(self.0, o.0)) }
    }

    /// `maxps` order (as `Vec4::max`).
    #[inline(always)]
    pub(crate) fn max(self, o: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_max_ps(self.0, o.0)) }
    }

    /// The magnitude of `self` with the sign of `s` (as `Vec4::copysign`).
    #[inline(always)]
    pub(crate) fn copysign(self, s: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe {
            let sign = _mm256_set1_ps(-0.0);
            F8(_mm256_or_ps(
                _mm256_andnot_ps(sign, self.0),
                _mm256_and_ps(s.0, sign),
            ))
        }
    }

    /// IEEE square root (as `_mm_sqrt_ps`).
    #[inline(always)]
    pub(crate) fn sqrt(self) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_sqrt_ps(self.0)) }
    }
}

impl Add for F8 {
    type Output = F8;
    #[inline(always)]
    fn add(self, o: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_add_ps(self.0, o.0)) }
    }
}

impl Sub for F8 {
    type Output = F8;
    #[inline(always)]
    fn sub(self, o: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_sub_ps(self.0, o.0)) }
    }
}

impl Mul for F8 {
    type Output = F8;
    #[inline(always)]
    fn mul(self, o: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_mul_ps(self.0, o.0)) }
    }
}

impl Div for F8 {
    type Output = F8;
    #[inline(always)]
    fn div(self, o: F8) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_div_ps(self.0, o.0)) }
    }
}

impl Neg for F8 {
    type Output = F8;
    /// Flips the sign bits (as `Vec4`'s `Neg`).
    #[inline(always)]
    fn neg(self) -> F8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { F8(_mm256_xor_ps(_mm256_set1_ps(-0.0), self.0)) }
    }
}

/// Eight rows of four `f32`s as four columns of eight lanes: lane `i` of
/// column `k` is `rows[i][k]`. Pure data movement (an 8×4 transpose: each
/// half of the register is the classic 4×4 `unpack`/`shuffle` transpose of
/// four rows), so every bit, NaN payloads included, arrives unchanged.
#[inline(always)]
pub(crate) fn columns(rows: [glam::Vec4; 8]) -> [F8; 4] {
    let r = rows.map(__m128::from);
    // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
    unsafe {
        // Rows i and i + 4 in the two halves of one register. (No closures
        // here: they would not inherit the caller's AVX, see the module docs.)
        let a0 = _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(r[0]), r[4]);
        let a1 = _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(r[1]), r[5]);
        let a2 = _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(r[2]), r[6]);
        let a3 = _mm256_insertf128_ps::<1>(_mm256_castps128_ps256(r[3]), r[7]);
        // [x0 x1 y0 y1], [z0 z1 w0 w1], [x2 x3 y2 y3], [z2 z3 w2 w3] (per half)
        let t0 = _mm256_unpacklo_ps(a0, a1);
        let t1 = _mm256_unpackhi_ps(a0, a1);
        let t2 = _mm256_unpacklo_ps(a2, a3);
        let t3 = _mm256_unpackhi_ps(a2, a3);
        [
            F8(_mm256_shuffle_ps::<0b01_00_01_00>(t0, t2)),
            F8(_mm256_shuffle_ps::<0b11_10_11_10>(t0, t2)),
            F8(_mm256_shuffle_ps::<0b01_00_01_00>(t1, t3)),
            F8(_mm256_shuffle_ps::<0b11_10_11_10>(t1, t3)),
        ]
    }
}

/// The inverse of [`columns`]: row `i` is lane `i` of the four columns
/// (pure data movement).
#[inline(always)]
pub(crate) fn rows(cols: [F8; 4]) -> [glam::Vec4; 8] {
    let [F8(x), F8(y), F8(z), F8(w)] = cols;
    // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
    unsafe {
        // [x0 y0 x1 y1], [x2 y2 x3 y3], [z0 w0 z1 w1], [z2 w2 z3 w3] (per half)
        let t0 = _mm256_unpacklo_ps(x, y);
        let t1 = _mm256_unpackhi_ps(x, y);
        let t2 = _mm256_unpacklo_ps(z, w);
        let t3 = _mm256_unpackhi_ps(z, w);
        // Rows i (low half) and i + 4 (high half).
        let r = [
            _mm256_shuffle_ps::<0b01_00_01_00>(t0, t2),
            _mm256_shuffle_ps::<0b11_10_11_10>(t0, t2),
            _mm256_shuffle_ps::<0b01_00_01_00>(t1, t3),
            _mm256_shuffle_ps::<0b11_10_11_10>(t1, t3),
        ];
        [
            _mm256_castps256_ps128(r[0]),
            _mm256_castps256_ps128(r[1]),
            _mm256_castps256_ps128(r[2]),
            _mm256_castps256_ps128(r[3]),
            _mm256_extractf128_ps::<1>(r[0]),
            _mm256_extractf128_ps::<1>(r[1]),
            _mm256_extractf128_ps::<1>(r[2]),
            _mm256_extractf128_ps::<1>(r[3]),
        ]
        .map(glam::Vec4::from)
    }
}

impl M8 {
    #[inline(always)]
    pub(crate) fn splat(v: bool) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_castsi256_ps(_mm256_set1_epi32(-i32::from(v)))) }
    }

    /// Lane `i` in bit `i`.
    #[inline(always)]
    pub(crate) fn bitmask(self) -> u32 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }

    #[inline(always)]
    pub(crate) fn any(self) -> bool {
        self.bitmask() != 0
    }

    #[inline(always)]
    pub(crate) fn test(self, i: usize) -> bool {
        self.bitmask() & (1 << i) != 0
    }
}

impl BitAnd for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitand(self, o: M8) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_and_ps(self.0, o.0)) }
    }
}

impl BitOr for M8 {
    type Output = M8;
    #[inline(always)]
    fn bitor(self, o: M8) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe { M8(_mm256_or_ps(self.0, o.0)) }
    }
}

impl Not for M8 {
    type Output = M8;
    #[inline(always)]
    fn not(self) -> M8 {
        // SAFETY: register-only AVX intrinsics, reached only from AVX2-enabled code on a CPU with AVX2 (module docs).
        unsafe {
            let ones = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
            M8(_mm256_xor_ps(self.0, ones))
        }
    }
}

impl BitAndAssign for M8 {
    #[inline(always)]
    fn bitand_assign(&mut self, o: M8) {
        *self = *self & o;
    }
}

impl BitOrAssign for M8 {
    #[inline(always)]
    fn bitor_assign(&mut self, o: M8) {
        *self = *self | o;
    }
}
