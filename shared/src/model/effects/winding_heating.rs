//! `winding_heating`: the armature resistance rises with the copper's temperature,
//! `Ra(T) = Ra (1 + ALPHA dT)`, where `ALPHA` = 0.00393 /K is annealed copper's temperature
//! coefficient of resistance at 20 °C (IEC 60028, *International standard of resistance
//! for copper*; NBS Handbook 100, *Copper Wire Tables*: 0.393 %/K) and `Ra` the resistance
//! at the record's start. The rise `dT` follows a first-order thermal model of the winding
//! driven by its copper loss, `tau_th d(dT)/dt = rth i^2 Ra(T) - dT`: one heat capacity
//! behind one thermal resistance to its surroundings, with `tau_th` the thermal time
//! constant and `rth` the rise per watt at the steady state (a motor's datasheet gives the
//! two stages winding-housing and housing-ambient; over a record of tens of seconds the
//! winding's own stage is the one that moves).
//!
//! `dT` starts at 0 at each record's start: the record begins cold, at the temperature
//! whose resistance the fit calls `Ra` (a record that starts warm from an earlier run is
//! modelled as if that warmth were its ambient). Heating is slow: a winding's time constant
//! is seconds to minutes, so the effect shows on long records (tens of seconds to minutes)
//! of a motor that works hard (reversals, steps, a cycling duty), as a resistance that
//! drifts along the record.
//!
//! In the model step the extra resistance is a held voltage `-ALPHA dT Ra i` over the step
//! (`dT` and `i` at its start), so that the step's exact discretisation at `Ra` stands; `dT`
//! is a state of its own that the simulator advances once per step with the exact step of
//! its first-order equation, the loss held over the step ([`rise_increment`]).

use super::entry::{ids, EffectBounds, EffectSpec, Held, HeldInputs, Role, StepState};
use crate::param_id::{ParamId, ParamSpec};

/// Annealed copper's temperature coefficient of resistance at 20 °C [1/K] (IEC 60028).
pub const ALPHA_COPPER: f32 = 0.00393;

/// Its parameters.
const PARAMS: [ParamSpec; 2] = [
    ParamSpec {
        id: ParamId::Rth,
        name: "rth",
        key: "rth",
        unit: "K/W",
        default_bounds: (0.01, 10.0),
        physical_range: (0.0, f32::MAX),
    },
    ParamSpec {
        id: ParamId::TauTh,
        name: "tau_th",
        key: "tau",
        unit: "s",
        default_bounds: (2.0, 3600.0),
        physical_range: (0.0, f32::MAX),
    },
];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "winding_heating",
    physics: "Ra rises 0.393 %/K with the winding's temperature, which follows its copper loss i^2 Ra(T) with a time constant tau_th and a rise rth per watt",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Physical ranges, not the record's: a rise per watt from 0.01 K/W (a large motor's
    // winding, or one cooled by a fan: barely warmer at full load) to 10 K/W (a small
    // motor's winding to its housing), and a thermal time constant from 2 s (the winding of
    // a motor of a few watts) to an hour (a large motor's frame). Both searched on a log
    // scale. A record much shorter than `tau_th` shows only the initial slope of the rise,
    // `rth / tau_th` times the loss: the fit then pins that ratio and leaves the two
    // unpinned, which the identifiability report says.
    search_bounds: |_, _| {
        let mut out = EffectBounds::new();
        for b in [(ParamId::Rth, 0.01, 10.0), (ParamId::TauTh, 2.0, 3600.0)] {
            let _ = out.push(b);
        }
        out
    },
    // Its residual lives along the record's time (the resistance drifts as the winding
    // warms), which a sample's operating point does not show: the diagnosis sees it as a
    // drift of `ra` from window to window instead.
    signature: None,
    shows_in: None,
    limit: None,
    role: Role::HeldInputs(held),
};

/// Its held input: the extra resistance's drop `-ALPHA dT Ra i` at the step's start.
fn held(_: &Held, x: &StepState) -> HeldInputs {
    HeldInputs {
        volts: -ALPHA_COPPER * x.winding_rise * x.ra() * x.current,
        load: 0.0,
    }
}

/// The hot resistance's factor over `Ra`, `1 + ALPHA dT`, at a rise `rise` [K].
#[inline(always)]
pub fn resistance_factor(rise: f32) -> f32 {
    1.0 + ALPHA_COPPER * rise
}

/// The share of the way to its steady state that a first-order state of time constant
/// `tau` goes in a step `dt`: `1 - e^{-dt/tau}` (1 for `tau` = 0, a winding without heat
/// capacity).
pub fn step_gain(tau: f32, dt: f32) -> f32 {
    -libm::expm1f(-dt / tau)
}

/// The rise's change over a step from `rise` [K] with the copper loss `loss` [W] held over
/// it (the exact step of `tau_th d(dT)/dt = rth loss - dT`), `gain` the step's
/// [`step_gain`].
#[inline(always)]
pub fn rise_increment(rise: f32, loss: f32, rth: f32, gain: f32) -> f32 {
    (rth * loss - rise) * gain
}
