//! Self-commissioning's experiment: the safety checks at 0 V, the bounded excitation
//! (voltage steps, then a coast-down) within the drive's limits, and the problem the board
//! then solves.

use crate::device::hardware::{Bridge, Drive, Link, Watchdog};
use crate::device::job::{abort_requested, fail, JobEnd};
use crate::device::record_store::RecordStore;
use crate::fit::space::ProblemSpec;
use crate::model::profile::{Experiment, Profile};
use crate::param_id::ParamId;
use crate::wire::protocol::{BoardMessage, JobStage, Refusal};

/// Limits of the commissioning experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest armature voltage applied [V].
    pub voltage: f32,
    /// Trip above this |current| [A].
    pub current: f32,
    /// Trip above this |speed| [rad/s].
    pub speed: f32,
}

/// Samples read at 0 V before an experiment (safety checks).
pub const SAFETY_SAMPLES: usize = 32;

/// Samples the safety checks wait at 0 V for the motor to come to rest.
pub const REST_WAIT_SAMPLES: usize = 2048;

/// Safety checks before any voltage is applied, at 0 V: the sensors read finite values;
/// the motor comes to rest (mean |speed| over [`SAFETY_SAMPLES`] under 2 % of the speed
/// limit) within [`REST_WAIT_SAMPLES`] (it may still be turning from a previous run);
/// then the current sensor shows no offset (mean |current| under 2 % of the limit).
pub fn safety_checks(
    limits: &Limits,
    drive: &mut impl Drive,
    watchdog: &mut impl Watchdog,
) -> Result<(), Refusal> {
    for _ in 0..REST_WAIT_SAMPLES / SAFETY_SAMPLES {
        let (mut omega, mut current) = (0.0f32, 0.0f32);
        for _ in 0..SAFETY_SAMPLES {
            watchdog.feed();
            let s = drive.step(0.0);
            if !(s.omega.is_finite() && s.current.is_finite()) {
                return Err(Refusal::SensorFault);
            }
            omega += s.omega;
            current += s.current;
        }
        let n = SAFETY_SAMPLES as f32;
        if (omega / n).abs() <= 0.02 * limits.speed {
            if (current / n).abs() > 0.02 * limits.current {
                return Err(Refusal::SensorFault);
            }
            return Ok(());
        }
    }
    Err(Refusal::NotAtRest)
}

/// The bounded experiment of self-commissioning, recorded into `store` over its whole
/// capacity (see [`commissioning_input`]: seed Section 6 speed changes, then a coast-down
/// for friction), read on tacho and current, with progress on the link. A trip of the
/// current or speed limit, or an abort from the host, stops the drive and ends it (reported
/// on the link); the drive is stopped at its end in every case.
pub fn run_experiment<const N: usize>(
    store: &mut RecordStore<N>,
    limits: &Limits,
    link: &mut impl Link,
    drive: &mut impl Drive,
    watchdog: &mut impl Watchdog,
) -> Result<(), JobEnd> {
    let dt = drive.dt();
    let s = store;
    s.dt = dt;
    s.with_current = true;
    s.len = 0;
    s.expected = N;
    s.coast_from = Some(coast_start(N));
    for k in 0..N {
        watchdog.feed();
        let input = commissioning_input(k, N, dt, limits.voltage);
        let sample = drive.apply(input);
        let within = sample.current.abs() <= limits.current && sample.omega.abs() <= limits.speed;
        if !within {
            drive.stop();
            return fail(JobEnd::Refused(Refusal::Trip), link);
        }
        s.v[k] = input.recorded_volts();
        s.omega[k] = sample.omega;
        s.current[k] = sample.current;
        s.len = k + 1;
        if k % 256 == 0 {
            link.send(&BoardMessage::Progress {
                stage: JobStage::Experiment,
                iteration: k as u32,
                total: N as u32,
                evaluations: 0,
                best: 0.0,
            });
            if abort_requested(link) {
                drive.stop();
                return fail(JobEnd::Aborted, link);
            }
        }
    }
    drive.stop();
    Ok(())
}

/// First sample of the coast-down in a commissioning record of `n` samples: the last
/// quarter coasts.
pub const fn coast_start(n: usize) -> usize {
    n - n / 4
}

