//! Tests of the means over a step (`model::step_mean`).

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
        measured: None,
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
        measured: None,
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

#[test]
fn a_first_order_mean_is_the_diagonal_of_the_matrix_doubling_bit_for_bit() {
    // The scalar doubling of a first-order step against the 2x2 doubling of the diagonal
    // system holding it (what the means were built from before): the same bits.
    for seed in 1..=200u64 {
        let p = crate::model::synth::table_one_motor(seed);
        let Motor { ra, la, j, b, .. } = Motor::of(&p);
        for (delta, m) in [(1e-5, 1), (5e-5, 45), (2e-4, 18), (1e-3, 7), (0.01, 64)] {
            let (a0, a1) = (-ra / la, -b / j);
            let (d0, f0) = first_order(a0, 1.0, delta);
            let (d1, f1) = first_order(a1, 1.0, delta);
            let d = [[d0, 0.0], [0.0, d1]];
            let f = [[f0, 0.0], [0.0, f1]];
            let (s, t) = Steps::means(Steps::one(d, f), m);
            for (k, a) in [(0, a0), (1, a1)] {
                let (s1, t1) = first_order_means(a, delta, m);
                assert_eq!(s1.to_bits(), s[k][k].to_bits(), "{seed} {delta} {m}");
                assert_eq!(t1.to_bits(), t[k][k].to_bits(), "{seed} {delta} {m}");
            }
        }
    }
}
