//! The drive's limits that commissioning works within: the largest voltage it applies, the
//! current and speed at which it trips, and the time the whole experiment may take.

use serde::{Deserialize, Serialize};

/// Limits of self-commissioning.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    /// Largest armature voltage applied [V].
    pub voltage: f32,
    /// Trip above this |current| [A].
    pub current: f32,
    /// Trip above this |speed| [rad/s].
    pub speed: f32,
    /// Longest the experiment (probe and records) may take [s].
    pub budget: f32,
}

impl Limits {
    /// Conservative defaults for a drive board of the paper's class (a 50 V motor): 50 V,
    /// 40 A, 500 rad/s, 60 s.
    pub const DEFAULT: Limits = Limits {
        voltage: 50.0,
        current: 40.0,
        speed: 500.0,
        budget: 60.0,
    };

    /// Shortest time budget [s]: the probe alone needs a few seconds.
    pub const MIN_BUDGET: f32 = 5.0;

    /// One count of a `bits`-bit ADC that reads speed and current over ±1.2 times their
    /// limits [rad/s, A] (a drive board's tacho and current scales).
    pub fn adc_counts(&self, bits: u32) -> (f32, f32) {
        let counts = (1u64 << bits.min(63)) as f32;
        (2.4 * self.speed / counts, 2.4 * self.current / counts)
    }

    /// Whether every limit is a finite positive number and the budget at least
    /// [`Limits::MIN_BUDGET`] (and at most a day).
    pub fn usable(&self) -> bool {
        let positive = |x: f32| x.is_finite() && x > 0.0;
        positive(self.voltage)
            && positive(self.current)
            && positive(self.speed)
            && self.budget >= Self::MIN_BUDGET
            && self.budget <= 86_400.0
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_usable_and_nonsense_is_not() {
        assert!(Limits::DEFAULT.usable());
        let fields: [fn(&mut Limits) -> &mut f32; 4] = [
            |l| &mut l.voltage,
            |l| &mut l.current,
            |l| &mut l.speed,
            |l| &mut l.budget,
        ];
        for (k, field) in fields.iter().enumerate() {
            for bad in [0.0, -1.0, f32::NAN, f32::INFINITY] {
                let mut l = Limits::DEFAULT;
                *field(&mut l) = bad;
                assert!(!l.usable(), "field {k} = {bad}");
            }
        }
        let short = Limits {
            budget: 1.0,
            ..Limits::DEFAULT
        };
        assert!(!short.usable());
    }

    #[test]
    fn a_12_bit_adc_counts_over_2_4_times_the_limits() {
        let (w, i) = Limits::DEFAULT.adc_counts(12);
        assert_eq!((w, i), (1200.0 / 4096.0, 96.0 / 4096.0));
    }
}
