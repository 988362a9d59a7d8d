//! Equation-error starts for the search, computed without a single simulation.
//!
//! With current: paper Eq. 1 and Eq. 4 integrated over time are linear in the parameters,
//!
//! `int v = Ra int i + La (i - i0) + Kv int w` and
//! `Kv int i - int tl = J (w - w0) + B int w`,
//!
//! so least squares over all samples gives Ra, La, Kv and then J, B.
//!
//! Speed only: paper Eq. 6 as a differential equation, `w'' + c2 w' + c3 w = c1 v` with
//! `c1 = Kv/(La J)`, `c2 = Ra/La + B/J`, `c3 = (Ra B + Kv^2)/(La J)`, integrated twice is
//! linear in `c1, c2, c3` and two constants of integration per record. Only these three
//! combinations are pinned (see [`crate::fit::identifiability`]), so the start is the point of the
//! equal-fit set `{c1, c2, c3} = const` that best respects the bounds and fixed values.
//!
//! Integrating (rather than differentiating) keeps the noise of the readings from being
//! amplified. The estimates are biased by noise on the regressors and by unmodelled effects,
//! so they only seed the search; the output-error fit decides.

use crate::capacity::MAX_FREE;
use crate::fit::linalg::{Mat, Vector};
use crate::fit::space::ProblemSpec;
use crate::model::params::ModelParams;
use crate::model::record::Record;
use crate::model::sim::sign;
use crate::param_id::ParamId;

/// A small least-squares problem (at most [`MAX_FREE`] unknowns) solved by a QR
/// factorisation updated one row at a time with square-root-free Givens rotations
/// (Gentleman 1973; Miller, AS 274, 1992): fixed memory, and the condition number is not
/// squared as in the normal equations (the integrated regressors of a mostly steady record
/// are nearly collinear). `R = D^(1/2) U` is kept as the row weights `d` and the unit upper
/// triangle `u`, so a row costs one division per column and no square root (f64 runs in
/// software on the board: a `hypot` per rotation made this start cost more than the fit).
struct LeastSquares {
    n: usize,
    d: Vector,
    u: Mat,
    /// `U beta = theta` at the solution.
    theta: Vector,
}

impl LeastSquares {
    fn new(n: usize) -> Self {
        LeastSquares {
            n,
            d: [0.0; MAX_FREE],
            u: [[0.0; MAX_FREE]; MAX_FREE],
            theta: [0.0; MAX_FREE],
        }
    }

    /// Rotate row `row` (observation `y`, weight 1) into the factorisation.
    fn add(&mut self, row: &[f64], y: f64) {
        let mut x = [0.0f64; MAX_FREE];
        x[..self.n].copy_from_slice(&row[..self.n]);
        let (mut w, mut y) = (1.0f64, y);
        for i in 0..self.n {
            let xi = x[i];
            if xi == 0.0 {
                continue;
            }
            let di = self.d[i];
            let wxi = w * xi;
            let dpi = di + wxi * xi;
            let inv = 1.0 / dpi;
            let (cbar, sbar) = (di * inv, wxi * inv);
            w *= cbar;
            self.d[i] = dpi;
            for k in i + 1..self.n {
                let (uk, xk) = (self.u[i][k], x[k]);
                x[k] = xk - xi * uk;
                self.u[i][k] = cbar * uk + sbar * xk;
            }
            let t = self.theta[i];
            self.theta[i] = cbar * t + sbar * y;
            y -= xi * t;
            if w == 0.0 {
                return;
            }
        }
    }

    fn solve(&self) -> Option<Vector> {
        let n = self.n;
        let largest = (0..n).map(|i| self.d[i]).fold(0.0f64, f64::max);
        let mut out = [0.0f64; MAX_FREE];
        for i in (0..n).rev() {
            // |R_ii| = sqrt(d_i) against 1e-12 of the largest.
            let d = self.d[i];
            if d.is_nan() || d <= 1e-24 * largest {
                return None;
            }
            let mut acc = self.theta[i];
            for k in i + 1..n {
                acc -= self.u[i][k] * out[k];
            }
            out[i] = acc;
        }
        out[..n].iter().all(|v| v.is_finite()).then_some(out)
    }
}

/// Rows a record contributes at most to a regression. The integrals run over every sample,
/// but rows a few samples apart carry almost the same information (they are running
/// integrals): every `stride`-th row is enough for a start, and each row costs a few dozen
/// f64 operations, in software on the board.
const ROWS_PER_RECORD: usize = 512;

/// Every how many samples a record of `len` samples adds a row.
fn row_stride(len: usize) -> usize {
    len.div_ceil(ROWS_PER_RECORD).max(1)
}

