//! Coverage: the operating regimes the held-out records visit and the training records never
//! do. An effect that acts only there (a friction that switches with the direction, a brush
//! drop that reverses with the current, a load) leaves no trace in the training records, so
//! no fit on them can learn it, however good the catalogue.
//!
//! The regimes are defined on the measured signals only (voltage, speed, known load), with
//! thresholds relative to the largest magnitudes over all records, so that training and
//! held-out samples are classified alike and no fitted model is involved ([`REGIMES`]).

use super::data::peak;
use crate::csvio::OwnedRecord;
use serde::Serialize;

/// A sign is "on" beyond this share of the signal's scale (voltage applied, motor turning).
const BAND: f32 = 0.05;
/// At rest: |speed| at most this share of the speed scale.
const REST: f32 = 0.02;
/// A reversal's window: |speed| below this share of the speed scale while passing between
/// excursions beyond it in opposite directions.
const REVERSAL_WINDOW: f32 = 0.2;
/// Speeds or voltages above the training's largest by this share are beyond its range.
const MARGIN: f32 = 0.1;
/// A record visits a regime when at least this many of its samples lie there ...
const MIN_SAMPLES: usize = 20;
/// ... and at least this share of them (isolated noisy samples are no visit).
const MIN_SHARE: f64 = 1e-3;

/// The scales the thresholds are relative to.
struct Scales {
    /// Largest |voltage| over all records [V].
    v: f32,
    /// Largest |speed| over all records [rad/s].
    omega: f32,
    /// Largest |load torque| over all records [N m].
    load: f32,
    /// Largest |voltage| over the training records [V].
    train_v: f32,
    /// Largest |speed| over the training records [rad/s].
    train_omega: f32,
}

/// What is known about one measured sample.
struct At {
    v: f32,
    omega: f32,
    load: f32,
    /// Within a reversal's window (see [`REVERSAL_WINDOW`]).
    reversing: bool,
    /// The record turned before this sample and turns again after it (a passage through zero
    /// within a reversal is not a rest).
    between_motions: bool,
}

/// A regime of the coverage table.
struct Regime {
    name: &'static str,
    /// The kind of experiment that visits it.
    experiment: &'static str,
    member: fn(&At, &Scales) -> bool,
}

fn turning(a: &At, s: &Scales) -> bool {
    a.omega.abs() > BAND * s.omega
}

fn driven(a: &At, s: &Scales) -> bool {
    a.v.abs() > BAND * s.v
}

/// The coverage regimes.
const REGIMES: [Regime; 10] = [
    Regime {
        name: "reversal",
        experiment: "a run that reverses direction (a ±V square wave, sine or chirp)",
        member: |a, _| a.reversing,
    },
    Regime {
        name: "negative_voltage",
        experiment: "a run with negative voltage (reverse steps, a ±V sine)",
        member: |a, s| a.v < -BAND * s.v,
    },
    Regime {
        name: "positive_voltage",
        experiment: "a run with positive voltage (forward steps, a ±V sine)",
        member: |a, s| a.v > BAND * s.v,
    },
    Regime {
        name: "reverse_rotation",
        experiment: "a run turning in reverse (negative voltage steps)",
        member: |a, s| a.omega < -BAND * s.omega,
    },
    Regime {
        name: "forward_rotation",
        experiment: "a run turning forward (positive voltage steps)",
        member: |a, s| a.omega > BAND * s.omega,
    },
    Regime {
        name: "voltage_against_rotation",
        experiment: "a run braking against the supply (the voltage reversed while the motor \
                     still turns: a reversing step, a ±V sine)",
        member: |a, s| driven(a, s) && turning(a, s) && a.v * a.omega < 0.0,
    },
    Regime {
        name: "standstill",
        experiment: "a run resting with voltage applied or between motions (a slow ramp from \
                     0 V, steps with returns to 0 V)",
        member: |a, s| {
            a.omega.abs() <= REST * s.omega && !a.reversing && (driven(a, s) || a.between_motions)
        },
    },
    Regime {
        name: "high_speed",
        experiment: "a run reaching those speeds (a higher voltage or a lighter load)",
        member: |a, s| a.omega.abs() > (1.0 + MARGIN) * s.train_omega,
    },
    Regime {
        name: "high_voltage",
        experiment: "a run at those voltages",
        member: |a, s| a.v.abs() > (1.0 + MARGIN) * s.train_v,
    },
    Regime {
        name: "load",
        experiment: "a run with a known load torque (a tl column)",
        member: |a, s| s.load > 0.0 && a.load.abs() > BAND * s.load,
    },
];

