//! How an ADC rounds a record's readings, and the error a reading held within one count
//! keeps however many samples are averaged: what a board's deviations add for its own
//! records ([`crate::fit::score_blocks`]).

/// How an ADC rounds a record's readings: its count and the spread of the error a reading
/// held within one count keeps ([`Rounding::of`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rounding {
    /// One count: the smallest step between consecutive readings (0: not on a grid).
    pub count: f32,
    /// Standard deviation of a held reading's rounding error.
    pub error: f32,
}

impl Rounding {
    /// The rounding of readings `x` whose measured noise is `sigma` (rounding included):
    /// with the noise before rounding `s` (Sheppard: `s^2 = sigma^2 - q^2/12`, `q` the
    /// count), the mean of the rounded readings of a signal held at a point of the count
    /// misses it by `(q/pi) sum_k (-1)^(k+1)/k e^(-2 pi^2 k^2 s^2/q^2) sin(2 pi k x/q)`; over
    /// a point uniform within the count its variance is
    /// `q^2/(2 pi^2) sum_k e^(-4 pi^2 k^2 s^2/q^2)/k^2` (eight terms; `q^2/12` without noise).
    /// A signal held within one count (a steady speed or current) errs by that much for as
    /// long as it stays there, however many samples are averaged: 0.29 count without noise,
    /// 0.10 with a noise of 0.2 count, 0.001 with half a count. About 0 for readings not on
    /// a grid (their smallest step lies far below the noise).
    pub fn of(x: &[f32], sigma: f32) -> Rounding {
        Rounding::of_means(x, sigma, 1)
    }

    /// [`Rounding::of`] for readings each the mean of `m` rounded readings (a record of
    /// averaged readings, [`crate::model::record::Record::averaged`]): their grid is a count
    /// over `m` and their noise `sigma` is one reading's over √m, while the error of a
    /// reading held within one count is one reading's, averaged or not.
    #[inline(never)]
    pub fn of_means(x: &[f32], sigma: f32, m: u32) -> Rounding {
        // Means of readings that the drive offset in f32 differ by rounding residue where
        // their sums are equal: steps under a thousandth of the noise are that.
        let least = match m > 1 {
            true => 1e-3 * sigma,
            false => 0.0,
        };
        let mut step = f32::INFINITY;
        for w in x.windows(2) {
            let d = (w[1] - w[0]).abs();
            if d > least && d < step {
                step = d;
            }
        }
        if !step.is_finite() {
            return Rounding::default();
        }
        // The smallest step may span several of the grid's (means of hundreds of readings
        // seldom differ by one): the grid is the largest that holds the small steps.
        // (Taken for the grid, three of its steps made a count three times too large, and a
        // held reading's error seven times: the deviations of B and tc of a benchmark motor
        // 60 times their noise's, docs/measurements/commissioning.md.)
        let step = grid_of(x, step, least);
        let m = m.max(1) as f32;
        let (q, sigma) = (step * m, sigma * libm::sqrtf(m));
        // In f32 (a board's FPU), the terms r^(k^2) by products, r = e^(-4 pi^2 s^2/q^2).
        let pi = core::f32::consts::PI;
        let s2 = (sigma * sigma - q * q / 12.0).max(0.0);
        let r = libm::powf(core::f32::consts::E, -4.0 * pi * pi * s2 / (q * q));
        let (mut term, mut step, r2) = (r, r, r * r);
        let mut sum = 0.0f32;
        for k in 1..=8u8 {
            sum += term / f32::from(k * k);
            step *= r2;
            term *= step;
        }
        Rounding {
            count: q,
            error: q / pi * libm::sqrtf(0.5 * sum),
        }
    }

    /// The count `y` lies in (0 when not on a grid).
    pub fn cell(&self, y: f32) -> i32 {
        match self.count > 0.0 {
            true => libm::roundf(y / self.count) as i32,
            false => 0,
        }
    }
}

/// The grid of readings `x` whose smallest step above `least` is `step`: the largest
/// `step / k`, `k` up to [`GRID_DIVISORS`], on which every step of up to [`GRID_QUOTIENT`]
/// smallest ones lies within a quarter of the grid's step (larger steps are left out: the
/// error of `step`, f32 residue of means, grows with the quotient); `step` itself if none.
fn grid_of(x: &[f32], step: f32, least: f32) -> f32 {
    for k in 1..=GRID_DIVISORS {
        let grid = step / f32::from(k);
        let on_grid = x.windows(2).all(|w| {
            let d = (w[1] - w[0]).abs();
            let n = d / grid;
            d <= least || d > GRID_QUOTIENT * step || (n - libm::roundf(n)).abs() <= 0.25
        });
        if on_grid {
            return grid;
        }
    }
    step
}

/// Most grid steps the smallest step of a record's readings is taken to span.
const GRID_DIVISORS: u8 = 4;
/// Largest step, in smallest steps, that [`grid_of`] checks.
const GRID_QUOTIENT: f32 = 4.0;

#[cfg(test)]
mod tests {
    use super::*;

    extern crate std;
    use std::vec::Vec;

    fn rms(v: impl Iterator<Item = f64>) -> f64 {
        let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
        libm::sqrt(s / n as f64)
    }