/// Motor parameters by equation error, or `None` without current in every record or when
/// the regression is degenerate or gives a non-positive parameter. Paper Eq. 1 holds only
/// while the bridge drives the armature, so a coast-down adds no electrical row; paper Eq. 4
/// holds throughout (with `i = 0` in the coast-down, where it shows friction alone). With
/// `with_friction`, the mechanical regression has a Coulomb term `tc int sign(w)` as well.
pub fn equation_error(records: &[Record], with_friction: bool) -> Option<ModelParams> {
    let mut electrical = LeastSquares::new(3);
    for r in records {
        let c = r.current?;
        let dt = r.dt as f64;
        let (mut iv, mut ii, mut iw) = (0.0f64, 0.0f64, 0.0f64);
        let stride = row_stride(r.len());
        for k in 1..r.driven_len() {
            iv += r.v[k - 1] as f64 * dt;
            ii += 0.5 * (c[k - 1] + c[k]) as f64 * dt;
            iw += 0.5 * (r.omega[k - 1] + r.omega[k]) as f64 * dt;
            if k % stride == 0 {
                electrical.add(&[ii, (c[k] - c[0]) as f64, iw], iv);
            }
        }
    }
    let x = electrical.solve()?;
    let (ra, la, kv) = (x[0], x[1], x[2]);
    let mut mechanical = LeastSquares::new(if with_friction { 3 } else { 2 });
    for r in records {
        let c = r.current?;
        let dt = r.dt as f64;
        let (mut ii, mut iw, mut it, mut is) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let stride = row_stride(r.len());
        let driven = r.driven_len();
        for k in 1..r.len() {
            // No current flows over a step of the coast-down (the reading at its first
            // sample is the current when the bridge opened): only steps before it count.
            if k < driven {
                ii += 0.5 * (c[k - 1] + c[k]) as f64 * dt;
            }
            iw += 0.5 * (r.omega[k - 1] + r.omega[k]) as f64 * dt;
            it += r.load_at(k - 1) as f64 * dt;
            // Only when it is regressed (f64 runs in software on the board).
            if with_friction {
                is += 0.5 * (sign(r.omega[k - 1]) + sign(r.omega[k])) as f64 * dt;
            }
            if k % stride == 0 {
                let row = [(r.omega[k] - r.omega[0]) as f64, iw, is];
                mechanical.add(&row, kv * ii - it);
            }
        }
    }
    let x = mechanical.solve()?;
    let (j, b) = (x[0], x[1]);
    let p = ModelParams::motor(ra as f32, la as f32, j as f32, b.max(0.0) as f32, kv as f32);
    let p = if with_friction {
        p.with(ParamId::Tc, x[2].max(0.0) as f32)
    } else {
        p
    };
    let positive = [ra, la, j, kv].iter().all(|x| *x > 0.0);
    (positive && p.validate().is_ok()).then_some(p)
}

/// Records used by the speed-only regression (two unknowns each).
const MAX_SPEED_RECORDS: usize = 4;

/// The transfer-function coefficients `(c1, c2, c3)` of paper Eq. 6 by equation error.
pub fn speed_coefficients(records: &[Record]) -> Option<(f64, f64, f64)> {
    let with_load = records.iter().any(|r| r.load.is_some());
    // Unknowns: c1, c2, c3, [1/J, Ra/(La J)], then (w0, w0' + c2 w0) per record.
    let base = if with_load { 5 } else { 3 };
    let fit = ((MAX_FREE - base) / 2).min(MAX_SPEED_RECORDS);
    let used = &records[..records.len().min(fit)];
    let with_load = used.iter().any(|r| r.load.is_some());
    let base = if with_load { 5 } else { 3 };
    let n = base + 2 * used.len();
    let mut ls = LeastSquares::new(n);
    for (idx, r) in used.iter().enumerate() {
        let dt = r.dt as f64;
        // Running integrals: of w, of int w, of v, of int v, of tl, of int tl.
        let (mut iw, mut iiw, mut iv, mut iiv, mut it, mut iit) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        let stride = row_stride(r.len());
        // Paper Eq. 6 holds only while the bridge drives the armature.
        for k in 1..r.driven_len() {
            let w_mid = 0.5 * (r.omega[k - 1] + r.omega[k]) as f64;
            iiw += (iw + 0.5 * w_mid * dt) * dt;
            iw += w_mid * dt;
            let v = r.v[k - 1] as f64;
            iiv += (iv + 0.5 * v * dt) * dt;
            iv += v * dt;
            let tl = r.load_at(k - 1) as f64;
            iit += (it + 0.5 * tl * dt) * dt;
            it += tl * dt;
            if k % stride != 0 {
                continue;
            }
            let mut row = [0.0f64; MAX_FREE];
            row[0] = iiv;
            row[1] = -iw;
            row[2] = -iiw;
            if with_load {
                row[3] = -it;
                row[4] = -iit;
            }
            row[base + 2 * idx] = 1.0;
            row[base + 2 * idx + 1] = k as f64 * dt;
            ls.add(&row[..n], r.omega[k] as f64);
        }
    }
    let x = ls.solve()?;
    let (c1, c2, c3) = (x[0], x[1], x[2]);
    (c1 > 0.0 && c2 > 0.0 && c3 > 0.0).then_some((c1, c2, c3))
}

