//! `armature_reaction`: the armature's own field weakens the main flux as the current
//! grows, so the back-EMF and torque constant of paper Eq. 2-3 fall to `kv (1 - kar |i|)`
//! (kept above a tenth). The linear step keeps `kv`; the loss enters as held inputs: the
//! voltage gains back `(1 - flux) kv w` and the torque loses `(1 - flux) kv i`.

use super::regime;
use super::entry::{ids, one, EffectSpec, Held, HeldInputs, Role, Signature, StepState};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Kar,
    name: "kar",
    key: "kar",
    unit: "1/A",
    default_bounds: (0.0, 0.1),
    physical_range: (0.0, 10.0),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "armature_reaction",
    physics: "flux falls with current: back-EMF and torque constant kv (1 - kar |i|)",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 50 % flux loss at the largest current.
    search_bounds: |_, s| one(ParamId::Kar, 0.0, 0.5 / s.current_max.max(1e-6)),
    signature: Some(Signature {
        label: "current*|current|",
        at: |x| x.current * x.current.abs(),
    }),
    shows_in: Some(regime::ACCELERATION),
    limit: None,
    role: Role::HeldInputs(held),
};

/// Flux factor `1 - kar |i|`, kept above 0.1.
#[inline(always)]
pub fn flux_factor(kar: f32, i: f32) -> f32 {
    if kar == 0.0 {
        1.0
    } else {
        (1.0 - kar * i.abs()).max(0.1)
    }
}

/// The lost part of the constant, `(1 - flux) kv`, at current `i`.
#[inline(always)]
pub fn lost_constant(kar: f32, kv: f32, i: f32) -> f32 {
    (1.0 - flux_factor(kar, i)) * kv
}

/// Its held inputs at the step's start: the voltage gains back `(1 - flux) kv w`, the torque
/// loses `(1 - flux) kv i` (a load).
fn held(h: &Held, x: &StepState) -> HeldInputs {
    let lost = lost_constant(h.get(ParamId::Kar), x.kv, x.current);
    HeldInputs {
        volts: lost * x.omega,
        load: lost * x.current,
    }
}
