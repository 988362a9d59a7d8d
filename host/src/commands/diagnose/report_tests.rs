//! Tests of the diagnose report: its text and JSON from hand-made reports.

use super::*;
use crate::commands::diagnose::regimes::Spectrum;

fn effect(name: &'static str, holdout: f32, significant: bool) -> EffectFit {
    EffectFit {
        name,
        train_rmse: Num(0.5),
        holdout_rmse: Num(holdout),
        holdout_joint: Num(holdout),
        params: ByParam(vec![]),
        effect_std: ByParam(vec![]),
        significant,
        restarted: None,
    }
}

/// A refit stalled above the model `from` nested in it and searched again from there.
fn stall(from: &'static str) -> crate::commands::diagnose::stalled::Restarted {
    crate::commands::diagnose::stalled::Restarted {
        from,
        stalled: Num(3.9142),
        nested: Num(3.2559),
        refitted: Num(1.9601),
        wider: false,
        evaluations: 410,
        decimation: 9,
    }
}

/// `effect`, its refit stalled above Coulomb friction and searched again from there.
fn restarted(e: EffectFit) -> EffectFit {
    EffectFit {
        restarted: Some(stall("coulomb_friction")),
        ..e
    }
}

/// A report whose verdict is `tc = 0.1`, with `second` on top when given (its fit at the
/// forward step stalled above the model it was added to, [`stall`]).
fn report(second: Option<&'static str>) -> DiagnoseReport {
    DiagnoseReport {
        schema_version: crate::report::SCHEMA_VERSION,
        baseline: Baseline {
            train_rmse: Num(0.61234),
            holdout_rmse: Num(0.7),
            params: ByParam(vec![]),
            noise_train: Num(0.2),
            noise_holdout: Num(0.25),
        },
        effects: vec![
            effect("coulomb_friction", 0.3, true),
            restarted(effect("sensor_delay", 0.69, false)),
        ],
        verdict: Verdict {
            effect: Some("coulomb_friction"),
            holdout_rmse_before: Num(0.7),
            holdout_rmse_after: Num(0.3),
            train_rmse_before: Num(0.61234),
            train_rmse_after: Num(0.5),
            share_of_misfit_removed: Num(share_removed(0.7, 0.3, 0.25)),
            holdout_noise: Num(0.25),
            chosen: Some(Chosen {
                effect_params: ByParam(vec![(ParamId::Tc, Num(0.1))]),
                effect_std: ByParam(vec![(ParamId::Tc, None)]),
                base_params_shift: ByParam(vec![]),
            }),
            second: Second {
                effect: second,
                fit: second.map(|_| SecondFit {
                    holdout_rmse_after: Num(0.26),
                    train_rmse_after: Num(0.21),
                    effect_params: ByParam(vec![(ParamId::Kq, Num(4e-6))]),
                }),
            },
            effects: std::iter::once(("coulomb_friction", ParamId::Tc, 0.1, 0.3))
                .chain(second.map(|e| (e, ParamId::Kq, 4e-6, 0.26)))
                .enumerate()
                .map(|(step, (name, id, value, after))| NamedEffect {
                    name,
                    params: ByParam(vec![(id, Num(value))]),
                    holdout_rmse_after: Num(after),
                    restarted: (step == 1).then(|| stall("the model it is added to")),
                })
                .collect(),
            partial: vec![],
            params: ByParam(vec![]),
            repeatability_floor: None,
            unexplained: false,
            remainder: None,
            widened: None,
            current: None,
        },
        where_: WhereReport {
            rmse: 0.6,
            noise: 0.2,
            regimes: vec![],
            records: vec![],
            signatures: vec![],
            spectrum: Spectrum {
                order_cycles_per_rev: 1,
                share_of_residual: 0.0,
                points_to: "tacho_ripple",
            },
            summary: vec!["50 % of the misfit lies in reverse rotation".into()],
        },
        data: DataReport {
            current: true,
            train: vec!["a.csv".into()],
            holdout: vec!["b.csv".into()],
        },
        cannot_support: vec!["something".into()],
        warnings: Vec::new(),
        coverage_gaps: vec![],
        repeatability: Repeatability {
            groups: vec![],
            method: "m",
            holdout: None,
        },
    }
}

#[test]
fn share_removed_is_relative_to_the_misfit_above_noise() {
    assert_eq!(share_removed(2.0, 1.0, 1.0), 1.0);
    assert!((share_removed(2.0, 1.5, 1.0) - (4.0 - 2.25) / 3.0).abs() < 1e-6);
    assert_eq!(share_removed(1.0, 2.0, 0.5), 0.0);
    // Fitted to the noise already: nothing above it to remove.
    assert_eq!(share_removed(0.5, 0.5, 0.5), 0.0);
}

