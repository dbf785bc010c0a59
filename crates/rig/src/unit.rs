//! Unit vectors without glam's float-class test.
//!
//! glam's `Vec3::normalize_or` keeps `self * rcp` where `rcp.is_finite() &&
//! rcp > 0.0`; `is_finite` compiles to a float-class test (about 16 integer
//! instructions on x86) on this hot path (2.2 % of a steady crowd's tick,
//! docs/performance.md). `rcp > 0.0 && rcp <= f32::MAX` gives the same
//! answer for every f32 (NaN and ±∞ fail, zeros fail, subnormals pass) in
//! two compares; the arithmetic is glam's own, so the results are the same
//! bits.

use glam::{Vec3, Vec3A};

/// [`Vec3::normalize_or`] and [`Vec3::normalize_or_zero`] (and `Vec3A`'s),
/// bit for bit, with two compares for the finiteness test.
pub trait UnitOr {
    /// `self` scaled to length 1, or `fallback` where that is not finite
    /// (zero or non-finite length): [`Vec3::normalize_or`].
    fn unit_or(self, fallback: Self) -> Self;
    /// [`Self::unit_or`] with zero: [`Vec3::normalize_or_zero`].
    fn unit_or_zero(self) -> Self;
}

macro_rules! unit_or {
    ($t:ty) => {
        impl UnitOr for $t {
            #[inline]
            fn unit_or(self, fallback: $t) -> $t {
                let rcp = self.length_recip();
                if (rcp > 0.0) & (rcp <= f32::MAX) {
                    self * rcp
                } else {
                    fallback
                }
            }

            #[inline]
            fn unit_or_zero(self) -> $t {
                self.unit_or(<$t>::ZERO)
            }
        }
    };
}

unit_or!(Vec3);
unit_or!(Vec3A);

#[cfg(test)]
mod tests {
    use super::*;

    fn same(a: Vec3, b: Vec3) -> bool {
        a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits)
    }

    /// Every vector of special and random components: the same bits as glam.
    #[test]
    fn unit_or_is_normalize_or_bit_for_bit() {
        let special = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1e-40,
            -1e-40,
            1e-20,
            1.0,
            -1.0,
            1e19,
            1e20,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let fallback = Vec3::new(0.25, -0.5, 2.0);
        let check = |v: Vec3| {
            assert!(same(v.unit_or(fallback), v.normalize_or(fallback)), "{v:?}");
            assert!(same(v.unit_or_zero(), v.normalize_or_zero()), "{v:?}");
            let (a, fa) = (Vec3A::from(v), Vec3A::from(fallback));
            assert!(
                same(a.unit_or(fa).into(), a.normalize_or(fa).into()),
                "{v:?}"
            );
            assert!(
                same(a.unit_or_zero().into(), a.normalize_or_zero().into()),
                "{v:?}"
            );
        };
        for &x in &special {
            for &y in &special {
                for &z in &special {
                    check(Vec3::new(x, y, z));
                }
            }
        }
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        let mut bits = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            f32::from_bits((s >> 32) as u32)
        };
        for _ in 0..1_000_000 {
            check(Vec3::new(bits(), bits(), bits()));
        }
    }
}
