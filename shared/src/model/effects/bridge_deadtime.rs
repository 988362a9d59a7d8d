//! `bridge_deadtime`: the voltage error of a PWM H-bridge. During the dead time between
//! one switch opening and the other closing, the freewheel diodes conduct and set the
//! output by the sign of the current, so the mean armature voltage falls short by
//! `vdt = Vbus t_dead / T_pwm` against the current (Mohan, Undeland, Robbins, *Power
//! Electronics*, dead-time effect). The current's PWM ripple smooths the sign over a band
//! `ib`: `v_error = -vdt clamp(i / ib, -1, 1)`. Unlike `brush_drop`, current flows through
//! it (no dead zone at zero current).

use super::regime;
use super::entry::{ids, EffectBounds, EffectSpec, Held, HeldInputs, Limit, Role, Signature, StepState};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 2] = [
    ParamSpec {
        id: ParamId::Vdt,
        name: "vdt",
        key: "vdt",
        unit: "V",
        default_bounds: (0.0, 5.0),
        physical_range: (0.0, f32::MAX),
    },
    ParamSpec {
        id: ParamId::Ib,
        name: "ib",
        key: "ib",
        unit: "A",
        default_bounds: (0.001, 10.0),
        physical_range: (0.0, f32::MAX),
    },
];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "bridge_deadtime",
    physics: "PWM bridge voltage error -vdt clamp(i/ib, -1, 1) against the current",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 10 % of the voltage, smoothed over 0.1 % to 30 % of the largest current.
    search_bounds: |_, s| {
        let i = s.current_max.max(1e-6);
        let mut out = EffectBounds::new();
        let _ = out.push((ParamId::Vdt, 0.0, 0.1 * s.v_max));
        let _ = out.push((ParamId::Ib, 1e-3 * i, 0.3 * i));
        out
    },
    signature: Some(Signature {
        label: "minus current over a small band",
        at: |x| -(x.current / (0.05 * x.current_max).max(1e-12)).clamp(-1.0, 1.0),
    }),
    shows_in: Some(regime::STANDSTILL),
    limit: Some(Limit {
        entry: "brush_drop",
        param: ParamId::Ib,
    }),
    role: Role::HeldInputs(held),
};

/// The voltage it takes from the bridge's output at current `i` (subtracted from the
/// applied voltage).
#[inline(always)]
pub fn voltage(vdt: f32, ib: f32, i: f32) -> f32 {
    let share = if ib > 0.0 {
        (i / ib).clamp(-1.0, 1.0)
    } else if i > 0.0 {
        1.0
    } else if i < 0.0 {
        -1.0
    } else {
        0.0
    };
    vdt * share
}

/// Its held inputs: the voltage the bridge loses at the step's starting current.
fn held(h: &Held, x: &StepState) -> HeldInputs {
    HeldInputs {
        volts: -voltage(h.get(ParamId::Vdt), h.get(ParamId::Ib), x.current),
        load: 0.0,
    }
}
