//! `static_friction`: break-away above the sliding friction (the Stribeck effect). A shaft
//! at rest breaks away only when the drive torque exceeds `tc + ts`; turning, the friction
//! falls from there towards the Coulomb torque `tc` over a speed scale `ws`:
//! `F(w) = tc + ts exp(-(w/ws)^2)` (Armstrong-Hélouvry's static + Coulomb + Stribeck
//! model, without its viscous term, which is paper Eq. 4's `B w`). It extends
//! `coulomb_friction` (`tc` is that entry's): the diagnosis tries it on top of it.

use super::regime;
use super::entry::{ids, EffectBounds, EffectSpec, Role, Signature};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 2] = [
    ParamSpec {
        id: ParamId::Ts,
        name: "ts",
        key: "ts",
        unit: "N m",
        default_bounds: (0.0, 1.0),
        physical_range: (0.0, f32::MAX),
    },
    ParamSpec {
        id: ParamId::Ws,
        name: "ws",
        key: "ws",
        unit: "rad/s",
        default_bounds: (0.01, 100.0),
        physical_range: (0.0, f32::MAX),
    },
];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "static_friction",
    physics:
        "break-away torque tc + ts at rest, friction falling as tc + ts exp(-(w/ws)^2) once turning",
    needs_current: false,
    extends: Some("coulomb_friction"),
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // A break-away excess up to half the stall torque, over a speed scale from 0.1 % to
    // 15 % of the top speed: a break-away's excess is gone (under 2 % of it, at twice `ws`)
    // within the low speeds (under 30 % of the top speed), where its form shows. A wider
    // scale is no break-away: an excess fading over the whole speed range, with a larger
    // viscous `B`, bends the friction's curve like a fan load's `kq w^2` (a Coulomb friction
    // beside a fan load was named `static_friction` with `ws` at 20-30 % of the top speed,
    // docs/measurements/blind-checks.md).
    search_bounds: |p, s| {
        let w = s.omega_max.max(1e-6);
        let mut out = EffectBounds::new();
        let _ = out.push((ParamId::Ts, 0.0, 0.5 * s.stall_torque(p)));
        let _ = out.push((ParamId::Ws, 1e-3 * w, 0.15 * w));
        out
    },
    // The model lacks friction that is larger near standstill: the measured speed falls
    // short of it at low speed, in the direction of motion.
    signature: Some(Signature {
        label: "minus sign of speed at low speed",
        at: |x| {
            let low = x.omega.abs() > 0.005 * x.omega_max && x.omega.abs() < 0.1 * x.omega_max;
            -x.omega.signum() * low as i32 as f64
        },
    }),
    shows_in: Some(regime::STANDSTILL),
    limit: None,
    role: Role::FrictionLaw,
};

/// The excess of friction over the Coulomb torque at speed `w`: `ts exp(-(w/ws)^2)` (all
/// of `ts` at rest; none once turning when `ws` is 0).
#[inline(always)]
pub fn excess(ts: f32, ws: f32, w: f32) -> f32 {
    if w == 0.0 {
        ts
    } else if ws > 0.0 {
        let x = w / ws;
        ts * libm::expf(-x * x)
    } else {
        0.0
    }
}
