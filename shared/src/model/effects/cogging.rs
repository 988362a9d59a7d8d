//! `cogging`: the detent torque of a motor whose rotor iron is drawn to the stator's
//! magnets (permanent-magnet motors: slots against poles), a load
//! `cog_amp sin(cog_cycles theta + cog_phase)` added to paper Eq. 4, with `theta` the shaft
//! angle integrated from the record's start and `cog_cycles` the detents per revolution
//! (Hanselman, *Brushless Permanent Magnet Motor Design*, cogging torque). It holds a shaft
//! at rest like friction does, but unlike friction it changes sign with the angle, and a
//! turning shaft shows it as a speed ripple at `cog_cycles` times the rotation, largest at
//! low speed (`cog_amp / (J cog_cycles w)`, where tacho ripple grows with `w`). The angle
//! follows the measured speed when a fit gives it, as the tacho ripple's does (but is not
//! corrected by the readings as the ripple's is: the correction also takes up an error of
//! the ripple's phase).

use super::regime;
use super::entry::{ids, EffectBounds, EffectSpec, Held, HeldInputs, Role, StepState};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        id: ParamId::CogAmp,
        name: "cog_amp",
        key: "amp",
        unit: "N m",
        default_bounds: (0.0, 1.0),
        physical_range: (0.0, f32::MAX),
    },
    ParamSpec {
        id: ParamId::CogCycles,
        name: "cog_cycles",
        key: "cycles",
        unit: "",
        default_bounds: (1.0, 64.0),
        physical_range: (0.0, 1000.0),
    },
    ParamSpec {
        id: ParamId::CogPhase,
        name: "cog_phase",
        key: "phase",
        unit: "rad",
        default_bounds: (0.0, core::f32::consts::TAU),
        physical_range: (-1000.0, 1000.0),
    },
];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "cogging",
    physics: "detent torque cog_amp sin(cog_cycles theta + cog_phase) with the shaft angle",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 20 % of the stall torque, at 1 to 64 detents per revolution (the diagnosis
    // holds the number at the order the residual shows).
    search_bounds: |p, s| {
        let mut out = EffectBounds::new();
        for b in [
            (ParamId::CogAmp, 0.0, 0.2 * s.stall_torque(p)),
            (ParamId::CogCycles, 1.0, 64.0),
            (ParamId::CogPhase, 0.0, core::f32::consts::TAU),
        ] {
            let _ = out.push(b);
        }
        out
    },
    // Its speed ripple lives at an angle, not at a speed or current: the diagnosis finds it
    // in the residual's order spectrum instead.
    signature: None,
    shows_in: Some(regime::LOW_SPEED),
    limit: None,
    role: Role::HeldInputs(held),
};

/// Its held input: the detent torque at the step's starting angle, a load.
fn held(h: &Held, x: &StepState) -> HeldInputs {
    HeldInputs {
        volts: 0.0,
        load: torque(
            h.get(ParamId::CogAmp),
            h.get(ParamId::CogPhase),
            x.cogging_angle,
        ),
    }
}

/// The detent torque at `angle` = `cog_cycles theta` (wrapped).
#[inline(always)]
pub fn torque(amp: f32, phase: f32, angle: f32) -> f32 {
    amp * libm::sinf(angle + phase)
}
