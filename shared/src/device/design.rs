//! The commissioning experiment designed from the probe ([`crate::device::probe`]) and the
//! limits: one voltage, and two records that share the board's record memory.
//!
//! - The **slow record** covers the mechanical mode: steps of ½ → ¼ → 1 of the voltage,
//!   each a quarter of the record and dipped by a tenth eight times
//!   ([`crate::device::experiment::slow_input`]), then a coast-down over the last
//!   quarter (paper Eq. 4 with i = 0 separates Coulomb from viscous friction), spanning
//!   [`SLOW_SPAN`] mechanical time scales when the budget allows.
//! - The **fast record** covers the electrical mode: [`FAST_STEP`] samples per La/Ra, a step
//!   of the voltage from 0 V and back, so that paper Eq. 1 pins Ra, La and Kv.
//!
//! Each record sample is the drive's reading at its instant, the drive sampling a whole
//! number of times per record step ([`crate::device::experiment`]). The voltage keeps the start current under
//! [`CURRENT_SHARE`] of the current limit and the steady speed under
//! [`crate::device::probe::SPEED_SHARE`] of the speed limit. In the steady state (paper
//! Eq. 1 and 4) ω = (Kv V - Ra tc) / (Kv² + Ra B) is affine in V, from 0 at the break-away
//! V₀ = Ra tc / Kv; so ω ≤ (V - V₀) / Kv always (the steady current is at least tc / Kv),
//! with V₀ at least a quarter of the ramp's break-away ([`BREAKAWAY_CREDIT`]), and when the
//! probe's step at V₁ settled with current i₁ (where Kv i₁ = B ω₁ + tc), ω ≤ (V - Ra i₁) /
//! Kv for V ≥ V₁. The voltage is the largest these bounds keep under ω_max, divided by the
//! step's overshoot, or the probe step's own V₁ when its rise bounds the records' speed
//! under ω_max ([`by_rise`]: a heavy shaft whose step never settles). A motor whose break-away voltage lies above it is refused. (Without
//! the friction's credit, a motor whose friction takes most of the voltage the speed bound
//! allows was driven below its break-away: commissioning benchmark, 18 motors refused as
//! too fast that now commission, and a fit 20 times off at 40 deviations that is gone,
//! `docs/measurements/commissioning.md`.)

use crate::device::experiment::coast_start;
use crate::device::probe::{Mechanical, Probed, KV_FLOOR, SPEED_SHARE};
use crate::device::rest::QUIET_BUDGET;
use crate::wire::limits::Limits;
use crate::wire::protocol::Refusal;

/// Share of the current limit the experiment's start current may reach.
pub const CURRENT_SHARE: f32 = 0.7;
/// Share of the ramp's break-away voltage the speed bound credits as the sliding friction's
/// drop V₀ (see [`design`]).
pub const BREAKAWAY_CREDIT: f32 = 0.25;

/// Samples of the fast record per electrical time constant.
pub const FAST_STEP: f32 = 20.0;
/// Samples of the fast record at most.
pub const FAST_SAMPLES: usize = 400;
/// Waits for the shaft to stand still the records need: one before each.
pub const QUIETS: f32 = 2.0;

/// Mechanical time scales the slow record spans when the budget allows: each of its three
/// levels about five, so that the speed settles and the level's dips
/// ([`crate::device::experiment::DITHER_CYCLES`]) relax (6 → 20: motor-like motors with
/// all six within 3 % 89.6 → 93.9 % with the dips, pinned estimates within 3 σ 94.7 →
/// 96.8 %; 30 and 40, each with dips of the same length, did no better,
/// `docs/measurements/commissioning.md`).
pub const SLOW_SPAN: f32 = 20.0;
/// Share of the budget the fast record may take at most.
const FAST_BUDGET: f32 = 0.15;

/// One record of the experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RecordPlan {
    /// Drive samples per record sample.
    pub step: u32,
    /// Record samples.
    pub samples: usize,
}

impl RecordPlan {
    /// The record's step for a drive sampled every `dt` [s].
    pub fn dt(&self, dt: f32) -> f32 {
        self.step as f32 * dt
    }

    /// Drive samples the record takes.
    pub fn drive_samples(&self) -> u32 {
        self.samples as u32 * self.step
    }
}

/// The designed experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Design {
    /// Largest voltage [V].
    pub volts: f32,
    /// The slow record (first, from rest).
    pub slow: RecordPlan,
    /// The fast record.
    pub fast: RecordPlan,
}

/// Drive samples per record sample for a record step of `x` drive samples: its whole part,
/// at least 1 (a record never outlasts its span).
fn whole(x: f32) -> u32 {
    if x.is_finite() && x > 1.0 {
        x.min(1e6) as u32
    } else {
        1
    }
}

