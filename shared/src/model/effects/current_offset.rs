//! `current_offset`: the current sensor reads an offset `io` (a shunt amplifier's or a Hall
//! sensor's zero error): the reading is `i + io` while the motor carries `i`. It acts on the
//! current channel only, so only records with current show it.

use super::regime;
use super::entry::{ids, one, EffectSpec, Role};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Io,
    name: "io",
    key: "io",
    unit: "A",
    default_bounds: (-1.0, 1.0),
    physical_range: (-f32::MAX, f32::MAX),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "current_offset",
    physics: "the current sensor reads i + io",
    needs_current: true,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 10 % of the largest current either way.
    search_bounds: |_, s| {
        let i = 0.1 * s.current_max.max(1e-6);
        one(ParamId::Io, -i, i)
    },
    // No mark on the speed: it shows in the current residual as a constant.
    signature: None,
    shows_in: Some(regime::STANDSTILL),
    limit: None,
    role: Role::Reading,
};

/// The current reading of armature current `i`.
#[inline(always)]
pub fn reading(io: f32, i: f32) -> f32 {
    if io == 0.0 {
        i
    } else {
        i + io
    }
}
