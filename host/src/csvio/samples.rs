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

    /// The record of these samples, from `path`, its first sample at `t0` [s] and
    /// stepping `dt` [s], coasting from `coast_from`, each reading the mean of `averaged`.
    pub fn into_record(
        self,
        path: std::path::PathBuf,
        (t0, dt): (f64, f32),
        coast_from: Option<usize>,
        averaged: u32,
    ) -> super::OwnedRecord {
        super::OwnedRecord {
            path,
            t0,
            dt,
            v: self.v,
            omega: self.omega,
            current: self.current,
            load: self.load,
            coast_from,
            averaged,
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

/// The first time and the step of a record decimated by `k` whose rows start at `first`
/// and step `step`: a sample stands for the middle of its block of rows.
pub fn decimated_time(first: f64, step: f64, k: usize) -> (f64, f32) {
    (
        first + (k - 1) as f64 / 2.0 * step,
        (step * k as f64) as f32,
    )
}

impl super::OwnedRecord {
    /// This record with one sample per `k` of its own, decimated as `--decimate k` reads
    /// a file (the module's doc): the readings the mean of each block, the inputs the mean
    /// over the new step. `None` when fewer than `MIN_SAMPLES` samples would be left, a
    /// coast-down would not survive the decimation, or the readings are means over each
    /// step already (their means would be taken for readings at instants).
    pub fn decimated(&self, k: usize) -> Option<super::OwnedRecord> {
        if self.averaged > 1 {
            return None;
        }
        let mut samples = Samples::new(k, self.current.is_some(), self.load.is_some());
        for n in 0..self.omega.len() {
            samples.push(&Row {
                line: 0,
                t: 0.0,
                v: self.v[n],
                omega: self.omega[n],
                current: self.current.as_ref().map_or(0.0, |c| c[n]),
                load: self.load.as_ref().map_or(0.0, |l| l[n]),
                driven: self.coast_from.is_none_or(|c| n < c),
                averaged: 1,
            });
        }
        samples.finish();
        if samples.len() < motor_id_shared::model::record::MIN_SAMPLES {
            return None;
        }
        let coast_from = self
            .coast_from
            .map(|row| samples.coast_from(row))
            .transpose()
            .ok()?;
        let (t0, dt) = decimated_time(self.t0, self.dt as f64, k);
        Some(samples.into_record(self.path.clone(), (t0, dt), coast_from, self.averaged))
    }
}
