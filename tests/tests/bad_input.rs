//! Bad input: one clear line on stderr and exit status 1, or clap's usage error and exit
//! status 2 for a malformed option value; never a panic.

use motor_id_tests::{run_err, run_usage_err, s};
use std::path::PathBuf;

fn file(dir: &tempfile::TempDir, name: &str, text: &str) -> PathBuf {
    let p = dir.path().join(name);
    std::fs::write(&p, text).unwrap();
    p
}

fn rows(n: usize, f: impl Fn(usize) -> String) -> String {
    let mut t = String::from("t,v,omega\n");
    for k in 0..n {
        t += &f(k);
        t.push('\n');
    }
    t
}

#[test]
fn broken_records_are_refused_with_one_line() {
    let d = tempfile::tempdir().unwrap();
    let good = |k: usize| format!("{},{},{}", k as f64 * 0.01, 10.0, k as f64);
    let cases: Vec<(&str, String, &str)> = vec![
        ("empty.csv", String::new(), "empty"),
        ("header.csv", "t,v,omega\n".into(), "no data rows"),
        (
            "missing.csv",
            "t,v,speed\n0,1,2\n".into(),
            "missing column(s) omega",
        ),
        (
            "nan.csv",
            rows(20, |k| {
                if k == 5 {
                    "0.05,10,NaN".into()
                } else {
                    good(k)
                }
            }),
            "not finite",
        ),
        (
            "text.csv",
            rows(20, |k| if k == 7 { "0.07,ten,7".into() } else { good(k) }),
            "not a number",
        ),
        (
            "nonuniform.csv",
            rows(20, |k| format!("{},{},{}", (k * k) as f64 * 0.01, 10, k)),
            "not uniform",
        ),
        (
            "decreasing.csv",
            rows(20, |k| format!("{},{},{}", 1.0 - k as f64 * 0.01, 10, k)),
            "not increasing",
        ),
        ("short.csv", rows(3, good), "only 3 data rows"),
        ("ragged.csv", "t,v,omega\n0,1,2\n0.01,1\n".into(), "fields"),
        (
            "twice.csv",
            format!(
                "t,v,omega,omega\n{}",
                &rows(20, |k| format!("{},1", good(k)))[10..]
            ),
            "column omega appears more than once",
        ),
        (
            "semicolons.csv",
            rows(20, good).replace(',', ";"),
            "separate fields with ';'",
        ),
        (
            "tabs.csv",
            rows(20, good).replace(',', "\t"),
            "separate fields with tabs",
        ),
        (
            "huge.csv",
            rows(20, |k| {
                if k == 4 {
                    "0.04,1e30,4".into()
                } else {
                    good(k)
                }
            }),
            "line 6: v = '1e30' is beyond",
        ),
        (
            "bridge2.csv",
            rows(20, |k| {
                format!("{},{}", good(k), if k == 3 { 2 } else { 1 })
            })
            .replacen("omega", "omega,bridge", 1),
            "bridge = 2: 1 (driven) or 0 (open circuit)",
        ),
        (
            "reclosed.csv",
            rows(20, |k| {
                format!("{},{}", good(k), u8::from(!(10..15).contains(&k)))
            })
            .replacen("omega", "omega,bridge", 1),
            "bridge is 1 again after the open circuit",
        ),
        (
            "openfirst.csv",
            rows(20, |k| format!("{},0", good(k))).replacen("omega", "omega,bridge", 1),
            "bridge is 0 from the first row",
        ),
        (
            "still.csv",
            rows(20, |k| format!("{},{},0", k as f64 * 0.01, 10.0)),
            "omega is zero throughout",
        ),
    ];
    for (name, text, expect) in cases {
        let p = file(&d, name, &text);
        let err = run_err(&["identify", s(&p), "-q"]);
        assert!(
            err.contains(expect),
            "{name}: expected '{expect}' in: {err}"
        );
        assert!(
            err.contains(name),
            "{name}: message should name the file: {err}"
        );
    }
    let err = run_err(&["identify", "/nonexistent/rec.csv"]);
    assert!(err.contains("cannot open"), "{err}");
}

