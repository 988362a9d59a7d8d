//! The names of every model parameter: the five of paper Eq. 1-5 and those of the effects,
//! and the shape of what is known of each ([`ParamSpec`]). A vocabulary that depends on
//! nothing but the table of parameters and effects ([`crate::catalogue`]), so that errors,
//! capacities and the model can all name a parameter; the specs themselves live with the
//! model ([`crate::model::params`], [`crate::model::effects`]).

use serde::{Deserialize, Serialize};

/// The enum of every parameter and the list of them, from the table's rows.
macro_rules! param_ids {
    (
        motor [$($(#[$motor_doc:meta])* $motor:ident),*]
        entries [$(
            $(#[$entry_doc:meta])* $entry:ident $module:ident [$($(#[$doc:meta])* $param:ident),*]
        )*]
    ) => {
        /// Every parameter the model has, by the name used on the command line and in JSON:
        /// the motor's, then each effect's, in the order of the table
        /// ([`crate::catalogue`]).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum ParamId {
            $($(#[$motor_doc])* $motor,)*
            $($($(#[$doc])* $param,)*)*
        }

        /// Every parameter, in the table's order.
        const LISTED: &[ParamId] = &[$(ParamId::$motor,)* $($(ParamId::$param,)*)*];
    };
}

crate::catalogue::catalogue_table!(param_ids);

/// Number of parameters in [`ParamId::ALL`].
pub const PARAM_COUNT: usize = LISTED.len();

impl ParamId {
    /// All parameters, in storage order.
    pub const ALL: [ParamId; PARAM_COUNT] = crate::catalogue::listed(LISTED);
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
