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
//! (Records of averaged readings, a board's, hold no ripple.)
//!
//! What it changes for a fit: `ripple_phase` is the angle at each record's start, which the
//! tracker takes up within some hundred steps of the shaft turning (a phase half a turn off
//! no longer leaves least squares on a ridge); it is pinned by those first revolutions only,
//! and a report may call it not pinned. Measured on the blind checks: the ripple's fits
//! reach the noise floor, docs/measurements/blind-checks.md (last section).

use super::Simulator;
use crate::param_id::ParamId;

/// The tracker's state.
#[derive(Clone, Copy, Debug)]
pub(super) struct AngleTracker {
    /// The variance of the angle's error over the tacho noise's variance [rad^2 per
    /// (rad/s)^2].
    variance: f32,
    /// The reading the simulation predicts for the newest sample [rad/s] (none before the
    /// first step of a record).
    predicted: Option<f32>,
    /// Its slope in the angle [rad/s per rad] (the factor `1 - amp sin(.)` of
    /// [`crate::model::effects::tacho_ripple::rotor_angle`]'s slope left out: a gain off by at most `amp`).
    slope: f32,
    /// The cosine of `ripple_phase` ([`crate::model::effects::tacho_ripple::reading_and_slope_at_read`]).
    pub(super) cos_phase: f32,
}

impl AngleTracker {
    /// At a record's start, for a ripple of phase `phase`: the angle known.
    pub(super) fn start(phase: f32) -> AngleTracker {
        AngleTracker {
            variance: 0.0,
            predicted: None,
            slope: 0.0,
            cos_phase: libm::cosf(phase),
        }
    }

    /// Keep the reading predicted for the newest sample and its slope in the angle.
    #[inline(always)]
    pub(super) fn predict(&mut self, reading: f32, slope: f32) {
        (self.predicted, self.slope) = (Some(reading), slope);
    }

    /// The reading predicted for the newest sample.
    #[inline(always)]
    pub(super) fn predicted(&self) -> Option<f32> {
        self.predicted
    }
}

impl Simulator {
    /// Correct the ripple angle by the tacho's reading `measured` at the end of the step
    /// just taken (see the module doc).
    #[inline(always)]
    pub(super) fn track_angle(&mut self, measured: f32) {
        let (cycles, dt) = (self.effect(ParamId::RippleCycles), self.dt);
        let Some(tracker) = self.angle_tracker.first_mut() else {
            return;
        };
        let Some(predicted) = tracker.predicted else {
            return;
        };
        let (walk, slope) = (cycles * dt, tracker.slope);
        let prior = tracker.variance + walk * walk;
        let gain = prior * slope / (slope * slope * prior + 1.0);
        let shift = gain * (measured - predicted);
        if !shift.is_finite() {
            return;
        }
        tracker.variance = prior * (1.0 - gain * slope);
        // (Not wrapped: a shift is a small part of a turn, and the next step's advance
        // wraps the angle. The cogging's angle is left as integrated: the shift also takes
        // up an error of the ripple's phase, which is no error of the rotor's angle; carried
        // over, it moved the detents off and cogging beside a ripple went unnamed on the
        // blind checks.)
        self.psi += shift;
    }
}

#[cfg(test)]
mod tests {
    use super::super::{InitialState, MeasuredTacho, StepInput};
    use super::*;
    use crate::model::params::ModelParams;
    use std::vec::Vec;

    /// A record of a rippled tacho and what a simulator told it predicts.
    struct Case {
        /// The angle tracked, or only integrated.
        track: bool,
        /// Whole samples the readings are late.
        late: usize,
        /// The sample the record starts at (the shaft turning from there on).
        from: usize,
        /// The error of the `ripple_phase` the simulator is given [rad].
        phase_error: f32,
    }