#[test]
fn bad_options_are_refused_with_one_line() {
    let d = tempfile::tempdir().unwrap();
    let p = file(
        &d,
        "ok.csv",
        &rows(50, |k| format!("{},{},{}", k as f64 * 0.01, 10, k)),
    );
    let ok = s(&p);
    for (args, expect) in [
        (
            vec!["identify", ok, "--fix", "ra=1,la=1,j=1,b=1,kv=1"],
            "nothing to identify",
        ),
        (vec!["simulate", "--rate", "0", "--out", "x.csv"], "--rate"),
        (
            vec!["identify", ok, "--fix", "ra=3", "--bounds", "ra=1:2"],
            "fix it or bound it, not both",
        ),
        (
            vec!["identify", ok, "--fix", "ra=3,ra=4"],
            "ra is fixed twice",
        ),
        (
            vec!["identify", ok, "--bounds", "ra=1:2", "--bounds", "ra=1:3"],
            "ra is bounded twice",
        ),
        (
            vec!["diagnose", "--train", ok, "--holdout", ok],
            "is the training record",
        ),
        // The paper's FFO cannot stop before 301 evaluations: a budget below that was
        // overspent 30 times over.
        (
            vec!["compare", ok, "--budget", "10"],
            "below one iteration of the paper's FFO (301 evaluations",
        ),
    ] {
        let err = run_err(&args);
        assert!(
            err.contains(expect),
            "{args:?}: expected '{expect}' in: {err}"
        );
    }
}

#[test]
fn malformed_option_values_are_usage_errors_that_name_the_option() {
    let d = tempfile::tempdir().unwrap();
    let p = file(
        &d,
        "ok.csv",
        &rows(50, |k| format!("{},{},{}", k as f64 * 0.01, 10, k)),
    );
    let ok = s(&p);
    let out = d.path().join("x.csv");
    let out = s(&out);
    // A value from a fixed set: clap lists the possible values.
    for (args, expect) in [
        (
            vec!["simulate", "--profile", "warp", "--out", out],
            "[possible values: start, steps, load, reversal]",
        ),
        (
            vec!["identify", ok, "--pipeline", "fast"],
            "[possible values: default, board, paper]",
        ),
        (
            vec![
                "board",
                "--port",
                "/nonexistent",
                "identify",
                ok,
                "--pipeline",
                "x",
            ],
            "[possible values: default, board, paper]",
        ),
        (
            vec![
                "diagnose",
                "--train",
                ok,
                "--holdout",
                ok,
                "--without",
                "coulomb_friction,warp",
            ],
            "[possible values: coulomb_friction, quadratic_load,",
        ),
    ] {
        let err = run_usage_err(&args);
        assert!(
            err.contains(expect),
            "{args:?}: expected '{expect}' in: {err}"
        );
    }
    // A malformed spec: clap's error names the option and says what is wrong.
    for (args, expect) in [
        (
            vec!["identify", ok, "--bounds", "ra=5:1"],
            "'--bounds <P=LO:HI,...>': ra has lo 5 >= hi 1",
        ),
        (vec!["identify", ok, "--bounds", "ra=1:1"], ">= hi"),
        (
            vec!["identify", ok, "--bounds", "xyz=1:2"],
            "unknown parameter 'xyz'",
        ),
        (vec!["identify", ok, "--bounds", "ra=1"], "ra needs LO:HI"),
        (vec!["identify", ok, "--bounds", "ra=-1:2"], "bound of ra"),
        (
            vec!["identify", ok, "--bounds", "kv=1e-20:1e20"],
            "more than 12 decades",
        ),
        (
            vec!["diagnose", "--train", ok, "--holdout", ok, "--fix", "foo=1"],
            "'--fix <P=V,...>': unknown parameter 'foo'",
        ),
        (
            vec!["compare", ok, "--fix", "ra=abc"],
            "ra: 'abc' is not a number",
        ),
        (
            vec!["identify", ok, "--fix", "ra=-1"],
            "fixed value of ra is out of range",
        ),
        (
            vec!["simulate", "--motor", "ra=1,la=1", "--out", out],
            "'--motor <ra=..,la=..,j=..,b=..,kv=..>': missing j",
        ),
        (
            vec![
                "simulate",
                "--motor",
                "ra=1,la=1,j=1,b=1,tc=1",
                "--out",
                out,
            ],
            "'tc' is an effect parameter",
        ),
        (
            vec!["simulate", "--effect", "bogus:x=1", "--out", out],
            "unknown effect 'bogus' (known: coulomb_friction,",
        ),
        (
            vec!["simulate", "--effect", "sensor_delay:amp=1", "--out", out],
            "sensor_delay: unknown key 'amp'",
        ),
        (
            vec![
                "simulate",
                "--effect",
                "coulomb_friction:tc=-1",
                "--out",
                out,
            ],
            "tc = -1 is outside",
        ),
    ] {
        let err = run_usage_err(&args);
        assert!(
            err.contains(expect),
            "{args:?}: expected '{expect}' in: {err}"
        );
    }
    assert!(!std::path::Path::new(out).exists());
}

