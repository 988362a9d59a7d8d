//! `sensor_delay`: the tacho reading lags the shaft by `td` seconds (filtering, the
//! converter's conversion time); the simulator reads it from a delay line, interpolating
//! between samples.

use super::regime;
use super::entry::{ids, one, EffectSpec, Role, Signature};
use crate::capacity::MAX_DELAY_SAMPLES;
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 1] = [ParamSpec {
    id: ParamId::Td,
    name: "td",
    key: "td",
    unit: "s",
    default_bounds: (0.0, 0.02),
    physical_range: (0.0, f32::MAX),
}];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "sensor_delay",
    physics: "the tacho reading lags the shaft by td",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to what the simulator's delay line holds.
    search_bounds: |_, s| one(ParamId::Td, 0.0, MAX_DELAY_SAMPLES as f32 * s.dt),
    // A lagging reading is the speed a moment ago: w(t - td) - w(t) ~ -td dw/dt.
    signature: Some(Signature {
        label: "minus acceleration",
        at: |x| -x.accel,
    }),
    shows_in: Some(regime::TRANSIENTS),
    limit: None,
    role: Role::ReadingDelay,
};

/// The delay in samples at step `dt`, split into whole samples and a fraction; `None` when
/// it exceeds the delay line.
#[inline(always)]
pub fn in_samples(td: f32, dt: f32) -> Option<(u8, f32)> {
    let delay = td / dt;
    if delay > MAX_DELAY_SAMPLES as f32 {
        return None;
    }
    // At most MAX_DELAY_SAMPLES (checked above), so it fits a ring position.
    let whole = libm::floorf(delay) as u8;
    Some((whole, delay - whole as f32))
}

/// The reading between the delay line's samples `a` (whole samples back) and `b` (one
/// more), at `frac` of the way.
#[inline(always)]
pub fn interpolate(a: f32, b: f32, frac: f32) -> f32 {
    a + frac * (b - a)
}
