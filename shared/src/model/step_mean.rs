//! The mean of a drive's readings over one record step: a record whose sample `k` is the
//! mean of the `m` readings the drive took at `(k - 1) dt + j dt / m`, `j = 1..=m` (the
//! step that ends at sample `k`), not the reading at `k dt` alone. Averaging lowers the
//! noise by √m; modelled as such, it adds no bias (the mean of an instant's model against
//! averaged readings is off by the signal's curvature over the window, which biased
//! earlier fits, `docs/measurements/commissioning.md`).
//!
//! With the inputs held over the step (zero-order hold) the state at `j δ` (`δ = dt / m`)
//! is `x0 + D_j x0 + F_j Bu u`, where `D_j = e^{A j δ} - I` and `F_j = ∫_0^{jδ} e^{As} ds`
//! (paper Eq. 5, [`crate::model::discretise`]). The mean over `j = 1..=m` is therefore
//! `x0 + P x0 + Q u` with `P = (1/m) Σ D_j` and `Q = (1/m) Σ F_j Bu`, exact for any `m`.
//! The sums are built by doubling, in f64, from one drive step's `D_1` and `F_1`:
//! `D_{a+b} = D_a + D_b + D_a D_b`, `F_{a+b} = F_a + F_b + D_a F_b`, and for the sums
//! `S_n = Σ_{j≤n} D_j`, `T_n = Σ_{j≤n} F_j`: `S_{a+b} = S_a + S_b + b D_a + D_a S_b`,
//! `T_{a+b} = T_a + T_b + b F_a + D_a T_b` (all functions of one `A`, so they commute).
//! The first-order steps (rotor held, paper Eq. 1; no armature current, paper Eq. 4) have
//! their own means the same way.

use crate::model::discretise::{
    exp_minus_identity_and_integral, first_order, mat_mul, mat_scaled, Motor, M2,
};
use crate::model::params::ModelParams;

/// Coefficients of the mean of the state over one step of `m` drive samples.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepMean {
    /// `P`: the mean of `[i, w]` is `x0 + P x0 + qv v + qt tl`.
    pub p: [[f32; 2]; 2],
    /// Mean response of `[i, w]` to one volt held over the step.
    pub qv: [f32; 2],
    /// Mean response of `[i, w]` to one newton-metre of load held over the step.
    pub qt: [f32; 2],
    /// Rotor held: the mean current is `i0 + pe i0 + qe v`.
    pub pe: f32,
    /// See [`StepMean::pe`].
    pub qe: f32,
    /// No armature current: the mean speed is `w0 + pm w0 + qm tl`.
    pub pm: f32,
    /// See [`StepMean::pm`].
    pub qm: f32,
}

/// What the doubling needs of the functions of one `A` it combines (they commute): 2x2
/// matrices for the motor, scalars for a first-order step (a matrix product of two
/// diagonal ones gives each entry's product plus `0 * 0`, the same bits: a scalar's
/// doubling is a quarter of the soft-float operations).
trait Commuting: Copy {
    const ZERO: Self;
    fn plus(&self, y: &Self) -> Self;
    fn times(&self, y: &Self) -> Self;
    fn scaled(&self, k: f64) -> Self;
}

impl Commuting for M2 {
    const ZERO: M2 = [[0.0; 2]; 2];
    fn plus(&self, y: &M2) -> M2 {
        [
            [self[0][0] + y[0][0], self[0][1] + y[0][1]],
            [self[1][0] + y[1][0], self[1][1] + y[1][1]],
        ]
    }
    fn times(&self, y: &M2) -> M2 {
        mat_mul(self, y)
    }
    fn scaled(&self, k: f64) -> M2 {
        mat_scaled(self, k)
    }
}

impl Commuting for f64 {
    const ZERO: f64 = 0.0;
    fn plus(&self, y: &f64) -> f64 {
        self + y
    }
    fn times(&self, y: &f64) -> f64 {
        self * y
    }
    fn scaled(&self, k: f64) -> f64 {
        self * k
    }
}

/// `n` drive steps of one linear system: `D_n`, `F_n` and their sums over `j = 1..=n`.
#[derive(Clone, Copy)]
struct Steps<T> {
    n: f64,
    d: T,
    f: T,
    s: T,
    t: T,
}

impl<T: Commuting> Steps<T> {
    const NONE: Steps<T> = Steps {
        n: 0.0,
        d: T::ZERO,
        f: T::ZERO,
        s: T::ZERO,
        t: T::ZERO,
    };

    /// One step of `D_1 = d`, `F_1 = f`.
    fn one(d: T, f: T) -> Steps<T> {
        Steps {
            n: 1.0,
            d,
            f,
            s: d,
            t: f,
        }
    }

