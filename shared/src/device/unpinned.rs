//! Why a commissioning left a parameter not pinned, from what the probe measured and the
//! experiment planned ([`Plan`]) and the current reading's resolution: the time scale the
//! experiment could not cover, a signal below one count of the ADC (the parameter's own,
//! or the back-EMF's, through which alone the records fix the scale of J, B, Kv and
//! friction), or, when none holds, records that do not separate it from the others. The board's report says which
//! parameters are not pinned (a NaN σ); this names the likely reason, so that a user knows
//! what to change (the budget, the limits, the drive's ADC) instead of guessing.

use crate::param_id::ParamId;
use crate::wire::protocol::{MotorReport, Plan};

/// Mechanical time scales the slow record must span for J, B, Kv and Coulomb friction to
/// show: a step's rise and its settling (the design aims at [`crate::device::design::SLOW_SPAN`]).
pub const MECHANICAL_SPAN: f32 = 3.0;
/// Record steps per electrical time constant below which La/Ra is not sampled.
pub const ELECTRICAL_STEPS: f32 = 2.0;
/// Counts of the current reading, as the probe reads the back-EMF's current (or the fit's
/// estimates give it, where lower), under which a scale of J, B, Kv and friction left
/// unfixed is put down to it. The probe's reading is a small difference of two currents of
/// tens of amperes, V / Ra - i, and on the motors concerned it read high: in the
/// commissioning benchmark's box (12-bit readings; run of 2026-11-26), motors that came back
/// with all four not pinned had a back-EMF of 0.3-5.4 counts, which the probe read as 1-15
/// (why it reads high is not settled: the electrical step's Ra, if anything, reads high
/// there, which would lower it). Of the motors whose back-EMF took under 1, 1-2, 2-4 and
/// 4-8 counts, 87 %, 38 %, 15 % and 2 % came back so (`docs/measurements/commissioning.md`).
pub const BACK_EMF_COUNTS: f32 = 16.0;

/// Why a parameter is not pinned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unpinned {
    /// The slow record (`covered` s) spans less than [`MECHANICAL_SPAN`] of the
    /// mechanical time scale the probe measured (`needed` s is that span): the budget could
    /// not cover the mechanical mode.
    TimeScale {
        /// Length of the slow record [s].
        covered: f32,
        /// Length it needed [s].
        needed: f32,
    },
    /// The electrical time constant (`tau_e` s) is shorter than [`ELECTRICAL_STEPS`] steps
    /// of the fast record (`step` s, the drive's fastest sampling): La/Ra is not sampled.
    FasterThanSampling {
        /// La/Ra from the probe [s].
        tau_e: f32,
        /// Step of the fast record [s].
        step: f32,
    },
    /// The current the parameter accounts for (`signal` A: viscous friction at the top
    /// speed, B ω / Kv; Coulomb friction, tc / Kv) is below one count of the current
    /// reading (`count` A).
    BelowResolution {
        /// Current the parameter accounts for [A].
        signal: f32,
        /// One count of the current reading [A].
        count: f32,
    },
    /// J, B, Kv and Coulomb friction (when fitted) are all not pinned, and the current the
    /// back-EMF takes away (`current` A, Kv ω / Ra: as the probe read it at its speed, or
    /// by the fit's estimates at the records' steady speed where that is lower; a rough
    /// figure) is under [`BACK_EMF_COUNTS`] counts of the current reading
    /// (`count` A). The speed gives J, B
    /// and friction relative to Kv (paper Eq. 4 divided by Kv); Kv itself shows only in
    /// the back-EMF term of the current (paper Eq. 1), so all four scale together; Ra and
    /// La, which share Eq. 1 with the back-EMF, lean on that scale too and are unpinned with
    /// it (their estimates may still lie close). With `whole_scale` false, only part of
    /// J, B, Kv and friction is unpinned: the valley along that scale bends (the block
    /// scores and the profile check follow it), and the parameter is the one it takes along
    /// where the others came out pinned (in the commissioning benchmark, viscous-dominated
    /// motors whose back-EMF took 1-8 counts at the top speed).
    BackEmfBelowResolution {
        /// Current the back-EMF takes away, the probe's reading or the fit's [A].
        current: f32,
        /// One count of the current reading [A].
        count: f32,
        /// J, B, Kv and friction (when fitted) are all unpinned.
        whole_scale: bool,
    },
    /// None of the above: the records do not separate it from the other parameters.
    NotSeparated,
}

