//! `quadratic_load`: a fan or pump load whose torque grows with the square of the speed,
//! `kq w |w|`, added to the load of paper Eq. 4.

use super::regime;
use super::entry::{ids, one, EffectSpec, Role, Signature};
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
    shows_in: Some(regime::HIGH_SPEED),
    limit: None,
    role: Role::SpeedLoad,
};

/// Its load torque at speed `w`, held over a step.
#[inline(always)]
pub fn torque(kq: f32, w: f32) -> f32 {
    kq * w * w.abs()
}

/// The load at a step's end, `kq w1 |w1|`, where the speed at the end solves
/// `w1 = w + g kq w1 |w1|`, with `w` the step's end without the load and `g < 0` the speed
/// one newton-metre held over the step takes. `w1` keeps the sign of `w` (the load only
/// slows the shaft) and `|w1| = 2 |w| / (sqrt(1 + 4 a |w|) + 1)` with `a = -g kq` (the root
/// of `a w1^2 + w1 = |w|`, written without cancellation). The load, not the speed, is
/// returned: `w1 - w` is a rounding of `w` where the load is small, while the load keeps
/// its relative precision (a fit's finite differences in `kq` see it).
#[inline(always)]
pub fn torque_at_step_end(kq: f32, g: f32, w: f32) -> f32 {
    let a = -g * kq;
    if a <= 0.0 || w == 0.0 {
        return torque(kq, w);
    }
    let magnitude = 2.0 * w.abs() / (libm::sqrtf(1.0 + 4.0 * a * w.abs()) + 1.0);
    torque(kq, magnitude.copysign(w))
}
