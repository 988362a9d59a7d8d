//! The samples a record keeps of its rows, built one row at a time: every row, or with
//! `--decimate K` one sample per `K` rows.
//!
//! **Decimation.** Sample `m` of the decimated record stands for rows `mK .. mK + K - 1`.
//! Its readings (`omega`, `i`) are their mean: an anti-alias (boxcar) filter whose output
//! belongs to the middle of the block, `(K - 1) / 2` rows after its first, so the decimated
//! record starts that much later and steps `K dt`. Its inputs (`v`, `tl`) are the mean of
//! the held input over its new step, from that middle to the next block's: the same
//! voltage-seconds the rows apply then (a row on the step's edge, for even `K`, counts
//! half). Under the zero-order hold of the record (sample `k`: the readings at `t_k`, the
//! inputs held from `t_k` to `t_k+1`) both are then in their place: averaging the inputs
//! over the block itself, or taking the block's first reading, would shift one against the
//! other by half a block. Rows after the last whole block are dropped; the last sample's
//! input, which runs past the rows, holds the last input. In a coast-down the voltage is
//! not applied: its rows count with the last driven voltage, and the bridge opens at the
//! first sample whose step lies mostly after the opening.

use super::rows::Row;
use anyhow::{bail, Result};
use std::collections::VecDeque;

/// The samples kept, as the record's columns.
pub struct Samples {
    /// Rows per sample.
    k: usize,
    /// Voltage [V].
    pub v: Vec<f32>,
    /// Speed [rad/s].
    pub omega: Vec<f32>,
    /// Current [A], if the record has it.
    pub current: Option<Vec<f32>>,
    /// Load torque [N m], if the record has it.
    pub load: Option<Vec<f32>>,
    /// Rows taken into the current block.
    in_block: usize,
    /// Sums of the current block's readings: speed, current.
    readings: [f64; 2],
    /// The inputs (voltage, load torque) of the last `K + 1` rows.
    inputs: VecDeque<[f32; 2]>,
    /// Rows whose input has been taken (past the end of the file too, when finishing).
    inputs_taken: usize,
    /// The last input taken, with the last voltage applied (held through a coast-down).
    held: [f32; 2],
}

impl Samples {
    /// No samples yet; one per `k` rows (at least 1), with columns for current and load
    /// torque as asked.
    pub fn new(k: usize, current: bool, load: bool) -> Samples {
        Samples {
            k,
            v: Vec::new(),
            omega: Vec::new(),
            current: current.then(Vec::new),
            load: load.then(Vec::new),
            in_block: 0,
            readings: [0.0; 2],
            inputs: VecDeque::with_capacity(if k > 1 { k + 1 } else { 0 }),
            inputs_taken: 0,
            held: [0.0; 2],
        }
    }

    /// Samples kept so far.
    pub fn len(&self) -> usize {
        self.omega.len()
    }

    /// Columns kept (f32 each): voltage and speed, current and load torque when present.
    pub fn columns(&self) -> usize {
        2 + usize::from(self.current.is_some()) + usize::from(self.load.is_some())
    }

    /// Samples kept of `rows` rows.
    pub fn kept_of(&self, rows: u64) -> u64 {
        rows / self.k as u64
    }

    /// Take the next row.
    #[inline]
    pub fn push(&mut self, row: &Row) {
        if self.k == 1 {
            self.v.push(row.v);
            self.omega.push(row.omega);
            if let Some(c) = &mut self.current {
                c.push(row.current);
            }
            if let Some(l) = &mut self.load {
                l.push(row.load);
            }
            return;
        }
        self.readings[0] += row.omega as f64;
        self.readings[1] += row.current as f64;
        self.in_block += 1;
        if self.in_block == self.k {
            self.in_block = 0;
            let [w, i] = self.readings.map(|s| (s / self.k as f64) as f32);
            self.omega.push(w);
            if let Some(c) = &mut self.current {
                c.push(i);
            }
            self.readings = [0.0; 2];
        }
        if row.driven {
            self.held[0] = row.v;
        }
        self.held[1] = row.load;
        self.take_input(self.held);
    }

    /// Give every sample its input (the last one's step runs past the rows: it holds the
    /// last input) and let go of the spare capacity.
    pub fn finish(&mut self) {
        while self.v.len() < self.omega.len() {
            self.take_input(self.held);
        }
        for column in [
            Some(&mut self.v),
            Some(&mut self.omega),
            self.current.as_mut(),
            self.load.as_mut(),
        ]
        .into_iter()
        .flatten()
        {
            column.shrink_to_fit();
        }
    }

    /// Take the input of the next row, and close the step of the next sample when it ends
    /// on this row.
    fn take_input(&mut self, input: [f32; 2]) {
        let k = self.k;
        if self.inputs.len() == k + 1 {
            self.inputs.pop_front();
        }
        self.inputs.push_back(input);
        self.inputs_taken += 1;
        // The step of sample m ends on row mK + K - 1 + ceil((K - 1) / 2): the middle of
        // block m + 1, or half-way into the row after it for even K.
        let ends = self.v.len() * k + k - 1 + (k - 1).div_ceil(2);
        if self.inputs_taken == ends + 1 {
            let n = self.inputs.len();
            let mut sum = [0.0f64; 2];
            let mut add = |x: [f32; 2], weight: f64| {
                sum[0] += weight * x[0] as f64;
                sum[1] += weight * x[1] as f64;
            };
            if k % 2 == 1 {
                self.inputs.range(n - k..).for_each(|&x| add(x, 1.0));
            } else {
                add(self.inputs[n - k - 1], 0.5);
                self.inputs.range(n - k..n - 1).for_each(|&x| add(x, 1.0));
                add(self.inputs[n - 1], 0.5);
            }
            let [v, tl] = sum.map(|s| (s / k as f64) as f32);
            self.v.push(v);
            if let Some(l) = &mut self.load {
                l.push(tl);
            }
        }
    }

    /// The first sample of a coast-down whose first open row is `row`: with decimation,
    /// the first sample whose step lies mostly after that row's start.
    pub fn coast_from(&self, row: usize) -> Result<usize> {
        let k = self.k;
        if k == 1 {
            return Ok(row);
        }
        // Step m spans rows mK + (K - 1) / 2 .. + K; its middle, mK + K - 1/2, at or after
        // the opening: m >= (row - K + 1/2) / K, in half rows (2 row - 2K + 1) / 2K.
        let first = (2 * row + 1).saturating_sub(2 * k).div_ceil(2 * k);
        if first == 0 {
            bail!("the coast-down starts within the first {k} rows: with --decimate {k} the record would start with the bridge open; decimate less");
        }
        if first >= self.len() {
            bail!("the coast-down is shorter than half a sample of --decimate {k}; decimate less");
        }
        Ok(first)
    }
}