    /// The gaps between the reading a simulator of a rippled tacho predicts and the
    /// noiseless reading, sample by sample, when it is given the readings with white noise
    /// of 0.05 rad/s. A light motor at 12 V (about 240 rad/s) for 2 s at 5 kHz, a 3 %
    /// ripple at 14 per revolution; the record is the run from sample `from` on. The truth
    /// is the test's own: the shaft speed of a simulator without ripple, its angle
    /// integrated in f64, the reading's formula written out.
    fn gaps(case: Case) -> Vec<f32> {
        let (dt, n, volts, sigma) = (2e-4f32, 10_000, 12.0f32, 0.05f32);
        let (amp, cycles, phase) = (0.03f64, 14.0f64, 0.7f64);
        let motor = ModelParams::motor(1.0, 1e-3, 1e-4, 1e-5, 0.05);
        let mut shaft = Simulator::new(&motor, dt, InitialState::REST).unwrap();
        let mut states = Vec::new();
        for _ in 0..n {
            states.push((shaft.reading().current, shaft.omega()));
            shaft.advance(volts, 0.0);
        }
        let w = |j: usize| states[j].1 as f64;
        let mut theta = std::vec![0.0f64; n];
        for j in 1..n {
            theta[j] = theta[j - 1] + 0.5 * (w(j - 1) + w(j)) * dt as f64;
        }
        // The record's first reading is the sensor's of sample `from - late`: the phase
        // is the angle there.
        let first = case.from.saturating_sub(case.late);
        let reading = |j: usize| {
            let angle = cycles * (theta[j] - theta[first]) + phase;
            (w(j) * (1.0 + amp * angle.sin())) as f32
        };
        let late: Vec<f32> = (case.from..n)
            .map(|j| reading(j.saturating_sub(case.late).max(first)))
            .collect();
        let mut rng = crate::rng::seeded(7);
        let noisy: Vec<f32> = late
            .iter()
            .map(|c| c + sigma * crate::rng::normal(&mut rng))
            .collect();
        let p = motor
            .with(ParamId::RippleAmp, amp as f32)
            .with(ParamId::RippleCycles, cycles as f32)
            .with(ParamId::RipplePhase, phase as f32 + case.phase_error)
            .with(ParamId::Td, case.late as f32 * dt);
        let (current, omega) = states[case.from];
        let mut sim = Simulator::new(&p, dt, InitialState { current, omega }).unwrap();
        let mut out = Vec::new();
        for k in 0..late.len() {
            out.push(sim.reading().omega - late[k]);
            let next = noisy.get(k + 1).copied();
            sim.apply(&StepInput {
                v: volts,
                tl: 0.0,
                measured: Some(MeasuredTacho {
                    rate: 0.5 * (noisy[k] + next.unwrap_or(noisy[k])),
                    after: next.filter(|_| case.track),
                }),
                opens: false,
            });
        }
        out
    }

    /// The RMS of `gaps`.
    fn rms(gaps: &[f32]) -> f32 {
        let sum: f64 = gaps.iter().map(|g| (*g as f64).powi(2)).sum();
        (sum / gaps.len() as f64).sqrt() as f32
    }

    /// [`gaps`]' RMS from rest, told the right phase.
    fn gap(track: bool, late: usize) -> f32 {
        rms(&gaps(Case {
            track,
            late,
            from: 0,
            phase_error: 0.0,
        }))
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

    #[test]
    fn a_delayed_record_that_starts_turning_is_rippled_once() {
        // From 0.4 s on, at full speed, three samples late: the delay line's first entry
        // is the record's first reading, rippled; taken for the shaft speed, it was rippled
        // again for the delay's first samples (7 rad/s off: the ripple's size).
        let tracked = rms(&gaps(Case {
            track: true,
            late: 3,
            from: 2000,
            phase_error: 0.0,
        }));
        assert!(tracked < 0.01, "{tracked}");
    }

    #[test]
    fn a_ripple_phase_half_a_turn_off_is_pulled_in() {
        // The simulator told a phase 3 rad off (a fit's start on the ridge): integrated
        // alone the reading misfits by the ripple's size throughout; tracked, the angle is
        // pulled in and the second half of the record is within a fifth of the noise.
        let off = |track| {
            gaps(Case {
                track,
                late: 0,
                from: 0,
                phase_error: 3.0,
            })
        };
        let (walked, tracked) = (off(false), off(true));
        assert!(rms(&walked[5000..]) > 1.0, "{}", rms(&walked[5000..]));
        assert!(rms(&tracked[5000..]) < 0.01, "{}", rms(&tracked[5000..]));
    }
}
