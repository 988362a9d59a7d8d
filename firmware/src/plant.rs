//! The QEMU build's motor: the shared model with sensor noise behind the same [`Drive`]
//! trait that the board's PWM and ADC implement.

use motor_id_shared::params::ModelParams;
use motor_id_shared::rng::{self, Rng};
use motor_id_shared::service::{Drive, Sample};
use motor_id_shared::sim::{InitialState, Simulator};

/// A simulated motor sampled every `dt`.
pub struct SimulatedPlant {
    sim: Simulator,
    dt: f32,
    rng: Rng,
    noise_omega: f32,
    noise_current: f32,
}

impl SimulatedPlant {
    /// The plant `p` at step `dt` with white sensor noise.
    pub fn new(
        p: &ModelParams,
        dt: f32,
        noise_omega: f32,
        noise_current: f32,
        seed: u64,
    ) -> Option<Self> {
        let sim = Simulator::new(p, dt, InitialState::REST).ok()?;
        Some(SimulatedPlant {
            sim,
            dt,
            rng: rng::seeded(seed),
            noise_omega,
            noise_current,
        })
    }
}

impl Drive for SimulatedPlant {
    fn dt(&self) -> f32 {
        self.dt
    }

    fn step(&mut self, volts: f32) -> Sample {
        let r = self.sim.reading();
        self.sim.advance(volts, 0.0);
        Sample {
            omega: r.omega + self.noise_omega * rng::normal(&mut self.rng),
            current: r.current + self.noise_current * rng::normal(&mut self.rng),
        }
    }

    fn stop(&mut self) {
        // Coasting is the plant's own business here: nothing to switch off.
    }
}
