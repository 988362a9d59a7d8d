//! Parameters that drift along a record: when the remainder is unexplained, the final model
//! refitted window by window over each long record, to say which motor parameter changes
//! from the record's start to its end and by how much.
//!
//! A model whose parameters are constants cannot follow a motor whose parameters are not:
//! the winding's resistance rises with its temperature (copper: +0.393 %/K, so a winding that
//! warms by 45 K over a long duty cycle has an Ra 18 % higher at the end), magnets weaken as
//! they warm (Kv), a bearing's grease thins (B). The misfit of such a record grows along it,
//! which the regimes of [`super::regimes`] do not see (they cut by operating point, not by
//! time). Each record of at least [`WINDOWS`] × [`MIN_WINDOW_SAMPLES`] driven samples is cut
//! into [`WINDOWS`] equal windows; in each, the motor parameters the final model fitted are
//! refitted by least squares from its values (its effects held), each window's own initial
//! speed projected out. A parameter drifts when its first and last windows' estimates differ
//! by more than [`DRIFT_SIGMAS`] of their combined standard deviation and by more than
//! [`DRIFT_SHARE`] of its value: then the remainder says so, in numbers, instead of only
//! where the misfit lies.
//!
//! A model that misses an effect fits different parameters where the record visits
//! different operating points (a stair of speeds: the first window slow, the last fast), which
//! is not a drift in time. So the first and the last window are compared only when they
//! visit the same operating points: the deciles of their voltage and of their speed agree
//! within [`SAME_REGIME`] of the record's range (a duty cycle repeated along the record);
//! otherwise the record is left out.

use super::data::Data;
use crate::csvio::OwnedRecord;
use crate::fit::{refit_from, Fit, FitOptions};
use crate::report::Num;
use anyhow::Result;
use motor_id_shared::{ModelParams, ParamId};
use serde::Serialize;

/// Windows a record is cut into.
pub const WINDOWS: usize = 4;

/// Fewest driven samples in a window (a record shorter than four such windows is not cut).
pub const MIN_WINDOW_SAMPLES: usize = 500;

/// Least distance, in combined standard deviations, between the first and the last window's
/// estimates of a parameter that drifts (far beyond the 3 of a two-sided test at 0.3 %: the
/// windows' deviations are local ones).
pub const DRIFT_SIGMAS: f32 = 4.0;

/// Least relative change of a parameter that drifts (a smaller one changes no verdict).
pub const DRIFT_SHARE: f32 = 0.02;

/// Largest difference between a decile of the first and of the last window (voltage and
/// speed), a share of the record's range, for the two to visit the same operating points.
pub const SAME_REGIME: f32 = 0.1;

/// The nine deciles of `x`.
fn deciles(x: &[f32]) -> [f32; 9] {
    let mut sorted = x.to_vec();
    sorted.sort_by(f32::total_cmp);
    let n = sorted.len();
    core::array::from_fn(|k| sorted[((k + 1) * n / 10).min(n - 1)])
}

/// Whether windows `a` and `b` of a record whose voltage and speed span `ranges` visit the
/// same operating points (see the module doc).
fn same_regime(a: &OwnedRecord, b: &OwnedRecord, ranges: (f32, f32)) -> bool {
    let close = |x: &[f32], y: &[f32], range: f32| {
        let (dx, dy) = (deciles(x), deciles(y));
        range > 0.0
            && dx
                .iter()
                .zip(&dy)
                .all(|(p, q)| (p - q).abs() <= SAME_REGIME * range)
    };
    close(&a.v, &b.v, ranges.0) && close(&a.omega, &b.omega, ranges.1)
}

/// The span of `x` (largest less smallest).
fn span(x: &[f32]) -> f32 {
    let (lo, hi) = x
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
    hi - lo
}

/// A parameter that changes along one record.
#[derive(Serialize, Debug, Clone)]
pub struct Drift {
    /// The record's file name.
    pub file: String,
    /// The parameter's name.
    pub param: &'static str,
    /// Length of a window [s].
    pub window_s: Num,
    /// The parameter's estimate in each window, first to last.
    pub per_window: Vec<Num>,
    /// Change from the first to the last window, a share of the first.
    pub change: Num,
    /// That change over the combined standard deviation of the two estimates.
    pub sigmas: Num,
}

