//! `asymmetric_friction`: Coulomb friction that differs by direction (brush angle, a
//! preloaded gear or seal): `tc + ta` turning forward, `tc - ta` backward (never below
//! zero). It extends `coulomb_friction` (`tc` is that entry's): the diagnosis tries it on
//! top of it.

use super::entry::{ids, one, EffectSpec, Signature};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Ta,
    name: "ta",
    key: "ta",
    unit: "N m",
    default_bounds: (-0.5, 0.5),
    physical_range: (-f32::MAX, f32::MAX),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "asymmetric_friction",
    physics: "Coulomb friction tc + ta forward and tc - ta backward",
    needs_current: false,
    extends: Some("coulomb_friction"),
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to a quarter of the stall torque either way.
    search_bounds: |p, s| {
        let t = 0.25 * s.stall_torque(p);
        one(ParamId::Ta, -t, t)
    },
    // A friction `ta` larger forward and smaller backward is a constant torque `-ta` on a
    // turning shaft: the measured speed falls short in both directions alike.
    signature: Some(Signature {
        label: "minus one while turning",
        at: |x| -((x.omega.abs() > 0.02 * x.omega_max) as i32 as f64),
    }),
};

/// Its change of the friction magnitude for a motion in `direction` (+1, -1).
#[inline(always)]
pub fn excess(ta: f32, direction: f32) -> f32 {
    ta * direction
}
