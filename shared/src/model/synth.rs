//! Synthetic records: an experiment applied to a simulated motor, with seeded white noise on
//! the readings. Serves `motor-id simulate`, the tests and the QEMU build's plant.

use crate::error::Error;
use crate::model::params::ModelParams;
use crate::model::profile::Experiment;
use crate::model::sim::{InitialState, Simulator, StepInput};
use crate::rng;

/// Standard deviations of white measurement noise.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Noise {
    /// On the speed reading [rad/s].
    pub omega: f32,
    /// On the current reading [A].
    pub current: f32,
}

/// Output buffers of [`synthesize`]; all of one length.
#[derive(Debug)]
pub struct Buffers<'a> {
    /// Armature voltage.
    pub v: &'a mut [f32],
    /// Load torque.
    pub tl: &'a mut [f32],
    /// Speed reading.
    pub omega: &'a mut [f32],
    /// Current reading.
    pub current: &'a mut [f32],
}

/// Run `experiment` on `p` from rest at step `dt` and fill `out`; from sample `coast_from`
/// on, if given, the bridge is open (a coast-down: paper Eq. 4 with `i = 0`), and the voltage
/// written there is 0 (none is applied).
pub fn synthesize(
    p: &ModelParams,
    experiment: &Experiment,
    dt: f32,
    noise: Noise,
    seed: u64,
    coast_from: Option<usize>,
    out: Buffers<'_>,
) -> Result<(), Error> {
    let n = out.v.len();
    if out.tl.len() != n || out.omega.len() != n || out.current.len() != n {
        return Err(Error::LengthMismatch);
    }
    let mut sim = Simulator::new(p, dt, InitialState::REST)?;
    let mut rng = rng::seeded(seed);
    for k in 0..n {
        let input = experiment.at(k as f32 * dt);
        let open = coast_from.is_some_and(|c| k >= c);
        let r = sim.reading();
        out.v[k] = if open { 0.0 } else { input.v };
        out.tl[k] = input.tl;
        out.omega[k] = r.omega + noise.omega * rng::normal(&mut rng);
        out.current[k] = r.current + noise.current * rng::normal(&mut rng);
        // The bridge opens over the step from sample `coast_from` (the reading there is
        // still the driven one: the convention of `Record::step_input`).
        sim.apply(&StepInput {
            v: input.v,
            tl: input.tl,
            measured: None,
            opens: coast_from == Some(k),
        });
    }
    Ok(())
}

/// A motor drawn log-uniformly from the paper's Table 1 box with random seed `seed`, no
/// effects (the benchmarks' motors).
#[cfg(any(test, feature = "std"))]
pub fn table_one_motor(seed: u64) -> ModelParams {
    let mut r = rng::seeded(seed);
    let mut truth = ModelParams::PAPER_MOTOR;
    for id in crate::param_id::ParamId::MOTOR {
        let (lo, hi) = id.default_bounds();
        truth.set(id, lo * (hi / lo).powf(rng::unit(&mut r)));
    }
    truth
}

/// A benchmark case: a motor drawn log-uniformly from the paper's Table 1 box (seed `seed`),
/// a `steps` experiment of `samples` samples lasting five slowest time constants per step,
/// white noise of 1 % of the peak speed and current. Shared by the benchmark
/// (`host/examples/benchmark.rs`) and the tests of the reported uncertainty.
#[cfg(any(test, feature = "std"))]
pub struct TableOneCase {
    /// The motor.
    pub truth: ModelParams,
    /// Sample step [s].
    pub dt: f32,
    /// Armature voltage [V].
    pub v: std::vec::Vec<f32>,
    /// Speed reading [rad/s].
    pub omega: std::vec::Vec<f32>,
    /// Current reading [A].
    pub current: std::vec::Vec<f32>,
}

#[cfg(any(test, feature = "std"))]
impl TableOneCase {
    /// The case of `seed` with `samples` samples.
    pub fn new(seed: u64, samples: usize) -> TableOneCase {
        use crate::model::profile::{settling_duration, Profile};
        let truth = table_one_motor(seed);
        let duration = settling_duration(&truth, Profile::Steps);
        let dt = duration / samples as f32;
        let exp = Experiment {
            profile: Profile::Steps,
            voltage: 50.0,
            duration,
            load_torque: 0.0,
        };
        let (mut v, mut tl, mut omega, mut current) = (
            vec![0.0; samples],
            vec![0.0; samples],
            vec![0.0; samples],
            vec![0.0; samples],
        );
        let mut run = |noise: Noise, noise_seed: u64, omega: &mut [f32], current: &mut [f32]| {
            let b = Buffers {
                v: &mut v,
                tl: &mut tl,
                omega,
                current,
            };
            synthesize(&truth, &exp, dt, noise, noise_seed, None, b)
                .expect("Table 1 motors simulate");
        };
        // Noise-free first, to scale the noise to 1 % of the peak signals.
        run(Noise::default(), 0, &mut omega, &mut current);
        let peak = |x: &[f32]| x.iter().fold(0.0f32, |m, y| m.max(y.abs()));
        let noise = Noise {
            omega: 0.01 * peak(&omega),
            current: 0.01 * peak(&current),
        };
        run(noise, seed ^ 0x5eed, &mut omega, &mut current);
        TableOneCase {
            truth,
            dt,
            v,
            omega,
            current,
        }
    }

    /// Its record, with the current column when `with_current`.
    pub fn record(&self, with_current: bool) -> crate::model::record::Record<'_> {
        crate::model::record::Record {
            dt: self.dt,
            v: &self.v,
            omega: &self.omega,
            current: with_current.then_some(&self.current[..]),
            load: None,
            coast_from: None,
            averaged: 1,
        }
    }
}
