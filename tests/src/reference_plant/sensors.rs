//! The reference plant's sensors: an analogue tacho (with delay and ripple) or an
//! incremental encoder for speed, a current sensor with an offset, and seeded white
//! Gaussian noise of their own (splitmix64 and Box-Muller; not the product's generator).

use std::f64::consts::TAU;

/// How the speed is measured.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpeedSensor {
    /// An analogue tacho read at the sample instant: `w (1 + amp sin(cycles theta + phase))`,
    /// delayed by `td`.
    Tacho,
    /// An incremental encoder of `lines` lines (4 `lines` counts per revolution, quadrature):
    /// the reading is the count difference over the last sample divided by `dt`, i.e. the
    /// mean speed over the sample quantised to `2 pi / (4 lines dt)`.
    Encoder {
        /// Lines per revolution.
        lines: u32,
    },
}

/// The sensors and their noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensors {
    /// Speed sensor.
    pub speed: SpeedSensor,
    /// Standard deviation of white noise on the speed reading [rad/s].
    pub noise_omega: f64,
    /// Standard deviation of white noise on the current reading [A].
    pub noise_current: f64,
    /// Seed of the noise (and of the encoder's angle offset).
    pub seed: u64,
}

impl Sensors {
    /// A noise-free tacho.
    pub const IDEAL: Sensors = Sensors {
        speed: SpeedSensor::Tacho,
        noise_omega: 0.0,
        noise_current: 0.0,
        seed: 1,
    };
}

/// Seeded standard normal numbers: splitmix64 bits, Box-Muller pairs.
#[derive(Clone, Debug)]
pub struct Gaussian {
    state: u64,
    spare: Option<f64>,
}

impl Gaussian {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Gaussian {
        Gaussian {
            state: seed,
            spare: None,
        }
    }

    /// Uniform in (0, 1] with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        ((z >> 11) + 1) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal.
    pub fn normal(&mut self) -> f64 {
        if let Some(x) = self.spare.take() {
            return x;
        }
        let r = (-2.0 * self.uniform().ln()).sqrt();
        let a = TAU * self.uniform();
        self.spare = Some(r * a.sin());
        r * a.cos()
    }
}

/// The fine history of what the speed sensor sees (instantaneous tacho output and rotor
/// angle at every substep), for readings that lag the shaft.
#[derive(Clone, Debug)]
pub struct History {
    h: f64,
    tacho: Vec<f64>,
    theta: Vec<f64>,
}

impl History {
    /// An empty history of substeps of `h` seconds.
    pub fn new(h: f64, capacity: usize) -> History {
        History {
            h,
            tacho: Vec::with_capacity(capacity),
            theta: Vec::with_capacity(capacity),
        }
    }

    /// Append the substep's values (the first push is at t = 0).
    pub fn push(&mut self, tacho: f64, theta: f64) {
        self.tacho.push(tacho);
        self.theta.push(theta);
    }

    /// Tacho output and angle at time `t` (at most the last pushed), linear between
    /// substeps; before t = 0 the plant was at rest as at t = 0.
    pub fn at(&self, t: f64) -> (f64, f64) {
        let x = (t / self.h).max(0.0);
        let k = (x.floor() as usize).min(self.tacho.len() - 1);
        let next = (k + 1).min(self.tacho.len() - 1);
        let f = (x - k as f64).min(1.0);
        let lerp = |v: &[f64]| v[k] + f * (v[next] - v[k]);
        (lerp(&self.tacho), lerp(&self.theta))
    }
}

/// Instantaneous tacho output with ripple: `w (1 + amp sin(cycles theta + phase))`.
pub fn tacho(w: f64, theta: f64, amp: f64, cycles: f64, phase: f64) -> f64 {
    w * (1.0 + amp * (cycles * theta + phase).sin())
}

/// An encoder's count at rotor angle `theta`: `floor(theta / c + offset)` with
/// `c = 2 pi / (4 lines)` and `offset` in [0, 1) (where the first edge lies).
pub fn encoder_count(theta: f64, lines: u32, offset: f64) -> i64 {
    (theta * f64::from(4 * lines) / TAU + offset).floor() as i64
}

/// The speed quantum of an encoder of `lines` lines read over `dt`: `2 pi / (4 lines dt)`.
pub fn encoder_quantum(lines: u32, dt: f64) -> f64 {
    TAU / (f64::from(4 * lines) * dt)
}
