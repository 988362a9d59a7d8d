//! The project's tasks, run as `cargo xtask <task>` (the alias is in `.cargo/config.toml`):
//!
//! - `cargo xtask test [ARGS]`: installs what the tests need and a fresh machine lacks (the
//!   board's target, the firmware's linker flip-link, QEMU for the firmware tests), then runs
//!   `cargo test --workspace --locked [ARGS]`, the tests `.ci/run` runs;
//! - `cargo xtask setup`: the installation alone.
//!
//! What cannot be installed from here (QEMU without the rights to run the system's package
//! manager) ends the task with one line naming the command that installs it: a test is never
//! skipped because a tool is missing.

mod setup;

use std::process::{Command, ExitCode};

const USAGE: &str = "usage: cargo xtask <test [CARGO TEST ARGS] | setup>";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("test") => setup::install_missing().and_then(|()| run_tests(&args[1..])),
        Some("setup") if args.len() == 1 => setup::install_missing(),
        Some("help" | "-h" | "--help") => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        _ => {
            eprintln!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("xtask: {message}");
            ExitCode::FAILURE
        }
    }
}

/// The workspace's tests, with the extra arguments given (e.g. a test name, `-- --nocapture`).
fn run_tests(extra: &[String]) -> Result<(), String> {
    let status = Command::new(setup::cargo())
        .args(["test", "--workspace", "--locked"])
        .args(extra)
        .status()
        .map_err(|e| format!("cargo test could not start: {e}"))?;
    match status.success() {
        true => Ok(()),
        false => Err(format!("cargo test failed ({status})")),
    }
}
