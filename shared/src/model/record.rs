//! A measured experiment, borrowed from the caller (no allocation), and the initial state
//! the fit derives from it (its noise: [`crate::model::noise`]).

use crate::error::Error;
use crate::model::effects::friction::FrictionLaw;
use crate::model::effects::quadratic_load;
use crate::model::params::ModelParams;
use crate::model::sim::{sign, InitialState, MeasuredTacho, Simulator, StepInput};
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
    /// applied and the shaft slows under friction and load alone (paper Eq. 4 with `i = 0`).
    pub coast_from: Option<usize>,
    /// Drive samples each reading is the mean of: 1 (or 0) for readings at the sample instants;
    /// `m > 1` for the mean of the `m` readings a drive took over the step that ends at
    /// the sample (`(k - 1) dt + j dt / m`, `j = 1..=m`), which the fit simulates as such
    /// ([`crate::model::step_mean`]). Sample 0 is the record's initial state as the fit
    /// takes it (the board: the mean of `m` readings at rest just before the record).
    pub averaged: u32,
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
    /// which the applied voltage drives the armature (paper Eq. 1 holds).
    pub fn driven_len(&self) -> usize {
        self.coast_from
            .map_or(self.len(), |c| (c + 1).min(self.len()))
    }

    /// What drives the simulation over step `k`; with `track_angle`, the tacho's readings
    /// over it (for the tacho ripple, see [`crate::model::sim::Simulator::apply`]).
    #[inline(always)]
    pub fn step_input(&self, k: usize, track_angle: bool) -> StepInput {
        StepInput {
            v: self.v[k],
            tl: self.load_at(k),
            measured: track_angle.then(|| MeasuredTacho {
                rate: self.angle_rate(k),
                after: self.omega.get(k + 1).copied(),
            }),
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

    /// True when this record starts at rest for motor `p`: its first speed reading within
    /// three standard deviations `sigma_omega` of zero and, when the current is fitted
    /// (`sigma_current` given), its first current reading, less the sensor's offset `io`,
    /// within three `sigma_current` of the current that holds a shaft at rest (the load
    /// torque's, paper Eq. 4 with w = 0). A shaft still creeping under the speed noise after a
    /// record before (a heavy rotor braked by its own back-EMF at 0 V) shows its braking
    /// current `-Kv w / Ra`: taken for rest, its speed and current residuals persisted over
    /// the whole record and pulled B by a factor two on a benchmark motor
    /// (docs/measurements/commissioning.md).
    pub fn starts_at_rest(
        &self,
        p: &ModelParams,
        sigma_omega: f32,
        sigma_current: Option<f32>,
    ) -> bool {
        let still = self.omega[0].abs() <= 3.0 * sigma_omega;
        let holding = self.load_at(0) / p.get(ParamId::Kv);
        let no_braking = match (self.current, sigma_current) {
            (Some(c), Some(sc)) => (c[0] - p.get(ParamId::Io) - holding).abs() <= 3.0 * sc,
            _ => true,
        };
        still && no_braking
    }

    /// Initial state of the simulation for this record and motor `p`. Speed: exactly rest
    /// when the record starts `at_rest` ([`Record::starts_at_rest`], which its caller needs
    /// too), else the first reading (the fit then projects the initial speed out). Current: the
    /// mechanical equilibrium `Kv i = B w + tc sign(w) + kq w |w| + tl` (paper Eq. 4 with
    /// dw/dt = 0 and the friction effects), exact at rest and in steady state, unless the
    /// current is fitted (`sigma_current` given) and its first reading, less the sensor's
    /// offset `io`, differs from that by more than three `sigma_current`. (A noisy first
    /// reading taken as the state would persist for a time constant: La/Ra reaches seconds
    /// in the paper's Table 1 box; so would an offset taken for a current.)
    pub fn initial_state(
        &self,
        p: &ModelParams,
        at_rest: bool,
        sigma_current: Option<f32>,
    ) -> InitialState {
        let omega = if at_rest { 0.0 } else { self.omega[0] };
        let friction = FrictionLaw::of(p).opposition(sign(omega), omega)
            + quadratic_load::torque(p.get(ParamId::Kq), omega);
        let equilibrium =
            (p.get(ParamId::B) * omega + friction + self.load_at(0)) / p.get(ParamId::Kv);
        // The first reading less the current sensor's offset (`current_offset`): the
        // reading of a shaft at rest is the offset, not a current.
        let first = self.current.map(|c| c[0] - p.get(ParamId::Io));
        let current = match (first, sigma_current) {
            (Some(c0), Some(sc)) if (c0 - equilibrium).abs() > 3.0 * sc => c0,
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

/// Simulate record `r`'s inputs (voltage, load, coast-down) from `init`:
/// `out_omega[k]` and `out_current[k]` are the readings at sample `k`, before the input of
/// sample `k` is applied (the convention of [`crate::model::record`]). With `track_angle`, the
/// ripple angle follows the record's measured speed and readings (see [`Simulator::apply`]).
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
    let mut sim = Simulator::for_record(p, r, init)?;
    match Simulator::averaged_path(core::slice::from_ref(r)) {
        true => simulate_into::<true>(&mut sim, r, track_angle, out_omega, out_current),
        false => simulate_into::<false>(&mut sim, r, track_angle, out_omega, out_current),
    }
    Ok(())
}

/// The loop of [`simulate`]: the readings at the instants, or with `AVERAGED` their means
/// over each step ([`Simulator::sample`]), so that records at the instants take the plain
/// step.
fn simulate_into<const AVERAGED: bool>(
    sim: &mut Simulator,
    r: &Record,
    track_angle: bool,
    out_omega: &mut [f32],
    out_current: &mut [f32],
) {
    for k in 0..r.len() {
        let y = sim.sample::<AVERAGED>();
        out_omega[k] = y.omega;
        out_current[k] = y.current;
        sim.apply_record::<AVERAGED>(&r.step_input(k, track_angle));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_current_sensors_offset_is_not_taken_for_an_initial_current() {
        // At rest, 12 V applied, the sensor reading its 0.35 A offset (plus noise): the
        // state starts at the equilibrium (no current), not at the offset.
        let v = [12.0f32; 4];
        let omega = [0.0f32; 4];
        let current = [0.33f32, 0.79, 1.2, 1.6];
        let r = Record {
            dt: 5e-4,
            v: &v,
            omega: &omega,
            current: Some(&current),
            load: None,
            coast_from: None,
            averaged: 1,
        };
        let p = ModelParams::PAPER_MOTOR.with(ParamId::Io, 0.35);
        let at_rest = |p: &ModelParams| r.starts_at_rest(p, 0.5, Some(0.05));
        assert_eq!(r.initial_state(&p, at_rest(&p), Some(0.05)).current, 0.0);
        // Without the offset in the model, the reading is 6.6 sigma from rest: a current.
        let q = ModelParams::PAPER_MOTOR;
        assert_eq!(r.initial_state(&q, at_rest(&q), Some(0.05)).current, 0.33);
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
            averaged: 1,
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
