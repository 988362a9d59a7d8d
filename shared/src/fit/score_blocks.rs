//! Batch-means estimate of the covariance of the fit's score `J^T r`, for standard
//! deviations that stay honest when the residuals are not white.
//!
//! The Fisher information `J^T J / sigma^2` of [`crate::fit::identifiability`] assumes
//! independent residuals. Residuals that are correlated over many samples make it
//! optimistic: a tacho or current reading quantised with less noise than one count errs by
//! the same amount for as long as the signal stays within that count (on the commissioning
//! benchmark, fits 34 of their own standard deviations from the truth had a speed RMSE at the
//! noise floor), and so does a residual misfit that persists over a record. The score's
//! covariance `J^T Sigma J` then exceeds `sigma^2 J^T J`, and the estimate's covariance is the
//! sandwich `(J^T J)^-1 (J^T Sigma J) (J^T J)^-1` (White 1982; the batch means of the score
//! over consecutive blocks estimate the middle term, as in the cluster-robust covariance of
//! least squares).
//!
//! Each record is cut into [`BLOCKS_PER_RECORD`] blocks of consecutive samples; the score of
//! each block is summed, and the sum of the outer products of the block scores, centred on
//! their mean within the record (a record's mean score is what its initial speed and a fit
//! stopped short of the optimum leave), estimates `J^T Sigma J` for correlations shorter than
//! a block. Fixed memory: one triangle of sums whatever the record length.

use crate::capacity::MAX_FREE;
use crate::fit::sums::{triangle_index, TRIANGLE};
use crate::model::rounding::Rounding;

/// Blocks per record: enough that the estimate is not dominated by a few blocks (its
/// relative standard deviation is about `sqrt(2 / blocks)`, a quarter of a variance for the
/// board's two records), few enough that a block spans the records' slow correlations. On
/// the commissioning benchmark's first 200 motors, the pinned estimates within 3 reported
/// deviations: 92.0 % with 32 blocks, 94.7 % with 16, 95.6 % with 12 (with 8, two records
/// have too few blocks for the estimate: 86.4 %, the white-noise deviations'). Not 12: one
/// record fitted for five parameters would then have too few blocks (12, not more than
/// twice the 6 lost), and the host's commonest fit would fall back to white noise.
pub const BLOCKS_PER_RECORD: usize = 16;

/// Streaming sums of the block scores of a fit's records.
///
/// A record whose initial speed is projected out ([`crate::fit::sums::RecordSums`]) has the
/// residual `r - c h`, with `h` the readings' response to the initial speed and `c` the
/// least-squares shift, known only at the record's end. So each block's score is kept as two
/// parts, `Gr = sum J r` and `Gh = sum J h`, and the outer products of the record's blocks as
/// three sums (`Gr Gr^T`, straight into the total, and `Gr Gh^T + Gh Gr^T`, `Gh Gh^T`),
/// combined with `c` when the record ends. (The Jacobian's own projection along `h` is left out: it changes no block's score
/// where `h` has died away, and the record's centring removes its mean.) f32 sums: the
/// board's stack holds this beside the normal equations.
#[derive(Clone, Copy, Debug)]
pub struct ScoreBlocks {
    dim: usize,
    /// Samples per block of the record being summed.
    block_len: usize,
    /// Samples in the current block.
    in_block: usize,
    /// `Gr` and `Gh` of the current block.
    block: [[f32; MAX_FREE]; 2],
    /// Sums of `Gr` and `Gh` over the record's blocks.
    record_sum: [[f32; MAX_FREE]; 2],
    /// Blocks of the record being summed.
    record_blocks: u32,
    /// The record's `Gr Gh^T + Gh Gr^T` and `Gh Gh^T` (lower triangles).
    record_outer: [[f32; TRIANGLE]; 2],
    /// Lower triangle of the sum of outer products over the records summed (centred and
    /// shifted as each record ends; the current record's `Gr Gr^T` as it goes).
    outer: [f32; TRIANGLE],
    /// Blocks over all records summed.
    blocks: u32,
    /// The readings are an ADC's ([`ScoreBlocks::set_adc_readings`]).
    adc: bool,
    /// The rounding of the record being summed, speed and current, the current's error
    /// weighted as its residuals are ([`ScoreBlocks::start_record`]).
    rounding: [Rounding; 2],
    /// The count each channel's modelled reading lies in now.
    cells: [i32; 2],
    /// Sums of the Jacobian's speed and current columns since each channel's reading
    /// entered its count.
    columns: [[f32; MAX_FREE]; 2],
    /// Lower triangle of the score's covariance from the records' rounding errors.
    rounded: [f32; TRIANGLE],
    /// Records summed.
    records: u32,
}

