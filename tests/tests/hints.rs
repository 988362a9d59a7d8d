//! `identify` names a cheap explanation of a large misfit when a refit confirms it (issue
//! 22): records of the independent reference plant written with an inverted sign, speed in
//! rpm, current in mA, or a voltage column that never changes. A correct record gets no
//! hint.

use motor_id_tests::reference_plant::SpeedSensor;
use motor_id_tests::reference_plant::{csv, experiment, run, Effects, Motor, Sensors, Shape};
use motor_id_tests::{json, run_ok, s};
use std::path::Path;

/// La/Ra 20 ms, mechanical time constant 0.27 s: inside Table 1, settled within the record.
const MOTOR: Motor = Motor {
    ra: 1.0,
    la: 0.02,
    j: 0.002,
    b: 0.001,
    kv: 0.08,
};

/// `src` with column `name` of every data row replaced by `f(value)`.
fn rewrite(src: &Path, dst: &Path, name: &str, f: impl Fn(f64) -> f64) {
    let text = std::fs::read_to_string(src).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let col = header.split(',').position(|c| c == name).unwrap();
    let mut out = format!("{header}\n");
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(str::to_string).collect();
        cells[col] = format!("{}", f(cells[col].parse::<f64>().unwrap()));
        out += &cells.join(",");
        out.push('\n');
    }
    std::fs::write(dst, out).unwrap();
}

/// A record written wrongly: its file, the column changed, the change, the hint expected.
type Case<'a> = (&'a str, &'a str, &'a dyn Fn(f64) -> f64, &'a str);

/// The `hints` of `identify FILE --json EXTRA`.
fn hints(dir: &Path, file: &Path, extra: &[&str]) -> Vec<String> {
    let report = dir.join("r.json");
    let mut args = vec!["identify", s(file), "-q", "--json", s(&report)];
    args.extend_from_slice(extra);
    run_ok(&args);
    json(&report)["hints"]
        .as_array()
        .expect("hints")
        .iter()
        .map(|h| h.as_str().unwrap().to_string())
        .collect()
}

#[test]
fn a_sign_or_a_unit_that_explains_the_misfit_is_named_and_a_good_record_gets_none() {
    let dir = tempfile::tempdir().unwrap();
    let sensors = Sensors {
        speed: SpeedSensor::Tacho,
        noise_omega: 0.2,
        noise_current: 0.02,
        seed: 3,
    };
    let r = run(
        MOTOR,
        Effects::default(),
        sensors,
        experiment(Shape::Steps, 24.0, 2000.0, 2.0),
    );
    let good = dir.path().join("good.csv");
    csv::write(&r, &good, true);
    assert_eq!(hints(dir.path(), &good, &[]), Vec::<String>::new());
    // A search box that leaves the motor (Ra 1 ohm) out: the fit stops at the bound.
    // (J, pulled with it, may reach its own.)
    let found = hints(dir.path(), &good, &["--bounds", "ra=2:10"]);
    assert!(found[0].starts_with("ra sits at its bound 2"), "{found:?}");
    assert!(
        found.iter().all(|h| h.contains("sits at its bound")),
        "{found:?}"
    );
    let rpm = 60.0 / std::f64::consts::TAU;
    let cases: [Case; 5] = [
        (
            "speed_inverted.csv",
            "omega",
            &|w| -w,
            "speed's sign is inverted",
        ),
        (
            "current_inverted.csv",
            "i",
            &|i| -i,
            "current's sign is inverted",
        ),
        ("rpm.csv", "omega", &|w| w * rpm, "speed is in rpm"),
        ("milliamps.csv", "i", &|i| i * 1000.0, "current is in mA"),
        (
            "constant_v.csv",
            "v",
            &|_| 12.0,
            "v column is 12 V throughout",
        ),
    ];
    for (file, column, f, expected) in cases {
        let path = dir.path().join(file);
        rewrite(&good, &path, column, f);
        let found = hints(dir.path(), &path, &[]);
        assert_eq!(found.len(), 1, "{file}: {found:?}");
        assert!(found[0].contains(expected), "{file}: {found:?}");
    }
}