impl Drift {
    /// The drift in words, e.g. "ra +18.2 % from the first to the last 10.0 s of cycle.csv".
    pub fn sentence(&self) -> String {
        format!(
            "{} {:+.1} % from the first to the last {:.1} s of {} ({:.0} standard deviations; by window: {})",
            self.param,
            100.0 * self.change.0,
            self.window_s.0,
            self.file,
            self.sigmas.0,
            self.per_window
                .iter()
                .map(|v| format!("{:.4}", v.0))
                .collect::<Vec<_>>()
                .join(", ")
        )
    }
}

/// The driven part of record `r` (before a coast-down) cut into `WINDOWS` equal windows,
/// each a record of its own; `None` when it is too short.
fn windows(r: &OwnedRecord) -> Option<Vec<OwnedRecord>> {
    let driven = r.coast_from.unwrap_or(r.len()).min(r.len());
    let len = driven / WINDOWS;
    if len < MIN_WINDOW_SAMPLES {
        return None;
    }
    let cut = |k: usize| {
        let span = k * len..(k + 1) * len;
        OwnedRecord {
            path: r.path.clone(),
            t0: r.t0 + (span.start as f64) * f64::from(r.dt),
            dt: r.dt,
            v: r.v[span.clone()].to_vec(),
            omega: r.omega[span.clone()].to_vec(),
            current: r.current.as_ref().map(|c| c[span.clone()].to_vec()),
            load: r.load.as_ref().map(|l| l[span.clone()].to_vec()),
            coast_from: None,
            averaged: 1,
        }
    };
    Some((0..WINDOWS).map(cut).collect())
}

/// The estimate and standard deviation of `id` in `fit` (`None` when not pinned).
fn estimate(fit: &Fit, id: ParamId) -> Option<(f32, f32)> {
    let c = fit
        .result
        .identifiability
        .params
        .iter()
        .find(|c| c.id == id)?;
    Some((c.value, c.std.filter(|_| c.pinned)?))
}

