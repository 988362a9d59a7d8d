//! The firmware in QEMU (netduinoplus2), driven through the host exactly as a board:
//! `motor-id board --port <pty> ...`, plus raw frames for abort and link faults.

use motor_id_shared::wire::frame::{encode, Decoder, MAX_FRAME};
use motor_id_shared::wire::protocol::{
    BoardMessage, HostMessage, PipelineName, Refusal, CHUNK, PROTOCOL_VERSION,
};
use motor_id_tests::{
    assert_within_3_percent, board_record, json, run, run_err, run_ok, s, Qemu, PAPER_WITH_FRICTION,
};
use std::io::{Read, Write};
use std::time::Duration;

#[test]
fn hello_and_version() {
    let q = Qemu::start();
    let out = run_ok(&q.board_args(&["hello"]));
    assert!(
        out.contains(&format!("protocol version {PROTOCOL_VERSION}")),
        "{out}"
    );
}

#[test]
fn board_identify_is_bit_identical_to_host_identify() {
    let q = Qemu::start();
    let dir = tempfile::tempdir().unwrap();
    let csv = board_record(dir.path());
    for pipeline in ["default", "board"] {
        let board = dir.path().join(format!("board-{pipeline}.json"));
        let host = dir.path().join(format!("host-{pipeline}.json"));
        let mut board_args = q.board_args(&["--seed", "5"]);
        board_args.extend(["--json", s(&board), "-q", "identify", s(&csv)]);
        // The default pipeline is the default on both sides.
        if pipeline != "default" {
            board_args.extend(["--pipeline", pipeline]);
        }
        run_ok(&board_args);
        let mut host_args = vec!["identify", s(&csv), "--seed", "5", "--json", s(&host), "-q"];
        if pipeline != "default" {
            host_args.extend(["--pipeline", pipeline]);
        }
        run_ok(&host_args);
        let (b, h) = (json(&board), json(&host));
        assert_eq!(h["mode"], pipeline);
        assert_eq!(
            b["params"], h["params"],
            "{pipeline}: board {b} vs host {h}"
        );
        assert_eq!(b["rmse_omega"], h["rmse_omega"], "{pipeline}");
        assert_eq!(b["evaluations"], h["evaluations"], "{pipeline}");
    }
    // The paper-faithful population does not fit the board's memory: a typed refusal, one
    // line, non-zero exit, and the board goes on answering.
    let err = run_err(&q.board_args(&["-q", "identify", s(&csv), "--pipeline", "paper"]));
    assert!(
        err.contains(&Refusal::PipelineTooLarge.to_string()),
        "{err}"
    );
    run_ok(&q.board_args(&["hello"]));
}

/// The QEMU build's default plant is the paper's motor with Coulomb friction
/// ([`PAPER_WITH_FRICTION`]), which commissioning identifies from its coast-down.
fn assert_paper_motor(r: &serde_json::Value) {
    assert_within_3_percent(r, &PAPER_WITH_FRICTION);
}

#[test]
fn first_power_up_commissions_and_the_host_commissions_again_after_clear() {
    let q = Qemu::start();
    let dir = tempfile::tempdir().unwrap();
    let (boot, again) = (dir.path().join("boot.json"), dir.path().join("again.json"));
    // Power-up found no parameters and commissioned the plant by itself (the host waits
    // while the board is busy).
    run_ok(&q.board_args(&["--json", s(&boot), "params"]));
    assert_paper_motor(&json(&boot));
    run_ok(&q.board_args(&["clear"]));
    // Nothing stored: the earlier report is removed, never left to be read as the board's.
    let out = run_ok(&q.board_args(&["--json", s(&boot), "params"]));
    assert!(out.contains("no parameters stored"), "{out}");
    assert!(!boot.exists(), "a stale report was left");
    run_ok(&q.board_args(&["--json", s(&again), "-q", "commission"]));
    let r = json(&again);
    assert_paper_motor(&r);
    assert_eq!(r["identifiability"]["rank"], 6, "{r}");
    assert_eq!(r["identifiability"]["free"], 6, "{r}");
    assert_eq!(
        r["identifiability"]["parameters"]["tc"]["pinned"], true,
        "{r}"
    );
    let stored = run_ok(&q.board_args(&["params"]));
    assert!(stored.contains("rmse_omega"), "{stored}");
}

/// A raw framed connection, for what the CLI does not do on purpose. Its waits count in
/// QEMU's processor time ([`Qemu::within_work`]).
struct Raw<'q> {
    qemu: &'q Qemu,
    port: Box<dyn serialport::SerialPort>,
    decoder: Decoder,
    /// Bytes read and not decoded yet (one read may bring several frames).
    unread: std::collections::VecDeque<u8>,
}

