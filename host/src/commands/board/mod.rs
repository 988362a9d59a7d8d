//! `motor-id board --port PORT <hello | identify F.csv | commission | params | clear | config
//! | record>`: drive a board (or its QEMU build) over a serial port with the frames of
//! `motor_id_shared::wire::frame`. The link itself is [`connection`]; records to and from
//! the board are [`transfer`].

mod connection;
mod transfer;

use crate::board_records::{check_out_dir, write_records};
use crate::csvio::OwnedRecord;
use crate::fit::PipelineArg;
use crate::limits_args::{limits_text, LimitArgs};
use crate::output::write_json;
use crate::report::board::{unpinned_reasons, BoardReport};
use anyhow::{anyhow, Result};
use clap::{Args, Subcommand};
use connection::{follow_job, hello, refused, Connection, ERASE_ALLOWANCE};
use motor_id_shared::wire::limits::Limits;
use motor_id_shared::wire::protocol::{
    BoardMessage, HostMessage, MotorReport, NotStored, PROTOCOL_VERSION,
};
use std::path::PathBuf;
use std::time::Duration;

/// Longest record this host reads back from a board [samples] (a board holds 2,000; a
/// board that announces more is refused before the host allocates for it).
const MAX_BOARD_SAMPLES: usize = 1 << 20;

/// Arguments of `board`.
#[derive(Args, Debug)]
pub struct BoardArgs {
    /// Serial port of the board (a pseudo-terminal for the QEMU build).
    #[arg(long)]
    pub port: String,
    /// Baud rate (300 to 12,000,000).
    #[arg(long, global = true, default_value_t = 115_200, value_parser = clap::value_parser!(u32).range(300..=12_000_000))]
    pub baud: u32,
    /// Seconds to wait for each reply, at most a day (progress frames that show the job
    /// advancing restart the clock); a board busy with a job (commissioning at power-up) is
    /// waited for up to six times as long.
    #[arg(long, global = true, default_value_t = 10.0, value_parser = parse_timeout)]
    pub timeout: f64,
    /// Random seed of identifications.
    #[arg(long, global = true, default_value_t = 1)]
    pub seed: u64,
    /// Write the result as JSON here: `params`, `rmse_omega`, `evaluations` and
    /// `identifiability {rank, free, parameters}` (what a board reports; see
    /// docs/CONTRACTS.md).
    #[arg(long, global = true)]
    pub json: Option<PathBuf>,
    /// No progress bar.
    #[arg(long, short, global = true)]
    pub quiet: bool,
    #[command(subcommand)]
    pub action: BoardAction,
}

/// What to ask the board.
#[derive(Subcommand, Debug)]
pub enum BoardAction {
    /// Open a session and show the board's protocol version.
    Hello,
    /// Stream a record to the board and identify it there (the same answer, bit for bit, as
    /// `motor-id identify` with the same seed and pipeline).
    Identify {
        /// Record CSV (t, v, omega, optional i).
        file: PathBuf,
        /// Pipeline, as for `motor-id identify` (a board refuses `paper`: its population of 100
        /// does not fit the board's memory).
        #[arg(long, value_enum, default_value_t = PipelineArg::Default)]
        pipeline: PipelineArg,
    },
    /// Run self-commissioning (probe, designed experiment, identification, store) within the
    /// board's limits (`board config`).
    Commission,
    /// Show the stored parameters.
    Params,
    /// Erase the stored parameters (the limits stay).
    Clear,
    /// Show the limits commissioning works within, or set those given (stored on the board
    /// beside the parameters; the others keep the board's values).
    Config {
        #[command(flatten)]
        limits: LimitArgs,
    },
    /// Download the records the board holds (its commissioning experiment's slow and fast
    /// records, or the record streamed in) as record CSVs with their `bridge` column, for
    /// `identify`, `validate` and `diagnose`.
    Record {
        /// Directory to write `slow.csv` and `fast.csv` (or `record-1.csv`) into.
        #[arg(long, value_name = "DIR")]
        out_dir: PathBuf,
    },
}

/// `--timeout`: seconds above 0 and at most [`MAX_TIMEOUT_S`] (a usage error otherwise,
/// exit status 2; a longer one would overflow the deadlines' clock).
fn parse_timeout(text: &str) -> std::result::Result<f64, String> {
    match text.trim().parse::<f64>() {
        Ok(t) if t > 0.0 && t <= MAX_TIMEOUT_S => Ok(t),
        _ => Err(format!(
            "expected a number of seconds above 0 and at most {MAX_TIMEOUT_S} (a day)"
        )),
    }
}

/// Longest `--timeout` [s].
const MAX_TIMEOUT_S: f64 = 86_400.0;