#[test]
fn board_timeouts_out_of_range_are_refused_with_one_line_before_any_port_is_opened() {
    // 1e19, 1e300 and 2e18 s once overflowed the host's clock (a panic); the port does not
    // exist, so a refusal that names the timeout was made before opening it. A value out of
    // range is malformed input: a usage error, status 2 (docs/CONTRACTS.md).
    for t in [
        "1e19", "1e300", "2e18", "86401", "0", "-1", "NaN", "inf", "ten",
    ] {
        let timeout = format!("--timeout={t}");
        let err = run_usage_err(&["board", "--port", "/nonexistent/port", &timeout, "hello"]);
        assert!(
            err.contains("--timeout") && err.contains("at most 86400"),
            "{t}: {err}"
        );
    }
}

#[test]
fn an_output_into_a_missing_directory_is_one_line_and_nothing_is_left_behind() {
    let d = tempfile::tempdir().unwrap();
    let rec = d.path().join("rec.csv");
    motor_id_tests::simulate(&rec, &["--profile", "start", "--duration", "2"]);
    let missing = d.path().join("no").join("such");
    for (flag, name) in [("--plot", "fit.png"), ("--json", "fit.json")] {
        let out = missing.join(name);
        let err = run_err(&["identify", s(&rec), flag, s(&out), "-q"]);
        assert!(
            err.contains(&format!("cannot write {}", out.display())),
            "{err}"
        );
    }
    let err = run_err(&["simulate", "--out", s(&missing.join("r.csv"))]);
    assert!(err.contains("cannot write"), "{err}");
    assert!(!missing.exists());
}

/// A record beyond the memory bound is refused in one line that names the file and the
/// `--decimate` that fits it, over every record of the command; a decimation that leaves
/// too few samples is refused too, and both options refuse nonsense before any file is read.
#[test]
fn a_record_beyond_the_memory_bound_is_refused_with_the_decimation_that_fits() {
    let d = tempfile::tempdir().unwrap();
    let p = file(
        &d,
        "long.csv",
        &rows(50, |k| format!("{},{},{}", k as f64 * 0.01, 10, k)),
    );
    let long = s(&p);
    let q = file(
        &d,
        "other.csv",
        &rows(50, |k| format!("{},{},{}", k as f64 * 0.01, 10, 2 * k)),
    );
    let other = s(&q);
    for (args, expect) in [
        (
            vec!["identify", long, "--max-samples", "20", "-q"],
            "long.csv: 50 rows, more than --max-samples 20 (8 bytes a sample, 0.00016 MB); keep one sample in 3 rows with --decimate 3, or raise --max-samples",
        ),
        (
            vec!["identify", long, long, "--max-samples", "80", "-q"],
            "long.csv: 50 rows, more than the 30 samples left of --max-samples 80 by the records before it",
        ),
        (
            vec!["diagnose", "--train", long, "--holdout", other, "--max-samples", "80"],
            "other.csv: 50 rows, more than the 30 samples left of --max-samples 80",
        ),
        (
            vec!["identify", long, "--decimate", "8", "-q"],
            "long.csv: only 6 samples of 50 rows with --decimate 8 (need at least 8)",
        ),
    ] {
        let err = run_err(&args);
        assert!(err.contains(expect), "{args:?}: expected '{expect}' in: {err}");
    }
    for args in [
        vec!["identify", long, "--max-samples", "7"],
        vec!["identify", long, "--decimate", "0"],
        vec![
            "diagnose",
            "--train",
            long,
            "--holdout",
            long,
            "--decimate",
            "x",
        ],
    ] {
        let err = run_usage_err(&args);
        assert!(err.contains("invalid value"), "{args:?}: {err}");
    }
}

