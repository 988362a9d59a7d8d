//! Fuzz target `csv` (the harness is described in the `motor-id-fuzz` crate, the seeds are
//! in `fuzz/corpus/csv/`: `ok-*` must load, `err-*` must be refused): the record CSV reader,
//! [`OwnedRecord::read`]. It checks that
//!
//! - on any bytes (random, the seeds mutated, generated records mutated) it never panics,
//!   and either loads a record that holds what a record must (at least [`MIN_SAMPLES`]
//!   rows, columns of one length, finite samples within the magnitude limit, a positive
//!   step, a coast-down inside the record, some speed) and that writes back to the same
//!   samples, or gives an error of one line, as the CLI prints it;
//! - a generated record (any column order and header case, extra columns, CRLF, a
//!   coast-down, any finite samples within the limit) loads to exactly its samples.

use super::rows::MAX_MAGNITUDE;
use super::*;
use motor_id_fuzz::{check, corpus, mutated};
use motor_id_shared::model::record::MIN_SAMPLES;
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::test_runner::TestCaseResult;

/// Cases per property in the default run (each writes and reads a file or two).
const CASES: u32 = 256;

/// Read `bytes` as a record CSV at `path`.
fn read_bytes(path: &Path, bytes: &[u8]) -> Result<OwnedRecord> {
    std::fs::write(path, bytes).expect("write the case");
    OwnedRecord::read(path)
}

/// An error as the CLI prints it (anyhow's context chain on one line) must be one line.
fn one_line(e: &anyhow::Error) -> Result<String, TestCaseError> {
    let text = format!("{e:#}");
    prop_assert!(!text.trim().is_empty(), "empty error");
    prop_assert!(
        !text.contains(['\n', '\r']),
        "error of several lines: {text:?}"
    );
    Ok(text)
}

/// What every loaded record holds, and that it writes back to the same samples.
fn check_loaded(rec: &OwnedRecord, dir: &Path) -> TestCaseResult {
    let n = rec.len();
    prop_assert!(n >= MIN_SAMPLES);
    prop_assert!(rec.dt.is_finite() && rec.dt > 0.0, "dt {}", rec.dt);
    let columns = [
        Some(&rec.v),
        Some(&rec.omega),
        rec.current.as_ref(),
        rec.load.as_ref(),
    ];
    for c in columns.into_iter().flatten() {
        prop_assert_eq!(c.len(), n);
        let within = |x: &f32| x.is_finite() && f64::from(x.abs()) <= MAX_MAGNITUDE;
        prop_assert!(c.iter().all(within), "{c:?}");
    }
    prop_assert!(rec.omega.iter().any(|w| *w != 0.0));
    prop_assert!(rec.coast_from.is_none_or(|c| c > 0 && c < n));
    prop_assert!(rec.as_record(true).validate().is_ok());
    let again = dir.join("again.csv");
    rec.write(&again).expect("a loaded record writes");
    let back = OwnedRecord::read(&again).expect("a written record loads");
    let same = OwnedRecord {
        dt: rec.dt,
        ..back.clone()
    };
    prop_assert!(same.same_data(rec), "written and read back: {back:?}");
    prop_assert!(((back.dt - rec.dt) / rec.dt).abs() < 1e-6);
    Ok(())
}

fn seeds() -> Vec<motor_id_fuzz::Seed> {
    corpus("csv")
}

#[test]
fn replays_the_seed_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("seed.csv");
    for seed in seeds() {
        match read_bytes(&path, &seed.bytes) {
            Ok(rec) => {
                assert!(seed.name.starts_with("ok-"), "{}: loaded", seed.name);
                check_loaded(&rec, dir.path()).unwrap();
            }
            Err(e) => {
                assert!(seed.name.starts_with("err-"), "{}: {e:#}", seed.name);
                one_line(&e).unwrap();
            }
        }
    }
}

/// A record to write as CSV.
#[derive(Clone, Debug)]
struct Generated {
    dt: f64,
    t0: f64,
    v: Vec<f32>,
    omega: Vec<f32>,
    current: Option<Vec<f32>>,
    load: Option<Vec<f32>>,
    /// First open-circuit row, when there is a `bridge` column.
    bridge: Option<Option<usize>>,
    /// Column order: indices into `t, v, omega, i, tl, bridge, note`.
    order: Vec<usize>,
    upper_case: bool,
    crlf: bool,
}

