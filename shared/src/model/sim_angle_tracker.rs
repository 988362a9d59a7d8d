//! The tacho ripple's angle, tracked (host builds only): a scalar Kalman filter of the
//! ripple angle `psi` on the tacho's readings.
//!
//! The angle advances by the measured speed ([`Simulator::apply`]), whose white noise
//! `sigma`, integrated, makes it a random walk: `cycles dt sigma` per step. Over a
//! record of ten thousand steps that is a phase error of some `cycles dt sigma 100`, and
//! with a ripple of a few rad/s a misfit of the tacho's noise order: the blind checks'
//! ripple fits stayed at 1.2-1.5 times the noise floor, in proportion to the noise
//! (docs/measurements/blind-checks.md). The ripple itself tells the angle: a reading that
//! differs from the simulated one by `r` moves the angle by the Kalman gain times `r`,
//! with the reading's slope in the angle `h = w amp cos(psi + phase)` as its measurement
//! model (Kalman, *A new approach to linear filtering and prediction problems*, 1960; a
//! phase-locked loop whose gain follows the angle's uncertainty). Both the walk and the
//! reading's noise are the tacho's `sigma`, so the filter needs no estimate of it: in units
//! of `sigma^2`, the walk adds `(cycles dt)^2` to the angle's variance `p` per step and the
//! reading's variance is 1, so the gain is `p h / (h^2 p + 1)`. The angle starts known (0
//! at the record's start, by the definition of `ripple_phase`). A delayed reading is
//! compared with the simulated reading it is: the angle integrates readings as late as it
//! ([`Simulator::push_reading`]).
//! Records of averaged readings (a board's) are not tracked.
//!
//! What it changes for a fit: `ripple_phase` is the angle at each record's start, which the
//! tracker takes up within some hundred steps of the shaft turning (a phase half a turn off
//! no longer leaves least squares on a ridge); it is pinned by those first revolutions only,
//! and a report may call it not pinned. Measured on the blind checks: the ripple's fits
//! reach the noise floor, docs/measurements/blind-checks.md (last section).

use super::Simulator;
use crate::model::effects::tacho_ripple;
use crate::param_id::ParamId;

/// The tracker's state.
#[derive(Clone, Copy, Debug)]
pub(super) struct AngleTracker {
    /// The variance of the angle's error, in units of the tacho noise's variance [rad^2].
    variance: f32,
    /// The newest reading [rad/s] (none before the first step of a record).
    reading: Option<f32>,
    /// Its slope in the angle [rad/s per rad].
    slope: f32,
}

impl AngleTracker {
    /// At a record's start: the angle known.
    pub(super) const START: AngleTracker = AngleTracker {
        variance: 0.0,
        reading: None,
        slope: 0.0,
    };

    /// Keep the newest reading and its slope in the angle.
    #[inline(always)]
    pub(super) fn read(&mut self, reading: f32, slope: f32) {
        (self.reading, self.slope) = (Some(reading), slope);
    }

    /// The newest reading.
    #[inline(always)]
    pub(super) fn reading(&self) -> Option<f32> {
        self.reading
    }
}

impl Simulator {
    /// Correct the ripple angle by the tacho's reading `measured` at the end of the step
    /// just taken (see the module doc).
    #[inline(never)]
    pub(super) fn track_angle(&mut self, measured: f32) {
        let cycles = self.effect(ParamId::RippleCycles);
        if self.effect(ParamId::RippleAmp) == 0.0 || cycles == 0.0 || self.averaged.is_some() {
            return;
        }
        let Some(tracker) = self.angle_tracker.first() else {
            return;
        };
        let (Some(predicted), slope) = (tracker.reading, tracker.slope) else {
            return;
        };
        let walk = cycles * self.dt;
        let prior = tracker.variance + walk * walk;
        let gain = prior * slope / (slope * slope * prior + 1.0);
        let shift = gain * (measured - predicted);
        if !shift.is_finite() {
            return;
        }
        if let Some(tracker) = self.angle_tracker.first_mut() {
            tracker.variance = prior * (1.0 - gain * slope);
        }
        // (The cogging's angle is left as integrated: the shift also takes up an error of
        // the ripple's phase, which is no error of the rotor's angle; carried over, it moved
        // the detents off and cogging beside a ripple went unnamed on the blind checks.)
        self.psi = tacho_ripple::shifted(self.psi, shift);
    }
}

