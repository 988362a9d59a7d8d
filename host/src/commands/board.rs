//! `motor-id board --port PORT <hello | identify F.csv | commission | params | clear>`: drive a
//! board (or its QEMU build) over a serial port with the frames of `motor_id_shared::wire::frame`.

use crate::csvio::OwnedRecord;
use crate::fit::PipelineArg;
use crate::output::write_json;
use crate::progress::{BarState, FitProgress};
use crate::report::board::{plan_text, BoardReport};
use anyhow::{anyhow, bail, Context, Result};
use clap::{Args, Subcommand};
use motor_id_shared::wire::frame::{encode, Decoder, MAX_FRAME};
use motor_id_shared::wire::protocol::{
    BoardMessage, HostMessage, MotorReport, NotStored, Refusal, CHUNK, PROTOCOL_VERSION,
};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

/// Arguments of `board`.
#[derive(Args, Debug)]
pub struct BoardArgs {
    /// Serial port of the board (a pseudo-terminal for the QEMU build).
    #[arg(long)]
    pub port: String,
    /// Baud rate.
    #[arg(long, global = true, default_value_t = 115_200)]
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
    /// Run self-commissioning (bounded experiment, identification, store).
    Commission,
    /// Show the stored parameters.
    Params,
    /// Erase the stored parameters.
    Clear,
}

/// A serial connection speaking frames.
struct Connection {
    port: Box<dyn serialport::SerialPort>,
    decoder: Decoder,
    /// Bytes read from the port and not yet decoded.
    unread: VecDeque<u8>,
    timeout: Duration,
}

impl Connection {
    fn open(a: &BoardArgs) -> Result<Connection> {
        let port = serialport::new(&a.port, a.baud)
            .timeout(Duration::from_millis(20))
            .open()
            .with_context(|| format!("cannot open serial port {}", a.port))?;
        Ok(Connection {
            port,
            decoder: Decoder::new(),
            unread: VecDeque::new(),
            timeout: Duration::from_secs_f64(a.timeout),
        })
    }

    fn send(&mut self, msg: &HostMessage) -> Result<()> {
        let mut out = [0u8; MAX_FRAME];
        let frame = encode(msg, &mut out).map_err(|e| anyhow!("{e}"))?;
        self.port.write_all(frame).context("serial write failed")?;
        self.port.flush().context("serial write failed")
    }

    /// The next message, or an error at `deadline`, `wait` after the request (also when
    /// frames keep coming: a message decoded after the deadline is not returned).
    fn receive_until(&mut self, deadline: Instant, wait: Duration) -> Result<BoardMessage> {
        let mut buf = [0u8; 256];
        loop {
            if INTERRUPTED.swap(false, Ordering::SeqCst) {
                return Err(anyhow::Error::new(Interrupted));
            }
            if Instant::now() > deadline {
                bail!(
                    "no answer from the board within {:.1} s",
                    wait.as_secs_f64()
                );
            }
            // Bytes read but not decoded yet first: one read may bring several frames (a
            // progress frame and the result, on a loaded machine), none of them lost.
            while let Some(b) = self.unread.pop_front() {
                // Corrupted frames are dropped; the request is repeated on timeout.
                if let Some(Ok(msg)) = self.decoder.push::<BoardMessage>(b) {
                    return Ok(msg);
                }
            }
            match self.port.read(&mut buf) {
                Ok(n) => self.unread.extend(&buf[..n]),
                // A signal (Ctrl-C) interrupts the read: the loop takes it above.
                Err(e)
                    if matches!(
                        e.kind(),
                        std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted
                    ) => {}
                Err(e) => return Err(anyhow!("serial read failed: {e}")),
            }
        }
    }

    /// Send `msg` and wait for a reply that `accept` takes, repeating the request (up to three
    /// times) when nothing comes back within the timeout, as after a corrupted frame. A
    /// board busy with a job (commissioning at power-up, say) is asked again every 0.2 s for
    /// up to [`BUSY_TIMEOUTS`] timeouts, which count no repeat; then its `Busy` is the answer.
    fn request<T>(
        &mut self,
        msg: &HostMessage,
        accept: impl FnMut(BoardMessage) -> Option<Result<T>>,
    ) -> Result<T> {
        self.request_every(msg, self.timeout, 3, accept)
    }

