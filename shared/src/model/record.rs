//! A measured experiment, borrowed from the caller (no allocation), and what the fit derives
//! from it: the initial state and a noise estimate.

use crate::error::Error;
use crate::model::effects::friction::FrictionLaw;
use crate::model::params::ModelParams;
use crate::model::sim::{sign, InitialState, Simulator, StepInput};
use crate::param_id::ParamId;

/// Fewest samples a record may hold.
pub const MIN_SAMPLES: usize = 8;

/// One experiment sampled at a fixed step: sample `k` holds the readings at `t = k dt` and the
/// voltage (and load torque) applied from `k dt` to `(k + 1) dt`.
#[derive(Clone, Copy, Debug)]
pub struct Record<'a> {
    /// Sample step [s].
    pub dt: f32,
    /// Armature voltage [V].
    pub v: &'a [f32],
    /// Measured speed [rad/s].
    pub omega: &'a [f32],
    /// Measured armature current [A], if logged.
    pub current: Option<&'a [f32]>,
    /// Known load torque [N m], if applied.
    pub load: Option<&'a [f32]>,
    /// First sample of a coast-down, if the record ends with one: from `k = coast_from` on,
    /// every bridge switch is off (open circuit), so no armature current flows, `v` is not
    /// applied and the shaft slows under friction and load alone (seed Eq. 4 with `i = 0`).
    pub coast_from: Option<usize>,
}

impl<'a> Record<'a> {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.v.len()
    }

    /// True when the record holds no sample.
    pub fn is_empty(&self) -> bool {
        self.v.is_empty()
    }

    /// Check lengths, step and finiteness.
    pub fn validate(&self) -> Result<(), Error> {
        if !(self.dt.is_finite() && self.dt > 0.0) {
            return Err(Error::InvalidStep);
        }
        let n = self.v.len();
        if self.omega.len() != n
            || self.current.is_some_and(|c| c.len() != n)
            || self.load.is_some_and(|l| l.len() != n)
        {
            return Err(Error::LengthMismatch);
        }
        if n < MIN_SAMPLES {
            return Err(Error::TooFewSamples);
        }
        if self.coast_from.is_some_and(|c| c >= n) {
            return Err(Error::CoastOutsideRecord);
        }
        let finite = |s: &[f32]| s.iter().all(|x| x.is_finite());
        if !(finite(self.v)
            && finite(self.omega)
            && self.current.is_none_or(finite)
            && self.load.is_none_or(finite))
        {
            return Err(Error::NonFiniteSample);
        }
        Ok(())
    }

    /// Samples up to the start of the coast-down (all of them without one): the rows in
    /// which the applied voltage drives the armature (seed Eq. 1 holds).
    pub fn driven_len(&self) -> usize {
        self.coast_from
            .map_or(self.len(), |c| (c + 1).min(self.len()))
    }

    /// What drives the simulation over step `k`; with `track_angle`, the measured speed
    /// over it (for the tacho ripple, see [`crate::model::sim::Simulator::apply`]).
    #[inline(always)]
    pub fn step_input(&self, k: usize, track_angle: bool) -> StepInput {
        StepInput {
            v: self.v[k],
            tl: self.load_at(k),
            measured_omega: track_angle.then(|| self.angle_rate(k)),
            opens: self.coast_from == Some(k),
        }
    }

    /// Mean measured speed over step `k` (trapezoid of readings `k` and `k + 1`): the rate at
    /// which the rotor angle advances, see [`crate::model::sim::Simulator::apply`].
    pub fn angle_rate(&self, k: usize) -> f32 {
        trapezoid_rate(self.omega, k)
    }

    /// Load torque at sample `k` (0 without a load column).
    pub fn load_at(&self, k: usize) -> f32 {
        self.load.map_or(0.0, |l| l[k])
    }

    /// Initial state of the simulation for this record and motor `p`. Speed: the first
    /// reading, or exactly rest when it is within three standard deviations `sigma_omega` of
    /// zero (a record that starts indistinguishable from rest starts at rest). Current: the
    /// mechanical equilibrium `Kv i = B w + tc sign(w) + kq w |w| + tl` (seed Eq. 4 with
    /// dw/dt = 0 and the friction effects), exact at rest and in steady state, unless the
    /// current is fitted (`sigma_current` given) and its first reading differs from that by
    /// more than three `sigma_current`. (A noisy first reading taken as the state would
    /// persist for a time constant: La/Ra reaches seconds in the seed's Table 1 box.)
    pub fn initial_state(
        &self,
        p: &ModelParams,
        sigma_omega: f32,
        sigma_current: Option<f32>,
    ) -> InitialState {
        let mut omega = self.omega[0];
        if omega.abs() <= 3.0 * sigma_omega {
            omega = 0.0;
        }
        let friction = FrictionLaw::of(p).opposition(sign(omega), omega)
            + p.get(ParamId::Kq) * omega * omega.abs();
        let equilibrium =
            (p.get(ParamId::B) * omega + friction + self.load_at(0)) / p.get(ParamId::Kv);
        let current = match (self.current, sigma_current) {
            (Some(c), Some(sc)) if (c[0] - equilibrium).abs() > 3.0 * sc => c[0],
            _ => equilibrium,
        };
        InitialState { current, omega }
    }
}

