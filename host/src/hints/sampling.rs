//! A record sampled too slowly for its input or its motor: decimated by keeping one row in
//! `K`, or logged below the rate at which its voltage switches.
//!
//! **Why it cannot fit.** The model holds `v` over each sample step (sample `k` holds the
//! voltage applied from `t_k` to `t_k+1`) and discretises paper Eq. 1-4 exactly under that
//! hold. That is exact only when the voltage does not move between two samples. A record
//! made by keeping one row in `K` of a fast record whose voltage moves between the kept rows
//! (a PWM, a PRBS, a fast chirp; a step whose edge falls between them) tells the model a
//! voltage that was not applied over most of the step: the voltage actually applied is
//! unknown, no parameter set fits, and the misfit looks like an unmodelled effect. Averaging
//! the `K` rows (`--decimate K`, a boxcar over the step) gives the mean of the applied
//! voltage over the step instead, which the held-voltage model does fit as long as the
//! motor's time constants are several steps long.
//!
//! Two rules read it off the records and the fit, each only once the fit misfits (the
//! `model_adequate` gate of the hints) and no sign or unit explains it:
//!
//! - **An input rougher than its sampling** ([`rough_input`]). A voltage sampled well above
//!   its bandwidth changes little from one sample to the next; one that jumps by more than
//!   half its range between at least [`ROUGH_SHARE`] of its consecutive samples (and
//!   [`ROUGH_JUMPS`] times at least) has most of its power near the Nyquist frequency: it is
//!   sampled below its switching (aliased), so it surely moved between the samples too. A
//!   voltage step, a few steps, a ramp or a chirp of ten samples a period or more stays far
//!   below that share (a sine jumps by half its peak-to-peak only below six samples a
//!   period). A PRBS applied at the sample clock is rough by this rule too but fits, so the
//!   gate keeps it from the hint; when such a record misfits for another cause, the hint
//!   is still given, as a question.
//! - **A motor faster than the sampling** ([`too_slow_sampling`]). With a voltage change
//!   between two samples, the model applies it up to a step late. The error that leaves is
//!   the share of the response the motor completes in that part of a step: about `dt / tau`
//!   of the jump for a time constant `tau` longer than the step `dt`, all of it for a shorter
//!   one. So a fitted motor whose fastest time constant (the faster pole of paper Eq. 1-4:
//!   roots of `s^2 + (Ra/La + B/J) s + (Ra B + Kv^2)/(La J)`, pinned with or without the
//!   current) is shorter than the record's step, and whose misfit lies mostly (at least
//!   [`CHANGE_MISFIT`] of its excess over the noise) in the two samples that follow each
//!   change of the voltage, which are at most [`CHANGE_SAMPLES`] of the record, points at a
//!   record too slow for its motor. An unmodelled effect spreads its misfit over whole
//!   regimes (a friction over every steady state, a fan load over high speed) instead.

use crate::csvio::OwnedRecord;
use crate::fit::Fit;
use anyhow::{anyhow, Result};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::{ModelParams, ParamId};

/// Least share of a record's consecutive samples between which its voltage jumps by more
/// than half its range for the input to be rougher than its sampling.
pub const ROUGH_SHARE: f64 = 0.2;

/// Fewest such jumps (a short record with a few steps is not rough).
pub const ROUGH_JUMPS: usize = 8;

/// Least share of the misfit's excess over the noise in the samples just after the
/// voltage's changes for a motor faster than the sampling to explain it.
pub const CHANGE_MISFIT: f64 = 0.5;

/// Largest share of the records' samples those samples may be (beyond it the misfit is not
/// concentrated at the changes: the voltage changes almost everywhere).
pub const CHANGE_SAMPLES: f64 = 0.1;

/// A change of the voltage at least this share of its range starts a transient.
const CHANGE: f32 = 0.1;

/// The driven part of a record's voltage (before a coast-down, where it is not applied).
fn driven(r: &OwnedRecord) -> &[f32] {
    &r.v[..r.coast_from.unwrap_or(r.len()).min(r.len())]
}