    /// As [`Connection::request`], waiting `every` for each reply and sending the request
    /// up to `tries` times.
    fn request_every<T>(
        &mut self,
        msg: &HostMessage,
        every: Duration,
        tries: u32,
        mut accept: impl FnMut(BoardMessage) -> Option<Result<T>>,
    ) -> Result<T> {
        let busy_until = Instant::now() + self.timeout * BUSY_TIMEOUTS;
        let mut silent = 0;
        while silent < tries {
            self.send(msg)?;
            // One deadline per request: replies it does not take (a stray progress frame,
            // say) do not extend it.
            let deadline = Instant::now() + every;
            loop {
                match self.receive_until(deadline, every) {
                    Ok(BoardMessage::Refused(Refusal::Busy)) if Instant::now() < busy_until => {
                        std::thread::sleep(Duration::from_millis(200));
                        break;
                    }
                    Ok(reply) => {
                        if let Some(r) = accept(reply) {
                            return r;
                        }
                    }
                    Err(e) if e.is::<Interrupted>() => {
                        bail!("interrupted: no job was running on the board")
                    }
                    Err(_) => {
                        silent += 1;
                        break;
                    }
                }
            }
        }
        bail!(
            "no answer from the board within {:.1} s ({tries} requests)",
            every.as_secs_f64() * f64::from(tries)
        )
    }
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

/// How often `Hello`, the first request on a port just opened, is repeated while nothing
/// comes back.
const HELLO_EVERY: Duration = Duration::from_millis(500);

/// A board's erase of its parameter sector stalls it (no reply, no progress) for up to 4 s
/// (docs/CONTRACTS.md): a reply that follows one (a commissioning's result, which it
/// stores; the answer to `clear`) is waited for this much longer than `--timeout`.
const ERASE_ALLOWANCE: Duration = Duration::from_secs(5);

/// How many `--timeout`s a busy board is waited for.
const BUSY_TIMEOUTS: u32 = 6;

fn refused(reply: &BoardMessage) -> Option<Result<()>> {
    match reply {
        BoardMessage::Refused(r) => Some(Err(anyhow!("the board refused: {r}"))),
        _ => None,
    }
}

fn hello(c: &mut Connection) -> Result<u32> {
    let hello = HostMessage::Hello {
        version: PROTOCOL_VERSION,
    };
    // Repeated often, at no cost: a port just opened may not pass the first reply on
    // (QEMU's pseudo-terminal drops what the board sends until it has noticed the host,
    // within a second; a board that resets when its port is opened is not listening yet).
    // For as long as three timeouts, and a board busy storing its parameters (after its
    // power-up commissioning) answers nothing while it erases.
    let every = HELLO_EVERY.min(c.timeout);
    let patience = c.timeout * 3 + ERASE_ALLOWANCE;
    let tries = (patience.as_secs_f64() / every.as_secs_f64()).ceil() as u32;
    c.request_every(&hello, every, tries, |reply| match reply {
        BoardMessage::Hello { version, max_samples } if version == PROTOCOL_VERSION => Some(Ok(max_samples)),
        BoardMessage::Refused(Refusal::VersionMismatch { board: version })
        | BoardMessage::Hello { version, .. } => Some(Err(anyhow!(
            "protocol mismatch: the board speaks protocol {version}, this host speaks {PROTOCOL_VERSION}; update one of them"
        ))),
        other => refused(&other).map(|r| r.map(|_| 0)),
    })
}

/// Wait for the end of a long job, showing its progress; `allowance` more than the timeout
/// after each frame for a job that stores its result ([`ERASE_ALLOWANCE`]).
fn follow_job(c: &mut Connection, quiet: bool, allowance: Duration) -> Result<MotorReport> {
    let bar = FitProgress::new(quiet);
    let wait = c.timeout + allowance;
    // The clock restarts only when a progress frame shows the job advancing: a board that
    // repeats itself, or sends frames that belong to no job, is timed out like a silent one.
    let mut deadline = Instant::now() + wait;
    let mut last = None;
    let out = loop {
        match c.receive_until(deadline, wait) {
            Ok(
                frame @ BoardMessage::Progress {
                    stage,
                    iteration,
                    evaluations,
                    ..
                },
            ) => {
                if last != Some((stage, iteration, evaluations)) {
                    last = Some((stage, iteration, evaluations));
                    deadline = Instant::now() + wait;
                }
                if let Some(state) = BarState::of_board(&frame) {
                    bar.show(&state);
                }
            }
            Ok(BoardMessage::Identified(report)) => break Ok(report),
            Ok(BoardMessage::Planned(plan)) => {
                if !quiet {
                    bar.println(&plan_text(&plan));
                }
            }
            Ok(BoardMessage::Aborted) => break Err(anyhow!("the board aborted the job")),
            Ok(BoardMessage::Refused(r)) => break Err(anyhow!("the board refused: {r}")),
            Ok(_) => {}
            Err(e) if e.is::<Interrupted>() => break Err(abort(c)),
            Err(e) => break Err(e),
        }
    };
    bar.finish();
    out
}

/// Ctrl-C was pressed while the host waited for the board.
#[derive(Debug)]
struct Interrupted;

impl std::fmt::Display for Interrupted {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("interrupted")
    }
}