#[cfg(test)]
mod tests {
    use super::super::{InitialState, MeasuredTacho, StepInput};
    use super::*;
    use crate::model::params::ModelParams;
    use std::vec::Vec;

    /// The RMS gap between the reading a simulator of a rippled tacho predicts and the
    /// noiseless reading, when it is given a record of the readings with white noise
    /// `sigma` (0.05 rad/s), `whole` samples late, its angle tracked (`track`) or only
    /// integrated. A light motor at 12 V (about 240 rad/s) for 2 s at 5 kHz, a 3 % ripple
    /// at 14 per revolution. The truth is the test's own: the shaft speed of a simulator
    /// without ripple, its angle integrated in f64, the reading's formula written out.
    fn gap(track: bool, whole: usize) -> f32 {
        let (dt, n, volts, sigma) = (2e-4f32, 10_000, 12.0f32, 0.05f32);
        let (amp, cycles, phase) = (0.03f64, 14.0f64, 0.7f64);
        let motor = ModelParams::motor(1.0, 1e-3, 1e-4, 1e-5, 0.05);
        let mut shaft = Simulator::new(&motor, dt, InitialState::REST).unwrap();
        let mut speeds = Vec::new();
        for _ in 0..n {
            speeds.push(shaft.omega() as f64);
            shaft.advance(volts, 0.0);
        }
        let mut theta = 0.0f64;
        let mut clean = Vec::new();
        for k in 0..n {
            if k > 0 {
                theta += 0.5 * (speeds[k - 1] + speeds[k]) * dt as f64;
            }
            clean.push((speeds[k] * (1.0 + amp * (cycles * theta + phase).sin())) as f32);
        }
        let late: Vec<f32> = (0..n).map(|k| clean[k.saturating_sub(whole)]).collect();
        let mut rng = crate::rng::seeded(7);
        let noisy: Vec<f32> = late
            .iter()
            .map(|c| c + sigma * crate::rng::normal(&mut rng))
            .collect();
        let p = motor
            .with(ParamId::RippleAmp, amp as f32)
            .with(ParamId::RippleCycles, cycles as f32)
            .with(ParamId::RipplePhase, phase as f32)
            .with(ParamId::Td, whole as f32 * dt);
        let mut sim = Simulator::new(&p, dt, InitialState::REST).unwrap();
        let mut sum = 0.0f64;
        for k in 0..n {
            sum += ((sim.reading().omega - late[k]) as f64).powi(2);
            let next = noisy.get(k + 1).copied();
            sim.apply(&StepInput {
                v: volts,
                tl: 0.0,
                measured: Some(MeasuredTacho {
                    rate: 0.5 * (noisy[k] + next.unwrap_or(noisy[k])),
                    after: next.filter(|_| track),
                }),
                opens: false,
            });
        }
        (sum / n as f64).sqrt() as f32
    }

    #[test]
    fn a_tracked_ripple_angle_follows_the_rotor_where_the_integrated_one_walks_off() {
        // Integrated alone, the angle takes the readings' noise as a random walk: the
        // predicted reading strays by a sizeable share of the noise (0.05 rad/s).
        let walked = gap(false, 0);
        assert!(walked > 0.02, "{walked}");
        // Tracked, it stays within a fifth of the noise: the filter's own steady state is
        // a phase error of (cycles dt sigma^2 / (w amp / sqrt 2))^(1/2) = 1.2e-3 rad, a
        // reading 0.006 rad/s RMS off.
        let tracked = gap(true, 0);
        assert!(tracked < 0.01, "{tracked} against {walked}");
    }

    #[test]
    fn a_delayed_reading_is_tracked_through_its_delay() {
        // Three samples late: the ripple's phase moves by 2 rad over the delay at 240
        // rad/s. The angle integrates the late readings, so it is the angle of the reading
        // the sensor gives now: delayed once more with the shaft speed it was 2 rad off.
        let walked = gap(false, 3);
        let tracked = gap(true, 3);
        assert!(walked > 0.02 && walked < 0.1, "{walked}");
        assert!(tracked < 0.01, "{tracked} against {walked}");
    }
}
