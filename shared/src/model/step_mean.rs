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

use crate::model::discretise::{exp_minus_identity_and_integral, first_order, mat_mul, Motor, M2};
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

/// `n` drive steps of one linear system: `D_n`, `F_n` and their sums over `j = 1..=n`.
#[derive(Clone, Copy)]
struct Steps {
    n: f64,
    d: M2,
    f: M2,
    s: M2,
    t: M2,
}

fn add(x: &M2, y: &M2) -> M2 {
    [
        [x[0][0] + y[0][0], x[0][1] + y[0][1]],
        [x[1][0] + y[1][0], x[1][1] + y[1][1]],
    ]
}

fn scaled(x: &M2, k: f64) -> M2 {
    [[x[0][0] * k, x[0][1] * k], [x[1][0] * k, x[1][1] * k]]
}

impl Steps {
    const NONE: Steps = Steps {
        n: 0.0,
        d: [[0.0; 2]; 2],
        f: [[0.0; 2]; 2],
        s: [[0.0; 2]; 2],
        t: [[0.0; 2]; 2],
    };

    /// `self` steps, then `other` steps.
    fn then(&self, other: &Steps) -> Steps {
        let (a, b) = (self, other);
        Steps {
            n: a.n + b.n,
            d: add(&add(&a.d, &b.d), &mat_mul(&a.d, &b.d)),
            f: add(&add(&a.f, &b.f), &mat_mul(&a.d, &b.f)),
            s: add(
                &add(&a.s, &b.s),
                &add(&scaled(&a.d, b.n), &mat_mul(&a.d, &b.s)),
            ),
            t: add(
                &add(&a.t, &b.t),
                &add(&scaled(&a.f, b.n), &mat_mul(&a.d, &b.t)),
            ),
        }
    }

    /// `m` steps of `one` (a single step), by doubling; `(S_m / m, T_m / m)`.
    fn means(one: Steps, m: u32) -> (M2, M2) {
        let (mut all, mut power, mut bits) = (Steps::NONE, one, m);
        while bits > 0 {
            if bits & 1 == 1 {
                all = all.then(&power);
            }
            power = power.then(&power);
            bits >>= 1;
        }
        let k = 1.0 / f64::from(m.max(1));
        (scaled(&all.s, k), scaled(&all.t, k))
    }
}

/// One step of a diagonal system `x' = diag(a0, a1) x`, as [`Steps`].
fn diagonal_step(a0: f64, a1: f64, t: f64) -> Steps {
    let (d0, f0) = first_order(a0, 1.0, t);
    let (d1, f1) = first_order(a1, 1.0, t);
    let (d, f) = ([[d0, 0.0], [0.0, d1]], [[f0, 0.0], [0.0, f1]]);
    Steps {
        n: 1.0,
        d,
        f,
        s: d,
        t: f,
    }
}

