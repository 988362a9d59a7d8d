//! What a simulation's sensors read: the tacho (its ripple, paper Eq. 4's speed seen through
//! [`crate::model::effects::tacho_ripple`]) through the delay line of
//! [`crate::model::effects::sensor_delay`], and the current with its sensor's offset
//! ([`crate::model::effects::current_offset`]).

use super::{Reading, Simulator, RING};
use crate::capacity::FULL;
use crate::model::effects::{current_offset, sensor_delay, tacho_ripple};
use crate::param_id::ParamId;

impl Simulator {
    #[inline(always)]
    pub(super) fn tacho_now(&self) -> f32 {
        let (amp, phase) = (
            self.effect(ParamId::RippleAmp),
            self.effect(ParamId::RipplePhase),
        );
        let psi = match FULL && self.psi_from_reading && amp != 0.0 {
            true => tacho_ripple::rotor_angle(amp, phase, self.psi),
            false => self.psi,
        };
        tacho_ripple::reading(amp, phase, self.omega.hi, psi)
    }

    #[inline(always)]
    pub(super) fn push_reading(&mut self) {
        self.push_tacho(self.tacho_now());
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

    fn ring_back(&self, n: usize) -> f32 {
        let n = n.min(usize::from(self.filled) - 1);
        self.ring[(usize::from(self.head) + RING - n) % RING]
    }

    /// What the sensors read now.
    #[inline(always)]
    pub fn reading(&self) -> Reading {
        let omega = if !self.delayed {
            self.tacho
        } else {
            let whole = usize::from(self.delay_whole);
            let a = self.ring_back(whole);
            let b = self.ring_back(whole + 1);
            sensor_delay::interpolate(a, b, self.delay_frac)
        };
        Reading {
            omega,
            current: current_offset::reading(self.effect(ParamId::Io), self.current.hi),
        }
    }
}
