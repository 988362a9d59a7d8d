//! Where the baseline misfits: the residual's share by operating regime and record, its
//! correlation with the signatures of the catalogued effects, and the peak of its order
//! spectrum ([`super::spectrum`]).

use super::data::{peak, Trace};
use super::spectrum::{order_peak, OrderPeak};
use motor_id_shared::model::effects::{Effect, Signature, SignatureSample};
use serde::Serialize;

/// A class of samples.
struct Regime {
    name: &'static str,
    short: &'static str,
    member: fn(&Sample) -> bool,
}

/// What is known about one sample.
struct Sample {
    omega: f32,
    accel: f32,
    current: f32,
    omega_max: f32,
    accel_max: f32,
    current_max: f32,
}

const REGIMES: [Regime; 12] = [
    Regime {
        name: "transients (start-up and speed changes)",
        short: "transient",
        member: |s| s.accel.abs() > 0.1 * s.accel_max,
    },
    Regime {
        name: "start-up (gaining speed below 30 % of max)",
        short: "start-up",
        member: |s| {
            s.omega.abs() < 0.3 * s.omega_max && s.accel * s.omega.signum() > 0.1 * s.accel_max
        },
    },
    Regime {
        name: "steady state",
        short: "steady",
        member: |s| s.accel.abs() <= 0.1 * s.accel_max,
    },
    Regime {
        name: "acceleration",
        short: "accel.",
        member: |s| s.accel * s.omega.signum() > 0.1 * s.accel_max,
    },
    Regime {
        name: "deceleration",
        short: "decel.",
        member: |s| s.accel * s.omega.signum() < -0.1 * s.accel_max,
    },
    Regime {
        name: "low speed (< 30 % of max)",
        short: "low speed",
        member: |s| s.omega.abs() < 0.3 * s.omega_max,
    },
    Regime {
        name: "high speed (>= 30 % of max)",
        short: "high speed",
        member: |s| s.omega.abs() >= 0.3 * s.omega_max,
    },
    Regime {
        name: "forward rotation",
        short: "forward",
        member: |s| s.omega > 0.05 * s.omega_max,
    },
    Regime {
        name: "reverse rotation",
        short: "reverse",
        member: |s| s.omega < -0.05 * s.omega_max,
    },
    Regime {
        name: "near standstill",
        short: "standstill",
        member: |s| s.omega.abs() <= 0.05 * s.omega_max,
    },
    Regime {
        name: "positive current",
        short: "i > 0",
        member: |s| s.current > 0.05 * s.current_max,
    },
    Regime {
        name: "negative current",
        short: "i < 0",
        member: |s| s.current < -0.05 * s.current_max,
    },
];

/// Central-difference derivative.
fn derivative(x: &[f32], dt: f32) -> Vec<f32> {
    let n = x.len();
    (0..n)
        .map(|k| {
            let (a, b) = (k.saturating_sub(1), (k + 1).min(n - 1));
            if b > a {
                (x[b] - x[a]) / ((b - a) as f32 * dt)
            } else {
                0.0
            }
        })
        .collect()
}

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

/// One regime's share of the misfit.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct RegimeShare {
    /// Name.
    pub name: &'static str,
    /// Short name (plot label).
    pub short: &'static str,
    /// Share of the squared residual.
    pub share_of_misfit: f64,
    /// Share of the samples.
    pub share_of_samples: f64,
    /// RMSE within it [rad/s].
    pub rmse: f64,
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

/// The regime of every sample of `traces`, with the maxima over them (the classes'
/// thresholds are shares of these).
struct Samples {
    per_trace: Vec<Vec<Sample>>,
}

impl Samples {
    fn of(traces: &[Trace]) -> Samples {
        let omega_max = traces.iter().map(|t| peak(&t.omega)).fold(0.0, f32::max);
        let current_max = traces.iter().map(|t| peak(&t.current)).fold(0.0, f32::max);
        let accels: Vec<Vec<f32>> = traces.iter().map(|t| derivative(&t.omega, t.dt)).collect();
        let accel_max = accels.iter().map(|a| peak(a)).fold(0.0, f32::max);
        let per_trace = traces
            .iter()
            .zip(&accels)
            .map(|(t, acc)| {
                (0..t.omega.len())
                    .map(|k| Sample {
                        omega: t.omega[k],
                        accel: acc[k],
                        current: t.current[k],
                        omega_max,
                        accel_max,
                        current_max,
                    })
                    .collect()
            })
            .collect();
        Samples { per_trace }
    }
}

