//! Streaming sums of a fit over one record and over all records: the squared residuals,
//! `J^T J` (a packed triangle) and `J^T r`, in f32 blocks flushed into f64, with the variable
//! projection of a record's initial speed and the early abandonment of a hopeless
//! candidate. Fixed memory `O(dim^2)` whatever the record length.

use crate::capacity::MAX_FREE;
use crate::fit::linalg::{Mat, Vector};
use crate::model::noise::noise_sigma;
use crate::model::record::Record;
use crate::model::sim::Reading;

/// Samples summed in f32 before the partial sum is added to the f64 total.
pub(crate) const BLOCK: usize = 64;
/// Samples between checks whether a candidate can be abandoned ([`Partial`]; a multiple of
/// [`BLOCK`]: the check costs a few f64 operations, in software on the board).
pub(crate) const CHECK_EVERY: usize = 4 * BLOCK;

/// Step of the initial speed used to measure the response to it [rad/s] (exact for the
/// linear model, whose response is linear in the initial state).
pub(crate) const SHIFT: f32 = 1.0;

/// Streaming sums over one record, for variable projection of its initial speed.
///
/// The initial speed of a record that does not start at rest is a nuisance parameter: taking
/// the first reading makes its noise persist for a mechanical time constant (a 3-sigma first
/// sample raised the fit RMSE by 28 % on a paper-motor record). With `h` the response of the (weighted) readings to
/// the initial speed, measured with a second simulation started [`SHIFT`] higher, the
/// least-squares shift is `hr / hh`, and the projected sums are
/// `sse - hr^2/hh`, `J^T J - (J^T h)(h^T J)/hh`, `J^T r - (J^T h) hr/hh`: all of them
/// running sums, so no record-length buffer is needed.
///
/// Every sum is an [`Accumulator`]; all of them take one term per sample, so they share one
/// sample count and flush their f32 blocks together (only the sums in use: the leading
/// `dim` Jacobian entries, the current sums when current is fitted).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct RecordSums {
    dim: usize,
    with_current: bool,
    /// The record's initial speed is projected out (the `h` sums are in use).
    with_shift: bool,
    /// Samples in the current blocks.
    count: usize,
    omega_sq: Accumulator,
    current_sq: Accumulator,
    h_omega_r: Accumulator,
    h_omega_sq: Accumulator,
    h_current_r: Accumulator,
    h_current_sq: Accumulator,
    /// Lower triangle of `J^T J`, packed by rows (entry `(a, b)`, `b <= a`, at
    /// [`triangle_index`]; the upper one is its mirror).
    jtj: Triangle,
    jtr: [Accumulator; MAX_FREE],
    jth: [Accumulator; MAX_FREE],
}

/// Entries of the packed lower triangle of a `MAX_FREE` square matrix.
pub(crate) const TRIANGLE: usize = MAX_FREE * (MAX_FREE + 1) / 2;

/// A packed lower triangle of sums (half the stack of the square matrix).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Triangle([Accumulator; TRIANGLE]);

impl Default for Triangle {
    fn default() -> Self {
        Triangle([Accumulator::default(); TRIANGLE])
    }
}

/// Position of entry `(a, b)`, `b <= a`, in a lower triangle packed by rows (`(dim, 0)`
/// gives the number of entries of a `dim` square matrix).
pub(crate) const fn triangle_index(a: usize, b: usize) -> usize {
    a * (a + 1) / 2 + b
}

/// The weighted SSE of the records before this one and the limit at which a cost
/// evaluation is abandoned ([`Objective::fitness_below`]). Every term added to the sums of a
/// record that starts at rest is a square, and f32 and f64 sums of non-negative terms
/// never decrease, so once the partial SSE reaches the limit the full one does too.
pub(crate) struct Partial {
    /// The SSE at which the candidate is abandoned.
    pub(crate) limit: f64,
    /// Speed SSE of the records before this one.
    pub(crate) omega_sq: f64,
    /// Current SSE of the records before this one.
    pub(crate) current_sq: f64,
    /// Square of the current weight.
    pub(crate) w2: f64,
}

impl Partial {
    /// No limit.
    pub(crate) const UNBOUNDED: Partial = Partial {
        limit: f64::INFINITY,
        omega_sq: 0.0,
        current_sq: 0.0,
        w2: 0.0,
    };