/// Input of sample `k` of the commissioning experiment of `n` samples at step `dt` within
/// `voltage`: the voltage steps ½ → 1 → ¼ of the limit ([`Profile::Steps`], seed Section 6
/// speed changes) over the first three quarters, then a coast-down (bridge open) over the
/// last quarter. The steps excite the electrical and mechanical modes with the current
/// measured; the coast-down shows the friction alone (seed Eq. 4 with `i = 0`), which
/// separates Coulomb from viscous friction without the electrical parameters.
pub fn commissioning_input(k: usize, n: usize, dt: f32, voltage: f32) -> Bridge {
    let coast_from = coast_start(n);
    if k >= coast_from {
        return Bridge::Open;
    }
    let steps = Experiment {
        profile: Profile::Steps,
        voltage,
        duration: dt * coast_from as f32,
        load_torque: 0.0,
    };
    // min/max rather than clamp: clamp's NaN/order assertion would link float formatting
    // (about 10 KB of flash) for a panic that cannot happen here.
    Bridge::Drive(steps.at(k as f32 * dt).v.min(voltage).max(-voltage))
}

/// The problem a board solves when it commissions itself: the five motor parameters within
/// the seed's Table 1 and Coulomb friction `tc` (which the coast-down pins), the other
/// effects left out.
pub fn commissioning_spec() -> ProblemSpec {
    let mut spec = ProblemSpec::default();
    spec.free(ParamId::Tc);
    spec
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::hardware::Sample;
    use crate::device::plant::{SimulatedPlant, DEMO_FRICTION};
    use crate::model::record::Record;

    const SAMPLES: usize = 2000;
    const VOLTAGE: f32 = 50.0;

    #[test]
    fn the_experiment_ends_with_a_coast_down_in_which_friction_alone_slows_the_shaft() {
        let (n, dt, volts) = (SAMPLES, 0.01, VOLTAGE);
        let coast = coast_start(n);
        assert_eq!(coast, 1500);
        let inputs: Vec<Bridge> = (0..n)
            .map(|k| commissioning_input(k, n, dt, volts))
            .collect();
        assert_eq!(inputs[0], Bridge::Drive(0.5 * volts));
        assert_eq!(inputs[700], Bridge::Drive(volts));
        assert_eq!(inputs[coast - 1], Bridge::Drive(0.25 * volts));
        assert!(inputs[coast..].iter().all(|b| *b == Bridge::Open));
        // Run it on a noise-free plant: in the coast-down no current flows and the speed
        // follows seed Eq. 4 with i = 0, w(t) = (w0 + tc/B) e^(-B t / J) - tc/B.
        let p = crate::device::plant::demo_motor();
        let mut plant = SimulatedPlant::new(&p, dt, 0.0, 0.0, 1).unwrap();
        let samples: Vec<Sample> = inputs.iter().map(|b| plant.apply(*b)).collect();
        let w0 = samples[coast].omega;
        assert!(w0 > 50.0, "turning when the bridge opens: {w0}");
        let (j, b, tc) = (0.0424f32, 0.00267f32, DEMO_FRICTION);
        for (m, s) in samples[coast + 1..].iter().enumerate() {
            let t = (m + 1) as f32 * dt;
            let want = (w0 + tc / b) * (-b * t / j).exp() - tc / b;
            assert!(
                (s.omega - want).abs() < 1e-3 * w0,
                "{t} s: {} vs {want}",
                s.omega
            );
            assert_eq!(s.current, 0.0);
        }
    }

    #[test]
    fn a_noise_free_commissioning_record_is_the_models_own_simulation_bit_for_bit() {
        // The plant and the fit open the bridge at the same sample: the true parameters
        // reproduce every reading exactly, so a coast-down one step early or late would show.
        let (n, truth) = (SAMPLES, crate::device::plant::demo_motor());
        let data = crate::testkit::Owned::commissioning(&truth, n, 0.01, VOLTAGE);
        let record = data.record(true, false);
        assert_eq!(record.coast_from, Some(coast_start(n)));
        let (w, i) = (&data.omega, &data.current);
        let (mut sim_w, mut sim_i) = (vec![0.0f32; n], vec![0.0f32; n]);
        crate::model::record::simulate(
            &truth,
            &record,
            crate::model::sim::InitialState::REST,
            false,
            &mut sim_w,
            &mut sim_i,
        )
        .unwrap();
        assert_eq!(&sim_w, w);
        assert_eq!(&sim_i, i);
        let cost = crate::fit::objective::Objective::new(&[record])
            .unwrap()
            .cost(&truth)
            .unwrap();
        assert_eq!(cost.sse, 0.0);
        // The same record read as if the bridge had opened one sample later does not fit.
        let late = Record {
            coast_from: Some(coast_start(n) + 1),
            ..record
        };
        let late = [late];
        let objective = crate::fit::objective::Objective::new(&late).unwrap();
        assert!(objective.cost(&truth).unwrap().sse > 0.0);
    }
}
