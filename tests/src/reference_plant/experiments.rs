//! Input sequences for the reference plant: the operating conditions of paper's Section 6
//! (start, voltage steps, load step) plus a reversal, a chirp, a ramp and a reversing cycle
//! (a duty that heats a winding), sampled at a given rate with the record CSV's convention
//! (sample `k` holds the input from `t_k` to `t_k+1`).

use std::f64::consts::TAU;

/// The armature voltage and known load torque of each sample, held over it.
#[derive(Clone, Debug, PartialEq)]
pub struct Input {
    /// Sample step [s].
    pub dt: f64,
    /// Armature voltage [V] held from `t_k` to `t_k+1`.
    pub v: Vec<f64>,
    /// Known load torque [N m] held from `t_k` to `t_k+1` (`None`: no load column).
    pub tl: Option<Vec<f64>>,
    /// The bridge opens at this sample (open-circuit coast-down: no current, `v` not applied).
    pub open_from: Option<usize>,
}

impl Input {
    /// Number of samples.
    pub fn len(&self) -> usize {
        self.v.len()
    }

    /// True when there is no sample.
    pub fn is_empty(&self) -> bool {
        self.v.is_empty()
    }

    /// Load torque of sample `k`.
    pub fn load(&self, k: usize) -> f64 {
        self.tl.as_ref().map_or(0.0, |tl| tl[k])
    }

    /// The same input with the bridge opened from sample `k` on.
    pub fn coast_from(mut self, k: usize) -> Input {
        self.open_from = Some(k);
        self
    }
}

/// An experiment's shape; `v` is the full voltage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A voltage step from rest at t = 0.
    Start,
    /// Half the voltage, the full voltage from a third, a quarter from two thirds.
    Steps,
    /// Full voltage; a known load torque from half time.
    LoadStep {
        /// The load torque [N m].
        torque: f64,
    },
    /// Full voltage, minus full voltage from half time.
    Reversal,
    /// `v sin(2 pi (f0 t + (f1 - f0) t^2 / (2 T)))`: a linear sweep from `f0` to `f1` Hz.
    Chirp {
        /// Start frequency [Hz].
        f0: f64,
        /// End frequency [Hz].
        f1: f64,
    },
    /// From 0 to `v` linearly over the record.
    Ramp,
    /// A reversing duty cycle: `v` for the first half of each `period`, `-v` for the second.
    Cycle {
        /// The cycle's period [s].
        period: f64,
    },
}

/// The input of `shape` at full voltage `v`, `rate` samples per second for `duration` s.
pub fn experiment(shape: Shape, v: f64, rate: f64, duration: f64) -> Input {
    let n = (duration * rate).round() as usize;
    let dt = 1.0 / rate;
    let half = n / 2;
    let volts = |k: usize| {
        let t = k as f64 * dt;
        match shape {
            Shape::Start | Shape::LoadStep { .. } => v,
            Shape::Steps if k < n / 3 => 0.5 * v,
            Shape::Steps if k < 2 * n / 3 => v,
            Shape::Steps => 0.25 * v,
            Shape::Reversal if k < half => v,
            Shape::Reversal => -v,
            Shape::Chirp { f0, f1 } => {
                v * (TAU * (f0 * t + (f1 - f0) * t * t / (2.0 * duration))).sin()
            }
            Shape::Ramp => v * t / duration,
            Shape::Cycle { period } if (t / period).fract() < 0.5 => v,
            Shape::Cycle { .. } => -v,
        }
    };
    let tl = match shape {
        Shape::LoadStep { torque } => Some(
            (0..n)
                .map(|k| if k < half { 0.0 } else { torque })
                .collect(),
        ),
        _ => None,
    };
    Input {
        dt,
        v: (0..n).map(volts).collect(),
        tl,
        open_from: None,
    }
}
