//! `coulomb_friction`: a constant friction torque against the motion, `tc sign(w)`, added
//! to the load of paper Eq. 4, with stiction: a shaft at rest stays there while the drive
//! torque `Kv i - tl` stays within `tc` (the dead zone of [`crate::model::sim`]).

use super::regime;
use super::entry::{ids, one, EffectSpec, Role, Signature};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Tc,
    name: "tc",
    key: "tc",
    unit: "N m",
    default_bounds: (0.0, 1.0),
    physical_range: (0.0, f32::MAX),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "coulomb_friction",
    physics: "constant friction torque tc sign(w) against the motion; at rest the shaft sticks while the drive torque stays within tc",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to half the stall torque.
    search_bounds: |p, s| one(ParamId::Tc, 0.0, 0.5 * s.stall_torque(p)),
    // The model lacks a torque against the motion: the measured speed falls short of it by
    // a step with the direction of motion (outside a band around standstill).
    signature: Some(Signature {
        label: "minus sign of speed",
        at: |x| -x.omega.signum() * (x.omega.abs() > 0.02 * x.omega_max) as i32 as f64,
    }),
    shows_in: Some(regime::STANDSTILL),
    limit: None,
    role: Role::ShaftDeadZone,
};

/// The friction torque over a step of a shaft turning in `direction` (+1 or -1): the
/// threshold of the shaft's dead zone.
#[inline(always)]
pub fn torque(tc: f32, direction: f32) -> f32 {
    tc * direction
}