/// The parameters of `final_fit` that drift along the records of `data` (training and
/// held-out), the largest drift first; empty when none does or no record is long enough.
pub fn drifts(data: &Data, final_fit: &Fit, opts: &FitOptions) -> Result<Vec<Drift>> {
    let quiet = FitOptions {
        quiet: true,
        speed_only: !data.with_current,
        ..opts.clone()
    };
    // The motor parameters the final model fitted, free; its effects held at its values.
    let p: ModelParams = final_fit.result.params;
    let mut spec = final_fit.spec;
    spec.base = p;
    for id in ParamId::ALL {
        if !ParamId::MOTOR.contains(&id) {
            spec.free[id.index()] = false;
        }
    }
    let motor: Vec<ParamId> = ParamId::MOTOR
        .into_iter()
        .filter(|id| spec.free[id.index()])
        .collect();
    let mut found = Vec::new();
    for r in data.train.iter().chain(&data.holdout) {
        let Some(parts) = windows(r) else {
            continue;
        };
        if !same_regime(&parts[0], &parts[WINDOWS - 1], (span(&r.v), span(&r.omega))) {
            continue;
        }
        let fits = parts
            .iter()
            .map(|w| refit_from(std::slice::from_ref(w), &quiet, &spec, &p))
            .collect::<Result<Vec<Fit>>>()?;
        for &id in &motor {
            let (Some((first, s0)), Some((last, s1))) =
                (estimate(&fits[0], id), estimate(&fits[WINDOWS - 1], id))
            else {
                continue;
            };
            let change = (last - first) / first;
            let sigmas = (last - first).abs() / s0.hypot(s1);
            if sigmas > DRIFT_SIGMAS && change.abs() > DRIFT_SHARE {
                found.push(Drift {
                    file: r.name(),
                    param: id.name(),
                    window_s: Num(parts[0].len() as f32 * r.dt),
                    per_window: fits.iter().map(|f| Num(f.result.params.get(id))).collect(),
                    change: Num(change),
                    sigmas: Num(sigmas),
                });
            }
        }
    }
    found.sort_by(|a, b| b.change.0.abs().total_cmp(&a.change.0.abs()));
    Ok(found)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::diagnose::data::record;
    use crate::fit::fit_spec_unwidened;
    use crate::fit::tests::{noise, square_wave};
    use motor_id_shared::model::sim::{InitialState, Simulator};

    /// A 40 s record at 1 kHz of a motor whose Ra rises linearly by `rise` (a share) from
    /// start to end, driven by a square wave of 24 V and 6 V with a 2 s period: simulated
    /// piecewise, Ra raised every 0.1 s, the state carried over.
    fn warming_record(rise: f32) -> OwnedRecord {
        let (dt, n, piece) = (1e-3f32, 40_000usize, 100usize);
        let base = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08);
        let v = square_wave(n);
        let (mut omega, mut current) = (Vec::with_capacity(n), Vec::with_capacity(n));
        let mut state = InitialState::REST;
        for start in (0..n).step_by(piece) {
            let ra = 1.0 + rise * start as f32 / n as f32;
            let p = base.with(ParamId::Ra, ra);
            let mut sim = Simulator::new(&p, dt, state).unwrap();
            for &volts in &v[start..start + piece] {
                let y = sim.reading();
                omega.push(y.omega);
                current.push(y.current);
                sim.advance(volts, 0.0);
            }
            let y = sim.reading();
            state = InitialState {
                omega: y.omega,
                current: y.current,
            };
        }
        // A little deterministic noise, so that the fits have a noise to measure.
        let mut noise = noise(7);
        omega.iter_mut().for_each(|w| *w += noise(0.05));
        current.iter_mut().for_each(|i| *i += noise(0.01));
        OwnedRecord::readings("warming.csv", dt, v, omega, Some(current))
    }

    fn drifts_of(rise: f32) -> Vec<Drift> {
        let r = warming_record(rise);
        let opts = FitOptions {
            quiet: true,
            ..FitOptions::default()
        };
        let data = Data {
            train: vec![r],
            holdout: Vec::new(),
            with_current: true,
        };
        let spec = motor_id_shared::fit::space::ProblemSpec::default();
        let fit = fit_spec_unwidened(&data.train, &opts, &spec).unwrap();
        drifts(&data, &fit, &opts).unwrap()
    }

    #[test]
    fn windows_at_other_operating_points_are_not_compared() {
        // A stair of voltages: the first quarter at 6 V, the last at 24 V.
        let stair: Vec<f32> = (0..4000).map(|k| 6.0 * (1 + k / 1000) as f32).collect();
        let omega = stair.iter().map(|v| 10.0 * v).collect();
        let r = record("stair.csv", stair, omega);
        let w = windows(&r).unwrap();
        assert!(!same_regime(&w[0], &w[3], (span(&r.v), span(&r.omega))));
        // A square wave repeated along the record: the same.
        let cycle = warming_record(0.0);
        let w = windows(&cycle).unwrap();
        assert!(same_regime(
            &w[0],
            &w[3],
            (span(&cycle.v), span(&cycle.omega))
        ));
    }

    #[test]
    fn a_resistance_that_rises_along_the_record_is_found_and_a_steady_one_is_not() {
        let found = drifts_of(0.2);
        let ra = found.iter().find(|d| d.param == "ra").expect("ra drifts");
        // Windows centred at 5, 15, 25, 35 s of 40: Ra 1.025 to 1.175, +14.6 %.
        assert!((ra.change.0 - 0.146).abs() < 0.02, "{ra:?}");
        assert!(ra.sentence().contains("ra +14."), "{}", ra.sentence());
        // Nothing else moves.
        assert!(found.iter().all(|d| d.param == "ra"), "{found:?}");
        assert!(drifts_of(0.0).is_empty());
    }
}
