//! The scale of J, B, Kv and friction against the current reading's resolution.
//!
//! Divided by Kv, paper Eq. 4 gives the speed from the current through J/Kv, B/Kv and
//! tc/Kv alone: scaling J, B, Kv and tc together leaves the speed unchanged for a given
//! current. Kv itself shows only in the back-EMF term of paper Eq. 1, a current of
//! Kv ω / Ra. When that current stays under [`SCALE_COUNTS`] of an ADC's current reading
//! whose noise is under half a count (too little to dither the rounding), the scale moves
//! few readings by a count: whatever the local analysis infers from averaging rounded
//! readings rests on their rounding pattern, not on the motor. A reading held within one
//! count keeps an error of 0.10 count at a noise of 0.2 count (0.29 without noise,
//! [`crate::model::rounding::Rounding`]): 7 to 19 % of a back-EMF of 1.5 counts, about the
//! 10 % that pins. And the rule is judged by the estimate, whose back-EMF moves with the
//! scale. On the commissioning benchmark a viscous motor whose back-EMF took
//! a quarter of a count came back with all four pinned 55 % off at 25 to 37 deviations;
//! once the Jacobian followed the scale (`crate::fit::torque_scale`), one whose back-EMF
//! took 0.46 count came back with the scale 124 % off, where its estimate put the back-EMF
//! at 1.03 counts, past a rule of half a count (docs/measurements/commissioning.md).
//! Such a scale is reported as not pinned.

use crate::fit::identifiability::Identifiability;
use crate::fit::torque_scale;
use crate::model::noise::noise_sigma;
use crate::model::params::ModelParams;
use crate::model::record::Record;
use crate::model::rounding::Rounding;
use crate::param_id::ParamId;

/// Counts under which the back-EMF current, by the estimate, leaves the scale unfixed.
pub const SCALE_COUNTS: f32 = 1.5;
/// Noise before rounding, in counts, under which the rounding is not dithered away.
const UNDITHERED: f32 = 0.5;

/// True when the back-EMF current at the records' highest speed, by the estimate `p`,
/// lies under [`SCALE_COUNTS`] of the current reading's count, the reading's noise
/// `sigma_current` (rounding included) being under [`UNDITHERED`] of a count before
/// rounding. False for records without current (readings off a grid have a smallest step
/// far under their noise: dithered).
pub fn below_resolution(records: &[Record], p: &ModelParams, sigma_current: f32) -> bool {
    let mut count = f32::INFINITY;
    let mut top = 0.0f32;
    // Drive readings per sample at most: the noise of one reading is √m times a mean's.
    let mut readings = 1u32;
    for r in records {
        readings = readings.max(r.averaged);
        let Some(current) = r.current else {
            return false;
        };
        let q = Rounding::of_means(current, sigma_current, r.averaged).count;
        if q > 0.0 {
            count = count.min(q);
        }
        top = r.omega.iter().fold(top, |m, w| m.max(w.abs()));
    }
    if !count.is_finite() {
        return false;
    }
    // Sheppard: the noise of one reading before rounding. Records of means (of several
    // readings each) pool noises of different sizes: the least of their single readings'.
    let single = match readings {
        1 => sigma_current,
        _ => records
            .iter()
            .filter_map(|r| {
                r.current
                    .map(|c| noise_sigma(c) * libm::sqrtf(r.averaged.max(1) as f32))
            })
            .fold(f32::INFINITY, f32::min),
    };
    let before = (single * single - count * count / 12.0).max(0.0);
    let back_emf = p.get(ParamId::Kv) * top / p.get(ParamId::Ra);
    libm::sqrtf(before) < UNDITHERED * count && back_emf < SCALE_COUNTS * count
}

/// Call J, B, Kv and the torque parameters that scale with them
/// ([`torque_scale::scales`]: tc, when free) not pinned when all of J, B and Kv are free
/// and [`below_resolution`] holds.
pub fn unpin_scale(
    identifiability: &mut Identifiability,
    records: &[Record],
    p: &ModelParams,
    sigma_current: f32,
) {
    let free = |id: ParamId| identifiability.params.iter().any(|c| c.id == id);
    let motor = [ParamId::J, ParamId::B, ParamId::Kv];
    if !motor.iter().all(|&id| free(id)) || !below_resolution(records, p, sigma_current) {
        return;
    }
    let mut unpinned = false;
    for c in identifiability.params.iter_mut() {
        if torque_scale::scales(c.id) {
            unpinned |= c.pinned;
            c.pinned = false;
            c.std = None;
        }
    }
    // One direction (the common scale) fewer is pinned.
    if unpinned {
        identifiability.rank = identifiability.rank.saturating_sub(1);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    extern crate std;
    use std::vec::Vec;

    /// A record of `n` samples whose current sweeps 0-3 A rounded to counts of `q` [A], with
    /// the speed rising to `top` [rad/s].
    fn readings(n: usize, q: f32, top: f32) -> (Vec<f32>, Vec<f32>, Vec<f32>) {
        let current = (0..n)
            .map(|k| libm::roundf(3.0 * k as f32 / n as f32 / q) * q)
            .collect();
        let omega = (0..n).map(|k| top * k as f32 / (n - 1) as f32).collect();
        (
            Vec::from_iter(core::iter::repeat_n(10.0, n)),
            omega,
            current,
        )
    }

    #[test]
    fn the_back_emf_within_a_count_and_a_half_of_an_undithered_reading_is_below_resolution() {
        let q = 0.0234;
        let (v, omega, current) = readings(500, q, 3.5);
        let record = Record {
            dt: 1e-3,
            v: &v,
            omega: &omega,
            current: Some(&current),
            load: None,
            coast_from: None,
            averaged: 1,
        };
        // Ra 8.56 ohm: Kv 0.0135 V s/rad gives 5.5 mA at 3.5 rad/s (0.24 count); 0.1 gives
        // 41 mA (1.7 counts).
        let motor = |kv: f32| {
            ModelParams::PAPER_MOTOR
                .with(ParamId::Ra, 8.56)
                .with(ParamId::Kv, kv)
        };
        // Noise of 5 mA (0.2 count) before rounding: its measured deviation with rounding.
        let sigma = libm::sqrtf(0.005 * 0.005 + q * q / 12.0);
        let records = [record];
        assert!(below_resolution(&records, &motor(0.0135), sigma));
        // 0.07 gives 28.6 mA, 1.2 counts: its held rounding error of 0.1 count is 8 % of it.
        assert!(below_resolution(&records, &motor(0.07), sigma));
        assert!(!below_resolution(&records, &motor(0.1), sigma));
        // Noise of a count dithers the rounding: averaging resolves the back-EMF.
        let dithered = libm::sqrtf(q * q + q * q / 12.0);
        assert!(!below_resolution(&records, &motor(0.0135), dithered));
    }
}