#[test]
fn text_reads_the_report() {
    let text = report(Some("quadratic_load")).text();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(
        lines,
        [
            "baseline: train rmse 0.6123, holdout rmse 0.7000 rad/s (holdout noise 0.2500)",
            "where:",
            "  50 % of the misfit lies in reverse rotation",
            "effects, best held-out misfit first:",
            "  coulomb_friction     train 0.5000  holdout 0.3000  significant",
            "  sensor_delay         train 0.5000  holdout 0.6900",
            "                       its refit stalled above coulomb_friction (objective 3.9142 > \
             3.2559): searched again from there to 1.9601",
            "verdict: coulomb_friction: holdout rmse 0.7000 -> 0.3000 rad/s with the effects \
             below (94 % of the misfit above noise removed), params {\"tc\":0.1}",
            "then: quadratic_load: holdout rmse -> 0.2600 rad/s",
            "  its refit stalled above the model it is added to (objective 3.9142 > 3.2559): \
             searched again from there to 1.9601",
            "explained: the held-out misfit (0.3000 rad/s) is within 1.2 x the noise floor \
             (0.2500 rad/s)",
            "note: something",
        ]
    );
    let without = report(None).text();
    assert!(!without.contains("then:"));
    assert!(without.contains("-> 0.3000 rad/s (94 %"), "{without}");
}

#[test]
fn an_unexplained_verdict_without_a_remainder_says_what_holds_it_up() {
    let stand_in = |name, in_model| PartialStandIn {
        name,
        share_of_excess: Num(0.5),
        channel: "speed",
        why: "because".into(),
        in_model,
    };
    let mut r = report(None);
    r.verdict.unexplained = true;
    // An extension of an entry left out is passed over: not in the model, so not what
    // holds the misfit at the floor; the current's misfit is what is left.
    r.verdict.partial = vec![stand_in("static_friction", false)];
    r.verdict.current = Some(ChannelVerdict {
        holdout_rmse_before: Num(0.2),
        holdout_rmse_after: Num(0.1),
        holdout_noise: Num(0.05),
        unexplained: true,
        regimes: Vec::new(),
        where_: vec!["71 % of the current's misfit lies in near standstill".into()],
    });
    let text = r.text();
    assert!(!text.contains("only with the partial stand-ins"), "{text}");
    assert!(
        text.contains(
            "unexplained: the held-out current misfit (0.1000 A) stays above 1.2 x its noise (0.0500 A)\nunexplained: 71 % of the current's misfit lies in near standstill\n"
        ),
        "{text}"
    );
    // A stand-in in the model is.
    r.verdict.partial.push(stand_in("brush_drop", true));
    r.verdict.current = None;
    let text = r.text();
    assert!(
        text.contains("only with the partial stand-ins (brush_drop)")
            && text.contains("with the partial stand-ins ("),
        "{text}"
    );
}

#[test]
fn json_has_the_contract_fields() {
    let json = serde_json::to_value(report(None)).unwrap();
    assert_eq!(json["schema_version"], 1);
    let v = &json["verdict"];
    assert_eq!(v["effect"], "coulomb_friction");
    assert_eq!(v["effect_params"]["tc"], 0.1);
    assert!(v["effect_std"]["tc"].is_null());
    assert_eq!(v["second"], serde_json::json!({ "effect": null }));
    assert!(json["where"]["summary"].is_array());
    assert!(json["effects"][0]["restarted"].is_null());
    let r = &json["effects"][1]["restarted"];
    assert_eq!(r["from"], "coulomb_friction");
    assert_eq!(
        (r["stalled"].as_f64(), r["decimation"].as_u64()),
        (Some(3.9142), Some(9))
    );
    let with = serde_json::to_value(report(Some("quadratic_load"))).unwrap();
    assert_eq!(with["verdict"]["second"]["effect_params"]["kq"], 4e-6);
    // A named effect's fit searched again at its step says so, as the first round's.
    let named = &with["verdict"]["effects"];
    assert!(named[0]["restarted"].is_null());
    assert_eq!(named[1]["restarted"]["from"], "the model it is added to");
    assert_eq!(named[1]["restarted"]["refitted"].as_f64(), Some(1.9601));
}

#[test]
fn a_null_verdict_says_so() {
    let mut r = report(None);
    r.verdict.effect = None;
    r.verdict.chosen = None;
    let json = serde_json::to_value(&r).unwrap();
    assert!(json["verdict"]["effect"].is_null());
    assert!(json["verdict"].get("effect_params").is_none());
    assert!(r
        .text()
        .contains("verdict: null (no effect of the catalogue improves"));
}

#[test]
fn an_unexplained_remainder_is_said_with_its_size_and_place() {
    let mut r = report(None);
    r.verdict.unexplained = true;
    r.verdict.remainder = Some(Remainder {
        rmse: Num(0.17),
        over_floor: Num(1.2),
        over_noise: Num(1.2),
        floor: "noise",
        floor_rmse: Num(0.25),
        regimes: vec![],
        current_regimes: vec![],
        records: vec![],
        span: super::super::remainder::Span {
            file: "b.csv".into(),
            from_s: Num(1.0),
            to_s: Num(2.0),
            share_of_misfit: Num(0.4),
        },
        drift: vec![],
        summary: vec!["0.170 rad/s lies above the noise floor".into()],
    });
    let text = r.text();
    assert!(text.contains("unexplained: 0.170 rad/s lies above the noise floor"));
    assert!(!text.contains("explained: the held-out"));
    let json = serde_json::to_value(&r).unwrap();
    assert_eq!(json["verdict"]["unexplained"], true);
    assert_eq!(json["verdict"]["remainder"]["span"]["file"], "b.csv");
    assert_eq!(json["verdict"]["effects"][0]["name"], "coulomb_friction");
}
