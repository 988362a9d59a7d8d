//! What the named effects leave: whether the held-out misfit of the final model is still
//! significantly above what no model can remove, how large the rest is, and where it lies —
//! never a catalogue name forced onto it.
//!
//! The floor is the measured noise, or, when repeat runs are given, the larger run-to-run
//! spread ([`super::repeatability`]): a model can at best predict the mean response, so a
//! held-out RMSE at the floor is all a model can do. The remainder is *unexplained* when the
//! held-out RMSE exceeds the floor by more than [`UNEXPLAINED_RATIO`]; its size is the part
//! above the floor in quadrature, `sqrt(rmse^2 - floor^2)` (independent errors add in
//! variance).

use super::data::{Data, Trace};
use super::drift::{self, Drift};
use super::regime_shares::{self, RegimeShare};
use super::regimes::{self, RecordShare};
use crate::fit::{Fit, FitOptions};
use crate::report::Num;
use anyhow::Result;
use serde::Serialize;

/// Held-out RMSE over the floor above which the remainder is unexplained: a misfit 20 %
/// above the floor is 44 % more variance than no model can remove, well beyond the spread of
/// a noise estimate over thousands of samples.
pub const UNEXPLAINED_RATIO: f32 = 1.2;

/// What the named effects leave.
#[derive(Serialize, Debug, Clone)]
pub struct Remainder {
    /// The held-out RMSE above the floor, in quadrature [rad/s].
    pub rmse: Num,
    /// The held-out RMSE over the floor.
    pub over_floor: Num,
    /// The held-out RMSE over the measured noise.
    pub over_noise: Num,
    /// What the floor is: `noise` or `repeatability`.
    pub floor: &'static str,
    /// The floor [rad/s].
    pub floor_rmse: Num,
    /// Regimes of the held-out records where the final model's residual concentrates, the
    /// most over-represented first.
    pub regimes: Vec<RegimeShare>,
    /// The same for the residual of the measured current (empty without one): an effect
    /// that acts through the current shows there where it acts (a current limit at
    /// start-ups and reversals), where the speed's misfit follows later.
    pub current_regimes: Vec<RegimeShare>,
    /// Each held-out record's share of it.
    pub records: Vec<RecordShare>,
    /// The stretch of one held-out record with the largest share of it.
    pub span: Span,
    /// Motor parameters that change along a record (window by window refits,
    /// [`super::drift`]), the largest change first.
    pub drift: Vec<Drift>,
    /// The findings in words.
    pub summary: Vec<String>,
}

/// A stretch of one record.
#[derive(Serialize, Debug, Clone)]
pub struct Span {
    /// File name.
    pub file: String,
    /// Start [s from the record's start].
    pub from_s: Num,
    /// End [s].
    pub to_s: Num,
    /// Its share of the squared residual of all held-out records.
    pub share_of_misfit: Num,
}

/// The floor and its kind: the noise, or the repeatability floor when that is larger.
pub fn floor(noise: f32, repeatability: Option<f32>) -> (f32, &'static str) {
    match repeatability {
        Some(r) if r > noise => (r, "repeatability"),
        _ => (noise, "noise"),
    }
}

/// Whether a held-out RMSE `rmse` is significantly above `floor`.
pub fn unexplained(rmse: f32, floor: f32) -> bool {
    rmse > UNEXPLAINED_RATIO * floor
}

