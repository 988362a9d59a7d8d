//! Blind checks of `motor-id diagnose` (a benchmark, not a test): records of the independent
//! reference plant (`tests/src/reference_plant/`) with every new catalogue effect alone, every
//! pair of them and none, at 2, 5 and 10 kHz, speed read by an encoder; each case's motor and
//! effect sizes drawn from its seed (`tests/src/blind.rs`). Counts how often the effects
//! named are exactly the true ones, the false effects on null records and the noise estimate
//! against the truth.
//!
//! `cargo run --release -p motor-id-tests --example blind_check -- [SEEDS] [RATES] [CASES]`
//! e.g. `-- 8 2000,5000,10000 all` (the defaults); CASES is `all` or names joined by `,`
//! (`null`, `static`, `asymmetric`, `deadtime`, `offset`, `limit`, `cogging` (told its
//! detents per revolution), `heating` (winding heating, on 40 s reversing cycles), the
//! withheld `cogging-untold`, a `delay` of the speed reading of 0.5-1 sample, pairs as
//! `static+offset` or `static+cogging-untold`).
//! One line per case on stderr, a summary table on stdout. `BLIND_VERBOSE=1` prints each
//! verdict, `BLIND_KEEP=DIR` keeps each case's records and report in `DIR`, `BLIND_TACHO=S`
//! reads the speed with a tacho of white noise `S` rad/s instead of the encoder.

use motor_id_tests::blind::{check, entry, label, SINGLES, WITHHELD};
use std::collections::BTreeSet;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let seeds: u64 = args.first().map_or(8, |a| a.parse().expect("SEEDS"));
    let rates: Vec<f64> = args.get(1).map_or(vec![2000.0, 5000.0, 10000.0], |a| {
        a.split(',').map(|r| r.parse().expect("RATES")).collect()
    });
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
    if let Some(pick) = args.get(2).filter(|a| *a != "all") {
        let wanted: Vec<&str> = pick.split(',').collect();
        cases.retain(|c| wanted.contains(&label(c).as_str()));
    }

    println!(
        "| case | rate | named right | a name not true | unexplained | noise est / truth | s per case |"
    );
    println!("|---|---|---|---|---|---|---|");
    let (mut right_all, mut total, mut false_on_null) = (0, 0, 0);
    let mut noise_bad = 0;
    for case in &cases {
        let expected: BTreeSet<String> = case
            .iter()
            .filter_map(|x| entry(x).map(str::to_string))
            .collect();
        for &rate in &rates {
            let (mut right, mut forced, mut unexplained, mut secs) = (0, 0, 0, 0.0);
            let (mut lo, mut hi) = (f64::MAX, 0f64);
            for seed in 1..=seeds {
                let dir = tempfile::tempdir().expect("temporary directory");
                // BLIND_KEEP=DIR keeps the records and reports (one folder per case).
                let kept = std::env::var_os("BLIND_KEEP").map(|d| {
                    let d = std::path::Path::new(&d).join(format!("{}-{rate}-{seed}", label(case)));
                    std::fs::create_dir_all(&d).expect("BLIND_KEEP folder");
                    d
                });
                let o = check(kept.as_deref().unwrap_or(dir.path()), case, rate, seed);
                let ok = o.named == expected;
                eprintln!(
                    "{} @ {rate} Hz seed {seed}: named {:?}{} unexplained {} noise x{:.2} ({:.1} s)",
                    label(case),
                    o.named,
                    if ok { "" } else { " WRONG" },
                    o.unexplained,
                    o.noise_ratio,
                    o.seconds
                );
                right += usize::from(ok);
                // A catalogue name the truth does not hold (a stand-in named as a cause).
                forced += usize::from(!o.named.is_subset(&expected));
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
            total += seeds as usize;
            println!(
                "| {} | {} kHz | {right}/{seeds} | {forced} | {unexplained} | {lo:.2}-{hi:.2} | {:.1} |",
                label(case),
                rate / 1000.0,
                secs / seeds as f64
            );
        }
    }
    println!(
        "\nnamed right: {right_all}/{total} ({:.1} %); false effects on null records: {false_on_null}; \
         noise estimate off by more than 20 %: {noise_bad}/{total}",
        100.0 * right_all as f64 / total as f64
    );
}