    /// `self` steps, then `other` steps.
    fn then(&self, other: &Steps<T>) -> Steps<T> {
        let (a, b) = (self, other);
        Steps {
            n: a.n + b.n,
            d: a.d.plus(&b.d).plus(&a.d.times(&b.d)),
            f: a.f.plus(&b.f).plus(&a.d.times(&b.f)),
            s: a.s.plus(&b.s).plus(&a.d.scaled(b.n).plus(&a.d.times(&b.s))),
            t: a.t.plus(&b.t).plus(&a.f.scaled(b.n).plus(&a.d.times(&b.t))),
        }
    }

    /// `m` steps of `one` (a single step), by doubling; `(S_m / m, T_m / m)`.
    fn means(one: Steps<T>, m: u32) -> (T, T) {
        let (mut all, mut power, mut bits) = (Steps::NONE, one, m);
        while bits > 0 {
            if bits & 1 == 1 {
                all = all.then(&power);
            }
            power = power.then(&power);
            bits >>= 1;
        }
        let k = 1.0 / f64::from(m.max(1));
        (all.s.scaled(k), all.t.scaled(k))
    }
}

/// The means over `m` steps `t` of the first-order system `x' = a x + u` (exact ZOH).
fn first_order_means(a: f64, t: f64, m: u32) -> (f64, f64) {
    let (d, f) = first_order(a, 1.0, t);
    Steps::means(Steps::one(d, f), m)
}

impl StepMean {
    /// The mean over a step `dt` of `m` drive samples of the motor of `p` (whose parameters
    /// [`crate::model::discretise::Discrete::new`] accepted).
    #[inline(never)]
    pub fn new(p: &ModelParams, dt: f32, m: u32) -> StepMean {
        let Motor { ra, la, j, b, a } = Motor::of(p);
        let delta = dt as f64 / f64::from(m.max(1));
        let (d, f) = exp_minus_identity_and_integral(&a, delta);
        let (s, t) = Steps::means(Steps::one(d, f), m);
        // The rotor held (current alone) and no current (speed alone).
        let (se, te) = first_order_means(-ra / la, delta, m);
        let (sm, tm) = first_order_means(-b / j, delta, m);
        let f32s = |x: f64| x as f32;
        StepMean {
            p: [
                [f32s(s[0][0]), f32s(s[0][1])],
                [f32s(s[1][0]), f32s(s[1][1])],
            ],
            // Bu = [[1/La, 0], [0, -1/J]].
            qv: [f32s(t[0][0] / la), f32s(t[1][0] / la)],
            qt: [f32s(-t[0][1] / j), f32s(-t[1][1] / j)],
            pe: f32s(se),
            qe: f32s(te / la),
            pm: f32s(sm),
            qm: f32s(-tm / j),
        }
    }

    /// Mean `[i, w]` over the step from `(i0, w0)` with `volts` and `load` held.
    #[inline(always)]
    pub fn linear(&self, i0: f32, w0: f32, volts: f32, load: f32) -> (f32, f32) {
        let di = self.p[0][0] * i0 + self.p[0][1] * w0 + self.qv[0] * volts + self.qt[0] * load;
        let dw = self.p[1][0] * i0 + self.p[1][1] * w0 + self.qv[1] * volts + self.qt[1] * load;
        (i0 + di, w0 + dw)
    }

    /// The start `(i0, w0)` of a step whose mean `[i, w]` with `volts` and `load` held is
    /// `mean`: `(I + P)^-1 (mean - qv v - qt tl)` (the inverse of [`StepMean::linear`]).
    /// `None` where `I + P` is singular (a mean that no start gives, as an undamped
    /// oscillation's over a whole period).
    pub fn start_of(&self, mean: (f32, f32), volts: f32, load: f32) -> Option<(f32, f32)> {
        let a = [
            [1.0 + self.p[0][0], self.p[0][1]],
            [self.p[1][0], 1.0 + self.p[1][1]],
        ];
        let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
        let yi = mean.0 - self.qv[0] * volts - self.qt[0] * load;
        let yw = mean.1 - self.qv[1] * volts - self.qt[1] * load;
        let i0 = (a[1][1] * yi - a[0][1] * yw) / det;
        let w0 = (a[0][0] * yw - a[1][0] * yi) / det;
        (i0.is_finite() && w0.is_finite()).then_some((i0, w0))
    }

    /// Mean current over the step with the rotor held.
    pub fn held_rotor(&self, i0: f32, volts: f32) -> f32 {
        i0 + self.pe * i0 + self.qe * volts
    }

    /// Mean speed over the step with no armature current.
    pub fn mechanical(&self, w0: f32, load: f32) -> f32 {
        w0 + self.pm * w0 + self.qm * load
    }
}

#[cfg(test)]
#[path = "step_mean_tests.rs"]
mod tests;