/// A regime the held-out records visit and the training records do not.
#[derive(Serialize, Debug, Clone, PartialEq)]
pub struct CoverageGap {
    /// The regime's name.
    pub regime: &'static str,
    /// Share of the held-out samples that lie in it.
    pub holdout_share: f64,
    /// The held-out files that visit it.
    pub records: Vec<String>,
    /// What to add to the training records.
    pub advice: String,
}

/// Per regime, how many of `r`'s samples lie in it.
fn counts(r: &OwnedRecord, s: &Scales) -> [usize; REGIMES.len()] {
    let n = r.len();
    let sign = |w: f32| {
        if w.abs() >= REVERSAL_WINDOW * s.omega {
            w.signum()
        } else {
            0.0
        }
    };
    // The sign of the last excursion beyond the window up to k, and of the next from k.
    let mut before = vec![0.0f32; n];
    let mut last = 0.0;
    for (k, w) in r.omega.iter().enumerate() {
        last = if sign(*w) != 0.0 { sign(*w) } else { last };
        before[k] = last;
    }
    let mut after = vec![0.0f32; n];
    let mut next = 0.0;
    for (k, w) in r.omega.iter().enumerate().rev() {
        next = if sign(*w) != 0.0 { sign(*w) } else { next };
        after[k] = next;
    }
    // Whether the record turned before k, and turns again after it.
    let moving = |w: &f32| w.abs() > BAND * s.omega;
    let mut moved = vec![false; n];
    let mut any = false;
    for (k, w) in r.omega.iter().enumerate() {
        any |= moving(w);
        moved[k] = any;
    }
    let mut out = [0usize; REGIMES.len()];
    let mut moves_later = false;
    for k in (0..n).rev() {
        moves_later |= moving(&r.omega[k]);
        let at = At {
            v: r.v[k],
            omega: r.omega[k],
            load: r.load.as_ref().map_or(0.0, |l| l[k]),
            reversing: sign(r.omega[k]) == 0.0 && before[k] * after[k] < 0.0,
            between_motions: moved[k] && moves_later,
        };
        for (c, reg) in out.iter_mut().zip(&REGIMES) {
            *c += usize::from((reg.member)(&at, s));
        }
    }
    out
}

/// Whether `count` of a record's `samples` is a visit.
fn visits(count: usize, samples: usize) -> bool {
    count >= MIN_SAMPLES && count as f64 >= MIN_SHARE * samples as f64
}

/// The regimes a record of `holdout` visits and no record of `train` does, in the order of
/// [`REGIMES`].
pub fn gaps(train: &[OwnedRecord], holdout: &[OwnedRecord]) -> Vec<CoverageGap> {
    let all = || train.iter().chain(holdout);
    let largest =
        |recs: &[OwnedRecord], f: fn(&OwnedRecord) -> f32| recs.iter().map(f).fold(0.0, f32::max);
    let scales = Scales {
        v: all().map(|r| peak(&r.v)).fold(0.0, f32::max),
        omega: all().map(|r| peak(&r.omega)).fold(0.0, f32::max),
        load: all()
            .filter_map(|r| r.load.as_deref().map(peak))
            .fold(0.0, f32::max),
        train_v: largest(train, |r| peak(&r.v)),
        train_omega: largest(train, |r| peak(&r.omega)),
    };
    let count = |recs: &[OwnedRecord]| -> Vec<[usize; REGIMES.len()]> {
        recs.iter().map(|r| counts(r, &scales)).collect()
    };
    let (in_train, held) = (count(train), count(holdout));
    let n_held: usize = holdout.iter().map(OwnedRecord::len).sum();
    let mut out = Vec::new();
    for (i, reg) in REGIMES.iter().enumerate() {
        let visited = |r: &OwnedRecord, c: &[usize; REGIMES.len()]| visits(c[i], r.len());
        if train.iter().zip(&in_train).any(|(r, c)| visited(r, c)) {
            continue;
        }
        let total: usize = held.iter().map(|c| c[i]).sum();
        let records: Vec<String> = holdout
            .iter()
            .zip(&held)
            .filter(|(r, c)| visited(r, c))
            .map(|(r, _)| r.name())
            .collect();
        let Some(first) = records.first() else {
            continue;
        };
        let advice = format!(
            "train on a run that visits it: move {first} to the training records (keeping \
             another such run held out), or record {}",
            reg.experiment
        );
        out.push(CoverageGap {
            regime: reg.name,
            holdout_share: (total as f64 / n_held.max(1) as f64 * 1e6).round() / 1e6,
            records,
            advice,
        });
    }
    out
}

