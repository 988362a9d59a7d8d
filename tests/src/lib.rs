//! Helpers for the end-to-end tests in `tests/tests/`: they drive the `motor-id` binary
//! exactly as a user (or another tool) would, through the CLI/CSV/JSON contract of `docs/CONTRACTS.md`.

pub mod blind;
pub mod footprint;
pub mod reference_plant;

use serde_json::Value;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// Path of the `motor-id` binary, built once per test run in the same target directory and
/// profile as the tests; `MOTOR_ID_BIN` names another one (a benchmark that must not see a
/// rebuild part-way).
pub fn motor_id() -> &'static Path {
    static BIN: OnceLock<PathBuf> = OnceLock::new();
    BIN.get_or_init(|| {
        if let Some(bin) = std::env::var_os("MOTOR_ID_BIN") {
            return PathBuf::from(bin);
        }
        // target/<profile>/deps/<test-exe> -> target/<profile>
        let exe = std::env::current_exe().expect("test executable path");
        let profile_dir = exe
            .parent()
            .and_then(Path::parent)
            .expect("target/<profile>");
        let release = profile_dir.file_name().is_some_and(|n| n == "release");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
        let mut build = Command::new(cargo);
        build.args(["build", "--quiet", "-p", "motor-id", "--bin", "motor-id"]);
        if release {
            build.arg("--release");
        }
        let target_dir = profile_dir.parent().expect("target dir");
        build.env("CARGO_TARGET_DIR", target_dir);
        let status = build.status().expect("run cargo build for motor-id");
        assert!(status.success(), "cargo build of motor-id failed");
        let bin = profile_dir.join(format!("motor-id{}", std::env::consts::EXE_SUFFIX));
        assert!(bin.exists(), "{} missing after build", bin.display());
        bin
    })
}

/// Run `motor-id` with `args`.
pub fn run(args: &[&str]) -> Output {
    Command::new(motor_id())
        .args(args)
        .output()
        .expect("start motor-id")
}

/// Run `motor-id` and require success; returns stdout.
pub fn run_ok(args: &[&str]) -> String {
    let out = run(args);
    assert!(
        out.status.success(),
        "motor-id {args:?} failed ({:?}):\n{}",
        out.status,
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout).expect("UTF-8 stdout")
}

