//! Fuzz target `spec` (the harness is described in the `motor-id-fuzz` crate, the seeds are
//! in `fuzz/corpus/spec/`, one valid spec a line, a file per parser): the parsers of
//! `--motor`, `--effect`, `--bounds` and `--fix`, and [`problem`], which applies the last
//! two. It checks that
//!
//! - on any string (random text, text of the specs' own alphabet, the seeds mutated) no
//!   parser panics, each refusal is a message of one line, and what is accepted is valid:
//!   a motor that [`ModelParams::validate`] takes, effect values and fixed values within
//!   their physical ranges, bounds that the problem takes, and [`problem`] of any accepted
//!   bounds and fixes answers without a panic;
//! - a generated valid spec (any values within the ranges, shortest or exponent notation,
//!   blanks around every item, a key or a name for an effect's parameter) parses to
//!   exactly its values, and [`problem`] applies them.

use super::*;
use motor_id_fuzz::{check, corpus, mutated};
use proptest::prelude::*;
use proptest::sample::{select, subsequence};
use proptest::test_runner::{TestCaseError, TestCaseResult};

/// Cases per property in the default run.
const CASES: u32 = 1000;

/// A refusal must be a non-empty message of one line (when the input is one line).
fn one_line(input: &str, e: &str) -> TestCaseResult {
    prop_assert!(!e.trim().is_empty(), "empty error for {input:?}");
    if !input.contains(['\n', '\r']) {
        prop_assert!(!e.contains(['\n', '\r']), "error of several lines: {e:?}");
    }
    Ok(())
}

/// Every parser on `text`: no panic, one-line refusals, valid acceptances.
fn parse_any(text: &str) -> TestCaseResult {
    match parse_motor(text) {
        Ok(p) => prop_assert!(p.validate().is_ok(), "{text:?} gave {p:?}"),
        Err(e) => one_line(text, &e)?,
    }
    match parse_effect(text) {
        Ok(spec) => {
            for &(id, x) in &spec.values {
                let (lo, hi) = id.physical_range();
                prop_assert!(x.is_finite() && lo <= x && x <= hi, "{text:?}: {id:?} {x}");
            }
            let mut p = ModelParams::PAPER_MOTOR;
            if let Err(e) = spec.apply(&mut p) {
                one_line(text, &format!("{e:#}"))?;
            }
        }
        Err(e) => one_line(text, &e)?,
    }
    let bounds = parse_bounds(text);
    match &bounds {
        Ok(b) => {
            for &(id, lo, hi) in &b.0 {
                let taken = ProblemSpec::default().set_bounds(id, lo, hi);
                prop_assert!(taken.is_ok(), "{text:?}: {id:?} {lo}:{hi}");
            }
        }
        Err(e) => one_line(text, e)?,
    }
    let fix = parse_fix(text);
    match &fix {
        Ok(f) => {
            for &(id, x) in &f.0 {
                prop_assert!(
                    ProblemSpec::default().fix(id, x).is_ok(),
                    "{text:?}: {id:?}"
                );
            }
        }
        Err(e) => one_line(text, e)?,
    }
    let bounds: Vec<BoundsSpec> = bounds.into_iter().collect();
    let fix: Vec<FixSpec> = fix.into_iter().collect();
    if let Err(e) = problem(&bounds, &fix) {
        one_line(text, &format!("{e:#}"))?;
    }
    Ok(())
}

/// The seed specs: (parser, line), from `motor.txt`, `effect.txt`, `bounds.txt`, `fix.txt`.
fn seed_lines() -> Vec<(String, String)> {
    let mut out = Vec::new();
    for seed in corpus("spec") {
        let parser = seed.name.trim_end_matches(".txt").to_string();
        let text = String::from_utf8(seed.bytes).expect("seed specs are text");
        out.extend(text.lines().map(|l| (parser.clone(), l.to_string())));
    }
    out
}

#[test]
fn replays_the_seed_corpus() {
    for (parser, line) in seed_lines() {
        parse_any(&line).unwrap();
        let ok = match parser.as_str() {
            "motor" => parse_motor(&line).is_ok(),
            "effect" => parse_effect(&line).is_ok(),
            "bounds" => parse_bounds(&line).is_ok(),
            "fix" => parse_fix(&line).is_ok(),
            other => panic!("seed file {other}.txt: no such parser"),
        };
        assert!(ok, "{parser}: {line}");
    }
}

#[test]
fn any_string_is_parsed_or_refused_on_one_line() {
    let lines: Vec<Vec<u8>> = seed_lines().into_iter().map(|l| l.1.into_bytes()).collect();
    let text = prop_oneof![
        any::<String>(),
        "[a-z_ =:,.0-9eE+-]{0,48}",
        mutated(lines, 6).prop_map(|b| String::from_utf8_lossy(&b).into_owned()),
    ];
    check("spec", CASES, &text, |text| parse_any(&text));
}

/// A value written as the CLI user may: shortest decimal or exponent notation, with blanks.
fn written(x: f32, exponent: bool, blanks: (bool, bool)) -> String {
    let number = if exponent {
        format!("{x:e}")
    } else {
        x.to_string()
    };
    let pad = |b: bool| if b { " " } else { "" };
    format!("{}{number}{}", pad(blanks.0), pad(blanks.1))
}