/// Lowest and highest of `v`.
fn range(v: &[f32]) -> (f32, f32) {
    v.iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &x| {
            (lo.min(x), hi.max(x))
        })
}

/// `x` seconds in words: ms below a second.
fn seconds(x: f64) -> String {
    match x < 1.0 {
        true => format!("{:.3} ms", x * 1e3),
        false => format!("{x:.3} s"),
    }
}

/// " of FILE" when there are several records, else nothing.
fn of(records: &[OwnedRecord], r: &OwnedRecord) -> String {
    match records.len() > 1 {
        true => format!(" of {}", r.name()),
        false => String::new(),
    }
}

/// The hint when a record's voltage is rougher than its sampling (the roughest record's
/// numbers), else `None`.
pub fn rough_input(records: &[OwnedRecord]) -> Option<String> {
    let mut roughest: Option<(f64, usize, &OwnedRecord)> = None;
    for r in records {
        let v = driven(r);
        let (lo, hi) = range(v);
        let half = 0.5 * (hi - lo);
        if v.len() < 3 || !half.is_finite() || half <= 0.0 {
            continue;
        }
        let jumps = v.windows(2).filter(|w| (w[1] - w[0]).abs() > half).count();
        let share = jumps as f64 / (v.len() - 1) as f64;
        if jumps >= ROUGH_JUMPS && roughest.is_none_or(|(s, _, _)| share > s) {
            roughest = Some((share, jumps, r));
        }
    }
    let (share, _, r) = roughest.filter(|(s, _, _)| *s >= ROUGH_SHARE)?;
    let (lo, hi) = range(driven(r));
    Some(format!(
        "the v column{} jumps by more than half its range ({lo} to {hi} V) between {:.0} % of its consecutive samples: an input rougher than its sampling (a PWM, a PRBS or a fast chirp logged too slowly, or a fast record thinned to one row in K?), while the model holds v over each step of {}; record faster, or read the fast record with --decimate K, which averages the K rows instead of keeping one",
        of(records, r),
        100.0 * share,
        seconds(f64::from(r.dt)),
    ))
}

/// The fitted motor's fastest time constant [s]: the inverse of the faster decay rate of
/// paper Eq. 1-4's two poles (`None` when the parameters give none).
pub fn fastest_time_constant(p: &ModelParams) -> Option<f64> {
    let get = |id| f64::from(p.get(id));
    let (ra, la, j, b, kv) = (
        get(ParamId::Ra),
        get(ParamId::La),
        get(ParamId::J),
        get(ParamId::B),
        get(ParamId::Kv),
    );
    let a = ra / la + b / j;
    let c = (ra * b + kv * kv) / (la * j);
    let disc = a * a - 4.0 * c;
    let rate = match disc > 0.0 {
        true => 0.5 * (a + disc.sqrt()),
        false => 0.5 * a,
    };
    (rate.is_finite() && rate > 0.0).then(|| 1.0 / rate)
}

