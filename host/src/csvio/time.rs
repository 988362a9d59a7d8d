//! The uniform-step check of a time column, without holding the column: a running summary
//! decides it, and only a column that fails is scanned again, step by step, for the line
//! of its first bad step.

use anyhow::{bail, Result};

/// Largest relative deviation of one time step from the mean step.
const STEP_TOLERANCE: f64 = 0.01;

/// What the check needs of a time column, gathered one time at a time: the first and last
/// time, the shortest and longest step.
#[derive(Clone, Copy, Debug, Default)]
pub struct TimeSteps {
    n: usize,
    first: f64,
    last: f64,
    shortest: f64,
    longest: f64,
}

impl TimeSteps {
    /// Take the next time.
    #[inline]
    pub fn push(&mut self, t: f64) {
        if self.n == 0 {
            self.first = t;
            (self.shortest, self.longest) = (f64::INFINITY, f64::NEG_INFINITY);
        } else {
            let step = t - self.last;
            self.shortest = self.shortest.min(step);
            self.longest = self.longest.max(step);
        }
        self.last = t;
        self.n += 1;
    }

    /// The first time.
    pub fn first(&self) -> f64 {
        self.first
    }

    /// The last time.
    pub fn last(&self) -> f64 {
        self.last
    }

    /// The mean step `(t_last - t_first) / (n - 1)`.
    pub fn mean_step(&self) -> f64 {
        (self.last - self.first) / (self.n - 1) as f64
    }

    /// Every step is positive and within [`STEP_TOLERANCE`] of the mean: the deviation of a
    /// step from the mean is largest at the shortest or the longest step, so these two
    /// decide it exactly as a check of every step would.
    fn uniform(&self) -> bool {
        let dt = self.mean_step();
        self.shortest > 0.0 && within(self.shortest, dt) && within(self.longest, dt)
    }

    /// The mean step as f32, when every step is positive and uniform; otherwise the error
    /// at the first step that is not, found by `rescan`, which feeds the times again, with
    /// their lines, to the [`StepScan`] it is given. At least two times.
    pub fn step(&self, rescan: impl FnOnce(&mut StepScan) -> Result<()>) -> Result<f32> {
        let dt = self.mean_step();
        if !self.uniform() {
            rescan(&mut StepScan { dt, last: None })?;
            bail!("the time column changed while it was read");
        }
        let dt32 = dt as f32;
        if !(dt32.is_finite() && dt32 > 0.0) {
            bail!("time step {dt} s is not representable");
        }
        Ok(dt32)
    }
}

/// `step` lies within [`STEP_TOLERANCE`] of the mean step `dt`.
fn within(step: f64, dt: f64) -> bool {
    (step - dt).abs() <= STEP_TOLERANCE * dt
}

/// The check of every step against a known mean step, in file order: it fails at the first
/// step that is not positive or not within [`STEP_TOLERANCE`] of the mean, naming its line.
pub struct StepScan {
    dt: f64,
    last: Option<f64>,
}

impl StepScan {
    /// Take the next time `t`, read at file line `line`.
    pub fn push(&mut self, t: f64, line: u64) -> Result<()> {
        if let Some(last) = self.last.replace(t) {
            let step = t - last;
            if step <= 0.0 {
                bail!("time is not increasing at line {line} (t = {t} after {last})");
            }
            if !within(step, self.dt) {
                bail!(
                    "time step is not uniform at line {line}: {step} s where the mean step is {} s",
                    self.dt
                );
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mean step of the strictly increasing, uniformly spaced times `t` (`lines[k]`: the
    /// file line of `t[k]`, for messages); at least two times.
    fn uniform_step(t: &[f64], lines: &[u64]) -> Result<f32> {
        let mut summary = TimeSteps::default();
        t.iter().for_each(|&x| summary.push(x));
        summary.step(|scan| t.iter().zip(lines).try_for_each(|(&x, &l)| scan.push(x, l)))
    }

    #[test]
    fn jittered_time_within_one_percent_is_uniform() {
        let t: Vec<f64> = (0..100)
            .map(|k| k as f64 * 0.001 + if k % 2 == 1 { 4e-6 } else { 0.0 })
            .collect();
        let lines: Vec<u64> = (2..102).collect();
        assert!(uniform_step(&t, &lines).is_ok());
        let mut bad = t.clone();
        bad[50] += 0.0005;
        let err = uniform_step(&bad, &lines).unwrap_err().to_string();
        assert!(err.contains("line 52"), "{err}");
    }

    /// The summary's verdict is the step-by-step check's: the first bad step is named,
    /// however far the worst one lies from it.
    #[test]
    fn the_first_bad_step_is_named_not_the_worst() {
        let lines: Vec<u64> = (2..202).collect();
        let mut t: Vec<f64> = (0..200).map(|k| k as f64 * 0.01).collect();
        t[20] += 0.0003; // 3 % early and late: the first bad step, line 22
        t[150] += 0.004; // 40 %: the worst
        let err = uniform_step(&t, &lines).unwrap_err().to_string();
        assert!(err.contains("not uniform at line 22"), "{err}");
        t[20] -= 0.0003;
        t[150] = t[149]; // a repeated time before the worst step
        let err = uniform_step(&t, &lines).unwrap_err().to_string();
        assert!(err.contains("not increasing at line 152"), "{err}");
        // On the edge of the tolerance both ways: the same verdict as every step's.
        for edge in [0.99, 1.01, 0.989, 1.011] {
            let mut u: Vec<f64> = (0..200).map(|k| k as f64 * 0.01).collect();
            u[100] = u[99] + 0.01 * edge;
            let each = u.windows(2).all(|w| {
                let dt = (u[199] - u[0]) / 199.0;
                w[1] > w[0] && within(w[1] - w[0], dt)
            });
            assert_eq!(uniform_step(&u, &lines).is_ok(), each, "{edge}");
        }
    }
}
