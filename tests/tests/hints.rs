//! `identify` names a cheap explanation of a large misfit when a refit confirms it (issue
//! 22): records of the independent reference plant written with an inverted sign, speed in
//! rpm, current in mA, or a voltage column that never changes; or made from a fast record
//! by keeping one row in K, where the voltage moved between the kept rows. A correct
//! record, and the fast record averaged with `--decimate K`, get no hint.

use motor_id_tests::reference_plant::SpeedSensor;
use motor_id_tests::reference_plant::{
    csv, experiment, run, Effects, Input, Motor, Sensors, Shape,
};
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

/// `src` with one data row in `k` kept (the first of each `k`), as a logger that samples
/// slowly, or a careless thinning of a fast record, makes it.
fn keep_one_in(src: &Path, dst: &Path, k: usize) {
    let text = std::fs::read_to_string(src).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for line in lines.step_by(k) {
        out += line;
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

/// The readings' noise of the records below.
const SENSORS: Sensors = Sensors {
    speed: SpeedSensor::Tacho,
    noise_omega: 0.2,
    noise_current: 0.02,
    seed: 3,
};

/// A bridge switched between 0 and 24 V at random, each level held 1 to 4 rows of 50 us: a
/// PRBS (or a PWM) far faster than the motor's 20 ms La/Ra, which filters it to its mean.
fn prbs(rate: f64, seconds: f64) -> Input {
    let n = (rate * seconds) as usize;
    let mut x: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        x
    };
    let mut v = Vec::with_capacity(n);
    while v.len() < n {
        let (hold, level) = (1 + next() % 4, [24.0, 0.0][(next() % 2) as usize]);
        v.extend((0..hold).map(|_| level));
    }
    v.truncate(n);
    Input {
        dt: 1.0 / rate,
        v,
        tl: None,
        open_from: None,
    }
}

/// `found` is one hint, holding each of `words`.
fn one_hint_saying(found: &[String], words: &[&str]) {
    assert_eq!(found.len(), 1, "{found:?}");
    for w in words {
        assert!(found[0].contains(w), "{w:?} not in {found:?}");
    }
}

#[test]
fn a_record_thinned_to_one_row_in_k_is_named_and_the_averaged_or_fast_record_gets_no_hint() {
    let dir = tempfile::tempdir().unwrap();
    // A switching input at 20 kHz, one row in 20 kept: the kept voltage (0 or 24 V) is not
    // what was applied over the 1 ms that follows it.
    let fast = dir.path().join("prbs_20kHz.csv");
    csv::write(
        &run(MOTOR, Effects::default(), SENSORS, prbs(20_000.0, 3.0)),
        &fast,
        true,
    );
    let kept = dir.path().join("prbs_kept.csv");
    keep_one_in(&fast, &kept, 20);
    one_hint_saying(
        &hints(dir.path(), &kept, &[]),
        &[
            "jumps by more than half its range (0 to 24 V)",
            "rougher than its sampling",
            "--decimate K, which averages",
        ],
    );
    // The same rows averaged by the reader, or all of them: the model fits, no hint.
    assert_eq!(
        hints(dir.path(), &fast, &["--decimate", "20"]),
        Vec::<String>::new()
    );
    assert_eq!(hints(dir.path(), &fast, &[]), Vec::<String>::new());

    // Voltage steps at 1 kHz, one row in 50 kept (20 Hz): the steps, at rows 2003 and
    // 4006, fall between kept rows, and La/Ra (20 ms) is shorter than the 50 ms step, so
    // the current's jump is seen a step early. (Before this hint: "la sits at its bound".)
    let steps = dir.path().join("steps_1kHz.csv");
    csv::write(
        &run(
            MOTOR,
            Effects::default(),
            SENSORS,
            experiment(Shape::Steps, 24.0, 1000.0, 6.01),
        ),
        &steps,
        true,
    );
    let kept = dir.path().join("steps_kept.csv");
    keep_one_in(&steps, &kept, 50);
    one_hint_saying(
        &hints(dir.path(), &kept, &[]),
        &[
            "just after the voltage changes",
            "shorter than the record's step of 50.000 ms",
            "record faster",
        ],
    );
    assert_eq!(hints(dir.path(), &steps, &[]), Vec::<String>::new());
    // Averaged instead, the new 50 ms step is still longer than La/Ra: averaging does not
    // help a motor faster than the step, the same hint holds.
    one_hint_saying(
        &hints(dir.path(), &steps, &["--decimate", "50"]),
        &["shorter than the record's step of 50.000 ms"],
    );
}
