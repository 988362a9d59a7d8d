//! `quadratic_load`: a fan or pump load whose torque grows with the square of the speed,
//! `kq w |w|`, added to the load of paper Eq. 4.

use super::entry::{ids, one, EffectSpec, Held, HeldInputs, Role, Signature, StepState};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Kq,
    name: "kq",
    key: "kq",
    unit: "N m s^2/rad^2",
    default_bounds: (0.0, 1e-3),
    physical_range: (0.0, f32::MAX),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "quadratic_load",
    physics: "fan or pump load torque kq w |w|",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to a load that takes the whole stall torque at the top speed.
    search_bounds: |p, s| {
        let w = s.omega_max.max(1e-6);
        one(ParamId::Kq, 0.0, s.stall_torque(p) / (w * w))
    },
    signature: Some(Signature {
        label: "minus speed*|speed|",
        at: |x| -x.omega * x.omega.abs(),
    }),
    role: Role::HeldInputs(held),
};

/// Its load torque at speed `w`, held over a step.
#[inline(always)]
pub fn torque(kq: f32, w: f32) -> f32 {
    kq * w * w.abs()
}

/// Its held inputs: the load torque at the step's starting speed.
fn held(h: &Held, x: &StepState) -> HeldInputs {
    HeldInputs {
        volts: 0.0,
        load: torque(h.get(ParamId::Kq), x.omega),
    }
}
