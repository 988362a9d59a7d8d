//! The conversion of an identification into the report the board sends and stores.

use crate::fit::identify::Identification;
use crate::model::params::ParamId;
use crate::wire::protocol::{Estimate, MotorReport};

/// Report of an identification in the message form.
pub fn motor_report(id: &Identification) -> MotorReport {
    // A free parameter's value and standard deviation (NaN when not pinned); `None` for a
    // parameter that was not identified.
    let estimate = |p: ParamId| {
        let certainty = id.identifiability.params.iter().find(|c| c.id == p)?;
        Some(Estimate {
            value: id.params.get(p),
            std: certainty.std.unwrap_or(f32::NAN),
        })
    };
    let mut params = [0.0f32; 5];
    let mut std = [f32::NAN; 5];
    for (k, p) in ParamId::MOTOR.iter().enumerate() {
        params[k] = id.params.get(*p);
        if let Some(e) = estimate(*p) {
            std[k] = e.std;
        }
    }
    MotorReport {
        params,
        std,
        friction: estimate(ParamId::Tc),
        rmse_omega: id.cost.rmse_omega,
        evaluations: id.evaluations,
        rank: id.identifiability.rank as u8,
    }
}
