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
/// on, if given, the bridge is open (a coast-down: seed Eq. 4 with `i = 0`), and the voltage
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
            measured_omega: None,
            opens: coast_from == Some(k),
        });
    }
    Ok(())
}