impl std::error::Error for Interrupted {}

/// Set by Ctrl-C, taken by the loops that wait for the board.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// After Ctrl-C during a job: ask the board to abort it and wait (up to the timeout, or a
/// second Ctrl-C) for its answer, so that the board is not left running; the error to end
/// with.
fn abort(c: &mut Connection) -> anyhow::Error {
    if c.send(&HostMessage::Abort).is_err() {
        return anyhow!(
            "interrupted: the abort could not be sent; the board may still run its job"
        );
    }
    let deadline = Instant::now() + c.timeout;
    loop {
        match c.receive_until(deadline, c.timeout) {
            Ok(BoardMessage::Aborted) => return anyhow!("interrupted: the board aborted its job"),
            Ok(BoardMessage::Identified(_)) | Ok(BoardMessage::Refused(_)) => {
                return anyhow!("interrupted: the board had just ended its job")
            }
            Ok(_) => {}
            Err(_) => {
                return anyhow!(
                    "interrupted: the board did not confirm the abort; it may still run its job"
                )
            }
        }
    }
}

/// Run `board`.
pub fn run(a: &BoardArgs) -> Result<()> {
    // Ctrl-C while a job runs aborts it on the board (see `abort`), then ends here. A
    // handler that cannot be installed leaves Ctrl-C as it was.
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::SeqCst));
    let mut c = Connection::open(a)?;
    let max_samples = hello(&mut c)?;
    let report = match &a.action {
        BoardAction::Hello => {
            println!("board speaks protocol version {PROTOCOL_VERSION}, holds records of up to {max_samples} samples");
            return Ok(());
        }
        BoardAction::Identify { file, pipeline } => {
            let rec = OwnedRecord::read(file)?;
            if rec.len() > max_samples as usize {
                bail!(
                    "{}: {} samples, the board holds at most {max_samples}",
                    rec.name(),
                    rec.len()
                );
            }
            if rec.load.is_some() {
                bail!(
                    "{}: the board identifies voltage-driven records only (no tl column)",
                    rec.name()
                );
            }
            let with_current = rec.current.is_some();
            let begin = HostMessage::IdentifyBegin {
                dt: rec.dt,
                samples: rec.len() as u32,
                with_current,
            };
            c.request(&begin, |reply| match reply {
                BoardMessage::ChunkOk { next: 0 } => Some(Ok(())),
                other => refused(&other),
            })?;
            for start in (0..rec.len()).step_by(CHUNK) {
                let end = (start + CHUNK).min(rec.len());
                let take =
                    |x: &[f32]| heapless::Vec::from_slice(&x[start..end]).expect("chunk fits");
                let chunk = HostMessage::RecordChunk {
                    offset: start as u32,
                    v: take(&rec.v),
                    omega: take(&rec.omega),
                    current: rec.current.as_deref().map_or_else(heapless::Vec::new, take),
                };
                c.request(&chunk, |reply| match reply {
                    BoardMessage::ChunkOk { next } if next as usize == end => Some(Ok(())),
                    other => refused(&other),
                })?;
            }
            c.send(&HostMessage::Identify {
                seed: a.seed,
                pipeline: (*pipeline).into(),
            })?;
            follow_job(&mut c, a.quiet, Duration::ZERO)?
        }
        BoardAction::Commission => {
            c.send(&HostMessage::Commission { seed: a.seed })?;
            // Commissioning stores its result: the board erases its parameter sector
            // before it answers.
            follow_job(&mut c, a.quiet, ERASE_ALLOWANCE)?
        }
        BoardAction::Params => {
            let stored = c.request(&HostMessage::ReadParams, |reply| match reply {
                BoardMessage::Params(p) => Some(Ok(p)),
                other => refused(&other).map(|r| r.map(|_| Err(NotStored::Empty))),
            })?;
            match stored {
                Ok(r) => r,
                Err(why) => {
                    println!("{why}: the board commissions at its next power-up");
                    return Ok(());
                }
            }
        }
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
    };
    let report = BoardReport::new(&report)?;
    print!("{}", report.text());
    if let Some(path) = &a.json {
        write_json(path, &report)?;
    }
    Ok(())
}

#[cfg(test)]
#[path = "board_tests.rs"]
mod tests;
