//! `motor-id import-scope`: an oscilloscope CSV of tacho volts converted into a record CSV
//! (the paper's workflow).

use crate::csvio::{import_scope as read_scope, ScopeImport};
use anyhow::{anyhow, Result};
use clap::Args;
use std::path::PathBuf;

/// Arguments of `import-scope`.
#[derive(Args, Debug)]
pub struct ScopeArgs {
    /// Oscilloscope CSV (time and channel columns; header and settings lines are skipped).
    pub file: PathBuf,
    /// Output record CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Tacho gain [rad/s per V] (the paper's tacho: 35).
    #[arg(long)]
    pub tacho_gain: f32,
    /// The trace was captured with the scope's inverted option: negate it.
    #[arg(long)]
    pub inverted: bool,
    /// Armature voltage applied [V].
    #[arg(long)]
    pub voltage: f32,
    /// Time at which the voltage was switched on [s] (before it: 0 V).
    #[arg(long, default_value_t = 0.0)]
    pub step_at: f64,
    /// Zero-based column of time.
    #[arg(long, default_value_t = 0)]
    pub time_column: usize,
    /// Zero-based column of the tacho channel.
    #[arg(long, default_value_t = 1)]
    pub channel: usize,
    /// No message on stderr.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `import-scope`.
pub fn run(a: &ScopeArgs) -> Result<()> {
    if !(a.tacho_gain.is_finite() && a.tacho_gain != 0.0) {
        return Err(anyhow!("--tacho-gain must be a non-zero number"));
    }
    if !a.voltage.is_finite() || !a.step_at.is_finite() {
        return Err(anyhow!("--voltage and --step-at must be finite"));
    }
    let s = ScopeImport {
        gain: a.tacho_gain,
        inverted: a.inverted,
        time_column: a.time_column,
        channel: a.channel,
        voltage: a.voltage,
        step_at: a.step_at,
    };
    let rec = read_scope(&a.file, &s)?;
    rec.write_showing(&a.out, a.quiet)?;
    if a.quiet {
        return Ok(());
    }
    eprintln!(
        "wrote {} samples at {} s step to {}",
        rec.len(),
        rec.dt,
        a.out.display()
    );
    Ok(())
}
