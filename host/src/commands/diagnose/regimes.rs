//! Where the baseline misfits: the residual's share by operating regime
//! ([`super::regime_shares`]) and record, its correlation with the signatures of the
//! catalogued effects, and the peak of its order spectrum ([`super::spectrum`]).

use super::data::Trace;
use super::regime_shares::{round, shares, RegimeSamples, RegimeShare};
use super::spectrum::{order_peak, OrderPeak};
use motor_id_shared::model::effects::{Effect, Signature};
use serde::Serialize;

/// Pearson correlation.
fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    if n < 2.0 {
        return 0.0;
    }
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    if saa <= 0.0 || sbb <= 0.0 {
        0.0
    } else {
        sab / (saa * sbb).sqrt()
    }
}

/// The `where` report: how the baseline's misfit spreads over regimes and records, and what
/// it resembles.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct WhereReport {
    /// Baseline speed RMSE over all records [rad/s].
    pub rmse: f64,
    /// Measured speed noise of the training records [rad/s].
    pub noise: f64,
    /// Regimes, the most over-represented in the misfit first.
    pub regimes: Vec<RegimeShare>,
    /// Each record's share.
    pub records: Vec<RecordShare>,
    /// Effects' signatures, the best correlated first.
    pub signatures: Vec<SignatureMatch>,
    /// The residual's strongest ripple against rotor angle.
    pub spectrum: Spectrum,
    /// The findings in words.
    pub summary: Vec<String>,
}

/// One record's share of the misfit.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct RecordShare {
    /// File name.
    pub file: String,
    /// "train" or "holdout".
    pub set: &'static str,
    /// Share of the squared residual.
    pub share_of_misfit: f64,
    /// RMSE of the record [rad/s].
    pub rmse: f64,
}

/// How well the residual follows an effect's signature.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct SignatureMatch {
    /// The signature.
    pub signature: &'static str,
    /// The effect it belongs to.
    pub points_to: &'static str,
    /// Pearson correlation with the residual.
    pub correlation: f64,
}

/// The order spectrum's peak.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct Spectrum {
    /// Cycles per revolution.
    pub order_cycles_per_rev: u32,
    /// Share of the residual's energy it explains.
    pub share_of_residual: f64,
    /// The effect a ripple points to.
    pub points_to: &'static str,
}

/// Where the baseline misfits `traces`, with `noise` the measured speed noise.
pub fn analyse(traces: &[Trace], noise: f32) -> WhereReport {
    let samples = RegimeSamples::of(traces);
    let (regimes, lines) = shares(
        traces,
        &samples,
        |t| Some(&t.residual[..]),
        "the misfit",
        "rad/s",
    );
    // Signatures: what the residual looks like when the model lacks an effect, from the
    // effect's catalogue entry.
    let names: Vec<(&'static str, Signature)> = Effect::ALL
        .iter()
        .filter_map(|e| e.spec().signature.map(|s| (e.name(), s)))
        .collect();
    let mut sig: Vec<Vec<f64>> = vec![Vec::new(); names.len()];
    let mut res_all = Vec::new();
    let mut records = Vec::new();
    let mut total = 0.0f64;
    for (t, at) in traces.iter().zip(&samples.per_trace) {
        let mut sse = 0.0f64;
        for (r, s) in t.residual.iter().zip(at) {
            let r = *r as f64;
            sse += r * r;
            for (series, (_, signature)) in sig.iter_mut().zip(&names) {
                series.push((signature.at)(s));
            }
            res_all.push(r);
        }
        total += sse;
        records.push((t.name.clone(), t.set, sse, t.residual.len()));
    }
    let n = res_all.len().max(1) as f64;
    let total = total.max(f64::MIN_POSITIVE);
    let per_record: Vec<RecordShare> = records
        .into_iter()
        .map(|(file, set, sse, len)| RecordShare {
            file,
            set,
            share_of_misfit: round(sse / total),
            rmse: round((sse / len.max(1) as f64).sqrt()),
        })
        .collect();
    // Ranked by correlation with its sign: a signature points at its effect only when the
    // residual follows it (a negative correlation is the opposite of that effect).
    let mut signatures: Vec<(f64, SignatureMatch)> = names
        .iter()
        .zip(&sig)
        .map(|(&(points_to, signature), s)| {
            let c = correlation(&res_all, s);
            let m = SignatureMatch {
                signature: signature.label,
                points_to,
                correlation: round(c),
            };
            (c, m)
        })
        .collect();
    signatures.sort_by(|a, b| b.0.total_cmp(&a.0));
    let OrderPeak { order, share, .. } = order_peak(traces);
    let mut summary = lines;
    let rmse = (total / n).sqrt();
    if rmse <= 1.05 * noise as f64 {
        summary.insert(0, format!("the baseline fits to the noise ({rmse:.3} vs {noise:.3} rad/s): no misfit to locate"));
    }
    if let Some((c, m)) = signatures.first() {
        if *c > 0.3 {
            summary.push(format!(
                "the residual follows {} (correlation {:.2}), the signature of {}",
                m.signature, m.correlation, m.points_to
            ));
        }
    }
    if share > 0.2 {
        summary.push(format!(
            "{:.0} % of the residual is a ripple at {order} cycles per revolution: it scales with speed (tacho)",
            100.0 * share
        ));
    }
    WhereReport {
        rmse: round(rmse),
        noise: round(noise as f64),
        regimes,
        records: per_record,
        signatures: signatures.into_iter().map(|(_, m)| m).collect(),
        spectrum: Spectrum {
            order_cycles_per_rev: order,
            share_of_residual: round(share),
            points_to: Effect::TachoRipple.name(),
        },
        summary,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A forward and a reverse run at constant speed, with the residual `misfit` in the
    /// reverse half only (after the reversal's sample).
    fn reversal(misfit: f32) -> Trace {
        let n = 400;
        let omega: Vec<f32> = (0..n)
            .map(|k| if k < n / 2 { 100.0 } else { -100.0 })
            .collect();
        let residual = (0..n)
            .map(|k| {
                if k <= n / 2 {
                    0.0
                } else {
                    misfit * if k % 2 == 0 { 1.0 } else { -1.0 }
                }
            })
            .collect();
        Trace {
            name: "r.csv".into(),
            set: "train",
            dt: 0.01,
            residual,
            current: omega.iter().map(|w| w * 0.01).collect(),
            current_residual: None,
            omega,
        }
    }

    #[test]
    fn the_misfit_is_found_where_it_lies() {
        let report = analyse(&[reversal(0.5)], 0.01);
        let first = &report.regimes[0];
        assert!(
            ["reverse", "i < 0"].contains(&first.short),
            "{:?}",
            report.regimes
        );
        assert_eq!(first.share_of_misfit, 1.0);
        let ratio = |r: &RegimeShare| r.share_of_misfit / r.share_of_samples;
        assert!(report
            .regimes
            .windows(2)
            .all(|w| ratio(&w[0]) >= ratio(&w[1])));
        assert!(report.summary[0].starts_with("100 % of the misfit lies in "));
        assert_eq!(
            report.records[0].rmse,
            round((0.25f64 * 199.0 / 400.0).sqrt())
        );
        // Fitted to the noise: said first.
        let quiet = analyse(&[reversal(0.01)], 0.01);
        assert!(quiet.summary[0].starts_with("the baseline fits to the noise"));
    }
}