impl ScoreBlocks {
    /// No sums, no coordinates (a constant: built in place, not on the stack and copied).
    pub const EMPTY: ScoreBlocks = ScoreBlocks {
        dim: 0,
        block_len: 1,
        in_block: 0,
        block: [[0.0; MAX_FREE]; 2],
        record_sum: [[0.0; MAX_FREE]; 2],
        record_blocks: 0,
        record_outer: [[0.0; TRIANGLE]; 2],
        outer: [0.0; TRIANGLE],
        blocks: 0,
        records: 0,
        adc: false,
        rounding: [Rounding {
            count: 0.0,
            error: 0.0,
        }; 2],
        cells: [0; 2],
        columns: [[0.0; MAX_FREE]; 2],
        rounded: [0.0; TRIANGLE],
    };

    /// Sum `dim` free coordinates.
    pub fn set_dim(&mut self, dim: usize) {
        self.dim = dim;
    }

    /// The readings are an ADC's: count each record's steady rounding error
    /// ([`ScoreBlocks::start_record`]).
    pub fn set_adc_readings(&mut self, on: bool) {
        self.adc = on;
    }

    /// Whether the readings are an ADC's.
    pub fn adc_readings(&self) -> bool {
        self.adc
    }

    /// Begin a record of `samples` samples whose readings an ADC rounds as `rounding` says
    /// (speed, and current with its error times the current's weight; defaults for
    /// readings not an ADC's).
    pub fn start_record(&mut self, samples: usize, rounding: [Rounding; 2]) {
        self.rounding = rounding;
        self.cells = [i32::MIN; 2];
        self.columns = [[0.0; MAX_FREE]; 2];
        self.block_len = samples.div_ceil(BLOCKS_PER_RECORD).max(1);
        self.in_block = 0;
        self.block = [[0.0; MAX_FREE]; 2];
        self.record_sum = [[0.0; MAX_FREE]; 2];
        self.record_blocks = 0;
        self.record_outer = [[0.0; TRIANGLE]; 2];
    }

    /// Add one sample: the Jacobian rows `col_w`, `col_i` of its (weighted) speed and current
    /// residuals `r = (rw, ri)` and the responses `h = (hw, hi)` of those residuals' readings
    /// to the record's initial speed (zeros for a record that starts at rest).
    ///
    /// `y` holds the modelled speed and current readings: while one stays within a count,
    /// its rounding error is one constant ([`Rounding`]), whose effect on the score is
    /// summed over that stretch and counted when the reading leaves the count.
    pub fn add(
        &mut self,
        col_w: &[f32],
        col_i: &[f32],
        r: (f32, f32),
        h: (f32, f32),
        y: (f32, f32),
    ) {
        for d in 0..self.dim {
            self.block[0][d] += col_w[d] * r.0 + col_i[d] * r.1;
            self.block[1][d] += col_w[d] * h.0 + col_i[d] * h.1;
        }
        if self.adc {
            self.follow_count(0, y.0, col_w);
            self.follow_count(1, y.1, col_i);
        }
        self.in_block += 1;
        if self.in_block == self.block_len {
            self.close_block();
        }
    }

    /// Channel `c`'s modelled reading `y` with its Jacobian column `col`: a stretch ends
    /// when the reading leaves its count. (Out of line: a board's flash.)
    #[inline(never)]
    fn follow_count(&mut self, c: usize, y: f32, col: &[f32]) {
        let cell = self.rounding[c].cell(y);
        if cell != self.cells[c] {
            self.close_stretch(c);
            self.cells[c] = cell;
        }
        for d in 0..self.dim {
            self.columns[c][d] += col[d];
        }
    }

    /// Count the stretch of channel `c` (0 speed, 1 current) whose reading stayed within
    /// one count: a constant error `e` on its readings moves the score by `e` times its
    /// columns' sum; with `e` of the rounding's spread, a covariance that the blocks see
    /// only in part (a stretch within a block, or its mean over the record, they do not).
    fn close_stretch(&mut self, c: usize) {
        let e = self.rounding[c].error;
        let g = self.columns[c];
        for a in 0..self.dim {
            for b in 0..=a {
                self.rounded[triangle_index(a, b)] += e * e * g[a] * g[b];
            }
        }
        self.columns[c] = [0.0; MAX_FREE];
    }

