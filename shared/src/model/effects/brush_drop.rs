//! `brush_drop`: the brushes take a constant voltage `vb` with the sign of the current from
//! paper Eq. 1; no current flows while the driving voltage `v - Kv w` stays within `vb` (the
//! dead zone of [`crate::model::sim`] on the current).

use super::regime;
use super::entry::{ids, one, EffectSpec, Role, Signature};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Vb,
    name: "vb",
    key: "vb",
    unit: "V",
    default_bounds: (0.0, 5.0),
    physical_range: (0.0, f32::MAX),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "brush_drop",
    physics: "constant brush voltage drop vb with the sign of the current; no current below it",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 30 % of the voltage.
    search_bounds: |_, s| one(ParamId::Vb, 0.0, 0.3 * s.v_max),
    signature: Some(Signature {
        label: "minus sign of current",
        at: |x| -x.current.signum() * (x.current.abs() > 0.02 * x.current_max) as i32 as f64,
    }),
    shows_in: Some(regime::STANDSTILL),
    limit: None,
    role: Role::CurrentDeadZone,
};

/// The voltage it takes over a step with current flowing in `direction` (+1 or -1): the
/// threshold of the current's dead zone.
#[inline(always)]
pub fn voltage(vb: f32, direction: f32) -> f32 {
    vb * direction
}
