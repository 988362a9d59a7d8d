//! The names of every model parameter: the five of paper Eq. 1-5 and those of the effects,
//! and the shape of what is known of each ([`ParamSpec`]). A vocabulary with no dependency,
//! so that errors, capacities and the model can all name a parameter; the specs themselves
//! live with the model ([`crate::model::params`], [`crate::model::effects`]).

use serde::{Deserialize, Serialize};

/// Every parameter the model has, by the name used on the command line and in JSON.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ParamId {
    /// Armature resistance Ra [ohm] (paper Eq. 1).
    Ra,
    /// Armature inductance La [H] (paper Eq. 1).
    La,
    /// Rotor inertia J [kg m^2] (paper Eq. 4).
    J,
    /// Viscous friction B [N m s/rad] (paper Eq. 4).
    B,
    /// Back-EMF / torque constant Kv [V s/rad] (paper Eq. 3).
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
    /// Break-away excess over the Coulomb torque [N m] (`static_friction`).
    Ts,
    /// Stribeck speed over which the break-away excess fades [rad/s] (`static_friction`).
    Ws,
    /// Direction asymmetry of the Coulomb torque, a fraction of it [-]: `tc (1 + ka)`
    /// forward, `tc (1 - ka)` backward (`asymmetric_friction`).
    Ka,
    /// Dead-time voltage error of the bridge [V] (`bridge_deadtime`).
    Vdt,
    /// Current band over which the dead-time error changes sign [A] (`bridge_deadtime`).
    Ib,
    /// Current sensor offset [A] (`current_offset`).
    Io,
}

/// Number of parameters in [`ParamId::ALL`].
pub const PARAM_COUNT: usize = 19;

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
        ParamId::Ts,
        ParamId::Ws,
        ParamId::Ka,
        ParamId::Vdt,
        ParamId::Ib,
        ParamId::Io,
    ];
    /// The five motor parameters of paper Eq. 5, in the order (Ra, La, J, B, Kv).
    pub const MOTOR: [ParamId; 5] = [
        ParamId::Ra,
        ParamId::La,
        ParamId::J,
        ParamId::B,
        ParamId::Kv,
    ];

    /// Position in [`ParamId::ALL`]: also the parameter's code on the wire and in the
    /// store (`docs/CONTRACTS.md`), so a new parameter is appended, never inserted.
    pub const fn index(self) -> usize {
        self as usize
    }

    /// True for the five motor parameters, which must be strictly positive.
    pub const fn is_motor(self) -> bool {
        (self as usize) < 5
    }
}

/// What the model knows of one parameter: its names, unit and ranges. The five motor
/// parameters' are in [`crate::model::params::MOTOR_SPECS`], each effect's in its entry of
/// the catalogue ([`crate::model::effects`]); [`ParamId::spec`] finds either.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamSpec {
    /// The parameter.
    pub id: ParamId,
    /// Name on the command line and in JSON (`ra`, `tc`, `ripple_amp`).
    pub name: &'static str,
    /// Key after `NAME:` in `simulate --effect NAME:key=val` (the name, or a shorter one).
    pub key: &'static str,
    /// Unit, as printed (empty for a ratio).
    pub unit: &'static str,
    /// Default search range: paper's Table 1 for the motor parameters, a generous range for an
    /// effect's (a fit usually narrows it to the motor at hand).
    pub default_bounds: (f32, f32),
    /// Smallest and largest physically meaningful value (inclusive), used to validate user
    /// input and fixed values.
    pub physical_range: (f32, f32),
}
