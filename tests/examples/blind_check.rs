//! Blind checks of `motor-id diagnose` (a benchmark, not a test): records of the independent
//! reference plant (`tests/src/reference_plant/`) with every new catalogue effect alone, every
//! pair of them and none, at 2, 5 and 10 kHz, speed read by an encoder (a case with a tacho
//! ripple or a delay by a quiet tacho, `blind::tacho_noise`); each case's motor and effect
//! sizes drawn from its seed (`tests/src/blind.rs`). Counts how often the effects
//! named are exactly the true ones, the names of effects the plant does not hold (the
//! Coulomb friction that static and asymmetric friction come with is held: naming it alone
//! is a miss, not a false name), the false effects on null records and the noise estimate
//! against the truth.
//!
//! `cargo run --release -p motor-id-tests --example blind_check -- [SEEDS] [RATES] [CASES]`
//! e.g. `-- 8 2000,5000,10000 all` (the defaults; SEEDS `N` runs seeds 1 to N, `A-B`
//! seeds A to B); CASES is `all` or names joined by `,` (`null`, `static`, `asymmetric`, `deadtime`, `offset`, `limit`, `cogging` (told its
//! detents per revolution), `heating` (winding heating, on 40 s reversing cycles), the
//! withheld `cogging-untold`, a `delay` of the speed reading of 0.5-1 sample, pairs as
//! `static+offset` or `static+cogging-untold`; `all` also holds the older entries
//! `coulomb`, `quadratic`, `reaction`, `brush` and `ripple` (a tacho ripple) alone, in
//! pairs, beside each newer entry and beside a delay).
//! CASES `without` (or `without:limit,cogging`) runs instead each catalogue entry's effect
//! alone with that entry left out of the search (`--without`): what is named for it (only a
//! part of the truth may be: the Coulomb friction of static friction), whether the verdict
//! says unexplained, the partial stand-ins and where the remainder lies.
//! A case with effects to name that is missed is diagnosed again on its records with the
//! catalogue held to the truth's own entries (`blind::all_but_the_truth`): named right
//! then, the records show the truth and the whole catalogue's search lost it to an entry
//! the plant does not hold; not named even then, the naming rule does not name it even
//! among the truth's own entries. The summary counts both and the share named right of the cases whose records
//! show the truth by that search (a case named right counts as shown; a miss with nothing
//! to name, a name on a null or withheld-only record, is not searched again).
//! One line per case on stderr, a summary table on stdout. `BLIND_VERBOSE=1` prints each
//! verdict, `BLIND_KEEP=DIR` keeps each case's records and report in `DIR`, `BLIND_TACHO=S`
//! reads every case's speed with a tacho of white noise `S` rad/s.
//! `MOTOR_ID_BIN=PATH` runs that `motor-id` instead of building and running
//! `target/release/motor-id` (a copy keeps an hour-long run apart from rebuilds).

use motor_id_tests::blind::{
    all_but_the_truth, check_without, components, entry, entry_cases, label, simulate, tacho_noise,
    OLDER, SINGLES, WITHHELD,
};
use motor_id_tests::partial_stand_ins;
use std::collections::BTreeSet;
use std::ops::RangeInclusive;

