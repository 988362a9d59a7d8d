//! Commissioning's first stage and its waits: the shaft at rest, the current sensor's offset
//! and the sensors' noise ([`rest_and_offset`]), and the quiet waits for the shaft to calm
//! down between the probe's steps and before each record ([`quiet`]).

use crate::device::bench::Bench;
use crate::device::hardware::{Bridge, Drive, Link, Watchdog};
use crate::device::job::JobEnd;
use crate::wire::protocol::Refusal;

/// Samples of one look at the shaft at rest.
const REST_WINDOW: u32 = 64;

/// Time over which the current sensor's offset is averaged [s] (at least [`REST_WINDOW`]
/// readings): the records' currents carry what is left of the offset as a constant error the
/// fit does not model, so it must lie well under the fit's own resolution of a constant
/// (σ over the square root of the records' samples). What is left is read again in the slow
/// record's coast-down ([`crate::device::offset`]).
const OFFSET_SECONDS: f32 = 0.25;

/// Longest wait for the shaft to stand still before anything is applied [s].
const REST_SECONDS: f32 = 20.0;

/// Largest current sensor offset taken for an offset rather than a fault (share of the
/// current limit).
const MAX_OFFSET: f32 = 0.1;

/// Share of the budget a wait for the shaft to calm down may take.
pub const QUIET_BUDGET: f32 = 0.05;

/// Speed above which the shaft turns: six deviations of the speed reading's noise, at least
/// 0.2 % of the speed limit (a few counts of a 12-bit tacho).
fn motion_threshold(sigma_omega: f32, speed_limit: f32) -> f32 {
    (6.0 * sigma_omega).max(0.002 * speed_limit)
}

/// The shaft at rest: the current sensor's offset and the sensors' noise.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rest {
    /// Current read at 0 V with the shaft at rest [A].
    pub current_offset: f32,
    /// Standard deviation of the speed reading at rest [rad/s].
    pub sigma_omega: f32,
    /// Standard deviation of the current reading at rest [A].
    pub sigma_current: f32,
    /// Drive readings the offset is the mean of.
    pub offset_readings: u32,
}

impl Rest {
    /// Speed above which the shaft turns ([`motion_threshold`]).
    pub fn motion(&self, speed_limit: f32) -> f32 {
        motion_threshold(self.sigma_omega, speed_limit)
    }

    /// Current below which none flows: four deviations of its noise, at least 1 % of the
    /// current limit.
    pub(crate) fn no_current(&self, current_limit: f32) -> f32 {
        (4.0 * self.sigma_current).max(0.01 * current_limit)
    }
}

/// Stage 1: at 0 V, wait (up to [`REST_SECONDS`], or a third of the budget) until the speed
/// reads under the motion threshold ([`motion_threshold`]) and neither the speed nor the
/// current changes from one look to the next; then the current read with the bridge open (no
/// current can flow) is the sensor's offset (refused as a fault above [`MAX_OFFSET`] of the
/// limit) and the spread of the readings at rest is their noise. The spread is taken from
/// consecutive readings' differences (`E[(x_k - x_k-1)^2] = 2 σ²` for white noise), which a
/// slow trend does not inflate: a braking current still decaying after a run before (a
/// commissioning asked for again) read as noise of 0.1 A where the sensor's was 20 mA, and
/// the quiet waits judged by it let a record start with that current
/// (docs/measurements/commissioning.md).
#[inline(never)]
pub fn rest_and_offset<D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
) -> Result<Rest, JobEnd> {
    let limits = bench.limits;
    let looks = (REST_SECONDS.min(limits.budget / 3.0) / (REST_WINDOW as f32 * bench.dt())) as u32;
    let mut previous = (f32::NAN, f32::NAN);
    for _ in 0..looks.max(2) {
        let mut last = bench.apply(Bridge::Drive(0.0))?;
        let (mut sw, mut si) = (last.omega, last.current);
        let (mut dww, mut dii) = (0.0f32, 0.0f32);
        for _ in 1..REST_WINDOW {
            let s = bench.apply(Bridge::Drive(0.0))?;
            let (dw, di) = (s.omega - last.omega, s.current - last.current);
            (sw, si) = (sw + s.omega, si + s.current);
            (dww, dii) = (dww + dw * dw, dii + di * di);
            last = s;
        }
        let (n, pairs) = (REST_WINDOW as f32, (REST_WINDOW - 1) as f32);
        let (w, i) = (sw / n, si / n);
        let (var_w, var_i) = (dww / (2.0 * pairs), dii / (2.0 * pairs));
        let unchanged = |now: f32, before: f32, var: f32, limit: f32| {
            (now - before).abs() <= 4.0 * libm::sqrtf(var / n) + 1e-4 * limit
        };
        let still = unchanged(w, previous.0, var_w, limits.speed)
            && unchanged(i, previous.1, var_i, limits.current);
        previous = (w, i);
        // Standing: no faster than the motion threshold (a shaft still braking at 0 V draws
        // -Kv ω / Ra, which would be taken for the sensor's offset).
        if w.abs() <= motion_threshold(libm::sqrtf(var_w), limits.speed) && still {
            // The offset with the bridge open: no current can flow, whatever the shaft does.
            let readings = ((OFFSET_SECONDS / bench.dt()) as u32).max(REST_WINDOW);
            let mut offset = 0.0f32;
            for _ in 0..readings {
                offset += bench.apply(Bridge::Open)?.current;
            }
            let offset = offset / readings as f32;
            if offset.abs() > MAX_OFFSET * limits.current {
                return Err(JobEnd::Refused(Refusal::SensorFault));
            }
            return Ok(Rest {
                current_offset: offset,
                sigma_omega: libm::sqrtf(var_w),
                sigma_current: libm::sqrtf(var_i),
                offset_readings: readings,
            });
        }
    }
    Err(JobEnd::Refused(Refusal::NotAtRest))
}

