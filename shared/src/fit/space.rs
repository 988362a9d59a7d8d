//! The search space: which parameters are free, their bounds and scaling, and the map between
//! the unit cube the optimisers work in and physical parameter values.

use crate::capacity::MODEL_PARAMS;
use crate::error::Error;
use crate::model::params::ModelParams;
use crate::param_id::ParamId;

use crate::capacity::MAX_FREE;

/// How a free parameter maps from the unit interval.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Scale {
    /// `p = lo + (hi - lo) u` (paper Eq. 9).
    Linear,
    /// `p = lo (hi / lo)^u`: equal resolution per decade, for bounds spanning decades.
    Log,
}

/// Bounds and fixed values of every parameter: the user's description of the problem.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ProblemSpec {
    /// Search bounds per parameter (indexed by [`ParamId::index`]; the first
    /// [`MODEL_PARAMS`]).
    pub bounds: [(f32, f32); MODEL_PARAMS],
    /// Free (true) or held at `base` (false), per parameter.
    pub free: [bool; MODEL_PARAMS],
    /// Values of the parameters that are not free.
    pub base: ModelParams,
}

/// The parameters a problem holds ([`MODEL_PARAMS`]).
const HELD: &[ParamId] = ParamId::ALL.split_at(MODEL_PARAMS).0;

/// `id` is one this build's problems hold.
fn held(id: ParamId) -> Result<(), Error> {
    match id.index() < MODEL_PARAMS {
        true => Ok(()),
        false => Err(Error::EffectNotInBuild(id)),
    }
}

/// A value `id` may be fixed at: finite, within its physical range.
fn check_fixed_value(id: ParamId, value: f32) -> Result<(), Error> {
    let (lo, hi) = id.physical_range();
    if !value.is_finite() || value < lo || value > hi {
        return Err(Error::InvalidFixedValue(id));
    }
    Ok(())
}

impl Default for ProblemSpec {
    /// The paper's problem: the five motor parameters free within Table 1, no effects.
    fn default() -> Self {
        let mut bounds = [(0.0, 0.0); MODEL_PARAMS];
        let mut free = [false; MODEL_PARAMS];
        for &id in HELD {
            bounds[id.index()] = id.default_bounds();
            free[id.index()] = id.is_motor();
        }
        ProblemSpec {
            bounds,
            free,
            base: ModelParams::PAPER_MOTOR,
        }
    }
}

impl ProblemSpec {
    /// Hold `id` at `value`.
    pub fn fix(&mut self, id: ParamId, value: f32) -> Result<(), Error> {
        held(id)?;
        check_fixed_value(id, value)?;
        self.free[id.index()] = false;
        self.base.set(id, value);
        Ok(())
    }

    /// Let `id` vary within `lo..hi`.
    pub fn set_bounds(&mut self, id: ParamId, lo: f32, hi: f32) -> Result<(), Error> {
        held(id)?;
        let (plo, phi) = id.physical_range();
        if !(lo.is_finite() && hi.is_finite() && lo < hi && lo >= plo && hi <= phi) {
            return Err(Error::InvalidBound(id));
        }
        if id.is_motor() && lo <= 0.0 {
            return Err(Error::InvalidBound(id));
        }
        self.bounds[id.index()] = (lo, hi);
        Ok(())
    }

    /// Make `id` a free parameter within its current bounds (one this build does not hold
    /// stays held at its default).
    pub fn free(&mut self, id: ParamId) {
        if let Some(f) = self.free.get_mut(id.index()) {
            *f = true;
        }
    }

    /// `p` as a point of this problem: each free parameter clamped to its bounds, each held
    /// one at its held value (`base`).
    pub fn point(&self, p: &ModelParams) -> ModelParams {
        let mut out = *p;
        for id in ParamId::ALL {
            let x = match self.free[id.index()] {
                true => {
                    let (lo, hi) = self.bounds[id.index()];
                    p.get(id).clamp(lo, hi)
                }
                false => self.base.get(id),
            };
            out.set(id, x);
        }
        out
    }
}