/// A value within `id`'s physical range (clipped to ±1000 where it is unbounded), strictly
/// positive for the motor's parameters other than `b`; `u` in 0..=1 picks it.
fn in_range(id: ParamId, u: f32) -> f32 {
    let (lo, hi) = id.physical_range();
    if id.is_motor() {
        // Log-uniform over 1e-6 ..= 1e3, which every motor parameter admits.
        let low = if id == ParamId::B { 0.0 } else { 1e-6 };
        return (1e-6f32 * 1e9f32.powf(u)).max(low).min(1e3);
    }
    let (lo, hi) = (lo.max(-1e3), hi.min(1e3));
    (lo + (hi - lo) * u).clamp(lo, hi)
}

/// How values are written: (exponent notation, blank before, blank after), per item.
fn style() -> impl Strategy<Value = (bool, (bool, bool))> {
    any::<(bool, (bool, bool))>()
}

fn items(parts: Vec<String>) -> String {
    parts.join(",")
}

#[test]
fn a_generated_motor_spec_parses_to_its_values() {
    let input = (
        proptest::array::uniform5((0.0f32..=1.0, style())),
        Just(ParamId::MOTOR.to_vec()).prop_shuffle(),
    );
    check("spec", CASES, &input, |(values, order)| {
        let value = |id: ParamId| in_range(id, values[id.index()].0);
        let parts = order.iter().map(|&id| {
            let (exp, blanks) = values[id.index()].1;
            format!("{}={}", id.name(), written(value(id), exp, blanks))
        });
        let text = items(parts.collect());
        let p = parse_motor(&text).map_err(TestCaseError::fail)?;
        for id in ParamId::MOTOR {
            prop_assert_eq!(p.get(id), value(id), "{}", text);
        }
        Ok(())
    });
}

#[test]
fn a_generated_effect_spec_parses_to_its_values() {
    let effect = select(Effect::ALL.to_vec());
    let input = effect.prop_flat_map(|effect| {
        let n = effect.params().len();
        let values = proptest::collection::vec((0.0f32..=1.0, style(), any::<bool>()), n);
        (
            Just(effect),
            subsequence(effect.params().to_vec(), 1..=n),
            values,
        )
    });
    check("spec", CASES, &input, |(effect, params, values)| {
        let mut want = Vec::new();
        let mut parts = Vec::new();
        for (&id, &(u, (exp, blanks), by_name)) in params.iter().zip(&values) {
            let x = in_range(id, u);
            let key = if by_name { id.name() } else { id.short_key() };
            parts.push(format!("{key}={}", written(x, exp, blanks)));
            want.push((id, x));
        }
        let text = format!("{}:{}", effect.name(), items(parts));
        let spec = parse_effect(&text).map_err(TestCaseError::fail)?;
        prop_assert_eq!(
            spec,
            EffectSpec {
                effect,
                values: want
            },
            "{}",
            text
        );
        Ok(())
    });
}

#[test]
fn generated_bounds_and_fixes_parse_to_their_values_and_apply() {
    // Distinct parameters, split between bounds and fixes.
    let split = Just(ParamId::ALL.to_vec())
        .prop_shuffle()
        .prop_flat_map(|all| (Just(all), 0..=ParamId::ALL.len(), 0..=ParamId::ALL.len()));
    let values = proptest::collection::vec(
        (0.0f32..=1.0, 0.0f32..=1.0, style()),
        motor_id_shared::param_id::PARAM_COUNT,
    );
    check("spec", CASES, &(split, values), |((all, b, f), values)| {
        let (b, f) = (b.min(f), b.max(f));
        let (bounded, fixed) = (&all[..b], &all[b..f]);
        let mut want_bounds = Vec::new();
        let mut parts = Vec::new();
        for (&id, &(u1, u2, (exp, blanks))) in bounded.iter().zip(&values) {
            let (lo, hi) = (in_range(id, u1.min(u2)), in_range(id, u1.max(u2)));
            // (Twelve decades at most: a wider range is refused as no bound.)
            if lo >= hi || (lo > 0.0 && hi / lo > 1e12) {
                continue;
            }
            let (lo_text, hi_text) = (written(lo, exp, blanks), written(hi, exp, blanks));
            parts.push(format!("{}={lo_text}:{hi_text}", id.name()));
            want_bounds.push((id, lo, hi));
        }
        let mut want_fix = Vec::new();
        let mut fixes = Vec::new();
        for (&id, &(u, _, (exp, blanks))) in fixed.iter().zip(&values[b..]) {
            let x = in_range(id, u);
            fixes.push(format!("{}={}", id.name(), written(x, exp, blanks)));
            want_fix.push((id, x));
        }
        let bounds = match parts.is_empty() {
            true => Vec::new(),
            false => vec![parse_bounds(&items(parts)).map_err(TestCaseError::fail)?],
        };
        let fix = match fixes.is_empty() {
            true => Vec::new(),
            false => vec![parse_fix(&items(fixes)).map_err(TestCaseError::fail)?],
        };
        prop_assert_eq!(
            bounds.iter().flat_map(|b| b.0.clone()).collect::<Vec<_>>(),
            want_bounds.clone()
        );
        prop_assert_eq!(
            fix.iter().flat_map(|f| f.0.clone()).collect::<Vec<_>>(),
            want_fix.clone()
        );
        let spec = problem(&bounds, &fix).map_err(|e| TestCaseError::fail(format!("{e:#}")))?;
        for (id, lo, hi) in want_bounds {
            prop_assert_eq!(spec.bounds[id.index()], (lo, hi));
            prop_assert!(spec.free[id.index()], "{:?} bounded, so free", id);
        }
        for (id, x) in want_fix {
            prop_assert_eq!(spec.base.get(id), x);
            prop_assert!(!spec.free[id.index()], "{:?} fixed", id);
        }
        Ok(())
    });
}
