//! `motor-id simulate`: an experiment on a simulated motor, written as record CSV.

use crate::simulation::simulate;
pub use crate::simulation::SimulateArgs;
use anyhow::Result;

/// Run `simulate`.
pub fn run(a: &SimulateArgs) -> Result<()> {
    let rec = simulate(a)?;
    rec.write_showing(&a.out, a.quiet)?;
    if a.quiet {
        return Ok(());
    }
    eprintln!(
        "wrote {} samples ({} s at {} Hz) to {}",
        rec.len(),
        rec.time_text(rec.len()),
        a.rate,
        a.out.display()
    );
    Ok(())
}