/// The hint when the fitted motor is faster than the records' step and the misfit lies in
/// the samples just after the voltage's changes, else `None`. Simulates each record once,
/// one at a time (8 bytes a sample of the longest, as `--plot`).
pub fn too_slow_sampling(records: &[OwnedRecord], given: &Fit) -> Result<Option<String>> {
    let Some(tau) = fastest_time_constant(&given.result.params) else {
        return Ok(None);
    };
    let Some(slow) = records
        .iter()
        .filter(|r| f64::from(r.dt) > tau)
        .max_by(|a, b| a.dt.total_cmp(&b.dt))
    else {
        return Ok(None);
    };
    let borrowed = OwnedRecord::as_records(records, given.with_current);
    let objective = Objective::new(&borrowed).map_err(|e| anyhow!("{e}"))?;
    // Each channel's noise and the share of it in a squared residual over it: 1, or 0 for
    // a noise-free channel, whose residual is taken as it is.
    let noise = |sigma: f32| match sigma.is_finite() && sigma > 0.0 {
        true => (f64::from(sigma), 1.0),
        false => (1.0, 0.0),
    };
    let (sigma_omega, omega_share) = noise(given.result.sigma_omega);
    let (sigma_current, current_share) = noise(given.result.sigma_current.unwrap_or(0.0));
    // Each sample's squared residual over the noise, less the noise's own share, summed
    // over every sample and over those just after a change.
    let (mut excess, mut at_changes, mut samples, mut changes) = (0.0, 0.0, 0usize, 0usize);
    for (k, r) in records.iter().enumerate() {
        let (mut w, mut i) = (vec![0.0; r.len()], vec![0.0; r.len()]);
        objective
            .simulate(&given.result.params, k, &mut w, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        let v = driven(r);
        let (lo, hi) = range(v);
        // Whether the voltage changes into sample `s` (by a tenth of its range or more),
        // in a record whose step is longer than the motor's time constant.
        let changes_at = |s: usize| {
            f64::from(r.dt) > tau
                && hi > lo
                && (1..v.len()).contains(&s)
                && (v[s] - v[s - 1]).abs() >= CHANGE * (hi - lo)
        };
        for s in 0..r.len() {
            let mut e = (f64::from(r.omega[s] - w[s]) / sigma_omega).powi(2) - omega_share;
            if let (true, Some(c)) = (given.with_current, &r.current) {
                e += (f64::from(c[s] - i[s]) / sigma_current).powi(2) - current_share;
            }
            excess += e;
            if changes_at(s) || (s > 0 && changes_at(s - 1)) {
                at_changes += e;
                changes += 1;
            }
        }
        samples += r.len();
    }
    let concentrated = changes > 0
        && (changes as f64) <= CHANGE_SAMPLES * samples as f64
        && excess > 0.0
        && at_changes >= CHANGE_MISFIT * excess;
    if !concentrated {
        return Ok(None);
    }
    Ok(Some(format!(
        "{:.0} % of the misfit lies in the {changes} samples ({:.1} % of them) just after the voltage changes, and the fitted motor settles with a time constant of {}, shorter than the record's step of {}{}: a voltage change between two samples (a step off the sample grid, a record thinned to one row in K) reaches the model up to a step late; record faster, several samples per time constant",
        100.0 * at_changes / excess,
        100.0 * changes as f64 / samples as f64,
        seconds(tau),
        seconds(f64::from(slow.dt)),
        of(records, slow),
    )))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn record(v: Vec<f32>) -> OwnedRecord {
        OwnedRecord {
            path: "r.csv".into(),
            t0: 0.0,
            dt: 1e-3,
            omega: vec![1.0; v.len()],
            v,
            current: None,
            load: None,
            coast_from: None,
            averaged: 1,
        }
    }

    #[test]
    fn a_switching_input_is_rough_and_steps_or_a_well_sampled_sine_are_not() {
        // Two levels at random, one sample each: half the steps jump by the whole range.
        let mut x: u32 = 12345;
        let prbs = (0..400)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                [24.0, 0.0][(x % 2) as usize]
            })
            .collect();
        let hint = rough_input(&[record(prbs)]).expect("a PRBS sampled at its clock is rough");
        assert!(hint.contains("rougher than its sampling"), "{hint}");
        assert!(hint.contains("(0 to 24 V)"), "{hint}");
        let steps = (0..400).map(|k| [12.0, 24.0, 6.0][k / 134]).collect();
        assert_eq!(rough_input(&[record(steps)]), None);
        // Ten samples a period: it jumps by at most sin(pi/10) = 31 % of its range.
        let sine = (0..400)
            .map(|k| 24.0 * (std::f32::consts::TAU * k as f32 / 10.0).sin())
            .collect();
        assert_eq!(rough_input(&[record(sine)]), None);
        // A short record with a few steps: too few jumps to say.
        let few = (0..20).map(|k| [0.0, 24.0][k / 4 % 2]).collect();
        assert_eq!(rough_input(&[record(few)]), None);
    }

    #[test]
    fn the_fastest_time_constant_is_la_over_ra_for_a_slow_shaft() {
        // La/Ra 20 ms, mechanical time constant 0.27 s: the fast pole is near Ra/La.
        let p = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08);
        let tau = fastest_time_constant(&p).unwrap();
        assert!((tau / 0.02 - 1.0).abs() < 0.1, "{tau}");
    }
}