/// Run `motor-id` expecting an error (exit status 1); returns the stderr text after checking
/// it is one clear line and not a panic.
pub fn run_err(args: &[&str]) -> String {
    let out = run(args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(
        out.status.code(),
        Some(1),
        "motor-id {args:?} should have failed with status 1: {stderr}"
    );
    assert!(!stderr.contains("panicked"), "panic on {args:?}: {stderr}");
    assert!(
        !stderr.contains("RUST_BACKTRACE"),
        "backtrace hint on {args:?}: {stderr}"
    );
    assert_eq!(
        stderr.trim_end().lines().count(),
        1,
        "not one line on {args:?}: {stderr}"
    );
    stderr
}

/// Run `motor-id` expecting a usage error from clap (exit status 2); returns the stderr text
/// after checking it is not a panic and that its first line is clap's `error: ...`.
pub fn run_usage_err(args: &[&str]) -> String {
    let out = run(args);
    let stderr = String::from_utf8_lossy(&out.stderr).to_string();
    assert_eq!(
        out.status.code(),
        Some(2),
        "motor-id {args:?} should have been a usage error (status 2): {stderr}"
    );
    assert!(!stderr.contains("panicked"), "panic on {args:?}: {stderr}");
    assert!(
        stderr.starts_with("error: "),
        "not clap's usage error on {args:?}: {stderr}"
    );
    stderr
}

/// The paper's experiment: a start from rest read on the tacho only (100 Hz, 20 s,
/// 0.2 rad/s noise), as `simulate` arguments.
pub const PAPER_START: &[&str] = &[
    "--profile",
    "start",
    "--rate",
    "100",
    "--duration",
    "20",
    "--speed-only",
    "--noise-omega",
    "0.2",
];

/// The paper's motor with Coulomb friction of 0.05 N m, by parameter name: the QEMU
/// build's default plant and `commission --sim`'s default with `coulomb_friction:tc=0.05`.
pub const PAPER_WITH_FRICTION: [(&str, f32); 6] = [
    ("ra", 3.412),
    ("la", 0.0573),
    ("j", 0.0424),
    ("b", 0.00267),
    ("kv", 0.1604),
    ("tc", 0.05),
];

/// Every parameter of `motor` within 3 % in the report `r` (its `params`).
pub fn assert_within_3_percent(r: &Value, motor: &[(&str, f32)]) {
    for (name, truth) in motor {
        let got = param(r, name);
        assert!(
            (got / *truth as f64 - 1.0).abs() < 0.03,
            "{name}: {got} vs {truth}: {r}"
        );
    }
}

/// A record for the board: 2,000 samples of the paper's motor (steps, 100 Hz, 20 s) with
/// speed and current noise, written to `dir/board-record.csv`.
pub fn board_record(dir: &Path) -> PathBuf {
    steps_record(
        &dir.join("board-record.csv"),
        &["--noise-omega", "0.5", "--noise-current", "0.02"],
    )
}

/// A board-sized record at `path`: voltage steps at 100 Hz for 20 s (2,000 samples), seed
/// 4, with `extra` options of `simulate` (the motor, the noise, `--speed-only`).
pub fn steps_record(path: &Path, extra: &[&str]) -> PathBuf {
    let mut args = vec![
        "--profile",
        "steps",
        "--rate",
        "100",
        "--duration",
        "20",
        "--seed",
        "4",
    ];
    args.extend_from_slice(extra);
    simulate(path, &args);
    path.to_path_buf()
}

/// `motor-id diagnose --train TRAIN... --holdout HOLDOUT... EXTRA --json REPORT -q`,
/// required to succeed; returns the JSON report and the text printed.
pub fn diagnose<P: AsRef<Path>>(
    train: &[P],
    holdout: &[P],
    extra: &[&str],
    report: &Path,
) -> (Value, String) {
    let text = |p: &P| p.as_ref().display().to_string();
    let (train, holdout): (Vec<String>, Vec<String>) = (
        train.iter().map(text).collect(),
        holdout.iter().map(text).collect(),
    );
    let mut args = vec!["diagnose", "--train"];
    args.extend(train.iter().map(String::as_str));
    args.push("--holdout");
    args.extend(holdout.iter().map(String::as_str));
    args.extend_from_slice(extra);
    args.extend(["--json", s(report), "-q"]);
    let printed = run_ok(&args);
    (json(report), printed)
}

/// The names of the effects a diagnosis `verdict` names (`verdict.effects`), in order.
pub fn named_effects(verdict: &Value) -> Vec<String> {
    verdict["effects"]
        .as_array()
        .expect("verdict.effects")
        .iter()
        .map(|e| e["name"].as_str().expect("effect name").to_string())
        .collect()
}

/// The partial stand-ins of a diagnosis `verdict` (`verdict.partial`): each one's name and
/// why it is not named, in order.
pub fn partial_stand_ins(verdict: &Value) -> Vec<(String, String)> {
    verdict["partial"]
        .as_array()
        .expect("verdict.partial")
        .iter()
        .map(|p| {
            let text = |k: &str| {
                p[k].as_str()
                    .expect("a stand-in's name and why")
                    .to_string()
            };
            (text("name"), text("why"))
        })
        .collect()
}

/// `motor-id simulate ARGS --out OUT`.
pub fn simulate(out: &Path, args: &[&str]) {
    let mut all = vec!["simulate"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", s(out)]);
    run_ok(&all);
}

/// Read a JSON file.
pub fn json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).expect("read JSON report");
    serde_json::from_str(&text).expect("valid JSON")
}

/// A parameter value from a report's `params`.
pub fn param(report: &Value, name: &str) -> f64 {
    report["params"][name]
        .as_f64()
        .unwrap_or_else(|| panic!("params.{name} missing in {report}"))
}

/// Relative error.
pub fn rel(a: f64, b: f64) -> f64 {
    (a / b - 1.0).abs()
}

/// The real lab-motor data directory (`../shared/realdata/fibo-lab-motor` beside the
/// repository: the project's shared folder holds it; it is not part of the repository).
/// Missing under CI (`CI` set) it is a failure; elsewhere the test says loudly, in one line
/// on the terminal, that it was not run and why, and returns `None`.
pub fn realdata() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../shared/realdata/fibo-lab-motor");
    if dir.join("step_1.csv").exists() {
        return Some(dir);
    }
    let why = format!(
        "real lab-motor data not found at {} (the project's shared/ folder must sit beside the repository)",
        dir.display()
    );
    assert!(std::env::var_os("CI").is_none(), "{why}");
    // Straight to the terminal: the test harness captures eprintln! of a passing test.
    let _ = writeln!(std::io::stderr(), "NOT RUN: {why}");
    None
}

