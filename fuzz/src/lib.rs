//! The fuzz harness of motor-id. `cargo fuzz` needs a nightly toolchain, so the five fuzz
//! targets are property tests (proptest) that `cargo test` runs on stable:
//!
//! | target | test module | what it checks |
//! |---|---|---|
//! | `frame` | `shared/src/wire/frame_fuzz.rs` | the frame decoder on arbitrary bytes, on frames with a valid CRC around arbitrary bodies, and on frames among garbage |
//! | `service` | `shared/src/device/service_fuzz.rs` | the board's request handler fed arbitrary message sequences |
//! | `csv` | `host/src/csvio/fuzz.rs` | the record CSV reader on arbitrary and mutated text |
//! | `report` | `host/src/validation_fuzz.rs` | the reader of a JSON report's parameters (`--params`) and of what it did not pin |
//! | `spec` | `host/src/spec_fuzz.rs` | the `--motor`, `--effect`, `--bounds` and `--fix` parsers |
//!
//! This crate holds what they share: the budget ([`check`]), the seed corpus
//! (`fuzz/corpus/<target>/`, [`corpus`]) and a byte mutator ([`mutated`]).
//!
//! **Budget.** Each target runs its own default number of cases, a few seconds in
//! `cargo test --workspace`. `PROPTEST_CASES=N` runs `N` cases per target instead.
//! `FUZZ_SECONDS=S` runs batches of cases, each with a fresh random seed, until `S` seconds
//! have passed: a bound on the work of a long run, never a pass/fail deadline. A failure
//! prints the shrunk input; add it to the corpus as a regression.

use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, TestCaseResult, TestRunner};
use std::fmt::Debug;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How much work one target does: cases per batch, and how long to repeat batches.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Budget {
    /// Cases per batch.
    pub cases: u32,
    /// Repeat batches until this much time has passed (`None`: one batch).
    pub duration: Option<Duration>,
}

impl Budget {
    /// The budget that `PROPTEST_CASES` and `FUZZ_SECONDS` ask for, `default_cases` when
    /// neither is set.
    pub fn from_env(default_cases: u32) -> Budget {
        Budget::from_vars(
            std::env::var("PROPTEST_CASES").ok().as_deref(),
            std::env::var("FUZZ_SECONDS").ok().as_deref(),
            default_cases,
        )
    }

    /// [`Budget::from_env`] on the values given. A value that is no number panics (a long run
    /// that silently ran the default would be worse).
    pub fn from_vars(cases: Option<&str>, seconds: Option<&str>, default_cases: u32) -> Budget {
        let cases = cases.map_or(default_cases, |text| {
            text.trim()
                .parse()
                .unwrap_or_else(|_| panic!("PROPTEST_CASES={text:?} is not a case count"))
        });
        let duration = seconds.map(|text| {
            let s: f64 = text
                .trim()
                .parse()
                .unwrap_or_else(|_| panic!("FUZZ_SECONDS={text:?} is not a number of seconds"));
            Duration::try_from_secs_f64(s)
                .unwrap_or_else(|_| panic!("FUZZ_SECONDS={text:?} is not a duration"))
        });
        Budget {
            cases: cases.max(1),
            duration,
        }
    }
}

/// Run fuzz target `target`: `test` on inputs drawn from `strategy`, within the budget of
/// the environment ([`Budget::from_env`], `default_cases` by default). A failing case is
/// shrunk and the test panics with it.
pub fn check<S>(
    target: &str,
    default_cases: u32,
    strategy: &S,
    test: impl Fn(S::Value) -> TestCaseResult,
) where
    S: Strategy,
    S::Value: Debug,
{
    let budget = Budget::from_env(default_cases);
    let start = Instant::now();
    let mut batches = 0u64;
    loop {
        let config = Config {
            cases: budget.cases,
            failure_persistence: None,
            ..Config::default()
        };
        let mut runner = TestRunner::new(config);
        if let Err(e) = runner.run(strategy, &test) {
            panic!("fuzz target {target}: {e}");
        }
        batches += 1;
        if budget.duration.is_none_or(|d| start.elapsed() >= d) {
            break;
        }
    }
    if budget.duration.is_some() {
        eprintln!(
            "fuzz target {target}: {} cases in {:.1} s",
            batches * u64::from(budget.cases),
            start.elapsed().as_secs_f64()
        );
    }
}