impl Raw<'_> {
    fn open(qemu: &Qemu) -> Raw<'_> {
        let port = serialport::new(&qemu.pty, 115_200)
            .timeout(Duration::from_millis(20))
            .open()
            .unwrap();
        Raw {
            qemu,
            port,
            decoder: Decoder::new(),
            unread: Default::default(),
        }
    }
    fn bytes(&mut self, b: &[u8]) {
        self.port.write_all(b).unwrap();
    }
    fn send(&mut self, msg: &HostMessage) {
        let mut out = [0u8; MAX_FRAME];
        let frame = encode(msg, &mut out).unwrap().to_vec();
        self.bytes(&frame);
    }
    /// The next message, unless QEMU works `within` of processor time without one.
    fn receive(&mut self, within: Duration) -> Option<BoardMessage> {
        let mut buf = [0u8; 64];
        let mut got = None;
        let qemu = self.qemu;
        qemu.within_work(within, || {
            while let Some(b) = self.unread.pop_front() {
                if let Some(Ok(m)) = self.decoder.push::<BoardMessage>(b) {
                    got = Some(m);
                    return false;
                }
            }
            if let Ok(n) = self.port.read(&mut buf) {
                self.unread.extend(&buf[..n]);
            }
            true
        });
        got
    }
    /// Hello, asked again while the board is busy (commissioning at power-up) or when no
    /// answer comes (bytes that arrive before the firmware enables its USART are lost, as on
    /// a board); the reply.
    fn hello(&mut self) -> Option<BoardMessage> {
        let (qemu, start) = (self.qemu, self.qemu.cpu_time());
        while qemu.cpu_time() - start < Duration::from_secs(60) {
            self.send(&HostMessage::Hello {
                version: PROTOCOL_VERSION,
            });
            loop {
                match self.receive(Duration::from_secs(5)) {
                    // The end of power-up commissioning may still be on its way.
                    Some(
                        BoardMessage::Progress { .. }
                        | BoardMessage::Planned(_)
                        | BoardMessage::Identified(_),
                    ) => {}
                    Some(BoardMessage::Refused(Refusal::Busy)) => {
                        std::thread::sleep(Duration::from_millis(200));
                        break;
                    }
                    None => break,
                    other => return other,
                }
            }
        }
        None
    }
}

#[test]
fn abort_mid_identification_and_the_board_answers_again() {
    let q = Qemu::start();
    let dir = tempfile::tempdir().unwrap();
    let csv = board_record(dir.path());
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut rows: Vec<Vec<f32>> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    // A 10 rad/s square wave on the speed, which no motor model fits: the fit stays above
    // the noise and escalates to its longer searches, a job long enough to abort (the clean
    // record is fitted in 14 evaluations, before an abort could arrive).
    for (k, row) in rows.iter_mut().enumerate() {
        if (k / 100) % 2 == 1 {
            row[2] += 10.0;
        }
    }
    let mut raw = Raw::open(&q);
    assert!(matches!(raw.hello(), Some(BoardMessage::Hello { .. })));
    raw.send(&HostMessage::IdentifyBegin {
        dt: 0.01,
        samples: rows.len() as u32,
        with_current: true,
        coast_from: None,
    });
    assert_eq!(
        raw.receive(Duration::from_secs(5)),
        Some(BoardMessage::ChunkOk { next: 0 })
    );
    for start in (0..rows.len()).step_by(CHUNK) {
        let end = (start + CHUNK).min(rows.len());
        let col = |c: usize| heapless::Vec::from_iter(rows[start..end].iter().map(|r| r[c]));
        raw.send(&HostMessage::RecordChunk {
            offset: start as u32,
            v: col(1),
            omega: col(2),
            current: col(3),
        });
        assert_eq!(
            raw.receive(Duration::from_secs(5)),
            Some(BoardMessage::ChunkOk { next: end as u32 })
        );
    }
    raw.send(&HostMessage::Identify {
        seed: 1,
        pipeline: PipelineName::Default,
    });
    assert!(matches!(
        raw.receive(Duration::from_secs(10)),
        Some(BoardMessage::Progress { .. })
    ));
    raw.send(&HostMessage::Abort);
    let mut saw_abort = false;
    for _ in 0..400 {
        match raw.receive(Duration::from_secs(10)) {
            Some(BoardMessage::Aborted) => {
                saw_abort = true;
                break;
            }
            Some(BoardMessage::Progress { .. }) => {}
            other => panic!("expected Aborted, got {other:?}"),
        }
    }
    assert!(saw_abort);
    assert!(matches!(raw.hello(), Some(BoardMessage::Hello { .. })));
}

#[test]
fn garbage_corrupted_and_dropped_bytes_are_survived() {
    let q = Qemu::start();
    let mut raw = Raw::open(&q);
    let first = raw.hello();
    assert!(
        matches!(first, Some(BoardMessage::Hello { .. })),
        "{first:?}"
    );
    // Garbage, then a frame with a flipped byte, then one with a byte dropped: no answer.
    raw.bytes(&[0x55, 0xAA, 0x13, 0x00, 0xFF, 0xFF]);
    let mut out = [0u8; MAX_FRAME];
    let good = encode(
        &HostMessage::Hello {
            version: PROTOCOL_VERSION,
        },
        &mut out,
    )
    .unwrap()
    .to_vec();
    let mut flipped = good.clone();
    flipped[1] ^= 0x10;
    raw.bytes(&flipped);
    let mut dropped = good.clone();
    dropped.remove(1);
    raw.bytes(&dropped);
    assert_eq!(raw.receive(Duration::from_millis(500)), None);
    // The next good frame is answered.
    assert!(matches!(raw.hello(), Some(BoardMessage::Hello { .. })));
    // A version mismatch is refused politely.
    raw.send(&HostMessage::Hello {
        version: PROTOCOL_VERSION + 1,
    });
    assert_eq!(
        raw.receive(Duration::from_secs(5)),
        Some(BoardMessage::Refused(Refusal::VersionMismatch {
            board: PROTOCOL_VERSION
        }))
    );
    // And the CLI copes with a board that never answers: one line, non-zero exit, no hang.
    drop(raw);
    drop(q);
    let dir = tempfile::tempdir().unwrap();
    let fake = dir.path().join("not-a-port");
    let out = run(&["board", "--port", s(&fake), "--timeout", "1", "hello"]);
    assert!(!out.status.success());
    assert_eq!(
        String::from_utf8_lossy(&out.stderr)
            .trim_end()
            .lines()
            .count(),
        1
    );
}