impl Generated {
    fn text(&self) -> String {
        let names = ["t", "v", "omega", "i", "tl", "bridge", "note"];
        let present = |c: usize| match c {
            3 => self.current.is_some(),
            4 => self.load.is_some(),
            5 => self.bridge.is_some(),
            _ => true,
        };
        let columns: Vec<usize> = self.order.iter().copied().filter(|c| present(*c)).collect();
        let eol = if self.crlf { "\r\n" } else { "\n" };
        let header: Vec<String> = columns
            .iter()
            .map(|c| match self.upper_case {
                true => format!(" {} ", names[*c].to_uppercase()),
                false => names[*c].to_string(),
            })
            .collect();
        let mut text = header.join(",") + eol;
        for k in 0..self.v.len() {
            let field = |c: usize| match c {
                0 => (self.t0 + k as f64 * self.dt).to_string(),
                1 => self.v[k].to_string(),
                2 => self.omega[k].to_string(),
                3 => self.current.as_ref().unwrap()[k].to_string(),
                4 => self.load.as_ref().unwrap()[k].to_string(),
                5 => match self.bridge.unwrap() {
                    Some(open) if k >= open => "0".into(),
                    _ => "1".into(),
                },
                _ => "x".into(),
            };
            let row: Vec<String> = columns.iter().map(|c| field(*c)).collect();
            text += &(row.join(",") + eol);
        }
        text
    }
}

/// A finite sample within the reader's magnitude limit: any such f32, or a plain one.
fn sample() -> impl Strategy<Value = f32> {
    let limit = MAX_MAGNITUDE as f32;
    prop_oneof![
        any::<f32>().prop_filter("finite, within the limit", move |x| x.is_finite()
            && x.abs() <= limit),
        -100.0f32..100.0,
        Just(0.0f32),
    ]
}

fn generated() -> impl Strategy<Value = Generated> {
    let dt = prop_oneof![
        proptest::sample::select(vec![1e-4, 1e-3, 2e-3, 0.01, 0.25]),
        1e-6f64..10.0
    ];
    let t0 = prop_oneof![Just(0.0f64), -10.0f64..1e4];
    (MIN_SAMPLES..40, dt, t0).prop_flat_map(|(n, dt, t0)| {
        let column = move || vec(sample(), n);
        (
            column(),
            column(),
            proptest::option::of(column()),
            proptest::option::of(column()),
            proptest::option::of(proptest::option::of(1..n)),
            Just((0..7).collect::<Vec<usize>>()).prop_shuffle(),
            any::<(bool, bool)>(),
        )
            .prop_map(
                move |(v, omega, current, load, bridge, order, (upper_case, crlf))| Generated {
                    dt,
                    t0,
                    v,
                    omega,
                    current,
                    load,
                    bridge,
                    order,
                    upper_case,
                    crlf,
                },
            )
    })
}

#[test]
fn any_bytes_load_a_valid_record_or_fail_on_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("case.csv");
    let all: Vec<Vec<u8>> = seeds().into_iter().map(|s| s.bytes).collect();
    let input = prop_oneof![
        vec(any::<u8>(), 0..512),
        mutated(all, 8),
        generated().prop_flat_map(|g| mutated(vec![g.text().into_bytes()], 4)),
    ];
    check("csv", CASES, &input, |bytes| {
        match read_bytes(&path, &bytes) {
            Ok(rec) => check_loaded(&rec, dir.path())?,
            Err(e) => drop(one_line(&e)?),
        }
        Ok(())
    });
}

#[test]
fn a_generated_record_loads_to_its_samples() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("case.csv");
    check("csv", CASES, &generated(), |g| {
        let got = read_bytes(&path, g.text().as_bytes());
        if g.omega.iter().all(|w| *w == 0.0) {
            let e = got.expect_err("zero speed is refused");
            prop_assert!(one_line(&e)?.contains("omega is zero throughout"));
            return Ok(());
        }
        let rec = got.map_err(|e| TestCaseError::fail(format!("{e:#}")))?;
        prop_assert_eq!(&rec.v, &g.v);
        prop_assert_eq!(&rec.omega, &g.omega);
        prop_assert_eq!(&rec.current, &g.current);
        prop_assert_eq!(&rec.load, &g.load);
        prop_assert_eq!(rec.coast_from, g.bridge.flatten());
        prop_assert!(
            (f64::from(rec.dt) / g.dt - 1.0).abs() < 1e-6,
            "dt {}",
            rec.dt
        );
        check_loaded(&rec, dir.path())
    });
}