/// One input of the seed corpus.
#[derive(Clone, Debug, PartialEq)]
pub struct Seed {
    /// File name (its prefix may say what the target expects of it).
    pub name: String,
    /// Contents.
    pub bytes: Vec<u8>,
}

/// Folder of the seed corpus of `target`.
pub fn corpus_dir(target: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("corpus")
        .join(target)
}

/// The seed corpus of `target`, by file name. Panics when it is missing or empty: a target
/// without seeds would fuzz less than it claims.
pub fn corpus(target: &str) -> Vec<Seed> {
    let dir = corpus_dir(target);
    let entries =
        std::fs::read_dir(&dir).unwrap_or_else(|e| panic!("seed corpus {}: {e}", dir.display()));
    let mut seeds: Vec<Seed> = entries
        .map(|entry| {
            let path = entry.expect("corpus entry").path();
            let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
            let name = path.file_name().unwrap().to_string_lossy().into_owned();
            Seed { name, bytes }
        })
        .collect();
    assert!(!seeds.is_empty(), "seed corpus {} is empty", dir.display());
    seeds.sort_by(|a, b| a.name.cmp(&b.name));
    seeds
}

/// Bytes a mutation likes to write: the frame delimiter, varint and sign edges, and the
/// separators and number characters of CSV and of the command-line specs.
const INTERESTING: &[u8] = b"\x00\x01\x7f\x80\xff\n\r\t ,;\"=:-+.e09";

/// One edit of a byte string.
#[derive(Clone, Debug)]
enum Edit {
    /// XOR the byte at the index with a mask.
    Flip(Index, u8),
    /// Overwrite the byte at the index.
    Set(Index, u8),
    /// Insert a byte before the index.
    Insert(Index, u8),
    /// Remove 1 to 8 bytes from the index.
    Remove(Index, u8),
    /// Repeat 1 to 64 bytes from the index right after themselves.
    Duplicate(Index, u8),
    /// Copy up to 64 bytes of another seed (from its index) in before the index.
    Splice(Index, Index, Index, u8),
    /// Cut everything from the index on.
    Truncate(Index),
}

fn byte() -> impl Strategy<Value = u8> {
    prop_oneof![any::<u8>(), proptest::sample::select(INTERESTING)]
}

fn edit() -> impl Strategy<Value = Edit> {
    let i = any::<Index>;
    prop_oneof![
        (i(), 1..=255u8).prop_map(|(at, mask)| Edit::Flip(at, mask)),
        (i(), byte()).prop_map(|(at, b)| Edit::Set(at, b)),
        (i(), byte()).prop_map(|(at, b)| Edit::Insert(at, b)),
        (i(), 1..=8u8).prop_map(|(at, n)| Edit::Remove(at, n)),
        (i(), 1..=64u8).prop_map(|(at, n)| Edit::Duplicate(at, n)),
        (i(), i(), i(), 1..=64u8).prop_map(|(s, from, at, n)| Edit::Splice(s, from, at, n)),
        i().prop_map(Edit::Truncate),
    ]
}

