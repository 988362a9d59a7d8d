//! Deterministic random numbers: one seeded xoshiro128++ (32-bit, cheap on the M4F) and the
//! few distributions the optimiser and the simulator need. Same seed, same numbers, on the
//! host and on the board.

use rand_core::{RngCore, SeedableRng};

/// The generator used everywhere in the crate.
pub type Rng = rand_xoshiro::Xoshiro128PlusPlus;

/// A generator from a 64-bit seed.
pub fn seeded(seed: u64) -> Rng {
    Rng::seed_from_u64(seed)
}

/// Uniform in [0, 1) with 24 random bits.
pub fn unit<R: RngCore>(rng: &mut R) -> f32 {
    (rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// Uniform in [lo, hi).
pub fn uniform<R: RngCore>(rng: &mut R, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * unit(rng)
}

/// Uniform index in [0, n), n > 0.
pub fn index<R: RngCore>(rng: &mut R, n: usize) -> usize {
    ((rng.next_u32() as u64 * n as u64) >> 32) as usize
}

/// Standard normal (Box-Muller, one value per call).
pub fn normal<R: RngCore>(rng: &mut R) -> f32 {
    let u1 = 1.0 - unit(rng); // (0, 1]
    let u2 = unit(rng);
    libm::sqrtf(-2.0 * libm::logf(u1)) * libm::cosf(core::f32::consts::TAU * u2)
}