/// The point of the equal-fit set of `(c1, c2, c3)` that best respects the bounds and fixed
/// values of `spec`: a grid over Kv and La (or their fixed values), both assignments of the
/// roots of `z^2 - c2 z + (c3 - Kv c1)` to `Ra/La` and `B/J`, scored by how far (in log
/// scale) the parameters fall outside their bounds or from their fixed values, ties broken
/// by distance from the centre of the box.
pub fn equal_fit_point(c: (f64, f64, f64), spec: &ProblemSpec) -> Option<ModelParams> {
    const GRID: usize = 9;
    let (c1, c2, c3) = c;
    let range = |id: ParamId| -> (f64, f64) {
        if spec.free[id.index()] {
            let (lo, hi) = spec.bounds[id.index()];
            (lo as f64, hi as f64)
        } else {
            let v = spec.base.get(id) as f64;
            (v, v)
        }
    };
    // Kv: the roots are real for Kv >= (c3 - c2^2/4)/c1, positive for Kv < c3/c1.
    let (kv_lo, kv_hi) = range(ParamId::Kv);
    let kv_min = kv_lo.max((c3 - 0.25 * c2 * c2) / c1).max(1e-12);
    let kv_max = kv_hi.min(c3 / c1 * (1.0 - 1e-6));
    if kv_min > kv_max {
        return None;
    }
    let (la_lo, la_hi) = range(ParamId::La);
    let geo = |lo: f64, hi: f64, k: usize| {
        if GRID == 1 || lo == hi {
            lo
        } else {
            // (hi / lo)^f as exp(f ln(hi / lo)): libm's `pow` took 2.6 KB of the board's
            // flash for this line alone (docs/measurements/footprint.md).
            lo * libm::exp(libm::log(hi / lo) * (k as f64 / (GRID - 1) as f64))
        }
    };
    let mut best: Option<(f64, f64, ModelParams)> = None;
    for a in 0..GRID {
        let kv = geo(kv_min, kv_max, a);
        let prod = c3 - kv * c1;
        let disc = (c2 * c2 - 4.0 * prod).max(0.0);
        let roots = [0.5 * (c2 + libm::sqrt(disc)), 0.5 * (c2 - libm::sqrt(disc))];
        for (x, y) in [(roots[0], roots[1]), (roots[1], roots[0])] {
            if x <= 0.0 || y < 0.0 {
                continue;
            }
            for l in 0..GRID {
                let la = geo(la_lo, la_hi, l);
                let ra = x * la;
                let j = kv / (c1 * la);
                let b = y * j;
                let p = ModelParams::motor(ra as f32, la as f32, j as f32, b as f32, kv as f32);
                let mut outside = 0.0;
                let mut centre = 0.0;
                for id in ParamId::MOTOR {
                    let (lo, hi) = range(id);
                    let v = p.get(id) as f64;
                    if v <= 0.0 {
                        continue;
                    }
                    if v < lo {
                        outside += libm::log(lo / v);
                    } else if v > hi {
                        outside += libm::log(v / hi);
                    }
                    if lo > 0.0 && hi > lo {
                        let mid = libm::sqrt(lo * hi);
                        centre += libm::fabs(libm::log(v / mid));
                    }
                }
                let better = match &best {
                    None => true,
                    Some((o, c, _)) => outside < *o - 1e-9 || (outside <= *o + 1e-9 && centre < *c),
                };
                if better && p.validate().is_ok() {
                    best = Some((outside, centre, p));
                }
            }
        }
    }
    best.map(|(_, _, p)| p)
}

/// The start for `records`: equation error with current when every record has it, else the
/// speed-only equal-fit point.
#[inline(never)]
pub fn start(records: &[Record], spec: &ProblemSpec) -> Option<ModelParams> {
    equation_error(records, spec.free[ParamId::Tc.index()])
        .or_else(|| equal_fit_point(speed_coefficients(records)?, spec))
}

#[cfg(test)]
#[path = "initial_tests.rs"]
mod tests;