/// Path as &str.
pub fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 path")
}

/// Build the firmware (`firmware/`, its own workspace) in release with `args` (features),
/// in `firmware/<target_dir>`; returns the ELF.
pub fn build_firmware(args: &[&str], target_dir: &str) -> PathBuf {
    require_flip_link();
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../firmware");
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    // Cargo reads firmware/.cargo/config.toml (target, linker scripts) from there only.
    let status = Command::new(cargo)
        .current_dir(&dir)
        .env_remove("CARGO_TARGET_DIR")
        .args([
            "build",
            "--quiet",
            "--locked",
            "--release",
            "--target-dir",
            target_dir,
        ])
        .args(args)
        .status()
        .expect("run cargo build in firmware/");
    assert!(status.success(), "firmware build {args:?} failed");
    let elf = dir
        .join(target_dir)
        .join("thumbv7em-none-eabihf/release/motor-id-firmware");
    assert!(elf.exists(), "{} missing", elf.display());
    elf
}

/// The firmware links with flip-link (`firmware/.cargo/config.toml`): its absence is a
/// failure in one line, not a linker error deep in cargo's output, and never a skip.
fn require_flip_link() {
    let found = Command::new("flip-link")
        .arg("--help")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|status| status.success());
    assert!(
        found,
        "flip-link is missing: the firmware links with it; `cargo xtask test` installs it (or `cargo install flip-link --locked`)"
    );
}

/// The firmware's QEMU build (`--features qemu`, in its own target directory so that the
/// board build is not overwritten), built once per test run.
pub fn firmware_elf() -> &'static Path {
    static ELF: OnceLock<PathBuf> = OnceLock::new();
    ELF.get_or_init(|| {
        build_firmware(
            &["--no-default-features", "--features", "qemu"],
            "target/qemu",
        )
    })
}

/// The firmware running in `qemu-system-arm -M netduinoplus2`, its USART1 on a
/// pseudo-terminal; killed when dropped. QEMU missing is a failure, not a skip.
pub struct Qemu {
    child: std::process::Child,
    /// The pseudo-terminal of the board's serial port.
    pub pty: String,
    /// Plain-text lines the firmware writes to semihosting stderr (footprint meter).
    pub stderr: std::sync::mpsc::Receiver<String>,
}

impl Qemu {
    /// Start the firmware.
    pub fn start() -> Qemu {
        Qemu::start_with(&[])
    }

    /// Start the firmware with extra QEMU arguments (e.g. `-icount shift=0`).
    pub fn start_with(extra: &[&str]) -> Qemu {
        Qemu::start_full(&[], extra)
    }

    /// Start the firmware with its simulated motor's parameters `plant` (`("j", 0.001)`, ...)
    /// in place of the default's, given on QEMU's semihosting command line (the QEMU build's
    /// `plant_args`): one binary, any motor.
    pub fn with_plant(plant: &[(&str, f32)]) -> Qemu {
        Qemu::start_full(plant, &[])
    }

    /// [`Qemu::with_plant`] with extra QEMU arguments (e.g. `-icount shift=0`).
    pub fn with_plant_and(plant: &[(&str, f32)], extra: &[&str]) -> Qemu {
        Qemu::start_full(plant, extra)
    }

