//! Progress bars on stderr for long work: fits, a large file's reading, a long simulation
//! and its writing (hidden when stderr is not a terminal or with --quiet).

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use motor_id_shared::fit::identify::{Progress, Stage};
use motor_id_shared::wire::protocol::{BoardMessage, JobStage};

/// What the bar shows at one moment: its label, how far along its stage is, and a message.
#[derive(Clone, Debug, PartialEq)]
pub struct BarState {
    /// The stage's label (`FFO`, `refine`, `check`, `probe`, `experiment`).
    pub prefix: &'static str,
    /// Steps done in the stage.
    pub position: u64,
    /// Steps the stage runs at most: the bar's length, fixed for the stage (a position past it
    /// stretches it, so the bar never runs backwards).
    pub length: u64,
    /// What else to say (evaluations, best fitness).
    pub message: String,
}

impl BarState {
    /// The bar after one iteration of an identification.
    pub fn of(p: &Progress) -> BarState {
        BarState {
            prefix: match p.stage {
                Stage::Search => "FFO",
                Stage::Refine => "refine",
                Stage::Check => "check",
            },
            position: u64::from(p.iteration),
            length: u64::from(p.iterations.max(p.iteration).max(1)),
            message: format!("{} evaluations, best {:.5}", p.evaluations, p.best),
        }
    }
}

impl BarState {
    /// The bar a board's progress frame shows (`None` for other messages): the stage's
    /// position against the total the frame carries, so that the bar's length is the job's
    /// known length and does not grow frame by frame. The commissioning's probe and
    /// experiment count milliseconds of its time budget.
    pub fn of_board(frame: &BoardMessage) -> Option<BarState> {
        let &BoardMessage::Progress {
            stage,
            iteration,
            total,
            evaluations,
            best,
        } = frame
        else {
            return None;
        };
        let stage = match stage {
            JobStage::Probe | JobStage::Experiment => {
                return Some(BarState {
                    prefix: match stage {
                        JobStage::Probe => "probe",
                        _ => "experiment",
                    },
                    position: u64::from(iteration),
                    length: u64::from(total.max(iteration).max(1)),
                    message: String::from("ms of the time budget"),
                })
            }
            JobStage::Search => Stage::Search,
            JobStage::Refine => Stage::Refine,
            JobStage::Check => Stage::Check,
        };
        Some(BarState::of(&Progress {
            stage,
            iteration,
            iterations: total,
            evaluations,
            best,
        }))
    }
}

/// Files from this size on show their reading's progress [bytes]: 10 M rows of a record
/// CSV (some 400 MB) take minutes to read.
pub const READ_PROGRESS_BYTES: u64 = 32 << 20;

/// A bar of the bytes of `file` read (`len` in all), on stderr; hidden when `quiet` or
/// when the file is smaller than [`READ_PROGRESS_BYTES`].
pub fn read_progress(file: &str, len: u64, quiet: bool) -> ProgressBar {
    if quiet || len < READ_PROGRESS_BYTES {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(len), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("reading {prefix} [{bar:30}] {bytes}/{total_bytes}")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(file.to_string());
    bar
}

/// Records from this many samples on show their simulation's and their writing's progress
/// on stderr: a million rows take a second or more to write.
pub const WRITE_PROGRESS_SAMPLES: usize = 1_000_000;

/// A spinner on stderr while `n` samples are simulated; hidden when `quiet` or when `n` is
/// below [`WRITE_PROGRESS_SAMPLES`].
pub fn simulating(n: usize, quiet: bool) -> ProgressBar {
    if quiet || n < WRITE_PROGRESS_SAMPLES {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(n as u64), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("{spinner} simulating {len} samples")
            .expect("static template"),
    );
    bar.enable_steady_tick(std::time::Duration::from_millis(100));
    bar
}

/// A bar on stderr of the rows of `file` written (`n` in all); hidden when `quiet` or when
/// `n` is below [`WRITE_PROGRESS_SAMPLES`].
pub fn writing(file: &str, n: usize, quiet: bool) -> ProgressBar {
    if quiet || n < WRITE_PROGRESS_SAMPLES {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::with_draw_target(Some(n as u64), ProgressDrawTarget::stderr());
    bar.set_style(
        ProgressStyle::with_template("writing {prefix} [{bar:30}] {pos}/{len} rows")
            .expect("static template")
            .progress_chars("=> "),
    );
    bar.set_prefix(file.to_string());
    bar
}

/// A progress bar fed by the identification's progress callback.
pub struct FitProgress {
    bar: ProgressBar,
}

impl FitProgress {
    /// A bar; hidden when `quiet`.
    pub fn new(quiet: bool) -> FitProgress {
        let bar = ProgressBar::with_draw_target(
            Some(1),
            if quiet {
                ProgressDrawTarget::hidden()
            } else {
                ProgressDrawTarget::stderr()
            },
        );
        bar.set_style(
            ProgressStyle::with_template("{spinner} {prefix:>10} [{bar:30}] {pos}/{len} {msg}")
                .expect("static template")
                .progress_chars("=> "),
        );
        FitProgress { bar }
    }

    /// Report one iteration.
    pub fn update(&self, p: &Progress) {
        self.show(&BarState::of(p));
    }

    /// Show `s`.
    pub fn show(&self, s: &BarState) {
        self.bar.set_prefix(s.prefix);
        self.bar.set_length(s.length);
        self.bar.set_position(s.position);
        self.bar.set_message(s.message.clone());
    }

    /// Print a line on stderr without tearing the bar.
    pub fn println(&self, line: &str) {
        self.bar.suspend(|| eprintln!("{line}"));
    }

    /// Remove the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