#[test]
fn a_scope_step_outside_the_trace_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let scope = file(
        &d,
        "scope.csv",
        &(0..50)
            .map(|k| format!("{},{}\n", k as f64 * 0.01, (k as f64 * 0.1).min(2.0)))
            .collect::<String>(),
    );
    let out = d.path().join("rec.csv");
    for (at, expect) in [
        ("5", "after the trace's end"),
        ("-1", "before the trace's start"),
    ] {
        let step = format!("--step-at={at}");
        let err = run_err(&[
            "import-scope",
            s(&scope),
            "--tacho-gain",
            "35",
            "--voltage",
            "12",
            &step,
            "--out",
            s(&out),
        ]);
        assert!(err.contains(expect), "{at}: {err}");
    }
    assert!(!out.exists());
}

#[test]
fn diagnose_warns_of_a_held_out_record_of_another_motor() {
    // Trained on the paper's motor, held out on a motor with three times its Kv: the baseline
    // predicts the held-out record hundreds of times its noise, the training records to it.
    let d = tempfile::tempdir().unwrap();
    let (train, other) = (d.path().join("train.csv"), d.path().join("other.csv"));
    let common = ["--profile", "steps", "--rate", "100", "--duration", "20"];
    let common = [&common[..], &["--speed-only", "--noise-omega", "0.2"]].concat();
    motor_id_tests::simulate(&train, &[&common[..], &["--seed", "1"]].concat());
    let motor = ["--motor", "ra=3.412,la=0.0573,j=0.0424,b=0.00267,kv=0.48"];
    motor_id_tests::simulate(
        &other,
        &[&common[..], &motor[..], &["--seed", "2"]].concat(),
    );
    let json = d.path().join("d.json");
    let out = motor_id_tests::run(&[
        "diagnose",
        "--train",
        s(&train),
        "--holdout",
        s(&other),
        "--json",
        s(&json),
        "-q",
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("other.csv is predicted to") && stderr.contains("same motor"),
        "{stderr}"
    );
    let report = motor_id_tests::json(&json);
    assert_eq!(
        report["warnings"].as_array().map(Vec::len),
        Some(1),
        "{report}"
    );
    // A held-out record of the same motor draws no warning.
    let same = d.path().join("same.csv");
    motor_id_tests::simulate(&same, &[&common[..], &["--seed", "3"]].concat());
    let out = motor_id_tests::run(&[
        "diagnose",
        "--train",
        s(&train),
        "--holdout",
        s(&same),
        "-q",
    ]);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("warning"));
}

/// An output that is an input (directly or through a link) is refused before the work and
/// the input is left as it was; a plot that is not `*.png` is refused before the fit; the
/// same for `import-scope --out` onto its own input.
#[test]
fn an_output_onto_an_input_is_refused_and_the_input_kept() {
    let d = tempfile::tempdir().unwrap();
    let rec = d.path().join("rec.csv");
    motor_id_tests::simulate(&rec, &["--profile", "start", "--duration", "2"]);
    let before = std::fs::read(&rec).unwrap();
    let link = d.path().join("alias.json");
    std::os::unix::fs::symlink(&rec, &link).unwrap();
    for out in [&rec, &link] {
        let err = run_err(&["identify", s(&rec), "--json", s(out), "-q"]);
        assert!(err.contains("refusing to write"), "{err}");
    }
    let err = run_err(&[
        "identify",
        s(&rec),
        "--plot",
        s(&d.path().join("fit.svg")),
        "-q",
    ]);
    assert!(err.contains("*.png"), "{err}");
    let scope = file(&d, "scope.csv", "t,ch1\n0,1\n0.001,1\n");
    let err = run_err(&[
        "import-scope",
        s(&scope),
        "--out",
        s(&scope),
        "--tacho-gain",
        "0.1",
        "--voltage",
        "10",
    ]);
    assert!(err.contains("refusing to write"), "{err}");
    assert_eq!(std::fs::read(&rec).unwrap(), before);
}