    fn close_block(&mut self) {
        let [gr, gh] = self.block;
        for a in 0..self.dim {
            self.record_sum[0][a] += gr[a];
            self.record_sum[1][a] += gh[a];
            for b in 0..=a {
                let t = triangle_index(a, b);
                self.outer[t] += gr[a] * gr[b];
                self.record_outer[0][t] += gr[a] * gh[b] + gh[a] * gr[b];
                self.record_outer[1][t] += gh[a] * gh[b];
            }
        }
        self.record_blocks += 1;
        self.block = [[0.0; MAX_FREE]; 2];
        self.in_block = 0;
    }

    /// End the record whose least-squares initial-speed shift is `shift` (0 for a record
    /// that starts at rest): its block scores `Gr - shift Gh`, centred on their mean.
    pub fn end_record(&mut self, shift: f32) {
        if self.in_block > 0 {
            self.close_block();
        }
        if self.record_blocks == 0 {
            return;
        }
        let n = self.record_blocks as f32;
        let [rh, hh] = &self.record_outer;
        let [sr, sh] = &self.record_sum;
        for a in 0..self.dim {
            let mean_a = sr[a] - shift * sh[a];
            for b in 0..=a {
                let t = triangle_index(a, b);
                let mean_b = sr[b] - shift * sh[b];
                self.outer[t] += shift * shift * hh[t] - shift * rh[t] - mean_a * mean_b / n;
            }
        }
        self.close_stretch(0);
        self.close_stretch(1);
        self.blocks += self.record_blocks;
        self.records += 1;
        self.record_blocks = 0;
    }

    /// The covariance of the score at `(a, b)` (unit coordinates) from the records' steady
    /// rounding errors, one constant error per record and channel.
    pub fn rounding_covariance(&self, a: usize, b: usize) -> f64 {
        self.rounded[triangle_index(a.max(b), a.min(b))] as f64
    }

