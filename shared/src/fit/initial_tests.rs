//! Tests of the equation-error start (`fit::initial`).

use super::*;
use crate::model::profile::{Experiment, Profile};
use crate::model::synth::Noise;
use crate::param_id::ParamId;
use crate::testkit::Owned;

#[test]
fn least_squares_solves_nearly_collinear_columns() {
    // Columns t, t + 1e-5 t^2 and 1 over 0 <= t < 20 (nearly collinear, as integrated
    // regressors of a steady record are); exact data.
    let beta = [2.0, -3.0, 0.5];
    let mut ls = LeastSquares::new(3);
    for k in 0..2000 {
        let t = k as f64 * 0.01;
        let row = [t, t + 1e-5 * t * t, 1.0];
        let y: f64 = row.iter().zip(beta).map(|(a, b)| a * b).sum();
        ls.add(&row, y);
    }
    let x = ls.solve().expect("full rank");
    for (got, want) in x.iter().zip(beta) {
        assert!((got - want).abs() < 1e-6 * want.abs(), "{got} vs {want}");
    }
    // A repeated column is rank deficient.
    let mut ls = LeastSquares::new(2);
    for k in 0..100 {
        ls.add(&[k as f64, k as f64], 1.0);
    }
    assert_eq!(ls.solve(), None);
}

#[test]
fn recovers_a_noise_free_motor_closely() {
    let truth = ModelParams::PAPER_MOTOR;
    let data = Owned::paper_motor(Profile::Steps, 0.001, 30_000, Noise::default(), 1);
    let est = equation_error(&[data.record(true, false)], false).unwrap();
    for id in ParamId::MOTOR {
        let rel = (est.get(id) / truth.get(id) - 1.0).abs();
        assert!(
            rel < 0.02,
            "{}: {} vs {}",
            id.name(),
            est.get(id),
            truth.get(id)
        );
    }
}

#[test]
fn a_coast_down_record_gives_coulomb_friction_and_the_motor() {
    let truth = crate::device::plant::demo_motor();
    let data = Owned::commissioning(&truth, 2000, 0.01, 50.0);
    let record = data.record(true, false);
    let est = equation_error(&[record], true).unwrap();
    // Sampled at 100 Hz, below the electrical time constant's resolution (17 ms): La is
    // the least accurate (the integrated equation is continuous-time; a start only).
    for (id, tol) in [
        (ParamId::Ra, 0.02),
        (ParamId::Kv, 0.02),
        (ParamId::J, 0.03),
        (ParamId::B, 0.03),
        (ParamId::Tc, 0.03),
        (ParamId::La, 0.3),
    ] {
        let rel = (est.get(id) / truth.get(id) - 1.0).abs();
        assert!(
            rel < tol,
            "{}: {} vs {}",
            id.name(),
            est.get(id),
            truth.get(id)
        );
    }
    // Without the friction term, viscous friction absorbs it.
    let linear = equation_error(&[record], false).unwrap();
    assert!(
        linear.get(ParamId::B) > 1.1 * truth.get(ParamId::B),
        "{linear:?}"
    );
}

#[test]
fn speed_only_start_lies_on_the_equal_fit_set() {
    let data = Owned::paper_motor(Profile::Steps, 0.001, 30_000, Noise::default(), 1);
    let (c1, c2, c3) = speed_coefficients(&[data.record(false, false)]).unwrap();
    // Paper Eq. 6 coefficients of the truth.
    let (ra, la, j, b, kv) = (3.412f64, 0.0573f64, 0.0424f64, 0.00267f64, 0.1604f64);
    for (got, want) in [
        (c1, kv / (la * j)),
        (c2, ra / la + b / j),
        (c3, (ra * b + kv * kv) / (la * j)),
    ] {
        assert!((got / want - 1.0).abs() < 0.02, "{got} vs {want}");
    }
    let p = equal_fit_point((c1, c2, c3), &ProblemSpec::default()).unwrap();
    let (a1, _) = crate::fit::identifiability::Combination::KvOverLaJ.evaluate(&p);
    assert!((a1 as f64 / c1 - 1.0).abs() < 1e-3);
}

#[test]
fn many_records_with_load_fit_in_fixed_memory() {
    // Sampled well above the electrical time constant (17 ms): the integrated equation is
    // continuous-time, so coarse sampling biases it (it is only a start).
    let exp = Experiment {
        profile: Profile::Load,
        voltage: 50.0,
        duration: 20.0,
        load_torque: 0.5,
    };
    let data: std::vec::Vec<Owned> = (0..6)
        .map(|s| {
            Owned::new(
                &ModelParams::PAPER_MOTOR,
                exp,
                0.002,
                10_000,
                Noise::default(),
                s,
            )
        })
        .collect();
    let recs: std::vec::Vec<Record> = data.iter().map(|d| d.record(false, true)).collect();
    let (c1, _, _) = speed_coefficients(&recs).unwrap();
    let want = 0.1604 / (0.0573 * 0.0424);
    assert!((c1 / want - 1.0).abs() < 0.02, "{c1} vs {want}");
}

#[test]
fn needs_current() {
    let exp = Experiment {
        profile: Profile::Start,
        voltage: 50.0,
        duration: 1.0,
        load_torque: 0.0,
    };
    let data = Owned::new(
        &ModelParams::PAPER_MOTOR,
        exp,
        0.001,
        1000,
        Noise::default(),
        1,
    );
    assert!(equation_error(&[data.record(false, false)], false).is_none());
}
