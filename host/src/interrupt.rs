//! Ctrl-C, one handler for the whole program. A command that can stop its work cleanly (a
//! job on the board, the virtual commissioning that opens its bridge) takes the interrupt
//! with [`take_over`] and polls the flag it returns; every other command ends at once with
//! status 130, after removing the temporary files of the writes in progress
//! ([`crate::output`]), so that an interrupted run leaves no hidden file behind.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

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
    remove_temporary_files();
    eprintln!("motor-id: interrupted");
    std::process::exit(130);
}

fn remove_temporary_files() {
    let files = TEMPORARY.lock().unwrap_or_else(|e| e.into_inner());
    for f in files.iter() {
        let _ = std::fs::remove_file(f);
    }
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
    /// Register `path` (a temporary file the caller removes itself on every other exit).
    pub fn new(path: &Path) -> Registered {
        let mut files = TEMPORARY.lock().unwrap_or_else(|e| e.into_inner());
        files.push(path.to_path_buf());
        Registered(path.to_path_buf())
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        let mut files = TEMPORARY.lock().unwrap_or_else(|e| e.into_inner());
        if let Some(at) = files.iter().position(|f| *f == self.0) {
            files.swap_remove(at);
        }
    }
}
