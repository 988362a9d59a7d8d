//! A full parameter set: the five motor parameters of paper Eq. 1-5 and the parameters of the
//! optional effects, with their validation.

use crate::error::Error;
use crate::param_id::{ParamId, ParamSpec, PARAM_COUNT};
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
    values: [f32; PARAM_COUNT],
}

impl ModelParams {
    /// The paper's identified motor (Section 6): Ra 3.412, La 0.0573, J 0.0424,
    /// B 0.00267, Kv 0.1604.
    pub const PAPER_MOTOR: ModelParams = ModelParams::motor(3.412, 0.0573, 0.0424, 0.00267, 0.1604);

    /// A linear motor without effects.
    pub const fn motor(ra: f32, la: f32, j: f32, b: f32, kv: f32) -> ModelParams {
        let mut values = [0.0; PARAM_COUNT];
        values[0] = ra;
        values[1] = la;
        values[2] = j;
        values[3] = b;
        values[4] = kv;
        values[ParamId::RippleCycles as usize] = 1.0;
        ModelParams { values }
    }

    /// Value of one parameter.
    pub fn get(&self, id: ParamId) -> f32 {
        self.values[id.index()]
    }

    /// Set one parameter.
    pub fn set(&mut self, id: ParamId, value: f32) {
        self.values[id.index()] = value;
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
