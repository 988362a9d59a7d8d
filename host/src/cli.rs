//! The command-line tree (docs/CONTRACTS.md) and its dispatch to the commands.

use crate::commands::{
    board, commission, compare, demo, diagnose, identify, import_scope, simulate, tune, validate,
};
use anyhow::Result;
use clap::{Parser, Subcommand};

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
    /// speed only (seed workflow) and from speed and current.
    Demo(demo::DemoArgs),
}

/// Run a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
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