impl StepMean {
    /// The mean over a step `dt` of `m` drive samples of the motor of `p` (whose parameters
    /// [`crate::model::discretise::Discrete::new`] accepted).
    #[inline(never)]
    pub fn new(p: &ModelParams, dt: f32, m: u32) -> StepMean {
        let Motor { ra, la, j, b, a } = Motor::of(p);
        let delta = dt as f64 / f64::from(m.max(1));
        let (d, f) = exp_minus_identity_and_integral(&a, delta);
        let one = Steps {
            n: 1.0,
            d,
            f,
            s: d,
            t: f,
        };
        let (s, t) = Steps::means(one, m);
        // The rotor held (current alone) and no current (speed alone), side by side.
        let (s1, t1) = Steps::means(diagonal_step(-ra / la, -b / j, delta), m);
        let f32s = |x: f64| x as f32;
        StepMean {
            p: [
                [f32s(s[0][0]), f32s(s[0][1])],
                [f32s(s[1][0]), f32s(s[1][1])],
            ],
            // Bu = [[1/La, 0], [0, -1/J]].
            qv: [f32s(t[0][0] / la), f32s(t[1][0] / la)],
            qt: [f32s(-t[0][1] / j), f32s(-t[1][1] / j)],
            pe: f32s(s1[0][0]),
            qe: f32s(t1[0][0] / la),
            pm: f32s(s1[1][1]),
            qm: f32s(-t1[1][1] / j),
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
mod tests {
    use super::*;
    use crate::model::discretise::Discrete;
    use crate::param_id::ParamId;

    /// The mean of `m` readings by stepping the exact discretisation at `dt / m` `m`
    /// times (f32, as a plant would): the reference the closed form must meet.
    fn stepped(p: &ModelParams, dt: f32, m: u32, x0: (f32, f32), v: f32, tl: f32) -> (f64, f64) {
        let d = Discrete::new(p, dt / m as f32).unwrap();
        let (mut i, mut w) = (x0.0 as f64, x0.1 as f64);
        let (mut si, mut sw) = (0.0, 0.0);
        for _ in 0..m {
            let (di, dw) = d.increments(i as f32, w as f32, v, tl);
            i += di as f64;
            w += dw as f64;
            si += i;
            sw += w;
        }
        (si / m as f64, sw / m as f64)
    }

    /// A record of averaged readings (`m` drive samples a step) with inputs `v` and readings
    /// `zeros` (the tests compare simulations, not fits).
    fn averaged_inputs<'a>(
        dt: f32,
        m: u32,
        v: &'a [f32],
        zeros: &'a [f32],
        coast_from: Option<usize>,
    ) -> crate::model::record::Record<'a> {
        crate::model::record::Record {
            dt,
            v,
            omega: zeros,
            current: Some(zeros),
            load: None,
            coast_from,
            averaged: m,
        }
    }

    /// The mean `(current, speed)` of `drive`'s readings after each of its next `m` steps,
    /// the `j`-th with `input(j)`: what a drive averages into one record sample.
    fn drive_mean(
        drive: &mut crate::model::sim::Simulator,
        m: u32,
        input: impl Fn(u32) -> crate::model::sim::StepInput,
    ) -> (f64, f64) {
        let (mut si, mut sw) = (0.0f64, 0.0f64);
        for j in 0..m {
            drive.apply(&input(j));
            let y = drive.reading();
            si += y.current as f64;
            sw += y.omega as f64;
        }
        (si / m as f64, sw / m as f64)
    }

    #[test]
    fn the_mean_over_a_step_is_the_mean_of_its_drive_samples() {
        // Fast and slow electrical modes against the step, under- and over-damped motors.
        let paper = ModelParams::PAPER_MOTOR;
        let light = paper.with(ParamId::J, 2e-6).with(ParamId::B, 0.0);
        for (p, dt) in [(paper, 1e-3), (paper, 0.02), (light, 5e-4), (light, 0.01)] {
            for m in [1u32, 2, 3, 16, 37, 250] {
                let mean = StepMean::new(&p, dt, m);
                for (x0, v, tl) in [((0.0, 0.0), 12.0, 0.0), ((1.5, 80.0), -3.0, 0.02)] {
                    let (i, w) = mean.linear(x0.0, x0.1, v, tl);
                    let (ri, rw) = stepped(&p, dt, m, x0, v, tl);
                    let scale_i = ri.abs().max(0.05);
                    let scale_w = rw.abs().max(1.0);
                    assert!(
                        ((i as f64 - ri) / scale_i).abs() < 2e-4,
                        "{dt} {m}: {i} {ri}"
                    );
                    assert!(
                        ((w as f64 - rw) / scale_w).abs() < 2e-4,
                        "{dt} {m}: {w} {rw}"
                    );
                }
            }
        }
    }

    #[test]
    fn one_drive_sample_per_step_is_the_step_s_end() {
        let p = ModelParams::PAPER_MOTOR;
        let (mean, d) = (StepMean::new(&p, 2e-3, 1), Discrete::new(&p, 2e-3).unwrap());
        let (di, dw) = d.increments(0.4, 30.0, 9.0, 0.01);
        let (i, w) = mean.linear(0.4, 30.0, 9.0, 0.01);
        assert!((i - (0.4 + di)).abs() < 1e-5 && (w - (30.0 + dw)).abs() < 1e-4);
        // The first-order means: held rotor (the current's exponential) and no current.
        let tau_e = p.get(ParamId::La) / p.get(ParamId::Ra);
        let end = 9.0 / p.get(ParamId::Ra) * (1.0 - (-2e-3f32 / tau_e).exp());
        assert!((mean.held_rotor(0.0, 9.0) - end).abs() < 1e-5);
        let (b, j) = (p.get(ParamId::B), p.get(ParamId::J));
        let w_end = 30.0 * (-b * 2e-3 / j).exp();
        assert!((mean.mechanical(30.0, 0.0) - w_end).abs() < 1e-3);
    }

    #[test]
    fn a_simulation_of_averaged_readings_meets_the_drive_s_mean_with_friction_and_coast() {
        use crate::model::sim::{InitialState, Simulator, StepInput};
        // The paper's motor with Coulomb friction: from rest, 6 V then 3 V, then the bridge
        // open until the shaft stops; 40 drive samples per record step.
        let p = ModelParams::PAPER_MOTOR.with(ParamId::Tc, 0.1);
        let (n, dt, m) = (150usize, 0.1f32, 40u32);
        let v: std::vec::Vec<f32> = (0..n).map(|k| if k < 50 { 6.0 } else { 3.0 }).collect();
        let zeros = std::vec![0.0f32; n];
        let coast = 100;
        let r = averaged_inputs(dt, m, &v, &zeros, Some(coast));
        let input = |k: usize| StepInput {
            v: v[k],
            tl: 0.0,
            measured_omega: None,
            opens: k == coast,
        };
        let mut sim = Simulator::for_record(&p, &r, InitialState::REST).unwrap();
        // The drive: the same simulator at its own step, read after each of its steps.
        let mut drive = Simulator::new(&p, dt / m as f32, InitialState::REST).unwrap();
        let (mut off, mut stopped) = (0, false);
        for k in 0..n - 1 {
            sim.apply_record::<true>(&input(k));
            let (wi, ww) = drive_mean(&mut drive, m, |j| StepInput {
                opens: k == coast && j == 0,
                ..input(k)
            });
            let y = sim.sample::<true>();
            let close = (y.current as f64 - wi).abs() < 2e-4 + 1e-4 * wi.abs()
                && (y.omega as f64 - ww).abs() < 2e-3 + 1e-4 * ww.abs();
            off += usize::from(!close);
            stopped |= k > coast && ww == 0.0;
        }
        assert!(stopped, "the shaft stops within the record");
        // The break-away and the stop too: their steps are simulated in the drive's steps
        // (the mean of their two ends missed both).
        assert_eq!(off, 0, "samples off the drive's mean");
        // The instant's readings miss by the signal's curvature and lag: many samples.
        let mut instant = Simulator::new(&p, dt, InitialState::REST).unwrap();
        let mut drive = Simulator::new(&p, dt / m as f32, InitialState::REST).unwrap();
        let mut lagging = 0;
        for k in 0..coast {
            instant.apply(&input(k));
            let mut wi = 0.0f64;
            for _ in 0..m {
                drive.apply(&input(k));
                wi += drive.reading().current as f64;
            }
            lagging += usize::from((instant.reading().current as f64 - wi / m as f64).abs() > 1e-3);
        }
        assert!(lagging > 10, "{lagging}");
    }

    #[test]
    fn a_record_of_averaged_readings_starting_in_motion_starts_where_its_quiet_step_ended() {
        use crate::model::sim::{InitialState, Simulator, StepInput};
        // The drive brakes a turning shaft at 0 V for one record step (m of its own), the
        // mean of its readings the record's first sample; then 6 V.
        let p = ModelParams::PAPER_MOTOR.with(ParamId::Tc, 0.05);
        let (n, dt, m) = (60usize, 0.01f32, 20u32);
        let turning = InitialState {
            current: 0.0,
            omega: 150.0,
        };
        let mut drive = Simulator::new(&p, dt / m as f32, turning).unwrap();
        let hold = |v: f32| StepInput {
            v,
            tl: 0.0,
            measured_omega: None,
            opens: false,
        };
        let first = drive_mean(&mut drive, m, |_| hold(0.0));
        // Taken for the state at the record's start, the mean lags it by far more than the
        // tolerance below.
        let lag = (first.0 - drive.reading().current as f64).abs();
        assert!(lag > 50.0 * 1e-3, "{lag}");
        let v = std::vec![6.0f32; n];
        let zeros = std::vec![0.0f32; n];
        let r = averaged_inputs(dt, m, &v, &zeros, None);
        let init = InitialState {
            current: first.0 as f32,
            omega: first.1 as f32,
        };
        let mut sim = Simulator::for_record(&p, &r, init).unwrap();
        let y = sim.sample::<true>();
        assert_eq!((y.current, y.omega), (init.current, init.omega));
        let mut worst = 0.0f64;
        for k in 0..n - 1 {
            sim.apply_record::<true>(&hold(v[k]));
            let (wi, _) = drive_mean(&mut drive, m, |_| hold(v[k]));
            worst = worst.max((sim.sample::<true>().current as f64 - wi).abs());
        }
        assert!(worst < 1e-3, "{worst}");
    }

    #[test]
    fn averaged_readings_with_an_effect_beyond_coulomb_friction_are_refused() {
        use crate::model::record::Record;
        use crate::model::sim::{InitialState, Simulator};
        use crate::Error;
        let zeros = [0.0f32; 16];
        let r = Record {
            dt: 1e-3,
            v: &zeros,
            omega: &zeros,
            current: None,
            load: None,
            coast_from: None,
            averaged: 8,
        };
        let p = ModelParams::PAPER_MOTOR.with(ParamId::Tc, 0.01);
        assert!(Simulator::for_record(&p, &r, InitialState::REST).is_ok());
        // A bridge dead time acts within the step: its mean is not modelled.
        let p = p.with(ParamId::Vdt, 0.5).with(ParamId::Ib, 0.1);
        let err = Simulator::for_record(&p, &r, InitialState::REST).err();
        assert_eq!(err, Some(Error::AveragedReadingsNotModelled));
        // One drive sample per step: the reading at the instant, any effect.
        let one = Record { averaged: 1, ..r };
        assert!(Simulator::for_record(&p, &one, InitialState::REST).is_ok());
    }

    #[test]
    fn the_held_rotor_mean_is_the_mean_of_its_exponential() {
        // i(t) = (V/Ra)(1 - e^{-t/tau}) sampled at j dt/m, j = 1..=m, averaged.
        let p = ModelParams::PAPER_MOTOR;
        let (ra, la) = (p.get(ParamId::Ra) as f64, p.get(ParamId::La) as f64);
        let (dt, m) = (0.01f32, 40u32);
        let delta = dt as f64 / m as f64;
        let truth: f64 = (1..=m)
            .map(|k| 12.0 / ra * (1.0 - (-(k as f64) * delta * ra / la).exp()))
            .sum::<f64>()
            / m as f64;
        let mean = StepMean::new(&p, dt, m).held_rotor(0.0, 12.0);
        assert!((mean as f64 - truth).abs() < 1e-5 * truth, "{mean} {truth}");
    }
}