/// One free parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FreeParam {
    /// Which parameter.
    pub id: ParamId,
    /// Lower bound.
    pub lo: f32,
    /// Upper bound.
    pub hi: f32,
    /// Mapping from the unit interval.
    pub scale: Scale,
}

impl FreeParam {
    /// Physical value at unit coordinate `u` (clamped to [0, 1]).
    pub fn value(&self, u: f32) -> f32 {
        let u = u.clamp(0.0, 1.0);
        match self.scale {
            Scale::Linear => self.lo + (self.hi - self.lo) * u,
            Scale::Log => self.lo * libm::powf(self.hi / self.lo, u),
        }
    }

    /// Unit coordinate of physical value `p` (clamped to the bounds).
    pub fn unit(&self, p: f32) -> f32 {
        let u = match self.scale {
            Scale::Linear => (p - self.lo) / (self.hi - self.lo),
            Scale::Log => libm::logf(p / self.lo) / libm::logf(self.hi / self.lo),
        };
        if u.is_finite() {
            u.clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The natural unit of this parameter at value `p`: a parameter with positive bounds is
    /// measured relative to its value (natural coordinate `ln p`, whatever the search scale);
    /// one whose range includes 0 (an effect that may be absent) relative to
    /// `max(|p|, 1 % of the range)`. Returns `d(natural coordinate)/du` at `p`.
    pub fn natural_per_unit(&self, p: f32) -> f64 {
        let (lo, hi, p) = (self.lo as f64, self.hi as f64, p as f64);
        match self.scale {
            Scale::Log => libm::log(hi / lo),
            Scale::Linear if lo > 0.0 => (hi - lo) / p.max(lo),
            Scale::Linear => (hi - lo) / self.natural_scale(p as f32),
        }
    }

    /// One natural unit in the parameter's own unit at value `p` (see
    /// [`FreeParam::natural_per_unit`]): `p` itself, or `max(|p|, 1 % of the range)`.
    pub fn natural_scale(&self, p: f32) -> f64 {
        let (lo, hi, p) = (self.lo as f64, self.hi as f64, p as f64);
        if lo > 0.0 {
            p
        } else {
            p.abs().max(0.01 * (hi - lo))
        }
    }
}

/// The free parameters of a problem and the fixed rest.
#[derive(Clone, Debug, PartialEq)]
pub struct Space {
    base: ModelParams,
    free: heapless::Vec<FreeParam, MAX_FREE>,
}

impl Space {
    /// Build the space of `spec`. With `log_scale`, parameters whose lower bound is positive
    /// are searched in log scale; otherwise every parameter is linear (paper Eq. 9). Not
    /// inlined: its temporaries stay off the frame of an identification (a board's stack).
    #[inline(never)]
    pub fn new(spec: &ProblemSpec, log_scale: bool) -> Result<Space, Error> {
        let mut free = heapless::Vec::new();
        for &id in HELD {
            if !spec.free[id.index()] {
                continue;
            }
            let (lo, hi) = spec.bounds[id.index()];
            if !(lo.is_finite() && hi.is_finite() && lo < hi) || (id.is_motor() && lo <= 0.0) {
                return Err(Error::InvalidBound(id));
            }
            let scale = if log_scale && lo > 0.0 {
                Scale::Log
            } else {
                Scale::Linear
            };
            free.push(FreeParam { id, lo, hi, scale })
                .map_err(|_| Error::TooManyParameters)?;
        }
        if free.is_empty() {
            return Err(Error::NothingToIdentify);
        }
        spec.base.validate()?;
        Ok(Space {
            base: spec.base,
            free,
        })
    }

    /// The space of a profile ([`crate::fit::profile_check`]): `id` fixed at `value` (within its
    /// physical range, checked as by [`ProblemSpec::fix`]), the other free parameters as here,
    /// with their bounds and scales, every fixed one as in `at`.
    pub fn fixing(&self, at: &ModelParams, id: ParamId, value: f32) -> Result<Space, Error> {
        check_fixed_value(id, value)?;
        let mut free = self.free.clone();
        free.retain(|f| f.id != id);
        if free.is_empty() {
            return Err(Error::NothingToIdentify);
        }
        let base = at.with(id, value);
        base.validate()?;
        Ok(Space { base, free })
    }

    /// Number of free parameters.
    pub fn dim(&self) -> usize {
        self.free.len()
    }

    /// The free parameters.
    pub fn free(&self) -> &[FreeParam] {
        &self.free
    }

    /// The place of parameter `id` among [`Space::free`] (its unit coordinate's index);
    /// None when it is not free.
    pub fn position(&self, id: ParamId) -> Option<usize> {
        self.free.iter().position(|f| f.id == id)
    }

    /// Parameter set at unit coordinates `u` (length [`Space::dim`]).
    pub fn params(&self, u: &[f32]) -> ModelParams {
        let mut p = self.base;
        for (f, &x) in self.free.iter().zip(u) {
            p.set(f.id, f.value(x));
        }
        p
    }

    /// Unit coordinates of `p`.
    pub fn unit(&self, p: &ModelParams) -> [f32; MAX_FREE] {
        let mut u = [0.0; MAX_FREE];
        for (x, f) in u.iter_mut().zip(self.free.iter()) {
            *x = f.unit(p.get(f.id));
        }
        u
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_profiles_space_is_the_space_of_the_problem_with_the_parameter_fixed() {
        let mut spec = ProblemSpec::default();
        spec.free(ParamId::Tc);
        spec.set_bounds(ParamId::Tc, 0.0, 0.05).unwrap();
        let at = ModelParams::PAPER_MOTOR.with(ParamId::Tc, 0.01);
        for log_scale in [false, true] {
            let space = Space::new(&spec, log_scale).unwrap();
            for id in [ParamId::Ra, ParamId::Kv, ParamId::Tc] {
                let value = 0.5 * at.get(id) + 0.001;
                let mut fixed = spec;
                fixed.base = at;
                fixed.fix(id, value).unwrap();
                let expected = Space::new(&fixed, log_scale).unwrap();
                let profile = space.fixing(&at, id, value).unwrap();
                assert_eq!(profile.base, expected.base, "{id:?}");
                assert_eq!(profile.free, expected.free, "{id:?}");
            }
            // What fix refuses, fixing refuses too.
            assert!(space.fixing(&at, ParamId::Ra, -1.0).is_err());
            assert!(space.fixing(&at, ParamId::Ra, f32::NAN).is_err());
        }
    }

    #[test]
    fn a_point_of_a_problem_is_clamped_where_free_and_held_where_fixed() {
        let mut spec = ProblemSpec::default();
        spec.set_bounds(ParamId::Tc, 0.01, 0.05).unwrap();
        spec.free(ParamId::Tc);
        spec.fix(ParamId::Ra, 2.5).unwrap();
        let p = ModelParams::PAPER_MOTOR
            .with(ParamId::Ra, 9.0)
            .with(ParamId::Tc, 0.0)
            .with(ParamId::Kv, 1e9);
        let q = spec.point(&p);
        assert_eq!(q.get(ParamId::Ra), 2.5, "held at the fixed value");
        assert_eq!(q.get(ParamId::Tc), 0.01, "clamped to its lower bound");
        let (_, kv_hi) = spec.bounds[ParamId::Kv.index()];
        assert_eq!(q.get(ParamId::Kv), kv_hi, "clamped to its upper bound");
        // Within its bounds a free value stays; a parameter neither free nor fixed is held
        // at the base's default.
        assert_eq!(
            spec.point(&p.with(ParamId::Tc, 0.02)).get(ParamId::Tc),
            0.02
        );
        assert_eq!(q.get(ParamId::Ts), spec.base.get(ParamId::Ts));
    }
}
