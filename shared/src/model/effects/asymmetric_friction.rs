//! `asymmetric_friction`: Coulomb friction that differs by direction (brush angle, a
//! preloaded gear or seal): `tc (1 + ka)` turning forward, `tc (1 - ka)` backward, with
//! `|ka| < 1`. It extends `coulomb_friction` (`tc` is that entry's): the diagnosis tries it
//! on top of it.
//!
//! The asymmetry is a fraction of the Coulomb torque, not a torque of its own: written as
//! `tc ± ta`, a fit could reach `|ta| > tc`, where the weaker direction's friction is
//! clamped at zero (a friction that never drives the shaft) and flat in both parameters, a
//! trap a local search does not leave; `ka` keeps both directions' friction positive and
//! smooth everywhere in its box.

use super::regime;
use super::entry::{ids, one, EffectSpec, Role, Signature};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Ka,
    name: "ka",
    key: "ka",
    unit: "",
    default_bounds: (-0.9, 0.9),
    physical_range: (-1.0, 1.0),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "asymmetric_friction",
    physics: "Coulomb friction tc (1 + ka) forward and tc (1 - ka) backward",
    needs_current: false,
    extends: Some("coulomb_friction"),
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 90 % of the Coulomb torque either way.
    search_bounds: |_, _| one(ParamId::Ka, -0.9, 0.9),
    // A friction `ka tc` larger forward and smaller backward is a constant torque
    // `-ka tc` on a turning shaft: the measured speed falls short in both directions alike.
    signature: Some(Signature {
        label: "minus one while turning",
        at: |x| -((x.omega.abs() > 0.02 * x.omega_max) as i32 as f64),
    }),
    shows_in: Some(regime::STANDSTILL),
    limit: None,
    role: Role::FrictionLaw,
};

/// Its change of the Coulomb torque `tc` for a motion in `direction` (+1, -1).
#[inline(always)]
pub fn excess(tc: f32, ka: f32, direction: f32) -> f32 {
    tc * ka * direction
}
