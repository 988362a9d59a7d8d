//! The catalogue of unmodelled effects: names (a stable contract, see DESIGN.md) and the
//! parameters each one adds to the model. Their physics lives in [`crate::sim`].

use crate::params::ParamId;

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

    /// Stable name (DESIGN.md contract).
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
