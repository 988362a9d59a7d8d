//! Every option of every command, at hostile values (issue 22): each run ends, within a
//! memory limit and a time limit, with status 0, 1, 2 or 3, no panic and a short message.
//! The options are read from each command's `--help`, so a new option is covered as soon
//! as it exists.

use motor_id_tests::{motor_id, s, simulate};
use std::path::Path;
use std::process::Command;

/// Values that broke commands before: zero, negatives, the extremes of f64, NaN and
/// infinities, a u32 overflow, a value a hair below a pole, and text.
const HOSTILE: [&str; 10] = [
    "0",
    "-1",
    "1e-300",
    "1e300",
    "NaN",
    "inf",
    "-inf",
    "4294967297",
    "89.9999999",
    "x",
];

/// Options not to feed hostile values: the help, the action chosen, flags without a value.
fn options_of(help: &str) -> Vec<String> {
    help.lines()
        .filter_map(|l| {
            let l = l.trim_start();
            let l = l.strip_prefix("-q, ").unwrap_or(l);
            let name = l.strip_prefix("--")?;
            let (name, rest) = name.split_once(' ')?;
            // `--name <VALUE>`: an option that takes a value.
            rest.trim_start()
                .starts_with('<')
                .then(|| format!("--{name}"))
        })
        .collect()
}

/// `motor-id ARGS` in `dir`, under 4 GB of address space and 60 s: its status (`None`
/// when killed) and stderr.
fn run_bounded(dir: &Path, args: &[String]) -> (Option<i32>, String) {
    let mut line = String::from("ulimit -v 4000000; exec timeout 60 \"$0\"");
    for k in 1..=args.len() {
        line += &format!(" \"${k}\"");
    }
    let out = Command::new("sh")
        .arg("-c")
        .arg(line)
        .arg(motor_id())
        .args(args)
        .current_dir(dir)
        .output()
        .expect("sh");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stderr).to_string(),
    )
}

#[test]
fn every_option_of_every_command_survives_hostile_values() {
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec.csv");
    simulate(
        &rec,
        &[
            "--profile",
            "steps",
            "--rate",
            "200",
            "--duration",
            "3",
            "--noise-omega",
            "0.1",
            "--noise-current",
            "0.01",
        ],
    );
    let params = dir.path().join("params.json");
    motor_id_tests::run_ok(&["identify", s(&rec), "-q", "--json", s(&params)]);
    let (rec, params) = (s(&rec).to_string(), s(&params).to_string());
    // Each command with what it needs to run, the option under test appended.
    let commands: Vec<(&str, Vec<String>)> = vec![
        (
            "simulate",
            vec!["simulate".into(), "--out".into(), "o.csv".into()],
        ),
        ("identify", vec!["identify".into(), rec.clone()]),
        (
            "import-scope",
            vec![
                "import-scope".into(),
                rec.clone(),
                "--out".into(),
                "s.csv".into(),
                "--tacho-gain".into(),
                "35".into(),
                "--voltage".into(),
                "12".into(),
            ],
        ),
        (
            "diagnose",
            vec![
                "diagnose".into(),
                "--train".into(),
                rec.clone(),
                "--holdout".into(),
                rec.clone(),
            ],
        ),
        (
            "validate",
            vec![
                "validate".into(),
                "--params".into(),
                params.clone(),
                rec.clone(),
            ],
        ),
        (
            "tune",
            vec!["tune".into(), "--params".into(), params.clone()],
        ),
        (
            "compare",
            vec!["compare".into(), rec.clone(), "--runs".into(), "1".into()],
        ),
        ("commission", vec!["commission".into(), "--sim".into()]),
        (
            "demo",
            vec!["demo".into(), "--out-dir".into(), "demo".into()],
        ),
        (
            "board",
            vec![
                "board".into(),
                "--port".into(),
                "/nonexistent".into(),
                "hello".into(),
            ],
        ),
    ];
    let mut failures = Vec::new();
    let mut runs = 0;
    for (name, base) in &commands {
        let help = Command::new(motor_id())
            .args([name, &"--help"])
            .output()
            .expect("help");
        let help = String::from_utf8_lossy(&help.stdout).to_string();
        let options = options_of(&help);
        assert!(!options.is_empty(), "{name}: no options in its help");
        for option in options {
            for value in HOSTILE {
                // The option before the action (`board`'s options precede it).
                let mut args = base.clone();
                let at = if *name == "board" { 1 } else { args.len() };
                args.insert(at, option.clone());
                args.insert(at + 1, value.into());
                let (status, stderr) = run_bounded(dir.path(), &args);
                runs += 1;
                let ok = matches!(status, Some(0..=3))
                    && !stderr.contains("panicked")
                    && stderr.len() <= 2000;
                if !ok {
                    failures.push(format!(
                        "{args:?}: status {status:?}, {} bytes: {:.300}",
                        stderr.len(),
                        stderr
                    ));
                }
            }
        }
    }
    assert!(runs > 300, "{runs} runs");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