impl Edit {
    fn apply(&self, b: &mut Vec<u8>, seeds: &[Vec<u8>]) {
        // An insertion point (0..=len) and an existing byte (None on an empty string).
        let gap = |at: &Index, b: &[u8]| at.index(b.len() + 1);
        let byte_at = |at: &Index, b: &[u8]| (!b.is_empty()).then(|| at.index(b.len()));
        match self {
            Edit::Flip(at, mask) => {
                if let Some(k) = byte_at(at, b) {
                    b[k] ^= mask;
                }
            }
            Edit::Set(at, x) => {
                if let Some(k) = byte_at(at, b) {
                    b[k] = *x;
                }
            }
            Edit::Insert(at, x) => b.insert(gap(at, b), *x),
            Edit::Remove(at, n) => {
                if let Some(k) = byte_at(at, b) {
                    b.drain(k..(k + *n as usize).min(b.len()));
                }
            }
            Edit::Duplicate(at, n) => {
                if let Some(k) = byte_at(at, b) {
                    let part = b[k..(k + *n as usize).min(b.len())].to_vec();
                    b.splice(k..k, part);
                }
            }
            Edit::Splice(seed, from, at, n) => {
                let other = &seeds[seed.index(seeds.len())];
                if let Some(f) = byte_at(from, other) {
                    let part = &other[f..(f + *n as usize).min(other.len())];
                    let k = gap(at, b);
                    b.splice(k..k, part.iter().copied());
                }
            }
            Edit::Truncate(at) => b.truncate(gap(at, b)),
        }
    }
}

/// One of `seeds` with up to `max_edits` random edits (bit flips, interesting bytes,
/// insertions, removals, repeats, splices of another seed, truncation). Shrinks towards
/// fewer edits of the first seed.
pub fn mutated(seeds: Vec<Vec<u8>>, max_edits: usize) -> impl Strategy<Value = Vec<u8>> {
    assert!(!seeds.is_empty(), "mutated: no seeds");
    let seeds = Arc::new(seeds);
    (
        0..seeds.len(),
        proptest::collection::vec(edit(), 0..=max_edits),
    )
        .prop_map(move |(k, edits)| {
            let mut b = seeds[k].clone();
            for e in &edits {
                e.apply(&mut b, &seeds);
            }
            b
        })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::strategy::ValueTree;

    #[test]
    fn the_budget_is_the_default_or_what_the_environment_asks() {
        let default = Budget {
            cases: 64,
            duration: None,
        };
        assert_eq!(Budget::from_vars(None, None, 64), default);
        assert_eq!(Budget::from_vars(Some("1000"), None, 64).cases, 1000);
        let long = Budget::from_vars(None, Some("600"), 64);
        assert_eq!(long.duration, Some(Duration::from_secs(600)));
        assert_eq!(long.cases, 64);
        assert!(std::panic::catch_unwind(|| Budget::from_vars(Some("many"), None, 64)).is_err());
        assert!(std::panic::catch_unwind(|| Budget::from_vars(None, Some("-1"), 64)).is_err());
    }

    #[test]
    fn every_target_has_a_seed_corpus() {
        for target in ["frame", "service", "csv", "spec", "report"] {
            assert!(!corpus(target).is_empty(), "{target}");
        }
    }

    #[test]
    fn mutations_reach_every_kind_of_edit_and_never_panic_on_empty_seeds() {
        let seeds = vec![Vec::new(), b"t,v,omega\n0,1,2\n".to_vec()];
        let (mut shorter, mut longer, mut same_length_changed) = (0, 0, 0);
        check("mutator", 2000, &mutated(seeds.clone(), 4), |b| {
            prop_assert!(b.len() <= seeds[1].len() + 4 * 64);
            Ok(())
        });
        let mut runner = TestRunner::deterministic();
        let strategy = mutated(vec![seeds[1].clone()], 1);
        for _ in 0..2000 {
            let b = strategy.new_tree(&mut runner).unwrap().current();
            match b.len().cmp(&seeds[1].len()) {
                std::cmp::Ordering::Less => shorter += 1,
                std::cmp::Ordering::Greater => longer += 1,
                _ if b != seeds[1] => same_length_changed += 1,
                _ => {}
            }
        }
        assert!(shorter > 100 && longer > 100 && same_length_changed > 100);
    }
}
