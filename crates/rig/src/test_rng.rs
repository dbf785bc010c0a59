//! A tiny seeded generator for the unit tests' random poses and targets.

/// Uniform floats in [0, 1) from a xorshift64 stream seeded with `seed`.
pub(crate) fn uniform(mut s: u64) -> impl FnMut() -> f32 {
    move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 40) as f32 / (1u64 << 24) as f32
    }
}