/// The experiment for a motor the probe measured, with `capacity` record samples and a
/// drive sampled every `dt`, after the probe's time. Refused when the speed limit leaves no
/// voltage above the break-away ([`Refusal::TooFast`], or [`Refusal::NoBackEmf`] when the
/// probe could not measure Kv, so that the speed bound is the resistive drop alone) or the
/// current limit none ([`Refusal::NoMotion`]).
pub fn design(
    limits: &Limits,
    dt: f32,
    capacity: usize,
    probed: &Probed,
) -> Result<Design, Refusal> {
    let (electrical, mechanical) = (&probed.electrical, &probed.mechanical);
    let floor = probed.ramp.breakaway.unwrap_or(0.0);
    let by_current = CURRENT_SHARE * limits.current * electrical.ra;
    // The resistive drop of the friction current the speed bound may credit: the settled
    // step's (V₀ ≤ Ra i₁), or a quarter of the ramp's break-away (the ramp reads it late on
    // a heavy shaft, and a static friction breaks away above the sliding V₀: a quarter holds
    // for readings up to twice late beside a static friction up to twice the sliding one).
    let friction_drop = match mechanical.settled {
        true => electrical.ra * mechanical.current.max(0.0),
        false => 0.0,
    }
    .max(BREAKAWAY_CREDIT * floor);
    let by_speed =
        mechanical.kv * SPEED_SHARE * limits.speed / mechanical.overshoot + friction_drop;
    let fast_samples = FAST_SAMPLES.min(capacity / 4);
    let fast_span =
        (electrical.tau_e / FAST_STEP * fast_samples as f32).min(FAST_BUDGET * limits.budget);
    let fast = RecordPlan {
        step: whole(fast_span / (fast_samples as f32 * dt)),
        samples: fast_samples,
    };
    let left = limits.budget
        - probed.seconds
        - fast.drive_samples() as f32 * dt
        - QUIETS * QUIET_BUDGET * limits.budget;
    let slow_span = (SLOW_SPAN * mechanical.tau_m).min(left).max(0.0);
    let slow_capacity = capacity - fast_samples;
    let step = whole(slow_span / (slow_capacity as f32 * dt));
    let samples = match step {
        1 => ((slow_span / dt) as usize).clamp(16, slow_capacity),
        _ => slow_capacity,
    };
    let slow = RecordPlan { step, samples };
    // The probe's step as a bound of its own: no voltage above its drove the shaft faster
    // than its top speed by its end (see [`by_rise`]).
    let driven =
        (coast_start(slow.samples) as u32 * slow.step + fast.drive_samples() / 2) as f32 * dt;
    let by_speed = by_speed.max(by_rise(limits, mechanical, driven));
    let volts = limits.voltage.min(by_current).min(by_speed);
    // The ramp reads the break-away late on a heavy shaft (it must gather speed to be seen):
    // only a voltage under half of it is surely below the true break-away.
    if volts <= 0.5 * floor {
        // With Kv not measured, the speed bound is the resistive drop alone: a refusal for
        // speed would name the wrong cause.
        return Err(match (by_speed <= by_current, mechanical.kv <= KV_FLOOR) {
            (true, true) => Refusal::NoBackEmf,
            (true, false) => Refusal::TooFast,
            (false, _) => Refusal::NoMotion,
        });
    }
    Ok(Design { volts, slow, fast })
}