    /// True when the SSE so far, with `sums` of the record being simulated, reaches the limit.
    pub(crate) fn reached(&self, sums: &RecordSums) -> bool {
        let omega_sq = self.omega_sq + sums.omega_sq.total();
        let current_sq = self.current_sq + sums.current_sq.total();
        omega_sq + self.w2 * current_sq >= self.limit
    }
}

impl RecordSums {
    pub(crate) fn new(dim: usize, with_current: bool, with_shift: bool) -> Self {
        RecordSums {
            dim,
            with_current,
            with_shift,
            ..RecordSums::default()
        }
    }

    /// Add the squared residuals of sample `k` for reading `y`; returns the speed residual
    /// and the weighted current residual (0 without current).
    pub(crate) fn add_residuals(&mut self, r: &Record, k: usize, y: Reading, w: f32) -> (f32, f32) {
        let rw = r.omega[k] - y.omega;
        self.omega_sq.add(rw * rw);
        let ri = match r.current {
            Some(c) if self.with_current => {
                let ri = c[k] - y.current;
                self.current_sq.add(ri * ri);
                w * ri
            }
            _ => 0.0,
        };
        (rw, ri)
    }

    /// Add the Jacobian terms of one sample: columns of the speed and (weighted) current
    /// residuals, and those residuals.
    pub(crate) fn add_jacobian(&mut self, rw: f32, ri: f32, col_w: &[f32], col_i: &[f32]) {
        for a in 0..col_w.len() {
            let (wa, ia) = (col_w[a], col_i[a]);
            // Row `a` of the triangle, zipped with the columns: no index checks in the
            // innermost loop of every refinement.
            let start = triangle_index(a, 0);
            let row = &mut self.jtj.0[start..=start + a];
            for ((entry, wb), ib) in row.iter_mut().zip(&col_w[..=a]).zip(&col_i[..=a]) {
                entry.add(wa * wb + ia * ib);
            }
            self.jtr[a].add(wa * rw + ia * ri);
        }
    }

    /// Add the response `h` of sample `k` to the initial speed (nominal reading `y`, shifted
    /// reading `ys`) and its products with the residuals and the Jacobian columns.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_shift_response(
        &mut self,
        r: &Record,
        k: usize,
        y: Reading,
        ys: Reading,
        w: f32,
        col_w: &[f32],
        col_i: &[f32],
    ) {
        let rw = r.omega[k] - y.omega;
        let hw = (ys.omega - y.omega) / SHIFT;
        self.h_omega_r.add(hw * rw);
        self.h_omega_sq.add(hw * hw);
        let hi = match r.current {
            Some(c) if self.with_current => {
                let ri = c[k] - y.current;
                let hi = (ys.current - y.current) / SHIFT;
                self.h_current_r.add(hi * ri);
                self.h_current_sq.add(hi * hi);
                w * hi
            }
            _ => 0.0,
        };
        for a in 0..col_w.len() {
            // The residual's response to the initial speed is -h.
            self.jth[a].add(-(col_w[a] * hw + col_i[a] * hi));
        }
    }

    /// Close one sample; every [`BLOCK`] samples the blocks in use are flushed into their
    /// f64 totals, and `true` is returned.
    #[inline(always)]
    pub(crate) fn end_sample(&mut self) -> bool {
        self.count += 1;
        if self.count < BLOCK {
            return false;
        }
        self.flush();
        true
    }

    #[inline(never)]
    pub(crate) fn flush(&mut self) {
        self.count = 0;
        let dim = self.dim;
        self.omega_sq.flush();
        if self.with_current {
            self.current_sq.flush();
        }
        if self.with_shift {
            self.h_omega_r.flush();
            self.h_omega_sq.flush();
            if self.with_current {
                self.h_current_r.flush();
                self.h_current_sq.flush();
            }
        }
        for entry in &mut self.jtj.0[..triangle_index(dim, 0)] {
            entry.flush();
        }
        for a in 0..dim {
            self.jtr[a].flush();
            if self.with_shift {
                self.jth[a].flush();
            }
        }
    }

    /// Add the record's sums, with its initial speed projected out, to `totals` and, given
    /// `jacobian` (`dim` and the `J^T J`, `J^T r` sums of all records so far), its Jacobian
    /// sums to those; returns the least-squares correction of the initial speed [rad/s].
    /// (In place: no record-sized copy of the matrix on the stack.)
    pub(crate) fn finish_into(
        &self,
        w: f32,
        totals: &mut Totals,
        jacobian: Option<(usize, &mut Mat, &mut Vector)>,
    ) -> f32 {
        let w2 = (w as f64) * (w as f64);
        let hh = self.h_omega_sq.total() + w2 * self.h_current_sq.total();
        let hr = self.h_omega_r.total() + w2 * self.h_current_r.total();
        let mut omega_sq = self.omega_sq.total();
        let mut current_sq = self.current_sq.total();
        // No projection when the readings do not respond to the initial speed.
        let shift = if hh > 1e-12 && hh.is_finite() {
            hr / hh
        } else {
            0.0
        };
        if shift != 0.0 {
            omega_sq +=
                shift * shift * self.h_omega_sq.total() - 2.0 * shift * self.h_omega_r.total();
            current_sq +=
                shift * shift * self.h_current_sq.total() - 2.0 * shift * self.h_current_r.total();
        }
        totals.omega_sq += omega_sq.max(0.0);
        totals.current_sq += current_sq.max(0.0);
        let Some((dim, jtj, jtr)) = jacobian else {
            return shift as f32;
        };
        for a in 0..dim {
            let ja = self.jth[a].total();
            for b in 0..dim {
                let mut x = self.jtj.0[triangle_index(a.max(b), a.min(b))].total();
                if shift != 0.0 {
                    // Residual r' = r - shift h'; J' = J - (J^T h'/hh) h'^T with h' the
                    // residual response -h, whence the signs.
                    x -= ja * self.jth[b].total() / hh;
                }
                jtj[a][b] += x;
            }
            let mut x = self.jtr[a].total();
            if shift != 0.0 {
                x += ja * hr / hh;
            }
            jtr[a] += x;
        }
        shift as f32
    }
}

