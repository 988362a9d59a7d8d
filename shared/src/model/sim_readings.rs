//! What a simulation's sensors read: the tacho (its ripple, paper Eq. 4's speed seen through
//! [`crate::model::effects::tacho_ripple`]) through the delay line of
//! [`crate::model::effects::sensor_delay`] (where the ripple's angle follows a record's
//! readings, the shaft speed through the delay line and the ripple after it), and the
//! current with its sensor's offset ([`crate::model::effects::current_offset`]).

use super::{Reading, Simulator, RING};
use crate::capacity::FULL;
use crate::model::effects::{current_offset, sensor_delay, tacho_ripple};
use crate::param_id::ParamId;

impl Simulator {
    #[inline(always)]
    pub(super) fn push_reading(&mut self) {
        let (amp, phase) = (
            self.effect(ParamId::RippleAmp),
            self.effect(ParamId::RipplePhase),
        );
        if FULL && self.psi_from_reading && amp != 0.0 {
            return self.push_reading_at_measured_angle(amp, phase);
        }
        self.push_tacho(tacho_ripple::reading(amp, phase, self.omega.hi, self.psi));
    }

    /// [`Simulator::push_reading`] when the ripple's angle integrates the record's readings
    /// ([`Simulator::apply`]): those are as late as the sensor is, so the angle is the
    /// rotor's of the reading the sensor gives now, and the ripple applies to the shaft
    /// speed after the delay line (not before, where it would be late twice: 2 rad of the
    /// ripple's phase for a delay of 3 samples of a 14 per revolution ripple at 240 rad/s,
    /// 5 kHz). Keeps the reading's slope in the angle for the angle's tracker
    /// (`sim_angle_tracker.rs`).
    #[inline(never)]
    fn push_reading_at_measured_angle(&mut self, amp: f32, phase: f32) {
        self.push_tacho(self.omega.hi);
        let late = self.delay_line_output();
        let psi = self.psi;
        if let Some(t) = self.angle_tracker.first_mut() {
            let given = (phase, t.cos_phase);
            let (reading, slope) = tacho_ripple::reading_and_slope_at_read(amp, given, late, psi);
            t.predict(reading, slope);
        }
    }

    /// The delay line's entry at a record's start (the tacho's first reading, rippled), as
    /// the shaft speed `w0` it was, once the ripple's angle follows the record's readings
    /// and the line holds the shaft speed ([`Simulator::push_reading_at_measured_angle`]):
    /// taken rippled, it was rippled twice for the delay's first samples. (A record's
    /// simulator is given its readings from its first step on, `Record::step_input`: the
    /// line holds that one entry then.)
    pub(super) fn unripple_delay_line(&mut self, w0: f32) {
        if self.delayed && self.filled == 1 {
            self.ring[usize::from(self.head)] = w0;
        }
    }

    #[inline(always)]
    pub(super) fn push_tacho(&mut self, tacho: f32) {
        self.tacho = tacho;
        if self.delayed {
            let head = (usize::from(self.head) + 1) % RING;
            self.ring[head] = self.tacho;
            self.head = head as u8;
            self.filled = (usize::from(self.filled) + 1).min(RING) as u8;
        }
    }

    /// The speed the delay line reads now (paper Eq. 4's speed `td` late,
    /// [`sensor_delay::interpolate`]).
    fn delay_line(&self) -> f32 {
        let back = |n: usize| {
            let n = n.min(usize::from(self.filled) - 1);
            self.ring[(usize::from(self.head) + RING - n) % RING]
        };
        let whole = usize::from(self.delay_whole);
        sensor_delay::interpolate(back(whole), back(whole + 1), self.delay_frac)
    }

    /// What leaves the delay line now: the newest value pushed, or the one `td` before.
    #[inline(always)]
    fn delay_line_output(&self) -> f32 {
        match self.delayed {
            false => self.tacho,
            true => self.delay_line(),
        }
    }

    /// What the sensors read now.
    #[inline(always)]
    pub fn reading(&self) -> Reading {
        let tracked = match FULL && self.psi_from_reading {
            true => self.angle_tracker.first().and_then(|t| t.predicted()),
            false => None,
        };
        let omega = match tracked {
            Some(reading) => reading,
            None => self.delay_line_output(),
        };
        Reading {
            omega,
            current: current_offset::reading(self.effect(ParamId::Io), self.current.hi),
        }
    }
}
