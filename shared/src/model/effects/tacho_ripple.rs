//! `tacho_ripple`: the tacho reading is modulated with rotor angle (commutator slots, an
//! eccentric or unevenly spaced encoder disc):
//! `w (1 + ripple_amp sin(ripple_cycles theta + ripple_phase))`. The angle follows the
//! measured speed when a fit gives it (see [`crate::model::sim::Simulator::apply`]).

use super::entry::{ids, EffectBounds, EffectSpec, Role};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        id: ParamId::RippleAmp,
        name: "ripple_amp",
        key: "amp",
        unit: "",
        default_bounds: (0.0, 0.2),
        physical_range: (0.0, 0.9),
    },
    ParamSpec {
        id: ParamId::RippleCycles,
        name: "ripple_cycles",
        key: "cycles",
        unit: "",
        default_bounds: (1.0, 64.0),
        physical_range: (0.0, 1000.0),
    },
    ParamSpec {
        id: ParamId::RipplePhase,
        name: "ripple_phase",
        key: "phase",
        unit: "rad",
        default_bounds: (0.0, core::f32::consts::TAU),
        physical_range: (-1000.0, 1000.0),
    },
];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "tacho_ripple",
    physics: "tacho reading modulated with rotor angle: w (1 + amp sin(cycles theta + phase))",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 20 % at 1 to 64 cycles per revolution.
    search_bounds: |_, _| {
        let mut out = EffectBounds::new();
        for b in [
            (ParamId::RippleAmp, 0.0, 0.2),
            (ParamId::RippleCycles, 1.0, 64.0),
            (ParamId::RipplePhase, 0.0, core::f32::consts::TAU),
        ] {
            let _ = out.push(b);
        }
        out
    },
    // Found by the order spectrum of the residual against rotor angle, not a correlation.
    signature: None,
    role: Role::Reading,
};

/// The tacho reading of shaft speed `w` at ripple angle `psi` (`ripple_cycles theta`).
#[inline(always)]
pub fn reading(amp: f32, phase: f32, w: f32, psi: f32) -> f32 {
    if amp == 0.0 {
        w
    } else {
        w * (1.0 + amp * libm::sinf(psi + phase))
    }
}

/// The ripple angle after a step of `dt` at mean speed `rate`, wrapped to [-pi, pi] so
/// that f32 sin stays accurate on long records.
#[inline(always)]
pub fn advance(psi: f32, cycles: f32, rate: f32, dt: f32) -> f32 {
    libm::remainderf(psi + cycles * rate * dt, core::f32::consts::TAU)
}