/// `tune`'s options at hostile values: a usage error (status 2) or one line (status 1),
/// never a panic or an allocation without bound.
#[test]
fn tune_refuses_hostile_options_without_a_panic() {
    let d = tempfile::tempdir().unwrap();
    let params = file(
        &d,
        "p.json",
        r#"{"params": {"ra": 3.412, "la": 0.0573, "j": 0.0424, "b": 0.00267, "kv": 0.1604}}"#,
    );
    for bad in [
        ["--phase-margin", "89.9999999"],
        ["--current-bandwidth", "1e-9"],
        ["--current-bandwidth", "1e-300"],
        ["--rate", "4294967297"],
        ["--rate", "nan"],
        ["--voltage", "-1"],
    ] {
        let err = run_usage_err(&["tune", "--params", s(&params), bad[0], bad[1]]);
        assert!(err.contains(bad[0]), "{bad:?}: {err}");
    }
    let err = run_err(&[
        "tune",
        "--params",
        s(&params),
        "--current-bandwidth",
        "0.01",
    ]);
    assert!(err.contains("samples"), "{err}");
}

/// The same record given twice (the same file, or a copy) is refused in one line: fitted
/// twice, its uncertainties would shrink by a factor of 1.41 without a word.
#[test]
fn a_record_given_twice_is_refused() {
    let d = tempfile::tempdir().unwrap();
    let rec = d.path().join("rec.csv");
    motor_id_tests::simulate(&rec, &["--profile", "start", "--duration", "2"]);
    let copy = d.path().join("copy.csv");
    std::fs::copy(&rec, &copy).unwrap();
    for second in [&rec, &copy] {
        let err = run_err(&["identify", s(&rec), s(second), "-q"]);
        assert!(err.contains("holds the same samples as"), "{err}");
    }
}

/// A file that is not a record (megabytes without a line break, `/dev/zero`) is refused at
/// its first long line in one short line, without reading it whole: before, a 1 GB file of
/// zeros took 15.7 GB of memory and an error message of gigabytes, and `/dev/zero` never
/// ended.
#[test]
fn a_file_without_line_breaks_is_refused_at_once_in_a_short_line() {
    let d = tempfile::tempdir().unwrap();
    let zeros = d.path().join("zeros.csv");
    std::fs::write(&zeros, vec![0u8; 4 << 20]).unwrap();
    for path in [zeros.as_path(), std::path::Path::new("/dev/zero")] {
        let err = run_err(&["identify", s(path), "-q"]);
        assert!(
            err.contains("line 1 is longer than"),
            "{}",
            &err[..err.len().min(300)]
        );
        assert!(err.len() < 300, "{} bytes of error", err.len());
    }
    // A header of binary junk is quoted, cut to 80 characters.
    let junk = file(&d, "junk.csv", &"\u{1}".repeat(5000));
    let err = run_err(&["identify", s(&junk), "-q"]);
    assert!(
        err.contains("missing column") && err.len() < 800,
        "{} bytes",
        err.len()
    );
}

/// `simulate` refuses an effect given twice (the last silently won) and a record its own
/// reader would refuse (values beyond 1e9), writing nothing.
#[test]
fn simulate_refuses_a_repeated_effect_and_values_the_reader_refuses() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("r.csv");
    let err = run_err(&[
        "simulate",
        "--effect",
        "coulomb_friction:tc=0.1",
        "--effect",
        "coulomb_friction:tc=0.2",
        "--out",
        s(&out),
    ]);
    assert!(err.contains("given twice"), "{err}");
    let err = run_err(&[
        "simulate",
        "--voltage",
        "1e10",
        "--duration",
        "1",
        "--out",
        s(&out),
    ]);
    assert!(err.contains("which the record reader refuses"), "{err}");
    assert!(!out.exists());
    assert_eq!(
        std::fs::read_dir(d.path()).unwrap().count(),
        0,
        "a file was left"
    );
}
