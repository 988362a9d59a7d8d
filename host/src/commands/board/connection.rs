//! The host's end of a board link: a serial connection speaking the frames of
//! `motor_id_shared::wire::frame`, with requests repeated on silence, a busy board waited
//! for, a long job followed with its progress, and Ctrl-C turned into the board's abort.

use crate::progress::{BarState, FitProgress};
use crate::report::board::plan_text;
use anyhow::{anyhow, bail, Context, Result};
use motor_id_shared::wire::frame::{encode, Decoder, MAX_FRAME};
use motor_id_shared::wire::protocol::{
    BoardMessage, HostMessage, MotorReport, Plan, Refusal, PROTOCOL_VERSION,
};
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

/// A serial connection speaking frames.
pub struct Connection {
    port: Box<dyn serialport::SerialPort>,
    decoder: Decoder,
    /// Bytes read from the port and not yet decoded.
    unread: VecDeque<u8>,
    /// How long each reply is waited for.
    pub timeout: Duration,
}

impl Connection {
    /// Open `port` at `baud`, each reply waited for `timeout`.
    pub fn open(port: &str, baud: u32, timeout: Duration) -> Result<Connection> {
        let handle = serialport::new(port, baud)
            .timeout(Duration::from_millis(20))
            .open()
            .with_context(|| format!("cannot open serial port {port}"))?;
        Ok(Connection {
            port: handle,
            decoder: Decoder::new(),
            unread: VecDeque::new(),
            timeout,
        })
    }

    /// Send one message.
    pub fn send(&mut self, msg: &HostMessage) -> Result<()> {
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
            if crate::interrupt::take_over().swap(false, Ordering::SeqCst) {
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
    pub fn request<T>(
        &mut self,
        msg: &HostMessage,
        accept: impl FnMut(BoardMessage) -> Option<Result<T>>,
    ) -> Result<T> {
        self.request_every(msg, self.timeout, 3, accept)
    }

    /// As [`Connection::request`], waiting `every` for each reply and sending the request
    /// up to `tries` times.
    pub fn request_every<T>(
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

/// How often `Hello`, the first request on a port just opened, is repeated while nothing
/// comes back.
const HELLO_EVERY: Duration = Duration::from_millis(500);

/// A board's erase of its parameter sector stalls it (no reply, no progress) for up to 4 s
/// (docs/CONTRACTS.md): a reply that follows one (a commissioning's result, which it
/// stores; the answer to `clear`) is waited for this much longer than `--timeout`.
pub const ERASE_ALLOWANCE: Duration = Duration::from_secs(5);

/// How many `--timeout`s a busy board is waited for.
const BUSY_TIMEOUTS: u32 = 6;

pub fn refused(reply: &BoardMessage) -> Option<Result<()>> {
    match reply {
        BoardMessage::Refused(r) => Some(Err(anyhow!("the board refused: {r}"))),
        _ => None,
    }
}

pub fn hello(c: &mut Connection) -> Result<u32> {
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
/// after each frame for a job that stores its result ([`ERASE_ALLOWANCE`]). The report, and
/// the plan of a commissioning.
pub fn follow_job(
    c: &mut Connection,
    quiet: bool,
    allowance: Duration,
) -> Result<(MotorReport, Option<Plan>)> {
    let bar = FitProgress::new(quiet);
    let wait = c.timeout + allowance;
    // The clock restarts only when a progress frame shows the job advancing: a board that
    // repeats itself, or sends frames that belong to no job, is timed out like a silent one.
    let mut deadline = Instant::now() + wait;
    let mut last = None;
    let mut planned = None;
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
            Ok(BoardMessage::Identified(report)) => break Ok((report, planned)),
            Ok(BoardMessage::Planned(plan)) => {
                if !quiet {
                    bar.println(&plan_text(&plan));
                }
                planned = Some(plan);
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

/// From now on Ctrl-C while a job runs aborts it on the board (see `abort`) and ends the
/// command ([`crate::interrupt`]).
pub fn listen_for_ctrl_c() {
    crate::interrupt::take_over();
}

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
