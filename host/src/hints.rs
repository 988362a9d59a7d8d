//! Cheap explanations of a large misfit, tested on the fit itself before it is blamed on
//! an unmodelled effect: a record whose input never changes, a sign inverted, a unit
//! scaled, a record sampled too slowly for its input or its motor, a parameter held at a
//! bound of the search box.
//!
//! A column read with the wrong sign or unit breaks paper Eq. 1-4's one constant `Kv`,
//! which couples the back-EMF `Kv w` of the armature equation to the torque `Kv i` of the
//! shaft's: with the current measured, speed in rpm (a factor 60/2pi) or current in mA (a
//! factor 1000) leaves the two equations wanting different constants, so no parameter set
//! fits; and an inverted speed or current cannot follow a positive voltage. Refitting with
//! the column corrected says which, if any, explains the misfit: a hint is given when the
//! corrected records fit within [`EXPLAINS`] of their noise and at most half as far from it
//! as the records given. (Without the current, a scale of the speed is absorbed by `Kv`
//! and an inverted speed by a negative gain the bounds refuse: only the sign is tried.)
//! A time column in ms rescales La and J alone and fits as well, so it is not a misfit to
//! explain.
//!
//! When no correction explains it, a record sampled too slowly is tried ([`sampling`]): a
//! voltage rougher than its sampling (a PWM or PRBS logged below its switching, a fast
//! record thinned to one row in K), or a fitted motor faster than the step whose misfit
//! sits just after the voltage's changes. Only then a parameter held at a bound of the
//! search box is named: a misfit of another cause drives parameters there too.

mod sampling;

use crate::csvio::OwnedRecord;
use crate::fit::{fit_quick, Fit, FitOptions};
use crate::report::identify::FitQuality;
use crate::report::summary::at_bound;
use anyhow::Result;

/// Largest RMSE over the noise of a corrected fit that is said to explain the misfit.
pub const EXPLAINS: f32 = 1.5;

/// A correction of the records to try: what it assumes, and the change.
struct Correction {
    /// The likely cause, as said.
    cause: &'static str,
    /// Needs the current column.
    needs_current: bool,
    /// The change, applied to a copy of each record.
    apply: fn(&mut OwnedRecord),
}

const CORRECTIONS: [Correction; 4] = [
    Correction {
        cause: "the speed's sign is inverted",
        needs_current: false,
        apply: |r| r.omega.iter_mut().for_each(|w| *w = -*w),
    },
    Correction {
        cause: "the current's sign is inverted",
        needs_current: true,
        apply: |r| {
            if let Some(i) = r.current.as_mut() {
                i.iter_mut().for_each(|x| *x = -*x);
            }
        },
    },
    Correction {
        cause: "the speed is in rpm, not rad/s",
        needs_current: true,
        apply: |r| {
            let per_rpm = std::f32::consts::TAU / 60.0;
            r.omega.iter_mut().for_each(|w| *w *= per_rpm);
        },
    },
    Correction {
        cause: "the current is in mA, not A",
        needs_current: true,
        apply: |r| {
            if let Some(i) = r.current.as_mut() {
                i.iter_mut().for_each(|x| *x *= 1e-3);
            }
        },
    },
];

/// The worst channel's RMSE over its noise.
fn worst_ratio(q: &FitQuality) -> f32 {
    let current = q.current.map_or(0.0, |c| c.rmse_over_noise.0);
    q.speed.rmse_over_noise.0.max(current)
}

/// What explains the misfit of `given` (the fit of `records` with `opts`), in words, each a
/// line to print after "hint: "; empty when the fit is adequate or nothing cheap explains
/// it. Refits once per correction tried, with the default pipeline without its escalation
/// (a corrected record fits to its noise from the equation-error start; `say` tells which).
pub fn cheap_explanations(
    records: &[OwnedRecord],
    opts: &FitOptions,
    given: &Fit,
    say: &dyn Fn(&str),
) -> Result<Vec<String>> {
    let quality = FitQuality::of(&given.result);
    if quality.model_adequate {
        return Ok(Vec::new());
    }
    let mut hints = Vec::new();
    if let Some(v) = constant_input(records) {
        hints.push(format!(
            "the v column is {v} V throughout every record: a change of the voltage (a step, a ramp) is what the fit learns the motor from"
        ));
        return Ok(hints);
    }
    let before = worst_ratio(&quality);
    let quiet = FitOptions {
        quiet: true,
        ..opts.clone()
    };
    for c in CORRECTIONS
        .iter()
        .filter(|c| given.with_current || !c.needs_current)
    {
        say(&format!("checking whether {}", c.cause));
        let mut corrected = records.to_vec();
        corrected.iter_mut().for_each(c.apply);
        let Ok(f) = fit_quick(&corrected, &quiet) else {
            continue;
        };
        let after = worst_ratio(&FitQuality::of(&f.result));
        if after <= EXPLAINS && after <= 0.5 * before {
            hints.push(format!(
                "{}? Corrected, the fit is {after:.2} x its noise instead of {before:.1} x",
                c.cause
            ));
        }
    }
    if !hints.is_empty() {
        // A column corrected explains it: parameters driven to the box's edge by the wrong
        // column say nothing more.
        return Ok(hints);
    }
    // Else a record sampled too slowly: its voltage rougher than its sampling, or a motor
    // faster than the step with the misfit just after the voltage's changes (the
    // parameters it drives to a bound say nothing more either).
    if let Some(h) = sampling::rough_input(records) {
        hints.push(h);
        return Ok(hints);
    }
    if let Some(h) = sampling::too_slow_sampling(records, given)? {
        hints.push(h);
        return Ok(hints);
    }
    // Else a free parameter the fit left at a bound of the box: the motor may lie beyond
    // it.
    for c in &given.result.identifiability.params {
        let value = given.result.params.get(c.id);
        if let Some(b) = at_bound(value, given.spec.bounds[c.id.index()]) {
            hints.push(format!(
                "{} sits at its bound {b}: the motor may lie outside the search box; widen --bounds {}=LO:HI",
                c.id.name(),
                c.id.name()
            ));
        }
    }
    Ok(hints)
}

/// The voltage every record holds throughout, if the input never changes.
fn constant_input(records: &[OwnedRecord]) -> Option<f32> {
    let first = *records.first()?.v.first()?;
    records
        .iter()
        .all(|r| r.v.iter().all(|&v| v == first))
        .then_some(first)
}