/// The gaps in words, one line each.
pub fn summary(gaps: &[CoverageGap]) -> Vec<String> {
    gaps.iter()
        .map(|g| {
            format!(
                "{} ({:.1} % of the held-out samples, in {}) is never visited by the training \
                 records: an effect living there cannot be learned from them; {}",
                g.regime,
                100.0 * g.holdout_share,
                g.records.join(", "),
                g.advice
            )
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::super::data::record;
    use super::*;

    /// A record `name` of the voltage `v`, the speed following it (first order, 0.1 s).
    fn driven(name: &str, v: Vec<f32>) -> OwnedRecord {
        let mut w = 0.0f32;
        let omega = v
            .iter()
            .map(|u| {
                w += (20.0 * u - w) * 0.01;
                w
            })
            .collect();
        record(name, v, omega)
    }

    /// Steps from rest to `top` V and back to 0 V, the speed following (first order).
    fn steps(name: &str, top: f32) -> OwnedRecord {
        let v: Vec<f32> = (0..4000)
            .map(|k| if (500..2000).contains(&k) { top } else { 0.0 })
            .collect();
        driven(name, v)
    }

    /// A ±`amp` V sine (1 Hz), the speed following it.
    fn sine(name: &str, amp: f32) -> OwnedRecord {
        let v: Vec<f32> = (0..4000)
            .map(|k| amp * (2.0 * std::f32::consts::PI * k as f32 * 1e-3).sin())
            .collect();
        driven(name, v)
    }

    fn regimes(g: &[CoverageGap]) -> Vec<&'static str> {
        g.iter().map(|g| g.regime).collect()
    }

    #[test]
    fn reversals_and_negative_voltage_are_gaps_of_a_forward_only_training() {
        let train = [steps("steps.csv", 12.0)];
        let holdout = [sine("sine.csv", 12.0), steps("more.csv", 12.0)];
        let g = gaps(&train, &holdout);
        let found = regimes(&g);
        for r in [
            "reversal",
            "negative_voltage",
            "reverse_rotation",
            "voltage_against_rotation",
        ] {
            assert!(found.contains(&r), "{r} missing in {found:?}");
        }
        // Rest between the steps and speeds within the training's are covered.
        for r in ["standstill", "high_speed", "positive_voltage", "load"] {
            assert!(!found.contains(&r), "{r} in {found:?}");
        }
        let rev = &g[0];
        assert_eq!(rev.regime, "reversal");
        assert_eq!(rev.records, ["sine.csv"]);
        assert!(
            rev.holdout_share > 0.0 && rev.holdout_share < 0.5,
            "{rev:?}"
        );
        assert!(rev.advice.contains("sine.csv"));
        let neg = g.iter().find(|g| g.regime == "negative_voltage").unwrap();
        // Half the sine's samples (a quarter of all) are below -5 % of 12 V, less the band.
        assert!((neg.holdout_share - 0.25).abs() < 0.02, "{neg:?}");
        assert_eq!(summary(&g).len(), g.len());
        // A sine in the training covers them all.
        let covered = gaps(&[steps("a.csv", 12.0), sine("s2.csv", 12.0)], &holdout);
        assert!(covered.is_empty(), "{covered:?}");
        // Held-out speeds beyond the training's: high speed (and voltage).
        let faster = gaps(&train, &[steps("fast.csv", 20.0)]);
        assert_eq!(regimes(&faster), ["high_speed", "high_voltage"]);
    }

    #[test]
    fn a_known_load_and_rest_under_voltage_are_gaps_when_only_held_out() {
        let mut loaded = steps("loaded.csv", 12.0);
        loaded.load = Some(
            (0..4000)
                .map(|k| if k > 1000 { 0.1 } else { 0.0 })
                .collect(),
        );
        // Voltage applied to a motor held at rest (stiction) for the first half.
        let mut stuck = steps("stuck.csv", 12.0);
        for w in &mut stuck.omega[500..1000] {
            *w = 0.0;
        }
        let g = gaps(&[steps("a.csv", 12.0)], &[loaded, stuck]);
        assert_eq!(regimes(&g), ["standstill", "load"]);
        assert_eq!(g[0].records, ["stuck.csv"]);
        assert_eq!(g[1].records, ["loaded.csv"]);
    }
}
