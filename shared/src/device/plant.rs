//! A simulated motor behind the [`Drive`] trait that the board's PWM and ADC implement: the
//! shared model (seed Eq. 1-5, with any effect of [`ModelParams`]) with white sensor noise.
//! The QEMU build commissions it, and the host tests of [`crate::device::service`] drive it.

use crate::device::hardware::{Drive, Sample};
use crate::model::params::ModelParams;
use crate::model::sim::{InitialState, Simulator};
use crate::rng::{self, Rng};
use crate::Error;

/// Coulomb friction [N m] of the demonstration plant ([`demo_motor`]): a fifth of the
/// viscous torque at the speed of the commissioning experiment's last voltage step.
pub const DEMO_FRICTION: f32 = 0.05;

/// The motor the QEMU build simulates and the commissioning tests identify: the seed's
/// (which has no Coulomb friction) with [`DEMO_FRICTION`], which a real motor has and the
/// commissioning coast-down is there to find.
pub fn demo_motor() -> ModelParams {
    ModelParams::SEED_MOTOR.with(crate::param_id::ParamId::Tc, DEMO_FRICTION)
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
    /// Offsets of the speed [rad/s] and current [A] readings (zero for healthy sensors).
    pub offset: Sample,
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
            offset: Sample {
                omega: 0.0,
                current: 0.0,
            },
        })
    }
}

impl SimulatedPlant {
    /// The sensors now, with their offsets and noise.
    fn read(&mut self) -> Sample {
        let r = self.sim.reading();
        Sample {
            omega: r.omega + self.offset.omega + self.noise_omega * rng::normal(&mut self.rng),
            current: r.current
                + self.offset.current
                + self.noise_current * rng::normal(&mut self.rng),
        }
    }
}

impl Drive for SimulatedPlant {
    fn dt(&self) -> f32 {
        self.dt
    }

    fn step(&mut self, volts: f32) -> Sample {
        let sample = self.read();
        self.sim.close_circuit();
        self.sim.advance(volts, 0.0);
        sample
    }

    fn coast(&mut self) -> Sample {
        let sample = self.read();
        self.sim.open_circuit();
        self.sim.advance(0.0, 0.0);
        sample
    }

    fn stop(&mut self) {
        self.stopped += 1;
    }
}