/// The remainder of the final model (`final_fit`, fitted with `opts`) on the held-out
/// records of `data` (its residuals there, `traces`), whose held-out RMSE is `rmse`, against `noise` and the repeatability
/// floor; `None` when it is not significantly above the floor.
#[allow(clippy::too_many_arguments)]
pub fn remainder(
    data: &Data,
    traces: &[Trace],
    final_fit: &Fit,
    opts: &FitOptions,
    rmse: f32,
    noise: f32,
    repeatability: Option<f32>,
) -> Result<Option<Remainder>> {
    let (floor_rmse, floor_kind) = floor(noise, repeatability);
    if !unexplained(rmse, floor_rmse) {
        return Ok(None);
    }
    let found = regimes::analyse(traces, noise);
    let span = worst_span(traces);
    let excess = (rmse * rmse - floor_rmse * floor_rmse).max(0.0).sqrt();
    let mut summary = vec![format!(
        "{excess:.3} rad/s of the held-out misfit ({rmse:.3} rad/s) lies above the {floor_kind} \
         floor ({floor_rmse:.3} rad/s) and is not explained by the catalogue"
    )];
    // Where it lies; the signatures are left out: the catalogue's names are what did not
    // explain it.
    summary.extend(
        found
            .summary
            .iter()
            .filter(|line| line.contains("of the misfit lies in"))
            .cloned(),
    );
    let (current_regimes, current_lines) = regime_shares::current_where(traces).unwrap_or_default();
    summary.extend(current_lines);
    summary.push(format!(
        "its largest share ({:.0} %) lies in {} from {:.3} s to {:.3} s",
        100.0 * span.share_of_misfit.0,
        span.file,
        span.from_s.0,
        span.to_s.0
    ));
    // Whether a parameter changes along a record: a misfit that grows along it.
    let drift = drift::drifts(data, final_fit, opts)?;
    summary.extend(
        drift
            .iter()
            .map(|d| format!("a parameter drifts along a record: {}", d.sentence())),
    );
    Ok(Some(Remainder {
        rmse: Num(excess),
        over_floor: Num(rmse / floor_rmse),
        over_noise: Num(rmse / noise),
        floor: floor_kind,
        floor_rmse: Num(floor_rmse),
        regimes: found.regimes,
        current_regimes,
        records: found.records,
        span,
        drift,
        summary,
    }))
}

/// The window of a tenth of a record (at least 20 samples) with the largest squared
/// residual over all `traces`.
fn worst_span(traces: &[Trace]) -> Span {
    let total: f64 = traces
        .iter()
        .flat_map(|t| t.residual.iter())
        .map(|r| (*r as f64) * (*r as f64))
        .sum::<f64>()
        .max(f64::MIN_POSITIVE);
    let mut best = (0.0f64, 0usize, 0usize, 0usize);
    for (k, t) in traces.iter().enumerate() {
        let n = t.residual.len();
        let w = (n / 10).max(20).min(n);
        let sq: Vec<f64> = t
            .residual
            .iter()
            .map(|r| (*r as f64) * (*r as f64))
            .collect();
        let mut sum: f64 = sq[..w].iter().sum();
        for start in 0..=n - w {
            if start > 0 {
                sum += sq[start + w - 1] - sq[start - 1];
            }
            if sum > best.0 {
                best = (sum, k, start, start + w);
            }
        }
    }
    let (sse, k, from, to) = best;
    let t = traces.get(k);
    Span {
        file: t.map_or(String::new(), |t| t.name.clone()),
        from_s: Num(from as f32 * t.map_or(0.0, |t| t.dt)),
        to_s: Num(to as f32 * t.map_or(0.0, |t| t.dt)),
        share_of_misfit: Num((sse / total) as f32),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn trace(name: &str, residual: Vec<f32>) -> Trace {
        let n = residual.len();
        Trace {
            name: name.into(),
            set: "holdout",
            dt: 0.01,
            residual,
            omega: vec![1.0; n],
            current: vec![0.0; n],
            current_residual: None,
        }
    }

    #[test]
    fn the_floor_is_the_larger_of_noise_and_repeatability() {
        assert_eq!(floor(1.3, None), (1.3, "noise"));
        assert_eq!(floor(1.3, Some(3.8)), (3.8, "repeatability"));
        assert_eq!(floor(1.3, Some(0.9)), (1.3, "noise"));
        assert!(!unexplained(1.19, 1.0));
        assert!(unexplained(1.21, 1.0));
    }

    #[test]
    fn the_worst_span_is_where_the_residual_is() {
        // 1,000 samples of small residual with a burst at samples 600..700 of the second.
        let quiet = trace("a.csv", vec![0.1; 1000]);
        let burst = trace(
            "b.csv",
            (0..1000)
                .map(|k| if (600..700).contains(&k) { 3.0 } else { 0.1 })
                .collect(),
        );
        let s = worst_span(&[quiet, burst]);
        assert_eq!(s.file, "b.csv");
        assert!(
            (s.from_s.0 - 6.0).abs() < 1e-4 && (s.to_s.0 - 7.0).abs() < 1e-4,
            "{s:?}"
        );
        // 100 x 9 against 1,900 x 0.01.
        let want = 900.0 / (900.0 + 19.0);
        assert!((s.share_of_misfit.0 - want).abs() < 1e-3, "{s:?}");
    }
}
