//! The conversion of an identification into the report the board sends and stores.

use crate::fit::identify::Identification;
use crate::param_id::ParamId;
use crate::wire::protocol::{Estimate, MotorReport};

/// Report of an identification in the message form: the five motor parameters, then every
/// other parameter the identification fitted, each with its standard deviation (NaN when
/// the data does not pin it, or when it was held fixed). `None` when the estimates do not fit
/// the report's capacity (more effect parameters than a board reports; the board's own
/// problems, a streamed record's five and commissioning's six, always fit).
pub fn motor_report(id: &Identification) -> Option<MotorReport> {
    let mut estimates = heapless::Vec::new();
    for p in ParamId::ALL {
        let certainty = id.identifiability.params.iter().find(|c| c.id == p);
        if !(p.is_motor() || certainty.is_some()) {
            continue;
        }
        let estimate = Estimate {
            param: p.index() as u8,
            value: id.params.get(p),
            std: certainty.and_then(|c| c.std).unwrap_or(f32::NAN),
        };
        estimates.push(estimate).ok()?;
    }
    Some(MotorReport {
        estimates,
        rmse_omega: id.cost.rmse_omega,
        evaluations: id.evaluations,
        rank: id.identifiability.rank as u8,
    })
}
