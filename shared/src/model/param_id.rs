//! The names of every model parameter: the five of seed Eq. 1-5 and those of the effects.
//! A vocabulary with no dependency, so that errors can name a parameter.

use serde::{Deserialize, Serialize};

/// Every parameter the model has, by the name used on the command line and in JSON.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamId {
    /// Armature resistance Ra [ohm] (seed Eq. 1).
    Ra,
    /// Armature inductance La [H] (seed Eq. 1).
    La,
    /// Rotor inertia J [kg m^2] (seed Eq. 4).
    J,
    /// Viscous friction B [N m s/rad] (seed Eq. 4).
    B,
    /// Back-EMF / torque constant Kv [V s/rad] (seed Eq. 3).
    Kv,
    /// Coulomb friction torque [N m] (`coulomb_friction`).
    Tc,
    /// Fan/pump load coefficient [N m s^2/rad^2], torque `kq * w * |w|` (`quadratic_load`).
    Kq,
    /// Flux weakening per ampere [1/A], flux factor `1 - kar * |i|` (`armature_reaction`).
    Kar,
    /// Brush voltage drop [V] with the sign of the current (`brush_drop`).
    Vb,
    /// Tacho delay [s] (`sensor_delay`).
    Td,
    /// Relative tacho ripple amplitude [-] (`tacho_ripple`).
    RippleAmp,
    /// Ripple cycles per mechanical revolution [-] (`tacho_ripple`).
    RippleCycles,
    /// Ripple phase [rad] (`tacho_ripple`).
    RipplePhase,
}

/// Number of parameters in [`ParamId::ALL`].
pub const PARAM_COUNT: usize = 13;

impl ParamId {
    /// All parameters, in storage order.
    pub const ALL: [ParamId; PARAM_COUNT] = [
        ParamId::Ra,
        ParamId::La,
        ParamId::J,
        ParamId::B,
        ParamId::Kv,
        ParamId::Tc,
        ParamId::Kq,
        ParamId::Kar,
        ParamId::Vb,
        ParamId::Td,
        ParamId::RippleAmp,
        ParamId::RippleCycles,
        ParamId::RipplePhase,
    ];
    /// The five motor parameters of seed Eq. 5, in the order (Ra, La, J, B, Kv).
    pub const MOTOR: [ParamId; 5] = [
        ParamId::Ra,
        ParamId::La,
        ParamId::J,
        ParamId::B,
        ParamId::Kv,
    ];

    /// Position in [`ParamId::ALL`].
    pub const fn index(self) -> usize {
        self as usize
    }

    /// Name on the command line and in JSON.
    pub const fn name(self) -> &'static str {
        match self {
            ParamId::Ra => "ra",
            ParamId::La => "la",
            ParamId::J => "j",
            ParamId::B => "b",
            ParamId::Kv => "kv",
            ParamId::Tc => "tc",
            ParamId::Kq => "kq",
            ParamId::Kar => "kar",
            ParamId::Vb => "vb",
            ParamId::Td => "td",
            ParamId::RippleAmp => "ripple_amp",
            ParamId::RippleCycles => "ripple_cycles",
            ParamId::RipplePhase => "ripple_phase",
        }
    }

    /// Parse a name as printed by [`ParamId::name`].
    pub fn from_name(name: &str) -> Option<ParamId> {
        ParamId::ALL.iter().copied().find(|p| p.name() == name)
    }

    /// True for the five motor parameters, which must be strictly positive.
    pub const fn is_motor(self) -> bool {
        (self as usize) < 5
    }

    /// Seed Table 1 bounds for the motor parameters; for effect parameters a default search
    /// range that a caller usually narrows to the motor at hand.
    pub const fn default_bounds(self) -> (f32, f32) {
        match self {
            ParamId::Ra => (0.5, 10.0),
            ParamId::La => (0.01, 2.0),
            ParamId::J => (0.001, 1.0),
            ParamId::B => (0.0005, 1.0),
            ParamId::Kv => (0.01, 2.0),
            ParamId::Tc => (0.0, 1.0),
            ParamId::Kq => (0.0, 1e-3),
            ParamId::Kar => (0.0, 0.1),
            ParamId::Vb => (0.0, 5.0),
            ParamId::Td => (0.0, 0.02),
            ParamId::RippleAmp => (0.0, 0.2),
            ParamId::RippleCycles => (1.0, 64.0),
            ParamId::RipplePhase => (0.0, core::f32::consts::TAU),
        }
    }

    /// Smallest and largest physically meaningful value (inclusive), used to validate
    /// user input and fixed values.
    pub const fn physical_range(self) -> (f32, f32) {
        match self {
            ParamId::Ra | ParamId::La | ParamId::J | ParamId::Kv => (f32::MIN_POSITIVE, f32::MAX),
            ParamId::B => (0.0, f32::MAX),
            ParamId::Kar => (0.0, 10.0),
            ParamId::RippleAmp => (0.0, 0.9),
            ParamId::RippleCycles => (0.0, 1000.0),
            ParamId::RipplePhase => (-1000.0, 1000.0),
            _ => (0.0, f32::MAX),
        }
    }
}
