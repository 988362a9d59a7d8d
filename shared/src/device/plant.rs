//! A simulated motor behind the [`Drive`] trait that the board's PWM and ADC implement: the
//! shared model (paper Eq. 1-5, with any effect of [`ModelParams`]) with white sensor noise.
//! The QEMU build commissions it, and the host tests of [`crate::device::service`] drive it.

use crate::device::hardware::{Drive, Sample};
use crate::model::params::ModelParams;
use crate::model::sim::{InitialState, Simulator};
use crate::rng::{self, Rng};
use crate::Error;

/// Coulomb friction [N m] of the demonstration plant ([`demo_motor`]): a fifth of the
/// viscous torque at the speed of the commissioning experiment's last voltage step.
pub const DEMO_FRICTION: f32 = 0.05;

/// The motor the QEMU build simulates and the commissioning tests identify: the paper's
/// (which has no Coulomb friction) with [`DEMO_FRICTION`], which a real motor has and the
/// commissioning coast-down is there to find.
pub fn demo_motor() -> ModelParams {
    ModelParams::PAPER_MOTOR.with(crate::param_id::ParamId::Tc, DEMO_FRICTION)
}

/// A simulated motor sampled every `dt`.
pub struct SimulatedPlant {
    sim: Simulator,
    dt: f32,
    rng: Rng,
    noise_omega: f32,
    noise_current: f32,
    /// How often the drive was stopped (the tests check that every trip stops it).
    pub stopped: u32,
    /// Samples taken (each [`Drive::step`] or [`Drive::coast`]).
    pub samples: u32,
    /// Offsets of the speed [rad/s] and current [A] readings (zero for healthy sensors).
    pub offset: Sample,
    /// Resolution of the speed [rad/s] and current [A] readings (an ADC's count; zero: none):
    /// each reading is rounded to a whole number of counts.
    pub resolution: Sample,
}

impl SimulatedPlant {
    /// The plant `p` at step `dt` with white sensor noise.
    pub fn new(
        p: &ModelParams,
        dt: f32,
        noise_omega: f32,
        noise_current: f32,
        seed: u64,
    ) -> Result<Self, Error> {
        let sim = Simulator::new(p, dt, InitialState::REST)?;
        Ok(SimulatedPlant {
            sim,
            dt,
            rng: rng::seeded(seed),
            noise_omega,
            noise_current,
            stopped: 0,
            samples: 0,
            offset: Sample {
                omega: 0.0,
                current: 0.0,
            },
            resolution: Sample {
                omega: 0.0,
                current: 0.0,
            },
        })
    }
}

impl SimulatedPlant {
    /// The sensors now, with their offsets and noise, in counts of their resolution.
    fn read(&mut self) -> Sample {
        let r = self.sim.reading();
        let omega = r.omega + self.offset.omega + self.noise_omega * rng::normal(&mut self.rng);
        let current =
            r.current + self.offset.current + self.noise_current * rng::normal(&mut self.rng);
        Sample {
            omega: counted(omega, self.resolution.omega),
            current: counted(current, self.resolution.current),
        }
    }
}

/// `x` rounded to a whole number of `count`s (unchanged for a zero count).
fn counted(x: f32, count: f32) -> f32 {
    if count > 0.0 {
        libm::roundf(x / count) * count
    } else {
        x
    }
}

impl Drive for SimulatedPlant {
    fn dt(&self) -> f32 {
        self.dt
    }

    fn step(&mut self, volts: f32) -> Sample {
        self.samples += 1;
        let sample = self.read();
        self.sim.close_circuit();
        self.sim.advance(volts, 0.0);
        sample
    }

    fn coast(&mut self) -> Sample {
        self.samples += 1;
        let sample = self.read();
        self.sim.open_circuit();
        self.sim.advance(0.0, 0.0);
        sample
    }

    fn stop(&mut self) {
        self.stopped += 1;
    }
}
