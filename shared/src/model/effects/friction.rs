//! The shaft's friction law, composed of the friction entries of the catalogue: the
//! Coulomb torque `tc` of [`super::coulomb_friction`], raised near standstill by
//! [`super::static_friction`] and by direction by [`super::asymmetric_friction`]. The
//! simulator's dead zone on the shaft and the equilibrium current of a record's start both
//! read it, so the two agree.

use super::{asymmetric_friction, coulomb_friction, static_friction};
use crate::model::params::ModelParams;
use crate::param_id::ParamId;

/// The friction parameters of one motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrictionLaw {
    /// Coulomb torque [N m].
    pub tc: f32,
    /// Break-away excess [N m].
    pub ts: f32,
    /// Stribeck speed [rad/s].
    pub ws: f32,
    /// Direction asymmetry, a fraction of `tc` [-].
    pub ka: f32,
}

impl FrictionLaw {
    /// The law of motor `p`.
    pub fn of(p: &ModelParams) -> FrictionLaw {
        FrictionLaw {
            tc: p.get(ParamId::Tc),
            ts: p.get(ParamId::Ts),
            ws: p.get(ParamId::Ws),
            ka: p.get(ParamId::Ka),
        }
    }

    /// The torque opposing a motion (at rest: a drive) in `direction` (+1, -1; 0 gives 0) at
    /// speed `w`: `direction max(tc (1 + ka direction) + ts exp(-(w/ws)^2), 0)` (never
    /// negative with `|ka| <= 1`; the floor guards other values). With Coulomb friction
    /// alone it is `tc direction`, bit for bit.
    #[inline(always)]
    pub fn opposition(&self, direction: f32, w: f32) -> f32 {
        let mut magnitude = self.tc;
        if self.ts != 0.0 {
            magnitude += static_friction::excess(self.ts, self.ws, w);
        }
        if self.ka != 0.0 {
            magnitude += asymmetric_friction::excess(self.tc, self.ka, direction);
        }
        coulomb_friction::torque(magnitude.max(0.0), direction)
    }
}