/// The voltage of the probe's mechanical step when its rise bounds the records' speed under
/// the speed bound's share of the limit, else 0; `driven` is the time the records drive the
/// shaft [s]. From rest under a held voltage the speed rises concavely (paper Eq. 4 with
/// the current settled: dω/dt = (Kv i − B ω − tc) / J falls as ω grows), so a step that
/// reached `top` in `seconds` reaches at most `top · T / seconds` in T ≥ `seconds`, and no
/// lower voltage more. A record may start before the shaft has stopped (its wait is
/// bounded), from at most `top`: the records stay under `top · (1 + driven / seconds)`.
/// This bounds a heavy viscous shaft, whose step never settles, by what it did rather than
/// by V / Kv: such a motor was driven under its break-away, its shaft stood through the
/// records, and its J and tc came out 18 times too large at 50 deviations
/// (docs/measurements/commissioning.md).
fn by_rise(limits: &Limits, mechanical: &Mechanical, driven: f32) -> f32 {
    let bound = mechanical.top * (1.0 + driven / mechanical.seconds.max(f32::MIN_POSITIVE));
    match bound <= SPEED_SHARE * limits.speed {
        true => mechanical.volts,
        false => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const DT: f32 = 5e-5;

    use crate::device::probe::{Electrical, Mechanical, Ramp};
    use crate::device::rest::Rest;

    /// A probe that took 3 s and found the shaft breaking away at 1 V.
    fn probe(ra: f32, tau_e: f32, kv: f32, tau_m: f32) -> Probed {
        Probed {
            rest: Rest {
                current_offset: 0.0,
                sigma_omega: 0.1,
                sigma_current: 0.005,
                offset_readings: 5000,
            },
            ramp: Ramp {
                breakaway: Some(1.0),
                volts: 1.0,
                current: 2.0,
            },
            electrical: Electrical { ra, tau_e },
            mechanical: Mechanical {
                kv,
                tau_m,
                overshoot: 1.0,
                current: 0.0,
                back_emf_current: 1.0,
                settled: true,
                volts: 10.0,
                top: 300.0,
                seconds: 1.0,
            },
            seconds: 3.0,
        }
    }

    #[test]
    fn the_records_fit_the_budget_and_the_memory_and_resolve_both_modes() {
        let limits = Limits::DEFAULT;
        for (tau_e, tau_m) in [(1e-3, 0.01), (0.0168, 4.2), (0.2, 30.0), (1e-4, 1e-3)] {
            let p = probe(3.4, tau_e, 0.16, tau_m);
            let d = design(&limits, DT, 2000, &p).unwrap();
            assert!(d.slow.samples + d.fast.samples <= 2000);
            let seconds = 3.0
                + (d.slow.drive_samples() + d.fast.drive_samples()) as f32 * DT
                + QUIETS * QUIET_BUDGET * limits.budget;
            assert!(seconds <= limits.budget, "{tau_e} {tau_m}: {seconds} s");
            let fast_dt = d.fast.dt(DT);
            assert!(fast_dt <= (tau_e / 10.0).max(DT), "{tau_e}: {fast_dt}");
            let slow_span = d.slow.samples as f32 * d.slow.dt(DT);
            assert!(
                slow_span >= (5.0 * tau_m).min(40.0),
                "{tau_m}: {slow_span} s"
            );
        }
    }

    #[test]
    fn an_unsettled_step_bounds_the_records_by_its_own_rise() {
        let limits = Limits::DEFAULT;
        // A heavy viscous shaft: the step at 50 V reached 18 rad/s in 15 s, still rising.
        // V / Kv alone allows 0.0155 x 350 = 5.4 V; the records, driven for about 45 s,
        // stay under 18 x (1 + 45 / 15) = 72 rad/s at 50 V.
        let mut p = probe(9.94, 0.17, 0.0155, 30.0);
        p.ramp.breakaway = None;
        p.mechanical = Mechanical {
            settled: false,
            volts: 50.0,
            top: 18.0,
            seconds: 15.0,
            ..p.mechanical
        };
        let d = design(&limits, DT, 2000, &p).unwrap();
        assert_eq!(d.volts, 50.0);
        // The same step having reached 150 rad/s: 150 x (1 + 45 / 15) passes 350 rad/s,
        // and V / Kv bounds the voltage again.
        p.mechanical.top = 150.0;
        let d = design(&limits, DT, 2000, &p).unwrap();
        assert!((d.volts - 0.0155 * 350.0).abs() < 1e-3, "{}", d.volts);
    }

    #[test]
    fn the_voltage_keeps_current_and_speed_under_their_shares() {
        let limits = Limits::DEFAULT;
        // Low resistance: the current limit binds (0.7 x 40 A x 0.5 ohm = 14 V).
        let p = probe(0.5, 0.01, 1.0, 1.0);
        let d = design(&limits, DT, 2000, &p).unwrap();
        assert!((d.volts - 14.0).abs() < 1e-4, "{}", d.volts);
        // Small Kv: the speed limit binds (0.01 x 350 rad/s = 3.5 V), plus the friction's
        // drop it credits, a quarter of the 1 V break-away.
        let p = probe(10.0, 0.01, 0.01, 1.0);
        let d = design(&limits, DT, 2000, &p).unwrap();
        assert!((d.volts - 3.75).abs() < 1e-4, "{}", d.volts);
        // Smaller still: no voltage above the break-away (1 V, read late: half of it) stays
        // under the speed limit (5e-4 x 350 + 0.25 = 0.425 V).
        let p = probe(10.0, 0.01, 5e-4, 1.0);
        assert_eq!(design(&limits, DT, 2000, &p), Err(Refusal::TooFast));
        // No back-EMF measured (V - Ra i not above zero): refused as such, not as too fast.
        let p = probe(10.0, 0.01, KV_FLOOR, 1.0);
        assert_eq!(design(&limits, DT, 2000, &p), Err(Refusal::NoBackEmf));
    }
}
