//! Recording the designed experiment ([`crate::device::design`]): the bridge's inputs of the
//! slow and the fast record, and the drive's samples taken into record samples.
//!
//! The model reads record sample k at the instant k·dt and holds the voltage of sample k over
//! [k·dt, (k+1)·dt) (zero-order hold). The drive samples `m` times faster and holds the same
//! voltage over those `m` samples. With [`Bench::averaged`] (the firmware's default) record
//! sample k is the mean of the drive's readings over the step that ends at it, sample 0 the
//! mean of as many at 0 V before the record, and the records say so
//! ([`crate::model::record::Record::averaged`]): the fit simulates that mean
//! ([`crate::model::step_mean`]), and the noise is √m lower. Motor-like motors with all six
//! within 3 % 93.9 → 98.2 %, the whole box 75.0 → 82.1 %
//! (`docs/measurements/commissioning.md`). Without it record sample k is the drive's reading
//! at the instant k·dt. (Means fitted as instants were biased by the signal's curvature over
//! the window, which the fit's noise floor σ/√m exposed: a median of 1,867 evaluations on
//! the benchmark, against 52.)

use crate::device::bench::Bench;
use crate::device::design::RecordPlan;
use crate::device::hardware::{Bridge, Drive, Link, Watchdog};
use crate::device::job::JobEnd;
use crate::device::record_store::RecordStore;

/// First sample of the coast-down in a slow record of `n` samples: the last quarter coasts.
pub const fn coast_start(n: usize) -> usize {
    n - n / 4
}

/// Dips of the voltage within each level of the slow record.
pub const DITHER_CYCLES: usize = 8;
/// Depth of a dip, a share of the level's voltage.
pub const DITHER_DEPTH: f32 = 0.1;

/// Input of sample `k` of the slow record of `n` samples: ½ → ¼ → 1 of `volts` over three
/// equal parts of the first three quarters (paper's Section 6 speed changes: each level a
/// speed held for several mechanical time scales, so that the torque balance of paper Eq. 4
/// is seen at three speeds, and the step down reverses the current against the back-EMF),
/// then the bridge open over the last quarter: the coast-down, friction alone slowing the
/// shaft, from the highest speed, where viscous friction B ω stands out most against
/// Coulomb friction.
///
/// Within each level the voltage dips by [`DITHER_DEPTH`] over every second of
/// 2 × [`DITHER_CYCLES`] equal parts. A level held still keeps the current and speed
/// readings on one ADC count (the noise is under a count), so that its mean, which carries
/// B through B ω / Kv, is known to a count only, and that rounding is the same over the
/// whole level, where the block scores cannot see it. Each dip moves the current by
/// 0.1 V / Ra and lets it relax with the mechanical time scale, sweeping the readings over
/// many counts so that their rounding averages out. On the commissioning benchmark's 1,000
/// motors: motor-like motors with all six within 3 % 89.6 → 93.9 %, pinned estimates within
/// 3 σ 94.7 → 96.8 %, the fit's 90th percentile of evaluations 1,771 → 137
/// (`docs/measurements/commissioning.md`).
pub fn slow_input(k: usize, n: usize, volts: f32) -> Bridge {
    let coast = coast_start(n);
    if k >= coast {
        return Bridge::Open;
    }
    let share = match 3 * k / coast.max(1) {
        0 => 0.5,
        1 => 0.25,
        _ => 1.0,
    };
    let dip = match (2 * DITHER_CYCLES * 3 * k / coast.max(1)) % 2 {
        0 => 1.0,
        _ => 1.0 - DITHER_DEPTH,
    };
    Bridge::Drive(share * dip * volts)
}

/// Input of sample `k` of the fast record of `n` samples: 0 V over the first twentieth, the
/// voltage until half way, then 0 V (the current reverses against the back-EMF).
pub fn fast_input(k: usize, n: usize, volts: f32) -> Bridge {
    if k >= (n / 20).max(1) && k < n / 2 {
        Bridge::Drive(volts)
    } else {
        Bridge::Drive(0.0)
    }
}

