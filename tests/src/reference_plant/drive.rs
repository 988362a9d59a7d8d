//! The reference plant as a drive board sees it: the device code's
//! [`Drive`](motor_id_shared::device::hardware::Drive) trait over the plant's own dynamics
//! (its RK4, its friction), stepped in lockstep with the board's commissioning: each call
//! reads the sensors (white noise, then a whole number of ADC counts) and holds the bridge's
//! input for one sample.

use super::dynamics::Dynamics;
use super::sensors::Gaussian;
use super::{Effects, Motor};
use motor_id_shared::device::hardware::{Drive, Sample};

/// RK4 substeps per drive sample.
const DRIVE_SUBSTEPS: usize = 4;

/// The reference plant behind the drive trait.
pub struct ReferenceDrive {
    plant: Dynamics,
    dt: f64,
    noise: Gaussian,
    /// Noise of the speed [rad/s] and current [A] readings.
    pub sigma: (f64, f64),
    /// One ADC count of the speed [rad/s] and current [A] readings (0: none).
    pub count: (f64, f64),
    /// Largest |current| and |speed| the plant reached.
    pub largest: (f64, f64),
    /// How often the drive was stopped.
    pub stopped: u32,
}

impl ReferenceDrive {
    /// Motor `m` with effects `e`, at rest, sampled every `dt`.
    pub fn new(m: Motor, e: Effects, dt: f64, seed: u64) -> ReferenceDrive {
        ReferenceDrive {
            plant: Dynamics::new(m, e),
            dt,
            noise: Gaussian::new(seed),
            sigma: (0.0, 0.0),
            count: (0.0, 0.0),
            largest: (0.0, 0.0),
            stopped: 0,
        }
    }

    fn counted(x: f64, count: f64) -> f32 {
        match count > 0.0 {
            true => ((x / count).round() * count) as f32,
            false => x as f32,
        }
    }

    fn sample(&mut self, v: f64, open: bool) -> Sample {
        let s = self.plant.s;
        self.largest.0 = self.largest.0.max(s.i.abs());
        self.largest.1 = self.largest.1.max(s.w.abs());
        let read = Sample {
            omega: Self::counted(s.w + self.sigma.0 * self.noise.normal(), self.count.0),
            current: Self::counted(s.i + self.sigma.1 * self.noise.normal(), self.count.1),
        };
        let h = self.dt / DRIVE_SUBSTEPS as f64;
        for _ in 0..DRIVE_SUBSTEPS {
            self.plant.substep(v, 0.0, open, h);
        }
        read
    }
}

impl Drive for ReferenceDrive {
    fn dt(&self) -> f32 {
        self.dt as f32
    }
    fn step(&mut self, volts: f32) -> Sample {
        self.sample(volts as f64, false)
    }
    fn coast(&mut self) -> Sample {
        self.sample(0.0, true)
    }
    fn stop(&mut self) {
        self.stopped += 1;
    }
}

/// Borrowed, so that a test reads what the plant reached after the board is done with it.
impl Drive for &mut ReferenceDrive {
    fn dt(&self) -> f32 {
        (**self).dt()
    }
    fn step(&mut self, volts: f32) -> Sample {
        (**self).step(volts)
    }
    fn coast(&mut self) -> Sample {
        (**self).coast()
    }
    fn stop(&mut self) {
        (**self).stop()
    }
}