/// The seeds of the argument SEEDS: `N` is 1 to N, `A-B` is A to B.
fn seed_range(arg: &str) -> RangeInclusive<u64> {
    let seed = |s: &str| s.parse::<u64>().expect("SEEDS: N or A-B");
    match arg.split_once('-') {
        Some((a, b)) => {
            let (a, b) = (seed(a), seed(b));
            assert!(a <= b, "SEEDS: A-B with A at most B");
            a..=b
        }
        None => 1..=seed(arg),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds = args.first().map_or(1..=8, |a| seed_range(a));
    let n_seeds = seeds.clone().count();
    let rates: Vec<f64> = args.get(1).map_or(vec![2000.0, 5000.0, 10000.0], |a| {
        a.split(',').map(|r| r.parse().expect("RATES")).collect()
    });
    if let Some(pick) = args.get(2).and_then(|a| a.strip_prefix("without")) {
        left_out(seeds.clone(), &rates, pick.strip_prefix(':'));
        return;
    }
    let mut cases: Vec<Vec<&str>> = vec![vec![]];
    cases.extend(SINGLES.iter().map(|x| vec![*x]));
    for (i, a) in SINGLES.iter().enumerate() {
        cases.extend(SINGLES[i + 1..].iter().map(|b| vec![*a, *b]));
    }
    // Each withheld effect alone and beside each catalogue entry: nothing named for it.
    for w in WITHHELD {
        cases.push(vec![w]);
        cases.extend(SINGLES.iter().map(|x| vec![*x, w]));
    }
    // A speed reading delayed by half a sample to one, alone and beside each entry.
    cases.push(vec!["delay"]);
    cases.extend(SINGLES.iter().map(|x| vec![*x, "delay"]));
    // The older entries, alone, in pairs and beside each newer entry; Coulomb friction not
    // beside its own extensions, which hold it. A case with a tacho ripple or a delay is
    // read by the quiet tacho (`tacho_noise`), every other by the encoder.
    for (i, a) in OLDER.iter().enumerate() {
        cases.push(vec![a]);
        cases.extend(OLDER[i + 1..].iter().map(|b| vec![*a, *b]));
        let extends_it = |x: &&str| *a == "coulomb" && matches!(*x, "static" | "asymmetric");
        cases.extend(
            SINGLES
                .iter()
                .filter(|x| !extends_it(x))
                .map(|x| vec![*a, *x]),
        );
        cases.push(vec![a, "delay"]);
    }
    // Cases named: each `a+b` (or `null`), any entry's case name.
    if let Some(pick) = args.get(2).filter(|a| *a != "all") {
        cases = pick
            .split(',')
            .map(|c| match c {
                "null" => vec![],
                c => c.split('+').collect(),
            })
            .collect();
    }

    println!(
        "| case | rate | named right | a name not true | unexplained | noise est / truth | s per case |"
    );
    println!("|---|---|---|---|---|---|---|");
    let (mut right_all, mut total, mut false_on_null, mut forced_all) = (0, 0, 0, 0);
    let mut noise_bad = 0;
    // Misses named right by a search of the truth's entries alone, and the others.
    let (mut named_alone, mut not_shown) = (0, 0);
    for case in &cases {
        let expected: BTreeSet<String> = case
            .iter()
            .filter_map(|x| entry(x).map(str::to_string))
            .collect();
        // What the plant holds: static and asymmetric friction come with their Coulomb
        // friction, so naming it is a miss (their own part not named), not a false name.
        let held: BTreeSet<String> = case
            .iter()
            .flat_map(|x| components(x))
            .map(str::to_string)
            .collect();
        for &rate in &rates {
            let (mut right, mut forced, mut unexplained, mut secs) = (0, 0, 0, 0.0);
            let (mut lo, mut hi) = (f64::MAX, 0f64);
            for seed in seeds.clone() {
                let dir = tempfile::tempdir().expect("temporary directory");
                // BLIND_KEEP=DIR keeps the records and reports (one folder per case).
                let kept = std::env::var_os("BLIND_KEEP").map(|d| {
                    let d = std::path::Path::new(&d).join(format!("{}-{rate}-{seed}", label(case)));
                    std::fs::create_dir_all(&d).expect("BLIND_KEEP folder");
                    d
                });
                let at = kept.as_deref().unwrap_or(dir.path());
                let records = simulate(at, case, rate, seed, tacho_noise(case));
                let o = records.diagnose(case, &[], at);
                let ok = o.named == expected;
                // A miss searched again on the same records with only the truth's entries
                // in the catalogue: does the naming rule find them at all? (A kept folder's
                // report of an earlier run's search alone goes first.)
                let at = at.join("alone");
                let _ = std::fs::remove_dir_all(&at);
                let alone = (!ok && !expected.is_empty()).then(|| {
                    std::fs::create_dir_all(&at).expect("folder of the search alone");
                    records.diagnose(case, &all_but_the_truth(case), &at).named
                });
                eprintln!(
                    "{} @ {rate} Hz seed {seed}: named {:?}{} unexplained {} noise x{:.2} ({:.1} s){}",
                    label(case),
                    o.named,
                    if ok { "" } else { " WRONG" },
                    o.unexplained,
                    o.noise_ratio,
                    o.seconds,
                    alone.as_ref().map_or(String::new(), |a| format!(
                        "; the truth's entries alone: named {a:?}{}",
                        if *a == expected { "" } else { " (not named alone either)" }
                    ))
                );
                right += usize::from(ok);
                match alone {
                    Some(a) if a == expected => named_alone += 1,
                    Some(_) => not_shown += 1,
                    None => {}
                }
                // A catalogue name the plant does not hold (a stand-in named as a cause).
                forced += usize::from(!o.named.is_subset(&held));
                unexplained += usize::from(o.unexplained);
                if case.is_empty() && !o.named.is_empty() {
                    false_on_null += 1;
                }
                noise_bad += usize::from((o.noise_ratio - 1.0).abs() > 0.2);
                lo = lo.min(o.noise_ratio);
                hi = hi.max(o.noise_ratio);
                secs += o.seconds;
            }
            right_all += right;
            forced_all += forced;
            total += n_seeds;
            println!(
                "| {} | {} kHz | {right}/{n_seeds} | {forced} | {unexplained} | {lo:.2}-{hi:.2} | {:.1} |",
                label(case),
                rate / 1000.0,
                secs / n_seeds as f64
            );
        }
    }
    println!(
        "\nnamed right: {right_all}/{total} ({:.1} %); a name not true: {forced_all}/{total}; \
         false effects on null records: {false_on_null}; noise estimate off by more than 20 %: \
         {noise_bad}/{total}",
        100.0 * right_all as f64 / total as f64
    );
    let shown = total - not_shown;
    let missed = total - right_all;
    println!(
        "misses: {missed}; the truth's entries alone name right: {named_alone}; not named \
         even so: {not_shown}; nothing to name, not searched again: {}; named right where the \
         records show the truth by that search: {right_all}/{shown} ({:.1} %)",
        missed - named_alone - not_shown,
        100.0 * right_all as f64 / shown.max(1) as f64
    );
}

/// The table of each entry left out (`--without`): its effect alone in the plant.
fn left_out(seeds: RangeInclusive<u64>, rates: &[f64], pick: Option<&str>) {
    let n_seeds = seeds.clone().count();
    let mut effects = entry_cases();
    if let Some(pick) = pick {
        let wanted: Vec<&str> = pick.split(',').collect();
        effects.retain(|e| wanted.contains(e));
    }
    println!("| effect, left out | rate | a name not true | unexplained | partial stand-ins | remainder's where |");
    println!("|---|---|---|---|---|---|");
    let (mut forced_all, mut explained_all, mut total) = (0, 0, 0);
    for effect in effects {
        let left = entry(effect).expect("a catalogue entry");
        let allowed: BTreeSet<String> = components(effect)
            .into_iter()
            .filter(|c| *c != left)
            .map(str::to_string)
            .collect();
        for &rate in rates {
            let (mut forced, mut unexplained) = (0, 0);
            let mut partial: BTreeSet<String> = BTreeSet::new();
            let mut wheres: BTreeSet<String> = BTreeSet::new();
            for seed in seeds.clone() {
                let dir = tempfile::tempdir().expect("temporary directory");
                let kept = std::env::var_os("BLIND_KEEP").map(|d| {
                    let d =
                        std::path::Path::new(&d).join(format!("{effect}-without-{rate}-{seed}"));
                    std::fs::create_dir_all(&d).expect("BLIND_KEEP folder");
                    d
                });
                let o = check_without(
                    kept.as_deref().unwrap_or(dir.path()),
                    &[effect],
                    rate,
                    seed,
                    &[left],
                    tacho_noise(&[effect]),
                );
                let wrong = !o.named.is_subset(&allowed);
                let stand_ins: Vec<String> = partial_stand_ins(&o.verdict)
                    .into_iter()
                    .map(|(name, _)| name)
                    .collect();
                let place = where_of(&o.verdict);
                eprintln!(
                    "{effect} without {left} @ {rate} Hz seed {seed}: named {:?}{} unexplained {} partial {stand_ins:?} where {place} ({:.1} s)",
                    o.named,
                    if wrong { " FORCED" } else { "" },
                    o.unexplained,
                    o.seconds
                );
                forced += usize::from(wrong);
                unexplained += usize::from(o.unexplained);
                partial.extend(stand_ins);
                wheres.insert(place);
            }
            forced_all += forced;
            explained_all += n_seeds - unexplained;
            total += n_seeds;
            println!(
                "| {effect} without {left} | {} kHz | {forced}/{n_seeds} | {unexplained}/{n_seeds} | {} | {} |",
                rate / 1000.0,
                partial.into_iter().collect::<Vec<_>>().join(", "),
                wheres.into_iter().collect::<Vec<_>>().join("; ")
            );
        }
    }
    println!(
        "\nleft out: a name not true {forced_all}/{total}; not called unexplained {explained_all}/{total}"
    );
}

/// Where the verdict's remainder lies, in a few words: the drift of a parameter along a
/// record, the regime that holds most of the speed's misfit, and (`current:`) the one that
/// holds most of the current's (the current channel's own where when the speed's misfit is
/// explained and the current's is not).
fn where_of(verdict: &serde_json::Value) -> String {
    let r = &verdict["remainder"];
    if r.is_null() {
        return most_over_represented(&verdict["current"]["regimes"])
            .map_or("-".into(), |top| format!("current: {top}"));
    }
    let mut parts = Vec::new();
    if let Some(d) = r["drift"][0]["param"].as_str() {
        parts.push(format!("drift of {d}"));
    }
    if let Some(top) = most_over_represented(&r["regimes"]) {
        parts.push(top);
    }
    if let Some(top) = most_over_represented(&r["current_regimes"]) {
        parts.push(format!("current: {top}"));
    }
    parts.join(", ")
}

/// The short name of the regime with the largest share of misfit over share of samples.
fn most_over_represented(regimes: &serde_json::Value) -> Option<String> {
    let regimes = regimes.as_array()?;
    let lift = |x: &serde_json::Value| {
        x["share_of_misfit"].as_f64().unwrap_or(0.0)
            / x["share_of_samples"].as_f64().unwrap_or(1.0).max(1e-9)
    };
    let top = regimes.iter().max_by(|a, b| lift(a).total_cmp(&lift(b)))?;
    Some(top["short"].as_str().unwrap_or("?").to_string())
}
