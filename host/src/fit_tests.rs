//! Tests of the fits' wrappers: the widened search.

use super::*;
use motor_id_shared::fit::objective::Cost;
use motor_id_shared::model::sim::{InitialState, Simulator};
use motor_id_shared::ParamId;

/// A motor with cogging of 0.1 N m at 8 per revolution (5 % of its stall torque): a speed
/// ripple of some 0.1 rad/s at the [`square_wave`]'s low step, 65 rad/s.
pub fn cogged() -> ModelParams {
    ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08)
        .with(ParamId::CogAmp, 0.1)
        .with(ParamId::CogCycles, 8.0)
        .with(ParamId::CogPhase, 1.0)
}

/// The test records' input at 1 kHz, `n` samples: 24 V and 6 V in turn, 1 s each.
pub fn square_wave(n: usize) -> Vec<f32> {
    (0..n)
        .map(|k| if (k / 1000) % 2 == 0 { 24.0 } else { 6.0 })
        .collect()
}

/// Deterministic noise for test readings: a draw uniform within `±scale` at each call, from
/// the xorshift generator seeded `seed` (0 taken as 1).
pub fn noise(seed: u32) -> impl FnMut(f32) -> f32 {
    let mut x = seed.max(1);
    move |scale| {
        x ^= x << 13;
        x ^= x >> 17;
        x ^= x << 5;
        scale * ((x % 2001) as f32 / 1000.0 - 1.0)
    }
}

/// `seconds` at 1 kHz of `p` driven by the [`square_wave`], with a little deterministic
/// [`noise`] on both readings (of the generator seeded `seed`).
pub fn record(p: &ModelParams, seconds: usize, seed: u32) -> OwnedRecord {
    let (dt, n) = (1e-3f32, 1000 * seconds);
    let v = square_wave(n);
    let mut sim = Simulator::new(p, dt, InitialState::REST).unwrap();
    let mut noise = noise(seed);
    let (mut omega, mut current) = (Vec::with_capacity(n), Vec::with_capacity(n));
    for &volts in &v {
        let y = sim.reading();
        omega.push(y.omega + noise(0.05));
        current.push(y.current + noise(0.01));
        sim.advance(volts, 0.0);
    }
    OwnedRecord::readings("rippled.csv", dt, v, omega, Some(current))
}

/// The motor of `p` free with the parameters `own` free within their bounds `lo..hi`, and
/// the same with only `own` free, everything else held at `start`: the problem and the
/// search of its basin.
fn problem_of(own: &[(ParamId, f32, f32)], start: &ModelParams) -> (ProblemSpec, ProblemSpec) {
    let mut spec = ProblemSpec::default();
    for &(id, lo, hi) in own {
        spec.set_bounds(id, lo, hi).unwrap();
        spec.free(id);
    }
    let mut alone = spec;
    alone.base = *start;
    ParamId::MOTOR
        .iter()
        .for_each(|id| alone.free[id.index()] = false);
    (spec, alone)
}

/// Fit options without progress bars.
pub fn quiet() -> FitOptions {
    FitOptions {
        quiet: true,
        ..FitOptions::default()
    }
}

/// Least squares alone from `start` stays above `stall` times the misfit of a refit from
/// the truth `truth` (`misfit` of a fit's cost); the search of `alone` widened (`decimate`d,
/// by `decimation`) refits `spec` to within 1 % of it. The widened fit.
#[allow(clippy::too_many_arguments)]
fn widened_past_a_stall(
    records: &[OwnedRecord],
    (spec, alone): (&ProblemSpec, &ProblemSpec),
    (truth, start): (&ModelParams, &ModelParams),
    (decimate, decimation): (bool, usize),
    misfit: fn(&Cost) -> f32,
    stall: f32,
) -> Identification {
    let at_truth = misfit(
        &refit_from(records, &quiet(), spec, truth)
            .unwrap()
            .result
            .cost,
    );
    let stalled = misfit(
        &refit_from(records, &quiet(), spec, start)
            .unwrap()
            .result
            .cost,
    );
    assert!(
        stalled > stall * at_truth,
        "least squares alone should stall: {stalled} against {at_truth}"
    );
    let widened = widen_from(records, &quiet(), alone, spec, start, decimate, refit_from).unwrap();
    assert_eq!(widened.decimation, decimation);
    let found = widened.fit.expect("the search gained: refitted").result;
    let reached = misfit(&found.cost);
    assert!(
        reached < 1.01 * at_truth,
        "the widened search should reach the truth's basin: {reached} against {at_truth}"
    );
    found
}

#[test]
fn a_widened_search_leaves_a_ridge_least_squares_stays_on() {
    // Cogging started half a turn off its phase: least squares alone sits on the ridge
    // (the phase's gradient vanishes there by symmetry) and takes the amplitude to zero.
    // (A tacho ripple no longer has this ridge: its angle is tracked on the readings,
    // which pull a phase half a turn off back in.)
    let truth = cogged();
    let records = [record(&truth, 12, 11)];
    let start = truth.with(ParamId::CogPhase, 1.0 + core::f32::consts::PI);
    let (mut spec, mut alone) = problem_of(
        &[
            (ParamId::CogAmp, 0.0, 0.5),
            (ParamId::CogPhase, 0.0, core::f32::consts::TAU),
        ],
        &start,
    );
    spec.fix(ParamId::CogCycles, 8.0).unwrap();
    alone.fix(ParamId::CogCycles, 8.0).unwrap();
    // On every sample: the speed's misfit four times the truth's from the ridge.
    let found = widened_past_a_stall(
        &records,
        (&spec, &alone),
        (&truth, &start),
        (false, 1),
        |c| c.rmse_omega,
        4.0,
    );
    let amp = found.params.get(ParamId::CogAmp);
    assert!((amp - 0.1).abs() < 0.01, "cogging amplitude {amp}");
}

#[test]
fn a_widened_search_on_decimated_records_finds_a_limit_least_squares_cannot_see() {
    // A drive's current limit of 10 A started at 30 A, above every current of the record
    // (24 A at the steps): the limit never binds there, its gradient is zero and least
    // squares stays.
    let truth = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08).with(ParamId::Imax, 10.0);
    let records = [record(&truth, 24, 11)];
    let start = truth.with(ParamId::Imax, 30.0);
    let (spec, alone) = problem_of(&[(ParamId::Imax, 0.5, 40.0)], &start);
    // 24,000 samples searched as 8,000.
    let found = widened_past_a_stall(
        &records,
        (&spec, &alone),
        (&truth, &start),
        (true, 3),
        Cost::fitness,
        2.0,
    );
    let imax = found.params.get(ParamId::Imax);
    assert!((imax - 10.0).abs() < 0.1, "imax {imax}");
}