/// Run `board`.
pub fn run(a: &BoardArgs) -> Result<()> {
    // Everything that can be checked without the board is checked before the port opens.
    let record = match &a.action {
        BoardAction::Identify { file, .. } => Some(OwnedRecord::read(file)?),
        BoardAction::Record { out_dir } => {
            check_out_dir(out_dir)?;
            None
        }
        _ => None,
    };
    connection::listen_for_ctrl_c();
    let timeout = Duration::from_secs_f64(a.timeout);
    let mut c = Connection::open(&a.port, a.baud, timeout)?;
    let max_samples = hello(&mut c)?;
    let report = match &a.action {
        BoardAction::Hello => {
            println!("board speaks protocol version {PROTOCOL_VERSION}, holds records of up to {max_samples} samples");
            return Ok(());
        }
        BoardAction::Identify { pipeline, .. } => {
            let rec = record.as_ref().expect("read above");
            transfer::upload(&mut c, rec, max_samples)?;
            c.send(&HostMessage::Identify {
                seed: a.seed,
                pipeline: (*pipeline).into(),
            })?;
            follow_job(&mut c, a.quiet, Duration::ZERO)?.0
        }
        BoardAction::Commission => {
            c.send(&HostMessage::Commission { seed: a.seed })?;
            // Commissioning stores its result: the board erases its parameter sector
            // before it answers.
            let (report, plan) = follow_job(&mut c, a.quiet, ERASE_ALLOWANCE)?;
            // The host does not know the board's ADC count: no parameter is said to lie
            // below it (such a one reads as not separated by the records).
            let unpinned =
                plan.map_or_else(Default::default, |p| unpinned_reasons(&report, &p, 0.0));
            let out = BoardReport::new(&report)?.with_unpinned(unpinned);
            return print_board_report(&out, a);
        }
        BoardAction::Params => match read_params(&mut c)? {
            Ok(r) => r,
            Err(why) => {
                println!("{why}: the board commissions at its next power-up");
                remove_stale_report(a.json.as_deref())?;
                return Ok(());
            }
        },
        BoardAction::Clear => {
            // The board erases its parameter sector before it answers.
            let wait = c.timeout + ERASE_ALLOWANCE;
            c.request_every(&HostMessage::ClearParams, wait, 3, |reply| match reply {
                BoardMessage::Cleared => Some(Ok(())),
                other => refused(&other),
            })?;
            println!("stored parameters erased");
            return Ok(());
        }
        BoardAction::Config { limits } => return config(&mut c, limits, a),
        BoardAction::Record { out_dir } => {
            let records = transfer::download(&mut c)?;
            if records.is_empty() {
                return Err(anyhow!(
                    "the board holds no record: commission it (or stream a record) first"
                ));
            }
            for path in write_records(out_dir, &records)? {
                println!("wrote {}", path.display());
            }
            return Ok(());
        }
    };
    print_board_report(&BoardReport::new(&report)?, a)
}

/// Print `report` and write it to `--json`.
fn print_board_report(report: &BoardReport, a: &BoardArgs) -> Result<()> {
    print!("{}", report.text());
    if let Some(path) = &a.json {
        write_json(path, report)?;
    }
    Ok(())
}

/// A `--json` report of an earlier run, removed when this run has none to write (the board
/// holds no parameters), so that old values are never read as the board's; says so.
fn remove_stale_report(path: Option<&std::path::Path>) -> Result<()> {
    let Some(path) = path else { return Ok(()) };
    match std::fs::remove_file(path) {
        Ok(()) => {
            eprintln!(
                "removed the earlier report {}: the board holds no parameters",
                path.display()
            );
            Ok(())
        }
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(e) => Err(anyhow!(
            "cannot remove the earlier report {}: {e}",
            path.display()
        )),
    }
}

/// The stored parameters, or why there are none.
fn read_params(c: &mut Connection) -> Result<Result<MotorReport, NotStored>> {
    c.request(&HostMessage::ReadParams, |reply| match reply {
        BoardMessage::Params(p) => Some(Ok(p)),
        other => refused(&other).map(|r| r.map(|_| Err(NotStored::Empty))),
    })
}

/// `board config`: read the board's limits, set the ones given over them, show the result
/// (and write it as JSON with `--json`).
fn config(c: &mut Connection, given: &LimitArgs, a: &BoardArgs) -> Result<()> {
    let mut limits = request_limits(c, &HostMessage::ReadLimits, Duration::ZERO)?;
    if given.any() {
        // The board erases its parameter sector to store them before it answers.
        let set = HostMessage::Configure(given.over(limits));
        limits = request_limits(c, &set, ERASE_ALLOWANCE)?;
    }
    println!("{}", limits_text(&limits));
    if let Some(path) = &a.json {
        write_json(path, &limits)?;
    }
    Ok(())
}

/// Send `msg` and take the board's limits in reply, waiting `allowance` more than the timeout.
fn request_limits(c: &mut Connection, msg: &HostMessage, allowance: Duration) -> Result<Limits> {
    let wait = c.timeout + allowance;
    c.request_every(msg, wait, 3, |reply| match reply {
        BoardMessage::Limits(l) => Some(Ok(l)),
        other => refused(&other).map(|r| r.map(|_| Limits::DEFAULT)),
    })
}

#[cfg(test)]
mod tests;
