//! A full parameter set: the five motor parameters of paper Eq. 1-5 and the parameters of the
//! optional effects, with their validation.

use crate::capacity::MODEL_PARAMS;
use crate::error::Error;
use crate::param_id::{ParamId, ParamSpec};
use serde::{Deserialize, Serialize};

/// The five motor parameters of paper Eq. 1-5: units, paper's Table 1 bounds, and the
/// physical range (strictly positive; viscous friction may vanish).
pub const MOTOR_SPECS: [ParamSpec; 5] = [
    motor_spec(ParamId::Ra, "ra", "ohm", (0.5, 10.0)),
    motor_spec(ParamId::La, "la", "H", (0.01, 2.0)),
    motor_spec(ParamId::J, "j", "kg m^2", (0.001, 1.0)),
    ParamSpec {
        physical_range: (0.0, f32::MAX),
        ..motor_spec(ParamId::B, "b", "N m s/rad", (0.0005, 1.0))
    },
    motor_spec(ParamId::Kv, "kv", "V s/rad", (0.01, 2.0)),
];

const fn motor_spec(
    id: ParamId,
    name: &'static str,
    unit: &'static str,
    table_1: (f32, f32),
) -> ParamSpec {
    ParamSpec {
        id,
        name,
        key: name,
        unit,
        default_bounds: table_1,
        physical_range: (f32::MIN_POSITIVE, f32::MAX),
    }
}

/// A full parameter set: motor (paper Eq. 5) plus every effect. An effect whose parameter is
/// zero is absent, so `ModelParams::motor(..)` is the paper's linear model.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct ModelParams {
    /// The first [`MODEL_PARAMS`] parameters in [`ParamId`] order (all on the host); the
    /// others read as their default.
    values: [f32; MODEL_PARAMS],
}

impl ModelParams {
    /// The value parameter `id` reads when it is not set: 0 (off), and one ripple cycle per
    /// revolution.
    pub const fn default_of(id: ParamId) -> f32 {
        match id {
            ParamId::RippleCycles => 1.0,
            _ => 0.0,
        }
    }

    /// The paper's identified motor (Section 6): Ra 3.412, La 0.0573, J 0.0424,
    /// B 0.00267, Kv 0.1604.
    pub const PAPER_MOTOR: ModelParams = ModelParams::motor(3.412, 0.0573, 0.0424, 0.00267, 0.1604);

    /// A linear motor without effects.
    pub const fn motor(ra: f32, la: f32, j: f32, b: f32, kv: f32) -> ModelParams {
        let mut values = [0.0; MODEL_PARAMS];
        let mut k = 0;
        while k < MODEL_PARAMS {
            values[k] = ModelParams::default_of(ParamId::ALL[k]);
            k += 1;
        }
        values[0] = ra;
        values[1] = la;
        values[2] = j;
        values[3] = b;
        values[4] = kv;
        ModelParams { values }
    }

    /// Value of one parameter (its default for one this build does not hold).
    #[inline(always)]
    pub fn get(&self, id: ParamId) -> f32 {
        match self.values.get(id.index()) {
            Some(v) => *v,
            None => ModelParams::default_of(id),
        }
    }

    /// Set one parameter. A parameter this build does not hold ([`MODEL_PARAMS`]: a board's
    /// are the five and `tc`) keeps its default; a problem refuses to fix or bound one
    /// ([`crate::Error::EffectNotInBuild`]).
    pub fn set(&mut self, id: ParamId, value: f32) {
        if let Some(v) = self.values.get_mut(id.index()) {
            *v = value;
        }
    }

    /// Builder form of [`ModelParams::set`].
    pub fn with(mut self, id: ParamId, value: f32) -> ModelParams {
        self.set(id, value);
        self
    }

    /// Check that motor parameters are finite and positive and effects are in range.
    pub fn validate(&self) -> Result<(), Error> {
        for id in ParamId::ALL {
            let v = self.get(id);
            let (lo, hi) = id.physical_range();
            if !v.is_finite() || v < lo || v > hi {
                return Err(if id.is_motor() {
                    Error::NonPositiveParameter(id)
                } else {
                    Error::InvalidEffectParameter(id)
                });
            }
        }
        Ok(())
    }
}