/// Why `param` is not pinned in `report`, given the commissioning's `plan` and one count
/// of the current reading `current_count` [A] (0 when the reading is not quantised).
pub fn why_not_pinned(
    param: ParamId,
    report: &MotorReport,
    plan: &Plan,
    current_count: f32,
) -> Unpinned {
    let value = |p: ParamId| report.get(p.index() as u8).map_or(f32::NAN, |e| e.value);
    let mechanical = crate::fit::torque_scale::scales(param);
    let covered = plan.slow_dt * plan.slow_samples as f32;
    let needed = MECHANICAL_SPAN * plan.tau_m;
    if param == ParamId::La && plan.tau_e < ELECTRICAL_STEPS * plan.fast_dt {
        return Unpinned::FasterThanSampling {
            tau_e: plan.tau_e,
            step: plan.fast_dt,
        };
    }
    // J, B and Kv held and unpinned, and Coulomb friction too when it is fitted (a friction
    // held at a known value would fix the scale: the speed gives tc / Kv). Checked first:
    // with the back-EMF within a few counts the probe's Kv, and with it its mechanical
    // time scale (J Ra / Kv²), is unreliable, so a slow record short of it says nothing.
    let unpinned = |p: ParamId| report.get(p.index() as u8).map(|e| !e.pinned());
    let scale_unpinned = [ParamId::J, ParamId::B, ParamId::Kv]
        .iter()
        .all(|p| unpinned(*p) == Some(true))
        && unpinned(ParamId::Tc) != Some(false);
    let motor = mechanical || matches!(param, ParamId::Ra | ParamId::La);
    // The probe's reading, or the fit's own figure where that is lower: a probe that read
    // the back-EMF high (motor 679 of the commissioning benchmark: 17 counts, the truth 2)
    // would leave an unpinned scale without its reason.
    let back_emf = plan
        .back_emf_current
        .min(fitted_back_emf(&value, plan.volts));
    let back_emf_within_counts = back_emf < BACK_EMF_COUNTS * current_count;
    if motor && scale_unpinned && back_emf_within_counts {
        return Unpinned::BackEmfBelowResolution {
            current: back_emf,
            count: current_count,
            whole_scale: true,
        };
    }
    if mechanical && covered < needed {
        return Unpinned::TimeScale { covered, needed };
    }
    let kv = value(ParamId::Kv);
    let signal = match param {
        // Viscous friction at the top speed the records reach, about V / Kv.
        ParamId::B => value(ParamId::B) * plan.volts / (kv * kv),
        ParamId::Tc => value(ParamId::Tc) / kv,
        _ => f32::NAN,
    };
    if signal.abs() < current_count {
        return Unpinned::BelowResolution {
            signal: signal.abs(),
            count: current_count,
        };
    }
    // Part of the scale: J, B and Kv all fitted (a J held at a known value fixes the scale,
    // the speed giving J / Kv), the slow record long enough and the parameter's own current
    // above a count, but the back-EMF within a few counts as above.
    let scale_fitted = [ParamId::J, ParamId::B, ParamId::Kv]
        .iter()
        .all(|p| unpinned(*p).is_some());
    if mechanical && scale_fitted && back_emf_within_counts {
        return Unpinned::BackEmfBelowResolution {
            current: back_emf,
            count: current_count,
            whole_scale: false,
        };
    }
    Unpinned::NotSeparated
}

/// The back-EMF's current Kv ω / Ra at the steady speed the estimates give at `volts`,
/// ω = (Kv V - Ra tc) / (Ra B + Kv²) (paper Eq. 1 and 4 with the derivatives at 0; tc 0
/// when not fitted); NaN without the estimates.
fn fitted_back_emf(value: &impl Fn(ParamId) -> f32, volts: f32) -> f32 {
    let (ra, b, kv) = (value(ParamId::Ra), value(ParamId::B), value(ParamId::Kv));
    let tc = match value(ParamId::Tc) {
        tc if tc.is_finite() => tc,
        _ => 0.0,
    };
    let omega = (kv * volts - ra * tc) / (ra * b + kv * kv);
    match omega.is_finite() {
        true => kv * omega.max(0.0) / ra,
        false => f32::NAN,
    }
}

