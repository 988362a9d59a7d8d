//! With speed and current, motors across the paper's Table 1 box are recovered within 1 % when
//! the record resolves them; where it cannot, the report says which parameter is not pinned.

use motor_id_tests::{json, param, rel, run_ok, s};

const NAMES: [&str; 5] = ["ra", "la", "j", "b", "kv"];

/// Simulate a `steps` record sampled at 20 samples per electrical time constant (at least
/// 200 Hz), identify it with the default bounds, return the report.
fn identify(motor: [f64; 5], seed: u64) -> serde_json::Value {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("rec.csv");
    let report = dir.path().join("r.json");
    let rate = (20.0 * motor[0] / motor[1])
        .clamp(200.0, 20_000.0)
        .to_string();
    let spec: Vec<String> = NAMES
        .iter()
        .zip(motor)
        .map(|(n, v)| format!("{n}={v}"))
        .collect();
    run_ok(&[
        "simulate",
        "--motor",
        &spec.join(","),
        "--profile",
        "steps",
        "--rate",
        &rate,
        "--noise-omega",
        "0.2",
        "--noise-current",
        "0.01",
        "--seed",
        &seed.to_string(),
        "--out",
        s(&csv),
    ]);
    run_ok(&["identify", s(&csv), "--json", s(&report), "-q"]);
    json(&report)
}

#[test]
fn motors_across_the_box_within_one_percent() {
    let motors = [
        [1.0, 0.1, 0.01, 0.005, 0.5],
        [5.0, 0.5, 0.2, 0.05, 1.0],
        [2.0, 1.5, 0.05, 0.002, 0.3],
        [8.0, 0.02, 0.5, 0.001, 1.5],
        [0.7, 1.8, 0.8, 0.9, 1.9],
    ];
    for (k, m) in motors.iter().enumerate() {
        let r = identify(*m, k as u64);
        assert_eq!(
            r["identifiability"]["all_pinned"], true,
            "motor {m:?}: {}",
            r["identifiability"]
        );
        for (name, truth) in NAMES.iter().zip(m) {
            let got = param(&r, name);
            assert!(
                rel(got, *truth) < 0.01,
                "motor {m:?}: {name} {got} vs {truth}"
            );
        }
    }
}

#[test]
fn what_the_record_cannot_resolve_is_flagged_not_guessed() {
    // The box's corner (complex poles near -25 +- 632j): viscous friction 0.0005 is
    // invisible next to Kv^2 = 4, so b is not pinned while the rest is recovered.
    let r = identify([0.5, 0.01, 0.001, 0.0005, 2.0], 1);
    let ident = &r["identifiability"]["parameters"];
    assert_eq!(ident["b"]["pinned"], false, "{ident}");
    for (name, truth) in [("ra", 0.5), ("la", 0.01), ("j", 0.001), ("kv", 2.0)] {
        assert_eq!(ident[name]["pinned"], true, "{name}: {ident}");
        assert!(
            rel(param(&r, name), truth) < 0.01,
            "{name}: {}",
            param(&r, name)
        );
    }
}
