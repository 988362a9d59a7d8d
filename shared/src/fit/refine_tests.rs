//! Tests of the least-squares refinement (`fit::refine`).

use super::*;
use crate::param_id::ParamId;
use crate::testkit::{Fitted, Owned};

#[test]
fn the_predicted_gain_is_the_local_model_s_fall_of_the_sse() {
    // SSE(du) = 10 + 2 (-2) du + 4 du^2 in one coordinate: at du = 0.5 it is 9, a fall
    // of 1 (the undamped step: g^2 / H = 4 / 4); at du = 0.25, 9.25.
    let mut ne = NormalEquations::EMPTY;
    ne.jtj[0][0] = 4.0;
    ne.jtr[0] = -2.0;
    let mut du: Vector = [0.0; MAX_FREE];
    du[0] = 0.5;
    assert_eq!(predicted_gain(&ne, &du, 1), 1.0);
    du[0] = 0.25;
    assert_eq!(predicted_gain(&ne, &du, 1), 0.75);
}

#[test]
fn a_refit_to_a_tolerance_ends_where_the_local_model_gains_under_half_of_it() {
    // The paper motor with current, Ra moved three deviations off the optimum: least
    // squares to its last digits gains G from there. Asked to gain at least 4 G a step,
    // the refit stops at its start's normal equations (the local model predicts about G,
    // under half of 4 G); asked for G / 4 a step, it steps.
    let data = Owned::paper_motor_noisy_steps(11);
    let rec = [data.record(true, false)];
    let fitted = Fitted::of(&rec, 1);
    let (fit, objective, space) = (&fitted.fit, &fitted.objective, &fitted.space);
    let ra = fit.identifiability.params[0];
    assert_eq!(ra.id, ParamId::Ra);
    let off = fit
        .params
        .with(ParamId::Ra, ra.value + 3.0 * ra.std.expect("pinned"));
    let start = space.unit(&off);
    let dim = space.dim();
    let refit = |abs_tol: f64| {
        let lm = LmConfig {
            abs_tol,
            ..LmConfig::default()
        };
        levenberg_marquardt(objective, space, &start[..dim], &lm, &mut |_| {
            ControlFlow::Continue(())
        })
        .unwrap()
    };
    let from = objective.cost(&off).unwrap().sse;
    let full = refit(0.0);
    let gained = from - full.cost.sse;
    assert!(full.iterations > 0 && gained > 0.0, "{full:?}");
    let ended = refit(4.0 * gained);
    assert_eq!(ended.iterations, 0, "{ended:?}");
    assert_eq!(ended.evaluations, dim as u32 + 1, "{ended:?}");
    let stepped = refit(0.25 * gained);
    assert!(stepped.iterations > 0, "{stepped:?}");
    assert!(stepped.cost.sse < from - 0.25 * gained, "{stepped:?}");
}

#[test]
fn a_step_whose_model_held_ends_a_refinement_to_a_tolerance_and_no_other() {
    let cfg = LmConfig {
        abs_tol: 1.0,
        ..LmConfig::default()
    };
    // Predicted 10, fell 10.2 (the model held to 0.2 of the tolerance), and the
    // undamped step predicted 10.3: 0.1 left, under half the tolerance.
    assert!(model_held(10.2, 10.0, 10.3, &cfg));
    // The model missed by 0.6, more than half the tolerance.
    assert!(!model_held(10.6, 10.0, 10.3, &cfg));
    // 0.8 left to gain by the undamped step.
    assert!(!model_held(10.2, 10.0, 11.0, &cfg));
    // A refinement to its last digits.
    assert!(!model_held(10.2, 10.0, 10.3, &LmConfig::default()));
}
