//! `motor-id`: identify DC motor parameters (paper: FFO on the speed RMSE, Eq. 7) from
//! recorded or simulated data, with an honest identifiability report.

mod board_records;
mod cli;
mod commands;
mod comparison;
mod csvio;
mod fit;
mod fit_plot;
mod hints;
mod interrupt;
mod limits_args;
mod output;
mod plot;
mod progress;
mod report;
mod simulation;
mod spec;
mod tuning;
mod validation;

use std::process::ExitCode;

fn main() -> ExitCode {
    interrupt::install();
    let args = match cli::try_parse() {
        Ok(a) => a,
        Err(e) => {
            // clap prints help/version to stdout (exit 0) and usage errors to stderr (exit 2).
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the whole context chain joined.
            let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            if e.downcast_ref::<cli::CheckFailed>().is_some() {
                eprintln!("motor-id: check failed: {}", msg.join(": "));
                return ExitCode::from(3);
            }
            eprintln!("motor-id: error: {}", msg.join(": "));
            ExitCode::FAILURE
        }
    }
}
