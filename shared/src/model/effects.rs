//! The catalogue of unmodelled effects: names (a stable contract, see `docs/CONTRACTS.md`) and the
//! parameters each one adds to the model. Their physics lives in [`crate::model::sim`].

use crate::capacity::MAX_DELAY_SAMPLES;
use crate::model::params::{ModelParams, ParamId};

/// One effect that the linear model of seed Eq. 5 lacks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Effect {
    /// Constant friction torque `tc * sign(w)`, with stiction at standstill.
    CoulombFriction,
    /// Fan or pump load `kq * w * |w|`.
    QuadraticLoad,
    /// Flux falls with current: back-EMF and torque constant `kv * (1 - kar * |i|)`.
    ArmatureReaction,
    /// Constant brush voltage drop `vb` with the sign of the current (no current below it).
    BrushDrop,
    /// The tacho reading lags the shaft by `td` seconds.
    SensorDelay,
    /// The tacho reading is modulated with rotor angle:
    /// `w * (1 + ripple_amp * sin(ripple_cycles * theta + ripple_phase))`.
    TachoRipple,
}

impl Effect {
    /// The whole catalogue.
    pub const ALL: [Effect; 6] = [
        Effect::CoulombFriction,
        Effect::QuadraticLoad,
        Effect::ArmatureReaction,
        Effect::BrushDrop,
        Effect::SensorDelay,
        Effect::TachoRipple,
    ];

    /// Stable name (`docs/CONTRACTS.md`, parameters and effects).
    pub const fn name(self) -> &'static str {
        match self {
            Effect::CoulombFriction => "coulomb_friction",
            Effect::QuadraticLoad => "quadratic_load",
            Effect::ArmatureReaction => "armature_reaction",
            Effect::BrushDrop => "brush_drop",
            Effect::SensorDelay => "sensor_delay",
            Effect::TachoRipple => "tacho_ripple",
        }
    }

    /// Parse a stable name.
    pub fn from_name(name: &str) -> Option<Effect> {
        Effect::ALL.iter().copied().find(|e| e.name() == name)
    }

    /// The parameters this effect adds. The first one switches the effect on (non-zero).
    pub const fn params(self) -> &'static [ParamId] {
        match self {
            Effect::CoulombFriction => &[ParamId::Tc],
            Effect::QuadraticLoad => &[ParamId::Kq],
            Effect::ArmatureReaction => &[ParamId::Kar],
            Effect::BrushDrop => &[ParamId::Vb],
            Effect::SensorDelay => &[ParamId::Td],
            Effect::TachoRipple => &[
                ParamId::RippleAmp,
                ParamId::RippleCycles,
                ParamId::RipplePhase,
            ],
        }
    }

    /// The short key of a parameter as written after `NAME:` on the command line
    /// (`tacho_ripple:amp=0.02,cycles=8,phase=0`); the full name is accepted too.
    pub const fn short_key(id: ParamId) -> &'static str {
        match id {
            ParamId::RippleAmp => "amp",
            ParamId::RippleCycles => "cycles",
            ParamId::RipplePhase => "phase",
            other => other.name(),
        }
    }
}

/// Magnitudes of an experiment that set the search range of effect parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scales {
    /// Largest |armature voltage| [V].
    pub v_max: f32,
    /// Largest |speed| [rad/s].
    pub omega_max: f32,
    /// Largest |current| [A] (measured, or estimated as `v_max / Ra`).
    pub current_max: f32,
    /// Sample step [s] (the smallest over the records).
    pub dt: f32,
}

impl Effect {
    /// Search bounds of this effect's parameters for motor `p` in an experiment of `s`:
    /// friction up to half the stall torque `Kv v_max / Ra` (seed Eq. 1-4 at standstill), a
    /// fan load that takes up to the stall torque at top speed, flux weakening up to 50 % at
    /// the largest current, a brush drop up to 30 % of the voltage, a tacho delay up to what
    /// the simulator holds, a ripple up to 20 % at 1 to 64 cycles per revolution.
    pub fn bounds(self, p: &ModelParams, s: &Scales) -> heapless::Vec<(ParamId, f32, f32), 3> {
        let stall = p.get(ParamId::Kv) * s.v_max / p.get(ParamId::Ra);
        let w = s.omega_max.max(1e-6);
        let mut out = heapless::Vec::new();
        let mut add = |id: ParamId, lo: f32, hi: f32| {
            let _ = out.push((id, lo, hi.max(lo + f32::EPSILON)));
        };
        match self {
            Effect::CoulombFriction => add(ParamId::Tc, 0.0, 0.5 * stall),
            Effect::QuadraticLoad => add(ParamId::Kq, 0.0, stall / (w * w)),
            Effect::ArmatureReaction => add(ParamId::Kar, 0.0, 0.5 / s.current_max.max(1e-6)),
            Effect::BrushDrop => add(ParamId::Vb, 0.0, 0.3 * s.v_max),
            Effect::SensorDelay => add(ParamId::Td, 0.0, MAX_DELAY_SAMPLES as f32 * s.dt),
            Effect::TachoRipple => {
                add(ParamId::RippleAmp, 0.0, 0.2);
                add(ParamId::RippleCycles, 1.0, 64.0);
                add(ParamId::RipplePhase, 0.0, core::f32::consts::TAU);
            }
        }
        out
    }
}
