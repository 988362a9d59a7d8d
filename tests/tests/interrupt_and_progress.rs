//! Ctrl-C and progress on local long work (issue 22, items 3 and 7). A long `simulate`
//! shows its progress on stderr when that is a terminal (a pseudo-terminal here, as a
//! user's), never on stdout, and none with `-q`. Ctrl-C (SIGINT) while it writes its record
//! ends it with status 130 and one line, and leaves no file at all: neither its temporary
//! file nor a part of the record.
//!
//! The waits end on what the program writes (its progress, its exit), not on a time tuned
//! to the machine; [`HANG`] only guards against a program that never ends.

use motor_id_tests::{motor_id, s};
use serialport::{SerialPort, TTYPort};
use std::io::{ErrorKind, Read};
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

/// The longest any wait below may take before the test fails (a hang, not a slow machine).
const HANG: Duration = Duration::from_secs(600);

/// `motor-id ARGS` with its stderr on a pseudo-terminal and its stdout on a pipe.
struct OnATerminal {
    child: Child,
    /// The terminal's side the test reads.
    master: TTYPort,
    /// The program's side, held open until the test has read everything (a terminal whose
    /// every slave closed may drop what is left unread).
    _slave: TTYPort,
    /// What the program wrote to its stderr so far (escape codes included).
    seen: Vec<u8>,
    started: Instant,
}

impl OnATerminal {
    fn start(args: &[&str]) -> OnATerminal {
        let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
        master.set_timeout(Duration::from_millis(50)).unwrap();
        let path = slave.name().expect("the slave's path");
        let stderr = std::fs::OpenOptions::new()
            .read(true)
            .write(true)
            .open(&path)
            .expect("open the pseudo-terminal");
        let child = Command::new(motor_id())
            .args(args)
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(stderr)
            .spawn()
            .expect("start motor-id");
        OnATerminal {
            child,
            master,
            _slave: slave,
            seen: Vec::new(),
            started: Instant::now(),
        }
    }

    /// The terminal's text so far.
    fn text(&self) -> String {
        String::from_utf8_lossy(&self.seen).into_owned()
    }

    /// Read the terminal until `until` holds of its text (true) or the program has ended and
    /// everything it wrote is read (false).
    fn read_until(&mut self, until: impl Fn(&str) -> bool) -> bool {
        let mut buf = [0u8; 4096];
        loop {
            let ended = self.child.try_wait().expect("wait for motor-id").is_some();
            match self.master.read(&mut buf) {
                Ok(n) => self.seen.extend_from_slice(&buf[..n]),
                // Nothing for 50 ms: once the program has ended, that is all of it.
                Err(e) if e.kind() == ErrorKind::TimedOut && ended => return false,
                Err(e) if e.kind() == ErrorKind::TimedOut => {}
                Err(e) => panic!("reading the terminal: {e}"),
            }
            if until(&self.text()) {
                return true;
            }
            if self.started.elapsed() > HANG {
                let _ = self.child.kill();
                panic!("motor-id still runs after {HANG:?}: {}", self.text());
            }
        }
    }

    /// Wait for the end: the exit status, and what went to stdout.
    fn finish(mut self) -> (ExitStatus, String, String) {
        self.read_until(|_| false);
        let status = self.child.wait().expect("wait for motor-id");
        let mut stdout = String::new();
        self.child
            .stdout
            .take()
            .expect("stdout piped")
            .read_to_string(&mut stdout)
            .unwrap();
        (status, stdout, self.text())
    }
}

/// The names in `dir`, hidden ones included.
fn names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn ctrl_c_while_simulate_writes_ends_it_with_130_and_leaves_no_file() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("long.csv");
    // 20 M samples (the most `simulate` writes): seconds of writing, interrupted once its
    // bar shows.
    let mut run = OnATerminal::start(&[
        "simulate",
        "--rate",
        "100000",
        "--duration",
        "200",
        "--out",
        s(&out),
    ]);
    assert!(
        run.read_until(|text| text.contains("writing ")),
        "simulate showed no progress while it wrote: {}",
        run.text()
    );
    // The bar shows once the temporary file exists: it is there now, and only it.
    let before = names(dir.path());
    assert!(
        before.len() == 1 && before[0].starts_with(".motor-id-"),
        "{before:?}"
    );
    let pid = run.child.id().to_string();
    let kill = Command::new("kill").args(["-INT", &pid]).status().unwrap();
    assert!(kill.success());
    let (status, stdout, stderr) = run.finish();
    assert_eq!(status.code(), Some(130), "{stderr}");
    assert!(stderr.contains("motor-id: interrupted"), "{stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stdout, "", "progress or messages on stdout");
    assert_eq!(
        names(dir.path()),
        Vec::<String>::new(),
        "an interrupted simulate left a file"
    );
}

#[test]
fn progress_goes_to_stderr_never_stdout_and_quiet_silences_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("r.csv");
    // 1 M samples: the least that shows its progress.
    let args = [
        "simulate",
        "--rate",
        "10000",
        "--duration",
        "100",
        "--out",
        s(&out),
    ];
    let (status, stdout, stderr) = OnATerminal::start(&args).finish();
    assert!(status.success(), "{stderr}");
    assert!(stderr.contains("writing "), "no progress: {stderr}");
    assert!(stderr.contains("wrote 1000000 samples"), "{stderr}");
    assert_eq!(stdout, "", "progress or messages on stdout");
    let quiet: Vec<&str> = args.iter().copied().chain(["-q"]).collect();
    let (status, stdout, stderr) = OnATerminal::start(&quiet).finish();
    assert!(status.success(), "{stderr}");
    assert_eq!(stderr, "", "-q and still something on stderr");
    assert_eq!(stdout, "");
    assert_eq!(names(dir.path()), ["r.csv"]);
}
