//! Tests of the board report read from a board's message.

use super::*;
use crate::progress::BarState;
use motor_id_shared::param_id::ParamId;
use motor_id_shared::wire::protocol::{Estimate, JobStage};

/// A report of the five motor parameters and, with `friction`, `tc` as its sixth.
fn motor(friction: Option<(f32, f32)>) -> MotorReport {
    let values = [3.412, 0.0573, 0.0424, 0.00267, 0.1604];
    let std = [0.01, f32::NAN, 1e-4, 2e-5, 3e-4];
    let tc = friction.map(|(value, std)| (ParamId::Tc.index(), value, std));
    MotorReport {
        estimates: (0..5)
            .map(|k| (k, values[k], std[k]))
            .chain(tc)
            .map(|(k, value, std)| Estimate {
                param: k as u8,
                value,
                std,
            })
            .collect(),
        rmse_omega: 0.25,
        evaluations: 31,
        rank: 4,
    }
}

#[test]
fn text_and_json_read_the_same_estimates() {
    let report = BoardReport::new(&motor(Some((0.1, 0.002)))).unwrap();
    let text = report.text();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines.len(), 7);
    assert_eq!(lines[0], "  ra  = 3.412          +- 1.000e-2");
    assert_eq!(lines[1], "  la  = 0.0573         NOT pinned");
    assert_eq!(lines[5], "  tc  = 0.1            +- 2.000e-3");
    assert_eq!(lines[6], "rmse_omega = 0.25 rad/s, 31 evaluations, rank 4");
    let json = serde_json::to_value(&report).unwrap();
    assert_eq!(json["params"]["tc"], 0.1);
    assert_eq!(json["identifiability"]["free"], 6);
    assert_eq!(
        json["identifiability"]["parameters"]["la"]["std"],
        serde_json::Value::Null
    );
    assert_eq!(json["identifiability"]["parameters"]["la"]["pinned"], false);
    assert_eq!(json["identifiability"]["parameters"]["tc"]["std"], 0.002);
}

#[test]
fn without_friction_no_tc() {
    let report = BoardReport::new(&motor(None)).unwrap();
    assert_eq!(report.text().lines().count(), 6);
    let json = serde_json::to_value(&report).unwrap();
    assert!(json["params"].get("tc").is_none());
    assert_eq!(json["identifiability"]["free"], 5);
}

#[test]
fn a_parameter_code_this_host_does_not_know_is_an_error() {
    let mut r = motor(None);
    r.estimates[4].param = 200;
    let err = BoardReport::new(&r).unwrap_err().to_string();
    assert_eq!(err, "the board reports an unknown parameter (code 200)");
}

#[test]
fn the_progress_bar_is_as_long_as_the_stage_the_board_announces() {
    let frame = |stage, iteration| BoardMessage::Progress {
        stage,
        iteration,
        total: 40,
        evaluations: 10 * iteration,
        best: 0.5,
    };
    // Frame after frame of one stage: the position advances, the length stays the total.
    for stage in [
        JobStage::Experiment,
        JobStage::Probe,
        JobStage::Search,
        JobStage::Refine,
        JobStage::Check,
    ] {
        let states: Vec<BarState> = (1..=5)
            .map(|k| BarState::of_board(&frame(stage, k)).unwrap())
            .collect();
        assert!(
            states.iter().all(|s| s.length == 40),
            "{stage:?}: {states:?}"
        );
        let positions: Vec<u64> = states.iter().map(|s| s.position).collect();
        assert_eq!(positions, [1, 2, 3, 4, 5], "{stage:?}");
    }
    let prefixes = [
        (JobStage::Experiment, "experiment"),
        (JobStage::Probe, "probe"),
        (JobStage::Search, "FFO"),
        (JobStage::Refine, "refine"),
        (JobStage::Check, "check"),
    ];
    for (stage, prefix) in prefixes {
        let state = BarState::of_board(&frame(stage, 0)).unwrap();
        assert_eq!(state.prefix, prefix, "{stage:?}");
    }
    // A board that runs past its announced total stretches the bar instead of overfilling it.
    assert_eq!(
        BarState::of_board(&frame(JobStage::Refine, 50))
            .unwrap()
            .length,
        50
    );
    assert_eq!(BarState::of_board(&BoardMessage::Cleared), None);
}