/// Drive 0 V until no current flows and the shaft stands, for at most `seconds`; then go on
/// whatever the shaft does (a record may start in motion). Judged on means over windows of
/// [`REST_WINDOW`] samples, each within three of its deviations of zero (and 0.01 % of the
/// limit): a heavy shaft still turning at a fraction of a radian per second reads as rest
/// sample by sample, yet the fit would take it for rest, with a braking current that rest
/// cannot have.
pub fn quiet<D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
    rest: &Rest,
    seconds: f32,
) -> Result<(), JobEnd> {
    let limits = bench.limits;
    let n = REST_WINDOW as f32;
    let within = |sigma: f32, limit: f32| 3.0 * sigma / libm::sqrtf(n) + 1e-4 * limit;
    let (still_w, no_i) = (
        within(rest.sigma_omega, limits.speed),
        within(rest.sigma_current, limits.current),
    );
    let windows = (seconds.max(0.0) / (n * bench.dt())) as u32;
    for _ in 0..windows.max(1) {
        let (mut sw, mut si) = (0.0f32, 0.0f32);
        for _ in 0..REST_WINDOW {
            let s = bench.apply(Bridge::Drive(0.0))?;
            (sw, si) = (sw + s.omega, si + s.current);
        }
        if (sw / n).abs() <= still_w && (si / n).abs() <= no_i {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::hardware::{NoWatchdog, Sample};
    use crate::rng::{self, Rng};
    use crate::testkit::SilentLink;
    use crate::wire::limits::Limits;

    /// A shaft at rest whose armature current still decays at 0 V (from `-0.5` A, with a
    /// time constant of 60 samples, after a run before), sensors with white noise of 0.1
    /// rad/s and 20 mA; no current with the bridge open.
    struct Decaying {
        k: f32,
        rng: Rng,
    }

    impl Drive for Decaying {
        fn dt(&self) -> f32 {
            5e-4
        }
        fn step(&mut self, _volts: f32) -> Sample {
            self.k += 1.0;
            Sample {
                omega: 0.1 * rng::normal(&mut self.rng),
                current: -0.5 * libm::expf(-self.k / 60.0) + 0.02 * rng::normal(&mut self.rng),
            }
        }
        fn coast(&mut self) -> Sample {
            Sample {
                omega: 0.1 * rng::normal(&mut self.rng),
                current: 0.02 * rng::normal(&mut self.rng),
            }
        }
        fn stop(&mut self) {}
    }

    #[test]
    fn a_decaying_current_is_waited_for_and_not_taken_for_noise() {
        for seed in 0..8 {
            let mut drive = Decaying {
                k: 0.0,
                rng: rng::seeded(seed),
            };
            let (mut link, mut dog) = (SilentLink, NoWatchdog);
            let mut bench = Bench::new(&mut drive, &mut link, &mut dog, Limits::DEFAULT);
            let rest = rest_and_offset(&mut bench).unwrap();
            // The noise within a fifth of the sensor's (a window's spread over the decay
            // read 0.1 A and more), and the wait went on until the current stood still:
            // past 5 time constants, where less than 4 mA of it is left.
            assert!((rest.sigma_current / 0.02 - 1.0).abs() < 0.2, "{rest:?}");
            assert!((rest.sigma_omega / 0.1 - 1.0).abs() < 0.2, "{rest:?}");
            assert!(rest.current_offset.abs() < 5e-3, "{rest:?}");
            let waited = bench.seconds() / 5e-4 - rest.offset_readings as f32;
            assert!(waited >= 5.0 * 60.0, "{waited} samples");
        }
    }
}
