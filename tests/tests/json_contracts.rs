//! Every key a command writes in its JSON report is documented in docs/CONTRACTS.md, in
//! that report's section, and every field a section's table documents is written (one home
//! per contract: the docs cannot drift from the code either way without this test
//! failing). Keys that are parameter names (`ra`, `tc`, ...) are
//! documented once, in the parameter table.

use motor_id_tests::{json, run, run_ok, s, simulate};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::Path;

/// docs/CONTRACTS.md.
fn contracts() -> String {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/CONTRACTS.md");
    std::fs::read_to_string(path).expect("docs/CONTRACTS.md")
}

/// The words (identifier characters) of the section whose heading starts with `heading`, up
/// to the next `## `; the whole file when `heading` is empty.
fn words_of(text: &str, heading: &str) -> BTreeSet<String> {
    let section = match heading {
        "" => text,
        _ => {
            let start = text
                .find(heading)
                .unwrap_or_else(|| panic!("no section {heading}"));
            let rest = &text[start + heading.len()..];
            &rest[..rest.find("\n## ").unwrap_or(rest.len())]
        }
    };
    section
        .split(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
        .filter(|w| !w.is_empty())
        .map(str::to_string)
        .collect()
}

/// Every key of `v`, at any depth, except those that are parameter names.
fn keys(v: &Value, out: &mut BTreeSet<String>) {
    match v {
        Value::Object(map) => {
            for (k, child) in map {
                if motor_id_shared::ParamId::from_name(k).is_none() {
                    out.insert(k.clone());
                }
                keys(child, out);
            }
        }
        Value::Array(items) => items.iter().for_each(|i| keys(i, out)),
        _ => {}
    }
}

/// The keys of `v` that the CONTRACTS section starting with `heading` does not name.
fn undocumented(v: &Value, heading: &str) -> Vec<String> {
    let mut written = BTreeSet::new();
    keys(v, &mut written);
    let documented = words_of(&contracts(), heading);
    written.difference(&documented).cloned().collect()
}

fn assert_documented(report: &Path, heading: &str) {
    let v = json(report);
    if !heading.is_empty() {
        // The reverse: every field the section documents is written (no stale rows).
        let mut written = BTreeSet::new();
        keys(&v, &mut written);
        let stale: Vec<String> = documented_keys(heading)
            .difference(&written)
            .cloned()
            .collect();
        assert!(
            stale.is_empty(),
            "CONTRACTS' section {heading:?} documents fields {} does not write: {stale:?}",
            report.display()
        );
    }
    assert!(
        v.as_object().is_some_and(|m| !m.is_empty()),
        "{}: no keys",
        report.display()
    );
    let missing = undocumented(&v, heading);
    assert!(
        missing.is_empty(),
        "keys of {} not in CONTRACTS' section {heading:?}: {missing:?}",
        report.display()
    );
}

#[test]
fn every_key_of_every_json_report_is_documented() {
    let d = tempfile::tempdir().unwrap();
    let rec = d.path().join("rec.csv");
    simulate(
        &rec,
        &["--profile", "steps", "--rate", "200", "--duration", "10"],
    );
    let identify = d.path().join("identify.json");
    run_ok(&["identify", s(&rec), "--json", s(&identify), "-q"]);
    assert_documented(&identify, "## `identify` JSON");
    let validate = d.path().join("validate.json");
    let status = run(&[
        "validate",
        "--params",
        s(&identify),
        s(&rec),
        "--json",
        s(&validate),
    ]);
    assert!(status.status.code().is_some_and(|c| c == 0 || c == 3));
    assert_documented(&validate, "## `validate` JSON");
    let tune = d.path().join("tune.json");
    run_ok(&["tune", "--params", s(&identify), "--json", s(&tune)]);
    assert_documented(&tune, "## `tune` JSON");
    let holdout = d.path().join("holdout.csv");
    let friction = [
        "--effect",
        "coulomb_friction:tc=0.02",
        "--rate",
        "200",
        "--duration",
        "10",
    ];
    simulate(
        &holdout,
        &[&["--profile", "reversal", "--seed", "2"], &friction[..]].concat(),
    );
    let train = d.path().join("train.csv");
    simulate(&train, &[&["--profile", "steps"], &friction[..]].concat());
    let diagnose = d.path().join("diagnose.json");
    let args = ["diagnose", "--train", s(&train), "--holdout", s(&holdout)];
    run_ok(&[&args[..], &["--json", s(&diagnose), "-q"]].concat());
    assert_documented(&diagnose, "## `diagnose` JSON");
    let commission = d.path().join("commission.json");
    run_ok(&[
        "commission",
        "--sim",
        "--rate",
        "5000",
        "--json",
        s(&commission),
        "-q",
    ]);
    // Its keys are spread over the command table (its own), the `board` JSON (`motor`) and
    // the `Plan` message (`plan`).
    assert_documented(&commission, "");
}

/// The check itself: a key absent from the docs is found, a parameter name is not asked for.
#[test]
fn an_undocumented_key_is_caught() {
    let v: Value = serde_json::json!({"rmse_omega": 1, "zz_not_a_key": {"ra": 1}});
    assert_eq!(undocumented(&v, "## `identify` JSON"), ["zz_not_a_key"]);
}

/// The keys a CONTRACTS section documents: the first cell of each row of its `| field |`
/// tables, as `` `a.b.c` ``, by its last segment (tables of values, such as the regimes,
/// are not keys).
fn documented_keys(heading: &str) -> BTreeSet<String> {
    let text = contracts();
    let start = text
        .find(heading)
        .unwrap_or_else(|| panic!("no section {heading}"));
    let rest = &text[start + heading.len()..];
    let section = &rest[..rest.find("\n## ").unwrap_or(rest.len())];
    let mut out = BTreeSet::new();
    let mut in_fields = false;
    let mut previous_was_table = false;
    for line in section.lines() {
        let is_table = line.starts_with('|');
        if is_table && !previous_was_table {
            in_fields = line.starts_with("| field |");
        }
        previous_was_table = is_table;
        let Some(cell) = line.strip_prefix("| `").filter(|_| in_fields) else {
            continue;
        };
        let Some(end) = cell.find('`') else { continue };
        if let Some(last) = cell[..end].rsplit('.').next() {
            out.insert(last.to_string());
        }
    }
    out
}

/// The reverse check itself: a documented field the report lacks is found.
#[test]
fn a_documented_field_no_report_writes_is_caught() {
    let fields = documented_keys("## `identify` JSON");
    assert!(
        fields.contains("rmse_omega") && fields.contains("hints"),
        "{fields:?}"
    );
    assert!(!fields.contains("high_speed"));
}