/// Mean of `omega[k]` and `omega[k + 1]` (just `omega[k]` at the end).
pub fn trapezoid_rate(omega: &[f32], k: usize) -> f32 {
    match omega.get(k + 1) {
        Some(next) => 0.5 * (omega[k] + next),
        None => omega[k],
    }
}

/// Standard deviation of white measurement noise on a smooth signal, from its second
/// differences: `var(x[k+1] - 2 x[k] + x[k-1]) = 6 sigma^2` for white noise, while a signal
/// sampled well above its bandwidth contributes almost nothing. Steps and transients show as
/// a few large second differences: those above twice their RMS are left out (fixed memory,
/// no sort) and the rest scaled for a normal distribution truncated at 2 sigma.
pub fn noise_sigma(x: &[f32]) -> f32 {
    if x.len() < 3 {
        return 0.0;
    }
    // Two passes: the mean square, then the mean square of the terms below it (trims steps
    // and transients, which show as a few large second differences).
    let mut sum = 0.0f64;
    let n = x.len() - 2;
    for k in 1..x.len() - 1 {
        let d = (x[k + 1] - 2.0 * x[k] + x[k - 1]) as f64;
        sum += d * d;
    }
    let ms = sum / n as f64;
    let mut trimmed = 0.0f64;
    let mut count = 0usize;
    for k in 1..x.len() - 1 {
        let d = (x[k + 1] - 2.0 * x[k] + x[k - 1]) as f64;
        if d * d <= 4.0 * ms {
            trimmed += d * d;
            count += 1;
        }
    }
    if count == 0 {
        return 0.0;
    }
    // For a normal variable, E[d^2 | |d| <= 2 sigma] = (1 - 4 phi(2) / (2 Phi(2) - 1)) sigma^2
    // = 0.7737 sigma^2.
    let var_d = trimmed / count as f64 / 0.7737;
    libm::sqrt(var_d / 6.0) as f32
}

/// Simulate record `r`'s inputs (voltage, load, coast-down) from `init`:
/// `out_omega[k]` and `out_current[k]` are the readings at sample `k`, before the input of
/// sample `k` is applied (the convention of [`crate::model::record`]). With `track_angle`, the
/// ripple angle follows the record's measured speed (see [`Simulator::apply`]).
pub fn simulate(
    p: &ModelParams,
    r: &Record,
    init: InitialState,
    track_angle: bool,
    out_omega: &mut [f32],
    out_current: &mut [f32],
) -> Result<(), Error> {
    let n = r.len();
    if out_omega.len() != n || out_current.len() != n {
        return Err(Error::LengthMismatch);
    }
    r.validate()?;
    let mut sim = Simulator::new(p, r.dt, init)?;
    for k in 0..n {
        let y = sim.reading();
        out_omega[k] = y.omega;
        out_current[k] = y.current;
        sim.apply(&r.step_input(k, track_angle));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noise_sigma_recovers_white_noise_on_a_smooth_signal() {
        let mut rng = crate::rng::seeded(7);
        let sigma = 0.5f32;
        let x: std::vec::Vec<f32> = (0..20_000)
            .map(|k| {
                let smooth = 100.0 * (1.0 - libm::expf(-(k as f32) * 1e-3));
                smooth + sigma * crate::rng::normal(&mut rng)
            })
            .collect();
        let est = noise_sigma(&x);
        assert!((est / sigma - 1.0).abs() < 0.02, "estimated {est}");
    }

    #[test]
    fn validation_catches_bad_records() {
        let v = [1.0f32; 10];
        let w = [0.0f32; 10];
        let short = [0.0f32; 9];
        let ok = Record {
            dt: 1e-3,
            v: &v,
            omega: &w,
            current: None,
            load: None,
            coast_from: None,
        };
        assert_eq!(ok.validate(), Ok(()));
        let coasting = Record {
            coast_from: Some(9),
            ..ok
        };
        assert_eq!(coasting.validate(), Ok(()));
        assert_eq!(coasting.driven_len(), 10);
        assert_eq!(
            Record {
                coast_from: Some(4),
                ..ok
            }
            .driven_len(),
            5
        );
        assert_eq!(
            Record {
                coast_from: Some(10),
                ..ok
            }
            .validate(),
            Err(Error::CoastOutsideRecord)
        );
        assert_eq!(
            Record {
                omega: &short,
                ..ok
            }
            .validate(),
            Err(Error::LengthMismatch)
        );
        assert_eq!(Record { dt: 0.0, ..ok }.validate(), Err(Error::InvalidStep));
        let mut bad = w;
        bad[3] = f32::NAN;
        assert_eq!(
            Record { omega: &bad, ..ok }.validate(),
            Err(Error::NonFiniteSample)
        );
        assert_eq!(
            Record {
                v: &v[..4],
                omega: &w[..4],
                ..ok
            }
            .validate(),
            Err(Error::TooFewSamples)
        );
    }
}
