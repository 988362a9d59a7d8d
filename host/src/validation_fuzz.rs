//! Fuzz target `report` (the harness is described in the `motor-id-fuzz` crate, the seeds
//! are in `fuzz/corpus/report/`: `ok-*` must load, `err-*` must be refused): the reader of
//! a JSON report's parameters and of what it did not pin, [`read_params_report`]
//! (`validate --params`, `tune --params`). It checks that on any bytes (random, the seeds
//! mutated) it never panics, and either gives parameters that [`ModelParams::validate`]
//! takes or an error of one line, as the CLI prints it.

use super::*;
use motor_id_fuzz::{check, corpus, mutated};
use proptest::prelude::*;
use proptest::test_runner::TestCaseResult;

/// Cases per property in the default run (each writes and reads a file).
const CASES: u32 = 512;

/// Read `bytes` as a report at `path`.
fn read_bytes(path: &Path, bytes: &[u8]) -> Result<ModelParams> {
    std::fs::write(path, bytes).expect("write the case");
    read_params_report(path).map(|r| r.params)
}

/// Loaded parameters are valid; a refusal is one line.
fn judge(result: &Result<ModelParams>) -> TestCaseResult {
    match result {
        Ok(p) => prop_assert!(p.validate().is_ok(), "{p:?}"),
        Err(e) => {
            let text = format!("{e:#}");
            prop_assert!(!text.trim().is_empty());
            prop_assert!(!text.contains(['\n', '\r']), "several lines: {text:?}");
        }
    }
    Ok(())
}

#[test]
fn replays_the_seed_corpus() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("seed.json");
    for seed in corpus("report") {
        let result = read_bytes(&path, &seed.bytes);
        match &result {
            Ok(_) => assert!(seed.name.starts_with("ok-"), "{}: loaded", seed.name),
            Err(e) => assert!(seed.name.starts_with("err-"), "{}: {e:#}", seed.name),
        }
        judge(&result).unwrap();
    }
    // What the seeds say was not pinned.
    let unpinned = |name: &str| {
        std::fs::write(
            &path,
            std::fs::read(motor_id_fuzz::corpus_dir("report").join(name)).unwrap(),
        )
        .unwrap();
        read_params_report(&path).unwrap().unpinned
    };
    assert_eq!(unpinned("ok-identify.json"), [ParamId::B]);
    assert_eq!(unpinned("ok-board.json"), [ParamId::Kv]);
    assert_eq!(unpinned("ok-diagnose.json"), []);
}

#[test]
fn any_bytes_give_valid_parameters_or_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("case.json");
    let seeds: Vec<Vec<u8>> = corpus("report").into_iter().map(|s| s.bytes).collect();
    let strategy = prop_oneof![
        proptest::collection::vec(any::<u8>(), 0..200),
        mutated(seeds, 8),
    ];
    check("report", CASES, &strategy, |bytes| {
        judge(&read_bytes(&path, &bytes))
    });
}