impl core::fmt::Display for Unpinned {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match *self {
            Unpinned::TimeScale { covered, needed } => write!(
                f,
                "the slow record ({covered:.3} s) covers less than {MECHANICAL_SPAN} mechanical time scales ({needed:.3} s): give a larger time budget (--budget)"
            ),
            Unpinned::FasterThanSampling { tau_e, step } => write!(
                f,
                "La/Ra ({tau_e:.3e} s) is shorter than {ELECTRICAL_STEPS} steps of the fast record ({step:.3e} s): the drive samples too slowly for it"
            ),
            Unpinned::BelowResolution { signal, count } => write!(
                f,
                "its current ({signal:.3e} A) is below one count of the current reading ({count:.3e} A)"
            ),
            Unpinned::BackEmfBelowResolution {
                current,
                count,
                whole_scale,
            } => {
                write!(
                    f,
                    "the back-EMF takes only a few counts of the current reading ({current:.2e} A against a count of {count:.2e} A: the probe's reading or the fit's, the lower, a rough figure): Kv shows only through it, and J, B and friction, which the speed gives relative to Kv, scale with it ({}); raise the current or voltage limit, or read the current finer",
                    match whole_scale {
                        true => "Ra and La lean on that scale",
                        false => "the valley along that scale bends, and takes this one along where the others came out pinned",
                    }
                )
            }
            Unpinned::NotSeparated => {
                f.write_str("the records do not separate it from the other parameters")
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::protocol::Estimate;

    fn plan() -> Plan {
        Plan {
            current_offset: 0.0,
            breakaway_volts: 1.0,
            ra: 1.0,
            tau_e: 1e-3,
            kv: 0.5,
            tau_m: 1.0,
            back_emf_current: 10.0,
            volts: 20.0,
            fast_dt: 5e-5,
            fast_samples: 400,
            slow_dt: 0.01,
            slow_samples: 600,
            probe_seconds: 2.0,
            planned_seconds: 10.0,
        }
    }

    fn report(b: f32, tc: f32) -> MotorReport {
        let mut estimates = heapless::Vec::new();
        for (p, v) in [(ParamId::Kv, 0.5), (ParamId::B, b), (ParamId::Tc, tc)] {
            let e = Estimate {
                param: p.index() as u8,
                value: v,
                std: f32::NAN,
            };
            estimates.push(e).unwrap();
        }
        MotorReport {
            estimates,
            rmse_omega: 0.1,
            evaluations: 10,
            rank: 4,
        }
    }

    #[test]
    fn a_slow_record_shorter_than_the_mechanical_scale_is_the_reason_for_j() {
        let mut p = plan();
        p.tau_m = 3.0; // 6 s of record against 9 s needed.
        let why = why_not_pinned(ParamId::J, &report(1e-3, 0.1), &p, 0.02);
        assert_eq!(
            why,
            Unpinned::TimeScale {
                covered: 6.0,
                needed: 9.0
            }
        );
        assert_eq!(
            why_not_pinned(ParamId::J, &report(1e-3, 0.1), &plan(), 0.02),
            Unpinned::NotSeparated
        );
    }

    #[test]
    fn a_viscous_current_below_one_count_is_the_reason_for_b() {
        // B w / Kv = 1e-4 * 40 / 0.5 = 8 mA against a 23 mA count.
        let why = why_not_pinned(ParamId::B, &report(1e-4, 0.1), &plan(), 0.0234);
        assert!(matches!(why, Unpinned::BelowResolution { .. }), "{why:?}");
        let why = why_not_pinned(ParamId::B, &report(1e-2, 0.1), &plan(), 0.0234);
        assert_eq!(why, Unpinned::NotSeparated);
    }

    #[test]
    fn a_back_emf_within_a_few_counts_is_the_reason_when_the_scale_of_j_b_kv_and_tc_is_free() {
        let mut p = plan();
        p.back_emf_current = 0.05; // About two counts of 23.4 mA.
        let mut r = report(1e-2, 0.1);
        let j = Estimate {
            param: ParamId::J.index() as u8,
            value: 1e-3,
            std: f32::NAN,
        };
        r.estimates.push(j).unwrap();
        for id in [ParamId::J, ParamId::B, ParamId::Kv, ParamId::Tc] {
            let why = why_not_pinned(id, &r, &p, 0.0234);
            assert_eq!(
                why,
                Unpinned::BackEmfBelowResolution {
                    current: 0.05,
                    count: 0.0234,
                    whole_scale: true,
                },
                "{id:?}"
            );
        }
        // The electrical parameters unpinned beside them lean on the same scale, where the
        // slow record covered the mechanical mode (else the time scale is the reason).
        let ra = Estimate {
            param: ParamId::Ra.index() as u8,
            value: 1.0,
            std: f32::NAN,
        };
        r.estimates.push(ra).unwrap();
        assert!(matches!(
            why_not_pinned(ParamId::Ra, &r, &p, 0.0234),
            Unpinned::BackEmfBelowResolution { .. }
        ));
        // Before the time scale: the probe's, from its Kv, is unreliable then.
        let mut short = p;
        short.tau_m = 3.0;
        assert!(matches!(
            why_not_pinned(ParamId::J, &r, &short, 0.0234),
            Unpinned::BackEmfBelowResolution { .. }
        ));
        // Not the whole scale with tc pinned (it fixes the scale: the speed gives tc / Kv),
        // nor with Kv pinned: part of it, the valley bending. Not at all with J not in the
        // report (held at a known value, it fixes the scale), nor with a back-EMF of many
        // counts, nor where the slow record fell short of the time scale.
        let part = Unpinned::BackEmfBelowResolution {
            current: 0.05,
            count: 0.0234,
            whole_scale: false,
        };
        let mut no_j = r.clone();
        no_j.estimates
            .retain(|e| e.param != ParamId::J.index() as u8);
        assert_eq!(
            why_not_pinned(ParamId::B, &no_j, &p, 0.0234),
            Unpinned::NotSeparated
        );
        let mut tc_pinned = r.clone();
        tc_pinned.estimates[2].std = 1e-3;
        assert_eq!(why_not_pinned(ParamId::B, &tc_pinned, &p, 0.0234), part);
        let mut kv_pinned = r.clone();
        kv_pinned.estimates[0].std = 1e-3;
        assert_eq!(why_not_pinned(ParamId::B, &kv_pinned, &p, 0.0234), part);
        assert_eq!(why_not_pinned(ParamId::Tc, &kv_pinned, &p, 0.0234), part);
        // Ra beside part of the scale: not put down to it.
        assert_eq!(
            why_not_pinned(ParamId::Ra, &kv_pinned, &p, 0.0234),
            Unpinned::NotSeparated
        );
        assert!(matches!(
            why_not_pinned(ParamId::B, &kv_pinned, &short, 0.0234),
            Unpinned::TimeScale { .. }
        ));
        p.back_emf_current = 0.5;
        assert_eq!(
            why_not_pinned(ParamId::B, &r, &p, 0.0234),
            Unpinned::NotSeparated
        );
    }

    #[test]
    fn a_back_emf_the_probe_read_high_is_the_reason_by_the_fit_s_own_estimates() {
        // Motor 679 of the commissioning benchmark: the probe read the back-EMF as 0.39 A
        // (17 counts), the truth 2 counts; the fit's estimates give Kv ω / Ra = 0.244 *
        // 1.19 / 8.24 = 35 mA at 50 V.
        let mut p = plan();
        (p.back_emf_current, p.volts) = (0.387, 50.0);
        let mut estimates = heapless::Vec::new();
        let values = [
            (ParamId::Ra, 8.243),
            (ParamId::J, 2.28e-3),
            (ParamId::B, 0.833),
            (ParamId::Kv, 0.244),
            (ParamId::Tc, 0.481),
        ];
        for (id, value) in values {
            let std = f32::NAN;
            let param = id.index() as u8;
            estimates.push(Estimate { param, value, std }).unwrap();
        }
        let r = MotorReport {
            estimates,
            rmse_omega: 0.1,
            evaluations: 10,
            rank: 3,
        };
        let why = why_not_pinned(ParamId::Kv, &r, &p, 0.0234);
        let Unpinned::BackEmfBelowResolution {
            current,
            whole_scale: true,
            ..
        } = why
        else {
            panic!("{why:?}");
        };
        assert!((current - 0.035).abs() < 1e-3, "{current}");
    }

    #[test]
    fn an_electrical_time_constant_within_two_steps_is_not_sampled() {
        let mut p = plan();
        p.tau_e = 8e-5;
        let why = why_not_pinned(ParamId::La, &report(1e-3, 0.1), &p, 0.02);
        assert!(
            matches!(why, Unpinned::FasterThanSampling { .. }),
            "{why:?}"
        );
    }
}