    #[test]
    fn means_of_rounded_readings_keep_one_reading_s_count_and_held_error() {
        // Readings on a grid of 0.25 with noise of 0.2 count, offset by a constant as a
        // board subtracts its sensor's offset, averaged in eights: their grid is an eighth of
        // a count (with f32 residue under it), their noise an eighth's root of one reading's.
        let (q, m, noise) = (0.25f32, 8u32, 0.05f32);
        let mut rng = crate::rng::seeded(5);
        let mut single = Vec::new();
        let mut means = Vec::new();
        for p in 0..400 {
            let x = 3.0 + 0.37 * p as f32 / 400.0;
            let mut sum = 0.0f32;
            for _ in 0..m {
                let y = libm::roundf((x + noise * crate::rng::normal(&mut rng)) / q) * q - 0.0137;
                single.push(y);
                sum += y;
            }
            means.push(sum / m as f32);
        }
        let sigma = libm::sqrtf(noise * noise + q * q / 12.0);
        let one = Rounding::of(&single, sigma);
        let averaged = Rounding::of_means(&means, sigma / libm::sqrtf(m as f32), m);
        assert!((one.count - q).abs() < 1e-6, "{one:?}");
        assert!((averaged.count - q).abs() < 1e-4, "{averaged:?}");
        assert!(
            (averaged.error / one.error - 1.0).abs() < 1e-3,
            "{averaged:?} {one:?}"
        );
        // Read as single readings, the means would claim a count of an eighth, or of the
        // residue.
        assert!(Rounding::of(&means, sigma).count < 0.5 * q);
    }

    #[test]
    fn means_that_never_differ_by_one_step_of_their_grid_still_give_the_count() {
        // A board's means of 347 readings of a 12-bit tacho (counts of 0.293 rad/s, noise
        // of 0.1 rad/s) over a step response and its plateau: consecutive means differ by
        // several of the grid's steps (a count over 347), seldom by one.
        let (q, m, noise) = (0.29296875f32, 347u32, 0.1f32);
        let mut rng = crate::rng::seeded(11);
        let means: Vec<f32> = (0..400)
            .map(|k| {
                let x = 40.0 * (1.0 - libm::expf(-(k as f32) / 60.0));
                let mut sum = 0.0f32;
                for _ in 0..m {
                    sum += libm::roundf((x + noise * crate::rng::normal(&mut rng)) / q) * q;
                }
                sum / m as f32
            })
            .collect();
        let sigma = libm::sqrtf(noise * noise + q * q / 12.0) / libm::sqrtf(m as f32);
        let r = Rounding::of_means(&means, sigma, m);
        assert!((r.count / q - 1.0).abs() < 0.01, "{r:?}");
        // Steps of two and three grid steps only: the grid is one.
        let grid = 0.01f32;
        let stepped: Vec<f32> = (0..50)
            .map(|k| 5.0 + grid * (2 * k + k / 3) as f32)
            .collect();
        let r = Rounding::of(&stepped, 0.001);
        assert!((r.count / grid - 1.0).abs() < 1e-3, "{r:?}");
    }

    #[test]
    fn a_held_readings_rounding_error_matches_its_monte_carlo_spread() {
        // Counts of 0.25: held signals at 200 points across a count, each read 2,000 times
        // with noise of 0, 0.2 and 0.5 count and rounded; the spread over the points of the
        // mean reading's error against `Rounding::of` on one record of such readings.
        let q = 0.25f32;
        for (noise, want_count_share) in [(0.0f32, 0.289), (0.2, 0.10), (0.5, 0.0)] {
            let mut rng = crate::rng::seeded(3);
            let mut errors = Vec::new();
            let mut record = Vec::new();
            for p in 0..200 {
                let x = 10.0 + q * p as f32 / 200.0;
                let mut sum = 0.0f64;
                for read in 0..2000 {
                    let y = libm::roundf((x + noise * q * crate::rng::normal(&mut rng)) / q) * q;
                    sum += y as f64;
                    if read < 100 {
                        record.push(y);
                    }
                }
                errors.push(sum / 2000.0 - x as f64);
            }
            let spread = rms(errors.iter().copied());
            // The record's noise as the fit measures it: rounding included.
            let sigma = libm::sqrtf((noise * q) * (noise * q) + q * q / 12.0);
            let r = Rounding::of(&record, sigma);
            assert!((r.count - q).abs() < 1e-6, "count {}", r.count);
            // The Monte Carlo mean of 2,000 readings carries their noise too.
            let predicted = (r.error as f64).hypot(sigma as f64 / libm::sqrt(2000.0));
            assert!(
                (predicted - spread).abs() < 0.1 * predicted + 0.002 * q as f64,
                "noise {noise}: {} ({predicted} with the mean's noise) against {spread}",
                r.error
            );
            assert!(
                (spread / q as f64 - want_count_share).abs() < 0.02,
                "{spread}"
            );
        }
        // Readings not on a grid (a ramp with white noise of 0.5): nothing.
        let mut rng = crate::rng::seeded(1);
        let x: Vec<f32> = (0..2000)
            .map(|k| 0.05 * k as f32 + 0.5 * crate::rng::normal(&mut rng))
            .collect();
        assert!(Rounding::of(&x, 0.5).error < 1e-6);
    }
}
