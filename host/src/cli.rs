//! Command-line interface (DESIGN.md contract).

use crate::{board_cmd, diagnose, identify_cmd, simulate_cmd};
use anyhow::Result;
use clap::{Args, Parser, Subcommand};

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
    Simulate(simulate_cmd::SimulateArgs),
    /// Identify motor parameters from one or more record CSVs (fitted jointly).
    Identify(identify_cmd::IdentifyArgs),
    /// Convert an oscilloscope CSV of tacho volts into a record CSV (the seed's workflow).
    ImportScope(identify_cmd::ScopeArgs),
    /// Locate the sim-to-real gap: where the model misfits, which unmodelled effect causes it,
    /// how far the misfit shrinks with it, judged on held-out records.
    Diagnose(diagnose::DiagnoseArgs),
    /// Talk to a drive board (or its QEMU build) over a serial port.
    Board(board_cmd::BoardArgs),
    /// Run the whole job on a built-in default: the seed's motor, simulated, identified from
    /// speed only (seed workflow) and from speed and current.
    Demo(identify_cmd::DemoArgs),
}

/// Options shared by the fitting commands.
#[derive(Args, Debug, Clone, Default)]
pub struct FitOptions {
    /// Search bounds, e.g. `ra=0.5:10,j=1e-6:1e-3` (default: seed Table 1). Bounds on an
    /// effect parameter (e.g. `tc=0:0.1`) fit that effect.
    #[arg(long, value_name = "P=LO:HI,...")]
    pub bounds: Vec<String>,
    /// Hold parameters at known values, e.g. `ra=3.4,la=0.00285`.
    #[arg(long, value_name = "P=V,...")]
    pub fix: Vec<String>,
    /// Random seed (same seed and data, same result).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Ignore the current column (fit speed only, as the seed does).
    #[arg(long)]
    pub speed_only: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run a parsed command line.
pub fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::Simulate(a) => simulate_cmd::run(&a),
        Command::Identify(a) => identify_cmd::run(&a),
        Command::ImportScope(a) => identify_cmd::import_scope(&a),
        Command::Demo(a) => identify_cmd::demo(&a),
        Command::Diagnose(a) => diagnose::run(&a),
        Command::Board(a) => board_cmd::run(&a),
    }
}