    /// The estimate of `J^T Sigma J` at `(a, b)` (unit coordinates), with the small-sample
    /// factor `blocks / (blocks - records - dim)` for the records' means and the fitted
    /// coordinates that the centred block scores of fitted residuals have lost (the
    /// cluster-robust covariance's `G / (G - 1)` alone left the slope of a fitted line at
    /// 0.80 of its white-noise variance over 16 blocks; with this factor, 0.92);
    /// `None` with fewer than twice as many blocks as are lost.
    pub fn covariance(&self, a: usize, b: usize) -> Option<f64> {
        let lost = self.records as usize + self.dim;
        let blocks = self.blocks as usize;
        if blocks <= 2 * lost {
            return None;
        }
        let factor = blocks as f64 / (blocks - lost) as f64;
        Some(factor * self.outer[triangle_index(a.max(b), a.min(b))] as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// No sums yet, for `dim` free coordinates.
    fn blocks(dim: usize) -> ScoreBlocks {
        let mut s = ScoreBlocks::EMPTY;
        s.set_dim(dim);
        s
    }
    use crate::rng::{normal, seeded};

    /// The slope's variance of the least-squares line through `y` over `t = k / n`, by the
    /// sandwich with the block scores, over the white-noise one with unit noise
    /// (`[(J^T J)^-1]_11`).
    fn slope_variance_ratio(y: &[f32]) -> f64 {
        let n = y.len();
        let t = |k: usize| k as f64 / n as f64;
        let (s1, st, stt) = (0..n).fold((0.0, 0.0, 0.0), |(a, b, c), k| {
            (a + 1.0, b + t(k), c + t(k) * t(k))
        });
        let (sy, sty) = (0..n).fold((0.0, 0.0), |(a, b), k| {
            (a + y[k] as f64, b + t(k) * y[k] as f64)
        });
        let det = s1 * stt - st * st;
        let slope = (s1 * sty - st * sy) / det;
        let intercept = (sy - slope * st) / s1;
        let mut s = blocks(2);
        s.start_record(n, [Rounding::default(); 2]);
        for (k, &yk) in y.iter().enumerate() {
            let r = (yk as f64 - intercept - slope * t(k)) as f32;
            s.add(
                &[1.0, t(k) as f32],
                &[0.0, 0.0],
                (r, 0.0),
                (0.0, 0.0),
                (0.0, 0.0),
            );
        }
        s.end_record(0.0);
        // (J^T J)^-1 = [[stt, -st], [-st, s1]] / det; the slope's row is [-st, s1] / det.
        let row = [-st / det, s1 / det];
        let m = |a: usize, b: usize| s.covariance(a, b).expect("enough blocks");
        let sandwich: f64 = (0..2)
            .map(|a| (0..2).map(|b| row[a] * m(a, b) * row[b]).sum::<f64>())
            .sum();
        sandwich / (s1 / det)
    }

    #[test]
    fn white_residuals_give_the_white_variance_and_correlated_ones_more() {
        let n = 6400;
        let line = |k: usize| 3.0 - 2.0 * k as f32 / n as f32;
        // Averaged over seeds (the estimate of one record has about a third's spread): 0.92.
        let seeds = 60;
        let mut ratio = 0.0;
        for seed in 0..seeds {
            let mut rng = seeded(100 + seed);
            let y: Vec<f32> = (0..n).map(|k| line(k) + normal(&mut rng)).collect();
            ratio += slope_variance_ratio(&y);
        }
        ratio /= seeds as f64;
        assert!((ratio - 1.0).abs() < 0.15, "white: {ratio}");
        // A first-order autoregression with coefficient 0.9 has a long-run variance
        // (1 + 0.9) / (1 - 0.9) = 19 times its samples' (unit here).
        let mut rng = seeded(7);
        let mut x = 0.0f32;
        let y: Vec<f32> = (0..n)
            .map(|k| {
                x = 0.9 * x + libm::sqrtf(1.0 - 0.81) * normal(&mut rng);
                line(k) + x
            })
            .collect();
        let ratio = slope_variance_ratio(&y);
        assert!(ratio > 8.0 && ratio < 30.0, "correlated: {ratio}");
    }

    #[test]
    fn a_record_whose_initial_speed_is_projected_counts_its_projected_residual() {
        // Residual r = e + c h with h a decaying response: after the shift c the block
        // scores are those of e alone, as if the record had been fitted from its true start.
        let n = 3200;
        let mut rng = seeded(5);
        let e: Vec<f32> = (0..n).map(|_| normal(&mut rng)).collect();
        let h: Vec<f32> = (0..n).map(|k| libm::expf(-(k as f32) / 400.0)).collect();
        let c = 7.0f32;
        let col = |k: usize| [1.0f32, k as f32 / n as f32];
        let mut plain = blocks(2);
        let mut shifted = blocks(2);
        plain.start_record(n, [Rounding::default(); 2]);
        shifted.start_record(n, [Rounding::default(); 2]);
        for k in 0..n {
            plain.add(&col(k), &[0.0; 2], (e[k], 0.0), (0.0, 0.0), (0.0, 0.0));
            shifted.add(
                &col(k),
                &[0.0; 2],
                (e[k] + c * h[k], 0.0),
                (h[k], 0.0),
                (0.0, 0.0),
            );
        }
        plain.end_record(0.0);
        shifted.end_record(c);
        for (a, b) in [(0, 0), (1, 0), (1, 1)] {
            let (x, y) = (
                plain.covariance(a, b).unwrap(),
                shifted.covariance(a, b).unwrap(),
            );
            assert!(
                (x - y).abs() <= 1e-3 * x.abs().max(1.0),
                "({a}, {b}): {x} vs {y}"
            );
        }
    }

    #[test]
    fn a_reading_held_within_a_count_errs_once_for_the_stretch() {
        // One coordinate, its speed column 1 at every sample, a count of 1 with an error of
        // 0.3: 100 samples whose modelled reading stays in one count give (0.3 x 100)^2;
        // readings that change count at every sample give 100 x 0.3^2; readings not an
        // ADC's give nothing.
        let rounding = [
            Rounding {
                count: 1.0,
                error: 0.3,
            },
            Rounding::default(),
        ];
        let run = |adc: bool, y: &dyn Fn(usize) -> f32| {
            let mut s = blocks(1);
            s.set_adc_readings(adc);
            s.start_record(100, rounding);
            for k in 0..100 {
                s.add(&[1.0], &[0.0], (0.0, 0.0), (0.0, 0.0), (y(k), 0.0));
            }
            s.end_record(0.0);
            s.rounding_covariance(0, 0)
        };
        let held = run(true, &|_| 5.2);
        assert!((held - 900.0).abs() < 1e-2, "{held}");
        let moving = run(true, &|k| k as f32);
        assert!((moving - 9.0).abs() < 1e-4, "{moving}");
        // Two stretches of 50: 2 x (0.3 x 50)^2.
        let two = run(true, &|k| if k < 50 { 5.2 } else { 6.1 });
        assert!((two - 450.0).abs() < 1e-2, "{two}");
        assert_eq!(run(false, &|_| 5.2), 0.0);
    }

    #[test]
    fn too_few_blocks_give_no_estimate() {
        let mut s = blocks(5);
        s.start_record(4, [Rounding::default(); 2]);
        for _ in 0..4 {
            s.add(&[1.0; 5], &[0.0; 5], (1.0, 0.0), (0.0, 0.0), (0.0, 0.0));
        }
        s.end_record(0.0);
        assert!(s.covariance(0, 0).is_none());
    }
}