/// Each regime's share of the squared `residual` of every trace (the speed's, or the
/// current's), the most over-represented first, and the three most over-represented (at
/// least 1.3 times their share of the samples) in words, `what` naming the misfit and
/// `unit` its unit.
fn shares<'t>(
    traces: &'t [Trace],
    samples: &Samples,
    residual: impl Fn(&'t Trace) -> Option<&'t [f32]>,
    what: &str,
    unit: &str,
) -> (Vec<RegimeShare>, Vec<String>) {
    let mut total = 0.0f64;
    let mut n = 0usize;
    let mut regime_sse = [0.0f64; REGIMES.len()];
    let mut regime_n = [0usize; REGIMES.len()];
    for (t, at) in traces.iter().zip(&samples.per_trace) {
        let Some(r) = residual(t) else { continue };
        for (r, s) in r.iter().zip(at) {
            let r2 = (*r as f64) * (*r as f64);
            total += r2;
            n += 1;
            for (i, reg) in REGIMES.iter().enumerate() {
                if (reg.member)(s) {
                    regime_sse[i] += r2;
                    regime_n[i] += 1;
                }
            }
        }
    }
    let total = total.max(f64::MIN_POSITIVE);
    let n = n.max(1) as f64;
    let mut regimes: Vec<RegimeShare> = Vec::new();
    let mut ranked: Vec<(f64, String)> = Vec::new();
    for (i, reg) in REGIMES.iter().enumerate() {
        if regime_n[i] == 0 {
            continue;
        }
        let share = regime_sse[i] / total;
        let sample_share = regime_n[i] as f64 / n;
        let rmse = (regime_sse[i] / regime_n[i] as f64).sqrt();
        regimes.push(RegimeShare {
            name: reg.name,
            short: reg.short,
            share_of_misfit: round(share),
            share_of_samples: round(sample_share),
            rmse: round(rmse),
        });
        ranked.push((
            share / sample_share,
            format!(
                "{:.0} % of {what} lies in {} ({:.0} % of the samples, rmse {:.3} {unit})",
                100.0 * share,
                reg.name,
                100.0 * sample_share,
                rmse
            ),
        ));
    }
    regimes.sort_by(|a, b| {
        let c = |r: &RegimeShare| r.share_of_misfit / r.share_of_samples;
        c(b).total_cmp(&c(a))
    });
    ranked.sort_by(|a, b| b.0.total_cmp(&a.0));
    let lines = ranked
        .into_iter()
        .filter(|(ratio, _)| *ratio > 1.3)
        .take(3)
        .map(|(_, s)| s)
        .collect();
    (regimes, lines)
}

/// Where the current's misfit lies on `traces` that hold a measured current's residual
/// ([`Trace::current_residual`]): each regime's share, the most over-represented first, and
/// the findings in words; `None` when no trace holds one. The current shows where an effect
/// acts through it (a current limit flattens the current at start-ups and reversals, where
/// the speed's misfit follows only later, at speed).
pub fn current_where(traces: &[Trace]) -> Option<(Vec<RegimeShare>, Vec<String>)> {
    traces
        .iter()
        .any(|t| t.current_residual.is_some())
        .then(|| {
            shares(
                traces,
                &Samples::of(traces),
                |t| t.current_residual.as_deref(),
                "the current's misfit",
                "A",
            )
        })
}

/// Where the baseline misfits `traces`, with `noise` the measured speed noise.
pub fn analyse(traces: &[Trace], noise: f32) -> WhereReport {
    let omega_max = traces.iter().map(|t| peak(&t.omega)).fold(0.0, f32::max);
    let current_max = traces.iter().map(|t| peak(&t.current)).fold(0.0, f32::max);
    let samples = Samples::of(traces);
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
            let at = SignatureSample {
                omega: s.omega as f64,
                accel: s.accel as f64,
                current: s.current as f64,
                omega_max: omega_max as f64,
                current_max: current_max as f64,
            };
            for (series, (_, signature)) in sig.iter_mut().zip(&names) {
                series.push((signature.at)(&at));
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

fn round(x: f64) -> f64 {
    if x.is_finite() {
        (x * 1e6).round() / 1e6
    } else {
        0.0
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

    /// A start from rest to 100 rad/s, a hold, a stop and a rest, the current's residual
    /// in the first 25 samples (a flat-topped current at the start).
    fn start_and_stop() -> Trace {
        let omega: Vec<f32> = (0..500)
            .map(|k| match k {
                0..100 => k as f32,
                100..300 => 100.0,
                300..400 => (400 - k) as f32,
                _ => 0.0,
            })
            .collect();
        let current = (0..500)
            .map(|k| match k {
                0..100 => 1.0,
                100..300 => 0.1,
                _ => 0.0,
            })
            .collect();
        Trace {
            name: "s.csv".into(),
            set: "holdout",
            dt: 0.01,
            residual: vec![0.0; 500],
            current,
            current_residual: Some((0..500).map(|k| if k < 25 { -0.3 } else { 0.0 }).collect()),
            omega,
        }
    }

    #[test]
    fn the_current_s_misfit_at_a_start_is_found_at_the_start() {
        let (regimes, lines) = current_where(&[start_and_stop()]).expect("a current residual");
        assert_eq!(regimes[0].short, "start-up", "{regimes:?}");
        assert_eq!(regimes[0].share_of_misfit, 1.0);
        assert!(
            lines[0].starts_with("100 % of the current's misfit lies in start-up")
                && lines[0].ends_with(" A)"),
            "{lines:?}"
        );
        let mut speed_only = start_and_stop();
        speed_only.current_residual = None;
        assert!(current_where(&[speed_only]).is_none());
    }
}