/// Record one record into `store` after those it holds: `plan.samples` samples of
/// `plan.step` drive samples each, the bridge as `input(k)` over record sample k, its
/// coast-down from `coast_from`; each sample the reading at its instant, or with
/// [`Bench::averaged`] the mean of the step's (see the module doc). `Ok(false)` when a reading passed the bench's guard
/// ([`Bench::guarded`]): the bridge is then open and the record incomplete.
pub fn record<const N: usize, D: Drive, L: Link, W: Watchdog>(
    bench: &mut Bench<D, L, W>,
    store: &mut RecordStore<N>,
    plan: RecordPlan,
    speed_share: f32,
    coast_from: Option<usize>,
    input: impl Fn(usize) -> Bridge,
) -> Result<bool, JobEnd> {
    let m = plan.step as usize;
    let averaged = bench.averaged && m > 1;
    let index = store.open(
        plan.dt(bench.dt()),
        coast_from,
        if averaged { m as u32 } else { 1 },
    );
    let n = plan.samples.min(store.free());
    if n == 0 {
        return Ok(true);
    }
    let (mut sum_w, mut sum_i) = (0.0f32, 0.0f32);
    if averaged {
        // Sample 0: the mean over the step that ends where the record starts, at 0 V (a
        // record starts from rest, or after the quiet wait ran out, braking; the fit reads
        // its starting state from this mean, `Simulator::for_record`): the readings at the
        // step's last m - 1 drive samples here, its end's below.
        for _ in 1..m {
            let Some(s) = bench.guarded(Bridge::Drive(0.0), speed_share)? else {
                return Ok(false);
            };
            sum_w += s.omega;
            sum_i += s.current;
        }
    }
    for b in 0..=(n - 1) * m {
        let k = b / m;
        let Some(s) = bench.guarded(input(k), speed_share)? else {
            return Ok(false);
        };
        if averaged {
            sum_w += s.omega;
            sum_i += s.current;
        }
        if b % m == 0 {
            let (w, i) = match averaged {
                true => (sum_w / m as f32, sum_i / m as f32),
                false => (s.omega, s.current),
            };
            (sum_w, sum_i) = (0.0, 0.0);
            store.push(index, input(k).recorded_volts(), w, i);
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::hardware::{NoWatchdog, Sample};
    use crate::testkit::SilentLink;
    use crate::wire::limits::Limits;

    #[test]
    fn the_slow_record_steps_half_quarter_full_then_coasts() {
        let (n, volts) = (2000, 48.0);
        let inputs: std::vec::Vec<Bridge> = (0..n).map(|k| slow_input(k, n, volts)).collect();
        assert_eq!(coast_start(n), 1500);
        // Each level of 500 samples: 16 parts of 31.25 samples, every second one dipped
        // by a tenth.
        let dipped = 1.0 - DITHER_DEPTH;
        assert_eq!(inputs[0], Bridge::Drive(24.0));
        assert_eq!(inputs[31], Bridge::Drive(24.0));
        assert_eq!(inputs[32], Bridge::Drive(24.0 * dipped));
        assert_eq!(inputs[499], Bridge::Drive(24.0 * dipped));
        assert_eq!(inputs[500], Bridge::Drive(12.0));
        assert_eq!(inputs[1000], Bridge::Drive(48.0));
        assert_eq!(inputs[1499], Bridge::Drive(48.0 * dipped));
        assert!(inputs[1500..].iter().all(|b| *b == Bridge::Open));
        // Half of each level is dipped: its mean voltage 0.95 of the level.
        for (level, volts) in [(0, 24.0), (1, 12.0), (2, 48.0)] {
            let mean: f32 = inputs[level * 500..(level + 1) * 500]
                .iter()
                .map(|b| match b {
                    Bridge::Drive(v) => *v,
                    Bridge::Open => f32::NAN,
                })
                .sum::<f32>()
                / 500.0;
            assert!((mean / volts - 0.95).abs() < 1e-3, "{level}: {mean}");
        }
        // No input exceeds the designed voltage.
        assert!(inputs.iter().all(|b| match b {
            Bridge::Drive(v) => *v <= volts,
            Bridge::Open => true,
        }));
    }

    /// A drive whose tacho reads its own sample count (1 rad/s a sample), no current.
    struct Counting(f32);

    impl Drive for Counting {
        fn dt(&self) -> f32 {
            1e-3
        }
        fn step(&mut self, _volts: f32) -> Sample {
            self.0 += 1.0;
            Sample {
                omega: self.0,
                current: 0.0,
            }
        }
        fn coast(&mut self) -> Sample {
            self.step(0.0)
        }
        fn stop(&mut self) {}
    }

    #[test]
    fn an_averaged_sample_is_the_mean_over_the_step_ending_at_it_the_first_too() {
        // Readings 1, 2, 3, ... at the drive's samples: the mean over each step of m ends
        // at the record's sample, so consecutive samples lie m apart, the first included
        // (its step the m readings at 0 V up to the record's start, the start's own last).
        let (mut drive, mut link, mut dog) = (Counting(0.0), SilentLink, NoWatchdog);
        let mut bench = Bench::new(&mut drive, &mut link, &mut dog, Limits::DEFAULT);
        bench.averaged = true;
        let mut store = RecordStore::<64>::new();
        store.clear(true);
        let plan = RecordPlan {
            step: 4,
            samples: 5,
        };
        let done = record(&mut bench, &mut store, plan, 1.0, None, |_| {
            Bridge::Drive(0.0)
        });
        assert_eq!(done, Ok(true));
        let records = store.records();
        // Readings 1..=4 before the start (the 4th at it), then 5..=8, ...
        assert_eq!(records[0].omega, [2.5, 6.5, 10.5, 14.5, 18.5]);
        assert_eq!(records[0].averaged, 4);
    }

    #[test]
    fn the_fast_record_steps_up_then_back_to_zero() {
        let inputs: std::vec::Vec<Bridge> = (0..400).map(|k| fast_input(k, 400, 9.0)).collect();
        assert_eq!(inputs[19], Bridge::Drive(0.0));
        assert_eq!(inputs[20], Bridge::Drive(9.0));
        assert_eq!(inputs[199], Bridge::Drive(9.0));
        assert_eq!(inputs[200], Bridge::Drive(0.0));
    }
}
