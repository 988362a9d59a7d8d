//! Tests of the pipelines (`fit::identify`): recovery, identifiability, refusals.

use super::*;
use crate::model::profile::Profile;
use crate::model::synth::Noise;
use crate::param_id::ParamId;
use crate::testkit::Owned;

fn assert_within(p: &ModelParams, truth: &ModelParams, rel: f32) {
    for id in ParamId::MOTOR {
        let (a, b) = (p.get(id), truth.get(id));
        assert!(
            (a / b - 1.0).abs() <= rel,
            "{}: {a} vs {b} (all: {p:?})",
            id.name()
        );
    }
}

#[test]
fn seed_motor_with_current_recovered_within_one_percent() {
    let truth = ModelParams::SEED_MOTOR;
    let data = Owned::seed_motor(
        Profile::Steps,
        0.015,
        2000,
        Noise {
            omega: 0.5,
            current: 0.02,
        },
        11,
    );
    let rec = [data.record(true, false)];
    let id = identify(
        &rec,
        &ProblemSpec::default(),
        &IdentifyConfig::default_pipeline(1),
        |_| ControlFlow::Continue(()),
    )
    .unwrap();
    std::println!(
        "{:?} evals {} rmse {}",
        id.params,
        id.evaluations,
        id.cost.rmse_omega
    );
    assert_within(&id.params, &truth, 0.01);
    assert!(id.identifiability.all_pinned(), "{:?}", id.identifiability);
    let floor = Objective::new(&rec)
        .unwrap()
        .cost(&truth)
        .unwrap()
        .rmse_omega;
    assert!(
        id.cost.rmse_omega <= 1.01 * floor,
        "{} vs floor {floor}",
        id.cost.rmse_omega
    );
}

#[test]
fn speed_only_step_pins_three_combinations() {
    let truth = ModelParams::SEED_MOTOR;
    let data = Owned::seed_motor(
        Profile::Start,
        0.01,
        2000,
        Noise {
            omega: 0.2,
            current: 0.0,
        },
        5,
    );
    let rec = [data.record(false, false)];
    let id = identify(
        &rec,
        &ProblemSpec::default(),
        &IdentifyConfig::default_pipeline(2),
        |_| ControlFlow::Continue(()),
    )
    .unwrap();
    let ident = &id.identifiability;
    std::println!("{:?}", ident);
    assert_eq!(ident.rank, 3);
    assert!(ident.params.iter().all(|p| !p.pinned));
    assert!(ident.combinations.iter().all(|c| c.pinned));
    assert_eq!(ident.unpinned.len(), 2);
    let floor = Objective::new(&rec)
        .unwrap()
        .cost(&truth)
        .unwrap()
        .rmse_omega;
    assert!(
        id.cost.rmse_omega <= 1.01 * floor,
        "{} vs floor {floor}",
        id.cost.rmse_omega
    );
}

#[test]
fn more_restarts_than_kept_starts_is_refused_before_any_work() {
    let data = Owned::seed_motor(Profile::Steps, 0.015, 200, Noise::default(), 1);
    let rec = [data.record(true, false)];
    let at_capacity = IdentifyConfig {
        restarts: MAX_RESTARTS as u32,
        ..IdentifyConfig::default_pipeline(1)
    };
    let go_on = |_: &Progress| ControlFlow::Continue(());
    assert!(identify(&rec, &ProblemSpec::default(), &at_capacity, go_on).is_ok());
    let over = IdentifyConfig {
        restarts: MAX_RESTARTS as u32 + 1,
        ..at_capacity
    };
    let mut called = false;
    let result = identify(&rec, &ProblemSpec::default(), &over, |_| {
        called = true;
        ControlFlow::Continue(())
    });
    assert_eq!(result.err(), Some(Error::InvalidConfig));
    assert!(!called);
}
