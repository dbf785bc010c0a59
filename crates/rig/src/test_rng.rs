//! A seeded generator for the unit tests' random poses and targets.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64Mcg;

/// Uniform floats in [0, 1) from a PCG stream seeded with `seed`.
pub(crate) fn uniform(seed: u64) -> impl FnMut() -> f32 {
    let mut rng = Pcg64Mcg::seed_from_u64(seed);
    move || rng.random::<f32>()
}