    fn start_full(plant: &[(&str, f32)], extra: &[&str]) -> Qemu {
        use std::io::BufRead;
        let elf = firmware_elf();
        let mut child = Command::new("qemu-system-arm")
            .args([
                "-M",
                "netduinoplus2",
                "-nographic",
                "-monitor",
                "none",
                "-serial",
                "pty",
            ])
            .arg("-semihosting-config")
            .arg(semihosting_config(plant))
            .args(extra)
            .arg("-kernel")
            .arg(elf)
            .stdin(std::process::Stdio::null())
            // QEMU names the pseudo-terminal on its standard output, where the firmware's
            // binary defmt log follows.
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("qemu-system-arm is missing: `cargo xtask test` installs it (or `apt-get install qemu-system-arm`)");
        let mut stdout = std::io::BufReader::new(child.stdout.take().expect("piped stdout"));
        let pty = loop {
            let mut line = Vec::new();
            let n = stdout
                .read_until(b'\n', &mut line)
                .expect("read QEMU's output");
            assert!(n > 0, "QEMU exited before opening its serial port");
            let line = String::from_utf8_lossy(&line);
            if let Some(at) = line.find("/dev/pts/") {
                let rest = &line[at..];
                break rest.split_whitespace().next().unwrap_or(rest).to_string();
            }
        };
        // Keep draining both outputs so that QEMU never blocks on them.
        std::thread::spawn(move || std::io::copy(&mut stdout, &mut std::io::sink()));
        let stderr = std::io::BufReader::new(child.stderr.take().expect("piped stderr"));
        let (tx, rx) = std::sync::mpsc::channel();
        std::thread::spawn(move || {
            for line in stderr.lines().map_while(Result::ok) {
                let _ = tx.send(line);
            }
        });
        Qemu {
            child,
            pty,
            stderr: rx,
        }
    }
}

/// QEMU's semihosting configuration with `plant` as the command line's arguments (after the
/// program's name), one `name=0x<bits of the f32>` each (what the QEMU build reads).
fn semihosting_config(plant: &[(&str, f32)]) -> String {
    let mut config = String::from("enable=on,target=native,arg=motor-id-firmware");
    for (name, value) in plant {
        config += &format!(",arg={name}={:#010x}", value.to_bits());
    }
    config
}

impl Qemu {
    /// The processor time QEMU has used so far (user and system, from
    /// `/proc/PID/stat`): the emulated board's work, which a loaded machine slows down in
    /// wall time but not in this. Test deadlines count in it, so that they follow the work
    /// and not the machine's load.
    pub fn cpu_time(&self) -> Duration {
        let stat = std::fs::read_to_string(format!("/proc/{}/stat", self.child.id()))
            .expect("QEMU's /proc/PID/stat (the tests run on Linux)");
        // Fields after the command name in parentheses: state is field 3, utime 14, stime 15.
        let rest = &stat[stat.rfind(')').expect("stat's command field") + 2..];
        let fields: Vec<&str> = rest.split_whitespace().collect();
        let ticks: u64 =
            fields[11].parse::<u64>().expect("utime") + fields[12].parse::<u64>().expect("stime");
        Duration::from_secs_f64(ticks as f64 / clock_ticks_per_second())
    }

    /// Wait while `pending` holds, until QEMU has spent `budget` of processor time (or ten
    /// times that in wall time, should QEMU be stopped altogether); true when `pending`
    /// ended first.
    pub fn within_work(&self, budget: Duration, mut pending: impl FnMut() -> bool) -> bool {
        let (cpu0, wall0) = (self.cpu_time(), Instant::now());
        while pending() {
            if self.cpu_time() - cpu0 > budget || wall0.elapsed() > 10 * budget {
                return false;
            }
        }
        true
    }

    /// `motor-id board --port PTY --timeout T ARGS`: the board command against this QEMU,
    /// with a reply timeout of 30 s, far above what the emulated board needs on a quiet
    /// machine (the CLI's default 10 s is for a real board, which no host load slows down;
    /// a busy board answers Busy at every iteration of its job, which restarts the wait).
    /// (QEMU's pseudo-terminal drops what the board sends until it has noticed a new
    /// command's open port, within a second: the host repeats its `Hello` every 0.5 s.)
    pub fn board_args<'a>(&'a self, args: &[&'a str]) -> Vec<&'a str> {
        let mut all = vec!["board", "--port", self.pty.as_str(), "--timeout", "30"];
        all.extend_from_slice(args);
        all
    }
}

/// `getconf CLK_TCK`: the unit of `/proc/PID/stat`'s times (100 on Linux's usual builds).
fn clock_ticks_per_second() -> f64 {
    static TCK: OnceLock<f64> = OnceLock::new();
    *TCK.get_or_init(|| {
        Command::new("getconf")
            .arg("CLK_TCK")
            .output()
            .ok()
            .and_then(|o| String::from_utf8(o.stdout).ok())
            .and_then(|s| s.trim().parse().ok())
            .unwrap_or(100.0)
    })
}

impl Drop for Qemu {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