/// Sums of squared residuals over all records (the Jacobian's sums are the caller's: see
/// [`RecordSums::finish_into`]).
#[derive(Clone, Debug, Default)]
pub(crate) struct Totals {
    pub(crate) omega_sq: f64,
    pub(crate) current_sq: f64,
}

/// Pooled noise of several signals, floored at the quantisation noise `q / sqrt(12)` of the
/// smallest step `q` between readings (an ADC- or encoder-quantised signal that is mostly
/// flat has zero local-quadratic residuals) and at 1e-4 of the RMS (noise-free simulations would
/// otherwise give a zero weight or a division by zero).
pub fn pooled_sigma<'s>(signals: impl Iterator<Item = &'s [f32]>) -> f32 {
    let mut var = 0.0f64;
    let mut ms = 0.0f64;
    let mut count = 0usize;
    let mut quantum = f32::INFINITY;
    for s in signals {
        let sig = noise_sigma(s) as f64;
        var += sig * sig * s.len() as f64;
        ms += s.iter().map(|x| (*x as f64) * (*x as f64)).sum::<f64>();
        count += s.len();
        for w in s.windows(2) {
            let d = (w[1] - w[0]).abs();
            if d > 0.0 && d < quantum {
                quantum = d;
            }
        }
    }
    if count == 0 {
        return 1.0;
    }
    let sigma = libm::sqrt(var / count as f64);
    let quantisation = if quantum.is_finite() {
        quantum as f64 / libm::sqrt(12.0)
    } else {
        0.0
    };
    let floor = (1e-4 * libm::sqrt(ms / count as f64) + 1e-12).max(quantisation);
    sigma.max(floor) as f32
}

/// f32 partial sums over blocks of [`BLOCK`] samples, added into an f64 total: f32 speed in
/// the per-sample loop, f64 accuracy over long records. The block count is kept by the owner
/// ([`RecordSums`]), which flushes all its sums at once.
///
/// Packed to 4-byte alignment: 12 bytes instead of 16, for the many of them a Jacobian needs
/// on a board's stack (the M4 loads an f64 from any word).
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, packed(4))]
pub(crate) struct Accumulator {
    block: f32,
    total: f64,
}

impl Accumulator {
    pub(crate) fn add(&mut self, x: f32) {
        self.block += x;
    }
    pub(crate) fn flush(&mut self) {
        self.total += self.block as f64;
        self.block = 0.0;
    }
    pub(crate) fn total(&self) -> f64 {
        self.total + self.block as f64
    }
}
