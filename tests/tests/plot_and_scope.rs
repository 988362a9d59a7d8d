//! The fit plot and the oscilloscope import of the paper's workflow.

use motor_id_tests::{json, param, rel, run_ok, s, simulate, PAPER_START};

#[test]
fn identify_writes_a_png_plot() {
    let d = tempfile::tempdir().unwrap();
    let csv = d.path().join("rec.csv");
    let png = d.path().join("fit.png");
    run_ok(&[
        "simulate",
        "--profile",
        "steps",
        "--rate",
        "100",
        "--duration",
        "30",
        "--noise-omega",
        "0.3",
        "--out",
        s(&csv),
    ]);
    run_ok(&["identify", s(&csv), "--plot", s(&png), "-q"]);
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    assert!(
        bytes.len() > 20_000,
        "a 1200x990 plot with three panels is not {} bytes",
        bytes.len()
    );
}

#[test]
fn scope_trace_of_tacho_volts_is_imported_and_identified() {
    // A record of the paper's motor turned into what the paper's oscilloscope saved: settings
    // lines, a units header, time from -1 s, tacho volts at 35 rad/s/V, inverted.
    let d = tempfile::tempdir().unwrap();
    let csv = d.path().join("rec.csv");
    simulate(&csv, &[PAPER_START, &["--voltage", "48"]].concat());
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut scope = String::from("HMO2024 trace\nin s,CH1[V]\n");
    for k in 0..100 {
        scope += &format!("{},{}\n", -1.0 + k as f64 * 0.01, 0.0);
    }
    for line in text.lines().skip(1) {
        let f: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        scope += &format!("{},{}\n", f[0], -f[2] / 35.0);
    }
    let scope_path = d.path().join("scope.csv");
    std::fs::write(&scope_path, scope).unwrap();
    let rec = d.path().join("imported.csv");
    run_ok(&[
        "import-scope",
        s(&scope_path),
        "--tacho-gain",
        "35",
        "--inverted",
        "--voltage",
        "48",
        "--out",
        s(&rec),
    ]);
    let report = d.path().join("r.json");
    run_ok(&["identify", s(&rec), "--json", s(&report), "-q"]);
    let r = json(&report);
    assert!(
        r["rmse_omega"].as_f64().unwrap() < 0.25,
        "{}",
        r["rmse_omega"]
    );
    // Speed only: the static gain Kv / (Ra B + Kv^2) is what the data pins.
    let gain = |ra: f64, b: f64, kv: f64| kv / (ra * b + kv * kv);
    let got = gain(param(&r, "ra"), param(&r, "b"), param(&r, "kv"));
    assert!(rel(got, gain(3.412, 0.00267, 0.1604)) < 0.01, "{got}");
}
