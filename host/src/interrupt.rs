//! Ctrl-C, one handler for the whole program. A command that can stop its work cleanly (a
//! job on the board, the virtual commissioning that opens its bridge) takes the interrupt
//! with [`take_over`] and polls the flag it returns; every other command ends at once with
//! status 130, after removing the temporary files of the writes in progress
//! ([`crate::output`]), so that an interrupted run leaves no hidden file behind.

use std::io::IsTerminal;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Mutex, MutexGuard};

/// Set by Ctrl-C while a command has taken the interrupt over.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// Whether the running command handles Ctrl-C itself.
static TAKEN_OVER: AtomicBool = AtomicBool::new(false);
/// The temporary files being written now.
static TEMPORARY: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// Install the handler (at start-up). One that cannot be installed leaves Ctrl-C as it was.
pub fn install() {
    let _ = ctrlc::set_handler(on_ctrl_c);
}

fn on_ctrl_c() {
    if TAKEN_OVER.load(Ordering::SeqCst) {
        INTERRUPTED.store(true, Ordering::SeqCst);
        return;
    }
    // The list stays locked until the end: a write cannot register (or complete) a file
    // between its removal and the exit.
    let files = temporary_files();
    for f in files.iter() {
        let _ = std::fs::remove_file(f);
    }
    // On a terminal, the message replaces a progress bar's line instead of trailing it.
    let clear = if std::io::stderr().is_terminal() {
        "\r\x1b[2K"
    } else {
        ""
    };
    eprintln!("{clear}motor-id: interrupted");
    std::process::exit(130);
}

/// The list of temporary files, locked (a panic elsewhere does not lose it).
fn temporary_files() -> MutexGuard<'static, Vec<PathBuf>> {
    TEMPORARY.lock().unwrap_or_else(|e| e.into_inner())
}

/// From now on Ctrl-C sets the returned flag instead of ending the program: the caller
/// polls it, stops its work cleanly and ends (clearing the flag to wait for a second one).
pub fn take_over() -> &'static AtomicBool {
    TAKEN_OVER.store(true, Ordering::SeqCst);
    &INTERRUPTED
}

/// A temporary file removed by Ctrl-C while this lives.
pub struct Registered(PathBuf);

impl Registered {
    /// Make a temporary file with `create` and register it (`path` names it), Ctrl-C held
    /// off in between: an interrupt never finds the file made and not yet registered. The
    /// caller removes the file itself on every other exit.
    pub fn create<T, E>(
        create: impl FnOnce() -> Result<T, E>,
        path: impl FnOnce(&T) -> &Path,
    ) -> Result<(T, Registered), E> {
        let mut files = temporary_files();
        let made = create()?;
        let at = path(&made).to_path_buf();
        files.push(at.clone());
        Ok((made, Registered(at)))
    }

    /// Run `rename`, which gives the complete file its name, and unregister it, Ctrl-C held
    /// off meanwhile: an interrupt finds the file either temporary (and removes it) or
    /// complete under its name.
    pub fn complete<R>(self, rename: impl FnOnce() -> R) -> R {
        let mut files = temporary_files();
        let done = rename();
        files.retain(|f| *f != self.0);
        done
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        let mut files = temporary_files();
        if let Some(at) = files.iter().position(|f| *f == self.0) {
            files.swap_remove(at);
        }
    }
}
