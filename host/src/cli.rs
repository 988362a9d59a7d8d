//! The command-line tree (docs/CONTRACTS.md) and its dispatch to the commands.

use crate::commands::{
    board, commission, compare, demo, diagnose, identify, import_scope, simulate, tune, validate,
};
use anyhow::{bail, Result};
use clap::{CommandFactory, FromArgMatches, Parser, Subcommand};
use std::path::Path;

/// Identify DC motor parameters (Ra, La, J, B, Kv and effects) from speed (and current) records.
#[derive(Parser, Debug)]
#[command(name = "motor-id", version, about)]
pub struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Simulate an experiment on a motor and write a record CSV.
    Simulate(simulate::SimulateArgs),
    /// Identify motor parameters from one or more record CSVs (fitted jointly).
    Identify(identify::IdentifyArgs),
    /// Convert an oscilloscope CSV of tacho volts into a record CSV (the paper's workflow).
    ImportScope(import_scope::ScopeArgs),
    /// Locate the sim-to-real gap: where the model misfits, which unmodelled effect causes it,
    /// how far the misfit shrinks with it, judged on held-out records.
    Diagnose(diagnose::DiagnoseArgs),
    /// Check identified parameters on new records (paper's Figs. 11-14): the prediction's
    /// misfit against each record's noise, and where it misfits most.
    Validate(validate::ValidateArgs),
    /// Current-loop and speed-loop PI gains from identified parameters, with their step
    /// responses on the identified model.
    Tune(tune::TuneArgs),
    /// Compare optimisers on the same records, objective and budget (paper's Table 3).
    Compare(compare::CompareArgs),
    /// Talk to a drive board (or its QEMU build) over a serial port.
    Board(board::BoardArgs),
    /// Commission a simulated motor on the virtual board: the board's own probe, experiment
    /// and fit, run on the host (try a motor and the limits before flashing a board).
    Commission(commission::CommissionArgs),
    /// Run the whole job on a built-in default: the paper's motor, simulated, identified from
    /// speed only (the paper's workflow) and from speed and current.
    Demo(demo::DemoArgs),
}

/// Parse the command line. Every command and subcommand takes negative numbers as option
/// values (`--x -35`, not only `--x=-35`).
pub fn try_parse() -> Result<Cli, clap::Error> {
    fn negatives(c: clap::Command) -> clap::Command {
        c.allow_negative_numbers(true).mut_subcommands(negatives)
    }
    let matches = negatives(Cli::command()).try_get_matches()?;
    Cli::from_arg_matches(&matches).map_err(|e| e.format(&mut Cli::command()))
}

/// A check that ran and failed (`validate`: the parameters do not predict the records to
/// their noise floor): exit status 3, apart from the errors of status 1 (docs/CONTRACTS.md).
#[derive(Debug)]
pub struct CheckFailed(pub String);

impl std::fmt::Display for CheckFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for CheckFailed {}

/// Run a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    let (inputs, outputs, plots) = paths(&cli.command);
    crate::output::check_paths(&inputs, &outputs)?;
    for plot in plots {
        if !plot
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("png"))
        {
            bail!(
                "cannot plot to {}: plots are PNG, name it *.png",
                plot.display()
            );
        }
    }
    match cli.command {
        Command::Simulate(a) => simulate::run(&a),
        Command::Identify(a) => identify::run(&a),
        Command::ImportScope(a) => import_scope::run(&a),
        Command::Demo(a) => demo::run(&a),
        Command::Diagnose(a) => diagnose::run(&a),
        Command::Board(a) => board::run(&a),
        Command::Commission(a) => commission::run(&a),
        Command::Validate(a) => validate::run(&a),
        Command::Tune(a) => tune::run(&a),
        Command::Compare(a) => compare::run_compare(&a),
    }
}

/// The files a command reads, the files it writes and (among those) its plots, checked
/// before any work ([`crate::output::check_paths`]): a typo in an output path must not lose
/// a long run, and no output may replace an input.
fn paths(command: &Command) -> (Vec<&Path>, Vec<&Path>, Vec<&Path>) {
    let mut inputs: Vec<&Path> = Vec::new();
    let mut json = None;
    let mut plot = None;
    let mut other = None;
    match command {
        Command::Simulate(a) => other = Some(a.out.as_path()),
        Command::Identify(a) => {
            inputs.extend(a.files.iter().map(|p| p.as_path()));
            (json, plot) = (a.json.as_deref(), a.plot.as_deref());
        }
        Command::ImportScope(a) => {
            inputs.push(&a.file);
            other = Some(a.out.as_path());
        }
        Command::Demo(_) => {}
        Command::Diagnose(a) => {
            inputs.extend(a.train.iter().chain(&a.holdout).map(|p| p.as_path()));
            (json, plot) = (a.json.as_deref(), a.plot.as_deref());
        }
        Command::Board(a) => {
            if let board::BoardAction::Identify { file, .. } = &a.action {
                inputs.push(file);
            }
            json = a.json.as_deref();
        }
        Command::Commission(a) => json = a.json.as_deref(),
        Command::Validate(a) => {
            inputs.push(&a.params);
            inputs.extend(a.files.iter().map(|p| p.as_path()));
            (json, plot) = (a.json.as_deref(), a.plot.as_deref());
        }
        Command::Tune(a) => {
            inputs.push(&a.params);
            (json, plot) = (a.json.as_deref(), a.plot.as_deref());
        }
        Command::Compare(a) => {
            inputs.extend(a.files.iter().map(|p| p.as_path()));
            (json, plot) = (a.json.as_deref(), a.plot.as_deref());
        }
    }
    let outputs = [json, plot, other].into_iter().flatten().collect();
    (inputs, outputs, plot.into_iter().collect())
}
