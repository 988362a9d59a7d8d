//! `current_limit`: the drive holds the armature current within `imax` by lowering the
//! voltage it applies, while the log keeps the voltage commanded (a drive's current loop, or
//! its hardware limit; Mohan, Undeland, Robbins, *Power Electronics*, current-mode
//! control). Held over a step, the applied voltage is the commanded one clamped to the
//! voltages that hold `|i|` at `imax` in paper Eq. 1, `e ± Ra imax`, with `e` the
//! back-EMF `kv (1 - kar |i|) w` and the brush drop `vb sign(i)`, and `Ra` the winding's
//! hot resistance under `winding_heating` (the other entries' parameters, off when they
//! are): below the limit the current rises towards it with La/Ra; at it, the logged current
//! is flat-topped, the most common reason a logged step response departs from the motor
//! model.

use super::armature_reaction::flux_factor;
use super::regime;
use super::entry::{ids, one, EffectSpec, Held, HeldInputs, Role, Signature, StepState};
use super::winding_heating::resistance_factor;
use crate::model::sim::sign;
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Imax,
    name: "imax",
    key: "imax",
    unit: "A",
    default_bounds: (0.0, 100.0),
    physical_range: (0.0, f32::MAX),
}];

/// Share of the largest current at and above which a current counts as held at the limit
/// (for the signature).
const AT_LIMIT: f64 = 0.98;

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "current_limit",
    physics: "the drive holds |i| within imax by lowering the applied voltage; the log keeps the commanded one",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // From a twentieth of the largest current (a limit that binds the whole record) to half
    // as much again (one the record never reaches: the effect then does nothing).
    search_bounds: |_, s| {
        let i = s.current_max.max(1e-6);
        one(ParamId::Imax, 0.05 * i, 1.5 * i)
    },
    // Without the limit the model drives more current where the drive held it: more torque,
    // so a speed residual against the current's sign where the current sits at its largest.
    signature: Some(Signature {
        label: "minus sign of current where it sits at its largest",
        at: |x| {
            if x.current.abs() >= AT_LIMIT * x.current_max && x.current_max > 0.0 {
                -x.current.signum()
            } else {
                0.0
            }
        },
    }),
    shows_in: Some(regime::START_UP),
    limit: None,
    role: Role::HeldInputs(held),
};

/// Its held input: the applied voltage less the commanded one, at the step's start.
fn held(h: &Held, x: &StepState) -> HeldInputs {
    HeldInputs {
        volts: limited(h, x) - x.volts,
        load: 0.0,
    }
}

/// The commanded voltage `x.volts` clamped to the voltages that hold `|i|` at `imax`.
#[inline(always)]
pub fn limited(h: &Held, x: &StepState) -> f32 {
    let imax = h.get(ParamId::Imax);
    let flux = flux_factor(h.get(ParamId::Kar), x.current);
    let emf = x.kv * flux * x.omega + h.get(ParamId::Vb) * sign(x.current);
    // The winding's hot resistance (`winding_heating`; a factor of 1 when it is off).
    let reach = x.ra() * resistance_factor(x.winding_rise) * imax;
    x.volts.clamp(emf - reach, emf + reach)
}
