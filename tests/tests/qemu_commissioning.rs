//! One firmware binary (the QEMU build) commissions motors chosen at run time on QEMU's
//! command line, whose mechanical time constants span more than 100x, each within 3 %; the
//! records it fitted download with their coast-down and are predicted to their noise by its
//! parameters; limits set over the link are stored and obeyed, and a motor that cannot be
//! commissioned within them is refused before anything trips.

use motor_id_tests::{
    assert_within_3_percent, json, run, run_err, run_ok, s, Qemu, PAPER_WITH_FRICTION,
};
use std::path::Path;

/// A motor of the Table 1 box with Coulomb friction: each parameter by name.
type Motor = [(&'static str, f32); 6];

/// The paper's motor with the QEMU build's default friction (the firmware's default
/// plant; `qemu.rs` commissions it at power-up): La/Ra 17 ms, J Ra / (Kv^2 + Ra B) 4.2 s.
const SLOW: Motor = PAPER_WITH_FRICTION;

/// A small fast motor: La/Ra 5 ms, mechanical time constant 22 ms.
const FAST: Motor = [
    ("ra", 2.0),
    ("la", 0.01),
    ("j", 0.001),
    ("b", 0.0005),
    ("kv", 0.3),
    ("tc", 0.05),
];

/// Between them: La/Ra 5 ms, mechanical time constant 0.34 s.
const MIDDLE: Motor = [
    ("ra", 2.0),
    ("la", 0.01),
    ("j", 0.004),
    ("b", 0.0005),
    ("kv", 0.15),
    ("tc", 0.05),
];

/// The mechanical time constant J Ra / (Kv^2 + Ra B) [s] (paper Eq. 4 with Eq. 3 at steady
/// current).
fn tau_m(m: &Motor) -> f32 {
    let p = |name: &str| m.iter().find(|(n, _)| *n == name).unwrap().1;
    p("j") * p("ra") / (p("kv") * p("kv") + p("ra") * p("b"))
}

/// Every parameter of `m` within 3 % in the JSON report `r`, and pinned.
fn assert_pinned_within_3_percent(r: &serde_json::Value, m: &Motor) {
    assert_within_3_percent(r, m);
    for (name, _) in m {
        let pinned = &r["identifiability"]["parameters"][name]["pinned"];
        assert_eq!(pinned, true, "{name}: {r}");
    }
}

/// Power up QEMU with motor `m`: it commissions itself; the parameters within 3 %. The
/// records it fitted, downloaded, are predicted by them to their noise (which a record read
/// without its coast-down, say, is not).
fn commissions_at_power_up(m: &Motor) {
    let q = Qemu::with_plant(m);
    let dir = tempfile::tempdir().unwrap();
    let report = dir.path().join("params.json");
    // The host waits while the board commissions.
    run_ok(&q.board_args(&["--json", s(&report), "params"]));
    assert_pinned_within_3_percent(&json(&report), m);
    let out = run_ok(&q.board_args(&["record", "--out-dir", s(dir.path())]));
    assert!(
        out.contains("slow.csv") && out.contains("fast.csv"),
        "{out}"
    );
    let slow = std::fs::read_to_string(dir.path().join("slow.csv")).unwrap();
    // Each reading the mean of the drive's over its step (the firmware's default) where
    // the record's step holds more than one of the drive's (2 kHz, `qemu/mod.rs`).
    let mut lines = slow.lines();
    let header = lines.next().unwrap();
    let dt: f64 = lines
        .nth(1)
        .unwrap()
        .split(',')
        .next()
        .unwrap()
        .parse()
        .unwrap();
    match dt > 1.5 / 2000.0 {
        true => assert_eq!(header, "t,v,omega,i,bridge,averaged", "step {dt} s"),
        false => assert_eq!(header, "t,v,omega,i,bridge", "step {dt} s"),
    }
    let last = slow.trim_end().lines().last().unwrap();
    assert!(
        last.split(',').nth(4) == Some("0"),
        "ends in its coast-down: {last}"
    );
    validated_to_noise(dir.path(), &report);
}

/// `validate` of the board's parameters on its downloaded records: every record at its
/// noise floor.
fn validated_to_noise(dir: &Path, params: &Path) {
    let out = dir.join("validation.json");
    let (slow, fast) = (dir.join("slow.csv"), dir.join("fast.csv"));
    run_ok(&[
        "validate",
        "--params",
        s(params),
        s(&slow),
        s(&fast),
        "--json",
        s(&out),
    ]);
    let v = json(&out);
    for r in v["records"].as_array().unwrap() {
        let ratio = r["speed"]["rmse_over_noise"].as_f64().unwrap();
        assert!(ratio < 1.2, "{r}");
    }
}

#[test]
fn the_motors_span_more_than_a_hundredfold_in_mechanical_time_constant() {
    let (fast, slow) = (tau_m(&FAST), tau_m(&SLOW));
    assert!(slow / fast > 100.0, "{fast} s to {slow} s");
    assert!(tau_m(&MIDDLE) > 5.0 * fast && tau_m(&MIDDLE) < slow / 5.0);
}

#[test]
fn a_fast_motor_commissions_at_power_up() {
    commissions_at_power_up(&FAST);
}

#[test]
fn a_middle_motor_commissions_at_power_up() {
    commissions_at_power_up(&MIDDLE);
}

#[test]
fn the_slow_motor_commissions_at_power_up() {
    commissions_at_power_up(&SLOW);
}

#[test]
fn limits_set_over_the_link_hold_and_a_motor_beyond_them_is_refused_before_any_trip() {
    // Friction of 0.5 N m needs 0.5 / 0.3 = 1.7 A to turn the shaft: the default 40 A do
    // (power-up commissions it), 1 A cannot.
    let mut sticky = FAST;
    sticky[5] = ("tc", 0.5);
    let q = Qemu::with_plant(&sticky);
    let dir = tempfile::tempdir().unwrap();
    let (limits, report) = (dir.path().join("limits.json"), dir.path().join("r.json"));
    run_ok(&q.board_args(&["--json", s(&report), "params"]));
    let out = run_ok(&q.board_args(&["config"]));
    assert!(
        out.contains("50 V, 40 A, 500 rad/s, time budget 60 s"),
        "{out}"
    );
    let set = [
        "--json",
        s(&limits),
        "config",
        "--current",
        "1",
        "--budget",
        "30",
    ];
    let out = run_ok(&q.board_args(&set));
    assert!(
        out.contains("50 V, 1 A, 500 rad/s, time budget 30 s"),
        "{out}"
    );
    assert_eq!(json(&limits)["current"], 1.0);
    // Limits the board cannot use are refused by the CLI, as a usage error, before they
    // are sent.
    let out = run(&q.board_args(&["config", "--budget", "1"]));
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("must be from 5"));
    // Refused by the probe, with its reason, not tripped.
    let err = run_err(&q.board_args(&["-q", "commission"]));
    assert!(err.contains("does not turn"), "{err}");
    // The parameters stored at power-up stay, and so do the limits.
    let out = run_ok(&q.board_args(&["params"]));
    assert!(out.contains("rmse_omega"), "{out}");
    let out = run_ok(&q.board_args(&["config"]));
    assert!(out.contains("1 A"), "{out}");
}
